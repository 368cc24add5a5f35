#!/usr/bin/env python
"""Benchmark lodkit against peer simplifiers: time, memory, error, validity.

    python bench/run.py --meshes bunny,igea,fandisk,generated1m --ratios 0.5,0.1,0.02,0.005 \\
        --repeats 3 --out bench/results/

Every (mesh, ratio, method) runs in a fresh worker subprocess (this same script with
``--worker``), which loads the mesh from an .npz cache, converts it into the library's
input format, and times only the simplify call (median of the repeats). Memory is the
growth of the worker's resident set during the call (see ``_Mem``). The parent then
computes the Metro-style error and validity of the first repeat's output (bench/metro.py),
writes ``results.json`` and ``results.csv`` into --out (after every case, so an
interrupted run keeps what it has), and finally regenerates docs/benchmarks.md with
bench/report.py.

A method that cannot be imported is reported as ``unavailable: <error>``; one that
raises, crashes or times out as ``failed: <error>``; the run goes on either way.
"""
from __future__ import annotations

import argparse
import csv
import gc
import json
import os
import platform
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

# --------------------------------------------------------------------------------------
# worker side
# --------------------------------------------------------------------------------------


class _Mem:
    """Resident-set accounting for the current process.

    Preferred: Linux ``VmHWM`` (peak RSS), which can be reset to the current RSS by
    writing ``5`` to ``/proc/self/clear_refs``. So peak extra memory of a call =
    VmHWM after the call - VmRSS just before it, with VmHWM reset just before it.
    Fallback (no clear_refs): ``resource.getrusage(RUSAGE_SELF).ru_maxrss`` delta, which
    is only exact for the first call and only if nothing before it peaked higher.
    """

    def __init__(self):
        self.method = "getrusage-maxrss"
        try:
            with open("/proc/self/clear_refs", "w") as fh:
                fh.write("5")
            self._status()
            self.method = "proc-vmhwm-reset"
        except OSError:
            pass

    @staticmethod
    def _status() -> dict:
        out = {}
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith(("VmRSS:", "VmHWM:")):
                    k, v = line.split(":")
                    out[k] = int(v.split()[0]) * 1024
        return out

    def reset(self) -> int:
        """Reset the peak to the current RSS; return the current RSS in bytes."""
        if self.method == "proc-vmhwm-reset":
            with open("/proc/self/clear_refs", "w") as fh:
                fh.write("5")
            return self._status()["VmRSS"]
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024

    def peak(self) -> int:
        if self.method == "proc-vmhwm-reset":
            return self._status()["VmHWM"]
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def _trim() -> None:
    """gc, then hand freed heap memory back to the OS (glibc), so each repeat starts alike."""
    gc.collect()
    try:
        import ctypes

        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


