"""Half-edge arrays: exact structure on hand-made meshes, non-manifold repair, the link
condition, edge collapse, and property tests against slow pure-Python references.

Conventions of ``lodkit._core.halfedge`` used here: half-edge ``h`` lies in face ``h // 3``
and runs from ``corners[h // 3][h % 3]`` to the next corner of that face; ``twins[h]`` is -1
on a boundary; ``collapse_edge(u, v)`` removes ``u`` and keeps ``v``.
"""
from __future__ import annotations

from collections import defaultdict

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

import lodkit
from conftest import shared_mesh
from lodkit._core.halfedge import build

# ---------------------------------------------------------------------- meshes
TRIANGLE = [[0, 1, 2]]

#   3 ----- 2
#   |     / |        two triangles sharing the edge 0-2
#   |   /   |
#   | /     |
#   0 ----- 1
TWO_TRIANGLES = [[0, 1, 2], [0, 2, 3]]

TETRAHEDRON = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]

#        4 --- 3
#       / \   / \
#      5 - 6 --- 2       six triangles [6, i, i+1] around the centre 6
#       \ / \   /
#        0 --- 1
HEXAGON = [[6, i, (i + 1) % 6] for i in range(6)]


def grid_faces(nx: int, ny: int, diagonals=None) -> np.ndarray:
    """(2 nx ny, 3) faces of an nx x ny grid of quads over vertices j * (nx + 1) + i,
    counter-clockwise seen from +z.  ``diagonals[j, i]`` True splits quad (i, j) along
    a-c (lower left to upper right), False along b-d; default: all a-c."""
    faces = []
    for j in range(ny):
        for i in range(nx):
            a = j * (nx + 1) + i
            b, c, d = a + 1, a + nx + 2, a + nx + 1
            if diagonals is None or diagonals[j][i]:
                faces += [[a, b, c], [a, c, d]]
            else:
                faces += [[a, b, d], [b, c, d]]
    return np.array(faces, dtype=np.int64).reshape(-1, 3)


