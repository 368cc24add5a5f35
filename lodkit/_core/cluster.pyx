# cython: language_level=3
"""Vertex clustering kernels: per-cell sums, quadric placement and the representative
choices, each one pass over the faces or vertices without the GIL (lodkit.cluster drives
them; numpy does the grid keys, labels and face re-forming around them).

Quadric rows are packed as in lodkit._core.quadric.vertex_quadrics:
a11 a12 a13 a22 a23 a33 b1 b2 b3 c w  (w: summed face areas).
"""
import numpy as np

from libc.math cimport sqrt

cdef enum:
    QSIZE = 11


cdef inline int check_label(long long c, Py_ssize_t i, long long n_cells) except -1 nogil:
    """Raise ValueError unless vertex ``i``'s label ``c`` names one of the ``n_cells`` cells."""
    if c < 0 or c >= n_cells:
        with gil:
            raise ValueError(f"label {c} of vertex {i} is outside 0..{n_cells - 1}")
    return 0


cdef inline int check_corner(Py_ssize_t f, int v, Py_ssize_t n) except -1 nogil:
    """Raise ValueError unless corner ``v`` of face ``f`` is one of the ``n`` vertices."""
    if v < 0 or v >= n:
        with gil:
            raise ValueError(f"face {f} has an index outside 0..{n - 1}")
    return 0


def cell_sums(const double[:, ::1] P, const int[:, ::1] F, const long long[::1] label,
              Py_ssize_t n_cells, bint quadrics):
    """Per cell: the summed positions (k, 3) and vertex counts (k,) of its vertices, and
    (when ``quadrics``) the sum (k, 11) of the area-weighted plane quadrics of the faces
    around its vertices: each face adds its plane to the cells of its three corners."""
    cdef Py_ssize_t n = P.shape[0], m = F.shape[0]
    if label.shape[0] != n or P.shape[1] != 3 or F.shape[1] != 3:
        raise ValueError("P must be (n, 3), F (m, 3) and label (n,)")
    sums_arr = np.zeros((n_cells, 3), dtype=np.float64)
    count_arr = np.zeros(n_cells, dtype=np.float64)
    q_arr = np.zeros((n_cells if quadrics else 0, QSIZE), dtype=np.float64)
    cdef double[:, ::1] S = sums_arr
    cdef double[::1] C = count_arr
    cdef double[:, ::1] Q = q_arr
    cdef Py_ssize_t i, f, j
    cdef long long c
    cdef int a, b, d
    cdef double ux, uy, uz, vx, vy, vz, nx, ny, nz, length, area, off
    cdef double row[QSIZE]
    cdef long long cells[3]
    with nogil:
        for i in range(n):
            c = label[i]
            check_label(c, i, n_cells)
            S[c, 0] += P[i, 0]
            S[c, 1] += P[i, 1]
            S[c, 2] += P[i, 2]
            C[c] += 1.0
        if quadrics:
            for f in range(m):
                a = F[f, 0]
                b = F[f, 1]
                d = F[f, 2]
                check_corner(f, a, n)
                check_corner(f, b, n)
                check_corner(f, d, n)
                ux = P[b, 0] - P[a, 0]
                uy = P[b, 1] - P[a, 1]
                uz = P[b, 2] - P[a, 2]
                vx = P[d, 0] - P[a, 0]
                vy = P[d, 1] - P[a, 1]
                vz = P[d, 2] - P[a, 2]
                nx = uy * vz - uz * vy
                ny = uz * vx - ux * vz
                nz = ux * vy - uy * vx
                length = sqrt(nx * nx + ny * ny + nz * nz)
                if length <= 0.0:
                    continue
                area = 0.5 * length
                nx /= length
                ny /= length
                nz /= length
                off = -(nx * P[a, 0] + ny * P[a, 1] + nz * P[a, 2])
                row[0] = area * nx * nx
                row[1] = area * nx * ny
                row[2] = area * nx * nz
                row[3] = area * ny * ny
                row[4] = area * ny * nz
                row[5] = area * nz * nz
                row[6] = area * off * nx
                row[7] = area * off * ny
                row[8] = area * off * nz
                row[9] = area * off * off
                row[10] = area
                cells[0] = label[a]
                cells[1] = label[b]
                cells[2] = label[d]
                for i in range(3):
                    c = cells[i]
                    for j in range(QSIZE):
                        Q[c, j] += row[j]
    return sums_arr, count_arr, (q_arr if quadrics else None)


