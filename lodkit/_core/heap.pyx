# cython: language_level=3
"""Indexed binary min-heap: push, pop, update (raise or lower) and remove by id in O(log n)."""
import numpy as np

cdef class IndexedHeap:
    """Min-heap of candidate ids ``0..capacity-1`` keyed by a float.

    ``push(id, key)`` inserts, or changes the key of an id already present (raise or lower).
    Ties are broken by id, so the pop order is fully determined by the keys.
    """

    def __cinit__(self, int capacity):
        if capacity < 0:
            raise ValueError(f"capacity must be >= 0, got {capacity}")
        self.capacity = capacity
        self.size = 0
        self.keys = np.zeros(max(capacity, 1), dtype=np.float64)
        self.heap = np.zeros(max(capacity, 1), dtype=np.intc)
        self.pos = np.full(max(capacity, 1), -1, dtype=np.intc)

    cdef inline bint _less(self, int a, int b) noexcept nogil:
        cdef double ka = self.keys[a]
        cdef double kb = self.keys[b]
        return ka < kb or (ka == kb and a < b)

    cdef void _sift_up(self, int slot) noexcept nogil:
        cdef int cid = self.heap[slot]
        cdef int parent
        while slot > 0:
            parent = (slot - 1) >> 1
            if not self._less(cid, self.heap[parent]):
                break
            self.heap[slot] = self.heap[parent]
            self.pos[self.heap[slot]] = slot
            slot = parent
        self.heap[slot] = cid
        self.pos[cid] = slot

    cdef void _sift_down(self, int slot) noexcept nogil:
        cdef int cid = self.heap[slot]
        cdef int child
        cdef int n = self.size
        while True:
            child = 2 * slot + 1
            if child >= n:
                break
            if child + 1 < n and self._less(self.heap[child + 1], self.heap[child]):
                child += 1
            if not self._less(self.heap[child], cid):
                break
            self.heap[slot] = self.heap[child]
            self.pos[self.heap[slot]] = slot
            slot = child
        self.heap[slot] = cid
        self.pos[cid] = slot

    cdef int push_fast(self, int cid, double key) except -1 nogil:
        """Insert ``cid`` or move it to ``key``. -1 (with ValueError) if cid is out of range."""
        cdef int slot
        cdef double old
        if cid < 0 or cid >= self.capacity:
            with gil:
                raise ValueError(f"candidate id {cid} outside 0..{self.capacity - 1}")
        if key != key:
            with gil:
                raise ValueError(f"key of candidate {cid} is NaN")
        slot = self.pos[cid]
        if slot < 0:
            self.keys[cid] = key
            slot = self.size
            self.size += 1
            self.heap[slot] = cid
            self.pos[cid] = slot
            self._sift_up(slot)
        else:
            old = self.keys[cid]
            self.keys[cid] = key
            if key < old:
                self._sift_up(slot)
            elif key > old:
                self._sift_down(slot)
        return 0

    cdef int pop_fast(self, int* cid, double* key) noexcept nogil:
        """Take the smallest entry; returns 0, or -1 when the heap is empty."""
        if self.size == 0:
            return -1
        cid[0] = self.heap[0]
        key[0] = self.keys[cid[0]]
        self.pos[cid[0]] = -1
        self.size -= 1
        if self.size > 0:
            self.heap[0] = self.heap[self.size]
            self.pos[self.heap[0]] = 0
            self._sift_down(0)
        return 0

    cdef int remove_fast(self, int cid) except -1 nogil:
        """Remove ``cid`` if present (absent ids are ignored). -1 if out of range."""
        cdef int slot, last
        if cid < 0 or cid >= self.capacity:
            with gil:
                raise ValueError(f"candidate id {cid} outside 0..{self.capacity - 1}")
        slot = self.pos[cid]
        if slot < 0:
            return 0
        self.pos[cid] = -1
        self.size -= 1
        if slot == self.size:
            return 0
        last = self.heap[self.size]
        self.heap[slot] = last
        self.pos[last] = slot
        if slot > 0 and self._less(last, self.heap[(slot - 1) >> 1]):
            self._sift_up(slot)
        else:
            self._sift_down(slot)
        return 0

    cdef inline bint contains_fast(self, int cid) noexcept nogil:
        return 0 <= cid < self.capacity and self.pos[cid] >= 0

    cdef void clear_fast(self) noexcept nogil:
        cdef int i
        for i in range(self.size):
            self.pos[self.heap[i]] = -1
        self.size = 0

    cdef void append_unordered(self, int cid, double key) noexcept nogil:
        """Bulk loading: add ``cid`` (in range, not present) without ordering; call
        ``heapify_fast`` before any other operation."""
        self.keys[cid] = key
        self.heap[self.size] = cid
        self.pos[cid] = self.size
        self.size += 1

    cdef void heapify_fast(self) noexcept nogil:
        """Restore the heap order after bulk loading, in O(n)."""
        cdef int slot
        for slot in range(self.size // 2 - 1, -1, -1):
            self._sift_down(slot)

    # ------------------------------------------------------------- Python API
    def push(self, int cid, double key):
        """Insert ``cid`` with ``key``, or change its key if it is already in the heap."""
        self.push_fast(cid, key)

    def update(self, int cid, double key):
        """Change the key of ``cid`` (raise or lower); KeyError if it is not in the heap."""
        if not self.contains_fast(cid):
            raise KeyError(cid)
        self.push_fast(cid, key)

    def pop(self):
        """Remove and return ``(id, key)`` of the smallest entry; IndexError when empty."""
        cdef int cid
        cdef double key
        if self.pop_fast(&cid, &key) < 0:
            raise IndexError("pop from an empty heap")
        return cid, key

    def peek(self):
        """``(id, key)`` of the smallest entry without removing it; IndexError when empty."""
        if self.size == 0:
            raise IndexError("peek at an empty heap")
        return self.heap[0], self.keys[self.heap[0]]

    def remove(self, int cid):
        """Remove ``cid``; KeyError if it is not in the heap."""
        if not self.contains_fast(cid):
            raise KeyError(cid)
        self.remove_fast(cid)

    def discard(self, int cid):
        """Remove ``cid`` if it is in the heap."""
        if self.contains_fast(cid):
            self.remove_fast(cid)

    def key(self, int cid):
        """The key of ``cid``; KeyError if it is not in the heap."""
        if not self.contains_fast(cid):
            raise KeyError(cid)
        return self.keys[cid]

    def heapify(self, ids, keys):
        """Replace the content with ``ids`` (distinct, in range) and their ``keys``, in O(n)."""
        ids_a = np.ascontiguousarray(ids, dtype=np.intc)
        keys_a = np.ascontiguousarray(keys, dtype=np.float64)
        if ids_a.shape[0] != keys_a.shape[0]:
            raise ValueError("ids and keys differ in length")
        if ids_a.size and (ids_a.min() < 0 or ids_a.max() >= self.capacity):
            raise ValueError(f"candidate ids must be in 0..{self.capacity - 1}")
        if np.unique(ids_a).size != ids_a.size:
            raise ValueError("candidate ids must be distinct")
        if np.isnan(keys_a).any():
            raise ValueError("keys must not be NaN")
        self.clear_fast()
        cdef int i
        for i in range(ids_a.shape[0]):
            self.append_unordered(ids_a[i], keys_a[i])
        self.heapify_fast()

    def clear(self):
        self.clear_fast()

    def __len__(self):
        return self.size

    def __contains__(self, cid):
        return self.contains_fast(<int>cid)

    def check(self):
        """Verify the heap invariant and the position index (for tests); raises AssertionError."""
        cdef int i
        for i in range(self.size):
            if self.pos[self.heap[i]] != i:
                raise AssertionError(f"pos[{self.heap[i]}] != {i}")
            if i > 0 and self._less(self.heap[i], self.heap[(i - 1) >> 1]):
                raise AssertionError(f"heap order broken at slot {i}")
        return True
