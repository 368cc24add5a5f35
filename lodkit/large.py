"""``simplify_large()``: simplify a mesh too large for one process, tile by tile, on Dask.

read the input without building the mesh (binary PLY through a memory map; OBJ and OFF
converted once, in blocks, into such a PLY: lodkit.io.stream) -> partition
the faces into spatial tiles in one streaming pass, noting the vertices that tiles share
-> write each tile as a compact part (positions, local faces, local-to-global vertex ids,
the shared ones) -> simplify the parts on the workers with the shared vertices and their
one-ring locked -> weld the results by global vertex id (the shared vertices did not move,
so the weld is exact) -> again on a grid shifted by half a cell, where the old borders are
interior and free -> finish in this process once the mesh is small enough.

Why the one-ring is locked too: a collapse may only touch vertices whose whole star lies
in the tile, so that the tile's link condition and flip checks are the global ones.  A
vertex off the border that is not shared has all its faces in the tile; a shared vertex
does not, and a free neighbour could otherwise collapse onto it and meet, across the
border, an edge the tile cannot see.  With both locked no collapse reaches the border, so
every collapse the tiles do is one the whole mesh would allow: a manifold input stays
manifold, a closed one closed, and the genus and the boundary loops are kept.

docs/scale.md explains the choices and how to pick ``tile_faces``.
"""
from __future__ import annotations

import math
import os
import re
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ._executor import open_executor
from .errors import MeshError, MeshIOError, OptionError
from .io.common import FileFormatError
from .io.ply import TYPES as PLY_TYPES
from .io.stream import STREAMED, to_binary_ply

__all__ = ["LargeResult", "simplify_large", "default_in_core_faces", "open_source", "CHUNK_FACES"]

#: faces read per step of the streaming passes (about 40 MB of faces and centroids)
CHUNK_FACES = 1 << 20
#: a tiled round that removes less than this fraction of the faces is the last one
MIN_ROUND_GAIN = 0.02
#: the largest in-core finishing step chosen by default (about 300 MB of half-edge arrays)
IN_CORE_CAP = 2_000_000
MAX_ROUNDS = 8
_AXIS = (1 << 21) - 1      # grid cells per axis: a cell key packs three 21-bit indices


@dataclass
class LargeResult:
    """What :func:`simplify_large` returns.

    mesh       : the simplified mesh (also written to ``out_path``)
    vertex_map : (n_out,) int64, for each output vertex the input vertex it comes from
    error      : the largest collapse error of any round (a fraction of the input's bbox
                 diagonal, or model units with ``absolute=True``); each round measures
                 against its own input, so this is a lower bound of simplify's figure
    rounds     : per round: kind ("tiles" or "in-core"), tiles, faces in and out, error,
                 largest tile (faces), seconds
    """

    mesh: object
    vertex_map: np.ndarray
    error: float
    rounds: list = field(default_factory=list)
    elapsed: float = 0.0
    report: dict = field(default_factory=dict)

    def __repr__(self) -> str:
        return (f"LargeResult({self.mesh!r}, error={self.error:.3g}, rounds={len(self.rounds)})")


