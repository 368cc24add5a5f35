"""OFF (OFF, COFF, NOFF, CNOFF, STOFF and combinations), read and written with numpy.

Reading checks the header counts against the lines that follow, exactly (a file with more
or fewer vertex or face lines than declared is an error), every vertex line's value count,
that indices are integers (the range is checked by :class:`lodkit.Mesh`). Polygons are
fan-triangulated (a note in the load report); face colours are skipped with a note.
Colours are RGB or RGBA, as floats in [0, 1] or, when any value exceeds 1, as 0..255
integers. Coordinates are rounded to float32, as Open3D's reader did.
"""
from __future__ import annotations

import re

import numpy as np

from .common import FileFormatError, MeshData, fan_triangulate, to_float32_precision

__all__ = ["read", "write", "counts"]

_KEY = re.compile(rb"^(ST)?(C)?(N)?OFF$")


def _lines(data: bytes) -> list[bytes]:
    out = []
    for line in data.split(b"\n"):
        h = line.find(b"#")
        if h >= 0:
            line = line[:h]
        line = line.strip()
        if line:
            out.append(line)
    return out


def _header(lines: list[bytes]):
    if not lines:
        raise FileFormatError("not an OFF file (no header)")
    words = lines[0].split()
    m = _KEY.match(words[0])
    if m is None:
        raise FileFormatError("not an OFF file (it does not start with 'OFF')")
    st, c, n = (bool(g) for g in m.groups())
    rest = words[1:]
    used = 1
    if not rest:
        if len(lines) < 2:
            raise FileFormatError("the OFF header has no vertex and face counts")
        rest = lines[1].split()
        used = 2
    if len(rest) < 2 or len(rest) > 3 or not all(re.fullmatch(rb"\d{1,15}", w) for w in rest):
        raise FileFormatError(f"bad OFF counts line {b' '.join(rest)[:60]!r} (expected 'vertices faces edges')")
    return st, c, n, int(rest[0]), int(rest[1]), used


def counts(data: bytes) -> tuple[int, int]:
    st, c, n, nv, nf, _ = _header(_lines(data[:4096]))
    return nv, nf


def _vertex_table(vlines: list[bytes], has_c: bool, has_n: bool, st: bool) -> np.ndarray:
    """The values of the vertex lines, one row each (every line the same count: position,
    then normal, colour, uv as the key says)."""
    base = 3 + 3 * has_n + 2 * st
    if not vlines:
        return np.zeros((0, base))
    k = np.array([len(ln.split()) for ln in vlines])
    allowed = {base + 3, base + 4} if has_c else {base}
    if not np.all(k == k[0]) or int(k[0]) not in allowed:
        bad = int(np.flatnonzero(~np.isin(k, list(allowed)) | (k != k[0]))[0])
        raise FileFormatError(f"vertex line {bad} holds {int(k[bad])} values; expected "
                              + " or ".join(str(a) for a in sorted(allowed)))
    try:
        return np.array(b" ".join(vlines).split(), dtype=np.bytes_).astype(np.float64).reshape(len(vlines), int(k[0]))
    except ValueError:
        raise FileFormatError("a vertex line holds a value that is not a number") from None


def _face_lists(flines: list[bytes], notes: list) -> np.ndarray:
    """The triangles of the face lines (polygons fan-triangulated, face colours skipped
    with a note)."""
    face_words = [ln.split() for ln in flines]
    try:
        n_per = np.array([int(w[0]) for w in face_words], dtype=np.int64)
    except (ValueError, OverflowError):
        raise FileFormatError("a face line does not start with its corner count") from None
    if n_per.size and (n_per.min() < 3 or n_per.max() > 1 << 20):
        bad = int(np.flatnonzero((n_per < 3) | (n_per > 1 << 20))[0])
        raise FileFormatError(f"face {bad} declares {int(n_per[bad])} corners; a face needs at least 3")
    extra = np.array([len(w) for w in face_words], dtype=np.int64) - 1 - n_per
    if extra.size and extra.min() < 0:
        bad = int(np.flatnonzero(extra < 0)[0])
        raise FileFormatError(f"face {bad} declares {int(n_per[bad])} corners but lists {int(n_per[bad] + extra[bad])}")
    if extra.size and extra.max() > 0:
        if np.any((extra > 0) & (extra != 3) & (extra != 4)):
            bad = int(np.flatnonzero((extra > 0) & (extra != 3) & (extra != 4))[0])
            raise FileFormatError(f"face {bad} holds {int(extra[bad])} values after its corners (a face colour "
                                  f"has 3 or 4)")
        notes.append(f"face colours of {int((extra > 0).sum())} face(s) not read")
    try:
        flat = np.array([t for w, c in zip(face_words, n_per.tolist()) for t in w[1: 1 + c]],
                        dtype=np.bytes_).astype(np.int64) if flines else np.zeros(0, dtype=np.int64)
    except (ValueError, OverflowError):
        raise FileFormatError("a face index is not an integer") from None
    return fan_triangulate(n_per, flat, notes)


