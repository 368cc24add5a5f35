"""Cost metrics: the registry (entry points, broken plugins, ambiguous and shadowed names,
the discovery switch, register), options, each of the four kinds end to end through
``simplify`` (quadric, vertex and edge fields, native kernels, batch), the field merge
rules and kernels driven directly, combinations, determinism, and a property test over
random meshes and random metric combinations.

Every test runs with entry-point discovery off unless it turns it on itself (with fake or
temporary entry points), so plugins installed in the environment do not change results.
"""
from __future__ import annotations

import ast
import importlib
import json
import os
import re
import subprocess
import sys
import textwrap
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lodkit
import lodkit.metrics as M
from lodkit import MetricError, OptionError, UnknownMetricError
from lodkit._core.decimate import EdgeCollapser, vertex_quadrics
from lodkit._core.halfedge import build
from lodkit.kernel import API_VERSION, ERROR, OK, VETO, Kernel
from lodkit.metrics import BatchMetric, FieldMetric, KernelMetric, Metric, Option, QuadricMetric
from native import load
from test_qem import uv_sphere
from test_simplify import grid

testkernels = load("lodkit_testkernels")    # tests/native/lodkit_testkernels.pyx, built for the tests

REPO = Path(__file__).resolve().parents[1]
# where the lodkit under test lives (the installed copy in CI, the source tree in a dev
# checkout): subprocesses must import that one, not an unbuilt source tree
LODKIT_ROOT = Path(lodkit.__file__).resolve().parents[1]
BUILTIN_NAMES = sorted(M.BUILTINS)


@pytest.fixture(autouse=True)
def no_discovery(monkeypatch):
    """Built-ins only (and what a test registers): the environment's plugins stay out."""
    monkeypatch.setenv(M.DISCOVERY_ENV, "0")
    M.refresh()
    yield
    M.refresh()


@pytest.fixture
def fake_entry_points(monkeypatch):
    """Discovery on, over the list of entry points the test fills in; nothing registered."""
    eps: list = []
    monkeypatch.delenv(M.DISCOVERY_ENV, raising=False)
    monkeypatch.setattr(M, "_entry_points", lambda: list(eps))
    monkeypatch.setattr(M, "_registered", {})
    M.refresh()
    yield eps
    M.refresh()


@pytest.fixture
def registry(monkeypatch):
    """A clean in-process registry: ``register`` here is undone after the test."""
    monkeypatch.setattr(M, "_registered", {})
    return M


# ---------------------------------------------------------------------- meshes
def grid_mesh(nx: int = 20, ny: int = 20, seed: int = 0, amplitude: float = 0.3) -> lodkit.Mesh:
    """A jittered height field over an nx x ny grid of unit quads (one boundary loop)."""
    return lodkit.Mesh(*grid(nx, ny, np.random.default_rng(seed), amplitude, alternate=True))


def sphere_mesh(n_lon: int = 12, n_lat: int = 8, seed: int = 0) -> lodkit.Mesh:
    """A closed, radially jittered UV sphere (poles 0 and 1), outward normals."""
    return lodkit.Mesh(*uv_sphere(n_lon, n_lat, jitter=0.05, seed=seed, uniform=True))


OCTAHEDRON = lodkit.Mesh(
    np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]),
    np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]),
)


def input_edges(mesh) -> set:
    f = mesh.faces
    pairs = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    return {tuple(sorted(map(int, p))) for p in pairs}


def left_region(mesh, x: float = 7.0) -> np.ndarray:
    return mesh.vertices[:, 0] < x


def kept_in(result, region) -> int:
    """How many output vertices stand for input vertices of ``region``."""
    return int(region[result.vertex_map].sum())


def same_output(a, b) -> bool:
    return (np.array_equal(a.mesh.vertices, b.mesh.vertices) and np.array_equal(a.mesh.faces, b.mesh.faces)
            and np.array_equal(a.vertex_map, b.vertex_map) and np.array_equal(a.face_map, b.face_map)
            and (a.error, a.stop_reason, a.n_collapses) == (b.error, b.stop_reason, b.n_collapses))


# ---------------------------------------------------------------------- metrics used by the tests
class CopyQEM(QuadricMetric):
    """QEM's quadrics handed back as a copy (the general folding path, not the shortcut)."""

    def quadrics(self, ctx):
        return ctx.face_quadrics.copy()


class DoubledQEM(QuadricMetric):
    """Twice QEM's quadrics at weight 1: the same order, an error sqrt(2) times QEM's."""

    def quadrics(self, ctx):
        return 2.0 * ctx.face_quadrics


class BadQuadrics(QuadricMetric):
    options = {"what": Option("shape", kind=str, choices=("shape", "nan", "text"))}

    def quadrics(self, ctx):
        q = ctx.face_quadrics.copy()
        if self.params["what"] == "shape":
            return q[:, :9]
        if self.params["what"] == "nan":
            q[3, 2] = np.nan
            return q
        return [["x"] * 10] * ctx.n_vertices


class EdgeTag(FieldMetric):
    """Per-edge field: 1 on edges with both input ends left of ``x``, else 0."""

    per = "edge"
    options = {"x": Option(7.0)}

    def values(self, ctx):
        ends = ctx.mesh.vertices[ctx.input_vertex[ctx.edges]]
        return (ends[:, :, 0] < self.params["x"]).all(axis=1).astype(float)


class ZeroEdgeField(FieldMetric):
    per = "edge"

    def values(self, ctx):
        return np.zeros((ctx.n_edges, 2))


class BadField(FieldMetric):
    def values(self, ctx):
        return np.zeros(ctx.n_vertices + 1)


class Veto(KernelMetric):
    kernel = testkernels.VetoAll


class Fail(KernelMetric):
    kernel = testkernels.FailAfter
    options = {"n": Option(0, kind=int, min=0)}


class Midpoint(KernelMetric):
    kernel = testkernels.MidpointPlacer


class Scale(KernelMetric):
    """ScaleBy; keeps the kernel it made so a test can read its counters."""

    kernel = testkernels.ScaleBy
    options = {"factor": Option(1.0)}
    made = None

    def make_kernel(self, ctx):
        self.made = super().make_kernel(ctx)
        return self.made


class WrongKernelObject(KernelMetric):
    kernel = testkernels.VetoAll

    def make_kernel(self, ctx):
        return testkernels.ScaleBy()


class ShortestEdge(BatchMetric):
    """Shortest edge first (the current length)."""

    def costs(self, batch):
        return batch.length


class MidpointBatch(BatchMetric):
    """Shortest edge first, new vertex at the midpoint of the current edge."""

    def costs(self, batch):
        mid = 0.5 * (batch.positions[batch.u] + batch.positions[batch.v])
        return batch.length, mid


