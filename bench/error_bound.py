#!/usr/bin/env python
"""The guaranteed error bound (``simplify(error="hausdorff")``, issue 15) against plain QEM.

For each mesh and bound eps (a fraction of the bounding-box diagonal) it

- runs ``simplify(mesh, max_error=eps, error="hausdorff")`` (wall and CPU time, faces, the
  certified bound), and measures the two-sided Hausdorff distance of the result with
  ``lodkit.evaluate`` (``--samples`` per side, 1M by default): it must not exceed eps;
- measures plain QEM's curve of faces against its measured Hausdorff distance (a
  progressive mesh of the plain run, cut at a geometric series of face counts, each
  measured with ``--curve-samples`` per side), and reads off the face count plain QEM
  needs for the same measured Hausdorff as the bounded run (interpolated in log-log
  between the two nearest cuts);
- times plain QEM to the bounded run's face count.

With ``--openmesh DIR`` (a directory holding OpenMesh's Python binding, ``pip install
--target DIR openmesh``; its 1.2.1 sdist builds with ``CMAKE_POLICY_VERSION_MINIMUM=3.5``)
it adds, to the results already in ``--out``, OpenMesh's decimater with ``ModQuadric`` for
the order and ``ModHausdorff`` (tolerance eps times the diagonal) as the bound, measured
the same way.

Writes bench/results/error_bound.json, the plot docs/img/error-bound.png (faces against
distance: the bounded runs at their guaranteed bound, plain QEM at its measured Hausdorff)
and the table of docs/error-bound.md (between ``<!-- error-bound:begin -->`` and
``<!-- error-bound:end -->``).

    python bench/error_bound.py                                   # the four meshes, ~15 min on 2 cores
    python bench/error_bound.py --meshes cow --eps 0.005 --samples 200000     # a quick look
"""
from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
if importlib.util.find_spec("lodkit") is None:     # a checkout without lodkit installed: its source
    sys.path.insert(0, str(REPO))
sys.path.insert(0, str(HERE))

from common import shared_mesh_path, write_results  # noqa: E402

BEGIN = "<!-- error-bound:begin -->"
END = "<!-- error-bound:end -->"
MESHES = {"bunny": "bunny.ply", "igea": "igea.ply", "fandisk": "fandisk.obj", "cow": "cow.obj"}
# evaluate() measures in float32: its distances may pass the bound by this much of the diagonal
EVAL_TOL = 1e-6


def timed(fn):
    w, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - w, time.process_time() - c


def qem_curve(lodkit, mesh, samples: int, n_points: int) -> list:
    """[(faces, measured Hausdorff), ...] of plain QEM, from n/2 faces down to ~60."""
    pm = lodkit.progressive(mesh, min_faces=60)
    counts = np.unique(np.geomspace(mesh.n_faces / 2, 60, n_points).astype(int))[::-1]
    ev = lodkit.Evaluator(mesh, samples=samples)
    out = []
    for f in counts:
        level = pm.level(faces=int(f))
        out.append((level.n_faces, ev.evaluate(level.mesh).distance.hausdorff))
    return out


def faces_at(curve, h: float) -> float:
    """Plain QEM's face count at measured Hausdorff h: log-log interpolation on the curve
    (faces decreasing, Hausdorff increasing, up to the noise of sampling)."""
    fs = np.array([c[0] for c in curve], dtype=float)
    hs = np.maximum.accumulate(np.array([c[1] for c in curve]))   # monotone in the cut
    if h <= hs[0]:
        return float(fs[0])
    if h >= hs[-1]:
        return float(fs[-1])
    i = int(np.searchsorted(hs, h))
    x0, x1 = np.log(hs[i - 1]), np.log(hs[i])
    t = 0.0 if x1 == x0 else (np.log(h) - x0) / (x1 - x0)
    return float(np.exp(np.log(fs[i - 1]) + t * (np.log(fs[i]) - np.log(fs[i - 1]))))


