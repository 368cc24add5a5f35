"""Pair contraction (Garland and Heckbert 1997, "virtual pairs"): vertices closer than a
threshold that share no edge merge, so separate parts join and small gaps close.

``simplify(..., pair_threshold=T)`` calls :func:`contract_pairs` before it builds the
half-edge arrays; the edge collapses then run on the welded mesh as usual.  The steps:

1. pairs:     every two used vertices closer than T (scipy's KD-tree), minus those joined by
              an edge (the edge collapses handle them), minus attribute-seam copies
              (coincident vertices whose normals / colours / uvs differ) and pairs of two
              locked vertices
2. contract:  a lazy priority queue in quadric-cost order; each merge sums the two
              area-weighted face quadrics and puts the vertex at their minimiser (the best of
              midpoint and the two ends when the 3x3 system is ill-conditioned); a popped
              pair whose ends have merged since it was costed is re-costed and requeued, and
              dropped once its ends are T or more apart
3. weld:      faces re-indexed to each merged group's vertex; faces with a repeated vertex
              dropped; faces on one vertex triple cancel in opposite-orientation pairs (two
              surfaces pressed together: the membrane between the joined parts goes), one of
              the rest is kept

docs/clustering.md ("Pair contraction") compares this with Garland's interleaved queue.
"""
from __future__ import annotations

import heapq
import math

import numpy as np

from .errors import OptionError
from .geometry import box_diagonal, plane_quadrics
from .mesh import Mesh

__all__ = ["contract_pairs"]

# a 3x3 quadric whose determinant is below this fraction of trace^3 / 27 (the determinant of
# the isotropic matrix of the same trace) is ill-conditioned: place on the segment instead
_DET_TOLERANCE = 1e-9


def contract_pairs(mesh: Mesh, threshold, *, absolute: bool = False, locked: np.ndarray | None = None):
    """Merge the close vertex pairs of ``mesh`` (see the module docstring).

    threshold : the distance T, a fraction of the bbox diagonal (model units with ``absolute``);
                pairs strictly closer than T merge, so T = 0 merges nothing
    locked    : optional (n,) bool mask; a locked vertex keeps its position (a pair of two
                locked vertices never merges)

    Returns (welded Mesh with the same vertex indexing -- merged vertices other than each
    group's representative are left unreferenced --, (k,) int64 index of each kept face in
    the input, report dict).
    """
    if isinstance(threshold, bool):
        raise OptionError(f"pair_threshold must be a number, got {threshold!r}")
    try:
        t = float(threshold)
    except (TypeError, ValueError):
        raise OptionError(f"pair_threshold must be a number, got {threshold!r}") from None
    if not (t >= 0.0 and math.isfinite(t)):
        raise OptionError(f"pair_threshold must be a finite number >= 0, got {threshold!r}")
    faces = mesh.faces
    n = mesh.n_vertices
    used = np.zeros(n, dtype=bool)
    used[faces.reshape(-1)] = True
    ids = np.flatnonzero(used)
    pts = mesh.vertices[ids]
    lo = np.array([pts[:, k].min() for k in range(3)]) if ids.size else np.zeros(3)
    hi = np.array([pts[:, k].max() for k in range(3)]) if ids.size else np.zeros(3)
    center, scale = 0.5 * lo + 0.5 * hi, box_diagonal(lo, hi)
    t_model = t if absolute else t * scale
    report = {"threshold": t_model, "candidate_pairs": 0, "merged": 0, "skipped_seams": 0,
              "membrane_faces_removed": 0, "duplicate_faces_removed": 0, "collapsed_faces_removed": 0}
    all_faces = np.arange(faces.shape[0], dtype=np.int64)
    if not (t_model > 0.0 and scale > 0.0) or ids.size < 2:
        return mesh, all_faces, report
    if 1e-50 < scale < 1e50:
        pairs = _close_pairs(pts, ids, t_model)
    else:       # squared distances would under- or overflow: search in normalised coordinates
        pairs = _close_pairs((pts - center) / scale, ids, t_model / scale)
    pairs = _drop_edges(pairs, faces, n)
    pairs, n_seams = _drop_seams(pairs, mesh)
    fixed = np.zeros(n, dtype=bool) if locked is None else np.asarray(locked, dtype=bool)
    pairs = pairs[~(fixed[pairs[:, 0]] & fixed[pairs[:, 1]])]
    report["candidate_pairs"] = int(pairs.shape[0])
    report["skipped_seams"] = n_seams
    if pairs.shape[0] == 0:
        return mesh, all_faces, report
    # normalised coordinates, as the core's, so costs and conditioning do not depend on units
    P = (mesh.vertices - center) / scale
    Q = plane_quadrics(P, faces, n)
    root, pos, origin = _contract(pairs, Q, P, fixed, t_model / scale)
    merged = root != np.arange(n)
    report["merged"] = int(np.count_nonzero(merged))
    if not merged.any():
        return mesh, all_faces, report
    # faces that repeat an index in the input pass through, for prepare() to drop and count
    bad = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    good = np.flatnonzero(~bad)
    new_faces, kept, counts = _weld_faces(faces[good], root)
    kept = good[kept]
    if bad.any():
        kept = np.sort(np.concatenate([kept, np.flatnonzero(bad)]))
        new_faces = np.where(bad[kept, None], faces[kept], root[faces[kept]]).astype(np.int32)
    report.update(counts)
    verts = mesh.vertices.copy()
    groups = np.unique(root[merged])
    # a position taken from an input vertex (a locked one, an end of the pair) bit for bit
    at = origin[groups]
    verts[groups] = np.where((at >= 0)[:, None], mesh.vertices[np.maximum(at, 0)], pos[groups] * scale + center)
    attrs = {}
    members = np.flatnonzero(merged)
    members = np.concatenate([members, groups])       # every vertex of a group, once
    g = root[members]
    cnt = np.bincount(g, minlength=n)[groups]
    for name, arr in mesh.attributes().items():
        out = arr.copy()
        sums = np.zeros((n, arr.shape[1]))
        np.add.at(sums, g, arr[members])
        avg = sums[groups] / cnt[:, None]
        if name == "normals":
            length = np.linalg.norm(avg, axis=1, keepdims=True)
            avg = np.divide(avg, length, out=np.zeros_like(avg), where=length > 0)
        out[groups] = avg
        attrs[name] = out
    welded = Mesh(verts, new_faces, **attrs, metadata=dict(mesh.metadata))
    return welded, kept, report


