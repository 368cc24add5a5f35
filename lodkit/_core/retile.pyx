# cython: language_level=3
"""Native parts of re-tiling (lodkit.retile, Turk 1992) and mesh optimisation
(lodkit.optimize, Hoppe et al. 1993); docs/retile.md and docs/optimize.md.

* :class:`RetileKernel` -- the vertex-removal kernel re-tiling removes the old vertices
  with: the hole of a removed vertex gets the triangulation that maximises its smallest
  triangle quality (dynamic programming over the polygon's diagonals, O(k^3)), among the
  triangulations whose triangles all face the star's area-weighted normal.
* :func:`flip_edges` -- edge flips that raise the smaller quality of the two triangles of
  an edge (the max-min quality criterion, Delaunay-like), between nearly coplanar faces
  only (so the shape does not change), on a face list with twin half-edges.
"""
import numpy as np

from libc.stdint cimport int64_t

from lodkit.kernel cimport KERNEL_OK, KERNEL_VETO
from .halfedge cimport HEArrays, he_dest, he_prev, he_ring_next
from lodkit.removal cimport RemovalKernel, Star, Removal, MAX_VALENCE, REMOVAL_API_VERSION
from .vec3 cimport sub3, cross3, dot3, norm3
from libc.math cimport sqrt, fabs, NAN

cdef double SQRT3_4 = 4.0 * 1.7320508075688772


cdef inline double tri_quality(const double* a, const double* b, const double* c,
                               const double* nref) noexcept nogil:
    """4 sqrt(3) A / (l0^2 + l1^2 + l2^2) in [0, 1]; -1 when the triangle does not face
    ``nref`` (its normal . nref <= 0) or has zero area."""
    cdef double e0[3]
    cdef double e1[3]
    cdef double e2[3]
    cdef double n[3]
    sub3(b, a, e0)
    sub3(c, b, e1)
    sub3(a, c, e2)
    cross3(e0, e1, n)
    cdef double twice_area = norm3(n)
    cdef double sq = dot3(e0, e0) + dot3(e1, e1) + dot3(e2, e2)
    if twice_area <= 0.0 or sq <= 0.0 or dot3(n, nref) <= 0.0:
        return -1.0
    return SQRT3_4 * 0.5 * twice_area / sq


