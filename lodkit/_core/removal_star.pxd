# cython: language_level=3
"""A :c:type:`Star` over bare positions, for the removal kernels' ``evaluate_star`` test
helpers (schroeder_kernel, volume_kernel): one star of a point set handed to a kernel's
``evaluate`` without a half-edge mesh (``KernelMesh.he`` is NULL, no face slots)."""
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
