# cython: language_level=3
"""The native metric interface (``lodkit.kernel``): see kernel.pxd for the contract."""
from libc.string cimport strncpy

API_VERSION = KERNEL_API_VERSION
OK = KERNEL_OK
VETO = KERNEL_VETO
ERROR = KERNEL_ERROR


cdef class Kernel:
    """Base class of native (Cython) metrics.  The defaults leave the candidate as it is."""

    api_version = KERNEL_API_VERSION

    def __cinit__(self):
        self.places = False
        self.wide = False
        self.changed = NULL
        self.n_changed = -1
        self.failed = False
        self._message[0] = 0

    def prepare(self, ctx, options):
        """Called once, with the GIL, before the run: allocate and fill what the nogil
        methods need.  ``options`` is the metric's validated options (a dict)."""
        pass

    cdef int place(self, Candidate* c) noexcept nogil:
        return KERNEL_OK

    cdef int cost(self, Candidate* c) noexcept nogil:
        return KERNEL_OK

    cdef int commit(self, const Candidate* c) noexcept nogil:
        return KERNEL_OK

    cdef int fail(self, const char* message) noexcept nogil:
        """Record ``message`` (truncated to 255 bytes) and return KERNEL_ERROR."""
        if not self.failed:
            strncpy(self._message, message, KERNEL_MESSAGE_SIZE - 1)
            self._message[KERNEL_MESSAGE_SIZE - 1] = 0
            self.failed = True
        return KERNEL_ERROR

    @property
    def message(self):
        """The message given to ``fail`` (empty if it was never called)."""
        return (<bytes>self._message).decode("utf-8", "replace")

    # for tests: drive a kernel by hand on a bare candidate
    def _call(self, str which, int u, int v, int removed, int kept, p, double cost):
        cdef Candidate c
        cdef double pos[3]
        pos[0], pos[1], pos[2] = p[0], p[1], p[2]
        fill_candidate(&c, NULL, -1, -1, u, v, removed, kept, pos, cost, 0.0)
        cdef int rc
        if which == "place":
            rc = self.place(&c)
        elif which == "cost":
            rc = self.cost(&c)
        elif which == "commit":
            rc = self.commit(&c)
        else:
            raise ValueError(which)
        return rc, c.cost, (c.p[0], c.p[1], c.p[2]), c.removed, c.kept