class BadBatch(BatchMetric):
    options = {"what": Option("nan", kind=str, choices=("nan", "shape", "triple", "positions", "nanpos"))}

    def costs(self, batch):
        k = len(batch)
        what = self.params["what"]
        if what == "nan":
            c = np.ones(k)
            c[k // 2] = np.nan
            return c
        if what == "shape":
            return np.ones(k + 1)
        if what == "triple":
            return np.ones(k), batch.position, None
        if what == "positions":
            return np.ones(k), batch.position[:, :2]
        pos = batch.position.copy()
        pos[0, 1] = np.nan
        return np.ones(k), pos


class NoVersionKernel(Kernel):
    pass


class OtherVersionKernel(Kernel):
    api_version = API_VERSION + 1


class NoVersionMetric(KernelMetric):
    kernel = NoVersionKernel


class OtherVersionMetric(KernelMetric):
    kernel = OtherVersionKernel


class NotAKernelMetric(KernelMetric):
    kernel = dict


class NoKindMetric(Metric):
    pass


class FaceField(FieldMetric):
    per = "face"


class BadOptionMetric(QuadricMetric):
    options = {"size": 3}


def not_a_metric():
    return None


class PlainClass:
    pass


# ---------------------------------------------------------------------- fake entry points
class FakeDist:
    def __init__(self, name: str, version: str):
        self.metadata = {"Name": name}
        self.version = version


_IMPORT = object()


class FakeEntryPoint:
    """What the registry reads of an importlib.metadata entry point.  ``obj`` is what
    ``load()`` returns (default: import ``target`` for real); loads are logged in ``log``."""

    def __init__(self, name, target, package="acme-metrics", version="1.0", obj=_IMPORT, log=None):
        self.name, self.value, self.group = name, target, M.GROUP
        self.dist = FakeDist(package, version)
        self.obj = obj
        self.log = log

    def load(self):
        if self.log is not None:
            self.log.append((self.dist.metadata["Name"], self.name))
        if self.obj is _IMPORT:
            return metadata.EntryPoint(self.name, self.value, M.GROUP).load()
        return self.obj


def infos(name=None, load=False):
    return [i for i in M.available(load=load) if name is None or i.name == name]


# ---------------------------------------------------------------------- registry
def test_builtins_are_available_without_discovery():
    names = [i.name for i in M.available()]
    assert names == BUILTIN_NAMES
    kinds = {i.name: i.kind for i in M.available(load=True)}
    assert kinds == {"qem": "quadric", "qem_native": "kernel", "importance": "field", "melod": "kernel",
                     "normal_qem": "quadric", "curvature": "kernel", "appearance": "quadric",
                     "schroeder": "removal", "volume": "removal"}
    for info in M.available(load=True):
        assert info.package == "lodkit" and info.version == lodkit.__version__
        assert info.loaded is True and info.error is None and info.description
    assert M.get("qem") is importlib.import_module("lodkit.metrics.qem").QEM
    assert M.get("lodkit:qem") is M.get("qem")


def test_builtins_table_matches_pyproject():
    try:
        import tomllib
    except ImportError:  # Python 3.10
        tomllib = pytest.importorskip("tomli")
    with open(REPO / "pyproject.toml", "rb") as fh:
        table = tomllib.load(fh)["project"]["entry-points"][M.GROUP]
    assert table == M.BUILTINS
    for name, target in M.BUILTINS.items():      # and each target is a well-formed metric
        module, _, attr = target.partition(":")
        assert M.check_metric_class(getattr(importlib.import_module(module), attr)) is None, name


def test_broken_plugin_is_reported_and_does_not_break_the_others(fake_entry_points):
    fake_entry_points.append(FakeEntryPoint("broken", "acme_no_such_module:Metric", "acme-metrics", "0.3"))
    fake_entry_points.append(FakeEntryPoint("copy", "x:y", "acme-good", "2.0", obj=CopyQEM))
    (info,) = infos("broken")
    assert (info.package, info.version, info.loaded, info.error) == ("acme-metrics", "0.3", None, None)
    (info,) = infos("broken", load=True)
    assert info.loaded is False and info.kind is None
    assert info.error == "import failed: ModuleNotFoundError: No module named 'acme_no_such_module'"
    with pytest.raises(MetricError) as exc:
        M.get("broken")
    msg = str(exc.value)
    assert "'broken'" in msg and "acme-metrics 0.3" in msg and "acme_no_such_module" in msg
    # everything else works, the registry and simplify alike
    assert M.get("copy") is CopyQEM and M.get("qem").kind == "quadric"
    mesh = grid_mesh(8, 8)
    a = lodkit.simplify(mesh, target_ratio=0.3, metric="copy")
    assert same_output(a, lodkit.simplify(mesh, target_ratio=0.3))
    with pytest.raises(MetricError, match="acme_no_such_module"):
        lodkit.simplify(mesh, target_ratio=0.3, metric=["qem", "broken"])


def _write_dist(root: Path, name: str, version: str, entry_points: dict, modules: dict | None = None) -> None:
    info = root / f"{name.replace('-', '_')}-{version}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n")
    lines = [f"[{M.GROUP}]"] + [f"{k} = {v}" for k, v in entry_points.items()]
    (info / "entry_points.txt").write_text("\n".join(lines) + "\n")
    for module, source in (modules or {}).items():
        (root / f"{module}.py").write_text(textwrap.dedent(source))


ACME_GOOD = """
    from lodkit.metrics import QuadricMetric

    class Good(QuadricMetric):
        '''QEM again, from a plugin.'''

        def quadrics(self, ctx):
            return ctx.face_quadrics.copy()
    """


def test_real_entry_points_from_an_installed_distribution(tmp_path, monkeypatch):
    """Real importlib.metadata entry points (a .dist-info on sys.path), not fakes."""
    _write_dist(tmp_path, "acme-metrics", "1.2",
                {"acme_broken": "acme_no_such_module:Metric", "acme_good": "acme_good_mod:Good"},
                {"acme_good_mod": ACME_GOOD})
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delenv(M.DISCOVERY_ENV, raising=False)
    monkeypatch.delitem(sys.modules, "acme_good_mod", raising=False)
    M.refresh()
    found = {i.name: i for i in M.available(load=True)}
    assert set(BUILTIN_NAMES) <= set(found)
    broken, good = found["acme_broken"], found["acme_good"]
    assert ((broken.package, broken.version, broken.source, broken.loaded)
            == ("acme-metrics", "1.2", "entry point", False))
    assert "No module named 'acme_no_such_module'" in broken.error
    assert (good.loaded, good.kind, good.description) == (True, "quadric", "QEM again, from a plugin.")
    mesh = grid_mesh(8, 8)
    assert same_output(lodkit.simplify(mesh, target_ratio=0.3, metric="acme-metrics:acme_good"),
                       lodkit.simplify(mesh, target_ratio=0.3))
    sys.modules.pop("acme_good_mod", None)


def test_import_lodkit_is_unaffected_by_a_broken_plugin(tmp_path):
    _write_dist(tmp_path, "acme-broken", "0.1", {"qem": "acme_no_such_module:X", "bad": "acme_no_such_module:Y"})
    script = textwrap.dedent("""
        import json, numpy as np, lodkit
        m = lodkit.Mesh(np.random.default_rng(0).normal(size=(4, 3)), [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
        r = lodkit.simplify(m, target_faces=4, metric="qem")
        print(json.dumps([[i.name, i.package, i.loaded, i.error] for i in lodkit.metrics.available(load=True)]))
    """)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), str(LODKIT_ROOT)]))
    env.pop(M.DISCOVERY_ENV, None)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env,
                          cwd=tmp_path, timeout=120)
    assert proc.returncode == 0, proc.stderr
    rows = {(name, package): (loaded, error) for name, package, loaded, error in json.loads(proc.stdout)}
    assert rows[("qem", "lodkit")] == (True, None)            # lodkit's own qem wins the name
    assert rows[("qem", "acme-broken")][0] is False
    assert "acme_no_such_module" in rows[("bad", "acme-broken")][1]


