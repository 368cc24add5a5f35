"""Orthographic cameras: the rotation of a view direction, the pixel mapping both backends
draw with (:class:`View`) and the user's :class:`Camera`; the checks of what is drawn."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..adapters import to_mesh
from ..errors import MeshError, OptionError
from ..mesh import Mesh


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
            margin: float = 0.06, zoom: float = 1.0, shift=(0.0, 0.0)) -> View:
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

    @classmethod
    def fit_camera(cls, camera: Camera, points: np.ndarray, width: int, height: int, margin: float = 0.06) -> Camera:
        """``camera``'s direction and up, centred on ``points`` and scaled to frame them."""
        R = camera.rotation()
        P = np.asarray(points, dtype=np.float64) @ R.T
        lo, hi = P.min(axis=0), P.max(axis=0)
        ext = np.maximum(hi - lo, 1e-12)
        s = min(width * (1 - 2 * margin) / ext[0], height * (1 - 2 * margin) / ext[1])
        return cls(R, 0.5 * (lo + hi), float(s), int(width), int(height)).camera()

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

    def camera(self) -> Camera:
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
            up: str = "y", margin: float = 0.06) -> Camera:
        """A camera that frames ``mesh`` (a Mesh, Open3D mesh, (vertices, faces) or an (n, 3)
        point array) in a width x height image, seen from ``azimuth`` degrees around the
        ``up`` axis ("y" or "z") and ``elevation`` degrees above the horizon."""
        width, height = check_size(width, height)
        if isinstance(mesh, np.ndarray):
            pts = points_array(mesh)
        else:
            pts = used_points(as_drawable(mesh))
        return View.fit(pts, width, height, azimuth, elevation, up, margin).camera()

    @classmethod
    def front(cls, mesh, width: int = 640, height: int = 480, *, azimuth: float = 30.0, elevation: float = 20.0,
              margin: float = 0.06) -> Camera:
        """A camera that frames ``mesh`` from the front of its principal axes: it looks along
        the axis in which the mesh is thinnest (so the picture shows its largest outline),
        with the world's +y (else +z) up in the picture, from the side facing +z (else +x:
        the glTF convention is that a model faces +z), then turned ``azimuth`` degrees
        about the picture's up axis and raised ``elevation`` degrees, so the relief shows.
        The scale is fixed from ``mesh``: pass the camera to several :func:`render` calls
        (a mesh and its LODs) and they are drawn alike."""
        width, height = check_size(width, height)
        pts = points_array(mesh) if isinstance(mesh, np.ndarray) else used_points(as_drawable(mesh))
        R0 = principal_frame(pts)
        a, e = np.radians(azimuth), np.radians(elevation)
        d = np.sin(a) * np.cos(e) * R0[0] + np.sin(e) * R0[1] + np.cos(a) * np.cos(e) * R0[2]
        # the turn goes towards the model's front (+z, else +x) when the picture's x axis has a
        # component along it
        ref = np.array([0.0, 0.0, 1.0]) if abs(R0[0, 2]) > 1e-6 else np.array([1.0, 0.0, 0.0])
        if np.dot(R0[0], ref) * np.sin(a) < 0:
            d = -np.sin(a) * np.cos(e) * R0[0] + np.sin(e) * R0[1] + np.cos(a) * np.cos(e) * R0[2]
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        up = R0[1] - np.dot(R0[1], d) * d
        probe = cls(tuple(0.5 * (lo + hi) + d), tuple(0.5 * (lo + hi)), tuple(up))
        return View.fit_camera(probe, pts, width, height, margin)

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


def principal_frame(points: np.ndarray) -> np.ndarray:
    """Rows: picture right, picture up, towards the viewer, for a front view of ``points``.

    The viewing axis is the principal axis of least extent (the eigenvector of the points'
    covariance with the smallest eigenvalue), pointing to the side of +z (else +x, else +y,
    whichever world axis it is closest to); up is the world's +y projected on the picture
    plane, or +z when +y is nearly the viewing axis."""
    P = np.asarray(points, dtype=np.float64)
    C = np.cov((P - P.mean(axis=0)).T) if len(P) > 1 else np.eye(3)
    _, U = np.linalg.eigh(np.atleast_2d(C))
    z = U[:, 0]
    k = int(np.argmax(np.abs(z) * np.array([1.0, 0.999, 1.001])))   # ties: z, then x, then y
    if z[k] < 0:
        z = -z
    up = np.array([0.0, 1.0, 0.0])
    if abs(np.dot(up, z)) > 0.9:
        up = np.array([0.0, 0.0, 1.0])
    y = up - np.dot(up, z) * z
    y /= np.linalg.norm(y)
    return np.stack([np.cross(y, z), y, z])


def points_array(points) -> np.ndarray:
    """``points`` as a non-empty finite (n, 3) float array (MeshError if not)."""
    P = np.asarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or P.shape[0] == 0 or not np.isfinite(P).all():
        raise MeshError(f"points must be a non-empty finite (n, 3) array, got shape {P.shape}")
    return P


def used_points(mesh: Mesh) -> np.ndarray:
    """The positions of the vertices the faces use (MeshError for a mesh without faces)."""
    if mesh.n_faces == 0:
        raise MeshError("the mesh has no faces; nothing to draw")
    return mesh.vertices[np.unique(mesh.faces)]


def as_drawable(mesh) -> Mesh:
    """A lodkit Mesh from any mesh type :func:`lodkit.adapters.coerce` takes, but a path."""
    return to_mesh(mesh)


def check_size(width, height) -> tuple[int, int]:
    """(width, height) as ints from 1 to 16384 (OptionError if not)."""
    for name, v in (("width", width), ("height", height)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 16384:
            raise OptionError(f"{name} must be an integer from 1 to 16384, got {v!r}")
    return int(width), int(height)
