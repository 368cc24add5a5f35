"""What a metric is: the five kinds, their options, and what they are handed.

A metric's Python code runs once, at set-up, and hands the core one of:

* quadrics  (:class:`QuadricMetric`): per-vertex quadrics, summed on collapse;
* fields    (:class:`FieldMetric`):   per-vertex or per-edge values with a merge rule;
* a kernel  (:class:`KernelMetric`):  a Cython ``cdef class`` run by the core without the GIL;
* a batch   (:class:`BatchMetric`):   a numpy function over all candidates, once per pass.

None of them is called from Python once per collapse.  See docs/writing-a-metric.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import OptionError
from ..geometry import face_vectors, vertex_sums
from ..settings import SETTING_DEFAULTS

__all__ = [
    "Option", "Metric", "QuadricMetric", "FieldMetric", "KernelMetric", "BatchMetric",
    "MetricContext", "Batch", "KINDS", "ATTRIBUTE_WIDTHS", "pack_quadrics", "unpack_quadrics",
    "packed_size",
]

KINDS = ("quadric", "field", "kernel", "batch", "removal")

_MISSING = object()


class Option:
    """One option of a metric: its default and what values it takes.

    kind    : float, int, bool, str or "array" (anything numpy turns into a float64 array)
    min/max : inclusive bounds for numbers
    choices : the allowed values of a str option
    """

    def __init__(self, default: Any, *, kind: Any = float, min: float | None = None,
                 max: float | None = None, choices: tuple | None = None, doc: str = "",
                 allow_none: bool = False):
        self.default = default
        # the type, or its name ("array" is an array of numbers)
        kinds = {"float": float, "int": int, "bool": bool, "str": str, "array": "array"}
        if isinstance(kind, str):
            if kind not in kinds:
                raise ValueError(f"Option kind must be one of {', '.join(kinds)}, got {kind!r}")
            kind = kinds[kind]
        elif choices is not None and kind is float and all(isinstance(c, str) for c in choices):
            kind = str                                  # choices of text: a text option
        self.kind = kind
        self.min = min
        self.max = max
        self.choices = tuple(choices) if choices is not None else None
        self.doc = doc
        self.allow_none = allow_none

    def describe(self) -> str:
        if self.choices:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        kind = self.kind if isinstance(self.kind, str) else self.kind.__name__
        if kind == "int":
            kind = "an integer"
        elif kind == "float":
            kind = "a number"
        elif kind == "bool":
            kind = "True or False"
        elif kind == "array":
            kind = "an array"
        else:
            kind = f"a {kind}"
        bounds = []
        if self.min is not None:
            bounds.append(f">= {self.min}")
        if self.max is not None:
            bounds.append(f"<= {self.max}")
        return kind + (" " + " and ".join(bounds) if bounds else "")

    def validate(self, metric: str, name: str, value: Any) -> Any:
        def bad():
            return OptionError(f"metric {metric!r}: option {name!r} must be {self.describe()}, got {value!r}")

        if value is None:
            if self.allow_none:
                return None
            raise bad()
        if self.kind == "array":
            try:
                arr = np.asarray(value, dtype=np.float64)
            except (TypeError, ValueError):
                raise bad() from None
            if not np.all(np.isfinite(arr)):
                raise OptionError(f"metric {metric!r}: option {name!r} holds NaN or infinite values")
            return arr
        if self.kind is bool:
            if not isinstance(value, (bool, np.bool_)):
                raise bad()
            return bool(value)
        if self.kind is str:
            if not isinstance(value, str) or (self.choices and value not in self.choices):
                raise bad()
            return value
        if self.kind is int:
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
                raise bad()
            value = int(value)
        elif self.kind is float:
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
                raise bad()
            value = float(value)
            if not math.isfinite(value):
                raise bad()
        if self.min is not None and value < self.min:
            raise bad()
        if self.max is not None and value > self.max:
            raise bad()
        if self.choices and value not in self.choices:
            raise bad()
        return value


class Metric:
    """Base of every metric.  Subclass one of the five kinds, not this.

    Class attributes a metric sets:
        options     : {name: Option}; every metric also has ``weight`` (default 1.0)
        description : one line for ``lodkit metrics``
        defaults    : {setting: value}, the simplify() settings this metric prefers
                      (placement, boundary, boundary_weight, max_normal_angle, min_quality);
                      the caller's explicit values win

    An instance holds validated options in ``self.params``; the registry sets ``name``.
    """

    kind: ClassVar[str] = ""
    description: ClassVar[str] = ""
    options: ClassVar[dict] = {}
    defaults: ClassVar[dict] = {}
    name: str = ""

    _base_options: ClassVar[dict] = {
        "weight": Option(1.0, min=0.0, doc="how much this metric counts when metrics are combined"),
    }

    def __init__(self, **options):
        if not self.name:
            self.name = type(self).__name__
        self.params = self.validate_options(options)

    def check_ready(self) -> None:
        """Raise OptionError if the options cannot run on any mesh (a required option left
        out); called by simplify() and compare() before any work.  The default: nothing."""

    @classmethod
    def all_options(cls) -> dict:
        merged: dict = {}
        for klass in reversed(cls.__mro__):
            merged.update(getattr(klass, "_base_options", {}) if "_base_options" in vars(klass) else {})
            merged.update(vars(klass).get("options", {}))
        return merged

    def validate_options(self, given: dict) -> dict:
        spec = self.all_options()
        unknown = sorted(set(given) - set(spec))
        if unknown:
            raise OptionError(f"metric {self.name!r} has no option {unknown[0]!r}; its options: "
                              + ", ".join(sorted(spec)))
        params = {}
        for key, opt in spec.items():
            value = given.get(key, _MISSING)
            if value is _MISSING:
                params[key] = opt.default
            else:
                params[key] = opt.validate(self.name, key, value)
        return params

    @property
    def weight(self) -> float:
        return float(self.params["weight"])

    def prepare(self, ctx: MetricContext) -> None:
        """Called once before the run (all kinds); the default does nothing."""

    def __repr__(self) -> str:
        opts = ", ".join(f"{k}={v!r}" for k, v in self.params.items()
                         if not isinstance(v, np.ndarray) and v != self.all_options()[k].default)
        return f"<metric {self.name} ({self.kind}){' ' + opts if opts else ''}>"


#: per-vertex attributes a quadric may range over, and their widths
ATTRIBUTE_WIDTHS = {"colors": 3, "uvs": 2, "normals": 3}


def packed_size(dim: int) -> int:
    """Entries of a packed quadric of dimension ``dim``: dim(dim+1)/2 + dim + 1."""
    return dim * (dim + 1) // 2 + dim + 1


def pack_quadrics(A: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(n, D, D), (n, D), (n,) -> (n, S) packed rows: the upper triangle of A row by row,
    then b, then c (for D = 3: a11 a12 a13 a22 a23 a33 b1 b2 b3 c)."""
    A = np.asarray(A, dtype=np.float64)
    D = A.shape[-1]
    iu = np.triu_indices(D)
    return np.concatenate([A[:, iu[0], iu[1]], np.asarray(b, dtype=np.float64),
                           np.asarray(c, dtype=np.float64).reshape(-1, 1)], axis=1)


