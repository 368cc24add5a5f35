"""``batch()``: LOD chains for many mesh files at once, on Dask (or threads), resumable.

find the inputs -> hash each file -> skip what the manifest says is done -> one task per
mesh (load, ``simplify`` once per ratio, save each level atomically) -> collect the rows
as they finish -> write ``manifest.json`` and ``manifest.csv``.

Each level is exactly ``simplify(load(file), target_ratio=r, **options)``: the same calls a
serial loop makes, so the files are the same, bit for bit, whichever engine ran them.
docs/scale.md says how to run it on a Dask cluster.
"""
from __future__ import annotations

import csv
import glob
import hashlib
import io as _io
import json
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from ._executor import open_executor, worker_name
from ._progress import Progress
from .errors import LodkitError, MeshIOError, OptionError
from .version import __version__

__all__ = ["BatchResult", "batch", "find_inputs", "MANIFEST_JSON", "MANIFEST_CSV"]

MANIFEST_JSON = "manifest.json"
MANIFEST_CSV = "manifest.csv"
FORMATS = ("ply", "obj", "glb")
#: options of simplify() that batch passes on (its targets are the ratios)
SIMPLIFY_OPTIONS = ("metric", "placement", "boundary", "boundary_weight", "max_normal_angle", "min_quality",
                    "absolute", "operator", "driver", "polish")
CSV_COLUMNS = ("key", "input", "status", "error", "sha256", "input_faces", "faces", "errors", "files",
               "seconds", "worker")
_MANIFEST_EVERY = 2.0   # seconds between rewrites of the manifest while the batch runs


@dataclass
class BatchResult:
    """What :func:`batch` returns.

    rows      : one dict per input, in input order (the manifest's items): key, input,
                sha256, status ("ok", "failed" or "skipped"), error, input_faces, levels
                (ratio, faces, vertices, error, file), seconds, worker
    manifest  : paths of manifest.json and manifest.csv
    """

    rows: list
    manifest: dict = field(default_factory=dict)
    elapsed: float = 0.0

    def count(self, status: str) -> int:
        return sum(1 for r in self.rows if r["status"] == status)

    @property
    def n_ok(self) -> int:
        return self.count("ok")

    @property
    def n_failed(self) -> int:
        return self.count("failed")

    @property
    def n_skipped(self) -> int:
        return self.count("skipped")

    def __repr__(self) -> str:
        return (f"BatchResult({len(self.rows)} inputs: {self.n_ok} ok, {self.n_skipped} skipped, "
                f"{self.n_failed} failed)")