@pytest.mark.parametrize("obj, problem", [
    (not_a_metric, "not a subclass of lodkit.metrics.Metric"),
    (PlainClass, "not a subclass of lodkit.metrics.Metric"),
    (NoKindMetric, "has kind ''"),
    (FaceField, "per='face'"),
    (BadOptionMetric, "option 'size' is 3"),
    (NotAKernelMetric, "not a subclass of lodkit.kernel.Kernel"),
    (NoVersionMetric, "does not state the kernel API"),
    (OtherVersionMetric, f"built for kernel API version {API_VERSION + 1}, this lodkit has version {API_VERSION}"),
], ids=["function", "plain class", "no kind", "face field", "bad option", "not a kernel",
        "kernel without api_version", "kernel for another api"])
def test_plugin_of_the_wrong_shape(fake_entry_points, obj, problem):
    fake_entry_points.append(FakeEntryPoint("odd", "acme:odd", "acme-odd", "0.9", obj=obj))
    fake_entry_points.append(FakeEntryPoint("copy", "acme:copy", "acme-odd", "0.9", obj=CopyQEM))
    (info,) = infos("odd", load=True)
    assert info.loaded is False and problem in info.error and info.error.startswith("acme:odd ")
    with pytest.raises(MetricError) as exc:
        M.get("odd")
    assert "'odd'" in str(exc.value) and "acme-odd 0.9" in str(exc.value) and problem in str(exc.value)
    assert M.get("copy") is CopyQEM                    # its neighbour is fine
    with pytest.raises(MetricError, match=problem.split("'")[0]):
        M.register("odd2", obj)                        # register checks the same way
    if isinstance(obj, type) and issubclass(obj, Metric):
        with pytest.raises(MetricError):
            M.create(obj)                              # and so does a class passed directly


def test_two_packages_with_one_name(fake_entry_points):
    fake_entry_points.append(FakeEntryPoint("curv", "b:C", "pkg-b", "2.0", obj=DoubledQEM))
    fake_entry_points.append(FakeEntryPoint("curv", "a:C", "pkg_a", "1.0", obj=CopyQEM))
    assert [(i.package, i.version) for i in infos("curv")] == [("pkg_a", "1.0"), ("pkg-b", "2.0")]
    with pytest.raises(MetricError) as exc:
        M.get("curv")
    msg = str(exc.value)
    assert "pkg_a 1.0" in msg and "pkg-b 2.0" in msg and "'pkg_a:curv' or 'pkg-b:curv'" in msg
    assert M.get("pkg_a:curv") is CopyQEM and M.get("pkg-b:curv") is DoubledQEM
    assert M.get("PKG-A:curv") is CopyQEM             # package names compare normalised
    (m,) = M.create(("pkg-b:curv", {"weight": 2.0}))
    assert isinstance(m, DoubledQEM) and m.name == "curv" and m.weight == 2.0
    with pytest.raises(UnknownMetricError, match="package 'pkg-c' provides no metric 'curv'"):
        M.get("pkg-c:curv")


def test_lodkit_wins_its_own_names(fake_entry_points):
    fake_entry_points.append(FakeEntryPoint("qem", "s:Q", "shadow-metrics", "3.1", obj=DoubledQEM))
    assert [i.package for i in infos("qem")] == ["lodkit", "shadow-metrics"]
    assert M.get("qem") is importlib.import_module("lodkit.metrics.qem").QEM
    assert M.get("shadow-metrics:qem") is DoubledQEM
    mesh = grid_mesh(8, 8)
    assert same_output(lodkit.simplify(mesh, target_ratio=0.3, metric="qem"),
                       lodkit.simplify(mesh, target_ratio=0.3, metric="lodkit:qem"))
    r = lodkit.simplify(mesh, target_ratio=0.3, metric="shadow-metrics:qem")
    assert r.report["metrics"] == ["qem"]


def test_lodkit_entry_points_are_used_when_installed(fake_entry_points):
    """With lodkit's own entry points installed, they replace the BUILTINS table."""
    for name, target in M.BUILTINS.items():
        fake_entry_points.append(FakeEntryPoint(name, target, "lodkit", "9.9"))
    got = infos(load=True)
    assert [(i.name, i.package, i.version, i.source, i.loaded) for i in got] == \
        [(n, "lodkit", "9.9", "entry point", True) for n in BUILTIN_NAMES]


def test_available_does_not_import_entry_points(fake_entry_points):
    log: list = []
    fake_entry_points.append(FakeEntryPoint("alpha", "a:A", "pkg-a", obj=CopyQEM, log=log))
    fake_entry_points.append(FakeEntryPoint("beta", "b:B", "pkg-b", obj=ShortestEdge, log=log))
    fake_entry_points.append(FakeEntryPoint("gamma", "no_such_mod_gamma:G", "pkg-c", log=log))
    listed = M.available()
    assert [i.name for i in listed] == sorted(["alpha", "beta", "gamma", *BUILTIN_NAMES])
    assert log == []
    assert all(i.loaded is None and i.kind is None for i in listed if i.package != "lodkit")
    assert M.get("beta") is ShortestEdge
    assert log == [("pkg-b", "beta")]                  # get() imports just the one asked for
    M.available(load=True)
    assert sorted(log) == [("pkg-a", "alpha"), ("pkg-b", "beta"), ("pkg-c", "gamma")]
    M.available(load=True)
    M.get("alpha")
    with pytest.raises(MetricError):
        M.get("gamma")
    assert len(log) == 3                               # each loaded once, failures included
    M.refresh()
    M.get("alpha")
    assert len(log) == 4                               # refresh() forgets what was loaded


def test_duplicate_entry_point_of_one_distribution_is_listed_once(fake_entry_points):
    fake_entry_points.append(FakeEntryPoint("alpha", "a:A", "pkg-a", obj=CopyQEM))
    fake_entry_points.append(FakeEntryPoint("alpha", "a:A", "pkg-a", obj=CopyQEM))
    assert len(infos("alpha")) == 1
    assert M.get("alpha") is CopyQEM


@pytest.mark.parametrize("value", ["0", "off", "false", "no", "OFF"])
def test_discovery_switch(fake_entry_points, monkeypatch, value):
    log: list = []
    fake_entry_points.append(FakeEntryPoint("alpha", "a:A", obj=CopyQEM, log=log))
    fake_entry_points.append(FakeEntryPoint("qem", "a:Q", obj=DoubledQEM, log=log))
    assert "alpha" in [i.name for i in M.available()]
    monkeypatch.setenv(M.DISCOVERY_ENV, value)
    M.refresh()
    assert [(i.name, i.package, i.source) for i in M.available(load=True)] == \
        [(n, "lodkit", "built-in") for n in BUILTIN_NAMES]
    assert log == []
    with pytest.raises(UnknownMetricError, match="'alpha'"):
        M.get("alpha")
    M.register("local", CopyQEM)                         # register still works
    assert M.get("local") is CopyQEM


def test_unknown_metric_lists_the_available_ones(fake_entry_points):
    fake_entry_points.append(FakeEntryPoint("alpha", "a:A", obj=CopyQEM))
    with pytest.raises(UnknownMetricError) as exc:
        M.get("kurvature")
    listed = ", ".join(sorted(["alpha", *BUILTIN_NAMES]))
    assert str(exc.value) == f"unknown metric 'kurvature'; available: {listed}"
    assert isinstance(exc.value, OptionError) and isinstance(exc.value, LookupError)
    with pytest.raises(UnknownMetricError, match=f"available: {listed}"):
        lodkit.simplify(grid_mesh(4, 4), target_ratio=0.5, metric=["qem", "kurvature"])


