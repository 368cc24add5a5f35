"""Type stubs for lodkit._core.vremove (Cython): the vertex-removal driver."""
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..removal import RemovalKernel
from .halfedge import HalfEdgeMesh

#: run() statuses: face target reached, step budget spent, no valid removal left, kernel failed
RUN_TARGET: int
RUN_CHUNK: int
RUN_EXHAUSTED: int
RUN_ERROR: int
#: names of the per-vertex state codes (VertexRemover.states): why a vertex is not removed
STATE_NAMES: tuple[str, ...]

class MedianFilter:
    """The lower median of a changing set of (id, value) pairs, kept by two indexed heaps
    (the smaller half in a max-heap, the larger in a min-heap); O(log n) per change."""

    capacity: int
    def __init__(self, capacity: int) -> None: ...
    def set(self, cid: int, value: float) -> None:
        """Insert ``cid`` with ``value`` or change its value; NaN removes it."""
    def remove(self, cid: int) -> None:
        """Remove ``cid`` (absent ids are ignored)."""
    def median(self) -> float | None:
        """The ceil(n/2)-th smallest value; None when empty."""
    def band(self, a: float, b: float) -> NDArray[np.intc]:
        """Sorted ids whose value v has a <= v < b."""
    def _check_id(self, cid: int) -> None: ...
    def check(self) -> bool:
        """Verify the two halves (for tests); raises AssertionError."""
    def __len__(self) -> int: ...
    def __contains__(self, cid: object) -> bool: ...

class RemovalRecords:
    """The removal sequence of a VertexRemover (record=True)."""

    def __init__(self, n: int, on: bool) -> None: ...
    def grow(self, cap: int, n_done: int) -> None:
        """Make room for cap link entries, keeping the n_done removals written."""
    def rows(self, r: int) -> dict[str, Any]:
        """The first r removals as a dict of arrays."""

class VertexRemover:
    """Greedy vertex removal over a HalfEdgeMesh (modified in place); see the module doc."""

    gated: bool
    n_collapses: int
    max_error_done: float
    failed: bool
    star_local: bool        # the kernel's star_local: popped candidates come from a cache
    n_evaluations: int      # kernel evaluate() calls over the run
    n_rescans: int          # full rescans of every vertex slot (the one at the start included)
    n_seam_pairs: int       # attribute-seam copies removed together with their partner
    def __init__(self, hm: HalfEdgeMesh, positions: ArrayLike, kernel: RemovalKernel, fixed: ArrayLike,
                 boundary: int = 1, max_normal_angle: float = 90.0, min_quality: float = 0.0,
                 max_error: float = ..., record: bool = False, closed_connected: bool = False,
                 weld: tuple[ArrayLike, ArrayLike] | None = None, seams: ArrayLike | None = None) -> None: ...
    def _alloc_records(self, cap: int) -> None: ...
    def run(self, target_faces: int, max_steps: int = ...) -> int:
        """Remove vertices until target_faces live faces remain, max_steps removals are done
        or none is valid; returns a RUN_* status."""
    @property
    def error_message(self) -> str: ...
    @property
    def n_alive_faces(self) -> int: ...
    @property
    def median(self) -> float | None:
        """Gated kernels: the current median gate of the candidates."""
    @property
    def states(self) -> NDArray[np.uint8]:
        """(n,) state code per vertex slot (STATE_NAMES)."""
    @property
    def refusals(self) -> dict[str, int]:
        """Refusal events over the run, by reason."""
    @property
    def held_back(self) -> dict[str, int]:
        """Live vertices that are no candidate now, by reason."""
    @property
    def n_vetoed(self) -> int: ...
    @property
    def n_rejected_error(self) -> int: ...
    @property
    def n_candidates(self) -> int: ...
    def records(self) -> dict[str, Any]:
        """The removal sequence in vertex slots (removed, closed, offsets, link, triangles,
        cost, error); needs record=True."""
    def evaluate_vertex(self, v: int) -> tuple[str, Any, Any, Any, Any]:
        """(state, cost, error, gate, triangles) of the kernel's answer for v now."""
