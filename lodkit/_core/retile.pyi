"""Type stubs for lodkit._core.retile (Cython): the native parts of re-tiling."""
import numpy as np
from numpy.typing import NDArray

from ..removal import RemovalKernel

class RetileKernel(RemovalKernel):
    """Vertex-removal kernel of re-tiling: the max-min-quality triangulation of the hole."""

def flip_edges(V: NDArray[np.float64], F: NDArray[np.intc], twin: NDArray[np.intc], min_dot: float,
               max_sweeps: int, locked: NDArray[np.uint8] | None = None) -> int:
    """Quality-raising flips between nearly coplanar faces; F and twin updated in place."""
