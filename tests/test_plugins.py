"""The two plugin packages in plugins/, installed and used by name through the registry.

    lodkit-edge-length  metric ``edge_length``      a pure-Python batch metric
    lodkit-max-edge     metric ``max_edge_length``  a Cython kernel cimporting lodkit's kernel.pxd

They are separate distributions, installed with
``pip install --no-build-isolation ./plugins/lodkit-edge-length ./plugins/lodkit-max-edge``
(the README's test command does).  A test of a plugin that is not installed is skipped,
with the reason -- unless ``LODKIT_REQUIRE_PLUGINS=1`` (CI sets it), then it fails.
"""
from __future__ import annotations

import os
from importlib import metadata

import numpy as np
import pytest

import lodkit
from conftest import shared_mesh
from lodkit import OptionError, metrics
from lodkit.demo import demo_mesh

REQUIRE_ENV = "LODKIT_REQUIRE_PLUGINS"

# metric name -> (distribution, module, kind)
PLUGINS = {
    "edge_length": ("lodkit-edge-length", "lodkit_edge_length", "batch"),
    "max_edge_length": ("lodkit-max-edge", "lodkit_max_edge", "kernel"),
}


def require_plugin(metric: str) -> str:
    """The installed version of the plugin providing ``metric``; skips (or, with
    LODKIT_REQUIRE_PLUGINS=1, fails) the test when it is not installed."""
    dist = PLUGINS[metric][0]
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        reason = (f"plugin package {dist} (metric {metric!r}) is not installed; "
                  f"pip install --no-build-isolation ./plugins/{dist}")
        if os.environ.get(REQUIRE_ENV, "").strip() == "1":
            pytest.fail(f"{reason} ({REQUIRE_ENV}=1 requires it)", pytrace=False)
        pytest.skip(reason)


@pytest.fixture(autouse=True)
def discovery_on(monkeypatch):
    """Entry-point discovery on, and a fresh look at the installed packages."""
    monkeypatch.delenv(metrics.DISCOVERY_ENV, raising=False)
    metrics.refresh()
    yield
    metrics.refresh()


@pytest.fixture
def edge_length():
    return require_plugin("edge_length")


@pytest.fixture
def max_edge():
    return require_plugin("max_edge_length")


# ----------------------------------------------------------------------------- helpers
def edge_lengths(mesh) -> np.ndarray:
    """(n_edges,) length of each undirected edge of ``mesh``, in its own units."""
    f = np.asarray(mesh.faces)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    e = np.unique(np.sort(e, axis=1), axis=0)
    v = np.asarray(mesh.vertices)
    return np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1)


def bbox_diagonal(mesh) -> float:
    v = np.asarray(mesh.vertices)
    return float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))


def assert_topology_kept(before, after):
    """Output manifold, with the input's components, boundary loops and genus."""
    t0, t1 = lodkit.topology(before), lodkit.topology(after)
    assert t1.is_manifold, str(t1)
    assert t1.n_nonmanifold_edges == 0 and t1.n_degenerate_faces == 0 and t1.n_duplicate_faces == 0
    assert (t1.n_components, t1.n_boundary_loops, t1.genus) == (t0.n_components, t0.n_boundary_loops, t0.genus)


def graded_grid(nx: int = 40, ny: int = 20, ratio: float = 4.0, seed: int = 0) -> lodkit.Mesh:
    """A flat (nx + 1) x (ny + 1) grid over y in [0, 1] with square cells for x < 0 and
    cells ``ratio`` times narrower for x > 0, so the right half holds the short edges.
    Vertex ids are shuffled so that no cost's tie-breaking by id favours either half."""
    steps = np.where(np.arange(nx) >= nx // 2, 1.0 / ratio, 1.0) / ny
    xs = np.concatenate([[0.0], np.cumsum(steps)])
    xs -= xs[nx // 2]                                  # the step change at x = 0
    ys = np.linspace(0.0, 1.0, ny + 1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    vertices = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], axis=1)
    idx = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    perm = np.random.default_rng(seed).permutation(len(vertices))
    return lodkit.Mesh(vertices[perm], np.argsort(perm)[faces].astype(np.int32))


def strip(n: int = 60) -> lodkit.Mesh:
    """A wavy strip two vertices wide: every vertex is on the boundary."""
    t = np.linspace(0.0, 3.0, n + 1)
    z = 0.05 * np.sin(4.0 * t)
    vertices = np.concatenate([np.stack([t, np.zeros_like(t), z], 1), np.stack([t, np.full_like(t, 0.1), z], 1)])
    i = np.arange(n)
    a, b, c, d = i, i + 1, n + 2 + i, n + 1 + i
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int32)
    return lodkit.Mesh(vertices, faces)


