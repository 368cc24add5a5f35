# cython: language_level=3
"""Edge collapse in passes (``use_heap=False``): :class:`PassCollapser` and two drivers.

**The pass driver** (:class:`PassDriver`, ``simplify(driver="pass")``, the default).
Each pass

1. *ranks* every candidate whose cost may have changed since it was last ranked (an edge of
   a vertex a collapse kept, or a refused edge of one of its neighbours) -- on several
   threads when the metric has no native kernel;
2. *limits* the pass: of the V ranked candidates within ``max_error``, the K = ceil(V /
   fraction) cheapest may go (a histogram of the costs finds the K-th, then only those are
   sorted, by (cost, edge id));
3. *stage 1*: groups them by block of vertex slots (the slots are in Morton order, so a
   block is a patch of the surface) and, in each block, in cost order, collapses each one
   that passes every check on the current mesh, unless a collapse of the pass kept one of
   its ends (its cost is stale: next pass) or it reaches out of its block.  Blocks never
   meet, so they run on several threads, and plain cost order gives the same result -- which
   is how a pass that may reach the face target runs, to stop exactly there;
4. *stages 1b and 1c*: the candidates that reached out of their block, grouped again by the
   blocks shifted by half a block (a candidate that straddled a border of stage 1's blocks
   lies inside one of these), then those left by blocks of COARSE stage-1 blocks (when
   there are at least two of them), and taken as in stage 1, on several threads;
5. *stage 2*: those that still reached out (and seam pairs), in cost order, with the same
   rules, on one thread (3-5% of the collapses on the benchmark meshes).

The schedule depends on the mesh and the settings, never on the face target: a run to a
smaller target does the same collapses in the same order, then more, so a progressive mesh
cut at N faces is ``simplify(target_faces=N)``; the output is the same for any thread count.
docs/algorithms.md ("The pass driver") says why.

**The batch pass driver** (:func:`collapse_pass_c`): Python ranks every candidate at once
(``PassCollapser.plan_all`` and a vectorised cost), then one ``collapse_pass`` tries the
edges in that order, skipping those with an end an earlier collapse of the same pass touched
(the kept vertex and its 1-ring; the 2-ring for wide kernels), so that every collapse sees the
costs it was ranked with.  Each collapse is re-planned and checked as the heap driver's."""
cimport cython
from cython.parallel cimport prange, threadid
from libc.math cimport isnan, INFINITY
from libc.stdlib cimport qsort, malloc, free
from libc.string cimport memcpy, memset
from cpython.mem cimport PyMem_RawCalloc, PyMem_RawFree, PyMem_RawMalloc, PyMem_RawRealloc
from posix.time cimport clock_gettime, timespec, CLOCK_MONOTONIC
import numpy as np
cimport numpy as cnp

from .halfedge cimport HEArrays, he_next, he_prev, he_dest, he_ring_next, run_starts
from lodkit.kernel cimport Candidate, fill_candidate, KERNEL_OK, VERTEX_FIXED, VERTEX_BOUNDARY
from .chain cimport chain_cost
from .common cimport QSIZE, VSTRIDE, BOUNDARY_FREE, RUN_TARGET, RUN_CHUNK, RUN_EXHAUSTED, RUN_ERROR
from .quadric cimport collapse_error, quadric_eval, within_reach
from .checks cimport turns_inside_out
from .edge cimport EdgeCollapser, SEAM_NONE
from .common cimport RUN_INTERRUPTED, PARALLEL_MIN_VERTICES, prefetch
from .interrupt cimport signal_pending, raise_pending, INTERRUPT_EVERY

cnp.import_array()


cdef class PassCollapser(EdgeCollapser):
    """Edge collapse driven in passes (made with ``use_heap=False``): the arguments of
    :class:`lodkit._core.edge.EdgeCollapser`."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.touched = np.zeros(self.hm.n_vertices if not self.opt.use_heap else 1, dtype=np.intc)
        self.pass_counter = 0

    def plan_all(self):
        """Plan every live edge (batch driver): a dict of ``edge``, ``u``, ``v``,
        ``removed``, ``kept`` (int32 vertex slots), ``position`` (k, 3), ``cost`` and
        ``error``, one row per edge that may collapse (within ``max_error``), or None if a
        kernel failed."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        cdef int ne = self.hm.n_edges
        cdef int e, h, r, hs, rc, k = 0
        cdef double cost, err
        cdef double p[3]
        out_e = np.empty(ne, dtype=np.intc)
        out_u = np.empty(ne, dtype=np.intc)
        out_v = np.empty(ne, dtype=np.intc)
        out_r = np.empty(ne, dtype=np.intc)
        out_p = np.empty((ne, 3), dtype=np.float64)
        out_c = np.empty(ne, dtype=np.float64)
        out_x = np.empty(ne, dtype=np.float64)
        cdef int[::1] OE = out_e
        cdef int[::1] OU = out_u
        cdef int[::1] OV = out_v
        cdef int[::1] OR = out_r
        cdef double[:, ::1] OP = out_p
        cdef double[::1] OC = out_c
        cdef double[::1] OX = out_x
        self.n_vetoed = 0
        self.n_rejected_error = 0
        with nogil:
            for e in range(ne):
                if not self.m.edge_alive[e]:
                    continue
                rc = self.plan(e, &h, &r, &hs, p, &cost, &err)
                if rc < 0:
                    if self.failed:
                        break
                    continue
                if hs >= 0 and self.m.edge[h] != e:
                    continue              # side b of a seam pair: listed as side a's edge
                if err > self.opt.max_error:
                    self.n_rejected_error += 1
                    continue
                OE[k] = e
                OU[k] = self.m.corner[h]
                OV[k] = he_dest(self.m, h)
                OR[k] = r
                OP[k, 0] = p[0]
                OP[k, 1] = p[1]
                OP[k, 2] = p[2]
                OC[k] = cost
                OX[k] = err
                k += 1
        if self.failed:
            return None
        u = out_u[:k].copy()
        v = out_v[:k].copy()
        removed = out_r[:k].copy()
        return {"edge": out_e[:k].copy(), "u": u, "v": v, "removed": removed,
                "kept": np.where(removed == u, v, u).astype(np.intc),
                "position": out_p[:k].copy(), "cost": out_c[:k].copy(), "error": out_x[:k].copy()}

    def collapse_pass(self, edges, positions=None, int target_faces=0):
        """Collapse, in the order given, the ``edges`` whose ends no earlier collapse of
        this pass touched (re-planned and checked like the heap driver's).  ``positions``
        (k, 3), one per edge, overrides the placement where both ends are free to move.
        Returns the number of collapses; -1 if a kernel failed."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        if self.opt.use_heap:
            raise RuntimeError("collapse_pass needs an EdgeCollapser made with use_heap=False")
        cdef int[::1] E = np.ascontiguousarray(edges, dtype=np.intc)
        cdef int n_cand = E.shape[0]
        if n_cand and (np.min(E) < 0 or np.max(E) >= self.hm.n_edges):
            raise ValueError(f"edge ids must be in 0..{self.hm.n_edges - 1}")
        cdef double[:, ::1] PO
        cdef const double* po = NULL
        if positions is not None:
            PO = np.ascontiguousarray(positions, dtype=np.float64)
            if PO.shape[0] != n_cand or PO.shape[1] != 3:
                raise ValueError(f"positions must have shape ({n_cand}, 3)")
            if n_cand:
                po = &PO[0, 0]
        cdef int done = 0
        if n_cand:
            with nogil:
                done = collapse_pass_c(self, &E[0], n_cand, po, target_faces)
        return done


cdef int collapse_pass_c(PassCollapser c, const int* E, int n_cand, const double* PO, int target_faces) noexcept nogil:
    """One pass of the batch driver: try the edges in the order given, skipping those
    with an end that an earlier collapse of this pass touched (the kept vertex and its
    1-ring), so every collapse sees the costs it was ranked with.  Returns the number of
    collapses, or -1 if a kernel failed."""
    cdef int i, e, h, r, k, u, v, hs, rs, ks, done = 0
    cdef double cost, err
    cdef double p[3]
    cdef double q[QSIZE]
    cdef double dvol[2]
    cdef Candidate cand
    cdef int stamp, rc
    c.pass_counter += 1
    stamp = c.pass_counter
    c.n_rejected_error = 0
    c.n_rejected_topology = 0
    c.n_rejected_geometry = 0
    for i in range(n_cand):
        if c.hm.n_alive_faces <= target_faces:
            break
        e = E[i]
        if not c.m.edge_alive[e]:
            continue
        h = c.m.edge_he[e]
        u = c.m.corner[h]
        v = he_dest(c.m, h)
        if c.touched[u] == stamp or c.touched[v] == stamp:
            continue
        if c.plan(e, &h, &r, &hs, p, &cost, &err) < 0:
            if c.failed:
                return -1
            continue
        if hs >= 0:
            # a seam edge: both sides together or neither, where the core placed it
            k = he_dest(c.m, h) if c.m.corner[h] == r else c.m.corner[h]
            rs = c.SP[r]
            ks = c.seam_kept(hs, rs)
            if c.touched[rs] == stamp or c.touched[ks] == stamp:
                continue
            if err > c.opt.max_error:
                c.n_rejected_error += 1
                continue
            if not c.pair_ok(h, r, k, hs, rs, ks, p, dvol):
                continue
            c.perform_pair(h, r, hs, rs, p, cost, err, dvol)
            if c.failed:
                return -1
            done += 1
            mark_touched(c, k, stamp, c.opt.wide_recost)
            mark_touched(c, ks, stamp, c.opt.wide_recost)
            continue
        if PO != NULL and c.SP != NULL and (c.SP[u] != SEAM_NONE or c.SP[v] != SEAM_NONE):
            pass            # a seam vertex stays where it is, whatever a batch metric says
        elif PO != NULL and not ((c.vflags[u] | c.vflags[v])
                                 & (VERTEX_FIXED if c.opt.boundary == BOUNDARY_FREE
                                    else VERTEX_FIXED | VERTEX_BOUNDARY)) \
                and within_reach(&PO[3 * i], &c.P[VSTRIDE * u], &c.P[VSTRIDE * v]):
            # the batch metric placed it: both ends are free to move
            p[0] = PO[3 * i]
            p[1] = PO[3 * i + 1]
            p[2] = PO[3 * i + 2]
            for k in range(QSIZE):
                q[k] = c.Q[VSTRIDE * u + k] + c.Q[VSTRIDE * v + k]
            err = collapse_error(quadric_eval(q, p), q[10], c.opt.error_scale)
            if c.kernel is not None:
                # the kernels judged the core's position: ask them again about this one
                # (only their verdict counts here; the batch has ranked already)
                fill_candidate(&cand, &c.kmesh, e, h, u, v, r, v if r == u else u, p, cost, err)
                rc = chain_cost(c.chain, &cand)
                if rc != KERNEL_OK:
                    if c.kernel_refused(rc) == -2:
                        return -1
                    continue
        if err > c.opt.max_error:
            c.n_rejected_error += 1
            continue
        k = v if r == u else u
        if not c.hm.link_ok(h):
            c.n_rejected_topology += 1
            continue
        if not c.geometry_ok(h, r, k, p, -1, -1, &dvol[0]):
            c.n_rejected_geometry += 1
            continue
        c.perform(h, r, p, cost, err, -1.0, dvol[0], True)
        if c.failed:
            return -1
        done += 1
        mark_touched(c, k, stamp, c.opt.wide_recost)
    return done


cdef void mark_touched(PassCollapser c, int k, int stamp, bint two_rings) noexcept nogil:
    """Mark k and its 1-ring (with ``two_rings``, its 2-ring) touched in this pass: the batch
    driver marks a kept vertex so no later collapse of the pass sees stale costs there (the
    2-ring for wide kernels)."""
    mark_rings(c.m, &c.touched[0], k, stamp, two_rings)


cdef void mark_rings(HEArrays* m, int* marks, int k, int stamp, bint two_rings) noexcept nogil:
    """``marks[w] = stamp`` for k and its 1-ring (with ``two_rings``: its 2-ring)."""
    cdef int start = m.v_he[k]
    cdef int y = start
    cdef int ny, w
    marks[k] = stamp
    while True:
        w = he_dest(m, y)
        if two_rings:
            mark_ring(m, marks, w, stamp)
        marks[w] = stamp
        ny = he_ring_next(m, y)
        if ny < 0:
            w = m.corner[he_prev(y)]
            if two_rings:
                mark_ring(m, marks, w, stamp)
            marks[w] = stamp
            return
        if ny == start:
            return
        y = ny


cdef void mark_ring(HEArrays* m, int* marks, int w, int stamp) noexcept nogil:
    """``marks[x] = stamp`` for w's neighbours."""
    cdef int start = m.v_he[w]
    cdef int y = start
    cdef int ny
    while True:
        marks[he_dest(m, y)] = stamp
        ny = he_ring_next(m, y)
        if ny < 0:
            marks[m.corner[he_prev(y)]] = stamp
            return
        if ny == start:
            return
        y = ny


