"""Point-cloud curvature by plane fitting (Wang et al. 2011, after Kodani et al.).

For each point p with neighbour set N (its ``k`` nearest other points, or all other points
within ``radius``)::

    c = (1/|N|) sum_{q in N} q                     centroid                      (eq. 1)
    C = sum_{q in N} (q - c)(q - c)^T              covariance                    (eq. 2)
    e0 = eigenvector of C's smallest eigenvalue    normal of the fitted plane
    d = |e0 . (p - c)|                             p's distance to that plane    (eq. 3)
    mu = (1/|N|) sum_{q in N} |q - p|              mean distance to the neighbours
    k = 2 d / mu^2                                 curvature                     (eq. 4)

The last line is the circle through p with p's height ``d`` above the plane and chord
half-width ``mu``: from s^2 = mu^2 - d^2 = r^2 - (r - d)^2, 1/r = 2d/mu^2.  Normalised by the
largest value, w = k / k_max lies in [0, 1] (eq. 5).

Choices made where the paper is silent (docs/metrics/curvature.md says why):

* p itself is **not** in N: the plane is fitted to the neighbours and p's distance to it is
  measured (with p in N the centroid moves toward p and d shrinks by k/(k+1)).
* Coincident points are merged first: every copy of a position gets the curvature of that
  position, computed from ``k`` *distinct* neighbours.
* Where the plane is not determined -- fewer than 3 distinct neighbours, or all of them on
  one line (second-smallest eigenvalue <= 1e-10 x the largest) -- the curvature is 0.
* Neighbours come from Open3D's KD-tree (``open3d.core.nns.NearestNeighborSearch``), searched
  in float64, in a spatially sorted (Morton) order and in chunks, so memory stays bounded
  (about 1 kB per point of a chunk at k = 16) and the per-point work is numpy-vectorised.
"""
from __future__ import annotations

import numpy as np

from .deps import open3d as import_open3d
from .errors import MeshError, OptionError

__all__ = ["point_curvature", "normalized_curvature", "DEFAULT_K"]

#: default neighbourhood size: about the 2-ring of a vertex of a regular triangle mesh
#: (1-ring 6, 2-ring 18); small enough to keep a crease's response narrow
DEFAULT_K = 16

# queries per chunk: (chunk, k, 3) float64 gathers stay in the tens of MB
_CHUNK = 1 << 16
# the plane is undetermined when the neighbours are (nearly) collinear
_COLLINEAR = 1e-10


def point_curvature(points, k: int = DEFAULT_K, radius: float | None = None, *,
                    normalize: bool = False) -> np.ndarray:
    """Curvature k_i = 2 d / mu^2 of every point of a cloud (Wang et al., eqs. 1-4).

    points    : (n, 3) float coordinates (finite)
    k         : number of nearest neighbours (other than the point and its copies); used
                when ``radius`` is None
    radius    : if given, the neighbours are all other points within this distance (same
                units as the points) instead of the k nearest
    normalize : return w_i = k_i / max k (eq. 5, in [0, 1]; all 0 if the max is 0)

    Returns (n,) float64: curvature in 1 / (the points' units), >= 0, never NaN.  Points
    whose neighbourhood does not determine a plane (fewer than 3 distinct neighbours, or
    collinear ones) get 0.  Raises MeshError for a bad array, OptionError for a bad k or
    radius.
    """
    pts = _check_points(points)
    k = _check_k(k)
    if radius is not None:
        radius = _check_radius(radius)
    n = pts.shape[0]
    out = np.zeros(n, dtype=np.float64)
    if n == 0:
        return out
    unique, inverse = _merge_copies(pts)
    if unique.shape[0] >= 3:
        curv = _curvature_unique(unique, k, radius)
        out = curv[inverse]
    if normalize:
        out = normalized_curvature(out)
    return out


def normalized_curvature(curvature) -> np.ndarray:
    """w_i = k_i / max_j k_j (eq. 5): values in [0, 1]; all zeros when every k_i is 0."""
    arr = np.asarray(curvature, dtype=np.float64)
    top = float(arr.max()) if arr.size else 0.0
    if not top > 0.0:
        return np.zeros_like(arr)
    return arr / top


