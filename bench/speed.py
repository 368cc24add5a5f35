#!/usr/bin/env python
"""Speed benchmark of issue 13: lodkit's simplify against the fast peers, in interleaved rounds.

    python bench/speed.py --quick                     # bunny + generated250k, 2 rounds (a few minutes)
    python bench/speed.py                             # bunny, igea, generated 250k / 1M / 4M, 3 rounds
    python bench/speed.py --meshes igea,generated1m --rounds 3 --exclude pymeshlab,open3d
    python bench/speed.py --lodkit-kwargs 'lodkit-greedy={"driver": "greedy"}' \\
                          --lodkit-kwargs 'lodkit-2t={"threads": 2}'

Methods (``--methods``, ``--exclude``): ``lodkit`` (default settings), every variant given
by ``--lodkit-kwargs NAME=JSON`` (a JSON object of keyword arguments added to
``lodkit.simplify``; a name that is not a parameter of ``lodkit.simplify`` stops the run
before anything is measured, naming the parameters it has), ``meshoptimizer``,
``fast_simplification``, ``pyfqmr``, ``open3d`` and ``pymeshlab`` (slow; ``--quick``
leaves it out). The calls and their parameters are bench/methods.py's (``PARAMS``).
lodkit's ``threads=`` is only passed when given in a variant's kwargs; the thread count a
call actually used is estimated as CPU time / wall time and recorded next to what was
asked for (``OMP_NUM_THREADS``, ``LODKIT_THREADS`` and the usable CPUs are recorded too).

Interleaved rounds: in each round every (method, ratio) case of a mesh runs once, in an
order shuffled per round by a seeded RNG (``--seed``), so a slow spell of the shared
machine hits every method alike; reported times are medians over the rounds, and the
ratios (method time / lodkit time, method time / meshoptimizer time) are medians of the
ratios *within* each round. Only the simplify call is timed: the input is converted into
each library's own structure before the clock starts (bench/methods.py ``setup``) and the
output converted back after it stops. Also reported: M input triangles per second,
seconds per million input faces (the linear-scaling target compares 4M with 250k) and
the faces reached.

Process layout (why): the timing runs in one worker subprocess per mesh, the methods
in-process, one after another. A subprocess per mesh keeps the parent (which has loaded
nothing heavy) isolated from crashes and gives each mesh a fresh heap; running all methods
in one process is what makes interleaving cheap (one import and one mesh load per mesh,
not per call -- Open3D alone takes 1-2 s to import) and keeps the timed calls free of
process start-up. If a method crashes the worker, the mesh is re-run without it (reported
as failed). Memory cannot be measured in that shared process (the heap is warm and each
library leaves pools behind), so lodkit's peak extra memory is measured separately in a
fresh subprocess per (mesh, ratio, lodkit variant): the mesh is loaded and
``lodkit.Mesh`` built, freed memory trimmed, then (1) the growth of the resident set over
the call (Linux ``VmHWM`` reset through ``/proc/self/clear_refs``; bench/run.py's
``_Mem``), and (2) in a second, untimed call the ``tracemalloc`` peak (the numpy arrays
lodkit allocates, which is nearly all of its memory). Both are divided by the input vertex
count (target: <= 300 B per input vertex). ``--memory all`` measures the peers the same way
(RSS only).

Writes bench/results/speed.json and the "Speed" section of docs/benchmarks.md (between
``<!-- speed:begin -->`` and ``<!-- speed:end -->``, through bench/report.py's
``splice_section``; bench/report.py keeps the section when it regenerates the page).
``--from-json`` re-renders the section without measuring.
"""
from __future__ import annotations

import argparse
import inspect
import json
import os
import random
import resource
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
if "LODKIT_TEST_DATA" in os.environ:  # the test suite's variable also points bench/meshes.py at the meshes
    os.environ.setdefault("LODKIT_MESH_DIR", os.environ["LODKIT_TEST_DATA"])

BEGIN = "<!-- speed:begin -->"
END = "<!-- speed:end -->"

PEERS = ["meshoptimizer", "fast_simplification", "pyfqmr", "open3d", "pymeshlab"]
FULL_MESHES = ["bunny", "igea", "generated250k", "generated1m", "generated4m"]
QUICK_MESHES = ["bunny", "generated250k"]
RATIOS = [0.1, 0.01]
BASE = "lodkit"           # the reference of the "x lodkit" column
REF = "meshoptimizer"     # the reference of the "x meshopt" column


