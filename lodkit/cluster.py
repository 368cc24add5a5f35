"""``cluster()``: vertex clustering on a uniform grid (Rossignac and Borrel, 1993).

The pipeline, each step one vectorised numpy pass (no Python loop over vertices or faces):

1. clean:     drop faces that repeat a vertex index and the vertices no face uses;
              normalise positions (bbox centre at the origin, unit diagonal)
2. grid:      cubic cells of side ``h`` from the bbox minimum; each vertex's cell key,
              one label per occupied cell (``np.unique`` on the keys)
3. faces:     re-form every face on its corners' cells; drop faces with two corners in
              one cell (degenerate) and keep one face per set of three cells (duplicates,
              either orientation; the orientation kept is the area-weighted majority)
4. represent: one vertex per cell still used by a face: the minimiser of the cell's
              summed face quadrics ("quadric", Lindstrom 2000), the cell's most important
              input vertex ("importance", Rossignac-Borrel's weight) or the centroid ("mean")
5. attributes: normals, colours and uvs averaged over the cell's vertices

docs/clustering.md gives the maths and what clustering does not guarantee.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._core import cluster as kern
from .adapters import coerce
from .errors import MeshError, OptionError
from .geometry import box_diagonal, face_vectors
from .io import load
from .mesh import Mesh
from .settings import finite_number

__all__ = ["ClusterResult", "cluster", "REPRESENTATIVES"]

REPRESENTATIVES = ("quadric", "importance", "mean")

#: Stop reasons, as found in :attr:`ClusterResult.stop_reason`.
STOP_CELL_SIZE = "cell_size"              # the cell size was given
STOP_TARGET_FACES = "target_faces"        # the cell size was searched for a face count
STOP_TARGET_VERTICES = "target_vertices"  # ... or for a vertex count

# Iterated Tikhonov towards the cell centroid (lodkit._core.cluster.place_quadric): weight
# lam = 1e-3 trace(A) / 3, three steps.  A direction the cell's quadric constrains at least
# ~1/10 as much as its average is solved to 1e-6 or better; one it does not constrain (a
# flat cell's in-plane directions, a crease's edge direction) keeps the centroid's
# coordinate; one ~1000x weaker than average (a crease of a few degrees) moves a fraction.
_REGULARISE = 1e-3
_TIKHONOV_STEPS = 3
# Orientation votes within this fraction of the group's area are ties (rounding).
_TIE = 1e-9
# The cell-size search: at most this many clusterings, and done within this relative error.
_SEARCH_STEPS = 10
_SEARCH_TOLERANCE = 0.01
# Grids of this many cells or more could overflow the int64 cell key.
_MAX_CELLS = 2**62


@dataclass
class ClusterResult:
    """What :func:`cluster` returns.

    mesh        : the clustered mesh (a lodkit.Mesh, or an open3d TriangleMesh if one was given)
    vertex_map  : (n_out,) int64, for each output vertex the input vertex that stands for
                  its cell: the chosen one ("importance"), else the one nearest to the
                  representative position
    face_map    : (m_out,) int64, for each output face the input face it was re-formed from
    error       : largest over the output vertices of sqrt(Q(x) / area): the area-weighted
                  RMS distance of the representative to the planes of the faces around its
                  cell's vertices, as a fraction of the bbox diagonal (model units with
                  ``absolute=True``) -- the measure ``simplify`` reports
    stop_reason : "cell_size", "target_faces" or "target_vertices"
    cell_size   : the cell side used (fraction of the bbox diagonal, or model units with
                  ``absolute=True``)
    """

    mesh: Any
    vertex_map: np.ndarray
    face_map: np.ndarray
    error: float
    stop_reason: str
    cell_size: float
    elapsed: float = 0.0
    report: dict = field(default_factory=dict)

    def __repr__(self) -> str:
        return (f"ClusterResult({self.mesh!r}, cell_size={self.cell_size:.3g}, error={self.error:.3g}, "
                f"stop_reason={self.stop_reason!r})")


@dataclass
class _Input:
    """The cleaned input: used vertices only, normalised positions."""

    positions: np.ndarray      # (n, 3) normalised
    faces: np.ndarray          # (m, 3) int32 into positions
    input_vertex: np.ndarray   # (n,) index into the input mesh
    input_face: np.ndarray     # (m,) index into the input mesh
    lo: np.ndarray             # (3,) bbox minimum (normalised)
    extent: np.ndarray         # (3,) bbox size (normalised; its norm is 1)
    center: np.ndarray
    scale: float
    n_degenerate: int
    n_unreferenced: int


@dataclass
class _Clustering:
    """One grid applied to the input: cells, and the faces that survive."""

    h: float
    label: np.ndarray          # (n,) cell label of each vertex (cells sorted by key)
    keys: np.ndarray           # (n_cells,) sorted cell keys
    dims: np.ndarray           # (3,) cells per axis
    face_cells: np.ndarray     # (k, 3) cell labels of the output faces (input rotation kept)
    face_source: np.ndarray    # (k,) index into _Input.faces of each output face
    n_degenerate: int          # faces with two corners in one cell
    n_duplicate: int           # faces dropped as duplicates of a kept one


def cluster(
    mesh,
    *,
    cell_size: float | None = None,
    target_vertices: int | None = None,
    target_faces: int | None = None,
    representative: str = "quadric",
    absolute: bool = False,
) -> ClusterResult:
    """Simplify by vertex clustering: merge the vertices in each cell of a uniform grid.

    Give exactly one of:

    cell_size        : the side of the cubic cells, a fraction of the bbox diagonal (model
                       units with ``absolute=True``); the grid starts at the bbox minimum
    target_vertices  : search the cell size whose output has about this many vertices
    target_faces     : ... or about this many faces (a few clusterings, log-log secant
                       steps; the closest one found is returned, typically within 1%)

    representative   : "quadric" (default; the point minimising the summed face quadrics
                       of the cell's vertices, Lindstrom's out-of-core clustering; found by
                       iterated Tikhonov from the centroid, so directions the quadric does
                       not constrain keep the centroid's coordinate; clamped to the cell),
                       "importance" (the cell's input vertex
                       of largest Rossignac-Borrel weight: longest incident edge times the
                       spread of the incident face normals) or "mean" (the centroid)

    Works on any triangle soup: non-manifold edges, several objects, open surfaces.  The
    output has no degenerate and no duplicate faces, but it is not guaranteed manifold nor
    of the input's topology (docs/clustering.md).  Normals, colours and uvs are averaged per
    cell.  An open3d.geometry.TriangleMesh in gives one out.
    """
    t0 = time.perf_counter()
    src, back = coerce(mesh, load=load)
    if representative not in REPRESENTATIVES:
        raise OptionError(f"representative must be one of {', '.join(REPRESENTATIVES)}, got {representative!r}")
    given = [k for k, v in (("cell_size", cell_size), ("target_vertices", target_vertices),
                            ("target_faces", target_faces)) if v is not None]
    if len(given) != 1:
        raise OptionError("give exactly one of cell_size=, target_vertices= or target_faces=" +
                          (f" (got {', '.join(given)})" if given else ""))
    want = None
    if cell_size is not None:
        size = finite_number("cell_size", cell_size)
        if not size > 0.0:
            raise OptionError(f"cell_size must be > 0, got {cell_size!r}")
    else:
        want = target_vertices if target_vertices is not None else target_faces
        if isinstance(want, bool) or not isinstance(want, (int, np.integer)) or want < 1:
            raise OptionError(f"{given[0]} must be a positive integer, got {want!r}")
    data = _clean(src)
    if want is not None:
        have = data.faces.shape[0] if target_faces is not None else data.positions.shape[0]
        if want > have:
            noun = "faces" if target_faces is not None else "vertices (used by faces)"
            raise OptionError(f"{given[0]}={want} is more than the mesh's {have} {noun}: clustering only "
                              f"merges vertices, so ask for at most {have}")
    to_model = data.scale if absolute else 1.0
    searched = 0
    if cell_size is not None:
        grid = _apply_grid(data, size / to_model)
        stop = STOP_CELL_SIZE
    else:
        grid, searched = _search(data, int(want), faces=target_faces is not None)
        stop = STOP_TARGET_FACES if target_faces is not None else STOP_TARGET_VERTICES
    out, vertex_map, face_map, err, rms = _build(src, data, grid, representative)
    return ClusterResult(
        mesh=back(out),
        vertex_map=vertex_map,
        face_map=face_map,
        error=float(err * to_model),
        stop_reason=stop,
        cell_size=float(grid.h * to_model),
        elapsed=time.perf_counter() - t0,
        report={
            "input_faces": src.n_faces,
            "input_vertices": src.n_vertices,
            "degenerate_faces_removed": data.n_degenerate,
            "unreferenced_vertices_removed": data.n_unreferenced,
            "grid": [int(d) for d in grid.dims],
            "occupied_cells": int(grid.keys.size),
            "collapsed_faces": grid.n_degenerate,
            "duplicate_faces": grid.n_duplicate,
            "representative": representative,
            "rms_error": float(rms * to_model),
            "search_steps": searched,
            "target": None if want is None else {given[0]: int(want)},
        },
    )


# ----------------------------------------------------------------------------- steps


def _clean(src: Mesh) -> _Input:
    """Drop faces that repeat an index and unused vertices; normalise positions."""
    faces = src.faces
    if faces.shape[0] == 0:
        raise MeshError("the mesh has no faces")
    degenerate = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    n_degenerate = int(np.count_nonzero(degenerate))
    if n_degenerate == faces.shape[0]:
        raise MeshError(f"all {faces.shape[0]} faces repeat a vertex index (zero area); nothing to cluster")
    if n_degenerate:
        input_face = np.flatnonzero(~degenerate)
        faces = faces[input_face]
    else:
        input_face = np.arange(faces.shape[0])
    used = np.zeros(src.n_vertices, dtype=bool)
    used[faces.reshape(-1)] = True
    input_vertex = np.flatnonzero(used)
    if input_vertex.size == src.n_vertices:
        compact = faces                           # every vertex is used: no renumbering
        pts = src.vertices.copy()
    else:
        remap = np.full(src.n_vertices, -1, dtype=np.int32)
        remap[input_vertex] = np.arange(input_vertex.size, dtype=np.int32)
        compact = remap[faces]
        pts = src.vertices[input_vertex]
    # column by column: numpy's axis=0 reduction of an (n, 3) array is ~40x slower
    lo = np.array([pts[:, k].min() for k in range(3)])
    hi = np.array([pts[:, k].max() for k in range(3)])
    with np.errstate(over="ignore", invalid="ignore"):
        center = 0.5 * lo + 0.5 * hi
        scale = box_diagonal(lo, hi)
    if not scale > 0.0:
        raise MeshError("all vertices used by faces coincide: the bounding box has zero size")
    if not math.isfinite(scale):
        raise MeshError("the bounding box is too large to measure; rescale the mesh")
    pts -= center
    pts /= scale
    # (x - c) / s is monotone in x, so these are the normalised points' exact bounds
    plo, phi = (lo - center) / scale, (hi - center) / scale
    return _Input(pts, compact, input_vertex, input_face, plo, phi - plo, center, scale,
                  n_degenerate, int(src.n_vertices - input_vertex.size))


def _apply_grid(data: _Input, h: float, count_only: bool = False) -> _Clustering:
    """Cell labels of the vertices and the faces re-formed on them (degenerate and
    duplicate faces removed)."""
    dims = np.maximum(np.ceil(data.extent / h), 1.0)
    if float(np.prod(dims)) >= _MAX_CELLS:
        raise OptionError(f"cell size {h:.3g} (of the bbox diagonal) makes a grid of "
                          f"{' x '.join(f'{d:.3g}' for d in dims)} cells; choose a larger cell size")
    dims = dims.astype(np.int64)
    ijk = np.floor((data.positions - data.lo) * (1.0 / h)).astype(np.int64)
    np.clip(ijk, 0, dims - 1, out=ijk)        # the bbox maximum lies on the far wall
    key = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    del ijk
    keys, label = np.unique(key, return_inverse=True)
    label = label.reshape(-1)
    fc = label[data.faces]
    keep = (fc[:, 0] != fc[:, 1]) & (fc[:, 1] != fc[:, 2]) & (fc[:, 0] != fc[:, 2])
    source = np.flatnonzero(keep)
    fc = fc[source]
    n_collapsed = int(data.faces.shape[0] - source.size)
    fc, source, n_dup = _drop_duplicates(data, fc, source, keys.size, count_only)
    return _Clustering(h, label, keys, dims, fc, source, n_collapsed, n_dup)


def _drop_duplicates(data: _Input, fc, source, n_cells: int, count_only: bool):
    """Keep one face per set of three cells.  Its orientation is the majority of the
    group's faces weighted by input area (ties, to 1e-9 of the group's area: the first
    face's); the face kept is the
    first of the group with that orientation, with its corners in the input's rotation."""
    if fc.shape[0] == 0:
        return fc, source, 0
    s = np.sort(fc, axis=1)
    if n_cells < 2**21:
        gkey = (s[:, 0] * n_cells + s[:, 1]) * n_cells + s[:, 2]
        order = np.argsort(gkey, kind="stable")
        sk = gkey[order]
        first = np.empty(sk.size, dtype=bool)
        first[0] = True
        first[1:] = sk[1:] != sk[:-1]
    else:
        order = np.lexsort((s[:, 2], s[:, 1], s[:, 0]))
        ss = s[order]
        first = np.empty(ss.shape[0], dtype=bool)
        first[0] = True
        first[1:] = (ss[1:] != ss[:-1]).any(axis=1)
    n_groups = int(np.count_nonzero(first))
    n_dup = int(fc.shape[0] - n_groups)
    if n_dup == 0:
        return fc, source, 0
    if count_only:
        return fc, source, n_dup                  # the search reads counts only
    # only the faces in groups of two or more need a vote
    group = np.cumsum(first) - 1                      # group of each face in sorted order
    size = np.bincount(group, minlength=n_groups)
    shared = size[group] > 1
    keep = np.ones(fc.shape[0], dtype=bool)
    keep[order[shared]] = False
    o = order[shared]                                 # the shared faces, by group, input order
    grp = group[shared]
    # even: the face is a rotation of its sorted cells (s0, s1, s2); odd: of (s0, s2, s1)
    fo = fc[o]
    at_min = np.argmin(fo, axis=1)
    after_min = fo[np.arange(o.size), (at_min + 1) % 3]
    even = after_min == s[o, 1]
    f = data.faces[source[o]]
    p = data.positions
    area = np.linalg.norm(face_vectors(p, f), axis=1)
    head = np.empty(o.size, dtype=bool)
    head[0] = True
    head[1:] = grp[1:] != grp[:-1]
    starts = np.flatnonzero(head)
    vote = np.add.reduceat(np.where(even, area, -area), starts)
    # a tie (to rounding: a face and its reverse) goes to the group's first face
    tie = np.abs(vote) <= _TIE * np.add.reduceat(area, starts)
    chosen = np.where(tie, even[starts], vote > 0)
    match = np.flatnonzero(even == np.repeat(chosen, np.diff(np.append(starts, o.size))))
    g = grp[match]
    firsts = np.empty(match.size, dtype=bool)
    firsts[0] = True
    firsts[1:] = g[1:] != g[:-1]
    keep[o[match[firsts]]] = True                     # the first face of the chosen orientation
    pick = np.flatnonzero(keep)                       # input face order
    return fc[pick], source[pick], n_dup


def _search(data: _Input, want: int, faces: bool):
    """Find the cell size whose output count (faces or vertices) is closest to ``want``:
    start from the surface area (a surface meets about area / h^2 cells), then secant steps
    on log(count) against log(h).  Returns (clustering, steps)."""
    p, f = data.positions, data.faces
    area = 0.5 * float(np.linalg.norm(face_vectors(p, f), axis=1).sum())
    per_vertex = 2.0 if faces else 1.0            # a closed surface has about 2 faces per vertex
    h = math.sqrt(max(area, 1e-12) / max(want / per_vertex, 1.0))
    h = min(max(h, 1e-7), 2.0)
    best, best_miss = None, math.inf
    tried = []
    for _ in range(_SEARCH_STEPS):
        g = _apply_grid(data, h, count_only=True)
        n = g.face_cells.shape[0] - g.n_duplicate if faces else _n_used_cells(g)
        miss = abs(math.log(max(n, 1) / want))
        if miss < best_miss:
            best, best_miss = h, miss
        tried.append((h, max(n, 1)))
        if miss <= math.log1p(_SEARCH_TOLERANCE):
            break
        slope = -2.0                              # count ~ h^-2 on a surface
        if len(tried) >= 2:
            (h0, n0), (h1, n1) = tried[-2], tried[-1]
            if h0 != h1 and n0 != n1:
                slope = min(max(math.log(n1 / n0) / math.log(h1 / h0), -3.0), -0.5)
        h_next = h * math.exp(math.log(want / max(n, 1)) / slope)
        h_next = min(max(h_next, h / 8.0, 1e-7), h * 8.0, 2.0)
        if any(abs(h_next - t) <= 1e-12 * t for t, _ in tried):
            break
        h = h_next
    return _apply_grid(data, best), len(tried)


def _n_used_cells(g: _Clustering) -> int:
    used = np.zeros(g.keys.size, dtype=bool)
    used[g.face_cells.reshape(-1)] = True
    return int(np.count_nonzero(used))


def _build(src: Mesh, data: _Input, g: _Clustering, representative: str):
    """The output mesh, vertex and face maps, and the (max, RMS) quadric error."""
    n_cells = g.keys.size
    label = g.label
    p = data.positions
    sums, count, q = kern.cell_sums(p, data.faces, label, n_cells, True)
    mean = sums / count[:, None]
    chosen = None
    if representative == "quadric":
        rep = kern.place_quadric(q, mean, _cell_corners(g, data), g.h, _REGULARISE, _TIKHONOV_STEPS)
    elif representative == "mean":
        rep = mean
    else:
        chosen, _ = kern.most_important(p, data.faces, label, n_cells)
        rep = p[chosen]
    # cells no face uses any more (everything in them collapsed) give no vertex
    used = np.zeros(n_cells, dtype=bool)
    used[g.face_cells.reshape(-1)] = True
    cells = np.flatnonzero(used)
    new_index = np.full(n_cells, -1, dtype=np.int32)
    new_index[cells] = np.arange(cells.size, dtype=np.int32)
    faces = new_index[g.face_cells]
    x = np.ascontiguousarray(rep[cells])
    qc = q[cells]
    err2 = kern.quadric_errors(qc, x)
    err = float(math.sqrt(err2.max())) if err2.size else 0.0
    w = qc[:, 10]
    rms = float(math.sqrt(np.average(err2, weights=w))) if w.sum() > 0 else err
    if chosen is None:
        chosen = kern.nearest_vertex(p, label, np.ascontiguousarray(rep))
    vertex_map = data.input_vertex[chosen[cells]].astype(np.int64)
    attrs = {}
    for name, arr in src.attributes().items():
        vals = arr[data.input_vertex] if data.input_vertex.size != src.n_vertices else arr
        avg = np.empty((cells.size, vals.shape[1]))
        for k in range(vals.shape[1]):
            avg[:, k] = np.bincount(label, weights=vals[:, k], minlength=n_cells)[cells]
        avg /= count[cells, None]
        if name == "normals":
            length = np.linalg.norm(avg, axis=1, keepdims=True)
            avg = np.divide(avg, length, out=np.zeros_like(avg), where=length > 0)
        elif name == "colors":
            np.clip(avg, 0.0, 1.0, out=avg)
        attrs[name] = avg
    if representative == "importance":
        verts = src.vertices[vertex_map]          # input positions bit for bit
    else:
        verts = x * data.scale + data.center
    out = Mesh(verts, faces, **attrs)
    face_map = data.input_face[g.face_source].astype(np.int64)
    return out, vertex_map, face_map, err, rms


def _cell_corners(g: _Clustering, data: _Input) -> np.ndarray:
    """(k, 3) the low corner of each occupied cell's box (normalised coordinates)."""
    dims = g.dims
    k = g.keys
    ijk = np.stack([k // (dims[1] * dims[2]), (k // dims[2]) % dims[1], k % dims[2]], axis=1)
    return np.ascontiguousarray(data.lo + ijk * g.h)
