"""Any mesh type in, the same type out (lodkit.adapters): one test per input type, each
round-tripping the attributes that type carries through simplify and checking the type of
what comes back; then the other entry points take every type too."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

import lodkit
from lodkit.adapters import coerce, to_mesh
from lodkit.errors import MeshError


def _grid(n: int = 10, colors=True, uvs=True, normals=True) -> lodkit.Mesh:
    """An open, gently bumped square grid with per-vertex normals, colours (multiples of
    1/255, so 8-bit colour types hold them exactly) and uvs."""
    xs = np.linspace(0.0, 1.0, n + 1)
    x, y = np.meshgrid(xs, xs, indexing="ij")
    z = 0.1 * np.sin(3.0 * x) * np.cos(2.0 * y)
    V = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    F = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    rng = np.random.default_rng(7)
    N = np.column_stack([-0.3 * np.cos(3.0 * x.ravel()), 0.2 * np.sin(2.0 * y.ravel()), np.ones(V.shape[0])])
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    C = rng.integers(0, 256, size=(V.shape[0], 3)) / 255.0
    return lodkit.Mesh(V, F, normals=N if normals else None, colors=C if colors else None,
                       uvs=V[:, :2].copy() if uvs else None)


def _check(obj, source: lodkit.Mesh, names, vtol=1e-12):
    """simplify(obj) returns obj's type; with no collapse (ratio 1) the result's attributes
    are the input's at vertex_map; with collapses they are there, one row per vertex."""
    full = lodkit.simplify(obj, target_ratio=1.0)
    assert type(full.mesh) is type(obj)
    back = to_mesh(full.mesh)
    assert back.n_faces == source.n_faces
    np.testing.assert_allclose(back.vertices, source.vertices[full.vertex_map], atol=vtol)
    assert sorted(back.attributes()) == sorted(names)
    for name in names:
        np.testing.assert_allclose(getattr(back, name), getattr(source, name)[full.vertex_map], atol=1e-6,
                                   err_msg=name)
    half = lodkit.simplify(obj, target_ratio=0.3)
    assert type(half.mesh) is type(obj)
    small = to_mesh(half.mesh)
    assert small.n_faces <= int(round(0.3 * source.n_faces)) + 1
    assert sorted(small.attributes()) == sorted(names)
    return full.mesh, half.mesh


def test_lodkit_mesh():
    src = _grid()
    out, _ = _check(src, src, ["normals", "colors", "uvs"])
    assert isinstance(out, lodkit.Mesh)


def test_open3d_legacy():
    pytest.importorskip("open3d")
    src = _grid()
    out, _ = _check(src.to_open3d(), src, ["normals", "colors", "uvs"])
    assert out.has_triangle_uvs() and out.has_vertex_colors() and out.has_vertex_normals()


def test_open3d_tensor():
    o3d = pytest.importorskip("open3d")
    src = _grid()
    t = o3d.t.geometry.TriangleMesh.from_legacy(src.to_open3d(), vertex_dtype=o3d.core.float64)
    out, half = _check(t, src, ["normals", "colors", "uvs"])
    assert out.vertex.positions.dtype == o3d.core.float64          # the input's dtype, kept
    assert "colors" in half.vertex and "normals" in half.vertex and "texture_uvs" in half.triangle


def test_trimesh_vertex_colours():
    trimesh = pytest.importorskip("trimesh")
    src = _grid(uvs=False)
    tm = trimesh.Trimesh(src.vertices, src.faces, vertex_normals=src.normals,
                         vertex_colors=np.round(src.colors * 255).astype(np.uint8), process=False)
    out, half = _check(tm, src, ["normals", "colors"])
    assert out.visual.kind == "vertex" and out.visual.vertex_colors.dtype == np.uint8
    np.testing.assert_array_equal(out.visual.vertex_colors[:, :3], tm.visual.vertex_colors[out_map(out, tm), :3])
    assert half.visual.kind == "vertex"


def out_map(out, tm):
    """Rows of tm matching out's vertices (ratio 1: every output vertex is an input one)."""
    lookup = {tuple(v): i for i, v in enumerate(np.asarray(tm.vertices))}
    return np.array([lookup[tuple(v)] for v in np.asarray(out.vertices)])


def test_trimesh_uvs_keep_the_material():
    trimesh = pytest.importorskip("trimesh")
    src = _grid(colors=False)
    material = trimesh.visual.material.SimpleMaterial(diffuse=[200, 10, 10, 255])
    tm = trimesh.Trimesh(src.vertices, src.faces, vertex_normals=src.normals,
                         visual=trimesh.visual.TextureVisuals(uv=src.uvs, material=material), process=False)
    _, half = _check(tm, src, ["normals", "uvs"])
    assert half.visual.kind == "texture"
    np.testing.assert_array_equal(half.visual.material.diffuse, material.diffuse)


def test_trimesh_computed_normals_are_not_taken_as_data():
    trimesh = pytest.importorskip("trimesh")
    src = _grid(colors=False, uvs=False, normals=False)
    tm = trimesh.Trimesh(src.vertices, src.faces, process=False)
    assert to_mesh(tm).normals is None


