# cython: language_level=3
"""Indexed 4-ary min-heap: push, pop, update (raise or lower) and remove by id in O(log n)."""
import numpy as np


cdef inline bint before(double ka, int a, double kb, int b) noexcept nogil:
    return ka < kb or (ka == kb and a < b)


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
        self._keys = np.zeros(max(capacity, 1), dtype=np.float64)
        self._ids = np.zeros(max(capacity, 1), dtype=np.intc)
        self._pos = np.full(max(capacity, 1), -1, dtype=np.intc)
        self.hkey = &self._keys[0]
        self.hid = &self._ids[0]
        self.hpos = &self._pos[0]

    cdef void _sift_up(self, int slot, double key, int cid) noexcept nogil:
        """Place (key, cid) at ``slot`` or above it."""
        cdef int parent
        while slot > 0:
            parent = (slot - 1) >> 2
            if not before(key, cid, self.hkey[parent], self.hid[parent]):
                break
            self.hkey[slot] = self.hkey[parent]
            self.hid[slot] = self.hid[parent]
            self.hpos[self.hid[slot]] = slot
            slot = parent
        self.hkey[slot] = key
        self.hid[slot] = cid
        self.hpos[cid] = slot

    cdef void _sift_down(self, int slot, double key, int cid) noexcept nogil:
        """Place (key, cid) at ``slot`` or below it."""
        cdef int first, best, c, last
        cdef int n = self.size
        while True:
            first = 4 * slot + 1
            if first >= n:
                break
            best = first
            last = first + 4 if first + 4 < n else n
            for c in range(first + 1, last):
                if before(self.hkey[c], self.hid[c], self.hkey[best], self.hid[best]):
                    best = c
            if not before(self.hkey[best], self.hid[best], key, cid):
                break
            self.hkey[slot] = self.hkey[best]
            self.hid[slot] = self.hid[best]
            self.hpos[self.hid[slot]] = slot
            slot = best
        self.hkey[slot] = key
        self.hid[slot] = cid
        self.hpos[cid] = slot

    cdef int push_fast(self, int cid, double key) except -1 nogil:
        """Insert ``cid`` or move it to ``key``. -1 (with ValueError) if cid is out of range."""
        cdef int slot
        if cid < 0 or cid >= self.capacity:
            with gil:
                raise ValueError(f"candidate id {cid} outside 0..{self.capacity - 1}")
        if key != key:
            with gil:
                raise ValueError(f"key of candidate {cid} is NaN")
        slot = self.hpos[cid]
        if slot < 0:
            self.size += 1
            self._sift_up(self.size - 1, key, cid)
        elif before(key, cid, self.hkey[slot], cid):
            self._sift_up(slot, key, cid)
        else:
            self._sift_down(slot, key, cid)
        return 0

    cdef int pop_fast(self, int* cid, double* key) noexcept nogil:
        """Take the smallest entry; returns 0, or -1 when the heap is empty."""
        if self.size == 0:
            return -1
        cid[0] = self.hid[0]
        key[0] = self.hkey[0]
        self.hpos[cid[0]] = -1
        self.size -= 1
        if self.size > 0:
            self._sift_down(0, self.hkey[self.size], self.hid[self.size])
        return 0

    cdef int remove_fast(self, int cid) except -1 nogil:
        """Remove ``cid`` if present (absent ids are ignored). -1 if out of range."""
        cdef int slot, last_id
        cdef double last_key
        if cid < 0 or cid >= self.capacity:
            with gil:
                raise ValueError(f"candidate id {cid} outside 0..{self.capacity - 1}")
        slot = self.hpos[cid]
        if slot < 0:
            return 0
        self.hpos[cid] = -1
        self.size -= 1
        if slot == self.size:
            return 0
        last_key = self.hkey[self.size]
        last_id = self.hid[self.size]
        if slot > 0 and before(last_key, last_id, self.hkey[(slot - 1) >> 2], self.hid[(slot - 1) >> 2]):
            self._sift_up(slot, last_key, last_id)
        else:
            self._sift_down(slot, last_key, last_id)
        return 0

    cdef inline bint contains_fast(self, int cid) noexcept nogil:
        return 0 <= cid < self.capacity and self.hpos[cid] >= 0

    cdef double key_fast(self, int cid) noexcept nogil:
        """The key of ``cid``; only meaningful when ``contains_fast(cid)``."""
        return self.hkey[self.hpos[cid]]

    cdef void clear_fast(self) noexcept nogil:
        cdef int i
        for i in range(self.size):
            self.hpos[self.hid[i]] = -1
        self.size = 0

    cdef void append_unordered(self, int cid, double key) noexcept nogil:
        """Bulk loading: add ``cid`` (in range, not present) without ordering; call
        ``heapify_fast`` before any other operation."""
        self.hkey[self.size] = key
        self.hid[self.size] = cid
        self.hpos[cid] = self.size
        self.size += 1

    cdef void heapify_fast(self) noexcept nogil:
        """Restore the heap order after bulk loading, in O(n)."""
        cdef int slot
        if self.size < 2:
            return          # (and C division would round (size - 2) / 4 towards zero)
        for slot in range((self.size - 2) // 4, -1, -1):
            self._sift_down(slot, self.hkey[slot], self.hid[slot])

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
        return self.hid[0], self.hkey[0]

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
        return self.key_fast(cid)

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
        """Remove every entry."""
        self.clear_fast()

    def __len__(self):
        return self.size

    def __contains__(self, cid):
        return self.contains_fast(<int>cid)

    def check(self):
        """Verify the heap order and the position index (for tests); raises AssertionError."""
        cdef int i, parent
        for i in range(self.size):
            if self.hpos[self.hid[i]] != i:
                raise AssertionError(f"pos[{self.hid[i]}] != {i}")
            if i > 0:
                parent = (i - 1) >> 2
                if before(self.hkey[i], self.hid[i], self.hkey[parent], self.hid[parent]):
                    raise AssertionError(f"heap order broken at slot {i}")
        return True
