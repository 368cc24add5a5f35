"""``edge_length``: a lodkit batch metric that makes long edges dear to collapse.

    cost = cost_so_far + weight * (length / mean_length) ** exponent

``length`` is the edge's current length and ``mean_length`` the mean edge length of the
input (both in lodkit's normalised units, so the ratio is scale-free).  Alone it
collapses the shortest edges first; added to ``qem`` it evens out edge lengths.
"""
from __future__ import annotations

import numpy as np

from lodkit import OptionError
from lodkit.metrics import Batch, BatchMetric, MetricContext, Option

__all__ = ["EdgeLength"]
__version__ = "0.1.0"


class EdgeLength(BatchMetric):
    """Edge length relative to the input's mean edge length, raised to ``exponent``."""

    description = "edge length / input mean edge length, to a power (short edges go first)"
    options = {
        "exponent": Option(2.0, doc="power of the length ratio (> 0); larger is stricter on long edges"),
    }

    def validate_options(self, given: dict) -> dict:
        params = super().validate_options(given)
        if not params["exponent"] > 0.0:
            raise OptionError(f"metric {self.name!r}: option 'exponent' must be a number > 0, "
                              f"got {given['exponent']!r}")
        return params

    def prepare(self, ctx: MetricContext) -> None:
        edges = ctx.edges
        d = ctx.positions[edges[:, 0]] - ctx.positions[edges[:, 1]]
        lengths = np.sqrt(np.einsum("ij,ij->i", d, d))
        mean = float(lengths.mean()) if lengths.size else 0.0
        # a mesh whose edges all have length 0 has nothing to compare with: use the unit
        # (the bbox diagonal) rather than divide by zero
        self.mean_length = mean if mean > 0.0 else 1.0

    def costs(self, batch: Batch) -> np.ndarray:
        ratio = batch.length / self.mean_length
        return batch.cost + self.weight * ratio ** self.params["exponent"]
