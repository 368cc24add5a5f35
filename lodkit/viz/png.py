"""PNG files, encoded with zlib and written atomically through lodkit's one writer."""
from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

import numpy as np

from ..errors import ImageIOError, OptionError
from ..io.atomic import commit


def check_image(name: str, img) -> np.ndarray:
    """``img`` as a non-empty (H, W, 3) uint8 array (OptionError naming ``name`` if not)."""
    a = np.asarray(img)
    if a.dtype != np.uint8 or a.ndim != 3 or a.shape[2] != 3 or a.shape[0] == 0 or a.shape[1] == 0:
        raise OptionError(f"{name} must be a non-empty (H, W, 3) uint8 image, got {a.dtype} {a.shape}")
    return a



def encode_png(image: np.ndarray) -> bytes:
    """The PNG file of an (H, W, 3) uint8 image: 8-bit RGB, no filter, zlib level 6."""
    h, w, _ = image.shape
    rows = np.concatenate([np.zeros((h, 1), np.uint8), image.reshape(h, w * 3)], axis=1)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows.tobytes(), 6)) + chunk(b"IEND", b""))


def write_png(path, image) -> Path:
    """Write an (H, W, 3) uint8 image to ``path`` (a .png name), through lodkit's one atomic
    writer (:func:`lodkit.io.atomic.commit`: a temporary beside the target, its size
    checked, fsynced, renamed), so a failure never leaves a half-written file. Returns the path."""
    a = np.ascontiguousarray(check_image("image", image))
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise OptionError(f"write_png writes .png files, got {path.name!r}")
    if not path.parent.is_dir():
        raise ImageIOError(f"cannot write {path}: directory {path.parent} does not exist")
    data = encode_png(a)

    def produce(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            fh.write(data)

    def verify(tmp: Path) -> None:
        if os.path.getsize(tmp) != len(data):
            raise ImageIOError(f"cannot write {path}: wrote {len(data)} bytes but the file holds "
                               f"{os.path.getsize(tmp)}")

    commit(path, produce, verify, error_class=ImageIOError)
    return path
