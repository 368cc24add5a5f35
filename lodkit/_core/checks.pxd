# cython: language_level=3
"""The geometric checks every driver makes before it changes the surface, as small inline
steps: a face turning too far (normal flip), turning away from the input face it stands
for, folding onto a neighbour, becoming a sliver, and a closed surface turning inside out.

The edge collapse drivers (``EdgeCollapser.fan_ok``) and vertex removal
(``VertexRemover.geometry_ok``) walk different faces (a moved fan; a re-triangulated star)
but decide with these same expressions.  Each takes its operands in the order the caller
gives, so that a driver's floating-point result does not depend on this module: ``a * b * c``
is ``(a * b) * c``.  One test stays with each driver: the degenerate-face test (the edge
driver refuses ``len <= 1e-12 * s``, vertex removal refuses ``not len > 1e-12 * s``: they
differ for a NaN length, and the two sums ``s`` are not the same edges)."""
from libc.math cimport cos, M_PI

from .common cimport FOLD_COS, SQRT3
from .vec3 cimport dot3


cdef struct CheckLimits:     # what the checks allow: the same options in every driver
    double cos_max_angle     # cos(max_normal_angle): the largest turn of a changed face
    double cos_orig_angle    # cos(min(max_normal_angle, 90)): its largest turn from its input face
    bint check_orig          # max_normal_angle < 180: the input-face test is on
    bint check_fold          # max_normal_angle < 180: the fold test is on (own flag: the census)
    double min_quality       # a face below this quality (and worse than before) is refused
    bint check_knife         # no collapse may join the two sides of a thin sheet (edge collapse)


cdef inline CheckLimits check_limits(double max_normal_angle, double min_quality) noexcept nogil:
    """The limits for ``max_normal_angle`` (degrees, in (0, 180], checked by the caller) and
    ``min_quality`` (0: no quality test)."""
    cdef CheckLimits lim
    lim.cos_max_angle = cos(max_normal_angle * M_PI / 180.0)
    lim.cos_orig_angle = cos((max_normal_angle if max_normal_angle < 90.0 else 90.0) * M_PI / 180.0)
    lim.check_orig = max_normal_angle < 180.0
    lim.check_fold = lim.check_orig
    lim.min_quality = min_quality
    lim.check_knife = lim.check_orig
    return lim


cdef inline bint angle_exceeds(double d, double cos_limit, double la, double lb) noexcept nogil:
    """Do two vectors of lengths ``la`` and ``lb`` whose dot product is ``d`` make an angle
    wider than acos(cos_limit)?  (d < cos_limit * la * lb, without a division.)"""
    return d < cos_limit * la * lb


cdef inline bint turned_from_input(double d, double cos_limit, double scale, double length) noexcept nogil:
    """Has a face turned more than acos(cos_limit) from the input face it stands for?  ``d``
    is its normal (of ``length``) dotted with the input face's unit normal stored times
    ``scale`` (the edge driver keeps int16 normals times 32767; vertex removal float64 ones,
    scale 1.0, for which ``cos_limit * 1.0`` is exactly ``cos_limit``)."""
    return d < cos_limit * scale * length


cdef inline bint new_fold(const double* n_new, double l_new, const double* n_old, double l_old,
                          const double* n_other, double l_other) noexcept nogil:
    """Does a face, changing from normal ``n_old`` to ``n_new``, fold onto a neighbour of
    normal ``n_other``: more than ~120 degrees from it (FOLD_COS) and further than before?"""
    cdef double d = dot3(n_new, n_other)
    return d < FOLD_COS * l_new * l_other and d * l_old < dot3(n_old, n_other) * l_new


cdef inline bint folds(const double* n_a, double l_a, const double* n_b, double l_b) noexcept nogil:
    """Do two new adjacent faces fold onto each other (more than ~120 degrees apart)?"""
    return dot3(n_a, n_b) < FOLD_COS * l_a * l_b


cdef inline bint sides_of_a_sheet(const short* N0, int f, int g) noexcept nogil:
    """Do faces ``f`` and ``g`` stand for input faces that are themselves folded onto each
    other (more than ~120 degrees apart: FOLD_COS), the two sides of a thin sheet?  Then a
    fold between them is the sheet's shape at a coarse level, not a new fold: the edge
    driver's fold tests let it be (``N0``: the input faces' unit normals times 32767)."""
    return (<double>N0[3 * f] * N0[3 * g] + <double>N0[3 * f + 1] * N0[3 * g + 1]
            + <double>N0[3 * f + 2] * N0[3 * g + 2]) < FOLD_COS * 32767.0 * 32767.0


cdef inline bint flat_sides(const short* N0, int f, int g) noexcept nogil:
    """Do faces ``f`` and ``g`` stand for input faces facing exactly opposite ways (their
    normals' dot product below -0.9999: within ~0.8 degrees), the two flat sides of a sheet
    such as a CAD plate's top and bottom?  The edge driver's knife test
    (``EdgeCollapser.knife``); a smooth thin part (an ear, a horn) seldom has two input
    faces that parallel, so it is left alone."""
    return (<double>N0[3 * f] * N0[3 * g] + <double>N0[3 * f + 1] * N0[3 * g + 1]
            + <double>N0[3 * f + 2] * N0[3 * g + 2]) < -0.9999 * 32767.0 * 32767.0


cdef inline double tri_quality(double twice_area, double sum_sq_edges) noexcept nogil:
    """Triangle quality 4 sqrt(3) A / (l0^2 + l1^2 + l2^2): 1 for an equilateral triangle,
    0 for a degenerate one (``twice_area`` is |(b - a) x (c - a)|)."""
    return 2.0 * SQRT3 * twice_area / sum_sq_edges


cdef inline double face_volume(const double* a, const double* b, const double* c) noexcept nogil:
    """Six times the signed volume of the cone from the origin over triangle a b c."""
    return (a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2])
            + a[2] * (b[0] * c[1] - b[1] * c[0]))


cdef inline bint turns_inside_out(double closed_volume, double dvol) noexcept nogil:
    """Would a closed surface of (six times) ``closed_volume`` change sign by ``dvol``
    (locally valid faces can still enclose a negative volume once the mesh is down to a
    handful of faces)?"""
    return (closed_volume + dvol) * closed_volume <= 0.0
