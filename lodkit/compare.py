"""Compare simplifiers on one mesh: error-versus-face-count curves, a table, a contact sheet.

>>> lodkit.compare("bunny.ply", metrics=["qem", "melod"], peers=["open3d"],
...                ratios=[0.5, 0.1, 0.02], out="bunny-report")

For every method (a lodkit metric, or a peer library) and every ratio the mesh is
simplified to ``round(ratio * faces)`` faces, the call is timed, and the result is measured
with :class:`lodkit.evaluate.Evaluator` against the original (one set of samples for all).
With ``out`` the directory gets

    results.csv, results.json   the table (one row per method and ratio)
    hausdorff.png, rms.png      error against face count, one line per method (MELOD's Figure 5)
    time.png                    time of the simplification call against face count
    contact_sheet.png           the LODs rendered (rows = methods, columns = the original and
                                the ratios), each labelled with its faces and Hausdorff error
    report.md, report.html      everything above; the HTML embeds the images (self-contained)

The table gives the target, the faces and vertices reached, why the run stopped and its
time; per ratio the best value of each error column (and of the time) is marked, among
the runs that reached their target. A run that stopped short of its target (more than
:data:`SHORT_TOLERANCE` faces above it, e.g. a metric that ran out of valid collapses) is
marked in the table, the plots and the contact sheet, and left out of the "best" marks: a
result with more faces is not comparable.

Every file is written to a temporary name in ``out`` and renamed into place, so each is
either complete or absent. The plots need matplotlib (``pip install lodkit[plot]``); the
contact sheet uses :mod:`lodkit.viz` (Open3D's offscreen renderer or the numpy rasteriser).
"""
from __future__ import annotations

import base64
import csv
import html
import io
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import viz
from .adapters import to_mesh
from .api import simplify
from .deps import open3d as import_open3d
from .errors import LodkitError, OptionError
from .evaluate import DEFAULT_SAMPLES, Evaluation, Evaluator
from .io import atomic_write, load
from .mesh import Mesh
from .metrics import create

__all__ = ["PEERS", "SHORT_TOLERANCE", "Comparison", "Run", "MissingDependencyError", "compare"]

#: a run "stopped short" when it kept more than ``target + max(2, SHORT_TOLERANCE * target)``
#: faces (an edge collapse removes two faces at once and peers land a face or two off)
SHORT_TOLERANCE = 0.01


class MissingDependencyError(LodkitError, ImportError):
    """An optional dependency a feature needs is not installed; the message says what to install."""


# ---------------------------------------------------------------------- peers
# Each peer: (vertices (n, 3) float64, faces (m, 3) int64, vertex colours (n, 3) or None,
# target faces) -> (vertices, faces, colours or None, seconds of the simplification call
# alone; conversions are not timed). Colours go through where the library carries them.
def _peer_open3d(V, F, C, target):
    o3d = import_open3d()

    m = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(V), o3d.utility.Vector3iVector(F.astype(np.int32)))
    if C is not None:
        m.vertex_colors = o3d.utility.Vector3dVector(C[:, :3])
    t0 = time.perf_counter()
    out = m.simplify_quadric_decimation(target_number_of_triangles=int(target))
    seconds = time.perf_counter() - t0
    colors = np.asarray(out.vertex_colors, dtype=np.float64) if out.has_vertex_colors() else None
    return np.asarray(out.vertices, dtype=np.float64), np.asarray(out.triangles, dtype=np.int64), colors, seconds


def _peer_fast_simplification(V, F, C, target):
    import fast_simplification

    t0 = time.perf_counter()
    v, f = fast_simplification.simplify(V, F.astype(np.int32), target_reduction=1.0 - target / len(F))
    seconds = time.perf_counter() - t0
    return np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64), None, seconds


def _peer_pyfqmr(V, F, C, target):
    import pyfqmr

    s = pyfqmr.Simplify()
    s.setMesh(V, F.astype(np.int32))
    t0 = time.perf_counter()
    s.simplify_mesh(target_count=int(target), aggressiveness=7, preserve_border=True, verbose=False)
    seconds = time.perf_counter() - t0
    v, f, _ = s.getMesh()
    return np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64), None, seconds