def place_quadric(const double[:, ::1] Q, const double[:, ::1] mean, const double[:, ::1] cell_lo,
                  double h, double regularise, int steps):
    """Per cell the minimiser of its quadric, regularised towards the centroid and clamped
    to the cell box [cell_lo, cell_lo + h], by ``steps`` steps of iterated Tikhonov:

        y_0 = 0,  y_k+1 = y_k + (A + lam I)^-1 (-b - A (mean + y_k)),  lam = regularise * trace(A) / 3

    Along an eigenvector of A with eigenvalue mu, y_k covers 1 - (lam / (mu + lam))^k of the
    way from the centroid to the minimiser: all of it (to 1e-9 in three steps at mu = trace/3)
    where A constrains the point, nothing where A is singular (a cell whose faces are one
    plane keeps the centroid's in-plane coordinates), a little where A is weak."""
    cdef Py_ssize_t k = Q.shape[0], i, j, _step
    if mean.shape[0] != k or cell_lo.shape[0] != k or Q.shape[1] < 10:
        raise ValueError("Q, mean and cell_lo must have one row per cell")
    out_arr = np.empty((k, 3), dtype=np.float64)
    cdef double[:, ::1] X = out_arr
    cdef double a11, a12, a13, a22, a23, a33, lam, r0, r1, r2, c11, c12, c13, c22, c23, c33, det
    cdef double x0, x1, x2, lo, x
    with nogil:
        for i in range(k):
            x0 = mean[i, 0]
            x1 = mean[i, 1]
            x2 = mean[i, 2]
            lam = regularise * (Q[i, 0] + Q[i, 3] + Q[i, 5]) / 3.0
            a11 = Q[i, 0] + lam
            a12 = Q[i, 1]
            a13 = Q[i, 2]
            a22 = Q[i, 3] + lam
            a23 = Q[i, 4]
            a33 = Q[i, 5] + lam
            # adjugate of the symmetric, regularised matrix
            c11 = a22 * a33 - a23 * a23
            c12 = a13 * a23 - a12 * a33
            c13 = a12 * a23 - a13 * a22
            c22 = a11 * a33 - a13 * a13
            c23 = a12 * a13 - a11 * a23
            c33 = a11 * a22 - a12 * a12
            det = a11 * c11 + a12 * c12 + a13 * c13
            if det > 0.0 and lam > 0.0:
                for _step in range(steps):
                    # r = -b - A x (with the plain A)
                    r0 = -Q[i, 6] - (Q[i, 0] * x0 + a12 * x1 + a13 * x2)
                    r1 = -Q[i, 7] - (a12 * x0 + Q[i, 3] * x1 + a23 * x2)
                    r2 = -Q[i, 8] - (a13 * x0 + a23 * x1 + Q[i, 5] * x2)
                    x0 = x0 + (c11 * r0 + c12 * r1 + c13 * r2) / det
                    x1 = x1 + (c12 * r0 + c22 * r1 + c23 * r2) / det
                    x2 = x2 + (c13 * r0 + c23 * r1 + c33 * r2) / det
            for j in range(3):
                x = x0 if j == 0 else (x1 if j == 1 else x2)
                lo = cell_lo[i, j]
                if x != x:
                    x = mean[i, j]
                if x < lo:
                    x = lo
                elif x > lo + h:
                    x = lo + h
                X[i, j] = x
    return out_arr


def quadric_errors(const double[:, ::1] Q, const double[:, ::1] X):
    """(k,) Q(x) / w per row (squared area-weighted RMS plane distance; 0 where w = 0)."""
    cdef Py_ssize_t k = Q.shape[0], i
    if X.shape[0] != k or Q.shape[1] < QSIZE:
        raise ValueError("Q must be (k, 11) and X (k, 3)")
    out_arr = np.empty(k, dtype=np.float64)
    cdef double[::1] E = out_arr
    cdef double x, y, z, e
    with nogil:
        for i in range(k):
            x = X[i, 0]
            y = X[i, 1]
            z = X[i, 2]
            e = (Q[i, 0] * x * x + 2.0 * Q[i, 1] * x * y + 2.0 * Q[i, 2] * x * z + Q[i, 3] * y * y
                 + 2.0 * Q[i, 4] * y * z + Q[i, 5] * z * z
                 + 2.0 * (Q[i, 6] * x + Q[i, 7] * y + Q[i, 8] * z) + Q[i, 9])
            E[i] = e / Q[i, 10] if Q[i, 10] > 0.0 and e > 0.0 else 0.0
    return out_arr