def test_register_unregister_replace(registry):
    M.register("copy_qem", CopyQEM)
    assert M.get("copy_qem") is CopyQEM
    (info,) = infos("copy_qem")
    assert (info.source, info.loaded, info.kind) == ("register", True, "quadric")
    with pytest.raises(MetricError, match="already registered"):
        M.register("copy_qem", DoubledQEM)
    M.register("copy_qem", DoubledQEM, replace=True)
    assert M.get("copy_qem") is DoubledQEM
    with pytest.raises(MetricError, match="already registered"):
        M.register("qem", CopyQEM)                       # a built-in name is taken too
    M.register("qem", CopyQEM, replace=True)             # ... unless replaced on purpose
    assert M.get("qem") is CopyQEM
    M.unregister("qem")
    assert M.get("qem") is importlib.import_module("lodkit.metrics.qem").QEM
    M.unregister("copy_qem")
    with pytest.raises(UnknownMetricError):
        M.get("copy_qem")
    with pytest.raises(UnknownMetricError, match="was registered"):
        M.unregister("copy_qem")
    with pytest.raises(UnknownMetricError):
        M.unregister("qem")                              # entry points cannot be unregistered
    for bad in ["", "a:b", 3, None]:
        with pytest.raises(OptionError):
            M.register(bad, CopyQEM)
    with pytest.raises(MetricError, match="not a subclass"):
        M.register("f", not_a_metric)
    with pytest.raises(OptionError, match="must be a string"):
        M.get(3)


# ---------------------------------------------------------------------- options
def test_option_defaults():
    assert M.create("qem")[0].params == {"weight": 1.0}
    assert M.create("qem_native")[0].params == {"weight": 1.0}
    (imp,) = M.create("importance")
    assert imp.params == {"weight": 1.0, "merge": "max", "value": "max", "mode": "scale", "offset": 1.0,
                          "values": None}
    assert imp.name == "importance" and imp.kind == "field" and imp.per == "vertex"
    assert ShortestEdge().params == {"weight": 1.0, "fraction": 0.25}
    assert Fail().params == {"weight": 1.0, "n": 0}
    assert repr(M.create(("importance", {"merge": "min", "weight": 2.0}))[0]) == \
        "<metric importance (field) weight=2.0, merge='min'>"


@pytest.mark.parametrize("name", BUILTIN_NAMES)
def test_every_metric_has_weight(name):
    opt = M.get(name).all_options()["weight"]
    assert opt.default == 1.0 and opt.min == 0.0
    assert M.create((name, {"weight": 2.5}))[0].weight == 2.5   # exact: the option as given
    assert M.create((name, {"weight": 0}))[0].weight == 0.0
    with pytest.raises(OptionError) as exc:
        M.create((name, {"weight": -1.0}))
    assert str(exc.value) == f"metric {name!r}: option 'weight' must be a number >= 0.0, got -1.0"


@pytest.mark.parametrize("spec, message", [
    (("importance", {"merge": "median"}),
     "metric 'importance': option 'merge' must be one of 'max', 'min', 'sum', 'keep', 'mean', got 'median'"),
    (("importance", {"mode": 1}), "option 'mode' must be one of 'scale', 'add', got 1"),
    (("qem", {"weight": "heavy"}), "metric 'qem': option 'weight' must be a number >= 0.0, got 'heavy'"),
    (("qem", {"weight": True}), "option 'weight' must be a number >= 0.0, got True"),
    (("qem", {"weight": float("inf")}), "option 'weight' must be a number >= 0.0, got inf"),
    (("qem", {"weight": float("nan")}), "option 'weight' must be a number >= 0.0, got nan"),
    (("importance", {"values": [1.0, np.nan]}), "metric 'importance': option 'values' holds NaN or infinite values"),
    (("importance", {"values": "high"}), "option 'values' must be an array, got 'high'"),
    ((Fail, {"n": 1.5}), "metric 'Fail': option 'n' must be an integer >= 0, got 1.5"),
    ((Fail, {"n": -1}), "option 'n' must be an integer >= 0, got -1"),
    ((ShortestEdge, {"fraction": 0.0}), "option 'fraction' must be a number >= 1e-06 and <= 1.0, got 0.0"),
    ((ShortestEdge, {"fraction": 1.5}), "option 'fraction' must be a number >= 1e-06 and <= 1.0, got 1.5"),
    (("qem", {"wieght": 2.0}), "metric 'qem' has no option 'wieght'; its options: weight"),
    (("importance", {"valus": [1.0]}),
     "metric 'importance' has no option 'valus'; its options: merge, mode, offset, value, values, weight"),
    (("qem", 2.0), "a metric with options is written (name, {option: value}), got ('qem', 2.0)"),
    (("qem", {}, {}), "a metric with options is written"),
    ([], "metric=[] names no metric"),
    (None, "metric must be a name"),
    (3, "a metric name must be a string, got 3"),
], ids=lambda x: x if isinstance(x, str) else None)
def test_option_errors(spec, message):
    with pytest.raises(OptionError) as exc:
        M.create(spec)
    assert message in str(exc.value)
    assert isinstance(exc.value, ValueError)


def test_bad_options_fail_before_any_work(monkeypatch):
    import lodkit._pipeline

    monkeypatch.setattr(lodkit._pipeline, "prepare",
                        lambda *a, **k: pytest.fail("prepared the mesh before checking metric="))
    with pytest.raises(OptionError, match="'weight'"):
        lodkit.simplify(grid_mesh(4, 4), target_ratio=0.5, metric=[("qem", {"weight": -2})])
    with pytest.raises(UnknownMetricError):
        lodkit.simplify(grid_mesh(4, 4), target_ratio=0.5, metric="nope")


@pytest.mark.parametrize("values, message", [
    (None, "metric 'importance' needs values=: one importance per input vertex"),
    (np.ones(24), "metric 'importance': values must have shape (25,), got (24,)"),
    (np.ones((25, 2)), "values must have shape (25,), got (25, 2)"),
    (-np.ones(25), "metric 'importance': values must be >= 0"),
])
def test_importance_values_are_checked(values, message):
    with pytest.raises(OptionError) as exc:
        lodkit.simplify(grid_mesh(4, 4), target_ratio=0.5, metric=["qem", ("importance", {"values": values})])
    assert message in str(exc.value)


def test_option_class():
    opt = Option(3, kind=int, min=1, max=5)
    assert opt.validate("m", "k", 4) == 4 and opt.validate("m", "k", np.int64(5)) == 5
    for bad in (0, 6, 2.0, True, "3", None):
        with pytest.raises(OptionError, match="metric 'm': option 'k' must be an integer >= 1 and <= 5"):
            opt.validate("m", "k", bad)
    assert Option(None, kind=float, allow_none=True).validate("m", "k", None) is None
    assert Option(False, kind=bool).validate("m", "k", np.bool_(True)) is True
    with pytest.raises(OptionError, match="must be True or False, got 1"):
        Option(False, kind=bool).validate("m", "k", 1)
    arr = Option(None, kind="array").validate("m", "k", [1, 2])
    assert arr.dtype == np.float64 and arr.tolist() == [1.0, 2.0]


