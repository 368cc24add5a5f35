"""Hole re-triangulation by recursive loop splitting (Schroeder et al. 1992):
lodkit._core.retriangulate.split_loop through its test wrapper py_split_loop."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lodkit._core.retriangulate import SPLIT_MIN_ASPECT, py_split_loop


def newell(P):
    P = np.asarray(P, dtype=np.float64)
    Q = np.roll(P, -1, axis=0)
    return np.array([np.sum((P[:, 1] - Q[:, 1]) * (P[:, 2] + Q[:, 2])),
                     np.sum((P[:, 2] - Q[:, 2]) * (P[:, 0] + Q[:, 0])),
                     np.sum((P[:, 0] - Q[:, 0]) * (P[:, 1] + Q[:, 1]))])


def project(P, n):
    """2-d coordinates of P in the plane orthogonal to n (right-handed about n)."""
    n = np.asarray(n, dtype=np.float64) / np.linalg.norm(n)
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(n, a)
    u /= np.linalg.norm(u)
    w = np.cross(n, u)
    P = np.asarray(P, dtype=np.float64)
    return np.c_[P @ u, P @ w]


def signed_area(Q):
    x, y = Q[:, 0], Q[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def check_triangulation(P, tris, normal=None):
    """tris is a triangulation of the loop P (k, 3) as seen along ``normal``: k - 2
    triangles with increasing indices, every one counter-clockwise about the normal, every
    polygon edge used once and every diagonal twice (once each way), and the triangles'
    projected areas sum to the polygon's -- so they cover it without overlapping."""
    P = np.asarray(P, dtype=np.float64)
    k = len(P)
    n = newell(P) if normal is None else np.asarray(normal, dtype=np.float64)
    tris = np.asarray(tris)
    assert tris.shape == (k - 2, 3)
    assert (tris[:, 0] < tris[:, 1]).all() and (tris[:, 1] < tris[:, 2]).all()
    Q = project(P, n)
    areas = [signed_area(Q[t]) for t in tris]
    assert min(areas) > 0.0, "a triangle is flat or inverted"
    poly = signed_area(Q)
    assert math.isclose(sum(areas), poly, rel_tol=1e-9, abs_tol=1e-12)
    directed = {}
    for t in tris:
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            directed[(a, b)] = directed.get((a, b), 0) + 1
    assert max(directed.values()) == 1, "an edge is used twice the same way: overlap"
    for i in range(k):
        assert directed.get((i, (i + 1) % k)) == 1, f"polygon edge {i} not covered once"
        assert (((i + 1) % k), i) not in directed
    for (a, b) in directed:
        if (b - a) % k not in (1, k - 1):
            assert (b, a) in directed, f"diagonal ({a}, {b}) used one way only"


def as_set(tris):
    return sorted(map(tuple, np.asarray(tris).tolist()))


def regular(k, r=1.0, z=None):
    a = 2 * np.pi * np.arange(k) / k
    return np.c_[r * np.cos(a), r * np.sin(a), np.zeros(k) if z is None else z]


# ---- exact output on small loops, worked out by hand ------------------------------------

def test_triangle_is_itself_and_an_inverted_one_is_refused():
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    assert py_split_loop(P).tolist() == [[0, 1, 2]]
    assert py_split_loop(P, normal=[0, 0, -1]) is None       # clockwise about the normal
    assert py_split_loop(P[[0, 1, 1]], normal=[0, 0, 1]) is None


def test_square():
    # Both diagonals have aspect ratio (sqrt(2)/2) / sqrt(2) = 0.5: the tie goes to the first
    # in enumeration order, (0, 2); halves 0,1,2 and 2,3,0.
    P = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]])
    assert py_split_loop(P).tolist() == [[0, 1, 2], [0, 2, 3]]
    # a rectangle 4 x 1: diagonal (0, 2) has min distance 4/sqrt(17) over length sqrt(17)
    # = 4/17; (1, 3) the same -> the tie goes to (0, 2) again
    R = P * [4, 1, 1]
    assert py_split_loop(R).tolist() == [[0, 1, 2], [0, 2, 3]]


