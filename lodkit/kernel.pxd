# cython: language_level=3
"""The C-level metric interface, version 3 (public: plugin packages ``cimport lodkit.kernel``).

A native metric is a ``cdef class`` that subclasses :class:`Kernel` and overrides some of

    place(c)   choose where the kept vertex goes and which end stays     (nogil)
    cost(c)    set or change ``c.cost``; or refuse the collapse            (nogil)
    commit(c)  the collapse of ``c`` was done: update the kernel's state   (nogil)

plus the Python-level ``prepare(self, ctx, options)``, called once with the GIL before the
run to allocate and fill the kernel's arrays (``ctx`` is a
:class:`lodkit.metrics.MetricContext`).  The three nogil methods must not allocate,
raise nor touch Python objects.  They return

    KERNEL_OK    (0)   go on
    KERNEL_VETO  (1)   this collapse may not happen now (the candidate is dropped until
                       one of its ends changes; ``commit`` never vetoes)
    KERNEL_ERROR (-1)  something is wrong: call ``self.fail(b"what")`` and return its value;
                       the run stops and lodkit raises ``MetricError`` with the message

Positions are the normalised ones the core works on (bbox centred at the origin, unit
diagonal); ``ctx.scale`` and ``ctx.center`` map back.  Vertices are vertex *slots* of the
half-edge arrays (``ctx.input_vertex[slot]`` is the input vertex).

A kernel whose cost of edge (a, b) depends on the stars of a and b (not only on the two
ends, as a quadric's does) sets ``self.wide = True`` in ``__cinit__`` or ``prepare``: after
each collapse the driver then re-ranks the edges around every neighbour of the kept vertex,
not only the edges at the kept vertex.  If it knows better, its ``commit`` points
``self.changed`` at ``self.n_changed`` vertex slots (memory the kernel owns) whose edges are
to be re-ranked, besides the kept vertex's; ``n_changed = -1`` (the default) means all
the kept vertex's neighbours.

Combined metrics: the driver holds the kernels of a combined metric in order and calls each
in turn (``place`` of every placing kernel, then ``cost`` of each, ``commit`` of each); a
kernel knows nothing of the others.

Versioning: ``KERNEL_API_VERSION`` changes whenever this file changes in a way that breaks
compiled plugins (3: ``Kernel`` no longer carries the driver's link to the next kernel).  A
kernel class states the version it was compiled against by setting
``api_version = KERNEL_API_VERSION`` in its class body; lodkit refuses a kernel whose
version differs, with a message telling the author to rebuild.  (Cython's own check of the
base type's size at import catches a layout change as well.)

The old path ``lodkit._core.kernel`` re-exports these names for one release (deprecated).
"""
from lodkit._core.halfedge cimport HEArrays, he_next, he_prev, he_dest, he_ring_next, he_is_boundary

cdef enum:
    KERNEL_API_VERSION = 3
    KERNEL_OK = 0
    KERNEL_VETO = 1
    KERNEL_ERROR = -1
    KERNEL_MESSAGE_SIZE = 256

# bits of KernelMesh.flags[v]
cdef enum:
    VERTEX_FIXED = 1        # may not move nor be removed (locked, split, or 'lock' boundary)
    VERTEX_BOUNDARY = 2     # on a boundary loop


cdef struct KernelMesh:
    const HEArrays* he          # live half-edge arrays (see halfedge.pxd for navigation)
    const double* positions     # position of vertex v at positions[stride * v + 0..2]
    int stride
    const unsigned char* flags  # VERTEX_FIXED | VERTEX_BOUNDARY bits per vertex slot
    int n_vertices
    int n_faces


cdef struct Candidate:
    const KernelMesh* mesh
    int edge            # edge id
    int h               # a half-edge of the edge, running u -> v
    int u
    int v
    int removed         # the end that goes ...
    int kept            # ... and the end that stays (and moves to p)
    double p[3]         # new position of ``kept``
    double cost         # the cost so far (quadrics, then fields, then earlier kernels)
    double error        # geometric error of the collapse (read-only for kernels)


cdef inline const double* vertex_position(const KernelMesh* m, int v) noexcept nogil:
    return &m.positions[m.stride * v]


cdef inline void fill_candidate(Candidate* c, const KernelMesh* mesh, int edge, int h, int u, int v,
                                int removed, int kept, const double* p, double cost,
                                double error) noexcept nogil:
    c.mesh = mesh
    c.edge = edge
    c.h = h
    c.u = u
    c.v = v
    c.removed = removed
    c.kept = kept
    c.p[0] = p[0]
    c.p[1] = p[1]
    c.p[2] = p[2]
    c.cost = cost
    c.error = error


cdef class Kernel:
    # places: True makes the driver call place()
    cdef readonly bint places
    # wide: True when a collapse changes the cost of every edge around the kept vertex's
    # neighbours (the driver re-ranks the 2-ring)
    cdef readonly bint wide
    # wide kernels, set by commit(): the n_changed vertices whose edges to re-rank (besides
    # the kept one's); n_changed = -1: all the kept vertex's neighbours
    cdef const int* changed
    cdef int n_changed
    cdef readonly bint failed
    cdef char _message[KERNEL_MESSAGE_SIZE]

    cdef int place(self, Candidate* c) noexcept nogil
    cdef int cost(self, Candidate* c) noexcept nogil
    cdef int commit(self, const Candidate* c) noexcept nogil
    cdef int fail(self, const char* message) noexcept nogil