def compact(faces: np.ndarray) -> tuple[np.ndarray, int]:
    """Renumber the vertices so that every one is used (as lodkit.api.prepare does)."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    used = np.unique(faces)
    remap = np.full(int(used.max()) + 1, -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    return remap[faces], int(used.size)


def undirected_edges(faces) -> set:
    faces = np.asarray(faces)
    return {tuple(sorted((int(f[k]), int(f[(k + 1) % 3])))) for f in faces for k in range(3)}


def is_rotation(seq, ref) -> bool:
    seq, ref = list(seq), list(ref)
    return len(seq) == len(ref) and any(seq == ref[i:] + ref[:i] for i in range(len(ref)))


# ---------------------------------------------------------------------- references
def component_invariants(faces, n: int, twins=None) -> list:
    """Sorted list of (Euler characteristic, number of boundary loops), one per component.

    ``faces`` (k, 3): the live faces; ``twins`` (3k,): the twin flag of each of their
    half-edges (>= 0: interior) or None to pair half-edges by their end vertices.
    Components join faces through shared vertices; an edge is a twin pair or a boundary
    half-edge (so parallel edges between the same two vertices, left by cutting a
    non-manifold edge, count separately); a boundary loop is a connected set of boundary
    edges."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if faces.shape[0] == 0:
        return []
    tails = faces.reshape(-1)
    heads = faces[:, [1, 2, 0]].reshape(-1)
    if twins is None:
        key = np.minimum(tails, heads) * n + np.maximum(tails, heads)
        _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
        interior = counts[inverse.reshape(-1)] == 2
    else:
        interior = np.asarray(twins) >= 0
    graph = coo_matrix((np.ones(tails.size), (tails, heads)), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    used = np.zeros(n, dtype=bool)
    used[tails] = True
    border = ~interior
    bgraph = coo_matrix((np.ones(int(border.sum())), (tails[border], heads[border])), shape=(n, n))
    _, blabel = connected_components(bgraph, directed=False)
    bverts = np.unique(tails[border])
    out = []
    for c in np.unique(label[used]):
        in_c = label[tails] == c
        n_v = int(np.count_nonzero(used & (label == c)))
        n_h = int(np.count_nonzero(in_c))
        n_b = int(np.count_nonzero(in_c & border))
        n_e = (n_h + n_b) // 2            # two half-edges per interior edge, one per border edge
        n_f = n_h // 3
        n_loops = int(np.unique(blabel[bverts[label[bverts] == c]]).size)
        out.append((n_v - n_e + n_f, n_loops))
    return sorted(out)


def structure_invariants(hm) -> list:
    alive = hm.alive_faces
    twins = hm.twins.reshape(-1, 3)[alive].reshape(-1)
    return component_invariants(hm.corners[alive], hm.n_vertices, twins)


class FanReference:
    """What build() must do to a face soup, computed the slow way.

    An edge is kept (its two half-edges become twins) iff exactly two faces use it and they
    run it in opposite directions; every other edge used more than once is cut.  Corners of
    one vertex joined across kept edges form a fan; a vertex gets one slot per fan.  The
    ends of cut edges and vertices with several fans are locked."""

    def __init__(self, faces):
        faces = [tuple(int(x) for x in f) for f in faces]
        groups = defaultdict(list)
        for f, tri in enumerate(faces):
            for k in range(3):
                a, b = tri[k], tri[(k + 1) % 3]
                groups[frozenset((a, b))].append((a, b, f))
        parent = {}

        def find(x):
            while parent.setdefault(x, x) != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        self.n_cut_edges = 0
        self.n_twin_pairs = 0
        self.locked = set()
        for key, hs in groups.items():
            if len(hs) == 2 and hs[0][0] == hs[1][1]:
                self.n_twin_pairs += 1
                (a, b, f1), (_, _, f2) = hs
                parent[find((f1, a))] = find((f2, a))
                parent[find((f1, b))] = find((f2, b))
            elif len(hs) > 1:
                self.n_cut_edges += 1
                self.locked |= set(key)
        fans = defaultdict(set)
        for f, tri in enumerate(faces):
            for v in tri:
                fans[v].add(find((f, v)))
        self.fans = {v: len(s) for v, s in fans.items()}
        self.n_split = sum(k - 1 for k in self.fans.values())
        self.locked |= {v for v, k in self.fans.items() if k > 1}


def assert_matches_reference(faces, n: int):
    """build(faces) == FanReference(faces), and the structure is valid."""
    hm = build(np.asarray(faces, dtype=np.int32), n)
    ref = FanReference(faces)
    assert hm.check() is True
    assert hm.n_nonmanifold_edges == ref.n_cut_edges
    assert hm.n_split_vertices == ref.n_split
    assert hm.n_vertices == n + ref.n_split
    assert int(np.count_nonzero(hm.twins >= 0)) == 2 * ref.n_twin_pairs
    src = hm.vertex_sources
    # no face lost or changed: the slots map back onto the input faces, in order
    np.testing.assert_array_equal(src[hm.faces()], np.asarray(faces))
    assert np.array_equal(src[:n], np.arange(n))
    # one slot per fan
    assert np.array_equal(np.bincount(src, minlength=n), [ref.fans[v] for v in range(n)])
    assert set(src[hm.locked_vertices].tolist()) == ref.locked
    assert hm.locked_vertices.sum() == sum(ref.fans[v] for v in ref.locked)
    # edges numbered in (smaller end, larger end) order of the input vertices, the
    # half-edges of one group (a non-manifold edge cut apart) in id order
    corners = src[hm.corners.reshape(-1)]
    nxt = src[hm.corners[:, [1, 2, 0]].reshape(-1)]
    key = np.lexsort((np.arange(corners.size), np.maximum(corners, nxt), np.minimum(corners, nxt)))
    edge_seq = hm.edges[key]
    assert np.array_equal(np.unique(edge_seq), np.arange(hm.n_edges))
    assert (np.diff(edge_seq) >= 0).all()
    # each edge's stored half-edge is its later one
    assert np.array_equal(hm.edge_halfedges, [np.flatnonzero(hm.edges == e).max() for e in range(hm.n_edges)])
    # the same arrays on any number of threads
    for threads in (2, 4):
        other = build(np.asarray(faces, dtype=np.int32), n, threads)
        for name in ("corners", "twins", "edges", "edge_halfedges", "vertex_halfedges", "vertex_sources",
                     "locked_vertices"):
            assert np.array_equal(getattr(hm, name), getattr(other, name)), name
    return hm


# ---------------------------------------------------------------------- exact structures
def test_build_copies_the_faces_unless_handed_them():
    # prepare() hands over the face array it made (no copy); a caller's array is only read,
    # even when a non-manifold vertex is split (the corners change)
    faces = np.array([[0, 1, 2], [0, 3, 4]], dtype=np.int32)        # two fans at vertex 0
    kept = faces.copy()
    hm = build(faces, 5)
    assert hm.n_split_vertices == 1 and np.array_equal(faces, kept)
    taken = build(faces, 5, 1, True)
    assert np.shares_memory(taken.corners, faces)
    assert np.array_equal(taken.corners, hm.corners) and np.array_equal(taken.twins, hm.twins)
    frozen = kept.copy()
    frozen.flags.writeable = False
    assert not np.shares_memory(build(frozen, 5, 1, True).corners, frozen)


def test_single_triangle():
    hm = build(np.array(TRIANGLE), 3)
    assert hm.check()
    assert (hm.n_vertices, hm.n_faces, hm.n_edges) == (3, 1, 3)
    assert hm.twins.tolist() == [-1, -1, -1]
    assert sorted(hm.edges.tolist()) == [0, 1, 2]
    assert hm.vertex_halfedges.tolist() == [0, 1, 2]     # h = v starts at v
    assert all(hm.vertex_is_boundary(v) for v in range(3))
    assert [hm.neighbors(v) for v in range(3)] == [[1, 2], [2, 0], [0, 1]]
    assert (hm.n_nonmanifold_edges, hm.n_split_vertices) == (0, 0)
    assert not hm.locked_vertices.any()


def test_two_triangles_share_one_twin_pair():
    hm = build(np.array(TWO_TRIANGLES), 4)
    assert hm.check()
    # half-edge 2 (2 -> 0) and half-edge 3 (0 -> 2) are the only twins
    assert hm.twins.tolist() == [-1, -1, 3, 2, -1, -1]
    assert hm.n_edges == 5
    assert hm.edges[2] == hm.edges[3]
    assert len(set(hm.edges.tolist())) == 5
    assert all(hm.vertex_is_boundary(v) for v in range(4))
    # boundary fans start at the outgoing boundary half-edge
    assert hm.neighbors(0) == [1, 2, 3]
    assert hm.neighbors(2) == [3, 0, 1]
    assert hm.neighbors(1) == [2, 0]
    assert hm.neighbors(3) == [0, 2]


def test_tetrahedron_is_closed():
    hm = build(np.array(TETRAHEDRON), 4)
    assert hm.check()
    twins = hm.twins
    assert (twins >= 0).all()
    assert np.array_equal(twins[twins], np.arange(12))
    corners = hm.corners.reshape(-1)
    nxt = np.arange(12) - np.arange(12) % 3 + (np.arange(12) + 1) % 3
    assert np.array_equal(corners[twins], corners[nxt])        # twins run the other way
    assert hm.n_edges == 6
    assert not any(hm.vertex_is_boundary(v) for v in range(4))
    for v in range(4):
        assert sorted(hm.neighbors(v)) == sorted(set(range(4)) - {v})


def test_hexagon_fan():
    hm = build(np.array(HEXAGON), 7)
    assert hm.check()
    assert hm.n_edges == 12
    assert int(np.count_nonzero(hm.twins >= 0)) == 12            # six interior edges
    assert not hm.vertex_is_boundary(6)
    assert is_rotation(hm.neighbors(6), [0, 1, 2, 3, 4, 5])      # counter-clockwise fan order
    for i in range(6):
        assert hm.vertex_is_boundary(i)
        # from the border edge i -> i+1, round the centre, to the border edge i-1 -> i
        assert hm.neighbors(i) == [(i + 1) % 6, 6, (i - 1) % 6]


@pytest.mark.parametrize("nx, ny", [(1, 1), (3, 2), (5, 5)])
def test_grid_counts(nx, ny):
    faces = grid_faces(nx, ny)
    n = (nx + 1) * (ny + 1)
    hm = build(faces, n)
    assert hm.check()
    n_edges = nx * (ny + 1) + ny * (nx + 1) + nx * ny
    n_border = 2 * (nx + ny)
    assert hm.n_edges == n_edges
    assert int(np.count_nonzero(hm.twins < 0)) == n_border
    border = {j * (nx + 1) + i for j in range(ny + 1) for i in range(nx + 1)
              if i in (0, nx) or j in (0, ny)}
    assert {v for v in range(n) if hm.vertex_is_boundary(v)} == border
    for v in range(n):
        i, j = v % (nx + 1), v // (nx + 1)
        expected = {(i + di) + (j + dj) * (nx + 1)
                    for di, dj in [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, -1)]
                    if 0 <= i + di <= nx and 0 <= j + dj <= ny}
        assert set(hm.neighbors(v)) == expected
        assert len(hm.neighbors(v)) == len(expected)


