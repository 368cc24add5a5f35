"""Type stubs for lodkit._core.qem_kernel (Cython): QEM as a native kernel (``qem_native``)."""
from typing import Any, ClassVar

from ..kernel import Kernel

class QEMKernel(Kernel):
    """Area-weighted plane quadrics (plus the 'preserve' boundary planes), summed on collapse
    and evaluated at the position the core chose: the same cost as the ``qem`` metric."""

    api_version: ClassVar[int]
    def prepare(self, ctx: Any, options: dict[str, Any]) -> None:
        """Copy the run's face quadrics (and add the boundary planes under 'preserve')."""
