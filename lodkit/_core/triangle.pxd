# cython: language_level=3
from .edge cimport EdgeCollapser


cdef class TriangleCollapser(EdgeCollapser):
    cdef int tri_collapses
    cdef int tri_refused_second     # refused at the second collapse's checks

    cdef int plan_tri(self, int f, int* h_out, int* r_out, int* r2_out, double* p, double* cost,
                      double* err) noexcept nogil
    cdef int find_he(self, int k, int w) noexcept nogil
    cdef bint tri_ok(self, int h1, int r1, int k, int r2, const double* p, int* h2_out,
                     int* dead_faces, double* dvol) noexcept nogil
    cdef void perform_tri(self, int h1, int r1, int h2, int r2, const double* p, double cost,
                          double err, const int* dead_faces, const double* dvol) noexcept nogil
    cdef void recost_face(self, int f) noexcept nogil
    cdef void rerank_tri(self, int k) noexcept nogil
    cdef void retry_refused_tri(self, int w) noexcept nogil
