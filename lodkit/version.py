"""lodkit's version: written once, in pyproject.toml, and read from the installed metadata.

A source checkout imported without being installed (no dist-info) reads pyproject.toml next
to the package instead.
"""
from __future__ import annotations

import re
from importlib import metadata
from pathlib import Path

__all__ = ["__version__"]


def _from_pyproject() -> str | None:
    path = Path(__file__).resolve().parent.parent / "pyproject.toml"
    try:
        text = path.read_text(encoding="utf-8")
    except OSError:
        return None
    project = re.search(r"^\[project\]\s*$(.*?)(?=^\[|\Z)", text, re.M | re.S)
    if project is None or not re.search(r'^name\s*=\s*"lodkit"', project.group(1), re.M):
        return None
    found = re.search(r'^version\s*=\s*"([^"]+)"', project.group(1), re.M)
    return found.group(1) if found else None


def _version() -> str:
    try:
        return metadata.version("lodkit")
    except metadata.PackageNotFoundError:
        return _from_pyproject() or "0+unknown"


__version__ = _version()
