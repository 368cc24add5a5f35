# cython: language_level=3
"""Small 3-vector helpers shared by the core's Cython modules (inlined; no module of its own)."""
from libc.math cimport sqrt


cdef inline void sub3(const double* a, const double* b, double* out) noexcept nogil:
    out[0] = a[0] - b[0]
    out[1] = a[1] - b[1]
    out[2] = a[2] - b[2]


cdef inline void cross3(const double* a, const double* b, double* out) noexcept nogil:
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


cdef inline double dot3(const double* a, const double* b) noexcept nogil:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


cdef inline double norm3(const double* a) noexcept nogil:
    return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


cdef inline bint same_point(const double* a, const double* b) noexcept nogil:
    return a[0] == b[0] and a[1] == b[1] and a[2] == b[2]


cdef inline double _sq(double x) noexcept nogil:
    return x * x


cdef inline double segment_sqdist(const double* x, const double* a, const double* b) noexcept nogil:
    cdef double ab[3]
    cdef double t = 0.0, l2 = 0.0
    cdef int i
    for i in range(3):
        ab[i] = b[i] - a[i]
        l2 += ab[i] * ab[i]
        t += (x[i] - a[i]) * ab[i]
    t = t / l2 if l2 > 0.0 else 0.0
    t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
    return _sq(x[0] - a[0] - t * ab[0]) + _sq(x[1] - a[1] - t * ab[1]) + _sq(x[2] - a[2] - t * ab[2])


cdef inline double point_triangle_sqdist(const double* x, const double* a, const double* b,
                                         const double* c) noexcept nogil:
    """Squared distance from x to the triangle abc, by the regions of its closest point
    (Ericson, Real-Time Collision Detection 5.1.5); a degenerate triangle by its edges.  The
    one copy: the error bound's certificates and the removal metrics' patch distance."""
    cdef double ab[3]
    cdef double ac[3]
    cdef double ap[3]
    cdef double bp[3]
    cdef double cp[3]
    cdef double d1, d2, d3, d4, d5, d6, va, vb, vc, v, w, denom
    cdef int i
    for i in range(3):
        ab[i] = b[i] - a[i]
        ac[i] = c[i] - a[i]
        ap[i] = x[i] - a[i]
    d1 = ab[0] * ap[0] + ab[1] * ap[1] + ab[2] * ap[2]
    d2 = ac[0] * ap[0] + ac[1] * ap[1] + ac[2] * ap[2]
    if d1 <= 0.0 and d2 <= 0.0:
        return ap[0] * ap[0] + ap[1] * ap[1] + ap[2] * ap[2]
    for i in range(3):
        bp[i] = x[i] - b[i]
    d3 = ab[0] * bp[0] + ab[1] * bp[1] + ab[2] * bp[2]
    d4 = ac[0] * bp[0] + ac[1] * bp[1] + ac[2] * bp[2]
    if d3 >= 0.0 and d4 <= d3:
        return bp[0] * bp[0] + bp[1] * bp[1] + bp[2] * bp[2]
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return _sq(ap[0] - v * ab[0]) + _sq(ap[1] - v * ab[1]) + _sq(ap[2] - v * ab[2])
    for i in range(3):
        cp[i] = x[i] - c[i]
    d5 = ab[0] * cp[0] + ab[1] * cp[1] + ab[2] * cp[2]
    d6 = ac[0] * cp[0] + ac[1] * cp[1] + ac[2] * cp[2]
    if d6 >= 0.0 and d5 <= d6:
        return cp[0] * cp[0] + cp[1] * cp[1] + cp[2] * cp[2]
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return _sq(ap[0] - w * ac[0]) + _sq(ap[1] - w * ac[1]) + _sq(ap[2] - w * ac[2])
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return _sq(bp[0] - w * (c[0] - b[0])) + _sq(bp[1] - w * (c[1] - b[1])) + _sq(bp[2] - w * (c[2] - b[2]))
    denom = va + vb + vc
    if not (denom > 0.0):
        # degenerate (zero area): the nearest of its edges
        v = segment_sqdist(x, a, b)
        w = segment_sqdist(x, b, c)
        if w < v:
            v = w
        w = segment_sqdist(x, c, a)
        return w if w < v else v
    v = vb / denom
    w = vc / denom
    return _sq(ap[0] - v * ab[0] - w * ac[0]) + _sq(ap[1] - v * ab[1] - w * ac[1]) + _sq(ap[2] - v * ab[2] - w * ac[2])
