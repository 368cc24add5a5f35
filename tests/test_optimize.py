"""lodkit.optimize (Hoppe et al. 1993): the energy never increases across iterations; an
already optimal mesh (a tetrahedron sampled exactly) stays in place; improving a QEM start;
reaching a vertex count by annealing c_rep; options and errors."""
from __future__ import annotations

import numpy as np
import open3d as o3d
import pytest

import lodkit
from lodkit import MeshError, OptionError
from lodkit.geometry import weld_positions
from lodkit.optimize import closest_on_segments, optimize


def sphere(res: int = 14) -> lodkit.Mesh:
    s = o3d.geometry.TriangleMesh.create_sphere(1.0, res)
    return lodkit.Mesh(*weld_positions(np.asarray(s.vertices), np.asarray(s.triangles)))


def bumpy_sphere() -> lodkit.Mesh:
    m = sphere(20)
    v = m.vertices * (1.0 + 0.15 * np.sin(3 * m.vertices[:, [0]]) * np.cos(2 * m.vertices[:, [1]]))
    return lodkit.Mesh(v, m.faces)


def tetrahedron() -> lodkit.Mesh:
    v = np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    f = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])
    return lodkit.Mesh(v, f)


def test_energy_never_increases():
    src = bumpy_sphere()
    start = lodkit.simplify(src, target_faces=120).mesh
    r = optimize(src, start=start, iterations=4, c_rep=1e-4, samples=3000)
    e = [row["E"] for row in r.energy]
    assert len(e) == 5
    for a, b in zip(e, e[1:]):
        assert b <= a + 1e-12 * e[0]
    assert e[-1] < e[0]
    # each row's parts add up to its E
    for row in r.energy:
        assert row["E"] == pytest.approx(row["E_dist"] + row["E_crease"] + row["E_rep"] + row["E_spring"],
                                         rel=1e-12)


def cylinder() -> lodkit.Mesh:
    """A closed cylinder (radius 1, height 1.5): two 90-degree crease circles between the
    curved side and the flat caps."""
    c = o3d.geometry.TriangleMesh.create_cylinder(1.0, 1.5, resolution=48, split=8)
    return lodkit.Mesh(*weld_positions(np.asarray(c.vertices), np.asarray(c.triangles)))


def rim_points(n: int = 400) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return np.concatenate([np.stack([np.cos(t), np.sin(t), np.full_like(t, z)], axis=1) for z in (-0.75, 0.75)])


def edge_distance(P, mesh) -> np.ndarray:
    """Distance of each point to the closest edge of the mesh."""
    F = mesh.faces
    e = np.unique(np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0)
    return np.sqrt(closest_on_segments(P, mesh.vertices[e[:, 0]], mesh.vertices[e[:, 1]])[2])


def test_creases_stay_sharp_and_energy_never_increases():
    src = cylinder()
    start = lodkit.simplify(src, target_faces=100).mesh
    rim = rim_points()
    before = edge_distance(rim, start).max()
    r = optimize(src, start=start, iterations=3, c_rep=1e-4, samples=4000)
    assert r.n_crease_samples > 0 and r.report["sharp_edges"] > 0
    # the crease circles stay polylines of mesh edges: every rim point is within the start's
    # largest distance (0.012 here: the chords' sagitta) of an edge of the result
    assert edge_distance(rim, r.mesh).max() <= 1.05 * before
    e = [row["E"] for row in r.energy]
    for a, b in zip(e, e[1:]):
        assert b <= a + 1e-12 * e[0]
    assert r.energy[-1]["E_crease"] < r.energy[0]["E_crease"]
    for row in r.energy:
        assert row["E"] == pytest.approx(row["E_dist"] + row["E_crease"] + row["E_rep"] + row["E_spring"],
                                         rel=1e-12)
    t = lodkit.topology(r.mesh)
    assert t.is_manifold and t.genus == 0


