#!/usr/bin/env python
"""Pictures for docs/retile.md and docs/optimize.md: bunny and fandisk at 2% of their
vertices, QEM (lodkit.simplify) next to retile and optimize (from that QEM result) at the
same vertex count, wireframe, one camera per mesh.

    python bench/global_pictures.py          # writes docs/img/global_methods.png (~1 minute)
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
if importlib.util.find_spec("lodkit") is None:     # a checkout without lodkit installed: its source
    sys.path.insert(0, str(REPO))
sys.path.insert(0, str(HERE))

from common import shared_mesh_path  # noqa: E402

import lodkit  # noqa: E402
from lodkit.viz import Camera, contact_sheet, render, write_png  # noqa: E402


def main() -> int:
    rows, labels = [], []
    for name, fraction in (("bunny.ply", 0.02), ("fandisk.obj", 0.02)):
        src = lodkit.load(shared_mesh_path(name))
        qem = lodkit.simplify(src, target_faces=int(round(2 * fraction * src.n_vertices))).mesh
        n = qem.n_vertices
        ret = lodkit.retile(src, n).mesh
        opt = lodkit.optimize(src, start=qem, n_vertices=n).mesh
        cam = Camera.fit(src, 360, 300)
        rows.append([render(m, 360, 300, camera=cam, wireframe=True) for m in (src, qem, ret, opt)])
        stem = name.split(".")[0]
        labels.append([f"{stem} {src.n_vertices} v", f"QEM {qem.n_vertices} v", f"retile {ret.n_vertices} v",
                       f"optimize {opt.n_vertices} v"])
    out = REPO / "docs" / "img" / "global_methods.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    write_png(out, contact_sheet(rows, labels=labels))
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
