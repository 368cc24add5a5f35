"""Pictures of meshes, headless: one renderer with two backends, contact sheets, PNG files.

>>> import lodkit, lodkit.demo, lodkit.render as lr
>>> mesh = lodkit.demo.demo_mesh(20_000)
>>> cam = lr.Camera.fit(mesh, 400, 300, up="z", elevation=35)        # one camera for all LODs
>>> row = [lr.render(m, 400, 300, camera=cam) for m in (mesh, lodkit.simplify(mesh, target_ratio=0.05).mesh)]
>>> lr.write_png("lods.png", lr.contact_sheet([row], labels=[["original", "5 %"]]))

:func:`render` draws a mesh with an orthographic camera and returns an (H, W, 3) uint8
array. Two backends draw the same picture:

- ``"open3d"``: Open3D's ``OffscreenRenderer`` (Filament). Headless it needs a Vulkan or
  EGL driver; on a machine without a GPU the software Vulkan of Mesa (Debian/Ubuntu
  packages ``libvulkan1`` and ``mesa-vulkan-drivers``) is enough.
- ``"numpy"``: a vectorised z-buffer rasteriser in this module (:func:`draw`), used when
  Open3D's renderer cannot start. It also draws what the Open3D path does not: textures
  by uv, highlighted edges and vertex dots (:class:`Style`; ``bench/pictures.py`` uses it).

:func:`backend` says which one :func:`render` uses by default and :func:`backend_info`
why; ``render(..., backend=...)`` or the environment variable
``LODKIT_RENDER_BACKEND=numpy|open3d`` chooses without probing. Open3D is the default only
on a hardware device: on Mesa's software Vulkan (llvmpipe) Filament draws correctly but
stalls on some frames, spinning a core for minutes (measured here: a 70k-face frame that
takes 0.5 s took 92, 141 and 279 s on about one call in three after the second in a
process, with one reused renderer or a fresh one per call), so there the numpy rasteriser
(1.8 s for the same frame at 320x240) is the default.

Shading is computed here, in numpy, for both backends (two-sided Lambert from a light near
the viewer, a little ambient and specular), and Open3D draws the shaded colours with its
unlit shader and post-processing off. Open3D's lit shaders tone-map the whole frame
(a white background comes out (230, 226, 219)), which would make a colour-mapped value
lie; this way a colour given is the colour drawn (at full light), both backends agree,
and a picture does not depend on the renderer. Both backends draw at ``supersample`` x
the size and box-filter down (anti-aliasing).

Open3D notes (0.20, measured here): creating an ``OffscreenRenderer`` costs 0.05-1 s, so
one renderer is kept and reused while the size stays the same. Two renderers alive at the
same time make the interpreter abort at exit (``PreconditionPanic: destroying
MaterialInstance ... still in use``, exit code 134), so this module never holds more than
one: a new size replaces it, and an ``atexit`` hook clears its scene and drops it. A driver
problem can abort the process instead of raising, so whether Open3D can draw at all is
probed once, in a subprocess. Open3D's line shader is 5-20x slower than the whole mesh on
the software device, so the wireframe is drawn as thin camera-facing strips.
"""
from __future__ import annotations

import atexit
import os
import secrets
import subprocess
import sys
import threading
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import LodkitError, MeshError, OptionError
from .mesh import Mesh

__all__ = [
    "Camera", "ImageIOError", "RenderError", "Style", "View", "backend", "backend_info", "colorbar",
    "colormap", "contact_sheet", "draw", "draw_text", "rasterize", "render", "rotation", "text_size", "write_png",
]

BACKENDS = ("open3d", "numpy")
DEFAULT_COLOR = (0.72, 0.74, 0.78)     # a light blue-grey
WIRE_COLOR = (0.1, 0.1, 0.1)
# light direction in camera space (x right, y up, z towards the viewer): above left of the eye
LIGHT = (-0.25, 0.35, 1.0)
AMBIENT = 0.33


class RenderError(LodkitError, RuntimeError):
    """The renderer asked for cannot draw here (Open3D's renderer did not start or failed)."""


class ImageIOError(LodkitError, OSError):
    """An image file could not be written."""


# --------------------------------------------------------------------------------------
# colours
# --------------------------------------------------------------------------------------

# viridis (matplotlib's perceptually uniform map) as a degree-6 polynomial per channel,
# t in [0, 1]: rgb = sum c_k t^k. Fit by Matt Zucker (shadertoy WlfXRN); within 0.011 of
# matplotlib's 256-entry table at every entry.
_VIRIDIS = np.array([
    [0.2777273272234177, 0.005407344544966578, 0.3340998053353061],
    [0.1050930431085774, 1.404613529898575, 1.384590162594685],
    [-0.3308618287255563, 0.214847559468213, 0.09509516302823659],
    [-4.634230498983486, -5.799100973351585, -19.33244095627987],
    [6.228269936347081, 14.17993336680509, 56.69055260068105],
    [4.776384997670288, -13.74514537774601, -65.35303263337234],
    [-5.435455855934631, 4.645852612178535, 26.3124352495832],
])
NAN_COLOR = (0.55, 0.55, 0.55)


def colormap(values, vmin: float | None = None, vmax: float | None = None) -> np.ndarray:
    """(n, 3) float64 RGB in [0, 1]: ``values`` (n,) through viridis.

    ``vmin``/``vmax`` default to the smallest and largest finite value; values outside are
    clipped; when all values are equal every row is the middle colour. Non-finite values
    (NaN, inf) get :data:`NAN_COLOR`, a neutral grey that is not on the map.
    """
    try:
        v = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise OptionError(f"colormap values must be numbers: {exc}") from None
    if v.ndim != 1:
        raise OptionError(f"colormap values must have shape (n,), got {v.shape}")
    finite = np.isfinite(v)
    lo = float(v[finite].min()) if vmin is None and finite.any() else (0.0 if vmin is None else float(vmin))
    hi = float(v[finite].max()) if vmax is None and finite.any() else (1.0 if vmax is None else float(vmax))
    if not (np.isfinite(lo) and np.isfinite(hi)) or hi < lo:
        raise OptionError(f"colormap range must be finite with vmin <= vmax, got [{lo}, {hi}]")
    t = np.full(v.shape, 0.5)
    if hi > lo:
        t = np.clip((np.where(finite, v, lo) - lo) / (hi - lo), 0.0, 1.0)
    rgb = np.zeros((v.size, 3)) + _VIRIDIS[-1]
    for c in _VIRIDIS[-2::-1]:                           # Horner
        rgb = rgb * t[:, None] + c
    rgb = np.clip(rgb, 0.0, 1.0)
    rgb[~finite] = NAN_COLOR
    return rgb


