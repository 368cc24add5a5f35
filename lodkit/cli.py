"""The ``lodkit`` command: ``simplify``, ``info``, ``metrics``, ``demo``, ``evaluate``, ``compare``, ``lods``
and ``cluster``.

Every failure the user can cause (a missing or unreadable file, a bad option, a mesh
lodkit cannot use) prints one line ``lodkit: error: ...`` on standard error and exits
with status 2; an interrupt exits with 130. Tracebacks are kept for real bugs.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
import time
import warnings

from .errors import LodkitError, MeshIOError
from .geometry import weld_positions
from .version import __version__

__all__ = ["main"]

PROG = "lodkit"
EXIT_OK = 0
EXIT_USAGE = 2          # argparse's own code for usage errors; used for every user error
EXIT_INTERRUPTED = 130  # 128 + SIGINT, what shells report for Ctrl-C


class _UsageError(Exception):
    """An argparse error, turned into one line by :func:`main`."""


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser that raises instead of printing usage and exiting."""

    def error(self, message):
        hint = f"see '{self.prog} --help'"
        raise _UsageError(f"{message} ({hint})")


def main(argv=None) -> int:
    """Run the command line ``argv`` (``sys.argv[1:]`` by default); returns the exit status."""
    parser = _build_parser()
    try:
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:       # --help and --version exit 0 through here
            return int(exc.code or 0) if not isinstance(exc.code, str) else EXIT_USAGE
        if args.command is None:
            parser.print_help(sys.stderr)
            return EXIT_USAGE
        with _warnings_as_lines():
            return args.run(args)
    except _UsageError as exc:
        return _fail(str(exc))
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # the reader of our output went away (e.g. `lodkit info x.ply | head -1`): stop quietly
        _silence_stdout()
        return EXIT_USAGE
    except LodkitError as exc:
        return _fail(str(exc))
    except OSError as exc:
        return _fail(_describe_os_error(exc))


@contextlib.contextmanager
def _warnings_as_lines():
    """lodkit's warnings (e.g. DataLossWarning: the output format cannot hold an attribute)
    printed as one ``lodkit: warning: ...`` line each, not Python's two-line format."""
    with warnings.catch_warnings():
        def show(message, category, filename, lineno, file=None, line=None):
            print(f"{PROG}: warning: {message}", file=sys.stderr)
        warnings.showwarning = show
        yield


