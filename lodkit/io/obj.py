"""Wavefront OBJ, read and written with numpy.

Reading: ``v x y z [w]`` or ``v x y z r g b`` (colours), ``vt u v [w]``, ``vn x y z`` and
``f`` with ``v``, ``v/vt``, ``v//vn`` or ``v/vt/vn`` corners (1-based, or negative: relative
to the elements read so far). Every index is checked against the elements defined before
the face. Polygons are fan-triangulated (a note in the load report); ``l``/``p`` elements
and other statements (``o``, ``g``, ``s``, ``usemtl``, ``mtllib``) are skipped with a note.

As Open3D's reader did (so files load to the same meshes as before): one mesh vertex per
distinct (position, uv, normal) index triple, numbered in the order faces first use them
(positions no face uses are dropped), coordinates rounded to float32.
"""
from __future__ import annotations

import numpy as np

from .common import FileFormatError, MeshData, fan_triangulate, parse_reals_obj, to_float32_precision

__all__ = ["read", "write", "counts"]

_SKIP = (b"o", b"g", b"s", b"usemtl", b"mtllib", b"l", b"p", b"vp", b"cstype", b"deg", b"curv",
         b"surf", b"parm", b"end", b"mg", b"bevel", b"c_interp", b"d_interp", b"lod", b"shadow_obj",
         b"trace_obj", b"ctech", b"stech", b"maplib", b"usemap", b"vc")


def _floats(rows: list[bytes], what: str) -> np.ndarray:
    if not rows:
        return np.zeros(0)
    try:
        return parse_reals_obj(b" ".join(rows).split())
    except ValueError:
        raise FileFormatError(f"a '{what}' line holds a value that is not a number") from None


def _corner_triples(tokens: list[bytes]) -> np.ndarray:
    """(n, 3) int64 (v, vt, vn) per corner token, 0 where absent."""
    n = len(tokens)
    triples = np.zeros((n, 3), dtype=np.int64)
    if n == 0:
        return triples
    joined = b" ".join(tokens)
    first = tokens[0]
    slashes = first.count(b"/")
    double = b"//" in first
    if (slashes <= 2 and joined.count(b"/") == n * slashes and joined.count(b"//") == (n if double else 0)
            and not first.startswith(b"/") and not first.endswith(b"/") and b" /" not in joined
            and b"/ " not in joined):
        width = slashes + 1 - (1 if double else 0)
        try:
            vals = np.array(joined.replace(b"/", b" ").split(), dtype=np.bytes_).astype(np.int64)
        except (ValueError, OverflowError):
            vals = None
        if vals is not None and vals.size == n * width:
            vals = vals.reshape(n, width)
            if double:
                triples[:, 0], triples[:, 2] = vals[:, 0], vals[:, 1]
            else:
                triples[:, :width] = vals
            return _checked(triples)
    tok = b""
    try:
        for j, tok in enumerate(tokens):
            parts = tok.split(b"/")
            if len(parts) > 3 or not parts[0]:
                raise ValueError
            for s, p in enumerate(parts):
                if p:
                    triples[j, s] = int(p)
    except (ValueError, OverflowError):
        raise FileFormatError(f"a face corner {tok[:30]!r} is not of the form v, v/vt, v//vn or v/vt/vn") from None
    return _checked(triples)


def _checked(triples: np.ndarray) -> np.ndarray:
    if triples.size and (triples.max() > 2**40 or triples.min() < -2**40):
        raise FileFormatError("a face refers to an absurdly large index")
    return triples


def counts(data: bytes) -> tuple[int, int]:
    """(distinct position lines, face lines): what the save check compares."""
    lines = data.split(b"\n")
    return sum(1 for ln in lines if ln.startswith(b"v ")), sum(1 for ln in lines if ln.startswith(b"f "))


class _Statements:
    """The statements of some OBJ lines, sorted by kind (:func:`_scan`)."""

    def __init__(self):
        self.v_rows: list[bytes] = []
        self.v_len: list[int] = []            # per v line its value count
        self.vt_rows: list[bytes] = []
        self.vn_rows: list[bytes] = []
        self.f_rows: list[tuple[int, bytes]] = []   # (line number, corners)
        self.f_at: list[tuple[int, int, int]] = []  # per f line (v, vt, vn) defined before it
        self.skipped: dict[bytes, int] = {}