# ---------------------------------------------------------------------- quadric metrics
def test_custom_quadric_metric_gives_qem_output(registry):
    M.register("copy_qem", CopyQEM)
    mesh = grid_mesh()
    qem = lodkit.simplify(mesh, target_ratio=0.2)
    copy = lodkit.simplify(mesh, target_ratio=0.2, metric="copy_qem")
    assert same_output(qem, copy)                           # bit for bit
    assert copy.report["metrics"] == ["copy_qem"]
    # sum of weights 2 (a weight, or two metrics): the order is unchanged and the error is
    # still a distance, because it is divided by the total weight
    for spec in [("copy_qem", {"weight": 2.0}), ["qem", "copy_qem"], ("qem", {"weight": 3.0}),
                 [("qem", {"weight": 0.5}), ("copy_qem", {"weight": 0.25})]]:
        r = lodkit.simplify(mesh, target_ratio=0.2, metric=spec)
        assert np.array_equal(r.mesh.faces, qem.mesh.faces), spec
        np.testing.assert_allclose(r.mesh.vertices, qem.mesh.vertices, rtol=0, atol=1e-9)
        assert r.error == pytest.approx(qem.error, rel=1e-9), spec
    # twice the quadrics at weight 1: the same order (without boundary planes, which do not
    # double), and an error that is sqrt(2) times QEM's
    free = lodkit.simplify(mesh, target_ratio=0.2, boundary="free")
    doubled = lodkit.simplify(mesh, target_ratio=0.2, boundary="free", metric=DoubledQEM)
    assert np.array_equal(doubled.mesh.faces, free.mesh.faces)
    assert doubled.error == pytest.approx(np.sqrt(2.0) * free.error, rel=1e-12)
    # with the 'preserve' boundary planes the quadric is doubled against them: another order
    assert not np.array_equal(lodkit.simplify(mesh, target_ratio=0.2, metric=DoubledQEM).mesh.faces,
                              qem.mesh.faces)


def test_quadric_metric_at_weight_zero_only_places():
    mesh = grid_mesh(10, 10)
    r = lodkit.simplify(mesh, target_ratio=0.3, metric=("qem", {"weight": 0.0}))
    assert r.stop_reason == "target_faces" and r.error > 0.0      # the error is still measured


@pytest.mark.parametrize("what, message", [
    ("shape", "returned quadrics of shape (121, 9); expected (121, 10)"),
    ("nan", "returned quadrics with NaN values"),
    ("text", "returned quadrics that are not numbers"),
])
def test_bad_quadrics_raise_metric_error(what, message):
    with pytest.raises(MetricError) as exc:
        lodkit.simplify(grid_mesh(10, 10), target_ratio=0.3, metric=(BadQuadrics, {"what": what}))
    assert "metric 'BadQuadrics'" in str(exc.value) and message in str(exc.value)


# ---------------------------------------------------------------------- vertex fields
def test_importance_keeps_the_important_region_denser():
    mesh = grid_mesh()
    left = left_region(mesh)
    n = mesh.n_vertices
    qem = lodkit.simplify(mesh, target_ratio=0.2)
    zero = lodkit.simplify(mesh, target_ratio=0.2, metric=["qem", ("importance", {"values": np.zeros(n)})])
    assert same_output(zero, qem)                          # cost * (1 + 0): QEM exactly
    high = lodkit.simplify(mesh, target_ratio=0.2,
                           metric=["qem", ("importance", {"values": left.astype(float), "weight": 100.0})])
    assert high.stop_reason == "target_faces" and high.mesh.n_faces in (160, 159)
    assert kept_in(high, left) >= kept_in(qem, left) + 15
    assert kept_in(high, ~left) < kept_in(qem, ~left)
    assert high.error > qem.error                           # the error went elsewhere
    # order does not matter for a quadric and a field
    assert same_output(high, lodkit.simplify(
        mesh, target_ratio=0.2, metric=[("importance", {"values": left.astype(float), "weight": 100.0}), "qem"]))


def test_importance_alone_scales_qem():
    mesh = grid_mesh()
    left = left_region(mesh)
    qem = lodkit.simplify(mesh, target_ratio=0.2)
    zero = lodkit.simplify(mesh, target_ratio=0.2, metric=("importance", {"values": np.zeros(mesh.n_vertices)}))
    assert same_output(zero, qem)
    high = lodkit.simplify(mesh, target_ratio=0.2,
                           metric=("importance", {"values": left.astype(float), "weight": 100.0}))
    assert kept_in(high, left) > kept_in(qem, left)


def _fan():
    """A flat hexagon fan: centre 0, rim 1..6 (all on the boundary)."""
    ang = np.arange(6) * np.pi / 3
    v = np.vstack([[0.0, 0, 0], np.stack([np.cos(ang), np.sin(ang), np.zeros(6)], 1)])
    f = np.array([[0, 1 + i, 1 + (i + 1) % 6] for i in range(6)])
    return v, f


def _edge_table(hm) -> np.ndarray:
    he = hm.edge_halfedges
    c = hm.corners.reshape(-1)
    return np.stack([c[he], c[np.where(he % 3 == 2, he - 2, he + 1)]], axis=1)


RULES = ["max", "min", "sum", "keep", "mean"]         # merge rule codes 0..4 in decimate.pxd


def _merge(kept, removed, rule):
    return {"max": max, "min": min, "sum": lambda a, b: a + b, "keep": lambda a, b: a,
            "mean": lambda a, b: 0.5 * (a + b)}[rule](kept, removed)


def test_field_merge_rules_in_the_core():
    """One collapse of a hand-made fan: the kept vertex takes merge(kept, removed) of each
    vertex field, and the edge each dead wing edge is glued onto merge(surviving, dead)."""
    v, f = _fan()
    hm = build(f, 7)
    edges = _edge_table(hm)
    rng = np.random.default_rng(5)
    efield = rng.uniform(0, 10, (hm.n_edges, 5))
    vfield = rng.uniform(0, 10, (7, 5))
    rules = np.array([[code, 0, 0, 1.0, 1.0] for code in range(5)])   # merge, value, mode, weight, offset
    c = EdgeCollapser(hm, v, vertex_quadrics(hm, v), None, np.zeros(7, np.uint8), boundary=2,
                      vertex_fields=vfield.copy(), vertex_rules=rules, edge_fields=efield.copy(),
                      edge_rules=rules, use_heap=False, record=True)
    np.testing.assert_array_equal(c.edge_field_values, efield)
    e01 = int(np.flatnonzero((np.sort(edges, axis=1) == [0, 1]).all(axis=1))[0])
    assert c.collapse_pass([e01]) == 1
    rec = c.records()
    r, k = int(rec["removed"][0]), int(rec["kept"][0])
    assert {r, k} == {0, 1}
    # vertex fields
    got_v = c.vertex_field_values
    for j, rule in enumerate(RULES):
        assert got_v[k, j] == _merge(vfield[k, j], vfield[r, j], rule), rule
    others = [x for x in range(7) if x not in (r, k)]
    np.testing.assert_array_equal(got_v[others], vfield[others])
    # edge fields: the wings (r, w) die onto (k, w), w = 2 and 6
    def eid(a, b):
        return int(np.flatnonzero((np.sort(edges, axis=1) == sorted((a, b))).all(axis=1))[0])

    alive = hm.alive_edges
    got_e = c.edge_field_values
    touched = {e01}
    for w in (2, 6):
        survivor, dead = eid(k, w), eid(r, w)
        assert alive[survivor] and not alive[dead]
        touched |= {survivor, dead}
        for j, rule in enumerate(RULES):
            assert got_e[survivor, j] == _merge(efield[survivor, j], efield[dead, j], rule), (w, rule)
    rest = [e for e in range(hm.n_edges) if e not in touched]
    np.testing.assert_array_equal(got_e[rest], efield[rest])


