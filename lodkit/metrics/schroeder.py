"""Vertex decimation of Schroeder, Zarge & Lorensen (SIGGRAPH 1992).

Each vertex is classified from its star (simple, complex, boundary, interior edge, corner;
a feature edge is one whose dihedral angle is more than ``feature_angle``).  A simple
vertex costs its distance to the average plane of its star, a boundary or interior-edge
vertex its distance to the line through its two boundary / feature neighbours (the edge
that will replace it); corners and complex vertices stay.  The cheapest vertex is removed
and its hole filled by recursive loop splitting (split planes orthogonal to the average
plane, splits chosen by aspect ratio; a crease's first split runs along the crease).
``simplify(max_error=...)`` is the paper's E_MAX.  docs/metrics/schroeder.md gives the
formulas, the defaults' sources and the readings where the sources are terse.
"""
from __future__ import annotations

from .._core.schroeder_kernel import DEFAULT_FEATURE_ANGLE, DEFAULT_MIN_ASPECT, SchroederKernel
from ._removal import accumulate_option
from .base import Option, RemovalMetric


class Schroeder(RemovalMetric):
    """Schroeder et al. 1992: vertex removal by distance to the average plane (or to the new
    boundary / feature edge), holes filled by recursive loop splitting."""

    description = "Schroeder et al. 1992: vertex removal, distance to average plane / feature line"
    kernel = SchroederKernel
    options = {
        "feature_angle": Option(DEFAULT_FEATURE_ANGLE, min=0.0, max=180.0,
                                doc="degrees: an edge whose two faces' normals differ by more is a "
                                    "feature edge (vtkDecimate's default 30)"),
        "min_aspect": Option(DEFAULT_MIN_ASPECT, min=0.0, max=1.0,
                             doc="smallest aspect ratio of a loop split (min distance of the loop "
                                 "to the split plane / split length); below it the vertex stays "
                                 "(vtkDecimate's 1/25)"),
        "remove_corners": Option(None, kind=bool, allow_none=True,
                                 doc="let corner vertices go (by distance to the average plane, or "
                                     "to the new boundary edge on a boundary, and by the carried "
                                     "error); Schroeder keeps them.  None, the default: False with "
                                     "accumulate='off', else True"),
        "triangulation": Option("auto", choices=("auto", "split", "nearest"),
                                doc="lodkit's addition: 'nearest' = for a vertex with no feature line "
                                    "to keep (simple, corner), of the loop split and the hole's "
                                    "least-volume triangulation, the one nearer to the "
                                    "removed vertex (none that folds; also when no loop split is "
                                    "valid); 'split' = the paper's recursive loop splitting; 'auto' "
                                    "= 'split' with accumulate='off', else 'nearest'"),
        "accumulate": accumulate_option("d", "e"),
    }
