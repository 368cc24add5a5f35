"""Type stubs for lodkit._core.chain (Cython): the driver's chain of kernels (chain.pxd)."""
from collections.abc import Iterable

from ..kernel import Kernel

class KernelChain:
    """One node of a chain of kernels: ``kernel`` and the node after it (``next``)."""

    def __init__(self, kernel: Kernel, next: KernelChain | None = None) -> None: ...
    @property
    def kernel(self) -> Kernel:
        """This node's kernel."""
    @property
    def next(self) -> KernelChain | None:
        """The following node (None at the end)."""
    def kernels(self) -> list[Kernel]:
        """The kernels from this node on, in order."""

def make_chain(kernels: Iterable[Kernel]) -> KernelChain | None:
    """The chain of ``kernels`` in order, or None for none (TypeError for a non-Kernel)."""