def batch(inputs, out_dir, *, ratios=(0.5, 0.1, 0.02), format: str = "ply", scheduler=None,
          workers: int | None = None, client=None, resume: bool = True, progress: bool | None = None,
          **options) -> BatchResult:
    """Write a chain of levels of detail for every mesh in ``inputs`` into ``out_dir``.

    inputs    : a path or a list of them: files, folders (searched recursively for the
                formats lodkit reads) or glob patterns (``"assets/**/*.obj"``)
    out_dir   : where ``<key>_lod<i>.<format>`` go (``key``: the file's path below the folder
                it was found in, or its name, without extension), with manifest.json and
                manifest.csv; made if missing
    ratios    : one level per ratio, each ``simplify(mesh, target_ratio=ratio, **options)``
    format    : "ply" (default), "obj" or "glb"
    scheduler : None or "processes" (a Dask LocalCluster of ``workers`` processes, default
                one per core), "threads" (``workers`` threads here; no Dask needed), "sync"
                (one at a time here) or the address of a running Dask scheduler
    client    : a ``distributed.Client`` to use instead
    resume    : skip inputs whose content hash and settings match an "ok" (or "skipped")
                row of the manifest already in ``out_dir`` and whose files are all there
    progress  : a progress bar across inputs on stderr (default: when stderr is a terminal)
    options   : passed to :func:`lodkit.simplify`: metric, placement, boundary,
                boundary_weight, max_normal_angle, min_quality, absolute, operator, driver, polish

    A file that cannot be read or simplified is a "failed" row with the error; the others
    go on.  Dask runs a task again elsewhere if its worker dies.
    """
    t0 = time.perf_counter()
    settings = _settings(ratios, format, options)
    settings_hash = _digest_text(json.dumps(settings, sort_keys=True))
    out = Path(os.fspath(out_dir)).absolute()
    if out.exists() and not out.is_dir():
        raise MeshIOError(f"cannot write to {out_dir}: it is not a directory")
    if not out.parent.is_dir():
        raise MeshIOError(f"cannot write to {out_dir}: directory {out.parent} does not exist")
    items = find_inputs(inputs, exclude=out)
    _check_options(options)
    out.mkdir(exist_ok=True)

    previous = _read_manifest(out / MANIFEST_JSON) if resume else {}
    rows, todo = [], []
    for path, key in items:
        row = {"key": key, "input": str(path), "sha256": None, "settings_hash": settings_hash,
               "status": "pending", "error": None, "input_faces": None, "levels": [], "seconds": None,
               "worker": None}
        try:
            row["sha256"] = _digest_file(path)
        except OSError as exc:
            row.update(status="failed", error=f"cannot read {path}: {exc.strerror or exc}")
        rows.append(row)
        if row["status"] == "failed":
            continue
        old = previous.get(key)
        if old is not None and _done(old, row, out):
            row.update(status="skipped", input_faces=old.get("input_faces"), levels=old["levels"],
                       seconds=0.0, worker=old.get("worker"))
        else:
            todo.append(row)

    bar = Progress(len(rows), enabled=_is_tty(sys.stderr) if progress is None else bool(progress))
    done = len(rows) - len(todo)
    bar.update(done)
    last_write = time.monotonic()
    if todo:
        with open_executor(scheduler, workers=workers, client=client) as engine:
            # the items run side by side: one core thread each (threads never change the
            # output; Dask's worker processes get one through OMP_NUM_THREADS=1)
            task_options = dict(options, threads=1) if engine.kind == "threads" else options
            futures = {}
            # the largest files first (longest processing time first): a large mesh left to
            # the end keeps one worker busy while the others wait (the manifest keeps the
            # input order)
            for row in sorted(todo, key=_work_estimate, reverse=True):
                job = {k: row[k] for k in ("key", "input", "sha256")}
                futures[engine.submit(run_item, job, str(out), list(ratios), format, task_options)] = row
            for future, result, exc in engine.completed(list(futures)):
                row = futures[future]
                if exc is not None:
                    row.update(status="failed", error=f"the task failed: {type(exc).__name__}: {exc}")
                else:
                    row.update(result)
                done += 1
                bar.update(done)
                if time.monotonic() - last_write >= _MANIFEST_EVERY:
                    _write_manifest(out, rows, settings, settings_hash)
                    last_write = time.monotonic()
    bar.close()
    paths = _write_manifest(out, rows, settings, settings_hash)
    return BatchResult(rows=rows, manifest=paths, elapsed=time.perf_counter() - t0)


def _work_estimate(row: dict) -> int:
    """How long an input may take, for the submission order: its file size (0 if gone)."""
    try:
        return os.path.getsize(row["input"])
    except OSError:
        return 0


def run_item(job: dict, out_dir: str, ratios: list, fmt: str, options: dict) -> dict:
    """One input's task: load it, simplify it once per ratio, save each level; the row.

    Runs on a worker.  Every error the file can cause comes back as a "failed" row."""
    from .api import simplify
    from .io import load, save

    t0 = time.perf_counter()
    row = {"status": "ok", "error": None, "levels": [], "worker": worker_name()}
    try:
        mesh = load(job["input"])
        row["input_faces"] = mesh.n_faces
        for i, ratio in enumerate(ratios):
            result = simplify(mesh, target_ratio=ratio, **options)
            name = f"{job['key']}_lod{i}.{fmt}"
            dest = os.path.join(out_dir, name)
            os.makedirs(os.path.dirname(dest), exist_ok=True)
            save(result.mesh, dest)
            row["levels"].append({"ratio": ratio, "faces": result.mesh.n_faces,
                                  "vertices": result.mesh.n_vertices, "error": result.error, "file": name})
    except Exception as exc:  # noqa: BLE001 - one bad file is a failed row, never the end of the batch
        what = "" if isinstance(exc, LodkitError) else f"{type(exc).__name__}: "
        row.update(status="failed", error=what + " ".join(str(exc).split()), levels=[])
    row["seconds"] = time.perf_counter() - t0
    return row


