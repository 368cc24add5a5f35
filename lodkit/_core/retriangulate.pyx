# cython: language_level=3
"""Hole re-triangulation for vertex removal: recursive loop splitting and fans (retriangulate.pxd says what each
function does)."""

# ---- split_loop: Schroeder et al. 1992 recursive loop splitting (NAME=schroeder) ----------
#
# A split of a (sub-)loop cur[0..m-1] by the diagonal (i, j), i < j, has
#   d = p_j - p_i, the split line;
#   s = (d x n) / |d x n|, the normal of the split plane (it contains d and is orthogonal
#     to the average plane, whose normal is n);
# and is valid when every vertex strictly between i and j (sub-loop A = i..j) has
# (p - p_i).s > 0 and every vertex after j or before i (sub-loop B = j..m-1, 0..i) has
# (p - p_i).s < 0.  The sign, not only "opposite sides" as the paper words it, is what keeps
# the triangles oriented as the surface: A's vertices lie to the right of i -> j for a loop
# that turns counter-clockwise about n, so every leaf triangle (a, b, c) of A or B has
# ((p_b - p_a) x (p_c - p_a)).n > 0.  Two sub-loops on opposite sides of a line cannot
# overlap, so by induction the triangles never overlap in the projection on the average
# plane and they cover the loop.
# Its aspect ratio is min |(p - p_i).s| over the loop's other vertices, divided by |d|;
# the valid split with the largest one is taken (ties within a relative 1e-9: the first
# in the order i = 0, 1, ...; j = i + 2, ...), and the loop is not triangulated at all
# when that best value is below ``min_aspect``.
# A forced (i, j) that is a polygon edge (adjacent in the loop) is the degenerate split
# with one empty side: every other vertex must lie on the loop's side of the plane through
# that edge (Schroeder's own vtkDecimate does this for the new boundary edge of a boundary
# vertex); the loop is then triangulated without constraint.
import numpy as np

from libc.math cimport sqrt, INFINITY
from libc.float cimport DBL_MIN, DBL_MAX

from .removal_star cimport point_triangle_dist2

# Schroeder's vtkDecimate: AspectRatio = 25, a split is refused when
# (min distance / split length)^2 < 1 / 25^2, i.e. below 1 / 25 = 0.04.
SPLIT_MIN_ASPECT = 0.04
cdef double _min_aspect_default = 0.04

cdef inline double _split_aspect(const double* P, int stride, const int* loop, const int* cur,
                                 int m, const double* n, double nlen, int i, int j,
                                 double cutoff) noexcept nogil:
    """Aspect ratio of the split of ``cur`` (indices into ``loop``) at local i < j, or -1
    if the split is invalid (a vertex on the wrong side of, or on, the split plane) or
    cannot beat ``cutoff``.  ``nlen`` is |n| (computed once per loop by the caller).

    ``cutoff``: the caller takes a split only when its ratio is > cutoff, so the scan stops
    (returning -1) as soon as the running minimum distance mind is <= lim, a bound below
    cutoff * L: then mind / L < cutoff exactly, the final ratio fl(min / L) <= cutoff (the
    minimum only decreases, rounding is monotone and cutoff is a double), so the split could
    not be taken whatever the remaining vertices give, and an invalid split would not be
    taken either (identical choices, ties included).  -inf never stops early.  The vertices are
    scanned side A (i+1..j-1) then side B (j+1..m-1, 0..i-1), each starting next to the
    diagonal, where the nearest vertices usually are; the minimum and the validity verdict
    do not depend on the order."""
    cdef const double* a = &P[stride * loop[cur[i]]]
    cdef const double* b = &P[stride * loop[cur[j]]]
    cdef const double* q
    cdef double d0 = b[0] - a[0], d1 = b[1] - a[1], d2 = b[2] - a[2]
    cdef double L = sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    cdef double s0, s1, s2, sl, h, eps, lim, mind = 1e300
    cdef int t
    if not L > 0.0:
        return -1.0
    s0 = d1 * n[2] - d2 * n[1]
    s1 = d2 * n[0] - d0 * n[2]
    s2 = d0 * n[1] - d1 * n[0]
    sl = sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    if not sl > 1e-12 * L * nlen:
        return -1.0                     # split line along the normal: no split plane
    s0 /= sl
    s1 /= sl
    s2 /= sl
    eps = 1e-12 * L
    # mind <= lim implies mind / L < cutoff in exact arithmetic (lim is cutoff * L made
    # smaller by far more than its two roundings), hence fl(mind / L) <= cutoff; only
    # used when lim is a normal positive number (no underflow, no overflow)
    lim = cutoff * L * (1.0 - 1e-12)
    if not (lim >= DBL_MIN and lim <= DBL_MAX):
        lim = -1.0
    for t in range(i + 1, j):           # side A: strictly positive
        q = &P[stride * loop[cur[t]]]
        h = (q[0] - a[0]) * s0 + (q[1] - a[1]) * s1 + (q[2] - a[2]) * s2
        if not h > eps:
            return -1.0
        if h < mind:
            mind = h
        if mind <= lim:
            return -1.0
    for t in range(j + 1, m + i):       # side B: strictly negative
        q = &P[stride * loop[cur[t - m if t >= m else t]]]
        h = (q[0] - a[0]) * s0 + (q[1] - a[1]) * s1 + (q[2] - a[2]) * s2
        if not h < -eps:
            return -1.0
        h = -h
        if h < mind:
            mind = h
        if mind <= lim:
            return -1.0
    if mind == 1e300:
        return -1.0                     # nothing to separate (m == 2)
    return mind / L


