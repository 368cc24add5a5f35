"""Imports of the heavy dependencies, with one clear error when they fail.

Open3D's wheel links against system libraries (libusb-1.0, libGL, libEGL, libX11, libgomp)
that a bare Debian/Ubuntu machine or container lacks; importing it then raises an OSError
("libusb-1.0.so.0: cannot open shared object file") from deep inside its package.  Every
lodkit module that needs Open3D gets it from :func:`open3d`, which turns that into a
:class:`lodkit.errors.DependencyError` naming the package to install, and the CLI prints it
as one line.
"""
from __future__ import annotations

from .errors import DependencyError

__all__ = ["APT_PACKAGES", "open3d"]

# what Open3D's Linux wheels need from the system (the README's set-up line installs them)
APT_PACKAGES = "libusb-1.0-0 libgl1 libegl1 libx11-6 libgomp1"


def open3d():
    """The ``open3d`` module, or DependencyError saying what is missing."""
    try:
        import open3d as o3d
    except OSError as exc:              # a shared library Open3D links against is missing
        raise DependencyError(
            f"Open3D cannot be loaded: {exc}. A system library it needs is missing; on Debian/Ubuntu: "
            f"apt-get install {APT_PACKAGES}") from exc
    except ImportError as exc:
        if isinstance(exc, DependencyError):
            raise
        missing = getattr(exc, "name", None) in ("open3d", None) and "open3d" in str(exc)
        hint = "pip install open3d (open3d-cpu on Linux x86-64)" if missing else \
            f"if a system library is missing, on Debian/Ubuntu: apt-get install {APT_PACKAGES}"
        raise DependencyError(f"Open3D cannot be imported: {exc} ({hint})") from exc
    return o3d