def most_important(const double[:, ::1] P, const int[:, ::1] F, const long long[::1] label,
                   Py_ssize_t n_cells):
    """Per cell the vertex of largest Rossignac-Borrel weight w = L * s, with L the longest
    incident edge and s = 1 - |sum_f 2 a_f n_f| / sum_f 2 a_f the spread of the incident
    face normals; ties go to the larger L, then the lower index.  Returns (k,) int64 and the
    (n,) weights."""
    cdef Py_ssize_t n = P.shape[0], m = F.shape[0], f, i, j
    if label.shape[0] != n:
        raise ValueError("label must have one entry per vertex")
    longest_arr = np.zeros(n, dtype=np.float64)
    normal_arr = np.zeros((n, 3), dtype=np.float64)
    total_arr = np.zeros(n, dtype=np.float64)
    weight_arr = np.empty(n, dtype=np.float64)
    chosen_arr = np.full(n_cells, -1, dtype=np.int64)
    cdef double[::1] L = longest_arr
    cdef double[:, ::1] N = normal_arr
    cdef double[::1] T = total_arr
    cdef double[::1] W = weight_arr
    cdef long long[::1] chosen = chosen_arr
    cdef int v[3]
    cdef double e[3]
    cdef double ux, uy, uz, vx, vy, vz, nx, ny, nz, length, s, dx, dy, dz
    cdef long long c, best
    with nogil:
        for f in range(m):
            for j in range(3):
                v[j] = F[f, j]
                check_corner(f, v[j], n)
            for j in range(3):
                dx = P[v[(j + 1) % 3], 0] - P[v[j], 0]
                dy = P[v[(j + 1) % 3], 1] - P[v[j], 1]
                dz = P[v[(j + 1) % 3], 2] - P[v[j], 2]
                e[j] = sqrt(dx * dx + dy * dy + dz * dz)     # edge j: corner j -> j + 1
            ux = P[v[1], 0] - P[v[0], 0]
            uy = P[v[1], 1] - P[v[0], 1]
            uz = P[v[1], 2] - P[v[0], 2]
            vx = P[v[2], 0] - P[v[0], 0]
            vy = P[v[2], 1] - P[v[0], 1]
            vz = P[v[2], 2] - P[v[0], 2]
            nx = uy * vz - uz * vy
            ny = uz * vx - ux * vz
            nz = ux * vy - uy * vx
            length = sqrt(nx * nx + ny * ny + nz * nz)
            for j in range(3):
                # corner j touches edges j and j - 1
                s = e[j] if e[j] > e[(j + 2) % 3] else e[(j + 2) % 3]
                if s > L[v[j]]:
                    L[v[j]] = s
                N[v[j], 0] += nx
                N[v[j], 1] += ny
                N[v[j], 2] += nz
                T[v[j]] += length
        for i in range(n):
            s = 0.0
            if T[i] > 0.0:
                s = 1.0 - sqrt(N[i, 0] * N[i, 0] + N[i, 1] * N[i, 1] + N[i, 2] * N[i, 2]) / T[i]
                if s < 0.0:
                    s = 0.0
            W[i] = L[i] * s
            c = label[i]
            check_label(c, i, n_cells)
            best = chosen[c]
            if best < 0 or W[i] > W[best] or (W[i] == W[best] and L[i] > L[best]):
                chosen[c] = i
    return chosen_arr, weight_arr


def nearest_vertex(const double[:, ::1] P, const long long[::1] label, const double[:, ::1] X):
    """Per cell (row of X) the vertex nearest X (ties: the lower index)."""
    cdef Py_ssize_t n = P.shape[0], k = X.shape[0], i
    if label.shape[0] != n:
        raise ValueError("label must have one entry per vertex")
    chosen_arr = np.full(k, -1, dtype=np.int64)
    dist_arr = np.full(k, np.inf, dtype=np.float64)
    cdef long long[::1] chosen = chosen_arr
    cdef double[::1] D = dist_arr
    cdef long long c
    cdef double dx, dy, dz, d
    with nogil:
        for i in range(n):
            c = label[i]
            check_label(c, i, k)
            dx = P[i, 0] - X[c, 0]
            dy = P[i, 1] - X[c, 1]
            dz = P[i, 2] - X[c, 2]
            d = dx * dx + dy * dy + dz * dz
            if d < D[c]:
                D[c] = d
                chosen[c] = i
    return chosen_arr
