"""Type stubs for lodkit._core.testkernels (Cython): small kernels for tests and examples."""
from typing import Any, ClassVar

from .kernel import Kernel
from .removal import RemovalKernel

class VetoAll(Kernel):
    """Refuses every collapse (``cost`` returns VETO)."""

    api_version: ClassVar[int]

class FailAfter(Kernel):
    """Reports an error from nogil code once ``options['n']`` cost calls are spent."""

    api_version: ClassVar[int]
    def prepare(self, ctx: Any, options: dict[str, Any]) -> None:
        """Reads ``n`` (default 0) and resets the call count."""

class MidpointPlacer(Kernel):
    """Places the kept vertex at the midpoint of the edge (sets ``places``)."""

    api_version: ClassVar[int]
    def prepare(self, ctx: Any, options: dict[str, Any]) -> None: ...

class ScaleBy(Kernel):
    """Multiplies the cost so far by ``options['factor']`` and counts its calls."""

    api_version: ClassVar[int]
    @property
    def n_cost(self) -> int:
        """Calls of ``cost`` since ``prepare``."""
    @property
    def n_commit(self) -> int:
        """Calls of ``commit`` since ``prepare``."""
    def prepare(self, ctx: Any, options: dict[str, Any]) -> None:
        """Reads ``factor`` (default 1.0) and resets the counters."""

class CommitVeto(Kernel):
    """Wrongly answers KERNEL_VETO from ``commit`` (a contract error: the run fails)."""

    api_version: ClassVar[int]

class PlaneFan(RemovalKernel):
    """Vertex removal: cost = error = distance to the star's average plane (boundary vertex:
    to the new boundary edge's line); the hole filled
    by the fan from the closest-line apex.  Options gate ((n,) floats: gated), veto ((n,)
    bools), fail_after (int)."""

    @property
    def n_evaluate(self) -> int:
        """Calls of ``evaluate`` since ``prepare``."""
    @property
    def n_commit(self) -> int:
        """Calls of ``commit`` since ``prepare``."""
    def prepare(self, ctx: Any, options: dict[str, Any]) -> None:
        """Reads gate, veto and fail_after."""
