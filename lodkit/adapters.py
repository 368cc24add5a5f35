"""Any mesh type in, the same type out: the one conversion every entry point runs.

:func:`coerce` turns what a user passes into a :class:`lodkit.Mesh` and gives back a function
that turns a result Mesh into the type that went in:

=============================================  ===========================================
input                                          attributes read (and written back)
=============================================  ===========================================
``lodkit.Mesh``                                all (the result is a Mesh)
``open3d.geometry.TriangleMesh`` (legacy)      vertex normals, vertex colours, triangle uvs
``open3d.t.geometry.TriangleMesh`` (tensor)    as legacy (through ``to_legacy``); the result
                                               has the input's dtypes and device
``trimesh.Trimesh``                            vertex normals (when given, not computed),
                                               ``visual`` vertex colours (COLOR visuals) or
                                               uvs (texture visuals; the material is kept)
``pyvista.PolyData``                           triangulated first; point data: active
                                               normals, a colour array (RGB / RGBA / colors),
                                               active texture coordinates
``(vertices, faces)`` tuple, ``[V, F]`` list   none (a tuple / list of two arrays back)
a path (``str`` / ``os.PathLike``)             read with :func:`lodkit.load`; a Mesh back
=============================================  ===========================================

trimesh and pyvista are not dependencies: their objects are told by their class's module and
the packages are imported only when such an object is passed.  Data that a lodkit Mesh cannot
carry (trimesh face colours, other pyvista point or cell arrays, other tensor attributes) is
left out with a :class:`UserWarning` naming it, never silently.
"""
from __future__ import annotations

import os
import warnings
from collections.abc import Callable

import numpy as np

from .deps import open3d as import_open3d
from .errors import MeshError
from .mesh import Mesh

__all__ = ["coerce", "to_mesh", "ACCEPTED"]

ACCEPTED = ("a lodkit.Mesh, an open3d TriangleMesh (legacy or tensor), a trimesh.Trimesh, a pyvista.PolyData, "
            "a (vertices, faces) tuple or list, or a file path")

# names a pyvista colour array goes by (Open3D's and VTK's PLY readers, trimesh's exporter, users)
_PV_COLOR_NAMES = ("RGB", "RGBA", "colors", "Colors", "colours", "RGBColors", "vertex_colors")


def _identity(mesh: Mesh) -> Mesh:
    return mesh


def _top_module(obj) -> str:
    return (type(obj).__module__ or "").split(".")[0]


def _dropped(kind: str, names) -> None:
    names = sorted(names)
    if names:
        warnings.warn(f"lodkit: {kind} {', '.join(names)} cannot be carried by a lodkit Mesh and are not in "
                      "the result", UserWarning, stacklevel=4)


def to_mesh(obj, what: str | None = None, *, load=None) -> Mesh:
    """A :class:`Mesh` from any input :func:`coerce` takes."""
    return coerce(obj, what, load=load)[0]


def coerce(obj, what: str | None = None, *, load=None) -> tuple[Mesh, Callable[[Mesh], object]]:
    """``(mesh, back)``: the input as a lodkit :class:`Mesh`, and a function that turns a
    result Mesh into the input's type (attributes included).

    what : names the argument in error messages ("original: face 0 ..."); any other type
           raises a MeshError that lists what is accepted.
    load : the function that reads a path (:func:`lodkit.load`; passed in by the entry
           points, as lodkit.io itself converts with this module); without it a path is
           refused.
    """
    prefix = f"{what}: " if what else ""
    try:
        return _coerce(obj, load)
    except MeshError as exc:
        if not what or str(exc).startswith(prefix):
            raise
        raise MeshError(f"{prefix}{exc}") from None


def _coerce(obj, load):
    if isinstance(obj, Mesh):
        return obj, _identity
    if isinstance(obj, (str, os.PathLike)):
        if load is None:
            raise MeshError(f"got the path {os.fspath(obj)!r}; read it with lodkit.load() first")
        return load(obj), _identity
    if isinstance(obj, (tuple, list)) and len(obj) == 2:
        mesh = Mesh(obj[0], obj[1])
        kind = type(obj) if type(obj) in (tuple, list) else tuple
        return mesh, lambda m: kind((m.vertices, m.faces))
    top, name = _top_module(obj), type(obj).__name__
    if top == "open3d" and name == "TriangleMesh":
        if hasattr(obj, "to_legacy"):
            return _from_open3d_tensor(obj)
        return Mesh.from_open3d(obj), lambda m: m.to_open3d()
    if top == "trimesh":
        if hasattr(obj, "faces") and hasattr(obj, "visual"):
            return _from_trimesh(obj)
        if name == "Scene":
            raise MeshError("got a trimesh.Scene; pass one mesh (scene.to_mesh() or scene.dump(concatenate=True))")
    if top == "pyvista":
        import pyvista

        if isinstance(obj, pyvista.PolyData):
            return _from_pyvista(obj, pyvista)
        if hasattr(obj, "extract_surface"):
            raise MeshError(f"got a pyvista.{name}; pass its surface (mesh.extract_surface())")
    raise MeshError(f"expected {ACCEPTED}, got {type(obj).__module__}.{type(obj).__qualname__}")