def _close_pairs(pts, ids, t_model):
    """(p, 2) input vertex pairs (i < j) strictly closer than t_model."""
    from scipy.spatial import cKDTree

    tree = cKDTree(pts)
    found = tree.query_pairs(r=t_model, output_type="ndarray").astype(np.int64)
    if found.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    d = np.linalg.norm(pts[found[:, 0]] - pts[found[:, 1]], axis=1)
    found = found[d < t_model]
    pairs = np.sort(ids[found], axis=1)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def _drop_edges(pairs, faces, n):
    """The pairs that are not an edge of a face."""
    if pairs.shape[0] == 0:
        return pairs
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]).astype(np.int64)
    e.sort(axis=1)
    edge_keys = np.unique(e[:, 0] * n + e[:, 1])
    keys = pairs[:, 0] * n + pairs[:, 1]
    at = np.minimum(np.searchsorted(edge_keys, keys), edge_keys.size - 1)
    return pairs[edge_keys[at] != keys]


def _drop_seams(pairs, mesh):
    """Drop attribute-seam copies: coincident vertices whose attributes differ (OBJ / glTF
    split a vertex to give it two uvs or normals; welding them would lose the seam)."""
    attrs = list(mesh.attributes().values())
    if pairs.shape[0] == 0 or not attrs:
        return pairs, 0
    v = mesh.vertices
    same_pos = (v[pairs[:, 0]] == v[pairs[:, 1]]).all(axis=1)
    differ = np.zeros(pairs.shape[0], dtype=bool)
    for a in attrs:
        differ |= (a[pairs[:, 0]] != a[pairs[:, 1]]).any(axis=1)
    seam = same_pos & differ
    return pairs[~seam], int(np.count_nonzero(seam))


def _quadric_value(q, x) -> float:
    return float(q[0] * x[0] * x[0] + 2 * q[1] * x[0] * x[1] + 2 * q[2] * x[0] * x[2] + q[3] * x[1] * x[1]
                 + 2 * q[4] * x[1] * x[2] + q[5] * x[2] * x[2] + 2 * (q[6] * x[0] + q[7] * x[1] + q[8] * x[2])
                 + q[9])


def _place(q, a, b, fixed_a: bool, fixed_b: bool):
    """(cost, position, which) of merging two groups with summed quadric q and positions
    a, b; which is 0 / 1 when the position is a's / b's, else -1."""
    if fixed_a or fixed_b:
        x, which = (a, 0) if fixed_a else (b, 1)
        return max(_quadric_value(q, x), 0.0), x, which
    A = np.array([[q[0], q[1], q[2]], [q[1], q[3], q[4]], [q[2], q[4], q[5]]])
    tr = q[0] + q[3] + q[5]
    det = float(np.linalg.det(A))
    if tr > 0.0 and det > _DET_TOLERANCE * (tr / 3.0) ** 3:
        x = np.linalg.solve(A, -q[6:9])
        return max(_quadric_value(q, x), 0.0), x, -1
    best = None
    for which, x in ((-1, 0.5 * (a + b)), (0, a), (1, b)):   # ties (all on one plane): the midpoint
        c = max(_quadric_value(q, x), 0.0)
        if best is None or c < best[0]:
            best = (c, x, which)
    return best


