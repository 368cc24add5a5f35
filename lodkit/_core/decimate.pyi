"""Type stubs for lodkit._core.decimate (Cython): the edge-collapse drivers' entry point."""
from collections.abc import Iterable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .edge import EdgeCollapser as _EdgeCollapser
from .halfedge import HalfEdgeMesh
from .kernel import Kernel
from .quadric import add_boundary_planes as add_boundary_planes
from .quadric import face_unit_normals as face_unit_normals
from .quadric import general_quadric_marginal as general_quadric_marginal
from .quadric import vertex_quadrics as vertex_quadrics

def EdgeCollapser(
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
    operator: int = ...,
    error_bound: tuple[float, float] | None = ...,
    threads: int = ...,
    input_normals: NDArray[np.int16] | None = ...,
) -> _EdgeCollapser:
    """The edge-collapse driver for these arguments: operator 0 with use_heap True
    :class:`lodkit._core.edge.EdgeCollapser`, with use_heap False
    :class:`lodkit._core.passes.PassCollapser`, operator 1
    :class:`lodkit._core.triangle.TriangleCollapser` (quadric metrics only).  The other
    arguments: :class:`lodkit._core.edge.EdgeCollapser`."""
