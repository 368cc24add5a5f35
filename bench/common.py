"""Helpers the single-section benchmark scripts share (bench/clustering.py, bench/progressive.py).

Import it as the scripts import their other bench modules (``bench/`` on ``sys.path``):
``from common import shared_mesh_path, write_results``.
"""
from __future__ import annotations

import json
import os
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
