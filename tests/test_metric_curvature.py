"""The ``curvature`` metric (Wang et al. 2011) and lodkit.point_curvature.

Analytic answers with stated tolerances (sphere, plane, cube), a slow obviously-correct
reference loop for the vectorised estimator, exact edge weights on hand-made meshes, and
invariants of whole runs on real meshes.
"""
from __future__ import annotations

import ast
import functools
import importlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

import lodkit
from conftest import shared_mesh
from lodkit import MeshError, OptionError
from lodkit.curvature import normalized_curvature, point_curvature
from lodkit.metrics import BatchMetric
from lodkit.metrics.curvature import Curvature

REPO = Path(__file__).resolve().parent.parent


# ---------------------------------------------------------------------- helpers
def random_sphere(n, seed=0):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def fibonacci_sphere(n):
    """Nearly uniform points on the unit sphere: every point's neighbours surround it."""
    i = np.arange(n) + 0.5
    phi = np.arccos(1.0 - 2.0 * i / n)
    theta = np.pi * (1.0 + 5.0 ** 0.5) * i
    return np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], axis=1)


def reference_curvature(points, k=None, radius=None):
    """The paper's eqs. 1-4, one point at a time, brute force: the obviously-correct twin
    of the vectorised code (neighbours: other distinct positions; numpy eigh)."""
    points = np.asarray(points, dtype=np.float64)
    uniq, inverse = np.unique(points, axis=0, return_inverse=True)
    out = np.zeros(uniq.shape[0])
    for i, p in enumerate(uniq):
        dist = np.linalg.norm(uniq - p, axis=1)
        others = np.flatnonzero(np.arange(uniq.shape[0]) != i)
        if radius is None:
            nbr = others[np.argsort(dist[others], kind="stable")[:k]]
        else:
            nbr = others[dist[others] <= radius]
        if nbr.size < 3:
            continue
        q = uniq[nbr]
        c = q.mean(axis=0)                                   # eq. 1
        C = sum(np.outer(x - c, x - c) for x in q)           # eq. 2
        lam, vec = np.linalg.eigh(C)
        if not lam[1] > 1e-10 * lam[2]:
            continue                                         # collinear: no plane
        d = abs(vec[:, 0] @ (p - c))                          # eq. 3
        mu = dist[nbr].mean()
        out[i] = 2.0 * d / mu ** 2                            # eq. 4
    return out[inverse.reshape(-1)]


