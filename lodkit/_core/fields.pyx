# cython: language_level=3
"""The field and kernel plumbing of the edge-collapse metrics (fields.pxd): checked field
arrays and rules, the order of the steps after the quadric, merging on collapse."""
import numpy as np
cimport numpy as cnp

cnp.import_array()


def _field_arrays(values, rules, int rows, str what):
    """Check a (rows, k) field block and its (k, 5) rules; an empty block if None."""
    if values is None:
        return np.zeros((1, 1)), np.zeros((1, RULE_COLS)), 0
    vals = np.ascontiguousarray(values, dtype=np.float64)
    if vals.ndim == 1:
        vals = vals.reshape(-1, 1)
    if vals.ndim != 2 or vals.shape[0] != rows:
        raise ValueError(f"{what} fields must have shape ({rows}, k), got {np.shape(values)}")
    rl = np.ascontiguousarray(rules, dtype=np.float64)
    if rl.shape != (vals.shape[1], RULE_COLS):
        raise ValueError(f"{what} field rules must have shape ({vals.shape[1]}, {RULE_COLS})")
    if vals.shape[1] == 0:
        return np.zeros((1, 1)), np.zeros((1, RULE_COLS)), 0
    return vals, rl, int(vals.shape[1])


cdef class FieldSet:
    """Vertex fields (n_vertices, k) and edge fields (n_edges, k) with their (k, 5) rules
    (merge, value, mode, weight, offset: the codes of fields.pxd), and ``steps``, the
    (kind, first, end) rows that order fields and ``n_kernels`` kernels as the metrics were
    listed (default: vertex fields, edge fields, kernels).  The arrays are used in place when
    C-contiguous float64; they change as collapses merge them."""

    def __init__(self, int n_vertices, int n_edges, vertex_fields=None, vertex_rules=None,
                 edge_fields=None, edge_rules=None, steps=None, int n_kernels=0):
        self.vfield, self.vrules, self.n_vfields = _field_arrays(vertex_fields, vertex_rules, n_vertices, "vertex")
        self.efield, self.erules, self.n_efields = _field_arrays(edge_fields, edge_rules, n_edges, "edge")
        self.VF = &self.vfield[0, 0] if self.n_vfields and n_vertices else NULL
        self.EF = &self.efield[0, 0] if self.n_efields and n_edges else NULL
        if steps is None:
            # default order: vertex fields, edge fields, kernels
            rows = []
            if self.n_vfields:
                rows.append((STEP_VFIELD, 0, self.n_vfields))
            if self.n_efields:
                rows.append((STEP_EFIELD, 0, self.n_efields))
            if n_kernels:
                rows.append((STEP_KERNEL, 0, n_kernels))
            steps = rows
        st = np.asarray(steps, dtype=np.intc).reshape(-1, 3)
        limits = {STEP_VFIELD: self.n_vfields, STEP_EFIELD: self.n_efields, STEP_KERNEL: n_kernels}
        for kind, first, end in st:
            if kind not in limits or not (0 <= first < end <= limits[kind]):
                raise ValueError(f"bad step ({kind}, {first}, {end}): kinds 0 vertex field, 1 edge field, "
                                 f"2 kernels, with 0 <= first < end <= their count")
        self.steps = np.ascontiguousarray(st) if st.shape[0] else np.zeros((1, 3), dtype=np.intc)
        self.n_steps = st.shape[0]

    cdef double vertex_cost(self, double total, int j, int kept, int removed) noexcept nogil:
        """``total`` after vertex field ``j`` of the edge kept-removed."""
        cdef double* rule = &self.vrules[j, 0]
        # a: the kept end's value, b: the removed end's
        cdef double a = self.VF[self.n_vfields * kept + j]
        cdef double b = self.VF[self.n_vfields * removed + j]
        cdef double val
        cdef int code = <int>rule[RULE_VALUE]
        if code == VALUE_KEPT:
            val = a
        elif code == VALUE_REMOVED:
            val = b
        else:                      # max, min, sum, mean: the merge rules' own
            val = merge_value(a, b, MERGE_MEAN if code == VALUE_MEAN else code)
        return apply_field(total, val, rule)

    cdef double edge_cost(self, double total, int j, int e) noexcept nogil:
        """``total`` after edge field ``j`` of edge ``e``."""
        return apply_field(total, self.EF[self.n_efields * e + j], &self.erules[j, 0])

    cdef void merge(self, int r, int k, const int* dead, const int* merged_into) noexcept nogil:
        """The kept vertex takes merge(kept, removed) of each vertex field; the edge that a
        dead wing edge was glued onto takes merge(surviving, dead) of each edge field."""
        cdef int j, i, es, ed
        cdef int nv = self.n_vfields, ne = self.n_efields
        for j in range(nv):
            self.VF[nv * k + j] = merge_value(self.VF[nv * k + j], self.VF[nv * r + j], <int>self.vrules[j, RULE_MERGE])
        for i in range(2):
            es = merged_into[i]
            ed = dead[1 + i]
            if es < 0 or ed < 0:
                continue
            for j in range(ne):
                self.EF[ne * es + j] = merge_value(self.EF[ne * es + j], self.EF[ne * ed + j],
                                                   <int>self.erules[j, RULE_MERGE])

    @property
    def vertex_values(self):
        """(n, k) current vertex fields (merged on collapse)."""
        return np.asarray(self.vfield)[:, :self.n_vfields]

    @property
    def edge_values(self):
        return np.asarray(self.efield)[:, :self.n_efields]
