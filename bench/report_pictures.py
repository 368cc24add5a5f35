#!/usr/bin/env python
"""Regenerate the report and demo pictures of the docs (docs/reports.md).

    python bench/report_pictures.py                  # into docs/img/
    python bench/report_pictures.py --out /tmp/img --mesh bunny

Writes

    docs/img/report/        ``lodkit compare`` on spot (qem, melod and Open3D at 50 %, 10 %
                            and 1 %): report.md, the plots, the contact sheet, results.csv
                            and results.json (report.html is left out: it embeds the same
                            pictures again)
    docs/img/demo_lods.png  the picture ``lodkit demo`` writes (the 100k-face demo surface)

The meshes come from the shared mesh directory (bench/meshes.py ``MESH_DIR``, or the
environment variable LODKIT_MESH_DIR). Both pictures are drawn by lodkit.render's numpy
rasteriser, so they do not depend on the GPU or driver; the times in the table and the
time plot are this machine's.
"""
from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(HERE))

from meshes import MESH_DIR  # noqa: E402

OUT_DIR = REPO / "docs" / "img"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(OUT_DIR), help="directory for report/ and demo_lods.png")
    ap.add_argument("--mesh", default="spot_triangulated", help="stem of a file in the mesh directory")
    ap.add_argument("--samples", type=int, default=50_000)
    args = ap.parse_args(argv)
    os.environ["LODKIT_RENDER_BACKEND"] = "numpy"          # reproducible pictures on any machine

    import lodkit
    from lodkit.demo import SHEET_NAME, run_demo

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    candidates = sorted(MESH_DIR.glob(args.mesh + ".*"))
    if not candidates:
        print(f"no mesh {args.mesh!r} in {MESH_DIR} (set LODKIT_MESH_DIR)", file=sys.stderr)
        return 2
    mesh = candidates[0]
    report = out / "report"
    with tempfile.TemporaryDirectory() as tmp:
        cwd = os.getcwd()
        os.chdir(mesh.parent)           # the report names the input by the path given: no machine paths
        try:
            lodkit.compare(mesh.name, metrics="qem,melod", peers="open3d", ratios=[0.5, 0.1, 0.01],
                           out=tmp, samples=args.samples, seed=0, image_size=(240, 180),
                           log=lambda line: print(line, flush=True))
        finally:
            os.chdir(cwd)
        if report.exists():
            shutil.rmtree(report)
        report.mkdir()
        for p in sorted(Path(tmp).iterdir()):
            if p.name != "report.html":
                shutil.copy(p, report / p.name)
        run_demo(Path(tmp) / "demo", image_size=(240, 180))
        shutil.copy(Path(tmp) / "demo" / SHEET_NAME, out / SHEET_NAME)
    print(f"wrote {report}/ and {out / SHEET_NAME}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
