"""Type stubs for lodkit._core.bound (Cython): the two-sided error bound of
``simplify(error="hausdorff")``."""
import numpy as np

from .halfedge import HalfEdgeMesh

#: pieces of the original Bound keeps at most (beyond, ``overflowed``)
MAX_PIECES: int

def triangle_covering_radius(t: np.ndarray) -> float:
    """The farthest a point of triangle ``t`` (9,) is from its nearest corner."""

class Bound:
    """The error-bound state of one run: a BVH over the original, its triangles (split
    where needed) attached to the current faces, each face's certified distance."""

    eps: float
    def __init__(self, hm: HalfEdgeMesh, vdata: np.ndarray, offset: int, eps: float,
                 spacing: float = 0.25) -> None: ...
    @property
    def n_pieces(self) -> int: ...
    @property
    def overflowed(self) -> bool: ...
    def pieces(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(pieces (k, 9), faces (k, 9), cert (k,)): each piece of the original, the face it
        is on and that face's certificate."""
    @property
    def n_nodes_bvh(self) -> int: ...
    def bound(self, alive_faces: np.ndarray) -> float:
        """The largest certificate of a live face."""
    def distance(self, x: np.ndarray) -> np.ndarray:
        """Distance from each point (k, 3) to the original."""
    def face_certificates(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(faces (k, 9), own (k,), cert (k,)) of the live faces: corners, the certified
        distance of their points to the original, and their certificate both ways."""
    def patch_distance(self, t: np.ndarray) -> float:
        """The flat-patch certificate of triangle ``t`` (9,) alone, or -1."""
    def face_distance(self, t: np.ndarray) -> float:
        """The certified distance of triangle ``t`` (9,) to the original, or -1."""
