"""Appearance-preserving quadrics: position and per-vertex attributes in one quadric.

Garland & Heckbert 1998 ("Simplifying surfaces with color and texture using quadric error
metrics"), as in the lecture survey's "Appearance-Preserving Simplification": a vertex is
a point [x y z a1 .. ak] of R^D, a triangle spans a 2-plane in R^D, and the quadric of a
face is the squared D-dimensional distance to that plane.  Hoppe 1999 ("New quadric
metric for simplifying meshes with appearance attributes") is the alternative
``formulation="hoppe99"``: geometric distance to the face's plane plus, per attribute, the
squared difference to the face's linear attribute field at the point.

Units (the lecture: "scale xyz to unit cube for consistency"): positions are lodkit's
normalised ones (bounding-box diagonal 1), colours RGB in [0, 1], normals unit vectors, uvs
as given; each attribute is multiplied by its weight option before the quadric is built.
"""
from __future__ import annotations

import numpy as np

from ..errors import MetricError, OptionError
from ..geometry import face_vectors
from .base import ATTRIBUTE_WIDTHS, MetricContext, Option, QuadricMetric, pack_quadrics

__all__ = ["Appearance", "gh98_face_quadrics", "hoppe99_face_quadrics"]

_ORDER = ("colors", "uvs", "normals")
_WEIGHT_OPTION = {"colors": "color_weight", "uvs": "uv_weight", "normals": "normal_weight"}


class _AttributesOption(Option):
    """None (every attribute the mesh has), one name, "a,b" or a list/tuple of names."""

    def __init__(self):
        super().__init__(None, kind=str, allow_none=True,
                         doc="attributes the quadric ranges over: 'colors', 'uvs', 'normals', "
                             "several ('colors,uvs' or a list), or None for every one the mesh has")

    def describe(self) -> str:
        return ("None, or one or more of " + ", ".join(repr(a) for a in _ORDER)
                + " (a name, 'a,b' or a list)")

    def validate(self, metric: str, name: str, value):
        if value is None:
            return None
        if isinstance(value, str):
            names = [v.strip() for v in value.replace("+", ",").split(",") if v.strip()]
        elif isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value):
            names = list(value)
        else:
            raise OptionError(f"metric {metric!r}: option {name!r} must be {self.describe()}, got {value!r}")
        if not names:
            raise OptionError(f"metric {metric!r}: option {name!r} names no attribute; "
                              "use None for every one the mesh has")
        for v in names:
            if v not in ATTRIBUTE_WIDTHS:
                raise OptionError(f"metric {metric!r}: option {name!r}: unknown attribute {v!r}; "
                                  f"choose among {', '.join(_ORDER)}")
        if len(set(names)) != len(names):
            raise OptionError(f"metric {metric!r}: option {name!r} repeats an attribute: {value!r}")
        return tuple(names)


class _class_or_instance:
    """A method that runs on the instance when there is one, else on the class: the
    quadric's dimension depends on the attributes an instance chose."""

    def __init__(self, func):
        self.func = func

    def __get__(self, obj, cls):
        target = obj if obj is not None else cls
        return lambda: self.func(target)


def _face_frames(points: np.ndarray):
    """Gram-Schmidt of p2 - p1, p3 - p1 in D dimensions: (e1, e2), each (m, D); zero rows
    where the triangle is degenerate in R^D (its 3D area is then zero too)."""
    d1 = points[:, 1] - points[:, 0]
    d2 = points[:, 2] - points[:, 0]
    n1 = np.linalg.norm(d1, axis=1)
    e1 = np.divide(d1, n1[:, None], out=np.zeros_like(d1), where=n1[:, None] > 0)
    t = d2 - np.einsum("ij,ij->i", e1, d2)[:, None] * e1
    n2 = np.linalg.norm(t, axis=1)
    # below ~1e-12 of the edge lengths the second direction is rounding noise
    ok = n2 > 1e-12 * np.maximum(n1, np.linalg.norm(d2, axis=1))
    e2 = np.divide(t, n2[:, None], out=np.zeros_like(t), where=ok[:, None])
    return e1, e2


