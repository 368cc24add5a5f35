# cython: language_level=3
"""The pass driver of batch metrics (``use_heap=False``): Python ranks every candidate at once
(``EdgeCollapser.plan_all`` and a vectorised cost), then one ``collapse_pass`` tries the
edges in that order, skipping those with an end an earlier collapse of the same pass touched
(the kept vertex and its 1-ring; the 2-ring for wide kernels), so that every collapse sees the
costs it was ranked with.  Each collapse is re-planned and checked as the heap driver's."""
import numpy as np
cimport numpy as cnp

from .halfedge cimport he_prev, he_dest, he_ring_next
from .kernel cimport Candidate, chain_cost, fill_candidate, KERNEL_OK, VERTEX_FIXED, VERTEX_BOUNDARY
from .common cimport QSIZE, VSTRIDE, BOUNDARY_FREE
from .quadric cimport collapse_error, quadric_eval
from .edge cimport EdgeCollapser, SEAM_NONE

cnp.import_array()


cdef class PassCollapser(EdgeCollapser):
    """Edge collapse driven in passes (made with ``use_heap=False``): the arguments of
    :class:`lodkit._core.edge.EdgeCollapser`."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.touched = np.zeros(self.hm.n_vertices if not self.opt.use_heap else 1, dtype=np.intc)
        self.pass_counter = 0

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
            ks = c.SP[k]
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
            mark_touched(c, k, stamp)
            mark_touched(c, ks, stamp)
            continue
        if PO != NULL and c.SP != NULL and (c.SP[u] != SEAM_NONE or c.SP[v] != SEAM_NONE):
            pass            # a seam vertex stays where it is, whatever a batch metric says
        elif PO != NULL and not ((c.vflags[u] | c.vflags[v])
                                 & (VERTEX_FIXED if c.opt.boundary == BOUNDARY_FREE else VERTEX_FIXED | VERTEX_BOUNDARY)):
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
                rc = chain_cost(c.kernel, &cand)
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
        mark_touched(c, k, stamp)
    return done


cdef void mark_touched(PassCollapser c, int k, int stamp) noexcept nogil:
    """Pass driver: mark the kept vertex k and its 1-ring (2-ring for wide kernels) as
    touched in this pass, so no later collapse of the pass sees stale costs there."""
    cdef int start = c.m.v_he[k]
    cdef int y = start
    cdef int ny
    c.touched[k] = stamp
    while True:
        if c.opt.wide_recost:
            touch_ring(c, he_dest(c.m, y), stamp)
        c.touched[he_dest(c.m, y)] = stamp
        ny = he_ring_next(c.m, y)
        if ny < 0:
            if c.opt.wide_recost:
                touch_ring(c, c.m.corner[he_prev(y)], stamp)
            c.touched[c.m.corner[he_prev(y)]] = stamp
            return
        if ny == start:
            return
        y = ny


cdef void touch_ring(PassCollapser c, int w, int stamp) noexcept nogil:
    """Mark w's neighbours touched in this pass (wide kernels: their costs changed)."""
    cdef int start = c.m.v_he[w]
    cdef int y = start
    cdef int ny
    while True:
        c.touched[he_dest(c.m, y)] = stamp
        ny = he_ring_next(c.m, y)
        if ny < 0:
            c.touched[c.m.corner[he_prev(y)]] = stamp
            return
        if ny == start:
            return
        y = ny
