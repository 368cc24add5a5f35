"""Type stubs for lodkit._core.triangle (Cython)."""
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .edge import EdgeCollapser

class TriangleCollapser(EdgeCollapser):
    """Triangle collapse: faces are the candidates, each goes to one point as two edge
    collapses checked before either is done.  Quadric metrics only."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        """The arguments of :class:`lodkit._core.edge.EdgeCollapser`."""
    def plan_face(self, f: int) -> tuple[int, int, int, NDArray[np.float64], float, float] | None:
        """(kept, first removed, second removed, position, cost, error) for face f, or None."""
    def check_face(self, f: int) -> bool:
        """Would face f collapse now (all checks of both collapses)?  Changes nothing."""
    @property
    def n_tri_collapses(self) -> int:
        """Triangle collapses done (two edge collapses each)."""
    @property
    def n_tri_refused_second(self) -> int:
        """Triangle candidates that passed the first collapse's checks and failed the second's."""
