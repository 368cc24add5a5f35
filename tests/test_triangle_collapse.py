"""Triangle collapse, ``simplify(operator="triangle")`` (the lecture's third operator: a face
goes to one point, v - 2, f - 4): exact single collapses on hand-made meshes against a
slow reference, the check-then-undo of the second collapse, invariants by hypothesis, the
real meshes, determinism, and the edge path left as it was."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import lodkit
from lodkit import OptionError
from lodkit._core.decimate import EdgeCollapser, vertex_quadrics
from lodkit._core.halfedge import build
from test_qem import grid_mesh, q_eval, reference_quadrics, split, uv_sphere
from test_simplify import SETTINGS, check_real_result, check_result, grid, load, manifold_meshes, topo

TRIANGLE = 1


def face_neighbours(faces, f):
    """The faces sharing an edge with face f."""
    edges = {frozenset((int(faces[f][k]), int(faces[f][(k + 1) % 3]))) for k in range(3)}
    return {g for g in range(len(faces)) if g != f
            and any(frozenset((int(faces[g][k]), int(faces[g][(k + 1) % 3]))) in edges for k in range(3))}


def check_tri_result(mesh, result, target, **kw):
    """``check_result`` for triangle collapse: a step removes up to four faces, so the run
    ends within three faces under the target; every step is two edge collapses."""
    got = result.mesh.n_faces
    assert result.report["operator"] == "triangle_collapse"
    assert result.n_collapses == 2 * result.report["triangle_collapses"]
    if result.stop_reason == "target_faces":
        assert target - 3 <= got <= target
        check_result(mesh, result, got, **kw)
    else:
        check_result(mesh, result, target, **kw)
    if lodkit.topology(mesh).is_closed:
        # inside a closed surface every triangle collapse is exactly v - 2, f - 4
        assert mesh.n_faces - got == 4 * result.report["triangle_collapses"]
        assert mesh.n_vertices - result.mesh.n_vertices == 2 * result.report["triangle_collapses"]


# ---------------------------------------------------------------------- one collapse, by hand
def flat_grid_one_free_face():
    """A flat 4 x 4 grid (z = 0) with face 0 moved to the front: an interior face whose
    corners are the only free vertices; colours linear in x and y."""
    v, f = grid_mesh(4, 4)
    interior = (v[:, 0] > 0) & (v[:, 0] < 4) & (v[:, 1] > 0) & (v[:, 1] < 4)
    pick = next(i for i, face in enumerate(f) if interior[face].all())
    f = np.concatenate([f[pick:pick + 1], f[:pick], f[pick + 1:]])
    colors = np.stack([0.1 + 0.2 * v[:, 0], 0.05 + 0.1 * v[:, 1], 0.5 + 0.05 * (v[:, 0] - v[:, 1])], axis=1)
    locked = np.ones(len(v), bool)
    locked[f[0]] = False
    return lodkit.Mesh(v, f, colors=colors), locked


def test_flat_face_collapses_to_its_centroid():
    mesh, locked = flat_grid_one_free_face()
    v, f = mesh.vertices, mesh.faces
    result = lodkit.simplify(mesh, target_faces=len(f) - 4, operator="triangle", locked=locked)
    out = result.mesh
    assert result.stop_reason == "target_faces"
    assert (out.n_vertices, out.n_faces) == (len(v) - 2, len(f) - 4)
    assert result.n_collapses == 2 and result.report["triangle_collapses"] == 1
    # the face and its three neighbours died, nothing else
    dead = {0} | face_neighbours(f, 0)
    assert len(dead) == 4
    assert sorted(result.face_map.tolist()) == sorted(set(range(len(f))) - dead)
    # a flat region: the quadric does not fix the point in the plane, the truncated solve
    # about the centroid leaves it there
    a, b, c = f[0]
    centroid = (v[a] + v[b] + v[c]) / 3
    kept = [a, b, c][int(np.argmin(np.linalg.norm(v[[a, b, c]] - centroid, axis=1)))]
    assert set(result.vertex_map.tolist()) == set(range(len(v))) - ({a, b, c} - {kept})
    i = int(np.flatnonzero(result.vertex_map == kept)[0])
    np.testing.assert_allclose(out.vertices[i], centroid, rtol=0, atol=1e-12)
    # every other vertex is where it was, bit for bit
    others = np.flatnonzero(result.vertex_map != kept)
    assert np.array_equal(out.vertices[others], v[result.vertex_map[others]])
    # the colour is the barycentric mix: linear colours stay exact at the centroid
    np.testing.assert_allclose(out.colors[i], mesh.colors[[a, b, c]].mean(axis=0), rtol=0, atol=1e-12)
    assert result.error == 0.0


def reference_cheapest_face(v, f):
    """Slow reference: Q_a + Q_b + Q_c of every face minimised by a dense solve; the
    cheapest face (ties by id), its optimum and cost."""
    q = reference_quadrics(v, f)
    best = None
    for i, (a, b, c) in enumerate(f):
        qs = q[a] + q[b] + q[c]
        A, bb, _ = split(qs)
        assert np.linalg.cond(A) < 1e3              # a curved patch: the 3x3 solve applies
        p = np.linalg.solve(A, -bb)
        cost = max(q_eval(qs, p), 0.0)
        if best is None or cost < best[2]:
            best = (i, p, cost, qs[10])
    return best


def test_sphere_face_collapses_to_the_quadric_optimum():
    v, f = uv_sphere(10, 6, jitter=0.04, seed=11)
    mesh = lodkit.Mesh(v, f)
    fid, p, cost, area = reference_cheapest_face(v, f)
    result = lodkit.simplify(mesh, target_faces=len(f) - 4, operator="triangle")
    out = result.mesh
    assert (out.n_vertices, out.n_faces) == (len(v) - 2, len(f) - 4)
    dead = {fid} | face_neighbours(f, fid)
    assert sorted(result.face_map.tolist()) == sorted(set(range(len(f))) - dead)
    new = np.flatnonzero(~np.all(out.vertices == v[result.vertex_map], axis=1))
    assert len(new) == 1 and result.vertex_map[new[0]] in f[fid]
    np.testing.assert_allclose(out.vertices[new[0]], p, rtol=0, atol=1e-10)
    # error: the area-weighted RMS distance to the planes, sqrt(Q(p) / area), in bbox diagonals
    diagonal = np.linalg.norm(v.max(axis=0) - v.min(axis=0))
    assert result.error == pytest.approx(np.sqrt(cost / area) / diagonal, rel=1e-6)


@pytest.mark.parametrize("seed", [1, 2])
def test_endpoint_placement_keeps_input_vertices(seed):
    v, f = uv_sphere(12, 8, jitter=0.05, seed=seed)
    mesh = lodkit.Mesh(v, f)
    result = lodkit.simplify(mesh, target_ratio=0.3, operator="triangle", placement="endpoint")
    check_tri_result(mesh, result, int(round(0.3 * len(f))))
    out = result.mesh
    # every output vertex is an input vertex, bit for bit (each at one of its face's corners)
    rows = {tuple(x) for x in v}
    assert all(tuple(x) in rows for x in out.vertices)


def test_lone_border_corner_holds_the_face():
    """Under "preserve" a face with one border corner collapses onto that corner."""
    v, f = grid_mesh(3, 3, z=lambda x, y: 0.2 * np.sin(x + 0.3) * np.cos(0.8 * y))
    hm = build(f.astype(np.int32), len(v))
    q = vertex_quadrics(hm, v.copy(), 10.0)
    col = EdgeCollapser(hm, v.copy(), q, None, np.zeros(len(v), np.uint8), operator=TRIANGLE)
    border = hm.boundary_vertices
    for i, face in enumerate(f):
        plan = col.plan_face(i)
        nb = int(border[face].sum())
        if nb == 1:
            kept, first, second, p, _, _ = plan
            b = int(face[border[face]][0])
            assert kept == b and np.array_equal(p, v[b])
            assert {first, second} == set(face.tolist()) - {b}
        elif nb == 0:
            assert plan is not None


def test_two_fixed_corners_refuse_the_face():
    v, f = uv_sphere(8, 5)
    hm = build(f.astype(np.int32), len(v))
    q = vertex_quadrics(hm, v.copy())
    fixed = np.zeros(len(v), np.uint8)
    fixed[f[0][:2]] = 1
    col = EdgeCollapser(hm, v.copy(), q, None, fixed, operator=TRIANGLE)
    assert col.plan_face(0) is None
    for i, face in enumerate(f):
        if fixed[face].sum() == 1:
            kept, first, second, p, _, _ = col.plan_face(i)
            assert fixed[kept] and np.array_equal(p, v[kept])


# ---------------------------------------------------------------------- check, then undo
def snapshot(hm, col):
    return [np.array(x, copy=True) for x in (hm.corners, hm.twins, hm.edges, hm.edge_halfedges,
                                             hm.vertex_halfedges, hm.alive_faces, hm.alive_vertices,
                                             hm.alive_edges, col.positions)] + [hm.n_alive_faces, hm.n_alive_vertices]


def same(a, b):
    return all(np.array_equal(x, y) for x, y in zip(a, b))


def triangle_collapser(v, f, **options):
    hm = build(f.astype(np.int32), len(v))
    q = vertex_quadrics(hm, v.copy())
    return hm, EdgeCollapser(hm, v.copy(), q, None, np.zeros(len(v), np.uint8), operator=TRIANGLE, **options)


MESHES = {
    "octahedron": uv_sphere(4, 2, jitter=0.05),
    "sphere": uv_sphere(9, 6, jitter=0.08, seed=5),
    "jittered grid": grid(6, 5, np.random.default_rng(3), 0.5),
}


@pytest.mark.parametrize("angle", [90.0, 20.0])
@pytest.mark.parametrize("name", sorted(MESHES))
def test_checking_a_face_changes_nothing(name, angle):
    """check_face does the first collapse on the half-edge arrays to check the second, then
    undoes it: the arrays must come back bit for bit, whatever the verdict."""
    v, f = MESHES[name]
    hm, col = triangle_collapser(v, f, closed_connected=lodkit.topology(lodkit.Mesh(v, f)).is_closed,
                                 max_normal_angle=angle, min_quality=0.3)
    before = snapshot(hm, col)
    verdicts = []
    for i in range(len(f)):
        verdicts.append(col.check_face(i))
        assert same(before, snapshot(hm, col)), f"face {i}"
    hm.check()
    if name == "octahedron":
        # any face of an octahedron may go (it leaves a tetrahedron), unless the normals
        # may not turn by more than 20 degrees
        assert all(verdicts) == (angle == 90.0)
    else:
        assert any(verdicts) and not all(verdicts)
        assert col.n_tri_refused_second > 0      # the undo ran after a refused second step


@pytest.mark.parametrize("name", sorted(MESHES))
def test_topology_verdict_matches_two_reference_collapses(name):
    """With the geometric checks off, a face may collapse iff edge r1-k passes the link
    condition and, once it is collapsed, edge r2-k does (HalfEdgeMesh's own operations on
    a fresh copy)."""
    v, f = MESHES[name]
    hm, col = triangle_collapser(v, f, max_normal_angle=180.0, min_quality=0.0)
    for i in range(len(f)):
        plan = col.plan_face(i)
        ref = build(f.astype(np.int32), len(v))
        if plan is None:
            continue
        kept, first, second = plan[:3]
        expected = ref.can_collapse(first, kept)
        if expected:
            ref.collapse_edge(first, kept)
            expected = ref.can_collapse(second, kept)
        assert col.check_face(i) == expected, f"face {i}"


# ---------------------------------------------------------------------- invariants
@SETTINGS
@given(manifold_meshes(), st.floats(0.02, 0.9), st.sampled_from(["optimal", "endpoint"]),
       st.sampled_from(["preserve", "lock", "free"]), st.sampled_from([90.0, 45.0]))
def test_triangle_collapse_properties(case, ratio, placement, boundary, angle):
    _, mesh = case
    target = int(round(ratio * mesh.n_faces))
    result = lodkit.simplify(mesh, target_ratio=ratio, operator="triangle", placement=placement,
                             boundary=boundary, max_normal_angle=angle)
    check_tri_result(mesh, result, target, max_normal_angle=angle)
    if boundary == "lock":
        # the border stays, bit for bit
        border = np.flatnonzero(build(mesh.faces.astype(np.int32), mesh.n_vertices).boundary_vertices)
        rows = np.searchsorted(result.vertex_map, border)
        assert np.array_equal(result.vertex_map[rows], border)
        assert np.array_equal(result.mesh.vertices[rows], mesh.vertices[border])


@SETTINGS
@given(manifold_meshes(), st.floats(0.05, 0.6))
def test_triangle_collapse_is_deterministic(case, ratio):
    _, mesh = case
    a = lodkit.simplify(mesh, target_ratio=ratio, operator="triangle")
    b = lodkit.simplify(mesh, target_ratio=ratio, operator="triangle")
    assert np.array_equal(a.mesh.vertices, b.mesh.vertices) and np.array_equal(a.mesh.faces, b.mesh.faces)
    assert np.array_equal(a.vertex_map, b.vertex_map) and np.array_equal(a.face_map, b.face_map)
    assert a.error == b.error


def test_max_error_is_respected():
    v, f = uv_sphere(16, 10, jitter=0.05, seed=4)
    mesh = lodkit.Mesh(v, f)
    result = lodkit.simplify(mesh, max_error=0.01, operator="triangle")
    assert result.stop_reason == "max_error" and result.error <= 0.01
    assert 0 < result.report["triangle_collapses"]


def test_records_hold_both_collapses_of_each_face():
    v, f = uv_sphere(10, 6, jitter=0.04)
    mesh = lodkit.Mesh(v, f)
    result = lodkit.simplify(mesh, target_faces=60, operator="triangle", record=True)
    rec = result.collapses
    n = result.n_collapses
    assert n == 2 * result.report["triangle_collapses"] == len(rec["removed"])
    # rows come in pairs: the first marked open, both keeping the same vertex at one point
    assert np.array_equal(rec["pair_open"], np.arange(n) % 2 == 0)
    assert np.array_equal(rec["kept"][0::2], rec["kept"][1::2])
    assert np.array_equal(rec["position"][0::2], rec["position"][1::2])
    assert np.array_equal(rec["error"][0::2], rec["error"][1::2])
    # replaying the removals by hand gives the output's vertices
    removed = set(rec["removed"].tolist())
    assert sorted(set(range(len(v))) - removed) == result.vertex_map.tolist()


def test_attribute_quadrics_and_colours():
    """A quadric metric over colours ('appearance') works with triangle collapse; colours
    are mixed, not invented."""
    v, f = uv_sphere(14, 9, jitter=0.03)
    colors = np.clip(0.5 + 0.4 * v, 0.0, 1.0)
    mesh = lodkit.Mesh(v, f, colors=colors)
    result = lodkit.simplify(mesh, target_ratio=0.25, operator="triangle", metric="appearance")
    check_tri_result(mesh, result, int(round(0.25 * len(f))))
    out = result.mesh.colors
    assert out.min() >= colors.min() - 1e-12 and out.max() <= colors.max() + 1e-12


# ---------------------------------------------------------------------- options
@pytest.mark.parametrize("operator", ["vertex", "Triangle", 1, None])
def test_unknown_operator(operator):
    v, f = uv_sphere()
    with pytest.raises(OptionError, match="operator must be one of"):
        lodkit.simplify(lodkit.Mesh(v, f), target_ratio=0.5, operator=operator)


@pytest.mark.parametrize("metric", ["importance", "curvature", ["qem", "importance"]])
def test_non_quadric_metrics_are_refused(metric):
    v, f = uv_sphere()
    with pytest.raises(OptionError, match="quadric metrics only"):
        lodkit.simplify(lodkit.Mesh(v, f), target_ratio=0.5, operator="triangle", metric=metric)


def test_collapser_refuses_extras_for_triangles():
    v, f = uv_sphere()
    hm = build(f.astype(np.int32), len(v))
    q = vertex_quadrics(hm, v.copy())
    with pytest.raises(ValueError, match="quadric metrics only"):
        EdgeCollapser(hm, v.copy(), q, None, np.zeros(len(v), np.uint8), operator=TRIANGLE,
                      vertex_fields=np.ones(len(v)), vertex_rules=np.array([[0, 0, 0, 1.0, 1.0]]))
    with pytest.raises(ValueError, match="unknown operator"):
        EdgeCollapser(hm, v.copy(), q, None, np.zeros(len(v), np.uint8), operator=2)


# ---------------------------------------------------------------------- real meshes
@pytest.mark.parametrize("name", ["bunny.ply", "fandisk.obj", "boot.obj"])
def test_real_meshes(name):
    mesh = load(name)
    target = int(round(0.1 * mesh.n_faces))
    result = lodkit.simplify(mesh, target_ratio=0.1, operator="triangle")
    got = result.mesh.n_faces
    assert target - 3 <= got <= target
    check_real_result(mesh, result, got, before=topo(name))
    assert result.report["triangle_collapses"] > 0


def test_edge_path_is_unchanged():
    mesh = load("bunny.ply")
    a = lodkit.simplify(mesh, target_ratio=0.1, driver="greedy")
    # the figure recorded before triangle collapse existed; the last bits differ between CPUs
    assert a.error == pytest.approx(1.8482975099007456e-3, rel=1e-9)
    assert a.report["operator"] == "edge_collapse" and a.report["triangle_collapses"] == 0
    b = lodkit.simplify(mesh, target_ratio=0.1, operator="edge", driver="greedy")
    assert np.array_equal(a.mesh.vertices, b.mesh.vertices) and np.array_equal(a.mesh.faces, b.mesh.faces)