def test_index_out_of_range_raises():
    with pytest.raises(ValueError, match="outside 0..2"):
        build(np.array([[0, 1, 3]]), 3)
    with pytest.raises(ValueError, match="outside"):
        build(np.array([[0, -1, 2]]), 3)


def test_unreferenced_vertex_is_not_a_live_vertex():
    """A vertex no face uses has no outgoing half-edge: it must not be a live vertex (or
    build must refuse it).  Vertex 0 here is unused."""
    try:
        hm = build(np.array([[1, 2, 3]]), 4)
    except ValueError as exc:
        assert "0" in str(exc)
        return
    assert not hm.alive_vertices[0]
    assert hm.n_alive_vertices == 3
    assert hm.check()
    with pytest.raises(ValueError):
        hm.neighbors(0)


# ---------------------------------------------------------------------- non-manifold input
def test_three_triangles_on_one_edge():
    faces = [[0, 1, 2], [1, 0, 3], [0, 1, 4]]
    hm = assert_matches_reference(faces, 5)
    assert hm.n_nonmanifold_edges == 1
    assert (hm.twins == -1).all()              # the shared edge is cut into three borders
    assert hm.n_split_vertices == 4            # 0 and 1 now have three fans each
    src = hm.vertex_sources
    assert sorted(src[5:].tolist()) == [0, 0, 1, 1]
    assert hm.locked_vertices.tolist() == [src[v] in (0, 1) for v in range(hm.n_vertices)]


