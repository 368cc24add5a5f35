"""The numpy rasteriser: a vectorised z-buffer, shading, wireframe, edges and dots."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .camera import View
from .colors import DEFAULT_COLOR

# light direction in camera space (x right, y up, z towards the viewer): above left of the eye
LIGHT = (-0.25, 0.35, 1.0)
AMBIENT = 0.33


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


def shade(base: np.ndarray, normals_cam: np.ndarray, ambient: float, light=None) -> np.ndarray:
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
        col = shade(base, nrm, style.ambient, style.light)
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
    return downsample(img, ss)


def downsample(img: np.ndarray, ss: int) -> np.ndarray:
    """Box filter an (H*ss, W*ss, 3) float image in [0, 1] to uint8 (H, W, 3)."""
    H, W = img.shape[0] // ss, img.shape[1] // ss
    img = img.reshape(H, ss, W, ss, 3).mean(axis=(1, 3))
    return (np.clip(img, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
