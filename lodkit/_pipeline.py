"""The steps every :func:`lodkit.simplify` driver shares, in the order they run:

    start()          -> Work      clean-up and half-edge arrays (prepare), pair contraction,
                                  locks, attribute seams, attribute block, the core's vertex rows
    metric_context() -> MetricContext   what the metrics see at set-up
    (the driver runs: lodkit.drivers)   -> Run
    extract()        -> (Mesh, vertex_map, face_map, polish report)   the live part of the
                                  half-edge arrays (then lodkit.polish, when asked)
    report()         -> dict      result.report

Also the helpers the drivers share: the chunked run loop with its progress bar and the
core's layout and status numbers, named once.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import _progress
from ._core.decimate import vertex_quadrics
from ._core.halfedge import (
    bounding_box,
    build,
    count_face_components,
    faces_by_first_slot,
    has_border,
    live_output,
    morton_permutation,
    normalised_positions,
    used_vertices,
)
from .errors import MeshError
from .geometry import box_diagonal
from .mesh import Mesh
from .metrics import MetricContext
from .pairs import contract_pairs
from .settings import locked_mask

# The core's per-vertex row (lodkit/_core/common.pxd, QSIZE and VSTRIDE): the quadric
# a11 a12 a13 a22 a23 a33 b1 b2 b3 c w (w = summed face area), then the position x y z.
QSIZE = 11
VSTRIDE = 14
PLANE_SIZE = 10            # the quadric without w: the packed 3D plane quadric a metric gives

# What a driver's run(target, max_steps) returns (common.pxd RunStatus)
RUN_TARGET = 0             # face target reached
RUN_CHUNK = 1              # max_steps operations done: call again
RUN_EXHAUSTED = 2          # no legal operation left (or none within max_error)
RUN_ERROR = 3              # a native kernel failed (the driver's error_message)

# Entries of seam_partners() besides a partner slot (edge.pxd SEAM_NONE / SEAM_STAYS)
SEAM_NONE = -1             # not on an attribute seam
SEAM_STAYS = -2            # a seam copy that may neither move nor go

#: Stop reasons, as found in :attr:`lodkit.SimplifyResult.stop_reason`.
STOP_TARGET = "target_faces"          # the face target (target_faces / target_ratio) was reached
STOP_MAX_ERROR = "max_error"          # every remaining collapse would exceed max_error
STOP_NO_COLLAPSE = "no_valid_collapse"  # no collapse passes the checks (topology, flips, locks)

# Run the nogil loop in chunks of this fraction of the work, to draw the progress bar.
PROGRESS_CHUNKS = 50
# ... and of at most this many operations (a few tens of milliseconds at 1M faces), so that
# Ctrl-C (the signal handlers run between chunks) and a progress callable are heard soon.
# A chunk boundary never changes the result (the drivers keep their whole state between
# calls; the pass driver ends a chunk only between passes).
INTERRUPT_CHUNK = 4096


@dataclass
class Prepared:
    """A mesh cleaned and turned into half-edge arrays, ready for a driver."""

    hm: Any                      # lodkit._core.halfedge.HalfEdgeMesh
    positions: np.ndarray | None  # (n_slots, 3) normalised positions: the last columns of ``rows``
    rows: np.ndarray | None      # (n_slots, width) the array that holds them (start(): the core's rows)
    input_vertex: np.ndarray     # (n_slots,) input vertex index of each slot
    input_face: np.ndarray       # (m_kept,) input face index of each face slot
    center: np.ndarray
    scale: float                 # bbox diagonal of the input
    n_degenerate_faces: int
    n_unreferenced_vertices: int
    memory_order: bool = False   # vertex and face slots sorted along a Morton curve


def prepare(mesh: Mesh, *, memory_order: bool = False, threads: int = 1, width: int = 3) -> Prepared:
    """Drop faces with a repeated index and unreferenced vertices, normalise positions
    (centre of the bbox at the origin, unit diagonal) and build the half-edge arrays.

    ``memory_order``: lay the vertex slots out along a Morton curve of their positions and
    the face slots by their first vertex slot, so that vertices and faces close on the
    surface are close in memory (the pass driver walks them in slot order); the maps
    (``input_vertex``, ``input_face``) take the permutations, so nothing downstream sees
    them but the speed.  ``threads``: OpenMP threads of the Morton codes, the face order
    and the half-edge build (the arrays are the same for any number).  ``width``: the positions are the
    last three columns of a (n_slots, width) array (``rows``), so that :func:`start` gets
    the core's vertex rows without copying them."""
    faces = mesh.faces
    if faces.shape[0] == 0:
        raise MeshError("the mesh has no faces")
    # the used vertices (of the faces without a repeated index) and the faces with one,
    # in one pass over the faces
    used, n_degenerate = used_vertices(faces, mesh.n_vertices)
    if n_degenerate == faces.shape[0]:
        raise MeshError(f"all {faces.shape[0]} faces repeat a vertex index (zero area); nothing to simplify")
    if n_degenerate:
        degenerate = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
        input_face = np.flatnonzero(~degenerate).astype(np.int32)
        faces = faces[input_face]
        del degenerate
    else:
        input_face = np.arange(faces.shape[0], dtype=np.int32)
    input_vertex = np.flatnonzero(used).astype(np.int32)
    del used
    if input_vertex.size == mesh.n_vertices:
        compact = faces                                 # every vertex is used: no renumbering
    else:
        remap = np.full(mesh.n_vertices, -1, dtype=np.int32)
        remap[input_vertex] = np.arange(input_vertex.size, dtype=np.int32)
        compact = remap[faces]
        del remap
    lo, hi = bounding_box(mesh.vertices, None if input_vertex.size == mesh.n_vertices else input_vertex)
    with np.errstate(over="ignore", invalid="ignore"):
        center = 0.5 * lo + 0.5 * hi
        scale = box_diagonal(lo, hi)
    if not scale > 0.0:
        raise MeshError("all vertices used by faces coincide: the bounding box has zero size")
    if not np.isfinite(scale):
        raise MeshError(f"the bounding box is too large to measure (coordinates up to "
                        f"{np.abs(mesh.vertices[input_vertex]).max():.3g}); rescale the mesh")
    if memory_order:
        # (geometry.morton_order and a stable argsort of the faces' smallest slot, in
        # the core: the same permutations, by radix and counting sorts)
        perm = morton_permutation(mesh.vertices, input_vertex, (lo, hi), threads)
        slot_of = np.empty_like(perm)
        slot_of[perm] = np.arange(perm.size, dtype=np.int32)
        # (an arange taken through a permutation is the permutation: no gather)
        input_vertex = perm if input_vertex.size == mesh.n_vertices else input_vertex[perm]
        compact, by_first = faces_by_first_slot(compact, int(input_vertex.size), True, slot_of, threads)
        input_face = by_first if not n_degenerate else input_face[by_first]
        del perm, slot_of, by_first
    # compact is ours to hand over unless it is still the caller's face array
    hm = build(compact, int(input_vertex.size), threads, take=compact is not mesh.faces)
    del compact, faces
    slot_input = input_vertex[hm.vertex_sources] if hm.n_split_vertices else input_vertex
    rows = np.empty((slot_input.size, width), dtype=np.float64)
    positions = rows[:, width - 3:]
    normalised_positions(mesh.vertices, slot_input, center, scale, positions)
    return Prepared(hm, positions, rows, slot_input, input_face, center, scale,
                    n_degenerate, int(mesh.n_vertices - input_vertex.size), bool(memory_order))


