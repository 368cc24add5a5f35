"""Type stubs for lodkit._core.retile (Cython): the native parts of re-tiling and mesh optimisation."""
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..removal import RemovalKernel

class RetileKernel(RemovalKernel):
    """Vertex-removal kernel of re-tiling: the max-min-quality triangulation of the hole."""

    api_version: ClassVar[int]
    def __init__(self, cos_feature: float = -2.0, group: NDArray[np.intc] | None = None) -> None:
        """cos_feature: edges whose faces' unit normals have a smaller dot product are
        creases the hole must keep (-2: none).  group: per vertex slot, the split copies of
        a non-manifold input vertex share a value >= 0 (others -1); chords that would put a
        vertex next to two copies of one input vertex are refused."""
    @property
    def star_local(self) -> bool:
        """True without ``group``."""

def flip_edges(V: NDArray[np.float64], F: NDArray[np.intc], twin: NDArray[np.intc], min_dot: float,
               max_sweeps: int, locked: NDArray[np.uint8] | None = None, below: float = 2.0,
               locked_dot: float = 2.0, group: NDArray[np.intc] | None = None) -> int:
    """Quality-raising flips between nearly coplanar faces; F and twin updated in place."""

def project_local(X: NDArray[np.float64], S: NDArray[np.int64], V: NDArray[np.float64],
                  T: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """For each sample X[S[i]], the closest of the triangles T: (index, weights, squared distance)."""

def closest_on_faces(X: NDArray[np.float64], V: NDArray[np.float64], F: NDArray[np.int64],
                     face: NDArray[np.int64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """For each point X[i], the closest point of face face[i]: (weights, squared distance)."""

def polish_sums(P: NDArray[np.float64], NI: NDArray[np.float64], X: NDArray[np.float64], F: NDArray[np.int64],
                NF: NDArray[np.float64], face: NDArray[np.int64], across: NDArray[np.int64], local: bool,
                floor: float) -> tuple[float, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                                       NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], int]:
    """One round of lodkit.polish's sums over the samples (``face`` updated in place):
    (mean distance, C, r, own, sq, ws, stand, samples kept)."""