def _peer_pymeshlab(V, F, C, target):
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=V, face_matrix=F.astype(np.int32)))
    t0 = time.perf_counter()
    ms.meshing_decimation_quadric_edge_collapse(targetfacenum=int(target))
    seconds = time.perf_counter() - t0
    m = ms.current_mesh()
    return np.asarray(m.vertex_matrix(), dtype=np.float64), np.asarray(m.face_matrix(), dtype=np.int64), None, seconds


def _lodkit_retile(V, F, C, target):
    from .retile import retile

    t0 = time.perf_counter()
    out = retile(Mesh(V, F, colors=C), max(4, int(target) // 2)).mesh
    return out.vertices, out.faces.astype(np.int64), out.colors, time.perf_counter() - t0


def _lodkit_optimize(V, F, C, target):
    from .optimize import optimize

    t0 = time.perf_counter()
    out = optimize(Mesh(V, F), n_vertices=max(4, int(target) // 2)).mesh
    return out.vertices, out.faces.astype(np.int64), None, time.perf_counter() - t0


def _lodkit_polish(V, F, C, target):
    from .api import simplify

    t0 = time.perf_counter()
    out = simplify(Mesh(V, F, colors=C), target_faces=int(target), polish=True).mesh
    return out.vertices, out.faces.astype(np.int64), out.colors, time.perf_counter() - t0


#: peer name -> (module to import, pip package, adapter, what is called). The adapters are
#: minimal on purpose (bench/methods.py has the benchmark's fuller ones; the package cannot import bench/).
PEERS = {
    "open3d": ("open3d", "open3d", _peer_open3d,
               "TriangleMesh.simplify_quadric_decimation(target_number_of_triangles=N)"),
    "fast_simplification": ("fast_simplification", "fast-simplification", _peer_fast_simplification,
                            "fast_simplification.simplify(V, F, target_reduction=1 - N/m)"),
    "pyfqmr": ("pyfqmr", "pyfqmr", _peer_pyfqmr,
               "Simplify.simplify_mesh(target_count=N, aggressiveness=7, preserve_border=True)"),
    "pymeshlab": ("pymeshlab", "pymeshlab", _peer_pymeshlab,
                  "MeshSet.meshing_decimation_quadric_edge_collapse(targetfacenum=N)"),
    # lodkit's global strategies (no face target: asked for N/2 vertices, about N faces)
    "retile": ("lodkit", "lodkit", _lodkit_retile, "lodkit.retile(mesh, n_vertices=N/2) (Turk 1992)"),
    "optimize": ("lodkit", "lodkit", _lodkit_optimize,
                 "lodkit.optimize(mesh, n_vertices=N/2) (Hoppe et al. 1993, from a QEM start)"),
    # lodkit's QEM with its vertices fitted to the input afterwards
    "polish": ("lodkit", "lodkit", _lodkit_polish, "lodkit.simplify(mesh, target_faces=N, polish=True)"),
}


# ---------------------------------------------------------------------- results
@dataclass
class Run:
    """One method at one ratio."""

    method: str
    kind: str                     # "metric" (lodkit.simplify) or "peer"
    ratio: float
    target_faces: int
    faces: int = 0
    vertices: int = 0
    seconds: float | None = None   # the simplification call alone
    evaluation: Evaluation | None = None
    error: str | None = None   # why the run or its evaluation failed (then no evaluation)
    mesh: Mesh | None = field(default=None, repr=False)
    stop_reason: str | None = None   # simplify's stop_reason; for a peer "target_faces" or "stopped_short"

    @property
    def stopped_short(self) -> bool:
        """True when the result kept clearly more faces than its target (see :data:`SHORT_TOLERANCE`)."""
        if self.error is not None or self.mesh is None:
            return False
        return self.faces > self.target_faces + max(2, SHORT_TOLERANCE * self.target_faces)

    def row(self) -> dict:
        """The table row: plain values (distances as fractions of the bounding-box diagonal)."""
        out = {"method": self.method, "kind": self.kind, "ratio": self.ratio, "target_faces": self.target_faces,
               "faces": self.faces, "vertices": self.vertices, "stop_reason": self.stop_reason,
               "stopped_short": self.stopped_short, "seconds": self.seconds}
        ev = self.evaluation
        if ev is None:
            out.update({k: None for k in _METRIC_COLUMNS})
        else:
            d, n, ch = ev.distance, ev.normal_deviation, ev.topology_changes
            out.update(hausdorff=d.hausdorff, mean=d.mean, rms=d.rms,
                       hausdorff_model=ev.distance_model.hausdorff, rms_model=ev.distance_model.rms,
                       normal_mean=n.mean, normal_p95=n.p95, quality_min=ev.quality_simplified.min,
                       genus_change=ch["genus"], components_change=ch["n_components"],
                       boundary_loops_change=ch["n_boundary_loops"],
                       nonmanifold_edges=ev.topology_simplified.n_nonmanifold_edges,
                       color_rms=None if ev.color is None else ev.color.rms)
        out["error"] = self.error
        return out


_METRIC_COLUMNS = ("hausdorff", "mean", "rms", "hausdorff_model", "rms_model", "normal_mean", "normal_p95",
                   "quality_min", "genus_change", "components_change", "boundary_loops_change",
                   "nonmanifold_edges", "color_rms")


@dataclass
class Comparison:
    """What :func:`compare` did: the runs in order (method by method, ratios in the order
    given), the input's size, and the files written (name -> path; empty without ``out``)."""

    source: str
    n_faces: int
    n_vertices: int
    diagonal: float
    n_samples: int
    seed: int
    methods: list
    ratios: list
    runs: list
    files: dict

    def rows(self) -> list[dict]:
        return [r.row() for r in self.runs]

    def run(self, method: str, ratio: float) -> Run:
        for r in self.runs:
            if r.method == method and r.ratio == ratio:
                return r
        raise KeyError((method, ratio))


# ---------------------------------------------------------------------- checking the options
def _method_list(items) -> list:
    if items is None:
        return []
    if isinstance(items, str):
        items = [s for s in (p.strip() for p in items.split(",")) if s]
    return list(items)


def _metric_label(spec) -> str:
    if isinstance(spec, str):
        return spec
    if isinstance(spec, tuple) and len(spec) == 2 and isinstance(spec[0], str) and isinstance(spec[1], dict):
        opts = ",".join(f"{k}={v}" for k, v in spec[1].items())
        return f"{spec[0]}:{opts}" if opts else spec[0]
    raise OptionError(f"a metric is a name or a (name, options) pair, got {spec!r}")


def _check_ratios(ratios) -> list[float]:
    if isinstance(ratios, str):
        ratios = [p for p in ratios.split(",") if p.strip()]
    try:
        values = [float(r) for r in ratios]
    except (TypeError, ValueError):
        raise OptionError(f"ratios must be numbers in (0, 1], got {ratios!r}") from None
    if not values:
        raise OptionError("give at least one ratio")
    for r in values:
        if not (0.0 < r <= 1.0):
            raise OptionError(f"every ratio must be in (0, 1], got {r}")
    if len(set(values)) != len(values):
        raise OptionError(f"ratios repeat: {values}")
    return values


def _check_peer(name: str) -> None:
    if name not in PEERS:
        raise OptionError(f"unknown peer {name!r}; peers: {', '.join(PEERS)}")
    module, package, _, _ = PEERS[name]
    try:
        __import__(module)
    except ImportError as exc:
        raise MissingDependencyError(f"peer {name!r} needs the package {package!r}, which is not installed "
                                     f"(pip install {package}): {exc}") from None


def _matplotlib():
    try:
        import matplotlib
    except ImportError:
        raise MissingDependencyError("the comparison plots need matplotlib: pip install 'lodkit[plot]'") from None
    return matplotlib


# ---------------------------------------------------------------------- the comparison
def compare(mesh, *, metrics=("qem",), peers=(), ratios=(0.5, 0.1, 0.02), out=None,
            samples: int = DEFAULT_SAMPLES, seed: int = 0, contact_sheet: bool = True,
            image_size: tuple = (320, 240), render_backend: str | None = None, view="front",
            simplify_options: dict | None = None, log: Callable[[str], None] | None = None) -> Comparison:
    """Simplify ``mesh`` with several methods to several ratios, time and evaluate each.

    mesh             : anything :func:`lodkit.evaluate` takes (Mesh, Open3D mesh, (V, F), path)
    metrics          : lodkit metric specs ("qem", ("importance", {"weight": 2}), ...) or a
                       comma-separated string of names; each runs ``lodkit.simplify``
    peers            : names from :data:`PEERS` (other libraries; each must be installed)
    ratios           : fractions of the faces to keep, each in (0, 1]; target faces
                       ``max(1, round(ratio * faces))``
    out              : directory for the report (created if missing); None: compute only
    samples, seed    : for :class:`lodkit.evaluate.Evaluator`
    contact_sheet    : render the LODs (needs a working Open3D offscreen renderer)
    image_size       : (width, height) of each rendered LOD, in pixels
    render_backend   : "open3d" or "numpy" for :func:`lodkit.render.render` (None: its choice)
    view             : the contact sheet's camera: "front" (:meth:`lodkit.render.Camera.front`:
                       the front of the mesh's principal axes, turned 30° and raised 20°),
                       ``(azimuth, elevation)`` in degrees from that front view (also as the
                       string "AZ,EL"; "0,0" is straight on, "180,0" from behind), or a
                       :class:`lodkit.render.Camera`
    simplify_options : extra keyword arguments for ``lodkit.simplify`` (boundary=, ...)
    log              : called with a line of text after each run (progress)

    A run that fails (a peer error, an empty result) is kept with its ``error`` and left out
    of the plots. Raises :class:`lodkit.OptionError` / :class:`lodkit.UnknownMetricError`
    for bad options before any work, :class:`MissingDependencyError` when matplotlib (with
    ``out``) or a requested peer is not installed.
    """
    metric_specs = _method_list(metrics)
    peer_names = _method_list(peers)
    if not metric_specs and not peer_names:
        raise OptionError("nothing to compare: give at least one metric or peer")
    labels = [_metric_label(s) for s in metric_specs]
    for spec in metric_specs:
        for m in create(spec):            # unknown names and bad options fail here
            m.check_ready()
    for name in peer_names:
        _check_peer(name)
    methods = labels + peer_names
    if len(set(methods)) != len(methods):
        raise OptionError(f"a method is listed twice: {methods}")
    ratio_list = _check_ratios(ratios)
    width, height = _check_size(image_size)
    view = _check_view(view)
    if render_backend not in (None, "open3d", "numpy"):
        raise OptionError(f"render_backend must be 'open3d', 'numpy' or None, got {render_backend!r}")
    options = dict(simplify_options or {})
    for key in ("target_faces", "target_ratio", "max_error", "metric"):
        if key in options:
            raise OptionError(f"simplify_options may not set {key!r}: compare() sets the targets and metrics")
    if out is not None:
        _matplotlib()
    source = str(mesh) if isinstance(mesh, (str, os.PathLike)) else type(mesh).__name__
    original = to_mesh(mesh, "input", load=load)
    evaluator = Evaluator(original, samples, seed)
    if out is not None:
        _check_dir(out)          # made only once the runs are done: an error leaves nothing behind
    n_faces = original.n_faces
    V0, F0 = original.vertices, original.faces.astype(np.int64)
    runs = []
    for label, spec in list(zip(labels, metric_specs)) + [(p, None) for p in peer_names]:
        kind = "metric" if spec is not None else "peer"
        for ratio in ratio_list:
            run = Run(method=label, kind=kind, ratio=ratio, target_faces=max(1, int(round(ratio * n_faces))))
            try:
                if kind == "metric":
                    t0 = time.perf_counter()
                    result = simplify(original, target_faces=run.target_faces, metric=spec, **options)
                    run.seconds = time.perf_counter() - t0
                    run.mesh = result.mesh
                    run.stop_reason = str(result.stop_reason)
                else:
                    V, F, C, run.seconds = PEERS[label][2](V0, F0, original.colors, run.target_faces)
                    run.mesh = Mesh(V, F, colors=C)
                run.faces, run.vertices = run.mesh.n_faces, int(np.unique(run.mesh.faces).size)
                if kind == "peer":
                    run.stop_reason = "stopped_short" if run.stopped_short else "target_faces"
                run.evaluation = evaluator.evaluate(run.mesh)
            except Exception as exc:  # noqa: BLE001
                # a peer library's failure (whatever it raises), or a result evaluate() cannot
                # measure (no faces, no area); lodkit's own bugs are not hidden
                if kind == "metric" and (isinstance(exc, OptionError)
                                         or not isinstance(exc, (LodkitError, RuntimeError, ValueError))):
                    raise           # a bad simplify_options value, or a bug
                run.error = f"{type(exc).__name__}: {' '.join(str(exc).split())}"
            runs.append(run)
            if log is not None:
                log(_progress_line(run))

    comparison = Comparison(source=source, n_faces=n_faces, n_vertices=original.n_vertices,
                            diagonal=evaluator.diagonal, n_samples=evaluator.samples, seed=evaluator.seed,
                            methods=methods, ratios=ratio_list, runs=runs, files={})
    if out is not None:
        out_dir = _prepare_dir(out)
        _write_report(comparison, original, out_dir, contact_sheet, width, height, peer_names, render_backend,
                      view)
    return comparison


def _check_view(view):
    """"front", (azimuth, elevation) or a Camera; "AZ,EL" strings become the pair."""
    if isinstance(view, viz.Camera) or view == "front":
        return view
    if isinstance(view, str):
        view = view.split(",")
    try:
        az, el = (float(x) for x in view)
    except (TypeError, ValueError):
        raise OptionError(f"view must be 'front', (azimuth, elevation) in degrees or a Camera, got {view!r}") from None
    if not (math.isfinite(az) and math.isfinite(el) and -90.0 < el < 90.0):
        raise OptionError(f"view elevation must be strictly between -90 and 90 degrees, got {el}")
    return az, el


def _progress_line(run: Run) -> str:
    head = f"{run.method} @ {run.ratio:g}: "
    if run.error:
        return head + "failed: " + run.error
    d = run.evaluation.distance
    short = f" (stopped short of {run.target_faces})" if run.stopped_short else ""
    return head + f"{run.faces} faces{short}, {run.seconds:.3f} s, hausdorff {d.hausdorff:.4g}, rms {d.rms:.4g}"


def _check_size(size) -> tuple[int, int]:
    try:
        w, h = (int(x) for x in size)
    except (TypeError, ValueError):
        raise OptionError(f"image_size must be (width, height), got {size!r}") from None
    if not (16 <= w <= 4096 and 16 <= h <= 4096):
        raise OptionError(f"image_size must be between 16 and 4096 pixels each way, got {w}x{h}")
    return w, h


def _check_dir(out) -> Path:
    """The output directory: an OptionError now if it cannot be one (a file is in the way,
    or the nearest existing parent is not a writable directory); nothing is made."""
    p = Path(os.fspath(out))
    if p.exists() and not p.is_dir():
        raise OptionError(f"the output directory {p} exists and is not a directory")
    parent = p.resolve()
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise OptionError(f"cannot create the output directory {p}: {parent} is not a writable directory")
    return p


def _prepare_dir(out) -> Path:
    p = _check_dir(out)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OptionError(f"cannot create the output directory {p}: {exc.strerror or exc}") from None
    return p


# ---------------------------------------------------------------------- writing
def _atomic_write(path: Path, data: bytes) -> None:
    atomic_write(path, lambda fh: fh.write(data), binary=True)


# (row key, plot title, y-axis label)
_PLOTS = (("hausdorff", "Hausdorff distance", "Hausdorff / bbox diagonal"),
          ("rms", "RMS distance", "RMS / bbox diagonal"),
          ("seconds", "Time", "seconds (the simplification call)"))
_PLOT_FILES = {"hausdorff": "hausdorff.png", "rms": "rms.png", "seconds": "time.png"}


def _plain_int(value, _pos=None) -> str:
    """A face count as a tick label: "6945", never "7×10³"."""
    return f"{int(round(value))}"


def _curve_figure(comparison: Comparison, key: str, title: str, ylabel: str):
    """The matplotlib Figure of ``key`` against face count, one line per method; face-count
    ticks at the targets (dotted lines), as plain integers; a run that stopped short of its
    target ringed in red."""
    _matplotlib()
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter, NullLocator

    fig = Figure(figsize=(6.4, 4.4), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    all_y, all_x, shorts = [], [], []
    for method in comparison.methods:
        runs = sorted((r for r in comparison.runs if r.method == method and r.evaluation is not None
                       and r.row()[key] is not None), key=lambda r: r.faces)
        if not runs:
            continue
        x = [r.faces for r in runs]
        y = [r.row()[key] for r in runs]
        all_x += x
        all_y += y
        ax.plot(x, y, marker="o", label=method)
        for r, yy in zip(runs, y):
            if r.stopped_short:
                shorts.append((r.faces, yy))
    if shorts:
        # a red ring round each result that kept more faces than its target (off its dotted line)
        ax.plot(*zip(*shorts), linestyle="none", marker="o", markersize=14, markerfacecolor="none",
                markeredgecolor="#c00000", markeredgewidth=1.6, label="stopped short of its target", zorder=3)
    ax.set_xscale("log")
    positive = all_y and min(all_y) > 0
    if positive and max(all_y) / min(all_y) > 20:
        ax.set_yscale("log")      # errors span decades between the ratios
    ticks = _thin_ticks(sorted({r.target_faces for r in comparison.runs}))
    for t in ticks:
        ax.axvline(t, color="#999999", linestyle=":", linewidth=0.8, zorder=0)   # the targets
    ax.xaxis.set_major_locator(FixedLocator(ticks))
    ax.xaxis.set_major_formatter(FuncFormatter(_plain_int))
    ax.xaxis.set_minor_locator(NullLocator())
    ax.xaxis.set_minor_formatter(NullFormatter())
    if ticks:
        ax.set_xlim(min(ticks + all_x) / 1.25, max(ticks + all_x) * 1.25)
    ax.set_xlabel("faces")
    ax.set_ylabel(ylabel)
    ax.set_title(f"{title} vs face count ({Path(comparison.source).name}, {comparison.n_faces} faces)")
    ax.grid(True, which="major", alpha=0.3)
    if all_y:
        ax.legend()
    return fig


def _thin_ticks(ticks: list) -> list:
    """Drop ticks closer than a factor 1.3 to the one kept before them (labels would overlap)."""
    kept = []
    for t in ticks:
        if t > 0 and (not kept or t / kept[-1] >= 1.3):
            kept.append(t)
    return kept


def _curve_png(comparison: Comparison, key: str, title: str, ylabel: str) -> bytes:
    fig = _curve_figure(comparison, key, title, ylabel)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def _camera(original: Mesh, width: int, height: int, view):
    if isinstance(view, viz.Camera):
        return view
    if view == "front":
        return viz.Camera.front(original, width, height)
    az, el = view
    return viz.Camera.front(original, width, height, azimuth=az, elevation=el)


def _contact_sheet(comparison: Comparison, original: Mesh, width: int, height: int,
                   backend: str | None, view="front") -> np.ndarray:
    """Rows = methods; columns = the original, then the ratios. One camera fitted to the
    original for every picture, so they are drawn alike; each cell labelled with its faces
    and Hausdorff error (the best per ratio in green, a run short of its target in red); a
    failed run leaves its cell empty but for the reason."""
    camera = _camera(original, width, height, view)
    first = viz.render(original, width, height, camera=camera, backend=backend)
    best = {id(r) for r in _best_runs(comparison, "hausdorff")}
    grid, labels, colors = [], [], []
    for method in comparison.methods:
        row, names, cols = [first], [f"{original.n_faces} faces\noriginal"], [None]
        for ratio in comparison.ratios:
            run = comparison.run(method, ratio)
            ok = run.mesh is not None and run.mesh.n_faces > 0
            row.append(viz.render(run.mesh, width, height, camera=camera, backend=backend) if ok else None)
            if run.evaluation is None:
                names.append("failed" if run.error else f"{run.faces} faces")
                cols.append("#c00000" if run.error else None)
                continue
            h = f"Hausdorff {run.evaluation.distance.hausdorff:.3g}"
            if run.stopped_short:
                names.append(f"{run.faces} faces, target {run.target_faces}\n{h} (stopped short)")
                cols.append("#c00000")
            else:
                names.append(f"{run.faces} faces\n{h}" + (" (best)" if id(run) in best else ""))
                cols.append("#00703c" if id(run) in best else None)
        grid.append(row)
        labels.append(names)
        colors.append(cols)
    col_titles = ["original"] + [f"{100 * r:g} %" for r in comparison.ratios]
    return viz.annotated_sheet(grid, labels=labels, label_colors=colors, row_titles=comparison.methods,
                               col_titles=col_titles)


def _best_runs(comparison: Comparison, key: str, higher: bool = False) -> list:
    """Per ratio, the run(s) with the best ``key`` among those evaluated that reached their
    target; nothing for a ratio with fewer than two such runs (no comparison to make)."""
    best = []
    for ratio in comparison.ratios:
        cands = [(r.row()[key], r) for r in comparison.runs
                 if r.ratio == ratio and r.evaluation is not None and not r.stopped_short]
        cands = [(v, r) for v, r in cands if v is not None and not (isinstance(v, float) and math.isnan(v))]
        if len(cands) < 2:
            continue
        top = max(v for v, _ in cands) if higher else min(v for v, _ in cands)
        best += [r for v, r in cands if v == top]
    return best


_CSV_COLUMNS = ("method", "kind", "ratio", "target_faces", "faces", "vertices", "stop_reason", "stopped_short",
                "seconds", *_METRIC_COLUMNS, "error")


def _csv_text(comparison: Comparison) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=_CSV_COLUMNS, lineterminator="\n")
    w.writeheader()
    for row in comparison.rows():
        w.writerow({k: ("" if v is None else repr(v) if isinstance(v, float) else v) for k, v in row.items()})
    return buf.getvalue()


# (column, header, format, best: "low" / "high" / None) of the report table
_REPORT_COLUMNS = (
    ("method", "method", "{}", None), ("ratio", "ratio", "{:g}", None), ("target_faces", "target", "{}", None),
    ("faces", "faces", "{}", None), ("vertices", "vertices", "{}", None),
    ("stop_reason", "stop reason", "{}", None), ("seconds", "time (s)", "{:.3f}", "low"),
    ("hausdorff", "Hausdorff", "{:.4g}", "low"), ("mean", "mean", "{:.4g}", "low"), ("rms", "RMS", "{:.4g}", "low"),
    ("normal_mean", "normal dev. mean (°)", "{:.3g}", "low"), ("normal_p95", "normal dev. p95 (°)", "{:.3g}", "low"),
    ("quality_min", "min Q", "{:.3f}", "high"), ("genus_change", "Δ genus", "{:+d}", None),
    ("boundary_loops_change", "Δ boundary loops", "{:+d}", None),
    ("nonmanifold_edges", "non-manifold edges", "{}", None), ("color_rms", "colour RMS (0-255)", "{:.3g}", "low"),
)

#: what marks a stopped-short result and a best value in the Markdown table
SHORT_MARK = "⚠ short"
BEST_MARK = "**"


def _report_cells(comparison: Comparison) -> tuple[list[str], list[list[tuple[str, str]]]]:
    """The table header and, per run, (text, kind) cells: kind "best", "short" or ""."""
    columns = [c for c in _REPORT_COLUMNS
               if c[0] != "color_rms" or any(r.evaluation is not None and r.evaluation.color for r in comparison.runs)]
    best = {key: set(map(id, _best_runs(comparison, key, higher=(way == "high"))))
            for key, _, _, way in columns if way}
    rows = []
    for run in comparison.runs:
        row = run.row()
        cells = []
        for key, _, fmt, way in columns:
            value = row[key]
            text = ("–" if value is None or (isinstance(value, float) and math.isnan(value))
                    else fmt.format(value))
            if key == "stop_reason":
                text = text.replace("_", " ")
            mark = ""
            if way and id(run) in best[key]:
                mark = "best"
            if key == "faces" and run.stopped_short:
                text, mark = f"{text} {SHORT_MARK}", "short"
            cells.append((text, mark))
        if run.error:
            cells[-1] = (f"failed: {run.error}", "")
        rows.append(cells)
    return [c[1] for c in columns], rows


def _intro(comparison: Comparison, peers: list) -> list[str]:
    c = comparison
    lines = [f"Input: {c.source} ({c.n_faces} faces, {c.n_vertices} vertices, bounding-box diagonal "
             f"{c.diagonal:.6g}). Ratios {', '.join(f'{r:g}' for r in c.ratios)}; methods "
             f"{', '.join(c.methods)}.",
             f"Distances are Metro-style from {c.n_samples} area-weighted samples on each surface (seed {c.seed}), "
             "as fractions of the input's bounding-box diagonal: Hausdorff = the larger one-sided maximum, "
             "mean and RMS over both sample sets (lodkit.evaluate; docs/evaluation.md). Time: the "
             "simplification call alone. Δ: simplified minus input."]
    for name in peers:
        lines.append(f"Peer {name}: {PEERS[name][3]}.")
    return lines


def _write_report(comparison: Comparison, original: Mesh, out: Path, contact_sheet: bool, width: int,
                  height: int, peers: list, backend: str | None, view="front") -> None:
    files = {}
    images = {}   # name -> PNG bytes, for the HTML
    for key, title, ylabel in _PLOTS:
        images[_PLOT_FILES[key]] = _curve_png(comparison, key, title, ylabel)
    for name, data in images.items():
        _atomic_write(out / name, data)
        files[name] = out / name
    if contact_sheet:
        # viz.write_png goes through the same atomic writer (lodkit.io.atomic.commit)
        sheet = _contact_sheet(comparison, original, width, height, backend, view)
        written = viz.write_png(out / "contact_sheet.png", sheet)
        images["contact_sheet.png"] = Path(written).read_bytes()
        files["contact_sheet.png"] = out / "contact_sheet.png"
    _atomic_write(out / "results.csv", _csv_text(comparison).encode())
    files["results.csv"] = out / "results.csv"
    payload = {k: v for k, v in comparison.__dict__.items() if k not in ("runs", "files")}
    payload["runs"] = [dict(r.row(), evaluation=None if r.evaluation is None else r.evaluation.as_dict())
                       for r in comparison.runs]
    _atomic_write(out / "results.json", json.dumps(payload, indent=1).encode())
    files["results.json"] = out / "results.json"

    header, rows = _report_cells(comparison)
    intro = _intro(comparison, peers)
    legend = (f"Bold: the best value in its column at that ratio, among the runs that reached their target. "
              f"\"{SHORT_MARK}\": the run stopped short of its target (more faces than asked for; "
              "see the stop reason), so its errors are not comparable with the others'.")
    sheet_caption = (f"Contact sheet: rows = {', '.join(comparison.methods)} (top to bottom); columns = the "
                     f"original, then ratios {', '.join(f'{r:g}' for r in comparison.ratios)} (left to right). "
                     "Each picture: its faces and Hausdorff distance (fraction of the bounding-box diagonal); "
                     "green: the best at that ratio, red: stopped short of its target.")

    def md_cell(text, mark):
        text = text.replace("|", "\\|")
        return f"{BEST_MARK}{text}{BEST_MARK}" if mark == "best" else text

    md = [f"# Simplification comparison: {Path(comparison.source).name}", "", *intro, "",
          "| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|",
          *("| " + " | ".join(md_cell(*c) for c in r) + " |" for r in rows), "", legend, "",
          "![Hausdorff distance against face count](hausdorff.png)", "",
          "![RMS distance against face count](rms.png)", "",
          "![Time against face count](time.png)", ""]
    if contact_sheet:
        md += [sheet_caption, "", "![contact sheet](contact_sheet.png)", ""]
    md += ["The table as CSV: [results.csv](results.csv); everything, with the full evaluations: "
           "[results.json](results.json).", ""]
    _atomic_write(out / "report.md", "\n".join(md).encode())
    files["report.md"] = out / "report.md"

    e = html.escape

    def img(name, alt):
        data = base64.b64encode(images[name]).decode("ascii")
        return f'<p><img src="data:image/png;base64,{data}" alt="{e(alt)}"></p>'

    def td(text, mark):
        return f'<td class="{mark}">{e(text)}</td>' if mark else f"<td>{e(text)}</td>"

    page = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
            f"<title>Simplification comparison: {e(Path(comparison.source).name)}</title>",
            "<style>body{font-family:sans-serif;margin:2em;max-width:80em}table{border-collapse:collapse}"
            "td,th{border:1px solid #bbb;padding:.2em .5em;text-align:right}td:first-child{text-align:left}"
            "td.best{font-weight:bold;background:#e3f4e8}td.short{color:#c00000;font-weight:bold}"
            "img{max-width:100%}</style></head><body>",
            f"<h1>Simplification comparison: {e(Path(comparison.source).name)}</h1>",
            *(f"<p>{e(line)}</p>" for line in intro),
            "<table><thead><tr>" + "".join(f"<th>{e(h)}</th>" for h in header) + "</tr></thead><tbody>",
            *("<tr>" + "".join(td(*c) for c in r) + "</tr>" for r in rows),
            "</tbody></table>", f"<p>{e(legend)}</p>",
            img("hausdorff.png", "Hausdorff distance against face count"),
            img("rms.png", "RMS distance against face count"),
            img("time.png", "Time against face count")]
    if contact_sheet:
        page += [f"<p>{e(sheet_caption)}</p>", img("contact_sheet.png", "contact sheet")]
    page += ['<p>The table as CSV: <a href="results.csv">results.csv</a>; everything, with the full '
             'evaluations: <a href="results.json">results.json</a>.</p>', "</body></html>", ""]
    _atomic_write(out / "report.html", "\n".join(page).encode())
    files["report.html"] = out / "report.html"
    comparison.files = files