def test_regular_hexagon():
    # short diagonals (i, i+2): the skipped vertex is 1/2 from the chord, length sqrt(3)
    # -> 0.289; long diagonals (i, i+3): the nearest vertices are sqrt(3)/2 from it, length
    # 2 -> 0.433.  First split: the first long one, (0, 3).  Each half 0,1,2,3 and 3,4,5,0
    # is a trapezoid whose two diagonals tie at 1/2 / sqrt(3): the first of each, (0, 2)
    # and (3, 5).
    tris = py_split_loop(regular(6))
    assert tris.tolist() == [[0, 1, 2], [0, 2, 3], [3, 4, 5], [0, 3, 5]]
    check_triangulation(regular(6), tris)


def test_l_shaped_concave_hexagon():
    #   5 +---+ 4
    #     |   |
    #     |   +---+ 2        0 (0,0) 1 (2,0) 2 (2,1) 3 (1,1) 4 (1,2) 5 (0,2); 3 is reflex
    #     |     3 |
    #   0 +-------+ 1
    # Valid first splits: (0,2) aspect (1/sqrt5)/sqrt5 = 0.2, (0,3) (1/sqrt2)/sqrt2 = 0.5,
    # (0,4) 0.2; every other diagonal has a vertex on or across its split plane.  Then
    # 0,1,2,3: (1,3) 0.5 beats (0,2) 0.2; 3,4,5,0: (3,5) 0.5 beats (4,0) 0.2.
    P = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0.0]])
    tris = py_split_loop(P)
    assert tris.tolist() == [[1, 2, 3], [0, 1, 3], [3, 4, 5], [0, 3, 5]]
    check_triangulation(P, tris)


def test_split_plane_is_orthogonal_to_the_given_normal():
    # the same square seen along a tilted normal is still a convex loop, but distances are
    # now measured to tilted split planes: the split through (1, 3) keeps vertex 0 and 2 at
    # |(p - p_1).s| with s = (d x n)/|d x n|, d = (-1, 1, 0), n = (0.3, -0.2, 1):
    # d x n = (1, 1, -0.1), distances 1/sqrt(2.01) each over length sqrt(2) -> 0.4988;
    # (0, 2): d = (1, 1, 0), d x n = (1, -1, -0.5), distances 1/1.5 over sqrt(2) -> 0.4714.
    P = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]])
    n = [0.3, -0.2, 1.0]
    tris = py_split_loop(P, normal=n)
    assert tris.tolist() == [[1, 2, 3], [0, 1, 3]]
    check_triangulation(P, tris, n)
    # seen edge-on (normal in the loop's plane) nothing separates
    assert py_split_loop(P, normal=[1.0, 0.0, 0.0]) is None


def test_min_aspect_refuses_thin_splits():
    # a 1 x 0.03 sliver: both diagonals have aspect 0.03 / (1 + 0.0009) ~ 0.03 < 0.04
    P = np.array([[0, 0, 0], [1, 0, 0], [1, 0.03, 0], [0, 0.03, 0.0]])
    assert py_split_loop(P) is None
    assert py_split_loop(P, min_aspect=0.02).tolist() == [[0, 1, 2], [0, 2, 3]]
    assert SPLIT_MIN_ASPECT == 0.04   # exact: the constant as written


