"""How far a simplified mesh is from the original: Metro-style distances and more.

>>> ev = lodkit.evaluate("bunny.ply", result.mesh)
>>> ev.distance.hausdorff          # fraction of the original's bounding-box diagonal
>>> ev.as_dict()                   # everything, JSON-serialisable

What is measured (docs/evaluation.md has the definitions and the tolerances):

* **distances** (Metro, Cignoni et al. 1998): ``samples`` area-weighted random points on
  each surface; for each, the distance to the other surface. ``fwd`` = samples on the
  original, distance to the simplified mesh; ``bwd`` = the other way. Hausdorff (max),
  mean and RMS per direction and symmetric (max of the two maxima; mean and RMS over the
  union of both sample sets), as fractions of the original's bounding-box diagonal
  (:attr:`Evaluation.distance`) and in model units (:attr:`Evaluation.distance_model`);
* **normal deviation**: the angle between the normal of the face a sample lies on and the
  normal of the face its closest point lies on (degrees; mean, max, 95th percentile);
* **triangle quality** Q = 4 sqrt(3) A / (l0^2 + l1^2 + l2^2) (1 equilateral, 0 degenerate):
  a histogram over fixed bins, min and mean, for both meshes;
* **topology** (:func:`lodkit.topology`) of both meshes and the changes: genus,
  components, boundary loops, non-manifold edges and vertices, degenerate and duplicate faces;
* **colour error** when both meshes have vertex colours: RMS difference in 8-bit units
  (0-255) between the barycentric colour at each sample and the barycentric colour at its
  closest point on the other surface.

Closest points come from Open3D's ``RaycastingScene`` (Embree, single precision, on
coordinates centred on the original's bounding box); the distance to the triangle it
names is then recomputed in double precision. A sample on a triangle whose three corners
the other mesh also has (the same coordinates, bit for bit) lies on the other surface:
its distance is exactly 0 and that triangle is its closest face. So identical meshes
give exactly 0 for every distance, angle and colour error.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from .adapters import to_mesh
from .deps import open3d as import_open3d
from .errors import MeshError, OptionError
from .geometry import face_normals, triangle_quality, weld_positions
from .io import load
from .mesh import Mesh
from .topology import TopologyReport, topology

__all__ = [
    "DEFAULT_SAMPLES",
    "QUALITY_BINS",
    "ColorError",
    "DistanceStats",
    "Evaluation",
    "Evaluator",
    "NormalDeviation",
    "QualityStats",
    "closest_points",
    "evaluate",
    "face_normals",
    "sample_surface",
    "triangle_quality",
]

DEFAULT_SAMPLES = 200_000
# about 200 bytes of working memory per sample and direction: 10^8 samples is ~40 GB
MAX_SAMPLES = 100_000_000
#: Edges of the triangle-quality histogram: ten bins of width 0.1 over [0, 1] (the last
#: bin includes Q = 1).
QUALITY_BINS = tuple(round(0.1 * k, 1) for k in range(11))


# ---------------------------------------------------------------------- results
@dataclass(frozen=True)
class DistanceStats:
    """Sampled surface-to-surface distances, all in one unit (see :class:`Evaluation`).

    ``fwd``: samples on the original, distance to the simplified surface; ``bwd``: samples
    on the simplified surface, distance to the original. The symmetric ``hausdorff`` is the
    larger of the two one-sided maxima; the symmetric ``mean`` and ``rms`` are taken over
    the union of both sample sets (each direction has the same number of samples).
    """

    hausdorff: float
    mean: float
    rms: float
    hausdorff_fwd: float
    mean_fwd: float
    rms_fwd: float
    hausdorff_bwd: float
    mean_bwd: float
    rms_bwd: float

    @classmethod
    def from_distances(cls, d_fwd: np.ndarray, d_bwd: np.ndarray) -> DistanceStats:
        sq_fwd, sq_bwd = float(np.mean(d_fwd * d_fwd)), float(np.mean(d_bwd * d_bwd))
        mean_fwd, mean_bwd = float(np.mean(d_fwd)), float(np.mean(d_bwd))
        return cls(
            hausdorff=float(max(d_fwd.max(), d_bwd.max())),
            mean=0.5 * (mean_fwd + mean_bwd),
            rms=math.sqrt(0.5 * (sq_fwd + sq_bwd)),
            hausdorff_fwd=float(d_fwd.max()),
            mean_fwd=mean_fwd,
            rms_fwd=math.sqrt(sq_fwd),
            hausdorff_bwd=float(d_bwd.max()),
            mean_bwd=mean_bwd,
            rms_bwd=math.sqrt(sq_bwd),
        )

    def scaled(self, factor: float) -> DistanceStats:
        """Every value multiplied by ``factor`` (e.g. the diagonal: fractions -> model units)."""
        return DistanceStats(**{f.name: getattr(self, f.name) * factor for f in fields(self)})

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True)
class NormalDeviation:
    """Angles (degrees, 0..180) between a sample's face normal and the normal of the face
    of its closest point on the other surface; symmetric over both sample sets, and per
    direction. ``n_skipped``: samples whose closest face has zero area (no normal), left
    out; a statistic with no sample left is None."""

    mean: float | None
    max: float | None
    p95: float | None
    mean_fwd: float | None
    max_fwd: float | None
    p95_fwd: float | None
    mean_bwd: float | None
    max_bwd: float | None
    p95_bwd: float | None
    n_skipped: int

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True)
class QualityStats:
    """Triangle quality Q = 4 sqrt(3) A / sum of squared edge lengths of one mesh.

    histogram[k] counts the faces with QUALITY_BINS[k] <= Q < QUALITY_BINS[k + 1] (the last
    bin includes 1); zero-area faces have Q = 0."""

    histogram: tuple
    min: float
    mean: float

    def as_dict(self) -> dict:
        return {"bins": list(QUALITY_BINS), "histogram": list(self.histogram), "min": self.min, "mean": self.mean}


@dataclass(frozen=True)
class ColorError:
    """Colour difference at the samples, per RGB channel, in 8-bit units (colours in [0, 1]
    times 255; an alpha channel is ignored). ``rms`` is over both sample sets and the three
    channels; ``max`` is the largest single-channel difference."""

    rms: float
    rms_fwd: float
    rms_bwd: float
    mean_abs: float
    max: float

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


# the topology counts reported side by side, and whose changes are listed
_TOPOLOGY_KEYS = ("n_faces", "n_referenced_vertices", "genus", "n_components", "n_boundary_loops",
                  "n_boundary_edges", "n_nonmanifold_edges", "n_nonmanifold_vertices",
                  "n_degenerate_faces", "n_duplicate_faces", "euler_characteristic")


@dataclass(frozen=True)
class Evaluation:
    """What :func:`evaluate` measured.

    diagonal          bounding-box diagonal of the original's referenced vertices (model units)
    n_samples, seed   samples per surface, and the seed they were drawn with
    distance          :class:`DistanceStats` as fractions of ``diagonal``
    normal_deviation  :class:`NormalDeviation` (degrees)
    quality_original, quality_simplified   :class:`QualityStats`
    topology_original, topology_simplified :class:`lodkit.TopologyReport` (positions are
                      welded first for meshes with uvs, whose vertices are split along seams)
    color             :class:`ColorError`, or None unless both meshes have vertex colours
    """

    diagonal: float
    n_samples: int
    seed: int
    distance: DistanceStats
    normal_deviation: NormalDeviation
    quality_original: QualityStats
    quality_simplified: QualityStats
    topology_original: TopologyReport
    topology_simplified: TopologyReport
    color: ColorError | None

    @property
    def distance_model(self) -> DistanceStats:
        """The distances in model units (``distance`` times ``diagonal``)."""
        return self.distance.scaled(self.diagonal)

    @property
    def topology_changes(self) -> dict:
        """simplified - original for the counts in both reports (None where a genus is undefined)."""
        out = {}
        for key in _TOPOLOGY_KEYS:
            a, b = getattr(self.topology_original, key), getattr(self.topology_simplified, key)
            out[key] = None if a is None or b is None else int(b - a)
        return out

    def as_dict(self) -> dict:
        """Everything as plain JSON-serialisable values (floats, ints, bools, None, lists)."""
        return {
            "diagonal": self.diagonal,
            "n_samples": self.n_samples,
            "seed": self.seed,
            "distance": self.distance.as_dict(),
            "distance_model": self.distance_model.as_dict(),
            "normal_deviation": self.normal_deviation.as_dict(),
            "quality": {"original": self.quality_original.as_dict(),
                        "simplified": self.quality_simplified.as_dict()},
            "topology": {"original": self.topology_original.as_dict(),
                         "simplified": self.topology_simplified.as_dict(),
                         "changes": self.topology_changes},
            "color": None if self.color is None else self.color.as_dict(),
        }

    def table(self) -> str:
        """A readable multi-line table (what ``lodkit evaluate`` prints)."""
        d, dm = self.distance, self.distance_model
        rows = [("distance", "fraction of diag", "model units")]
        for name, key in (("hausdorff", "hausdorff"), ("mean", "mean"), ("rms", "rms")):
            for suffix, label in (("", ""), ("_fwd", " original->simplified"), ("_bwd", " simplified->original")):
                rows.append((name + label, f"{getattr(d, key + suffix):.6g}", f"{getattr(dm, key + suffix):.6g}"))
        out = [f"bbox diagonal {self.diagonal:.6g}, {self.n_samples} samples per surface, seed {self.seed}", ""]
        out += _columns(rows)
        n = self.normal_deviation
        g = lambda x: "-" if x is None else f"{x:.4g}"  # noqa: E731
        out += ["", *_columns([
            ("normal deviation (deg)", "mean", "p95", "max"),
            ("symmetric", g(n.mean), g(n.p95), g(n.max)),
            ("original->simplified", g(n.mean_fwd), g(n.p95_fwd), g(n.max_fwd)),
            ("simplified->original", g(n.mean_bwd), g(n.p95_bwd), g(n.max_bwd)),
        ])]
        if n.n_skipped:
            out.append(f"({n.n_skipped} samples left out: their closest face has zero area)")
        if self.color is not None:
            c = self.color
            out += ["", f"colour error (0-255): rms {c.rms:.4g} (original->simplified {c.rms_fwd:.4g}, "
                        f"simplified->original {c.rms_bwd:.4g}), mean abs {c.mean_abs:.4g}, max {c.max:.4g}"]
        qo, qs = self.quality_original, self.quality_simplified
        rows = [("triangle quality", "original", "simplified"),
                ("min", f"{qo.min:.4g}", f"{qs.min:.4g}"),
                ("mean", f"{qo.mean:.4g}", f"{qs.mean:.4g}")]
        for k in range(len(QUALITY_BINS) - 1):
            lo, hi = QUALITY_BINS[k], QUALITY_BINS[k + 1]
            rows.append((f"Q in [{lo:.1f}, {hi:.1f}{']' if k == len(QUALITY_BINS) - 2 else ')'}",
                         str(qo.histogram[k]), str(qs.histogram[k])))
        out += ["", *_columns(rows)]
        changes = self.topology_changes
        rows = [("topology", "original", "simplified", "change")]
        for key in _TOPOLOGY_KEYS:
            a, b = getattr(self.topology_original, key), getattr(self.topology_simplified, key)
            ch = changes[key]
            rows.append((key.replace("n_", "", 1).replace("_", " "), "-" if a is None else str(a),
                         "-" if b is None else str(b), "-" if ch is None else f"{ch:+d}"))
        out += ["", *_columns(rows)]
        return "\n".join(out)

    def __str__(self) -> str:
        return self.table()


def _columns(rows) -> list[str]:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return ["  ".join(cell.ljust(w) if i == 0 else cell.rjust(w) for i, (cell, w) in enumerate(zip(r, widths))).rstrip()
            for r in rows]


# ---------------------------------------------------------------------- inputs
def _input(mesh, what: str) -> Mesh:
    """A lodkit Mesh from any input evaluate() takes: those of :func:`lodkit.adapters.coerce`."""
    return to_mesh(mesh, what, load=load)


def _check_surface(mesh: Mesh, what: str) -> None:
    if mesh.n_faces == 0:
        raise MeshError(f"{what} has no faces")
    _, area = face_normals(mesh.vertices, mesh.faces)
    if not area.sum() > 0:
        raise MeshError(f"{what} has zero surface area (all {mesh.n_faces} faces are degenerate)")


# ---------------------------------------------------------------------- geometry
def _quality_stats(mesh: Mesh) -> QualityStats:
    q = triangle_quality(mesh.vertices, mesh.faces)
    hist, _ = np.histogram(q, bins=np.asarray(QUALITY_BINS))
    return QualityStats(histogram=tuple(int(h) for h in hist), min=float(q.min()), mean=float(q.mean()))


def sample_surface(vertices: np.ndarray, faces: np.ndarray, n: int,
                   seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``n`` area-weighted uniform random points on a triangle surface.

    Returns (points (n, 3) float64, face index (n,) int64, barycentric weights (n, 3)), with
    ``points = sum_k w[:, k] * vertices[faces[face, k]]``. A face is drawn with probability
    proportional to its area (zero-area faces never), then a uniform point in it
    (w = (1 - sqrt(r1), sqrt(r1) (1 - r2), sqrt(r1) r2)); the draws come from
    ``numpy.random.default_rng(seed)`` in that order, so a seed fixes the points.
    """
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    rng = np.random.default_rng(seed)
    _, area = face_normals(V, F)
    cdf = np.cumsum(area)
    if not (len(F) and np.isfinite(cdf[-1]) and cdf[-1] > 0):
        raise MeshError("cannot sample a surface with zero area")
    idx = np.searchsorted(cdf, rng.random(n) * cdf[-1], side="right")
    idx = np.minimum(idx, len(F) - 1)
    r1 = np.sqrt(rng.random(n))
    r2 = rng.random(n)
    w = np.stack([1.0 - r1, r1 * (1.0 - r2), r1 * r2], axis=1)
    P = np.einsum("nk,nkj->nj", w, V[F[idx]])
    return P, idx, w


