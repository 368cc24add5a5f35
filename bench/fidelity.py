#!/usr/bin/env python
"""Fidelity benchmark of the paper metrics (melod, normal_qem, curvature, appearance).

Measures what the issue claims for each metric, next to lodkit's plain ``qem`` (and Open3D
where the claim names it), and writes one table per claim with a met / not met line:

1. geometry  -- at 2% (and 10%) of the faces, ``melod``'s symmetric Metro Hausdorff error on
   bunny and cow is below Open3D's ``simplify_quadric_decimation``'s;
2. colour    -- ``appearance``'s sampled colour error on colored_airplane (2%, 10%) is below
   geometry-only ``qem``'s (which carries the colours along but does not weigh them);
3. seams     -- ``appearance`` keeps the UV seams of spot_triangulated closed (10%, 2%): the
   copies of a seam vertex still coincide, no seam vertex lost on one side only, and each
   kept seam copy has its own input uv;
4. creases   -- ``curvature`` keeps more vertices near fandisk's creases (dihedral angle
   > 30 deg) than ``qem`` at the same face count (10%, 2%);
5. speed     -- each metric to 1% of bunny within 3x lodkit ``qem``'s time on the same input
   (median of interleaved rounds).

    python bench/fidelity.py                         # everything, about 1-3 minutes
    python bench/fidelity.py --claims seams,creases --samples 50000

Every metric runs in its own worker subprocess (this script with ``--worker``), so a metric
that raises, is still a placeholder, or crashes the interpreter is reported as "not
available" with its error, and the run goes on. The measuring (bench/metro.py: Metro
distances, colour error, crease vertices, seam check) happens in the parent.

Writes bench/results/fidelity.json and the "Fidelity" section of docs/benchmarks.md
(between ``<!-- fidelity:begin -->`` and ``<!-- fidelity:end -->``; bench/report.py keeps it).
"""
from __future__ import annotations

import argparse
import gc
import importlib.util
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
if importlib.util.find_spec("lodkit") is None:     # a checkout without lodkit installed: its source
    sys.path.insert(0, str(REPO))
sys.path.insert(0, str(HERE))

from common import run_worker  # noqa: E402

BEGIN = "<!-- fidelity:begin -->"
END = "<!-- fidelity:end -->"

PAPER_METRICS = ["melod", "normal_qem", "curvature", "appearance"]
ALL_CLAIMS = ["geometry", "colour", "seams", "creases", "speed"]

# mesh keys -> shared files; variants with computed attributes end in +normals / +colors
MESH_FILES = {
    "bunny": "bunny.ply",
    "cow": "cow.obj",
    "fandisk": "fandisk.obj",
    "colored_airplane": "colored_airplane.ply",
    "spot": "spot_triangulated.obj",
}


# --------------------------------------------------------------------------------------
# inputs
# --------------------------------------------------------------------------------------

def mesh_dir() -> Path:
    from meshes import MESH_DIR

    return Path(MESH_DIR)


