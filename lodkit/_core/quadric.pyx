# cython: language_level=3
"""Quadric maths that is not inline (quadric.pxd) and the quadric builders over a mesh:
per-vertex plane quadrics, boundary planes, the input faces' unit normals.  Used by the edge
collapse drivers and vertex removal; Python reaches the builders through
``lodkit._core.decimate`` as well."""
import numpy as np
cimport numpy as cnp
from cython.parallel cimport prange
from libc.math cimport sqrt, fabs, acos, cos, M_PI, NAN
from libc.stdlib cimport malloc, free

from .common cimport QSIZE, PARALLEL_MIN_VERTICES, insertion_sort
from .halfedge cimport HalfEdgeMesh, HEArrays, he_next, he_ring_next
from .vec3 cimport cross3, dot3

cnp.import_array()

# In the truncated solve, directions whose eigenvalue is below this fraction of the largest
# are left alone (the quadric barely constrains them; moving along them is guesswork).
cdef double EIG_EPS = 1e-3
# Newton steps ``cubic_top_root`` may take before the trigonometric solution takes over
# (from h = -0.99, the slowest it is tried on, it takes 9)
cdef int NEWTON_STEPS = 12


cdef void sym3_eigen(const double* q, double* w, double* V) noexcept nogil:
    """Eigen-decomposition of the symmetric 3x3 block of a quadric by cyclic Jacobi
    rotations: eigenvalues ``w[0..2]``, eigenvectors in the columns of ``V`` (row-major)."""
    cdef double a[3][3]
    cdef int i, j, k, pp, qq
    cdef double off, theta, t, c, s, apq, app, aqq, akp, akq, vkp, vkq
    cdef int sym[9]
    sym[0] = 0
    sym[1] = 1
    sym[2] = 2
    sym[3] = 1
    sym[4] = 3
    sym[5] = 4
    sym[6] = 2
    sym[7] = 4
    sym[8] = 5
    for i in range(3):
        for j in range(3):
            a[i][j] = q[sym[3 * i + j]]
    for i in range(3):
        for j in range(3):
            V[3 * i + j] = 1.0 if i == j else 0.0
    for _ in range(12):
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


cdef int quadric_solve_truncated_jacobi(const double* q, const double* x0, double* p) noexcept nogil:
    """The truncated solve through the Jacobi eigen-decomposition (the reference the
    closed-form :func:`quadric_solve_truncated` is tested against); returns the number of
    directions solved in."""
    cdef double w[3]
    cdef double V[9]
    cdef double r[3]
    cdef double wmax, coef
    cdef int i, j, k
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
        return 0
    k = 0
    for j in range(3):
        if w[j] > EIG_EPS * wmax:
            coef = (V[j] * r[0] + V[3 + j] * r[1] + V[6 + j] * r[2]) / w[j]
            for i in range(3):
                p[i] += coef * V[3 * i + j]
            k += 1
    return k


cdef inline bint cubic_top_root(double h, double* x) noexcept nogil:
    """The largest root of x^3 - 3x - 2h (|h| <= 1: three real roots in [-2, 2]) by Newton
    steps from 2.  The cubic is convex above its largest root (which is >= 1), so the steps
    fall monotonically onto it; from h = 1 (a rank-1 quadric, a flat region) the root is 2
    itself and near it a step or two suffice.  False when the root is near the double root
    at h = -1 (slow, linear convergence) or the steps do not settle: the caller then takes
    the trigonometric solution."""
    cdef double y = 2.0, f, dx
    if h < -0.99:
        return False
    for _ in range(NEWTON_STEPS):
        f = (y * y - 3.0) * y - 2.0 * h
        dx = f / (3.0 * (y * y - 1.0))
        y -= dx
        # with h >= -0.99 the root is >= 1.08, where a step is at least 1/18 of the error
        # before it and the error after it at most 6.5 (error before)^2: a step of 1e-10
        # leaves an error below 1e-16 (rounding)
        if not (dx > 1e-10):
            x[0] = y
            return True
    return False


