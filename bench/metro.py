"""Metro-style geometric error and output validity, for the bench scripts.

The distances are lodkit's own (:mod:`lodkit.evaluate`, one implementation for the
library and the benchmarks); this module keeps the dict interface the bench scripts use
and adds what only they need (validity counts, flipped faces, crease and seam checks)::

    from metro import Reference, compare
    ref = Reference(V0, F0)                 # prepares the original once (samples, raycasting scene)
    report = ref.compare(V1, F1)            # dict, see below
    # or one-off: compare(V0, F0, V1, F1)

Definitions (all distances are unsigned point-to-surface distances and are divided by
the bounding-box diagonal of the original's *referenced* vertices; docs/evaluation.md):

* Sampling: ``n_samples`` points on each surface (default 200 000), area-weighted
  (face chosen with probability proportional to its area, then a uniform point in the
  triangle), from ``numpy.random.default_rng(seed)`` for the original and ``seed + 1`` for
  the simplified mesh (:func:`lodkit.evaluate.sample_surface`), so results are
  reproducible. Zero-area faces are never sampled.
* ``d_fwd``: for each sample on the original, distance to the simplified surface;
  ``d_bwd``: for each sample on the simplified surface, distance to the original
  (closest triangle from ``open3d.t.geometry.RaycastingScene``, the distance to it in
  double precision; a sample on a triangle both meshes have is at distance 0).
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
  normal of the original face closest to the output face's centroid;
* ``flipped_faces_near``: the subset of those whose centroid lies within
  ``near_factor`` (default 0.1) x the face's longest edge of the original -- i.e. the
  face sits on the original surface, so the disagreement cannot come from the closest
  point landing on the far side of a thin part;
* ``flipped_area_frac``: area of flipped faces / total output area.
* ``flipped_faces_matched``: output faces whose unit normal opposes, on average, the normals
  of the input surface they stand for: the original's samples (``n_samples``, area-weighted,
  seed ``seed + 2``) are matched to their closest output face (the correspondence of
  ``d_fwd``), and a face is flipped when the mean dot product of its normal with the normals
  of the input faces its matched samples lie on is negative; a face no sample is matched to
  falls back to the rule of ``flipped_faces``. On a thin sheet (a plate 1 % as thick as it
  is wide) the original face closest to an output face's centroid can lie on the sheet's
  other side: a top face placed a little below the mid-plane still faces up, stands for the
  top samples around it and is closer to the top than to the bottom of the *output*, yet
  ``flipped_faces`` counts it. ``flipped_faces_matched`` judges a face by what it replaces
  (bench/cad.py reports it; docs/algorithms.md, issue 17, has the comparison).

Degenerate output faces (zero area) have no normal and are never counted as flipped.

Attribute fidelity (used by bench/fidelity.py and bench/pictures.py; see each docstring):

* ``color_error``: sampled colour difference between original and simplified per-vertex
  colours (samples on the original, closest point on the simplified surface);
* ``crease_edges`` / ``crease_vertices``: edges with a dihedral angle above a threshold,
  and how many output vertices lie within a distance of one;
* ``seam_check``: whether the copies of a UV-seam vertex stay together after simplification.
"""
from __future__ import annotations

import numpy as np

from lodkit.evaluate import Evaluator, closest_points, face_normals
from lodkit.evaluate import sample_surface as _sample_surface

__all__ = ["Reference", "compare", "sample_surface", "sample_surface_bary", "edge_counts", "validity", "face_normals",
           "closest_points", "color_error", "crease_edges", "segment_distance", "crease_vertices", "seam_check"]

DEFAULT_SAMPLES = 200_000
DEFAULT_SEED = 20240521


