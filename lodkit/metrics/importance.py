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

    def __init__(self, **options):
        super().__init__(**options)
        # checked here, when the metric is made, before any work (simplify, compare, lods)
        if self.params["values"] is None:
            raise OptionError("metric 'importance' needs values=: one importance >= 0 per input vertex, "
                              "e.g. ('importance', {'values': heights}) (an array; the command line "
                              "cannot give one)")
        if self.params["values"].ndim != 1:
            raise OptionError(f"metric 'importance': values must be one number per input vertex "
                              f"(a 1-D array), got shape {self.params['values'].shape}")
        if (self.params["values"] < 0).any():
            raise OptionError("metric 'importance': values must be >= 0")

    def values(self, ctx: MetricContext) -> np.ndarray:
        vals = self.params["values"]
        n_in = ctx.mesh.n_vertices
        if vals.shape != (n_in,):
            raise OptionError(f"metric 'importance': values must have shape ({n_in},), got {vals.shape}")
        if (vals < 0).any():
            raise OptionError("metric 'importance': values must be >= 0")
        return vals[ctx.input_vertex]
