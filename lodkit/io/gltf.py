"""glTF 2.0 (GLB and GLTF), read and written with numpy and :mod:`json`.

Reading checks the GLB container (magic, version, total length, chunk lengths), the JSON
(every primitive's and accessor's keys against the specification: a misspelt ``indices``
would otherwise turn the triangles into garbage), every buffer view and accessor against
the bytes that hold it, component types, index ranges; triangles only (``mode`` 4).
Meshes are placed by their nodes' transforms (matrix or translation/rotation/scale) of the
default scene; vertices keep their order within each primitive. Read: POSITION, NORMAL,
COLOR_0 (RGB or RGBA), TEXCOORD_0; other attributes are skipped with a note. GLTF buffers
may be ``data:`` URIs or files beside the .gltf.

Writing: one mesh, one primitive; float32 positions, normals, colours (RGBA when the mesh
has alpha), uvs; uint32 indices. A GLTF file embeds its buffer as a base64 ``data:`` URI,
so it is one self-contained file (no ``.bin`` beside it).
"""
from __future__ import annotations

import base64
import json
import os
import struct

import numpy as np

from .common import FileFormatError, MeshData

__all__ = ["read", "write", "counts"]

_COMPONENT = {5120: "i1", 5121: "u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_PRIMITIVE_KEYS = {"attributes", "indices", "material", "mode", "targets", "extensions", "extras"}
_ACCESSOR_KEYS = {"bufferView", "byteOffset", "componentType", "normalized", "count", "type", "max", "min",
                  "sparse", "name", "extensions", "extras"}
_VIEW_KEYS = {"buffer", "byteOffset", "byteLength", "byteStride", "target", "name", "extensions", "extras"}
_NODE_KEYS = {"camera", "children", "skin", "matrix", "mesh", "rotation", "scale", "translation", "weights",
              "name", "extensions", "extras"}
_KNOWN_ATTRIBUTES = {"POSITION", "NORMAL", "TANGENT"}
_JSON, _BIN = 0x4E4F534A, 0x004E4942


def _int(obj: dict, key: str, what: str, default=None, lo: int = 0) -> int:
    v = obj.get(key, default)
    if v is None:
        raise FileFormatError(f"{what} has no '{key}'")
    if isinstance(v, bool) or not isinstance(v, int) or v < lo or v > 1 << 53:
        raise FileFormatError(f"{what}: '{key}' is {v!r}, not an integer >= {lo}")
    return v


def _list(doc: dict, key: str) -> list:
    v = doc.get(key, [])
    if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
        raise FileFormatError(f"glTF '{key}' is not a list of objects")
    return v


def _index(v, n: int, what: str) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < n:
        raise FileFormatError(f"{what} refers to {v!r}, which does not exist (there are {n})")
    return v


def _split_glb(data: bytes) -> tuple[dict, bytes | None]:
    if len(data) < 20:
        raise FileFormatError("not a GLB file (too short)")
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF":
        raise FileFormatError("not a GLB file (it does not start with 'glTF')")
    if version != 2:
        raise FileFormatError(f"GLB version {version}; only glTF 2 is supported")
    if length != len(data):
        raise FileFormatError(f"the GLB header says {length} bytes but the file has {len(data)} "
                              f"(truncated or corrupt file)")
    pos, chunks = 12, []
    while pos < len(data):
        if pos + 8 > len(data):
            raise FileFormatError("a GLB chunk header runs past the end of the file")
        clen, ctype = struct.unpack_from("<II", data, pos)
        if pos + 8 + clen > len(data):
            raise FileFormatError(f"a GLB chunk of {clen} bytes runs past the end of the file")
        chunks.append((ctype, data[pos + 8: pos + 8 + clen]))
        pos += 8 + clen
    if not chunks or chunks[0][0] != _JSON:
        raise FileFormatError("the GLB's first chunk is not its JSON")
    doc = _json(chunks[0][1])
    binary = next((c for t, c in chunks[1:] if t == _BIN), None)
    return doc, binary


def _json(text: bytes) -> dict:
    try:
        doc = json.loads(text.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise FileFormatError(f"the glTF JSON does not parse ({type(exc).__name__}: {str(exc)[:80]})") from None
    if not isinstance(doc, dict):
        raise FileFormatError("the glTF JSON is not an object")
    asset = doc.get("asset")
    if not isinstance(asset, dict) or not str(asset.get("version", "")).startswith("2"):
        raise FileFormatError("the glTF JSON has no 'asset' with version 2.x")
    return doc


def _buffers(doc: dict, binary: bytes | None, base_dir: str | None) -> list[bytes]:
    out = []
    for i, b in enumerate(_list(doc, "buffers")):
        length = _int(b, "byteLength", f"buffer {i}", lo=1)
        uri = b.get("uri")
        if uri is None:
            if i != 0 or binary is None:
                raise FileFormatError(f"buffer {i} has no 'uri' and there is no GLB binary chunk for it")
            data = binary
        elif not isinstance(uri, str):
            raise FileFormatError(f"buffer {i}: 'uri' is not a string")
        elif uri.startswith("data:"):
            head, _, payload = uri.partition(",")
            if not head.endswith(";base64"):
                raise FileFormatError(f"buffer {i}: a data: URI that is not base64")
            try:
                data = base64.b64decode(payload, validate=True)
            except ValueError:
                raise FileFormatError(f"buffer {i}: its base64 data is corrupt") from None
        else:
            if base_dir is None or "://" in uri:
                raise FileFormatError(f"buffer {i}: external buffer {uri[:60]!r} cannot be read here")
            from urllib.parse import unquote
            path = os.path.join(base_dir, unquote(uri))
            try:
                with open(path, "rb") as fh:
                    data = fh.read(length + 1)
            except OSError as exc:
                raise FileFormatError(f"buffer {i}: cannot read {path} ({exc.strerror or exc})") from None
        if len(data) < length:
            raise FileFormatError(f"buffer {i} declares {length} bytes but holds only {len(data)}")
        out.append(data[:length])
    return out


def _accessor(doc: dict, buffers: list[bytes], index, what: str, normalize: bool = False) -> np.ndarray:
    accessors = _list(doc, "accessors")
    views = _list(doc, "bufferViews")
    a = accessors[_index(index, len(accessors), what)]
    name = f"{what} (accessor {index})"
    unknown = set(a) - _ACCESSOR_KEYS
    if unknown:
        raise FileFormatError(f"{name} has unknown propert{'y' if len(unknown) == 1 else 'ies'} "
                              f"{', '.join(sorted(map(repr, unknown)))[:120]} (corrupt file?)")
    if "sparse" in a:
        raise FileFormatError(f"{name} is sparse, which lodkit does not read")
    ctype = a.get("componentType")
    if not isinstance(ctype, int) or ctype not in _COMPONENT:
        raise FileFormatError(f"{name}: unknown componentType {ctype!r}")
    kind = a.get("type")
    if not isinstance(kind, str) or kind not in _WIDTH:
        raise FileFormatError(f"{name}: unknown type {kind!r}")
    count = _int(a, "count", name, lo=1)
    if "bufferView" not in a:
        raise FileFormatError(f"{name} has no bufferView (all-zero accessors are not read)")
    v = views[_index(a["bufferView"], len(views), f"{name}: bufferView")]
    vname = f"bufferView {a['bufferView']}"
    unknown = set(v) - _VIEW_KEYS
    if unknown:
        raise FileFormatError(f"{vname} has unknown properties {', '.join(sorted(map(repr, unknown)))[:120]}")
    buf = buffers[_index(v.get("buffer"), len(buffers), f"{vname}: buffer")]
    v_off = _int(v, "byteOffset", vname, 0)
    v_len = _int(v, "byteLength", vname, lo=1)
    if v_off + v_len > len(buf):
        raise FileFormatError(f"{vname} (bytes {v_off}..{v_off + v_len}) runs past its buffer's {len(buf)} bytes")
    dt = np.dtype(_COMPONENT[ctype])
    width = _WIDTH[kind]
    elem = dt.itemsize * width
    stride = _int(v, "byteStride", vname, elem, lo=elem)
    a_off = _int(a, "byteOffset", name, 0)
    need = a_off + stride * (count - 1) + elem
    if need > v_len:
        raise FileFormatError(f"{name}: {count} elements need {need} bytes of its bufferView, which has {v_len}")
    raw = np.frombuffer(buf, dtype=np.uint8, count=need - a_off, offset=v_off + a_off)
    if stride == elem:
        arr = raw.view(dt).reshape(count, width)
    else:
        rows = np.lib.stride_tricks.as_strided(raw, shape=(count, elem), strides=(stride, 1))
        arr = np.ascontiguousarray(rows).view(dt).reshape(count, width)
    out = arr.astype(np.float64)
    if dt.kind in "iu" and (normalize or a.get("normalized")):
        out = out / float(np.iinfo(dt).max)
        if dt.kind == "i":
            out = np.maximum(out, -1.0)
    return out


def _node_matrix(node: dict, what: str) -> np.ndarray:
    try:
        return _node_matrix_unchecked(node, what)
    except OverflowError:
        raise FileFormatError(f"{what}: a transform value is too large") from None


def _node_matrix_unchecked(node: dict, what: str) -> np.ndarray:
    if "matrix" in node:
        m = node["matrix"]
        if not isinstance(m, list) or len(m) != 16 or not all(isinstance(x, (int, float)) for x in m):
            raise FileFormatError(f"{what}: 'matrix' is not 16 numbers")
        return np.array(m, dtype=np.float64).reshape(4, 4).T
    def vec(key, n, default):
        v = node.get(key, default)
        if not isinstance(v, list) or len(v) != n or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                             for x in v):
            raise FileFormatError(f"{what}: '{key}' is not {n} numbers")
        return np.array(v, dtype=np.float64)
    t = vec("translation", 3, [0, 0, 0])
    x, y, z, w = vec("rotation", 4, [0, 0, 0, 1])
    s = vec("scale", 3, [1, 1, 1])
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    m = np.eye(4)
    m[:3, :3] = r * s
    m[:3, 3] = t
    return m


def _placed_meshes(doc: dict) -> list[tuple[int, np.ndarray]]:
    """(mesh index, 4x4 world matrix) for every node of the default scene that has a mesh;
    every mesh once with the identity when the file has no scenes or nodes."""
    meshes = _list(doc, "meshes")
    nodes = _list(doc, "nodes")
    scenes = _list(doc, "scenes")
    if not nodes or not scenes:
        return [(i, np.eye(4)) for i in range(len(meshes))]
    scene = scenes[_index(doc.get("scene", 0), len(scenes), "the default scene")]
    roots = scene.get("nodes", [])
    if not isinstance(roots, list):
        raise FileFormatError("a scene's 'nodes' is not a list")
    out, stack, visits = [], [(r, np.eye(4)) for r in reversed(roots)], 0
    while stack:
        ni, parent = stack.pop()
        visits += 1
        if visits > 10 * len(nodes) + 10:
            raise FileFormatError("the glTF node hierarchy has a cycle")
        node = nodes[_index(ni, len(nodes), "a scene or node child")]
        unknown = set(node) - _NODE_KEYS
        if unknown:
            raise FileFormatError(f"node {ni} has unknown properties {', '.join(sorted(map(repr, unknown)))[:120]}")
        world = parent @ _node_matrix(node, f"node {ni}")
        if "mesh" in node:
            out.append((_index(node["mesh"], len(meshes), f"node {ni}: mesh"), world))
        children = node.get("children", [])
        if not isinstance(children, list):
            raise FileFormatError(f"node {ni}: 'children' is not a list")
        stack.extend((c, world) for c in reversed(children))
    return out


def _document(data: bytes, base_dir: str | None):
    if data[:4] == b"glTF":
        doc, binary = _split_glb(data)
    else:
        doc, binary = _json(data), None
    return doc, binary


def counts(data: bytes) -> tuple[int, int]:
    """(vertices, faces) the JSON declares; ``data`` may be only the start of a GLB, as long
    as it holds the JSON chunk."""
    if data[:4] == b"glTF":
        if len(data) < 20:
            raise FileFormatError("not a GLB file (too short)")
        clen, ctype = struct.unpack_from("<II", data, 12)
        if ctype != _JSON or 20 + clen > len(data):
            raise FileFormatError("the GLB's JSON chunk is missing or longer than what was read")
        doc = _json(data[20: 20 + clen])
    else:
        doc = _json(data)
    acc = _list(doc, "accessors")
    nv = nf = 0
    for mesh in _list(doc, "meshes"):
        for prim in mesh.get("primitives", []):
            nv += acc[prim["attributes"]["POSITION"]]["count"]
            nf += (acc[prim["indices"]]["count"] if "indices" in prim else 0) // 3
    return nv, nf


def _attribute(doc, buffers, attrs, what, n, key, widths, normalize=False):
    if key not in attrs:
        return None
    arr = _accessor(doc, buffers, attrs[key], f"{what} {key}", normalize)
    if arr.shape[0] != n or arr.shape[1] not in widths:
        raise FileFormatError(f"{what}: {key} has {arr.shape[0]} x {arr.shape[1]} values for {n} vertices")
    return arr


def read(data: bytes, base_dir: str | None = None) -> MeshData:
    doc, binary = _document(data, base_dir)
    buffers = _buffers(doc, binary, base_dir)
    meshes = _list(doc, "meshes")
    notes: list[str] = []
    parts = []
    skipped: set[str] = set()
    for mi, world in _placed_meshes(doc):
        prims = meshes[mi].get("primitives")
        if not isinstance(prims, list) or not prims or not all(isinstance(p, dict) for p in prims):
            raise FileFormatError(f"mesh {mi} has no list of primitives")
        for pi, prim in enumerate(prims):
            what = f"mesh {mi} primitive {pi}"
            unknown = set(prim) - _PRIMITIVE_KEYS
            if unknown:
                raise FileFormatError(f"{what} has unknown propert{'y' if len(unknown) == 1 else 'ies'} "
                                      f"{', '.join(sorted(map(repr, unknown)))[:120]} (corrupt file?)")
            mode = prim.get("mode", 4)
            if mode != 4:
                raise FileFormatError(f"{what} has mode {mode!r}; lodkit reads triangles (mode 4) only")
            attrs = prim.get("attributes")
            if not isinstance(attrs, dict) or "POSITION" not in attrs:
                raise FileFormatError(f"{what} has no POSITION attribute")
            for name in attrs:
                base = name.rsplit("_", 1)[0] if name[-1:].isdigit() else name
                if not (name in _KNOWN_ATTRIBUTES or name.startswith("_")
                        or base in ("TEXCOORD", "COLOR", "JOINTS", "WEIGHTS")):
                    raise FileFormatError(f"{what} has an unknown attribute {name[:40]!r} (corrupt file?)")
            pos = _accessor(doc, buffers, attrs["POSITION"], f"{what} POSITION")
            if pos.shape[1] != 3:
                raise FileFormatError(f"{what}: POSITION is not VEC3")
            n = pos.shape[0]

            nrm = _attribute(doc, buffers, attrs, what, n, "NORMAL", (3,))
            col = _attribute(doc, buffers, attrs, what, n, "COLOR_0", (3, 4), normalize=True)
            uv = _attribute(doc, buffers, attrs, what, n, "TEXCOORD_0", (2,), normalize=True)
            skipped |= set(attrs) - {"POSITION", "NORMAL", "COLOR_0", "TEXCOORD_0"}
            if "indices" in prim:
                idx = _accessor(doc, buffers, prim["indices"], f"{what} indices")
                acc = _list(doc, "accessors")[prim["indices"]]
                if idx.shape[1] != 1 or acc.get("componentType") not in (5121, 5123, 5125):
                    raise FileFormatError(f"{what}: indices must be unsigned integer SCALARs")
                idx = idx.reshape(-1).astype(np.int64)
                if idx.size and idx.max() >= n:
                    raise FileFormatError(f"{what}: index {int(idx.max())} is out of range for its {n} vertices")
            else:
                idx = np.arange(n, dtype=np.int64)
            if idx.size % 3:
                raise FileFormatError(f"{what}: {idx.size} indices is not a whole number of triangles")
            p4 = np.concatenate([pos, np.ones((n, 1))], axis=1) @ world.T
            pos = p4[:, :3]
            if nrm is not None and not np.allclose(world[:3, :3], np.eye(3)):
                with np.errstate(all="ignore"):
                    nrm = nrm @ np.linalg.pinv(world[:3, :3])
            parts.append((pos, idx.reshape(-1, 3), nrm, col, uv))
    if skipped:
        notes.append("glTF attributes not read: " + ", ".join(sorted(skipped)))
    if not parts:
        return MeshData(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), notes=notes)
    offsets = np.cumsum([0] + [p[0].shape[0] for p in parts])
    vertices = np.concatenate([p[0] for p in parts])
    faces = np.concatenate([p[1] + o for p, o in zip(parts, offsets)])

    def merged(k, width_of=None):
        arrs = [p[k] for p in parts]
        if all(a is None for a in arrs):
            return None
        if any(a is None for a in arrs):
            notes.append(f"{('normals', 'colours', 'uvs')[k - 2]} present on some primitives only: dropped")
            return None
        w = max(a.shape[1] for a in arrs)
        return np.concatenate([a if a.shape[1] == w else np.concatenate([a, np.ones((a.shape[0], 1))], 1)
                               for a in arrs])
    return MeshData(vertices, faces, merged(2), merged(3), merged(4), notes)


