"""A synthetic test surface and a small LOD demo, generated in code (no downloads).

>>> from lodkit.demo import demo_mesh, run_demo
>>> mesh = demo_mesh(20_000)
>>> rows = run_demo("lodkit-demo")          # demo_lod0.ply ... demo_lod4.ply and demo_lods.png
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

from .api import simplify
from .errors import OptionError
from .geometry import vertex_normals
from .io import save
from .mesh import Mesh

__all__ = ["demo_mesh", "run_demo", "SHEET_NAME", "demo_sheet"]

#: the contact sheet :func:`run_demo` writes next to the PLY files
SHEET_NAME = "demo_lods.png"

# The surface lives over [-1, 1]^2; heights are in the same units.
_PYRAMID_HEIGHT = 0.35      # square pyramid: four diagonal ridges, an apex and a square base crease
_PYRAMID_HALF_WIDTH = 0.5   # base from -0.5 to 0.5 in x and y
_STEP_Y = 0.75              # a terrace: the ground rises by _STEP_HEIGHT beyond y = 0.75
_STEP_HEIGHT = 0.06
_RIDGE_X = 0.78             # a roof-like ridge along x = 0.78 (|x| term)
_RIDGE_HALF_WIDTH = 0.12
_RIDGE_HEIGHT = 0.12
_BUMP_AMPLITUDE = 0.002     # fine detail: 0.6 % of the pyramid height, 36 bumps across
_BUMP_FREQUENCY = 18.0


def demo_mesh(n_faces: int = 100_000) -> Mesh:
    """An open height-field surface with about ``n_faces`` triangles.

    It has what a simplifier should keep: a square pyramid (sharp diagonal ridges, an apex
    and a crease around its base), a terrace step and a roof ridge (|x| terms), fine
    high-frequency bumps everywhere, the grid border as its one boundary loop, and
    per-vertex colours that vary smoothly with height and jump across the terrace edge.
    Per-vertex normals are area-weighted averages of the face normals.

    The grid is (nx + 1) x (ny + 1) vertices over [-1, 1]^2 with 2 * nx * ny faces; nx and
    ny are even so the pyramid apex is a vertex, and each quad is split along the diagonal
    that follows the pyramid ridge in its quadrant, so the ridges are exact mesh edges.
    Deterministic: the same ``n_faces`` gives the same arrays, bit for bit.
    """
    if isinstance(n_faces, bool) or not isinstance(n_faces, (int, np.integer)) or n_faces < 8:
        raise OptionError(f"n_faces must be an integer >= 8, got {n_faces!r}")
    nx = max(2, 2 * round(math.sqrt(n_faces / 2) / 2))
    ny = max(2, 2 * round(n_faces / (2 * nx) / 2))
    vertices = _grid_vertices(nx, ny)
    faces = _grid_faces(nx, ny, vertices)
    colors = _colors(vertices)
    mesh = Mesh(vertices, faces, colors=colors)
    mesh.normals = vertex_normals(mesh.vertices, mesh.faces)
    mesh.metadata["name"] = f"lodkit demo surface {nx}x{ny}"
    return mesh


def _height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    pyramid = _PYRAMID_HEIGHT * np.clip(1.0 - np.maximum(np.abs(x), np.abs(y)) / _PYRAMID_HALF_WIDTH, 0.0, None)
    step = _STEP_HEIGHT * (y > _STEP_Y)
    ridge = _RIDGE_HEIGHT * np.clip(1.0 - np.abs(x - _RIDGE_X) / _RIDGE_HALF_WIDTH, 0.0, None)
    swell = 0.04 * np.sin(1.3 * np.pi * x) * np.cos(np.pi * y)   # broad, smooth undulation
    w = 2.0 * np.pi * _BUMP_FREQUENCY
    bumps = _BUMP_AMPLITUDE * np.sin(w * x) * np.sin(w * y)
    return pyramid + step + ridge + swell + bumps


def _grid_vertices(nx: int, ny: int) -> np.ndarray:
    x, y = np.meshgrid(np.linspace(-1.0, 1.0, nx + 1), np.linspace(-1.0, 1.0, ny + 1))
    x, y = x.reshape(-1), y.reshape(-1)
    return np.stack([x, y, _height(x, y)], axis=1)


def _grid_faces(nx: int, ny: int, vertices: np.ndarray) -> np.ndarray:
    """Two counter-clockwise (seen from +z) triangles per grid cell."""
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))   # cell (i, j): columns i..i+1, rows j..j+1
    i, j = i.reshape(-1), j.reshape(-1)
    v00 = j * (nx + 1) + i
    v10, v01, v11 = v00 + 1, v00 + nx + 1, v00 + nx + 2
    # Cell centre quadrant: where x * y > 0 the pyramid ridge runs along (1, 1), so split the
    # cell v00-v11; elsewhere it runs along (1, -1), so split v10-v01.
    cx = 0.5 * (vertices[v00, 0] + vertices[v11, 0])
    cy = 0.5 * (vertices[v00, 1] + vertices[v11, 1])
    main = cx * cy > 0
    main = main[:, None]
    a = np.where(main, np.stack([v00, v10, v11], axis=1), np.stack([v00, v10, v01], axis=1))
    b = np.where(main, np.stack([v00, v11, v01], axis=1), np.stack([v10, v11, v01], axis=1))
    faces = np.empty((2 * i.size, 3), dtype=np.int64)
    faces[0::2], faces[1::2] = a, b
    return faces


def _colors(vertices: np.ndarray) -> np.ndarray:
    """Terrain-like colours: green low, brown to white high; a darker terrace; faint stripes."""
    x, y, z = vertices[:, 0], vertices[:, 1], vertices[:, 2]
    t = np.clip((z - z.min()) / max(float(np.ptp(z)), 1e-12), 0.0, 1.0)
    low = np.array([0.20, 0.55, 0.20])
    mid = np.array([0.55, 0.42, 0.25])
    high = np.array([0.95, 0.95, 0.95])
    s = t[:, None]
    rgb = np.where(s < 0.5, low + (mid - low) * (2 * s), mid + (high - mid) * (2 * s - 1))
    rgb = rgb * np.where(y > _STEP_Y, 0.7, 1.0)[:, None]          # colour edge along the step
    rgb[:, 2] += 0.08 * np.sin(6.0 * np.pi * x)                    # smooth variation in x
    return np.clip(rgb, 0.0, 1.0)


def run_demo(out_dir="lodkit-demo", ratios=(0.5, 0.2, 0.05, 0.01), stream=None, n_faces: int = 100_000,
             picture: bool = True, image_size: tuple = (320, 240)) -> list[dict]:
    """Build :func:`demo_mesh`, simplify it to each ratio and write one PLY per level.

    Writes ``demo_lod0.ply`` (the original) and ``demo_lod1.ply`` ... into ``out_dir``
    (created if needed), prints a table to ``stream`` (standard output by default) and
    returns its rows as dicts: level, ratio, faces, vertices, error (a fraction of the
    bounding-box diagonal; None for the original), seconds, stop_reason, file.

    With ``picture`` it also writes :data:`SHEET_NAME`, a contact sheet of the levels
    (:func:`demo_sheet`, each picture ``image_size`` pixels) and prints its path; when
    nothing can be drawn here it prints one line saying why instead (the PLY files and
    the table are written either way).
    """
    stream = sys.stdout if stream is None else stream
    ratios = tuple(float(r) for r in ratios)
    bad = [r for r in ratios if not 0.0 < r <= 1.0]
    if bad:
        raise OptionError(f"ratios must be in (0, 1], got {bad[0]!r}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)

    t0 = time.perf_counter()
    mesh = demo_mesh(n_faces)
    built = time.perf_counter() - t0
    path = out / "demo_lod0.ply"
    save(mesh, path)
    rows = [dict(level=0, ratio=1.0, faces=mesh.n_faces, vertices=mesh.n_vertices, error=None,
                 seconds=built, stop_reason="original", file=str(path))]
    print(f"lodkit demo: {mesh.metadata.get('name', 'demo surface')}, {mesh.n_faces} faces -> {out}/",
          file=stream, flush=True)
    for level, ratio in enumerate(ratios, start=1):
        t = time.perf_counter()
        result = simplify(mesh, target_ratio=ratio)
        seconds = time.perf_counter() - t
        path = out / f"demo_lod{level}.ply"
        save(result.mesh, path)
        rows.append(dict(level=level, ratio=ratio, faces=result.mesh.n_faces, vertices=result.mesh.n_vertices,
                         error=float(result.error), seconds=seconds, stop_reason=str(result.stop_reason),
                         file=str(path)))
    stream.write(format_table(rows) + "\n")
    if picture:
        meshes = [mesh] + [None] * len(ratios)
        try:
            from .io import load

            meshes[1:] = [load(r["file"]) for r in rows[1:]]
            path = demo_sheet(meshes, rows, out / SHEET_NAME, image_size)
        except Exception as exc:  # noqa: BLE001 - a picture is a bonus: say why there is none
            reason = " ".join(str(exc).split()) or type(exc).__name__
            stream.write(f"lodkit demo: no picture of the levels ({type(exc).__name__}: {reason})\n")
        else:
            stream.write(f"picture of the levels: {path}\n")
    stream.flush()
    return rows


def demo_sheet(meshes: list, rows: list[dict], path, image_size: tuple = (320, 240)) -> Path:
    """Render ``meshes`` (the levels of :func:`run_demo`, the original first) with one camera,
    labelled with their level, faces and error, into one PNG at ``path``; returns the path.
    Uses :mod:`lodkit.viz` (Open3D's offscreen renderer where it draws, else the numpy
    rasteriser) and matplotlib's text when installed (else the built-in pixel font)."""
    from . import viz

    width, height = image_size
    camera = viz.Camera.fit(meshes[0], width, height, up="z", azimuth=30.0, elevation=35.0)
    images = [viz.render(m, width, height, camera=camera) for m in meshes]
    labels, titles = [], []
    for r in rows:
        titles.append(f"LOD {r['level']}: " + ("original" if r["level"] == 0 else f"{100 * r['ratio']:g} %"))
        error = "" if r["error"] is None else f", error {r['error']:.2g}"
        labels.append(f"{r['faces']} faces{error}")
    sheet = viz.annotated_sheet([images], labels=[labels], col_titles=titles)
    return Path(viz.write_png(path, sheet))


def format_table(rows: list[dict]) -> str:
    """The rows of :func:`run_demo` as an aligned text table."""
    header = ("level", "ratio", "faces", "vertices", "error", "time s", "stop reason", "file")
    cells = [header]
    for r in rows:
        cells.append((
            str(r["level"]),
            f"{r['ratio']:g}",
            str(r["faces"]),
            str(r["vertices"]),
            "-" if r["error"] is None else f"{r['error']:.2e}",
            f"{r['seconds']:.2f}",
            r["stop_reason"],
            Path(r["file"]).name,
        ))
    widths = [max(len(row[k]) for row in cells) for k in range(len(header))]
    left = {6, 7}   # text columns; numbers align right
    lines = []
    for row in cells:
        cells = (c.ljust(w) if k in left else c.rjust(w) for k, (c, w) in enumerate(zip(row, widths)))
        lines.append("  ".join(cells).rstrip())
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)
