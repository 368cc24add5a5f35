"""MELOD (Hussain, Okada, Nijima, WSCG 2004): half-edge collapse ranked by the turn of the
moved triangles, scaled by the visual importance of the removed vertex, with cost
accumulation and boundary heuristics.  docs/metrics/melod.md has the formulas and the
readings chosen where the paper is ambiguous."""
from __future__ import annotations

from .._core.melod_kernel import MELODKernel
from .base import KernelMetric, Option


class MELOD(KernelMetric):
    """Memory-efficient LOD: w_v * max(sum of l_t (1 - n_t . n_t'), accumulated cost), plus
    lambda * phi * length along boundaries.  Output vertices are a subset of the input's, and
    ``record=True`` gives the collapse sequence of a progressive mesh."""

    description = "Hussain et al.: half-edge collapse, visual importance, cost accumulation"
    kernel = MELODKernel
    options = {
        "boundary_lambda": Option(10.0, min=1.0, max=50.0,
                                  doc="lambda: weight of the boundary penalty (paper: 1..50, default 10)"),
        "phi": Option("head", choices=("head", "origin"),
                      doc="phi of a boundary half-edge o->h: 'head' = 1 - u_ho.u_hn as printed in "
                          "the paper, 'origin' = 1 + u_op.u_oh (the turn at the removed vertex)"),
        "importance": Option(True, kind="bool", doc="scale by the visual importance w_v (paper: yes)"),
        "accumulate": Option("cost", choices=("cost", "key", "off"),
                             doc="after a collapse its neighbours' costs are at least its cost: 'cost' "
                                 "= the unscaled cost max(sum Q_t, acc) (our reading of the paper), "
                                 "'key' = the cost scaled by w_v, 'off' = no accumulation"),
        "scale_boundary": Option(True, kind="bool",
                                 doc="scale the boundary penalty by w_v with the rest, as the paper does "
                                     "(False: add it unscaled, so a flat boundary vertex still pays for "
                                     "bending its boundary)"),
    }
    # half-edge collapse: the kept vertex stays where it is; the core's own placement is not
    # needed (endpoint is the cheap one).  The paper checks no triangle quality (its only
    # rules are the boundary ones); lodkit's flip check (90 degrees) stays on.
    defaults = {"placement": "endpoint", "min_quality": 0.0}
