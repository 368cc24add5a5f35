# cython: language_level=3
"""The pass driver: edge collapse in error-limited passes over independent sets.

Each pass

1. **ranks** every candidate whose cost may have changed since it was last ranked (its
   edge touches a vertex that a collapse kept, or a vertex whose refused candidates get
   another chance) -- in parallel, when the metric allows it;
2. **limits**: of the ranked candidates within ``max_error``, the ``1/fraction`` cheapest
   may go in this pass: the limit is the cost of the K-th cheapest (K = ceil(valid /
   fraction)), found with a histogram of the costs, not a full sort;
3. **performs**, in cost order (ties by edge id), each of those whose ends no earlier
   collapse of the pass has touched, with every check the greedy driver makes (link
   condition, flips, folds, quality, volume, boundary, locks, seams); a collapse marks its
   kept vertex and 1-ring (2-ring for wide kernels) touched, so every collapse of a pass
   sees exactly the costs it was ranked with.

The schedule depends on the mesh and settings only, never on the face target, so a run to
a smaller target performs the same collapses in the same order, then more: a progressive
mesh cut at N faces equals ``simplify(target_faces=N)``.  Ranking writes one slot per edge
and everything else runs in one thread in a fixed order: the output is the same for any
thread count.
"""
cimport cython
from cython.parallel cimport prange
from libc.math cimport isnan
from libc.stdlib cimport qsort
from libc.string cimport memcpy, memset

import numpy as np

from .decimate cimport EdgeCollapser, RUN_TARGET, RUN_CHUNK, RUN_EXHAUSTED, RUN_ERROR, SEAM_NONE
from .halfedge cimport HEArrays, he_dest, he_prev, he_ring_next

cdef enum:
    ST_DIRTY = 0        # rank again before the next pass
    ST_VALID = 1        # ranked, within max_error, waiting for its pass
    ST_NONE = 2         # may not collapse (fixed ends, link of two boundary vertices, kernel veto)
    ST_OVER = 3         # ranked above max_error
    ST_REFUSED = 4      # failed a check; ranked again once something near it changes
    ST_SIDE_B = 5       # side b of a seam pair: ranked as its partner's edge

cdef enum:
    N_BUCKETS = 65536   # histogram of the upper 16 bits of the float32 cost


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


