# cython: language_level=3
"""A guaranteed two-sided error bound for edge collapse (``simplify(error="hausdorff")``):
every collapse is accepted only if the mesh it leaves stays within ``eps`` of the original
surface O in both directions (docs/error-bound.md has the argument in full).

simplified -> original
    A static bounding-volume hierarchy over O's triangles (built once, here, without the
    GIL).  The distance to one triangle T is a convex function of the point, so on a
    triangle t its largest value is at a corner: if the three corners of t are within
    ``eps`` of one T, all of t is.  A new face is accepted if it, or each of the pieces of
    its midpoint subdivision (up to BOUND_MAX_DEPTH levels), is covered so -- or, for a
    piece t of covering radius h(t) (the farthest a point of t is from its nearest
    corner), if each corner is within ``eps - h(t)`` of O (triangle inequality).  A corner
    farther than ``eps`` from O refuses the collapse outright.

original -> simplified
    Sample points of O: each original triangle T carries the points of its regular grid of
    level n_T (its corners included), n_T the least that brings the grid's covering
    radius s_T = h(T) / n_T down to ``spacing * eps``.  Every point is attached to a face
    of the current mesh; a collapse re-attaches the points of the faces it changes to the
    nearest face of the new 1-ring and is refused if one would be farther than
    ``eps - s_T``: then every point of O is within ``eps`` of the mesh (its nearest grid
    point is within s_T of it).  While T's face is untouched its points lie on it.

Every face carries the distance it is certified for (``cert``: the larger of its own
distance to O found by the check and its points' distances plus their slack), so the
largest ``cert`` over the live faces bounds the two-sided Hausdorff distance, and a
collapse's record carries the largest of its new faces'.

Thread-safety (the pass driver's blocks): ``check`` only reads, except ``pending`` of the
faces of the collapse's fans; ``commit_*`` write only the faces of those fans, their points
and the kept vertex's ``last`` -- all inside the collapse's closed 1-rings.
"""
import numpy as np
cimport numpy as cnp
from libc.math cimport sqrt, ceil, INFINITY

from .halfedge cimport HalfEdgeMesh, he_prev, he_dest, he_ring_next
from .vec3 cimport point_triangle_sqdist

cnp.import_array()

cdef enum:
    LEAF_SIZE = 4


cdef inline double sq(double x) noexcept nogil:
    return x * x


cdef inline double tri_sqdist(const double* x, const double* t) noexcept nogil:
    """Squared distance from x to the triangle t (9 doubles): vec3.point_triangle_sqdist."""
    return point_triangle_sqdist(x, t, &t[3], &t[6])


cdef double covering_radius(const double* t) noexcept nogil:
    """The farthest a point of triangle t is from its nearest corner: the circumradius of an
    acute triangle, half the longest edge otherwise (the largest distance is then reached
    on the boundary, where each point is within half an edge of a corner); at most the
    longest edge over sqrt(3)."""
    cdef double la = 0.0, lb = 0.0, lc = 0.0, big, cr, r
    cdef double e1[3]
    cdef double e2[3]
    cdef int i
    for i in range(3):
        la += sq(t[6 + i] - t[3 + i])
        lb += sq(t[6 + i] - t[i])
        lc += sq(t[3 + i] - t[i])
        e1[i] = t[3 + i] - t[i]
        e2[i] = t[6 + i] - t[i]
    big = la if la > lb else lb
    if lc > big:
        big = lc
    if big >= la + lb + lc - big:               # right or obtuse
        return 0.5 * sqrt(big)
    cr = sqrt(sq(e1[1] * e2[2] - e1[2] * e2[1]) + sq(e1[2] * e2[0] - e1[0] * e2[2])
              + sq(e1[0] * e2[1] - e1[1] * e2[0]))
    if not (cr > 0.0):
        return 0.5 * sqrt(big)
    r = sqrt(la) * sqrt(lb) * sqrt(lc) / (2.0 * cr)
    # rounding: never report less than the (always valid) half edge nor more than L/sqrt(3)
    if r < 0.5 * sqrt(big):
        r = 0.5 * sqrt(big)
    return r