cdef void sym3_eigenvalues(const double* q, double* w) noexcept nogil:
    """Eigenvalues of the symmetric 3x3 block of a quadric in closed form, largest first:
    with B = (A - m I) / s (m the mean eigenvalue, s their spread), the roots of the
    characteristic cubic x^3 - 3x - det(B) = 0, which lie in [-2, 2].  The largest by
    Newton steps from 2 (``cubic_top_root``: exact at once for a rank-1 block, the common
    case here), the other two from the quadratic left after dividing it out; the
    trigonometric solution (``acos``, ``cos``) where Newton would be slow.  Off-diagonal
    entries must not all be zero (the caller handles a diagonal block)."""
    cdef double a11 = q[0], a12 = q[1], a13 = q[2], a22 = q[3], a23 = q[4], a33 = q[5]
    cdef double off = a12 * a12 + a13 * a13 + a23 * a23
    cdef double m = (a11 + a22 + a33) / 3.0
    cdef double b11 = a11 - m, b22 = a22 - m, b33 = a33 - m
    cdef double s = sqrt((b11 * b11 + b22 * b22 + b33 * b33 + 2.0 * off) / 6.0)
    cdef double det, h, phi, x0, disc
    if s == 0.0:
        w[0] = w[1] = w[2] = m
        return
    # det(B) / 2 with B = (A - m I) / s, in [-1, 1] up to rounding
    det = (b11 * (b22 * b33 - a23 * a23) - a12 * (a12 * b33 - a23 * a13)
           + a13 * (a12 * a23 - b22 * a13)) / (s * s * s)
    h = 0.5 * det
    if h >= 1.0:
        x0 = 2.0
    elif not cubic_top_root(h, &x0):
        if h <= -1.0:
            phi = M_PI / 3.0
        else:
            phi = acos(h) / 3.0
        w[0] = m + 2.0 * s * cos(phi)
        w[2] = m + 2.0 * s * cos(phi + 2.0 * M_PI / 3.0)
        w[1] = 3.0 * m - w[0] - w[2]
        return
    # the other roots: x^2 + x0 x + x0^2 - 3 = 0, discriminant 12 - 3 x0^2
    disc = 3.0 * (2.0 - x0) * (2.0 + x0)
    disc = sqrt(disc) if disc > 0.0 else 0.0
    w[0] = m + s * x0
    w[2] = m + s * (0.5 * (-x0 - disc))
    w[1] = 3.0 * m - w[0] - w[2]


cdef inline void shifted_row(const double* q, double lam, int i, double* r) noexcept nogil:
    """Row ``i`` of the quadric's 3x3 block minus ``lam`` I (the block stored as q[0..5] =
    a11 a12 a13 a22 a23 a33)."""
    if i == 0:
        r[0] = q[0] - lam
        r[1] = q[1]
        r[2] = q[2]
    elif i == 1:
        r[0] = q[1]
        r[1] = q[3] - lam
        r[2] = q[4]
    else:
        r[0] = q[2]
        r[1] = q[4]
        r[2] = q[5] - lam


cdef inline double longer_cross(const double* a, const double* b, double* v, double best) noexcept nogil:
    """``v = a x b`` if that is longer than ``best`` (a squared length); the longer one's."""
    cdef double c[3]
    cdef double n
    cross3(a, b, c)
    n = dot3(c, c)
    if n > best:
        v[0] = c[0]
        v[1] = c[1]
        v[2] = c[2]
        return n
    return best


cdef bint sym3_eigenvector(const double* q, double lam, double* v) noexcept nogil:
    """A unit eigenvector of the quadric's 3x3 block for the (simple) eigenvalue ``lam``:
    the longest cross product of two rows of A - lam I.  False if all three vanish."""
    cdef double r0[3]
    cdef double r1[3]
    cdef double r2[3]
    cdef double n, best
    shifted_row(q, lam, 0, r0)
    shifted_row(q, lam, 1, r1)
    shifted_row(q, lam, 2, r2)
    cross3(r0, r1, v)
    best = dot3(v, v)
    best = longer_cross(r0, r2, v, best)
    best = longer_cross(r1, r2, v, best)
    if not (best > 0.0):
        return False
    n = 1.0 / sqrt(best)
    v[0] *= n
    v[1] *= n
    v[2] *= n
    return True


