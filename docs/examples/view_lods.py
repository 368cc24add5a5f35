#!/usr/bin/env python
"""A mesh and its LODs side by side.

    python docs/examples/view_lods.py [MESH] [--ratios 0.5,0.1,0.02] [--metric qem]
    python docs/examples/view_lods.py bunny.ply --png lods.png      # headless: a contact sheet

With a window (Open3D's ``draw_geometries``) the LODs are translated copies next to the
original; with ``--png`` they are drawn headless by ``lodkit.render`` with one camera and
put in a row with their face counts and errors.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import camera, load, open3d_mesh, panel_size, parser  # noqa: E402

import lodkit  # noqa: E402
import lodkit.render as lr  # noqa: E402


def lods(mesh: lodkit.Mesh, ratios: list[float], metric: str) -> list[tuple[str, lodkit.Mesh]]:
    out = [(f"original {mesh.n_faces} faces", mesh)]
    for r in ratios:
        res = lodkit.simplify(mesh, target_ratio=r, metric=metric)
        out.append((f"{r:.3g}: {res.mesh.n_faces} faces, err {res.error:.2g}", res.mesh))
    return out


def main(argv=None) -> int:
    ap = parser(__doc__.split("\n\n")[0])
    ap.add_argument("--ratios", default="0.5,0.1,0.02", help="comma list of target ratios")
    ap.add_argument("--metric", default="qem", help="the simplification metric (default qem)")
    args = ap.parse_args(argv)
    try:
        ratios = [float(r) for r in args.ratios.split(",") if r.strip()]
    except ValueError:
        ap.error(f"--ratios must be numbers, got {args.ratios!r}")
    mesh, name = load(args)
    chain = lods(mesh, ratios, args.metric)
    for label, _ in chain:
        print(f"{name}: {label}")
    if args.png:
        w, h = panel_size(args)
        cam = camera(args, mesh, w, h)
        row = [lr.render(m, w, h, camera=cam) for _, m in chain]
        sheet = lr.contact_sheet([row], labels=[[label for label, _ in chain]], label_scale=1)
        lr.write_png(args.png, sheet)
        print(f"wrote {args.png} ({sheet.shape[1]}x{sheet.shape[0]}, {lr.backend()} renderer)")
        return 0
    import open3d as o3d

    step = 1.15 * float(np.ptp(mesh.vertices[:, 0]))
    shown = []
    for i, (_, m) in enumerate(chain):
        g = open3d_mesh(m)
        g.translate((i * step, 0.0, 0.0))
        shown.append(g)
    o3d.visualization.draw_geometries(shown, window_name=f"lodkit LODs of {name}", mesh_show_wireframe=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
