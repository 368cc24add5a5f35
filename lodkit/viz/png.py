"""PNG files, written atomically through Open3D's image writer."""
from __future__ import annotations

import os
import secrets
from pathlib import Path

import numpy as np

from ..errors import ImageIOError, OptionError


def check_image(name: str, img) -> np.ndarray:
    """``img`` as a non-empty (H, W, 3) uint8 array (OptionError naming ``name`` if not)."""
    a = np.asarray(img)
    if a.dtype != np.uint8 or a.ndim != 3 or a.shape[2] != 3 or a.shape[0] == 0 or a.shape[1] == 0:
        raise OptionError(f"{name} must be a non-empty (H, W, 3) uint8 image, got {a.dtype} {a.shape}")
    return a



def write_png(path, image) -> Path:
    """Write an (H, W, 3) uint8 image to ``path`` (a .png name) through Open3D's image
    writer. The file is written under a temporary name in the same directory and renamed,
    so a failure never leaves a half-written file. Returns the path."""
    a = np.ascontiguousarray(check_image("image", image))
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise OptionError(f"write_png writes .png files, got {path.name!r}")
    if not path.parent.is_dir():
        raise ImageIOError(f"cannot write {path}: directory {path.parent} does not exist")
    try:
        import open3d as o3d
    except (ImportError, OSError) as exc:
        raise ImageIOError(f"cannot write {path}: open3d is needed to write PNG files ({exc})") from None
    tmp = path.parent / f".{path.stem}.{secrets.token_hex(4)}.tmp.png"
    try:
        ok = o3d.io.write_image(str(tmp), o3d.geometry.Image(a))
        if not ok or not tmp.exists():
            raise ImageIOError(f"cannot write {path}: Open3D's PNG writer failed")
        os.replace(tmp, path)
    except OSError as exc:
        if isinstance(exc, ImageIOError):
            raise
        raise ImageIOError(f"cannot write {path}: {exc}") from None
    finally:
        if tmp.exists():
            tmp.unlink()
    return path
