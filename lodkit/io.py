"""Reading and writing mesh files through Open3D: PLY, OBJ, OFF, STL, GLB/GLTF.

Open3D is imported inside the functions, never at module import, so ``import lodkit``
stays fast. What each format carries (and what Open3D 0.20 keeps of it):

======  =================================  ===========================================
format  attributes written and read back    coordinates
======  =================================  ===========================================
PLY     normals, colours (8-bit)            binary little-endian float64: exact
OBJ     normals, colours, uvs               text, 6 significant digits on writing
OFF     normals, colours (8-bit)            text, 6 significant digits on writing
STL     none (face normals only)            float32; unconnected triangles, welded on load
GLB     normals, colours, uvs               float32 (written through ``open3d.t.io``)
GLTF    normals, colours, uvs               float32, plus a ``<name>.bin`` buffer file
======  =================================  ===========================================

Open3D's OBJ and OFF readers parse coordinates as float32 whatever the file holds; its
OBJ and glTF readers renumber vertices in the order faces first use them and drop
vertices no face uses. Alpha channels are dropped (Open3D keeps RGB only).
"""
from __future__ import annotations

import errno
import os
import re
import secrets
import shutil
import tempfile
from pathlib import Path
from typing import Union

import numpy as np

from .deps import open3d as import_open3d
from .errors import MeshError, MeshIOError
from .mesh import Mesh, as_mesh

__all__ = ["load", "save", "SUPPORTED_FORMATS"]

#: File extensions :func:`load` and :func:`save` understand (lower case, without the dot).
SUPPORTED_FORMATS = ("ply", "obj", "off", "stl", "glb", "gltf")

# Which per-vertex attributes each format carries through Open3D's writers and readers.
_CARRIES = {
    "ply": {"normals", "colors"},
    "obj": {"normals", "colors", "uvs"},
    "off": {"normals", "colors"},
    "stl": set(),
    "glb": {"normals", "colors", "uvs"},
    "gltf": {"normals", "colors", "uvs"},
}

PathLike = Union[str, "os.PathLike[str]"]


# ---------------------------------------------------------------------------- helpers
def _import_open3d():
    """Open3D, or lodkit.errors.DependencyError (an ImportError) saying what to install."""
    return import_open3d()


def _io_error(action: str, path: Path, problem: str, err: int | None = None) -> MeshIOError:
    exc = MeshIOError(f"cannot {action} {path}: {problem}")
    # Only errno is set: OSError.__str__ would replace the message with
    # "[Errno n] strerror: filename" if strerror or filename were set.
    if err is not None:
        exc.errno = err
    return exc


def _o3d_message(exc: BaseException) -> str:
    """Open3D's exception text without its terminal colour codes."""
    return re.sub(r"\x1b\[[0-9;]*m", "", str(exc)).strip()


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


# Sizes of PLY scalar types, for the header sanity check below.
_PLY_TYPE_SIZE = {
    "char": 1, "uchar": 1, "int8": 1, "uint8": 1,
    "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
    "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4,
    "double": 8, "float64": 8,
}


def _check_header(path: Path, fmt: str, head: bytes, size: int) -> int | None:
    """Reject PLY/OFF files whose header declares more elements than the file can hold;
    return the number of faces the header declares (None if unknown).

    Open3D allocates what a header declares before reading the data: a truncated or
    corrupt header claiming a billion vertices makes it try to allocate tens of
    gigabytes. Anything this check cannot parse is left for Open3D to judge.
    """
    if fmt == "ply":
        if not head.startswith(b"ply"):
            raise _io_error("load", path, "not a PLY file (it does not start with 'ply')")
        end = re.search(rb"end_header\r?\n", head)
        if end is None:
            if len(head) < size:
                return None  # header longer than what we read: let Open3D judge
            raise _io_error("load", path, "PLY header has no 'end_header' line (corrupt or truncated file)")
        available = size - end.end()
        binary = True
        needed = 0
        count = 0
        row = 0
        n_faces = None
        for raw in head[: end.start()].decode("latin-1").splitlines():
            words = raw.split()
            if not words:
                continue
            if words[0] == "format" and len(words) > 1:
                binary = words[1] != "ascii"
            elif words[0] == "element" and len(words) == 3:
                needed += count * row
                try:
                    count, row = int(words[2]), 0
                except ValueError:
                    return None
                if words[1] == "face":
                    n_faces = count
            elif words[0] == "property" and len(words) >= 3:
                # smallest row: a binary scalar takes its size, a list at least its count;
                # in ASCII every value takes at least one digit and one separator
                if words[1] == "list":
                    row += _PLY_TYPE_SIZE.get(words[2], 1) if binary else 2
                else:
                    row += _PLY_TYPE_SIZE.get(words[1], 1) if binary else 2
        needed += count * row
        if needed > available + 1:  # +1: an ASCII file may lack its last newline
            raise _io_error(
                "load", path,
                f"PLY header declares elements needing at least {needed} bytes but the file "
                f"holds only {available} bytes after the header (truncated or corrupt file)",
            )
        return n_faces
    elif fmt == "off":
        lines = [ln.split("#", 1)[0].strip() for ln in head.decode("latin-1").splitlines()]
        lines = [ln for ln in lines if ln]
        if not lines or not lines[0].split()[0].endswith("OFF"):
            raise _io_error("load", path, "not an OFF file (it does not start with 'OFF')")
        if lines[0] not in ("OFF", "COFF", "NOFF", "CNOFF") or len(lines) < 2:
            return None  # a variant Open3D may reject with its own diagnosis
        try:
            nv, nf = (int(w) for w in lines[1].split()[:2])
        except ValueError:
            return None
        needed = 6 * nv + 8 * nf  # "0 0 0\n" per vertex, "3 0 1 2\n" per face at least
        if nv < 0 or nf < 0 or needed > size:
            raise _io_error(
                "load", path,
                f"OFF header declares {nv} vertices and {nf} faces but the file has only "
                f"{size} bytes (truncated or corrupt file)",
            )
        return nf
    return None


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


