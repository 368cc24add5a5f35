"""A one-line text progress bar: ``[#########...........]  45% 12345/27000``."""
from __future__ import annotations

import sys
import time

__all__ = ["Progress"]


class Progress:
    """Draw ``\\r[#####.....] 45% 12345/27000`` on ``stream``, at most ``max_rate`` times a second.

    total   : the count that means 100 % (values above it are shown as 100 %)
    enabled : when False every method does nothing, so callers need no ``if``
    stream  : where to draw (standard error by default, so piped output stays clean)

    ``update(done)`` takes the running total, not an increment. ``close()`` draws the
    final state and ends the line; it is safe to call twice. Usable as a context manager.
    """

    width = 30          # characters between the brackets
    max_rate = 10.0     # redraws per second; more is flicker and wasted terminal writes

    def __init__(self, total: int, enabled: bool = True, stream=None) -> None:
        self.total = max(int(total), 0)
        self.enabled = bool(enabled)
        self.stream = sys.stderr if stream is None else stream
        self.done = 0
        self._last_draw = -float("inf")
        self._closed = False

    def update(self, done: int) -> None:
        """Record that ``done`` units are finished; redraw if the last draw is old enough."""
        if not self.enabled or self._closed:
            return
        self.done = int(done)
        now = time.monotonic()
        if now - self._last_draw >= 1.0 / self.max_rate:
            self._last_draw = now
            self._draw()

    def close(self) -> None:
        """Draw the last state and end the line (once)."""
        if not self.enabled or self._closed:
            return
        self._closed = True
        self._draw()
        self._write("\n")

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def line(self) -> str:
        """The bar as text, without the leading carriage return."""
        shown = min(max(self.done, 0), self.total)
        fraction = shown / self.total if self.total else 1.0
        filled = int(round(fraction * self.width))
        bar = "#" * filled + "." * (self.width - filled)
        return f"[{bar}] {fraction * 100:3.0f}% {shown}/{self.total}"

    def _draw(self) -> None:
        self._write("\r" + self.line())

    def _write(self, text: str) -> None:
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError):
            # a closed or broken stream (e.g. stderr piped to a process that exited) must not
            # abort a simplification that is otherwise fine
            self.enabled = False
