# cython: language_level=3
"""Greedy edge-collapse driver with Garland-Heckbert quadrics.

The loop (``EdgeCollapser.run_c``) reads as the pipeline of the papers:

    pop the cheapest edge -> re-plan it (cost, placement, which end goes) -> check the
    link condition -> check the moved faces (normal flip, quality) -> collapse -> add the
    quadrics -> re-cost the edges around the kept vertex.

Everything is allocated in ``__init__``; ``run_c`` runs without the GIL and never allocates.
With ``operator=1`` the candidates are faces instead (triangle collapse: ``run_tri_c``).
A candidate that fails a check leaves the heap; it comes back when one of its ends is touched
again, and, when the heap runs dry, a full rescan gives every live edge another chance -- so
"no valid collapse left" is only reported after a rescan that found none.
"""
import numpy as np
cimport numpy as cnp
from libc.math cimport sqrt, fabs, cos, M_PI, INFINITY

from .halfedge cimport HalfEdgeMesh, HEArrays, he_next, he_prev, he_dest, he_ring_next, he_is_boundary
from .heap cimport IndexedHeap
from .vec3 cimport cross3, dot3, same_point
from lodkit.kernel cimport Kernel, Candidate, fill_candidate, KERNEL_OK, KERNEL_VETO, KERNEL_ERROR
from .chain cimport chain_place, chain_cost, chain_cost_range, chain_commit, chain_failed
from .chain import make_chain

cnp.import_array()

# An ill-conditioned quadric (flat or crease region) has det(A) ~ 0; below this fraction of
# (trace/3)^3 the 3x3 solve is not trusted and the placement falls back to the edge itself.
cdef double DET_EPS = 1e-7
# In the truncated solve, directions whose eigenvalue is below this fraction of the largest
# are left alone (the quadric barely constrains them; moving along them is guesswork).
cdef double EIG_EPS = 1e-3
# A moved face whose normal ends more than ~120 degrees from a neighbour's (and further
# than before) folds the surface back on itself: refused (cos 120 = -0.5).
cdef double FOLD_COS = -0.5
cdef double SQRT3 = 1.7320508075688772


cdef inline double sq(double x) noexcept nogil:
    return x * x


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