cdef inline bint rank1_eigenvector(const double* q, double lam, double* v) noexcept nogil:
    """``sym3_eigenvector`` for the top eigenvalue ``lam`` of a nearly rank-1 block
    (A ~ lam e e^T, the other eigenvalues below EIG_EPS lam): the rows of A - lam I are then
    ~ -lam (e_i - e[i] e), and the cross product of rows i and j is ~ lam^2 e[k] e (k the
    third index), longest for the k with the largest e[k]^2 ~ A[k][k] / lam, at least
    lam^2 / sqrt(3).  One cross product instead of three."""
    cdef double r0[3]
    cdef double r1[3]
    cdef double n
    cdef int k = 0
    if q[3] > q[0]:
        k = 1
    if q[5] > (q[3] if k == 1 else q[0]):
        k = 2
    shifted_row(q, lam, 1 if k == 0 else 0, r0)   # the two rows other than k
    shifted_row(q, lam, 1 if k == 2 else 2, r1)
    cross3(r0, r1, v)
    n = dot3(v, v)
    if not (n > 0.0):
        return sym3_eigenvector(q, lam, v)
    n = 1.0 / sqrt(n)
    v[0] *= n
    v[1] *= n
    v[2] *= n
    return True


cdef int quadric_solve_truncated(const double* q, const double* x0, double* p) noexcept nogil:
    """Minimise the quadric in the well-determined directions only, staying at ``x0`` along
    the others (pseudo-inverse about x0, after Lindstrom): on a crease the point slides along
    the crease line to the spot nearest x0; in a flat region it stays at x0.

    The directions are the eigenvectors of A whose eigenvalue is above EIG_EPS times the
    largest, found in closed form (docs/performance.md): the eigenvalues from the
    characteristic cubic; with one such direction, its eigenvector (one cross product of
    two rows of A - w1 I); with two, the plane
    normal to the remaining eigenvector, where the system is solved with that direction
    given the largest eigenvalue (so the step stays in the plane); with three, the plain
    solve.  The same point as the Jacobi decomposition's (``quadric_solve_truncated_jacobi``)
    up to rounding, at a fraction of its cost.

    Returns the number of directions solved in (0-3): with 3, ``p`` is the quadric's
    minimum; with fewer, its minimum over the plane or line through x0 spanned by them, so
    no point of that plane or line (x0 itself) is lower."""
    cdef double w[3]
    cdef double v[3]
    cdef double r[3]
    cdef double a[QSIZE]
    cdef double d[3]
    cdef double wmax, lim, coef
    cdef int i, k
    r[0] = -(q[0] * x0[0] + q[1] * x0[1] + q[2] * x0[2] + q[6])
    r[1] = -(q[1] * x0[0] + q[3] * x0[1] + q[4] * x0[2] + q[7])
    r[2] = -(q[2] * x0[0] + q[4] * x0[1] + q[5] * x0[2] + q[8])
    for i in range(3):
        p[i] = x0[i]
    if q[1] == 0.0 and q[2] == 0.0 and q[4] == 0.0:
        # a diagonal block: the axes are the eigenvectors
        w[0] = q[0]
        w[1] = q[3]
        w[2] = q[5]
        wmax = max(w[0], max(w[1], w[2]))
        if not (wmax > 0.0):
            return 0
        k = 0
        for i in range(3):
            if w[i] > EIG_EPS * wmax:
                p[i] += r[i] / w[i]
                k += 1
        return k
    sym3_eigenvalues(q, w)
    wmax = w[0]
    if not (wmax > 0.0):
        return 0
    lim = EIG_EPS * wmax
    k = (w[0] > lim) + (w[1] > lim) + (w[2] > lim)
    if k == 1:
        if not rank1_eigenvector(q, w[0], v):
            return quadric_solve_truncated_jacobi(q, x0, p)
        coef = (v[0] * r[0] + v[1] * r[1] + v[2] * r[2]) / w[0]
        for i in range(3):
            p[i] += coef * v[i]
        return 1
    for i in range(6):
        a[i] = q[i]
    if k == 2:
        # drop the weak direction v: solve in the plane normal to it, where A is invertible
        if not sym3_eigenvector(q, w[2], v):
            return quadric_solve_truncated_jacobi(q, x0, p)
        coef = v[0] * r[0] + v[1] * r[1] + v[2] * r[2]
        for i in range(3):
            r[i] -= coef * v[i]
        coef = wmax - w[2]                 # A + (wmax - w3) v v^T: v gets the eigenvalue wmax
        a[0] += coef * v[0] * v[0]
        a[1] += coef * v[0] * v[1]
        a[2] += coef * v[0] * v[2]
        a[3] += coef * v[1] * v[1]
        a[4] += coef * v[1] * v[2]
        a[5] += coef * v[2] * v[2]
    # solve a d = r (cofactor_solve solves A d = -b: b = -r)
    a[6] = -r[0]
    a[7] = -r[1]
    a[8] = -r[2]
    if not cofactor_solve(a, d, 0.0):
        return quadric_solve_truncated_jacobi(q, x0, p)
    if k == 2:
        coef = v[0] * d[0] + v[1] * d[1] + v[2] * d[2]
        for i in range(3):
            d[i] -= coef * v[i]
    for i in range(3):
        p[i] += d[i]
    return k


