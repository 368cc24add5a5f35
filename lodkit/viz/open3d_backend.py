"""The Open3D backend: Open3D's OffscreenRenderer, probed once in a subprocess, one renderer
alive at a time (see the notes of :mod:`lodkit.viz`), the wireframe as camera-facing strips."""
from __future__ import annotations

import atexit
import os
import subprocess
import sys
import threading

import numpy as np

from ..errors import OptionError, RenderError
from .camera import View
from .colors import DEFAULT_COLOR, WIRE_COLOR
from .raster import AMBIENT, downsample

BACKENDS = ("open3d", "numpy")

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
    return downsample(img[..., :3] / 255.0, ss)


def require() -> None:
    """Raise RenderError unless Open3D's renderer can draw here (probing it if not yet done;
    the environment variable LODKIT_RENDER_BACKEND=open3d skips the probe)."""
    with _lock:
        if _state["probed"] is None and os.environ.get("LODKIT_RENDER_BACKEND", "").lower() != "open3d":
            _state["probed"], _state["reason"], _state["software"] = _probe_open3d()
        if _state["probed"] is False:
            raise RenderError(_state["reason"])


def render_open3d(V, F, view: View, corner_colors, wire_edges, background, ss) -> np.ndarray:
    """(height, width, 3) uint8: the triangles ``F`` over ``V`` with shaded ``corner_colors``
    ((3m, 3) in [0, 1]) and the ``wire_edges`` ((k, 2) or None) drawn by Open3D."""
    with _lock:
        return _render_open3d(V, F, view, corner_colors, wire_edges, background, ss)


def give_up(reason: str) -> None:
    """Open3D failed during a call: drop its renderer and use the numpy rasteriser from now on."""
    with _lock:
        _drop_renderer()
        _state["probed"], _state["reason"] = False, reason
