"""Type stubs for lodkit._core.decimate (Cython)."""
from typing import Iterable, Optional, TypedDict

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..kernel import Kernel
from .halfedge import HalfEdgeMesh

def face_unit_normals(hm: HalfEdgeMesh, positions: ArrayLike) -> NDArray[np.int16]:
    """(n_faces * 3,) int16 unit normals of the face slots, scaled by 32767 (zeros for
    degenerate faces)."""

def vertex_quadrics(
    hm: HalfEdgeMesh, positions: ArrayLike, boundary_weight: float = ..., out: Optional[NDArray[np.float64]] = ...
) -> NDArray[np.float64]:
    """(n, 11) area-weighted plane quadrics (a11 a12 a13 a22 a23 a33 b1 b2 b3 c w)."""

def general_quadric_marginal(
    g: ArrayLike, D: int, p: Optional[ArrayLike] = ...
) -> tuple[NDArray[np.float64], Optional[NDArray[np.float64]]]:
    """The marginal of one packed D-dimensional quadric (3 <= D <= 16): its 3D quadric (10,)
    and, with ``p``, the attributes (D - 3,) that minimise it there (None without ``p`` or
    when the attribute block is singular).  For tests."""

def add_boundary_planes(hm: HalfEdgeMesh, positions: ArrayLike, weight: float, out: NDArray[np.float64]) -> None:
    """Add to ``out`` (n, >= 10), for every boundary edge and to both its ends, the plane
    through the edge perpendicular to its face, weighted by ``weight * length^2``."""

class _Plan(TypedDict):
    """What :meth:`EdgeCollapser.plan_all` returns: one row per edge that may collapse."""

    edge: NDArray[np.intc]
    u: NDArray[np.intc]
    v: NDArray[np.intc]
    removed: NDArray[np.intc]
    kept: NDArray[np.intc]
    position: NDArray[np.float64]
    cost: NDArray[np.float64]
    error: NDArray[np.float64]

class EdgeCollapser:
    """Greedy QEM edge collapse over a HalfEdgeMesh, modified in place.

    Field rules are (k, 5) float rows: merge, value, mode, weight, offset (codes in
    decimate.pxd: merge max 0, min 1, sum 2, keep 3, mean 4; value max 0, min 1, sum 2,
    kept 3, removed 4, mean 5; mode scale 0, add 1).
    """

    n_collapses: int
    max_error_done: float
    n_rejected_error: int
    n_rejected_topology: int
    n_rejected_geometry: int
    n_vetoed: int
    """Candidates refused by a kernel since the last rescan (or plan_all)."""
    failed: bool
    """A kernel returned KERNEL_ERROR: see ``error_message``."""
    n_seam_pairs: int
    """Seam edges collapsed together with their partner edge (two collapses each)."""
    n_tri_collapses: int
    """Triangle collapses done (operator=1; two edge collapses each)."""
    n_tri_refused_second: int
    """Triangle candidates that passed the first collapse's checks and failed the second's."""
    def __init__(
        self,
        hm: HalfEdgeMesh,
        positions: Optional[ArrayLike],
        quadrics: ArrayLike,
        attributes: Optional[ArrayLike],
        fixed: ArrayLike,
        placement: int = ...,
        boundary: int = ...,
        max_normal_angle: float = ...,
        min_quality: float = ...,
        max_error: float = ...,
        record: bool = ...,
        closed_connected: bool = ...,
        quadric_weight: float = ...,
        error_scale: float = ...,
        vertex_fields: Optional[ArrayLike] = ...,
        vertex_rules: Optional[ArrayLike] = ...,
        edge_fields: Optional[ArrayLike] = ...,
        edge_rules: Optional[ArrayLike] = ...,
        kernels: Iterable[Kernel] = ...,
        use_heap: bool = ...,
        attribute_quadrics: Optional[ArrayLike] = ...,
        attribute_columns: Optional[ArrayLike] = ...,
        steps: Optional[ArrayLike] = ...,
        seam_partners: Optional[ArrayLike] = ...,
        operator: int = ...,
    ) -> None:
        """quadric_weight: factor of the quadric in the cost (0: the quadric only places);
        error_scale: error = sqrt(error_scale * Q(p) / area); vertex_fields (n, k) and
        edge_fields (n_edges, k) with their (k, 5) rules (C-contiguous float64 arrays are
        used, and merged, in place); kernels: chained in order; use_heap=False for the pass
        driver (plan_all / collapse_pass) instead of ``run``; attribute_quadrics (n, S)
        packed D-dimensional quadrics over [x, y, z, attributes] with attribute_columns, the
        D - 3 columns of ``attributes`` they range over (placement by their marginal);
        steps: (k, 3) rows (kind, first, end) ordering fields and kernels; seam_partners
        (n,) int: each seam vertex's partner slot, -1 off the seams, -2 a seam copy that
        stays (see lodkit.api._seam_partners); operator: 0 edge collapse, 1 triangle
        collapse (faces are the candidates; quadric metrics only)."""
    def _setup_seams(self, partners: Optional[ArrayLike]) -> None: ...
    def _setup_attribute_quadrics(self, gq: Optional[ArrayLike], columns: Optional[ArrayLike]) -> None: ...
    def run(self, target_faces: int, max_steps: int = ...) -> int:
        """0: target reached, 1: step budget used, 2: no legal collapse left, 3: a kernel failed."""
    def plan_all(self) -> Optional[_Plan]:
        """Plan every live edge (batch driver); None if a kernel failed."""
    def collapse_pass(self, edges: ArrayLike, positions: Optional[ArrayLike] = ..., target_faces: int = ...) -> int:
        """Collapse, in the order given, the edges no earlier collapse of this pass touched;
        the number of collapses, or -1 if a kernel failed.  Needs use_heap=False."""
    @property
    def error_message(self) -> str:
        """The message of the kernel that failed ('' if none did)."""
    @property
    def vertex_field_values(self) -> NDArray[np.float64]:
        """(n, k) current vertex fields (merged on collapse)."""
    @property
    def edge_field_values(self) -> NDArray[np.float64]:
        """(n_edges, k) current edge fields (merged on collapse)."""
    def release(self) -> None:
        """Free the heap, quadrics and input normals after the run."""
    def plan_edge(self, u: int, v: int) -> Optional[tuple[int, int, NDArray[np.float64], float, float]]:
        """(removed, kept, position, cost, error) for edge (u, v), or None."""
    def plan_face(self, f: int) -> Optional[tuple[int, int, int, NDArray[np.float64], float, float]]:
        """Triangle collapse: (kept, first removed, second removed, position, cost, error)
        for face f, or None."""
    def check_face(self, f: int) -> bool:
        """Triangle collapse: would face f collapse now (all checks of both collapses)?
        Changes nothing."""
    @property
    def n_alive_faces(self) -> int: ...
    @property
    def seam_partners(self) -> Optional[NDArray[np.intc]]:
        """Each slot's seam partner (-1 none, -2 stays) as used, or None without seams."""
    @property
    def positions(self) -> NDArray[np.float64]: ...
    @property
    def attributes(self) -> NDArray[np.float64]: ...
    @property
    def moved_vertices(self) -> NDArray[np.bool_]: ...
    @property
    def quadrics(self) -> NDArray[np.float64]: ...
    def records(self) -> dict[str, NDArray]:
        """The collapse sequence: removed, kept, position, cost, error, moved."""
