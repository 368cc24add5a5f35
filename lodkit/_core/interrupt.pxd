# cython: language_level=3
"""Ctrl-C inside the nogil loops of the drivers (docs/reliability.md, "Interrupts").

A loop calls ``signal_pending()`` every ``INTERRUPT_EVERY`` operations (a few milliseconds
of work): it takes the GIL for a moment and runs Python's signal handlers
(``PyErr_CheckSignals``; outside the main thread that does nothing).  When a handler raised
(KeyboardInterrupt), its exception stays set, ``signal_pending()`` is True and the loop
returns ``RUN_INTERRUPTED`` at once, leaving its driver unusable (the run is abandoned: the
driver works on its own copies, so the caller's arrays are untouched).  The ``def`` wrapper
then calls ``raise_pending()``, which raises that exception.  Nothing to build."""

cdef extern from "Python.h":
    # declared without an exception value: the exception it sets is raised later, by
    # raise_pending(), outside the nogil block
    int _lodkit_check_signals "PyErr_CheckSignals"() noexcept


cdef enum:
    INTERRUPT_EVERY = 4096     # operations between two checks (a power of two)


cdef inline bint signal_pending() noexcept nogil:
    """Run the signal handlers; True if one raised (its exception is set)."""
    cdef int rc
    with gil:
        rc = _lodkit_check_signals()
    return rc != 0


cdef inline int raise_pending() except -1:
    """Raise the exception a signal handler left set (call with the GIL, after a loop
    returned RUN_INTERRUPTED)."""
    return -1