cdef int split_loop_aspect(const double* P, int stride, const int* loop, int k,
                           const double* normal, int force_a, int force_b, double min_aspect,
                           int* tri, int* work) noexcept nogil:
    """split_loop with the minimum aspect ratio of a split as a parameter (see above)."""
    cdef int* store            # sub-loops waiting to be split, back to back: <= 3k ints
    cdef int* cur              # the sub-loop being split: k ints
    cdef int* stack            # (offset, size) of each waiting sub-loop: <= 2k ints
    cdef int nst = 0, top = 0, n_tri = 0, off, m, i, j, bi, bj, t, sa, sb, a, b, c, tmp
    cdef bint forced = force_a >= 0 and force_b >= 0
    cdef double ar, best, cutoff
    cdef double nlen = sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2])
    cdef const double* p0
    cdef const double* p1
    cdef const double* p2
    cdef double e0, e1, e2, f0, f1, f2
    if k < 3 or k > 1 << 14:
        return -1
    if forced:
        if force_a >= k or force_b >= k or force_a == force_b:
            return -1
        if force_a > force_b:
            force_a, force_b = force_b, force_a
    store = work
    cur = work + 3 * k
    stack = work + 4 * k
    for t in range(k):
        store[t] = t
    stack[0] = 0
    stack[1] = k
    nst = 1
    top = k
    while nst > 0:
        nst -= 1
        off = stack[2 * nst]
        m = stack[2 * nst + 1]
        for t in range(m):
            cur[t] = store[off + t]
        top = off
        if forced:
            # the first loop is the whole loop in order: local index == loop index
            bi = force_a
            bj = force_b
            best = _split_aspect(P, stride, loop, cur, m, normal, nlen, bi, bj, -INFINITY)
            forced = False
            if best < 0.0 or best < min_aspect:
                return -1
        elif m == 3:
            p0 = &P[stride * loop[cur[0]]]
            p1 = &P[stride * loop[cur[1]]]
            p2 = &P[stride * loop[cur[2]]]
            e0 = p1[0] - p0[0]
            e1 = p1[1] - p0[1]
            e2 = p1[2] - p0[2]
            f0 = p2[0] - p0[0]
            f1 = p2[1] - p0[1]
            f2 = p2[2] - p0[2]
            if not ((e1 * f2 - e2 * f1) * normal[0] + (e2 * f0 - e0 * f2) * normal[1]
                    + (e0 * f1 - e1 * f0) * normal[2]) > 0.0:
                return -1               # a flat or inverted triangle (only a k = 3 loop)
            a = cur[0]
            b = cur[1]
            c = cur[2]
            # rotate so the smallest index comes first: i < j < l, same cyclic order
            while a > b or a > c:
                tmp = a
                a = b
                b = c
                c = tmp
            tri[3 * n_tri] = a
            tri[3 * n_tri + 1] = b
            tri[3 * n_tri + 2] = c
            n_tri += 1
            continue
        else:
            best = -1.0
            cutoff = -INFINITY          # before any valid split: no early stop
            bi = bj = -1
            for i in range(m - 2):
                for j in range(i + 2, m):
                    if i == 0 and j == m - 1:
                        continue        # a polygon edge, not a diagonal
                    ar = _split_aspect(P, stride, loop, cur, m, normal, nlen, i, j, cutoff)
                    if ar > best * (1.0 + 1e-9):
                        best = ar
                        bi = i
                        bj = j
                        if best >= 0.0:
                            cutoff = best * (1.0 + 1e-9)
            if bi < 0 or best < 0.0 or best < min_aspect:
                return -1               # no valid split (best < 0), whatever min_aspect says
        # split cur at (bi, bj): A = bi..bj, B = bj..m-1, 0..bi; B is pushed first so that
        # A is split first (the order of the output triangles)
        sb = m - bj + bi + 1
        sa = bj - bi + 1
        if sb >= 3:
            for t in range(m - bj):
                store[top + t] = cur[bj + t]
            for t in range(bi + 1):
                store[top + m - bj + t] = cur[t]
            stack[2 * nst] = top
            stack[2 * nst + 1] = sb
            nst += 1
            top += sb
        if sa >= 3:
            for t in range(sa):
                store[top + t] = cur[bi + t]
            stack[2 * nst] = top
            stack[2 * nst + 1] = sa
            nst += 1
            top += sa
    if n_tri != k - 2:
        return -1                       # cannot happen: every split keeps a + b = m + 2
    return n_tri