@dataclass
class Work:
    """One run's input, ready for a driver: the (pair-contracted) mesh, its half-edge arrays
    and the core's arrays, one row per vertex slot."""

    src: Mesh                    # the mesh the half-edge arrays were built from
    prep: Prepared
    fixed: np.ndarray            # (n_slots,) bool: may neither move nor go
    seams: np.ndarray | None  # seam_partners(), None without seams
    n_seam_fixed: int            # seam copies made fixed
    names: list                  # (attribute name, width) in column order of ``attributes``
    layout: dict                 # attribute name -> its first column in ``attributes``
    attributes: np.ndarray | None   # (n_slots, k) the input's attributes, None without any
    vdata: np.ndarray            # (n_slots, VSTRIDE): plain face quadric, then position
    input_faces: int             # faces of the mesh as given (before pair contraction)
    pair_report: dict | None = None
    welded_faces: np.ndarray | None = None   # after pair contraction / pruning: input face of each face
    prune_report: dict | None = None
    normals: np.ndarray | None = None   # (3 m,) int16 input face normals for the edge collapser, or None

    @property
    def positions(self) -> np.ndarray:
        """(n_slots, 3) the normalised positions the core moves (a view of ``vdata``)."""
        return self.vdata[:, QSIZE:]


def start(src: Mesh, settings: dict, *, locked=None, pair_threshold=None, absolute: bool = False,
          fix_seams: bool = False, memory_order: bool = False, prune: float | None = None,
          input_normals: bool = False) -> Work:
    """Everything before the metrics: pair contraction (when ``pair_threshold`` is given),
    :func:`prepare`, the fixed vertices (non-manifold copies, ``locked``, the boundary
    under "lock", attribute seam copies that stay -- every seam copy with ``fix_seams``, for
    a driver that cannot keep a seam closed), the attribute block and the vertex rows with
    the plain face quadrics (they place the vertex and measure the error when no quadric
    metric is given).  ``input_normals``: also the input faces' int16 unit normals (the
    edge collapser's; made from the face planes the quadrics need anyway, not in a face
    pass of the collapser's own)."""
    input_faces, pair_report, welded_faces = src.n_faces, None, None
    if pair_threshold is not None:
        src, welded_faces, pair_report = contract_pairs(
            src, pair_threshold, absolute=absolute,
            locked=None if locked is None else locked_mask(locked, src.n_vertices))
    prune_report = None
    if prune is not None:
        src, kept_faces, prune_report = prune_debris(src, prune)
        welded_faces = kept_faces if welded_faces is None else welded_faces[kept_faces]
    threads = int(settings.get("threads", (1,))[0])
    prep = prepare(src, memory_order=memory_order, threads=threads, width=VSTRIDE)
    hm = prep.hm
    fixed = hm.locked_vertices.copy()
    if locked is not None:
        fixed |= locked_mask(locked, src.n_vertices)[prep.input_vertex]
    attrs = src.attributes()
    names, layout, col = [], {}, 0
    for name, arr in attrs.items():
        names.append((name, arr.shape[1]))
        layout[name] = col
        col += arr.shape[1]
    attributes = np.concatenate([arr[prep.input_vertex] for arr in attrs.values()], axis=1) if attrs else None
    vdata = prep.rows                            # the positions are in place; the quadrics follow
    prep.positions = prep.rows = None
    normals = np.zeros(3 * hm.n_faces, dtype=np.int16) if input_normals else None
    vertex_quadrics(hm, vdata[:, QSIZE:], 0.0, out=vdata, threads=threads, normals=normals)
    n_seam_fixed = 0
    seams = seam_partners(src, prep, fixed)
    if settings["boundary"][0] == "lock":
        # the true border stays; a seam is no border (its pairs collapse together)
        fixed |= hm.boundary_vertices if seams is None else hm.boundary_vertices & (seams == SEAM_NONE)
    if seams is not None:
        stays = seams != SEAM_NONE if fix_seams else seams == SEAM_STAYS
        fixed |= stays
        n_seam_fixed = int(np.count_nonzero(stays))
    return Work(src, prep, fixed, seams, n_seam_fixed, names, layout, attributes, vdata,
                input_faces, pair_report, welded_faces, prune_report, normals)