# ---------------------------------------------------------------------- validation
def _check_points(points) -> np.ndarray:
    try:
        pts = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise MeshError(f"points must be numeric: {exc}") from None
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise MeshError(f"points must have shape (n, 3), got {pts.shape}")
    bad = ~np.isfinite(pts).all(axis=1)
    if bad.any():
        rows = np.flatnonzero(bad)
        raise MeshError(f"points has {rows.size} row(s) with NaN or inf values "
                        f"(first at row {rows[0]}: {pts[rows[0]].tolist()})")
    return pts


def _check_k(k) -> int:
    if isinstance(k, (bool, np.bool_)) or not isinstance(k, (int, np.integer)) or k < 3:
        raise OptionError(f"k must be an integer >= 3 (a plane needs 3 neighbours), got {k!r}")
    return int(k)


def _check_radius(radius) -> float:
    try:
        r = float(radius)
    except (TypeError, ValueError):
        raise OptionError(f"radius must be a number > 0 or None, got {radius!r}") from None
    if isinstance(radius, (bool, np.bool_)) or not (r > 0.0 and np.isfinite(r)):
        raise OptionError(f"radius must be a finite number > 0 or None, got {radius!r}")
    return r


# ---------------------------------------------------------------------- the pipeline
def _merge_copies(pts: np.ndarray):
    """Distinct positions, in Morton order (good locality for the KD-tree queries), and for
    each input point the row of its position."""
    n = pts.shape[0]
    # copies of a position have equal bits (+ 0.0 turns -0.0 into 0.0): sort by a 64-bit
    # hash of the bits, then compare neighbours in that order exactly.  Two distinct rows
    # with equal hashes stay distinct; a copy parted from its twin by such a collision (odds
    # about n / 2^64) would only stay a separate point at distance 0, which is harmless.
    bits = np.ascontiguousarray(pts + 0.0).view(np.uint64)
    h = bits[:, 0] * np.uint64(0x9E3779B97F4A7C15)
    h ^= bits[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F)
    h ^= bits[:, 2] * np.uint64(0x165667B19E3779F9)
    h ^= h >> np.uint64(31)
    order = np.argsort(h)
    s = pts[order]
    new = np.empty(n, dtype=bool)
    new[0] = True
    np.any(s[1:] != s[:-1], axis=1, out=new[1:])
    group = np.cumsum(new) - 1
    unique = s[new]
    # Morton order of the distinct points
    lo = unique.min(axis=0)
    extent = float((unique.max(axis=0) - lo).max())
    if extent > 0.0:
        cells = np.minimum((unique - lo) * (1023.0 / extent), 1023.0).astype(np.int64)
    else:
        cells = np.zeros(unique.shape, dtype=np.int64)
    code = _spread_bits(cells[:, 0]) | (_spread_bits(cells[:, 1]) << 1) | (_spread_bits(cells[:, 2]) << 2)
    morton = np.argsort(code, kind="stable")
    rank = np.empty_like(morton)
    rank[morton] = np.arange(morton.size)
    inverse = np.empty(n, dtype=np.int64)
    inverse[order] = rank[group]
    return np.ascontiguousarray(unique[morton]), inverse


def _spread_bits(x: np.ndarray) -> np.ndarray:
    """Interleave two zero bits after each of the 10 low bits (3D Morton code)."""
    x = x & 0x3FF
    x = (x | (x << 16)) & 0x30000FF
    x = (x | (x << 8)) & 0x300F00F
    x = (x | (x << 4)) & 0x30C30C3
    x = (x | (x << 2)) & 0x9249249
    return x


