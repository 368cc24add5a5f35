# cython: language_level=3
"""The edge-collapse drivers' entry point: ``EdgeCollapser(...)`` makes the driver the
arguments ask for, and the quadric builders are re-exported for the Python callers.

    operator=0, use_heap=True    lodkit._core.edge.EdgeCollapser      greedy, one edge at a time
    operator=0, use_heap=False   lodkit._core.passes.PassCollapser    batch metrics, in passes
    operator=1                   lodkit._core.triangle.TriangleCollapser   faces to points

All three share the state and the checked edge collapse of ``edge.pyx``; quadric maths and
builders live in ``quadric.pyx``, the checks' expressions in ``checks.pxd``.
"""
from libc.math cimport INFINITY

from .common cimport OP_EDGE, OP_TRIANGLE, PLACE_OPTIMAL, BOUNDARY_PRESERVE
from .halfedge cimport HalfEdgeMesh

from .quadric import face_unit_normals, vertex_quadrics, add_boundary_planes, general_quadric_marginal
from . import edge as _edge, passes as _passes, triangle as _triangle

__all__ = ["EdgeCollapser", "face_unit_normals", "vertex_quadrics", "add_boundary_planes", "general_quadric_marginal"]


def EdgeCollapser(HalfEdgeMesh hm, positions, quadrics, attributes, fixed,
                  int placement=PLACE_OPTIMAL, int boundary=BOUNDARY_PRESERVE,
                  double max_normal_angle=90.0, double min_quality=0.0,
                  double max_error=INFINITY, bint record=False, bint closed_connected=False,
                  double quadric_weight=1.0, double error_scale=1.0,
                  vertex_fields=None, vertex_rules=None, edge_fields=None, edge_rules=None,
                  kernels=(), bint use_heap=True, attribute_quadrics=None, attribute_columns=None,
                  steps=None, seam_partners=None, int operator=OP_EDGE, error_bound=None, int threads=1,
                  input_normals=None):
    """The edge-collapse driver for these arguments (see the module docstring and
    :class:`lodkit._core.edge.EdgeCollapser` for their meaning); ``operator``: 0 edge
    collapse (the candidates are edges), 1 triangle collapse (faces: a face goes to one point
    as two edge collapses, both checked before either is done; quadric metrics only);
    ``threads``: OpenMP threads of the set-up (the driver's state is the same for any);
    ``input_normals``: the input faces' int16 normals when ``vertex_quadrics(normals=)``
    made them already."""
    if operator not in (OP_EDGE, OP_TRIANGLE):
        raise ValueError(f"unknown operator {operator} (0 edge collapse, 1 triangle collapse)")
    if operator == OP_TRIANGLE:
        driver = _triangle.TriangleCollapser
    elif not use_heap:
        driver = _passes.PassCollapser
    else:
        driver = _edge.EdgeCollapser
    return driver(hm, positions, quadrics, attributes, fixed, placement=placement, boundary=boundary,
                  max_normal_angle=max_normal_angle, min_quality=min_quality, max_error=max_error,
                  record=record, closed_connected=closed_connected, quadric_weight=quadric_weight,
                  error_scale=error_scale, vertex_fields=vertex_fields, vertex_rules=vertex_rules,
                  edge_fields=edge_fields, edge_rules=edge_rules, kernels=kernels, use_heap=use_heap,
                  attribute_quadrics=attribute_quadrics, attribute_columns=attribute_columns,
                  steps=steps, seam_partners=seam_partners, error_bound=error_bound, threads=threads,
                  input_normals=input_normals)
