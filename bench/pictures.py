#!/usr/bin/env python
"""Pictures for the metric pages: each paper metric's result next to plain QEM.

    python bench/pictures.py                   # all pictures into docs/metrics/img/
    python bench/pictures.py --only melod_cow,curvature_fandisk --out /tmp/img

Each picture has three panels with one camera: the original, the metric's result and
lodkit ``qem``'s result at the same face count; a label over each panel (face count,
symmetric Metro Hausdorff error as a fraction of the bbox diagonal, bench/metro.py) and a
caption line under them. The simplifications run in worker subprocesses
(bench/fidelity.py ``run_metric_cases``), so a metric that is not available yet gives a
panel saying so instead of stopping the run.

Rendering is headless and needs nothing beyond numpy and Pillow: :func:`render` is a small
vectorised z-buffer rasteriser (orthographic camera, two-sided Lambert shading, flat or
with interpolated vertex normals; vertex colours; texture lookup by uv; hidden-line
wireframe; highlighted edges; visible vertex dots), supersampled 2x and box-filtered.
Open3D's ``OffscreenRenderer`` was the first choice but needs a Vulkan/EGL driver this
machine does not have (``RuntimeError: Failed to load vulkan library!``), and
:func:`open3d_available` says whether it would work.
"""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(HERE))

OUT_DIR = REPO / "docs" / "metrics" / "img"


# --------------------------------------------------------------------------------------
# rasteriser
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
        raise ValueError("up must be 'y' or 'z'")
    return R


@dataclass
class Camera:
    """Orthographic camera: rotation, a centre (camera space) and pixels per model unit."""

    R: np.ndarray
    center: np.ndarray
    scale: float
    width: int
    height: int

    @classmethod
    def fit(cls, points: np.ndarray, width: int, height: int, azimuth=30.0, elevation=20.0, up="y",
            margin: float = 0.06, zoom: float = 1.0, shift=(0.0, 0.0)) -> "Camera":
        """A camera that frames ``points`` (the original's vertices) in a width x height panel.

        ``zoom`` > 1 magnifies about the centre; ``shift`` moves the view centre by fractions
        of the framed extent (x right, y up), to look at a detail.
        """
        R = rotation(azimuth, elevation, up)
        P = points @ R.T
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


@dataclass
class Style:
    """How to draw a mesh. Colours are RGB floats in [0, 1]."""

    color: tuple = (0.72, 0.74, 0.78)
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
    ambient: float = 0.33
    background: tuple = (1.0, 1.0, 1.0)
    light: np.ndarray | None = None               # camera-space direction to the light
    extra: dict = field(default_factory=dict)


