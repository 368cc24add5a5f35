# cython: language_level=3
"""Greedy vertex-removal driver (Schroeder et al. 1992; Chuon & Guha), the second operator
family of the papers: remove a vertex with its star and re-triangulate the hole.

The loop (``VertexRemover.run_c``), without the GIL and without allocation:

    pop the cheapest vertex -> re-evaluate its star with the kernel (cost, error, the hole's
    triangulation) -> check the triangulation (topology, flips, quality, volume) -> replace
    the star in the half-edge arrays -> kernel.commit -> re-evaluate every vertex of the old
    link (their stars changed).

One candidate per vertex slot lives in an indexed heap keyed by the kernel's
``Removal.cost``; for a ``star_local`` kernel its triangles are kept too, so a popped
candidate is not evaluated a second time.  A removal the checks refuse takes the vertex out of the heap until its
star changes (or a rescan, when the heap runs dry).  Gated kernels (``kernel.gated``,
Chuon & Guha's median filter) only let the candidates whose gate is >= the median gate of
all candidates compete; the median is kept by :class:`MedianFilter` (two indexed heaps).

Checks and their exact meaning: docs/algorithms.md, "Vertex removal".
"""
import numpy as np
cimport numpy as cnp
from libc.math cimport sqrt, INFINITY

from .halfedge cimport HalfEdgeMesh, HEArrays, he_next, he_prev, he_dest, he_ring_next, replace_star
from .heap cimport IndexedHeap
from .vec3 cimport cross3, dot3
from lodkit.kernel cimport KernelMesh, KERNEL_OK, KERNEL_VETO, KERNEL_ERROR, VERTEX_FIXED, VERTEX_BOUNDARY
from lodkit.removal cimport RemovalKernel, Star, Removal, MAX_VALENCE as STAR_MAX_VALENCE
from . cimport common
from .interrupt cimport signal_pending, raise_pending, INTERRUPT_EVERY

cdef enum:
    # triangles cached per vertex for a star-local kernel (stars of up to 16 link vertices;
    # larger ones are evaluated again when popped): 42 bytes a vertex instead of 3 MAX_VALENCE
    CACHE_TRIS = 14
from .common cimport MAX_VALENCE, BOUNDARY_LOCK, BOUNDARY_PRESERVE, BOUNDARY_FREE
from .checks cimport (CheckLimits, check_limits, angle_exceeds, turned_from_input, new_fold, folds, tri_quality,
                      face_volume, turns_inside_out)

cnp.import_array()

# Star / Removal (removal.pxd, the public interface) are sized by its MAX_VALENCE, the driver's
# and the half-edge arrays' buffers by common.pxd's: they must agree.
if STAR_MAX_VALENCE != MAX_VALENCE:
    raise ImportError(f"removal.pxd MAX_VALENCE ({STAR_MAX_VALENCE}) != common.pxd MAX_VALENCE ({MAX_VALENCE})")

# statuses of run(): common.pxd's RunStatus (RUN_GROW stays inside run())
RUN_TARGET = common.RUN_TARGET
RUN_CHUNK = common.RUN_CHUNK
RUN_EXHAUSTED = common.RUN_EXHAUSTED
RUN_ERROR = common.RUN_ERROR

# per-vertex state (VertexRemover.states): why a vertex is not removed (yet)
cdef enum:
    ST_NONE = 0         # dead, fixed, or not evaluated
    ST_CANDIDATE = 1    # a valid evaluation: in the heap (or, gated, below the median)
    ST_KERNEL = 2       # the kernel vetoed its removal
    ST_ERROR = 3        # its error exceeds max_error
    ST_TOPOLOGY = 4     # the triangulation would break the manifold / topology / welding rules
    ST_GEOMETRY = 5     # a new face would flip, fold or degenerate
    ST_QUALITY = 6      # a new face would be a sliver (min_quality)
    ST_VOLUME = 7       # a closed surface would turn inside out
    ST_VALENCE = 8      # more than MAX_VALENCE link vertices
    ST_FIXED = 9        # locked, split copy, 'lock' boundary or attribute-seam vertex
    N_STATES = 10
    PAIR_RERANK = 100   # remove_pair(): the pair costs more than its key, ranked again

STATE_NAMES = ("none", "candidate", "kernel", "max_error", "topology", "geometry", "quality",
               "volume", "valence", "fixed")

