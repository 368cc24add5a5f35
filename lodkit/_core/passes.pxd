# cython: language_level=3
from .edge cimport EdgeCollapser


cdef class PassCollapser(EdgeCollapser):
    cdef int[::1] touched           # vertices touched in the current pass (its stamp)
    cdef int pass_counter

cdef int collapse_pass_c(PassCollapser c, const int* E, int n_cand, const double* PO,
                         int target_faces) noexcept nogil
cdef void mark_touched(PassCollapser c, int k, int stamp, bint two_rings) noexcept nogil
