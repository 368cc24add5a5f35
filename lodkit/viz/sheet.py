"""Composed images: contact sheets (grids of pictures with labels) and colour bars."""
from __future__ import annotations

import numpy as np

from ..errors import OptionError
from .camera import check_size
from .colors import colormap
from .png import check_image
from .text import draw_text, text_size


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
    cells = [[None if c is None else check_image(f"image [{i}][{j}]", c) for j, c in enumerate(r)]
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
    width, height = check_size(width, height)
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