# --------------------------------------------------------------------------------------
# methods
# --------------------------------------------------------------------------------------

def lodkit_params() -> tuple[set[str], bool]:
    """The keyword parameters of lodkit.simplify, and whether it takes **kwargs."""
    import lodkit

    sig = inspect.signature(lodkit.simplify)
    names = {n for n, p in sig.parameters.items()
             if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD) and n != "mesh"}
    varkw = any(p.kind == p.VAR_KEYWORD for p in sig.parameters.values())
    return names, varkw


def parse_variants(specs: list[str]) -> dict[str, dict]:
    """``NAME=JSON`` strings -> {name: kwargs}; raises SystemExit with a clear message."""
    out: dict[str, dict] = {}
    for spec in specs:
        name, sep, js = spec.partition("=")
        name = name.strip()
        if not sep or not name:
            raise SystemExit(f"--lodkit-kwargs {spec!r}: expected NAME=JSON, "
                             f"e.g. lodkit-greedy='{{\"driver\": \"greedy\"}}'")
        try:
            kw = json.loads(js)
        except ValueError as exc:
            raise SystemExit(f"--lodkit-kwargs {name}: not valid JSON ({exc}): {js!r}") from None
        if not isinstance(kw, dict):
            raise SystemExit(f"--lodkit-kwargs {name}: expected a JSON object of keyword arguments, got {js!r}")
        if name in PEERS:
            raise SystemExit(f"--lodkit-kwargs {name}: that name is a peer method; pick another")
        out[name] = kw
    return out


def check_variants(variants: dict[str, dict]) -> None:
    """Every kwarg must be a parameter of lodkit.simplify (the checkout's): fail before measuring."""
    if not variants:
        return
    names, varkw = lodkit_params()
    if varkw:
        return
    for name, kw in variants.items():
        bad = sorted(set(kw) - names)
        reserved = sorted(set(kw) & {"target_ratio", "target_faces"})
        if bad:
            raise SystemExit(f"--lodkit-kwargs {name}: lodkit.simplify has no parameter(s) {', '.join(bad)} "
                             f"(it has: {', '.join(sorted(names))})")
        if reserved:
            raise SystemExit(f"--lodkit-kwargs {name}: {', '.join(reserved)} is set by the benchmark (--ratios)")


def make_method(name: str, variants: dict[str, dict]):
    from methods import METHODS, Lodkit

    if name in variants or name == BASE:
        m = Lodkit()
        m.name = name
        m.kwargs = dict(variants.get(name, {}))
        return m
    return METHODS[name]


def asked_threads(name: str, variants: dict[str, dict]):
    if name in variants and "threads" in variants[name]:
        return variants[name]["threads"]
    return None


# --------------------------------------------------------------------------------------
# worker side
# --------------------------------------------------------------------------------------

def _trim() -> None:
    from run import _trim as trim

    trim()


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _load(npz: str):
    import numpy as np

    with np.load(npz) as z:
        V = np.ascontiguousarray(z["vertices"], dtype=np.float64)
        F = np.ascontiguousarray(z["faces"], dtype=np.int32)
    return V, F


