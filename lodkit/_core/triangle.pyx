# cython: language_level=3
"""Triangle collapse (``operator=1``): the heap ranks faces.  A face (a, b, c) collapses to
one point p (the minimum of Q_a + Q_b + Q_c) as two edge collapses sharing the kept vertex
k: r1 -> k along the face's edge h1 (k moves to p), then r2 -> k along the edge k-r2 that
the first collapse leaves (k is at p already).  Both are checked before either is done: the
first as the edge driver checks it; the second against the state the first leaves, made for
real on the half-edge arrays and undone (``tri_ok``).  The face and its three neighbours
across its edges die: v - 2, f - 4 inside the surface.

The loop (``TriangleCollapser.run_c``): pop the cheapest face -> re-plan it (``plan_tri``)
-> check both collapses (``tri_ok``) -> do them (``perform_tri``) -> re-rank the faces
around the kept vertex.  Quadric metrics only: no fields, kernels nor batch metrics (their
values are defined per edge).
"""
import numpy as np
cimport numpy as cnp
from libc.math cimport INFINITY

from .halfedge cimport he_next, he_prev, he_dest, he_ring_next
from .vec3 cimport dot3
from lodkit.kernel cimport VERTEX_FIXED, VERTEX_BOUNDARY
from .common cimport QSIZE, VSTRIDE, RUN_TARGET, RUN_CHUNK, RUN_EXHAUSTED, BOUNDARY_PRESERVE, PLACE_ENDPOINT
from .quadric cimport (sq, collapse_error, quadric_eval, take_if_lower, quadric_solve, quadric_solve_truncated,
                       within_reach3)
from .edge cimport EdgeCollapser, SEAM_NONE
from .common cimport RUN_INTERRUPTED
from .interrupt cimport signal_pending, INTERRUPT_EVERY

cnp.import_array()