def test_two_triangles_sharing_only_a_vertex():
    hm = assert_matches_reference([[0, 1, 2], [0, 3, 4]], 5)
    assert hm.n_nonmanifold_edges == 0
    assert hm.n_split_vertices == 1
    assert hm.vertex_sources.tolist() == [0, 1, 2, 3, 4, 0]
    assert hm.locked_vertices.tolist() == [True, False, False, False, False, True]
    assert hm.faces().tolist() == [[0, 1, 2], [5, 3, 4]]


def test_two_tetrahedra_sharing_a_vertex():
    second = (np.array(TETRAHEDRON) + 3).tolist()                 # vertices 3..6; 3 shared
    faces = TETRAHEDRON + second
    hm = assert_matches_reference(faces, 7)
    assert hm.n_split_vertices == 1
    assert hm.vertex_sources[7] == 3
    assert np.flatnonzero(hm.locked_vertices).tolist() == [3, 7]
    assert (hm.twins >= 0).all()                                 # both stay closed
    for v in range(hm.n_vertices):
        assert not hm.vertex_is_boundary(v)


def test_flipped_face_edge_is_cut():
    # the second face runs 0 -> 1 like the first: orientations clash on edge 0-1
    hm = assert_matches_reference([[0, 1, 2], [0, 1, 3]], 4)
    assert hm.n_nonmanifold_edges == 1
    assert (hm.twins == -1).all()
    assert hm.n_split_vertices == 2