def time_worker(args) -> int:
    """All (method, ratio) cases of one mesh, ``rounds`` interleaved rounds; JSON lines to --result."""
    variants = json.loads(args.variants)
    methods = args.methods.split(",")
    ratios = [float(r) for r in args.ratios.split(",")]
    V, F = _load(args.mesh_npz)
    out = open(args.result, "a", buffering=1)

    def emit(**kw):
        out.write(json.dumps(kw) + "\n")

    live = {}
    for name in methods:
        m = make_method(name, variants)
        try:
            live[name] = (m, m.probe())
        except BaseException as exc:  # noqa: BLE001
            emit(kind="unavailable", method=name, error=f"{type(exc).__name__}: {exc}")
    cases = [(name, r) for name in live for r in ratios]
    skipped: set = set()
    for rnd in range(args.rounds):
        order = list(cases)
        random.Random(args.seed * 1000 + rnd).shuffle(order)
        for name, ratio in order:
            if (name, ratio) in skipped:
                continue
            m, version = live[name]
            target = int(round(ratio * len(F)))
            emit(kind="start", method=name, ratio=ratio, round=rnd)
            try:
                st = m.setup(V, F, target, ratio)
                _trim()
                c0 = _cpu()
                t0 = time.perf_counter()
                raw = m.call(st)
                t1 = time.perf_counter()
                c1 = _cpu()
                Vo, Fo = m.extract(st, raw)
                rec = dict(kind="time", method=name, ratio=ratio, round=rnd, time_s=t1 - t0, cpu_s=c1 - c0,
                           faces=int(len(Fo)), vertices=int(len(Vo)), target=target, version=version)
                if rnd == 0 and hasattr(m, "info"):
                    try:
                        info = m.info(raw)
                        rec["info"] = {k: info[k] for k in ("stop_reason", "n_collapses", "max_error") if k in info}
                    except Exception:  # noqa: BLE001
                        pass
                emit(**rec)
                del st, raw, Vo, Fo
                if t1 - t0 > args.max_call:
                    skipped.add((name, ratio))
                    emit(kind="note", method=name, ratio=ratio,
                         note=f"one call took {t1 - t0:.1f} s > --max-call {args.max_call:g} s: no more rounds")
            except Exception as exc:  # noqa: BLE001
                skipped.add((name, ratio))
                emit(kind="failed", method=name, ratio=ratio, round=rnd, error=f"{type(exc).__name__}: {exc}",
                     traceback=traceback.format_exc(limit=4))
    emit(kind="done")
    return 0


def mem_worker(args) -> int:
    """Peak extra memory of one call in this fresh process: RSS growth, then a tracemalloc peak."""
    variants = json.loads(args.variants)
    from run import _Mem

    name, ratio = args.methods, float(args.ratios)
    m = make_method(name, variants)
    res: dict = {"method": name, "ratio": ratio}
    try:
        m.probe()
        V, F = _load(args.mesh_npz)
        target = int(round(ratio * len(F)))
        mem = _Mem()
        res["memory_method"] = mem.method
        _trim()
        base0 = mem.reset()
        st = m.setup(V, F, target, ratio)
        _trim()
        base1 = mem.reset()
        raw = m.call(st)
        peak = mem.peak()
        res.update(rss_call_bytes=int(peak - base1), rss_incl_setup_bytes=int(max(peak, base1) - base0),
                   vertices_in=int(len(V)), faces_in=int(len(F)))
        del st, raw
        if name.startswith("lodkit") or name in variants:
            import tracemalloc

            st = m.setup(V, F, target, ratio)
            _trim()
            tracemalloc.start()
            tracemalloc.reset_peak()
            cur0, _ = tracemalloc.get_traced_memory()
            m.call(st)
            _, tpeak = tracemalloc.get_traced_memory()
            tracemalloc.stop()
            res["traced_bytes"] = int(tpeak - cur0)
        res["status"] = "ok"
    except Exception as exc:  # noqa: BLE001
        res.update(status="failed", error=f"{type(exc).__name__}: {exc}")
    Path(args.result).write_text(json.dumps(res))
    return 0


# --------------------------------------------------------------------------------------
# parent side
# --------------------------------------------------------------------------------------

def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), str(HERE)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    return env


def _spawn(role: str, npz: Path, methods: str, ratios: str, variants: dict, result: Path, args) -> str | None:
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", role, "--mesh-npz", str(npz),
           "--methods", methods, "--ratios", ratios, "--variants-json", json.dumps(variants),
           "--result", str(result), "--rounds", str(args.rounds), "--seed", str(args.seed),
           "--max-call", str(args.max_call)]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, env=_env(), cwd=str(HERE), timeout=args.timeout)
    except subprocess.TimeoutExpired:
        return f"timed out after {args.timeout:.0f} s"
    if p.returncode == 0:
        return None
    sig = f" (signal {-p.returncode})" if p.returncode < 0 else ""
    return f"worker exited with {p.returncode}{sig}: {' | '.join(p.stderr.strip().splitlines()[-3:])[-300:]}"


