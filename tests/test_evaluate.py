"""lodkit.evaluate: Metro-style distances, normal deviation, quality, topology, colour error.

Expected values are exact where the geometry makes them exact (identical meshes, a
translated plane, a subset of a mesh, constant colour offsets), analytic with a derived
tolerance where they are not (a sphere against a scaled copy), and checked against a slow
brute-force point-to-triangle distance on small meshes.
"""
from __future__ import annotations

import io
import json
import math
from contextlib import redirect_stdout

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("open3d")

import lodkit  # noqa: E402
from conftest import shared_mesh  # noqa: E402
from lodkit.cli import main  # noqa: E402
from lodkit.errors import MeshError, MeshIOError, OptionError  # noqa: E402
from lodkit.evaluate import QUALITY_BINS, Evaluator, evaluate, sample_surface, triangle_quality  # noqa: E402


# ---------------------------------------------------------------------- meshes
def square_grid(n: int, size: float = 1.0):
    """The square [0, size]^2 at z = 0 as an n x n grid of quads, two triangles each, normals +z."""
    xs, ys = np.meshgrid(np.linspace(0, size, n + 1), np.linspace(0, size, n + 1))
    V = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], axis=1)
    F = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            F += [[a, a + 1, a + n + 2], [a, a + n + 2, a + n + 1]]
    return V, np.array(F)