def test_flipped_face_in_a_fan():
    faces = [list(f) for f in HEXAGON]
    faces[0] = [6, 1, 0]                          # flipped: clashes on 6-0 and 6-1
    hm = assert_matches_reference(faces, 7)
    assert hm.n_nonmanifold_edges == 2
    assert hm.n_split_vertices == 3               # 6, 0 and 1 each get a second slot
    assert set(hm.vertex_sources[7:].tolist()) == {0, 1, 6}
    assert int(np.count_nonzero(hm.twins >= 0)) == 8   # edges 6-2 .. 6-5 stay glued


def test_duplicate_faces_are_cut_apart():
    hm = assert_matches_reference([[0, 1, 2], [0, 1, 2]], 3)
    assert hm.n_nonmanifold_edges == 3
    assert hm.n_split_vertices == 3
    assert hm.locked_vertices.all()
    # two faces, opposite orientation: a closed two-sided "pillow", a valid manifold
    hm = assert_matches_reference([[0, 1, 2], [2, 1, 0]], 3)
    assert hm.n_nonmanifold_edges == 0 and (hm.twins >= 0).all()


def test_duplicate_face_inside_a_grid():
    faces = grid_faces(3, 3)
    faces = np.vstack([faces, faces[8:9]])        # face 8 (interior) stored twice
    hm = assert_matches_reference(faces, 16)
    assert hm.n_nonmanifold_edges == 3


# ---------------------------------------------------------------------- link condition
def test_link_condition_tetrahedron():
    hm = build(np.array(TETRAHEDRON), 4)
    assert not any(hm.can_collapse(a, b) for a in range(4) for b in range(4) if a != b)
    with pytest.raises(ValueError, match="topology"):
        hm.collapse_edge(0, 1)
    assert hm.check() and hm.n_alive_faces == 4


def test_link_condition_isolated_triangle():
    hm = build(np.array(TRIANGLE), 3)
    assert not any(hm.can_collapse(a, b) for a in range(3) for b in range(3) if a != b)


def test_link_condition_interior_edge_between_border_vertices():
    #  6 --- 7 --- 8
    #  |   / |   / |     2 x 2 quads, diagonals a-c.  Edge 1-5 is interior (faces
    #  | /   | /   |     [1, 2, 5] and [1, 5, 4]) but both ends are on the border:
    #  3 --- 4 --- 5     collapsing it would pinch the disc into two.
    #  |   / |   / |
    #  | /   | /   |
    #  0 --- 1 --- 2
    hm = build(grid_faces(2, 2), 9)
    assert not hm.can_collapse(1, 5) and not hm.can_collapse(5, 1)
    assert not hm.can_collapse(3, 7) and not hm.can_collapse(7, 3)
    assert hm.can_collapse(0, 4) and hm.can_collapse(4, 0)   # border - interior: fine
    assert hm.can_collapse(0, 1)                             # border edge with one common neighbour
    assert not hm.can_collapse(0, 8)                         # not an edge


def test_link_condition_two_quad_strip():
    # 3 --- 4 --- 5
    # | \   | \   |     every interior edge joins two border vertices
    # 0 --- 1 --- 2
    hm = build(grid_faces(2, 1, diagonals=[[False, False]]), 6)
    assert hm.faces().tolist() == [[0, 1, 3], [1, 4, 3], [1, 2, 4], [2, 5, 4]]
    for a, b in [(1, 3), (1, 4), (2, 4)]:
        assert not hm.can_collapse(a, b) and not hm.can_collapse(b, a)
    assert hm.can_collapse(0, 1) and hm.can_collapse(4, 5)      # border edges may go


def test_link_condition_big_grid():
    nx = 6
    hm = build(grid_faces(nx, nx), (nx + 1) ** 2)
    c = 3 * (nx + 1) + 3                                    # centre vertex (3, 3)
    for w in (c + 1, c - 1, c + nx + 1, c - nx - 1, c + nx + 2, c - nx - 2):
        assert hm.can_collapse(c, w) and hm.can_collapse(w, c)
    assert hm.can_collapse(1, 2)                            # border edge