# ---------------------------------------------------------------------- the parser
def _build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog=PROG, description="Simplify triangle meshes into levels of detail.")
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    p = sub.add_parser(
        "simplify", help="simplify a mesh file",
        description="Simplify IN and write the result to OUT (any format lodkit can save: "
                    "PLY, OBJ, OFF, STL, GLB/GLTF). Give at least one target; with several, "
                    "simplification stops at whichever is reached first.",
    )
    p.add_argument("input", metavar="IN", help="input mesh file")
    p.add_argument("output", metavar="OUT", help="output mesh file")
    target = p.add_argument_group("targets (at least one)")
    target.add_argument("--ratio", type=_ratio, metavar="R", help="keep this fraction of the faces, 0 < R <= 1")
    target.add_argument("--faces", type=_count, metavar="N", help="stop at N faces")
    target.add_argument("--max-error", type=_non_negative, metavar="E",
                        help="stop before the error exceeds E (a fraction of the bounding-box "
                             "diagonal, or model units with --absolute)")
    p.add_argument("--absolute", action="store_true", help="--max-error and the reported error are in model units")
    _add_collapse_options(p, "cost metric, with options after a colon, e.g. 'qem' or "
                             "'importance:weight=2,merge=min' (values are read as int, float, "
                             "true/false or text); repeat to combine metrics (default: qem); "
                             "'lodkit metrics' lists them")
    p.add_argument("--max-normal-angle", type=float, metavar="DEG",
                   help="reject collapses that turn a face normal by more than DEG degrees")
    p.add_argument("--min-quality", type=float, metavar="Q",
                   help="reject collapses that make a triangle of quality below Q (0..1)")
    p.add_argument("--pair-threshold", type=_non_negative, metavar="T",
                   help="pair contraction: first merge vertices closer than T that share no edge, "
                        "joining parts and closing gaps (a fraction of the bbox diagonal, model "
                        "units with --absolute; off by default)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar and no summary line")
    p.set_defaults(run=_run_simplify)

    p = sub.add_parser("info", help="print counts, topology and attributes of a mesh file",
                       description="Print counts, manifoldness, boundary loops, components, genus, "
                                   "bounding-box diagonal and the attributes present.")
    p.add_argument("file", metavar="FILE", help="mesh file")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(run=_run_info)

    p = sub.add_parser("metrics", help="list the available cost metrics",
                       description="List every cost metric lodkit finds (its own and those of "
                                   "installed plugin packages): name, package, version, kind and "
                                   "whether it loads. Each metric is imported to check it.")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(run=_run_metrics)

    p = sub.add_parser("demo", help="simplify a generated test surface to several levels",
                       description="Generate the demo surface (creases, a boundary, fine detail, "
                                   "colours), simplify it to 50 %%, 20 %%, 5 %% and 1 %% and write "
                                   "one PLY per level.")
    p.add_argument("--out", default="lodkit-demo", metavar="DIR", help="output directory (default: lodkit-demo)")
    p.add_argument("--faces", type=_count, default=100_000, metavar="N",
                   help="faces of the demo surface (default: 100000)")
    p.set_defaults(run=_run_demo)

    p = sub.add_parser("lods", help="write a chain of levels of detail from one simplification run",
                       description="Simplify IN once into a progressive mesh, extract one level per "
                                   "ratio (each equal to 'lodkit simplify --ratio R') and write them "
                                   "to DIR as <name>_lod<i>.<format>, with summary.json and "
                                   "summary.csv (level, ratio, faces, vertices, error, file).")
    p.add_argument("input", metavar="IN", help="input mesh file")
    p.add_argument("--ratios", type=_ratio_list, required=True, metavar="R1,R2,...",
                   help="fractions of the faces to keep, each 0 < R <= 1, e.g. 0.5,0.1,0.02")
    p.add_argument("--out-dir", required=True, metavar="DIR", help="output directory (made if missing)")
    p.add_argument("--format", choices=("ply", "obj", "glb"), default="ply",
                   help="file format of the levels (default: ply)")
    _add_collapse_options(p, "cost metric, as for 'lodkit simplify' (repeat to combine; default: qem)")
    p.add_argument("--absolute", action="store_true", help="report errors in model units")
    p.add_argument("--quiet", "-q", action="store_true", help="no summary lines")
    p.set_defaults(run=_run_lods)

    p = sub.add_parser("evaluate", help="measure how far a simplified mesh is from the original",
                       description="Metro-style distances (Hausdorff, mean, RMS; both one-sided and "
                                   "symmetric) from area-weighted samples, normal deviation, triangle "
                                   "quality, topology changes and, when both have vertex colours, the "
                                   "colour error of SIMPLIFIED against ORIGINAL (docs/evaluation.md).")
    p.add_argument("original", metavar="ORIGINAL", help="original mesh file")
    p.add_argument("simplified", metavar="SIMPLIFIED", help="simplified mesh file")
    _add_sampling_options(p, "random points on each surface (default: 200000)")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(run=_run_evaluate)

    p = sub.add_parser("compare", help="compare simplifiers on a mesh: curves, table, contact sheet, report",
                       description="Simplify IN with each metric and peer library to each ratio, time and "
                                   "evaluate every result, and write error-versus-face-count plots, a table "
                                   "(CSV, JSON), a contact sheet of the LODs and a Markdown and HTML report "
                                   "into DIR. The plots need matplotlib: pip install 'lodkit[plot]'.")
    p.add_argument("input", metavar="IN", help="input mesh file")
    p.add_argument("--metrics", default="qem", metavar="NAMES",
                   help="comma-separated lodkit metrics (default: qem); 'lodkit metrics' lists them")
    p.add_argument("--peers", default="", metavar="NAMES",
                   help="comma-separated peer libraries: open3d, fast_simplification, pyfqmr, pymeshlab")
    p.add_argument("--ratios", default="0.5,0.1,0.02", type=_ratio_list, metavar="R,R,...",
                   help="fractions of the faces to keep (default: 0.5,0.1,0.02)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created if missing)")
    _add_sampling_options(p, "random points on each surface per evaluation (default: 200000)")
    p.add_argument("--size", type=_image_size, default=(320, 240), metavar="WxH",
                   help="size of each picture in the contact sheet (default: 320x240)")
    p.add_argument("--render-backend", choices=("open3d", "numpy"),
                   help="renderer for the contact sheet (default: Open3D's if it works here)")
    p.add_argument("--no-contact-sheet", action="store_true", help="do not render the LODs")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress lines")
    p.set_defaults(run=_run_compare)

    p = sub.add_parser("cluster", help="simplify a mesh file by vertex clustering on a uniform grid",
                       description="Merge the vertices in each cell of a uniform grid (Rossignac-Borrel "
                                   "vertex clustering; docs/clustering.md) and write the result to OUT. "
                                   "Fast and works on any triangle soup, but the output need not be "
                                   "manifold. Give exactly one of --cell-size, --faces, --vertices.")
    p.add_argument("input", metavar="IN", help="input mesh file")
    p.add_argument("output", metavar="OUT", help="output mesh file")
    size = p.add_mutually_exclusive_group(required=True)
    size.add_argument("--cell-size", type=_positive, metavar="H",
                      help="cell side, a fraction of the bounding-box diagonal (model units with --absolute)")
    size.add_argument("--faces", type=_count, metavar="N", help="search the cell size for about N faces")
    size.add_argument("--vertices", type=_count, metavar="N", help="search the cell size for about N vertices")
    p.add_argument("--representative", choices=("quadric", "importance", "mean"), default="quadric",
                   help="the vertex of a cell: quadric minimiser (default), most important input vertex, or centroid")
    p.add_argument("--absolute", action="store_true", help="--cell-size and the reported error are in model units")
    p.add_argument("--quiet", "-q", action="store_true", help="no summary line")
    p.set_defaults(run=_run_cluster)
    return parser