def unpack_quadrics(packed: np.ndarray, dim: int):
    """Inverse of :func:`pack_quadrics`: (A (n, D, D), b (n, D), c (n,))."""
    packed = np.asarray(packed, dtype=np.float64)
    n = packed.shape[0]
    iu = np.triu_indices(dim)
    t = iu[0].size
    A = np.zeros((n, dim, dim))
    A[:, iu[0], iu[1]] = packed[:, :t]
    A[:, iu[1], iu[0]] = packed[:, :t]
    return A, packed[:, t:t + dim].copy(), packed[:, t + dim].copy()


class QuadricMetric(Metric):
    """Per-vertex quadrics Q_v(x) = x^T A x + 2 b^T x + c, added on collapse.

    ``quadrics(ctx)`` returns one packed row per vertex slot, in normalised coordinates.
    With no ``attributes`` x is the position and a row is a11 a12 a13 a22 a23 a33 b1 b2 b3 c
    (n, 10).  With ``attributes = ("colors",)`` (any of "colors" 3, "uvs" 2, "normals" 3)
    x = [x, y, z, r, g, b] and a row is the packed D = 6 quadric (:func:`pack_quadrics`):
    the core minimises the folded quadric over position and attributes together, so the
    kept vertex gets the attribute values of the optimum.

    Several quadric metrics fold into one quadric: sum of weight * Q (over the union of
    their attributes).  The folded quadric places the new vertex.
    """

    kind = "quadric"
    attributes: ClassVar[tuple] = ()

    @classmethod
    def dimension(cls) -> int:
        return 3 + sum(ATTRIBUTE_WIDTHS[a] for a in cls.attributes)

    def quadrics(self, ctx: MetricContext) -> np.ndarray:
        raise NotImplementedError


_MERGES = ("max", "min", "sum", "keep", "mean")
_VALUES = ("max", "min", "sum", "kept", "removed", "mean")
_MODES = ("scale", "add")