def _cpu() -> float:
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def worker(args) -> int:
    """Run one (mesh, ratio, method) case; write a JSON result (and the output mesh)."""
    import numpy as np

    result: dict = {"method": args.method, "ratio": args.ratio}

    def finish(status: str, **kw):
        result.update(status=status, **kw)
        tmp = args.result + ".tmp"
        with open(tmp, "w") as fh:
            json.dump(result, fh)
        os.replace(tmp, args.result)
        return 0

    from methods import METHODS

    m = METHODS[args.method]
    try:
        version = m.probe()
    except BaseException as exc:  # noqa: BLE001 -- anything at import time means "unavailable"
        return finish("unavailable", error=f"{type(exc).__name__}: {exc}")
    result["version"] = version

    with np.load(args.mesh_npz) as z:
        V = np.ascontiguousarray(z["vertices"], dtype=np.float64)
        F = np.ascontiguousarray(z["faces"], dtype=np.int32)
    target = int(round(args.ratio * len(F)))
    result.update(target=target, faces_in=int(len(F)), vertices_in=int(len(V)))

    mem = _Mem()
    result["memory_method"] = mem.method
    times, times_total, cpu_times, mem_call, mem_total = [], [], [], [], []
    out = None
    try:
        for rep in range(max(1, args.repeats)):
            _trim()
            base0 = mem.reset()
            t0 = time.perf_counter()
            st = m.setup(V, F, target, args.ratio)
            t1 = time.perf_counter()
            peak_setup = mem.peak()
            _trim()
            base1 = mem.reset()
            c0 = _cpu()
            t2 = time.perf_counter()
            raw = m.call(st)
            t3 = time.perf_counter()
            c1 = _cpu()
            peak_call = mem.peak()
            Vo, Fo = m.extract(st, raw)
            t4 = time.perf_counter()
            peak_extract = mem.peak()
            times.append(t3 - t2)
            times_total.append((t1 - t0) + (t3 - t2) + (t4 - t3))
            cpu_times.append(c1 - c0)
            mem_call.append(peak_call - base1)
            mem_total.append(max(peak_setup, peak_call, peak_extract) - base0)
            if out is None:
                out = (Vo, Fo)
                if hasattr(m, "info"):
                    try:
                        result["info"] = m.info(raw)
                    except Exception:  # noqa: BLE001
                        pass
            del st, raw, Vo, Fo
            if mem.method != "proc-vmhwm-reset":
                break  # ru_maxrss cannot be reset: later repeats would be meaningless for memory
            if sum(times) >= args.time_budget and rep + 1 < args.repeats:
                result["repeats_cut"] = f"stopped after {rep + 1}: {sum(times):.1f} s >= budget {args.time_budget} s"
                break
        # remaining repeats if memory could not be reset (time only)
        while mem.method != "proc-vmhwm-reset" and len(times) < args.repeats and sum(times) < args.time_budget:
            st = m.setup(V, F, target, args.ratio)
            t2 = time.perf_counter()
            raw = m.call(st)
            times.append(time.perf_counter() - t2)
            del st, raw

        if args.tracemalloc:
            import tracemalloc

            st = m.setup(V, F, target, args.ratio)
            _trim()
            tracemalloc.start()
            cur0, _ = tracemalloc.get_traced_memory()
            tracemalloc.reset_peak()
            raw = m.call(st)
            _, tpeak = tracemalloc.get_traced_memory()
            tracemalloc.stop()
            result["tracemalloc_peak_bytes"] = int(tpeak - cur0)
            del st, raw
    except BaseException as exc:  # noqa: BLE001
        return finish("failed", error=f"{type(exc).__name__}: {exc}",
                      traceback=traceback.format_exc(limit=6))

    Vo, Fo = out
    np.savez(args.out_mesh, vertices=Vo, faces=Fo)
    return finish(
        "ok",
        repeats=len(times),
        time_s=statistics.median(times),
        times_s=times,
        time_total_s=statistics.median(times_total) if times_total else None,
        cpu_s=statistics.median(cpu_times) if cpu_times else None,
        peak_mem_bytes=int(max(mem_call)),
        peak_mem_total_bytes=int(max(mem_total)),
        mem_call_all=mem_call,
    )


# --------------------------------------------------------------------------------------
# parent side
# --------------------------------------------------------------------------------------

def machine_info() -> dict:
    model = "?"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = None
    try:
        for line in open("/proc/meminfo"):
            if line.startswith("MemTotal:"):
                mem = int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count()
    return {
        "cpu": model,
        "logical_cpus": os.cpu_count(),
        "usable_cpus": usable,
        "mem_total_bytes": mem,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "kernel": platform.release(),
    }


def library_versions() -> dict:
    from importlib.metadata import PackageNotFoundError, version

    out = {}
    for dist in ("numpy", "scipy", "open3d", "Cython", "fast-simplification", "pyfqmr", "pymeshlab",
                 "vtk", "meshoptimizer"):
        try:
            out[dist] = version(dist)
        except PackageNotFoundError:
            out[dist] = None
    return out


_LODKIT_ROOT = REPO  # where workers import lodkit from; snapshot_lodkit() points it at a frozen copy


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(_LODKIT_ROOT), str(HERE)]
                                        + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    return env


def snapshot_lodkit(dest: Path) -> str:
    """Copy the checkout's lodkit package (sources and built extensions) to ``dest``/lodkit.

    The whole run then measures one build even if someone edits or rebuilds the checkout
    meanwhile. Retries if the package changed while it was being copied. Returns the digest.
    """
    import shutil

    from methods import _lodkit_digest

    global _LODKIT_ROOT
    src = REPO / "lodkit"
    for _ in range(5):
        before = _lodkit_digest(src)
        if (dest / "lodkit").exists():
            shutil.rmtree(dest / "lodkit")
        shutil.copytree(src, dest / "lodkit", ignore=shutil.ignore_patterns("__pycache__", "*.c", "*.html"))
        if _lodkit_digest(src) == before == _lodkit_digest(dest / "lodkit"):
            break
        time.sleep(2)
    _LODKIT_ROOT = dest
    return _lodkit_digest(dest / "lodkit")


