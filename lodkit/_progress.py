"""Progress reports of a long run: a tqdm bar (rate, time left; a widget in notebooks), or
the caller's own function.

:func:`make` turns the public ``progress=`` option into a reporter or None:

- False / None: no reports (None, so callers skip the work of counting)
- True (or another true value): a :class:`Progress` bar on standard error (:mod:`tqdm`)
- a callable: :class:`Callback`, which calls it with ``(done, total)``; returning False
  cancels the run (:class:`lodkit.Cancelled`)

Whether a bar is wanted at all is the caller's decision: the CLI asks for one only when
standard error is a terminal (``lodkit.cli``), so piped and logged output stays clean.
Every reporter has ``update(done)`` (the running total, not an increment) and ``close()``
(safe to call twice) and is a context manager.
"""
from __future__ import annotations

import sys
from collections.abc import Callable

import numpy as np

from .errors import Cancelled, OptionError

__all__ = ["Progress", "Callback", "make"]


class Progress:
    """A tqdm progress bar of ``total`` units on ``stream`` (standard error by default).

    total   : the count that means 100 % (values above it are shown as 100 %)
    enabled : when False every method does nothing, so callers need no ``if``
    stream  : where to draw; the default (None) lets :mod:`tqdm.auto` pick a notebook
              widget inside Jupyter and a text bar on standard error elsewhere
    unit    : the name of a unit in the rate ("faces/s")

    tqdm redraws at most every ``min_interval`` seconds. A broken stream (standard error
    piped to a process that exited) disables the bar instead of failing the run.
    """

    min_interval = 0.1

    def __init__(self, total: int, enabled: bool = True, stream=None, unit: str = "faces",
                 description: str | None = None) -> None:
        self.total = max(int(total), 0)
        self.enabled = bool(enabled)
        self.done = 0
        self._closed = False
        self._bar = None
        if not self.enabled:
            return
        if stream is None:
            from tqdm.auto import tqdm
        else:
            from tqdm.std import tqdm
        try:
            self._bar = tqdm(total=self.total, file=sys.stderr if stream is None else stream, unit=unit,
                             unit_scale=False, desc=description, mininterval=self.min_interval, leave=True,
                             dynamic_ncols=True, disable=False)
        except (OSError, ValueError):
            self.enabled = False

    def update(self, done: int) -> None:
        """Record that ``done`` units are finished (a running total); tqdm redraws when due."""
        if not self.enabled or self._closed:
            return
        done = min(max(int(done), 0), self.total)
        step, self.done = done - self.done, done
        if step:
            self._call(lambda: self._bar.update(step))

    def close(self) -> None:
        """Draw the last state and end the line (once)."""
        if self._closed:
            return
        self._closed = True
        if self.enabled:
            self._call(self._bar.close)

    def _call(self, fn) -> None:
        try:
            fn()
        except (OSError, ValueError):
            # a closed or broken stream must not abort a simplification that is otherwise fine
            self.enabled = False

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class Callback:
    """Reports progress to ``fn(done, total)``: after every update (a few thousand
    operations apart) and once more on close (with the last value).  ``fn`` returning
    ``False`` (exactly False: None and True go on) stops the run with
    :class:`lodkit.Cancelled`; what ``fn`` raises propagates: it is the caller's code."""

    def __init__(self, fn: Callable[[int, int], object], total: int) -> None:
        self.fn = fn
        self.total = max(int(total), 0)
        self.done = 0
        self._closed = False

    def update(self, done: int) -> None:
        if self._closed:
            return
        self.done = min(max(int(done), 0), self.total)
        if self.fn(self.done, self.total) is False:
            self._closed = True
            raise Cancelled(f"cancelled by the progress callback at {self.done}/{self.total}")

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self.fn(self.done, self.total)

    def __enter__(self) -> Callback:
        return self

    def __exit__(self, *exc) -> None:
        if exc[0] is None:
            self.close()


def make(progress, total: int, **options):
    """The reporter for a ``progress=`` option (see the module docstring), or None."""
    if callable(progress):
        return Callback(progress, total)
    if progress is None or progress is False:
        return None
    if progress is True or isinstance(progress, (int, np.bool_)) and not isinstance(progress, str):
        return Progress(total, enabled=bool(progress), **options) if progress else None
    raise OptionError(f"progress must be True, False or a callable (done, total) -> bool | None, "
                      f"got {progress!r}")