def _weld_exact(mesh: Mesh) -> Mesh:
    """Merge vertices with bit-for-bit equal positions (STL stores unconnected triangles).

    Welded vertices keep the order of their first occurrence. Only used for STL, which
    carries no per-vertex attributes, so nothing can be lost.
    """
    if mesh.n_vertices == 0:
        return mesh
    # + 0.0 turns -0.0 into +0.0 so the two zeros weld too
    _, first, inverse = np.unique(mesh.vertices + 0.0, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return Mesh(mesh.vertices[first[order]], rank[inverse][mesh.faces], metadata=mesh.metadata)


# ---------------------------------------------------------------------------- load
def load(path: PathLike) -> Mesh:
    """Read a triangle mesh file into a :class:`lodkit.Mesh`.

    Supported formats, chosen by extension (case-insensitive): PLY, OBJ, OFF, STL, GLB
    and GLTF, read through Open3D. Attributes the file carries are kept: per-vertex
    normals (scaled to unit length; all-zero placeholder normals are dropped), colours
    (RGB in [0, 1]) and texture coordinates (Open3D's per-corner uvs become per-vertex
    uvs, splitting vertices along uv seams). Nothing Open3D computes on its own is kept:
    the vertex normals Open3D derives from an STL file's face normals are dropped. STL
    files store unconnected triangles; vertices with exactly equal positions are welded
    so the mesh is connected.

    Raises:
        MeshIOError: the file is missing, unreadable, empty, of an unsupported format,
            corrupt, or holds no triangles. The message names the file.
        MeshError: the file reads but its content is not a valid mesh (NaN/inf
            coordinates, face indices out of range). The message names the file.
        ImportError: open3d is not installed.
    """
    p = Path(os.fspath(path))
    fmt = _format_of(p, "load")
    if not p.exists():
        raise _io_error("load", p, "no such file", errno.ENOENT)
    if p.is_dir():
        raise _io_error("load", p, "it is a directory, not a file", errno.EISDIR)
    try:
        size = p.stat().st_size
        with open(p, "rb") as fh:
            head = fh.read(65536)
    except OSError as exc:
        raise _io_error("load", p, f"unreadable file ({exc.strerror or exc})", exc.errno) from exc
    if size == 0:
        raise _io_error("load", p, "the file is empty")
    declared_faces = _check_header(p, fmt, head, size)

    o3d = _import_open3d()
    try:
        with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
            om = o3d.io.read_triangle_mesh(str(p), enable_post_processing=False, print_progress=False)
    except RuntimeError as exc:  # Open3D raises RuntimeError for hard read errors
        raise _io_error("load", p, f"Open3D could not read it ({_o3d_message(exc)})") from exc

    # Open3D returns an empty mesh instead of failing on unreadable files.
    if len(om.triangles) == 0:
        if len(om.vertices) == 0:
            raise _io_error(
                "load", p,
                f"Open3D read no vertices and no triangles: the file is corrupt, truncated "
                f"or not a valid {fmt.upper()} file",
            )
        raise _io_error(
            "load", p,
            f"the file holds {len(om.vertices)} vertices but no triangles (a point cloud, "
            f"or a truncated or corrupt file)",
        )

    if declared_faces is not None and len(om.triangles) < declared_faces:
        # Open3D's PLY and OFF readers stop at the first bad or missing value and return
        # what they read so far (they only log a warning); do not pass off a partial mesh.
        raise _io_error(
            "load", p,
            f"the header declares {declared_faces} faces but only {len(om.triangles)} could "
            f"be read (truncated or corrupt file)",
        )

    if fmt == "stl":
        # Open3D copies STL's per-face normals onto the vertices; they are not the file's
        # vertex normals (and would disagree after welding), so drop them.
        normals = None
    else:
        normals = np.asarray(om.vertex_normals) if om.has_vertex_normals() else None
        normals = _clean_normals(normals)
    if normals is None:
        om.vertex_normals = o3d.utility.Vector3dVector()
    else:
        om.vertex_normals = o3d.utility.Vector3dVector(normals)

    try:
        mesh = Mesh.from_open3d(om)
        if fmt == "stl":
            mesh = _weld_exact(mesh)
    except MeshError as exc:
        raise type(exc)(f"cannot load {p}: {exc}") from exc
    return mesh


# ---------------------------------------------------------------------------- save
def _writable_mesh(mesh, fmt: str, o3d) -> Mesh:
    """A lodkit Mesh for writing: Mesh as is; Open3D meshes (legacy or tensor) converted and
    validated by :func:`lodkit.mesh.as_mesh`, their uvs dropped first when the format cannot
    hold them (converting them would only split vertices).  Anything else is a TypeError."""
    if isinstance(mesh, o3d.t.geometry.TriangleMesh):
        mesh = mesh.to_legacy()
    if isinstance(mesh, o3d.geometry.TriangleMesh) and "uvs" not in _CARRIES[fmt] and mesh.has_triangle_uvs():
        mesh = o3d.geometry.TriangleMesh(mesh)
        mesh.triangle_uvs = o3d.utility.Vector2dVector()
    if isinstance(mesh, (Mesh, o3d.geometry.TriangleMesh)):
        return as_mesh(mesh)
    raise TypeError(
        "save() takes a lodkit.Mesh or an open3d.geometry.TriangleMesh, "
        f"got {type(mesh).__module__}.{type(mesh).__qualname__}"
    )


def _used_extensions(node, found: set) -> set:
    if isinstance(node, dict):
        for key, value in node.items():
            if key == "extensions" and isinstance(value, dict):
                found.update(value)
            _used_extensions(value, found)
    elif isinstance(node, list):
        for value in node:
            _used_extensions(value, found)
    return found


def _tidy_gltf(path: Path, fmt: str, colors_only: bool) -> None:
    """Fix up the glTF JSON Open3D's writer (assimp) produced, in place:

    * ``extensionsUsed`` / ``extensionsRequired`` list only extensions the file uses (assimp
      declares ``KHR_materials_volume`` and ``FB_ngon_encoding`` without using them);
    * with vertex colours and no uvs, the primitive gets no material: readers such as
      trimesh take a primitive with a material for a textured one and file its COLOR_0 as a
      texture attribute; without one, COLOR_0 is the vertex colour (glTF's default material
      multiplies it by white).
    """
    import json
    import struct

    raw = path.read_bytes()
    if fmt == "glb":
        magic, version, _ = struct.unpack_from("<4sII", raw, 0)
        json_len, json_type = struct.unpack_from("<I4s", raw, 12)
        if magic != b"glTF" or version != 2 or json_type != b"JSON":
            return
        doc = json.loads(raw[20:20 + json_len])
        rest = raw[20 + json_len:]
    else:
        doc = json.loads(raw)
    used = _used_extensions({k: v for k, v in doc.items() if not k.startswith("extensions")}, set())
    used |= set(doc.get("extensions", {}))
    for key in ("extensionsUsed", "extensionsRequired"):
        if key in doc:
            doc[key] = [e for e in doc[key] if e in used]
            if not doc[key]:
                del doc[key]
    if colors_only:
        for mesh in doc.get("meshes", []):
            for prim in mesh.get("primitives", []):
                if "COLOR_0" in prim.get("attributes", {}):
                    prim.pop("material", None)
        if not any("material" in prim for mesh in doc.get("meshes", []) for prim in mesh.get("primitives", [])):
            doc.pop("materials", None)
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    if fmt == "glb":
        text += b" " * (-len(text) % 4)             # chunks are 4-byte aligned, JSON padded with spaces
        body = struct.pack("<I4s", len(text), b"JSON") + text + rest
        path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)
    else:
        path.write_bytes(text)


