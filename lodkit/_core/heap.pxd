# cython: language_level=3
"""Indexed binary min-heap over candidate ids 0..capacity-1.

Ordering is by (key, id), so equal keys pop in id order and runs are deterministic.
All ``*_fast`` methods are nogil; the ones that can fail return -1 (``except -1``).
"""

cdef class IndexedHeap:
    cdef double[::1] keys      # key of each candidate id (valid while in the heap)
    cdef int[::1] heap         # heap slot -> candidate id
    cdef int[::1] pos          # candidate id -> heap slot, -1 when absent
    cdef readonly int capacity
    cdef int size

    cdef inline bint _less(self, int a, int b) noexcept nogil
    cdef void _sift_up(self, int slot) noexcept nogil
    cdef void _sift_down(self, int slot) noexcept nogil
    cdef int push_fast(self, int cid, double key) except -1 nogil
    cdef int pop_fast(self, int* cid, double* key) noexcept nogil
    cdef int remove_fast(self, int cid) except -1 nogil
    cdef inline bint contains_fast(self, int cid) noexcept nogil
    cdef void clear_fast(self) noexcept nogil
    cdef void append_unordered(self, int cid, double key) noexcept nogil
    cdef void heapify_fast(self) noexcept nogil
