"""Reading and writing mesh files: PLY, OBJ, OFF, STL, GLB/GLTF.

lodkit reads and writes every format with its own numpy code (one module per format in
this package); Open3D's readers crashed (segfaults) or returned wrong data on malformed
files, and its writers reported success on failed writes. The readers check a file before
using any of it (header counts against the data, exactly; indices; polygon sizes), so a
malformed file is one :class:`lodkit.MeshIOError` or :class:`lodkit.MeshError` naming it.
Polygons are fan-triangulated, with a note in ``mesh.metadata["load_notes"]``.

Every file is written through :func:`atomic_write`/:func:`lodkit.io.atomic.commit`
(a temporary beside the target, checked, fsynced, renamed). What each format holds
(docs/reliability.md has the full table):

======  =======================  ================================================
format  attributes               coordinates
======  =======================  ================================================
PLY     normals, colours (8-bit  binary little-endian float64: exact
        RGB/RGBA), uvs
OBJ     normals, colours (RGB),  text, 9 significant digits; read as float32
        uvs
OFF     normals, colours (RGB/   text, 9 significant digits; read as float32
        RGBA), uvs (STOFF)
STL     none (face normals)      float32; unconnected triangles, welded on load
GLB     normals, colours (RGB/   float32
        RGBA), uvs
GLTF    as GLB                   float32; the buffer embedded (one file)
======  =======================  ================================================

What a format cannot hold is left out with a :class:`lodkit.errors.DataLossWarning`
(never silently): alpha in OBJ; normals, colours and uvs in STL.
"""
from __future__ import annotations

import errno
import os
import struct
import warnings
from pathlib import Path
from typing import Union

import numpy as np

from ..errors import DataLossWarning, MeshError, MeshIOError
from ..mesh import Mesh, as_mesh
from . import gltf, obj, off, ply, stl
from .atomic import atomic_write, commit
from .common import FileFormatError

__all__ = ["load", "save", "atomic_write", "SUPPORTED_FORMATS", "CARRIES"]

#: File extensions :func:`load` and :func:`save` understand (lower case, without the dot).
SUPPORTED_FORMATS = ("ply", "obj", "off", "stl", "glb", "gltf")

#: Which per-vertex attributes :func:`save` writes in each format ("alpha": colours' 4th channel).
CARRIES = {
    "ply": {"normals", "colors", "alpha", "uvs"},
    "obj": {"normals", "colors", "uvs"},
    "off": {"normals", "colors", "alpha", "uvs"},
    "stl": set(),
    "glb": {"normals", "colors", "alpha", "uvs"},
    "gltf": {"normals", "colors", "alpha", "uvs"},
}

_READERS = {"ply": ply.read, "obj": obj.read, "off": off.read, "stl": stl.read, "glb": gltf.read,
            "gltf": gltf.read}
_COUNTS = {"ply": ply.counts, "obj": obj.counts, "off": off.counts, "stl": stl.counts, "glb": gltf.counts,
           "gltf": gltf.counts}

PathLike = Union[str, "os.PathLike[str]"]


# ---------------------------------------------------------------------------- helpers
def _io_error(action: str, path: Path, problem: str, err: int | None = None) -> MeshIOError:
    exc = MeshIOError(f"cannot {action} {path}: {problem}")
    # Only errno is set: OSError.__str__ would replace the message with
    # "[Errno n] strerror: filename" if strerror or filename were set.
    if err is not None:
        exc.errno = err
    return exc


def _format_of(path: Path, action: str) -> str:
    ext = path.suffix.lower().lstrip(".")
    if ext not in SUPPORTED_FORMATS:
        what = f"extension '{path.suffix}'" if path.suffix else "no extension"
        raise _io_error(
            action, path,
            f"unsupported file format ({what}); supported: "
            + ", ".join("." + e for e in SUPPORTED_FORMATS),
        )
    return ext


def _clean_normals(normals: np.ndarray | None) -> np.ndarray | None:
    """Unit normals, or None when the file's normals carry no information.

    Some exporters write placeholder normals: all-zero ``vn`` lines (MeshLab writes zero
    normals for unreferenced vertices, e.g. broken_test_nm.obj), or unnormalised ones
    (the same file's other normals have lengths 3..6). A zero or non-finite normal says
    nothing about the surface, so such rows become zero; when no row is usable the
    normals are dropped altogether rather than keeping garbage. The rest are scaled to
    unit length, as :class:`lodkit.Mesh` documents.
    """
    if normals is None or normals.shape[0] == 0:
        return None
    normals = np.array(normals, dtype=np.float64)
    finite = np.isfinite(normals).all(axis=1)
    normals[~finite] = 0.0
    length = np.linalg.norm(normals, axis=1)
    usable = length > 0
    if not usable.any():
        return None
    normals[usable] /= length[usable, None]
    return normals