def time_mesh(mesh: str, npz: Path, methods: list[str], ratios: list[float], variants: dict, args,
              tmp: Path) -> list[dict]:
    """Run the timing worker; if it dies, blame the case it had started and run again without that method."""
    lines: list[dict] = []
    crashed: list[dict] = []
    todo = list(methods)
    while todo:
        res = tmp / f"{mesh}-time-{len(crashed)}.jsonl"
        err = _spawn("time", npz, ",".join(todo), ",".join(map(repr, ratios)), variants, res, args)
        got = [json.loads(x) for x in res.read_text().splitlines() if x.strip()] if res.exists() else []
        if err is None and got and got[-1].get("kind") == "done":
            lines = got
            break
        started = [x for x in got if x.get("kind") == "start"]
        culprit = started[-1]["method"] if started else None
        print(f"  {mesh}: worker died ({err}); culprit: {culprit}", flush=True)
        if culprit is None:
            crashed.extend({"kind": "failed", "method": m, "ratio": r, "error": err} for m in todo for r in ratios)
            break
        crashed.extend({"kind": "failed", "method": culprit, "ratio": r, "error": err} for r in ratios)
        todo.remove(culprit)
    return lines + crashed


def summarise(mesh: str, minfo: dict, lines: list[dict], methods: list[str], ratios: list[float],
              variants: dict) -> list[dict]:
    rows = []
    times = {}
    for x in lines:
        if x.get("kind") == "time":
            times.setdefault((x["method"], x["ratio"]), {})[x["round"]] = x
    for ratio in ratios:
        base = times.get((BASE, ratio)) or next((times[(m, ratio)] for m in methods
                                                  if m in variants and (m, ratio) in times), {})
        ref = times.get((REF, ratio), {})
        for m in methods:
            row = {"mesh": mesh, "method": m, "ratio": ratio, "faces_in": minfo["faces"],
                   "vertices_in": minfo["vertices"], "threads_asked": asked_threads(m, variants),
                   "kwargs": variants.get(m) if m in variants or m == BASE else None}
            bad = [x for x in lines if x.get("method") == m and x.get("kind") in ("failed", "unavailable")
                   and x.get("ratio", ratio) == ratio]
            notes = [x["note"] for x in lines if x.get("kind") == "note" and x["method"] == m and x["ratio"] == ratio]
            t = times.get((m, ratio), {})
            if not t:
                row.update(status=bad[0]["kind"] if bad else "missing", error=bad[0].get("error") if bad else None)
                rows.append(row)
                continue
            ts = [t[r]["time_s"] for r in sorted(t)]
            cpu = [t[r]["cpu_s"] for r in sorted(t)]
            med = statistics.median(ts)
            first = t[min(t)]

            def within(refd):
                rs = [t[r]["time_s"] / refd[r]["time_s"] for r in t if r in refd and refd[r]["time_s"] > 0]
                return statistics.median(rs) if rs else None

            row.update(status="ok", rounds=len(ts), times_s=ts, time_s=med, cpu_s=statistics.median(cpu),
                       threads_used=round(statistics.median(c / w for c, w in zip(cpu, ts) if w > 0), 2),
                       x_lodkit=within(base) if base else None, x_meshopt=within(ref) if ref else None,
                       mtri_per_s=minfo["faces"] / med / 1e6, s_per_mface=med / (minfo["faces"] / 1e6),
                       faces=first["faces"], target=first["target"], version=first.get("version"),
                       info=first.get("info"), notes=notes)
            if bad:
                row["error"] = bad[0].get("error")
            rows.append(row)
    return rows


def measure_memory(mesh: str, npz: Path, names: list[str], ratios: list[float], variants: dict, args,
                   tmp: Path) -> list[dict]:
    out = []
    for m in names:
        for r in ratios:
            res = tmp / f"{mesh}-mem-{m}-{r}.json"
            err = _spawn("mem", npz, m, repr(r), variants, res, args)
            d = json.loads(res.read_text()) if res.exists() else {"method": m, "ratio": r, "status": "failed"}
            if err:
                d.update(status="failed", error=err)
            d["mesh"] = mesh
            out.append(d)
            if d.get("status") == "ok":
                nv = d["vertices_in"]
                print(f"  mem {mesh} {m} @{r:g}: RSS {d['rss_call_bytes'] / nv:.0f} B/vert"
                      + (f", traced {d['traced_bytes'] / nv:.0f} B/vert" if "traced_bytes" in d else ""), flush=True)
            else:
                print(f"  mem {mesh} {m} @{r:g}: {d.get('error')}", flush=True)
    return out


