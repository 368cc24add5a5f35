# cython: language_level=3
"""Greedy edge-collapse driver with Garland-Heckbert quadrics: the collapser's state and
one edge collapse, checked.

The loop (``EdgeCollapser.run_c``) reads as the pipeline of the papers:

    pop the cheapest edge -> re-plan it (cost, placement, which end goes) -> check the
    link condition -> check the moved faces (normal flip, quality) -> collapse -> add the
    quadrics -> re-cost the edges around the kept vertex.

Everything is allocated in ``__init__``; ``run_c`` runs without the GIL and never allocates.
A candidate that fails a check leaves the heap; it comes back when one of its ends is touched
again, and, when the heap runs dry, a full rescan gives every live edge another chance -- so
"no valid collapse left" is only reported after a rescan that found none.

The other edge-collapse drivers subclass it: triangle collapse (``triangle.pyx``: the
candidates are faces) and the pass driver of batch metrics (``passes.pyx``).
``lodkit._core.decimate.EdgeCollapser`` picks the class from ``operator`` and ``use_heap``.
Quadric maths: quadric.pxd; the checks' expressions: checks.pxd; fields: fields.pxd.
"""
import numpy as np
cimport numpy as cnp
from cython.parallel cimport prange
from libc.math cimport sqrt, INFINITY

from .halfedge cimport HalfEdgeMesh, he_next, he_prev, he_dest, he_ring_next, he_is_boundary
from .heap cimport IndexedHeap
from .vec3 cimport cross3, dot3, same_point
from lodkit.kernel cimport (Kernel, Candidate, fill_candidate, KERNEL_OK, KERNEL_VETO, KERNEL_ERROR,
                            VERTEX_FIXED, VERTEX_BOUNDARY)
from .chain cimport chain_place, chain_commit, chain_cost_range, chain_failed
from .chain import make_chain
from .common cimport (QSIZE, VSTRIDE, RUN_TARGET, RUN_CHUNK, RUN_EXHAUSTED, RUN_ERROR, BOUNDARY_LOCK,
                      BOUNDARY_PRESERVE, BOUNDARY_FREE, PLACE_OPTIMAL, PLACE_ENDPOINT)
from .quadric cimport (AttributeQuadrics, sq, collapse_error, quadric_eval, quadric_sum, take_if_lower, quadric_solve,
                       quadric_solve_truncated, within_reach, Rows, face_normal16)
from .checks cimport (CheckLimits, check_limits, angle_exceeds, turned_from_input, new_fold, folds, tri_quality,
                      face_volume, turns_inside_out, sides_of_a_sheet, flat_sides)
from .fields cimport FieldSet, STEP_VFIELD, STEP_EFIELD

cdef enum:
    FALLBACK_FRACTION = 2  # greedy: a fallback out of order costs no more than the median candidate (run_c)
    KNIFE_FAN = 64      # faces of a fan the knife test reads (more: the rest is not looked at)
    KNIFE_SIGN_SLACK = 512  # int16 units (1/64): exactly opposite normals' components sum to within 574
    MAX_PLACES = 8      # place_ok's other placements under an error bound (end_points; 3 without)

from .common cimport RUN_INTERRUPTED, PARALLEL_MIN_VERTICES
from .interrupt cimport signal_pending, raise_pending, INTERRUPT_EVERY

cnp.import_array()

cdef class Records:
    """The collapse sequence: ``n`` rows (``on``) or one unused row."""

    def __init__(self, int n, int n_attr, bint on):
        cdef int nrec = n if on else 1
        self.on = on
        self.removed = np.empty(nrec, dtype=np.intc)
        self.kept = np.empty(nrec, dtype=np.intc)
        self.pos = np.empty((nrec, 3), dtype=np.float64)
        self.cost = np.empty(nrec, dtype=np.float64)
        self.error = np.empty(nrec, dtype=np.float64)
        self.bound = np.zeros(nrec, dtype=np.float64)
        self.moved = np.empty(nrec, dtype=np.uint8)
        self.faces = np.empty((nrec, 2), dtype=np.intc)
        self.pair_open = np.zeros(nrec, dtype=np.uint8)
        self.attr = np.empty((nrec, n_attr), dtype=np.float64)

    def rows(self, int n):
        """The first ``n`` records as a dict of arrays (copies)."""
        return {
            "removed": np.asarray(self.removed)[:n].copy(),
            "kept": np.asarray(self.kept)[:n].copy(),
            "position": np.asarray(self.pos)[:n].copy(),
            "cost": np.asarray(self.cost)[:n].copy(),
            "error": np.asarray(self.error)[:n].copy(),
            "bound": np.asarray(self.bound)[:n].copy(),
            "moved": np.asarray(self.moved)[:n].astype(bool),
            # for progressive meshes (lodkit.progressive): the vertex slots, the faces each
            # collapse removed, pairs' first halves and the kept vertex's attributes
            "removed_slot": np.asarray(self.removed)[:n].copy(),
            "kept_slot": np.asarray(self.kept)[:n].copy(),
            "faces": np.asarray(self.faces)[:n].copy(),
            "pair_open": np.asarray(self.pair_open)[:n].astype(bool),
            "attributes": np.asarray(self.attr)[:n].copy(),
        }


cdef enum:
    VOLUME_RUN = 65536      # faces whose volumes _input_faces holds at a time


