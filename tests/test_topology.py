"""lodkit.topology: exact counts on hand-made meshes, a slow reference, and the shared meshes."""
from __future__ import annotations

import dataclasses
import json
from collections import defaultdict

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import shared_mesh
from lodkit.mesh import Mesh
from lodkit.topology import TopologyReport, topology


def report(faces, n_vertices=None) -> TopologyReport:
    """topology() of faces over otherwise unused vertex positions (coordinates do not matter)."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    n = int(faces.max()) + 1 if n_vertices is None else n_vertices
    return topology(Mesh(np.zeros((n, 3)), faces))


def check(r: TopologyReport, **expected) -> None:
    got = {k: getattr(r, k) for k in expected}
    assert got == expected


# ---------------------------------------------------------------------- small meshes
TETRAHEDRON = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]   # every face counter-clockwise from outside

#   3 ----- 2
#   |     / |        two triangles sharing the edge 0-2
#   |   /   |
#   | /     |
#   0 ----- 1
TWO_TRIANGLES = [[0, 1, 2], [0, 2, 3]]


def grid_torus(rows: int, cols: int, offset: int = 0) -> np.ndarray:
    """A rows x cols grid wrapped in both directions: a closed torus, consistently oriented."""
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    r, c = r.ravel(), c.ravel()
    v = lambda rr, cc: (rr % rows) * cols + (cc % cols) + offset  # noqa: E731
    a, b, d, e = v(r, c), v(r, c + 1), v(r + 1, c), v(r + 1, c + 1)
    return np.concatenate([np.stack([a, b, e], 1), np.stack([a, e, d], 1)])


def cube(open_top: bool = False) -> list:
    #      7-----6
    #     /|    /|      z up; faces counter-clockwise from outside
    #    4-----5 |
    #    | 3---|-2
    #    |/    |/
    #    0-----1
    quads = [[0, 3, 2, 1], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7], [4, 5, 6, 7]]
    if open_top:
        quads = quads[:-1]
    return [t for a, b, c, d in quads for t in ([a, b, c], [a, c, d])]


def test_single_triangle():
    r = report([[0, 1, 2]])
    check(r, n_vertices=3, n_referenced_vertices=3, n_faces=1, n_edges=3, n_boundary_edges=3,
          n_nonmanifold_edges=0, n_nonmanifold_vertices=0, n_degenerate_faces=0, n_duplicate_faces=0,
          n_inconsistent_edges=0, n_boundary_loops=1, n_components=1, euler_characteristic=1, genus=0,
          is_edge_manifold=True, is_vertex_manifold=True, is_manifold=True, is_closed=False,
          is_oriented=True, is_orientable=True)


def test_two_triangles_sharing_an_edge():
    r = report(TWO_TRIANGLES)
    check(r, n_edges=5, n_boundary_edges=4, n_boundary_loops=1, n_components=1,
          euler_characteristic=1, genus=0, is_manifold=True, is_oriented=True)


def test_tetrahedron_is_closed_genus_0():
    r = report(TETRAHEDRON)
    check(r, n_edges=6, n_boundary_edges=0, n_boundary_loops=0, euler_characteristic=2, genus=0,
          is_manifold=True, is_closed=True, is_oriented=True, n_inconsistent_edges=0)


def test_torus_is_closed_genus_1():
    faces = grid_torus(5, 7)
    r = report(faces)
    check(r, n_vertices=35, n_faces=70, n_edges=105, n_boundary_edges=0, n_boundary_loops=0,
          euler_characteristic=0, genus=1, is_manifold=True, is_closed=True, is_oriented=True)


def test_genus_is_summed_per_component():
    # torus + tetrahedron: chi = 0 + 2, so the one-component formula would say genus 0
    faces = np.concatenate([grid_torus(4, 4), np.asarray(TETRAHEDRON) + 16])
    check(report(faces), n_components=2, euler_characteristic=2, genus=1, is_closed=True)
    two_tori = np.concatenate([grid_torus(4, 4), grid_torus(3, 5, offset=16)])
    check(report(two_tori), n_components=2, euler_characteristic=0, genus=2)


def test_cube_with_one_face_missing_has_one_loop():
    r = report(cube(open_top=True))
    check(r, n_faces=10, n_edges=17, n_boundary_edges=4, n_boundary_loops=1, euler_characteristic=1,
          genus=0, is_manifold=True, is_closed=False, is_oriented=True)
    check(report(cube()), n_edges=18, is_closed=True, genus=0, euler_characteristic=2)


def test_two_tetrahedra_sharing_a_vertex_pinch():
    second = [[0 if v == 0 else v + 3 for v in f] for f in TETRAHEDRON]   # shares vertex 0 only
    r = report(TETRAHEDRON + second)
    check(r, n_vertices=7, n_faces=8, n_edges=12, n_boundary_edges=0, n_nonmanifold_edges=0,
          n_nonmanifold_vertices=1, n_components=1, euler_characteristic=3, genus=None,
          is_edge_manifold=True, is_vertex_manifold=False, is_manifold=False, is_closed=True,
          is_oriented=True)


def test_bowtie_pinch_merges_the_two_loops():
    # two triangles touching at vertex 0: one pinch vertex; the boundary-edge graph is connected
    # through it, so the two loops count as one (documented)
    r = report([[0, 1, 2], [0, 3, 4]])
    check(r, n_nonmanifold_vertices=1, n_boundary_edges=6, n_boundary_loops=1, n_components=1,
          is_vertex_manifold=False, genus=None)


def test_three_triangles_on_one_edge():
    r = report([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    check(r, n_edges=7, n_boundary_edges=6, n_nonmanifold_edges=1,
          n_nonmanifold_vertices=2,   # the edge's ends: three fans each, as no manifold edge joins them
          n_inconsistent_edges=0, is_edge_manifold=False, is_vertex_manifold=False, is_manifold=False,
          genus=None)


def test_flipped_face_is_an_orientation_conflict():
    flipped = [[0, 1, 2], [0, 3, 2]]
    check(report(flipped), n_inconsistent_edges=1, is_oriented=False, is_orientable=True,
          is_manifold=True, genus=0)
    tet = [list(f) for f in TETRAHEDRON]
    tet[3] = tet[3][::-1]
    check(report(tet), n_inconsistent_edges=3, is_oriented=False, is_orientable=True, genus=0,
          is_closed=True)


def test_moebius_strip_is_not_orientable():
    n = 6   # top vertices 0..5, bottom 6..11; the last quad joins back with a half twist
    quads = [[i, i + 1, n + i + 1, n + i] for i in range(n - 1)] + [[n - 1, n, 0, 2 * n - 1]]
    faces = [t for a, b, c, d in quads for t in ([a, b, c], [a, c, d])]
    r = report(faces)
    check(r, n_edges=24, n_boundary_edges=12, n_boundary_loops=1, euler_characteristic=0,
          is_manifold=True, is_oriented=False, is_orientable=False, genus=None)


def test_degenerate_faces_are_counted_and_left_out_of_edges():
    r = report([[0, 1, 2], [0, 0, 1], [2, 2, 2]])
    check(r, n_faces=3, n_degenerate_faces=2, n_edges=3, n_boundary_edges=3, n_boundary_loops=1,
          euler_characteristic=1, is_edge_manifold=True, is_manifold=False, genus=None)


def test_degenerate_face_still_connects_components():
    r = report([[0, 1, 2], [2, 2, 3], [3, 4, 5]])
    check(r, n_components=1, n_degenerate_faces=1)
    check(report([[0, 1, 2], [3, 4, 5]]), n_components=2, n_boundary_loops=2, genus=0)


def test_duplicate_faces():
    # the same vertex set three times (any rotation or winding): two duplicates, each edge on 3 faces
    r = report([[0, 1, 2], [2, 1, 0], [1, 2, 0]])
    check(r, n_duplicate_faces=2, n_nonmanifold_edges=3, n_edges=3, is_edge_manifold=False)
    # one reversed copy closes a two-faced "pillow": a (degenerate-looking) sphere
    check(report([[0, 1, 2], [0, 2, 1]]), n_duplicate_faces=1, is_manifold=True, is_closed=True,
          is_oriented=True, genus=0)


def test_unreferenced_vertices_and_empty_mesh():
    check(report([[0, 1, 2]], n_vertices=5), n_vertices=5, n_referenced_vertices=3, n_components=1)
    r = topology(Mesh(np.zeros((4, 3)), np.zeros((0, 3), dtype=np.int32)))
    check(r, n_vertices=4, n_referenced_vertices=0, n_faces=0, n_edges=0, n_components=0,
          n_boundary_loops=0, euler_characteristic=0, genus=None)


def test_open3d_mesh_is_accepted_and_coordinates_are_ignored():
    o3d = pytest.importorskip("open3d")
    m = o3d.geometry.TriangleMesh()
    m.vertices = o3d.utility.Vector3dVector(np.full((4, 3), np.nan))   # lodkit.Mesh would refuse NaN
    m.triangles = o3d.utility.Vector3iVector(np.asarray(TETRAHEDRON, dtype=np.int32))
    check(topology(m), genus=0, is_closed=True)


def test_report_as_dict_and_str():
    r = report(TWO_TRIANGLES)
    d = r.as_dict()
    assert d["n_faces"] == 2 and d["genus"] == 0 and d["is_closed"] is False
    assert json.loads(json.dumps(d)) == d
    lines = str(r).splitlines()
    assert len(lines) == len(d)
    assert len({len(line) for line in lines}) == 1          # aligned: every line the same width
    assert lines[0].startswith("n vertices") and lines[0].endswith("4")
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.n_faces = 3                                       # frozen


def test_rejects_other_types():
    from lodkit.errors import MeshError

    with pytest.raises(MeshError, match="topology"):
        topology([[0, 1, 2]])


# ---------------------------------------------------------------------- slow reference
class _UnionFind:
    def __init__(self):
        self.parent = {}

    def find(self, x):
        self.parent.setdefault(x, x)
        while self.parent[x] != x:
            self.parent[x] = self.parent[self.parent[x]]
            x = self.parent[x]
        return x

    def union(self, a, b):
        self.parent[self.find(a)] = self.find(b)

    def count(self, items):
        return len({self.find(x) for x in items})


def reference(faces, n) -> dict:
    """Obviously-correct, per-element Python version of the counts topology() makes."""
    faces = [tuple(int(v) for v in f) for f in faces]
    good = [(i, f) for i, f in enumerate(faces) if len(set(f)) == 3]
    sides = defaultdict(list)                 # undirected edge -> [(face, tail)]
    for i, f in good:
        for k in range(3):
            a, b = f[k], f[(k + 1) % 3]
            sides[frozenset((a, b))].append((i, a))
    boundary = [e for e, s in sides.items() if len(s) == 1]
    manifold = {e: s for e, s in sides.items() if len(s) == 2}
    inconsistent = [e for e, s in manifold.items() if s[0][1] == s[1][1]]

    fans = _UnionFind()                       # nodes (vertex, face)
    for e, ((f1, _), (f2, _)) in manifold.items():
        for v in e:
            fans.union((v, f1), (v, f2))
    corners = defaultdict(list)
    for i, f in good:
        for v in f:
            corners[v].append((v, i))
    nonmanifold_vertices = sum(1 for v, c in corners.items() if fans.count(c) > 1)

    loops = _UnionFind()
    for e in boundary:
        a, b = tuple(e)
        loops.union(a, b)
    boundary_vertices = {v for e in boundary for v in e}

    comps = _UnionFind()
    for f in faces:
        comps.union(f[0], f[1])
        comps.union(f[1], f[2])
    referenced = {v for f in faces for v in f}

    # orientability: breadth-first flips across manifold edges, then look for a conflict
    neighbours = defaultdict(list)
    for (f1, t1), (f2, t2) in manifold.values():
        same = t1 == t2                       # the faces disagree as stored
        neighbours[f1].append((f2, same))
        neighbours[f2].append((f1, same))
    flip, orientable = {}, True
    for i, _ in good:
        if i in flip:
            continue
        flip[i] = False
        stack = [i]
        while stack:
            f = stack.pop()
            for g, same in neighbours[f]:
                want = flip[f] ^ same
                if g not in flip:
                    flip[g] = want
                    stack.append(g)
                elif flip[g] != want:
                    orientable = False

    chi = len(referenced) - len(sides) + len(good)
    manifold_ok = (all(len(s) <= 2 for s in sides.values()) and nonmanifold_vertices == 0
                   and len(good) == len(faces))
    genus = None
    if manifold_ok and orientable and faces:
        per = defaultdict(lambda: [0, 0, 0, set()])    # component -> [V, E, F, loops]
        for v in referenced:
            per[comps.find(v)][0] += 1
        for e in sides:
            per[comps.find(next(iter(e)))][1] += 1
        for _, f in good:
            per[comps.find(f[0])][2] += 1
        for v in boundary_vertices:
            per[comps.find(v)][3].add(loops.find(v))
        genus = sum((2 - (V - E + F) - len(L)) // 2 for V, E, F, L in per.values())
    return dict(
        n_vertices=n,
        n_referenced_vertices=len(referenced),
        n_faces=len(faces),
        n_edges=len(sides),
        n_boundary_edges=len(boundary),
        n_nonmanifold_edges=sum(1 for s in sides.values() if len(s) >= 3),
        n_nonmanifold_vertices=nonmanifold_vertices,
        n_degenerate_faces=len(faces) - len(good),
        n_duplicate_faces=len(faces) - len({tuple(sorted(f)) for f in faces}),
        n_inconsistent_edges=len(inconsistent),
        n_boundary_loops=loops.count(boundary_vertices),
        n_components=comps.count(referenced),
        euler_characteristic=chi,
        genus=genus,
        is_orientable=orientable,
    )


@settings(max_examples=300, deadline=None)
@given(st.integers(3, 9).flatmap(
    lambda n: st.tuples(st.just(n), st.lists(st.lists(st.integers(0, n - 1), min_size=3, max_size=3),
                                            min_size=1, max_size=14))))
def test_matches_slow_reference_on_random_faces(case):
    n, faces = case
    got = report(faces, n_vertices=n).as_dict()
    want = reference(faces, n)
    assert {k: got[k] for k in want} == want


@pytest.mark.parametrize("faces", [
    TETRAHEDRON,
    cube(open_top=True),
    grid_torus(4, 6),
    [[0, 1, 2], [1, 0, 3], [0, 1, 4]],
    [[0, 1, 2], [0, 3, 4]],
], ids=["tetrahedron", "open cube", "torus", "three on an edge", "bowtie"])
def test_matches_slow_reference_on_hand_made_meshes(faces):
    faces = np.asarray(faces)
    n = int(faces.max()) + 1
    got = report(faces).as_dict()
    want = reference(faces, n)
    assert {k: got[k] for k in want} == want


def grid(k: int) -> np.ndarray:
    i = (np.arange(k)[:, None] * (k + 1) + np.arange(k)[None, :]).ravel()
    return np.concatenate([np.stack([i, i + 1, i + k + 2], 1), np.stack([i, i + k + 2, i + k + 1], 1)])


def test_invariant_under_reordering():
    # 200 x 200 cells = 80k faces: shuffled, the fan search takes the renumbering path
    rng = np.random.default_rng(7)
    faces = grid(200)
    faces = np.concatenate([faces, grid_torus(30, 40, offset=201 * 201)])
    faces[5] = faces[5][[0, 0, 1]]                           # one degenerate face
    faces[9] = faces[9][::-1]                               # one flipped face
    n = int(faces.max()) + 1
    base = report(faces, n)
    perm = rng.permutation(n)
    shuffled = perm[faces][rng.permutation(len(faces))]
    rolled = np.roll(shuffled, 1, axis=1)                   # same faces, corners rotated
    assert report(shuffled, n) == base
    assert report(rolled, n) == base
    check(base, n_components=2, n_boundary_loops=1, n_degenerate_faces=1, is_manifold=False)


def test_a_million_faces():
    """Counts on a 1M-face grid (speed is measured in bench/, never by a timed test: the
    machines are shared)."""
    faces = grid(707)                                       # 999,698 faces
    mesh = Mesh(np.zeros((708 * 708, 3)), faces)
    r = topology(mesh)
    check(r, n_faces=999_698, genus=0, n_boundary_loops=1, is_manifold=True)


# ---------------------------------------------------------------------- shared meshes
def read_o3d(name: str):
    o3d = pytest.importorskip("open3d")
    mesh = o3d.io.read_triangle_mesh(str(shared_mesh(name)))
    assert len(mesh.triangles) > 0, f"open3d read no faces from {name}"
    return mesh


# Values from shared/data/meshes/MANIFEST.md. Open3D's OBJ reader drops unreferenced
# vertices, so the "unreferenced" counts are only checked for PLY files.
MANIFEST = {
    "bunny.ply": dict(n_faces=69451, n_vertices=35947, n_referenced_vertices=35947 - 1113,
                      n_boundary_edges=223, n_boundary_loops=5, is_manifold=True, genus=0),
    "cow.obj": dict(n_faces=5804, n_vertices=2903, is_closed=True, n_nonmanifold_edges=0,
                    n_nonmanifold_vertices=1, euler_characteristic=1, is_manifold=False, genus=None),
    "fandisk.obj": dict(n_faces=12946, n_vertices=6475, is_closed=True, is_manifold=True, genus=0),
    "boot.obj": dict(n_faces=39906, n_vertices=19931, is_closed=True, is_manifold=True, genus=12),
    "colored_airplane.ply": dict(n_faces=10796, n_vertices=7017, n_referenced_vertices=5400,
                                 is_closed=True, is_manifold=True, genus=0),
    "mountain.obj": dict(n_faces=50562, n_vertices=25600, n_boundary_edges=636, n_boundary_loops=1,
                         is_manifold=True, genus=0),
    "igea.ply": dict(n_faces=268686, n_vertices=134345, is_closed=True, is_manifold=True, genus=0),
    "broken_bunny_res2.ply": dict(n_faces=16301, n_vertices=8171, n_referenced_vertices=8171 - 25,
                                  n_boundary_edges=123, n_boundary_loops=5, n_nonmanifold_edges=150,
                                  n_duplicate_faces=87, is_manifold=False, genus=None),
    "broken_inf_nan.obj": dict(n_faces=1, n_boundary_edges=3, n_boundary_loops=1, is_manifold=True),
    "broken_deg_faces.obj": dict(n_faces=4, n_boundary_edges=5, n_boundary_loops=1, n_degenerate_faces=1,
                                 is_edge_manifold=True, is_vertex_manifold=True),
    "broken_non_manifold_wrap.obj": dict(n_faces=12, n_boundary_edges=8, n_boundary_loops=2,
                                         n_nonmanifold_edges=1),
    "broken_test_nm.obj": dict(n_faces=170, n_boundary_edges=30, n_boundary_loops=3, n_nonmanifold_edges=0,
                               n_nonmanifold_vertices=2, is_manifold=False),
}


@pytest.mark.parametrize("name", sorted(MANIFEST))
def test_shared_meshes_match_manifest(name):
    r = topology(read_o3d(name))      # Open3D mesh directly: broken_inf_nan has NaN coordinates
    check(r, **MANIFEST[name])
    assert r.n_inconsistent_edges == 0   # "no orientation problems were found on manifold edges"


def test_spot_welded_at_uv_seams_is_a_closed_sphere():
    # Open3D splits spot's vertices along UV seams (2930 positions -> 3225 vertices), which
    # cuts the surface open; welding coincident positions restores the closed genus-0 cow.
    mesh = read_o3d("spot_triangulated.obj")
    positions = np.asarray(mesh.vertices)
    unique, inverse = np.unique(positions, axis=0, return_inverse=True)
    faces = inverse.reshape(-1)[np.asarray(mesh.triangles)]
    check(topology(mesh), is_closed=False)
    r = topology(Mesh(unique, faces))
    check(r, n_vertices=2930, n_faces=5856, is_closed=True, is_manifold=True, genus=0)