def _scan(data: bytes, first_line: int = 1, base=(0, 0, 0)) -> _Statements:
    """Sort the lines of ``data`` (numbered from ``first_line``) by statement, checking each
    line's value count; ``base``: the (v, vt, vn) elements defined before ``data`` (a file
    read in blocks), so that the faces' counts of what is defined before them are the
    file's."""
    st = _Statements()
    nv, nvt, nvn = base
    for number, line in enumerate(data.split(b"\n"), start=first_line):
        hashpos = line.find(b"#")
        if hashpos >= 0:
            line = line[:hashpos]
        words = line.split(None, 1)
        if not words:
            continue
        key = words[0]
        rest = words[1] if len(words) > 1 else b""
        if key == b"v":
            k = len(rest.split())
            if k not in (3, 4, 6, 7):
                raise FileFormatError(f"line {number}: a 'v' line needs 3, 4 (w) or 6 (rgb) values, has {k}")
            st.v_rows.append(rest)
            st.v_len.append(k)
            nv += 1
        elif key == b"vt":
            k = len(rest.split())
            if k not in (1, 2, 3):
                raise FileFormatError(f"line {number}: a 'vt' line needs 1 to 3 values, has {k}")
            st.vt_rows.append(rest + b" 0" * (3 - k))
            nvt += 1
        elif key == b"vn":
            if len(rest.split()) != 3:
                raise FileFormatError(f"line {number}: a 'vn' line needs 3 values")
            st.vn_rows.append(rest)
            nvn += 1
        elif key == b"f":
            st.f_rows.append((number, rest))
            st.f_at.append((nv, nvt, nvn))
        elif key in _SKIP:
            st.skipped[key] = st.skipped.get(key, 0) + 1
        else:
            raise FileFormatError(f"line {number}: unknown statement {key[:20]!r} (not an OBJ file?)")
    return st


def _positions(st: _Statements):
    """(positions, colours or None) of the v lines, rounded to float32 as Open3D read them."""
    v_len_a = np.array(st.v_len, dtype=np.int64)
    vals = _floats(st.v_rows, "v")
    if vals.size != int(v_len_a.sum()):
        raise FileFormatError("the 'v' lines could not be parsed")
    colors = None
    if v_len_a.size and np.all(v_len_a == v_len_a[0]):
        table = vals.reshape(v_len_a.size, int(v_len_a[0]))
        positions = table[:, :3]
        if v_len_a[0] >= 6:
            colors = table[:, 3:6] if v_len_a[0] == 6 else table[:, 4:7]
    else:
        starts = np.concatenate([[0], np.cumsum(v_len_a)[:-1]]).astype(np.int64)
        positions = vals[starts[:, None] + np.arange(3)] if v_len_a.size else np.zeros((0, 3))
        if np.any(v_len_a >= 6):
            colors = np.ones((v_len_a.size, 3))
            has = v_len_a >= 6
            off = np.where(v_len_a == 7, 4, 3)[has]
            colors[has] = vals[(starts[has] + off)[:, None] + np.arange(3)]
    positions = to_float32_precision(positions)
    if colors is not None:
        colors = to_float32_precision(colors)
    return positions, colors


def _face_corners(st: _Statements):
    """(corners per face, (n, 3) 0-based (v, vt, vn) per corner, -1 where absent) of the f
    lines; relative indices resolved and every index checked against the elements defined
    before its face."""
    n_corners = np.empty(len(st.f_rows), dtype=np.int64)
    corner_tokens: list[bytes] = []
    for i, (_line, rest) in enumerate(st.f_rows):
        toks = rest.split()
        n_corners[i] = len(toks)
        corner_tokens.extend(toks)
    if n_corners.size and n_corners.min() < 3:
        bad = int(np.flatnonzero(n_corners < 3)[0])
        raise FileFormatError(f"line {st.f_rows[bad][0]}: a face needs at least 3 corners, has {int(n_corners[bad])}")
    triples = _corner_triples(corner_tokens)
    # relative (negative) indices count back from the elements defined so far
    seen = np.repeat(np.array(st.f_at, dtype=np.int64).reshape(-1, 3), n_corners, axis=0)
    neg = triples < 0
    triples = np.where(neg, seen + 1 + triples, triples)
    absent = triples == 0
    absent[neg] = False
    bad = (~absent & ((triples < 1) | (triples > seen))) | (neg & (triples < 1))
    if bad.any():
        j = int(np.flatnonzero(bad.any(axis=1))[0])
        face = int(np.searchsorted(np.cumsum(n_corners), j, side="right"))
        kind = ("position", "texture coordinate", "normal")[int(np.flatnonzero(bad[j])[0])]
        raise FileFormatError(f"line {st.f_rows[face][0]}: face corner {corner_tokens[j][:30].decode('latin-1')!r} "
                              f"refers to a {kind} that is not defined before it")
    if absent[:, 0].any():
        raise FileFormatError("a face corner has no position index")
    triples -= 1                                          # absent -> -1
    return n_corners, triples


