"""Type stubs for lodkit._core.bound (Cython): the two-sided error bound of
``simplify(error="hausdorff")``."""
import numpy as np

from .halfedge import HalfEdgeMesh

#: sample points Bound takes at most (beyond, ValueError)
MAX_POINTS: int

def triangle_covering_radius(t: np.ndarray) -> float:
    """The farthest a point of triangle ``t`` (9,) is from its nearest corner."""

def sample_original(tris: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points, slack, triangle): the grid points of each triangle (n, 9), covering it to ``spacing``."""

class Bound:
    """The error-bound state of one run: a BVH over the original, its sample points
    attached to the current faces, each face's certified distance."""

    eps: float
    def __init__(self, hm: HalfEdgeMesh, vdata: np.ndarray, offset: int, eps: float,
                 spacing: float = 0.25) -> None: ...
    @property
    def n_points(self) -> int: ...
    @property
    def n_nodes_bvh(self) -> int: ...
    def bound(self, alive_faces: np.ndarray) -> float:
        """The largest certificate of a live face."""
    def distance(self, x: np.ndarray) -> np.ndarray:
        """Distance from each point (k, 3) to the original."""
    def face_distance(self, t: np.ndarray) -> float:
        """The certified distance of triangle ``t`` (9,) to the original, or -1."""
