"""``simplify(..., polish=True)``: fit the output's vertex positions to the input surface.

An edge collapse places each vertex where its quadric is smallest: the point nearest (in the
least-squares sense, area-weighted) to the planes of the input faces it stands for.  On a
curved surface those are tangent planes, and the best place for a vertex is not on them:
the output's faces are chords, and a chord is nearest the surface on average when its ends
sit outside a convex arc (inside a concave one).  For an arc of radius R and a vertex
spacing of angle t the quadric's point is R (1 + t^2/24) from the centre and the chords'
best R (1 + t^2/12): every vertex of a smooth region is placed about half as far out as it
should be, by an amount the quadric cannot see, since it knows the planes, not the faces
the vertex will end up with.  This step, run once on the final mesh, measures exactly that:
the distance of points of the input to the faces of the output.

Each round (docs/algorithms.md, "Polish"):

1. Every sample of the input (area-weighted, a fixed seed) is matched to the closest point
   of the output (the face by Embree through Open3D, the point on it in double
   precision); a sample whose input normal opposes that face's normal (the other side of
   a thin sheet) is left out.
2. The vertex positions minimise the weighted sum over the samples of the squared
   distance from the sample to the plane of its face, through its matched point's
   barycentric weights (point-to-plane: a vertex may slide along the surface without
   cost, the regulariser below holds it), plus lambda |v - v_now|^2 per vertex. The
   weights are those of iteratively reweighted least squares for the mean distance
   (1 / max(|d|, delta), d the sample's distance now, delta a tenth of the RMS one): the
   step lowers the mean error, which the quadric's squared one does not measure, and a
   flat face that is exact stays exact.  A conjugate-gradient solve (Jacobi
   preconditioned) from the current positions.
3. A vertex moves at most as far as the RMS distance of the samples on its faces (the
   leash: with few samples a vertex could otherwise fly off to pull them in), and a move
   that would leave any of its faces turned by more than ~45 degrees (cos < 0.7) from the
   run's output is undone, with its neighbours', until none does.

Vertices that must stay put do not move: locked vertices, the fixed ones of the run
(non-manifold copies, the boundary under ``boundary="lock"``), boundary vertices (a
point-to-plane fit would let a border slide outwards) and vertices that share their
position with another (attribute-seam copies, which must stay together).  Faces,
connectivity and attributes are left as the run made them.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from ._core.retile import closest_on_faces, polish_sums
from .adapters import coerce
from .errors import MeshError, OptionError
from .evaluate import sample_surface
from .geometry import face_normals
from .io import load
from .retile import SurfaceProjector, face_twins
from .settings import locked_mask

__all__ = ["DEFAULT_ROUNDS", "PolishResult", "polish_mesh", "polish_positions", "resolve_polish"]

#: rounds of ``polish=True``
DEFAULT_ROUNDS = 3
# samples of the input: this many per output face, at least the input's vertex count ...
_SAMPLES_PER_FACE = 10
# ... (this times the input's vertex count at least) and within these bounds
_FLOOR_INPUT_VERTICES = 1
_MIN_SAMPLES, _MAX_SAMPLES = 10_000, 2_000_000
# the regulariser: this times the vertex's summed sample weight (holds its tangential slide)
_LAMBDA = 1e-3
# the IRLS floor: delta = this times the samples' RMS distance
_IRLS_FLOOR = 0.1
# a vertex moves at most this times the RMS distance of the samples on its faces
_LEASH = 1.0
# a move that turns one of its faces' normals to a cosine below this is undone
_TURN_COS = 0.7
# the sample seed
_SEED = 0
# the solve: each round re-linearises, so a loose tolerance does
_CG_RTOL, _CG_ITERATIONS = 1e-6, 200


@dataclasses.dataclass
class PolishResult:
    """What :func:`polish_mesh` returns: the mesh (the type ``simplified`` came in) and
    the report ``simplify(polish=True)`` puts in ``report["polish"]``."""

    mesh: Any
    report: dict


def polish_mesh(original, simplified, *, rounds: int = DEFAULT_ROUNDS, locked=None) -> PolishResult:
    """Fit ``simplified``'s vertices to ``original``'s surface: the step of
    ``simplify(polish=True)`` for any simplified mesh (a progressive mesh's level, another
    tool's output).  Faces and attributes stay; boundary vertices, vertices sharing a
    position and ``locked`` ones (a bool mask or indices into ``simplified``'s vertices)
    do not move.  ``original`` and ``simplified``: any mesh type lodkit reads, or paths.

    Raises MeshError for an unusable mesh, OptionError for bad options."""
    n_rounds = resolve_polish(rounds)
    src, _ = coerce(original, "original", load=load)
    out, back = coerce(simplified, "simplified", load=load)
    if src.n_faces == 0 or out.n_faces == 0:
        raise MeshError("polish_mesh needs faces in both meshes")
    fixed = np.zeros(out.n_vertices, dtype=bool) if locked is None else locked_mask(locked, out.n_vertices)
    V, report = polish_positions(src.vertices, src.faces, out.vertices, out.faces, fixed, rounds=n_rounds)
    return PolishResult(mesh=back(dataclasses.replace(out, vertices=V)), report=report)


def resolve_polish(polish) -> int:
    """The rounds ``polish`` stands for: False / 0 -> 0, True -> DEFAULT_ROUNDS, an int >= 0."""
    if polish is None or polish is False:
        return 0
    if polish is True:
        return DEFAULT_ROUNDS
    if isinstance(polish, np.bool_):
        return DEFAULT_ROUNDS if polish else 0
    if isinstance(polish, (int, np.integer)) and 0 <= int(polish) <= 100:
        return int(polish)
    raise OptionError(f"polish must be True, False or a number of rounds in 0..100, got {polish!r}")


def _fixed_vertices(V: np.ndarray, F: np.ndarray, fixed: np.ndarray, border: np.ndarray) -> np.ndarray:
    """``fixed`` or ``border`` or sharing its position with another vertex, or unreferenced."""
    out = np.array(fixed, dtype=bool, copy=True) | border
    order = np.lexsort((V[:, 2], V[:, 1], V[:, 0]))
    same = np.all(V[order[1:]] == V[order[:-1]], axis=1)          # a sorted row equal to the next
    out[order[1:][same]] = True
    out[order[:-1][same]] = True
    used = np.zeros(V.shape[0], dtype=bool)
    used[F.ravel()] = True
    return out | ~used                                          # unreferenced: nothing to fit


def _edge_neighbours(F: np.ndarray, n: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """((faces, 3): the face across each edge (corners k, k+1), the face itself where the
    edge has no twin (retile.face_twins: a border, a non-manifold edge, or two faces that
    disagree on its direction); (n,) bool: the vertices of such edges, which polish holds)."""
    m = F.shape[0]
    n = int(F.max()) + 1 if n is None else n
    twin = face_twins(F)
    across = np.where(twin >= 0, twin // 3, np.repeat(np.arange(m), 3))
    border = np.zeros(n, dtype=bool)
    open_ = np.flatnonzero(twin < 0)
    border[F.reshape(-1)[open_]] = True
    border[F[:, [1, 2, 0]].reshape(-1)[open_]] = True
    return across.reshape(m, 3).astype(np.int64), border


class _Blocks:
    """The block sparsity of the normal equations: a BSR matrix's indptr and indices, its
    number of blocks and where each row's diagonal block is."""

    def __init__(self, indptr, indices, diagonal):
        self.indptr, self.indices, self.diagonal = indptr, indices, diagonal
        self.nnzb = int(indices.size)


def _block_structure(cf: np.ndarray, n_free: int):
    """(_Blocks, and for each (face, a, b) with both corners free: face, a, b, its block)."""
    both = (cf[:, :, None] >= 0) & (cf[:, None, :] >= 0)
    pair_face, pair_a, pair_b = np.nonzero(both)
    key = cf[pair_face, pair_a] * np.int64(n_free) + cf[pair_face, pair_b]
    # every vertex's diagonal block too (a free vertex of no face keeps its lambda)
    diag_key = np.arange(n_free, dtype=np.int64) * (n_free + 1)
    uniq, inverse = np.unique(np.concatenate([key, diag_key]), return_inverse=True)
    pair_block = inverse[:key.size]
    rows = uniq // n_free
    indptr = np.zeros(n_free + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=n_free), out=indptr[1:])
    return _Blocks(indptr, (uniq % n_free).astype(np.int64), inverse[key.size:]), pair_face, pair_a, pair_b, pair_block


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """A dot product by numpy's own pairwise sum, not BLAS: OpenBLAS splits long dot
    products over its threads, so their last bits would depend on the machine's thread
    count (np.dot, and scipy's cg, which uses it)."""
    return float(np.add.reduce(a * b))


def _solve_cg(K, b, x0, diag):
    """Conjugate gradients with the Jacobi preconditioner, its reductions by :func:`_dot`:
    the same bits for any thread count of the BLAS library (a test).  Stops at a relative
    residual of _CG_RTOL or after _CG_ITERATIONS."""
    x = x0.copy()
    r = b - K @ x
    tol2 = (_CG_RTOL * _CG_RTOL) * _dot(b, b)
    z = r / diag
    p = z.copy()
    rz = _dot(r, z)
    for _ in range(_CG_ITERATIONS):
        if _dot(r, r) <= tol2 or not rz > 0.0:
            break
        Kp = K @ p
        pKp = _dot(p, Kp)
        if not pKp > 0.0:
            break
        alpha = rz / pKp
        x += alpha * p
        r -= alpha * Kp
        z = r / diag
        rz_next = _dot(r, z)
        p = z + (rz_next / rz) * p
        rz = rz_next
    return x


def polish_positions(V0: np.ndarray, F0: np.ndarray, V: np.ndarray, F: np.ndarray,
                     fixed: np.ndarray, rounds: int = DEFAULT_ROUNDS) -> tuple[np.ndarray, dict]:
    """Fit (V, F)'s free vertices to the surface (V0, F0); (new V, report).

    V0, F0 : the input surface; V, F: the output mesh; fixed: (len(V),) bool, vertices that
    must not move (more are held: see the module's docstring).  Deterministic: the same
    input gives the same output (fixed samples, a fixed number of sweeps)."""
    from scipy.sparse import bsr_matrix

    V0 = np.asarray(V0, dtype=np.float64)
    F0 = np.asarray(F0, dtype=np.int64)
    F = np.asarray(F, dtype=np.int64)
    n = V.shape[0]
    # the mean distances: of the samples to the output, as a fraction of the input's diagonal
    report = {"rounds": 0, "samples": 0, "moved_vertices": 0, "held_vertices": 0,
              "mean_distance_before": 0.0, "mean_distance_after": 0.0}
    if rounds <= 0 or n == 0 or F.shape[0] == 0 or F0.shape[0] == 0:
        return np.array(V, dtype=np.float64, copy=True), report
    # normalised units: the input's bbox centre at the origin, diagonal 1
    used = np.zeros(V0.shape[0], dtype=bool)
    used[F0.ravel()] = True
    lo, hi = V0[used].min(axis=0), V0[used].max(axis=0)
    center, scale = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
    if not (scale > 0.0 and math.isfinite(scale)):
        return np.array(V, dtype=np.float64, copy=True), report
    X0 = (V0 - center) / scale
    X = (np.asarray(V, dtype=np.float64) - center) / scale
    across, border = _edge_neighbours(F, n)
    hold = _fixed_vertices(X, F, fixed, border)
    free = np.flatnonzero(~hold)
    report["held_vertices"] = int(hold.sum())
    if free.size == 0:
        return np.array(V, dtype=np.float64, copy=True), report
    ns = min(max(_SAMPLES_PER_FACE * F.shape[0], _FLOOR_INPUT_VERTICES * V0.shape[0], _MIN_SAMPLES),
                        _MAX_SAMPLES)
    n_in_all, area_in = face_normals(X0, F0)
    total = float(area_in.sum())
    if not (total > 0.0 and math.isfinite(total)):
        return np.array(V, dtype=np.float64, copy=True), report      # no surface to fit to
    P, sface, _ = sample_surface(X0, F0, int(ns), seed=_SEED)
    # in the input's face order (the draws come in random order): the passes over the samples
    # then walk the output's faces and vertices in about the order the input lists its own
    by_face = np.argsort(sface, kind="stable")
    P, sface = P[by_face], sface[by_face]
    n_in = n_in_all[sface]
    report["samples"] = int(P.shape[0])
    # the unknowns: 3 per free vertex
    col_of = np.full(n, -1, dtype=np.int64)
    col_of[free] = np.arange(free.size)
    start = X.copy()
    N_start = face_normals(X, F)[0]        # no face turns further than _TURN_COS from these
    first_mean = None
    last = None
    # the block structure of the normal equations (fixed connectivity: once), each face's free
    # corner pairs (a, b) and the block they add to
    cf = col_of[F]                                        # (faces, 3): the unknown of a corner, -1 held
    blocks, pair_face, pair_a, pair_b, pair_block = _block_structure(cf, free.size)
    face = None
    N_out = N_start                      # the normals of X, kept up to date below
    for _ in range(rounds):
        local = face is not None
        if not local:
            face = SurfaceProjector(X, F).closest(P)[0]
        # one pass over the samples (native): each matched to its face (after the first round:
        # the nearest of its last face and the three across its edges), the IRLS weights and
        # the sums below
        mean_d, C, r, own, sq, ws, stand, kept = polish_sums(P, n_in, X, F, N_out, face, across, local, _IRLS_FLOOR)
        last = face
        if first_mean is None:
            first_mean = float(mean_d)
        if kept == 0 or not float(sq.sum()) > 0.0:
            break
        # a move may not turn a face against the input surface its samples stand for
        facing = np.einsum("ij,ij->i", N_out, stand) > 0.0
        # the normal equations, summed per output face: a face's samples share its normal n, so
        # their rows add up to C = sum sw w w^T (3 x 3, w the barycentric weights) and
        # r = sum sw w (n . p) (polish_sums); the blocks of K are C[a, b] n n^T
        nv = np.einsum("fj,fkj->fk", N_out, X[F])             # n . v of each corner
        r = r - np.einsum("fab,fb->fa", C, np.where(cf < 0, nv, 0.0))   # held corners: known
        NN = N_out[:, :, None] * N_out[:, None, :]
        # K's 3 x 3 blocks (free a, free b), summed per block by one bincount per entry
        data = np.empty((blocks.nnzb, 3, 3))
        cpair = C[pair_face, pair_a, pair_b]
        for i in range(3):
            for j in range(3):
                data[:, i, j] = np.bincount(pair_block, cpair * NN[pair_face, i, j], minlength=blocks.nnzb)
        # lambda per vertex: a share of its summed sample weight (at least the mean's)
        fr = cf >= 0
        wsum = np.bincount(cf[fr], own[fr], minlength=free.size)
        if not float(wsum.sum()) > 0.0:
            break                                         # no free vertex has a sample
        lam = _LAMBDA * np.maximum(wsum, float(wsum.mean()))
        lam3 = np.repeat(lam, 3)
        data[blocks.diagonal] += lam[:, None, None] * np.eye(3)
        K = bsr_matrix((data, blocks.indices, blocks.indptr), shape=(3 * free.size, 3 * free.size))
        ax = np.arange(3)
        fa, aa = np.nonzero(fr)
        b = np.bincount((3 * cf[fa, aa][:, None] + ax).reshape(-1), (r[fa, aa][:, None] * N_out[fa]).reshape(-1),
                        minlength=3 * free.size) + lam3 * X[free].reshape(-1)
        x = _solve_cg(K, b, X[free].reshape(-1), data[blocks.diagonal][:, ax, ax].reshape(-1))
        if not np.all(np.isfinite(x)):
            break
        Y = X.copy()
        Y[free] = x.reshape(-1, 3)
        # the leash: at most the RMS distance of the samples on the vertex's faces
        lim = _LEASH * np.sqrt(sq / np.maximum(ws, 1e-300))
        step = Y - X
        length = np.linalg.norm(step, axis=1)
        over = length > lim
        step[over] *= (lim[over] / length[over])[:, None]
        Y = X + step
        # undo moves that leave a face turned too far from the run's output, with the face's other
        # corners, until none does
        for _ in range(64):
            N_new = face_normals(Y, F)[0]
            bad = np.einsum("ij,ij->i", N_new, N_start) < _TURN_COS
            bad |= facing & (np.einsum("ij,ij->i", N_new, stand) <= 0.0)
            bad &= np.any(Y[F] != X[F], axis=(1, 2))
            if not bad.any():
                break
            back = np.unique(F[bad].ravel())
            Y[back] = X[back]
        else:
            Y, N_new = X, N_out   # still a face too far after the sweeps: the round moves nothing
        X, N_out = Y, N_new
        report["rounds"] += 1
    report["mean_distance_before"] = float(first_mean if first_mean is not None else 0.0)
    # after: to the faces matched last (no new search: an upper bound of the distance to the output)
    report["mean_distance_after"] = float(np.sqrt(closest_on_faces(P, X, F, last)[1]).mean()) \
        if last is not None else report["mean_distance_before"]
    moved = np.any(X != start, axis=1)
    report["moved_vertices"] = int(moved.sum())
    out = np.asarray(V, dtype=np.float64).copy()
    out[moved] = X[moved] * scale + center
    return out, report
