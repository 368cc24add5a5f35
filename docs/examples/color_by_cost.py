#!/usr/bin/env python
"""Colour a mesh by how much each vertex matters to the simplifier.

    python docs/examples/color_by_cost.py [MESH] --by importance|cost|order
    python docs/examples/color_by_cost.py cow.obj --by importance --png cow.png   # headless

--by importance   MELOD's visual importance w_v = 1 - |sum A_i n_i| / sum A_i over the faces
                  around each vertex (0 on a flat patch, towards 1 at a sharp tip or crease;
                  docs/metrics/melod.md)
--by cost         log10 of the cost of the collapse that removes the vertex, in one
                  ``simplify(..., record=True)`` run down to 1% of the faces; vertices that
                  survive it are grey
--by order        when the vertex goes: the step of its collapse as a fraction of all
                  steps (0: first to go; survivors are 1)

Colours are viridis (dark blue low, yellow high). The window is Open3D's
``draw_geometries``; ``--png`` writes the picture with a colour bar.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import camera, load, open3d_mesh, panel_size, parser  # noqa: E402

import lodkit  # noqa: E402
import lodkit.render as lr  # noqa: E402


def importance(mesh: lodkit.Mesh) -> np.ndarray:
    from lodkit._core.melod_kernel import visual_importance

    return np.asarray(visual_importance(mesh.vertices, mesh.faces, mesh.n_vertices))


def collapse_records(mesh: lodkit.Mesh, metric: str) -> tuple[dict, int]:
    target = max(4, int(round(0.01 * mesh.n_faces)))
    res = lodkit.simplify(mesh, target_faces=target, metric=metric, record=True)
    return res.collapses, res.n_collapses


def values_for(mesh: lodkit.Mesh, by: str, metric: str) -> tuple[np.ndarray, str]:
    """Per-vertex values and the colour bar's label."""
    if by == "importance":
        return importance(mesh), "visual importance"
    rec, n = collapse_records(mesh, metric)
    removed = np.asarray(rec["removed"], dtype=np.int64)
    if by == "cost":
        v = np.full(mesh.n_vertices, np.nan)
        cost = np.asarray(rec["cost"], dtype=np.float64)
        v[removed] = np.log10(np.maximum(cost, 1e-16))
        return v, f"log10 cost ({metric})"
    v = np.ones(mesh.n_vertices)
    v[removed] = np.arange(len(removed)) / max(1, n)
    return v, "removal step / all"


def main(argv=None) -> int:
    ap = parser(__doc__.split("\n\n")[0])
    ap.add_argument("--by", choices=("importance", "cost", "order"), default="importance")
    ap.add_argument("--metric", default="qem", help="metric for --by cost|order (default qem)")
    args = ap.parse_args(argv)
    mesh, name = load(args)
    values, label = values_for(mesh, args.by, args.metric)
    finite = values[np.isfinite(values)]
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    print(f"{name}: {label} from {lo:.4g} to {hi:.4g} over {mesh.n_vertices} vertices "
          f"({int(np.count_nonzero(~np.isfinite(values)))} without a value)")
    rgb = lr.colormap(values, lo, hi)
    if args.png:
        w, h = panel_size(args)
        img = lr.render(mesh, w, h, colors=rgb, camera=camera(args, mesh, w, h))
        bar = lr.colorbar(lo, hi, height=int(0.7 * h), label=None, scale=1)
        sheet = lr.contact_sheet([[img, bar]], labels=[[f"{name}: {label}", ""]], label_scale=1)
        lr.write_png(args.png, sheet)
        print(f"wrote {args.png} ({sheet.shape[1]}x{sheet.shape[0]}, {lr.backend()} renderer)")
        return 0
    import open3d as o3d

    o3d.visualization.draw_geometries([open3d_mesh(mesh, rgb)], window_name=f"lodkit: {name} by {label}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
