"""Type stubs for lodkit.removal (Cython): the base class of vertex-removal kernels
(the C interface is lodkit/removal.pxd)."""
from typing import Any, ClassVar

#: the version of the removal-kernel interface (removal.pxd) this lodkit was built with
API_VERSION: int
#: the largest star (number of link vertices) the driver hands a kernel
MAX_STAR: int

class RemovalKernel:
    """A vertex-removal metric's native part; ``evaluate`` and ``commit`` are nogil C
    methods (removal.pxd).  The default ``evaluate`` vetoes every removal."""

    api_version: ClassVar[int]
    #: optional hook: True when ``evaluate`` depends on the star alone (the driver caches it)
    star_local: ClassVar[bool]
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
    def veto_note(self) -> str:
        """Optional hook: why vetoed vertices were held back, in words ('' by default)."""
