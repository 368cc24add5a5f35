"""``max_edge_length``: a native lodkit metric that keeps edges shorter than a limit.

A collapse moves the kept vertex to ``p`` and joins it to the 1-rings of both ends of the
edge.  If any of those new edges would be longer than ``max_length`` the collapse is
vetoed; otherwise the cost so far is scaled:

    cost = cost_so_far * (1 + weight * (longest_new_edge / max_length) ** 2)

``max_length`` is a fraction of the input's bounding-box diagonal (lodkit's normalised
units).  The work is done by :class:`lodkit_max_edge._kernel.MaxEdgeKernel`, a Cython
``cdef class`` run by lodkit's core without the GIL.
"""
from __future__ import annotations

from lodkit import OptionError
from lodkit.metrics import KernelMetric, Option

from ._kernel import MaxEdgeKernel

__all__ = ["MaxEdgeLength", "MaxEdgeKernel"]
__version__ = "0.1.0"


class MaxEdgeLength(KernelMetric):
    """Veto collapses that would create an edge longer than ``max_length``."""

    description = "veto collapses making an edge longer than max_length (fraction of the bbox diagonal)"
    kernel = MaxEdgeKernel
    options = {
        "max_length": Option(0.05, doc="longest edge a collapse may create, as a fraction of the "
                                       "bbox diagonal (> 0)"),
    }

    def validate_options(self, given: dict) -> dict:
        params = super().validate_options(given)
        if not params["max_length"] > 0.0:
            raise OptionError(f"metric {self.name!r}: option 'max_length' must be a number > 0, "
                              f"got {given['max_length']!r}")
        return params
