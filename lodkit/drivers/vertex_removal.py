"""Vertex removal (``operator="vertex_removal"``, implied by a "removal" metric): the core's
VertexRemover removes a vertex and re-triangulates its hole with the metric's kernel;
docs/algorithms.md, "Vertex removal", describes the operator, its checks and its record."""
from __future__ import annotations

import numpy as np

from .._compile import removal_kernel
from .._core import vremove
from .._pipeline import (
    RUN_TARGET,
    STOP_MAX_ERROR,
    STOP_NO_COLLAPSE,
    STOP_TARGET,
    Run,
    Work,
    closed_connected,
    progress_bar,
    run_chunked,
    weld_cycles,
)
from ..errors import MetricError, OptionError
from ..settings import BOUNDARY_POLICIES

__all__ = ["FIX_SEAMS", "OPERATOR", "check", "setup", "run", "records"]

OPERATOR = "vertex_removal"

#: a seam copy goes together with its partner on the other side of the seam
#: (VertexRemover.remove_pair): only the copies that cannot be paired stay
FIX_SEAMS = False


def check(metrics, pair_threshold) -> None:
    """Vertex removal takes no pair contraction, and its metric runs alone."""
    if pair_threshold is not None:
        raise OptionError("pair_threshold works with edge collapse; a vertex-removal metric takes none")
    if len(metrics) != 1:
        names = ", ".join(repr(m.name) for m in metrics)
        raise MetricError(f"a vertex-removal metric runs alone: it cannot be combined with other metrics "
                          f"(got {names})")


def memory_order(metrics, settings) -> bool:
    """The removal driver keeps its greedy heap order on the slots as loaded."""
    return False


def setup(metrics, ctx, work: Work):
    """(the metric, its prepared RemovalKernel)."""
    return metrics[0], removal_kernel(metrics[0], ctx)


def run(work: Work, compiled, settings: dict, *, target: int, max_error: float, record: bool,
        progress: bool) -> Run:
    """Remove vertices down to ``target`` faces; ``n_collapses`` counts removals."""
    metric, kernel = compiled
    hm = work.prep.hm
    # the remover reads positions only (contiguous: it would copy the strided view anyway);
    # the quadric rows of work.vdata are not needed any more: dropped, ~90 bytes a vertex
    positions = np.ascontiguousarray(work.positions)
    work.vdata = None
    remover = vremove.VertexRemover(hm, positions, kernel, work.fixed,
                                    boundary=BOUNDARY_POLICIES[settings["boundary"][0]],
                                    max_normal_angle=float(settings["max_normal_angle"][0]),
                                    min_quality=float(settings["min_quality"][0]),
                                    max_error=max_error, record=bool(record),
                                    closed_connected=closed_connected(hm), weld=weld_groups(work),
                                    seams=work.seams)
    _raise_if_failed(remover, metric)

    bar = progress_bar(progress, hm, target)
    status = run_chunked(remover, hm, target, bar)
    if bar:
        bar.close()
    _raise_if_failed(remover, metric)

    held = remover.held_back
    if status == RUN_TARGET:
        stop, detail = STOP_TARGET, ""
    elif held["max_error"] > 0:
        stop, detail = STOP_MAX_ERROR, f"{held['max_error']} candidate removals exceed max_error"
    else:
        stop, detail = STOP_NO_COLLAPSE, _detail(remover, held)
        note = kernel.veto_note() if held.get("kernel") else ""   # e.g. volume: "... hyperbolic"
        detail += "; " + note if note else ""
    refused = remover.refusals
    return Run(
        core=remover,
        positions=positions,
        moved=None,                     # removal keeps the other vertices where they are
        attributes=work.attributes,
        max_error=remover.max_error_done,
        n_collapses=int(remover.n_collapses),
        stop=stop,
        detail=detail,
        seam_pair_collapses=int(remover.n_seam_pairs),
        counters={
            "vetoed": int(refused["kernel"]),
            "refused": refused,
            "held_back": held,
            "gated": bool(remover.gated),
            "passes": 0,
            "operator": OPERATOR,
        },
    )


def weld_groups(work: Work):
    """(rep, next) over the vertex slots grouped by input position, for a mesh with
    attribute seams (None without): the remover's manifold rules then hold for the surface
    welded along its seams.  Without them both sides of a seam could each fill the same
    corner with a triangle on the same three positions -- once welded, a duplicate face on
    a non-manifold edge (docs/reliability.md, "The volume seam bug")."""
    if work.seams is None:
        return None
    pos = work.src.vertices[work.prep.input_vertex] + 0.0        # -0.0 and 0.0 are one position
    _, inverse = np.unique(pos, axis=0, return_inverse=True)
    return weld_cycles(inverse.reshape(-1))


def _raise_if_failed(remover, metric) -> None:
    if remover.failed:
        raise MetricError(f"metric {metric.name!r} failed during the run: {remover.error_message}")


def _detail(remover, held) -> str:
    others = any(v for k, v in held.items() if k not in ("kernel", "fixed"))
    if remover.n_collapses == 0 and held["kernel"] and not others:
        return f"the metric kernel vetoed every removal ({held['kernel']} vertices); the mesh is unchanged"
    parts = [f"{n} {k}" for k, n in held.items() if n and k != "fixed"]
    why = ", ".join(parts) if parts else "none"
    return (f"no vertex can be removed: vertices held back by reason: {why} "
            f"({held['fixed']} fixed)")


def records(work: Work, run: Run, scale: float) -> dict:
    """The removal record in input vertex indices (docs/algorithms.md, "Vertex removal")."""
    prep, src = work.prep, work.src
    rec = run.core.records()
    iv = prep.input_vertex.astype(np.int64)
    off = rec["offsets"].astype(np.int64)
    r = rec["removed"].shape[0]
    k = np.diff(off)
    closed = rec["closed"]
    link = iv[rec["link"]]
    removed = iv[rec["removed"]]
    # old faces (v, link[j], link[j+1]): k of them for a closed star, k - 1 for an open one
    nf = np.where(closed, k, k - 1)
    rid = np.repeat(np.arange(r), nf)
    j = np.arange(int(nf.sum())) - np.repeat(np.cumsum(nf) - nf, nf)
    a = off[rid] + j
    b = off[rid] + (j + 1) % k[rid]
    old_faces = np.stack([removed[rid], link[a], link[b]], axis=1) if r else np.zeros((0, 3), np.int64)
    nt = k - 2
    tid = np.repeat(np.arange(r), nt)
    new_faces = link[off[tid][:, None] + rec["triangles"]] if r else np.zeros((0, 3), np.int64)
    return {
        "operator": OPERATOR,
        "removed": removed,
        "position": src.vertices[removed].copy(),
        "closed": closed,
        "link": link,
        "link_offsets": off,
        "old_faces": old_faces.astype(np.int64),
        "old_face_offsets": np.r_[0, np.cumsum(nf)].astype(np.int64),
        "new_faces": new_faces.astype(np.int64).reshape(-1, 3),
        "new_face_offsets": np.r_[0, np.cumsum(nt)].astype(np.int64),
        "cost": rec["cost"],
        "error": rec["error"] * scale,
    }
