# cython: language_level=3
"""Kernels written against lodkit 0.1.0's cimport paths (``lodkit._core.kernel`` and
``lodkit._core.removal``, deprecated for one release): the tests build this module to
check that a plugin on the old path still builds and runs (tests/test_native_build.py).

OldPathScaleBy  the test kernel ScaleBy (cost *= factor)
OldPathMaxEdge  the lodkit-max-edge plugin's kernel (uses the half-edge navigation inlines)
OldPathFan      a removal kernel: cost = vertex slot, the fan from link[0]
"""
from lodkit._core.kernel cimport (Kernel, Candidate, KernelMesh, HEArrays, vertex_position,
                                  he_prev, he_dest, he_ring_next,
                                  KERNEL_OK, KERNEL_VETO, KERNEL_API_VERSION)
from lodkit._core.removal cimport RemovalKernel, Star, Removal, REMOVAL_API_VERSION
from lodkit._core.retriangulate cimport fan_from


cdef class OldPathScaleBy(Kernel):
    api_version = KERNEL_API_VERSION
    cdef double factor

    def prepare(self, ctx, options):
        self.factor = float(options.get("factor", 1.0))

    cdef int cost(self, Candidate* c) noexcept nogil:
        c.cost *= self.factor
        return KERNEL_OK


cdef class OldPathFan(RemovalKernel):
    api_version = REMOVAL_API_VERSION

    cdef int evaluate(self, const Star* s, Removal* r) noexcept nogil:
        r.cost = s.v
        r.error = 0.0
        r.n_tris = fan_from(0, s.k, r.tri) if s.k >= 3 else 0
        return KERNEL_OK


cdef inline double dist2(const double* a, const double* b) noexcept nogil:
    cdef double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2]
    return dx * dx + dy * dy + dz * dz


cdef class OldPathMaxEdge(Kernel):
    """Vetoes a collapse that would make an edge longer than ``max_length``; otherwise
    scales the cost so far by ``1 + weight * (longest new edge / max_length)**2``."""

    api_version = KERNEL_API_VERSION

    cdef readonly double max_length
    cdef readonly double weight
    cdef double max_length2

    def prepare(self, ctx, options):
        self.max_length = float(options["max_length"])
        self.weight = float(options["weight"])
        self.max_length2 = self.max_length * self.max_length

    cdef int ring_max2(self, const KernelMesh* m, int center, int other, const double* p,
                       double* out) noexcept nogil:
        """out = max(out, squared distance from p to each 1-ring neighbour of ``center``
        other than ``other``).  Returns -1 if the walk does not close (broken arrays)."""
        cdef const HEArrays* a = m.he
        cdef int start = a.v_he[center]
        cdef int y = start, ny, w, steps = 0
        cdef double d
        if start < 0:
            return 0                  # no faces around it: no edges
        while True:
            w = he_dest(a, y)
            if w != other:
                d = dist2(p, vertex_position(m, w))
                if d > out[0]:
                    out[0] = d
            ny = he_ring_next(a, y)
            if ny < 0:
                # past the last face of a boundary fan: its last neighbour is the origin of
                # that face's previous half-edge (it has no outgoing half-edge of its own here)
                w = a.corner[he_prev(y)]
                if w != other:
                    d = dist2(p, vertex_position(m, w))
                    if d > out[0]:
                        out[0] = d
                return 0
            if ny == start:
                return 0
            y = ny
            steps += 1
            if steps > 3 * m.n_faces:
                return -1

    cdef int cost(self, Candidate* c) noexcept nogil:
        cdef double longest2 = 0.0
        if c.mesh == NULL:
            return KERNEL_OK          # a bare candidate (Kernel._call): no mesh to look at
        # after the collapse the kept vertex, at p, is joined to the 1-ring of both ends
        if (self.ring_max2(c.mesh, c.u, c.v, c.p, &longest2) < 0
                or self.ring_max2(c.mesh, c.v, c.u, c.p, &longest2) < 0):
            return self.fail(b"max_edge_length: a 1-ring walk did not close")
        if longest2 > self.max_length2:
            return KERNEL_VETO
        c.cost += self.weight * (longest2 / self.max_length2) * c.cost
        return KERNEL_OK