def _contract(pairs, Q, P, fixed, t):
    """Greedy contraction in cost order.  Returns (root (n,) group representative of each
    vertex, pos (n, 3) normalised position of each group representative, origin (n,) the
    input vertex whose position the group took, -1 for a new position)."""
    n = P.shape[0]
    parent = np.arange(n)
    q = Q.copy()
    pos = P.copy()
    fix = fixed.copy()
    version = np.zeros(n, dtype=np.int64)
    origin = np.arange(n)                         # the input vertex whose position a group has, or -1

    def find(i):
        r = i
        while parent[r] != r:
            r = parent[r]
        while parent[i] != r:                     # path compression
            parent[i], i = r, parent[i]
        return r

    heap = []
    for seq, (i, j) in enumerate(pairs.tolist()):
        cost = _place(q[i] + q[j], pos[i], pos[j], fix[i], fix[j])[0]
        heap.append((cost, seq, i, j, 0, 0))
    heapq.heapify(heap)
    seq = len(heap)
    while heap:
        cost, _, i, j, vi, vj = heapq.heappop(heap)
        if version[i] != vi or version[j] != vj or parent[i] != i or parent[j] != j:
            ri, rj = find(i), find(j)
            if ri == rj or (fix[ri] and fix[rj]):
                continue
            if np.linalg.norm(pos[ri] - pos[rj]) >= t:
                continue                          # the groups have moved apart
            cost = _place(q[ri] + q[rj], pos[ri], pos[rj], fix[ri], fix[rj])[0]
            seq += 1
            heapq.heappush(heap, (cost, seq, min(ri, rj), max(ri, rj), version[min(ri, rj)], version[max(ri, rj)]))
            continue
        qs = q[i] + q[j]
        _, x, which = _place(qs, pos[i], pos[j], fix[i], fix[j])
        keep, gone = (j, i) if fix[j] else (i, j)  # the locked one (else the lower index) stays
        origin[keep] = origin[(i, j)[which]] if which >= 0 else -1
        parent[gone] = keep
        q[keep] = qs
        pos[keep] = x
        fix[keep] = fix[i] or fix[j]
        version[keep] += 1
    root = np.array([find(i) for i in range(n)])
    return root, pos, origin


def _weld_faces(faces, root):
    """Faces on the group representatives: drop the ones with a repeated vertex; on each
    vertex triple cancel opposite orientations in pairs and keep one of what is left."""
    f = root[faces]
    ok = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    idx = np.flatnonzero(ok)
    counts = {"collapsed_faces_removed": int(faces.shape[0] - idx.size),
              "membrane_faces_removed": 0, "duplicate_faces_removed": 0}
    f = f[idx]
    if f.shape[0] == 0:
        return f.astype(np.int32), idx.astype(np.int64), counts
    s = np.sort(f, axis=1)
    order = np.lexsort((idx, s[:, 2], s[:, 1], s[:, 0]))
    ss = s[order]
    head = np.ones(order.size, dtype=bool)
    head[1:] = (ss[1:] != ss[:-1]).any(axis=1)
    group = np.cumsum(head) - 1
    at_min = np.argmin(f, axis=1)
    even = f[np.arange(f.shape[0]), (at_min + 1) % 3] == s[:, 1]
    n_groups = int(group[-1]) + 1
    n_even = np.bincount(group, weights=even[order].astype(float), minlength=n_groups)
    size = np.bincount(group, minlength=n_groups)
    n_odd = size - n_even
    # after cancelling in pairs: |even - odd| faces of the majority orientation remain; keep one
    keep_even = n_even > n_odd
    keep_any = n_even != n_odd
    counts["membrane_faces_removed"] = int((2 * np.minimum(n_even, n_odd)).sum())
    counts["duplicate_faces_removed"] = int((np.abs(n_even - n_odd) - keep_any).sum())
    cand = keep_any[group] & (even[order] == keep_even[group])
    c = np.flatnonzero(cand)
    first = np.ones(c.size, dtype=bool)
    first[1:] = group[c[1:]] != group[c[:-1]]
    pick = np.sort(order[c[first]])
    return f[pick].astype(np.int32), idx[pick].astype(np.int64), counts