def icosphere(level: int):
    """Unit icosphere: the icosahedron, each triangle split in four ``level`` times, vertices
    pushed onto the unit sphere; outward normals."""
    t = (1 + 5 ** 0.5) / 2
    V = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    F = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    V = [np.array(v, dtype=float) / np.linalg.norm(v) for v in V]
    for _ in range(level):
        mid, out = {}, []

        def middle(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                m = V[a] + V[b]
                V.append(m / np.linalg.norm(m))
                mid[key] = len(V) - 1
            return mid[key]

        for a, b, c in F:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            out += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        F = out
    return np.array(V), np.array(F)


def torus(nu: int = 12, nv: int = 8, R: float = 1.0, r: float = 0.4):
    u = 2 * np.pi * np.arange(nu) / nu
    w = 2 * np.pi * np.arange(nv) / nv
    uu, ww = np.meshgrid(u, w)
    V = np.stack([(R + r * np.cos(ww)) * np.cos(uu), (R + r * np.cos(ww)) * np.sin(uu), r * np.sin(ww)],
                 axis=-1).reshape(-1, 3)
    idx = lambda j, i: (j % nv) * nu + i % nu  # noqa: E731
    F = []
    for j in range(nv):
        for i in range(nu):
            a, b, c, d = idx(j, i), idx(j, i + 1), idx(j + 1, i + 1), idx(j + 1, i)
            F += [[a, b, c], [a, c, d]]
    return V, np.array(F)


def inradius(V, F) -> float:
    """Smallest distance from the origin to a face plane (a lower bound on |x| over the surface)."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return float(np.abs(np.einsum("ij,ij->i", n, a)).min())


# Embree finds the closest triangle in single precision: between two triangles whose
# distances differ by less than the float32 rounding of the coordinates it may pick either,
# so a distance can exceed the true one by about 2^-24 of the model's size. Distances are
# checked to 1e-7 of the bounding-box diagonal where they are not exact by construction.
EPS32 = 1e-7

def max_vertex_fan_angle(V, F) -> float:
    """The largest angle (degrees) between the normals of two faces sharing a vertex."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    vert = F.reshape(-1)
    order = np.argsort(vert, kind="stable")
    vert, face = vert[order], np.repeat(np.arange(len(F)), 3)[order]
    worst = 0.0
    for k in range(1, int(np.bincount(vert).max())):       # pairs k apart in one vertex's run
        same = vert[k:] == vert[:-k]
        cos = np.einsum("ij,ij->i", n[face[k:][same]], n[face[:-k][same]])
        worst = max(worst, float(np.degrees(np.arccos(np.clip(cos, -1, 1))).max()))
    return worst


DIST_FIELDS = ("hausdorff", "mean", "rms", "hausdorff_fwd", "mean_fwd", "rms_fwd",
               "hausdorff_bwd", "mean_bwd", "rms_bwd")


# ---------------------------------------------------------------------- exact cases
def test_identical_meshes_give_exactly_zero():
    V, F = icosphere(3)
    C = np.random.default_rng(0).random((len(V), 3))
    m = lodkit.Mesh(V, F, colors=C)
    ev = evaluate(m, m.copy(), samples=20_000)
    for name in DIST_FIELDS:
        assert getattr(ev.distance, name) == 0.0, name
        assert getattr(ev.distance_model, name) == 0.0, name
    n = ev.normal_deviation
    assert (n.mean, n.max, n.p95, n.max_fwd, n.max_bwd, n.n_skipped) == (0.0, 0.0, 0.0, 0.0, 0.0, 0)
    assert (ev.color.rms, ev.color.max, ev.color.mean_abs) == (0.0, 0.0, 0.0)
    assert all(v == 0 for k, v in ev.topology_changes.items())
    assert ev.quality_original == ev.quality_simplified


def test_identical_real_mesh_gives_exactly_zero():
    path = shared_mesh("bunny.ply")
    ev = evaluate(path, lodkit.load(path), samples=20_000)
    assert all(getattr(ev.distance, name) == 0.0 for name in DIST_FIELDS)
    assert ev.normal_deviation.max == 0.0
    assert ev.topology_original.n_boundary_loops == ev.topology_simplified.n_boundary_loops == 5


def test_translated_plane():
    V, F = square_grid(8)
    t = 0.0625
    ev = evaluate((V, F), (V + [0.0, 0.0, t], F), samples=5000)
    diag = math.sqrt(2.0)
    assert ev.diagonal == pytest.approx(diag, rel=1e-15)
    for name in DIST_FIELDS:
        # every foot of perpendicular lands inside the other square: all distances are t, to
        # within the single-precision closest-triangle search (EPS32 of the diagonal)
        assert getattr(ev.distance, name) == pytest.approx(t / diag, abs=EPS32), name
        assert getattr(ev.distance_model, name) == pytest.approx(t, abs=EPS32 * diag), name
    assert ev.normal_deviation.max == 0.0


def test_flipped_copy_has_180_degree_normal_deviation():
    V, F = square_grid(4)
    ev = evaluate((V, F), (V, F[:, ::-1]), samples=2000)
    assert ev.distance.hausdorff == 0.0                    # the same triangles
    assert ev.normal_deviation.mean == pytest.approx(180.0)
    assert ev.normal_deviation.p95 == pytest.approx(180.0)


def test_one_sided_distances_of_a_subset():
    """B = the left half of the square A. Samples on B lie on A (distance 0 exactly); a
    sample (x, y) on A is x - 1/2 away from B when x > 1/2 and on it otherwise."""
    V, F = square_grid(10)
    left = F[V[F].mean(axis=1)[:, 0] < 0.5]
    n, seed = 20_000, 7
    ev = evaluate((V, F), (V, left), samples=n, seed=seed)
    diag = math.sqrt(2.0)
    assert (ev.distance.hausdorff_bwd, ev.distance.mean_bwd, ev.distance.rms_bwd) == (0.0, 0.0, 0.0)

    # by hand, from the same samples (the original is sampled with default_rng(seed))
    P, _, _ = sample_surface(V, F, n, seed)
    d = np.maximum(P[:, 0] - 0.5, 0.0)
    assert ev.distance_model.hausdorff_fwd == pytest.approx(d.max(), rel=1e-9)
    assert ev.distance_model.mean_fwd == pytest.approx(d.mean(), rel=1e-9)
    assert ev.distance_model.rms_fwd == pytest.approx(math.sqrt(np.mean(d * d)), rel=1e-9)
    # symmetric values: the larger maximum, the mean and RMS over both sample sets
    assert ev.distance.hausdorff == ev.distance.hausdorff_fwd
    assert ev.distance.mean == pytest.approx(0.5 * ev.distance.mean_fwd, rel=1e-12)
    assert ev.distance.rms == pytest.approx(ev.distance.rms_fwd / math.sqrt(2), rel=1e-12)

    # and the analytic values for a uniform point on the unit square: E[d] = 1/8,
    # E[d^2] = 1/24, max d -> 1/2; tolerance 5 standard errors of the sample mean
    sd = math.sqrt(1 / 24 - 1 / 64)
    assert ev.distance_model.mean_fwd == pytest.approx(1 / 8, abs=5 * sd / math.sqrt(n))
    assert ev.distance_model.rms_fwd ** 2 == pytest.approx(1 / 24, abs=5 * 0.05 / math.sqrt(n))
    assert 0.49 < ev.distance_model.hausdorff_fwd <= 0.5
    assert ev.distance.hausdorff == pytest.approx(ev.distance_model.hausdorff / diag, rel=1e-12)


@pytest.mark.parametrize("s", [1.05, 0.95])
def test_sphere_against_scaled_copy(s):
    """Unit icosphere P (vertices on the unit sphere) against sP.

    P lies in the unit ball and contains the ball of radius r_in (its smallest face-plane
    distance), so every point of either surface is within |s - 1| of the other (move it
    radially) and at least s r_in - 1 (s > 1) or r_in - s (s < 1) away from it. Hausdorff,
    mean and RMS, both directions, lie in that interval: |s - 1| r = |s - 1| for r = 1, to
    within the tessellation's sagitta 1 - r_in (here 3e-4)."""
    V, F = icosphere(5)
    r_in = inradius(V, F)
    assert 0.9996 < r_in < 1.0
    lo, hi = (s * r_in - 1.0, s - 1.0) if s > 1 else (r_in - s, 1.0 - s)
    ev = evaluate((V, F), (s * V, F), samples=50_000)
    for name in DIST_FIELDS:
        value = getattr(ev.distance_model, name)
        assert lo - 1e-12 <= value <= hi + 1e-12, (name, value, lo, hi)
    assert ev.distance.hausdorff == pytest.approx(abs(s - 1.0) / ev.diagonal, rel=(1 - r_in) * s / abs(s - 1) + 1e-9)
    # a scaled copy has the same normals, but a sample near a vertex of one surface can have
    # its closest point on a neighbouring face of the other: the largest angle between two
    # faces sharing a vertex bounds the deviation, and most samples see none
    assert ev.normal_deviation.p95 < 1e-9
    assert 0 < ev.normal_deviation.max <= max_vertex_fan_angle(V, F) + 1e-9
    assert ev.topology_changes["genus"] == 0


# ---------------------------------------------------------------------- against a slow reference
def _brute_distance(P, V, F):
    """Distance from each point to the nearest triangle: projection onto the plane when the
    foot is inside the triangle, otherwise the nearest of the three edges (loops, slow)."""
    out = np.full(len(P), np.inf)
    for a, b, c in V[F]:
        n = np.cross(b - a, c - a)
        area2 = np.linalg.norm(n)
        n = n / area2
        h = (P - a) @ n
        foot = P - h[:, None] * n
        # barycentric signs of the foot
        inside = np.ones(len(P), dtype=bool)
        for x, y in ((a, b), (b, c), (c, a)):
            inside &= (np.cross(y - x, foot - x) @ n) >= 0
        d = np.where(inside, np.abs(h), np.inf)
        for x, y in ((a, b), (b, c), (c, a)):
            e = y - x
            t = np.clip((P - x) @ e / (e @ e), 0, 1)
            d = np.minimum(d, np.linalg.norm(P - (x + t[:, None] * e), axis=1))
        out = np.minimum(out, d)
    return out


def test_matches_brute_force_reference():
    rng = np.random.default_rng(5)
    V, F = icosphere(1)
    A = V * (1 + rng.uniform(-0.1, 0.1, (len(V), 1)))
    B = V * (1 + rng.uniform(-0.1, 0.1, (len(V), 1))) + [0.03, -0.02, 0.01]
    n, seed = 3000, 11
    ev = evaluate((A, F), (B, F), samples=n, seed=seed)
    d_fwd = _brute_distance(sample_surface(A, F, n, seed)[0], B, F)
    d_bwd = _brute_distance(sample_surface(B, F, n, seed + 1)[0], A, F)
    dm = ev.distance_model
    # Embree picks the closest triangle in single precision; the distance to it is exact
    assert dm.hausdorff_fwd == pytest.approx(d_fwd.max(), rel=1e-6)
    assert dm.hausdorff_bwd == pytest.approx(d_bwd.max(), rel=1e-6)
    assert dm.mean_fwd == pytest.approx(d_fwd.mean(), rel=1e-6)
    assert dm.mean_bwd == pytest.approx(d_bwd.mean(), rel=1e-6)
    assert dm.rms == pytest.approx(math.sqrt(np.mean(np.r_[d_fwd, d_bwd] ** 2)), rel=1e-6)


# ---------------------------------------------------------------------- colour
def test_colour_error_of_a_constant_offset():
    V, F = square_grid(6)
    C = np.full((len(V), 3), 0.5)
    offset = np.array([10.0, -20.0, 5.0]) / 255.0
    ev = evaluate(lodkit.Mesh(V, F, colors=C), lodkit.Mesh(V, F, colors=C + offset), samples=5000)
    # every sample differs by (10, -20, 5): RMS over channels sqrt((100 + 400 + 25) / 3)
    assert ev.color.rms == pytest.approx(math.sqrt(525 / 3), rel=1e-12)
    assert ev.color.rms_fwd == pytest.approx(math.sqrt(525 / 3), rel=1e-12)
    assert ev.color.mean_abs == pytest.approx(35 / 3, rel=1e-12)
    assert ev.color.max == pytest.approx(20.0, rel=1e-12)


def test_colour_error_of_a_linear_recolouring():
    """Recolour by c1 = c0 + k x: linear colours interpolate exactly, so a sample at x
    differs by 255 k x in each channel; its RMS is 255 k sqrt(mean x^2) over the samples
    (and 255 k / sqrt(3) for uniform x in [0, 1])."""
    V, F = square_grid(6)
    C0 = np.column_stack([np.full(len(V), 0.2), 0.1 + 0.3 * V[:, 1], np.full(len(V), 0.4)])
    k = 0.5
    C1 = C0 + k * V[:, [0]]
    n, seed = 20_000, 3
    ev = evaluate(lodkit.Mesh(V, F, colors=C0), lodkit.Mesh(V, F, colors=C1), samples=n, seed=seed)
    x_fwd = sample_surface(V, F, n, seed)[0][:, 0]
    x_bwd = sample_surface(V, F, n, seed + 1)[0][:, 0]
    assert ev.color.rms_fwd == pytest.approx(255 * k * math.sqrt(np.mean(x_fwd ** 2)), rel=1e-9)
    assert ev.color.rms_bwd == pytest.approx(255 * k * math.sqrt(np.mean(x_bwd ** 2)), rel=1e-9)
    assert ev.color.rms == pytest.approx(255 * k / math.sqrt(3), rel=0.01)
    assert ev.color.max == pytest.approx(255 * k * max(x_fwd.max(), x_bwd.max()), rel=1e-9)


def test_colour_error_across_different_meshes():
    """A coarse and a fine grid of the same square, both coloured by the same linear
    function of position: the colour error is 0 up to rounding."""
    Vf, Ff = square_grid(12)
    Vc, Fc = square_grid(3)
    lin = lambda V: np.column_stack([V[:, 0], V[:, 1], 0.5 * (V[:, 0] + V[:, 1])]) * 0.8  # noqa: E731
    ev = evaluate(lodkit.Mesh(Vf, Ff, colors=lin(Vf)), lodkit.Mesh(Vc, Fc, colors=lin(Vc)), samples=5000)
    assert ev.distance.hausdorff < 1e-12
    assert ev.color.max < 1e-9


def test_no_colour_error_unless_both_have_colours():
    V, F = square_grid(2)
    assert evaluate(lodkit.Mesh(V, F, colors=np.ones((len(V), 3))), (V, F), samples=100).color is None


# ---------------------------------------------------------------------- quality and topology
def test_triangle_quality_histogram():
    s3 = math.sqrt(3.0)
    V = np.array([[0, 0, 0], [1, 0, 0], [0.5, s3 / 2, 0], [0, 1, 0], [2, 0, 0]], dtype=float)
    # equilateral (Q = 1), right isosceles (Q = 4 sqrt3 (1/2) / (1 + 1 + 2) = sqrt3 / 2),
    # and a sliver with collinear corners (Q = 0)
    F = np.array([[0, 1, 2], [0, 1, 3], [0, 1, 4]])
    q = triangle_quality(V, F)
    assert q == pytest.approx([1.0, s3 / 2, 0.0], abs=1e-15)
    ev = evaluate((V, F[:2]), (V, F), samples=200)
    assert ev.quality_original.histogram == (0, 0, 0, 0, 0, 0, 0, 0, 1, 1)
    assert ev.quality_simplified.histogram == (1, 0, 0, 0, 0, 0, 0, 0, 1, 1)
    assert ev.quality_simplified.min == 0.0
    assert ev.quality_original.min == pytest.approx(s3 / 2)
    assert ev.quality_original.mean == pytest.approx((1 + s3 / 2) / 2)
    assert len(QUALITY_BINS) == 11 and QUALITY_BINS[0] == 0.0 and QUALITY_BINS[-1] == 1.0
    assert ev.topology_changes["n_degenerate_faces"] == 0    # collinear, but no repeated index
    assert ev.topology_simplified.n_nonmanifold_edges == 1   # edge 0-1 has three faces


def test_topology_changes_torus_to_sphere():
    Vt, Ft = torus()
    Vs, Fs = icosphere(1)
    ev = evaluate((Vt, Ft), (0.5 * Vs, Fs), samples=2000)
    assert ev.topology_original.genus == 1
    assert ev.topology_simplified.genus == 0
    ch = ev.topology_changes
    assert ch["genus"] == -1
    assert ch["n_components"] == 0
    assert ch["n_boundary_loops"] == 0
    assert ch["euler_characteristic"] == 2
    assert ch["n_faces"] == len(Fs) - len(Ft)


def test_topology_changes_boundary_loops_and_duplicates():
    V, F = square_grid(6)
    centre = V[F].mean(axis=1)
    hole = (np.abs(centre[:, 0] - 0.5) < 0.17) & (np.abs(centre[:, 1] - 0.5) < 0.17)
    with_hole = F[~hole]
    doubled = np.vstack([F, F[:1]])
    ev = evaluate((V, with_hole), (V, doubled), samples=1000)
    assert ev.topology_original.n_boundary_loops == 2
    assert ev.topology_simplified.n_boundary_loops == 1
    assert ev.topology_changes["n_boundary_loops"] == -1
    assert ev.topology_changes["n_duplicate_faces"] == 1
    # the doubled corner face: its two interior edges now have three faces, its boundary edge two
    assert ev.topology_changes["n_nonmanifold_edges"] == 2
    # boundary edges: 24 outside + 8 around the hole, then 24 outside less the doubled one
    assert ev.topology_changes["n_boundary_edges"] == (24 - 1) - (24 + 8)


# ---------------------------------------------------------------------- inputs and errors
def test_input_kinds_agree(tmp_path):
    import open3d as o3d

    V, F = icosphere(2)
    B = (V * 1.02, F)
    ref = evaluate((V, F), B, samples=3000).as_dict()
    mesh = lodkit.Mesh(V, F)
    legacy = mesh.to_open3d()
    tensor = o3d.t.geometry.TriangleMesh.from_legacy(legacy, vertex_dtype=o3d.core.float64)
    path = tmp_path / "a.ply"
    lodkit.save(mesh, path)
    for original in (mesh, legacy, tensor, path, str(path)):
        assert evaluate(original, B, samples=3000).as_dict() == ref


def test_errors():
    V, F = square_grid(2)
    with pytest.raises(MeshError, match="simplified mesh has no faces"):
        evaluate((V, F), (V, np.zeros((0, 3), dtype=int)), samples=10)
    with pytest.raises(MeshError, match="original mesh has zero surface area"):
        evaluate((V, np.array([[0, 1, 2]])), (V, F), samples=10)     # collinear corners
    with pytest.raises(MeshError, match="expected a lodkit.Mesh"):
        evaluate([1, 2, 3], (V, F))
    with pytest.raises(MeshError, match="simplified: face 0"):
        evaluate((V, F), (V, np.array([[0, 1, 99]])))
    with pytest.raises(MeshError, match="NaN"):
        evaluate((V, F), (np.full_like(V, np.nan), F))
    with pytest.raises(MeshIOError, match="no such file"):
        evaluate("/nonexistent/x.ply", (V, F))
    for bad in (0, -5, 2.5, True):
        with pytest.raises(OptionError, match="samples"):
            evaluate((V, F), (V, F), samples=bad)
    with pytest.raises(OptionError, match="seed"):
        evaluate((V, F), (V, F), seed=-1)


def test_evaluator_reuses_the_original():
    V, F = icosphere(2)
    ev = Evaluator((V, F), samples=2000, seed=4)
    for s in (1.01, 1.1):
        B = (s * V, F)
        assert ev.evaluate(B).as_dict() == evaluate((V, F), B, samples=2000, seed=4).as_dict()
        assert ev.distances(B) == ev.evaluate(B).distance


# ---------------------------------------------------------------------- properties
@settings(max_examples=15, deadline=None)
@given(scale=st.floats(0.01, 100.0), shift=st.tuples(*[st.floats(-50, 50)] * 3),
       bump=st.floats(0.001, 0.2))
def test_relative_distances_do_not_depend_on_position_or_size(scale, shift, bump):
    V, F = icosphere(1)
    W = V * (1 + bump * np.cos(3 * V[:, [0]]))
    base = evaluate((V, F), (W, F), samples=2000)
    moved = evaluate((scale * V + shift, F), (scale * W + shift, F), samples=2000)
    for name in DIST_FIELDS:
        a, b = getattr(base.distance, name), getattr(moved.distance, name)
        assert b == pytest.approx(a, rel=1e-4, abs=1e-6), name
    d = base.distance
    assert 0 <= d.mean <= d.rms <= d.hausdorff
    assert d.hausdorff == max(d.hausdorff_fwd, d.hausdorff_bwd)


# ---------------------------------------------------------------------- the command
def _run(argv):
    buf = io.StringIO()
    with redirect_stdout(buf):
        code = main(argv)
    return code, buf.getvalue()


def test_cli_json_matches_python(tmp_path):
    V, F = icosphere(2)
    C = np.random.default_rng(1).random((len(V), 3))
    a, b = tmp_path / "a.ply", tmp_path / "b.ply"
    lodkit.save(lodkit.Mesh(V, F, colors=C), a)
    lodkit.save(lodkit.Mesh(1.03 * V, F, colors=C[::-1].copy()), b)
    code, out = _run(["evaluate", str(a), str(b), "--samples", "3000", "--seed", "2", "--json"])
    assert code == 0
    got = json.loads(out)
    want = evaluate(a, b, samples=3000, seed=2).as_dict()
    assert got.pop("original") == str(a) and got.pop("simplified") == str(b)
    assert got == want
    assert got["color"]["rms"] > 0 and got["distance"]["hausdorff"] > 0


def test_cli_table_and_errors(tmp_path, capsys):
    V, F = icosphere(1)
    a = tmp_path / "a.ply"
    lodkit.save(lodkit.Mesh(V, F), a)
    code, out = _run(["evaluate", str(a), str(a), "--samples", "500"])
    assert code == 0
    assert "hausdorff" in out and "genus" in out and "normal deviation" in out
    assert code == 0
    assert main(["evaluate", str(a), str(tmp_path / "missing.ply")]) == 2
    assert "no such file" in capsys.readouterr().err
    assert main(["evaluate", str(a), str(a), "--samples", "0"]) == 2
    assert "must be at least 1" in capsys.readouterr().err
