"""User-painted importance: a per-vertex field that makes collapses near important vertices dearer."""
from __future__ import annotations

import numpy as np

from ..errors import OptionError
from .base import FieldMetric, MetricContext, Option


class Importance(FieldMetric):
    """Per-vertex importance given by the caller (one value >= 0 per input vertex).

    With the defaults an edge costs ``cost * (1 + weight * max(importance of its ends))``,
    and the kept vertex keeps the larger importance of the two, so an important region
    stays dear as it shrinks.
    """

    description = "caller-given per-vertex importance (scales the cost)"
    options = {
        "values": Option(None, kind="array", allow_none=True,
                         doc="(n_input_vertices,) importance >= 0 of each input vertex"),
    }

    def check_ready(self) -> None:
        """Before any work (simplify, compare): values= must be given."""
        if self.params["values"] is None:
            raise OptionError("metric 'importance' needs values=: one importance per input vertex "
                              "(an array, e.g. ('importance', {'values': heights}); the command line "
                              "cannot give one)")

    def values(self, ctx: MetricContext) -> np.ndarray:
        vals = self.params["values"]
        if vals is None:
            raise OptionError("metric 'importance' needs values=: one importance per input vertex")
        n_in = ctx.mesh.n_vertices
        if vals.shape != (n_in,):
            raise OptionError(f"metric 'importance': values must have shape ({n_in},), got {vals.shape}")
        if (vals < 0).any():
            raise OptionError("metric 'importance': values must be >= 0")
        return vals[ctx.input_vertex]
