# cython: language_level=3
"""Hole re-triangulation (placeholder: being written; see retriangulate.pxd)."""

cdef int split_loop(const double* P, int stride, const int* loop, int k,
                    const double* normal, int force_a, int force_b,
                    int* tri, int* work) noexcept nogil:
    return -1

cdef int fan_from(int apex, int k, int* tri) noexcept nogil:
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
    return -1
