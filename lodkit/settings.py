"""The options of :func:`lodkit.simplify`: their defaults, the numbers the core takes for
them, and their checks.  Every check raises :class:`lodkit.OptionError` naming the option.

    resolve_operator(operator, metrics) -> "edge" | "triangle" | "vertex_removal"
    resolve_settings(metrics, **given)  -> {setting: (value, where it came from)}
    resolve_driver(driver), resolve_threads(threads) -> (value, where it came from)
    check_settings(settings, max_error)
    resolve_target(n_faces, target_faces, target_ratio, max_error) -> face target
    locked_mask(locked, n)              -> (n,) bool
"""
from __future__ import annotations

import math
import numbers
import os

import numpy as np

from .errors import OptionError

__all__ = ["SETTING_DEFAULTS", "PLACEMENTS", "BOUNDARY_POLICIES", "OPERATORS", "COLLAPSE_OPERATORS",
           "EDGE_DRIVERS", "resolve_operator", "resolve_settings", "resolve_driver", "resolve_threads", "finite_number",
           "check_settings", "resolve_target", "ERRORS", "resolve_error", "locked_mask", "resolve_prune", "PRUNE_SIZE"]

#: simplify()'s own defaults for the settings a metric may prefer other values of
SETTING_DEFAULTS = {
    "placement": "optimal",
    "boundary": "preserve",
    "boundary_weight": 10.0,
    "max_normal_angle": 90.0,
    "min_quality": 0.1,
}

# The numbers the core takes: the values of the enums Placement, BoundaryPolicy and Operator
# in lodkit/_core/common.pxd (the vertex-removal driver takes the same boundary numbers).
PLACEMENTS = {"optimal": 0, "endpoint": 1}
BOUNDARY_POLICIES = {"lock": 0, "preserve": 1, "free": 2}
#: the collapse driver's candidates: edges, or faces collapsed as two edge collapses
COLLAPSE_OPERATORS = {"edge": 0, "triangle": 1}

#: simplify(operator=): the operators, each run by its driver (lodkit.drivers.DRIVERS)
OPERATORS = ("edge", "triangle", "vertex_removal")

#: simplify(driver=): how edge collapse picks its collapses -- "pass" (the default):
#: error-limited passes, each walking blocks of the surface in memory order on several
#: threads (lodkit/_core/passes.pyx; docs/algorithms.md, "The pass driver"), or "greedy":
#: always the cheapest candidate next, from an indexed heap (the papers' reference order)
EDGE_DRIVERS = ("pass", "greedy")


def resolve_operator(operator, metrics) -> str:
    """The operator that runs: ``operator`` as given, except that a vertex-removal metric
    turns the default "edge" into "vertex_removal" (``metric="schroeder"`` alone removes
    vertices).  Raises when the operator cannot run the metrics."""
    if not isinstance(operator, str) or operator not in OPERATORS:
        raise OptionError(f"operator must be one of {', '.join(OPERATORS)}, got {operator!r}")
    removal = [m for m in metrics if m.kind == "removal"]
    if operator == "triangle":
        other = [m for m in metrics if m.kind != "quadric"]
        if other:
            raise OptionError(f"operator='triangle' takes quadric metrics only; {other[0].name!r} is a "
                              f"{other[0].kind} metric, whose values are defined per edge or vertex "
                              f"pair (use operator='edge')")
    if operator == "vertex_removal" and not removal:
        raise OptionError(f"operator='vertex_removal' needs a vertex-removal metric (one of kind 'removal', "
                          f"e.g. 'schroeder' or 'volume'); {metrics[0].name!r} is a {metrics[0].kind} metric "
                          f"(use operator='edge')")
    if operator == "edge" and removal:
        return "vertex_removal"
    return operator


def resolve_settings(metrics, **given) -> dict:
    """{setting: (value, where it came from)}: the caller's value when given (not None),
    else the first listed metric's ``defaults``, else :data:`SETTING_DEFAULTS`."""
    out = {}
    for key, default in SETTING_DEFAULTS.items():
        value = given.get(key)
        if value is not None:
            out[key] = (value, "caller")
            continue
        for m in metrics:
            if key in m.defaults:
                out[key] = (m.defaults[key], f"metric {m.name}")
                break
        else:
            out[key] = (default, "lodkit")
    return out