def test_link_condition_hole_of_three_edges():
    # a 4x4 grid with one interior face missing: the hole's border is a triangle; collapsing
    # one of its edges would close the hole into a doubled edge
    faces = grid_faces(4, 4)
    hole = 12                                               # face [a, b, c] of quad (2, 1)
    a, b, c = faces[hole]
    faces = np.delete(faces, hole, axis=0)
    hm = build(faces, 25)
    assert hm.check()
    for u, v in [(a, b), (b, c), (c, a)]:
        assert not hm.can_collapse(int(u), int(v)) and not hm.can_collapse(int(v), int(u))


def test_link_condition_parallel_edges():
    """Faces 0 and 2 are glued along 1-2 and 2-0 into a two-sided disc; edge 0-1 has three
    faces, so it is cut, leaving two *parallel* border edges 0-1 (one per face).  Collapsing
    either would fold the other into a loop edge 1-1 (face [1, 2, 1]): the link condition
    must refuse it."""
    faces = [[0, 1, 2], [0, 1, 3], [0, 2, 1]]
    hm = assert_matches_reference(faces, 4)
    assert hm.faces().tolist() == [[0, 1, 2], [4, 5, 3], [0, 2, 1]]
    assert not hm.can_collapse(0, 1)
    assert not hm.can_collapse(1, 0)
    with pytest.raises(ValueError, match="topology"):
        hm.collapse_edge(0, 1)
    assert hm.check()


# ---------------------------------------------------------------------- collapse
def test_collapse_border_vertex_into_centre():
    hm = build(np.array(HEXAGON), 7)
    assert hm.collapse_edge(0, 6) == 6
    assert hm.check()
    assert hm.faces().tolist() == [[6, 1, 2], [6, 2, 3], [6, 3, 4], [6, 4, 5]]
    assert hm.vertex_is_boundary(6)
    assert hm.neighbors(6) == [1, 2, 3, 4, 5]
    assert (hm.n_alive_faces, hm.n_alive_vertices) == (4, 6)
    assert hm.alive_vertices.tolist() == [False] + [True] * 6
    assert int(hm.alive_edges.sum()) == 9
    with pytest.raises(ValueError, match="not a live vertex"):
        hm.neighbors(0)


def test_collapse_centre_into_border_vertex():
    hm = build(np.array(HEXAGON), 7)
    hm.collapse_edge(6, 0)
    assert hm.check()
    assert hm.faces().tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]
    assert hm.neighbors(0) == [1, 2, 3, 4, 5]


def test_collapse_border_edge():
    hm = build(np.array(HEXAGON), 7)
    hm.collapse_edge(0, 1)
    assert hm.check()
    assert hm.faces().tolist() == [[6, 1, 2], [6, 2, 3], [6, 3, 4], [6, 4, 5], [6, 5, 1]]
    assert not hm.vertex_is_boundary(6)
    assert is_rotation(hm.neighbors(6), [1, 2, 3, 4, 5])
    assert hm.neighbors(1) == [2, 6, 5]


def test_collapse_errors():
    hm = build(np.array(HEXAGON), 7)
    with pytest.raises(ValueError, match="not an edge"):
        hm.collapse_edge(0, 3)
    with pytest.raises(ValueError, match="not a live vertex"):
        hm.collapse_edge(0, 7)
    hm.collapse_edge(0, 6)
    with pytest.raises(ValueError, match="not a live vertex"):
        hm.collapse_edge(0, 1)
    assert hm.check() and hm.n_alive_faces == 4


