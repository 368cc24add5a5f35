"""Text meshes too large to hold, converted in blocks into a binary PLY that can be memory-mapped.

:func:`lodkit.simplify_large` reads a binary PLY through memory maps, so that the driving
process never holds the whole mesh. An OBJ or OFF file is converted once into such a PLY:
the file is read in blocks that end at line ends, each block is parsed by the format's own
reader steps (``obj.read_blocks``, ``off.read_blocks``: the same checks and number parsing
as :func:`lodkit.load`), and its positions and triangles are appended to two raw files,
which are then joined under a PLY header. Memory: one block and what parsing it takes
(about 40 times its bytes: ``BLOCK_BYTES``), whatever the size of the file.

Positions only: the vertices are the file's position records in file order ('v' lines,
OFF vertex lines), not split by texture coordinate or normal as :func:`lodkit.load` splits
them, and positions no face uses stay (they are in no tile). Coordinates are rounded to
float32, as :func:`lodkit.load` rounds them, and stored as float32.
"""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np

from . import obj, off
from .common import FileFormatError

__all__ = ["BLOCK_BYTES", "STREAMED", "blocks", "to_binary_ply"]

#: bytes read at a time (a block is extended to the next line end).  Parsing holds about 40
#: times a block (Python objects per line and token): 4 MB blocks peak near 150 MB
BLOCK_BYTES = 4 << 20

#: the formats converted in blocks, by suffix
STREAMED = {".obj": obj.read_blocks, ".off": off.read_blocks}

_FACE = np.dtype([("n", "u1"), ("v", "<i4", (3,))])


def blocks(path, size: int = BLOCK_BYTES):
    """The bytes of ``path`` in blocks of about ``size`` that end at line ends (the last
    one where the file ends)."""
    with open(path, "rb") as fh:
        tail = b""
        while True:
            chunk = fh.read(size)
            if not chunk:
                break
            data = tail + chunk
            cut = data.rfind(b"\n") + 1
            if cut == 0:                      # no line end yet: read on
                tail = data
                continue
            tail = data[cut:]
            yield data[:cut]
        if tail:
            yield tail


def to_binary_ply(path, out_path, size: int | None = None) -> tuple[int, int]:
    """Convert the OBJ or OFF file ``path`` into a binary little-endian PLY ``out_path``
    (float32 positions, int32 triangles), in blocks of about ``size`` bytes (default
    BLOCK_BYTES); returns its
    (vertices, faces).  Raises FileFormatError (what is wrong with the file), as the
    format's reader would, and leaves no ``out_path`` behind then."""
    path, out_path = Path(path), Path(out_path)
    read_blocks = STREAMED.get(path.suffix.lower())
    if read_blocks is None:
        raise ValueError(f"{path.suffix!r} files are not converted in blocks (only {', '.join(STREAMED)})")
    v_raw, f_raw, tmp = (out_path.with_name(out_path.name + ext) for ext in (".v", ".f", ".part"))
    n_v = n_f = 0
    top = -1                                  # the largest vertex index of a face so far
    try:
        with open(v_raw, "wb") as fv, open(f_raw, "wb") as ff:
            for positions, faces in read_blocks(blocks(path, size or BLOCK_BYTES)):
                if positions.size and not np.isfinite(positions).all():
                    raise FileFormatError("a vertex coordinate is NaN or infinite (or beyond float32's range)")
                positions.astype("<f4").tofile(fv)
                n_v += len(positions)
                if len(faces):
                    hi = int(faces.max())
                    if faces.min() < 0 or hi >= 2**31 - 1:
                        raise FileFormatError("a face refers to a vertex index out of range")
                    top = max(top, hi)
                    rec = np.empty(len(faces), dtype=_FACE)
                    rec["n"] = 3
                    rec["v"] = faces
                    rec.tofile(ff)
                    n_f += len(faces)
        if top >= n_v:
            raise FileFormatError(f"a face refers to vertex {top}; the file has {n_v} vertices")
        with open(tmp, "wb") as out:
            out.write(("ply\nformat binary_little_endian 1.0\n"
                       f"comment converted by lodkit from {path.name}\n"
                       f"element vertex {n_v}\nproperty float x\nproperty float y\nproperty float z\n"
                       f"element face {n_f}\nproperty list uchar int vertex_indices\nend_header\n").encode("ascii"))
            for raw in (v_raw, f_raw):
                with open(raw, "rb") as fh:
                    shutil.copyfileobj(fh, out, 16 << 20)
        os.replace(tmp, out_path)
    finally:
        for p in (v_raw, f_raw, tmp):
            if p.exists():
                p.unlink()
    return n_v, n_f

