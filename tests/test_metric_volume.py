"""The ``volume`` metric (Chuon & Guha: hyperbolic vertices, angle(V), ht(V), vol = angle·ht³,
the median filter, the closest-line fan).

Exact solid angles of known configurations, the hull classification against scipy
(ConvexHull and an LP) on random point sets including coplanar ones, angle(V) against two
independent references (Girard's spherical excess, and the paper's literal construction:
separating plane, projected polygon, Van Oosterom–Strackee fan), ht and vol by hand on a
pyramid, the closest-line apex on hand-made stars, and whole runs through
``lodkit.simplify(metric="volume")`` on small and real meshes.
"""
from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, QhullError

import lodkit
from conftest import shared_mesh
from lodkit import OptionError
from lodkit._core import volume_kernel as vk
from lodkit.metrics.volume import Volume

REPO = Path(__file__).resolve().parent.parent
TAU = 2.0 * math.pi


# ---------------------------------------------------------------------- references
def girard_area(U):
    """Area of the simple spherical polygon with unit vertices U (k, 3), counter-clockwise
    seen from outside the sphere: sum of interior angles - (k - 2) pi."""
    k = len(U)
    total = 0.0
    for i in range(k):
        a, b, c = U[i - 1], U[i], U[(i + 1) % k]
        t_next = c - (c @ b) * b
        t_prev = a - (a @ b) * b
        ang = math.atan2(b @ np.cross(t_next, t_prev), t_next @ t_prev)
        total += ang % TAU
    return total - (k - 2) * math.pi


def vos(a, b, c):
    """Van Oosterom–Strackee solid angle at the origin, vectors of any length (numpy)."""
    la, lb, lc = (np.linalg.norm(x) for x in (a, b, c))
    num = a @ np.cross(b, c)
    den = la * lb * lc + (a @ b) * lc + (a @ c) * lb + (b @ c) * la
    return 2.0 * math.atan2(num, den)


def ear_clip(P2):
    """Triangles of a simple planar polygon (k, 2), either orientation: ear clipping."""
    idx = list(range(len(P2)))
    area = 0.5 * sum(P2[i - 1][0] * P2[i][1] - P2[i][0] * P2[i - 1][1] for i in range(len(P2)))
    sgn = 1.0 if area > 0 else -1.0
    tris = []

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    while len(idx) > 3:
        for n in range(len(idx)):
            i, j, k = idx[n - 1], idx[n], idx[(n + 1) % len(idx)]
            if sgn * cross(P2[i], P2[j], P2[k]) <= 1e-15:
                continue
            inside = False
            for m in idx:
                if m in (i, j, k):
                    continue
                if (sgn * cross(P2[i], P2[j], P2[m]) >= 0 and sgn * cross(P2[j], P2[k], P2[m]) >= 0
                        and sgn * cross(P2[k], P2[i], P2[m]) >= 0):
                    inside = True
                    break
            if not inside:
                tris.append((i, j, k))
                idx.pop(n)
                break
        else:
            raise AssertionError("no ear: the polygon is not simple")
    tris.append(tuple(idx))
    return tris


