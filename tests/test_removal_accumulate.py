"""Issue 17: the vertex-removal metrics (``volume``, ``schroeder``) carry what each removal
took away to what remains (``accumulate="points"``, the default: the removed vertices and
face centroids themselves; ``"bound"``: an accumulated distance bound per vertex), so a
smooth, mostly convex surface is not shaved flat; ``accumulate="off"`` is the papers'
memory-less rule (tests/test_removal_fidelity.py tests the default's other parts).  The
surface: a small version of bench/head.py (a head-like ellipsoid with a nose,
a brow, a chin and two shallow eye sockets)."""
from __future__ import annotations

import numpy as np
import pytest

import lodkit


def small_head(levels=4, noise=0.0, seed=0):
    """A head-like closed surface: an icosahedron subdivided ``levels`` times (20 4^levels
    faces), on an ellipsoid with a nose, a brow, a chin and two shallow eye sockets."""
    t = (1.0 + 5 ** 0.5) / 2.0
    V = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
                  [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    F = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                  [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    for _ in range(levels):
        E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        uniq, inv = np.unique(E, axis=0, return_inverse=True)
        mid = V[uniq].mean(axis=1)
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = len(V) + inv.reshape(3, -1)         # midpoints of edges 01, 12, 20 of each face
        V = np.vstack([V, mid])
        a, b, c = F.T
        F = np.concatenate([np.c_[a, m[0], m[2]], np.c_[m[0], b, m[1]], np.c_[m[2], m[1], c],
                            np.c_[m[0], m[1], m[2]]])
    r = np.ones(len(V))
    for d, amp, width in (((0, 1, 0.2), 0.10, 0.16), ((0.3, 1, 0.4), -0.03, 0.12),
                          ((-0.3, 1, 0.4), -0.03, 0.12), ((0, 1, 0.55), 0.035, 0.55),
                          ((0, 0.8, -0.6), 0.04, 0.40)):
        d = np.asarray(d, float) / np.linalg.norm(d)
        r += amp * np.exp(-0.5 * (np.arccos(np.clip(V @ d, -1, 1)) / width) ** 2)
    if noise:
        r += noise * np.random.default_rng(seed).uniform(-1, 1, len(V))
    return V * r[:, None] * np.array([0.78, 0.92, 1.0]), F.astype(np.int32)


@pytest.fixture(scope="module")
def head():
    V, F = small_head(4)
    return lodkit.Mesh(V, F)


@pytest.fixture(scope="module")
def head_with_holes():
    """The head with two caps cut away (two boundary loops), genus 0."""
    V, F = small_head(4)
    c = V[F].mean(axis=1)
    keep = (c[:, 2] < 0.85) & (c[:, 0] < 0.7)
    return lodkit.Mesh(V, F[keep])


def _errors(mesh, out):
    d = lodkit.evaluate(mesh, out, samples=20_000).distance
    return d.hausdorff, d.mean


@pytest.mark.parametrize("metric", ["volume", "schroeder"])
@pytest.mark.parametrize("ratio", [0.1, 0.02])
def test_convex_head_is_not_flattened(head, metric, ratio):
    target = int(round(ratio * head.n_faces))
    qem = lodkit.simplify(head, target_faces=target)
    r = lodkit.simplify(head, target_faces=target, metric=metric)
    assert r.stop_reason == "target_faces"
    h_qem, m_qem = _errors(head, qem.mesh)
    h, m = _errors(head, r.mesh)
    # measured (5120 faces): volume H 4.1-4.7x QEM's and mean 3.6-3.7x; schroeder H 1.8-2.7x,
    # mean 2.5-2.9x (the paper's rule: volume H 5.2-6.6x); generous margins for any CPU
    assert h <= 8.0 * h_qem and m <= 6.0 * m_qem
    # no region shaved into a few flat faces: at 10% the worst deviation stays small (measured
    # volume 0.016, schroeder 0.006 of the diagonal)
    if ratio > 0.05:
        assert h < 0.035


@pytest.mark.parametrize("metric", ["volume", "schroeder"])
def test_accumulation_lowers_the_worst_error_on_the_head(head, metric):
    # what the bound is for: the worst-case error (measured on this head at 10%: volume
    # 1.55e-2 against 1.73e-2 with the paper's rule, schroeder 6.0e-3 against 7.7e-3)
    target = int(round(0.1 * head.n_faces))
    default = lodkit.simplify(head, target_faces=target, metric=metric)
    paper = lodkit.simplify(head, target_faces=target, metric=(metric, {"accumulate": "off"}))
    assert _errors(head, default.mesh)[0] < _errors(head, paper.mesh)[0]


@pytest.mark.parametrize("metric", ["volume", "schroeder"])
def test_paper_rule_is_reproducible_and_differs_from_the_default(head, metric):
    target = int(round(0.1 * head.n_faces))
    spec = (metric, {"accumulate": "off"})
    a = lodkit.simplify(head, target_faces=target, metric=spec, record=True)
    b = lodkit.simplify(head, target_faces=target, metric=spec, record=True)
    assert np.array_equal(a.mesh.faces, b.mesh.faces) and np.array_equal(a.vertex_map, b.vertex_map)
    assert np.array_equal(a.collapses["removed"], b.collapses["removed"])
    default = lodkit.simplify(head, target_faces=target, metric=metric, record=True)
    assert not np.array_equal(default.collapses["removed"], a.collapses["removed"])
    assert np.all(default.collapses["error"] >= 0.0)


@pytest.mark.parametrize("metric", ["volume", "schroeder"])
@pytest.mark.parametrize("accumulate", ["points", "bound", "off"])
def test_invariants_kept(head_with_holes, metric, accumulate):
    mesh = head_with_holes
    before = lodkit.topology(mesh)
    assert before.n_boundary_loops == 2 and before.genus == 0
    r = lodkit.simplify(mesh, target_ratio=0.05, metric=(metric, {"accumulate": accumulate}))
    after = lodkit.topology(r.mesh)
    assert after.is_manifold and after.is_oriented and after.n_nonmanifold_edges == 0
    assert after.genus == before.genus
    assert after.n_boundary_loops == before.n_boundary_loops
    assert after.n_components == before.n_components
    assert after.n_degenerate_faces == 0 and after.n_duplicate_faces == 0
    assert np.array_equal(r.mesh.vertices, mesh.vertices[r.vertex_map])


@pytest.mark.parametrize("metric", ["volume", "schroeder"])
def test_max_error_holds_the_accumulated_bound(head, metric):
    # max_error applies to the accumulated bound: every recorded removal is within it, and a
    # tight limit stops the run before the target
    r = lodkit.simplify(head, target_ratio=0.02, metric=metric, max_error=0.002, record=True)
    assert r.stop_reason == "max_error" and r.mesh.n_faces > 0.02 * head.n_faces
    assert np.all(r.collapses["error"] <= 0.002)


def test_option_values():
    from lodkit import OptionError

    with pytest.raises(OptionError):
        lodkit.simplify(lodkit.Mesh(*small_head(1)), target_ratio=0.5, metric=("volume", {"accumulate": "max"}))
    with pytest.raises(OptionError):
        lodkit.simplify(lodkit.Mesh(*small_head(1)), target_ratio=0.5, metric=("schroeder", {"accumulate": True}))
