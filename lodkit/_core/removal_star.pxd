# cython: language_level=3
"""A :c:type:`Star` over bare positions, for the removal kernels' ``evaluate_star`` test
helpers (schroeder_kernel, volume_kernel): one star of a point set handed to a kernel's
``evaluate`` without a half-edge mesh (``KernelMesh.he`` is NULL, no face slots); and the
distance of a removed vertex to the patch that replaces its star (their accumulated
bounds)."""
from libc.math cimport sqrt

from lodkit.kernel cimport KernelMesh
from lodkit.removal cimport Star


cdef inline void star_on_points(KernelMesh* mesh, Star* star, const double* positions, int n_vertices,
                                const unsigned char* flags, int v, const int* link, int k,
                                bint closed) noexcept nogil:
    """Fill ``mesh`` (positions with stride 3, ``flags`` or NULL) and ``star`` (vertex ``v``,
    its ``k`` link vertices in order, closed or open; ``k`` <= MAX_VALENCE, checked by the
    caller; face slots -1)."""
    cdef int i
    mesh.he = NULL
    mesh.positions = positions
    mesh.stride = 3
    mesh.flags = flags
    mesh.n_vertices = n_vertices
    mesh.n_faces = 0
    star.mesh = mesh
    star.v = v
    star.k = k
    star.closed = 1 if closed else 0
    for i in range(k):
        star.link[i] = link[i]
        star.face[i] = -1


