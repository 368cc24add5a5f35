"""simplify(..., polish=...): the output's vertices fitted to the input surface (lodkit.polish)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lodkit
from lodkit import Mesh, OptionError
from lodkit.cli import main
from lodkit.geometry import face_normals
from lodkit.polish import DEFAULT_ROUNDS, polish_positions, resolve_polish
from test_error_bound import grid


def uv_sphere(n_lon: int = 48, n_lat: int = 24) -> Mesh:
    """A closed unit sphere: poles and n_lat - 1 rings of n_lon vertices."""
    th = np.linspace(0.0, np.pi, n_lat + 1)[1:-1]
    ph = np.linspace(0.0, 2.0 * np.pi, n_lon, endpoint=False)
    ring = np.stack([np.sin(th)[:, None] * np.cos(ph), np.sin(th)[:, None] * np.sin(ph),
                     np.repeat(np.cos(th)[:, None], n_lon, axis=1)], axis=2).reshape(-1, 3)
    V = np.concatenate([[[0.0, 0.0, 1.0]], ring, [[0.0, 0.0, -1.0]]])
    south = len(V) - 1
    F = []
    for j in range(n_lon):
        k = (j + 1) % n_lon
        F.append((0, 1 + j, 1 + k))
        for i in range(n_lat - 2):
            a, b = 1 + i * n_lon + j, 1 + i * n_lon + k
            c, d = a + n_lon, b + n_lon
            F += [(a, c, d), (a, d, b)]
        base = 1 + (n_lat - 2) * n_lon
        F.append((south, base + k, base + j))
    return Mesh(V, np.array(F, dtype=np.int32))


def radial_mean_error(mesh: Mesh, samples: int = 20_000) -> float:
    """The mean distance of the output to the unit sphere over its surface samples, plus
    that of the sphere to the output (Metro's mean, both ways), from lodkit.evaluate."""
    return lodkit.evaluate(uv_sphere(), mesh, samples=samples).distance.mean


def test_resolve_polish():
    assert resolve_polish(False) == 0 and resolve_polish(None) == 0
    assert resolve_polish(True) == DEFAULT_ROUNDS
    assert resolve_polish(2) == 2
    for bad in (-1, 101, 1.5, "yes"):
        with pytest.raises(OptionError, match="polish"):
            resolve_polish(bad)


def test_polish_lowers_the_mean_error_on_a_sphere():
    m = uv_sphere()
    plain = lodkit.simplify(m, target_ratio=0.1)
    pol = lodkit.simplify(m, target_ratio=0.1, polish=True)
    np.testing.assert_array_equal(pol.mesh.faces, plain.mesh.faces)   # only positions change
    rep = pol.report["polish"]
    assert rep["rounds"] == DEFAULT_ROUNDS and rep["moved_vertices"] > 0.5 * pol.mesh.n_vertices
    assert rep["mean_distance_after"] < 0.9 * rep["mean_distance_before"]
    assert plain.report["polish"] is None
    # measured independently (Metro both ways): lower by at least a tenth
    assert radial_mean_error(pol.mesh) < 0.9 * radial_mean_error(plain.mesh)
    # vertices move outwards (chords of a convex surface belong outside it): the mean radius grows
    assert np.linalg.norm(pol.mesh.vertices, axis=1).mean() > np.linalg.norm(plain.mesh.vertices, axis=1).mean()


def test_polish_moves_nothing_on_an_exact_plane():
    """A flat input is fitted exactly by any flat output: the first round finds every
    sample at distance 0 and stops; nothing moves."""
    rng = np.random.default_rng(1)
    m = grid(21)
    inner = (m.vertices[:, 0] > 0) & (m.vertices[:, 0] < 1) & (m.vertices[:, 1] > 0) & (m.vertices[:, 1] < 1)
    V = m.vertices.copy()
    V[inner, :2] += rng.uniform(-0.01, 0.01, size=(inner.sum(), 2))
    m = Mesh(V, m.faces)
    plain = lodkit.simplify(m, target_ratio=0.2)
    pol = lodkit.simplify(m, target_ratio=0.2, polish=True)
    assert pol.report["polish"]["moved_vertices"] == 0 and pol.report["polish"]["rounds"] == 0
    # exact: nothing moved, so the run's positions are kept bit for bit
    np.testing.assert_array_equal(pol.mesh.vertices, plain.mesh.vertices)


def test_polish_keeps_the_border_of_a_curved_sheet_exact():
    """An open curved sheet: the interior moves (and gets closer), the border stays bit for bit."""
    xs = np.linspace(0.0, 1.0, 41)
    z = 0.3 * np.sin(3 * xs)[:, None] * np.cos(2 * xs)[None, :]
    m = grid(41, z)
    plain = lodkit.simplify(m, target_ratio=0.1)
    pol = lodkit.simplify(m, target_ratio=0.1, polish=True)
    on_border = np.isin(np.arange(pol.mesh.n_vertices), _border_vertices(pol.mesh.faces))
    assert pol.report["polish"]["moved_vertices"] > 0.5 * (~on_border).sum()
    # exact: boundary vertices are held, not moved and written back
    np.testing.assert_array_equal(pol.mesh.vertices[on_border], plain.mesh.vertices[on_border])
    e0 = lodkit.evaluate(m, plain.mesh, samples=20_000).distance.mean
    e1 = lodkit.evaluate(m, pol.mesh, samples=20_000).distance.mean
    assert e1 < e0


def _border_vertices(F) -> np.ndarray:
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    u, c = np.unique(e, axis=0, return_counts=True)
    return np.unique(u[c == 1])


def test_polish_leaves_locked_vertices_where_they_are():
    m = uv_sphere()
    locked = np.arange(0, m.n_vertices, 7)
    pol = lodkit.simplify(m, target_ratio=0.2, locked=locked, polish=True)
    keep = np.isin(pol.vertex_map, locked)
    assert keep.sum() == locked.size
    # exact: a locked vertex keeps its input position bit for bit
    np.testing.assert_array_equal(pol.mesh.vertices[keep], m.vertices[pol.vertex_map[keep]])


def test_polish_holds_coincident_vertices_and_the_fixed_mask():
    """Two closed parts meeting at a point through two copies of one position (no border
    anywhere): both copies stay, and so does a vertex marked fixed; the rest move back to
    the input."""
    from lodkit.polish import _edge_neighbours, _fixed_vertices
    a = uv_sphere(16, 8)
    b = Mesh(a.vertices + [0.0, 0.0, 2.0], a.faces)              # touches a's north pole with its south
    V = np.concatenate([a.vertices, b.vertices])
    F = np.concatenate([a.faces, b.faces + a.n_vertices]).astype(np.int64)
    north, south = 0, a.n_vertices + (b.n_vertices - 1)
    assert np.allclose(V[north], V[south])
    V[south] = V[north]                                          # exactly one position
    _, border = _edge_neighbours(F, len(V))
    assert not border.any()
    held = _fixed_vertices(V, F, np.zeros(len(V), dtype=bool), border)
    assert set(np.flatnonzero(held)) == {north, south}
    fixed = np.zeros(len(V), dtype=bool)
    fixed[9] = True
    Vs = V * 1.02                                                # an output "off" the input
    Vs[south] = Vs[north]
    out, rep = polish_positions(V, F, Vs, F, fixed)
    # exact: held vertices are copied, not recomputed
    np.testing.assert_array_equal(out[[north, south, 9]], Vs[[north, south, 9]])
    assert rep["held_vertices"] == 3 and rep["moved_vertices"] > 0
    free = np.setdiff1d(np.arange(len(V)), [north, south, 9])
    d0 = np.abs(np.linalg.norm(Vs[free] - np.where(free[:, None] < a.n_vertices, 0.0, [0, 0, 2.0]), axis=1) - 1)
    d1 = np.abs(np.linalg.norm(out[free] - np.where(free[:, None] < a.n_vertices, 0.0, [0, 0, 2.0]), axis=1) - 1)
    assert d1.mean() < 0.5 * d0.mean()


def test_polish_is_deterministic_and_thread_independent():
    m = uv_sphere(40, 20)
    a = lodkit.simplify(m, target_ratio=0.1, polish=True, threads=1)
    b = lodkit.simplify(m, target_ratio=0.1, polish=True, threads=2)
    c = lodkit.simplify(m, target_ratio=0.1, polish=True, threads=2)
    np.testing.assert_array_equal(a.mesh.vertices, b.mesh.vertices)
    np.testing.assert_array_equal(b.mesh.vertices, c.mesh.vertices)


def test_polish_refused_with_the_error_bound():
    with pytest.raises(OptionError, match="polish"):
        lodkit.simplify(uv_sphere(16, 8), max_error=0.01, error="hausdorff", polish=True)


def test_polish_rounds_zero_is_plain():
    m = uv_sphere(24, 12)
    a = lodkit.simplify(m, target_ratio=0.2)
    b = lodkit.simplify(m, target_ratio=0.2, polish=0)
    np.testing.assert_array_equal(a.mesh.vertices, b.mesh.vertices)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), ratio=st.sampled_from([0.05, 0.1, 0.3]))
