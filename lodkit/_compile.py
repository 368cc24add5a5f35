"""Metric specs -> what the core runs.  A metric's Python code runs here, once, at set-up:

    compile_metrics(metrics, ctx, work) -> Compiled   for the collapse drivers: one folded
        quadric (in the vertex rows, or over attributes), field blocks with their rules,
        a chain of prepared kernels, and the batch metrics for the pass driver
    removal_kernel(metric, ctx)           the prepared kernel of a vertex-removal metric
    batch_result(metric, result, k)       a batch metric's (costs, positions), checked

Every array a metric returns is checked (shape, numbers, NaN) and a bad one raises
MetricError naming the metric.  docs/writing-a-metric.md says how metrics combine.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._core.decimate import add_boundary_planes
from ._pipeline import PLANE_SIZE, Work
from .errors import MetricError
from .metrics import ATTRIBUTE_WIDTHS, MetricContext, packed_size
from .removal import RemovalKernel

__all__ = ["Compiled", "compile_metrics", "removal_kernel", "batch_result", "checked"]

# rows of the core's ``steps``: (kind, first, end) over the vertex-field columns, the
# edge-field columns and the kernel chain (fields.pxd STEP_VFIELD / STEP_EFIELD / STEP_KERNEL)
STEP_VERTEX_FIELD = 0
STEP_EDGE_FIELD = 1
STEP_KERNEL = 2


@dataclass
class Compiled:
    """The metrics, compiled for the collapse drivers."""

    core: dict                    # EdgeCollapser keyword arguments
    kernels: list                 # (metric, kernel) pairs, in chain order
    batch: list                   # batch metrics, in order
    ctx: MetricContext            # the context they were prepared with (batches see it)


def compile_metrics(metrics, ctx: MetricContext, work: Work) -> Compiled:
    """Turn the metrics into what the core runs: one folded quadric, field blocks with their
    rules, a chain of prepared kernels, and the batch metrics for the pass driver.  The
    folded 3D quadric is written into ``work.vdata`` in place."""
    vdata, attr_layout = work.vdata, work.layout
    n = ctx.n_vertices
    for m in metrics:
        m.prepare(ctx)
    # everything that reads ctx.face_quadrics runs before vdata is overwritten below
    quads = [m for m in metrics if m.kind == "quadric"]
    for m in quads:
        missing = [a for a in m.attributes if a not in attr_layout]
        if missing:
            raise MetricError(f"metric {m.name!r} needs per-vertex {missing[0]}, and the mesh has none")
    total_w = sum(m.weight for m in quads)
    blocks = []
    if quads and total_w > 0.0:
        blocks = [(m, checked(m, m.quadrics(ctx), (n, packed_size(m.dimension())), "quadrics",
                              columns=packed_size(m.dimension()))) for m in quads]
    attr_names = []
    for m in quads:
        attr_names += [a for a in m.attributes if a not in attr_names]
    core = {}
    # fields and kernels apply in the order the metrics are listed: steps (kind, first, end)
    # over the columns of the vertex / edge field blocks and the kernel chain
    values = {"vertex": [], "edge": []}
    rules = {"vertex": [], "edge": []}
    width = {"vertex": 0, "edge": 0}
    kernels, steps = [], []
    for m in metrics:
        if m.kind == "field":
            rows = n if m.per == "vertex" else ctx.n_edges
            v = checked(m, m.values(ctx), (rows,), f"{m.per} field values").reshape(rows, -1)
            values[m.per].append(v)
            rules[m.per].append(m.rules(v.shape[1]))
            kind = STEP_VERTEX_FIELD if m.per == "vertex" else STEP_EDGE_FIELD
            step = (kind, width[m.per], width[m.per] + v.shape[1])
            width[m.per] += v.shape[1]
        elif m.kind == "kernel":
            k = m.make_kernel(ctx)
            if not isinstance(k, m.kernel):
                raise MetricError(f"metric {m.name!r}: make_kernel returned {type(k).__name__}, "
                                  f"not {m.kernel.__name__}")
            step = (STEP_KERNEL, len(kernels), len(kernels) + 1)
            kernels.append((m, k))
        else:
            continue
        if steps and steps[-1][0] == step[0] and steps[-1][2] == step[1]:
            steps[-1] = (step[0], steps[-1][1], step[2])          # one run of the same kind
        else:
            steps.append(step)
    for per in ("vertex", "edge"):
        if values[per]:
            core[f"{per}_fields"] = np.ascontiguousarray(np.concatenate(values[per], axis=1))
            core[f"{per}_rules"] = np.concatenate(rules[per], axis=0)
    core["kernels"] = [k for _, k in kernels]
    core["steps"] = steps
    bw = ctx.settings.get("boundary_weight", 0.0)
    if ctx.settings.get("boundary") != "preserve":
        bw = 0.0
    # weight of the boundary planes added to vdata's 3D quadrics below: they scale with the
    # quadric weights, so "preserve" means the same whatever the weights
    plane_weight = bw * total_w
    if blocks and attr_names:
        # quadrics over attributes: fold them in D = 3 + k dimensions (boundary planes
        # included); the 3D rows of vdata keep the plain quadric and measure the geometric error
        core["attribute_quadrics"], core["attribute_columns"] = _fold_attribute_quadrics(
            blocks, attr_names, attr_layout, ctx, plane_weight)
        core["quadric_weight"], core["error_scale"] = 1.0, 1.0
        plane_weight = bw
    elif blocks:
        # the folded quadric: sum of weight * Q over the quadric metrics
        if len(blocks) == 1 and _is_face_quadrics(blocks[0][1], ctx):
            if total_w != 1.0:
                vdata[:, :PLANE_SIZE] *= total_w          # plain QEM, weighted: scale in place
        else:
            acc = np.zeros((n, PLANE_SIZE))
            for m, q in blocks:
                acc += m.weight * q[:, :PLANE_SIZE]
            vdata[:, :PLANE_SIZE] = acc
        del blocks
        core["quadric_weight"], core["error_scale"] = 1.0, 1.0 / total_w
    else:
        # no quadric metric: plain QEM places the vertex and measures the error; it is also
        # the cost when nothing else supplies one (fields alone modulate plain QEM)
        only_fields = all(m.kind == "field" for m in metrics)
        core["quadric_weight"], core["error_scale"] = (1.0 if only_fields else 0.0), 1.0
        plane_weight = bw
    if plane_weight > 0.0:
        add_boundary_planes(ctx.halfedge, ctx.positions, plane_weight, vdata)
    return Compiled(core, kernels, [m for m in metrics if m.kind == "batch"], ctx)


def _is_face_quadrics(block: np.ndarray, ctx: MetricContext) -> bool:
    """True when a metric handed back ``ctx.face_quadrics`` itself (plain QEM does): the
    vertex rows already hold exactly those quadrics, so there is nothing to sum (a sum
    would also turn -0.0 entries into 0.0)."""
    return block is ctx.face_quadrics


def _fold_attribute_quadrics(blocks, attr_names, attr_layout, ctx, boundary_weight):
    """Sum weight * Q over the quadric metrics in the space [x, y, z, attributes...] of the
    union of their attributes.  Returns the packed (n, S) fold and, for each dimension past
    3, its column in the collapser's attribute array."""
    widths = ATTRIBUTE_WIDTHS
    columns, dim_of = [], {}
    for name in attr_names:
        dim_of[name] = 3 + len(columns)
        start = attr_layout[name]
        columns += list(range(start, start + widths[name]))
    D = 3 + len(columns)
    tri = D * (D + 1) // 2

    def index(i, j):
        i, j = min(i, j), max(i, j)
        return i * D - i * (i - 1) // 2 + (j - i)

    n = ctx.n_vertices
    fold = np.zeros((n, packed_size(D)))

    def add(packed, dims, weight):
        d = len(dims)
        k = 0
        for i in range(d):
            for j in range(i, d):
                fold[:, index(dims[i], dims[j])] += weight * packed[:, k]
                k += 1
        for i in range(d):
            fold[:, tri + dims[i]] += weight * packed[:, k + i]
        fold[:, tri + D] += weight * packed[:, k + d]

    for m, packed in blocks:
        dims = [0, 1, 2]
        for name in m.attributes:
            dims += list(range(dim_of[name], dim_of[name] + widths[name]))
        add(packed, dims, m.weight)
    if boundary_weight > 0.0:
        planes = np.zeros((n, PLANE_SIZE))
        add_boundary_planes(ctx.halfedge, ctx.positions, boundary_weight, planes)
        add(planes, [0, 1, 2], 1.0)
    return fold, np.asarray(columns, dtype=np.intc)


