# cython: language_level=3
"""Precomputed per-vertex and per-edge fields of the edge-collapse metrics: how a field
merges on collapse, how a vertex field gives an edge its value, how the value enters the
cost, and the order (``steps``) in which fields and native kernels apply after the quadric."""

# field rules: how a field merges on collapse, how a vertex field gives an edge its value,
# and how the value enters the cost
cdef enum FieldMerge:
    MERGE_MAX = 0
    MERGE_MIN = 1
    MERGE_SUM = 2
    MERGE_KEEP = 3       # the kept vertex's (or surviving edge's) value
    MERGE_MEAN = 4

cdef enum FieldValue:    # the value of edge (u, v) from a vertex field
    VALUE_MAX = 0
    VALUE_MIN = 1
    VALUE_SUM = 2
    VALUE_KEPT = 3
    VALUE_REMOVED = 4
    VALUE_MEAN = 5

cdef enum FieldMode:
    MODE_SCALE = 0       # cost *= offset + weight * value
    MODE_ADD = 1         # cost += weight * value

cdef enum:
    STEP_VFIELD = 0      # rows of FieldSet.steps: (kind, first, end)
    STEP_EFIELD = 1
    STEP_KERNEL = 2

cdef enum:
    RULE_MERGE = 0       # columns of the (n_fields, 5) rule arrays
    RULE_VALUE = 1
    RULE_MODE = 2
    RULE_WEIGHT = 3
    RULE_OFFSET = 4
    RULE_COLS = 5


cdef inline double apply_field(double cost, double value, const double* rule) noexcept nogil:
    if <int>rule[RULE_MODE] == MODE_SCALE:
        return cost * (rule[RULE_OFFSET] + rule[RULE_WEIGHT] * value)
    return cost + rule[RULE_WEIGHT] * value


cdef inline double merge_value(double kept, double removed, int rule) noexcept nogil:
    if rule == MERGE_MAX:
        return kept if kept > removed else removed
    if rule == MERGE_MIN:
        return kept if kept < removed else removed
    if rule == MERGE_SUM:
        return kept + removed
    if rule == MERGE_MEAN:
        return 0.5 * (kept + removed)
    return kept


cdef class FieldSet:
    cdef readonly int n_vfields
    cdef readonly int n_efields
    cdef double[:, ::1] vfield      # (n_vertices, n_vfields)
    cdef double[:, ::1] vrules      # (n_vfields, RULE_COLS)
    cdef double[:, ::1] efield      # (n_edges, n_efields)
    cdef double[:, ::1] erules
    cdef double* VF                 # &vfield[0, 0], NULL without vertex fields
    cdef double* EF
    cdef int[:, ::1] steps          # (n_steps, 3): fields and kernels in the metrics' order
    cdef readonly int n_steps

    cdef double vertex_cost(self, double total, int j, int kept, int removed) noexcept nogil
    cdef double edge_cost(self, double total, int j, int e) noexcept nogil
    cdef void merge(self, int r, int k, const int* dead, const int* merged_into) noexcept nogil