def sample_surface_bary(V: np.ndarray, F: np.ndarray, n: int,
                        seed: int = DEFAULT_SEED) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``n`` area-weighted uniform samples: (points (n,3), face index (n,), barycentric weights (n,3)).

    ``points[i] = sum_k bary[i, k] * V[F[face[i], k]]`` (:func:`lodkit.evaluate.sample_surface`).
    """
    return _sample_surface(V, F, n, seed)


def sample_surface(V: np.ndarray, F: np.ndarray, n: int, seed: int = DEFAULT_SEED) -> np.ndarray:
    """``n`` area-weighted uniform samples on the triangle surface (float64 (n,3))."""
    return _sample_surface(V, F, n, seed)[0]


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
    """The original mesh, prepared once: samples, raycasting scene, normals, scale
    (a :class:`lodkit.evaluate.Evaluator`)."""

    def __init__(self, V: np.ndarray, F: np.ndarray, n_samples: int = DEFAULT_SAMPLES,
                 seed: int = DEFAULT_SEED):
        self.V = np.asarray(V, dtype=np.float64)
        self.F = np.asarray(F, dtype=np.int64)
        self.n_samples = int(n_samples)
        self.seed = int(seed)
        self.evaluator = Evaluator((self.V, self.F), self.n_samples, self.seed)
        self.diag = self.evaluator.diagonal
        self.normals, _ = face_normals(self.V, self.F)
        self.validity = validity(self.V, self.F)
        self._flip_samples = None

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
        out.update(self.evaluator.distances((V, F)).as_dict())
        out.update(self.flipped(V, F, near_factor))
        return out

    def flipped(self, V: np.ndarray, F: np.ndarray, near_factor: float = 0.1) -> dict:
        n_out, area = face_normals(V, F)
        ok = area > 0
        cent = V[F].mean(axis=1)
        closest, prim, _ = closest_points(self.V, self.F, cent)
        dist = np.linalg.norm(closest - cent, axis=1)
        dots = np.einsum("ij,ij->i", n_out, self.normals[prim])
        flipped = ok & (dots < 0)
        a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
        longest = np.max(np.stack([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1),
                                   np.linalg.norm(a - c, axis=1)]), axis=0)
        near = flipped & (dist <= near_factor * longest)
        if self._flip_samples is None:
            P, face, _ = sample_surface_bary(self.V, self.F, self.n_samples, self.seed + 2)
            self._flip_samples = (P, self.normals[face])
        P, normal = self._flip_samples
        _, out_face, _ = closest_points(V, F, P)
        agree = np.einsum("ij,ij->i", n_out[out_face], normal)
        total = np.bincount(out_face, weights=agree, minlength=len(F))
        matched = np.bincount(out_face, minlength=len(F)) > 0
        flipped_matched = ok & np.where(matched, total < 0, dots < 0)
        return {
            "flipped_faces": int(flipped.sum()),
            "flipped_faces_near": int(near.sum()),
            "flipped_area_frac": float(area[flipped].sum() / area.sum()),
            "flipped_faces_matched": int(flipped_matched.sum()),
        }


def compare(V0, F0, V1, F1, n_samples: int = DEFAULT_SAMPLES, seed: int = DEFAULT_SEED) -> dict:
    """One-off: error and validity of (V1, F1) against the original (V0, F0)."""
    return Reference(V0, F0, n_samples, seed).compare(V1, F1)


# --------------------------------------------------------------------------------------
# attribute fidelity: colour error, crease vertices, UV seams (bench/fidelity.py)
# --------------------------------------------------------------------------------------

def color_error(V0: np.ndarray, F0: np.ndarray, C0: np.ndarray, V1: np.ndarray, F1: np.ndarray,
                C1: np.ndarray, n_samples: int = DEFAULT_SAMPLES, seed: int = DEFAULT_SEED,
                scale: float = 255.0) -> dict:
    """Sampled colour error of the simplified (V1, F1, C1) against the original (V0, F0, C0).

    ``n_samples`` area-weighted points on the original (seeded, as for the geometric error);
    the original's colour there is the barycentric interpolation of its per-vertex colours
    ``C0``; the simplified colour is the interpolation of ``C1`` at the closest point of the
    simplified surface (:func:`lodkit.evaluate.closest_points`). Colours are compared per
    channel (RGB; an alpha column is ignored), in units of ``scale`` (255: 8-bit RGB units
    for colours in [0, 1]).

    Returns ``rms`` (sqrt of the mean over samples and channels of the squared difference),
    ``mean_abs`` (mean absolute difference over samples and channels), ``p99`` (99th
    percentile of the per-sample largest channel difference), ``max`` and ``n_samples``.
    A constant offset ``c`` added to every channel gives rms = mean_abs = max = c.
    """
    V0, V1 = np.asarray(V0, dtype=np.float64), np.asarray(V1, dtype=np.float64)
    F0, F1 = np.asarray(F0, dtype=np.int64), np.asarray(F1, dtype=np.int64)
    C0 = np.asarray(C0, dtype=np.float64)[:, :3]
    C1 = np.asarray(C1, dtype=np.float64)[:, :3]
    P, face0, w0 = sample_surface_bary(V0, F0, n_samples, seed)
    col0 = np.einsum("nk,nkc->nc", w0, C0[F0[face0]])
    _, face1, w1 = closest_points(V1, F1, P)
    col1 = np.einsum("nk,nkc->nc", w1, C1[F1[face1]])
    d = (col1 - col0) * scale
    per_sample = np.abs(d).max(axis=1)
    return {
        "rms": float(np.sqrt(np.mean(d * d))),
        "mean_abs": float(np.mean(np.abs(d))),
        "p99": float(np.percentile(per_sample, 99)),
        "max": float(per_sample.max()),
        "n_samples": int(n_samples),
    }


def crease_edges(V: np.ndarray, F: np.ndarray, angle_deg: float = 30.0) -> tuple[np.ndarray, np.ndarray]:
    """Edges whose dihedral angle exceeds ``angle_deg``: (edges (k,2) vertex pairs, angles in degrees (k,)).

    The dihedral angle of an edge with exactly two faces is the angle between the two face
    normals (0 = flat). Boundary and non-manifold edges, and edges next to a zero-area face,
    are never creases.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    n, _ = face_normals(V, F)
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    fid = np.tile(np.arange(len(F)), 3)
    e.sort(axis=1)
    key = e[:, 0] * (int(F.max()) + 1) + e[:, 1]
    order = np.argsort(key, kind="stable")
    key, e, fid = key[order], e[order], fid[order]
    uniq, start, counts = np.unique(key, return_index=True, return_counts=True)
    two = counts == 2
    i0 = start[two]
    f0, f1 = fid[i0], fid[i0 + 1]
    ok = (np.linalg.norm(n[f0], axis=1) > 0) & (np.linalg.norm(n[f1], axis=1) > 0)
    cosang = np.clip(np.einsum("ij,ij->i", n[f0], n[f1]), -1.0, 1.0)
    ang = np.degrees(np.arccos(cosang))
    sel = ok & (ang > angle_deg)
    return e[i0[sel]], ang[sel]