def octahedron():
    """An irregular octahedron: +-x at 1, +-y at 2, +-z at 3 (so edges differ in length)."""
    v = np.array([[1, 0, 0], [-1, 0, 0], [0, 2, 0], [0, -2, 0], [0, 0, 3], [0, 0, -3]], float)
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4],
                  [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    return lodkit.Mesh(v, f)


def bumpy_grid(n=12):
    """A height field z = 0.3 sin(x) cos(y) on an n x n grid over [0, 3]^2."""
    x, y = np.meshgrid(np.linspace(0, 3, n), np.linspace(0, 3, n))
    v = np.stack([x.ravel(), y.ravel(), 0.3 * np.sin(x.ravel()) * np.cos(y.ravel())], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    f = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return lodkit.Mesh(v, f)


def normalised(vertices):
    """lodkit's working coordinates: bbox centre at the origin, unit diagonal."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    return (vertices - (0.5 * lo + 0.5 * hi)) / np.linalg.norm(hi - lo)


class _Stop(Exception):
    pass


class Capture(BatchMetric):
    """Sees the first pass's candidates (cost = everything before it) and stops the run."""

    def costs(self, batch):
        self.seen = {"edge": batch.edge.copy(), "u": batch.u.copy(), "v": batch.v.copy(),
                     "cost": batch.cost.copy(), "position": batch.position.copy(),
                     "positions": np.array(batch.positions)}
        raise _Stop


def first_pass(mesh, metric, **kw):
    cap = Capture()
    metrics = (metric if isinstance(metric, list) else [metric]) + [cap]
    with pytest.raises(_Stop):
        lodkit.simplify(mesh, target_faces=0, metric=metrics, **kw)
    return cap.seen


RELAXED = {"max_normal_angle": 180.0, "min_quality": 0.0}


# ---------------------------------------------------------------------- analytic answers
@pytest.mark.parametrize("r", [0.01, 1.0, 250.0])
def test_sphere_curvature_is_one_over_r(r):
    # 2d/mu^2 with d ~ E[rho^2] / (2r) (the neighbours' mean depth below the tangent plane)
    # and mu = E[rho] gives k = (1/r) E[rho^2] / E[rho]^2 >= 1/r (Jensen): for neighbours
    # spread evenly over a disc the factor is 9/8; measured median 1.07 at k = 16.
    kr = point_curvature(r * random_sphere(3000), k=16) * r
    assert 1.0 <= np.median(kr) <= 1.125
    assert np.percentile(kr, 5) > 0.6 and np.percentile(kr, 95) < 1.4


def test_sphere_bias_is_the_neighbour_distance_spread():
    # on nearly uniform samples the estimate is (1/r) E[rho^2]/E[rho]^2 (the spread of the
    # neighbour distances rho): within 0.5% at the median point; the rest comes from the
    # fitted plane tilting where the k nearest are lopsided (a k = 6 ring on a spiral
    # lattice ties with the 7th point).  Measured: |error| 90th percentile 7.3% (k = 6),
    # 1.1% (k = 16); largest 11% (k = 6), 4.6% (k = 16).
    p = fibonacci_sphere(4000)
    for k, p90, worst in ((6, 0.08, 0.12), (16, 0.02, 0.05)):
        kr = point_curvature(p, k=k)
        d, _ = cKDTree(p).query(p, k + 1)
        d = d[:, 1:]
        spread = (d ** 2).mean(axis=1) / d.mean(axis=1) ** 2
        err = np.abs(kr / spread - 1.0)
        assert np.median(err) < 0.005
        assert np.percentile(err, 90) < p90 and err.max() < worst
        assert np.all((kr > 0.9) & (kr < 1.1))


def test_scaling_the_cloud_scales_the_curvature_exactly():
    p = random_sphere(500, seed=4)
    k1 = point_curvature(p)
    np.testing.assert_allclose(point_curvature(4.0 * p), k1 / 4.0, rtol=1e-12, atol=0)
    np.testing.assert_allclose(point_curvature(p, radius=0.3), 4.0 * point_curvature(4 * p, radius=1.2),
                               rtol=1e-12, atol=0)


def test_plane_has_zero_curvature():
    rng = np.random.default_rng(5)
    uv = rng.uniform(-1, 1, size=(2000, 2))
    flat = np.column_stack([uv, np.zeros(2000)])
    assert np.all(point_curvature(flat) == 0.0)                  # exactly: every z is 0
    # a tilted, shifted plane: zero up to rounding (spacing ~0.05, so 1/r ~ 20 for a bend)
    basis = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    tilted = flat @ basis.T + np.array([3.0, -7.0, 11.0])
    assert point_curvature(tilted).max() < 1e-9
    assert point_curvature(tilted, radius=0.15).max() < 1e-9


def test_normalisation():
    k = point_curvature(random_sphere(800, seed=6) * np.array([1.0, 2.0, 3.0]))   # an ellipsoid
    w = point_curvature(random_sphere(800, seed=6) * np.array([1.0, 2.0, 3.0]), normalize=True)
    assert w.max() == 1.0 and w.min() >= 0.0
    np.testing.assert_allclose(w, k / k.max(), rtol=1e-15)
    assert np.all(normalized_curvature(np.zeros(5)) == 0.0)
    assert normalized_curvature(np.zeros(0)).shape == (0,)


def cube_points(step=0.1):
    """A grid of points on each face of the cube [-1, 1]^3 (edges and corners shared)."""
    t = np.arange(-1.0, 1.0 + step / 2, step)
    a, b = np.meshgrid(t, t)
    a, b = a.ravel(), b.ravel()
    faces = []
    for axis in range(3):
        for side in (-1.0, 1.0):
            f = np.empty((a.size, 3))
            f[:, axis] = side
            f[:, (axis + 1) % 3] = a
            f[:, (axis + 2) % 3] = b
            faces.append(f)
    return np.concatenate(faces)


def test_cube_corners_and_edges_are_sharper_than_faces():
    p = cube_points()
    k = point_curvature(p)

    def at(x):
        return k[np.flatnonzero(np.all(np.isclose(p, x), axis=1))[0]]

    face_centre = at([0, 0, 1])
    edge_mid = at([1, 0, 1])
    corner = at([1, 1, 1])
    assert face_centre == 0.0                  # its 16 neighbours lie in its face's plane
    assert edge_mid > 1.0 and corner > 1.0     # 1/step = 10: a crease spans ~one spacing
    on_face = np.sum(np.abs(p) > 0.75, axis=1) == 1          # 2.5 spacings or more from an edge
    on_edge = np.sum(np.isclose(np.abs(p), 1.0), axis=1) >= 2
    assert k[on_face].max() == 0.0             # more than two spacings from any edge
    assert np.min(k[on_edge]) > k[on_face].max()


# ---------------------------------------------------------------------- modes, degenerate input
def test_vectorised_code_matches_the_reference_loop():
    rng = np.random.default_rng(7)
    p = random_sphere(270, seed=7) * np.array([1.0, 1.5, 0.7]) + 0.02 * rng.normal(size=(270, 3))
    p = np.concatenate([p, p[:30]])            # 30 exact copies
    rng.shuffle(p)
    for k in (3, 8, 16):
        np.testing.assert_allclose(point_curvature(p, k=k), reference_curvature(p, k=k),
                                   rtol=1e-7, atol=1e-9)
    for radius in (0.2, 0.45):
        np.testing.assert_allclose(point_curvature(p, radius=radius), reference_curvature(p, radius=radius),
                                   rtol=1e-7, atol=1e-9)


def test_radius_mode_on_a_sphere():
    p = random_sphere(3000, seed=8)
    k_rad = point_curvature(p, radius=0.15)
    # neighbours spread over a disc: factor E[rho^2]/E[rho]^2 = 9/8 when the disc is full
    assert 1.0 <= np.median(k_rad) <= 1.2
    # a radius holding about as many points as k = 16 gives a similar estimate
    assert abs(np.median(k_rad) - np.median(point_curvature(p, k=16))) < 0.1
    # no neighbour within the radius: 0, not NaN
    assert np.all(point_curvature(p, radius=1e-6) == 0.0)


def test_copies_share_their_position_curvature():
    p = random_sphere(400, seed=9)
    k = point_curvature(p)
    tripled = np.concatenate([p, p, p[::-1]])
    kt = point_curvature(tripled)
    np.testing.assert_array_equal(kt[:400], k)
    np.testing.assert_array_equal(kt[400:800], k)
    np.testing.assert_array_equal(kt[800:], k[::-1])
    # -0.0 and 0.0 are the same position
    q = np.array([[0.0, 0, 0], [-0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0.3]])
    kq = point_curvature(q, k=4)
    assert kq[0] == kq[1]


@pytest.mark.parametrize("points", [
    np.zeros((0, 3)),
    np.array([[1.0, 2.0, 3.0]]),
    np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [1.0, 2.0, 3.0]]),                  # one position
    np.array([[0.0, 0, 0], [1, 0, 0]] * 5),                                         # two positions
    np.column_stack([np.linspace(0, 1, 50), 2 * np.linspace(0, 1, 50), np.zeros(50)]),  # a line
])
def test_degenerate_clouds_give_zero(points):
    for kw in ({}, {"k": 3}, {"radius": 0.5}):
        k = point_curvature(points, **kw)
        assert k.shape == (points.shape[0],)
        assert np.all(k == 0.0)