@pytest.fixture(scope="module")
def surface():
    """The demo surface (creases, a terrace, bumps, one boundary loop), 2048 faces."""
    return demo_mesh(2000)


# ----------------------------------------------------------------------------- registry
@pytest.mark.parametrize("name", sorted(PLUGINS))
def test_plugin_is_listed_with_its_package_version_and_kind(name):
    version = require_plugin(name)
    dist, module, kind = PLUGINS[name]
    infos = [i for i in metrics.available(load=True) if i.name == name]
    assert len(infos) == 1, infos
    info = infos[0]
    assert (info.package, info.version, info.kind, info.source) == (dist, version, kind, "entry point")
    assert info.loaded is True and info.error is None
    assert info.target.startswith(module + ":")
    assert info.description
    # by name and by package:name, the same class, from the plugin's own module
    cls = metrics.get(name)
    assert cls is metrics.get(f"{dist}:{name}")
    assert cls.__module__ == module and cls.kind == kind


def test_native_kernel_states_the_kernel_api_it_was_built_for(max_edge):
    from lodkit.kernel import API_VERSION, Kernel

    cls = metrics.get("max_edge_length")
    assert issubclass(cls.kernel, Kernel)
    assert vars(cls.kernel)["api_version"] == API_VERSION


@pytest.mark.parametrize("spec", [
    ("edge_length", {"exponent": 0.0}),
    ("edge_length", {"exponent": -1.0}),
    ("edge_length", {"exponent": "2"}),
    ("edge_length", {"length": 1.0}),
    ("max_edge_length", {"max_length": 0.0}),
    ("max_edge_length", {"max_length": -0.1}),
    ("max_edge_length", {"max_length": True}),
    ("max_edge_length", {"weight": -1.0}),
], ids=lambda s: f"{s[0]}-{next(iter(s[1]))}={next(iter(s[1].values()))!r}")
def test_bad_options_are_refused_by_name(spec, surface):
    require_plugin(spec[0])
    option = next(iter(spec[1]))
    with pytest.raises(OptionError, match=repr(option)):
        lodkit.simplify(surface, target_ratio=0.5, metric=spec)


def test_defaults(edge_length, max_edge):
    el, = metrics.create("edge_length")
    mx, = metrics.create("max_edge_length")
    assert el.params["exponent"] == 2.0 and el.weight == 1.0
    assert mx.params["max_length"] == 0.05 and mx.weight == 1.0   # exact: the options as given


# ----------------------------------------------------------------------------- edge_length
def test_edge_length_alone_reaches_the_target(edge_length, surface):
    result = lodkit.simplify(surface, target_ratio=0.25, metric="edge_length")
    assert result.stop_reason == "target_faces"
    assert result.mesh.n_faces <= result.report["target_faces"] == round(0.25 * surface.n_faces)
    assert result.report["metrics"] == ["edge_length"]
    assert result.report["passes"] > 1                  # the batch driver ran it
    assert_topology_kept(surface, result.mesh)


def test_edge_length_alone_collapses_the_short_edges_first(edge_length):
    grid = graded_grid()

    def share_on_the_short_side(metric):
        result = lodkit.simplify(grid, target_ratio=0.8, metric=metric, record=True)
        assert result.stop_reason == "target_faces"
        removed = result.collapses["removed"]
        assert len(removed) > 100
        return float((grid.vertices[removed, 0] > 0.0).mean())

    # the batch driver collapses the cheapest `fraction` of the candidates per pass, so
    # "shortest first" holds pass by pass: with small passes nearly every collapse is on
    # the short side (measured 0.95), while plain qem (zero cost everywhere on a plane)
    # spreads them over both halves (0.42)
    assert share_on_the_short_side(("edge_length", {"fraction": 0.05})) > 0.9
    assert share_on_the_short_side("qem") < 0.7


