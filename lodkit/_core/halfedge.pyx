# cython: language_level=3
"""Half-edge arrays: O(m) construction, 1-ring walks, the link condition and edge collapse.

Non-manifold input is cut into a manifold-with-border structure: an edge with more than two
faces, or whose two faces run it in the same direction, becomes one boundary edge per face;
a vertex whose faces form several fans gets one vertex slot per fan.  Vertices touched by
either repair are locked (they never move and are never removed) so that welding the copies
back on output restores the input's non-manifold configuration exactly.
"""
from cython.parallel cimport prange, threadid
from libc.stdlib cimport qsort
from libc.string cimport memset
import numpy as np
cimport numpy as cnp

from .common cimport MAX_VALENCE, PARALLEL_MIN_VERTICES, insertion_sort, prefetch

cnp.import_array()


cdef inline int _take_neighbour(int* ring, int n, int w, int u, int v) noexcept nogil:
    """1 if w (not u nor v) is in ring[:n], which then forgets it (a neighbour counts once,
    even across parallel edges); else 0."""
    cdef int i, found = 0
    if w == u or w == v:
        return 0
    for i in range(n):
        if ring[i] == w:
            ring[i] = -1
            found = 1
    return found


cdef class HalfEdgeMesh:
    """Half-edge connectivity of a triangle mesh.  Build with :func:`build`."""

    # --------------------------------------------------------------- navigation
    cdef inline int dest(self, int h) noexcept nogil:
        return he_dest(&self.c, h)

    cdef inline int ring_next(self, int h) noexcept nogil:
        return he_ring_next(&self.c, h)

    cdef inline bint is_boundary(self, int v) noexcept nogil:
        return he_is_boundary(&self.c, v)

    cdef inline int source(self, int v) noexcept nogil:
        """The input vertex of slot ``v`` (itself unless it is a copy of a split vertex)."""
        return self.vertex_source[v] if self.has_copies else v

    cdef void _bind(self) noexcept:
        """Point the raw views at the arrays (after the arrays are set)."""
        self.c.corner = &self.corner[0]
        self.c.twin = &self.twin[0]
        self.c.edge = &self.edge[0]
        self.c.edge_he = &self.edge_he[0] if self.edge_he.shape[0] else NULL
        self.c.v_he = &self.v_he[0]
        self.c.face_alive = &self.face_alive[0]
        self.c.vertex_alive = &self.vertex_alive[0]
        self.c.edge_alive = &self.edge_alive[0] if self.edge_alive.shape[0] else NULL

    cdef int valence(self, int v) noexcept nogil:
        cdef int start = self.c.v_he[v]
        cdef int h = start
        cdef int n = 0
        while True:
            n += 1
            h = self.ring_next(h)
            if h < 0:
                return n + 1        # the boundary fan ends with one more neighbour
            if h == start:
                return n

    cdef int find_fan_start(self, int h) noexcept nogil:
        """From outgoing ``h``, walk backwards to the fan's boundary half-edge (or back to h)."""
        cdef int start = h
        cdef int t
        while True:
            t = self.c.twin[h]
            if t < 0:
                return h
            h = he_next(t)
            if h == start:
                return h

    cdef int _mark_ring(self, int v) noexcept nogil:
        """Stamp the input vertex (source) of every neighbour of slot ``v``; returns the
        number of neighbours (the valence)."""
        cdef int start = self.c.v_he[v]
        cdef int x = start
        cdef int nx, n = 0
        while True:
            self.stamp[self.source(self.dest(x))] = self.stamp_counter
            n += 1
            nx = self.ring_next(x)
            if nx < 0:
                self.stamp[self.source(self.c.corner[he_prev(x)])] = self.stamp_counter
                return n + 1
            x = nx
            if x == start:
                return n

    cdef int _count_marked(self, int v, int su, int sv) noexcept nogil:
        """Count the marked sources around slot ``v`` (other than su, sv), each once."""
        cdef int start = self.c.v_he[v]
        cdef int x = start
        cdef int nx, w, n = 0
        while True:
            w = self.source(self.dest(x))
            if w != su and w != sv and self.stamp[w] == self.stamp_counter:
                n += 1
                self.stamp[w] = 0       # count a neighbour once, even across parallel edges
            nx = self.ring_next(x)
            if nx < 0:
                w = self.source(self.c.corner[he_prev(x)])
                if w != su and w != sv and self.stamp[w] == self.stamp_counter:
                    n += 1
                    self.stamp[w] = 0
                return n
            x = nx
            if x == start:
                return n

    cdef bint link_ok(self, int h) noexcept nogil:
        """Can the edge of ``h`` collapse without changing the topology?

        The link condition (Dey et al.): the vertices adjacent to both ends are exactly the
        opposite vertices of the edge's faces; plus: no interior edge between two boundary
        vertices (that would pinch the surface), no isolated triangle, no tetrahedron.

        Neighbours are compared by input vertex, over every copy of a split vertex, so the
        condition holds for the mesh as it is welded on output: a collapse next to a split
        vertex cannot create an edge that the copies would then share.
        """
        cdef int u = self.c.corner[h]
        cdef int v = self.dest(h)
        cdef int su = self.source(u)
        cdef int sv = self.source(v)
        cdef int common, x, valence_u0
        cdef int expected = self._link_expected(h)
        if expected < 0:
            return False
        if not self.has_copies:
            # no split copies: the scratch-free count, which threads may run at once
            common = self._count_common_local(u, v, &valence_u0)
            if common >= 0:
                return self._link_tail(h, common, expected, valence_u0)
        self.stamp_counter += 1
        if self.stamp_counter == 0x7fffffff:
            self.stamp[:] = 0
            self.stamp_counter = 1
        cdef int valence_u = self._mark_ring(u)
        if self.has_copies:
            x = self.next_copy[u]
            while x >= 0 and x != u:
                self._mark_ring(x)
                x = self.next_copy[x]
        common = self._count_marked(v, su, sv)
        if self.has_copies:
            x = self.next_copy[v]
            while x >= 0 and x != v:
                common += self._count_marked(x, su, sv)
                x = self.next_copy[x]
        if not self._link_tail(h, common, expected, valence_u):
            return False
        if self.has_copies and self._faces_would_coincide(u, v):
            return False    # the welded mesh would get two faces on the same three vertices
        return True

    cdef int _link_expected(self, int h) noexcept nogil:
        """The common neighbours the link condition wants for the edge of ``h`` (1 on the
        boundary, 2 inside), or -1 where the edge may not collapse whatever the counts: an
        isolated triangle, an interior edge between two boundary vertices (it would pinch the
        surface), two faces sharing their third vertex (a two-face pillow)."""
        cdef int hb = self.c.twin[h]
        if hb < 0:
            if self.c.twin[he_next(h)] < 0 and self.c.twin[he_prev(h)] < 0:
                return -1
            return 1
        if self.is_boundary(self.c.corner[h]) and self.is_boundary(self.dest(h)):
            return -1
        if (self.source(self.c.corner[he_prev(h)])
                == self.source(self.c.corner[he_prev(hb)])):
            return -1
        return 2

    cdef bint _link_tail(self, int h, int common, int expected, int valence_u) noexcept nogil:
        """The rest of the link condition once the common neighbours are counted: exactly
        ``expected`` of them, and no tetrahedron (``valence_u`` < 0: count it here)."""
        cdef int u = self.c.corner[h]
        cdef int v = self.dest(h)
        if common != expected:
            return False
        if self.c.twin[h] >= 0 and not self.is_boundary(u) and not self.is_boundary(v):
            if valence_u < 0:
                valence_u = self.valence(u)
            if valence_u == 3 and self.valence(v) == 3:
                return False    # the two ends and their common neighbours form a tetrahedron
        return True

    cdef int _count_common_local(self, int u, int v, int* valence_u) noexcept nogil:
        """The neighbours of u that are also neighbours of v (u, v themselves not counted,
        each once), without the shared stamp array, so threads can ask at once; -1 when u has
        more than MAX_VALENCE neighbours (then the stamps count).  Slots are vertices here
        (no split copies).  ``valence_u`` gets u's valence (its ring's length, as
        ``valence``), which the tetrahedron test would otherwise walk again."""
        cdef int ring[MAX_VALENCE + 1]
        cdef int n = 0, common = 0, nx
        cdef int start = self.c.v_he[u]
        cdef int x = start
        while True:
            if n >= MAX_VALENCE:
                return -1
            ring[n] = self.dest(x)
            n += 1
            nx = self.ring_next(x)
            if nx < 0:
                ring[n] = self.c.corner[he_prev(x)]     # the boundary fan's last neighbour
                n += 1
                break
            x = nx
            if x == start:
                break
        valence_u[0] = n
        start = self.c.v_he[v]
        x = start
        while True:
            common += _take_neighbour(ring, n, self.dest(x), u, v)
            nx = self.ring_next(x)
            if nx < 0:
                return common + _take_neighbour(ring, n, self.c.corner[he_prev(x)], u, v)
            x = nx
            if x == start:
                return common

    cdef bint _faces_would_coincide(self, int u, int v) noexcept nogil:
        """Is there a face (u, b, c) and a face (v, b, c), by input vertex, over all copies of
        u and v?  Collapsing u-v would make them one face twice.  O(valence^2); only asked
        for meshes that have split vertices."""
        cdef int sv = self.source(v)
        cdef int x, y, hx, hy, sx, ex, bx, cx, by, cy
        x = u
        while True:
            hx = self.c.v_he[x]
            sx = hx
            while True:
                bx = self.source(self.dest(hx))
                cx = self.source(self.c.corner[he_prev(hx)])
                if bx != sv and cx != sv:
                    y = v
                    while True:
                        hy = self.c.v_he[y]
                        ex = hy
                        while True:
                            by = self.source(self.dest(hy))
                            cy = self.source(self.c.corner[he_prev(hy)])
                            if (by == bx and cy == cx) or (by == cx and cy == bx):
                                return True
                            hy = self.ring_next(hy)
                            if hy < 0 or hy == ex:
                                break
                        y = self.next_copy[y]
                        if y < 0 or y == v:
                            break
                hx = self.ring_next(hx)
                if hx < 0 or hx == sx:
                    break
            x = self.next_copy[x]
            if x < 0 or x == u:
                return False

    cdef int collapse(self, int h, int removed, int* dead_edges, int* merged_into) noexcept nogil:
        """Collapse the edge of ``h`` (see :meth:`collapse_uncounted`) and count what went."""
        cdef int faces = 2 if self.c.twin[h] >= 0 else 1
        cdef int k = self.collapse_uncounted(h, removed, dead_edges, merged_into)
        self.n_alive_faces -= faces
        self.n_alive_vertices -= 1
        return k

    cdef int collapse_uncounted(self, int h, int removed, int* dead_edges, int* merged_into) noexcept nogil:
        """Collapse the edge of ``h``; ``removed`` (one of its ends) goes, the other stays.
        The live counts are not updated (the caller does: collapses of disjoint closed
        1-rings may run on several threads at once, and write nothing outside them).

        Returns the kept vertex.  ``dead_edges`` receives the ids of the edges that vanish
        (the collapsed edge, then one per removed face; -1 for unused slots).  When not NULL,
        ``merged_into[i]`` receives the edge that ``dead_edges[1 + i]`` was glued onto (the
        surviving edge kept-c of the removed face), or -1.  The caller has checked
        ``link_ok(h)``.
        """
        cdef int r = removed
        cdef int k = self.dest(h) if self.c.corner[h] == r else self.c.corner[h]
        cdef int xs[2]
        cdef int ts[2]
        cdef int td[2]
        cdef int es[2]
        cdef int opp[2]
        cdef int i, x, s, d, start, y, ny, hk, hc
        cdef bint r_border = self.c.twin[self.c.v_he[r]] < 0
        xs[0] = h
        xs[1] = self.c.twin[h]
        dead_edges[0] = self.c.edge[h]
        dead_edges[1] = -1
        dead_edges[2] = -1
        if merged_into != NULL:
            merged_into[0] = -1
            merged_into[1] = -1
        for i in range(2):
            x = xs[i]
            if x < 0:
                continue
            if self.c.corner[x] == r:      # x: r -> k, next(x): k -> c survives, prev(x): c -> r dies
                s = he_next(x)
                d = he_prev(x)
            else:                        # x: k -> r, prev(x): c -> k survives, next(x): r -> c dies
                s = he_prev(x)
                d = he_next(x)
            ts[i] = self.c.twin[s]
            td[i] = self.c.twin[d]
            es[i] = self.c.edge[s]
            dead_edges[1 + i] = self.c.edge[d]
            if merged_into != NULL:
                merged_into[i] = es[i]
            opp[i] = self.c.corner[he_prev(x)]
        # 1. every half-edge leaving r now leaves k (walk r's fan before the twins change)
        start = self.c.v_he[r]
        y = start
        while True:
            self.c.corner[y] = k
            ny = self.ring_next(y)
            if ny < 0 or ny == start:
                break
            y = ny
        # 2. glue the outer twins of each removed face: two edges become one
        for i in range(2):
            x = xs[i]
            if x < 0:
                continue
            if ts[i] >= 0:
                self.c.twin[ts[i]] = td[i]
            if td[i] >= 0:
                self.c.twin[td[i]] = ts[i]
                self.c.edge[td[i]] = es[i]
            self.c.edge_he[es[i]] = ts[i] if ts[i] >= 0 else td[i]
            self.c.edge_alive[dead_edges[1 + i]] = 0
            self.c.face_alive[x // 3] = 0
        self.c.edge_alive[dead_edges[0]] = 0
        self.c.vertex_alive[r] = 0
        # 3. re-anchor v_he of k and of the opposite vertices where it went with a removed
        #    face (or, for k, where it inherits r's border): the glued edge k-c has a
        #    half-edge k -> c and/or c -> k, and either gives one leaving each end
        for i in range(2):
            x = xs[i]
            if x < 0:
                continue
            hk = ts[i] if ts[i] >= 0 and self.c.corner[ts[i]] == k else td[i]
            hc = td[i] if hk == ts[i] else ts[i]
            if hk >= 0 and self.c.corner[hk] != k:
                hk, hc = hc, hk
            if r_border or not self.c.face_alive[self.c.v_he[k] // 3]:
                self.c.v_he[k] = self.find_fan_start(hk if hk >= 0 else he_next(hc))
            if not self.c.face_alive[self.c.v_he[opp[i]] // 3]:
                self.c.v_he[opp[i]] = self.find_fan_start(hc if hc >= 0 else he_next(hk))
        return k

    # ------------------------------------------------------------- Python API
    @property
    def corners(self):
        """(n_faces, 3) int32 view of the face slots (dead faces keep stale values)."""
        return np.asarray(self.corner).reshape(-1, 3)

    @property
    def twins(self):
        return np.asarray(self.twin)

    @property
    def edges(self):
        return np.asarray(self.edge)

    @property
    def edge_halfedges(self):
        return np.asarray(self.edge_he)

    @property
    def vertex_halfedges(self):
        return np.asarray(self.v_he)

    @property
    def boundary_vertices(self):
        """(n_vertices,) bool: the vertex slots whose fan starts at a boundary half-edge."""
        vhe = np.asarray(self.v_he)
        return (vhe >= 0) & (np.asarray(self.twin)[np.maximum(vhe, 0)] < 0)

    @property
    def vertex_sources(self):
        """(n_vertices,) int32: for each vertex slot, the input vertex it copies."""
        if not self.has_copies:
            return np.arange(self.n_vertices, dtype=np.intc)
        return np.asarray(self.vertex_source)

    @property
    def locked_vertices(self):
        return np.asarray(self.locked).astype(bool)

    @property
    def alive_faces(self):
        return np.asarray(self.face_alive).astype(bool)

    @property
    def alive_vertices(self):
        return np.asarray(self.vertex_alive).astype(bool)

    @property
    def alive_edges(self):
        return np.asarray(self.edge_alive).astype(bool)

    def faces(self):
        """(k, 3) int32 array of the live faces, in face-slot order."""
        return self.corners[self.alive_faces].copy()

    def neighbors(self, int v):
        """The 1-ring of vertex ``v`` in fan order (boundary fans start at the border)."""
        self._check_vertex(v)
        out = []
        cdef int start = self.v_he[v]
        cdef int h = start
        cdef int nh
        while True:
            out.append(self.dest(h))
            nh = self.ring_next(h)
            if nh < 0:
                out.append(self.corner[he_prev(h)])
                break
            h = nh
            if h == start:
                break
        return out

    def vertex_is_boundary(self, int v):
        self._check_vertex(v)
        return bool(self.is_boundary(v))

    def can_collapse(self, int u, int v):
        """Whether edge (u, v) exists and passes the link condition."""
        h = self._find_halfedge(u, v)
        return h >= 0 and bool(self.link_ok(h))

    def collapse_edge(self, int u, int v):
        """Collapse edge (u, v) removing ``u`` (topology only).  ValueError if not allowed."""
        cdef int dead[3]
        h = self._find_halfedge(u, v)
        if h < 0:
            raise ValueError(f"({u}, {v}) is not an edge")
        if not self.link_ok(h):
            raise ValueError(f"collapsing ({u}, {v}) would change the topology")
        self.collapse(h, u, dead, NULL)
        return v

    def _check_vertex(self, int v):
        if v < 0 or v >= self.n_vertices or not self.vertex_alive[v]:
            raise ValueError(f"vertex {v} is not a live vertex")

    def _find_halfedge(self, int u, int v):
        self._check_vertex(u)
        self._check_vertex(v)
        cdef int start = self.v_he[u]
        cdef int h = start
        cdef int nh
        while True:
            if self.dest(h) == v:
                return h
            nh = self.ring_next(h)
            if nh < 0:
                if self.corner[he_prev(h)] == v:
                    return he_prev(h)
                return -1
            h = nh
            if h == start:
                return -1

    def star(self, int v):
        """``(link, faces, closed)`` of vertex ``v``: its link vertices in order, its face
        slots (face i is (v, link[i], link[i+1])) and whether the link is a cycle."""
        self._check_vertex(v)
        link, faces = [], []
        cdef int start = self.v_he[v]
        cdef int h = start
        cdef int nh
        while True:
            link.append(self.dest(h))
            faces.append(h // 3)
            nh = self.ring_next(h)
            if nh < 0:
                link.append(self.corner[he_prev(h)])
                return link, faces, False
            h = nh
            if h == start:
                return link, faces, True

    def remove_vertex(self, int v, triangles):
        """Remove ``v`` and fill its hole with ``triangles`` ((k - 2, 3) indices into the
        link as :meth:`star` gives it, oriented as the surface).  Topology only, and only
        the combinatorial validity of the triangulation is checked (ValueError); the
        vertex-removal driver checks the rest.  Returns the face slots of the triangles."""
        link, faces, closed = self.star(v)
        cdef int k = len(link)
        tri_arr = np.ascontiguousarray(triangles, dtype=np.intc).reshape(-1, 3)
        if k > MAX_VALENCE:
            raise ValueError(f"vertex {v} has {k} neighbours (at most {MAX_VALENCE})")
        if tri_arr.shape[0] != k - 2:
            raise ValueError(f"a hole of {k} link vertices takes {k - 2} triangles, got {tri_arr.shape[0]}")
        if not triangulation_ok(tri_arr, k, closed):
            raise ValueError("the triangles are no oriented triangulation of the hole")
        if not closed and k == 2 and self.twin[self._find_halfedge(link[0], link[1])] < 0:
            raise ValueError(f"vertex {v} is a corner of an isolated triangle")
        cdef int[::1] L = np.asarray(link, dtype=np.intc)
        cdef int[::1] Fs = np.asarray(faces + [0], dtype=np.intc)
        cdef int[::1] tri = np.ascontiguousarray(tri_arr.reshape(-1)) if tri_arr.size else np.zeros(1, dtype=np.intc)
        cdef int[::1] slots = np.full(max(k - 2, 1), -1, dtype=np.intc)
        cdef int[::1] dead = np.zeros(MAX_VALENCE, dtype=np.intc)
        replace_star(self, v, &L[0], &Fs[0], k, closed, &tri[0], k - 2, &slots[0], &dead[0])
        return np.asarray(slots)[:k - 2].copy()

    def check(self):
        """Verify every invariant of the structure; raises AssertionError naming the first
        broken one.  O(size); for tests."""
        cdef int h, t, v, e, n_out
        corner = np.asarray(self.corner)
        fa = np.asarray(self.face_alive).astype(bool)
        for h in range(3 * self.n_faces):
            if not self.face_alive[h // 3]:
                continue
            if not self.vertex_alive[self.corner[h]]:
                raise AssertionError(f"half-edge {h} starts at dead vertex {self.corner[h]}")
            t = self.twin[h]
            if t >= 0:
                if not self.face_alive[t // 3]:
                    raise AssertionError(f"twin of {h} is in a dead face")
                if self.twin[t] != h:
                    raise AssertionError(f"twin not symmetric at {h}")
                if self.corner[t] != self.dest(h) or self.dest(t) != self.corner[h]:
                    raise AssertionError(f"twin {t} of {h} does not run the other way")
                if self.edge[t] != self.edge[h]:
                    raise AssertionError(f"twins {h}, {t} have different edge ids")
            e = self.edge[h]
            if not self.edge_alive[e]:
                raise AssertionError(f"half-edge {h} has dead edge {e}")
            if self.edge[self.edge_he[e]] != e or not self.face_alive[self.edge_he[e] // 3]:
                raise AssertionError(f"edge_he of edge {e} is stale")
        # each live vertex: one fan holding all its outgoing half-edges
        live = corner.reshape(-1)[np.repeat(fa, 3)]
        out_count = np.bincount(live, minlength=self.n_vertices)
        for v in range(self.n_vertices):
            if not self.vertex_alive[v]:
                continue
            h = self.v_he[v]
            if not self.face_alive[h // 3] or self.corner[h] != v:
                raise AssertionError(f"v_he of vertex {v} is not a live outgoing half-edge")
            if self.find_fan_start(h) != h:
                raise AssertionError(f"v_he of boundary vertex {v} is not its boundary half-edge")
            n_out = 0
            t = h
            while True:
                n_out += 1
                t = self.ring_next(t)
                if t < 0 or t == h:
                    break
                if n_out > out_count[v]:
                    break
            if n_out != out_count[v]:
                raise AssertionError(f"vertex {v} has {out_count[v]} faces but its fan has {n_out}")
        return True


cdef int replace_star(HalfEdgeMesh hm, int v, const int* link, const int* face, int k, bint closed,
                      const int* tri, int n_tris, int* slot_of, int* dead_edges) noexcept nogil:
    """See halfedge.pxd.  O(k^2) for the diagonals' pairing (k <= MAX_VALENCE), plus the fans of the
    link vertices to re-anchor their v_he."""
    cdef HEArrays* m = &hm.c
    cdef int nf = k if closed else k - 1
    cdef int T[MAX_VALENCE]          # outer twin of link edge i (-1 on a boundary)
    cdef int E[MAX_VALENCE]          # edge id of link edge i
    cdef int S[MAX_VALENCE]          # spoke edge ids (all die; reused for the new edges)
    cdef int used[MAX_VALENCE]
    cdef int dh[3 * MAX_VALENCE]        # new half-edges that are no link edge, with their ends
    cdef int da[3 * MAX_VALENCE]
    cdef int db[3 * MAX_VALENCE]
    cdef int nd = 0, pool = 0, i, j, t, c, f, h, a, b, x, n_dead = 0, hv = -1
    for i in range(nf):
        f = face[i]
        h = 3 * f
        if m.corner[h] != v:
            h = 3 * f + 1 if m.corner[3 * f + 1] == v else 3 * f + 2
        x = he_next(h)
        T[i] = m.twin[x]
        E[i] = m.edge[x]
        S[i] = m.edge[h]
        used[i] = 0
        hv = h
    if not closed:
        S[k - 1] = m.edge[he_prev(hv)]          # link[k-1] -> v, the last spoke
    if n_tris > 0 and slot_of[0] >= 0:
        # the caller's slots (distinct slots of the old faces)
        for t in range(n_tris):
            for i in range(nf):
                if face[i] == slot_of[t]:
                    used[i] = 1
    else:
        # a triangle takes the slot of the old face whose link edge it inherits
        for t in range(n_tris):
            slot_of[t] = -1
            for c in range(3):
                a = tri[3 * t + c]
                b = tri[3 * t + (c + 1) % 3]
                if b == (a + 1) % k and (closed or a != k - 1):
                    slot_of[t] = face[a]
                    used[a] = 1
                    break
        j = 0
        for t in range(n_tris):
            if slot_of[t] < 0:
                while used[j]:
                    j += 1
                slot_of[t] = face[j]
                used[j] = 1
    # corners, then twins and edge ids
    for t in range(n_tris):
        f = slot_of[t]
        for c in range(3):
            m.corner[3 * f + c] = link[tri[3 * t + c]]
    for t in range(n_tris):
        f = slot_of[t]
        for c in range(3):
            h = 3 * f + c
            a = tri[3 * t + c]
            b = tri[3 * t + (c + 1) % 3]
            if b == (a + 1) % k and (closed or a != k - 1):
                m.twin[h] = T[a]
                if T[a] >= 0:
                    m.twin[T[a]] = h
                m.edge[h] = E[a]
                m.edge_he[E[a]] = h
            elif not closed and a == k - 1 and b == 0:
                m.twin[h] = -1                   # the open star's new boundary edge
                m.edge[h] = S[pool]
                m.edge_he[S[pool]] = h
                pool += 1
            else:
                dh[nd] = h
                da[nd] = a
                db[nd] = b
                nd += 1
    for i in range(nd):
        if da[i] < 0:
            continue
        for j in range(i + 1, nd):
            if da[j] == db[i] and db[j] == da[i]:
                m.twin[dh[i]] = dh[j]
                m.twin[dh[j]] = dh[i]
                m.edge[dh[i]] = S[pool]
                m.edge[dh[j]] = S[pool]
                m.edge_he[S[pool]] = dh[i]
                pool += 1
                da[j] = -1
                break
    for i in range(nf):
        if not used[i]:
            m.face_alive[face[i]] = 0
            hm.n_alive_faces -= 1
    for i in range(pool, k):
        m.edge_alive[S[i]] = 0
        dead_edges[n_dead] = S[i]
        n_dead += 1
    m.vertex_alive[v] = 0
    m.v_he[v] = -1
    hm.n_alive_vertices -= 1
    # v_he of the link vertices: an outgoing half-edge of a live face, then the fan start
    # (a boundary vertex's fan starts at its outgoing boundary half-edge)
    if n_tris == 0:
        # an open star of one face: its link edge link[0] -> link[1] keeps the outer face
        x = T[0]                                 # link[1] -> link[0]: now a boundary edge
        m.twin[x] = -1
        m.edge_he[E[0]] = x
        m.v_he[link[1]] = hm.find_fan_start(x)
        m.v_he[link[0]] = hm.find_fan_start(he_next(x))
        return n_dead
    for t in range(n_tris):
        f = slot_of[t]
        for c in range(3):
            m.v_he[m.corner[3 * f + c]] = 3 * f + c
    for i in range(k):
        m.v_he[link[i]] = hm.find_fan_start(m.v_he[link[i]])
    return n_dead


cdef int compare_i64(const void* a, const void* b) noexcept nogil:
    cdef long long x = (<const long long*>a)[0]
    cdef long long y = (<const long long*>b)[0]
    return (x > y) - (x < y)


cdef inline void sort_keys(long long* a, int k) noexcept nogil:
    """Sort ``k`` keys ascending: insertion sort for the usual few, qsort past 32."""
    if k > 32:
        qsort(a, k, sizeof(long long), compare_i64)
        return
    insertion_sort(a, k)


cdef int run_starts(int* cnt, int n_keys, int n_runs, Py_ssize_t stride) noexcept nogil:
    """A counting sort by runs (each run of the items, in order, counted by key into its
    row ``cnt[run * stride:][:n_keys]``): each count becomes where that run's items of that
    key start, keys in order and runs in order within a key, so the sort is stable for any
    number of runs.  Returns the total."""
    cdef int key, run, size, acc = 0
    for key in range(n_keys):
        for run in range(n_runs):
            size = cnt[run * stride + key]
            cnt[run * stride + key] = acc
            acc += size
    return acc


cdef void place_by_key(const int* key, Py_ssize_t lo, Py_ssize_t hi, int* pos, int* out) noexcept nogil:
    """A run's scatter of a counting sort: item i of lo .. hi - 1 to ``out[pos[key[i]]]``
    (``pos`` advanced; from run_starts)."""
    cdef Py_ssize_t i
    for i in range(lo, hi):
        out[pos[key[i]]] = <int>i
        pos[key[i]] += 1


cdef int pair_at(const int* corner, const int* first, const int* out_he, int v, long long* buf,
                 int* twin, int* local, unsigned char* nm_he, int* n_nm) noexcept nogil:
    """Pair the half-edges whose smaller end is ``v``: each is an outgoing half-edge of v to
    a larger vertex, or the incoming one of a face of v from a larger vertex (every
    half-edge has one smaller end, so each is seen once over all v).  Grouped by the other
    end (keys ``w << 32 | h``: h ascending within a group), a group of two opposite
    half-edges is one edge and a twin pair; any other group gives each member an edge of
    its own (a border edge; a non-manifold one when there are several, flagged in
    ``nm_he`` and counted in ``n_nm``).  Writes ``local``: the edge's number among v's, in
    (w, h) order; returns how many edges v has."""
    cdef int k = 0, s, h, p, w, i, j, t, x0, x1, ne = 0
    cdef unsigned int r
    for s in range(first[v], first[v + 1]):
        h = out_he[s]
        r = <unsigned int>h % 3               # (one unsigned remainder for next and prev)
        w = corner[h + 1 if r != 2 else h - 2]
        if w > v:
            buf[k] = (<long long>w << 32) | h
            k += 1
        p = h - 1 if r != 0 else h + 2
        w = corner[p]
        if w > v:
            buf[k] = (<long long>w << 32) | p
            k += 1
    sort_keys(buf, k)
    i = 0
    while i < k:
        j = i + 1
        while j < k and (buf[j] >> 32) == (buf[i] >> 32):
            j += 1
        x0 = <int><unsigned int>buf[i]
        if j - i == 2:
            x1 = <int><unsigned int>buf[i + 1]
            if corner[x1] != corner[x0]:          # opposite directions: one manifold edge
                twin[x0] = x1
                twin[x1] = x0
                local[x0] = ne
                local[x1] = ne
                ne += 1
                i = j
                continue
        if j - i > 1:
            n_nm[0] += 1
        for t in range(i, j):
            x0 = <int><unsigned int>buf[t]
            local[x0] = ne
            ne += 1
            if j - i > 1:
                nm_he[x0] = 1
        i = j
    return ne


cdef inline int fan_first(const int* twin, int h) noexcept nogil:
    """The first half-edge of the fan of outgoing half-edge ``h``: walk back across twins
    to a border, or (a closed fan) to the half-edge just before h."""
    cdef int start = h
    cdef int nxt
    while twin[start] >= 0:
        nxt = he_next(twin[start])
        if nxt == h:
            break
        start = nxt
    return start


cdef int count_fans(const int* twin, const int* first, const int* out_he, int v, unsigned char* seen,
                    int* first_start) noexcept nogil:
    """How many fans (edge-connected runs of faces) meet at ``v``, found in the order of
    its outgoing half-edges; ``first_start`` gets the first fan's first half-edge (-1:
    no face).  One walk round the first fan; when it holds all of v's outgoing
    half-edges (a manifold vertex: nearly all of them) that is the answer.  Otherwise
    the fans are walked in turn, v's outgoing half-edges marked in ``seen`` (they are
    v's alone: cleared here first)."""
    cdef int s, h, start, t, nf = 0
    cdef int deg = first[v + 1] - first[v]
    first_start[0] = -1
    if deg == 0:
        return 0
    # walk back from v's first outgoing half-edge to a border (or round to it), counting
    h = out_he[first[v]]
    start = h
    nf = 1
    while twin[start] >= 0:
        t = he_next(twin[start])
        if t == h:
            break
        start = t
        nf += 1
    if twin[start] < 0:
        t = twin[he_prev(h)]          # an open fan: on forward from h to its end
        while t >= 0:
            nf += 1
            t = twin[he_prev(t)]
    if nf == deg:
        first_start[0] = start
        return 1
    nf = 0
    for s in range(first[v], first[v + 1]):
        seen[out_he[s]] = 0
    for s in range(first[v], first[v + 1]):
        h = out_he[s]
        if seen[h]:
            continue
        start = fan_first(twin, h)
        if nf == 0:
            first_start[0] = start
        nf += 1
        t = start
        while True:
            seen[t] = 1
            t = twin[he_prev(t)]
            if t < 0 or t == start:
                break
    return nf


def build(faces, int n_vertices, int threads=1, bint take=False):
    """Half-edge arrays for ``faces`` ((m, 3) int32, no repeated index within a face, every
    index in ``0..n_vertices-1``).  O(m + n): the outgoing half-edges of each vertex (a
    counting sort), then, per vertex, its edges to larger vertices paired up and its fans
    counted -- per vertex on ``threads`` OpenMP threads, each vertex writing only its own
    half-edges, so the arrays are the same for any thread count.  Edges are numbered in
    (smaller end, larger end) order, the half-edges of a non-manifold group in id order.

    Returns a :class:`HalfEdgeMesh`.  Non-manifold edges and vertices are cut as described
    in the module docstring; the counts are in ``n_nonmanifold_edges`` / ``n_split_vertices``.
    ``take``: the caller hands ``faces`` over (it drops them), so a writeable int32
    C-contiguous array becomes the corner array itself instead of being copied.
    """
    arr = np.ascontiguousarray(faces, dtype=np.intc)
    # a conversion made a copy of our own; otherwise the caller's array is only read
    take = (take and arr.flags.writeable) or arr is not faces
    cdef const int[:, ::1] F = arr          # read only: read-only input is fine
    cdef Py_ssize_t m = F.shape[0]
    if m >= 700_000_000:
        raise ValueError("too many faces for 32-bit half-edge ids")
    if threads < 1 or n_vertices < PARALLEL_MIN_VERTICES:
        threads = 1                   # waking a team costs more than a small mesh's build
    cdef int H = <int>(3 * m)
    cdef int n = n_vertices
    cdef int[::1] corner = arr.reshape(-1) if take else arr.reshape(-1).copy()
    cdef int[::1] twin = np.full(H, -1, dtype=np.intc)
    cdef int[::1] edge = np.empty(H, dtype=np.intc)
    cdef int[::1] first = np.empty(n + 1, dtype=np.intc)
    cdef int[::1] out_he = np.empty(H, dtype=np.intc)
    cdef int[::1] n_edges_at = np.empty(n + 1, dtype=np.intc)
    cdef unsigned char[::1] flags = np.zeros(H, dtype=np.uint8)   # non-manifold, then seen
    cdef unsigned char[::1] nm_vertex = np.zeros(n, dtype=np.uint8)
    cdef int[::1] nm_t = np.zeros(threads, dtype=np.intc)
    cdef int[::1] vstart = np.empty(n, dtype=np.intc)
    cdef int[::1] nfans = np.empty(n, dtype=np.intc)
    cdef long long[:, ::1] buf
    cdef int h, a, b, c, f, v, t, s, bad_h = -1, maxdeg = 0, n_edges = 0, n_nm = 0
    cdef int n_new, k, start, fan_vertex, n_extra = 0
    # ---- outgoing half-edges by vertex (CSR: out_he[first[v]:first[v + 1]], h ascending):
    #      a counting sort, each thread counting, then placing, its own run of half-edges
    #      (runs in h order, so each vertex's list is in h order for any thread count)
    cdef int[:, ::1] fill = np.zeros((threads, n + 1), dtype=np.intc)
    cdef int[::1] bad_t = np.full(threads, -1, dtype=np.intc)
    cdef int per = (H + threads - 1) // threads
    with nogil:
        for t in prange(threads, num_threads=threads, schedule="static", chunksize=1):
            for h in range(t * per, min(t * per + per, H)):
                a = corner[h]
                if <unsigned int>a >= <unsigned int>n:
                    bad_t[t] = h
                    break
                fill[t, a] += 1
        for t in range(threads):
            if bad_t[t] >= 0:
                bad_h = bad_t[t]
                break
    if bad_h >= 0:
        raise ValueError(f"face {bad_h // 3} has a vertex index outside 0..{n - 1}")
    with nogil:
        first[n] = run_starts(&fill[0, 0], n, threads, n + 1)   # where run t's half-edges of v go
        for v in range(n):
            first[v] = fill[0, v]
        for v in range(n):
            if first[v + 1] - first[v] > maxdeg:
                maxdeg = first[v + 1] - first[v]
        for t in prange(threads, num_threads=threads, schedule="static", chunksize=1):
            place_by_key(&corner[0], t * per, min(t * per + per, H), &fill[t, 0], &out_he[0])
    fill = None                          # (threads x n ints: not kept past the sort)
    buf = np.empty((threads, 2 * maxdeg + 2), dtype=np.int64)
    with nogil:
        # ---- pair the half-edges at their smaller end, count the fans at each vertex
        for v in prange(n, num_threads=threads, schedule="static", chunksize=4096):
            t = threadid()
            n_edges_at[v] = pair_at(&corner[0], &first[0], &out_he[0], v, &buf[t, 0], &twin[0], &edge[0],
                                    &flags[0], &nm_t[t])
        for t in range(threads):
            n_nm += nm_t[t]
        if n_nm:
            for h in range(H):
                if flags[h]:
                    nm_vertex[corner[h]] = 1
                    nm_vertex[corner[he_next(h)]] = 1
        # edges numbered in (smaller end, larger end) order: v's come after those of 0..v-1
        n_edges = run_starts(&n_edges_at[0], n, 1, 0)
        # (count_fans clears the flags it uses itself: nm_vertex has been read off them)
        for f in prange(<int>m, num_threads=threads, schedule="static"):
            a = corner[3 * f]
            b = corner[3 * f + 1]
            c = corner[3 * f + 2]
            edge[3 * f] += n_edges_at[a if a < b else b]
            edge[3 * f + 1] += n_edges_at[b if b < c else c]
            edge[3 * f + 2] += n_edges_at[c if c < a else a]
        for v in prange(n, num_threads=threads, schedule="static", chunksize=4096):
            nfans[v] = count_fans(&twin[0], &first[0], &out_he[0], v, &flags[0], &vstart[v])
        for v in range(n):
            if nfans[v] > 1:
                n_extra += nfans[v] - 1
    # ---- split vertices with several fans: the second, third, ... fan of v (in the order
    #      of v's outgoing half-edges) gets a new slot, numbered in the order of v
    cdef int[::1] source = np.arange(n + n_extra, dtype=np.intc)
    cdef int[::1] vhe
    if n_extra == 0:
        vhe = vstart
    else:
        vhe = np.full(n + n_extra, -1, dtype=np.intc)
        with nogil:
            n_new = n
            for v in range(n):
                vhe[v] = vstart[v]
                if nfans[v] < 2:
                    continue
                for s in range(first[v], first[v + 1]):
                    flags[out_he[s]] = 0
                k = 0
                for s in range(first[v], first[v + 1]):
                    h = out_he[s]
                    if flags[h]:
                        continue
                    start = fan_first(&twin[0], h)
                    if k == 0:
                        fan_vertex = v
                    else:
                        fan_vertex = n_new
                        n_new += 1
                        source[fan_vertex] = v
                    vhe[fan_vertex] = start
                    k += 1
                    t = start
                    while True:
                        flags[t] = 1
                        corner[t] = fan_vertex
                        t = twin[he_prev(t)]
                        if t < 0 or t == start:
                            break
    n_new = n + n_extra
    cdef HalfEdgeMesh hm = HalfEdgeMesh.__new__(HalfEdgeMesh)
    hm.n_vertices = n_new
    hm.n_faces = <int>m
    hm.n_edges = n_edges
    hm.n_alive_faces = <int>m
    hm.n_split_vertices = n_new - n
    hm.n_nonmanifold_edges = n_nm
    hm.corner = corner
    hm.twin = twin
    hm.edge = edge
    cdef int[::1] edge_he = np.empty(n_edges, dtype=np.intc)
    with nogil:
        for h in prange(H, num_threads=threads, schedule="static"):
            if twin[h] < h:                      # the later half-edge of a pair, or a lone one
                edge_he[edge[h]] = h
    hm.edge_he = np.asarray(edge_he)
    hm.v_he = vhe
    src = np.asarray(source)
    hm.has_copies = n_new > n
    if hm.has_copies:
        hm.vertex_source = src
    # locked: a vertex on a non-manifold edge or with several fans, and every copy (made
    # for a vertex with several fans); alive: a vertex no face uses has no half-edge, it is
    # not part of the surface
    cdef unsigned char[::1] locked = np.empty(n_new, dtype=np.uint8)
    cdef unsigned char[::1] vertex_alive = np.empty(n_new, dtype=np.uint8)
    cdef int n_alive = 0
    with nogil:
        for v in range(n_new):
            locked[v] = 1 if v >= n or nm_vertex[v] or nfans[v] > 1 else 0
            vertex_alive[v] = vhe[v] >= 0
            n_alive += vertex_alive[v]
    hm.locked = locked
    hm.face_alive = np.ones(m, dtype=np.uint8)
    hm.vertex_alive = vertex_alive
    hm.n_alive_vertices = n_alive
    hm.edge_alive = np.ones(n_edges, dtype=np.uint8)
    hm.stamp = np.zeros(n_new, dtype=np.intc)
    # copies of one input vertex form a cycle through next_copy (-1: no copies)
    if hm.has_copies:
        next_copy = np.full(n_new, -1, dtype=np.intc)
        order = np.argsort(src, kind="stable")
        ss = src[order]
        starts = np.flatnonzero(np.r_[True, ss[1:] != ss[:-1]])
        sizes = np.diff(np.r_[starts, n_new])
        for g in np.flatnonzero(sizes > 1):
            members = order[starts[g]:starts[g] + sizes[g]]
            next_copy[members] = np.roll(members, -1)
        hm.next_copy = next_copy
    hm.stamp_counter = 0
    hm._bind()
    return hm


def triangulation_ok(triangles, int k, bint closed):
    """Is ``triangles`` ((k - 2, 3) link indices) an oriented triangulation of a k-gon hole:
    every link edge i -> i+1 (and an open star's closing edge k-1 -> 0) used once in that
    direction, every other edge used once each way, each index in 0..k-1?"""
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if tri.shape[0] != k - 2 or (tri.size and (tri.min() < 0 or tri.max() >= k)):
        return False
    if k == 2:
        return not closed
    a = tri.reshape(-1)
    b = np.roll(tri, -1, axis=1).reshape(-1)
    if ((a == b)).any():
        return False
    directed = a * k + b
    if np.unique(directed).size != directed.size:
        return False
    ring = (np.arange(k) * k + (np.arange(k) + 1) % k)
    ds = set(directed.tolist())
    if not set(ring.tolist()) <= ds:
        return False
    rest = ds - set(ring.tolist())
    return all((x % k) * k + x // k in rest for x in rest)


def has_border(HalfEdgeMesh hm):
    """True when some half-edge (of a live face or not) has no twin; stops at the run of
    4096 where it finds the first (the twins of a run OR-ed together, a loop the compiler
    vectorises: a sign bit is a -1)."""
    cdef const int* twin = hm.c.twin
    cdef Py_ssize_t h, lo, hi, n = 3 * <Py_ssize_t>hm.n_faces
    cdef int acc = 0
    with nogil:
        lo = 0
        while lo < n and acc >= 0:
            hi = min(lo + 4096, n)
            for h in range(lo, hi):
                acc |= twin[h]
            lo = hi
    return acc < 0


def count_face_components(HalfEdgeMesh hm):
    """Number of components of the live faces, faces joined across twin half-edges."""
    cdef int m = hm.n_faces
    cdef unsigned char[::1] seen_a = np.zeros(max(m, 1), dtype=np.uint8)
    cdef int[::1] stack_a = np.empty(max(m, 1), dtype=np.intc)
    # raw pointers in locals: a byte store may alias anything, so loads through ``hm`` or a
    # memoryview would be made again after every mark
    cdef unsigned char* seen = &seen_a[0]
    cdef int* stack = &stack_a[0]
    cdef const int* twin = hm.c.twin
    cdef const unsigned char* alive = hm.c.face_alive
    cdef int f, g, top, i, t, n_comp = 0
    with nogil:
        for f in range(m):
            if seen[f] or not alive[f]:
                continue
            n_comp += 1
            seen[f] = 1
            stack[0] = f
            top = 1
            while top > 0:
                top -= 1
                g = stack[top]
                for i in range(3):
                    t = twin[3 * g + i]
                    if t >= 0:
                        t = <int>(<unsigned int>t // 3)
                        if not seen[t]:
                            seen[t] = 1
                            stack[top] = t
                            top += 1
    return n_comp


# ------------------------------------------------------------------ output
cdef enum:
    PREFETCH_AHEAD = 16      # rows fetched ahead of a sparse walk in slot order


cdef inline int popcount64(unsigned long long x) noexcept nogil:
    x = x - ((x >> 1) & 0x5555555555555555ULL)
    x = (x & 0x3333333333333333ULL) + ((x >> 2) & 0x3333333333333333ULL)
    x = (x + (x >> 4)) & 0x0F0F0F0F0F0F0F0FULL
    return <int>((x * 0x0101010101010101ULL) >> 56)


cdef int rank_bits(unsigned long long* bits, int* before, Py_ssize_t n_words) noexcept nogil:
    """``before[w]``: the set bits in the words before ``w``; returns all of them."""
    cdef Py_ssize_t w
    cdef int total = 0
    for w in range(n_words):
        before[w] = total
        total += popcount64(bits[w])
    return total


cdef inline int bit_rank(const unsigned long long* bits, const int* before, int i) noexcept nogil:
    """The set bits below bit ``i`` (a sorted set's index of its member ``i``)."""
    return before[i >> 6] + popcount64(bits[i >> 6] & ((1ULL << (i & 63)) - 1ULL))


def live_output(HalfEdgeMesh hm, input_vertex, input_face, vertices, int n_input_faces,
                bint by_input_face, moved, positions, center, double scale):
    """The live part of the half-edge arrays in the input's numbering, as
    ``_pipeline.extract`` hands it out: (vertices (k, 3) float64, faces (f, 3) int32,
    vertex_map (k,) int64, face_map (f,) int64, first (k,) intp).

    One output vertex per input vertex (``input_vertex[slot]``) with a live slot, in
    input order: the input position ``vertices[i]``, or, when its first live slot (in slot
    order; ``first``) has ``moved``, that slot's ``positions`` row ``* scale + center`` (as
    numpy computes it).  The live faces in slot order, or, with ``by_input_face``, in the
    order of ``input_face`` (< ``n_input_faces``; unique).  The sorted sets of the live
    input vertices and faces are bitmaps, and a member's place is its rank in one (the
    set bits before its word, counted once, and those below it in its word): no sort, no
    array of the input's or the slots' size, and the slots and faces are read in slot
    order (in memory order when the slots are laid out along a curve)."""
    cdef const int[::1] VERT_IN = np.ascontiguousarray(input_vertex, dtype=np.intc)
    cdef const int[::1] FACE_IN = np.ascontiguousarray(input_face, dtype=np.intc)
    cdef const double[:, ::1] V = np.ascontiguousarray(vertices, dtype=np.float64)
    cdef const double[::1] c = np.ascontiguousarray(center, dtype=np.float64).reshape(-1)
    cdef int n = hm.n_vertices, m = hm.n_faces
    cdef int n_in = <int>V.shape[0]
    if VERT_IN.shape[0] != n or FACE_IN.shape[0] != m or V.shape[1] != 3 or c.shape[0] != 3:
        raise ValueError("input_vertex must have one entry a vertex slot, input_face one a face slot")
    if n and (np.min(VERT_IN) < 0 or np.max(VERT_IN) >= n_in):
        raise ValueError("input_vertex out of range")
    if m and (np.min(FACE_IN) < 0 or np.max(FACE_IN) >= n_input_faces):
        raise ValueError("input_face out of range")
    cdef const unsigned char* MV = NULL
    cdef const double* P = NULL
    cdef Py_ssize_t ps = 0
    if moved is not None:
        moved_a = np.ascontiguousarray(moved).view(np.uint8).reshape(-1)
        pos_a = np.asarray(positions, dtype=np.float64)
        if moved_a.shape[0] != n or pos_a.shape != (n, 3):
            raise ValueError("moved and positions must have one entry / row a vertex slot")
        if pos_a.strides[1] != 8 or pos_a.strides[0] % 8:
            pos_a = np.ascontiguousarray(pos_a)
        MV = <const unsigned char*>cnp.PyArray_DATA(moved_a)
        P = <const double*>cnp.PyArray_DATA(pos_a)
        ps = pos_a.strides[0] // 8
    cdef Py_ssize_t nw_v = (n_in >> 6) + 1, nw_f = (n_input_faces >> 6) + 1
    cdef unsigned long long[::1] vbits_a = np.zeros(nw_v, dtype=np.uint64)
    cdef int[::1] vbefore_a = np.empty(nw_v, dtype=np.intc)
    cdef unsigned long long* vbits = &vbits_a[0]
    cdef int* vbefore = &vbefore_a[0]
    cdef const int* iv = &VERT_IN[0] if n else NULL
    cdef const int* iface = &FACE_IN[0] if m else NULL
    cdef const unsigned char* valive = hm.c.vertex_alive
    cdef const unsigned char* falive = hm.c.face_alive
    cdef const int* corner = hm.c.corner
    cdef int s, f, i, o, r, k, n_faces = 0
    cdef Py_ssize_t w
    cdef unsigned long long word
    with nogil:
        for s in range(n):
            if valive[s]:
                vbits[iv[s] >> 6] |= 1ULL << (iv[s] & 63)
        k = rank_bits(vbits, vbefore, nw_v)
        for f in range(m):
            n_faces += falive[f]
    vertex_map = np.empty(k, dtype=np.int64)
    first = np.full(k, -1, dtype=np.intp)
    out_v = np.empty((k, 3), dtype=np.float64)
    out_f = np.empty((n_faces, 3), dtype=np.intc)
    face_map = np.empty(n_faces, dtype=np.int64)
    cdef long long* VM = <long long*>cnp.PyArray_DATA(vertex_map)
    cdef Py_ssize_t* FI = <Py_ssize_t*>cnp.PyArray_DATA(first)
    cdef double* OV = <double*>cnp.PyArray_DATA(out_v)
    cdef int* OF = <int*>cnp.PyArray_DATA(out_f)
    cdef long long* FM = <long long*>cnp.PyArray_DATA(face_map)
    cdef const double* src = &V[0, 0] if n_in else NULL
    cdef unsigned long long[::1] fbits_a = np.zeros(nw_f if by_input_face else 1, dtype=np.uint64)
    cdef int[::1] fbefore_a = np.empty(nw_f if by_input_face else 1, dtype=np.intc)
    cdef unsigned long long* fbits = &fbits_a[0]
    cdef int* fbefore = &fbefore_a[0]
    cdef int[::1] moved_slots_a = np.empty(max(k, 1), dtype=np.intc)
    cdef unsigned char[::1] took_a = np.zeros(max(k, 1), dtype=np.uint8)
    cdef int* moved_slots = &moved_slots_a[0]
    cdef unsigned char* took = &took_a[0]
    cdef int n_moved = 0, j
    with nogil:
        # each output vertex's first live slot; the moved ones give their new position
        for s in range(n):
            if not valive[s]:
                continue
            o = bit_rank(vbits, vbefore, iv[s])
            if FI[o] >= 0:
                continue
            FI[o] = s
            if MV != NULL and MV[s]:
                moved_slots[n_moved] = s
                n_moved += 1
        # (their rows are a tenth of the slots' at a 10 % target, in slot order but apart:
        # fetched ahead, or each is a miss)
        for j in range(n_moved):
            if j + PREFETCH_AHEAD < n_moved:
                prefetch(&P[ps * moved_slots[j + PREFETCH_AHEAD]])
            s = moved_slots[j]
            o = bit_rank(vbits, vbefore, iv[s])
            took[o] = 1
            for i in range(3):
                OV[3 * o + i] = P[ps * s + i] * scale + c[i]
        # the live input vertices in order, and the input positions of those that stay
        o = 0
        for w in range(nw_v):
            word = vbits[w]
            while word:
                i = <int>(w << 6) + popcount64((word & (~word + 1ULL)) - 1ULL)
                word &= word - 1ULL
                VM[o] = i
                if not took[o]:
                    OV[3 * o] = src[3 * i]
                    OV[3 * o + 1] = src[3 * i + 1]
                    OV[3 * o + 2] = src[3 * i + 2]
                o += 1
        if by_input_face:
            for f in range(m):
                if falive[f]:
                    fbits[iface[f] >> 6] |= 1ULL << (iface[f] & 63)
            rank_bits(fbits, fbefore, nw_f)
        # the live faces in slot order, each written at its place in the output
        o = 0
        for f in range(m):
            if falive[f]:
                r = bit_rank(fbits, fbefore, iface[f]) if by_input_face else o
                FM[r] = iface[f]
                for i in range(3):
                    OF[3 * r + i] = bit_rank(vbits, vbefore, iv[corner[3 * f + i]])
                o += 1
    return out_v, out_f, vertex_map, face_map, first


# ------------------------------------------------------------------ memory order
cdef inline unsigned long long spread_bits(unsigned long long x) noexcept nogil:
    """The low 21 bits of x with two zero bits after each (an axis's share of a 3D Morton
    code; lodkit.geometry._spread_bits in C)."""
    x &= 0x1FFFFFULL
    x = (x | (x << 32)) & 0x1F00000000FFFFULL
    x = (x | (x << 16)) & 0x1F0000FF0000FFULL
    x = (x | (x << 8)) & 0x100F00F00F00F00FULL
    x = (x | (x << 4)) & 0x10C30C30C30C30C3ULL
    x = (x | (x << 2)) & 0x1249249249249249ULL
    return x


cdef enum:
    # the Morton sort's digits: 2048 buckets (16 KB of counts) keep the scatter's write
    # streams in cache, where 65536 of them (16-bit digits) missed on most writes
    RADIX_BITS = 11
    RADIX = 1 << RADIX_BITS
    RADIX_DIGITS = 6         # 66 bits: the 63 of a code


cdef inline unsigned long long morton_code(const double* p, const double* lo, const double* ext,
                                           double top) noexcept nogil:
    """The Morton code of point ``p`` in the box from ``lo`` of size ``ext``, ``top`` + 1
    steps an axis (a coordinate outside, or NaN, clamped)."""
    cdef unsigned long long q[3]
    cdef double x
    cdef int k
    for k in range(3):
        x = (p[k] - lo[k]) / ext[k] * top
        if not (x >= 0.0):
            x = 0.0
        elif x > top:
            x = top
        q[k] = <unsigned long long>x
    return spread_bits(q[0]) | (spread_bits(q[1]) << 1) | (spread_bits(q[2]) << 2)


cdef void radix_count(const unsigned long long* src, Py_ssize_t lo, Py_ssize_t hi,
                      int* cnt) noexcept nogil:
    """morton_permutation's histograms of every digit of src[lo:hi] (cnt: RADIX_DIGITS rows)."""
    cdef Py_ssize_t i
    cdef int k
    for i in range(lo, hi):
        for k in range(RADIX_DIGITS):
            cnt[k * RADIX + ((src[i] >> (RADIX_BITS * k)) & (RADIX - 1))] += 1


cdef void radix_count_digit(const unsigned long long* src, Py_ssize_t lo, Py_ssize_t hi, int shift,
                            int* cnt) noexcept nogil:
    """morton_permutation's histogram of the digit at ``shift`` of src[lo:hi] (cnt zeroed here)."""
    cdef Py_ssize_t i
    memset(cnt, 0, RADIX * sizeof(int))
    for i in range(lo, hi):
        cnt[(src[i] >> shift) & (RADIX - 1)] += 1


cdef void radix_place(const unsigned long long* src, unsigned long long* dst, const int* isrc,
                      int* idst, Py_ssize_t lo, Py_ssize_t hi, int shift, int* pos) noexcept nogil:
    """morton_permutation's stable scatter of src[lo:hi] (and its permutation) by the digit
    at ``shift``, to the next rows ``pos`` (advanced) of each digit value."""
    cdef Py_ssize_t i
    cdef unsigned long long d
    for i in range(lo, hi):
        d = (src[i] >> shift) & (RADIX - 1)
        dst[pos[d]] = src[i]
        idst[pos[d]] = isrc[i]
        pos[d] += 1


def morton_permutation(points, index=None, box=None, int threads=1):
    """(n,) int32 permutation sorting (n, 3) ``points`` (or ``points[index]``, without the
    copy) along their Morton curve: the same as ``lodkit.geometry.morton_order`` (21 bits
    per axis over the bounding box, ties in input order), by one pass for the codes and a
    stable radix sort instead of numpy's comparison sort (any digit size gives the same
    permutation: a stable sort by the whole code).

    ``box``: the points' (lo, hi) from :func:`bounding_box` when the caller has it (not
    measured again); ``threads``: OpenMP threads (from PARALLEL_MIN_VERTICES points) of
    the codes (each point's own) and of the sort (for each digit, each thread counts, then
    places, its own run of the points: runs in order, so the sort stays stable and the
    permutation is the same for any number)."""
    cdef const double[:, ::1] P = np.ascontiguousarray(points, dtype=np.float64)
    if P.shape[1] != 3:
        raise ValueError("points must have shape (n, 3)")
    cdef const int[::1] X = np.ascontiguousarray(np.arange(P.shape[0]) if index is None else index,
                                                 dtype=np.intc)
    cdef Py_ssize_t n = X.shape[0]
    if n and (np.min(X) < 0 or np.max(X) >= P.shape[0]):
        raise ValueError("index out of range")
    perm = np.arange(n, dtype=np.intc)
    if n < 2:
        return perm
    codes = np.empty(n, dtype=np.uint64)
    tmp_codes = np.empty(n, dtype=np.uint64)
    tmp_perm = np.empty(n, dtype=np.intc)
    cdef unsigned long long[::1] C = codes
    cdef unsigned long long[::1] C2 = tmp_codes
    cdef int[::1] I = perm
    cdef int[::1] I2 = tmp_perm
    cdef int[:, :, ::1] cnt                 # (counts below 2**31: the permutation is int32)
    cdef double lo[3]
    cdef double ext[3]
    cdef double hi
    cdef double top = <double>((1 << 21) - 1)
    cdef Py_ssize_t i, size, per
    cdef int k, shift, t
    cdef unsigned long long* src
    cdef unsigned long long* dst
    cdef int* isrc
    cdef int* idst
    if threads < 1 or n < PARALLEL_MIN_VERTICES:
        threads = 1
    cnt = np.zeros((threads, RADIX_DIGITS, RADIX), dtype=np.intc)
    per = (n + threads - 1) // threads
    if box is None:
        box = bounding_box(P, X)
    for k in range(3):
        lo[k] = box[0][k]
        hi = box[1][k]
        ext[k] = hi - lo[k] if hi > lo[k] else 1.0
    with nogil:
        for i in prange(n, num_threads=threads, schedule="static"):
            C[i] = morton_code(&P[X[i], 0], lo, ext, top)
        src, dst, isrc, idst = &C[0], &C2[0], &I[0], &I2[0]
        for t in prange(threads, num_threads=threads, schedule="static", chunksize=1):
            radix_count(src, t * per, min(t * per + per, n), &cnt[t, 0, 0])   # every digit's, in one read
        for k in range(RADIX_DIGITS):
            shift = RADIX_BITS * k
            size = 0
            for t in range(threads):
                size = size + cnt[t, k, (src[0] >> shift) & (RADIX - 1)]
            if size == n:
                continue                          # one digit value: already in order
            if threads > 1:
                # each run's own histogram of this digit, in the order the last pass left
                # (the first read's are of the input order; their sums hold for any order)
                for t in prange(threads, num_threads=threads, schedule="static", chunksize=1):
                    radix_count_digit(src, t * per, min(t * per + per, n), shift, &cnt[t, k, 0])
            run_starts(&cnt[0, k, 0], RADIX, threads, RADIX_DIGITS * RADIX)
            for t in prange(threads, num_threads=threads, schedule="static", chunksize=1):
                radix_place(src, dst, isrc, idst, t * per, min(t * per + per, n), shift, &cnt[t, k, 0])
            src, dst = dst, src
            isrc, idst = idst, isrc
        if isrc != &I[0]:
            for i in range(n):
                I[i] = isrc[i]
    return perm


cdef inline int smallest(const int* F, const int* remap, int n_remap) noexcept nogil:
    """The smallest of the face ``F[0:3]``'s vertices (renumbered by ``remap`` when not
    NULL), -1 when a corner is outside ``remap``."""
    cdef int a = F[0], b = F[1], c = F[2]
    if remap != NULL:
        if (<unsigned int>a >= <unsigned int>n_remap or <unsigned int>b >= <unsigned int>n_remap
                or <unsigned int>c >= <unsigned int>n_remap):
            return -1
        a, b, c = remap[a], remap[b], remap[c]
    if b < a:
        a = b
    if c < a:
        a = c
    return a


cdef Py_ssize_t face_keys(const int* F, const int* map_, int n_map, int n_vertices, Py_ssize_t lo,
                          Py_ssize_t hi, int* key, int* cnt) noexcept nogil:
    """faces_by_first_slot's first step for faces lo .. hi - 1: each one's smallest
    (renumbered) vertex into ``key``, counted per vertex into ``cnt``.  Returns the first
    face with an index out of range, or -1."""
    cdef Py_ssize_t f
    cdef int a
    for f in range(lo, hi):
        a = smallest(&F[3 * f], map_, n_map)
        key[f] = a
        if a < 0 or a >= n_vertices:
            return f
        cnt[a] += 1
    return -1


def faces_by_first_slot(faces, int n_vertices, bint reorder=False, remap=None, int threads=1):
    """(m,) int32 permutation ordering (m, 3) ``faces`` by their smallest vertex index,
    ties in input order (``np.argsort(faces.min(axis=1), kind="stable")`` by a counting
    sort); with ``reorder``, (the faces in that order, the permutation).

    ``remap``: the faces' vertices are ``remap[faces]`` (read, not gathered into a copy;
    the reordered faces are renumbered).  ``threads``: OpenMP threads (from
    PARALLEL_MIN_VERTICES vertices) of the per-face steps and of the counting sort (each
    thread counts, then places, its own run of faces: runs in order, so the sort stays
    stable and the permutation is the same for any number)."""
    cdef const int[:, ::1] F = np.ascontiguousarray(faces, dtype=np.intc)
    cdef const int[::1] R = np.ascontiguousarray(np.zeros(1) if remap is None else remap, dtype=np.intc)
    cdef Py_ssize_t m = F.shape[0]
    if threads < 1 or n_vertices < PARALLEL_MIN_VERTICES:
        threads = 1
    out = np.empty(m, dtype=np.intc)
    cdef int[::1] key = np.empty(m, dtype=np.intc)
    cdef int[::1] O = out
    if m == 0:
        return (np.empty((0, 3), dtype=np.intc), out) if reorder else out
    cdef int[:, ::1] cnt = np.zeros((threads, max(n_vertices, 1)), dtype=np.intc)   # (m < 2**31)
    cdef Py_ssize_t[::1] bad_t = np.full(threads, -1, dtype=np.intp)
    cdef Py_ssize_t f, bad = -1
    cdef Py_ssize_t per = (m + threads - 1) // threads
    cdef const int* map_ = NULL
    if remap is not None:
        if R.shape[0] == 0:
            raise ValueError("remap is empty")
        map_ = &R[0]
    cdef int n_map = R.shape[0]
    cdef int t
    with nogil:
        for t in prange(threads, num_threads=threads, schedule="static", chunksize=1):
            bad_t[t] = face_keys(&F[0, 0], map_, n_map, n_vertices, t * per, min(t * per + per, m),
                                 &key[0], &cnt[t, 0])
        for t in range(threads):
            if bad_t[t] >= 0:
                bad = bad_t[t]
                break
        if bad < 0:
            run_starts(&cnt[0, 0], n_vertices, threads, cnt.shape[1])
            for t in prange(threads, num_threads=threads, schedule="static", chunksize=1):
                place_by_key(&key[0], t * per, min(t * per + per, m), &cnt[t, 0], &O[0])
    if bad >= 0:
        raise ValueError(f"face {bad} has an index outside 0..{n_vertices - 1}")
    if not reorder:
        return out
    ordered = np.empty((m, 3), dtype=np.intc)
    cdef int[:, ::1] G = ordered
    cdef int k
    with nogil:
        for f in prange(m, num_threads=threads, schedule="static"):
            for k in range(3):
                G[f, k] = F[O[f], k] if map_ == NULL else map_[F[O[f], k]]
    return ordered, out


def used_vertices(faces, int n_vertices):
    """(used, n_degenerate): ``used`` (n_vertices,) bool, which vertices the faces of (m, 3)
    ``faces`` without a repeated index use (``used[faces[ok]] = True`` without numpy's
    temporaries and fancy-index machinery), ``n_degenerate`` how many faces repeat an
    index; ValueError for an index outside."""
    cdef const int[:, ::1] F = np.ascontiguousarray(faces, dtype=np.intc).reshape(-1, 3)
    used = np.zeros(n_vertices, dtype=bool)
    cdef unsigned char* U = <unsigned char*>cnp.PyArray_DATA(used)
    cdef const int* G = &F[0, 0] if F.shape[0] else NULL
    cdef Py_ssize_t f, bad = -1, n_degenerate = 0
    cdef int a, b, c
    cdef unsigned int n = <unsigned int>n_vertices
    with nogil:
        for f in range(F.shape[0]):
            a = G[3 * f]
            b = G[3 * f + 1]
            c = G[3 * f + 2]
            if <unsigned int>a >= n or <unsigned int>b >= n or <unsigned int>c >= n:
                bad = f
                break
            if a == b or b == c or a == c:
                n_degenerate += 1
                continue
            U[a] = 1
            U[b] = 1
            U[c] = 1
    if bad >= 0:
        raise ValueError(f"face {bad} has a vertex index outside 0..{n_vertices - 1}")
    return used, n_degenerate


def bounding_box(points, index=None):
    """(lo, hi): the corners of the bounding box of (n, 3) ``points`` (or of
    ``points[index]``, without the copy), n >= 1."""
    cdef const double[:, ::1] P = np.ascontiguousarray(points, dtype=np.float64)
    if P.shape[1] != 3:
        raise ValueError("points must have shape (n, 3)")
    cdef const int[::1] X = np.ascontiguousarray(np.arange(P.shape[0]) if index is None else index,
                                                 dtype=np.intc)
    cdef Py_ssize_t n = X.shape[0], i
    if n == 0:
        raise ValueError("no points")
    if np.min(X) < 0 or np.max(X) >= P.shape[0]:
        raise ValueError("index out of range")
    lo_a = np.empty(3)
    hi_a = np.empty(3)
    cdef double[::1] lo = lo_a
    cdef double[::1] hi = hi_a
    cdef double x
    cdef int k
    with nogil:
        for k in range(3):
            lo[k] = P[X[0], k]
            hi[k] = P[X[0], k]
        for i in range(1, n):
            for k in range(3):
                x = P[X[i], k]
                if x < lo[k]:
                    lo[k] = x
                if x > hi[k]:
                    hi[k] = x
    return lo_a, hi_a


def normalised_positions(points, index, center, double scale, out):
    """``out`` = ``(points[index] - center) / scale``: (n, 3) float64, written in place (its
    rows may be spaced: the position columns of the core's (n, 14) vertex rows), as numpy
    computes it (one subtraction and one division a coordinate), without the gathered
    copy.  One thread: the cost is the first touch of ``out``'s pages, which threads do not
    share out (on two threads the page faults made it up to ten times slower at times:
    1M faces, transparent huge pages)."""
    cdef const double[:, ::1] P = np.ascontiguousarray(points, dtype=np.float64)
    cdef const int[::1] X = np.ascontiguousarray(index, dtype=np.intc)
    cdef const double[::1] c = np.ascontiguousarray(center, dtype=np.float64).reshape(-1)
    cdef double[:, :] O = out
    cdef Py_ssize_t n = X.shape[0], i
    cdef int k
    if P.shape[1] != 3 or O.shape[0] != n or O.shape[1] != 3 or c.shape[0] != 3:
        raise ValueError("points must have shape (m, 3), out (n, 3) for n indices, center (3,)")
    if n and (np.min(X) < 0 or np.max(X) >= P.shape[0]):
        raise ValueError("index out of range")
    with nogil:
        for i in range(n):
            for k in range(3):
                O[i, k] = (P[X[i], k] - c[k]) / scale