#: twice a face's area at most this times its summed squared edge lengths: zero area, up to
#: rounding (quality below ~3.5e-12); ``prune`` removes such faces
ZERO_AREA = 1e-12


def prune_debris(src: Mesh, size: float):
    """``simplify(prune=)``: (mesh, kept input faces, report) without the debris of ``src``:

    - zero-area faces: twice the area at most ZERO_AREA (1e-12) times the sum of the
      squared edge lengths (collinear or coincident corners, up to rounding);
    - small parts: connected components (faces sharing a position, so attribute seams do
      not part them) whose bounding-box diagonal is below ``size`` times the whole mesh's.
      The part with the most faces always stays.

    The vertices stay (unreferenced ones are dropped later, by :func:`prepare`)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from .geometry import face_vectors, weld_positions

    faces = src.faces
    m = faces.shape[0]
    keep = np.ones(m, dtype=bool)
    v = src.vertices
    if m:
        cross = face_vectors(v, faces)
        twice_area = np.linalg.norm(cross, axis=1)
        p0, p1, p2 = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
        sum_sq = (np.einsum("ij,ij->i", p1 - p0, p1 - p0) + np.einsum("ij,ij->i", p2 - p1, p2 - p1)
                  + np.einsum("ij,ij->i", p0 - p2, p0 - p2))
        keep &= twice_area > ZERO_AREA * sum_sq
    n_zero = int(m - np.count_nonzero(keep))
    n_parts, part_faces = 0, 0
    if m and size > 0.0:
        positions, wf = weld_positions(v, faces)
        k = positions.shape[0]
        rows = np.concatenate([wf[:, 0], wf[:, 1]])
        cols = np.concatenate([wf[:, 1], wf[:, 2]])
        graph = coo_matrix((np.ones(2 * m), (rows, cols)), shape=(k, k))
        n_comp, label = connected_components(graph, directed=False)
        if n_comp > 1:
            face_label = label[wf[:, 0]]
            corners = np.repeat(face_label, 3)
            pts = positions[wf.reshape(-1)]
            lo = np.full((n_comp, 3), np.inf)
            hi = np.full((n_comp, 3), -np.inf)
            for c in range(3):
                np.minimum.at(lo[:, c], corners, pts[:, c])
                np.maximum.at(hi[:, c], corners, pts[:, c])
            diag = np.linalg.norm(hi - lo, axis=1)
            whole = float(np.linalg.norm(positions.max(axis=0) - positions.min(axis=0)))
            counts = np.bincount(face_label, minlength=n_comp)
            small = diag < size * whole
            small[int(np.argmax(counts))] = False
            drop = small[face_label] & keep
            n_parts = int(np.count_nonzero(small & (counts > 0)))
            part_faces = int(np.count_nonzero(drop))
            keep &= ~small[face_label]
    kept = np.flatnonzero(keep)
    report = {"zero_area_faces": n_zero, "small_parts": n_parts, "small_part_faces": part_faces,
              "size": float(size)}
    if kept.size == m:
        return src, kept, report
    return Mesh(src.vertices, faces[kept], **src.attributes()), kept, report


def seam_partners(src: Mesh, prep: Prepared, fixed: np.ndarray) -> np.ndarray | None:
    """Attribute seams of the input, for the collapser's ``seam_partners``: (n_slots,)
    int32 holding each seam vertex's partner slot, SEAM_NONE (-1) off the seams and
    SEAM_STAYS (-2) for a seam copy that must stay; None when there are no seams.

    A seam is where a file splits a vertex to give it two sets of attributes (OBJ / glTF
    uv, normal or colour seams): two input vertices with bit-identical positions, each on
    a boundary chain of the split connectivity, the two chains running side by side in
    opposite directions.  A boundary half-edge a -> b is a seam edge when some boundary
    half-edge runs from a copy of b to a copy of a.  Two boundary copies of one position
    are partners when one's outgoing seam edge pairs with the other's incoming one (as in
    meshoptimizer, positions alone decide: equal attributes on both sides make no
    difference).  That includes the two copies at the end of a seam (where it meets a
    true boundary or stops) and fixed copies: ``EdgeCollapser`` fixes both copies of
    such a pair, but a seam pair next to it may still collapse into it.  Boundary
    vertices touching a seam that cannot be paired (more than two copies at one
    position) stay (-2).  Copies of one input vertex (non-manifold splits) are no seam;
    they are locked anyway."""
    hm = prep.hm
    n = hm.n_vertices
    if not has_border(hm):
        return None                                 # a seam is a pair of boundary chains
    corners = hm.corners.reshape(-1)
    border = hm.twins < 0
    he = np.flatnonzero(border & np.repeat(hm.alive_faces, 3))
    if he.size == 0:
        return None
    a = corners[he]
    b = corners[np.where(he % 3 == 2, he - 2, he + 1)]
    out_he = np.full(n, -1, dtype=np.int64)
    in_he = np.full(n, -1, dtype=np.int64)
    out_he[a] = np.arange(he.size)
    in_he[b] = np.arange(he.size)
    slots = np.flatnonzero(out_he >= 0)             # the boundary vertex slots
    # classes of equal position among them (+ 0.0: -0.0 and 0.0 are one position)
    pos = src.vertices[prep.input_vertex[slots]] + 0.0
    order = np.lexsort((pos[:, 2], pos[:, 1], pos[:, 0]))
    sp = pos[order]
    first = np.ones(slots.size, dtype=bool)
    first[1:] = (sp[1:] != sp[:-1]).any(axis=1)
    if first.all():
        return None                                 # no two boundary slots share a position
    cls = np.full(n, -1, dtype=np.int64)
    cls[slots[order]] = np.cumsum(first) - 1
    n_cls = int(cls.max()) + 1
    # distinct input vertices at each position (split copies of one vertex do not count)
    stride = int(prep.input_vertex.max()) + 1
    pairs = np.unique(cls[slots] * stride + prep.input_vertex[slots])
    n_inputs = np.bincount(pairs // stride, minlength=n_cls)
    forward = np.sort(cls[a] * n_cls + cls[b])
    backward = cls[b] * n_cls + cls[a]
    at = np.minimum(np.searchsorted(forward, backward), forward.size - 1)
    mated = forward[at] == backward                # a copy of b -> a copy of a exists
    shared = np.zeros(n, dtype=bool)
    shared[slots] = n_inputs[cls[slots]] >= 2
    n_boundary = np.bincount(cls[slots], minlength=n_cls)
    partners = np.full(n, SEAM_NONE, dtype=np.intc)
    two = slots[shared[slots] & (n_boundary[cls[slots]] == 2)]
    two = two[np.argsort(cls[two], kind="stable")]
    s, t = two[0::2], two[1::2]

    def chains_pair(x, y):
        # x's outgoing seam edge x -> c runs beside y's incoming one c' -> y
        o, i = out_he[x], in_he[y]
        return mated[o] & mated[i] & (cls[b[o]] == cls[a[i]])

    # chains side by side in at least one direction: along the seam, or at its end (where
    # it meets a true border or stops).  The collapser keeps an end, and a pair with a
    # fixed copy, in place; a seam pair next to one may still collapse into it
    ok = chains_pair(s, t) | chains_pair(t, s)
    partners[s[ok]] = t[ok]
    partners[t[ok]] = s[ok]
    near = shared.copy()
    near[a[mated]] = True
    near[b[mated]] = True
    partners[near & (partners < 0)] = SEAM_STAYS
    # the copies made for non-manifold input are locked by the half-edge build; their cut
    # edges pair up like seams, but unless another input vertex shares the position they
    # are no attribute seam
    partners[hm.locked_vertices & ~shared] = SEAM_NONE
    if not (partners != SEAM_NONE).any():
        return None
    return partners


def weld_cycles(group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rep, next) for the vertex remover's ``weld`` from a group id per slot (< 0: a slot
    alone): the slots of a group share the first of them as representative and form a
    cycle through ``next``; a slot alone (or alone in its group) is its own representative,
    with next -1.  Seams (drivers.vertex_removal.weld_groups: slots grouped by position)
    and the split copies of a non-manifold vertex (retile) weld this way."""
    group = np.asarray(group)
    n = group.size
    rep = np.arange(n, dtype=np.intc)
    nxt = np.full(n, -1, dtype=np.intc)
    members = np.flatnonzero(group >= 0)
    if members.size:
        order = members[np.argsort(group[members], kind="stable")]
        g = group[order]
        start = np.r_[True, g[1:] != g[:-1]]
        first = order[np.flatnonzero(start)][np.cumsum(start) - 1]     # each slot's group's first
        rep[order] = first
        last = np.r_[start[1:], True]                                  # last member of its group
        succ = np.where(last, first, np.r_[order[1:], 0])              # the last wraps to the first
        nxt[order] = np.where(start & last, -1, succ)
    return rep, nxt


