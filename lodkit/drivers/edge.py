"""Edge collapse (``operator="edge"``): the core's EdgeCollapser, run by the core's pass
driver (``driver="pass"``, the default: lodkit/_core/passes.pyx), greedily from its heap
(``driver="greedy"``), or, with batch metrics, by the Python pass driver
(:func:`run_passes`).  Triangle collapse (lodkit.drivers.triangle) runs through
:func:`run_collapser` too."""
from __future__ import annotations

import math

import numpy as np

from .._compile import Compiled, batch_result, compile_metrics
from .._core.bound import MAX_PIECES
from .._core.decimate import EdgeCollapser
from .._core.passes import PassDriver
from .._pipeline import (
    RUN_EXHAUSTED,
    RUN_TARGET,
    STOP_MAX_ERROR,
    STOP_NO_COLLAPSE,
    STOP_TARGET,
    Run,
    Work,
    closed_connected,
    progress_bar,
    run_chunked,
)
from ..errors import MetricError, OptionError
from ..metrics import Batch
from ..settings import BOUNDARY_POLICIES, COLLAPSE_OPERATORS, PLACEMENTS

__all__ = ["FIX_SEAMS", "PASS_BLOCK", "PASS_MIN_PARALLEL", "PASS_FRACTION", "check", "memory_order", "setup", "run",
           "run_collapser", "run_passes", "records"]

#: seam copies that can be paired collapse together with their partner: only the others stay
FIX_SEAMS = False
#: the pass driver's limit: the cheapest 1/PASS_FRACTION of the valid candidates go per pass
PASS_FRACTION = 6.0
#: live vertices per block of the pass driver's first stage (docs/algorithms.md)
PASS_BLOCK = 8192
#: below this many live vertices the pass driver runs on one thread (the same output): its
#: passes are too short to pay for waking the thread team several times a pass
PASS_MIN_PARALLEL = 16384


def check(metrics, pair_threshold) -> None:
    """Edge collapse runs every metric kind but removal (which implies vertex removal)."""


def _core_passes(metrics, settings, operator: str = "edge") -> bool:
    """Does the core's pass driver run? Edge collapse under ``driver="pass"``, unless a batch
    metric is there (batch metrics have their own pass loop, :func:`run_passes`)."""
    return (operator == "edge" and settings["driver"][0] == "pass"
            and not any(m.kind == "batch" for m in metrics))


def memory_order(metrics, settings) -> bool:
    """The pass driver walks the slots in order: it wants them along a Morton curve."""
    return _core_passes(metrics, settings)


def setup(metrics, ctx, work: Work) -> Compiled:
    return compile_metrics(metrics, ctx, work)


def run(work: Work, compiled: Compiled, settings: dict, *, target: int, max_error: float, record: bool,
        progress: bool) -> Run:
    return run_collapser(work, compiled, settings, target=target, max_error=max_error, record=record,
                         progress=progress, operator="edge")


