# cython: language_level=3
"""Half-edge arrays (Li et al.'s structure with `next` and `face` implicit).

Half-edge ``h`` belongs to face ``h // 3`` and runs from ``corner[h]`` (its origin, the
face's vertex ``h % 3``) to ``corner[next(h)]``.  ``twin[h]`` is the opposite half-edge
(-1 on a boundary), ``edge[h]`` the undirected edge id, ``edge_he[e]`` one live half-edge
of edge ``e``, ``v_he[v]`` one outgoing half-edge of ``v`` -- for a boundary vertex the
outgoing boundary half-edge, so that a 1-ring walk starting there sees the whole fan.
"""

cdef inline int he_next(int h) noexcept nogil:
    return h + 1 if h % 3 != 2 else h - 2

cdef inline int he_prev(int h) noexcept nogil:
    return h - 1 if h % 3 != 0 else h + 2


cdef struct HEArrays:
    # raw views of the HalfEdgeMesh arrays, for inlined access from other Cython modules
    int* corner
    int* twin
    int* edge
    int* edge_he
    int* v_he
    unsigned char* face_alive
    unsigned char* vertex_alive
    unsigned char* edge_alive

cdef inline int he_dest(const HEArrays* a, int h) noexcept nogil:
    return a.corner[he_next(h)]

cdef inline int he_ring_next(const HEArrays* a, int h) noexcept nogil:
    """Next outgoing half-edge around ``corner[h]`` (-1 past the last face of a fan)."""
    return a.twin[he_prev(h)]

cdef inline bint he_is_boundary(const HEArrays* a, int v) noexcept nogil:
    return a.twin[a.v_he[v]] < 0


cdef class HalfEdgeMesh:
    cdef HEArrays c
    cdef readonly int n_vertices          # vertex slots (input vertices + split copies)
    cdef readonly int n_faces             # face slots
    cdef readonly int n_edges             # edge slots
    cdef readonly int n_alive_faces
    cdef readonly int n_alive_vertices
    cdef readonly int n_split_vertices    # copies made to split non-manifold vertices
    cdef readonly int n_nonmanifold_edges  # edges cut because of >2 faces or clashing orientation
    cdef int[::1] corner
    cdef int[::1] twin
    cdef int[::1] edge
    cdef int[::1] edge_he
    cdef int[::1] v_he
    cdef int[::1] vertex_source           # vertex slot -> vertex of the input face array
    cdef bint has_copies                  # False: no split vertices, source(v) == v
    cdef unsigned char[::1] locked        # 1 for split / non-manifold-edge vertices
    cdef unsigned char[::1] face_alive
    cdef unsigned char[::1] vertex_alive
    cdef unsigned char[::1] edge_alive
    cdef int[::1] next_copy               # next slot with the same input vertex, -1 if none
    cdef int[::1] stamp                   # scratch marks (by input vertex) for the link condition
    cdef int stamp_counter

    cdef void _bind(self) noexcept
    cdef inline int source(self, int v) noexcept nogil
    cdef inline int dest(self, int h) noexcept nogil
    cdef inline int ring_next(self, int h) noexcept nogil
    cdef inline bint is_boundary(self, int v) noexcept nogil
    cdef int valence(self, int v) noexcept nogil
    cdef int find_fan_start(self, int h) noexcept nogil
    cdef int _mark_ring(self, int v) noexcept nogil
    cdef int _count_marked(self, int v, int su, int sv) noexcept nogil
    cdef bint _faces_would_coincide(self, int u, int v) noexcept nogil
    cdef bint link_ok(self, int h) noexcept nogil
    cdef int _link_expected(self, int h) noexcept nogil
    cdef bint _link_tail(self, int h, int common, int expected, int valence_u) noexcept nogil
    cdef int _count_common_local(self, int u, int v, int* valence_u) noexcept nogil
    cdef int collapse(self, int h, int removed, int* dead_edges, int* merged_into) noexcept nogil
    cdef int collapse_uncounted(self, int h, int removed, int* dead_edges, int* merged_into) noexcept nogil


# Vertex removal (the vertex-removal driver, vremove.pyx): replace the star of ``v`` -- its
# k link vertices ``link`` and its faces ``face`` (face[i] = (v, link[i], link[i+1]); k faces
# when ``closed``, k - 1 for a boundary vertex) -- by ``n_tris`` = k - 2 triangles ``tri``
# (link-index triples, oriented as the surface; see removal.pxd).  The caller has validated
# the triangulation.  The new triangles reuse old face slots: ``slot_of[t]`` is the slot of
# triangle t -- given by the caller (distinct slots of the old faces), or, when slot_of[0] is
# -1 on entry, chosen here (the slot of the old face whose outer link edge it inherits, else a
# leftover one) and written back.  The new diagonals (and an open star's new boundary edge) reuse dead spoke edge ids,
# twins and v_he are rewired, counts updated.  ``dead_edges`` receives the ids of the edges
# that die; returns their number.
cdef int replace_star(HalfEdgeMesh hm, int v, const int* link, const int* face, int k, bint closed,
                      const int* tri, int n_tris, int* slot_of, int* dead_edges) noexcept nogil


# A counting sort by runs (the set-up's sorts, the pass driver's grouping by block): each
# run of the items, in order, counted by key into its row cnt[run * stride:][:n_keys]
# becomes where that run's items of each key start (keys in order, runs in order within a
# key: stable for any number of runs).  Returns the total.
cdef int run_starts(int* cnt, int n_keys, int n_runs, Py_ssize_t stride) noexcept nogil
