"""Beyond one process (issue 14): lodkit.batch and lodkit.simplify_large, measured.

    python bench/scale.py batch --count 40 --out /tmp/scale       # 1 vs 2 workers, resume, a corrupt file
    python bench/scale.py threads --out /tmp/scale                # 1 vs 2 threads in one process
    python bench/scale.py quality --faces 2000000 --out /tmp/scale   # tiled vs in-core error (and igea-1m)
    python bench/scale.py large --faces 5000000 --out /tmp/scale  # a big closed surface, memory per process

Each prints one JSON object per measurement on stdout.  Errors are lodkit.evaluate's
(symmetric, area-weighted samples), as fractions of the bbox diagonal.  Not a test:
timings on a shared machine vary; docs/scale.md gives the figures of one run.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import lodkit  # noqa: E402
from lodkit.large import simplify_large  # noqa: E402
from lodkit.topology import topology  # noqa: E402

MESH_DIR = Path(os.environ.get("LODKIT_MESH_DIR", Path(__file__).resolve().parents[2] / "shared" / "data" / "meshes"))
SHARED = ("bunny.ply", "cow.obj", "fandisk.obj", "igea.ply", "spot_triangulated.obj", "boot.obj", "mountain.obj")


def emit(record: dict) -> None:
    print(json.dumps(record), flush=True)


def peak_rss_mb() -> float:
    """This process's peak resident memory: VmHWM, the high-water mark of its own address
    space.  Not ``ru_maxrss``: Linux folds the parent's high-water mark into a child's at
    exec, so a child started by a parent that once held 3 GB (this script generating the
    20M-face input) reports at least 3 GB whatever it uses itself."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


# ---------------------------------------------------------------------- batch
def make_library(directory: Path, count: int) -> list:
    """The shared meshes that are there, then generated variants up to ``count`` files,
    and one corrupt file."""
    from lodkit.demo import demo_mesh

    directory.mkdir(parents=True, exist_ok=True)
    files = []
    for name in SHARED:
        if (MESH_DIR / name).is_file() and len(files) < count - 1:
            shutil.copy(MESH_DIR / name, directory / name)
            files.append(directory / name)
    i = 0
    while len(files) < count - 1:
        path = directory / f"generated_{i:03d}.ply"
        lodkit.save(demo_mesh(10_000 + 1_500 * (i % 20)), path)
        files.append(path)
        i += 1
    bad = directory / "corrupt.ply"
    bad.write_bytes((MESH_DIR / "bunny.ply").read_bytes()[:5000] if (MESH_DIR / "bunny.ply").is_file()
                    else b"ply\nformat ascii 1.0\nelement vertex 3\n")
    files.append(bad)
    return files


def run_batch(args) -> None:
    lib = Path(args.out) / "library"
    files = make_library(lib, args.count)
    faces = 0
    for w in (1, 2):
        out = Path(args.out) / f"batch_{w}"
        shutil.rmtree(out, ignore_errors=True)
        t = time.perf_counter()
        r = lodkit.batch(lib, out, ratios=[0.5, 0.1, 0.02], workers=w)
        total = time.perf_counter() - t
        faces = sum(row["input_faces"] or 0 for row in r.rows)
        t2 = time.perf_counter()
        again = lodkit.batch(lib, out, ratios=[0.5, 0.1, 0.02], workers=w)
        emit({"bench": "batch", "files": len(files), "input_faces": faces, "workers": w, "seconds": round(total, 2),
              "ok": r.n_ok, "failed": r.n_failed, "rerun_seconds": round(time.perf_counter() - t2, 2),
              "rerun_skipped": again.n_skipped, "rerun_failed": again.n_failed})


def run_threads(args) -> None:
    lib = Path(args.out) / "library"
    make_library(lib, args.count)
    for w in (1, 2):
        out = Path(args.out) / f"threads_{w}"
        shutil.rmtree(out, ignore_errors=True)
        t = time.perf_counter()
        r = lodkit.batch(lib, out, ratios=[0.5, 0.1, 0.02], scheduler="threads", workers=w)
        emit({"bench": "threads", "files": len(r.rows), "threads": w, "seconds": round(time.perf_counter() - t, 2),
              "ok": r.n_ok, "failed": r.n_failed})


# ---------------------------------------------------------------------- tiles
def generated(n_faces: int, directory: Path) -> Path:
    from meshes import generated_mesh

    path = directory / f"torus_{n_faces}.ply"
    if not path.is_file():
        v, f = generated_mesh(n_faces)
        lodkit.save(lodkit.Mesh(v, f), path)
    return path


def igea_1m(directory: Path) -> Path | None:
    import open3d as o3d

    src = MESH_DIR / "igea.ply"
    if not src.is_file():
        return None
    path = directory / "igea_1m.ply"
    if not path.is_file():
        m = o3d.io.read_triangle_mesh(str(src)).subdivide_midpoint(1)
        lodkit.save(lodkit.Mesh(np.asarray(m.vertices), np.asarray(m.triangles)), path)
    return path


