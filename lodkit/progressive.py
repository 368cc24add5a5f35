"""Progressive meshes (Hoppe 1996; the output of MELOD): one simplification run, any LOD.

``progressive(mesh)`` simplifies once, as far as the driver goes, and keeps the ordered
collapse records.  Read backwards they are Hoppe's vertex splits: the base (coarsest) mesh
plus, per step, the vertex that comes back, the vertex it splits from, the positions and
attributes before and after, the faces that come back and the face corners that move
over.  From them :class:`ProgressiveMesh` extracts the mesh after any number of collapses
with a handful of vectorised array passes (no simplifier), walks one step at a time
(``refine`` / ``coarsen``, touching only what the step changes), and saves itself to one
``.npz`` file.  docs/progressive.md describes the representation and its guarantees.
"""
from __future__ import annotations

import json
import os
import threading
import zipfile
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._pipeline import attribute_arrays, prepare
from .adapters import coerce
from .api import simplify
from .errors import MeshIOError, OptionError
from .io import atomic_write, load
from .mesh import Mesh, is_open3d
from .metrics import create as create_metrics

__all__ = ["progressive", "ProgressiveMesh", "Level", "Cursor", "FORMAT", "FORMAT_VERSION"]

#: what ``ProgressiveMesh.save`` writes in the ``format`` field, and the layout version
FORMAT = "lodkit-progressive"
FORMAT_VERSION = 1

_ATTRIBUTES = ("normals", "colors", "uvs")      # the order Mesh.attributes() gives them in
_NEVER = np.iinfo(np.int32).max                 # "never removed" as a step number


@dataclass
class Level:
    """One extracted level of detail.

    mesh       : the mesh (a lodkit.Mesh, or an open3d TriangleMesh if the input was one)
    vertex_map : (n_out,) int64, the input vertex each output vertex comes from
    face_map   : (m_out,) int64, the input face each output face comes from
    error      : the largest collapse error up to this step, as simplify() reports it
    step       : the number of collapses done
    """

    mesh: Any
    vertex_map: np.ndarray
    face_map: np.ndarray
    error: float
    step: int

    @property
    def n_faces(self) -> int:
        return int(self.face_map.shape[0])

    @property
    def n_vertices(self) -> int:
        return int(self.vertex_map.shape[0])


# simplify() options progressive() passes on as they are (the others it sets itself)
_SIMPLIFY_OPTIONS = {"pair_threshold", "operator", "driver", "threads", "error", "sample_spacing"}