def test_edge_length_with_qem_evens_out_edge_lengths(edge_length):
    mesh = demo_mesh(5000)
    alone = lodkit.simplify(mesh, target_ratio=0.2, metric="qem")
    both = lodkit.simplify(mesh, target_ratio=0.2, metric=["qem", ("edge_length", {"weight": 10.0})])
    assert alone.stop_reason == both.stop_reason == "target_faces"
    assert abs(alone.mesh.n_faces - both.mesh.n_faces) <= 2

    def spread(m):
        lengths = edge_lengths(m)
        return lengths.std() / lengths.mean(), lengths.max() / lengths.mean()

    cv_alone, peak_alone = spread(alone.mesh)
    cv_both, peak_both = spread(both.mesh)
    # qem alone makes long thin triangles on the flat parts; measured: cv 0.35 -> 0.26,
    # max/mean 2.7 -> 1.9 on this surface
    assert cv_both < 0.9 * cv_alone, (cv_alone, cv_both)
    assert peak_both < peak_alone, (peak_alone, peak_both)
    assert_topology_kept(mesh, both.mesh)


# ----------------------------------------------------------------------------- max_edge_length
@pytest.mark.parametrize("with_qem", [True, False], ids=["with-qem", "alone"])
def test_max_edge_length_bounds_every_output_edge(max_edge, surface, with_qem):
    limit = 0.08                                          # a fraction of the bbox diagonal
    diag = bbox_diagonal(surface)
    assert edge_lengths(surface).max() <= limit * diag     # the input's edges all are shorter
    spec = ("max_edge_length", {"max_length": limit})
    result = lodkit.simplify(surface, target_ratio=0.3, metric=["qem", spec] if with_qem else spec)
    assert result.stop_reason == "target_faces"
    assert edge_lengths(result.mesh).max() <= limit * diag * (1 + 1e-9)
    assert result.report["vetoed"] > 0                     # it did refuse some collapses ...
    plain = lodkit.simplify(surface, target_ratio=0.3, metric="qem")
    assert edge_lengths(plain.mesh).max() > limit * diag   # ... that plain qem makes
    assert_topology_kept(surface, result.mesh)


def test_batch_positions_are_rechecked_by_the_kernel(max_edge, surface):
    """A batch metric that places the vertex itself (here: far along the edge, past its
    end) must not slip past the kernel's veto, which judged the core's position."""

    class Overshoot(lodkit.metrics.BatchMetric):
        def costs(self, batch):
            pos = batch.positions
            return batch.length, pos[batch.u] + 1.5 * (pos[batch.v] - pos[batch.u])

    limit = 0.08
    diag = bbox_diagonal(surface)
    result = lodkit.simplify(surface, target_ratio=0.3, max_normal_angle=180.0, min_quality=0.0,
                             metric=[("max_edge_length", {"max_length": limit}), Overshoot()])
    assert result.n_collapses > 0
    assert edge_lengths(result.mesh).max() <= limit * diag * (1 + 1e-9)


def test_max_edge_length_stops_when_the_target_is_unreachable(max_edge, surface):
    limit = 0.08
    diag = bbox_diagonal(surface)
    result = lodkit.simplify(surface, target_ratio=0.05,
                             metric=["qem", ("max_edge_length", {"max_length": limit})])
    assert result.stop_reason == "no_valid_collapse"
    assert result.mesh.n_faces > result.report["target_faces"]
    assert result.report["vetoed"] > 0
    assert "vetoed" in result.report["stop_detail"]
    assert result.n_collapses > 0
    assert edge_lengths(result.mesh).max() <= limit * diag * (1 + 1e-9)
    assert_topology_kept(surface, result.mesh)