def truncated_solve(q, x0, method="closed"):
    """The truncated quadric solve about ``x0`` for a QSIZE quadric row (tests): "closed"
    (what the drivers use) or "jacobi" (the reference)."""
    return truncated_solve_rank(q, x0, method)[0]


def truncated_solve_rank(q, x0, method="closed"):
    """``truncated_solve`` and the number of directions it solved in (tests)."""
    cdef double[::1] Q = np.ascontiguousarray(q, dtype=np.float64)
    cdef double[::1] X = np.ascontiguousarray(x0, dtype=np.float64)
    cdef int k
    if Q.shape[0] != QSIZE or X.shape[0] != 3:
        raise ValueError(f"q must have {QSIZE} entries and x0 3")
    out = np.empty(3)
    cdef double[::1] P = out
    if method == "closed":
        k = quadric_solve_truncated(&Q[0], &X[0], &P[0])
    elif method == "jacobi":
        k = quadric_solve_truncated_jacobi(&Q[0], &X[0], &P[0])
    else:
        raise ValueError("method must be 'closed' or 'jacobi'")
    return out, k


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
    q3[0] = A[0]
    q3[1] = A[1]
    q3[2] = A[2]
    q3[3] = A[D + 1]
    q3[4] = A[D + 2]
    q3[5] = A[2 * D + 2]
    q3[6] = b[0]
    q3[7] = b[1]
    q3[8] = b[2]
    q3[9] = c
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


cdef object readable_positions(positions):
    """(n, 3) float64 ``positions`` that :func:`rows_of` reads in place: as given when
    each row's x y z are adjacent (a view of the position columns of the (n, 14) vertex
    rows is not copied), else a C-contiguous copy."""
    arr = np.asarray(positions)
    if (arr.dtype == np.float64 and arr.ndim == 2 and arr.shape[1] == 3 and arr.strides[1] == sizeof(double)
            and arr.strides[0] >= 3 * <Py_ssize_t>sizeof(double) and arr.strides[0] % sizeof(double) == 0):
        return arr
    return np.ascontiguousarray(arr, dtype=np.float64)