cdef class TriangleCollapser(EdgeCollapser):
    """Triangle collapse over a :class:`HalfEdgeMesh` (modified in place): the arguments of
    :class:`lodkit._core.edge.EdgeCollapser`; quadric metrics only (no fields, kernels, nor
    ``use_heap=False``)."""

    def __init__(self, *args, **kwargs):
        self.tri_collapses = 0
        self.tri_refused_second = 0
        super().__init__(*args, **kwargs)
        if self.bound is not None:
            raise ValueError("triangle collapse does not take an error bound (use operator='edge')")
        if self.opt.has_extras or not self.opt.use_heap:
            raise ValueError("triangle collapse takes quadric metrics only: no fields, kernels "
                             "nor batch metrics (their values are defined per edge)")

    cdef int n_candidates(self):
        """The heap's capacity: one candidate per face."""
        return self.hm.n_faces

    cdef void rescan(self) noexcept nogil:
        """Rebuild the heap from every live face that may collapse."""
        cdef int f, h, r, r2
        cdef double p[3]
        cdef double cost
        self.heap.clear_fast()
        self.n_vetoed = 0
        for f in range(self.hm.n_faces):
            if self.m.face_alive[f] and self.plan_tri(f, &h, &r, &r2, p, &cost, NULL) == 0:
                self.heap.append_unordered(f, cost)
        self.heap.heapify_fast()
        self.collapses_since_rescan = 0
        self.n_rejected_error = 0
        self.n_rejected_topology = 0
        self.n_rejected_geometry = 0

    cdef void drop_dead(self, const int* dead) noexcept nogil:
        pass            # the heap holds faces: perform_tri drops the dead ones

    cdef int plan_tri(self, int f, int* h_out, int* r_out, int* r2_out, double* p, double* cost,
                      double* err) noexcept nogil:
        """Cost and placement of collapsing face ``f`` to one point, and the two collapses
        that do it: ``h_out`` (an edge of f: the first collapse), ``r_out`` (the end of it
        that goes first; the other end is kept), ``r2_out`` (the third corner, which goes
        second).  -1 if the face may not collapse.

        The fixed rules, per corner: fixed (locked, split, ``lock``-policy boundary) and
        seam vertices may not move nor go; under ``preserve`` a lone boundary corner is held
        too.  Two held corners: no collapse; one: everything goes to it.  With two or three
        corners on the border the first collapse runs along a boundary edge of the face
        (through the held corner, if any) -- an interior edge between border vertices would
        pinch the surface -- and, for ``placement="endpoint"`` under ``preserve``, p is one
        of that edge's ends (a border vertex is not pulled onto an interior one)."""
        cdef int v[3]
        cdef bint fx[3]
        cdef bint bd[3]
        cdef int i, j, i0, i1, ik, ib, h, nb = 0, nf = 0, kf = -1, first = -1
        cdef double q[QSIZE]
        cdef double qg[QSIZE]
        cdef double cand[3]
        cdef double c, best, d, dbest
        if not self.m.face_alive[f]:
            return -1
        for i in range(3):
            v[i] = self.m.corner[3 * f + i]
            fx[i] = (self.vflags[v[i]] & VERTEX_FIXED) != 0 or (self.SP != NULL and self.SP[v[i]] != SEAM_NONE)
            bd[i] = (self.vflags[v[i]] & VERTEX_BOUNDARY) != 0
            if bd[i]:
                nb += 1
        if self.opt.boundary == BOUNDARY_PRESERVE and nb == 1:
            for i in range(3):
                if bd[i]:
                    fx[i] = True            # the face is pulled to its one border corner
        for i in range(3):
            if fx[i]:
                nf += 1
                kf = i
        if nf >= 2:
            return -1
        if nb >= 2:
            for i in range(3):
                h = 3 * f + i
                if self.m.twin[h] >= 0:
                    continue
                if kf >= 0 and kf != i and kf != (i + 1) % 3:
                    continue
                first = h
                break
            if first < 0:
                return -1
        for i in range(QSIZE):
            q[i] = (self.Q[VSTRIDE * v[0] + i] + self.Q[VSTRIDE * v[1] + i]) + self.Q[VSTRIDE * v[2] + i]
        if self.aq.dim > 0:
            for i in range(QSIZE):
                qg[i] = q[i]
            self.aq.marginal3(v[0], v[1], v[2], q)
        if kf >= 0:
            for i in range(3):
                p[i] = self.P[VSTRIDE * v[kf] + i]
            c = quadric_eval(q, p)
        elif self.opt.placement == PLACE_ENDPOINT:
            ib = -1
            best = INFINITY
            for j in range(3):
                if (first >= 0 and nb == 2 and self.opt.boundary == BOUNDARY_PRESERVE
                        and j == (first - 3 * f + 2) % 3):
                    continue                # the interior corner: the border would move in
                c = quadric_eval(q, &self.P[VSTRIDE * v[j]])
                if ib < 0 or c < best or (c == best and v[j] < v[ib]):
                    best = c
                    ib = j
            for i in range(3):
                p[i] = self.P[VSTRIDE * v[ib] + i]
            c = best
        else:
            if quadric_solve(q, p) and within_reach3(p, &self.P[VSTRIDE * v[0]], &self.P[VSTRIDE * v[1]],
                                                     &self.P[VSTRIDE * v[2]]):
                c = quadric_eval(q, p)
            else:
                # fallback: the best of the truncated solve about the centroid (if within
                # reach), the three corners and the centroid
                for i in range(3):
                    cand[i] = (self.P[VSTRIDE * v[0] + i] + self.P[VSTRIDE * v[1] + i]
                               + self.P[VSTRIDE * v[2] + i]) / 3.0
                quadric_solve_truncated(q, cand, p)
                if within_reach3(p, &self.P[VSTRIDE * v[0]], &self.P[VSTRIDE * v[1]], &self.P[VSTRIDE * v[2]]):
                    best = quadric_eval(q, p)
                else:
                    for i in range(3):
                        p[i] = cand[i]
                    best = quadric_eval(q, p)
                for j in range(3):
                    take_if_lower(q, &self.P[VSTRIDE * v[j]], p, &best)
                take_if_lower(q, cand, p, &best)
                c = best
        if c < 0.0:
            c = 0.0
        # the kept slot: the held corner, else the corner nearest to p (provenance), one of
        # the first edge's ends when that edge is prescribed
        ik = kf
        if ik < 0:
            dbest = INFINITY
            for j in range(3):
                if first >= 0 and j != first - 3 * f and j != (first - 3 * f + 1) % 3:
                    continue
                d = (sq(p[0] - self.P[VSTRIDE * v[j]]) + sq(p[1] - self.P[VSTRIDE * v[j] + 1])
                     + sq(p[2] - self.P[VSTRIDE * v[j] + 2]))
                if ik < 0 or d < dbest or (d == dbest and v[j] < v[ik]):
                    dbest = d
                    ik = j
        if first < 0:
            first = 3 * f + ik              # the first collapse: k's edge to the next corner
        i0 = first - 3 * f
        i1 = (i0 + 1) % 3
        h_out[0] = first
        r_out[0] = v[i1] if ik == i0 else v[i0]
        r2_out[0] = v[(i0 + 2) % 3]
        if err != NULL:
            err[0] = collapse_error(quadric_eval(qg, p) if self.aq.dim > 0 else c, q[10], self.opt.error_scale)
        cost[0] = self.opt.quadric_weight * c
        return 0

    cdef int find_he(self, int k, int w) noexcept nogil:
        """A half-edge of edge k-w (either way), -1 if there is none."""
        cdef int start = self.m.v_he[k]
        cdef int y = start
        cdef int ny
        while True:
            if he_dest(self.m, y) == w:
                return y
            ny = he_ring_next(self.m, y)
            if ny < 0:
                y = he_prev(y)
                return y if self.m.corner[y] == w else -1
            if ny == start:
                return -1
            y = ny

    cdef bint tri_ok(self, int h1, int r1, int k, int r2, const double* p, int* h2_out,
                     int* dead_faces, double* dvol) noexcept nogil:
        """May the face of ``h1`` collapse as r1 -> k (k to p), then r2 -> k?  The first
        collapse gets the edge driver's checks (link condition, moved faces, volume); then
        it is done on the half-edge arrays (k at p), the second is checked the same way
        against that state, and the first is undone: every entry ``HalfEdgeMesh.collapse``
        writes is saved before and written back after (r1's corners by walking its fan
        again once the twins are back).  Fills ``h2_out`` (the second collapse's
        half-edge, valid once the first is done), ``dead_faces[0..3]`` (the four faces that
        die, -1 for none on a border) and ``dvol[0..1]``; counts the refusals."""
        cdef int* ip[16]
        cdef int iv[16]
        cdef unsigned char* bp[8]
        cdef unsigned char bv[8]
        cdef int ni = 0, nb = 0, i, x, s, d, y, ny, start, h2, skip_c, skip_d
        cdef int dead[3]
        cdef int merged[2]
        cdef double saved_p[3]
        cdef unsigned char saved_signs
        cdef double saved_vol = self.closed_volume
        cdef int saved_faces = self.hm.n_alive_faces
        cdef int saved_verts = self.hm.n_alive_vertices
        cdef bint ok = True
        if not self.hm.link_ok(h1):
            self.n_rejected_topology += 1
            return False
        # the faces across the face's other two edges die in the second collapse: the first
        # one's check counts their volume but does not judge their passing shape
        x = h1 - 3 * (h1 // 3)
        s = self.m.twin[3 * (h1 // 3) + (x + 1) % 3]
        d = self.m.twin[3 * (h1 // 3) + (x + 2) % 3]
        skip_c = s // 3 if s >= 0 else -1
        skip_d = d // 3 if d >= 0 else -1
        if not self.geometry_ok(h1, r1, k, p, skip_c, skip_d, &dvol[0]):
            self.n_rejected_geometry += 1
            return False
        dead_faces[0] = h1 // 3
        dead_faces[1] = self.m.twin[h1] // 3 if self.m.twin[h1] >= 0 else -1
        dead_faces[2] = -1
        dead_faces[3] = -1
        # what collapse(h1, r1) writes, as it computes it (halfedge.pyx)
        for i in range(2):
            x = h1 if i == 0 else self.m.twin[h1]
            if x < 0:
                continue
            if self.m.corner[x] == r1:
                s = he_next(x)
                d = he_prev(x)
            else:
                s = he_prev(x)
                d = he_next(x)
            if self.m.twin[s] >= 0:
                ip[ni] = &self.m.twin[self.m.twin[s]]
                ni += 1
            if self.m.twin[d] >= 0:
                ip[ni] = &self.m.twin[self.m.twin[d]]
                ip[ni + 1] = &self.m.edge[self.m.twin[d]]
                ni += 2
            ip[ni] = &self.m.edge_he[self.m.edge[s]]
            ip[ni + 1] = &self.m.v_he[self.m.corner[he_prev(x)]]
            ni += 2
            bp[nb] = &self.m.edge_alive[self.m.edge[d]]
            bp[nb + 1] = &self.m.face_alive[x // 3]
            nb += 2
        ip[ni] = &self.m.v_he[k]
        ni += 1
        bp[nb] = &self.m.edge_alive[self.m.edge[h1]]
        bp[nb + 1] = &self.m.vertex_alive[r1]
        nb += 2
        for i in range(ni):
            iv[i] = ip[i][0]
        for i in range(nb):
            bv[i] = bp[i][0]
        self.hm.collapse(h1, r1, dead, merged)
        saved_signs = self.NS[k]
        self.merge_signs(r1, k)                    # k's fan holds r1's faces now (the knife test)
        for i in range(3):
            saved_p[i] = self.P[VSTRIDE * k + i]
            self.P[VSTRIDE * k + i] = p[i]
        if self.closed_volume != 0.0:
            self.closed_volume += dvol[0]
        h2 = self.find_he(k, r2)
        if h2 < 0 or not self.hm.link_ok(h2):
            self.n_rejected_topology += 1
            ok = False
        else:
            dead_faces[2] = h2 // 3
            dead_faces[3] = self.m.twin[h2] // 3 if self.m.twin[h2] >= 0 else -1
            if not self.geometry_ok(h2, r2, k, p, -1, -1, &dvol[1]):
                self.n_rejected_geometry += 1
                ok = False
        if not ok:
            self.tri_refused_second += 1
        # undo the first collapse
        self.closed_volume = saved_vol
        self.NS[k] = saved_signs
        for i in range(3):
            self.P[VSTRIDE * k + i] = saved_p[i]
        for i in range(ni - 1, -1, -1):
            ip[i][0] = iv[i]
        for i in range(nb - 1, -1, -1):
            bp[i][0] = bv[i]
        start = self.m.v_he[r1]
        y = start
        while True:
            self.m.corner[y] = r1
            ny = he_ring_next(self.m, y)
            if ny < 0 or ny == start:
                break
            y = ny
        self.hm.n_alive_faces = saved_faces
        self.hm.n_alive_vertices = saved_verts
        h2_out[0] = h2
        return ok

    cdef void perform_tri(self, int h1, int r1, int h2, int r2, const double* p, double cost,
                          double err, const int* dead_faces, const double* dvol) noexcept nogil:
        """Do the two collapses ``tri_ok`` passed, then drop the dead faces from the heap and
        re-rank the faces around the kept vertex.  The attributes (and vertex fields' merge
        rules, edge by edge) follow the two collapses; the attribute weights are p's
        barycentric coordinates over the face (clamped to it), so that k ends with
        l_k A_k + l_r1 A_r1 + l_r2 A_r2.  Both collapses are recorded, the first marked as
        half of one step (``rec_open``), with the triangle's cost and error."""
        cdef int k = he_dest(self.m, h1) if self.m.corner[h1] == r1 else self.m.corner[h1]
        cdef double e0[3]
        cdef double e1[3]
        cdef double w[3]
        cdef double d00, d01, d11, d20, d21, den, l0, l1, l2, t1 = -1.0, t2 = -1.0
        cdef int i
        for i in range(3):
            e0[i] = self.P[VSTRIDE * r1 + i] - self.P[VSTRIDE * k + i]
            e1[i] = self.P[VSTRIDE * r2 + i] - self.P[VSTRIDE * k + i]
            w[i] = p[i] - self.P[VSTRIDE * k + i]
        d00 = dot3(e0, e0)
        d01 = dot3(e0, e1)
        d11 = dot3(e1, e1)
        d20 = dot3(w, e0)
        d21 = dot3(w, e1)
        den = d00 * d11 - d01 * d01
        if den > 1e-12 * d00 * d11:
            l1 = (d11 * d20 - d01 * d21) / den
            l2 = (d00 * d21 - d01 * d20) / den
            l0 = 1.0 - l1 - l2
            l0 = l0 if l0 > 0.0 else 0.0
            l1 = l1 if l1 > 0.0 else 0.0
            l2 = l2 if l2 > 0.0 else 0.0
            den = l0 + l1 + l2
            l0 /= den
            l1 /= den
            t1 = l0 / (l0 + l1) if l0 + l1 > 0.0 else 1.0
            t2 = l0 + l1
        self.perform(h1, r1, p, cost, err, t1, dvol[0], False)
        if self.rec.on:
            self.rec.pair_open[self.n_collapses - 1] = 1
        self.perform(h2, r2, p, cost, err, t2, dvol[1], False)
        self.tri_collapses += 1
        for i in range(4):
            if dead_faces[i] >= 0:
                self.heap.remove_fast(dead_faces[i])
        self.rerank_tri(k)

    cdef void recost_face(self, int f) noexcept nogil:
        cdef int h, r, r2
        cdef double p[3]
        cdef double cost
        if self.plan_tri(f, &h, &r, &r2, p, &cost, NULL) == 0:
            self.heap.push_fast(f, cost)
        else:
            self.heap.remove_fast(f)

    cdef void rerank_tri(self, int k) noexcept nogil:
        """After a triangle collapse kept ``k``: re-rank the faces around k (their corners'
        quadrics or positions changed; no other face's did), and give the refused faces of
        k's neighbours another chance."""
        cdef int start = self.m.v_he[k]
        cdef int y = start
        cdef int ny
        self.refused[k] = 0
        while True:
            self.recost_face(y // 3)
            self.retry_refused_tri(he_dest(self.m, y))
            ny = he_ring_next(self.m, y)
            if ny < 0:
                self.retry_refused_tri(self.m.corner[he_prev(y)])
                return
            if ny == start:
                return
            y = ny

    cdef void retry_refused_tri(self, int w) noexcept nogil:
        cdef int start, y, ny
        if not self.refused[w]:
            return
        self.refused[w] = 0
        start = self.m.v_he[w]
        y = start
        while True:
            if not self.heap.contains_fast(y // 3):
                self.recost_face(y // 3)
            ny = he_ring_next(self.m, y)
            if ny < 0 or ny == start:
                return
            y = ny

    cdef int run_c(self, int target_faces, int max_steps) noexcept nogil:
        """Triangle collapse: pop the cheapest face, re-plan it, check both
        collapses, do them; ``max_steps`` counts triangle collapses."""
        cdef int f, h1, r1, r2, h2, k, steps = 0, n_iter = 0
        cdef int dead_faces[4]
        cdef double cost, err
        cdef double p[3]
        cdef double dvol[2]
        while self.hm.n_alive_faces > target_faces:
            n_iter += 1
            if n_iter % INTERRUPT_EVERY == 0 and signal_pending():
                return RUN_INTERRUPTED
            if steps >= max_steps:
                return RUN_CHUNK
            if not self.pop_candidate(&f):
                return RUN_EXHAUSTED
            if self.plan_tri(f, &h1, &r1, &r2, p, &cost, &err) < 0:
                continue
            if err > self.opt.max_error:
                self.n_rejected_error += 1
                continue
            k = he_dest(self.m, h1) if self.m.corner[h1] == r1 else self.m.corner[h1]
            dvol[0] = 0.0
            dvol[1] = 0.0
            if not self.tri_ok(h1, r1, k, r2, p, &h2, dead_faces, dvol):
                self.refused[k] = 1
                self.refused[r1] = 1
                self.refused[r2] = 1
                continue
            self.perform_tri(h1, r1, h2, r2, p, cost, err, dead_faces, dvol)
            steps += 1
        return RUN_TARGET

    # ------------------------------------------------------------- Python API
    def plan_face(self, int f):
        """``(kept, first, second, position, cost, error)`` for collapsing face ``f`` (a
        triangle-collapse EdgeCollapser): the kept vertex slot, the corner removed by the
        first collapse and the one removed by the second; None if it may not collapse.
        Checks nothing but the fixed/boundary rules; for tests."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        if not 0 <= f < self.hm.n_faces:
            raise ValueError(f"face ids must be in 0..{self.hm.n_faces - 1}")
        cdef int h, r, r2
        cdef double p[3]
        cdef double cost, err
        if self.plan_tri(f, &h, &r, &r2, p, &cost, &err) < 0:
            return None
        k = self.hm.dest(h) if self.hm.corner[h] == r else self.hm.corner[h]
        return k, r, r2, np.array([p[0], p[1], p[2]]), cost, err

    def check_face(self, int f):
        """Would face ``f`` collapse now (plan, max_error and both collapses' checks, as
        the driver does them)?  True / False; nothing is changed (the first collapse is
        done and undone inside).  For tests."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        if not 0 <= f < self.hm.n_faces:
            raise ValueError(f"face ids must be in 0..{self.hm.n_faces - 1}")
        cdef int h1, r1, r2, h2, k
        cdef int dead_faces[4]
        cdef double p[3]
        cdef double dvol[2]
        cdef double cost, err
        cdef bint ok
        with nogil:
            ok = self.plan_tri(f, &h1, &r1, &r2, p, &cost, &err) == 0 and err <= self.opt.max_error
            if ok:
                k = he_dest(self.m, h1) if self.m.corner[h1] == r1 else self.m.corner[h1]
                ok = self.tri_ok(h1, r1, k, r2, p, &h2, dead_faces, dvol)
        return bool(ok)

    @property
    def n_tri_collapses(self):
        """Triangle collapses done (two edge collapses each)."""
        return self.tri_collapses

    @property
    def n_tri_refused_second(self):
        """Triangle candidates that passed the first collapse's checks and failed the second's."""
        return self.tri_refused_second