def test_polish_turns_no_face_over(seed, ratio):
    """On bumpy closed surfaces: same faces, no face turned by more than the step's limit
    (cosine 0.7, ~45 degrees) from the unpolished output over all rounds together,
    positions finite."""
    rng = np.random.default_rng(seed)
    m = uv_sphere(24, 12)
    V = m.vertices * (1.0 + 0.15 * rng.standard_normal((m.n_vertices, 1)))
    m = Mesh(V, m.faces)
    plain = lodkit.simplify(m, target_ratio=ratio)
    pol = lodkit.simplify(m, target_ratio=ratio, polish=True)
    np.testing.assert_array_equal(pol.mesh.faces, plain.mesh.faces)
    assert np.isfinite(pol.mesh.vertices).all()
    n0, a0 = face_normals(plain.mesh.vertices, plain.mesh.faces)
    n1, _ = face_normals(pol.mesh.vertices, pol.mesh.faces)
    live = a0 > 0
    # the step checks in normalised units: a little slack for the rounding of the scaling
    assert np.einsum("ij,ij->i", n0[live], n1[live]).min() > 0.7 - 1e-6


def test_cli_polish(tmp_path):
    src = tmp_path / "sphere.ply"
    lodkit.save(uv_sphere(), str(src))
    out = tmp_path / "out.ply"
    assert main(["simplify", str(src), str(out), "--ratio", "0.2", "--polish", "--quiet"]) == 0
    plain = tmp_path / "plain.ply"
    assert main(["simplify", str(src), str(plain), "--ratio", "0.2", "--quiet"]) == 0
    a, b = lodkit.load(str(out)), lodkit.load(str(plain))
    assert a.n_faces == b.n_faces > 0 and np.any(a.vertices != b.vertices)
    bad = tmp_path / "bad.ply"
    assert main(["simplify", str(src), str(bad), "--max-distance", "1%", "--polish", "--quiet"]) == 2
    assert not bad.exists()


