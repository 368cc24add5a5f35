"""lodkit.demo: the generated demo surface, and run_demo()."""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from lodkit.demo import demo_mesh, format_table, run_demo
from lodkit.errors import OptionError
from lodkit.topology import topology


def _simplify_available() -> bool:
    try:
        import lodkit._core.decimate  # noqa: F401
        from lodkit.api import simplify  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.mark.parametrize("n_faces", [200, 2000, 20_000, 100_000])
def test_about_the_requested_number_of_faces(n_faces):
    mesh = demo_mesh(n_faces)
    assert abs(mesh.n_faces - n_faces) <= 0.05 * n_faces
    assert mesh.faces.dtype == np.int32 and mesh.vertices.dtype == np.float64


def test_default_size_is_100k():
    assert demo_mesh().n_faces == pytest.approx(100_000, rel=0.01)


def test_open_manifold_surface_with_one_boundary_loop():
    r = topology(demo_mesh(20_000))
    assert r.is_manifold and r.is_oriented
    assert not r.is_closed and r.n_boundary_loops == 1
    assert r.n_components == 1 and r.genus == 0


def test_faces_point_up_and_normals_are_unit():
    mesh = demo_mesh(5000)
    assert (mesh.face_normals()[:, 2] > 0).all()     # a height field, counter-clockwise from above
    assert np.allclose(np.linalg.norm(mesh.normals, axis=1), 1.0)
    assert (mesh.normals[:, 2] > 0).all()


def test_has_sharp_creases_and_fine_detail():
    mesh = demo_mesh(20_000)
    fn = mesh.face_normals()
    f = mesh.faces.astype(np.int64)
    # dihedral angles across interior edges
    tail, head = f.reshape(-1), f[:, [1, 2, 0]].reshape(-1)
    key = np.minimum(tail, head) * mesh.n_vertices + np.maximum(tail, head)
    order = np.argsort(key, kind="stable")
    same = key[order][1:] == key[order][:-1]
    pairs = np.stack([order[:-1][same], order[1:][same]], axis=1) // 3
    cos = np.einsum("ij,ij->i", fn[pairs[:, 0]], fn[pairs[:, 1]])
    angles = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    assert (angles > 30).sum() > 300                 # creases: pyramid ridges and base, step, roof ridge
    assert np.median(angles) < 8                     # ... on an otherwise gently curved surface

    # fine detail: away from every feature (x, y < -0.6) only the broad swell and the small
    # bumps remain; the swell alone would give a discrete Laplacian 40x smaller than this
    nx = np.unique(mesh.vertices[:, 0]).size
    z = mesh.vertices[:, 2].reshape(-1, nx)
    lap = z[1:-1, :-2] + z[1:-1, 2:] + z[:-2, 1:-1] + z[2:, 1:-1] - 4 * z[1:-1, 1:-1]
    x = mesh.vertices[:, 0].reshape(-1, nx)[1:-1, 1:-1]
    y = mesh.vertices[:, 1].reshape(-1, nx)[1:-1, 1:-1]
    corner = (x < -0.6) & (y < -0.6)
    assert np.abs(lap[corner]).mean() > 1e-3


def test_colours_vary():
    mesh = demo_mesh(5000)
    assert mesh.colors.shape == (mesh.n_vertices, 3)
    assert mesh.colors.min() >= 0 and mesh.colors.max() <= 1
    assert np.unique(mesh.colors.round(3), axis=0).shape[0] > 500