def run(args) -> dict:
    import lodkit

    rows, curves = [], {}
    for name in args.meshes:
        mesh = lodkit.load(shared_mesh_path(MESHES.get(name, name)))
        print(f"{name}: {mesh.n_faces} faces", flush=True)
        curves[name] = qem_curve(lodkit, mesh, args.curve_samples, args.curve_points)
        ev = lodkit.Evaluator(mesh, samples=args.samples)
        for eps in args.eps:
            try:
                res, wall, cpu = timed(lambda: lodkit.simplify(mesh, max_error=eps, error="hausdorff",
                                                               threads=args.threads))
            except lodkit.OptionError as exc:
                rows.append({"mesh": name, "eps": eps, "failed": str(exc)})
                print(f"  eps {eps:g}: {exc}", flush=True)
                continue
            h = ev.evaluate(res.mesh).distance
            qem, qwall, qcpu = timed(lambda: lodkit.simplify(mesh, target_faces=res.mesh.n_faces,
                                                             threads=args.threads))
            row = {
                "mesh": name, "input_faces": mesh.n_faces, "eps": eps, "faces": res.mesh.n_faces,
                "certified": res.bound.relative, "hausdorff": h.hausdorff, "hausdorff_fwd": h.hausdorff_fwd,
                "hausdorff_bwd": h.hausdorff_bwd, "within": bool(h.hausdorff <= eps + EVAL_TOL),
                "stop": res.stop_reason, "pieces": res.report["error_bound"]["pieces"],
                "wall": wall, "cpu": cpu, "qem_wall": qwall, "qem_cpu": qcpu,
                "qem_faces_same_hausdorff": faces_at(curves[name], h.hausdorff),
                "samples": args.samples,
            }
            row["faces_ratio"] = row["faces"] / row["qem_faces_same_hausdorff"]
            row["time_ratio"] = cpu / max(qcpu, 1e-9)
            rows.append(row)
            print(f"  eps {eps:g}: {row['faces']} faces, certified {row['certified']:.4g}, measured "
                  f"{row['hausdorff']:.4g} ({'ok' if row['within'] else 'OVER'}); QEM at that Hausdorff "
                  f"{row['qem_faces_same_hausdorff']:.0f} faces (x{row['faces_ratio']:.2f}); "
                  f"CPU {cpu:.2f} s vs QEM {qcpu:.3f} s (x{row['time_ratio']:.0f})", flush=True)
    return {"rows": rows, "curves": {k: [list(map(float, c)) for c in v] for k, v in curves.items()},
            "samples": args.samples, "curve_samples": args.curve_samples, "threads": args.threads}


def run_openmesh(args, results: dict) -> None:
    """OpenMesh's ModHausdorff at the same eps, into the rows of ``results``."""
    import lodkit

    sys.path.append(args.openmesh)
    import openmesh as om

    for name in args.meshes:
        mesh = lodkit.load(shared_mesh_path(MESHES.get(name, name)))
        diag = float(np.linalg.norm(mesh.vertices.max(0) - mesh.vertices.min(0)))
        ev = lodkit.Evaluator(mesh, samples=args.samples)
        for row in results["rows"]:
            if row["mesh"] != name or "failed" in row:
                continue
            tm = om.TriMesh(mesh.vertices, mesh.faces)
            dec = om.TriMeshDecimater(tm)
            hq, hh = om.TriMeshModQuadricHandle(), om.TriMeshModHausdorffHandle()
            dec.add(hq)
            dec.add(hh)
            dec.module(hq).unset_max_err()
            dec.module(hh).set_binary(True)
            dec.module(hh).set_tolerance(row["eps"] * diag)
            dec.initialize()
            _, wall, cpu = timed(dec.decimate)
            tm.garbage_collection()
            out = lodkit.Mesh(np.asarray(tm.points(), dtype=np.float64), tm.face_vertex_indices().astype(np.int32))
            h = ev.evaluate(out).distance
            row.update({"om_faces": out.n_faces, "om_hausdorff": h.hausdorff, "om_hausdorff_fwd": h.hausdorff_fwd,
                        "om_hausdorff_bwd": h.hausdorff_bwd, "om_wall": wall, "om_cpu": cpu})
            print(f"  {name} eps {row['eps']:g}: OpenMesh {out.n_faces} faces, measured {h.hausdorff:.4g} "
                  f"(fwd {h.hausdorff_fwd:.4g}, bwd {h.hausdorff_bwd:.4g}), {cpu:.2f} s", flush=True)