def metric_context(work: Work, settings: dict) -> MetricContext:
    """What the metrics see at set-up: read-only views of the positions and plain face
    quadrics, the half-edge arrays, the fixed vertices and the run's settings."""
    prep = work.prep
    positions_ro = work.vdata[:, QSIZE:].view()
    positions_ro.flags.writeable = False
    face_quadrics = work.vdata[:, :PLANE_SIZE].view()
    face_quadrics.flags.writeable = False
    return MetricContext(positions=positions_ro, halfedge=prep.hm, input_vertex=prep.input_vertex,
                         input_face=prep.input_face, fixed=work.fixed.copy(), scale=prep.scale,
                         center=prep.center, mesh=work.src, face_quadrics=face_quadrics,
                         settings={"placement": settings["placement"][0], "boundary": settings["boundary"][0],
                                   "boundary_weight": float(settings["boundary_weight"][0])})


def error_limit(max_error, work: Work, absolute: bool) -> float:
    """``max_error`` in the core's normalised units (inf when not given)."""
    if max_error is None:
        return math.inf
    return float(max_error) / (work.prep.scale if absolute else 1.0)


def closed_connected(hm) -> bool:
    """True when the half-edge mesh has no boundary and one face-connected component."""
    return not has_border(hm) and count_face_components(hm) == 1