cdef class RetileKernel(RemovalKernel):
    """Removal kernel of re-tiling: the max-min-quality triangulation of the hole; cost
    1 - that quality (the vertices that leave the best holes go first), error 0."""

    api_version = REMOVAL_API_VERSION
    cdef double best[MAX_VALENCE * MAX_VALENCE]
    cdef int choice[MAX_VALENCE * MAX_VALENCE]
    cdef double fn[3 * MAX_VALENCE]
    # feature edges: an edge (v, link[i]) of a closed star whose two faces' unit normals have
    # a dot product below this is a crease; -2: none (the default)
    cdef double cos_feature
    # ``group``: the split copies of a non-manifold input vertex share a group >= 0 (others
    # -1); a chord that would put a vertex next to two copies of one input vertex is refused
    cdef int[::1] group_arr
    cdef const int* group
    cdef unsigned long long bad[MAX_VALENCE]

    def __init__(self, double cos_feature=-2.0, group=None):
        self.cos_feature = cos_feature
        self.group = NULL
        if group is not None:
            self.group_arr = np.ascontiguousarray(group, dtype=np.intc)
            if self.group_arr.shape[0]:
                self.group = &self.group_arr[0]

    @property
    def star_local(self):
        """The triangulation depends on the star alone -- not with ``group``, where a chord
        is refused by the link vertices' other neighbours (the driver then evaluates a
        popped vertex again)."""
        return self.group == NULL

    cdef bint next_to_copy(self, const HEArrays* he, int x, int g, int y, int v) noexcept nogil:
        """Is x next to a vertex of group g other than y and v?"""
        cdef int start = he.v_he[x], h, w, nh
        if start < 0:
            return False
        h = start
        while True:
            w = he_dest(he, h)
            if w != y and w != v and self.group[w] == g:
                return True
            nh = he_ring_next(he, h)
            if nh < 0:
                w = he.corner[he_prev(h)]
                return w != y and w != v and self.group[w] == g
            if nh == start:
                return False
            h = nh

    cdef void mark_bad_chords(self, const Star* s) noexcept nogil:
        """self.bad[i] bit j: the chord link[i]-link[j] would join two copies of one input
        vertex, or put one end next to a second copy of the other end's input vertex."""
        cdef int k = s.k, i, j, gi, gj
        for i in range(k):
            self.bad[i] = 0
        if self.group == NULL or s.mesh.he == NULL:
            return
        for j in range(k):
            gj = self.group[s.link[j]]
            if gj < 0:
                continue
            for i in range(k):
                if i == j:
                    continue
                gi = self.group[s.link[i]]
                if gi == gj or self.next_to_copy(s.mesh.he, s.link[i], gj, s.link[j], s.v):
                    self.bad[i] |= 1ULL << j
                    self.bad[j] |= 1ULL << i

    cdef int evaluate(self, const Star* s, Removal* r) noexcept nogil:
        cdef int k = s.k
        cdef const double* P = s.mesh.positions
        cdef int st = s.mesh.stride
        cdef const double* pv = P + st * s.v
        cdef double N[3]
        cdef double a[3]
        cdef double b[3]
        cdef double c[3]
        cdef int i, j, m, gap, nf, n_out
        cdef int fa = -1, fb = -1, n_feat = 0
        cdef double q, v, bestv
        if k < 3:
            return KERNEL_VETO
        N[0] = 0.0
        N[1] = 0.0
        N[2] = 0.0
        nf = k if s.closed else k - 1
        for i in range(nf):
            sub3(P + st * s.link[i], pv, a)
            sub3(P + st * s.link[(i + 1) % k], pv, b)
            cross3(a, b, c)
            N[0] += c[0]
            N[1] += c[1]
            N[2] += c[2]
            q = norm3(c)
            self.fn[3 * i] = c[0] / q if q > 0.0 else 0.0
            self.fn[3 * i + 1] = c[1] / q if q > 0.0 else 0.0
            self.fn[3 * i + 2] = c[2] / q if q > 0.0 else 0.0
        # a vertex on a crease (exactly two feature edges, to link[fa] and link[fb]): the hole
        # must keep the crease as the diagonal fa-fb (chords crossing it are not allowed)
        if s.closed and self.cos_feature > -2.0:
            for i in range(k):
                if dot3(&self.fn[3 * ((i + k - 1) % k)], &self.fn[3 * i]) < self.cos_feature:
                    n_feat += 1
                    if fa < 0:
                        fa = i
                    else:
                        fb = i
            if n_feat != 0 and n_feat != 2:
                return KERNEL_VETO
        if norm3(N) <= 0.0:
            return KERNEL_VETO
        self.mark_bad_chords(s)
        if not s.closed and (self.bad[0] >> (k - 1)) & 1ULL:
            return KERNEL_VETO                             # the new boundary edge
        for i in range(k - 1):
            self.best[i * MAX_VALENCE + i + 1] = 2.0       # an edge of the polygon: no triangle
        for gap in range(2, k):
            for i in range(k - gap):
                j = i + gap
                bestv = -2.0
                self.choice[i * MAX_VALENCE + j] = -1
                if n_feat == 2 and ((i < fa < j < fb) or (fa < i < fb < j)):
                    self.best[i * MAX_VALENCE + j] = -2.0      # the chord i-j crosses the crease
                    continue
                if (self.bad[i] >> j) & 1ULL and not (s.closed and i == 0 and j == k - 1):
                    self.best[i * MAX_VALENCE + j] = -2.0      # it would weld into a non-manifold edge
                    continue
                for m in range(i + 1, j):
                    q = tri_quality(P + st * s.link[i], P + st * s.link[m], P + st * s.link[j], N)
                    v = q
                    if self.best[i * MAX_VALENCE + m] < v:
                        v = self.best[i * MAX_VALENCE + m]
                    if self.best[m * MAX_VALENCE + j] < v:
                        v = self.best[m * MAX_VALENCE + j]
                    if v > bestv:
                        bestv = v
                        self.choice[i * MAX_VALENCE + j] = m
                self.best[i * MAX_VALENCE + j] = bestv
        bestv = self.best[k - 1]
        if not bestv > 0.0:
            return KERNEL_VETO
        # unfold the choices (an explicit stack of (i, j) pairs in r.tri as scratch ends)
        cdef int stack_i[MAX_VALENCE]
        cdef int stack_j[MAX_VALENCE]
        cdef int top = 0
        n_out = 0
        stack_i[0] = 0
        stack_j[0] = k - 1
        top = 1
        while top > 0:
            top -= 1
            i = stack_i[top]
            j = stack_j[top]
            if j - i < 2:
                continue
            m = self.choice[i * MAX_VALENCE + j]
            r.tri[3 * n_out] = i
            r.tri[3 * n_out + 1] = m
            r.tri[3 * n_out + 2] = j
            n_out += 1
            stack_i[top] = i
            stack_j[top] = m
            top += 1
            stack_i[top] = m
            stack_j[top] = j
            top += 1
        r.n_tris = n_out
        r.cost = 1.0 - bestv
        r.error = 0.0
        return KERNEL_OK


