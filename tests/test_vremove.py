"""The vertex-removal driver (lodkit._core.vremove) and what it stands on: the fan and the
closest-line apex of retriangulate, the star replacement of the half-edge arrays, the
median filter of gated kernels, and ``simplify`` with a removal metric (run with the
PlaneFan test kernel: cost = distance to the average plane, fan from the closest-line apex)."""
from __future__ import annotations

import functools
import importlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lodkit
from conftest import shared_mesh
from lodkit import MetricError, OptionError
from lodkit._core.halfedge import build, triangulation_ok
from lodkit._core.retriangulate import py_closest_line_apex, py_fan_from
from lodkit._core.vremove import STATE_NAMES, MedianFilter, VertexRemover
from lodkit.metrics.base import Option, RemovalMetric
from native import load
from test_simplify import BROKEN, check_real_result, face_soups, manifold_meshes, signed_volume

REPO = Path(__file__).resolve().parent.parent
PlaneFan = load("lodkit_testkernels").PlaneFan      # tests/native/lodkit_testkernels.pyx
SETTINGS = settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])


class PlaneFanMetric(RemovalMetric):
    """The PlaneFan test kernel as a removal metric (not registered)."""

    name = "planefan"
    kernel = PlaneFan
    options = {"gate": Option(None, kind="array"), "veto": Option(None, kind="array"),
               "fail_after": Option(-1, kind=int), "invalid": Option(False, kind=bool),
               "n_tris": Option(-1, kind=int)}


def cyclic(faces):
    """Faces as a set of tuples, each rotated to start at its smallest index (orientation kept)."""
    out = set()
    for f in np.asarray(faces).tolist():
        i = f.index(min(f))
        out.add(tuple(f[i:] + f[:i]))
    return out


def hexagon(center=(0.1, 0.02, 0.0)):
    ang = np.arange(6) * np.pi / 3
    v = np.vstack([center, np.c_[np.cos(ang), np.sin(ang), np.zeros(6)]])
    f = np.array([[0, 1 + i, 1 + (i + 1) % 6] for i in range(6)])
    return lodkit.Mesh(v, f)


def polar_disk(rings=4, per_ring=12, rng=None):
    """A flat disk: a centre and ``rings`` rings of ``per_ring`` vertices (the outer one the
    boundary, a strictly convex polygon), triangulated ring to ring, with a little jitter
    inside."""
    rng = rng or np.random.default_rng(0)
    v = [[0.0, 0.0, 0.0]]
    for r in range(1, rings + 1):
        a = 2 * np.pi * (np.arange(per_ring) + 0.5 * (r % 2)) / per_ring
        rad = r + (rng.uniform(-0.15, 0.15, per_ring) if r < rings else 0.0)
        v += np.c_[rad * np.cos(a), rad * np.sin(a), np.zeros(per_ring)].tolist()
    ring = lambda r, i: 1 + (r - 1) * per_ring + i % per_ring  # noqa: E731
    f = [[0, ring(1, i), ring(1, i + 1)] for i in range(per_ring)]
    for r in range(1, rings):
        for i in range(per_ring):
            if r % 2:
                f += [[ring(r, i), ring(r + 1, i), ring(r + 1, i + 1)],
                      [ring(r, i), ring(r + 1, i + 1), ring(r, i + 1)]]
            else:
                f += [[ring(r, i), ring(r + 1, i - 1), ring(r + 1, i)], [ring(r, i), ring(r + 1, i), ring(r, i + 1)]]
    return lodkit.Mesh(np.array(v), np.array(f))


# ---------------------------------------------------------------------- retriangulate
def test_fan_from_exact():
    np.testing.assert_array_equal(py_fan_from(0, 5), [[0, 1, 2], [0, 2, 3], [0, 3, 4]])
    np.testing.assert_array_equal(py_fan_from(2, 5), [[2, 0, 1], [2, 3, 4], [2, 4, 0]])
    np.testing.assert_array_equal(py_fan_from(1, 3), [[1, 2, 0]])
    for k in range(3, 12):
        for apex in range(k):
            t = py_fan_from(apex, k)
            assert t.shape == (k - 2, 3) and (t[:, 0] == apex).all()
            assert triangulation_ok(t, k, True) and triangulation_ok(t, k, False)
    with pytest.raises(ValueError):
        py_fan_from(3, 3)


def test_closest_line_apex_exact():
    ang = np.arange(6) * np.pi / 3
    hexa = np.c_[np.cos(ang), np.sin(ang), np.zeros(6)]
    # near the diagonal 0-3 (the x axis), nearer to 0
    assert py_closest_line_apex(hexa, [0.1, 0.02, 0.0]) == 0
    # near the same diagonal, nearer to its other end
    assert py_closest_line_apex(hexa, [-0.1, 0.02, 0.0]) == 3
    # near the diagonal 1-4, nearer to 4
    p = 0.3 * hexa[4] + np.array([0.01, -0.005, 0.0])
    assert py_closest_line_apex(hexa, p) == 4
    # on the line of the polygon edge 0-1, beyond vertex 1: that line, its end 1
    p = hexa[1] + 0.5 * (hexa[1] - hexa[0])
    assert py_closest_line_apex(hexa, p) == 1
    assert py_closest_line_apex(np.eye(3)[:2], [0, 0, 0]) == -1