def paper_angle(V, W, d):
    """Definition 2 literally: the plane d·x = t (t = half the smallest d·u_i) separates V
    from the hull; project the link radially onto it, ear-clip the polygon, add the
    (unsigned) Van Oosterom–Strackee solid angles of its triangles."""
    u = np.asarray(W, float) - np.asarray(V, float)
    h = u @ d
    assert (h > 0).all()
    t = 0.5 * h.min()
    Wp = u * (t / h)[:, None]
    e1 = np.cross(d, [1.0, 0, 0] if abs(d[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    P2 = np.stack([Wp @ e1, Wp @ e2], axis=1)
    return sum(abs(vos(Wp[i], Wp[j], Wp[k])) for i, j, k in ear_clip(P2))


def lp_non_hyperbolic(V, W):
    """V is not in the interior of conv(W): some d != 0 has d·(W_i - V) >= 0 for all i.
    Rank < 3 (coplanar): yes.  Else, such a d has sum_i d·u_i > 0: an LP with that sum = 1."""
    u = np.asarray(W, float) - np.asarray(V, float)
    if np.linalg.matrix_rank(u, tol=1e-9 * np.abs(u).max()) < 3:
        return True
    res = linprog(np.zeros(3), A_ub=-u, b_ub=np.zeros(len(u)), A_eq=u.sum(axis=0)[None, :],
                  b_eq=[1.0], bounds=[(None, None)] * 3, method="highs")
    return res.status == 0


def hull_non_hyperbolic(V, W):
    """The same by scipy's ConvexHull: V is interior iff strictly inside every facet."""
    try:
        hull = ConvexHull(np.asarray(W, float))
    except QhullError:
        return True                                     # flat: the hull has no interior
    eq = hull.equations
    return bool((eq[:, :3] @ np.asarray(V, float) + eq[:, 3] >= -1e-9).any())


def closest_line_apex_ref(V, W):
    """Brute force: of the lines through two distinct link vertices, the closest to V; its
    end nearer V (first such pair in (i, j) order on ties)."""
    best = (math.inf, -1)
    for i in range(len(W)):
        for j in range(i + 1, len(W)):
            e = W[j] - W[i]
            if e @ e == 0:
                continue
            dist = np.linalg.norm(np.cross(V - W[i], e)) / np.linalg.norm(e)
            near = i if np.linalg.norm(V - W[i]) <= np.linalg.norm(V - W[j]) else j
            if dist < best[0] - 1e-15:
                best = (dist, near)
    return best[1]


def ring(k, z=0.0, r=1.0, phase=0.0):
    th = phase + np.arange(k) * TAU / k
    return np.stack([r * np.cos(th), r * np.sin(th), np.broadcast_to(z, th.shape)], axis=1)


# ---------------------------------------------------------------------- solid angles
def point_triangle_distance(p, a, b, c):
    """Distance of p to the triangle abc (reference: the plane if the foot lies inside,
    else the nearest edge segment)."""
    n = np.cross(b - a, c - a)
    n = n / np.linalg.norm(n)
    q = p - np.dot(p - a, n) * n
    inside = all(np.dot(np.cross(y - x, q - x), n) >= 0 for x, y in ((a, b), (b, c), (c, a)))
    if inside:
        return abs(np.dot(p - a, n))

    def seg(x, y):
        t = np.clip(np.dot(p - x, y - x) / np.dot(y - x, y - x), 0.0, 1.0)
        return np.linalg.norm(p - (x + t * (y - x)))

    return min(seg(a, b), seg(b, c), seg(c, a))


def test_solid_angle_of_known_triangles():
    # an octant: the triangle on the three axes subtends 4 pi / 8
    assert vk.solid_angle([1, 0, 0], [0, 1, 0], [0, 0, 1]) == pytest.approx(math.pi / 2, abs=1e-15)
    assert vk.solid_angle([1, 0, 0], [0, 0, 1], [0, 1, 0]) == pytest.approx(-math.pi / 2, abs=1e-15)
    # scale invariance per vector
    assert vk.solid_angle([5, 0, 0], [0, 0.1, 0], [0, 0, 3]) == pytest.approx(math.pi / 2, abs=1e-15)
    # a large triangle close to the origin: over pi (atan2, not atan), tends to 2 pi
    T = ring(3, z=-1e-3)
    big = vk.solid_angle(T[0], T[2], T[1])
    assert math.pi < big < TAU
    assert big == pytest.approx(girard_area(T[[0, 2, 1]] / np.linalg.norm(T, axis=1)[:, None]), abs=1e-12)
    # the square of side 2 at distance 1, split in two: 4 arcsin(1/2) = 2 pi / 3 in total
    S = np.array([[1, 1, -1], [-1, 1, -1], [-1, -1, -1], [1, -1, -1]], float)
    assert abs(vk.solid_angle(S[0], S[1], S[2])) + abs(vk.solid_angle(S[0], S[2], S[3])) == \
        pytest.approx(TAU / 3, abs=1e-14)
    with pytest.raises(ValueError):
        vk.solid_angle([1, 0], [0, 1, 0], [0, 0, 1])
    with pytest.raises(ValueError):
        vk.solid_angle([np.nan, 0, 0], [0, 1, 0], [0, 0, 1])


def test_cube_corner_is_pi_over_2():
    # the corner of a cube seen from the corner: the three edge neighbours ...
    m = vk.measure([0, 0, 0], [[1, 0, 0], [0, 1, 0], [0, 0, 1]])
    assert m["class"] == "non_hyperbolic" and not m["on_hull"]
    assert m["angle"] == pytest.approx(math.pi / 2, abs=1e-14)
    # ... and the corner vertex of a triangulated cube: 6 neighbours (3 edges, 3 diagonals)
    link = [[1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 1, 1], [0, 0, 1], [1, 0, 1]]
    m = vk.measure([0, 0, 0], link)
    assert m["angle"] == pytest.approx(math.pi / 2, abs=1e-14)
    assert m["pole"] == pytest.approx(np.full(3, 1 / math.sqrt(3)), abs=1e-12)


def test_flat_star_is_2pi():
    for k in (3, 4, 6, 9):
        m = vk.measure([0, 0, 0], ring(k, phase=0.3))
        assert m["class"] == "non_hyperbolic" and m["on_hull"]
        assert m["angle"] == pytest.approx(TAU, abs=1e-13)
        assert m["height"] == pytest.approx(0.0, abs=1e-15)
        assert m["volume"] == pytest.approx(0.0, abs=1e-15)
    # a flat, tilted, non-convex star (V inside): still 2 pi
    rng = np.random.default_rng(1)
    W = ring(8) * rng.uniform(0.3, 2.0, size=(8, 1))
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    V = np.array([0.3, -0.7, 2.0])
    m = vk.measure(V, W @ R.T + V)
    assert m["angle"] == pytest.approx(TAU, abs=1e-12) and m["height"] < 1e-14


def test_regular_tetrahedron_vertex():
    T = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    for i in range(4):
        m = vk.measure(T[i], np.delete(T, i, axis=0))
        assert m["angle"] == pytest.approx(math.acos(23 / 27), abs=1e-14)


def test_straight_crease_is_the_wedge():
    # a vertex on a straight 90-degree crease (a subdivided cube's edge): on the hull of its
    # neighbours (the two crease neighbours are opposite) but not coplanar: solid angle 2 * 90deg
    link = [[1, 0, 0], [1, 0, -1], [0, 0, -1], [-1, 0, -1], [-1, 0, 0], [-1, -1, 0], [0, -1, 0], [1, -1, 0]]
    m = vk.measure([0, 0, 0], link)
    assert m["class"] == "non_hyperbolic" and m["on_hull"]
    assert m["angle"] == pytest.approx(math.pi, abs=1e-14)
    # a shallower crease of opening alpha
    for alpha in (0.5, 2.0, 3.0):
        a = [0.0, math.cos(alpha), math.sin(alpha)]
        link = [[1, 0, 0], [1, 1, 0], [0, 1, 0], [-1, 1, 0], [-1, 0, 0],
                np.add([-1, 0, 0], a), a, np.add([1, 0, 0], a)]
        m = vk.measure([0, 0, 0], link)
        assert m["angle"] == pytest.approx(2 * alpha, abs=1e-12)


def test_non_convex_projected_polygon_exact():
    # an L-shaped link in the plane z = -1, V above the L's corner: the solid angle is
    # R(2,1) + R(1,2) - R(1,1), R(a,b) = atan(ab / (h sqrt(a^2+b^2+h^2))) the rectangle
    # [0,a]x[0,b] seen from height h above its corner
    def R(a, b, h=1.0):
        return math.atan(a * b / (h * math.sqrt(a * a + b * b + h * h)))

    L = np.array([[0, 0, -1], [2, 0, -1], [2, 1, -1], [1, 1, -1], [1, 2, -1], [0, 2, -1]], float)
    expected = R(2, 1) + R(1, 2) - R(1, 1)
    for shift in range(6):                              # every start of the cycle
        m = vk.measure([0, 0, 0], np.roll(L, shift, axis=0))
        assert m["angle"] == pytest.approx(expected, abs=1e-14)
        assert m["height"] == pytest.approx(1.0, abs=1e-14)
    m = vk.measure([0, 0, 0], L[::-1])                  # orientation does not matter
    assert m["angle"] == pytest.approx(expected, abs=1e-14)


# ---------------------------------------------------------------------- classification
def test_saddles_are_hyperbolic():
    th = np.arange(8) * TAU / 8
    # hyperbolic paraboloid z = x y and monkey saddle z = x^3 - 3 x y^2 around the origin
    for z in (np.cos(th) * np.sin(th), np.cos(th) ** 3 - 3 * np.cos(th) * np.sin(th) ** 2):
        W = np.stack([np.cos(th), np.sin(th), z], axis=1)
        assert vk.measure([0, 0, 0], W)["class"] == "hyperbolic"
        r = vk.evaluate_star(np.vstack([[0, 0, 0], W]), 0, np.arange(1, 9), hyperbolic="veto")
        assert r["status"] == "veto" and r["hyperbolic"] and math.isnan(r["gate"])
        assert vk.evaluate_star(np.vstack([[0, 0, 0], W]), 0, np.arange(1, 9), accumulate="off")["status"] == "veto"
        # lodkit's default: removable, measured about the mean normal (a saddle's angle is
        # near 2 pi) and costed by V's distance to the patch
        r = vk.evaluate_star(np.vstack([[0, 0, 0], W]), 0, np.arange(1, 9))
        assert r["status"] == "ok" and r["hyperbolic"] and 0.0 < r["gate"] <= TAU + 1e-12
        assert r["error"] > 0.0 and r["tris"].shape == (6, 3)


def test_cube_corner_and_cone_tip_are_not_hyperbolic():
    assert vk.measure([0, 0, 0], [[1, 0, 0], [0, 1, 0], [0, 0, 1]])["class"] == "non_hyperbolic"
    for k, h in ((3, 0.2), (5, 1.0), (12, 3.0)):
        W = ring(k, z=-h)
        m = vk.measure([0, 0, 0], W)
        assert m["class"] == "non_hyperbolic" and not m["on_hull"]
        U = W / np.linalg.norm(W, axis=1, keepdims=True)
        assert m["angle"] == pytest.approx(girard_area(U[::-1]), abs=1e-12)
        # concave: the same tip pointing into the solid is the same star
        assert vk.measure([0, 0, 0], -W)["angle"] == pytest.approx(m["angle"], abs=1e-12)


def test_degenerate_stars():
    # a neighbour at V
    assert vk.measure([0, 0, 0], [[0, 0, 0], [1, 0, 0], [0, 1, 0]])["class"] == "degenerate"
    # every neighbour on one line through V
    assert vk.measure([0, 0, 0], [[1, 0, 0], [-1, 0, 0], [2, 0, 0]])["class"] == "degenerate"
    r = vk.evaluate_star([[0, 0, 0], [1, 0, 0], [-1, 0, 0], [2, 0, 0]], 0, [1, 2, 3])
    assert r["status"] == "veto" and not r["hyperbolic"]
    with pytest.raises(ValueError):
        vk.measure([0, 0, 0], [[1, 0, 0], [0, 1, 0]])


coord = st.integers(-4, 4)


@st.composite
def point_sets(draw):
    k = draw(st.integers(3, 9))
    flat = draw(st.booleans())
    pts = np.array(draw(st.lists(st.tuples(coord, coord, coord), min_size=k + 1, max_size=k + 1)), float)
    if flat:                                            # V and its neighbours in one plane
        pts[:, 2] = 0.0
        if draw(st.booleans()):                         # tilted
            pts = pts @ np.array([[1, 0, 0], [0, 1, 0], [1, 2, 1]], float).T
    V, W = pts[0], pts[1:]
    assume((np.abs(W - V).sum(axis=1) > 0).all())
    u = W - V
    assume(np.linalg.matrix_rank(u) >= 2)               # not all on one line through V
    return V, W


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(point_sets())
def test_hull_classification_matches_scipy(case):
    V, W = case
    m = vk.measure(V, W)
    ref_lp = lp_non_hyperbolic(V, W)
    ref_hull = hull_non_hyperbolic(V, W)
    assert ref_lp == ref_hull
    assert (m["class"] == "non_hyperbolic") == ref_lp
    if ref_lp:
        U = (W - V) / np.linalg.norm(W - V, axis=1, keepdims=True)
        assert np.linalg.norm(m["pole"]) == pytest.approx(1.0)
        assert (U @ m["pole"]).min() >= -1e-9            # every neighbour in the closed hemisphere
        assert m["on_hull"] == ((U @ m["pole"]).min() <= 1e-9)
        assert 0.0 <= m["angle"] <= TAU + 1e-12


@st.composite
def cones(draw):
    """A star-shaped (simple) link around a random axis, every neighbour strictly on one
    side of a plane through V: azimuths increasing, polar angles and distances random."""
    k = draw(st.integers(3, 12))
    az = np.sort(np.array(draw(st.lists(st.floats(0, TAU), min_size=k, max_size=k, unique=True))))
    gaps = np.diff(np.append(az, az[0] + TAU))
    assume(gaps.min() > 1e-3 and gaps.max() < math.pi - 1e-3)
    polar = np.array(draw(st.lists(st.floats(0.05, 1.5), min_size=k, max_size=k)))
    dist = np.array(draw(st.lists(st.floats(0.01, 100.0), min_size=k, max_size=k)))
    U = np.stack([np.sin(polar) * np.cos(az), np.sin(polar) * np.sin(az), np.cos(polar)], axis=1)
    q = np.array(draw(st.lists(st.floats(-1, 1), min_size=4, max_size=4)))
    assume(np.linalg.norm(q) > 0.1)
    w, x, y, z = q / np.linalg.norm(q)
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    V = np.array(draw(st.tuples(st.floats(-10, 10), st.floats(-10, 10), st.floats(-10, 10))))
    return V, V + (U * dist[:, None]) @ R.T, U @ R.T


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(cones())
def test_angle_matches_girard_and_the_papers_construction(case):
    V, W, U = case
    m = vk.measure(V, W)
    assert m["class"] == "non_hyperbolic"
    g = girard_area(U)                                  # counter-clockwise around the axis
    assert m["angle"] == pytest.approx(g, rel=1e-9, abs=1e-9)
    if not m["on_hull"] and m["margin"] > 1e-6:
        assert m["angle"] == pytest.approx(paper_angle(V, W, m["pole"]), rel=1e-9, abs=1e-9)


# ---------------------------------------------------------------------- ht, vol
def test_pyramid_by_hand():
    # apex (0,0,h) over the square (+-1, +-1, 0): the solid angle is 4 arcsin(1 / (1 + h^2)),
    # ht = h, vol = angle * h^3
    base = np.array([[1, 1, 0], [-1, 1, 0], [-1, -1, 0], [1, -1, 0]], float)
    for h in (0.25, 1.0, 3.0):
        m = vk.measure([0, 0, h], base)
        angle = 4 * math.asin(1 / (1 + h * h))
        assert m["angle"] == pytest.approx(angle, abs=1e-13)
        assert m["height"] == pytest.approx(h, abs=1e-14)
        assert m["volume"] == pytest.approx(angle * h ** 3, rel=1e-13)
    # h = 1: 4 arcsin(1/2) = 2 pi / 3, a sixth of the sphere (the cube seen from its centre)
    assert vk.measure([0, 0, 1], base)["angle"] == pytest.approx(TAU / 3, abs=1e-14)
    # the best-fit plane of a non-planar link: neighbours at z = +-0.1 alternating -> the
    # plane z = 0 (least squares), so ht = |Vz|
    W = np.hstack([ring(6)[:, :2], np.array([[0.1], [-0.1]] * 3)])
    for Vz in (0.5, 2.0):
        m = vk.measure([0, 0, Vz], W)
        assert m["height"] == pytest.approx(Vz, abs=1e-14)


def test_height_against_numpy_eigh():
    rng = np.random.default_rng(7)
    for _ in range(200):
        k = rng.integers(3, 20)
        W = rng.normal(size=(k, 3)) * rng.uniform(0.01, 10, size=3)
        V = rng.normal(size=3)
        c = W.mean(axis=0)
        n = np.linalg.eigh((W - c).T @ (W - c))[1][:, 0]
        expected = abs((V - c) @ n)
        m = vk.measure(V, W)
        if m["class"] == "non_hyperbolic":
            assert m["height"] == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_boundary_star():
    # flat straight boundary: angle 2 pi (twice the half disc), ht 0
    W = ring(8)[:5]                                      # a half ring from (1,0) to (-1,0)
    m = vk.measure([0, 0, 0], W, closed=False)
    assert m["angle"] == pytest.approx(TAU, abs=1e-13) and m["height"] == pytest.approx(0, abs=1e-15)
    # flat 90-degree corner: twice the quarter disc = pi; ht = distance to the new edge
    W = np.array([[1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    m = vk.measure([0, 0, 0], W, closed=False)
    assert m["angle"] == pytest.approx(math.pi, abs=1e-14)
    assert m["height"] == pytest.approx(math.sqrt(0.5), abs=1e-14)
    # a reflex (270-degree) flat corner: capped at 2 pi
    W = ring(8)[:7]
    m = vk.measure([0, 0, 0], W, closed=False)
    assert m["angle"] == pytest.approx(TAU, abs=1e-13)
    assert m["height"] == pytest.approx(math.sqrt(0.5), abs=1e-14)
    # an open box's rim corner: the two walls' faces, sharp (angle well under 2 pi)
    W = np.array([[1, 0, 0], [1, 0, -1], [0, 0, -1], [0, 1, -1], [0, 1, 0]], float)
    m = vk.measure([0, 0, 0], W, closed=False)
    assert m["class"] == "non_hyperbolic" and m["angle"] < math.pi


# ---------------------------------------------------------------------- the kernel
def test_evaluate_star_costs_and_fan():
    # the ridge star: V on the line W0 W2 (W0 nearer), W1 and W3 below: the closest line is
    # W0 W2 (distance 0), apex W0 (index 0): fan (0,1,2), (0,2,3) -- the ridge survives.
    # The paper's formulas: accumulate="off" (the default's error is checked below)
    P = np.array([[0, 0, 0], [-1, 0, 0], [0, -1, -0.5], [1.2, 0, 0], [0, 1, -0.5]], float)
    r = vk.evaluate_star(P, 0, [1, 2, 3, 4], accumulate="off")
    assert r["status"] == "ok"
    assert r["tris"].tolist() == [[0, 1, 2], [0, 2, 3]]
    m = vk.measure(P[0], P[1:])
    assert r["gate"] == m["angle"] and r["error"] == m["height"]
    assert r["cost"] == pytest.approx(m["angle"] * m["height"] ** 3, rel=1e-15)
    # accumulate="bound": the larger of ht and V's distance to the fan (nothing carried yet)
    b = vk.evaluate_star(P, 0, [1, 2, 3, 4], accumulate="bound")
    fan_distance = min(point_triangle_distance(P[0], *P[1:][t]) for t in b["tris"])
    assert b["tris"].tolist() == r["tris"].tolist() and b["gate"] == r["gate"]
    assert b["error"] == pytest.approx(max(m["height"], fan_distance), rel=1e-12)
    assert b["cost"] == pytest.approx(m["angle"] * b["error"] ** 3, rel=1e-12)
    # lodkit's default (accumulate="points"): how far V and the star faces' centroids lie
    # from the patch, at least min(ht, V's distance to the closest line) -- both halves of the
    # ridge are planar and the fan keeps the ridge, so the removal changes nothing: 0
    p = vk.evaluate_star(P, 0, [1, 2, 3, 4])
    assert p["tris"].tolist() == r["tris"].tolist() and p["error"] < 1e-12
    # the same star, the cycle started elsewhere: apex W0 is now link index 2
    r = vk.evaluate_star(P, 0, [3, 4, 1, 2])
    assert r["tris"].tolist() == [[2, 0, 1], [2, 3, 0]]
    # the paper's Fig. 10: V above a quad W0..W3 folded along W1 W3 (a roof); the line W1 W3
    # passes under V more closely than W0 W2, so V collapses into W1 (nearer than W3)
    P = np.array([[0, 0, 0.3], [-1, 0, -1], [0, -0.9, 0.2], [1, 0, -1], [0, 1, 0.2]], float)
    r = vk.evaluate_star(P, 0, [1, 2, 3, 4])
    assert r["status"] == "ok" and r["tris"].tolist() == [[1, 2, 3], [1, 3, 0]]
    assert closest_line_apex_ref(P[0], P[1:]) == 1
    # fixed vertices are never removed
    assert vk.evaluate_star(P, 0, [1, 2, 3, 4], fixed=[0])["status"] == "veto"
    # a flat vertex: gate 2 pi, cost 0
    P = np.vstack([[0, 0, 0], ring(6)])
    r = vk.evaluate_star(P, 0, np.arange(1, 7), accumulate="off")
    assert r["gate"] == pytest.approx(TAU) and r["cost"] == 0.0 and len(r["tris"]) == 4
    r = vk.evaluate_star(P, 0, np.arange(1, 7))
    assert r["gate"] == pytest.approx(TAU) and r["cost"] <= 1e-30 and len(r["tris"]) == 4


@settings(max_examples=100, deadline=None)
@given(cones(), st.integers(0, 11))
def test_apex_is_the_nearer_end_of_the_closest_line(case, shift):
    V, W, _ = case
    k = len(W)
    W = np.roll(W, shift % k, axis=0)
    r = vk.evaluate_star(np.vstack([V, W]), 0, np.arange(1, k + 1), fallback=False,
                         triangulation="closest_line")
    assert r["status"] == "ok"
    apex = r["tris"][0][0]
    assert (r["tris"][:, 0] == apex).all() and len(r["tris"]) == k - 2
    # the chosen line is as close as the brute-force best (ties may pick another pair)
    ref = closest_line_apex_ref(V, W)
    dist = [np.linalg.norm(np.cross(V - W[i], W[j] - W[i])) / np.linalg.norm(W[j] - W[i])
            for i in range(k) for j in range(i + 1, k) if apex in (i, j)]
    best = min(np.linalg.norm(np.cross(V - W[i], W[j] - W[i])) / np.linalg.norm(W[j] - W[i])
               for i in range(k) for j in range(i + 1, k))
    assert min(dist) <= best * (1 + 1e-9) + 1e-12
    if apex != ref:
        assert min(dist) == pytest.approx(best, rel=1e-9, abs=1e-12)


def test_fallback_when_the_closest_line_fan_folds():
    # a flat dart W0..W3 (W2 its reflex corner), V inside it near W1: the closest line is
    # W1 W2 (distance 0.102), nearer end W1 -- but the fan from W1 folds over (W1 does not
    # see W3 past the reflex corner).  The fallback takes the next line's apex.
    P = np.array([[-0.7, 0.75, 0.0],     # V
                  [2.0, 0.0, 0.0],       # W0
                  [-1.0, 1.0, 0.0],      # W1
                  [-0.3, 0.0, 0.0],      # W2: the reflex corner
                  [-1.0, -1.0, 0.0]],    # W3
                 float)
    link = [1, 2, 3, 4]
    ref = closest_line_apex_ref(P[0], P[1:])
    plain = vk.evaluate_star(P, 0, link, fallback=False, accumulate="off")
    assert plain["tris"][0][0] == ref
    W = P[1:]
    N = np.array([0, 0, 1.0])

    def folds(tris):
        return any(np.cross(W[b] - W[a], W[c] - W[a]) @ N <= 0 for a, b, c in tris)

    assert ref == 1 and folds(plain["tris"])
    fixed = vk.evaluate_star(P, 0, link, accumulate="off")
    # the other apexes by the distance of the closest line they are the nearer end of:
    # W2 (line W2 W0, 0.75), W3 (line W3 W0, 1.57), W0 (nearer end of none): the fan from W2
    # is the first that does not fold
    assert fixed["tris"].tolist() == [[2, 0, 1], [2, 3, 0]]
    assert not folds(fixed["tris"])
    # the fallback changes nothing else: cost, error and gate are the star's
    assert (fixed["cost"], fixed["error"], fixed["gate"]) == (plain["cost"], plain["error"], plain["gate"])


def test_options():
    # None: the median filter under the paper's rule (accumulate="off"), none by default
    assert Volume().params["median"] is None
    assert Volume().params["hyperbolic"] == "auto" and Volume().params["triangulation"] == "auto"
    assert Volume().params["tolerance"] == 1e-9   # exact: the default as written
    with pytest.raises(OptionError):
        Volume(tolerance=-1.0)
    with pytest.raises(OptionError):
        Volume(median="yes")
    with pytest.raises(OptionError):
        Volume(bogus=1)
    k = vk.VolumeKernel()
    k.prepare(None, {"median": False, "tolerance": 1e-6, "n_vertices": 4})
    assert not k.gated and k.tolerance == 1e-6   # exact: the option as given
    k.prepare(None, {"n_vertices": 4})
    assert not k.gated and k.n_hyperbolic == 0 and k.hyperbolic_mask().tolist() == [False] * 4
    k.prepare(None, {"accumulate": "off", "n_vertices": 4})
    assert k.gated                                  # the paper's rule: the median filter
    with pytest.raises(ValueError):
        k.prepare(None, {"tolerance": 1.0})


def test_stub_names_every_python_visible_name():
    tree = ast.parse((REPO / "lodkit" / "_core" / "volume_kernel.pyi").read_text())
    stub = {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            stub[node.name] = {i.name for i in getattr(node, "body", []) if isinstance(i, ast.FunctionDef)} \
                | {i.target.id for i in getattr(node, "body", []) if isinstance(i, ast.AnnAssign)}
        elif isinstance(node, ast.AnnAssign):
            stub[node.target.id] = set()
    public = {n for n, o in vars(vk).items() if not n.startswith("_") and n != "np"
              and getattr(o, "__module__", vk.__name__) == vk.__name__}
    assert public <= set(stub), sorted(public - set(stub))
    visible = {n for n in vars(vk.VolumeKernel) if not n.startswith("_")}
    assert visible <= stub["VolumeKernel"], sorted(visible - stub["VolumeKernel"])


# ---------------------------------------------------------------------- whole runs
def saddle_grid(n=8):
    """z = x^2 - y^2 on an n x n grid over [-1, 1]^2: every interior vertex is hyperbolic
    (its x-neighbours lie above its tangent plane, its y-neighbours below)."""
    x = np.linspace(-1, 1, n + 1)
    X, Y = np.meshgrid(x, x)
    V = np.c_[X.ravel(), Y.ravel(), (X ** 2 - Y ** 2).ravel()]
    F = []
    for i in range(n):
        for j in range(n):
            a = i * (n + 1) + j
            F += [[a, a + 1, a + n + 2], [a, a + n + 2, a + n + 1]]
    return lodkit.Mesh(V, np.array(F))


def test_flat_grid_is_removed_down_to_its_corners():
    from test_qem import grid_mesh

    V, F = grid_mesh(6, 6)
    result = lodkit.simplify(lodkit.Mesh(V, F), target_faces=2, metric="volume")
    assert result.stop_reason == "target_faces" and result.mesh.n_faces == 2
    corners = {(0.0, 0.0), (6.0, 0.0), (0.0, 6.0), (6.0, 6.0)}
    assert {tuple(p[:2]) for p in result.mesh.vertices.tolist()} == corners
    assert np.all(result.mesh.vertices[:, 2] == 0.0)
    assert result.error <= 1e-12                        # every removal was flat
    # with the boundary locked only the interior goes
    result = lodkit.simplify(lodkit.Mesh(V, F), target_faces=2, metric="volume", boundary="lock")
    assert result.stop_reason == "no_valid_collapse"
    assert result.mesh.n_vertices == 24                 # the 24 boundary vertices of the 6 x 6 grid


def test_cube_keeps_its_corners_and_edges():
    from test_qem import subdivided_cube
    from test_simplify import check_result

    V, F = subdivided_cube(4)
    mesh = lodkit.Mesh(V, F)
    for target in (100, 40):
        result = lodkit.simplify(mesh, target_faces=target, metric="volume")
        check_result(mesh, result, target)
        out = result.mesh.vertices
        assert np.all(np.isin(out, [0.0, 1.0]), axis=1).sum() == 8          # all 8 corners
        # the output stays on the cube: every vertex an input vertex, on the surface
        assert np.all(np.isin(out, V).all(axis=1))
        assert np.all((np.isin(out, [0.0, 1.0])).any(axis=1))
    # down to 100 faces (from 192) only flat face vertices (cost 0) have gone
    result = lodkit.simplify(mesh, target_faces=100, metric="volume", record=True)
    assert result.error < 1e-12 and np.all(result.collapses["cost"] < 1e-12)   # 0 up to rounding


def test_every_vertex_hyperbolic_stops_with_the_reason():
    mesh = saddle_grid(8)
    result = lodkit.simplify(mesh, target_faces=10, metric=("volume", {"hyperbolic": "veto"}),
                             boundary="lock")
    assert result.n_collapses == 0 and result.mesh.n_faces == mesh.n_faces
    assert result.stop_reason == "no_valid_collapse"
    assert "49 hyperbolic" in result.report["stop_detail"]
    assert "never removes" in result.report["stop_detail"]


def test_record_matches_the_kernel():
    from test_qem import uv_sphere

    V, F = uv_sphere(16, 10)
    result = lodkit.simplify((V, F), target_ratio=0.3, metric="volume", record=True)
    rec = result.collapses
    assert rec["operator"] == "vertex_removal"
    assert len(rec["removed"]) == result.n_collapses > 0
    # replay the first removal on the input: the kernel's cost, error and triangles
    v = int(rec["removed"][0])
    link = rec["link"][rec["link_offsets"][0]:rec["link_offsets"][1]]
    r = vk.evaluate_star(V, v, link, closed=bool(rec["closed"][0]))
    assert r["status"] == "ok"
    # positions are normalised in the core (unit diagonal): costs scale by diag^-3, ht by diag^-1
    diag = np.linalg.norm(V.max(axis=0) - V.min(axis=0))
    assert rec["cost"][0] == pytest.approx(r["cost"] / diag ** 3, rel=1e-9)
    assert rec["error"][0] == pytest.approx(r["error"] / diag, rel=1e-9)
    new = rec["new_faces"][rec["new_face_offsets"][0]:rec["new_face_offsets"][1]]
    assert sorted(map(tuple, new.tolist())) == sorted(tuple(link[t]) for t in r["tris"])


REAL = [("bunny.ply", 0.1), ("boot.obj", 0.1), ("mountain.obj", 0.1), ("fandisk.obj", 0.1),
        ("cow.obj", 0.2)]


def near_flipped_faces(mesh, out) -> int:
    """Output faces lying on the input surface (centroid within 0.1 x their longest edge of
    it) whose normal opposes the closest input face's (bench/metro.py's flipped_faces_near)."""
    from lodkit.evaluate import closest_points

    V, F = out.vertices, out.faces
    cent = V[F].mean(axis=1)
    cp, prim, _ = closest_points(mesh.vertices, mesh.faces, cent)
    dots = np.einsum("ij,ij->i", out.face_normals(), mesh.face_normals()[prim])
    longest = np.linalg.norm(V[F[:, [1, 2, 0]]] - V[F], axis=2).max(axis=1)
    return int(((dots < 0) & (np.linalg.norm(cp - cent, axis=1) <= 0.1 * longest)).sum())


@pytest.mark.parametrize("name,ratio", REAL)
def test_real_meshes(name, ratio):
    mesh = lodkit.load(shared_mesh(name))
    before = lodkit.topology(mesh)
    target = int(round(ratio * mesh.n_faces))
    result = lodkit.simplify(mesh, target_faces=target, metric="volume")
    after = lodkit.topology(result.mesh)
    assert result.stop_reason == "target_faces"
    assert result.mesh.n_faces in (target, target - 1)
    assert result.n_collapses == mesh.n_vertices - result.mesh.n_vertices - result.report.get(
        "unreferenced_vertices_removed", 0)
    assert after.n_nonmanifold_edges == 0
    assert after.n_nonmanifold_vertices == before.n_nonmanifold_vertices   # the cow's pinch kept
    assert after.is_manifold == before.is_manifold and after.is_oriented
    assert after.genus == before.genus
    assert after.n_boundary_loops == before.n_boundary_loops
    assert after.n_components == before.n_components
    assert after.n_degenerate_faces == 0 and after.n_duplicate_faces == 0
    # output vertices are input vertices, bit for bit
    assert np.array_equal(result.mesh.vertices, mesh.vertices[result.vertex_map])
    # the run's error: the largest accumulated bound of a removal (docs/metrics/volume.md)
    assert 0.0 < result.error < 0.5
    # faces turned over against the surface they sit on: every removal is checked against
    # its own star only (docs/algorithms.md), so a few coarse faces spanning thin parts (the
    # cow's ears and legs) end up facing the far side (measured: bunny 9 of 6945, boot 30 of
    # 3990, cow 14 of 1160, mountain 3, fandisk 0; qem at the same count: 0, 9, 7, 0, 0)
    assert near_flipped_faces(mesh, result.mesh) <= 0.02 * result.mesh.n_faces


def test_stall_on_a_real_mesh_is_explained():
    # the cow cannot go to 2%: what is left is hyperbolic or refused by the checks
    mesh = lodkit.load(shared_mesh("cow.obj"))
    result = lodkit.simplify(mesh, target_ratio=0.02, metric=("volume", {"accumulate": "off"}))
    assert result.stop_reason == "no_valid_collapse" and result.mesh.n_faces > 0.02 * mesh.n_faces
    detail = result.report["stop_detail"]
    n = int(detail.split("kernel vetoes: ")[1].split(" hyperbolic")[0])
    assert n > 0 and f"{n} kernel" in detail


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(point_sets(), st.sampled_from([1e-9, 1e-3, 0.05]))
def test_hyperbolic_witness_never_contradicts_the_exhaustive_test(case, tol):
    """The quick tetrahedron certificate (a shortcut before the O(k^3) hull test) only
    answers "hyperbolic" where the LP does too, with a ball of radius > tolerance (so the
    exhaustive test, with the same tolerance, would say so as well)."""
    V, W = case
    if vk.hyperbolic_witness(V, W, tolerance=tol):
        assert not lp_non_hyperbolic(V, W)
        assert vk.measure(V, W, tolerance=tol)["class"] == "hyperbolic"


def test_hyperbolic_witness_finds_saddles():
    ring = [(math.cos(a), math.sin(a)) for a in np.linspace(0, 2 * math.pi, 8, endpoint=False)]
    W = [(x, y, x * y) for x, y in ring]                # z = x y: A, B, C, D alternate
    assert vk.hyperbolic_witness([0, 0, 0], W)
    assert vk.measure([0, 0, 0], W)["class"] == "hyperbolic"
    # a cube corner and a flat star: no witness (not hyperbolic)
    assert not vk.hyperbolic_witness([0, 0, 0], [[1, 0, 0], [0, 1, 0], [0, 0, 1]])
    assert not vk.hyperbolic_witness([0, 0, 0], [(x, y, 0.0) for x, y in ring])
    # a shallow saddle whose tetrahedra hold only a thin ball: no witness above that radius
    W = [(x, y, 1e-4 * x * y) for x, y in ring]
    assert vk.measure([0, 0, 0], W)["class"] == "hyperbolic"
    assert not vk.hyperbolic_witness([0, 0, 0], W, tolerance=1e-3)
    assert vk.measure([0, 0, 0], W, tolerance=1e-3)["class"] == "non_hyperbolic"
