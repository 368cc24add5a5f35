"""Type stubs for lodkit._core.passes (Cython)."""
from typing import Any

from numpy.typing import ArrayLike

from .edge import EdgeCollapser, _Plan

#: the phases of PassDriver.phase_seconds, in order
PHASE_NAMES: tuple[str, ...]

class PassCollapser(EdgeCollapser):
    """Edge collapse driven in passes by a batch metric (made with use_heap=False)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        """The arguments of :class:`lodkit._core.edge.EdgeCollapser`."""
    def plan_all(self) -> _Plan | None:
        """Plan every live edge (batch driver); None if a kernel failed."""
    def collapse_pass(self, edges: ArrayLike, positions: ArrayLike | None = ..., target_faces: int = ...) -> int:
        """Collapse, in the order given, the edges no earlier collapse of this pass touched;
        the number of collapses, or -1 if a kernel failed."""

class PassDriver:
    """Runs a PassCollapser in error-limited passes, each in two stages: blocks of the
    surface on several threads, then what reached out of its block, in cost order
    (``simplify(driver="pass")``); the output is the same for any ``threads``."""

    n_passes: int
    n_deferred: int
    n_late: int
    threads: int
    fraction: float

    def __init__(self, collapser: PassCollapser, fraction: float = ..., threads: int = ...,
                 block: int = ..., min_parallel: int = ...) -> None: ...
    @property
    def phase_seconds(self) -> dict[str, float]: ...
    def run(self, target_faces: int, max_steps: int = ...) -> int:
        """Collapse until ``target_faces`` faces are left, nothing legal is left, or a pass
        ends with ``max_steps`` collapses done; 0 target, 1 chunk, 2 exhausted, 3 kernel error."""
