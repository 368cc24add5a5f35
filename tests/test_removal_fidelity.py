"""Issue 17, vertex removal: the lodkit readings of ``volume`` and ``schroeder`` that are on
by default (docs/algorithms.md, "Vertex removal: what each removal costs"):

* ``accumulate="points"``: the removed vertices and the input faces' centroids are carried
  on the face nearest them, and a removal costs how far they (and V) lie from the patch;
* ``volume``: hyperbolic vertices are removable (``hyperbolic="remove"``), the hole takes
  the patch nearer V (``triangulation="nearest"``: the paper's fan or the least-volume
  triangulation), no median filter;
* ``schroeder``: corners removable, the same nearest-patch choice for vertices with no
  feature line;

and ``accumulate="off"`` resolves every one of them to the papers' rules.
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lodkit
from lodkit._core import retriangulate as rt
from lodkit._core import schroeder_kernel as sk
from lodkit._core import volume_kernel as vk
from lodkit.evaluate import closest_points
from test_removal_accumulate import small_head

# ---- the least-volume triangulation ------------------------------------------------------

def test_min_volume_triangulation_takes_the_diagonal_nearer_the_vertex():
    # a quad under V folded along one diagonal: W1, W3 at height 0.5, W0, W2 at 0; V above
    # the middle.  Diagonal (1, 3) runs under V at height 0.5, (0, 2) at 0: the patch over
    # (1, 3) encloses less volume with V's cone
    W = np.array([[1, 0, 0], [0, 1, 0.5], [-1, 0, 0], [0, -1, 0.5]], float)
    x = np.array([0, 0, 1.0])
    tris = rt.py_min_volume_triangulation(W, x, [0, 0, 1])
    assert sorted(map(tuple, tris.tolist())) == [(0, 1, 3), (1, 2, 3)]
    # folded the other way (W0, W2 up) the other diagonal wins
    W[:, 2] = [0.5, 0, 0.5, 0]
    tris = rt.py_min_volume_triangulation(W, x, [0, 0, 1])
    assert sorted(map(tuple, tris.tolist())) == [(0, 1, 2), (0, 2, 3)]


def test_min_volume_triangulation_refuses_a_hole_it_can_only_fold():
    # every triangle of a quad seen from below turns away from the normal
    W = np.array([[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], float)
    assert rt.py_min_volume_triangulation(W, [0, 0, 1], [0, 0, -1]) is None
    assert rt.py_min_volume_triangulation(W, [0, 0, 1], [0, 0, 1]).shape == (2, 3)


@settings(max_examples=200, deadline=None)
@given(st.integers(3, 12), st.floats(-0.5, 0.5), st.integers(0, 2 ** 31 - 1))
def test_min_volume_triangulation_is_a_triangulation(k, h, seed):
    rng = np.random.default_rng(seed)
    th = np.sort(rng.uniform(0, 2 * np.pi, k))
    th += np.arange(k) * 1e-3                        # distinct angles: a star-shaped polygon
    r = rng.uniform(0.5, 1.5, k)
    W = np.stack([r * np.cos(th), r * np.sin(th), rng.uniform(-0.2, 0.2, k)], axis=1)
    tris = rt.py_min_volume_triangulation(W, [0, 0, h], [0, 0, 1])
    if tris is None:
        return
    assert tris.shape == (k - 2, 3)
    # every polygon edge once, every diagonal twice (once each way in the oriented sense)
    edges = {}
    for a, b, c in tris:
        assert a < b < c
        for e in ((a, b), (b, c), (a, c)):
            edges[e] = edges.get(e, 0) + 1
    for i in range(k):
        e = (min(i, (i + 1) % k), max(i, (i + 1) % k))
        assert edges.pop(e) == 1
    assert all(n == 2 for n in edges.values())
    # every triangle faces up (none folds against the normal)
    n = np.cross(W[tris[:, 1]] - W[tris[:, 0]], W[tris[:, 2]] - W[tris[:, 0]])
    assert (n[:, 2] > 0).all()


# ---- the options resolve to the papers' rules under accumulate="off" ----------------------

def test_accumulate_off_resolves_to_the_papers_rules():
    k = vk.VolumeKernel()
    k.prepare(None, {"accumulate": "off", "n_vertices": 4})
    assert (k.gated, k.hyperbolic_code, k.triangulation_code) == (True, 0, 0)
    k.prepare(None, {"n_vertices": 4})
    assert (k.gated, k.hyperbolic_code, k.triangulation_code) == (False, 1, 1)
    assert vk.HYPERBOLIC_MODES[1] == "remove" and vk.TRIANGULATION_MODES[1] == "nearest"
    s = sk.SchroederKernel()
    s.prepare(None, {"accumulate": "off"})
    assert (s.remove_corners, s.triangulation_code) == (False, 0)
    s.prepare(None, {})
    assert (s.remove_corners, s.triangulation_code) == (True, 1)
    with pytest.raises(ValueError):
        k.prepare(None, {"hyperbolic": "sometimes"})
    with pytest.raises(ValueError):
        s.prepare(None, {"triangulation": "fan"})


@pytest.mark.parametrize("metric, paper", [
    ("volume", {"hyperbolic": "veto", "triangulation": "closest_line", "median": True}),
    ("schroeder", {"remove_corners": False, "triangulation": "split"}),
])
def test_paper_rule_is_the_same_run_as_its_explicit_options(metric, paper):
    V, F = small_head(3)
    mesh = lodkit.Mesh(V, F)
    a = lodkit.simplify(mesh, target_ratio=0.1, metric=(metric, {"accumulate": "off"}), record=True)
    b = lodkit.simplify(mesh, target_ratio=0.1, metric=(metric, {"accumulate": "off", **paper}), record=True)
    assert np.array_equal(a.mesh.faces, b.mesh.faces) and np.array_equal(a.vertex_map, b.vertex_map)
    assert np.array_equal(a.collapses["removed"], b.collapses["removed"])
    assert np.array_equal(a.collapses["error"], b.collapses["error"])


# ---- hyperbolic vertices ----------------------------------------------------------------

def saddle_sheet(n=9):
    """z = 0.3 (x^2 - y^2) over an n x n grid on [-1, 1]^2: every interior vertex hyperbolic."""
    x = np.linspace(-1, 1, n)
    X, Y = np.meshgrid(x, x, indexing="ij")
    V = np.stack([X.ravel(), Y.ravel(), 0.3 * (X ** 2 - Y ** 2).ravel()], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    F = np.concatenate([np.c_[a, b, c], np.c_[a, c, d]]).astype(np.int32)
    return V, F


def test_hyperbolic_vertices_go_by_their_real_cost():
    V, F = saddle_sheet(9)
    mesh = lodkit.Mesh(V, F)
    before = lodkit.topology(mesh)
    paper = lodkit.simplify(mesh, target_faces=40, metric=("volume", {"accumulate": "off"}), boundary="lock")
    assert paper.n_collapses == 0 and "hyperbolic" in paper.report["stop_detail"]
    r = lodkit.simplify(mesh, target_faces=40, metric="volume", boundary="lock")
    assert r.stop_reason == "target_faces" and r.mesh.n_faces in (40, 39)
    after = lodkit.topology(r.mesh)
    assert (after.n_boundary_loops, after.n_components, after.is_manifold) == (
        before.n_boundary_loops, before.n_components, True)
    # a saddle's removal is not free: the run's error is the carried distance, > 0, and the
    # output stays within it of every input vertex (the carried points' promise)
    assert 0.0 < r.error < 0.05
    diag = np.linalg.norm(V.max(0) - V.min(0))
    cp, _, _ = closest_points(r.mesh.vertices, r.mesh.faces.astype(np.int64), V)
    assert (np.linalg.norm(cp - V, axis=1) / diag).max() <= r.error * (1 + 1e-9) + 1e-12


# ---- the carried points bound the distance of every input vertex ------------------------

@pytest.mark.parametrize("metric", ["volume", "schroeder"])
@pytest.mark.parametrize("ratio", [0.1, 0.02])
def test_carried_points_bound_every_input_vertex(metric, ratio):
    V, F = small_head(4, noise=0.004, seed=1)
    r = lodkit.simplify(lodkit.Mesh(V, F), target_ratio=ratio, metric=metric)
    assert r.stop_reason == "target_faces"
    diag = np.linalg.norm(V.max(0) - V.min(0))
    cp, _, _ = closest_points(r.mesh.vertices, r.mesh.faces.astype(np.int64), V)
    d = np.linalg.norm(cp - V, axis=1) / diag
    # each removed vertex (and face centroid) lies within its recorded distance of the face
    # it was handed to, and faces change only by removals that measure them again
    assert d.max() <= r.error * (1 + 1e-9) + 1e-12
    assert r.error > 0.0


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(["volume", "schroeder"]), st.floats(0.03, 0.5), st.floats(0.0, 0.05),
       st.integers(0, 10 ** 6))
def test_defaults_keep_a_closed_surface_closed(metric, ratio, noise, seed):
    V, F = small_head(2, noise=noise, seed=seed)
    mesh = lodkit.Mesh(V, F)
    r = lodkit.simplify(mesh, target_ratio=ratio, metric=metric)
    t = lodkit.topology(r.mesh)
    assert t.is_manifold and t.is_closed and t.genus == 0 and t.n_components == 1
    # vertex removal: the output vertices are input vertices, bit for bit
    assert np.array_equal(r.mesh.vertices, V[r.vertex_map])
    # no face turned over against its own input neighbourhood by more than the driver allows
    n_out = np.cross(r.mesh.vertices[r.mesh.faces[:, 1]] - r.mesh.vertices[r.mesh.faces[:, 0]],
                     r.mesh.vertices[r.mesh.faces[:, 2]] - r.mesh.vertices[r.mesh.faces[:, 0]])
    c = r.mesh.vertices[r.mesh.faces].mean(axis=1)
    assert (np.einsum("ij,ij->i", n_out, c) > 0).mean() > 0.95       # outward on a star-shaped head


# ---- no region flattened: the issue's limits on the head ---------------------------------

def _errors(mesh, out):
    d = lodkit.evaluate(mesh, out, samples=20_000).distance
    return d.hausdorff, d.mean


@pytest.mark.parametrize("metric", ["volume", "schroeder"])
@pytest.mark.parametrize("ratio", [0.1, 0.02])
def test_head_within_the_issue_limits(metric, ratio):
    V, F = small_head(4)
    head = lodkit.Mesh(V, F)
    target = int(round(ratio * head.n_faces))
    qem = lodkit.simplify(head, target_faces=target)
    r = lodkit.simplify(head, target_faces=target, metric=metric)
    assert r.stop_reason == "target_faces"
    h_qem, m_qem = _errors(head, qem.mesh)
    h, m = _errors(head, r.mesh)
    # issue 17: Hausdorff <= 5x QEM's, mean <= 3x (measured on this 5120-face head at 10% /
    # 2%: volume 1.5x, 1.7x / 2.3x, 2.4x; schroeder 1.3x, 1.6x / 2.2x, 2.3x; the papers'
    # rules: volume 5.2x, 6.2x / 3.9x, 3.9x; schroeder 2.3x, 2.6x / 2.5x, 2.8x)
    assert h <= 5.0 * h_qem and m <= 3.0 * m_qem
