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

Rendering is headless: :func:`render` is lodkit.render's numpy rasteriser
(:func:`lodkit.render.draw`: orthographic camera, two-sided Lambert shading, flat or with
interpolated vertex normals; vertex colours; texture lookup by uv; hidden-line wireframe;
highlighted edges; visible vertex dots), supersampled 2x and box-filtered. Open3D's
``OffscreenRenderer`` (``lodkit.render``'s other backend) can draw here now, but these
pictures need the texture, edge and dot styles only the numpy rasteriser has, and it makes
them bit-for-bit reproducible. Pillow composes the panels and writes the files.
"""
from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from PIL import Image

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
if importlib.util.find_spec("lodkit") is None:     # a checkout without lodkit installed: its source
    sys.path.insert(0, str(REPO))
sys.path.insert(0, str(HERE))

OUT_DIR = REPO / "docs" / "metrics" / "img"


# --------------------------------------------------------------------------------------
# rasteriser: lodkit.render's numpy backend (one renderer for the library and the bench)
# --------------------------------------------------------------------------------------

from lodkit.render import Style, draw, rasterize, rotation  # noqa: E402,F401
from lodkit.render import View as Camera  # noqa: E402


def render(V: np.ndarray, F: np.ndarray, cam: Camera, style: Style | None = None, ss: int = 2) -> np.ndarray:
    """An (height, width, 3) uint8 image of the mesh (see :class:`lodkit.render.Style`)."""
    return draw(V, F, cam, style, ss)


def open3d_available() -> tuple[bool, str]:
    """Whether Open3D's OffscreenRenderer can draw here (lodkit.render's probe)."""
    import lodkit.render

    info = lodkit.render.backend_info()
    return info["backend"] == "open3d", info["reason"]


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


def compose(panels: list[np.ndarray], labels: list[str], caption: str) -> Image.Image:
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
    from fidelity import load_mesh
    from metro import Reference
    from PIL import Image

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
    print(f"lodkit.render's default backend: {'open3d' if ok else 'numpy'} ({why}); "
          "these pictures use the numpy rasteriser")
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
