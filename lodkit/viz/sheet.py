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


def _have_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def annotated_sheet(images, *, labels=None, label_colors=None, row_titles=None, col_titles=None,
                    pad: int = 10, font_size: float = 9.0, background=(255, 255, 255),
                    font: str = "auto") -> np.ndarray:
    """A contact sheet for people: a grid of (H, W, 3) uint8 images (a list of rows; None
    leaves a cell empty) with a title over each column, a title left of each row and a
    label of one or more lines under each cell, written in a real font (matplotlib's
    bundled DejaVu Sans, drawn with its Agg backend: no system fonts, no display).

    labels       : same nesting as ``images``: str (``\\n`` separates lines) or None
    label_colors : same nesting: a colour for each label (matplotlib colour or RGB floats;
                   None: dark grey) - e.g. red for a method that stopped short of its target
    row_titles   : one str per row (None: no title column)
    col_titles   : one str per column (None: no title band)
    font         : "matplotlib", "pixel" (the built-in 5x7 font of :func:`contact_sheet`:
                   for machines without matplotlib) or "auto" (matplotlib when installed)

    The size of the result depends only on the images, the number of label lines and
    ``font_size``, not on the text drawn; a label too long for its cell is drawn smaller.
    """
    rows = [list(r) for r in images]
    if not rows or not any(len(r) for r in rows):
        raise OptionError("annotated_sheet needs at least one image")
    if font not in ("auto", "matplotlib", "pixel"):
        raise OptionError(f"font must be 'auto', 'matplotlib' or 'pixel', got {font!r}")
    n_cols = max(len(r) for r in rows)
    rows = [r + [None] * (n_cols - len(r)) for r in rows]

    def grid(name, value):
        if value is None:
            return [[None] * n_cols for _ in rows]
        value = [list(r) for r in value]
        if len(value) != len(rows) or any(len(v) > n_cols for v in value):
            raise OptionError(f"{name} must have the same rows and columns as images")
        return [v + [None] * (n_cols - len(v)) for v in value]

    labels, label_colors = grid("labels", labels), grid("label_colors", label_colors)
    if row_titles is not None and len(row_titles) != len(rows):
        raise OptionError("row_titles must have one title per row")
    if col_titles is not None and len(col_titles) != n_cols:
        raise OptionError("col_titles must have one title per column")
    use_mpl = font == "matplotlib" or (font == "auto" and _have_matplotlib())
    if not use_mpl:
        # the pixel font: titles become the first line of each label
        flat = [[" ".join(x for x in ((row_titles[i] if row_titles and j == 0 else None),
                                      (col_titles[j] if col_titles and i == 0 else None),
                                      (labels[i][j] or "").replace("\n", " ")) if x) or None
                 for j in range(n_cols)] for i in range(len(rows))]
        return contact_sheet(rows, pad, labels=flat, background=background, label_scale=1)

    cells = [[None if c is None else check_image(f"image [{i}][{j}]", c) for j, c in enumerate(r)]
             for i, r in enumerate(rows)]
    col_w = [max((r[j].shape[1] for r in cells if r[j] is not None), default=0) for j in range(n_cols)]
    row_h = [max((c.shape[0] for c in r if c is not None), default=0) for r in cells]
    line_px = int(round(font_size * 100 / 72 * 1.35))          # at 100 dpi
    n_lines = max((lab.count("\n") + 1 for r in labels for lab in r if lab), default=0)
    label_h = n_lines * line_px + (4 if n_lines else 0)
    title_h = int(round(font_size * 1.2 * 100 / 72 * 1.35)) + 4 if col_titles is not None else 0
    left = int(round(font_size * 1.2 * 100 / 72 * 1.35)) + 8 if row_titles is not None else 0
    H = pad + title_h + sum(row_h) + len(rows) * (label_h + pad)
    W = left + pad + sum(col_w) + n_cols * pad
    canvas = np.empty((H, W, 3), dtype=np.uint8)
    canvas[:] = np.asarray(background, dtype=np.uint8)
    texts = []                           # (x, y from the top, text, colour, size, weight, rotation, ha, va)
    y = pad + title_h
    xs = np.concatenate([[left + pad], left + pad + np.cumsum([w + pad for w in col_w])])
    if col_titles is not None:
        for j, t in enumerate(col_titles):
            if t:
                texts.append((xs[j] + col_w[j] / 2, pad + title_h / 2, str(t), "#202020", font_size * 1.15,
                              "bold", 0, "center", "center"))
    for i, r in enumerate(cells):
        if row_titles is not None and row_titles[i]:
            texts.append((left / 2 + 2, y + row_h[i] / 2, str(row_titles[i]), "#202020", font_size * 1.15,
                          "bold", 90, "center", "center"))
        for j, c in enumerate(r):
            if c is not None:
                oy = y + (row_h[i] - c.shape[0]) // 2
                ox = xs[j] + (col_w[j] - c.shape[1]) // 2
                canvas[oy:oy + c.shape[0], ox:ox + c.shape[1]] = c
            if labels[i][j]:
                text = str(labels[i][j])
                # narrow cells: smaller letters (about 0.6 em a character), in the same band
                longest = max(len(part) for part in text.split("\n")) or 1
                size = max(5.0, min(font_size, col_w[j] / (0.6 * longest * 100 / 72)))
                texts.append((xs[j] + col_w[j] / 2, y + row_h[i] + 2, text,
                              label_colors[i][j] or "#303030", size, "normal", 0, "center", "top"))
        y += row_h[i] + label_h + pad
    return _draw_texts(canvas, texts)


def _draw_texts(canvas: np.ndarray, texts) -> np.ndarray:
    """``canvas`` with the texts drawn over it by matplotlib (Agg, 100 dpi, pixel units)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    H, W = canvas.shape[:2]
    fig = Figure(figsize=(W / 100, H / 100), dpi=100)
    agg = FigureCanvasAgg(fig)
    fig.figimage(canvas, xo=0, yo=0, origin="upper")
    for x, y, text, color, size, weight, rotation, ha, va in texts:
        if isinstance(color, tuple) and max(color) > 1:
            color = tuple(c / 255 for c in color)
        fig.text(x / W, 1 - y / H, text, color=color, fontsize=size, fontweight=weight, rotation=rotation,
                 ha=ha, va=va, linespacing=1.2, multialignment="center")
    agg.draw()
    out = np.asarray(agg.buffer_rgba())[..., :3]
    if out.shape[:2] != (H, W):           # figsize rounding: crop or pad to the exact size
        fixed = np.empty_like(canvas)
        fixed[:] = canvas[0, 0]
        h, w = min(H, out.shape[0]), min(W, out.shape[1])
        fixed[:h, :w] = out[:h, :w]
        out = fixed
    return np.ascontiguousarray(out)