def test_negative_min_aspect_accepts_no_invalid_split():
    # a self-intersecting loop: no diagonal separates it.  A valid split has aspect > 0, so
    # a negative bound must behave as 0 (it used to let an invalid split, aspect -1, through
    # and return overlapping triangles)
    P = np.array([[0.137, 0.748, 0], [0.47, 0.326, 0], [0.734, 0.845, 0], [0.322, 0.155, 0],
                  [0.992, 0.919, 0], [0.29, 0.814, 0.0]])
    assert py_split_loop(P, normal=[0, 0, 1], min_aspect=0.0) is None
    assert py_split_loop(P, normal=[0, 0, 1], min_aspect=-1.0) is None
    H = regular(6)
    assert py_split_loop(H, min_aspect=-1.0).tolist() == py_split_loop(H, min_aspect=0.0).tolist()


# ---- forced first split ------------------------------------------------------------------

def test_forced_diagonal_is_the_first_split():
    H = regular(6)
    tris = py_split_loop(H, force=(1, 4))
    check_triangulation(H, tris)
    # halves 1,2,3,4 and 4,5,0,1, each a trapezoid whose first diagonal wins the tie
    assert tris.tolist() == [[1, 2, 3], [1, 3, 4], [0, 4, 5], [0, 1, 4]]
    assert as_set(py_split_loop(H, force=(4, 1))) == as_set(tris)


def test_forced_diagonal_that_does_not_separate_is_refused():
    # L-hexagon: (1, 5) has vertex 3 on its split plane
    P = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0.0]])
    assert py_split_loop(P, force=(1, 5)) is None
    assert py_split_loop(P, force=(2, 4)) is None
    assert py_split_loop(P, force=(0, 3)).tolist() == py_split_loop(P).tolist()
    assert py_split_loop(P, force=(0, 0)) is None
    assert py_split_loop(P, force=(0, 6)) is None


def test_forced_polygon_edge_is_a_one_sided_split():
    # an open star's loop closed by its new boundary edge 3 -> 0: every other vertex must be
    # on the surface's side of that edge
    P = np.array([[1, 0, 0], [0.7, 0.7, 0], [-0.7, 0.7, 0], [-1, 0, 0.0]])
    tris = py_split_loop(P, force=(0, 3), normal=[0, 0, 1])
    assert tris.tolist() == py_split_loop(P, normal=[0, 0, 1]).tolist()
    # vertex 1 pulled across the line 0-3: the loop is no longer on one side
    Q = P.copy()
    Q[1] = [0.5, -0.1, 0]
    assert py_split_loop(Q, force=(0, 3), normal=[0, 0, 1]) is None
    # vertex 1 too close to the new edge: aspect 0.01 / 2 < 0.04
    Q[1] = [0.5, 0.01, 0]
    assert py_split_loop(Q, force=(0, 3), normal=[0, 0, 1]) is None
    assert py_split_loop(Q, force=(0, 3), normal=[0, 0, 1], min_aspect=0.001) is not None


# ---- non-planar loops ------------------------------------------------------------------

def test_non_planar_loops():
    for k in range(4, 13):
        z = 0.25 * np.cos(3 * np.arange(k)) * (np.arange(k) % 2)
        P = regular(k, z=z)
        tris = py_split_loop(P)
        assert tris is not None, k
        check_triangulation(P, tris)


def test_twisted_loop_has_no_valid_split():
    # a square loop whose two halves are folded over each other: seen along its average
    # normal it is a bow-tie, so no split plane separates the two sub-loops
    P = np.array([[0, 0, 0], [1, 1, 0.4], [1, 0, 0], [0, 1, 0.4]])
    assert py_split_loop(P) is None
    assert py_split_loop(P, normal=[0, 0, 1]) is None
    # a hexagon wound twice half-way ("figure eight" in projection)
    a = np.array([0, 1, 2, 0.5, 1.5, 2.5]) * 2 * np.pi / 3
    P = np.c_[np.cos(a), np.sin(a), 0.1 * np.arange(6)]
    assert py_split_loop(P, normal=[0, 0, 1]) is None


