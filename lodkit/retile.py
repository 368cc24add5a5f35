"""``retile()``: re-tiling polygonal surfaces (Turk 1992), the lecture's four steps.

1. sample:     ``n_vertices`` random points on the surface, area-weighted (``adapt > 0``:
               weighted by 1 + adapt * normalised curvature too); boundary loops (and,
               with ``features=``, crease lines) get their share of points spread evenly
               along them by arc length, their corners kept
2. repulsion:  each interior point is pushed away from its neighbours within a radius
               derived from the local point density, the step taken in the tangent plane of
               the face it lies on and the result projected back onto the closest point of
               the surface (Embree, through Open3D); neighbourhoods from a KD-tree
               (scipy's cKDTree) restricted to points whose faces' normals are within
               120 degrees, an approximation of the geodesic neighbourhood (docs/retile.md)
3. tessellate: the new points are inserted into the faces that hold them (1-to-3 splits;
               1-to-2 on boundary edges, on both faces of a crease edge): the mutual
               tessellation
4. remove:     the old vertices are removed one by one by lodkit's vertex-removal driver
               (lodkit._core.vremove) with lodkit._core.retile.RetileKernel, which fills
               each hole with its max-min-quality triangulation; the driver's checks keep
               the topology (link condition, no flipped faces).  New points are fixed.
               Old vertices still left go by a legal collapse into a neighbour.

Then edge flips between nearly coplanar faces (and, for slivers, faces within 60 degrees)
raise the smaller quality of each pair
(lodkit._core.retile.flip_edges).  Attributes (normals, colours, uvs) are interpolated
barycentrically on the input face a new point lies on.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._core import retile as kern
from ._core import vremove
from ._core.halfedge import build
from ._pipeline import RUN_CHUNK, prepare, weld_cycles
from ._progress import Progress
from .errors import MeshError, OptionError
from .geometry import face_normals, triangle_quality
from .mesh import Mesh, as_mesh, is_open3d
from .settings import finite_number

__all__ = ["RetileResult", "SurfaceProjector", "retile", "face_twins"]

BOUNDARY_FREE = 2                # lodkit/_core/common.pxd: boundary vertices may be removed
# interior points are kept this far (barycentric) from the edges of the face they are on, so
# that the 1-to-3 split never makes a zero-area triangle
_EDGE_MARGIN = 1e-3
# points whose faces' normals differ by more than 120 degrees do not repel each other (the
# other side of a thin sheet): the geodesic approximation; points across a crease of up to
# 120 degrees still do (else they crowd on both sides of it and make slivers)
_NEIGHBOUR_DOT = -0.5
# after the repulsion, of two points closer than this (times the target edge length) one goes
_MIN_GAP = 0.25
# max_normal_angle of the removal rounds (vremove's checks; the last still refuses flips)
_RADIUS = 1.0
# the second flip pass: edges whose worse triangle is below this quality, between faces
# within this many degrees
_SLIVER_QUALITY = 0.2
_SLIVER_FLIP_ANGLE = 60.0
# interior points closer than this (times the target edge length) to a boundary are dropped
_BOUNDARY_GAP = 0.3
# the fallback collapse of a held-back old vertex prefers a new vertex as the target when
# the faces left are at least this good
_FALLBACK_QUALITY = 0.2
_REMOVAL_ANGLES = (90.0, 135.0, 170.0)
# equalize: the density is at least this fraction of the mean, at most its 99th percentile
_EQ_FLOOR = 0.1
_EQ_CAP = 99.0
# refine: a pass multiplies the density by (local error / mean error) ** _REFINE_POWER (1:
# the chord error edge^2 * curvature / 8 is then the same everywhere on smooth parts), by at
# most _REFINE_CLAMP either way.  Power 2 (right for creases, where the error ~ edge) and
# points pinned at the largest errors were tried on bunny@2% and did not do better.
_REFINE_POWER = 1.0
#: crease networks (connected crease edges) shorter in total than this fraction of the bbox
#: diagonal are not creases (retile's ``features``, optimize's crease samples)
CREASE_MIN_LENGTH = 0.1
_REFINE_CLAMP = 4.0
# refine keeps, of the finished passes whose largest error is within this factor of the
# smallest, one that meets the shape targets (smallest quality >= _COLLAPSE_QUALITY, mean
# >= _KEEP_MEAN_QUALITY, issue 16's), the smallest error first among equals: on cow@2% the
# passes' mean qualities scatter by 0.05-0.08 while their errors are often within 20%
# (docs/retile.md)
_KEEP_ERROR_SLACK = 1.2
# ... and within this factor when each pass draws more than once (``draws``): among twice
# the candidates a well-shaped one is found within it on every seed measured, where 1.2
# left cow@2 %'s out on half of them (docs/retile.md, "The draws round")
_KEEP_ERROR_SLACK_DRAWS = 1.7
_KEEP_MEAN_QUALITY = 0.85


class SurfaceProjector:
    """Closest points on a fixed triangle surface: the face from Embree (Open3D's
    RaycastingScene, single precision), the point on it in double precision (native)."""

    def __init__(self, V: np.ndarray, F: np.ndarray):
        import open3d as o3d

        self.V = np.ascontiguousarray(V, dtype=np.float64)
        self.F = np.ascontiguousarray(F, dtype=np.int64)
        self.scene = o3d.t.geometry.RaycastingScene()
        self.scene.add_triangles(o3d.core.Tensor(self.V.astype(np.float32)),
                                 o3d.core.Tensor(self.F.astype(np.uint32)))

    def closest(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(face (n,), barycentric weights (n, 3), distance (n,)) of the closest points."""
        import open3d as o3d

        P = np.ascontiguousarray(P, dtype=np.float64)
        res = self.scene.compute_closest_points(o3d.core.Tensor(P.astype(np.float32)))
        face = np.ascontiguousarray(res["primitive_ids"].numpy(), dtype=np.int64)
        w, d2 = kern.closest_on_faces(P, self.V, self.F, face)
        return face, w, np.sqrt(d2)

    def distance(self, P: np.ndarray) -> np.ndarray:
        """(n,) distance of each point to the surface (single precision, Embree)."""
        import open3d as o3d

        P = np.ascontiguousarray(P, dtype=np.float32)
        return self.scene.compute_distance(o3d.core.Tensor(P)).numpy().astype(np.float64)


@dataclass
class RetileResult:
    """What :func:`retile` returns.

    mesh         : the re-tiled mesh (a lodkit.Mesh, or an open3d TriangleMesh if one was given)
    n_new        : new vertices placed (interior and boundary)
    n_old_kept   : input vertices the removal could not take out (locked non-manifold copies,
                   or holes with no valid triangulation); 0 in the usual case
    flips        : edge flips of the final clean-up
    elapsed      : seconds
    report       : details (radius, per-step times, counts)
    """

    mesh: Any
    n_new: int
    n_old_kept: int
    flips: int
    elapsed: float = 0.0
    report: dict = field(default_factory=dict)

    def __repr__(self) -> str:
        return (f"RetileResult({self.mesh!r}, n_new={self.n_new}, n_old_kept={self.n_old_kept}, "
                f"flips={self.flips})")


