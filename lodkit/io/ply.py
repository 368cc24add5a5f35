"""PLY (ascii, binary little and big endian), read and written with numpy.

Reading checks the header (format line, elements, property types, ``end_header``), that the
data holds exactly what the header declares (no more, no fewer bytes or values), that list
counts and indices are integers; faces with more than 3 corners are fan-triangulated (a
note in the load report). Vertex properties read: x y z (required), nx ny nz, red green
blue [alpha] (integer types scaled to [0, 1]), texture_u texture_v (or s t, u v,
texture_s texture_t). Other properties and elements are skipped with a note.
"""
from __future__ import annotations

import re

import numpy as np

from .common import FileFormatError, MeshData, fan_triangulate

__all__ = ["TYPES", "read", "write", "counts"]

#: PLY scalar type names -> numpy dtype codes (lodkit.large's memory maps read the same)
TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
_UV_NAMES = (("texture_u", "texture_v"), ("s", "t"), ("u", "v"), ("texture_s", "texture_t"))
_HEADER_LIMIT = 1 << 20


class _Element:
    def __init__(self, name: str, count: int):
        self.name, self.count = name, count
        self.props: list[tuple[str, str, str | None]] = []   # (name, type or count type, list item type)

    @property
    def has_list(self) -> bool:
        return any(p[2] is not None for p in self.props)


