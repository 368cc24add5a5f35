# cython: language_level=3
from .halfedge cimport HalfEdgeMesh, HEArrays
from .heap cimport IndexedHeap
from lodkit.kernel cimport Kernel, KernelMesh, Candidate
from .chain cimport KernelChain

cdef enum BoundaryPolicy:
    BOUNDARY_LOCK = 0
    BOUNDARY_PRESERVE = 1
    BOUNDARY_FREE = 2

cdef enum Placement:
    PLACE_OPTIMAL = 0
    PLACE_ENDPOINT = 1

cdef enum Operator:
    OP_EDGE = 0          # candidates are edges: one edge collapse per step
    OP_TRIANGLE = 1      # candidates are faces: a face collapses to one point (two edge collapses)

cdef enum RunStatus:
    RUN_TARGET = 0       # face target reached
    RUN_CHUNK = 1        # max_steps collapses done, call again
    RUN_EXHAUSTED = 2    # no legal collapse left (or none within max_error)
    RUN_ERROR = 3        # a native kernel reported an error (see EdgeCollapser.error_message)

# field rules: how a field merges on collapse, how a vertex field gives an edge its value,
# and how the value enters the cost
cdef enum FieldMerge:
    MERGE_MAX = 0
    MERGE_MIN = 1
    MERGE_SUM = 2
    MERGE_KEEP = 3       # the kept vertex's (or surviving edge's) value
    MERGE_MEAN = 4

cdef enum FieldValue:    # the value of edge (u, v) from a vertex field
    VALUE_MAX = 0
    VALUE_MIN = 1
    VALUE_SUM = 2
    VALUE_KEPT = 3
    VALUE_REMOVED = 4
    VALUE_MEAN = 5

cdef enum FieldMode:
    MODE_SCALE = 0       # cost *= offset + weight * value
    MODE_ADD = 1         # cost += weight * value

cdef enum:
    STEP_VFIELD = 0      # rows of EdgeCollapser.steps: (kind, first, end)
    STEP_EFIELD = 1
    STEP_KERNEL = 2

cdef enum:
    RULE_MERGE = 0       # columns of the (n_fields, 5) rule arrays
    RULE_VALUE = 1
    RULE_MODE = 2
    RULE_WEIGHT = 3
    RULE_OFFSET = 4
    RULE_COLS = 5

# quadric layout: a11 a12 a13 a22 a23 a33 b1 b2 b3 c w   (w = summed face area)
cdef enum:
    GMAX_D = 16          # quadrics over attributes: up to 13 attribute channels
    GMAX_S = 153         # packed size for GMAX_D: D(D+1)/2 + D + 1