cdef inline bint same(int x, int d, const int* group, int gd) noexcept nogil:
    """x is d, or (``group`` given, ``gd`` >= 0) x is another copy of d's input vertex."""
    return x == d or (gd >= 0 and group[x] == gd)


cdef inline int has_edge(const int* F, const int* twin, int h_out, int d, const int* group=NULL,
                         int gd=-1) noexcept nogil:
    """Is d -- or, with ``group`` and ``gd`` >= 0, any vertex x with group[x] == gd (a copy of
    d's input vertex) -- a neighbour of the vertex half-edge ``h_out`` leaves?  Walks the fan
    both ways (to the boundary or around)."""
    cdef int h = h_out, f, nh
    while True:
        f = h // 3
        if same(F[3 * f + (h % 3 + 1) % 3], d, group, gd):
            return 1
        if same(F[3 * f + (h % 3 + 2) % 3], d, group, gd):
            return 1
        nh = twin[3 * f + (h % 3 + 2) % 3]           # the previous half-edge's twin leaves v
        if nh < 0:
            break
        if nh == h_out:
            return 0
        h = nh
    h = h_out
    while True:
        nh = twin[h]
        if nh < 0:
            return 0
        h = 3 * (nh // 3) + (nh % 3 + 1) % 3           # the twin's next leaves v
        if h == h_out:
            return 0
        f = h // 3
        if same(F[3 * f + (h % 3 + 1) % 3], d, group, gd):
            return 1
        if same(F[3 * f + (h % 3 + 2) % 3], d, group, gd):
            return 1


cdef inline void set_twin(int* twin, int h, int t) noexcept nogil:
    twin[h] = t
    if t >= 0:
        twin[t] = h


def flip_edges(double[:, ::1] V, int[:, ::1] F, int[::1] twin, double min_dot, int max_sweeps,
               const unsigned char[::1] locked=None, double below=2.0, double locked_dot=2.0,
               const int[::1] group=None):
    """Flip interior edges while a flip raises min(quality) of its two triangles by more
    than 1e-9, and the two faces before and after are within ``min_dot`` (cosine) of each
    other.  ``F`` (m, 3) and ``twin`` (3 m,) (half-edge h = 3 f + i runs F[f, i] -> F[f, i+1];
    -1 on the boundary) are updated in place.  An edge between two ``locked`` vertices is
    not flipped (nor one that would join two) when its two faces' unit normals, before (or
    after) the flip, have a dot product below ``locked_dot`` (2: never; a crease's cosine:
    only the edges along the crease stay).  Only edges whose worse triangle has a quality
    below ``below`` are flipped (2: all).  ``group`` (one entry per vertex of ``V``): the
    split copies of a non-manifold input vertex share a group >= 0, other vertices have -1;
    a flip whose new edge c-d would join two copies of one input vertex, or make c (d)
    adjacent to a second copy of d's (c's) input vertex, is refused (welded, the edge would
    have more than two faces).  Returns the number of flips."""
    cdef Py_ssize_t m = F.shape[0]
    if twin.shape[0] != 3 * m:
        raise ValueError("twin must have 3 m entries")
    cdef int* Fp = &F[0, 0] if m else NULL
    cdef int* T = &twin[0] if m else NULL
    cdef const double* P = &V[0, 0] if V.shape[0] else NULL
    cdef bint use_lock = locked is not None
    cdef const int* G = NULL
    cdef int gc, gd
    if group is not None:
        if group.shape[0] != V.shape[0]:
            raise ValueError("group must have one entry per vertex")
        if V.shape[0]:
            G = &group[0]
    cdef int flips = 0, _sweep, h, t, f, g, i, j, a, b, c, d, ha1, ha2, hb1, hb2, changed
    cdef bint lock_ab, lock_cd
    cdef double n1[3]
    cdef double n2[3]
    cdef double m1[3]
    cdef double m2[3]
    cdef double e0[3]
    cdef double e1[3]
    cdef double navg[3]
    cdef double qo, qn, q
    with nogil:
        for _sweep in range(max_sweeps):
            changed = 0
            for h in range(3 * m):
                t = T[h]
                if t < h:                 # each interior edge once (t = -1: boundary)
                    continue
                f = h // 3
                i = h % 3
                g = t // 3
                j = t % 3
                a = Fp[3 * f + i]
                b = Fp[3 * f + (i + 1) % 3]
                c = Fp[3 * f + (i + 2) % 3]
                d = Fp[3 * g + (j + 2) % 3]
                if c == d:
                    continue
                lock_ab = use_lock and locked[a] and locked[b]
                lock_cd = use_lock and locked[c] and locked[d]
                if (lock_ab or lock_cd) and locked_dot > 1.0:
                    continue
                # old faces (a, b, c), (b, a, d); new faces (c, a, d), (d, b, c)
                sub3(P + 3 * b, P + 3 * a, e0)
                sub3(P + 3 * c, P + 3 * a, e1)
                cross3(e0, e1, n1)
                sub3(P + 3 * a, P + 3 * b, e0)
                sub3(P + 3 * d, P + 3 * b, e1)
                cross3(e0, e1, n2)
                if norm3(n1) <= 0.0 or norm3(n2) <= 0.0:
                    continue
                if dot3(n1, n2) < min_dot * norm3(n1) * norm3(n2):
                    continue
                if lock_ab and dot3(n1, n2) < locked_dot * norm3(n1) * norm3(n2):
                    continue
                navg[0] = n1[0] / norm3(n1) + n2[0] / norm3(n2)
                navg[1] = n1[1] / norm3(n1) + n2[1] / norm3(n2)
                navg[2] = n1[2] / norm3(n1) + n2[2] / norm3(n2)
                qo = tri_quality(P + 3 * a, P + 3 * b, P + 3 * c, navg)
                q = tri_quality(P + 3 * b, P + 3 * a, P + 3 * d, navg)
                if q < qo:
                    qo = q
                if qo >= below:
                    continue
                qn = tri_quality(P + 3 * c, P + 3 * a, P + 3 * d, navg)
                q = tri_quality(P + 3 * d, P + 3 * b, P + 3 * c, navg)
                if q < qn:
                    qn = q
                if not qn > qo + 1e-9:
                    continue
                sub3(P + 3 * a, P + 3 * c, e0)
                sub3(P + 3 * d, P + 3 * c, e1)
                cross3(e0, e1, m1)
                sub3(P + 3 * b, P + 3 * d, e0)
                sub3(P + 3 * c, P + 3 * d, e1)
                cross3(e0, e1, m2)
                if dot3(m1, m2) < min_dot * norm3(m1) * norm3(m2):
                    continue
                if lock_cd and dot3(m1, m2) < locked_dot * norm3(m1) * norm3(m2):
                    continue
                gc = G[c] if G != NULL else -1
                gd = G[d] if G != NULL else -1
                if gc >= 0 and gc == gd:
                    continue                      # an edge between two copies of one vertex
                if has_edge(Fp, T, 3 * f + (i + 2) % 3, d, G, gd):
                    continue                      # c already next to d (or to a copy of it)
                if gc >= 0 and has_edge(Fp, T, 3 * g + (j + 2) % 3, c, G, gc):
                    continue                      # d already next to another copy of c
                # outer half-edges: b->c (hb1), c->a (ha1) in f; a->d (ha2), d->b (hb2) in g
                hb1 = T[3 * f + (i + 1) % 3]
                ha1 = T[3 * f + (i + 2) % 3]
                ha2 = T[3 * g + (j + 1) % 3]
                hb2 = T[3 * g + (j + 2) % 3]
                # f becomes (c, a, d): c->a, a->d, d->c; g becomes (d, b, c): d->b, b->c, c->d
                Fp[3 * f] = c
                Fp[3 * f + 1] = a
                Fp[3 * f + 2] = d
                Fp[3 * g] = d
                Fp[3 * g + 1] = b
                Fp[3 * g + 2] = c
                set_twin(T, 3 * f, ha1)
                set_twin(T, 3 * f + 1, ha2)
                set_twin(T, 3 * f + 2, 3 * g + 2)
                set_twin(T, 3 * g, hb2)
                set_twin(T, 3 * g + 1, hb1)
                flips += 1
                changed += 1
            if changed == 0:
                break
    return flips


cdef inline double closest_on_triangle(const double* p, const double* a, const double* b, const double* c,
                                       double* w) noexcept nogil:
    """Barycentric weights ``w`` of the point of triangle abc closest to p (Ericson, Real-Time
    Collision Detection 5.1.5); returns the squared distance.  A zero-area triangle gets
    its closest edge point."""
    cdef double ab[3]
    cdef double ac[3]
    cdef double ap[3]
    cdef double bp[3]
    cdef double cp[3]
    cdef double q[3]
    cdef double d1, d2, d3, d4, d5, d6, va, vb, vc, t, denom, v, u
    cdef int t3
    sub3(b, a, ab)
    sub3(c, a, ac)
    sub3(p, a, ap)
    d1 = dot3(ab, ap)
    d2 = dot3(ac, ap)
    if d1 <= 0.0 and d2 <= 0.0:
        w[0] = 1.0
        w[1] = 0.0
        w[2] = 0.0
    else:
        sub3(p, b, bp)
        d3 = dot3(ab, bp)
        d4 = dot3(ac, bp)
        sub3(p, c, cp)
        d5 = dot3(ab, cp)
        d6 = dot3(ac, cp)
        vc = d1 * d4 - d3 * d2
        vb = d5 * d2 - d1 * d6
        va = d3 * d6 - d5 * d4
        if d3 >= 0.0 and d4 <= d3:
            w[0] = 0.0
            w[1] = 1.0
            w[2] = 0.0
        elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0 and d1 - d3 != 0.0:
            t = d1 / (d1 - d3)
            w[0] = 1.0 - t
            w[1] = t
            w[2] = 0.0
        elif d6 >= 0.0 and d5 <= d6:
            w[0] = 0.0
            w[1] = 0.0
            w[2] = 1.0
        elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0 and d2 - d6 != 0.0:
            t = d2 / (d2 - d6)
            w[0] = 1.0 - t
            w[1] = 0.0
            w[2] = t
        elif va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0 and (d4 - d3) + (d5 - d6) != 0.0:
            t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            w[0] = 0.0
            w[1] = 1.0 - t
            w[2] = t
        else:
            denom = va + vb + vc
            if denom != 0.0:
                v = vb / denom
                u = vc / denom
                w[0] = 1.0 - v - u
                w[1] = v
                w[2] = u
            else:                          # degenerate: the nearest corner
                w[0] = 1.0
                w[1] = 0.0
                w[2] = 0.0
    for t3 in range(3):
        q[t3] = w[0] * a[t3] + w[1] * b[t3] + w[2] * c[t3] - p[t3]
    return dot3(q, q)


def project_local(const double[:, ::1] X, const int64_t[::1] S, const double[:, ::1] V, const int64_t[:, ::1] T):
    """For each sample X[S[i]], the closest of the triangles T (k, 3 vertex ids into V):
    (triangle index (n,) int64, barycentric weights (n, 3), squared distance (n,))."""
    cdef Py_ssize_t n = S.shape[0], k = T.shape[0], i, t
    best_arr = np.zeros(n, dtype=np.int64)
    w_arr = np.zeros((n, 3))
    d_arr = np.full(n, np.inf)
    cdef int64_t[::1] best = best_arr
    cdef double[:, ::1] W = w_arr
    cdef double[::1] D = d_arr
    cdef double wt[3]
    cdef double d
    with nogil:
        for i in range(n):
            for t in range(k):
                d = closest_on_triangle(&X[S[i], 0], &V[T[t, 0], 0], &V[T[t, 1], 0], &V[T[t, 2], 0], wt)
                if d < D[i]:
                    D[i] = d
                    best[i] = t
                    W[i, 0] = wt[0]
                    W[i, 1] = wt[1]
                    W[i, 2] = wt[2]
    return best_arr, w_arr, d_arr


def closest_on_faces(const double[:, ::1] X, const double[:, ::1] V, const int64_t[:, ::1] F,
                     const int64_t[::1] face):
    """For each point X[i], the closest point of face ``face[i]`` of (V, F): (barycentric
    weights (n, 3), squared distance (n,))."""
    cdef Py_ssize_t n = X.shape[0], i
    if face.shape[0] != n:
        raise ValueError("face must have one entry per point")
    w_arr = np.zeros((n, 3))
    d_arr = np.zeros(n)
    cdef double[:, ::1] W = w_arr
    cdef double[::1] D = d_arr
    cdef int64_t f
    with nogil:
        for i in range(n):
            f = face[i]
            D[i] = closest_on_triangle(&X[i, 0], &V[F[f, 0], 0], &V[F[f, 1], 0], &V[F[f, 2], 0], &W[i, 0])
    return w_arr, d_arr


def polish_sums(const double[:, ::1] P, const double[:, ::1] NI, const double[:, ::1] X,
                const int64_t[:, ::1] F, const double[:, ::1] NF, int64_t[::1] face,
                const int64_t[:, ::1] across, bint local, double floor):
    """One round of lodkit.polish's sums over the samples, in one pass each.

    P: (m, 3) samples, NI: (m, 3) the input normal at each, X / F: the output mesh, NF: its
    unit face normals, face: (m,) each sample's face (in: from the search, or last round's;
    out: the face it is matched to), across: (faces, 3) the face over each edge.  With
    ``local``, a sample goes to the closest of its face and the three across its edges;
    else it stays on ``face``.  A sample whose input normal opposes its face's normal is
    left out.  The signed distance d of a sample to its face's plane gets the weight
    sw = 1 / max(|d|, floor * RMS(d)).  Returns (the samples' mean distance to their
    faces, C (faces, 3, 3) = sum sw w w^T, r (faces, 3) = sum sw w (n . p), own (faces, 3) =
    sum sw w, sq (vertices,) = sum w d^2 and ws (vertices,) = sum w over the samples on the
    vertex's faces, stand (faces, 3) = the summed input normals of the samples kept on the
    face, and the number of samples kept)."""
    cdef Py_ssize_t m = P.shape[0], nf = F.shape[0], nv = X.shape[0], i, k, a, c
    if NI.shape[0] != m or face.shape[0] != m or NF.shape[0] != nf or across.shape[0] != nf:
        raise ValueError("polish_sums: array sizes do not match")
    if (P.shape[1] != 3 or NI.shape[1] != 3 or X.shape[1] != 3 or F.shape[1] != 3 or NF.shape[1] != 3
            or across.shape[1] != 3):
        raise ValueError("polish_sums: points, normals, faces and neighbours must have 3 columns")
    if not floor > 0.0:
        raise ValueError("polish_sums: floor must be positive")
    if m and (np.min(face) < 0 or np.max(face) >= nf):
        raise ValueError("polish_sums: a sample's face is out of range")
    if nf and (np.min(across) < 0 or np.max(across) >= nf or np.min(F) < 0 or np.max(F) >= nv):
        raise ValueError("polish_sums: a face or neighbour index is out of range")
    C_arr = np.zeros((nf, 3, 3))
    r_arr = np.zeros((nf, 3))
    own_arr = np.zeros((nf, 3))
    stand_arr = np.zeros((nf, 3))
    sq_arr = np.zeros(nv)
    ws_arr = np.zeros(nv)
    W_arr = np.zeros((m, 3))
    S_arr = np.zeros(m)
    cdef double[:, :, ::1] C = C_arr
    cdef double[:, ::1] R = r_arr
    cdef double[:, ::1] OWN = own_arr
    cdef double[:, ::1] STAND = stand_arr
    cdef double[::1] SQ = sq_arr
    cdef double[::1] WS = ws_arr
    cdef double[:, ::1] W = W_arr
    cdef double[::1] S = S_arr
    cdef double w[3]
    cdef double q[3]
    cdef double d2, best, total = 0.0, ss = 0.0, s, sw, rms, t, dl
    cdef int64_t f, g, kept = 0
    with nogil:
        for i in range(m):
            f = face[i]
            best = closest_on_triangle(&P[i, 0], &X[F[f, 0], 0], &X[F[f, 1], 0], &X[F[f, 2], 0], &W[i, 0])
            if local:
                for k in range(3):
                    g = across[f, k]
                    if g == f:
                        continue
                    d2 = closest_on_triangle(&P[i, 0], &X[F[g, 0], 0], &X[F[g, 1], 0], &X[F[g, 2], 0], w)
                    if d2 < best:
                        best = d2
                        face[i] = g
                        W[i, 0] = w[0]
                        W[i, 1] = w[1]
                        W[i, 2] = w[2]
                f = face[i]
            total += sqrt(best)
            if NF[f, 0] * NI[i, 0] + NF[f, 1] * NI[i, 1] + NF[f, 2] * NI[i, 2] <= 0.0:
                S[i] = NAN
                continue
            for k in range(3):
                q[k] = (W[i, 0] * X[F[f, 0], k] + W[i, 1] * X[F[f, 1], k] + W[i, 2] * X[F[f, 2], k]) - P[i, k]
            s = NF[f, 0] * q[0] + NF[f, 1] * q[1] + NF[f, 2] * q[2]
            S[i] = s
            ss += s * s
            kept += 1
        rms = sqrt(ss / kept) if kept else 0.0
        dl = floor * rms
        if rms > 0.0:
            for i in range(m):
                s = S[i]
                if s != s:             # left out (NaN)
                    continue
                f = face[i]
                sw = 1.0 / (fabs(s) if fabs(s) > dl else dl)
                t = NF[f, 0] * P[i, 0] + NF[f, 1] * P[i, 1] + NF[f, 2] * P[i, 2]
                for a in range(3):
                    STAND[f, a] += NI[i, a]
                    OWN[f, a] += sw * W[i, a]
                    R[f, a] += sw * W[i, a] * t
                    SQ[F[f, a]] += W[i, a] * s * s
                    WS[F[f, a]] += W[i, a]
                    for c in range(3):
                        C[f, a, c] += sw * W[i, a] * W[i, c]
    return (total / m if m else 0.0), C_arr, r_arr, own_arr, sq_arr, ws_arr, stand_arr, int(kept)
