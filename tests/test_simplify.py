"""lodkit.simplify end to end: properties on generated manifold meshes (topology kept, no
flipped faces, targets met, deterministic), attributes and Open3D round trips, bad input,
and the shared real meshes (skipped when absent)."""
from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import lodkit
from conftest import shared_mesh
from lodkit import MeshError, OptionError

SETTINGS = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])


# ---------------------------------------------------------------------- generated meshes
def grid(nx: int, ny: int, rng, amplitude: float, holes=(), alternate: bool = False):
    """A jittered height field over an nx x ny grid of quads, faces counter-clockwise from
    +z (so normals point up); each hole (i0, j0, i1, j1) removes quads i0 <= i < i1,
    j0 <= j < j1 -- callers keep holes apart and away from the border.  Quad diagonals are
    random, or alternate in a checkerboard with ``alternate``."""
    xs, ys = np.meshgrid(np.arange(nx + 1, dtype=float), np.arange(ny + 1, dtype=float))
    v = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], axis=1)
    v[:, :2] += rng.uniform(-0.2, 0.2, (len(v), 2))
    v[:, 2] = amplitude * np.sin(0.9 * v[:, 0]) * np.cos(0.6 * v[:, 1]) + rng.normal(0, 0.02, len(v))
    faces = []
    for j in range(ny):
        for i in range(nx):
            if any(i0 <= i < i1 and j0 <= j < j1 for i0, j0, i1, j1 in holes):
                continue
            a = j * (nx + 1) + i
            b, c, d = a + 1, a + nx + 2, a + nx + 1
            first = (i + j) % 2 == 0 if alternate else rng.random() < 0.5
            faces += [[a, b, c], [a, c, d]] if first else [[a, b, d], [b, c, d]]
    faces = np.array(faces)
    used = np.unique(faces)                      # holes may leave vertices unused
    remap = np.full(len(v), -1)
    remap[used] = np.arange(used.size)
    return v[used], remap[faces]


def torus_or_sphere(kind: str, nu: int, nv: int, rng):
    """A closed surface on an nu x nv parameter grid: a torus (genus 1) or a UV sphere
    (poles added), outward normals, radial jitter."""
    jitter = lambda shape: 1.0 + rng.uniform(-0.04, 0.04, shape)  # noqa: E731
    if kind == "torus":
        u = 2 * np.pi * np.arange(nu) / nu
        w = 2 * np.pi * np.arange(nv) / nv
        uu, ww = np.meshgrid(u, w)                      # row j: w_j, column i: u_i
        r = 0.35 * jitter(uu.shape)
        v = np.stack([(1 + r * np.cos(ww)) * np.cos(uu), (1 + r * np.cos(ww)) * np.sin(uu),
                      r * np.sin(ww)], axis=-1).reshape(-1, 3)
        idx = lambda j, i: (j % nv) * nu + i % nu  # noqa: E731
        faces = []
        for j in range(nv):
            for i in range(nu):
                a, b, c, d = idx(j, i), idx(j, i + 1), idx(j + 1, i + 1), idx(j + 1, i)
                faces += [[a, b, c], [a, c, d]] if rng.random() < 0.5 else [[a, b, d], [b, c, d]]
        return v, np.array(faces)
    # sphere: nv - 1 rings of nu vertices between the poles 0 (top) and 1 (bottom)
    rings = []
    for j in range(1, nv):
        t = np.pi * j / nv
        p = 2 * np.pi * np.arange(nu) / nu
        rings.append(np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.full(nu, np.cos(t))], 1))
    v = np.vstack([[[0, 0, 1], [0, 0, -1]]] + rings) * jitter((2 + nu * (nv - 1), 1))
    ring = lambda j, i: 2 + j * nu + i % nu  # noqa: E731
    faces = []
    for i in range(nu):
        faces += [[0, ring(0, i), ring(0, i + 1)], [1, ring(nv - 2, i + 1), ring(nv - 2, i)]]
    for j in range(nv - 2):
        for i in range(nu):
            a, b, c, d = ring(j, i), ring(j + 1, i), ring(j + 1, i + 1), ring(j, i + 1)
            faces += [[a, b, c], [a, c, d]] if rng.random() < 0.5 else [[a, b, d], [b, c, d]]
    return v, np.array(faces)


