#!/usr/bin/env python
"""The before/after picture of issue 17's accumulated bound (docs/algorithms.md, "Vertex
removal", and the ``volume`` / ``schroeder`` pages): bench/head.py's smooth head-like
surface (~100k faces) at 2% by ``volume`` and ``schroeder`` with the papers' memory-less
rule (``accumulate="off"``, lodkit before) and with lodkit's default (the accumulated
distance bound), next to ``qem``; flat shading, so a shaved region shows as a few large
flat faces.  Each label: faces and the symmetric Metro Hausdorff / mean distance as
fractions of the bbox diagonal (bench/metro.py, 100k samples per surface).

    python bench/removal_pictures.py                 # -> docs/img/removal_accumulate_head.png
    python bench/removal_pictures.py --out /tmp/x.png --ratio 0.05
"""
from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
if importlib.util.find_spec("lodkit") is None:     # a checkout without lodkit installed: its source
    sys.path.insert(0, str(REPO))
sys.path.insert(0, str(HERE))

OUT = REPO / "docs" / "img" / "removal_accumulate_head.png"

#: (label, metric=) of each panel after the original
PANELS = [
    ("volume, accumulate='off'", ("volume", {"accumulate": "off"})),
    ("volume (default: bound)", "volume"),
    ("schroeder, accumulate='off'", ("schroeder", {"accumulate": "off"})),
    ("schroeder (default: bound)", "schroeder"),
    ("qem", "qem"),
]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(OUT))
    ap.add_argument("--ratio", type=float, default=0.02)
    ap.add_argument("--width", type=int, default=230, help="pixels per panel")
    ap.add_argument("--samples", type=int, default=100_000)
    args = ap.parse_args(argv)

    from head import head
    from metro import Reference
    from pictures import Camera, Style, compose, render

    import lodkit

    V0, F0 = head(100_000)
    mesh = lodkit.Mesh(V0, F0)
    target = int(round(args.ratio * len(F0)))
    ref = Reference(V0, F0.astype(np.int64), n_samples=args.samples)
    view = dict(azimuth=125, elevation=15, up="z")
    cam = Camera.fit(V0, args.width, int(args.width * 1.15), **view)
    style = Style(wire=(0.25, 0.25, 0.3), wire_width=0.35)
    panels = [render(V0, F0, cam, Style())]
    labels = [f"input\n{len(F0):,} faces\nbench/head.py"]
    lines = []
    for label, metric in PANELS:
        r = lodkit.simplify(mesh, target_faces=target, metric=metric)
        V, F = r.mesh.vertices, r.mesh.faces.astype(np.int64)
        e = ref.compare(V, F)
        panels.append(render(V, F, cam, style))
        labels.append(f"{label}\n{len(F):,} faces\nH {e['hausdorff']:.2g}, mean {e['mean']:.2g}")
        lines.append(f"{label}: {len(F)} faces, Hausdorff {e['hausdorff']:.3e}, mean {e['mean']:.3e}")
        print(lines[-1], flush=True)
    caption = (f"A smooth, mostly convex head-like surface to {args.ratio:g} of its faces. The papers' "
               "memory-less costs (distance to the current neighbours' plane) keep removing from the "
               "regions they have already flattened; carrying each removal's error to the vertices "
               "that remain (lodkit's default) spreads the removals. Metro distances as fractions of "
               "the bbox diagonal.")
    img = compose(panels, labels, caption)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    img.save(out, optimize=True)
    print(f"-> {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
