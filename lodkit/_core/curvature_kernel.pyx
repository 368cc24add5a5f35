# cython: language_level=3
"""The native kernel of the ``curvature`` metric (Wang et al. 2011, eq. 6).

Each vertex slot carries w, its normalised curvature (eq. 5, in [0, 1]; filled by
``lodkit.metrics.curvature.Curvature`` from the vertex cloud).  An edge (u, v) of current
length l weighs

    omega = l * (floor + (w_u + w_v) / 2)

(the paper's garbled ``l^{-k} w_k`` read as length times mean normalised curvature: short
edges in flat regions go first, creases last; ``floor`` keeps flat regions, where w = 0,
ordered by length).  ``mode`` says what the kernel does with the cost it is handed:

    MODE_REPLACE (0)   cost = weight * omega                       (the paper: omega alone)
    MODE_SCALE   (1)   cost = cost * (1 + weight * (w_u + w_v) / 2)   (modulates e.g. QEM)

After a collapse the kept vertex's w becomes ``merge`` of the two ends' values (MERGE_MAX
keeps creases dear as they shrink; MERGE_MEAN averages).  With ``midpoint`` set, ``place``
puts the kept vertex at the edge midpoint, unless an end is fixed or on the boundary (then
the core's placement stands).
"""
import numpy as np

from lodkit.kernel cimport (Kernel, Candidate, vertex_position, KERNEL_OK, KERNEL_API_VERSION,
                            VERTEX_FIXED, VERTEX_BOUNDARY)

from libc.math cimport sqrt

cdef enum:
    C_MODE_REPLACE = 0
    C_MODE_SCALE = 1
    C_MERGE_MAX = 0
    C_MERGE_MEAN = 1

MODE_REPLACE = C_MODE_REPLACE
MODE_SCALE = C_MODE_SCALE
MERGE_MAX = C_MERGE_MAX
MERGE_MEAN = C_MERGE_MEAN


cdef class CurvatureKernel(Kernel):
    api_version = KERNEL_API_VERSION

    cdef double[::1] w              # normalised curvature of each vertex slot, kept up to date
    cdef double* W
    cdef readonly double floor
    cdef readonly double weight
    cdef readonly int mode
    cdef readonly int merge

    def prepare(self, ctx, options):
        """Take the per-slot normalised curvature from ``options["curvature"]`` (n,) and the
        rules from ``options``: floor, weight, mode, merge, midpoint (see the module doc)."""
        if options.get("curvature") is None:
            raise ValueError("CurvatureKernel.prepare needs options['curvature']: the (n,) normalised "
                             "curvature of every vertex slot (lodkit.metrics.curvature computes it)")
        w = np.ascontiguousarray(options["curvature"], dtype=np.float64).copy()
        n = ctx.n_vertices if ctx is not None else w.shape[0]
        if w.ndim != 1 or w.shape[0] != n:
            raise ValueError(f"curvature must have shape ({n},), got {w.shape}")
        if not np.isfinite(w).all() or (w < 0.0).any():
            raise ValueError("curvature must be finite and >= 0")
        self.w = w
        self.W = &self.w[0] if w.shape[0] else NULL
        self.floor = float(options.get("floor", 0.0))
        self.weight = float(options.get("weight", 1.0))
        self.mode = MODE_SCALE if options.get("mode", "replace") == "scale" else MODE_REPLACE
        self.merge = MERGE_MEAN if options.get("merge", "max") == "mean" else MERGE_MAX
        self.places = bool(options.get("midpoint", False))

    @property
    def curvature(self):
        """(n,) the current normalised curvature of every vertex slot (a copy)."""
        return np.asarray(self.w).copy()

    cdef int place(self, Candidate* c) noexcept nogil:
        cdef const double* a
        cdef const double* b
        cdef int i
        if c.mesh == NULL:
            return KERNEL_OK          # a bare candidate (Kernel._call): no positions
        if (c.mesh.flags[c.u] | c.mesh.flags[c.v]) & (VERTEX_FIXED | VERTEX_BOUNDARY):
            return KERNEL_OK          # the core's fixed / boundary rules place this one
        a = vertex_position(c.mesh, c.u)
        b = vertex_position(c.mesh, c.v)
        for i in range(3):
            c.p[i] = 0.5 * (a[i] + b[i])
        return KERNEL_OK

    cdef int cost(self, Candidate* c) noexcept nogil:
        cdef double wk = 0.5 * (self.W[c.u] + self.W[c.v])
        cdef const double* a
        cdef const double* b
        cdef double dx, dy, dz
        if self.mode == C_MODE_SCALE:
            c.cost = c.cost * (1.0 + self.weight * wk)
            return KERNEL_OK
        if c.mesh == NULL:
            return KERNEL_OK          # a bare candidate: no positions, no length
        a = vertex_position(c.mesh, c.u)
        b = vertex_position(c.mesh, c.v)
        dx = a[0] - b[0]
        dy = a[1] - b[1]
        dz = a[2] - b[2]
        c.cost = self.weight * sqrt(dx * dx + dy * dy + dz * dz) * (self.floor + wk)
        return KERNEL_OK

    cdef int commit(self, const Candidate* c) noexcept nogil:
        cdef double a = self.W[c.kept], b = self.W[c.removed]
        if self.merge == C_MERGE_MEAN:
            self.W[c.kept] = 0.5 * (a + b)
        elif b > a:
            self.W[c.kept] = b
        return KERNEL_OK