def read(data: bytes) -> MeshData:
    lines = _lines(data)
    st, has_c, has_n, nv, nf, start = _header(lines)
    if start + nv + nf > len(lines):
        raise FileFormatError(f"the header declares {nv} vertices and {nf} faces but the file holds only "
                              f"{len(lines) - start} data lines (truncated file, or the header overstates them)")
    if start + nv + nf < len(lines):
        raise FileFormatError(f"the file holds {len(lines) - start - nv - nf} more data line(s) than the "
                              f"{nv} vertices and {nf} faces its header declares (the header understates "
                              f"a count, or the file is corrupt)")
    notes: list[str] = []
    table = _vertex_table(lines[start: start + nv], has_c, has_n, st)
    base = 3 + 3 * has_n + 2 * st
    vertices = to_float32_precision(table[:, :3])
    col = 3
    normals = colors = uvs = None
    if has_n:
        normals = to_float32_precision(table[:, col: col + 3])
        col += 3
    if has_c:
        width = table.shape[1] - base
        colors = table[:, col: col + width]
        if colors.size and colors.max() > 1.0:
            colors = colors / 255.0
        col += width
    if st:
        uvs = to_float32_precision(table[:, col: col + 2])
    faces = _face_lists(lines[start + nv:], notes)
    return MeshData(vertices, faces, normals, colors, uvs, notes)


def read_blocks(blocks):
    """Positions and triangles of an OFF given as successive byte blocks that end at line
    ends (a file too large to hold, :func:`lodkit.io.stream`): yields (positions, faces) per
    block, as ``read`` reads them; the counts of the header are checked against the lines,
    exactly, at the end."""
    header = None
    done_v = done_f = 0
    pending: list[bytes] = []
    for block in blocks:
        lines = _lines(block)
        if header is None:
            # the counts may stand on the line after the key: wait for two lines
            pending += lines
            if len(pending) < 2:
                continue
            header = _header(pending[:2])
            lines = pending[header[5]:]
        st, has_c, has_n, nv, nf, _ = header
        take_v = min(len(lines), nv - done_v)
        take_f = len(lines) - take_v
        if done_f + take_f > nf:
            raise FileFormatError(f"the file holds more data lines than the {nv} vertices and {nf} faces its "
                                  f"header declares (the header understates a count, or the file is corrupt)")
        positions = to_float32_precision(_vertex_table(lines[:take_v], has_c, has_n, st)[:, :3])
        faces = _face_lists(lines[take_v:], [])
        done_v += take_v
        done_f += take_f
        yield positions, faces
    if header is None:
        header = _header(pending)            # at most one line: says what is missing
    if done_v < header[3] or done_f < header[4]:
        raise FileFormatError(f"the header declares {header[3]} vertices and {header[4]} faces but the file holds "
                              f"only {done_v} and {done_f} (truncated file, or the header overstates them)")


def write(vertices, faces, normals=None, colors=None, uvs=None) -> bytes:
    """``[ST][C][N]OFF``; 9 significant digits (float32 exact, what the reader keeps); colours
    as floats in [0, 1] (RGBA when the mesh has alpha), read back as written."""
    key = (("ST" if uvs is not None else "") + ("C" if colors is not None else "")
           + ("N" if normals is not None else "") + "OFF")
    cols = [vertices] + [a for a in (normals, colors, uvs) if a is not None]
    rows = [" ".join(f"{x:.9g}" for x in r) for r in np.concatenate(cols, axis=1).tolist()]
    out = [key, f"{vertices.shape[0]} {faces.shape[0]} 0"] + rows + [f"3 {a} {b} {c}" for a, b, c in faces.tolist()]
    return ("\n".join(out) + "\n").encode("ascii")