def test_large_loop_and_bad_input():
    # a fine regular 64-gon: its ears are thin (1 - cos(2 pi/64) over 2 sin(2 pi/64) =
    # 0.025 < 0.04), so Schroeder's bound refuses it; without the bound it triangulates
    P = regular(64)
    assert py_split_loop(P) is None
    check_triangulation(P, py_split_loop(P, min_aspect=0.0))
    R = regular(5)
    R.setflags(write=False)                     # read-only input is fine
    check_triangulation(R, py_split_loop(R, normal=np.array([0.0, 0.0, 1.0])))
    with pytest.raises(ValueError):
        py_split_loop(np.zeros((2, 3)))
    with pytest.raises(ValueError):
        py_split_loop(np.zeros((4, 2)))


# ---- a slow reference and random polygons --------------------------------------------

def reference_split(P, n, min_aspect=SPLIT_MIN_ASPECT):
    """The same rule in plain Python, recursively."""
    P = np.asarray(P, dtype=np.float64)
    n = np.asarray(n, dtype=np.float64)
    out = []

    def aspect(cur, i, j):
        a, b = P[cur[i]], P[cur[j]]
        d = b - a
        L = np.linalg.norm(d)
        s = np.cross(d, n)
        if not L > 0 or not np.linalg.norm(s) > 1e-12 * L * np.linalg.norm(n):
            return -1.0
        s = s / np.linalg.norm(s)
        m = len(cur)
        best = math.inf
        for t in range(m):
            if t in (i, j):
                continue
            h = float(np.dot(P[cur[t]] - a, s))
            if i < t < j:
                if not h > 1e-12 * L:
                    return -1.0
            elif not h < -1e-12 * L:
                return -1.0
            best = min(best, abs(h))
        return best / L

    def rec(cur):
        m = len(cur)
        if m == 3:
            e = np.cross(P[cur[1]] - P[cur[0]], P[cur[2]] - P[cur[0]])
            if not np.dot(e, n) > 0:
                return False
            t = list(cur)
            while t[0] != min(t):
                t = t[1:] + t[:1]
            out.append(t)
            return True
        best, bi, bj = -1.0, -1, -1
        for i in range(m - 2):
            for j in range(i + 2, m):
                if i == 0 and j == m - 1:
                    continue
                ar = aspect(cur, i, j)
                if ar > best * (1 + 1e-9):
                    best, bi, bj = ar, i, j
        if bi < 0 or best < min_aspect:
            return False
        return rec(cur[bi:bj + 1]) and rec(cur[bj:] + cur[:bi + 1])

    return np.array(out) if rec(list(range(len(P)))) else None


@st.composite
def star_polygons(draw):
    k = draw(st.integers(3, 14))
    gaps = np.array(draw(st.lists(st.floats(0.2, 1.0), min_size=k, max_size=k)))
    angles = np.cumsum(gaps) / gaps.sum() * 2 * np.pi
    radii = np.array(draw(st.lists(st.floats(0.3, 1.0), min_size=k, max_size=k)))
    return np.c_[radii * np.cos(angles), radii * np.sin(angles), np.zeros(k)]


@settings(max_examples=150, deadline=None)
@given(star_polygons(), st.sampled_from([0.0, SPLIT_MIN_ASPECT, 0.1]))
def test_random_star_shaped_polygons(P, min_aspect):
    tris = py_split_loop(P, normal=[0, 0, 1], min_aspect=min_aspect)
    ref = reference_split(P, [0, 0, 1], min_aspect)
    if ref is None:
        assert tris is None
    else:
        assert tris is not None and tris.tolist() == ref.tolist()
        check_triangulation(P, tris, [0, 0, 1])


@settings(max_examples=100, deadline=None)
@given(st.integers(3, 20), st.lists(st.floats(0.2, 1.0), min_size=20, max_size=20),
       st.floats(-1.0, 1.0), st.floats(-1.0, 1.0))