class FieldMetric(Metric):
    """Precomputed per-vertex (``per = "vertex"``) or per-edge (``per = "edge"``) values.

    ``values(ctx)`` returns (n,) or (n, k) for vertex slots, (n_edges,) or (n_edges, k) for
    the rows of ``ctx.edges``.  On a collapse the kept vertex (the surviving edge) takes
    ``merge`` of the two values.  A vertex field gives edge (u, v) the value ``value``
    (max, min, sum, mean, the kept end's or the removed end's).  The value enters the cost
    as ``mode``: "scale" -> cost * (offset + weight * value); "add" -> cost + weight * value.
    """

    kind = "field"
    per: ClassVar[str] = "vertex"
    options = {
        "merge": Option("max", kind=str, choices=_MERGES, doc="rule for the kept vertex / surviving edge"),
        "value": Option("max", kind=str, choices=_VALUES, doc="value of an edge from its two ends"),
        "mode": Option("scale", kind=str, choices=_MODES,
                       doc="scale: cost * (offset + weight * value); add: cost + weight * value"),
        "offset": Option(1.0, doc="the offset of the scale mode"),
    }

    def values(self, ctx: MetricContext) -> np.ndarray:
        raise NotImplementedError

    def rules(self, k: int) -> np.ndarray:
        """The core's (k, 5) rule rows: merge, value, mode, weight, offset."""
        p = self.params
        row = [_MERGES.index(p["merge"]), _VALUES.index(p["value"]), _MODES.index(p["mode"]),
               self.weight, p["offset"]]
        return np.tile(np.asarray(row, dtype=np.float64), (k, 1))


class KernelMetric(Metric):
    """A native kernel: ``kernel`` is a ``cdef class`` subclassing
    ``lodkit.kernel.Kernel``; one instance is made per run and prepared with
    ``prepare(ctx, options)``."""

    kind = "kernel"
    kernel: ClassVar[Any] = None

    def make_kernel(self, ctx: MetricContext):
        k = self.kernel()
        k.prepare(ctx, dict(self.params))
        return k


class RemovalMetric(Metric):
    """A vertex-removal metric: ``kernel`` is a ``cdef class`` subclassing
    ``lodkit.removal.RemovalKernel`` that costs removing a vertex and re-triangulates
    its hole (removal.pxd).  It runs on the vertex-removal driver, alone: it cannot be
    combined with edge-collapse metrics."""

    kind = "removal"
    kernel: ClassVar[Any] = None

    def make_kernel(self, ctx: MetricContext):
        k = self.kernel()
        k.prepare(ctx, dict(self.params))
        return k


class BatchMetric(Metric):
    """A vectorised cost over many candidates: ``costs(batch)`` returns (k,) costs, or
    ``(costs, positions)`` with (k, 3) positions for the kept vertex.

    The pass driver ranks every candidate, calls ``costs`` once, and collapses the cheapest
    ``fraction`` of them that share no vertex neighbourhood, then ranks again.
    """

    kind = "batch"
    options = {
        "fraction": Option(0.25, min=1e-6, max=1.0,
                           doc="share of the ranked candidates tried in each pass"),
    }

    def costs(self, batch: Batch):
        raise NotImplementedError


class MetricContext:
    """What a metric sees at set-up.  Positions are normalised (bbox centred on the origin,
    unit diagonal): multiply by ``scale`` and add ``center`` for input units.

    positions    : (n, 3) float64, one row per vertex slot (read-only)
    faces        : (m, 3) int32 vertex slots of each face
    edges        : (n_edges, 2) int32 vertex slots of each edge (rows of per-edge fields)
    input_vertex : (n,) int32, the input vertex each slot stands for
    input_face   : (m,) int32, the input face of each face slot
    boundary     : (n,) bool, on a boundary loop
    fixed        : (n,) bool, may not move nor go (locked, non-manifold copies, 'lock' boundary)
    mesh         : the input lodkit.Mesh (normals, colors, uvs as given)
    face_quadrics: (n, 10) plain area-weighted plane quadrics (do not modify)
    halfedge     : the lodkit._core.halfedge.HalfEdgeMesh (for Cython kernels)
    settings     : the run's options: placement, boundary, boundary_weight, ...
    """

    def __init__(self, *, positions, halfedge, input_vertex, input_face, fixed, scale, center,
                 mesh, face_quadrics, settings=None):
        self.positions = positions
        self.halfedge = halfedge
        self.input_vertex = input_vertex
        self.input_face = input_face
        self.fixed = fixed
        self.scale = float(scale)
        self.center = center
        self.mesh = mesh
        self.face_quadrics = face_quadrics
        self.settings = dict(settings or {})
        self._edges = None
        self._boundary = None

    @property
    def n_vertices(self) -> int:
        return int(self.positions.shape[0])

    @property
    def faces(self) -> np.ndarray:
        return self.halfedge.corners

    def face_vectors(self) -> np.ndarray:
        """(m, 3) (b - a) x (c - a) of each face slot at the current positions (twice the
        area times the unit normal)."""
        return face_vectors(self.positions, self.faces)

    def vertex_sums(self, values) -> np.ndarray:
        """Per vertex slot, the sum over its faces of a per-face value ((m,) or (m, k))."""
        return vertex_sums(self.faces, values, self.n_vertices)

    @property
    def edges(self) -> np.ndarray:
        if self._edges is None:
            he = self.halfedge.edge_halfedges
            corners = self.halfedge.corners.reshape(-1)
            nxt = np.where(he % 3 == 2, he - 2, he + 1)
            self._edges = np.stack([corners[he], corners[nxt]], axis=1).astype(np.int32)
            self._edges.flags.writeable = False
        return self._edges

    @property
    def n_edges(self) -> int:
        return int(self.halfedge.n_edges)

    @property
    def boundary(self) -> np.ndarray:
        if self._boundary is None:
            self._boundary = self.halfedge.boundary_vertices
        return self._boundary

    def vertex_attribute(self, name: str) -> np.ndarray | None:
        """The input's per-vertex ``normals``, ``colors`` or ``uvs``, one row per slot (None if absent)."""
        arr = getattr(self.mesh, name, None)
        if arr is None:
            return None
        return np.asarray(arr)[self.input_vertex]


