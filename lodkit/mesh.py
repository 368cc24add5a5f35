"""The triangle mesh lodkit works on and its conversion to and from Open3D.

The entry points turn their input into a :class:`Mesh` with :func:`lodkit.adapters.coerce`
(every supported mesh type, the same type back); :func:`as_mesh` here is its Open3D-only
subset, for :mod:`lodkit.io`'s writer (lodkit.adapters imports this module, not the reverse)."""
from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from .deps import open3d as import_open3d
from .errors import MeshError

__all__ = ["Mesh", "as_mesh", "is_open3d"]


def _as_float_array(name: str, values, n_rows: int | None, n_cols: int | tuple) -> np.ndarray:
    try:
        arr = np.ascontiguousarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise MeshError(f"{name} must be numeric: {exc}") from None
    cols = (n_cols,) if isinstance(n_cols, int) else n_cols
    if arr.ndim != 2 or arr.shape[1] not in cols:
        want = " or ".join(f"(n, {c})" for c in cols)
        raise MeshError(f"{name} must have shape {want}, got {arr.shape}")
    if n_rows is not None and arr.shape[0] != n_rows:
        raise MeshError(f"{name} has {arr.shape[0]} rows but the mesh has {n_rows} vertices")
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        rows = np.flatnonzero(bad)
        raise MeshError(
            f"{name} has {rows.size} row(s) with NaN or inf values "
            f"(first at row {rows[0]}: {arr[rows[0]].tolist()})"
        )
    return arr


def _as_index_array(faces) -> np.ndarray:
    """``faces`` as an array; a ragged list (rows of different lengths: polygons) or
    anything else numpy cannot make an array of is a MeshError saying which row."""
    try:
        return np.asarray(faces)
    except (TypeError, ValueError) as exc:
        try:
            lengths = [len(row) for row in faces]
        except TypeError:
            lengths = []
        odd = next((i for i, n in enumerate(lengths) if n != 3), None)
        if odd is not None:
            raise MeshError(f"faces must be triangles, an (m, 3) array of vertex indices: face {odd} has "
                            f"{lengths[odd]} indices (triangulate polygons first)") from None
        raise MeshError(f"faces must be an (m, 3) array of vertex indices: {exc}") from None


