# cython: language_level=3
"""Quadric maths (Garland-Heckbert): evaluation, minimisation (cofactor solve, truncated
eigen-solve, Cholesky), the marginal of a quadric over attributes, and plane adding.
The small steps are inline here; the builders over a mesh live in quadric.pyx.

Layout of a 3D quadric (QSIZE, common.pxd): a11 a12 a13 a22 a23 a33 b1 b2 b3 c w, with
w the summed face area.  A quadric over attributes (D = 3 + channels) is packed as the upper
triangle of A row by row, then b (D), then c."""
from libc.math cimport sqrt, fabs

from .common cimport QSIZE
from .halfedge cimport HEArrays
from .vec3 cimport cross3, dot3

cdef enum:
    GMAX_D = 16          # quadrics over attributes: up to 13 attribute channels
    GMAX_S = 153         # packed size for GMAX_D: D(D+1)/2 + D + 1

cdef extern from *:
    """
    #define LODKIT_DET_EPS 1e-7
    """
    # An ill-conditioned quadric (flat or crease region) has det(A) ~ 0; below this fraction
    # of (trace/3)^3 the 3x3 solve is not trusted and the placement falls back to the edge.
    const double DET_EPS "LODKIT_DET_EPS"


cdef inline double sq(double x) noexcept nogil:
    return x * x


cdef inline void quadric_sum(const double* a, const double* b, double* out) noexcept nogil:
    """``out = a + b`` over the QSIZE entries of a quadric, unrolled (the hottest lines of
    planning: a loop indexed from a row number was not vectorised)."""
    out[0] = a[0] + b[0]
    out[1] = a[1] + b[1]
    out[2] = a[2] + b[2]
    out[3] = a[3] + b[3]
    out[4] = a[4] + b[4]
    out[5] = a[5] + b[5]
    out[6] = a[6] + b[6]
    out[7] = a[7] + b[7]
    out[8] = a[8] + b[8]
    out[9] = a[9] + b[9]
    out[10] = a[10] + b[10]


cdef inline double collapse_error(double value, double area, double scale) noexcept nogil:
    """The error reported for a collapse: sqrt(scale * Q(p) / area), the area-weighted RMS
    distance to the planes the vertex stands for (0 without area or below zero)."""
    return sqrt(scale * value / area) if area > 0.0 and value > 0.0 else 0.0


cdef inline double quadric_eval(const double* q, const double* p) noexcept nogil:
    cdef double x = p[0], y = p[1], z = p[2]
    return (q[0] * x * x + 2.0 * q[1] * x * y + 2.0 * q[2] * x * z
            + q[3] * y * y + 2.0 * q[4] * y * z + q[5] * z * z
            + 2.0 * (q[6] * x + q[7] * y + q[8] * z) + q[9])


cdef inline void take_if_lower(const double* q, const double* x, double* p, double* best) noexcept nogil:
    """The fallback placement's search: move ``p`` to ``x`` when the quadric is lower there
    than ``best`` (which then becomes that value)."""
    cdef double c = quadric_eval(q, x)
    cdef int i
    if c < best[0]:
        best[0] = c
        for i in range(3):
            p[i] = x[i]


cdef inline bint within_reach(const double* p, const double* a, const double* b) noexcept nogil:
    """Is ``p`` inside the bounding box of ``a`` and ``b`` grown by their distance on every
    side?  A placement outside it is one an ill-conditioned quadric flung off (a thin
    sheet, a flat CAD face): the planners then fall back to the edge (lodkit's rule,
    docs/algorithms.md, "Placement reach").  A NaN ``p`` is out of reach."""
    cdef double L = sqrt(sq(a[0] - b[0]) + sq(a[1] - b[1]) + sq(a[2] - b[2]))
    cdef int i
    for i in range(3):
        if not (p[i] >= (a[i] if a[i] < b[i] else b[i]) - L and p[i] <= (a[i] if a[i] > b[i] else b[i]) + L):
            return False
    return True


cdef inline bint within_reach3(const double* p, const double* a, const double* b, const double* c) noexcept nogil:
    """``within_reach`` for a triangle's three corners: their box grown by the longest edge."""
    cdef double L = sqrt(sq(a[0] - b[0]) + sq(a[1] - b[1]) + sq(a[2] - b[2]))
    cdef double L2 = sqrt(sq(c[0] - b[0]) + sq(c[1] - b[1]) + sq(c[2] - b[2]))
    cdef double L3 = sqrt(sq(a[0] - c[0]) + sq(a[1] - c[1]) + sq(a[2] - c[2]))
    cdef double lo, hi
    cdef int i
    if L2 > L:
        L = L2
    if L3 > L:
        L = L3
    for i in range(3):
        lo = a[i] if a[i] < b[i] else b[i]
        lo = lo if lo < c[i] else c[i]
        hi = a[i] if a[i] > b[i] else b[i]
        hi = hi if hi > c[i] else c[i]
        if not (p[i] >= lo - L and p[i] <= hi + L):
            return False
    return True