# --------------------------------------------------------------------------------------
# report
# --------------------------------------------------------------------------------------

def _f(x, spec=".2f", dash="–"):
    return dash if x is None else format(x, spec)


def _t(x):
    if x is None:
        return "–"
    return f"{x:.3f}" if x < 10 else f"{x:.1f}"


def render(doc: dict) -> str:
    L = [BEGIN, "## Speed (issue 13)", ""]
    w = L.append
    S = doc["settings"]
    mi = doc.get("machine", {})
    w(f"`python bench/speed.py {S.get('argv', '')}`, {doc.get('date', '')}. {mi.get('cpu', '?')}, "
      f"{mi.get('usable_cpus', '?')} usable CPUs (shared with other work: compare ratios, not absolute times); "
      f"load average at start {', '.join(f'{x:.2f}' for x in doc.get('loadavg_start', []))}, "
      f"at end {', '.join(f'{x:.2f}' for x in doc.get('loadavg_end', []))}. "
      f"OMP_NUM_THREADS={S.get('omp_num_threads')}, LODKIT_THREADS={S.get('lodkit_threads')}.")
    w("")
    w(f"{S['rounds']} interleaved rounds (every case of a mesh once per round, order shuffled per round, seed "
      f"{S['seed']}); **time** = median over rounds of the simplify call alone (inputs converted before the clock "
      "starts); **×lodkit**, **×meshopt** = median over rounds of (method time / that round's lodkit or "
      "meshoptimizer time at the same ratio); **M tri/s** = input faces / time; **s/M faces** = time per million "
      "input faces; **faces** = faces reached (target); **thr** = CPU time / wall time of the call (threads "
      "actually busy; asked-for count in brackets when a variant passes `threads=`; well below 1 for a "
      "single-threaded library means the call waited for a CPU: the machine was busy).")
    if doc.get("variants"):
        w("")
        w("lodkit variants: " + "; ".join(f"`{k}` = `simplify(..., {', '.join(f'{a}={v!r}' for a, v in kw.items())})`"
                                          for k, kw in doc["variants"].items()) + ".")
    w("")
    w("| mesh (faces) | ratio | method | time (s) | ×lodkit | ×meshopt | M tri/s | s/M faces | faces (target) | thr |")
    w("|---|--:|---|--:|--:|--:|--:|--:|--:|--:|")
    for r in doc["rows"]:
        head = f"{r['mesh']} ({r['faces_in'] / 1e3:.0f}k)"
        if r.get("status") != "ok":
            err = str(r.get("error") or "")[:100]
            w(f"| {head} | {r['ratio']:g} | {r['method']} | {r.get('status')}: {err} | | | | | | |")
            continue
        asked = r.get("threads_asked")
        thr = _f(r.get("threads_used"), ".1f") + (f" ({asked})" if asked is not None else "")
        rounds = "" if r["rounds"] == S["rounds"] else f" ×{r['rounds']}"
        w(f"| {head} | {r['ratio']:g} | {r['method']} | {_t(r['time_s'])}{rounds} | {_f(r.get('x_lodkit'))} |"
          f" {_f(r.get('x_meshopt'))} | {_f(r['mtri_per_s'])} | {_f(r['s_per_mface'], '.3f')} |"
          f" {r['faces']} ({r['target']}) | {thr} |")
    w("")
    if any(r.get("rounds", S["rounds"]) != S["rounds"] for r in doc["rows"] if r.get("status") == "ok"):
        w(f"`×n` after a time: only n rounds (one call took longer than --max-call {S.get('max_call')} s).")
        w("")
    # linear scaling: s/M faces of the generated meshes, relative to the smallest
    gen = sorted({(r["faces_in"], r["mesh"]) for r in doc["rows"] if r["mesh"].startswith("generated")})
    if len(gen) >= 2:
        w("Scaling on the generated torus: seconds per million input faces, and the largest mesh's over the "
          "smallest's (target for lodkit: ≤ 1.25).")
        w("")
        w("| method | ratio | " + " | ".join(f"{m} ({n / 1e6:.2g}M)" for n, m in gen) + " | largest / smallest |")
        w("|---|--:|" + "--:|" * (len(gen) + 1))
        keys = dict.fromkeys((r["method"], r["ratio"]) for r in doc["rows"])
        for m, ratio in keys:
            cells = []
            for _, mesh in gen:
                hit = [r for r in doc["rows"] if r["mesh"] == mesh and r["method"] == m and r["ratio"] == ratio
                       and r.get("status") == "ok"]
                cells.append(hit[0]["s_per_mface"] if hit else None)
            grow = cells[-1] / cells[0] if cells[0] and cells[-1] else None
            w(f"| {m} | {ratio:g} | " + " | ".join(_f(c, ".3f") for c in cells) + f" | {_f(grow)} |")
        w("")
    mem = [d for d in doc.get("memory", [])]
    if mem:
        w("Peak extra memory of one call, each in a fresh subprocess after `lodkit.Mesh` (or the peer's input) "
          "is built: **RSS** = growth of the resident set over the call (`VmHWM` reset just before it), "
          "**traced** = `tracemalloc` peak of a second, untimed call (numpy arrays). Per input vertex; "
          "target for lodkit: ≤ 300 B.")
        w("")
        w("| mesh | ratio | method | RSS (MiB) | RSS B/vert | traced (MiB) | traced B/vert |")
        w("|---|--:|---|--:|--:|--:|--:|")
        for d in mem:
            if d.get("status") != "ok":
                w(f"| {d['mesh']} | {d['ratio']:g} | {d['method']} | failed: {str(d.get('error'))[:80]} | | | |")
                continue
            nv = d["vertices_in"]
            tb = d.get("traced_bytes")
            w(f"| {d['mesh']} | {d['ratio']:g} | {d['method']} | {d['rss_call_bytes'] / 2**20:.1f} |"
              f" {d['rss_call_bytes'] / nv:.0f} | {_f(tb / 2**20 if tb is not None else None, '.1f')} |"
              f" {_f(tb / nv if tb is not None else None, '.0f')} |")
        w("")
    w("Versions: " + "; ".join(f"{k} {v}" for k, v in doc.get("versions", {}).items()) + ".")
    w("")
    w(END)
    return "\n".join(L) + "\n"


