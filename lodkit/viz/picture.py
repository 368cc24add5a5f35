"""render(): a picture of a mesh, by the Open3D backend or the numpy rasteriser."""
from __future__ import annotations

import warnings

import numpy as np

from ..errors import OptionError, RenderError
from . import open3d_backend
from .camera import Camera, as_drawable, check_size, used_points
from .colors import DEFAULT_COLOR, WIRE_COLOR, rgb_option, vertex_colors
from .open3d_backend import BACKENDS, backend_info
from .raster import AMBIENT, Style, draw, shade


def _unique_edges(F: np.ndarray) -> np.ndarray:
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]).astype(np.int64)
    return np.unique(np.sort(e, axis=1), axis=0)


def _vertex_normals(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])    # area weighted
    n = np.zeros_like(V)
    for k in range(3):
        np.add.at(n, F[:, k], fn)
    return n


def render(mesh, width: int = 640, height: int = 480, *, colors=None, camera: Camera | None = None,
           wireframe: bool = False, background=(1.0, 1.0, 1.0), shading: str = "flat",
           backend: str | None = None, supersample: int = 2) -> np.ndarray:
    """An (height, width, 3) uint8 picture of ``mesh`` (any mesh type
    :func:`lodkit.adapters.coerce` takes, but a path), drawn headless.

    colors     : None (the mesh's own vertex colours, else a light grey), (n, 3) RGB floats
                 in [0, 1] or uint8, or (n,) values mapped through :func:`colormap`
    camera     : a :class:`Camera`; None looks at the mesh from a fixed direction (azimuth
                 30°, elevation 20°, y up) and fits it in the image. Give several calls one
                 Camera (e.g. ``Camera.fit(original)``) and they are drawn alike.
    wireframe  : draw the edges too (hidden ones stay hidden)
    background : RGB floats in [0, 1]
    shading    : "flat" (one normal per face: the facets show) or "smooth" (the mesh's
                 normals, else area-weighted vertex normals)
    backend    : "open3d", "numpy", or None for :func:`backend` (Open3D when it can draw
                 here; if it fails during a call the numpy rasteriser draws instead, with a
                 warning). Asking for "open3d" where it cannot draw raises RenderError.
    supersample: draw at this many times the size and box-filter down (1-4)
    """
    m = as_drawable(mesh)
    width, height = check_size(width, height)
    bg = rgb_option("background", background)
    if shading not in ("flat", "smooth"):
        raise OptionError(f"shading must be 'flat' or 'smooth', got {shading!r}")
    if isinstance(supersample, bool) or not isinstance(supersample, (int, np.integer)) or not 1 <= supersample <= 4:
        raise OptionError(f"supersample must be an integer from 1 to 4, got {supersample!r}")
    if camera is not None and not isinstance(camera, Camera):
        raise OptionError(f"camera must be a lodkit.render.Camera or None, got {type(camera).__name__}")
    if backend not in (None,) + BACKENDS:
        raise OptionError(f"backend must be one of {', '.join(BACKENDS)} or None, got {backend!r}")
    base = vertex_colors(m, colors)
    pts = used_points(m)
    view = (camera or Camera.fit(pts, width, height)).view(pts, width, height)
    V = m.vertices
    F = m.faces.astype(np.int64)
    normals = None
    if shading == "smooth":
        normals = m.normals if m.normals is not None else _vertex_normals(V, F)

    chosen = backend or backend_info()["backend"]
    if chosen == "open3d":
        if backend == "open3d":
            open3d_backend.require()
        if normals is not None:
            nc = normals[F.reshape(-1)] @ view.R.T
        else:
            fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]) @ view.R.T
            nc = np.repeat(fn, 3, axis=0)
        corner_base = (np.broadcast_to(np.asarray(DEFAULT_COLOR), (F.size, 3)) if base is None
                       else base[F.reshape(-1)])
        corner_colors = shade(corner_base, nc, AMBIENT)
        try:
            return open3d_backend.render_open3d(V, F, view, corner_colors, _unique_edges(F) if wireframe else None,
                                                bg, int(supersample))
        except Exception as exc:  # noqa: BLE001 - any failure of the C++ side
            reason = f"Open3D's renderer failed: {type(exc).__name__}: {exc}"
            if backend == "open3d":
                raise RenderError(reason) from exc
            open3d_backend.give_up(reason)
            warnings.warn(f"{reason}; drawing with the numpy rasteriser from now on", RuntimeWarning, stacklevel=2)
    style = Style(vertex_colors=base, normals=normals, wire=WIRE_COLOR if wireframe else None,
                  background=tuple(bg))
    return draw(V, F, view, style, int(supersample))
