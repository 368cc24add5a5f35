"""Type stubs for lodkit._core.halfedge (Cython)."""
import numpy as np
from numpy.typing import ArrayLike, NDArray

class HalfEdgeMesh:
    """Half-edge connectivity; half-edge h is in face h // 3 and leaves corners[h // 3, h % 3]."""

    n_vertices: int
    n_faces: int
    n_edges: int
    n_alive_faces: int
    n_alive_vertices: int
    n_split_vertices: int
    n_nonmanifold_edges: int
    @property
    def corners(self) -> NDArray[np.intc]: ...
    @property
    def twins(self) -> NDArray[np.intc]: ...
    @property
    def edges(self) -> NDArray[np.intc]:
        """(3 * n_faces,) edge id of each half-edge."""
    @property
    def edge_halfedges(self) -> NDArray[np.intc]: ...
    @property
    def vertex_halfedges(self) -> NDArray[np.intc]: ...
    @property
    def boundary_vertices(self) -> np.ndarray:
        """(n_vertices,) bool: the vertex slots whose fan starts at a boundary half-edge."""
    @property
    def vertex_sources(self) -> NDArray[np.intc]: ...
    @property
    def locked_vertices(self) -> NDArray[np.bool_]: ...
    @property
    def alive_faces(self) -> NDArray[np.bool_]: ...
    @property
    def alive_vertices(self) -> NDArray[np.bool_]: ...
    @property
    def alive_edges(self) -> NDArray[np.bool_]: ...
    def faces(self) -> NDArray[np.intc]:
        """(k, 3) live faces in face-slot order."""
    def neighbors(self, v: int) -> list[int]:
        """1-ring of ``v`` in fan order."""
    def vertex_is_boundary(self, v: int) -> bool: ...
    def can_collapse(self, u: int, v: int) -> bool:
        """Whether edge (u, v) exists and passes the link condition."""
    def collapse_edge(self, u: int, v: int) -> int:
        """Collapse (u, v) removing u; returns v.  ValueError if not allowed."""
    def _check_vertex(self, v: int) -> None:
        """ValueError unless ``v`` is a live vertex."""
    def _find_halfedge(self, u: int, v: int) -> int:
        """A half-edge running u -> v, or -1 if (u, v) is not an edge (ValueError for a dead vertex)."""
    def star(self, v: int) -> tuple[list[int], list[int], bool]:
        """(link, face slots, closed) of vertex v: face i is (v, link[i], link[i+1])."""
    def remove_vertex(self, v: int, triangles: ArrayLike) -> NDArray[np.intc]:
        """Remove v and fill its hole with (k - 2, 3) link-index triangles (topology only);
        returns their face slots."""
    def check(self) -> bool:
        """Verify all invariants; AssertionError naming the first broken one."""

def build(faces: ArrayLike, n_vertices: int, threads: int = 1, take: bool = False) -> HalfEdgeMesh:
    """Half-edge arrays for (m, 3) faces in O(m + n); non-manifold parts are cut and locked;
    ``take``: the faces are handed over (the corner array is made in them, not a copy)."""

def triangulation_ok(triangles: ArrayLike, k: int, closed: bool) -> bool:
    """Is ``triangles`` an oriented triangulation of a k-gon hole (link indices)?"""
def count_face_components(hm: HalfEdgeMesh) -> int:
    """Number of components of the live faces (joined across twin half-edges)."""

def has_border(hm: HalfEdgeMesh) -> bool:
    """Some half-edge has no twin (stops at the first)."""

def live_output(
    hm: HalfEdgeMesh,
    input_vertex: ArrayLike,
    input_face: ArrayLike,
    vertices: ArrayLike,
    n_input_faces: int,
    by_input_face: bool,
    moved: ArrayLike | None,
    positions: ArrayLike | None,
    center: ArrayLike,
    scale: float,
) -> tuple[NDArray[np.float64], NDArray[np.int32], NDArray[np.int64], NDArray[np.int64], NDArray[np.intp]]:
    """(vertices, faces, vertex_map, face_map, first): the live part in the input's
    numbering, welded by input vertex, faces in slot or input-face order (extract's core)."""

def morton_permutation(
    points: ArrayLike,
    index: ArrayLike | None = ...,
    box: tuple[ArrayLike, ArrayLike] | None = ...,
    threads: int = ...,
) -> NDArray[np.int32]:
    """(n,) permutation sorting (n, 3) points (or points[index]) along their Morton curve
    (as ``lodkit.geometry.morton_order``, by a radix sort); ``box`` their (lo, hi) when
    known; the same for any number of ``threads``."""

def faces_by_first_slot(
    faces: ArrayLike, n_vertices: int, reorder: bool = ..., remap: ArrayLike | None = ..., threads: int = ...
):
    """(m,) permutation ordering faces (``remap[faces]`` with ``remap``) by their smallest
    vertex index, ties in input order; with ``reorder``, (the faces in that order, the
    permutation); the same for any number of ``threads``."""

def used_vertices(faces: ArrayLike, n_vertices: int) -> tuple[NDArray[np.bool_], int]:
    """(used, n_degenerate): which vertices the faces without a repeated index use, and how
    many faces repeat one, in one pass; ValueError for an index outside."""

def bounding_box(points: ArrayLike, index: ArrayLike | None = ...) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(lo, hi) corners of the bounding box of points (or points[index]), without a copy."""

def normalised_positions(
    points: ArrayLike, index: ArrayLike, center: ArrayLike, scale: float, out: NDArray[np.float64]
) -> None:
    """``out`` ((n, 3), rows may be spaced) = (points[index] - center) / scale, in place, as
    numpy computes it."""