def progressive(mesh, metric="qem", *, min_faces: int = 0, max_error: float | None = None,
                absolute: bool = False,
                placement: str | None = None, boundary: str | None = None,
                boundary_weight: float | None = None, locked=None,
                max_normal_angle: float | None = None, min_quality: float | None = None,
                progress: bool = False, **options) -> ProgressiveMesh:
    """Simplify ``mesh`` once, down to ``min_faces`` faces or as far as the collapses go,
    and return the :class:`ProgressiveMesh` of the run.

    The settings are those of :func:`lodkit.simplify` (``absolute`` also sets the unit of
    the errors: model units instead of fractions of the bbox diagonal).  ``max_error``
    limits the run as in simplify: candidates over it are skipped, the others go on.
    ``pm.at(faces=N)`` is then the mesh ``simplify(mesh, target_faces=N, <same settings>)``
    gives, bit for bit, and the base mesh (``at(step=pm.n_steps)``) is
    ``simplify(mesh, target_faces=min_faces, <same settings>)`` (docs/progressive.md).
    Other keyword options go to simplify as they are; a driver that keeps no collapse
    records (vertex removal metrics) raises OptionError.
    """
    if isinstance(min_faces, bool) or not isinstance(min_faces, (int, np.integer)) or min_faces < 0:
        raise OptionError(f"min_faces must be a non-negative integer, got {min_faces!r}")
    unknown = sorted(set(options) - _SIMPLIFY_OPTIONS)
    if unknown:
        raise OptionError(f"progressive() got an unexpected keyword argument {unknown[0]!r} (it takes "
                          f"simplify()'s options but the targets: {', '.join(sorted(_SIMPLIFY_OPTIONS))})")
    if options.get("pair_threshold") is not None:
        raise OptionError("progressive meshes do not support pair_threshold: the pairs it joins "
                          "are not edge collapses of the input's half-edge arrays")
    if any(m.kind == "removal" for m in create_metrics(metric)):
        raise OptionError(f"metric {metric!r} removes vertices and re-triangulates their holes; progressive "
                          "meshes are made of edge collapses (use an edge-collapse metric)")
    src, back = coerce(mesh, load=load)
    was_o3d = is_open3d(mesh)
    result = simplify(src, target_faces=int(min_faces), max_error=max_error, metric=metric, absolute=absolute,
                      placement=placement, boundary=boundary, boundary_weight=boundary_weight,
                      locked=locked, max_normal_angle=max_normal_angle, min_quality=min_quality,
                      progress=progress, record=True, **options)
    rec = result.collapses
    if not rec or "kept_slot" not in rec:
        raise OptionError(f"metric {result.report.get('metrics')}: this simplification driver keeps no "
                          "edge-collapse records, which progressive meshes are made of")
    # deterministic: the same vertex and face slots the run used
    prep = prepare(src, memory_order=result.report["memory_order"])
    scale = prep.scale if absolute else 1.0
    data = {
        "vertices": src.vertices,
        "input_vertex": prep.input_vertex.astype(np.int32),
        "input_face": prep.input_face.astype(np.int32),
        "corners": np.ascontiguousarray(prep.hm.corners, dtype=np.int32),
        "removed": rec["removed_slot"].astype(np.int32),
        "kept": rec["kept_slot"].astype(np.int32),
        "position": rec["position"],
        "dead_faces": rec["faces"].astype(np.int32),
        "pair_open": rec["pair_open"],
        "cost": rec["cost"],
        # the records' errors are in the caller's units (absolute=True: scaled by the
        # diagonal); kept in the core's, as the bound is, and scaled on the way out
        "error": rec["error"] / scale,
        "attributes": rec["attributes"],
        "error_scale": np.float64(scale),
        "n_input_faces": np.int64(src.n_faces),
        "min_faces": np.int64(min_faces),
    }
    if "bound" in rec:
        # error="hausdorff": the distance certified after each step, kept in the core's
        # units (fractions of the diagonal) and scaled as the errors are on the way out
        data["bound"] = rec["bound"] / scale
    for name, arr in src.attributes().items():
        data["input_" + name] = arr
    info = {
        "metrics": result.report["metrics"],
        "settings": result.report["settings"],
        "absolute": bool(absolute),
        "max_error": None if max_error is None else float(max_error),
        "stop_reason": result.stop_reason,
        "open3d": bool(was_o3d),
    }
    pm = ProgressiveMesh(data, info)
    # the records must give back the run's own result (O(mesh), once)
    pm._back = None                        # compare lodkit Meshes (result.mesh is one)
    base = pm.level(step=pm.n_steps) if pm.stops[-1] else None
    pm._back = back
    if base is None or not (np.array_equal(base.face_map, result.face_map)
                            and np.array_equal(base.vertex_map, result.vertex_map)
                            and np.array_equal(base.mesh.faces, result.mesh.faces)
                            and np.array_equal(base.mesh.vertices, result.mesh.vertices)):
        raise RuntimeError("lodkit.progressive: the collapse records do not reproduce the run's "
                           f"result (options {sorted(options)}); this is a bug")
    return pm


def _trusted_mesh(vertices, faces, attrs) -> Mesh:
    """A Mesh from arrays known to be valid (float64, finite, indices in range: they are
    rows of a validated input and its records), without Mesh's O(n) checks."""
    mesh = object.__new__(Mesh)
    mesh.vertices = np.ascontiguousarray(vertices, dtype=np.float64)
    mesh.faces = np.ascontiguousarray(faces, dtype=np.int32)
    for name in _ATTRIBUTES:
        a = attrs.get(name)
        setattr(mesh, name, None if a is None else np.ascontiguousarray(a, dtype=np.float64))
    mesh.metadata = {}
    return mesh


def _validate_cardinal(name, value, lo, hi):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise OptionError(f"{name} must be an integer, got {value!r}")
    if not (lo <= int(value) <= hi):
        raise OptionError(f"{name} must be in {lo}..{hi}, got {value}")
    return int(value)