cdef inline double point_triangle_dist2(const double* p, const double* a, const double* b,
                                        const double* c) noexcept nogil:
    """The squared distance of p to the triangle abc (Ericson, *Real-Time Collision
    Detection* 5.1.5); a degenerate triangle gives the distance to its nearest edge point
    or corner."""
    cdef double ab[3]
    cdef double ac[3]
    cdef double ap[3]
    cdef double bp[3]
    cdef double cp[3]
    cdef double q[3]
    cdef double d1, d2, d3, d4, d5, d6, va, vb, vc, t, denom, v, w
    cdef int i
    for i in range(3):
        ab[i] = b[i] - a[i]
        ac[i] = c[i] - a[i]
        ap[i] = p[i] - a[i]
        bp[i] = p[i] - b[i]
        cp[i] = p[i] - c[i]
    d1 = ab[0] * ap[0] + ab[1] * ap[1] + ab[2] * ap[2]
    d2 = ac[0] * ap[0] + ac[1] * ap[1] + ac[2] * ap[2]
    d3 = ab[0] * bp[0] + ab[1] * bp[1] + ab[2] * bp[2]
    d4 = ac[0] * bp[0] + ac[1] * bp[1] + ac[2] * bp[2]
    d5 = ab[0] * cp[0] + ab[1] * cp[1] + ab[2] * cp[2]
    d6 = ac[0] * cp[0] + ac[1] * cp[1] + ac[2] * cp[2]
    vc = d1 * d4 - d3 * d2
    vb = d5 * d2 - d1 * d6
    va = d3 * d6 - d5 * d4
    if d1 <= 0.0 and d2 <= 0.0:
        for i in range(3):
            q[i] = a[i]
    elif d3 >= 0.0 and d4 <= d3:
        for i in range(3):
            q[i] = b[i]
    elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0 and d1 - d3 != 0.0:
        t = d1 / (d1 - d3)
        for i in range(3):
            q[i] = a[i] + t * ab[i]
    elif d6 >= 0.0 and d5 <= d6:
        for i in range(3):
            q[i] = c[i]
    elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0 and d2 - d6 != 0.0:
        t = d2 / (d2 - d6)
        for i in range(3):
            q[i] = a[i] + t * ac[i]
    elif va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0 and (d4 - d3) + (d5 - d6) != 0.0:
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        for i in range(3):
            q[i] = b[i] + t * (c[i] - b[i])
    else:
        denom = va + vb + vc
        if denom != 0.0:
            v = vb / denom
            w = vc / denom
            for i in range(3):
                q[i] = a[i] + v * ab[i] + w * ac[i]
        else:                               # degenerate and no edge case fired: corner a
            for i in range(3):
                q[i] = a[i]
    return (p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2 + (p[2] - q[2]) ** 2


cdef inline double _nearest_tri2(const double* positions, int stride, const double* x, const int* link,
                                 const int* tri, int n_tris, double floor) noexcept nogil:
    """The squared distance of x to its nearest triangle of ``tri`` (-1 with none), or some
    value <= ``floor`` as soon as one triangle is that near (the caller keeps a maximum that
    such a point cannot raise; a negative floor: the nearest)."""
    cdef int t
    cdef double d2, best = -1.0
    for t in range(n_tris):
        d2 = point_triangle_dist2(x, &positions[stride * link[tri[3 * t]]],
                                  &positions[stride * link[tri[3 * t + 1]]],
                                  &positions[stride * link[tri[3 * t + 2]]])
        if best < 0.0 or d2 < best:
            best = d2
            if best <= floor:
                break
    return best


cdef inline double patch_distance(const double* positions, int stride, const double* p, const int* link,
                                  const int* tri, int n_tris) noexcept nogil:
    """The distance of p to the nearest of the ``n_tris`` triangles ``tri`` (indices into
    ``link``, whose entries index ``positions``): how far a removed vertex lies from the
    patch that replaces its star (0 when there is no triangle)."""
    cdef double best = _nearest_tri2(positions, stride, p, link, tri, n_tris, -1.0)
    return sqrt(best) if best > 0.0 else 0.0


# ---- the removed points each face stands for (accumulate="points") ------------------------
# The points are the vertex slots (q < nv, at ``positions``) and the input faces' centroids
# (q = nv + f, at ``cent[3 f]``).  ``fhead[f]`` is the first point whose nearest face, when it
# was last placed, was face slot f (-1 if none); ``nxt[q]`` the next one after q.  At the
# start each face holds its own centroid (distance 0); a vertex joins when it is removed.  A removal is costed
# by how far v and the removed vertices of its star's faces lie from the patch that would
# replace the star -- the only ones whose face changes -- and hands them, in ``commit``, to
# the nearest face of the new patch.  A removed vertex then always lies within the
# recorded distance of its face, so the largest recorded distance bounds how far any input
# vertex lies from the output.

cdef inline const double* carried_point(const double* positions, int stride, const double* cent,
                                        int nv, int q) noexcept nogil:
    return &positions[stride * q] if q < nv else &cent[3 * (q - nv)]


cdef inline double carried_distance(const double* positions, int stride, const Star* s,
                                    const int* tri, int n_tris, const int* fhead,
                                    const int* nxt, const double* cent, int nv) noexcept nogil:
    """The largest distance of s.v, and of the removed vertices of its star's faces, to the
    patch ``tri`` (indices into ``s.link``) that would replace the star (0 with no
    triangle)."""
    cdef int i, f, q, nf = s.k if s.closed else s.k - 1
    cdef double d2, worst
    if n_tris <= 0:
        return 0.0
    worst = _nearest_tri2(positions, stride, &positions[stride * s.v], s.link, tri, n_tris, -1.0)
    for i in range(nf):
        f = s.face[i]
        if f < 0:
            continue
        q = fhead[f]
        while q >= 0:
            d2 = _nearest_tri2(positions, stride, carried_point(positions, stride, cent, nv, q),
                               s.link, tri, n_tris, worst)
            if d2 > worst:
                worst = d2
            q = nxt[q]
    return sqrt(worst) if worst > 0.0 else 0.0


cdef inline void carry_points(const double* positions, int stride, const Star* s,
                              int* fhead, int* nxt, const double* cent, int nv) noexcept nogil:
    """After the star of s.v was replaced (its face slots hold the new triangles or are
    dead): hand s.v and the removed vertices of the old faces to the nearest live face slot
    of the star.  Needs the half-edge arrays (``s.mesh.he``); without them, nothing."""
    cdef int i, f, q, nq, bf, nf = s.k if s.closed else s.k - 1
    cdef int todo = -1
    cdef double d2, best
    cdef const double* x
    cdef const int* corner
    if s.mesh == NULL or s.mesh.he == NULL:
        return
    corner = s.mesh.he.corner
    # one list of everything to place: s.v, then each old face's list
    nxt[s.v] = -1
    todo = s.v
    for i in range(nf):
        f = s.face[i]
        if f < 0:
            continue
        q = fhead[f]
        fhead[f] = -1
        while q >= 0:
            nq = nxt[q]
            nxt[q] = todo
            todo = q
            q = nq
    q = todo
    while q >= 0:
        nq = nxt[q]
        x = carried_point(positions, stride, cent, nv, q)
        best = -1.0
        bf = -1
        for i in range(nf):
            f = s.face[i]
            if f < 0 or not s.mesh.he.face_alive[f]:
                continue
            d2 = point_triangle_dist2(x, &positions[stride * corner[3 * f]],
                                      &positions[stride * corner[3 * f + 1]],
                                      &positions[stride * corner[3 * f + 2]])
            if best < 0.0 or d2 < best:
                best = d2
                bf = f
        if bf >= 0:
            nxt[q] = fhead[bf]
            fhead[bf] = q
        q = nq