def test_closest_line_apex_coincident_vertices():
    pts = np.array([[1.0, 0, 0], [1.0, 0, 0], [0, 1.0, 0], [0, 1.0, 0]])
    # the only lines run from a copy of (1,0,0) to a copy of (0,1,0); first pair (0, 2)
    assert py_closest_line_apex(pts, [0.9, 0.2, 0.0]) == 0
    assert py_closest_line_apex(pts, [0.1, 0.95, 0.0]) == 2
    # all coincident: any apex is as good; 0
    assert py_closest_line_apex(np.ones((5, 3)), [0, 0, 0]) == 0


def _closest_line_reference(P, x):
    best = None
    for i in range(len(P)):
        for j in range(i + 1, len(P)):
            d = P[j] - P[i]
            if not np.dot(d, d) > 0:
                continue
            dist = np.linalg.norm(np.cross(x - P[i], d)) / np.linalg.norm(d)
            if best is None or dist < best[0] - 1e-12:
                best = (dist, i, j)
    if best is None:
        return 0
    _, i, j = best
    return j if np.linalg.norm(x - P[j]) < np.linalg.norm(x - P[i]) else i


@settings(max_examples=200, deadline=None)
@given(st.integers(3, 12), st.integers(0, 2**32 - 1))
def test_closest_line_apex_matches_brute_force(k, seed):
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(k, 3))
    x = rng.normal(size=3)
    got = py_closest_line_apex(P, x)
    want = _closest_line_reference(P, x)
    if got != want:
        # only a near-tie may differ: both lines as close to within rounding
        def dist_to_best(a):
            return min(np.linalg.norm(np.cross(x - P[a], P[b] - P[a])) / np.linalg.norm(P[b] - P[a])
                       for b in range(k) if b != a)
        assert abs(dist_to_best(got) - dist_to_best(want)) < 1e-9


# ---------------------------------------------------------------------- median filter
@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["set", "remove"]), st.integers(0, 29),
                          st.one_of(st.sampled_from([0.0, 1.0, 2.0, 6.283185307179586, float("nan")]),
                                    st.floats(-5, 5))), max_size=120),
       st.floats(-6, 6), st.floats(-6, 7))
