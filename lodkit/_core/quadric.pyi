"""Type stubs for lodkit._core.quadric (Cython)."""

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .halfedge import HalfEdgeMesh

def face_unit_normals(hm: HalfEdgeMesh, positions: ArrayLike, threads: int = ...) -> NDArray[np.int16]:
    """(n_faces * 3,) int16 unit normals of the face slots, scaled by 32767 (zeros for
    degenerate faces); the same for any number of ``threads``."""

def vertex_quadrics(
    hm: HalfEdgeMesh,
    positions: ArrayLike,
    boundary_weight: float = ...,
    out: NDArray[np.float64] | None = ...,
    threads: int = ...,
    normals: NDArray[np.int16] | None = ...,
) -> NDArray[np.float64]:
    """(n, 11) area-weighted plane quadrics (a11 a12 a13 a22 a23 a33 b1 b2 b3 c w); the same
    bits for any number of ``threads``.  ``normals`` ((3 m,) int16): also each face's unit
    normal x 32767, rounded, as :func:`face_unit_normals` gives it (degenerate faces left
    alone)."""

def general_quadric_marginal(
    g: ArrayLike, D: int, p: ArrayLike | None = ...
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """The marginal of one packed D-dimensional quadric (3 <= D <= 16): its 3D quadric (10,)
    and, with ``p``, the attributes (D - 3,) that minimise it there (None without ``p`` or
    when the attribute block is singular).  For tests."""

def truncated_solve(q: ArrayLike, x0: ArrayLike, method: str = ...) -> NDArray[np.float64]:
    """The truncated quadric solve about ``x0`` for one (11,) quadric row: "closed" (the
    closed-form eigen-solve the planners use) or "jacobi" (the reference).  For tests."""

def truncated_solve_rank(q: ArrayLike, x0: ArrayLike, method: str = ...) -> tuple[NDArray[np.float64], int]:
    """``truncated_solve`` and the number of directions (0-3) it solved in.  For tests."""

def add_boundary_planes(hm: HalfEdgeMesh, positions: ArrayLike, weight: float, out: NDArray[np.float64]) -> None:
    """Add to ``out`` (n, >= 10), for every boundary edge and to both its ends, the plane
    through the edge perpendicular to its face, weighted by ``weight * length^2``."""

class AttributeQuadrics:
    """Per-vertex quadrics over [position, attributes] (packed (n, D(D+1)/2 + D + 1)) over
    the attribute ``columns``, with each vertex's clamp box; ``gq`` None: none."""

    dim: int
    """D = 3 + attribute channels (0: no quadrics over attributes)."""
    def __init__(
        self,
        hm: HalfEdgeMesh,
        attributes: NDArray[np.float64],
        gq: ArrayLike | None = ...,
        columns: ArrayLike | None = ...,
    ) -> None: ...
