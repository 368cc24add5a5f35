"""The test-only Cython modules (tests/native), and through them the public C interface:
``cimport lodkit.kernel`` / ``lodkit.removal`` and the deprecated old paths
``lodkit._core.kernel`` / ``lodkit._core.removal``, which plugins compiled against 0.1.0's
layout of the names still build against (tests/native/lodkit_oldpath_kernels.pyx)."""
from __future__ import annotations

import importlib
import importlib.util
import sys
import warnings

import numpy as np
import pytest

import lodkit
import lodkit.metrics as M
from conftest import lodkit_subprocess_env
from lodkit.kernel import API_VERSION, Kernel
from lodkit.metrics import KernelMetric, Option, RemovalMetric
from lodkit.removal import RemovalKernel
from native import NativeBuildError, build, load
from test_metrics import _write_dist, grid_mesh

testkernels = load("lodkit_testkernels")
oldpath = load("lodkit_oldpath_kernels")


def test_testkernels_build_against_the_imported_lodkit():
    assert issubclass(testkernels.VetoAll, Kernel)
    assert importlib.util.find_spec("lodkit._core.testkernels") is None     # not shipped in the package


def test_a_broken_source_names_the_module_and_the_compiler_output(tmp_path, monkeypatch):
    monkeypatch.setenv("LODKIT_TEST_BUILD_DIR", str(tmp_path / "cache"))
    src = tmp_path / "broken_kernel.pyx"
    src.write_text("from lodkit.kernel cimport NoSuchName\n")
    with pytest.raises(NativeBuildError, match=r"(?s)broken_kernel.*NoSuchName"):
        build("broken_kernel", src)


# ---------------------------------------------------------------------- the C interface
def test_the_kernel_layout_has_no_chain_link():
    """The driver holds the chain of a combined metric (lodkit._core.chain); plugins compile
    against a Kernel without the driver's link (kernel API 3)."""
    assert API_VERSION == 3
    assert not any(hasattr(Kernel(), name) for name in ("_next", "_chain", "_next_kernel"))
    from lodkit._core.chain import make_chain

    a, b = testkernels.ScaleBy(), testkernels.VetoAll()
    assert make_chain([]) is None
    assert make_chain([a, b]).kernels() == [a, b]
    with pytest.raises(TypeError, match="lodkit.kernel.Kernel"):
        make_chain([a, object()])


def test_removal_hooks_have_defaults():
    base = RemovalKernel()
    assert RemovalKernel.star_local is False and base.veto_note() == ""
    from lodkit._core.schroeder_kernel import SchroederKernel
    from lodkit._core.volume_kernel import VolumeKernel

    assert SchroederKernel.star_local and VolumeKernel.star_local
    assert SchroederKernel().veto_note() == ""
    assert VolumeKernel().veto_note().startswith("kernel vetoes: ")


@pytest.mark.parametrize("old, new, names", [
    ("lodkit._core.kernel", "lodkit.kernel", ["API_VERSION", "OK", "VETO", "ERROR", "Kernel"]),
    ("lodkit._core.removal", "lodkit.removal", ["API_VERSION", "MAX_STAR", "RemovalKernel"]),
])
def test_old_python_paths_warn_and_give_the_same_objects(old, new, names, monkeypatch):
    monkeypatch.delitem(sys.modules, old, raising=False)
    with pytest.warns(DeprecationWarning, match=f"{old} is deprecated.*{new}"):
        mod = importlib.import_module(old)
    current = importlib.import_module(new)
    assert all(getattr(mod, n) is getattr(current, n) for n in names)


def _metric(kernel_cls, **options):
    class Wrapped(KernelMetric):
        name = kernel_cls.__name__.lower()
        kernel = kernel_cls
    Wrapped.options = {k: Option(v, kind=type(v)) for k, v in options.items()}
    return Wrapped


