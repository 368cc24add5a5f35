"""The one atomic writer every file lodkit writes goes through (meshes, PNG, JSON, CSV, npz).

The rule (docs/reliability.md, "Atomic writes"):

* The content is written to a temporary file *beside* the target, named
  ``.<name>.lodkit-tmp-<pid>-<8 hex digits><suffix>`` (the suffix is the target's, so a
  writer that picks its format by extension still can), created with ``O_EXCL``.
* The written file is checked (its size, and whatever ``verify`` checks: the mesh writers
  read the element counts back), fsynced, renamed onto the target with :func:`os.replace`,
  and the directory is fsynced.
* On any failure -- an exception in ``write`` or ``verify``, a full disk, ``RLIMIT_FSIZE``
  (EFBIG), a failing rename -- the temporary is removed, the target is left as it was and
  the error is raised.
* A temporary left behind by a killed process (SIGKILL, power loss) is removed by the next
  write into the same directory, once no process with its pid is alive.
* Permissions: a new file gets what a plain ``open`` would give (0o666 less the umask --
  the kernel applies the umask when the temporary is created, the process umask is never
  read or set); an existing target keeps its mode.
* A read-only target (no write permission for its owner, e.g. 0444) is refused with a
  :class:`lodkit.MeshIOError` (errno EACCES) naming it: lodkit does not replace a file its
  owner protected. Make it writable (or remove it) first.
"""
from __future__ import annotations

import errno
import os
import re
import secrets
import stat
from collections.abc import Callable
from pathlib import Path

from ..errors import LodkitError, MeshIOError

__all__ = ["atomic_write", "commit", "temporary_name", "TEMP_PATTERN", "clean_stale_temporaries"]

#: Matches the names of lodkit's temporaries (group 1: the target's name, group 2: the pid).
TEMP_PATTERN = re.compile(r"^\.(.+)\.lodkit-tmp-(\d+)-[0-9a-f]{8}(\.[A-Za-z0-9]+)?$")


def temporary_name(target: Path) -> str:
    return f".{target.name}.lodkit-tmp-{os.getpid()}-{secrets.token_hex(4)}{target.suffix}"


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return True  # a process we may not signal exists (or the pid is absurd: keep it)
    except OSError:
        return True
    return True


def clean_stale_temporaries(directory: Path) -> list[str]:
    """Remove lodkit temporaries in ``directory`` whose writing process is gone; returns
    their names. Errors are ignored (a temporary we cannot remove is left for later)."""
    removed = []
    try:
        names = os.listdir(directory)
    except OSError:
        return removed
    for name in names:
        m = TEMP_PATTERN.match(name)
        if m is None or _alive(int(m.group(2))):
            continue
        try:
            p = os.path.join(directory, name)
            if os.path.isdir(p) and not os.path.islink(p):
                for inner in os.listdir(p):  # the 0.x writers staged side files in a directory
                    os.unlink(os.path.join(p, inner))
                os.rmdir(p)
            else:
                os.unlink(p)
            removed.append(name)
        except OSError:
            pass
    return removed


def _fsync_dir(directory: Path) -> None:
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _error(path: Path, problem: str, err: int | None, cls=MeshIOError) -> Exception:
    exc = cls(f"cannot write {path}: {problem}")
    if err is not None:
        exc.errno = err  # errno only: setting strerror/filename would change str(exc)
    return exc


def commit(path, produce: Callable[[Path], None], verify: Callable[[Path], None] | None = None,
           error_class=MeshIOError) -> Path:
    """Write ``path`` atomically: ``produce(tmp)`` writes the temporary file ``tmp`` (it
    exists, empty, when called), ``verify(tmp)`` may check it and raise; then fsync and
    rename. Errors of the file system become ``error_class`` (a lodkit error naming the
    target, errno kept); lodkit errors from ``produce``/``verify`` pass through; anything
    else (a bug, KeyboardInterrupt) is re-raised as is. The temporary never survives."""
    target = Path(os.fspath(path))
    directory = target.parent if str(target.parent) else Path(".")
    if target.is_dir():
        raise _error(target, "it is a directory", errno.EISDIR, error_class)
    if not directory.is_dir():
        raise _error(target, f"directory {directory} does not exist", errno.ENOENT, error_class)
    mode = None
    try:
        st = os.stat(target)
    except FileNotFoundError:
        pass
    except OSError as exc:
        raise _error(target, f"cannot inspect it ({exc.strerror or exc})", exc.errno, error_class) from None
    else:
        if not stat.S_ISREG(st.st_mode):
            raise _error(target, "it exists and is not a regular file", errno.EEXIST, error_class)
        if not st.st_mode & stat.S_IWUSR:
            raise _error(target, f"it is read-only (mode {stat.S_IMODE(st.st_mode):04o}); lodkit does not "
                         "replace a protected file: make it writable or remove it first", errno.EACCES,
                         error_class)
        mode = stat.S_IMODE(st.st_mode)
    clean_stale_temporaries(directory)
    tmp = directory / temporary_name(target)
    try:
        # 0o666: the kernel applies the umask, as for a plain open()
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o666)
    except OSError as exc:
        raise _error(target, f"cannot create a temporary file in {directory} ({exc.strerror or exc})",
                     exc.errno, error_class) from None
    os.close(fd)
    try:
        try:
            produce(tmp)
            if verify is not None:
                verify(tmp)
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
            if mode is not None:
                os.chmod(tmp, mode)
            os.replace(tmp, target)
        except LodkitError:
            raise
        except OSError as exc:
            what = exc.strerror or str(exc)
            if exc.errno == errno.EFBIG:
                what = f"{what} (the file size limit, ulimit -f, was reached)"
            raise _error(target, what, exc.errno, error_class) from None
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    _fsync_dir(directory)
    return target


def atomic_write(path, write, binary: bool = False, verify: Callable[[Path], None] | None = None) -> None:
    """Call ``write(file)`` on a temporary file beside ``path`` (text mode unless ``binary``),
    then check, fsync and rename it onto ``path`` (see the module docstring for the rule):
    the target is either left as it was or completely replaced, never half written."""
    def produce(tmp: Path) -> None:
        with open(tmp, "wb" if binary else "w", encoding=None if binary else "utf-8",
                  **({} if binary else {"newline": ""})) as fh:
            write(fh)

    commit(path, produce, verify)