@st.composite
def manifold_meshes(draw):
    kind = draw(st.sampled_from(["grid", "grid_holes", "sphere", "torus"]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if kind.startswith("grid"):
        nx, ny = draw(st.integers(4, 14)), draw(st.integers(4, 14))
        holes = []
        if kind == "grid_holes":
            holes.append((1, 1, draw(st.integers(2, nx - 2)), draw(st.integers(2, ny - 2))))
            if nx >= 9 and draw(st.booleans()):
                holes.append((nx - 3, 1, nx - 1, 3))   # a second hole, apart from the first
                holes[0] = (1, 1, min(holes[0][2], nx - 5), holes[0][3])
        v, f = grid(nx, ny, rng, draw(st.sampled_from([0.0, 0.3, 1.5])), holes)
    else:
        v, f = torus_or_sphere(kind, draw(st.integers(6, 16)), draw(st.integers(5, 12)), rng)
    return kind, lodkit.Mesh(v, f)


def signed_volume(mesh) -> float:
    v, f = mesh.vertices, mesh.faces
    return float(np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6)


def check_result(mesh, result, target, max_normal_angle=90.0):
    """The properties every simplification of a manifold mesh must have."""
    out = result.mesh
    before, after = lodkit.topology(mesh), lodkit.topology(out)
    # provenance is well formed
    assert result.vertex_map.shape == (out.n_vertices,) and result.face_map.shape == (out.n_faces,)
    assert np.all(np.diff(result.vertex_map) > 0) and result.vertex_map.max() < mesh.n_vertices
    assert len(np.unique(result.face_map)) == out.n_faces and result.face_map.max() < mesh.n_faces
    assert np.isfinite(out.vertices).all()
    # topology
    if before.is_manifold:
        assert after.is_edge_manifold and after.is_vertex_manifold and after.is_manifold
        assert after.n_degenerate_faces == 0 and after.n_duplicate_faces == 0
    assert after.genus == before.genus
    assert after.n_boundary_loops == before.n_boundary_loops
    assert after.n_components == before.n_components
    assert after.is_oriented
    # no face turned over: each output face agrees with the input face it stands for
    n_in = mesh.face_normals()[result.face_map]
    n_out = out.face_normals()
    assert np.all(np.linalg.norm(n_out, axis=1) > 0.5), "degenerate output face"
    dots = np.einsum("ij,ij->i", n_in, n_out)
    # (1e-3: the core compares against input normals quantised to 16 bits)
    assert dots.min() > -1e-3, f"face {dots.argmin()} flipped (cos = {dots.min():.3g})"
    # ... and has not turned further than max_normal_angle from it
    assert dots.min() >= np.cos(np.radians(max_normal_angle)) - 1e-3
    if before.is_closed:
        assert signed_volume(out) > 0 and signed_volume(mesh) > 0
    # the face target, or a reason
    got = out.n_faces
    assert got >= target - 1
    if result.stop_reason == "target_faces":
        assert got in (target, target - 1)
    else:
        assert result.stop_reason == "no_valid_collapse" and got > target
    assert result.n_collapses == (mesh.n_vertices - out.n_vertices)


@SETTINGS
@given(manifold_meshes(), st.floats(0.02, 0.9), st.sampled_from(["optimal", "endpoint"]),
       st.sampled_from(["preserve", "lock", "free"]), st.sampled_from([90.0, 60.0, 25.0]))
def test_simplify_properties(case, ratio, placement, boundary, angle):
    kind, mesh = case
    result = lodkit.simplify(mesh, target_ratio=ratio, placement=placement, boundary=boundary,
                             max_normal_angle=angle)
    target = int(round(ratio * mesh.n_faces))
    assert result.report["target_faces"] == target
    check_result(mesh, result, target, angle)
    if placement == "endpoint":
        np.testing.assert_array_equal(result.mesh.vertices, mesh.vertices[result.vertex_map])
    if boundary == "lock":
        t = lodkit.topology(mesh)
        if not t.is_closed:
            edges = np.sort(np.concatenate([mesh.faces[:, [0, 1]], mesh.faces[:, [1, 2]],
                                            mesh.faces[:, [2, 0]]]), axis=1)
            uniq, counts = np.unique(edges, axis=0, return_counts=True)
            border = np.unique(uniq[counts == 1])
            rows = np.isin(result.vertex_map, border)
            assert rows.sum() == border.size
            np.testing.assert_array_equal(result.mesh.vertices[rows], mesh.vertices[result.vertex_map[rows]])


@SETTINGS
@given(manifold_meshes(), st.floats(0.02, 0.9))
def test_simplify_is_deterministic(case, ratio):
    _, mesh = case
    a = lodkit.simplify(mesh, target_ratio=ratio)
    b = lodkit.simplify(mesh.copy(), target_ratio=ratio)
    assert np.array_equal(a.mesh.vertices, b.mesh.vertices)
    assert np.array_equal(a.mesh.faces, b.mesh.faces)
    assert np.array_equal(a.vertex_map, b.vertex_map)
    assert np.array_equal(a.face_map, b.face_map)
    assert (a.error, a.stop_reason, a.n_collapses) == (b.error, b.stop_reason, b.n_collapses)


@pytest.mark.parametrize("placement", ["endpoint", "optimal"])
def test_sphere_is_not_turned_inside_out_at_four_faces(placement):
    """Simplified all the way to a tetrahedron, a closed surface must keep its outward
    orientation (positive signed volume).  Found by test_simplify_properties: with endpoint
    placement the last collapse (6 -> 4 faces) of this sphere once gave volume -0.135
    although every face stayed within 90 degrees of the input face it stands for."""
    rng = np.random.default_rng(428)
    nu, nv = int(rng.integers(6, 17)), int(rng.integers(5, 13))
    assert (nu, nv) == (9, 10)
    mesh = lodkit.Mesh(*torus_or_sphere("sphere", nu, nv, rng))
    assert signed_volume(mesh) > 0
    six = lodkit.simplify(mesh, target_faces=6, placement=placement)
    four = lodkit.simplify(mesh, target_faces=4, placement=placement)
    assert six.mesh.n_faces == 6 and signed_volume(six.mesh) > 0
    assert four.mesh.n_faces == 4
    assert signed_volume(four.mesh) > 0


def test_input_is_not_modified():
    mesh = lodkit.Mesh(*torus_or_sphere("torus", 12, 8, np.random.default_rng(0)))
    v, f = mesh.vertices.copy(), mesh.faces.copy()
    lodkit.simplify(mesh, target_ratio=0.2)
    assert np.array_equal(mesh.vertices, v) and np.array_equal(mesh.faces, f)


@pytest.mark.parametrize("ratio", [0.5, 0.1])
def test_max_error_and_target_together(ratio):
    mesh = lodkit.Mesh(*torus_or_sphere("sphere", 24, 16, np.random.default_rng(1)))
    free = lodkit.simplify(mesh, target_ratio=ratio)
    bounded = lodkit.simplify(mesh, target_ratio=ratio, max_error=free.error / 2)
    assert bounded.stop_reason == "max_error"
    assert bounded.error <= free.error / 2
    assert bounded.mesh.n_faces > free.mesh.n_faces


# ---------------------------------------------------------------------- attributes, Open3D
def attributed_sphere():
    v, f = torus_or_sphere("sphere", 20, 12, np.random.default_rng(4))
    normals = v / np.linalg.norm(v, axis=1, keepdims=True)
    colors = np.clip(0.5 + 0.5 * v, 0.0, 1.0)
    return lodkit.Mesh(v, f, normals=normals, colors=colors)


@pytest.mark.parametrize("placement", ["optimal", "endpoint"])
def test_attributes_are_carried(placement):
    mesh = attributed_sphere()
    result = lodkit.simplify(mesh, target_ratio=0.15, placement=placement)
    out = result.mesh
    n = out.n_vertices
    assert out.normals.shape == (n, 3) and out.colors.shape == (n, 3)
    assert out.uvs is None
    assert np.all((out.colors >= 0) & (out.colors <= 1))
    np.testing.assert_allclose(np.linalg.norm(out.normals, axis=1), 1.0, atol=1e-12)
    # the attributes still describe the surface: colour ~ position, normal ~ radial
    radial = out.vertices / np.linalg.norm(out.vertices, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", out.normals, radial).min() > 0.9
    assert np.abs(out.colors - (0.5 + 0.5 * out.vertices)).max() < 0.1
    if placement == "endpoint":
        # a half-edge collapse keeps the kept vertex's attributes
        np.testing.assert_allclose(out.colors, mesh.colors[result.vertex_map], atol=1e-12)


def test_constant_colour_stays_exact():
    v, f = torus_or_sphere("torus", 16, 10, np.random.default_rng(2))
    colors = np.tile([0.25, 0.5, 0.75], (len(v), 1))
    result = lodkit.simplify(lodkit.Mesh(v, f, colors=colors), target_ratio=0.1)
    assert np.array_equal(result.mesh.colors, np.tile([0.25, 0.5, 0.75], (result.mesh.n_vertices, 1)))


def test_uvs_are_carried():
    v, f = grid(10, 8, np.random.default_rng(3), 0.3)
    uvs = v[:, :2] / [10.0, 8.0]
    result = lodkit.simplify(lodkit.Mesh(v, f, uvs=uvs), target_ratio=0.2, boundary="lock")
    assert result.mesh.uvs.shape == (result.mesh.n_vertices, 2)
    # uv is linear in x, y here; on a vertex that never moved it is the input's exactly
    out = result.mesh
    unmoved = np.all(out.vertices == v[result.vertex_map], axis=1)
    assert unmoved.any()
    np.testing.assert_allclose(out.uvs, out.vertices[:, :2] / [10.0, 8.0], atol=0.1)


def test_open3d_in_open3d_out():
    o3d = pytest.importorskip("open3d")
    mesh = attributed_sphere()
    o3d_mesh = mesh.to_open3d()
    result = lodkit.simplify(o3d_mesh, target_ratio=0.25)
    out = result.mesh
    assert isinstance(out, o3d.geometry.TriangleMesh)
    assert out.has_vertex_colors() and out.has_vertex_normals()
    n_out = len(out.vertices)
    assert n_out == len(result.vertex_map) and len(out.triangles) == len(result.face_map)
    ref = lodkit.simplify(mesh, target_ratio=0.25)
    np.testing.assert_array_equal(np.asarray(out.vertices), ref.mesh.vertices)
    np.testing.assert_array_equal(np.asarray(out.triangles), ref.mesh.faces)
    np.testing.assert_allclose(np.asarray(out.vertex_colors), ref.mesh.colors)
    assert len(o3d_mesh.triangles) == mesh.n_faces              # the input is untouched


# ---------------------------------------------------------------------- bad input
TRI_V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
TRI_F = np.array([[0, 1, 2], [1, 3, 2]])


@pytest.mark.parametrize("vertices, faces, message", [
    (np.array([[0.0, 0, 0], [1, 0, 0], [0, np.nan, 0], [1, 1, 0]]), TRI_F, "NaN"),
    (np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, np.inf, 0]]), TRI_F, "inf"),
    (TRI_V, np.array([[0, 1, 2], [1, 4, 2]]), "outside 0..3"),
    (TRI_V, np.array([[0, 1, 2], [-1, 3, 2]]), "outside"),
    (TRI_V, np.array([[0, 1, 2, 3]]), "shape"),
    (TRI_V[:, :2], TRI_F, "shape"),
    (TRI_V, np.zeros((0, 3), int), "no faces"),
    (TRI_V, np.array([[0, 0, 1], [2, 2, 3]]), "repeat"),
    (np.zeros((4, 3)), TRI_F, "coincide"),
    (TRI_V, np.array([[0, 1, 2.5]]), "integer"),
])
def test_bad_meshes_raise_mesh_error(vertices, faces, message):
    with pytest.raises(MeshError, match=message):
        lodkit.simplify((vertices, faces), target_ratio=0.5)


