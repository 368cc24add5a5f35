# cython: language_level=3
"""The two-sided error bound of ``simplify(error="hausdorff")`` (bound.pyx says how)."""
from .halfedge cimport HEArrays

cdef enum:
    BOUND_MAX_FAN = 128      # faces of a collapse's two fans the check handles (more: refused)
    BOUND_MAX_DEPTH = 6      # midpoint subdivisions of a new face before it is refused
    BOUND_STACK = 64         # BVH traversal stack
    BOUND_PIECE_DEPTH = 13   # midpoint subdivisions of an original triangle at most (bound.pyx: the codes)
    BOUND_PIECE_STACK = 3 * BOUND_PIECE_DEPTH + 4    # a depth-first split of one piece
    BOUND_PATCH_MAX = 256    # input triangles a flat-patch certificate takes at most (bound.pyx)
    BOUND_PATCH_HASH = 1024  # its set of the input triangles looked at (a power of two)


cdef class Bound:
    cdef readonly double eps          # the bound, normalised units (unit bbox diagonal)
    cdef double eps2
    cdef HEArrays* m
    cdef double* P                    # positions, stride ``stride`` (the collapser's rows)
    cdef int stride
    # the BVH over the original triangles (static)
    cdef double[:, ::1] tri           # (n_tri, 9) the triangles, in leaf order
    cdef double[:, ::1] tbox          # (n_tri, 6) their boxes: lo xyz, hi xyz
    cdef double[:, ::1] box           # (n_nodes, 6) lo xyz, hi xyz
    cdef int[::1] left                # inner node: its first child (the second is left + 1); leaf: -1
    cdef int[::1] first               # leaf: first triangle
    cdef int[::1] count               # leaf: number of triangles
    cdef int n_nodes
    cdef int[:, ::1] nbr              # (n_tri, 3) the triangle across edge j (corner j to j + 1), -1 none
    cdef int[:, ::1] nbe              # (n_tri, 3) which edge of that triangle is the twin, -1 none (bound.pyx)
    # the pieces of the original (bound.pyx), attached to the face slots of the current mesh
    cdef double[:, ::1] base          # (n_tri, 9) in BVH order: a, b - a, c - a
    cdef int[::1] tdepth              # (n_tri,) the depth its pieces split to at most
    cdef int[::1] ptri                # (capacity,) the piece's original triangle (BVH row)
    cdef int[::1] pcode               # (capacity,) the piece's code: depth, up/down, grid position
    cdef int[::1] nxt                 # (capacity,) next piece on the same face, -1
    cdef int[::1] head                # (n_faces,) first piece on the face, -1
    cdef int n_used                   # slots taken (atomically: the pass driver's threads)
    cdef int capacity
    cdef bint overflow                # a piece found no slot to split into
    cdef double[::1] cert             # (n_faces,) certified distance of the face (both ways)
    cdef double[::1] fval             # (n_faces,) certified distance of the face's points to the original
    cdef double[::1] pdist            # (n_faces,) the largest distance of its pieces' corners to it
    cdef double[::1] pending          # (n_faces,) the check's face-to-original value
    cdef int[::1] ctri                # (n_faces,) the original triangle that covers the face whole, else one near it
    cdef int[::1] pending_tri         # (n_faces,) the check's
    cdef double[::1] pending_keep     # (n_faces,) the check's: its pieces may stay on it (within this), -1 not
    cdef double[:, ::1] sphere        # (n_faces, 4) a ball around the pieces on the face (centre, radius)
    cdef double[::1] last             # (n_vertices,) the bound of the last collapse that kept it
    cdef double[::1] vd2              # (n_vertices,) squared distance to the original, -1 not known
    cdef int[::1] vtri                # (n_vertices,) the triangle it was found on
    # refusals kept (check): a vertex's version counts the commits that changed a face
    # around it; an edge's refusal stands while both ends' versions do
    cdef int[::1] vver                # (n_vertices,)
    cdef int[:, ::1] memo             # (n_edges, 5): removed, kept, versions, kinds refused, piece refusing
    cdef double[:, ::1] memo_p        # (n_edges, 3): the planned point refused (kind 1)

    cdef object keep                  # the half-edge mesh and the rows the pointers see
    cdef int build(self, int* idx, const double* cent, const double* tb, int n) noexcept nogil
    cdef void link_edges(self, int n) noexcept nogil
    cdef bint within(self, const double* x, double d2) noexcept nogil
    cdef double nearest2(self, const double* x, double stop2, int* near) noexcept nogil
    cdef double cover2(self, const double* t, const int* hints, int* cover, bint least,
                       bint search=*) noexcept nogil
    cdef double pair_cover2(self, const double* t, int ta, int tb) noexcept nogil
    cdef double patch_cover(self, const double* t, const int* seeds, int n_seeds, int* cover) noexcept nogil
    cdef double vertex_dist2(self, int v, const double* x, int* near) noexcept nogil
    cdef double face_value(self, const double* t, int* cover, const int* vids, double* p2,
                           int* p_near) noexcept nogil
    cdef int collect(self, int center, int fa, int fb, const double* p, double* tris, int* fids,
                     int* vids, int n) noexcept nogil
    cdef bint check(self, int h, int r, int k, const double* p, int kind=*) noexcept nogil
    cdef int memo_kind(self, int r, int k, const double* p) noexcept nogil
    cdef bint check_uncached(self, int h, int r, int k, const double* p, int* first) noexcept nogil
    cdef int commit_begin(self, int h, int r, int k) noexcept nogil
    cdef double commit_end(self, int k, int chain) noexcept nogil
    cdef void corners(self, int t, int code, double* x) noexcept nogil
    cdef bint fits(self, int t, int code, const double* tris, const double* balls, int n,
                   int* hint) noexcept nogil
    cdef void place(self, int q, const double* tris, const double* balls, const int* fids, int n,
                    int* hint) noexcept nogil
    cdef void sphere_grow(self, int f, const double* x) noexcept nogil
    cdef void fit_sphere(self, int f) noexcept nogil
    cdef double face_fits(self, int f, const double* t) noexcept nogil