def triangle_covering_radius(t):
    """covering_radius for a (9,) array (tests)."""
    cdef double[::1] a = np.ascontiguousarray(t, dtype=np.float64).reshape(-1)
    return covering_radius(&a[0])


#: sample points Bound takes at most (about 36 bytes each): beyond, ValueError
MAX_POINTS = 20_000_000


def sample_original(double[:, ::1] tris, double spacing):
    """(points (k, 3), slack (k,), triangle (k,)): the grid points of each triangle of
    ``tris`` (n, 9) at the level that brings its covering radius to ``spacing`` at most,
    corners included; ``slack`` is the grid's covering radius.  ValueError when that takes
    more than MAX_POINTS points."""
    cdef int n = tris.shape[0], i, lev
    cdef double h
    levels = np.empty(n, dtype=np.int64)
    hs = np.empty(n, dtype=np.float64)
    cdef long[::1] L = levels
    cdef double[::1] H = hs
    for i in range(n):
        h = covering_radius(&tris[i, 0])
        H[i] = h
        lev = 1
        if spacing > 0.0 and h > spacing:
            lev = <int>min(ceil(h / spacing), 1e6)
        L[i] = lev
    total = int(((levels + 1) * (levels + 2) // 2).sum())
    if total > MAX_POINTS:
        raise ValueError(f"the error bound would sample the input with {total} points (at most {MAX_POINTS}): "
                         f"max_error is small next to the input's triangles; raise max_error or sample_spacing")
    tri_np = np.asarray(tris)
    out_p, out_s, out_t = [], [], []
    for lev in np.unique(levels):
        sel = np.flatnonzero(levels == lev)
        ii, jj = np.meshgrid(np.arange(lev + 1), np.arange(lev + 1), indexing="ij")
        keep = (ii + jj) <= lev
        bu = ii[keep].astype(np.float64) / lev
        bv = jj[keep].astype(np.float64) / lev
        a = tri_np[sel, 0:3]
        b = tri_np[sel, 3:6]
        c = tri_np[sel, 6:9]
        pts = (a[:, None, :] + bu[None, :, None] * (b - a)[:, None, :] + bv[None, :, None] * (c - a)[:, None, :])
        out_p.append(pts.reshape(-1, 3))
        out_s.append(np.repeat(hs[sel] / lev, bu.size))
        out_t.append(np.repeat(sel, bu.size))
    return (np.concatenate(out_p), np.concatenate(out_s), np.concatenate(out_t).astype(np.intc))


cdef class Bound:
    """The error-bound state of one run.

    hm      : the half-edge mesh (its live faces are the original O)
    vdata   : the collapser's per-vertex rows; the position starts at column ``offset``
    eps     : the bound, in the units of the positions
    spacing : the covering radius of the original's sample grids, as a fraction of eps
    """

    def __init__(self, HalfEdgeMesh hm, double[:, ::1] vdata, int offset, double eps, double spacing=0.25):
        if not (eps >= 0.0):
            raise ValueError("eps must be >= 0")
        if not (0.0 < spacing < 1.0):
            raise ValueError("spacing must be in (0, 1)")
        self.eps = eps
        self.eps2 = eps * eps
        self.m = &hm.c
        self.keep = (hm, vdata)
        self.stride = vdata.shape[1]
        self.P = &vdata[0, offset]
        pos = np.asarray(vdata)[:, offset:offset + 3]
        faces = np.flatnonzero(np.asarray(hm.alive_faces, dtype=bool)).astype(np.intc)
        corners = np.asarray(hm.corners)[faces]
        tris = np.ascontiguousarray(pos[corners].reshape(-1, 9))
        n_tri = tris.shape[0]
        # the sample points, attached to their own triangle's face slot
        pts, slack, owner = sample_original(tris, spacing * eps)
        self.pts = np.ascontiguousarray(pts)
        self.slack = slack
        n_faces = hm.n_faces
        order = np.argsort(owner, kind="stable")
        face_of = faces[owner[order]]
        nxt = np.full(order.size, -1, dtype=np.intc)
        same = face_of[1:] == face_of[:face_of.size - 1]
        nxt[order[:order.size - 1][same]] = order[1:][same]
        head = np.full(max(n_faces, 1), -1, dtype=np.intc)
        starts = np.ones(order.size, dtype=bool)
        starts[1:] = ~same
        head[face_of[starts]] = order[starts]
        self.nxt = nxt if nxt.size else np.full(1, -1, dtype=np.intc)
        self.head = head
        self.sphere = np.zeros((max(n_faces, 1), 5))
        self.cert = np.zeros(max(n_faces, 1))
        self.pending = np.zeros(max(n_faces, 1))
        self.last = np.zeros(max(hm.n_vertices, 1))
        cdef int f
        for f in faces:
            self.fit_sphere(f)
        # the BVH
        cap = max(2 * n_tri, 1)
        self.box = np.zeros((cap, 6))
        self.left = np.full(cap, -1, dtype=np.intc)
        self.first = np.zeros(cap, dtype=np.intc)
        self.count = np.zeros(cap, dtype=np.intc)
        idx = np.arange(n_tri, dtype=np.intc)
        cent = np.ascontiguousarray((tris[:, 0:3] + tris[:, 3:6] + tris[:, 6:9]) / 3.0)
        lo = np.minimum(np.minimum(tris[:, 0:3], tris[:, 3:6]), tris[:, 6:9])
        hi = np.maximum(np.maximum(tris[:, 0:3], tris[:, 3:6]), tris[:, 6:9])
        tb = np.ascontiguousarray(np.concatenate([lo, hi], axis=1))
        cdef int[::1] I = idx
        cdef double[:, ::1] C = cent
        cdef double[:, ::1] TB = tb
        cdef int nt = n_tri
        if nt > 0:
            with nogil:
                self.n_nodes = self.build(&I[0], &C[0, 0], &TB[0, 0], nt)
        else:
            self.n_nodes = 0
        self.tri = np.ascontiguousarray(tris[idx]) if n_tri else np.zeros((1, 9))

    cdef int build(self, int* idx, const double* cent, const double* tb, int n) noexcept nogil:
        """Top-down BVH: split at the median centroid along the longest axis of the
        centroids' box, leaves of LEAF_SIZE triangles at most; nodes in depth-first order,
        the two children of a node next to each other.  Returns the number of nodes."""
        cdef int stack_node[128]
        cdef int stack_lo[128]
        cdef int stack_hi[128]
        cdef int sp = 0, nn = 1, node, lo, hi, i, j, ax, mid
        cdef double clo[3]
        cdef double chi[3]
        cdef double ext, best
        if n == 0:
            return 0
        stack_node[0] = 0
        stack_lo[0] = 0
        stack_hi[0] = n
        sp = 1
        while sp > 0:
            sp -= 1
            node = stack_node[sp]
            lo = stack_lo[sp]
            hi = stack_hi[sp]
            for j in range(3):
                self.box[node, j] = INFINITY
                self.box[node, 3 + j] = -INFINITY
                clo[j] = INFINITY
                chi[j] = -INFINITY
            for i in range(lo, hi):
                for j in range(3):
                    if tb[6 * idx[i] + j] < self.box[node, j]:
                        self.box[node, j] = tb[6 * idx[i] + j]
                    if tb[6 * idx[i] + 3 + j] > self.box[node, 3 + j]:
                        self.box[node, 3 + j] = tb[6 * idx[i] + 3 + j]
                    if cent[3 * idx[i] + j] < clo[j]:
                        clo[j] = cent[3 * idx[i] + j]
                    if cent[3 * idx[i] + j] > chi[j]:
                        chi[j] = cent[3 * idx[i] + j]
            if hi - lo <= LEAF_SIZE or sp + 2 > 128:
                self.left[node] = -1
                self.first[node] = lo
                self.count[node] = hi - lo
                continue
            ax = 0
            best = chi[0] - clo[0]
            for j in range(1, 3):
                ext = chi[j] - clo[j]
                if ext > best:
                    best = ext
                    ax = j
            mid = (lo + hi) // 2
            select_nth(idx, cent, ax, lo, hi - 1, mid)
            self.left[node] = nn
            stack_node[sp] = nn
            stack_lo[sp] = lo
            stack_hi[sp] = mid
            stack_node[sp + 1] = nn + 1
            stack_lo[sp + 1] = mid
            stack_hi[sp + 1] = hi
            sp += 2
            nn += 2
        return nn

    # ------------------------------------------------------------- queries
    cdef double sqdist_box(self, int node, const double* x) noexcept nogil:
        cdef double d = 0.0, t
        cdef int j
        for j in range(3):
            t = self.box[node, j] - x[j]
            if t > 0.0:
                d += t * t
            else:
                t = x[j] - self.box[node, 3 + j]
                if t > 0.0:
                    d += t * t
        return d

    cdef bint within(self, const double* x, double d2) noexcept nogil:
        """Is x within sqrt(d2) of the original?"""
        return self.nearest2(x, d2) <= d2

    cdef double nearest2(self, const double* x, double stop2) noexcept nogil:
        """The squared distance from x to the original -- or, as soon as a triangle within
        ``stop2`` is found, that triangle's (an upper bound, <= stop2)."""
        cdef int stack[BOUND_STACK]
        cdef int sp = 1, node, i, a
        cdef double best = INFINITY, d, da, db
        if self.n_nodes == 0:
            return INFINITY
        stack[0] = 0
        while sp > 0:
            sp -= 1
            node = stack[sp]
            if self.sqdist_box(node, x) >= best:
                continue
            if self.left[node] < 0:
                for i in range(self.first[node], self.first[node] + self.count[node]):
                    d = tri_sqdist(x, &self.tri[i, 0])
                    if d < best:
                        best = d
                        if best <= stop2:
                            return best
                continue
            a = self.left[node]
            da = self.sqdist_box(a, x)
            db = self.sqdist_box(a + 1, x)
            if da <= db:               # the nearer child on top
                stack[sp] = a + 1
                stack[sp + 1] = a
            else:
                stack[sp] = a
                stack[sp + 1] = a + 1
            sp += 2
        return best

    cdef double cover2(self, const double* t, double best2) noexcept nogil:
        """min over original triangles T of max over t's corners of their squared distance
        to T, if that is at most ``best2``; else INFINITY."""
        cdef int stack[BOUND_STACK]
        cdef int sp = 1, node, i, c, a
        cdef double found = INFINITY, bound = best2, d, lb, v
        if self.n_nodes == 0:
            return INFINITY
        stack[0] = 0
        while sp > 0:
            sp -= 1
            node = stack[sp]
            lb = 0.0
            for c in range(3):
                d = self.sqdist_box(node, &t[3 * c])
                if d > lb:
                    lb = d
                    if lb > bound:
                        break
            if lb > bound:
                continue
            if self.left[node] < 0:
                for i in range(self.first[node], self.first[node] + self.count[node]):
                    v = 0.0
                    for c in range(3):
                        d = tri_sqdist(&t[3 * c], &self.tri[i, 0])
                        if d > v:
                            v = d
                            if v > bound:
                                break
                    if v <= bound:
                        bound = v
                        found = v
                continue
            a = self.left[node]
            # the child nearer the first corner on top
            if self.sqdist_box(a, t) <= self.sqdist_box(a + 1, t):
                stack[sp] = a + 1
                stack[sp + 1] = a
            else:
                stack[sp] = a
                stack[sp + 1] = a + 1
            sp += 2
        return found

    cdef double face_value(self, const double* t) noexcept nogil:
        """A certified upper bound (<= eps) on the distance of triangle ``t``'s points to
        the original, or -1 when none is found (a corner of a piece is farther than eps,
        or the subdivision ran out of levels).

        Each piece is accepted by one of two certificates: (a) one original triangle within
        eps of its three corners (convexity: then of all of it; exact, tried first on the
        face itself), (b) its corners within eps - h of the original, h its covering
        radius (the triangle inequality).  Otherwise it splits in four at its edges'
        midpoints.  The corners' distances go down to the pieces that share them."""
        cdef double st[9 * (3 * BOUND_MAX_DEPTH + 4)]
        cdef double du[3 * (3 * BOUND_MAX_DEPTH + 4)]   # the corners' squared distances (see nearest2)
        cdef int dep[3 * BOUND_MAX_DEPTH + 4]
        cdef double mid[9]
        cdef double dm[3]
        cdef double pd[3]
        cdef double* s
        cdef double* o
        cdef double* u
        cdef int n = 1, d, i, c
        cdef double worst2 = 0.0, b, hs, lim2, mx, v
        for i in range(9):
            st[i] = t[i]
        # the face's corners: the caller's p was found within eps; the others are vertices
        # of the current mesh (certified already) -- measured all the same
        for c in range(3):
            du[c] = self.nearest2(&t[3 * c], 0.0)
            if du[c] > self.eps2:
                return -1.0
        dep[0] = 0
        while n > 0:
            n -= 1
            s = &st[9 * n]
            u = &du[3 * n]
            d = dep[n]
            if d == 0:
                b = self.cover2(s, self.eps2)
                if b <= self.eps2:
                    if b > worst2:
                        worst2 = b
                    continue
            hs = covering_radius(s)
            mx = u[0]
            if u[1] > mx:
                mx = u[1]
            if u[2] > mx:
                mx = u[2]
            if hs < self.eps and mx <= sq(self.eps - hs):
                v = sq(sqrt(mx) + hs)
                if v > worst2:
                    worst2 = v
                continue
            if d > 0:
                b = self.cover2(s, self.eps2)
                if b <= self.eps2:
                    if b > worst2:
                        worst2 = b
                    continue
            if d >= BOUND_MAX_DEPTH:
                return -1.0
            for i in range(3):
                mid[i] = 0.5 * (s[i] + s[3 + i])           # ab
                mid[3 + i] = 0.5 * (s[3 + i] + s[6 + i])   # bc
                mid[6 + i] = 0.5 * (s[6 + i] + s[i])       # ca
            # the children's covering radius is half this one's: the distances they need
            lim2 = sq(self.eps - 0.5 * hs) if 0.5 * hs < self.eps else 0.0
            for c in range(3):
                dm[c] = self.nearest2(&mid[3 * c], lim2)
                if dm[c] > self.eps2:
                    return -1.0                       # a point of the face is too far
            pd[0] = u[0]
            pd[1] = u[1]
            pd[2] = u[2]
            # four children over slot n..n+3 (slot n is s itself: copy its corners first)
            o = &st[9 * (n + 1)]
            for i in range(3):
                o[i] = mid[i]                  # (ab, b, bc)
                o[3 + i] = s[3 + i]
                o[6 + i] = mid[3 + i]
                o[9 + i] = mid[6 + i]          # (ca, bc, c)
                o[12 + i] = mid[3 + i]
                o[15 + i] = s[6 + i]
                o[18 + i] = mid[i]             # (ab, bc, ca)
                o[21 + i] = mid[3 + i]
                o[24 + i] = mid[6 + i]
            for i in range(3):                 # (a, ab, ca) in place
                s[3 + i] = mid[i]
                s[6 + i] = mid[6 + i]
            u[1] = dm[0]
            u[2] = dm[2]
            du[3 * (n + 1)] = dm[0]
            du[3 * (n + 1) + 1] = pd[1]
            du[3 * (n + 1) + 2] = dm[1]
            du[3 * (n + 2)] = dm[2]
            du[3 * (n + 2) + 1] = dm[1]
            du[3 * (n + 2) + 2] = pd[2]
            du[3 * (n + 3)] = dm[0]
            du[3 * (n + 3) + 1] = dm[1]
            du[3 * (n + 3) + 2] = dm[2]
            for i in range(4):
                dep[n + i] = d + 1
            n += 4
        return sqrt(worst2)

    # ------------------------------------------------------------- a collapse
    cdef int collect(self, int center, int fa, int fb, const double* p, double* tris, int* fids,
                     int n) noexcept nogil:
        """Append the faces around ``center`` but fa, fb, with ``center`` at ``p``, to
        tris / fids from row n on; returns the new count, -1 past BOUND_MAX_FAN."""
        cdef int start = self.m.v_he[center]
        cdef int y = start
        cdef int f, b, c, i
        while True:
            f = y // 3
            if f != fa and f != fb:
                if n >= BOUND_MAX_FAN:
                    return -1
                b = he_dest(self.m, y)
                c = self.m.corner[he_prev(y)]
                for i in range(3):
                    tris[9 * n + i] = p[i]
                    tris[9 * n + 3 + i] = self.P[self.stride * b + i]
                    tris[9 * n + 6 + i] = self.P[self.stride * c + i]
                fids[n] = f
                n += 1
            y = he_ring_next(self.m, y)
            if y < 0 or y == start:
                return n

    cdef bint check(self, int h, int r, int k, const double* p) noexcept nogil:
        """May half-edge h collapse (``r`` goes, ``k`` moves to ``p``) and the mesh stay
        within eps of the original both ways?  Writes ``pending`` of the new faces."""
        cdef double tris[9 * BOUND_MAX_FAN]
        cdef int fids[BOUND_MAX_FAN]
        cdef int fa = h // 3
        cdef int fb = self.m.twin[h] // 3 if self.m.twin[h] >= 0 else -1
        cdef int n, i, pass_, center, start, y, f, q, own
        cdef double lim, lim2, v
        cdef bint ok
        if not self.within(p, self.eps2):
            return False
        n = self.collect(r, fa, fb, p, tris, fids, 0)
        if n < 0:
            return False
        n = self.collect(k, fa, fb, p, tris, fids, n)
        if n < 0:
            return False
        # original -> simplified: the points of every face the collapse changes, each within
        # eps - slack of a new face; a face whose ball of points lies so near one new face
        # passes whole
        for pass_ in range(2):
            center = r if pass_ == 0 else k
            start = self.m.v_he[center]
            y = start
            while True:
                f = y // 3
                q = self.head[f]
                if q >= 0 and (pass_ == 0 or (f != fa and f != fb)):
                    own = -1
                    ok = False
                    lim = self.eps - self.sphere[f, 3] - self.sphere[f, 4]
                    for i in range(n):
                        if fids[i] == f:
                            own = i
                        if not ok and lim >= 0.0 and tri_sqdist(&self.sphere[f, 0], &tris[9 * i]) <= lim * lim:
                            ok = True
                    while q >= 0 and not ok:
                        lim = self.eps - self.slack[q]
                        if lim < 0.0:
                            return False
                        lim2 = lim * lim
                        # the face the point is on, if it stays, first
                        if own < 0 or tri_sqdist(&self.pts[q, 0], &tris[9 * own]) > lim2:
                            for i in range(n):
                                if i != own and tri_sqdist(&self.pts[q, 0], &tris[9 * i]) <= lim2:
                                    break
                            else:
                                return False
                        q = self.nxt[q]
                y = he_ring_next(self.m, y)
                if y < 0 or y == start:
                    break
        # simplified -> original: every new face
        for i in range(n):
            v = self.face_value(&tris[9 * i])
            if v < 0.0:
                return False
            self.pending[fids[i]] = v
        return True

    cdef int commit_begin(self, int h, int r, int k) noexcept nogil:
        """Before collapsing h: detach the points of the faces around r and k into one
        chain (returned); those faces' certificates are redone by commit_end."""
        cdef int fa = h // 3
        cdef int fb = self.m.twin[h] // 3 if self.m.twin[h] >= 0 else -1
        cdef int chain = -1, pass_, center, start, y, f, q, nq
        for pass_ in range(2):
            center = r if pass_ == 0 else k
            start = self.m.v_he[center]
            y = start
            while True:
                f = y // 3
                if pass_ == 0 or (f != fa and f != fb):
                    q = self.head[f]
                    while q >= 0:
                        nq = self.nxt[q]
                        self.nxt[q] = chain
                        chain = q
                        q = nq
                    self.head[f] = -1
                    self.cert[f] = 0.0
                y = he_ring_next(self.m, y)
                if y < 0 or y == start:
                    break
        return chain

    cdef double commit_end(self, int k, int chain) noexcept nogil:
        """After the collapse (k at its new position): attach the chain's points to the
        nearest face around k, set those faces' certificates; returns the largest (the
        bound this collapse guarantees for what it changed), also kept in ``last[k]``."""
        cdef double tris[9 * BOUND_MAX_FAN]
        cdef int fids[BOUND_MAX_FAN]
        cdef int n, i, best, q, nq
        cdef double d, bd, v, worst = 0.0
        n = self.collect(k, -1, -1, &self.P[self.stride * k], tris, fids, 0)
        if n < 0:
            n = 0
        for i in range(n):
            self.cert[fids[i]] = self.pending[fids[i]]
        q = chain
        while q >= 0:
            nq = self.nxt[q]
            best = -1
            bd = INFINITY
            for i in range(n):
                d = tri_sqdist(&self.pts[q, 0], &tris[9 * i])
                if d < bd:
                    bd = d
                    best = i
            if best >= 0:
                self.nxt[q] = self.head[fids[best]]
                self.head[fids[best]] = q
                v = sqrt(bd) + self.slack[q]
                if v > self.cert[fids[best]]:
                    self.cert[fids[best]] = v
            q = nq
        for i in range(n):
            self.fit_sphere(fids[i])
            if self.cert[fids[i]] > worst:
                worst = self.cert[fids[i]]
        self.last[k] = worst
        return worst

    cdef void fit_sphere(self, int f) noexcept nogil:
        """sphere[f]: a ball around the points attached to f (their centroid, the farthest
        one's distance) and their largest slack."""
        cdef int q = self.head[f], cnt = 0, i
        cdef double c[3]
        cdef double r2 = 0.0, d, smax = 0.0
        c[0] = c[1] = c[2] = 0.0
        while q >= 0:
            for i in range(3):
                c[i] += self.pts[q, i]
            cnt += 1
            q = self.nxt[q]
        if cnt == 0:
            for i in range(5):
                self.sphere[f, i] = 0.0
            return
        for i in range(3):
            c[i] /= cnt
        q = self.head[f]
        while q >= 0:
            d = sq(self.pts[q, 0] - c[0]) + sq(self.pts[q, 1] - c[1]) + sq(self.pts[q, 2] - c[2])
            if d > r2:
                r2 = d
            if self.slack[q] > smax:
                smax = self.slack[q]
            q = self.nxt[q]
        for i in range(3):
            self.sphere[f, i] = c[i]
        # a hair more than the largest distance: rounding never lets a point out
        self.sphere[f, 3] = sqrt(r2) * (1.0 + 1e-12) + 1e-300
        self.sphere[f, 4] = smax

    # ------------------------------------------------------------- Python API
    @property
    def n_points(self):
        """Sample points of the original."""
        return self.pts.shape[0]

    @property
    def n_nodes_bvh(self):
        return self.n_nodes

    def bound(self, alive_faces):
        """The certified two-sided distance of the current mesh: the largest certificate of
        a live face (0 when nothing changed)."""
        c = np.asarray(self.cert)[:np.asarray(alive_faces).shape[0]]
        live = c[np.asarray(alive_faces, dtype=bool)]
        return float(live.max()) if live.size else 0.0

    def distance(self, x):
        """Distance from each point of x (k, 3) to the original (tests)."""
        cdef double[:, ::1] X = np.ascontiguousarray(x, dtype=np.float64).reshape(-1, 3)
        out = np.empty(X.shape[0])
        cdef int i
        for i in range(X.shape[0]):
            out[i] = sqrt(self.nearest2(&X[i, 0], -1.0))
        return out

    def face_distance(self, t):
        """face_value for one triangle (9,) (tests): its certified distance, or -1."""
        cdef double[::1] a = np.ascontiguousarray(t, dtype=np.float64).reshape(-1)
        return self.face_value(&a[0])


cdef void select_nth(int* idx, const double* cent, int ax, int lo, int hi, int k) noexcept nogil:
    """Partially sort idx[lo..hi] (inclusive) by centroid coordinate ``ax`` so that idx[k] is
    in place, the smaller before it, the larger after (Hoare's selection)."""
    cdef double pivot
    cdef int i, j, tmp
    while hi > lo:
        pivot = cent[3 * idx[(lo + hi) // 2] + ax]
        i = lo
        j = hi
        while i <= j:
            while cent[3 * idx[i] + ax] < pivot:
                i += 1
            while cent[3 * idx[j] + ax] > pivot:
                j -= 1
            if i <= j:
                tmp = idx[i]
                idx[i] = idx[j]
                idx[j] = tmp
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            return