def _parse_header(data: bytes):
    if not data.startswith(b"ply"):
        raise FileFormatError("not a PLY file (it does not start with 'ply')")
    end = re.search(rb"(^|\n)end_header[ \t]*\r?\n", data[:_HEADER_LIMIT])
    if end is None:
        if re.search(rb"(^|\n)end_header[ \t]*\r?$", data[:_HEADER_LIMIT]):
            end_pos = len(data)
        else:
            raise FileFormatError("the PLY header has no 'end_header' line (corrupt or truncated file)")
    else:
        end_pos = end.end()
    text = data[:end_pos].decode("latin-1")
    fmt = None
    elements: list[_Element] = []
    for number, raw in enumerate(text.splitlines()[1:], start=2):
        words = raw.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        key = words[0]
        if key == "format":
            if len(words) != 3 or words[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise FileFormatError(f"PLY header line {number}: unknown format {raw.strip()!r}")
            fmt = words[1]
        elif key == "element":
            if len(words) != 3 or not re.fullmatch(r"\d{1,15}", words[2]):
                raise FileFormatError(f"PLY header line {number}: bad element line {raw.strip()!r}")
            elements.append(_Element(words[1], int(words[2])))
        elif key == "property":
            if not elements:
                raise FileFormatError(f"PLY header line {number}: a property before any element")
            if len(words) == 5 and words[1] == "list":
                if words[2] not in TYPES or words[3] not in TYPES:
                    raise FileFormatError(f"PLY header line {number}: unknown type in {raw.strip()!r}")
                if TYPES[words[2]][0] == "f":
                    raise FileFormatError(f"PLY header line {number}: a list count must be an integer type")
                elements[-1].props.append((words[4], TYPES[words[2]], TYPES[words[3]]))
            elif len(words) == 3 and words[1] in TYPES:
                elements[-1].props.append((words[2], TYPES[words[1]], None))
            else:
                raise FileFormatError(f"PLY header line {number}: bad property line {raw.strip()!r}")
        elif key == "end_header":
            break
        else:
            raise FileFormatError(f"PLY header line {number}: unknown keyword {key!r}")
    if fmt is None:
        raise FileFormatError("the PLY header has no 'format' line")
    for el in elements:
        names = [p[0] for p in el.props]
        if len(set(names)) != len(names):
            raise FileFormatError(f"PLY element '{el.name}' declares a property twice")
    return fmt, elements, end_pos


def counts(data: bytes) -> tuple[int, int]:
    """(vertices, faces) the header declares (the save check reads only this)."""
    _, elements, _ = _parse_header(data)
    n = {el.name: el.count for el in elements}
    return n.get("vertex", 0), n.get("face", 0)


# ------------------------------------------------------------------------ binary
def _read_binary_element(el: _Element, buf: memoryview, pos: int, order: str):
    """Returns ({prop: array or (counts, flat)}, new pos)."""
    avail = len(buf) - pos
    if not el.has_list:
        dt = np.dtype([(p[0], order + p[1]) for p in el.props])
        need = el.count * dt.itemsize
        if need > avail:
            raise FileFormatError(f"element '{el.name}' needs {need} bytes, the file holds only {avail} "
                                  f"after the previous data (truncated file, or the header overstates the count)")
        rows = np.frombuffer(buf, dtype=dt, count=el.count, offset=pos)
        return {p[0]: rows[p[0]] for p in el.props}, pos + need
    if el.count == 0:
        return {p[0]: (np.zeros(0, np.int64), np.zeros(0)) if p[2] else np.zeros(0) for p in el.props}, pos
    # minimum size: every list at least its count
    least = el.count * sum(np.dtype(p[1]).itemsize for p in el.props)
    if least > avail:
        raise FileFormatError(f"element '{el.name}' needs at least {least} bytes, the file holds only {avail} "
                              f"(truncated file, or the header overstates the count)")
    # fast path: every list has the length of the first row's
    fields, lengths, p0 = [], [], pos
    for name, t, item in el.props:
        if item is None:
            fields.append((name, order + t))
            p0 += np.dtype(t).itemsize
        else:
            if p0 + np.dtype(t).itemsize > len(buf):
                raise FileFormatError(f"element '{el.name}' row 0 runs past the end of the file")
            c = int(np.frombuffer(buf, dtype=order + t, count=1, offset=p0)[0])
            if c < 0:
                raise FileFormatError(f"element '{el.name}' row 0: negative list length {c}")
            fields.append((name + "#n", order + t))
            if c:
                fields.append((name, order + item, (c,)))
            lengths.append((name, c))
            p0 += np.dtype(t).itemsize + c * np.dtype(item).itemsize
            if p0 > len(buf):
                raise FileFormatError(f"element '{el.name}' row 0 runs past the end of the file")
    dt = np.dtype(fields)
    need = el.count * dt.itemsize
    if need <= avail:
        rows = np.frombuffer(buf, dtype=dt, count=el.count, offset=pos)
        if all(np.all(rows[name + "#n"] == c) for name, c in lengths):
            out = {}
            for name, _t, item in el.props:
                if item is None:
                    out[name] = rows[name]
                else:
                    c = dict(lengths)[name]
                    flat = rows[name].reshape(-1) if c else np.zeros(0, dtype=item)
                    out[name] = (np.full(el.count, c, dtype=np.int64), flat)
            return out, pos + need
    # general path: rows of different lengths, walked one by one
    cols: dict = {p[0]: [] for p in el.props}
    lens: dict = {p[0]: [] for p in el.props if p[2] is not None}
    end = len(buf)
    for _ in range(el.count):
        for name, t, item in el.props:
            size = np.dtype(t).itemsize
            if pos + size > end:
                raise FileFormatError(f"element '{el.name}' runs past the end of the file (truncated file, "
                                      f"or the header overstates the count)")
            v = np.frombuffer(buf, dtype=order + t, count=1, offset=pos)[0]
            pos += size
            if item is None:
                cols[name].append(v)
                continue
            c = int(v)
            isz = np.dtype(item).itemsize
            if c < 0 or pos + c * isz > end:
                raise FileFormatError(f"element '{el.name}': a list of {c} items runs past the end of the file")
            cols[name].append(np.frombuffer(buf, dtype=order + item, count=c, offset=pos))
            lens[name].append(c)
            pos += c * isz
    out = {}
    for name, t, item in el.props:
        if item is None:
            out[name] = np.array(cols[name], dtype=t)
        else:
            parts = cols[name]
            out[name] = (np.array(lens[name], dtype=np.int64),
                         np.concatenate(parts) if parts else np.zeros(0, dtype=item))
    return out, pos


# ------------------------------------------------------------------------ ascii
def _read_ascii(elements, body: bytes):
    tokens = body.split()
    try:
        values = np.array(tokens, dtype=np.bytes_).astype(np.float64) if tokens else np.zeros(0)
    except ValueError as exc:
        raise FileFormatError(f"the PLY data holds a value that is not a number ({exc})") from None
    pos = 0
    result = {}
    for el in elements:
        out = {}
        if not el.has_list:
            k = len(el.props)
            need = el.count * k
            if pos + need > values.size:
                raise FileFormatError(f"element '{el.name}' needs {need} values, the file holds only "
                                      f"{values.size - pos} (truncated file, or the header overstates the count)")
            block = values[pos: pos + need].reshape(el.count, k) if k else np.zeros((el.count, 0))
            for j, p in enumerate(el.props):
                out[p[0]] = block[:, j]
            pos += need
            result[el.name] = out
            continue
        cols: dict = {p[0]: [] for p in el.props}
        lens: dict = {p[0]: [] for p in el.props if p[2] is not None}
        # vectorised when the element is scalars then one list of constant length
        scal = [p for p in el.props if p[2] is None]
        if el.props[-1][2] is not None and len(scal) == len(el.props) - 1 and el.count:
            k = len(scal)
            if pos + k < values.size:
                c = values[pos + k]
                if 0 <= c < 1 << 20 and c == int(c):      # (a NaN or inf count: the slow path says so)
                    width = k + 1 + int(c)
                    need = el.count * width
                    if pos + need <= values.size:
                        block = values[pos: pos + need].reshape(el.count, width)
                        if np.all(block[:, k] == c):
                            for j, p in enumerate(scal):
                                out[p[0]] = block[:, j]
                            name = el.props[-1][0]
                            out[name] = (np.full(el.count, int(c), dtype=np.int64), block[:, k + 1:].reshape(-1))
                            pos += need
                            result[el.name] = out
                            continue
        for _ in range(el.count):
            for name, _t, item in el.props:
                if pos >= values.size:
                    raise FileFormatError(f"element '{el.name}' runs past the end of the data (truncated "
                                          f"file, or the header overstates the count)")
                v = values[pos]
                pos += 1
                if item is None:
                    cols[name].append(v)
                    continue
                if v != int(v) if np.isfinite(v) else True:
                    raise FileFormatError(f"element '{el.name}': list length {v} is not an integer")
                c = int(v)
                if c < 0 or pos + c > values.size:
                    raise FileFormatError(f"element '{el.name}': a list of {c} items runs past the end of the data")
                cols[name].append(values[pos: pos + c])
                lens[name].append(c)
                pos += c
        for name, _t, item in el.props:
            if item is None:
                out[name] = np.array(cols[name], dtype=np.float64)
            else:
                parts = cols[name]
                out[name] = (np.array(lens[name], dtype=np.int64),
                             np.concatenate(parts) if parts else np.zeros(0))
        result[el.name] = out
    if pos != values.size:
        raise FileFormatError(f"the file holds {values.size - pos} value(s) more than its header declares "
                              f"(the header understates an element count, or the file is corrupt)")
    return result


def _integers(values: np.ndarray, what: str) -> np.ndarray:
    if values.dtype.kind == "f":
        if values.size and (not np.all(np.isfinite(values)) or np.any(values != np.round(values))):
            raise FileFormatError(f"{what} holds a value that is not an integer")
        if values.size and np.abs(values).max() > 2**62:
            raise FileFormatError(f"{what} holds an absurdly large index")
    return values.astype(np.int64)


def read(data: bytes) -> MeshData:
    fmt, elements, start = _parse_header(data)
    by_name = {el.name: el for el in elements}
    if "vertex" not in by_name:
        raise FileFormatError("the PLY header declares no 'vertex' element")
    names = [p[0] for p in by_name["vertex"].props]
    for axis in "xyz":
        if axis not in names:
            raise FileFormatError(f"the PLY 'vertex' element has no '{axis}' property")
    if fmt == "ascii":
        parsed = _read_ascii(elements, data[start:])
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        buf = memoryview(data)
        pos = start
        parsed = {}
        for el in elements:
            parsed[el.name], pos = _read_binary_element(el, buf, pos, order)
        if pos != len(data):
            raise FileFormatError(f"the file holds {len(data) - pos} byte(s) more than its header declares "
                                  f"(the header understates an element count, or the file is corrupt)")
    notes: list[str] = []
    vel, v = by_name["vertex"], parsed["vertex"]
    types = {p[0]: p[1] for p in vel.props}
    for name in names:
        if vel.props[names.index(name)][2] is not None:
            raise FileFormatError(f"the PLY vertex property '{name}' is a list")
    vertices = np.stack([np.asarray(v[a], dtype=np.float64) for a in "xyz"], axis=1)
    used = {"x", "y", "z"}
    normals = colors = uvs = None
    if all(a in v for a in ("nx", "ny", "nz")):
        normals = np.stack([np.asarray(v[a], dtype=np.float64) for a in ("nx", "ny", "nz")], axis=1)
        used |= {"nx", "ny", "nz"}
    cnames = [c for c in ("red", "green", "blue", "alpha") if c in v]
    if all(c in v for c in ("red", "green", "blue")):
        chans = []
        for c in cnames:
            t = np.dtype(types[c])
            col = np.asarray(v[c], dtype=np.float64)
            if t.kind in "iu":
                col = col / float(np.iinfo(t).max)
            chans.append(col)
        colors = np.stack(chans, axis=1)
        used |= set(cnames)
    for pair in _UV_NAMES:
        if all(a in v for a in pair):
            uvs = np.stack([np.asarray(v[a], dtype=np.float64) for a in pair], axis=1)
            used |= set(pair)
            break
    skipped = [n for n in names if n not in used]
    if skipped:
        notes.append("vertex properties not read: " + ", ".join(skipped))
    faces = np.zeros((0, 3), dtype=np.int64)
    if "face" in by_name:
        fel, f = by_name["face"], parsed["face"]
        key = next((p[0] for p in fel.props if p[0] in ("vertex_indices", "vertex_index") and p[2]), None)
        if key is None:
            raise FileFormatError("the PLY 'face' element has no 'vertex_indices' list")
        n_per, flat = f[key]
        flat = _integers(np.asarray(flat), "a face list")
        faces = fan_triangulate(n_per, flat, notes)
        other = [p[0] for p in fel.props if p[0] != key]
        if other:
            notes.append("face properties not read: " + ", ".join(other))
    for el in elements:
        if el.name not in ("vertex", "face"):
            notes.append(f"element '{el.name}' ({el.count} rows) not read")
    return MeshData(vertices, faces, normals, colors, uvs, notes)


# ------------------------------------------------------------------------ write
def write(vertices, faces, normals=None, colors=None, uvs=None, ascii: bool = False) -> bytes:
    n, m = vertices.shape[0], faces.shape[0]
    fields = [("x", "<f8"), ("y", "<f8"), ("z", "<f8")]
    header_props = ["property double x", "property double y", "property double z"]
    cols = [vertices[:, 0], vertices[:, 1], vertices[:, 2]]
    if normals is not None:
        for j, a in enumerate(("nx", "ny", "nz")):
            fields.append((a, "<f8"))
            header_props.append(f"property double {a}")
            cols.append(normals[:, j])
    if colors is not None:
        c8 = np.clip(np.rint(np.asarray(colors) * 255.0), 0, 255).astype(np.uint8)
        for j, a in enumerate(("red", "green", "blue", "alpha")[: colors.shape[1]]):
            fields.append((a, "u1"))
            header_props.append(f"property uchar {a}")
            cols.append(c8[:, j])
    if uvs is not None:
        for j, a in enumerate(("texture_u", "texture_v")):
            fields.append((a, "<f8"))
            header_props.append(f"property double {a}")
            cols.append(uvs[:, j])
    header = "\n".join(
        ["ply", f"format {'ascii' if ascii else 'binary_little_endian'} 1.0", "comment written by lodkit",
         f"element vertex {n}", *header_props, f"element face {m}",
         "property list uchar int vertex_indices", "end_header"]) + "\n"
    if ascii:
        lines = []
        kinds = [f[1] for f in fields]
        table = np.empty((n, len(cols)), dtype=object)
        for j, (c, k) in enumerate(zip(cols, kinds)):
            table[:, j] = [repr(float(x)) for x in c] if k == "<f8" else [str(int(x)) for x in c]
        lines = [" ".join(row) for row in table.tolist()]
        flines = [f"3 {a} {b} {c}" for a, b, c in faces.tolist()]
        return (header + "\n".join(lines + flines) + "\n").encode("ascii")
    vrows = np.empty(n, dtype=np.dtype(fields))
    for (name, _), c in zip(fields, cols):
        vrows[name] = c
    frows = np.empty(m, dtype=np.dtype([("n", "u1"), ("i", "<i4", (3,))]))
    frows["n"] = 3
    frows["i"] = faces
    return header.encode("ascii") + vrows.tobytes() + frows.tobytes()