def resolve_driver(driver) -> tuple:
    """(driver, where it came from): the caller's ``driver=`` or the default, "pass"."""
    if driver is None:
        return EDGE_DRIVERS[0], "lodkit"
    if not isinstance(driver, str) or driver not in EDGE_DRIVERS:
        raise OptionError(f"driver must be one of {', '.join(EDGE_DRIVERS)}, got {driver!r}")
    return driver, "caller"


def resolve_threads(threads) -> tuple:
    """(threads, where it came from): the caller's ``threads=``, else ``$LODKIT_THREADS``,
    else ``$OMP_NUM_THREADS`` (its first level; Dask's worker processes, for one, set it to
    1, so that the workers of a batch do not each start a thread per core), else the cores
    this process may run on.  The output does not depend on it."""
    if threads is not None:
        if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
            raise OptionError(f"threads must be a positive integer, got {threads!r}")
        return int(threads), "caller"
    env = os.environ.get("LODKIT_THREADS", "").strip()
    if env:
        if not env.isdigit() or int(env) < 1:
            raise OptionError(f"LODKIT_THREADS must be a positive integer, got {env!r}")
        return int(env), "LODKIT_THREADS"
    omp = os.environ.get("OMP_NUM_THREADS", "").split(",")[0].strip()
    if omp.isdigit() and int(omp) >= 1:        # anything else: OpenMP ignores it too
        return int(omp), "OMP_NUM_THREADS"
    try:
        return max(len(os.sched_getaffinity(0)), 1), "cores"
    except (AttributeError, OSError):        # not Linux
        return max(os.cpu_count() or 1, 1), "cores"


