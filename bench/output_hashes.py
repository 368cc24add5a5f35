"""Hash every output of simplify() for every built-in metric and operator on the shared meshes.

A refactor that must not change behaviour is checked by running this before and after,
on the same machine, and comparing the two JSON files (bit-for-bit hashes of vertices,
faces, maps, attributes, errors, records, stop reasons and report counters):

    python bench/output_hashes.py --out before.json
    ... change the code, rebuild ...
    python bench/output_hashes.py --out after.json --compare before.json

Hashes are of the raw bytes, so they only compare runs on one machine (floating-point
sums differ in the last bits between CPUs); this is a development tool, not a test.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np

import lodkit

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from meshes import MESH_DIR  # noqa: E402

# mesh -> ratios; small enough that the whole matrix runs in a couple of minutes
MESHES = {
    "bunny.ply": (0.1, 0.02),
    "fandisk.obj": (0.1, 0.02),
    "cow.obj": (0.1,),
    "boot.obj": (0.1,),
    "colored_airplane.ply": (0.1,),
    "spot_triangulated.obj": (0.1, 0.02),
    "mountain.obj": (0.1,),
    "broken_bunny_res2.ply": (0.1,),
    "broken_test_nm.obj": (0.3,),
}

# (label, simplify keyword arguments); every built-in metric and operator
CASES = [
    ("qem", {}),
    ("qem_endpoint", {"placement": "endpoint"}),
    ("qem_lock", {"boundary": "lock"}),
    ("qem_free", {"boundary": "free"}),
    ("qem_native", {"metric": "qem_native"}),
    ("importance", {"metric": ["qem", ("importance", {"values": "height"})]}),
    ("melod", {"metric": "melod"}),
    ("normal_qem", {"metric": ("normal_qem", {"normals": "estimate"})}),
    ("curvature", {"metric": "curvature"}),
    ("appearance", {"metric": "appearance"}),
    ("triangle", {"operator": "triangle"}),
    ("pairs", {"pair_threshold": 0.002}),
    ("schroeder", {"metric": "schroeder"}),
    ("volume", {"metric": "volume"}),
    # the paper-pure rules (no accumulation): the outputs of "schroeder" / "volume" before
    # lodkit carried the removals' error (compare them with those labels of an older run)
    ("schroeder_pure", {"metric": ("schroeder", {"accumulate": "off"})}),
    ("volume_pure", {"metric": ("volume", {"accumulate": "off"})}),
    ("max_error", {"max_error": 0.002, "target_ratio": None}),
]


def digest(obj) -> str:
    h = hashlib.sha256()

    def feed(x):
        if isinstance(x, np.ndarray):
            h.update(str((x.dtype.str, x.shape)).encode())
            h.update(np.ascontiguousarray(x).tobytes())
        elif isinstance(x, dict):
            for k in sorted(x, key=str):
                h.update(repr(k).encode())
                feed(x[k])
        elif isinstance(x, (list, tuple)):
            h.update(b"[")
            for y in x:
                feed(y)
            h.update(b"]")
        elif isinstance(x, float):
            h.update(np.float64(x).tobytes())
        else:
            h.update(repr(x).encode())

    feed(obj)
    return h.hexdigest()[:20]


def _with_values(spec, mesh):
    """Resolve the placeholder "height" into per-vertex values (importance needs some)."""
    if isinstance(spec, list):
        return [_with_values(s, mesh) for s in spec]
    if isinstance(spec, tuple) and spec[1].get("values") == "height":
        z = mesh.vertices[:, 2]
        return (spec[0], {**spec[1], "values": (z - z.min()) / max(float(np.ptp(z)), 1e-30)})
    return spec


def run_case(mesh, ratio, kwargs) -> dict:
    kw = {"target_ratio": ratio, "record": True}
    kw.update(kwargs)
    if "metric" in kw:
        kw["metric"] = _with_values(kw["metric"], mesh)
    if kw.get("target_ratio") is None:
        kw.pop("target_ratio")
    try:
        r = lodkit.simplify(mesh, **kw)
    except Exception as exc:  # an error is an output too: it must stay the same
        return {"raised": f"{type(exc).__name__}: {exc}", "all": f"{type(exc).__name__}: {exc}"}
    # settings (and keys added since the baseline) say how, not what: not hashed
    report = {k: v for k, v in r.report.items() if k not in ("settings", "memory_order")}
    out = {
        "vertices": digest(r.mesh.vertices),
        "faces": digest(r.mesh.faces),
        "attributes": digest(r.mesh.attributes()),
        "vertex_map": digest(r.vertex_map),
        "face_map": digest(r.face_map),
        "error": digest(r.error),
        "records": digest(r.collapses),
        "stop": r.stop_reason,
        "n_collapses": r.n_collapses,
        "report": digest(report),
    }
    out["all"] = digest(out)
    return out


def progressive_case(mesh, extra) -> dict:
    pm = lodkit.progressive(mesh, **extra)
    lod = pm.at(faces=max(4, mesh.n_faces // 20))
    m = lod.mesh if hasattr(lod, "mesh") else lod
    return {"all": digest([m.vertices, m.faces])}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--compare", help="a JSON file from an earlier run to compare with")
    ap.add_argument("--only", help="comma-separated case labels")
    ap.add_argument("--kwargs", default="{}", help="JSON of simplify() keywords added to every case, "
                    'e.g. \'{"driver": "greedy"}\'')
    args = ap.parse_args(argv)
    directory = MESH_DIR
    if not directory.is_dir():
        print("the shared meshes are not here", file=sys.stderr)
        return 2
    only = set(args.only.split(",")) if args.only else None
    extra = json.loads(args.kwargs)
    results = {}
    t0 = time.perf_counter()
    for name, ratios in MESHES.items():
        mesh = lodkit.load(directory / name)
        for label, kwargs in CASES:
            if only and label not in only:
                continue
            for ratio in ratios:
                results[f"{name}:{label}:{ratio}"] = run_case(mesh, ratio, {**kwargs, **extra})
        if not only or "progressive" in only:
            results[f"{name}:progressive"] = progressive_case(mesh, extra)
    Path(args.out).write_text(json.dumps(results, indent=1, sort_keys=True))
    print(f"{len(results)} cases in {time.perf_counter() - t0:.1f} s -> {args.out}")
    if args.compare:
        before = json.loads(Path(args.compare).read_text())
        diff = [k for k in sorted(set(before) | set(results))
                if before.get(k, {}).get("all") != results.get(k, {}).get("all")]
        for k in diff:
            b, a = before.get(k, {}), results.get(k, {})
            parts = [f for f in sorted(set(a) | set(b)) if a.get(f) != b.get(f) and f != "all"]
            print(f"DIFFERS {k}: {', '.join(parts)}")
        print("identical" if not diff else f"{len(diff)} of {len(results)} cases differ")
        return 1 if diff else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