cdef class MedianFilter:
    """The median of a changing set of (id, value) pairs, without re-sorting: the smaller
    half in a max-heap (``lo``, keys negated), the larger half in a min-heap (``hi``),
    ``len(lo) == ceil(n / 2)``.  The median is the largest value of ``lo`` (the lower
    median: the ceil(n/2)-th smallest value).  Insert, update and remove are O(log n);
    :meth:`band` lists the ids whose value lies in [a, b) in O(answer) by walking both heaps
    from their roots."""

    cdef IndexedHeap lo
    cdef IndexedHeap hi
    cdef double[::1] val
    cdef int[::1] stack
    cdef readonly int capacity

    def __cinit__(self, int capacity):
        if capacity < 0:
            raise ValueError(f"capacity must be >= 0, got {capacity}")
        self.capacity = capacity
        self.lo = IndexedHeap(capacity)
        self.hi = IndexedHeap(capacity)
        self.val = np.full(max(capacity, 1), np.nan)
        self.stack = np.zeros(max(capacity, 1), dtype=np.intc)

    cdef inline int count(self) noexcept nogil:
        return self.lo.size + self.hi.size

    cdef void _rebalance(self) noexcept nogil:
        cdef int cid
        cdef double key
        while self.lo.size > self.hi.size + 1:
            self.lo.pop_fast(&cid, &key)
            self.hi.push_fast(cid, -key)
        while self.hi.size > self.lo.size:
            self.hi.pop_fast(&cid, &key)
            self.lo.push_fast(cid, -key)

    cdef void remove_fast(self, int cid) noexcept nogil:
        if self.lo.contains_fast(cid):
            self.lo.remove_fast(cid)
        elif self.hi.contains_fast(cid):
            self.hi.remove_fast(cid)
        else:
            return
        self.val[cid] = INFINITY
        self._rebalance()

    cdef void set_fast(self, int cid, double value) noexcept nogil:
        """Insert ``cid`` with ``value`` or change its value; NaN removes it.  ``cid`` must
        be in range (the driver's vertex slots are)."""
        if self.lo.contains_fast(cid) or self.hi.contains_fast(cid):
            if value == self.val[cid]:
                return
            if value == value:
                # stays in its half: move it there (the halves' sizes, hence the median's
                # rank, are unchanged)
                if self.lo.contains_fast(cid) and (self.hi.size == 0 or value <= self.hi.hkey[0]):
                    self.val[cid] = value
                    self.lo.push_fast(cid, -value)
                    return
                if self.hi.contains_fast(cid) and value >= -self.lo.hkey[0]:
                    self.val[cid] = value
                    self.hi.push_fast(cid, value)
                    return
            self.remove_fast(cid)
        if value != value:
            return
        self.val[cid] = value
        if self.lo.size == 0 or value <= -self.lo.hkey[0]:
            self.lo.push_fast(cid, -value)
        else:
            self.hi.push_fast(cid, value)
        self._rebalance()

    cdef double median_fast(self) noexcept nogil:
        """The lower median, +inf when empty."""
        if self.lo.size == 0:
            return INFINITY
        return -self.lo.hkey[0]

    cdef int band_fast(self, double a, double b, int* out) noexcept nogil:
        """Write the ids whose value v has a <= v < b to ``out``; returns their number."""
        cdef int n = 0, top, s, c, last
        cdef double v
        # lo holds keys -v: the ids with v >= a form a subtree at the root (key <= -a)
        if self.lo.size and self.lo.hkey[0] <= -a:
            self.stack[0] = 0
            top = 1
            while top > 0:
                top -= 1
                s = self.stack[top]
                v = -self.lo.hkey[s]
                if v < b:
                    out[n] = self.lo.hid[s]
                    n += 1
                c = 4 * s + 1
                last = c + 4 if c + 4 < self.lo.size else self.lo.size
                while c < last:
                    if self.lo.hkey[c] <= -a:
                        self.stack[top] = c
                        top += 1
                    c += 1
        # hi holds keys v: the ids with v < b form a subtree at the root
        if self.hi.size and self.hi.hkey[0] < b:
            self.stack[0] = 0
            top = 1
            while top > 0:
                top -= 1
                s = self.stack[top]
                v = self.hi.hkey[s]
                if v >= a:
                    out[n] = self.hi.hid[s]
                    n += 1
                c = 4 * s + 1
                last = c + 4 if c + 4 < self.hi.size else self.hi.size
                while c < last:
                    if self.hi.hkey[c] < b:
                        self.stack[top] = c
                        top += 1
                    c += 1
        return n

    # ------------------------------------------------------------- Python API (tests)
    def _check_id(self, int cid):
        if not 0 <= cid < self.capacity:
            raise ValueError(f"id {cid} outside 0..{self.capacity - 1}")

    def set(self, int cid, double value):
        """Insert ``cid`` with ``value``, or change its value; NaN removes it."""
        self._check_id(cid)
        self.set_fast(cid, value)

    def remove(self, int cid):
        """Remove ``cid`` (absent ids are ignored)."""
        self._check_id(cid)
        self.remove_fast(cid)

    def median(self):
        """The lower median of the values (the ceil(n/2)-th smallest), None when empty."""
        return None if self.count() == 0 else self.median_fast()

    def band(self, double a, double b):
        """Sorted int32 array of the ids whose value v has a <= v < b."""
        out = np.zeros(max(self.count(), 1), dtype=np.intc)
        cdef int[::1] o = out
        cdef int n = self.band_fast(a, b, &o[0])
        return np.sort(out[:n])

    def __len__(self):
        return self.count()

    def __contains__(self, cid):
        return self.lo.contains_fast(<int>cid) or self.hi.contains_fast(<int>cid)

    def check(self):
        """Verify the halves' sizes and order (for tests); raises AssertionError."""
        self.lo.check()
        self.hi.check()
        if not (self.hi.size <= self.lo.size <= self.hi.size + 1):
            raise AssertionError(f"halves of sizes {self.lo.size}, {self.hi.size}")
        if self.lo.size and self.hi.size and -self.lo.hkey[0] > self.hi.hkey[0]:
            raise AssertionError("the lower half holds a value above the upper half's least")
        return True


cdef inline double tri_normal(const double* a, const double* b, const double* c, double* n,
                              double* sumsq) noexcept nogil:
    """(b - a) x (c - a) into ``n``; returns its length; ``sumsq`` gets the summed squared
    edge lengths."""
    cdef double e1[3]
    cdef double e2[3]
    cdef int i
    sumsq[0] = 0.0
    for i in range(3):
        e1[i] = b[i] - a[i]
        e2[i] = c[i] - a[i]
        sumsq[0] += e1[i] * e1[i] + e2[i] * e2[i] + (c[i] - b[i]) * (c[i] - b[i])
    cross3(e1, e2, n)
    return sqrt(dot3(n, n))


cdef class RemovalRecords:
    """The removal sequence of a VertexRemover: per removal the vertex, whether its star was
    closed, its link (``off[i] .. off[i+1]`` in ``link``), the hole's k - 2 triangles (link
    indices, at ``3 * (off[i] - 2 i)`` in ``tri``), the cost and the error.  ``on`` False:
    one unused row."""
    cdef bint on
    cdef int n                      # rows: vertex slots
    cdef int[::1] v
    cdef unsigned char[::1] closed
    cdef long long[::1] off
    cdef int[::1] link
    cdef unsigned char[::1] tri
    cdef double[::1] cost
    cdef double[::1] err
    cdef long long cap              # capacity of link

    def __init__(self, int n, bint on):
        self.on = on
        self.n = n
        self.cap = 0

    def grow(self, long long cap, int n_done):
        """Make room for ``cap`` link entries, keeping the ``n_done`` removals written."""
        cdef long long used = self.off[n_done] if self.cap else 0
        cap = max(cap, 1)
        if self.cap == 0:
            nr = self.n if self.on else 0
            self.v = np.zeros(max(nr, 1), dtype=np.intc)
            self.closed = np.zeros(max(nr, 1), dtype=np.uint8)
            self.off = np.zeros(nr + 1, dtype=np.int64)
            self.cost = np.zeros(max(nr, 1))
            self.err = np.zeros(max(nr, 1))
            self.link = np.zeros(cap, dtype=np.intc)
            self.tri = np.zeros(3 * cap, dtype=np.uint8)
        else:
            link = np.zeros(cap, dtype=np.intc)
            link[:used] = np.asarray(self.link)[:used]
            tri = np.zeros(3 * cap, dtype=np.uint8)
            tri[:3 * used] = np.asarray(self.tri)[:3 * used]
            self.link = link
            self.tri = tri
        self.cap = cap

    def rows(self, int r):
        """The first ``r`` removals as a dict of arrays (see ``VertexRemover.records``)."""
        off = np.asarray(self.off)[:r + 1].copy()
        total = int(off[r])
        return {
            "removed": np.asarray(self.v)[:r].copy(),
            "closed": np.asarray(self.closed)[:r].astype(bool),
            "offsets": off,
            "link": np.asarray(self.link)[:total].copy(),
            "triangles": np.asarray(self.tri)[:3 * (total - 2 * r)].astype(np.int64).reshape(-1, 3),
            "cost": np.asarray(self.cost)[:r].copy(),
            "error": np.asarray(self.err)[:r].copy(),
        }