# ---------------------------------------------------------------------- the pass driver
cdef enum:
    ST_DIRTY = 0        # rank again before the next pass
    ST_VALID = 1        # ranked, within max_error, waiting for its pass
    ST_NONE = 2         # may not collapse (fixed ends, link of two boundary vertices, kernel veto)
    ST_OVER = 3         # ranked above max_error
    ST_REFUSED = 4      # failed a check; ranked again once something near it changes
    ST_SIDE_B = 5       # side b of a seam pair: ranked as its partner's edge

cdef enum:
    CK_NONE = 0         # check of a pass's candidate: may not collapse after all
    CK_OK = 1
    CK_TOPOLOGY = 2     # refused by the link condition
    CK_GEOMETRY = 3     # refused by a flip / fold / quality / volume check
    CK_PAIR = 4         # a seam edge: both sides are checked when it comes up, in order

cdef enum:
    CF_DEFER = 1        # stage 1 left the candidate to stage 2 (out of its block, or a seam pair)
    CF_DONE = 2         # stage 1 collapsed it
    CF_DONE_SHIFTED = 3  # stage 1b (the blocks shifted by half a block) collapsed it
    CF_PENDING_B = 4    # deferred by stage 1 (1b), waiting for stage 1b (1c)
    CF_DONE_COARSE = 5  # stage 1c (blocks of COARSE stage-1 blocks) collapsed it
    CF_TRIED = 6        # a stage took it up and left it (stale, refused, or no collapse):
    #                     no later stage of the pass takes it up again

cdef enum:
    N_BUCKETS = 65536   # histogram of the upper 16 bits of the float32 cost
    STAGE_RUN = 4096    # select_staged's own staging buffers: edges between checks of the room left
    BORROWED = 3        # select_staged's threads that stage in cblock, blk_order, blk_edge

cdef enum:
    COARSE = 8          # stage 1c's blocks: this many of stage 1's

cdef enum:
    RANK_CHUNK = 2048   # edges a thread ranks at a time
    RANK_RUN = 64       # rank_range's runs: dirty edges gathered, their rows prefetched, then planned
    LIVE_SHARE = 4      # the sweeps walk a list of the live edges once the faces are 1/LIVE_SHARE of the start's

cdef enum:
    SERIAL_TAIL = 256   # a pass that may reach the target takes its last few candidates one by one


cdef inline void prefetch_row(const double* row) noexcept nogil:
    """Fetch a vertex row ahead: VSTRIDE doubles span up to three cache lines."""
    prefetch(row)
    prefetch(row + 7)
    prefetch(row + VSTRIDE - 1)


cdef inline unsigned int bucket_of(float c) noexcept nogil:
    cdef unsigned int bits
    if isnan(c):
        return N_BUCKETS - 1
    memcpy(&bits, &c, sizeof(float))
    return bits >> 16         # costs are >= 0: their bits sort as the values do


cdef struct Keyed:
    float cost
    int edge


cdef int compare_keyed(const void* a, const void* b) noexcept nogil:
    cdef const Keyed* x = <const Keyed*>a
    cdef const Keyed* y = <const Keyed*>b
    if x.cost < y.cost:
        return -1
    if x.cost > y.cost:
        return 1
    return (x.edge > y.edge) - (x.edge < y.edge)


cdef inline void insertion_sort(Keyed* a, int n) noexcept nogil:
    """Sort a few keyed candidates by (cost, edge): the order compare_keyed gives."""
    cdef int i, j
    cdef Keyed x
    for i in range(1, n):
        x = a[i]
        j = i - 1
        while j >= 0 and compare_keyed(&a[j], &x) > 0:
            a[j + 1] = a[j]
            j -= 1
        a[j + 1] = x


cdef enum:
    FINITE_BUCKETS = 0x7F80   # buckets below this hold positive finite costs only


cdef inline unsigned int cost_bits(float c) noexcept nogil:
    cdef unsigned int bits
    memcpy(&bits, &c, sizeof(float))
    return bits


cdef void radix_low16(Keyed* a, int n, Keyed* tmp) noexcept nogil:
    """Sort a bucket of keyed candidates (their costs share the upper 16 bits, positive and
    finite, and they come in edge order) by the lower 16 bits of the cost, stably: two
    counting passes of 8 bits, giving the (cost, edge) order compare_keyed gives."""
    cdef int cnt[256]
    cdef int i, acc, size
    cdef unsigned int d
    cdef Keyed* src = a
    cdef Keyed* dst = tmp
    cdef Keyed* sw
    cdef int shift
    for shift in range(0, 16, 8):
        memset(cnt, 0, sizeof(cnt))
        for i in range(n):
            cnt[(cost_bits(src[i].cost) >> shift) & 0xFF] += 1
        if cnt[(cost_bits(src[0].cost) >> shift) & 0xFF] == n:
            continue                              # one digit value: already in order
        acc = 0
        for i in range(256):
            size = cnt[i]
            cnt[i] = acc
            acc += size
        for i in range(n):
            d = (cost_bits(src[i].cost) >> shift) & 0xFF
            dst[cnt[d]] = src[i]
            cnt[d] += 1
        sw = src
        src = dst
        dst = sw
    if src != a:
        memcpy(a, src, n * sizeof(Keyed))


cdef void sort_bucket(Keyed* a, int size, bint finite, Keyed* tmp) noexcept nogil:
    """Sort one bucket of keyed candidates into (cost, edge) order: a few by insertion, more
    by the radix sort on the lower cost bits when the bucket holds positive finite costs
    (``tmp``: scratch of ``size`` rows, or NULL to take it here), else by compare_keyed."""
    cdef bint own = False
    if size <= 1:
        return
    if size <= 16:
        insertion_sort(a, size)
        return
    if finite and tmp == NULL:
        tmp = <Keyed*>malloc(size * sizeof(Keyed))
        own = True
    if finite and tmp != NULL:
        radix_low16(a, size, tmp)
    else:
        qsort(a, size, sizeof(Keyed), compare_keyed)
    if own:
        free(tmp)


cdef inline double now() noexcept nogil:
    cdef timespec ts
    clock_gettime(CLOCK_MONOTONIC, &ts)
    return ts.tv_sec + 1e-9 * ts.tv_nsec


cdef enum:
    PH_RANK = 0
    PH_SELECT = 1
    PH_STAGE1 = 2
    PH_STAGE1B = 3
    PH_STAGE2 = 4
    N_PHASES = 5