def _closest_on_triangles(P, A, B, C) -> np.ndarray:
    """Barycentric weights (n, 3) of the point of triangle (A[i], B[i], C[i]) closest to P[i].

    Ericson, Real-Time Collision Detection 5.1.5 (Voronoi regions of the vertices, edges and
    face), vectorised; zero-area triangles get the closest point on their three edges.
    """
    dot = lambda x, y: np.einsum("ij,ij->i", x, y)  # noqa: E731
    ab, ac = B - A, C - A
    ap, bp, cp = P - A, P - B, P - C
    d1, d2 = dot(ab, ap), dot(ac, ap)
    d3, d4 = dot(ab, bp), dot(ac, bp)
    d5, d6 = dot(ab, cp), dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    n = len(P)
    w = np.empty((n, 3))
    done = np.zeros(n, dtype=bool)

    def put(mask, *weights):
        m = mask & ~done
        for k, x in enumerate(weights):
            w[m, k] = x[m] if np.ndim(x) else x
        done[m] = True

    with np.errstate(divide="ignore", invalid="ignore"):
        put((d1 <= 0) & (d2 <= 0), 1.0, 0.0, 0.0)
        put((d3 >= 0) & (d4 <= d3), 0.0, 1.0, 0.0)
        t = d1 / (d1 - d3)
        put((vc <= 0) & (d1 >= 0) & (d3 <= 0), 1.0 - t, t, 0.0)
        put((d6 >= 0) & (d5 <= d6), 0.0, 0.0, 1.0)
        t = d2 / (d2 - d6)
        put((vb <= 0) & (d2 >= 0) & (d6 <= 0), 1.0 - t, 0.0, t)
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        put((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), 0.0, 1.0 - t, t)
        denom = va + vb + vc
        inside = ~done & (denom != 0) & np.isfinite(denom)
        v, u = vb / denom, vc / denom
        put(inside, 1.0 - v - u, v, u)
    rest = np.flatnonzero(~done | ~np.isfinite(w).all(axis=1))
    if rest.size:
        w[rest] = _closest_on_edges(P[rest], A[rest], B[rest], C[rest])
    return w