def simplify_large(in_path, out_path, *, target_faces: int | None = None, target_ratio: float | None = None,
                   max_error: float | None = None, absolute: bool = False, tile_faces: int = 250_000,
                   in_core_faces: int | None = None, client=None, scheduler=None, workers: int | None = None,
                   work_dir=None, metric="qem", progress: bool = False) -> LargeResult:
    """Simplify the mesh file ``in_path`` into ``out_path`` in tiles of about ``tile_faces`` faces.

    Targets as for :func:`lodkit.simplify` (whichever is reached first).  ``in_core_faces``
    (default: :func:`default_in_core_faces`, four times the target up to 2M faces, at least
    two tiles): once the mesh is that small, the rest is one ordinary ``simplify`` in
    this process.  The engine as for :func:`lodkit.batch`: ``client``, or
    ``scheduler`` (None: a Dask LocalCluster of ``workers`` processes; "threads"; "sync";
    a scheduler address).  ``work_dir`` holds the parts (default: a temporary folder next
    to ``out_path``); on a multi-machine cluster it must be a folder every worker sees.

    Binary PLY inputs are read through memory maps, and OBJ and OFF inputs are first
    converted in blocks into such a PLY in the work folder (:mod:`lodkit.io.stream`), so the
    driving process never holds the whole mesh; other formats (ASCII PLY, STL, glTF) are
    loaded once with :func:`lodkit.load`.  Positions only: normals, colours and uvs are not
    carried, and ``vertex_map`` gives the file's own vertex numbers (OBJ: its 'v' lines,
    0-based; not :func:`lodkit.load`'s vertices, which split positions at uv seams).
    """
    from .io import save
    from .mesh import Mesh
    from .settings import resolve_target

    t0 = time.perf_counter()
    if isinstance(tile_faces, bool) or not isinstance(tile_faces, int) or tile_faces < 100:
        raise OptionError(f"tile_faces must be an integer of at least 100, got {tile_faces!r}")
    if in_core_faces is not None and (isinstance(in_core_faces, bool) or not isinstance(in_core_faces, int)
                                      or in_core_faces < 1):
        raise OptionError(f"in_core_faces must be a positive integer, got {in_core_faces!r}")
    _check_output_path(out_path)

    parts_dir = Path(tempfile.mkdtemp(prefix=".lodkit-tiles-", dir=work_dir or os.path.dirname(
        os.path.abspath(out_path))))
    rounds, origin = [], None          # origin: input vertex of each current vertex (None: identity)
    max_err = 0.0
    engine = source = None
    try:
        source = open_source(in_path, parts_dir)
        n_in = source.n_faces
        target = resolve_target(n_in, target_faces, target_ratio, max_error)
        if in_core_faces is None:
            in_core_faces = default_in_core_faces(tile_faces, target)
        lo, hi, area = source.bounds_and_area()
        diag = float(np.linalg.norm(hi - lo))
        error_limit = None if max_error is None else (max_error if absolute else max_error * diag)
        options = {"metric": metric, "absolute": True}
        k = 0
        while source.n_faces > in_core_faces and k < MAX_ROUNDS:
            if engine is None:
                engine = open_executor(scheduler, workers=workers, client=client)
            n_before = source.n_faces
            # leave the last quarter to the in-core step, which frees the locked borders;
            # a target above in_core_faces is reached by a second, shifted round instead
            goal = max(target, (3 * in_core_faces) // 4)
            if k == 0 and goal == target:
                # the target is reached without the in-core step: keep a fifth of the work
                # for the shifted round, which frees this round's borders
                goal = min(n_before, (5 * target) // 4)
            cell = math.sqrt(area * tile_faces / n_before)
            shift = (0.5 * cell) * (k % 2)
            t_round = time.perf_counter()
            source, ids, info = _tiled_round(source, lo - shift, cell, goal, error_limit, options, engine,
                                             parts_dir / f"round{k}", progress, tile_faces)
            origin = ids if origin is None else origin[ids]
            max_err = max(max_err, info["error"])
            rounds.append({"kind": "tiles", "faces_in": n_before, "faces_out": source.n_faces,
                           "seconds": time.perf_counter() - t_round, **info})
            k += 1
            if k >= 2 and (source.n_faces <= target or source.n_faces > n_before * (1.0 - MIN_ROUND_GAIN)):
                break          # the borders of the round before were interior in this one: done
        vertices, faces = source.arrays()
        if origin is None:
            origin = np.arange(len(vertices), dtype=np.int64)
        mesh, vertex_map = Mesh(vertices, faces), None
        # the last step is in core only when the mesh is small enough: a target above
        # in_core_faces is reached by the tiled rounds alone
        if mesh.n_faces <= in_core_faces and (mesh.n_faces > target or error_limit is not None):
            from .api import simplify

            t_round = time.perf_counter()
            result = simplify(mesh, target_faces=min(target, mesh.n_faces), max_error=error_limit, **options,
                              progress=progress)
            rounds.append({"kind": "in-core", "faces_in": mesh.n_faces, "faces_out": result.mesh.n_faces,
                           "error": result.error, "seconds": time.perf_counter() - t_round})
            max_err = max(max_err, result.error)
            mesh, vertex_map = result.mesh, result.vertex_map
        else:
            used = np.unique(faces)
            mesh, vertex_map = Mesh(vertices[used], np.searchsorted(used, faces).astype(np.int32)), used
        save(mesh, out_path)
    finally:
        if engine is not None:
            engine.close()
        if source is not None:
            source.close()
        shutil.rmtree(parts_dir, ignore_errors=True)
    error = max_err if absolute else (max_err / diag if diag > 0 else 0.0)
    return LargeResult(mesh=mesh, vertex_map=origin[vertex_map].astype(np.int64), error=float(error),
                       rounds=rounds, elapsed=time.perf_counter() - t0,
                       report={"input_faces": n_in, "target_faces": target, "tile_faces": tile_faces,
                               "in_core_faces": in_core_faces, "bbox_diagonal": diag})


def default_in_core_faces(tile_faces: int, target: int) -> int:
    """Where the tiled rounds stop and one in-core ``simplify`` takes over: at least four
    times the target where that is at most IN_CORE_CAP faces, else twice a tile.

    Measured (docs/scale.md): the error stays that of one in-core run when the in-core
    step still removes three quarters or more of what it gets -- each round starts its
    quadrics afresh from its input, and a short last step cannot spread the error the
    rounds before it left behind."""
    return max(2 * tile_faces, min(4 * target, IN_CORE_CAP))


# ---------------------------------------------------------------------- one tiled round
def _tiled_round(source, origin, cell, goal, error_limit, options, engine, directory: Path, progress,
                 tile_faces: int):
    """Partition ``source`` on a grid of ``cell`` from ``origin``, simplify every tile on
    ``engine`` down to one global error, weld: (the new source, the old vertex id of each
    new vertex, info).

    Two steps, so that the faces go where the error is lowest as in one greedy run, not
    the same fraction from every tile: (1) each tile runs its collapses once, down to a
    quarter of its share, and keeps them (a progressive mesh) and sends back its error and
    face-count curve; (2) the error at which all the tiles together reach ``goal`` faces
    is found from the curves, and each tile writes its mesh at that error."""
    directory.mkdir()
    tiles, shared = _partition(source, origin, cell, directory)
    floor = 0.25 * goal / source.n_faces
    jobs = []
    for key in tiles:
        corner = origin + cell * np.array([key >> 42, (key >> 21) & _AXIS, key & _AXIS], dtype=np.float64)
        for part in _write_parts(source, shared, directory, key, corner, cell, 2 * tile_faces):
            jobs.append((str(part), str(part.with_name("pm" + part.name[4:])), floor, error_limit, options))
    source.close_after_round()
    curves = engine.map(run_part, jobs)
    # never push every tile to its floor: the locked borders cannot go in this round, and
    # a goal below what the tiles can reach would take the largest error everywhere
    reachable = sum(int(c["faces"][-1]) for c in curves)
    level_error = _error_for(curves, max(goal, 2 * reachable))
    if error_limit is not None:
        level_error = min(level_error, error_limit)
    jobs = [(part, pm, str(Path(part).with_name("out" + Path(part).name[4:])), level_error)
            for part, pm, *_ in jobs]
    results = engine.map(extract_part, jobs)
    vertices, faces, ids = _weld(results)
    info = {"tiles": len(jobs), "largest_tile": max((c["faces_in"] for c in curves), default=0),
            "error": max((r["error"] for r in results), default=0.0), "cell": cell}
    return ArraySource(vertices, faces), ids, info


def _partition(source, origin, cell, directory: Path):
    """One streaming pass: the tile of every face (its centroid's grid cell), the faces
    appended to one raw file per tile, and which vertices more than one tile uses."""
    n = source.n_vertices
    lo_tile = np.full(n, np.iinfo(np.int64).max, dtype=np.int64)
    hi_tile = np.full(n, -1, dtype=np.int64)
    handles = {}
    try:
        for start in range(0, source.n_faces, CHUNK_FACES):
            faces = source.faces(start, min(start + CHUNK_FACES, source.n_faces))
            centroids = source.centroids(faces)
            cells = np.floor((centroids - origin) / cell).astype(np.int64)
            cells = np.clip(cells, 0, _AXIS)
            keys = (cells[:, 0] << 42) | (cells[:, 1] << 21) | cells[:, 2]
            order = np.argsort(keys, kind="stable")
            keys, faces = keys[order], faces[order]
            flat_v = faces.reshape(-1)
            flat_k = np.repeat(keys, 3)
            np.minimum.at(lo_tile, flat_v, flat_k)
            np.maximum.at(hi_tile, flat_v, flat_k)
            bounds = np.flatnonzero(np.diff(keys)) + 1
            for a, b in zip(np.r_[0, bounds], np.r_[bounds, len(keys)]):
                key = int(keys[a])
                fh = handles.get(key)
                if fh is None:
                    fh = handles[key] = open(directory / f"faces{key}.i32", "wb")
                faces[a:b].astype(np.int32).tofile(fh)
    finally:
        for fh in handles.values():
            fh.close()
    shared = (lo_tile != hi_tile) & (hi_tile >= 0)
    return sorted(handles), shared


def _write_parts(source, shared, directory: Path, key: int, corner, size: float, limit: int) -> list:
    """The compact parts of one grid cell (positions, local faces, global ids, shared
    mask): one part, or -- when the surface crosses the cell in several sheets and it holds
    more than ``limit`` faces -- one per octant that holds faces, split again as needed.
    Vertices the octants share are shared too (locked), as those between cells are."""
    raw = directory / f"faces{key}.i32"
    faces = np.fromfile(raw, dtype=np.int32).reshape(-1, 3)
    raw.unlink()
    groups = _split_cell(source, faces, np.asarray(corner, dtype=np.float64), size, limit, depth=0)
    extra = None
    if len(groups) > 1:
        used = np.concatenate([np.unique(g) for g in groups])
        ids, counts = np.unique(used, return_counts=True)
        extra = ids[counts > 1]
    paths = []
    for i, group in enumerate(groups):
        used, local = np.unique(group, return_inverse=True)
        mask = shared[used]
        if extra is not None:
            mask = mask | np.isin(used, extra)
        path = directory / f"part{key}_{i}.npz"
        np.savez(path, vertices=source.vertices(used), faces=local.reshape(-1, 3).astype(np.int32),
                 ids=used.astype(np.int64), shared=mask)
        paths.append(path)
    return paths


def _split_cell(source, faces, corner, size, limit, depth) -> list:
    """``faces`` as one group, or split by the octants of the cell at ``corner``."""
    if len(faces) <= limit or depth >= 6:
        return [faces]
    half = 0.5 * size
    octant = np.clip(np.floor((source.centroids(faces.astype(np.int64)) - corner) / half), 0, 1).astype(np.int64)
    code = octant[:, 0] * 4 + octant[:, 1] * 2 + octant[:, 2]
    out = []
    for k in range(8):
        sel = code == k
        if sel.any():
            sub = corner + half * np.array([k >> 2, (k >> 1) & 1, k & 1], dtype=np.float64)
            out += _split_cell(source, faces[sel], sub, half, limit, depth + 1)
    return out


#: points of a tile's error curve sent back to the driver (enough to place the error)
CURVE_POINTS = 1024


def run_part(part_path: str, pm_path: str, floor: float, error_limit, options: dict) -> dict:
    """Step 1 of a tile (on a worker): its collapses, with the shared vertices and their
    one-ring locked, down to ``floor`` times its faces, kept as a progressive mesh at
    ``pm_path``; returns the curve of error against faces."""
    from .mesh import Mesh
    from .progressive import progressive

    with np.load(part_path) as part:
        vertices, faces, shared = part["vertices"], part["faces"], part["shared"]
    locked = shared.copy()
    locked[faces[shared[faces].any(axis=1)].reshape(-1)] = True
    pm = progressive(Mesh(vertices, faces), min_faces=int(floor * len(faces)), max_error=error_limit,
                     locked=locked, **options)
    pm.save(pm_path)
    n = len(pm.faces_per_step)
    pick = np.unique(np.linspace(0, n - 1, min(n, CURVE_POINTS)).astype(np.int64))
    return {"faces_in": len(faces), "faces": pm.faces_per_step[pick], "errors": pm.errors_per_step[pick]}


def extract_part(part_path: str, pm_path: str, out_path: str, error: float) -> dict:
    """Step 2 of a tile (on a worker): its mesh at ``error``, with global vertex ids."""
    from .progressive import ProgressiveMesh

    pm = ProgressiveMesh.load(pm_path)
    level = pm.level(error=error)
    with np.load(part_path) as part:
        ids = part["ids"]
    out = level.mesh
    np.savez(out_path, vertices=out.vertices, faces=out.faces, ids=ids[level.vertex_map])
    os.unlink(part_path)
    os.unlink(pm_path)
    return {"out": out_path, "faces_out": out.n_faces, "error": level.error}


def _error_for(curves, goal: int) -> float:
    """The smallest error at which the tiles together have at most ``goal`` faces (each
    tile at the longest prefix of its collapses none over it); the largest error reached
    when they cannot get there."""
    candidates = np.unique(np.concatenate([c["errors"] for c in curves] or [np.zeros(1)]))

    def total(e):
        return sum(int(c["faces"][np.searchsorted(c["errors"], e, side="right") - 1]) for c in curves)

    lo, hi = 0, len(candidates) - 1
    if total(candidates[hi]) > goal:
        return float(candidates[hi])
    while lo < hi:
        mid = (lo + hi) // 2
        if total(candidates[mid]) <= goal:
            hi = mid
        else:
            lo = mid + 1
    return float(candidates[lo])


def _weld(results):
    """The tiles' outputs as one mesh: vertices with the same global id are one (they were
    locked, so their positions agree exactly; checked)."""
    all_ids, all_vertices, all_faces, offset = [], [], [], 0
    for r in results:
        with np.load(r["out"]) as part:
            all_ids.append(part["ids"])
            all_vertices.append(part["vertices"])
            all_faces.append(part["faces"].astype(np.int64) + offset)
            offset += len(part["ids"])
        os.unlink(r["out"])
    ids = np.concatenate(all_ids)
    vertices = np.concatenate(all_vertices)
    unique, first, inverse = np.unique(ids, return_index=True, return_inverse=True)
    if not np.array_equal(vertices, vertices[first][inverse.reshape(-1)]):
        raise MeshError("tiles disagree on the position of a shared vertex (a lodkit bug: shared vertices are locked)")
    faces = inverse.reshape(-1)[np.concatenate(all_faces)].astype(np.int32)
    return vertices[first], faces, unique.astype(np.int64)


# ---------------------------------------------------------------------- inputs
def open_source(path, work_dir=None):
    """A reader of ``path``'s positions and faces in chunks: memory maps of a binary PLY of
    triangles; an OBJ or OFF file converted in blocks into such a PLY in ``work_dir``
    (:mod:`lodkit.io.stream`; None: loaded whole); other files (ASCII PLY, polygon PLY,
    STL, glTF) the arrays :func:`lodkit.load` gives."""
    p = Path(os.fspath(path))
    if not p.is_file():
        raise MeshIOError(f"cannot load {p}: no such file")
    if p.suffix.lower() == ".ply":
        source = PlySource.open(p)
        if source is not None:
            return source
    if work_dir is not None and p.suffix.lower() in STREAMED:
        converted = Path(work_dir) / "input.ply"
        try:
            to_binary_ply(p, converted)
        except FileFormatError as exc:
            raise MeshIOError(f"cannot load {p}: {exc} (truncated or corrupt {p.suffix[1:].upper()} file)") from None
        except (ValueError, OverflowError) as exc:
            raise MeshIOError(f"cannot load {p}: malformed {p.suffix[1:].upper()} file ({exc})") from None
        source = PlySource.open(converted)
        source.path = p                      # errors name the file the caller gave
        if source.n_faces == 0:
            raise MeshIOError(f"cannot load {p}: the file holds no triangles")
        return source
    from .io import load

    mesh = load(p)
    return ArraySource(mesh.vertices, mesh.faces)


class ArraySource:
    """Positions and faces held as arrays (the inputs of the rounds after the first)."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        self._v = np.ascontiguousarray(vertices, dtype=np.float64)
        self._f = np.ascontiguousarray(faces, dtype=np.int32)

    @property
    def n_vertices(self) -> int:
        return len(self._v)

    @property
    def n_faces(self) -> int:
        return len(self._f)

    def faces(self, start: int, stop: int) -> np.ndarray:
        return np.asarray(self._f[start:stop], dtype=np.int64)

    def vertices(self, index: np.ndarray) -> np.ndarray:
        return np.asarray(self._v[index], dtype=np.float64)

    def centroids(self, faces: np.ndarray) -> np.ndarray:
        return (self.vertices(faces[:, 0]) + self.vertices(faces[:, 1]) + self.vertices(faces[:, 2])) / 3.0

    def bounds_and_area(self):
        """Bounding box of the used vertices and the total face area, in chunks."""
        lo = np.full(3, np.inf)
        hi = np.full(3, -np.inf)
        area = 0.0
        for start in range(0, self.n_faces, CHUNK_FACES):
            faces = self.faces(start, min(start + CHUNK_FACES, self.n_faces))
            a, b, c = (self.vertices(faces[:, i]) for i in range(3))
            for corner in (a, b, c):
                lo = np.minimum(lo, corner.min(axis=0))
                hi = np.maximum(hi, corner.max(axis=0))
            area += 0.5 * float(np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())
        if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
            raise MeshError("the mesh has no faces, or NaN/inf positions")
        return lo, hi, area

    def arrays(self):
        return self._v, self._f

    def close_after_round(self) -> None:
        pass

    def close(self) -> None:
        pass


class PlySource(ArraySource):
    """A binary little-endian PLY of triangles read through memory maps: nothing is read
    before it is asked for, so the process holds only the chunks it works on."""

    @classmethod
    def open(cls, path: Path):
        """The source, or None when the file is not a PLY this reader maps (ASCII, big
        endian, other elements first, polygons): then lodkit.load reads it."""
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
        end = re.search(rb"end_header\r?\n", head)
        if not head.startswith(b"ply") or end is None:
            return None
        lines = head[:end.start()].decode("ascii", "replace").splitlines()
        formats = [ln.strip() for ln in lines if ln.startswith("format")]
        if formats not in (["format binary_little_endian 1.0"], ["format binary_big_endian 1.0"]):
            return None                      # ASCII: lodkit.load reads it
        order = "<" if "little" in formats[0] else ">"
        elements = []
        for line in lines:
            words = line.split()
            if words[:1] == ["element"] and len(words) == 3:
                elements.append((words[1], int(words[2]), []))
            elif words[:1] == ["property"] and elements:
                elements[-1][2].append(words[1:])
        if [e[0] for e in elements[:2]] != ["vertex", "face"]:
            return None
        (_, n_v, vprops), (_, n_f, fprops) = elements[:2]
        try:
            vdtype = np.dtype([(p[1], order + PLY_TYPES[p[0]]) for p in vprops])
        except (KeyError, IndexError):
            return None
        if not {"x", "y", "z"} <= set(vdtype.names) or len(fprops) != 1 or fprops[0][0] != "list":
            return None
        count_t, index_t = PLY_TYPES.get(fprops[0][1]), PLY_TYPES.get(fprops[0][2])
        if count_t is None or index_t is None or index_t[0] == "f":
            return None
        fdtype = np.dtype([("n", order + count_t), ("v", order + index_t, (3,))])
        offset = end.end()
        size = path.stat().st_size
        if offset + n_v * vdtype.itemsize + n_f * fdtype.itemsize > size:
            raise MeshIOError(f"cannot load {path}: the file is shorter than its PLY header says")
        vmap = np.memmap(path, dtype=vdtype, mode="r", offset=offset, shape=(n_v,))
        fmap = np.memmap(path, dtype=fdtype, mode="r", offset=offset + n_v * vdtype.itemsize, shape=(n_f,))
        return cls(path, vmap, fmap)

    def __init__(self, path, vmap, fmap):
        self.path = path
        self._vm, self._fm = vmap, fmap

    @property
    def n_vertices(self) -> int:
        return len(self._vm)

    @property
    def n_faces(self) -> int:
        return len(self._fm)

    def faces(self, start: int, stop: int) -> np.ndarray:
        rows = self._fm[start:stop]
        if (rows["n"] != 3).any():
            raise MeshIOError(f"cannot simplify {self.path} in tiles: it has faces that are not triangles")
        faces = np.asarray(rows["v"], dtype=np.int64)
        if len(faces) and (faces.min() < 0 or faces.max() >= self.n_vertices):
            raise MeshError(f"{self.path}: a face refers to a vertex outside 0..{self.n_vertices - 1}")
        return faces

    def vertices(self, index: np.ndarray) -> np.ndarray:
        rows = self._vm[index]
        return np.stack([rows["x"], rows["y"], rows["z"]], axis=-1).astype(np.float64)

    def arrays(self):
        return self.vertices(np.arange(self.n_vertices)), self.faces(0, self.n_faces).astype(np.int32)

    def close_after_round(self) -> None:
        self.close()

    def close(self) -> None:
        # the maps are dropped, not closed: an array still viewing one keeps it valid
        self._vm = self._fm = None


def _check_output_path(path) -> None:
    from .io import SUPPORTED_FORMATS

    ext = os.path.splitext(os.fspath(path))[1].lower().lstrip(".")
    if ext not in SUPPORTED_FORMATS:
        raise MeshIOError(f"cannot save {path}: unsupported file format; supported: "
                          + ", ".join("." + e for e in SUPPORTED_FORMATS))
    directory = os.path.dirname(os.path.abspath(os.fspath(path)))
    if not os.path.isdir(directory):
        raise MeshIOError(f"cannot save {path}: directory {directory} does not exist")