def test_median_filter_matches_brute_force(ops, a, b):
    filt = MedianFilter(30)
    ref = {}
    for op, cid, value in ops:
        if op == "set":
            filt.set(cid, value)
            if value != value:
                ref.pop(cid, None)
            else:
                ref[cid] = value
        else:
            filt.remove(cid)
            ref.pop(cid, None)
        filt.check()
        assert len(filt) == len(ref)
        assert all((c in filt) == (c in ref) for c in range(30))
        vals = sorted(ref.values())
        want = vals[(len(vals) + 1) // 2 - 1] if vals else None
        assert filt.median() == want
    lo, hi = min(a, b), max(a, b)
    np.testing.assert_array_equal(filt.band(lo, hi), sorted(c for c, v in ref.items() if lo <= v < hi))
    m = filt.median()
    if m is not None:
        # the competitors of the driver: gate >= median, at least half of them
        assert sum(v >= m for v in ref.values()) >= len(ref) / 2
        np.testing.assert_array_equal(filt.band(m, np.inf), sorted(c for c, v in ref.items() if v >= m))


def test_median_filter_bad_ids():
    filt = MedianFilter(3)
    with pytest.raises(ValueError):
        filt.set(3, 1.0)
    with pytest.raises(ValueError):
        MedianFilter(-1)
    assert filt.median() is None and len(filt) == 0


# ---------------------------------------------------------------------- half-edge star replacement
def consistent_with_rebuild(hm):
    """The arrays after removals agree with arrays built afresh from the live faces: same
    faces, the same twin pairs (as vertex pairs), the same boundary half-edges, edge ids and
    v_he valid, the counts right."""
    hm.check()
    faces = hm.faces()
    fresh = build(faces, hm.n_vertices)
    assert fresh.n_split_vertices == 0 and fresh.n_nonmanifold_edges == 0
    corners = hm.corners.reshape(-1)
    live = np.flatnonzero(np.repeat(hm.alive_faces, 3))
    nxt = np.where(live % 3 == 2, live - 2, live + 1)
    tw = hm.twins[live]
    pairs = {(corners[h], corners[n], tw_ >= 0) for h, n, tw_ in zip(live, nxt, tw)}
    fc = fresh.corners.reshape(-1)
    fl = np.arange(fc.size)
    fn = np.where(fl % 3 == 2, fl - 2, fl + 1)
    fresh_pairs = {(fc[h], fc[n], t >= 0) for h, n, t in zip(fl, fn, fresh.twins)}
    assert pairs == fresh_pairs
    # twins point at the reverse half-edge
    has = tw >= 0
    assert (corners[tw[has]] == corners[nxt[has]]).all()
    # edge ids: one live id per undirected edge, both half-edges share it
    eids = hm.edges[live]
    assert np.unique(eids).size == fresh.n_edges
    assert hm.alive_edges.sum() == fresh.n_edges
    assert (hm.edges[tw[has]] == eids[has]).all()
    assert hm.n_alive_faces == faces.shape[0]
    assert hm.n_alive_vertices == np.unique(faces).size
    alive_v = np.flatnonzero(hm.alive_vertices)
    np.testing.assert_array_equal(alive_v, np.unique(faces))
    # boundary vertices start their fan at the boundary
    np.testing.assert_array_equal(hm.boundary_vertices[alive_v], fresh.boundary_vertices[alive_v])


def test_remove_vertex_hexagon_exact():
    m = hexagon()
    hm = build(m.faces.astype(np.int32), 7)
    link, faces, closed = hm.star(0)
    assert link == [2, 3, 4, 5, 6, 1] and closed and len(faces) == 6
    slots = hm.remove_vertex(0, [[5, 0, 1], [5, 1, 2], [5, 2, 3], [5, 3, 4]])   # fan from vertex 1
    assert cyclic(hm.faces()) == {(1, 2, 3), (1, 3, 4), (1, 4, 5), (1, 5, 6)}
    assert len(set(slots.tolist())) == 4
    consistent_with_rebuild(hm)
    with pytest.raises(ValueError):
        hm.remove_vertex(1, [[0, 1, 2]])          # a boundary vertex of k = 4 takes 2 triangles


def test_remove_vertex_rejects_non_triangulations():
    m = hexagon()
    hm = build(m.faces.astype(np.int32), 7)
    with pytest.raises(ValueError, match="no oriented triangulation"):
        hm.remove_vertex(0, [[0, 2, 1], [0, 2, 3], [0, 3, 4], [0, 4, 5]])
    assert not triangulation_ok([[0, 1, 2], [0, 1, 3]], 4, True)
    assert not triangulation_ok([[0, 1, 2], [2, 3, 0]], 5, True)
    assert triangulation_ok([[0, 1, 2], [0, 2, 3], [0, 3, 4]], 5, True)
    assert triangulation_ok([[1, 2, 3], [1, 3, 4], [1, 4, 0]], 5, False)
    assert triangulation_ok([[0, 2, 4], [0, 1, 2], [2, 3, 4], [4, 5, 0]], 6, True)


@SETTINGS
@given(manifold_meshes(), st.floats(0.05, 0.8))
def test_star_replacement_matches_rebuild_after_many_removals(case, ratio):
    kind, mesh = case
    prep = lodkit.api.prepare(mesh)
    hm = prep.hm
    k = PlaneFan()
    k.prepare(None, {})
    vr = VertexRemover(hm, prep.positions, k, hm.locked_vertices, boundary=1)
    target = int(ratio * mesh.n_faces)
    vr.run(target)
    assert vr.n_collapses > 0
    consistent_with_rebuild(hm)


# ---------------------------------------------------------------------- the driver, exact cases
def test_hexagon_interior_vertex_gives_the_four_fan_triangles():
    m = hexagon()
    r = lodkit.simplify(m, target_faces=4, metric=PlaneFanMetric(), boundary="lock", record=True)
    assert r.stop_reason == "target_faces" and r.n_collapses == 1
    # closest line to the centre (0.1, 0.02): the diagonal 1-4; its nearer end 1 is the apex
    np.testing.assert_array_equal(r.vertex_map, np.arange(1, 7))
    got = cyclic(r.vertex_map[r.mesh.faces])
    assert got == {(1, 2, 3), (1, 3, 4), (1, 4, 5), (1, 5, 6)}
    np.testing.assert_array_equal(r.mesh.vertices, m.vertices[1:])          # bit for bit
    rec = r.collapses
    assert rec["operator"] == "vertex_removal"
    np.testing.assert_array_equal(rec["removed"], [0])
    np.testing.assert_array_equal(rec["link"], [2, 3, 4, 5, 6, 1])
    np.testing.assert_array_equal(rec["link_offsets"], [0, 6])
    assert cyclic(rec["old_faces"]) == cyclic(m.faces)
    assert cyclic(rec["new_faces"]) == got
    np.testing.assert_array_equal(rec["new_face_offsets"], [0, 4])
    np.testing.assert_array_equal(rec["position"], m.vertices[[0]])
    # the centre is 0 off the plane of its flat star
    assert rec["cost"][0] == 0.0 and r.error == 0.0
    assert r.report["operator"] == "vertex_removal"


def test_face_map_of_retriangulated_faces():
    """A new triangle takes the face slot (and so the input face) of the old face whose link
    edge it inherits."""
    m = hexagon()
    r = lodkit.simplify(m, target_faces=4, metric=PlaneFanMetric(), boundary="lock")
    faces = r.vertex_map[r.mesh.faces]
    for f, src in zip(faces, r.face_map):
        old = m.faces[src]                      # (0, a, a+1): its link edge a -> a+1
        a, b = old[1], old[2]
        assert any((f[i], f[(i + 1) % 3]) == (a, b) for i in range(3))


def test_boundary_vertex_removal_exact():
    # v = 0 on the border of a half-disk fan, off-centre; link 1, 2, 3, 4 along the arc
    ang = np.arange(4) * np.pi / 3
    v = np.vstack([[0.1, 0.0, 0.0], np.c_[np.cos(ang), np.sin(ang), np.zeros(4)]])
    f = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4]])
    m = lodkit.Mesh(v, f)
    r = lodkit.simplify(m, target_faces=2, metric=PlaneFanMetric(), boundary="preserve", record=True)
    assert r.n_collapses == 1 and r.stop_reason == "target_faces"
    np.testing.assert_array_equal(r.collapses["removed"], [0])
    assert not r.collapses["closed"][0]
    # the line 1-4 (the x axis) runs through v; its nearer end 1 is the apex
    assert cyclic(r.vertex_map[r.mesh.faces]) == {(1, 2, 3), (1, 3, 4)}
    assert cyclic(r.collapses["old_faces"]) == cyclic(f)
    # under "lock" no boundary vertex goes: nothing can be removed
    r = lodkit.simplify(m, target_faces=2, metric=PlaneFanMetric(), boundary="lock")
    assert r.n_collapses == 0 and r.stop_reason == "no_valid_collapse"
    assert r.report["held_back"]["fixed"] == 5