@pytest.mark.parametrize("value, expect", [
    (0, lambda a, b, kept: max(a, b)), (1, lambda a, b, kept: min(a, b)), (2, lambda a, b, kept: a + b),
    (3, lambda a, b, kept: a if kept == "u" else b), (4, lambda a, b, kept: b if kept == "u" else a),
    (5, lambda a, b, kept: 0.5 * (a + b)),
], ids=["max", "min", "sum", "kept", "removed", "mean"])
def test_vertex_field_value_rules_and_modes(value, expect):
    """cost = ((quadric_weight * Q) + w1 * value) * (offset + w2 * value2), fields in order."""
    v, f = _fan()
    hm = build(f, 7)
    vfield = np.array([[3.0, 2.0], [5.0, 7.0], [1.0, 1.0], [1.0, 1.0], [1.0, 1.0], [1.0, 1.0], [1.0, 1.0]])
    rules = np.array([[0, value, 1, 0.5, 0.0],           # add 0.5 * value
                      [0, 0, 0, 2.0, 3.0]])              # then scale by 3 + 2 * max
    c = EdgeCollapser(hm, v, vertex_quadrics(hm, v), None, np.zeros(7, np.uint8), boundary=2,
                      placement=1, quadric_weight=0.0, vertex_fields=vfield, vertex_rules=rules)
    removed, kept, _, cost, err = c.plan_edge(0, 1)
    assert err == 0.0                                    # the fan is flat
    val = expect(vfield[0, 0], vfield[1, 0], "u" if kept == 0 else "v")
    assert cost == pytest.approx((0.5 * val) * (3.0 + 2.0 * 7.0), rel=1e-15)


# ---------------------------------------------------------------------- edge fields
def test_edge_field_end_to_end(registry):
    M.register("edge_tag", EdgeTag)
    mesh = grid_mesh()
    left = left_region(mesh)
    qem = lodkit.simplify(mesh, target_ratio=0.2)
    zero = lodkit.simplify(mesh, target_ratio=0.2, metric=["qem", (ZeroEdgeField, {"mode": "add"})])
    assert same_output(zero, qem)                          # cost + 0 twice: QEM exactly
    tagged = lodkit.simplify(mesh, target_ratio=0.2, metric=["qem", ("edge_tag", {"weight": 1000.0})])
    assert tagged.report["metrics"] == ["qem", "edge_tag"]
    assert kept_in(tagged, left) >= kept_in(qem, left) + 15
    with pytest.raises(MetricError, match=r"metric 'BadField' returned vertex field values of shape \(442,\); "
                                          r"expected \(441,\) or \(441, k\)"):
        lodkit.simplify(mesh, target_ratio=0.2, metric=["qem", BadField])


# ---------------------------------------------------------------------- kernels
def test_kernel_interface_constants():
    assert (OK, VETO, ERROR) == (0, 1, -1)
    assert Kernel.api_version == API_VERSION == 3
    from lodkit._core.qem_kernel import QEMKernel

    for cls in (QEMKernel, testkernels.VetoAll, testkernels.FailAfter, testkernels.MidpointPlacer,
                testkernels.ScaleBy):
        assert issubclass(cls, Kernel) and vars(cls)["api_version"] == API_VERSION, cls


def test_kernels_driven_by_hand():
    base = Kernel()
    assert (base.places, base.failed, base.message) == (False, False, "")
    assert base._call("cost", 0, 1, 1, 0, (0.0, 0.0, 0.0), 2.0) == (OK, 2.0, (0.0, 0.0, 0.0), 1, 0)
    assert base._call("place", 0, 1, 1, 0, (1.0, 2.0, 3.0), 2.0) == (OK, 2.0, (1.0, 2.0, 3.0), 1, 0)
    with pytest.raises(ValueError):
        base._call("bogus", 0, 1, 1, 0, (0.0, 0.0, 0.0), 0.0)

    s = testkernels.ScaleBy()
    s.prepare(None, {"factor": 2.5})
    assert s._call("cost", 3, 4, 3, 4, (0.0, 0.0, 0.0), 2.0) == (OK, 5.0, (0.0, 0.0, 0.0), 3, 4)
    assert s._call("cost", 3, 4, 3, 4, (0.0, 0.0, 0.0), -1.0)[1] == -2.5   # exact: -1.0 * 2.5 is exact in binary
    assert s._call("commit", 3, 4, 3, 4, (0.0, 0.0, 0.0), 0.0)[0] == OK
    assert (s.n_cost, s.n_commit) == (2, 1)

    assert testkernels.VetoAll()._call("cost", 0, 1, 1, 0, (0.0, 0.0, 0.0), 1.0)[0] == VETO
    assert testkernels.VetoAll()._call("commit", 0, 1, 1, 0, (0.0, 0.0, 0.0), 1.0)[0] == OK

    fail = testkernels.FailAfter()
    fail.prepare(None, {"n": 2})
    assert [fail._call("cost", 0, 1, 1, 0, (0.0, 0.0, 0.0), 1.0)[0] for _ in range(4)] == [OK, OK, ERROR, ERROR]
    assert fail.failed and fail.message == "FailAfter: the cost budget is spent"

    mid = testkernels.MidpointPlacer()
    assert mid.places is False
    mid.prepare(None, {})
    assert mid.places is True


def test_qem_native_equals_qem_exactly():
    for mesh, kw in [(grid_mesh(), {}), (grid_mesh(12, 9, seed=4), {"boundary": "lock"}),
                     (grid_mesh(12, 9, seed=5), {"boundary": "free", "placement": "endpoint"}),
                     (sphere_mesh(), {}), (grid_mesh(15, 15, seed=6), {"max_error": 0.01})]:
        a = lodkit.simplify(mesh, target_ratio=0.2, **kw)
        b = lodkit.simplify(mesh, target_ratio=0.2, metric="qem_native", **kw)
        assert same_output(a, b), kw
        assert b.report["metrics"] == ["qem_native"]


def test_qem_native_honours_its_weight():
    mesh = grid_mesh(16, 16, seed=3)
    add = ("importance", {"values": left_region(mesh, 6.0).astype(float), "mode": "add", "weight": 1e-4})
    for w in (4.0, 0.25):             # powers of two: the scaled sums are exact
        a = lodkit.simplify(mesh, target_ratio=0.2, metric=[("qem", {"weight": w}), add])
        b = lodkit.simplify(mesh, target_ratio=0.2, metric=[("qem_native", {"weight": w}), add])
        assert same_output(a, b), w


def test_importance_scales_qem_native_as_it_scales_qem():
    mesh = grid_mesh()
    imp = ("importance", {"values": left_region(mesh).astype(float), "weight": 100.0})
    a = lodkit.simplify(mesh, target_ratio=0.2, metric=["qem", imp])
    b = lodkit.simplify(mesh, target_ratio=0.2, metric=["qem_native", imp])
    assert same_output(a, b)


def test_scale_by_counts_its_calls():
    mesh = grid_mesh()
    qem = lodkit.simplify(mesh, target_ratio=0.2)
    m = Scale(factor=4.0)           # a power of two: every cost scaled exactly, same order
    r = lodkit.simplify(mesh, target_ratio=0.2, metric=["qem", m])
    assert same_output(r, qem)
    assert m.made.n_commit == r.n_collapses == qem.n_collapses
    assert m.made.n_cost >= mesh.n_vertices and m.made.n_cost > r.n_collapses
    # in the batch driver too
    m2 = Scale(factor=4.0)
    r2 = lodkit.simplify(mesh, target_ratio=0.2, metric=[m2, ShortestEdge])
    assert m2.made.n_commit == r2.n_collapses > 0


