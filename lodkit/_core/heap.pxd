# cython: language_level=3
"""Indexed 4-ary min-heap over candidate ids 0..capacity-1.

Ordering is by (key, id), so equal keys pop in id order and runs are deterministic.
Keys live beside the ids in slot order, so the four children of a slot share a cache line.
All ``*_fast`` methods are nogil; the ones that can fail return -1 (``except -1``).
"""

cdef class IndexedHeap:
    cdef double[::1] _keys     # slot -> key
    cdef int[::1] _ids         # slot -> candidate id
    cdef int[::1] _pos         # candidate id -> slot, -1 when absent
    cdef double* hkey
    cdef int* hid
    cdef int* hpos
    cdef readonly int capacity
    cdef int size

    cdef void _sift_up(self, int slot, double key, int cid) noexcept nogil
    cdef void _sift_down(self, int slot, double key, int cid) noexcept nogil
    cdef int push_fast(self, int cid, double key) except -1 nogil
    cdef int pop_fast(self, int* cid, double* key) noexcept nogil
    cdef int remove_fast(self, int cid) except -1 nogil
    cdef inline bint contains_fast(self, int cid) noexcept nogil
    cdef double key_fast(self, int cid) noexcept nogil
    cdef void clear_fast(self) noexcept nogil
    cdef void append_unordered(self, int cid, double key) noexcept nogil
    cdef void heapify_fast(self) noexcept nogil