cdef int split_loop(const double* P, int stride, const int* loop, int k,
                    const double* normal, int force_a, int force_b,
                    int* tri, int* work) noexcept nogil:
    return split_loop_aspect(P, stride, loop, k, normal, force_a, force_b, _min_aspect_default,
                             tri, work)


def py_split_loop(points, normal=None, force=None, min_aspect=None):
    """Test wrapper of ``split_loop``: triangulate the loop ``points`` (k, 3) (in order,
    turning counter-clockwise about ``normal``; default: the loop's Newell normal).
    ``force`` = (a, b) names the first split (or a polygon edge: see above);
    ``min_aspect`` defaults to SPLIT_MIN_ASPECT.  Returns (k - 2, 3) int32 triangles as
    indices into the loop, each i < j < l, or None when no valid triangulation exists."""
    import numpy as np

    P = np.ascontiguousarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or P.shape[0] < 3:
        raise ValueError(f"points must have shape (k, 3) with k >= 3, got {P.shape}")
    k = P.shape[0]
    if normal is None:
        nx = P[:, 1] * np.roll(P[:, 2], -1) - P[:, 2] * np.roll(P[:, 1], -1)
        ny = P[:, 2] * np.roll(P[:, 0], -1) - P[:, 0] * np.roll(P[:, 2], -1)
        nz = P[:, 0] * np.roll(P[:, 1], -1) - P[:, 1] * np.roll(P[:, 0], -1)
        normal = [nx.sum(), ny.sum(), nz.sum()]
    N = np.ascontiguousarray(normal, dtype=np.float64).reshape(3)
    fa, fb = (-1, -1) if force is None else (int(force[0]), int(force[1]))
    ma = SPLIT_MIN_ASPECT if min_aspect is None else float(min_aspect)
    cdef const double[:, ::1] Pv = P
    cdef const double[::1] Nv = N
    cdef int[::1] loop = np.arange(k, dtype=np.int32)
    cdef int[::1] tri = np.zeros(3 * k, dtype=np.int32)
    cdef int[::1] work = np.zeros(6 * k, dtype=np.int32)
    cdef int kk = k, n, a = fa, b = fb
    cdef double mm = ma
    with nogil:
        n = split_loop_aspect(&Pv[0, 0], 3, &loop[0], kk, &Nv[0], a, b, mm, &tri[0], &work[0])
    if n < 0:
        return None
    return np.asarray(tri)[:3 * n].reshape(n, 3).copy()
# ---- end split_loop --------------------------------------------------------------------


# ---- fan_from, closest_line_apex (NAME=vremove) ------------------------------------------

cdef int fan_from(int apex, int k, int* tri) noexcept nogil:
    """The fan from loop index ``apex``: (apex, j, j+1) over every polygon edge not at apex
    (the closing edge k-1 -> 0 included), oriented as the loop.  Returns k - 2."""
    cdef int n = 0, j, a
    for j in range(k):
        a = (j + 1) % k
        if j == apex or a == apex:
            continue
        tri[3 * n] = apex
        tri[3 * n + 1] = j
        tri[3 * n + 2] = a
        n += 1
    return n