def test_midpoint_placer_one_collapse():
    r = lodkit.simplify(OCTAHEDRON, target_faces=6, metric=Midpoint)
    assert (r.mesh.n_faces, r.mesh.n_vertices, r.n_collapses, r.stop_reason) == (6, 5, 1, "target_faces")
    (removed,) = sorted(set(range(6)) - set(r.vertex_map.tolist()))
    moved = np.flatnonzero((r.mesh.vertices != OCTAHEDRON.vertices[r.vertex_map]).any(axis=1))
    assert len(moved) == 1
    kept = int(r.vertex_map[moved[0]])
    assert tuple(sorted((removed, kept))) in input_edges(OCTAHEDRON)
    np.testing.assert_allclose(r.mesh.vertices[moved[0]],
                               0.5 * (OCTAHEDRON.vertices[removed] + OCTAHEDRON.vertices[kept]), atol=1e-12)


def _replay_midpoints(mesh, records):
    """Every collapse put the kept vertex at the midpoint of the edge as it was then."""
    pos = mesh.vertices.copy()
    scale = mesh.bbox_diagonal()
    for r, k, p in zip(records["removed"], records["kept"], records["position"]):
        np.testing.assert_allclose(p, 0.5 * (pos[r] + pos[k]), rtol=0, atol=1e-12 * scale)
        pos[k] = p


def test_midpoint_placer_over_a_whole_run():
    mesh = sphere_mesh()
    r = lodkit.simplify(mesh, target_ratio=0.2, metric=["qem", Midpoint], record=True)
    assert r.stop_reason == "target_faces" and r.n_collapses > 50
    _replay_midpoints(mesh, r.collapses)
    edges = input_edges(mesh)
    first = tuple(sorted((int(r.collapses["removed"][0]), int(r.collapses["kept"][0]))))
    assert first in edges


def test_veto_all_leaves_the_mesh_untouched():
    mesh = grid_mesh(10, 10)
    for spec in (Veto, ["qem", Veto], [Veto, ShortestEdge]):
        r = lodkit.simplify(mesh, target_ratio=0.2, metric=spec)
        assert np.array_equal(r.mesh.faces, mesh.faces) and np.array_equal(r.mesh.vertices, mesh.vertices)
        assert (r.n_collapses, r.stop_reason, r.error) == (0, "no_valid_collapse", 0.0)
        assert r.report["vetoed"] > 0
        assert "vetoed" in r.report["stop_detail"] and "unchanged" in r.report["stop_detail"]


@pytest.mark.parametrize("spec", [
    [(Fail, {"n": 0})], ["qem", (Fail, {"n": 5})], [(Fail, {"n": 0}), ShortestEdge],
    [(Fail, {"n": 200}), ShortestEdge],
], ids=["at once", "after 5", "batch at once", "batch after 200"])
def test_kernel_failure_raises_metric_error(spec):
    with pytest.raises(MetricError) as exc:
        lodkit.simplify(grid_mesh(10, 10), target_ratio=0.1, metric=spec)
    assert str(exc.value) == "metric 'Fail' failed during the run: FailAfter: the cost budget is spent"


def test_a_commit_that_vetoes_is_a_contract_error():
    class Veto(M.KernelMetric):
        kernel = testkernels.CommitVeto

    with pytest.raises(M.MetricError, match="commit\\(\\) must return KERNEL_OK or KERNEL_ERROR"):
        lodkit.simplify(grid_mesh(8, 8), target_ratio=0.5, metric=["qem", Veto()])


def test_failing_kernel_with_a_large_budget_is_qem():
    mesh = grid_mesh(10, 10)
    assert same_output(lodkit.simplify(mesh, target_ratio=0.2, metric=["qem", (Fail, {"n": 10**9})]),
                       lodkit.simplify(mesh, target_ratio=0.2))


def test_make_kernel_of_the_wrong_type():
    with pytest.raises(MetricError, match="make_kernel returned ScaleBy, not VetoAll"):
        lodkit.simplify(grid_mesh(4, 4), target_ratio=0.5, metric=WrongKernelObject)


# ---------------------------------------------------------------------- batch metrics
def test_batch_shortest_edge_first(registry):
    M.register("shortest", ShortestEdge)
    mesh = sphere_mesh(seed=2)
    lengths = {e: float(np.linalg.norm(mesh.vertices[e[0]] - mesh.vertices[e[1]])) for e in input_edges(mesh)}
    r = lodkit.simplify(mesh, target_ratio=0.25, metric="shortest", record=True)
    assert r.stop_reason == "target_faces" and r.mesh.n_faces == round(0.25 * mesh.n_faces)
    assert r.report["metrics"] == ["shortest"] and r.report["passes"] >= 2
    first = tuple(sorted((int(r.collapses["removed"][0]), int(r.collapses["kept"][0]))))
    assert first == min(lengths, key=lengths.get)
    assert lodkit.topology(r.mesh).is_manifold and lodkit.topology(r.mesh).is_closed
    # a larger fraction needs fewer passes
    r1 = lodkit.simplify(mesh, target_ratio=0.25, metric=("shortest", {"fraction": 1.0}))
    r2 = lodkit.simplify(mesh, target_ratio=0.25, metric=("shortest", {"fraction": 0.05}))
    assert 1 <= r1.report["passes"] < r.report["passes"] < r2.report["passes"]


def test_batch_positions_are_used():
    mesh = sphere_mesh(seed=1)
    r = lodkit.simplify(mesh, target_ratio=0.3, metric=MidpointBatch, record=True)
    assert r.stop_reason == "target_faces" and r.n_collapses > 30
    _replay_midpoints(mesh, r.collapses)


def test_batch_sees_the_cost_of_the_other_metrics():
    seen = {}

    class Spy(BatchMetric):
        def costs(self, batch):
            seen.setdefault("first", (batch.cost.copy(), batch.error.copy(), len(batch), batch.ctx.n_edges))
            return batch.cost

    mesh = grid_mesh(10, 10)
    r = lodkit.simplify(mesh, target_ratio=0.3, metric=["qem", Spy])
    cost, error, k, n_edges = seen["first"]
    assert 0 < k <= n_edges and r.stop_reason == "target_faces"
    assert (cost >= 0).all() and cost.max() > 0 and (error >= 0).all()


@pytest.mark.parametrize("what, message", [
    ("nan", "metric 'BadBatch' returned costs with NaN values"),
    ("shape", "metric 'BadBatch' returned costs of shape"),
    ("triple", "metric 'BadBatch': costs() must return costs or (costs, positions)"),
    ("positions", "metric 'BadBatch' returned positions of shape"),
    ("nanpos", "metric 'BadBatch' returned positions with NaN values"),
])
def test_bad_batch_results_raise_metric_error(what, message):
    with pytest.raises(MetricError) as exc:
        lodkit.simplify(grid_mesh(8, 8), target_ratio=0.3, metric=(BadBatch, {"what": what}))
    assert message in str(exc.value)


# ---------------------------------------------------------------------- combinations, determinism
def test_combining_changes_the_result_in_the_expected_direction():
    mesh = grid_mesh()
    left = left_region(mesh)
    vals = left.astype(float)
    qem = lodkit.simplify(mesh, target_ratio=0.2)
    counts = []
    for w in (0.0, 1.0, 10.0, 100.0):
        r = lodkit.simplify(mesh, target_ratio=0.2, metric=["qem", ("importance", {"values": vals, "weight": w})])
        counts.append(kept_in(r, left))
    assert counts[0] == kept_in(qem, left)
    assert counts == sorted(counts) and counts[-1] > counts[0]
    # a field and a kernel and a batch metric together still reach the target
    r = lodkit.simplify(mesh, target_ratio=0.2,
                        metric=["qem", ("importance", {"values": vals, "weight": 10.0}), Scale(factor=2.0),
                                ShortestEdge])
    assert r.stop_reason == "target_faces" and r.report["metrics"] == ["qem", "importance", "Scale", "ShortestEdge"]