def _rgb(name: str, value) -> np.ndarray:
    try:
        c = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise OptionError(f"{name} must be an RGB triple in [0, 1], got {value!r}") from None
    if c.shape != (3,) or not np.isfinite(c).all() or c.min() < 0 or c.max() > 1:
        raise OptionError(f"{name} must be an RGB triple in [0, 1], got {value!r}")
    return c


def _vertex_colors(mesh: Mesh, colors) -> np.ndarray | None:
    """(n, 3) float colours in [0, 1] from the ``colors`` argument of :func:`render`."""
    if colors is None:
        return None if mesh.colors is None else np.clip(mesh.colors[:, :3], 0.0, 1.0)
    arr = np.asarray(colors)
    n = mesh.n_vertices
    if arr.ndim == 1:
        if arr.shape[0] != n:
            raise OptionError(f"colors: {arr.shape[0]} values for a mesh with {n} vertices")
        return colormap(arr)
    if arr.ndim != 2 or arr.shape[0] != n or arr.shape[1] not in (3, 4):
        raise OptionError(f"colors must be (n,) values or (n, 3) RGB for n = {n} vertices, got shape {arr.shape}")
    if arr.dtype == np.uint8:
        return arr[:, :3] / 255.0
    try:
        arr = arr[:, :3].astype(np.float64)
    except (TypeError, ValueError):
        raise OptionError(f"colors must be numeric, got dtype {arr.dtype}") from None
    if not np.isfinite(arr).all() or arr.min() < 0 or arr.max() > 1:
        raise OptionError("RGB colors must be finite floats in [0, 1] (or uint8)")
    return arr


# --------------------------------------------------------------------------------------
# cameras
# --------------------------------------------------------------------------------------

def rotation(azimuth: float, elevation: float, up: str = "y") -> np.ndarray:
    """World -> camera rotation (rows: camera x right, y up, z towards the viewer).

    The camera looks at the model from ``azimuth`` degrees around the ``up`` axis (0: from
    +z for y-up, from -y for z-up) and ``elevation`` degrees above the horizon.
    """
    a, e = np.radians(azimuth), np.radians(elevation)
    # direction from the target to the eye, in a y-up frame
    d = np.array([np.sin(a) * np.cos(e), np.sin(e), np.cos(a) * np.cos(e)])
    world_up = np.array([0.0, 1.0, 0.0])
    z = d / np.linalg.norm(d)
    x = np.cross(world_up, z)
    if np.linalg.norm(x) < 1e-9:
        x = np.array([1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    if up == "z":          # model is z-up: first map model (x, y, z) -> y-up frame (x, z, -y)
        R = R @ np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])
    elif up != "y":
        raise OptionError(f"up must be 'y' or 'z', got {up!r}")
    return R