def test_deterministic():
    a, b = demo_mesh(3000), demo_mesh(3000)
    for name in ("vertices", "faces", "normals", "colors"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


@pytest.mark.parametrize("bad", [0, 7, -5, 2.5, "100", True])
def test_rejects_bad_sizes(bad):
    with pytest.raises(OptionError):
        demo_mesh(bad)


def test_format_table_aligns_columns():
    rows = [dict(level=0, ratio=1.0, faces=1000, vertices=600, error=None, seconds=0.01,
                 stop_reason="original", file="/x/demo_lod0.ply"),
            dict(level=1, ratio=0.5, faces=500, vertices=300, error=1.5e-3, seconds=0.2,
                 stop_reason="target_faces", file="/x/demo_lod1.ply")]
    lines = format_table(rows).splitlines()
    assert lines[0].split()[:4] == ["level", "ratio", "faces", "vertices"]
    assert set(lines[1]) <= {"-", " "}
    assert lines[2].split()[4] == "-" and lines[3].split()[4] == "1.50e-03"
    assert lines[3].endswith("demo_lod1.ply")
    assert lines[2].index("1000") + 4 == lines[3].index("500") + 3    # numbers right-aligned


@pytest.mark.skipif(not _simplify_available(), reason="lodkit.simplify or its Cython core is not built yet")
def test_run_demo_writes_one_file_per_level(tmp_path):
    import lodkit

    stream = io.StringIO()
    rows = run_demo(tmp_path / "out", ratios=(0.5, 0.1), stream=stream, n_faces=4000, picture=False)
    assert [r["level"] for r in rows] == [0, 1, 2]
    assert rows[0]["faces"] == demo_mesh(4000).n_faces
    for row, ratio in zip(rows[1:], (0.5, 0.1)):
        assert row["faces"] == pytest.approx(ratio * rows[0]["faces"], abs=2)
        assert row["error"] >= 0 and row["stop_reason"] == "target_faces"
        loaded = lodkit.load(row["file"])
        assert loaded.n_faces == row["faces"] and loaded.colors is not None
    text = stream.getvalue()
    assert "stop reason" in text and "demo_lod2.ply" in text


def test_run_demo_rejects_bad_ratios(tmp_path):
    with pytest.raises(OptionError):
        run_demo(tmp_path, ratios=(0.5, 1.5), stream=io.StringIO(), n_faces=200)


@pytest.mark.skipif(not _simplify_available(), reason="lodkit.simplify or its Cython core is not built yet")
def test_run_demo_writes_a_picture_of_the_levels(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    import matplotlib.image

    from lodkit.demo import SHEET_NAME
    from lodkit.viz import annotated_sheet

    monkeypatch.setenv("LODKIT_RENDER_BACKEND", "numpy")
    stream = io.StringIO()
    run_demo(tmp_path, ratios=(0.5, 0.1), stream=stream, n_faces=2000, image_size=(120, 90))
    path = tmp_path / SHEET_NAME
    assert f"picture of the levels: {path}" in stream.getvalue()
    img = matplotlib.image.imread(path)
    # three pictures of 120 x 90 in a row, a title over each and one label line under it
    blank = [np.zeros((90, 120, 3), np.uint8)] * 3
    like = annotated_sheet([blank], labels=[["x"] * 3], col_titles=["t"] * 3)
    assert img.shape[:2] == like.shape[:2]
    assert img.shape[1] > 3 * 120 and 90 < img.shape[0] < 90 + 120
    rgb = img[..., :3]
    assert len(np.unique(rgb.reshape(-1, 3), axis=0)) > 50           # shaded meshes, not blank


@pytest.mark.skipif(not _simplify_available(), reason="lodkit.simplify or its Cython core is not built yet")
def test_run_demo_says_why_when_it_cannot_draw(tmp_path, monkeypatch):
    import lodkit.viz
    from lodkit.demo import SHEET_NAME
    from lodkit.errors import RenderError

    def cannot(*args, **kwargs):
        raise RenderError("no renderer here")

    monkeypatch.setattr(lodkit.viz, "render", cannot)
    stream = io.StringIO()
    rows = run_demo(tmp_path, ratios=(0.5,), stream=stream, n_faces=500)
    assert "lodkit demo: no picture of the levels (RenderError: no renderer here)" in stream.getvalue()
    assert not (tmp_path / SHEET_NAME).exists()
    assert [r["level"] for r in rows] == [0, 1] and all(Path(r["file"]).is_file() for r in rows)


def test_annotated_sheet_without_matplotlib_uses_the_pixel_font(monkeypatch):
    import sys

    from lodkit.viz import annotated_sheet, contact_sheet

    monkeypatch.setitem(sys.modules, "matplotlib", None)
    a = np.full((20, 30, 3), 128, np.uint8)
    sheet = annotated_sheet([[a, a]], labels=[["10 faces", "5 faces"]], col_titles=["A", "B"])
    expected = contact_sheet([[a, a]], 10, labels=[["A 10 faces", "B 5 faces"]], label_scale=1)
    np.testing.assert_array_equal(sheet, expected)
