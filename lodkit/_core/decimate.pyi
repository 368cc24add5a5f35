"""Type stubs for lodkit._core.decimate (Cython)."""
from typing import Optional

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .halfedge import HalfEdgeMesh

def vertex_quadrics(
    hm: HalfEdgeMesh, positions: ArrayLike, boundary_weight: float = ..., out: Optional[NDArray[np.float64]] = ...
) -> NDArray[np.float64]:
    """(n, 11) area-weighted plane quadrics (a11 a12 a13 a22 a23 a33 b1 b2 b3 c w)."""

class EdgeCollapser:
    """Greedy QEM edge collapse over a HalfEdgeMesh, modified in place."""

    n_collapses: int
    max_error_done: float
    n_rejected_error: int
    n_rejected_topology: int
    n_rejected_geometry: int
    def __init__(
        self,
        hm: HalfEdgeMesh,
        positions: ArrayLike,
        quadrics: ArrayLike,
        attributes: Optional[ArrayLike],
        fixed: ArrayLike,
        placement: int = ...,
        boundary: int = ...,
        max_normal_angle: float = ...,
        min_quality: float = ...,
        max_error: float = ...,
    ) -> None: ...
    def run(self, target_faces: int, max_steps: int = ...) -> int:
        """0: target reached, 1: step budget used, 2: no legal collapse left."""
    def release(self) -> None:
        """Free the heap, quadrics and input normals after the run."""
    def plan_edge(self, u: int, v: int) -> Optional[tuple[int, int, NDArray[np.float64], float, float]]:
        """(removed, kept, position, cost, error) for edge (u, v), or None."""
    @property
    def n_alive_faces(self) -> int: ...
    @property
    def positions(self) -> NDArray[np.float64]: ...
    @property
    def attributes(self) -> NDArray[np.float64]: ...
    @property
    def moved_vertices(self) -> NDArray[np.bool_]: ...
    @property
    def quadrics(self) -> NDArray[np.float64]: ...
    def records(self) -> dict[str, NDArray]:
        """The collapse sequence: removed, kept, position, cost, error."""