def test_unknown_mesh_type_raises_mesh_error():
    with pytest.raises(MeshError, match="builtins.dict"):
        lodkit.simplify({"vertices": []}, target_ratio=0.5)


def test_a_path_is_read_and_a_missing_one_named(tmp_path):
    with pytest.raises(lodkit.MeshIOError, match="nope.ply"):
        lodkit.simplify(tmp_path / "nope.ply", target_ratio=0.5)


@pytest.mark.parametrize("options, message", [
    ({"target_ratio": 2}, "target_ratio"),
    ({"target_ratio": -0.1}, "target_ratio"),
    ({"target_ratio": 0}, r"target_ratio must be in \(0, 1\]"),         # as --ratio 0 on the CLI
    ({"target_ratio": 0.0}, "target_faces=0"),
    ({"target_faces": -1}, "target_faces"),
    ({"target_faces": 2.5}, "target_faces"),
    ({}, "stop criterion"),
    ({"target_ratio": 0.5, "metric": "nope"}, "nope"),
    ({"target_ratio": 0.5, "placement": "middle"}, "middle"),
    ({"target_ratio": 0.5, "boundary": "glue"}, "glue"),
    ({"target_ratio": 0.5, "max_normal_angle": 0}, "max_normal_angle"),
    ({"target_ratio": 0.5, "min_quality": 2}, "min_quality"),
    ({"target_ratio": 0.5, "boundary_weight": -1}, "boundary_weight"),
    ({"max_error": -1.0}, "max_error"),
    ({"target_ratio": 0.5, "locked": np.zeros(3, bool)}, "locked"),
    ({"target_ratio": 0.5, "locked": np.array([0, 9])}, "locked"),
])
def test_bad_options_raise_option_error(options, message):
    with pytest.raises(OptionError, match=message):
        lodkit.simplify((TRI_V, TRI_F), **options)