def _fsync_file(path: Path) -> None:
    with open(path, "rb") as fh:
        os.fsync(fh.fileno())


def _fsync_dir(directory: Path) -> None:
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def atomic_write(path, write, binary: bool = False) -> None:
    """Call ``write(file)`` on a temporary file next to ``path``, fsync it, then rename it
    onto ``path``: the target is either left as it was or completely replaced.  The file
    gets the permissions a plain ``open`` would give (0o666 less the umask)."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp", dir=directory)
    try:
        with os.fdopen(fd, "wb" if binary else "w") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def save(mesh, path: PathLike, *, ascii: bool = False) -> None:
    """Write a mesh to a file, atomically; the format is chosen by the extension.

    ``mesh`` is a :class:`lodkit.Mesh` or an ``open3d.geometry.TriangleMesh`` (a tensor
    ``open3d.t.geometry.TriangleMesh`` is converted too; Open3D textures and materials are
    not written). Formats: PLY (binary unless ``ascii=True``; float64 coordinates),
    OBJ, OFF, STL (binary; face normals computed), GLB and GLTF (written through
    ``open3d.t.io``, whose output Open3D reads back, unlike the legacy writer's). Normals,
    colours and uvs are written where the format carries them and silently left out
    where it does not (see the module docstring). OBJ with uvs also writes
    ``<name>.mtl`` and GLTF writes ``<name>.bin`` next to the file, as Open3D does.

    The file is written into a fresh temporary directory next to the target and then
    renamed onto it with :func:`os.replace`, so the target is either left untouched or
    completely replaced, never half written.

    Raises:
        MeshIOError: unsupported extension, missing or unwritable directory, or the
            writer failed. Nothing is left behind. The message names the file.
        MeshError: the mesh has no faces, or an Open3D mesh given is invalid.
        TypeError: ``mesh`` is neither a lodkit nor an Open3D triangle mesh.
    """
    p = Path(os.fspath(path))
    fmt = _format_of(p, "save")
    o3d = _import_open3d()
    try:
        m = _writable_mesh(mesh, fmt, o3d)
    except MeshError as exc:
        raise type(exc)(f"cannot save {p}: {exc}") from exc
    if m.n_faces == 0:
        # load() refuses such files, so do not write one
        raise MeshError(f"cannot save {p}: the mesh has no faces")

    directory = p.parent
    if p.is_dir():
        raise _io_error("save", p, "it is a directory", errno.EISDIR)
    if not directory.is_dir():
        raise _io_error("save", p, f"directory {directory} does not exist", errno.ENOENT)

    carries = _CARRIES[fmt]
    out = Mesh(
        m.vertices,
        m.faces,
        normals=m.normals if "normals" in carries else None,
        colors=m.colors if "colors" in carries else None,
        uvs=m.uvs if "uvs" in carries else None,
    )
    om = out.to_open3d()
    if fmt == "stl":
        om.triangle_normals = o3d.utility.Vector3dVector(out.face_normals())

    # A temporary *directory* rather than a temporary file: OBJ (.mtl) and GLTF (.bin)
    # writers add side files named after the file and reference them by that name inside
    # it, so the file is written under its final name and everything is moved in place.
    tmp_dir = directory / f".{p.name}.tmp-{os.getpid()}-{secrets.token_hex(4)}"
    try:
        os.mkdir(tmp_dir, 0o700)
    except OSError as exc:
        raise _io_error(
            "save", p, f"cannot create a temporary in {directory} ({exc.strerror or exc})", exc.errno
        ) from exc
    try:
        tmp = tmp_dir / p.name
        kwargs = dict(
            write_ascii=bool(ascii) and fmt == "ply",  # STL would raise; the rest are text
            compressed=False,
            write_vertex_normals=out.normals is not None,
            write_vertex_colors=out.colors is not None,
            write_triangle_uvs=out.uvs is not None,
            print_progress=False,
        )
        try:
            with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
                if fmt in ("glb", "gltf"):
                    # the legacy writer's GLB cannot be read back (zero triangles) and its
                    # GLTF reads back scrambled; the tensor writer's can
                    ok = o3d.t.io.write_triangle_mesh(str(tmp), o3d.t.geometry.TriangleMesh.from_legacy(om), **kwargs)
                else:
                    ok = o3d.io.write_triangle_mesh(str(tmp), om, **kwargs)
        except (RuntimeError, OSError) as exc:
            raise _io_error("save", p, f"Open3D's writer failed ({_o3d_message(exc)})") from exc
        if not ok:
            raise _io_error("save", p, "Open3D's writer reported failure")
        if not tmp.is_file() or tmp.stat().st_size == 0:
            raise _io_error("save", p, "Open3D's writer reported success but wrote nothing")
        if fmt in ("glb", "gltf"):
            _tidy_gltf(tmp, fmt, colors_only=out.colors is not None and out.uvs is None)
        try:
            side_files = sorted(f for f in tmp_dir.iterdir() if f.name != p.name)
            for f in side_files + [tmp]:
                _fsync_file(f)
            # side files first, the file itself last: once it appears, it is complete
            for f in side_files:
                os.replace(f, directory / f.name)
            os.replace(tmp, p)
        except OSError as exc:
            raise _io_error("save", p, f"cannot move the written file into place ({exc.strerror or exc})",
                            exc.errno) from exc
        _fsync_dir(directory)
    finally:
        shutil.rmtree(tmp_dir, ignore_errors=True)
