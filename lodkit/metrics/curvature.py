"""Feature-preserving simplification by curvature-weighted edge order (Wang et al. 2011).

Every vertex gets a normalised curvature w in [0, 1] from its point neighbourhood (eqs.
1-5, :func:`lodkit.curvature.point_curvature`); an edge of length l weighs

    omega = l * (floor + (w_u + w_v) / 2)                                   (eq. 6, as read)

and the lightest edge collapses first: flat regions and short edges go first, creases and
corners last.  The paper's validity checks are this metric's defaults: normals may turn by
at most 60 degrees, no face below quality Q = 4 sqrt(3) A / (l0^2 + l1^2 + l2^2) = 0.5, and
the link condition (always on in lodkit) keeps the surface manifold.
docs/metrics/curvature.md gives the choices made where the paper is ambiguous.
"""
from __future__ import annotations

import numpy as np

from .._core.curvature_kernel import CurvatureKernel
from ..curvature import DEFAULT_K, point_curvature
from ..errors import MetricError, OptionError
from .base import KernelMetric, MetricContext, Option


class Curvature(KernelMetric):
    """Wang et al.'s edge weight: edge length times the mean normalised curvature of its
    ends; the lightest edge collapses first."""

    description = "Wang et al. 2011: length x mean normalised curvature (flat and short first)"
    kernel = CurvatureKernel
    defaults = {"max_normal_angle": 60.0, "min_quality": 0.5}
    options = {
        "k": Option(DEFAULT_K, kind=int, min=3, max=1000,
                    doc="neighbours of each vertex in the curvature fit (k nearest other vertices)"),
        "radius": Option(None, allow_none=True, min=0.0,
                         doc="if given: the neighbours are all vertices within this distance, in the "
                             "mesh's units, instead of the k nearest"),
        "floor": Option(0.01, min=0.0,
                        doc="added to the mean curvature, so flat regions (w = 0) are still ordered by "
                            "length; 0 is the paper's formula"),
        "merge": Option("max", kind=str, choices=("max", "mean"),
                        doc="curvature of the kept vertex after a collapse: the larger of the two "
                            "(keeps creases dear) or their mean"),
        "mode": Option("replace", kind=str, choices=("replace", "scale"),
                       doc="replace: cost = weight * omega (the paper); scale: the cost so far "
                           "(e.g. QEM's) times 1 + weight * mean curvature"),
        "midpoint": Option(False, kind=bool,
                           doc="put the kept vertex at the edge midpoint (else the core places it: "
                               "the QEM optimum, or an end under placement='endpoint')"),
    }

    def validate_options(self, given: dict) -> dict:
        params = super().validate_options(given)
        if params["radius"] is not None and not params["radius"] > 0.0:
            raise OptionError(f"metric {self.name!r}: option 'radius' must be a number > 0 or None, "
                              f"got {given['radius']!r}")
        return params

    def vertex_curvature(self, ctx: MetricContext) -> np.ndarray:
        """(n,) normalised curvature w (eq. 5) of every vertex slot, from the vertex cloud
        with this metric's ``k`` / ``radius`` (``radius`` in model units)."""
        p = self.params
        radius = None if p["radius"] is None else p["radius"] / ctx.scale
        w = point_curvature(np.asarray(ctx.positions), k=p["k"], radius=radius, normalize=True)
        if w.shape != (ctx.n_vertices,) or not np.isfinite(w).all():
            raise MetricError(f"metric {self.name!r}: the curvature estimate is not finite")
        return w

    def prepare(self, ctx: MetricContext) -> None:
        self._curvature = self.vertex_curvature(ctx)

    def make_kernel(self, ctx: MetricContext):
        w = getattr(self, "_curvature", None)
        if w is None or w.shape != (ctx.n_vertices,):
            w = self.vertex_curvature(ctx)
        self._curvature = None          # one run's array: do not keep it alive on the instance
        k = self.kernel()
        k.prepare(ctx, dict(self.params, curvature=w))
        return k