@dataclass
class View:
    """The pixel mapping of an orthographic camera: rotation ``R`` (world -> camera rows x
    right, y up, z towards the viewer), the image centre in camera coordinates, pixels per
    model unit and the image size. What both backends draw with."""

    R: np.ndarray
    center: np.ndarray
    scale: float
    width: int
    height: int

    @classmethod
    def fit(cls, points: np.ndarray, width: int, height: int, azimuth=30.0, elevation=20.0, up="y",
            margin: float = 0.06, zoom: float = 1.0, shift=(0.0, 0.0)) -> "View":
        """A view that frames ``points`` in a width x height image.

        ``zoom`` > 1 magnifies about the centre; ``shift`` moves the view centre by fractions
        of the framed extent (x right, y up), to look at a detail.
        """
        R = rotation(azimuth, elevation, up)
        P = np.asarray(points, dtype=np.float64) @ R.T
        lo, hi = P.min(axis=0), P.max(axis=0)
        ext = np.maximum(hi - lo, 1e-12)
        c = 0.5 * (lo + hi)
        c[:2] += np.asarray(shift) * ext[:2]
        s = zoom * min(width * (1 - 2 * margin) / ext[0], height * (1 - 2 * margin) / ext[1])
        return cls(R, c, float(s), int(width), int(height))

    def aspect_of(self, points: np.ndarray) -> float:
        P = points @ self.R.T
        ext = np.maximum(P.max(axis=0) - P.min(axis=0), 1e-12)
        return float(ext[1] / ext[0])

    def project(self, V: np.ndarray, ss: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """(pixel coordinates (n,2) at supersampling ``ss``, depth (n,), smaller = nearer)."""
        P = V @ self.R.T - self.center
        x = (P[:, 0] * self.scale + 0.5 * self.width) * ss
        y = (0.5 * self.height - P[:, 1] * self.scale) * ss
        return np.column_stack([x, y]), -P[:, 2]

    def view_dir(self) -> np.ndarray:
        """Unit vector from the model towards the viewer, in world coordinates."""
        return self.R[2]

    def camera(self) -> "Camera":
        """The :class:`Camera` of this view (for :func:`render`)."""
        center = self.R.T @ self.center
        return Camera(tuple(center + self.R[2]), tuple(center), tuple(self.R[1]), self.height / self.scale)


def _vec3(name: str, value) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise OptionError(f"camera {name} must be 3 numbers, got {value!r}") from None
    if v.shape != (3,) or not np.isfinite(v).all():
        raise OptionError(f"camera {name} must be 3 finite numbers, got {value!r}")
    return v


@dataclass(frozen=True)
class Camera:
    """An orthographic camera: it looks from ``eye`` towards ``center`` with ``up`` pointing
    up in the picture; the image height spans ``view_height`` model units (None: fitted to
    the mesh drawn, about ``center``). Only the direction from ``eye`` to ``center`` matters,
    not the distance. Pass one Camera to several :func:`render` calls to draw them alike
    (a mesh and its LODs); :meth:`fit` makes one that frames a mesh."""

    eye: tuple
    center: tuple
    up: tuple = (0.0, 1.0, 0.0)
    view_height: float | None = None

    def __post_init__(self):
        eye, center, up = _vec3("eye", self.eye), _vec3("center", self.center), _vec3("up", self.up)
        d = eye - center
        if np.linalg.norm(d) == 0:
            raise OptionError("camera eye and center are the same point")
        if np.linalg.norm(np.cross(up, d)) <= 1e-9 * np.linalg.norm(up) * np.linalg.norm(d):
            raise OptionError(f"camera up {up.tolist()} is parallel to the viewing direction (or zero)")
        if self.view_height is not None and not (np.isfinite(self.view_height) and self.view_height > 0):
            raise OptionError(f"camera view_height must be a positive number, got {self.view_height!r}")
        object.__setattr__(self, "eye", tuple(map(float, eye)))
        object.__setattr__(self, "center", tuple(map(float, center)))
        object.__setattr__(self, "up", tuple(map(float, up)))
        if self.view_height is not None:
            object.__setattr__(self, "view_height", float(self.view_height))

    @classmethod
    def fit(cls, mesh, width: int = 640, height: int = 480, *, azimuth: float = 30.0, elevation: float = 20.0,
            up: str = "y", margin: float = 0.06) -> "Camera":
        """A camera that frames ``mesh`` (a Mesh, Open3D mesh, (vertices, faces) or an (n, 3)
        point array) in a width x height image, seen from ``azimuth`` degrees around the
        ``up`` axis ("y" or "z") and ``elevation`` degrees above the horizon."""
        width, height = _check_size(width, height)
        if isinstance(mesh, np.ndarray):
            pts = _vec_points(mesh)
        else:
            pts = _used_points(_as_mesh(mesh))
        return View.fit(pts, width, height, azimuth, elevation, up, margin).camera()

    def rotation(self) -> np.ndarray:
        """World -> camera rotation (rows x right, y up, z towards the eye)."""
        eye, center, up = (np.asarray(v) for v in (self.eye, self.center, self.up))
        z = (eye - center) / np.linalg.norm(eye - center)
        x = np.cross(up, z)
        x /= np.linalg.norm(x)
        return np.stack([x, np.cross(z, x), z])

    def view(self, points: np.ndarray, width: int, height: int, margin: float = 0.06) -> View:
        """The :class:`View` for an image of this size (``points`` fit the scale when
        ``view_height`` is None)."""
        R = self.rotation()
        c = R @ np.asarray(self.center)
        if self.view_height is not None:
            return View(R, c, height / self.view_height, int(width), int(height))
        P = np.asarray(points) @ R.T - c
        half = np.maximum(np.abs(P[:, :2]).max(axis=0), 1e-12) if len(P) else np.ones(2)
        scale = min(width * (1 - 2 * margin) / (2 * half[0]), height * (1 - 2 * margin) / (2 * half[1]))
        return View(R, c, float(scale), int(width), int(height))


def _vec_points(points) -> np.ndarray:
    P = np.asarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or P.shape[0] == 0 or not np.isfinite(P).all():
        raise MeshError(f"points must be a non-empty finite (n, 3) array, got shape {P.shape}")
    return P


def _used_points(mesh: Mesh) -> np.ndarray:
    if mesh.n_faces == 0:
        raise MeshError("the mesh has no faces; nothing to draw")
    return mesh.vertices[np.unique(mesh.faces)]


def _as_mesh(mesh) -> Mesh:
    if isinstance(mesh, Mesh):
        return mesh
    if type(mesh).__name__ == "TriangleMesh" and hasattr(mesh, "triangles"):
        if hasattr(mesh, "to_legacy"):             # open3d.t.geometry.TriangleMesh
            mesh = mesh.to_legacy()
        return Mesh.from_open3d(mesh)
    if isinstance(mesh, tuple) and len(mesh) == 2:
        return Mesh(*mesh)
    raise MeshError(f"expected a lodkit.Mesh, an open3d TriangleMesh or (vertices, faces), got {type(mesh).__name__}")


def _check_size(width, height) -> tuple[int, int]:
    for name, v in (("width", width), ("height", height)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 16384:
            raise OptionError(f"{name} must be an integer from 1 to 16384, got {v!r}")
    return int(width), int(height)


# --------------------------------------------------------------------------------------
# the numpy rasteriser
# --------------------------------------------------------------------------------------

@dataclass
class Style:
    """How :func:`draw` draws a mesh. Colours are RGB floats in [0, 1]."""

    color: tuple = DEFAULT_COLOR
    vertex_colors: np.ndarray | None = None      # (n,3) in [0,1]
    uvs: np.ndarray | None = None                 # (n,2), with ``texture``
    texture: np.ndarray | None = None             # (h,w,3) float [0,1]
    normals: np.ndarray | None = None             # (n,3): smooth shading by interpolated normals
    wire: tuple | None = None                     # wireframe colour, or None
    wire_width: float = 0.6                       # half-width in output pixels
    edges: np.ndarray | None = None               # (k,2) vertex pairs drawn in ``edge_color``
    edge_color: tuple = (0.85, 0.1, 0.1)
    edge_width: float = 1.1
    points: np.ndarray | None = None              # vertex indices drawn as dots (visible ones only)
    point_color: tuple = (0.85, 0.1, 0.1)
    point_radius: float = 1.6
    ambient: float = AMBIENT
    background: tuple = (1.0, 1.0, 1.0)
    light: np.ndarray | None = None               # camera-space direction to the light
    extra: dict = field(default_factory=dict)


def _edge_keys(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    return lo.astype(np.int64) * n + hi


def rasterize(V: np.ndarray, F: np.ndarray, cam: View, ss: int = 2, max_pairs: int = 3_000_000):
    """Z-buffer visibility: (face id (H,W) int64, -1 = background; barycentric weights (H,W,3);
    vertex screen xy (n,2); depth buffer (H,W), inf = background; vertex depth (n,)).

    At ``ss`` x the camera's resolution. Every face whose screen bounding box covers a pixel
    centre gets a candidate (face, pixel) pair (generated with ``np.repeat``, in chunks of
    about ``max_pairs``); the barycentric weights decide inside; per pixel the nearest
    candidate wins (sort by pixel then depth). Both sides of a face are drawn.
    """
    W, H = cam.width * ss, cam.height * ss
    F = np.asarray(F, dtype=np.int64)
    xy, depth = cam.project(np.asarray(V, dtype=np.float64), ss)
    zbuf = np.full(W * H, np.inf)
    fbuf = np.full(W * H, -1, dtype=np.int64)
    if len(F) == 0:
        return fbuf.reshape(H, W), np.zeros((H, W, 3)), xy, zbuf.reshape(H, W), depth
    T = xy[F]                                             # (m,3,2)
    x0 = np.clip(np.floor(T[..., 0].min(axis=1) - 0.5), 0, W - 1).astype(np.int64)
    x1 = np.clip(np.ceil(T[..., 0].max(axis=1) - 0.5), 0, W - 1).astype(np.int64)
    y0 = np.clip(np.floor(T[..., 1].min(axis=1) - 0.5), 0, H - 1).astype(np.int64)
    y1 = np.clip(np.ceil(T[..., 1].max(axis=1) - 0.5), 0, H - 1).astype(np.int64)
    area2 = ((T[:, 1, 0] - T[:, 0, 0]) * (T[:, 2, 1] - T[:, 0, 1])
             - (T[:, 2, 0] - T[:, 0, 0]) * (T[:, 1, 1] - T[:, 0, 1]))
    offscreen = ((T[..., 0].max(axis=1) < 0) | (T[..., 0].min(axis=1) > W) | (T[..., 1].max(axis=1) < 0)
                 | (T[..., 1].min(axis=1) > H))
    live = np.flatnonzero((np.abs(area2) > 1e-12) & ~offscreen)
    bw = x1 - x0 + 1
    count = bw * (y1 - y0 + 1)
    cum = np.cumsum(count[live])
    start = 0
    while start < len(live):
        base = cum[start - 1] if start else 0
        stop = int(np.searchsorted(cum, base + max_pairs, side="right"))
        stop = max(stop, start + 1)
        fs = live[start:stop]
        start = stop
        c = count[fs]
        f = np.repeat(fs, c)
        first = np.repeat(np.cumsum(c) - c, c)
        k = np.arange(len(f)) - first
        px = x0[f] + k % bw[f]
        py = y0[f] + k // bw[f]
        cx, cy = px + 0.5, py + 0.5
        t = T[f]
        a2 = area2[f]
        w0 = ((t[:, 1, 0] - cx) * (t[:, 2, 1] - cy) - (t[:, 2, 0] - cx) * (t[:, 1, 1] - cy)) / a2
        w1 = ((t[:, 2, 0] - cx) * (t[:, 0, 1] - cy) - (t[:, 0, 0] - cx) * (t[:, 2, 1] - cy)) / a2
        w2 = 1.0 - w0 - w1
        inside = (w0 >= -1e-9) & (w1 >= -1e-9) & (w2 >= -1e-9)
        f, px, py, w0, w1, w2 = f[inside], px[inside], py[inside], w0[inside], w1[inside], w2[inside]
        d = w0 * depth[F[f, 0]] + w1 * depth[F[f, 1]] + w2 * depth[F[f, 2]]
        pix = py * W + px
        order = np.lexsort((d, pix))
        pix, d, f = pix[order], d[order], f[order]
        firsts = np.r_[True, pix[1:] != pix[:-1]]
        pix, d, f = pix[firsts], d[firsts], f[firsts]
        better = d < zbuf[pix]
        zbuf[pix[better]] = d[better]
        fbuf[pix[better]] = f[better]
    # weights of the winners, recomputed per visible pixel
    wts = np.zeros((H * W, 3))
    vis = np.flatnonzero(fbuf >= 0)
    if len(vis):
        f = fbuf[vis]
        cx = vis % W + 0.5
        cy = vis // W + 0.5
        t = T[f]
        a2 = area2[f]
        w0 = ((t[:, 1, 0] - cx) * (t[:, 2, 1] - cy) - (t[:, 2, 0] - cx) * (t[:, 1, 1] - cy)) / a2
        w1 = ((t[:, 2, 0] - cx) * (t[:, 0, 1] - cy) - (t[:, 0, 0] - cx) * (t[:, 2, 1] - cy)) / a2
        wts[vis] = np.column_stack([w0, w1, 1.0 - w0 - w1])
    return fbuf.reshape(H, W), wts.reshape(H, W, 3), xy, zbuf.reshape(H, W), depth


def _sample_texture(tex: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Bilinear lookup; uv (n,2) with v up (OBJ convention), wrapping."""
    h, w = tex.shape[:2]
    x = (uv[:, 0] % 1.0) * w - 0.5
    y = (1.0 - (uv[:, 1] % 1.0)) * h - 0.5
    x0 = np.floor(x).astype(np.int64)
    y0 = np.floor(y).astype(np.int64)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x0w, x1w = x0 % w, (x0 + 1) % w
    y0c, y1c = np.clip(y0, 0, h - 1), np.clip(y0 + 1, 0, h - 1)
    return ((1 - fx) * (1 - fy) * tex[y0c, x0w] + fx * (1 - fy) * tex[y0c, x1w]
            + (1 - fx) * fy * tex[y1c, x0w] + fx * fy * tex[y1c, x1w])


def _shade(base: np.ndarray, normals_cam: np.ndarray, ambient: float, light=None) -> np.ndarray:
    """Lit colours: ``base`` (p,3) under two-sided Lambert from ``light`` (camera space) with
    ``ambient``, plus a weak specular highlight (Blinn, exponent 40, 0.15) that keeps flat
    regions readable. ``normals_cam`` (p,3) need not be unit length."""
    nrm = normals_cam / np.maximum(np.linalg.norm(normals_cam, axis=1, keepdims=True), 1e-30)
    L = np.asarray(LIGHT if light is None else light, dtype=np.float64)
    L = L / np.linalg.norm(L)
    lam = np.abs(nrm @ L)
    hv = L + np.array([0.0, 0.0, 1.0])
    hv /= np.linalg.norm(hv)
    spec = np.abs(nrm @ hv) ** 40 * 0.15
    return base * (ambient + (1 - ambient) * lam)[:, None] + spec[:, None]


def draw(V: np.ndarray, F: np.ndarray, cam: View, style: Style | None = None, ss: int = 2) -> np.ndarray:
    """An (height, width, 3) uint8 image of the mesh drawn by the numpy rasteriser (see
    :class:`Style`), at ``ss`` x supersampling box-filtered down."""
    style = style or Style()
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    fb, wts, xy, zbuf, depth = rasterize(V, F, cam, ss)
    H, W = fb.shape
    img = np.empty((H, W, 3))
    img[:] = style.background
    vis = fb >= 0
    if vis.any():
        f = fb[vis]
        w = wts[vis]
        corners = F[f]                                                       # (p,3)
        # normal per pixel (camera space), two-sided
        if style.normals is not None:
            nrm = np.einsum("pk,pkj->pj", w, np.asarray(style.normals)[corners])
        else:
            a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
            fn = np.cross(b - a, c - a)
            nrm = fn[f]
        nrm = nrm @ cam.R.T
        if style.texture is not None and style.uvs is not None:
            uv = np.einsum("pk,pkj->pj", w, np.asarray(style.uvs)[corners])
            base = _sample_texture(style.texture, uv)
        elif style.vertex_colors is not None:
            base = np.einsum("pk,pkj->pj", w, np.asarray(style.vertex_colors)[:, :3][corners])
        else:
            base = np.broadcast_to(np.asarray(style.color, dtype=np.float64), (len(f), 3))
        col = _shade(base, nrm, style.ambient, style.light)
        # distance (output pixels) from the pixel to each edge of its face; edge i is opposite corner i
        if style.wire is not None or style.edges is not None:
            t = xy[corners]                                                   # (p,3,2)
            ln = np.stack([np.linalg.norm(t[:, 1] - t[:, 2], axis=1), np.linalg.norm(t[:, 2] - t[:, 0], axis=1),
                           np.linalg.norm(t[:, 0] - t[:, 1], axis=1)], axis=1)
            a2 = np.abs((t[:, 1, 0] - t[:, 0, 0]) * (t[:, 2, 1] - t[:, 0, 1])
                        - (t[:, 2, 0] - t[:, 0, 0]) * (t[:, 1, 1] - t[:, 0, 1]))
            dist = np.abs(w) * a2[:, None] / np.maximum(ln, 1e-12) / ss
            if style.wire is not None:
                on = dist.min(axis=1) < style.wire_width
                col[on] = 0.35 * col[on] + 0.65 * np.asarray(style.wire)
            if style.edges is not None and len(style.edges):
                n = len(V)
                keys = np.unique(_edge_keys(style.edges[:, 0], style.edges[:, 1], n))
                fe = np.stack([_edge_keys(F[:, 1], F[:, 2], n), _edge_keys(F[:, 2], F[:, 0], n),
                               _edge_keys(F[:, 0], F[:, 1], n)], axis=1)
                flag = np.isin(fe, keys)[f]                                   # (p,3)
                on = (flag & (dist < style.edge_width)).any(axis=1)
                col[on] = np.asarray(style.edge_color)
        img[vis] = np.clip(col, 0.0, 1.0)
    if style.points is not None and len(style.points):
        pts = np.asarray(style.points, dtype=np.int64)
        r = style.point_radius * ss
        R = int(np.ceil(r))
        oy, ox = np.mgrid[-R:R + 1, -R:R + 1]
        disc = (ox ** 2 + oy ** 2) <= r * r
        ox, oy = ox[disc], oy[disc]
        px = np.floor(xy[pts, 0]).astype(np.int64)
        py = np.floor(xy[pts, 1]).astype(np.int64)
        inb = (px >= 0) & (px < W) & (py >= 0) & (py < H)
        pts, px, py = pts[inb], px[inb], py[inb]
        # visible: not behind the surface at its own pixel (tolerance: 1% of the depth range)
        tol = 0.01 * max(float(np.ptp(depth)), 1e-12)
        seen = depth[pts] <= zbuf[py, px] + tol
        px, py = px[seen], py[seen]
        X = (px[:, None] + ox[None, :]).ravel()
        Y = (py[:, None] + oy[None, :]).ravel()
        ok = (X >= 0) & (X < W) & (Y >= 0) & (Y < H)
        img[Y[ok], X[ok]] = style.point_color
    return _downsample(img, ss)


def _downsample(img: np.ndarray, ss: int) -> np.ndarray:
    """Box filter an (H*ss, W*ss, 3) float image in [0, 1] to uint8 (H, W, 3)."""
    H, W = img.shape[0] // ss, img.shape[1] // ss
    img = img.reshape(H, ss, W, ss, 3).mean(axis=(1, 3))
    return (np.clip(img, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


# --------------------------------------------------------------------------------------
# the Open3D backend
# --------------------------------------------------------------------------------------

_PROBE = r"""
import sys
import open3d as o3d
o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
r = o3d.visualization.rendering.OffscreenRenderer(8, 8)
m = o3d.geometry.TriangleMesh.create_tetrahedron()
mat = o3d.visualization.rendering.MaterialRecord()
mat.shader = "defaultUnlit"
r.scene.add_geometry("m", m, mat)
r.setup_camera(60.0, [0, 0, 0], [0, 0, 3], [0, 1, 0])
img = r.render_to_image()
r.scene.clear_geometry()
del r
sys.stderr.write("LODKIT-PROBE-OK\n")
"""

_lock = threading.RLock()
_state: dict = {"probed": None, "reason": None, "software": False, "renderer": None, "size": None}


def _probe_open3d() -> tuple[bool, str, bool]:
    """(whether Open3D's OffscreenRenderer can start and draw, why, whether it draws on a
    software device), tried once in a subprocess (a broken driver can abort the process
    instead of raising)."""
    try:
        import open3d  # noqa: F401
    except (ImportError, OSError) as exc:
        return False, f"open3d cannot be imported: {exc}", False
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.SubprocessError) as exc:
        return False, f"the probe subprocess failed: {exc}", False
    if proc.returncode == 0 and "LODKIT-PROBE-OK" in proc.stderr:
        banner = proc.stdout + proc.stderr
        if "llvmpipe" in banner or "software device" in banner or "SwiftShader" in banner:
            return True, ("Open3D's OffscreenRenderer draws here, but only through a software Vulkan (llvmpipe), "
                          "where Filament stalls on some frames for minutes; the numpy rasteriser is the default "
                          "(backend='open3d' or LODKIT_RENDER_BACKEND=open3d uses Open3D anyway)"), True
        return True, "Open3D's OffscreenRenderer starts and draws", False
    lines = [ln for ln in (proc.stderr + proc.stdout).splitlines() if "rror" in ln or "what()" in ln]
    detail = lines[-1].strip() if lines else (proc.stderr.strip().splitlines() or ["no output"])[-1]
    return False, f"Open3D's OffscreenRenderer cannot start (exit code {proc.returncode}): {detail[:300]}", False


def backend_info() -> dict:
    """``{"backend": "open3d" | "numpy", "reason": str}``: what :func:`render` uses when no
    backend is asked for, and why. The first call probes Open3D (about 2 s) unless the
    environment variable ``LODKIT_RENDER_BACKEND`` names a backend."""
    with _lock:
        forced = os.environ.get("LODKIT_RENDER_BACKEND", "").strip().lower()
        if forced in BACKENDS and _state["probed"] is None:
            return {"backend": forced, "reason": f"LODKIT_RENDER_BACKEND={forced}"}
        if forced not in BACKENDS + ("", "auto"):
            raise OptionError(f"LODKIT_RENDER_BACKEND must be one of {', '.join(BACKENDS)} or auto, got {forced!r}")
        if _state["probed"] is None:
            _state["probed"], _state["reason"], _state["software"] = _probe_open3d()
        name = "open3d" if _state["probed"] and not _state["software"] and forced != "numpy" else "numpy"
        return {"backend": name, "reason": _state["reason"]}


def backend() -> str:
    """``"open3d"`` or ``"numpy"``: the backend :func:`render` uses by default (see
    :func:`backend_info` for why)."""
    return backend_info()["backend"]


class _StdoutToNull:
    """Send file descriptor 1 to /dev/null for a moment: Filament prints its start-up
    banner (engine, Vulkan device, ...) with printf, which would garble a program's output."""

    def __enter__(self):
        try:
            sys.stdout.flush()
            self.saved = os.dup(1)
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, 1)
            os.close(null)
        except (OSError, ValueError, AttributeError):
            self.saved = None
        return self

    def __exit__(self, *exc):
        if self.saved is not None:
            os.dup2(self.saved, 1)
            os.close(self.saved)


def _renderer(width: int, height: int):
    """The one OffscreenRenderer, of this size (see the module notes on why only one)."""
    if _state["renderer"] is not None and _state["size"] == (width, height):
        return _state["renderer"]
    _drop_renderer()
    import open3d as o3d

    rendering = o3d.visualization.rendering
    level = o3d.utility.get_verbosity_level()
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    try:
        with _StdoutToNull():
            r = rendering.OffscreenRenderer(width, height)
    finally:
        o3d.utility.set_verbosity_level(level)
    r.scene.view.set_post_processing(False)         # no tone mapping: colours as given
    r.scene.show_skybox(False)
    _state["renderer"], _state["size"] = r, (width, height)
    return r


def _drop_renderer() -> None:
    r = _state["renderer"]
    _state["renderer"], _state["size"] = None, None
    if r is not None:
        try:
            r.scene.clear_geometry()
        except Exception:  # noqa: BLE001 - best effort at shutdown
            pass
        del r


atexit.register(_drop_renderer)


def _wire_ribbons(V, edges, view: View, lift: float, half_width: float = 0.6):
    """Triangles (as a soup: (6k, 3) positions) drawing each edge as a strip ``2 *
    half_width`` output pixels wide facing the camera, lifted towards it by ``lift`` model
    units so the surface under it does not hide it; with their colours. Open3D's line
    shader would do, but on a software Vulkan it is 5-20x slower than the whole mesh."""
    a, b = V[edges[:, 0]], V[edges[:, 1]]
    toward = view.R[2]
    perp = np.cross(toward, b - a)
    length = np.linalg.norm(perp, axis=1, keepdims=True)
    perp = np.divide(perp, length, out=np.zeros_like(perp), where=length > 0) * (half_width / view.scale)
    a, b = a + lift * toward, b + lift * toward
    quads = np.stack([a - perp, b - perp, b + perp, a - perp, b + perp, a + perp], axis=1)
    shade = np.asarray(WIRE_COLOR) * 0.65 + 0.35 * np.asarray(DEFAULT_COLOR) * AMBIENT
    return quads.reshape(-1, 3), np.broadcast_to(shade, (quads.shape[0] * 6, 3))


def _render_open3d(V, F, view: View, corner_colors, wire_edges, background, ss) -> np.ndarray:
    import open3d as o3d

    rendering = o3d.visualization.rendering
    W, H = view.width * ss, view.height * ss
    R = view.R
    P = V @ R.T
    zmin, zmax = float(P[:, 2].min()), float(P[:, 2].max())
    depth = max(zmax - zmin, 1e-9 * max(1.0, float(np.abs(P).max())))
    hw, hh = 0.5 * view.width / view.scale, 0.5 * view.height / view.scale
    # the eye 2 gaps in front of the nearest point; near and far planes one gap clear of the
    # mesh (and of the wire ribbons, lifted towards the eye by 0.4% of the view height)
    gap = 0.5 * depth + 0.01 * hh
    cx, cy = float(view.center[0]), float(view.center[1])
    eye = R.T @ np.array([cx, cy, zmax + 2 * gap])
    target = R.T @ np.array([cx, cy, zmin])

    corners = F.reshape(-1)
    positions, colors = V[corners], np.clip(corner_colors, 0.0, 1.0)
    if wire_edges is not None and len(wire_edges):
        ribbons, ribbon_colors = _wire_ribbons(V, wire_edges, view, lift=0.002 * 2 * hh)
        positions = np.concatenate([positions, ribbons])
        colors = np.concatenate([colors, ribbon_colors])
    soup = o3d.geometry.TriangleMesh()
    soup.vertices = o3d.utility.Vector3dVector(positions)
    soup.triangles = o3d.utility.Vector3iVector(np.arange(len(positions), dtype=np.int32).reshape(-1, 3))
    soup.vertex_colors = o3d.utility.Vector3dVector(colors)
    mat = rendering.MaterialRecord()
    mat.shader = "defaultUnlit"
    r = _renderer(W, H)
    try:
        r.scene.clear_geometry()
        r.scene.set_background([*map(float, background), 1.0])
        r.scene.add_geometry("mesh", soup, mat)
        cam = r.scene.camera
        cam.look_at(target, eye, R[1])
        cam.set_projection(rendering.Camera.Projection.Ortho, -hw, hw, -hh, hh, gap, 3 * gap + depth + gap)
        img = np.array(r.render_to_image(), dtype=np.float64, copy=True)
    finally:
        r.scene.clear_geometry()
    if img.shape[:2] != (H, W):
        raise RenderError(f"Open3D returned a {img.shape} image for a {W}x{H} renderer")
    return _downsample(img[..., :3] / 255.0, ss)


# --------------------------------------------------------------------------------------
# render
# --------------------------------------------------------------------------------------

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
    """An (height, width, 3) uint8 picture of ``mesh`` (a Mesh, an Open3D TriangleMesh or
    (vertices, faces)), drawn headless.

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
    m = _as_mesh(mesh)
    width, height = _check_size(width, height)
    bg = _rgb("background", background)
    if shading not in ("flat", "smooth"):
        raise OptionError(f"shading must be 'flat' or 'smooth', got {shading!r}")
    if isinstance(supersample, bool) or not isinstance(supersample, (int, np.integer)) or not 1 <= supersample <= 4:
        raise OptionError(f"supersample must be an integer from 1 to 4, got {supersample!r}")
    if camera is not None and not isinstance(camera, Camera):
        raise OptionError(f"camera must be a lodkit.render.Camera or None, got {type(camera).__name__}")
    if backend not in (None,) + BACKENDS:
        raise OptionError(f"backend must be one of {', '.join(BACKENDS)} or None, got {backend!r}")
    base = _vertex_colors(m, colors)
    pts = _used_points(m)
    view = (camera or Camera.fit(pts, width, height)).view(pts, width, height)
    V = m.vertices
    F = m.faces.astype(np.int64)
    normals = None
    if shading == "smooth":
        normals = m.normals if m.normals is not None else _vertex_normals(V, F)

    chosen = backend or backend_info()["backend"]
    if chosen == "open3d":
        if backend == "open3d":
            with _lock:
                if _state["probed"] is None and os.environ.get("LODKIT_RENDER_BACKEND", "").lower() != "open3d":
                    _state["probed"], _state["reason"], _state["software"] = _probe_open3d()
                if _state["probed"] is False:
                    raise RenderError(_state["reason"])
        if normals is not None:
            nc = normals[F.reshape(-1)] @ view.R.T
        else:
            fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]) @ view.R.T
            nc = np.repeat(fn, 3, axis=0)
        corner_base = (np.broadcast_to(np.asarray(DEFAULT_COLOR), (F.size, 3)) if base is None
                       else base[F.reshape(-1)])
        corner_colors = _shade(corner_base, nc, AMBIENT)
        try:
            with _lock:
                return _render_open3d(V, F, view, corner_colors, _unique_edges(F) if wireframe else None, bg,
                                      int(supersample))
        except Exception as exc:  # noqa: BLE001 - any failure of the C++ side
            reason = f"Open3D's renderer failed: {type(exc).__name__}: {exc}"
            if backend == "open3d":
                raise RenderError(reason) from exc
            with _lock:
                _drop_renderer()
                _state["probed"], _state["reason"] = False, reason
            warnings.warn(f"{reason}; drawing with the numpy rasteriser from now on", RuntimeWarning, stacklevel=2)
    style = Style(vertex_colors=base, normals=normals, wire=WIRE_COLOR if wireframe else None,
                  background=tuple(bg))
    return draw(V, F, view, style, int(supersample))


# --------------------------------------------------------------------------------------
# text, contact sheets, colour bars
# --------------------------------------------------------------------------------------

# A 5x7 pixel font (rows top to bottom, 5 bits each, most significant = left): digits,
# capitals (lower case is drawn as capitals) and some punctuation; "?" for the rest.
_GLYPHS = {
    "0": (14, 17, 19, 21, 25, 17, 14), "1": (4, 12, 4, 4, 4, 4, 14), "2": (14, 17, 1, 2, 4, 8, 31),
    "3": (31, 2, 4, 2, 1, 17, 14), "4": (2, 6, 10, 18, 31, 2, 2), "5": (31, 16, 30, 1, 1, 17, 14),
    "6": (6, 8, 16, 30, 17, 17, 14), "7": (31, 1, 2, 4, 8, 8, 8), "8": (14, 17, 17, 14, 17, 17, 14),
    "9": (14, 17, 17, 15, 1, 2, 12),
    "A": (14, 17, 17, 31, 17, 17, 17), "B": (30, 17, 17, 30, 17, 17, 30), "C": (14, 17, 16, 16, 16, 17, 14),
    "D": (28, 18, 17, 17, 17, 18, 28), "E": (31, 16, 16, 30, 16, 16, 31), "F": (31, 16, 16, 30, 16, 16, 16),
    "G": (14, 17, 16, 23, 17, 17, 15), "H": (17, 17, 17, 31, 17, 17, 17), "I": (14, 4, 4, 4, 4, 4, 14),
    "J": (7, 2, 2, 2, 2, 18, 12), "K": (17, 18, 20, 24, 20, 18, 17), "L": (16, 16, 16, 16, 16, 16, 31),
    "M": (17, 27, 21, 21, 17, 17, 17), "N": (17, 17, 25, 21, 19, 17, 17), "O": (14, 17, 17, 17, 17, 17, 14),
    "P": (30, 17, 17, 30, 16, 16, 16), "Q": (14, 17, 17, 17, 21, 18, 13), "R": (30, 17, 17, 30, 20, 18, 17),
    "S": (15, 16, 16, 14, 1, 1, 30), "T": (31, 4, 4, 4, 4, 4, 4), "U": (17, 17, 17, 17, 17, 17, 14),
    "V": (17, 17, 17, 17, 17, 10, 4), "W": (17, 17, 17, 21, 21, 21, 10), "X": (17, 17, 10, 4, 10, 17, 17),
    "Y": (17, 17, 17, 10, 4, 4, 4), "Z": (31, 1, 2, 4, 8, 16, 31),
    " ": (0, 0, 0, 0, 0, 0, 0), ".": (0, 0, 0, 0, 0, 12, 12), ",": (0, 0, 0, 0, 12, 4, 8),
    "-": (0, 0, 0, 31, 0, 0, 0), "+": (0, 4, 4, 31, 4, 4, 0), "%": (24, 25, 2, 4, 8, 19, 3),
    ":": (0, 12, 12, 0, 12, 12, 0), "=": (0, 0, 31, 0, 31, 0, 0), "(": (2, 4, 8, 8, 8, 4, 2),
    ")": (8, 4, 2, 2, 2, 4, 8), "/": (0, 1, 2, 4, 8, 16, 0), "_": (0, 0, 0, 0, 0, 0, 31),
    "?": (14, 17, 1, 2, 4, 0, 4), "'": (4, 4, 8, 0, 0, 0, 0), "<": (2, 4, 8, 16, 8, 4, 2),
    ">": (8, 4, 2, 1, 2, 4, 8), "#": (10, 10, 31, 10, 31, 10, 10), "[": (14, 8, 8, 8, 8, 8, 14),
    "]": (14, 2, 2, 2, 2, 2, 14), "*": (0, 4, 21, 14, 21, 4, 0), "|": (4, 4, 4, 4, 4, 4, 4),
}
_GLYPH_BITS = {k: np.array([[(row >> (4 - i)) & 1 for i in range(5)] for row in v], dtype=bool)
               for k, v in _GLYPHS.items()}


def _text_mask(text: str, scale: int) -> np.ndarray:
    """Boolean (7*scale, (6*len - 1)*scale) mask of ``text`` in the 5x7 font."""
    if not text:
        return np.zeros((7 * scale, 0), dtype=bool)
    cells = []
    for ch in text:
        g = _GLYPH_BITS.get(ch.upper(), _GLYPH_BITS["?"])
        cells += [g, np.zeros((7, 1), dtype=bool)]
    mask = np.concatenate(cells[:-1], axis=1)
    return np.kron(mask, np.ones((scale, scale), dtype=bool))


def text_size(text: str, scale: int = 2) -> tuple[int, int]:
    """(height, width) in pixels of ``text`` drawn by :func:`draw_text`."""
    return 7 * scale, max(0, (6 * len(text) - 1) * scale)


def draw_text(image: np.ndarray, text: str, x: int, y: int, color=(30, 30, 30), scale: int = 2) -> np.ndarray:
    """Write ``text`` into ``image`` (H, W, 3) uint8 in place with its top-left corner at
    (x, y), in a built-in 5x7 pixel font magnified ``scale`` times (lower case comes out as
    capitals); what falls outside the image is cut. Returns ``image``."""
    mask = _text_mask(str(text), int(scale))
    h, w = mask.shape
    H, W = image.shape[:2]
    x0, y0 = max(0, x), max(0, y)
    x1, y1 = min(W, x + w), min(H, y + h)
    if x1 > x0 and y1 > y0:
        sub = mask[y0 - y:y1 - y, x0 - x:x1 - x]
        image[y0:y1, x0:x1][sub] = np.asarray(color, dtype=np.uint8)
    return image


def _check_image(name: str, img) -> np.ndarray:
    a = np.asarray(img)
    if a.dtype != np.uint8 or a.ndim != 3 or a.shape[2] != 3 or a.shape[0] == 0 or a.shape[1] == 0:
        raise OptionError(f"{name} must be a non-empty (H, W, 3) uint8 image, got {a.dtype} {a.shape}")
    return a


def contact_sheet(images, pad: int = 8, *, labels=None, background=(255, 255, 255),
                  label_scale: int = 2) -> np.ndarray:
    """A grid of images: ``images`` is a list of rows, each a list of (H, W, 3) uint8
    images (None leaves a cell empty; a flat list of images is one row). Each column is as
    wide as its widest image and each row as tall as its tallest; images are centred in
    their cells, with ``pad`` pixels around every cell. ``labels`` (same nesting, str or
    None) are written over the cells in the built-in pixel font."""
    if isinstance(images, np.ndarray) or (len(images) and isinstance(images[0], np.ndarray)):
        images = [list(images)]
        if labels is not None and (not len(labels) or isinstance(labels[0], (str, type(None)))):
            labels = [list(labels)]
    rows = [list(r) for r in images]
    if not rows or not any(len(r) for r in rows):
        raise OptionError("contact_sheet needs at least one image")
    if isinstance(pad, bool) or not isinstance(pad, (int, np.integer)) or pad < 0:
        raise OptionError(f"pad must be a non-negative integer, got {pad!r}")
    n_cols = max(len(r) for r in rows)
    cells = [[None if c is None else _check_image(f"image [{i}][{j}]", c) for j, c in enumerate(r)]
             for i, r in enumerate(rows)]
    if labels is not None:
        if len(labels) != len(rows) or any(len(lr) != len(r) for lr, r in zip(labels, rows)):
            raise OptionError("labels must have the same rows and columns as images")
    col_w = [max((c.shape[1] for r in cells if j < len(r) and (c := r[j]) is not None), default=0)
             for j in range(n_cols)]
    row_h = [max((c.shape[0] for c in r if c is not None), default=0) for r in cells]
    label_h = 7 * label_scale + 6 if labels is not None and any(any(x for x in lr) for lr in labels) else 0
    H = sum(row_h) + len(rows) * (label_h + pad) + pad
    W = sum(col_w) + n_cols * pad + pad
    sheet = np.empty((H, W, 3), dtype=np.uint8)
    sheet[:] = np.asarray(background, dtype=np.uint8)
    y = pad
    for i, r in enumerate(cells):
        x = pad
        for j in range(n_cols):
            c = r[j] if j < len(r) else None
            if labels is not None and j < len(labels[i]) and labels[i][j]:
                draw_text(sheet, str(labels[i][j]), x + 2, y + 2, scale=label_scale)
            if c is not None:
                oy = y + label_h + (row_h[i] - c.shape[0]) // 2
                ox = x + (col_w[j] - c.shape[1]) // 2
                sheet[oy:oy + c.shape[0], ox:ox + c.shape[1]] = c
            x += col_w[j] + pad
        y += row_h[i] + label_h + pad
    return sheet


def colorbar(vmin: float, vmax: float, height: int = 240, width: int = 18, *, label: str | None = None,
             ticks: int = 5, scale: int = 2, background=(255, 255, 255)) -> np.ndarray:
    """A vertical colour bar of :func:`colormap` from ``vmin`` (bottom) to ``vmax`` (top) with
    ``ticks`` values written beside it and an optional ``label`` over it: (H, W, 3) uint8."""
    if not (np.isfinite(vmin) and np.isfinite(vmax)) or vmax < vmin:
        raise OptionError(f"colorbar range must be finite with vmin <= vmax, got [{vmin}, {vmax}]")
    width, height = _check_size(width, height)
    values = np.linspace(vmax, vmin, height)
    bar = (colormap(values, vmin, vmax) * 255 + 0.5).astype(np.uint8)
    th = 7 * scale
    tick_vals = np.linspace(vmax, vmin, max(2, int(ticks)))
    texts = [f"{v:.3g}" for v in tick_vals]
    tw = max(text_size(t, scale)[1] for t in texts)
    top = th + 8 if label else th // 2 + 2
    W = max(width + 6 + tw + 4, text_size(label or "", scale)[1] + 4)
    img = np.empty((top + height + th // 2 + 2, W, 3), dtype=np.uint8)
    img[:] = np.asarray(background, dtype=np.uint8)
    img[top:top + height, 0:width] = bar[:, None, :]
    if label:
        draw_text(img, label, 0, 2, scale=scale)
    for k, t in enumerate(texts):
        yk = top + int(round(k * (height - 1) / (len(texts) - 1)))
        img[yk, width:width + 4] = 30
        draw_text(img, t, width + 6, yk - th // 2, scale=scale)
    return img


# --------------------------------------------------------------------------------------
# files
# --------------------------------------------------------------------------------------

def write_png(path, image) -> Path:
    """Write an (H, W, 3) uint8 image to ``path`` (a .png name) through Open3D's image
    writer. The file is written under a temporary name in the same directory and renamed,
    so a failure never leaves a half-written file. Returns the path."""
    a = np.ascontiguousarray(_check_image("image", image))
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise OptionError(f"write_png writes .png files, got {path.name!r}")
    if not path.parent.is_dir():
        raise ImageIOError(f"cannot write {path}: directory {path.parent} does not exist")
    try:
        import open3d as o3d
    except (ImportError, OSError) as exc:
        raise ImageIOError(f"cannot write {path}: open3d is needed to write PNG files ({exc})") from None
    tmp = path.parent / f".{path.stem}.{secrets.token_hex(4)}.tmp.png"
    try:
        ok = o3d.io.write_image(str(tmp), o3d.geometry.Image(a))
        if not ok or not tmp.exists():
            raise ImageIOError(f"cannot write {path}: Open3D's PNG writer failed")
        os.replace(tmp, path)
    except OSError as exc:
        if isinstance(exc, ImageIOError):
            raise
        raise ImageIOError(f"cannot write {path}: {exc}") from None
    finally:
        if tmp.exists():
            tmp.unlink()
    return path