def plot(results: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(results["curves"])
    fig, axes = plt.subplots(1, len(names), figsize=(3.6 * len(names), 3.4), squeeze=False)
    for ax, name in zip(axes[0], names):
        curve = np.array(results["curves"][name])
        ax.loglog(100 * curve[:, 1], curve[:, 0], "o-", ms=3, color="tab:gray",
                  label="plain QEM (measured Hausdorff)")
        rows = [r for r in results["rows"] if r["mesh"] == name and "failed" not in r]
        if rows:
            ax.loglog([100 * r["eps"] for r in rows], [r["faces"] for r in rows], "s-", color="tab:blue",
                      label="error='hausdorff' (guaranteed bound)")
            ax.loglog([100 * r["hausdorff"] for r in rows], [r["faces"] for r in rows], "x", color="tab:blue",
                      label="error='hausdorff' (measured)")
            om = [r for r in rows if "om_faces" in r]
            if om:
                ax.loglog([100 * r["om_hausdorff"] for r in om], [r["om_faces"] for r in om], "^", color="tab:red",
                          label="OpenMesh ModHausdorff (measured)")
        ax.set_title(name)
        ax.set_xlabel("distance (% of bbox diagonal)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("faces")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def table(results: dict) -> str:
    lines = [BEGIN, "",
             f"Measured by `bench/error_bound.py` ({results['samples']:,} samples per side for the bounded "
             f"runs, {results['curve_samples']:,} for plain QEM's curve; wall seconds, CPU seconds of the "
             f"process in brackets, {results['threads']} thread(s) on a 2-core machine shared with other jobs: "
             f"the wall times are noisy, the ratio is of CPU times).", "",
             "| mesh | ε | faces | certified | measured Hausdorff | ≤ ε | QEM faces at that Hausdorff | faces ratio "
             "| s (CPU) | QEM s (CPU) | time ratio (CPU) | OpenMesh faces | OpenMesh measured |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results["rows"]:
        if "failed" in r:
            lines.append(f"| {r['mesh']} | {100 * r['eps']:g} % | – | – | – | – | – | – | – | – | {r['failed']} |")
            continue
        om = (f"| {r['om_faces']} | {100 * r['om_hausdorff']:.3f} %" if "om_faces" in r else "| – | –")
        # past the end of plain QEM's curve (it starts at half the input's faces): a bound only
        first = min(c[1] for c in results["curves"][r["mesh"]])
        ge, le = ("≥ ", "≤ ") if r["hausdorff"] <= first else ("", "")
        lines.append(f"| {r['mesh']} | {100 * r['eps']:g} % | {r['faces']} | {100 * r['certified']:.3f} % "
                     f"| {100 * r['hausdorff']:.3f} % | {'yes' if r['within'] else '**no**'} "
                     f"| {ge}{r['qem_faces_same_hausdorff']:.0f} | {le}{r['faces_ratio']:.2f} "
                     f"| {r['wall']:.2f} ({r['cpu']:.2f}) | {r['qem_wall']:.3f} ({r['qem_cpu']:.3f}) "
                     f"| {r['time_ratio']:.0f} {om} |")
    lines += ["", END]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--meshes", default="bunny,igea,fandisk,cow", type=lambda s: s.split(","))
    ap.add_argument("--eps", default="0.001,0.005,0.02", type=lambda s: [float(x) for x in s.split(",")])
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--curve-samples", type=int, default=200_000)
    ap.add_argument("--curve-points", type=int, default=12)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default=str(REPO / "bench" / "results" / "error_bound.json"))
    ap.add_argument("--plot", default=str(REPO / "docs" / "img" / "error-bound.png"))
    ap.add_argument("--report", default=str(REPO / "docs" / "error-bound.md"))
    ap.add_argument("--openmesh", metavar="DIR", help="add OpenMesh's ModHausdorff to the results in --out")
    ap.add_argument("--table-only", action="store_true", help="redo the table and plot from --out")
    args = ap.parse_args(argv)
    if args.openmesh or args.table_only:
        import json

        results = json.loads(Path(args.out).read_text())
        if args.openmesh:
            run_openmesh(args, results)
    else:
        results = run(args)
    if args.plot:
        plot(results, Path(args.plot))
    write_results(results, args.out, table(results), Path(args.report) if args.report else Path(args.out + ".md"),
                  BEGIN, END)
    return 0


if __name__ == "__main__":
    sys.exit(main())
