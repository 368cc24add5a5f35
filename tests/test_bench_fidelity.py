"""The measuring code of bench/fidelity.py and bench/pictures.py (bench/metro.py helpers).

Tiny hand-made meshes with hand-computed answers: crease-vertex counting, the sampled
colour error, the UV-seam checker and the numpy rasteriser.
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parent.parent / "bench"
sys.path.insert(0, str(BENCH))

import metro  # noqa: E402
import pictures  # noqa: E402

HAS_O3D = importlib.util.find_spec("open3d") is not None
needs_o3d = pytest.mark.skipif(not HAS_O3D, reason="open3d is not installed (colour error uses its RaycastingScene)")


# ------------------------------------------------------------------ creases

def folded_sheet():
    """Two unit quads meeting at 90 degrees along the ridge (0,0,0)-(1,0,0).

    Quad A lies in z=0 for y in [0,1]; quad B in y=0 for z in [-1,0]. The only crease is the
    ridge; the quad diagonals are flat and the rest is boundary. Bbox diagonal sqrt(3).
    """
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, -1], [1, 0, -1]], dtype=float)
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 4, 5], [0, 5, 1]])
    return V, F


def test_crease_edges_finds_the_ridge_only():
    V, F = folded_sheet()
    E, ang = metro.crease_edges(V, F, 30.0)
    assert sorted(map(tuple, np.sort(E, axis=1))) == [(0, 1)]
    assert ang == pytest.approx([90.0])
    E, _ = metro.crease_edges(V, F, 95.0)          # the threshold is a parameter
    assert len(E) == 0


def test_segment_distance_exact():
    A = np.array([[0.0, 0, 0]])
    B = np.array([[1.0, 0, 0]])
    P = np.array([[0.5, 0.3, 0.4], [-0.3, 0.4, 0], [1.6, 0, 0.8], [0.2, 0, 0]])
    assert metro.segment_distance(P, A, B) == pytest.approx([0.5, 0.5, 1.0, 0.0])
    # nearest of several segments, and a zero-length one (a point)
    A2 = np.array([[0.0, 0, 0], [5.0, 5, 5]])
    B2 = np.array([[1.0, 0, 0], [5.0, 5, 5]])
    P2 = np.array([[5.0, 5, 6], [0.5, 2, 0]])
    assert metro.segment_distance(P2, A2, B2, chunk=2) == pytest.approx([1.0, 2.0])


def test_crease_vertices_counts_points_within_tolerance():
    V, F = folded_sheet()
    tol = 0.005 * np.sqrt(3.0)                      # 0.00866
    out = np.array([
        [0.5, 0.005, 0.0],        # 0.005 from the ridge: near
        [0.5, 0.02, 0.0],         # 0.02: not near
        [1.004, 0.0, 0.0],        # 0.004 past the ridge's end: near
        [1.01, 0.0, 0.0],         # 0.01 past the end: not near
        [0.5, 0.003, -0.003],     # 0.00424: near
        [0.0, 1.0, 0.0],          # a corner far from the ridge
    ])
    r = metro.crease_vertices(V, F, out, None, angle_deg=30.0, tol_frac=0.005)
    assert r["near"] == 3 and r["vertices"] == 6
    assert r["crease_edges"] == 1 and r["crease_length"] == pytest.approx(1.0)
    assert r["tol"] == pytest.approx(tol)
    # with faces given, only referenced vertices count
    r = metro.crease_vertices(V, F, out, np.array([[0, 1, 5]]), 30.0, 0.005)
    assert (r["near"], r["vertices"]) == (1, 3)
    assert metro.crease_vertices(V, F, out, None, angle_deg=100.0)["near"] == 0


# ------------------------------------------------------------------ colour error

def grid(n: int, z=0.0):
    """An n x n-quad grid on the unit square (2 n^2 triangles)."""
    t = np.linspace(0.0, 1.0, n + 1)
    X, Y = np.meshgrid(t, t, indexing="ij")
    V = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, z)])
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a = (i * (n + 1) + j).ravel()
    F = np.concatenate([np.stack([a, a + n + 1, a + n + 2], 1), np.stack([a, a + n + 2, a + 1], 1)])
    return V, F


@needs_o3d
def test_color_error_zero_for_identical_meshes():
    V, F = grid(6)
    C = np.random.default_rng(1).random((len(V), 3))
    r = metro.color_error(V, F, C, V, F, C, n_samples=5000)
    assert r["rms"] < 1e-3 and r["mean_abs"] < 1e-3 and r["max"] < 1e-2   # float32 closest points


@needs_o3d
def test_color_error_constant_offset():
    V, F = grid(6)
    C = np.random.default_rng(2).random((len(V), 3)) * 0.5
    r = metro.color_error(V, F, C, V, F, C + 10.0 / 255.0, n_samples=5000)
    assert r["rms"] == pytest.approx(10.0, abs=1e-3)
    assert r["mean_abs"] == pytest.approx(10.0, abs=1e-3)
    assert r["max"] == pytest.approx(10.0, abs=1e-2)


@needs_o3d
def test_color_error_linear_field_on_coarser_mesh_is_zero():
    # a colour that is linear in the position is reproduced exactly by any triangulation
    Vf, Ff = grid(8)
    Vc, Fc = grid(1)
    def lin(V):
        return np.column_stack([0.2 + 0.5 * V[:, 0], 0.7 - 0.4 * V[:, 1], 0.1 + 0.3 * V[:, 0] + 0.3 * V[:, 1]])

    r = metro.color_error(Vf, Ff, lin(Vf), Vc, Fc, lin(Vc), n_samples=5000)
    assert r["rms"] < 1e-3
    # the coarse mesh black everywhere: error = the mean / RMS of the fine colours in 0..255
    r = metro.color_error(Vf, Ff, lin(Vf), Vc, Fc, np.zeros((len(Vc), 3)), n_samples=20000, seed=3)
    P, face, w = metro.sample_surface_bary(Vf, Ff, 20000, 3)
    expect = np.abs(lin(P)).mean() * 255
    assert r["mean_abs"] == pytest.approx(expect, rel=1e-4)


# ------------------------------------------------------------------ seams

def split_strip():
    """Two unit quads side by side, cut along x=1 (a uv seam): b,c on the left, b2,c2 on the right.

    vertices: a(0,0) b(1,0) c(1,1) d(0,1) | b2(1,0) e(2,0) f(2,1) c2(1,1)
    """
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [1, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0]], float)
    F = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    uv = np.array([[0, 0], [.4, 0], [.4, .4], [0, .4], [.6, 0], [1, 0], [1, .4], [.6, .4]])
    return V, F, uv


def test_seam_check_intact_mesh():
    V, F, uv = split_strip()
    r = metro.seam_check(V, F, np.arange(len(V)), V, F, uv, uv)
    assert r["seam_positions_in"] == 2 and r["seam_vertices_in"] == 4 and r["seam_vertices_out"] == 4
    assert r["cracks"] == 0 and r["split_groups"] == 0 and r["orphans"] == 0 and r["max_gap"] == 0.0
    assert r["open_edges_in"] == 6 and r["new_open_edges"] == 0      # the rectangle's outline only
    assert r["uv_kept"] == 4 and r["uv_changed"] == 0


def test_seam_check_detects_a_moved_copy():
    V, F, uv = split_strip()
    Vo = V.copy()
    Vo[7] = [1.1, 1.0, 0.0]                 # the right copy of c drifted: a crack
    r = metro.seam_check(V, F, np.arange(len(V)), Vo, F, uv, uv)
    assert r["split_groups"] == 1 and r["cracks"] == 1
    assert r["max_gap"] == pytest.approx(0.1 / np.sqrt(5.0))


def test_seam_check_detects_a_one_sided_collapse_and_uv_change():
    V, F, uv = split_strip()
    # output keeps a b c d | b2 e f: c2 was collapsed away on the right side only
    keep = np.array([0, 1, 2, 3, 4, 5, 6])
    Fo = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6]])
    uvo = uv[keep].copy()
    uvo[4] = [0.65, 0.0]                     # b2's uv moved away from its own input uv
    r = metro.seam_check(V, F, keep, V[keep], Fo, uv, uvo)
    assert r["orphans"] == 1 and r["split_groups"] == 0 and r["cracks"] == 1
    assert r["new_open_edges"] == 1          # b-c now has one face once the seam is glued
    assert r["uv_changed"] == 1 and r["uv_max_change"] == pytest.approx(0.05)


# ------------------------------------------------------------------ rendering

def two_squares():
    """A red square at z=0 in front of a larger blue one at z=-1 (camera looks down -z)."""
    V = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0],
                  [-2, -2, -1], [2, -2, -1], [2, 2, -1], [-2, 2, -1]], float)
    F = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    C = np.array([[1, 0, 0]] * 4 + [[0, 0, 1]] * 4, float)
    return V, F, C


def test_rasteriser_draws_nearest_face():
    V, F, C = two_squares()
    cam = pictures.Camera.fit(V, 64, 64, azimuth=0, elevation=0)
    img = pictures.render(V, F, cam, pictures.Style(vertex_colors=C, ambient=1.0))
    assert img.shape == (64, 64, 3) and img.dtype == np.uint8
    centre = img[32, 32].astype(int)
    assert centre[0] > 200 and centre[2] < 50            # the front (red) square wins
    corner = img[6, 6].astype(int)                          # only the back square reaches there
    assert corner[2] > 200 and corner[0] < 50
    # the back square fills the panel up to the margin; beyond it is background (white)
    assert (img[0, 0] == 255).all()


def test_rasteriser_wireframe_and_blank_mesh():
    V, F, C = two_squares()
    cam = pictures.Camera.fit(V, 48, 48, azimuth=0, elevation=0)
    plain = pictures.render(V, F, cam, pictures.Style())
    wired = pictures.render(V, F, cam, pictures.Style(wire=(0, 0, 0)))
    assert (plain != 255).any()                             # not blank
    assert (wired.astype(int).sum(axis=2) < plain.astype(int).sum(axis=2)).sum() > 20
    empty = pictures.render(V, np.zeros((0, 3), int), cam, pictures.Style())
    assert (empty == 255).all()


def test_texture_lookup_by_uv():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    F = np.array([[0, 1, 2], [0, 2, 3]])
    tex = np.zeros((2, 2, 3))
    tex[0, :, 1] = 1.0        # top row green (v near 1)
    tex[1, :, 0] = 1.0        # bottom row red (v near 0)
    cam = pictures.Camera.fit(V, 40, 40, azimuth=0, elevation=0, margin=0.0)
    img = pictures.render(V, F, cam, pictures.Style(uvs=V[:, :2], texture=tex, ambient=1.0), ss=1)
    assert img[3, 20, 1] > 200 and img[3, 20, 0] < 60       # top of the image: green
    assert img[36, 20, 0] > 200 and img[36, 20, 1] < 60     # bottom: red


def test_compose_png(tmp_path):
    pytest.importorskip("PIL", reason="Pillow is needed to write the pictures")
    V, F, C = two_squares()
    cam = pictures.Camera.fit(V, 60, 50)
    panel = pictures.render(V, F, cam, pictures.Style(vertex_colors=C))
    im = pictures.compose([panel, panel], ["a\nb", "c"], "a caption that is long enough " * 4)
    path = tmp_path / "x.png"
    im.save(path)
    assert im.size[0] == 120 and im.size[1] > 50 and path.stat().st_size > 100