def write(vertices, faces, normals=None, colors=None, uvs=None, binary: bool = True) -> bytes:
    blobs, views, accessors, attrs = [], [], [], {}
    offset = 0

    def add(arr: np.ndarray, ctype: int, kind: str, target: int, minmax: bool = False) -> int:
        nonlocal offset
        raw = np.ascontiguousarray(arr).tobytes()
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(raw), "target": target})
        acc = {"bufferView": len(views) - 1, "componentType": ctype, "count": int(arr.shape[0]), "type": kind}
        if minmax:
            acc["min"] = arr.min(axis=0).tolist()
            acc["max"] = arr.max(axis=0).tolist()
        accessors.append(acc)
        pad = (-len(raw)) % 4
        blobs.append(raw + b"\0" * pad)
        offset += len(raw) + pad
        return len(accessors) - 1

    attrs["POSITION"] = add(vertices.astype("<f4"), 5126, "VEC3", 34962, minmax=True)
    if normals is not None:
        attrs["NORMAL"] = add(normals.astype("<f4"), 5126, "VEC3", 34962)
    if colors is not None:
        attrs["COLOR_0"] = add(colors.astype("<f4"), 5126, "VEC4" if colors.shape[1] == 4 else "VEC3", 34962)
    if uvs is not None:
        attrs["TEXCOORD_0"] = add(uvs.astype("<f4"), 5126, "VEC2", 34962)
    indices = add(faces.reshape(-1).astype("<u4"), 5125, "SCALAR", 34963)
    payload = b"".join(blobs)
    buffer = {"byteLength": len(payload)}
    if not binary:
        buffer["uri"] = "data:application/octet-stream;base64," + base64.b64encode(payload).decode("ascii")
    doc = {
        "asset": {"version": "2.0", "generator": "lodkit"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": attrs, "indices": indices, "mode": 4}]}],
        "buffers": [buffer], "bufferViews": views, "accessors": accessors,
    }
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    if not binary:
        return text + b"\n"
    text += b" " * ((-len(text)) % 4)
    total = 12 + 8 + len(text) + 8 + len(payload)
    return (struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<II", len(text), _JSON) + text
            + struct.pack("<II", len(payload), _BIN) + payload)
