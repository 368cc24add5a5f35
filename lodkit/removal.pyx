# cython: language_level=3
"""Base class of vertex-removal kernels (``lodkit.removal``): see removal.pxd for the contract."""
from libc.string cimport strncpy
from lodkit.kernel cimport KERNEL_OK, KERNEL_VETO, KERNEL_ERROR

API_VERSION = REMOVAL_API_VERSION
MAX_STAR = MAX_VALENCE


cdef class RemovalKernel:
    """A vertex-removal metric's native part.  The default ``evaluate`` vetoes every
    removal (a subclass must override it)."""

    api_version = REMOVAL_API_VERSION
    # optional hook: True when evaluate() depends on the star alone (the driver caches it)
    star_local = False

    def __cinit__(self):
        self.gated = False
        self.failed = False
        self._message[0] = 0

    def prepare(self, ctx, options):
        """Called once, with the GIL, before the run: allocate and fill what the nogil
        methods need.  ``options`` is the metric's validated options (a dict)."""
        pass

    cdef int evaluate(self, const Star* s, Removal* r) noexcept nogil:
        return KERNEL_VETO

    cdef int commit(self, const Star* s, const Removal* r) noexcept nogil:
        return KERNEL_OK

    cdef int fail(self, const char* message) noexcept nogil:
        """Record ``message`` (truncated to 255 bytes) and return KERNEL_ERROR."""
        if not self.failed:
            strncpy(self._message, message, 255)
            self._message[255] = 0
            self.failed = True
        return KERNEL_ERROR

    @property
    def message(self):
        """The message given to ``fail`` (empty if it was never called)."""
        return (<bytes>self._message).decode("utf-8", "replace")

    cpdef str veto_note(self):
        """Why the kernel held vertices back, in words, appended to a run's stop_detail when
        it vetoed some ('' by default: nothing is appended)."""
        return ""
