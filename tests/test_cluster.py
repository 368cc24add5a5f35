"""lodkit.cluster: exact output on hand-made grids, a slow pure-Python reference of the
whole pipeline on random triangle soups (hypothesis), the representatives (quadric
placement against a numpy reference, importance weights against a loop), attributes,
the cell-size search, options and errors, and the shared real meshes."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lodkit
from conftest import shared_mesh
from lodkit import MeshError, OptionError
from lodkit.cluster import _REGULARISE, _TIKHONOV_STEPS

SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


# ---------------------------------------------------------------------- test meshes
def flat_grid(n: int, size: float = 1.0):
    """(n + 1) x (n + 1) vertices over [0, n*size]^2 at z = 0, vertex j*(n+1)+i at (i, j);
    quad (i, j) is faces 2*(j*n+i) = (a, b, c) and 2*(j*n+i)+1 = (a, c, d), counter-clockwise."""
    xs, ys = np.meshgrid(np.arange(n + 1) * size, np.arange(n + 1) * size)
    v = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], axis=1)
    faces = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            b, c, d = a + 1, a + n + 2, a + n + 1
            faces += [[a, b, c], [a, c, d]]
    return v, np.array(faces)


def cube_surface(n: int):
    """The surface of [0, 1]^3 cut into n x n squares per side, outward faces."""
    from test_qem import subdivided_cube

    return subdivided_cube(n)


def signed_volume(v, f) -> float:
    return float(np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6.0)


# ---------------------------------------------------------------------- slow reference
def reference_cluster(v, f, h):
    """Vertex clustering with "mean" representatives, written out with Python loops.
    h is a fraction of the bbox diagonal.  Returns (vertices, faces, face_map)."""
    v = np.asarray(v, dtype=float)
    f = [tuple(int(x) for x in t) for t in f]
    f_idx = [k for k, t in enumerate(f) if len(set(t)) == 3]
    used = sorted({x for k in f_idx for x in f[k]})
    pts = v[used]
    lo, hi = np.array([pts[:, k].min() for k in range(3)]), np.array([pts[:, k].max() for k in range(3)])
    center, scale = 0.5 * lo + 0.5 * hi, float(np.linalg.norm(hi - lo))
    plo, phi = (lo - center) / scale, (hi - center) / scale
    dims = [max(int(math.ceil((phi[k] - plo[k]) / h)), 1) for k in range(3)]
    cell = {}
    for i in used:
        p = (v[i] - center) / scale
        cell[i] = tuple(min(max(int(math.floor((p[k] - plo[k]) * (1.0 / h))), 0), dims[k] - 1) for k in range(3))
    groups = {}
    for k in f_idx:
        c = tuple(cell[x] for x in f[k])
        if len(set(c)) < 3:
            continue
        groups.setdefault(frozenset(c), []).append(k)
    kept = []
    for members in groups.values():
        def even(k):
            c = [cell[x] for x in f[k]]
            s = sorted(c)
            return c in ([s[0], s[1], s[2]], [s[1], s[2], s[0]], [s[2], s[0], s[1]])
        vote = total = 0.0
        for k in members:
            a, b, c = v[list(f[k])]
            area = np.linalg.norm(np.cross((b - center) / scale - (a - center) / scale,
                                           (c - center) / scale - (a - center) / scale))
            vote += area if even(k) else -area
            total += area
        # ties to rounding (a face and its reverse cancel) go to the first face
        want = even(members[0]) if abs(vote) <= 1e-9 * total else vote > 0
        kept.append(next(k for k in members if even(k) == want))
    kept.sort()
    cells = sorted({cell[x] for k in kept for x in f[k]})
    index = {c: i for i, c in enumerate(cells)}
    members = {c: [i for i in used if cell[i] == c] for c in cells}
    verts = np.array([v[members[c]].mean(axis=0) for c in cells]).reshape(-1, 3)
    faces = np.array([[index[cell[x]] for x in f[k]] for k in kept], dtype=np.int64).reshape(-1, 3)
    return verts, faces, np.array(kept, dtype=np.int64)


@st.composite
def soups(draw):
    """Random triangle soups: vertices on a coarse lattice (so coincidences happen), faces
    random triples -- repeated indices, duplicates, non-manifold edges all allowed."""
    n = draw(st.integers(4, 40))
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    v = rng.integers(0, 17, (n, 3)) / 16.0
    m = draw(st.integers(1, 80))
    f = rng.integers(0, n, (m, 3))
    if not ((f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])).any():
        f = np.vstack([f, [[0, 1, 2]]])
        v[:3] = [[0, 0, 0], [1, 0, 0], [0, 1, 1]]
    return v, f


def check_clean(result, n_in_faces: int):
    """No degenerate face, no duplicate face (either orientation), every vertex used, maps in range."""
    out = result.mesh
    f = out.faces
    assert not ((f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])).any()
    assert len({frozenset(t) for t in f.tolist()}) == f.shape[0]
    assert np.array_equal(np.unique(f), np.arange(out.n_vertices))
    assert result.vertex_map.shape == (out.n_vertices,) and result.face_map.shape == (out.n_faces,)
    assert np.all(np.diff(result.face_map) > 0) and (result.face_map < n_in_faces).all()


# ---------------------------------------------------------------------- exact small cases
def test_two_triangles_in_a_2x1x1_grid_collapse_entirely():
    # the rectangle [0,2] x [0,1] in cells of side 1: two cells, so no face keeps three
    v = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0]], float)
    r = lodkit.cluster(lodkit.Mesh(v, [[0, 1, 2], [0, 2, 3]]), cell_size=1.0, absolute=True, representative="mean")
    assert r.report["grid"] == [2, 1, 1] and r.report["occupied_cells"] == 2
    assert r.report["collapsed_faces"] == 2
    assert r.mesh.n_faces == 0 and r.mesh.n_vertices == 0


@pytest.mark.parametrize("representative", ["mean", "quadric"])
def test_flat_grid_collapses_to_its_middle_square(representative):
    # 3 x 3 quads over [0, 3]^2 in cells of 1.5: a 2 x 2 x 1 grid; only the middle quad
    # (faces 8 and 9) reaches three cells.  Cells in key order: (0,0) (0,1) (1,0) (1,1),
    # each holding a 2 x 2 block of vertices whose centroid is its centre.
    v, f = flat_grid(3)
    r = lodkit.cluster(lodkit.Mesh(v, f), cell_size=1.5, absolute=True, representative=representative)
    assert r.report["grid"] == [2, 2, 1]
    assert r.mesh.faces.tolist() == [[0, 2, 3], [0, 3, 1]]
    assert r.face_map.tolist() == [8, 9]
    expect = [[0.5, 0.5, 0], [0.5, 2.5, 0], [2.5, 0.5, 0], [2.5, 2.5, 0]]
    np.testing.assert_allclose(r.mesh.vertices, expect, atol=1e-12)
    # each output vertex's input vertex: the one nearest the centroid (ties: lowest index)
    assert r.vertex_map.tolist() == [0, 8, 2, 10]
    assert r.error == pytest.approx(0.0, abs=1e-12)            # everything on one plane
    check_clean(r, f.shape[0])


def test_cube_collapses_to_a_cube_with_centroids_by_hand():
    # the surface of [0,1]^3 with vertices at 0, 1/3, 2/3, 1 in cells of 1/2: one cell per
    # octant.  The octant at the origin holds the 7 surface points of {0, 1/3}^3, whose mean
    # is (0*4 + 1/3*3)/7 = 1/7 per coordinate; the far one 6/7.
    v, f = cube_surface(3)
    r = lodkit.cluster(lodkit.Mesh(v, f), cell_size=0.5, absolute=True, representative="mean")
    out = r.mesh
    assert out.n_vertices == 8 and out.n_faces == 12
    octant = (out.vertices > 0.5).astype(int)
    assert sorted(map(tuple, octant.tolist())) == [(i, j, k) for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    np.testing.assert_allclose(out.vertices, np.where(octant, 6 / 7, 1 / 7), atol=1e-12)
    topo = lodkit.topology(out)
    assert topo.is_manifold and topo.is_closed and topo.genus == 0 and topo.is_oriented
    assert signed_volume(out.vertices, out.faces) == pytest.approx((5 / 7) ** 3)
    # every face lies on one side of the cube: its three octants agree in one coordinate
    assert all((octant[t] == octant[t][0]).all(axis=0).any() for t in out.faces)


def test_cube_quadric_representatives_are_the_corners():
    # each octant's faces lie on three orthogonal planes through one cube corner: the
    # quadric minimiser is that corner (Lindstrom's corner preservation), error 0
    v, f = cube_surface(3)
    r = lodkit.cluster(lodkit.Mesh(v, f), cell_size=0.5, absolute=True, representative="quadric")
    corners = (r.mesh.vertices > 0.5).astype(float)
    np.testing.assert_allclose(r.mesh.vertices, corners, atol=1e-9)
    assert r.error < 1e-7                     # sqrt of the rounding in Q(x) ~ 1e-16
    assert r.report["rms_error"] <= r.error


def test_duplicates_keep_the_area_majority_orientation():
    # cells of side 1 over [0, 1.9]^2: A = (0, 0), B = (1, 0), C = (0, 1).  Faces 0 and 1 run
    # A C B (clockwise, area 1/2 each), face 2 runs A B C (counter-clockwise, area 1.805):
    # the counter-clockwise side wins the vote and its first face (2) is kept
    v = np.array([[0.1, 0.1, 0], [0.1, 1.1, 0], [1.1, 0.1, 0],
                  [0.2, 0.2, 0], [0.2, 1.2, 0], [1.2, 0.2, 0],
                  [0, 0, 0], [1.9, 0, 0], [0, 1.9, 0]], float)
    f = [[0, 1, 2], [3, 4, 5], [6, 7, 8]]
    r = lodkit.cluster(lodkit.Mesh(v, f), cell_size=1.0, absolute=True, representative="mean")
    assert r.report["duplicate_faces"] == 2
    assert r.face_map.tolist() == [2]
    # cells in key order A (0,0), C (0,1), B (1,0): A B C is 0 2 1
    assert r.mesh.faces.tolist() == [[0, 2, 1]]
    # with the big face turned over, the clockwise side wins and face 0 is kept
    r = lodkit.cluster(lodkit.Mesh(v, [[0, 1, 2], [3, 4, 5], [6, 8, 7]]), cell_size=1.0, absolute=True)
    assert r.face_map.tolist() == [0] and r.mesh.faces.tolist() == [[0, 1, 2]]


def test_opposite_duplicates_of_equal_area_keep_the_first():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    r = lodkit.cluster(lodkit.Mesh(v, [[0, 2, 1], [0, 1, 2]]), cell_size=0.5, absolute=True)
    # cells in key order: vertex 0 (0,0), vertex 2 (0,1), vertex 1 (1,0)
    assert r.face_map.tolist() == [0] and r.mesh.faces.tolist() == [[0, 1, 2]]


def test_faces_and_their_reverses_tie_whatever_the_rounding():
    # vertices 0, 3, 4 share a cell, 1 and 2 have one each.  Faces 0 and 2 are one
    # triangle both ways round, faces 4 and 5 another: an exact tie, whatever order the
    # areas are summed in, so the group's first face (0) decides; faces 1 and 3 collapse
    v = np.array([[0.1, 0.1, 0], [0.9, 0.3, 0.2], [0.2, 0.7, 0.4], [0.3, 0.15, 0.05], [0.45, 0.1, 0.3]])
    f = [[1, 0, 2], [3, 4, 2], [0, 1, 2], [2, 4, 3], [4, 1, 2], [2, 1, 4]]
    r = lodkit.cluster(lodkit.Mesh(v, f), cell_size=0.55, absolute=True, representative="mean")
    assert r.report["grid"] == [2, 2, 1] and r.report["occupied_cells"] == 3
    assert r.report["collapsed_faces"] == 2 and r.report["duplicate_faces"] == 3
    assert r.face_map.tolist() == [0]


# ---------------------------------------------------------------------- against the reference
@SETTINGS
@given(soups(), st.floats(0.05, 0.7))
def test_mean_clustering_matches_the_reference(soup, h):
    v, f = soup
    r = lodkit.cluster(lodkit.Mesh(v, f), cell_size=h, representative="mean")
    check_clean(r, f.shape[0])
    rv, rf, rmap = reference_cluster(v, f, h)
    assert r.face_map.tolist() == rmap.tolist()
    assert r.mesh.faces.tolist() == rf.tolist()
    np.testing.assert_allclose(r.mesh.vertices, rv, atol=1e-12)


@SETTINGS
@given(soups(), st.floats(0.05, 0.7), st.sampled_from(["quadric", "importance"]))
def test_other_representatives_give_the_same_faces(soup, h, representative):
    # the faces depend on the grid only; the representative only places the vertices
    v, f = soup
    a = lodkit.cluster(lodkit.Mesh(v, f), cell_size=h, representative="mean")
    b = lodkit.cluster(lodkit.Mesh(v, f), cell_size=h, representative=representative)
    check_clean(b, f.shape[0])
    assert b.mesh.faces.tolist() == a.mesh.faces.tolist() and b.face_map.tolist() == a.face_map.tolist()
    # every representative stays in its cell: within the cell's box of the centroid's cell
    proper = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    hh = b.cell_size * np.linalg.norm(np.ptp(v[np.unique(proper)], axis=0))
    assert (np.abs(b.mesh.vertices - a.mesh.vertices) <= hh * (1 + 1e-9)).all()
    if representative == "importance":
        # an input vertex, bit for bit
        assert np.array_equal(b.mesh.vertices, np.asarray(v, float)[b.vertex_map])


def reference_importance(p, f, label, n_cells):
    """Rossignac-Borrel weights with loops: L = longest incident edge, s = 1 - |sum of
    incident cross products| / sum of their lengths; per cell the largest L*s, then L, then
    the lowest index."""
    n = p.shape[0]
    L = [0.0] * n
    N = [[0.0, 0.0, 0.0] for _ in range(n)]
    T = [0.0] * n
    for a, b, c in f.tolist():
        tri = (a, b, c)
        e = []
        for j in range(3):
            d = p[tri[(j + 1) % 3]] - p[tri[j]]
            e.append(math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]))
        u, w = p[b] - p[a], p[c] - p[a]
        nx, ny, nz = u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]
        length = math.sqrt(nx * nx + ny * ny + nz * nz)
        for j in range(3):
            s = e[j] if e[j] > e[(j + 2) % 3] else e[(j + 2) % 3]
            L[tri[j]] = max(L[tri[j]], s)
            N[tri[j]][0] += nx
            N[tri[j]][1] += ny
            N[tri[j]][2] += nz
            T[tri[j]] += length
    best = [None] * n_cells
    for i in range(n):
        s = max(1.0 - math.sqrt(sum(x * x for x in N[i])) / T[i], 0.0) if T[i] > 0 else 0.0
        key = (L[i] * s, L[i], -i)
        if best[label[i]] is None or key > best[label[i]][0]:
            best[label[i]] = (key, i)
    return [b[1] for b in best]


@SETTINGS
@given(soups(), st.floats(0.05, 0.7))
def test_importance_matches_the_reference(soup, h):
    from lodkit._core.cluster import most_important
    from lodkit.cluster import _apply_grid, _clean

    v, f = soup
    data = _clean(lodkit.Mesh(v, f))
    g = _apply_grid(data, h)
    chosen, _ = most_important(data.positions, data.faces, g.label, g.keys.size)
    assert chosen.tolist() == reference_importance(data.positions, data.faces, g.label, g.keys.size)


def reference_placement(q, mean, lo, h):
    """Iterated Tikhonov in numpy (the same formula as the kernel, by np.linalg.solve)."""
    A = q[[0, 1, 2, 1, 3, 4, 2, 4, 5]].reshape(3, 3)
    b = q[6:9]
    lam = _REGULARISE * np.trace(A) / 3
    x = mean.copy()
    if lam > 0:
        for _ in range(_TIKHONOV_STEPS):
            x = x + np.linalg.solve(A + lam * np.eye(3), -b - A @ x)
    return np.clip(x, lo, lo + h)


@pytest.mark.parametrize("seed", range(3))
def test_quadric_placement_matches_numpy(seed):
    from lodkit._core.cluster import place_quadric

    rng = np.random.default_rng(seed)
    k = 200
    rows = []
    for _ in range(k):
        # 1 to 4 random planes near the cell: ranks 1, 2 and 3
        q = np.zeros(11)
        for _ in range(rng.integers(1, 5)):
            nrm = rng.normal(size=3)
            nrm /= np.linalg.norm(nrm)
            d = -nrm @ rng.uniform(0, 1, 3)
            a = rng.uniform(0.1, 1)
            q += a * np.array([*(nrm[[0, 0, 0, 1, 1, 2]] * nrm[[0, 1, 2, 1, 2, 2]]), *(d * nrm), d * d, 1])
        rows.append(q)
    Q = np.array(rows)
    mean = rng.uniform(0, 1, (k, 3))
    lo = np.floor(mean * 2) / 2
    got = place_quadric(Q, mean, np.ascontiguousarray(lo), 0.5, _REGULARISE, _TIKHONOV_STEPS)
    want = np.array([reference_placement(Q[i], mean[i], lo[i], 0.5) for i in range(k)])
    np.testing.assert_allclose(got, want, atol=1e-9)
    assert ((got >= lo) & (got <= lo + 0.5)).all()


def test_rank_one_cell_keeps_the_centroid_in_plane():
    from lodkit._core.cluster import place_quadric

    # one plane z = 0.3 (area 2): the point moves onto it, x and y stay the centroid's
    q = 2.0 * np.array([0, 0, 0, 0, 0, 1, 0, 0, -0.3, 0.09, 1.0])
    got = place_quadric(q[None, :], np.array([[0.2, 0.7, 0.1]]), np.zeros((1, 3)), 1.0, _REGULARISE, _TIKHONOV_STEPS)
    np.testing.assert_allclose(got, [[0.2, 0.7, 0.3]], atol=1e-9)


def test_far_minimiser_is_clamped_to_the_cell():
    from lodkit._core.cluster import place_quadric

    # two nearly parallel planes, z = 0.5 - 0.01 y and z = 0.4 + 0.01 y, meeting at y = 5
    q = np.zeros(11)
    for nrm, d in ((np.array([0.0, 0.01, 1.0]), -0.5), (np.array([0.0, -0.01, 1.0]), -0.4)):
        nrm = nrm / np.linalg.norm(nrm)
        q += np.array([*(nrm[[0, 0, 0, 1, 1, 2]] * nrm[[0, 1, 2, 1, 2, 2]]), *(d * nrm), d * d, 1])
    got = place_quadric(q[None, :], np.array([[0.5, 0.5, 0.5]]), np.zeros((1, 3)), 1.0, 1e-9, 3)
    assert ((got >= 0) & (got <= 1)).all()
    assert got[0, 1] == 1.0                       # pushed to the wall


# ---------------------------------------------------------------------- attributes and I/O
def test_attributes_are_averaged_per_cell():
    v, f = flat_grid(3)
    rng = np.random.default_rng(1)
    colors = rng.uniform(0, 1, (len(v), 3))
    uvs = rng.uniform(0, 1, (len(v), 2))
    normals = rng.normal(size=(len(v), 3)) + [0, 0, 3]
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    r = lodkit.cluster(lodkit.Mesh(v, f, normals=normals, colors=colors, uvs=uvs), cell_size=1.5,
                       absolute=True, representative="quadric")
    # the cells' 2 x 2 vertex blocks, in key order (0,0) (0,1) (1,0) (1,1)
    blocks = [[0, 1, 4, 5], [8, 9, 12, 13], [2, 3, 6, 7], [10, 11, 14, 15]]
    np.testing.assert_allclose(r.mesh.colors, [colors[b].mean(0) for b in blocks], atol=1e-12)
    np.testing.assert_allclose(r.mesh.uvs, [uvs[b].mean(0) for b in blocks], atol=1e-12)
    want = np.array([normals[b].sum(0) for b in blocks])
    np.testing.assert_allclose(r.mesh.normals, want / np.linalg.norm(want, axis=1, keepdims=True), atol=1e-12)


def test_open3d_in_open3d_out():
    o3d = pytest.importorskip("open3d")
    m = o3d.geometry.TriangleMesh.create_sphere(1.0, 20)
    r = lodkit.cluster(m, cell_size=0.15)
    assert isinstance(r.mesh, o3d.geometry.TriangleMesh)
    assert len(r.mesh.triangles) == len(r.face_map) > 0


def test_input_is_not_modified():
    v, f = cube_surface(4)
    m = lodkit.Mesh(v.copy(), f.copy())
    lodkit.cluster(m, cell_size=0.3)
    assert np.array_equal(m.vertices, v) and np.array_equal(m.faces, f)


def test_nonmanifold_input_and_several_objects():
    # a fin of three triangles on one edge, and a separate cube; all faces reach 3 cells
    v, f = cube_surface(2)
    fin_v = np.array([[3, 0, 0], [3, 0, 1], [4, 0, 0], [3, 1, 0.5], [2, -1, 0.5]], float)
    fin_f = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]]) + len(v)
    m = lodkit.Mesh(np.vstack([v, fin_v]), np.vstack([f, fin_f]))
    r = lodkit.cluster(m, cell_size=0.2, absolute=True)
    check_clean(r, m.n_faces)
    assert lodkit.topology(r.mesh).n_components == 2
    assert lodkit.topology(r.mesh).n_nonmanifold_edges == 1        # the fin's edge stays


def test_unused_and_degenerate_input_is_dropped():
    v, f = flat_grid(3)
    v = np.vstack([v, [[9, 9, 9]]])                           # unused, and far away
    f = np.vstack([f, [[0, 0, 1]]])
    r = lodkit.cluster(lodkit.Mesh(v, f), cell_size=1.5, absolute=True)
    assert r.report["unreferenced_vertices_removed"] == 1 and r.report["degenerate_faces_removed"] == 1
    assert r.report["grid"] == [2, 2, 1] and r.mesh.n_faces == 2


# ---------------------------------------------------------------------- the cell-size search
@pytest.mark.parametrize("kind, want", [("target_faces", 400), ("target_faces", 3000), ("target_vertices", 150),
                                        ("target_vertices", 1500)])
def test_target_is_approached(kind, want):
    o3d = pytest.importorskip("open3d")
    m = lodkit.Mesh.from_open3d(o3d.geometry.TriangleMesh.create_torus(1.0, 0.4, 120, 60))
    r = lodkit.cluster(m, **{kind: want})
    got = r.mesh.n_faces if kind == "target_faces" else r.mesh.n_vertices
    assert abs(got - want) <= 0.05 * want
    assert r.stop_reason == kind and r.report["search_steps"] <= 10
    # the same cell size given directly gives the same mesh
    again = lodkit.cluster(m, cell_size=r.cell_size)
    assert np.array_equal(again.mesh.faces, r.mesh.faces)


def test_smaller_cells_keep_more():
    v, f = cube_surface(12)
    counts = [lodkit.cluster(lodkit.Mesh(v, f), cell_size=h).mesh.n_faces for h in (0.4, 0.2, 0.1, 0.05)]
    assert counts == sorted(counts) and counts[0] < counts[-1]


# ---------------------------------------------------------------------- options and errors
@pytest.mark.parametrize("options, message", [
    ({}, "exactly one of"),
    ({"cell_size": 0.1, "target_faces": 10}, "exactly one of"),
    ({"cell_size": 0.0}, "cell_size must be > 0"),
    ({"cell_size": -1.0}, "cell_size must be > 0"),
    ({"cell_size": float("nan")}, "must be finite"),
    ({"cell_size": "big"}, "must be a number"),
    ({"cell_size": True}, "must be a number"),
    ({"cell_size": 1e-30}, "choose a larger cell size"),
    ({"target_faces": 0}, "positive integer"),
    ({"target_vertices": 2.5}, "positive integer"),
    ({"cell_size": 0.1, "representative": "median"}, "representative must be one of"),
])
def test_bad_options_raise_option_error(options, message):
    v, f = cube_surface(2)
    with pytest.raises(OptionError, match=message):
        lodkit.cluster((v, f), **options)


@pytest.mark.parametrize("vertices, faces, message", [
    (np.zeros((3, 3)), np.zeros((0, 3), int), "no faces"),
    (np.eye(3), [[0, 0, 1]], "repeat a vertex index"),
    (np.ones((3, 3)), [[0, 1, 2]], "zero size"),
])
def test_bad_meshes_raise_mesh_error(vertices, faces, message):
    with pytest.raises(MeshError, match=message):
        lodkit.cluster((vertices, faces), cell_size=0.1)


def test_cli_cluster(tmp_path):
    from lodkit.cli import main

    v, f = cube_surface(3)
    src, dst = tmp_path / "cube.ply", tmp_path / "out.ply"
    lodkit.save(lodkit.Mesh(v, f), src)
    assert main(["cluster", str(src), str(dst), "--cell-size", "0.5", "--absolute", "-q",
                 "--representative", "mean"]) == 0
    out = lodkit.load(dst)
    assert out.n_faces == 12
    assert main(["cluster", str(src), str(dst), "--faces", "10", "--cell-size", "0.1"]) == 2


# ---------------------------------------------------------------------- real meshes
@pytest.mark.parametrize("name", ["bunny.ply", "fandisk.obj", "colored_airplane.ply"])
def test_real_meshes(name):
    mesh = lodkit.load(shared_mesh(name))
    for representative in ("quadric", "importance", "mean"):
        r = lodkit.cluster(mesh, target_faces=max(mesh.n_faces // 20, 200), representative=representative)
        check_clean(r, mesh.n_faces)
        assert lodkit.topology(r.mesh).n_degenerate_faces == 0
        assert abs(r.mesh.n_faces - mesh.n_faces // 20) <= 0.1 * (mesh.n_faces // 20)
        assert r.error < 0.1
    if mesh.colors is not None:
        assert r.mesh.colors is not None and (r.mesh.colors >= 0).all() and (r.mesh.colors <= 1).all()


def test_kernel_stub_names_every_function():
    import ast
    import importlib
    from pathlib import Path

    mod = importlib.import_module("lodkit._core.cluster")
    stub = Path(lodkit.__file__).parent / "_core" / "cluster.pyi"
    named = {n.name for n in ast.parse(stub.read_text()).body if isinstance(n, ast.FunctionDef)}
    public = {n for n, o in vars(mod).items() if not n.startswith("_") and callable(o) and n != "np"}
    assert named == public


def test_kernels_reject_bad_labels():
    from lodkit._core.cluster import cell_sums, nearest_vertex

    p = np.zeros((3, 3))
    f = np.array([[0, 1, 2]], dtype=np.int32)
    with pytest.raises(ValueError, match="outside"):
        cell_sums(p, f, np.array([0, 1, 5], dtype=np.int64), 2, True)
    with pytest.raises(ValueError, match="outside"):
        nearest_vertex(p, np.array([0, -1, 0], dtype=np.int64), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="outside"):
        cell_sums(p, np.array([[0, 1, 3]], dtype=np.int32), np.zeros(3, dtype=np.int64), 1, True)