def test_convex_polygons_always_triangulate(k, gaps, tx, ty):
    # a strictly convex loop: every diagonal separates, so with min_aspect = 0 it never fails,
    # seen along any normal within 45 degrees of its own
    g = np.array(gaps[:k])
    a = np.cumsum(g) / g.sum() * 2 * np.pi
    P = np.c_[np.cos(a), 0.5 * np.sin(a), np.zeros(k)]
    n = [0.5 * tx, 0.5 * ty, 1.0]
    tris = py_split_loop(P, normal=n, min_aspect=0.0)
    assert tris is not None
    check_triangulation(P, tris, n)


# ---- a bit-exact port of split_loop -------------------------------------------------------
#
# The compiled search stops scanning a candidate split early (once it cannot beat the best
# so far) and reads the vertices in another order; it must choose exactly the split the plain
# rule chooses, ties (relative 1e-9, first in order) included.  This port evaluates every
# candidate in full with the same floating-point expressions in the same order (Python floats
# are IEEE doubles, math.sqrt is correctly rounded, as the C code without FMA), so the
# triangles must be equal, not merely both valid.

def exact_split(P, n, min_aspect=SPLIT_MIN_ASPECT, force=None):
    P = [tuple(float(c) for c in p) for p in np.asarray(P, dtype=np.float64)]
    n0, n1, n2 = (float(c) for c in np.asarray(n, dtype=np.float64).reshape(3))
    nlen = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    k = len(P)

    def aspect(cur, i, j):
        a, b = P[cur[i]], P[cur[j]]
        d0, d1, d2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
        L = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if not L > 0.0:
            return -1.0
        s0 = d1 * n2 - d2 * n1
        s1 = d2 * n0 - d0 * n2
        s2 = d0 * n1 - d1 * n0
        sl = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        if not sl > 1e-12 * L * nlen:
            return -1.0
        s0, s1, s2 = s0 / sl, s1 / sl, s2 / sl
        eps = 1e-12 * L
        mind = 1e300
        for t in range(len(cur)):
            if t in (i, j):
                continue
            q = P[cur[t]]
            h = (q[0] - a[0]) * s0 + (q[1] - a[1]) * s1 + (q[2] - a[2]) * s2
            if i < t < j:
                if not h > eps:
                    return -1.0
            else:
                if not h < -eps:
                    return -1.0
                h = -h
            mind = min(mind, h)
        return -1.0 if mind == 1e300 else mind / L   # exact: the sentinel set above

    forced = force is not None and force[0] >= 0 and force[1] >= 0
    if forced:
        fa, fb = int(force[0]), int(force[1])
        if fa >= k or fb >= k or fa == fb:
            return None
        fa, fb = min(fa, fb), max(fa, fb)
    tris = []
    stack = [list(range(k))]
    while stack:
        cur = stack.pop()
        m = len(cur)
        if forced:
            bi, bj = fa, fb
            best = aspect(cur, bi, bj)
            forced = False
            if best < 0.0 or best < min_aspect:
                return None
        elif m == 3:
            p0, p1, p2 = P[cur[0]], P[cur[1]], P[cur[2]]
            e0, e1, e2 = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
            f0, f1, f2 = p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]
            if not ((e1 * f2 - e2 * f1) * n0 + (e2 * f0 - e0 * f2) * n1
                    + (e0 * f1 - e1 * f0) * n2) > 0.0:
                return None
            t = list(cur)
            while t[0] > t[1] or t[0] > t[2]:
                t = t[1:] + t[:1]
            tris.append(t)
            continue
        else:
            best, bi, bj = -1.0, -1, -1
            for i in range(m - 2):
                for j in range(i + 2, m):
                    if i == 0 and j == m - 1:
                        continue
                    ar = aspect(cur, i, j)
                    if ar > best * (1.0 + 1e-9):
                        best, bi, bj = ar, i, j
            if bi < 0 or best < 0.0 or best < min_aspect:
                return None
        B = cur[bj:] + cur[:bi + 1]
        A = cur[bi:bj + 1]
        if len(B) >= 3:
            stack.append(B)
        if len(A) >= 3:
            stack.append(A)
    return np.array(tris, dtype=np.int32).reshape(-1, 3)


