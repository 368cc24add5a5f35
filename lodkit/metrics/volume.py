"""Volume-cost vertex decimation (Chuon & Guha, *Volume Cost Based Mesh Simplification*).

A vertex V is *hyperbolic* when it lies inside the convex hull of its neighbours; those are
never removed.  Every other vertex costs

    vol(V) = angle(V) * ht(V)^3                                          (Definition 4)

with angle(V) the solid angle its link subtends (Van Oosterom-Strackee over the link
projected onto a plane separating V from the hull; 2 pi when V lies on a flat hull) and
ht(V) its distance to the least-squares plane of its neighbours.  Only vertices whose angle
is at least the median angle of the current non-hyperbolic vertices compete (the paper's
guard for sharp features), the cheapest goes, and its hole is filled by the fan from the
nearer end of the line through two neighbours closest to V (a half-edge collapse).

That is the paper's rule, ``accumulate="off"``.  lodkit's default (``accumulate="points"``)
carries the removed vertices and the input faces' centroids on the faces nearest them and
costs a removal by how far they lie from the new patch; hyperbolic vertices then compete at
that cost, the hole takes the triangulation nearest V and there is no median filter (the
options ``hyperbolic``, ``triangulation`` and ``median`` follow ``accumulate`` unless set).
docs/metrics/volume.md gives the formulas as implemented and the readings chosen.
"""
from __future__ import annotations

from .._core.volume_kernel import VolumeKernel
from ._removal import accumulate_option
from .base import Option, RemovalMetric


class Volume(RemovalMetric):
    """Chuon & Guha: remove the non-hyperbolic vertex of least angle * ht^3 among those
    with angle >= the median; closest-line fan re-triangulation."""

    description = "Chuon & Guha: vertex removal by volume cost angle*ht^3, median angle filter"
    kernel = VolumeKernel
    options = {
        "median": Option(None, kind=bool, allow_none=True,
                         doc="the paper's median filter: only vertices whose angle(V) is at least "
                             "the median angle of the non-hyperbolic vertices compete (False: all "
                             "vertices compete on their cost alone; None, the default: True with "
                             "accumulate='off', else False -- the carried error protects sharp "
                             "features, and the filter would force dearer removals)"),
        "tolerance": Option(1e-9, min=0.0, max=0.01,
                            doc="angle (radians) within which a neighbour counts as on a plane "
                                "through V: vertices hyperbolic by less than this are treated as "
                                "non-hyperbolic (flat)"),
        "fallback": Option(True, kind=bool,
                           doc="if the closest-line fan folds over (a new triangle turns 90 degrees "
                               "or more from the star's mean normal), use the apex of the next-closest "
                               "line whose fan does not (False: always the paper's closest-line fan, "
                               "which the driver then refuses)"),
        "hyperbolic": Option("auto", choices=("auto", "veto", "remove"),
                             doc="lodkit's addition: 'remove' = a hyperbolic vertex (inside the convex "
                                 "hull of its neighbours) competes like any other, its angle measured "
                                 "about the star's mean normal and its cost by what its removal moves "
                                 "the surface by; 'veto' = the paper: never removed; 'auto' = 'veto' "
                                 "with accumulate='off', else 'remove'"),
        "triangulation": Option("auto", choices=("auto", "closest_line", "nearest"),
                                doc="lodkit's addition: 'nearest' = of the paper's fan and the hole's "
                                    "least-volume triangulation, the one nearer to "
                                    "the removed vertex (none that folds); 'closest_line' = the paper's "
                                    "fan; 'auto' = 'closest_line' with accumulate='off', else 'nearest'"),
        "accumulate": accumulate_option("ht(V)", "angle * e^3"),
    }
