"""Type stubs for lodkit._core.volume_kernel (Cython): the native kernel of the ``volume``
metric (Chuon & Guha: vol(V) = angle(V) * ht(V)^3, hyperbolic vertices kept, closest-line
fan re-triangulation)."""
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np

from ..removal import RemovalKernel

#: classification codes of a star
DEGENERATE: int
NON_HYPERBOLIC: int
HYPERBOLIC: int
#: the ``accumulate`` option's values: "off" (the paper), "bound", "points" (lodkit's default)
ACCUMULATE_MODES: tuple[str, ...]
#: the ``hyperbolic`` option's values besides "auto": "veto" (the paper), "remove"
HYPERBOLIC_MODES: tuple[str, ...]
#: the ``triangulation`` option's values besides "auto": "closest_line" (the paper), "nearest"
TRIANGULATION_MODES: tuple[str, ...]

class VolumeKernel(RemovalKernel):
    """Removal cost vol(V) = angle * ht^3, gate angle(V) (the median filter), error ht(V);
    hyperbolic and degenerate stars are vetoed."""

    api_version: ClassVar[int]
    star_local: ClassVar[bool]
    @property
    def tolerance(self) -> float:
        """Angle (radians) within which a neighbour counts as on a plane through V."""
    @property
    def n_hyperbolic(self) -> int:
        """Live vertex slots that were hyperbolic at their last evaluation."""
    @property
    def n_degenerate(self) -> int:
        """Live vertex slots vetoed at their last evaluation because their star was degenerate
        (a neighbour at V, or every neighbour on one line through V)."""
    @property
    def fallback(self) -> bool:
        """True: when the closest-line fan folds over, the next-closest lines' apexes are tried."""
    @property
    def n_fallbacks(self) -> int:
        """Evaluations that took another apex than the closest line's (fallback)."""
    @property
    def hyperbolic_code(self) -> int:
        """Index of the resolved ``hyperbolic`` option in HYPERBOLIC_MODES (0 veto, 1 remove)."""
    @property
    def triangulation_code(self) -> int:
        """Index of the resolved ``triangulation`` option in TRIANGULATION_MODES (0
        closest_line, 1 nearest)."""
    @property
    def accumulate_code(self) -> int:
        """Index of the ``accumulate`` option in ACCUMULATE_MODES (0 off, 1 bound, 2 points)."""
    def accumulated(self) -> np.ndarray:
        """(n,) float64: the distance bound each vertex slot carries from the removals
        around it (normalised units; zeros with ``accumulate="off"``)."""
    def veto_note(self) -> str:
        """Why the kernel holds vertices back now, in words (appended to a run's stop_detail)."""
    def prepare(self, ctx: Any, options: dict[str, Any]) -> None:
        """Options ``median`` (bool, or None: gated only when ``accumulate`` is "off"),
        ``tolerance`` (radians in [0, 0.1), default 1e-9), ``fallback`` (bool, default
        True), ``accumulate`` ("points", the default, "bound" or "off"), ``hyperbolic``
        ("auto", "veto", "remove") and ``triangulation`` ("auto", "closest_line",
        "nearest"; "auto": the paper's with accumulate="off", else lodkit's);
        ``ctx.n_vertices`` / ``ctx.halfedge`` (or ``options["n_vertices"]`` /
        ``options["n_faces"]`` without a context) size the per-vertex marks, bounds and
        the per-face lists of carried vertices."""
    def hyperbolic_mask(self) -> np.ndarray:
        """(n,) bool: the vertex slots hyperbolic at their last evaluation (not removed)."""

def solid_angle(a: Sequence[float], b: Sequence[float], c: Sequence[float]) -> float:
    """Signed solid angle at the origin of the triangle (a, b, c) (Van Oosterom-Strackee
    with atan2); positive when (a, b, c) runs counter-clockwise seen from the origin."""

def hyperbolic_witness(center: Sequence[float], neighbours: Any, closed: bool = True,
                       tolerance: float = 1e-9) -> bool:
    """True if the quick tetrahedron certificate settled the star as hyperbolic."""
    ...
def measure(center: Sequence[float], neighbours: Any, closed: bool = True,
            tolerance: float = 1e-9) -> dict[str, Any]:
    """Classify and measure a star: ``class``, ``on_hull``, ``angle``, ``height``,
    ``volume``, ``pole``, ``margin``."""

def evaluate_star(positions: Any, v: int, link: Any, closed: bool = True, fixed: Any | None = None,
                  median: bool = True, tolerance: float = 1e-9, fallback: bool = True,
                  accumulate: str = "points", hyperbolic: str = "auto",
                  triangulation: str = "auto") -> dict[str, Any]:
    """``VolumeKernel.evaluate`` on one star of a point set: ``status`` ("ok", "veto",
    "error"), ``cost``, ``error``, ``gate``, ``tris`` ((k-2, 3) indices into ``link``) and
    ``hyperbolic``; ``accumulate``, ``hyperbolic`` and ``triangulation`` as the metric's
    options ("points": the larger of V's and its star faces' centroids' distance to the patch
    and min(ht, V's distance to the closest line); "bound": the larger of ht and V's distance
    to the patch; "off": the paper's ht)."""
