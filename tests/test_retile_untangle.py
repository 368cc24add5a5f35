"""The untangling of the kept pass (docs/retile.md, cow's pinch): the sliver splits."""
from __future__ import annotations

import numpy as np

from lodkit.geometry import triangle_quality
from lodkit.retile import SurfaceProjector, _split_slivers


def _plane():
    """A flat input square [-1, 2] x [-1, 1] (two triangles)."""
    P0 = np.array([[-1.0, -1.0, 0.0], [2.0, -1.0, 0.0], [2.0, 1.0, 0.0], [-1.0, 1.0, 0.0]])
    F0 = np.array([[0, 1, 2], [0, 2, 3]])
    return P0, F0


def _euler(F):
    e = np.unique(np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0)
    return np.unique(F).size - e.shape[0] + F.shape[0]


def test_split_lifts_two_needles_and_keeps_the_topology():
    P0, F0 = _plane()
    surf = SurfaceProjector(P0, F0)
    # two long thin triangles on the edge a-b (quality ~0.27 each)
    P = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.12, 0.0], [0.5, -0.12, 0.0]])
    F = np.array([[0, 1, 2], [1, 0, 3]], dtype=np.int32)
    q0 = float(triangle_quality(P, F).min())
    assert q0 < 0.3
    P2, F2, face, w, crease, n = _split_slivers(P, F, surf, P0, F0, None)
    assert n == 1 and P2.shape[0] == 5 and F2.shape[0] == 4
    assert crease.tolist() == [False]                       # no crease vertices given
    assert float(triangle_quality(P2, F2).min()) > q0 + 0.05
    assert _euler(F2) == _euler(F) == 1
    # the new vertex is on the input surface, at its recorded face and weights
    np.testing.assert_allclose(np.einsum("k,kj->j", w[0], P0[F0[face[0]]]), P2[4], atol=1e-12)
    assert abs(float(P2[4, 2])) < 1e-12
    # the faces keep their orientation (normals up)
    cr = np.cross(P2[F2[:, 1]] - P2[F2[:, 0]], P2[F2[:, 2]] - P2[F2[:, 0]])
    assert (np.sign(cr[:, 2]) == np.sign(np.cross(P[1] - P[0], P[2] - P[0])[2])).all()


def test_split_refuses_to_join_two_copies():
    P0, F0 = _plane()
    surf = SurfaceProjector(P0, F0)
    P = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.12, 0.0], [0.5, -0.12, 0.0]])
    F = np.array([[0, 1, 2], [1, 0, 3]], dtype=np.int32)
    group = np.array([-1, -1, 7, 7], dtype=np.intc)        # c and d: copies of one input vertex
    P2, F2, _, _, _, n = _split_slivers(P, F, surf, P0, F0, group)
    assert n == 0 and P2.shape[0] == 4
    np.testing.assert_array_equal(F2, F)


def test_split_of_a_crease_edge_makes_a_crease_vertex():
    """A split of the edge between two crease vertices marks the new vertex a crease vertex
    (so the moves, collapses and flips after leave the crease edges a-m, m-b alone); a split
    of an edge with one crease end does not."""
    P0, F0 = _plane()
    surf = SurfaceProjector(P0, F0)
    P = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.12, 0.0], [0.5, -0.12, 0.0]])
    F = np.array([[0, 1, 2], [1, 0, 3]], dtype=np.int32)
    for marked, want in (([0, 1], True), ([0], False), ([2, 3], False)):
        crease_vertex = np.zeros(4, dtype=np.uint8)
        crease_vertex[marked] = 1
        P2, _, _, _, crease, n = _split_slivers(P, F, surf, P0, F0, None, crease_vertex)
        assert n == 1 and P2.shape[0] == 5
        assert crease.tolist() == [want]


def test_split_on_the_edge_where_no_surface_point_helps():
    """An edge across the rim of a sheet thinner than it (cow's tail): the input surface
    near the edge's middle lies off to one side (here a plane 0.3 above the two faces), so
    every point of it turns the new faces by more than the limit and the split is refused.
    With ``on_edge`` (``fit`` runs) the vertex may stay on the edge: the four faces cover the
    two old ones exactly, no face turns, and the smallest quality rises."""
    P0, F0 = _plane()
    P0 = P0 + [0.0, 0.0, 0.3]
    surf = SurfaceProjector(P0, F0)
    P = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.12, 0.0], [0.5, -0.12, 0.0]])
    F = np.array([[0, 1, 2], [1, 0, 3]], dtype=np.int32)
    q0 = float(triangle_quality(P, F).min())
    _, _, _, _, _, n = _split_slivers(P, F, surf, P0, F0, None)
    assert n == 0
    P2, F2, face, w, _, n = _split_slivers(P, F, surf, P0, F0, None, on_edge=True)
    assert n == 1 and F2.shape[0] == 4 and _euler(F2) == 1
    assert float(triangle_quality(P2, F2).min()) > q0 + 0.05
    m = P2[4]
    assert abs(float(m[1])) < 1e-12 and abs(float(m[2])) < 1e-12 and 0.0 < m[0] < 1.0   # on the edge a-b
    cr = np.cross(P2[F2[:, 1]] - P2[F2[:, 0]], P2[F2[:, 2]] - P2[F2[:, 0]])
    assert (np.abs(cr[:, :2]) < 1e-12).all() and (cr[:, 2] != 0).all()                  # flat: nothing turned
    area = 0.5 * np.abs(cr[:, 2]).sum()
    cr0 = np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]])
    assert abs(area - 0.5 * np.abs(cr0[:, 2]).sum()) < 1e-12                              # the same surface
    np.testing.assert_allclose(np.einsum("k,kj->j", w[0], P0[F0[face[0]]]), m + [0.0, 0.0, 0.3], atol=1e-12)