def run_collapser(work: Work, compiled: Compiled, settings: dict, *, target: int, max_error: float,
                  record: bool, progress: bool, operator: str) -> Run:
    """Build the EdgeCollapser over ``work`` and run it to ``target`` faces (or until no
    collapse within ``max_error`` is left)."""
    hm = work.prep.hm
    passes = work.prep.memory_order and operator == "edge" and not compiled.batch
    # error="hausdorff": max_error is the distance the core's error bound keeps to
    # (lodkit/_core/bound.pyx), not a limit on the collapse error
    error_bound = None
    if settings.get("error", ("qem",))[0] == "hausdorff":
        error_bound = (max_error, float(settings["sample_spacing"][0]))
        max_error = math.inf
    try:
        collapser = EdgeCollapser(
            hm, None, work.vdata, work.attributes, work.fixed,
            placement=PLACEMENTS[settings["placement"][0]], boundary=BOUNDARY_POLICIES[settings["boundary"][0]],
            max_normal_angle=float(settings["max_normal_angle"][0]), min_quality=float(settings["min_quality"][0]),
            max_error=max_error, record=bool(record),
            closed_connected=closed_connected(hm),
            use_heap=not compiled.batch and not passes, seam_partners=work.seams, operator=COLLAPSE_OPERATORS[operator],
            error_bound=error_bound, threads=int(settings["threads"][0]), input_normals=work.normals,
            **compiled.core,
        )
    except ValueError as exc:
        if error_bound is not None and str(exc).startswith("the error bound"):
            raise OptionError(str(exc)) from None
        raise
    work.fixed = work.normals = None           # the collapser's vertex flags (and input normals) hold them now
    raise_if_failed(collapser, compiled)
    if work.seams is not None:
        work.n_seam_fixed = collapser.n_seam_fixed      # seam ends stay too (EdgeCollapser)

    relaxable = max_error == math.inf and error_bound is None and not compiled.batch
    if not relaxable and collapser.knife_test:
        # the knife test is a first step that simplify relaxes when stuck (below); a run
        # that cannot take that step (a max_error, an error bound, a batch metric) goes without it
        collapser.allow_knives()
    bar = progress_bar(progress, hm, target)
    n_passes = 0
    relaxed = None
    knives = False
    fallback = False
    if compiled.batch:
        status, rejected_error, n_passes = run_passes(collapser, compiled, work, target, bar)
    else:
        driver = (PassDriver(collapser, threads=int(settings["threads"][0]), fraction=PASS_FRACTION, block=PASS_BLOCK,
                              min_parallel=PASS_MIN_PARALLEL)
                  if passes else collapser)
        status = run_chunked(driver, hm, target, bar)
        for step in quality_steps(settings) if max_error == math.inf and error_bound is None else ():
            if status != RUN_EXHAUSTED:
                break
            # the checks left no collapse: relax the quality limit a step and go on
            collapser.relax_quality(step)
            relaxed = step
            status = run_chunked(driver, hm, target, bar)
        if status == RUN_EXHAUSTED and relaxable and collapser.knife_test:
            # still stuck: let a collapse join the two sides of a thin sheet (a knife edge;
            # EdgeCollapser.knife), which the quality relaxation alone did not free
            collapser.allow_knives()
            knives = True
            status = run_chunked(driver, hm, target, bar)
        if status == RUN_EXHAUSTED and operator == "edge" and max_error == math.inf:
            # still stuck: let the refused candidates collapse at an end or the midpoint of
            # their edge (EdgeCollapser.place_ok: every check still holds; only the placement
            # changes).  Edge collapse only: triangle collapse plans faces, not edges.  Under
            # an error bound too: an end or the midpoint may stay within the bound where the
            # optimal placement does not (cow at 2 % of the diagonal: 182 -> 160 faces)
            collapser.allow_end_fallback()
            fallback = True
            status = run_chunked(driver, hm, target, bar)
        rejected_error = collapser.n_rejected_error
        n_passes = driver.n_passes if passes else 0
        del driver          # the pass driver's arrays go before release() copies the positions
    if bar:
        bar.close()
    raise_if_failed(collapser, compiled)
    if error_bound is not None and collapser.bound.overflowed:
        # a piece of the input that had to split found no slot: its face's certificate may
        # exceed max_error, so the run cannot stand (the same for any thread count: the
        # pieces a run needs do not depend on the threads)
        raise OptionError(f"the error bound needed more than {MAX_PIECES} pieces of the input: max_error is "
                          f"small next to the input's triangles; raise max_error or sample_spacing")

    bound_refused = collapser.count_bound_refusals() if error_bound is not None and status != RUN_TARGET else 0
    if status == RUN_TARGET:
        stop, detail = STOP_TARGET, ""
    elif rejected_error > 0:
        stop, detail = STOP_MAX_ERROR, f"{rejected_error} candidate collapses exceed max_error"
    elif bound_refused > 0:
        stop, detail = STOP_MAX_ERROR, (f"{bound_refused} candidate collapses would take the surface farther "
                                        f"than max_error from the input (error='hausdorff')")
    else:
        stop, detail = STOP_NO_COLLAPSE, _no_collapse_detail(collapser)
    if relaxed is not None and detail:
        detail += f" (min_quality relaxed to {relaxed:g})"
    if knives and detail:
        detail += " (knife collapses allowed)"
    if fallback and detail:
        detail += " (end-of-edge placement allowed)"
    census = None
    if stop == STOP_NO_COLLAPSE and operator == "edge" and not compiled.batch and not collapser.failed:
        census = collapser.refusal_census()
        detail += "; " + census_detail(census)
    bound = collapser.certified_bound()
    counters = {}
    if error_bound is not None:
        counters["error_bound"] = {"max_error": error_bound[0], "certified": bound,
                                   "pieces": int(collapser.bound.n_pieces),
                                   "sample_spacing": error_bound[1]}
    collapser.release()          # the heap and quadrics are not needed to build the output
    return Run(
        core=collapser,
        positions=collapser.positions,
        moved=collapser.moved_vertices,
        attributes=collapser.attributes if work.names else None,
        max_error=collapser.max_error_done,
        n_collapses=int(collapser.n_collapses),
        stop=stop,
        detail=detail,
        seam_pair_collapses=int(collapser.n_seam_pairs),
        counters={
            "pair_contraction": work.pair_report,
            "vetoed": int(collapser.n_vetoed),
            "passes": n_passes,
            "operator": operator + "_collapse",
            "triangle_collapses": int(collapser.n_tri_collapses),
            "refused_at_second_collapse": int(collapser.n_tri_refused_second),
            "min_quality_relaxed_to": relaxed,
            "knives_allowed": knives,
            "end_fallback": fallback,
            "refusals": census,
            **counters,
        },
        bound=bound,
    )


#: when the checks leave no collapse above the target, lodkit's default ``min_quality`` (not
#: the caller's, nor a metric's preferred value) is relaxed in these steps, as fractions of it (docs/algorithms.md,
#: "Relative quality"); a caller's value is a hard limit
QUALITY_STEPS = (0.1, 0.0)