@cython.final
cdef class PassDriver:
    """Runs an :class:`EdgeCollapser` (built with ``use_heap=False``) in passes.

    fraction : K = ceil(valid candidates / fraction) may go per pass (default 6: about
               what one collapse's 1-ring excludes, so a pass is not mostly skips)
    threads  : ranking threads (1 when the metric has kernels or the mesh has seams:
               their planning writes shared state)
    """
    cdef EdgeCollapser c
    cdef HEArrays* m
    cdef float[::1] cost            # (n_edges,) ranked cost, float32: orders the pass only
    cdef unsigned char[::1] state   # (n_edges,) ST_*
    cdef int[::1] live              # live edges, compacted once a pass
    cdef int n_live
    cdef Keyed[::1] keyed_buf
    cdef int[::1] hist
    cdef int stamp
    cdef readonly int n_passes
    cdef readonly int threads
    cdef readonly double fraction
    cdef bint parallel_ok
    cdef bint wide

    def __init__(self, EdgeCollapser collapser, double fraction=6.0, int threads=1):
        if not (fraction >= 1.0):
            raise ValueError("fraction must be >= 1")
        self.c = collapser
        self.m = collapser.m
        cdef int ne = collapser.hm.n_edges
        cdef int nv = collapser.hm.n_vertices
        self.cost = np.zeros(max(ne, 1), dtype=np.float32)
        self.state = np.zeros(max(ne, 1), dtype=np.uint8)
        self.live = np.nonzero(np.asarray(collapser.hm.edge_alive, dtype=bool))[0].astype(np.intc)
        if self.live.shape[0] == 0:
            self.live = np.zeros(1, dtype=np.intc)
            self.n_live = 0
        else:
            self.n_live = self.live.shape[0]
        self.keyed_buf = np.zeros(max(self.n_live, 1), dtype=[("cost", np.float32), ("edge", np.intc)])
        self.hist = np.zeros(N_BUCKETS, dtype=np.intc)
        self.stamp = 0
        self.n_passes = 0
        self.fraction = fraction
        self.parallel_ok = collapser.kernel is None and collapser.SP == NULL
        self.threads = threads if self.parallel_ok and threads > 1 else 1
        self.wide = collapser.wide_recost

    # ------------------------------------------------------------- named steps
    cdef void rank(self) noexcept nogil:
        """Plan every dirty live edge: its cost, or why it may not go."""
        cdef int i, e, h, r, rc
        cdef double c, err
        cdef double p[3]
        if self.threads > 1:
            for i in prange(self.n_live, num_threads=self.threads, schedule="static"):
                self.rank_one(self.live[i])
            return
        for i in range(self.n_live):
            self.rank_one(self.live[i])
            if self.c.failed:
                return

    cdef inline void rank_one(self, int e) noexcept nogil:
        cdef int h, r, rc
        cdef double c, err
        cdef double p[3]
        if self.state[e] != ST_DIRTY:
            return
        rc = self.c.plan(e, &h, &r, p, &c, &err)
        if rc < 0:
            self.state[e] = ST_NONE
        elif self.c.SP != NULL and self.c.seam_h >= 0 and self.m.edge[h] != e:
            self.state[e] = ST_SIDE_B
        elif err > self.c.max_error:
            self.state[e] = ST_OVER
        else:
            self.state[e] = ST_VALID
            self.cost[e] = <float>c

    cdef int compact(self) noexcept nogil:
        """Drop dead edges from the live list; returns the number of valid candidates and
        fills the cost histogram of those."""
        cdef int i, e, n = 0, valid = 0
        memset(&self.hist[0], 0, N_BUCKETS * sizeof(int))
        for i in range(self.n_live):
            e = self.live[i]
            if not self.m.edge_alive[e]:
                continue
            self.live[n] = e
            n += 1
            if self.state[e] == ST_VALID:
                valid += 1
                self.hist[bucket_of(self.cost[e])] += 1
        self.n_live = n
        return valid

    cdef int select(self, int k) noexcept nogil:
        """The K cheapest valid candidates, sorted by (cost, edge), into keyed_buf; returns
        how many were gathered (>= k: the whole bucket holding the K-th is taken, then
        sorted, and the caller uses the first k)."""
        cdef int b, acc = 0, i, e, n = 0
        for b in range(N_BUCKETS):
            acc += self.hist[b]
            if acc >= k:
                break
        for i in range(self.n_live):
            e = self.live[i]
            if self.state[e] == ST_VALID and bucket_of(self.cost[e]) <= <unsigned int>b:
                self.keyed_buf[n].cost = self.cost[e]
                self.keyed_buf[n].edge = e
                n += 1
        qsort(&self.keyed_buf[0], n, sizeof(Keyed), compare_keyed)
        return n

    cdef void dirty_ring(self, int k) noexcept nogil:
        """After a collapse kept k: its edges (and, for wide kernels, its neighbours' edges)
        must be ranked again; so must the refused edges of its neighbours (the collapse may
        have made them legal)."""
        cdef int start = self.m.v_he[k]
        cdef int y = start
        cdef int ny, w
        self.c.refused[k] = 0
        while True:
            self.state[self.m.edge[y]] = ST_DIRTY
            w = he_dest(self.m, y)
            self.dirty_neighbour(w)
            ny = he_ring_next(self.m, y)
            if ny < 0:
                y = he_prev(y)
                self.state[self.m.edge[y]] = ST_DIRTY
                self.dirty_neighbour(self.m.corner[y])
                return
            if ny == start:
                return
            y = ny

    cdef void dirty_neighbour(self, int w) noexcept nogil:
        cdef int start, y, ny
        cdef bint all_edges = self.wide
        if not all_edges and not self.c.refused[w]:
            return
        self.c.refused[w] = 0
        start = self.m.v_he[w]
        y = start
        while True:
            if all_edges or self.state[self.m.edge[y]] == ST_REFUSED:
                self.state[self.m.edge[y]] = ST_DIRTY
            ny = he_ring_next(self.m, y)
            if ny < 0:
                y = he_prev(y)
                if all_edges or self.state[self.m.edge[y]] == ST_REFUSED:
                    self.state[self.m.edge[y]] = ST_DIRTY
                return
            if ny == start:
                return
            y = ny

    cdef int perform_pass(self, int n_sel, int target_faces, int* done) noexcept nogil:
        """Collapse the selected candidates in order, skipping those an earlier collapse of
        this pass touched.  RUN_TARGET once the target is reached, RUN_ERROR if a kernel
        failed, else RUN_CHUNK."""
        cdef int i, e, h, r, k, u, v, hs, rs, ks
        cdef double c, err
        cdef double p[3]
        cdef double dvol[2]
        cdef int stamp
        self.stamp += 1
        stamp = self.stamp
        self.c.pass_counter = stamp
        for i in range(n_sel):
            if self.c.hm.n_alive_faces <= target_faces:
                return RUN_TARGET
            e = self.keyed_buf[i].edge
            if not self.m.edge_alive[e] or self.state[e] != ST_VALID:
                continue
            h = self.m.edge_he[e]
            u = self.m.corner[h]
            v = he_dest(self.m, h)
            if self.c.touched[u] == stamp or self.c.touched[v] == stamp:
                continue
            # the plan is the one ranked (nothing around the edge changed since): planned
            # again here for the position and error, which the ranking does not keep
            if self.c.plan(e, &h, &r, p, &c, &err) < 0:
                if self.c.failed:
                    return RUN_ERROR
                self.state[e] = ST_NONE
                continue
            k = v if r == u else u
            if self.c.SP != NULL and self.c.seam_h >= 0:
                hs = self.c.seam_h
                rs = self.c.SP[r]
                ks = self.c.SP[k]
                if self.c.touched[rs] == stamp or self.c.touched[ks] == stamp:
                    continue
                if not self.c.pair_ok(h, r, k, hs, rs, ks, p, dvol):
                    self.refuse(e, r, k)
                    self.c.refused[rs] = 1
                    self.c.refused[ks] = 1
                    continue
                self.c.perform_pair(h, r, hs, rs, p, c, err, dvol)
                if self.c.failed:
                    return RUN_ERROR
                done[0] += 1
                self.c.mark_touched(k, stamp)
                self.c.mark_touched(ks, stamp)
                self.dirty_ring(k)
                self.dirty_ring(ks)
                continue
            if not self.c.hm.link_ok(h):
                self.c.n_rejected_topology += 1
                self.refuse(e, r, k)
                continue
            if not self.c.geometry_ok(h, r, k, p):
                self.c.n_rejected_geometry += 1
                self.refuse(e, r, k)
                continue
            self.c.perform(h, r, p, c, err)
            if self.c.failed:
                return RUN_ERROR
            done[0] += 1
            self.c.mark_touched(k, stamp)
            self.dirty_ring(k)
        if self.c.hm.n_alive_faces <= target_faces:
            return RUN_TARGET
        return RUN_CHUNK

    cdef inline void refuse(self, int e, int r, int k) noexcept nogil:
        self.state[e] = ST_REFUSED
        self.c.refused[r] = 1
        self.c.refused[k] = 1

    cdef int run_c(self, int target_faces, int max_steps) noexcept nogil:
        cdef int valid, k, n_sel, status, done, steps = 0, i, over
        while self.c.hm.n_alive_faces > target_faces:
            if steps >= max_steps:
                return RUN_CHUNK
            self.rank()
            if self.c.failed:
                return RUN_ERROR
            valid = self.compact()
            if valid == 0:
                over = 0
                for i in range(self.n_live):
                    if self.state[self.live[i]] == ST_OVER:
                        over += 1
                self.c.n_rejected_error = over
                return RUN_EXHAUSTED
            k = <int>((valid + self.fraction - 1.0) / self.fraction)
            if k < 1:
                k = 1
            n_sel = self.select(k)
            if n_sel > k:
                n_sel = k
            done = 0
            status = self.perform_pass(n_sel, target_faces, &done)
            self.n_passes += 1
            steps += done
            if status != RUN_CHUNK:
                return status
        return RUN_TARGET

    def run(self, int target_faces, int max_steps=2**31 - 1):
        """Collapse until ``target_faces`` live faces remain or nothing legal is left; or
        return after the pass in which ``max_steps`` collapses were reached (a chunk, for a
        progress bar: passes are never cut, so chunks do not change the result).  Returns 0
        (target), 1 (chunk done), 2 (exhausted) or 3 (a kernel failed)."""
        cdef int status
        with nogil:
            status = self.run_c(target_faces, max_steps)
        return status