# --------------------------------------------------------------------------------------
# main
# --------------------------------------------------------------------------------------

def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", help=f"comma list (default {','.join(FULL_MESHES)}; --quick: {','.join(QUICK_MESHES)})")
    ap.add_argument("--ratios", default=",".join(map(str, RATIOS)), help="target face ratios (default %(default)s)")
    ap.add_argument("--rounds", type=int, help="interleaved rounds (default 3; --quick: 2)")
    ap.add_argument("--methods", help=f"comma list (default: lodkit, the variants, {','.join(PEERS)})")
    ap.add_argument("--exclude", default="", help="comma list of methods to leave out (--quick: pymeshlab)")
    ap.add_argument("--lodkit-kwargs", action="append", default=[], metavar="NAME=JSON",
                    help="add a lodkit variant NAME calling simplify(..., **JSON); repeatable. "
                         "NAME=lodkit changes the reference itself")
    ap.add_argument("--quick", action="store_true", help="bunny + generated250k, 2 rounds, no pymeshlab")
    ap.add_argument("--seed", type=int, default=13)
    ap.add_argument("--memory", choices=["lodkit", "all", "none"], default="lodkit",
                    help="peak-memory runs (fresh subprocess each) for lodkit variants, all methods or none")
    ap.add_argument("--max-call", type=float, default=120.0,
                    help="after a call longer than this (s), that case gets no more rounds (default %(default)s)")
    ap.add_argument("--timeout", type=float, default=3600.0, help="kill a worker after S seconds")
    ap.add_argument("--out", default=str(HERE / "results" / "speed.json"))
    ap.add_argument("--report", default=str(REPO / "docs" / "benchmarks.md"), help="'' to skip")
    ap.add_argument("--from-json", action="store_true", help="re-render the section from --out, no measuring")
    # worker-only
    ap.add_argument("--worker", choices=["time", "mem"], help=argparse.SUPPRESS)
    ap.add_argument("--mesh-npz", help=argparse.SUPPRESS)
    ap.add_argument("--variants-json", dest="variants", default="{}", help=argparse.SUPPRESS)
    ap.add_argument("--result", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)

    if args.worker:
        return time_worker(args) if args.worker == "time" else mem_worker(args)

    from common import write_results

    if args.from_json:
        doc = json.loads(Path(args.out).read_text())
        if args.report:
            from report import splice_section

            splice_section(Path(args.report), render(doc), BEGIN, END)
            print(f"wrote the speed section of {args.report}")
        return 0

    sys.path.insert(0, str(REPO))
    variants = parse_variants(args.lodkit_kwargs)
    check_variants(variants)
    base_kw = variants.pop(BASE, None)
    meshes = (args.meshes or ",".join(QUICK_MESHES if args.quick else FULL_MESHES)).split(",")
    rounds = args.rounds or (2 if args.quick else 3)
    args.rounds = rounds
    exclude = set(filter(None, args.exclude.split(","))) | ({"pymeshlab"} if args.quick else set())
    methods = args.methods.split(",") if args.methods else [BASE, *variants, *PEERS]
    from methods import METHODS

    unknown = [m for m in methods if m not in METHODS and m not in variants and m != BASE]
    if unknown:
        raise SystemExit(f"unknown method(s) {', '.join(unknown)} (known: {', '.join([BASE, *variants, *PEERS])}; "
                         "add lodkit variants with --lodkit-kwargs NAME=JSON)")
    methods = [m for m in methods if m not in exclude]
    if base_kw is not None:
        variants[BASE] = base_kw
    ratios = [float(r) for r in args.ratios.split(",")]

    from meshes import prepare
    from run import library_versions, machine_info

    cache = HERE / "results" / "cache"
    doc = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "machine": machine_info(),
           "loadavg_start": list(os.getloadavg()), "versions": library_versions(), "variants": variants,
           "settings": {"argv": shlex.join(sys.argv[1:] if argv is None else argv), "rounds": rounds,
                        "seed": args.seed, "ratios": ratios, "methods": methods, "max_call": args.max_call,
                        "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
                        "lodkit_threads": os.environ.get("LODKIT_THREADS")},
           "meshes": {}, "rows": [], "memory": []}
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="lodkit-speed-") as tmpd:
        tmp = Path(tmpd)
        for mesh in meshes:
            t0 = time.perf_counter()
            npz = prepare(mesh, cache)
            import numpy as np

            with np.load(npz) as z:
                minfo = {"faces": int(len(z["faces"])), "vertices": int(len(z["vertices"])), "source": str(z["source"])}
            doc["meshes"][mesh] = minfo
            print(f"{mesh}: {minfo['faces']} faces, {minfo['vertices']} vertices "
                  f"({time.perf_counter() - t0:.1f} s to load)",
                  flush=True)
            lines = time_mesh(mesh, npz, methods, ratios, variants, args, tmp)
            rows = summarise(mesh, minfo, lines, methods, ratios, variants)
            for r in rows:
                if r.get("status") == "ok":
                    print(f"  {r['method']:>20} @{r['ratio']:<5g} {r['time_s']:8.3f} s  ×lodkit {_f(r['x_lodkit'])}"
                          f"  ×meshopt {_f(r['x_meshopt'])}  {r['mtri_per_s']:.2f} Mtri/s  faces {r['faces']}"
                          f"  thr {r['threads_used']}", flush=True)
                else:
                    print(f"  {r['method']:>20} @{r['ratio']:<5g} {r['status']}: {r.get('error')}", flush=True)
            doc["rows"].extend(rows)
            if args.memory != "none":
                names = methods if args.memory == "all" else [m for m in methods if m == BASE or m in variants]
                doc["memory"].extend(measure_memory(mesh, npz, names, ratios, variants, args, tmp))
            doc["loadavg_end"] = list(os.getloadavg())
            doc["elapsed_s"] = time.perf_counter() - t_start
            if args.report:
                write_results(doc, args.out, render(doc), args.report, BEGIN, END)
            else:
                Path(args.out).parent.mkdir(parents=True, exist_ok=True)
                Path(args.out).write_text(json.dumps(doc, indent=2) + "\n")
    print(f"wrote {args.out}" + (f" and the speed section of {args.report}" if args.report else "")
          + f" ({time.perf_counter() - t_start:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
