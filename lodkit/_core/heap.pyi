"""Type stubs for lodkit._core.heap (Cython)."""
from collections.abc import Iterable

class IndexedHeap:
    """Indexed 4-ary min-heap of candidate ids 0..capacity-1, ordered by (key, id)."""

    capacity: int
    def __init__(self, capacity: int) -> None: ...
    def push(self, cid: int, key: float) -> None:
        """Insert ``cid`` or change its key (raise or lower)."""
    def update(self, cid: int, key: float) -> None:
        """Change the key of a present ``cid``; KeyError if absent."""
    def pop(self) -> tuple[int, float]:
        """Remove and return the smallest ``(id, key)``; IndexError when empty."""
    def peek(self) -> tuple[int, float]: ...
    def remove(self, cid: int) -> None:
        """Remove a present ``cid``; KeyError if absent."""
    def discard(self, cid: int) -> None: ...
    def key(self, cid: int) -> float: ...
    def heapify(self, ids: Iterable[int], keys: Iterable[float]) -> None:
        """Replace the content in O(n)."""
    def clear(self) -> None: ...
    def check(self) -> bool:
        """Verify the heap invariants; AssertionError if broken."""
    def __len__(self) -> int: ...
    def __contains__(self, cid: object) -> bool: ...
