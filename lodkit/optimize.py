"""``optimize()``: mesh optimisation (Hoppe, DeRose, Duchamp, McDonald & Stuetzle 1993).

Minimise over meshes M (vertex positions and connectivity) the energy

    E(M) = E_dist + E_rep + E_spring
    E_dist   = sum_i d(x_i, M)^2          x_i: points sampled on the original surface
    E_rep    = c_rep * (number of vertices)
    E_spring = kappa * sum_{edges jk} |v_j - v_k|^2

in normalised units (the original's bounding-box centre at the origin, diagonal 1), plus,
where the original has creases (Hoppe et al. 1994's sharp edges), E_crease: the squared
distances of points along the creases to the mesh edges tagged sharp.  Two nested loops,
as in the paper:

* positions (Hoppe's OptimizeVertexPositions): with every sample's closest point fixed as
  barycentric weights b_i on a face, E_dist + E_spring is a linear least-squares problem in
  the vertex positions; its normal equations (sparse, symmetric positive definite) are
  solved by scipy.sparse.linalg.spsolve, then every sample is projected again onto the
  closest point of the new mesh (Embree, through Open3D).  Each half-step lowers the
  energy (a projection can only shorten a distance).
* connectivity (OptimizeMesh): in random order, each edge is tried as a collapse, a split
  and a swap; a move is legal when it keeps the surface a manifold of the same topology and
  flips no face; its energy change is evaluated locally (the samples on the faces it
  touches are projected onto the new faces, the new vertex placed by a local fit) and the
  move is taken when it lowers E.

The energy kept (and reported per iteration) is E with each sample's distance measured to
the face it is assigned to, an upper bound of the true E that no step can raise.
``n_vertices=`` adjusts c_rep between iterations until the vertex count is reached.
docs/optimize.md gives the details and the measured figures.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._core.retile import project_local
from ._progress import Progress
from .errors import MeshError, OptionError
from .evaluate import sample_surface
from .geometry import face_normals, triangle_quality, weld_positions
from .mesh import Mesh, as_mesh, is_open3d
from .retile import CREASE_MIN_LENGTH, SurfaceProjector, crease_edges, face_twins

__all__ = ["OptimizeResult", "optimize"]

#: default c_rep (normalised units: a vertex is worth this much squared distance, summed)
DEFAULT_C_REP = 1e-5
#: default spring constant kappa
DEFAULT_SPRING = 1e-8
# local fits: projection / placement rounds for the new vertex of a collapse or split
_LOCAL_ROUNDS = 3
# a move may not make a face worse than this quality (or than the worst face it replaces)
_MIN_QUALITY = 0.1
# a move is taken when it lowers E by more than this (relative to the energy's scale)
_GAIN = 1e-12
#: default crease angle (degrees): fandisk's creases are 60-90 degrees; a scan's noise makes
#: isolated edges that steep too, which the length filter drops
DEFAULT_CREASE_ANGLE = 60.0
# a crease network (connected crease edges) shorter than retile.CREASE_MIN_LENGTH of the bbox
# diagonal is noise (at 60 degrees bunny's and igea's longest are 0.068 and 0.02; fandisk's
# one network is 8.9, cow's 7 kept 0.13-0.27)
# the weight of a crease sample's squared distance (to the sharp edges) in E
_CREASE_WEIGHT = 1.0
_NONE = np.zeros(0, dtype=np.int64)
# the positions step holds a vertex that would end farther from the original than where it
# is and than this many times the samples' RMS distance (0: off)
_LEASH = 4.0
# default samples: the original's vertices and random points up to this many per output vertex
_SAMPLES_PER_VERTEX = 100


@dataclass
class OptimizeResult:
    """What :func:`optimize` returns.

    mesh     : the optimised mesh (a lodkit.Mesh, or an open3d TriangleMesh if one was given)
    energy   : one dict per outer iteration (the first is the start): E, E_dist, E_crease,
               E_rep, E_spring, n_vertices, c_rep
    moves    : {"collapse": n, "split": n, "swap": n} moves taken
    n_samples: points sampled on the original
    n_crease_samples: points sampled along the original's creases (fitted to sharp edges)
    elapsed  : seconds
    """

    mesh: Any
    energy: list
    moves: dict
    n_samples: int
    n_crease_samples: int = 0
    elapsed: float = 0.0
    report: dict = field(default_factory=dict)

    def __repr__(self) -> str:
        e0, e1 = self.energy[0]["E"], self.energy[-1]["E"]
        return f"OptimizeResult({self.mesh!r}, E {e0:.4g} -> {e1:.4g}, moves={self.moves})"


def optimize(mesh, *, n_vertices: int | None = None, c_rep: float | None = None,
             spring: float = DEFAULT_SPRING, start=None, samples: int | None = None,
             iterations: int = 6, seed: int = 0, creases: float | None = DEFAULT_CREASE_ANGLE,
             progress: bool = False) -> OptimizeResult:
    """Hoppe et al.'s mesh optimisation of ``mesh`` (the original surface).

    n_vertices : aim for this many vertices: c_rep is adjusted between iterations (doubled
                 while there are too many vertices, halved while too few); without it c_rep
                 stays fixed
    c_rep      : the cost of a vertex (default 1e-5, or a value estimated from the start
                 mesh with ``n_vertices``)
    spring     : the spring constant kappa (>= 0)
    start      : the mesh to start from (any mesh, e.g. a QEM result); default: with
                 ``n_vertices``, lodkit.simplify's QEM result at about that count; without,
                 the original itself
    samples    : points sampled on the original (default: its vertices and as many
                 area-weighted random points again, at least 100 per output vertex, at
                 most 200 000 in all)
    iterations : outer iterations (each: positions, then one sweep of edge moves)
    seed       : for the samples and the order of the edge sweeps
    creases    : dihedral angle (degrees) above which an edge of the original is a crease
                 (Hoppe et al. 1994's sharp edges): the crease networks at least 10% of the
                 bounding-box diagonal long get their own samples, fitted to the mesh edges
                 tagged sharp along them, and no move breaks a sharp edge; None or 0: off.
                 A mesh without such creases (a smooth scan) is optimised as without it

    Raises MeshError for an unusable mesh, OptionError for bad options.
    """
    t0 = time.perf_counter()
    src, was_o3d = as_mesh(mesh), is_open3d(mesh)
    if n_vertices is not None:
        if isinstance(n_vertices, bool) or not isinstance(n_vertices, (int, np.integer)) or n_vertices < 4:
            raise OptionError(f"n_vertices must be an integer >= 4, got {n_vertices!r}")
        n_vertices = int(n_vertices)
    if c_rep is not None:
        c_rep = _nonneg("c_rep", c_rep)
    spring = _nonneg("spring", spring)
    if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)) or iterations < 0:
        raise OptionError(f"iterations must be an integer >= 0, got {iterations!r}")
    if creases is not None:
        creases = _nonneg("creases", creases)
        if not creases < 180.0:
            raise OptionError(f"creases must be an angle below 180 degrees, got {creases!r}")
    if samples is not None and (isinstance(samples, bool) or not isinstance(samples, (int, np.integer))
                                or samples < 1):
        raise OptionError(f"samples must be a positive integer, got {samples!r}")
    if src.n_faces == 0:
        raise MeshError("the mesh has no faces")
    used = np.unique(src.faces)
    lo, hi = src.vertices[used].min(axis=0), src.vertices[used].max(axis=0)
    center, scale = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
    if not scale > 0.0 or not math.isfinite(scale):
        raise MeshError("the mesh's bounding box has zero or infinite size")
    # -- the start mesh
    if start is None:
        if n_vertices is not None:
            from .api import simplify

            start_mesh = simplify(src, target_faces=max(4, 2 * n_vertices)).mesh
        else:
            start_mesh = src
    else:
        start_mesh = as_mesh(start)
    if start_mesh.n_faces == 0:
        raise MeshError("the start mesh has no faces")
    # -- samples on the original (normalised)
    Vn = (src.vertices - center) / scale
    n_rand = samples
    if n_rand is None:
        want = max(src.n_vertices, _SAMPLES_PER_VERTEX * (n_vertices or start_mesh.n_vertices))
        n_rand = int(min(max(want, src.n_vertices), 200_000))
        X = np.concatenate([Vn[used], sample_surface(Vn, src.faces, max(n_rand - used.size, 0), seed)[0]])
    else:
        X = sample_surface(Vn, src.faces, int(n_rand), seed)[0]
    spacing = _sample_spacing(Vn, src.faces, X.shape[0]) if creases else 0.0
    Xc = crease_samples(Vn, src.faces, creases, spacing) if creases else np.zeros((0, 3))
    opt = _Optimizer(start_mesh, center, scale, X, spring, np.random.default_rng(seed), Xc, spacing,
                     SurfaceProjector(Vn, src.faces))
    if c_rep is None:
        c_rep = DEFAULT_C_REP if n_vertices is None else max(opt.e_dist / max(opt.n_alive, 1), 1e-12)
    history = [opt.record(c_rep)]
    bar = Progress(iterations, enabled=progress)
    for it in range(iterations):
        opt.positions()
        opt.sweep(c_rep, n_vertices)
        opt.positions()
        history.append(opt.record(c_rep))
        if n_vertices is not None:
            n = opt.n_alive
            if n > n_vertices * 1.01:
                c_rep *= 2.0
            elif n < n_vertices * 0.99:
                c_rep *= 0.5
        bar.update(it + 1)
    bar.close()
    out = opt.mesh()
    verts = out.vertices * scale + center
    res = Mesh(verts, out.faces)
    return OptimizeResult(
        mesh=res.to_open3d() if was_o3d else res,
        energy=history,
        moves=dict(opt.moves),
        n_samples=int(X.shape[0]),
        n_crease_samples=int(opt.Xc.shape[0]),
        elapsed=time.perf_counter() - t0,
        report={"start_vertices": start_mesh.n_vertices, "start_faces": start_mesh.n_faces,
                "final_c_rep": c_rep, "spring": spring, "rejected": dict(opt.rejected),
                "sharp_edges": len(opt.sharp)},
    )


def _sample_spacing(V, F, n: int) -> float:
    """The mean spacing of n points spread over the surface (V, F): sqrt(area / n)."""
    _, area = face_normals(V, F)
    return math.sqrt(max(float(np.sum(area)), 1e-300) / max(n, 1))


def crease_samples(V: np.ndarray, F: np.ndarray, angle: float, spacing: float) -> np.ndarray:
    """(k, 3) points along the creases of (V, F), about ``spacing`` apart: the edges whose two
    faces' normals differ by more than ``angle`` degrees, in connected networks at least
    CREASE_MIN_LENGTH (of the bbox diagonal of V) long."""
    P, Fw = weld_positions(np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64))
    Fw = Fw[(Fw[:, 0] != Fw[:, 1]) & (Fw[:, 1] != Fw[:, 2]) & (Fw[:, 0] != Fw[:, 2])]
    if Fw.shape[0] < 2:
        return np.zeros((0, 3))
    diag = float(np.linalg.norm(P.max(axis=0) - P.min(axis=0)))
    hc, a, b = crease_edges(P, Fw, face_twins(Fw), math.cos(math.radians(angle)), CREASE_MIN_LENGTH * diag)
    if hc.size == 0:
        return np.zeros((0, 3))
    length = np.linalg.norm(P[a] - P[b], axis=1)
    k = np.maximum(1, np.ceil(length / max(spacing, 1e-300))).astype(np.int64)
    e = np.repeat(np.arange(a.size), k)
    first = np.repeat(np.cumsum(k) - k, k)
    tt = ((np.arange(e.size) - first) + 0.5) / k[e]
    return P[a[e]] + tt[:, None] * (P[b[e]] - P[a[e]])


def closest_on_segments(X: np.ndarray, A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each point X[i], the closest of the segments A[j] B[j]: (segment (n,), parameter t
    (n,) of the point A + t (B - A), squared distance (n,)).  Brute force in blocks."""
    n = X.shape[0]
    seg = np.zeros(n, dtype=np.int64)
    tt = np.zeros(n)
    d2 = np.full(n, np.inf)
    if n == 0 or A.shape[0] == 0:
        return seg, tt, d2
    D = B - A
    dd = np.maximum(np.einsum("ij,ij->i", D, D), 1e-300)
    block = max(1, 2_000_000 // A.shape[0])
    for s in range(0, n, block):
        x = X[s:s + block]
        r = x[:, None, :] - A[None, :, :]                                  # (b, k, 3)
        t = np.clip(np.einsum("bkj,kj->bk", r, D) / dd, 0.0, 1.0)
        q = r - t[:, :, None] * D[None, :, :]
        d = np.einsum("bkj,bkj->bk", q, q)
        j = np.argmin(d, axis=1)
        rows = np.arange(x.shape[0])
        seg[s:s + block], tt[s:s + block], d2[s:s + block] = j, t[rows, j], d[rows, j]
    return seg, tt, d2


def _nonneg(name: str, value) -> float:
    if isinstance(value, bool):
        raise OptionError(f"{name} must be a number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise OptionError(f"{name} must be a number, got {value!r}") from None
    if not (math.isfinite(x) and x >= 0):
        raise OptionError(f"{name} must be finite and >= 0, got {value!r}")
    return x


class _Optimizer:
    """The mesh being optimised: growing arrays of positions and faces with alive flags,
    vertex -> faces sets, and each sample's face, barycentric weights and squared distance.
    With crease samples: the sharp edges (vertex pairs), each vertex's sharp neighbours, and
    each crease sample's sharp edge, parameter along it and squared distance."""

    def __init__(self, start: Mesh, center, scale, X, spring: float, rng, Xc=None, spacing: float = 0.0,
                 original=None):
        F = np.asarray(start.faces, dtype=np.int64)
        keep = (F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 0] != F[:, 2])
        F = F[keep]
        used = np.unique(F)
        remap = np.full(start.n_vertices, -1, dtype=np.int64)
        remap[used] = np.arange(used.size)
        self.V = ((start.vertices[used] - center) / scale).astype(np.float64)
        self.valive = np.ones(used.size, dtype=bool)
        self.F = [list(map(int, f)) for f in remap[F]]
        self.falive = [True] * len(self.F)
        self.vf = [set() for _ in range(used.size)]
        for fi, f in enumerate(self.F):
            for v in f:
                self.vf[v].add(fi)
        self.X = np.ascontiguousarray(X, dtype=np.float64)
        self.kappa = spring
        self.rng = rng
        self.moves = {"collapse": 0, "split": 0, "swap": 0}
        self.rejected = {"illegal": 0, "energy": 0}
        self.original = original
        self.Xc = np.zeros((0, 3)) if Xc is None else np.ascontiguousarray(Xc, dtype=np.float64)
        self.sharp: set = set()
        self.sn = [set() for _ in range(used.size)]
        self.e_crease = 0.0
        if self.Xc.shape[0]:
            self.tag_sharp(spacing)
        self.project_all()

    # ------------------------------------------------------------------ bookkeeping
    @property
    def n_alive(self) -> int:
        return int(np.count_nonzero(self.valive))

    def faces_array(self) -> tuple[np.ndarray, np.ndarray]:
        ids = np.asarray([i for i, a in enumerate(self.falive) if a], dtype=np.int64)
        return ids, np.asarray([self.F[i] for i in ids], dtype=np.int64).reshape(-1, 3)

    def edges(self) -> np.ndarray:
        _, F = self.faces_array()
        e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        return np.unique(e, axis=0)

    def spring_energy(self) -> float:
        e = self.edges()
        d = self.V[e[:, 0]] - self.V[e[:, 1]]
        return float(self.kappa * np.einsum("ij,ij->", d, d))

    def record(self, c_rep: float) -> dict:
        es = self.spring_energy()
        n = self.n_alive
        return {"E": self.e_dist + self.e_crease + c_rep * n + es, "E_dist": self.e_dist,
                "E_crease": self.e_crease, "E_rep": c_rep * n, "E_spring": es, "n_vertices": n, "c_rep": c_rep}

    def mesh(self) -> Mesh:
        _, F = self.faces_array()
        used = np.flatnonzero(self.valive)
        remap = np.full(self.V.shape[0], -1, dtype=np.int64)
        remap[used] = np.arange(used.size)
        return Mesh(self.V[used], remap[F])

    def set_samples(self, sface, sw, sd2):
        self.sface, self.sw, self.sd2 = sface, sw, sd2
        self.e_dist = float(sd2.sum())
        self.fs = [[] for _ in self.F]
        order = np.argsort(sface, kind="stable")
        fsorted = sface[order]
        starts = np.flatnonzero(np.r_[True, fsorted[1:] != fsorted[:-1]])
        for s, e in zip(starts, np.r_[starts[1:], fsorted.size]):
            self.fs[int(fsorted[s])] = list(map(int, order[s:e]))

    # ------------------------------------------------------------------ sharp edges
    def tag_sharp(self, spacing: float) -> None:
        """Tag the start mesh's edges that run along the original's creases (points at 0, 1/4,
        ..., 1 of the edge within spacing + 10% of its length of a crease sample) and keep
        the crease samples whose sharp edges are about as near as the mesh itself (within
        twice their distance to the mesh plus a quarter spacing): where the start mesh cut
        across a crease, its samples have no sharp edge to be fitted to, and the nearest
        one, along another stretch, would pull the mesh out of shape."""
        from scipy.spatial import cKDTree

        e = self.edges()
        if e.shape[0] == 0:
            self.Xc = np.zeros((0, 3))
            return
        tree = cKDTree(self.Xc)
        A, B = self.V[e[:, 0]], self.V[e[:, 1]]
        L = np.linalg.norm(B - A, axis=1)
        far = np.zeros(e.shape[0])
        for t in (0.0, 0.25, 0.5, 0.75, 1.0):
            far = np.maximum(far, tree.query(A + t * (B - A))[0])
        sel = far <= spacing + 0.1 * L
        for a, b in e[sel].tolist():
            self.sharp.add((a, b))
            self.sn[a].add(b)
            self.sn[b].add(a)
        seg = e[sel]
        _, _, d2 = closest_on_segments(self.Xc, self.V[seg[:, 0]], self.V[seg[:, 1]])
        d_mesh = SurfaceProjector(self.V, self.faces_array()[1]).distance(self.Xc)
        self.Xc = np.ascontiguousarray(self.Xc[np.sqrt(d2) <= 2.0 * d_mesh + 0.25 * spacing])

    def set_creases(self, cseg, ct, cd2) -> None:
        self.cseg, self.ct, self.cd2 = cseg, ct, cd2
        self.e_crease = _CREASE_WEIGHT * float(cd2.sum())
        self.es = {}
        for i, (a, b) in enumerate(cseg.tolist()):
            self.es.setdefault((a, b) if a < b else (b, a), []).append(i)

    def _project_creases(self, C, segs):
        """Closest of the segments ``segs`` ((k, 2) vertex ids) for the crease samples C:
        (segment index (n,), parameter (n,), squared distance (n,))."""
        S = np.asarray(segs, dtype=np.int64).reshape(-1, 2)
        return closest_on_segments(self.Xc[C], self.V[S[:, 0]], self.V[S[:, 1]])

    def _crease_d2(self, V) -> np.ndarray:
        a, b = V[self.cseg[:, 0]], V[self.cseg[:, 1]]
        q = self.Xc - (a + self.ct[:, None] * (b - a))
        return np.einsum("ij,ij->i", q, q)

    def _crease_samples_at(self, keys) -> np.ndarray:
        return np.asarray([i for k in keys for i in self.es.get(k, ())], dtype=np.int64)

    # ------------------------------------------------------------------ global steps
    def project_all(self) -> None:
        """Every sample onto the closest point of the current mesh."""
        ids, F = self.faces_array()
        surf = SurfaceProjector(self.V, F)
        face, w, dist = surf.closest(self.X)
        # the distance again in double precision from the weights
        Q = np.einsum("nk,nkj->nj", w, self.V[F[face]])
        d2 = np.einsum("ij,ij->i", self.X - Q, self.X - Q)
        if hasattr(self, "sd2"):
            # never lose ground to Embree's single-precision face choice
            better = d2 <= self.sd2
            sface = np.where(better, ids[face], self.sface)
            sw = np.where(better[:, None], w, self.sw)
            d2 = np.where(better, d2, self.sd2)
        else:
            sface, sw = ids[face], w
        self.set_samples(sface, sw, d2)
        if self.Xc.shape[0]:
            segs = np.asarray(sorted(self.sharp), dtype=np.int64).reshape(-1, 2)
            j, t, cd2 = closest_on_segments(self.Xc, self.V[segs[:, 0]], self.V[segs[:, 1]])
            cseg = segs[j]
            if hasattr(self, "cd2"):
                better = cd2 <= self.cd2
                cseg = np.where(better[:, None], cseg, self.cseg)
                t = np.where(better, t, self.ct)
                cd2 = np.where(better, cd2, self.cd2)
            self.set_creases(cseg, t, cd2)

    def positions(self, rounds: int = 2) -> None:
        """Hoppe's OptimizeVertexPositions: least squares with fixed projections, then
        re-projection; a solve that would not lower the energy is not taken."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.linalg import spsolve

        for _ in range(rounds):
            nV = self.V.shape[0]
            Fs = np.asarray(self.F, dtype=np.int64)[self.sface]          # (n_s, 3)
            ns = self.X.shape[0]
            rows = np.repeat(np.arange(ns), 3)
            A = coo_matrix((self.sw.reshape(-1), (rows, Fs.reshape(-1))), shape=(ns, nV)).tocsr()
            M = A.T @ A
            rhs = A.T @ self.X
            nc = self.Xc.shape[0]
            if nc:
                # a crease sample's point on its sharp edge: (1 - t) v_a + t v_b, weighted
                r = math.sqrt(_CREASE_WEIGHT)
                Ac = coo_matrix((r * np.stack([1.0 - self.ct, self.ct], axis=1).reshape(-1),
                                 (np.repeat(np.arange(nc), 2), self.cseg.reshape(-1))), shape=(nc, nV)).tocsr()
                M = M + Ac.T @ Ac
                rhs = rhs + Ac.T @ (r * self.Xc)
            M = M.tocoo()
            e = self.edges()
            k = self.kappa
            data = [M.data, np.full(e.shape[0], k), np.full(e.shape[0], k), np.full(e.shape[0], -k),
                    np.full(e.shape[0], -k)]
            ri = [M.row, e[:, 0], e[:, 1], e[:, 0], e[:, 1]]
            ci = [M.col, e[:, 0], e[:, 1], e[:, 1], e[:, 0]]
            # dead or sample-less, spring-less vertices: a tiny pull to where they are
            reg = 1e-12 + 1e-9 * (M.diagonal().mean() if M.nnz else 1.0)
            data.append(np.full(nV, reg))
            ri.append(np.arange(nV))
            ci.append(np.arange(nV))
            rhs = rhs + reg * self.V
            K = coo_matrix((np.concatenate(data), (np.concatenate(ri), np.concatenate(ci))), shape=(nV, nV)).tocsc()
            Vnew = np.ascontiguousarray(spsolve(K, rhs), dtype=np.float64).reshape(nV, 3)
            if not np.isfinite(Vnew).all():
                return
            if self.original is not None and _LEASH > 0:
                Vnew = self._leash(K, rhs, Vnew, reg)
                if Vnew is None:
                    return
            old_V, old_e = self.V, self.e_dist + self.e_crease + self.spring_energy()
            self.V = Vnew
            Q = np.einsum("nk,nkj->nj", self.sw, Vnew[Fs])
            d2 = np.einsum("ij,ij->i", self.X - Q, self.X - Q)
            cd2 = self._crease_d2(Vnew) if nc else np.zeros(0)
            if float(d2.sum()) + _CREASE_WEIGHT * float(cd2.sum()) + self.spring_energy() > old_e \
                    or self._flipped(old_V):
                self.V = old_V
                return
            self.sd2 = d2
            self.e_dist = float(d2.sum())
            if nc:
                self.set_creases(self.cseg, self.ct, cd2)
            self.project_all()

    def _leash(self, K, rhs, Vnew, reg):
        """Hold the vertices the solve would take farther from the original than both where
        they are and _LEASH times the samples' RMS distance: E_dist is one-sided, and with
        few samples on its faces a vertex (a thin tip's) may fly off the surface to bring
        them nearer.  Held vertices get a stiff pull to where they are, and the system is
        solved again (up to three times)."""
        from scipy.sparse import diags
        from scipy.sparse.linalg import spsolve

        alive = self.valive
        d_old = self.original.distance(self.V)
        cap = _LEASH * math.sqrt(self.e_dist / max(self.X.shape[0], 1))
        held = np.zeros(self.V.shape[0], dtype=bool)
        stiff = 1e6 * max(float(K.diagonal().max()), reg)
        for _ in range(3):
            far = alive & ~held & (self.original.distance(Vnew) > np.maximum(d_old, cap))
            if not far.any():
                return Vnew
            held |= far
            w = np.where(held, stiff, 0.0)
            Vnew = np.ascontiguousarray(spsolve((K + diags(w)).tocsc(), rhs + w[:, None] * self.V),
                                        dtype=np.float64).reshape(-1, 3)
            if not np.isfinite(Vnew).all():
                return None
        return Vnew

    def _flipped(self, old_V) -> bool:
        """Did any face turn by more than 90 degrees (a fold the positions step must not make)?"""
        _, F = self.faces_array()

        def normals(V):
            return np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])

        return bool((np.einsum("ij,ij->i", normals(old_V), normals(self.V)) <= 0).any())

    # ------------------------------------------------------------------ local moves
    def sweep(self, c_rep: float, n_target: int | None) -> None:
        e = self.edges()
        order = self.rng.permutation(e.shape[0])
        for idx in order:
            u, v = int(e[idx, 0]), int(e[idx, 1])
            if not (self.valive[u] and self.valive[v]):
                continue
            shared = self.vf[u] & self.vf[v]
            if not shared:
                continue
            n = self.n_alive
            if n_target is None or n > n_target:
                if self.try_collapse(u, v, shared, c_rep):
                    continue
            if n_target is None or n < n_target:
                if self.try_split(u, v, shared, c_rep):
                    continue
            self.try_swap(u, v, shared)

    def _local(self, faces):
        s = [i for f in faces for i in self.fs[f]]
        return np.asarray(s, dtype=np.int64)

    def _project_local(self, S, tris):
        """Closest of the triangles ``tris`` (k, 3 vertex ids) for each sample in S:
        (tri index (n,), weights (n, 3), d2 (n,)) (native: lodkit._core.retile.project_local)."""
        T = np.ascontiguousarray(tris, dtype=np.int64)
        return project_local(self.X, np.ascontiguousarray(S, dtype=np.int64), self.V, T)

    def _spring_of(self, pairs) -> float:
        s = 0.0
        for a, b in pairs:
            d = self.V[a] - self.V[b]
            s += float(d @ d)
        return self.kappa * s

    def _neighbours(self, v) -> set:
        return {x for f in self.vf[v] for x in self.F[f]} - {v}

    def _is_boundary_edge(self, u, v, shared) -> bool:
        return len(shared) == 1

    def _is_boundary_vertex(self, v) -> bool:
        for w in self._neighbours(v):
            if len(self.vf[v] & self.vf[w]) == 1:
                return True
        return False

    def _fit_vertex(self, w, S, tris, nbrs, C=None, segs=(), fixed=False):
        """Place the new vertex ``w`` (already in V) by alternating local projection and the
        one-vertex least-squares fit (the samples S on the triangles ``tris``, the crease
        samples C on the sharp edges ``segs``; ``fixed``: w stays, only the projections);
        returns (tri index, weights, d2) and (segment index, parameter, d2) of the final
        projections."""
        C = _NONE if C is None else C
        for r in range(_LOCAL_ROUNDS + 1):
            ti, bw, d2 = self._project_local(S, tris) if S.size else (np.zeros(0, np.int64), np.zeros((0, 3)),
                                                                     np.zeros(0))
            cj, ct, cd2 = self._project_creases(C, segs) if C.size else (_NONE, np.zeros(0), np.zeros(0))
            if fixed or r == _LOCAL_ROUNDS:
                break
            T = np.asarray(tris, dtype=np.int64)
            if S.size:
                Ts = T[ti]
                alpha = np.where(Ts == w, bw, 0.0).sum(axis=1)
                rest = np.einsum("nk,nkj->nj", np.where(Ts == w, 0.0, bw), self.V[Ts])
                num = (alpha[:, None] * (self.X[S] - rest)).sum(axis=0)
                den = float(alpha @ alpha)
            else:
                num, den = np.zeros(3), 0.0
            if C.size:
                G = np.asarray(segs, dtype=np.int64).reshape(-1, 2)[cj]
                wa, wb = 1.0 - ct, ct
                alpha = np.where(G[:, 0] == w, wa, 0.0) + np.where(G[:, 1] == w, wb, 0.0)
                rest = np.where(G[:, 0] == w, 0.0, wa)[:, None] * self.V[G[:, 0]] + \
                    np.where(G[:, 1] == w, 0.0, wb)[:, None] * self.V[G[:, 1]]
                num = num + _CREASE_WEIGHT * (alpha[:, None] * (self.Xc[C] - rest)).sum(axis=0)
                den += _CREASE_WEIGHT * float(alpha @ alpha)
            if self.kappa > 0:
                num = num + self.kappa * self.V[list(nbrs)].sum(axis=0)
                den += self.kappa * len(nbrs)
            if den <= 0:
                fixed = True
                continue
            self.V[w] = num / den
        return (ti, bw, d2), (cj, ct, cd2)

    def _quality_ok(self, old_tris, new_tris) -> bool:
        """No new face worse than min(_MIN_QUALITY, the worst old face): the energy does not
        see slivers, the mesh's users do."""
        qn = triangle_quality(self.V, np.asarray(new_tris, dtype=np.int64))
        if not qn.size:
            return True
        qo = triangle_quality(self.V, np.asarray(old_tris, dtype=np.int64)) if len(old_tris) else np.ones(1)
        return bool(qn.min() > 0.0 and qn.min() >= min(_MIN_QUALITY, float(qo.min())))

    def _normals(self, tris):
        T = np.asarray(tris, dtype=np.int64)
        return np.cross(self.V[T[:, 1]] - self.V[T[:, 0]], self.V[T[:, 2]] - self.V[T[:, 0]])

    def _commit(self, old_faces, new_tris, S, ti, bw, d2):
        for f in old_faces:
            self.falive[f] = False
            for x in self.F[f]:
                self.vf[x].discard(f)
            self.fs[f] = []
        ids = []
        for t in new_tris:
            fid = len(self.F)
            self.F.append(list(map(int, t)))
            self.falive.append(True)
            self.fs.append([])
            for x in t:
                self.vf[x].add(fid)
            ids.append(fid)
        ids = np.asarray(ids, dtype=np.int64)
        if S.size:
            nf = ids[ti]
            self.sface[S] = nf
            self.sw[S] = bw
            self.e_dist += float(d2.sum() - self.sd2[S].sum())
            self.sd2[S] = d2
            for s, f in zip(S, nf):
                self.fs[int(f)].append(int(s))

    def _new_vertex(self, p) -> int:
        w = self.V.shape[0]
        self.V = np.concatenate([self.V, np.asarray(p, dtype=np.float64)[None, :]])
        self.valive = np.append(self.valive, True)
        self.vf.append(set())
        self.sn.append(set())
        return w

    def _drop_vertex(self, w) -> None:
        """Undo _new_vertex for a move not taken (w is the last vertex)."""
        self.V = self.V[:w]
        self.valive = self.valive[:w]
        del self.vf[w:]
        del self.sn[w:]

    def _commit_creases(self, old_edges, new_edges, C, cfit) -> None:
        """Replace the sharp edges old_edges by new_edges (vertex pairs) and move the crease
        samples C (all those on old_edges) to their projections ``cfit`` on new_edges."""
        for a, b in old_edges:
            key = (a, b) if a < b else (b, a)
            self.sharp.discard(key)
            self.es.pop(key, None)
            self.sn[a].discard(b)
            self.sn[b].discard(a)
        for a, b in new_edges:
            self.sharp.add((a, b) if a < b else (b, a))
            self.sn[a].add(b)
            self.sn[b].add(a)
        if C.size:
            cj, ct, cd2 = cfit
            G = np.asarray(new_edges, dtype=np.int64).reshape(-1, 2)[cj]
            self.cseg[C] = G
            self.ct[C] = ct
            self.e_crease += _CREASE_WEIGHT * float(cd2.sum() - self.cd2[C].sum())
            self.cd2[C] = cd2
            for i, (a, b) in zip(C.tolist(), G.tolist()):
                self.es.setdefault((a, b) if a < b else (b, a), []).append(i)

    def try_collapse(self, u, v, shared, c_rep) -> bool:
        nu, nv = self._neighbours(u), self._neighbours(v)
        opp = {x for f in shared for x in self.F[f]} - {u, v}
        bu, bv = self._is_boundary_vertex(u), self._is_boundary_vertex(v)
        boundary_edge = len(shared) == 1
        if (nu & nv) != opp or self.n_alive <= 4 or (bu and bv and not boundary_edge):
            self.rejected["illegal"] += 1
            return False
        if len(nu | nv) - 2 < 3 and not boundary_edge:
            self.rejected["illegal"] += 1
            return False
        # sharp edges (Hoppe et al. 1994): a crease may shorten along itself, but two creases
        # never join, a corner (3+ sharp edges) never moves and a crease vertex never leaves
        # its crease; w inherits u's and v's sharp edges
        su, sv = self.sn[u], self.sn[v]
        fixed_at = None
        if (u, v) in self.sharp or (v, u) in self.sharp:
            keep_sharp = (su | sv) - {u, v}
            if (len(su) >= 3 and len(sv) >= 3) or not keep_sharp:
                self.rejected["illegal"] += 1
                return False
            fixed_at = u if len(su) >= 3 else v if len(sv) >= 3 else None
        elif su and sv:
            self.rejected["illegal"] += 1
            return False
        else:
            keep_sharp = su | sv
            fixed_at = u if su else v if sv else None
        old_sharp = [(u, x) for x in su] + [(v, x) for x in sv if x != u]
        C = self._crease_samples_at([(min(a, b), max(a, b)) for a, b in old_sharp]) if old_sharp else _NONE
        old_c = _CREASE_WEIGHT * float(self.cd2[C].sum()) if C.size else 0.0
        old_faces = sorted(self.vf[u] | self.vf[v])
        stay = [f for f in old_faces if f not in shared]
        S = self._local(old_faces)
        old_d2 = float(self.sd2[S].sum()) if S.size else 0.0
        nbrs = (nu | nv) - {u, v}
        old_spring = self._spring_of([(u, x) for x in nu]) + self._spring_of([(v, x) for x in nv if x != u])
        if fixed_at is not None:
            start = self.V[fixed_at]
        else:
            start = self.V[v] if (bv and not bu) else self.V[u] if (bu and not bv) else 0.5 * (self.V[u] + self.V[v])
        w = self._new_vertex(start)
        new_tris = [[w if x in (u, v) else x for x in self.F[f]] for f in stay]
        new_sharp = [(w, x) for x in sorted(keep_sharp)]
        n_old = self._normals([self.F[f] for f in stay])
        (ti, bw, d2), cfit = self._fit_vertex(w, S, new_tris, nbrs, C, new_sharp, fixed=fixed_at is not None)
        n_new = self._normals(new_tris)
        new_spring = self._spring_of([(w, x) for x in nbrs])
        new_c = _CREASE_WEIGHT * float(cfit[2].sum())
        dE = (float(d2.sum()) - old_d2) + (new_c - old_c) + (new_spring - old_spring) - c_rep
        ok = (np.einsum("ij,ij->i", n_old, n_new) > 0).all() and \
            self._quality_ok([self.F[f] for f in old_faces], new_tris)
        if not ok or not dE < -_GAIN:
            self._drop_vertex(w)
            self.rejected["illegal" if not ok else "energy"] += 1
            return False
        self.valive[u] = self.valive[v] = False
        self._commit(old_faces, new_tris, S, ti, bw, d2)
        if old_sharp:
            self._commit_creases(old_sharp, new_sharp, C, cfit)
        self.moves["collapse"] += 1
        return True

    def try_split(self, u, v, shared, c_rep) -> bool:
        old_faces = sorted(shared)
        S = self._local(old_faces)
        old_d2 = float(self.sd2[S].sum()) if S.size else 0.0
        w = self._new_vertex(0.5 * (self.V[u] + self.V[v]))
        new_tris = []
        opp = []
        for f in old_faces:
            t = self.F[f]
            i = t.index(u)
            b, c = t[(i + 1) % 3], t[(i + 2) % 3]
            if b == v:                     # (u, v, c) -> (u, w, c), (w, v, c)
                new_tris += [[u, w, c], [w, v, c]]
                opp.append(c)
            else:                          # (u, b=other, c=v): (v, u, b) -> (v, w, b), (w, u, b)
                new_tris += [[v, w, b], [w, u, b]]
                opp.append(b)
        nbrs = {u, v, *opp}
        old_spring = self._spring_of([(u, v)])
        # a sharp edge splits into two sharp halves, its crease samples fitted to them
        is_sharp = (min(u, v), max(u, v)) in self.sharp
        C = self._crease_samples_at([(min(u, v), max(u, v))]) if is_sharp else _NONE
        new_sharp = [(u, w), (w, v)] if is_sharp else []
        n_old = self._normals([self.F[f] for f in old_faces])
        (ti, bw, d2), cfit = self._fit_vertex(w, S, new_tris, nbrs, C, new_sharp)
        n_new = self._normals(new_tris)
        new_spring = self._spring_of([(w, x) for x in nbrs])
        dc = _CREASE_WEIGHT * float(cfit[2].sum() - self.cd2[C].sum()) if C.size else 0.0
        dE = (float(d2.sum()) - old_d2) + dc + (new_spring - old_spring) + c_rep
        ok = (np.einsum("ij,ij->i", np.repeat(n_old, 2, axis=0), n_new) > 0).all() and \
            self._quality_ok([self.F[f] for f in old_faces], new_tris)
        if not ok or not dE < -_GAIN:
            self._drop_vertex(w)
            self.rejected["illegal" if not ok else "energy"] += 1
            return False
        self._commit(old_faces, new_tris, S, ti, bw, d2)
        if is_sharp:
            self._commit_creases([(u, v)], new_sharp, C, cfit)
        self.moves["split"] += 1
        return True

    def try_swap(self, u, v, shared) -> bool:
        if len(shared) != 2:
            return False
        if (min(u, v), max(u, v)) in self.sharp:          # a sharp edge stays
            self.rejected["illegal"] += 1
            return False
        f1, f2 = sorted(shared)
        t1 = self.F[f1]
        if t1[(t1.index(u) + 1) % 3] != v:          # orient so that f1 = (u, v, a)
            f1, f2 = f2, f1
            t1 = self.F[f1]
        a = next(x for x in t1 if x not in (u, v))
        b = next(x for x in self.F[f2] if x not in (u, v))
        if a == b or b in self._neighbours(a):
            self.rejected["illegal"] += 1
            return False
        old_faces = [f1, f2]
        new_tris = [[a, u, b], [b, v, a]]
        n_old = self._normals([self.F[f1], self.F[f2]])
        n_new = self._normals(new_tris)
        # the new faces must face the way the old ones did (no fold)
        avg = n_old.sum(axis=0)
        if not ((n_new @ avg) > 0).all() or not self._quality_ok([self.F[f1], self.F[f2]], new_tris):
            self.rejected["illegal"] += 1
            return False
        S = self._local(old_faces)
        old_d2 = float(self.sd2[S].sum()) if S.size else 0.0
        if S.size:
            ti, bw, d2 = self._project_local(S, new_tris)
        else:
            ti, bw, d2 = np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0)
        dE = (float(d2.sum()) - old_d2) + self._spring_of([(a, b)]) - self._spring_of([(u, v)])
        if not dE < -_GAIN:
            self.rejected["energy"] += 1
            return False
        self._commit(old_faces, new_tris, S, ti, bw, d2)
        self.moves["swap"] += 1
        return True
