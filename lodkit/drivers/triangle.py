"""Triangle collapse (``operator="triangle"``): the cheapest face goes to one point and dies
with its three neighbours, done and recorded as two edge collapses by the core's
EdgeCollapser (docs/algorithms.md, "Triangle collapse").  Quadric metrics only: the other
kinds define their values per edge or vertex pair (lodkit.settings.resolve_operator says so)."""
from __future__ import annotations

from .._compile import Compiled
from .._pipeline import Run, Work
from .edge import FIX_SEAMS, check, records, run_collapser, setup

__all__ = ["FIX_SEAMS", "check", "memory_order", "setup", "run", "records"]


def memory_order(metrics, settings) -> bool:
    """Triangle collapse runs from the heap in the greedy order, on the slots as loaded."""
    return False


def run(work: Work, compiled: Compiled, settings: dict, *, target: int, max_error: float, record: bool,
        progress: bool) -> Run:
    return run_collapser(work, compiled, settings, target=target, max_error=max_error, record=record,
                         progress=progress, operator="triangle")