def probe(method: str, timeout: float) -> tuple[str, str]:
    """('ok', version) or ('unavailable', error) -- in a subprocess, like the real runs."""
    code = (
        "import json,sys\n"
        "from methods import METHODS\n"
        "try:\n"
        f"    print(json.dumps(['ok', METHODS[{method!r}].probe()]))\n"
        "except BaseException as e:\n"
        "    print(json.dumps(['unavailable', type(e).__name__ + ': ' + str(e)]))\n"
    )
    try:
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env(),
                           cwd=str(HERE), timeout=timeout)
    except subprocess.TimeoutExpired:
        return "unavailable", f"import timed out after {timeout} s"
    for line in reversed(p.stdout.splitlines()):
        try:
            status, val = json.loads(line)
            return status, val
        except (ValueError, TypeError):
            continue
    return "unavailable", f"probe exited {p.returncode}: {p.stderr.strip()[-500:]}"


def run_case(mesh, method, mesh_npz, ratio, repeats, time_budget, timeout, tracemalloc, tmpdir) -> tuple[dict, Path]:
    tag = f"{mesh}-{method}-{ratio}"
    res_path = Path(tmpdir) / f"{tag}.json"
    out_mesh = Path(tmpdir) / f"{tag}.npz"
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", "--method", method, "--mesh-npz", str(mesh_npz),
           "--ratio", repr(ratio), "--repeats", str(repeats), "--time-budget", str(time_budget),
           "--result", str(res_path), "--out-mesh", str(out_mesh)]
    cmd += ["--tracemalloc", "on" if tracemalloc else "off"]
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, env=_env(), cwd=str(HERE), timeout=timeout)
        rc, err = p.returncode, p.stderr
    except subprocess.TimeoutExpired:
        return {"status": "failed", "error": f"timeout after {timeout} s"}, out_mesh
    wall = time.perf_counter() - t0
    if res_path.exists():
        r = json.loads(res_path.read_text())
    else:
        sig = f" (signal {-rc})" if rc < 0 else ""
        tail = " | ".join(err.strip().splitlines()[-3:])
        r = {"status": "failed", "error": f"worker exited with {rc}{sig}: {tail[-400:]}"}
    r["worker_wall_s"] = wall
    return r, out_mesh


CSV_FIELDS = ["mesh", "method", "ratio", "status", "error", "faces_in", "vertices_in", "target", "faces", "vertices",
              "used_vertices", "repeats", "time_s", "time_total_s", "cpu_s", "time_ratio_vs_lodkit", "peak_mem_bytes",
              "peak_mem_total_bytes", "tracemalloc_peak_bytes", "bytes_per_input_vertex", "hausdorff", "mean", "rms",
              "hausdorff_fwd", "hausdorff_bwd", "nonmanifold_edges", "boundary_edges", "degenerate_faces",
              "flipped_faces", "flipped_faces_near", "flipped_area_frac", "version"]


def add_ratios(records: list[dict]) -> None:
    """time_ratio_vs_lodkit = method time / lodkit time (same mesh and ratio); >1 = slower than lodkit."""
    base = {(r["mesh"], r["ratio"]): r.get("time_s") for r in records
            if r["method"] == "lodkit" and r.get("status") == "ok"}
    for r in records:
        b = base.get((r["mesh"], r["ratio"]))
        r["time_ratio_vs_lodkit"] = (r["time_s"] / b) if (b and r.get("time_s") is not None) else None


def write_results(out_dir: Path, meta: dict, records: list[dict]) -> None:
    add_ratios(records)
    doc = dict(meta, records=records)
    tmp = out_dir / "results.json.tmp"
    tmp.write_text(json.dumps(doc, indent=1, default=float))
    os.replace(tmp, out_dir / "results.json")
    tmp = out_dir / "results.csv.tmp"
    with open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=CSV_FIELDS, extrasaction="ignore")
        w.writeheader()
        for r in records:
            w.writerow(r)
    os.replace(tmp, out_dir / "results.csv")


def parse_repeats_for(items: list[str]) -> dict:
    out = {}
    for it in items or []:
        for part in it.split(","):
            if part.strip():
                k, v = part.split("=")
                out[k.strip()] = int(v)
    return out


