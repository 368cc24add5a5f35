"""What the built-in vertex-removal metrics (``schroeder``, ``volume``) share: their
``accumulate`` option."""
from __future__ import annotations

from .base import Option


def accumulate_option(own_error: str, ranked_by: str) -> Option:
    """The ``accumulate`` option of a removal metric whose own error of a vertex is
    ``own_error`` (its memory-less measure) and whose 'bound' reading ranks by
    ``ranked_by``."""
    return Option("points", choices=("points", "bound", "off"),
                  doc="lodkit's addition: 'points' (the default) = every removed vertex and every "
                      "input face's centroid stays on the face nearest it, and a removal costs the "
                      "largest distance of the vertex and of the points on its star's faces to the "
                      "patch that would replace the star (a measured distance: the error bounds how "
                      "far any input vertex lies from the output); 'bound' = carry what each removal "
                      "took away to the vertices that remain: a vertex's error e is the larger of "
                      f"{own_error} and its distance to the patch that would replace its star, plus "
                      "the largest e of a removed neighbour (an accumulated distance bound; ranked "
                      f"by {ranked_by}, held to max_error); 'off' = the paper's memory-less rule")
