"""The ``lodkit`` command: ``simplify``, ``info``, ``metrics``, ``demo``, ``evaluate``, ``compare``, ``lods``,
``cluster``, ``retile``, ``optimize`` and ``batch``.

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

from . import _signals

with _signals.import_guard():       # Ctrl-C while the command starts: one line, exit 130
    import argparse
    import json
    import math
    import os
    import time

    from .errors import LodkitError, MeshIOError
    from .geometry import weld_positions
    from .version import __version__

__all__ = ["main"]

PROG = "lodkit"
EXIT_OK = 0
EXIT_USAGE = 2          # argparse's own code for usage errors; used for every user error
EXIT_FAILED = 1         # lodkit batch: some inputs failed (the others were written)
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
    with _signals.cli_handler():
        try:
            return _main(argv)
        except Exception:
            # a library that turned Ctrl-C into its own error (Open3D's import does)
            if _signals.interrupted():
                return _interrupted()
            raise


def _main(argv) -> int:
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
        return _interrupted()
    except BrokenPipeError:
        # the reader of our output went away (e.g. `lodkit info x.ply | head -1`): stop quietly
        _silence_stdout()
        return EXIT_USAGE
    except LodkitError as exc:
        return _interrupted() if _signals.interrupted() else _fail(str(exc))
    except ImportError as exc:          # a dependency lodkit.deps does not wrap
        return _fail(f"a library lodkit needs cannot be imported: {exc}")
    except OSError as exc:
        return _interrupted() if _signals.interrupted() else _fail(_describe_os_error(exc))


def _interrupted() -> int:
    print(f"{PROG}: interrupted", file=sys.stderr)
    _signals.exit_if_command(EXIT_INTERRUPTED)      # the command ends here, status 130
    return EXIT_INTERRUPTED


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
    target.add_argument("--max-distance", type=_distance, metavar="E",
                        help="a guaranteed bound: stop before the surface would move farther than E from "
                             "the input, both ways (model units, or 'E%%' of the bounding-box diagonal; "
                             "docs/error-bound.md)")
    p.add_argument("--absolute", action="store_true", help="--max-error and the reported error are in model units")
    _add_collapse_options(p, "cost metric, with options after a colon, e.g. 'qem' or "
                             "'curvature:merge=mean,weight=2' (values are read as int, float, "
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
    p.add_argument("--polish", action="store_true",
                   help="after the run, fit the output's vertices to the input surface: a lower "
                        "mean error, for a closest-point search per round (docs/algorithms.md, "
                        "\"Polish\"); not with --max-distance")
    tiles = p.add_argument_group("meshes too large for one process (docs/scale.md)")
    tiles.add_argument("--tiles", action="store_true",
                       help="simplify in spatial tiles on Dask workers (lodkit.simplify_large): positions only")
    tiles.add_argument("--tile-faces", type=_count, default=250_000, metavar="N",
                       help="faces per tile (default: 250000)")
    tiles.add_argument("--workers", type=_count, metavar="N",
                       help="worker processes of the local Dask cluster (default: one per core)")
    tiles.add_argument("--scheduler", metavar="ADDRESS",
                       help="a running Dask scheduler, or 'threads' / 'sync' to run in this process")
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
                                   "colours), simplify it to 50 %, 20 %, 5 % and 1 %, write "
                                   "one PLY per level (demo_lod0.ply is the original, demo_lod1.ply "
                                   "... demo_lod4.ply the levels) and a picture of them (demo_lods.png).")
    p.add_argument("--out", default="lodkit-demo", metavar="DIR", help="output directory (default: lodkit-demo)")
    p.add_argument("--faces", type=_count, default=100_000, metavar="N",
                   help="faces of the demo surface (default: 100000)")
    p.add_argument("--no-picture", action="store_true", help="do not render the levels into demo_lods.png")
    p.set_defaults(run=_run_demo)

    p = sub.add_parser("lods", help="write a chain of levels of detail from one simplification run",
                       description="Simplify IN once into a progressive mesh, extract one level per "
                                   "ratio (each equal to 'lodkit simplify --ratio R') and write them "
                                   "to DIR as <name>_lod1.<format>, <name>_lod2.<format>, ... in the "
                                   "order given, with the input itself as <name>_lod0.<format> (level 0 "
                                   "is the original, as in 'lodkit demo'), and summary.json and "
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
                   help="comma-separated peer libraries: open3d, fast_simplification, pyfqmr, pymeshlab; "
                        "or lodkit's global methods retile, optimize; or polish (lodkit's QEM with polish=True)")
    p.add_argument("--ratios", default="0.5,0.1,0.02", type=_ratio_list, metavar="R,R,...",
                   help="fractions of the faces to keep (default: 0.5,0.1,0.02)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created if missing)")
    _add_sampling_options(p, "random points on each surface per evaluation (default: 200000)")
    p.add_argument("--size", type=_image_size, default=(320, 240), metavar="WxH",
                   help="size of each picture in the contact sheet (default: 320x240)")
    p.add_argument("--render-backend", choices=("open3d", "numpy"),
                   help="renderer for the contact sheet (default: Open3D's if it works here)")
    p.add_argument("--view", default="front", metavar="front|AZ,EL",
                   help="the contact sheet's camera: 'front' (default: the front of the mesh's principal axes, "
                        "turned 30 degrees and raised 20) or AZ,EL degrees from that front view (0,0: straight on)")
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

    p = sub.add_parser("retile", help="re-tile a mesh file with evenly spread new vertices (Turk 1992)",
                       description="Spread N new vertices evenly over the surface of IN by repulsion, "
                                   "insert them and remove the old vertices (docs/retile.md); the result "
                                   "has well-shaped triangles and the input's topology.")
    p.add_argument("input", metavar="IN", help="input mesh file")
    p.add_argument("output", metavar="OUT", help="output mesh file")
    p.add_argument("--vertices", type=_count, required=True, metavar="N", help="number of new vertices (>= 4)")
    p.add_argument("--adapt", type=_non_negative, default=0.0, metavar="A",
                   help="density follows curvature: 1 + A * curvature / mean (default: 0, uniform)")
    p.add_argument("--equalize", action="store_true",
                   help="density proportional to curvature at the edge length's scale (the same chord error "
                        "everywhere; replaces --adapt)")
    p.add_argument("--features", type=_positive, metavar="DEG",
                   help="keep creases: edges whose faces turn by more than DEG degrees (default: off)")
    p.add_argument("--refine", type=_seed, default=0, metavar="K",
                   help="error-driven passes: re-tile K more times with the density raised where the "
                        "last pass was far from the input; of the passes within 1.2x of the smallest "
                        "largest error, the best-shaped is kept (default: 0)")
    p.add_argument("--draws", type=_count, default=1, metavar="K",
                   help="re-tilings per pass at the same density; the choice among passes sees all of "
                        "them, within 1.7x of the smallest error (default: 1)")
    p.add_argument("--fit", type=_seed, default=0, metavar="K",
                   help="lodkit's addition, not Turk's: K rounds moving the new vertices along their normals "
                        "so that the result straddles the input (vertices leave the surface; default: 0)")
    p.add_argument("--iterations", type=_seed, default=30, metavar="K", help="repulsion steps (default: 30)")
    p.add_argument("--relax", type=_seed, default=3, metavar="K",
                   help="rounds of tangential relaxation after the flips (default: 3; 0: Turk's steps only)")
    p.add_argument("--seed", type=_seed, default=0, metavar="S", help="random seed (default: 0)")
    p.add_argument("--quiet", "-q", action="store_true", help="no summary line")
    p.set_defaults(run=_run_retile)

    p = sub.add_parser("optimize", help="mesh optimisation: minimise distance + vertex count + springs "
                                        "(Hoppe et al. 1993)",
                       description="Fit a mesh to points sampled on IN by alternating least-squares vertex "
                                   "positions with edge collapses, splits and swaps (docs/optimize.md). "
                                   "Starts from --start, or from lodkit's QEM result at --vertices.")
    p.add_argument("input", metavar="IN", help="input mesh file (the original surface)")
    p.add_argument("output", metavar="OUT", help="output mesh file")
    p.add_argument("--vertices", type=_count, metavar="N", help="aim for N vertices (c_rep is annealed)")
    p.add_argument("--start", metavar="FILE", help="the mesh to start from (e.g. a simplify result)")
    p.add_argument("--c-rep", type=_non_negative, metavar="C", help="cost of a vertex (default: 1e-5, or "
                   "estimated with --vertices)")
    p.add_argument("--spring", type=_non_negative, default=None, metavar="K", help="spring constant (default: 1e-8)")
    p.add_argument("--iterations", type=_seed, default=6, metavar="K", help="outer iterations (default: 6)")
    p.add_argument("--samples", type=_count, metavar="N", help="points sampled on IN (default: see docs)")
    p.add_argument("--creases", type=_non_negative, default=None, metavar="DEG",
                   help="dihedral angle above which an edge of IN is a crease kept sharp (default: 60; 0: off)")
    p.add_argument("--seed", type=_seed, default=0, metavar="S", help="random seed (default: 0)")
    p.add_argument("--quiet", "-q", action="store_true", help="no summary line nor progress bar")
    p.set_defaults(run=_run_optimize)

    parser.set_defaults(subcommands=sub.choices)

    p = sub.add_parser("batch", help="write LOD chains for many mesh files, on Dask, resumably",
                       description="Simplify every mesh in IN... (files, folders searched recursively, "
                                   "globs) to each ratio and write DIR/<name>_lod<i>.<format>, with "
                                   "manifest.json and manifest.csv (hash, settings, status, faces and "
                                   "error per level, time, worker). A re-run skips what the manifest "
                                   "says is done; a file that fails is a 'failed' row and the others go "
                                   "on. Runs on a Dask LocalCluster by default (pip install "
                                   "'lodkit[dask]'); docs/scale.md.")
    p.add_argument("inputs", nargs="+", metavar="IN", help="mesh file, folder or glob pattern")
    p.add_argument("--out-dir", required=True, metavar="DIR", help="output directory (made if missing)")
    p.add_argument("--ratios", type=_ratio_list, default=[0.5, 0.1, 0.02], metavar="R1,R2,...",
                   help="fractions of the faces to keep, one level each (default: 0.5,0.1,0.02)")
    p.add_argument("--format", choices=("ply", "obj", "glb"), default="ply",
                   help="file format of the levels (default: ply)")
    _add_collapse_options(p, "cost metric, as for 'lodkit simplify' (repeat to combine; default: qem)")
    engine = p.add_mutually_exclusive_group()
    engine.add_argument("--workers", type=_count, metavar="N",
                        help="worker processes of the local Dask cluster (default: one per core), "
                             "or threads with --scheduler threads")
    engine.add_argument("--scheduler", metavar="ADDRESS",
                        help="a running Dask scheduler (e.g. tcp://10.0.0.5:8786), or 'threads' / "
                             "'sync' to run in this process without Dask")
    p.add_argument("--threads", type=_count, metavar="N", help="with --scheduler threads: N threads")
    p.add_argument("--polish", action="store_true",
                   help="fit each level's vertices to the input surface, as 'lodkit simplify --polish'")
    p.add_argument("--force", action="store_true", help="redo every input, even those the manifest says are done")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar and no summary line")
    p.set_defaults(run=_run_batch)
    return parser


SYNOPSIS_BEGIN = "<!-- cli-synopsis: generated from argparse by lodkit.cli.update_synopsis; do not edit -->"
SYNOPSIS_END = "<!-- end of cli-synopsis -->"


def synopsis(width: int = 100) -> str:
    """The usage line of every subcommand, as argparse prints it at ``width`` columns (the
    command-line synopsis of docs/getting-started.md)."""
    commands = _build_parser().get_default("subcommands")
    blocks = []
    for p in commands.values():
        formatter = argparse.HelpFormatter(prog=p.prog, width=width)
        formatter.add_usage(p.usage, p._actions, p._mutually_exclusive_groups, prefix="")
        blocks.append(formatter.format_help().strip())
    return "\n".join(blocks)


def update_synopsis(path) -> bool:
    """Rewrite the synopsis block of the Markdown file ``path`` (between SYNOPSIS_BEGIN and
    SYNOPSIS_END) from :func:`synopsis`; True when it changed."""
    with open(path, encoding="utf-8") as fh:
        text = fh.read()
    head, begin, rest = text.partition(SYNOPSIS_BEGIN)
    _, end, tail = rest.partition(SYNOPSIS_END)
    if not begin or not end:
        raise ValueError(f"{path} has no {SYNOPSIS_BEGIN!r} ... {SYNOPSIS_END!r} block")
    new = f"{head}{SYNOPSIS_BEGIN}\n```text\n{synopsis()}\n```\n{SYNOPSIS_END}{tail}"
    if new != text:
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(new)
    return new != text


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


def _distance(text: str) -> tuple:
    """``E`` (model units) or ``E%`` (percent of the bounding-box diagonal) -> (E, is_percent)."""
    t = text.strip()
    percent = t.endswith("%")
    value = _non_negative(t[:-1].strip() if percent else t)
    return value, percent


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

    if args.ratio is None and args.faces is None and args.max_error is None and args.max_distance is None:
        raise _UsageError("simplify needs a target: --ratio, --faces, --max-error or --max-distance "
                          "(see 'lodkit simplify --help')")
    if args.max_distance is not None and args.max_error is not None:
        raise _UsageError("give --max-error (the collapse error) or --max-distance (a guaranteed distance), not both")
    if args.polish and args.max_distance is not None:
        raise _UsageError("--polish does not go with --max-distance (moving vertices would void the bound)")
    if args.polish and args.tiles:
        raise _UsageError("--polish does not go with --tiles")
    if args.max_distance is not None and args.tiles:
        raise _UsageError("--max-distance does not go with --tiles (the tiles' seams are not bounded)")
    _check_output(args.output)     # before the work, not after it
    if args.tiles:
        return _run_simplify_large(args)
    if args.workers is not None or args.scheduler is not None:
        raise _UsageError("--workers and --scheduler go with --tiles (see 'lodkit simplify --help')")
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
        "polish": True if args.polish else None,
    }
    # leave out what the user did not give, so simplify()'s own defaults apply
    options = {k: v for k, v in options.items() if v is not None}
    options["progress"] = not args.quiet and _is_tty(sys.stderr)

    mesh = load(args.input)
    if args.max_distance is not None:
        value, percent = args.max_distance
        options["error"] = "hausdorff"
        # max_error in the unit --absolute says (the reported error's): convert if needed
        if percent and not args.absolute:
            options["max_error"] = value / 100.0
        elif not percent and args.absolute:
            options["max_error"] = value
        else:
            diagonal = _diagonal(mesh)
            options["max_error"] = value / 100.0 * diagonal if percent else value / diagonal
    t0 = time.perf_counter()
    result = simplify(mesh, **options)
    seconds = time.perf_counter() - t0
    save(result.mesh, args.output)
    if not args.quiet:
        out = result.mesh
        unit = "model units" if args.absolute else "of bbox diagonal"
        bound = ""
        if result.bound is not None:
            bound = (f", within {result.bound.absolute:.3g} model units ({100.0 * result.bound.relative:.3g} % "
                     f"of bbox diagonal) both ways")
        print(f"{args.input}: {_reduction(mesh, out)}, error {result.error:.3g} {unit}{bound}, "
              f"stop: {result.stop_reason}, {seconds:.2f} s -> {args.output}")
    return EXIT_OK


def _diagonal(mesh) -> float:
    """The bounding-box diagonal simplify() measures relative errors by: that of the
    vertices used by faces that repeat no index."""
    import numpy as np

    from .geometry import box_diagonal

    f = mesh.faces
    ok = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    used = mesh.vertices[np.unique(f[ok])]
    if used.shape[0] == 0:
        return 1.0                       # simplify() refuses such a mesh with its own message
    return float(box_diagonal(used.min(axis=0), used.max(axis=0)))


def _run_simplify_large(args) -> int:
    from .large import simplify_large

    unsupported = [name for name, value in (("--placement", args.placement), ("--boundary", args.boundary),
                                            ("--max-normal-angle", args.max_normal_angle),
                                            ("--min-quality", args.min_quality),
                                            ("--pair-threshold", args.pair_threshold)) if value is not None]
    if unsupported or (args.metric and len(args.metric) > 1):
        what = ", ".join(unsupported) or "several metrics"
        raise _UsageError(f"--tiles takes one --metric and the targets; not {what}")
    metric = _metric_spec(args.metric) or "qem"
    result = simplify_large(args.input, args.output, target_ratio=args.ratio, target_faces=args.faces,
                            max_error=args.max_error, absolute=args.absolute, tile_faces=args.tile_faces,
                            scheduler=args.scheduler, workers=args.workers, metric=metric,
                            progress=not args.quiet and _is_tty(sys.stderr))
    if not args.quiet:
        unit = "model units" if args.absolute else "of bbox diagonal"
        tiled = [r for r in result.rounds if r["kind"] == "tiles"]
        print(f"{args.input}: {result.report['input_faces']} -> {result.mesh.n_faces} faces, "
              f"{len(tiled)} tiled round(s) ({', '.join(str(r['tiles']) + ' tiles' for r in tiled) or 'none'}), "
              f"error {result.error:.3g} {unit}, {result.elapsed:.2f} s -> {args.output}")
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


def _run_retile(args) -> int:
    from . import load, save
    from .retile import retile

    _check_output(args.output)
    mesh = load(args.input)
    result = retile(mesh, args.vertices, adapt=args.adapt, equalize=args.equalize, iterations=args.iterations,
                    seed=args.seed, refine=args.refine, draws=args.draws, fit=args.fit,
                    features=args.features, relax=args.relax,
                    progress=not args.quiet and _is_tty(sys.stderr))
    save(result.mesh, args.output)
    if not args.quiet:
        rep = result.report
        print(f"{args.input}: {_reduction(mesh, result.mesh)}, triangle quality mean {rep['quality_mean']:.3f} "
              f"min {rep['quality_min']:.3f}, {result.elapsed:.2f} s -> {args.output}")
    return EXIT_OK


def _run_optimize(args) -> int:
    from . import load, save
    from .optimize import DEFAULT_CREASE_ANGLE, DEFAULT_SPRING, optimize

    _check_output(args.output)
    mesh = load(args.input)
    start = load(args.start) if args.start else None
    result = optimize(mesh, n_vertices=args.vertices, c_rep=args.c_rep, start=start,
                      spring=DEFAULT_SPRING if args.spring is None else args.spring,
                      samples=args.samples, iterations=args.iterations, seed=args.seed,
                      creases=DEFAULT_CREASE_ANGLE if args.creases is None else args.creases,
                      progress=not args.quiet and _is_tty(sys.stderr))
    save(result.mesh, args.output)
    if not args.quiet:
        e0, e1 = result.energy[0]["E"], result.energy[-1]["E"]
        moves = ", ".join(f"{n} {k}s" for k, n in result.moves.items())
        print(f"{args.input}: {_reduction(mesh, result.mesh)}, energy {e0:.4g} -> {e1:.4g} "
              f"({len(result.energy) - 1} iterations; {moves}), {result.elapsed:.2f} s -> {args.output}")
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
    # level 0 is the original, as in `lodkit demo` (demo_lod0.ply): one numbering everywhere
    name = f"{stem}_lod0.{args.format}"
    save(mesh, os.path.join(out_dir, name))
    rows = [{"level": 0, "ratio": 1.0, "faces": mesh.n_faces, "vertices": mesh.n_vertices, "error": 0.0,
             "file": name}]
    for i, ratio in enumerate(args.ratios, start=1):
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


def _run_batch(args) -> int:
    from .batch import batch

    metric = _metric_spec(args.metric)
    options = {"metric": metric, "placement": args.placement, "boundary": args.boundary,
               "polish": True if args.polish else None}
    options = {k: v for k, v in options.items() if v is not None}
    workers = args.workers
    if args.threads is not None:
        if args.scheduler != "threads":
            raise _UsageError("--threads goes with --scheduler threads (see 'lodkit batch --help')")
        workers = args.threads
    result = batch(args.inputs, args.out_dir, ratios=args.ratios, format=args.format, scheduler=args.scheduler,
                   workers=workers, resume=not args.force, progress=not args.quiet and _is_tty(sys.stderr),
                   **options)
    if not args.quiet:
        print(f"{len(result.rows)} inputs: {result.n_ok} done, {result.n_skipped} skipped (already done), "
              f"{result.n_failed} failed, {result.elapsed:.1f} s -> {result.manifest['csv']}")
    if result.n_failed:
        for row in result.rows:
            if row["status"] == "failed":
                print(f"{PROG}: failed: {row['input']}: {row['error']}", file=sys.stderr)
        print(f"{PROG}: error: {result.n_failed} of {len(result.rows)} inputs failed (see {result.manifest['csv']})",
              file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _run_demo(args) -> int:
    from .demo import run_demo

    run_demo(args.out, n_faces=args.faces, stream=sys.stdout, picture=not args.no_picture)
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
                     image_size=args.size, render_backend=args.render_backend, view=args.view, log=log)
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