def test_fewer_points_than_k():
    p = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]])
    k = point_curvature(p, k=50)               # each point uses the other 4
    np.testing.assert_allclose(k, reference_curvature(p, k=4), rtol=1e-12)
    assert np.isfinite(k).all() and (k > 0).all()


def test_bad_input_raises_lodkit_errors():
    with pytest.raises(MeshError, match="NaN or inf.*row 1"):
        point_curvature([[0, 0, 0], [np.nan, 0, 0], [0, 1, 0], [1, 1, 1]])
    with pytest.raises(MeshError, match="shape"):
        point_curvature(np.zeros((4, 2)))
    with pytest.raises(MeshError, match="numeric"):
        point_curvature([["a", "b", "c"]])
    for k in (2, 0, -1, 3.5, True, "8"):
        with pytest.raises(OptionError, match="k must be"):
            point_curvature(random_sphere(10), k=k)
    for radius in (0.0, -1.0, np.inf, np.nan, "x"):
        with pytest.raises(OptionError, match="radius"):
            point_curvature(random_sphere(10), radius=radius)


@settings(max_examples=25, deadline=None)
@given(n=st.integers(4, 120), seed=st.integers(0, 2**32 - 1), copies=st.integers(0, 10),
       k=st.integers(3, 20))
def test_estimator_invariants(n, seed, copies, k):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3)) * rng.uniform(0.1, 10.0, size=3)
    p = np.concatenate([p, p[rng.integers(0, n, size=copies)]])
    curv = point_curvature(p, k=k)
    assert curv.shape == (p.shape[0],) and np.isfinite(curv).all() and (curv >= 0).all()
    perm = rng.permutation(p.shape[0])
    np.testing.assert_array_equal(point_curvature(p[perm], k=k), curv[perm])
    np.testing.assert_allclose(point_curvature(p * 8.0, k=k), curv / 8.0, rtol=1e-12, atol=0)
    shifted = point_curvature(p + rng.uniform(-5, 5, size=3), k=k)
    np.testing.assert_allclose(shifted, curv, rtol=1e-6, atol=1e-9 * max(curv.max(), 1.0))
    w = point_curvature(p, k=k, normalize=True)
    assert (w <= 1.0).all() and (w.max() == 1.0 or w.max() == 0.0)


# ---------------------------------------------------------------------- the edge weight
class HandCurvature(Curvature):
    """The curvature metric with hand-given normalised curvature per input vertex."""

    given = None

    def vertex_curvature(self, ctx):
        return np.asarray(self.given, dtype=np.float64)[ctx.input_vertex]


def hand(w, **options):
    m = HandCurvature(**options)
    m.given = w
    return m


def test_edge_weight_of_hand_made_edges():
    mesh = octahedron()
    w = np.array([0.0, 0.2, 0.4, 0.6, 0.8, 1.0])
    seen = first_pass(mesh, hand(w), **RELAXED)
    assert seen["edge"].size == 12                  # every edge of the octahedron may go
    # the diagonal of the bbox is |(2, 4, 6)| = sqrt(56): lengths in normalised units
    length = {frozenset((0, 2)): np.sqrt(5), frozenset((0, 3)): np.sqrt(5), frozenset((1, 2)): np.sqrt(5),
              frozenset((1, 3)): np.sqrt(5), frozenset((0, 4)): np.sqrt(10), frozenset((0, 5)): np.sqrt(10),
              frozenset((1, 4)): np.sqrt(10), frozenset((1, 5)): np.sqrt(10), frozenset((2, 4)): np.sqrt(13),
              frozenset((2, 5)): np.sqrt(13), frozenset((3, 4)): np.sqrt(13), frozenset((3, 5)): np.sqrt(13)}
    for u, v, cost in zip(seen["u"], seen["v"], seen["cost"]):
        expect = length[frozenset((int(u), int(v)))] / np.sqrt(56) * (0.01 + 0.5 * (w[u] + w[v]))
        assert cost == pytest.approx(expect, rel=1e-12)
    # e.g. the +x/+y edge: sqrt(5/56) * (0.01 + (0 + 0.4) / 2) = 0.0627495...
    i = [k for k, (u, v) in enumerate(zip(seen["u"], seen["v"])) if {int(u), int(v)} == {0, 2}][0]
    assert seen["cost"][i] == pytest.approx(0.06274950199005567, rel=1e-12)
    # floor 0 and weight 3: the paper's l * w_k, times 3
    seen = first_pass(mesh, hand(w, floor=0.0, weight=3.0), **RELAXED)
    for u, v, cost in zip(seen["u"], seen["v"], seen["cost"]):
        expect = 3.0 * length[frozenset((int(u), int(v)))] / np.sqrt(56) * 0.5 * (w[u] + w[v])
        assert cost == pytest.approx(expect, rel=1e-12, abs=1e-300)


def test_flat_edges_go_first_then_short_ones():
    mesh = octahedron()
    w = np.array([0.0, 0.0, 0.0, 0.0, 1.0, 1.0])    # the z tips are "creases"
    seen = first_pass(mesh, hand(w), **RELAXED)
    order = np.argsort(seen["cost"])
    ends = [frozenset((int(seen["u"][i]), int(seen["v"][i]))) for i in order]
    assert set(ends[:4]) == {frozenset(e) for e in ((0, 2), (0, 3), (1, 2), (1, 3))}   # flat, length sqrt 5
    assert set(ends[4:8]) == {frozenset(e) for e in ((0, 4), (0, 5), (1, 4), (1, 5))}  # sqrt 10 to a tip


def test_kernel_cost_equals_the_numpy_reference():
    mesh = bumpy_grid()
    for options in ({}, {"k": 8, "floor": 0.0}, {"radius": 0.6, "weight": 2.5}):
        seen = first_pass(mesh, ("curvature", options), **RELAXED)
        P = normalised(mesh.vertices)
        np.testing.assert_allclose(seen["positions"], P, rtol=0, atol=1e-15)
        metric = Curvature(**options)
        # the working coordinates themselves: on a regular grid the k-th nearest neighbour
        # ties with others, and which one wins may change with the last bit of a coordinate
        diag = np.linalg.norm(mesh.vertices.max(0) - mesh.vertices.min(0))
        radius = options["radius"] / diag if "radius" in options else None
        w = point_curvature(seen["positions"], k=metric.params["k"], radius=radius, normalize=True)
        u, v = seen["u"], seen["v"]
        length = np.linalg.norm(P[u] - P[v], axis=1)
        expect = metric.params["weight"] * length * (metric.params["floor"] + 0.5 * (w[u] + w[v]))
        assert seen["edge"].size > 100
        np.testing.assert_allclose(seen["cost"], expect, rtol=1e-9, atol=1e-15)


def test_scale_mode_multiplies_the_quadric_cost():
    mesh = bumpy_grid()
    plain = first_pass(mesh, "qem", **RELAXED)
    scaled = first_pass(mesh, ["qem", ("curvature", {"mode": "scale", "weight": 2.0})], **RELAXED)
    np.testing.assert_array_equal(plain["edge"], scaled["edge"])
    np.testing.assert_array_equal(plain["position"], scaled["position"])   # QEM places either way
    w = point_curvature(plain["positions"], normalize=True)     # working coordinates (grid ties)
    u, v = plain["u"], plain["v"]
    np.testing.assert_allclose(scaled["cost"], plain["cost"] * (1.0 + 2.0 * 0.5 * (w[u] + w[v])),
                               rtol=1e-12, atol=0)
    # replace mode (the default) discards the quadric cost: with or without qem it is omega
    a = first_pass(mesh, ["qem", "curvature"], **RELAXED)
    b = first_pass(mesh, "curvature", **RELAXED)
    np.testing.assert_array_equal(a["cost"], b["cost"])


def test_placement_default_is_the_core_and_midpoint_is_an_option():
    mesh = octahedron()
    w = np.linspace(0.0, 1.0, 6)
    qem = first_pass(mesh, "qem", **RELAXED)
    core = first_pass(mesh, hand(w), **RELAXED)
    np.testing.assert_array_equal(core["position"], qem["position"])
    mid = first_pass(mesh, hand(w, midpoint=True), **RELAXED)
    P = mid["positions"]
    np.testing.assert_allclose(mid["position"], 0.5 * (P[mid["u"]] + P[mid["v"]]), rtol=0, atol=1e-15)
    # an edge with an end on the boundary keeps the core's placement (the boundary rules)
    grid = bumpy_grid(6)
    seen = first_pass(grid, ("curvature", {"midpoint": True}), **RELAXED)
    core = first_pass(grid, "curvature", **RELAXED)
    np.testing.assert_array_equal(seen["edge"], core["edge"])
    P = seen["positions"]
    boundary = np.array([i % 6 in (0, 5) or i // 6 in (0, 5) for i in range(36)])
    at_border = boundary[seen["u"]] | boundary[seen["v"]]
    assert at_border.any() and (~at_border).any()
    inner = ~at_border
    np.testing.assert_allclose(seen["position"][inner], 0.5 * (P[seen["u"][inner]] + P[seen["v"][inner]]),
                               rtol=0, atol=1e-15)
    np.testing.assert_array_equal(seen["position"][at_border], core["position"][at_border])


def test_commit_merges_the_curvature_of_the_ends():
    from lodkit._core.curvature_kernel import MERGE_MAX, MERGE_MEAN, MODE_SCALE, CurvatureKernel

    k = CurvatureKernel()
    k.prepare(None, {"curvature": [0.1, 0.7, 0.4], "merge": "max"})
    assert k.merge == MERGE_MAX
    k._call("commit", 0, 1, 1, 0, (0, 0, 0), 0.0)        # 1 goes, 0 stays
    np.testing.assert_array_equal(k.curvature, [0.7, 0.7, 0.4])   # exact: max merge copies a value given
    k._call("commit", 2, 0, 0, 2, (0, 0, 0), 0.0)
    np.testing.assert_array_equal(k.curvature, [0.7, 0.7, 0.7])   # exact: max merge copies a value given
    k = CurvatureKernel()
    k.prepare(None, {"curvature": [0.1, 0.7, 0.4], "merge": "mean"})
    assert k.merge == MERGE_MEAN
    k._call("commit", 0, 1, 1, 0, (0, 0, 0), 0.0)
    np.testing.assert_allclose(k.curvature, [0.4, 0.7, 0.4])
    # scale mode on a bare candidate: cost * (1 + weight * mean w)
    k = CurvatureKernel()
    k.prepare(None, {"curvature": [0.2, 0.6], "mode": "scale", "weight": 0.5})
    assert k.mode == MODE_SCALE
    rc, cost, *_ = k._call("cost", 0, 1, 1, 0, (0, 0, 0), 8.0)
    assert rc == 0 and cost == pytest.approx(8.0 * (1.0 + 0.5 * 0.4), rel=1e-15)


def test_kernel_refuses_bad_curvature():
    from lodkit._core.curvature_kernel import CurvatureKernel

    with pytest.raises(ValueError, match="options\\['curvature'\\]"):
        CurvatureKernel().prepare(None, {})
    with pytest.raises(ValueError, match="finite"):
        CurvatureKernel().prepare(None, {"curvature": [0.1, np.nan]})
    with pytest.raises(ValueError, match="finite"):
        CurvatureKernel().prepare(None, {"curvature": [0.1, -1.0]})


# ---------------------------------------------------------------------- options, defaults
def test_options_are_validated():
    for bad in ({"k": 2}, {"k": 2.5}, {"radius": 0.0}, {"radius": -1.0}, {"floor": -0.1},
                {"merge": "sum"}, {"mode": "add"}, {"midpoint": 1}, {"size": 3}):
        with pytest.raises(OptionError):
            lodkit.simplify(octahedron(), target_faces=4, metric=("curvature", bad))
    assert Curvature().params == {"weight": 1.0, "k": 16, "radius": None, "floor": 0.01, "merge": "max",
                                  "mode": "replace", "midpoint": False}


def test_paper_checks_are_the_defaults_and_the_caller_wins():
    mesh = bumpy_grid()
    r = lodkit.simplify(mesh, target_ratio=0.5, metric="curvature")
    s = r.report["settings"]
    assert s["max_normal_angle"] == {"value": 60.0, "from": "metric curvature"}
    assert s["min_quality"] == {"value": 0.5, "from": "metric curvature"}
    assert s["placement"]["from"] == "lodkit" and s["boundary"]["from"] == "lodkit"
    r2 = lodkit.simplify(mesh, target_ratio=0.5, metric="curvature", max_normal_angle=75.0, min_quality=0.2)
    s = r2.report["settings"]
    assert s["max_normal_angle"] == {"value": 75.0, "from": "caller"}
    assert s["min_quality"] == {"value": 0.2, "from": "caller"}
    # the checks bind: every face made under the defaults has quality >= 0.5 or no worse
    # than the input face it stands for
    def quality(v, f):
        a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
        area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
        return 4 * np.sqrt(3) * area / (((b - a) ** 2).sum(1) + ((c - b) ** 2).sum(1) + ((a - c) ** 2).sum(1))
    q_out = quality(r.mesh.vertices, r.mesh.faces)
    q_in = quality(mesh.vertices, mesh.faces)[r.face_map]
    assert np.all((q_out >= 0.5 - 1e-9) | (q_out >= q_in - 1e-9))


def test_radius_option_is_in_model_units():
    mesh = bumpy_grid()
    big = lodkit.Mesh(mesh.vertices * 2.0, mesh.faces)   # x2 is exact: same working coordinates
    a = lodkit.simplify(mesh, target_ratio=0.3, metric=("curvature", {"radius": 0.6}))
    b = lodkit.simplify(big, target_ratio=0.3, metric=("curvature", {"radius": 1.2}))
    np.testing.assert_array_equal(a.mesh.faces, b.mesh.faces)
    np.testing.assert_array_equal(a.vertex_map, b.vertex_map)
    w = Curvature(radius=0.6).vertex_curvature(_ctx(mesh))
    np.testing.assert_allclose(w, point_curvature(mesh.vertices, radius=0.6, normalize=True), rtol=1e-9)


def _ctx(mesh):
    from lodkit.api import prepare
    from lodkit.metrics import MetricContext

    prep = prepare(mesh)
    return MetricContext(positions=prep.positions, halfedge=prep.hm, input_vertex=prep.input_vertex,
                         input_face=prep.input_face, fixed=np.zeros(prep.hm.n_vertices, bool),
                         scale=prep.scale, center=prep.center, mesh=mesh, face_quadrics=None)


# ---------------------------------------------------------------------- real meshes
@functools.cache
def load(name):
    return lodkit.load(shared_mesh(name))


@pytest.mark.parametrize("name", ["bunny.ply", "fandisk.obj"])
def test_real_mesh_invariants(name):
    mesh = load(name)
    before = lodkit.topology(mesh)
    r = lodkit.simplify(mesh, target_ratio=0.1, metric="curvature")
    after = lodkit.topology(r.mesh)
    assert r.stop_reason == "target_faces"
    assert r.mesh.n_faces in (round(0.1 * mesh.n_faces), round(0.1 * mesh.n_faces) - 1)
    assert np.isfinite(r.mesh.vertices).all() and np.isfinite(r.error)
    assert after.n_nonmanifold_edges == 0 and after.is_manifold == before.is_manifold
    assert after.genus == before.genus and after.n_boundary_loops == before.n_boundary_loops
    # no face turned over (the 60-degree check binds)
    n_in = mesh.face_normals()[r.face_map]
    assert np.all(np.einsum("ij,ij->i", n_in, r.mesh.face_normals()) > 0.0)
    # deterministic
    again = lodkit.simplify(mesh, target_ratio=0.1, metric="curvature")
    np.testing.assert_array_equal(again.mesh.faces, r.mesh.faces)
    np.testing.assert_array_equal(again.mesh.vertices, r.mesh.vertices)


def test_fandisk_reaches_2_percent_under_the_paper_quality():
    # Q >= 0.5 judged face by face left no legal collapse on fandisk's long crease strips
    # well before 2%; judged over the fan (a fan that held a sliver may keep one as bad,
    # issue 17) it reaches the target, and the paper's limit is never relaxed
    mesh = load("fandisk.obj")
    r = lodkit.simplify(mesh, target_ratio=0.02, metric="curvature")
    assert r.stop_reason == "target_faces"
    assert r.report["min_quality_relaxed_to"] is None
    assert r.report["settings"]["min_quality"] == {"value": 0.5, "from": "metric curvature"}


def crease_vertex_count(mesh, out, angle=30.0, within=0.005):
    """Output vertices within ``within`` x bbox diagonal of an input edge whose dihedral
    angle exceeds ``angle`` degrees."""
    v, f = mesh.vertices, mesh.faces
    fn = mesh.face_normals()
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    fid = np.tile(np.arange(f.shape[0]), 3)
    key = np.sort(e, axis=1)
    order = np.lexsort(key.T[::-1])
    ks, fo = key[order], fid[order]
    pair = np.flatnonzero(np.all(ks[1:] == ks[:-1], axis=1))
    dots = np.einsum("ij,ij->i", fn[fo[pair]], fn[fo[pair + 1]])
    crease = ks[pair][dots < np.cos(np.radians(angle))]
    t = np.linspace(0.0, 1.0, 20)[None, :, None]
    samples = (v[crease[:, 0]][:, None] * (1 - t) + v[crease[:, 1]][:, None] * t).reshape(-1, 3)
    d, _ = cKDTree(samples).query(out.vertices)
    return int(np.count_nonzero(d < within * np.linalg.norm(v.max(0) - v.min(0))))


@pytest.mark.parametrize("checks", [{}, {"max_normal_angle": 90.0, "min_quality": 0.1}])
def test_fandisk_keeps_more_vertices_near_creases_than_qem_under_equal_checks(checks):
    # measured (10%, 1,294 faces, 649 vertices each): the paper's checks 330 vs 236,
    # lodkit's 434 vs 329; the claim is "more", not those numbers
    mesh = load("fandisk.obj")
    both = checks or {"max_normal_angle": 60.0, "min_quality": 0.5}
    curv = lodkit.simplify(mesh, target_ratio=0.1, metric="curvature", **both)
    qem = lodkit.simplify(mesh, target_ratio=0.1, metric="qem", **both)
    assert curv.mesh.n_faces == qem.mesh.n_faces
    assert crease_vertex_count(mesh, curv.mesh) > 1.2 * crease_vertex_count(mesh, qem.mesh)


# ---------------------------------------------------------------------- the stub
def test_stub_names_every_python_visible_name():
    mod = importlib.import_module("lodkit._core.curvature_kernel")
    tree = ast.parse((REPO / "lodkit" / "_core" / "curvature_kernel.pyi").read_text())
    stub: dict = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            stub[node.name] = {item.name if isinstance(item, ast.FunctionDef) else item.target.id
                               for item in node.body if isinstance(item, (ast.FunctionDef, ast.AnnAssign))}
        elif isinstance(node, ast.AnnAssign):
            stub[node.target.id] = set()
    public = {n for n, o in vars(mod).items() if not n.startswith("_") and n != "np"
              and getattr(o, "__module__", mod.__name__) == mod.__name__}
    assert public == set(stub)
    visible = {n for n in vars(mod.CurvatureKernel) if not n.startswith("__")}
    assert visible == stub["CurvatureKernel"]