def test_a_kernel_on_the_old_cimport_path_builds_and_runs():
    """OldPathScaleBy cimports lodkit._core.kernel; it runs as ScaleBy (lodkit.kernel) does."""
    assert issubclass(oldpath.OldPathScaleBy, Kernel)
    assert vars(oldpath.OldPathScaleBy)["api_version"] == API_VERSION
    mesh = grid_mesh(12, 12)
    old_scale = _metric(oldpath.OldPathScaleBy, factor=1.0)(factor=3.0)
    old = lodkit.simplify(mesh, target_ratio=0.3, metric=["qem", old_scale])
    new = lodkit.simplify(mesh, target_ratio=0.3, metric=["qem", _metric(testkernels.ScaleBy, factor=1.0)(factor=3.0)])
    assert np.array_equal(old.mesh.faces, new.mesh.faces) and np.array_equal(old.mesh.vertices, new.mesh.vertices)
    assert old.n_collapses == new.n_collapses > 0


def test_the_max_edge_kernel_on_the_old_cimport_path_runs():
    """The lodkit-max-edge plugin's kernel, compiled on the old path: it walks the half-edge
    arrays through the re-exported navigation inlines and vetoes long edges."""
    mesh = grid_mesh(12, 12)
    metric = _metric(oldpath.OldPathMaxEdge, max_length=1.0, weight=0.0)(max_length=0.15, weight=0.0)
    free = lodkit.simplify(mesh, target_ratio=0.1)
    held = lodkit.simplify(mesh, target_ratio=0.1, metric=["qem", metric])
    assert held.mesh.n_faces > free.mesh.n_faces
    if "max_edge_length" in {i.name for i in M.available()}:        # the plugin, on the new path
        try:
            plugin = lodkit.simplify(mesh, target_ratio=0.1,
                                     metric=["qem", ("max_edge_length", {"max_length": 0.15, "weight": 0.0})])
        except lodkit.MetricError:
            return                                                  # a plugin built for another lodkit
        assert np.array_equal(plugin.mesh.faces, held.mesh.faces)


def test_a_removal_kernel_on_the_old_cimport_path_runs():
    class OldFan(RemovalMetric):
        name = "oldfan"
        kernel = oldpath.OldPathFan

    assert issubclass(oldpath.OldPathFan, RemovalKernel)
    r = lodkit.simplify(grid_mesh(10, 10), target_ratio=0.5, metric=OldFan(), boundary="lock")
    assert r.report["operator"] == "vertex_removal" and r.n_collapses > 0


def test_a_plugin_built_for_another_layout_says_rebuild(tmp_path, monkeypatch):
    """Cython refuses a plugin whose base type's size differs (a layout change) at import;
    the registry's message says what to do."""
    _write_dist(tmp_path, "acme-stale", "0.3", {"stale": "acme_stale_mod:Stale"},
                {"acme_stale_mod": """
                    raise ValueError("lodkit._core.kernel.Kernel size changed, may indicate binary "
                                     "incompatibility. Expected 312 from C header, got 304 from PyObject")
                    """})
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delenv(M.DISCOVERY_ENV, raising=False)
    M.refresh()
    try:
        info = {i.name: i for i in M.available(load=True)}["stale"]
        assert not info.loaded
        assert "size changed" in info.error and "kernel API version 3" in info.error
        assert "rebuild the plugin" in info.error
    finally:
        sys.modules.pop("acme_stale_mod", None)
        M.refresh()


def test_no_lodkit_module_imports_the_old_paths(tmp_path):
    """lodkit itself uses the new paths: importing it raises no DeprecationWarning."""
    code = ("import warnings; warnings.simplefilter('error', DeprecationWarning); import lodkit, lodkit.metrics as M; "
            "[M.get(n) for n in ('qem_native', 'melod', 'schroeder', 'volume', 'curvature')]")
    import subprocess

    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=lodkit_subprocess_env(),
                          cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        importlib.import_module("lodkit.kernel")