def test_flat_disk_is_removed_down_to_its_boundary():
    m = polar_disk()
    r = lodkit.simplify(m, target_faces=0, metric=PlaneFanMetric(), boundary="lock")
    assert r.stop_reason == "no_valid_collapse"
    boundary = np.arange(m.n_vertices - 12, m.n_vertices)
    np.testing.assert_array_equal(r.vertex_map, boundary)
    assert r.mesh.n_faces == 12 - 2
    assert r.error == 0.0
    assert lodkit.topology(r.mesh).n_boundary_loops == 1


def test_flat_grid_with_free_boundary_goes_down_to_two_triangles():
    xs, ys = np.meshgrid(np.arange(6.0), np.arange(5.0))
    v = np.c_[xs.ravel(), ys.ravel(), np.zeros(xs.size)]
    f = []
    for j in range(4):
        for i in range(5):
            a = j * 6 + i
            f += [[a, a + 1, a + 7], [a, a + 7, a + 6]]
    m = lodkit.Mesh(v, np.array(f))
    r = lodkit.simplify(m, max_error=1e-12, metric=PlaneFanMetric(), boundary="preserve")
    # the collinear border vertices go too (0 from the border line): the four corners stay
    np.testing.assert_array_equal(r.vertex_map, [0, 5, 24, 29])
    assert r.mesh.n_faces == 2 and r.error == 0.0 and r.stop_reason == "max_error"
    # without an error bound a corner goes as well (an open star of three: one triangle left)
    r = lodkit.simplify(m, target_faces=0, metric=PlaneFanMetric(), boundary="preserve")
    assert r.mesh.n_faces == 1 and r.stop_reason == "no_valid_collapse"


def test_tetrahedron_is_the_floor_of_a_closed_surface():
    v = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1], [0.6, -0.6, 0.6]], dtype=float)
    # a tetrahedron (outward faces) with its face (0, 3, 1) raised into a pyramid: 6 faces
    f = np.array([[0, 1, 2], [0, 2, 3], [1, 3, 2], [0, 3, 4], [3, 1, 4], [1, 0, 4]])
    m = lodkit.Mesh(v, f)
    assert lodkit.topology(m).is_closed
    r = lodkit.simplify(m, target_faces=0, metric=PlaneFanMetric())
    assert r.mesh.n_faces == 4 and r.stop_reason == "no_valid_collapse"
    assert signed_volume(m) > 0 and signed_volume(r.mesh) > 0
    assert r.report["held_back"]["topology"] == 4


def test_max_error_stops_removal():
    m = polar_disk()
    v = m.vertices.copy()
    v[0, 2] = 0.5                         # a bump at the centre
    m = lodkit.Mesh(v, m.faces)
    r = lodkit.simplify(m, max_error=1e-9, metric=PlaneFanMetric(), boundary="lock", record=True)
    assert r.stop_reason == "max_error"
    assert 0 in r.vertex_map                  # the bump stays
    assert (r.collapses["error"] <= 1e-9).all() and r.error <= 1e-9
    assert r.report["held_back"]["max_error"] >= 1


