# cython: language_level=3
"""Hole re-triangulation for vertex removal (cimported by removal kernels).

A hole is a polygon given as vertex slots ``loop[0..k-1]`` in order (oriented as the
surface: see removal.pxd).  Triangles are written as indices into ``loop``, three ints
each, oriented as the surface; a triangulation of a k-gon has k - 2 triangles.  Positions
are read at ``P[stride * slot + 0..2]``.  Nothing here allocates or touches Python.
"""

# Schroeder et al. 1992: split the loop recursively by a diagonal whose split plane
# (through the diagonal, orthogonal to the average plane with normal ``normal``) separates
# the two sub-loops; of the valid splits take the one with the best aspect ratio.
# ``force_a``/``force_b`` (indices into loop, or -1) name a diagonal that must be the first
# split (a feature edge through an interior-edge vertex).  Returns k - 2, or -1 when no valid
# triangulation exists (the vertex is then kept).  ``work`` is scratch of >= 6*k ints.
cdef int split_loop(const double* P, int stride, const int* loop, int k,
                    const double* normal, int force_a, int force_b,
                    int* tri, int* work) noexcept nogil

# split_loop with the smallest accepted aspect ratio of a split as a parameter (split_loop
# uses 0.04, vtkDecimate's 1/25); a forced pair that is a polygon edge is a one-sided split.
cdef int split_loop_aspect(const double* P, int stride, const int* loop, int k,
                           const double* normal, int force_a, int force_b, double min_aspect,
                           int* tri, int* work) noexcept nogil

# The fan from loop index ``apex``: triangles (apex, j, j+1) over every polygon edge not at
# apex.  Returns k - 2.
cdef int fan_from(int apex, int k, int* tri) noexcept nogil

# Chuon & Guha: of the lines through two distinct loop vertices, the one closest to point
# ``x``; its end nearer to ``x`` (index into loop) is returned, or -1 if k < 3.
cdef int closest_line_apex(const double* P, int stride, const int* loop, int k,
                           const double* x) noexcept nogil

# lodkit's addition for the removal kernels' default rule: the triangulation of the hole
# ``W`` (k x 3 positions, contiguous, in loop order) that minimises the volume between it and
# the cone of the removed vertex ``x`` (the sum of |det(a - x, b - x, c - x)| over its
# triangles), by dynamic programming over the polygon (O(k^3)); a triangle whose normal is
# not within 90 degrees of ``normal`` costs +inf (the driver would refuse it).  ``cost`` is
# scratch of >= k*k doubles, ``split`` of >= k*k ints.  Returns k - 2, or -1 when every
# triangulation has such a triangle.
cdef int min_volume_triangulation(const double* W, int k, const double* x, const double* normal,
                                  int* tri, double* cost, int* split) noexcept nogil

# lodkit's addition: of two candidate triangulations of the hole ``W`` (k x 3, contiguous) --
# the one already in ``tri`` if ``n_in`` > 0 (it wins ties), and the least-volume one above
# -- the one whose nearest triangle is nearest to the removed vertex ``x``, among those with
# no triangle at 90 degrees or more from ``normal``.  (The k fans as further candidates were
# measured and dropped: slower, and no nearer to the input.)  Writes it to ``tri`` and
# its distance to ``dist``; returns k - 2, or -1 when every candidate folds (``tri`` then
# unchanged).  ``cost`` (k*k doubles), ``split`` (k*k ints) and ``cand`` (3k ints) are scratch.
cdef int least_distance_patch(const double* W, int k, const double* x, const double* normal,
                              int* tri, int n_in, double* dist, double* cost, int* split,
                              int* cand) noexcept nogil
