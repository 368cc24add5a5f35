# cython: language_level=3
from .halfedge cimport HalfEdgeMesh, HEArrays
from .heap cimport IndexedHeap
from lodkit.kernel cimport Kernel, KernelMesh
from .chain cimport KernelChain
from .fields cimport FieldSet
from .quadric cimport AttributeQuadrics
from .checks cimport CheckLimits
from .bound cimport Bound

cdef enum:
    SEAM_NONE = -1       # EdgeCollapser.seam: not on an attribute seam
    SEAM_STAYS = -2      # a seam copy that may not move nor go (seam end, >2 copies, ...)


cdef struct CollapseOptions:     # set once, in __init__
    int placement                # common.pxd Placement
    int boundary                 # common.pxd BoundaryPolicy
    double max_error
    double quadric_weight        # 0 when no quadric metric: the quadric only places
    double error_scale           # error = sqrt(error_scale * Q(p) / area)
    bint use_heap                # False: the pass driver (batch metrics) runs instead
    bint has_extras              # any field or kernel
    bint kernel_places           # a kernel may re-place the kept vertex
    bint wide_recost             # a kernel's costs depend on the stars: re-rank the 2-ring


cdef class Records:
    """The collapse sequence (a progressive mesh), one row per collapse; ``on`` False: the
    buffers have one row and nothing is written."""
    cdef bint on
    cdef int[::1] removed
    cdef int[::1] kept
    cdef double[:, ::1] pos
    cdef double[::1] cost
    cdef double[::1] error
    cdef double[::1] bound           # the distance each collapse is certified for (error bound on)
    cdef unsigned char[::1] moved
    cdef int[:, ::1] faces           # the (up to two) faces each collapse removed, -1: none
    cdef unsigned char[::1] pair_open  # 1: the first half of a pair (the pair is one step)
    cdef double[:, ::1] attr         # the kept vertex's attributes after each collapse


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
    cdef unsigned char[::1] vflags  # VERTEX_FIXED | VERTEX_BOUNDARY (kernel.pxd)
    cdef unsigned char[::1] moved
    cdef unsigned char[::1] refused  # 1: an edge of this vertex was refused by a check
    cdef CollapseOptions opt
    cdef CheckLimits lim            # the checks' limits (checks.pxd)
    cdef bint end_fallback          # place_ok may fall back to an end or the midpoint (allow_end_fallback)
    cdef short[::1] face_n0         # (3 * n_faces,) unit normals of the input faces, x 32767
    cdef short* N0
    cdef unsigned char[::1] normal_sign  # (n,) per vertex: its faces' input normals' sign bits (knife)
    cdef unsigned char* NS
    cdef bint released              # heap and quadrics freed after the run
    cdef double closed_volume       # 6 x signed volume of a closed connected surface, else 0
    cdef Records rec
    cdef readonly int n_collapses
    cdef readonly double max_error_done
    cdef readonly int n_rejected_error
    cdef readonly int n_rejected_topology
    cdef readonly int n_rejected_geometry
    cdef int collapses_since_rescan
    cdef int round_size              # greedy: candidates the last rescan ranked
    cdef int round_popped            # greedy: candidates popped since the last rescan
    cdef double round_limit          # greedy: the median key of the round (run_c)
    # the metric past the quadric: fields, native kernels
    cdef FieldSet fields
    cdef Kernel kernel              # first of the chain, None if no kernels
    cdef KernelChain chain          # the kernels in order (lodkit._core.chain), None if none
    cdef Kernel wide_kernel         # the only wide kernel (it may name the vertices), or None
    cdef unsigned char[::1] walked  # wide re-rank (heap driver): vertices whose edges were re-ranked
    cdef KernelMesh kmesh
    cdef readonly int n_vetoed      # candidates refused by a kernel since the last rescan
    cdef readonly bint failed       # a kernel returned KERNEL_ERROR
    cdef AttributeQuadrics aq       # quadrics over attributes (aq.dim 0: none)
    # attribute seams (uv / normal / colour splits: coincident vertex slots, each on its own
    # side of a pair of boundary chains): seam[v] is v's partner slot, SEAM_NONE, or
    # SEAM_STAYS for a seam copy that must not move nor go (it is also fixed)
    cdef int[::1] seam
    cdef int* SP                    # &seam[0], NULL when the mesh has no seams
    cdef readonly int n_seam_pairs  # seam edges collapsed together with their partner
    # simplify(error="hausdorff"): the two-sided error bound's state (bound.pyx), None when off
    cdef readonly Bound bound

    cdef int n_candidates(self)
    cdef int plan(self, int e, int* h_out, int* r_out, int* hs_out, double* p, double* cost,
                  double* err) noexcept nogil
    cdef int plan_he(self, int h, int u, int v, int* h_out, int* r_out, int* hs_out, double* p,
                     double* cost, double* err) noexcept nogil
    cdef int metric_cost(self, int h, int u, int v, int fu, int fv, const double* q, const double* qg,
                         int* r_out, double* p, double* c, double* err) noexcept nogil
    cdef int kernel_refused(self, int rc) noexcept nogil
    cdef int seam_mate(self, int h, int u, int v) noexcept nogil
    cdef int seam_kept(self, int hs, int rs) noexcept nogil
    cdef int plan_seam(self, int h, int hs, int* h_out, int* r_out, int* hs_out, double* p,
                       double* cost, double* err) noexcept nogil
    cdef bint fan_ok(self, int center, int fa, int fb, int skip_c, int skip_d, const double* p,
                     double* dvol, double* min_q) noexcept nogil
    cdef double fan_worst_quality(self, int center, double floor) noexcept nogil
    cdef bint knife(self, int r, int k, int fa, int fb) noexcept nogil
    cdef bint opposite_signs(self, int r, int k) noexcept nogil
    cdef void merge_signs(self, int r, int k) noexcept nogil
    cdef void normal_signs(self)
    cdef int fan_faces(self, int center, int fa, int fb, int* out) noexcept nogil
    cdef bint geometry_ok(self, int h, int r, int k, const double* p, int skip_c, int skip_d,
                          double* dvol_out, int kind=*) noexcept nogil
    cdef bint place_ok(self, int h, int r, int k, double* p, double* cost_err, double limit,
                       double* dvol_out) noexcept nogil
    cdef int end_points(self, int r, int k, const double* p, double* alt, double* ca, double* q,
                        int* kinds) noexcept nogil
    cdef double face_volume6(self, int f) noexcept nogil
    cdef bint ring_has(self, int v, int a, int b) noexcept nogil
    cdef bint pair_ok(self, int h, int r, int k, int hs, int rs, int ks, const double* p,
                      double* dvol) noexcept nogil
    cdef void perform_pair(self, int h, int r, int hs, int rs, const double* p, double cost,
                           double err, const double* dvol) noexcept nogil
    cdef void recost(self, int e) noexcept nogil
    cdef void recost_he(self, int e, int h, int u, int v) noexcept nogil
    cdef void recost_ring(self, int v) noexcept nogil
    cdef void recost_wide(self, int v) noexcept nogil
    cdef void recost_around(self, int w) noexcept nogil
    cdef void unwalk(self, int v) noexcept nogil
    cdef void retry_refused(self, int w) noexcept nogil
    cdef void rerank(self, int k) noexcept nogil
    cdef void rescan(self) noexcept nogil
    cdef bint pop_candidate(self, int* item) noexcept nogil
    cdef void drop_dead(self, const int* dead) noexcept nogil
    cdef void perform(self, int h, int r, const double* p, double cost, double err, double t_attr,
                      double dvol, bint rerank) noexcept nogil
    cdef int perform_local(self, int h, int r, const double* p, double cost, double err, double t_attr,
                           int row, int* dead) noexcept nogil
    cdef int run_c(self, int target_faces, int max_steps) noexcept nogil