def _curvature_unique(pts: np.ndarray, k: int, radius: float | None) -> np.ndarray:
    """Curvature of distinct points (n >= 3)."""
    o3d = import_open3d()  # lazily: importing Open3D takes a second or two

    n = pts.shape[0]
    # centre the cloud: the KD-tree's arithmetic then works on small numbers
    centred = pts - 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    centred = np.ascontiguousarray(centred)
    data = o3d.core.Tensor(centred)
    nns = o3d.core.nns.NearestNeighborSearch(data)
    out = np.zeros(n, dtype=np.float64)
    if radius is None:
        k_eff = min(k, n - 1)
        nns.knn_index()
        for start in range(0, n, _CHUNK):
            stop = min(start + _CHUNK, n)
            idx, _ = nns.knn_search(o3d.core.Tensor(centred[start:stop]), k_eff + 1)
            idx = _drop_self(idx.numpy(), start)
            out[start:stop] = _knn_curvature(centred, centred[start:stop], idx)
    else:
        nns.fixed_radius_index(radius)
        for start in range(0, n, _CHUNK):
            stop = min(start + _CHUNK, n)
            idx, splits = _radius_search(nns, o3d, centred[start:stop], radius)
            out[start:stop] = _radius_curvature(centred, centred[start:stop], start, idx, splits)
    return out


def _drop_self(idx: np.ndarray, start: int) -> np.ndarray:
    """(m, k+1) neighbour rows including the query point -> (m, k) without it (or without
    the farthest, if the query point is not in its row)."""
    m, kk = idx.shape
    me = np.arange(start, start + m)[:, None]
    is_me = idx == me
    col = np.where(is_me.any(axis=1), is_me.argmax(axis=1), kk - 1)
    keep = np.arange(kk)[None, :] != col[:, None]
    return idx[keep].reshape(m, kk - 1)


def _radius_search(nns, o3d, queries, radius):
    """(indices, splits) of a fixed-radius search: CSR rows, the query point included."""
    res = [r.numpy() for r in nns.fixed_radius_search(o3d.core.Tensor(queries), radius)]
    # Open3D's docstring gives the order (indices, splits, distances), its example and
    # version 0.20 (indices, distances, splits): indices come first either way, and the
    # splits are the other integer array
    ints = [a for a in res if a.dtype.kind in "iu"]
    return ints[0], ints[1]


