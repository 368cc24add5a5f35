"""``optimize()``: mesh optimisation (Hoppe, DeRose, Duchamp, McDonald & Stuetzle 1993).

Minimise over meshes M (vertex positions and connectivity) the energy

    E(M) = E_dist + E_rep + E_spring
    E_dist   = sum_i d(x_i, M)^2          x_i: points sampled on the original surface
    E_rep    = c_rep * (number of vertices)
    E_spring = kappa * sum_{edges jk} |v_j - v_k|^2

in normalised units (the original's bounding-box centre at the origin, diagonal 1).  Two
nested loops, as in the paper:

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
from .geometry import triangle_quality
from .mesh import Mesh, as_mesh, is_open3d
from .retile import SurfaceProjector

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


@dataclass
class OptimizeResult:
    """What :func:`optimize` returns.

    mesh     : the optimised mesh (a lodkit.Mesh, or an open3d TriangleMesh if one was given)
    energy   : one dict per outer iteration (the first is the start): E, E_dist, E_rep,
               E_spring, n_vertices, c_rep
    moves    : {"collapse": n, "split": n, "swap": n} moves taken
    n_samples: points sampled on the original
    elapsed  : seconds
    """

    mesh: Any
    energy: list
    moves: dict
    n_samples: int
    elapsed: float = 0.0
    report: dict = field(default_factory=dict)

    def __repr__(self) -> str:
        e0, e1 = self.energy[0]["E"], self.energy[-1]["E"]
        return f"OptimizeResult({self.mesh!r}, E {e0:.4g} -> {e1:.4g}, moves={self.moves})"


def optimize(mesh, *, n_vertices: int | None = None, c_rep: float | None = None,
             spring: float = DEFAULT_SPRING, start=None, samples: int | None = None,
             iterations: int = 6, seed: int = 0, progress: bool = False) -> OptimizeResult:
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
                 area-weighted random points again, at least 20 per output vertex, at
                 most 200 000 in all)
    iterations : outer iterations (each: positions, then one sweep of edge moves)
    seed       : for the samples and the order of the edge sweeps

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
        want = max(src.n_vertices, 20 * (n_vertices or start_mesh.n_vertices))
        n_rand = int(min(max(want, src.n_vertices), 200_000))
        X = np.concatenate([Vn[used], sample_surface(Vn, src.faces, max(n_rand - used.size, 0), seed)[0]])
    else:
        X = sample_surface(Vn, src.faces, int(n_rand), seed)[0]
    opt = _Optimizer(start_mesh, center, scale, X, spring, np.random.default_rng(seed))
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
        elapsed=time.perf_counter() - t0,
        report={"start_vertices": start_mesh.n_vertices, "start_faces": start_mesh.n_faces,
                "final_c_rep": c_rep, "spring": spring, "rejected": dict(opt.rejected)},
    )


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
    vertex -> faces sets, and each sample's face, barycentric weights and squared distance."""

    def __init__(self, start: Mesh, center, scale, X, spring: float, rng):
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
        return {"E": self.e_dist + c_rep * n + es, "E_dist": self.e_dist, "E_rep": c_rep * n,
                "E_spring": es, "n_vertices": n, "c_rep": c_rep}

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
            M = (A.T @ A).tocoo()
            rhs = A.T @ self.X
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
            old_V, old_e = self.V, self.e_dist + self.spring_energy()
            self.V = Vnew
            Q = np.einsum("nk,nkj->nj", self.sw, Vnew[Fs])
            d2 = np.einsum("ij,ij->i", self.X - Q, self.X - Q)
            if float(d2.sum()) + self.spring_energy() > old_e or self._flipped(old_V):
                self.V = old_V
                return
            self.sd2 = d2
            self.e_dist = float(d2.sum())
            self.project_all()

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

    def _fit_vertex(self, w, S, tris, nbrs):
        """Place the new vertex ``w`` (already in V) by alternating local projection and the
        one-vertex least-squares fit; returns (weights, tri index, d2) of the final projection."""
        best = None
        for _ in range(_LOCAL_ROUNDS):
            ti, bw, d2 = self._project_local(S, tris) if S.size else (np.zeros(0, np.int64), np.zeros((0, 3)),
                                                                     np.zeros(0))
            best = (ti, bw, d2)
            T = np.asarray(tris, dtype=np.int64)
            if S.size:
                Ts = T[ti]
                alpha = np.where(Ts == w, bw, 0.0).sum(axis=1)
                rest = np.einsum("nk,nkj->nj", np.where(Ts == w, 0.0, bw), self.V[Ts])
                num = (alpha[:, None] * (self.X[S] - rest)).sum(axis=0)
                den = float(alpha @ alpha)
            else:
                num, den = np.zeros(3), 0.0
            if self.kappa > 0:
                num = num + self.kappa * self.V[list(nbrs)].sum(axis=0)
                den += self.kappa * len(nbrs)
            if den <= 0:
                break
            self.V[w] = num / den
        ti, bw, d2 = self._project_local(S, tris) if S.size else best
        return ti, bw, d2

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
        return w

    def _drop_vertex(self, w) -> None:
        """Undo _new_vertex for a move not taken (w is the last vertex)."""
        self.V = self.V[:w]
        self.valive = self.valive[:w]
        del self.vf[w:]

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
        old_faces = sorted(self.vf[u] | self.vf[v])
        stay = [f for f in old_faces if f not in shared]
        S = self._local(old_faces)
        old_d2 = float(self.sd2[S].sum()) if S.size else 0.0
        nbrs = (nu | nv) - {u, v}
        old_spring = self._spring_of([(u, x) for x in nu]) + self._spring_of([(v, x) for x in nv if x != u])
        start = self.V[v] if (bv and not bu) else self.V[u] if (bu and not bv) else 0.5 * (self.V[u] + self.V[v])
        w = self._new_vertex(start)
        new_tris = [[w if x in (u, v) else x for x in self.F[f]] for f in stay]
        n_old = self._normals([self.F[f] for f in stay])
        ti, bw, d2 = self._fit_vertex(w, S, new_tris, nbrs)
        n_new = self._normals(new_tris)
        new_spring = self._spring_of([(w, x) for x in nbrs])
        dE = (float(d2.sum()) - old_d2) + (new_spring - old_spring) - c_rep
        ok = (np.einsum("ij,ij->i", n_old, n_new) > 0).all() and \
            self._quality_ok([self.F[f] for f in old_faces], new_tris)
        if not ok or not dE < -_GAIN:
            self._drop_vertex(w)
            self.rejected["illegal" if not ok else "energy"] += 1
            return False
        self.valive[u] = self.valive[v] = False
        self._commit(old_faces, new_tris, S, ti, bw, d2)
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
        n_old = self._normals([self.F[f] for f in old_faces])
        ti, bw, d2 = self._fit_vertex(w, S, new_tris, nbrs)
        n_new = self._normals(new_tris)
        new_spring = self._spring_of([(w, x) for x in nbrs])
        dE = (float(d2.sum()) - old_d2) + (new_spring - old_spring) + c_rep
        ok = (np.einsum("ij,ij->i", np.repeat(n_old, 2, axis=0), n_new) > 0).all() and \
            self._quality_ok([self.F[f] for f in old_faces], new_tris)
        if not ok or not dE < -_GAIN:
            self._drop_vertex(w)
            self.rejected["illegal" if not ok else "energy"] += 1
            return False
        self._commit(old_faces, new_tris, S, ti, bw, d2)
        self.moves["split"] += 1
        return True

    def try_swap(self, u, v, shared) -> bool:
        if len(shared) != 2:
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