def _weld_exact(vertices: np.ndarray, faces: np.ndarray):
    """Merge vertices with bit-for-bit equal positions (STL stores unconnected triangles),
    keeping the order of their first occurrence (-0.0 and 0.0 weld too)."""
    if vertices.shape[0] == 0:
        return vertices, faces
    _, first, inverse = np.unique(vertices + 0.0, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return vertices[first[order]], rank[inverse][faces]


def read_file(data: bytes, fmt: str, base_dir: str | None = None):
    """The format's reader on ``data``: a :class:`lodkit.io.common.MeshData`; raises
    :class:`lodkit.io.common.FileFormatError` for a malformed file (the fuzzers call this)."""
    if fmt == "gltf" or fmt == "glb":
        return gltf.read(data, base_dir)
    return _READERS[fmt](data)


# ---------------------------------------------------------------------------- load
def load(path: PathLike) -> Mesh:
    """Read a triangle mesh file into a :class:`lodkit.Mesh`.

    Supported formats, chosen by extension (case-insensitive): PLY, OBJ, OFF, STL, GLB
    and GLTF, each read by lodkit's own checked reader (see the module docstring). Kept:
    per-vertex normals (scaled to unit length; all-zero placeholder normals are dropped),
    colours (RGB or RGBA in [0, 1]) and texture coordinates (one vertex per distinct
    position and uv: vertices are split along uv seams). STL files store unconnected
    triangles; vertices with exactly equal positions are welded so the mesh is connected.
    Polygons are fan-triangulated; what the reader did besides reading (triangulated
    polygons, skipped properties or elements) is listed in ``mesh.metadata["load_notes"]``.

    Raises:
        MeshIOError: the file is missing, unreadable, empty, of an unsupported format,
            malformed (its counts disagree with its data, bad indices or values...), or
            holds no triangles. The message names the file and says what is wrong.
        MeshError: the file reads but its content is not a valid mesh (NaN/inf
            coordinates, face indices out of range). The message names the file.
    """
    p = Path(os.fspath(path))
    fmt = _format_of(p, "load")
    if not p.exists():
        raise _io_error("load", p, "no such file", errno.ENOENT)
    if p.is_dir():
        raise _io_error("load", p, "it is a directory, not a file", errno.EISDIR)
    try:
        with open(p, "rb") as fh:
            data = fh.read()
    except OSError as exc:
        raise _io_error("load", p, f"unreadable file ({exc.strerror or exc})", exc.errno) from exc
    if not data:
        raise _io_error("load", p, "the file is empty")
    try:
        got = read_file(data, fmt, str(p.parent))
    except FileFormatError as exc:
        raise _io_error("load", p, f"{exc} (truncated or corrupt {fmt.upper()} file)") from None
    except MemoryError:
        raise _io_error("load", p, "not enough memory to read it") from None
    except (ValueError, IndexError, KeyError, TypeError, OverflowError, struct.error) as exc:
        # a reader bug on a malformed file: still one clear error (the fuzzers look for these)
        raise _io_error("load", p, f"malformed {fmt.upper()} file ({type(exc).__name__}: {exc})") from None
    del data
    if got.faces.shape[0] == 0:
        if got.vertices.shape[0] == 0:
            raise _io_error("load", p, f"the file holds no vertices and no triangles (an empty or not a valid "
                                       f"{fmt.upper()} file)")
        raise _io_error(
            "load", p,
            f"the file holds {got.vertices.shape[0]} vertices but no triangles (a point cloud, "
            f"or a truncated or corrupt file)",
        )
    vertices, faces = got.vertices, got.faces
    if fmt == "stl":
        vertices, faces = _weld_exact(vertices, faces)
    try:
        mesh = Mesh(vertices, faces, normals=_clean_normals(got.normals), colors=got.colors, uvs=got.uvs)
    except MeshError as exc:
        raise type(exc)(f"cannot load {p}: {exc}") from None
    if got.notes:
        mesh.metadata["load_notes"] = list(got.notes)
    return mesh


# ---------------------------------------------------------------------------- save
def _writable_mesh(mesh, fmt: str) -> Mesh:
    """A lodkit Mesh for writing: Mesh as is; Open3D meshes (legacy or tensor) converted and
    validated by :func:`lodkit.mesh.as_mesh`, their uvs dropped first when the format cannot
    hold them (converting them would only split vertices).  Anything else is a TypeError."""
    if isinstance(mesh, Mesh):
        return mesh
    if (type(mesh).__module__ or "").startswith("open3d"):
        import open3d as o3d

        if isinstance(mesh, o3d.t.geometry.TriangleMesh):
            mesh = mesh.to_legacy()
        if isinstance(mesh, o3d.geometry.TriangleMesh):
            if "uvs" not in CARRIES[fmt] and mesh.has_triangle_uvs():
                mesh = o3d.geometry.TriangleMesh(mesh)
                mesh.triangle_uvs = o3d.utility.Vector2dVector()
            return as_mesh(mesh)
    raise TypeError(
        "save() takes a lodkit.Mesh or an open3d.geometry.TriangleMesh, "
        f"got {type(mesh).__module__}.{type(mesh).__qualname__}"
    )


def _encode(m: Mesh, fmt: str, ascii: bool, path: Path) -> bytes:
    carries = CARRIES[fmt]
    lost = [name for name in ("normals", "colors", "uvs") if getattr(m, name) is not None and name not in carries]
    colors = m.colors if "colors" in carries else None
    if colors is not None and colors.shape[1] == 4 and "alpha" not in carries:
        lost.append("alpha")
        colors = colors[:, :3]
    if lost:
        warnings.warn(f"saving {path}: {fmt.upper()} cannot hold the mesh's {', '.join(lost)}; "
                      f"not written (docs/reliability.md lists what each format holds)",
                      DataLossWarning, stacklevel=3)
    normals = m.normals if "normals" in carries else None
    uvs = m.uvs if "uvs" in carries else None
    if fmt == "ply":
        return ply.write(m.vertices, m.faces, normals, colors, uvs, ascii=bool(ascii))
    if fmt == "obj":
        return obj.write(m.vertices, m.faces, normals, colors, uvs)
    if fmt == "off":
        return off.write(m.vertices, m.faces, normals, colors, uvs)
    if fmt == "stl":
        return stl.write(m.vertices, m.faces, m.face_normals())
    return gltf.write(m.vertices, m.faces, normals, colors, uvs, binary=fmt == "glb")


def save(mesh, path: PathLike, *, ascii: bool = False) -> None:
    """Write a mesh to a file, atomically and checked; the format is chosen by the extension.

    ``mesh`` is a :class:`lodkit.Mesh` or an ``open3d.geometry.TriangleMesh`` (a tensor
    ``open3d.t.geometry.TriangleMesh`` is converted too; textures and materials are not
    written). Formats: PLY (binary unless ``ascii=True``; float64 coordinates), OBJ, OFF,
    STL (binary; face normals computed), GLB and GLTF (one self-contained file). Normals,
    colours and uvs are written where the format holds them; what it cannot hold is left out
    with a :class:`lodkit.errors.DataLossWarning` (see the module docstring).

    The bytes go to a temporary file beside the target (``.<name>.lodkit-tmp-<pid>-<hex>``);
    its size and the vertex and face counts read back from it are checked, it is fsynced
    and renamed onto the target: the target is either left as it was or completely
    replaced, never half written, and nothing is left behind (a temporary left by a killed
    process is removed by the next write into that directory). A read-only target is
    refused. See :mod:`lodkit.io.atomic`.

    Raises:
        MeshIOError: unsupported extension, missing or unwritable directory, read-only
            target, the write failed (disk full, file size limit). The message names the file.
        MeshError: the mesh has no faces, or an Open3D mesh given is invalid.
        TypeError: ``mesh`` is neither a lodkit nor an Open3D triangle mesh.
    """
    p = Path(os.fspath(path))
    fmt = _format_of(p, "save")
    try:
        m = _writable_mesh(mesh, fmt)
    except MeshError as exc:
        raise type(exc)(f"cannot save {p}: {exc}") from exc
    if m.n_faces == 0:
        # load() refuses such files, so do not write one
        raise MeshError(f"cannot save {p}: the mesh has no faces")
    if p.is_dir():
        raise _io_error("save", p, "it is a directory", errno.EISDIR)
    if not p.parent.is_dir():
        raise _io_error("save", p, f"directory {p.parent} does not exist", errno.ENOENT)
    payload = _encode(m, fmt, ascii, p)
    expected = (m.n_vertices if fmt != "stl" else 3 * m.n_faces, m.n_faces)

    def produce(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            fh.write(payload)

    def verify(tmp: Path) -> None:
        size = os.path.getsize(tmp)
        if size != len(payload):
            raise _io_error("save", p, f"wrote {len(payload)} bytes but the file holds {size}", errno.EIO)
        with open(tmp, "rb") as fh:
            head = fh.read() if fmt in ("obj", "gltf") else fh.read(1 << 20)
        try:
            got = _COUNTS[fmt](head)
        except (FileFormatError, ValueError, KeyError, IndexError, TypeError) as exc:
            raise _io_error("save", p, f"the written file does not read back ({exc})", errno.EIO) from None
        if tuple(got) != expected:
            raise _io_error("save", p, f"the written file reads back {got[0]} vertices and {got[1]} faces, "
                                       f"expected {expected[0]} and {expected[1]}", errno.EIO)

    try:
        commit(p, produce, verify)
    except MeshIOError as exc:
        msg = str(exc)
        if msg.startswith(f"cannot write {p}"):
            new = MeshIOError("cannot save" + msg[len("cannot write"):])
            new.errno = exc.errno
            raise new from None
        raise