def number(name: str, value) -> float:
    """``value`` as a float, or OptionError naming ``name`` when it is not a real number
    (a string, a list, a bool, None...)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.integer, np.floating)):
        raise OptionError(f"{name} must be a number, got {value!r}")
    return float(value)


def finite_number(name: str, value) -> float:
    """:func:`number`, which must also be finite (not NaN, not infinite)."""
    if isinstance(value, (bool, np.bool_)):
        raise OptionError(f"{name} must be a number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise OptionError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(x):
        raise OptionError(f"{name} must be finite, got {value!r}")
    return x


def check_settings(settings: dict, max_error) -> None:
    """Raise OptionError on a setting (from :func:`resolve_settings`) or ``max_error`` out of range."""
    placement, boundary = settings["placement"][0], settings["boundary"][0]
    boundary_weight = settings["boundary_weight"][0]
    max_normal_angle, min_quality = settings["max_normal_angle"][0], settings["min_quality"][0]
    if placement not in PLACEMENTS:
        raise OptionError(f"placement must be one of {', '.join(PLACEMENTS)}, got {placement!r}")
    if boundary not in BOUNDARY_POLICIES:
        raise OptionError(f"boundary must be one of {', '.join(BOUNDARY_POLICIES)}, got {boundary!r}")
    if not (0.0 < number("max_normal_angle", max_normal_angle) <= 180.0):
        raise OptionError(f"max_normal_angle must be in (0, 180] degrees, got {max_normal_angle!r}")
    if not (0.0 <= number("min_quality", min_quality) <= 1.0):
        raise OptionError(f"min_quality must be in [0, 1], got {min_quality!r}")
    if not (number("boundary_weight", boundary_weight) >= 0.0 and math.isfinite(float(boundary_weight))):
        raise OptionError(f"boundary_weight must be a finite number >= 0, got {boundary_weight!r}")
    if max_error is not None and not (number("max_error", max_error) >= 0.0):
        raise OptionError(f"max_error must be >= 0, got {max_error!r}")


#: simplify(error=): what max_error limits -- the collapse error ("qem") or a guaranteed
#: two-sided distance to the input ("hausdorff", docs/error-bound.md)
ERRORS = ("qem", "hausdorff")
#: simplify(sample_spacing=)'s default: the input's triangles split down to pieces whose points are
#: within a quarter of max_error of a corner
SAMPLE_SPACING = 0.25


def resolve_error(error, sample_spacing, max_error, operator, pair_threshold) -> dict:
    """The settings of the error bound: {"error": ("hausdorff", ...), "sample_spacing": (...)},
    or {} for error="qem"; OptionError when the error bound cannot run as asked."""
    if not isinstance(error, str) or error not in ERRORS:
        raise OptionError(f"error must be one of {', '.join(ERRORS)}, got {error!r}")
    if error == "qem":
        if sample_spacing is not None:
            raise OptionError("sample_spacing applies to error='hausdorff' only")
        return {}                    # nothing new in the settings: runs without a bound look as before
    if max_error is None:
        raise OptionError("error='hausdorff' needs max_error= (the distance to stay within)")
    if operator == "triangle":
        raise OptionError("error='hausdorff' runs with operator='edge' (triangle collapse takes "
                          "no error bound)")
    if operator == "vertex_removal":
        raise OptionError("error='hausdorff' runs with edge collapse; vertex removal re-triangulates "
                          "holes with its own checks and takes no error bound (docs/error-bound.md)")
    if pair_threshold is not None:
        raise OptionError("error='hausdorff' does not combine with pair_threshold: pair contraction "
                          "changes the surface before the bound could be measured from it")
    if sample_spacing is None:
        spacing = (SAMPLE_SPACING, "lodkit")
    else:
        x = number("sample_spacing", sample_spacing)
        if not (0.0 < x < 1.0):
            raise OptionError(f"sample_spacing must be in (0, 1) (a fraction of max_error), got {sample_spacing!r}")
        spacing = (x, "caller")
    return {"error": ("hausdorff", "caller"), "sample_spacing": spacing}


def resolve_target(n_faces: int, target_faces, target_ratio, max_error) -> int:
    """The face count to stop at (0 when only ``max_error`` stops the run)."""
    if target_faces is None and target_ratio is None and max_error is None:
        raise OptionError("give a stop criterion: target_faces=, target_ratio= or max_error=")
    target = 0
    if target_faces is not None:
        if isinstance(target_faces, bool) or not isinstance(target_faces, (int, np.integer)) or target_faces < 0:
            raise OptionError(f"target_faces must be a non-negative integer, got {target_faces!r}")
        target = max(target, int(target_faces))
    if target_ratio is not None:
        r = number("target_ratio", target_ratio)
        if not (0.0 < r <= 1.0):
            # 0 is refused as the CLI's --ratio refuses it: "keep no faces" is not a ratio
            # anyone means; target_faces=0 simplifies as far as the checks allow
            raise OptionError(f"target_ratio must be in (0, 1] (the fraction of the faces to keep; "
                              f"target_faces=0 simplifies as far as possible), got {target_ratio!r}")
        target = max(target, int(round(r * n_faces)))
    return target


#: simplify(prune=True): parts whose bounding-box diagonal is below this fraction of the mesh's go
PRUNE_SIZE = 0.01


def resolve_prune(prune) -> float | None:
    """The part size ``prune`` stands for (a fraction of the bbox diagonal), None when off."""
    if prune is None or prune is False:
        return None
    if prune is True:
        return PRUNE_SIZE
    if isinstance(prune, (int, float, np.integer, np.floating)) and 0.0 <= float(prune) < 1.0:
        return float(prune)
    raise OptionError(f"prune must be True, False or a fraction in [0, 1) of the bounding-box diagonal, got {prune!r}")


def locked_mask(locked, n: int) -> np.ndarray:
    """(n,) bool from ``locked``: an (n,) bool mask or an array of vertex indices."""
    arr = np.asarray(locked)
    if arr.dtype == bool:
        if arr.shape != (n,):
            raise OptionError(f"locked as a mask must have shape ({n},), got {arr.shape}")
        return arr
    if arr.size == 0:
        return np.zeros(n, dtype=bool)
    if arr.dtype.kind not in "iu" or arr.ndim != 1:
        raise OptionError("locked must be a boolean mask or a 1-D array of vertex indices")
    if arr.min() < 0 or arr.max() >= n:
        raise OptionError(f"locked holds a vertex index outside 0..{n - 1}")
    mask = np.zeros(n, dtype=bool)
    mask[arr] = True
    return mask

