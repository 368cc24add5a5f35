# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""MELOD (Hussain, Okada, Nijima 2004) as a native kernel: the ``melod`` metric.

Half-edge collapse o -> h (o goes, h stays where it is).  For the triangles t = (o, a, b)
around o that do not contain h, the collapse turns t into t' = (h, a, b):

    Q_t = l_t * (1 - n_t . n_t'),    l_t = (area(t) + area(t')) / 2
    surface(o -> h) = sum of Q_t

The visual importance of a vertex is w_v = 1 - |sum_i A_i n_i / sum_i A_i| over its star
(0 on a flat vertex).  The key of the half-edge is

    key(o -> h) = w_o * max(surface(o -> h), acc_o) + boundary(o -> h)

where acc_o is the cost accumulated into o by earlier collapses around it (after a
collapse with cost c = max(surface, acc_removed), every vertex of the new 1-ring of the
kept vertex, and the kept vertex, get acc = max(acc, c)).  An edge costs the smaller key of
its two half-edges, so the edge heap pops exactly the vertex with the least key, as the
paper's per-vertex queue does.

Boundary (the paper's heuristics): a boundary vertex never collapses into the interior; a
half-edge along a boundary edge pays lambda * phi * |o - h|.  See docs/metrics/melod.md for
phi and the other readings of the paper.

Memory (docs/reliability.md, "Memory"): per vertex acc and w (16 bytes), per face 2 bits,
per half-edge 3 bits.  Face vectors and half-edge costs are computed again from the
positions when needed rather than cached, from the same corners as the first time, so
they are the same numbers (see MELODKernel's attributes).
"""
import numpy as np

from ..metrics.base import face_vectors, vertex_sums
from libc.math cimport sqrt, INFINITY
from cpython.mem cimport PyMem_RawMalloc, PyMem_RawFree

from .halfedge cimport HEArrays, he_prev, he_dest, he_ring_next
from .vec3 cimport sub3, cross3, dot3, norm3, same_point
from lodkit.kernel cimport (Kernel, Candidate, KernelMesh, KERNEL_OK, KERNEL_VETO, KERNEL_API_VERSION,
                            VERTEX_FIXED, VERTEX_BOUNDARY)

cdef enum:
    ACC_OFF = 0       # no accumulation
    ACC_COST = 1      # neighbours take max(acc, cost of the collapse) (unscaled)
    ACC_KEY = 2       # neighbours take max(acc, key of the collapse) (scaled by w)

cdef enum:
    RING_MAX = 128    # neighbours of the removed vertex remembered by place() for commit()

cdef enum:
    SPILL_MIN = 64    # first size of the spill table (a power of 2)

cdef enum:
    PHI_HEAD = 0      # the paper's formula: phi_oh = 1 - u_ho . u_hn (turn at the head)
    PHI_ORIGIN = 1    # phi_oh = 1 + u_op . u_oh (turn at the removed vertex)


# tests: keep every valid cost that a new cost shares a face with in the spill table (the
# table is then used all the time; the numbers, hence the output, must not change)
cdef bint force_spill = False


def _force_spill(bint on):
    """Tests only: exercise the spill table on every cost computed (see force_spill)."""
    global force_spill
    force_spill = on


cdef inline double unit_dot(const double* o, const double* a, const double* b) noexcept nogil:
    """(a - o)/|a - o| . (b - o)/|b - o| (0 if either has zero length)."""
    cdef double x[3]
    cdef double y[3]
    cdef double lx, ly
    sub3(a, o, x)
    sub3(b, o, y)
    lx = norm3(x)
    ly = norm3(y)
    if lx == 0.0 or ly == 0.0:
        return 0.0
    return dot3(x, y) / (lx * ly)


cdef class MELODKernel(Kernel):
    """Hussain et al.'s half-edge collapse cost with visual importance, cost accumulation
    and the boundary heuristics (see the module docstring)."""

    api_version = KERNEL_API_VERSION

    cdef double[::1] acc           # accumulated cost of each vertex slot
    cdef double[::1] wv            # visual importance of each vertex slot (kept current)
    cdef double lam
    cdef int phi_mode
    cdef bint use_importance
    cdef int accumulate
    # Face vectors (b - a) x (c - a) are taken from the positions when needed, not cached:
    # per face slot, 2 bits (four faces a byte) say from which corner a -- the kept vertex's
    # after a collapse around it, 0 before.  The costs max(surface(o -> h), acc_o) are
    # not cached either (a half-edge collapse moves no vertex: the cost of o -> h changes
    # only when o's star does, and the key is w_o times it), but a cost must stay the same
    # number until o is touched, although the corner of a face of o may change meanwhile (a
    # collapse around one of o's neighbours): so per half-edge, 1 bit says its cost is
    # valid (computed since o was touched) and 2 bits keep the corner o takes the
    # half-edge's face's vector from, the one the valid costs of o read.  When a cost
    # needs a face's new corner while another valid cost of o read the old one, that other
    # cost is kept in a small hash table (spill_*) until o is touched.
    cdef unsigned char[::1] fcorner
    cdef unsigned char[::1] hcorner
    cdef unsigned char[::1] hvalid
    cdef int* spill_key              # half-edge, -1 empty (open addressing, linear probing)
    cdef double* spill_val
    cdef int spill_cap
    cdef int spill_count
    cdef bint spill_failed
    cdef readonly long n_spilled     # costs kept in the table over the run (for tests)
    cdef int ring[RING_MAX]          # neighbours of the removed end of the last placed collapse
    cdef int ring_len                # -1: too many, commit() uses the kept vertex's 1-ring
    cdef int changed_buf[RING_MAX]   # the vertices commit() names to the driver (place() reuses ring)
    cdef bint scale_boundary
    cdef double weight
    # the last key computed by place(): cost() and commit() reuse it
    cdef int cache_edge
    cdef int cache_removed
    cdef double cache_key
    cdef double cache_acc

    def __cinit__(self):
        self.places = True
        self.wide = True          # a collapse changes the stars (and acc) of the kept vertex's ring
        self.cache_edge = -1
        self.spill_key = NULL
        self.spill_val = NULL
        self.spill_cap = 0
        self.spill_count = 0

    def __dealloc__(self):
        self.spill_free()

    def prepare(self, ctx, options):
        n = ctx.n_vertices
        self.lam = float(options["boundary_lambda"])
        self.phi_mode = PHI_HEAD if options["phi"] == "head" else PHI_ORIGIN
        self.use_importance = bool(options["importance"])
        self.accumulate = {"off": ACC_OFF, "cost": ACC_COST, "key": ACC_KEY}[options["accumulate"]]
        self.scale_boundary = bool(options["scale_boundary"])
        self.weight = float(options.get("weight", 1.0))
        self.acc = np.zeros(n, dtype=np.float64)
        self.wv = _slot_importance(ctx.positions, ctx.faces, n)
        self.cache_edge = -1
        nf = ctx.halfedge.n_faces
        self.fcorner = np.zeros((nf + 3) // 4, dtype=np.uint8)   # numpy's are from corner 0
        self.hcorner = np.zeros((3 * nf + 3) // 4, dtype=np.uint8)
        self.hvalid = np.zeros((3 * nf + 7) // 8, dtype=np.uint8)     # no cost valid yet
        self.spill_free()
        self.spill_failed = False
        self.n_spilled = 0

    # ------------------------------------------------------------------ the spill table
    cdef void spill_free(self) noexcept nogil:
        if self.spill_key != NULL:
            PyMem_RawFree(self.spill_key)
            PyMem_RawFree(self.spill_val)
        self.spill_key = NULL
        self.spill_val = NULL
        self.spill_cap = 0
        self.spill_count = 0

    cdef inline int spill_home(self, int he) noexcept nogil:
        return <int>((<unsigned int>he * 2654435761u) & <unsigned int>(self.spill_cap - 1))

    cdef int spill_find(self, int he) noexcept nogil:
        """The slot of half-edge he in the table, -1 if absent."""
        cdef int i
        if self.spill_cap == 0:
            return -1
        i = self.spill_home(he)
        while self.spill_key[i] != -1:
            if self.spill_key[i] == he:
                return i
            i = (i + 1) & (self.spill_cap - 1)
        return -1

    cdef bint spill_put(self, int he, double value) noexcept nogil:
        """Keep value for half-edge he (absent); False when out of memory."""
        cdef int i, j, cap, old_cap = self.spill_cap
        cdef int* old_key = self.spill_key
        cdef double* old_val = self.spill_val
        if 2 * (self.spill_count + 1) > old_cap:
            cap = SPILL_MIN if old_cap == 0 else 2 * old_cap
            self.spill_key = <int*>PyMem_RawMalloc(cap * sizeof(int))
            self.spill_val = <double*>PyMem_RawMalloc(cap * sizeof(double))
            if self.spill_key == NULL or self.spill_val == NULL:
                PyMem_RawFree(self.spill_key)
                PyMem_RawFree(self.spill_val)
                self.spill_key, self.spill_val = old_key, old_val
                return False
            self.spill_cap = cap
            for i in range(cap):
                self.spill_key[i] = -1
            for j in range(old_cap):
                if old_key[j] != -1:
                    i = self.spill_home(old_key[j])
                    while self.spill_key[i] != -1:
                        i = (i + 1) & (cap - 1)
                    self.spill_key[i] = old_key[j]
                    self.spill_val[i] = old_val[j]
            if old_key != NULL:
                PyMem_RawFree(old_key)
                PyMem_RawFree(old_val)
        i = self.spill_home(he)
        while self.spill_key[i] != -1:
            i = (i + 1) & (self.spill_cap - 1)
        self.spill_key[i] = he
        self.spill_val[i] = value
        self.spill_count += 1
        self.n_spilled += 1
        return True

    cdef void spill_drop(self, int he) noexcept nogil:
        """Forget half-edge he (present): backward-shift deletion."""
        cdef int i = self.spill_find(he)
        cdef int j, k, mask = self.spill_cap - 1
        if i < 0:
            return
        j = i
        while True:
            j = (j + 1) & mask
            if self.spill_key[j] == -1:
                break
            k = self.spill_home(self.spill_key[j])
            # move j back into the hole at i unless its home lies cyclically in (i, j]
            if (j > i and (k <= i or k > j)) or (j < i and (k <= i and k > j)):
                self.spill_key[i] = self.spill_key[j]
                self.spill_val[i] = self.spill_val[j]
                i = j
        self.spill_key[i] = -1
        self.spill_count -= 1

    cdef inline int kept_slot(self, int he) noexcept nogil:
        """The slot of the cost kept for half-edge he in the spill table, -1 if none."""
        return self.spill_find(he) if self.spill_count else -1

    # ------------------------------------------------------------------ per half-edge bits
    cdef inline bint he_valid(self, int y) noexcept nogil:
        return (self.hvalid[y >> 3] >> (y & 7)) & 1

    cdef inline void set_valid(self, int y, bint on) noexcept nogil:
        if on:
            self.hvalid[y >> 3] |= 1 << (y & 7)
        else:
            self.hvalid[y >> 3] &= ~(1 << (y & 7))

    cdef inline int he_corner(self, int y) noexcept nogil:
        return (self.hcorner[y >> 2] >> (2 * (y & 3))) & 3

    cdef inline void set_corner(self, int y, int corner) noexcept nogil:
        cdef int sh = 2 * (y & 3)
        self.hcorner[y >> 2] = (self.hcorner[y >> 2] & ~(3 << sh)) | (corner << sh)

    cdef inline int face_corner(self, int f) noexcept nogil:
        return (self.fcorner[f >> 2] >> (2 * (f & 3))) & 3

    # ------------------------------------------------------------------ the measures
    cdef double importance(self, const KernelMesh* m, int v) noexcept nogil:
        """w_v = 1 - |sum A_i n_i| / sum A_i over the live star of v; forgets the cached
        costs of v's half-edges (touch() calls it when v's star changed)."""
        cdef const HEArrays* a = m.he
        cdef int start = a.v_he[v]
        cdef int y = start
        cdef double fv[4]
        cdef double s0 = 0.0, s1 = 0.0, s2 = 0.0, total = 0.0, w
        while True:
            self.face_vector(m, y // 3, self.face_corner(y // 3), fv)
            s0 += fv[0]
            s1 += fv[1]
            s2 += fv[2]
            total += fv[3]
            if self.he_valid(y):         # v's star changed: its half-edges' costs are stale
                self.set_valid(y, False)
                if self.spill_count:
                    self.spill_drop(y)
            y = he_ring_next(a, y)
            if y < 0 or y == start:
                break
        if total <= 0.0:
            return 0.0
        w = 1.0 - sqrt(s0 * s0 + s1 * s1 + s2 * s2) / total
        return w if w > 0.0 else 0.0

    cdef inline void face_vector(self, const KernelMesh* m, int f, int i, double* out) noexcept nogil:
        """out[0:3] = (b - a) x (c - a) of face f from its corner a = corner i (b, c the
        next corners), out[3] = its length: twice the area times the normal."""
        cdef const int* c = &m.he.corner[3 * f]
        cdef const double* P = m.positions
        cdef int s = m.stride
        cdef const double* p0 = &P[s * c[i]]
        cdef double e1[3]
        cdef double e2[3]
        sub3(&P[s * c[(i + 1) % 3]], p0, e1)
        sub3(&P[s * c[(i + 2) % 3]], p0, e2)
        cross3(e1, e2, out)
        out[3] = norm3(out)

    cdef void update_faces(self, const KernelMesh* m, int v) noexcept nogil:
        """Take the face vectors of the faces around v from v's corner from now on."""
        cdef const HEArrays* a = m.he
        cdef int start = a.v_he[v]
        cdef int y = start
        cdef int f, sh
        while True:
            f = y // 3
            sh = 2 * (f & 3)
            self.fcorner[f >> 2] = (self.fcorner[f >> 2] & ~(3 << sh)) | ((y % 3) << sh)   # corner[y] == v
            y = he_ring_next(a, y)
            if y < 0 or y == start:
                break

    cdef double surface(self, const KernelMesh* m, int o, int h, bint kept_corners, bint* moved) noexcept nogil:
        """sum of Q_t over the triangles around o that do not contain h, o moved onto h;
        the face vectors from the faces' corners, or with ``kept_corners`` from those the
        half-edges of o keep (the number computed when the cost was).  ``moved`` (or NULL):
        set if a face read has another corner than the one o's half-edge in it keeps."""
        cdef const HEArrays* a = m.he
        cdef int start = a.v_he[o]
        cdef int y = start
        cdef int b, c, i
        cdef double e1[3]
        cdef double e2[3]
        cdef double n1[3]
        cdef double n0[4]
        cdef double A0, A1, d, total = 0.0
        cdef const double* P = m.positions
        cdef const double* pb
        cdef int s = m.stride
        while True:
            b = he_dest(a, y)
            c = a.corner[he_prev(y)]
            if b != h and c != h:
                # twice the areas and the unnormalised normals of t = (o, b, c), t' = (h, b, c):
                # both share the edge b -> c
                # t = (o, b, c) from its face corner; t' = (h, b, c): (c - b) x (h - b)
                i = self.face_corner(y // 3)
                if kept_corners:
                    i = self.he_corner(y)
                elif moved != NULL and i != self.he_corner(y):
                    moved[0] = True
                self.face_vector(m, y // 3, i, n0)
                pb = &P[s * b]
                sub3(&P[s * c], pb, e1)
                sub3(&P[s * h], pb, e2)
                cross3(e1, e2, n1)
                A0 = n0[3]
                A1 = norm3(n1)
                if A0 > 0.0 and A1 > 0.0:
                    d = 1.0 - (n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2]) / (A0 * A1)
                else:
                    d = 1.0           # a degenerate triangle before or after: full turn
                total += 0.25 * (A0 + A1) * d          # areas are A/2: l_t = (A0 + A1) / 4
            y = he_ring_next(a, y)
            if y < 0 or y == start:
                break
        return total

    cdef void boundary_neighbours(self, const KernelMesh* m, int v, int* out_next, int* out_prev) noexcept nogil:
        """The two neighbours of boundary vertex v along its boundary loop."""
        cdef const HEArrays* a = m.he
        cdef int start = a.v_he[v]           # the outgoing boundary half-edge
        cdef int y = start
        cdef int ny
        out_next[0] = he_dest(a, start)
        while True:
            ny = he_ring_next(a, y)
            if ny < 0 or ny == start:
                break
            y = ny
        out_prev[0] = a.corner[he_prev(y)]

    cdef double boundary_penalty(self, const KernelMesh* m, int o, int h) noexcept nogil:
        """lambda * phi * |o - h| for a half-edge along a boundary edge."""
        cdef int n1, n2, other
        cdef double phi, L
        cdef double d[3]
        cdef const double* P = m.positions
        cdef int s = m.stride
        if self.phi_mode == PHI_HEAD:
            # the paper: phi_oh = 1 - u_ho . u_hn, n the head's other boundary neighbour
            self.boundary_neighbours(m, h, &n1, &n2)
            other = n2 if n1 == o else n1
            phi = 1.0 - unit_dot(&P[s * h], &P[s * o], &P[s * other])
        else:
            # phi_oh = 1 + u_op . u_oh, p the removed vertex's other boundary neighbour
            self.boundary_neighbours(m, o, &n1, &n2)
            other = n2 if n1 == h else n1
            phi = 1.0 + unit_dot(&P[s * o], &P[s * other], &P[s * h])
        sub3(&P[s * o], &P[s * h], d)
        L = norm3(d)
        return self.lam * phi * L

    cdef bint may_remove(self, const KernelMesh* m, const Candidate* c, int o, int h) noexcept nogil:
        cdef unsigned char fo = m.flags[o]
        if fo & VERTEX_FIXED:
            return False
        if fo & VERTEX_BOUNDARY:
            # a boundary vertex may only slide along a boundary edge onto its neighbour
            if not (m.flags[h] & VERTEX_BOUNDARY) or m.he.twin[c.h] >= 0:
                return False
        return True

    cdef double key(self, const KernelMesh* m, const Candidate* c, int o, int h, double* acc_out) noexcept nogil:
        cdef int he = c.h if o == c.u else m.he.twin[c.h]      # the half-edge o -> h, if any
        cdef double surf, w, bpen = 0.0, k
        cdef bint moved = False
        cdef int i
        w = self.wv[o] if self.use_importance else 1.0
        if he >= 0 and self.he_valid(he):   # o untouched since: the same number again
            i = self.kept_slot(he)
            surf = self.spill_val[i] if i >= 0 else self.cost_of(m, o, h, True, NULL)
            acc_out[0] = surf
            return w * surf
        surf = self.cost_of(m, o, h, False, &moved)
        acc_out[0] = surf
        if (m.flags[o] & VERTEX_BOUNDARY) and m.he.twin[c.h] < 0:
            # depends on the boundary neighbours of h as well: not cached
            bpen = self.boundary_penalty(m, o, h)
            return w * (surf + bpen) if self.scale_boundary else w * surf + bpen
        k = w * surf
        if he >= 0:
            if moved or force_spill:
                self.adopt(m, o, h)
            self.set_valid(he, True)
        return k

    cdef inline double cost_of(self, const KernelMesh* m, int o, int h, bint kept_corners,
                               bint* moved) noexcept nogil:
        """max(surface(o -> h), acc_o)."""
        cdef double surf = self.surface(m, o, h, kept_corners, moved)
        if self.accumulate != ACC_OFF and self.acc[o] > surf:
            surf = self.acc[o]
        return surf

    cdef void adopt(self, const KernelMesh* m, int o, int h) noexcept nogil:
        """The cost of o -> h was just computed from faces' corners that o's half-edges do
        not all keep: they keep those from now on.  Another valid cost of o that read a face
        whose corner changed is kept in the spill table first (its number stays)."""
        cdef const HEArrays* a = m.he
        cdef int start = a.v_he[o]
        cdef int y = start, y2, b, c, d
        while True:
            b = he_dest(a, y)
            c = a.corner[he_prev(y)]
            if b != h and c != h and (self.he_corner(y) != self.face_corner(y // 3) or force_spill):
                y2 = start
                while True:
                    d = he_dest(a, y2)
                    if self.he_valid(y2) and d != b and d != c and self.kept_slot(y2) < 0:
                        # a valid cost that reads face y // 3 from its old corner
                        if not self.spill_put(y2, self.cost_of(m, o, d, True, NULL)):
                            self.spill_failed = True
                            return
                    y2 = he_ring_next(a, y2)
                    if y2 < 0 or y2 == start:
                        break
            y = he_ring_next(a, y)
            if y < 0 or y == start:
                break
        y = start
        while True:
            b = he_dest(a, y)
            c = a.corner[he_prev(y)]
            if b != h and c != h:
                self.set_corner(y, self.face_corner(y // 3))
            y = he_ring_next(a, y)
            if y < 0 or y == start:
                break

    # ------------------------------------------------------------------ the kernel
    cdef int place(self, Candidate* c) noexcept nogil:
        cdef const KernelMesh* m = c.mesh
        cdef double ku = INFINITY, kv = INFINITY, au = 0.0, av = 0.0
        cdef int r, k
        if self.may_remove(m, c, c.u, c.v):
            ku = self.key(m, c, c.u, c.v, &au)
        if self.may_remove(m, c, c.v, c.u):
            kv = self.key(m, c, c.v, c.u, &av)
        if self.spill_failed:
            return self.fail(b"melod: out of memory for the spill table")
        if ku == INFINITY and kv == INFINITY:
            self.cache_edge = -1
            return KERNEL_VETO
        if ku < kv or (ku == kv and c.u < c.v):
            r, k = c.u, c.v
            self.cache_key, self.cache_acc = ku, au
        else:
            r, k = c.v, c.u
            self.cache_key, self.cache_acc = kv, av
        c.removed = r
        c.kept = k
        c.p[0] = m.positions[m.stride * k]
        c.p[1] = m.positions[m.stride * k + 1]
        c.p[2] = m.positions[m.stride * k + 2]
        self.cache_edge = c.edge
        self.cache_removed = r
        self.remember_ring(m, r)
        return KERNEL_OK

    cdef void remember_ring(self, const KernelMesh* m, int r) noexcept nogil:
        """Keep the neighbours of r: the vertices whose stars the collapse changes."""
        cdef const HEArrays* a = m.he
        cdef int start = a.v_he[r]
        cdef int y = start
        cdef int ny, n = 0
        while True:
            if n == RING_MAX:
                self.ring_len = -1
                return
            self.ring[n] = he_dest(a, y)
            n += 1
            ny = he_ring_next(a, y)
            if ny < 0:
                if n == RING_MAX:
                    self.ring_len = -1
                    return
                self.ring[n] = a.corner[he_prev(y)]
                n += 1
                break
            if ny == start:
                break
            y = ny
        self.ring_len = n

    cdef int cost(self, Candidate* c) noexcept nogil:
        cdef double acc
        if c.edge != self.cache_edge or c.removed != self.cache_removed:
            # another kernel re-placed the collapse: cost the direction it chose
            if not self.may_remove(c.mesh, c, c.removed, c.kept):
                return KERNEL_VETO
            self.cache_key = self.key(c.mesh, c, c.removed, c.kept, &acc)
            if self.spill_failed:
                return self.fail(b"melod: out of memory for the spill table")
            self.cache_acc = acc
            self.cache_edge = c.edge
            self.cache_removed = c.removed
            self.remember_ring(c.mesh, c.removed)
        c.cost += self.weight * self.cache_key
        return KERNEL_OK

    cdef int commit(self, const Candidate* c) noexcept nogil:
        cdef const KernelMesh* m = c.mesh
        cdef const HEArrays* a = m.he
        cdef int k = c.kept
        cdef int start, y, ny, i
        cdef double acc = self.cache_key if self.accumulate == ACC_KEY else self.cache_acc
        if c.edge != self.cache_edge or c.removed != self.cache_removed:
            # a collapse the driver did along with the one ranked last (the other side of a
            # seam): it costs what that one cost; every star around k may have changed
            acc = self.cache_acc if self.accumulate != ACC_KEY else self.cache_key
            self.ring_len = -1
        self.cache_edge = -1
        self.update_faces(m, k)
        # the stars of the removed vertex's neighbours (k among them) changed: new
        # importance, accumulated cost (the paper's N_{v_i})
        self.touch(m, k, acc)
        if self.ring_len >= 0 and not same_point(c.p, &m.positions[m.stride * k]):
            self.ring_len = -1             # another kernel moved k: every star around k changed
        if self.ring_len >= 0:
            for i in range(self.ring_len):
                self.changed_buf[i] = self.ring[i]
                if self.ring[i] != k:
                    self.touch(m, self.ring[i], acc)
            # the driver re-ranks the edges around these (a copy: re-ranking calls place())
            self.changed = &self.changed_buf[0]
            self.n_changed = self.ring_len
            return KERNEL_OK
        self.n_changed = -1
        start = a.v_he[k]
        y = start
        while True:
            self.touch(m, he_dest(a, y), acc)
            ny = he_ring_next(a, y)
            if ny < 0:
                self.touch(m, a.corner[he_prev(y)], acc)
                break
            if ny == start:
                break
            y = ny
        return KERNEL_OK

    cdef void touch(self, const KernelMesh* m, int v, double acc) noexcept nogil:
        """v's star changed: new importance, accumulated cost, and its half-edges' cached
        costs forgotten (importance() does that on its walk round v)."""
        self.wv[v] = self.importance(m, v)
        if self.accumulate != ACC_OFF and acc > self.acc[v]:
            self.acc[v] = acc

    @property
    def importance_values(self):
        """The current visual importance of every vertex slot."""
        return np.asarray(self.wv)

    @property
    def accumulated(self):
        """The current accumulated cost of every vertex slot."""
        return np.asarray(self.acc)


def visual_importance(positions, faces, int n):
    """w_v = 1 - |sum A_i n_i / sum A_i| over the faces around each vertex (numpy; 0 for a
    vertex without faces of positive area)."""
    F = np.asarray(faces)
    cr = face_vectors(positions, F)                  # 2 A n
    return _importance(cr, np.linalg.norm(cr, axis=1), F, n)


def _slot_importance(const double[:, :] P, const int[:, ::1] F, int n):
    """visual_importance() of the face slots, face by face (no per-face arrays: 32 bytes a
    vertex at most): the same numbers, summed in the same order as numpy's bincount."""
    cdef int m = F.shape[0]
    cdef int f, j, v
    cdef double e1[3]
    cdef double e2[3]
    cdef double cr[3]
    cdef double L, w
    sums = np.zeros((n, 4), dtype=np.float64)       # sum of (b - a) x (c - a), of its length
    cdef double[:, ::1] S = sums
    out = np.zeros(n, dtype=np.float64)
    cdef double[::1] W = out
    with nogil:
        for f in range(m):
            for j in range(3):
                e1[j] = P[F[f, 1], j] - P[F[f, 0], j]
                e2[j] = P[F[f, 2], j] - P[F[f, 0], j]
            cross3(e1, e2, cr)
            L = norm3(cr)
            for j in range(3):
                v = F[f, j]
                S[v, 0] += cr[0]
                S[v, 1] += cr[1]
                S[v, 2] += cr[2]
                S[v, 3] += L
        for v in range(n):
            if S[v, 3] > 0.0:
                w = 1.0 - sqrt(S[v, 0] * S[v, 0] + S[v, 1] * S[v, 1] + S[v, 2] * S[v, 2]) / S[v, 3]
                W[v] = w if w > 0.0 else 0.0
    return out


def _importance(cr, length, faces, int n):
    s = vertex_sums(faces, cr, n)
    tot = vertex_sums(faces, length, n)
    w = np.zeros(n)
    ok = tot > 0.0
    w[ok] = 1.0 - np.linalg.norm(s[ok], axis=1) / tot[ok]
    return np.clip(w, 0.0, 1.0)