@pytest.mark.parametrize("spec", [
    "qem", "qem_native", ["qem", "importance"], [CopyQEM, EdgeTag, Midpoint], [ShortestEdge],
    ["qem", Scale, MidpointBatch],
], ids=["qem", "qem_native", "qem+importance", "copy+edge+midpoint", "batch", "qem+kernel+batch"])
def test_same_spec_twice_gives_the_same_output(spec):
    mesh = grid_mesh(14, 12, seed=9)
    spec = [("importance", {"values": np.linspace(0, 3, mesh.n_vertices)}) if s == "importance" else s
            for s in (spec if isinstance(spec, list) else [spec])]
    a = lodkit.simplify(mesh, target_ratio=0.25, metric=spec)
    b = lodkit.simplify(mesh.copy(), target_ratio=0.25, metric=spec)
    assert same_output(a, b)
    assert a.report == b.report


# ---------------------------------------------------------------------- property test
POOL = ["qem", "qem_native", "importance", "copy", "edge_tag", "scale", "midpoint", "veto", "shortest",
        "midpoint_batch"]


@st.composite
def meshes_and_metrics(draw):
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if draw(st.booleans()):
        mesh = grid_mesh(draw(st.integers(3, 12)), draw(st.integers(3, 12)), seed=int(rng.integers(2**31)),
                         amplitude=draw(st.sampled_from([0.0, 0.3, 1.5])))
    else:
        mesh = sphere_mesh(draw(st.integers(5, 12)), draw(st.integers(4, 9)), seed=int(rng.integers(2**31)))
    names = draw(st.lists(st.sampled_from(POOL), min_size=1, max_size=3, unique=True))
    spec = []
    for name in names:
        weight = draw(st.sampled_from([0.0, 0.5, 1.0, 20.0]))
        if name in ("qem", "qem_native"):
            spec.append((name, {"weight": weight}))
        elif name == "importance":
            spec.append(("importance", {"values": rng.uniform(0, 2, mesh.n_vertices), "weight": weight,
                                        "merge": draw(st.sampled_from(["max", "min", "sum", "keep", "mean"])),
                                        "mode": draw(st.sampled_from(["scale", "add"]))}))
        else:
            cls = {"copy": CopyQEM, "edge_tag": EdgeTag, "scale": Scale, "midpoint": Midpoint, "veto": Veto,
                   "shortest": ShortestEdge, "midpoint_batch": MidpointBatch}[name]
            spec.append((cls, {"weight": weight}))
    return mesh, spec, names


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(meshes_and_metrics(), st.floats(0.05, 0.9), st.sampled_from(["preserve", "lock", "free"]),
       st.sampled_from(["optimal", "endpoint"]))
def test_any_combination_keeps_the_mesh_valid(case, ratio, boundary, placement):
    mesh, spec, names = case
    r = lodkit.simplify(mesh, target_ratio=ratio, metric=spec, boundary=boundary, placement=placement)
    before, after = lodkit.topology(mesh), lodkit.topology(r.mesh)
    assert after.is_manifold and after.is_oriented
    assert (after.genus, after.n_components, after.n_boundary_loops) == \
        (before.genus, before.n_components, before.n_boundary_loops)
    assert np.isfinite(r.mesh.vertices).all() and np.isfinite(r.error)
    assert r.mesh.n_faces <= mesh.n_faces
    assert r.n_collapses == mesh.n_vertices - r.mesh.n_vertices
    target = r.report["target_faces"]
    if r.stop_reason == "target_faces":
        assert r.mesh.n_faces in (target, target - 1)
    else:
        assert r.stop_reason == "no_valid_collapse" and r.mesh.n_faces > target
        assert r.report["stop_detail"]
    if "veto" in names:
        assert r.n_collapses == 0 and np.array_equal(r.mesh.faces, mesh.faces)
    assert r.report["metrics"] == [s[0] if isinstance(s[0], str) else s[0].__name__ for s in spec]


# ---------------------------------------------------------------------- stubs
# every compiled module has a stub (setup.py MODULES in lodkit._core, PUBLIC_MODULES in lodkit)
def _setup_list(name: str) -> list[str]:
    found = re.search(rf"^{name} = (\[.*?\])", (REPO / "setup.py").read_text(), re.S | re.M)
    return ast.literal_eval(found.group(1))


STUBBED = ([f"_core.{m}" for m in _setup_list("MODULES")] + _setup_list("PUBLIC_MODULES"))


def _stub_path(module: str) -> Path:
    return REPO / "lodkit" / (module.replace(".", "/") + ".pyi")


def test_every_compiled_module_is_stubbed():
    assert len(STUBBED) >= 14 and {"kernel", "removal"} <= set(STUBBED)
    missing = [m for m in STUBBED if not _stub_path(m).is_file()]
    assert not missing, f"no .pyi stub for {missing}"


def _stub_names(path: Path) -> dict:
    tree = ast.parse(path.read_text())
    names: dict = {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            members = set()
            if isinstance(node, ast.ClassDef):
                for item in node.body:
                    if isinstance(item, ast.FunctionDef):
                        members.add(item.name)
                    elif isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name):
                        members.add(item.target.id)
                    elif isinstance(item, ast.Assign):
                        members |= {t.id for t in item.targets if isinstance(t, ast.Name)}
            names[node.name] = members
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names[node.target.id] = set()
        elif isinstance(node, ast.Assign):
            names.update({t.id: set() for t in node.targets if isinstance(t, ast.Name)})
    return names


@pytest.mark.parametrize("module", STUBBED)
def test_stubs_name_every_python_visible_name(module):
    mod = importlib.import_module(f"lodkit.{module}")
    stub = _stub_names(_stub_path(module))
    public = {n for n, o in vars(mod).items() if not n.startswith("_") and n != "np"
              and getattr(o, "__module__", mod.__name__) == mod.__name__}
    assert public <= set(stub), f"not in {module}.pyi: {sorted(public - set(stub))}"
    for name, members in stub.items():
        if name.startswith("_") and not hasattr(mod, name):
            continue                                     # a stub-only helper type
        obj = getattr(mod, name, None)
        assert obj is not None, f"{module}.pyi names {name}, which the module lacks"
        if isinstance(obj, type):
            visible = {n for n in vars(obj) if not n.startswith("__") or n in ("__init__", "__len__", "__contains__")}
            visible -= {"_setup_metric"}                 # called by __init__ only
            assert visible <= members, f"{module}.{name}: not in the stub: {sorted(visible - members)}"
            missing = {m for m in members if not hasattr(obj, m)}
            assert not missing, f"{module}.pyi: {name} has no {sorted(missing)}"


def test_removal_metric_kernel_is_checked():
    from lodkit._core.schroeder_kernel import SchroederKernel
    from lodkit.kernel import Kernel
    from lodkit.removal import API_VERSION, RemovalKernel

    class EdgeKernelAsRemoval(M.RemovalMetric):
        kernel = Kernel

    class BaseRemoval(M.RemovalMetric):
        kernel = RemovalKernel

    class GoodRemoval(M.RemovalMetric):
        kernel = SchroederKernel

    assert "not a subclass of lodkit.removal.RemovalKernel" in M.check_metric_class(EdgeKernelAsRemoval)
    assert "not a subclass of lodkit.removal.RemovalKernel" in M.check_metric_class(BaseRemoval)
    assert M.check_metric_class(GoodRemoval) is None
    assert vars(SchroederKernel)["api_version"] == API_VERSION