cdef int closest_line_apex(const double* P, int stride, const int* loop, int k,
                           const double* x) noexcept nogil:
    """Chuon & Guha (paper 004, section III.D): of the O(k^2) lines through two loop
    vertices at distinct positions, the one closest to ``x``; returns its end nearer to
    ``x`` (index into ``loop``).  Distance to a line through a, b: |(x - a) x (b - a)| /
    |b - a|, compared squared and cross-multiplied (no division).  Ties keep the first pair
    in the order (i, j), i < j, and the lower index between equally near ends.  Pairs at
    coincident positions span no line and are skipped; if every loop vertex coincides, 0.
    -1 if k < 3."""
    cdef int i, j, best_i = -1, best_j = -1
    cdef const double* a
    cdef const double* b
    cdef double d0, d1, d2, w0, w1, w2, c0, c1, c2, len2, num, best_num = 0.0, best_len2 = 1.0
    cdef double da, db
    if k < 3:
        return -1
    for i in range(k):
        a = &P[stride * loop[i]]
        w0 = x[0] - a[0]
        w1 = x[1] - a[1]
        w2 = x[2] - a[2]
        for j in range(i + 1, k):
            b = &P[stride * loop[j]]
            d0 = b[0] - a[0]
            d1 = b[1] - a[1]
            d2 = b[2] - a[2]
            len2 = d0 * d0 + d1 * d1 + d2 * d2
            if not len2 > 0.0:
                continue                     # coincident vertices: no line
            c0 = w1 * d2 - w2 * d1
            c1 = w2 * d0 - w0 * d2
            c2 = w0 * d1 - w1 * d0
            num = c0 * c0 + c1 * c1 + c2 * c2
            # num / len2 < best_num / best_len2, without dividing
            if best_i < 0 or num * best_len2 < best_num * len2:
                best_i = i
                best_j = j
                best_num = num
                best_len2 = len2
    if best_i < 0:
        return 0
    a = &P[stride * loop[best_i]]
    b = &P[stride * loop[best_j]]
    da = (x[0] - a[0]) ** 2 + (x[1] - a[1]) ** 2 + (x[2] - a[2]) ** 2
    db = (x[0] - b[0]) ** 2 + (x[1] - b[1]) ** 2 + (x[2] - b[2]) ** 2
    return best_j if db < da else best_i


cdef int min_volume_triangulation(const double* W, int k, const double* x, const double* normal,
                                  int* tri, double* cost, int* split) noexcept nogil:
    """The hole's triangulation of least |volume| to the removed vertex's cone (see the
    .pxd): C[i][j] = min over i < m < j of C[i][m] + C[m][j] + w(i, m, j) over the
    sub-polygon i..j, w the triangle's |det| (+inf if it turns 90 degrees or more from
    ``normal``); ties keep the smallest m.  Triangles come out as (i, m, j), i < m < j."""
    cdef int i, j, m, gap, best_m, n = 0, top
    cdef double best, c, w
    cdef double a[3]
    cdef double b[3]
    cdef double d[3]
    cdef double e[3]
    cdef const double* pi
    cdef const double* pm
    cdef const double* pj
    cdef int stack[2 * 64]
    if k < 3 or k > 64:
        return -1
    for i in range(k - 1):
        cost[k * i + i + 1] = 0.0
    for gap in range(2, k):
        for i in range(k - gap):
            j = i + gap
            best = INFINITY
            best_m = -1
            pi = &W[3 * i]
            pj = &W[3 * j]
            for m in range(i + 1, j):
                pm = &W[3 * m]
                a[0] = pi[0] - x[0]
                a[1] = pi[1] - x[1]
                a[2] = pi[2] - x[2]
                b[0] = pm[0] - x[0]
                b[1] = pm[1] - x[1]
                b[2] = pm[2] - x[2]
                d[0] = pj[0] - x[0]
                d[1] = pj[1] - x[1]
                d[2] = pj[2] - x[2]
                # (m - i) x (j - i) . normal > 0: oriented as the surface
                e[0] = (b[1] - a[1]) * (d[2] - a[2]) - (b[2] - a[2]) * (d[1] - a[1])
                e[1] = (b[2] - a[2]) * (d[0] - a[0]) - (b[0] - a[0]) * (d[2] - a[2])
                e[2] = (b[0] - a[0]) * (d[1] - a[1]) - (b[1] - a[1]) * (d[0] - a[0])
                if not (e[0] * normal[0] + e[1] * normal[1] + e[2] * normal[2]) > 0.0:
                    continue
                w = (a[0] * (b[1] * d[2] - b[2] * d[1]) + a[1] * (b[2] * d[0] - b[0] * d[2])
                     + a[2] * (b[0] * d[1] - b[1] * d[0]))
                c = cost[k * i + m] + cost[k * m + j] + (w if w >= 0.0 else -w)
                if c < best:
                    best = c
                    best_m = m
            cost[k * i + j] = best
            split[k * i + j] = best_m
    if not cost[k - 1] < INFINITY:
        return -1
    # unwind the splits from (0, k - 1)
    stack[0] = 0
    stack[1] = k - 1
    top = 1
    while top > 0:
        top -= 1
        i = stack[2 * top]
        j = stack[2 * top + 1]
        if j - i < 2:
            continue
        m = split[k * i + j]
        tri[3 * n] = i
        tri[3 * n + 1] = m
        tri[3 * n + 2] = j
        n += 1
        stack[2 * top] = i
        stack[2 * top + 1] = m
        stack[2 * top + 2] = m
        stack[2 * top + 3] = j
        top += 2
    return n