def test_edge_neighbours():
    from lodkit.polish import _edge_neighbours
    F = np.array([[0, 1, 2], [2, 1, 3], [0, 2, 4], [0, 2, 5]])
    # edge (0, 2) has three faces: non-manifold, each face keeps itself there
    across, border = _edge_neighbours(F)
    np.testing.assert_array_equal(across, [[0, 1, 0], [0, 1, 1], [2, 2, 2], [3, 3, 3]])
    # borders: (0, 1), (1, 3), (3, 2), (2, 4), (4, 0), (2, 5), (5, 0); (0, 2) is not one (three faces)
    np.testing.assert_array_equal(border, [True] * 6)
    across, border = _edge_neighbours(F[:3], 6)
    np.testing.assert_array_equal(across, [[0, 1, 2], [0, 1, 1], [0, 2, 2]])
    np.testing.assert_array_equal(border, [True, True, True, True, True, False])


def test_polish_keeps_uv_seams_closed_and_attributes():
    """spot (shared mesh, UV seams as coincident copies): the seam copies stay together and the
    attributes are the run's; the mean error drops."""
    from conftest import shared_mesh
    m = lodkit.load(str(shared_mesh("spot_triangulated.obj")))
    plain = lodkit.simplify(m, target_ratio=0.1, metric="appearance")
    pol = lodkit.simplify(m, target_ratio=0.1, metric="appearance", polish=True)
    np.testing.assert_array_equal(pol.mesh.faces, plain.mesh.faces)
    np.testing.assert_array_equal(pol.mesh.uvs, plain.mesh.uvs)
    V0, V1 = plain.mesh.vertices, pol.mesh.vertices
    _, inv, cnt = np.unique(V0, axis=0, return_inverse=True, return_counts=True)
    seam = cnt[inv.ravel()] > 1
    assert seam.sum() > 0
    # exact: seam copies are held, so they keep the run's position
    np.testing.assert_array_equal(V1[seam], V0[seam])
    e0 = lodkit.evaluate(m, plain.mesh, samples=50_000).distance.mean
    e1 = lodkit.evaluate(m, pol.mesh, samples=50_000).distance.mean
    assert e1 < e0


@pytest.mark.parametrize("kw", [{"operator": "triangle"}, {"metric": "schroeder"}, {"driver": "greedy"}])
def test_polish_after_every_operator_and_driver(kw):
    m = uv_sphere(32, 16)
    plain = lodkit.simplify(m, target_ratio=0.2, **kw)
    pol = lodkit.simplify(m, target_ratio=0.2, polish=True, **kw)
    np.testing.assert_array_equal(pol.mesh.faces, plain.mesh.faces)
    assert pol.report["polish"]["moved_vertices"] > 0
    assert radial_mean_error(pol.mesh) < radial_mean_error(plain.mesh)