def face_unit_normals(HalfEdgeMesh hm, positions, int threads=1):
    """(n_faces * 3,) int16 unit normals of the face slots, scaled by 32767 (zeros for
    degenerate faces): 6 bytes a face is plenty for a 90-degree test.

    Taken before any collapse: each face slot keeps its identity through the collapses, so
    these are the normals of the input faces the live faces stand for.  ``threads``: OpenMP
    threads (from PARALLEL_MIN_VERTICES vertex slots; each face is its own)."""
    cdef const double[:, :] P = readable_positions(positions)
    if threads < 1 or hm.n_vertices < PARALLEL_MIN_VERTICES:
        threads = 1
    out = np.zeros(3 * hm.n_faces, dtype=np.int16)
    cdef short[::1] N = out
    cdef Rows X = rows_of(P)
    cdef const HEArrays* m = &hm.c
    cdef int f
    with nogil:
        for f in prange(hm.n_faces, num_threads=threads, schedule="static"):
            face_normal16(m, X, f, &N[3 * f])
    return out


cdef enum:
    RING_LOCAL = 64        # a vertex's faces sorted on the stack up to this many (else malloc)


cdef inline int ring_faces(const HEArrays* m, int v, int* out, int room) noexcept nogil:
    """The faces around vertex slot ``v`` (its one fan: the build gives every fan its own
    slot), the first ``room`` of them into ``out``; returns their number."""
    cdef int start = m.v_he[v]
    cdef int h = start
    cdef int k = 0
    while True:
        if k < room:
            out[k] = h // 3
        k += 1
        h = he_ring_next(m, h)
        if h < 0 or h == start:
            return k


cdef inline void face_plane(const HEArrays* m, Rows P, int f, double* pl) noexcept nogil:
    """``pl[0:5]`` = the plane of face slot ``f`` as the serial scatter of vertex_quadrics
    computes it: unit normal nx ny nz, offset d, then the length of the cross product
    (twice the area; <= 0 for a face that adds nothing, 0 for a dead one, the plane then
    unset)."""
    cdef double nrm[3]
    cdef double length
    cdef int i
    cdef int a = m.corner[3 * f]
    pl[4] = 0.0
    if not m.face_alive[f]:
        return
    length = face_cross(P, a, m.corner[3 * f + 1], m.corner[3 * f + 2], nrm)
    pl[4] = length
    if length <= 0.0:
        return
    for i in range(3):
        nrm[i] /= length
        pl[i] = nrm[i]
    pl[3] = -(nrm[0] * P.p[P.s * a] + nrm[1] * P.p[P.s * a + 1] + nrm[2] * P.p[P.s * a + 2])


cdef inline void add_face_plane(double* q, const double* pl) noexcept nogil:
    """Add the plane ``pl`` (from :func:`face_plane`) to the quadric ``q`` weighted by its
    face's area, as the serial scatter does (nothing for a face of no area)."""
    cdef double area
    if pl[4] <= 0.0:
        return
    area = 0.5 * pl[4]
    add_plane(q, pl[0], pl[1], pl[2], pl[3], area)
    q[10] += area


cdef int ring_owner(const HEArrays* m, int v, int chunk) noexcept nogil:
    """Which run of ``chunk`` face slots holds every face around vertex slot ``v``: its
    index, -1 when they are in several runs, -2 when ``v`` has no face."""
    cdef int start, h, f, lo, hi
    if m.v_he[v] < 0 or not m.vertex_alive[v]:
        return -2
    start = m.v_he[v]
    h = start
    lo = hi = h // 3
    while True:
        f = h // 3
        if f < lo:
            lo = f
        if f > hi:
            hi = f
        h = he_ring_next(m, h)
        if h < 0 or h == start:
            break
    return lo // chunk if lo // chunk == hi // chunk else -1


cdef void gather_quadric(const HEArrays* m, Rows P, int v, double* q) noexcept nogil:
    """Add to ``q`` (zero) the planes of the faces around vertex slot ``v`` in increasing
    face order, the order of the serial scatter (the same sums bit for bit); each face's
    plane is computed here."""
    cdef int local[RING_LOCAL]
    cdef int* faces = local
    cdef int i, k
    cdef double pl[5]
    k = ring_faces(m, v, local, RING_LOCAL)
    if k > RING_LOCAL:
        faces = <int*>malloc(k * sizeof(int))
        if faces == NULL:
            # no memory for a huge fan (k ints): NaN marks the row rather than a wrong sum
            for i in range(QSIZE):
                q[i] = NAN
            return
        ring_faces(m, v, faces, k)
    insertion_sort(faces, k)
    for i in range(k):
        face_plane(m, P, faces[i], pl)
        add_face_plane(q, pl)
    if faces != local:
        free(faces)


