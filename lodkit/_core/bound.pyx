# cython: language_level=3
"""A guaranteed two-sided error bound for edge collapse (``simplify(error="hausdorff")``):
every collapse is accepted only if the mesh it leaves stays within ``eps`` of the original
surface O in both directions (docs/error-bound.md has the argument in full).

simplified -> original
    A static bounding-volume hierarchy over O's triangles (built once, here, without the
    GIL).  The distance to one triangle T is a convex function of the point, so on a
    triangle t its largest value is at a corner: if the three corners of t are within
    ``eps`` of one T, all of t is.  A new face is accepted if it, or each of the pieces of
    its midpoint subdivision (up to BOUND_MAX_DEPTH levels), is covered so -- or by two
    triangles that share an edge, each on its side of the plane between them, or, for a
    piece t of covering radius h(t) (the farthest a point of t is from its nearest
    corner), if each corner is within ``eps - h(t)`` of O (triangle inequality) -- or by a
    flat patch of O under it (``patch_cover``: input triangles within eps of t's plane whose
    projections cover t's).  A corner farther than ``eps`` from O refuses the collapse
    outright.

original -> simplified
    The same convexity the other way: each triangle T of O is attached to a face F of the
    current mesh, whole while its three corners are within ``eps`` of F (then all of T
    is), else as pieces -- its midpoint subdivision, as deep as needed, each piece on a face
    that holds its corners so, down to pieces of covering radius ``spacing * eps``.  A
    collapse re-attaches the pieces of the faces it changes to the faces of the new
    1-ring (splitting them where needed) and is refused if a piece of the finest level
    fits no face.  While T's face is untouched it lies on it.

Every face carries the distance it is certified for (``cert``: the larger of its own
distance to O found by the check and its pieces' corners' distances to it), so the largest
``cert`` over the live faces bounds the two-sided Hausdorff distance, and a collapse's
record carries the largest of its new faces'.

Thread-safety (the pass driver's blocks): ``check`` only reads, except ``pending`` of the
faces of the collapse's fans and the distances kept for the vertices of its 1-rings;
``commit_*`` write only the faces of those fans, their pieces (new pieces take slots from
a counter shared atomically; no result depends on which slots) and the kept vertex's --
all inside the collapse's closed 1-rings.
"""
import numpy as np
cimport numpy as cnp
from libc.math cimport sqrt, fabs, INFINITY

from .halfedge cimport HalfEdgeMesh, he_prev, he_dest, he_ring_next
from .vec3 cimport point_triangle_sqdist, same_point, sub3, dot3, norm3

cnp.import_array()

cdef enum:
    LEAF_SIZE = 4
    SPHERE_KEEP = 64     # pieces whose corners fit_sphere keeps for its second pass


cdef inline double sq(double x) noexcept nogil:
    return x * x


cdef inline double point_sqdist(const double* a, const double* b) noexcept nogil:
    """Squared distance between points a and b."""
    return sq(a[0] - b[0]) + sq(a[1] - b[1]) + sq(a[2] - b[2])


cdef inline double tri_sqdist(const double* x, const double* t) noexcept nogil:
    """Squared distance from x to the triangle t (9 doubles): vec3.point_triangle_sqdist."""
    return point_triangle_sqdist(x, t, &t[3], &t[6])


cdef inline double box_sqdist(const double* b, const double* x) noexcept nogil:
    """Squared distance from x to the box b (6 doubles: lo xyz, hi xyz)."""
    cdef double d = 0.0, t
    cdef int j
    for j in range(3):
        t = b[j] - x[j]
        if t > 0.0:
            d += t * t
        else:
            t = x[j] - b[3 + j]
            if t > 0.0:
                d += t * t
    return d


cdef double covering_radius(const double* t) noexcept nogil:
    """The farthest a point of triangle t is from its nearest corner: the circumradius of an
    acute triangle, half the longest edge otherwise (the largest distance is then reached
    on the boundary, where each point is within half an edge of a corner); at most the
    longest edge over sqrt(3)."""
    cdef double la = 0.0, lb = 0.0, lc = 0.0, big, cr, r
    cdef double e1[3]
    cdef double e2[3]
    cdef int i
    for i in range(3):
        la += sq(t[6 + i] - t[3 + i])
        lb += sq(t[6 + i] - t[i])
        lc += sq(t[3 + i] - t[i])
        e1[i] = t[3 + i] - t[i]
        e2[i] = t[6 + i] - t[i]
    big = la if la > lb else lb
    if lc > big:
        big = lc
    if big >= la + lb + lc - big:               # right or obtuse
        return 0.5 * sqrt(big)
    cr = sqrt(sq(e1[1] * e2[2] - e1[2] * e2[1]) + sq(e1[2] * e2[0] - e1[0] * e2[2])
              + sq(e1[0] * e2[1] - e1[1] * e2[0]))
    if not (cr > 0.0):
        return 0.5 * sqrt(big)
    r = sqrt(la) * sqrt(lb) * sqrt(lc) / (2.0 * cr)
    # rounding: never report less than the (always valid) half edge nor more than L/sqrt(3)
    if r < 0.5 * sqrt(big):
        r = 0.5 * sqrt(big)
    return r


def triangle_covering_radius(t):
    """covering_radius for a (9,) array (tests)."""
    cdef double[::1] a = np.ascontiguousarray(t, dtype=np.float64).reshape(-1)
    return covering_radius(&a[0])


#: pieces of the input Bound keeps at most (12 bytes each, in arrays the pages of which the
#: system only commits once a piece is there): more are refused (OptionError)
MAX_PIECES = 1 << 26

# A piece of original triangle T = (a, b, c) is a triangle of the regular grid of level
# N = 2**d on T (grid point (x, y) = a + (x / N)(b - a) + (y / N)(c - a)): "up" with corners
# (i, j), (i + 1, j), (i, j + 1), or "down" with corners (i + 1, j), (i, j + 1), (i + 1, j + 1).
# Its four children (its edges' midpoints) are the pieces of depth d + 1 in it.  A code
# packs d, up/down and i, j into 31 bits.
cdef enum:
    PIECE_BITS = 13                       # i, j < 2**13: BOUND_PIECE_DEPTH at most 13
    PIECE_MASK = (1 << PIECE_BITS) - 1
    PIECE_DOWN = 1 << (2 * PIECE_BITS)
    PIECE_DEPTH_SHIFT = 2 * PIECE_BITS + 1


cdef inline double corners_box_sqdist0(const double* b, const double* t, double lim2, double* d0) noexcept nogil:
    """The largest squared distance of the three corners of ``t`` (9 doubles) to box ``b``,
    or, once one exceeds ``lim2``, that one; and in ``d0`` the first corner's."""
    cdef double lb, d
    lb = d0[0] = box_sqdist(b, t)
    if lb > lim2:
        return lb
    d = box_sqdist(b, &t[3])
    if d > lb:
        lb = d
        if lb > lim2:
            return lb
    d = box_sqdist(b, &t[6])
    return d if d > lb else lb


cdef inline double corners_box_sqdist(const double* b, const double* t, double lim2) noexcept nogil:
    """The largest squared distance of the three corners of ``t`` (9 doubles) to box ``b``,
    or, once one exceeds ``lim2``, that one (enough to know the triangle is out of reach)."""
    cdef double d0
    return corners_box_sqdist0(b, t, lim2, &d0)


cdef inline int piece_depth(int code) noexcept nogil:
    return code >> PIECE_DEPTH_SHIFT


cdef inline void piece_split(int code, int* out) noexcept nogil:
    """The codes of the four children of piece ``code``: the three at its corners, then the
    middle one (turned the other way)."""
    cdef int d = (piece_depth(code) + 1) << PIECE_DEPTH_SHIFT
    cdef int i = 2 * ((code >> PIECE_BITS) & PIECE_MASK)
    cdef int j = 2 * (code & PIECE_MASK)
    if code & PIECE_DOWN:
        out[0] = d | PIECE_DOWN | ((i + 1) << PIECE_BITS) | j
        out[1] = d | PIECE_DOWN | (i << PIECE_BITS) | (j + 1)
        out[2] = d | PIECE_DOWN | ((i + 1) << PIECE_BITS) | (j + 1)
        out[3] = d | ((i + 1) << PIECE_BITS) | (j + 1)
    else:
        out[0] = d | (i << PIECE_BITS) | j
        out[1] = d | ((i + 1) << PIECE_BITS) | j
        out[2] = d | (i << PIECE_BITS) | (j + 1)
        out[3] = d | PIECE_DOWN | (i << PIECE_BITS) | j


cdef inline double corners_sqdist(const double* x, const double* t, double lim2) noexcept nogil:
    """The largest squared distance of the three points x (9 doubles) to triangle t -- or,
    as soon as one is above ``lim2``, that one's."""
    cdef double v = tri_sqdist(x, t), d
    if v > lim2:
        return v
    d = tri_sqdist(&x[3], t)
    if d > v:
        v = d
        if v > lim2:
            return v
    d = tri_sqdist(&x[6], t)
    return d if d > v else v


# The flat-patch certificate (Bound.patch_cover): a triangle t, and the input triangles near
# it projected onto t's plane.  PATCH_MARGIN (normalised units: the positions have a unit
# diagonal) is the margin of every test in that plane, far above the rounding of the
# projected coordinates (about 1e-16).
cdef double PATCH_MARGIN = 1e-10
cdef double PLACE_NEAR = 1.0 / 4.0
# where in t the patch's winding number is counted (barycentric weights): the centroid,
# then two points no regular grid puts on its lines
cdef double PATCH_AT[9]
PATCH_AT[:] = [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0, 0.4142135, 0.3183099, 0.2674766, 0.2718282, 0.4472136, 0.2809582]