# ---------------------------------------------------------------------- Open3D tensor
def _from_open3d_tensor(obj):
    o3d = import_open3d()

    extra = [k for k in obj.vertex if k not in ("positions", "normals", "colors")]
    extra += [f"triangle {k}" for k in obj.triangle if k not in ("indices", "texture_uvs", "normals")]
    _dropped("Open3D tensor attributes", [f"vertex {k}" if not k.startswith("triangle ") else k for k in extra])
    mesh = Mesh.from_open3d(obj.to_legacy())
    device = obj.device
    vdtype = obj.vertex["positions"].dtype if "positions" in obj.vertex else o3d.core.float32
    fdtype = obj.triangle["indices"].dtype if "indices" in obj.triangle else o3d.core.int64

    def back(m: Mesh):
        return o3d.t.geometry.TriangleMesh.from_legacy(m.to_open3d(), vertex_dtype=vdtype,
                                                       triangle_dtype=fdtype, device=device)

    return mesh, back


# ---------------------------------------------------------------------- trimesh
def _from_trimesh(obj):
    import trimesh

    vertices = np.asarray(obj.vertices, dtype=np.float64)
    faces = np.asarray(obj.faces)
    cache = getattr(obj, "_cache", None)
    try:       # normals the user or the file gave (trimesh computes them on demand otherwise)
        given_normals = cache is not None and "vertex_normals" in cache
    except Exception:
        given_normals = False
    normals = np.asarray(obj.vertex_normals, dtype=np.float64) if given_normals else None
    visual = obj.visual
    kind = getattr(visual, "kind", None)
    colors = uvs = None
    material = None
    if kind == "vertex":
        rgba = np.asarray(visual.vertex_colors)
        colors = rgba.astype(np.float64) / (255.0 if rgba.dtype.kind in "iu" else 1.0)
        if colors.shape[1] == 4 and np.all(colors[:, 3] == 1.0):
            colors = colors[:, :3]
    elif kind == "texture":
        if getattr(visual, "uv", None) is not None:
            uvs = np.asarray(visual.uv, dtype=np.float64)
        material = getattr(visual, "material", None)
    elif kind == "face":
        _dropped("trimesh", ["face colours"])
    mesh = Mesh(vertices, faces, normals=normals, colors=colors, uvs=uvs)
    metadata = dict(getattr(obj, "metadata", {}) or {})

    def back(m: Mesh):
        visual = None
        if m.uvs is not None:
            mat = material.copy() if material is not None and hasattr(material, "copy") else material
            visual = trimesh.visual.TextureVisuals(uv=m.uvs, material=mat)
        elif m.colors is not None:
            visual = trimesh.visual.ColorVisuals(
                vertex_colors=np.round(np.clip(m.colors, 0.0, 1.0) * 255.0).astype(np.uint8))
        return trimesh.Trimesh(vertices=m.vertices, faces=m.faces, vertex_normals=m.normals, visual=visual,
                               metadata=dict(metadata), process=False)

    return mesh, back


# ---------------------------------------------------------------------- pyvista
def _from_pyvista(obj, pyvista):
    poly = obj if obj.is_all_triangles else obj.triangulate()
    if poly.n_lines or poly.n_verts:
        _dropped("pyvista", ["lines and vertex cells"])
    points = np.asarray(poly.points)
    faces = np.asarray(poly.regular_faces) if poly.n_cells else np.zeros((0, 3), dtype=np.int64)
    pd = poly.point_data
    n = points.shape[0]
    normals_name = pd.active_normals_name
    if normals_name is None and "Normals" in pd:
        normals_name = "Normals"
    uv_name = pd.active_texture_coordinates_name
    color_name = next((c for c in _PV_COLOR_NAMES if c in pd and np.asarray(pd[c]).ndim == 2
                       and np.asarray(pd[c]).shape[1] in (3, 4)), None)
    normals = np.asarray(pd[normals_name], dtype=np.float64) if normals_name else None
    uvs = np.asarray(pd[uv_name], dtype=np.float64) if uv_name else None
    colors = None
    color_dtype = None
    if color_name:
        raw = np.asarray(pd[color_name])
        color_dtype = raw.dtype
        colors = raw.astype(np.float64) / (255.0 if raw.dtype.kind in "iu" else 1.0)
    used = {normals_name, uv_name, color_name}
    _dropped("pyvista point arrays", [k for k in pd.keys() if k not in used and len(pd[k]) == n])
    _dropped("pyvista cell arrays", list(poly.cell_data.keys()))
    mesh = Mesh(points, faces, normals=normals, colors=colors, uvs=uvs)
    point_dtype = points.dtype

    def back(m: Mesh):
        out = pyvista.PolyData.from_regular_faces(m.vertices.astype(point_dtype, copy=False), m.faces)
        if m.normals is not None and normals_name:
            out.point_data[normals_name] = m.normals
            out.point_data.active_normals_name = normals_name
        if m.colors is not None and color_name:
            c = m.colors
            if color_dtype.kind in "iu":
                c = np.round(np.clip(c, 0.0, 1.0) * 255.0).astype(color_dtype)
            out.point_data[color_name] = c
        if m.uvs is not None and uv_name:
            out.point_data[uv_name] = m.uvs
            out.point_data.active_texture_coordinates_name = uv_name
        for k in obj.field_data.keys():
            out.field_data[k] = obj.field_data[k]
        return out

    return mesh, back
