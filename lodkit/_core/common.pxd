# cython: language_level=3
"""What every driver of the core agrees on, in one place: run statuses, boundary policies,
placements, operators, limits and the per-vertex row layout.  Cimported by the
drivers (edge, triangle, passes, vremove) and by the half-edge arrays; nothing to build."""
# Vertex flag bits: VERTEX_FIXED (1) and VERTEX_BOUNDARY (2) of the public kernel.pxd (not
# repeated here: plugins compile against that file).


cdef enum RunStatus:     # what a driver's run() returns
    RUN_TARGET = 0       # face target reached
    RUN_CHUNK = 1        # max_steps operations done, call again
    RUN_EXHAUSTED = 2    # no legal operation left (or none within max_error)
    RUN_ERROR = 3        # a native kernel reported an error (see the driver's error_message)
    # vertex removal with record=True: the record buffers are full; run() grows them and
    # goes on (never returned to Python)
    RUN_GROW = 4
    # a signal handler raised (Ctrl-C) during the run: the def wrapper raises its exception
    # (interrupt.pxd); the driver is not usable afterwards
    RUN_INTERRUPTED = 5

cdef enum BoundaryPolicy:
    BOUNDARY_LOCK = 0        # boundary vertices are fixed
    BOUNDARY_PRESERVE = 1    # a boundary vertex never moves into the interior
    BOUNDARY_FREE = 2

cdef enum Placement:
    PLACE_OPTIMAL = 0
    PLACE_ENDPOINT = 1       # half-edge collapse: the vertices stay a subset of the input

cdef enum Operator:
    OP_EDGE = 0          # candidates are edges: one edge collapse per step
    OP_TRIANGLE = 1      # candidates are faces: a face collapses to one point (two edge collapses)

cdef enum:
    # The largest star a vertex removal (and HalfEdgeMesh.replace_star) handles: its buffers
    # are sized from it.  removal.pxd (the public removal interface) states the same limit.
    MAX_VALENCE = 64

cdef enum:
    # The set-up loops (Morton codes, face order, positions, the half-edge build, the
    # quadrics, the input faces' normals and volumes) run on OpenMP threads from this many
    # vertex slots; below it waking the thread team costs more than the loop
    # (lodkit.drivers.edge.PASS_MIN_PARALLEL is the pass driver's same limit).
    PARALLEL_MIN_VERTICES = 16384

cdef enum:
    # per-vertex quadric: a11 a12 a13 a22 a23 a33 b1 b2 b3 c w   (w = summed face area)
    QSIZE = 11
    VSTRIDE = 14         # the edge driver's per-vertex row: quadric (QSIZE) then position (3)

# Geometric constants of the checks (checks.pxd), as C constants so every module that
# cimports them folds the same value.
cdef extern from *:
    """
    #define LODKIT_FOLD_COS (-0.5)
    #define LODKIT_SQRT3 1.7320508075688772
    """
    # A face whose normal ends more than ~120 degrees from a neighbour's (and further than
    # before) folds the surface back on itself: refused (cos 120 = -0.5).
    const double FOLD_COS "LODKIT_FOLD_COS"
    const double SQRT3 "LODKIT_SQRT3"


# A hint that the cache line holding p will be read soon (GCC and Clang; a no-op for other
# compilers): the pass driver's walks and the output's gathers fetch ahead what their
# next steps read.  Never faults, whatever p is.
cdef extern from *:
    """
    #if defined(__GNUC__) || defined(__clang__)
    #define LODKIT_PREFETCH(p) __builtin_prefetch((const void*)(p))
    #else
    #define LODKIT_PREFETCH(p) ((void)0)
    #endif
    """
    void prefetch "LODKIT_PREFETCH"(const void* p) noexcept nogil

ctypedef fused sort_key:
    int
    long long


cdef inline void insertion_sort(sort_key* a, int k) noexcept nogil:
    """Sort ``a[:k]`` ascending in place: for the few keys of one vertex's ring (a vertex
    of very high valence pays k^2; callers with many keys sort otherwise)."""
    cdef int i, j
    cdef sort_key x
    for i in range(1, k):
        x = a[i]
        j = i - 1
        while j >= 0 and a[j] > x:
            a[j + 1] = a[j]
            j -= 1
        a[j + 1] = x