def _edge_keys(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    return lo.astype(np.int64) * n + hi


def rasterize(V: np.ndarray, F: np.ndarray, cam: Camera, ss: int = 2, max_pairs: int = 3_000_000):
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


def render(V: np.ndarray, F: np.ndarray, cam: Camera, style: Style | None = None, ss: int = 2) -> np.ndarray:
    """An (height, width, 3) uint8 image of the mesh (see :class:`Style`)."""
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
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-30)
        L = style.light if style.light is not None else np.array([-0.25, 0.35, 1.0])
        L = L / np.linalg.norm(L)
        lam = np.abs(nrm @ L)
        # a little specular keeps flat regions readable
        hv = L + np.array([0.0, 0.0, 1.0])
        hv /= np.linalg.norm(hv)
        spec = np.abs(nrm @ hv) ** 40 * 0.15
        if style.texture is not None and style.uvs is not None:
            uv = np.einsum("pk,pkj->pj", w, np.asarray(style.uvs)[corners])
            base = _sample_texture(style.texture, uv)
        elif style.vertex_colors is not None:
            base = np.einsum("pk,pkj->pj", w, np.asarray(style.vertex_colors)[:, :3][corners])
        else:
            base = np.broadcast_to(np.asarray(style.color, dtype=np.float64), (len(f), 3))
        col = base * (style.ambient + (1 - style.ambient) * lam)[:, None] + spec[:, None]
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
    # box filter down to the camera's resolution
    img = img.reshape(H // ss, ss, W // ss, ss, 3).mean(axis=(1, 3))
    return (img * 255.0 + 0.5).astype(np.uint8)


def open3d_available() -> tuple[bool, str]:
    """Whether Open3D's OffscreenRenderer can start here (it needs a GPU/EGL/Vulkan driver)."""
    try:
        import open3d as o3d

        o3d.visualization.rendering.OffscreenRenderer(16, 16)
        return True, "ok"
    except Exception as exc:  # noqa: BLE001
        return False, f"{type(exc).__name__}: {exc}"


# --------------------------------------------------------------------------------------
# composing pictures
# --------------------------------------------------------------------------------------

def _font(size: int):
    from PIL import ImageFont

    for name in ("DejaVuSans.ttf", "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf"):
        try:
            return ImageFont.truetype(name, size)
        except OSError:
            continue
    try:
        return ImageFont.load_default(size=size)
    except TypeError:
        return ImageFont.load_default()


def _wrap(text: str, font, width: float) -> list[str]:
    words, lines, cur = text.split(), [], ""
    for wd in words:
        trial = (cur + " " + wd).strip()
        if cur and font.getlength(trial) > width:
            lines.append(cur)
            cur = wd
        else:
            cur = trial
    return lines + [cur]


def compose(panels: list[np.ndarray], labels: list[str], caption: str) -> "Image.Image":
    """Panels side by side, a label over each (lines split on newlines), a caption under all (wrapped)."""
    from PIL import Image, ImageDraw

    font = _font(13)
    line = 17
    h = max(p.shape[0] for p in panels)
    w = sum(p.shape[1] for p in panels)
    label_h = 6 + line * max(lab.count("\n") + 1 for lab in labels)
    cap_lines = _wrap(caption, font, w - 12)
    caption_h = 8 + line * len(cap_lines)
    canvas = Image.new("RGB", (w, h + label_h + caption_h), (255, 255, 255))
    draw = ImageDraw.Draw(canvas)
    x = 0
    for p, lab in zip(panels, labels):
        canvas.paste(Image.fromarray(p), (x, label_h))
        for i, text in enumerate(lab.split("\n")):
            draw.text((x + 6, 4 + i * line), text, fill=(20, 20, 20), font=font)
        if x:
            draw.line([(x, 0), (x, label_h + h)], fill=(210, 210, 210))
        x += p.shape[1]
    for i, text in enumerate(cap_lines):
        draw.text((6, label_h + h + 4 + i * line), text, fill=(60, 60, 60), font=font)
    return canvas


def blank_panel(width: int, height: int, text: str) -> np.ndarray:
    from PIL import Image, ImageDraw

    im = Image.new("RGB", (width, height), (245, 245, 245))
    d = ImageDraw.Draw(im)
    words, lines, cur = text.split(), [], ""
    for wd in words:
        if len(cur) + len(wd) + 1 > 38:
            lines.append(cur)
            cur = wd
        else:
            cur = (cur + " " + wd).strip()
    lines.append(cur)
    d.multiline_text((10, height // 2 - 8 * len(lines)), "\n".join(lines[:10]), fill=(150, 30, 30), font=_font(12))
    return np.asarray(im)


@dataclass
class Scene:
    name: str            # file stem: <metric>_<mesh>
    metric: str
    mesh: str            # fidelity.load_mesh key (the metric's input)
    ratio: float
    view: dict           # Camera.fit keywords
    draw: str = "flat"   # flat | colors | texture | smooth | wire
    note: str = ""


SCENES = [
    Scene("melod_cow", "melod", "cow", 0.02, dict(azimuth=-35, elevation=12)),
    Scene("melod_bunny", "melod", "bunny", 0.02, dict(azimuth=10, elevation=10)),
    Scene("curvature_fandisk", "curvature", "fandisk", 0.05, dict(azimuth=35, elevation=35), draw="wire"),
    Scene("appearance_colored_airplane", "appearance", "colored_airplane", 0.05, dict(azimuth=-20, elevation=60),
          draw="colors"),
    Scene("appearance_spot", "appearance", "spot", 0.05, dict(azimuth=-50, elevation=15), draw="texture"),
    Scene("normal_qem_blob", "normal_qem", "blob", 0.02, dict(azimuth=25, elevation=25), draw="smooth"),
    Scene("normal_qem_bunny", "normal_qem", "bunny+normals", 0.01, dict(azimuth=10, elevation=10), draw="smooth"),
    Scene("normal_qem_cow", "normal_qem", "cow+normals", 0.1, dict(azimuth=-35, elevation=12), draw="smooth"),
]


def _style_for(scene: Scene, mesh_arrays: dict, V_in, F_in, texture, is_original: bool) -> Style:
    st = Style()
    if scene.draw == "colors" and mesh_arrays.get("colors") is not None:
        st.vertex_colors = mesh_arrays["colors"]
        st.ambient = 0.45
    elif scene.draw == "texture" and mesh_arrays.get("uvs") is not None and texture is not None:
        st.uvs, st.texture = mesh_arrays["uvs"], texture
        st.ambient = 0.45
        # seams: edges with one face in the (uv-split) mesh -- spot is closed, so these are seams/cracks
        F = np.asarray(mesh_arrays["faces"], dtype=np.int64)
        e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        u, c = np.unique(e, axis=0, return_counts=True)
        st.edges = u[c == 1]
        st.edge_color = (0.95, 0.1, 0.75)
        st.edge_width = 0.9
    elif scene.draw == "smooth" and mesh_arrays.get("normals") is not None:
        st.normals = mesh_arrays["normals"]
        st.color = (0.75, 0.77, 0.82)
    elif scene.draw == "wire":
        from metro import crease_edges

        if is_original:
            st.edges, _ = crease_edges(V_in, F_in, 30.0)
            st.edge_width = 0.8
        else:
            st.wire = (0.1, 0.1, 0.1)
            st.wire_width = 0.55
    return st


def _near_crease_points(V_in, F_in, V, F) -> np.ndarray:
    from metro import crease_edges, segment_distance

    E, _ = crease_edges(V_in, F_in, 30.0)
    used = np.unique(F)
    used_in = V_in[np.unique(F_in)]
    tol = 0.005 * float(np.linalg.norm(used_in.max(axis=0) - used_in.min(axis=0)))
    d = segment_distance(V[used], V_in[E[:, 0]], V_in[E[:, 1]])
    return used[d <= tol]


def make_picture(scene: Scene, results: dict, out_dir: Path, panel_w: int = 300, samples: int = 100_000,
                 ss: int = 2) -> dict:
    from PIL import Image

    from fidelity import load_mesh
    from metro import Reference

    src = load_mesh(scene.mesh)
    V_in, F_in = src.vertices, src.faces.astype(np.int64)
    used = V_in[np.unique(F_in)]
    texture = None
    if scene.draw == "texture":
        from fidelity import mesh_dir

        tex_path = mesh_dir() / "spot_texture.png"
        if tex_path.exists():
            texture = np.asarray(Image.open(tex_path).convert("RGB"), dtype=np.float64) / 255.0
    probe = Camera.fit(used, panel_w, panel_w, **scene.view)
    panel_h = int(np.clip(round(panel_w * probe.aspect_of(used) * 1.06 + 10), 200, 400))
    cam = Camera.fit(used, panel_w, panel_h, **scene.view)
    ref = Reference(V_in, F_in, n_samples=samples)

    orig = {"vertices": V_in, "faces": F_in, "colors": src.colors, "uvs": src.uvs, "normals": src.normals}
    panels = [render(V_in, F_in, cam, _style_for(scene, orig, V_in, F_in, texture, True), ss)]
    labels = [f"original — {len(F_in):,} faces\n "]
    info = {"file": f"{scene.name}.png", "metric": scene.metric, "mesh": scene.mesh, "ratio": scene.ratio}
    for label in (scene.metric, "qem"):
        r = results.get(label)
        if r is None or r["status"] != "ok":
            err = "not run" if r is None else r.get("error", r["status"])
            panels.append(blank_panel(panel_w, panel_h, f"{label}: not available — {err}"))
            labels.append(f"{label}\nnot available")
            info[label] = {"status": "not available", "error": err}
            continue
        out = r["out"]
        V, F = out["vertices"], out["faces"].astype(np.int64)
        st = _style_for(scene, out, V_in, F_in, texture, False)
        e = ref.compare(V, F)
        extra = ""
        if scene.draw == "wire":
            st.points = _near_crease_points(V_in, F_in, V, F)
            extra = f", {len(st.points)} of {len(np.unique(F))} vertices near a crease"
        elif scene.draw == "colors" and out.get("colors") is not None:
            from metro import color_error

            ce = color_error(V_in, F_in, src.colors, V, F, out["colors"], n_samples=samples)
            extra = f", colour RMS {ce['rms']:.1f}/255"
        elif scene.draw == "texture":
            from metro import seam_check

            sc = seam_check(V_in, F_in, out["vertex_map"], V, F, src.uvs, out.get("uvs"))
            extra = f", {sc['cracks']} seam cracks"
        panels.append(render(V, F, cam, st, ss))
        target = int(round(scene.ratio * len(F_in)))
        short = f" (target {target:,})" if len(F) > 1.02 * target + 2 else ""
        labels.append(f"{label} — {len(F):,} faces{short}\nH {e.get('hausdorff', float('nan')):.2g}{extra}")
        info[label] = {"status": "ok", "faces": int(len(F)), "hausdorff": e.get("hausdorff"), "label": labels[-1]}
    faces_str = f"{int(round(scene.ratio * len(F_in))):,}"
    cap = (f"{scene.mesh}: {scene.metric} vs qem at {scene.ratio:.0%} ({faces_str} faces). "
           "H = symmetric Hausdorff error / bbox diagonal.")
    if scene.draw == "wire":
        cap += " Red: the input's creases (dihedral > 30°); output vertices within 0.5% of the diagonal of one."
    elif scene.draw == "texture":
        cap += " Texture by uv; magenta: uv seam edges (cracks show as gaps or unmatched edges)."
    elif scene.draw == "smooth":
        cap += " Shaded with the interpolated vertex normals (the output's normals)."
    image = compose(panels, labels, cap)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{scene.name}.png"
    image.save(path, optimize=True)
    info.update(caption=cap, size=list(image.size), bytes=path.stat().st_size)
    return info


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(OUT_DIR))
    ap.add_argument("--only", default="", help="comma list of picture names (default: all)")
    ap.add_argument("--panel-width", type=int, default=300)
    ap.add_argument("--samples", type=int, default=100_000, help="Metro samples for the Hausdorff labels")
    ap.add_argument("--timeout", type=float, default=300.0)
    args = ap.parse_args(argv)

    from fidelity import run_metric_cases

    only = {s for s in args.only.split(",") if s}
    scenes = [s for s in SCENES if not only or s.name in only]
    ok, why = open3d_available()
    print(f"Open3D OffscreenRenderer: {'available' if ok else 'unavailable (' + why + ')'}; using the numpy rasteriser")
    # one worker per metric over all its scenes, plus qem over every scene
    by_metric: dict[str, list] = {}
    for sc in scenes:
        from fidelity import load_mesh

        n = load_mesh(sc.mesh).n_faces
        case = {"claim": "picture", "base": sc.name, "mesh": sc.mesh, "ratio": sc.ratio,
                "target": int(round(sc.ratio * n))}
        by_metric.setdefault(sc.metric, []).append(case)
        by_metric.setdefault("qem", []).append(case)
    results: dict[tuple, dict] = {}
    for metric, cases in by_metric.items():
        for r in run_metric_cases(metric, cases, timeout=args.timeout):
            results[(metric, r["base"])] = r
    infos = []
    for sc in scenes:
        t0 = time.perf_counter()
        info = make_picture(sc, {m: results.get((m, sc.name)) for m in (sc.metric, "qem")}, Path(args.out),
                            args.panel_width, args.samples)
        infos.append(info)
        panels = "; ".join(info[m].get("label", info[m].get("error", "")).replace("\n", ", ")
                           for m in (sc.metric, "qem") if m in info)
        print(f"{info['file']}: {info['size'][0]}x{info['size'][1]}, {info['bytes'] / 1024:.0f} KB, "
              f"{time.perf_counter() - t0:.1f} s — {info['caption']} [{panels}]", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