@dataclass
class Batch:
    """The candidates of one pass of the batch driver (k of them).

    edge, u, v, removed, kept : (k,) int32 edge id and vertex slots
    position  : (k, 3) where the kept vertex goes (the core's placement)
    cost      : (k,) the cost from the other metrics so far (0 without them)
    error     : (k,) geometric error of each collapse
    positions : (n, 3) current positions of all vertex slots (read-only)
    ctx       : the MetricContext of the run
    """

    edge: np.ndarray
    u: np.ndarray
    v: np.ndarray
    removed: np.ndarray
    kept: np.ndarray
    position: np.ndarray
    cost: np.ndarray
    error: np.ndarray
    positions: np.ndarray
    ctx: MetricContext

    def __len__(self) -> int:
        return int(self.edge.shape[0])

    @property
    def length(self) -> np.ndarray:
        """(k,) current edge lengths (normalised units)."""
        d = self.positions[self.u] - self.positions[self.v]
        return np.sqrt(np.einsum("ij,ij->i", d, d))


def check_metric_class(obj: Any) -> str | None:
    """Why ``obj`` is not a usable metric class (None if it is)."""
    if not isinstance(obj, type) or not issubclass(obj, Metric):
        return f"gives {obj!r}, not a subclass of lodkit.metrics.Metric"
    if obj.kind not in KINDS:
        return (f"has kind {obj.kind!r}; subclass QuadricMetric, FieldMetric, KernelMetric, BatchMetric "
                "or RemovalMetric")
    for key, opt in obj.all_options().items():
        if not isinstance(opt, Option):
            return f"option {key!r} is {opt!r}, not a lodkit.metrics.Option"
    defaults = getattr(obj, "defaults", {})
    if not isinstance(defaults, dict) or any(k not in SETTING_DEFAULTS for k in defaults):
        return (f"has defaults={defaults!r}; a metric may prefer values of "
                + ", ".join(SETTING_DEFAULTS))
    if obj.kind == "quadric":
        attrs = getattr(obj, "attributes", ())
        if (not isinstance(attrs, tuple) or any(a not in ATTRIBUTE_WIDTHS for a in attrs)
                or len(set(attrs)) != len(attrs)):
            return (f"has attributes={attrs!r}; a quadric ranges over a tuple of distinct names among "
                    + ", ".join(ATTRIBUTE_WIDTHS))
        if obj.dimension() > 16:
            return f"has dimension {obj.dimension()}; quadrics go up to 16 dimensions"
    if obj.kind == "field" and obj.per not in ("vertex", "edge"):
        return f"has per={obj.per!r}; a field is per 'vertex' or per 'edge'"
    if obj.kind in ("kernel", "removal"):
        if obj.kind == "kernel":
            from ..kernel import API_VERSION
            from ..kernel import Kernel as Base
            constant = "KERNEL_API_VERSION"
        else:
            from ..removal import API_VERSION
            from ..removal import RemovalKernel as Base
            constant = "REMOVAL_API_VERSION"
        where = f"{Base.__module__}.{Base.__name__}"
        api = "kernel API" if obj.kind == "kernel" else "removal kernel API"
        if not isinstance(obj.kernel, type) or not issubclass(obj.kernel, Base) or obj.kernel is Base:
            return f"has kernel={obj.kernel!r}, not a subclass of {where}"
        # read from the class itself: a value inherited from lodkit's base says nothing
        version = vars(obj.kernel).get("api_version")
        if version is None:
            return (f"kernel {obj.kernel.__name__} does not state the {api} it was built for: "
                    f"set api_version = {constant} in its class body")
        if version != API_VERSION:
            return (f"kernel {obj.kernel.__name__} was built for {api} version {version}, "
                    f"this lodkit has version {API_VERSION}: rebuild the plugin against it")
    return None