class ProgressiveMesh:
    """A mesh and its ordered edge collapses (equivalently: a base mesh and vertex splits).

    Steps count collapses: step 0 is the input (after simplify's clean-up of degenerate
    faces and unused vertices), step ``n_steps`` the base mesh.  A seam pair (the two
    collapses that close an attribute seam together) is one indivisible change: the state
    between its halves is never a stopping point, of ``at`` or of the cursor.

    at(faces=N | ratio=R | error=E | bound=D | step=S) -> mesh
    level(...)             -> Level(mesh, vertex_map, face_map, error, step)
    lods([N1, N2, ...])    -> [mesh, ...]   (ints: face counts, floats in (0, 1]: ratios)
    refine(n) / coarsen(n) / current / step : a cursor, starting at the base mesh
    save(path) / ProgressiveMesh.load(path)
    """

    def __init__(self, data: dict, info: dict):
        self._d = data
        self.info = info
        self._open3d = bool(info.get("open3d", False))
        # turns a level's Mesh into the input's type (a saved one knows only "Open3D or not")
        self._back = Mesh.to_open3d if self._open3d else None
        d = data
        self._names = [(name, d["input_" + name].shape[1]) for name in _ATTRIBUTES if "input_" + name in d]
        self.n_steps = int(d["removed"].shape[0])
        n_slots = int(d["input_vertex"].shape[0])
        m = int(d["corners"].shape[0])
        S = self.n_steps
        steps = np.arange(S, dtype=np.int64)
        # per vertex slot: the state from which it is gone (step + 1), else _NEVER
        self._vgone = np.full(n_slots, _NEVER, dtype=np.int64)
        self._vgone[d["removed"]] = steps + 1
        # per face slot: the state from which it is gone
        self._fgone = np.full(m, _NEVER, dtype=np.int64)
        dead = d["dead_faces"]
        for j in range(dead.shape[1]):
            ok = dead[:, j] >= 0
            self._fgone[dead[ok, j]] = steps[ok] + 1
        n_dead = (dead >= 0).sum(axis=1)
        #: (n_steps + 1,) live faces after each number of collapses
        self.faces_per_step = m - np.concatenate(([0], np.cumsum(n_dead))).astype(np.int64)
        raw = np.concatenate(([0.0], np.maximum.accumulate(d["error"]) if S else []))
        #: (n_steps + 1,) the error simplify() reports after each number of collapses
        self.errors_per_step = raw * float(d["error_scale"])
        self._raw_errors = raw
        #: (n_steps + 1,) with error="hausdorff": the distance the mesh after each number of
        #: collapses is certified to be within of the input, both ways (None without it)
        self.bounds_per_step = None
        if "bound" in d:
            self._raw_bounds = np.concatenate(([0.0], np.maximum.accumulate(d["bound"]) if S else []))
            self.bounds_per_step = self._raw_bounds * float(d["error_scale"])
        #: (n_steps + 1,) True where a state is a stopping point (not inside a seam pair)
        self.stops = np.ones(S + 1, dtype=bool)
        self.stops[1:] = ~d["pair_open"]
        # the records grouped by kept slot, in step order: the last one before a step gives
        # a vertex's position and attributes there
        order = np.lexsort((steps, d["kept"]))
        self._by_kept = order
        self._next_record = np.full(S, S, dtype=np.int64)   # the next record keeping the same slot
        if S > 1:
            same = d["kept"][order[1:]] == d["kept"][order[:-1]]
            self._next_record[order[:-1][same]] = order[1:][same]
        self._identity = np.arange(n_slots, dtype=np.int32)
        iv = d["input_vertex"]
        self._welded = not (iv.size > 1 and np.all(iv[1:] > iv[:-1]))
        inf = d["input_face"]
        # face slots laid out in another order than the input's (a memory-ordered run): the
        # output lists faces in input order, as lodkit._pipeline.extract does
        self._faces_reordered = bool(inf.size > 1 and not np.all(inf[1:] > inf[:-1]))
        self._slot_attr = None
        self._cursor = None
        self._events = None
        # the built-in cursor (refine / coarsen / current / step) is shared by every thread
        # using this object: each of those calls holds the lock, so each sees and leaves a
        # consistent state.  Threads that walk on their own take pm.cursor() each.
        self._lock = threading.RLock()

    # ------------------------------------------------------------------ sizes
    @property
    def n_input_faces(self) -> int:
        return int(self._d["n_input_faces"])

    @property
    def n_vertices(self) -> int:
        """Vertex count of the input."""
        return int(self._d["vertices"].shape[0])

    @property
    def costs(self) -> np.ndarray:
        """(n_steps,) the cost of each collapse (the heap key it was done at)."""
        return self._d["cost"]

    @property
    def records(self) -> dict:
        """The collapse records, in input vertex / face numbering: removed, kept, position
        (of the kept vertex after the collapse), position_before (of the kept vertex before
        it), dead_faces (input faces removed, -1: none), cost, error.  Read from the end,
        each row is a vertex split of the base mesh."""
        d = self._d
        iv, inf = d["input_vertex"], d["input_face"]
        dead = d["dead_faces"]
        before = self._previous_record()
        pos_before = d["vertices"][iv[d["kept"]]].copy()
        has = before >= 0
        pos_before[has] = d["position"][before[has]]
        return {
            "removed": iv[d["removed"]].astype(np.int64),
            "kept": iv[d["kept"]].astype(np.int64),
            "position": d["position"].copy(),
            "position_before": pos_before,
            "dead_faces": np.where(dead >= 0, inf[np.maximum(dead, 0)], -1).astype(np.int64),
            "cost": d["cost"].copy(),
            "error": d["error"].copy(),
            **({"bound": d["bound"] * float(d["error_scale"])} if "bound" in d else {}),
        }

    def n_faces_at(self, step: int) -> int:
        return int(self.faces_per_step[self._check_step(step)])

    def __repr__(self) -> str:
        return (f"ProgressiveMesh({self.faces_per_step[0]} -> {self.faces_per_step[-1]} faces, "
                f"{self.n_steps} collapses, metrics={self.info.get('metrics')})")

    # ------------------------------------------------------------------ choosing a step
    def _check_step(self, step) -> int:
        s = _validate_cardinal("step", step, 0, self.n_steps)
        if not self.stops[s]:
            raise OptionError(f"step {s} falls inside a seam pair (two collapses done together); "
                              f"use {s - 1} or {s + 1}")
        return s

    def step_for(self, *, faces=None, ratio=None, error=None, step=None, bound=None) -> int:
        """The step ``at`` extracts for the target given (exactly one)."""
        given = [k for k, v in (("faces", faces), ("ratio", ratio), ("error", error), ("step", step),
                                ("bound", bound)) if v is not None]
        if len(given) != 1:
            raise OptionError("give exactly one of faces=, ratio=, error=, bound= or step=")
        if step is not None:
            return self._check_step(step)
        if bound is not None:
            return self._bound_step(bound)
        if ratio is not None:
            try:
                r = float(ratio)
            except (TypeError, ValueError):
                raise OptionError(f"ratio must be a number in (0, 1], got {ratio!r}") from None
            if isinstance(ratio, bool) or not (0.0 < r <= 1.0):
                # as simplify(target_ratio=) and --ratio: faces=0 or step=n_steps for the base
                raise OptionError(f"ratio must be in (0, 1] (faces=0 gives the base mesh), got {ratio!r}")
            faces = int(round(r * self.n_input_faces))      # as simplify(target_ratio=) does
        if faces is not None:
            if isinstance(faces, bool) or not isinstance(faces, (int, np.integer)) or faces < 0:
                raise OptionError(f"faces must be a non-negative integer, got {faces!r}")
            faces = int(faces)
            min_faces = int(self._d["min_faces"])
            if faces < min_faces:
                raise OptionError(f"this progressive mesh was built down to min_faces={min_faces}; "
                                  f"cannot extract {faces} faces")
            # the first stopping state with at most `faces` faces (simplify stops there);
            # if none, the base mesh (simplify runs out of collapses there too)
            ok = np.flatnonzero((self.faces_per_step <= faces) & self.stops)
            return int(ok[0]) if ok.size else self.n_steps
        try:
            e = float(error)
        except (TypeError, ValueError):
            raise OptionError(f"error must be a number >= 0, got {error!r}") from None
        if not e >= 0.0:
            raise OptionError(f"error must be >= 0, got {error!r}")
        # the longest run of collapses none of which exceeds the error (simplify's test:
        # err > limit, in the core's units)
        limit = e / float(self._d["error_scale"])
        over = np.flatnonzero(self._raw_errors > limit)
        s = int(over[0]) - 1 if over.size else self.n_steps
        while not self.stops[s]:
            s -= 1
        return s

    def _bound_step(self, bound) -> int:
        """The last stopping state certified within ``bound`` (in the unit of the errors)."""
        if self.bounds_per_step is None:
            raise OptionError("bound= needs a progressive mesh built with error='hausdorff' (and max_error): "
                              "only those certify a distance per step")
        try:
            b = float(bound)
        except (TypeError, ValueError):
            raise OptionError(f"bound must be a number >= 0, got {bound!r}") from None
        if isinstance(bound, bool) or not b >= 0.0:
            raise OptionError(f"bound must be a number >= 0, got {bound!r}")
        # the certified distance never decreases along the steps (a running maximum)
        s = int(np.searchsorted(self._raw_bounds, b / float(self._d["error_scale"]), side="right")) - 1
        while not self.stops[s]:
            s -= 1
        return s

    # ------------------------------------------------------------------ extraction
    def at(self, *, faces=None, ratio=None, error=None, step=None, bound=None):
        """The mesh after the collapses the target allows: ``faces=N`` (the first state
        with at most N faces), ``ratio=R`` (N = round(R * input faces)), ``error=E`` (the
        longest prefix whose collapses all have error <= E), ``bound=D`` (the last state
        certified within D of the input, both ways: progressive meshes built with
        ``error="hausdorff"``; D in the unit of the errors) or ``step=S``."""
        return self.level(faces=faces, ratio=ratio, error=error, step=step, bound=bound).mesh

    def level(self, *, faces=None, ratio=None, error=None, step=None, bound=None) -> Level:
        """Like :meth:`at`, with the vertex and face maps and the error."""
        s = self.step_for(faces=faces, ratio=ratio, error=error, step=step, bound=bound)
        d = self._d
        face_idx = np.flatnonzero(self._fgone > s)
        # each removed slot points at the slot it merged into, from state `s` on; pointer
        # jumping (on the removed slots only) gives every slot its representative there
        parent = self._identity.copy()
        done = d["removed"][:s]
        parent[done] = d["kept"][:s]
        while done.size:
            up = parent[parent[done]]
            moved = up != parent[done]
            parent[done] = up
            done = done[moved]
        corners = np.take(parent, np.take(d["corners"], face_idx, axis=0))
        slots = np.flatnonzero(self._vgone > s)
        return self._assemble(face_idx, corners, slots, self._last_records(s), s)

    def lods(self, targets) -> list:
        """Meshes for several targets: ints are face counts, floats in (0, 1] ratios of the
        input face count."""
        return [self.at(**self._target(t)) for t in targets]

    def levels(self, targets) -> list:
        return [self.level(**self._target(t)) for t in targets]

    @staticmethod
    def _target(t) -> dict:
        if isinstance(t, (bool, np.bool_)):
            raise OptionError(f"a LOD target is a face count or a ratio, got {t!r}")
        if isinstance(t, (int, np.integer)):
            return {"faces": int(t)}
        if isinstance(t, (float, np.floating)):
            if not (0.0 < t <= 1.0):
                raise OptionError(f"a ratio target must be in (0, 1], got {t!r}")
            return {"ratio": float(t)}
        raise OptionError(f"a LOD target is a face count (int) or a ratio (float), got {t!r}")

    def _last_records(self, s) -> np.ndarray:
        """(n_slots,) for each vertex slot, the index of the last record before state
        ``s`` that kept it (-1: none): the records i < s whose next record for the same
        slot is at s or later, one per slot."""
        last = np.full(self._identity.shape[0], -1, dtype=np.int64)
        sel = np.flatnonzero(self._next_record[:s] >= s)
        last[self._d["kept"][sel]] = sel
        return last

    def _previous_record(self) -> np.ndarray:
        """(n_steps,) for each record, the previous record that kept the same slot (-1)."""
        order = self._by_kept
        kept = self._d["kept"][order]
        prev = np.full(self.n_steps, -1, dtype=np.int64)
        if self.n_steps > 1:
            same = kept[1:] == kept[:-1]
            prev[order[1:][same]] = order[:-1][same]
        return prev

    def _slot_attributes(self):
        if self._slot_attr is None and self._names:
            iv = self._d["input_vertex"]
            self._slot_attr = np.concatenate([self._d["input_" + n][iv] for n, _ in self._names], axis=1)
        return self._slot_attr

    def _assemble(self, face_idx, corners, slots, last, s) -> Level:
        """The output mesh from live face slots (with their corner slots) and live vertex
        slots, as lodkit._pipeline.extract builds it."""
        d = self._d
        face_map = d["input_face"][face_idx].astype(np.int64)
        if self._faces_reordered:
            by_input = np.argsort(face_map, kind="stable")
            face_map, corners = face_map[by_input], corners[by_input]
        iv = d["input_vertex"]
        inputs = iv[slots]
        if self._welded:
            vertex_map, first, inverse = np.unique(inputs, return_index=True, return_inverse=True)
        else:                                        # no split copies: slots are in input order
            vertex_map, first, inverse = inputs, np.arange(slots.size), np.arange(slots.size)
        slot_to_out = np.full(iv.shape[0], -1, dtype=np.int32)
        slot_to_out[slots] = inverse.reshape(-1)
        out_faces = slot_to_out[corners].astype(np.int32)
        rec = last[slots[first]]
        has = np.flatnonzero(rec >= 0)
        rec = rec[has]
        verts = d["vertices"][vertex_map]
        verts[has] = d["position"][rec]
        attrs = {}
        if self._names:
            block = self._slot_attributes()[slots[first]]
            block[has] = d["attributes"][rec]
            attrs = attribute_arrays(block, self._names)
        mesh = _trusted_mesh(verts, out_faces, attrs)
        if self._back is not None:
            mesh = self._back(mesh)
        return Level(mesh, vertex_map.astype(np.int64), face_map,
                     float(self.errors_per_step[s]), int(s))

    # ------------------------------------------------------------------ the cursor
    def cursor(self, step: int | None = None) -> Cursor:
        """A new cursor (independent of ``pm.refine`` / ``pm.coarsen``), at ``step``
        (default: the base mesh).  A cursor is for one thread; give each thread its own."""
        return Cursor(self, self.n_steps if step is None else step)

    def _default_cursor(self) -> Cursor:
        if self._cursor is None:
            self._cursor = Cursor(self, self.n_steps)
        return self._cursor

    def refine(self, n: int = 1) -> int:
        """Undo ``n`` collapses (vertex splits) at the built-in cursor; returns the step.
        The built-in cursor is thread-safe: each call is done whole under a lock."""
        with self._lock:
            return self._default_cursor().refine(n)

    def coarsen(self, n: int = 1) -> int:
        """Redo ``n`` collapses at the built-in cursor; returns the step (thread-safe)."""
        with self._lock:
            return self._default_cursor().coarsen(n)

    @property
    def current(self):
        """The mesh at the built-in cursor (which starts at the base mesh).  To read the
        step and the mesh together while other threads move it, use :meth:`current_level`."""
        with self._lock:
            return self._default_cursor().mesh

    def current_level(self) -> Level:
        """The built-in cursor's :class:`Level` (mesh, maps, error and step, taken together)."""
        with self._lock:
            return self._default_cursor().level()

    @property
    def step(self) -> int:
        """The built-in cursor's step."""
        with self._lock:
            return self._default_cursor().step

    def _relabel_events(self):
        """Per step, the face corners (face * 3 + j) of faces that survive the step whose
        vertex slot is the removed one: they move to the kept slot.  CSR: (offsets, corners)."""
        if self._events is None:
            d = self._d
            S = self.n_steps
            m = d["corners"].shape[0]
            corner = np.arange(3 * m, dtype=np.int64)
            label = d["corners"].reshape(-1).astype(np.int64)
            fgone = np.repeat(self._fgone, 3)
            ev_step, ev_corner = [], []
            while corner.size:
                gone = self._vgone[label]              # the state from which the label is gone
                # it moves at step gone - 1, if the face is still there after that step
                keep = (gone <= S) & (fgone[corner] > gone)
                corner, label, gone = corner[keep], label[keep], gone[keep]
                ev_step.append(gone - 1)
                ev_corner.append(corner)
                label = d["kept"][gone - 1].astype(np.int64)
            steps = np.concatenate(ev_step) if ev_step else np.zeros(0, np.int64)
            corners = np.concatenate(ev_corner) if ev_corner else np.zeros(0, np.int64)
            order = np.argsort(steps, kind="stable")
            offsets = np.zeros(S + 1, dtype=np.int64)
            np.cumsum(np.bincount(steps, minlength=S), out=offsets[1:])
            self._events = (offsets, corners[order].astype(np.int64), self._previous_record())
        return self._events

    # ------------------------------------------------------------------ files
    def save(self, path) -> None:
        """Write to one ``.npz`` file (compressed), atomically: the target is either left
        as it was or completely replaced."""
        p = os.fspath(path)
        directory = os.path.dirname(os.path.abspath(p)) or "."
        if os.path.isdir(p):
            raise MeshIOError(f"cannot save {p}: it is a directory")
        if not os.path.isdir(directory):
            raise MeshIOError(f"cannot save {p}: directory {directory} does not exist")
        d = self._d
        arrays = {k: np.asarray(v) for k, v in d.items()}
        # the exact narrow types: indices fit in int32, positions and errors stay float64
        for k in ("input_vertex", "input_face", "corners", "removed", "kept", "dead_faces"):
            arrays[k] = arrays[k].astype(np.int32)
        arrays["pair_open"] = arrays["pair_open"].astype(bool)
        # the slot maps are usually the identity (no unused vertices, degenerate faces nor
        # non-manifold copies): left out, and made again on load
        for k in ("input_vertex", "input_face"):
            if np.array_equal(arrays[k], np.arange(arrays[k].shape[0])):
                arrays[k + "_size"] = np.array(arrays.pop(k).shape[0], dtype=np.int64)
        arrays["format"] = np.array(FORMAT)
        arrays["format_version"] = np.array(FORMAT_VERSION, dtype=np.int32)
        arrays["info"] = np.array(json.dumps(self.info))
        try:
            atomic_write(p, lambda fh: np.savez_compressed(fh, **arrays), binary=True)
        except MeshIOError:
            raise
        except OSError as exc:
            raise MeshIOError(f"cannot save {p}: {exc.strerror or exc}") from exc

    @classmethod
    def load(cls, path) -> ProgressiveMesh:
        """Read a file written by :meth:`save`; MeshIOError if it is not one (or is damaged)."""
        p = os.fspath(path)
        try:
            with np.load(p, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
        except FileNotFoundError:
            raise MeshIOError(f"cannot load {p}: no such file") from None
        except IsADirectoryError:
            raise MeshIOError(f"cannot load {p}: it is a directory") from None
        except (zipfile.BadZipFile, ValueError, OSError, EOFError, KeyError) as exc:
            raise MeshIOError(f"cannot load {p}: not a lodkit progressive mesh file or damaged ({exc})") from None
        fmt = arrays.pop("format", None)
        if fmt is None or fmt.shape != () or str(fmt) != FORMAT:
            raise MeshIOError(f"cannot load {p}: not a lodkit progressive mesh file (no '{FORMAT}' format field)")
        version = arrays.pop("format_version", None)
        if version is None or version.shape != () or int(version) != FORMAT_VERSION:
            got = None if version is None else version.tolist()
            raise MeshIOError(f"cannot load {p}: format version {got}, this lodkit reads version {FORMAT_VERSION}")
        try:
            info = json.loads(str(arrays.pop("info")))
        except (KeyError, ValueError) as exc:
            raise MeshIOError(f"cannot load {p}: damaged info field ({exc})") from None
        for k in ("input_vertex", "input_face"):
            size = arrays.pop(k + "_size", None)
            if size is not None and k not in arrays:
                if size.shape != () or size.dtype.kind not in "iu" or not 0 <= int(size) < 2**31:
                    raise MeshIOError(f"cannot load {p}: damaged progressive mesh (bad {k}_size)")
                arrays[k] = np.arange(int(size), dtype=np.int32)
        problem = _check_arrays(arrays)
        if problem:
            raise MeshIOError(f"cannot load {p}: damaged progressive mesh ({problem})")
        for k in ("input_vertex", "input_face", "corners", "removed", "kept", "dead_faces"):
            arrays[k] = arrays[k].astype(np.int32)
        return cls(arrays, info)


def _check_arrays(a: dict) -> str:
    """'' if the arrays make a consistent progressive mesh, else what is wrong."""
    need = {"vertices": (2, "f"), "input_vertex": (1, "iu"), "input_face": (1, "iu"),
            "corners": (2, "iu"), "removed": (1, "iu"), "kept": (1, "iu"), "position": (2, "f"),
            "dead_faces": (2, "iu"), "pair_open": (1, "b"), "cost": (1, "f"), "error": (1, "f"),
            "attributes": (2, "f"), "error_scale": (0, "f"), "n_input_faces": (0, "iu"),
            "min_faces": (0, "iu")}
    for k, (ndim, kinds) in need.items():
        if k not in a:
            return f"missing array {k!r}"
        if a[k].ndim != ndim or a[k].dtype.kind not in kinds:
            return f"array {k!r} has shape {a[k].shape} and type {a[k].dtype}"
    n, S, m, ns = a["vertices"].shape[0], a["removed"].shape[0], a["corners"].shape[0], a["input_vertex"].shape[0]
    if a["vertices"].shape[1] != 3 or a["corners"].shape[1] != 3 or a["position"].shape != (S, 3) \
            or a["dead_faces"].shape != (S, 2):
        return "array shapes disagree"
    for k in ("kept", "pair_open", "cost", "error", "attributes"):
        if a[k].shape[0] != S:
            return f"array {k!r} has {a[k].shape[0]} rows, not {S}"
    if "bound" in a and (a["bound"].shape != (S,) or a["bound"].dtype.kind != "f"):
        return f"array 'bound' has shape {a['bound'].shape} and type {a['bound'].dtype}"
    if a["input_face"].shape[0] != m:
        return "input_face and corners disagree"
    width = 0
    for name in _ATTRIBUTES:
        arr = a.get("input_" + name)
        if arr is not None:
            if arr.ndim != 2 or arr.shape[0] != n or arr.dtype.kind != "f":
                return f"array 'input_{name}' has shape {arr.shape}"
            width += arr.shape[1]
    if a["attributes"].shape[1] != width:
        return "the attribute records do not match the input attributes"

    def inside(x, hi):
        return x.size == 0 or (x.min() >= 0 and x.max() < hi)

    if not (inside(a["input_vertex"], n) and inside(a["corners"], ns) and inside(a["removed"], ns)
            and inside(a["kept"], ns) and inside(a["input_face"], int(a["n_input_faces"]))):
        return "an index is out of range"
    dead = a["dead_faces"]
    if dead.size and (dead.min() < -1 or dead.max() >= m):
        return "a dead face index is out of range"
    if np.unique(a["removed"]).size != S or not _kept_before_removed(a["removed"], a["kept"]):
        return "the collapse records are inconsistent"
    if not (np.isfinite(a["vertices"]).all() and np.isfinite(a["position"]).all()):
        return "non-finite positions"
    return ""


def _kept_before_removed(removed, kept) -> bool:
    """A slot may be kept by a collapse only while it is there: before it is removed."""
    if removed.size == 0:
        return True
    gone = np.full(max(int(removed.max()), int(kept.max())) + 1, np.iinfo(np.int64).max, dtype=np.int64)
    gone[removed] = np.arange(removed.size)
    return bool(np.all(gone[kept] > np.arange(kept.size)))


class Cursor:
    """A position in a progressive mesh that moves one vertex split (``refine``) or edge
    collapse (``coarsen``) at a time; each move costs what the step changes (the corners
    that move, the faces that come or go), not a re-extraction.  ``mesh`` builds the
    current mesh (O(mesh size)); it equals ``pm.at(step=cursor.step)``."""

    def __init__(self, pm: ProgressiveMesh, step: int):
        self.pm = pm
        s = pm._check_step(step)
        d = pm._d
        self._offsets, self._ev_corners, self._prev = pm._relabel_events()
        # the state at step s by extraction; the corner labels of dead faces are those they
        # had when they died (so that a split brings them back as they were)
        m = d["corners"].shape[0]
        label = d["corners"].reshape(-1).astype(np.int32).copy()
        offs, evc = self._offsets, self._ev_corners
        if s:
            upto = offs[s]
            order = np.arange(upto)
            step_of = np.repeat(np.arange(s), np.diff(offs[:s + 1]))
            # the corners relabelled in steps 0..s-1; the last relabel of each corner wins
            last = np.full(3 * m, -1, dtype=np.int64)
            np.maximum.at(last, evc[order], step_of)
            moved = last >= 0
            label[moved] = d["kept"][last[moved]]
        self._label = label
        self._face_alive = pm._fgone > s
        self._vert_alive = pm._vgone > s
        self._last = pm._last_records(s)
        self._step = s

    @property
    def step(self) -> int:
        return self._step

    @property
    def n_faces(self) -> int:
        return int(self.pm.faces_per_step[self._step])

    def _apply(self, i: int) -> None:                 # collapse i
        d = self.pm._d
        k = d["kept"][i]
        self._label[self._ev_corners[self._offsets[i]:self._offsets[i + 1]]] = k
        dead = d["dead_faces"][i]
        self._face_alive[dead[dead >= 0]] = False
        self._vert_alive[d["removed"][i]] = False
        self._last[k] = i

    def _undo(self, i: int) -> None:                  # vertex split i
        d = self.pm._d
        self._label[self._ev_corners[self._offsets[i]:self._offsets[i + 1]]] = d["removed"][i]
        dead = d["dead_faces"][i]
        self._face_alive[dead[dead >= 0]] = True
        self._vert_alive[d["removed"][i]] = True
        self._last[d["kept"][i]] = self._prev[i]

    def coarsen(self, n: int = 1) -> int:
        """Do the next ``n`` collapses (a seam pair counts as one); stops at the base mesh.
        Returns the new step."""
        n = _validate_cardinal("n", n, 0, 2**62)
        stops = self.pm.stops
        for _ in range(n):
            if self._step >= self.pm.n_steps:
                break
            self._apply(self._step)
            self._step += 1
            while not stops[self._step]:
                self._apply(self._step)
                self._step += 1
        return self._step

    def refine(self, n: int = 1) -> int:
        """Undo the last ``n`` collapses (vertex splits; a seam pair counts as one); stops
        at the input.  Returns the new step."""
        n = _validate_cardinal("n", n, 0, 2**62)
        stops = self.pm.stops
        for _ in range(n):
            if self._step <= 0:
                break
            self._step -= 1
            self._undo(self._step)
            while not stops[self._step]:
                self._step -= 1
                self._undo(self._step)
        return self._step

    def seek(self, step: int) -> int:
        """Walk to ``step`` by refining or coarsening."""
        s = self.pm._check_step(step)
        while self._step < s:
            self.coarsen()
        while self._step > s:
            self.refine()
        return self._step

    def level(self) -> Level:
        face_idx = np.flatnonzero(self._face_alive)
        corners = self._label.reshape(-1, 3)[face_idx]
        slots = np.flatnonzero(self._vert_alive)
        return self.pm._assemble(face_idx, corners, slots, self._last, self._step)

    @property
    def mesh(self):
        return self.level().mesh