def test_no_creases_on_a_smooth_mesh():
    src = bumpy_sphere()
    start = lodkit.simplify(src, target_faces=120).mesh
    a = optimize(src, start=start, iterations=2, samples=2000)
    b = optimize(src, start=start, iterations=2, samples=2000, creases=None)
    assert a.n_crease_samples == 0 and a.report["sharp_edges"] == 0
    np.testing.assert_allclose(a.mesh.vertices, b.mesh.vertices, rtol=0, atol=0)   # two runs, one machine
    np.testing.assert_array_equal(a.mesh.faces, b.mesh.faces)


def test_closest_on_segments():
    A = np.array([[0.0, 0, 0], [0, 0, 1]])
    B = np.array([[1.0, 0, 0], [0, 1, 1]])
    X = np.array([[0.5, 1.0, 0], [-1.0, 0, 0], [0, 0.25, 2.0]])
    seg, t, d2 = closest_on_segments(X, A, B)
    np.testing.assert_array_equal(seg, [0, 0, 1])
    np.testing.assert_allclose(t, [0.5, 0.0, 0.25])
    np.testing.assert_allclose(d2, [1.0, 1.0, 1.0])


def test_optimal_tetrahedron_stays_in_place():
    tet = tetrahedron()
    r = optimize(tet, iterations=3, samples=2000)
    out = r.mesh
    assert out.n_vertices == 4 and out.n_faces == 4
    # the same corners (up to the spring's pull, ~1e-8 here) and the same faces
    order = [int(np.argmin(np.linalg.norm(tet.vertices - p, axis=1))) for p in out.vertices]
    assert sorted(order) == [0, 1, 2, 3]
    np.testing.assert_allclose(out.vertices, tet.vertices[order], atol=1e-5)
    mapped = {tuple(sorted(order[i] for i in f)) for f in out.faces}
    assert mapped == {tuple(sorted(f)) for f in tet.faces.tolist()}
    assert r.moves == {"collapse": 0, "split": 0, "swap": 0}
    assert r.energy[-1]["E_dist"] < 1e-12


def test_improves_a_qem_start():
    src = bumpy_sphere()
    start = lodkit.simplify(src, target_faces=150).mesh
    r = optimize(src, start=start, n_vertices=start.n_vertices, iterations=3, samples=4000)
    before = lodkit.evaluate(src, start, samples=20000).distance
    after = lodkit.evaluate(src, r.mesh, samples=20000).distance
    assert after.mean < before.mean
    t = lodkit.topology(r.mesh)
    assert t.is_manifold and t.genus == 0


def test_n_vertices_anneals_c_rep():
    src = bumpy_sphere()
    start = lodkit.simplify(src, target_faces=300).mesh       # ~150 vertices
    r = optimize(src, start=start, n_vertices=110, iterations=6, samples=3000)
    assert abs(r.mesh.n_vertices - 110) <= 0.05 * 110
    assert r.moves["collapse"] > 0
    assert r.energy[-1]["c_rep"] > r.energy[0]["c_rep"]


def test_open3d_in_out_and_defaults():
    src = sphere(8)
    r = optimize(src.to_open3d(), n_vertices=30, iterations=1, samples=1000)
    assert isinstance(r.mesh, o3d.geometry.TriangleMesh)
    assert r.n_samples == 1000


def test_options_and_errors():
    src = tetrahedron()
    with pytest.raises(OptionError, match="n_vertices"):
        optimize(src, n_vertices=2)
    with pytest.raises(OptionError, match="c_rep"):
        optimize(src, c_rep=-1)
    with pytest.raises(OptionError, match="spring"):
        optimize(src, spring=float("nan"))
    with pytest.raises(OptionError, match="iterations"):
        optimize(src, iterations=-1)
    with pytest.raises(OptionError, match="samples"):
        optimize(src, samples=0)
    with pytest.raises(OptionError, match="creases"):
        optimize(src, creases=-1)
    with pytest.raises(OptionError, match="creases"):
        optimize(src, creases=180)
    with pytest.raises(MeshError):
        optimize(lodkit.Mesh(np.zeros((3, 3)), [[0, 1, 2]]))
