# cython: language_level=3
"""QEM written as a native kernel (the ``qem_native`` metric).

The same cost as the core's hard-wired quadrics -- area-weighted plane quadrics plus the
boundary planes of the 'preserve' policy, summed on collapse, evaluated at the position the
core chose -- but computed through the public kernel interface, the way a plugin would.
It exists to measure what the interface costs (bench/) and as a worked example.
"""
import numpy as np

from lodkit.kernel cimport Kernel, Candidate, KERNEL_OK, KERNEL_API_VERSION


cdef class QEMKernel(Kernel):
    api_version = KERNEL_API_VERSION

    cdef double[:, ::1] q          # (n, 10) quadric of each vertex slot
    cdef double* Q
    cdef double weight

    def prepare(self, ctx, options):
        from .quadric import add_boundary_planes

        q = np.ascontiguousarray(ctx.face_quadrics[:, :10], dtype=np.float64).copy()
        if ctx.settings.get("boundary") == "preserve" and ctx.settings.get("boundary_weight", 0.0) > 0.0:
            add_boundary_planes(ctx.halfedge, ctx.positions, float(ctx.settings["boundary_weight"]), q)
        self.q = q
        self.weight = float(options.get("weight", 1.0))
        self.Q = &self.q[0, 0] if q.shape[0] else NULL

    cdef int cost(self, Candidate* c) noexcept nogil:
        cdef const double* a = &self.Q[10 * c.u]
        cdef const double* b = &self.Q[10 * c.v]
        cdef double x = c.p[0], y = c.p[1], z = c.p[2]
        cdef double e = ((a[0] + b[0]) * x * x + 2.0 * (a[1] + b[1]) * x * y + 2.0 * (a[2] + b[2]) * x * z
                         + (a[3] + b[3]) * y * y + 2.0 * (a[4] + b[4]) * y * z + (a[5] + b[5]) * z * z
                         + 2.0 * ((a[6] + b[6]) * x + (a[7] + b[7]) * y + (a[8] + b[8]) * z) + (a[9] + b[9]))
        c.cost += self.weight * e if e > 0.0 else 0.0
        return KERNEL_OK

    cdef int commit(self, const Candidate* c) noexcept nogil:
        cdef int i
        for i in range(10):
            self.Q[10 * c.kept + i] += self.Q[10 * c.removed + i]
        return KERNEL_OK
