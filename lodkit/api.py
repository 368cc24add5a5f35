"""``simplify()``: validation and dtype handling around the Cython collapse driver."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

from .errors import MeshError, MetricError, OptionError
from .mesh import Mesh

__all__ = ["SimplifyResult", "simplify", "prepare"]

PLACEMENTS = {"optimal": 0, "endpoint": 1}
OPERATORS = {"edge": 0, "triangle": 1}      # simplify(operator=): the collapse driver's candidates
BOUNDARY_POLICIES = {"lock": 0, "preserve": 1, "free": 2}

#: Stop reasons, as found in :attr:`SimplifyResult.stop_reason`.
STOP_TARGET = "target_faces"          # the face target (target_faces / target_ratio) was reached
STOP_MAX_ERROR = "max_error"          # every remaining collapse would exceed max_error
STOP_NO_COLLAPSE = "no_valid_collapse"  # no collapse passes the checks (topology, flips, locks)

# Run the nogil loop in chunks of this fraction of the work, to draw the progress bar.
_PROGRESS_CHUNKS = 50


@dataclass
class SimplifyResult:
    """What :func:`simplify` returns.

    mesh        : the simplified mesh (a lodkit.Mesh, or an open3d TriangleMesh if one was given)
    vertex_map  : (n_out,) int64, for each output vertex the input vertex it comes from
    face_map    : (m_out,) int64, for each output face the input face it comes from
    error       : largest collapse error, as a fraction of the bbox diagonal (or in model
                  units when ``absolute=True``): sqrt(quadric error / summed face area), the
                  area-weighted RMS distance of the new vertex to the planes it stands for
    stop_reason : "target_faces", "max_error" or "no_valid_collapse"
    n_collapses : number of edge collapses done (vertex removals for a "removal" metric)
    """

    mesh: Any
    vertex_map: np.ndarray
    face_map: np.ndarray
    error: float
    stop_reason: str
    n_collapses: int
    elapsed: float = 0.0
    report: dict = field(default_factory=dict)
    collapses: Optional[dict] = None

    def __repr__(self) -> str:
        return (f"SimplifyResult({self.mesh!r}, error={self.error:.3g}, "
                f"stop_reason={self.stop_reason!r}, n_collapses={self.n_collapses})")


@dataclass
class Prepared:
    """A mesh cleaned and turned into half-edge arrays, ready for a driver."""

    hm: Any                      # lodkit._core.halfedge.HalfEdgeMesh
    positions: Optional[np.ndarray]  # (n_slots, 3) normalised positions (dropped once copied)
    input_vertex: np.ndarray     # (n_slots,) input vertex index of each slot
    input_face: np.ndarray       # (m_kept,) input face index of each face slot
    center: np.ndarray
    scale: float                 # bbox diagonal of the input
    n_degenerate_faces: int
    n_unreferenced_vertices: int


def _as_mesh(mesh) -> tuple[Mesh, bool]:
    if isinstance(mesh, Mesh):
        return mesh, False
    if type(mesh).__name__ == "TriangleMesh" and hasattr(mesh, "triangles"):
        return Mesh.from_open3d(mesh), True
    if isinstance(mesh, tuple) and len(mesh) == 2:
        return Mesh(*mesh), False
    raise MeshError(f"expected a lodkit.Mesh, an open3d TriangleMesh or (vertices, faces), got {type(mesh).__name__}")


def prepare(mesh: Mesh) -> Prepared:
    """Drop faces with a repeated index and unreferenced vertices, normalise positions
    (centre of the bbox at the origin, unit diagonal) and build the half-edge arrays."""
    from ._core.halfedge import build

    faces = mesh.faces
    if faces.shape[0] == 0:
        raise MeshError("the mesh has no faces")
    degenerate = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    n_degenerate = int(np.count_nonzero(degenerate))
    if n_degenerate == faces.shape[0]:
        raise MeshError(f"all {faces.shape[0]} faces repeat a vertex index (zero area); nothing to simplify")
    if n_degenerate:
        input_face = np.flatnonzero(~degenerate).astype(np.int32)
        faces = faces[input_face]
    else:
        input_face = np.arange(faces.shape[0], dtype=np.int32)
    del degenerate
    used = np.zeros(mesh.n_vertices, dtype=bool)
    used[faces.reshape(-1)] = True
    input_vertex = np.flatnonzero(used).astype(np.int32)
    del used
    if input_vertex.size == mesh.n_vertices:
        compact = faces                                 # every vertex is used: no renumbering
    else:
        remap = np.full(mesh.n_vertices, -1, dtype=np.int32)
        remap[input_vertex] = np.arange(input_vertex.size, dtype=np.int32)
        compact = remap[faces]
        del remap
    pts = mesh.vertices[input_vertex]
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    del pts
    with np.errstate(over="ignore", invalid="ignore"):
        center = 0.5 * lo + 0.5 * hi
        scale = float(np.linalg.norm(hi - lo))
    if not scale > 0.0:
        raise MeshError("all vertices used by faces coincide: the bounding box has zero size")
    if not np.isfinite(scale):
        raise MeshError(f"the bounding box is too large to measure (coordinates up to "
                        f"{np.abs(mesh.vertices[input_vertex]).max():.3g}); rescale the mesh")
    hm = build(compact, int(input_vertex.size))
    del compact, faces
    slot_input = input_vertex[hm.vertex_sources] if hm.n_split_vertices else input_vertex
    positions = mesh.vertices[slot_input]
    positions -= center
    positions /= scale
    return Prepared(hm, positions, slot_input, input_face, center, scale,
                    n_degenerate, int(mesh.n_vertices - input_vertex.size))


def _resolve_target(n_faces: int, target_faces, target_ratio, max_error) -> int:
    if target_faces is None and target_ratio is None and max_error is None:
        raise OptionError("give a stop criterion: target_faces=, target_ratio= or max_error=")
    target = 0
    if target_faces is not None:
        if isinstance(target_faces, bool) or not isinstance(target_faces, (int, np.integer)) or target_faces < 0:
            raise OptionError(f"target_faces must be a non-negative integer, got {target_faces!r}")
        target = max(target, int(target_faces))
    if target_ratio is not None:
        r = float(target_ratio)
        if not (0.0 <= r <= 1.0):
            raise OptionError(f"target_ratio must be in [0, 1], got {target_ratio!r}")
        target = max(target, int(round(r * n_faces)))
    return target


def simplify(
    mesh,
    *,
    target_faces: Optional[int] = None,
    target_ratio: Optional[float] = None,
    max_error: Optional[float] = None,
    absolute: bool = False,
    metric="qem",
    placement: Optional[str] = None,
    boundary: Optional[str] = None,
    boundary_weight: Optional[float] = None,
    locked=None,
    max_normal_angle: Optional[float] = None,
    min_quality: Optional[float] = None,
    progress: bool = False,
    record: bool = False,
    pair_threshold: Optional[float] = None,
    operator: str = "edge",
) -> SimplifyResult:
    """Simplify a triangle mesh by greedy edge collapse with quadric error metrics.

    Stops at whichever comes first: ``target_faces`` faces, ``target_ratio`` times the input
    face count, or a collapse error above ``max_error`` (a fraction of the bbox diagonal
    unless ``absolute=True``).  With no legal collapse left it stops and says so in
    ``stop_reason``.

    metric           : the cost: a registered name ("qem", see ``lodkit.metrics.available()``),
                       ``(name, {options})``, a Metric instance, or a list of those to combine
                       (quadrics add up, then fields and kernels apply in the order given,
                       then batch metrics; docs/writing-a-metric.md says exactly how)
    placement        : "optimal" (default; minimise the quadric; falls back to the edge when the 3x3
                       system is ill-conditioned) or "endpoint" (half-edge collapse: output
                       vertices are a subset of the input)
    boundary         : "preserve" (default; boundary planes weighted by ``boundary_weight``; a boundary
                       vertex never moves into the interior), "lock" (boundary vertices never
                       move nor go) or "free" (no special treatment)
    locked           : (n,) bool mask or index array of vertices that must stay as they are
    boundary_weight  : weight of the boundary planes under "preserve" (default 10)
    max_normal_angle : reject a collapse that turns any face normal by more than this
                       (degrees, default 90)
    min_quality      : reject a collapse that makes a face with quality
                       Q = 4*sqrt(3)*A/(l0^2+l1^2+l2^2) below this (and below its old Q); 0 = off
                       (default 0.1)

    The five settings above that are left as None take the value the metric prefers (a
    metric's ``defaults``, e.g. ``curvature`` checks normals within 60 degrees and quality
    0.5, as its paper does; the first metric listed wins), else the default given here.
    ``result.report["settings"]`` says what was used and where it came from.
    progress         : draw a progress bar on stderr
    record           : keep the collapse sequence in ``result.collapses``
    pair_threshold   : pair contraction (off when None): before the collapses, vertices closer
                       than this (a fraction of the bbox diagonal unless ``absolute=True``)
                       that share no edge merge in quadric-cost order, so separate parts join
                       and gaps close (topology changes; docs/clustering.md, "Pair
                       contraction"); ``report["pair_contraction"]`` counts the merges
    operator         : "edge" (default: edge collapse) or "triangle" (triangle collapse: the
                       cheapest face goes to one point, the face and its three neighbours
                       die; done and recorded as two edge collapses, ``n_collapses`` counts
                       those; quadric metrics only -- docs/algorithms.md, "Triangle collapse")

    An open3d.geometry.TriangleMesh in gives one out.  Per-vertex normals, colours and uvs
    are carried along (interpolated on the collapsed edge at the new position).  Attribute
    seams (coincident vertex copies, as OBJ / glTF uv seams load) stay closed under the
    "preserve" and "free" boundary policies: seam vertices do not move, and a collapse along
    a seam is done on both sides together (docs/metrics.md, "Attribute seams").
    """
    from ._core.decimate import EdgeCollapser, vertex_quadrics
    from .metrics import create as create_metrics

    t0 = time.perf_counter()
    src, was_o3d = _as_mesh(mesh)
    metrics = create_metrics(metric)
    if not isinstance(operator, str) or operator not in OPERATORS:
        raise OptionError(f"operator must be one of {', '.join(OPERATORS)}, got {operator!r}")
    if operator == "triangle":
        other = [m for m in metrics if m.kind != "quadric"]
        if other:
            raise OptionError(f"operator='triangle' takes quadric metrics only; {other[0].name!r} is a "
                              f"{other[0].kind} metric, whose values are defined per edge or vertex "
                              f"pair (use operator='edge')")
    settings = resolve_settings(metrics, placement=placement, boundary=boundary,
                                boundary_weight=boundary_weight,
                                max_normal_angle=max_normal_angle, min_quality=min_quality)
    placement, boundary = settings["placement"][0], settings["boundary"][0]
    boundary_weight = settings["boundary_weight"][0]
    max_normal_angle, min_quality = settings["max_normal_angle"][0], settings["min_quality"][0]
    if placement not in PLACEMENTS:
        raise OptionError(f"placement must be one of {', '.join(PLACEMENTS)}, got {placement!r}")
    if boundary not in BOUNDARY_POLICIES:
        raise OptionError(f"boundary must be one of {', '.join(BOUNDARY_POLICIES)}, got {boundary!r}")
    if not (0.0 < float(max_normal_angle) <= 180.0):
        raise OptionError(f"max_normal_angle must be in (0, 180] degrees, got {max_normal_angle!r}")
    if not (0.0 <= float(min_quality) <= 1.0):
        raise OptionError(f"min_quality must be in [0, 1], got {min_quality!r}")
    if not (float(boundary_weight) >= 0.0 and math.isfinite(float(boundary_weight))):
        raise OptionError(f"boundary_weight must be a finite number >= 0, got {boundary_weight!r}")
    if max_error is not None and not (float(max_error) >= 0.0):
        raise OptionError(f"max_error must be >= 0, got {max_error!r}")
    target = _resolve_target(src.n_faces, target_faces, target_ratio, max_error)
    if any(m.kind == "removal" for m in metrics):
        # vertex removal (a "removal" metric runs alone, on its own driver: lodkit/_vremove.py)
        if pair_threshold is not None:
            raise OptionError("pair_threshold works with edge collapse; a vertex-removal metric takes none")
        from ._vremove import simplify_removal
        return simplify_removal(src, was_o3d, metrics, settings, target=target, max_error=max_error,
                                absolute=absolute, locked=locked, progress=progress, record=record, t0=t0)

    input_faces, pair_report = src.n_faces, None
    if pair_threshold is not None:
        from .pairs import contract_pairs
        src, welded_faces, pair_report = contract_pairs(
            src, pair_threshold, absolute=absolute,
            locked=None if locked is None else _locked_mask(locked, src.n_vertices))
    prep = prepare(src)
    hm = prep.hm
    fixed = hm.locked_vertices.copy()
    if locked is not None:
        fixed |= _locked_mask(locked, src.n_vertices)[prep.input_vertex]
    attrs = src.attributes()
    names, blocks = [], []
    for name, arr in attrs.items():
        names.append((name, arr.shape[1]))
        blocks.append(arr[prep.input_vertex])
    attr_in = np.concatenate(blocks, axis=1) if blocks else None

    # one row per vertex: quadric (11) then position (3); the collapser works on it in place.
    # The plain face quadrics are always there: they place the vertex and measure the error
    # when no quadric metric is given.
    vdata = np.empty((hm.n_vertices, 14), dtype=np.float64)
    vdata[:, 11:] = prep.positions
    prep.positions = None
    vertex_quadrics(hm, vdata[:, 11:], 0.0, out=vdata)
    if boundary == "lock":
        fixed |= hm.boundary_vertices
        seams = None                 # every seam vertex is a boundary vertex: all stay
    else:
        seams = _seam_partners(src, prep, fixed)
        if seams is not None:
            fixed |= seams == -2
    ctx = _metric_context(src, prep, vdata, fixed, placement=placement, boundary=boundary,
                          boundary_weight=float(boundary_weight))
    layout, col = {}, 0
    for name, width in names:
        layout[name] = col
        col += width
    setup = _metric_setup(metrics, ctx, vdata, layout)
    err_limit = math.inf
    if max_error is not None:
        err_limit = float(max_error) / (prep.scale if absolute else 1.0)
    collapser = EdgeCollapser(
        hm, None, vdata, attr_in, fixed,
        placement=PLACEMENTS[placement], boundary=BOUNDARY_POLICIES[boundary],
        max_normal_angle=float(max_normal_angle), min_quality=float(min_quality),
        max_error=err_limit, record=bool(record),
        closed_connected=_closed_connected(hm),
        use_heap=not setup.batch, seam_partners=seams, operator=OPERATORS[operator], **setup.core,
    )
    _raise_if_failed(collapser, setup)

    bar = _progress_bar(progress, hm, target)
    start_faces = hm.n_alive_faces
    n_passes = 0
    if setup.batch:
        status, rejected_error, n_passes = _run_passes(collapser, setup, ctx, target, bar, start_faces)
    else:
        status = _run_chunked(collapser, hm, target, bar)
        rejected_error = collapser.n_rejected_error
    if bar:
        bar.close()
    _raise_if_failed(collapser, setup)

    if status == 0:
        stop, detail = STOP_TARGET, ""
    elif rejected_error > 0:
        stop, detail = STOP_MAX_ERROR, f"{rejected_error} candidate collapses exceed max_error"
    else:
        stop, detail = STOP_NO_COLLAPSE, _no_collapse_detail(collapser, hm)

    collapser.release()          # the heap and quadrics are not needed to build the output
    out_mesh, vertex_map, face_map = _extract(src, prep, collapser, names)
    if pair_report is not None:
        face_map = welded_faces[face_map]        # faces of the welded mesh -> input faces
    scale = prep.scale if absolute else 1.0
    records = None
    if record:
        records = collapser.records()
        records["removed"] = prep.input_vertex[records["removed"]].astype(np.int64)
        records["kept"] = prep.input_vertex[records["kept"]].astype(np.int64)
        moved = records.pop("moved")
        # positions that are an input vertex's are given bit for bit, the others denormalised
        records["position"] = np.where(moved[:, None], records["position"] * prep.scale + prep.center,
                                       src.vertices[records["kept"]])
        records["error"] = records["error"] * scale
    result = SimplifyResult(
        mesh=out_mesh.to_open3d() if was_o3d else out_mesh,
        vertex_map=vertex_map,
        face_map=face_map,
        error=float(collapser.max_error_done * scale),
        stop_reason=stop,
        n_collapses=int(collapser.n_collapses),
        elapsed=time.perf_counter() - t0,
        report={
            "input_faces": input_faces,
            "pair_contraction": pair_report,
            "degenerate_faces_removed": prep.n_degenerate_faces,
            "unreferenced_vertices_removed": prep.n_unreferenced_vertices,
            "nonmanifold_edges_cut": hm.n_nonmanifold_edges,
            "vertices_split": hm.n_split_vertices,
            "target_faces": target,
            "metrics": [m.name for m in metrics],
            "vetoed": int(collapser.n_vetoed),
            "passes": n_passes,
            "operator": operator + "_collapse",
            "triangle_collapses": int(collapser.n_tri_collapses),
            "refused_at_second_collapse": int(collapser.n_tri_refused_second),
            "stop_detail": detail,
            "seams": {"paired_vertices": 0 if seams is None else int(np.count_nonzero(seams >= 0)),
                      "fixed_vertices": 0 if seams is None else int(np.count_nonzero(seams == -2)),
                      "pair_collapses": int(collapser.n_seam_pairs)},
            "settings": {k: {"value": v, "from": src_} for k, (v, src_) in settings.items()},
        },
        collapses=records,
    )
    return result


#: simplify()'s own defaults for the settings a metric may prefer other values of
SETTING_DEFAULTS = {
    "placement": "optimal",
    "boundary": "preserve",
    "boundary_weight": 10.0,
    "max_normal_angle": 90.0,
    "min_quality": 0.1,
}


def _progress_bar(progress: bool, hm, target: int):
    """A progress bar over the faces to remove (None when ``progress`` is off)."""
    if not progress:
        return None
    from ._progress import Progress
    return Progress(total=max(hm.n_alive_faces - target, 1), enabled=True)


def _run_chunked(driver, hm, target: int, bar) -> int:
    """``driver.run(target, chunk)`` until it stops for another reason than the chunk
    (status 1), updating ``bar`` between chunks (one chunk when there is no bar); returns
    the driver's final status."""
    start_faces = hm.n_alive_faces
    chunk = max((start_faces - target) // (2 * _PROGRESS_CHUNKS), 1000) if bar else 2**31 - 1
    while True:
        status = driver.run(target, chunk)
        if bar:
            bar.update(start_faces - hm.n_alive_faces)
        if status != 1:
            return status


def resolve_settings(metrics, **given) -> dict:
    """{setting: (value, where it came from)}: the caller's value when given (not None),
    else the first listed metric's ``defaults``, else :data:`SETTING_DEFAULTS`."""
    out = {}
    for key, default in SETTING_DEFAULTS.items():
        value = given.get(key)
        if value is not None:
            out[key] = (value, "caller")
            continue
        for m in metrics:
            if key in m.defaults:
                out[key] = (m.defaults[key], f"metric {m.name}")
                break
        else:
            out[key] = (default, "lodkit")
    return out


@dataclass
class _MetricSetup:
    core: dict                    # EdgeCollapser keyword arguments
    kernels: list                 # (metric, kernel) pairs, in chain order
    batch: list                   # batch metrics, in order


def _metric_context(src, prep, vdata, fixed, **settings):
    from .metrics import MetricContext

    positions = vdata[:, 11:]
    positions_ro = positions.view()
    positions_ro.flags.writeable = False
    face_quadrics = vdata[:, :10].view()
    face_quadrics.flags.writeable = False
    return MetricContext(positions=positions_ro, halfedge=prep.hm, input_vertex=prep.input_vertex,
                         input_face=prep.input_face, fixed=fixed.copy(), scale=prep.scale,
                         center=prep.center, mesh=src, face_quadrics=face_quadrics, settings=settings)


def _metric_setup(metrics, ctx, vdata, attr_layout=None) -> _MetricSetup:
    """Turn the metrics into what the core runs: one folded quadric, field blocks with their
    rules, a chain of prepared kernels, and the batch metrics for the pass driver."""
    from ._core.decimate import add_boundary_planes
    from .metrics.base import packed_size

    attr_layout = attr_layout or {}
    n = ctx.n_vertices
    for m in metrics:
        m.prepare(ctx)
    # everything that reads ctx.face_quadrics runs before vdata is overwritten below
    quads = [m for m in metrics if m.kind == "quadric"]
    for m in quads:
        missing = [a for a in m.attributes if a not in attr_layout]
        if missing:
            raise MetricError(f"metric {m.name!r} needs per-vertex {missing[0]}, and the mesh has none")
    total_w = sum(m.weight for m in quads)
    blocks = []
    if quads and total_w > 0.0:
        blocks = [(m, _checked(m, m.quadrics(ctx), (n, packed_size(m.dimension())), "quadrics",
                               columns=packed_size(m.dimension()))) for m in quads]
    attr_names = []
    for m in quads:
        attr_names += [a for a in m.attributes if a not in attr_names]
    core = {}
    # fields and kernels apply in the order the metrics are listed: steps (kind, first, end)
    # over the columns of the vertex / edge field blocks and the kernel chain
    values = {"vertex": [], "edge": []}
    rules = {"vertex": [], "edge": []}
    width = {"vertex": 0, "edge": 0}
    kernels, steps = [], []
    for m in metrics:
        if m.kind == "field":
            rows = n if m.per == "vertex" else ctx.n_edges
            v = _checked(m, m.values(ctx), (rows,), f"{m.per} field values").reshape(rows, -1)
            values[m.per].append(v)
            rules[m.per].append(m.rules(v.shape[1]))
            step = (0 if m.per == "vertex" else 1, width[m.per], width[m.per] + v.shape[1])
            width[m.per] += v.shape[1]
        elif m.kind == "kernel":
            k = m.make_kernel(ctx)
            if not isinstance(k, m.kernel):
                raise MetricError(f"metric {m.name!r}: make_kernel returned {type(k).__name__}, not {m.kernel.__name__}")
            step = (2, len(kernels), len(kernels) + 1)
            kernels.append((m, k))
        else:
            continue
        if steps and steps[-1][0] == step[0] and steps[-1][2] == step[1]:
            steps[-1] = (step[0], steps[-1][1], step[2])          # one run of the same kind
        else:
            steps.append(step)
    for per in ("vertex", "edge"):
        if values[per]:
            core[f"{per}_fields"] = np.ascontiguousarray(np.concatenate(values[per], axis=1))
            core[f"{per}_rules"] = np.concatenate(rules[per], axis=0)
    core["kernels"] = [k for _, k in kernels]
    core["steps"] = steps
    bw = ctx.settings.get("boundary_weight", 0.0)
    if ctx.settings.get("boundary") != "preserve":
        bw = 0.0
    # weight of the boundary planes added to vdata's 3D quadrics below: they scale with the
    # quadric weights, so "preserve" means the same whatever the weights
    plane_weight = bw * total_w
    if blocks and attr_names:
        # quadrics over attributes: fold them in D = 3 + k dimensions (boundary planes
        # included); the 3D rows of vdata keep the plain quadric and measure the geometric error
        core["attribute_quadrics"], core["attribute_columns"] = _fold_attribute_quadrics(
            blocks, attr_names, attr_layout, ctx, plane_weight)
        core["quadric_weight"], core["error_scale"] = 1.0, 1.0
        plane_weight = bw
    elif blocks:
        # the folded quadric: sum of weight * Q over the quadric metrics
        if len(blocks) == 1 and blocks[0][1] is ctx.face_quadrics:
            if total_w != 1.0:
                vdata[:, :10] *= total_w              # plain QEM, weighted: scale in place
        else:
            acc = np.zeros((n, 10))
            for m, q in blocks:
                acc += m.weight * q[:, :10]
            vdata[:, :10] = acc
        del blocks
        core["quadric_weight"], core["error_scale"] = 1.0, 1.0 / total_w
    else:
        # no quadric metric: plain QEM places the vertex and measures the error; it is also
        # the cost when nothing else supplies one (fields alone modulate plain QEM)
        only_fields = all(m.kind == "field" for m in metrics)
        core["quadric_weight"], core["error_scale"] = (1.0 if only_fields else 0.0), 1.0
        plane_weight = bw
    if plane_weight > 0.0:
        add_boundary_planes(ctx.halfedge, ctx.positions, plane_weight, vdata)
    return _MetricSetup(core, kernels, [m for m in metrics if m.kind == "batch"])


def _fold_attribute_quadrics(blocks, attr_names, attr_layout, ctx, boundary_weight):
    """Sum weight * Q over the quadric metrics in the space [x, y, z, attributes...] of the
    union of their attributes.  Returns the packed (n, S) fold and, for each dimension past
    3, its column in the collapser's attribute array."""
    from ._core.decimate import add_boundary_planes
    from .metrics.base import ATTRIBUTE_WIDTHS as widths, packed_size

    columns, dim_of = [], {}
    for name in attr_names:
        dim_of[name] = 3 + len(columns)
        start = attr_layout[name]
        columns += list(range(start, start + widths[name]))
    D = 3 + len(columns)
    tri = D * (D + 1) // 2

    def index(i, j):
        i, j = min(i, j), max(i, j)
        return i * D - i * (i - 1) // 2 + (j - i)

    n = ctx.n_vertices
    fold = np.zeros((n, packed_size(D)))

    def add(packed, dims, weight):
        d = len(dims)
        k = 0
        for i in range(d):
            for j in range(i, d):
                fold[:, index(dims[i], dims[j])] += weight * packed[:, k]
                k += 1
        for i in range(d):
            fold[:, tri + dims[i]] += weight * packed[:, k + i]
        fold[:, tri + D] += weight * packed[:, k + d]

    for m, packed in blocks:
        dims = [0, 1, 2]
        for name in m.attributes:
            dims += list(range(dim_of[name], dim_of[name] + widths[name]))
        add(packed, dims, m.weight)
    if boundary_weight > 0.0:
        planes = np.zeros((n, 10))
        add_boundary_planes(ctx.halfedge, ctx.positions, boundary_weight, planes)
        add(planes, [0, 1, 2], 1.0)
    return fold, np.asarray(columns, dtype=np.intc)


def _checked(metric, arr, shape, what, columns=None):
    """A metric's array as float64, with the shape it must have and no NaN."""
    try:
        out = np.asarray(arr, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise MetricError(f"metric {metric.name!r} returned {what} that are not numbers: {exc}") from None
    ok = out.ndim >= 1 and out.shape[0] == shape[0]
    if columns is not None:
        ok = ok and out.ndim == 2 and out.shape[1] == columns
    elif len(shape) == 1:
        ok = ok and out.ndim in (1, 2)
    if not ok:
        want = f"({shape[0]}, {columns})" if columns else f"({shape[0]},) or ({shape[0]}, k)"
        raise MetricError(f"metric {metric.name!r} returned {what} of shape {out.shape}; expected {want}")
    if np.isnan(out).any():
        raise MetricError(f"metric {metric.name!r} returned {what} with NaN values")
    return out


def _raise_if_failed(collapser, setup) -> None:
    if not collapser.failed:
        return
    for m, k in setup.kernels:
        if k.failed:
            raise MetricError(f"metric {m.name!r} failed during the run: {k.message}")
    raise MetricError(f"a metric kernel failed during the run: {collapser.error_message}")


def _no_collapse_detail(collapser, hm) -> str:
    if collapser.n_vetoed and collapser.n_collapses == 0:
        return (f"every candidate collapse was vetoed by a metric kernel "
                f"({collapser.n_vetoed} vetoes); the mesh is unchanged")
    if collapser.n_vetoed:
        return f"the remaining candidates failed the checks or were vetoed by a metric kernel ({collapser.n_vetoed} vetoes)"
    return "every remaining collapse would break the topology, flip or degrade a face, or move a locked vertex"


def _run_passes(collapser, setup, ctx, target, bar, start_faces):
    """The pass driver for batch metrics: rank every candidate (the core's cost, then each
    batch metric in order), collapse the cheapest ``fraction`` that share no vertex
    neighbourhood, repeat.  Returns (status, candidates over max_error, passes)."""
    from .metrics import Batch

    fraction = min(m.params["fraction"] for m in setup.batch)
    passes = 0
    while ctx.halfedge.n_alive_faces > target:
        plan = collapser.plan_all()
        if plan is None:
            _raise_if_failed(collapser, setup)
        rejected = collapser.n_rejected_error
        k = plan["edge"].shape[0]
        if k == 0:
            return 2, rejected, passes
        cost, pos = plan["cost"], None
        live = collapser.positions
        for m in setup.batch:
            batch = Batch(edge=plan["edge"], u=plan["u"], v=plan["v"], removed=plan["removed"],
                          kept=plan["kept"], position=plan["position"] if pos is None else pos,
                          cost=cost, error=plan["error"], positions=live, ctx=ctx)
            cost, new_pos = _batch_result(m, m.costs(batch), k)
            if new_pos is not None:
                pos = new_pos
        order = np.argsort(cost, kind="stable")
        n_try = max(int(math.ceil(fraction * k)), 1)
        done = 0
        for take in ((order[:n_try], order) if n_try < k else (order,)):
            done = collapser.collapse_pass(plan["edge"][take], None if pos is None else pos[take], target)
            if done != 0:
                break
        if done < 0:
            _raise_if_failed(collapser, setup)
        passes += 1
        if bar:
            bar.update(start_faces - ctx.halfedge.n_alive_faces)
        if done == 0:
            return 2, rejected, passes
    return 0, 0, passes


def _batch_result(metric, result, k):
    pos = None
    if isinstance(result, tuple):
        if len(result) != 2:
            raise MetricError(f"metric {metric.name!r}: costs() must return costs or (costs, positions)")
        result, pos = result
        pos = _checked(metric, pos, (k, 3), "positions", columns=3)
        if pos.shape != (k, 3) or not np.isfinite(pos).all():
            raise MetricError(f"metric {metric.name!r} returned positions that are not ({k}, 3) finite numbers")
    cost = _checked(metric, result, (k,), "costs")
    if cost.shape != (k,):
        raise MetricError(f"metric {metric.name!r} returned costs of shape {cost.shape}; expected ({k},)")
    return cost, pos


def _seam_partners(src: Mesh, prep: Prepared, fixed: np.ndarray) -> Optional[np.ndarray]:
    """Attribute seams of the input, for the collapser's ``seam_partners``: (n_slots,)
    int32 holding each seam vertex's partner slot, -1 off the seams and -2 for a seam
    copy that must stay; None when there are no seams.

    A seam is where a file splits a vertex to give it two sets of attributes (OBJ / glTF
    uv, normal or colour seams): two input vertices with bit-identical positions, each on
    a boundary chain of the split connectivity, the two chains running side by side in
    opposite directions.  A boundary half-edge a -> b is a seam edge when some boundary
    half-edge runs from a copy of b to a copy of a.  Two boundary copies of one position
    are partners when each one's outgoing seam edge pairs with the other's incoming one
    (as in meshoptimizer, positions alone decide: equal attributes on both sides make
    no difference).  Boundary vertices touching a seam that cannot be paired -- more than
    two copies, the end of a cut, a seam meeting a true boundary -- stay (-2).  Copies of
    one input vertex (non-manifold splits) are no seam; they are locked anyway."""
    hm = prep.hm
    n = hm.n_vertices
    corners = hm.corners.reshape(-1)
    he = np.flatnonzero((hm.twins < 0) & np.repeat(hm.alive_faces, 3))
    if he.size == 0:
        return None                                 # a seam is a pair of boundary chains
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
    partners = np.full(n, -1, dtype=np.intc)
    two = slots[shared[slots] & (n_boundary[cls[slots]] == 2)]
    two = two[np.argsort(cls[two], kind="stable")]
    s, t = two[0::2], two[1::2]

    def chains_pair(x, y):
        # x's outgoing seam edge x -> c runs beside y's incoming one c' -> y
        o, i = out_he[x], in_he[y]
        return mated[o] & mated[i] & (cls[b[o]] == cls[a[i]])

    ok = chains_pair(s, t) & chains_pair(t, s) & ~fixed[s] & ~fixed[t]
    partners[s[ok]] = t[ok]
    partners[t[ok]] = s[ok]
    near = shared.copy()
    near[a[mated]] = True
    near[b[mated]] = True
    partners[near & (partners < 0)] = -2
    # the copies made for non-manifold input are locked by the half-edge build; their cut
    # edges pair up like seams, but unless another input vertex shares the position they
    # are no attribute seam
    partners[hm.locked_vertices & ~shared] = -1
    if not (partners != -1).any():
        return None
    return partners


def _closed_connected(hm) -> bool:
    """True when the half-edge mesh has no boundary and one face-connected component."""
    from ._core.halfedge import count_face_components

    return not (hm.twins < 0).any() and count_face_components(hm) == 1


def _locked_mask(locked, n: int) -> np.ndarray:
    arr = np.asarray(locked)
    if arr.dtype == bool:
        if arr.shape != (n,):
            raise OptionError(f"locked as a mask must have shape ({n},), got {arr.shape}")
        return arr
    if arr.size == 0:
        return np.zeros(n, dtype=bool)
    if arr.dtype.kind not in "iu" or arr.ndim != 1:
        raise OptionError("locked must be a boolean mask or a 1-D array of vertex indices")
    if arr.min() < 0 or arr.max() >= n:
        raise OptionError(f"locked holds a vertex index outside 0..{n - 1}")
    mask = np.zeros(n, dtype=bool)
    mask[arr] = True
    return mask


def _extract(src: Mesh, prep: Prepared, collapser, names):
    """Compact the live part of the half-edge arrays into an output Mesh, welding the copies
    made for non-manifold vertices back together."""
    hm = prep.hm
    alive_faces = hm.alive_faces
    faces_slots = hm.corners[alive_faces]
    face_map = prep.input_face[np.flatnonzero(alive_faces)].astype(np.int64)
    alive_v = hm.alive_vertices
    slots = np.flatnonzero(alive_v)
    # weld: one output vertex per input vertex (split copies are locked, so they coincide)
    inputs = prep.input_vertex[slots]
    vertex_map, first, inverse = np.unique(inputs, return_index=True, return_inverse=True)
    slot_to_out = np.full(hm.n_vertices, -1, dtype=np.int32)
    slot_to_out[slots] = inverse.reshape(-1)
    out_faces = slot_to_out[faces_slots].astype(np.int32)
    rep = slots[first]
    moved = collapser.moved_vertices[rep]
    verts = src.vertices[vertex_map].copy()
    verts[moved] = collapser.positions[rep[moved]] * prep.scale + prep.center
    out_attrs = _attribute_arrays(collapser.attributes[rep], names) if names else {}
    out = Mesh(verts, out_faces, **out_attrs)
    return out, vertex_map.astype(np.int64), face_map


def _attribute_arrays(block: np.ndarray, names) -> dict:
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