cdef inline void plane_normal16(const double* pl, short* N) noexcept nogil:
    """``N[0:3]`` from a face's plane (:func:`face_plane`): its unit normal scaled by 32767
    and rounded, the bits ``face_normal16`` gives (the same ``nrm / length``); left alone
    for a face of no area (or a dead one)."""
    cdef int i
    if pl[4] > 0.0:
        for i in range(3):
            N[i] = <short>(pl[i] * 32767.0 + (0.5 if pl[i] >= 0 else -0.5))


cdef void scatter_run(const HEArrays* m, Rows P, const int* owner, int t, int chunk, int n_faces, double* Q,
                      Py_ssize_t stride, short* N) noexcept nogil:
    """Scatter the planes of the ``t``-th run of ``chunk`` face slots, in face order, to
    their corners that run ``t`` owns (``owner``: every face of the vertex is in it); the
    quadric rows are ``stride`` doubles apart in ``Q``.  ``N`` (or NULL): the run's int16
    face normals (:func:`plane_normal16`)."""
    cdef int f, i, v
    cdef int end = (t + 1) * chunk if (t + 1) * chunk < n_faces else n_faces
    cdef double pl[5]
    for f in range(t * chunk, end):
        face_plane(m, P, f, pl)
        if N != NULL:
            plane_normal16(pl, &N[3 * f])
        if pl[4] <= 0.0:
            continue
        for i in range(3):
            v = m.corner[3 * f + i]
            if owner[v] == t:
                add_face_plane(&Q[stride * v], pl)


def vertex_quadrics(HalfEdgeMesh hm, positions, double boundary_weight=0.0, out=None, int threads=1,
                    normals=None):
    """(n, 11) per-vertex quadrics: a11 a12 a13 a22 a23 a33 b1 b2 b3 c w (written into the
    first 11 columns of ``out`` when given, e.g. an (n, 14) EdgeCollapser row array).

    Each face adds its plane weighted by its area (Garland-Heckbert); ``w`` sums the areas.
    With ``boundary_weight > 0`` every boundary edge adds, to both ends, the plane through
    the edge perpendicular to its face, weighted by ``boundary_weight * length^2`` (a
    length^2 weight keeps the constraint scale-invariant, like the area weight of faces).

    ``threads``: OpenMP threads (from PARALLEL_MIN_VERTICES vertex slots).  One thread
    scatters each face's plane to its corners in face order.  With T threads the face
    slots are cut into T runs and each thread scatters one run, in face order, to the
    vertices whose faces all lie in it (most of them when faces are laid out along the
    surface); the few others gather their faces' planes in face order (a 1-ring walk,
    sorted).  Each vertex's sum is the serial scatter's, bit for bit, for 4 bytes a vertex
    of scratch.

    ``normals``: a (3 m,) int16 array that gets each face's unit normal scaled by 32767
    and rounded, as ``face_normal16`` computes it (the collapser's input normals), from
    the plane computed here anyway; a degenerate face's entries are left alone.
    """
    positions = readable_positions(positions)
    cdef const double[:, :] P = positions
    if P.shape[0] != hm.n_vertices or P.shape[1] != 3:
        raise ValueError(f"positions must have shape ({hm.n_vertices}, 3)")
    if threads < 1 or hm.n_vertices < PARALLEL_MIN_VERTICES:
        threads = 1
    if out is None:
        out = np.zeros((hm.n_vertices, QSIZE), dtype=np.float64)
    elif (not isinstance(out, np.ndarray) or out.dtype != np.float64 or out.ndim != 2
          or out.shape[0] != hm.n_vertices or out.shape[1] < QSIZE or not out.flags.c_contiguous):
        raise ValueError(f"out must be a C-contiguous float64 array of shape ({hm.n_vertices}, >= {QSIZE})")
    cdef double[:, ::1] Q = out
    cdef short[::1] N16
    cdef short* N = NULL
    if normals is not None:
        N16 = normals
        if N16.shape[0] != 3 * hm.n_faces:
            raise ValueError(f"normals must have shape ({3 * hm.n_faces},)")
        N = &N16[0] if hm.n_faces else NULL
    cdef int[::1] owner
    cdef Rows X = rows_of(P)
    cdef const HEArrays* m = &hm.c
    cdef int f, i, v, t, chunk
    cdef double pl[5]
    if threads == 1:
        with nogil:
            # (a loop, not ``out[:, :QSIZE] = 0.0``: numpy's strided fill took ~8 instructions
            # a value; the threaded path zeroes each row as it goes)
            for v in range(hm.n_vertices):
                for i in range(QSIZE):
                    Q[v, i] = 0.0
            for f in range(hm.n_faces):
                face_plane(m, X, f, pl)
                if N != NULL:
                    plane_normal16(pl, &N[3 * f])
                for i in range(3):
                    add_face_plane(&Q[m.corner[3 * f + i], 0], pl)
    elif hm.n_faces:
        chunk = (hm.n_faces + threads - 1) // threads
        owner = np.empty(hm.n_vertices, dtype=np.intc)
        with nogil:
            for v in prange(hm.n_vertices, num_threads=threads, schedule="static"):
                for i in range(QSIZE):
                    Q[v, i] = 0.0
                owner[v] = ring_owner(m, v, chunk)
            for t in prange(threads, num_threads=threads, schedule="static", chunksize=1):
                scatter_run(m, X, &owner[0], t, chunk, hm.n_faces, &Q[0, 0], Q.shape[1], N)
            for v in prange(hm.n_vertices, num_threads=threads, schedule="dynamic", chunksize=4096):
                if owner[v] == -1:
                    gather_quadric(m, X, v, &Q[v, 0])
    else:
        out[:, :QSIZE] = 0.0
    if boundary_weight > 0.0:
        add_boundary_planes(hm, positions, boundary_weight, out)
    return out


