"""Pictures of meshes, headless: one renderer with two backends, contact sheets, PNG files
(:mod:`lodkit.viz`; its public names are also :mod:`lodkit.render`).

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
- ``"numpy"``: a vectorised z-buffer rasteriser (:func:`draw`, :mod:`lodkit.viz.raster`), used when
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

The modules: ``camera`` (rotation, View, Camera), ``colors`` (colormap), ``raster`` (the
numpy rasteriser), ``open3d_backend`` (probe, the one renderer), ``picture`` (render),
``text`` (the pixel font), ``sheet`` (contact sheets, colour bars; :func:`annotated_sheet`
writes titles and labels in matplotlib's text), ``png`` (write_png).
"""
from ..errors import ImageIOError, RenderError
from .camera import Camera, View, rotation
from .colors import DEFAULT_COLOR, NAN_COLOR, WIRE_COLOR, colormap
from .open3d_backend import BACKENDS, backend, backend_info
from .picture import render
from .png import write_png
from .raster import AMBIENT, LIGHT, Style, draw, rasterize
from .sheet import annotated_sheet, colorbar, contact_sheet
from .text import draw_text, text_size

__all__ = [
    "AMBIENT", "BACKENDS", "DEFAULT_COLOR", "LIGHT", "NAN_COLOR", "WIRE_COLOR",
    "Camera", "ImageIOError", "RenderError", "Style", "View", "annotated_sheet", "backend", "backend_info", "colorbar",
    "colormap", "contact_sheet", "draw", "draw_text", "rasterize", "render", "rotation", "text_size", "write_png",
]