cdef void sym3_eigen(const double* q, double* w, double* V) noexcept nogil:
    """Eigen-decomposition of the symmetric 3x3 block of a quadric by cyclic Jacobi
    rotations: eigenvalues ``w[0..2]``, eigenvectors in the columns of ``V`` (row-major)."""
    cdef double a[3][3]
    cdef int i, j, k, sweep, pp, qq
    cdef double off, theta, t, c, s, tau, apq, app, aqq, akp, akq, vkp, vkq
    a[0][0] = q[0]; a[0][1] = q[1]; a[0][2] = q[2]
    a[1][0] = q[1]; a[1][1] = q[3]; a[1][2] = q[4]
    a[2][0] = q[2]; a[2][1] = q[4]; a[2][2] = q[5]
    for i in range(3):
        for j in range(3):
            V[3 * i + j] = 1.0 if i == j else 0.0
    for sweep in range(12):
        off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2]
        if off <= 1e-20 * (a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2]) or off == 0.0:
            break
        for pp in range(2):
            for qq in range(pp + 1, 3):
                apq = a[pp][qq]
                if apq == 0.0:
                    continue
                app = a[pp][pp]
                aqq = a[qq][qq]
                theta = (aqq - app) / (2.0 * apq)
                t = 1.0 / (fabs(theta) + sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
                c = 1.0 / sqrt(t * t + 1.0)
                s = t * c
                for k in range(3):
                    akp = a[k][pp]
                    akq = a[k][qq]
                    a[k][pp] = c * akp - s * akq
                    a[k][qq] = s * akp + c * akq
                for k in range(3):
                    akp = a[pp][k]
                    akq = a[qq][k]
                    a[pp][k] = c * akp - s * akq
                    a[qq][k] = s * akp + c * akq
                for k in range(3):
                    vkp = V[3 * k + pp]
                    vkq = V[3 * k + qq]
                    V[3 * k + pp] = c * vkp - s * vkq
                    V[3 * k + qq] = s * vkp + c * vkq
    for i in range(3):
        w[i] = a[i][i]


cdef void quadric_solve_truncated(const double* q, const double* x0, double* p) noexcept nogil:
    """Minimise the quadric in the well-determined directions only, staying at ``x0`` along
    the others (pseudo-inverse about x0, after Lindstrom): on a crease the point slides along
    the crease line to the spot nearest x0; in a flat region it stays at x0."""
    cdef double w[3]
    cdef double V[9]
    cdef double r[3]
    cdef double wmax, coef
    cdef int i, j
    sym3_eigen(q, w, V)
    wmax = w[0]
    if w[1] > wmax:
        wmax = w[1]
    if w[2] > wmax:
        wmax = w[2]
    # residual -(A x0 + b)
    r[0] = -(q[0] * x0[0] + q[1] * x0[1] + q[2] * x0[2] + q[6])
    r[1] = -(q[1] * x0[0] + q[3] * x0[1] + q[4] * x0[2] + q[7])
    r[2] = -(q[2] * x0[0] + q[4] * x0[1] + q[5] * x0[2] + q[8])
    for i in range(3):
        p[i] = x0[i]
    if wmax <= 0.0:
        return
    for j in range(3):
        if w[j] > EIG_EPS * wmax:
            coef = (V[j] * r[0] + V[3 + j] * r[1] + V[6 + j] * r[2]) / w[j]
            for i in range(3):
                p[i] += coef * V[3 * i + j]


cdef int cholesky(double* M, int m, double rel_eps) noexcept nogil:
    """In-place Cholesky M = L L^T of an m x m SPD matrix (row-major, lower triangle
    written); 0 if a pivot falls below rel_eps times the largest diagonal entry."""
    cdef int i, j, k
    cdef double s, dmax = 0.0
    for i in range(m):
        if M[i * m + i] > dmax:
            dmax = M[i * m + i]
    if not (dmax > 0.0):
        return 0
    for j in range(m):
        s = M[j * m + j]
        for k in range(j):
            s -= M[j * m + k] * M[j * m + k]
        if not (s > rel_eps * dmax):
            return 0
        M[j * m + j] = sqrt(s)
        for i in range(j + 1, m):
            s = M[i * m + j]
            for k in range(j):
                s -= M[i * m + k] * M[j * m + k]
            M[i * m + j] = s / M[j * m + j]
    return 1


cdef void cholesky_solve(const double* L, int m, double* x) noexcept nogil:
    """Solve L L^T y = x in place."""
    cdef int i, k
    cdef double s
    for i in range(m):
        s = x[i]
        for k in range(i):
            s -= L[i * m + k] * x[k]
        x[i] = s / L[i * m + i]
    for i in range(m - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, m):
            s -= L[k * m + i] * x[k]
        x[i] = s / L[i * m + i]


cdef bint gq_marginal(const double* g, int D, double* q3, const double* p, double* a) noexcept nogil:
    """Marginal of a packed D-dimensional quadric over x = [position, attributes]:
    min over the attributes of Q, a 3D quadric written to q3[0..9] (a11 a12 a13 a22 a23
    a33 b1 b2 b3 c).  With p given, also the minimising attributes at p into a[0..D-4].
    Packed layout: the upper triangle of A row by row, then b (D), then c.

    With M = A_aa (the attribute block), Y = M^-1 A_ax and z = M^-1 b_a:
    A' = A_xx - A_xa Y, b' = b_x - A_xa z, c' = c - b_a . z, and a*(p) = -(z + Y p).
    If M is singular (an attribute with no information) a tiny ridge is added; if it is
    zero the attributes are ignored (q3 = the position block) and False is returned."""
    cdef double A[GMAX_D * GMAX_D]
    cdef double b[GMAX_D]
    cdef double M[GMAX_D * GMAX_D]
    cdef double Y[3 * GMAX_D]        # column j of Y at Y[j * m]
    cdef double z[GMAX_D]
    cdef double c, ridge, dmax = 0.0
    cdef int i, j, k, idx = 0, m = D - 3
    for i in range(D):
        for j in range(i, D):
            A[i * D + j] = g[idx]
            A[j * D + i] = g[idx]
            idx += 1
    for i in range(D):
        b[i] = g[idx + i]
    c = g[idx + D]
    for i in range(m):
        for j in range(m):
            M[i * m + j] = A[(3 + i) * D + 3 + j]
        if M[i * m + i] > dmax:
            dmax = M[i * m + i]
    cdef bint ok = dmax > 0.0 and m > 0
    if ok and not cholesky(M, m, 1e-12):
        # rank-deficient attribute block: regularise slightly (a direction with no
        # information then stays near zero change rather than blowing up)
        ridge = 1e-9 * dmax
        for i in range(m):
            for j in range(m):
                M[i * m + j] = A[(3 + i) * D + 3 + j] + (ridge if i == j else 0.0)
        ok = cholesky(M, m, 1e-15)
    # position block
    q3[0] = A[0]; q3[1] = A[1]; q3[2] = A[2]
    q3[3] = A[D + 1]; q3[4] = A[D + 2]; q3[5] = A[2 * D + 2]
    q3[6] = b[0]; q3[7] = b[1]; q3[8] = b[2]; q3[9] = c
    if not ok:
        return False
    for j in range(3):
        for i in range(m):
            Y[j * m + i] = A[(3 + i) * D + j]
        cholesky_solve(M, m, &Y[j * m])
    for i in range(m):
        z[i] = b[3 + i]
    cholesky_solve(M, m, z)
    # A' = A_xx - A_xa Y ; b' = b_x - A_xa z ; c' = c - b_a . z
    idx = 0
    for i in range(3):
        for j in range(i, 3):
            for k in range(m):
                q3[idx] -= A[i * D + 3 + k] * Y[j * m + k]
            idx += 1
    for i in range(3):
        for k in range(m):
            q3[6 + i] -= A[i * D + 3 + k] * z[k]
    for k in range(m):
        q3[9] -= b[3 + k] * z[k]
    if p != NULL:
        for i in range(m):
            a[i] = -(z[i] + Y[i] * p[0] + Y[m + i] * p[1] + Y[2 * m + i] * p[2])
    return True


def general_quadric_marginal(g, int D, p=None):
    """Python access to the marginal of one packed quadric (for tests): returns the 3D
    quadric (10,) and, with p, the minimising attributes (D-3,) or None."""
    cdef double[::1] G = np.ascontiguousarray(g, dtype=np.float64)
    if not 3 <= D <= GMAX_D or G.shape[0] != D * (D + 1) // 2 + D + 1:
        raise ValueError(f"a packed quadric of dimension D (3..{GMAX_D}) has D(D+1)/2 + D + 1 entries")
    cdef double q3[QSIZE]
    cdef double a[GMAX_D]
    cdef double pp[3]
    if p is not None:
        pp[0], pp[1], pp[2] = p[0], p[1], p[2]
    ok = gq_marginal(&G[0], D, q3, pp if p is not None else NULL, a)
    q = np.array([q3[i] for i in range(10)])
    attrs = np.array([a[i] for i in range(D - 3)]) if (p is not None and ok) else None
    return q, attrs


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


cdef inline double face_cross(double[:, ::1] P, int a, int b, int c, double* nrm) noexcept nogil:
    """(b - a) x (c - a) into ``nrm`` (twice the area vector of face a b c); returns its length."""
    cdef double e1[3]
    cdef double e2[3]
    cdef int i
    for i in range(3):
        e1[i] = P[b, i] - P[a, i]
        e2[i] = P[c, i] - P[a, i]
    cross3(e1, e2, nrm)
    return sqrt(dot3(nrm, nrm))


def face_unit_normals(HalfEdgeMesh hm, positions):
    """(n_faces * 3,) int16 unit normals of the face slots, scaled by 32767 (zeros for
    degenerate faces): 6 bytes a face is plenty for a 90-degree test.

    Taken before any collapse: each face slot keeps its identity through the collapses, so
    these are the normals of the input faces the live faces stand for."""
    cdef double[:, ::1] P = np.ascontiguousarray(positions, dtype=np.float64)
    out = np.zeros(3 * hm.n_faces, dtype=np.int16)
    cdef short[::1] N = out
    cdef int f, i
    cdef double nrm[3]
    cdef double length
    with nogil:
        for f in range(hm.n_faces):
            length = face_cross(P, hm.corner[3 * f], hm.corner[3 * f + 1], hm.corner[3 * f + 2], nrm)
            if length > 0.0:
                for i in range(3):
                    N[3 * f + i] = <short>(nrm[i] / length * 32767.0 + (0.5 if nrm[i] >= 0 else -0.5))
    return out


def vertex_quadrics(HalfEdgeMesh hm, positions, double boundary_weight=0.0, out=None):
    """(n, 11) per-vertex quadrics: a11 a12 a13 a22 a23 a33 b1 b2 b3 c w (written into the
    first 11 columns of ``out`` when given, e.g. an (n, 14) EdgeCollapser row array).

    Each face adds its plane weighted by its area (Garland-Heckbert); ``w`` sums the areas.
    With ``boundary_weight > 0`` every boundary edge adds, to both ends, the plane through
    the edge perpendicular to its face, weighted by ``boundary_weight * length^2`` (a
    length^2 weight keeps the constraint scale-invariant, like the area weight of faces).
    """
    cdef double[:, ::1] P = np.ascontiguousarray(positions, dtype=np.float64)
    if P.shape[0] != hm.n_vertices or P.shape[1] != 3:
        raise ValueError(f"positions must have shape ({hm.n_vertices}, 3)")
    if out is None:
        out = np.zeros((hm.n_vertices, QSIZE), dtype=np.float64)
    elif (not isinstance(out, np.ndarray) or out.dtype != np.float64 or out.ndim != 2
          or out.shape[0] != hm.n_vertices or out.shape[1] < QSIZE or not out.flags.c_contiguous):
        raise ValueError(f"out must be a C-contiguous float64 array of shape ({hm.n_vertices}, >= {QSIZE})")
    else:
        out[:, :QSIZE] = 0.0
    cdef double[:, ::1] Q = out
    cdef int f, i, a
    cdef double nrm[3]
    cdef double length, area, d
    with nogil:
        for f in range(hm.n_faces):
            if not hm.face_alive[f]:
                continue
            a = hm.corner[3 * f]
            length = face_cross(P, a, hm.corner[3 * f + 1], hm.corner[3 * f + 2], nrm)
            if length <= 0.0:
                continue
            area = 0.5 * length
            for i in range(3):
                nrm[i] /= length
            d = -(nrm[0] * P[a, 0] + nrm[1] * P[a, 1] + nrm[2] * P[a, 2])
            for i in range(3):
                add_plane(&Q[hm.corner[3 * f + i], 0], nrm[0], nrm[1], nrm[2], d, area)
                Q[hm.corner[3 * f + i], 10] += area
    if boundary_weight > 0.0:
        add_boundary_planes(hm, P, boundary_weight, out)
    return out


def add_boundary_planes(HalfEdgeMesh hm, positions, double weight, out):
    """Add to ``out`` (n, >= 10) float64 quadrics, for every boundary edge and to both its
    ends, the plane through the edge perpendicular to its face, weighted by
    ``weight * length^2`` (a length^2 weight keeps the constraint scale-invariant, like the
    area weight of faces)."""
    cdef double[:, ::1] P = np.ascontiguousarray(positions, dtype=np.float64)
    cdef double[:, ::1] Q = out
    if P.shape[0] != hm.n_vertices or Q.shape[0] != hm.n_vertices or Q.shape[1] < 10:
        raise ValueError(f"positions and out must have {hm.n_vertices} rows (out >= 10 columns)")
    cdef int f, h, i, a, b, c
    cdef double e1[3]
    cdef double nrm[3]
    cdef double m[3]
    cdef double length, d, w, el
    with nogil:
        for f in range(hm.n_faces):
            if not hm.face_alive[f]:
                continue
            if hm.twin[3 * f] >= 0 and hm.twin[3 * f + 1] >= 0 and hm.twin[3 * f + 2] >= 0:
                continue
            length = face_cross(P, hm.corner[3 * f], hm.corner[3 * f + 1], hm.corner[3 * f + 2], nrm)
            if length <= 0.0:
                continue
            for i in range(3):
                nrm[i] /= length
            for i in range(3):
                h = 3 * f + i
                if hm.twin[h] >= 0:
                    continue
                a = hm.corner[h]
                b = hm.corner[he_next(h)]
                for c in range(3):
                    e1[c] = P[b, c] - P[a, c]
                el = dot3(e1, e1)
                cross3(e1, nrm, m)
                length = sqrt(dot3(m, m))
                if length <= 0.0:
                    continue
                for c in range(3):
                    m[c] /= length
                d = -(m[0] * P[a, 0] + m[1] * P[a, 1] + m[2] * P[a, 2])
                w = weight * el
                add_plane(&Q[a, 0], m[0], m[1], m[2], d, w)
                add_plane(&Q[b, 0], m[0], m[1], m[2], d, w)


cdef inline double apply_field(double cost, double value, const double* rule) noexcept nogil:
    if <int>rule[RULE_MODE] == MODE_SCALE:
        return cost * (rule[RULE_OFFSET] + rule[RULE_WEIGHT] * value)
    return cost + rule[RULE_WEIGHT] * value


cdef inline double merge_value(double kept, double removed, int rule) noexcept nogil:
    if rule == MERGE_MAX:
        return kept if kept > removed else removed
    if rule == MERGE_MIN:
        return kept if kept < removed else removed
    if rule == MERGE_SUM:
        return kept + removed
    if rule == MERGE_MEAN:
        return 0.5 * (kept + removed)
    return kept


def _field_arrays(values, rules, int rows, str what):
    """Check a (rows, k) field block and its (k, 5) rules; an empty block if None."""
    if values is None:
        return np.zeros((1, 1)), np.zeros((1, RULE_COLS)), 0
    vals = np.ascontiguousarray(values, dtype=np.float64)
    if vals.ndim == 1:
        vals = vals.reshape(-1, 1)
    if vals.ndim != 2 or vals.shape[0] != rows:
        raise ValueError(f"{what} fields must have shape ({rows}, k), got {np.shape(values)}")
    rl = np.ascontiguousarray(rules, dtype=np.float64)
    if rl.shape != (vals.shape[1], RULE_COLS):
        raise ValueError(f"{what} field rules must have shape ({vals.shape[1]}, {RULE_COLS})")
    if vals.shape[1] == 0:
        return np.zeros((1, 1)), np.zeros((1, RULE_COLS)), 0
    return vals, rl, int(vals.shape[1])


cdef class EdgeCollapser:
    """Greedy QEM edge collapse over a :class:`HalfEdgeMesh` (modified in place).

    positions : (n, 3) float64, preferably normalised (centred, unit bbox diagonal)
    quadrics  : (n, 11) float64 from :func:`vertex_quadrics`
    attributes: (n, k) float64 or None, interpolated along the edge at each collapse
                (C-contiguous float64 arrays are used in place, not copied)
    fixed     : (n,) uint8, 1 = the vertex may not move nor be removed
    placement : 0 optimal, 1 endpoint (half-edge collapse)
    boundary  : 0 lock (boundary vertices are fixed), 1 preserve, 2 free
    closed_connected : the surface is closed and connected: refuse collapses that would
                turn it inside out (its signed volume is tracked)
    operator  : 0 edge collapse (the candidates are edges), 1 triangle collapse (faces:
                a face goes to one point as two edge collapses, both checked before either
                is done; quadric metrics only -- ``plan_tri``, ``tri_ok``)
    seam_partners : (n,) int or None: attribute seams.  For a vertex slot on a seam (a
                coincident copy on the other side of a pair of boundary chains) its
                partner slot; -1 off the seams; -2 for a seam copy that must stay where
                and as it is (it is made fixed).  A seam vertex never moves, and keeps its
                attributes; a seam edge collapses only together with its partner edge,
                keeping the same end on both sides (``perform_pair``); any other collapse
                keeps a seam vertex in place.
    """

    def __init__(self, HalfEdgeMesh hm, positions, quadrics, attributes, fixed,
                 int placement=PLACE_OPTIMAL, int boundary=BOUNDARY_PRESERVE,
                 double max_normal_angle=90.0, double min_quality=0.0,
                 double max_error=INFINITY, bint record=False, bint closed_connected=False,
                 double quadric_weight=1.0, double error_scale=1.0,
                 vertex_fields=None, vertex_rules=None, edge_fields=None, edge_rules=None,
                 kernels=(), bint use_heap=True, attribute_quadrics=None, attribute_columns=None,
                 steps=None, seam_partners=None, int operator=OP_EDGE):
        cdef int n = hm.n_vertices
        if operator not in (OP_EDGE, OP_TRIANGLE):
            raise ValueError(f"unknown operator {operator} (0 edge collapse, 1 triangle collapse)")
        self.tri = operator == OP_TRIANGLE
        self.forced_t = -1.0
        self.skip_c = -1
        self.skip_d = -1
        self.n_tri_collapses = 0
        self.n_tri_refused_second = 0
        self.hm = hm
        # One row per vertex: the quadric (11 doubles) then the position (3), so that a
        # plan touches two cache-line pairs, not four scattered lines.  A (n, 14) array is
        # used in place (no copy); an (n, 11) one is joined with ``positions``.
        q_arr = np.asarray(quadrics)
        if q_arr.ndim == 2 and q_arr.shape[1] == VSTRIDE and q_arr.dtype == np.float64 and q_arr.flags.c_contiguous:
            self.vdata = q_arr
        else:
            if q_arr.ndim != 2 or q_arr.shape[1] != QSIZE:
                raise ValueError(f"quadrics must have shape ({n}, {QSIZE}) or ({n}, {VSTRIDE})")
            pos_arr = np.asarray(positions, dtype=np.float64)
            if pos_arr.shape != (n, 3):
                raise ValueError(f"positions must have shape ({n}, 3)")
            joined = np.empty((q_arr.shape[0], VSTRIDE), dtype=np.float64)
            joined[:, :QSIZE] = q_arr
            joined[:, QSIZE:] = pos_arr
            self.vdata = joined
        if self.vdata.shape[0] != n:
            raise ValueError(f"quadrics must have {n} rows")
        if attributes is None:
            attributes = np.zeros((n, 0))
        self.attr = np.ascontiguousarray(attributes, dtype=np.float64)
        if self.attr.shape[0] != n:
            raise ValueError(f"attributes must have {n} rows")
        self.n_attr = self.attr.shape[1]
        fixed_arr = np.asarray(fixed).reshape(-1)
        if fixed_arr.shape[0] != n:
            raise ValueError(f"fixed must have {n} entries")
        # bit 0: fixed (may not move nor go); bit 1: on the boundary (kept up to date: after
        # a collapse the kept vertex is on the boundary iff either end was)
        self.vflags = (fixed_arr != 0).astype(np.uint8)
        self.moved = np.zeros(n, dtype=np.uint8)
        self.refused = np.zeros(n, dtype=np.uint8)
        self.released = False
        if placement not in (PLACE_OPTIMAL, PLACE_ENDPOINT):
            raise ValueError(f"unknown placement {placement}")
        if boundary not in (BOUNDARY_LOCK, BOUNDARY_PRESERVE, BOUNDARY_FREE):
            raise ValueError(f"unknown boundary policy {boundary}")
        if not (0.0 < max_normal_angle <= 180.0):
            raise ValueError("max_normal_angle must be in (0, 180] degrees")
        self.placement = placement
        self.boundary = boundary
        self.cos_max_angle = cos(max_normal_angle * M_PI / 180.0)
        self.min_quality = min_quality
        self.max_error = max_error
        # the collapse sequence (a progressive mesh) is only kept on request: 48 bytes/vertex
        self.record = record
        cdef int nrec = n if record else 1
        self.rec_removed = np.empty(nrec, dtype=np.intc)
        self.rec_kept = np.empty(nrec, dtype=np.intc)
        self.rec_pos = np.empty((nrec, 3), dtype=np.float64)
        self.rec_cost = np.empty(nrec, dtype=np.float64)
        self.rec_error = np.empty(nrec, dtype=np.float64)
        self.rec_moved = np.empty(nrec, dtype=np.uint8)
        self.rec_faces = np.empty((nrec, 2), dtype=np.intc)
        self.rec_open = np.zeros(nrec, dtype=np.uint8)
        self.rec_attr = np.empty((nrec, self.n_attr), dtype=np.float64)
        self.n_collapses = 0
        self.max_error_done = 0.0
        self.cos_orig_angle = cos(min(max_normal_angle, 90.0) * M_PI / 180.0)
        self.check_orig = max_normal_angle < 180.0
        self.face_n0 = face_unit_normals(hm, np.asarray(self.vdata)[:, QSIZE:])
        self.N0 = &self.face_n0[0] if hm.n_faces else NULL
        # the pass driver needs none; triangle collapse ranks faces
        self.heap = IndexedHeap((hm.n_faces if self.tri else hm.n_edges) if use_heap else 0)
        self.m = &hm.c
        # The volume guard is on for a closed, connected surface (the common case): six
        # times its signed volume, kept up to date collapse by collapse.
        self.closed_volume = 0.0
        self.pending_dvol = 0.0
        self.Q = &self.vdata[0, 0] if n else NULL
        self.P = &self.vdata[0, QSIZE] if n else NULL
        cdef int v
        for v in range(n):
            if self.m.v_he[v] >= 0 and he_is_boundary(self.m, v):
                # under the 'lock' policy a boundary vertex is also fixed
                self.vflags[v] |= 3 if boundary == BOUNDARY_LOCK else 2
        self.A = &self.attr[0, 0] if n and self.n_attr else NULL
        self._setup_seams(seam_partners)
        self._setup_metric(quadric_weight, error_scale, vertex_fields, vertex_rules,
                           edge_fields, edge_rules, kernels, use_heap, steps)
        self._setup_attribute_quadrics(attribute_quadrics, attribute_columns)
        if self.tri and (self.has_extras or not self.use_heap):
            raise ValueError("triangle collapse takes quadric metrics only: no fields, kernels "
                             "nor batch metrics (their values are defined per edge)")
        cdef int f
        if closed_connected and n:
            for f in range(hm.n_faces):
                if hm.face_alive[f]:
                    self.closed_volume += self.face_volume(f)
        if self.use_heap:
            with nogil:
                self.rescan()

    def _setup_seams(self, partners):
        cdef int n = self.hm.n_vertices
        self.seam_h = -1
        self.defer_recost = False
        self.n_seam_pairs = 0
        self.seam = np.full(1, SEAM_NONE, dtype=np.intc)
        self.SP = NULL
        if partners is None:
            return
        arr = np.array(partners, dtype=np.intc).reshape(-1)
        if arr.shape[0] != n:
            raise ValueError(f"seam_partners must have {n} entries")
        if n == 0 or (arr == SEAM_NONE).all():
            return
        if arr.min() < SEAM_STAYS or arr.max() >= n:
            raise ValueError(f"seam_partners must hold vertex slots 0..{n - 1}, -1 or -2")
        paired = np.flatnonzero(arr >= 0)
        if (arr[arr[paired]] != paired).any() or (arr[paired] == paired).any():
            raise ValueError("seam_partners must pair distinct vertex slots both ways")
        flags = np.asarray(self.vflags)
        # a seam vertex off the boundary is no seam (nothing to keep apart); one whose
        # partner is fixed stays too, so that both sides always agree
        stays = (arr == SEAM_STAYS)
        stays[paired] |= ((flags[paired] & 1) != 0) | ((flags[arr[paired]] & 1) != 0)
        stays[paired] |= ((flags[paired] & 2) == 0) | ((flags[arr[paired]] & 2) == 0)
        arr[stays] = SEAM_STAYS
        flags[stays] |= 1
        self.seam = arr
        self.SP = &self.seam[0]

    def _setup_attribute_quadrics(self, gq, columns):
        cdef int n = self.hm.n_vertices
        self.gdim = 0
        self.gsize = 0
        self.gq = np.zeros((1, 1))
        self.GQ = NULL
        self.gcol = np.zeros(1, dtype=np.intc)
        self.gbox = np.zeros((1, 1))
        if gq is None:
            return
        cols = np.ascontiguousarray(columns, dtype=np.intc).reshape(-1)
        D = 3 + cols.shape[0]
        if D > GMAX_D:
            raise ValueError(f"quadrics over attributes support at most {GMAX_D - 3} attribute channels")
        if cols.shape[0] == 0:
            raise ValueError("attribute_columns must name at least one attribute column")
        if cols.min() < 0 or cols.max() >= self.n_attr:
            raise ValueError(f"attribute_columns must be in 0..{self.n_attr - 1}")
        arr = np.ascontiguousarray(gq, dtype=np.float64)
        S = D * (D + 1) // 2 + D + 1
        if arr.shape != (n, S):
            raise ValueError(f"attribute_quadrics must have shape ({n}, {S}) for {D - 3} attribute channels")
        self.gq = arr
        self.GQ = &self.gq[0, 0] if n else NULL
        self.gcol = cols
        # the clamp box of a vertex: per channel, the range of the values on the input
        # faces around it -- the faces its quadric is made of (a vertex placed a little
        # outside its own neighbours keeps the linear extrapolation the faces allow)
        vals = np.asarray(self.attr)[:, cols]
        self.gbox = np.ascontiguousarray(np.concatenate([vals, vals], axis=1))
        cdef double[:, ::1] box = self.gbox
        cdef int[::1] gc = self.gcol
        cdef int nch = cols.shape[0], f, i, j, ch, a, b
        cdef double x
        with nogil:
            for f in range(self.hm.n_faces):
                if not self.m.face_alive[f]:
                    continue
                for i in range(3):
                    a = self.m.corner[3 * f + i]
                    for j in range(3):
                        b = self.m.corner[3 * f + j]
                        for ch in range(nch):
                            x = self.A[self.n_attr * b + gc[ch]]
                            if x < box[a, ch]:
                                box[a, ch] = x
                            if x > box[a, nch + ch]:
                                box[a, nch + ch] = x
        self.gdim = D
        self.gsize = S

    def _setup_metric(self, double quadric_weight, double error_scale, vertex_fields, vertex_rules,
                      edge_fields, edge_rules, kernels, bint use_heap, steps=None):
        cdef int n = self.hm.n_vertices
        if not (quadric_weight >= 0.0) or not (error_scale > 0.0):
            raise ValueError("quadric_weight must be >= 0 and error_scale > 0")
        self.quadric_weight = quadric_weight
        self.error_scale = error_scale
        self.vfield, self.vrules, self.n_vfields = _field_arrays(vertex_fields, vertex_rules, n, "vertex")
        self.efield, self.erules, self.n_efields = _field_arrays(edge_fields, edge_rules, self.hm.n_edges, "edge")
        self.VF = &self.vfield[0, 0] if self.n_vfields and n else NULL
        self.EF = &self.efield[0, 0] if self.n_efields and self.hm.n_edges else NULL
        cdef Kernel k
        kernels = list(kernels)
        for k in kernels:            # type-checks each one
            if k is None:
                raise TypeError("kernels must be lodkit.kernel.Kernel instances")
        self.chain = make_chain(kernels)
        self.kernel = kernels[0] if kernels else None
        self.kernel_places = False
        self.wide_recost = False
        self.wide_kernel = None
        if self.kernel is not None:
            for k in kernels:
                self.kernel_places |= k.places
                self.wide_recost |= k.wide
            wide = [k for k in kernels if k.wide]
            if len(wide) == 1:
                self.wide_kernel = wide[0]
        self.edge_stamp = np.zeros(self.hm.n_edges if self.wide_recost else 1, dtype=np.intc)
        self.recost_counter = 0
        self.kmesh.he = self.m
        self.kmesh.positions = self.P
        self.kmesh.stride = VSTRIDE
        self.kmesh.flags = &self.vflags[0] if n else NULL
        self.kmesh.n_vertices = n
        self.kmesh.n_faces = self.hm.n_faces
        if steps is None:
            # default order: vertex fields, edge fields, kernels
            rows = []
            if self.n_vfields:
                rows.append((STEP_VFIELD, 0, self.n_vfields))
            if self.n_efields:
                rows.append((STEP_EFIELD, 0, self.n_efields))
            if kernels:
                rows.append((STEP_KERNEL, 0, len(kernels)))
            steps = rows
        st = np.asarray(steps, dtype=np.intc).reshape(-1, 3)
        limits = {STEP_VFIELD: self.n_vfields, STEP_EFIELD: self.n_efields, STEP_KERNEL: len(kernels)}
        for kind, first, end in st:
            if kind not in limits or not (0 <= first < end <= limits[kind]):
                raise ValueError(f"bad step ({kind}, {first}, {end}): kinds 0 vertex field, 1 edge field, "
                                 f"2 kernels, with 0 <= first < end <= their count")
        self.steps = np.ascontiguousarray(st) if st.shape[0] else np.zeros((1, 3), dtype=np.intc)
        self.n_steps = st.shape[0]
        self.has_extras = self.n_vfields > 0 or self.n_efields > 0 or self.kernel is not None
        self.use_heap = use_heap
        self.n_vetoed = 0
        self.failed = False
        self.touched = np.zeros(n if not use_heap else 1, dtype=np.intc)
        self.pass_counter = 0

    # ------------------------------------------------------------- planning
    cdef int plan(self, int e, int* h_out, int* r_out, double* p, double* cost, double* err) noexcept nogil:
        """Cost and placement of collapsing edge ``e``; -1 if it may not collapse at all."""
        cdef int h = self.m.edge_he[e]
        return self.plan_he(h, self.m.corner[h], he_dest(self.m, h), h_out, r_out, p, cost, err)

    cdef int plan_he(self, int h, int u, int v, int* h_out, int* r_out, double* p, double* cost,
                     double* err) noexcept nogil:
        """``plan`` for the edge of half-edge ``h`` running u -> v, when the caller already
        holds them (a ring walk): saves the edge -> half-edge -> vertex chain of loads."""
        cdef unsigned char gu = self.vflags[u]
        cdef unsigned char gv = self.vflags[v]
        cdef bint bu = (gu & 2) != 0
        cdef bint bv = (gv & 2) != 0
        cdef bint fu = (gu & 1) != 0
        cdef bint fv = (gv & 1) != 0
        cdef double q[QSIZE]
        cdef double qg[QSIZE]
        cdef double cand[3]
        cdef double best, c, t, denom, d0, d1
        cdef double du[3]
        cdef int i, keep, hs
        if self.SP != NULL:
            self.seam_h = -1
            if self.SP[u] != SEAM_NONE or self.SP[v] != SEAM_NONE:
                if self.SP[u] >= 0 and self.SP[v] >= 0 and self.m.twin[h] < 0:
                    hs = self.seam_mate(h, u, v)
                    if hs >= 0:
                        return self.plan_seam(h, hs, h_out, r_out, p, cost, err)
                # any other collapse keeps a seam vertex where it is (its partner could
                # not follow); a seam vertex that stays is fixed already
                if self.SP[u] != SEAM_NONE:
                    fu = True
                if self.SP[v] != SEAM_NONE:
                    fv = True
        if bu and bv and self.m.twin[h] >= 0:
            return -1                     # would pinch the surface (link condition)
        if self.boundary == BOUNDARY_PRESERVE:
            # Li et al.: a boundary vertex never moves into the interior
            if bu and not bv:
                fu = True
            elif bv and not bu:
                fv = True
        if fu and fv:
            return -1
        for i in range(QSIZE):
            q[i] = self.Q[VSTRIDE * u + i] + self.Q[VSTRIDE * v + i]
        if self.gdim > 0:
            # quadrics over attributes: place by the marginal quadric in x (the attributes
            # minimised out), keep the plain one (qg) to measure the geometric error
            for i in range(QSIZE):
                qg[i] = q[i]
            self.general_marginal(u, v, q)
        h_out[0] = h
        if fu or fv:
            keep = u if fu else v
            for i in range(3):
                p[i] = self.P[VSTRIDE * keep + i]
            r_out[0] = v if fu else u
            c = quadric_eval(q, p)
        elif self.placement == PLACE_ENDPOINT:
            d0 = quadric_eval(q, &self.P[VSTRIDE * u])
            d1 = quadric_eval(q, &self.P[VSTRIDE * v])
            keep = u if (d0 < d1 or (d0 == d1 and u < v)) else v
            for i in range(3):
                p[i] = self.P[VSTRIDE * keep + i]
            r_out[0] = v if keep == u else u
            c = d0 if keep == u else d1
        else:
            if quadric_solve(q, p):
                c = quadric_eval(q, p)
            else:
                # fallback: the best of the truncated solve about the midpoint, both ends,
                # the midpoint and the minimum along the edge
                for i in range(3):
                    du[i] = self.P[VSTRIDE * v + i] - self.P[VSTRIDE * u + i]
                    cand[i] = self.P[VSTRIDE * u + i] + 0.5 * du[i]
                quadric_solve_truncated(q, cand, p)
                best = quadric_eval(q, p)
                take_if_lower(q, &self.P[VSTRIDE * u], p, &best)
                take_if_lower(q, &self.P[VSTRIDE * v], p, &best)
                take_if_lower(q, cand, p, &best)
                # Q(u + t du) = alpha t^2 + 2 beta t + const  ->  t* = -beta / alpha
                denom = (q[0] * du[0] * du[0] + 2 * q[1] * du[0] * du[1] + 2 * q[2] * du[0] * du[2]
                         + q[3] * du[1] * du[1] + 2 * q[4] * du[1] * du[2] + q[5] * du[2] * du[2])
                if denom > 0.0:
                    t = -((q[0] * self.P[VSTRIDE * u + 0] + q[1] * self.P[VSTRIDE * u + 1] + q[2] * self.P[VSTRIDE * u + 2] + q[6]) * du[0]
                          + (q[1] * self.P[VSTRIDE * u + 0] + q[3] * self.P[VSTRIDE * u + 1] + q[4] * self.P[VSTRIDE * u + 2] + q[7]) * du[1]
                          + (q[2] * self.P[VSTRIDE * u + 0] + q[4] * self.P[VSTRIDE * u + 1] + q[5] * self.P[VSTRIDE * u + 2] + q[8]) * du[2]) / denom
                    if 0.0 < t < 1.0:
                        for i in range(3):
                            cand[i] = self.P[VSTRIDE * u + i] + t * du[i]
                        take_if_lower(q, cand, p, &best)
                c = best
            # the kept slot is the end nearer to the new position (provenance); only the
            # collapse itself and the metric's fields / kernels need it, not QEM's ranking
            if err != NULL or self.has_extras:
                d0 = 0.0
                d1 = 0.0
                for i in range(3):
                    d0 += (p[i] - self.P[VSTRIDE * u + i]) * (p[i] - self.P[VSTRIDE * u + i])
                    d1 += (p[i] - self.P[VSTRIDE * v + i]) * (p[i] - self.P[VSTRIDE * v + i])
                r_out[0] = v if (d0 < d1 or (d0 == d1 and u < v)) else u
        if c < 0.0:
            c = 0.0
        if self.has_extras:
            keep = self.metric_cost(h, u, v, fu, fv, q, &qg[0] if self.gdim > 0 else &q[0], r_out, p, &c, err)
            cost[0] = c
            return keep
        if err != NULL:
            err[0] = collapse_error(quadric_eval(qg, p) if self.gdim > 0 else c, q[10], self.error_scale)
        cost[0] = self.quadric_weight * c
        return 0

    cdef int seam_mate(self, int h, int u, int v) noexcept nogil:
        """The partner of seam edge ``h`` (u -> v, a boundary half-edge between two paired
        seam vertices): the boundary half-edge partner(v) -> partner(u) on the other side
        of the seam, or -1 if there is none (the seam chains part there)."""
        cdef int vs = self.SP[v]
        cdef int hs = self.m.v_he[vs]          # a boundary vertex's fan starts at its border
        if self.m.twin[hs] < 0 and he_dest(self.m, hs) == self.SP[u]:
            return hs
        return -1

    cdef int plan_seam(self, int h, int hs, int* h_out, int* r_out, double* p, double* cost,
                       double* err) noexcept nogil:
        """Plan seam edge ``h`` together with its partner ``hs`` on the other side: one
        collapse on each side, removing the same position and keeping the other, which
        stays where it is (endpoint placement: the seam stays a sub-polyline of the
        input's, and the two sides cannot part).  The cost is that of both collapses: the
        summed quadrics of both sides (attribute quadrics: the sum of each side's marginal,
        as each side keeps its own attributes).  The plan is the same from either edge
        (the side of the smaller edge id is side a), and ``seam_h`` gets side b's
        half-edge.  Returns 0, or -1 / -2 as ``plan_he``."""
        cdef int ha = h, hb = hs
        if self.m.edge[hs] < self.m.edge[h]:
            ha = hs
            hb = h
        self.seam_h = hb
        h_out[0] = ha
        cdef int ua = self.m.corner[ha], va = he_dest(self.m, ha)
        cdef int ub = self.m.corner[hb], vb = he_dest(self.m, hb)     # partner(va), partner(ua)
        # seam vertices whose partner is fixed are fixed themselves (SEAM_STAYS), so both
        # sides agree on what may go
        cdef bint fu = (self.vflags[ua] & 1) != 0
        cdef bint fv = (self.vflags[va] & 1) != 0
        cdef double q[QSIZE]
        cdef double qg[QSIZE]
        cdef double qb[QSIZE]
        cdef double c, d0, d1
        cdef int i, keep, rc
        if fu and fv:
            return -1
        for i in range(QSIZE):
            q[i] = (self.Q[VSTRIDE * ua + i] + self.Q[VSTRIDE * va + i]) + (self.Q[VSTRIDE * ub + i] + self.Q[VSTRIDE * vb + i])
        if self.gdim > 0:
            for i in range(QSIZE):
                qg[i] = q[i]
            self.general_marginal(ua, va, q)
            self.general_marginal(ub, vb, qb)
            for i in range(10):
                q[i] += qb[i]
        if fu:
            keep = ua
        elif fv:
            keep = va
        else:
            d0 = quadric_eval(q, &self.P[VSTRIDE * ua])
            d1 = quadric_eval(q, &self.P[VSTRIDE * va])
            keep = ua if (d0 < d1 or (d0 == d1 and ua < va)) else va
        for i in range(3):
            p[i] = self.P[VSTRIDE * keep + i]
        r_out[0] = va if keep == ua else ua
        c = quadric_eval(q, p)
        if c < 0.0:
            c = 0.0
        if self.has_extras:
            # fields and kernels see side a's collapse; a kernel may swap the ends but not
            # move the kept one (the seam would part)
            rc = self.metric_cost(ha, ua, va, fu, fv, q, &qg[0] if self.gdim > 0 else &q[0], r_out, p, &c, err)
            if rc != 0:
                return rc
            keep = va if r_out[0] == ua else ua
            if not same_point(p, &self.P[VSTRIDE * keep]):
                self.n_vetoed += 1
                return -1
            cost[0] = c
            return 0
        if err != NULL:
            err[0] = collapse_error(quadric_eval(qg, p) if self.gdim > 0 else c, q[10], self.error_scale)
        cost[0] = self.quadric_weight * c
        return 0

    cdef void general_marginal(self, int u, int v, double* q) noexcept nogil:
        """Sum the attribute quadrics of u and v and write into q[0..9] their marginal in
        x: min over the attributes a of Q(x, a), itself a 3D quadric (Schur complement)."""
        cdef double g[GMAX_S]
        cdef int i, gs = self.gsize
        for i in range(gs):
            g[i] = self.GQ[gs * u + i] + self.GQ[gs * v + i]
        gq_marginal(g, self.gdim, q, NULL, NULL)

    cdef int metric_cost(self, int h, int u, int v, int fu, int fv, const double* q, const double* qg,
                         int* r_out, double* p, double* c, double* err) noexcept nogil:
        """The rest of the metric after the quadric: a kernel may re-place, then the
        quadric cost (times its weight), the fields in order, the kernels in order.
        ``c`` holds the quadric value at ``p`` on entry, the total cost on return.
        Returns 0, -1 (a kernel vetoed) or -2 (a kernel failed: ``self.failed``)."""
        cdef Candidate cand
        cdef double cq = c[0]
        cdef double total, val, a, b, e_err
        cdef double* rule
        cdef int* step
        cdef int i, j, rc, code, e = self.m.edge[h]
        cdef int kept = v if r_out[0] == u else u
        if self.kernel is not None:
            fill_candidate(&cand, &self.kmesh, e, h, u, v, r_out[0], kept, p, 0.0, 0.0)
            if self.kernel_places:
                rc = chain_place(self.chain, &cand)
                if rc != KERNEL_OK:
                    return self.kernel_refused(rc)
                if not ((cand.removed == u and cand.kept == v) or (cand.removed == v and cand.kept == u)):
                    self.kernel.fail(b"place() set removed/kept to vertices that are not the edge's ends")
                    self.failed = True
                    return -2
                # the fixed rules bind a kernel too: a fixed end stays, where it is
                if (fu and cand.removed == u) or (fv and cand.removed == v):
                    self.n_vetoed += 1
                    return -1
                if (fu or fv) and not same_point(cand.p, &self.P[VSTRIDE * cand.kept]):
                    self.n_vetoed += 1
                    return -1
                r_out[0] = cand.removed
                kept = cand.kept
                if not same_point(cand.p, p):
                    p[0] = cand.p[0]
                    p[1] = cand.p[1]
                    p[2] = cand.p[2]
                    cq = quadric_eval(q, p)
                    if cq < 0.0:
                        cq = 0.0
        e_err = collapse_error(quadric_eval(qg, p) if qg != q else cq, q[10], self.error_scale)
        if err != NULL:
            err[0] = e_err
        total = self.quadric_weight * cq
        # fields and kernels in the order the metrics were listed (steps: kind, first, end)
        for i in range(self.n_steps):
            step = &self.steps[i, 0]
            if step[0] == STEP_VFIELD:
                for j in range(step[1], step[2]):
                    rule = &self.vrules[j, 0]
                    # a: the kept end's value, b: the removed end's
                    a = self.VF[self.n_vfields * kept + j]
                    b = self.VF[self.n_vfields * (v if kept == u else u) + j]
                    code = <int>rule[RULE_VALUE]
                    if code == VALUE_KEPT:
                        val = a
                    elif code == VALUE_REMOVED:
                        val = b
                    else:                      # max, min, sum, mean: the merge rules' own
                        val = merge_value(a, b, MERGE_MEAN if code == VALUE_MEAN else code)
                    total = apply_field(total, val, rule)
            elif step[0] == STEP_EFIELD:
                for j in range(step[1], step[2]):
                    total = apply_field(total, self.EF[self.n_efields * e + j], &self.erules[j, 0])
            else:
                # removed / kept / p in cand are current: set above, or by place() and copied out
                cand.cost = total
                cand.error = e_err
                if step[1] == 0 and self.chain.next is None:
                    rc = self.kernel.cost(&cand)
                else:
                    rc = chain_cost_range(self.chain, &cand, step[1], step[2] - step[1])
                if rc != KERNEL_OK:
                    return self.kernel_refused(rc)
                total = cand.cost
        if total != total:
            total = INFINITY          # a NaN cost ranks last rather than breaking the heap order
        c[0] = total
        return 0

    cdef int kernel_refused(self, int rc) noexcept nogil:
        if rc == KERNEL_VETO:
            self.n_vetoed += 1
            return -1
        self.failed = True            # KERNEL_ERROR, or anything else a kernel should not return
        if not chain_failed(self.chain):
            self.kernel.fail(b"a kernel returned an unknown status (not KERNEL_OK, KERNEL_VETO nor KERNEL_ERROR)")
        return -2

    # ------------------------------------------------------------- checks
    cdef bint fan_ok(self, int center, int fa, int fb, const double* p, double* dvol) noexcept nogil:
        """Do the faces around ``center`` (except fa, fb) stay valid when it moves to p?
        Adds to ``dvol`` six times the change of the enclosed volume.  Faces ``skip_c`` /
        ``skip_d`` (set by a triangle collapse's check) count for the volume only."""
        cdef int start = self.m.v_he[center]
        cdef int y = start
        cdef int f, b, c, i
        cdef double e1[3]
        cdef double e2[3]
        cdef double n0[3]
        cdef double n1[3]
        cdef double l0, l1, l2, len0, len1, q0, q1, lg, prev_ok
        cdef double bc[3]
        cdef double ng[3]
        cdef double prev_n1[3]
        cdef double prev_len1 = 0.0
        cdef int t, g, x
        prev_n1[0] = prev_n1[1] = prev_n1[2] = 0.0
        while True:
            f = y // 3
            if f == fa or f == fb:
                prev_len1 = 0.0
            elif f == self.skip_c or f == self.skip_d:
                # a triangle collapse's first step: this face dies in the second one, its
                # passing shape does not matter, its volume change does
                if self.closed_volume != 0.0:
                    b = he_dest(self.m, y)
                    c = self.m.corner[he_prev(y)]
                    cross3(&self.P[VSTRIDE * b], &self.P[VSTRIDE * c], bc)
                    dvol[0] += ((p[0] - self.P[VSTRIDE * center]) * bc[0] + (p[1] - self.P[VSTRIDE * center + 1]) * bc[1]
                                + (p[2] - self.P[VSTRIDE * center + 2]) * bc[2])
                prev_len1 = 0.0
            else:
                b = he_dest(self.m, y)
                c = self.m.corner[he_prev(y)]
                for i in range(3):
                    e1[i] = self.P[VSTRIDE * b + i] - self.P[VSTRIDE * center + i]
                    e2[i] = self.P[VSTRIDE * c + i] - self.P[VSTRIDE * center + i]
                cross3(e1, e2, n0)
                if self.closed_volume != 0.0:
                    # change of the cone from the origin over this face: (p - old) . (b x c)
                    cross3(&self.P[VSTRIDE * b], &self.P[VSTRIDE * c], bc)
                    dvol[0] += ((p[0] - self.P[VSTRIDE * center]) * bc[0] + (p[1] - self.P[VSTRIDE * center + 1]) * bc[1]
                                + (p[2] - self.P[VSTRIDE * center + 2]) * bc[2])
                len0 = sqrt(dot3(n0, n0))
                prev_ok = prev_len1
                prev_len1 = 0.0                      # set again below if this face is checked
                if len0 > 0.0:
                    for i in range(3):
                        e1[i] = self.P[VSTRIDE * b + i] - p[i]
                        e2[i] = self.P[VSTRIDE * c + i] - p[i]
                    cross3(e1, e2, n1)
                    len1 = sqrt(dot3(n1, n1))
                    l0 = dot3(e1, e1)
                    l1 = dot3(e2, e2)
                    if len1 <= 1e-12 * (l0 + l1):
                        return False                 # the face would degenerate
                    if dot3(n0, n1) < self.cos_max_angle * len0 * len1:
                        return False                 # the face would turn too far (or flip)
                    if self.check_orig and (n1[0] * self.N0[3 * f] + n1[1] * self.N0[3 * f + 1]
                                            + n1[2] * self.N0[3 * f + 2]) < self.cos_orig_angle * 32767.0 * len1:
                        return False                 # turned away from the input face it stands for
                    if self.min_quality > 0.0:
                        l2 = 0.0
                        for i in range(3):
                            l2 += sq(self.P[VSTRIDE * b + i] - self.P[VSTRIDE * c + i])
                        q1 = 2.0 * SQRT3 * len1 / (l0 + l1 + l2)
                        if q1 < self.min_quality:
                            l0 = 0.0
                            l1 = 0.0
                            for i in range(3):
                                l0 += sq(self.P[VSTRIDE * b + i] - self.P[VSTRIDE * center + i])
                                l1 += sq(self.P[VSTRIDE * c + i] - self.P[VSTRIDE * center + i])
                            q0 = 2.0 * SQRT3 * len0 / (l0 + l1 + l2)
                            if q1 < q0:
                                return False         # a sliver, worse than before
                    if self.check_orig:
                        # no new fold: the face must not bend back onto the neighbour across
                        # its far edge b-c, nor onto the previous face of the fan
                        t = self.m.twin[he_next(y)]
                        if t >= 0:
                            g = t // 3
                            if g != fa and g != fb and g != self.skip_c and g != self.skip_d:
                                x = self.m.corner[he_prev(t)]
                                for i in range(3):
                                    e1[i] = self.P[VSTRIDE * b + i] - self.P[VSTRIDE * c + i]
                                    e2[i] = self.P[VSTRIDE * x + i] - self.P[VSTRIDE * c + i]
                                cross3(e1, e2, ng)
                                lg = sqrt(dot3(ng, ng))
                                if (dot3(n1, ng) < FOLD_COS * len1 * lg
                                        and dot3(n1, ng) * len0 < dot3(n0, ng) * len1):
                                    return False
                        if prev_ok > 0.0 and dot3(n1, prev_n1) < FOLD_COS * len1 * prev_ok:
                            return False
                        for i in range(3):
                            prev_n1[i] = n1[i]
                        prev_len1 = len1
            y = he_ring_next(self.m, y)
            if y < 0 or y == start:
                return True

    cdef bint geometry_ok(self, int h, int r, int k, const double* p) noexcept nogil:
        cdef int fa = h // 3
        cdef int fb = self.m.twin[h] // 3 if self.m.twin[h] >= 0 else -1
        cdef double dvol = 0.0
        if not self.fan_ok(r, fa, fb, p, &dvol):
            return False
        if not same_point(p, &self.P[VSTRIDE * k]):
            if not self.fan_ok(k, fa, fb, p, &dvol):
                return False
        if self.closed_volume != 0.0:
            # a closed surface must not be turned inside out (locally valid faces can still
            # enclose a negative volume once the mesh is down to a handful of faces)
            dvol -= self.face_volume(fa)
            if fb >= 0:
                dvol -= self.face_volume(fb)
            if (self.closed_volume + dvol) * self.closed_volume <= 0.0:
                return False
            self.pending_dvol = dvol
        return True

    cdef bint ring_has(self, int v, int a, int b) noexcept nogil:
        """Is ``a`` or ``b`` a neighbour of ``v``?"""
        cdef int start = self.m.v_he[v]
        cdef int y = start
        cdef int w, ny
        while True:
            w = he_dest(self.m, y)
            if w == a or w == b:
                return True
            ny = he_ring_next(self.m, y)
            if ny < 0:
                w = self.m.corner[he_prev(y)]
                return w == a or w == b
            if ny == start:
                return False
            y = ny

    cdef bint pair_ok(self, int h, int r, int k, int hs, int rs, int ks, const double* p,
                      double* dvol) noexcept nogil:
        """May seam edge h (r -> k) and its partner hs (rs -> ks) collapse together?
        If so ``dvol[0..1]`` get each side's volume change; if not, the refusal is counted
        (topology or geometry).  The two sides must not touch (no edge from one side's ends
        to the other's): then the first collapse changes nothing the second one's checks
        look at, and both can be checked before either is done."""
        if (not self.hm.link_ok(h) or not self.hm.link_ok(hs)
                or self.ring_has(r, rs, ks) or self.ring_has(k, rs, ks)):
            self.n_rejected_topology += 1
            return False
        if not self.geometry_ok(h, r, k, p):
            self.n_rejected_geometry += 1
            return False
        dvol[0] = self.pending_dvol
        if not self.geometry_ok(hs, rs, ks, p):
            self.n_rejected_geometry += 1
            return False
        dvol[1] = self.pending_dvol
        return True

    cdef void perform_pair(self, int h, int r, int hs, int rs, const double* p, double cost,
                           double err, const double* dvol) noexcept nogil:
        """Collapse seam edge h (removing r) and its partner hs (removing rs), then
        re-rank around both kept vertices (once both sides are done: a seam edge's cost
        reads both sides).  Both collapses are recorded."""
        cdef int k = he_dest(self.m, h) if self.m.corner[h] == r else self.m.corner[h]
        cdef int ks = he_dest(self.m, hs) if self.m.corner[hs] == rs else self.m.corner[hs]
        self.defer_recost = True
        self.pending_dvol = dvol[0]
        self.perform(h, r, p, cost, err)
        if self.record:
            self.rec_open[self.n_collapses - 1] = 1
        if not self.failed:
            self.pending_dvol = dvol[1]
            self.perform(hs, rs, p, cost, err)
        self.defer_recost = False
        if self.failed:
            return
        self.n_seam_pairs += 1
        self.rerank(k)
        self.rerank(ks)

    cdef double face_volume(self, int f) noexcept nogil:
        """Six times the signed volume of the cone from the origin over face ``f``."""
        cdef double* a = &self.P[VSTRIDE * self.m.corner[3 * f]]
        cdef double* b = &self.P[VSTRIDE * self.m.corner[3 * f + 1]]
        cdef double* c = &self.P[VSTRIDE * self.m.corner[3 * f + 2]]
        return (a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2])
                + a[2] * (b[0] * c[1] - b[1] * c[0]))

    # ------------------------------------------------------------- heap upkeep
    cdef void recost(self, int e) noexcept nogil:
        """Re-rank edge ``e`` after a change around it (or drop it if it may not collapse)."""
        cdef int h = self.m.edge_he[e]
        self.recost_he(e, h, self.m.corner[h], he_dest(self.m, h))

    cdef void recost_he(self, int e, int h, int u, int v) noexcept nogil:
        cdef int hh, r
        cdef double p[3]
        cdef double cost
        if self.plan_he(h, u, v, &hh, &r, p, &cost, NULL) == 0:       # ranking only
            if self.SP != NULL and self.seam_h >= 0:
                # a seam pair is ranked once, as the edge of side a (plan_seam's h_out)
                self.heap.push_fast(self.m.edge[hh], cost)
                self.heap.remove_fast(self.m.edge[self.seam_h])
            else:
                self.heap.push_fast(e, cost)
        else:
            self.heap.remove_fast(e)
            if self.SP != NULL and self.seam_h >= 0:
                self.heap.remove_fast(self.m.edge[self.seam_h])
                self.heap.remove_fast(self.m.edge[hh])

    cdef void recost_ring(self, int v) noexcept nogil:
        """Re-cost the edges around ``v``; around each neighbour that had a candidate
        refused by a check, give its refused edges (those out of the heap) another chance:
        the collapse at ``v`` may have made them legal."""
        cdef int start = self.m.v_he[v]
        cdef int y = start
        cdef int ny, w, hp
        self.refused[v] = 0
        while True:
            w = he_dest(self.m, y)
            self.recost_he(self.m.edge[y], y, v, w)
            self.retry_refused(w)
            ny = he_ring_next(self.m, y)
            if ny < 0:
                hp = he_prev(y)
                w = self.m.corner[hp]
                self.recost_he(self.m.edge[hp], hp, w, v)
                self.retry_refused(w)
                return
            if ny == start:
                return
            y = ny

    cdef void recost_wide(self, int v) noexcept nogil:
        """Re-rank every edge around ``v`` and around each of its neighbours, once each (for
        kernels whose costs depend on the stars of the ends: ``Kernel.wide``)."""
        cdef int start = self.m.v_he[v]
        cdef int y = start
        cdef int ny, i
        self.recost_counter += 1
        self.refused[v] = 0
        self.recost_around(v, self.recost_counter)
        if self.wide_kernel is not None and self.wide_kernel.n_changed >= 0:
            # the kernel named the vertices whose stars changed
            for i in range(self.wide_kernel.n_changed):
                self.recost_around(self.wide_kernel.changed[i], self.recost_counter)
            return
        while True:
            self.recost_around(he_dest(self.m, y), self.recost_counter)
            ny = he_ring_next(self.m, y)
            if ny < 0:
                self.recost_around(self.m.corner[he_prev(y)], self.recost_counter)
                return
            if ny == start:
                return
            y = ny

    cdef void recost_around(self, int w, int stamp) noexcept nogil:
        cdef int start = self.m.v_he[w]
        cdef int y = start
        cdef int ny, e
        self.refused[w] = 0
        while True:
            e = self.m.edge[y]
            if self.edge_stamp[e] != stamp:
                self.edge_stamp[e] = stamp
                self.recost_he(e, y, w, he_dest(self.m, y))
            ny = he_ring_next(self.m, y)
            if ny < 0:
                y = he_prev(y)
                e = self.m.edge[y]
                if self.edge_stamp[e] != stamp:
                    self.edge_stamp[e] = stamp
                    self.recost_he(e, y, self.m.corner[y], w)
                return
            if ny == start:
                return
            y = ny

    cdef void retry_refused(self, int w) noexcept nogil:
        cdef int start, y, ny, e
        if not self.refused[w]:
            return
        self.refused[w] = 0
        start = self.m.v_he[w]
        y = start
        while True:
            e = self.m.edge[y]
            if not self.heap.contains_fast(e):
                self.recost(e)
            ny = he_ring_next(self.m, y)
            if ny < 0:
                e = self.m.edge[he_prev(y)]
                if not self.heap.contains_fast(e):
                    self.recost(e)
                return
            if ny == start:
                return
            y = ny

    cdef void rescan(self) noexcept nogil:
        """Rebuild the heap from every live candidate: edges, or faces for triangle collapse."""
        cdef int e, f
        cdef int h, r, r2
        cdef double p[3]
        cdef double cost
        self.heap.clear_fast()
        self.n_vetoed = 0
        if self.tri:
            for f in range(self.hm.n_faces):
                if self.m.face_alive[f] and self.plan_tri(f, &h, &r, &r2, p, &cost, NULL) == 0:
                    self.heap.append_unordered(f, cost)
        else:
            for e in range(self.hm.n_edges):
                if self.m.edge_alive[e] and self.plan(e, &h, &r, p, &cost, NULL) == 0:
                    if self.SP != NULL and self.seam_h >= 0 and self.m.edge[h] != e:
                        continue              # side b of a seam pair: ranked as side a's edge
                    self.heap.append_unordered(e, cost)
                if self.failed:
                    break
        self.heap.heapify_fast()
        self.collapses_since_rescan = 0
        self.n_rejected_error = 0
        self.n_rejected_topology = 0
        self.n_rejected_geometry = 0

    # ------------------------------------------------------------- the collapse
    cdef void perform(self, int h, int r, const double* p, double cost, double err) noexcept nogil:
        cdef int dead[3]
        cdef int merged_into[2]
        cdef int k, i, j
        cdef double t = 0.0, len2 = 0.0
        cdef Candidate cand
        k = he_dest(self.m, h) if self.m.corner[h] == r else self.m.corner[h]
        # where p falls along r -> k decides how the attributes mix (for a triangle collapse
        # perform_tri gives the weight: barycentric over the face)
        if self.forced_t >= 0.0:
            t = self.forced_t
        else:
            for i in range(3):
                len2 += sq(self.P[VSTRIDE * k + i] - self.P[VSTRIDE * r + i])
                t += (p[i] - self.P[VSTRIDE * r + i]) * (self.P[VSTRIDE * k + i] - self.P[VSTRIDE * r + i])
            t = t / len2 if len2 > 0.0 else 1.0
            t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
        if self.record:
            self.rec_faces[self.n_collapses, 0] = h // 3
            self.rec_faces[self.n_collapses, 1] = self.m.twin[h] // 3 if self.m.twin[h] >= 0 else -1
        self.hm.collapse(h, r, dead, merged_into)
        self.vflags[k] |= self.vflags[r] & 2
        if self.closed_volume != 0.0:
            self.closed_volume += self.pending_dvol
        if self.use_heap and not self.tri:       # triangle collapse: perform_tri drops the faces
            for i in range(3):
                if dead[i] >= 0:
                    self.heap.remove_fast(dead[i])
        if self.n_vfields or self.n_efields:
            self.merge_fields(r, k, dead, merged_into)
        for i in range(QSIZE):
            self.Q[VSTRIDE * k + i] += self.Q[VSTRIDE * r + i]
        for i in range(self.n_attr):
            self.A[self.n_attr * k + i] = (1.0 - t) * self.A[self.n_attr * r + i] + t * self.A[self.n_attr * k + i]
        if self.gdim > 0:
            self.general_commit(r, k, p)
        if not same_point(p, &self.P[VSTRIDE * k]):
            for i in range(3):
                self.P[VSTRIDE * k + i] = p[i]
            self.moved[k] = 1
        if self.record:
            i = self.n_collapses
            self.rec_removed[i] = r
            self.rec_kept[i] = k
            self.rec_pos[i, 0] = p[0]
            self.rec_pos[i, 1] = p[1]
            self.rec_pos[i, 2] = p[2]
            self.rec_cost[i] = cost
            self.rec_error[i] = err
            self.rec_moved[i] = self.moved[k]
            for j in range(self.n_attr):
                self.rec_attr[i, j] = self.A[self.n_attr * k + j]
        self.n_collapses += 1
        if err > self.max_error_done:
            self.max_error_done = err
        self.collapses_since_rescan += 1
        if self.kernel is not None:
            # both ends are k now: u, v are not meaningful, removed / kept are
            fill_candidate(&cand, &self.kmesh, dead[0], h, r, k, r, k, p, cost, err)
            if chain_commit(self.chain, &cand) == KERNEL_ERROR:
                self.failed = True
                return
        if not self.defer_recost:
            self.rerank(k)

    cdef void rerank(self, int k) noexcept nogil:
        """Heap driver, after a collapse kept ``k``: re-rank the edges whose cost changed
        (around k, or around its neighbours too for wide kernels)."""
        if not self.use_heap:
            return
        if self.wide_recost:
            self.recost_wide(k)
        else:
            self.recost_ring(k)

    cdef void general_commit(self, int r, int k, const double* p) noexcept nogil:
        """Add the attribute quadric of r to k's and give k the attribute values that
        minimise it at the new position (where that is determined; else the interpolated
        values stay), each channel clamped to the range of the input values on the
        faces k now stands for (``gbox``).  The minimum of a sum of quadrics is no
        convex combination: unclamped, it can extrapolate (colours a few percent outside
        anything in the input)."""
        cdef double a[GMAX_D]
        cdef double q3[QSIZE]
        cdef double lo, hi
        cdef int i, gs = self.gsize, m = self.gdim - 3
        for i in range(gs):
            self.GQ[gs * k + i] += self.GQ[gs * r + i]
        for i in range(m):
            if self.gbox[r, i] < self.gbox[k, i]:
                self.gbox[k, i] = self.gbox[r, i]
            if self.gbox[r, m + i] > self.gbox[k, m + i]:
                self.gbox[k, m + i] = self.gbox[r, m + i]
        if self.SP != NULL and self.SP[k] != SEAM_NONE:
            return            # a seam vertex keeps its attributes: its side's chart at the seam
        if gq_marginal(&self.GQ[gs * k], self.gdim, q3, p, a):
            for i in range(m):
                lo = self.gbox[k, i]
                hi = self.gbox[k, m + i]
                self.A[self.n_attr * k + self.gcol[i]] = lo if a[i] < lo else (hi if a[i] > hi else a[i])

    cdef void merge_fields(self, int r, int k, const int* dead, const int* merged_into) noexcept nogil:
        """The kept vertex takes merge(kept, removed) of each vertex field; the edge that a
        dead wing edge was glued onto takes merge(surviving, dead) of each edge field."""
        cdef int j, i, es, ed
        cdef int nv = self.n_vfields, ne = self.n_efields
        for j in range(nv):
            self.VF[nv * k + j] = merge_value(self.VF[nv * k + j], self.VF[nv * r + j], <int>self.vrules[j, RULE_MERGE])
        for i in range(2):
            es = merged_into[i]
            ed = dead[1 + i]
            if es < 0 or ed < 0:
                continue
            for j in range(ne):
                self.EF[ne * es + j] = merge_value(self.EF[ne * es + j], self.EF[ne * ed + j], <int>self.erules[j, RULE_MERGE])

    cdef bint pop_candidate(self, int* item) noexcept nogil:
        """Pop the cheapest candidate (edge, or face for triangle collapse) into ``item``.
        When the heap is empty, rescan and pop again, unless nothing collapsed since the
        last rescan; False: no candidate is left."""
        cdef double key
        while self.heap.pop_fast(item, &key) < 0:
            if self.collapses_since_rescan == 0:
                return False
            self.rescan()
        return True

    cdef int run_c(self, int target_faces, int max_steps) noexcept nogil:
        cdef int e, h, r, k, hs, rs, ks, steps = 0
        cdef double cost, err
        cdef double p[3]
        cdef double dvol[2]
        if self.tri:
            return self.run_tri_c(target_faces, max_steps)
        while self.hm.n_alive_faces > target_faces:
            if steps >= max_steps:
                return RUN_CHUNK
            if not self.pop_candidate(&e):
                return RUN_EXHAUSTED
            if self.plan(e, &h, &r, p, &cost, &err) < 0:
                if self.failed:
                    return RUN_ERROR
                continue
            if err > self.max_error:
                self.n_rejected_error += 1
                continue
            k = he_dest(self.m, h) if self.m.corner[h] == r else self.m.corner[h]
            if self.SP != NULL and self.seam_h >= 0:
                # a seam edge: both sides together or neither
                hs = self.seam_h
                rs = self.SP[r]
                ks = self.SP[k]
                if not self.pair_ok(h, r, k, hs, rs, ks, p, dvol):
                    self.refused[r] = 1
                    self.refused[k] = 1
                    self.refused[rs] = 1
                    self.refused[ks] = 1
                    continue
                self.perform_pair(h, r, hs, rs, p, cost, err, dvol)
                if self.failed:
                    return RUN_ERROR
                steps += 1
                continue
            if not self.hm.link_ok(h):
                self.n_rejected_topology += 1
                self.refused[r] = 1
                self.refused[k] = 1
                continue
            if not self.geometry_ok(h, r, k, p):
                self.n_rejected_geometry += 1
                self.refused[r] = 1
                self.refused[k] = 1
                continue
            self.perform(h, r, p, cost, err)
            if self.failed:
                return RUN_ERROR
            steps += 1
        return RUN_TARGET

    # ------------------------------------------------------------- triangle collapse
    # operator=OP_TRIANGLE: the heap ranks faces.  A face (a, b, c) collapses to one point p
    # (the minimum of Q_a + Q_b + Q_c) as two edge collapses sharing the kept vertex k:
    # r1 -> k along the face's edge h1 (k moves to p), then r2 -> k along the edge k-r2
    # that the first collapse leaves (k is at p already).  Both are checked before either
    # is done: the first as the edge driver checks it; the second against the state the
    # first leaves, made for real on the half-edge arrays and undone (``tri_ok``).  The
    # face and its three neighbours across its edges die: v - 2, f - 4 inside the surface.

    cdef void general_marginal3(self, int a, int b, int c, double* q) noexcept nogil:
        """``general_marginal`` for the summed attribute quadrics of a face's three corners."""
        cdef double g[GMAX_S]
        cdef int i, gs = self.gsize
        for i in range(gs):
            g[i] = (self.GQ[gs * a + i] + self.GQ[gs * b + i]) + self.GQ[gs * c + i]
        gq_marginal(g, self.gdim, q, NULL, NULL)

    cdef int plan_tri(self, int f, int* h_out, int* r_out, int* r2_out, double* p, double* cost,
                      double* err) noexcept nogil:
        """Cost and placement of collapsing face ``f`` to one point, and the two collapses
        that do it: ``h_out`` (an edge of f: the first collapse), ``r_out`` (the end of it
        that goes first; the other end is kept), ``r2_out`` (the third corner, which goes
        second).  -1 if the face may not collapse.

        The fixed rules, per corner: fixed (locked, split, ``lock``-policy boundary) and
        seam vertices may not move nor go; under ``preserve`` a lone boundary corner is held
        too.  Two held corners: no collapse; one: everything goes to it.  With two or three
        corners on the border the first collapse runs along a boundary edge of the face
        (through the held corner, if any) -- an interior edge between border vertices would
        pinch the surface -- and, for ``placement="endpoint"`` under ``preserve``, p is one
        of that edge's ends (a border vertex is not pulled onto an interior one)."""
        cdef int v[3]
        cdef bint fx[3]
        cdef bint bd[3]
        cdef int i, j, i0, i1, ik, ib, h, nb = 0, nf = 0, kf = -1, first = -1
        cdef double q[QSIZE]
        cdef double qg[QSIZE]
        cdef double cand[3]
        cdef double c, best, d, dbest
        if not self.m.face_alive[f]:
            return -1
        for i in range(3):
            v[i] = self.m.corner[3 * f + i]
            fx[i] = (self.vflags[v[i]] & 1) != 0 or (self.SP != NULL and self.SP[v[i]] != SEAM_NONE)
            bd[i] = (self.vflags[v[i]] & 2) != 0
            if bd[i]:
                nb += 1
        if self.boundary == BOUNDARY_PRESERVE and nb == 1:
            for i in range(3):
                if bd[i]:
                    fx[i] = True            # the face is pulled to its one border corner
        for i in range(3):
            if fx[i]:
                nf += 1
                kf = i
        if nf >= 2:
            return -1
        if nb >= 2:
            for i in range(3):
                h = 3 * f + i
                if self.m.twin[h] >= 0:
                    continue
                if kf >= 0 and kf != i and kf != (i + 1) % 3:
                    continue
                first = h
                break
            if first < 0:
                return -1
        for i in range(QSIZE):
            q[i] = (self.Q[VSTRIDE * v[0] + i] + self.Q[VSTRIDE * v[1] + i]) + self.Q[VSTRIDE * v[2] + i]
        if self.gdim > 0:
            for i in range(QSIZE):
                qg[i] = q[i]
            self.general_marginal3(v[0], v[1], v[2], q)
        if kf >= 0:
            for i in range(3):
                p[i] = self.P[VSTRIDE * v[kf] + i]
            c = quadric_eval(q, p)
        elif self.placement == PLACE_ENDPOINT:
            ib = -1
            best = INFINITY
            for j in range(3):
                if (first >= 0 and nb == 2 and self.boundary == BOUNDARY_PRESERVE
                        and j == (first - 3 * f + 2) % 3):
                    continue                # the interior corner: the border would move in
                c = quadric_eval(q, &self.P[VSTRIDE * v[j]])
                if ib < 0 or c < best or (c == best and v[j] < v[ib]):
                    best = c
                    ib = j
            for i in range(3):
                p[i] = self.P[VSTRIDE * v[ib] + i]
            c = best
        else:
            if quadric_solve(q, p):
                c = quadric_eval(q, p)
            else:
                # fallback: the best of the truncated solve about the centroid, the three
                # corners and the centroid
                for i in range(3):
                    cand[i] = (self.P[VSTRIDE * v[0] + i] + self.P[VSTRIDE * v[1] + i]
                               + self.P[VSTRIDE * v[2] + i]) / 3.0
                quadric_solve_truncated(q, cand, p)
                best = quadric_eval(q, p)
                for j in range(3):
                    take_if_lower(q, &self.P[VSTRIDE * v[j]], p, &best)
                take_if_lower(q, cand, p, &best)
                c = best
        if c < 0.0:
            c = 0.0
        # the kept slot: the held corner, else the corner nearest to p (provenance), one of
        # the first edge's ends when that edge is prescribed
        ik = kf
        if ik < 0:
            dbest = INFINITY
            for j in range(3):
                if first >= 0 and j != first - 3 * f and j != (first - 3 * f + 1) % 3:
                    continue
                d = sq(p[0] - self.P[VSTRIDE * v[j]]) + sq(p[1] - self.P[VSTRIDE * v[j] + 1]) + sq(p[2] - self.P[VSTRIDE * v[j] + 2])
                if ik < 0 or d < dbest or (d == dbest and v[j] < v[ik]):
                    dbest = d
                    ik = j
        if first < 0:
            first = 3 * f + ik              # the first collapse: k's edge to the next corner
        i0 = first - 3 * f
        i1 = (i0 + 1) % 3
        h_out[0] = first
        r_out[0] = v[i1] if ik == i0 else v[i0]
        r2_out[0] = v[(i0 + 2) % 3]
        if err != NULL:
            err[0] = collapse_error(quadric_eval(qg, p) if self.gdim > 0 else c, q[10], self.error_scale)
        cost[0] = self.quadric_weight * c
        return 0

    cdef int find_he(self, int k, int w) noexcept nogil:
        """A half-edge of edge k-w (either way), -1 if there is none."""
        cdef int start = self.m.v_he[k]
        cdef int y = start
        cdef int ny
        while True:
            if he_dest(self.m, y) == w:
                return y
            ny = he_ring_next(self.m, y)
            if ny < 0:
                y = he_prev(y)
                return y if self.m.corner[y] == w else -1
            if ny == start:
                return -1
            y = ny

    cdef bint tri_ok(self, int h1, int r1, int k, int r2, const double* p, int* h2_out,
                     int* dead_faces, double* dvol) noexcept nogil:
        """May the face of ``h1`` collapse as r1 -> k (k to p), then r2 -> k?  The first
        collapse gets the edge driver's checks (link condition, moved faces, volume); then
        it is done on the half-edge arrays (k at p), the second is checked the same way
        against that state, and the first is undone: every entry ``HalfEdgeMesh.collapse``
        writes is saved before and written back after (r1's corners by walking its fan
        again once the twins are back).  Fills ``h2_out`` (the second collapse's
        half-edge, valid once the first is done), ``dead_faces[0..3]`` (the four faces that
        die, -1 for none on a border) and ``dvol[0..1]``; counts the refusals."""
        cdef int* ip[16]
        cdef int iv[16]
        cdef unsigned char* bp[8]
        cdef unsigned char bv[8]
        cdef int ni = 0, nb = 0, i, x, s, d, y, ny, start, h2
        cdef int dead[3]
        cdef int merged[2]
        cdef double saved_p[3]
        cdef double saved_vol = self.closed_volume
        cdef int saved_faces = self.hm.n_alive_faces
        cdef int saved_verts = self.hm.n_alive_vertices
        cdef bint ok = True
        if not self.hm.link_ok(h1):
            self.n_rejected_topology += 1
            return False
        # the faces across the face's other two edges die in the second collapse: the first
        # one's check counts their volume but does not judge their passing shape
        x = h1 - 3 * (h1 // 3)
        s = self.m.twin[3 * (h1 // 3) + (x + 1) % 3]
        d = self.m.twin[3 * (h1 // 3) + (x + 2) % 3]
        self.skip_c = s // 3 if s >= 0 else -1
        self.skip_d = d // 3 if d >= 0 else -1
        self.pending_dvol = 0.0
        ok = self.geometry_ok(h1, r1, k, p)
        self.skip_c = -1
        self.skip_d = -1
        if not ok:
            self.n_rejected_geometry += 1
            return False
        dvol[0] = self.pending_dvol
        dead_faces[0] = h1 // 3
        dead_faces[1] = self.m.twin[h1] // 3 if self.m.twin[h1] >= 0 else -1
        dead_faces[2] = -1
        dead_faces[3] = -1
        # what collapse(h1, r1) writes, as it computes it (halfedge.pyx)
        for i in range(2):
            x = h1 if i == 0 else self.m.twin[h1]
            if x < 0:
                continue
            if self.m.corner[x] == r1:
                s = he_next(x)
                d = he_prev(x)
            else:
                s = he_prev(x)
                d = he_next(x)
            if self.m.twin[s] >= 0:
                ip[ni] = &self.m.twin[self.m.twin[s]]
                ni += 1
            if self.m.twin[d] >= 0:
                ip[ni] = &self.m.twin[self.m.twin[d]]
                ip[ni + 1] = &self.m.edge[self.m.twin[d]]
                ni += 2
            ip[ni] = &self.m.edge_he[self.m.edge[s]]
            ip[ni + 1] = &self.m.v_he[self.m.corner[he_prev(x)]]
            ni += 2
            bp[nb] = &self.m.edge_alive[self.m.edge[d]]
            bp[nb + 1] = &self.m.face_alive[x // 3]
            nb += 2
        ip[ni] = &self.m.v_he[k]
        ni += 1
        bp[nb] = &self.m.edge_alive[self.m.edge[h1]]
        bp[nb + 1] = &self.m.vertex_alive[r1]
        nb += 2
        for i in range(ni):
            iv[i] = ip[i][0]
        for i in range(nb):
            bv[i] = bp[i][0]
        self.hm.collapse(h1, r1, dead, merged)
        for i in range(3):
            saved_p[i] = self.P[VSTRIDE * k + i]
            self.P[VSTRIDE * k + i] = p[i]
        if self.closed_volume != 0.0:
            self.closed_volume += dvol[0]
        h2 = self.find_he(k, r2)
        if h2 < 0 or not self.hm.link_ok(h2):
            self.n_rejected_topology += 1
            ok = False
        else:
            dead_faces[2] = h2 // 3
            dead_faces[3] = self.m.twin[h2] // 3 if self.m.twin[h2] >= 0 else -1
            self.pending_dvol = 0.0
            if not self.geometry_ok(h2, r2, k, p):
                self.n_rejected_geometry += 1
                ok = False
            dvol[1] = self.pending_dvol
        if not ok:
            self.n_tri_refused_second += 1
        # undo the first collapse
        self.closed_volume = saved_vol
        for i in range(3):
            self.P[VSTRIDE * k + i] = saved_p[i]
        for i in range(ni - 1, -1, -1):
            ip[i][0] = iv[i]
        for i in range(nb - 1, -1, -1):
            bp[i][0] = bv[i]
        start = self.m.v_he[r1]
        y = start
        while True:
            self.m.corner[y] = r1
            ny = he_ring_next(self.m, y)
            if ny < 0 or ny == start:
                break
            y = ny
        self.hm.n_alive_faces = saved_faces
        self.hm.n_alive_vertices = saved_verts
        h2_out[0] = h2
        return ok

    cdef void perform_tri(self, int h1, int r1, int h2, int r2, const double* p, double cost,
                          double err, const int* dead_faces, const double* dvol) noexcept nogil:
        """Do the two collapses ``tri_ok`` passed, then drop the dead faces from the heap and
        re-rank the faces around the kept vertex.  The attributes (and vertex fields' merge
        rules, edge by edge) follow the two collapses; the attribute weights are p's
        barycentric coordinates over the face (clamped to it), so that k ends with
        l_k A_k + l_r1 A_r1 + l_r2 A_r2.  Both collapses are recorded, the first marked as
        half of one step (``rec_open``), with the triangle's cost and error."""
        cdef int k = he_dest(self.m, h1) if self.m.corner[h1] == r1 else self.m.corner[h1]
        cdef double e0[3]
        cdef double e1[3]
        cdef double w[3]
        cdef double d00, d01, d11, d20, d21, den, l0, l1, l2, t1 = -1.0, t2 = -1.0
        cdef int i
        for i in range(3):
            e0[i] = self.P[VSTRIDE * r1 + i] - self.P[VSTRIDE * k + i]
            e1[i] = self.P[VSTRIDE * r2 + i] - self.P[VSTRIDE * k + i]
            w[i] = p[i] - self.P[VSTRIDE * k + i]
        d00 = dot3(e0, e0)
        d01 = dot3(e0, e1)
        d11 = dot3(e1, e1)
        d20 = dot3(w, e0)
        d21 = dot3(w, e1)
        den = d00 * d11 - d01 * d01
        if den > 1e-12 * d00 * d11:
            l1 = (d11 * d20 - d01 * d21) / den
            l2 = (d00 * d21 - d01 * d20) / den
            l0 = 1.0 - l1 - l2
            l0 = l0 if l0 > 0.0 else 0.0
            l1 = l1 if l1 > 0.0 else 0.0
            l2 = l2 if l2 > 0.0 else 0.0
            den = l0 + l1 + l2
            l0 /= den
            l1 /= den
            t1 = l0 / (l0 + l1) if l0 + l1 > 0.0 else 1.0
            t2 = l0 + l1
        self.defer_recost = True
        self.forced_t = t1
        self.pending_dvol = dvol[0]
        self.perform(h1, r1, p, cost, err)
        if self.record:
            self.rec_open[self.n_collapses - 1] = 1
        self.forced_t = t2
        self.pending_dvol = dvol[1]
        self.perform(h2, r2, p, cost, err)
        self.forced_t = -1.0
        self.defer_recost = False
        self.n_tri_collapses += 1
        for i in range(4):
            if dead_faces[i] >= 0:
                self.heap.remove_fast(dead_faces[i])
        self.rerank_tri(k)

    cdef void recost_face(self, int f) noexcept nogil:
        cdef int h, r, r2
        cdef double p[3]
        cdef double cost
        if self.plan_tri(f, &h, &r, &r2, p, &cost, NULL) == 0:
            self.heap.push_fast(f, cost)
        else:
            self.heap.remove_fast(f)

    cdef void rerank_tri(self, int k) noexcept nogil:
        """After a triangle collapse kept ``k``: re-rank the faces around k (their corners'
        quadrics or positions changed; no other face's did), and give the refused faces of
        k's neighbours another chance."""
        cdef int start = self.m.v_he[k]
        cdef int y = start
        cdef int ny
        self.refused[k] = 0
        while True:
            self.recost_face(y // 3)
            self.retry_refused_tri(he_dest(self.m, y))
            ny = he_ring_next(self.m, y)
            if ny < 0:
                self.retry_refused_tri(self.m.corner[he_prev(y)])
                return
            if ny == start:
                return
            y = ny

    cdef void retry_refused_tri(self, int w) noexcept nogil:
        cdef int start, y, ny
        if not self.refused[w]:
            return
        self.refused[w] = 0
        start = self.m.v_he[w]
        y = start
        while True:
            if not self.heap.contains_fast(y // 3):
                self.recost_face(y // 3)
            ny = he_ring_next(self.m, y)
            if ny < 0 or ny == start:
                return
            y = ny

    cdef int run_tri_c(self, int target_faces, int max_steps) noexcept nogil:
        """``run_c`` for triangle collapse: pop the cheapest face, re-plan it, check both
        collapses, do them; ``max_steps`` counts triangle collapses."""
        cdef int f, h1, r1, r2, h2, k, steps = 0
        cdef int dead_faces[4]
        cdef double cost, err
        cdef double p[3]
        cdef double dvol[2]
        while self.hm.n_alive_faces > target_faces:
            if steps >= max_steps:
                return RUN_CHUNK
            if not self.pop_candidate(&f):
                return RUN_EXHAUSTED
            if self.plan_tri(f, &h1, &r1, &r2, p, &cost, &err) < 0:
                continue
            if err > self.max_error:
                self.n_rejected_error += 1
                continue
            k = he_dest(self.m, h1) if self.m.corner[h1] == r1 else self.m.corner[h1]
            dvol[0] = 0.0
            dvol[1] = 0.0
            if not self.tri_ok(h1, r1, k, r2, p, &h2, dead_faces, dvol):
                self.refused[k] = 1
                self.refused[r1] = 1
                self.refused[r2] = 1
                continue
            self.perform_tri(h1, r1, h2, r2, p, cost, err, dead_faces, dvol)
            steps += 1
        return RUN_TARGET

    cdef int collapse_pass_c(self, const int* E, int n_cand, const double* PO, int target_faces) noexcept nogil:
        """One pass of the batch driver: try the edges in the order given, skipping those
        with an end that an earlier collapse of this pass touched (the kept vertex and its
        1-ring), so every collapse sees the costs it was ranked with.  Returns the number of
        collapses, or -1 if a kernel failed."""
        cdef int i, e, h, r, k, u, v, hs, rs, ks, done = 0
        cdef double cost, err
        cdef double p[3]
        cdef double q[QSIZE]
        cdef double dvol[2]
        cdef Candidate cand
        cdef int stamp, rc
        self.pass_counter += 1
        stamp = self.pass_counter
        self.n_rejected_error = 0
        self.n_rejected_topology = 0
        self.n_rejected_geometry = 0
        for i in range(n_cand):
            if self.hm.n_alive_faces <= target_faces:
                break
            e = E[i]
            if not self.m.edge_alive[e]:
                continue
            h = self.m.edge_he[e]
            u = self.m.corner[h]
            v = he_dest(self.m, h)
            if self.touched[u] == stamp or self.touched[v] == stamp:
                continue
            if self.plan(e, &h, &r, p, &cost, &err) < 0:
                if self.failed:
                    return -1
                continue
            if self.SP != NULL and self.seam_h >= 0:
                # a seam edge: both sides together or neither, where the core placed it
                hs = self.seam_h
                k = he_dest(self.m, h) if self.m.corner[h] == r else self.m.corner[h]
                rs = self.SP[r]
                ks = self.SP[k]
                if self.touched[rs] == stamp or self.touched[ks] == stamp:
                    continue
                if err > self.max_error:
                    self.n_rejected_error += 1
                    continue
                if not self.pair_ok(h, r, k, hs, rs, ks, p, dvol):
                    continue
                self.perform_pair(h, r, hs, rs, p, cost, err, dvol)
                if self.failed:
                    return -1
                done += 1
                self.mark_touched(k, stamp)
                self.mark_touched(ks, stamp)
                continue
            if PO != NULL and self.SP != NULL and (self.SP[u] != SEAM_NONE or self.SP[v] != SEAM_NONE):
                pass            # a seam vertex stays where it is, whatever a batch metric says
            elif PO != NULL and not ((self.vflags[u] | self.vflags[v]) & (1 if self.boundary == BOUNDARY_FREE else 3)):
                # the batch metric placed it: both ends are free to move
                p[0] = PO[3 * i]
                p[1] = PO[3 * i + 1]
                p[2] = PO[3 * i + 2]
                for k in range(QSIZE):
                    q[k] = self.Q[VSTRIDE * u + k] + self.Q[VSTRIDE * v + k]
                err = collapse_error(quadric_eval(q, p), q[10], self.error_scale)
                if self.kernel is not None:
                    # the kernels judged the core's position: ask them again about this one
                    # (only their verdict counts here; the batch has ranked already)
                    fill_candidate(&cand, &self.kmesh, e, h, u, v, r, v if r == u else u, p, cost, err)
                    rc = chain_cost(self.chain, &cand)
                    if rc != KERNEL_OK:
                        if self.kernel_refused(rc) == -2:
                            return -1
                        continue
            if err > self.max_error:
                self.n_rejected_error += 1
                continue
            k = v if r == u else u
            if not self.hm.link_ok(h):
                self.n_rejected_topology += 1
                continue
            if not self.geometry_ok(h, r, k, p):
                self.n_rejected_geometry += 1
                continue
            self.perform(h, r, p, cost, err)
            if self.failed:
                return -1
            done += 1
            self.mark_touched(k, stamp)
        return done

    cdef void mark_touched(self, int k, int stamp) noexcept nogil:
        """Pass driver: mark the kept vertex k and its 1-ring (2-ring for wide kernels) as
        touched in this pass, so no later collapse of the pass sees stale costs there."""
        cdef int start = self.m.v_he[k]
        cdef int y = start
        cdef int ny
        self.touched[k] = stamp
        while True:
            if self.wide_recost:
                self.touch_ring(he_dest(self.m, y), stamp)
            self.touched[he_dest(self.m, y)] = stamp
            ny = he_ring_next(self.m, y)
            if ny < 0:
                if self.wide_recost:
                    self.touch_ring(self.m.corner[he_prev(y)], stamp)
                self.touched[self.m.corner[he_prev(y)]] = stamp
                return
            if ny == start:
                return
            y = ny

    cdef void touch_ring(self, int w, int stamp) noexcept nogil:
        """Mark w's neighbours touched in this pass (wide kernels: their costs changed)."""
        cdef int start = self.m.v_he[w]
        cdef int y = start
        cdef int ny
        while True:
            self.touched[he_dest(self.m, y)] = stamp
            ny = he_ring_next(self.m, y)
            if ny < 0:
                self.touched[self.m.corner[he_prev(y)]] = stamp
                return
            if ny == start:
                return
            y = ny

    # ------------------------------------------------------------- Python API
    def run(self, int target_faces, int max_steps=2**31 - 1):
        """Collapse until ``target_faces`` live faces remain, ``max_steps`` collapses are done,
        or nothing legal is left.  Returns 0 (target), 1 (step budget) or 2 (exhausted)."""
        cdef int status
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        with nogil:
            status = self.run_c(target_faces, max_steps)
        return status

    def plan_all(self):
        """Plan every live edge (batch driver): a dict of ``edge``, ``u``, ``v``,
        ``removed``, ``kept`` (int32 vertex slots), ``position`` (k, 3), ``cost`` and
        ``error``, one row per edge that may collapse (within ``max_error``), or None if a
        kernel failed."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        cdef int ne = self.hm.n_edges
        cdef int e, h, r, rc, k = 0
        cdef double cost, err
        cdef double p[3]
        out_e = np.empty(ne, dtype=np.intc)
        out_u = np.empty(ne, dtype=np.intc)
        out_v = np.empty(ne, dtype=np.intc)
        out_r = np.empty(ne, dtype=np.intc)
        out_p = np.empty((ne, 3), dtype=np.float64)
        out_c = np.empty(ne, dtype=np.float64)
        out_x = np.empty(ne, dtype=np.float64)
        cdef int[::1] OE = out_e
        cdef int[::1] OU = out_u
        cdef int[::1] OV = out_v
        cdef int[::1] OR = out_r
        cdef double[:, ::1] OP = out_p
        cdef double[::1] OC = out_c
        cdef double[::1] OX = out_x
        self.n_vetoed = 0
        self.n_rejected_error = 0
        with nogil:
            for e in range(ne):
                if not self.m.edge_alive[e]:
                    continue
                rc = self.plan(e, &h, &r, p, &cost, &err)
                if rc < 0:
                    if self.failed:
                        break
                    continue
                if self.SP != NULL and self.seam_h >= 0 and self.m.edge[h] != e:
                    continue              # side b of a seam pair: listed as side a's edge
                if err > self.max_error:
                    self.n_rejected_error += 1
                    continue
                OE[k] = e
                OU[k] = self.m.corner[h]
                OV[k] = he_dest(self.m, h)
                OR[k] = r
                OP[k, 0] = p[0]
                OP[k, 1] = p[1]
                OP[k, 2] = p[2]
                OC[k] = cost
                OX[k] = err
                k += 1
        if self.failed:
            return None
        u = out_u[:k].copy()
        v = out_v[:k].copy()
        removed = out_r[:k].copy()
        return {"edge": out_e[:k].copy(), "u": u, "v": v, "removed": removed,
                "kept": np.where(removed == u, v, u).astype(np.intc),
                "position": out_p[:k].copy(), "cost": out_c[:k].copy(), "error": out_x[:k].copy()}

    def collapse_pass(self, edges, positions=None, int target_faces=0):
        """Collapse, in the order given, the ``edges`` whose ends no earlier collapse of
        this pass touched (re-planned and checked like the heap driver's).  ``positions``
        (k, 3), one per edge, overrides the placement where both ends are free to move.
        Returns the number of collapses; -1 if a kernel failed."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        if self.use_heap:
            raise RuntimeError("collapse_pass needs an EdgeCollapser made with use_heap=False")
        cdef int[::1] E = np.ascontiguousarray(edges, dtype=np.intc)
        cdef int n_cand = E.shape[0]
        if n_cand and (np.min(E) < 0 or np.max(E) >= self.hm.n_edges):
            raise ValueError(f"edge ids must be in 0..{self.hm.n_edges - 1}")
        cdef double[:, ::1] PO
        cdef const double* po = NULL
        if positions is not None:
            PO = np.ascontiguousarray(positions, dtype=np.float64)
            if PO.shape[0] != n_cand or PO.shape[1] != 3:
                raise ValueError(f"positions must have shape ({n_cand}, 3)")
            if n_cand:
                po = &PO[0, 0]
        cdef int done = 0
        if n_cand:
            with nogil:
                done = self.collapse_pass_c(&E[0], n_cand, po, target_faces)
        return done

    @property
    def error_message(self):
        """The message of the kernel that failed ('' if none did)."""
        for k in (self.chain.kernels() if self.chain is not None else ()):
            if k.failed:
                return k.message
        return ""

    @property
    def vertex_field_values(self):
        """(n, k) current vertex fields (merged on collapse)."""
        return np.asarray(self.vfield)[:, :self.n_vfields]

    @property
    def edge_field_values(self):
        return np.asarray(self.efield)[:, :self.n_efields]

    def release(self):
        """Free the heap, the quadrics and the input normals once the run is over (the
        positions, attributes and records stay readable); ``run`` may not be called again."""
        if self.released:
            return
        self.released = True
        self.heap = IndexedHeap(0)
        self.face_n0 = np.zeros(3, dtype=np.int16)
        self.N0 = &self.face_n0[0]
        self.pos_out = np.ascontiguousarray(np.asarray(self.vdata)[:, QSIZE:])
        self.vdata = np.zeros((1, VSTRIDE))
        self.Q = &self.vdata[0, 0]
        self.P = &self.vdata[0, QSIZE]

    def plan_face(self, int f):
        """``(kept, first, second, position, cost, error)`` for collapsing face ``f`` (a
        triangle-collapse EdgeCollapser): the kept vertex slot, the corner removed by the
        first collapse and the one removed by the second; None if it may not collapse.
        Checks nothing but the fixed/boundary rules; for tests."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        if not self.tri:
            raise RuntimeError("plan_face needs an EdgeCollapser made with operator=1 (triangle)")
        if not 0 <= f < self.hm.n_faces:
            raise ValueError(f"face ids must be in 0..{self.hm.n_faces - 1}")
        cdef int h, r, r2
        cdef double p[3]
        cdef double cost, err
        if self.plan_tri(f, &h, &r, &r2, p, &cost, &err) < 0:
            return None
        k = self.hm.dest(h) if self.hm.corner[h] == r else self.hm.corner[h]
        return k, r, r2, np.array([p[0], p[1], p[2]]), cost, err

    def check_face(self, int f):
        """Would face ``f`` collapse now (plan, max_error and both collapses' checks, as
        the driver does them)?  True / False; nothing is changed (the first collapse is
        done and undone inside).  For tests."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        if not self.tri:
            raise RuntimeError("check_face needs an EdgeCollapser made with operator=1 (triangle)")
        if not 0 <= f < self.hm.n_faces:
            raise ValueError(f"face ids must be in 0..{self.hm.n_faces - 1}")
        cdef int h1, r1, r2, h2, k
        cdef int dead_faces[4]
        cdef double p[3]
        cdef double dvol[2]
        cdef double cost, err
        cdef bint ok
        with nogil:
            ok = self.plan_tri(f, &h1, &r1, &r2, p, &cost, &err) == 0 and err <= self.max_error
            if ok:
                k = he_dest(self.m, h1) if self.m.corner[h1] == r1 else self.m.corner[h1]
                ok = self.tri_ok(h1, r1, k, r2, p, &h2, dead_faces, dvol)
        return bool(ok)

    def plan_edge(self, int u, int v):
        """``(removed, kept, position, cost, error)`` for edge (u, v), or None if it may not
        collapse.  Checks nothing but the fixed/boundary rules; for tests."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        h = self.hm._find_halfedge(u, v)
        if h < 0:
            raise ValueError(f"({u}, {v}) is not an edge")
        cdef int hh, r
        cdef double p[3]
        cdef double cost, err
        if self.plan(self.hm.edge[h], &hh, &r, p, &cost, &err) < 0:
            return None
        k = self.hm.dest(hh) if self.hm.corner[hh] == r else self.hm.corner[hh]
        return r, k, np.array([p[0], p[1], p[2]]), cost, err

    @property
    def n_alive_faces(self):
        return self.hm.n_alive_faces

    @property
    def seam_partners(self):
        """(n,) int32: each vertex slot's seam partner, -1 off the seams, -2 a seam copy
        that stays (as given, with the fixed rules applied); None without seams."""
        if self.SP == NULL:
            return None
        return np.asarray(self.seam).copy()

    @property
    def positions(self):
        """(n, 3) current positions (a view while running, a copy after ``release``)."""
        if self.released:
            return self.pos_out
        return np.asarray(self.vdata)[:, QSIZE:]

    @property
    def attributes(self):
        return np.asarray(self.attr)

    @property
    def moved_vertices(self):
        return np.asarray(self.moved).astype(bool)

    @property
    def quadrics(self):
        """(n, 11) current quadrics (a view)."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        return np.asarray(self.vdata)[:, :QSIZE]

    def records(self):
        """The collapse sequence: dict of removed, kept (vertex slots), position (n, 3),
        cost, error and moved (False: the position is the kept vertex's input position),
        one row per collapse in the order they were done.  Needs
        ``record=True`` at construction."""
        if not self.record:
            raise RuntimeError("this EdgeCollapser was made with record=False")
        n = self.n_collapses
        return {
            "removed": np.asarray(self.rec_removed)[:n].copy(),
            "kept": np.asarray(self.rec_kept)[:n].copy(),
            "position": np.asarray(self.rec_pos)[:n].copy(),
            "cost": np.asarray(self.rec_cost)[:n].copy(),
            "error": np.asarray(self.rec_error)[:n].copy(),
            "moved": np.asarray(self.rec_moved)[:n].astype(bool),
            # for progressive meshes (lodkit.progressive): the vertex slots, the faces each
            # collapse removed, seam pairs' first halves and the kept vertex's attributes
            "removed_slot": np.asarray(self.rec_removed)[:n].copy(),
            "kept_slot": np.asarray(self.rec_kept)[:n].copy(),
            "faces": np.asarray(self.rec_faces)[:n].copy(),
            "pair_open": np.asarray(self.rec_open)[:n].astype(bool),
            "attributes": np.asarray(self.rec_attr)[:n].copy(),
        }
