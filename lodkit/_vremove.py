"""``simplify()`` with a vertex-removal metric: the Python side of the vertex-removal driver
(``lodkit._core.vremove``).  ``lodkit.api.simplify`` routes here when the metric's kind is
"removal"; docs/algorithms.md, "Vertex removal", describes the operator and its checks."""
from __future__ import annotations

import math
import time
from types import SimpleNamespace

import numpy as np

from .errors import MetricError

OPERATOR = "vertex_removal"


def simplify_removal(src, was_o3d, metrics, settings, *, target, max_error, absolute, locked,
                     progress, record, t0):
    """Run the vertex-removal driver; returns a :class:`lodkit.api.SimplifyResult`.

    ``n_collapses`` counts removals; ``stop_reason`` is "target_faces", "max_error" or
    "no_valid_collapse" (no valid removal left); ``result.collapses`` (record=True) is the
    removal record described in docs/algorithms.md."""
    from . import api
    from ._core.decimate import vertex_quadrics
    from ._core.vremove import VertexRemover
    from .removal import RemovalKernel

    if len(metrics) != 1:
        names = ", ".join(repr(m.name) for m in metrics)
        raise MetricError(f"a vertex-removal metric runs alone: it cannot be combined with other metrics "
                          f"(got {names})")
    metric = metrics[0]
    boundary = settings["boundary"][0]
    max_normal_angle, min_quality = settings["max_normal_angle"][0], settings["min_quality"][0]

    prep = api.prepare(src)
    hm = prep.hm
    fixed = hm.locked_vertices.copy()
    if locked is not None:
        fixed |= api._locked_mask(locked, src.n_vertices)[prep.input_vertex]
    if boundary == "lock":
        fixed |= hm.boundary_vertices
        seams = None
    else:
        seams = api._seam_partners(src, prep, fixed)
        if seams is not None:
            fixed |= seams != -1          # every seam copy stays: a removal on one side would open it
    attrs = src.attributes()
    names = [(name, arr.shape[1]) for name, arr in attrs.items()]
    attr_in = np.concatenate([arr[prep.input_vertex] for arr in attrs.values()], axis=1) if attrs else None
    vdata = np.empty((hm.n_vertices, 14), dtype=np.float64)
    vdata[:, 11:] = prep.positions
    prep.positions = None
    vertex_quadrics(hm, vdata[:, 11:], 0.0, out=vdata)
    ctx = api._metric_context(src, prep, vdata, fixed, placement=settings["placement"][0], boundary=boundary,
                              boundary_weight=float(settings["boundary_weight"][0]))
    metric.prepare(ctx)
    kernel = metric.make_kernel(ctx)
    if not isinstance(kernel, RemovalKernel):
        raise MetricError(f"metric {metric.name!r}: make_kernel returned {type(kernel).__name__}, "
                          f"not a lodkit.removal.RemovalKernel")
    err_limit = math.inf
    if max_error is not None:
        err_limit = float(max_error) / (prep.scale if absolute else 1.0)
    remover = VertexRemover(hm, vdata[:, 11:], kernel, fixed,
                            boundary=api.BOUNDARY_POLICIES[boundary],
                            max_normal_angle=float(max_normal_angle), min_quality=float(min_quality),
                            max_error=err_limit, record=bool(record),
                            closed_connected=api._closed_connected(hm))
    _raise_if_failed(remover, metric)

    bar = api._progress_bar(progress, hm, target)
    status = api._run_chunked(remover, hm, target, bar)
    if bar:
        bar.close()
    _raise_if_failed(remover, metric)

    held = remover.held_back
    if status == 0:
        stop, detail = api.STOP_TARGET, ""
    elif held["max_error"] > 0:
        stop, detail = api.STOP_MAX_ERROR, f"{held['max_error']} candidate removals exceed max_error"
    else:
        stop, detail = api.STOP_NO_COLLAPSE, _detail(remover, held)
        note = kernel.veto_note() if held.get("kernel") else ""   # e.g. volume: "... hyperbolic"
        detail += "; " + note if note else ""

    shim = SimpleNamespace(moved_vertices=np.zeros(hm.n_vertices, dtype=bool),
                           positions=vdata[:, 11:], attributes=attr_in)
    out_mesh, vertex_map, face_map = api._extract(src, prep, shim, names)
    scale = prep.scale if absolute else 1.0
    records = _records(remover, prep, src, scale) if record else None
    refused = remover.refusals
    return api.SimplifyResult(
        mesh=out_mesh.to_open3d() if was_o3d else out_mesh,
        vertex_map=vertex_map,
        face_map=face_map,
        error=float(remover.max_error_done * scale),
        stop_reason=stop,
        n_collapses=int(remover.n_collapses),
        elapsed=time.perf_counter() - t0,
        report={
            "operator": OPERATOR,
            "input_faces": src.n_faces,
            "degenerate_faces_removed": prep.n_degenerate_faces,
            "unreferenced_vertices_removed": prep.n_unreferenced_vertices,
            "nonmanifold_edges_cut": hm.n_nonmanifold_edges,
            "vertices_split": hm.n_split_vertices,
            "target_faces": target,
            "metrics": [metric.name],
            "vetoed": int(refused["kernel"]),
            "refused": refused,
            "held_back": held,
            "gated": bool(remover.gated),
            "passes": 0,
            "stop_detail": detail,
            "seams": {"paired_vertices": 0 if seams is None else int(np.count_nonzero(seams >= 0)),
                      "fixed_vertices": 0 if seams is None else int(np.count_nonzero(seams != -1)),
                      "pair_collapses": 0},
            "settings": {k: {"value": v, "from": s} for k, (v, s) in settings.items()},
        },
        collapses=records,
    )


def _raise_if_failed(remover, metric) -> None:
    if remover.failed:
        raise MetricError(f"metric {metric.name!r} failed during the run: {remover.error_message}")


def _detail(remover, held) -> str:
    if remover.n_collapses == 0 and held["kernel"] and not any(v for k, v in held.items() if k not in ("kernel", "fixed")):
        return f"the metric kernel vetoed every removal ({held['kernel']} vertices); the mesh is unchanged"
    parts = [f"{n} {k}" for k, n in held.items() if n and k != "fixed"]
    why = ", ".join(parts) if parts else "none"
    return (f"no vertex can be removed: vertices held back by reason: {why} "
            f"({held['fixed']} fixed)")


def _records(remover, prep, src, scale) -> dict:
    """The removal record in input vertex indices (docs/algorithms.md, "Vertex removal")."""
    rec = remover.records()
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
