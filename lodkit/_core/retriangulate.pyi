"""Type stubs for lodkit._core.retriangulate (Cython): hole re-triangulation for vertex
removal.  The nogil routines (split_loop, fan_from, closest_line_apex) are cimported from
retriangulate.pxd; these are their Python test wrappers."""
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: smallest accepted aspect ratio of a split in split_loop (vtkDecimate's 1/25)
SPLIT_MIN_ASPECT: float

def py_split_loop(points: ArrayLike, normal: ArrayLike | None = None,
                  force: Sequence[int] | None = None,
                  min_aspect: float | None = None) -> NDArray[np.int32] | None:
    """Schroeder's recursive loop splitting of the loop ``points`` (k, 3): (k - 2, 3)
    triangles as loop indices, or None when no valid triangulation exists."""

def py_min_volume_triangulation(points: ArrayLike, x: ArrayLike,
                                normal: ArrayLike) -> NDArray[np.int32] | None:
    """The hole ``points`` (k, 3)'s triangulation of least volume to the cone of ``x``
    (sum of |det|), none of whose triangles turns 90 degrees or more from ``normal``:
    (k - 2, 3) loop indices, or None."""

def py_fan_from(apex: int, k: int) -> NDArray[np.int32]:
    """(k - 2, 3) triangles of the fan from loop index ``apex``."""

def py_closest_line_apex(points: ArrayLike, x: ArrayLike) -> int:
    """Chuon & Guha: the loop index of the end, nearer to ``x``, of the line through two
    loop vertices closest to ``x`` (-1 if k < 3)."""

def carried_points(ctx: Any, n: int) -> tuple[NDArray[np.float64], NDArray[np.int32], NDArray[np.int32]]:
    """The starting lists of a removal kernel's carried points: (face centroids flattened,
    the head point of each face slot, the next point of each point; -1 ends a list)."""

def auto_mode(name: str, value: Any, modes: Sequence[str], paper: str, ours: str, accumulate: str) -> int:
    """The index in ``modes`` of a removal kernel's option (``"auto"``: ``paper`` with
    accumulate="off", else ``ours``)."""
