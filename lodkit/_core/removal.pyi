"""Type stubs for lodkit._core.removal (Cython): the base class of vertex-removal kernels
(the C interface is removal.pxd)."""
from typing import Any, ClassVar

#: the version of the removal-kernel interface (removal.pxd) this lodkit was built with
API_VERSION: int
#: the largest star (number of link vertices) the driver hands a kernel
MAX_STAR: int

class RemovalKernel:
    """A vertex-removal metric's native part; ``evaluate`` and ``commit`` are nogil C
    methods (removal.pxd).  The default ``evaluate`` vetoes every removal."""

    api_version: ClassVar[int]
    @property
    def gated(self) -> bool:
        """True: only vertices whose gate >= the median gate compete (Chuon-Guha)."""
    @property
    def failed(self) -> bool:
        """True once ``fail`` was called."""
    @property
    def message(self) -> str:
        """The message given to ``fail`` (empty if it was never called)."""
    def prepare(self, ctx: Any, options: dict[str, Any]) -> None:
        """Called once, with the GIL, before the run."""
