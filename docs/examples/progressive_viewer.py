#!/usr/bin/env python
"""Flip through a progressive mesh: one simplifier run, every level of detail.

    python docs/examples/progressive_viewer.py [MESH] [--metric qem]
    python docs/examples/progressive_viewer.py bunny.ply --png strip.png    # headless: a strip

``lodkit.progressive`` simplifies the mesh once, to the coarsest mesh, and keeps the
collapse records; any level is then extracted without re-running the simplifier. In the
window (Open3D's ``VisualizerWithKeyCallback``) the keys step along the records:

    [  coarsen by one collapse        ]  refine by one vertex split
    -  coarsen by 10% of the faces    =  refine by 10% of the faces

With ``--png`` it writes a strip of a few levels (100%, 30%, 10%, 3%, 1% of the faces).
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import camera, load, open3d_mesh, panel_size, parser  # noqa: E402

import lodkit  # noqa: E402
import lodkit.render as lr  # noqa: E402

STRIP = (1.0, 0.3, 0.1, 0.03, 0.01)


def main(argv=None) -> int:
    ap = parser(__doc__.split("\n\n")[0])
    ap.add_argument("--metric", default="qem", help="the simplification metric (default qem)")
    args = ap.parse_args(argv)
    mesh, name = load(args)
    pm = lodkit.progressive(mesh, metric=args.metric)
    n_in = mesh.n_faces
    print(f"{name}: {n_in} faces, {pm.n_steps} collapse records, base mesh {pm.at(step=pm.n_steps).n_faces} faces")
    if args.png:
        w, h = panel_size(args)
        cam = camera(args, mesh, w, h)
        row, labels = [], []
        for r in STRIP:
            level = pm.at(faces=max(1, int(round(r * n_in))))
            row.append(lr.render(level, w, h, camera=cam, wireframe=level.n_faces <= 4000))
            labels.append(f"{level.n_faces} faces")
        sheet = lr.contact_sheet([row], labels=[labels], label_scale=1)
        lr.write_png(args.png, sheet)
        print(f"wrote {args.png} ({sheet.shape[1]}x{sheet.shape[0]}, {lr.backend()} renderer)")
        return 0
    import open3d as o3d

    # start in the middle of the records, so both directions do something
    pm.refine(pm.n_steps // 2)
    shown = open3d_mesh(pm.current)
    ten_percent = max(1, pm.n_steps // 10)

    def update(vis, move):
        move()
        cur = open3d_mesh(pm.current)
        shown.vertices, shown.triangles = cur.vertices, cur.triangles
        shown.vertex_normals, shown.vertex_colors = cur.vertex_normals, cur.vertex_colors
        vis.update_geometry(shown)
        print(f"step {pm.step}/{pm.n_steps}: {len(shown.triangles)} faces")
        return False

    vis = o3d.visualization.VisualizerWithKeyCallback()
    vis.create_window(window_name=f"lodkit progressive mesh of {name}")
    vis.add_geometry(shown)
    vis.register_key_callback(ord("["), lambda v: update(v, lambda: pm.coarsen(1)))
    vis.register_key_callback(ord("]"), lambda v: update(v, lambda: pm.refine(1)))
    vis.register_key_callback(ord("-"), lambda v: update(v, lambda: pm.coarsen(min(ten_percent, pm.n_steps - pm.step))))
    vis.register_key_callback(ord("="), lambda v: update(v, lambda: pm.refine(min(ten_percent, pm.step))))
    vis.get_render_option().mesh_show_wireframe = True
    print("keys: [ ] one step, - = 10%; q closes")
    vis.run()
    vis.destroy_window()
    return 0


if __name__ == "__main__":
    sys.exit(main())