cdef inline bint _folds(const double* W, const double* normal, const int* tri, int n) noexcept nogil:
    """True if a triangle of ``tri`` (indices into W) is not within 90 degrees of ``normal``."""
    cdef int t, a, b, c
    cdef double e0, e1, e2, f0, f1, f2
    for t in range(n):
        a = 3 * tri[3 * t]
        b = 3 * tri[3 * t + 1]
        c = 3 * tri[3 * t + 2]
        e0 = W[b] - W[a]
        e1 = W[b + 1] - W[a + 1]
        e2 = W[b + 2] - W[a + 2]
        f0 = W[c] - W[a]
        f1 = W[c + 1] - W[a + 1]
        f2 = W[c + 2] - W[a + 2]
        if not ((e1 * f2 - e2 * f1) * normal[0] + (e2 * f0 - e0 * f2) * normal[1]
                + (e0 * f1 - e1 * f0) * normal[2]) > 0.0:
            return True
    return False


cdef inline double _nearest2(const double* W, const double* x, const int* tri, int n) noexcept nogil:
    """The squared distance of x to the nearest triangle of ``tri`` (indices into W)."""
    cdef int t
    cdef double d2, best = INFINITY
    for t in range(n):
        d2 = point_triangle_dist2(x, &W[3 * tri[3 * t]], &W[3 * tri[3 * t + 1]], &W[3 * tri[3 * t + 2]])
        if d2 < best:
            best = d2
    return best


cdef int least_distance_patch(const double* W, int k, const double* x, const double* normal,
                              int* tri, int n_in, double* dist, double* cost, int* split,
                              int* cand) noexcept nogil:
    """See the .pxd: candidates in order (the given one, then the least-volume one); the
    latter must be nearer by more than rounding, so ties keep the given one."""
    cdef int n = k - 2, c, t, found = 0
    cdef double d2, best = INFINITY, tie = 0.0
    if k < 3 or k > 64:
        return -1
    # a candidate must be nearer by more than rounding: 1e-9 of the star's size, in
    # distance (so a flat star keeps the first candidate, not a rounding winner)
    for c in range(k):
        d2 = (W[3 * c] - x[0]) ** 2 + (W[3 * c + 1] - x[1]) ** 2 + (W[3 * c + 2] - x[2]) ** 2
        if d2 > tie:
            tie = d2
    tie *= 1e-18
    if n_in == n and not _folds(W, normal, tri, n):
        best = _nearest2(W, x, tri, n)
        found = 1
    # the least-volume triangulation never folds (its triangles are screened): no _folds
    if min_volume_triangulation(W, k, x, normal, cand, cost, split) >= 0:
        d2 = _nearest2(W, x, cand, n)
        if d2 < best - tie:
            best = d2
            found = 1
            for t in range(3 * n):
                tri[t] = cand[t]
    if not found:
        return -1
    dist[0] = sqrt(best)
    return n


