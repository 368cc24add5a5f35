"""Metro-style geometric error and output validity, independent of lodkit.

Importable by any bench script::

    from metro import Reference, compare
    ref = Reference(V0, F0)                 # builds the raycasting scene and samples once
    report = ref.compare(V1, F1)            # dict, see below
    # or one-off: compare(V0, F0, V1, F1)

Definitions (all distances are unsigned point-to-surface distances and are divided by
the bounding-box diagonal of the original's *referenced* vertices):

* Sampling: ``n_samples`` points on each surface (default 200 000), area-weighted
  (face chosen with probability proportional to its area, then a uniform point in the
  triangle), from ``numpy.random.default_rng(seed)``; the same seed for every mesh, so
  results are reproducible. Zero-area faces are never sampled.
* ``d_fwd``: for each sample on the original, distance to the simplified surface;
  ``d_bwd``: for each sample on the simplified surface, distance to the original
  (``open3d.t.geometry.RaycastingScene.compute_distance``, exact point-triangle distance).
* ``hausdorff`` = max(max d_fwd, max d_bwd)  (symmetric, sampled Hausdorff);
* ``mean`` = mean of the union of d_fwd and d_bwd (2 * n_samples values);
* ``rms`` = sqrt(mean of squares) of the same union;
* the one-sided values are kept too (``hausdorff_fwd``/``_bwd``, ``mean_fwd``/``_bwd``,
  ``rms_fwd``/``_bwd``).

Validity of the simplified mesh:

* ``nonmanifold_edges``: undirected edges with 3 or more incident faces;
* ``boundary_edges``: edges with exactly one incident face (compare with the input's);
* ``degenerate_faces``: faces with a repeated vertex index or zero area;
* ``flipped_faces``: output faces whose unit normal has a negative dot product with the
  normal of the original face closest to the output face's centroid
  (``RaycastingScene.compute_closest_points`` -> ``primitive_ids``);
* ``flipped_faces_near``: the subset of those whose centroid lies within
  ``near_factor`` (default 0.1) x the face's longest edge of the original -- i.e. the
  face sits on the original surface, so the disagreement cannot come from the closest
  point landing on the far side of a thin part;
* ``flipped_area_frac``: area of flipped faces / total output area.

Degenerate output faces (zero area) have no normal and are never counted as flipped.
"""
from __future__ import annotations

import numpy as np

__all__ = ["Reference", "compare", "sample_surface", "edge_counts", "validity", "face_normals"]

DEFAULT_SAMPLES = 200_000
DEFAULT_SEED = 20240521


def _o3d():
    import open3d as o3d  # lazy: import takes 1-2 s

    return o3d


def face_normals(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(unit normals (m,3) -- zero rows for degenerate faces, areas (m,))."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    n = np.cross(b - a, c - a)
    ln = np.linalg.norm(n, axis=1)
    area = 0.5 * ln
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = np.where(ln[:, None] > 0, n / np.where(ln > 0, ln, 1.0)[:, None], 0.0)
    return unit, area


def sample_surface(V: np.ndarray, F: np.ndarray, n: int, seed: int = DEFAULT_SEED) -> np.ndarray:
    """``n`` area-weighted uniform samples on the triangle surface (float64 (n,3))."""
    rng = np.random.default_rng(seed)
    _, area = face_normals(V, F)
    total = area.sum()
    if not np.isfinite(total) or total <= 0:
        raise ValueError("surface has zero area")
    cdf = np.cumsum(area)
    idx = np.searchsorted(cdf, rng.random(n) * cdf[-1], side="right")
    idx = np.minimum(idx, len(F) - 1)
    r1 = np.sqrt(rng.random(n))
    r2 = rng.random(n)
    a, b, c = V[F[idx, 0]], V[F[idx, 1]], V[F[idx, 2]]
    return (1.0 - r1)[:, None] * a + (r1 * (1.0 - r2))[:, None] * b + (r1 * r2)[:, None] * c


def _scene(V: np.ndarray, F: np.ndarray):
    o3d = _o3d()
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor(np.ascontiguousarray(V, dtype=np.float32)),
        o3d.core.Tensor(np.ascontiguousarray(F, dtype=np.uint32)),
    )
    return scene


def _distance(scene, P: np.ndarray) -> np.ndarray:
    o3d = _o3d()
    return scene.compute_distance(o3d.core.Tensor(np.ascontiguousarray(P, dtype=np.float32))).numpy().astype(np.float64)


def edge_counts(F: np.ndarray) -> np.ndarray:
    """Number of incident faces for every distinct undirected edge."""
    if len(F) == 0:
        return np.zeros(0, dtype=np.int64)
    F = np.asarray(F, dtype=np.int64)
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    e.sort(axis=1)
    n = int(F.max()) + 1
    key = e[:, 0] * n + e[:, 1]
    _, counts = np.unique(key, return_counts=True)
    return counts