cdef inline bint patch_taken(const unsigned long long* used, int hsh) noexcept nogil:
    """Is slot hsh of the flat patch's table taken (its bit in ``used``)?"""
    return (used[hsh >> 6] >> (hsh & 63)) & 1


cdef inline int patch_slot(const int* seen, const unsigned long long* used, int t) noexcept nogil:
    """The slot of input triangle t in the flat patch's open-addressing table ``seen``
    (BOUND_PATCH_HASH slots, those taken marked in the bitmap ``used``, which alone is
    cleared per call): where t is, or the empty slot it would take."""
    cdef int hsh = (<unsigned int>t * 2654435761u) & (BOUND_PATCH_HASH - 1)
    while patch_taken(used, hsh) and seen[hsh] != t:
        hsh = (hsh + 1) & (BOUND_PATCH_HASH - 1)
    return hsh


cdef inline void patch_mark(int* seen, unsigned long long* used, int hsh, int t) noexcept nogil:
    seen[hsh] = t
    used[hsh >> 6] |= 1ULL << (hsh & 63)


# (k + 1) % 3 and (k + 2) % 3 for a corner k: NEXT3[k], NEXT3[k + 1]
cdef int NEXT3[5]
NEXT3[:] = [1, 2, 0, 1, 2]


cdef struct Frame:
    double o[3]          # t's first corner
    double u[3]          # unit vectors in t's plane
    double v[3]
    double n[3]          # t's unit normal (u x v)
    double p[6]          # t's corners in (u, v): (0, 0), then b, c (counter-clockwise)
    double d[6]          # t's edges' unit directions (corner k to k + 1)
    double lo[2]         # t's box in the plane, grown by the margin
    double hi[2]


cdef inline void frame_project(const Frame* f, const double* x, double* uv, double* h) noexcept nogil:
    """x in the frame: (u, v) in the plane, and h its signed distance from the plane."""
    cdef double r0 = x[0] - f.o[0], r1 = x[1] - f.o[1], r2 = x[2] - f.o[2]
    uv[0] = f.u[0] * r0 + f.u[1] * r1 + f.u[2] * r2
    uv[1] = f.v[0] * r0 + f.v[1] * r1 + f.v[2] * r2
    h[0] = f.n[0] * r0 + f.n[1] * r1 + f.n[2] * r2


cdef inline double frame_inside(const Frame* f, int k, const double* q) noexcept nogil:
    """The distance of q (in the plane) inside edge k of t's projection (negative: outside)."""
    return f.d[2 * k] * (q[1] - f.p[2 * k + 1]) - f.d[2 * k + 1] * (q[0] - f.p[2 * k])


cdef bint frame_apart(const Frame* f, const double* q, int m) noexcept nogil:
    """Is the convex hull of the m points q (in the plane: m = 2 a segment, 3 a triangle)
    apart from t's projection shrunk by the margin (the points at least PATCH_MARGIN inside
    each of its edges)?  True only if a line separates them: an edge of t shifted inwards by
    the margin with all of q outside it, or an edge of q's hull with t's three corners more
    than the margin beyond it (and q's hull on its other side).  False can mean "not sure"."""
    cdef int k, i, j
    cdef double lo, hi, ex, ey, le, s0, s1, s2, third
    cdef double ins[9]
    # the boxes first
    lo = hi = q[0]
    for i in range(1, m):
        if q[2 * i] < lo:
            lo = q[2 * i]
        if q[2 * i] > hi:
            hi = q[2 * i]
    if hi < f.lo[0] or lo > f.hi[0]:
        return True
    lo = hi = q[1]
    for i in range(1, m):
        if q[2 * i + 1] < lo:
            lo = q[2 * i + 1]
        if q[2 * i + 1] > hi:
            hi = q[2 * i + 1]
    if hi < f.lo[1] or lo > f.hi[1]:
        return True
    # each point's distance inside t's three edges: one that is inside all three by the
    # margin settles it (no line can separate: the triangles under t mostly stop here)
    for i in range(m):
        ins[3 * i] = frame_inside(f, 0, &q[2 * i])
        ins[3 * i + 1] = frame_inside(f, 1, &q[2 * i])
        ins[3 * i + 2] = frame_inside(f, 2, &q[2 * i])
        if ins[3 * i] >= PATCH_MARGIN and ins[3 * i + 1] >= PATCH_MARGIN and ins[3 * i + 2] >= PATCH_MARGIN:
            return False
    for k in range(3):
        for i in range(m):
            if ins[3 * i + k] >= PATCH_MARGIN:
                break
        else:
            return True
    for i in range(m if m == 3 else 1):
        j = (i + 1) % m
        ex = q[2 * j] - q[2 * i]
        ey = q[2 * j + 1] - q[2 * i + 1]
        le = sqrt(ex * ex + ey * ey)
        if not (le > 0.0):
            continue
        s0 = (ex * (f.p[1] - q[2 * i + 1]) - ey * (f.p[0] - q[2 * i])) / le
        s1 = (ex * (f.p[3] - q[2 * i + 1]) - ey * (f.p[2] - q[2 * i])) / le
        s2 = (ex * (f.p[5] - q[2 * i + 1]) - ey * (f.p[4] - q[2 * i])) / le
        third = 0.0
        if m == 3:
            third = ex * (q[2 * ((i + 2) % 3) + 1] - q[2 * i + 1]) - ey * (q[2 * ((i + 2) % 3)] - q[2 * i])
        if third >= 0.0 and s0 < -PATCH_MARGIN and s1 < -PATCH_MARGIN and s2 < -PATCH_MARGIN:
            return True
        if third <= 0.0 and s0 > PATCH_MARGIN and s1 > PATCH_MARGIN and s2 > PATCH_MARGIN:
            return True
    return False


cdef inline int winding(const double* q, const double* x) noexcept nogil:
    """The winding number of triangle q's boundary (in the plane, q[0] -> q[1] -> q[2]) around
    x: +1 inside a counter-clockwise q, -1 inside a clockwise one, 0 outside; 2 when x is
    too near one of q's edge lines to tell (within PATCH_MARGIN) and the others do not
    decide."""
    cdef int k, j, pos = 0, neg = 0, amb = 0
    cdef double ex, ey, c, le
    for k in range(3):
        j = (k + 1) % 3
        ex = q[2 * j] - q[2 * k]
        ey = q[2 * j + 1] - q[2 * k + 1]
        c = ex * (x[1] - q[2 * k + 1]) - ey * (x[0] - q[2 * k])
        le = PATCH_MARGIN * sqrt(ex * ex + ey * ey)
        if c > le:
            pos += 1
        elif c < -le:
            neg += 1
        else:
            amb += 1
    if pos > 0 and neg > 0:
        return 0
    if amb > 0:
        return 2
    return 1 if pos == 3 else -1


cdef void face_balls(const double* tris, int n, double* balls) noexcept nogil:
    """A ball around each of the n triangles (centroid, farthest corner; 4 doubles each, the
    radius a hair large for rounding): a point farther than r from a ball is farther than r
    from its triangle, which fits and place skip so."""
    cdef int i, c, a
    cdef double r2, d
    for i in range(n):
        for a in range(3):
            balls[4 * i + a] = (tris[9 * i + a] + tris[9 * i + 3 + a] + tris[9 * i + 6 + a]) / 3.0
        r2 = 0.0
        for c in range(3):
            d = (sq(tris[9 * i + 3 * c] - balls[4 * i]) + sq(tris[9 * i + 3 * c + 1] - balls[4 * i + 1])
                 + sq(tris[9 * i + 3 * c + 2] - balls[4 * i + 2]))
            if d > r2:
                r2 = d
        balls[4 * i + 3] = sqrt(r2) * (1.0 + 1e-12) + 1e-300


cdef inline bint ball_beyond(const double* ball, const double* x, double r) noexcept nogil:
    """Is x farther than r from the ball (so from its triangle)?"""
    return point_sqdist(x, ball) > sq(ball[3] + r)


cdef extern from *:
    """
    /* slots for new pieces: taken by the pass driver's threads at once (relaxed: the
       passes' barriers order the pieces' writes before any other thread reads them) */
    #if defined(_MSC_VER)
    #include <intrin.h>
    static int lodkit_bound_take(int* counter, int n) {
        return (int)_InterlockedExchangeAdd((volatile long*)counter, (long)n);
    }
    #else
    static int lodkit_bound_take(int* counter, int n) {
        return __atomic_fetch_add(counter, n, __ATOMIC_RELAXED);
    }
    #endif
    """
    int lodkit_bound_take(int* counter, int n) noexcept nogil


