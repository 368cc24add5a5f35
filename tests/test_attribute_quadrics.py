"""Quadrics over attributes: packing, the marginal in x against a numpy reference, and
end-to-end runs where the attribute values come out of the solve."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import lodkit
from lodkit._core.decimate import general_quadric_marginal
from lodkit.metrics import MetricError, QuadricMetric, pack_quadrics, packed_size, unpack_quadrics
from lodkit.metrics.base import check_metric_class
from test_qem import grid_mesh


def random_quadric(rng, D):
    R = rng.normal(size=(D + 2, D))
    return R.T @ R, rng.normal(size=D), float(rng.normal()) + 5.0


@settings(max_examples=60, deadline=None)
@given(st.integers(3, 16), st.integers(0, 2**31 - 1))
def test_marginal_matches_reference(D, seed):
    rng = np.random.default_rng(seed)
    A, b, c = random_quadric(rng, D)
    g = pack_quadrics(A[None], b[None], np.array([c]))[0]
    p = rng.normal(size=3)
    q3, attrs = general_quadric_marginal(g, D, p)
    Q3 = np.array([[q3[0], q3[1], q3[2]], [q3[1], q3[3], q3[4]], [q3[2], q3[4], q3[5]]])
    marginal_at_p = p @ Q3 @ p + 2 * q3[6:9] @ p + q3[9]
    full = lambda x: x @ A @ x + 2 * b @ x + c  # noqa: E731
    if D == 3:
        assert attrs is None                      # nothing to solve for
        assert np.allclose(q3, g)
        return
    a_ref = -np.linalg.solve(A[3:, 3:], b[3:] + A[3:, :3] @ p)
    scale = np.abs(A).max() + np.abs(b).max() + abs(c)
    np.testing.assert_allclose(attrs, a_ref, rtol=1e-7, atol=1e-7 * (1 + np.abs(a_ref).max()))
    assert abs(marginal_at_p - full(np.concatenate([p, a_ref]))) <= 1e-8 * scale * (1 + p @ p)
    # the marginal is the minimum over the attributes: any other attributes cost more
    other = a_ref + rng.normal(size=D - 3) * 0.1
    assert full(np.concatenate([p, other])) >= marginal_at_p - 1e-9 * scale


def test_marginal_with_no_attribute_information_ignores_the_attributes():
    D = 5
    A = np.zeros((D, D))
    A[:3, :3] = np.diag([1.0, 2.0, 3.0])
    g = pack_quadrics(A[None], np.zeros((1, D)), np.zeros(1))[0]
    q3, attrs = general_quadric_marginal(g, D, np.zeros(3))
    assert attrs is None
    np.testing.assert_array_equal(q3, [1, 0, 0, 2, 0, 3, 0, 0, 0, 0])


def test_pack_unpack_round_trip():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(4, 6, 6))
    A = A + A.transpose(0, 2, 1)
    b, c = rng.normal(size=(4, 6)), rng.normal(size=4)
    packed = pack_quadrics(A, b, c)
    assert packed.shape == (4, packed_size(6)) == (4, 28)
    A2, b2, c2 = unpack_quadrics(packed, 6)
    np.testing.assert_array_equal(A2, A)
    np.testing.assert_array_equal(b2, b)
    np.testing.assert_array_equal(c2, c)
    # D = 3 is the core's 10-column layout
    np.testing.assert_array_equal(pack_quadrics(np.eye(3)[None] * 2, np.ones((1, 3)), [7.0])[0],
                                  [2, 0, 0, 2, 0, 2, 1, 1, 1, 7])


def anchor_metric(attribute: str, width: int) -> type:
    """A quadric metric |attribute - attribute_v|^2 per vertex: summed over a collapse, its
    minimiser is the mean of the two ends' values."""

    class Anchor(QuadricMetric):
        attributes = (attribute,)

        def quadrics(self, ctx):
            n = ctx.n_vertices
            values = ctx.vertex_attribute(attribute)
            A = np.zeros((n, 3 + width, 3 + width))
            A[:, 3:, 3:] = np.eye(width)
            b = np.zeros((n, 3 + width))
            b[:, 3:] = -values
            return pack_quadrics(A, b, (values ** 2).sum(axis=1))

    Anchor.__name__ = f"{attribute.title()}Anchor"
    return Anchor


ColorAnchor = anchor_metric("colors", 3)
UVAnchor = anchor_metric("uvs", 2)


def coloured_grid():
    v, f = grid_mesh(4, 4)
    rng = np.random.default_rng(5)
    return lodkit.Mesh(v, f, colors=rng.uniform(0.0, 1.0, (len(v), 3)), uvs=rng.uniform(0.0, 1.0, (len(v), 2)))


def test_one_collapse_takes_the_mean_colour():
    mesh = coloured_grid()
    # boundary="free": under "lock" the first collapse keeps a locked border vertex, which
    # keeps its own colour (a lock keeps the attributes too)
    r = lodkit.simplify(mesh, target_faces=mesh.n_faces - 2, metric=["qem", ColorAnchor()], record=True,
                        boundary="free")
    assert r.n_collapses == 1
    removed, kept = int(r.collapses["removed"][0]), int(r.collapses["kept"][0])
    out = int(np.flatnonzero(r.vertex_map == kept)[0])
    np.testing.assert_allclose(r.mesh.colors[out], 0.5 * (mesh.colors[removed] + mesh.colors[kept]), atol=1e-12)


def test_two_attribute_metrics_fold_over_the_union():
    mesh = coloured_grid()
    r = lodkit.simplify(mesh, target_ratio=0.3, metric=["qem", ColorAnchor(), UVAnchor(weight=2.0)])
    assert r.stop_reason == "target_faces"
    assert np.isfinite(r.mesh.colors).all() and np.isfinite(r.mesh.uvs).all()
    # every output colour is a mean of input colours: inside their bounding box
    assert (r.mesh.colors >= mesh.colors.min(0) - 1e-12).all()
    assert (r.mesh.colors <= mesh.colors.max(0) + 1e-12).all()
    # the geometric error of a flat grid stays zero: the attribute terms do not leak into it
    assert r.error == pytest.approx(0.0, abs=1e-9)


def test_a_mesh_without_the_attribute_is_refused():
    v, f = grid_mesh(3, 3)
    with pytest.raises(MetricError, match="colors"):
        lodkit.simplify(lodkit.Mesh(v, f), target_ratio=0.5, metric=["qem", ColorAnchor()])


def test_bad_attribute_declarations_are_refused():
    class Bad(QuadricMetric):
        attributes = ("temperature",)

    class Dup(QuadricMetric):
        attributes = ("colors", "colors")

    assert "attributes" in check_metric_class(Bad)
    assert "attributes" in check_metric_class(Dup)
    assert check_metric_class(ColorAnchor) is None


def test_wrong_packed_width_is_refused():
    class Narrow(ColorAnchor):
        def quadrics(self, ctx):
            return super().quadrics(ctx)[:, :10]

    with pytest.raises(MetricError, match="shape"):
        lodkit.simplify(coloured_grid(), target_ratio=0.5, metric=["qem", Narrow()])