def _add_collapse_options(p, metric_help: str) -> None:
    """--metric, --placement and --boundary, as simplify and lods take them."""
    p.add_argument("--metric", type=_metric_option, action="append", metavar="NAME[:OPT=VAL,...]", help=metric_help)
    p.add_argument("--placement", choices=("optimal", "endpoint"),
                   help="where the merged vertex goes (default: optimal)")
    p.add_argument("--boundary", choices=("lock", "preserve", "free"),
                   help="how boundaries are treated (default: preserve)")


def _add_sampling_options(p, samples_help: str) -> None:
    """--samples and --seed of the error measurement, as evaluate and compare take them."""
    p.add_argument("--samples", type=_count, default=200_000, metavar="N", help=samples_help)
    p.add_argument("--seed", type=_seed, default=0, metavar="S", help="sampling seed (default: 0)")


def _number(text: str, kind=float):
    try:
        value = kind(text)
    except ValueError:
        what = "a whole number" if kind is int else "a number"
        raise argparse.ArgumentTypeError(f"not {what}: {text!r}") from None
    if kind is float and not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return value


def _ratio(text: str) -> float:
    value = _number(text)
    if not 0.0 < value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be in (0, 1], got {text}")
    return value


def _count(text: str) -> int:
    value = _number(text, int)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {text}")
    return value


def _ratio_list(text: str) -> list:
    items = [t.strip() for t in text.split(",")]
    if not items or any(not t for t in items):
        raise argparse.ArgumentTypeError(f"expected comma-separated ratios like 0.5,0.1, got {text!r}")
    return [_ratio(t) for t in items]


def _image_size(text: str) -> tuple:
    w, sep, h = text.lower().partition("x")
    if not sep:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT, got {text!r}")
    return _count(w.strip()), _count(h.strip())


def _seed(text: str) -> int:
    value = _number(text, int)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text}")
    return value


def _non_negative(text: str) -> float:
    value = _number(text)
    if value < 0.0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text}")
    return value


