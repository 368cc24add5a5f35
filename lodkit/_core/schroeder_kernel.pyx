# cython: language_level=3
"""The native kernel of the ``schroeder`` metric (Schroeder, Zarge & Lorensen 1992).

For a vertex v with link l_0 .. l_{k-1} (removal.pxd: face i is (v, l_i, l_{i+1})):

1. **Classify** the star.  Face i has the area vector a_i = (l_i - v) x (l_{i+1} - v) (twice
   its area times its unit normal n_i).  The edge (v, l_i) between faces i - 1 and i is a
   *feature edge* when the angle between n_{i-1} and n_i is more than ``feature_angle``
   (n_{i-1}.n_i < cos(feature_angle)); edges touching a face of zero area are not feature
   edges (their angle is undefined).  Then

   =============  =====================================================================
   SIMPLE         closed star, no feature edge
   INTERIOR_EDGE  closed star, exactly two feature edges (v lies on a crease)
   CORNER         closed star with one or more than two feature edges, or an open star
                  with any feature edge
   BOUNDARY       open star (v on a boundary loop), no feature edge
   COMPLEX        anything the driver did not already exclude that has no well-defined
                  average plane or loop: a repeated link vertex, fewer than 3 link
                  vertices (an open star of one face), zero total area or zero average
                  normal
   =============  =====================================================================

2. **Average plane** (Schroeder's area-weighted one): normal N = sum a_i / |sum a_i|,
   point x_0 = sum A_i c_i / sum A_i with A_i = |a_i| / 2 and c_i the centroid of face i.

3. **Decimation criterion** d, the vertex's error and cost:
   SIMPLE (and a closed-star CORNER with ``remove_corners``): d = |N . (v - x_0)|;
   BOUNDARY (and an open-star CORNER with ``remove_corners``): the distance of v to the
   line through l_0 and l_{k-1} (the new boundary edge);
   INTERIOR_EDGE: the distance of v to the line through its two feature neighbours (the
   new feature edge).  COMPLEX and (by default) CORNER vertices are vetoed.

4. **Hole**: the loop l_0 .. l_{k-1} is triangulated by recursive loop splitting with split
   planes orthogonal to the average plane (retriangulate.split_loop_aspect, smallest split
   aspect ratio ``min_aspect``).  INTERIOR_EDGE: the first split is forced along the
   feature edge, so the crease survives as an edge.  BOUNDARY: the first "split" is the new
   boundary edge l_{k-1} -> l_0 itself, one-sided: every other link vertex must lie on the
   surface's side of its split plane, with the same aspect-ratio bound (what Schroeder's
   vtkDecimate checks).  No valid triangulation: KERNEL_VETO (the vertex stays until its
   star changes).

With ``accumulate="off"`` the kernel keeps no state between removals: the error is local, as
in the paper.  lodkit's default (``accumulate="points"``) carries the removed vertices and
the input faces' centroids on the face slots nearest them (removal_star.pxd) and takes as
the error the larger of d and their distance to the new patch; corners are then removable
(``remove_corners`` None) and a vertex with no feature line to keep takes the triangulation
nearest it (``triangulation="nearest"``: the loop split or the hole's least-volume
triangulation).  ``accumulate="bound"`` keeps a per-vertex distance bound instead.
"""
import math as _math

import numpy as np

from .retriangulate import auto_mode, carried_points

from libc.math cimport sqrt, NAN

from lodkit.kernel cimport KernelMesh, KERNEL_OK, KERNEL_VETO
from lodkit.removal cimport RemovalKernel, Star, Removal, MAX_VALENCE, REMOVAL_API_VERSION
from .retriangulate cimport split_loop_aspect, least_distance_patch
from .removal_star cimport star_on_points, patch_distance, carried_distance, carry_points
from .vec3 cimport sub3, cross3, dot3, norm3

cdef enum:
    C_SIMPLE = 0
    C_COMPLEX = 1
    C_BOUNDARY = 2
    C_INTERIOR_EDGE = 3
    C_CORNER = 4

SIMPLE = C_SIMPLE
COMPLEX = C_COMPLEX
BOUNDARY = C_BOUNDARY
INTERIOR_EDGE = C_INTERIOR_EDGE
CORNER = C_CORNER
cdef enum:
    ACC_OFF = 0             # the paper: the criterion is the star's alone
    ACC_BOUND = 1           # lodkit's default: an accumulated distance bound (module doc)
    ACC_POINTS = 2          # lodkit's default: the removed vertices themselves are carried

#: the ``accumulate`` option's values, in ACC_* order
ACCUMULATE_MODES = ("off", "bound", "points")

cdef enum:
    TRI_SPLIT = 0           # the paper: recursive loop splitting
    TRI_NEAREST = 1         # lodkit's: the patch nearest the removed vertex (no feature line)