def find_inputs(inputs, *, exclude=None) -> list:
    """``[(path, key), ...]`` for ``inputs`` (files, folders searched recursively, globs),
    without duplicates and without anything under ``exclude``.  ``key`` names the outputs:
    the path below the folder given (or the file name) without its extension."""
    from .io import SUPPORTED_FORMATS

    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    found = []
    for item in inputs:
        text = os.fspath(item)
        path = Path(text)
        if path.is_dir():
            files = sorted(p for p in path.rglob("*")
                           if p.is_file() and p.suffix.lower().lstrip(".") in SUPPORTED_FORMATS)
            found += [(p, p.relative_to(path).with_suffix("").as_posix()) for p in files]
        elif path.is_file():
            found.append((path, path.stem))
        elif glob.has_magic(text):
            matches = sorted(Path(p) for p in glob.glob(text, recursive=True) if os.path.isfile(p))
            if not matches:
                raise OptionError(f"no file matches {text!r}")
            found += [(p, p.stem) for p in matches]
        else:
            raise OptionError(f"no such file or directory: {text}")
    exclude = None if exclude is None else Path(exclude).absolute()
    seen, keys, result = set(), {}, []
    for path, key in found:
        absolute = path.absolute()
        if absolute in seen or (exclude is not None and absolute.is_relative_to(exclude)):
            continue
        seen.add(absolute)
        if key in keys:
            raise OptionError(f"{keys[key]} and {path} would both write {key}_lod*; give their folder "
                              f"instead, or rename one")
        keys[key] = path
        result.append((path, key))
    if not result:
        raise OptionError("no mesh files found in the inputs given")
    return result


# ---------------------------------------------------------------------- helpers
def _settings(ratios, fmt, options) -> dict:
    ratios = list(ratios) if not isinstance(ratios, (int, float)) else [ratios]
    if not ratios or any(isinstance(r, bool) or not isinstance(r, (int, float)) or not 0 < r <= 1 for r in ratios):
        raise OptionError(f"ratios must be numbers in (0, 1], got {ratios!r}")
    if fmt not in FORMATS:
        raise OptionError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    unknown = sorted(set(options) - set(SIMPLIFY_OPTIONS))
    if unknown:
        raise OptionError(f"batch() passes only {', '.join(SIMPLIFY_OPTIONS)} on to simplify(); "
                          f"got {', '.join(unknown)}")
    try:
        simplify_settings = json.loads(json.dumps({k: v for k, v in options.items() if v is not None}))
    except TypeError as exc:
        raise OptionError(f"batch() options must be plain values (names, numbers, dicts): {exc}") from exc
    return {"lodkit": __version__, "ratios": [float(r) for r in ratios], "format": fmt,
            "simplify": simplify_settings}


def _check_options(options) -> None:
    """Fail before any work on a metric or option simplify() would refuse."""
    from .metrics import create

    if options.get("metric") is not None:
        create(options["metric"])


def _digest_file(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _digest_text(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def _done(old: dict, row: dict, out: Path) -> bool:
    """Whether a manifest row of an earlier run covers ``row``: same content and settings,
    finished, and every level file still there."""
    return (old.get("status") in ("ok", "skipped") and old.get("sha256") == row["sha256"]
            and old.get("settings_hash") == row["settings_hash"] and bool(old.get("levels"))
            and all((out / level["file"]).is_file() for level in old["levels"]))


def _read_manifest(path: Path) -> dict:
    """The rows of an earlier manifest by key ({} when there is none or it is unreadable:
    then everything runs again)."""
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
        return {row["key"]: row for row in data["items"] if isinstance(row, dict) and "key" in row}
    except (OSError, ValueError, KeyError, TypeError):
        return {}


def _write_manifest(out: Path, rows: list, settings: dict, settings_hash: str) -> dict:
    from .io import atomic_write

    counts = {s: sum(1 for r in rows if r["status"] == s) for s in ("ok", "skipped", "failed", "pending")}
    data = {"lodkit": __version__, "written": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "settings": settings, "settings_hash": settings_hash, "counts": counts, "items": rows}
    text = _io.StringIO()
    writer = csv.DictWriter(text, fieldnames=CSV_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for r in rows:
        levels = r["levels"] or []
        writer.writerow({
            "key": r["key"], "input": r["input"], "status": r["status"], "error": r["error"] or "",
            "sha256": r["sha256"] or "", "input_faces": "" if r["input_faces"] is None else r["input_faces"],
            "faces": ";".join(str(lv["faces"]) for lv in levels),
            "errors": ";".join(repr(lv["error"]) for lv in levels),
            "files": ";".join(lv["file"] for lv in levels),
            "seconds": "" if r["seconds"] is None else f"{r['seconds']:.3f}", "worker": r["worker"] or "",
        })
    paths = {"json": str(out / MANIFEST_JSON), "csv": str(out / MANIFEST_CSV)}
    atomic_write(paths["json"], lambda fh: fh.write(json.dumps(data, indent=2) + "\n"))
    atomic_write(paths["csv"], lambda fh: fh.write(text.getvalue()))
    return paths


def _is_tty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False