def test_errors_are_value_errors():
    # callers that catch ValueError keep working
    assert issubclass(MeshError, ValueError) and issubclass(OptionError, ValueError)


# ---------------------------------------------------------------------- real meshes
@functools.cache
def load(name):
    return lodkit.load(shared_mesh(name))


@functools.cache
def topo(name):
    return lodkit.topology(load(name))


@pytest.mark.parametrize("ratio", [0.1, 0.02])
@pytest.mark.parametrize("name", ["bunny.ply", "cow.obj", "fandisk.obj", "mountain.obj", "boot.obj"])
def test_real_meshes(name, ratio):
    mesh = load(name)
    before = topo(name)
    result = lodkit.simplify(mesh, target_ratio=ratio)
    check_real_result(mesh, result, int(round(ratio * mesh.n_faces)), before)


def check_real_result(mesh, result, target, before=None, max_error=0.05):
    """What a run to ``target`` on a real mesh must give: the target, the same topology
    (the cow's one pinch vertex kept, not multiplied), no flipped face, a sane error."""
    before = before or lodkit.topology(mesh)
    after = lodkit.topology(result.mesh)
    assert result.stop_reason == "target_faces"
    assert result.mesh.n_faces in (target, target - 1)
    assert after.n_nonmanifold_edges == 0
    assert after.n_nonmanifold_vertices == before.n_nonmanifold_vertices
    assert after.is_manifold == before.is_manifold
    assert after.genus == before.genus
    assert after.n_boundary_loops == before.n_boundary_loops
    assert after.n_components == before.n_components
    n_in = mesh.face_normals()[result.face_map]
    dots = np.einsum("ij,ij->i", n_in, result.mesh.face_normals())
    assert dots.min() > -1e-3
    assert 0 < result.error < max_error


def test_real_colours_and_uvs_are_carried():
    plane = load("colored_airplane.ply")
    result = lodkit.simplify(plane, target_ratio=0.1)
    colors = result.mesh.colors
    assert colors.shape == (result.mesh.n_vertices, plane.colors.shape[1])
    assert colors.min() >= 0.0 and colors.max() <= 1.0
    # colours are interpolated, not invented: each channel stays in the input's range
    used = plane.colors[np.unique(plane.faces)]
    assert np.all(colors >= used.min(axis=0) - 1e-12) and np.all(colors <= used.max(axis=0) + 1e-12)
    spot = load("spot_triangulated.obj")
    result = lodkit.simplify(spot, target_ratio=0.1)
    uvs = result.mesh.uvs
    assert uvs.shape == (result.mesh.n_vertices, 2)
    used = spot.uvs[np.unique(spot.faces)]
    assert np.all(uvs >= used.min(axis=0) - 1e-12) and np.all(uvs <= used.max(axis=0) + 1e-12)


BROKEN = ["broken_bunny_res2.ply", "broken_deg_faces.obj", "broken_non_manifold_wrap.obj",
          "broken_test_nm.obj"]


def check_target_and_repairs(mesh, result, target, faces):
    """The face target is met (within the one face a boundary collapse can overshoot) or
    the stop reason says why not; the repairs of the input are counted exactly."""
    from test_halfedge import FanReference, compact

    got = result.mesh.n_faces
    assert got >= max(target - 1, 1)
    if result.stop_reason == "target_faces":
        assert got in (target, target - 1)
    else:
        assert result.stop_reason == "no_valid_collapse" and got > target
    good, n_used = compact(faces)
    ref = FanReference(good)
    assert result.report["unreferenced_vertices_removed"] == mesh.n_vertices - n_used
    assert result.report["nonmanifold_edges_cut"] == ref.n_cut_edges
    assert result.report["vertices_split"] == ref.n_split