def quality_steps(settings: dict) -> list:
    """The lower quality limits to try in turn once a run is exhausted (none when the
    caller or the metric set ``min_quality``, or it is 0; a run with a ``max_error`` is
    not relaxed: a run to N faces stays the start of a run to fewer, as progressive meshes
    need, with or without one)."""
    value, source = settings["min_quality"]
    if source != "lodkit" or not float(value) > 0.0:
        return []            # the caller's value, or a metric's own (a paper's setting)
    return [float(value) * f for f in QUALITY_STEPS]


def raise_if_failed(collapser, compiled: Compiled) -> None:
    """MetricError naming the kernel that failed during the run, if one did."""
    if not collapser.failed:
        return
    for m, k in compiled.kernels:
        if k.failed:
            raise MetricError(f"metric {m.name!r} failed during the run: {k.message}")
    raise MetricError(f"a metric kernel failed during the run: {collapser.error_message}")


#: the stop census's names (EdgeCollapser.refusal_census) as the stop detail words them
CENSUS_WORDS = {"fixed": "locked or boundary rules", "topology": "link condition (topology)",
                "quality": "quality", "input_face": "turn from the input face", "fold": "fold",
                "turn": "normal turn", "volume": "enclosed volume",
                "knife": "knife edge (two sides of a thin sheet)", "several": "more than one check",
                "free": "no check"}


def census_detail(census: dict) -> str:
    """The stop census as words: what refuses the last candidate edges, most first."""
    parts = [f"{n} {CENSUS_WORDS[k]}" for k, n in sorted(census.items(), key=lambda kv: -kv[1]) if n]
    out = "last candidates refused by: " + (", ".join(parts) if parts else "none left")
    topo, total = census.get("topology", 0), sum(census.values())
    if total and topo == total:
        out += " (a topological minimum of edge collapse: no edge left passes the link condition)"
    elif topo:
        out += (f" (not the topological minimum: {total - topo} of {total} edges pass the link condition, "
                "refused by the other rules)")
    return out


def _no_collapse_detail(collapser) -> str:
    if collapser.n_vetoed and collapser.n_collapses == 0:
        return (f"every candidate collapse was vetoed by a metric kernel "
                f"({collapser.n_vetoed} vetoes); the mesh is unchanged")
    if collapser.n_vetoed:
        return (f"the remaining candidates failed the checks or were vetoed by a metric kernel "
                f"({collapser.n_vetoed} vetoes)")
    return "every remaining collapse would break the topology, flip or degrade a face, or move a locked vertex"


def run_passes(collapser, compiled: Compiled, work: Work, target: int, bar):
    """The pass driver for batch metrics: rank every candidate (the core's cost, then each
    batch metric in order), collapse the cheapest ``fraction`` that share no vertex
    neighbourhood, repeat.  Returns (status, candidates over max_error, passes)."""
    hm = work.prep.hm
    ctx = compiled.ctx
    start_faces = hm.n_alive_faces
    fraction = min(m.params["fraction"] for m in compiled.batch)
    passes = 0
    while hm.n_alive_faces > target:
        plan = collapser.plan_all()
        if plan is None:
            raise_if_failed(collapser, compiled)
        rejected = collapser.n_rejected_error
        k = plan["edge"].shape[0]
        if k == 0:
            return RUN_EXHAUSTED, rejected, passes
        cost, pos = plan["cost"], None
        live = collapser.positions
        for m in compiled.batch:
            batch = Batch(edge=plan["edge"], u=plan["u"], v=plan["v"], removed=plan["removed"],
                          kept=plan["kept"], position=plan["position"] if pos is None else pos,
                          cost=cost, error=plan["error"], positions=live, ctx=ctx)
            cost, new_pos = batch_result(m, m.costs(batch), k)
            if new_pos is not None:
                pos = new_pos
        order = np.argsort(cost, kind="stable")
        n_try = max(int(math.ceil(fraction * k)), 1)
        done = 0
        for take in ((order[:n_try], order) if n_try < k else (order,)):
            done = collapser.collapse_pass(plan["edge"][take], None if pos is None else pos[take], target)
            if done != 0:
                break
        if done < 0:
            raise_if_failed(collapser, compiled)
        passes += 1
        if bar:
            bar.update(start_faces - hm.n_alive_faces)
        if done == 0:
            return RUN_EXHAUSTED, rejected, passes
    return RUN_TARGET, 0, passes


def records(work: Work, run: Run, scale: float) -> dict:
    """The collapse record in input vertex indices (docs/progressive.md)."""
    prep, src = work.prep, work.src
    out = run.core.records()
    out["removed"] = prep.input_vertex[out["removed"]].astype(np.int64)
    out["kept"] = prep.input_vertex[out["kept"]].astype(np.int64)
    moved = out.pop("moved")
    # positions that are an input vertex's are given bit for bit, the others denormalised
    out["position"] = np.where(moved[:, None], out["position"] * prep.scale + prep.center,
                               src.vertices[out["kept"]])
    out["error"] = out["error"] * scale
    if run.bound is not None:
        # the distance certified after each step (a running maximum: each collapse certifies
        # the faces it made; the others keep theirs), in the unit of the errors
        out["bound"] = np.maximum.accumulate(out["bound"]) * scale if out["bound"].size else out["bound"]
    else:
        out.pop("bound")
    return out