def test_collapse_down_to_a_tetrahedron():
    # an octahedron: collapse any edge and a closed 6-face mesh remains; then a tetrahedron
    faces = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4],
                      [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    hm = build(faces, 6)
    assert hm.check()
    hm.collapse_edge(4, 0)
    assert hm.check() and hm.n_alive_faces == 6
    assert component_invariants(hm.faces(), 6) == [(2, 0)]
    live = hm.faces()
    e = sorted(undirected_edges(live))
    done = False
    for a, b in e:
        if hm.can_collapse(a, b):
            hm.collapse_edge(a, b)
            done = True
            break
    assert done and hm.check() and hm.n_alive_faces == 4
    fs = hm.faces()
    assert not any(hm.can_collapse(a, b) for a, b in undirected_edges(fs))


# ---------------------------------------------------------------------- properties
@st.composite
def grid_soups(draw):
    """Faces of a random grid, random diagonals, a random subset of the faces kept."""
    nx = draw(st.integers(1, 6))
    ny = draw(st.integers(1, 6))
    diagonals = draw(st.lists(st.lists(st.booleans(), min_size=nx, max_size=nx), min_size=ny, max_size=ny))
    faces = grid_faces(nx, ny, diagonals)
    keep = draw(st.lists(st.booleans(), min_size=len(faces), max_size=len(faces)))
    if not draw(st.booleans()):
        keep = [True] * len(faces)
    faces = faces[np.array(keep, dtype=bool)]
    assume(len(faces) > 0)
    return compact(faces)


@st.composite
def face_soups(draw):
    """Random triangles over a few vertices: non-manifold edges, pinches, clashing
    orientations and duplicates are all likely."""
    n = draw(st.integers(3, 8))
    tri = st.lists(st.integers(0, n - 1), min_size=3, max_size=3, unique=True)
    faces = np.array(draw(st.lists(tri, min_size=1, max_size=14)), dtype=np.int64)
    return compact(faces)


@settings(max_examples=150, deadline=None)
@given(grid_soups())
def test_build_grid_subsets(case):
    faces, n = case
    assert_matches_reference(faces, n)


@settings(max_examples=300, deadline=None)
@given(face_soups())
def test_build_face_soups(case):
    faces, n = case
    assert_matches_reference(faces, n)


def random_collapses(hm, rng, n_tries: int, simple: bool = True) -> int:
    """Try random (u, v) edges; collapse the legal ones, checking the invariants each time.

    ``simple``: no two faces share an edge unless they are twins (no cut edges), so the
    number of faces a collapse removes is known in advance."""
    invariants = structure_invariants(hm)
    if simple:
        assert component_invariants(hm.faces(), hm.n_vertices) == invariants
    done = 0
    for _ in range(n_tries):
        faces = hm.faces()
        if len(faces) == 0:
            break
        f = faces[rng.integers(len(faces))]
        k = int(rng.integers(3))
        u, v = int(f[k]), int(f[(k + 1) % 3])
        if rng.random() < 0.5:
            u, v = v, u
        if not hm.can_collapse(u, v):
            with pytest.raises(ValueError):
                hm.collapse_edge(u, v)
            continue
        n_faces = hm.n_alive_faces
        n_sharing = sum(1 for g in faces if {u, v} <= set(map(int, g)))
        assert hm.collapse_edge(u, v) == v
        done += 1
        assert hm.check()
        assert not hm.alive_vertices[u] and hm.alive_vertices[v]
        if simple:
            assert hm.n_alive_faces == n_faces - n_sharing
        else:
            assert n_faces - hm.n_alive_faces in (1, 2)
        assert u not in hm.faces()
        assert structure_invariants(hm) == invariants
        if simple:
            assert component_invariants(hm.faces(), hm.n_vertices) == invariants
    return done


@settings(max_examples=120, deadline=None)
@given(grid_soups(), st.integers(0, 2**32 - 1))
def test_random_collapses_keep_topology_on_grids(case, seed):
    faces, n = case
    hm = build(faces.astype(np.int32), n)
    random_collapses(hm, np.random.default_rng(seed), 150)


@settings(max_examples=150, deadline=None)
@given(face_soups(), st.integers(0, 2**32 - 1))
def test_random_collapses_keep_topology_on_soups(case, seed):
    faces, n = case
    hm = build(faces.astype(np.int32), n)
    random_collapses(hm, np.random.default_rng(seed), 40, simple=False)


def closed_torus(nu: int, nv: int, rng) -> np.ndarray:
    faces = []
    for j in range(nv):
        for i in range(nu):
            a, b = j * nu + i, j * nu + (i + 1) % nu
            c, d = ((j + 1) % nv) * nu + (i + 1) % nu, ((j + 1) % nv) * nu + i
            faces += [[a, b, c], [a, c, d]] if rng.random() < 0.5 else [[a, b, d], [b, c, d]]
    return np.array(faces)


@settings(max_examples=40, deadline=None)
@given(st.integers(3, 7), st.integers(3, 7), st.integers(0, 2**32 - 1))
def test_random_collapses_on_a_torus(nu, nv, seed):
    rng = np.random.default_rng(seed)
    faces = closed_torus(nu, nv, rng)
    hm = build(faces.astype(np.int32), nu * nv)
    assert component_invariants(hm.faces(), nu * nv) == [(0, 0)]
    done = random_collapses(hm, rng, 300)
    if nu >= 5 and nv >= 5:
        assert done > 0
    assert hm.n_alive_faces >= 14            # the smallest triangulated torus has 14 faces


# ---------------------------------------------------------------------- real meshes
REAL = ["bunny.ply", "cow.obj", "fandisk.obj", "boot.obj", "mountain.obj", "colored_airplane.ply",
        "spot_triangulated.obj", "broken_bunny_res2.ply", "broken_deg_faces.obj",
        "broken_non_manifold_wrap.obj", "broken_test_nm.obj"]


def clean_faces(mesh):
    """Drop faces with a repeated index and unused vertices, as lodkit.api.prepare does."""
    f = mesh.faces
    bad = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])
    return compact(f[~bad])