def progress_bar(progress, hm, target: int):
    """A progress reporter over the faces to remove (:func:`lodkit._progress.make`: a tqdm
    bar for True, the caller's function for a callable, None when ``progress`` is off)."""
    return _progress.make(progress, max(hm.n_alive_faces - target, 1))


def run_chunked(driver, hm, target: int, bar) -> int:
    """``driver.run(target, chunk)`` until it stops for another reason than the chunk
    (RUN_CHUNK), updating ``bar`` between chunks; returns the driver's final status.
    Between chunks Python runs its signal handlers (Ctrl-C raises KeyboardInterrupt here,
    within a chunk's time) and a progress callable may cancel."""
    start_faces = hm.n_alive_faces
    chunk = INTERRUPT_CHUNK
    if bar:
        chunk = min(chunk, max((start_faces - target) // (2 * PROGRESS_CHUNKS), 1000))
    while True:
        status = driver.run(target, chunk)
        if bar:
            bar.update(start_faces - hm.n_alive_faces)
        if status != RUN_CHUNK:
            return status


@dataclass
class Run:
    """What a driver hands back: the state of the vertex slots after the run, why it
    stopped, and its own counters for the report."""

    core: Any                    # the core's driver object (its records, once the run is over)
    positions: np.ndarray        # (n_slots, 3) normalised positions
    moved: np.ndarray | None  # (n_slots,) bool, the slots whose position is new (None: none)
    attributes: np.ndarray | None   # (n_slots, k) attributes after the run
    max_error: float             # largest error done, normalised
    n_collapses: int
    stop: str                    # a STOP_* reason
    detail: str                  # report["stop_detail"]
    seam_pair_collapses: int = 0
    counters: dict = field(default_factory=dict)   # the driver's entries of the report
    bound: float | None = None   # error="hausdorff": the distance certified, normalised


def extract(work: Work, run: Run, polish=None):
    """(Mesh, vertex_map, face_map, polish report or None): the live part of the half-edge
    arrays compacted into a Mesh, the copies made for non-manifold vertices welded back
    together; vertices that did not move keep their input position bit for bit.
    ``polish``: None, or ``f(input vertices, input faces, vertices, faces, slots) ->
    (vertices, report)`` run on the output before it is made a Mesh (lodkit.polish),
    ``slots`` the vertex slot each output vertex comes from."""
    src, prep = work.src, work.prep
    # weld: one output vertex per input vertex (split copies are locked, so they coincide);
    # faces in input order, whatever order the slots were laid out in
    verts, out_faces, vertex_map, face_map, rep = live_output(
        prep.hm, prep.input_vertex, prep.input_face, src.vertices, src.n_faces, prep.memory_order,
        run.moved, run.positions, prep.center, prep.scale)
    out_attrs = attribute_arrays(run.attributes[rep], work.names) if work.names else {}
    polished = None
    if polish is not None:
        verts, polished = polish(src.vertices, src.faces, verts, out_faces, rep)
    out = Mesh(verts, out_faces, **out_attrs)
    if work.welded_faces is not None:
        face_map = work.welded_faces[face_map]       # faces of the welded mesh -> input faces
    return out, vertex_map, face_map, polished


def attribute_arrays(block: np.ndarray, names) -> dict:
    """The output attributes from the core's attribute block (one row per output vertex,
    the columns of each ``(name, width)`` in turn): normals renormalised (a zero normal
    stays zero), colours clamped to [0, 1]."""
    out = {}
    col = 0
    for name, width in names:
        a = block[:, col:col + width]
        col += width
        if name == "normals":
            length = np.linalg.norm(a, axis=1, keepdims=True)
            a = np.divide(a, length, out=np.zeros_like(a), where=length > 0)
        elif name == "colors":
            a = np.clip(a, 0.0, 1.0)
        out[name] = a
    return out


def report(work: Work, run: Run, metrics, settings: dict, target: int) -> dict:
    """``result.report``: what the clean-up did, the run's counters, why it stopped, the
    seams and the settings used (docs/getting-started.md lists the keys)."""
    prep, seams = work.prep, work.seams
    hm = prep.hm
    out = {
        "input_faces": work.input_faces,
        "degenerate_faces_removed": prep.n_degenerate_faces,
        "unreferenced_vertices_removed": prep.n_unreferenced_vertices,
        "nonmanifold_edges_cut": hm.n_nonmanifold_edges,
        "vertices_split": hm.n_split_vertices,
        "target_faces": target,
        "metrics": [m.name for m in metrics],
        "memory_order": prep.memory_order,
    }
    out.update(run.counters)
    out["stop_detail"] = run.detail
    out["pruned"] = work.prune_report
    out["seams"] = {"paired_vertices": 0 if seams is None else int(np.count_nonzero(seams >= 0)),
                    "fixed_vertices": work.n_seam_fixed,
                    "pair_collapses": run.seam_pair_collapses}
    out["settings"] = {k: {"value": v, "from": s} for k, (v, s) in settings.items()}
    return out
