"""The format x attribute table of docs/reliability.md ("What each format holds"), one test
per cell: every attribute a mesh carries is written natively, or left out with a
DataLossWarning -- never silently (issue 18, item 3)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from conftest import shared_mesh
from lodkit.errors import DataLossWarning
from lodkit.geometry import weld_positions
from lodkit.io import CARRIES, SUPPORTED_FORMATS, load, save
from lodkit.mesh import Mesh
from lodkit.topology import topology

# (format, attribute) -> what save() does with it; the table in docs/reliability.md
TABLE = {
    "ply": {"normals": "native", "colors": "native", "alpha": "native", "uvs": "native"},
    "obj": {"normals": "native", "colors": "native", "alpha": "warned", "uvs": "native"},
    "off": {"normals": "native", "colors": "native", "alpha": "native", "uvs": "native"},
    "stl": {"normals": "warned", "colors": "warned", "alpha": "warned", "uvs": "warned"},
    "glb": {"normals": "native", "colors": "native", "alpha": "native", "uvs": "native"},
    "gltf": {"normals": "native", "colors": "native", "alpha": "native", "uvs": "native"},
}
# how close a written attribute comes back (colours: 8-bit in PLY)
TOL = {"ply": {"colors": 0.5 / 255 + 1e-9}, "obj": {}, "off": {}, "glb": {}, "gltf": {}}


def seamed_box() -> Mesh:
    """A closed octahedron cut open along a uv seam: vertex 6 is a copy of vertex 0 with
    another uv (as a uv-mapped mesh is loaded), so the positions are closed, the vertices not."""
    v = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1], [1, 0, 0]], float)
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 6, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [6, 3, 5]])
    rng = np.random.default_rng(5)
    n = v / np.linalg.norm(v, axis=1, keepdims=True)
    return Mesh(v, f, normals=n, colors=rng.random((7, 4)), uvs=rng.random((7, 2)))


def only(mesh: Mesh, attribute: str) -> Mesh:
    kw = {"normals": None, "colors": None, "uvs": None}
    if attribute == "alpha":
        kw["colors"] = mesh.colors
    elif attribute == "colors":
        kw["colors"] = mesh.colors[:, :3]
    else:
        kw[attribute] = getattr(mesh, attribute)
    return Mesh(mesh.vertices, mesh.faces, **kw)


def test_table_matches_what_save_declares():
    for fmt in SUPPORTED_FORMATS:
        native = {a for a, how in TABLE[fmt].items() if how == "native"}
        assert native == CARRIES[fmt], fmt


@pytest.mark.parametrize("attribute", ["normals", "colors", "alpha", "uvs"])
@pytest.mark.parametrize("fmt", SUPPORTED_FORMATS)
def test_cell(tmp_path, fmt, attribute):
    mesh = only(seamed_box(), attribute)
    path = tmp_path / f"m.{fmt}"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        save(mesh, path)
    lost = [w for w in caught if issubclass(w.category, DataLossWarning)]
    how = TABLE[fmt][attribute]
    assert bool(lost) == (how == "warned"), [str(w.message) for w in caught]
    loaded = load(path)
    name = "colors" if attribute == "alpha" else attribute
    if how == "warned":
        assert str(path) in str(lost[0].message) and attribute in str(lost[0].message)
        if attribute == "alpha" and fmt == "obj":              # RGB still written
            def rows(m, c):
                t = np.concatenate([m.vertices, c], axis=1)
                return t[np.lexsort(t.T[::-1])]
            np.testing.assert_allclose(rows(loaded, loaded.colors), rows(mesh, mesh.colors[:, :3]), atol=1e-6)
        else:
            assert getattr(loaded, name) is None
        return
    got = getattr(loaded, name)
    assert got is not None, f"{fmt} lost {attribute}"
    # match vertices by position and attribute (the OBJ reader renumbers)
    want = getattr(mesh, name)
    tol = TOL[fmt].get(name, 1e-6)
    assert got.shape == want.shape
    for i in range(loaded.n_vertices):
        d = np.linalg.norm(mesh.vertices - loaded.vertices[i], axis=1)
        cands = np.flatnonzero(d < 1e-6)
        assert any(np.abs(want[j] - got[i]).max() <= tol for j in cands), (fmt, attribute, i)


@pytest.mark.parametrize("fmt", SUPPORTED_FORMATS)
def test_seams_survive_every_format_as_a_closed_shape(tmp_path, fmt):
    mesh = seamed_box()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataLossWarning)
        save(mesh, tmp_path / f"m.{fmt}")
    loaded = load(tmp_path / f"m.{fmt}")
    positions, faces = weld_positions(loaded.vertices, loaded.faces)
    report = topology(Mesh(positions, faces))
    assert report.n_components == 1 and report.is_closed and report.genus == 0
    # where uvs are written, the seam copy (two uvs at one position) is kept
    assert loaded.n_vertices == (6 if fmt == "stl" else 7)


@pytest.mark.parametrize("fmt", SUPPORTED_FORMATS)
def test_spot_simplified_keeps_its_uvs_and_one_closed_component(tmp_path, fmt):
    """The issue's case: spot simplified to PLY came out as 13 components with split seams."""
    pytest.importorskip("lodkit._core.decimate")
    from lodkit import simplify

    spot = load(shared_mesh("spot_triangulated.obj"))
    result = simplify(spot, target_ratio=0.2)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        save(result.mesh, tmp_path / f"out.{fmt}")
    assert any(issubclass(w.category, DataLossWarning) for w in caught) == (fmt == "stl")
    loaded = load(tmp_path / f"out.{fmt}")
    assert (loaded.uvs is not None) == (fmt != "stl")
    positions, faces = weld_positions(loaded.vertices, loaded.faces)
    report = topology(Mesh(positions, faces))
    assert (report.n_components, report.is_closed, report.genus) == (1, True, 0)
    assert report.n_boundary_edges == 0


def test_cli_prints_the_data_loss_warning_as_one_line(tmp_path, capsys):
    pytest.importorskip("lodkit._core.decimate")
    from lodkit.cli import main

    save(seamed_box(), tmp_path / "in.ply")
    assert main(["simplify", str(tmp_path / "in.ply"), str(tmp_path / "out.stl"), "--ratio", "0.9"]) == 0
    err = capsys.readouterr().err
    assert "lodkit: warning: saving" in err and "STL cannot hold the mesh's normals, colors, uvs" in err
    assert "save(" not in err