cdef inline bint cofactor_solve(const double* q, double* p, double min_det) noexcept nogil:
    """Solve A p = -b (A the quadric's 3x3 block) by cofactors; False if |det A| <= min_det."""
    cdef double a11 = q[0], a12 = q[1], a13 = q[2], a22 = q[3], a23 = q[4], a33 = q[5]
    cdef double c11 = a22 * a33 - a23 * a23
    cdef double c12 = a13 * a23 - a12 * a33
    cdef double c13 = a12 * a23 - a13 * a22
    cdef double det = a11 * c11 + a12 * c12 + a13 * c13
    if not (fabs(det) > min_det):
        return False
    cdef double c22 = a11 * a33 - a13 * a13
    cdef double c23 = a12 * a13 - a11 * a23
    cdef double c33 = a11 * a22 - a12 * a12
    cdef double inv = -1.0 / det
    p[0] = (c11 * q[6] + c12 * q[7] + c13 * q[8]) * inv
    p[1] = (c12 * q[6] + c22 * q[7] + c23 * q[8]) * inv
    p[2] = (c13 * q[6] + c23 * q[7] + c33 * q[8]) * inv
    return True


cdef inline bint quadric_solve(const double* q, double* p) noexcept nogil:
    """Minimise the quadric when A is clearly well-conditioned: det(A) above
    DET_EPS * (trace/3)^3, i.e. roughly an eigenvalue ratio over ~1e-3.  Otherwise False,
    and ``quadric_solve_truncated`` takes over."""
    cdef double tr = (q[0] + q[3] + q[5]) / 3.0
    if not (tr > 0.0):
        return False
    return cofactor_solve(q, p, DET_EPS * tr * tr * tr)


cdef inline void add_plane(double* q, double nx, double ny, double nz, double d, double w) noexcept nogil:
    q[0] += w * nx * nx
    q[1] += w * nx * ny
    q[2] += w * nx * nz
    q[3] += w * ny * ny
    q[4] += w * ny * nz
    q[5] += w * nz * nz
    q[6] += w * nx * d
    q[7] += w * ny * d
    q[8] += w * nz * d
    q[9] += w * d * d


cdef struct Rows:
    # (n, 3) positions read in place: row v's x y z at p[s * v], p[s * v + 1], p[s * v + 2]
    # (s = 3 for an (n, 3) array, VSTRIDE for the position columns of the vertex rows)
    const double* p
    Py_ssize_t s


cdef inline Rows rows_of(const double[:, :] P) noexcept nogil:
    """The rows of (n, 3) positions whose x y z are adjacent (p NULL when there are none)."""
    cdef Rows r
    r.p = &P[0, 0] if P.shape[0] else NULL
    r.s = P.strides[0] // sizeof(double)
    return r


cdef inline double face_cross(Rows P, int a, int b, int c, double* nrm) noexcept nogil:
    """(b - a) x (c - a) into ``nrm`` (twice the area vector of face a b c); returns its
    length."""
    cdef double e1[3]
    cdef double e2[3]
    cdef int i
    for i in range(3):
        e1[i] = P.p[P.s * b + i] - P.p[P.s * a + i]
        e2[i] = P.p[P.s * c + i] - P.p[P.s * a + i]
    cross3(e1, e2, nrm)
    return sqrt(dot3(nrm, nrm))


cdef inline void face_normal16(const HEArrays* m, Rows P, int f, short* N) noexcept nogil:
    """``N[0:3]`` = face slot ``f``'s unit normal scaled by 32767 and rounded (left alone for
    a degenerate face): 6 bytes a face is plenty for a 90-degree test."""
    cdef double nrm[3]
    cdef int i
    cdef double length = face_cross(P, m.corner[3 * f], m.corner[3 * f + 1], m.corner[3 * f + 2], nrm)
    if length > 0.0:
        for i in range(3):
            N[i] = <short>(nrm[i] / length * 32767.0 + (0.5 if nrm[i] >= 0 else -0.5))


cdef void sym3_eigen(const double* q, double* w, double* V) noexcept nogil
cdef int quadric_solve_truncated(const double* q, const double* x0, double* p) noexcept nogil
cdef int cholesky(double* M, int m, double rel_eps) noexcept nogil
cdef void cholesky_solve(const double* L, int m, double* x) noexcept nogil
cdef bint gq_marginal(const double* g, int D, double* q3, const double* p, double* a) noexcept nogil


cdef class AttributeQuadrics:
    cdef readonly int dim           # D = 3 + attribute channels (0: no quadrics over attributes)
    cdef int size                   # packed size D(D+1)/2 + D + 1
    cdef double[:, ::1] gq          # (n, size)
    cdef double* GQ
    cdef int[::1] col               # attribute column of each quadric dimension past 3
    # (n, 2 (D - 3)): per channel, the least and the largest input value on the faces a
    # slot stands for
    cdef double[:, ::1] box

    cdef void marginal(self, int u, int v, double* q) noexcept nogil
    cdef void marginal3(self, int a, int b, int c, double* q) noexcept nogil
    cdef void commit(self, int r, int k, const double* p, double* A, int n_attr,
                     bint keep_attributes) noexcept nogil
