"""Colours: the viridis map, colour options, per-vertex colours of a picture."""
from __future__ import annotations

import numpy as np

from ..errors import OptionError
from ..mesh import Mesh

DEFAULT_COLOR = (0.72, 0.74, 0.78)     # a light blue-grey
WIRE_COLOR = (0.1, 0.1, 0.1)

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


def rgb_option(name: str, value) -> np.ndarray:
    """``value`` as an RGB triple of floats in [0, 1] (OptionError naming ``name`` if not)."""
    try:
        c = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise OptionError(f"{name} must be an RGB triple in [0, 1], got {value!r}") from None
    if c.shape != (3,) or not np.isfinite(c).all() or c.min() < 0 or c.max() > 1:
        raise OptionError(f"{name} must be an RGB triple in [0, 1], got {value!r}")
    return c


def vertex_colors(mesh: Mesh, colors) -> np.ndarray | None:
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