cdef enum:
    SEAM_NONE = -1       # EdgeCollapser.seam: not on an attribute seam
    SEAM_STAYS = -2      # a seam copy that may not move nor go (seam end, >2 copies, ...)

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
    cdef int[:, ::1] rec_faces         # the (up to two) faces each collapse removed, -1: none
    cdef unsigned char[::1] rec_open   # 1: the first half of a seam pair (the pair is one step)
    cdef double[:, ::1] rec_attr       # the kept vertex's attributes after each collapse
    cdef readonly int n_collapses
    cdef readonly double max_error_done
    cdef readonly int n_rejected_error
    cdef readonly int n_rejected_topology
    cdef readonly int n_rejected_geometry
    cdef int collapses_since_rescan
    # the metric: quadric cost weight, fields, native kernels
    cdef double quadric_weight      # 0 when no quadric metric: the quadric only places
    cdef double error_scale         # error = sqrt(error_scale * Q(p) / area)
    cdef int n_vfields
    cdef double* VF                 # (n, n_vfields) vertex fields
    cdef double[:, ::1] vfield
    cdef double[:, ::1] vrules      # (n_vfields, RULE_COLS)
    cdef int n_efields
    cdef double* EF                 # (n_edges, n_efields) edge fields
    cdef double[:, ::1] efield
    cdef double[:, ::1] erules
    cdef Kernel kernel              # first of the chain, None if no kernels
    cdef KernelChain chain          # the kernels in order (lodkit._core.chain), None if none
    cdef bint kernel_places
    cdef bint wide_recost           # a kernel's costs depend on the stars: re-rank the 2-ring
    cdef Kernel wide_kernel         # the only wide kernel (it may name the vertices), or None
    cdef int[::1] edge_stamp        # wide re-rank: edges already re-ranked for this collapse
    cdef int recost_counter
    cdef KernelMesh kmesh
    cdef int[:, ::1] steps          # (n_steps, 3): fields and kernels in the metrics' order
    cdef int n_steps
    cdef bint has_extras            # any field or kernel
    cdef bint use_heap              # False: the pass driver (batch metrics) runs instead
    cdef readonly int n_vetoed      # candidates refused by a kernel since the last rescan
    cdef readonly bint failed       # a kernel returned KERNEL_ERROR
    cdef int gdim                   # dimension of the quadrics over attributes (0: none)
    cdef int gsize                  # packed size D(D+1)/2 + D + 1
    cdef double[:, ::1] gq          # (n, gsize)
    cdef double* GQ
    cdef int[::1] gcol              # attribute column of each quadric dimension past 3
    cdef double[:, ::1] gbox        # (n, 2 (D - 3)): per channel, the least and the largest
                                    # input value on the faces a slot stands for
    cdef int[::1] touched           # pass driver: vertices touched in the current pass
    cdef int pass_counter
    # attribute seams (uv / normal / colour splits: coincident vertex slots, each on its own
    # side of a pair of boundary chains): seam[v] is v's partner slot, SEAM_NONE, or
    # SEAM_STAYS for a seam copy that must not move nor go (it is also fixed)
    cdef int[::1] seam
    cdef int* SP                    # &seam[0], NULL when the mesh has no seams
    cdef int seam_h                 # set by plan_he: the partner side's half-edge of a seam
                                    # edge (-1 if the edge is not one)
    cdef bint defer_recost          # perform(): leave the re-ranking to perform_pair
    cdef readonly int n_seam_pairs  # seam edges collapsed together with their partner
    # triangle collapse (operator OP_TRIANGLE): the heap ranks faces; a face collapses to one
    # point as two edge collapses, both checked before either is done
    cdef bint tri
    cdef double forced_t            # perform(): the kept end's attribute weight (< 0: from p)
    cdef int skip_c                 # fan_ok(): faces whose shape is not checked (-1: none):
    cdef int skip_d                 # they die in a triangle collapse's second step
    cdef readonly int n_tri_collapses
    cdef readonly int n_tri_refused_second   # refused at the second collapse's checks

    cdef int plan_tri(self, int f, int* h_out, int* r_out, int* r2_out, double* p, double* cost,
                      double* err) noexcept nogil
    cdef void general_marginal3(self, int a, int b, int c, double* q) noexcept nogil
    cdef int find_he(self, int k, int w) noexcept nogil
    cdef bint tri_ok(self, int h1, int r1, int k, int r2, const double* p, int* h2_out,
                     int* dead_faces, double* dvol) noexcept nogil
    cdef void perform_tri(self, int h1, int r1, int h2, int r2, const double* p, double cost,
                          double err, const int* dead_faces, const double* dvol) noexcept nogil
    cdef void recost_face(self, int f) noexcept nogil
    cdef void rerank_tri(self, int k) noexcept nogil
    cdef void retry_refused_tri(self, int w) noexcept nogil
    cdef int run_tri_c(self, int target_faces, int max_steps) noexcept nogil

    cdef int plan(self, int e, int* h_out, int* r_out, double* p, double* cost, double* err) noexcept nogil
    cdef bint geometry_ok(self, int h, int r, int k, const double* p) noexcept nogil
    cdef bint fan_ok(self, int center, int fa, int fb, const double* p, double* dvol) noexcept nogil
    cdef double face_volume(self, int f) noexcept nogil
    cdef void recost(self, int e) noexcept nogil
    cdef void recost_he(self, int e, int h, int u, int v) noexcept nogil
    cdef int plan_he(self, int h, int u, int v, int* h_out, int* r_out, double* p, double* cost,
                     double* err) noexcept nogil
    cdef int metric_cost(self, int h, int u, int v, int fu, int fv, const double* q, const double* qg,
                         int* r_out, double* p, double* c, double* err) noexcept nogil
    cdef int seam_mate(self, int h, int u, int v) noexcept nogil
    cdef int plan_seam(self, int h, int hs, int* h_out, int* r_out, double* p, double* cost,
                       double* err) noexcept nogil
    cdef bint ring_has(self, int v, int a, int b) noexcept nogil
    cdef bint pair_ok(self, int h, int r, int k, int hs, int rs, int ks, const double* p,
                     double* dvol) noexcept nogil
    cdef void perform_pair(self, int h, int r, int hs, int rs, const double* p, double cost,
                           double err, const double* dvol) noexcept nogil
    cdef void general_marginal(self, int u, int v, double* q) noexcept nogil
    cdef void general_commit(self, int r, int k, const double* p) noexcept nogil
    cdef int kernel_refused(self, int rc) noexcept nogil
    cdef void merge_fields(self, int r, int k, const int* dead, const int* merged_into) noexcept nogil
    cdef void recost_ring(self, int v) noexcept nogil
    cdef void recost_wide(self, int v) noexcept nogil
    cdef void rerank(self, int k) noexcept nogil
    cdef void recost_around(self, int w, int stamp) noexcept nogil
    cdef void retry_refused(self, int w) noexcept nogil
    cdef void rescan(self) noexcept nogil
    cdef bint pop_candidate(self, int* item) noexcept nogil
    cdef void perform(self, int h, int r, const double* p, double cost, double err) noexcept nogil
    cdef void touch_ring(self, int w, int stamp) noexcept nogil
    cdef void mark_touched(self, int k, int stamp) noexcept nogil
    cdef int collapse_pass_c(self, const int* E, int n_cand, const double* PO, int target_faces) noexcept nogil
    cdef int run_c(self, int target_faces, int max_steps) noexcept nogil