def vertex_normals(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals (unit; zero for vertices no face uses)."""
    F = np.asarray(F, dtype=np.int64)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])   # length = 2 * area
    out = np.zeros_like(V)
    for k in range(3):
        np.add.at(out, F[:, k], n)
    ln = np.linalg.norm(out, axis=1, keepdims=True)
    return np.divide(out, ln, out=np.zeros_like(out), where=ln > 0)


def synthetic_colors(V: np.ndarray) -> np.ndarray:
    """Smooth colour bands from the position (deterministic), RGB in [0, 1]."""
    lo, hi = V.min(axis=0), V.max(axis=0)
    p = (V - lo) / np.where(hi > lo, hi - lo, 1.0)
    return np.clip(0.5 + 0.5 * np.sin(2.0 * np.pi * np.array([3.0, 2.0, 4.0]) * p[:, [0, 1, 2]]
                                      + np.array([0.0, 1.0, 2.0])), 0.0, 1.0)


def _blob_radius(U: np.ndarray) -> np.ndarray:
    x, y, z = U[:, 0], U[:, 1], U[:, 2]
    return (1.0 + 0.16 * np.cos(5.0 * np.arctan2(y, x)) * (1.0 - z * z) + 0.12 * np.sin(3.0 * z + 0.5)
            + 0.08 * np.exp(-((x - 0.6) ** 2 + (y + 0.5) ** 2 + (z - 0.6) ** 2) / 0.05))


def blob_mesh(n: int = 56):
    """A closed bumpy star-shaped surface (a cube sphere, 12 n^2 faces) with exact normals.

    Vertex ``u`` (unit vector) sits at ``r(u) u``; the normals are the normalised gradient
    of the implicit function ``|x| - r(x / |x|)`` (central differences of the analytic
    function, not of the mesh), as a marching-cubes mesh of an implicit surface would carry:
    normals that know more than the faces do. Deterministic. Returns (V, F, normals).
    """
    t = np.linspace(-1.0, 1.0, n + 1)
    a, b = np.meshgrid(t, t, indexing="ij")
    pts, faces, off = [], [], 0
    for axis in range(3):
        for sign in (-1.0, 1.0):
            P = np.empty((n + 1, n + 1, 3))
            P[..., axis] = sign
            P[..., (axis + 1) % 3] = a
            P[..., (axis + 2) % 3] = b
            pts.append(P.reshape(-1, 3))
            i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
            q0 = (i * (n + 1) + j).ravel() + off
            q1, q2, q3 = q0 + (n + 1), q0 + (n + 1) + 1, q0 + 1
            faces.append(np.concatenate([np.stack([q0, q1, q2], 1), np.stack([q0, q2, q3], 1)]))
            off += (n + 1) ** 2
    P = np.concatenate(pts)
    U = P / np.linalg.norm(P, axis=1, keepdims=True)
    _, first, inv = np.unique(np.round(U, 12), axis=0, return_index=True, return_inverse=True)
    U = U[first]
    F = inv.reshape(-1)[np.concatenate(faces)]
    c = U[F].mean(axis=1)
    nrm = np.cross(U[F[:, 1]] - U[F[:, 0]], U[F[:, 2]] - U[F[:, 0]])
    flip = np.einsum("ij,ij->i", nrm, c) < 0
    F[flip] = F[flip][:, ::-1]
    V = U * _blob_radius(U)[:, None]

    def implicit(X):
        return np.linalg.norm(X, axis=1) - _blob_radius(X / np.linalg.norm(X, axis=1, keepdims=True))

    h = 1e-6
    G = np.stack([(implicit(V + h * e) - implicit(V - h * e)) / (2 * h) for e in np.eye(3)], axis=1)
    N = G / np.linalg.norm(G, axis=1, keepdims=True)
    return V, F.astype(np.int64), N


def load_mesh(key: str):
    """A lodkit.Mesh for ``key``: a MESH_FILES key or 'blob', optionally with '+normals' / '+colors'."""
    import lodkit

    base, *extras = key.split("+")
    if base == "blob":
        V, F, N = blob_mesh()
        mesh = lodkit.Mesh(V, F, normals=N)
    else:
        mesh = lodkit.load(mesh_dir() / MESH_FILES.get(base, base))
    for extra in extras:
        if extra == "normals":
            mesh = lodkit.Mesh(mesh.vertices, mesh.faces, normals=vertex_normals(mesh.vertices, mesh.faces),
                               colors=mesh.colors, uvs=mesh.uvs)
        elif extra == "colors":
            mesh = lodkit.Mesh(mesh.vertices, mesh.faces, normals=mesh.normals,
                               colors=synthetic_colors(mesh.vertices), uvs=mesh.uvs)
        else:
            raise ValueError(f"unknown mesh variant {extra!r} in {key!r}")
    return mesh


#: extra rows of the crease table: a metric run with other check settings than its defaults
#: (curvature's defaults are the paper's 60 degrees / quality 0.5; this row uses lodkit's,
#: the same checks plain qem runs with, so the ordering alone is compared)
CREASE_VARIANTS = {"curvature (checks 90°/0.1)": ("curvature", {"max_normal_angle": 90.0, "min_quality": 0.1})}


def input_for(metric: str, base: str) -> str:
    """The input a metric gets: normal_qem gets area-weighted vertex normals (none of the files has any)."""
    if metric == "normal_qem":
        return base + "+normals"
    return base


# --------------------------------------------------------------------------------------
# worker: run one metric on a list of cases, save every output
# --------------------------------------------------------------------------------------

def _short(exc: BaseException) -> str:
    msg = f"{type(exc).__name__}: {exc}"
    return msg if len(msg) < 300 else msg[:297] + "..."


def worker(metric: str, cases: list[dict], out_dir: Path) -> int:
    """Simplify each case with ``metric``; write case<i>.npz (arrays) and case<i>.json (status)."""
    import lodkit

    meshes = {}
    for i, case in enumerate(cases):
        status = {"metric": metric, **case}
        try:
            if case["mesh"] not in meshes:
                meshes[case["mesh"]] = load_mesh(case["mesh"])
            mesh = meshes[case["mesh"]]
            spec, settings = CREASE_VARIANTS.get(metric, (case.get("spec", metric), {}))
            t0 = time.perf_counter()
            res = lodkit.simplify(mesh, target_faces=int(case["target"]), metric=spec, **settings)
            dt = time.perf_counter() - t0
            m = res.mesh
            arrays = {"vertices": m.vertices, "faces": m.faces.astype(np.int64), "vertex_map": res.vertex_map}
            for name in ("colors", "uvs", "normals"):
                if getattr(m, name, None) is not None:
                    arrays[name] = getattr(m, name)
            np.savez(out_dir / f"case{i}.npz", **arrays)
            status.update(status_="ok", faces=int(m.n_faces), time_s=dt, stop_reason=res.stop_reason,
                          error_bound=float(res.error))
        except Exception as exc:  # noqa: BLE001 -- a failing metric is a result, not a crash
            status.update(status_="failed", error=_short(exc), traceback=traceback.format_exc(limit=4))
        (out_dir / f"case{i}.json").write_text(json.dumps(status))
    return 0


def run_metric_cases(metric: str, cases: list[dict], timeout: float = 300.0) -> list[dict]:
    """Run ``cases`` for ``metric`` in a worker subprocess; one dict per case.

    Each dict has ``status`` ('ok' / 'failed' / 'not available'), ``error`` if not ok, and
    for ok cases the output arrays under ``out`` (vertices, faces, vertex_map, attributes).
    """
    with tempfile.TemporaryDirectory(prefix="lodkit-fidelity-") as tmp:
        tmp = Path(tmp)
        (tmp / "cases.json").write_text(json.dumps(cases))
        crash = run_worker([Path(__file__).resolve(), "--worker", metric, "--worker-dir", tmp], timeout)
        out = []
        for i, case in enumerate(cases):
            js = tmp / f"case{i}.json"
            if not js.exists():
                out.append({**case, "metric": metric, "status": "failed",
                            "error": crash or "worker wrote no result"})
                continue
            r = json.loads(js.read_text())
            r["status"] = r.pop("status_")
            if r["status"] == "ok":
                with np.load(tmp / f"case{i}.npz") as z:
                    r["out"] = {k: z[k] for k in z.files}
            elif "being written" in r.get("error", "") or "placeholder" in r.get("error", "").lower():
                r["status"] = "not available"
            out.append(r)
        return out


def open3d_simplify(V: np.ndarray, F: np.ndarray, target: int, colors=None) -> dict:
    import open3d as o3d

    m = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(V), o3d.utility.Vector3iVector(F.astype(np.int32)))
    if colors is not None:
        m.vertex_colors = o3d.utility.Vector3dVector(np.ascontiguousarray(colors[:, :3]))
    t0 = time.perf_counter()
    s = m.simplify_quadric_decimation(target_number_of_triangles=int(target))
    dt = time.perf_counter() - t0
    out = {"vertices": np.asarray(s.vertices, dtype=np.float64), "faces": np.asarray(s.triangles, dtype=np.int64)}
    if s.has_vertex_colors():
        out["colors"] = np.asarray(s.vertex_colors, dtype=np.float64)
    return {"metric": "open3d", "status": "ok", "faces": int(len(out["faces"])), "time_s": dt, "out": out}


# --------------------------------------------------------------------------------------
# the claims
# --------------------------------------------------------------------------------------

def _target(n_faces: int, ratio: float) -> int:
    return int(round(ratio * n_faces))


def _row_base(r: dict) -> dict:
    keep = ("metric", "mesh", "ratio", "target", "status", "error", "faces", "time_s", "stop_reason")
    return {k: r[k] for k in keep if k in r}


def collect(metrics: list[str], plan: dict[str, list[dict]], timeout: float) -> dict[tuple, dict]:
    """Run every metric's cases (one worker per metric); {(metric, claim, mesh, ratio): result}."""
    results = {}
    for metric in metrics + [m for m in plan if m not in metrics]:
        cases = [c for c in plan.get(metric, [])]
        if not cases:
            continue
        t0 = time.perf_counter()
        for r in run_metric_cases(metric, cases, timeout=timeout):
            results[(metric, r["claim"], r["base"], r["ratio"])] = r
        states = sorted({r["status"] for k, r in results.items() if k[0] == metric})
        print(f"  {metric}: {len(cases)} cases in {time.perf_counter() - t0:.1f} s ({', '.join(states)})", flush=True)
    return results


def build_plan(claims: list[str], metrics: list[str], geo_meshes: list[str], ratios_geo: list[float],
               ratios_attr: list[float]) -> tuple[dict, dict]:
    """({metric: [case, ...]}, {mesh key: face count}) for the chosen claims."""
    face_counts = {}

    def faces(base):
        if base not in face_counts:
            face_counts[base] = int(load_mesh(base).n_faces)
        return face_counts[base]

    plan: dict[str, list[dict]] = {m: [] for m in metrics}
    for claim in claims:
        if claim == "geometry":
            pairs = [(b, r) for b in geo_meshes for r in ratios_geo]
        elif claim == "colour":
            pairs = [("colored_airplane", r) for r in ratios_attr]
        elif claim == "seams":
            pairs = [("spot", r) for r in ratios_attr]
        elif claim == "creases":
            pairs = [("fandisk", r) for r in ratios_attr]
        else:
            continue
        extra = list(CREASE_VARIANTS) if claim == "creases" and "curvature" in metrics else []
        for m in metrics + extra:
            for base, r in pairs:
                plan.setdefault(m, []).append({"claim": claim, "base": base, "mesh": input_for(m, base),
                                               "ratio": r, "target": _target(faces(base), r)})
    return plan, face_counts


def _reached(r: dict) -> bool:
    """Did the run get to its face target (within 2% + 2 faces)?"""
    t, f = r.get("target"), r.get("faces")
    return t is None or f is None or f <= 1.02 * t + 2


def _short_of(r: dict) -> str:
    return (f"{r.get('metric')} stopped at {r.get('faces'):,} faces for a target of {r.get('target'):,} "
            f"({r.get('stop_reason', '?')}), so it is not the same face count")


def claim_geometry(results, meshes, ratios, metrics, samples) -> dict:
    from metro import Reference

    rows = []
    for base in meshes:
        src = load_mesh(base)
        ref = Reference(src.vertices, src.faces, n_samples=samples)
        for ratio in ratios:
            target = _target(src.n_faces, ratio)
            entries = [("open3d", open3d_simplify(src.vertices, src.faces, target))]
            entries += [(m, results.get((m, "geometry", base, ratio))) for m in metrics]
            for label, r in entries:
                if r is None:
                    continue
                row = {**_row_base(r), "metric": label, "mesh": base, "ratio": ratio, "target": target,
                       "input": r.get("mesh", base)}
                if r["status"] == "ok":
                    e = ref.compare(r["out"]["vertices"], r["out"]["faces"])
                    row.update(hausdorff=e.get("hausdorff"), mean=e.get("mean"), rms=e.get("rms"),
                               flipped=e.get("flipped_faces_near"))
                rows.append(row)
    verdicts = []
    for ratio in ratios:
        wins, parts = [], []
        for base in meshes:
            get = {r["metric"]: r for r in rows if r["mesh"] == base and r["ratio"] == ratio}
            a, b = get.get("melod", {}), get.get("open3d", {})
            if a.get("hausdorff") is None or b.get("hausdorff") is None:
                wins.append(None)
                parts.append(f"{base}: melod not available")
                continue
            wins.append(a["hausdorff"] < b["hausdorff"] and _reached(a))
            parts.append(f"{base}: melod {a['hausdorff']:.3g} vs Open3D {b['hausdorff']:.3g} "
                         f"({a['hausdorff'] / b['hausdorff']:.2f}x)" + ("" if _reached(a) else f" but {_short_of(a)}"))
        met = False if False in wins else (None if None in wins else True)
        verdicts.append({"ratio": ratio, "met": met, "detail": "; ".join(parts),
                         "claimed": abs(ratio - 0.02) < 1e-12})
    return {"rows": rows, "verdicts": verdicts}


def claim_colour(results, ratios, metrics, samples) -> dict:
    from metro import Reference, color_error

    base = "colored_airplane"
    src = load_mesh(base)
    ref = Reference(src.vertices, src.faces, n_samples=samples)
    rows = []
    for ratio in ratios:
        target = _target(src.n_faces, ratio)
        entries = [(m, results.get((m, "colour", base, ratio))) for m in ["qem"] + [x for x in metrics if x != "qem"]]
        entries.append(("open3d", open3d_simplify(src.vertices, src.faces, target, colors=src.colors)))
        for label, r in entries:
            if r is None:
                continue
            row = {**_row_base(r), "metric": label, "mesh": base, "ratio": ratio, "target": target}
            if r["status"] == "ok":
                out = r["out"]
                if out.get("colors") is None:
                    row.update(status="failed", error="output has no vertex colours")
                else:
                    row.update(color_error(src.vertices, src.faces, src.colors, out["vertices"], out["faces"],
                                           out["colors"], n_samples=samples))
                    row["hausdorff"] = ref.compare(out["vertices"], out["faces"]).get("hausdorff")
            rows.append(row)
    verdicts = []
    for ratio in ratios:
        get = {r["metric"]: r for r in rows if r["ratio"] == ratio}
        a, b = get.get("appearance", {}), get.get("qem", {})
        if a.get("rms") is None or b.get("rms") is None:
            verdicts.append({"ratio": ratio, "met": None, "detail": "appearance not available", "claimed": True})
            continue
        met = a["rms"] < b["rms"] and a["mean_abs"] < b["mean_abs"] and _reached(a)
        verdicts.append({"ratio": ratio, "met": met, "claimed": True,
                         "detail": f"RMS {a['rms']:.2f} vs qem {b['rms']:.2f} ({a['rms'] / b['rms']:.2f}x), "
                                   f"mean |d| {a['mean_abs']:.2f} vs {b['mean_abs']:.2f}"
                                   + ("" if _reached(a) else f"; but {_short_of(a)}")})
    return {"rows": rows, "verdicts": verdicts}


def claim_seams(results, ratios, metrics) -> dict:
    from metro import seam_check

    base = "spot"
    src = load_mesh(base)
    rows = []
    for ratio in ratios:
        target = _target(src.n_faces, ratio)
        for m in ["qem"] + [x for x in metrics if x != "qem"]:
            r = results.get((m, "seams", base, ratio))
            if r is None:
                continue
            row = {**_row_base(r), "metric": m, "mesh": base, "ratio": ratio, "target": target}
            if r["status"] == "ok":
                out = r["out"]
                row.update(seam_check(src.vertices, src.faces, out["vertex_map"], out["vertices"], out["faces"],
                                      src.uvs, out.get("uvs")))
            rows.append(row)
    verdicts = []
    for ratio in ratios:
        a = next((r for r in rows if r["ratio"] == ratio and r["metric"] == "appearance"), {})
        if a.get("cracks") is None:
            verdicts.append({"ratio": ratio, "met": None, "detail": "appearance not available", "claimed": True})
            continue
        met = a["cracks"] == 0 and a["new_open_edges"] == 0 and a.get("uv_changed", 1) == 0 and _reached(a)
        q = next((r for r in rows
                  if r["ratio"] == ratio and r["metric"] == "qem" and r.get("cracks") is not None), None)
        qtxt = (f"; qem: {q['cracks']} cracks, {q['new_open_edges']} open seam edges, {q.get('uv_changed', '?')} "
                "changed uvs" if q else "")
        verdicts.append({"ratio": ratio, "met": met, "claimed": True,
                         "detail": f"{a['cracks']} cracks ({a['split_groups']} split, {a['orphans']} one-sided), "
                                   f"{a['new_open_edges']} open seam edges, max gap {a['max_gap']:.2g}, "
                                   f"{a.get('uv_changed', '?')} of {a['seam_vertices_out']} seam copies with a "
                                   "changed uv" + ("" if _reached(a) else f"; but {_short_of(a)}") + qtxt})
    return {"rows": rows, "verdicts": verdicts}


def claim_creases(results, ratios, metrics, samples, angle, tol_frac) -> dict:
    from metro import Reference, crease_vertices

    base = "fandisk"
    src = load_mesh(base)
    ref = Reference(src.vertices, src.faces, n_samples=samples)
    inp = crease_vertices(src.vertices, src.faces, src.vertices, src.faces, angle, tol_frac)
    rows = []
    for ratio in ratios:
        target = _target(src.n_faces, ratio)
        for m in ["qem"] + [x for x in metrics if x != "qem"] + list(CREASE_VARIANTS):
            r = results.get((m, "creases", base, ratio))
            if r is None:
                continue
            row = {**_row_base(r), "metric": m, "mesh": base, "ratio": ratio, "target": target}
            if r["status"] == "ok":
                out = r["out"]
                row.update(crease_vertices(src.vertices, src.faces, out["vertices"], out["faces"], angle, tol_frac))
                row["hausdorff"] = ref.compare(out["vertices"], out["faces"]).get("hausdorff")
            rows.append(row)
    verdicts = []
    for ratio in ratios:
        get = {r["metric"]: r for r in rows if r["ratio"] == ratio}
        a, b = get.get("curvature", {}), get.get("qem", {})
        if a.get("near") is None or b.get("near") is None:
            verdicts.append({"ratio": ratio, "met": None, "detail": "curvature not available", "claimed": True})
            continue
        verdicts.append({"ratio": ratio, "met": a["near"] > b["near"] and _reached(a), "claimed": True,
                         "detail": f"{a['near']} of {a['vertices']} vertices near a crease vs qem "
                                   f"{b['near']} of {b['vertices']}"
                                   + ("" if _reached(a) else f"; but {_short_of(a)}")})
        for name in CREASE_VARIANTS:
            v = get.get(name, {})
            if v.get("near") is not None:
                verdicts.append({"ratio": ratio, "met": v["near"] > b["near"] and _reached(v), "claimed": False,
                                 "detail": f"{name}: {v['near']} of {v['vertices']} vertices near a crease vs qem "
                                           f"{b['near']} of {b['vertices']}"
                                           + ("" if _reached(v) else f"; but {_short_of(v)}")})
    return {"rows": rows, "verdicts": verdicts, "input": inp, "angle": angle, "tol_frac": tol_frac}


# --------------------------------------------------------------------------------------
# speed (in a worker too: a crashing metric must not take the run down)
# --------------------------------------------------------------------------------------

SPEED_INPUT = {"melod": "bunny", "normal_qem": "bunny+normals", "curvature": "bunny", "appearance": "bunny+colors"}


def speed_worker(metrics: list[str], ratio: float, rounds: int, out_path: Path) -> int:
    import lodkit

    configs = []                      # (label, metric, mesh key)
    for key in sorted({SPEED_INPUT.get(m, "bunny") for m in metrics}):
        configs.append((f"qem@{key}", "qem", key))
    for m in metrics:
        configs.append((m, m, SPEED_INPUT.get(m, "bunny")))
    meshes = {key: load_mesh(key) for _, _, key in configs}
    status, times, faces = {}, {c[0]: [] for c in configs}, {}
    for label, metric, key in configs:       # warm-up, and drop what does not run
        try:
            res = lodkit.simplify(meshes[key], target_ratio=ratio, metric=metric)
            status[label] = "ok"
            faces[label] = int(res.mesh.n_faces)
        except Exception as exc:  # noqa: BLE001
            status[label] = _short(exc)
    live = [c for c in configs if status[c[0]] == "ok"]
    for r in range(rounds):
        k = r % max(1, len(live))
        for label, metric, key in live[k:] + live[:k]:
            gc.collect()
            t0 = time.perf_counter()
            lodkit.simplify(meshes[key], target_ratio=ratio, metric=metric)
            times[label].append(time.perf_counter() - t0)
    doc = {"ratio": ratio, "rounds": rounds, "loadavg": list(os.getloadavg()), "configs": [
        {"label": lb, "metric": m, "input": key, "status": status[lb], "faces": faces.get(lb),
         "times_s": times[lb], "time_s": statistics.median(times[lb]) if times[lb] else None}
        for lb, m, key in configs]}
    out_path.write_text(json.dumps(doc))
    return 0


def claim_speed(metrics: list[str], ratio: float, rounds: int, limit: float, timeout: float) -> dict:
    with tempfile.TemporaryDirectory(prefix="lodkit-fidelity-speed-") as tmp:
        out = Path(tmp) / "speed.json"
        cmd = [sys.executable, str(Path(__file__).resolve()), "--speed-worker", ",".join(metrics),
               "--worker-dir", tmp, "--speed-ratio", repr(ratio), "--rounds", str(rounds)]
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([str(REPO), str(HERE)]
                                            + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
        err = None
        try:
            p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, cwd=str(HERE))
            if p.returncode != 0:
                tail = " | ".join(p.stderr.strip().splitlines()[-3:])[-300:]
                err = f"speed worker exited with {p.returncode}: {tail}"
        except subprocess.TimeoutExpired:
            err = f"speed worker timed out after {timeout:.0f} s"
        if not out.exists():
            return {"rows": [], "verdicts": [{"met": None, "detail": err or "no result", "claimed": True}],
                    "ratio": ratio, "rounds": rounds, "limit": limit}
        doc = json.loads(out.read_text())
    by = {c["label"]: c for c in doc["configs"]}
    rows, verdicts = [], []
    for m in metrics:
        c = by.get(m)
        if c is None:
            continue
        base = by.get(f"qem@{c['input']}", {})
        row = {"metric": m, "input": c["input"], "status": "ok" if c["status"] == "ok" else "not available",
               "faces": c["faces"], "time_s": c["time_s"], "qem_time_s": base.get("time_s"),
               "qem_faces": base.get("faces"), "times_s": c["times_s"]}
        if c["status"] != "ok":
            row["error"] = c["status"]
        if row["time_s"] and row["qem_time_s"]:
            row["ratio_to_qem"] = row["time_s"] / row["qem_time_s"]
        rows.append(row)
        if row.get("ratio_to_qem") is None:
            verdicts.append({"metric": m, "met": None, "claimed": True, "detail": f"{m} not available"})
        else:
            short = bool(row["faces"] and row["qem_faces"] and row["faces"] > 1.02 * row["qem_faces"] + 2)
            verdicts.append({"metric": m, "met": row["ratio_to_qem"] <= limit and not short, "claimed": True,
                             "detail": f"{m}: {row['ratio_to_qem']:.2f}x qem ({row['time_s'] * 1000:.0f} ms vs "
                                       f"{row['qem_time_s'] * 1000:.0f} ms on {row['input']})"
                                       + (f"; but it stopped at {row['faces']} faces, qem at {row['qem_faces']}"
                                          if short else "")})
    return {"rows": rows, "verdicts": verdicts, "ratio": ratio, "rounds": rounds, "limit": limit,
            "loadavg": doc.get("loadavg")}


# --------------------------------------------------------------------------------------
# report
# --------------------------------------------------------------------------------------

def _e(x) -> str:
    return "–" if x is None else f"{x:.2e}"


def _f(x, spec=".2f") -> str:
    return "–" if x is None else format(x, spec)


def _esc(s) -> str:
    return str(s).replace("|", "\\|").replace("\n", " ")


def _row(head: str, r: dict, ncols: int, cells) -> str:
    """A table row: ``head`` then ``cells(r)``, or the ``ncols`` cells saying why ``r`` has
    no numbers (``_na``)."""
    na = _na(r, ncols)
    return f"{head} {na}" if na else f"{head} {cells(r)}"


def _na(r: dict, ncols: int) -> str | None:
    """A table cell run saying why a row has no numbers, or None if it has them."""
    if r.get("status") == "ok":
        return None
    label = "not available" if r.get("status") == "not available" else "failed"
    err = str(r.get("error", "?"))
    err = err if len(err) <= 160 else err[:157] + "..."
    return f"{label}: {_esc(err)} |" + " |" * (ncols - 1)


def _faces(r: dict) -> str:
    """The face count, with the target and stop reason when the run stopped short of it."""
    if _reached(r):
        return f"{r['faces']:,}"
    return f"{r['faces']:,} ⚠ (target {r['target']:,}: {r.get('stop_reason', '?')})"


def _verdict(v: dict) -> str:
    met = {True: "**met**", False: "**not met**", None: "**not measured**"}[v["met"]]
    return met


def _verdict_lines(verdicts: list[dict], unclaimed: str) -> list[str]:
    """One line per verdict, ratio first; ``unclaimed`` tags the rows that are not the claim."""
    return [f"- {v['ratio']:g}{'' if v.get('claimed', True) else unclaimed}: {_verdict(v)} — {_esc(v['detail'])}"
            for v in verdicts] + [""]


def render(doc: dict) -> str:
    L = [BEGIN, "## Fidelity of the paper metrics", "",
         f"Generated by `{doc['command']}` on {doc['started']} ({doc['elapsed_s']:.0f} s; lodkit src "
         f"{doc.get('lodkit_digest', '?')}). Each claim of the issue, measured; the other metrics and plain "
         "`qem` are listed for context. Every lodkit run uses the metric's own defaults "
         "(`lodkit.simplify(mesh, target_faces=round(r*m), metric=name)`), so a row differs from `qem` by "
         "the metric and by the settings it prefers. Distances are Metro-style (bench/metro.py: "
         f"{doc['samples']:,} area-weighted samples per surface, symmetric, exact point-triangle distance by "
         "Open3D's RaycastingScene) as fractions of the input's bbox diagonal. A metric that raises or crashes "
         "is listed as not available with its error. ⚠ after a face count: the run stopped above its "
         "target (the stop reason follows); such a row is not at the same face count and cannot meet a claim.", ""]
    status = doc.get("metric_status", {})
    if status:
        L.append("Metric status at this run: " + "; ".join(f"`{m}` {_esc(s)}" for m, s in status.items()) + ".")
        L.append("")
    C = doc["claims"]

    if "geometry" in C:
        g = C["geometry"]
        L += ["### 1. Geometric error: melod vs Open3D quadric decimation", "",
              "Claim: at 2% of the faces `melod`'s Hausdorff error is below Open3D's "
              "`simplify_quadric_decimation` on bunny and cow. (10% shown too.) `normal_qem` is given "
              "area-weighted vertex normals computed from the mesh (the files have none), in every table; "
              "`flipped` = output faces lying on the surface with their normal opposite the original's.", "",
              "| mesh | ratio | method | faces | Hausdorff | mean | RMS | flipped |",
              "|---|--:|---|--:|--:|--:|--:|--:|"]
        for r in g["rows"]:
            L.append(_row(f"| {r['mesh']} | {r['ratio']:g} | {r['metric']} |", r, 5, lambda r:
                          f"{_faces(r)} | {_e(r.get('hausdorff'))} | {_e(r.get('mean'))} | "
                          f"{_e(r.get('rms'))} | {r.get('flipped', '–')} |"))
        L.append("")
        L += _verdict_lines(g["verdicts"], " (not part of the claim)")

    if "colour" in C:
        c = C["colour"]
        L += ["### 2. Colour error: appearance vs geometry-only QEM (colored_airplane)", "",
              "Claim: `appearance` has a lower colour error than `qem` (which carries the colours along, "
              "interpolated on each collapsed edge, but does not weigh them). Colour error: "
              f"{doc['samples']:,} area-weighted samples on the original, colour interpolated from its vertex "
              "colours; the simplified colour interpolated at the closest point of the simplified surface "
              "(`metro.color_error`). In 8-bit RGB units (0–255), per channel: RMS, mean absolute, and the 99th "
              "percentile and maximum of the per-sample largest channel difference.", "",
              "| ratio | method | faces | RMS | mean abs | p99 | max | Hausdorff |",
              "|--:|---|--:|--:|--:|--:|--:|--:|"]
        for r in c["rows"]:
            L.append(_row(f"| {r['ratio']:g} | {r['metric']} |", r, 6, lambda r:
                          f"{_faces(r)} | {_f(r.get('rms'))} | {_f(r.get('mean_abs'))} | {_f(r.get('p99'), '.1f')} | "
                          f"{_f(r.get('max'), '.1f')} | {_e(r.get('hausdorff'))} |"))
        L.append("")
        L += _verdict_lines(c["verdicts"], " (a variant, not the claim)")

    if "seams" in C:
        s = C["seams"]
        rows = s["rows"]
        first_ok = next((r for r in rows if r.get("seam_positions_in") is not None), None)
        L += ["### 3. UV seams: appearance on spot_triangulated", "",
              "Claim: `appearance` keeps the UV seams intact. The loaded mesh has one vertex per (position, uv) "
              "pair, so a seam is a row of positions with two or more vertex copies"
              + (f" ({first_ok['seam_positions_in']} positions, {first_ok['seam_vertices_in']} copies)"
                 if first_ok else "") +
              ". Through `result.vertex_map` each output vertex goes back to an input copy and its position "
              "(`metro.seam_check`). **kept**: output vertices from seam copies; **split**: positions whose "
              "output copies no longer coincide; **one-sided**: positions that lost some but not all copies "
              "(a T-junction across the seam); **open edges**: edges with one face once the copies of each "
              "position are glued (the input has none: every one is a crack edge); **max gap**: largest distance "
              "between two copies of one position / bbox diagonal; **uv changed**: kept seam copies whose uv "
              "differs (> 1e-6) from their own input copy's uv.", "",
              "| ratio | method | faces | seam copies kept | split | one-sided | open edges | max gap | uv changed |",
              "|--:|---|--:|--:|--:|--:|--:|--:|--:|"]
        for r in rows:
            L.append(_row(f"| {r['ratio']:g} | {r['metric']} |", r, 7, lambda r:
                          f"{_faces(r)} | {r['seam_vertices_out']} | {r['split_groups']} | {r['orphans']} | "
                          f"{r['new_open_edges']} | {r['max_gap']:.2g} | {r.get('uv_changed', '–')} |"))
        L.append("")
        L += _verdict_lines(s["verdicts"], " (a variant, not the claim)")

    if "creases" in C:
        k = C["creases"]
        inp = k["input"]
        L += ["### 4. Crease vertices: curvature on fandisk", "",
              f"Claim: `curvature` keeps more vertices near the creases than `qem` at the same face count. "
              f"Creases: input edges with a dihedral angle above {k['angle']:g}° ({inp['crease_edges']} edges, "
              f"{inp['near']} of the input's {inp['vertices']} vertices lie on or near them). **near crease**: "
              f"output vertices within {k['tol_frac'] * 100:g}% of the bbox diagonal of a crease edge (exact "
              "point-to-segment distance, `metro.crease_vertices`).", "",
              "| ratio | method | faces | vertices | near crease | fraction | Hausdorff |",
              "|--:|---|--:|--:|--:|--:|--:|"]
        for r in k["rows"]:
            L.append(_row(f"| {r['ratio']:g} | {r['metric']} |", r, 5, lambda r:
                          f"{_faces(r)} | {r['vertices']} | {r['near']} | {r['fraction']:.0%} | "
                          f"{_e(r.get('hausdorff'))} |"))
        L.append("")
        L += _verdict_lines(k["verdicts"], " (a variant, not the claim)")

    if "speed" in C:
        sp = C["speed"]
        L += [f"### 5. Speed: each metric to {sp['ratio']:g} of bunny vs `qem`", "",
              f"Claim: within {sp['limit']:g}× lodkit `qem`'s time. Median of {sp['rounds']} interleaved rounds "
              "(rotated order) in one process, after a warm-up call; `qem` runs on the same input as the metric "
              "(`+normals`: area-weighted vertex normals; `+colors`: smooth synthetic vertex colours from the "
              "position). Wall time of `lodkit.simplify`, including the metric's setup."
              + (f" Load average when the timing ended: {sp['loadavg'][0]:.1f} (1 min) on "
                 f"{os.cpu_count()} CPUs; the machine is shared, so compare the ratios." if sp.get("loadavg") else ""),
              "",
              "| metric | input | faces | time | qem time | ×qem |", "|---|---|--:|--:|--:|--:|"]
        for r in sp["rows"]:
            L.append(_row(f"| {r['metric']} | {r['input']} |", r, 4, lambda r:
                          f"{r['faces']:,} | {r['time_s'] * 1000:.0f} ms | {r['qem_time_s'] * 1000:.0f} ms | "
                          f"{r['ratio_to_qem']:.2f} |"))
        L.append("")
        for v in sp["verdicts"]:
            L.append(f"- {_verdict(v)} — {_esc(v['detail'])}")
        L.append("")
    L.append(END)
    return "\n".join(L) + "\n"


def splice(report: Path, section: str) -> None:
    """Put ``section`` into the report, replacing an earlier one (or appending)."""
    from report import splice_section

    splice_section(report, section, BEGIN, END)


def metric_status(metrics: list[str], timeout: float = 120.0) -> dict[str, str]:
    """'works' or the error of ``simplify(bunny, target_ratio=0.1, metric=name)`` (in a worker)."""
    cases = [{"claim": "probe", "base": "bunny", "mesh": input_for(m, "bunny"), "ratio": 0.1,
              "target": 6945} for m in metrics]
    out = {}
    for m, case in zip(metrics, cases):
        r = run_metric_cases(m, [case], timeout=timeout)[0]
        out[m] = "works" if r["status"] == "ok" else f"{r['status']} ({r.get('error', '?')})"
    return out


def _strip(obj):
    """Drop output arrays before writing JSON."""
    if isinstance(obj, dict):
        return {k: _strip(v) for k, v in obj.items() if k not in ("out", "traceback")}
    if isinstance(obj, list):
        return [_strip(v) for v in obj]
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating,)):
        return float(obj)
    return obj


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--claims", default=",".join(ALL_CLAIMS), help="comma list of %(default)s")
    ap.add_argument("--metrics", default=",".join(PAPER_METRICS), help="paper metrics to measure (default %(default)s)")
    ap.add_argument("--context", default="qem", help="extra lodkit metrics listed for context (default %(default)s)")
    ap.add_argument("--geo-meshes", default="bunny,cow")
    ap.add_argument("--ratios", default="0.02,0.1", help="ratios for the geometry claim (default %(default)s)")
    ap.add_argument("--attr-ratios", default="0.1,0.02", help="ratios for colour/seams/creases (default %(default)s)")
    ap.add_argument("--samples", type=int, default=200_000, help="Metro samples per surface (default %(default)s)")
    ap.add_argument("--crease-angle", type=float, default=30.0, help="dihedral angle of a crease, degrees")
    ap.add_argument("--crease-tol", type=float, default=0.005,
                    help="'near a crease' as a fraction of the bbox diagonal")
    ap.add_argument("--speed-ratio", type=float, default=0.01)
    ap.add_argument("--rounds", type=int, default=5, help="speed rounds (default %(default)s)")
    ap.add_argument("--speed-limit", type=float, default=3.0)
    ap.add_argument("--timeout", type=float, default=300.0, help="per metric worker, seconds")
    ap.add_argument("--out", default=str(HERE / "results" / "fidelity.json"))
    ap.add_argument("--report", default=str(REPO / "docs" / "benchmarks.md"))
    ap.add_argument("--no-report", action="store_true", help="do not touch docs/benchmarks.md")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--speed-worker", help=argparse.SUPPRESS)
    ap.add_argument("--worker-dir", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)

    if args.worker:
        d = Path(args.worker_dir)
        return worker(args.worker, json.loads((d / "cases.json").read_text()), d)
    if args.speed_worker:
        return speed_worker(args.speed_worker.split(","), args.speed_ratio, args.rounds,
                            Path(args.worker_dir) / "speed.json")

    t_start = time.perf_counter()
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    claims = [c for c in args.claims.split(",") if c]
    bad = set(claims) - set(ALL_CLAIMS)
    if bad:
        ap.error(f"unknown claims {sorted(bad)}; choose from {ALL_CLAIMS}")
    paper = [m for m in args.metrics.split(",") if m]
    context = [m for m in args.context.split(",") if m and m not in paper]
    metrics = context + paper
    geo_meshes = [m for m in args.geo_meshes.split(",") if m]
    ratios_geo = [float(x) for x in args.ratios.split(",") if x]
    ratios_attr = [float(x) for x in args.attr_ratios.split(",") if x]

    from methods import _lodkit_digest

    print("metric status (bunny, 10%):", flush=True)
    status = metric_status(paper)
    for m, s in status.items():
        print(f"  {m}: {s}", flush=True)
    plan, _ = build_plan(claims, metrics, geo_meshes, ratios_geo, ratios_attr)
    print("simplifying:", flush=True)
    results = collect(metrics, plan, args.timeout)

    out: dict = {"claims": {}}
    if "geometry" in claims:
        print("measuring geometry ...", flush=True)
        out["claims"]["geometry"] = claim_geometry(results, geo_meshes, ratios_geo, metrics, args.samples)
    if "colour" in claims:
        print("measuring colour ...", flush=True)
        out["claims"]["colour"] = claim_colour(results, ratios_attr, metrics, args.samples)
    if "seams" in claims:
        print("measuring seams ...", flush=True)
        out["claims"]["seams"] = claim_seams(results, ratios_attr, metrics)
    if "creases" in claims:
        print("measuring creases ...", flush=True)
        out["claims"]["creases"] = claim_creases(results, ratios_attr, metrics, args.samples,
                                                 args.crease_angle, args.crease_tol)
    if "speed" in claims:
        print("timing ...", flush=True)
        out["claims"]["speed"] = claim_speed(paper, args.speed_ratio, args.rounds, args.speed_limit, args.timeout)

    cmd = "python bench/fidelity.py" + ("" if argv is None and len(sys.argv) == 1 else
                                        " " + " ".join(argv if argv is not None else sys.argv[1:]))
    doc = _strip({"command": cmd, "started": started, "elapsed_s": time.perf_counter() - t_start,
                  "samples": args.samples, "lodkit_digest": _lodkit_digest(REPO / "lodkit"),
                  "metric_status": status, **out})
    path = Path(args.out)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(doc, indent=1))
    section = render(doc)
    if not args.no_report:
        splice(Path(args.report), section)
    print(section)
    print(f"wrote {path}" + ("" if args.no_report else f" and the fidelity section of {args.report}"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