@dataclass(eq=False)
class Mesh:
    """A triangle mesh with optional per-vertex attributes.

    vertices : (n, 3) float64
    faces    : (m, 3) int32, counter-clockwise seen from outside
    normals  : (n, 3) float64 or None, per-vertex unit normals
    colors   : (n, 3) or (n, 4) float64 in [0, 1], or None
    uvs      : (n, 2) float64 or None, per-vertex texture coordinates

    The constructor converts dtypes, checks shapes, index range and finiteness, and raises
    :class:`lodkit.MeshError` naming the first problem found.
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    colors: np.ndarray | None = None
    uvs: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.vertices = _as_float_array("vertices", self.vertices, None, 3)
        n = self.vertices.shape[0]
        faces = _as_index_array(self.faces)
        if faces.size == 0 and faces.ndim <= 2:
            faces = faces.reshape(0, 3)
        if faces.ndim != 2 or faces.shape[1] != 3:
            raise MeshError(f"faces must have shape (m, 3), got {faces.shape}")
        if faces.dtype.kind not in "iu":
            if faces.dtype.kind == "f" and np.all(np.isfinite(faces)) and np.all(faces == np.round(faces)):
                faces = faces.astype(np.int64)
            else:
                raise MeshError(f"faces must hold integer vertex indices, got dtype {faces.dtype}")
        if faces.size:
            lo, hi = faces.min(), faces.max()
            if lo < 0 or hi >= n:
                bad = np.flatnonzero(((faces < 0) | (faces >= n)).any(axis=1))[0]
                raise MeshError(
                    f"face {bad} {faces[bad].tolist()} has a vertex index outside 0..{n - 1}"
                )
        self.faces = np.ascontiguousarray(faces, dtype=np.int32)
        if self.normals is not None:
            self.normals = _as_float_array("normals", self.normals, n, 3)
        if self.colors is not None:
            self.colors = _as_float_array("colors", self.colors, n, (3, 4))
        if self.uvs is not None:
            self.uvs = _as_float_array("uvs", self.uvs, n, 2)

    # ------------------------------------------------------------------ basics
    @property
    def n_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        return int(self.faces.shape[0])

    def attributes(self) -> dict[str, np.ndarray]:
        """The per-vertex attribute arrays that are present, by name."""
        return {k: getattr(self, k) for k in ("normals", "colors", "uvs") if getattr(self, k) is not None}

    def copy(self) -> Mesh:
        return Mesh(
            self.vertices.copy(),
            self.faces.copy(),
            normals=None if self.normals is None else self.normals.copy(),
            colors=None if self.colors is None else self.colors.copy(),
            uvs=None if self.uvs is None else self.uvs.copy(),
            metadata=dict(self.metadata),
        )

    def bbox_diagonal(self) -> float:
        """Length of the diagonal of the axis-aligned box around the referenced vertices."""
        if self.faces.size:
            pts = self.vertices[np.unique(self.faces)]
        else:
            pts = self.vertices
        if pts.shape[0] == 0:
            return 0.0
        from .geometry import box_diagonal
        return box_diagonal(pts.min(axis=0), pts.max(axis=0))

    def face_normals(self) -> np.ndarray:
        """(m, 3) unit face normals (zero rows for degenerate faces)."""
        v = self.vertices
        f = self.faces
        n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        length = np.linalg.norm(n, axis=1, keepdims=True)
        return np.divide(n, length, out=np.zeros_like(n), where=length > 0)

    def __repr__(self) -> str:
        attrs = ", ".join(self.attributes()) or "no attributes"
        return f"Mesh({self.n_vertices} vertices, {self.n_faces} faces, {attrs})"

    # ------------------------------------------------------------------ Open3D
    @classmethod
    def from_open3d(cls, o3d_mesh) -> Mesh:
        """Build a Mesh from an ``open3d.geometry.TriangleMesh`` (copies the arrays).

        Per-corner ``triangle_uvs`` are turned into per-vertex uvs; where one vertex carries
        different uvs in different faces it is split into one vertex per distinct uv (a seam):
        vertex ``i`` keeps index ``i``, the extra copies are appended after the last vertex.
        """
        # np.array(copy=True): np.asarray would alias Open3D's memory (the Mesh would change
        # when the Open3D mesh does)
        vertices = np.array(o3d_mesh.vertices, dtype=np.float64, copy=True).reshape(-1, 3)
        faces = np.array(o3d_mesh.triangles, dtype=np.int64, copy=True).reshape(-1, 3)
        normals = (np.array(o3d_mesh.vertex_normals, dtype=np.float64, copy=True)
                   if o3d_mesh.has_vertex_normals() else None)
        colors = np.array(o3d_mesh.vertex_colors, dtype=np.float64, copy=True) if o3d_mesh.has_vertex_colors() else None
        uvs = None
        in_range = faces.size and faces.min() >= 0 and faces.max() < vertices.shape[0]
        # (out-of-range faces skip the uv split so the constructor reports them as MeshError)
        if in_range and o3d_mesh.has_triangle_uvs() and len(o3d_mesh.triangle_uvs) == 3 * faces.shape[0]:
            corner_uv = np.asarray(o3d_mesh.triangle_uvs, dtype=np.float64).reshape(-1, 2)
            vertices, faces, uvs, extra = _split_at_uv_seams(vertices, faces, corner_uv,
                                                             {"normals": normals, "colors": colors})
            normals, colors = extra["normals"], extra["colors"]
        return cls(vertices, faces, normals=normals, colors=colors, uvs=uvs)

    def to_open3d(self):
        """An ``open3d.geometry.TriangleMesh`` with the same vertices, faces and attributes."""
        o3d = import_open3d()

        m = o3d.geometry.TriangleMesh()
        m.vertices = o3d.utility.Vector3dVector(self.vertices)
        m.triangles = o3d.utility.Vector3iVector(self.faces.astype(np.int32))
        if self.normals is not None:
            m.vertex_normals = o3d.utility.Vector3dVector(self.normals)
        if self.colors is not None:
            m.vertex_colors = o3d.utility.Vector3dVector(np.ascontiguousarray(self.colors[:, :3]))
        if self.uvs is not None:
            m.triangle_uvs = o3d.utility.Vector2dVector(self.uvs[self.faces.reshape(-1)])
        return m


def is_open3d(mesh) -> bool:
    """True for a legacy ``open3d.geometry.TriangleMesh`` (told by its class name, so Open3D
    is not imported to ask): the entry points give one back when they are given one."""
    return type(mesh).__name__ == "TriangleMesh" and hasattr(mesh, "triangles")


def as_mesh(mesh, what: str | None = None, *, tensor: bool = False, load=None) -> Mesh:
    """The Open3D subset of :func:`lodkit.adapters.coerce`, for lodkit.io's writer.

    A :class:`Mesh` from a Mesh (as is), a legacy Open3D ``TriangleMesh`` or a
    ``(vertices, faces)`` tuple; with ``tensor`` also an ``open3d.t.geometry.TriangleMesh``;
    with a ``load`` function (:func:`lodkit.load`) also a file path, read with it.

    what : names the argument in error messages ("original: face 0 ..."); the MeshError
           raised for any other type says what is accepted.
    """
    if isinstance(mesh, Mesh):
        return mesh
    if load is not None and isinstance(mesh, (str, os.PathLike)):
        return load(mesh)
    prefix = f"{what}: " if what else ""
    if isinstance(mesh, tuple) and len(mesh) == 2:
        try:
            return Mesh(mesh[0], mesh[1])
        except MeshError as exc:
            if not what:
                raise
            raise MeshError(f"{prefix}{exc}") from None
    if tensor and type(mesh).__name__ == "TriangleMesh" and (type(mesh).__module__ or "").startswith("open3d"):
        if hasattr(mesh, "to_legacy"):
            mesh = mesh.to_legacy()
    if is_open3d(mesh):
        try:
            return Mesh.from_open3d(mesh)
        except MeshError as exc:
            if not what:
                raise
            raise MeshError(f"{prefix}{exc}") from None
    accepted = "a lodkit.Mesh, an open3d TriangleMesh" + (", a (vertices, faces) tuple or a file path"
                                                          if load is not None else " or a (vertices, faces) tuple")
    raise MeshError(f"{prefix}expected {accepted}, got {type(mesh).__module__}.{type(mesh).__qualname__}")


def _split_at_uv_seams(vertices, faces, corner_uv, attrs):
    """Give every distinct (vertex, uv) pair its own vertex; returns new arrays and per-vertex uvs.

    Vertex ``i`` keeps index ``i`` and the uv of the first corner that uses it, so indices
    into the input stay valid for its first ``n`` vertices; each further uv a vertex takes
    on (a seam) gets a copy of the vertex appended at the end, in order of first use.
    Vertices no face uses stay in place with uv (0, 0). Faces must index in range.
    """
    n = vertices.shape[0]
    corner_v = faces.reshape(-1).astype(np.int64)
    keys = np.concatenate([corner_v[:, None].astype(np.float64), corner_uv], axis=1)
    uniq, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    src = uniq[:, 0].astype(np.int64)
    # rows are sorted by vertex; per vertex, the primary row is the one used first
    by_vertex_then_use = np.lexsort((first, src))
    primary = np.zeros(uniq.shape[0], dtype=bool)
    sorted_src = src[by_vertex_then_use]
    primary[by_vertex_then_use[np.r_[True, sorted_src[1:] != sorted_src[:-1]]]] = True
    uvs = np.zeros((n, 2), dtype=np.float64)
    uvs[src[primary]] = uniq[primary, 1:]
    extra = np.flatnonzero(~primary)
    if extra.size == 0:
        return vertices, faces, uvs, attrs
    extra = extra[np.argsort(first[extra], kind="stable")]
    new_index = src.copy()
    new_index[extra] = n + np.arange(extra.size)
    copy_of = src[extra]
    new_vertices = np.concatenate([vertices, vertices[copy_of]])
    new_uvs = np.concatenate([uvs, uniq[extra, 1:]])
    new_attrs = {k: (None if a is None else np.concatenate([a, a[copy_of]])) for k, a in attrs.items()}
    return new_vertices, new_index[inverse].reshape(-1, 3), new_uvs, new_attrs
