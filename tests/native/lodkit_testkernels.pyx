# cython: language_level=3
"""Small native kernels for tests and examples of the kernel interface (not metrics a user
would pick; they are not registered).

VetoAll        refuses every collapse
FailAfter      reports an error from nogil code after ``n`` cost calls
MidpointPlacer places the kept vertex at the edge midpoint (a kernel that ``places``)
ScaleBy        multiplies the cost so far by ``factor`` and counts its calls
"""
from lodkit.kernel cimport Kernel, Candidate, vertex_position, KERNEL_OK, KERNEL_VETO, KERNEL_API_VERSION


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


# ---- vertex-removal test kernels (removal.pxd) -----------------------------------------
from lodkit.removal cimport RemovalKernel, Star, Removal
from lodkit._core.retriangulate cimport fan_from, closest_line_apex
from lodkit._core.vec3 cimport sub3, cross3, norm3
from libc.math cimport sqrt, fabs


cdef class PlaneFan(RemovalKernel):
    """A vertex-removal kernel for tests and as the simplest example: cost = error = the
    distance from the vertex to the average plane of its star (normal: the area-weighted
    sum of its face normals; point: the area-weighted mean of its face centroids) -- for a
    boundary vertex, to the line of the new boundary edge link[0]-link[k-1] -- the hole
    filled by the fan from the closest-line apex (``closest_line_apex``).

    Options: ``gate`` ((n,) floats, NaN allowed: makes the kernel gated, each vertex's gate
    its entry), ``fail_after`` (report an error after that many evaluations; -1 never),
    ``veto`` ((n,) bools: vertices it refuses), ``invalid`` (True: answer triangles that are
    no triangulation of the hole -- a contract error), ``n_tris`` (>= 0: claim that many
    triangles, however many there are -- a contract error).  Counts ``n_evaluate`` and
    ``n_commit``."""

    cdef double[::1] gates
    cdef unsigned char[::1] vetoes
    cdef bint has_veto
    cdef bint invalid
    cdef bint has_claim
    cdef int claim_tris
    cdef long fail_after
    cdef readonly long n_evaluate
    cdef readonly long n_commit

    def prepare(self, ctx, options):
        import numpy as np

        n = ctx.n_vertices if ctx is not None else 0
        g = options.get("gate")
        self.gated = g is not None
        self.gates = np.ascontiguousarray(g, dtype=np.float64) if g is not None else np.zeros(1)
        if g is not None and self.gates.shape[0] < n:
            raise ValueError(f"gate must have {n} entries")
        vt = options.get("veto")
        self.has_veto = vt is not None
        self.vetoes = np.ascontiguousarray(vt, dtype=np.uint8) if vt is not None else np.zeros(1, dtype=np.uint8)
        self.fail_after = int(options.get("fail_after", -1))
        self.invalid = bool(options.get("invalid", False))
        self.claim_tris = int(options.get("n_tris", -1))
        self.has_claim = self.claim_tris >= 0
        self.n_evaluate = 0
        self.n_commit = 0

    cdef int evaluate(self, const Star* s, Removal* r) noexcept nogil:
        cdef const double* P = s.mesh.positions
        cdef int st = s.mesh.stride
        cdef int nf = s.k if s.closed else s.k - 1
        cdef int i, j, apex
        cdef double nrm[3]
        cdef double cen[3]
        cdef double e1[3]
        cdef double e2[3]
        cdef double f[3]
        cdef double area, total = 0.0, ln, d
        cdef const double* pv = &P[st * s.v]
        cdef const double* a
        cdef const double* b
        self.n_evaluate += 1
        if self.fail_after >= 0 and self.n_evaluate > self.fail_after:
            return self.fail(b"PlaneFan: the evaluation budget is spent")
        if self.has_veto and self.vetoes[s.v]:
            return KERNEL_VETO
        for j in range(3):
            nrm[j] = 0.0
            cen[j] = 0.0
        for i in range(nf):
            a = &P[st * s.link[i]]
            b = &P[st * s.link[(i + 1) % s.k]]
            sub3(a, pv, e1)
            sub3(b, pv, e2)
            cross3(e1, e2, f)
            area = norm3(f)
            total += area
            for j in range(3):
                nrm[j] += f[j]
                cen[j] += area * (pv[j] + a[j] + b[j]) / 3.0
        ln = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2])
        if ln > 0.0 and total > 0.0:
            d = 0.0
            for j in range(3):
                d += (pv[j] - cen[j] / total) * nrm[j] / ln
            d = fabs(d)
        else:
            d = 0.0
        if not s.closed:
            # a boundary vertex: the distance to the new boundary edge's line (Schroeder)
            a = &P[st * s.link[0]]
            b = &P[st * s.link[s.k - 1]]
            sub3(b, a, e1)
            sub3(pv, a, e2)
            cross3(e1, e2, f)
            ln = norm3(e1)
            if ln > 0.0:
                d = norm3(f) / ln
            else:
                d = norm3(e2)
        r.cost = d
        r.error = d
        r.gate = self.gates[s.v] if self.gated else 0.0
        if s.k < 3:
            r.n_tris = 0
            return KERNEL_OK
        apex = closest_line_apex(P, st, s.link, s.k, pv)
        r.n_tris = fan_from(apex, s.k, r.tri)
        if self.invalid:
            r.tri[0] = r.tri[1]
        if self.has_claim:
            r.n_tris = self.claim_tris
        return KERNEL_OK

    cdef int commit(self, const Star* s, const Removal* r) noexcept nogil:
        self.n_commit += 1
        return KERNEL_OK