def segment_distance(P: np.ndarray, A: np.ndarray, B: np.ndarray, chunk: int = 1 << 21) -> np.ndarray:
    """Distance from each point of P (n,3) to the nearest of the segments A[j]-B[j] (k,3): (n,).

    Exact point-to-segment distance, brute force over all pairs in chunks of about
    ``chunk`` pairs (vectorised; fine for thousands of points against thousands of segments).
    """
    P = np.asarray(P, dtype=np.float64)
    A = np.asarray(A, dtype=np.float64)
    B = np.asarray(B, dtype=np.float64)
    if len(A) == 0:
        return np.full(len(P), np.inf)
    D = B - A
    dd = np.einsum("ij,ij->i", D, D)
    dd_safe = np.where(dd > 0, dd, 1.0)
    out = np.empty(len(P))
    step = max(1, chunk // len(A))
    for s in range(0, len(P), step):
        Q = P[s:s + step, None, :] - A[None, :, :]                     # (c, k, 3)
        t = np.clip(np.einsum("ckj,kj->ck", Q, D) / dd_safe, 0.0, 1.0)
        t = np.where(dd > 0, t, 0.0)
        R = Q - t[..., None] * D[None, :, :]
        out[s:s + step] = np.sqrt(np.einsum("ckj,ckj->ck", R, R).min(axis=1))
    return out


def crease_vertices(V_in: np.ndarray, F_in: np.ndarray, V_out: np.ndarray, F_out: np.ndarray | None = None,
                    angle_deg: float = 30.0, tol_frac: float = 0.005) -> dict:
    """How many output vertices lie near the input's creases.

    Crease edges: input edges with dihedral angle > ``angle_deg`` (:func:`crease_edges`).
    A vertex is near a crease when its distance to the nearest crease segment is at most
    ``tol_frac`` x the bounding-box diagonal of the input's referenced vertices. Only
    vertices referenced by ``F_out`` are counted when it is given.

    Returns ``near`` (count), ``vertices`` (vertices counted), ``fraction`` (near / vertices),
    ``crease_edges`` and ``crease_length`` (summed length of the crease edges, in model units),
    ``tol`` (the distance used, in model units).
    """
    V_in = np.asarray(V_in, dtype=np.float64)
    F_in = np.asarray(F_in, dtype=np.int64)
    V_out = np.asarray(V_out, dtype=np.float64)
    used_in = V_in[np.unique(F_in)]
    diag = float(np.linalg.norm(used_in.max(axis=0) - used_in.min(axis=0)))
    tol = tol_frac * diag
    E, _ = crease_edges(V_in, F_in, angle_deg)
    P = V_out if F_out is None else V_out[np.unique(np.asarray(F_out, dtype=np.int64))]
    d = segment_distance(P, V_in[E[:, 0]], V_in[E[:, 1]]) if len(E) else np.full(len(P), np.inf)
    near = int((d <= tol).sum())
    return {
        "near": near,
        "vertices": int(len(P)),
        "fraction": near / len(P) if len(P) else 0.0,
        "crease_edges": int(len(E)),
        "crease_length": float(np.linalg.norm(V_in[E[:, 0]] - V_in[E[:, 1]], axis=1).sum()) if len(E) else 0.0,
        "tol": tol,
    }


def _edge_face_counts_keyed(F: np.ndarray, label: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct undirected edges of F after mapping vertices through ``label`` (keys, face counts).

    Edges whose two ends get the same label (collapsed in label space) are left out.
    """
    L = label[np.asarray(F, dtype=np.int64)]
    e = np.concatenate([L[:, [0, 1]], L[:, [1, 2]], L[:, [2, 0]]])
    e = e[e[:, 0] != e[:, 1]]
    e.sort(axis=1)
    key = e[:, 0] * (int(label.max()) + 1) + e[:, 1]
    return np.unique(key, return_counts=True)


def seam_check(V_in: np.ndarray, F_in: np.ndarray, vertex_map: np.ndarray, V_out: np.ndarray,
               F_out: np.ndarray, uv_in: np.ndarray | None = None, uv_out: np.ndarray | None = None,
               tol_frac: float = 1e-9, uv_tol: float = 1e-6) -> dict:
    """Are the copies of a split vertex (a UV seam) still together after simplification?

    The input mesh carries seams as several vertices at one position (copies; one per UV
    chart that meets there). ``vertex_map[i]`` is the input vertex output vertex ``i`` comes
    from; its *group* is the input position that input vertex has. Reported:

    * ``seam_positions_in``: input positions with 2 or more referenced copies;
      ``seam_vertices_in``: the copies; ``seam_vertices_out``: output vertices whose group
      is such a position (seam vertices kept);
    * ``split_groups`` / ``max_gap``: groups with 2 or more output copies that no longer
      coincide (gap > ``tol_frac`` x input bbox diagonal), and the largest distance between two
      copies of one group over all groups, as a fraction of the input bbox diagonal;
    * ``orphans``: groups that kept some but not all of their copies (one side of the seam
      collapsed a seam vertex away, the other did not: a T-junction, so a crack unless the
      three points are collinear);
    * ``open_edges_out`` / ``open_edges_in``: edges with exactly one face when vertices are
      identified by group (the surface glued along its seams); a crack along a seam shows
      up as open edges the input did not have (``new_open_edges`` = out - in, for a closed
      input this counts every edge of every crack);
    * ``uv_kept`` / ``uv_changed``: output seam vertices whose uv equals (within ``uv_tol``)
      / differs from the uv of the very input copy they come from (only with uvs given);
    * ``cracks``: split_groups + orphans (0 = the seams are intact).
    """
    V_in = np.asarray(V_in, dtype=np.float64)
    F_in = np.asarray(F_in, dtype=np.int64)
    V_out = np.asarray(V_out, dtype=np.float64)
    vm = np.asarray(vertex_map, dtype=np.int64)
    used_in = np.zeros(len(V_in), dtype=bool)
    used_in[F_in.ravel()] = True
    diag = float(np.linalg.norm(V_in[used_in].max(axis=0) - V_in[used_in].min(axis=0)))
    _, group = np.unique(V_in + 0.0, axis=0, return_inverse=True)
    group = group.reshape(-1)
    n_groups = int(group.max()) + 1
    size_in = np.bincount(group[used_in], minlength=n_groups)
    seam_group = size_in >= 2

    used_out = np.zeros(len(V_out), dtype=bool)
    used_out[np.asarray(F_out, dtype=np.int64).ravel()] = True
    g_out = group[vm]
    size_out = np.bincount(g_out[used_out], minlength=n_groups)
    seam_out = used_out & seam_group[g_out]

    # largest pairwise distance between the output copies of each group
    idx = np.flatnonzero(seam_out)
    order = idx[np.argsort(g_out[idx], kind="stable")]
    gs = g_out[order]
    gap = np.zeros(n_groups)
    for s in range(1, int(size_out.max(initial=1))):
        same = gs[s:] == gs[:-s]
        if not same.any():
            break
        a, b = order[:-s][same], order[s:][same]
        dist = np.linalg.norm(V_out[a] - V_out[b], axis=1)
        np.maximum.at(gap, gs[:-s][same], dist)
    split = int((gap > tol_frac * diag).sum())
    orphans = int((seam_group & (size_out > 0) & (size_out < size_in)).sum())

    _, cnt_in = _edge_face_counts_keyed(F_in, group)
    _, cnt_out = _edge_face_counts_keyed(np.asarray(F_out, dtype=np.int64), g_out)
    out = {
        "seam_positions_in": int(seam_group.sum()),
        "seam_vertices_in": int(size_in[seam_group].sum()),
        "seam_vertices_out": int(seam_out.sum()),
        "seam_positions_out": int((seam_group & (size_out > 0)).sum()),
        "split_groups": split,
        "max_gap": float(gap.max(initial=0.0) / diag),
        "orphans": orphans,
        "open_edges_in": int((cnt_in == 1).sum()),
        "open_edges_out": int((cnt_out == 1).sum()),
        "cracks": split + orphans,
    }
    out["new_open_edges"] = out["open_edges_out"] - out["open_edges_in"]
    if uv_in is not None and uv_out is not None:
        if len(idx):
            duv = np.abs(np.asarray(uv_out, dtype=np.float64)[idx]
                         - np.asarray(uv_in, dtype=np.float64)[vm[idx]]).max(axis=1)
        else:
            duv = np.zeros(0)
        out["uv_kept"] = int((duv <= uv_tol).sum())
        out["uv_changed"] = int((duv > uv_tol).sum())
        out["uv_max_change"] = float(duv.max(initial=0.0))
    return out


if __name__ == "__main__":
    import argparse
    import json

    ap = argparse.ArgumentParser(description="Metro-style error between two mesh files (read with Open3D).")
    ap.add_argument("original")
    ap.add_argument("simplified")
    ap.add_argument("--samples", type=int, default=DEFAULT_SAMPLES)
    ap.add_argument("--seed", type=int, default=DEFAULT_SEED)
    args = ap.parse_args()
    import open3d as o3d
    m0 = o3d.io.read_triangle_mesh(args.original)
    m1 = o3d.io.read_triangle_mesh(args.simplified)
    r = compare(np.asarray(m0.vertices), np.asarray(m0.triangles), np.asarray(m1.vertices),
                np.asarray(m1.triangles), args.samples, args.seed)
    print(json.dumps(r, indent=2))