def add_boundary_planes(HalfEdgeMesh hm, positions, double weight, out):
    """Add to ``out`` (n, >= 10) float64 quadrics, for every boundary edge and to both its
    ends, the plane through the edge perpendicular to its face, weighted by
    ``weight * length^2`` (a length^2 weight keeps the constraint scale-invariant, like the
    area weight of faces)."""
    cdef const double[:, :] P = readable_positions(positions)
    cdef double[:, ::1] Q = out
    if P.shape[0] != hm.n_vertices or Q.shape[0] != hm.n_vertices or Q.shape[1] < 10:
        raise ValueError(f"positions and out must have {hm.n_vertices} rows (out >= 10 columns)")
    cdef Rows X = rows_of(P)
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
            length = face_cross(X, hm.corner[3 * f], hm.corner[3 * f + 1], hm.corner[3 * f + 2], nrm)
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


cdef class AttributeQuadrics:
    """Per-vertex quadrics over [position, attributes] (Hoppe's appearance-preserving
    quadrics), packed (n, D(D+1)/2 + D + 1), with the attribute ``columns`` they span; and
    per vertex the clamp box of those channels.  ``gq`` None: none (``dim`` 0).  The quadric
    array is used in place when C-contiguous float64."""

    def __init__(self, HalfEdgeMesh hm, attributes, gq=None, columns=None):
        cdef int n = hm.n_vertices
        self.dim = 0
        self.size = 0
        self.gq = np.zeros((1, 1))
        self.GQ = NULL
        self.col = np.zeros(1, dtype=np.intc)
        self.box = np.zeros((1, 1))
        if gq is None:
            return
        cdef double[:, ::1] attr = attributes
        cdef int n_attr = attr.shape[1]
        cols = np.ascontiguousarray(columns, dtype=np.intc).reshape(-1)
        D = 3 + cols.shape[0]
        if D > GMAX_D:
            raise ValueError(f"quadrics over attributes support at most {GMAX_D - 3} attribute channels")
        if cols.shape[0] == 0:
            raise ValueError("attribute_columns must name at least one attribute column")
        if cols.min() < 0 or cols.max() >= n_attr:
            raise ValueError(f"attribute_columns must be in 0..{n_attr - 1}")
        arr = np.ascontiguousarray(gq, dtype=np.float64)
        S = D * (D + 1) // 2 + D + 1
        if arr.shape != (n, S):
            raise ValueError(f"attribute_quadrics must have shape ({n}, {S}) for {D - 3} attribute channels")
        self.gq = arr
        self.GQ = &self.gq[0, 0] if n else NULL
        self.col = cols
        # the clamp box of a vertex: per channel, the range of the values on the input
        # faces around it -- the faces its quadric is made of (a vertex placed a little
        # outside its own neighbours keeps the linear extrapolation the faces allow)
        vals = np.asarray(attr)[:, cols]
        self.box = np.ascontiguousarray(np.concatenate([vals, vals], axis=1))
        cdef double[:, ::1] box = self.box
        cdef int[::1] gc = self.col
        cdef int nch = cols.shape[0], f, i, j, ch, a, b
        cdef double x
        with nogil:
            for f in range(hm.n_faces):
                if not hm.c.face_alive[f]:
                    continue
                for i in range(3):
                    a = hm.c.corner[3 * f + i]
                    for j in range(3):
                        b = hm.c.corner[3 * f + j]
                        for ch in range(nch):
                            x = attr[b, gc[ch]]
                            if x < box[a, ch]:
                                box[a, ch] = x
                            if x > box[a, nch + ch]:
                                box[a, nch + ch] = x
        self.dim = D
        self.size = S

    cdef void marginal(self, int u, int v, double* q) noexcept nogil:
        """Sum the attribute quadrics of u and v and write into q[0..9] their marginal in
        x: min over the attributes a of Q(x, a), itself a 3D quadric (Schur complement)."""
        cdef double g[GMAX_S]
        cdef int i, gs = self.size
        for i in range(gs):
            g[i] = self.GQ[gs * u + i] + self.GQ[gs * v + i]
        gq_marginal(g, self.dim, q, NULL, NULL)

    cdef void marginal3(self, int a, int b, int c, double* q) noexcept nogil:
        """``marginal`` for the summed attribute quadrics of a face's three corners."""
        cdef double g[GMAX_S]
        cdef int i, gs = self.size
        for i in range(gs):
            g[i] = (self.GQ[gs * a + i] + self.GQ[gs * b + i]) + self.GQ[gs * c + i]
        gq_marginal(g, self.dim, q, NULL, NULL)

    cdef void commit(self, int r, int k, const double* p, double* A, int n_attr,
                     bint keep_attributes) noexcept nogil:
        """Add the attribute quadric of r to k's and give k (row k of the attributes ``A``,
        ``n_attr`` wide) the attribute values that minimise it at the new position (where
        that is determined; else the interpolated values stay), each channel clamped to the
        range of the input values on the faces k now stands for (``box``).  The minimum of a
        sum of quadrics is no convex combination: unclamped, it can extrapolate (colours a
        few percent outside anything in the input).  ``keep_attributes``: k's attributes
        stay as they are (a seam vertex keeps its side's chart at the seam)."""
        cdef double a[GMAX_D]
        cdef double q3[QSIZE]
        cdef double lo, hi
        cdef int i, gs = self.size, m = self.dim - 3
        for i in range(gs):
            self.GQ[gs * k + i] += self.GQ[gs * r + i]
        for i in range(m):
            if self.box[r, i] < self.box[k, i]:
                self.box[k, i] = self.box[r, i]
            if self.box[r, m + i] > self.box[k, m + i]:
                self.box[k, m + i] = self.box[r, m + i]
        if keep_attributes:
            return
        if gq_marginal(&self.GQ[gs * k], self.dim, q3, p, a):
            for i in range(m):
                lo = self.box[k, i]
                hi = self.box[k, m + i]
                A[n_attr * k + self.col[i]] = lo if a[i] < lo else (hi if a[i] > hi else a[i])
