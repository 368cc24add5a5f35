"""Type stubs for lodkit._core.fields (Cython)."""

import numpy as np
from numpy.typing import ArrayLike, NDArray

class FieldSet:
    """Vertex and edge fields with their (k, 5) rules (merge, value, mode, weight, offset)
    and the (kind, first, end) steps ordering fields and kernels."""

    n_vfields: int
    n_efields: int
    n_steps: int
    def __init__(
        self,
        n_vertices: int,
        n_edges: int,
        vertex_fields: ArrayLike | None = ...,
        vertex_rules: ArrayLike | None = ...,
        edge_fields: ArrayLike | None = ...,
        edge_rules: ArrayLike | None = ...,
        steps: ArrayLike | None = ...,
        n_kernels: int = ...,
    ) -> None: ...
    @property
    def vertex_values(self) -> NDArray[np.float64]:
        """(n, k) current vertex fields (merged on collapse)."""
    @property
    def edge_values(self) -> NDArray[np.float64]:
        """(n_edges, k) current edge fields (merged on collapse)."""
