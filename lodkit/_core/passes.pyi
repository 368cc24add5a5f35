"""Type stubs for lodkit._core.passes (Cython)."""
from typing import Any, Optional

from numpy.typing import ArrayLike

from .edge import EdgeCollapser

class PassCollapser(EdgeCollapser):
    """Edge collapse driven in passes by a batch metric (made with use_heap=False)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        """The arguments of :class:`lodkit._core.edge.EdgeCollapser`."""
    def collapse_pass(self, edges: ArrayLike, positions: Optional[ArrayLike] = ..., target_faces: int = ...) -> int:
        """Collapse, in the order given, the edges no earlier collapse of this pass touched;
        the number of collapses, or -1 if a kernel failed."""
