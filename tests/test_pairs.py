"""Pair contraction (``simplify(..., pair_threshold=T)``): two cubes a gap apart join, a thin
slit closes, nothing happens with T = 0 or a gap wider than T, off by default, seams and
edges are left alone, locked vertices stay, and the welding of faces (membranes cancel)."""
from __future__ import annotations

import numpy as np
import pytest

import lodkit
from lodkit import OptionError
from lodkit.pairs import _weld_faces, contract_pairs


def cube(n: int, offset=(0.0, 0.0, 0.0)):
    from test_qem import subdivided_cube

    v, f = subdivided_cube(n)
    return v + np.asarray(offset), f


def two_cubes(gap: float, n: int = 4):
    """Unit cubes [0,1]^3 and [1+gap, 2+gap] x [0,1]^2, n x n squares a side: the facing
    sides' vertices are ``gap`` apart, every other pair at least 1/n."""
    va, fa = cube(n)
    vb, fb = cube(n, (1.0 + gap, 0.0, 0.0))
    return lodkit.Mesh(np.vstack([va, vb]), np.vstack([fa, fb + len(va)]))


def slit_grid(gap: float, n: int = 6, row: int = 3, cut=(2, 5)):
    """A flat n x n grid of unit quads with a slit along y = row for row-vertices
    cut[0] <= i < cut[1]: the quads above use copies of those vertices moved up by ``gap``.
    Boundary loops: the outline and the slit."""
    xs, ys = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0))
    v = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], axis=1)
    copies = {}
    for i in range(*cut):
        copies[row * (n + 1) + i] = len(v) + len(copies)
    v = np.vstack([v, v[list(copies)] + [0.0, gap, 0.0]])
    faces = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            quad = [a, a + 1, a + n + 2, a + n + 1]
            if j == row:                         # the quads just above the slit
                quad = [copies.get(x, x) for x in quad]
            faces += [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
    return lodkit.Mesh(v, np.array(faces))


# ---------------------------------------------------------------------- joining parts
def test_two_cubes_a_gap_apart_join():
    m = two_cubes(0.01)
    assert lodkit.topology(m).n_components == 2
    r = lodkit.simplify(m, target_ratio=1.0, pair_threshold=0.05, absolute=True)
    rep = r.report["pair_contraction"]
    # the facing sides' 5 x 5 vertices merge; their 2 x 16 faces meet back to back and cancel
    assert rep["candidate_pairs"] == 25 and rep["merged"] == 25
    assert rep["membrane_faces_removed"] == 64 and rep["duplicate_faces_removed"] == 0
    topo = lodkit.topology(r.mesh)
    assert topo.n_components == 1 and topo.is_manifold and topo.is_closed and topo.genus == 0
    assert r.mesh.n_faces == 2 * 6 * 32 - 64
    # the joined vertices lie in the gap: the ring of 16 around the vanished membrane (its
    # 3 x 3 inner vertices belong to no face any more)
    joined = np.abs(r.mesh.vertices[:, 0] - 1.005) < 0.01
    assert np.count_nonzero(joined) == 16
    # a corner pair sums six planes (x = 1, x = 1.01, y = 0, z = 0 twice): a full-rank
    # quadric, minimised on y = z = 0 between the two sides
    at_origin_edge = (np.abs(r.mesh.vertices[:, 1:]) < 1e-12).all(axis=1)   # (positions round-trip
    corner = r.mesh.vertices[joined & at_origin_edge]                       # the normalisation)
    assert corner.shape == (1, 3) and 1.0 < corner[0, 0] < 1.01


def test_joined_cubes_simplify_to_a_box():
    r = lodkit.simplify(two_cubes(0.01), target_faces=12, pair_threshold=0.05, absolute=True)
    topo = lodkit.topology(r.mesh)
    assert topo.n_components == 1 and topo.is_manifold and topo.genus == 0
    lo, hi = r.mesh.vertices.min(0), r.mesh.vertices.max(0)
    np.testing.assert_allclose(lo, [0, 0, 0], atol=1e-9)
    np.testing.assert_allclose(hi, [2.01, 1, 1], atol=1e-9)


@pytest.mark.parametrize("threshold, absolute", [(0.0, True), (0.01, True), (0.005, True), (0.0, False),
                                                 (0.003, False)])
def test_no_merge_at_zero_or_below_the_gap(threshold, absolute):
    # the gap is 0.01 (0.0041 of the bbox diagonal): strictly closer than T merges
    m = two_cubes(0.01)
    plain = lodkit.simplify(m, target_ratio=0.5)
    r = lodkit.simplify(m, target_ratio=0.5, pair_threshold=threshold, absolute=absolute)
    assert r.report["pair_contraction"]["merged"] == 0
    assert np.array_equal(r.mesh.vertices, plain.mesh.vertices) and np.array_equal(r.mesh.faces, plain.mesh.faces)
    assert np.array_equal(r.face_map, plain.face_map) and np.array_equal(r.vertex_map, plain.vertex_map)
    assert lodkit.topology(r.mesh).n_components == 2


def test_relative_threshold_is_a_fraction_of_the_diagonal():
    m = two_cubes(0.01)
    diag = m.bbox_diagonal()
    r = lodkit.simplify(m, target_ratio=1.0, pair_threshold=0.02 / diag)
    assert r.report["pair_contraction"]["threshold"] == pytest.approx(0.02)
    assert r.report["pair_contraction"]["merged"] == 25


def test_off_by_default():
    m = two_cubes(0.01)
    a = lodkit.simplify(m, target_ratio=0.3)
    b = lodkit.simplify(m, target_ratio=0.3, pair_threshold=None)
    assert a.report["pair_contraction"] is None and b.report["pair_contraction"] is None
    for x, y in ((a.mesh.vertices, b.mesh.vertices), (a.mesh.faces, b.mesh.faces),
                 (a.vertex_map, b.vertex_map), (a.face_map, b.face_map)):
        assert np.array_equal(x, y)
    assert lodkit.topology(a.mesh).n_components == 2


# ---------------------------------------------------------------------- closing gaps
@pytest.mark.parametrize("gap", [0.0, 0.02])
def test_thin_slit_closes(gap):
    m = slit_grid(gap)
    before = lodkit.topology(m)
    assert before.n_boundary_loops == 2 and before.is_manifold
    r = lodkit.simplify(m, target_ratio=1.0, pair_threshold=0.05, absolute=True)
    assert r.report["pair_contraction"]["merged"] == 3
    after = lodkit.topology(r.mesh)
    assert after.n_boundary_loops == 1 and after.is_manifold and after.n_faces == m.n_faces
    # the slit closes half way across (on a plane every position costs 0: the tie goes to
    # the midpoint); with no gap the whole row of 7 vertices is at y = 3
    assert np.isclose(r.mesh.vertices[:, 1], 3 + gap / 2, rtol=0, atol=1e-12).sum() == (3 if gap else 7)


def test_slit_wider_than_threshold_stays_open():
    r = lodkit.simplify(slit_grid(0.1), target_ratio=1.0, pair_threshold=0.05, absolute=True)
    assert r.report["pair_contraction"]["merged"] == 0
    assert lodkit.topology(r.mesh).n_boundary_loops == 2


def test_face_map_points_at_input_faces():
    m = slit_grid(0.02)
    r = lodkit.simplify(m, target_ratio=1.0, pair_threshold=0.05, absolute=True)
    # every output face is its input face with each corner moved by less than T
    moved = np.linalg.norm(r.mesh.vertices[r.mesh.faces] - m.vertices[m.faces[r.face_map]], axis=2)
    assert (moved < 0.05).all()
    assert sorted(r.face_map.tolist()) == list(range(m.n_faces))


# ---------------------------------------------------------------------- what is left alone
def test_edges_are_not_virtual_pairs():
    # every pair of a small tetrahedron is an edge: nothing for pair contraction
    v = np.array([[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]])
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    r = lodkit.simplify(lodkit.Mesh(v, f), target_ratio=1.0, pair_threshold=0.5)
    assert r.report["pair_contraction"]["candidate_pairs"] == 0
    assert r.mesh.n_faces == 4


def test_attribute_seams_are_not_welded():
    # coincident copies with different uvs are a seam, not a gap
    m = slit_grid(0.0)
    uvs = m.vertices[:, :2] / 6.0
    uvs[49:] += [0.0, 0.5]                    # the three copies have their own uvs
    r = lodkit.simplify(lodkit.Mesh(m.vertices, m.faces, uvs=uvs), target_ratio=1.0,
                        pair_threshold=0.05, absolute=True)
    rep = r.report["pair_contraction"]
    assert rep["skipped_seams"] == 3 and rep["merged"] == 0
    assert r.mesh.n_vertices == m.n_vertices
    # the same copies with equal uvs are a crack and close, with the uvs averaged
    uvs[49:] -= [0.0, 0.5]
    r = lodkit.simplify(lodkit.Mesh(m.vertices, m.faces, uvs=uvs), target_ratio=1.0,
                        pair_threshold=0.05, absolute=True)
    assert r.report["pair_contraction"]["merged"] == 3 and r.mesh.n_vertices == m.n_vertices - 3


def test_locked_vertices_keep_their_place():
    m = two_cubes(0.01)
    locked = np.zeros(m.n_vertices, dtype=bool)
    locked[: m.n_vertices // 2] = True                   # all of the first cube
    r = lodkit.simplify(m, target_ratio=1.0, pair_threshold=0.05, absolute=True, locked=locked)
    assert r.report["pair_contraction"]["merged"] == 25
    near = np.abs(r.mesh.vertices[:, 0] - 1.0) < 0.02
    assert np.count_nonzero(near) == 16 and (r.mesh.vertices[near, 0] == 1.0).all()
    # at the locked vertices' positions, bit for bit
    assert np.array_equal(r.mesh.vertices[near], m.vertices[r.vertex_map[near]])
    assert (r.vertex_map[near] < m.n_vertices // 2).all()     # the locked copies stay
    # two locked vertices never merge
    r = lodkit.simplify(m, target_ratio=1.0, pair_threshold=0.05, absolute=True,
                        locked=np.ones(m.n_vertices, dtype=bool))
    assert r.report["pair_contraction"]["candidate_pairs"] == 0


def test_open3d_mesh_in():
    o3d = pytest.importorskip("open3d")
    r = lodkit.simplify(two_cubes(0.01).to_open3d(), target_ratio=1.0, pair_threshold=0.05, absolute=True)
    assert isinstance(r.mesh, o3d.geometry.TriangleMesh) and len(r.mesh.triangles) == 320


# ---------------------------------------------------------------------- welding faces
def test_weld_cancels_opposite_faces_in_pairs():
    root = np.arange(6)
    root[3:] = [0, 1, 2]                      # vertices 3 4 5 merge into 0 1 2
    faces = np.array([[0, 1, 2], [3, 5, 4], [0, 1, 2], [5, 4, 3], [1, 2, 0], [0, 0, 1]])
    f, kept, counts = _weld_faces(faces, root)
    # one collapsed face; on the triple {0,1,2}: even 0 1 2 x2 + 1 2 0, odd 3 5 4 and 5 4 3
    # -> two cancelled pairs, one even face left: the first even face (0)
    assert counts == {"collapsed_faces_removed": 1, "membrane_faces_removed": 4, "duplicate_faces_removed": 0}
    assert kept.tolist() == [0] and f.tolist() == [[0, 1, 2]]


def test_weld_keeps_one_of_equal_duplicates():
    root = np.arange(4)
    root[3] = 0
    f, kept, counts = _weld_faces(np.array([[1, 2, 3], [0, 1, 2], [3, 2, 1]]), root)
    # faces 0 and 1 are even on {0,1,2} (0 1 2 is a rotation of 1 2 0), face 2 odd:
    # one pair cancels, one even face is left, the first one (0)
    assert kept.tolist() == [0] and f.tolist() == [[1, 2, 0]]
    assert counts["membrane_faces_removed"] == 2 and counts["duplicate_faces_removed"] == 0


def test_contract_pairs_unchanged_without_pairs():
    m = two_cubes(0.5)
    out, kept, rep = contract_pairs(m, 0.1, absolute=True)
    assert out is m and kept.tolist() == list(range(m.n_faces)) and rep["merged"] == 0


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf"), "far", True])
def test_bad_threshold_raises_option_error(bad):
    with pytest.raises(OptionError, match="pair_threshold"):
        lodkit.simplify(two_cubes(0.01), target_ratio=0.5, pair_threshold=bad)


def test_cli_pair_threshold(tmp_path):
    from lodkit.cli import main

    src, dst = tmp_path / "cubes.ply", tmp_path / "out.ply"
    lodkit.save(two_cubes(0.01), src)
    assert main(["simplify", str(src), str(dst), "--ratio", "1", "--pair-threshold", "0.05",
                 "--absolute", "-q"]) == 0
    assert lodkit.topology(lodkit.load(dst)).n_components == 1


def test_input_degenerate_faces_are_counted_by_simplify():
    m = two_cubes(0.01)
    faces = np.vstack([m.faces, [[0, 0, 1]]])
    r = lodkit.simplify(lodkit.Mesh(m.vertices, faces), target_ratio=1.0, pair_threshold=0.05, absolute=True)
    assert r.report["degenerate_faces_removed"] == 1
    assert r.report["pair_contraction"]["collapsed_faces_removed"] == 0
    assert r.mesh.n_faces == 320 and (r.face_map < m.n_faces).all()


def test_merged_attributes_are_averaged():
    # colours in the gap differ only slightly from position to position; a crack, not a seam
    m = slit_grid(0.02)
    colors = np.zeros((m.n_vertices, 3))
    colors[49:] = [1.0, 0.5, 0.0]                 # the three copies above the slit
    r = lodkit.simplify(lodkit.Mesh(m.vertices, m.faces, colors=colors), target_ratio=1.0,
                        pair_threshold=0.05, absolute=True)
    assert r.report["pair_contraction"]["merged"] == 3
    on_slit = np.isclose(r.mesh.vertices[:, 1], 3.01, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.mesh.colors[on_slit], [[0.5, 0.25, 0.0]] * 3, atol=1e-12)
    assert (r.mesh.colors[~on_slit] == 0).all()
