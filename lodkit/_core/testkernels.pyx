# cython: language_level=3
"""Small native kernels for tests and examples of the kernel interface (not metrics a user
would pick; they are not registered).

VetoAll        refuses every collapse
FailAfter      reports an error from nogil code after ``n`` cost calls
MidpointPlacer places the kept vertex at the edge midpoint (a kernel that ``places``)
ScaleBy        multiplies the cost so far by ``factor`` and counts its calls
"""
from .kernel cimport Kernel, Candidate, KernelMesh, vertex_position, KERNEL_OK, KERNEL_VETO, KERNEL_API_VERSION


cdef class VetoAll(Kernel):
    api_version = KERNEL_API_VERSION

    cdef int cost(self, Candidate* c) noexcept nogil:
        return KERNEL_VETO


cdef class FailAfter(Kernel):
    api_version = KERNEL_API_VERSION
    cdef long n
    cdef long calls

    def prepare(self, ctx, options):
        self.n = int(options.get("n", 0))
        self.calls = 0

    cdef int cost(self, Candidate* c) noexcept nogil:
        self.calls += 1
        if self.calls > self.n:
            return self.fail(b"FailAfter: the cost budget is spent")
        return KERNEL_OK


cdef class MidpointPlacer(Kernel):
    api_version = KERNEL_API_VERSION

    def prepare(self, ctx, options):
        self.places = True

    cdef int place(self, Candidate* c) noexcept nogil:
        cdef const double* a = vertex_position(c.mesh, c.u)
        cdef const double* b = vertex_position(c.mesh, c.v)
        cdef int i
        for i in range(3):
            c.p[i] = 0.5 * (a[i] + b[i])
        return KERNEL_OK


cdef class ScaleBy(Kernel):
    api_version = KERNEL_API_VERSION
    cdef double factor
    cdef readonly long n_cost
    cdef readonly long n_commit

    def prepare(self, ctx, options):
        self.factor = float(options.get("factor", 1.0))
        self.n_cost = 0
        self.n_commit = 0

    cdef int cost(self, Candidate* c) noexcept nogil:
        self.n_cost += 1
        c.cost *= self.factor
        return KERNEL_OK

    cdef int commit(self, const Candidate* c) noexcept nogil:
        self.n_commit += 1
        return KERNEL_OK


cdef class CommitVeto(Kernel):
    """Wrongly answers KERNEL_VETO from commit(), which is a contract error."""
    api_version = KERNEL_API_VERSION

    cdef int commit(self, const Candidate* c) noexcept nogil:
        return KERNEL_VETO