cdef class Bound:
    """The error-bound state of one run.

    hm      : the half-edge mesh (its live faces are the original O)
    vdata   : the collapser's per-vertex rows; the position starts at column ``offset``
    eps     : the bound, in the units of the positions
    spacing : the finest pieces of the original: their covering radius at most ``spacing * eps``
    """

    def __init__(self, HalfEdgeMesh hm, double[:, ::1] vdata, int offset, double eps, double spacing=0.25):
        if not (eps >= 0.0):
            raise ValueError("eps must be >= 0")
        if not (0.0 < spacing < 1.0):
            raise ValueError("spacing must be in (0, 1)")
        self.eps = eps
        self.eps2 = eps * eps
        self.m = &hm.c
        self.keep = (hm, vdata)
        self.stride = vdata.shape[1]
        self.P = &vdata[0, offset]
        pos = np.asarray(vdata)[:, offset:offset + 3]
        faces = np.flatnonzero(np.asarray(hm.alive_faces, dtype=bool)).astype(np.intc)
        corners = np.asarray(hm.corners)[faces]
        tris = np.ascontiguousarray(pos[corners].reshape(-1, 9))
        n_tri = tris.shape[0]
        if n_tri > MAX_PIECES:
            raise ValueError(f"the error bound takes inputs of at most {MAX_PIECES} triangles, not {n_tri}")
        # the BVH
        cap = max(2 * n_tri, 1)
        self.box = np.zeros((cap, 6))
        self.left = np.full(cap, -1, dtype=np.intc)
        self.first = np.zeros(cap, dtype=np.intc)
        self.count = np.zeros(cap, dtype=np.intc)
        idx = np.arange(n_tri, dtype=np.intc)
        cent = np.ascontiguousarray((tris[:, 0:3] + tris[:, 3:6] + tris[:, 6:9]) / 3.0)
        lo = np.minimum(np.minimum(tris[:, 0:3], tris[:, 3:6]), tris[:, 6:9])
        hi = np.maximum(np.maximum(tris[:, 0:3], tris[:, 3:6]), tris[:, 6:9])
        tb = np.ascontiguousarray(np.concatenate([lo, hi], axis=1))
        cdef int[::1] I = idx
        cdef double[:, ::1] C = cent
        cdef double[:, ::1] TB = tb
        cdef int nt = n_tri
        if nt > 0:
            with nogil:
                self.n_nodes = self.build(&I[0], &C[0, 0], &TB[0, 0], nt)
        else:
            self.n_nodes = 0
        tri = np.ascontiguousarray(tris[idx]) if n_tri else np.zeros((1, 9))
        self.tri = tri
        # each triangle's neighbours across its edges (BVH rows; the half-edge twins: the
        # same two corners the other way round), for the flat-patch certificate
        row_of_face = np.full(max(hm.n_faces, 1), -1, dtype=np.intc)
        row_of_face[faces[idx]] = np.arange(n_tri, dtype=np.intc)
        if n_tri:
            tw = np.asarray(hm.twins)[(3 * faces[idx])[:, None] + np.arange(3)]
            self.nbr = np.ascontiguousarray(np.where(tw >= 0, row_of_face[np.maximum(tw, 0) // 3], -1),
                                            dtype=np.intc)
            # nbe[T, j]: which edge of that neighbour N is the twin (N's corners nbe, nbe + 1
            # are T's j + 1, j), -1 when none or when those corners are not the very same
            # points (then the flat patch projects all of N's corners)
            self.nbe = np.ascontiguousarray(np.where(tw >= 0, tw % 3, -1), dtype=np.intc)
            self.link_edges(n_tri)
        else:
            self.nbr = np.full((1, 3), -1, dtype=np.intc)
            self.nbe = np.full((1, 3), -1, dtype=np.intc)
        # each triangle's own box, a cheap test before its distance
        self.tbox = np.ascontiguousarray(tb[idx]) if n_tri else np.zeros((1, 6))
        # the pieces of the original: at first each triangle whole (a piece of depth 0, code
        # 0), on its own face; triangle t splits down to depth tdepth[t] at most, where its
        # pieces' covering radius is spacing * eps
        base = tri.copy()
        base[:, 3:6] -= tri[:, 0:3]
        base[:, 6:9] -= tri[:, 0:3]
        self.base = base
        depth = np.zeros(max(n_tri, 1), dtype=np.intc)
        self.tdepth = depth
        cdef double s = spacing * eps, h
        cdef int t
        for t in range(nt):
            h = covering_radius(&self.tri[t, 0])
            while self.tdepth[t] < BOUND_PIECE_DEPTH and h > s * (1 << self.tdepth[t]):
                self.tdepth[t] += 1
        # slots: a triangle split all the way has 4**depth pieces; beyond MAX_PIECES in all
        # the run may run out of them (the driver then raises OptionError)
        self.capacity = int(min(MAX_PIECES, max(int((4 ** depth[:n_tri].astype(np.int64)).sum()), 1)))
        self.ptri = np.empty(self.capacity, dtype=np.intc)
        self.pcode = np.empty(self.capacity, dtype=np.intc)
        self.nxt = np.empty(self.capacity, dtype=np.intc)
        n_faces = hm.n_faces
        head = np.full(max(n_faces, 1), -1, dtype=np.intc)
        face_of = faces[idx]
        head[face_of] = np.arange(n_tri, dtype=np.intc)
        self.head = head
        # each face is covered by its own triangle, the first guess when a collapse moves it
        ctri = np.full(max(n_faces, 1), -1, dtype=np.intc)
        ctri[face_of] = np.arange(n_tri, dtype=np.intc)
        self.ctri = ctri
        self.pending_tri = np.full(max(n_faces, 1), -1, dtype=np.intc)
        self.pending_keep = np.full(max(n_faces, 1), -1.0)
        np.asarray(self.ptri)[:n_tri] = np.arange(n_tri, dtype=np.intc)
        np.asarray(self.pcode)[:n_tri] = 0
        np.asarray(self.nxt)[:n_tri] = -1
        self.n_used = n_tri
        self.overflow = False
        self.sphere = np.zeros((max(n_faces, 1), 4))
        self.cert = np.zeros(max(n_faces, 1))
        self.fval = np.zeros(max(n_faces, 1))
        self.pdist = np.zeros(max(n_faces, 1))
        self.pending = np.zeros(max(n_faces, 1))
        self.last = np.zeros(max(hm.n_vertices, 1))
        self.vd2 = np.full(max(hm.n_vertices, 1), -1.0)
        self.vtri = np.full(max(hm.n_vertices, 1), -1, dtype=np.intc)
        self.vver = np.zeros(max(hm.n_vertices, 1), dtype=np.intc)
        memo = np.empty((max(hm.n_edges, 1), 5), dtype=np.intc)
        memo[:, 0] = -1                       # nothing refused yet
        self.memo = memo
        self.memo_p = np.zeros((max(hm.n_edges, 1), 3))
        cdef int[::1] F = faces
        cdef int f
        with nogil:
            for f in range(F.shape[0]):
                self.fit_sphere(F[f])

    cdef int build(self, int* idx, const double* cent, const double* tb, int n) noexcept nogil:
        """Top-down BVH: split at the median centroid along the longest axis of the
        centroids' box, leaves of LEAF_SIZE triangles at most; nodes in depth-first order,
        the two children of a node next to each other.  Returns the number of nodes."""
        cdef int stack_node[128]
        cdef int stack_lo[128]
        cdef int stack_hi[128]
        cdef int sp = 0, nn = 1, node, lo, hi, i, j, ax, mid
        cdef double clo[3]
        cdef double chi[3]
        cdef double ext, best
        if n == 0:
            return 0
        stack_node[0] = 0
        stack_lo[0] = 0
        stack_hi[0] = n
        sp = 1
        while sp > 0:
            sp -= 1
            node = stack_node[sp]
            lo = stack_lo[sp]
            hi = stack_hi[sp]
            for j in range(3):
                self.box[node, j] = INFINITY
                self.box[node, 3 + j] = -INFINITY
                clo[j] = INFINITY
                chi[j] = -INFINITY
            for i in range(lo, hi):
                for j in range(3):
                    if tb[6 * idx[i] + j] < self.box[node, j]:
                        self.box[node, j] = tb[6 * idx[i] + j]
                    if tb[6 * idx[i] + 3 + j] > self.box[node, 3 + j]:
                        self.box[node, 3 + j] = tb[6 * idx[i] + 3 + j]
                    if cent[3 * idx[i] + j] < clo[j]:
                        clo[j] = cent[3 * idx[i] + j]
                    if cent[3 * idx[i] + j] > chi[j]:
                        chi[j] = cent[3 * idx[i] + j]
            if hi - lo <= LEAF_SIZE or sp + 2 > 128:
                self.left[node] = -1
                self.first[node] = lo
                self.count[node] = hi - lo
                continue
            ax = 0
            best = chi[0] - clo[0]
            for j in range(1, 3):
                ext = chi[j] - clo[j]
                if ext > best:
                    best = ext
                    ax = j
            mid = (lo + hi) // 2
            select_nth(idx, cent, ax, lo, hi - 1, mid)
            self.left[node] = nn
            stack_node[sp] = nn
            stack_lo[sp] = lo
            stack_hi[sp] = mid
            stack_node[sp + 1] = nn + 1
            stack_lo[sp + 1] = mid
            stack_hi[sp + 1] = hi
            sp += 2
            nn += 2
        return nn

    cdef void link_edges(self, int n) noexcept nogil:
        """Keep nbe[T, j] (the twin's edge in the neighbour N across T's edge j) only where
        N's corners nbe, nbe + 1 are T's corners j + 1, j -- the very same points; else -1,
        and the flat patch projects all of N's corners."""
        cdef int t, j, m, nb
        for t in range(n):
            for j in range(3):
                m = self.nbe[t, j]
                nb = self.nbr[t, j]
                if m < 0 or nb < 0:
                    self.nbe[t, j] = -1
                elif not (same_point(&self.tri[nb, 3 * m], &self.tri[t, 3 * ((j + 1) % 3)])
                          and same_point(&self.tri[nb, 3 * ((m + 1) % 3)], &self.tri[t, 3 * j])):
                    self.nbe[t, j] = -1

    # ------------------------------------------------------------- queries
    cdef bint within(self, const double* x, double d2) noexcept nogil:
        """Is x within sqrt(d2) of the original?"""
        cdef int near = -1
        return self.nearest2(x, d2, &near) <= d2

    cdef double nearest2(self, const double* x, double stop2, int* near) noexcept nogil:
        """The squared distance from x to the original -- or, as soon as a triangle within
        ``stop2`` is found, that triangle's (an upper bound, <= stop2).  ``near``: in, a
        triangle to try first (its row in ``tri``; -1 none), out, the one found (-1 when
        the original is empty)."""
        cdef int stack[BOUND_STACK]
        cdef double sdist[BOUND_STACK]        # the node's box's squared distance to x
        cdef int sp = 1, node, i, a
        cdef double best = INFINITY, d, da, db
        if near[0] >= 0:
            best = tri_sqdist(x, &self.tri[near[0], 0])
            if best <= stop2:
                return best
        if self.n_nodes == 0:
            return INFINITY
        stack[0] = 0
        sdist[0] = box_sqdist(&self.box[0, 0], x)
        while sp > 0:
            sp -= 1
            node = stack[sp]
            if sdist[sp] >= best:
                continue
            if self.left[node] < 0:
                for i in range(self.first[node], self.first[node] + self.count[node]):
                    if box_sqdist(&self.tbox[i, 0], x) >= best:
                        continue               # no nearer than the best yet
                    d = tri_sqdist(x, &self.tri[i, 0])
                    if d < best:
                        best = d
                        near[0] = i
                        if best <= stop2:
                            return best
                continue
            a = self.left[node]
            da = box_sqdist(&self.box[a, 0], x)
            db = box_sqdist(&self.box[a + 1, 0], x)
            if da <= db:               # the nearer child on top
                stack[sp] = a + 1
                sdist[sp] = db
                stack[sp + 1] = a
                sdist[sp + 1] = da
            else:
                stack[sp] = a
                sdist[sp] = da
                stack[sp + 1] = a + 1
                sdist[sp + 1] = db
            sp += 2
        return best

    cdef double cover2(self, const double* t, const int* hints, int* cover, bint least,
                       bint search=True) noexcept nogil:
        """min over original triangles T of max over t's corners of their squared distance
        to T, if that is at most eps**2 (``cover`` gets that T's row), else INFINITY (and
        -1).  The three ``hints`` (rows, -1 none) are tried first: the best of them within
        eps bounds the search from the start, which then prunes all the more; unless
        ``least``, it is the answer (some T within eps, not the nearest: a certificate all
        the same, found without searching).  Unless ``search``, no hint within eps is the
        answer too (INFINITY, without searching)."""
        cdef int stack[BOUND_STACK]
        cdef double sval[BOUND_STACK]         # corners_box_sqdist of the node, when pushed
        cdef int sp = 1, node, i, c, a, near, far
        cdef double found = INFINITY, bound = self.eps2, v, va, vb, vn, vf, da, db
        cover[0] = -1
        for c in range(3):
            if hints[c] >= 0:
                v = corners_sqdist(t, &self.tri[hints[c], 0], bound)
                if v <= bound:
                    bound = v
                    found = v
                    cover[0] = hints[c]
        if self.n_nodes == 0 or (found <= self.eps2 and not least) or (found > self.eps2 and not search):
            return found
        # a node is pushed with corners_box_sqdist of its box, taken against the bound then
        # (all three corners unless one was past it: then it is not pushed), and dropped when
        # popped if that is past the bound now -- as if it were taken again
        stack[0] = 0
        sval[0] = corners_box_sqdist(&self.box[0, 0], t, bound)
        while sp > 0:
            sp -= 1
            node = stack[sp]
            if sval[sp] > bound:
                continue
            if self.left[node] < 0:
                for i in range(self.first[node], self.first[node] + self.count[node]):
                    if corners_box_sqdist(&self.tbox[i, 0], t, bound) > bound:
                        continue               # a corner is farther than the bound
                    v = corners_sqdist(t, &self.tri[i, 0], bound)
                    if v <= bound:
                        bound = v
                        found = v
                        cover[0] = i
                continue
            a = self.left[node]
            va = corners_box_sqdist0(&self.box[a, 0], t, bound, &da)
            vb = corners_box_sqdist0(&self.box[a + 1, 0], t, bound, &db)
            # the child nearer the first corner on top (pushed last)
            if da <= db:
                near, vn, far, vf = a, va, a + 1, vb
            else:
                near, vn, far, vf = a + 1, vb, a, va
            if vf <= bound:
                stack[sp] = far
                sval[sp] = vf
                sp += 1
            if vn <= bound:
                stack[sp] = near
                sval[sp] = vn
                sp += 1
        return found

    cdef double vertex_dist2(self, int v, const double* x, int* near) noexcept nogil:
        """The squared distance of vertex v, at x, to the original (and the triangle it is
        found on, in ``near``): kept until v moves (commit_end forgets it), as only the
        kept vertex of a collapse does.  Written by the check of a collapse whose 1-ring
        holds v: the pass driver's threads never share one."""
        if self.vd2[v] < 0.0:
            # no first guess: the triangle found then depends on v's position alone (ties
            # alike), so the first guesses made from it do not depend on when it was asked
            self.vtri[v] = -1
            self.vd2[v] = self.nearest2(x, 0.0, &self.vtri[v])
        near[0] = self.vtri[v]
        return self.vd2[v]

    cdef double pair_cover2(self, const double* t, int ta, int tb) noexcept nogil:
        """The largest squared distance of triangle t's points to the union of original
        triangles ta and tb, if they share an edge: the plane through that edge which
        halves the angle between them (normal u_a - u_b, u the unit vector in each
        triangle's plane from the edge to its third corner; a flat pair gives the plane
        square to both) cuts t in two convex parts, each with its corners on the cut, and
        the distance to ta on ta's side, to tb on tb's, is largest at those corners
        (convexity).  INFINITY when they share no edge, or past eps**2."""
        cdef const double* A = &self.tri[ta, 0]
        cdef const double* B = &self.tri[tb, 0]
        cdef int ia[2]
        cdef int ib[2]
        cdef int i, j, na = 0, oa, ob
        cdef double e[3]
        cdef double ua[3]
        cdef double ub[3]
        cdef double m[3]
        cdef double x[3]
        cdef double sd[3]
        cdef double le, la, lb, w, v = 0.0, d
        for i in range(3):
            for j in range(3):
                if same_point(&A[3 * i], &B[3 * j]):
                    if na == 2:
                        return INFINITY                # the same triangle twice
                    ia[na] = i
                    ib[na] = j
                    na += 1
        if na != 2:
            return INFINITY
        oa = 3 - ia[0] - ia[1]
        ob = 3 - ib[0] - ib[1]
        for i in range(3):
            e[i] = A[3 * ia[1] + i] - A[3 * ia[0] + i]
            ua[i] = A[3 * oa + i] - A[3 * ia[0] + i]
            ub[i] = B[3 * ob + i] - A[3 * ia[0] + i]
        le = dot3(e, e)
        if not (le > 0.0):
            return INFINITY
        la = dot3(ua, e) / le
        lb = dot3(ub, e) / le
        for i in range(3):
            ua[i] -= la * e[i]
            ub[i] -= lb * e[i]
        la = norm3(ua)
        lb = norm3(ub)
        if not (la > 0.0 and lb > 0.0):
            return INFINITY
        for i in range(3):
            m[i] = ua[i] / la - ub[i] / lb
        if not (dot3(m, m) > 1e-12):
            return INFINITY                        # folded onto each other: no plane between
        for i in range(3):
            sub3(&t[3 * i], &A[3 * ia[0]], x)
            sd[i] = dot3(x, m)
            if sd[i] >= 0.0:
                d = tri_sqdist(&t[3 * i], A)
                if d > v:
                    v = d
            if sd[i] <= 0.0:
                d = tri_sqdist(&t[3 * i], B)
                if d > v:
                    v = d
            if v > self.eps2:
                return INFINITY
        for i in range(3):
            j = (i + 1) % 3
            if (sd[i] > 0.0 and sd[j] < 0.0) or (sd[i] < 0.0 and sd[j] > 0.0):
                w = sd[i] / (sd[i] - sd[j])
                for na in range(3):
                    x[na] = t[3 * i + na] + w * (t[3 * j + na] - t[3 * i + na])
                d = tri_sqdist(x, A)
                if d > v:
                    v = d
                d = tri_sqdist(x, B)
                if d > v:
                    v = d
                if v > self.eps2:
                    return INFINITY
        return v

    cdef double patch_cover(self, const double* t, const int* seeds, int n_seeds, int* cover) noexcept nogil:
        """A certified bound (<= eps) on the distance of triangle t's points to the original
        from a patch of input triangles under it, or -1 (docs/error-bound.md, "a flat
        patch").  Project onto t's plane; the patch is the input triangles, connected
        across their edges to the first of ``seeds`` (rows, -1 none) that qualifies, whose
        projection is not apart from t's (shrunk by the margin) -- each of them with its
        corners within eps of the plane, else -1.  If no edge of the original's border in
        the patch meets t's shrunk projection and the patch's triangles wind around a point
        of it, they cover it all: each point x of t has a point y of the original straight
        above or below it, |x - y| = |h(y)| at most the largest |h| of the patch's corners
        (h affine on each triangle).  The margins add their slack to the bound.  ``cover``
        gets the seed."""
        cdef Frame f
        cdef int rows[BOUND_PATCH_MAX]
        cdef double q2[6 * BOUND_PATCH_MAX]
        cdef int seen[BOUND_PATCH_HASH]
        cdef unsigned long long used[BOUND_PATCH_HASH >> 6]
        cdef double hr[3 * BOUND_PATCH_MAX]
        cdef double* qt
        cdef double* ht
        cdef double e1[3]
        cdef double e2[3]
        cdef double x0[2]
        cdef double q[6]
        cdef double hq[3]
        cdef double l1, l2, l3, big, area, r, slack, lim, H = 0.0
        cdef int i, j, k, c, m, n = 0, head = 0, n_seen = 0, T, N, w, tries
        cdef unsigned int hsh
        # the frame: u along t's first edge, n its normal, v = n x u
        for i in range(3):
            f.o[i] = t[i]
            e1[i] = t[3 + i] - t[i]
            e2[i] = t[6 + i] - t[i]
        l1 = norm3(e1)
        f.n[0] = e1[1] * e2[2] - e1[2] * e2[1]
        f.n[1] = e1[2] * e2[0] - e1[0] * e2[2]
        f.n[2] = e1[0] * e2[1] - e1[1] * e2[0]
        area = norm3(f.n)                      # twice t's area
        if not (l1 > 0.0 and area > 0.0):
            return -1.0
        for i in range(3):
            f.u[i] = e1[i] / l1
            f.n[i] /= area
        f.v[0] = f.n[1] * f.u[2] - f.n[2] * f.u[1]
        f.v[1] = f.n[2] * f.u[0] - f.n[0] * f.u[2]
        f.v[2] = f.n[0] * f.u[1] - f.n[1] * f.u[0]
        f.p[0] = f.p[1] = 0.0
        frame_project(&f, &t[3], &f.p[2], &hq[0])
        frame_project(&f, &t[6], &f.p[4], &hq[0])
        for k in range(3):
            j = (k + 1) % 3
            f.d[2 * k] = f.p[2 * j] - f.p[2 * k]
            f.d[2 * k + 1] = f.p[2 * j + 1] - f.p[2 * k + 1]
            l2 = sqrt(f.d[2 * k] * f.d[2 * k] + f.d[2 * k + 1] * f.d[2 * k + 1])
            if not (l2 > 0.0):
                return -1.0
            f.d[2 * k] /= l2
            f.d[2 * k + 1] /= l2
        for i in range(2):
            f.lo[i] = f.p[i]
            f.hi[i] = f.p[i]
            for k in range(1, 3):
                if f.p[2 * k + i] < f.lo[i]:
                    f.lo[i] = f.p[2 * k + i]
                if f.p[2 * k + i] > f.hi[i]:
                    f.hi[i] = f.p[2 * k + i]
            f.lo[i] -= 2.0 * PATCH_MARGIN
            f.hi[i] += 2.0 * PATCH_MARGIN
        # the slack: a point of t is within margin * (longest edge / inradius) of t shrunk
        # by the margin (a homothety about the incentre), plus the margin for rounding
        l2 = norm3(e2)
        l3 = sqrt(sq(t[6] - t[3]) + sq(t[7] - t[4]) + sq(t[8] - t[5]))
        big = l1 if l1 > l2 else l2
        if l3 > big:
            big = l3
        r = area / (l1 + l2 + l3)              # the inradius: twice the area over the perimeter
        if not (r > 4.0 * PATCH_MARGIN and big < 1e4 * r):
            return -1.0                        # a sliver: the slack would not stay small
        slack = PATCH_MARGIN * (2.0 + big / r)
        lim = self.eps - slack
        if not (lim > 0.0):
            return -1.0
        for i in range(BOUND_PATCH_HASH >> 6):
            used[i] = 0
        # the seed: the first that is near t's projection (all of them are marked seen)
        for c in range(n_seeds):
            T = seeds[c]
            if T < 0:
                continue
            hsh = patch_slot(seen, used, T)
            if patch_taken(used, hsh):
                continue
            for k in range(3):
                frame_project(&f, &self.tri[T, 3 * k], &q[2 * k], &hq[k])
            if frame_apart(&f, q, 3) or fabs(hq[0]) > lim or fabs(hq[1]) > lim or fabs(hq[2]) > lim:
                continue                       # not marked: if the patch reaches it, it decides
            patch_mark(seen, used, hsh, T)
            n_seen += 1
            rows[0] = T
            for k in range(6):
                q2[k] = q[k]
            for k in range(3):
                hr[k] = hq[k]
                if fabs(hq[k]) > H:
                    H = fabs(hq[k])
            n = 1
            break
        if n == 0:
            return -1.0
        # grow it across the edges (breadth first)
        while head < n:
            T = rows[head]
            qt = &q2[6 * head]
            ht = &hr[3 * head]
            head += 1
            for j in range(3):
                N = self.nbr[T, j]
                if N < 0:
                    # a border edge of the original: it must stay apart from t
                    q[0] = qt[2 * j]
                    q[1] = qt[2 * j + 1]
                    q[2] = qt[2 * NEXT3[j]]
                    q[3] = qt[2 * NEXT3[j] + 1]
                    if not frame_apart(&f, q, 2):
                        return -1.0
                    continue
                hsh = patch_slot(seen, used, N)
                if patch_taken(used, hsh):
                    continue
                if n_seen >= BOUND_PATCH_HASH // 2:
                    return -1.0
                patch_mark(seen, used, hsh, N)
                n_seen += 1
                m = self.nbe[T, j]
                if m >= 0:
                    # N's corners m, m + 1 are T's j + 1, j (the same points): their
                    # projections are T's; only its third corner is new
                    c = NEXT3[j]
                    q[2 * m] = qt[2 * c]
                    q[2 * m + 1] = qt[2 * c + 1]
                    hq[m] = ht[c]
                    k = NEXT3[m]
                    q[2 * k] = qt[2 * j]
                    q[2 * k + 1] = qt[2 * j + 1]
                    hq[k] = ht[j]
                    k = NEXT3[m + 1]
                    frame_project(&f, &self.tri[N, 3 * k], &q[2 * k], &hq[k])
                else:
                    for k in range(3):
                        frame_project(&f, &self.tri[N, 3 * k], &q[2 * k], &hq[k])
                if frame_apart(&f, q, 3):
                    continue                   # its edges are apart from t too
                if fabs(hq[0]) > lim or fabs(hq[1]) > lim or fabs(hq[2]) > lim:
                    return -1.0
                if n >= BOUND_PATCH_MAX:
                    return -1.0
                rows[n] = N
                for k in range(6):
                    q2[6 * n + k] = q[k]
                for k in range(3):
                    hr[3 * n + k] = hq[k]
                    if fabs(hq[k]) > H:
                        H = fabs(hq[k])
                n += 1
        # the winding number around a point inside t's shrunk projection: the centroid, or
        # (on an edge of the patch, as on a regular grid) two points off-centre
        for tries in range(3):
            x0[0] = PATCH_AT[3 * tries] * f.p[0] + PATCH_AT[3 * tries + 1] * f.p[2] + PATCH_AT[3 * tries + 2] * f.p[4]
            x0[1] = PATCH_AT[3 * tries] * f.p[1] + PATCH_AT[3 * tries + 1] * f.p[3] + PATCH_AT[3 * tries + 2] * f.p[5]
            for k in range(3):
                if frame_inside(&f, k, x0) < 2.0 * PATCH_MARGIN:
                    return -1.0
            w = 0
            for i in range(n):
                c = winding(&q2[6 * i], x0)
                if c == 2:
                    w = 2 * BOUND_PATCH_MAX + 1
                    break
                w += c
            if w != 2 * BOUND_PATCH_MAX + 1:
                break
        if w == 0 or w == 2 * BOUND_PATCH_MAX + 1:
            return -1.0
        cover[0] = rows[0]
        return H + slack

    cdef double face_value(self, const double* t, int* cover, const int* vids, double* p2,
                           int* p_near) noexcept nogil:
        """A certified upper bound (<= eps) on the distance of triangle ``t``'s points to
        the original, or -1 when none is found (a corner of a piece is farther than eps,
        or the subdivision ran out of levels).  ``cover``: in, an original triangle to try
        first (-1: none; the one that covered the face before the collapse); out, the one
        that covers t whole, else one nearest a corner (the next collapse's first guess).
        ``vids``: the corners' vertices (:meth:`collect`; NULL: none), whose distances to
        the original are kept (:meth:`vertex_dist2`), -1 for the collapse's new point,
        whose distance the caller keeps in ``p2`` / ``p_near`` (< 0: not known yet).

        Each piece is accepted by one of two certificates: (a) one original triangle within
        eps of its three corners (convexity: then of all of it; exact, tried first on the
        face itself), (b) its corners within eps - h of the original, h its covering
        radius (the triangle inequality).  Otherwise it splits in four at its edges'
        midpoints.  The corners' distances, and the triangles they were found on (the
        first guesses for (a)), go down to the pieces that share them."""
        cdef double st[9 * (3 * BOUND_MAX_DEPTH + 4)]
        cdef double du[3 * (3 * BOUND_MAX_DEPTH + 4)]   # the corners' squared distances (see nearest2)
        cdef int dt[3 * (3 * BOUND_MAX_DEPTH + 4)]      # the triangles they were found on
        cdef int dep[3 * (3 * BOUND_MAX_DEPTH + 4)]
        cdef double mid[9]
        cdef double dm[3]
        cdef double pd[3]
        cdef int tm[3]
        cdef int pt[3]
        cdef int hint[3]
        cdef double* s
        cdef double* o
        cdef double* u
        cdef int n = 1, d, i, c, found
        cdef double worst2 = 0.0, b, hs, lim2, mx, v
        # (a) on the face itself first: most faces pass whole, and need nothing else (the
        # triangle that covered it before the collapse, its value the certificate: no
        # search for a nearer one; the search for any other waits until the flat patch
        # has failed)
        hint[0] = cover[0]
        hint[1] = hint[2] = -1
        b = self.cover2(t, hint, &found, False, False)
        if b <= self.eps2:
            cover[0] = found
            return sqrt(b)
        for i in range(9):
            st[i] = t[i]
        # the face's corners: the caller's p was found within eps; the others are vertices
        # of the current mesh (certified already) -- measured all the same
        for c in range(3):
            dt[c] = -1
            if vids == NULL:
                du[c] = self.nearest2(&t[3 * c], 0.0, &dt[c])
            elif vids[c] >= 0:
                du[c] = self.vertex_dist2(vids[c], &t[3 * c], &dt[c])
            else:
                if p2[0] < 0.0:
                    p2[0] = self.nearest2(&t[3 * c], 0.0, p_near)
                du[c] = p2[0]
                dt[c] = p_near[0]
            if du[c] > self.eps2:
                return -1.0
        # (d) a flat patch of the original under the whole face
        hint[1] = dt[0]
        hint[2] = dt[1]
        b = self.patch_cover(t, hint, 3, &found)
        if b >= 0.0:
            cover[0] = found
            return b
        # (a) again, any input triangle (a search of the hierarchy)
        hint[2] = dt[2]
        b = self.cover2(t, hint, &found, True)
        if b <= self.eps2:
            cover[0] = found
            return sqrt(b)
        cover[0] = dt[0]
        dep[0] = 0
        while n > 0:
            n -= 1
            s = &st[9 * n]
            u = &du[3 * n]
            d = dep[n]
            hs = covering_radius(s)
            mx = u[0]
            if u[1] > mx:
                mx = u[1]
            if u[2] > mx:
                mx = u[2]
            if hs < self.eps and mx <= sq(self.eps - hs):
                v = sq(sqrt(mx) + hs)
                if v > worst2:
                    worst2 = v
                continue
            if d > 0:
                b = self.cover2(s, &dt[3 * n], &found, False)
                if b <= self.eps2:
                    if b > worst2:
                        worst2 = b
                    continue
            # (c) two original triangles that share an edge, each for its side of the
            # plane between them (a piece across a ridge of the original)
            b = INFINITY
            for c in range(3):
                i = dt[3 * n + c]
                found = dt[3 * n + (c + 1) % 3]
                if i >= 0 and found >= 0 and i != found:
                    b = self.pair_cover2(s, i, found)
                    if b <= self.eps2:
                        break
            if b <= self.eps2:
                if b > worst2:
                    worst2 = b
                continue
            if d > 0:
                # (d) a flat patch of the original under the piece
                b = self.patch_cover(s, &dt[3 * n], 3, &found)
                if b >= 0.0:
                    if b * b > worst2:
                        worst2 = b * b
                    continue
            if d >= BOUND_MAX_DEPTH:
                return -1.0
            for i in range(3):
                mid[i] = 0.5 * (s[i] + s[3 + i])           # ab
                mid[3 + i] = 0.5 * (s[3 + i] + s[6 + i])   # bc
                mid[6 + i] = 0.5 * (s[6 + i] + s[i])       # ca
            # the children's covering radius is half this one's: the distances they need
            lim2 = sq(self.eps - 0.5 * hs) if 0.5 * hs < self.eps else 0.0
            for c in range(3):
                # the triangle an end of the edge was found on first: often near enough
                tm[c] = dt[3 * n + c]
                dm[c] = self.nearest2(&mid[3 * c], lim2, &tm[c])
                if dm[c] > self.eps2:
                    return -1.0                       # a point of the face is too far
            for c in range(3):
                pd[c] = u[c]
                pt[c] = dt[3 * n + c]
            # four children over slot n..n+3 (slot n is s itself: copy its corners first)
            o = &st[9 * (n + 1)]
            for i in range(3):
                o[i] = mid[i]                  # (ab, b, bc)
                o[3 + i] = s[3 + i]
                o[6 + i] = mid[3 + i]
                o[9 + i] = mid[6 + i]          # (ca, bc, c)
                o[12 + i] = mid[3 + i]
                o[15 + i] = s[6 + i]
                o[18 + i] = mid[i]             # (ab, bc, ca)
                o[21 + i] = mid[3 + i]
                o[24 + i] = mid[6 + i]
            for i in range(3):                 # (a, ab, ca) in place
                s[3 + i] = mid[i]
                s[6 + i] = mid[6 + i]
            u[1] = dm[0]
            u[2] = dm[2]
            dt[3 * n + 1] = tm[0]
            dt[3 * n + 2] = tm[2]
            du[3 * (n + 1)] = dm[0]
            du[3 * (n + 1) + 1] = pd[1]
            du[3 * (n + 1) + 2] = dm[1]
            dt[3 * (n + 1)] = tm[0]
            dt[3 * (n + 1) + 1] = pt[1]
            dt[3 * (n + 1) + 2] = tm[1]
            du[3 * (n + 2)] = dm[2]
            du[3 * (n + 2) + 1] = dm[1]
            du[3 * (n + 2) + 2] = pd[2]
            dt[3 * (n + 2)] = tm[2]
            dt[3 * (n + 2) + 1] = tm[1]
            dt[3 * (n + 2) + 2] = pt[2]
            du[3 * (n + 3)] = dm[0]
            du[3 * (n + 3) + 1] = dm[1]
            du[3 * (n + 3) + 2] = dm[2]
            dt[3 * (n + 3)] = tm[0]
            dt[3 * (n + 3) + 1] = tm[1]
            dt[3 * (n + 3) + 2] = tm[2]
            for i in range(4):
                dep[n + i] = d + 1
            n += 4
        return sqrt(worst2)

    # ------------------------------------------------------------- a collapse
    cdef int collect(self, int center, int fa, int fb, const double* p, double* tris, int* fids,
                     int* vids, int n) noexcept nogil:
        """Append the faces around ``center`` but fa, fb, with ``center`` at ``p``, to
        tris / fids (and, unless NULL, their corners' vertices to vids: -1 for ``center``)
        from row n on; returns the new count, -1 past BOUND_MAX_FAN."""
        cdef int start = self.m.v_he[center]
        cdef int y = start
        cdef int f, b, c, i
        while True:
            f = y // 3
            if f != fa and f != fb:
                if n >= BOUND_MAX_FAN:
                    return -1
                b = he_dest(self.m, y)
                c = self.m.corner[he_prev(y)]
                for i in range(3):
                    tris[9 * n + i] = p[i]
                    tris[9 * n + 3 + i] = self.P[self.stride * b + i]
                    tris[9 * n + 6 + i] = self.P[self.stride * c + i]
                fids[n] = f
                if vids != NULL:
                    vids[3 * n] = -1
                    vids[3 * n + 1] = b
                    vids[3 * n + 2] = c
                n += 1
            y = he_ring_next(self.m, y)
            if y < 0 or y == start:
                return n

    cdef int memo_kind(self, int r, int k, const double* p) noexcept nogil:
        """Which of the points a collapse of r into k is tried at ``p`` is, as a bit of
        ``memo``'s kinds: k's position 2, r's 4, their midpoint 8 (computed as
        EdgeCollapser.end_points does), any other 1 (the planned point, kept in memo_p)."""
        cdef const double* a = &self.P[self.stride * k]
        cdef const double* b = &self.P[self.stride * r]
        cdef double mid[3]
        cdef int i
        if same_point(p, a):
            return 2
        if same_point(p, b):
            return 4
        for i in range(3):
            mid[i] = 0.5 * (a[i] + b[i])
        return 8 if same_point(p, mid) else 1

    cdef bint check(self, int h, int r, int k, const double* p, int kind=0) noexcept nogil:
        """May half-edge h collapse (``r`` goes, ``k`` moves to ``p``) and the mesh stay
        within eps of the original both ways?  Writes ``pending`` of the new faces.
        ``kind``: which of the collapse's points ``p`` is, as a bit of ``memo``'s kinds
        (EdgeCollapser.end_points' placements name theirs); 0: work it out (memo_kind).

        A refusal is kept (``memo``, per edge) and given again without the work while no
        face around r or k has changed since (their versions, ``vver``, which every commit
        that changes a face raises for the face's corners): the check reads nothing else
        -- those faces, their corners' positions, their pieces and covers -- so it would
        refuse again.  Meanwhile the piece that refused it (memo's last column) is fitted
        first at the edge's other points: it is still on the same face of the fans, and
        whether one piece fails does not depend on the order they are tried in."""
        cdef int e = self.m.edge[h]
        cdef int q
        cdef int s = self.vver[r] + self.vver[k]
        cdef int* mm = &self.memo[e, 0]
        cdef bint same = mm[0] == r and mm[1] == k and mm[2] == s     # nothing changed since
        if kind == 0:
            kind = self.memo_kind(r, k, p)
        if same and (mm[3] & kind):
            if kind != 1 or same_point(p, &self.memo_p[e, 0]):
                return False
        # the piece that refused the last check of this edge, while nothing changed since:
        # tried first (it is still on the same face of the fans)
        q = mm[4] if same else -1
        if self.check_uncached(h, r, k, p, &q):
            return True
        if not same:
            mm[0] = r
            mm[1] = k
            mm[2] = s
            mm[3] = 0
            mm[4] = -1
        mm[3] |= kind
        if q >= 0:
            mm[4] = q
        if kind == 1:
            self.memo_p[e, 0] = p[0]
            self.memo_p[e, 1] = p[1]
            self.memo_p[e, 2] = p[2]
        return False

    cdef bint check_uncached(self, int h, int r, int k, const double* p, int* first) noexcept nogil:
        """check, always done.  ``first``: in, a piece on a face of the fans to fit first (-1
        none: whether one piece fails does not depend on the order); out, the piece that
        refused the collapse, else -1."""
        cdef double tris[9 * BOUND_MAX_FAN]
        cdef double balls[4 * BOUND_MAX_FAN]
        cdef int fids[BOUND_MAX_FAN]
        cdef int vids[3 * BOUND_MAX_FAN]
        cdef int fa = h // 3
        cdef int fb = self.m.twin[h] // 3 if self.m.twin[h] >= 0 else -1
        cdef int first_ = first[0]
        cdef int n, n_r, i, pass_, center, start, y, f, q, hint, cover, p_near = -1
        cdef double lim, v, move_r, move_k, p2 = -1.0
        cdef bint ok
        first[0] = -1
        if not self.within(p, self.eps2):
            return False
        n = self.collect(r, fa, fb, p, tris, fids, vids, 0)
        if n < 0:
            return False
        n_r = n
        n = self.collect(k, fa, fb, p, tris, fids, vids, n)
        if n < 0:
            return False
        face_balls(tris, n, balls)
        if first_ >= 0:
            hint = -1
            if not self.fits(self.ptri[first_], self.pcode[first_], tris, balls, n, &hint):
                first[0] = first_
                return False
        # original -> simplified: the pieces on every face the collapse changes, each within
        # eps of one new face.  A face passes whole when its corners are near enough one new
        # face (face_fits), or when its ball of pieces lies so near one; when that face is
        # its moved self (the one in its slot), its pieces stay on it (pending_keep)
        for pass_ in range(2):
            center = r if pass_ == 0 else k
            start = self.m.v_he[center]
            y = start
            while True:
                f = y // 3
                q = self.head[f]
                if pass_ == 0 or (f != fa and f != fb):
                    self.pending_keep[f] = -1.0
                if q >= 0 and (pass_ == 0 or (f != fa and f != fb)):
                    hint = -1
                    ok = False
                    lim = self.eps - self.sphere[f, 3]
                    for i in range(n):
                        if fids[i] == f:
                            hint = i
                    if hint >= 0:
                        self.pending_keep[f] = self.face_fits(f, &tris[9 * hint])
                        ok = self.pending_keep[f] >= 0.0
                    for i in range(n):
                        if not ok and i != hint and self.face_fits(f, &tris[9 * i]) >= 0.0:
                            ok = True
                    for i in range(n):
                        if not ok and lim >= 0.0 and tri_sqdist(&self.sphere[f, 0], &tris[9 * i]) <= lim * lim:
                            ok = True
                    while q >= 0 and not ok:
                        if not self.fits(self.ptri[q], self.pcode[q], tris, balls, n, &hint):
                            first[0] = q
                            return False
                        q = self.nxt[q]
                y = he_ring_next(self.m, y)
                if y < 0 or y == start:
                    break
        # simplified -> original: every new face.  First its face before (in its slot, the
        # moved end at its old place) and how far that end moves: each point of the new
        # face is the point of the old one with the same barycentric weights moved by at
        # most that much, so within the old face's certificate plus it of the original
        # (taken a hair large for rounding)
        move_r = sqrt(point_sqdist(p, &self.P[self.stride * r]))
        move_k = sqrt(point_sqdist(p, &self.P[self.stride * k]))
        for i in range(n):
            v = (self.fval[fids[i]] + (move_r if i < n_r else move_k)) * (1.0 + 1e-12)
            if v <= self.eps:
                self.pending[fids[i]] = v
                self.pending_tri[fids[i]] = self.ctri[fids[i]]
                continue
            cover = self.ctri[fids[i]]
            v = self.face_value(&tris[9 * i], &cover, &vids[3 * i], &p2, &p_near)
            if v < 0.0:
                return False
            self.pending[fids[i]] = v
            self.pending_tri[fids[i]] = cover
        return True

    cdef int commit_begin(self, int h, int r, int k) noexcept nogil:
        """Before collapsing h: detach the pieces on the faces around r and k into one
        chain (returned), but those of a face the check let keep them (``pending_keep``);
        those faces' certificates are redone by commit_end."""
        cdef int fa = h // 3
        cdef int fb = self.m.twin[h] // 3 if self.m.twin[h] >= 0 else -1
        cdef int chain = -1, pass_, center, start, y, f, q, nq
        for pass_ in range(2):
            center = r if pass_ == 0 else k
            start = self.m.v_he[center]
            y = start
            while True:
                f = y // 3
                if pass_ == 0 or (f != fa and f != fb):
                    # every face around r and k changes (or goes): its corners' refusals lapse
                    self.vver[self.m.corner[3 * f]] += 1
                    self.vver[self.m.corner[3 * f + 1]] += 1
                    self.vver[self.m.corner[3 * f + 2]] += 1
                    if self.pending_keep[f] >= 0.0 and self.head[f] >= 0:
                        # its pieces stay on it, within pending_keep of it (face_fits)
                        self.pdist[f] = self.pending_keep[f]
                        self.cert[f] = self.pending_keep[f]
                    else:
                        self.pending_keep[f] = -1.0
                        q = self.head[f]
                        while q >= 0:
                            nq = self.nxt[q]
                            self.nxt[q] = chain
                            chain = q
                            q = nq
                        self.head[f] = -1
                        self.cert[f] = 0.0
                        self.pdist[f] = 0.0
                y = he_ring_next(self.m, y)
                if y < 0 or y == start:
                    break
        return chain

    cdef double commit_end(self, int k, int chain) noexcept nogil:
        """After the collapse (k at its new position): place the chain's pieces on the
        faces around k (:meth:`place`), set those faces' certificates; returns the largest
        (the bound this collapse guarantees for what it changed), also kept in ``last[k]``."""
        cdef double tris[9 * BOUND_MAX_FAN]
        cdef double balls[4 * BOUND_MAX_FAN]
        cdef int fids[BOUND_MAX_FAN]
        cdef int n, i, q, nq, hint = -1
        cdef double worst = 0.0
        n = self.collect(k, -1, -1, &self.P[self.stride * k], tris, fids, NULL, 0)
        if n < 0:
            n = 0
        face_balls(tris, n, balls)
        for i in range(n):
            # (pieces kept on the face: their bound, commit_begin)
            self.fval[fids[i]] = self.pending[fids[i]]
            if self.pending[fids[i]] > self.cert[fids[i]]:
                self.cert[fids[i]] = self.pending[fids[i]]
            self.ctri[fids[i]] = self.pending_tri[fids[i]]
            if self.pending_keep[fids[i]] < 0.0:
                # no pieces kept: a new ball around its pieces, about the face's centroid,
                # grown by place as they come
                self.sphere[fids[i], 0] = balls[4 * i]
                self.sphere[fids[i], 1] = balls[4 * i + 1]
                self.sphere[fids[i], 2] = balls[4 * i + 2]
                self.sphere[fids[i], 3] = 0.0
        self.vd2[k] = -1.0                   # k moved
        q = chain
        while q >= 0:
            nq = self.nxt[q]
            self.place(q, tris, balls, fids, n, &hint)
            q = nq
        for i in range(n):
            if self.cert[fids[i]] > worst:
                worst = self.cert[fids[i]]
        self.last[k] = worst
        return worst

    # ------------------------------------------------------------- the pieces
    cdef void corners(self, int t, int code, double* x) noexcept nogil:
        """The corners (9 doubles) of piece ``code`` of original triangle t."""
        cdef double s = 1.0 / (1 << piece_depth(code))
        cdef double i = (code >> PIECE_BITS) & PIECE_MASK
        cdef double j = code & PIECE_MASK
        cdef double u[3]
        cdef double v[3]
        cdef int c, a
        if code & PIECE_DOWN:
            u[0] = (i + 1.0) * s
            u[1] = i * s
            u[2] = (i + 1.0) * s
            v[0] = j * s
            v[1] = (j + 1.0) * s
            v[2] = (j + 1.0) * s
        else:
            u[0] = i * s
            u[1] = (i + 1.0) * s
            u[2] = i * s
            v[0] = j * s
            v[1] = j * s
            v[2] = (j + 1.0) * s
        for c in range(3):
            for a in range(3):
                x[3 * c + a] = self.base[t, a] + u[c] * self.base[t, 3 + a] + v[c] * self.base[t, 6 + a]

    cdef bint fits(self, int t, int code, const double* tris, const double* balls, int n,
                   int* hint) noexcept nogil:
        """Is piece ``code`` of original triangle t within eps of the new faces ``tris``
        (n)?  A piece whose three corners are within eps of one face is (convexity); else
        its four children are tried, down to depth tdepth[t], where a piece that fits no
        face refuses.  ``hint``: the face to try first, -1 none; set to the last that fit
        (neighbouring pieces mostly fit the same face)."""
        cdef int stack[BOUND_PIECE_STACK]
        cdef int sp = 1, c, i, j
        cdef double x[9]
        stack[0] = code
        while sp > 0:
            sp -= 1
            c = stack[sp]
            self.corners(t, c, x)
            j = hint[0]
            if j >= 0 and corners_sqdist(x, &tris[9 * j], self.eps2) <= self.eps2:
                continue
            for i in range(n):
                if i != j and not ball_beyond(&balls[4 * i], x, self.eps) and \
                        corners_sqdist(x, &tris[9 * i], self.eps2) <= self.eps2:
                    hint[0] = i
                    break
            else:
                if piece_depth(c) >= self.tdepth[t]:
                    return False
                piece_split(c, &stack[sp])
                sp += 4
        return True

    cdef void place(self, int q, const double* tris, const double* balls, const int* fids, int n,
                    int* hint) noexcept nogil:
        """Attach piece q (its face is gone) to the new face nearest its three corners, if
        that holds them within eps; else split it as :meth:`fits` did (child 0 keeps slot
        q, the others take new slots) and place the children.  Each face's certificate
        takes the largest distance of its pieces' corners.  ``hint``: the face to measure
        first (-1 none), set to the last one a piece went to."""
        cdef int stack[BOUND_PIECE_STACK]
        cdef int kids[4]
        cdef int sp = 1, s, c, i, best, slot, t = self.ptri[q]
        cdef double x[9]
        cdef double v, bv
        stack[0] = q
        while sp > 0:
            sp -= 1
            s = stack[sp]
            c = self.pcode[s]
            self.corners(t, c, x)
            # the face the last piece went to first: with its distance to prune by, the
            # others mostly stop at their first corner
            best = hint[0]
            bv = corners_sqdist(x, &tris[9 * best], INFINITY) if best >= 0 else INFINITY
            for i in range(n if bv > PLACE_NEAR * self.eps2 else 0):
                if i != hint[0]:
                    if bv < INFINITY and ball_beyond(&balls[4 * i], x, sqrt(bv)):
                        continue               # its first corner is farther than the best
                    v = corners_sqdist(x, &tris[9 * i], bv)
                    if v < bv:
                        bv = v
                        best = i
            if best < 0:
                continue
            hint[0] = best
            if bv > self.eps2 and piece_depth(c) < self.tdepth[t] and not self.overflow:
                slot = lodkit_bound_take(&self.n_used, 3)
                if slot <= self.capacity - 3:
                    piece_split(c, kids)
                    self.pcode[s] = kids[0]
                    stack[sp] = s
                    for i in range(3):
                        self.pcode[slot + i] = kids[1 + i]
                        self.ptri[slot + i] = t
                        stack[sp + 1 + i] = slot + i
                    sp += 4
                    continue
                self.overflow = True         # placed whole: the driver raises OptionError
            self.nxt[s] = self.head[fids[best]]
            self.head[fids[best]] = s
            self.sphere_grow(fids[best], x)
            v = sqrt(bv)
            if v > self.cert[fids[best]]:
                self.cert[fids[best]] = v
            if v > self.pdist[fids[best]]:
                self.pdist[fids[best]] = v

    cdef double face_fits(self, int f, const double* t) noexcept nogil:
        """A bound (<= eps) on the distance of the pieces on face f (as it is) to triangle
        t, or -1 when none is found.  Each point of a piece is within pdist[f] of a point y
        of f (convexity: the distance to f is largest at the piece's corners), and y within
        the largest distance of f's corners to t (convexity again): the sum bounds it (the
        triangle inequality; pdist taken a hair large for rounding)."""
        cdef const double* y
        cdef double pd = self.pdist[f] * (1.0 + 1e-12)
        cdef double lim = self.eps - pd, v, d
        cdef int c
        if not (lim >= 0.0):
            return -1.0
        # a corner of f that is a corner of t is at 0 from it (the face in f's slot shares
        # two): only the others are measured
        v = 0.0
        for c in range(3):
            y = &self.P[self.stride * self.m.corner[3 * f + c]]
            if same_point(y, t) or same_point(y, &t[3]) or same_point(y, &t[6]):
                continue
            d = tri_sqdist(y, t)
            if not (d <= lim * lim):
                return -1.0
            if d > v:
                v = d
        v = sqrt(v) + pd
        return v if v < self.eps else self.eps

    cdef void sphere_grow(self, int f, const double* x) noexcept nogil:
        """Grow sphere[f] (its centre kept) to hold the three points x (a piece placed on f):
        the ball still holds every piece on f, which is all the check asks of it."""
        cdef double* b = &self.sphere[f, 0]
        cdef double d, r2 = 0.0
        cdef int c
        for c in range(3):
            d = point_sqdist(&x[3 * c], b)
            if d > r2:
                r2 = d
        d = sqrt(r2) * (1.0 + 1e-12) + 1e-300   # a hair large: rounding never lets a corner out
        if d > b[3]:
            b[3] = d

    cdef void fit_sphere(self, int f) noexcept nogil:
        """sphere[f]: a ball around the pieces on f (the centroid of their corners, the
        farthest corner's distance)."""
        cdef int q = self.head[f], cnt = 0, i, c, k = 0
        cdef double x[9]
        cdef double keep[9 * SPHERE_KEEP]    # the first pieces' corners, for the second pass
        cdef double* y
        cdef double ctr[3]
        cdef double r2 = 0.0, d
        ctr[0] = ctr[1] = ctr[2] = 0.0
        while q >= 0:
            y = &keep[3 * cnt] if cnt < 3 * SPHERE_KEEP else x
            self.corners(self.ptri[q], self.pcode[q], y)
            for c in range(3):
                for i in range(3):
                    ctr[i] += y[3 * c + i]
            cnt += 3
            q = self.nxt[q]
        if cnt == 0:
            for i in range(4):
                self.sphere[f, i] = 0.0
            return
        for i in range(3):
            ctr[i] /= cnt
        q = self.head[f]
        while q >= 0:
            if k < SPHERE_KEEP:
                y = &keep[9 * k]
            else:
                y = x
                self.corners(self.ptri[q], self.pcode[q], y)
            k += 1
            for c in range(3):
                d = sq(y[3 * c] - ctr[0]) + sq(y[3 * c + 1] - ctr[1]) + sq(y[3 * c + 2] - ctr[2])
                if d > r2:
                    r2 = d
            q = self.nxt[q]
        for i in range(3):
            self.sphere[f, i] = ctr[i]
        # a hair more than the largest distance: rounding never lets a corner out
        self.sphere[f, 3] = sqrt(r2) * (1.0 + 1e-12) + 1e-300

    # ------------------------------------------------------------- Python API
    @property
    def n_pieces(self):
        """Pieces of the original (its triangles at first; each split adds three)."""
        return min(self.n_used, self.capacity)

    @property
    def overflowed(self):
        """Whether a piece that had to split found no free slot (MAX_PIECES): it was placed
        whole, and the certificate of its face may exceed eps."""
        return bool(self.overflow)

    def pieces(self):
        """(pieces (k, 9), faces (k, 9), cert (k,), alive (k,)): the corners of each piece
        of the original, of the face it is on, that face's certificate, and whether that
        face is live (tests: a piece on a dead face would be lost from the output)."""
        cdef int f, q, a, c
        cdef double[::1] x = np.empty(9)
        out_p, out_f, out_c, out_a = [], [], [], []
        for f in range(self.head.shape[0]):
            q = self.head[f]
            while q >= 0:
                self.corners(self.ptri[q], self.pcode[q], &x[0])
                out_p.append(np.asarray(x).copy())
                out_f.append([self.P[self.stride * self.m.corner[3 * f + c] + a] for c in range(3) for a in range(3)])
                out_c.append(self.cert[f])
                out_a.append(self.m.face_alive[f] != 0)
                q = self.nxt[q]
        return (np.asarray(out_p).reshape(-1, 9), np.asarray(out_f, dtype=np.float64).reshape(-1, 9),
                np.asarray(out_c), np.asarray(out_a, dtype=bool))

    def face_certificates(self):
        """(faces (k, 9), own (k,), cert (k,)) of the live faces: their corners, the distance
        of their points to the original they are certified for, and their certificate both
        ways (tests)."""
        cdef int f, a, c
        out_f, out_o, out_c = [], [], []
        for f in range(self.head.shape[0]):
            if self.m.face_alive[f]:
                out_f.append([self.P[self.stride * self.m.corner[3 * f + c] + a] for c in range(3) for a in range(3)])
                out_o.append(self.fval[f])
                out_c.append(self.cert[f])
        return (np.asarray(out_f, dtype=np.float64).reshape(-1, 9), np.asarray(out_o, dtype=np.float64),
                np.asarray(out_c, dtype=np.float64))

    @property
    def n_nodes_bvh(self):
        return self.n_nodes

    def bound(self, alive_faces):
        """The certified two-sided distance of the current mesh: the largest certificate of
        a live face (0 when nothing changed)."""
        c = np.asarray(self.cert)[:np.asarray(alive_faces).shape[0]]
        live = c[np.asarray(alive_faces, dtype=bool)]
        return float(live.max()) if live.size else 0.0

    def distance(self, x):
        """Distance from each point of x (k, 3) to the original (tests)."""
        cdef double[:, ::1] X = np.ascontiguousarray(x, dtype=np.float64).reshape(-1, 3)
        out = np.empty(X.shape[0])
        cdef int i, near
        for i in range(X.shape[0]):
            near = -1
            out[i] = sqrt(self.nearest2(&X[i, 0], -1.0, &near))
        return out

    def patch_distance(self, t):
        """patch_cover for one triangle (9,) (tests), seeded with the input triangles
        nearest its centroid and its corners: its certified distance, or -1."""
        cdef double[::1] a = np.ascontiguousarray(t, dtype=np.float64).reshape(-1)
        cdef double ctr[3]
        cdef int seeds[4]
        cdef int c, cover = -1
        for c in range(3):
            ctr[c] = (a[c] + a[3 + c] + a[6 + c]) / 3.0
        seeds[0] = -1
        self.nearest2(ctr, 0.0, &seeds[0])
        for c in range(3):
            seeds[1 + c] = -1
            self.nearest2(&a[3 * c], 0.0, &seeds[1 + c])
        return self.patch_cover(&a[0], seeds, 4, &cover)

    def face_distance(self, t):
        """face_value for one triangle (9,) (tests): its certified distance, or -1."""
        cdef double[::1] a = np.ascontiguousarray(t, dtype=np.float64).reshape(-1)
        cdef int cover = -1
        return self.face_value(&a[0], &cover, NULL, NULL, NULL)


cdef void select_nth(int* idx, const double* cent, int ax, int lo, int hi, int k) noexcept nogil:
    """Partially sort idx[lo..hi] (inclusive) by centroid coordinate ``ax`` so that idx[k] is
    in place, the smaller before it, the larger after (Hoare's selection)."""
    cdef double pivot
    cdef int i, j, tmp
    while hi > lo:
        pivot = cent[3 * idx[(lo + hi) // 2] + ax]
        i = lo
        j = hi
        while i <= j:
            while cent[3 * idx[i] + ax] < pivot:
                i += 1
            while cent[3 * idx[j] + ax] > pivot:
                j -= 1
            if i <= j:
                tmp = idx[i]
                idx[i] = idx[j]
                idx[j] = tmp
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            return