def test_deterministic_and_counts():
    m = polar_disk(rings=6, per_ring=16, rng=np.random.default_rng(3))
    v = m.vertices.copy()
    v[:, 2] = 0.1 * np.sin(v[:, 0]) * np.cos(v[:, 1])
    m = lodkit.Mesh(v, m.faces)
    a = lodkit.simplify(m, target_ratio=0.3, metric=PlaneFanMetric(), record=True)
    b = lodkit.simplify(m, target_ratio=0.3, metric=PlaneFanMetric(), record=True)
    np.testing.assert_array_equal(a.mesh.faces, b.mesh.faces)
    np.testing.assert_array_equal(a.face_map, b.face_map)
    for key in ("removed", "link", "new_faces", "cost"):
        np.testing.assert_array_equal(a.collapses[key], b.collapses[key])
    assert a.n_collapses == len(a.collapses["removed"]) == m.n_vertices - a.mesh.n_vertices
    rec = a.collapses
    k = np.diff(rec["link_offsets"])
    np.testing.assert_array_equal(np.diff(rec["new_face_offsets"]), k - 2)
    np.testing.assert_array_equal(np.diff(rec["old_face_offsets"]), np.where(rec["closed"], k, k - 1))


def test_record_replays_to_the_output():
    """Applying the recorded removals to the input faces, in order, gives the output."""
    m = polar_disk(rings=5, per_ring=14, rng=np.random.default_rng(7))
    v = m.vertices.copy()
    v[:, 2] = 0.05 * v[:, 0] ** 2
    m = lodkit.Mesh(v, m.faces)
    r = lodkit.simplify(m, target_ratio=0.25, metric=PlaneFanMetric(), record=True)
    rec = r.collapses
    faces = cyclic(m.faces)
    for i in range(len(rec["removed"])):
        old = cyclic(rec["old_faces"][rec["old_face_offsets"][i]:rec["old_face_offsets"][i + 1]])
        new = cyclic(rec["new_faces"][rec["new_face_offsets"][i]:rec["new_face_offsets"][i + 1]])
        assert old <= faces
        faces = (faces - old) | new
    assert faces == cyclic(r.vertex_map[r.mesh.faces])