def main(argv=None) -> int:
    from methods import DEFAULT_METHODS, METHODS

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", default="bunny,igea,fandisk,generated1m",
                    help="comma list: stems of files in the shared mesh dir, or generated<N>[k|m] "
                         "(default %(default)s)")
    ap.add_argument("--ratios", default="0.5,0.1,0.02,0.005", help="target face ratios (default %(default)s)")
    ap.add_argument("--methods", default=",".join(DEFAULT_METHODS),
                    help=f"comma list, or 'all', or 'peers' (all but lodkit*). Known: {', '.join(METHODS)} "
                         "(default %(default)s)")
    ap.add_argument("--repeats", type=int, default=3, help="timed repeats per case; the median is reported (default 3)")
    ap.add_argument("--repeats-for", action="append", metavar="MESH=N",
                    help="override --repeats for a mesh, e.g. generated1m=1 (repeatable, comma lists ok)")
    ap.add_argument("--time-budget", type=float, default=20.0,
                    help="stop repeating a case once its calls have used this many seconds (>=1 repeat; default 20)")
    ap.add_argument("--timeout", type=float, default=900.0, help="kill a worker after this many seconds (default 900)")
    ap.add_argument("--tracemalloc", default="lodkit",
                    help="methods that get an extra, untimed tracemalloc run: 'lodkit' (lodkit*), 'all' or 'none'")
    ap.add_argument("--samples", type=int, default=200_000, help="Metro samples per surface (default 200000)")
    ap.add_argument("--seed", type=int, default=None, help="sampling seed (default: bench.metro.DEFAULT_SEED)")
    ap.add_argument("--out", default=str(HERE / "results"), help="results directory (default bench/results/)")
    ap.add_argument("--report", default=str(REPO / "docs" / "benchmarks.md"),
                    help="Markdown report to regenerate at the end ('' to skip; default docs/benchmarks.md)")
    ap.add_argument("--no-snapshot", dest="snapshot", action="store_false",
                    help="import lodkit from the live checkout instead of a copy taken at the start of the run")
    ap.add_argument("--keep-outputs", action="store_true", help="keep simplified meshes in <out>/outputs/")
    # worker mode (internal)
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--method", help=argparse.SUPPRESS)
    ap.add_argument("--mesh-npz", help=argparse.SUPPRESS)
    ap.add_argument("--ratio", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--result", help=argparse.SUPPRESS)
    ap.add_argument("--out-mesh", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)

    if args.worker:
        args.tracemalloc = args.tracemalloc == "on"
        return worker(args)

    import metro
    import numpy as np
    from meshes import prepare

    meshes = [m.strip() for m in args.meshes.split(",") if m.strip()]
    ratios = [float(r) for r in args.ratios.split(",") if r.strip()]
    if args.methods == "all":
        methods = list(METHODS)
    elif args.methods == "peers":
        methods = [m for m in METHODS if not m.startswith("lodkit")]
    else:
        methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        ap.error(f"unknown method(s) {unknown}; known: {list(METHODS)}")
    repeats_for = parse_repeats_for(args.repeats_for)
    seed = metro.DEFAULT_SEED if args.seed is None else args.seed

    out_dir = Path(args.out).resolve()  # workers run with cwd=bench/
    out_dir.mkdir(parents=True, exist_ok=True)
    cache = out_dir / "cache"
    keep_dir = out_dir / "outputs"

    t_start = time.perf_counter()
    cmdline = "python bench/run.py " + " ".join(shlex.quote(a) for a in (argv if argv is not None else sys.argv[1:]))
    meta = {
        "command": cmdline,
        "started": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
        "machine": machine_info(),
        "versions": library_versions(),
        "settings": {"meshes": meshes, "ratios": ratios, "methods": methods, "repeats": args.repeats,
                     "repeats_for": repeats_for, "time_budget_s": args.time_budget, "timeout_s": args.timeout,
                     "samples": args.samples, "seed": seed, "tracemalloc": args.tracemalloc},
        "methods": {},
        "meshes": {},
    }
    from methods import PARAMS

    print(f"[bench] machine: {meta['machine']['cpu']}, {meta['machine']['usable_cpus']} usable cpus", flush=True)
    records: list[dict] = []
    with tempfile.TemporaryDirectory(prefix="lodkit-bench-") as tmpdir:
        if args.snapshot and any(m.startswith("lodkit") for m in methods) and (REPO / "lodkit").is_dir():
            digest = snapshot_lodkit(Path(tmpdir) / "snapshot")
            meta["lodkit_snapshot"] = digest
            print(f"[bench] lodkit: measuring a snapshot of {REPO / 'lodkit'} (src {digest})", flush=True)
        for m in methods:
            status, val = probe(m, timeout=120)
            if "lodkit_snapshot" in meta:
                val = val.replace(str(Path(tmpdir) / "snapshot" / "lodkit"), f"snapshot of {REPO / 'lodkit'}")
            meta["methods"][m] = {"status": status, ("version" if status == "ok" else "error"): val,
                                  "call": PARAMS.get(m, "")}
            print(f"[bench] {m}: {status}: {val}", flush=True)

        for mesh in meshes:
            t = time.perf_counter()
            try:
                npz = prepare(mesh, cache)
            except Exception as exc:  # noqa: BLE001
                print(f"[bench] {mesh}: cannot load: {exc}", flush=True)
                meta["meshes"][mesh] = {"error": f"{type(exc).__name__}: {exc}"}
                continue
            with np.load(npz) as z:
                V0, F0, src = z["vertices"], z["faces"], str(z["source"])
            ref = metro.Reference(V0, F0, n_samples=args.samples, seed=seed)
            reps = repeats_for.get(mesh, args.repeats)
            meta["meshes"][mesh] = {"source": src, "faces": int(len(F0)), "vertices": int(len(V0)),
                                    "used_vertices": ref.validity["used_vertices"], "bbox_diag": ref.diag,
                                    "input_validity": ref.validity, "repeats": reps}
            print(f"[bench] {mesh}: {len(F0)} faces, {len(V0)} vertices ({time.perf_counter() - t:.1f} s to prepare)",
                  flush=True)
            for ratio in ratios:
                for m in methods:
                    rec = {"mesh": mesh, "method": m, "ratio": ratio}
                    info = meta["methods"][m]
                    if info["status"] != "ok":
                        rec.update(status="unavailable", error=info["error"])
                        records.append(rec)
                        continue
                    want_tm = args.tracemalloc == "all" or (args.tracemalloc == "lodkit" and m.startswith("lodkit"))
                    r, out_mesh = run_case(mesh, m, npz, ratio, reps, args.time_budget, args.timeout, want_tm, tmpdir)
                    rec.update({k: v for k, v in r.items() if k not in ("method", "ratio")})
                    if r.get("status") == "ok" and out_mesh.exists():
                        with np.load(out_mesh) as z:
                            Vo, Fo = z["vertices"], z["faces"]
                        try:
                            rec.update(ref.compare(Vo, Fo))
                        except Exception as exc:  # noqa: BLE001
                            rec["metro_error"] = f"{type(exc).__name__}: {exc}"
                        rec["bytes_per_input_vertex"] = rec["peak_mem_bytes"] / len(V0)
                        if args.keep_outputs:
                            keep_dir.mkdir(exist_ok=True)
                            os.replace(out_mesh, keep_dir / out_mesh.name)
                        else:
                            out_mesh.unlink()
                    records.append(rec)
                    _print_case(rec)
                    meta["elapsed_s"] = time.perf_counter() - t_start
                    write_results(out_dir, meta, records)
            del ref
    meta["elapsed_s"] = time.perf_counter() - t_start
    meta["finished"] = time.strftime("%Y-%m-%d %H:%M:%S %Z")
    write_results(out_dir, meta, records)
    print(f"[bench] wrote {out_dir / 'results.json'} and results.csv ({meta['elapsed_s']:.0f} s)", flush=True)
    if args.report:
        import report

        report.write(out_dir / "results.json", Path(args.report).resolve())
        print(f"[bench] wrote {args.report}", flush=True)
    return 0


def _print_case(r: dict) -> None:
    head = f"[bench]   {r['mesh']:>12s} r={r['ratio']:<6g} {r['method']:<20s}"
    if r.get("status") != "ok":
        print(f"{head} {r.get('status')}: {r.get('error')}", flush=True)
        return
    h = r.get("hausdorff")
    print(f"{head} faces={r.get('faces')}/{r.get('target')} t={r['time_s']:.3f}s x{r['repeats']} "
          f"mem={r['peak_mem_bytes'] / 2**20:.1f}MiB H={h if h is None else f'{h:.2e}'} "
          f"nm={r.get('nonmanifold_edges')} flip={r.get('flipped_faces')} (wall {r['worker_wall_s']:.1f}s)", flush=True)


if __name__ == "__main__":
    sys.exit(main())
