"""Type stubs for lodkit._core.curvature_kernel (Cython): the native kernel of the
``curvature`` metric (Wang et al. 2011, eq. 6)."""
from typing import Any, ClassVar

import numpy as np

from ..kernel import Kernel

#: ``mode`` codes: replace the cost with weight * omega, or scale the cost so far
MODE_REPLACE: int
MODE_SCALE: int
#: ``merge`` codes: the kept vertex's curvature after a collapse
MERGE_MAX: int
MERGE_MEAN: int

class CurvatureKernel(Kernel):
    """Edge weight omega = l * (floor + (w_u + w_v) / 2) from per-vertex normalised
    curvature w; the kept vertex's w becomes the max (or mean) of the two ends'."""

    api_version: ClassVar[int]
    @property
    def floor(self) -> float:
        """Added to the mean curvature of an edge's ends."""
    @property
    def weight(self) -> float:
        """Factor of omega (mode replace) or of the curvature term (mode scale)."""
    @property
    def mode(self) -> int:
        """MODE_REPLACE or MODE_SCALE."""
    @property
    def merge(self) -> int:
        """MERGE_MAX or MERGE_MEAN."""
    @property
    def curvature(self) -> np.ndarray:
        """(n,) float64 copy of the current normalised curvature of every vertex slot."""
    def prepare(self, ctx: Any, options: dict[str, Any]) -> None:
        """Take ``options["curvature"]`` ((n,) normalised curvature, finite, >= 0) and the
        options floor, weight, mode ("replace"/"scale"), merge ("max"/"mean"), midpoint."""
