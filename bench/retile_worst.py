#!/usr/bin/env python
"""Where re-tiling's worst errors are (docs/retile.md, "Where the worst points are").

Re-tiles one mesh at the vertex count QEM reaches at a fraction of the input's vertices,
reports Hausdorff / QEM's (lodkit.evaluate, 100 000 samples a side, both sides), then
samples both surfaces again and lists the worst samples (at least three mean output edge
lengths apart) with their side, sign along the sampled surface's normal, distance to the
input's boundary (in mean output edge lengths) and the local output spacing.

    python bench/retile_worst.py bunny 0.02 --refine 3 --fit 4 --seed 0
    python bench/retile_worst.py fandisk 0.1 --features 40 --refine 3 --fit 4
"""
from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
if importlib.util.find_spec("lodkit") is None:     # a checkout without lodkit installed: its source
    sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from common import shared_mesh_path  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

import lodkit  # noqa: E402
from lodkit.evaluate import closest_points, sample_surface  # noqa: E402
from lodkit.geometry import face_normals, triangle_quality  # noqa: E402
from lodkit.retile import face_twins, retile  # noqa: E402

MESHES = {"bunny": "bunny.ply", "igea": "igea.ply", "fandisk": "fandisk.obj", "cow": "cow.obj"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mesh", choices=sorted(MESHES))
    ap.add_argument("fraction", type=float)
    ap.add_argument("--refine", type=int, default=3)
    ap.add_argument("--fit", type=int, default=4)
    ap.add_argument("--features", type=float, default=None)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--worst", type=int, default=6)
    args = ap.parse_args(argv)
    src = lodkit.load(shared_mesh_path(MESHES[args.mesh]))
    qem = lodkit.simplify(src, target_faces=max(4, int(round(2 * args.fraction * src.n_vertices))))
    t = time.perf_counter()
    r = retile(src, qem.mesh.n_vertices, refine=args.refine, fit=args.fit, features=args.features, seed=args.seed)
    seconds = time.perf_counter() - t
    out = r.mesh
    diag = float(np.linalg.norm(src.vertices.max(axis=0) - src.vertices.min(axis=0)))
    eq = lodkit.evaluate(src, qem.mesh, samples=100_000).distance
    er = lodkit.evaluate(src, out, samples=100_000).distance
    q = triangle_quality(out.vertices, out.faces)
    h = eq.hausdorff
    print(f"{args.mesh}@{args.fraction:g} V={out.n_vertices} seed={args.seed} {seconds:.1f} s: H / QEM "
          f"{er.hausdorff / h:.2f} (input->output {er.hausdorff_fwd / h:.2f}, output->input "
          f"{er.hausdorff_bwd / h:.2f}), mean / QEM {er.mean / eq.mean:.2f}, quality {q.mean():.3f} / {q.min():.3f}")
    V0, F0 = src.vertices, src.faces.astype(np.int64)
    Fo = out.faces.astype(np.int64)
    bh = np.flatnonzero(face_twins(F0) < 0)
    btree = cKDTree(V0[np.unique(F0.reshape(-1)[bh])]) if bh.size else None
    e = np.concatenate([Fo[:, [0, 1]], Fo[:, [1, 2]], Fo[:, [2, 0]]])
    mel = float(np.linalg.norm(out.vertices[e[:, 0]] - out.vertices[e[:, 1]], axis=1).mean())
    otree = cKDTree(out.vertices)
    for side, (A, FA, B, FB) in (("input->output", (V0, F0, out.vertices, Fo)),
                                 ("output->input", (out.vertices, Fo, V0, F0))):
        P, face, _ = sample_surface(A, FA, 100_000, 0)
        C, _, _ = closest_points(B, FB, P)
        d = np.linalg.norm(P - C, axis=1)
        sign = np.sign(np.einsum("ij,ij->i", P - C, face_normals(A, FA)[0][face]))
        chosen = []
        for i in np.argsort(-d):
            if all(np.linalg.norm(P[i] - P[j]) > 3 * mel for j in chosen):
                chosen.append(i)
            if len(chosen) == args.worst:
                break
        for i in chosen:
            bnd = btree.query(P[i])[0] / mel if btree is not None else float("inf")
            spacing = float(otree.query(P[i], k=6)[0].mean()) / mel
            print(f"  {side} {d[i] / diag:.2e} ({d[i] / diag / h:.2f} x QEM) at {np.round(P[i], 3)} "
                  f"{'outside' if sign[i] > 0 else 'inside'} the other surface, boundary {bnd:.2f} edges, "
                  f"local spacing {spacing:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