def _check_text(data: bytes) -> None:
    try:
        data.decode("utf-8")
    except UnicodeDecodeError:
        if b"\0" in data:
            raise FileFormatError("not an OBJ file (binary data)") from None


def read(data: bytes) -> MeshData:
    _check_text(data)
    st = _scan(data)
    notes: list[str] = []
    if st.skipped.get(b"l") or st.skipped.get(b"p"):
        notes.append(f"line ('l') and point ('p') elements not read: {st.skipped.get(b'l', 0)} and "
                     f"{st.skipped.get(b'p', 0)}")
    positions, colors = _positions(st)
    tex = to_float32_precision(_floats(st.vt_rows, "vt").reshape(-1, 3)[:, :2]) if st.vt_rows else None
    nrm = to_float32_precision(_floats(st.vn_rows, "vn").reshape(-1, 3)) if st.vn_rows else None
    if not st.f_rows:
        return MeshData(positions, np.zeros((0, 3), dtype=np.int64), notes=notes)
    n_corners, triples = _face_corners(st)
    # one vertex per distinct triple, in order of first use (as Open3D's reader)
    uniq, first, inverse = np.unique(triples, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    keys = uniq[order]
    corner_vertex = rank[inverse.reshape(-1)]
    faces = fan_triangulate(n_corners, corner_vertex, notes)
    vertices = positions[keys[:, 0]]
    vcolors = colors[keys[:, 0]] if colors is not None else None
    uvs = normals = None
    if tex is not None and (keys[:, 1] >= 0).any():
        uvs = np.where(keys[:, 1:2] >= 0, tex[np.maximum(keys[:, 1], 0)], 0.0)
    if nrm is not None and (keys[:, 2] >= 0).any():
        normals = np.where(keys[:, 2:3] >= 0, nrm[np.maximum(keys[:, 2], 0)], 0.0)
    dropped = positions.shape[0] - np.unique(keys[:, 0]).size
    if dropped:
        notes.append(f"{dropped} position(s) no face uses were dropped")
    return MeshData(vertices, faces, normals, vcolors, uvs, notes)


def read_blocks(blocks):
    """Positions and triangles of an OBJ given as successive byte blocks that end at line
    ends (a file too large to hold, :func:`lodkit.io.stream`): yields (positions, faces) per
    block, positions as ``read`` rounds them, faces as 0-based indices of the file's 'v'
    lines (not split by texture coordinate or normal: positions only), polygons
    fan-triangulated.  Checks as ``read`` does, across blocks."""
    base, line = (0, 0, 0), 1
    for block in blocks:
        _check_text(block)
        st = _scan(block, line, base)
        line += block.count(b"\n")
        positions, _ = _positions(st)
        faces = np.zeros((0, 3), dtype=np.int64)
        if st.f_rows:
            n_corners, triples = _face_corners(st)
            faces = fan_triangulate(n_corners, triples[:, 0], [])
        base = (base[0] + len(st.v_rows), base[1] + len(st.vt_rows), base[2] + len(st.vn_rows))
        yield positions, faces


def _fmt(a: np.ndarray) -> list[str]:
    return [" ".join(f"{x:.9g}" for x in row) for row in a.tolist()]


def write(vertices, faces, normals=None, colors=None, uvs=None) -> bytes:
    """One ``v`` (with ``r g b`` when coloured), ``vt`` and ``vn`` line per vertex, 9
    significant digits (float32 exact, which is what the reader keeps); faces ``f a/a/a``."""
    out = ["# written by lodkit"]
    pos = _fmt(vertices)
    if colors is not None:
        cols = _fmt(colors[:, :3])
        out += [f"v {p} {c}" for p, c in zip(pos, cols)]
    else:
        out += ["v " + p for p in pos]
    if uvs is not None:
        out += ["vt " + t for t in _fmt(uvs)]
    if normals is not None:
        out += ["vn " + t for t in _fmt(normals)]
    f1 = faces + 1
    if uvs is not None and normals is not None:
        out += [f"f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}" for a, b, c in f1.tolist()]
    elif uvs is not None:
        out += [f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in f1.tolist()]
    elif normals is not None:
        out += [f"f {a}//{a} {b}//{b} {c}//{c}" for a, b, c in f1.tolist()]
    else:
        out += [f"f {a} {b} {c}" for a, b, c in f1.tolist()]
    return ("\n".join(out) + "\n").encode("ascii")