def py_min_volume_triangulation(points, x, normal):
    """Test wrapper of ``min_volume_triangulation``: ``points`` (k, 3) the hole in order,
    ``x`` (3,) the removed vertex, ``normal`` (3,) the star's normal.  Returns (k - 2, 3)
    int32 triangles as loop indices, or None."""
    import numpy as np

    P = np.ascontiguousarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or not 3 <= P.shape[0] <= 64:
        raise ValueError(f"points must have shape (k, 3) with 3 <= k <= 64, got {P.shape}")
    X = np.ascontiguousarray(x, dtype=np.float64).reshape(3)
    N = np.ascontiguousarray(normal, dtype=np.float64).reshape(3)
    k = P.shape[0]
    out = np.zeros(3 * k, dtype=np.int32)
    cst = np.zeros(k * k)
    spl = np.zeros(k * k, dtype=np.int32)
    cdef double[:, ::1] Pv = P
    cdef double[::1] Xv = X
    cdef double[::1] Nv = N
    cdef int[::1] tv = out
    cdef double[::1] cv = cst
    cdef int[::1] sv = spl
    cdef int n = min_volume_triangulation(&Pv[0, 0], k, &Xv[0], &Nv[0], &tv[0], &cv[0], &sv[0])
    if n < 0:
        return None
    return out[:3 * n].reshape(n, 3).copy()


def py_fan_from(int apex, int k):
    """Test wrapper of ``fan_from``: (k - 2, 3) int32 triangles of the fan from ``apex``."""
    import numpy as np

    if k < 3 or not 0 <= apex < k:
        raise ValueError(f"need k >= 3 and 0 <= apex < k, got apex={apex}, k={k}")
    out = np.zeros(3 * k, dtype=np.int32)
    cdef int[::1] tri = out
    cdef int n = fan_from(apex, k, &tri[0])
    return out[:3 * n].reshape(n, 3).copy()


def py_closest_line_apex(points, x):
    """Test wrapper of ``closest_line_apex``: ``points`` (k, 3) the loop, ``x`` (3,) the
    point.  Returns the loop index of the apex (-1 if k < 3)."""
    import numpy as np

    P = np.ascontiguousarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3:
        raise ValueError(f"points must have shape (k, 3), got {P.shape}")
    X = np.ascontiguousarray(x, dtype=np.float64).reshape(3)
    k = P.shape[0]
    if k == 0:
        return -1
    cdef double[:, ::1] Pv = P
    cdef double[::1] Xv = X
    cdef int[::1] loop = np.arange(k, dtype=np.int32)
    return closest_line_apex(&Pv[0, 0], 3, &loop[0], k, &Xv[0])


def carried_points(ctx, int n):
    """The starting lists of a removal kernel's carried points (``accumulate="points"``,
    removal_star.pxd): every input face's centroid (point ``n + f``) on its own face.
    Returns (centroids flattened (3 nf,), the head point of each face slot, the next point
    of each of the n + nf points: -1 ends a list); ``ctx`` None: no faces."""
    if ctx is not None:
        corners = np.asarray(ctx.halfedge.corners, dtype=np.int64)
        pos = np.asarray(ctx.positions, dtype=np.float64)
        cent = pos[corners].mean(axis=1) if len(corners) else np.zeros((0, 3))
    else:
        cent = np.zeros((0, 3))
    nf = len(cent)
    flat = np.ascontiguousarray(cent.reshape(-1) if nf else np.zeros(3))
    head = np.arange(n, n + max(nf, 1), dtype=np.int32) if nf else np.full(1, -1, dtype=np.int32)
    nxt = np.full(max(n + nf, 1), -1, dtype=np.int32)
    return flat, head, nxt


def auto_mode(name, value, modes, paper, ours, accumulate):
    """The index in ``modes`` of a removal kernel's option ``name``: ``value``, where
    "auto" is the paper's reading (``paper``) with ``accumulate="off"`` and lodkit's
    (``ours``) otherwise; ValueError naming the choices for anything else."""
    if value == "auto":
        value = paper if accumulate == "off" else ours
    if value not in modes:
        raise ValueError(f"{name} must be 'auto' or one of {modes}, got {value!r}")
    return modes.index(value)
