# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""The native kernel of the ``volume`` metric (Chuon & Guha, *Volume Cost Based Mesh
Simplification*): vertex removal ranked by vol(V) = angle(V) * ht(V)^3.

For a vertex V with link W_0 .. W_{k-1} (removal.pxd's order), u_i = W_i - V and
U_i = u_i / |u_i|:

* **Hyperbolic** (Definition 1): V lies in the interior of the convex hull of the W_i.  V is
  *not* hyperbolic iff some direction d != 0 has d . u_i >= 0 for every i (a closed
  half-space through V holds every neighbour).  The set of such d is a polyhedral cone; if
  it is pointed, its extreme rays are +-(U_i x U_j) for pairs (i, j) tight on it, and if it
  is not pointed every U_i lies in one plane through V, whose normal is then +-(U_i x U_j)
  for any non-parallel pair.  So it suffices to try the 2 k (k - 1) / 2 directions
  +-(U_i x U_j) (the non-parallel pairs): a direction is feasible when min_l d . U_l >=
  -tolerance (unit vectors: the tolerance is an angle in radians, scale-free).  No feasible
  direction: hyperbolic (vetoed, never removed; gate NaN).
  Fast path first: the star's mean normal N (either sense) with min_l N . U_l > tolerance
  separates V strictly (non-hyperbolic, pole N).
* **The pole** d: N on the fast path; else the normalised sum of the feasible directions, a
  point inside the cone when the cone has an interior (the sum of its extreme rays); if that
  fails (the cone is a half-plane or a line) the feasible direction with the largest
  min_l d . U_l; coplanar neighbours: their plane's normal.  Every U_i lies in the closed
  hemisphere around d.
* **angle(V)** (Definition 2): min_l d . U_l > tolerance means a plane separates V from the
  hull (the paper's main case); the radial projection of the link onto that plane is a
  polygon whose triangles subtend the same solid angles as the triangles (d, U_i, U_{i+1})
  (Van Oosterom-Strackee's formula is invariant under positive scaling of each vector), so

      angle(V) = | sum_i Omega(d, U_i, U_{i+1}) |,
      Omega(a, b, c) = 2 atan2(a . (b x c), 1 + a.b + a.c + b.c)   (unit vectors)

  -- a signed fan, exact for non-convex simple polygons too (a folded, self-overlapping
  link can sum past 2 pi: the angle is capped at 2 pi).  When V lies on the hull
  (min_l d . U_l within the tolerance of 0) the same fan from the pole gives 2 pi for
  coplanar neighbours (the paper's value and its Note 1) and the wedge's solid angle 2
  alpha for a straight crease of opening alpha (Note 1 overlooks that case; see
  docs/metrics/volume.md).
* **ht(V)** (Definition 3): the distance of V to the least-squares plane of the W_i (normal:
  the eigenvector of the smallest eigenvalue of their covariance, in closed form, by cyclic
  Jacobi rotations when the two smallest eigenvalues nearly coincide).  Collinear
  neighbours (no plane): the distance to their line.
* **vol(V)** = angle * ht^3 (Definition 4): ``Removal.cost``.  ``Removal.gate`` = angle (the
  driver's median filter), ``Removal.error`` = ht.
* **Re-triangulation** (section III.D): the fan from the nearer end of the line through two
  link vertices closest to V (``closest_line_apex`` / ``fan_from``): a half-edge collapse of
  V into that neighbour.  ``fallback`` (lodkit's addition): if a triangle of that fan is at
  90 degrees or more from the star's mean normal (the driver would refuse it), the apexes of
  the next-closest lines are tried in order and the first fan that does not fold is taken.
* **Boundary vertices** (open star, link a chain W_0 .. W_{k-1}): the same hull test; angle =
  min(2 pi, 2 | sum_{i < k-1} Omega(d, U_i, U_{i+1}) |), the fan over the star's own faces
  doubled (a boundary vertex is half a star: a flat one on a straight boundary gets 2 pi like
  a flat interior vertex, a flat corner of planar angle theta gets 2 theta); ht = the larger
  of the plane distance and V's distance to the line W_0 W_{k-1} (the new boundary edge), so
  a boundary vertex is free only when it is flat *and* on a straight boundary.  Stars with
  fewer than 3 link vertices are not removed.

lodkit's readings (issue 17; each an option whose default follows ``accumulate``, so that
``accumulate="off"`` is the paper throughout): ``accumulate="points"`` carries the removed
vertices and the input faces' centroids on the face slots nearest them (removal_star.pxd)
and the error is their largest distance to the new patch, floored by min(ht, V's distance to
the closest line); ``hyperbolic="remove"`` measures a hyperbolic star about its mean normal
(``measure_saddle``) instead of vetoing it; ``triangulation="nearest"`` takes of the
paper's fan and the hole's least-volume triangulation the one nearer V
(retriangulate.least_distance_patch); ``median=None`` is not gated.
"""
import numpy as np

from .retriangulate import auto_mode, carried_points

from libc.math cimport sqrt, fabs, atan2, acos, cos, NAN, INFINITY, M_PI

from lodkit.kernel cimport (KernelMesh, KERNEL_OK, KERNEL_VETO, KERNEL_ERROR, VERTEX_FIXED)
from lodkit.removal cimport (RemovalKernel, Star, Removal, MAX_VALENCE, REMOVAL_API_VERSION)
from .retriangulate cimport closest_line_apex, fan_from, least_distance_patch
from .removal_star cimport star_on_points, patch_distance, carried_distance, carry_points
from .vec3 cimport dot3, cross3

# classification codes
cdef enum:
    C_DEGENERATE = -1   # a neighbour at V, or all neighbours on one line through V: vetoed
    C_NON_HYPERBOLIC = 0
    C_HYPERBOLIC = 1

DEGENERATE = C_DEGENERATE
NON_HYPERBOLIC = C_NON_HYPERBOLIC
HYPERBOLIC = C_HYPERBOLIC

cdef double PARALLEL = 1e-12        # |U_i x U_j| below this: the pair spans no plane


cdef inline double solid_angle_unit(const double* a, const double* b, const double* c) noexcept nogil:
    """Signed solid angle of the triangle (a, b, c) of unit vectors seen from the origin
    (Van Oosterom-Strackee, with atan2 so angles above pi come out right)."""
    cdef double bc[3]
    cross3(b, c, bc)
    return 2.0 * atan2(dot3(a, bc), 1.0 + dot3(a, b) + dot3(a, c) + dot3(b, c))


cdef double solid_angle_vec(const double* a, const double* b, const double* c) noexcept nogil:
    """Signed solid angle of the triangle (a, b, c) seen from the origin, any lengths."""
    cdef double bc[3]
    cdef double la = sqrt(dot3(a, a)), lb = sqrt(dot3(b, b)), lc = sqrt(dot3(c, c))
    cross3(b, c, bc)
    return 2.0 * atan2(dot3(a, bc), la * lb * lc + dot3(a, b) * lc + dot3(a, c) * lb + dot3(b, c) * la)


cdef inline void _tri_cross(const double* a, const double* b, const double* c, double* x) noexcept nogil:
    """(b - a) x (c - a) into ``x``."""
    cdef double e[3]
    cdef double f[3]
    cdef int i
    for i in range(3):
        e[i] = b[i] - a[i]
        f[i] = c[i] - a[i]
    cross3(e, f, x)


cdef double tet_ball_radius(const double* A, const double* B, const double* C, const double* D) noexcept nogil:
    """The distance of the origin to the nearest face plane of the tetrahedron A B C D if
    the origin lies strictly inside it, else -1.  Its barycentric coordinates are the
    signed volumes of the tetrahedra with the origin in place of one corner (all of one
    sign: inside); each over its face's area vector is the distance to that face."""
    cdef double x[4][3]
    cdef double lam[4]
    cdef double r = INFINITY
    cdef int i
    _tri_cross(B, C, D, x[0])
    _tri_cross(A, D, C, x[1])
    _tri_cross(A, B, D, x[2])
    _tri_cross(A, C, B, x[3])
    lam[0] = -dot3(B, x[0])             # -det(B, C, D): the four share the factor -1
    lam[1] = -dot3(A, x[1])
    lam[2] = -dot3(A, x[2])
    lam[3] = -dot3(A, x[3])
    if not ((lam[0] > 0.0 and lam[1] > 0.0 and lam[2] > 0.0 and lam[3] > 0.0)
            or (lam[0] < 0.0 and lam[1] < 0.0 and lam[2] < 0.0 and lam[3] < 0.0)):
        return -1.0                     # the origin is not strictly inside
    for i in range(4):
        r = min(r, fabs(lam[i]) / sqrt(dot3(x[i], x[i])))
    return r


cdef bint hyperbolic_certificate(const double* U, int k, const double* N, double tol) noexcept nogil:
    """A quick sufficient test for Definition 1 before :func:`hull_pole`'s exhaustive one:
    a tetrahedron of four neighbour directions that holds the ball of radius r > tol about
    V.  Then every unit d has min_l d . U_l <= -r < -tol (the point -r d is a convex
    combination of the four), so hull_pole would refute every candidate direction and
    answer C_HYPERBOLIC: the answer is the same, at O(k) cost instead of O(k^3).  The
    candidates are a saddle's typical witnesses: A and B the highest and lowest neighbours
    along the star's mean normal ``N``, then C above and D below the plane through V, A and
    B -- the farthest pair first, then every C with the farthest D and every D with the
    farthest C (on the real meshes this finds a certificate for ~98% of the hyperbolic
    stars).  False: no certificate (hull_pole decides)."""
    cdef int l, ia = 0, ib = 0, ic = -1, id_ = -1
    cdef double t, ta = -1e300, tb = 1e300, tc = 0.0, td = 0.0
    cdef double side[MAX_VALENCE]
    cdef double ab[3]
    cdef const double* A
    cdef const double* B
    for l in range(k):
        t = dot3(N, &U[3 * l])
        if t > ta:
            ta = t
            ia = l
        if t < tb:
            tb = t
            ib = l
    if ia == ib:
        return False
    A = &U[3 * ia]
    B = &U[3 * ib]
    cross3(A, B, ab)
    for l in range(k):
        t = dot3(ab, &U[3 * l])
        side[l] = t
        if t > tc:
            tc = t
            ic = l
        elif t < td:
            td = t
            id_ = l
    if ic < 0 or id_ < 0:
        return False
    # radius > tol: every candidate of hull_pole refuted; the margin covers its rounding
    tol = tol + 1e-12
    if tet_ball_radius(A, B, &U[3 * ic], &U[3 * id_]) > tol:
        return True
    for l in range(k):
        if side[l] > 0.0 and l != ic and tet_ball_radius(A, B, &U[3 * l], &U[3 * id_]) > tol:
            return True
    for l in range(k):
        if side[l] < 0.0 and l != id_ and tet_ball_radius(A, B, &U[3 * ic], &U[3 * l]) > tol:
            return True
    return False


cdef int hull_pole(const double* U, int k, double tol, double* d, double* margin) noexcept nogil:
    """Definition 1 on unit directions U (k x 3).  Returns C_HYPERBOLIC, C_NON_HYPERBOLIC (``d``
    the unit pole, ``margin`` = min_l d . U_l) or C_DEGENERATE (all U_i on one line).

    One pass over the neighbours serves both senses of a candidate c = U_i x U_j: +c is
    refuted by some t = c . U_l < -tol |c|, -c by some t > tol |c| (compared squared, no
    sqrt); the pass runs in branch-free blocks of 4 and stops after a block once both senses
    are refuted."""
    cdef int i, j, l, e, n_feasible = 0, spans = 0
    cdef bint neg, pos
    cdef double c[3]
    cdef double best[3]
    cdef double acc[3]
    cdef double n, m, t, tmin, tmax, thr2, inv, sign, c0, c1, c2, best_m = -1e300
    acc[0] = acc[1] = acc[2] = 0.0
    best[0] = best[1] = best[2] = 0.0
    for i in range(k):
        for j in range(i + 1, k):
            cross3(&U[3 * i], &U[3 * j], c)
            n = dot3(c, c)
            if n <= PARALLEL * PARALLEL:
                continue
            spans = 1
            thr2 = tol * tol * n
            tmin = 0.0
            tmax = 0.0
            c0 = c[0]
            c1 = c[1]
            c2 = c[2]
            l = 0
            while l < k:                # branch-free blocks of 4: min and max of c . U_l
                e = l + 4 if l + 4 < k else k
                while l < e:
                    t = c0 * U[3 * l] + c1 * U[3 * l + 1] + c2 * U[3 * l + 2]
                    tmin = t if t < tmin else tmin
                    tmax = t if t > tmax else tmax
                    l += 1
                if tmin < 0.0 and tmax > 0.0 and tmin * tmin > thr2 and tmax * tmax > thr2:
                    break               # both senses refuted
            neg = tmin < 0.0 and tmin * tmin > thr2
            pos = tmax > 0.0 and tmax * tmax > thr2
            if neg and pos:
                continue
            inv = 1.0 / sqrt(n)
            if not neg and not pos:
                # every neighbour on the plane through V normal to c: coplanar, the pole is
                # c (either sense), V on the hull
                d[0] = c[0] * inv
                d[1] = c[1] * inv
                d[2] = c[2] * inv
                margin[0] = tmin * inv
                return C_NON_HYPERBOLIC
            if not neg:                 # +c: min_l c . U_l >= -tol |c|
                sign = inv
                m = tmin * inv
            else:                       # -c
                sign = -inv
                m = -tmax * inv
            n_feasible += 1
            acc[0] += sign * c[0]
            acc[1] += sign * c[1]
            acc[2] += sign * c[2]
            if m > best_m:
                best_m = m
                best[0] = sign * c[0]
                best[1] = sign * c[1]
                best[2] = sign * c[2]
    if not spans:
        return C_DEGENERATE
    if n_feasible == 0:
        return C_HYPERBOLIC
    n = sqrt(dot3(acc, acc))
    if n > 1e-6:
        acc[0] /= n
        acc[1] /= n
        acc[2] /= n
        m = 1e300
        for l in range(k):
            m = min(m, dot3(acc, &U[3 * l]))
        if m >= best_m:
            d[0] = acc[0]
            d[1] = acc[1]
            d[2] = acc[2]
            margin[0] = m
            return C_NON_HYPERBOLIC
    d[0] = best[0]
    d[1] = best[1]
    d[2] = best[2]
    margin[0] = best_m
    return C_NON_HYPERBOLIC


cdef void jacobi3(double* A, double* vecs) noexcept nogil:
    """Diagonalise the symmetric 3x3 ``A`` (row-major, overwritten: its diagonal ends up the
    eigenvalues) by cyclic Jacobi rotations; ``vecs`` (row-major) gets the eigenvectors as
    columns."""
    cdef int _sweep, p, q, r, i
    cdef double off, scale, apq, theta, t, c, s, app, aqq, arp, arq, vip, viq
    for i in range(9):
        vecs[i] = 0.0
    vecs[0] = vecs[4] = vecs[8] = 1.0
    scale = fabs(A[0]) + fabs(A[4]) + fabs(A[8]) + fabs(A[1]) + fabs(A[2]) + fabs(A[5])
    if scale == 0.0:
        return
    for _sweep in range(50):
        off = fabs(A[1]) + fabs(A[2]) + fabs(A[5])
        if off <= 1e-15 * scale:
            return
        for p in range(2):
            for q in range(p + 1, 3):
                apq = A[3 * p + q]
                if apq == 0.0:
                    continue
                app = A[3 * p + p]
                aqq = A[3 * q + q]
                theta = (aqq - app) / (2.0 * apq)
                t = (1.0 if theta >= 0.0 else -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0))
                c = 1.0 / sqrt(t * t + 1.0)
                s = t * c
                A[3 * p + p] = app - t * apq
                A[3 * q + q] = aqq + t * apq
                A[3 * p + q] = 0.0
                A[3 * q + p] = 0.0
                r = 3 - p - q
                arp = A[3 * r + p]
                arq = A[3 * r + q]
                A[3 * r + p] = A[3 * p + r] = c * arp - s * arq
                A[3 * r + q] = A[3 * q + r] = s * arp + c * arq
                for i in range(3):
                    vip = vecs[3 * i + p]
                    viq = vecs[3 * i + q]
                    vecs[3 * i + p] = c * vip - s * viq
                    vecs[3 * i + q] = s * vip + c * viq


cdef bint smallest_eigvec(const double* A, double* n) noexcept nogil:
    """The unit eigenvector of the smallest eigenvalue of the symmetric 3x3 ``A`` (row-major)
    in closed form: the eigenvalues by the trigonometric solution of the characteristic
    cubic, the vector as the longest cross product of two rows of A - lambda I.  Returns
    False (n untouched) when that is ill-conditioned -- the two smallest eigenvalues within
    1e-6 of the spread, or a collinear / single-point set -- and Jacobi must decide."""
    cdef double p1 = A[1] * A[1] + A[2] * A[2] + A[5] * A[5]
    cdef double q = (A[0] + A[4] + A[8]) / 3.0
    cdef double b00 = A[0] - q, b11 = A[4] - q, b22 = A[8] - q
    cdef double p2 = b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * p1
    cdef double p, r, phi, lo, hi, mid, l2
    cdef double r0[3]
    cdef double r1[3]
    cdef double r2[3]
    cdef double x[3]
    cdef double y[3]
    cdef double z[3]
    cdef double nx, ny, nz
    if not p2 > 0.0:
        return False
    p = sqrt(p2 / 6.0)
    r = (b00 * (b11 * b22 - A[5] * A[5]) - A[1] * (A[1] * b22 - A[5] * A[2])
         + A[2] * (A[1] * A[5] - b11 * A[2])) / (2.0 * p * p * p)
    r = -1.0 if r < -1.0 else (1.0 if r > 1.0 else r)
    phi = acos(r) / 3.0
    hi = q + 2.0 * p * cos(phi)
    lo = q + 2.0 * p * cos(phi + 2.0 * M_PI / 3.0)
    mid = 3.0 * q - hi - lo
    if mid - lo <= 1e-6 * (hi - lo) or mid <= 1e-12 * hi:
        return False
    r0[0] = A[0] - lo
    r0[1] = A[1]
    r0[2] = A[2]
    r1[0] = A[3]
    r1[1] = A[4] - lo
    r1[2] = A[5]
    r2[0] = A[6]
    r2[1] = A[7]
    r2[2] = A[8] - lo
    cross3(r0, r1, x)
    cross3(r0, r2, y)
    cross3(r1, r2, z)
    nx = dot3(x, x)
    ny = dot3(y, y)
    nz = dot3(z, z)
    if ny > nx and ny >= nz:
        x[0] = y[0]
        x[1] = y[1]
        x[2] = y[2]
        nx = ny
    elif nz > nx:
        x[0] = z[0]
        x[1] = z[1]
        x[2] = z[2]
        nx = nz
    if not nx > 0.0:
        return False
    l2 = 1.0 / sqrt(nx)
    n[0] = x[0] * l2
    n[1] = x[1] * l2
    n[2] = x[2] * l2
    return True


cdef double plane_height(const double* u, int k) noexcept nogil:
    """Distance of the origin (V) to the least-squares plane of the points u (k x 3, relative
    to V); the distance to their line if they are collinear, to the point if k == 1."""
    cdef double c[3]
    cdef double A[9]
    cdef double E[9]
    cdef double n[3]
    cdef double x, y, z, hi, mid, t
    cdef int i, imin, imax
    c[0] = c[1] = c[2] = 0.0
    for i in range(k):
        c[0] += u[3 * i]
        c[1] += u[3 * i + 1]
        c[2] += u[3 * i + 2]
    c[0] /= k
    c[1] /= k
    c[2] /= k
    for i in range(9):
        A[i] = 0.0
    for i in range(k):
        x = u[3 * i] - c[0]
        y = u[3 * i + 1] - c[1]
        z = u[3 * i + 2] - c[2]
        A[0] += x * x
        A[1] += x * y
        A[2] += x * z
        A[4] += y * y
        A[5] += y * z
        A[8] += z * z
    A[3] = A[1]
    A[6] = A[2]
    A[7] = A[5]
    if smallest_eigvec(A, n):
        return fabs(dot3(c, n))
    jacobi3(A, E)
    imin = 0
    imax = 0
    for i in range(1, 3):
        if A[4 * i] < A[4 * imin]:
            imin = i
        if A[4 * i] > A[4 * imax]:
            imax = i
    hi = A[4 * imax]
    mid = A[0] + A[4] + A[8] - hi - A[4 * imin]
    if hi <= 0.0:
        return sqrt(dot3(c, c))                  # all neighbours at one point
    if mid <= 1e-12 * hi:
        # collinear: distance of the origin to the line through c along the main axis
        n[0] = E[imax]
        n[1] = E[3 + imax]
        n[2] = E[6 + imax]
        t = dot3(c, n)
        x = c[0] - t * n[0]
        y = c[1] - t * n[1]
        z = c[2] - t * n[2]
        return sqrt(x * x + y * y + z * z)
    n[0] = E[imin]
    n[1] = E[3 + imin]
    n[2] = E[6 + imin]
    return fabs(dot3(c, n)) / sqrt(dot3(n, n))


cdef double line_distance(const double* a, const double* b) noexcept nogil:
    """Distance of the origin to the line through a and b (|a| if they coincide)."""
    cdef double e[3]
    cdef double x[3]
    cdef double ee
    e[0] = b[0] - a[0]
    e[1] = b[1] - a[1]
    e[2] = b[2] - a[2]
    ee = dot3(e, e)
    if ee <= 0.0:
        return sqrt(dot3(a, a))
    cross3(a, e, x)
    return sqrt(dot3(x, x) / ee)


cdef struct Measure:
    int cls              # C_HYPERBOLIC, C_NON_HYPERBOLIC, C_DEGENERATE
    int on_hull          # 1: no strictly separating plane (V on the hull of its neighbours)
    double angle
    double height
    double margin        # min_l d . U_l
    double pole[3]
    double normal[3]     # the star's area vector sum_i u_i x u_{i+1} (fan_folds reuses it)


cdef int measure_star(const double* V, const double* W, int k, bint closed, double tol,
                      Measure* out) noexcept nogil:
    """Classify and measure the star of V (neighbour positions W, k x 3, in link order)."""
    cdef double u[3 * MAX_VALENCE]
    cdef double U[3 * MAX_VALENCE]
    cdef double n
    cdef int i, j
    out.angle = NAN
    out.height = NAN
    out.margin = NAN
    out.on_hull = 0
    out.pole[0] = out.pole[1] = out.pole[2] = 0.0
    for i in range(k):
        for j in range(3):
            u[3 * i + j] = W[3 * i + j] - V[j]
        n = sqrt(dot3(&u[3 * i], &u[3 * i]))
        if not n > 0.0:
            out.cls = C_DEGENERATE
            return C_DEGENERATE
        for j in range(3):
            U[3 * i + j] = u[3 * i + j] / n
    # fast path: the star's mean normal (either sense) often separates V strictly; any
    # strictly separating direction gives the same angle, so it can serve as the pole
    cdef double N[3]
    cdef double c[3]
    cdef double m, sign
    cdef int s
    N[0] = N[1] = N[2] = 0.0
    for i in range(k if closed else k - 1):
        j = i + 1 if i + 1 < k else 0
        cross3(&u[3 * i], &u[3 * j], c)
        N[0] += c[0]
        N[1] += c[1]
        N[2] += c[2]
    out.normal[0] = N[0]
    out.normal[1] = N[1]
    out.normal[2] = N[2]
    n = sqrt(dot3(N, N))
    out.cls = -2
    if n > 0.0:
        for s in range(2):
            sign = (1.0 if s == 0 else -1.0) / n
            m = 1e300
            for i in range(k):
                m = min(m, sign * dot3(N, &U[3 * i]))
            if m > tol:
                out.pole[0] = sign * N[0]
                out.pole[1] = sign * N[1]
                out.pole[2] = sign * N[2]
                out.margin = m
                out.cls = C_NON_HYPERBOLIC
                break
    if out.cls != C_NON_HYPERBOLIC:
        if n > 0.0 and hyperbolic_certificate(U, k, N, tol):
            out.cls = C_HYPERBOLIC
            return C_HYPERBOLIC
        out.cls = hull_pole(U, k, tol, out.pole, &out.margin)
        if out.cls != C_NON_HYPERBOLIC:
            return out.cls
    out.on_hull = out.margin <= tol
    angle_and_height(u, U, k, closed, out)
    return C_NON_HYPERBOLIC


cdef void angle_and_height(const double* u, const double* U, int k, bint closed, Measure* out) noexcept nogil:
    """angle(V): the fan of solid angles about ``out.pole`` (doubled for an open star,
    capped at 2 pi: more only for a self-overlapping, folded link), and ht(V) (an open
    star: at least the distance to the line through its two border neighbours), from the
    star's spokes ``u`` and their unit vectors ``U``."""
    cdef double total = 0.0
    cdef int i, j
    cdef int last = k if closed else k - 1
    for i in range(last):
        j = i + 1 if i + 1 < k else 0
        total += solid_angle_unit(out.pole, &U[3 * i], &U[3 * j])
    total = fabs(total)
    if not closed:
        total *= 2.0
    out.angle = min(total, 2.0 * M_PI)
    out.height = plane_height(u, k)
    if not closed:
        out.height = max(out.height, line_distance(&u[0], &u[3 * (k - 1)]))


cdef int measure_saddle(const double* V, const double* W, int k, bint closed, Measure* out) noexcept nogil:
    """lodkit's reading for a hyperbolic star that may be removed (``hyperbolic="remove"``):
    the pole is the star's mean normal, angle(V) the same signed fan of solid angles about
    it (capped at 2 pi, doubled for an open star; a saddle's is near 2 pi, so the median
    filter lets it compete as a flat vertex does), ht(V) as for any star.  Returns
    C_NON_HYPERBOLIC, or C_DEGENERATE when the star has no mean normal."""
    cdef double u[3 * MAX_VALENCE]
    cdef double U[3 * MAX_VALENCE]
    cdef double n
    cdef int i, j
    for i in range(k):
        for j in range(3):
            u[3 * i + j] = W[3 * i + j] - V[j]
        n = sqrt(dot3(&u[3 * i], &u[3 * i]))
        if not n > 0.0:
            return C_DEGENERATE
        for j in range(3):
            U[3 * i + j] = u[3 * i + j] / n
    n = sqrt(dot3(out.normal, out.normal))
    if not n > 0.0:
        return C_DEGENERATE
    for j in range(3):
        out.pole[j] = out.normal[j] / n
    out.on_hull = 0
    angle_and_height(u, U, k, closed, out)
    return C_NON_HYPERBOLIC


cdef enum:
    ACC_OFF = 0             # the paper: the cost is the star's alone
    ACC_BOUND = 1           # lodkit's default: an accumulated distance bound (module doc)
    ACC_POINTS = 2          # lodkit's default: the removed vertices themselves are carried

#: the ``accumulate`` option's values, in ACC_* order
ACCUMULATE_MODES = ("off", "bound", "points")

cdef enum:
    HYP_VETO = 0            # the paper: a hyperbolic vertex is never removed
    HYP_REMOVE = 1          # lodkit's default: it competes, costed by its real removal error

#: the ``hyperbolic`` option's values, in HYP_* order ("auto" follows ``accumulate``)
HYPERBOLIC_MODES = ("veto", "remove")

cdef enum:
    TRI_CLOSEST_LINE = 0    # the paper: the closest-line fan (with ``fallback``)
    TRI_NEAREST = 1         # lodkit's default: the patch nearest the removed vertex

#: the ``triangulation`` option's values, in TRI_* order ("auto" follows ``accumulate``)
TRIANGULATION_MODES = ("closest_line", "nearest")


cdef enum:
    MARK_NONE = 0           # removable, or not evaluated
    MARK_HYPERBOLIC = 1     # inside the convex hull of its neighbours (never removed)
    MARK_DEGENERATE = 2     # a neighbour at V or every neighbour on a line through V
    MARK_VALENCE = 3        # fewer than 3 or more than MAX_VALENCE link vertices


cdef double closest_line_distance(const double* W, int k, const double* x) noexcept nogil:
    """The distance of x to the nearest line through two of the points W (k x 3)."""
    cdef int i, j, t
    cdef double e[3]
    cdef double w[3]
    cdef double c[3]
    cdef double ee, d, best = INFINITY
    for i in range(k):
        for j in range(i + 1, k):
            for t in range(3):
                e[t] = W[3 * j + t] - W[3 * i + t]
                w[t] = x[t] - W[3 * i + t]
            ee = dot3(e, e)
            if not ee > 0.0:
                continue
            cross3(w, e, c)
            d = dot3(c, c) / ee
            if d < best:
                best = d
    return sqrt(best) if best < INFINITY else 0.0


cdef bint fan_folds(const double* W, const double* N, const int* tri, int n_tris) noexcept nogil:
    """True if a triangle of the fan ``tri`` (indices into W) has a normal at or beyond 90
    degrees from the star's area vector ``N`` (Measure.normal; or is degenerate): the fold
    the driver refuses with its default max_normal_angle."""
    cdef double a[3]
    cdef double b[3]
    cdef double c[3]
    cdef int i, t
    for t in range(n_tris):
        for i in range(3):
            a[i] = W[3 * tri[3 * t + 1] + i] - W[3 * tri[3 * t] + i]
            b[i] = W[3 * tri[3 * t + 2] + i] - W[3 * tri[3 * t] + i]
        cross3(a, b, c)
        if not dot3(c, N) > 0.0:
            return True
    return False


cdef class VolumeKernel(RemovalKernel):
    """vol(V) = angle(V) * ht(V)^3, gate angle(V), error ht(V); hyperbolic vertices vetoed;
    the closest-line fan re-triangulates (see the module doc)."""

    api_version = REMOVAL_API_VERSION
    star_local = True                   # evaluate() depends on the star alone (vremove caches it)

    cdef readonly double tolerance
    cdef readonly bint fallback         # try the next-closest lines' apexes if the fan folds
    cdef unsigned char[::1] _state      # per vertex slot: MARK_* at its last evaluation
    cdef unsigned char* state
    cdef int n_state
    cdef long counts[4]                 # live vertex slots per MARK_* code
    cdef readonly long n_fallbacks      # evaluations that took another apex than the closest line's
    # accumulation (lodkit's addition, see the module doc): ACC_* code and the distance
    # bound each vertex slot carries from the removals around it
    cdef readonly int accumulate_code
    cdef double[::1] _acc
    cdef double* acc
    cdef int[::1] _head                 # accumulate="points": removal_star's lists
    cdef int[::1] _nxt
    cdef double[::1] _cent              # the input faces' centroids (carried points)
    cdef int _nv
    cdef readonly int hyperbolic_code   # HYP_*
    cdef readonly int triangulation_code  # TRI_*
    cdef double[::1] _dp_cost           # least_distance_patch scratch (MAX_VALENCE^2)
    cdef int[::1] _dp_split

    def __cinit__(self):
        self.gated = True
        self.tolerance = 1e-9
        self.fallback = True
        self.state = NULL
        self.n_state = 0
        self.counts[0] = self.counts[1] = self.counts[2] = self.counts[3] = 0
        self.n_fallbacks = 0
        self.accumulate_code = ACC_OFF
        self.acc = NULL
        self.hyperbolic_code = HYP_VETO
        self.triangulation_code = TRI_CLOSEST_LINE
        self._dp_cost = np.zeros(MAX_VALENCE * MAX_VALENCE)
        self._dp_split = np.zeros(MAX_VALENCE * MAX_VALENCE, dtype=np.int32)

    def prepare(self, ctx, options):
        """Options: ``median`` (bool, default True: the paper's median filter, i.e. the
        kernel is gated), ``tolerance`` (radians, default 1e-9) and ``fallback`` (bool,
        default True)."""
        acc = options.get("accumulate", "points")
        med = options.get("median", None)
        self.gated = (acc == "off") if med is None else bool(med)
        tol = float(options.get("tolerance", 1e-9))
        if not (tol >= 0.0 and tol < 0.1):
            raise ValueError(f"tolerance must be in [0, 0.1), got {tol!r}")
        self.tolerance = tol
        self.fallback = bool(options.get("fallback", True))
        acc = options.get("accumulate", "points")
        if acc not in ACCUMULATE_MODES:
            raise ValueError(f"accumulate must be one of {ACCUMULATE_MODES}, got {acc!r}")
        self.accumulate_code = ACCUMULATE_MODES.index(acc)
        # lodkit's readings follow accumulate unless set: "off" is the paper throughout
        self.hyperbolic_code = auto_mode("hyperbolic", options.get("hyperbolic", "auto"), HYPERBOLIC_MODES,
                                         "veto", "remove", acc)
        self.triangulation_code = auto_mode("triangulation", options.get("triangulation", "auto"),
                                            TRIANGULATION_MODES, "closest_line", "nearest", acc)
        n = int(ctx.n_vertices) if ctx is not None else int(options.get("n_vertices", 0))
        self._state = np.zeros(max(n, 1), dtype=np.uint8)
        self.state = &self._state[0]
        self._acc = np.zeros(max(n, 1))
        self.acc = &self._acc[0]
        self._nv = n
        # each face slot starts with its own centroid (point n + f)
        self._cent, self._head, self._nxt = carried_points(ctx, n)
        self.n_state = n
        self.counts[0] = n
        self.counts[1] = self.counts[2] = self.counts[3] = 0
        self.n_fallbacks = 0

    cdef inline void _mark(self, int v, unsigned char code) noexcept nogil:
        if 0 <= v < self.n_state and self.state[v] != code:
            self.counts[self.state[v]] -= 1
            self.counts[code] += 1
            self.state[v] = code

    @property
    def n_hyperbolic(self):
        """Live vertex slots that were hyperbolic at their last evaluation."""
        return int(self.counts[MARK_HYPERBOLIC])

    @property
    def n_degenerate(self):
        """Live vertex slots vetoed at their last evaluation as degenerate stars."""
        return int(self.counts[MARK_DEGENERATE])

    cdef int evaluate(self, const Star* s, Removal* r) noexcept nogil:
        cdef const KernelMesh* m = s.mesh
        cdef double W[3 * MAX_VALENCE]
        cdef double key[MAX_VALENCE]
        cdef int order[MAX_VALENCE]
        cdef int cand[3 * MAX_VALENCE]
        cdef const double* p
        cdef const double* a
        cdef const double* b
        cdef double e[3]
        cdef double w[3]
        cdef double c[3]
        cdef double ee, dist, da, db, ht
        cdef Measure ms
        cdef int i, j, t, n, apex, cls, near
        r.gate = NAN
        if m == NULL:
            return self.fail(b"volume: evaluate() got a star without a mesh")
        if s.k < 3 or s.k > MAX_VALENCE:
            self._mark(s.v, MARK_VALENCE)
            return KERNEL_VETO
        if m.flags != NULL and (m.flags[s.v] & VERTEX_FIXED):
            self._mark(s.v, MARK_NONE)
            return KERNEL_VETO
        for i in range(s.k):
            p = &m.positions[m.stride * s.link[i]]
            for j in range(3):
                W[3 * i + j] = p[j]
        p = &m.positions[m.stride * s.v]
        cls = measure_star(p, W, s.k, s.closed, self.tolerance, &ms)
        if cls == C_HYPERBOLIC:
            if self.hyperbolic_code == HYP_VETO:
                self._mark(s.v, MARK_HYPERBOLIC)
                return KERNEL_VETO
            # lodkit's reading: measured about the mean normal, costed below by what its
            # removal really moves the surface by
            cls = measure_saddle(p, W, s.k, s.closed, &ms)
            self._mark(s.v, MARK_HYPERBOLIC if cls == C_NON_HYPERBOLIC else MARK_DEGENERATE)
            if cls != C_NON_HYPERBOLIC:
                return KERNEL_VETO
        elif cls == C_DEGENERATE:
            self._mark(s.v, MARK_DEGENERATE)
            return KERNEL_VETO
        else:
            self._mark(s.v, MARK_NONE)
        apex = closest_line_apex(m.positions, m.stride, s.link, s.k, p)
        if apex < 0 or apex >= s.k:
            return self.fail(b"volume: closest_line_apex found no line through two link vertices")
        r.n_tris = fan_from(apex, s.k, r.tri)
        if self.fallback and self.triangulation_code == TRI_CLOSEST_LINE and fan_folds(W, ms.normal, r.tri, r.n_tris):
            # the apexes of the next-closest lines, in order of their line's distance
            for i in range(s.k):
                key[i] = INFINITY
            for i in range(s.k):
                a = &W[3 * i]
                for j in range(i + 1, s.k):
                    b = &W[3 * j]
                    for t in range(3):
                        e[t] = b[t] - a[t]
                        w[t] = p[t] - a[t]
                    ee = dot3(e, e)
                    if not ee > 0.0:
                        continue
                    cross3(w, e, c)
                    dist = dot3(c, c) / ee
                    da = dot3(w, w)
                    db = (p[0] - b[0]) ** 2 + (p[1] - b[1]) ** 2 + (p[2] - b[2]) ** 2
                    near = j if db < da else i
                    if dist < key[near]:
                        key[near] = dist
            n = 0
            for i in range(s.k):            # insertion sort of the other apexes by key
                if i == apex:
                    continue
                j = n
                while j > 0 and key[order[j - 1]] > key[i]:
                    order[j] = order[j - 1]
                    j -= 1
                order[j] = i
                n += 1
            for i in range(n):
                fan_from(order[i], s.k, r.tri)
                if not fan_folds(W, ms.normal, r.tri, r.n_tris):
                    self.n_fallbacks += 1
                    break
            else:
                r.n_tris = fan_from(apex, s.k, r.tri)    # none fits: propose the paper's
        dist = -1.0
        if self.triangulation_code == TRI_NEAREST:
            # lodkit's addition: of the paper's fan, the least-volume triangulation and the
            # hole's least-volume triangulation, the one nearer to V (none that folds)
            if least_distance_patch(W, s.k, p, ms.normal, r.tri, r.n_tris, &dist,
                                    &self._dp_cost[0], &self._dp_split[0], cand) < 0:
                dist = -1.0
        r.gate = ms.angle
        if self.accumulate_code == ACC_BOUND:
            # lodkit's addition: the error is how far the removal moves the surface from
            # the input, bounded -- the larger of ht and V's distance to the fan that
            # replaces its star, plus the bound V carries from the removals around it
            ht = dist if dist >= 0.0 else patch_distance(m.positions, m.stride, p, s.link, r.tri, r.n_tris)
            if ms.height > ht:
                ht = ms.height
            if s.v < self.n_state:
                ht = ht + self.acc[s.v]
            r.error = ht
            r.cost = ms.angle * ht * ht * ht
        elif self.accumulate_code == ACC_POINTS and s.v < self.n_state:
            # lodkit's default: how far V and the removed vertices in its care lie from the
            # patch (a measured one-sided distance, not a bound), or ht if larger
            ht = carried_distance(m.positions, m.stride, s, r.tri, r.n_tris, &self._head[0], &self._nxt[0],
                                  &self._cent[0], self._nv)
            da = closest_line_distance(W, s.k, p)
            if min(ms.height, da) > ht:
                ht = min(ms.height, da)
            r.error = ht
            r.cost = ms.angle * ht * ht * ht
        else:
            r.error = ms.height
            r.cost = ms.angle * ms.height * ms.height * ms.height
        return KERNEL_OK

    cdef int commit(self, const Star* s, const Removal* r) noexcept nogil:
        cdef int i, w
        self._mark(s.v, MARK_NONE)       # the vertex is gone
        if self.accumulate_code == ACC_BOUND:
            # the new faces lie within r.error of the input: so do the link vertices' stars
            for i in range(s.k):
                w = s.link[i]
                if 0 <= w < self.n_state and r.error > self.acc[w]:
                    self.acc[w] = r.error
        elif self.accumulate_code == ACC_POINTS and 0 <= s.v < self.n_state:
            carry_points(s.mesh.positions, s.mesh.stride, s, &self._head[0], &self._nxt[0],
                         &self._cent[0], self._nv)
        return KERNEL_OK

    def accumulated(self):
        """(n,) float64: the distance bound each vertex slot carries from the removals
        around it (normalised units; zeros with ``accumulate="off"``)."""
        return np.asarray(self._acc[:self.n_state]).copy()

    def hyperbolic_mask(self):
        """(n,) bool: the vertex slots hyperbolic at their last evaluation (not removed)."""
        return np.asarray(self._state[:self.n_state]) == MARK_HYPERBOLIC

    cpdef str veto_note(self):
        """Why the kernel holds vertices back now, in words (for a run's stop_detail)."""
        h, d, v = self.counts[MARK_HYPERBOLIC], self.counts[MARK_DEGENERATE], self.counts[MARK_VALENCE]
        parts = []
        if h and self.hyperbolic_code == HYP_VETO:
            parts.append(f"{h} hyperbolic (inside the convex hull of their neighbours: the volume "
                         f"metric never removes them)")
        if d:
            parts.append(f"{d} with a degenerate star")
        if v:
            parts.append(f"{v} with fewer than 3 or more than {MAX_VALENCE} neighbours")
        return "kernel vetoes: " + ("; ".join(parts) if parts else "none")


# ----------------------------------------------------------------------------------------
# Python-visible helpers (tests, docs): the same nogil routines on given points

def solid_angle(a, b, c):
    """Signed solid angle at the origin of the triangle (a, b, c) (Van Oosterom-Strackee with
    atan2): positive when (a, b, c) runs counter-clockwise seen from the origin."""
    cdef double A[3]
    cdef double B[3]
    cdef double C[3]
    vecs = []
    for name, src in (("a", a), ("b", b), ("c", c)):
        arr = np.asarray(src, dtype=np.float64)
        if arr.shape != (3,) or not np.isfinite(arr).all():
            raise ValueError(f"{name} must be a finite 3-vector, got {src!r}")
        vecs.append(arr)
    for i in range(3):
        A[i] = vecs[0][i]
        B[i] = vecs[1][i]
        C[i] = vecs[2][i]
    return solid_angle_vec(A, B, C)


def hyperbolic_witness(center, neighbours, closed=True, tolerance=1e-9):
    """Did the quick certificate (:func:`hyperbolic_certificate`: a tetrahedron of
    neighbour directions holding a ball of radius > tolerance about ``center``) settle the
    star as hyperbolic?  False when measure() had to run the exhaustive test (or the fast
    path found a separating plane).  For tests: a witness must never contradict it."""
    V = np.ascontiguousarray(center, dtype=np.float64)
    W = np.ascontiguousarray(neighbours, dtype=np.float64)
    if V.shape != (3,) or W.ndim != 2 or W.shape[1] != 3 or not 3 <= W.shape[0] <= MAX_VALENCE:
        raise ValueError(f"center must be (3,) and neighbours (k, 3) with 3 <= k <= {MAX_VALENCE}")
    cdef int k = W.shape[0], i, j
    cdef double u[3 * MAX_VALENCE]
    cdef double U[3 * MAX_VALENCE]
    cdef double N[3]
    cdef double c[3]
    cdef double n
    for i in range(k):
        for j in range(3):
            u[3 * i + j] = W[i, j] - V[j]
        n = sqrt(dot3(&u[3 * i], &u[3 * i]))
        if not n > 0.0:
            return False
        for j in range(3):
            U[3 * i + j] = u[3 * i + j] / n
    N[0] = N[1] = N[2] = 0.0
    for i in range(k if closed else k - 1):
        cross3(&u[3 * i], &u[3 * ((i + 1) % k)], c)
        for j in range(3):
            N[j] += c[j]
    return bool(hyperbolic_certificate(U, k, N, float(tolerance)))


def measure(center, neighbours, closed=True, tolerance=1e-9):
    """Classify and measure the star of ``center`` with ``neighbours`` ((k, 3), in link
    order; a cycle if ``closed``, else a chain).  Returns a dict: ``class`` ("hyperbolic",
    "non_hyperbolic" or "degenerate"), ``on_hull``, ``angle``, ``height``, ``volume``,
    ``pole`` (the unit direction d) and ``margin`` (min d . U_i)."""
    V = np.ascontiguousarray(center, dtype=np.float64)
    W = np.ascontiguousarray(neighbours, dtype=np.float64)
    if V.shape != (3,) or W.ndim != 2 or W.shape[1] != 3:
        raise ValueError("center must be (3,) and neighbours (k, 3)")
    k = W.shape[0]
    if not 3 <= k <= MAX_VALENCE:
        raise ValueError(f"need 3 to {MAX_VALENCE} neighbours, got {k}")
    if not (np.isfinite(V).all() and np.isfinite(W).all()):
        raise ValueError("positions must be finite")
    cdef double[::1] v = V
    cdef double[:, ::1] w = W
    cdef Measure ms
    cdef int cls = measure_star(&v[0], &w[0, 0], k, bool(closed), float(tolerance), &ms)
    names = {C_HYPERBOLIC: "hyperbolic", C_NON_HYPERBOLIC: "non_hyperbolic", C_DEGENERATE: "degenerate"}
    return {
        "class": names[cls],
        "on_hull": bool(ms.on_hull),
        "angle": ms.angle,
        "height": ms.height,
        "volume": ms.angle * ms.height ** 3,
        "pole": np.array([ms.pole[0], ms.pole[1], ms.pole[2]]),
        "margin": ms.margin,
    }


def evaluate_star(positions, int v, link, closed=True, fixed=None, median=True, tolerance=1e-9,
                  fallback=True, accumulate="points", hyperbolic="auto", triangulation="auto"):
    """Run ``VolumeKernel.evaluate`` on one star of a point set: ``positions`` (n, 3),
    vertex ``v``, ``link`` (k,) vertex indices in link order.  Returns a dict: ``status``
    ("ok", "veto" or "error"), ``cost``, ``error``, ``gate``, ``tris`` ((k-2, 3) indices into
    ``link``, or None) and ``hyperbolic`` (the kernel's mark for v).  ``accumulate``,
    ``hyperbolic`` and ``triangulation`` as the metric's options ("auto" follows
    ``accumulate``; nothing is carried in a lone star: "bound" and "points" measure the
    larger of ht and V's distance to the patch, "off" the paper's ht)."""
    P = np.ascontiguousarray(positions, dtype=np.float64)
    L = np.ascontiguousarray(link, dtype=np.int32)
    if P.ndim != 2 or P.shape[1] != 3 or L.ndim != 1:
        raise ValueError("positions must be (n, 3) and link (k,)")
    n = P.shape[0]
    k = L.shape[0]
    if not 0 <= v < n or (k and (L.min() < 0 or L.max() >= n)):
        raise ValueError("vertex indices out of range")
    if k > MAX_VALENCE:
        raise ValueError(f"at most {MAX_VALENCE} link vertices")
    flags = np.zeros(max(n, 1), dtype=np.uint8)
    if fixed is not None:
        flags[np.asarray(fixed, dtype=np.int64)] |= VERTEX_FIXED
    cdef VolumeKernel kern = VolumeKernel()
    kern.prepare(None, {"median": median, "tolerance": tolerance, "fallback": fallback,
                        "accumulate": accumulate, "hyperbolic": hyperbolic,
                        "triangulation": triangulation, "n_vertices": n})
    cdef double[:, ::1] pv = P
    cdef unsigned char[::1] fv = flags
    cdef const int[::1] lv = L
    cdef KernelMesh km
    cdef Star s
    cdef Removal r
    cdef int i, rc
    star_on_points(&km, &s, &pv[0, 0], n, &fv[0], v, &lv[0] if k else NULL, k, bool(closed))
    if kern.accumulate_code == ACC_POINTS and 3 <= k:
        # as at the start of a run: each face of the star holds its centroid
        nfs = k if closed else k - 1
        idx = np.stack([np.full(nfs, v), L[:nfs], L[(np.arange(nfs) + 1) % k]], axis=1)
        kern._cent = np.ascontiguousarray(P[idx].mean(axis=1).reshape(-1))
        kern._head = np.arange(n, n + nfs, dtype=np.int32)
        kern._nxt = np.full(n + nfs, -1, dtype=np.int32)
        kern._nv = n
        for i in range(nfs):
            s.face[i] = i
    r.n_tris = 0
    r.cost = NAN
    r.error = NAN
    r.gate = NAN
    rc = kern.evaluate(&s, &r)
    if rc == KERNEL_ERROR:
        return {"status": "error", "message": kern.message, "cost": None, "error": None,
                "gate": None, "tris": None, "hyperbolic": kern._state[v] == MARK_HYPERBOLIC}
    if rc == KERNEL_VETO:
        return {"status": "veto", "cost": None, "error": None, "gate": r.gate, "tris": None,
                "hyperbolic": kern._state[v] == MARK_HYPERBOLIC}
    tris = np.array([[r.tri[3 * i], r.tri[3 * i + 1], r.tri[3 * i + 2]] for i in range(r.n_tris)],
                    dtype=np.int64).reshape(-1, 3)
    return {"status": "ok", "cost": r.cost, "error": r.error, "gate": r.gate, "tris": tris,
            "hyperbolic": kern._state[v] == MARK_HYPERBOLIC}
