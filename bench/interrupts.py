"""Ctrl-C latency of every driver on the 1M-face demo surface (docs/reliability.md, "Interrupts").

For each driver a fresh process loads the demo surface (generated once and cached as .npz),
says "go", and starts the run; this script sends it SIGINT ``--delay`` seconds later and
measures the time from the signal to the worker's ``except KeyboardInterrupt`` (both read
CLOCK_MONOTONIC, which is system-wide on Linux).  The worker then checks that its input
arrays are unchanged and that a second, small call works, and reports.

    python bench/interrupts.py                       # every driver, SIGINT 1 s into the run
    python bench/interrupts.py --delay 0.3 2 --only qem,melod
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent

# label -> the call, as Python source run on ``mesh`` (a lodkit.Mesh of the demo surface)
DRIVERS = {
    "qem (greedy edge)": "lodkit.simplify(mesh, target_ratio=0.01)",
    "qem, driver=pass": "lodkit.simplify(mesh, target_ratio=0.01, driver='pass')",
    "triangle": "lodkit.simplify(mesh, target_ratio=0.01, operator='triangle')",
    "melod": "lodkit.simplify(mesh, target_ratio=0.01, metric='melod')",
    "schroeder": "lodkit.simplify(mesh, target_ratio=0.01, metric='schroeder')",
    "volume": "lodkit.simplify(mesh, target_ratio=0.01, metric='volume')",
    "cluster": "lodkit.cluster(mesh, target_faces=5000)",
    "progressive": "lodkit.progressive(mesh, min_faces=1000)",
}

WORKER = r"""
import hashlib, sys, time
import numpy as np
import lodkit
data = np.load(sys.argv[1])
mesh = lodkit.Mesh(data["vertices"], data["faces"])
def digest():
    return hashlib.sha256(mesh.vertices.tobytes() + mesh.faces.tobytes()).hexdigest()
before = digest()
small = lodkit.Mesh(mesh.vertices[:0], mesh.faces[:0])
print("go", flush=True)
t0 = time.monotonic()
try:
    CALL
except KeyboardInterrupt:
    t = time.monotonic()
    ok_input = digest() == before
    from lodkit.demo import demo_mesh
    again = lodkit.simplify(demo_mesh(2000), target_ratio=0.5)
    print(f"interrupted {t!r} {t - t0!r} input_unchanged={ok_input} next_call_faces={again.mesh.n_faces}",
          flush=True)
else:
    print(f"finished {time.monotonic() - t0!r}", flush=True)
"""


def demo_path(n_faces: int) -> Path:
    path = Path(os.environ.get("TMPDIR", "/tmp")) / f"lodkit_demo_{n_faces}.npz"
    if not path.exists():
        import numpy as np

        from lodkit.demo import demo_mesh
        m = demo_mesh(n_faces)
        tmp = path.with_suffix(".tmp.npz")
        np.savez(tmp, vertices=m.vertices, faces=m.faces)
        tmp.replace(path)
    return path


def measure(call: str, data: Path, delay: float) -> dict:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    p = subprocess.Popen([sys.executable, "-c", WORKER.replace("CALL", call), str(data)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    assert p.stdout.readline().strip() == "go"
    time.sleep(delay)
    sent = time.monotonic()
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=600)
    words = out.split()
    if p.returncode != 0 or not words:
        return {"error": f"exit {p.returncode}: {err.strip()[-300:]}"}
    if words[0] == "finished":
        return {"finished_before_signal": float(words[1])}
    return {"latency_s": round(float(words[1]) - sent, 3), "interrupted_after_s": round(float(words[2]), 2),
            "input_unchanged": words[3].endswith("True"), "next_call": words[4]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--faces", type=int, default=1_000_000)
    ap.add_argument("--delay", type=float, nargs="+", default=[1.0])
    ap.add_argument("--only", default="", help="comma-separated substrings of driver labels")
    ap.add_argument("--json", default="")
    args = ap.parse_args(argv)
    data = demo_path(args.faces)
    rows = []
    for label, call in DRIVERS.items():
        if args.only and not any(s in label for s in args.only.split(",")):
            continue
        for delay in args.delay:
            r = {"driver": label, "delay_s": delay, **measure(call, data, delay)}
            rows.append(r)
            print(json.dumps(r), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")
    worst = max((r.get("latency_s", 0.0) for r in rows), default=0.0)
    print(f"worst latency {worst:.3f} s over {len(rows)} runs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