cdef class EdgeCollapser:
    """Greedy QEM edge collapse over a :class:`HalfEdgeMesh` (modified in place).

    positions : (n, 3) float64, preferably normalised (centred, unit bbox diagonal)
    quadrics  : (n, 11) float64 from :func:`vertex_quadrics`
    attributes: (n, k) float64 or None, interpolated along the edge at each collapse
                (C-contiguous float64 arrays are used in place, not copied)
    fixed     : (n,) uint8, 1 = the vertex may not move nor be removed
    placement : 0 optimal, 1 endpoint (half-edge collapse)
    boundary  : 0 lock (boundary vertices are fixed), 1 preserve, 2 free
    closed_connected : the surface is closed and connected: refuse collapses that would
                turn it inside out (its signed volume is tracked)
    seam_partners : (n,) int or None: attribute seams.  For a vertex slot on a seam (a
                coincident copy on the other side of a pair of boundary chains) its
                partner slot; -1 off the seams; -2 for a seam copy that must stay where
                and as it is (it is made fixed).  A seam vertex never moves, and keeps its
                attributes; a seam edge collapses only together with its partner edge,
                keeping the same end on both sides (``perform_pair``); any other collapse
                keeps a seam vertex in place.
    threads   : OpenMP threads of the set-up's loops over faces and vertices (from
                PARALLEL_MIN_VERTICES vertex slots); the state is the same for any number
    """

    def __init__(self, HalfEdgeMesh hm, positions, quadrics, attributes, fixed,
                 int placement=PLACE_OPTIMAL, int boundary=BOUNDARY_PRESERVE,
                 double max_normal_angle=90.0, double min_quality=0.0,
                 double max_error=INFINITY, bint record=False, bint closed_connected=False,
                 double quadric_weight=1.0, double error_scale=1.0,
                 vertex_fields=None, vertex_rules=None, edge_fields=None, edge_rules=None,
                 kernels=(), bint use_heap=True, attribute_quadrics=None, attribute_columns=None,
                 steps=None, seam_partners=None, error_bound=None, int threads=1, input_normals=None):
        cdef int n = hm.n_vertices
        self.hm = hm
        # One row per vertex: the quadric (11 doubles) then the position (3), so that a
        # plan touches two cache-line pairs, not four scattered lines.  A (n, 14) array is
        # used in place (no copy); an (n, 11) one is joined with ``positions``.
        q_arr = np.asarray(quadrics)
        if q_arr.ndim == 2 and q_arr.shape[1] == VSTRIDE and q_arr.dtype == np.float64 and q_arr.flags.c_contiguous:
            self.vdata = q_arr
        else:
            if q_arr.ndim != 2 or q_arr.shape[1] != QSIZE:
                raise ValueError(f"quadrics must have shape ({n}, {QSIZE}) or ({n}, {VSTRIDE})")
            pos_arr = np.asarray(positions, dtype=np.float64)
            if pos_arr.shape != (n, 3):
                raise ValueError(f"positions must have shape ({n}, 3)")
            joined = np.empty((q_arr.shape[0], VSTRIDE), dtype=np.float64)
            joined[:, :QSIZE] = q_arr
            joined[:, QSIZE:] = pos_arr
            self.vdata = joined
        if self.vdata.shape[0] != n:
            raise ValueError(f"quadrics must have {n} rows")
        if attributes is None:
            attributes = np.zeros((n, 0))
        self.attr = np.ascontiguousarray(attributes, dtype=np.float64)
        if self.attr.shape[0] != n:
            raise ValueError(f"attributes must have {n} rows")
        self.n_attr = self.attr.shape[1]
        fixed_arr = np.asarray(fixed).reshape(-1)
        if fixed_arr.shape[0] != n:
            raise ValueError(f"fixed must have {n} entries")
        # VERTEX_FIXED: may not move nor go; VERTEX_BOUNDARY: on the boundary (kept up to
        # date: after a collapse the kept vertex is on the boundary iff either end was);
        # both written in one loop below (numpy's product took an int64 temporary a slot)
        fixed_u8 = np.ascontiguousarray(fixed_arr if fixed_arr.dtype == np.bool_ else fixed_arr != 0).view(np.uint8)
        self.vflags = np.empty(n, dtype=np.uint8)
        self.moved = np.zeros(n, dtype=np.uint8)
        self.refused = np.zeros(n, dtype=np.uint8)
        self.released = False
        if placement not in (PLACE_OPTIMAL, PLACE_ENDPOINT):
            raise ValueError(f"unknown placement {placement}")
        if boundary not in (BOUNDARY_LOCK, BOUNDARY_PRESERVE, BOUNDARY_FREE):
            raise ValueError(f"unknown boundary policy {boundary}")
        if not (0.0 < max_normal_angle <= 180.0):
            raise ValueError("max_normal_angle must be in (0, 180] degrees")
        self.opt.placement = placement
        self.opt.boundary = boundary
        self.lim = check_limits(max_normal_angle, min_quality)
        self.end_fallback = False
        self.opt.max_error = max_error
        # the collapse sequence (a progressive mesh) is only kept on request: 48 bytes/vertex
        self.rec = Records(n, self.n_attr, record)
        self.n_collapses = 0
        self.max_error_done = 0.0
        if threads < 1 or n < PARALLEL_MIN_VERTICES:
            threads = 1
        # the pass driver needs none; triangle collapse ranks faces
        self.heap = IndexedHeap(self.n_candidates() if use_heap else 0)
        self.m = &hm.c
        # The volume guard is on for a closed, connected surface (the common case): six
        # times its signed volume, kept up to date collapse by collapse.
        self.closed_volume = 0.0
        self.Q = &self.vdata[0, 0] if n else NULL
        self.P = &self.vdata[0, QSIZE] if n else NULL
        self._input_faces(threads, closed_connected and n and hm.n_faces, input_normals)
        self.normal_signs()
        cdef int v
        cdef const unsigned char* fx = <const unsigned char*>cnp.PyArray_DATA(fixed_u8)
        cdef unsigned char* vf = &self.vflags[0] if n else NULL
        cdef const HEArrays* he = self.m
        with nogil:
            for v in prange(n, num_threads=threads, schedule="static"):
                vf[v] = (VERTEX_FIXED if fx[v] else 0) | (
                    VERTEX_BOUNDARY if he.v_he[v] >= 0 and he_is_boundary(he, v) else 0)
        self.A = &self.attr[0, 0] if n and self.n_attr else NULL
        self._setup_seams(seam_partners)
        if boundary == BOUNDARY_LOCK:
            # under the 'lock' policy a vertex of the true border is also fixed; a seam is
            # no border: its vertices pair up as under the other policies
            for v in range(n):
                if (self.vflags[v] & VERTEX_BOUNDARY) and (self.SP == NULL or self.SP[v] == SEAM_NONE):
                    self.vflags[v] |= VERTEX_FIXED
        self._setup_metric(quadric_weight, error_scale, vertex_fields, vertex_rules,
                           edge_fields, edge_rules, kernels, use_heap, steps)
        self.aq = AttributeQuadrics(hm, self.attr, attribute_quadrics, attribute_columns)
        # error_bound=(eps, spacing): the two-sided bound (bound.pyx); built on the input as
        # it is now, before any collapse
        self.bound = None
        if error_bound is not None:
            self.bound = Bound(hm, self.vdata, QSIZE, float(error_bound[0]), float(error_bound[1]))
        if self.opt.use_heap:
            with nogil:
                self.rescan()

    def _input_faces(self, int threads, bint closed, normals=None):
        """``face_n0``, the unit normals of the input faces (the checks measure turns from
        them; ``normals``: the (3 m,) int16 array ``vertex_quadrics(normals=)`` filled from
        the positions as they are, taken as it is) and, when ``closed``, ``closed_volume``:
        one pass over the faces on
        ``threads`` (each face loads its corners once for both), the volumes then summed in
        face order (one sum: the same bits for any number of threads).  The faces go in
        runs of VOLUME_RUN, so that the volumes need a small buffer, not 8 bytes a face
        (the greedy driver's heap is allocated by then: that would be its peak)."""
        cdef int m = self.hm.n_faces
        cdef int f, lo, hi
        cdef Rows rows
        rows.p = self.P
        rows.s = VSTRIDE
        cdef bint given = normals is not None
        if given:
            if not (isinstance(normals, np.ndarray) and normals.dtype == np.int16 and normals.shape == (3 * m,)):
                raise ValueError(f"input_normals must be a ({3 * m},) int16 array")
            self.face_n0 = normals
        else:
            self.face_n0 = np.zeros(3 * m, dtype=np.int16)
        self.N0 = &self.face_n0[0] if m else NULL
        cdef double[::1] vol6 = np.empty(min(m, VOLUME_RUN) if closed else 1, dtype=np.float64)
        # the loops read locals: a store through ``self`` would make the compiler load
        # self.m, self.N0 and self.P again for every face (and face_volume6 is a method call)
        cdef const HEArrays* he = self.m
        cdef short* N0 = self.N0
        cdef const double* P = self.P
        cdef double* V = &vol6[0]
        cdef double total = 0.0
        lo = 0
        if given and not closed:
            return
        with nogil:
            while lo < m:
                hi = min(lo + <int>VOLUME_RUN, m)
                for f in prange(lo, hi, num_threads=threads, schedule="static"):
                    if not given:
                        face_normal16(he, rows, f, &N0[3 * f])
                    if closed:
                        V[f - lo] = face_volume(&P[VSTRIDE * he.corner[3 * f]], &P[VSTRIDE * he.corner[3 * f + 1]],
                                                &P[VSTRIDE * he.corner[3 * f + 2]])
                if closed:
                    for f in range(lo, hi):
                        if he.face_alive[f]:
                            total += V[f - lo]
                lo = hi
        self.closed_volume += total

    cdef void normal_signs(self):
        """``normal_sign``: for each vertex, which signs the input normals of its faces take
        along each axis, a bit each -- bit i: some face's component i is at least -SLACK,
        bit 3 + i: at most +SLACK (KNIFE_SIGN_SLACK, 1/64 of a unit normal: a component
        near 0 sets both); a collapse's kept vertex takes the union of both ends' bits
        (``merge_signs``), so that a vertex's bits hold the normals of every face around
        it, then and later.  The knife test's pre-filter (``opposite_signs``).  One pass
        over the faces, each OR-ed into its corners' bytes (no branch; a walk around each
        vertex would miss the second fan of a vertex where two fans meet, and the output
        would change: boot)."""
        cdef int n = self.hm.n_vertices
        cdef int nf = self.hm.n_faces
        cdef int f
        cdef unsigned char s
        self.normal_sign = np.zeros(n if n else 1, dtype=np.uint8)
        self.NS = &self.normal_sign[0]
        # locals: a store through an unsigned char* may alias anything, so values read
        # through ``self`` would be loaded again after every store
        cdef unsigned char* S = self.NS
        cdef const short* N = self.N0
        cdef const int* corner = self.m.corner
        cdef const unsigned char* alive = self.m.face_alive
        cdef int x, y, z, a, b, c
        with nogil:
            for f in range(nf):
                if not alive[f]:
                    continue
                x = N[3 * f]
                y = N[3 * f + 1]
                z = N[3 * f + 2]
                s = <unsigned char>((x >= -KNIFE_SIGN_SLACK) | ((y >= -KNIFE_SIGN_SLACK) << 1)
                                    | ((z >= -KNIFE_SIGN_SLACK) << 2) | ((x <= KNIFE_SIGN_SLACK) << 3)
                                    | ((y <= KNIFE_SIGN_SLACK) << 4) | ((z <= KNIFE_SIGN_SLACK) << 5))
                a = corner[3 * f]
                b = corner[3 * f + 1]
                c = corner[3 * f + 2]
                S[a] |= s
                S[b] |= s
                S[c] |= s

    cdef void merge_signs(self, int r, int k) noexcept nogil:
        """After a collapse of ``r`` into ``k``: k's sign bits take in r's."""
        self.NS[k] |= self.NS[r]

    cdef bint opposite_signs(self, int r, int k) noexcept nogil:
        """Could a face around ``r`` and one around ``k`` stand for input faces facing
        exactly opposite ways (``flat_sides``)?  Their normals' components sum to within
        0.0175 (574 int16 units; 2 x KNIFE_SIGN_SLACK is more), so along every axis one
        side has a sign bit that the other has the opposite of: r's + and k's -, or r's -
        and k's +.  False: the knife test has nothing to find (on a smooth surface nearly
        always: a fan's normals lie in a narrow cone, and no cone is near 0 along all
        three axes)."""
        cdef unsigned int u = self.NS[r]
        cdef unsigned int v = self.NS[k]
        return (((u & (v >> 3)) | ((u >> 3) & v)) & 7) == 7

    cdef int n_candidates(self):
        """The heap's capacity: one candidate per edge."""
        return self.hm.n_edges

    def _setup_seams(self, partners):
        cdef int n = self.hm.n_vertices
        self.n_seam_pairs = 0
        self.seam = np.full(1, SEAM_NONE, dtype=np.intc)
        self.SP = NULL
        if partners is None:
            return
        arr = np.array(partners, dtype=np.intc).reshape(-1)
        if arr.shape[0] != n:
            raise ValueError(f"seam_partners must have {n} entries")
        if n == 0 or (arr == SEAM_NONE).all():
            return
        if arr.min() < SEAM_STAYS or arr.max() >= n:
            raise ValueError(f"seam_partners must hold vertex slots 0..{n - 1}, -1 or -2")
        paired = np.flatnonzero(arr >= 0)
        if (arr[arr[paired]] != paired).any() or (arr[paired] == paired).any():
            raise ValueError("seam_partners must pair distinct vertex slots both ways")
        flags = np.asarray(self.vflags)
        # a seam vertex off the boundary is no seam (nothing to keep apart)
        stays = (arr == SEAM_STAYS)
        stays[paired] |= ((flags[paired] & VERTEX_BOUNDARY) == 0) | ((flags[arr[paired]] & VERTEX_BOUNDARY) == 0)
        arr[stays] = SEAM_STAYS
        flags[stays] |= VERTEX_FIXED
        # a pair stays where it is (both copies fixed, so that both sides agree) when one
        # copy is fixed, or at the end of a seam: where a copy's boundary chain leaves the
        # seam on either side.  It stays paired: a seam pair next to it collapses into it
        self.seam = arr
        self.SP = &self.seam[0]
        cdef int v, w, h
        fix = np.zeros(n, dtype=bool)
        for v in np.flatnonzero(arr >= 0):
            w = self.SP[v]
            h = self.m.v_he[v]                    # v's outgoing boundary half-edge
            if (flags[v] & VERTEX_FIXED) or (flags[w] & VERTEX_FIXED):
                fix[v] = True
            elif self.m.twin[h] >= 0 or self.SP[he_dest(self.m, h)] == SEAM_NONE:
                fix[v] = True                     # the chain leaves the seam here
            elif self.seam_mate(h, v, he_dest(self.m, h)) < 0:
                fix[v] = True
        fix[arr[fix]] = True
        flags[fix] |= VERTEX_FIXED

    def _setup_metric(self, double quadric_weight, double error_scale, vertex_fields, vertex_rules,
                      edge_fields, edge_rules, kernels, bint use_heap, steps=None):
        cdef int n = self.hm.n_vertices
        if not (quadric_weight >= 0.0) or not (error_scale > 0.0):
            raise ValueError("quadric_weight must be >= 0 and error_scale > 0")
        self.opt.quadric_weight = quadric_weight
        self.opt.error_scale = error_scale
        cdef Kernel k
        kernels = list(kernels)
        self.fields = FieldSet(n, self.hm.n_edges, vertex_fields, vertex_rules, edge_fields, edge_rules,
                               steps, len(kernels))
        for k in kernels:            # type-checks each one
            if k is None:
                raise TypeError("kernels must be lodkit.kernel.Kernel instances")
        self.chain = make_chain(kernels)
        self.kernel = kernels[0] if kernels else None
        self.opt.kernel_places = False
        self.opt.wide_recost = False
        self.wide_kernel = None
        if self.kernel is not None:
            for k in kernels:
                self.opt.kernel_places |= k.places
                self.opt.wide_recost |= k.wide
            wide = [k for k in kernels if k.wide]
            if len(wide) == 1:
                self.wide_kernel = wide[0]
        # one byte a vertex, for the heap driver's wide re-rank only (the pass driver re-ranks
        # in its own way)
        self.walked = np.zeros(n if self.opt.wide_recost and use_heap else 1, dtype=np.uint8)
        self.kmesh.he = self.m
        self.kmesh.positions = self.P
        self.kmesh.stride = VSTRIDE
        self.kmesh.flags = &self.vflags[0] if n else NULL
        self.kmesh.n_vertices = n
        self.kmesh.n_faces = self.hm.n_faces
        self.opt.has_extras = self.fields.n_vfields > 0 or self.fields.n_efields > 0 or self.kernel is not None
        self.opt.use_heap = use_heap
        self.n_vetoed = 0
        self.failed = False

    # ------------------------------------------------------------- planning
    cdef int plan(self, int e, int* h_out, int* r_out, int* hs_out, double* p, double* cost,
                  double* err) noexcept nogil:
        """Cost and placement of collapsing edge ``e``; -1 if it may not collapse at all.
        ``h_out``: the half-edge to collapse, ``r_out``: the vertex that goes, ``hs_out``:
        for a seam edge the partner side's half-edge (the pair collapses together), else -1;
        ``err`` (or NULL): the geometric error."""
        cdef int h = self.m.edge_he[e]
        return self.plan_he(h, self.m.corner[h], he_dest(self.m, h), h_out, r_out, hs_out, p, cost, err)

    cdef int plan_he(self, int h, int u, int v, int* h_out, int* r_out, int* hs_out, double* p,
                     double* cost, double* err) noexcept nogil:
        """``plan`` for the edge of half-edge ``h`` running u -> v, when the caller already
        holds them (a ring walk): saves the edge -> half-edge -> vertex chain of loads."""
        cdef unsigned char gu = self.vflags[u]
        cdef unsigned char gv = self.vflags[v]
        cdef bint bu = (gu & VERTEX_BOUNDARY) != 0
        cdef bint bv = (gv & VERTEX_BOUNDARY) != 0
        cdef bint fu = (gu & VERTEX_FIXED) != 0
        cdef bint fv = (gv & VERTEX_FIXED) != 0
        cdef double q[QSIZE]
        cdef double qg[QSIZE]
        cdef double cand[3]
        cdef double best, c, t, denom, d0, d1
        cdef double du[3]
        cdef int i, keep, hs, k
        hs_out[0] = -1
        if self.SP != NULL:
            if self.SP[u] != SEAM_NONE or self.SP[v] != SEAM_NONE:
                if (self.SP[u] != SEAM_NONE and self.SP[v] != SEAM_NONE and (self.SP[u] >= 0 or self.SP[v] >= 0)
                        and self.m.twin[h] < 0):
                    hs = self.seam_mate(h, u, v)
                    if hs >= 0:
                        return self.plan_seam(h, hs, h_out, r_out, hs_out, p, cost, err)
                # any other collapse keeps a seam vertex where it is (its partner could
                # not follow); a seam vertex that stays is fixed already
                if self.SP[u] != SEAM_NONE:
                    fu = True
                if self.SP[v] != SEAM_NONE:
                    fv = True
        if bu and bv and self.m.twin[h] >= 0:
            return -1                     # would pinch the surface (link condition)
        if self.opt.boundary == BOUNDARY_PRESERVE:
            # Li et al.: a boundary vertex never moves into the interior
            if bu and not bv:
                fu = True
            elif bv and not bu:
                fv = True
        if fu and fv:
            return -1
        quadric_sum(&self.Q[VSTRIDE * u], &self.Q[VSTRIDE * v], q)
        if self.aq.dim > 0:
            # quadrics over attributes: place by the marginal quadric in x (the attributes
            # minimised out), keep the plain one (qg) to measure the geometric error
            for i in range(QSIZE):
                qg[i] = q[i]
            self.aq.marginal(u, v, q)
        h_out[0] = h
        if fu or fv:
            keep = u if fu else v
            for i in range(3):
                p[i] = self.P[VSTRIDE * keep + i]
            r_out[0] = v if fu else u
            c = quadric_eval(q, p)
        elif self.opt.placement == PLACE_ENDPOINT:
            d0 = quadric_eval(q, &self.P[VSTRIDE * u])
            d1 = quadric_eval(q, &self.P[VSTRIDE * v])
            keep = u if (d0 < d1 or (d0 == d1 and u < v)) else v
            for i in range(3):
                p[i] = self.P[VSTRIDE * keep + i]
            r_out[0] = v if keep == u else u
            c = d0 if keep == u else d1
        else:
            if quadric_solve(q, p) and within_reach(p, &self.P[VSTRIDE * u], &self.P[VSTRIDE * v]):
                c = quadric_eval(q, p)
            else:
                # fallback: the best of the truncated solve about the midpoint (if within
                # reach; else the midpoint), both ends and the minimum along the edge.  The
                # truncated point is the lowest of the line or plane through the midpoint it
                # was solved in (so never above the midpoint); with all three directions
                # (k == 3: an optimal solve flung out of reach, or a determinant just under
                # DET_EPS) it is the quadric's minimum, and no point of the edge is lower.
                for i in range(3):
                    cand[i] = self.P[VSTRIDE * u + i] + 0.5 * (self.P[VSTRIDE * v + i] - self.P[VSTRIDE * u + i])
                k = quadric_solve_truncated(q, cand, p)
                if within_reach(p, &self.P[VSTRIDE * u], &self.P[VSTRIDE * v]):
                    best = quadric_eval(q, p)
                else:
                    k = 0
                    for i in range(3):
                        p[i] = cand[i]
                    best = quadric_eval(q, p)
                if k < 3:
                    take_if_lower(q, &self.P[VSTRIDE * u], p, &best)
                    take_if_lower(q, &self.P[VSTRIDE * v], p, &best)
                    # Q(u + t du) = alpha t^2 + 2 beta t + const  ->  t* = -beta / alpha
                    for i in range(3):
                        du[i] = self.P[VSTRIDE * v + i] - self.P[VSTRIDE * u + i]
                    denom = (q[0] * du[0] * du[0] + 2 * q[1] * du[0] * du[1] + 2 * q[2] * du[0] * du[2]
                             + q[3] * du[1] * du[1] + 2 * q[4] * du[1] * du[2] + q[5] * du[2] * du[2])
                    if denom > 0.0:
                        t = -((q[0] * self.P[VSTRIDE * u + 0] + q[1] * self.P[VSTRIDE * u + 1]
                               + q[2] * self.P[VSTRIDE * u + 2] + q[6]) * du[0]
                              + (q[1] * self.P[VSTRIDE * u + 0] + q[3] * self.P[VSTRIDE * u + 1]
                                 + q[4] * self.P[VSTRIDE * u + 2] + q[7]) * du[1]
                              + (q[2] * self.P[VSTRIDE * u + 0] + q[4] * self.P[VSTRIDE * u + 1]
                                 + q[5] * self.P[VSTRIDE * u + 2] + q[8]) * du[2]) / denom
                        if 0.0 < t < 1.0:
                            for i in range(3):
                                cand[i] = self.P[VSTRIDE * u + i] + t * du[i]
                            take_if_lower(q, cand, p, &best)
                c = best
            # the kept slot is the end nearer to the new position (provenance); only the
            # collapse itself and the metric's fields / kernels need it, not QEM's ranking
            if err != NULL or self.opt.has_extras:
                d0 = 0.0
                d1 = 0.0
                for i in range(3):
                    d0 += (p[i] - self.P[VSTRIDE * u + i]) * (p[i] - self.P[VSTRIDE * u + i])
                    d1 += (p[i] - self.P[VSTRIDE * v + i]) * (p[i] - self.P[VSTRIDE * v + i])
                r_out[0] = v if (d0 < d1 or (d0 == d1 and u < v)) else u
        if c < 0.0:
            c = 0.0
        if self.opt.has_extras:
            keep = self.metric_cost(h, u, v, fu, fv, q, &qg[0] if self.aq.dim > 0 else &q[0], r_out, p, &c, err)
            cost[0] = c
            return keep
        if err != NULL:
            err[0] = collapse_error(quadric_eval(qg, p) if self.aq.dim > 0 else c, q[10], self.opt.error_scale)
        cost[0] = self.opt.quadric_weight * c
        return 0

    cdef int seam_mate(self, int h, int u, int v) noexcept nogil:
        """The partner of seam edge ``h`` (u -> v, a boundary half-edge between two seam
        vertices, at least one of them paired): the boundary half-edge mate(v) -> mate(u)
        on the other side of the seam, or -1 if there is none (the seam chains part
        there).  The mate of a paired vertex is its partner; that of a seam copy that
        stays (SEAM_STAYS: a seam end with more than two copies, a cube's corner) is the
        copy at its position at the other end of the partner side's boundary edge."""
        cdef int hs, y, ny, w
        if self.SP[v] >= 0:
            hs = self.m.v_he[self.SP[v]]          # a boundary vertex's fan starts at its border
            if self.m.twin[hs] >= 0:
                return -1
            w = he_dest(self.m, hs)
            if self.SP[u] >= 0:
                return hs if w == self.SP[u] else -1
            if w != u and self.SP[w] == SEAM_STAYS and same_point(&self.P[VSTRIDE * w], &self.P[VSTRIDE * u]):
                return hs
            return -1
        # v stays, u is paired: the boundary half-edge into partner(u), from a copy of v
        y = self.m.v_he[self.SP[u]]
        while True:
            ny = he_ring_next(self.m, y)
            if ny < 0:
                break
            if ny == self.m.v_he[self.SP[u]]:
                return -1                         # not on the boundary
            y = ny
        hs = he_prev(y)
        if self.m.twin[hs] >= 0:
            return -1
        w = self.m.corner[hs]
        if w != v and self.SP[w] == SEAM_STAYS and same_point(&self.P[VSTRIDE * w], &self.P[VSTRIDE * v]):
            return hs
        return -1

    cdef int seam_kept(self, int hs, int rs) noexcept nogil:
        """The end of seam half-edge ``hs`` that is not ``rs``: the partner side's kept vertex."""
        return he_dest(self.m, hs) if self.m.corner[hs] == rs else self.m.corner[hs]

    cdef int plan_seam(self, int h, int hs, int* h_out, int* r_out, int* hs_out, double* p,
                       double* cost, double* err) noexcept nogil:
        """Plan seam edge ``h`` together with its partner ``hs`` on the other side: one
        collapse on each side, removing the same position and keeping the other, which
        stays where it is (endpoint placement: the seam stays a sub-polyline of the
        input's, and the two sides cannot part).  The cost is that of both collapses: the
        summed quadrics of both sides (attribute quadrics: the sum of each side's marginal,
        as each side keeps its own attributes).  The plan is the same from either edge
        (the side of the smaller edge id is side a), and ``hs_out`` gets side b's
        half-edge.  Returns 0, or -1 / -2 as ``plan_he``."""
        cdef int ha = h, hb = hs
        if self.m.edge[hs] < self.m.edge[h]:
            ha = hs
            hb = h
        hs_out[0] = hb
        h_out[0] = ha
        cdef int ua = self.m.corner[ha], va = he_dest(self.m, ha)
        cdef int ub = self.m.corner[hb], vb = he_dest(self.m, hb)     # partner(va), partner(ua)
        # seam vertices whose partner is fixed are fixed themselves (SEAM_STAYS), so both
        # sides agree on what may go
        cdef bint fu = (self.vflags[ua] & VERTEX_FIXED) != 0
        cdef bint fv = (self.vflags[va] & VERTEX_FIXED) != 0
        cdef double q[QSIZE]
        cdef double qg[QSIZE]
        cdef double qb[QSIZE]
        cdef double c, d0, d1
        cdef int i, keep, rc
        if fu and fv:
            return -1
        for i in range(QSIZE):
            q[i] = ((self.Q[VSTRIDE * ua + i] + self.Q[VSTRIDE * va + i])
                    + (self.Q[VSTRIDE * ub + i] + self.Q[VSTRIDE * vb + i]))
        if self.aq.dim > 0:
            for i in range(QSIZE):
                qg[i] = q[i]
            self.aq.marginal(ua, va, q)
            self.aq.marginal(ub, vb, qb)
            for i in range(10):
                q[i] += qb[i]
        if fu:
            keep = ua
        elif fv:
            keep = va
        else:
            d0 = quadric_eval(q, &self.P[VSTRIDE * ua])
            d1 = quadric_eval(q, &self.P[VSTRIDE * va])
            keep = ua if (d0 < d1 or (d0 == d1 and ua < va)) else va
        for i in range(3):
            p[i] = self.P[VSTRIDE * keep + i]
        r_out[0] = va if keep == ua else ua
        c = quadric_eval(q, p)
        if c < 0.0:
            c = 0.0
        if self.opt.has_extras:
            # fields and kernels see side a's collapse; a kernel may swap the ends but not
            # move the kept one (the seam would part)
            rc = self.metric_cost(ha, ua, va, fu, fv, q, &qg[0] if self.aq.dim > 0 else &q[0], r_out, p, &c, err)
            if rc != 0:
                return rc
            keep = va if r_out[0] == ua else ua
            if not same_point(p, &self.P[VSTRIDE * keep]):
                self.n_vetoed += 1
                return -1
            cost[0] = c
            return 0
        if err != NULL:
            err[0] = collapse_error(quadric_eval(qg, p) if self.aq.dim > 0 else c, q[10], self.opt.error_scale)
        cost[0] = self.opt.quadric_weight * c
        return 0

    cdef int metric_cost(self, int h, int u, int v, int fu, int fv, const double* q, const double* qg,
                         int* r_out, double* p, double* c, double* err) noexcept nogil:
        """The rest of the metric after the quadric: a kernel may re-place, then the
        quadric cost (times its weight), the fields in order, the kernels in order.
        ``c`` holds the quadric value at ``p`` on entry, the total cost on return.
        Returns 0, -1 (a kernel vetoed) or -2 (a kernel failed: ``self.failed``)."""
        cdef Candidate cand
        cdef double cq = c[0]
        cdef double total, e_err
        cdef int* step
        cdef int i, j, rc, e = self.m.edge[h]
        cdef int kept = v if r_out[0] == u else u
        if self.kernel is not None:
            fill_candidate(&cand, &self.kmesh, e, h, u, v, r_out[0], kept, p, 0.0, 0.0)
            if self.opt.kernel_places:
                rc = chain_place(self.chain, &cand)
                if rc != KERNEL_OK:
                    return self.kernel_refused(rc)
                if not ((cand.removed == u and cand.kept == v) or (cand.removed == v and cand.kept == u)):
                    self.kernel.fail(b"place() set removed/kept to vertices that are not the edge's ends")
                    self.failed = True
                    return -2
                # the fixed rules bind a kernel too: a fixed end stays, where it is
                if (fu and cand.removed == u) or (fv and cand.removed == v):
                    self.n_vetoed += 1
                    return -1
                if (fu or fv) and not same_point(cand.p, &self.P[VSTRIDE * cand.kept]):
                    self.n_vetoed += 1
                    return -1
                r_out[0] = cand.removed
                kept = cand.kept
                if not same_point(cand.p, p):
                    if within_reach(cand.p, &self.P[VSTRIDE * u], &self.P[VSTRIDE * v]):
                        p[0] = cand.p[0]
                        p[1] = cand.p[1]
                        p[2] = cand.p[2]
                        cq = quadric_eval(q, p)
                        if cq < 0.0:
                            cq = 0.0
                    else:
                        # flung off the edge: the core's placement stands (quadric.pxd within_reach)
                        cand.p[0] = p[0]
                        cand.p[1] = p[1]
                        cand.p[2] = p[2]
        e_err = collapse_error(quadric_eval(qg, p) if qg != q else cq, q[10], self.opt.error_scale)
        if err != NULL:
            err[0] = e_err
        total = self.opt.quadric_weight * cq
        # fields and kernels in the order the metrics were listed (steps: kind, first, end)
        for i in range(self.fields.n_steps):
            step = &self.fields.steps[i, 0]
            if step[0] == STEP_VFIELD:
                for j in range(step[1], step[2]):
                    total = self.fields.vertex_cost(total, j, kept, v if kept == u else u)
            elif step[0] == STEP_EFIELD:
                for j in range(step[1], step[2]):
                    total = self.fields.edge_cost(total, j, e)
            else:
                # removed / kept / p in cand are current: set above, or by place() and copied out
                cand.cost = total
                cand.error = e_err
                if step[1] == 0 and self.chain.next is None:
                    rc = self.kernel.cost(&cand)
                else:
                    rc = chain_cost_range(self.chain, &cand, step[1], step[2] - step[1])
                if rc != KERNEL_OK:
                    return self.kernel_refused(rc)
                total = cand.cost
        if total != total:
            total = INFINITY          # a NaN cost ranks last rather than breaking the heap order
        c[0] = total
        return 0

    cdef int kernel_refused(self, int rc) noexcept nogil:
        if rc == KERNEL_VETO:
            self.n_vetoed += 1
            return -1
        self.failed = True            # KERNEL_ERROR, or anything else a kernel should not return
        if not chain_failed(self.chain):
            self.kernel.fail(b"a kernel returned an unknown status (not KERNEL_OK, KERNEL_VETO nor KERNEL_ERROR)")
        return -2

    # ------------------------------------------------------------- checks
    cdef bint fan_ok(self, int center, int fa, int fb, int skip_c, int skip_d, const double* p,
                     double* dvol, double* min_q) noexcept nogil:
        """Do the faces around ``center`` (except fa, fb) stay valid when it moves to p?
        Adds to ``dvol`` six times the change of the enclosed volume; lowers ``min_q`` to
        the lowest quality of a moved face (with a quality limit).  Faces ``skip_c`` /
        ``skip_d`` (-1: none; a triangle collapse's first step) count for the volume only.
        (The arrays and limits are read into locals, and the sums kept in locals until the
        end: a store through a double pointer would otherwise make the compiler load them
        again after each one.)"""
        cdef const double* P = self.P
        cdef const int* corner = self.m.corner
        cdef const int* twin = self.m.twin
        cdef const short* N0 = self.N0
        cdef const double* C0 = &P[VSTRIDE * center]
        cdef const double* B
        cdef const double* C
        cdef const double* X
        cdef bint vol = self.closed_volume != 0.0
        cdef bint orig = self.lim.check_orig
        cdef bint fold = self.lim.check_fold
        cdef double cos_max = self.lim.cos_max_angle
        cdef double cos_orig = self.lim.cos_orig_angle
        cdef double qlim = self.lim.min_quality
        cdef double dv = dvol[0]
        cdef double mq = min_q[0]
        cdef int start = self.m.v_he[center]
        cdef int y = start
        cdef int f, i, t, g, pv, prev_f = -1
        cdef double dp[3]
        cdef double e1[3]
        cdef double e2[3]
        cdef double n0[3]
        cdef double n1[3]
        cdef double bc[3]
        cdef double ng[3]
        cdef double prev_n1[3]
        cdef double l0, l1, l2, len0, len1, q1, lg, prev_ok
        cdef double prev_len1 = 0.0
        for i in range(3):
            dp[i] = p[i] - C0[i]
            prev_n1[i] = 0.0
        while True:
            f = y // 3
            pv = he_prev(y)
            if f == fa or f == fb:
                prev_len1 = 0.0
            elif f == skip_c or f == skip_d:
                # a triangle collapse's first step: this face dies in the second one, its
                # passing shape does not matter, its volume change does
                if vol:
                    cross3(&P[VSTRIDE * corner[he_next(y)]], &P[VSTRIDE * corner[pv]], bc)
                    dv += (dp[0] * bc[0] + dp[1] * bc[1] + dp[2] * bc[2])
                prev_len1 = 0.0
            else:
                B = &P[VSTRIDE * corner[he_next(y)]]
                C = &P[VSTRIDE * corner[pv]]
                for i in range(3):
                    e1[i] = B[i] - C0[i]
                    e2[i] = C[i] - C0[i]
                cross3(e1, e2, n0)
                if vol:
                    # change of the cone from the origin over this face: (p - old) . (b x c)
                    cross3(B, C, bc)
                    dv += (dp[0] * bc[0] + dp[1] * bc[1] + dp[2] * bc[2])
                len0 = sqrt(dot3(n0, n0))
                prev_ok = prev_len1
                prev_len1 = 0.0                      # set again below if this face is checked
                if len0 > 0.0:
                    for i in range(3):
                        e1[i] = B[i] - p[i]
                        e2[i] = C[i] - p[i]
                    cross3(e1, e2, n1)
                    len1 = sqrt(dot3(n1, n1))
                    l0 = dot3(e1, e1)
                    l1 = dot3(e2, e2)
                    if len1 <= 1e-12 * (l0 + l1):
                        return False                 # the face would degenerate
                    if angle_exceeds(dot3(n0, n1), cos_max, len0, len1):
                        return False                 # the face would turn too far (or flip)
                    if orig and turned_from_input(
                            n1[0] * N0[3 * f] + n1[1] * N0[3 * f + 1] + n1[2] * N0[3 * f + 2],
                            cos_orig, 32767.0, len1):
                        return False                 # turned away from the input face it stands for
                    if qlim > 0.0:
                        # judged over the whole fan by geometry_ok (relative_quality_ok)
                        l2 = 0.0
                        for i in range(3):
                            l2 += sq(B[i] - C[i])
                        q1 = tri_quality(len1, l0 + l1 + l2)
                        if q1 < mq:
                            mq = q1
                    if fold:
                        # no new fold: the face must not bend back onto the neighbour across
                        # its far edge b-c, nor onto the previous face of the fan
                        t = twin[he_next(y)]
                        if t >= 0:
                            g = t // 3
                            if g != fa and g != fb and g != skip_c and g != skip_d:
                                X = &P[VSTRIDE * corner[he_prev(t)]]
                                for i in range(3):
                                    e1[i] = B[i] - C[i]
                                    e2[i] = X[i] - C[i]
                                cross3(e1, e2, ng)
                                # new_fold wants n1 . ng < FOLD_COS * len1 * lg <= 0 (FOLD_COS < 0):
                                # never so when n1 . ng >= 0 (nor NaN), the common case: no lg needed
                                if dot3(n1, ng) < 0.0:
                                    lg = sqrt(dot3(ng, ng))
                                    if new_fold(n1, len1, n0, len0, ng, lg) and not sides_of_a_sheet(N0, f, g):
                                        return False
                        if (prev_ok > 0.0 and folds(n1, len1, prev_n1, prev_ok)
                                and not sides_of_a_sheet(N0, f, prev_f)):
                            return False
                        for i in range(3):
                            prev_n1[i] = n1[i]
                        prev_len1 = len1
                        prev_f = f
            y = twin[pv]                             # he_ring_next
            if y < 0 or y == start:
                dvol[0] = dv
                min_q[0] = mq
                return True

    cdef bint place_ok(self, int h, int r, int k, double* p, double* cost_err, double limit,
                       double* dvol_out) noexcept nogil:
        """``geometry_ok`` for a planned collapse, with a fallback: when the moved faces fail
        a check at the planned position ``p`` (an optimal placement), the collapse may still
        go with the kept vertex at one of the edge's ends or its midpoint (under an error
        bound also its quarter points and points towards ``p``: end_points) -- the cheapest
        first -- if that passes every check and costs no more than ``limit``, what the driver would take
        next anyway (the greedy driver: the heap's top; the pass driver: the pass's dearest
        candidate; < 0: no fallback).  Under an error bound the cost limit is not applied:
        the bound is what stops a bounded run.  Then ``p`` and ``cost_err`` (cost, error) are
        updated.  Without it, a refusal sends the driver to a costlier collapse elsewhere
        (issue 17: the thin-CAD set stopped above its targets; docs/algorithms.md)."""
        cdef double q[QSIZE]
        cdef double alt[3 * MAX_PLACES]
        cdef double ca[MAX_PLACES]
        cdef int kinds[MAX_PLACES]
        cdef double c, err
        cdef int j, n
        if self.geometry_ok(h, r, k, p, -1, -1, dvol_out):
            return True
        if not self.end_fallback or limit < 0.0:
            return False
        n = self.end_points(r, k, p, alt, ca, q, kinds)
        for j in range(n):
            c = ca[j]
            if self.opt.quadric_weight * c > limit and self.bound is None:
                # (under an error bound the bound, not the quadric cost, is the limit: a
                # bounded run only gets here once no planned collapse stays within it)
                return False
            err = collapse_error(c, q[10], self.opt.error_scale)
            if err > self.opt.max_error:
                return False
            if self.geometry_ok(h, r, k, &alt[3 * j], -1, -1, dvol_out, kinds[j]):
                p[0] = alt[3 * j]
                p[1] = alt[3 * j + 1]
                p[2] = alt[3 * j + 2]
                cost_err[0] = self.opt.quadric_weight * c
                cost_err[1] = err
                return True
        return False

    cdef int end_points(self, int r, int k, const double* p, double* alt, double* ca, double* q,
                        int* kinds) noexcept nogil:
        """``place_ok``'s other placements for collapsing ``r`` into ``k`` (planned at ``p``):
        the edge's two ends and its midpoint -- and, under an error bound, its quarter
        points and three points from ``p`` to the midpoint (a quarter, half and three
        quarters of the way) -- in rising quadric cost: ``alt`` (3 x n) the points, ``ca``
        their costs (clamped at 0), ``kinds`` the bound's memo kind of each (Bound.check),
        ``q`` the summed quadric.  Returns n (3, or MAX_PLACES under a bound), or 0 where
        there is no other placement: only where plan() chose a free optimal placement
        (neither end fixed, on the border or a seam, no fields, kernels or attribute
        quadrics in the cost) and did not plan an end already.  (The optimal point minimises
        the squared distance to the planes, not the largest distance to the input: under a
        bound a point nearer the edge often stays within it where that one does not.)"""
        cdef double pts[MAX_PLACES][3]
        cdef double cost[MAX_PLACES]
        cdef int order[MAX_PLACES]
        cdef int i, j, t
        cdef int n = MAX_PLACES if self.bound is not None else 3
        if self.opt.placement != PLACE_OPTIMAL or self.opt.has_extras or self.aq.dim > 0:
            return 0
        if (self.vflags[k] | self.vflags[r]) & (VERTEX_FIXED | VERTEX_BOUNDARY):
            return 0
        if self.SP != NULL and (self.SP[k] != SEAM_NONE or self.SP[r] != SEAM_NONE):
            return 0
        if same_point(p, &self.P[VSTRIDE * k]) or same_point(p, &self.P[VSTRIDE * r]):
            return 0
        quadric_sum(&self.Q[VSTRIDE * k], &self.Q[VSTRIDE * r], q)
        for i in range(3):
            pts[0][i] = self.P[VSTRIDE * k + i]
            pts[1][i] = self.P[VSTRIDE * r + i]
            pts[2][i] = 0.5 * (pts[0][i] + pts[1][i])
            pts[3][i] = 0.75 * pts[0][i] + 0.25 * pts[1][i]
            pts[4][i] = 0.25 * pts[0][i] + 0.75 * pts[1][i]
            pts[5][i] = 0.75 * p[i] + 0.25 * pts[2][i]
            pts[6][i] = 0.5 * (p[i] + pts[2][i])
            pts[7][i] = 0.25 * p[i] + 0.75 * pts[2][i]
        if n > 5 and same_point(p, pts[2]):
            n = 5                       # p is the midpoint: the points towards it are it again
        for i in range(n):
            cost[i] = quadric_eval(q, pts[i])
            order[i] = i
        for i in range(n):
            for j in range(i + 1, n):
                if cost[order[j]] < cost[order[i]]:
                    t = order[i]
                    order[i] = order[j]
                    order[j] = t
        for j in range(n):
            i = order[j]
            ca[j] = cost[i] if cost[i] > 0.0 else 0.0
            alt[3 * j] = pts[i][0]
            alt[3 * j + 1] = pts[i][1]
            alt[3 * j + 2] = pts[i][2]
            kinds[j] = 2 << i          # k's end 2, r's 4, the midpoint 8 (as Bound.memo_kind), then 16 ...
        return n

    cdef bint geometry_ok(self, int h, int r, int k, const double* p, int skip_c, int skip_d,
                          double* dvol_out, int kind=0) noexcept nogil:
        """The moved faces' checks for collapsing half-edge ``h`` (``r`` goes, ``k`` moves to
        ``p``), faces ``skip_c`` / ``skip_d`` judged for their volume only (-1: none); on
        success ``dvol_out`` gets six times the change of the enclosed volume."""
        cdef int fa = h // 3
        cdef int fb = self.m.twin[h] // 3 if self.m.twin[h] >= 0 else -1
        cdef double dvol = 0.0
        cdef double min_q = INFINITY
        if not self.fan_ok(r, fa, fb, skip_c, skip_d, p, &dvol, &min_q):
            return False
        if not same_point(p, &self.P[VSTRIDE * k]):
            if not self.fan_ok(k, fa, fb, skip_c, skip_d, p, &dvol, &min_q):
                return False
        if min_q < self.lim.min_quality:
            # a sliver is refused only when the fan had none as bad: the new worst face may
            # not be worse than min(min_quality, the worst face of both fans before)
            if min_q < self.fan_worst_quality(r, min_q) and min_q < self.fan_worst_quality(k, min_q):
                return False
        if self.lim.check_knife and self.knife(r, k, fa, fb):
            return False
        if self.closed_volume != 0.0:
            # a closed surface must not be turned inside out (locally valid faces can still
            # enclose a negative volume once the mesh is down to a handful of faces)
            dvol -= self.face_volume6(fa)
            if fb >= 0:
                dvol -= self.face_volume6(fb)
            if turns_inside_out(self.closed_volume, dvol):
                return False
        if self.bound is not None and not self.bound.check(h, r, k, p, kind):
            return False                     # would leave the error bound (last: the costliest check)
        dvol_out[0] = dvol
        return True

    cdef bint knife(self, int r, int k, int fa, int fb) noexcept nogil:
        """Would the collapse make a knife edge: join the two flat sides of a thin sheet
        (``flat_sides``: input faces facing exactly opposite ways, a CAD plate's top and
        bottom), one side in each end's fan, when neither fan held both sides before?  Its
        quadric cost is small (a rim vertex of a plate stands for little area) but it tilts
        every face of the new fan through the thickness (issue 17, docs/algorithms.md)."""
        cdef int fr[KNIFE_FAN]
        cdef int fk[KNIFE_FAN]
        cdef int nr, nk
        cdef int i, j
        cdef bint cross = False
        if not self.opposite_signs(r, k):
            return False
        nr = self.fan_faces(r, fa, fb, fr)
        nk = self.fan_faces(k, fa, fb, fk)
        for i in range(nr):
            for j in range(nk):
                if flat_sides(self.N0, fr[i], fk[j]):
                    cross = True
                    break
            if cross:
                break
        if not cross:
            return False
        for i in range(nr):
            for j in range(i + 1, nr):
                if flat_sides(self.N0, fr[i], fr[j]):
                    return False
        for i in range(nk):
            for j in range(i + 1, nk):
                if flat_sides(self.N0, fk[i], fk[j]):
                    return False
        return True

    cdef int fan_faces(self, int center, int fa, int fb, int* out) noexcept nogil:
        """The faces around ``center`` but fa and fb, into ``out`` (at most KNIFE_FAN); their count."""
        cdef int start = self.m.v_he[center]
        cdef int y = start
        cdef int f, n = 0
        while True:
            f = y // 3
            if f != fa and f != fb and n < KNIFE_FAN:
                out[n] = f
                n += 1
            y = he_ring_next(self.m, y)
            if y < 0 or y == start:
                return n

    cdef double fan_worst_quality(self, int center, double floor) noexcept nogil:
        """The lowest quality among the faces around ``center`` as they are (the ones a
        collapse removes included); stops early once one is at or below ``floor``."""
        cdef int start = self.m.v_he[center]
        cdef int y = start
        cdef int a, b, c, i
        cdef double e1[3]
        cdef double e2[3]
        cdef double n0[3]
        cdef double l2, q, worst = INFINITY
        while True:
            a = self.m.corner[y]
            b = he_dest(self.m, y)
            c = self.m.corner[he_prev(y)]
            l2 = 0.0
            for i in range(3):
                e1[i] = self.P[VSTRIDE * b + i] - self.P[VSTRIDE * a + i]
                e2[i] = self.P[VSTRIDE * c + i] - self.P[VSTRIDE * a + i]
                l2 += sq(e1[i]) + sq(e2[i]) + sq(self.P[VSTRIDE * c + i] - self.P[VSTRIDE * b + i])
            cross3(e1, e2, n0)
            q = tri_quality(sqrt(dot3(n0, n0)), l2) if l2 > 0.0 else 0.0
            if q < worst:
                worst = q
                if worst <= floor:
                    return worst
            y = he_ring_next(self.m, y)
            if y < 0 or y == start:
                return worst

    cdef bint ring_has(self, int v, int a, int b) noexcept nogil:
        """Is ``a`` or ``b`` a neighbour of ``v``?"""
        cdef int start = self.m.v_he[v]
        cdef int y = start
        cdef int w, ny
        while True:
            w = he_dest(self.m, y)
            if w == a or w == b:
                return True
            ny = he_ring_next(self.m, y)
            if ny < 0:
                w = self.m.corner[he_prev(y)]
                return w == a or w == b
            if ny == start:
                return False
            y = ny

    cdef bint pair_ok(self, int h, int r, int k, int hs, int rs, int ks, const double* p,
                      double* dvol) noexcept nogil:
        """May seam edge h (r -> k) and its partner hs (rs -> ks) collapse together?
        If so ``dvol[0..1]`` get each side's volume change; if not, the refusal is counted
        (topology or geometry).  The two sides must not touch (no edge from one side's ends
        to the other's): then the first collapse changes nothing the second one's checks
        look at, and both can be checked before either is done."""
        if (not self.hm.link_ok(h) or not self.hm.link_ok(hs)
                or self.ring_has(r, rs, ks) or self.ring_has(k, rs, ks)):
            self.n_rejected_topology += 1
            return False
        if not self.geometry_ok(h, r, k, p, -1, -1, &dvol[0]):
            self.n_rejected_geometry += 1
            return False
        if not self.geometry_ok(hs, rs, ks, p, -1, -1, &dvol[1]):
            self.n_rejected_geometry += 1
            return False
        return True

    cdef void perform_pair(self, int h, int r, int hs, int rs, const double* p, double cost,
                           double err, const double* dvol) noexcept nogil:
        """Collapse seam edge h (removing r) and its partner hs (removing rs), then
        re-rank around both kept vertices (once both sides are done: a seam edge's cost
        reads both sides).  Both collapses are recorded."""
        cdef int k = he_dest(self.m, h) if self.m.corner[h] == r else self.m.corner[h]
        cdef int ks = he_dest(self.m, hs) if self.m.corner[hs] == rs else self.m.corner[hs]
        self.perform(h, r, p, cost, err, -1.0, dvol[0], False)
        if self.rec.on:
            self.rec.pair_open[self.n_collapses - 1] = 1
        if not self.failed:
            self.perform(hs, rs, p, cost, err, -1.0, dvol[1], False)
        if self.failed:
            return
        self.n_seam_pairs += 1
        self.rerank(k)
        self.rerank(ks)

    cdef double face_volume6(self, int f) noexcept nogil:
        """Six times the signed volume of the cone from the origin over face ``f``."""
        return face_volume(&self.P[VSTRIDE * self.m.corner[3 * f]], &self.P[VSTRIDE * self.m.corner[3 * f + 1]],
                           &self.P[VSTRIDE * self.m.corner[3 * f + 2]])

    # ------------------------------------------------------------- heap upkeep
    cdef void recost(self, int e) noexcept nogil:
        """Re-rank edge ``e`` after a change around it (or drop it if it may not collapse)."""
        cdef int h = self.m.edge_he[e]
        self.recost_he(e, h, self.m.corner[h], he_dest(self.m, h))

    cdef void recost_he(self, int e, int h, int u, int v) noexcept nogil:
        cdef int hh, r, hs
        cdef double p[3]
        cdef double cost
        if self.plan_he(h, u, v, &hh, &r, &hs, p, &cost, NULL) == 0:       # ranking only
            if hs >= 0:
                # a seam pair is ranked once, as the edge of side a (plan_seam's h_out)
                self.heap.push_fast(self.m.edge[hh], cost)
                self.heap.remove_fast(self.m.edge[hs])
            else:
                self.heap.push_fast(e, cost)
        else:
            self.heap.remove_fast(e)
            if hs >= 0:
                self.heap.remove_fast(self.m.edge[hs])
                self.heap.remove_fast(self.m.edge[hh])

    cdef void recost_ring(self, int v) noexcept nogil:
        """Re-cost the edges around ``v``; around each neighbour that had a candidate
        refused by a check, give its refused edges (those out of the heap) another chance:
        the collapse at ``v`` may have made them legal."""
        cdef int start = self.m.v_he[v]
        cdef int y = start
        cdef int ny, w, hp
        self.refused[v] = 0
        while True:
            w = he_dest(self.m, y)
            self.recost_he(self.m.edge[y], y, v, w)
            self.retry_refused(w)
            ny = he_ring_next(self.m, y)
            if ny < 0:
                hp = he_prev(y)
                w = self.m.corner[hp]
                self.recost_he(self.m.edge[hp], hp, w, v)
                self.retry_refused(w)
                return
            if ny == start:
                return
            y = ny

    cdef void recost_wide(self, int v) noexcept nogil:
        """Re-rank every edge around ``v`` and around each of its neighbours, once each (for
        kernels whose costs depend on the stars of the ends: ``Kernel.wide``)."""
        cdef int start = self.m.v_he[v]
        cdef int y = start
        cdef int ny, i
        self.refused[v] = 0
        self.recost_around(v)
        if self.wide_kernel is not None and self.wide_kernel.n_changed >= 0:
            # the kernel named the vertices whose stars changed (re-ranking leaves the list be)
            for i in range(self.wide_kernel.n_changed):
                self.recost_around(self.wide_kernel.changed[i])
            self.walked[v] = 0
            for i in range(self.wide_kernel.n_changed):
                self.walked[self.wide_kernel.changed[i]] = 0
            return
        while True:
            self.recost_around(he_dest(self.m, y))
            ny = he_ring_next(self.m, y)
            if ny < 0:
                self.recost_around(self.m.corner[he_prev(y)])
                break
            if ny == start:
                break
            y = ny
        self.unwalk(v)

    cdef void recost_around(self, int w) noexcept nogil:
        """Re-rank the edges around ``w`` but those to a vertex already walked round in
        this re-rank (an edge is re-ranked once, from the first of its ends walked round)."""
        cdef int start = self.m.v_he[w]
        cdef int y = start
        cdef int ny
        self.refused[w] = 0
        if self.walked[w]:
            return
        self.walked[w] = 1
        while True:
            if not self.walked[he_dest(self.m, y)]:
                self.recost_he(self.m.edge[y], y, w, he_dest(self.m, y))
            ny = he_ring_next(self.m, y)
            if ny < 0:
                y = he_prev(y)
                if not self.walked[self.m.corner[y]]:
                    self.recost_he(self.m.edge[y], y, self.m.corner[y], w)
                return
            if ny == start:
                return
            y = ny

    cdef void unwalk(self, int v) noexcept nogil:
        """Clear the marks of recost_wide(v)'s walk: v and its neighbours."""
        cdef int start = self.m.v_he[v]
        cdef int y = start
        cdef int ny
        self.walked[v] = 0
        while True:
            self.walked[he_dest(self.m, y)] = 0
            ny = he_ring_next(self.m, y)
            if ny < 0:
                self.walked[self.m.corner[he_prev(y)]] = 0
                return
            if ny == start:
                return
            y = ny

    cdef void retry_refused(self, int w) noexcept nogil:
        cdef int start, y, ny, e
        if not self.refused[w]:
            return
        self.refused[w] = 0
        start = self.m.v_he[w]
        y = start
        while True:
            e = self.m.edge[y]
            if not self.heap.contains_fast(e):
                self.recost(e)
            ny = he_ring_next(self.m, y)
            if ny < 0:
                e = self.m.edge[he_prev(y)]
                if not self.heap.contains_fast(e):
                    self.recost(e)
                return
            if ny == start:
                return
            y = ny

    cdef void rescan(self) noexcept nogil:
        """Rebuild the heap from every live candidate edge."""
        cdef int e, h, r, hs
        cdef double p[3]
        cdef double cost
        self.heap.clear_fast()
        self.n_vetoed = 0
        for e in range(self.hm.n_edges):
            if self.m.edge_alive[e] and self.plan(e, &h, &r, &hs, p, &cost, NULL) == 0:
                if hs >= 0 and self.m.edge[h] != e:
                    continue              # side b of a seam pair: ranked as side a's edge
                self.heap.append_unordered(e, cost)
            if self.failed:
                break
        self.heap.heapify_fast()
        self.collapses_since_rescan = 0
        self.round_size = self.heap.size
        self.round_popped = 0
        self.round_limit = INFINITY
        self.n_rejected_error = 0
        self.n_rejected_topology = 0
        self.n_rejected_geometry = 0

    # ------------------------------------------------------------- the collapse
    cdef void drop_dead(self, const int* dead) noexcept nogil:
        """After a collapse: drop its dead edges (-1: none) from the heap."""
        cdef int i
        if self.opt.use_heap:
            for i in range(3):
                if dead[i] >= 0:
                    self.heap.remove_fast(dead[i])

    cdef void perform(self, int h, int r, const double* p, double cost, double err, double t_attr,
                      double dvol, bint rerank) noexcept nogil:
        """Collapse half-edge ``h``, removing ``r``; the kept end moves to ``p``.  ``t_attr``:
        the kept end's weight in the attributes' mix (< 0: from where p falls along the edge);
        ``dvol``: the enclosed volume's change (``geometry_ok``); ``rerank``: re-rank the
        candidates around the kept vertex now (False: the caller does it once a pair of
        collapses is done)."""
        cdef int dead[3]
        cdef int k
        cdef Candidate cand
        cdef int faces = 2 if self.m.twin[h] >= 0 else 1
        k = self.perform_local(h, r, p, cost, err, t_attr, self.n_collapses, dead)
        self.hm.n_alive_faces -= faces
        self.hm.n_alive_vertices -= 1
        if self.closed_volume != 0.0:
            self.closed_volume += dvol
        self.drop_dead(dead)
        self.n_collapses += 1
        if err > self.max_error_done:
            self.max_error_done = err
        self.collapses_since_rescan += 1
        if self.kernel is not None:
            # both ends are k now: u, v are not meaningful, removed / kept are
            fill_candidate(&cand, &self.kmesh, dead[0], h, r, k, r, k, p, cost, err)
            if chain_commit(self.chain, &cand) == KERNEL_ERROR:
                self.failed = True
                return
        if rerank:
            self.rerank(k)

    cdef int perform_local(self, int h, int r, const double* p, double cost, double err, double t_attr,
                           int row, int* dead) noexcept nogil:
        """The part of a collapse that stays inside the closed 1-rings of its ends: the
        half-edges, the kept vertex's flags, fields, quadric, attributes and position, and
        record ``row``.  No counter, heap or kernel is touched, so collapses of disjoint
        closed 1-rings can run at once (the pass driver); :meth:`perform` does the rest.
        ``row`` < 0: no record (the pass driver writes it later).  Returns the kept vertex;
        ``dead`` gets the dead edges."""
        cdef int merged_into[2]
        cdef int k, i, j, chain = -1
        cdef double t = 0.0, len2 = 0.0, bound_done = 0.0
        k = he_dest(self.m, h) if self.m.corner[h] == r else self.m.corner[h]
        # where p falls along r -> k decides how the attributes mix (for a triangle collapse
        # perform_tri gives the weight: barycentric over the face)
        if t_attr >= 0.0:
            t = t_attr
        else:
            for i in range(3):
                len2 += sq(self.P[VSTRIDE * k + i] - self.P[VSTRIDE * r + i])
                t += (p[i] - self.P[VSTRIDE * r + i]) * (self.P[VSTRIDE * k + i] - self.P[VSTRIDE * r + i])
            t = t / len2 if len2 > 0.0 else 1.0
            t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
        if self.rec.on and row >= 0:
            self.rec.faces[row, 0] = h // 3
            self.rec.faces[row, 1] = self.m.twin[h] // 3 if self.m.twin[h] >= 0 else -1
        if self.bound is not None:
            chain = self.bound.commit_begin(h, r, k)
        self.hm.collapse_uncounted(h, r, dead, merged_into)
        self.vflags[k] |= self.vflags[r] & VERTEX_BOUNDARY
        self.merge_signs(r, k)
        if self.fields.n_vfields or self.fields.n_efields:
            self.fields.merge(r, k, dead, merged_into)
        quadric_sum(&self.Q[VSTRIDE * k], &self.Q[VSTRIDE * r], &self.Q[VSTRIDE * k])
        for i in range(self.n_attr):
            self.A[self.n_attr * k + i] = (1.0 - t) * self.A[self.n_attr * r + i] + t * self.A[self.n_attr * k + i]
        if self.aq.dim > 0:
            # a seam vertex keeps its attributes: its side's chart at the seam
            self.aq.commit(r, k, p, self.A, self.n_attr,
                           (self.SP != NULL and self.SP[k] != SEAM_NONE) or (self.vflags[k] & VERTEX_FIXED) != 0)
        if not same_point(p, &self.P[VSTRIDE * k]):
            for i in range(3):
                self.P[VSTRIDE * k + i] = p[i]
            self.moved[k] = 1
        if self.bound is not None:
            bound_done = self.bound.commit_end(k, chain)
        if self.rec.on and row >= 0:
            self.rec.bound[row] = bound_done
            self.rec.removed[row] = r
            self.rec.kept[row] = k
            self.rec.pos[row, 0] = p[0]
            self.rec.pos[row, 1] = p[1]
            self.rec.pos[row, 2] = p[2]
            self.rec.cost[row] = cost
            self.rec.error[row] = err
            self.rec.moved[row] = self.moved[k]
            for j in range(self.n_attr):
                self.rec.attr[row, j] = self.A[self.n_attr * k + j]
        return k

    cdef void rerank(self, int k) noexcept nogil:
        """Heap driver, after a collapse kept ``k``: re-rank the edges whose cost changed
        (around k, or around its neighbours too for wide kernels)."""
        if not self.opt.use_heap:
            return
        if self.opt.wide_recost:
            self.recost_wide(k)
        else:
            self.recost_ring(k)

    cdef bint pop_candidate(self, int* item) noexcept nogil:
        """Pop the cheapest candidate (edge, or face for triangle collapse) into ``item``.
        When the heap is empty, rescan and pop again, unless nothing collapsed since the
        last rescan; False: no candidate is left."""
        cdef double key
        while self.heap.pop_fast(item, &key) < 0:
            if self.collapses_since_rescan == 0:
                return False
            self.rescan()
        self.round_popped += 1
        if self.round_popped == (self.round_size + FALLBACK_FRACTION - 1) // FALLBACK_FRACTION:
            self.round_limit = key
        return True

    cdef int run_c(self, int target_faces, int max_steps) noexcept nogil:
        """The greedy driver: the cheapest candidate first, until ``target_faces``.  With the
        end-of-edge fallback on (simplify's last step), a candidate whose planned position
        fails takes an end or the midpoint of its edge if that costs no more than the heap's
        next candidate (``place_ok``); otherwise it is refused, and the cheapest legal
        fallback among those refused since the last collapse is remembered (``defer_e``).
        When a whole round (a rescan, then every candidate) takes nothing, that one is taken
        -- one collapse, then a new round -- if it costs no more than the round's median
        candidate (``round_limit``: as the pass driver's fallback costs no more than its
        pass's dearest candidate, the cheapest sixth).  Without it the run stopped there: a
        refused candidate leaves the heap and a fallback could not cost more than the next
        (issue 17: plate24 at 5 % stopped at 376 faces for 319; with no limit the bracket's
        Hausdorff doubled; docs/algorithms.md)."""
        cdef int e, h, r, k, hs, rs, ks, steps = 0, n_iter = 0
        cdef int defer_e = -1
        cdef double cost, err, limit
        cdef double defer_cost = INFINITY
        cdef double ce[2]
        cdef double ce2[2]
        cdef double p[3]
        cdef double q[3]
        cdef double dvol[2]
        while self.hm.n_alive_faces > target_faces:
            n_iter += 1
            if n_iter % INTERRUPT_EVERY == 0 and signal_pending():
                return RUN_INTERRUPTED
            if steps >= max_steps:
                return RUN_CHUNK
            if not self.pop_candidate(&e):
                if defer_e < 0 or defer_cost > self.round_limit:
                    return RUN_EXHAUSTED
                # a round took nothing: the cheapest legal fallback of its refusals
                # (planned again on the same mesh: the same plan, the same fallback)
                e = defer_e
                defer_e = -1
                defer_cost = INFINITY
            if self.plan(e, &h, &r, &hs, p, &cost, &err) < 0:
                if self.failed:
                    return RUN_ERROR
                continue
            if err > self.opt.max_error:
                self.n_rejected_error += 1
                continue
            k = he_dest(self.m, h) if self.m.corner[h] == r else self.m.corner[h]
            if hs >= 0:
                # a seam edge: both sides together or neither
                rs = self.SP[r]
                ks = self.seam_kept(hs, rs)
                if not self.pair_ok(h, r, k, hs, rs, ks, p, dvol):
                    self.refused[r] = 1
                    self.refused[k] = 1
                    self.refused[rs] = 1
                    self.refused[ks] = 1
                    continue
                self.perform_pair(h, r, hs, rs, p, cost, err, dvol)
                if self.failed:
                    return RUN_ERROR
                steps += 1
                defer_e = -1
                defer_cost = INFINITY
                continue
            if not self.hm.link_ok(h):
                self.n_rejected_topology += 1
                self.refused[r] = 1
                self.refused[k] = 1
                continue
            ce[0] = cost
            ce[1] = err
            # what the driver takes next anyway: the heap's top, or once the heap is empty
            # the cheapest fallback refused since the last collapse (none: any cost)
            limit = self.heap.hkey[0] if self.heap.size > 0 else defer_cost
            if not self.place_ok(h, r, k, p, ce, limit, &dvol[0]):
                if self.end_fallback and limit < INFINITY:
                    # refused for its fallback's cost alone?  Remember the cheapest such
                    q[0] = p[0]
                    q[1] = p[1]
                    q[2] = p[2]
                    ce2[0] = cost
                    ce2[1] = err
                    if self.place_ok(h, r, k, q, ce2, INFINITY, &dvol[1]) and ce2[0] < defer_cost:
                        defer_e = e
                        defer_cost = ce2[0]
                self.n_rejected_geometry += 1
                self.refused[r] = 1
                self.refused[k] = 1
                continue
            self.perform(h, r, p, ce[0], ce[1], -1.0, dvol[0], True)
            if self.failed:
                return RUN_ERROR
            steps += 1
            defer_e = -1
            defer_cost = INFINITY
        return RUN_TARGET

    # ------------------------------------------------------------- Python API
    def run(self, int target_faces, int max_steps=2**31 - 1):
        """Collapse until ``target_faces`` live faces remain, ``max_steps`` collapses are done,
        or nothing legal is left.  Returns 0 (target), 1 (step budget) or 2 (exhausted)."""
        cdef int status
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        with nogil:
            status = self.run_c(target_faces, max_steps)
        if status == RUN_INTERRUPTED:
            raise_pending()
        return status

    def count_bound_refusals(self):
        """The live candidate edges that pass every check but the error bound (0 without
        one): after a run that found no collapse left, whether the bound stopped it."""
        if self.bound is None or self.released:
            return 0
        cdef Bound b = self.bound
        cdef int e, h, r, hs, k, rs, ks, n = 0
        cdef double p[3]
        cdef double ce[2]
        cdef double dv2[2]
        cdef double cost, err, dv
        cdef bint ok
        for e in range(self.hm.n_edges):
            if not self.m.edge_alive[e]:
                continue
            if self.plan(e, &h, &r, &hs, p, &cost, &err) != 0:
                continue
            k = he_dest(self.m, h) if self.m.corner[h] == r else self.m.corner[h]
            self.bound = None
            if hs >= 0:
                if self.m.edge[h] != e:
                    self.bound = b
                    continue              # a seam pair counts once, as side a's edge
                rs = self.SP[r]
                ks = self.seam_kept(hs, rs)
                ok = self.pair_ok(h, r, k, hs, rs, ks, p, dv2)
                self.bound = b
                if ok and (not b.check(h, r, k, p) or not b.check(hs, rs, ks, p)):
                    n += 1
                continue
            # the planned point, or after simplify's last step an end or the midpoint (the
            # bound is off here, so no cost limit: place_ok's own fallback)
            ok = self.hm.link_ok(h) and self.place_ok(h, r, k, p, ce, INFINITY, &dv)
            self.bound = b
            if ok and not b.check(h, r, k, p):
                n += 1
        return n

    def refusal_census(self):
        """Why each live candidate edge may not collapse now, after a run that found none:
        a dict of counts -- ``fixed`` (the lock / boundary rules), ``topology`` (the link
        condition), and for the ones the moved-face checks refuse, the one check which,
        switched off alone, would let it through (``quality``, ``input_face``, ``fold``,
        ``turn``, ``volume``), else ``several``; ``free``: passes every check (none, after
        an exhausted run).  Seam pairs count once.  For the stop detail and for study; the
        collapser is left as it was."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        cdef int e, h, r, hs, k, rs, ks
        cdef double p[3]
        cdef double dv2[2]
        cdef double cost, err, dv, vol
        cdef CheckLimits saved = self.lim
        out = {"fixed": 0, "topology": 0, "quality": 0, "input_face": 0, "fold": 0, "turn": 0, "volume": 0,
               "knife": 0, "several": 0, "free": 0}
        for e in range(self.hm.n_edges):
            if not self.m.edge_alive[e]:
                continue
            if self.plan(e, &h, &r, &hs, p, &cost, &err) != 0:
                out["fixed"] += 1
                continue
            k = he_dest(self.m, h) if self.m.corner[h] == r else self.m.corner[h]
            if hs >= 0:
                if self.m.edge[h] != e:
                    continue
                rs = self.SP[r]
                ks = self.seam_kept(hs, rs)
                if (not self.hm.link_ok(h) or not self.hm.link_ok(hs)
                        or self.ring_has(r, rs, ks) or self.ring_has(k, rs, ks)):
                    out["topology"] += 1
                elif self.pair_ok(h, r, k, hs, rs, ks, p, dv2):
                    out["free"] += 1
                else:
                    out["several"] += 1
                continue
            if not self.hm.link_ok(h):
                out["topology"] += 1
                continue
            if self.geometry_ok(h, r, k, p, -1, -1, &dv):
                out["free"] += 1
                continue
            reason = "several"
            for name in ("quality", "input_face", "fold", "turn", "volume", "knife"):
                self.lim = saved
                vol = self.closed_volume
                if name == "quality":
                    self.lim.min_quality = 0.0
                elif name == "input_face":
                    self.lim.check_orig = False
                elif name == "fold":
                    self.lim.check_fold = False
                elif name == "turn":
                    self.lim.cos_max_angle = -2.0
                elif name == "knife":
                    self.lim.check_knife = False
                else:
                    self.closed_volume = 0.0
                ok = self.geometry_ok(h, r, k, p, -1, -1, &dv)
                self.closed_volume = vol
                if ok:
                    reason = name
                    break
            self.lim = saved
            out[reason] += 1
        self.lim = saved
        return out

    def certified_bound(self):
        """The distance (normalised units) the current mesh is certified to be within of
        the input, both ways: the largest certificate of a live face (None without a bound)."""
        if self.bound is None:
            return None
        return self.bound.bound(self.hm.alive_faces)

    def relax_quality(self, double min_quality):
        """Lower the quality limit (``min_quality``) and give every live candidate another
        chance on the next ``run`` (a full rescan; the pass driver ranks every live edge
        again): ``simplify``'s relaxation steps when the checks leave no collapse."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        if not (0.0 <= min_quality <= 1.0):
            raise ValueError("min_quality must be in [0, 1]")
        self.lim.min_quality = min_quality
        self.collapses_since_rescan += 1

    def allow_knives(self):
        """Switch the knife test off (a collapse may join the two sides of a thin sheet) and
        give every live candidate another chance on the next ``run``: ``simplify``'s
        relaxation step when the checks leave no collapse."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        self.lim.check_knife = False
        self.collapses_since_rescan += 1

    def allow_end_fallback(self):
        """From the next ``run`` on, a candidate whose planned position fails the checks may
        collapse at an end or the midpoint of its edge (``place_ok``), and every live candidate gets another
        chance (a full rescan): ``simplify``'s last step when the checks leave no collapse."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        self.end_fallback = True
        self.collapses_since_rescan += 1

    def collapse_pass(self, edges, positions=None, int target_faces=0):
        """The pass driver's step (``lodkit._core.passes.PassCollapser``, made with
        ``use_heap=False``)."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        raise RuntimeError("collapse_pass needs an EdgeCollapser made with use_heap=False")

    def plan_face(self, int f):
        """Triangle collapse only (``lodkit._core.triangle.TriangleCollapser``)."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        raise RuntimeError("plan_face needs an EdgeCollapser made with operator=1 (triangle)")

    def check_face(self, int f):
        """Triangle collapse only (``lodkit._core.triangle.TriangleCollapser``)."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        raise RuntimeError("check_face needs an EdgeCollapser made with operator=1 (triangle)")

    @property
    def knife_test(self):
        """Is the knife test on (``allow_knives`` switches it off)?"""
        return bool(self.lim.check_knife)

    @property
    def n_tri_collapses(self):
        """Triangle collapses done (0: not a triangle collapser)."""
        return 0

    @property
    def n_tri_refused_second(self):
        """Triangle candidates refused at the second collapse's checks (0: not a triangle
        collapser)."""
        return 0

    @property
    def error_message(self):
        """The message of the kernel that failed ('' if none did)."""
        for k in (self.chain.kernels() if self.chain is not None else ()):
            if k.failed:
                return k.message
        return ""

    @property
    def vertex_field_values(self):
        """(n, k) current vertex fields (merged on collapse)."""
        return self.fields.vertex_values

    @property
    def edge_field_values(self):
        return self.fields.edge_values

    def release(self):
        """Free the heap and the input normals once the run is over (the positions,
        attributes and records stay readable; the quadric columns go with the positions);
        ``run`` may not be called again."""
        if self.released:
            return
        self.released = True
        self.heap = IndexedHeap(0)
        self.face_n0 = np.zeros(3, dtype=np.int16)
        self.N0 = &self.face_n0[0]
        self.normal_sign = np.zeros(1, dtype=np.uint8)
        self.NS = &self.normal_sign[0]
        # the positions stay where they are: a view of the rows' last columns (a copy was
        # a fresh 24 B a slot, page faults and all, of which the output reads a tenth),
        # which keeps the rows' memory until the positions go too
        self.pos_out = np.asarray(self.vdata)[:, QSIZE:]
        self.vdata = np.zeros((1, VSTRIDE))
        self.Q = &self.vdata[0, 0]
        self.P = &self.vdata[0, QSIZE]

    def plan_edge(self, int u, int v):
        """``(removed, kept, position, cost, error)`` for edge (u, v), or None if it may not
        collapse.  Checks nothing but the fixed/boundary rules; for tests."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        h = self.hm._find_halfedge(u, v)
        if h < 0:
            raise ValueError(f"({u}, {v}) is not an edge")
        cdef int hh, r, hs
        cdef double p[3]
        cdef double cost, err
        if self.plan(self.hm.edge[h], &hh, &r, &hs, p, &cost, &err) < 0:
            return None
        k = self.hm.dest(hh) if self.hm.corner[hh] == r else self.hm.corner[hh]
        return r, k, np.array([p[0], p[1], p[2]]), cost, err

    @property
    def n_alive_faces(self):
        return self.hm.n_alive_faces

    @property
    def seam_partners(self):
        """(n,) int32: each vertex slot's seam partner, -1 off the seams, -2 a seam copy
        that stays (as given, with the fixed rules applied); None without seams."""
        if self.SP == NULL:
            return None
        return np.asarray(self.seam).copy()

    @property
    def n_seam_fixed(self):
        """Seam vertex slots that may neither move nor go (SEAM_STAYS, and both copies of
        a seam end or of a pair with a fixed copy), as set up (0 without seams)."""
        if self.SP == NULL:
            return 0
        sp = np.asarray(self.seam)
        return int(np.count_nonzero((sp != SEAM_NONE) & ((np.asarray(self.vflags) & VERTEX_FIXED) != 0)))

    @property
    def positions(self):
        """(n, 3) current positions (a view of the vertex rows, also after ``release``)."""
        if self.released:
            return self.pos_out
        return np.asarray(self.vdata)[:, QSIZE:]

    @property
    def attributes(self):
        return np.asarray(self.attr)

    @property
    def moved_vertices(self):
        return np.asarray(self.moved).astype(bool)

    @property
    def quadrics(self):
        """(n, 11) current quadrics (a view)."""
        if self.released:
            raise RuntimeError("this EdgeCollapser was released")
        return np.asarray(self.vdata)[:, :QSIZE]

    def records(self):
        """The collapse sequence: dict of removed, kept (vertex slots), position (n, 3),
        cost, error and moved (False: the position is the kept vertex's input position),
        one row per collapse in the order they were done.  Needs
        ``record=True`` at construction."""
        if not self.rec.on:
            raise RuntimeError("this EdgeCollapser was made with record=False")
        return self.rec.rows(self.n_collapses)