def run_quality(args) -> None:
    directory = Path(args.out)
    directory.mkdir(parents=True, exist_ok=True)
    inputs = [generated(args.faces, directory)]
    igea = igea_1m(directory)
    if igea is not None:
        inputs.append(igea)
    for path in inputs:
        mesh = lodkit.load(path)
        for ratio in (0.1, 0.01):
            t = time.perf_counter()
            ref = lodkit.simplify(mesh, target_ratio=ratio)
            t_ref = time.perf_counter() - t
            t = time.perf_counter()
            big = simplify_large(path, directory / "tiled.ply", target_ratio=ratio, tile_faces=args.tile_faces,
                                 workers=2)
            t_big = time.perf_counter() - t
            e_ref = lodkit.evaluate(mesh, ref.mesh, samples=200_000, seed=0).distance
            e_big = lodkit.evaluate(mesh, big.mesh, samples=200_000, seed=0).distance
            topo = topology(big.mesh)
            emit({"bench": "quality", "mesh": path.stem, "faces": mesh.n_faces, "ratio": ratio,
                  "tile_faces": args.tile_faces, "rounds": [(r["kind"], r.get("tiles")) for r in big.rounds],
                  "in_core_s": round(t_ref, 2), "tiled_s": round(t_big, 2),
                  "faces_out": [ref.mesh.n_faces, big.mesh.n_faces],
                  "hausdorff": [e_ref.hausdorff, e_big.hausdorff], "mean": [e_ref.mean, e_big.mean],
                  "hausdorff_x": round(e_big.hausdorff / e_ref.hausdorff, 3),
                  "mean_x": round(e_big.mean / e_ref.mean, 3),
                  "closed": topo.is_closed, "manifold": topo.is_manifold, "genus": topo.genus})


def run_large(args) -> None:
    """The big run in a fresh process (the driver's memory is its own), on a LocalCluster
    of 2 workers with a memory limit; the in-core figure in another fresh process."""
    import subprocess

    directory = Path(args.out)
    directory.mkdir(parents=True, exist_ok=True)
    path = generated(args.faces, directory)
    for mode in ("tiled", "in-core") if not args.no_in_core else ("tiled",):
        run = subprocess.run([sys.executable, __file__, "_large_child", str(path), str(directory), mode,
                              str(args.tile_faces), args.memory_limit], capture_output=True, text=True)
        if run.returncode:
            emit({"bench": "large", "mode": mode, "failed": run.stderr[-2000:]})
        else:
            print(run.stdout.strip().splitlines()[-1], flush=True)


def _large_child(path, directory, mode, tile_faces, memory_limit) -> None:
    t = time.perf_counter()
    out = Path(directory) / f"large_{mode}.ply"
    if mode == "in-core":
        mesh = lodkit.load(path)
        r = lodkit.simplify(mesh, target_ratio=0.01)
        lodkit.save(r.mesh, out)
        workers = []
    else:
        import distributed

        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, memory_limit=memory_limit,
                                      host="127.0.0.1", dashboard_address=None) as cluster, \
                distributed.Client(cluster, set_as_default=False) as client:
            r = simplify_large(path, out, target_ratio=0.01, tile_faces=int(tile_faces), client=client)
            workers = sorted(client.run(peak_rss_mb).values())
    seconds = time.perf_counter() - t
    topo = topology(lodkit.load(out))
    emit({"bench": "large", "mode": mode, "input_faces": int(lodkit.large.open_source(path).n_faces),
          "faces_out": topo.n_faces, "seconds": round(seconds, 1), "driver_peak_mb": round(peak_rss_mb()),
          "worker_peak_mb": [round(w) for w in workers], "memory_limit": memory_limit,
          "closed": topo.is_closed, "manifold": topo.is_manifold, "boundary_edges": topo.n_boundary_edges,
          "genus": topo.genus, "rounds": getattr(r, "rounds", None)})


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "_large_child":
        _large_child(*sys.argv[2:])
        return
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("what", choices=("batch", "threads", "quality", "large"))
    p.add_argument("--out", default="/tmp/lodkit-scale")
    p.add_argument("--count", type=int, default=40, help="files in the batch library (with one corrupt)")
    p.add_argument("--faces", type=int, default=2_000_000)
    p.add_argument("--tile-faces", type=int, default=250_000)
    p.add_argument("--memory-limit", default="2GB")
    p.add_argument("--no-in-core", action="store_true")
    args = p.parse_args()
    {"batch": run_batch, "threads": run_threads, "quality": run_quality, "large": run_large}[args.what](args)


if __name__ == "__main__":
    main()
