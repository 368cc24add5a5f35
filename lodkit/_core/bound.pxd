# cython: language_level=3
"""The two-sided error bound of ``simplify(error="hausdorff")`` (bound.pyx says how)."""
from .halfedge cimport HEArrays

cdef enum:
    BOUND_MAX_FAN = 128      # faces of a collapse's two fans the check handles (more: refused)
    BOUND_MAX_DEPTH = 6      # midpoint subdivisions of a new face before it is refused
    BOUND_STACK = 64         # BVH traversal stack


cdef class Bound:
    cdef readonly double eps          # the bound, normalised units (unit bbox diagonal)
    cdef double eps2
    cdef HEArrays* m
    cdef double* P                    # positions, stride ``stride`` (the collapser's rows)
    cdef int stride
    # the BVH over the original triangles (static)
    cdef double[:, ::1] tri           # (n_tri, 9) the triangles, in leaf order
    cdef double[:, ::1] box           # (n_nodes, 6) lo xyz, hi xyz
    cdef int[::1] left                # inner node: its first child (the second is left + 1); leaf: -1
    cdef int[::1] first               # leaf: first triangle
    cdef int[::1] count               # leaf: number of triangles
    cdef int n_nodes
    # sample points of the original, attached to the face slots of the current mesh
    cdef double[:, ::1] pts           # (n_pts, 3)
    cdef double[::1] slack            # covering radius of the point's grid (its triangle's)
    cdef int[::1] nxt                 # next point of the same face, -1
    cdef int[::1] head                # (n_faces,) first point attached to the face, -1
    cdef double[::1] cert             # (n_faces,) certified distance of the face (both ways)
    cdef double[::1] pending          # (n_faces,) the check's face-to-original value
    cdef double[:, ::1] sphere        # (n_faces, 5) a ball around the points (centre, radius), their largest slack
    cdef double[::1] last             # (n_vertices,) the bound of the last collapse that kept it

    cdef object keep                  # the half-edge mesh and the rows the pointers see
    cdef int build(self, int* idx, const double* cent, const double* tb, int n) noexcept nogil
    cdef double sqdist_box(self, int node, const double* x) noexcept nogil
    cdef bint within(self, const double* x, double d2) noexcept nogil
    cdef double nearest2(self, const double* x, double stop2) noexcept nogil
    cdef double cover2(self, const double* t, double best2) noexcept nogil
    cdef double face_value(self, const double* t) noexcept nogil
    cdef int collect(self, int center, int fa, int fb, const double* p, double* tris, int* fids,
                     int n) noexcept nogil
    cdef bint check(self, int h, int r, int k, const double* p) noexcept nogil
    cdef int commit_begin(self, int h, int r, int k) noexcept nogil
    cdef double commit_end(self, int k, int chain) noexcept nogil
    cdef void fit_sphere(self, int f) noexcept nogil
