"""Type stubs for lodkit._core.schroeder_kernel (Cython): the native kernel of the
``schroeder`` metric (Schroeder, Zarge & Lorensen 1992 vertex decimation)."""
from typing import Any, ClassVar, TypedDict

import numpy as np

from ..removal import RemovalKernel

#: vertex classes (codes of ``evaluate_star(...)["cls"]``)
SIMPLE: int
COMPLEX: int
BOUNDARY: int
INTERIOR_EDGE: int
CORNER: int
#: class code -> name: "simple", "complex", "boundary", "interior_edge", "corner"
CLASS_NAMES: tuple[str, ...]
#: feature angle in degrees (vtkDecimate's InitialFeatureAngle)
DEFAULT_FEATURE_ANGLE: float
#: smallest aspect ratio of a loop split (vtkDecimate's 1 / AspectRatio = 1/25)
DEFAULT_MIN_ASPECT: float
#: the ``accumulate`` option's values: "off" (the paper), "bound", "points" (lodkit's default)
ACCUMULATE_MODES: tuple[str, ...]
#: the ``triangulation`` option's values besides "auto": "split" (the paper), "nearest"
TRIANGULATION_MODES: tuple[str, ...]

class _StarEvaluation(TypedDict):
    cls: int
    name: str
    features: tuple[int, int] | None
    vetoed: bool
    error: float | None
    cost: float | None
    triangles: np.ndarray | None

class SchroederKernel(RemovalKernel):
    """Classifies each star, costs a removal by the distance to the average plane (simple
    vertices) or to the new boundary / feature edge, fills the hole by recursive loop
    splitting; vetoes corners (unless ``remove_corners``), complex stars and holes with no
    valid triangulation."""

    api_version: ClassVar[int]
    star_local: ClassVar[bool]
    @property
    def feature_angle(self) -> float:
        """Degrees: a feature edge's faces' normals differ by more."""
    @property
    def cos_feature(self) -> float:
        """cos(feature_angle)."""
    @property
    def min_aspect(self) -> float:
        """Smallest accepted aspect ratio of a loop split."""
    @property
    def remove_corners(self) -> bool:
        """True: corner vertices may go too."""
    @property
    def triangulation_code(self) -> int:
        """Index of the resolved ``triangulation`` option in TRIANGULATION_MODES (0 split,
        1 nearest)."""
    @property
    def accumulate_code(self) -> int:
        """Index of the ``accumulate`` option in ACCUMULATE_MODES (0 off, 1 bound, 2 points)."""
    def prepare(self, ctx: Any, options: dict[str, Any]) -> None:
        """Take ``feature_angle`` (degrees, [0, 180]), ``min_aspect`` (>= 0),
        ``remove_corners`` (None: True unless accumulate is "off") and ``accumulate`` ("points", "bound"
        or "off") from ``options``; missing
        ones keep the defaults.  ``ctx.n_vertices`` (or ``options["n_vertices"]``) sizes the
        per-vertex bounds (0: nothing is carried)."""
    def accumulated(self) -> np.ndarray:
        """(n,) float64: the distance bound each vertex slot carries from the removals
        around it (normalised units; zeros with ``accumulate="off"``)."""
    def evaluate_star(self, positions: np.ndarray, v: int, link: Any, closed: bool) -> _StarEvaluation:
        """Classify and cost removing vertex ``v`` of ``positions`` (n, 3) with the given
        link (in order; closed: a cycle, else an open chain): class, the criterion's line
        ends (link indices) for boundary / interior-edge vertices, the error (= cost) and
        the hole's triangles ((k - 2, 3) indices into ``link``), or vetoed.  With
        ``accumulate="bound"`` the error is the larger of the paper's d and v's distance to
        those triangles (plus what v carries, if the kernel was prepared for a mesh)."""

def evaluate_star(positions: np.ndarray, v: int, link: Any, closed: bool, **options: Any) -> _StarEvaluation:
    """:meth:`SchroederKernel.evaluate_star` with a kernel prepared from ``options``."""
