"""``simplify()``: the simplification pipeline, step by step, and what it returns.

validate the options (lodkit.settings) -> prepare the mesh (lodkit._pipeline.start) -> the
metric context -> compile the metrics -> run the operator's driver (lodkit.drivers.DRIVERS)
-> extract the output mesh -> report.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import _pipeline
from ._pipeline import STOP_MAX_ERROR, STOP_NO_COLLAPSE, STOP_TARGET, Prepared, prepare
from .adapters import coerce
from .drivers import DRIVERS
from .errors import OptionError
from .io import load
from .metrics import create as create_metrics
from .polish import polish_positions, resolve_polish
from .settings import (
    BOUNDARY_POLICIES,
    OPERATORS,
    PLACEMENTS,
    SETTING_DEFAULTS,
    check_settings,
    resolve_driver,
    resolve_error,
    resolve_operator,
    resolve_prune,
    resolve_settings,
    resolve_target,
    resolve_threads,
)

__all__ = ["SimplifyResult", "ErrorBound", "simplify", "prepare", "Prepared", "STOP_TARGET", "STOP_MAX_ERROR",
           "STOP_NO_COLLAPSE", "SETTING_DEFAULTS", "PLACEMENTS", "BOUNDARY_POLICIES", "OPERATORS",
           "resolve_settings"]


@dataclass(frozen=True)
class ErrorBound:
    """The two-sided distance a ``simplify(error="hausdorff")`` result is guaranteed to stay
    within: every point of the output is at most this far from the input's surface and
    every point of the input's surface at most this far from the output's
    (docs/error-bound.md).  It is at most the ``max_error`` asked for, often less.

    absolute : in model units
    relative : as a fraction of the input's bounding-box diagonal
    """

    absolute: float
    relative: float


@dataclass
class SimplifyResult:
    """What :func:`simplify` returns.

    mesh        : the simplified mesh (a lodkit.Mesh, or an open3d TriangleMesh if one was given)
    vertex_map  : (n_out,) int64, for each output vertex the input vertex it comes from
    face_map    : (m_out,) int64, for each output face the input face it comes from
    error       : largest collapse error, as a fraction of the bbox diagonal (or in model
                  units when ``absolute=True``): sqrt(quadric error / summed face area), the
                  area-weighted RMS distance of the new vertex to the planes it stands for
    bound       : with ``error="hausdorff"``, the :class:`ErrorBound` the output is
                  guaranteed to be within of the input, both ways; None otherwise
    stop_reason : "target_faces", "max_error" or "no_valid_collapse"
    n_collapses : number of edge collapses done (vertex removals for a "removal" metric)
    """

    mesh: Any
    vertex_map: np.ndarray
    face_map: np.ndarray
    error: float
    stop_reason: str
    n_collapses: int
    elapsed: float = 0.0
    report: dict = field(default_factory=dict)
    collapses: dict | None = None
    bound: ErrorBound | None = None

    def __repr__(self) -> str:
        return (f"SimplifyResult({self.mesh!r}, error={self.error:.3g}, "
                f"stop_reason={self.stop_reason!r}, n_collapses={self.n_collapses})")


def simplify(
    mesh,
    *,
    target_faces: int | None = None,
    target_ratio: float | None = None,
    max_error: float | None = None,
    absolute: bool = False,
    metric="qem",
    placement: str | None = None,
    boundary: str | None = None,
    boundary_weight: float | None = None,
    locked=None,
    max_normal_angle: float | None = None,
    min_quality: float | None = None,
    progress=False,
    record: bool = False,
    pair_threshold: float | None = None,
    operator: str = "edge",
    driver: str | None = None,
    threads: int | None = None,
    prune: bool | float = False,
    error: str = "qem",
    sample_spacing: float | None = None,
    polish: bool | int = False,
) -> SimplifyResult:
    """Simplify a triangle mesh by greedy edge collapse with quadric error metrics (or by
    triangle collapse or vertex removal: ``operator``).

    Stops at whichever comes first: ``target_faces`` faces, ``target_ratio`` (in (0, 1]; 0 is
    refused, as by the CLI's ``--ratio``: use ``target_faces=0``) times the input face count,
    or a collapse error above ``max_error`` (a fraction of the bbox diagonal unless
    ``absolute=True``).  With no legal collapse left it stops and says so in
    ``stop_reason``.

    error            : what ``max_error`` limits: "qem" (default: the collapse error below)
                       or "hausdorff": a guaranteed two-sided bound -- a collapse is done only
                       if the mesh stays within ``max_error`` of the input's surface both ways
                       (every point of each within that distance of the other), and
                       ``result.bound`` says the distance the output is certified for
                       (docs/error-bound.md).  Edge collapse only (the pass and greedy
                       drivers, any edge-collapse metric); needs ``max_error``
    sample_spacing   : with ``error="hausdorff"``: how finely the input's triangles may be
                       split (at their edges' midpoints, where one face of the output does
                       not hold a whole triangle within ``max_error``): down to pieces whose
                       points are at most this fraction of ``max_error`` from a corner
                       (default 0.25); smaller refuses fewer collapses near the bound and
                       may take more pieces and time

    metric           : the cost: a registered name ("qem", see ``lodkit.metrics.available()``),
                       ``(name, {options})``, a Metric instance, or a list of those to combine
                       (quadrics add up, then fields and kernels apply in the order given,
                       then batch metrics; docs/writing-a-metric.md says exactly how)
    placement        : "optimal" (default; minimise the quadric; falls back to the edge when the 3x3
                       system is ill-conditioned) or "endpoint" (half-edge collapse: output
                       vertices are a subset of the input)
    boundary         : "preserve" (default; boundary planes weighted by ``boundary_weight``; a boundary
                       vertex never moves into the interior), "lock" (boundary vertices never
                       move nor go; attribute seams are no border) or "free" (no special
                       treatment)
    locked           : (n,) bool mask or index array of vertices that must stay as they are
    boundary_weight  : weight of the boundary planes under "preserve" (default 10)
    max_normal_angle : reject a collapse that turns any face normal by more than this
                       (degrees, default 90)
    min_quality      : reject a collapse that leaves the worst face of its fan with quality
                       Q = 4*sqrt(3)*A/(l0^2+l1^2+l2^2) below min(this, the fan's worst
                       before); 0 = off (default 0.1).  lodkit's default (not given here nor
                       by the metric) is relaxed to 0.01, then 0, when no collapse is left
                       above the target in a run without ``max_error``
                       (``report["min_quality_relaxed_to"]``); then a collapse may
                       join the two flat sides of a thin sheet (a knife edge, refused
                       until then: ``report["knives_allowed"]``, docs/algorithms.md)

    The five settings above that are left as None take the value the metric prefers (a
    metric's ``defaults``, e.g. ``curvature`` checks normals within 60 degrees and quality
    0.5, as its paper does; the first metric listed wins), else the default given here.
    ``result.report["settings"]`` says what was used and where it came from.
    progress         : True: draw a progress bar on stderr; or a callable ``(done, total)``
                       called every few thousand operations (faces removed so far, to remove
                       in all) whose ``False`` cancels the run with :class:`lodkit.Cancelled`
                       (the input untouched).  Ctrl-C raises KeyboardInterrupt within a
                       fraction of a second in every driver (docs/reliability.md, "Interrupts")
    record           : keep the collapse sequence in ``result.collapses``
    pair_threshold   : pair contraction (off when None): before the collapses, vertices closer
                       than this (a fraction of the bbox diagonal unless ``absolute=True``)
                       that share no edge merge in quadric-cost order, so separate parts join
                       and gaps close (topology changes; docs/clustering.md, "Pair
                       contraction"); ``report["pair_contraction"]`` counts the merges
    operator         : "edge" (default: edge collapse), "triangle" (triangle collapse: the
                       cheapest face goes to one point, the face and its three neighbours
                       die; done and recorded as two edge collapses, ``n_collapses`` counts
                       those; quadric metrics only -- docs/algorithms.md, "Triangle collapse")
                       or "vertex_removal" (a vertex goes and its hole is re-triangulated;
                       needs a "removal" metric such as "schroeder" or "volume", which runs
                       alone; docs/algorithms.md, "Vertex removal").  A removal metric implies
                       "vertex_removal": ``metric="schroeder"`` alone removes vertices
    driver           : how edge collapse picks its collapses: "pass" (default: error-limited
                       passes over the cheapest candidates, walking blocks of the surface in
                       memory order on ``threads`` threads; docs/algorithms.md, "The pass
                       driver") or "greedy" (always the cheapest collapse next, from an
                       indexed heap: the reference order of the papers).
                       Triangle collapse and batch metrics run their own loops and ignore it
    threads          : threads of the pass driver (default: ``$LODKIT_THREADS``, else
                       ``$OMP_NUM_THREADS``, else the cores this process may use).  The output
                       is the same for any number of threads

    prune            : drop debris before simplifying (off by default): zero-area faces (twice
                       the area at most 1e-12 times the summed squared edge lengths) and
                       small parts -- connected components (faces sharing a position) whose
                       bounding-box diagonal is below 1% of the mesh's (``prune=True``) or
                       below the given fraction (``prune=0.05``); the largest part always
                       stays.  ``report["pruned"]`` counts what went (docs/getting-started.md)

    polish           : after the run, fit the output's vertex positions to the input surface
                       (off by default; True: 3 rounds, or a number of rounds): each round
                       matches area-weighted samples of the input to their closest output
                       faces and moves the free vertices to lower the mean distance (an
                       iteratively reweighted point-to-plane least squares, each vertex held
                       within the RMS distance of its samples, no face turned by more than
                       ~45 degrees); locked, fixed, boundary and seam vertices stay.  Lowers
                       the mean error by 11-37 % on scans (docs/algorithms.md, "Polish"), for
                       2-5 times the run's time.
                       ``report["polish"]`` says what it did.  Not with ``error="hausdorff"``
                       (it would void the certificate)

    An open3d.geometry.TriangleMesh in gives one out.  Per-vertex normals, colours and uvs
    are carried along (interpolated on the collapsed edge at the new position).  Attribute
    seams (coincident vertex copies, as OBJ / glTF uv seams load) stay closed under the
    "preserve" and "free" boundary policies: seam vertices do not move, and a collapse along
    a seam is done on both sides together (docs/metrics.md, "Attribute seams").
    """
    t0 = time.perf_counter()
    src, back = coerce(mesh, load=load)
    metrics = create_metrics(metric)
    operator = resolve_operator(operator, metrics)
    settings = resolve_settings(metrics, placement=placement, boundary=boundary,
                                boundary_weight=boundary_weight,
                                max_normal_angle=max_normal_angle, min_quality=min_quality)
    settings["driver"] = resolve_driver(driver)
    settings["threads"] = resolve_threads(threads)
    check_settings(settings, max_error)
    settings.update(resolve_error(error, sample_spacing, max_error, operator, pair_threshold))
    prune_size = resolve_prune(prune)
    polish_rounds = resolve_polish(polish)
    if polish_rounds and error == "hausdorff":
        raise OptionError("polish cannot be used with error='hausdorff': moving vertices after the run "
                          "would void the certified bound")
    target = resolve_target(src.n_faces, target_faces, target_ratio, max_error)
    runner = DRIVERS[operator]
    runner.check(metrics, pair_threshold)
    for m in metrics:
        m.check_ready()          # options a metric cannot run without, before any work

    # the pass driver (the memory order's only user) takes the input normals the quadrics' face
    # pass makes
    order = runner.memory_order(metrics, settings)
    work = _pipeline.start(src, settings, locked=locked, pair_threshold=pair_threshold,
                           absolute=absolute, fix_seams=runner.FIX_SEAMS,
                           memory_order=order, prune=prune_size, input_normals=order)
    fit = None
    if polish_rounds:
        held = work.fixed.copy()     # the driver takes work.fixed over

        def fit(V0, F0, V, F, slots):
            return polish_positions(V0, F0, V, F, held[slots], rounds=polish_rounds)
    ctx = _pipeline.metric_context(work, settings)
    compiled = runner.setup(metrics, ctx, work)
    del ctx         # what the metrics keep of it they hold themselves; the rest may be freed
    run = runner.run(work, compiled, settings, target=target, record=record, progress=progress,
                     max_error=_pipeline.error_limit(max_error, work, absolute))
    out_mesh, vertex_map, face_map, polished = _pipeline.extract(work, run, polish=fit)

    scale = work.prep.scale if absolute else 1.0
    report = _pipeline.report(work, run, metrics, settings, target)
    report["polish"] = polished
    bound = None if run.bound is None else ErrorBound(absolute=float(run.bound * work.prep.scale),
                                                      relative=float(run.bound))
    return SimplifyResult(
        mesh=back(out_mesh),
        vertex_map=vertex_map,
        face_map=face_map,
        error=float(run.max_error * scale),
        stop_reason=run.stop,
        n_collapses=run.n_collapses,
        elapsed=time.perf_counter() - t0,
        report=report,
        collapses=runner.records(work, run, scale) if record else None,
        bound=bound,
    )
