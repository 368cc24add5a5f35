"""Ctrl-C in the ``lodkit`` command: one line, exit status 130, never a traceback
(docs/reliability.md, "Interrupts").

Two places need help beyond ``except KeyboardInterrupt`` in :func:`lodkit.cli.main`:

* while ``import lodkit`` itself runs (before ``main`` exists): :func:`import_guard` around
  the package's imports turns the KeyboardInterrupt into that line and ``SystemExit(130)``,
  but only when this process *is* the command (``lodkit ...`` or ``python -m lodkit``);
  a program that imports lodkit gets its KeyboardInterrupt as usual;
* inside a library that turns the KeyboardInterrupt into its own error (Open3D's lazy import
  reports "ImportError: initialization failed"): while ``main`` runs, its SIGINT handler
  (:func:`cli_handler`) notes the signal before raising KeyboardInterrupt, so ``main`` knows
  the error it catches came from Ctrl-C.
"""
from __future__ import annotations

import os
import signal
import sys
import threading
from contextlib import contextmanager

__all__ = ["EXIT_INTERRUPTED", "exit_if_command", "import_guard", "is_command", "cli_handler", "interrupted"]

EXIT_INTERRUPTED = 130   # 128 + SIGINT, what shells report for Ctrl-C
_seen = False


def is_command() -> bool:
    """Is this process the ``lodkit`` command (console script or ``python -m lodkit``)?"""
    argv0 = os.path.basename(sys.argv[0]) if sys.argv else ""
    orig = getattr(sys, "orig_argv", [])
    return argv0 in ("lodkit", "lodkit.exe") or orig[1:3] == ["-m", "lodkit"]


@contextmanager
def import_guard():
    try:
        yield
    except KeyboardInterrupt:
        if not is_command():
            raise
        print("lodkit: interrupted", file=sys.stderr)
        exit_if_command(EXIT_INTERRUPTED)
        raise SystemExit(EXIT_INTERRUPTED) from None


def exit_if_command(code: int) -> None:
    """In the ``lodkit`` command, end the process now with ``code`` (after flushing the
    standard streams), skipping interpreter shutdown: a library interrupted half way may
    complain there and change the exit status (Open3D reports "memory leaks" and exits 1
    when a read was cut short).  Elsewhere (main() called from Python) do nothing."""
    if not is_command():
        return
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(code)


def interrupted() -> bool:
    """Did SIGINT arrive while :func:`cli_handler` was installed?"""
    return _seen


def _note_and_raise(signum, frame):
    global _seen
    _seen = True
    raise KeyboardInterrupt


@contextmanager
def cli_handler():
    """Install the noting SIGINT handler for the block (main thread, default handler only)."""
    global _seen
    _seen = False
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield
        return
    signal.signal(signal.SIGINT, _note_and_raise)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)