cdef class VertexRemover:
    """Greedy vertex removal over a :class:`HalfEdgeMesh` (modified in place).

    positions : (n, 3) float64 normalised positions (never changed: the output vertices are
                a subset of the input)
    kernel    : a prepared :class:`lodkit._core.removal.RemovalKernel`
    fixed     : (n,) uint8/bool, 1 = never removed (locked, split copies, seam copies)
    boundary  : 0 lock (boundary vertices are fixed), 1 preserve, 2 free (the same checks:
                see docs/algorithms.md)
    max_normal_angle, min_quality, max_error : as for the collapse driver
    closed_connected : track the signed volume and refuse a removal that changes its sign
    record    : keep every removal (``records()``)
    """

    cdef HalfEdgeMesh hm
    cdef HEArrays* m
    cdef double[:, ::1] pos
    cdef double* P
    cdef unsigned char[::1] vflags
    cdef RemovalKernel kernel
    cdef KernelMesh kmesh
    cdef IndexedHeap heap
    cdef MedianFilter filt
    cdef readonly bint gated
    cdef double med                 # the median the heap's membership agrees with
    cdef double[::1] vcost
    cdef double[::1] verr
    cdef double[::1] vgate
    cdef unsigned char[::1] state
    cdef int[::1] band_buf
    cdef double[::1] n0             # (3 n_faces) unit normal of the input face of each face slot
    cdef int boundary
    cdef CheckLimits lim            # the checks' limits (checks.pxd)
    cdef double max_error
    cdef double closed_volume
    cdef double pending_dvol
    cdef readonly int n_collapses   # removals done
    cdef readonly double max_error_done
    cdef readonly bint failed
    cdef long[::1] nref             # refusal events by state code
    cdef int removals_since_rescan
    cdef readonly long n_evaluations  # kernel evaluate() calls over the run (profiling, tests)
    cdef readonly long n_rescans      # full rescans of every vertex slot (the start included)
    cdef int reranks                # re-ranks on pop since the last removal
    cdef Star star
    cdef Removal rem
    cdef int hv[MAX_VALENCE]        # hv[i]: the half-edge v -> link[i] in face[i]
    # star-local kernels (``star_local = True``): each candidate's triangulation, kept from
    # its evaluation so that popping it needs no second evaluation (its star is unchanged)
    cdef readonly bint star_local
    cdef unsigned char[::1] ctri    # 3 CACHE_TRIS per vertex slot: the triangles (link indices)
    cdef unsigned char[::1] ck      # the star's k at that evaluation
    cdef unsigned char[::1] cn      # the number of triangles
    cdef int slot_plan[MAX_VALENCE]  # geometry_ok: the face slot each new triangle takes
    cdef RemovalRecords rec
    # ``weld``: the slots grouped by position (attribute seam copies, split copies), so the
    # manifold rules hold for the welded surface too: weld_rep[v] names v's group, weld_next
    # walks it (cyclic; -1 alone).  Without it, groups are the split copies of one input vertex.
    cdef bint welded
    cdef int[::1] weld_rep
    cdef int[::1] weld_next
    # ``seams``: each attribute-seam copy's partner slot on the other side of its seam (< 0:
    # none).  A paired copy goes only together with its partner (remove_pair), so the seam
    # stays closed; without ``seams`` every seam copy must be fixed by the caller
    cdef bint paired
    cdef int[::1] partner
    cdef readonly int n_seam_pairs  # pair removals done (two removals each)

    def __init__(self, HalfEdgeMesh hm, positions, RemovalKernel kernel, fixed,
                 int boundary=BOUNDARY_PRESERVE, double max_normal_angle=90.0, double min_quality=0.0,
                 double max_error=INFINITY, bint record=False, bint closed_connected=False, weld=None,
                 seams=None):
        cdef int n = hm.n_vertices
        if kernel is None:
            raise TypeError("kernel must be a lodkit._core.removal.RemovalKernel")
        self.hm = hm
        self.m = &hm.c
        pos_arr = np.ascontiguousarray(positions, dtype=np.float64)
        if pos_arr.shape != (n, 3):
            raise ValueError(f"positions must have shape ({n}, 3)")
        self.pos = pos_arr
        self.P = &self.pos[0, 0] if n else NULL
        fixed_arr = np.asarray(fixed).reshape(-1)
        if fixed_arr.shape[0] != n:
            raise ValueError(f"fixed must have {n} entries")
        if boundary not in (BOUNDARY_LOCK, BOUNDARY_PRESERVE, BOUNDARY_FREE):
            raise ValueError(f"unknown boundary policy {boundary}")
        if not (0.0 < max_normal_angle <= 180.0):
            raise ValueError("max_normal_angle must be in (0, 180] degrees")
        self.boundary = boundary
        self.welded = weld is not None
        if self.welded:
            self.weld_rep = np.ascontiguousarray(weld[0], dtype=np.intc)
            self.weld_next = np.ascontiguousarray(weld[1], dtype=np.intc)
            if self.weld_rep.shape[0] != n or self.weld_next.shape[0] != n:
                raise ValueError(f"weld must be two arrays of {n} slots")
        self.paired = seams is not None
        if self.paired:
            self.partner = np.ascontiguousarray(seams, dtype=np.intc)
            if self.partner.shape[0] != n:
                raise ValueError(f"seams must have {n} entries")
            if not self.welded:
                raise ValueError("seams need weld (the manifold rules must see the welded surface)")
        flags = (fixed_arr != 0).astype(np.uint8) * VERTEX_FIXED
        bnd = hm.boundary_vertices
        flags[bnd] |= VERTEX_BOUNDARY
        if boundary == BOUNDARY_LOCK:
            # the true border stays; a seam is no border (its pairs go together)
            flags[bnd & ~(np.asarray(self.partner) >= 0) if self.paired else bnd] |= VERTEX_FIXED
        self.vflags = np.ascontiguousarray(flags, dtype=np.uint8)
        self.kernel = kernel
        self.gated = kernel.gated
        self.star_local = bool(getattr(kernel, "star_local", False))
        nc = n if self.star_local else 0
        self.ctri = np.zeros(max(3 * CACHE_TRIS * nc, 1), dtype=np.uint8)
        self.ck = np.zeros(max(nc, 1), dtype=np.uint8)
        self.cn = np.zeros(max(nc, 1), dtype=np.uint8)
        self.kmesh.he = self.m
        self.kmesh.positions = self.P
        self.kmesh.stride = 3
        self.kmesh.flags = &self.vflags[0] if n else NULL
        self.kmesh.n_vertices = n
        self.kmesh.n_faces = hm.n_faces
        self.star.mesh = &self.kmesh
        self.lim = check_limits(max_normal_angle, min_quality)
        self.max_error = max_error
        self.heap = IndexedHeap(n)
        self.filt = MedianFilter(n if self.gated else 0)
        self.med = INFINITY
        self.vcost = np.zeros(max(n, 1))
        self.verr = np.zeros(max(n, 1))
        self.vgate = np.full(max(n, 1), np.nan)
        self.state = np.zeros(max(n, 1), dtype=np.uint8)
        self.band_buf = np.zeros(max(n, 1), dtype=np.intc)
        self.nref = np.zeros(N_STATES, dtype=np.int_)
        self.n_collapses = 0
        self.max_error_done = 0.0
        self.failed = False
        # the input face normals: a face slot keeps its input face (face_map) for good
        P = pos_arr
        C = hm.corners
        # in blocks of faces: the same numbers as over the whole array at once, without its
        # temporaries (several (m, 3) arrays: ~200 bytes per input vertex at the peak)
        n0 = np.zeros((C.shape[0], 3)) if C.shape[0] else np.zeros((1, 3))
        for b in range(0, C.shape[0], 65536):
            Cb = C[b:b + 65536]
            nrm = np.cross(P[Cb[:, 1]] - P[Cb[:, 0]], P[Cb[:, 2]] - P[Cb[:, 0]])
            ln = np.linalg.norm(nrm, axis=1, keepdims=True)
            np.divide(nrm, ln, out=n0[b:b + 65536], where=ln > 0)
        self.n0 = n0.reshape(-1)
        self.closed_volume = 0.0
        cdef int f
        if closed_connected:
            for f in range(hm.n_faces):
                if hm.face_alive[f]:
                    self.closed_volume += face_volume(&self.P[3 * hm.corner[3 * f]], &self.P[3 * hm.corner[3 * f + 1]],
                                                      &self.P[3 * hm.corner[3 * f + 2]])
        self.rec = RemovalRecords(n, record)
        self._alloc_records(8 * n if record else 0)
        self.removals_since_rescan = 0
        self.reranks = 0
        with nogil:
            self.rescan()

    def _alloc_records(self, long long cap):
        """Make room for ``cap`` link entries in the records (keeping those written)."""
        self.rec.grow(cap, self.n_collapses)

    # ------------------------------------------------------------- the star
    cdef int fill_star(self, int v) noexcept nogil:
        """Fill ``self.star`` (and ``hv``) for vertex ``v``; returns k, or -1 if the star has
        more than MAX_VALENCE link vertices."""
        cdef Star* s = &self.star
        cdef int start = self.m.v_he[v]
        cdef int h = start
        cdef int nh, k = 0
        s.v = v
        while True:
            if k >= MAX_VALENCE:
                return -1
            s.link[k] = he_dest(self.m, h)
            s.face[k] = h // 3
            self.hv[k] = h
            k += 1
            nh = he_ring_next(self.m, h)
            if nh < 0:
                if k >= MAX_VALENCE:
                    return -1
                s.link[k] = self.m.corner[he_prev(h)]
                k += 1
                s.closed = 0
                break
            h = nh
            if h == start:
                s.closed = 1
                break
        s.k = k
        return k

    cdef int evaluate(self, int v) noexcept nogil:
        """Fill the star of ``v`` and ask the kernel: returns ST_CANDIDATE, ST_ERROR (over
        max_error), ST_KERNEL, ST_VALENCE or ST_FIXED; -1 if the kernel failed.  On
        ST_CANDIDATE ``self.rem`` holds the kernel's answer."""
        cdef int rc
        if not self.m.vertex_alive[v] or self.m.v_he[v] < 0:
            return ST_NONE
        if self.vflags[v] & VERTEX_FIXED:
            return ST_FIXED
        if self.fill_star(v) < 0:
            return ST_VALENCE
        self.rem.n_tris = 0
        self.rem.cost = 0.0
        self.rem.error = 0.0
        self.rem.gate = 0.0
        self.n_evaluations += 1
        rc = self.kernel.evaluate(&self.star, &self.rem)
        if rc == KERNEL_VETO:
            return ST_KERNEL
        if rc != KERNEL_OK:
            if not self.kernel.failed:
                self.kernel.fail(b"evaluate() returned an unknown status (not KERNEL_OK, KERNEL_VETO nor KERNEL_ERROR)")
            self.failed = True
            return -1
        if self.rem.cost != self.rem.cost:
            self.rem.cost = INFINITY        # a NaN cost ranks last rather than breaking the heap
        if not (self.rem.error <= self.max_error):
            return ST_ERROR                 # a NaN error is not within max_error
        return ST_CANDIDATE

    cdef void set_state(self, int v, int st) noexcept nogil:
        """Record the outcome of an evaluation of ``v`` and put it in / out of the heap and
        the median filter accordingly."""
        cdef double g
        if st != ST_CANDIDATE and st != ST_NONE:
            self.nref[st] += 1
        self.state[v] = st if st >= 0 else ST_NONE
        if st != ST_CANDIDATE:
            self.heap.remove_fast(v)
            if self.gated:
                self.filt.remove_fast(v)
            return
        self.vcost[v] = self.rem.cost
        self.verr[v] = self.rem.error
        if self.star_local:
            self.keep(v)
        if not self.gated:
            self.heap.push_fast(v, self.rem.cost)
            return
        g = self.rem.gate
        self.vgate[v] = g
        self.filt.set_fast(v, g)
        if g == g and g >= self.med:
            self.heap.push_fast(v, self.rem.cost)
        else:
            self.heap.remove_fast(v)

    cdef void keep(self, int v) noexcept nogil:
        """Cache ``self.rem``'s triangles for ``v`` (just evaluated: ``self.star`` is its star).
        A count outside 0..CACHE_TRIS is kept as 255, which :meth:`recall` never matches: that
        star is evaluated again when popped (the same answer: the kernel is star-local)."""
        cdef int i, n = self.rem.n_tris
        cdef unsigned char* t = &self.ctri[3 * CACHE_TRIS * v]
        self.ck[v] = <unsigned char>self.star.k
        if n < 0 or n > CACHE_TRIS:
            self.cn[v] = 255
            return
        self.cn[v] = <unsigned char>n
        for i in range(3 * n):
            t[i] = <unsigned char>self.rem.tri[i]

    cdef int recall(self, int v) noexcept nogil:
        """The popped candidate ``v`` of a star-local kernel: fill its star and restore its
        evaluation from the cache (the star has not changed since: every vertex whose star a
        removal changes is evaluated again).  Falls back to :meth:`evaluate` if the star's
        size does not match.  Returns as evaluate()."""
        cdef int i, n
        cdef const unsigned char* t
        if self.cn[v] == 255 or self.fill_star(v) != self.ck[v]:
            return self.evaluate(v)
        n = self.cn[v]
        t = &self.ctri[3 * CACHE_TRIS * v]
        self.rem.n_tris = n
        for i in range(3 * n):
            self.rem.tri[i] = t[i]
        self.rem.cost = self.vcost[v]
        self.rem.error = self.verr[v]
        self.rem.gate = self.vgate[v] if self.gated else 0.0
        return ST_CANDIDATE

    cdef void refuse(self, int v, int st) noexcept nogil:
        self.nref[st] += 1
        self.state[v] = st
        self.heap.remove_fast(v)
        if self.gated:
            self.filt.remove_fast(v)

    cdef void sync_median(self) noexcept nogil:
        """Bring the heap's membership in line with the current median: the candidates whose
        gate crossed it enter or leave."""
        cdef double mnew = self.filt.median_fast()
        cdef double mold = self.med
        cdef int n, i, w
        if mnew == mold:
            return
        self.med = mnew
        if mnew > mold:
            n = self.filt.band_fast(mold, mnew, &self.band_buf[0])
            for i in range(n):
                self.heap.remove_fast(self.band_buf[i])
        else:
            n = self.filt.band_fast(mnew, mold, &self.band_buf[0])
            for i in range(n):
                w = self.band_buf[i]
                if self.state[w] == ST_CANDIDATE:
                    self.heap.push_fast(w, self.vcost[w])

    cdef void rescan(self) noexcept nogil:
        cdef int v, st
        self.n_rescans += 1
        self.heap.clear_fast()
        for v in range(self.hm.n_vertices):
            st = self.evaluate(v)
            if st < 0:
                return
            if st == ST_NONE and self.state[v] == ST_NONE:
                continue
            if st == ST_FIXED:
                self.state[v] = ST_FIXED
                continue
            self.set_state(v, st)
        if self.gated:
            self.sync_median()
        self.removals_since_rescan = 0

    # ------------------------------------------------------------- the checks
    cdef bint triangulation_valid(self, int k, bint closed) noexcept nogil:
        """Is ``self.rem`` an oriented triangulation of the k-gon (kernel contract)?  Every
        link edge i -> i+1 (with an open star's closing edge k-1 -> 0) used once in that
        direction, every other directed edge used once and its reverse too."""
        cdef unsigned long long mark[MAX_VALENCE]
        cdef int t, c, a, b, i
        if self.rem.n_tris != k - 2:
            return False
        for i in range(k):
            mark[i] = 0
        for t in range(k - 2):
            for c in range(3):
                a = self.rem.tri[3 * t + c]
                b = self.rem.tri[3 * t + (c + 1) % 3]
                if a < 0 or a >= k or b < 0 or b >= k or a == b:
                    return False
                if mark[a] & (1ULL << b):
                    return False
                mark[a] |= 1ULL << b
        for i in range(k):
            if k > 2 and not (mark[i] & (1ULL << ((i + 1) % k))):
                return False
        for t in range(k - 2):
            for c in range(3):
                a = self.rem.tri[3 * t + c]
                b = self.rem.tri[3 * t + (c + 1) % 3]
                if b == (a + 1) % k:
                    continue
                if not (mark[b] & (1ULL << a)) or a == (b + 1) % k:
                    return False
        return True

    cdef inline int source(self, int v) noexcept nogil:
        return self.hm.vertex_source[v] if self.hm.has_copies else v

    cdef inline int key(self, int v) noexcept nogil:
        """v's group: its position group with ``weld``, else its input vertex."""
        return self.weld_rep[v] if self.welded else self.source(v)

    cdef bint ring_has(self, int a, int b, int c) noexcept nogil:
        """Over every copy of ``a`` (its group: key()), is there a live face (a, p, q) with
        key(b) in {p, q} (``c`` < 0: the edge a b exists, for every neighbour of a is the p or
        q of one of its faces) or with {p, q} = {key(b), key(c)} (the face a b c exists)?"""
        cdef int sb = self.key(b), sc = self.key(c) if c >= 0 else -1
        cdef int x = a
        cdef int start, y, ny, p, q
        while True:
            start = self.m.v_he[x]
            y = start
            while True:
                p = self.key(he_dest(self.m, y))
                q = self.key(self.m.corner[he_prev(y)])
                if (p == sb and (sc < 0 or q == sc)) or (q == sb and (sc < 0 or p == sc)):
                    return True
                ny = he_ring_next(self.m, y)
                if ny < 0 or ny == start:
                    break
                y = ny
            if self.welded:
                x = self.weld_next[x]
            elif self.hm.has_copies:
                x = self.hm.next_copy[x]
            else:
                return False
            if x < 0 or x == a:
                return False

    cdef inline bint adjacent(self, int a, int b) noexcept nogil:
        """Is there an edge between the groups of a and b (key())?"""
        return self.ring_has(a, b, -1)

    cdef inline bint face_exists(self, int a, int b, int c) noexcept nogil:
        """Is there a live face on the groups of a, b and c (key())?"""
        return self.ring_has(a, b, c)

    cdef int topology_ok(self) noexcept nogil:
        """The manifold / weld rules for the removal in ``self.star`` / ``self.rem``."""
        cdef Star* s = &self.star
        cdef int k = s.k, i, j, t, c, a, b
        if s.closed and k < 3:
            return False                  # a two-face pillow would vanish
        if not s.closed and k == 2:
            # one face: its outer edge must have a face on the other side (else the whole
            # isolated triangle would go)
            return self.m.twin[he_next(self.hv[0])] >= 0
        # link vertices distinct, by input vertex (copies of a split vertex)
        for i in range(k):
            for j in range(i + 1, k):
                if s.link[i] == s.link[j] or self.source(s.link[i]) == self.source(s.link[j]):
                    return False
        # every new edge (diagonal, or an open star's closing edge) must not exist yet
        for t in range(k - 2):
            for c in range(3):
                a = self.rem.tri[3 * t + c]
                b = self.rem.tri[3 * t + (c + 1) % 3]
                if b == (a + 1) % k and (s.closed or a != k - 1):
                    continue                  # a link edge: it stays
                if a > b and b != (a + 1) % k:
                    continue                  # each diagonal once (its a < b half)
                if self.adjacent(s.link[a], s.link[b]):
                    return False
        if s.closed and k == 3 and self.face_exists(s.link[0], s.link[1], s.link[2]):
            return False                      # a tetrahedron (or the like) would collapse flat
        return True

    cdef int geometry_ok(self) noexcept nogil:
        """Flips, folds, slivers and volume (see docs/algorithms.md, "Vertex removal").
        Returns ST_CANDIDATE, ST_GEOMETRY, ST_QUALITY or ST_VOLUME.  Sets pending_dvol and
        slot_plan (the face slot, hence the input face, each new triangle takes)."""
        cdef Star* s = &self.star
        cdef int k = s.k, nf = s.k if s.closed else s.k - 1
        cdef int i, j, t, c, a, b, x3, out, best
        cdef double nold[3 * MAX_VALENCE]
        cdef double lold[MAX_VALENCE]
        cdef double nnew[3 * MAX_VALENCE]
        cdef double lnew[MAX_VALENCE]
        cdef int used[MAX_VALENCE]
        cdef double N[3]
        cdef double ng[3]
        cdef double lN, ss, q, qmin_old = INFINITY, qmin_new = INFINITY, lg, dvol = 0.0, d, dbest
        cdef const double* pv = &self.P[3 * s.v]
        N[0] = N[1] = N[2] = 0.0
        for i in range(nf):
            lold[i] = tri_normal(pv, &self.P[3 * s.link[i]], &self.P[3 * s.link[(i + 1) % k]], &nold[3 * i], &ss)
            used[i] = 0
            for j in range(3):
                N[j] += nold[3 * i + j]
            q = tri_quality(lold[i], ss) if ss > 0.0 else 0.0
            if q < qmin_old:
                qmin_old = q
            if self.closed_volume != 0.0:
                dvol -= face_volume(pv, &self.P[3 * s.link[i]], &self.P[3 * s.link[(i + 1) % k]])
        lN = sqrt(dot3(N, N))
        for t in range(k - 2):
            a = s.link[self.rem.tri[3 * t]]
            b = s.link[self.rem.tri[3 * t + 1]]
            c = s.link[self.rem.tri[3 * t + 2]]
            lnew[t] = tri_normal(&self.P[3 * a], &self.P[3 * b], &self.P[3 * c], &nnew[3 * t], &ss)
            if not lnew[t] > 1e-12 * ss:
                return ST_GEOMETRY            # degenerate
            if lN > 0.0 and angle_exceeds(dot3(&nnew[3 * t], N), self.lim.cos_max_angle, lnew[t], lN):
                return ST_GEOMETRY            # turned too far from the star's mean normal
            # the face slot it takes: of the old faces' slots left, the one whose input face
            # is best aligned with it (greedy, in triangle order); it must stay within
            # min(max_normal_angle, 90) degrees of that input face (as a moved face must in
            # the collapse driver)
            best = -1
            dbest = -INFINITY
            for i in range(nf):
                if used[i]:
                    continue
                d = dot3(&nnew[3 * t], &self.n0[3 * s.face[i]])
                if d > dbest:
                    dbest = d
                    best = i
            used[best] = 1
            self.slot_plan[t] = s.face[best]
            if self.lim.check_orig and turned_from_input(dbest, self.lim.cos_orig_angle, 1.0, lnew[t]):
                return ST_GEOMETRY
            q = tri_quality(lnew[t], ss)
            if q < qmin_new:
                qmin_new = q
            if self.closed_volume != 0.0:
                dvol += face_volume(&self.P[3 * a], &self.P[3 * b], &self.P[3 * c])
        # each new face against the old face whose link edge it inherits, and against the
        # outer face across that edge (no new fold)
        for t in range(k - 2):
            for c in range(3):
                a = self.rem.tri[3 * t + c]
                b = self.rem.tri[3 * t + (c + 1) % 3]
                if b != (a + 1) % k or (not s.closed and a == k - 1):
                    continue
                if lold[a] > 0.0 and angle_exceeds(dot3(&nnew[3 * t], &nold[3 * a]), self.lim.cos_max_angle,
                                                   lnew[t], lold[a]):
                    return ST_GEOMETRY
                if not self.lim.check_orig:
                    continue
                out = self.m.twin[he_next(self.hv[a])]        # link[a+1] -> link[a]
                if out < 0:
                    continue
                x3 = self.m.corner[he_prev(out)]
                lg = tri_normal(&self.P[3 * s.link[b]], &self.P[3 * s.link[a]], &self.P[3 * x3], ng, &ss)
                if lg > 0.0 and new_fold(&nnew[3 * t], lnew[t], &nold[3 * a], lold[a], ng, lg):
                    return ST_GEOMETRY
        if self.lim.check_orig:
            # no fold between two new faces across a diagonal
            for t in range(k - 2):
                for j in range(t + 1, k - 2):
                    if self.share_edge(t, j) and folds(&nnew[3 * t], lnew[t], &nnew[3 * j], lnew[j]):
                        return ST_GEOMETRY
        if self.lim.min_quality > 0.0 and k > 2 and qmin_new < self.lim.min_quality and qmin_new < qmin_old:
            return ST_QUALITY
        if self.closed_volume != 0.0:
            if turns_inside_out(self.closed_volume, dvol):
                return ST_VOLUME
        self.pending_dvol = dvol
        return ST_CANDIDATE

    cdef bint share_edge(self, int t, int u) noexcept nogil:
        cdef int n = 0, i, j
        for i in range(3):
            for j in range(3):
                if self.rem.tri[3 * t + i] == self.rem.tri[3 * u + j]:
                    n += 1
        return n >= 2

    # ------------------------------------------------------------- the removal
    cdef int perform(self) noexcept nogil:
        """Replace the star in ``self.star`` by ``self.rem``; commit; re-evaluate the link.
        Returns 0, or -1 if the kernel failed."""
        cdef Star* s = &self.star
        cdef int k = s.k
        cdef int slot_of[MAX_VALENCE]
        cdef int dead[MAX_VALENCE]
        cdef int link[MAX_VALENCE]
        cdef int i, j, t, v = s.v
        cdef long long off
        for t in range(k - 2):
            slot_of[t] = self.slot_plan[t]
        replace_star(self.hm, v, s.link, s.face, k, s.closed, self.rem.tri, k - 2, slot_of, dead)
        if self.closed_volume != 0.0:
            self.closed_volume += self.pending_dvol
        if self.rec.on:
            i = self.n_collapses
            off = self.rec.off[i]
            self.rec.v[i] = v
            self.rec.closed[i] = s.closed
            for j in range(k):
                self.rec.link[off + j] = s.link[j]
            for j in range(3 * (k - 2)):
                self.rec.tri[3 * (off - 2 * i) + j] = <unsigned char>self.rem.tri[j]
            self.rec.off[i + 1] = off + k
            self.rec.cost[i] = self.rem.cost
            self.rec.err[i] = self.rem.error
        self.n_collapses += 1
        self.removals_since_rescan += 1
        self.reranks = 0
        if self.rem.error > self.max_error_done:
            self.max_error_done = self.rem.error
        self.heap.remove_fast(v)
        self.state[v] = ST_NONE
        if self.gated:
            self.filt.remove_fast(v)
        if self.kernel.commit(&self.star, &self.rem) == KERNEL_ERROR or self.kernel.failed:
            self.failed = True
            return -1
        # the old link's stars changed: evaluate them again (from a copy of the link:
        # evaluate() overwrites self.star)
        for i in range(k):
            link[i] = s.link[i]
        for i in range(k):
            if self.reevaluate(link[i]) < 0:
                return -1
            if self.paired and self.partner[link[i]] >= 0:
                # a seam copy goes with its partner: the partner's chances changed too
                if self.reevaluate(self.partner[link[i]]) < 0:
                    return -1
        return 0

    cdef int reevaluate(self, int x) noexcept nogil:
        cdef int st = self.evaluate(x)
        if st < 0:
            return -1
        if st != ST_FIXED:
            self.set_state(x, st)
        return 0

    cdef bint diagonals_clash(self, const Star* a, const Removal* ra, const Star* b,
                              const Removal* rb) noexcept nogil:
        """Do two holes' triangulations add an edge between the same two position groups
        (key()), other than the new boundary edges of a seam pair (which become one seam
        edge)?  Welded, that edge would have four faces."""
        cdef int t, c, x, y, u, w, ka = a.k, kb = b.k
        cdef int p0, p1, q0, q1
        for t in range(ka - 2):
            for c in range(3):
                x = ra.tri[3 * t + c]
                y = ra.tri[3 * t + (c + 1) % 3]
                if y == (x + 1) % ka and x != ka - 1:
                    continue                  # a link edge of a: it stays
                p0 = self.key(a.link[x])
                p1 = self.key(a.link[y])
                for u in range(kb - 2):
                    for w in range(3):
                        x = rb.tri[3 * u + w]
                        y = rb.tri[3 * u + (w + 1) % 3]
                        if y == (x + 1) % kb and x != kb - 1:
                            continue
                        if x == kb - 1 and y == 0:
                            continue          # b's new boundary edge (checked against a's by the caller)
                        q0 = self.key(b.link[x])
                        q1 = self.key(b.link[y])
                        if (p0 == q0 and p1 == q1) or (p0 == q1 and p1 == q0):
                            # a's new boundary edge may meet b's only (skipped above)
                            return True
        return False

    cdef int remove_pair(self, int v, double key) noexcept nogil:
        """``self.star`` / ``self.rem`` hold v's checked removal, v an attribute-seam copy:
        remove it together with its partner w, whose open star must end at the copies of
        v's two boundary neighbours (so both new boundary edges join the same two positions:
        the seam stays closed).  w's removal passes every check on its own; neither new
        triangulation may add an edge the other adds (welded, a non-manifold edge).  The
        pair costs the dearer of the two: a cheaper key is ranked again first.  Returns
        ST_CANDIDATE once both are done, the refusal's state, PAIR_RERANK, or -1 (the
        kernel failed)."""
        cdef Star sv = self.star
        cdef Removal rv = self.rem
        cdef int plan_v[MAX_VALENCE]
        cdef int plan_w[MAX_VALENCE]
        cdef double dv = self.pending_dvol, dw, cost
        cdef int w = self.partner[v], st, i, kw
        cdef Star sw
        cdef Removal rw
        for i in range(sv.k - 2):
            plan_v[i] = self.slot_plan[i]
        if sv.closed or not self.m.vertex_alive[w]:
            return ST_TOPOLOGY
        st = self.recall(w) if self.star_local and self.state[w] == ST_CANDIDATE else self.evaluate(w)
        if st < 0:
            return -1
        if st != ST_CANDIDATE:
            return st
        kw = self.star.k
        if (self.star.closed or self.key(sv.link[0]) != self.key(self.star.link[kw - 1])
                or self.key(sv.link[sv.k - 1]) != self.key(self.star.link[0])):
            return ST_TOPOLOGY                # not a stretch of one seam: it would open
        for i in range(kw):
            if self.key(self.star.link[i]) == self.key(v):
                return ST_TOPOLOGY
        if not self.triangulation_valid(kw, self.star.closed):
            self.kernel.fail(b"evaluate() returned triangles that are no oriented triangulation "
                             b"of the hole (k - 2 triangles over the link indices; removal.pxd)")
            self.failed = True
            return -1
        if not self.topology_ok():
            return ST_TOPOLOGY
        st = self.geometry_ok()
        if st != ST_CANDIDATE:
            return st
        if self.diagonals_clash(&sv, &rv, &self.star, &self.rem):
            return ST_TOPOLOGY
        if self.closed_volume != 0.0 and turns_inside_out(self.closed_volume, dv + self.pending_dvol):
            return ST_VOLUME
        cost = rv.cost if rv.cost >= self.rem.cost else self.rem.cost
        if cost > key and self.reranks < self.hm.n_vertices:
            self.reranks += 1
            self.vcost[v] = cost
            self.heap.push_fast(v, cost)
            return PAIR_RERANK
        sw = self.star
        rw = self.rem
        dw = self.pending_dvol
        for i in range(kw - 2):
            plan_w[i] = self.slot_plan[i]
        self.star = sv
        self.rem = rv
        self.pending_dvol = dv
        for i in range(sv.k - 2):
            self.slot_plan[i] = plan_v[i]
        if self.perform() < 0:
            return -1
        self.star = sw
        self.rem = rw
        self.pending_dvol = dw
        for i in range(kw - 2):
            self.slot_plan[i] = plan_w[i]
        if self.perform() < 0:
            return -1
        self.n_seam_pairs += 1
        return ST_CANDIDATE

    cdef int run_c(self, int target_faces, int max_steps) noexcept nogil:
        cdef int v, st, steps = 0, n_iter = 0
        cdef double key
        while self.hm.n_alive_faces > target_faces:
            n_iter += 1
            if n_iter % INTERRUPT_EVERY == 0 and signal_pending():
                return common.RUN_INTERRUPTED
            if self.gated:
                self.sync_median()
            if steps >= max_steps:
                return common.RUN_CHUNK
            if self.rec.on and self.rec.off[self.n_collapses] + MAX_VALENCE > self.rec.cap:
                return common.RUN_GROW
            if self.heap.pop_fast(&v, &key) < 0:
                if self.removals_since_rescan == 0:
                    return common.RUN_EXHAUSTED
                self.rescan()
                if self.failed:
                    return common.RUN_ERROR
                continue
            if self.star_local and self.state[v] == ST_CANDIDATE:
                st = self.recall(v)
            else:
                st = self.evaluate(v)
            if st < 0:
                return common.RUN_ERROR
            if st != ST_CANDIDATE:
                self.set_state(v, st)
                continue
            if ((self.rem.cost > key or (self.gated and self.rem.gate != self.vgate[v]))
                    and self.reranks < self.hm.n_vertices):
                # the kernel's answer changed (a kernel with global state): re-rank.  A
                # cheaper answer is still the cheapest; the bound keeps a kernel whose
                # answers drift on every call from spinning here.
                self.reranks += 1
                self.set_state(v, st)
                continue
            if not self.triangulation_valid(self.star.k, self.star.closed):
                self.kernel.fail(b"evaluate() returned triangles that are no oriented triangulation "
                                 b"of the hole (k - 2 triangles over the link indices; removal.pxd)")
                self.failed = True
                return common.RUN_ERROR
            if not self.topology_ok():
                self.refuse(v, ST_TOPOLOGY)
                continue
            st = self.geometry_ok()
            if st != ST_CANDIDATE:
                self.refuse(v, st)
                continue
            if self.paired and self.partner[v] >= 0:
                st = self.remove_pair(v, key)
                if st < 0:
                    return common.RUN_ERROR
                if st == PAIR_RERANK:
                    continue
                if st != ST_CANDIDATE:
                    self.refuse(v, st)
                    continue
                steps += 2
                continue
            if self.perform() < 0:
                return common.RUN_ERROR
            steps += 1
        return common.RUN_TARGET

    # ------------------------------------------------------------- Python API
    def run(self, int target_faces, int max_steps=2**31 - 1):
        """Remove vertices until ``target_faces`` live faces remain, ``max_steps`` removals
        are done, or no valid removal is left.  Returns RUN_TARGET, RUN_CHUNK,
        RUN_EXHAUSTED or RUN_ERROR (the kernel failed: ``error_message``)."""
        cdef int status
        cdef int left = max_steps
        cdef int before
        while True:
            before = self.n_collapses
            with nogil:
                status = self.run_c(target_faces, left)
            left -= self.n_collapses - before
            if status == common.RUN_INTERRUPTED:
                raise_pending()
            if status != common.RUN_GROW:
                return status
            self._alloc_records(2 * self.rec.cap + 64)

    @property
    def error_message(self):
        """The message of the kernel if it failed ('' if it did not)."""
        return self.kernel.message if self.kernel.failed else ""

    @property
    def n_alive_faces(self):
        return self.hm.n_alive_faces

    @property
    def median(self):
        """Gated kernels: the current median gate of the candidates (None if none / not gated)."""
        return self.filt.median() if self.gated else None

    @property
    def states(self):
        """(n,) uint8 per vertex slot: why it is not removed (yet); STATE_NAMES names the codes."""
        return np.asarray(self.state)[:self.hm.n_vertices].copy()

    @property
    def refusals(self):
        """{reason: events} over the run: every evaluation or check that kept a vertex, by
        reason (kernel, max_error, topology, geometry, quality, volume, valence)."""
        arr = np.asarray(self.nref)
        return {STATE_NAMES[i]: int(arr[i]) for i in range(2, N_STATES - 1)}

    @property
    def held_back(self):
        """{reason: vertices} now: the live vertices that are no candidate, by reason."""
        st = self.states[np.asarray(self.hm.alive_vertices)]
        counts = np.bincount(st, minlength=N_STATES)
        return {STATE_NAMES[i]: int(counts[i]) for i in range(2, N_STATES)}

    @property
    def n_vetoed(self):
        """Kernel vetoes over the run (evaluation events)."""
        return int(self.nref[ST_KERNEL])

    @property
    def n_rejected_error(self):
        """Live vertices now held back because their error exceeds max_error."""
        return int(np.count_nonzero(self.states[np.asarray(self.hm.alive_vertices)] == ST_ERROR))

    @property
    def n_candidates(self):
        """Vertices in the heap now (competing)."""
        return self.heap.size

    def records(self):
        """The removal sequence, in vertex / face slots: dict of ``removed`` (r,), ``closed``
        (r,) bool, ``offsets`` (r + 1,) into ``link`` (the link of removal i is
        ``link[offsets[i]:offsets[i+1]]``, k_i entries), ``triangles`` (sum (k_i - 2), 3)
        link indices (removal i's at rows offsets[i] - 2 i onwards), ``cost``, ``error``.
        Needs ``record=True``."""
        if not self.rec.on:
            raise RuntimeError("this VertexRemover was made with record=False")
        return self.rec.rows(self.n_collapses)

    def evaluate_vertex(self, int v):
        """For tests: ``(state name, cost, error, gate, triangles)`` of the kernel's answer
        for ``v`` now (triangles as link indices; None unless a candidate).  Does not
        change the heap."""
        if not 0 <= v < self.hm.n_vertices:
            raise ValueError(f"vertex {v} out of range")
        cdef int st
        with nogil:
            st = self.evaluate(v)
        if st < 0:
            return ("error", None, None, None, None)
        tris = None
        if st == ST_CANDIDATE:
            # n_tris is the kernel's word: never read past Removal.tri (3 * MAX_VALENCE ints)
            n = min(max(self.rem.n_tris, 0), MAX_VALENCE)
            tris = np.array([self.rem.tri[i] for i in range(3 * n)], dtype=np.int64).reshape(-1, 3)
        return (STATE_NAMES[st], self.rem.cost, self.rem.error, self.rem.gate, tris)
