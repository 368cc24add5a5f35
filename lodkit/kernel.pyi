"""Type stubs for lodkit.kernel (Cython): the native metric interface, see lodkit/kernel.pxd.

The C-level part (``Candidate``, ``KernelMesh``, the nogil ``place``/``cost``/``commit``
methods, ``fail``) is only reachable from Cython through ``cimport``; these are the names
Python sees.
"""
from collections.abc import Sequence
from typing import Any, ClassVar, Literal

#: The kernel API version this lodkit was built with (KERNEL_API_VERSION in kernel.pxd).
API_VERSION: int
#: Return codes of place / cost / commit.
OK: int
VETO: int
ERROR: int

class Kernel:
    """Base class of native (Cython) metrics.  The defaults leave the candidate as it is.

    A subclass states the API it was compiled against with ``api_version = KERNEL_API_VERSION``
    in its class body; lodkit refuses a kernel whose version differs.
    """

    api_version: ClassVar[int]
    @property
    def places(self) -> bool:
        """True: the driver calls ``place()`` (set by the kernel in ``prepare``)."""
    @property
    def wide(self) -> bool:
        """True: the kernel's cost of an edge depends on the stars of its ends; after a
        collapse the driver re-ranks the edges around every neighbour of the kept vertex."""
    @property
    def failed(self) -> bool:
        """True once ``fail()`` was called (the run stops with MetricError)."""
    def prepare(self, ctx: Any, options: dict[str, Any]) -> None:
        """Called once, with the GIL, before the run; ``ctx`` is a lodkit.metrics.MetricContext,
        ``options`` the metric's validated options."""
    @property
    def message(self) -> str:
        """The message given to ``fail`` ('' if it was never called)."""
    def _call(
        self,
        which: Literal["place", "cost", "commit"],
        u: int,
        v: int,
        removed: int,
        kept: int,
        p: Sequence[float],
        cost: float,
    ) -> tuple[int, float, tuple[float, float, float], int, int]:
        """Drive one method by hand on a bare candidate (no mesh): returns
        ``(status, cost, position, removed, kept)`` after the call.  For tests."""