def _metric_option(text: str):
    """``NAME[:OPT=VAL,...]`` -> ``NAME`` or ``(NAME, {OPT: VAL})``.  NAME may itself be
    ``package:name``: the options start at the first ``:`` followed by ``OPT=``."""
    parts = text.split(":")
    start = next((i for i in range(1, len(parts)) if "=" in parts[i]), len(parts))
    name = ":".join(parts[:start]).strip()
    if not name or any(not p.strip() for p in parts[:start]):
        raise argparse.ArgumentTypeError(f"expected NAME[:OPT=VALUE,...], got {text!r}")
    if start == len(parts):
        return name
    options = {}
    for item in ":".join(parts[start:]).split(","):
        key, eq, value = item.partition("=")
        key = key.strip()
        if not eq or not key:
            raise argparse.ArgumentTypeError(
                f"metric {name!r}: expected OPT=VALUE, got {item.strip()!r} (in {text!r})")
        if key in options:
            raise argparse.ArgumentTypeError(f"metric {name!r}: option {key!r} given twice")
        options[key] = _option_value(value.strip())
    return name, options


def _option_value(text: str):
    """An option value from the command line: int, float, bool (true/false) or text."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    return text


def _metric_spec(items):
    """The ``metric=`` argument of simplify() from the ``--metric`` options (None: default),
    created once so that unknown names and bad options fail before a large mesh is loaded."""
    if not items:
        return None
    metric = items[0] if len(items) == 1 else list(items)
    from .metrics import create

    create(metric)
    return metric


# ---------------------------------------------------------------------- commands
def _run_simplify(args) -> int:
    from . import load, save, simplify

    if args.ratio is None and args.faces is None and args.max_error is None:
        raise _UsageError("simplify needs a target: --ratio, --faces or --max-error (see 'lodkit simplify --help')")
    _check_output(args.output)     # before the work, not after it
    metric = _metric_spec(args.metric)
    options = {
        "target_ratio": args.ratio,
        "target_faces": args.faces,
        "max_error": args.max_error,
        "absolute": args.absolute,
        "metric": metric,
        "placement": args.placement,
        "boundary": args.boundary,
        "max_normal_angle": args.max_normal_angle,
        "min_quality": args.min_quality,
        "pair_threshold": args.pair_threshold,
    }
    # leave out what the user did not give, so simplify()'s own defaults apply
    options = {k: v for k, v in options.items() if v is not None}
    options["progress"] = not args.quiet and _is_tty(sys.stderr)

    mesh = load(args.input)
    t0 = time.perf_counter()
    result = simplify(mesh, **options)
    seconds = time.perf_counter() - t0
    save(result.mesh, args.output)
    if not args.quiet:
        out = result.mesh
        unit = "model units" if args.absolute else "of bbox diagonal"
        print(f"{args.input}: {_reduction(mesh, out)}, error {result.error:.3g} {unit}, "
              f"stop: {result.stop_reason}, {seconds:.2f} s -> {args.output}")
    return EXIT_OK


def _run_cluster(args) -> int:
    from . import cluster, load, save

    _check_output(args.output)
    mesh = load(args.input)
    result = cluster(mesh, cell_size=args.cell_size, target_faces=args.faces, target_vertices=args.vertices,
                     representative=args.representative, absolute=args.absolute)
    save(result.mesh, args.output)
    if not args.quiet:
        out = result.mesh
        unit = "model units" if args.absolute else "of bbox diagonal"
        print(f"{args.input}: {_reduction(mesh, out)}, cell {result.cell_size:.3g} {unit}, "
              f"grid {'x'.join(map(str, result.report['grid']))}, error {result.error:.3g} {unit}, "
              f"{result.elapsed:.2f} s -> {args.output}")
    return EXIT_OK


def _positive(text: str) -> float:
    value = _number(text)
    if not value > 0.0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def _run_info(args) -> int:
    from . import load
    from .topology import topology

    mesh = load(args.file)
    welded = mesh
    if mesh.uvs is not None:
        # load() gives a vertex per (position, uv) pair, which cuts the surface open along
        # every uv seam; the topology of the shape is that of the welded positions
        welded = _weld_positions(mesh)
    report = topology(welded)
    info = {
        "file": str(args.file),
        "n_vertices": mesh.n_vertices,
        "n_faces": mesh.n_faces,
        "bbox_diagonal": mesh.bbox_diagonal(),
        "attributes": sorted(mesh.attributes()),
        "uv_seam_split_vertices": mesh.n_vertices - welded.n_vertices,
        "topology": report.as_dict(),
    }
    if mesh.metadata.get("load_notes"):
        info["load_notes"] = list(mesh.metadata["load_notes"])   # polygons triangulated, data not read
    if args.json:
        print(json.dumps(info, indent=2))
        return EXIT_OK
    rows = [
        ("file", info["file"]),
        ("vertices", f"{mesh.n_vertices} ({report.n_vertices - report.n_referenced_vertices} unreferenced"
                     + (f", {welded.n_vertices} positions: split at uv seams)" if welded is not mesh else ")")),
        ("faces", f"{report.n_faces} ({report.n_degenerate_faces} degenerate, {report.n_duplicate_faces} duplicate)"),
        ("edges", f"{report.n_edges} ({report.n_boundary_edges} boundary, {report.n_nonmanifold_edges} non-manifold)"),
        ("manifold", _manifold_text(report)),
        ("closed", "yes" if report.is_closed else f"no, {report.n_boundary_loops} boundary loop(s)"),
        ("oriented", "yes" if report.is_oriented else
            f"no, {report.n_inconsistent_edges} edge(s) with conflicting faces"
            + ("" if report.is_orientable else "; not orientable")),
        ("components", str(report.n_components)),
        ("euler characteristic", str(report.euler_characteristic)),
        ("genus", "-" if report.genus is None else str(report.genus)),
        ("bbox diagonal", f"{info['bbox_diagonal']:.6g}"),
        ("attributes", ", ".join(info["attributes"]) or "none"),
    ] + [("load note", note) for note in info.get("load_notes", [])]
    width = max(len(name) for name, _ in rows)
    for name, value in rows:
        print(f"{name:<{width}}  {value}")
    return EXIT_OK


def _run_metrics(args) -> int:
    from .metrics import available

    rows = []
    for info in available(load=True):
        status = "ok" if info.loaded else " ".join(str(info.error or "not loaded").split())
        rows.append({
            "name": info.name,
            "package": info.package,
            "version": info.version,
            "kind": info.kind,
            "status": status,
            "ok": bool(info.loaded),
            "qualified": info.qualified,
            "source": info.source,
            "target": info.target,
            "description": info.description,
        })
    if args.json:
        print(json.dumps(rows, indent=2))
        return EXIT_OK
    columns = ("name", "package", "version", "kind", "status")
    table = [columns] + [tuple(str(r[c]) if r[c] not in (None, "") else "-" for c in columns) for r in rows]
    widths = [max(len(row[i]) for row in table) for i in range(len(columns) - 1)]
    for row in table:
        print("  ".join(f"{cell:<{w}}" for cell, w in zip(row, widths)) + "  " + row[-1])
    if not rows:
        print("(no metrics found)")
    return EXIT_OK


def _run_lods(args) -> int:
    import csv
    import io as _io

    from . import load, save
    from .io import atomic_write
    from .progressive import progressive

    metric = _metric_spec(args.metric)
    out_dir = os.path.abspath(args.out_dir)
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise MeshIOError(f"cannot write to {args.out_dir}: it is not a directory")
    parent = os.path.dirname(out_dir)
    if not os.path.isdir(parent):
        raise MeshIOError(f"cannot write to {args.out_dir}: directory {parent} does not exist")
    mesh = load(args.input)
    options = {"metric": metric, "placement": args.placement, "boundary": args.boundary}
    options = {k: v for k, v in options.items() if v is not None}
    t0 = time.perf_counter()
    pm = progressive(mesh, absolute=args.absolute, **options)
    seconds = time.perf_counter() - t0
    os.makedirs(out_dir, exist_ok=True)
    stem = os.path.splitext(os.path.basename(args.input))[0] or "mesh"
    rows = []
    for i, ratio in enumerate(args.ratios):
        level = pm.level(ratio=ratio)
        name = f"{stem}_lod{i}.{args.format}"
        save(level.mesh, os.path.join(out_dir, name))
        rows.append({"level": i, "ratio": ratio, "faces": level.n_faces, "vertices": level.n_vertices,
                     "error": level.error, "file": name})
    summary = {"input": str(args.input), "input_faces": mesh.n_faces, "input_vertices": mesh.n_vertices,
               "metrics": pm.info["metrics"], "error_unit": "model units" if args.absolute else "bbox diagonal",
               "levels": rows}
    text = _io.StringIO()
    writer = csv.DictWriter(text, fieldnames=["level", "ratio", "faces", "vertices", "error", "file"],
                            lineterminator="\n")
    writer.writeheader()
    writer.writerows({**r, "error": repr(r["error"])} for r in rows)
    for fname, content in (("summary.json", json.dumps(summary, indent=2) + "\n"), ("summary.csv", text.getvalue())):
        atomic_write(os.path.join(out_dir, fname), lambda fh, c=content: fh.write(c))
    if not args.quiet:
        print(f"{args.input}: {mesh.n_faces} faces, one run of {pm.n_steps} collapses in {seconds:.2f} s")
        for r in rows:
            print(f"  lod{r['level']}: ratio {r['ratio']:g}, {r['faces']} faces, {r['vertices']} vertices, "
                  f"error {r['error']:.3g} -> {os.path.join(args.out_dir, r['file'])}")
    return EXIT_OK


def _run_demo(args) -> int:
    from .demo import run_demo

    run_demo(args.out, n_faces=args.faces, stream=sys.stdout)
    return EXIT_OK


def _run_evaluate(args) -> int:
    from .evaluate import evaluate

    ev = evaluate(args.original, args.simplified, samples=args.samples, seed=args.seed)
    if args.json:
        print(json.dumps({"original": str(args.original), "simplified": str(args.simplified), **ev.as_dict()},
                         indent=2))
        return EXIT_OK
    print(f"{args.simplified} against {args.original}")
    print(ev.table())
    return EXIT_OK


def _run_compare(args) -> int:
    from .compare import compare

    log = None if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    result = compare(args.input, metrics=args.metrics, peers=args.peers, ratios=args.ratios, out=args.out,
                     samples=args.samples, seed=args.seed, contact_sheet=not args.no_contact_sheet,
                     image_size=args.size, render_backend=args.render_backend, log=log)
    failed = sum(1 for r in result.runs if r.error)
    print(f"{len(result.runs)} runs ({failed} failed) -> {result.files['report.html']}, {result.files['report.md']}")
    return EXIT_OK


# ---------------------------------------------------------------------- helpers
def _manifold_text(report) -> str:
    if report.is_manifold:
        return "yes"
    problems = []
    if report.n_nonmanifold_edges:
        problems.append(f"{report.n_nonmanifold_edges} non-manifold edge(s)")
    if report.n_nonmanifold_vertices:
        problems.append(f"{report.n_nonmanifold_vertices} non-manifold vertex(es)")
    if report.n_degenerate_faces:
        problems.append(f"{report.n_degenerate_faces} degenerate face(s)")
    return "no, " + ", ".join(problems)


def _percent(part: int, whole: int) -> str:
    return f"{100.0 * part / whole:.1f} %" if whole else "-"


def _check_output(path: str) -> None:
    """Fail early on an output path save() would refuse: unknown format, missing directory."""
    from .io import SUPPORTED_FORMATS

    ext = os.path.splitext(path)[1].lower().lstrip(".")
    if ext not in SUPPORTED_FORMATS:
        raise MeshIOError(
            f"cannot save {path}: unsupported file format ("
            + (f"extension '.{ext}'" if ext else "no extension")
            + "); supported: " + ", ".join("." + e for e in SUPPORTED_FORMATS)
        )
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise MeshIOError(f"cannot save {path}: directory {directory} does not exist")
    if os.path.isdir(path):
        raise MeshIOError(f"cannot save {path}: it is a directory")


def _reduction(mesh, out) -> str:
    """``"F -> f faces (p %), V -> v vertices"`` for a summary line."""
    return (f"{mesh.n_faces} -> {out.n_faces} faces ({_percent(out.n_faces, mesh.n_faces)}), "
            f"{mesh.n_vertices} -> {out.n_vertices} vertices")


def _weld_positions(mesh):
    """The mesh's faces over its distinct positions (attributes dropped): for topology only."""
    from .mesh import Mesh

    return Mesh(*weld_positions(mesh.vertices, mesh.faces))


def _is_tty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def _describe_os_error(exc: OSError) -> str:
    if exc.filename is not None and exc.strerror:
        return f"{exc.filename}: {exc.strerror}"
    return str(exc) or type(exc).__name__


def _fail(message: str) -> int:
    # one line, whatever the exception text looks like
    line = " ".join(str(message).split())
    print(f"{PROG}: error: {line}", file=sys.stderr)
    return EXIT_USAGE


def _silence_stdout() -> None:
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass
