"""Progress reports: a one-line text bar (``[#########...........]  45% 12345/27000``,
:class:`Progress`) or the caller's own function (:class:`ProgressCallback`); :func:`make_progress`
picks one from a ``progress=`` option.  The two are separate so the bar can be swapped for
another without touching the callback hook."""
from __future__ import annotations

import sys
import time

from .errors import Cancelled, OptionError

__all__ = ["Progress", "ProgressCallback", "make_progress"]


def make_progress(progress, total: int):
    """What a ``progress=`` option asks for: None (False / None: nothing), a :class:`Progress`
    bar on standard error (True) or a :class:`ProgressCallback` (a callable)."""
    if progress is None or progress is False:
        return None
    if progress is True:
        return Progress(total=total, enabled=True)
    if callable(progress):
        return ProgressCallback(progress, total)
    raise OptionError(f"progress must be True, False or a callable (done, total) -> bool | None, "
                      f"got {progress!r}")


class ProgressCallback:
    """Call ``fn(done, total)`` at each update (a few thousand operations apart) and once more
    at ``close()``.  ``fn`` returning ``False`` (exactly False: None and True go on) stops the
    run with :class:`lodkit.Cancelled`; an exception it raises goes through unchanged."""

    def __init__(self, fn, total: int) -> None:
        self.fn = fn
        self.total = max(int(total), 0)
        self.done = 0
        self._closed = False

    def update(self, done: int) -> None:
        if self._closed:
            return
        self.done = int(done)
        if self.fn(self.done, self.total) is False:
            self._closed = True
            raise Cancelled(f"cancelled by the progress callback at {self.done}/{self.total}")

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        self.fn(self.done, self.total)

    def __enter__(self) -> ProgressCallback:
        return self

    def __exit__(self, *exc) -> None:
        if exc[0] is None:
            self.close()


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
