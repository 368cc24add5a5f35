"""Type stubs for lodkit._core.edge (Cython)."""
from collections.abc import Iterable
from typing import TypedDict

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .bound import Bound
from .halfedge import HalfEdgeMesh
from .kernel import Kernel

class Records:
    """The collapse sequence of an EdgeCollapser (``record=True``)."""

    def __init__(self, n: int, n_attr: int, on: bool) -> None: ...
    def rows(self, n: int) -> dict[str, NDArray]:
        """The first n records as a dict of arrays (copies)."""

class _Plan(TypedDict):
    """What :meth:`lodkit._core.passes.PassCollapser.plan_all` returns: one row per edge that may
    collapse."""

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
    fields.pxd: merge max 0, min 1, sum 2, keep 3, mean 4; value max 0, min 1, sum 2,
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
    def __init__(
        self,
        hm: HalfEdgeMesh,
        positions: ArrayLike | None,
        quadrics: ArrayLike,
        attributes: ArrayLike | None,
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
        vertex_fields: ArrayLike | None = ...,
        vertex_rules: ArrayLike | None = ...,
        edge_fields: ArrayLike | None = ...,
        edge_rules: ArrayLike | None = ...,
        kernels: Iterable[Kernel] = ...,
        use_heap: bool = ...,
        attribute_quadrics: ArrayLike | None = ...,
        attribute_columns: ArrayLike | None = ...,
        steps: ArrayLike | None = ...,
        seam_partners: ArrayLike | None = ...,
        error_bound: tuple[float, float] | None = ...,
        threads: int = ...,
        input_normals: NDArray[np.int16] | None = ...,
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
        stays (see lodkit._pipeline.seam_partners); error_bound (eps, spacing): the two-sided
        error bound (lodkit._core.bound), None when off; input_normals (3 m,) int16: the
        input faces' normals as ``vertex_quadrics(normals=)`` made them (else computed
        here)."""
    bound: Bound | None
    def count_bound_refusals(self) -> int:
        """Live candidates that pass every check but the error bound (0 without one)."""
    def allow_knives(self) -> None:
        """Switch the knife test off (a collapse may join the two flat sides of a sheet); the next run() rescans."""
    @property
    def knife_test(self) -> bool:
        """Is the knife test on?"""
    def allow_end_fallback(self) -> None:
        """Let refused candidates collapse at an end or the midpoint of their edge from the next run on."""
    def refusal_census(self) -> dict[str, int]:
        """Why each live candidate may not collapse: counts by the check that refuses it."""
    def certified_bound(self) -> float | None:
        """The largest certificate of a live face (normalised units), None without a bound."""
    def _setup_seams(self, partners: ArrayLike | None) -> None: ...
    def _input_faces(self, threads: int, closed: bool) -> None:
        """The input faces' int16 unit normals and (``closed``) the enclosed volume, in one
        pass over the faces on ``threads``."""
    def run(self, target_faces: int, max_steps: int = ...) -> int:
        """0: target reached, 1: step budget used, 2: no legal collapse left, 3: a kernel failed."""
    def relax_quality(self, min_quality: float) -> None:
        """Lower the quality limit; the next run() gives every live candidate another chance."""
    def collapse_pass(self, edges: ArrayLike, positions: ArrayLike | None = ..., target_faces: int = ...) -> int:
        """Collapse, in the order given, the edges no earlier collapse of this pass touched;
        the number of collapses, or -1 if a kernel failed.  Here: RuntimeError (the pass
        driver is :class:`lodkit._core.passes.PassCollapser`)."""
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
    def plan_edge(self, u: int, v: int) -> tuple[int, int, NDArray[np.float64], float, float] | None:
        """(removed, kept, position, cost, error) for edge (u, v), or None."""
    def plan_face(self, f: int) -> tuple[int, int, int, NDArray[np.float64], float, float] | None:
        """Triangle collapse only (:class:`lodkit._core.triangle.TriangleCollapser`): here
        RuntimeError."""
    def check_face(self, f: int) -> bool:
        """Triangle collapse only: here RuntimeError."""
    @property
    def n_tri_collapses(self) -> int:
        """Triangle collapses done (0 here)."""
    @property
    def n_tri_refused_second(self) -> int:
        """Triangle candidates refused at the second collapse's checks (0 here)."""
    @property
    def n_alive_faces(self) -> int: ...
    @property
    def seam_partners(self) -> NDArray[np.intc] | None:
        """Each slot's seam partner (-1 none, -2 stays) as used, or None without seams."""
    @property
    def n_seam_fixed(self) -> int:
        """Seam slots that may neither move nor go (seam ends, -2 copies, pairs with a fixed copy)."""
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
