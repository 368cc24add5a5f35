"""STL (binary and ascii), read and written with numpy.

Binary: an 80-byte header, a triangle count, 50 bytes per triangle; the file size must be
exactly what the count says. ASCII: ``solid``, then ``facet normal``/``outer loop``/three
``vertex`` lines/``endloop``/``endfacet`` per triangle, checked for that structure.
Coordinates are float32 (binary) or rounded to float32 (ascii), as Open3D's reader did; the
facet normals are not kept (lodkit welds the unconnected triangles on load).
"""
from __future__ import annotations

import numpy as np

from .common import FileFormatError, MeshData, to_float32_precision

__all__ = ["read", "write", "counts"]

_TRI = np.dtype([("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])


def _binary_count(data: bytes) -> int | None:
    if len(data) < 84:
        return None
    n = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
    return n if len(data) == 84 + 50 * n else None


def counts(data: bytes) -> tuple[int, int]:
    n = _binary_count(data)
    if n is None:
        raise FileFormatError("not a binary STL file of consistent size")
    return 3 * n, n


def read(data: bytes) -> MeshData:
    n = _binary_count(data)
    if n is not None:
        tris = np.frombuffer(data, dtype=_TRI, count=n, offset=84)
        with np.errstate(invalid="ignore"):
            corners = tris["v"].reshape(-1, 3).astype(np.float64)
    else:
        if not data.lstrip().startswith(b"solid"):
            if len(data) >= 84:
                declared = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
                raise FileFormatError(f"binary STL header declares {declared} triangles "
                                      f"({84 + 50 * declared} bytes) but the file has {len(data)} bytes "
                                      f"(truncated or corrupt file)")
            raise FileFormatError("not an STL file (too short for binary, no 'solid' for ascii)")
        words = data.split()
        lowered = [w.lower() for w in words]
        if b"facet" not in lowered:
            raise FileFormatError("an ascii STL file without facets (or a corrupt binary STL)")
        corners_list = []
        i, nw = 1, len(words)
        # skip the solid name: everything up to the first 'facet' or 'endsolid'
        while i < nw and lowered[i] not in (b"facet", b"endsolid"):
            i += 1
        try:
            while i < nw and lowered[i] == b"facet":
                if lowered[i + 1] != b"normal" or lowered[i + 5] != b"outer" or lowered[i + 6] != b"loop":
                    raise FileFormatError(f"ascii STL: malformed facet near word {i}")
                j = i + 7
                for _ in range(3):
                    if lowered[j] != b"vertex":
                        raise FileFormatError(f"ascii STL: a facet without 3 vertices near word {j}"
                                              " (polygons are not STL)")
                    corners_list.append(words[j + 1: j + 4])
                    j += 4
                if lowered[j] != b"endloop" or lowered[j + 1] != b"endfacet":
                    raise FileFormatError(f"ascii STL: a facet does not end with endloop/endfacet near word {j}")
                i = j + 2
        except IndexError:
            raise FileFormatError("ascii STL: the file ends inside a facet (truncated file)") from None
        if i >= nw or lowered[i] != b"endsolid":
            raise FileFormatError(f"ascii STL: unexpected {words[i][:20]!r} where a facet or endsolid should be"
                                  if i < nw else "ascii STL: no 'endsolid' (truncated file)")
        try:
            corners = np.array(corners_list, dtype=np.bytes_).astype(np.float64).reshape(-1, 3)
        except ValueError:
            raise FileFormatError("ascii STL: a vertex coordinate is not a number") from None
        corners = to_float32_precision(corners)
    faces = np.arange(corners.shape[0], dtype=np.int64).reshape(-1, 3)
    return MeshData(corners, faces)


def write(vertices, faces, face_normals) -> bytes:
    tris = np.zeros(faces.shape[0], dtype=_TRI)
    tris["n"] = face_normals
    tris["v"] = vertices[faces]
    header = b"binary STL written by lodkit".ljust(80, b" ")
    return header + np.array([faces.shape[0]], dtype="<u4").tobytes() + tris.tobytes()