def gh98_face_quadrics(points: np.ndarray):
    """Garland-Heckbert 1998 quadric of each triangle over R^D (unweighted).

    points : (m, 3, D) the corners [x y z a1 .. ak]
    returns A (m, D, D), b (m, D), c (m,) with Q(v) = v'Av + 2b'v + c the squared distance
    of v to the 2-plane through the corners:
        A = I - e1 e1' - e2 e2',  b = (p1.e1) e1 + (p1.e2) e2 - p1,
        c = p1.p1 - (p1.e1)^2 - (p1.e2)^2
    """
    points = np.asarray(points, dtype=np.float64)
    m, _, D = points.shape
    e1, e2 = _face_frames(points)
    p1 = points[:, 0]
    a1 = np.einsum("ij,ij->i", p1, e1)
    a2 = np.einsum("ij,ij->i", p1, e2)
    A = np.broadcast_to(np.eye(D), (m, D, D)) - e1[:, :, None] * e1[:, None, :] - e2[:, :, None] * e2[:, None, :]
    b = a1[:, None] * e1 + a2[:, None] * e2 - p1
    c = np.einsum("ij,ij->i", p1, p1) - a1 * a1 - a2 * a2
    return A, b, c


def _gh98_packed(points: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """:func:`gh98_face_quadrics` of the weighted points ``points * scale``, transformed
    back to the unweighted coordinates (A -> S A S, b -> S b) and packed (m, S) -- built
    entry by entry, without the (m, D, D) matrices."""
    m, _, D = points.shape
    y = points * scale
    e1, e2 = _face_frames(y)
    p1 = y[:, 0]
    a1 = np.einsum("ij,ij->i", p1, e1)
    a2 = np.einsum("ij,ij->i", p1, e2)
    i, j = np.triu_indices(D)
    out = np.empty((m, i.size + D + 1))
    out[:, :i.size] = (np.eye(D)[i, j] - e1[:, i] * e1[:, j] - e2[:, i] * e2[:, j]) * (scale[i] * scale[j])
    out[:, i.size:i.size + D] = (a1[:, None] * e1 + a2[:, None] * e2 - p1) * scale
    out[:, -1] = np.einsum("ij,ij->i", p1, p1) - a1 * a1 - a2 * a2
    return out


def hoppe99_face_quadrics(points: np.ndarray):
    """Hoppe 1999 quadric of each triangle over R^D (unweighted).

    Q(p, s) = (n.p + d)^2 + sum_j (s_j - g_j.p - d_j)^2: the squared distance of the
    position to the face's plane plus, for each attribute channel j, the squared
    difference to the face's linear field g_j.p + d_j (g_j in the face's plane, the field
    takes the corners' values).  Returns A (m, D, D), b (m, D), c (m,).
    """
    points = np.asarray(points, dtype=np.float64)
    m, _, D = points.shape
    k = D - 3
    P = points[:, :, :3]
    nrm = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    length = np.linalg.norm(nrm, axis=1)
    scale = np.maximum(np.einsum("ijk,ijk->i", P[:, 1:] - P[:, :1], P[:, 1:] - P[:, :1]), 1e-300)
    ok = length > 1e-12 * scale
    n = np.divide(nrm, length[:, None], out=np.zeros_like(nrm), where=ok[:, None])
    d = -np.einsum("ij,ij->i", n, P[:, 0])
    # [p_i' 1] [g; d_j] = s_ij (i = 1..3), [n' 0] [g; d_j] = 0: the field lies in the plane
    M = np.zeros((m, 4, 4))
    M[:, :3, :3] = P
    M[:, :3, 3] = 1.0
    M[:, 3, :3] = n
    rhs = np.zeros((m, 4, k))
    rhs[:, :3, :] = points[:, :, 3:]
    M[~ok] = np.eye(4)
    rhs[~ok] = 0.0
    sol = np.linalg.solve(M, rhs)                    # (m, 4, k)
    g = sol[:, :3, :]                                # (m, 3, k) gradients, one column each
    dj = sol[:, 3, :]                                # (m, k)
    A = np.zeros((m, D, D))
    A[:, :3, :3] = n[:, :, None] * n[:, None, :] + np.einsum("mik,mjk->mij", g, g)
    A[:, :3, 3:] = -g
    A[:, 3:, :3] = -g.transpose(0, 2, 1)
    A[:, 3:, 3:] = np.eye(k)
    b = np.zeros((m, D))
    b[:, :3] = d[:, None] * n + np.einsum("mik,mk->mi", g, dj)
    b[:, 3:] = -dj
    c = d * d + np.einsum("mk,mk->m", dj, dj)
    A[~ok] = 0.0
    b[~ok] = 0.0
    c[~ok] = 0.0
    return A, b, c


class Appearance(QuadricMetric):
    """Appearance-preserving quadrics (Garland-Heckbert 1998; Hoppe 1999 as an option).

    The quadric ranges over position and the attributes chosen by ``attributes`` (by
    default every one the mesh has among colors, uvs and normals); each face's quadric is
    weighted by its area and given to its three corners.  The core places the vertex by
    the quadric with the attributes minimised out and gives the kept vertex the attribute
    values of the minimum; ``result.error`` stays the geometric (plain QEM) error.
    """

    description = "appearance-preserving quadrics over position + colours/uvs/normals (Garland-Heckbert 1998)"
    attributes: tuple = ()                  # the class's; an instance's follow its options / mesh
    options = {
        "attributes": _AttributesOption(),
        "color_weight": Option(1.0, min=0.0, doc="scale of RGB (in [0, 1]) against positions "
                                                 "normalised to a unit bbox diagonal"),
        "uv_weight": Option(1.0, min=0.0, doc="scale of the uvs (as given) against normalised positions"),
        "normal_weight": Option(1.0, min=0.0, doc="scale of the unit normals against normalised positions"),
        "formulation": Option("gh98", kind=str, choices=("gh98", "hoppe99"),
                              doc="gh98: squared distance to the face's 2-plane in R^D (Garland-Heckbert "
                                  "1998); hoppe99: distance to the face's plane plus the attribute "
                                  "differences to its linear fields (Hoppe 1999)"),
    }

    def __init__(self, **options):
        super().__init__(**options)
        chosen = self.params["attributes"]
        if chosen is not None:
            self.attributes = tuple(a for a in _ORDER if a in chosen)

    @_class_or_instance
    def dimension(self) -> int:
        return 3 + sum(ATTRIBUTE_WIDTHS[a] for a in self.attributes)

    def prepare(self, ctx: MetricContext) -> None:
        mesh = ctx.mesh
        chosen = self.params["attributes"]
        if chosen is None:
            self.attributes = tuple(a for a in _ORDER if getattr(mesh, a, None) is not None)
            return
        for a in self.attributes:
            if getattr(mesh, a, None) is None:
                have = [x for x in _ORDER if getattr(mesh, x, None) is not None]
                raise MetricError(f"metric {self.name!r}: attributes={chosen!r} asks for per-vertex {a}, "
                                  f"and the mesh has none (it has: {', '.join(have) or 'no attributes'})")

    def scales(self) -> np.ndarray:
        """(D,) the factor of each coordinate: 1 for x, y, z, then each attribute's weight."""
        return np.concatenate([np.ones(3)] + [np.full(ATTRIBUTE_WIDTHS[a], self.params[_WEIGHT_OPTION[a]])
                                              for a in self.attributes])

    def points(self, ctx: MetricContext, weighted: bool = True) -> np.ndarray:
        """(n, D) the vertex slots as points of R^D: normalised position, then each
        attribute (colours: RGB, alpha left out), times its weight unless ``weighted`` is
        False."""
        cols = [np.asarray(ctx.positions, dtype=np.float64)]
        for a in self.attributes:
            cols.append(np.asarray(ctx.vertex_attribute(a), dtype=np.float64)[:, :ATTRIBUTE_WIDTHS[a]])
        X = np.concatenate(cols, axis=1)
        return X * self.scales() if weighted else X

    def quadrics(self, ctx: MetricContext) -> np.ndarray:
        from scipy.sparse import csr_matrix

        faces = np.asarray(ctx.faces)
        alive = np.asarray(ctx.halfedge.alive_faces)
        faces = faces[alive]
        X = self.points(ctx, weighted=False)
        corners = X[faces]                                          # (m, 3, D)
        area = 0.5 * np.linalg.norm(face_vectors(X[:, :3], faces), axis=1)
        # built over the weighted coordinates y = S x; the core solves for the attributes in
        # their own units, so it gets Q(S x): A -> S A S, b -> S b
        s = self.scales()
        if self.params["formulation"] == "hoppe99" and X.shape[1] > 3:
            A, b, c = hoppe99_face_quadrics(corners * s)
            per_face = pack_quadrics(A * (s[:, None] * s[None, :]), b * s, c)
        else:
            per_face = _gh98_packed(corners, s)
        per_face *= area[:, None]                                   # (m, S), area-weighted
        m = faces.shape[0]
        n = ctx.n_vertices
        # each face's quadric goes to its three corners: (n, m) incidence times (m, S)
        incidence = csr_matrix((np.ones(3 * m), (faces.reshape(-1), np.repeat(np.arange(m), 3))),
                               shape=(n, m))
        return np.asarray(incidence @ per_face)
