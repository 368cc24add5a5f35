# cython: language_level=3
from .halfedge cimport HalfEdgeMesh, HEArrays
from .heap cimport IndexedHeap

cdef enum BoundaryPolicy:
    BOUNDARY_LOCK = 0
    BOUNDARY_PRESERVE = 1
    BOUNDARY_FREE = 2

cdef enum Placement:
    PLACE_OPTIMAL = 0
    PLACE_ENDPOINT = 1

cdef enum RunStatus:
    RUN_TARGET = 0       # face target reached
    RUN_CHUNK = 1        # max_steps collapses done, call again
    RUN_EXHAUSTED = 2    # no legal collapse left (or none within max_error)

# quadric layout: a11 a12 a13 a22 a23 a33 b1 b2 b3 c w   (w = summed face area)
cdef enum:
    QSIZE = 11
    VSTRIDE = 14         # per-vertex row: quadric (QSIZE) then position (3)

cdef class EdgeCollapser:
    cdef HalfEdgeMesh hm
    cdef HEArrays* m            # raw views of hm's arrays
    cdef double* P              # &vdata[0, QSIZE]: position of v at P[VSTRIDE * v]
    cdef double* Q              # &vdata[0, 0]: quadric of v at Q[VSTRIDE * v]
    cdef double* A              # attr, (n, n_attr)
    cdef IndexedHeap heap
    cdef double[:, ::1] vdata       # (n, VSTRIDE): quadric then position
    cdef object pos_out             # positions kept after release()
    cdef double[:, ::1] attr
    cdef int n_attr
    cdef unsigned char[::1] vflags  # bit 0 fixed, bit 1 boundary
    cdef unsigned char[::1] moved
    cdef unsigned char[::1] refused  # 1: an edge of this vertex was refused by a check
    cdef int placement
    cdef int boundary
    cdef double cos_max_angle
    cdef double cos_orig_angle      # limit on the turn from the input face's normal
    cdef bint check_orig
    cdef short[::1] face_n0         # (3 * n_faces,) unit normals of the input faces, x 32767
    cdef short* N0
    cdef bint record
    cdef bint released              # heap and quadrics freed after the run
    cdef double closed_volume       # 6 x signed volume of a closed connected surface, else 0
    cdef double pending_dvol        # its change by the collapse just checked
    cdef double min_quality
    cdef double max_error
    cdef int[::1] rec_removed
    cdef int[::1] rec_kept
    cdef double[:, ::1] rec_pos
    cdef double[::1] rec_cost
    cdef double[::1] rec_error
    cdef unsigned char[::1] rec_moved
    cdef readonly int n_collapses
    cdef readonly double max_error_done
    cdef readonly int n_rejected_error
    cdef readonly int n_rejected_topology
    cdef readonly int n_rejected_geometry
    cdef int collapses_since_rescan

    cdef int plan(self, int e, int* h_out, int* r_out, double* p, double* cost, double* err) noexcept nogil
    cdef bint geometry_ok(self, int h, int r, int k, const double* p) noexcept nogil
    cdef bint fan_ok(self, int center, int fa, int fb, const double* p, double* dvol) noexcept nogil
    cdef double face_volume(self, int f) noexcept nogil
    cdef void recost(self, int e) noexcept nogil
    cdef void recost_he(self, int e, int h, int u, int v) noexcept nogil
    cdef int plan_he(self, int h, int u, int v, int* h_out, int* r_out, double* p, double* cost,
                     double* err) noexcept nogil
    cdef void recost_ring(self, int v) noexcept nogil
    cdef void retry_refused(self, int w) noexcept nogil
    cdef void rescan(self) noexcept nogil
    cdef void perform(self, int h, int r, const double* p, double cost, double err) noexcept nogil
    cdef int run_c(self, int target_faces, int max_steps) noexcept nogil