def assert_same_as_exact(P, n, min_aspect, force=None):
    got = py_split_loop(P, normal=n, force=force, min_aspect=min_aspect)
    want = exact_split(P, n, min_aspect, force)
    if want is None:
        assert got is None
    else:
        assert got is not None and got.tolist() == want.tolist()


coord = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
aspects = st.sampled_from([-1.0, 0.0, 0.01, SPLIT_MIN_ASPECT, 0.1, 0.3])


@st.composite
def star_loops(draw, planar):
    k = draw(st.integers(3, 16))
    gaps = np.array(draw(st.lists(st.floats(0.05, 1.0), min_size=k, max_size=k)))
    angles = np.cumsum(gaps) / gaps.sum() * 2 * np.pi
    radii = np.array(draw(st.lists(st.floats(0.2, 1.0), min_size=k, max_size=k)))
    z = (np.zeros(k) if planar
         else np.array(draw(st.lists(st.floats(-0.5, 0.5), min_size=k, max_size=k))))
    return np.c_[radii * np.cos(angles), radii * np.sin(angles), z]


@st.composite
def normals_and_forces(draw, k):
    n = draw(st.one_of(st.just(None), st.tuples(coord, coord, st.floats(0.1, 1.0))))
    force = draw(st.one_of(st.just(None),
                           st.tuples(st.integers(0, k - 1), st.integers(0, k - 1))))
    return n, force


@settings(max_examples=200, deadline=None)
@given(st.data(), st.booleans(), aspects)
def test_star_loops_match_the_exact_port(data, planar, min_aspect):
    P = data.draw(star_loops(planar))
    n, force = data.draw(normals_and_forces(len(P)))
    assert_same_as_exact(P, newell(P) if n is None else n, min_aspect, force)


@settings(max_examples=200, deadline=None)
@given(st.data(), st.integers(3, 14), aspects)
def test_random_non_planar_loops_match_the_exact_port(data, k, min_aspect):
    P = np.array(data.draw(st.lists(st.tuples(coord, coord, coord), min_size=k, max_size=k)))
    n, force = data.draw(normals_and_forces(k))
    assert_same_as_exact(P, newell(P) if n is None else n, min_aspect, force)


@settings(max_examples=150, deadline=None)
@given(st.integers(3, 14), st.integers(1, 4), st.integers(0, 13), aspects)
def test_snapped_loops_with_exact_ties_match_the_exact_port(k, grid, shift, min_aspect):
    # regular polygons snapped to a coarse grid: many candidate splits tie exactly, so the
    # early stop must give way to the first of equal splits as the full scan does
    a = 2 * np.pi * ((np.arange(k) + shift) % k) / k
    P = np.round(np.c_[np.cos(a), np.sin(a), np.zeros(k)] * 2 * grid) / (2 * grid)
    assert_same_as_exact(P, [0.0, 0.0, 1.0], min_aspect)
    assert_same_as_exact(regular(k), [0.0, 0.0, 1.0], min_aspect)


@settings(max_examples=150, deadline=None)
@given(st.integers(4, 12), st.integers(7, 11), st.integers(0, 2**32 - 1), aspects)
def test_nearly_regular_loops_match_the_exact_port(k, e, seed, min_aspect):
    # perturbed by about 10^-e: candidate splits within a few 1e-9 of each other, where the
    # relative tie tolerance decides and an early stop that is too eager would show
    P = regular(k) + np.random.default_rng(seed).uniform(-1, 1, (k, 3)) * 10.0 ** -e
    assert_same_as_exact(P, [0.0, 0.0, 1.0], min_aspect)
    assert_same_as_exact(P, newell(P), min_aspect)