def checked(metric, arr, shape, what, columns=None):
    """A metric's array as float64, with the shape it must have and no NaN."""
    try:
        out = np.asarray(arr, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise MetricError(f"metric {metric.name!r} returned {what} that are not numbers: {exc}") from None
    ok = out.ndim >= 1 and out.shape[0] == shape[0]
    if columns is not None:
        ok = ok and out.ndim == 2 and out.shape[1] == columns
    elif len(shape) == 1:
        ok = ok and out.ndim in (1, 2)
    if not ok:
        want = f"({shape[0]}, {columns})" if columns else f"({shape[0]},) or ({shape[0]}, k)"
        raise MetricError(f"metric {metric.name!r} returned {what} of shape {out.shape}; expected {want}")
    # (a minimum propagates NaN: one pass, no boolean temporary of the array's size)
    if out.size and np.isnan(np.min(out)):
        raise MetricError(f"metric {metric.name!r} returned {what} with NaN values")
    return out


def batch_result(metric, result, k):
    """(costs (k,), positions (k, 3) or None) from what a batch metric's ``costs`` returned."""
    pos = None
    if isinstance(result, tuple):
        if len(result) != 2:
            raise MetricError(f"metric {metric.name!r}: costs() must return costs or (costs, positions)")
        result, pos = result
        pos = checked(metric, pos, (k, 3), "positions", columns=3)
        if pos.shape != (k, 3) or not np.isfinite(pos).all():
            raise MetricError(f"metric {metric.name!r} returned positions that are not ({k}, 3) finite numbers")
    cost = checked(metric, result, (k,), "costs")
    if cost.shape != (k,):
        raise MetricError(f"metric {metric.name!r} returned costs of shape {cost.shape}; expected ({k},)")
    return cost, pos


def removal_kernel(metric, ctx: MetricContext):
    """The vertex-removal metric's kernel, prepared for this run."""
    metric.prepare(ctx)
    kernel = metric.make_kernel(ctx)
    if not isinstance(kernel, RemovalKernel):
        raise MetricError(f"metric {metric.name!r}: make_kernel returned {type(kernel).__name__}, "
                          f"not a lodkit.removal.RemovalKernel")
    return kernel
