"""IndexedHeap against a slow, obviously-correct reference (a dict and min()).

The reference orders entries by (key, id), the order the heap promises, so every pop and
peek has exactly one right answer, ties included.  ``heap.check()`` (heap order and the
position index) runs after every operation.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lodkit._core.heap import IndexedHeap

INF = math.inf


class RefHeap:
    """The specification: a dict id -> key; the minimum is min over (key, id)."""

    def __init__(self, capacity: int):
        self.capacity = capacity
        self.entries: dict[int, float] = {}

    def _smallest(self):
        cid = min(self.entries, key=lambda i: (self.entries[i], i))
        return cid, self.entries[cid]

    def push(self, cid, key):
        self.entries[cid] = key

    def pop(self):
        if not self.entries:
            raise IndexError
        cid, key = self._smallest()
        del self.entries[cid]
        return cid, key

    def peek(self):
        if not self.entries:
            raise IndexError
        return self._smallest()


# Few distinct keys so that ties (equal keys, +-0.0, infinities) are common.
keys = st.one_of(
    st.sampled_from([-INF, -1.0, -0.0, 0.0, 0.5, 1.0, 2.0, INF]),
    st.floats(allow_nan=False, min_value=-1e6, max_value=1e6),
)


@st.composite
def operation_sequences(draw):
    capacity = draw(st.integers(min_value=1, max_value=40))
    ids = st.integers(min_value=0, max_value=capacity - 1)
    op = st.one_of(
        st.tuples(st.just("push"), ids, keys),
        st.tuples(st.just("update"), ids, keys),
        st.tuples(st.just("remove"), ids),
        st.tuples(st.just("discard"), ids),
        st.tuples(st.just("pop")),
        st.tuples(st.just("peek")),
        st.tuples(st.just("key"), ids),
        st.tuples(st.just("contains"), ids),
        st.tuples(st.just("clear")),
        st.tuples(
            st.just("heapify"),
            st.lists(st.tuples(ids, keys), max_size=capacity, unique_by=lambda t: t[0]),
        ),
    )
    # pushes are weighted up so the heap actually fills
    pushes = st.tuples(st.just("push"), ids, keys)
    return capacity, draw(st.lists(st.one_of(pushes, pushes, op), max_size=120))


def assert_same(heap: IndexedHeap, ref: RefHeap) -> None:
    assert heap.check() is True
    assert len(heap) == len(ref.entries)
    for cid in range(ref.capacity):
        assert (cid in heap) == (cid in ref.entries)
        if cid in ref.entries:
            assert heap.key(cid) == ref.entries[cid]


@settings(max_examples=300, deadline=None)
@given(operation_sequences())
def test_matches_reference(case):
    capacity, ops = case
    heap, ref = IndexedHeap(capacity), RefHeap(capacity)
    for op in ops:
        name = op[0]
        if name == "push":
            heap.push(op[1], op[2])
            ref.push(op[1], op[2])
        elif name == "update":
            if op[1] in ref.entries:
                heap.update(op[1], op[2])
                ref.push(op[1], op[2])
            else:
                with pytest.raises(KeyError):
                    heap.update(op[1], op[2])
        elif name == "remove":
            if op[1] in ref.entries:
                heap.remove(op[1])
                del ref.entries[op[1]]
            else:
                with pytest.raises(KeyError):
                    heap.remove(op[1])
        elif name == "discard":
            heap.discard(op[1])
            ref.entries.pop(op[1], None)
        elif name in ("pop", "peek"):
            if ref.entries:
                got = getattr(heap, name)()
                want = getattr(ref, name)()
                assert got[0] == want[0]
                assert got[1] == want[1]
                # -0.0 and 0.0 tie, but the stored key must come back bit for bit
                assert math.copysign(1.0, got[1]) == math.copysign(1.0, want[1])
            else:
                with pytest.raises(IndexError):
                    getattr(heap, name)()
        elif name == "key":
            if op[1] in ref.entries:
                assert heap.key(op[1]) == ref.entries[op[1]]
            else:
                with pytest.raises(KeyError):
                    heap.key(op[1])
        elif name == "contains":
            assert (op[1] in heap) == (op[1] in ref.entries)
        elif name == "clear":
            heap.clear()
            ref.entries.clear()
        elif name == "heapify":
            pairs = op[1]
            heap.heapify([p[0] for p in pairs], [p[1] for p in pairs])
            ref.entries = dict(pairs)
        assert_same(heap, ref)
    # draining gives the whole content in (key, id) order
    drained = [heap.pop() for _ in range(len(heap))]
    assert drained == sorted(((c, k) for c, k in ref.entries.items()), key=lambda t: (t[1], t[0]))
    assert len(heap) == 0


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(allow_nan=False), min_size=1, max_size=200))
def test_heapify_then_drain_is_sorted(key_list):
    n = len(key_list)
    heap = IndexedHeap(n)
    ids = np.random.default_rng(n).permutation(n)
    heap.heapify(ids, [key_list[i] for i in ids])
    assert heap.check()
    out = [heap.pop() for _ in range(n)]
    assert out == sorted(((i, k) for i, k in enumerate(key_list)), key=lambda t: (t[1], t[0]))


def test_ties_pop_in_id_order():
    heap = IndexedHeap(10)
    for cid in [7, 3, 9, 0, 5, 1, 8, 2, 6, 4]:
        heap.push(cid, 1.0)
    assert [heap.pop()[0] for _ in range(10)] == list(range(10))


def test_ties_after_updates_pop_in_id_order():
    heap = IndexedHeap(6)
    for cid in range(6):
        heap.push(cid, float(10 - cid))    # 5 is smallest
    heap.update(4, 0.0)
    heap.push(1, 0.0)                      # push of a present id lowers its key
    heap.update(5, 0.0)
    heap.update(0, 0.0)
    assert heap.check()
    assert [heap.pop() for _ in range(6)] == [(0, 0.0), (1, 0.0), (4, 0.0), (5, 0.0), (3, 7.0), (2, 8.0)]


def test_push_existing_raises_and_lowers_key():
    heap = IndexedHeap(4)
    heap.push(0, 1.0)
    heap.push(1, 2.0)
    heap.push(2, 3.0)
    heap.push(0, 5.0)                      # raise: 0 goes to the back
    assert heap.peek() == (1, 2.0)
    heap.push(2, -1.0)                     # lower: 2 comes to the front
    assert heap.peek() == (2, -1.0)
    assert len(heap) == 3
    assert [heap.pop() for _ in range(3)] == [(2, -1.0), (1, 2.0), (0, 5.0)]


def test_infinite_keys_order():
    heap = IndexedHeap(4)
    heap.push(0, INF)
    heap.push(1, -INF)
    heap.push(2, 0.0)
    heap.push(3, INF)
    assert [heap.pop() for _ in range(4)] == [(1, -INF), (2, 0.0), (0, INF), (3, INF)]


# ---------------------------------------------------------------------- errors
def test_empty_pop_and_peek_raise_index_error():
    heap = IndexedHeap(3)
    with pytest.raises(IndexError):
        heap.pop()
    with pytest.raises(IndexError):
        heap.peek()
    heap.push(1, 0.0)
    assert heap.pop() == (1, 0.0)
    with pytest.raises(IndexError):
        heap.pop()


def test_absent_ids_raise_key_error():
    heap = IndexedHeap(5)
    heap.push(2, 1.0)
    with pytest.raises(KeyError):
        heap.update(3, 0.0)
    with pytest.raises(KeyError):
        heap.remove(3)
    with pytest.raises(KeyError):
        heap.key(3)
    heap.remove(2)
    with pytest.raises(KeyError):
        heap.remove(2)                     # removed twice
    heap.discard(2)                        # discard of an absent id is silent
    heap.discard(4)
    assert len(heap) == 0 and heap.check()


@pytest.mark.parametrize("cid", [-1, 5, 6, 1000])
def test_out_of_range_id_push_raises_value_error(cid):
    heap = IndexedHeap(5)
    heap.push(0, 1.0)
    with pytest.raises(ValueError, match=str(cid)):
        heap.push(cid, 1.0)
    assert cid not in heap
    assert len(heap) == 1 and heap.check()
    assert heap.peek() == (0, 1.0)


def test_nan_key_raises_value_error_and_changes_nothing():
    heap = IndexedHeap(3)
    heap.push(0, 1.0)
    with pytest.raises(ValueError, match="NaN"):
        heap.push(1, math.nan)
    assert 1 not in heap
    with pytest.raises(ValueError, match="NaN"):
        heap.push(0, math.nan)             # existing id: its key must stay as it was
    with pytest.raises(ValueError, match="NaN"):
        heap.update(0, math.nan)
    assert heap.key(0) == 1.0
    assert len(heap) == 1 and heap.check()


def test_negative_capacity_raises():
    with pytest.raises(ValueError, match="capacity"):
        IndexedHeap(-1)


def test_zero_capacity_heap():
    heap = IndexedHeap(0)
    assert len(heap) == 0
    assert 0 not in heap
    with pytest.raises(ValueError):
        heap.push(0, 1.0)
    with pytest.raises(IndexError):
        heap.pop()
    heap.heapify([], [])
    assert len(heap) == 0


@pytest.mark.parametrize(
    "ids, keys, message",
    [
        ([0, 1], [1.0], "length"),
        ([0, 5], [1.0, 2.0], "0..4"),
        ([-1, 0], [1.0, 2.0], "0..4"),
        ([1, 1], [1.0, 2.0], "distinct"),
        ([0, 1], [1.0, math.nan], "NaN"),
    ],
)
def test_bad_heapify_raises_and_keeps_content(ids, keys, message):
    heap = IndexedHeap(5)
    heap.push(3, 7.0)
    with pytest.raises(ValueError, match=message):
        heap.heapify(ids, keys)
    assert len(heap) == 1 and heap.key(3) == 7.0 and heap.check()


def test_heapify_replaces_content():
    heap = IndexedHeap(6)
    heap.push(0, -5.0)
    heap.push(5, 0.0)
    heap.heapify([4, 2, 3], [1.0, 1.0, 0.5])
    assert 0 not in heap and 5 not in heap
    assert [heap.pop() for _ in range(3)] == [(3, 0.5), (2, 1.0), (4, 1.0)]   # exact: the keys as pushed
    heap.push(0, 2.0)                      # still usable after draining
    assert heap.pop() == (0, 2.0)


def test_heapify_with_nothing_leaves_an_empty_heap():
    # An empty bulk load must not mark the stale id in slot 0 as present: with C division
    # (size - 2) // 4 is 0, not -1, for size 0, so slot 0 would be "sifted" into place.
    heap = IndexedHeap(3)
    heap.push(2, 1.0)
    assert heap.pop() == (2, 1.0)
    heap.heapify([], [])
    assert 2 not in heap
    assert len(heap) == 0
    with pytest.raises(KeyError):
        heap.remove(2)
    assert len(heap) == 0 and heap.check()
    with pytest.raises(IndexError):
        heap.pop()