# ---------------------------------------------------------------------- gated kernels
@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 0.1, 0.3]), st.booleans())
def test_gated_removals_respect_the_median(seed, nan_share, ties):
    """Step by step, against a brute-force median of the candidates' gates."""
    rng = np.random.default_rng(seed)
    m = polar_disk(rings=5, per_ring=12, rng=rng)
    v = m.vertices.copy()
    v[:, 2] = rng.uniform(0, 0.05) * v[:, 0] ** 2
    m = lodkit.Mesh(v, m.faces)
    if ties:
        gate = rng.choice([0.5, 1.0, 2.0, 6.283185307179586], size=m.n_vertices)
    else:
        gate = rng.normal(size=m.n_vertices)
    gate[rng.random(m.n_vertices) < nan_share] = np.nan
    prep = lodkit.api.prepare(m)
    hm = prep.hm
    k = PlaneFan()
    k.prepare(None, {"gate": gate[prep.input_vertex]})
    vr = VertexRemover(hm, prep.positions, k, hm.boundary_vertices, boundary=1, record=True)
    assert vr.gated
    g = gate[prep.input_vertex]
    done = checked = 0
    while True:
        cand = np.flatnonzero(vr.states == STATE_NAMES.index("candidate"))
        vals = np.sort(g[cand][~np.isnan(g[cand])])
        med = vals[(len(vals) + 1) // 2 - 1] if len(vals) else None
        assert vr.median == med
        # the heap holds exactly the candidates whose gate is >= the median
        assert vr.n_candidates == (0 if med is None else int(np.count_nonzero(vals >= med)))
        refused = sum(vr.refusals.values())
        status = vr.run(0, 1)
        if vr.n_collapses == done:
            break
        done = vr.n_collapses
        removed = vr.records()["removed"][-1]
        if sum(vr.refusals.values()) == refused:
            # no candidate was refused on the way (a refusal leaves the median's set and
            # may lower it): the removed vertex competed against this median
            assert g[removed] >= med
            checked += 1
    assert status == 2 and checked > done / 2
    # NaN-gated vertices are never removed; vertices below every median stay
    assert hm.alive_vertices[np.flatnonzero(np.isnan(g) & ~hm.boundary_vertices)].all()


def test_flat_region_all_equal_gates_is_removed():
    """With ">=" a flat region, where every gate is the same (2 pi in Chuon-Guha), is
    removed; with ">" nothing could ever be."""
    m = polar_disk()
    r = lodkit.simplify(m, target_faces=0, metric=PlaneFanMetric(gate=np.full(m.n_vertices, 2 * np.pi)),
                        boundary="lock")
    assert r.report["gated"] and r.mesh.n_faces == 10


def test_record_buffers_grow():
    """The record arrays grow (with the GIL, between nogil chunks) when a run outgrows them."""
    m = polar_disk(rings=5, per_ring=14, rng=np.random.default_rng(2))
    runs = []
    for small in (False, True):
        prep = lodkit.api.prepare(m)
        k = PlaneFan()
        k.prepare(None, {})
        vr = VertexRemover(prep.hm, prep.positions, k, prep.hm.boundary_vertices, record=True)
        if small:
            vr._alloc_records(16)            # room for two or three stars: grown many times
        vr.run(0)
        runs.append(vr.records())
    assert len(runs[0]["removed"]) > 20
    for key in runs[0]:
        np.testing.assert_array_equal(runs[0][key], runs[1][key])


def test_open3d_progress_and_absolute_error(capsys):
    o3d = pytest.importorskip("open3d")
    m = polar_disk()
    v = m.vertices.copy()
    v[:, 2] = 0.02 * v[:, 0] ** 2
    m = lodkit.Mesh(v * 10.0, m.faces)
    tm = m.to_open3d()
    r = lodkit.simplify(tm, target_ratio=0.3, metric=PlaneFanMetric(), progress=True, absolute=True)
    assert isinstance(r.mesh, o3d.geometry.TriangleMesh)
    assert "100%" in capsys.readouterr().err           # the bar was drawn to the end
    rel = lodkit.simplify(m, target_ratio=0.3, metric=PlaneFanMetric())
    scale = np.linalg.norm(m.vertices.max(0) - m.vertices.min(0))
    assert r.error == pytest.approx(rel.error * scale)
    assert len(np.asarray(r.mesh.triangles)) == rel.mesh.n_faces


# ---------------------------------------------------------------------- errors
def test_removal_metric_cannot_be_combined():
    with pytest.raises(MetricError, match="runs alone"):
        lodkit.simplify(hexagon(), target_faces=4, metric=[PlaneFanMetric(), "qem"])


def test_kernel_failure_and_contract_errors_raise_metric_error():
    with pytest.raises(MetricError, match="evaluation budget"):
        lodkit.simplify(polar_disk(), target_faces=0, metric=PlaneFanMetric(fail_after=30))
    with pytest.raises(MetricError, match="no oriented triangulation"):
        lodkit.simplify(polar_disk(), target_faces=0, metric=PlaneFanMetric(invalid=True))


def test_kernel_claiming_too_many_triangles():
    # a plugin's n_tris is not trusted: the run fails with MetricError, and the test API
    # never reads past Removal.tri (3 * MAX_VALENCE ints)
    with pytest.raises(MetricError, match="no oriented triangulation"):
        lodkit.simplify(polar_disk(), target_faces=0, metric=PlaneFanMetric(n_tris=100000))
    prep = lodkit.api.prepare(polar_disk())
    k = PlaneFan()
    k.prepare(None, {"n_tris": 100000})
    vr = VertexRemover(prep.hm, prep.positions, k, prep.hm.boundary_vertices)
    state, _, _, _, tris = vr.evaluate_vertex(0)
    assert state == "candidate" and tris.shape == (64, 3)


@pytest.mark.parametrize("n", [63, 64, 65, 200])
def test_high_valence_stars(n):
    """A star of n link vertices, closed (a disc's centre) or open (a boundary vertex): up
    to MAX_VALENCE = 64 it is removed (the fixed-size Star / Removal arrays filled to the
    brim), above it the vertex is held back as 'valence'."""
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    disc = lodkit.Mesh(np.vstack([np.c_[np.cos(t), np.sin(t), np.zeros(n)], [0.0, 0.0, 0.01]]),
                       np.array([[n, i, (i + 1) % n] for i in range(n)]))
    t = np.linspace(0.0, np.pi, n)
    half = lodkit.Mesh(np.vstack([np.c_[np.cos(t), np.sin(t), np.zeros(n)], [0.0, -0.01, 0.0]]),
                       np.array([[n, i, i + 1] for i in range(n - 1)]))
    for mesh in (disc, half):
        r = lodkit.simplify(mesh, target_faces=0, metric=PlaneFanMetric(), locked=np.arange(n),
                            min_quality=0.0)
        assert lodkit.topology(r.mesh).is_manifold
        if n <= 64:
            assert r.n_collapses == 1 and n not in r.vertex_map
            assert r.mesh.n_faces == n - 2
        else:
            assert r.n_collapses == 0 and r.report["held_back"]["valence"] == 1
            assert r.mesh.n_faces == mesh.n_faces


def test_kernel_veto_is_reported():
    m = polar_disk()
    r = lodkit.simplify(m, target_faces=0, metric=PlaneFanMetric(veto=np.ones(m.n_vertices)), boundary="lock")
    assert r.n_collapses == 0 and r.stop_reason == "no_valid_collapse"
    assert r.report["vetoed"] > 0 and "vetoed every removal" in r.report["stop_detail"]


def test_pair_threshold_is_refused():
    with pytest.raises(OptionError):
        lodkit.simplify(hexagon(), target_faces=4, metric=PlaneFanMetric(), pair_threshold=0.1)


def test_locked_vertices_stay():
    m = polar_disk()
    r = lodkit.simplify(m, target_faces=0, metric=PlaneFanMetric(), boundary="lock", locked=[0, 5])
    assert {0, 5} <= set(r.vertex_map.tolist())


# ---------------------------------------------------------------------- properties
def check_removal_result(mesh, result, target, angle=90.0):
    out = result.mesh
    before, after = lodkit.topology(mesh), lodkit.topology(out)
    np.testing.assert_array_equal(out.vertices, mesh.vertices[result.vertex_map])   # a subset, exact
    assert np.all(np.diff(result.vertex_map) > 0)
    assert len(np.unique(result.face_map)) == out.n_faces
    assert after.is_edge_manifold and after.is_vertex_manifold and after.is_manifold
    assert after.n_degenerate_faces == 0 and after.n_duplicate_faces == 0
    assert after.genus == before.genus
    assert after.n_boundary_loops == before.n_boundary_loops
    assert after.n_components == before.n_components
    assert after.is_oriented
    assert np.all(np.linalg.norm(out.face_normals(), axis=1) > 0.5)
    if before.is_closed:
        assert signed_volume(out) > 0
    if result.stop_reason == "target_faces":
        assert out.n_faces in (target, target - 1)
    else:
        assert result.stop_reason in ("no_valid_collapse", "max_error") and out.n_faces > target
    assert result.n_collapses == mesh.n_vertices - out.n_vertices


def no_flip_against_input(mesh, result, angle=90.0):
    """Every output face within min(angle, 90) degrees of the input face it stands for
    (face_map), as for the collapse driver."""
    n_in = mesh.face_normals()[result.face_map]
    dots = np.einsum("ij,ij->i", n_in, result.mesh.face_normals())
    assert dots.min() >= np.cos(np.radians(min(angle, 90.0))) - 1e-9


@SETTINGS
@given(manifold_meshes(), st.floats(0.02, 0.9), st.sampled_from(["preserve", "lock", "free"]),
       st.sampled_from([90.0, 60.0]))
def test_removal_properties(case, ratio, boundary, angle):
    kind, mesh = case
    r = lodkit.simplify(mesh, target_ratio=ratio, metric=PlaneFanMetric(), boundary=boundary,
                        max_normal_angle=angle)
    target = int(round(ratio * mesh.n_faces))
    check_removal_result(mesh, r, target, angle)
    no_flip_against_input(mesh, r, angle)
    if boundary == "lock" and not lodkit.topology(mesh).is_closed:
        hm = lodkit.api.prepare(mesh).hm
        border = np.flatnonzero(hm.boundary_vertices)
        assert np.isin(border, r.vertex_map).all()
    again = lodkit.simplify(mesh, target_ratio=ratio, metric=PlaneFanMetric(), boundary=boundary,
                            max_normal_angle=angle)
    np.testing.assert_array_equal(r.mesh.faces, again.mesh.faces)


# ---------------------------------------------------------------------- real meshes
@functools.cache
def load(name):
    return lodkit.load(shared_mesh(name))


@pytest.mark.parametrize("name", ["bunny.ply", "cow.obj", "boot.obj"])
def test_real_meshes(name):
    mesh = load(name)
    target = int(round(0.1 * mesh.n_faces))
    r = lodkit.simplify(mesh, target_ratio=0.1, metric=PlaneFanMetric())
    assert r.stop_reason == "target_faces", r.report["stop_detail"]
    check_real_result(mesh, r, target, max_error=0.05)      # topology, no flip vs face_map
    before, after = lodkit.topology(mesh), lodkit.topology(r.mesh)
    assert after.n_nonmanifold_vertices == before.n_nonmanifold_vertices    # the cow's pinch
    assert after.genus == before.genus                                          # boot: 12
    np.testing.assert_array_equal(r.mesh.vertices, mesh.vertices[r.vertex_map])


def _face_map_cosines(mesh, r):
    """Cosine of the angle between each output face's normal and its face_map input face's."""
    a = mesh.face_normals()[r.face_map]
    b = r.mesh.face_normals()
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    return np.einsum("ij,ij->i", a, b)


@pytest.mark.parametrize("metric", ["schroeder", "volume"])
@pytest.mark.parametrize("name", ["boot.obj", "fandisk.obj", "bunny.ply", "cow.obj"])
def test_real_meshes_no_face_flipped_against_its_face_map_face(name, metric):
    """docs/algorithms.md "Slots, face_map": every output face stays within
    min(max_normal_angle, 90) degrees of the input face it stands for (check 3(c)); at 10%
    and 2% (runs that stop short of the target included), and within 60 degrees when asked."""
    mesh = load(name)
    for ratio in (0.1, 0.02):
        r = lodkit.simplify(mesh, target_ratio=ratio, metric=metric)
        assert r.mesh.n_faces < 0.35 * mesh.n_faces
        cos = _face_map_cosines(mesh, r)
        assert cos.min() >= -1e-9, (ratio, cos.min())
    r = lodkit.simplify(mesh, target_ratio=0.1, metric=metric, max_normal_angle=60.0)
    assert _face_map_cosines(mesh, r).min() >= 0.5 - 1e-9


@pytest.mark.parametrize("name", ["fandisk.obj", "cow.obj"])
def test_star_local_cache_gives_the_same_run(name):
    """schroeder and volume say star_local = True: a popped candidate's triangles come from
    the cache instead of a second evaluation.  The same kernels without the flag (evaluated
    again on every pop) give the same run, with more kernel calls."""
    from lodkit._core import vremove
    from lodkit._core.schroeder_kernel import SchroederKernel
    from lodkit._core.volume_kernel import VolumeKernel
    from lodkit.metrics.schroeder import Schroeder
    from lodkit.metrics.volume import Volume

    class PlainSchroederKernel(SchroederKernel):
        star_local = False

    class PlainVolumeKernel(VolumeKernel):
        star_local = False

    class PlainSchroeder(Schroeder):
        kernel = PlainSchroederKernel

    class PlainVolume(Volume):
        kernel = PlainVolumeKernel

    made = []

    class Counting(vremove.VertexRemover):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            made.append(self)

    mesh = load(name)
    original = vremove.VertexRemover
    vremove.VertexRemover = Counting
    try:
        for cached, plain in (("schroeder", PlainSchroeder()), ("volume", PlainVolume())):
            made.clear()
            a = lodkit.simplify(mesh, target_ratio=0.02, metric=cached)
            b = lodkit.simplify(mesh, target_ratio=0.02, metric=plain)
            assert made[0].star_local and not made[1].star_local
            np.testing.assert_array_equal(a.mesh.faces, b.mesh.faces)
            np.testing.assert_array_equal(a.face_map, b.face_map)
            np.testing.assert_array_equal(a.vertex_map, b.vertex_map)
            assert a.error == b.error and a.n_collapses == b.n_collapses > 0
            assert a.report["held_back"] == b.report["held_back"]
            assert made[0].n_evaluations < made[1].n_evaluations
            assert 1 <= made[0].n_rescans <= 4
    finally:
        vremove.VertexRemover = original


def test_real_mesh_with_uvs_keeps_attributes_and_seams():
    mesh = load("spot_triangulated.obj")
    r = lodkit.simplify(mesh, target_ratio=0.2, metric=PlaneFanMetric())
    np.testing.assert_array_equal(r.mesh.uvs, mesh.uvs[r.vertex_map])
    assert r.report["seams"]["fixed_vertices"] > 0
    assert lodkit.topology(r.mesh).n_boundary_loops == lodkit.topology(mesh).n_boundary_loops


@settings(max_examples=200, deadline=None)
@given(face_soups(), st.sampled_from([0.0, 0.3, 0.7]), st.sampled_from(["preserve", "lock", "free"]))
def test_face_soups_are_not_damaged(mesh, ratio, boundary):
    """Non-manifold input: the cut edges and split vertices are locked, the weld rule holds
    across the copies -- nothing non-manifold or duplicated is added."""
    target = {"target_faces": 0} if ratio == 0 else {"target_ratio": ratio}     # target_ratio=0 is refused
    r = lodkit.simplify(mesh, **target, metric=PlaneFanMetric(), boundary=boundary)
    before, after = lodkit.topology(mesh), lodkit.topology(r.mesh)
    assert after.n_degenerate_faces == 0
    assert after.n_duplicate_faces <= before.n_duplicate_faces
    assert after.n_nonmanifold_edges <= before.n_nonmanifold_edges
    assert after.n_nonmanifold_vertices <= before.n_nonmanifold_vertices
    assert after.n_components == before.n_components
    assert after.euler_characteristic == before.euler_characteristic
    np.testing.assert_array_equal(r.mesh.vertices, mesh.vertices[r.vertex_map])


@pytest.mark.parametrize("name", BROKEN)
def test_broken_meshes(name):
    mesh = load(name)
    r = lodkit.simplify(mesh, target_ratio=0.1, metric=PlaneFanMetric())
    before, after = lodkit.topology(mesh), lodkit.topology(r.mesh)
    assert after.n_nonmanifold_edges <= before.n_nonmanifold_edges
    assert after.n_nonmanifold_vertices <= before.n_nonmanifold_vertices
    assert after.n_degenerate_faces == 0
    assert after.genus == before.genus or not before.is_manifold
    target = int(round(0.1 * mesh.n_faces))
    assert r.mesh.n_faces in (target, target - 1) or (r.stop_reason == "no_valid_collapse" and r.mesh.n_faces > target)


# ---------------------------------------------------------------------- stubs
@pytest.mark.parametrize("module", ["vremove", "retriangulate"])
def test_stubs_name_every_python_visible_name(module):
    from test_metrics import _stub_names

    path = REPO / "lodkit" / "_core" / f"{module}.pyi"
    if not path.exists():
        pytest.skip(f"{module}.pyi not written yet")
    mod = importlib.import_module(f"lodkit._core.{module}")
    stub = _stub_names(path)
    public = {n for n, o in vars(mod).items() if not n.startswith("_") and n != "np"
              and getattr(o, "__module__", mod.__name__) == mod.__name__}
    assert public <= set(stub), f"not in {module}.pyi: {sorted(public - set(stub))}"
    for name, members in stub.items():
        obj = getattr(mod, name, None)
        assert obj is not None, f"{module}.pyi names {name}, which the module lacks"
        if isinstance(obj, type):
            visible = {n for n in vars(obj) if not n.startswith("__") or n in ("__init__", "__len__", "__contains__")}
            assert visible <= members, f"{module}.{name}: not in the stub: {sorted(visible - members)}"