def _target(ratio: float) -> dict:
    """target_ratio=ratio, or target_faces=0 for 0 (target_ratio=0 is refused)."""
    return {"target_faces": 0} if ratio == 0 else {"target_ratio": ratio}


@pytest.mark.parametrize("ratio", [0.5, 0.1, 0.0])
@pytest.mark.parametrize("name", BROKEN)
def test_broken_meshes(name, ratio):
    mesh = load(name)
    result = lodkit.simplify(mesh, **_target(ratio))
    f = mesh.faces
    bad = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])
    check_target_and_repairs(mesh, result, int(round(ratio * mesh.n_faces)), f[~bad])
    assert result.report["input_faces"] == mesh.n_faces
    assert result.report["degenerate_faces_removed"] == int(bad.sum())
    # nothing made worse: no new non-manifold edges or pinch vertices
    before, after = topo(name), lodkit.topology(result.mesh)
    assert after.n_nonmanifold_edges <= before.n_nonmanifold_edges
    assert after.n_nonmanifold_vertices <= before.n_nonmanifold_vertices
    assert after.n_degenerate_faces == 0
    assert np.isfinite(result.mesh.vertices).all()


@st.composite
def face_soups(draw):
    """Random triangles over a few random points: non-manifold edges, pinch vertices,
    clashing orientations and duplicate faces are all likely."""
    n = draw(st.integers(4, 9))
    tri = st.lists(st.integers(0, n - 1), min_size=3, max_size=3, unique=True)
    faces = np.array(draw(st.lists(tri, min_size=2, max_size=16)))
    vertices = np.random.default_rng(draw(st.integers(0, 2**32 - 1))).normal(size=(n, 3))
    return lodkit.Mesh(vertices, faces)


@settings(max_examples=60, deadline=None)
@given(face_soups(), st.sampled_from([0.0, 0.3, 0.7]), st.sampled_from(["optimal", "endpoint"]),
       st.sampled_from(["preserve", "lock", "free"]))
def test_face_soups_are_repaired_not_damaged(mesh, ratio, placement, boundary):
    result = lodkit.simplify(mesh, **_target(ratio), placement=placement, boundary=boundary)
    check_target_and_repairs(mesh, result, int(round(ratio * mesh.n_faces)), mesh.faces)
    before, after = lodkit.topology(mesh), lodkit.topology(result.mesh)
    assert after.n_degenerate_faces == 0
    assert after.n_nonmanifold_edges <= before.n_nonmanifold_edges
    assert after.n_nonmanifold_vertices <= before.n_nonmanifold_vertices
    assert after.n_components == before.n_components
    assert after.euler_characteristic == before.euler_characteristic


