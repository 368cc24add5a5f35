"""Helpers the benchmark scripts share (bench/clustering.py, bench/progressive.py,
bench/fidelity.py, bench/removal.py).

Import it as the scripts import their other bench modules (``bench/`` on ``sys.path``):
``from common import shared_mesh_path, write_results``.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def shared_mesh_path(filename: str) -> Path:
    """A file of the shared meshes, looked up as the test suite does: in
    ``$LODKIT_TEST_DATA`` when set, else in ``../shared/data/meshes`` next to the repo."""
    return Path(os.environ.get("LODKIT_TEST_DATA", REPO.parent / "shared" / "data" / "meshes")) / filename


def write_results(results, json_path, section: str, report, begin: str, end: str) -> None:
    """Write ``results`` to ``json_path`` (atomically; its folder is made if missing) and put
    ``section`` into the report between ``begin`` and ``end`` (bench/report.py's splice_section)."""
    from report import splice_section

    json_path = Path(json_path)
    json_path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(str(json_path) + ".tmp")
    tmp.write_text(json.dumps(results, indent=2) + "\n")
    tmp.replace(json_path)
    splice_section(Path(report), section, begin, end)


def run_worker(args, timeout: float) -> str | None:
    """Run ``python <args>`` in a fresh process with this checkout and ``bench/`` on its
    path (a crash or a hang there cannot take the benchmark down); None if it exited 0,
    else what went wrong (exit code or signal and the last stderr lines, or the timeout)."""
    here = Path(__file__).resolve().parent
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), str(here)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    try:
        p = subprocess.run([sys.executable, *map(str, args)], capture_output=True, text=True, timeout=timeout,
                           env=env, cwd=str(here))
    except subprocess.TimeoutExpired:
        return f"timed out after {timeout:.0f} s"
    if p.returncode == 0:
        return None
    sig = f" (signal {-p.returncode})" if p.returncode < 0 else ""
    tail = " | ".join(p.stderr.strip().splitlines()[-3:])
    return f"worker exited with {p.returncode}{sig}: {tail[-300:]}"