@pytest.mark.parametrize("name", REAL)
def test_build_real_meshes(name):
    mesh = lodkit.load(shared_mesh(name))
    faces, n = clean_faces(mesh)
    hm = build(faces.astype(np.int32), n)
    assert hm.check()
    np.testing.assert_array_equal(hm.vertex_sources[hm.faces()], faces)
    if len(faces) < 20000:
        assert_matches_reference(faces, n)
    expected = {
        "bunny.ply": (0, 0), "fandisk.obj": (0, 0), "boot.obj": (0, 0), "mountain.obj": (0, 0),
        "colored_airplane.ply": (0, 0), "cow.obj": (0, 1),              # one pinch vertex
        "broken_test_nm.obj": (0, 2), "broken_non_manifold_wrap.obj": (1, None),
    }.get(name)
    if expected is not None:
        assert hm.n_nonmanifold_edges == expected[0]
        if expected[1] is not None:
            assert hm.n_split_vertices == expected[1]


@pytest.mark.parametrize("seed", [0, 1])
def test_build_is_the_same_on_any_number_of_threads(seed):
    """A grid of 30k vertices (several of build's 4096-vertex chunks per thread) with faces
    dropped, flipped and duplicated at random: pinches, cut edges and split fans in every
    chunk; the arrays are the same for 1, 2 and 3 threads."""
    rng = np.random.default_rng(seed)
    faces = grid_faces(170, 170)
    faces = faces[rng.random(len(faces)) > 0.05]
    flip = rng.random(len(faces)) < 0.01
    faces[flip] = faces[flip][:, ::-1]
    faces = np.concatenate([faces, faces[rng.integers(0, len(faces), 200)]])
    faces, n = compact(faces)
    faces = faces.astype(np.int32)
    one = build(faces, n, 1)
    assert one.n_nonmanifold_edges > 0 and one.n_split_vertices > 0
    for threads in (2, 3):
        other = build(faces, n, threads)
        assert (other.n_edges, other.n_vertices) == (one.n_edges, one.n_vertices)
        for name in ("corners", "twins", "edges", "edge_halfedges", "vertex_halfedges", "vertex_sources",
                     "locked_vertices"):
            assert np.array_equal(getattr(one, name), getattr(other, name)), name


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_build_names_the_first_face_with_an_index_out_of_range(threads):
    # each thread checks its own run of half-edges: the error still names the first bad
    # face, whichever run holds it (a 170 x 170 grid is above the threads' threshold)
    faces, n = compact(grid_faces(170, 170))
    faces = faces.astype(np.int32)
    faces[40000, 2] = n
    faces[50000, 0] = -1
    with pytest.raises(ValueError, match=f"face 40000 has a vertex index outside 0..{n - 1}"):
        build(faces, n, threads)