def test_max_edge_length_vetoes_everything_below_the_input_edges(max_edge, surface):
    # shorter than almost every input edge: (nearly) nothing may collapse, nothing breaks
    result = lodkit.simplify(surface, target_ratio=0.5, metric=("max_edge_length", {"max_length": 0.01}))
    assert result.stop_reason == "no_valid_collapse"
    assert result.n_collapses <= 2 and result.report["vetoed"] > 0
    assert result.mesh.n_faces >= surface.n_faces - 4


@pytest.mark.parametrize("boundary", ["free", "preserve"])
def test_max_edge_length_checks_the_whole_boundary_fan(max_edge, boundary):
    # every vertex of a strip is a boundary vertex, and its 1-ring walk ends past a boundary:
    # the last neighbour must be checked too
    mesh = strip()
    diag = bbox_diagonal(mesh)
    limit = 2.5 * edge_lengths(mesh).max() / diag
    result = lodkit.simplify(mesh, target_ratio=0.1, boundary=boundary,
                             metric=("max_edge_length", {"max_length": limit}))
    assert result.n_collapses > 0 and result.report["vetoed"] > 0
    assert edge_lengths(result.mesh).max() <= limit * diag * (1 + 1e-9)
    assert_topology_kept(mesh, result.mesh)


def test_max_edge_length_weight_penalises_long_new_edges(max_edge, surface):
    # a bigger weight prices long new edges higher: the output's edges get no longer
    light = lodkit.simplify(surface, target_ratio=0.3,
                            metric=["qem", ("max_edge_length", {"max_length": 0.1, "weight": 0.0})])
    heavy = lodkit.simplify(surface, target_ratio=0.3,
                            metric=["qem", ("max_edge_length", {"max_length": 0.1, "weight": 1e3})])
    assert light.stop_reason == heavy.stop_reason == "target_faces"
    assert edge_lengths(heavy.mesh).mean() <= edge_lengths(light.mesh).mean()
    assert not np.array_equal(light.mesh.faces, heavy.mesh.faces)


# ----------------------------------------------------------------------------- both
# id -> (metric spec, plugin metrics it needs)
SPECS = {
    "edge_length": ("edge_length", ["edge_length"]),
    "qem+edge_length": (["qem", ("edge_length", {"weight": 2.0, "exponent": 3.0})], ["edge_length"]),
    "qem+max_edge_length": (["qem", ("max_edge_length", {"max_length": 0.08})], ["max_edge_length"]),
    "all": (["qem", ("max_edge_length", {"max_length": 0.08}), ("edge_length", {"weight": 1e-6})],
            ["edge_length", "max_edge_length"]),
}


@pytest.mark.parametrize("key", sorted(SPECS))
def test_runs_are_deterministic(key, surface):
    spec, needs = SPECS[key]
    for name in needs:
        require_plugin(name)
    a = lodkit.simplify(surface, target_ratio=0.3, metric=spec)
    b = lodkit.simplify(surface, target_ratio=0.3, metric=spec)
    assert a.stop_reason == b.stop_reason and a.n_collapses == b.n_collapses
    assert np.array_equal(a.mesh.vertices, b.mesh.vertices)
    assert np.array_equal(a.mesh.faces, b.mesh.faces)
    assert np.array_equal(a.vertex_map, b.vertex_map)
    assert a.report["vetoed"] == b.report["vetoed"]
    assert_topology_kept(surface, a.mesh)


def test_both_plugins_on_a_real_mesh(edge_length, max_edge):
    mesh = lodkit.load(shared_mesh("fandisk.obj"))         # closed CAD part, sharp creases
    diag = bbox_diagonal(mesh)
    limit = 0.05
    result = lodkit.simplify(mesh, target_ratio=0.1, metric=[
        "qem", ("max_edge_length", {"max_length": limit}), ("edge_length", {"weight": 1e-6})])
    assert result.report["metrics"] == ["qem", "max_edge_length", "edge_length"]
    assert result.stop_reason in ("target_faces", "no_valid_collapse")
    assert result.mesh.n_faces < 0.5 * mesh.n_faces
    assert edge_lengths(result.mesh).max() <= max(limit * diag, edge_lengths(mesh).max()) * (1 + 1e-9)
    assert_topology_kept(mesh, result.mesh)
