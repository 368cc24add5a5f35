"""simplify(operator=) is chosen one way, and the numbers Python hands the core are the
core's own (the Python mirrors of the .pxd enums are checked against the .pxd files)."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import lodkit
from lodkit import _compile, _pipeline, settings
from lodkit.errors import OptionError


def grid(n=8):
    xs, ys = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float))
    v = np.stack([xs.ravel(), ys.ravel(), 0.1 * np.sin(xs.ravel()) * np.cos(ys.ravel())], axis=1)
    f = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, i * n + j + 1, (i + 1) * n + j, (i + 1) * n + j + 1
            f += [[a, b, d], [a, d, c]]
    return lodkit.Mesh(v, np.array(f))


def test_a_removal_metric_implies_vertex_removal():
    mesh = grid()
    implied = lodkit.simplify(mesh, target_ratio=0.5, metric="schroeder")
    named = lodkit.simplify(mesh, target_ratio=0.5, metric="schroeder", operator="vertex_removal")
    assert implied.report["operator"] == named.report["operator"] == "vertex_removal"
    assert np.array_equal(implied.mesh.faces, named.mesh.faces)
    assert np.array_equal(implied.vertex_map, named.vertex_map)


@pytest.mark.parametrize("metric", ["qem", "melod", ["qem", "importance"]])
def test_vertex_removal_needs_a_removal_metric(metric):
    with pytest.raises(OptionError, match="operator='vertex_removal' needs a vertex-removal metric"):
        lodkit.simplify(grid(), target_ratio=0.5, metric=metric, operator="vertex_removal")


def test_triangle_refuses_a_removal_metric():
    with pytest.raises(OptionError, match="takes quadric metrics only"):
        lodkit.simplify(grid(), target_ratio=0.5, metric="schroeder", operator="triangle")


def test_every_operator_has_a_driver():
    from lodkit.drivers import DRIVERS

    assert set(DRIVERS) == set(settings.OPERATORS)
    for driver in DRIVERS.values():
        for name in ("FIX_SEAMS", "check", "setup", "run", "records"):
            assert hasattr(driver, name), (driver.__name__, name)


def _pxd_constants() -> dict:
    """NAME = integer from every enum of lodkit/_core/*.pxd."""
    out = {}
    for pxd in sorted((Path(lodkit.__file__).parent / "_core").glob("*.pxd")):
        for name, value in re.findall(r"^\s+([A-Z][A-Z0-9_]*)\s*=\s*(-?\d+)", pxd.read_text(), re.M):
            out.setdefault(name, int(value))
    return out


def test_python_mirrors_of_the_core_constants():
    pxd = _pxd_constants()
    assert _pipeline.QSIZE == pxd["QSIZE"] and _pipeline.VSTRIDE == pxd["VSTRIDE"]
    assert _pipeline.VSTRIDE == _pipeline.QSIZE + 3
    for name in ("RUN_TARGET", "RUN_CHUNK", "RUN_EXHAUSTED", "RUN_ERROR", "SEAM_NONE", "SEAM_STAYS"):
        assert getattr(_pipeline, name) == pxd[name], name
    assert settings.PLACEMENTS == {"optimal": pxd["PLACE_OPTIMAL"], "endpoint": pxd["PLACE_ENDPOINT"]}
    assert settings.BOUNDARY_POLICIES == {"lock": pxd["BOUNDARY_LOCK"], "preserve": pxd["BOUNDARY_PRESERVE"],
                                          "free": pxd["BOUNDARY_FREE"]}
    assert settings.COLLAPSE_OPERATORS == {"edge": pxd["OP_EDGE"], "triangle": pxd["OP_TRIANGLE"]}
    assert (_compile.STEP_VERTEX_FIELD, _compile.STEP_EDGE_FIELD, _compile.STEP_KERNEL) == (
        pxd["STEP_VFIELD"], pxd["STEP_EFIELD"], pxd["STEP_KERNEL"])


def test_vertex_removal_statuses_match():
    from lodkit._core import vremove

    assert (vremove.RUN_TARGET, vremove.RUN_CHUNK, vremove.RUN_EXHAUSTED, vremove.RUN_ERROR) == (
        _pipeline.RUN_TARGET, _pipeline.RUN_CHUNK, _pipeline.RUN_EXHAUSTED, _pipeline.RUN_ERROR)
