"""Type stubs for lodkit._core.melod_kernel (Cython): the native kernel of the ``melod``
metric (Hussain et al.: vertex visual importance, half-edge collapse, cost accumulation)."""
from typing import Any, ClassVar

import numpy as np

from ..kernel import Kernel

class MELODKernel(Kernel):
    """Half-edge key w_o * max(sum Q_t, acc_o) + boundary term, re-costed over the stars
    that each collapse changes (docs/metrics/melod.md)."""

    api_version: ClassVar[int]
    n_spilled: int
    """Costs kept in the spill table during the run (the table is rarely needed; for tests)."""
    def prepare(self, ctx: Any, options: dict[str, Any]) -> None:
        """Visual importance of every vertex slot, the per-face and per-half-edge bits (no
        cost is computed before the driver asks)."""
    def importance_values(self) -> np.ndarray:
        """The current visual importance of every vertex slot."""
    @property
    def accumulated(self) -> np.ndarray:
        """The current accumulated cost of every vertex slot."""

def visual_importance(positions: Any, faces: Any, n: int) -> np.ndarray:
    """w_v = 1 - |sum A_i n_i / sum A_i| over the faces around each vertex (0 for a vertex
    without faces of positive area)."""
