# cython: language_level=3
"""The C-level interface of vertex-removal metrics, version 2 (public: plugins
``cimport lodkit.removal``).

The vertex-removal driver (``lodkit._core.vremove``) keeps one candidate per vertex in an
indexed heap.  For each vertex it fills a :c:type:`Star` (the vertex, its link in order and
its faces) and asks the metric's kernel to ``evaluate`` it: the kernel fills a
:c:type:`Removal` -- the re-triangulation of the hole as triangles over link indices, the
ranking cost and the geometric error -- or vetoes the removal.  The driver pops the
cheapest vertex, checks the triangulation (manifold kept, no flipped or sliver faces,
boundary policy, fixed vertices), replaces the star by it, calls ``commit`` and re-evaluates
every vertex of the old link.

Orientation: face ``i`` of the star is ``(v, link[i], link[i+1])`` (indices mod k for a
closed star), oriented as the mesh.  A closed star (interior vertex) has k faces and its
link is a cycle; an open star (boundary vertex) has k - 1 faces and its link is a chain from
``link[0]`` to ``link[k-1]``, both boundary neighbours.  The hole is the polygon
``link[0], link[1], ..., link[k-1]``; a triangle ``(i, j, l)`` with ``i < j < l`` (indices
into ``link``) is oriented as the surface.  A closed star's hole takes ``k - 2`` triangles,
an open star's ``k - 2`` as well (its new boundary edge is ``link[k-1] -> link[0]``).

The nogil methods return KERNEL_OK, KERNEL_VETO (keep the vertex until its star changes)
or KERNEL_ERROR (after ``self.fail(b"...")``), as for edge kernels (lodkit/kernel.pxd).

Optional hooks (both have defaults in ``RemovalKernel``; override what applies):

* ``star_local`` -- a class attribute (Python level, read once when the run is set up):
  True when ``evaluate`` depends on the star alone, not on state that changes elsewhere.
  The driver then keeps each candidate's triangulation and does not evaluate a popped
  vertex again.  Default False.  Per-vertex state that ``commit`` changes for the old
  link's vertices only is fine (the driver evaluates exactly those again right after the
  commit): ``volume`` and ``schroeder`` carry their accumulated bounds that way.
* ``veto_note(self)`` -- a ``cpdef str`` method, called with the GIL after the run when the
  kernel vetoed some vertices: why, in words (appended to the run's ``stop_detail``; e.g.
  volume's "12 hyperbolic ...").  Default ``""`` (nothing appended).

Versioning: ``REMOVAL_API_VERSION`` changes whenever this file changes in a way that breaks
compiled plugins (2: ``veto_note`` declared here); a kernel states the version it was built
for with ``api_version = REMOVAL_API_VERSION`` in its class body.  The old path
``lodkit._core.removal`` re-exports these names for one release (deprecated).

Driver details (lodkit/_core/vremove.pyx; docs/algorithms.md, "Vertex removal"):
* ``evaluate`` is called for every vertex at the start, for every vertex of the old link
  after a removal, again when a vertex is popped (a dearer answer is re-ranked; not for a
  ``star_local`` kernel: the driver keeps its triangles), and for all vertices when the
  heap runs dry.  Fixed vertices (``VERTEX_FIXED``) and stars with more than MAX_VALENCE
  link vertices are never handed to it.  Positions are the driver's:
  ``s.mesh.positions`` with ``s.mesh.stride`` (3).  ``Removal`` is not cleared between
  calls except n_tris, cost, error and gate (set to 0).
* The triangles must form an oriented triangulation of the k-gon (every link edge i -> i+1,
  with an open star's closing edge k-1 -> 0, used once in that direction; every other edge
  once each way), else the run fails with MetricError.  A removal the driver's checks
  refuse is not an error: the vertex waits until its star changes.
* ``commit(s, r)`` is called after the half-edge arrays were updated: ``s`` still holds the
  old star (``s.v`` is dead now, its face slots hold the new triangles or are dead).
* Gated kernels: the candidates whose gate is >= the (lower) median gate of all candidates
  compete; a candidate whose gate is NaN is outside the median and does not compete (veto a
  vertex to keep it out of both).
"""
from lodkit.kernel cimport KernelMesh

cdef enum:
    REMOVAL_API_VERSION = 2
    MAX_VALENCE = 64         # stars with more link vertices are not removed


cdef struct Star:
    const KernelMesh* mesh
    int v                    # the vertex to remove
    int k                    # number of link vertices
    int closed               # 1: interior vertex (link is a cycle); 0: boundary (a chain)
    int link[MAX_VALENCE]    # link vertex slots in order (see the orientation note above)
    int face[MAX_VALENCE]    # face slots: face[i] = (v, link[i], link[i+1])


cdef struct Removal:
    int n_tris                # k - 2
    int tri[3 * MAX_VALENCE]  # the hole's triangles, as indices into Star.link
    double cost               # ranking key (smallest first)
    double error              # geometric error in normalised units (max_error applies to it)
    # gated kernels: the value the median filter compares; NaN: not part of the median
    # (e.g. a hyperbolic vertex)
    double gate


cdef class RemovalKernel:
    # gated: True when only vertices whose gate >= the median gate of the live gated
    # vertices compete (Chuon-Guha)
    cdef readonly bint gated
    cdef readonly bint failed
    cdef char _message[256]

    cdef int evaluate(self, const Star* s, Removal* r) noexcept nogil
    cdef int commit(self, const Star* s, const Removal* r) noexcept nogil
    cdef int fail(self, const char* message) noexcept nogil
    # optional hook (see the module notes): why vetoed vertices were held back, in words
    cpdef str veto_note(self)
