"""Peak memory per input vertex of each driver on the 1M-face demo surface
(docs/reliability.md, "Memory").

Each driver runs in a fresh process that has imported lodkit, loaded the surface and run a
tiny warm-up simplification (so one-off import and code allocations are not counted).
Two figures, both divided by the input vertex count:

* ``traced``: the tracemalloc peak during the call -- every numpy array and Python object
  lodkit allocates (the core's buffers are numpy arrays), the returned result included;
* ``rss``: the growth of the process's peak resident set (VmHWM, reset just before the
  call through /proc/self/clear_refs) over its resident set before the call: what the
  machine sees, allocator slack and untraced C allocations included.

    python bench/memory.py                     # every driver
    python bench/memory.py --only melod,volume --faces 250000
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
from interrupts import demo_path  # noqa: E402

# a label without a driver= runs the default driver (the pass driver for edge collapse)
DRIVERS = {
    "qem": "lodkit.simplify(mesh, target_ratio=0.01)",
    "qem, driver=greedy": "lodkit.simplify(mesh, target_ratio=0.01, driver='greedy')",
    "qem, driver=pass": "lodkit.simplify(mesh, target_ratio=0.01, driver='pass')",
    "triangle": "lodkit.simplify(mesh, target_ratio=0.01, operator='triangle')",
    "melod": "lodkit.simplify(mesh, target_ratio=0.01, metric='melod')",
    "melod, driver=greedy": "lodkit.simplify(mesh, target_ratio=0.01, metric='melod', driver='greedy')",
    "schroeder": "lodkit.simplify(mesh, target_ratio=0.01, metric='schroeder')",
    "volume": "lodkit.simplify(mesh, target_ratio=0.01, metric='volume')",
}

WORKER = r"""
import gc, json, sys, tracemalloc
import numpy as np
import lodkit
from lodkit.demo import demo_mesh
data = np.load(sys.argv[1])
mesh = lodkit.Mesh(data["vertices"], data["faces"])
del data
lodkit.simplify(demo_mesh(2000), target_ratio=0.5, metric=METRIC)     # warm-up
gc.collect()
def status(key):
    for line in open("/proc/self/status"):
        if line.startswith(key):
            return int(line.split()[1]) * 1024
with open("/proc/self/clear_refs", "w") as fh:
    fh.write("5")                                   # reset VmHWM to the current RSS
rss0 = status("VmRSS:")
tracemalloc.start()
result = CALL
traced = tracemalloc.get_traced_memory()[1]
tracemalloc.stop()
hwm = status("VmHWM:")
print(json.dumps({"n_vertices": mesh.n_vertices, "n_faces": mesh.n_faces, "traced": traced,
                  "rss": hwm - rss0, "out_faces": result.mesh.n_faces}))
"""


def measure(call: str, data: Path) -> dict:
    metric = "'qem'"
    for name in ("melod", "schroeder", "volume"):
        if f"metric='{name}'" in call:
            metric = f"'{name}'"
    code = WORKER.replace("CALL", call).replace("METRIC", metric)
    p = subprocess.run([sys.executable, "-c", code, str(data)], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=str(REPO)), timeout=1800)
    if p.returncode != 0:
        return {"error": p.stderr.strip()[-400:]}
    r = json.loads(p.stdout.strip().splitlines()[-1])
    n = r["n_vertices"]
    return {"traced_B_per_vertex": round(r["traced"] / n), "rss_B_per_vertex": round(r["rss"] / n),
            "n_vertices": n, "n_faces": r["n_faces"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--faces", type=int, default=1_000_000)
    ap.add_argument("--only", default="", help="comma-separated substrings of driver labels")
    ap.add_argument("--json", default="")
    args = ap.parse_args(argv)
    data = demo_path(args.faces)
    rows = []
    for label, call in DRIVERS.items():
        if args.only and not any(s in label for s in args.only.split(",")):
            continue
        r = {"driver": label, **measure(call, data)}
        rows.append(r)
        print(json.dumps(r), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