def test_pyvista():
    pv = pytest.importorskip("pyvista")
    src = _grid()
    poly = pv.PolyData.from_regular_faces(src.vertices, src.faces)
    poly.point_data["Normals"] = src.normals
    poly.point_data.active_normals_name = "Normals"
    poly.point_data["RGB"] = np.round(src.colors * 255).astype(np.uint8)
    poly.point_data["Texture Coordinates"] = src.uvs
    poly.point_data.active_texture_coordinates_name = "Texture Coordinates"
    out, half = _check(poly, src, ["normals", "colors", "uvs"])
    assert out.point_data["RGB"].dtype == np.uint8
    assert half.point_data.active_normals_name == "Normals"
    assert half.point_data.active_texture_coordinates_name == "Texture Coordinates"


def test_pyvista_quads_are_triangulated_and_other_arrays_reported():
    pv = pytest.importorskip("pyvista")
    plane = pv.Plane(i_resolution=6, j_resolution=6)              # quads, with normals and uvs
    plane.point_data["height"] = np.arange(plane.n_points, dtype=float)
    with pytest.warns(UserWarning, match="height"):
        mesh, back = coerce(plane)
    assert mesh.n_faces == 2 * 36 and mesh.uvs is not None and mesh.normals is not None
    assert type(back(mesh)).__name__ == "PolyData" and back(mesh).is_all_triangles


def test_tuple_and_list():
    src = _grid(colors=False, uvs=False, normals=False)
    for kind in (tuple, list):
        obj = kind((src.vertices, src.faces))
        full = lodkit.simplify(obj, target_ratio=1.0)
        assert type(full.mesh) is kind and len(full.mesh) == 2
        np.testing.assert_array_equal(full.mesh[0], src.vertices[full.vertex_map])
        half = lodkit.simplify(obj, target_ratio=0.3).mesh
        assert type(half) is kind and np.asarray(half[1]).shape[1] == 3


def test_path(tmp_path):
    pytest.importorskip("open3d")
    src = _grid(uvs=False)
    path = tmp_path / "grid.ply"
    lodkit.save(src, path)
    for given in (path, str(path)):
        full = lodkit.simplify(given, target_ratio=1.0)
        assert isinstance(full.mesh, lodkit.Mesh)                  # a path gives a lodkit Mesh
        assert sorted(full.mesh.attributes()) == ["colors", "normals"]
        np.testing.assert_allclose(full.mesh.vertices, src.vertices[full.vertex_map], atol=1e-6)


@pytest.mark.parametrize("kind", ["mesh", "tuple", "open3d", "tensor", "trimesh", "pyvista", "path"])
def test_every_entry_point_takes_every_type(kind, tmp_path):
    src = _grid(uvs=False)
    if kind == "mesh":
        obj = src
    elif kind == "tuple":
        obj = (src.vertices, src.faces)
    elif kind == "open3d":
        obj = src.to_open3d()
    elif kind == "tensor":
        o3d = pytest.importorskip("open3d")
        obj = o3d.t.geometry.TriangleMesh.from_legacy(src.to_open3d())
    elif kind == "trimesh":
        trimesh = pytest.importorskip("trimesh")
        obj = trimesh.Trimesh(src.vertices, src.faces, process=False)
    elif kind == "pyvista":
        pv = pytest.importorskip("pyvista")
        obj = pv.PolyData.from_regular_faces(src.vertices, src.faces)
    else:
        obj = tmp_path / "grid.ply"
        lodkit.save(src, obj)
    want = lodkit.Mesh if kind == "path" else type(obj)
    assert type(lodkit.simplify(obj, target_ratio=0.5).mesh) is want
    assert type(lodkit.cluster(obj, target_faces=40).mesh) is want
    pm = lodkit.progressive(obj)
    assert type(pm.at(ratio=0.5)) is want
    assert all(type(m) is want for m in pm.lods([0.5, 0.25]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ev = lodkit.evaluate(obj, obj, samples=200)
    assert ev.distance.hausdorff == pytest.approx(0.0, abs=1e-9)


def test_other_objects_are_refused_with_what_is_accepted():
    with pytest.raises(MeshError, match="trimesh.Trimesh, a pyvista.PolyData"):
        lodkit.simplify(object(), target_ratio=0.5)
    with pytest.raises(MeshError, match="original: expected"):
        lodkit.evaluate({"a": 1}, (np.eye(3), [[0, 1, 2]]))


def test_topology_and_render_take_the_other_types_too():
    trimesh = pytest.importorskip("trimesh")
    src = _grid(colors=False, uvs=False, normals=False)
    tm = trimesh.Trimesh(src.vertices, src.faces, process=False)
    assert lodkit.topology(tm).as_dict() == lodkit.topology(src).as_dict()
    from lodkit import render

    a = render.render(tm, 40, 30, backend="numpy")
    b = render.render(src, 40, 30, backend="numpy")
    np.testing.assert_array_equal(a, b)