def validity(V: np.ndarray, F: np.ndarray) -> dict:
    """Topology counts that do not need the original."""
    counts = edge_counts(F)
    _, area = face_normals(V, F)
    repeated = (F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 2] == F[:, 0])
    used = np.unique(F) if len(F) else np.zeros(0, dtype=np.int64)
    return {
        "faces": int(len(F)),
        "vertices": int(len(V)),
        "used_vertices": int(len(used)),
        "edges": int(len(counts)),
        "boundary_edges": int((counts == 1).sum()),
        "nonmanifold_edges": int((counts >= 3).sum()),
        "degenerate_faces": int((repeated | (area <= 0)).sum()),
    }


class Reference:
    """The original mesh, prepared once: raycasting scene, samples, normals, scale."""

    def __init__(self, V: np.ndarray, F: np.ndarray, n_samples: int = DEFAULT_SAMPLES,
                 seed: int = DEFAULT_SEED):
        self.V = np.asarray(V, dtype=np.float64)
        self.F = np.asarray(F, dtype=np.int64)
        self.n_samples = int(n_samples)
        self.seed = int(seed)
        used = self.V[np.unique(self.F)]
        self.diag = float(np.linalg.norm(used.max(axis=0) - used.min(axis=0)))
        self.normals, _ = face_normals(self.V, self.F)
        self.scene = _scene(self.V, self.F)
        self.samples = sample_surface(self.V, self.F, self.n_samples, self.seed)
        self.validity = validity(self.V, self.F)

    def compare(self, V: np.ndarray, F: np.ndarray, near_factor: float = 0.1) -> dict:
        V = np.asarray(V, dtype=np.float64)
        F = np.asarray(F, dtype=np.int64)
        out = validity(V, F) if len(F) else {"faces": 0, "vertices": int(len(V))}
        out["diag"] = self.diag
        out["n_samples"] = self.n_samples
        if len(F) == 0:
            out["error"] = "empty output"
            return out
        _, area = face_normals(V, F)
        if not np.isfinite(V).all():
            out["error"] = "non-finite output coordinates"
            return out
        if area.sum() <= 0:
            out["error"] = "output has zero area"
            return out
        # forward: original samples -> simplified surface
        d_fwd = _distance(_scene(V, F), self.samples) / self.diag
        # backward: simplified samples -> original surface
        P = sample_surface(V, F, self.n_samples, self.seed + 1)
        d_bwd = _distance(self.scene, P) / self.diag
        d = np.concatenate([d_fwd, d_bwd])
        out.update(
            hausdorff=float(max(d_fwd.max(), d_bwd.max())),
            mean=float(d.mean()),
            rms=float(np.sqrt(np.mean(d * d))),
            hausdorff_fwd=float(d_fwd.max()),
            hausdorff_bwd=float(d_bwd.max()),
            mean_fwd=float(d_fwd.mean()),
            mean_bwd=float(d_bwd.mean()),
            rms_fwd=float(np.sqrt(np.mean(d_fwd ** 2))),
            rms_bwd=float(np.sqrt(np.mean(d_bwd ** 2))),
        )
        out.update(self.flipped(V, F, near_factor))
        return out

    def flipped(self, V: np.ndarray, F: np.ndarray, near_factor: float = 0.1) -> dict:
        o3d = _o3d()
        n_out, area = face_normals(V, F)
        ok = area > 0
        cent = V[F].mean(axis=1)
        res = self.scene.compute_closest_points(o3d.core.Tensor(cent.astype(np.float32)))
        prim = res["primitive_ids"].numpy().astype(np.int64)
        closest = res["points"].numpy().astype(np.float64)
        dist = np.linalg.norm(closest - cent, axis=1)
        dots = np.einsum("ij,ij->i", n_out, self.normals[prim])
        flipped = ok & (dots < 0)
        a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
        longest = np.max(np.stack([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1),
                                   np.linalg.norm(a - c, axis=1)]), axis=0)
        near = flipped & (dist <= near_factor * longest)
        return {
            "flipped_faces": int(flipped.sum()),
            "flipped_faces_near": int(near.sum()),
            "flipped_area_frac": float(area[flipped].sum() / area.sum()),
        }


def compare(V0, F0, V1, F1, n_samples: int = DEFAULT_SAMPLES, seed: int = DEFAULT_SEED) -> dict:
    """One-off: error and validity of (V1, F1) against the original (V0, F0)."""
    return Reference(V0, F0, n_samples, seed).compare(V1, F1)


if __name__ == "__main__":
    import argparse
    import json

    ap = argparse.ArgumentParser(description="Metro-style error between two mesh files (read with Open3D).")
    ap.add_argument("original")
    ap.add_argument("simplified")
    ap.add_argument("--samples", type=int, default=DEFAULT_SAMPLES)
    ap.add_argument("--seed", type=int, default=DEFAULT_SEED)
    args = ap.parse_args()
    o3d = _o3d()
    m0 = o3d.io.read_triangle_mesh(args.original)
    m1 = o3d.io.read_triangle_mesh(args.simplified)
    r = compare(np.asarray(m0.vertices), np.asarray(m0.triangles), np.asarray(m1.vertices),
                np.asarray(m1.triangles), args.samples, args.seed)
    print(json.dumps(r, indent=2))