def _knn_curvature(pts: np.ndarray, queries: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Equal-size neighbourhoods: (m, k) indices into pts."""
    nb = pts[idx]                                      # (m, k, 3)
    c = nb.mean(axis=1)                                # eq. 1
    dev = nb - c[:, None, :]
    cov = np.empty((idx.shape[0], 3, 3))               # eq. 2, one entry at a time (fast)
    for i in range(3):
        for j in range(i, 3):
            cov[:, i, j] = cov[:, j, i] = np.einsum("mk,mk->m", dev[:, :, i], dev[:, :, j])
    diff = nb - queries[:, None, :]
    mu = np.sqrt(np.einsum("mki,mki->mk", diff, diff)).mean(axis=1)
    count = np.full(queries.shape[0], idx.shape[1])
    return _finish(queries, c, cov, mu, count)


def _radius_curvature(pts, queries, start, idx, splits) -> np.ndarray:
    """Variable-size neighbourhoods: CSR (idx, splits) of the queries, self included."""
    m = queries.shape[0]
    owner = np.repeat(np.arange(m), np.diff(splits))
    keep = idx != owner + start                       # p is not its own neighbour
    idx, owner = idx[keep], owner[keep]
    count = np.bincount(owner, minlength=m)
    safe = np.maximum(count, 1).astype(np.float64)
    nb = pts[idx]
    c = np.stack([np.bincount(owner, nb[:, i], minlength=m) for i in range(3)], axis=1) / safe[:, None]
    dev = nb - c[owner]
    cov = np.empty((m, 3, 3))
    for i in range(3):
        for j in range(i, 3):
            cov[:, i, j] = cov[:, j, i] = np.bincount(owner, dev[:, i] * dev[:, j], minlength=m)
    diff = nb - queries[owner]
    mu = np.bincount(owner, np.sqrt(np.einsum("ki,ki->k", diff, diff)), minlength=m) / safe
    return _finish(queries, c, cov, mu, count)


def _finish(queries, c, cov, mu, count) -> np.ndarray:
    """Eqs. 3-4 from the fitted planes, with 0 where the plane is undetermined."""
    lam, e0 = _smallest_eigenpairs(cov)
    d = np.abs(np.einsum("mi,mi->m", e0, queries - c))   # eq. 3
    ok = (count >= 3) & (mu > 0.0) & (lam[:, 1] > _COLLINEAR * lam[:, 2])
    out = np.zeros(queries.shape[0])
    out[ok] = 2.0 * d[ok] / (mu[ok] * mu[ok])         # eq. 4
    return out


def _smallest_eigenpairs(cov: np.ndarray):
    """Eigenvalues (m, 3), ascending, and the unit eigenvector of the smallest (m, 3) of
    symmetric 3x3 matrices.

    Closed form (about 5x faster than a batched ``numpy.linalg.eigh``): the eigenvalues by
    the trigonometric solution of the characteristic cubic, the eigenvector as the longest
    cross product of two rows of C - lambda_0 I.  An error of delta in lambda_0 tilts that
    vector by about delta / (lambda_1 - lambda_0), so rows whose two smallest eigenvalues
    are within 1e-6 of the largest of each other (where the vector is ill-defined and the
    closed form loses digits) go to ``eigh`` instead.
    """
    m = cov.shape[0]
    trace = cov[:, 0, 0] + cov[:, 1, 1] + cov[:, 2, 2]
    scale = np.where(trace > 0.0, trace, 1.0)
    a00, a11, a22 = cov[:, 0, 0] / scale, cov[:, 1, 1] / scale, cov[:, 2, 2] / scale
    a01, a02, a12 = cov[:, 0, 1] / scale, cov[:, 0, 2] / scale, cov[:, 1, 2] / scale
    q = (a00 + a11 + a22) / 3.0                       # trace 1: well-scaled numbers
    b00, b11, b22 = a00 - q, a11 - q, a22 - q
    off = a01 * a01 + a02 * a02 + a12 * a12
    p = np.sqrt((b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * off) / 6.0)
    det = (b00 * (b11 * b22 - a12 * a12) - a01 * (a01 * b22 - a12 * a02)
           + a02 * (a01 * a12 - b11 * a02))
    safe_p = np.where(p > 0.0, p, 1.0)
    phi = np.arccos(np.clip(0.5 * det / (safe_p * safe_p * safe_p), -1.0, 1.0)) / 3.0
    lam2 = q + 2.0 * p * np.cos(phi)
    lam0 = q + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0)
    lam1 = 3.0 * q - lam0 - lam2
    lam = np.stack([lam0, lam1, lam2], axis=1)
    # rows of C - lambda_0 I: (x0 a01 a02), (a01 x1 a12), (a02 a12 x2)
    x0, x1, x2 = a00 - lam0, a11 - lam0, a22 - lam0
    crosses = np.empty((m, 3, 3))
    crosses[:, 0] = np.stack([a01 * a12 - a02 * x1, a02 * a01 - x0 * a12, x0 * x1 - a01 * a01], axis=1)
    crosses[:, 1] = np.stack([a01 * x2 - a02 * a12, a02 * a02 - x0 * x2, x0 * a12 - a01 * a02], axis=1)
    crosses[:, 2] = np.stack([x1 * x2 - a12 * a12, a12 * a02 - a01 * x2, a01 * a12 - x1 * a02], axis=1)
    norms = np.einsum("mij,mij->mi", crosses, crosses)
    best = norms.argmax(axis=1)
    rows = np.arange(m)
    vec = crosses[rows, best]
    length = np.sqrt(norms[rows, best])
    hard = ~((lam1 - lam0) > 1e-6 * np.abs(lam2)) | ~(length > 0.0)
    vec /= np.where(length > 0.0, length, 1.0)[:, None]
    if hard.any():
        w, v = np.linalg.eigh(cov[hard] / scale[hard, None, None])
        lam[hard] = w
        vec[hard] = v[:, :, 0]
    return lam * scale[:, None], vec