def retile(mesh, n_vertices: int, *, adapt: float = 0.0, equalize: bool = False, iterations: int = 30,
           flip_angle: float = 25.0, corner_angle: float = 30.0, features: float | None = None, relax: int = 3,
           refine: int = 0, draws: int = 1, fit: int = 0, seed: int = 0, progress: bool = False) -> RetileResult:
    """Re-tile ``mesh`` with about ``n_vertices`` new, evenly spread vertices (Turk 1992).

    n_vertices : number of new vertices (>= 4); boundary loops take a share proportional
                 to their length (at least 3 each)
    adapt      : >= 0; 0 spreads the points uniformly by area, larger values put them
                 denser where the surface curves (density ~ 1 + adapt * curvature / mean)
    equalize   : density proportional to the curvature measured at the scale of the target
                 edge length (edge ~ 1 / sqrt(curvature): the same interpolation error
                 everywhere), at least a tenth of the mean, capped at the 99th percentile;
                 replaces ``adapt``'s density
    iterations : repulsion steps
    flip_angle : the final edge flips only act between faces within this many degrees
                 (0 turns them off)
    corner_angle : boundary vertices where the boundary turns by more than this (degrees)
                 are kept as they are (they count towards ``n_vertices``)
    features   : None (default), or an angle in degrees: edges whose faces' normals differ
                 by more than it are creases (in networks at least CREASE_MIN_LENGTH of the
                 bbox diagonal long); crease lines get their own points (like boundaries, at
                 the local spacing), their ends and sharp turns stay, and the removal keeps them
    relax      : rounds of tangential relaxation after the final flips (lodkit's addition,
                 0: Turk's steps only): each new interior point moves half-way to the
                 area-weighted centroid of its faces within its tangent plane, back onto
                 the input surface (so do the old vertices the removal left, but for
                 boundary corners, crease vertices and non-manifold copies: report["old_moved"]);
                 a move that would turn or spoil a face is undone;
                 each round, crease points then slide along their crease lines to better
                 triangles and boundary points along their loops to chords closer to the
                 input's loop (report["relax_slides"]); then the flips again, then the
                 worst-triangle step: the new points of
                 faces below quality 0.4 move, on the surface, to where their worst face is
                 best (report["worst_moves"]; those old vertices too; crease points slide
                 along their crease line, report["slid"], boundary points too); faces still
                 below 0.3 get a second, wider round and a sliver's free vertex may
                 collapse into a neighbour
                 (report["sliver_collapses"]); then a last sliver flip pass; on every
                 pass, faces still below 0.3 get up to 8 rounds of those moves,
                 collapses, sliver splits (report["sliver_splits"]) and flips (docs/retile.md)
    refine     : error-driven passes (lodkit's addition, 0: off): after each pass the
                 distance between the re-tiling and the input is measured both ways, the
                 density is multiplied by the local error over its mean (at most 4x
                 either way) and the surface is re-tiled again from the input with as many
                 points; every pass is finished (the untangling and ``fit``) and
                 measured again, and of the ``refine + 1`` passes those within 1.2x of the
                 smallest largest error (a Hausdorff estimate) compete on shape: smallest
                 quality >= 0.3 first, then mean >= 0.85, then the smallest error
                 (report["refine_errors"], report["refine_quality"]: (mean, min) per pass,
                 report["refine_pass"])
    draws      : re-tilings per pass (lodkit's addition, >= 1; 1: one): each pass draws its
                 points this many times at the same density (the first from ``seed``'s
                 generator, as with 1, the others from generators spawned from it), finishes
                 every draw, and the choice above sees all of them, within 1.7x of the
                 smallest error instead of 1.2x; the next pass's density comes from the
                 first draw.  report["refine_errors"] and ["refine_quality"] then hold pass
                 p's draw d at index p * draws + d
    fit        : rounds (lodkit's addition, NOT Turk's method; 0: off) that move the new
                 interior vertices along their normals so that the result straddles the
                 input instead of lying on one side of it (at most a quarter of the mean edge
                 length off the surface; connectivity unchanged; report["fitted"])
    seed       : the random points come from ``numpy.random.default_rng(seed)``

    The output keeps the input's topology: the old vertices go by vertex removal with the
    driver's link-condition and orientation checks.  Sharp creases are resampled, hence
    blurred unless ``features`` keeps them (docs/retile.md).  Raises MeshError for an unusable mesh, OptionError for bad
    options.
    """
    t0 = time.perf_counter()
    src, was_o3d = as_mesh(mesh), is_open3d(mesh)
    n_vertices = _count("n_vertices", n_vertices, 4)
    iterations = _count("iterations", iterations, 0)
    relax = _count("relax", relax, 0)
    refine = _count("refine", refine, 0)
    draws = _count("draws", draws, 1)
    fit = _count("fit", fit, 0)
    adapt = finite_number("adapt", adapt)
    if adapt < 0:
        raise OptionError(f"adapt must be >= 0, got {adapt!r}")
    if not isinstance(equalize, (bool, np.bool_)):
        raise OptionError(f"equalize must be True or False, got {equalize!r}")
    flip_angle = finite_number("flip_angle", flip_angle)
    if not 0.0 <= flip_angle < 90.0:
        raise OptionError(f"flip_angle must be in [0, 90) degrees, got {flip_angle!r}")
    if features is not None:
        features = finite_number("features", features)
        if not 0.0 < features < 180.0:
            raise OptionError(f"features must be an angle in (0, 180) degrees, got {features!r}")
    corner_angle = finite_number("corner_angle", corner_angle)
    if not 0.0 < corner_angle <= 180.0:
        raise OptionError(f"corner_angle must be in (0, 180] degrees, got {corner_angle!r}")
    prep = prepare(src)
    hm = prep.hm
    P0 = prep.positions                       # (n_slots, 3) normalised
    F0 = np.ascontiguousarray(hm.corners, dtype=np.int32)
    n0 = P0.shape[0]
    normals0, area0 = face_normals(P0, F0)
    total_area = float(area0.sum())
    if not total_area > 0.0:
        raise MeshError("the mesh has zero surface area; nothing to re-tile")
    rng = np.random.default_rng(seed)
    times = {}

    # -- 1. density and sampling
    t = time.perf_counter()
    weight = np.ones(F0.shape[0])
    if equalize:
        weight = _equalizing_density(P0, F0, area0, math.sqrt(2.0 * total_area / (math.sqrt(3.0) * n_vertices)))
    elif adapt > 0:
        from .curvature import point_curvature

        kv = point_curvature(P0)
        kf = kv[F0].mean(axis=1)
        mean = float(np.average(kf, weights=area0)) if area0.sum() > 0 else 0.0
        if mean > 0:
            weight = 1.0 + adapt * kf / mean
    wsum = float((area0 * weight).sum())
    edge_len = math.sqrt(2.0 * wsum / (math.sqrt(3.0) * n_vertices))   # equilateral, 2 faces per vertex
    twins0 = np.asarray(hm.twins)
    # the build cut each non-manifold input vertex into copies; welded back in the output,
    # no vertex may be next to two of them (that edge would have more than two faces):
    # group0[slot] = its input vertex where that has several slots, else -1
    group0 = _copy_groups(prep.input_vertex) if hm.n_split_vertices else None
    loops = _boundary_loops(F0, twins0)
    lines, creases = ([], []) if features is None else _crease_lines(P0, F0, twins0,
                                                                      math.cos(math.radians(features)))
    surf = SurfaceProjector(P0, F0)
    from scipy.spatial import cKDTree

    # the boundary and crease lines, densely sampled (the same for every pass)
    dense_tree = (cKDTree(_boundary_samples(P0, F0, loops + creases + lines, edge_len / 32.0))
                  if loops or creases or lines else None)
    # the flips' limits: between faces within flip_angle, and for slivers within the wider
    # _SLIVER_FLIP_ANGLE; edges between two crease points may flip where no crease is
    cos_flip = math.cos(math.radians(flip_angle))
    cos_sliver = math.cos(math.radians(max(flip_angle, _SLIVER_FLIP_ANGLE)))
    cos_crease = math.cos(math.radians(features)) if features is not None else 2.0
    errors, qualities, passes = [], [], []
    choose = refine > 0 or draws > 1              # several finished candidates: _keep_pass
    for pass_ in range(refine + 1):
        # draw 0 takes the points from rng (the passes of draws=1); the others from generators
        # spawned from it (spawning leaves rng's stream as it was)
        subs = rng.spawn(draws - 1) if draws > 1 else []
        for draw in range(draws):
            gen = subs[draw - 1] if draw else rng
            if pass_ or draw:
                t = time.perf_counter()
            # the lines get the local target spacing, edge_len / sqrt(weight), of the denser side
            hscale = np.sqrt(np.maximum(weight[np.arange(twins0.size) // 3],
                                        np.where(twins0 >= 0, weight[np.maximum(twins0, 0) // 3], 0.0)))
            B, bface, bw, kept, bh, bt = _boundary_points(P0, F0, loops + creases, edge_len, gen, corner_angle, lines,
                                                          hscale)
            if group0 is not None and bh.size:
                # a crease point joins the far corners of both faces of its edge: not two copies
                keep = ~_joins_copies(F0, twins0, bh, group0)
                B, bface, bw, bh, bt = B[keep], bface[keep], bw[keep], bh[keep], bt[keep]
            n_inner = n_vertices - B.shape[0] - kept.size
            if n_inner < 1:
                raise OptionError(f"n_vertices={n_vertices} is too few: the boundary loops"
                                  f"{' and crease lines' if features is not None else ''} alone take "
                                  f"{B.shape[0] + kept.size} points; ask for more vertices")
            face, w = _sample(area0 * weight, n_inner, gen)
            w = _off_edges(w)
            X = np.einsum("nk,nkj->nj", w, P0[F0[face]])
            # local radius: density rho = n * weight / wsum points per unit area; a point's disc
            # pi (r/2)^2 = 1 / rho (Turk's radius from the area per point)
            times["sample"] = times.get("sample", 0.0) + time.perf_counter() - t

            # -- 2. repulsion
            t = time.perf_counter()

            r_face = _RADIUS * 2.0 * np.sqrt(wsum / (math.pi * n_vertices * weight))
            rb = edge_len / hscale[bh] if B.shape[0] else np.zeros(0)      # the local spacing
            nb = normals0[bface] if B.shape[0] else np.zeros((0, 3))
            bar = Progress(iterations, enabled=progress)
            for it in range(iterations):
                r = r_face[face]
                Q = np.concatenate([X, B])
                R = np.concatenate([r, rb])
                N = np.concatenate([normals0[face], nb])
                pairs = cKDTree(Q).query_pairs(float(R.max()), output_type="ndarray")
                force = np.zeros_like(Q)
                if pairs.size:
                    i, j = pairs[:, 0], pairs[:, 1]
                    d = Q[i] - Q[j]
                    dist = np.linalg.norm(d, axis=1)
                    rij = 0.5 * (R[i] + R[j])
                    keep = (dist < rij) & (dist > 0) & (np.einsum("ij,ij->i", N[i], N[j]) > _NEIGHBOUR_DOT)
                    i, j, d, dist, rij = i[keep], j[keep], d[keep], dist[keep], rij[keep]
                    f = ((1.0 - dist / rij) / dist)[:, None] * d
                    for k in range(3):
                        force[:, k] += np.bincount(i, weights=f[:, k], minlength=Q.shape[0])
                        force[:, k] -= np.bincount(j, weights=f[:, k], minlength=Q.shape[0])
                fx = force[:n_inner]
                nx = normals0[face]
                fx -= np.einsum("ij,ij->i", fx, nx)[:, None] * nx          # tangent plane
                step = 0.2 * r[:, None] * fx
                ln = np.linalg.norm(step, axis=1)
                cap = 0.25 * r
                big = ln > cap
                step[big] *= (cap[big] / ln[big])[:, None]
                face, w, _ = surf.closest(X + step)
                w = _off_edges(w)
                X = np.einsum("nk,nkj->nj", w, P0[F0[face]])
                bar.update(it + 1)
            bar.close()
            # an interior point the repulsion pushed over a boundary was projected back onto it:
            # it would make slivers with the boundary points, so it goes
            n_dropped = 0
            if dense_tree is not None and n_inner:
                near = dense_tree.query(X)[0] < _BOUNDARY_GAP * edge_len / np.sqrt(weight[face])
                n_dropped = int(np.count_nonzero(near))
                if n_dropped:
                    X, face, w = X[~near], face[~near], w[~near]
                    n_inner = X.shape[0]
            # two points left almost on top of each other (across a fold the repulsion did not see)
            if n_inner > 1:
                Q = np.concatenate([X, B])
                gap = _MIN_GAP * edge_len / np.sqrt(np.concatenate([weight[face], weight[bface]]))
                pairs = cKDTree(Q).query_pairs(float(gap.max()), output_type="ndarray")
                if pairs.size:
                    pairs = pairs[np.linalg.norm(Q[pairs[:, 0]] - Q[pairs[:, 1]], axis=1)
                                  < np.minimum(gap[pairs[:, 0]], gap[pairs[:, 1]])]
                drop = np.zeros(Q.shape[0], dtype=bool)
                for i, j in pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))] if pairs.size else ():
                    if not drop[i] and not drop[j]:
                        drop[max(i, j) if max(i, j) < n_inner else min(i, j)] = True   # boundary points stay
                drop = drop[:n_inner]
                if drop.any() and np.count_nonzero(~drop) >= 1:
                    n_dropped += int(np.count_nonzero(drop))
                    X, face, w = X[~drop], face[~drop], w[~drop]
                    n_inner = X.shape[0]
            times["repulsion"] = times.get("repulsion", 0.0) + time.perf_counter() - t

            # -- 3. mutual tessellation
            t = time.perf_counter()
            # a crease point lies on an edge with a face on each side: it splits both
            on = twins0[bh] >= 0 if bh.size else np.zeros(0, dtype=bool)
            tw = twins0[bh[on]]
            w2 = np.zeros((tw.size, 3))
            w2[np.arange(tw.size), tw % 3] = bt[on]
            w2[np.arange(tw.size), (tw % 3 + 1) % 3] = 1.0 - bt[on]
            nX = X.shape[0]
            all_face = np.concatenate([face, bface, tw // 3]).astype(np.int64)
            all_w = np.concatenate([w, bw, w2])
            all_pid = np.concatenate([np.arange(nX + B.shape[0]), nX + np.flatnonzero(on)]).astype(np.int64)
            faces2 = _tessellate(F0, n0, all_face, all_w, all_pid)
            new_pos = np.concatenate([X, B])
            P2 = np.ascontiguousarray(np.concatenate([P0, new_pos]))
            times["tessellate"] = times.get("tessellate", 0.0) + time.perf_counter() - t

            # -- 4. remove the old vertices
            t = time.perf_counter()
            n_new = new_pos.shape[0]
            hm2 = build(faces2, n0 + n_new)
            fixed = np.zeros(n0 + n_new, dtype=np.uint8)
            fixed[n0:] = 1
            fixed[kept] = 1                                                    # boundary corners stay
            fixed[:n0][np.asarray(hm.locked_vertices, dtype=bool)[:n0]] = 1     # non-manifold copies stay
            # (no crease network long enough: no creases for the kernel and the flips either)
            group2 = weld = None
            if group0 is not None:
                # the removal's manifold rules then see the copies welded (vremove's ``weld``), and
                # the kernel avoids the chords those rules would refuse
                group2 = np.ascontiguousarray(np.concatenate([group0, np.full(n_new, -1)]), dtype=np.intc)
                weld = weld_cycles(group2)
            kernel = kern.RetileKernel(math.cos(math.radians(features)) if lines or creases else -2.0, group2)
            crease_vertex = None
            if lines or creases:
                crease_vertex = np.zeros(n0 + n_new, dtype=np.uint8)
                crease_vertex[n0 + nX + np.flatnonzero(on)] = 1
                crease_vertex[np.unique(F0.reshape(-1)[np.concatenate(lines + creases)])
                              if lines or creases else np.zeros(0, dtype=np.int64)] = 1
            removals = 0
            held = {}
            # later rounds (fresh removal state) for the vertices the first one held back: new faces
            # may then turn further from the old ones (a held-back vertex sits in a fold of old
            # faces that the new points do not resolve)
            for angle in _REMOVAL_ANGLES:
                remover = vremove.VertexRemover(hm2, P2, kernel, fixed, boundary=BOUNDARY_FREE,
                                                max_normal_angle=angle, min_quality=0.0, weld=weld)
                while remover.run(0, 1 << 30) == RUN_CHUNK:
                    pass
                if remover.failed:
                    raise MeshError(f"re-tiling failed while removing the old vertices: {remover.error_message}")
                removals += int(remover.n_collapses)
                held = remover.held_back
                if not np.asarray(hm2.alive_vertices, dtype=bool)[:n0][fixed[:n0] == 0].any():
                    break
            n_collapsed = _collapse_leftovers(hm2, P2, n0, fixed, group2)
            alive_v = np.asarray(hm2.alive_vertices, dtype=bool)
            n_old_kept = int(np.count_nonzero(alive_v[:n0])) - int(kept.size)
            times["remove"] = times.get("remove", 0.0) + time.perf_counter() - t

            # -- clean-up flips, compaction, attributes
            t = time.perf_counter()
            F = np.ascontiguousarray(hm2.faces(), dtype=np.int32)
            flips = 0
            if flip_angle > 0 and F.shape[0]:
                twin = face_twins(F)
                flips = int(kern.flip_edges(P2, F, twin, cos_flip, 50, crease_vertex, group=group2))
                # slivers (often across a crease the new points straddle): flips between faces
                # further apart, only where the worse triangle is a sliver
                flips += int(kern.flip_edges(P2, F, twin, cos_sliver, 20, crease_vertex, _SLIVER_QUALITY, group=group2))
            relaxed = worst_moves = slid = slid_relax = collapsed = 0
            old_at = (np.full(n0, -1, dtype=np.int64), np.zeros((n0, 3)))
            free_old = None
            if relax and F.shape[0] and nX:
                # old vertices the removal left (not copies, boundary corners or crease vertices)
                # may move like new points; where they went is in old_at
                free_old = np.zeros(P2.shape[0], dtype=bool)
                free_old[np.unique(F.reshape(-1))] = True
                free_old[n0:] = False
                free_old &= fixed == 0
                if crease_vertex is not None:
                    free_old &= crease_vertex == 0
                slider = None
                if on.size:
                    # crease points slide along their line, in the relaxation and in the
                    # worst-triangle step; boundary points along their loop
                    slider = LineSlider(P0, F0, [(x, True) for x in loops + creases] + [(x, False) for x in lines],
                                        n0 + nX + np.arange(on.size), bh, bt, ~on)
                if slider is None:
                    relaxed = _relax(P2, F, n0, nX, surf, P0, F0, all_face, all_w, relax, free_old, old_at)
                for _ in range(relax if slider is not None else 0):
                    # interior points in their tangent planes, then the crease points along their
                    # lines, then the flips (edges between two crease points too, where no crease)
                    relaxed += _relax(P2, F, n0, nX, surf, P0, F0, all_face, all_w, 1, free_old, old_at)
                    for _sweep in range(_SLIDE_SWEEPS if np.any(on) else 0):
                        relaxed_slid = _slide_relax(P2, F, slider, surf, all_face, all_w, n0)
                        relaxed += relaxed_slid
                        slid_relax += relaxed_slid
                    for _sweep in range(_BOUNDARY_SWEEPS if slider.boundary.any() else 0):
                        relaxed_slid = _slide_boundary(P2, F, slider, all_face, all_w, n0)
                        relaxed += relaxed_slid
                        slid_relax += relaxed_slid
                    if flip_angle > 0 and np.any(on):
                        twin = face_twins(F)
                        flips += int(kern.flip_edges(P2, F, twin, cos_flip, 50, crease_vertex,
                                                     2.0, cos_crease, group=group2))
                if flip_angle > 0:
                    # (cos_crease is 2, no edge between crease points flips, without crease points)
                    twin = face_twins(F)
                    flips += int(kern.flip_edges(P2, F, twin, cos_flip, 50, crease_vertex,
                                                 2.0, cos_crease if slider is not None else 2.0, group=group2))
                    flips += int(kern.flip_edges(P2, F, twin, cos_sliver,
                                                 20, crease_vertex, _SLIVER_QUALITY,
                                                 cos_crease if slider is not None else 2.0, group=group2))
                worst_moves, n_slid = _improve_worst(P2, F, n0, nX, surf, P0, F0, all_face, all_w, _WORST_ROUNDS,
                                                     slider, free_old, old_at)
                slid += n_slid
                if F.shape[0] and float(triangle_quality(P2, F).min()) < _COLLAPSE_QUALITY:
                    # still below the target: the old vertices the removal left move too, further,
                    # then a free vertex of a sliver may go, then the points around move again
                    for k in range(2):
                        more, n_slid = _improve_worst(P2, F, n0, nX, surf, P0, F0, all_face, all_w, _WORST_ROUNDS,
                                                      slider, free_old, old_at, _COLLAPSE_QUALITY, _FAR_STEPS,
                                                      _FAR_DIRECTIONS, _FAR_TURN)
                        worst_moves += more
                        slid += n_slid
                        if k:
                            break
                        F_c, n_sliver = _collapse_slivers(P2, F, n0, nX, free_old, group2, crease_vertex)
                        if not n_sliver:
                            break
                        F = F_c
                        collapsed += n_sliver
                    twin = face_twins(F)
                if flip_angle > 0:
                    # slivers again, now also between two crease points where the edge is no crease
                    flips += int(kern.flip_edges(P2, F, twin, cos_sliver,
                                                 20, crease_vertex, _WORST_QUALITY, cos_crease,
                                                 group=group2))
            times["finish"] = times.get("finish", 0.0) + time.perf_counter() - t
            if refine and not draw:
                # error-driven density: measure this pass (its first draw), reweight the next by
                # its local error
                t = time.perf_counter()
                new_weight, _ = _error_density(weight, area0, P0, F0, P2, F, surf)
                times["refine"] = times.get("refine", 0.0) + time.perf_counter() - t
            # -- the last quality steps and the fit, on every pass: refine compares finished passes
            t = time.perf_counter()
            split = 0
            if free_old is not None and F.shape[0] and float(triangle_quality(P2, F).min()) < _COLLAPSE_QUALITY:
                # still below the target: moves that no stuck vertex blocks, collapses, splits
                # and flips
                P2, F, all_face, all_w, more, n_c, split, n_f = _untangle(
                    P2, F, n0, nX, surf, P0, F0, all_face, all_w, free_old, old_at, group2, crease_vertex,
                    cos_sliver if flip_angle > 0 else 2.0, cos_crease, on_edge=fit > 0)
                worst_moves += more
                collapsed += n_c
                flips += n_f
                n_new = P2.shape[0] - n0
            fitted = _fit_normal(P2, F, n0, nX, surf, normals0, fit) if fit and nX else 0
            times["finish"] += time.perf_counter() - t
            if choose:
                t = time.perf_counter()
                # the finished pass's largest error (its density is the one above, measured
                # before the last quality steps and the fit, so that the passes stay as they were)
                err = _error_density(weight, area0, P0, F0, P2, F, surf)[1]
                q_pass = triangle_quality(P2, F) if F.shape[0] else np.zeros(1)
                errors.append(err * prep.scale)
                qualities.append((float(q_pass.mean()), float(q_pass.min())))
                passes.append((P2, F, n_new, nX, all_face, all_w, B, kept, on, n_dropped,
                               removals, held, n_collapsed, flips, relaxed, worst_moves, slid, n_old_kept, collapsed,
                               old_at, slid_relax, split, fitted))
                times["refine"] = times.get("refine", 0.0) + time.perf_counter() - t
        if refine:
            weight = new_weight
    kept_pass = 0
    if choose:
        kept_pass = _keep_pass(errors, qualities, _KEEP_ERROR_SLACK if draws == 1 else _KEEP_ERROR_SLACK_DRAWS)
        (P2, F, n_new, nX, all_face, all_w, B, kept, on, n_dropped, removals, held, n_collapsed, flips, relaxed,
         worst_moves, slid, n_old_kept, collapsed, old_at, slid_relax, split, fitted) = passes[kept_pass]
    t = time.perf_counter()
    used = np.zeros(n0 + n_new, dtype=bool)
    used[F.reshape(-1)] = True
    # old vertices: one output vertex per input vertex (split copies weld back); an old
    # vertex the worst-triangle step moved is a point on the surface like the new ones
    moved_old = used[:n0] & (old_at[0] >= 0)
    old_slots = np.flatnonzero(used[:n0] & ~moved_old)
    old_inputs = prep.input_vertex[old_slots]
    uniq_in, first, inv = np.unique(old_inputs, return_index=True, return_inverse=True)
    new_slots = np.concatenate([n0 + np.flatnonzero(used[n0:]), np.flatnonzero(moved_old)])
    remap = np.full(n0 + n_new, -1, dtype=np.int64)
    remap[old_slots] = inv.reshape(-1)
    remap[new_slots] = uniq_in.size + np.arange(new_slots.size)
    out_faces = remap[F]
    verts = np.concatenate([src.vertices[uniq_in], P2[new_slots] * prep.scale + prep.center])
    attrs = {}
    corner_inputs = prep.input_vertex[F0]                      # (m0, 3) input vertex per corner
    at_face = np.concatenate([all_face[new_slots[new_slots >= n0] - n0], old_at[0][new_slots[new_slots < n0]]])
    at_w = np.concatenate([all_w[new_slots[new_slots >= n0] - n0], old_at[1][new_slots[new_slots < n0]]])
    for name, arr in src.attributes().items():
        interp = np.einsum("nk,nkj->nj", at_w, arr[corner_inputs[at_face]])
        if name == "normals":
            ln = np.linalg.norm(interp, axis=1, keepdims=True)
            interp = np.divide(interp, ln, out=np.zeros_like(interp), where=ln > 0)
        elif name == "colors":
            np.clip(interp, 0.0, 1.0, out=interp)
        attrs[name] = np.concatenate([arr[uniq_in], interp])
    out = Mesh(verts, out_faces, **attrs)
    times["finish"] += time.perf_counter() - t
    q = triangle_quality(out.vertices, out.faces) if out.n_faces else np.zeros(1)
    return RetileResult(
        mesh=out.to_open3d() if was_o3d else out,
        n_new=int(n_new),
        n_old_kept=n_old_kept,
        flips=flips,
        elapsed=time.perf_counter() - t0,
        report={
            "input_vertices": src.n_vertices,
            "input_faces": src.n_faces,
            "boundary_points": int(B.shape[0]),
            "boundary_loops": len(loops),
            "boundary_corners": int(kept.size),
            "crease_lines": len(lines) + len(creases),
            "crease_points": int(np.count_nonzero(on)),
            "dropped": n_dropped,
            "edge_length": float(edge_len * prep.scale),
            "removals": removals,
            "held_back": held,
            "fallback_collapses": n_collapsed,
            "quality_mean": float(q.mean()),
            "quality_min": float(q.min()),
            "relaxed_moves": relaxed,
            "worst_moves": worst_moves,
            "slid": slid,
            "relax_slides": slid_relax,
            "sliver_collapses": collapsed,
            "sliver_splits": split,
            "old_moved": int(np.count_nonzero(moved_old)),
            "refine_errors": errors,
            "refine_quality": qualities,
            "refine_pass": kept_pass,
            "refine_draws": draws,
            "fitted": fitted,
            "times": times,
        },
    )


def _keep_pass(errors, qualities, slack: float = _KEEP_ERROR_SLACK) -> int:
    """The pass ``refine`` keeps, given each finished pass's largest error (a Hausdorff
    estimate, both ways) and its (mean, smallest) triangle quality: of the passes whose
    error is within ``slack`` times the smallest, those whose smallest quality is at
    least _COLLAPSE_QUALITY first, of them those whose mean is at least _KEEP_MEAN_QUALITY,
    and of those the one with the smallest error.  Where the smallest-error pass meets both
    shape targets, it is kept."""
    e = np.asarray(errors, dtype=np.float64)
    near = np.flatnonzero(e <= slack * e.min())
    good_min = np.array([qualities[i][1] >= _COLLAPSE_QUALITY for i in near])
    good_mean = np.array([qualities[i][0] >= _KEEP_MEAN_QUALITY for i in near])
    return int(near[np.lexsort((e[near], ~good_mean, ~good_min))[0]])


# ----------------------------------------------------------------------------- steps
#: a relaxation move is undone when a face of the moved point would turn by more than this
#: many degrees, or end below this quality while it was better before
_RELAX_TURN = 30.0
_COS_RELAX_TURN = math.cos(math.radians(_RELAX_TURN))
_RELAX_QUALITY = 0.3


def _new_interior_points(F: np.ndarray, n: int, n0: int, nX: int, extra=None):
    """(movable, edges): which of the n slots are new interior points -- slots n0 .. n0 + nX
    - 1 not on a boundary edge of ``F`` (those were placed along it and stay), and the
    slots ``extra`` marks ((n,) bool or None) not on one either -- and F's half-edges as
    sorted vertex pairs ((3 m, 2), one row per face corner)."""
    movable = np.zeros(n, dtype=bool)
    movable[n0:n0 + nX] = True
    if extra is not None:
        movable |= extra
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(e, axis=0, return_counts=True)
    movable[uniq[count == 1].reshape(-1)] = False
    return movable, e


def _relax(P2, F, n0: int, nX: int, surf, P0, F0, all_face, all_w, rounds: int, free_old=None, old_at=None) -> int:
    """Tangential relaxation of the new interior points (slots n0 .. n0 + nX - 1) of the
    re-tiled faces ``F``, in place in ``P2``; their closest input faces and barycentric
    weights (``all_face`` / ``all_w``, rows 0 .. nX - 1) follow.  Each round moves every
    such point half-way to the area-weighted centroid of its faces, minus the move along
    its normal, and back onto the input surface; then the moves that turn one of their
    faces by more than _RELAX_TURN degrees, or leave one below _RELAX_QUALITY that was
    above it, are undone (with their neighbours', until none is left).  Boundary and
    crease points stay; so do old vertices, but those ``free_old`` marks ((n,) bool or
    None; the ones the removal left, which sit where the input had them and make the worst
    shaped faces, docs/retile.md), whose moves go to ``old_at`` (see :func:`_improve_worst`).
    Returns the moves kept."""
    if free_old is not None and old_at is None:
        raise ValueError("free_old needs old_at, where the moved old vertices go")
    F = np.asarray(F, dtype=np.int64)
    n = P2.shape[0]
    movable, _ = _new_interior_points(F, n, n0, nX, free_old)
    if not movable.any():
        return 0
    corners = F.reshape(-1)
    cos_turn = _COS_RELAX_TURN
    kept_moves = 0
    for _ in range(rounds):
        normals, area = face_normals(P2, F)
        q_before = triangle_quality(P2, F)
        centroid = P2[F].mean(axis=1)
        w_area = np.repeat(area, 3)
        acc = np.zeros((n, 3))
        nrm = np.zeros((n, 3))
        for k in range(3):
            acc[:, k] = np.bincount(corners, weights=w_area * np.repeat(centroid[:, k], 3), minlength=n)
            nrm[:, k] = np.bincount(corners, weights=np.repeat(normals[:, k] * area, 3), minlength=n)
        total = np.bincount(corners, weights=w_area, minlength=n)
        idx = np.flatnonzero(movable & (total > 0))
        if idx.size == 0:
            break
        c = acc[idx] / total[idx, None]
        vn = nrm[idx]
        ln = np.linalg.norm(vn, axis=1, keepdims=True)
        vn = np.divide(vn, ln, out=np.zeros_like(vn), where=ln > 0)
        d = c - P2[idx]
        d -= np.einsum("ij,ij->i", d, vn)[:, None] * vn
        face, w, _ = surf.closest(P2[idx] + 0.5 * d)
        new = np.einsum("nk,nkj->nj", w, P0[F0[face]])
        old = P2[idx].copy()
        P2[idx] = new
        moved = np.zeros(n, dtype=bool)
        moved[idx] = True
        while True:
            n_after, _ = face_normals(P2, F)
            q_after = triangle_quality(P2, F)
            bad = (np.einsum("ij,ij->i", n_after, normals) < cos_turn) | \
                  ((q_after < _RELAX_QUALITY) & (q_after < q_before))
            bad &= moved[F].any(axis=1)
            if not bad.any():
                break
            undo = np.zeros(n, dtype=bool)
            undo[F[bad].reshape(-1)] = True
            undo &= moved
            pos = np.searchsorted(idx, np.flatnonzero(undo))
            P2[idx[pos]] = old[pos]
            moved[idx[pos]] = False
        keep = moved[idx]
        new_row = idx >= n0
        rows = idx[keep & new_row] - n0
        all_face[rows] = face[keep & new_row]
        all_w[rows] = w[keep & new_row]
        if old_at is not None:
            o = keep & ~new_row
            old_at[0][idx[o]] = face[o]
            old_at[1][idx[o]] = w[o]
        kept_moves += int(np.count_nonzero(keep))
    return kept_moves


class LineSlider:
    """Points that slide along the input's crease lines (the 1-D relaxation of the
    worst-triangle step, lodkit's addition).  ``lines``: (half-edges in walking order,
    closed?) per line of ``(P0, F0)``; ``slots`` (k,): the output slots of the points;
    ``h`` (k,), ``t`` (k,): the line half-edge each lies on and its parameter along it.
    A point stays on its line: its arc length ``s`` moves, never past the next output vertex
    on the line (another point, or a line vertex still in the output), so the order along
    the line and the crease edges between them stay.  Corners and line ends are old
    vertices and do not move."""

    def __init__(self, P0, F0, lines, slots, h, t, boundary=None):
        Ff = np.asarray(F0).reshape(-1)
        self.P0 = P0
        self.geo = []
        where = {}
        for li, (loop, closed) in enumerate(lines):
            a = Ff[loop]
            b = Ff[3 * (loop // 3) + (loop % 3 + 1) % 3]
            seg = np.linalg.norm(P0[b] - P0[a], axis=1)
            cum = np.concatenate([[0.0], np.cumsum(seg)])
            self.geo.append((loop, a, b, seg, cum, bool(closed)))
            for e, he in enumerate(loop.tolist()):
                where[he] = (li, e)
        self.slots = np.asarray(slots, dtype=np.int64)
        at = [where.get(int(x), (-1, 0)) for x in np.asarray(h).tolist()]
        self.line = np.array([x[0] for x in at], dtype=np.int64)
        e = np.array([x[1] for x in at], dtype=np.int64)
        keep = self.line >= 0
        self.slots, self.line, e = self.slots[keep], self.line[keep], e[keep]
        self.boundary = (np.zeros(keep.size, dtype=bool) if boundary is None
                         else np.asarray(boundary, dtype=bool))[keep]
        t = np.asarray(t, dtype=np.float64)[keep]
        self.s = np.array([self.geo[li][4][k] + tt * self.geo[li][3][k]
                           for li, k, tt in zip(self.line.tolist(), e.tolist(), t.tolist())])
        self.row = {int(v): i for i, v in enumerate(self.slots.tolist())}

    def locate(self, li: int, s: np.ndarray):
        """Points at arc lengths ``s`` on line ``li``: (positions (k, 3), input face (k,),
        barycentric weights (k, 3), s wrapped on a closed line)."""
        loop, a, b, seg, cum, closed = self.geo[li]
        length = float(cum[-1])
        s = np.mod(s, length) if closed else np.clip(s, 0.0, length)
        e = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, loop.size - 1)
        tt = np.clip((s - cum[e]) / np.where(seg[e] > 0, seg[e], 1.0), 0.0, 1.0)
        he = loop[e]
        i = he % 3
        w = np.zeros((s.size, 3))
        w[np.arange(s.size), i] = 1.0 - tt
        w[np.arange(s.size), (i + 1) % 3] = tt
        X = self.P0[a[e]] + tt[:, None] * (self.P0[b[e]] - self.P0[a[e]])
        return X, he // 3, w, s

    def deviation(self, li: int, s0: float, s1: float) -> float:
        """The largest distance of line ``li``'s input vertices strictly between arc lengths
        ``s0`` < ``s1`` (on a closed line ``s1`` may pass its length) to the chord between
        the line's points at ``s0`` and ``s1``: how far that output edge leaves the line."""
        loop, a, b, seg, cum, closed = self.geo[li]
        length = float(cum[-1])
        if closed:
            shift = math.floor(s0 / length) * length
            s0, s1 = s0 - shift, s1 - shift
            arcs = np.concatenate([cum[:-1], cum[:-1] + length])
            verts = np.concatenate([a, a])
        else:
            arcs = cum
            verts = np.concatenate([a, b[-1:]])
        inside = (arcs > s0) & (arcs < s1)
        if not inside.any():
            return 0.0
        (x0, x1), _, _, _ = self.locate(li, np.array([s0, s1]))
        d = x1 - x0
        X = self.P0[verts[inside]] - x0
        t = np.clip(X @ d / max(float(d @ d), 1e-300), 0.0, 1.0)
        return float(np.linalg.norm(X - t[:, None] * d, axis=1).max())

    def room(self, v: int, alive: np.ndarray):
        """(back, ahead): how far the point in slot ``v`` may slide along its line before it
        meets the next output vertex on the line (another point, or one of the line's input
        vertices still in the output, ``alive`` by slot)."""
        i = self.row[v]
        li = int(self.line[i])
        loop, a, b, seg, cum, closed = self.geo[li]
        length = float(cum[-1])
        verts = np.concatenate([a, b[-1:]]) if not closed else a
        arcs = cum if not closed else cum[:-1]
        occ = np.concatenate([self.s[(self.line == li) & (np.arange(self.s.size) != i)], arcs[alive[verts]]])
        s = self.s[i]
        if closed:
            gap = np.mod(occ - s, length)
            gap = gap[gap > 0]
            if gap.size == 0:
                return 0.5 * length, 0.5 * length
            return float(length - gap.max()), float(gap.min())
        back = s - occ[occ < s]
        ahead = occ[occ > s] - s
        return (float(back.min()) if back.size else float(s),
                float(ahead.min()) if ahead.size else float(length - s))


#: the worst-triangle step: the movable vertices of faces below this quality are moved to
#: the point of the input surface, among candidates around them, that maximises the smallest
#: quality of their faces (0.4: a margin over the 0.3 target)
_WORST_QUALITY = 0.4
#: candidates: this many directions in the tangent plane, at these fractions of the
#: vertex's mean edge length (and the centroid of its link)
_WORST_DIRECTIONS = 12
_WORST_STEPS = (0.04, 0.1, 0.2, 0.35)
_WORST_ROUNDS = 10
#: faces still below _COLLAPSE_QUALITY after that: a second round with these steps and
#: directions, the old vertices the removal left movable too, and this turn limit
_FAR_STEPS = _WORST_STEPS + (0.5, 0.7, 1.0)
_FAR_DIRECTIONS = 24
_FAR_TURN = _RELAX_TURN
#: a crease point slides at most this fraction of the way to the next vertex on its line
_SLIDE_ROOM = 0.9
#: a crease point's candidates: these fractions of its mean edge length either way along
#: the line (further than the 2-D steps: it has no other direction to go; fandisk@2% seeds
#: 2 and 3 reach 0.36 and 0.31 with the two longer steps, 0.29 and 0.31 without)
_SLIDE_STEPS = _WORST_STEPS + (0.5, 0.7)


def _improve_worst(P2, F, n0: int, nX: int, surf, P0, F0, all_face, all_w, rounds: int,
                   slider: LineSlider | None = None, free_old=None, old_at=None, limit: float = _WORST_QUALITY,
                   steps=_WORST_STEPS, directions: int = _WORST_DIRECTIONS,
                   turn: float = _RELAX_TURN, stuck: bool = False) -> tuple[int, int]:
    """The worst-triangle step (lodkit's addition, the last step of remeshers, Botsch and
    Kobbelt 2004): ``rounds`` rounds that each take the new interior points (slots n0 ..
    n0 + nX - 1 of ``P2``, in place) on faces of quality below _WORST_QUALITY, worst star
    first and no two on one face, and move each to the candidate that maximises the smallest
    quality of its faces: points around it in its tangent plane and its link's centroid,
    projected onto the input surface.  A candidate that turns one of its faces by more than
    _RELAX_TURN degrees is refused; a point moves only when its worst face gets better.
    Connectivity is unchanged; old vertices stay.  Crease and boundary points (``slider``,
    a :class:`LineSlider`; None: they stay too) slide along their line or loop instead: their
    candidates are points of the line ahead and behind (_SLIDE_STEPS of the mean edge
    length, and half-way between the next output vertices on the line), never past those.
    ``all_face`` / ``all_w`` (rows 0 .. nX - 1, and the crease points' rows) follow the
    moved points.  ``free_old`` ((n,) bool or None): old vertices the removal left that may
    move too, like new points (not copies of a split vertex, boundary corners or crease
    vertices); ``old_at`` = (faces (n0,), weights (n0, 3)) records where they went (face -1:
    not moved).  ``stuck``: a vertex that found no better candidate is not taken again until
    a neighbour moves (else it is taken first every round, and the neighbours it shares a
    face with never are).  Returns (moves made, of them crease points slid)."""
    F = np.asarray(F, dtype=np.int64)
    n = P2.shape[0]
    movable, _ = _new_interior_points(F, n, n0, nX, free_old)
    slides = np.zeros(n, dtype=bool)
    if slider is not None and slider.slots.size:
        slides[slider.slots] = True
    _, alive, start, vface = _sweep_state(P2, F)           # faces of v: vface[start[v]:start[v + 1]]
    cos_turn = math.cos(math.radians(turn))
    ang = 2.0 * math.pi * np.arange(directions) / directions
    unit = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    ring = np.concatenate([unit * s for s in steps])                   # (K - 1, 2)
    along = np.concatenate([-np.asarray(_SLIDE_STEPS), np.asarray(_SLIDE_STEPS)])
    moves = slid = 0
    held = np.zeros(n, dtype=bool)
    for _ in range(rounds):
        q = triangle_quality(P2, F)
        verts = np.unique(F[q < limit].reshape(-1))
        verts = verts[(movable[verts] | slides[verts]) & ~held[verts]]
        if verts.size == 0:
            break
        worst = np.array([q[vface[start[v]:start[v + 1]]].min() for v in verts])
        taken = np.zeros(n, dtype=bool)
        chosen = []
        for v in verts[np.argsort(worst, kind="stable")]:
            star = F[vface[start[v]:start[v + 1]]].reshape(-1)
            if not taken[star].any():
                taken[star] = True
                chosen.append(int(v))
        normals, area = face_normals(P2, F)
        cands = []
        line_cands = {}
        for v in chosen:
            fs = vface[start[v]:start[v + 1]]
            if slides[v]:
                # 1-D: along the crease line, within the room to the next vertices on it
                link = np.unique(F[fs].reshape(-1))
                link = link[link != v]
                h = float(np.linalg.norm(P2[link] - P2[v], axis=1).mean())
                back, ahead = slider.room(v, alive)
                ds = np.concatenate([h * along, [0.5 * (ahead - back)]])
                ds = ds[(ds > -_SLIDE_ROOM * back) & (ds < _SLIDE_ROOM * ahead)]
                i = slider.row[v]
                line_cands[v] = slider.locate(int(slider.line[i]), slider.s[i] + ds)
                continue
            nv = (normals[fs] * area[fs, None]).sum(axis=0)
            nv /= max(float(np.linalg.norm(nv)), 1e-300)
            a = np.cross(nv, [1.0, 0.0, 0.0] if abs(nv[0]) < 0.9 else [0.0, 1.0, 0.0])
            a /= np.linalg.norm(a)
            b = np.cross(nv, a)
            link = np.unique(F[fs].reshape(-1))
            link = link[link != v]
            h = float(np.linalg.norm(P2[link] - P2[v], axis=1).mean())
            c = P2[link].mean(axis=0)
            c -= float(np.dot(c - P2[v], nv)) * nv
            cands.append(np.concatenate([P2[v] + h * (ring[:, :1] * a + ring[:, 1:] * b), c[None]]))
        if cands:
            k = cands[0].shape[0]
            face, w, _ = surf.closest(np.concatenate(cands))
            Y = np.einsum("nk,nkj->nj", w, P0[F0[face]])
        r = -1
        for v in chosen:
            fs = vface[start[v]:start[v + 1]]
            if slides[v]:
                Yv, face_v, w_v, s_v = line_cands[v]
                if Yv.shape[0] == 0:
                    held[v] = stuck
                    continue
            else:
                r += 1
                Yv, face_v, w_v = Y[r * k:(r + 1) * k], face[r * k:(r + 1) * k], w[r * k:(r + 1) * k]
            qs, ok = _star_candidates(P2, F[fs], v, Yv, normals[fs], cos_turn)
            score = np.where(ok, qs.min(axis=1), -1.0)
            best = int(np.argmax(score))
            held[v] = stuck
            if score[best] > q[fs].min() + 1e-6:
                held[F[fs].reshape(-1)] = False
                P2[v] = Yv[best]
                if v < n0:
                    old_at[0][v] = face_v[best]
                    old_at[1][v] = w_v[best]
                else:
                    all_face[v - n0] = face_v[best]
                    all_w[v - n0] = w_v[best]
                moves += 1
                if slides[v]:
                    slider.s[slider.row[v]] = s_v[best]
                    slid += 1
    return moves, slid


def _moved_star(P2, faces, v: int, Y):
    """The corners of the faces ``faces`` ((f, 3) slots of ``P2``) with vertex ``v`` at each
    of the positions ``Y`` (k, 3): (k, f, 3, 3)."""
    T = np.broadcast_to(P2[faces], (Y.shape[0], faces.shape[0], 3, 3)).copy()
    T[:, faces == v] = Y[:, None]
    return T


def _star_candidates(P2, faces, v: int, Y, normals, cos_turn: float):
    """Vertex ``v`` of the faces ``faces`` ((f, 3) slots of ``P2``) tried at each of the
    positions ``Y`` (k, 3): (the faces' qualities (k, f), whether no face turns from its
    unit normal ``normals`` (f, 3) by more than acos(cos_turn) nor degenerates (k,))."""
    T = _moved_star(P2, faces, v, Y)
    cr = np.cross(T[:, :, 1] - T[:, :, 0], T[:, :, 2] - T[:, :, 0])
    sq = ((T[:, :, 1] - T[:, :, 0]) ** 2 + (T[:, :, 2] - T[:, :, 1]) ** 2
          + (T[:, :, 0] - T[:, :, 2]) ** 2).sum(axis=2)
    twice = np.linalg.norm(cr, axis=2)
    qs = np.divide(2.0 * math.sqrt(3.0) * twice, sq, out=np.zeros_like(sq), where=sq > 0)
    ok = (np.einsum("kfj,fj->kf", cr, normals) >= cos_turn * twice).all(axis=1) & (twice > 0).all(axis=1)
    return qs, ok


#: the crease points' relaxation (lodkit's addition): candidates along the line at these
#: fractions of the point's mean edge length either way, and the arc-length midpoint of its
#: line neighbours
_SLIDE_RELAX_STEPS = (0.05, 0.1, 0.2, 0.35)
_SLIDE_RELAX_ALONG = np.concatenate([-np.asarray(_SLIDE_RELAX_STEPS), np.asarray(_SLIDE_RELAX_STEPS)])
#: a slide may leave the point's worst face no worse than min(before, this)
_SLIDE_RELAX_FLOOR = _WORST_QUALITY
#: ... nor its faces further from the input than max(before, this fraction of its mean
#: edge length) (fandisk@10 %, pass fixed: Hausdorff 20.8 -> 30.6x QEM's without the test,
#: 21.5x with it)
_SLIDE_RELAX_ERR = 0.02
#: sweeps over the crease points per relaxation round
_SLIDE_SWEEPS = 2


def _sweep_state(P2, F):
    """What a sweep over points reads: the faces (int64), which slots are live and each
    slot's faces (``vface[start[v]:start[v + 1]]``)."""
    F = np.asarray(F, dtype=np.int64)
    n = P2.shape[0]
    corners = F.reshape(-1)
    alive = np.zeros(n, dtype=bool)
    alive[corners] = True
    order = np.argsort(corners, kind="stable")
    start = np.searchsorted(corners[order], np.arange(n + 1))
    return F, alive, start, order // 3


def _mean_edge(P2, star, v: int) -> float:
    """The mean length of the edges from ``v`` to the other corners of its faces ``star``."""
    link = np.unique(star.reshape(-1))
    link = link[link != v]
    return float(np.linalg.norm(P2[link] - P2[v], axis=1).mean())


def _slide_to(P2, F, fs, normals, v: int, i: int, slider: LineSlider, y, face, w, s, all_face, all_w, n0: int):
    """Move line point ``v`` (the ``i``-th of ``slider``) to ``y`` on its line, at arc length
    ``s`` and barycentric ``w`` in input face ``face``; its faces ``fs``' normals follow."""
    P2[v] = y
    all_face[v - n0] = face
    all_w[v - n0] = w
    slider.s[i] = s
    normals[fs] = face_normals(P2, F[fs])[0]


def _slide_relax(P2, F, slider: LineSlider, surf, all_face, all_w, n0: int) -> int:
    """One sweep of the crease points' relaxation along their crease lines (lodkit's
    addition; interleaved with :func:`_relax`'s rounds): each crease point of ``slider``, in
    turn, is tried at points of its line (_SLIDE_RELAX_STEPS of its mean edge length ahead
    and behind, and the arc-length midpoint of its neighbours on the line; never past
    _SLIDE_ROOM of the way to them, so the order along the line and the crease edges stay).
    A candidate is refused when a face turns by more than _RELAX_TURN degrees, the worst
    face ends below min(before, _SLIDE_RELAX_FLOOR), or a centroid or edge midpoint of the
    faces ends further from the input ``surf`` than max(before, _SLIDE_RELAX_ERR of the mean
    edge length).  The point moves to the candidate with the largest mean quality of its
    faces (the largest smallest quality when a face is below _WORST_QUALITY) if that beats
    the current one.  Connectivity is unchanged; ``all_face`` / ``all_w`` (rows slot - n0)
    and ``slider.s`` follow.  Returns the moves made."""
    F, alive, start, vface = _sweep_state(P2, F)
    normals = face_normals(P2, F)[0]
    moves = 0
    for i, v in enumerate(slider.slots.tolist()):
        if not alive[v] or slider.boundary[i]:
            continue
        fs = vface[start[v]:start[v + 1]]
        h = _mean_edge(P2, F[fs], v)
        back, ahead = slider.room(v, alive)
        ds = np.concatenate([h * _SLIDE_RELAX_ALONG, [0.5 * (ahead - back)]])
        ds = ds[(ds > -_SLIDE_ROOM * back) & (ds < _SLIDE_ROOM * ahead) & (ds != 0.0)]   # exact: 0 is no move
        if ds.size == 0:
            continue
        Y, face, w, s_new = slider.locate(int(slider.line[i]), slider.s[i] + ds)
        q0 = triangle_quality(P2, F[fs])
        qs, ok = _star_candidates(P2, F[fs], v, Y, normals[fs], _COS_RELAX_TURN)
        # the star's faces may not leave the input surface further than before: their
        # centroids and edge midpoints, now and at each candidate
        T = _moved_star(P2, F[fs], v, np.concatenate([P2[v][None], Y]))
        S = np.concatenate([T.mean(axis=2)[:, :, None], 0.5 * (T + T[:, :, [1, 2, 0]])], axis=2)
        err = surf.distance(S.reshape(-1, 3)).reshape(Y.shape[0] + 1, -1).max(axis=1)
        ok &= err[1:] <= max(float(err[0]), _SLIDE_RELAX_ERR * h) + 1e-9 * h
        ok &= qs.min(axis=1) >= min(float(q0.min()), _SLIDE_RELAX_FLOOR)
        if float(q0.min()) < _WORST_QUALITY:
            score = np.where(ok, qs.min(axis=1), -1.0)
            cur = float(q0.min())
        else:
            score = np.where(ok, qs.mean(axis=1), -1.0)
            cur = float(q0.mean())
        best = int(np.argmax(score))
        if score[best] > cur + 1e-6:
            _slide_to(P2, F, fs, normals, v, i, slider, Y[best], face[best], w[best], s_new[best], all_face, all_w, n0)
            moves += 1
    return moves


#: sweeps of the boundary points' relaxation per relaxation round
_BOUNDARY_SWEEPS = 2


def _slide_boundary(P2, F, slider: LineSlider, all_face, all_w, n0: int) -> int:
    """One sweep of the boundary points' relaxation along their boundary loops (lodkit's
    addition): each boundary point of ``slider``, in turn, is tried at points of its loop
    (_SLIDE_RELAX_STEPS of its mean edge length ahead and behind, never past _SLIDE_ROOM of
    the way to its neighbours on the loop, so their order stays) and moves to the one where
    its two boundary edges leave the input's loop least (:meth:`LineSlider.deviation`), if
    that is less than now, no face turns by more than _RELAX_TURN degrees and its worst face
    gets no worse.  Connectivity is unchanged;
    ``all_face`` / ``all_w`` (rows slot - n0) and ``slider.s`` follow.  Returns the moves."""
    F, alive, start, vface = _sweep_state(P2, F)
    normals = face_normals(P2, F)[0]
    moves = 0
    for i, v in enumerate(slider.slots.tolist()):
        if not alive[v] or not slider.boundary[i]:
            continue
        fs = vface[start[v]:start[v + 1]]
        h = _mean_edge(P2, F[fs], v)
        back, ahead = slider.room(v, alive)
        ds = h * _SLIDE_RELAX_ALONG
        ds = ds[(ds > -_SLIDE_ROOM * back) & (ds < _SLIDE_ROOM * ahead)]
        if ds.size == 0:
            continue
        li = int(slider.line[i])
        s0 = float(slider.s[i])
        Y, face, w, s_new = slider.locate(li, s0 + ds)
        q0 = triangle_quality(P2, F[fs])
        qs, ok = _star_candidates(P2, F[fs], v, Y, normals[fs], _COS_RELAX_TURN)
        ok &= qs.min(axis=1) >= float(q0.min())
        if not ok.any():
            continue
        lo, hi = s0 - back, s0 + ahead
        dev0 = max(slider.deviation(li, lo, s0), slider.deviation(li, s0, hi))
        dev = np.array([max(slider.deviation(li, lo, s0 + d), slider.deviation(li, s0 + d, hi)) if good else np.inf
                        for d, good in zip(ds.tolist(), ok.tolist())])
        best = int(np.argmin(dev))
        if dev[best] < dev0 * (1.0 - 1e-3):
            _slide_to(P2, F, fs, normals, v, i, slider, Y[best], face[best], w[best], s_new[best], all_face, all_w, n0)
            moves += 1
    return moves


#: the sliver collapses: faces below this quality (the issue's target) get their free
#: vertices collapsed into a neighbour when that raises the smallest quality around them
_COLLAPSE_QUALITY = 0.3
_COLLAPSE_ROUNDS = 4


def _collapse_slivers(P2, F, n0: int, nX: int, free_old, group, crease_vertex) -> tuple[np.ndarray, int]:
    """Faces still below _COLLAPSE_QUALITY after the worst-triangle step (lodkit's addition):
    a free vertex of such a face -- a new interior point, or an old vertex ``free_old`` marks
    -- is collapsed into the neighbour that leaves the best smallest quality over the two
    stars, when that beats the smallest quality before, no remaining face turns by more than
    _RELAX_TURN degrees, the link condition holds and (``group``, :func:`_copy_groups`) no
    vertex ends next to two copies of one input vertex.  The vertex goes; its neighbour
    stays where it is, on the surface.  Crease and boundary vertices never go.  Returns
    (the faces, collapses made)."""
    F = np.asarray(F, dtype=np.int64)
    n = P2.shape[0]
    movable, _ = _new_interior_points(F, n, n0, nX, free_old)
    if crease_vertex is not None:
        movable &= crease_vertex[:n] == 0
    q = triangle_quality(P2, F)
    if not (q < _COLLAPSE_QUALITY).any():
        return F, 0
    hm = build(np.ascontiguousarray(F, dtype=np.int32), n)
    cos_turn = _COS_RELAX_TURN
    corners_all = np.asarray(hm.corners)
    done = 0
    for _ in range(_COLLAPSE_ROUNDS):
        Fa = np.asarray(hm.faces(), dtype=np.int64)
        q = triangle_quality(P2, Fa)
        bad = np.argsort(q, kind="stable")
        bad = bad[q[bad] < _COLLAPSE_QUALITY]
        changed = False
        for f in bad.tolist():
            alive = np.asarray(hm.alive_vertices, dtype=bool)
            if not alive[Fa[f]].all():
                continue
            best, best_key = None, None
            for u in Fa[f].tolist():
                if not movable[u]:
                    continue
                link, slots, _closed = hm.star(u)
                cu = corners_all[np.asarray(slots, dtype=np.int64)]
                for v in sorted(set(int(x) for x in link)):
                    if not hm.can_collapse(u, v):
                        continue
                    if group is not None and not _collapse_keeps_copies_apart(hm, u, v, group):
                        continue
                    _lv, slots_v, _c = hm.star(v)
                    cv = corners_all[np.asarray(slots_v, dtype=np.int64)]
                    before = min(float(triangle_quality(P2, cu).min()), float(triangle_quality(P2, cv).min()))
                    new, n_old, n_new = _star_after_collapse(P2, cu, u, v)
                    l_old = np.linalg.norm(n_old, axis=1)
                    l_new = np.linalg.norm(n_new, axis=1)
                    if not (l_new > 0).all() or \
                            (np.einsum("ij,ij->i", n_old, n_new) < cos_turn * l_old * l_new).any():
                        continue
                    rest = cv[~(cv == u).any(axis=1)]
                    after = min(float(triangle_quality(P2, new).min()) if new.size else 1.0,
                                float(triangle_quality(P2, rest).min()) if rest.size else 1.0)
                    if after > before + 1e-6 and (best_key is None or after > best_key):
                        best, best_key = (u, v), after
            if best is not None:
                hm.collapse_edge(*best)
                done += 1
                changed = True
        if not changed:
            break
    return np.ascontiguousarray(hm.faces(), dtype=np.int32), done


#: the sliver splits: the longest edge of a face below _COLLAPSE_QUALITY is tried split at
#: these fractions of its length (the point projected onto the input surface)
_SPLIT_AT = (0.3, 0.4, 0.5, 0.6, 0.7)


def _split_slivers(P2, F, surf, P0, F0, group, crease_vertex=None, on_edge: bool = False):
    """Faces still below _COLLAPSE_QUALITY (lodkit's addition): the longest edge a-b of each,
    worst first, is split by a new vertex m on the input surface (the closest point to a
    point of the edge, _SPLIT_AT) when the four new faces' smallest quality beats the two
    old faces', none of them turns by more than _RELAX_TURN degrees from the face it
    replaces and (``group``, :func:`_copy_groups`) m is not next to two copies of one input
    vertex.  An edge split keeps the topology.  When a and b are both ``crease_vertex``
    vertices (None: none are) m is one too (else the moves, collapses and flips after
    would take the crease edges a-m and m-b apart).  ``on_edge``: where no point of the
    input surface makes the four faces better (an edge across the rim of a sheet thinner
    than it: the surface points near its middle lie on one side of the sheet), m may be a
    point of the edge itself; the four faces then cover the two old ones exactly, so the
    re-tiling's surface and its distances to the input do not change, but m lies off the
    input surface (by at most the two faces' distance to it).  The new vertices' input faces
    and weights are those of the surface points nearest them.  Returns (``P2`` with the new
    vertices appended, the faces (int32), the new vertices' input faces (k,) and
    barycentric weights (k, 3), whether each is a crease vertex (k,) bool, splits made)."""
    F = np.asarray(F, dtype=np.int64).copy()
    cos_turn = _COS_RELAX_TURN
    at = np.asarray(_SPLIT_AT)
    sub = np.array([[0, 4, 2], [4, 1, 2], [1, 4, 3], [4, 0, 3]])      # of (a, b, c, d, m)
    added_f, added_w, added_crease = [], [], []
    n_in = P2.shape[0]
    P = P2
    tried = set()
    while True:
        q = triangle_quality(P, F)
        order = np.argsort(q, kind="stable")
        split = False
        for f in order[q[order] < _COLLAPSE_QUALITY].tolist():
            T = P[F[f]]
            i = int(np.argmax(np.linalg.norm(T[[1, 2, 0]] - T, axis=1)))
            a, b, c = int(F[f, i]), int(F[f, (i + 1) % 3]), int(F[f, (i + 2) % 3])
            if (a, b) in tried:
                continue
            tried.add((a, b))
            g = np.flatnonzero((F == a).any(axis=1) & (F == b).any(axis=1))
            g = g[g != f]
            if g.size != 1:
                continue                      # a boundary edge (or a non-manifold one)
            g = int(g[0])
            d = int(F[g][(F[g] != a) & (F[g] != b)][0])
            if group is not None and max(c, d) < group.size and group[c] >= 0 and group[c] == group[d]:
                continue                      # m would join two copies (a vertex added here is none)
            chord = P[a] + at[:, None] * (P[b] - P[a])
            face, w, _ = surf.closest(chord)
            old = np.array([[a, b, c], [b, a, d]])
            n_old = face_normals(P, old)[0][[0, 0, 1, 1]]
            q_old = float(triangle_quality(P, old).min()) + 1e-6
            # the points of the input surface nearest the edge's; where none makes the four
            # faces better (the edge spans the rim of a sheet thinner than it: the nearest
            # surface point lies on one side) and ``on_edge``, the edge's own points, which
            # subdivide the two faces without changing the surface
            Y = np.einsum("nk,nkj->nj", w, P0[F0[face]])
            best = _best_split(P, a, b, c, d, Y, sub, n_old, cos_turn, q_old)
            if best < 0 and on_edge:
                Y = chord
                best = _best_split(P, a, b, c, d, Y, sub, n_old, cos_turn, q_old)
            if best < 0:
                continue
            m = P.shape[0]
            P = np.concatenate([P, Y[best:best + 1]])
            F[f] = [a, m, c]
            F[g] = [b, m, d]
            F = np.concatenate([F, [[m, b, c], [m, a, d]]])
            added_f.append(int(face[best]))
            added_w.append(w[best])
            added_crease.append(crease_vertex is not None
                                and all(crease_vertex[x] if x < n_in else added_crease[x - n_in] for x in (a, b)))
            split = True
            break
        if not split:
            break
    return (P, np.ascontiguousarray(F, dtype=np.int32), np.asarray(added_f, dtype=np.int64),
            np.asarray(added_w, dtype=np.float64).reshape(-1, 3), np.asarray(added_crease, dtype=bool), len(added_f))


def _best_split(P, a: int, b: int, c: int, d: int, Y, sub, n_old, cos_turn: float, q_old: float) -> int:
    """Of the points ``Y`` for splitting edge a-b (faces a b c and b a d), the one whose four
    faces ``sub`` have the largest smallest quality above ``q_old``, none degenerate nor
    turned from its old face's normal (``n_old``, one row per new face) by more than
    acos(``cos_turn``); -1 if none."""
    best, best_q = -1, q_old
    for k in range(Y.shape[0]):
        Pm = np.concatenate([P[[a, b, c, d]], Y[k:k + 1]])
        n_sub, area = face_normals(Pm, sub)
        if not (area > 0).all() or (np.einsum("ij,ij->i", n_sub, n_old) < cos_turn).any():
            continue
        qk = float(triangle_quality(Pm, sub).min())
        if qk > best_q:
            best, best_q = k, qk
    return best


#: the untangling of the kept pass: at most this many rounds of moves, collapses, splits and
#: flips while a face is below _COLLAPSE_QUALITY
_UNTANGLE_ROUNDS = 8


def _untangle(P2, F, n0: int, nX: int, surf, P0, F0, all_face, all_w, free_old, old_at, group, crease_vertex,
              cos_flip: float, cos_crease: float, on_edge: bool = False):
    """What is left below _COLLAPSE_QUALITY on the pass ``refine`` keeps (lodkit's addition;
    cow's pinch, docs/retile.md): rounds of the wide worst-triangle step (``stuck``: a vertex
    that cannot improve no longer blocks its neighbours), the sliver collapses, the sliver
    splits (:func:`_split_slivers`) and the sliver flips (faces within acos(``cos_flip``),
    worse triangle below _WORST_QUALITY), until no face is below _COLLAPSE_QUALITY or
    nothing changes.  Each operation raises the smallest quality of what it touches, so the
    worst face never gets worse.  ``all_face`` / ``all_w`` hold one row per new vertex (slot
    - n0); the split vertices are appended to ``P2`` and to them (and to ``free_old``,
    ``group`` and ``crease_vertex``, which may be None); ``on_edge``: a split may keep its
    vertex on the split edge (:func:`_split_slivers`; with ``fit``, whose vertices leave the
    surface anyway).  Returns (P2, F, all_face, all_w, moves, collapses, splits, flips)."""
    moves = collapses = splits = flips = 0
    n_rows = P2.shape[0] - n0
    all_face, all_w = all_face[:n_rows], all_w[:n_rows]
    for k in range(_UNTANGLE_ROUNDS):
        more, _ = _improve_worst(P2, F, n0, nX, surf, P0, F0, all_face, all_w, _WORST_ROUNDS, None, free_old,
                                 old_at, _COLLAPSE_QUALITY, _FAR_STEPS, _FAR_DIRECTIONS, _FAR_TURN, stuck=True)
        moves += more
        if k == _UNTANGLE_ROUNDS - 1 or float(triangle_quality(P2, F).min()) >= _COLLAPSE_QUALITY:
            break
        F_c, n_c = _collapse_slivers(P2, F, n0, nX, free_old, group, crease_vertex)
        if n_c:
            F = F_c
        P2, F, s_face, s_w, s_crease, n_s = _split_slivers(P2, F, surf, P0, F0, group, crease_vertex, on_edge)
        if n_s:
            all_face = np.concatenate([all_face, s_face])
            all_w = np.concatenate([all_w, s_w])
            free_old = np.concatenate([free_old, ~s_crease])           # a crease vertex stays
            if group is not None:
                group = np.ascontiguousarray(np.concatenate([group, np.full(n_s, -1)]), dtype=np.intc)
            if crease_vertex is not None:
                crease_vertex = np.concatenate([crease_vertex, s_crease.astype(np.uint8)])
        F = np.ascontiguousarray(F, dtype=np.int32)
        n_f = int(kern.flip_edges(P2, F, face_twins(F), cos_flip, 20, crease_vertex, _WORST_QUALITY, cos_crease,
                                  group=group))
        collapses += n_c
        splits += n_s
        flips += n_f
        if not (n_c or n_s or n_f):
            break
    return P2, F, all_face, all_w, moves, collapses, splits, flips


#: fit: a vertex moves by at most this fraction of its mean edge length in all
_FIT_MAX = 0.25


def _fit_normal(P2, F, n0: int, nX: int, surf, normals0, rounds: int) -> int:
    """``fit`` (lodkit's addition, not Turk's): ``rounds`` rounds that move each new interior
    point (slots n0 .. n0 + nX - 1 of ``P2``, in place) along its vertex normal so that the
    re-tiling straddles the input instead of lying on one side of it.  The signed distances
    (output minus input, along the input's normal) of the samples on a vertex's faces --
    their centroids and edge midpoints to the input, the input's vertices to them -- span
    [lo, hi]; the vertex moves by -(lo + hi) / 4 (half-way to the centre of the span, as its
    neighbours move too), at most _FIT_MAX of its mean edge length from the surface in all.
    A move that turns one of its faces by more than _RELAX_TURN degrees or leaves one below
    _RELAX_QUALITY that was above it is undone.  Returns the vertices moved."""
    F = np.asarray(F, dtype=np.int64)
    n = P2.shape[0]
    movable, e = _new_interior_points(F, n, n0, nX)
    idx = np.flatnonzero(movable & np.isin(np.arange(n), F))
    if idx.size == 0 or rounds < 1:
        return 0
    import open3d as o3d

    corners = F.reshape(-1)
    el = np.linalg.norm(P2[e[:, 0]] - P2[e[:, 1]], axis=1)
    deg = np.bincount(e.reshape(-1), minlength=n)
    mean_edge = np.bincount(e.reshape(-1), weights=np.repeat(el, 2), minlength=n) / np.maximum(deg, 1)
    origin = P2[idx].copy()
    V0 = surf.V
    cos_turn = _COS_RELAX_TURN
    for _ in range(rounds):
        normals, area = face_normals(P2, F)
        q_before = triangle_quality(P2, F)
        vn = np.zeros((n, 3))
        for k in range(3):
            vn[:, k] = np.bincount(corners, weights=np.repeat(normals[:, k] * area, 3), minlength=n)
        ln = np.linalg.norm(vn, axis=1, keepdims=True)
        vn = np.divide(vn, ln, out=np.zeros_like(vn), where=ln > 0)
        # output samples to the input: (x - closest) . input normal
        S = np.concatenate([P2[F].mean(axis=1), 0.5 * (P2[F] + P2[F[:, [1, 2, 0]]]).reshape(-1, 3)])
        s_face = np.concatenate([np.arange(F.shape[0]), np.repeat(np.arange(F.shape[0]), 3)])
        fi, w, _ = surf.closest(S)
        cp = np.einsum("nk,nkj->nj", w, V0[surf.F[fi]])
        d = np.einsum("ij,ij->i", S - cp, normals0[fi])
        # input vertices to the output: (closest - y) . input normal at y (its face's)
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor(P2.astype(np.float32)), o3d.core.Tensor(F.astype(np.uint32)))
        res = scene.compute_closest_points(o3d.core.Tensor(V0.astype(np.float32)))
        vf = np.full(V0.shape[0], -1, dtype=np.int64)
        vf[surf.F.reshape(-1)] = np.repeat(np.arange(surf.F.shape[0]), 3)
        ok = vf >= 0
        d_in = np.einsum("ij,ij->i", res["points"].numpy().astype(np.float64)[ok] - V0[ok], normals0[vf[ok]])
        d = np.concatenate([d, d_in])
        s_face = np.concatenate([s_face, res["primitive_ids"].numpy().astype(np.int64)[ok]])
        hi = np.full(n, -np.inf)
        lo = np.full(n, np.inf)
        for k in range(3):
            np.maximum.at(hi, F[s_face, k], d)
            np.minimum.at(lo, F[s_face, k], d)
        step = -0.25 * (hi[idx] + lo[idx])
        step[~np.isfinite(step)] = 0.0
        old = P2[idx].copy()
        new = old + step[:, None] * vn[idx]
        off = new - origin
        lim = _FIT_MAX * mean_edge[idx]
        big = np.linalg.norm(off, axis=1) > lim
        new[big] = origin[big] + off[big] * (lim[big] / np.linalg.norm(off[big], axis=1))[:, None]
        P2[idx] = new
        moved = np.ones(idx.size, dtype=bool)
        at = np.full(n, -1, dtype=np.int64)
        at[idx] = np.arange(idx.size)
        while True:
            n_after, _ = face_normals(P2, F)
            q_after = triangle_quality(P2, F)
            bad = (np.einsum("ij,ij->i", n_after, normals) < cos_turn) | \
                  ((q_after < _RELAX_QUALITY) & (q_after < q_before))
            rows = at[F[bad].reshape(-1)]
            rows = rows[(rows >= 0)]
            rows = rows[moved[rows]]
            if rows.size == 0:
                break
            P2[idx[rows]] = old[rows]
            moved[rows] = False
    return int(np.count_nonzero(np.linalg.norm(P2[idx] - origin, axis=1) > 0))


def _equalizing_density(P, F, area, edge_len: float) -> np.ndarray:
    """(m,) density weight per face for ``equalize``: the curvature of the input's vertices
    among their neighbours within the uniform target edge length (a scan's noise at its own
    vertex spacing would drive a k-nearest estimate), over its area-weighted mean, floored
    at _EQ_FLOOR and capped at the _EQ_CAP percentile (a few spikes would take the budget).
    A linear density keeps the chord error, edge^2 * curvature / 8, the same everywhere."""
    from .curvature import point_curvature

    kf = point_curvature(P, radius=edge_len)[F].mean(axis=1)
    mean = float(np.average(kf, weights=area)) if area.sum() > 0 else 0.0
    if not mean > 0:
        return np.ones(F.shape[0])
    c = kf / mean
    return np.maximum(np.minimum(c, np.percentile(c, _EQ_CAP)), _EQ_FLOOR)


def _error_density(weight, area, P0, F0, P, F, surf) -> tuple[np.ndarray, float]:
    """The density of the next ``refine`` pass: ``weight`` (m,) times the local error of the
    re-tiling (P, F) over its area-weighted mean, to the _REFINE_POWER, within
    [1 / _REFINE_CLAMP, _REFINE_CLAMP], rescaled so that sum(area * weight) stays (and with
    it the target edge length).  Chord error grows as edge^2 * curvature (edge * angle
    across a crease), so on smooth parts a density ~ error evens it out.

    The error is measured both ways, like the Hausdorff distance: the input's vertices and
    face centroids to the re-tiling, and the re-tiling's face centroids and edge midpoints to
    the input.  It is gathered on the re-tiling's vertices (the largest error of the samples
    on their faces), spread over their one-ring (the largest, then the mean: the scale of the
    local edge length), and read back on the input faces at their closest points.
    Returns (the new weight, the largest distance seen, either way: a Hausdorff estimate)."""
    import open3d as o3d

    used = np.unique(F)
    Fc = np.searchsorted(used, F)
    V = np.ascontiguousarray(P[used])
    n = V.shape[0]
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)), o3d.core.Tensor(Fc.astype(np.uint32)))
    Q = np.concatenate([P0, P0[F0].mean(axis=1)]).astype(np.float32)
    res = scene.compute_closest_points(o3d.core.Tensor(Q))
    d_in = np.linalg.norm(res["points"].numpy().astype(np.float64) - Q, axis=1)
    f_in = res["primitive_ids"].numpy().astype(np.int64)
    err = np.zeros(n)
    for k in range(3):
        np.maximum.at(err, Fc[f_in, k], d_in)
    # the other way: points of the re-tiling to the input
    C = V[Fc].mean(axis=1)
    M = 0.5 * (V[Fc] + V[Fc[:, [1, 2, 0]]])
    d_out = np.maximum(surf.distance(C), surf.distance(M.reshape(-1, 3)).reshape(-1, 3).max(axis=1))
    for k in range(3):
        np.maximum.at(err, Fc[:, k], d_out)
    # one-ring: the largest, then the mean
    a = Fc.reshape(-1)
    b = Fc[:, [1, 2, 0]].reshape(-1)
    ring = err.copy()
    np.maximum.at(ring, a, err[b])
    np.maximum.at(ring, b, err[a])
    deg = np.bincount(a, minlength=n) + np.bincount(b, minlength=n) + 1.0
    err = (ring + np.bincount(a, weights=ring[b], minlength=n) + np.bincount(b, weights=ring[a], minlength=n)) / deg
    e_face = err[Fc[f_in[P0.shape[0]:]]].mean(axis=1)           # at each input face's centroid
    ref = float(np.average(e_face, weights=area))
    if not ref > 0:
        return weight, max(float(d_in.max()), float(d_out.max()))
    fac = np.clip((e_face / ref) ** _REFINE_POWER, 1.0 / _REFINE_CLAMP, _REFINE_CLAMP)
    new = weight * fac
    new *= float((area * weight).sum()) / float((area * new).sum())
    return new, max(float(d_in.max()), float(d_out.max()))


def _count(name: str, value, lo: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lo:
        raise OptionError(f"{name} must be an integer >= {lo}, got {value!r}")
    return int(value)


def _sample(weights: np.ndarray, n: int, rng) -> tuple[np.ndarray, np.ndarray]:
    """(face (n,), barycentric weights (n, 3)): faces drawn with probability ~ weights,
    uniform points in them."""
    cdf = np.cumsum(weights)
    idx = np.searchsorted(cdf, rng.random(n) * cdf[-1], side="right")
    idx = np.minimum(idx, weights.size - 1)
    r1 = np.sqrt(rng.random(n))
    r2 = rng.random(n)
    return idx, np.stack([1.0 - r1, r1 * (1.0 - r2), r1 * r2], axis=1)


def _off_edges(w: np.ndarray) -> np.ndarray:
    w = np.maximum(w, _EDGE_MARGIN)
    return w / w.sum(axis=1, keepdims=True)


def face_twins(F: np.ndarray) -> np.ndarray:
    """(3 m,) int32 twin of each half-edge h = 3 f + i (running F[f, i] -> F[f, i+1]); -1 on
    the boundary and on edges that are not shared by exactly one opposite pair."""
    F = np.asarray(F, dtype=np.int64)
    m = F.shape[0]
    if m == 0:
        return np.zeros(0, dtype=np.intc)
    src = F.reshape(-1)
    dst = F[:, [1, 2, 0]].reshape(-1)
    n = int(F.max()) + 1
    key = src * n + dst
    order = np.argsort(key, kind="stable")
    sk = key[order]
    dup_sorted = np.zeros(sk.size, dtype=bool)
    same = sk[1:] == sk[:-1]
    dup_sorted[1:] |= same
    dup_sorted[:-1] |= same
    dup = np.empty_like(dup_sorted)
    dup[order] = dup_sorted
    rkey = dst * n + src
    pos = np.minimum(np.searchsorted(sk, rkey), sk.size - 1)
    cand = order[pos]
    ok = (sk[pos] == rkey) & ~dup & ~dup[cand]
    return np.ascontiguousarray(np.where(ok, cand, -1), dtype=np.intc)


def _boundary_loops(F: np.ndarray, twins: np.ndarray) -> list[np.ndarray]:
    """Boundary loops as arrays of half-edge ids, in order (the half-edge arrays of a
    prepared mesh are manifold: each boundary vertex starts one boundary half-edge)."""
    bh = np.flatnonzero(twins < 0)
    if bh.size == 0:
        return []
    Ff = F.reshape(-1)
    start = Ff[bh]
    end = Ff[3 * (bh // 3) + (bh % 3 + 1) % 3]
    by_start = {int(s): int(h) for s, h in zip(start, bh)}
    seen = set()
    loops = []
    for h0, e in zip(bh, end):
        h0 = int(h0)
        if h0 in seen:
            continue
        loop = [h0]
        seen.add(h0)
        h = by_start.get(int(e))
        while h is not None and h not in seen:
            seen.add(h)
            loop.append(h)
            h = by_start.get(int(Ff[3 * (h // 3) + (h % 3 + 1) % 3]))
        loops.append(np.asarray(loop, dtype=np.int64))
    return loops


def _boundary_points(P, F, loops, spacing, rng, corner_angle, open_lines=(), hscale=None):
    """Points along each boundary loop (and crease line): its corners (vertices where the
    line turns by more than ``corner_angle`` degrees; an open line's two ends) stay as they
    are, the stretches between them get points spread evenly by arc length (a loop without
    corners: random phase).  Returns (points (b, 3), face (b,), barycentric weights (b, 3),
    corner vertex slots (c,), half-edge (b,), parameter along it (b,)).  ``hscale`` (3 m,),
    per half-edge: the spacing there is ``spacing / hscale`` (the points are spread evenly in
    the length scaled by it); None: 1 everywhere."""
    pts, faces, ws, corners, hs, ts = [], [], [], [], [], []
    Ff = F.reshape(-1)
    cos_corner = math.cos(math.radians(corner_angle))
    for loop, closed in [(x, True) for x in loops] + [(x, False) for x in open_lines]:
        a = Ff[loop]
        b = Ff[3 * (loop // 3) + (loop % 3 + 1) % 3]
        d = P[b] - P[a]
        seg = np.linalg.norm(d, axis=1)
        length = float(seg.sum())
        if not length > 0:
            continue
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        # the scaled length (even spacing in it: the local spacing in the true length)
        wcum = cum if hscale is None else np.concatenate([[0.0], np.cumsum(seg * hscale[loop])])
        wlength = float(wcum[-1])
        if not closed:
            corners.append(np.array([a[0], b[-1]]))
            k = int(round(wlength / spacing))
            if k < 2:
                continue
            s = np.arange(1, k) * (wlength / k)
            s = [s]
            cidx = np.zeros(0, dtype=np.int64)
        else:
            cidx = _corners(P[a], cum, length, spacing, cos_corner)
            s = []
        for c0, c1 in zip(cidx, np.r_[cidx[1:], cidx[:1] + loop.size]) if closed else ():
            s0, s1 = wcum[c0], wcum[c1] if c1 <= loop.size else wcum[c1 - loop.size] + wlength
            k = int(round((s1 - s0) / spacing))             # stretches, k - 1 inner points
            if k >= 2:
                s.append(np.mod(s0 + np.arange(1, k) * ((s1 - s0) / k), wlength))
        if closed and cidx.size + sum(x.size for x in s) < 3:     # no corners, or too few points
            k = max(3, int(round(wlength / spacing)))
            s = [(np.arange(k) + rng.random()) * (wlength / k)]
        elif closed:
            corners.append(a[cidx])
            if not s:
                continue
        s = np.interp(np.concatenate(s), wcum, cum)                   # back to the true length
        n = s.size
        e = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, loop.size - 1)
        tpar = np.clip((s - cum[e]) / np.where(seg[e] > 0, seg[e], 1.0), 0.02, 0.98)
        h = loop[e]
        f = h // 3
        i = h % 3
        w = np.zeros((n, 3))
        w[np.arange(n), i] = 1.0 - tpar
        w[np.arange(n), (i + 1) % 3] = tpar
        faces.append(f)
        ws.append(w)
        hs.append(h)
        ts.append(tpar)
        pts.append(np.einsum("nk,nkj->nj", w, P[F[f]]))
    cs = np.unique(np.concatenate(corners)).astype(np.int64) if corners else np.zeros(0, dtype=np.int64)
    if not pts:
        z = np.zeros(0, dtype=np.int64)
        return np.zeros((0, 3)), z, np.zeros((0, 3)), cs, z, np.zeros(0)
    return (np.concatenate(pts), np.concatenate(faces), np.concatenate(ws), cs, np.concatenate(hs),
            np.concatenate(ts))


def _corners(pts, cum, length, spacing, cos_corner):
    """Loop indices of the corners of a boundary loop (vertices ``pts`` at arc lengths
    ``cum[:-1]``): the turn is measured between the chords to the points half a
    ``spacing`` back and ahead along the loop (so the zig-zag of a scanned boundary is not
    a corner), corners are turns sharper than acos(cos_corner), strongest first, at least
    ``spacing`` apart along the loop."""
    k = pts.shape[0]
    if k < 3:
        return np.zeros(0, dtype=np.int64)
    h = min(0.5 * spacing, length / 4.0)
    s = cum[:-1]
    ext_s = np.concatenate([s - length, s, s + length, [2.0 * length]])
    ext_p = np.concatenate([pts, pts, pts, pts[:1]])

    def at(x):
        return np.stack([np.interp(x, ext_s, ext_p[:, j]) for j in range(3)], axis=1)

    back = pts - at(s - h)
    ahead = at(s + h) - pts
    lb = np.linalg.norm(back, axis=1)
    la = np.linalg.norm(ahead, axis=1)
    ok = (lb > 0) & (la > 0)
    cos_turn = np.ones(k)
    cos_turn[ok] = np.einsum("ij,ij->i", back[ok], ahead[ok]) / (lb[ok] * la[ok])
    cand = np.flatnonzero(cos_turn < cos_corner)
    chosen = []
    for i in cand[np.argsort(cos_turn[cand], kind="stable")]:
        if all(min(abs(s[i] - s[j]), length - abs(s[i] - s[j])) >= spacing for j in chosen):
            chosen.append(int(i))
    return np.asarray(sorted(chosen), dtype=np.int64)


def crease_edges(P, F, twins, cos_limit, min_length: float = 0.0):
    """The interior edges of (P, F) whose two faces' unit normals have a dot product below
    ``cos_limit``, once each (the half-edge of the pair with the smaller number; ``twins``
    from :func:`face_twins`): (half-edges, their start vertices, their end vertices).
    ``min_length`` > 0: only the connected networks of such edges at least that long in
    total (a scan's noise makes many short "creases"; a CAD part's are long)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n, _ = face_normals(P, F)
    h = np.arange(twins.size)
    t = np.asarray(twins)
    sel = (t > h) & (np.einsum("ij,ij->i", n[h // 3], n[np.maximum(t, 0) // 3]) < cos_limit)
    hc = h[sel]
    Ff = F.reshape(-1)
    a, b = Ff[hc], Ff[3 * (hc // 3) + (hc % 3 + 1) % 3]
    if min_length > 0 and hc.size:
        m = P.shape[0]
        _, comp = connected_components(coo_matrix((np.ones(a.size), (a, b)), shape=(m, m)), directed=False)
        total = np.bincount(comp[a], weights=np.linalg.norm(P[a] - P[b], axis=1), minlength=m)
        keep = total[comp[a]] >= min_length
        hc, a, b = hc[keep], a[keep], b[keep]
    return hc, a, b


def _crease_lines(P, F, twins, cos_feature):
    """Crease lines: chains of interior edges whose two faces' normals differ by more than
    acos(cos_feature), in networks at least CREASE_MIN_LENGTH of the bbox diagonal long, split
    at vertices where other than two crease edges meet.  Returns (open lines, closed loops),
    each an array of half-edges in walking order."""
    diag = float(np.linalg.norm(P.max(axis=0) - P.min(axis=0)))
    hc, a, b = crease_edges(P, F, twins, cos_feature, CREASE_MIN_LENGTH * diag)
    if hc.size == 0:
        return [], []
    t = np.asarray(twins)
    adj = {}
    for e, (x, y) in enumerate(zip(a.tolist(), b.tolist())):
        adj.setdefault(x, []).append(e)
        adj.setdefault(y, []).append(e)
    used = np.zeros(hc.size, dtype=bool)

    def walk(x, e):
        out = []
        while True:
            used[e] = True
            if a[e] == x:
                out.append(int(hc[e]))
                y = int(b[e])
            else:
                out.append(int(t[hc[e]]))           # the twin runs x -> y
                y = int(a[e])
            nxt = [g for g in adj[y] if not used[g]]
            if len(adj[y]) != 2 or not nxt:
                return out
            x, e = y, nxt[0]

    lines, loops = [], []
    for x, es in adj.items():
        if len(es) != 2:
            for e in es:
                if not used[e]:
                    lines.append(np.asarray(walk(x, e), dtype=np.int64))
    for e in range(hc.size):
        if not used[e]:
            loops.append(np.asarray(walk(int(a[e]), e), dtype=np.int64))
    return lines, loops


def _boundary_samples(P, F, loops, step):
    """(k, 3) points along the boundary loops, at most ``step`` apart."""
    Ff = F.reshape(-1)
    out = []
    for loop in loops:
        a = P[Ff[loop]]
        b = P[Ff[3 * (loop // 3) + (loop % 3 + 1) % 3]]
        n = np.maximum(1, np.ceil(np.linalg.norm(b - a, axis=1) / step).astype(np.int64))
        seg = np.repeat(np.arange(loop.size), n)
        t = (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n, n)
        out.append(a[seg] + t[:, None] * (b[seg] - a[seg]))
    return np.concatenate(out)


def _copy_groups(slot_input) -> np.ndarray:
    """(n,) intc: each slot's input vertex where that vertex has several slots (the copies
    the half-edge build cut a non-manifold vertex into), else -1."""
    slot_input = np.asarray(slot_input, dtype=np.int64)
    split = np.bincount(slot_input)[slot_input] > 1
    return np.ascontiguousarray(np.where(split, slot_input, -1), dtype=np.intc)


def _joins_copies(F, twins, h, group) -> np.ndarray:
    """(len(h),) bool: a point on the interior half-edge h (running a -> b, faces (a, b, c)
    and (b, a, d)) would be next to c and d: are they copies of one input vertex?"""
    Ff = np.asarray(F).reshape(-1)
    t = np.asarray(twins)[h]
    c = Ff[3 * (h // 3) + (h % 3 + 2) % 3]
    d = Ff[3 * (np.maximum(t, 0) // 3) + (np.maximum(t, 0) % 3 + 2) % 3]
    return (t >= 0) & (group[c] >= 0) & (group[c] == group[d])


def _collapse_keeps_copies_apart(hm, u: int, v: int, group: np.ndarray) -> bool:
    """Would collapsing u into v leave no vertex next to two copies of one input vertex (nor
    two copies joined)?  ``group`` as :func:`_copy_groups` (-1: not a copy)."""
    nu = {int(x) for x in hm.star(u)[0]} - {v}
    nv = {int(x) for x in hm.star(v)[0]} - {u}
    gv = int(group[v])
    gs = [int(group[x]) for x in nu | nv if group[x] >= 0]
    if len(gs) != len(set(gs)) or (gv >= 0 and gv in gs):
        return False
    if gv >= 0:                       # u's neighbours join v: none may be next to another copy
        for x in nu - nv:
            if any(group[w] == gv and w != v for w in (int(y) for y in hm.star(x)[0])):
                return False
    return True


def _star_after_collapse(P, corners, u: int, v: int):
    """u's faces ``corners`` (k, 3) when u collapses into its neighbour v: (those that stay,
    with u replaced by v; their normals before; after)."""
    old = corners[~(corners == v).any(axis=1)]
    new = np.where(old == u, v, old)
    n_old = np.cross(P[old[:, 1]] - P[old[:, 0]], P[old[:, 2]] - P[old[:, 0]])
    n_new = np.cross(P[new[:, 1]] - P[new[:, 0]], P[new[:, 2]] - P[new[:, 0]])
    return new, n_old, n_new


def _collapse_leftovers(hm, P, n0: int, fixed: np.ndarray, group: np.ndarray | None = None) -> int:
    """Old vertices the removal rounds held back (typically at a sharp tip the new points
    do not resolve): collapse each into a neighbour -- a new vertex first, the nearest
    first -- when the link condition holds, no remaining face flips or degenerates and
    (``group``: the copies of a non-manifold input vertex, :func:`_copy_groups`) no vertex
    ends next to two copies of one input vertex.  Returns the number of collapses."""
    done = 0
    changed = True
    while changed:
        changed = False
        alive = np.asarray(hm.alive_vertices, dtype=bool)
        for u in np.flatnonzero(alive[:n0] & (fixed[:n0] == 0)):
            u = int(u)
            link, slots, _closed = hm.star(u)
            corners = np.asarray(hm.corners)[np.asarray(slots, dtype=np.int64)]
            best, best_key = -1, None
            for v in set(int(x) for x in link):
                if not hm.can_collapse(u, v):
                    continue
                if group is not None and not _collapse_keeps_copies_apart(hm, u, v, group):
                    continue
                new, n_old, n_new = _star_after_collapse(P, corners, u, v)
                if (np.einsum("ij,ij->i", n_old, n_new) <= 0).any():
                    continue
                q = float(triangle_quality(P, new).min()) if new.size else 1.0
                if not q > 0.0:
                    continue
                key = (q >= _FALLBACK_QUALITY and v >= n0, q)        # a new vertex first, then quality
                if best_key is None or key > best_key:
                    best, best_key = v, key
            if best >= 0:
                hm.collapse_edge(u, best)
                done += 1
                changed = True
    return done


def _tessellate(F0: np.ndarray, n0: int, face: np.ndarray, w: np.ndarray, pid: np.ndarray) -> np.ndarray:
    """The faces of ``F0`` with each new point entry p (vertex n0 + pid[p], on face
    ``face[p]`` at barycentric ``w[p]``; a point on an edge has an entry for each face)
    inserted: a point inside a local triangle splits it in three, a
    point on a local edge splits the triangle(s) on that edge in two each."""
    order = np.argsort(face, kind="stable")
    fs = face[order]
    starts = np.flatnonzero(np.r_[True, fs[1:] != fs[:-1]]) if fs.size else np.zeros(0, dtype=np.int64)
    ends = np.r_[starts[1:], fs.size]
    keep = np.ones(F0.shape[0], dtype=bool)
    extra = []
    for s, e in zip(starts, ends):
        f = int(fs[s])
        keep[f] = False
        ids = order[s:e]
        # local vertices: the 3 corners (2D coordinates = the last two barycentric weights)
        uv = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)]
        gid = [int(F0[f, 0]), int(F0[f, 1]), int(F0[f, 2])]
        tris = [[0, 1, 2]]
        for p in ids:
            uv.append((float(w[p, 1]), float(w[p, 2])))
            gid.append(n0 + int(pid[p]))
            _insert(uv, tris, len(uv) - 1)
        extra.extend([[gid[a], gid[b], gid[c]] for a, b, c in tris])
    out = np.concatenate([F0[keep], np.asarray(extra, dtype=np.int32).reshape(-1, 3)])
    return np.ascontiguousarray(out, dtype=np.int32)


def _insert(uv, tris, p) -> None:
    x, y = uv[p]
    best, best_t, best_l = -np.inf, -1, None
    for t, (a, b, c) in enumerate(tris):
        (ax, ay), (bx, by), (cx, cy) = uv[a], uv[b], uv[c]
        det = (bx - ax) * (cy - ay) - (cx - ax) * (by - ay)
        if det <= 0:
            continue
        l1 = ((x - ax) * (cy - ay) - (cx - ax) * (y - ay)) / det
        l2 = ((bx - ax) * (y - ay) - (x - ax) * (by - ay)) / det
        lam = (1.0 - l1 - l2, l1, l2)
        m = min(lam)
        if m > best:
            best, best_t, best_l = m, t, lam
    a, b, c = tris[best_t]
    if best > 1e-9:
        tris[best_t] = [a, b, p]
        tris.append([b, c, p])
        tris.append([c, a, p])
        return
    k = int(np.argmin(best_l))                  # p is on the edge opposite corner k
    tri = tris[best_t]
    x0, y0, z0 = tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]     # edge y0 -> z0
    tris[best_t] = [x0, y0, p]
    tris.append([x0, p, z0])
    for t, other in enumerate(tris):            # the local triangle across the edge, if any
        for i in range(3):
            if other[i] == z0 and other[(i + 1) % 3] == y0:
                w0 = other[(i + 2) % 3]
                tris[t] = [z0, p, w0]
                tris.append([p, y0, w0])
                return
