"""The volume seam bug (issue 18): on a uv-seamed mesh both sides of a seam could each
re-triangulate the same corner, leaving, once welded, a duplicate face on a non-manifold
edge.  The removal driver's manifold rules now hold for the welded surface."""
from __future__ import annotations

import numpy as np
import pytest

import lodkit
from conftest import shared_mesh
from lodkit.geometry import weld_positions


def welded_defects(mesh) -> tuple[int, int, int]:
    """(duplicate faces, non-manifold edges, boundary edges) of the mesh welded by position."""
    _, F = weld_positions(mesh.vertices, mesh.faces)
    _, fcount = np.unique(np.sort(F, axis=1), axis=0, return_counts=True)
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, ecount = np.unique(E, axis=0, return_counts=True)
    return int((fcount > 1).sum()), int((ecount > 2).sum()), int((ecount == 1).sum())


@pytest.mark.parametrize("metric", ["volume", "schroeder"])
@pytest.mark.parametrize("ratio", [0.1, 0.02])
def test_removal_keeps_a_seamed_mesh_closed_and_manifold_once_welded(metric, ratio):
    spot = lodkit.load(shared_mesh("spot_triangulated.obj"))
    assert welded_defects(spot) == (0, 0, 0)
    out = lodkit.simplify(spot, metric=metric, target_ratio=ratio).mesh
    assert welded_defects(out) == (0, 0, 0)


def test_weld_groups_chain_every_copy_of_a_position():
    from types import SimpleNamespace

    from lodkit.drivers.vertex_removal import weld_groups
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 0], [-0.0, 0, 0], [2, 0, 0], [1, 0, 0]], float)
    work = SimpleNamespace(seams=np.zeros(6), src=SimpleNamespace(vertices=v),
                           prep=SimpleNamespace(input_vertex=np.arange(6)))
    rep, nxt = weld_groups(work)
    assert rep.tolist() == [0, 1, 0, 0, 4, 1]
    assert nxt.tolist() == [2, 5, 3, 0, -1, 1]
    assert weld_groups(SimpleNamespace(seams=None)) is None
