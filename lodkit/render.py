"""Pictures of meshes, headless: the public names of :mod:`lodkit.viz`, under the name
scripts have used since 0.1.0 (``import lodkit.render as lr``).

See :mod:`lodkit.viz` for the renderer's notes (two backends, one camera for several LODs,
contact sheets, PNG files).
"""
from .viz import (
    AMBIENT,
    BACKENDS,
    DEFAULT_COLOR,
    LIGHT,
    NAN_COLOR,
    WIRE_COLOR,
    Camera,
    ImageIOError,
    RenderError,
    Style,
    View,
    annotated_sheet,
    backend,
    backend_info,
    colorbar,
    colormap,
    contact_sheet,
    draw,
    draw_text,
    rasterize,
    render,
    rotation,
    text_size,
    write_png,
)

__all__ = [
    "AMBIENT", "BACKENDS", "DEFAULT_COLOR", "LIGHT", "NAN_COLOR", "WIRE_COLOR",
    "Camera", "ImageIOError", "RenderError", "Style", "View", "annotated_sheet", "backend", "backend_info", "colorbar",
    "colormap", "contact_sheet", "draw", "draw_text", "rasterize", "render", "rotation", "text_size", "write_png",
]