MISORIENTED_TETRAHEDRON = (
    np.array([[-0.918, 0.1, -0.203], [-0.687, -0.102, 2.036],
              [0.389, 0.197, -1.849], [0.784, -0.33, -0.362]]),
    np.array([[2, 1, 3], [0, 2, 1], [0, 2, 3], [0, 3, 1]]),
)

@settings(max_examples=400, deadline=None)      # the bad cases are rare: ~1 soup in 500
@given(face_soups(), st.sampled_from(["optimal", "endpoint"]))
@example(lodkit.Mesh(*MISORIENTED_TETRAHEDRON), "optimal")
def test_face_soups_gain_no_duplicate_faces(mesh, placement):
    result = lodkit.simplify(mesh, target_faces=0, placement=placement)
    before, after = lodkit.topology(mesh), lodkit.topology(result.mesh)
    assert after.n_duplicate_faces <= before.n_duplicate_faces


def test_misoriented_tetrahedron_does_not_fold_into_a_double_face():
    """A closed tetrahedron with three faces against the others: its three clashing edges
    are cut, and collapsing 3 -> 2 once turned face [0, 3, 1] into a second copy of
    [0, 2, 1].  Found by test_face_soups_gain_no_duplicate_faces."""
    mesh = lodkit.Mesh(*MISORIENTED_TETRAHEDRON)
    assert lodkit.topology(mesh).n_inconsistent_edges == 3
    result = lodkit.simplify(mesh, target_faces=0)
    out = lodkit.topology(result.mesh)
    assert out.n_duplicate_faces == 0, result.mesh.faces.tolist()
    assert out.n_degenerate_faces == 0


def test_broken_inf_nan_raises_mesh_error():
    path = shared_mesh("broken_inf_nan.obj")
    with pytest.raises(MeshError, match="NaN or inf"):
        lodkit.load(path)
    o3d = pytest.importorskip("open3d")
    o3d_mesh = o3d.io.read_triangle_mesh(str(path))
    assert len(o3d_mesh.triangles) == 1
    with pytest.raises(MeshError, match="NaN or inf"):
        lodkit.simplify(o3d_mesh, target_ratio=0.5)


def min_dihedral_dot(mesh) -> float:
    """The smallest dot product of unit normals across the interior edges of ``mesh``
    (-1: two faces folded flat onto each other)."""
    normals = mesh.face_normals()
    f = mesh.faces
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    owner = np.tile(np.arange(len(f)), 3)
    key = np.sort(e, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    key, owner = key[order], owner[order]
    same = np.all(key[1:] == key[:-1], axis=1)
    a, b = owner[:-1][same], owner[1:][same]
    return float(np.einsum("ij,ij->i", normals[a], normals[b]).min())


@pytest.mark.parametrize("ratio", [0.1, 0.02, 0.005])
@pytest.mark.parametrize("name", ["igea.ply", "fandisk.obj", "mountain.obj"])
def test_no_face_folds_flat(name, ratio):
    """No face may bend back flat onto its neighbour, down to a few hundred faces (igea at
    0.5% used to get a face at -0.995 to two neighbours while it had turned only 80 degrees
    from the input face it stands for).  The inputs have no fold beyond -0.3."""
    mesh = load(name)
    assert min_dihedral_dot(mesh) > -0.3
    result = lodkit.simplify(mesh, target_ratio=ratio)
    assert result.stop_reason == "target_faces"
    assert min_dihedral_dot(result.mesh) > -0.9


def test_overflowing_bounding_box_raises_mesh_error():
    mesh = lodkit.Mesh(np.array([[-1e308, 0, 0], [1e308, 0, 0], [0, 1e308, 0]]), np.array([[0, 1, 2]]))
    with pytest.raises(MeshError, match="too large"):
        lodkit.simplify(mesh, target_faces=0)