PHASE_NAMES = ("rank", "select", "stage1", "stage1b", "stage2")


@cython.final
cdef class PassDriver:
    """Runs a :class:`PassCollapser` (an EdgeCollapser made with ``use_heap=False``) in
    error-limited passes (the module docstring says how).

    fraction : K = ceil(valid candidates / fraction) may go per pass (default 6)
    threads  : threads for ranking and for the blocks of a pass (1 when the metric has
               native kernels -- they may keep state between calls -- or the mesh has
               split non-manifold copies)
    block    : live vertices per block (the slots are in Morton order, so a block is a
               compact patch of the surface)
    """
    cdef PassCollapser c
    cdef HEArrays* m
    cdef float[::1] cost            # (n_edges,) ranked cost, float32: orders the pass only
    cdef unsigned char[::1] state   # (n_edges,) ST_*
    cdef int ne                     # edge slots (dead ones are skipped where they come up)
    # late in a run most edge slots are dead: the sweeps of a pass (rank, select) then walk
    # ``live`` (the ids of the edges alive when it was last made, ascending; edges only
    # die) instead of every slot.  NULL: every slot.  (update_live)
    cdef int* live
    cdef int n_live
    cdef int live_faces             # live faces when ``live`` is to be made (again)
    cdef Keyed[::1] keyed_buf       # (kmax,) the candidates of a pass, in (cost, edge) order
    cdef double fallback_limit      # the pass's dearest candidate's cost (EdgeCollapser.place_ok)
    cdef int[::1] hist
    cdef int[::1] hist_low          # histogram of the lower 16 cost bits of select()'s last bucket
    cdef int[:, ::1] hist_t         # (threads, N_BUCKETS) rank()'s cost histograms
    # one row per candidate of a pass (at most ceil(live edges / fraction)): its plan and
    # checks. plan_he (rows, 4): h, removed, seam partner half-edge (-1: none), check
    cdef int[:, ::1] plan_he
    cdef double[:, ::1] plan_x       # (rows, 6): position (3), cost, error, volume change
    # a row per candidate when the records are kept (reduce() writes them after stage 1,
    # from the rows); else a row per block, used by one candidate after another
    cdef bint keep_plans
    cdef int[:, ::1] rec_faces       # (kmax, 2): the faces a collapse of stage 1 removed
    cdef unsigned char[::1] cflag    # (kmax,) CF_*
    cdef int[::1] cblock             # (kmax,) the block of each candidate
    cdef int[::1] blk_order          # (kmax,) candidates grouped by block, cost order within
    cdef int[::1] blk_edge           # (kmax,) their edges, in the same order (read in order)
    cdef int[::1] blk_start          # (n_blocks + 1,)
    cdef int[:, ::1] acc_i           # (n_blocks, 4): collapses, faces, topology / geometry refusals
    cdef double[:, ::1] acc_x        # (n_blocks, 2): volume change, largest error
    cdef int kmax
    cdef int block                   # live vertices a block should hold
    cdef int bsize                   # vertex slots per block in this pass
    cdef int n_blocks
    cdef int lo_i, hi_i              # the slice of the pass's candidates walk_block takes
    cdef readonly int n_passes
    cdef double phase_t[N_PHASES]      # wall seconds spent in each phase (diagnostics)
    cdef int** staging               # (threads,) select_staged's staged edges, one buffer a thread
    cdef int* stage_cap              # (threads,) capacities of the own ones (from BORROWED on)
    cdef int[::1] stage_n            # (threads,) entries staged in the current select
    cdef readonly long n_deferred    # candidates left to stage 2 (diagnostics)
    cdef readonly long n_late        # collapses done in stage 2 (diagnostics)
    cdef readonly int threads
    cdef readonly double fraction
    cdef bint single                 # kernels or split copies: every pass in cost order
    cdef bint interrupted            # a signal handler raised during a run: not usable again

    def __init__(self, PassCollapser collapser, double fraction=6.0, int threads=1, int block=4096,
                 int min_parallel=0):
        if not (fraction >= 1.0):
            raise ValueError("fraction must be >= 1")
        if block < 1:
            raise ValueError("block must be >= 1")
        self.c = collapser
        self.m = collapser.m
        cdef int ne = collapser.hm.n_edges
        cdef int nv = collapser.hm.n_vertices
        self.cost = np.zeros(max(ne, 1), dtype=np.float32)
        self.state = np.zeros(max(ne, 1), dtype=np.uint8)
        self.ne = ne
        self.live = NULL
        self.n_live = 0
        self.live_faces = collapser.hm.n_alive_faces // LIVE_SHARE
        cdef int n_alive = int(np.count_nonzero(np.asarray(collapser.hm.edge_alive, dtype=bool)))
        self.hist = np.zeros(N_BUCKETS, dtype=np.intc)
        self.hist_low = np.zeros(N_BUCKETS, dtype=np.intc)
        self.n_passes = 0
        self.fallback_limit = -1.0
        self.n_deferred = 0
        self.n_late = 0
        self.fraction = fraction
        # native kernels may keep state between calls (their commits must come in cost
        # order), and the link condition of a mesh with split copies reads the copies'
        # rings wherever they are: those run every pass in plain cost order, on one thread
        self.single = collapser.kernel is not None or collapser.hm.has_copies
        # below min_parallel live vertices the passes are too short to pay for waking a
        # thread team (several times a pass): one thread, the same output
        self.threads = (threads if not self.single and threads > 1
                        and collapser.hm.n_alive_vertices >= min_parallel else 1)
        self.hist_t = np.zeros((self.threads, N_BUCKETS), dtype=np.intc)
        self.staging = <int**>PyMem_RawCalloc(self.threads, sizeof(int*))
        self.stage_cap = <int*>PyMem_RawCalloc(self.threads, sizeof(int))
        if self.staging == NULL or self.stage_cap == NULL:
            raise MemoryError()
        self.stage_n = np.zeros(self.threads, dtype=np.intc)
        # room for the bucket of the K-th candidate past K (1/64 of the edges, ~1 B a
        # vertex): without it the first pass, where nearly every edge is valid, cuts that
        # bucket on one thread (select)
        self.kmax = <int>((n_alive + fraction - 1.0) / fraction) + n_alive // 64 + 1
        self.keyed_buf = np.zeros(self.kmax, dtype=[("cost", np.float32), ("edge", np.intc)])
        self.keep_plans = collapser.rec.on
        self.rec_faces = np.zeros((self.kmax if collapser.rec.on else 1, 2), dtype=np.intc)
        self.cflag = np.zeros(self.kmax, dtype=np.uint8)
        # (one row more: select_staged's first threads stage in these three, which the
        # grouping fills only later in the pass, and write a row past their last edge)
        self.cblock = np.zeros(self.kmax + 1, dtype=np.intc)
        self.blk_order = np.zeros(self.kmax + 1, dtype=np.intc)
        self.blk_edge = np.zeros(self.kmax + 1, dtype=np.intc)
        self.staging[0] = &self.cblock[0]
        if self.threads > 1:
            self.staging[1] = &self.blk_order[0]
        if self.threads > 2:
            self.staging[2] = &self.blk_edge[0]
        self.block = block
        self.bsize = block
        self.n_blocks = 1
        # group() never makes blocks of fewer than block // 8 live vertices: at most this many
        max_blocks = (nv + max(block // 8, 1) - 1) // max(block // 8, 1) + 1
        # (stage 1b's shifted blocks: one more than stage 1's)
        self.blk_start = np.zeros(max_blocks + 2, dtype=np.intc)
        rows = self.kmax if self.keep_plans else max_blocks + 1
        self.plan_he = np.zeros((rows, 4), dtype=np.intc)
        self.plan_x = np.zeros((rows, 6), dtype=np.float64)
        self.acc_i = np.zeros((max_blocks + 1, 4), dtype=np.intc)
        self.acc_x = np.zeros((max_blocks + 1, 2), dtype=np.float64)

    def __dealloc__(self):
        cdef int t
        if self.staging != NULL:
            for t in range(BORROWED, self.threads):
                PyMem_RawFree(self.staging[t])
        PyMem_RawFree(self.staging)
        PyMem_RawFree(self.stage_cap)
        PyMem_RawFree(self.live)

    # ------------------------------------------------------------- named steps
    cdef void update_live(self) noexcept nogil:
        """Before a pass: once the live faces have fallen to ``live_faces`` (a quarter of
        the start's, then half of those at the last making), make ``live`` again from the
        edges still alive -- from every slot the first time, then from the last list (edges
        only die).  Each making halves the list at least, so the making costs O(edges) in
        all, and a pass's sweeps cost what is alive, not every slot: late in a run (to 1 %,
        or a bounded run's many short passes) most slots are dead.  Ascending ids, so every
        sweep visits the live edges in the same order as before: the same output.  Without
        the memory for it (a byte a slot at most), the sweeps go on over every slot."""
        cdef const unsigned char* alive = self.m.edge_alive
        cdef int n = 0, i, e
        cdef int* made
        if self.c.hm.n_alive_faces > self.live_faces:
            return
        self.live_faces = self.c.hm.n_alive_faces // 2
        if self.live == NULL:
            for e in range(self.ne):
                n += alive[e] != 0
            made = <int*>PyMem_RawMalloc((n + 1) * sizeof(int))   # (a row past the last: the loop below writes it)
            if made == NULL:
                return
            n = 0
            for e in range(self.ne):
                made[n] = e
                n += alive[e] != 0
            self.live = made
        else:
            for i in range(self.n_live):
                e = self.live[i]
                self.live[n] = e
                n += alive[e] != 0
            made = <int*>PyMem_RawRealloc(self.live, max(n, 1) * sizeof(int))
            if made != NULL:
                self.live = made
        self.n_live = n

    cdef inline int n_sweep(self) noexcept nogil:
        """How many entries a pass's sweeps walk: the live list's, else every edge slot."""
        return self.n_live if self.live != NULL else self.ne

    cdef void rank(self) noexcept nogil:
        """Plan every dirty live edge: its cost, or why it may not go; and count the valid
        candidates into a cost histogram per thread (``compact`` sums them).  Each edge
        writes its own slots only, and the histograms are integer counts, so the result
        does not depend on the number of threads."""
        cdef int c, t, lo, hi
        cdef int n_items = self.n_sweep()
        cdef int n_chunks = (n_items + RANK_CHUNK - 1) // RANK_CHUNK
        memset(&self.hist_t[0, 0], 0, self.hist_t.shape[0] * N_BUCKETS * sizeof(int))
        if self.threads > 1:
            # one parallel region a pass, in dynamic chunks: a thread the system holds back
            # (a loaded machine) delays the end by one chunk, not by its share; the calling
            # thread (the team's thread 0) hears Ctrl-C, and then every thread skips the rest
            for c in prange(n_chunks, num_threads=self.threads, schedule="dynamic", chunksize=1):
                if self.interrupted:
                    continue
                t = threadid()
                if t == 0 and (c & 31) == 31 and signal_pending():
                    self.interrupted = True
                    continue
                lo = c * RANK_CHUNK
                hi = min(lo + RANK_CHUNK, n_items)
                self.rank_range(lo, hi, &self.hist_t[t, 0])
            if not self.interrupted and signal_pending():
                self.interrupted = True
            return
        for c in range(n_chunks):
            lo = c * RANK_CHUNK
            hi = min(lo + RANK_CHUNK, n_items)
            self.rank_range(lo, hi, &self.hist_t[0, 0])
            if self.c.failed:
                return
            if (c & 31) == 31 and signal_pending():
                self.interrupted = True
                return

    cdef void rank_range(self, int lo, int hi, int* hist) noexcept nogil:
        """rank() for the sweep's entries lo .. hi - 1 (edges, or entries of ``live``),
        counting into ``hist`` (the arrays are read through
        locals: the histogram's stores would otherwise reload them for every edge).  In runs
        of RANK_RUN edges: the run's dirty live edges are gathered and their ends' rows
        prefetched (and the valid ones counted), then planned (their rows lie anywhere near
        the run: the plans would otherwise wait for each one in turn) and counted if valid."""
        cdef const unsigned char* state = &self.state[0]
        cdef const unsigned char* alive = self.m.edge_alive
        cdef const float* cost = &self.cost[0]
        cdef const int* edge_he = self.m.edge_he
        cdef const int* corner = self.m.corner
        cdef const double* Q = self.c.Q
        cdef const int* live = self.live
        cdef int dirty[RANK_RUN]
        cdef int i, j, e, h, n, sub, sub_end
        cdef unsigned char st
        sub = lo
        while sub < hi:
            sub_end = min(sub + <int>RANK_RUN, hi)
            n = 0
            for i in range(sub, sub_end):
                e = live[i] if live != NULL else i
                if not alive[e]:
                    continue
                st = state[e]
                if st == ST_VALID:
                    hist[bucket_of(cost[e])] += 1
                elif st == ST_DIRTY:
                    dirty[n] = e
                    n += 1
                    h = edge_he[e]
                    prefetch_row(&Q[VSTRIDE * corner[h]])
                    prefetch_row(&Q[VSTRIDE * corner[he_next(h)]])
            for j in range(n):
                e = dirty[j]
                self.rank_one(e)
                if self.c.failed:
                    return
                if state[e] == ST_VALID:
                    hist[bucket_of(cost[e])] += 1
            sub = sub_end

    cdef inline void rank_one(self, int e) noexcept nogil:
        """Plan dirty live edge ``e`` (rank_range has checked it is one) into its state and
        cost.  (``plan_he`` straight from the edge's half-edge: ``plan`` is the same call
        through one more frame.)"""
        cdef int h = self.m.edge_he[e]
        cdef int r, hs, rc
        cdef double c, err
        cdef double p[3]
        # without an error limit the ranking needs no error (nor the provenance the core
        # works out with it): check() plans the candidates of a pass again, in full
        err = 0.0
        rc = self.c.plan_he(h, self.m.corner[h], he_dest(self.m, h), &h, &r, &hs, p, &c,
                            &err if self.c.opt.max_error < INFINITY else NULL)
        if rc < 0:
            self.state[e] = ST_NONE
        elif hs >= 0 and self.m.edge[h] != e:
            self.state[e] = ST_SIDE_B
        elif err > self.c.opt.max_error:
            self.state[e] = ST_OVER
        else:
            self.state[e] = ST_VALID
            self.cost[e] = <float>c

    cdef int compact(self) noexcept nogil:
        """The number of valid candidates (live edges ranked within the limit), and the
        histogram of their costs: the sum of rank()'s histograms."""
        cdef int* hist = &self.hist[0]
        cdef const int* row
        cdef int b, t, valid = 0
        # (through pointers, a row at a time: the loops vectorise; integer sums, so the
        # order does not matter.  It runs every pass, over all N_BUCKETS.)
        memcpy(hist, &self.hist_t[0, 0], N_BUCKETS * sizeof(int))
        for t in range(1, self.hist_t.shape[0]):
            row = &self.hist_t[t, 0]
            for b in range(N_BUCKETS):
                hist[b] += row[b]
        for b in range(N_BUCKETS):
            valid += hist[b]
        return valid

    cdef int select(self, int k) noexcept nogil:
        """The k cheapest valid candidates, sorted by (cost, edge), into keyed_buf; returns
        how many were gathered (>= k: the whole bucket holding the k-th is taken when it
        fits, and the caller uses the first k).  A counting sort by bucket (edges are
        visited in edge order, so each bucket fills in edge order), then each bucket sorted
        by cost: the order is (cost, edge) whatever the buckets hold.  When the bucket of
        the k-th does not fit in keyed_buf (kmax rows), only its share of the k is kept,
        through a histogram of the lower 16 cost bits within that bucket (the same bits are
        the same cost, and those come in edge order): the same k, in the same order.
        (select_staged when it fits; the cut, rare with kmax's room, on one thread.)"""
        cdef int b, last, acc = 0, e, n, start, size, big = 0, before, need, last2 = 0, take = 0
        cdef unsigned int bk, lo
        cdef Keyed* tmp
        for last in range(N_BUCKETS):
            acc += self.hist[last]
            if acc >= k:
                break
        n = acc
        before = n - self.hist[last]
        if n <= self.keyed_buf.shape[0]:
            return self.select_staged(last, n)
        if last >= FINITE_BUCKETS:
            return self.select_wide(k, last, n)
        # bucket `last` overflows: find the low 16 bits of the k-th within it
        need = k - before
        memset(&self.hist_low[0], 0, N_BUCKETS * sizeof(int))
        for e in range(self.ne):
            if (self.state[e] == ST_VALID and self.m.edge_alive[e]
                    and bucket_of(self.cost[e]) == <unsigned int>last):
                self.hist_low[cost_bits(self.cost[e]) & 0xFFFF] += 1
        acc = 0
        for last2 in range(N_BUCKETS):
            if acc + self.hist_low[last2] >= need:
                break
            acc += self.hist_low[last2]
        take = need - acc                  # of the entries with exactly the k-th's cost
        acc = before                       # hist_low: write positions within the bucket
        for b in range(last2 + 1):
            size = self.hist_low[b]
            self.hist_low[b] = acc
            acc += size
        n = k
        acc = 0
        for b in range(last + 1):             # hist becomes each bucket's write position
            size = self.hist[b]
            self.hist[b] = acc
            acc += size
        for e in range(self.ne):
            if self.state[e] != ST_VALID or not self.m.edge_alive[e]:
                continue
            bk = bucket_of(self.cost[e])
            if bk > <unsigned int>last:
                continue
            if bk < <unsigned int>last:
                self.keyed_buf[self.hist[bk]].cost = self.cost[e]
                self.keyed_buf[self.hist[bk]].edge = e
                self.hist[bk] += 1
                continue
            lo = cost_bits(self.cost[e]) & 0xFFFF
            if lo > <unsigned int>last2:
                continue
            if lo == <unsigned int>last2:
                if take == 0:
                    continue
                take -= 1
            self.keyed_buf[self.hist_low[lo]].cost = self.cost[e]
            self.keyed_buf[self.hist_low[lo]].edge = e
            self.hist_low[lo] += 1
        start = 0
        for b in range(last + 1):             # hist[b] is now the end of bucket b
            size = self.hist[b] - start
            if size > big:
                big = size
            start = self.hist[b]
        tmp = <Keyed*>malloc(big * sizeof(Keyed)) if big > 16 else NULL
        start = 0
        for b in range(last):                 # (the cut bucket is in order already)
            sort_bucket(&self.keyed_buf[start], self.hist[b] - start, b < FINITE_BUCKETS, tmp)
            start = self.hist[b]
        free(tmp)
        return n

    cdef int select_staged(self, int last, int n) noexcept nogil:
        """select() on ``threads`` threads when every candidate up to bucket ``last`` fits
        (n of them): each thread copies the edges of the candidates of its range of edges,
        in edge order, to its staging buffer and counts them by bucket; then, their write
        positions known (ranges in edge order, so each bucket still fills in edge order),
        places its staged ones (a sixth of the edges or so, not every edge again); and the
        buckets are sorted on threads.  The same order as one thread's.  The first three
        threads stage in cblock, blk_order and blk_edge (kmax + 1 rows each, free until the
        grouping), so this takes no memory of its own on up to three threads.  (Where a
        buffer of its own cannot grow, the candidates are counted and then written from the
        edges.)"""
        cdef int T = self.threads
        cdef int n_items = self.n_sweep()
        cdef int per = (n_items + T - 1) // T
        cdef int t, b, lo, hi, pos, c, start, end
        cdef bint staged = True
        for t in prange(T, num_threads=T, schedule="static", chunksize=1):
            memset(&self.hist_t[t, 0], 0, (last + 1) * sizeof(int))
            lo = t * per
            hi = min(lo + per, n_items)
            self.stage_n[t] = self.stage_range(t, lo, hi, last)
        for t in range(T):
            if self.stage_n[t] < 0:
                staged = False
        if not staged:
            for t in prange(T, num_threads=T, schedule="static", chunksize=1):
                memset(&self.hist_t[t, 0], 0, (last + 1) * sizeof(int))
                lo = t * per
                hi = min(lo + per, n_items)
                self.bucket_range(lo, hi, last, &self.hist_t[t, 0], False)
        pos = 0
        for b in range(last + 1):             # hist: bucket starts; hist_t: each range's
            self.hist[b] = pos
            for t in range(T):
                c = self.hist_t[t, b]
                self.hist_t[t, b] = pos
                pos += c
        for t in prange(T, num_threads=T, schedule="static", chunksize=1):
            if staged:
                self.unstage(t, &self.hist_t[t, 0])
            else:
                lo = t * per
                hi = min(lo + per, n_items)
                self.bucket_range(lo, hi, last, &self.hist_t[t, 0], True)
        for b in prange(last + 1, num_threads=T, schedule="dynamic", chunksize=256):
            start = self.hist[b]
            end = self.hist[b + 1] if b < last else n
            sort_bucket(&self.keyed_buf[start], end - start, b < FINITE_BUCKETS, NULL)
        return n

    cdef int stage_range(self, int t, int lo, int hi, int last) noexcept nogil:
        """select_staged's first step for thread ``t``: the valid candidates of the sweep's
        entries lo .. hi - 1 in buckets up to ``last``, their edges in edge order, into its staging
        buffer (one of its own grown as needed), counted by bucket into its row of hist_t.
        Returns how many, or -1 when the buffer could not grow."""
        cdef const unsigned char* state = &self.state[0]
        cdef const unsigned char* alive = self.m.edge_alive
        cdef const float* cost = &self.cost[0]
        cdef int* hist = &self.hist_t[t, 0]
        cdef int* buf = self.staging[t]
        cdef const int* live = self.live
        cdef int* grown
        cdef int cap = self.stage_cap[t]
        cdef int e, i, j = 0, sub, sub_end
        cdef unsigned int bk, take
        # without branches on the edge's state (dead and valid edges mix at random late in
        # a run): every edge is written to the next row and counted, and kept (the row
        # advanced, the count left) only if it is a valid candidate up to ``last``
        sub = lo
        while sub < hi:
            sub_end = min(sub + <int>STAGE_RUN, hi)
            if t >= BORROWED and cap - j < sub_end - sub:
                cap = max(cap + cap // 2, j + STAGE_RUN)
                grown = <int*>PyMem_RawRealloc(buf, <size_t>cap * sizeof(int))
                if grown == NULL:
                    return -1
                buf = grown
                self.staging[t] = buf
                self.stage_cap[t] = cap
            for i in range(sub, sub_end):
                e = live[i] if live != NULL else i
                bk = bucket_of(cost[e])
                take = (state[e] == ST_VALID) & (alive[e] != 0) & (bk <= <unsigned int>last)
                buf[j] = e
                j += take
                hist[bk] += take
            sub = sub_end
        return j

    cdef void unstage(self, int t, int* pos) noexcept nogil:
        """select_staged's second step for thread ``t``: its staged candidates to their
        buckets' next rows ``pos`` (advanced) of keyed_buf."""
        cdef const int* buf = self.staging[t]
        cdef const float* cost = &self.cost[0]
        cdef Keyed* out = &self.keyed_buf[0]
        cdef int j, e
        cdef unsigned int bk
        for j in range(self.stage_n[t]):
            e = buf[j]
            bk = bucket_of(cost[e])
            out[pos[bk]].cost = cost[e]
            out[pos[bk]].edge = e
            pos[bk] += 1

    cdef void bucket_range(self, int lo, int hi, int last, int* pos, bint write) noexcept nogil:
        """The valid candidates of the sweep's entries lo .. hi - 1 in buckets up to
        ``last``, in edge order: counted into ``pos`` (``write`` False), or written to their buckets' next
        rows ``pos`` (advanced).  Through locals: the stores would otherwise reload the
        arrays for every edge."""
        cdef const unsigned char* state = &self.state[0]
        cdef const unsigned char* alive = self.m.edge_alive
        cdef const float* cost = &self.cost[0]
        cdef Keyed* out = &self.keyed_buf[0]
        cdef const int* live = self.live
        cdef unsigned int bk
        cdef int e, i
        for i in range(lo, hi):
            e = live[i] if live != NULL else i
            if state[e] == ST_VALID and alive[e]:
                bk = bucket_of(cost[e])
                if bk <= <unsigned int>last:
                    if write:
                        out[pos[bk]].cost = cost[e]
                        out[pos[bk]].edge = e
                    pos[bk] += 1

    cdef int select_wide(self, int k, int last, int n) noexcept nogil:
        """select() when the bucket of the k-th holds infinite, NaN or negative costs (a
        kernel's) and does not fit in keyed_buf: all n gathered into a temporary buffer,
        sorted by compare_keyed, the first k kept.  Without memory for that, the buckets
        before and then that bucket's first entries in edge order (the same on every run)."""
        cdef Keyed* all_ = <Keyed*>malloc(n * sizeof(Keyed))
        cdef int e, i = 0
        cdef unsigned int bk
        if all_ != NULL:
            for e in range(self.ne):
                if self.state[e] == ST_VALID and self.m.edge_alive[e] and bucket_of(self.cost[e]) <= <unsigned int>last:
                    all_[i].cost = self.cost[e]
                    all_[i].edge = e
                    i += 1
            qsort(all_, i, sizeof(Keyed), compare_keyed)
            memcpy(&self.keyed_buf[0], all_, k * sizeof(Keyed))
            free(all_)
            return k
        for e in range(self.ne):
            if self.state[e] != ST_VALID or not self.m.edge_alive[e]:
                continue
            bk = bucket_of(self.cost[e])
            if bk < <unsigned int>last:
                self.keyed_buf[i].cost = self.cost[e]
                self.keyed_buf[i].edge = e
                i += 1
        qsort(&self.keyed_buf[0], i, sizeof(Keyed), compare_keyed)
        for e in range(self.ne):
            if i >= k:
                break
            if self.state[e] == ST_VALID and self.m.edge_alive[e] and bucket_of(self.cost[e]) == <unsigned int>last:
                self.keyed_buf[i].cost = self.cost[e]
                self.keyed_buf[i].edge = e
                i += 1

        return i

    cdef void dirty_ring(self, int k) noexcept nogil:
        """After a collapse kept k: its edges (and, for wide kernels, its neighbours' edges)
        must be ranked again; so must the refused edges of its neighbours (the collapse may
        have made them legal).  (Arrays through locals: a byte store may alias anything
        reached through ``self``.)"""
        cdef unsigned char* state = &self.state[0]
        cdef const int* edge = self.m.edge
        cdef const int* corner = self.m.corner
        cdef const int* twin = self.m.twin
        cdef unsigned char* refused = &self.c.refused[0]
        cdef bint wide = self.c.opt.wide_recost
        cdef int start = self.m.v_he[k]
        cdef int y = start
        cdef int ny, w
        refused[k] = 0
        while True:
            state[edge[y]] = ST_DIRTY
            w = corner[he_next(y)]
            if wide or refused[w]:                   # else dirty_neighbour has nothing to do
                self.dirty_neighbour(w, state)
            ny = twin[he_prev(y)]                    # he_ring_next
            if ny < 0:
                y = he_prev(y)
                state[edge[y]] = ST_DIRTY
                w = corner[y]
                if wide or refused[w]:
                    self.dirty_neighbour(w, state)
                return
            if ny == start:
                return
            y = ny

    cdef void dirty_neighbour(self, int w, unsigned char* state) noexcept nogil:
        cdef const int* edge = self.m.edge
        cdef const int* twin = self.m.twin
        cdef int start, y, ny
        cdef bint all_edges = self.c.opt.wide_recost      # wide kernels: costs read the stars
        if not all_edges and not self.c.refused[w]:
            return
        self.c.refused[w] = 0
        start = self.m.v_he[w]
        y = start
        while True:
            if all_edges or state[edge[y]] == ST_REFUSED:
                state[edge[y]] = ST_DIRTY
            ny = twin[he_prev(y)]                    # he_ring_next
            if ny < 0:
                y = he_prev(y)
                if all_edges or state[edge[y]] == ST_REFUSED:
                    state[edge[y]] = ST_DIRTY
                return
            if ny == start:
                return
            y = ny

    cdef void check(self, int e, int pr) noexcept nogil:
        """Plan candidate edge ``e`` of the pass again (for its position, which ranking does
        not keep) and run the checks on the current state; writes plan row ``pr`` only."""
        cdef int h, r, hs, k
        cdef double dvol = 0.0
        cdef double* x = &self.plan_x[pr, 0]
        if self.c.plan(e, &h, &r, &hs, x, &x[3], &x[4]) < 0:
            self.plan_he[pr, 3] = CK_NONE
            return
        self.plan_he[pr, 0] = h
        self.plan_he[pr, 1] = r
        self.plan_he[pr, 2] = hs
        if hs >= 0:
            self.plan_he[pr, 3] = CK_PAIR              # both sides: checked in order
            return
        k = he_dest(self.m, h) if self.m.corner[h] == r else self.m.corner[h]
        if not self.c.hm.link_ok(h):
            self.plan_he[pr, 3] = CK_TOPOLOGY
        elif not self.c.place_ok(h, r, k, x, &x[3], self.fallback_limit, &dvol):
            self.plan_he[pr, 3] = CK_GEOMETRY
        else:
            self.plan_he[pr, 3] = CK_OK
            x[5] = dvol

    cdef int group(self, int n_sel) noexcept nogil:
        """Group the pass's candidates by the block of their first end (a counting sort,
        cost order kept within a block) and clear the blocks' tallies."""
        cdef long long nv = self.c.hm.n_vertices
        cdef long long alive = self.c.hm.n_alive_vertices
        cdef long long per = self.block
        # about `block` live vertices a block, whatever share of the slots is dead, but at
        # least 16 blocks while each keeps an eighth of that (so that threads have blocks to
        # share out as the mesh shrinks)
        if alive // 16 < per:
            per = max(alive // 16, self.block // 8, 1)
        self.bsize = <int>min(nv, (per * nv + alive - 1) // max(alive, 1))
        if self.bsize < 1:
            self.bsize = 1
        self.n_blocks = <int>((nv + self.bsize - 1) // self.bsize)
        if self.n_blocks > self.acc_i.shape[0]:
            self.n_blocks = self.acc_i.shape[0]          # cannot happen (see __init__)
            self.bsize = <int>((nv + self.n_blocks - 1) // self.n_blocks)
        memset(&self.cflag[0], 0, n_sel * sizeof(unsigned char))
        self.by_block(n_sel, self.n_blocks, 0, False)
        return 0

    cdef inline bint in_block(self, int v, int lo) noexcept nogil:
        """Is slot v in the block whose first slot is ``lo``?  (A subtraction and an
        unsigned compare: no division in the reach test's inner loop.)"""
        return <unsigned int>(v - lo) < <unsigned int>self.bsize

    cdef bint inside(self, int u, int v, int lo) noexcept nogil:
        """Is everything a collapse of edge u-v reads or writes in block b: the ends, their
        neighbours and the vertices across the far edges of their fans?  A collapse writes
        only faces whose corners are all in its closed 1-rings, so two collapses inside
        different blocks never meet."""
        return self.fan_inside(u, lo) and self.fan_inside(v, lo)

    cdef bint fan_inside(self, int w, int lo) noexcept nogil:
        """Are w, its neighbours and the vertices across the far edges of its fan in the
        block?  (A face's third corner is the next face's far end, so only the last face
        of an open fan has its third corner tested apart.)"""
        cdef const int* corner = self.m.corner
        cdef const int* twin = self.m.twin
        cdef const double* P = self.c.P
        cdef const short* N0 = self.c.N0
        cdef const int* edge = self.m.edge
        cdef int start, y, ny, t, nx, x
        if not self.in_block(w, lo):
            return False
        start = self.m.v_he[w]
        y = start
        while True:
            nx = he_next(y)
            x = corner[nx]
            if not self.in_block(x, lo):
                return False
            # (the checks read the positions of the ring and of the far corners next, and
            # the input normals of the fan's faces)
            prefetch(&P[VSTRIDE * x])
            prefetch(&P[VSTRIDE * x + 2])
            prefetch(&N0[3 * (y // 3)])
            prefetch(&edge[y])                    # (dirty_ring's, after a collapse)
            t = twin[nx]
            if t >= 0:
                x = corner[he_prev(t)]
                if not self.in_block(x, lo):
                    return False
                prefetch(&P[VSTRIDE * x])
                prefetch(&P[VSTRIDE * x + 2])
            ny = twin[he_prev(y)]                    # he_ring_next
            if ny < 0:
                return self.in_block(corner[he_prev(y)], lo)
            if ny == start:
                return True
            y = ny

    cdef int try_inside(self, int i, int e, int b, int stamp, int row, int shift, unsigned char flag) noexcept nogil:
        """Stage 1 (``shift`` 0) or 1b (``shift`` half a block) for candidate ``i``:
        collapse it if it lies inside its block (slots ``cblock[i] * bsize - shift`` on) and
        passes every check, keeping the tallies in its block's row (``row`` < 0: its record
        is written after the stage); a collapse is flagged ``flag`` (the stage's).  Returns
        the faces it removed (0: none); candidates that reach out of their block, and seam
        pairs, are left to the next stage.  (``e`` and ``b``: its edge and block, which the
        caller holds: a block's walk reads them in block order.)"""
        cdef int pr = i if self.keep_plans else b         # the plan row
        cdef int h, u, v, r, k, st, faces
        cdef int dead[3]
        cdef double* x
        if not self.m.edge_alive[e]:
            self.cflag[i] = CF_TRIED
            return 0
        h = self.m.edge_he[e]
        u = self.m.corner[h]
        v = he_dest(self.m, h)
        if self.c.touched[u] == stamp or self.c.touched[v] == stamp:
            self.cflag[i] = CF_TRIED
            return 0                          # ranked on a state a collapse changed
        if self.n_blocks > 1 and not self.inside(u, v, b * self.bsize - shift):
            self.cflag[i] = CF_DEFER
            return 0
        self.check(e, pr)
        st = self.plan_he[pr, 3]
        if st == CK_PAIR:
            self.cflag[i] = CF_DEFER
            return 0
        if st == CK_NONE:
            self.state[e] = ST_NONE
            self.cflag[i] = CF_TRIED
            return 0
        h = self.plan_he[pr, 0]
        r = self.plan_he[pr, 1]
        k = he_dest(self.m, h) if self.m.corner[h] == r else self.m.corner[h]
        x = &self.plan_x[pr, 0]
        if st == CK_TOPOLOGY:
            self.acc_i[b, 2] += 1
            self.refuse(e, r, k)
            self.cflag[i] = CF_TRIED
            return 0
        if st == CK_GEOMETRY or (self.c.closed_volume != 0.0 and
                                 turns_inside_out(self.c.closed_volume + self.acc_x[b, 0], x[5])):
            self.acc_i[b, 3] += 1
            self.refuse(e, r, k)
            self.cflag[i] = CF_TRIED
            return 0
        faces = 2 if self.m.twin[h] >= 0 else 1
        if self.c.rec.on and row < 0:
            self.rec_faces[i, 0] = h // 3
            self.rec_faces[i, 1] = self.m.twin[h] // 3 if self.m.twin[h] >= 0 else -1
        if self.single:
            # kernels commit in order: the whole collapse now, counters included, but the
            # volume, as for blocks, summed apart until the stage ends
            self.c.perform(h, r, x, x[3], x[4], -1.0, 0.0, False)
            self.acc_x[b, 0] += x[5]
        else:
            self.c.perform_local(h, r, x, x[3], x[4], -1.0, row, dead)
            self.acc_i[b, 0] += 1
            self.acc_i[b, 1] += faces
            self.acc_x[b, 0] += x[5]
            if x[4] > self.acc_x[b, 1]:
                self.acc_x[b, 1] = x[4]
        self.cflag[i] = flag
        self.lock(k, stamp)
        self.dirty_ring(k)
        return faces

    cdef void walk_block(self, int b, int stamp, int shift, unsigned char flag) noexcept nogil:
        """Block b's candidates numbered lo_i .. hi_i - 1, in cost order.  Their edges come
        in cost order, anywhere in the block: what a try reads first is fetched ahead, in
        steps (the edge's half-edge eight candidates ahead, its corners four ahead, the
        ends' rows, marks and first half-edges two ahead)."""
        cdef const int* edge = &self.blk_edge[0]
        cdef const int* edge_he = self.m.edge_he
        cdef const int* corner = self.m.corner
        cdef const int* v_he = self.m.v_he
        cdef const int* touched = &self.c.touched[0]
        cdef const double* Q = self.c.Q
        cdef int j, i, h, u, v
        cdef int end = self.blk_start[b + 1]
        for j in range(self.blk_start[b], end):
            if j + 8 < end:
                prefetch(&edge_he[edge[j + 8]])
            if j + 4 < end:
                prefetch(&corner[edge_he[edge[j + 4]]])
            if j + 2 < end:
                h = edge_he[edge[j + 2]]
                u = corner[h]
                v = corner[he_next(h)]
                prefetch(&touched[u])
                prefetch(&touched[v])
                prefetch(&v_he[u])
                prefetch(&v_he[v])
                prefetch(&Q[VSTRIDE * u])
                prefetch(&Q[VSTRIDE * u + VSTRIDE - 1])
                prefetch(&Q[VSTRIDE * v])
                prefetch(&Q[VSTRIDE * v + VSTRIDE - 1])
            i = self.blk_order[j]
            if i < self.lo_i:
                continue
            if i >= self.hi_i:
                break                          # a block's candidates come in cost order
            self.try_inside(i, edge[j], b, stamp, -1, shift, flag)

    cdef int stage(self, int n_sel, int stamp, int target_faces, bint to_target, int shift,
                   unsigned char flag, int nb) noexcept nogil:
        """A block stage (run_stage); with native kernels or split copies (``single``), its
        candidates in plain cost order, each collapse whole at once (kernels commit in
        order), the volume change summed over the stage's blocks afterwards as reduce()
        does -- the same decisions as the blocks would take.  Returns the collapses, or -1
        (interrupted) or -2 (a kernel failed)."""
        cdef int i, b, st, n = 0
        cdef int faces_left = self.c.hm.n_alive_faces
        cdef double vol
        if not self.single:
            return self.run_stage(n_sel, stamp, target_faces, to_target, shift, flag, nb)
        for i in range(n_sel):
            if faces_left <= target_faces:
                break
            if flag != CF_DONE and self.cflag[i] != CF_PENDING_B:
                continue
            if (i & (INTERRUPT_EVERY - 1)) == INTERRUPT_EVERY - 1 and signal_pending():
                return -1                       # abandons the pass: the run ends with the exception
            st = self.try_inside(i, self.keyed_buf[i].edge, self.cblock[i], stamp, self.c.n_collapses, shift, flag)
            if self.c.failed:
                return -2
            if st > 0:
                faces_left -= st
                n += 1
        vol = self.c.closed_volume               # summed in block order, as reduce() does
        for b in range(nb):
            vol += self.acc_x[b, 0]
        if self.c.closed_volume != 0.0:
            self.c.closed_volume = vol
        return n

    cdef int run_stage(self, int n_sel, int stamp, int target_faces, bint to_target, int shift,
                       unsigned char flag, int nb) noexcept nogil:
        """Stage 1 (``shift`` 0) or 1b (half a block) over the grouped candidates, their
        collapses flagged ``flag``.  Without a face target in reach, all blocks at once (on
        several threads).  With one, in cost-order slices, each as long as the candidates
        that cannot reach the target whatever they do (a collapse removes two faces at
        most): each slice's blocks at once, since a slice taken block by block is the slice
        taken in plain cost order; the last few candidates one by one, stopping exactly at
        the target.  Records always come in cost order.  Returns the collapses done, or -1
        (interrupted) or -2 (a kernel failed)."""
        cdef int lo = 0, hi, i, b, st, row, safe, faces_left, n = 0
        while lo < n_sel:
            faces_left = self.c.hm.n_alive_faces
            hi = n_sel
            if to_target:
                if faces_left <= target_faces:
                    break
                safe = (faces_left - target_faces - 1) // 2
                if safe < SERIAL_TAIL:
                    memset(&self.acc_i[0, 0], 0, nb * 4 * sizeof(int))
                    memset(&self.acc_x[0, 0], 0, nb * 2 * sizeof(double))
                    row = self.c.n_collapses
                    for i in range(lo, n_sel):
                        if faces_left <= target_faces:
                            break
                        if flag != CF_DONE and self.cflag[i] != CF_PENDING_B:
                            continue
                        if (i & (INTERRUPT_EVERY - 1)) == INTERRUPT_EVERY - 1 and signal_pending():
                            return -1           # abandons the pass: the run ends with the exception
                        st = self.try_inside(i, self.keyed_buf[i].edge, self.cblock[i], stamp, row, shift, flag)
                        if self.c.failed:
                            return -2
                        if st > 0:
                            faces_left -= st
                            row += 1
                    return n + self.reduce(False, flag, nb, lo, n_sel)
                hi = min(n_sel, lo + safe)
            memset(&self.acc_i[0, 0], 0, nb * 4 * sizeof(int))
            memset(&self.acc_x[0, 0], 0, nb * 2 * sizeof(double))
            self.lo_i = lo
            self.hi_i = hi
            if self.threads > 1:
                for b in prange(nb, num_threads=self.threads, schedule="dynamic", chunksize=1):
                    self.walk_block(b, stamp, shift, flag)
                if signal_pending():
                    return -1
            else:
                for b in range(nb):
                    self.walk_block(b, stamp, shift, flag)
                    if signal_pending():
                        return -1
            n += self.reduce(True, flag, nb, lo, hi)
            lo = hi
        return n

    cdef int group_shifted(self, int n_sel, int half) noexcept nogil:
        """Stage 1b's (1c's) blocks: the candidates deferred so far, grouped (cost order
        kept) by the blocks of ``bsize`` slots shifted by ``half`` slots, so that a candidate
        that reached over a border of the blocks before lies inside one of these; clears
        their tallies and marks them CF_PENDING_B (try_inside makes those that still reach
        out CF_DEFER again).  Returns the number of blocks."""
        cdef int nb = (self.c.hm.n_vertices + half) // self.bsize + 1
        self.by_block(n_sel, nb, half, True)
        return nb

    cdef void by_block(self, int n_sel, int nb, int half, bint deferred) noexcept nogil:
        """Group the pass's candidates (``deferred``: only those CF_DEFER, which become
        CF_PENDING_B) by the block of ``bsize`` slots, shifted by ``half``, of their first end:
        a counting sort, cost order kept within a block, into cblock, blk_order, blk_edge and
        blk_start; and clear the ``nb`` blocks' tallies.  On threads, by runs of the
        candidates (each run counted into its row of hist_t, free between select and the
        next rank, then placed from run_starts: runs in order, so the same arrays)."""
        cdef int b, t
        cdef int T = self.threads if n_sel >= PARALLEL_MIN_VERTICES and nb < N_BUCKETS else 1
        cdef int per = (n_sel + T - 1) // T
        if T > 1:
            # the blocks (two reads at random a candidate: they come in cost order) and the
            # counts, then the places, each thread over its run
            for t in prange(T, num_threads=T, schedule="static", chunksize=1):
                memset(&self.hist_t[t, 0], 0, nb * sizeof(int))
                self.block_range(t * per, min(t * per + per, n_sel), half, deferred, &self.hist_t[t, 0])
            self.blk_start[nb] = run_starts(&self.hist_t[0, 0], nb, T, N_BUCKETS)
            for b in range(nb):
                self.blk_start[b] = self.hist_t[0, b]
            for t in prange(T, num_threads=T, schedule="static", chunksize=1):
                self.place_range(t * per, min(t * per + per, n_sel), deferred, &self.hist_t[t, 0])
        else:
            # counts one row up: block b's start lands in blk_start[b + 1], and placing
            # advances it to b's end, which is b + 1's start
            memset(&self.blk_start[0], 0, (nb + 1) * sizeof(int))
            self.block_range(0, n_sel, half, deferred, &self.blk_start[1])
            run_starts(&self.blk_start[1], nb, 1, 0)
            self.place_range(0, n_sel, deferred, &self.blk_start[1])
        memset(&self.acc_i[0, 0], 0, nb * 4 * sizeof(int))
        memset(&self.acc_x[0, 0], 0, nb * 2 * sizeof(double))

    cdef void place_range(self, int lo, int hi, bint deferred, int* pos) noexcept nogil:
        """by_block's placing of candidates lo .. hi - 1 (``deferred``: of those CF_DEFER
        only, which become CF_PENDING_B) at their blocks' next rows ``pos`` (advanced) of
        blk_order and blk_edge (through locals: the stores would reload the arrays)."""
        cdef const Keyed* cand = &self.keyed_buf[0]
        cdef const int* cblock = &self.cblock[0]
        cdef unsigned char* cflag = &self.cflag[0]
        cdef int* order = &self.blk_order[0]
        cdef int* edge = &self.blk_edge[0]
        cdef int i, b
        for i in range(lo, hi):
            if deferred:
                if cflag[i] != CF_DEFER:
                    continue
                cflag[i] = CF_PENDING_B
            b = cblock[i]
            order[pos[b]] = i
            edge[pos[b]] = cand[i].edge
            pos[b] += 1

    cdef void block_range(self, int lo, int hi, int half, bint deferred, int* cnt) noexcept nogil:
        """by_block's blocks of candidates lo .. hi - 1 (``deferred``: of those CF_DEFER
        only) into cblock, counted into ``cnt`` by block (through locals: the stores would
        reload the arrays)."""
        cdef const Keyed* cand = &self.keyed_buf[0]
        cdef const unsigned char* cflag = &self.cflag[0]
        cdef const int* corner = self.m.corner
        cdef const int* edge_he = self.m.edge_he
        cdef int* cblock = &self.cblock[0]
        cdef int bsize = self.bsize
        cdef int i, b
        for i in range(lo, hi):
            if deferred and cflag[i] != CF_DEFER:
                continue
            b = (corner[edge_he[cand[i].edge]] + half) // bsize
            cblock[i] = b
            cnt[b] += 1

    cdef int walk_pass(self, int n_sel, int target_faces, int* done) noexcept nogil:
        """One pass over the K cheapest candidates (keyed_buf[:n_sel]), in two stages.

        Stage 1: the candidates are grouped into blocks of vertex slots (a block is a
        patch of the surface: the slots are in Morton order).  Within its block, each
        candidate in cost order is collapsed if it passes every check on the current
        state, unless an end of it was kept by an earlier collapse of the pass (its cost
        is stale: it waits for the next pass) or it reaches out of its block.  Blocks do
        not meet, so they run on several threads; their tallies (faces, volume change)
        are summed in block order.  The same collapses taken in plain cost order give
        the same mesh: that is what the pass does when it may reach the face target, so
        it stops exactly there, and the records are always in that order.
        Stages 1b and 1c: the candidates that reached out of their block, the same way in
        the blocks shifted by half a block, then in blocks of COARSE blocks (in cost-order
        slices when the pass may reach the target; the records follow stage 1's).
        Stage 2: those that still reached out (and seam pairs), in cost order, on the
        state the stages before left, with the same rules."""
        cdef int i, e, h, r, k, hs, rs, ks, st, stamp, faces_left, nb, pr, fine, n1 = 0
        cdef double dv2[2]
        cdef double* x
        cdef bint to_target
        cdef double t0 = now(), t1
        self.c.pass_counter += 1
        stamp = self.c.pass_counter
        self.group(n_sel)
        faces_left = self.c.hm.n_alive_faces
        # ---- stage 1
        to_target = self.single or faces_left - 2 * n_sel <= target_faces
        st = self.stage(n_sel, stamp, target_faces, to_target, 0, CF_DONE, self.n_blocks)
        if st < 0:
            return RUN_INTERRUPTED if st == -1 else RUN_ERROR
        n1 = st
        t1 = now()
        self.phase_t[PH_STAGE1] += t1 - t0
        t0 = t1
        # ---- stage 1b: the deferred candidates again, in the blocks shifted by half a block
        # (the same rules; most of those that reached over a border of stage 1's blocks lie
        # inside one of these), then 1c: what is left, in blocks of COARSE blocks
        if self.n_blocks > 1 and self.c.hm.n_alive_faces > target_faces:
            nb = self.group_shifted(n_sel, self.bsize // 2)
            st = self.stage(n_sel, stamp, target_faces, to_target, self.bsize // 2, CF_DONE_SHIFTED, nb)
            if st < 0:
                return RUN_INTERRUPTED if st == -1 else RUN_ERROR
            n1 += st
            if self.c.hm.n_alive_faces > target_faces and self.n_blocks >= 2 * COARSE:
                fine = self.bsize
                self.bsize = fine * COARSE
                nb = self.group_shifted(n_sel, 0)
                st = self.stage(n_sel, stamp, target_faces, to_target, 0, CF_DONE_COARSE, nb)
                self.bsize = fine
                if st < 0:
                    return RUN_INTERRUPTED if st == -1 else RUN_ERROR
                n1 += st
        t1 = now()
        self.phase_t[PH_STAGE1B] += t1 - t0
        t0 = t1
        # ---- stage 2
        for i in range(n_sel):
            if self.c.hm.n_alive_faces <= target_faces:
                break
            if self.cflag[i] != CF_DEFER:
                continue
            self.n_deferred += 1
            if (self.n_deferred & (INTERRUPT_EVERY - 1)) == 0 and signal_pending():
                return RUN_INTERRUPTED
            e = self.keyed_buf[i].edge
            if not self.m.edge_alive[e]:
                continue
            h = self.m.edge_he[e]
            if self.c.touched[self.m.corner[h]] == stamp or self.c.touched[he_dest(self.m, h)] == stamp:
                continue
            pr = i if self.keep_plans else 0
            self.check(e, pr)
            st = self.plan_he[pr, 3]
            if st == CK_NONE:
                self.state[e] = ST_NONE
                continue
            h = self.plan_he[pr, 0]
            r = self.plan_he[pr, 1]
            hs = self.plan_he[pr, 2]
            k = he_dest(self.m, h) if self.m.corner[h] == r else self.m.corner[h]
            x = &self.plan_x[pr, 0]
            if st == CK_TOPOLOGY:
                self.c.n_rejected_topology += 1
                self.refuse(e, r, k)
                continue
            if st == CK_GEOMETRY:
                self.c.n_rejected_geometry += 1
                self.refuse(e, r, k)
                continue
            ks = -1
            if st == CK_PAIR:
                rs = self.c.SP[r]
                ks = self.c.seam_kept(hs, rs)
                if self.c.touched[rs] == stamp or self.c.touched[ks] == stamp:
                    continue
                if not self.c.pair_ok(h, r, k, hs, rs, ks, x, dv2):       # counts its refusals
                    self.refuse(e, r, k)
                    self.c.refused[rs] = 1
                    self.c.refused[ks] = 1
                    continue
                self.c.perform_pair(h, r, hs, rs, x, x[3], x[4], dv2)
            else:
                self.c.perform(h, r, x, x[3], x[4], -1.0, x[5], False)
            if self.c.failed:
                return RUN_ERROR
            n1 += 1
            self.n_late += 1
            self.lock(k, stamp)
            self.dirty_ring(k)
            if ks >= 0:
                self.lock(ks, stamp)
                self.dirty_ring(ks)
        done[0] += n1
        self.phase_t[PH_STAGE2] += now() - t0
        if self.c.hm.n_alive_faces <= target_faces:
            return RUN_TARGET
        return RUN_CHUNK

    cdef int reduce(self, bint write_records, unsigned char flag, int n_blocks, int i0, int i1) noexcept nogil:
        """After (a slice of) stage 1 or 1b: the ``n_blocks`` blocks' tallies into the
        collapser's counters, in block order; with ``write_records``, the records of the
        collapses of candidates i0 .. i1 - 1 (cflag ``flag``) in cost order.  Returns how many
        collapses the tallies count."""
        cdef int b, i, j, h, k, r, row, n = 0, faces = 0
        cdef double vol = self.c.closed_volume
        for b in range(n_blocks):
            n += self.acc_i[b, 0]
            faces += self.acc_i[b, 1]
            self.c.n_rejected_topology += self.acc_i[b, 2]
            self.c.n_rejected_geometry += self.acc_i[b, 3]
            vol += self.acc_x[b, 0]
            if self.acc_x[b, 1] > self.c.max_error_done:
                self.c.max_error_done = self.acc_x[b, 1]
        if write_records and self.c.rec.on:
            row = self.c.n_collapses
            for i in range(i0, i1):
                if row >= self.c.n_collapses + n:
                    break
                if self.cflag[i] != flag:
                    continue
                r = self.plan_he[i, 1]
                h = self.plan_he[i, 0]
                k = he_dest(self.m, h) if self.m.corner[h] == r else self.m.corner[h]
                self.c.rec.faces[row, 0] = self.rec_faces[i, 0]
                self.c.rec.faces[row, 1] = self.rec_faces[i, 1]
                self.c.rec.removed[row] = r
                self.c.rec.kept[row] = k
                for j in range(3):
                    self.c.rec.pos[row, j] = self.plan_x[i, j]
                self.c.rec.cost[row] = self.plan_x[i, 3]
                self.c.rec.error[row] = self.plan_x[i, 4]
                self.c.rec.bound[row] = self.c.bound.last[k] if self.c.bound is not None else 0.0
                self.c.rec.moved[row] = self.c.moved[k]
                for j in range(self.c.n_attr):
                    self.c.rec.attr[row, j] = self.c.A[self.c.n_attr * k + j]
                row += 1
        self.c.hm.n_alive_faces -= faces
        self.c.hm.n_alive_vertices -= n
        if self.c.closed_volume != 0.0:
            self.c.closed_volume = vol
        self.c.n_collapses += n
        self.c.collapses_since_rescan += n
        return n

    cdef inline void lock(self, int k, int stamp) noexcept nogil:
        """After a collapse kept k: the candidates of the pass whose cost it changed wait for
        the next pass -- those ending at k, or, for kernels whose costs read the stars, at k
        or a neighbour (the edges the greedy driver re-costs)."""
        if self.c.opt.wide_recost:
            mark_rings(self.m, &self.c.touched[0], k, stamp, False)
        else:
            self.c.touched[k] = stamp

    cdef inline void refuse(self, int e, int r, int k) noexcept nogil:
        self.state[e] = ST_REFUSED
        self.c.refused[r] = 1
        self.c.refused[k] = 1

    cdef int run_c(self, int target_faces, int max_steps) noexcept nogil:
        cdef int valid, k, n_sel, status, done, steps = 0, i, over
        cdef double t0
        while self.c.hm.n_alive_faces > target_faces:
            if steps >= max_steps:
                return RUN_CHUNK
            t0 = now()
            self.update_live()
            self.rank()
            self.phase_t[PH_RANK] += now() - t0
            if self.interrupted:
                return RUN_INTERRUPTED
            if self.c.failed:
                return RUN_ERROR
            valid = self.compact()
            if valid == 0 and self.c.collapses_since_rescan > 0:
                # as the greedy driver does when its heap runs dry: rank every live edge
                # again (a refusal can be lifted by a collapse two rings away, which
                # dirtied nothing around it), and go on if that finds any
                for i in range(self.ne):
                    if self.m.edge_alive[i]:
                        self.state[i] = ST_DIRTY
                self.c.collapses_since_rescan = 0
                continue
            if valid == 0:
                over = 0
                for i in range(self.ne):
                    if self.state[i] == ST_OVER and self.m.edge_alive[i]:
                        over += 1
                self.c.n_rejected_error = over
                return RUN_EXHAUSTED
            k = <int>((valid + self.fraction - 1.0) / self.fraction)
            if k < 1:
                k = 1
            t0 = now()
            n_sel = self.select(k)
            self.phase_t[PH_SELECT] += now() - t0
            if n_sel > k:
                n_sel = k
            done = 0
            # once simplify allows it (EdgeCollapser.allow_end_fallback), a candidate whose
            # planned position fails the checks may go at an end or the midpoint of its edge
            # if that costs no more than the pass's dearest candidate (place_ok): a pass
            # never takes a collapse costlier than its limit
            self.fallback_limit = self.keyed_buf[n_sel - 1].cost if n_sel > 0 else -1.0
            status = self.walk_pass(n_sel, target_faces, &done)
            self.n_passes += 1
            steps += done
            if status != RUN_CHUNK:
                return status
        return RUN_TARGET

    @property
    def phase_seconds(self):
        """Wall seconds spent so far in each phase of the passes (diagnostics): ranking,
        selection, stage 1 (with the grouping), stages 1b and 1c, stage 2."""
        return {name: self.phase_t[i] for i, name in enumerate(PHASE_NAMES)}

    def run(self, int target_faces, int max_steps=2**31 - 1):
        """Collapse until ``target_faces`` live faces remain or nothing legal is left; or
        return after the pass in which ``max_steps`` collapses were reached (a chunk, for a
        progress bar: passes are never cut, so chunks do not change the result).  Returns 0
        (target), 1 (chunk done), 2 (exhausted) or 3 (a kernel failed)."""
        cdef int status
        if self.interrupted:
            raise RuntimeError("this PassDriver's run was interrupted; make a new one")
        with nogil:
            status = self.run_c(target_faces, max_steps)
        if status == RUN_INTERRUPTED:
            self.interrupted = True
            raise_pending()
        return status