#: the ``triangulation`` option's values, in TRI_* order ("auto" follows ``accumulate``)
TRIANGULATION_MODES = ("split", "nearest")

#: class code -> name
CLASS_NAMES = ("simple", "complex", "boundary", "interior_edge", "corner")

#: defaults of the options (docs/metrics/schroeder.md gives their sources)
DEFAULT_FEATURE_ANGLE = 30.0     # degrees: vtkDecimate's InitialFeatureAngle
DEFAULT_MIN_ASPECT = 0.04        # vtkDecimate's AspectRatio 25: a split is refused below 1/25


cdef class SchroederKernel(RemovalKernel):
    api_version = REMOVAL_API_VERSION
    star_local = True                        # evaluate() depends on the star alone (vremove caches it)

    cdef readonly double feature_angle       # degrees
    cdef readonly double cos_feature
    cdef readonly double min_aspect
    cdef readonly bint remove_corners
    cdef int[::1] _work                      # split_loop scratch: 6 * MAX_VALENCE ints
    cdef int* work
    # what the last evaluate() found (for evaluate_star and tests)
    cdef int last_class
    cdef int last_fa
    cdef int last_fb
    # accumulation (lodkit's addition, see the module doc): ACC_* code and the distance
    # bound each vertex slot carries from the removals around it
    cdef readonly int accumulate_code
    cdef double[::1] _acc
    cdef double* acc
    cdef readonly int triangulation_code     # TRI_*
    cdef double[::1] _dp_cost                # least_distance_patch scratch (MAX_VALENCE^2)
    cdef int[::1] _dp_split
    cdef int[::1] _head                 # accumulate="points": removal_star's lists
    cdef int[::1] _nxt
    cdef double[::1] _cent              # the input faces' centroids (carried points)
    cdef int _nv
    cdef int n_acc

    def __cinit__(self):
        self._work = np.zeros(6 * MAX_VALENCE, dtype=np.int32)
        self.work = &self._work[0]
        self.feature_angle = DEFAULT_FEATURE_ANGLE
        self.cos_feature = _math.cos(_math.radians(DEFAULT_FEATURE_ANGLE))
        self.min_aspect = DEFAULT_MIN_ASPECT
        self.remove_corners = False
        self.last_class = C_COMPLEX
        self.last_fa = self.last_fb = -1
        self.accumulate_code = ACC_OFF
        self.acc = NULL
        self.triangulation_code = TRI_SPLIT
        self._dp_cost = np.zeros(MAX_VALENCE * MAX_VALENCE)
        self._dp_split = np.zeros(MAX_VALENCE * MAX_VALENCE, dtype=np.int32)
        self.n_acc = 0

    def prepare(self, ctx, options):
        """Take ``feature_angle`` (degrees, in [0, 180]), ``min_aspect`` (>= 0) and
        ``remove_corners`` from ``options`` (missing ones keep their defaults)."""
        fa = float(options.get("feature_angle", DEFAULT_FEATURE_ANGLE))
        ma = float(options.get("min_aspect", DEFAULT_MIN_ASPECT))
        if not (0.0 <= fa <= 180.0):
            raise ValueError(f"feature_angle must be in [0, 180] degrees, got {fa!r}")
        if not (ma >= 0.0 and _math.isfinite(ma)):
            raise ValueError(f"min_aspect must be a finite number >= 0, got {ma!r}")
        self.feature_angle = fa
        self.cos_feature = _math.cos(_math.radians(fa))
        self.min_aspect = ma
        acc = options.get("accumulate", "points")
        rc = options.get("remove_corners", None)
        self.remove_corners = (acc != "off") if rc is None else bool(rc)
        self.triangulation_code = auto_mode("triangulation", options.get("triangulation", "auto"),
                                            TRIANGULATION_MODES, "split", "nearest", acc)
        if acc not in ACCUMULATE_MODES:
            raise ValueError(f"accumulate must be one of {ACCUMULATE_MODES}, got {acc!r}")
        self.accumulate_code = ACCUMULATE_MODES.index(acc)
        n = int(ctx.n_vertices) if ctx is not None else int(options.get("n_vertices", 0))
        self._acc = np.zeros(max(n, 1))
        self.acc = &self._acc[0]
        self._nv = n
        # each face slot starts with its own centroid (point n + f)
        self._cent, self._head, self._nxt = carried_points(ctx, n)
        self.n_acc = n

    cdef int evaluate(self, const Star* s, Removal* r) noexcept nogil:
        cdef const KernelMesh* m = s.mesh
        cdef const double* P = m.positions
        cdef int stride = m.stride
        cdef int k = s.k, nf, i, j, ia, ib, cls, nfeat, fa = -1, fb = -1, n
        cdef const double* x = &P[stride * s.v]
        cdef const double* b
        cdef const double* c
        cdef double un[3 * MAX_VALENCE]          # unit normal of each face (0 if degenerate)
        cdef double N[3]
        cdef double C[3]
        cdef double e[3]
        cdef double f[3]
        cdef double g[3]
        cdef double area, A = 0.0, nl, d, t, ll, dp
        cdef int force_a, force_b
        cdef double W[3 * MAX_VALENCE]
        cdef int cand[3 * MAX_VALENCE]
        r.gate = NAN
        self.last_class = C_COMPLEX
        self.last_fa = self.last_fb = -1
        if k < 3 or k > MAX_VALENCE:
            return KERNEL_VETO
        for i in range(k):
            for j in range(i):
                if s.link[i] == s.link[j]:
                    return KERNEL_VETO          # a repeated link vertex: not a disc
        nf = k if s.closed else k - 1
        N[0] = N[1] = N[2] = 0.0
        C[0] = C[1] = C[2] = 0.0
        for i in range(nf):
            b = &P[stride * s.link[i]]
            c = &P[stride * s.link[(i + 1) % k]]
            sub3(b, x, e)
            sub3(c, x, f)
            cross3(e, f, g)
            nl = norm3(g)
            area = 0.5 * nl
            for j in range(3):
                N[j] += g[j]
                C[j] += area * (x[j] + b[j] + c[j]) / 3.0
                un[3 * i + j] = g[j] / nl if nl > 0.0 else 0.0
            A += area
        nl = sqrt(N[0] * N[0] + N[1] * N[1] + N[2] * N[2])
        if not (A > 0.0 and nl > 1e-12 * A):
            return KERNEL_VETO                  # no average plane (VTK's zero-area / -normal)
        for j in range(3):
            N[j] /= nl
            C[j] /= A

        # feature edges: edge (v, l_i) lies between faces i - 1 and i
        nfeat = 0
        for i in range(k):
            if s.closed:
                ia = (i + k - 1) % k
            elif i == 0 or i == k - 1:
                continue                        # the two boundary edges
            else:
                ia = i - 1
            ib = i
            t = un[3 * ia] * un[3 * ib] + un[3 * ia + 1] * un[3 * ib + 1] + un[3 * ia + 2] * un[3 * ib + 2]
            if (un[3 * ia] == 0.0 and un[3 * ia + 1] == 0.0 and un[3 * ia + 2] == 0.0) or \
               (un[3 * ib] == 0.0 and un[3 * ib + 1] == 0.0 and un[3 * ib + 2] == 0.0):
                continue                        # a face of zero area: no angle
            if t < self.cos_feature:
                if nfeat == 0:
                    fa = i
                elif nfeat == 1:
                    fb = i
                nfeat += 1
        if s.closed:
            cls = C_SIMPLE if nfeat == 0 else (C_INTERIOR_EDGE if nfeat == 2 else C_CORNER)
        else:
            cls = C_BOUNDARY if nfeat == 0 else C_CORNER
        if not s.closed and (cls == C_BOUNDARY or self.remove_corners):
            fa = 0                              # the new boundary edge's ends
            fb = k - 1
        self.last_class = cls
        self.last_fa = fa if cls == C_INTERIOR_EDGE or cls == C_BOUNDARY else -1
        self.last_fb = fb if cls == C_INTERIOR_EDGE or cls == C_BOUNDARY else -1

        force_a = force_b = -1
        if cls == C_SIMPLE or (cls == C_CORNER and self.remove_corners and s.closed):
            d = (x[0] - C[0]) * N[0] + (x[1] - C[1]) * N[1] + (x[2] - C[2]) * N[2]
            if d < 0.0:
                d = -d
        elif cls == C_INTERIOR_EDGE or cls == C_BOUNDARY or (cls == C_CORNER and self.remove_corners):
            b = &P[stride * s.link[fa]]
            c = &P[stride * s.link[fb]]
            sub3(c, b, e)
            sub3(x, b, f)
            ll = dot3(e, e)
            if not ll > 0.0:
                return KERNEL_VETO
            cross3(e, f, g)
            d = sqrt(dot3(g, g) / ll)
            force_a = fa
            force_b = fb
        else:
            return KERNEL_VETO                  # corner (kept, as Schroeder) or complex
        n = split_loop_aspect(P, stride, s.link, k, N, force_a, force_b, self.min_aspect,
                              r.tri, self.work)
        if self.triangulation_code == TRI_NEAREST and force_a < 0:
            # lodkit's addition (no feature line to keep): of the loop split, the hole's
            # least-volume triangulation, the one nearer to v
            for i in range(k):
                for j in range(3):
                    W[3 * i + j] = P[stride * s.link[i] + j]
            if least_distance_patch(W, k, x, N, r.tri, n if n > 0 else 0, &dp,
                                    &self._dp_cost[0], &self._dp_split[0], cand) > 0:
                n = k - 2
        if n < 0:
            return KERNEL_VETO                  # no valid triangulation: the vertex stays
        r.n_tris = n
        if self.accumulate_code == ACC_BOUND:
            # lodkit's addition: the larger of d and v's distance to the patch that
            # replaces its star, plus the bound v carries from the removals around it
            dp = patch_distance(P, stride, x, s.link, r.tri, r.n_tris)
            if dp > d:
                d = dp
            if s.v < self.n_acc:
                d = d + self.acc[s.v]
        elif self.accumulate_code == ACC_POINTS:
            # lodkit's default: how far v and the removed vertices in its care lie from the
            # patch (measured), or d if larger
            if s.v < self.n_acc:
                dp = carried_distance(P, stride, s, r.tri, r.n_tris, &self._head[0], &self._nxt[0],
                                      &self._cent[0], self._nv)
            else:                               # a lone star (evaluate_star): nothing carried
                dp = patch_distance(P, stride, x, s.link, r.tri, r.n_tris)
            if dp > d:
                d = dp
        r.cost = d
        r.error = d
        return KERNEL_OK

    cdef int commit(self, const Star* s, const Removal* r) noexcept nogil:
        cdef int i, w
        if self.accumulate_code == ACC_BOUND:
            # the new faces lie within r.error of the input: so do the link vertices' stars
            for i in range(s.k):
                w = s.link[i]
                if 0 <= w < self.n_acc and r.error > self.acc[w]:
                    self.acc[w] = r.error
        elif self.accumulate_code == ACC_POINTS and 0 <= s.v < self.n_acc:
            carry_points(s.mesh.positions, s.mesh.stride, s, &self._head[0], &self._nxt[0],
                         &self._cent[0], self._nv)
        return KERNEL_OK

    def accumulated(self):
        """(n,) float64: the distance bound each vertex slot carries from the removals
        around it (normalised units; zeros with ``accumulate="off"``)."""
        return np.asarray(self._acc[:self.n_acc]).copy() if self.n_acc else np.zeros(0)

    def evaluate_star(self, positions, int v, link, bint closed):
        """Evaluate removing vertex ``v`` of ``positions`` (n, 3) whose link is ``link``
        (in order, see removal.pxd) and star closed or open, with this kernel's options.

        Returns a dict: ``cls`` (class code), ``name`` (class name), ``features`` (the two
        link indices whose line is the criterion's, for boundary and interior-edge
        vertices, else None), ``vetoed`` (bool), ``error`` and ``cost`` (None when
        vetoed) and ``triangles`` ((k - 2, 3) int32 indices into ``link``, or None)."""
        cdef const double[:, ::1] Pv = np.ascontiguousarray(positions, dtype=np.float64)
        L = np.ascontiguousarray(link, dtype=np.int32).reshape(-1)
        if Pv.shape[1] != 3:
            raise ValueError("positions must have shape (n, 3)")
        if L.shape[0] > MAX_VALENCE:
            raise ValueError(f"at most {MAX_VALENCE} link vertices")
        if not (0 <= v < Pv.shape[0]) or (L.shape[0] and (L.min() < 0 or L.max() >= Pv.shape[0])):
            raise ValueError("vertex index out of range")
        cdef KernelMesh mesh
        cdef Star star
        cdef Removal rem
        cdef int i, rc
        cdef const int[::1] Lv = L
        star_on_points(&mesh, &star, &Pv[0, 0], Pv.shape[0], NULL, v,
                       &Lv[0] if L.shape[0] else NULL, L.shape[0], closed)
        rem.n_tris = 0
        with nogil:
            rc = self.evaluate(&star, &rem)
        out = {"cls": self.last_class, "name": CLASS_NAMES[self.last_class],
               "features": (self.last_fa, self.last_fb) if self.last_fa >= 0 else None,
               "vetoed": rc != KERNEL_OK, "error": None, "cost": None, "triangles": None}
        if rc == KERNEL_OK:
            out["error"] = rem.error
            out["cost"] = rem.cost
            out["triangles"] = np.array([rem.tri[i] for i in range(3 * rem.n_tris)],
                                        dtype=np.int32).reshape(rem.n_tris, 3)
        return out


def evaluate_star(positions, int v, link, bint closed, **options):
    """:meth:`SchroederKernel.evaluate_star` with a kernel prepared from ``options``
    (feature_angle, min_aspect, remove_corners)."""
    k = SchroederKernel()
    k.prepare(None, options)
    return k.evaluate_star(positions, v, link, closed)