def test_polish_open3d_in_open3d_out():
    import open3d as o3d
    m = uv_sphere(24, 12)
    t = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(m.vertices), o3d.utility.Vector3iVector(m.faces))
    out = lodkit.simplify(t, target_ratio=0.3, polish=True).mesh
    plain = lodkit.simplify(t, target_ratio=0.3).mesh
    assert isinstance(out, o3d.geometry.TriangleMesh) and len(out.triangles) > 0
    np.testing.assert_array_equal(np.asarray(out.triangles), np.asarray(plain.triangles))
    assert np.any(np.asarray(out.vertices) != np.asarray(plain.vertices))


def test_polish_sums_refuses_out_of_range_faces():
    from lodkit._core.retile import polish_sums
    X = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2]], dtype=np.int64)
    N = np.array([[0.0, 0, 1]])
    P = np.array([[0.2, 0.2, 0.1]])
    across = np.zeros((1, 3), dtype=np.int64)
    out = polish_sums(P, N, X, F, N, np.zeros(1, dtype=np.int64), across, False, 0.1)
    assert out[-1] == 1 and out[0] == pytest.approx(0.1)
    with pytest.raises(ValueError, match="out of range"):
        polish_sums(P, N, X, F, N, np.array([4294967295], dtype=np.int64), across, False, 0.1)


def test_polish_mesh_on_a_progressive_level_and_another_tools_output():
    """lodkit.polish_mesh: a progressive mesh's level and a plain (V, F) result polish as
    simplify(polish=True) does; locked indices stay; bad input is a lodkit error."""
    m = uv_sphere()
    pm = lodkit.progressive(m)
    level = pm.at(ratio=0.1)
    res = lodkit.polish_mesh(m, level)
    np.testing.assert_array_equal(res.mesh.faces, level.faces)
    assert radial_mean_error(res.mesh) < 0.9 * radial_mean_error(level)
    assert res.report["rounds"] == DEFAULT_ROUNDS
    # the same step as simplify's: simplify(polish=True) equals polishing its plain output
    plain = lodkit.simplify(m, target_ratio=0.1)
    pol = lodkit.simplify(m, target_ratio=0.1, polish=True)
    np.testing.assert_array_equal(lodkit.polish_mesh(m, plain.mesh).mesh.vertices, pol.mesh.vertices)
    # a (V, F) tuple in, one out; locked vertices keep their bits
    V, F = plain.mesh.vertices, plain.mesh.faces
    out_V, out_F = lodkit.polish_mesh((m.vertices, m.faces), (V, F), locked=[0, 1, 2]).mesh
    # exact: held vertices are copied
    np.testing.assert_array_equal(out_V[:3], V[:3])
    assert np.any(out_V != V)
    with pytest.raises(OptionError, match="polish"):
        lodkit.polish_mesh(m, plain.mesh, rounds=-1)
    with pytest.raises(lodkit.MeshError):
        lodkit.polish_mesh(m, (V, np.zeros((0, 3), dtype=np.int64)))


def test_polish_of_a_zero_area_input_is_the_plain_run():
    """Four collinear points as a closed tetrahedron: no surface to fit to; the run is the
    plain one, not an error."""
    V = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]])
    F = np.array([[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]])
    plain = lodkit.simplify(Mesh(V, F), target_faces=2)
    pol = lodkit.simplify(Mesh(V, F), target_faces=2, polish=True)
    np.testing.assert_array_equal(pol.mesh.vertices, plain.mesh.vertices)
    assert pol.report["polish"]["rounds"] == 0


_BLAS_RUN = """
import hashlib, sys, numpy as np, lodkit
sys.path.insert(0, {tests!r})
from test_polish import uv_sphere
m = uv_sphere(200, 100)
rng = np.random.default_rng(0)
m = lodkit.Mesh(m.vertices * (1 + 0.01 * rng.standard_normal((m.n_vertices, 1))), m.faces)
r = lodkit.simplify(m, target_ratio=0.3, polish=True, threads=1)
print(hashlib.sha256(np.ascontiguousarray(r.mesh.vertices).tobytes()).hexdigest())
"""


def test_polish_is_the_same_for_any_blas_thread_count(tmp_path):
    """The solve's reductions are numpy's own sums, not BLAS dot products (which OpenBLAS
    splits over its threads): the same bits with one and with two BLAS threads, on a system
    large enough for OpenBLAS to split (20k unknowns)."""
    import subprocess
    import sys
    from pathlib import Path

    from conftest import lodkit_subprocess_env
    code = _BLAS_RUN.format(tests=str(Path(__file__).resolve().parent))
    out = []
    for n in ("1", "2"):
        env = lodkit_subprocess_env(OPENBLAS_NUM_THREADS=n, OMP_NUM_THREADS=n, MKL_NUM_THREADS=n)
        res = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                             timeout=300)
        assert res.returncode == 0, res.stderr[-2000:]
        out.append(res.stdout.strip().splitlines()[-1])
    assert out[0] == out[1]