def _closest_on_edges(P, A, B, C) -> np.ndarray:
    """Barycentric weights of the closest point on the three edges (for zero-area triangles)."""
    best_d = np.full(len(P), np.inf)
    best_w = np.zeros((len(P), 3))
    for (X, Y, i, j) in ((A, B, 0, 1), (B, C, 1, 2), (C, A, 2, 0)):
        D = Y - X
        dd = np.einsum("ij,ij->i", D, D)
        t = np.divide(np.einsum("ij,ij->i", P - X, D), dd, out=np.zeros_like(dd), where=dd > 0)
        t = np.clip(t, 0.0, 1.0)
        dist = np.linalg.norm(P - (X + t[:, None] * D), axis=1)
        better = dist < best_d
        best_d[better] = dist[better]
        best_w[better] = 0.0
        best_w[better, i] = 1.0 - t[better]
        best_w[better, j] = t[better]
    return best_w


def _mix64(x: np.ndarray) -> np.ndarray:
    """splitmix64's finaliser on uint64 arrays (wrapping arithmetic)."""
    x = x ^ (x >> np.uint64(30))
    x = x * np.uint64(0xBF58476D1CE4E5B9)
    x = x ^ (x >> np.uint64(27))
    x = x * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


# ---------------------------------------------------------------------- one surface, prepared
class _Surface:
    """A mesh prepared for sampling and closest-point queries.

    Coordinates handed to Embree are centred on ``centre`` (the original's bbox centre) so
    single precision keeps ~7 digits relative to the model, not to its distance from the origin.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, colors: np.ndarray | None, centre: np.ndarray):
        self.V = vertices
        self.F = faces.astype(np.int64)
        self.centre = centre
        self.Vc = self.V - centre
        self.normals, self.areas = face_normals(self.V, self.F)
        self.colors = None if colors is None else colors[:, :3]
        self._scene = None
        self._keys = None

    # -- closest points
    def scene(self):
        if self._scene is None:
            o3d = import_open3d()

            self._scene = o3d.t.geometry.RaycastingScene()
            self._scene.add_triangles(o3d.core.Tensor(np.ascontiguousarray(self.Vc, dtype=np.float32)),
                                      o3d.core.Tensor(np.ascontiguousarray(self.F, dtype=np.uint32)))
        return self._scene

    def closest(self, Pc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For centred points: (closest face (n,), barycentric weights (n, 3), distance (n,))."""
        o3d = import_open3d()

        res = self.scene().compute_closest_points(o3d.core.Tensor(np.ascontiguousarray(Pc, dtype=np.float32)))
        face = res["primitive_ids"].numpy().astype(np.int64)
        T = self.Vc[self.F[face]]
        w = _closest_on_triangles(Pc, T[:, 0], T[:, 1], T[:, 2])
        Q = np.einsum("nk,nkj->nj", w, T)
        return face, w, np.linalg.norm(Pc - Q, axis=1)

    # -- exact matches of whole triangles
    def face_keys(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(hash of each face's corner set (m,) uint64, corner order sorting the corners by
        their hash (m, 3), faces sorted by key (m,))."""
        if self._keys is None:
            bits = np.ascontiguousarray(self.V + 0.0).view(np.uint64).reshape(-1, 3)   # -0.0 -> +0.0
            h = _mix64(_mix64(_mix64(bits[:, 0]) ^ bits[:, 1]) ^ bits[:, 2])
            hc = h[self.F]
            order = np.argsort(hc, axis=1, kind="stable")
            hs = np.take_along_axis(hc, order, axis=1)
            key = _mix64(_mix64(_mix64(hs[:, 0]) ^ hs[:, 1]) ^ hs[:, 2])
            self._keys = (key, order, np.argsort(key, kind="stable"))
        return self._keys

    def match(self, other: _Surface, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For faces of self: the face of ``other`` with the same three corner positions
        (-1 if none) and, per corner of the face of self, the corner of that face at the same
        position ((k, 3); undefined where unmatched)."""
        key, order, _ = self.face_keys()
        okey, oorder, osorted = other.face_keys()
        k = key[faces]
        pos = np.minimum(np.searchsorted(okey[osorted], k), len(osorted) - 1)
        cand = osorted[pos]
        hit = okey[cand] == k
        mine = np.take_along_axis(self.F[faces], order[faces], axis=1)
        theirs = np.take_along_axis(other.F[cand], oorder[cand], axis=1)
        same = hit & (self.V[mine] == other.V[theirs]).all(axis=(1, 2))
        # own corner order[f, p] sits where the other's corner oorder[g, p] does
        corner = np.empty((len(faces), 3), dtype=np.int64)
        np.put_along_axis(corner, order[faces], oorder[cand], axis=1)
        return np.where(same, cand, -1), corner

    def colour_at(self, face: np.ndarray, w: np.ndarray) -> np.ndarray:
        return np.einsum("nk,nkc->nc", w, self.colors[self.F[face]])


@dataclass
class _Direction:
    """Samples on one surface and their closest points on the other."""

    distance: np.ndarray     # (n,) model units
    angle: np.ndarray        # (n,) degrees, NaN where the closest face has no normal
    colour_diff: np.ndarray | None   # (n, 3) in [0, 1] units, or None


def _project(src: _Surface, dst: _Surface, n: int, seed: int) -> _Direction:
    P, face, w = sample_surface(src.V, src.F, n, seed)
    # samples on a triangle dst has too (same corners, bit for bit) lie on dst: distance 0
    # exactly, that triangle as their closest face, their weights carried over corner by
    # corner; only the others are looked up
    used, inverse = np.unique(face, return_inverse=True)
    match, corner = src.match(dst, used)
    m_face, m_corner = match[inverse], corner[inverse]
    on = m_face >= 0
    dface = m_face.copy()
    dw = np.zeros((n, 3))
    np.put_along_axis(dw, np.where(on[:, None], m_corner, np.arange(3)), np.where(on[:, None], w, 0.0), axis=1)
    dist = np.zeros(n)
    off = np.flatnonzero(~on)
    if off.size:
        dface[off], dw[off], dist[off] = dst.closest(P[off] - src.centre)
    n_src = src.normals[face]
    n_dst = dst.normals[dface]
    cross = np.linalg.norm(np.cross(n_src, n_dst), axis=1)
    angle = np.degrees(np.arctan2(cross, np.einsum("ij,ij->i", n_src, n_dst)))
    angle[dst.areas[dface] <= 0] = np.nan
    colour = None
    if src.colors is not None and dst.colors is not None:
        colour = dst.colour_at(dface, dw) - src.colour_at(face, w)
    return _Direction(dist, angle, colour)


def _angle_stats(a_fwd: np.ndarray, a_bwd: np.ndarray) -> NormalDeviation:
    ok_f, ok_b = a_fwd[np.isfinite(a_fwd)], a_bwd[np.isfinite(a_bwd)]
    both = np.concatenate([ok_f, ok_b])

    def trio(a):
        if a.size == 0:        # every closest face had zero area: no angle to report
            return None, None, None
        return float(a.mean()), float(a.max()), float(np.percentile(a, 95))

    (m, x, p), (mf, xf, pf), (mb, xb, pb) = trio(both), trio(ok_f), trio(ok_b)
    return NormalDeviation(mean=m, max=x, p95=p, mean_fwd=mf, max_fwd=xf, p95_fwd=pf,
                           mean_bwd=mb, max_bwd=xb, p95_bwd=pb,
                           n_skipped=int(a_fwd.size + a_bwd.size - both.size))


def _topology_of(mesh: Mesh) -> TopologyReport:
    # a mesh read with uvs is cut along its uv seams; its shape's topology is that of the
    # welded positions
    return topology(Mesh(*weld_positions(mesh.vertices, mesh.faces)) if mesh.uvs is not None else mesh)


# ---------------------------------------------------------------------- the API
class Evaluator:
    """The original mesh, prepared once, to evaluate several simplified meshes against it.

    ``Evaluator(original, samples, seed).evaluate(simplified)`` equals
    ``evaluate(original, simplified, samples, seed)``; the original's samples, raycasting
    scene, quality and topology are computed once.
    """

    def __init__(self, original, samples: int = DEFAULT_SAMPLES, seed: int = 0):
        if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
            raise OptionError(f"samples must be a whole number >= 1, got {samples!r}")
        if samples > MAX_SAMPLES:
            raise OptionError(f"samples={samples} is more than evaluate() takes ({MAX_SAMPLES:.0e} per surface, "
                              f"about 200 bytes of memory each); a few hundred thousand measure to "
                              f"~0.1 % of the diagonal")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise OptionError(f"seed must be a whole number >= 0, got {seed!r}")
        self.mesh = _input(original, "original")
        self.diagonal = self.mesh.bbox_diagonal()
        # far from 1 (1e-170, 1e+200) face areas and squared distances under- or overflow:
        # measure on copies divided by the diagonal (ratios and angles do not change; model
        # units are the ratios times the diagonal).  Meshes of ordinary size are used as given.
        self._unit = self.diagonal if 0.0 < self.diagonal and not (1e-50 < self.diagonal < 1e50) else 1.0
        self.mesh = self._measured(self.mesh)
        self._d = self.diagonal / self._unit        # the diagonal in the units measured in
        _check_surface(self.mesh, "the original mesh")
        self.samples = int(samples)
        self.seed = int(seed)
        used = self.mesh.vertices[np.unique(self.mesh.faces)]
        self.centre = 0.5 * (used.min(axis=0) + used.max(axis=0))
        self.surface = _Surface(self.mesh.vertices, self.mesh.faces, self.mesh.colors, self.centre)
        self.quality = _quality_stats(self.mesh)
        self.topology = _topology_of(self.mesh)

    def _measured(self, mesh: Mesh) -> Mesh:
        if self._unit == 1.0:
            return mesh
        return Mesh(mesh.vertices / self._unit, mesh.faces, colors=mesh.colors, uvs=mesh.uvs)

    def _directions(self, simplified) -> tuple[Mesh, _Direction, _Direction]:
        mesh = self._measured(_input(simplified, "simplified"))
        _check_surface(mesh, "the simplified mesh")
        other = _Surface(mesh.vertices, mesh.faces, mesh.colors, self.centre)
        # fwd: samples on the original (seed); bwd: samples on the simplified mesh (seed + 1)
        try:
            fwd = _project(self.surface, other, self.samples, self.seed)
            bwd = _project(other, self.surface, self.samples, self.seed + 1)
        except MemoryError:
            raise OptionError(f"not enough memory for samples={self.samples} (about 200 bytes each "
                              f"per surface); give fewer samples") from None
        return mesh, fwd, bwd

    def distances(self, simplified) -> DistanceStats:
        """Only the distances (fractions of the diagonal), as :meth:`evaluate` computes them:
        what a benchmark loop needs, without quality and topology."""
        _, fwd, bwd = self._directions(simplified)
        return DistanceStats.from_distances(fwd.distance / self._d, bwd.distance / self._d)

    def evaluate(self, simplified) -> Evaluation:
        """Evaluate one simplified mesh against the original (see :func:`evaluate`)."""
        mesh, fwd, bwd = self._directions(simplified)
        color = None
        if fwd.colour_diff is not None:
            df, db = 255.0 * fwd.colour_diff, 255.0 * bwd.colour_diff
            sq_f, sq_b = float(np.mean(df * df)), float(np.mean(db * db))
            color = ColorError(rms=math.sqrt(0.5 * (sq_f + sq_b)), rms_fwd=math.sqrt(sq_f), rms_bwd=math.sqrt(sq_b),
                               mean_abs=0.5 * (float(np.mean(np.abs(df))) + float(np.mean(np.abs(db)))),
                               max=float(max(np.abs(df).max(), np.abs(db).max())))
        return Evaluation(
            diagonal=self.diagonal,
            n_samples=self.samples,
            seed=self.seed,
            distance=DistanceStats.from_distances(fwd.distance / self._d, bwd.distance / self._d),
            normal_deviation=_angle_stats(fwd.angle, bwd.angle),
            quality_original=self.quality,
            quality_simplified=_quality_stats(mesh),
            topology_original=self.topology,
            topology_simplified=_topology_of(mesh),
            color=color,
        )


def evaluate(original, simplified, samples: int = DEFAULT_SAMPLES, seed: int = 0) -> Evaluation:
    """Measure how far ``simplified`` is from ``original`` (Metro-style, and more).

    original, simplified : :class:`lodkit.Mesh`, Open3D triangle meshes, ``(vertices, faces)``
                           tuples or file paths
    samples              : area-weighted random points on *each* surface (>= 1)
    seed                 : the original is sampled with ``default_rng(seed)``, the simplified
                           mesh with ``default_rng(seed + 1)`` (see :func:`sample_surface`)

    Returns an :class:`Evaluation`; distances are fractions of the original's bounding-box
    diagonal (``.distance``) and model units (``.distance_model``).

    Raises :class:`lodkit.MeshError` for a mesh with no faces or no area, or an input of
    another type; :class:`lodkit.MeshIOError` for an unreadable file;
    :class:`lodkit.OptionError` for a bad ``samples`` or ``seed``.
    """
    return Evaluator(original, samples, seed).evaluate(simplified)


def closest_points(vertices: np.ndarray, faces: np.ndarray,
                   points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The closest point of the surface (vertices, faces) to each point.

    Returns (closest points (n, 3), face index (n,), barycentric weights (n, 3)) with
    ``closest = sum_k w[:, k] * vertices[faces[face, k]]``: the face from Embree (single
    precision), the point on it in double precision.
    """
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    P = np.asarray(points, dtype=np.float64)
    used = V[np.unique(F)]
    centre = 0.5 * (used.min(axis=0) + used.max(axis=0))
    face, w, _ = _Surface(V, F, None, centre).closest(P - centre)
    return np.einsum("nk,nkj->nj", w, V[F[face]]), face, w
