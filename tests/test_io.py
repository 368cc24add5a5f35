"""lodkit.io: load/save with lodkit's own readers and writers, attributes kept, atomic
writes, clear errors. (Malformed files: test_io_malformed.py; atomic writes under
limits and signals: test_io_atomic.py; the format x attribute table: test_io_attributes.py.)

Precision (why the tolerances below are what they are):

* PLY (binary, the default): coordinates, normals and uvs as float64: bit for bit.
  Colours are stored as 8-bit channels: error <= 0.5/255. ASCII PLY: repr() digits, exact.
* OBJ, OFF: 9 significant digits, read back as float32 (as Open3D's readers did):
  relative error about 6e-8.
* STL, GLB, GLTF: float32 (relative error about 6e-8).

The OBJ reader numbers vertices in the order faces first use them (as Open3D's did), so
round trips compare meshes up to a vertex permutation found by matching positions.
"""
from __future__ import annotations

import errno
import os
import struct
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import shared_mesh
from lodkit.errors import MeshError, MeshIOError
from lodkit.io import SUPPORTED_FORMATS, load, save
from lodkit.mesh import Mesh, _split_at_uv_seams

o3d = pytest.importorskip("open3d")

# relative position tolerance per format (times the largest coordinate), see above
POS_RTOL = {"ply": 0.0, "obj": 2e-7, "off": 2e-7, "stl": 2e-7, "glb": 2e-7, "gltf": 2e-7}
ATTR_TOL = {"ply": 1e-15, "obj": 1e-5, "off": 1e-5, "glb": 1e-6, "gltf": 1e-6}
COLOR_TOL = {"ply": 0.5 / 255 + 1e-9, "off": 1e-8, "obj": 1e-5, "glb": 1e-6, "gltf": 1e-6}
CARRIES = {
    "ply": {"normals", "colors", "uvs"},
    "obj": {"normals", "colors", "uvs"},
    "off": {"normals", "colors", "uvs"},
    "stl": set(),
    "glb": {"normals", "colors", "uvs"},
    "gltf": {"normals", "colors", "uvs"},
}


# ------------------------------------------------------------------ hand-made meshes
OCTA_FACES = np.array(
    [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
)


def octahedron(attributes: bool = True, seed: int = 0) -> Mesh:
    """A closed octahedron with coordinates that float32 and 6 digits cannot hold exactly."""
    rng = np.random.default_rng(seed)
    unit = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    vertices = unit * 1.1 + np.array([0.123456789012345, -2.718281828459045, 3.141592653589793])
    if not attributes:
        return Mesh(vertices, OCTA_FACES)
    normals = unit + rng.normal(scale=0.2, size=(6, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return Mesh(vertices, OCTA_FACES, normals=normals, colors=rng.random((6, 3)), uvs=rng.random((6, 2)))


def grid(nx: int = 5, ny: int = 4, seed: int = 1) -> Mesh:
    """An open, bumpy height field with per-vertex attributes."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(-1.0, 1.0, nx), np.linspace(0.0, 0.7, ny), indexing="ij")
    z = rng.normal(scale=0.05, size=x.shape)
    vertices = np.stack([x, y, z], axis=-1).reshape(-1, 3) * 10.0 / 3.0
    idx = np.arange(nx * ny).reshape(nx, ny)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    normals = rng.normal(size=vertices.shape) + [0, 0, 3]
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    uvs = np.stack([x.ravel() * 0.5 + 0.5, y.ravel() / 0.7], axis=1)
    return Mesh(vertices, faces, normals=normals, colors=rng.random(vertices.shape), uvs=uvs)


def match_vertices(loaded: Mesh, original: Mesh, atol: float) -> np.ndarray:
    """perm with loaded.vertices[i] ~ original.vertices[perm[i]]; asserts a bijection."""
    d = np.linalg.norm(loaded.vertices[:, None, :] - original.vertices[None, :, :], axis=2)
    perm = d.argmin(axis=1)
    assert loaded.n_vertices == original.n_vertices
    assert np.unique(perm).size == perm.size, "two loaded vertices match the same original"
    assert d[np.arange(perm.size), perm].max() <= atol
    return perm


def assert_round_trip(original: Mesh, loaded: Mesh, fmt: str) -> np.ndarray:
    scale = np.abs(original.vertices).max()
    perm = match_vertices(loaded, original, POS_RTOL[fmt] * scale)
    # same faces, same order, same corner order (orientation kept)
    np.testing.assert_array_equal(perm[loaded.faces], original.faces)
    for name in ("normals", "colors", "uvs"):
        got = getattr(loaded, name)
        if name not in CARRIES[fmt] or getattr(original, name) is None:
            assert got is None, f"{fmt}: {name} appeared from nowhere"
            continue
        assert got is not None, f"{fmt}: {name} were lost"
        tol = COLOR_TOL[fmt] if name == "colors" else ATTR_TOL[fmt]
        np.testing.assert_allclose(got, getattr(original, name)[perm], rtol=0, atol=tol, err_msg=f"{fmt} {name}")
    return perm


# ------------------------------------------------------------------ round trips
@pytest.mark.parametrize("fmt", SUPPORTED_FORMATS)
@pytest.mark.parametrize("make", [octahedron, grid], ids=["octahedron", "grid"])
def test_round_trip_keeps_geometry_and_attributes(tmp_path, fmt, make):
    mesh = make()
    path = tmp_path / f"mesh.{fmt}"
    save(mesh, path)
    assert_round_trip(mesh, load(path), fmt)


@pytest.mark.parametrize("fmt", SUPPORTED_FORMATS)
def test_round_trip_without_attributes_adds_none(tmp_path, fmt):
    # Open3D must not invent normals (or anything else) on reading
    mesh = octahedron(attributes=False)
    save(mesh, tmp_path / f"bare.{fmt}")
    loaded = load(tmp_path / f"bare.{fmt}")
    assert loaded.attributes() == {}
    assert_round_trip(mesh, loaded, fmt)


def test_binary_ply_is_exact_and_binary(tmp_path):
    mesh = grid(7, 6)
    save(mesh, tmp_path / "g.ply")
    header = (tmp_path / "g.ply").read_bytes()[:400]
    assert b"format binary_little_endian" in header and b"property double x" in header
    loaded = load(tmp_path / "g.ply")
    np.testing.assert_array_equal(loaded.vertices, mesh.vertices)   # bit for bit, same order
    np.testing.assert_array_equal(loaded.faces, mesh.faces)
    np.testing.assert_allclose(loaded.normals, mesh.normals, rtol=0, atol=1e-15)
    np.testing.assert_allclose(loaded.colors, mesh.colors, rtol=0, atol=0.5 / 255 + 1e-9)
    np.testing.assert_array_equal(loaded.uvs, mesh.uvs)   # texture_u/texture_v, float64


def test_ascii_ply_on_request(tmp_path):
    mesh = octahedron()
    save(mesh, tmp_path / "a.ply", ascii=True)
    assert b"format ascii 1.0" in (tmp_path / "a.ply").read_bytes()[:100]
    loaded = load(tmp_path / "a.ply")
    np.testing.assert_array_equal(loaded.vertices, mesh.vertices)  # repr() digits: exact
    np.testing.assert_array_equal(loaded.faces, mesh.faces)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-1e30, 1e30, allow_nan=False, allow_infinity=False, width=64), min_size=9, max_size=9))
def test_ply_positions_are_bit_exact_for_any_finite_double(tmp_path_factory, coords):
    mesh = Mesh(np.array(coords).reshape(3, 3), [[0, 1, 2]])
    path = tmp_path_factory.mktemp("ply") / "t.ply"
    save(mesh, path)
    loaded = load(path)
    np.testing.assert_array_equal(loaded.vertices, mesh.vertices)


def seamed_octahedron() -> o3d.geometry.TriangleMesh:
    """Open3D octahedron whose vertex 0 has uv (0.9, 0.5) in its first faces and (0.1, 0.5)
    in the others: a uv seam through one vertex."""
    base = octahedron(attributes=False)
    m = o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector(base.vertices), o3d.utility.Vector3iVector(OCTA_FACES.astype(np.int32))
    )
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 1.0], [0.5, 0.0], [0.5, 0.5], [0.5, 0.25]])
    corner = uv[OCTA_FACES.reshape(-1)]
    for f in (0, 3):                       # faces 0 and 3 see vertex 0 at one uv ...
        corner[3 * f + list(OCTA_FACES[f]).index(0)] = [0.9, 0.5]
    for f in (4, 7):                       # ... faces 4 and 7 at another
        corner[3 * f + list(OCTA_FACES[f]).index(0)] = [0.1, 0.5]
    m.triangle_uvs = o3d.utility.Vector2dVector(corner)
    return m


@pytest.mark.parametrize("fmt", ["obj", "glb", "gltf"])
def test_uv_seams_survive_a_round_trip(tmp_path, fmt):
    mesh = Mesh.from_open3d(seamed_octahedron())
    assert mesh.n_vertices == 7            # vertex 0 split in two along the seam
    save(mesh, tmp_path / f"seam.{fmt}")
    loaded = load(tmp_path / f"seam.{fmt}")
    assert loaded.n_vertices == 7 and loaded.n_faces == 8
    # the per-corner (position, uv) pairs are the same, face by face
    def key(m):
        return np.concatenate([m.vertices[m.faces.reshape(-1)], m.uvs[m.faces.reshape(-1)]], axis=1)

    np.testing.assert_allclose(key(loaded), key(mesh), rtol=0, atol=1e-5)


def test_obj_with_uvs_is_one_file(tmp_path):
    # no material is written (a lodkit Mesh has no texture), so no .mtl beside the file
    save(octahedron(), tmp_path / "o.obj")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.obj"]
    assert "mtllib" not in (tmp_path / "o.obj").read_text()


def test_gltf_embeds_its_buffer(tmp_path):
    save(octahedron(), tmp_path / "g.gltf")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.gltf"]
    assert '"uri":"data:application/octet-stream;base64,' in (tmp_path / "g.gltf").read_text()


def test_glb_reads_back_and_open3d_reads_it_too(tmp_path):
    mesh = grid()
    save(mesh, tmp_path / "g.glb")
    assert (tmp_path / "g.glb").read_bytes()[:4] == b"glTF"
    assert load(tmp_path / "g.glb").n_faces == mesh.n_faces
    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        om = o3d.io.read_triangle_mesh(str(tmp_path / "g.glb"))
    assert len(om.triangles) == mesh.n_faces


def test_save_accepts_open3d_meshes(tmp_path):
    m = o3d.geometry.TriangleMesh.create_octahedron(radius=2.0)
    m.compute_vertex_normals()
    m.paint_uniform_color([0.2, 0.4, 0.6])
    save(m, tmp_path / "o.ply")
    loaded = load(tmp_path / "o.ply")
    np.testing.assert_array_equal(loaded.vertices, np.asarray(m.vertices))
    np.testing.assert_array_equal(loaded.faces, np.asarray(m.triangles))
    np.testing.assert_allclose(loaded.colors, np.asarray(m.vertex_colors), atol=0.5 / 255)
    save(o3d.t.geometry.TriangleMesh.from_legacy(m), tmp_path / "t.ply")
    assert load(tmp_path / "t.ply").n_faces == 8


def test_open3d_uvs_do_not_split_vertices_in_formats_without_uvs(tmp_path):
    save(seamed_octahedron(), tmp_path / "s.stl")
    assert load(tmp_path / "s.stl").n_vertices == 6
    save(seamed_octahedron(), tmp_path / "s.ply")          # PLY holds uvs: the seam copy stays
    assert load(tmp_path / "s.ply").n_vertices == 7
    save(seamed_octahedron(), tmp_path / "s.obj")
    assert load(tmp_path / "s.obj").n_vertices == 7


def test_extensions_are_case_insensitive(tmp_path):
    save(octahedron(), tmp_path / "UPPER.PLY")
    assert load(tmp_path / "UPPER.PLY").n_faces == 8


def test_save_overwrites_and_accepts_str_paths(tmp_path):
    target = str(tmp_path / "o.ply")
    save(octahedron(), target)
    save(grid(), target)
    assert load(target).n_faces == grid().n_faces


# ------------------------------------------------------------------ STL
def write_binary_stl(path: Path, triangles: np.ndarray) -> None:
    triangles = np.asarray(triangles, dtype=np.float32).reshape(-1, 3, 3)
    with open(path, "wb") as fh:
        fh.write(b"\0" * 80 + struct.pack("<I", len(triangles)))
        for tri in triangles:
            fh.write(struct.pack("<3f", 0, 0, 0) + tri.tobytes() + b"\0\0")


def edge_face_counts(mesh: Mesh) -> np.ndarray:
    e = np.sort(mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(e, axis=0, return_counts=True)[1]


def test_stl_is_welded_into_a_connected_mesh(tmp_path):
    mesh = octahedron()
    save(mesh, tmp_path / "o.stl")
    loaded = load(tmp_path / "o.stl")
    assert loaded.n_vertices == 6 and loaded.n_faces == 8
    assert np.all(edge_face_counts(loaded) == 2)     # closed: every edge has two faces
    assert loaded.attributes() == {}                 # Open3D's vertex normals are not kept
    # welded vertices come in the order faces first use them: 0, 2, 4, 1, 3, 5 here
    perm = match_vertices(loaded, mesh, 2e-7 * np.abs(mesh.vertices).max())
    np.testing.assert_array_equal(perm, [0, 2, 4, 1, 3, 5])
    np.testing.assert_array_equal(perm[loaded.faces], mesh.faces)


def test_stl_welds_exactly_equal_positions_only(tmp_path):
    # two triangles sharing an edge, one of its ends written as -0.0 in one triangle;
    # a third triangle whose corner is 1e-6 away from a shared corner stays separate
    tris = [
        [[0.0, 0.0, 0.0], [1, 0, 0], [0, 1, 0]],
        [[1, 0, 0], [1, 1, 0], [-0.0, 1, -0.0]],
        [[1, 1, 1e-6], [2, 1, 0], [2, 2, 0]],
    ]
    write_binary_stl(tmp_path / "t.stl", tris)
    loaded = load(tmp_path / "t.stl")
    assert loaded.n_faces == 3
    assert loaded.n_vertices == 4 + 3
    np.testing.assert_array_equal(loaded.faces[:2], [[0, 1, 2], [1, 3, 2]])


# ------------------------------------------------------------------ normals policy
def write_obj(path: Path, vertices, faces, normals=None) -> None:
    lines = ["v {:.17g} {:.17g} {:.17g}".format(*row) for row in vertices]
    if normals is not None:
        lines += ["vn {:.17g} {:.17g} {:.17g}".format(*row) for row in normals]
        lines += ["f " + " ".join(f"{i + 1}//{i + 1}" for i in f) for f in faces]
    else:
        lines += ["f " + " ".join(str(i + 1) for i in f) for f in faces]
    path.write_text("\n".join(lines) + "\n")


def test_all_zero_normals_are_dropped(tmp_path):
    mesh = octahedron(attributes=False)
    write_obj(tmp_path / "z.obj", mesh.vertices, mesh.faces, normals=np.zeros((6, 3)))
    loaded = load(tmp_path / "z.obj")
    assert loaded.normals is None


def test_unnormalised_normals_are_scaled_to_unit_length(tmp_path):
    mesh = octahedron(attributes=False)
    normals = (mesh.vertices - mesh.vertices.mean(axis=0)) * 3.0
    normals[2] = 0.0                                       # one zero normal stays zero
    write_obj(tmp_path / "n.obj", mesh.vertices, mesh.faces, normals=normals)
    loaded = load(tmp_path / "n.obj")
    perm = match_vertices(loaded, mesh, 1e-5)
    length = np.linalg.norm(loaded.normals, axis=1)
    np.testing.assert_allclose(length[perm != 2], 1.0, atol=1e-12)
    assert length[perm == 2] == 0.0


def test_files_without_normals_load_without_normals(tmp_path):
    mesh = octahedron(attributes=False)
    write_obj(tmp_path / "p.obj", mesh.vertices, mesh.faces)
    assert load(tmp_path / "p.obj").normals is None


# ------------------------------------------------------------------ atomic writes
def listing(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir())


def test_successful_save_leaves_only_the_target(tmp_path):
    save(octahedron(), tmp_path / "o.ply")
    assert listing(tmp_path) == ["o.ply"]


def test_saved_file_has_ordinary_permissions(tmp_path):
    # a new file gets 0o666 less the umask, as a plain open() would (the test may read the
    # umask by setting it; lodkit never does)
    save(octahedron(), tmp_path / "o.ply")
    umask = os.umask(0)
    os.umask(umask)
    assert (tmp_path / "o.ply").stat().st_mode & 0o777 == 0o666 & ~umask


@pytest.mark.parametrize("fmt", SUPPORTED_FORMATS)
def test_failing_encoder_leaves_no_target_and_no_temporary(tmp_path, monkeypatch, fmt):
    import lodkit.io

    module = {"glb": "gltf"}.get(fmt, fmt)

    def broken(*args, **kwargs):
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(getattr(lodkit.io, module), "write", broken)
    with pytest.raises(RuntimeError, match="disk on fire"):
        save(octahedron(), tmp_path / f"o.{fmt}")
    assert listing(tmp_path) == []


@pytest.mark.parametrize("fmt", SUPPORTED_FORMATS)
def test_a_write_that_does_not_read_back_keeps_the_previous_file(tmp_path, monkeypatch, fmt):
    import lodkit.io

    save(octahedron(attributes=False), tmp_path / f"o.{fmt}")
    before = (tmp_path / f"o.{fmt}").read_bytes()
    monkeypatch.setitem(lodkit.io._COUNTS, fmt, lambda data: (1, 1))
    with pytest.raises(MeshIOError, match=r"reads back 1 vertices and 1 faces") as info:
        save(grid(), tmp_path / f"o.{fmt}")
    assert str(tmp_path / f"o.{fmt}") in str(info.value)
    assert (tmp_path / f"o.{fmt}").read_bytes() == before
    assert listing(tmp_path) == [f"o.{fmt}"]


def test_failing_rename_leaves_no_temporary(tmp_path, monkeypatch):
    import lodkit.io.atomic

    def refuse(src, dst):
        raise OSError(errno.EXDEV, "Invalid cross-device link")

    monkeypatch.setattr(lodkit.io.atomic.os, "replace", refuse)
    with pytest.raises(MeshIOError, match="cannot save .*Invalid cross-device link") as info:
        save(octahedron(), tmp_path / "o.ply")
    assert info.value.errno == errno.EXDEV
    assert listing(tmp_path) == []


def test_save_into_missing_directory(tmp_path):
    with pytest.raises(MeshIOError, match="does not exist") as info:
        save(octahedron(), tmp_path / "nope" / "o.ply")
    assert info.value.errno == errno.ENOENT
    assert not (tmp_path / "nope").exists()


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root can write to read-only directories")
def test_save_into_unwritable_directory(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        with pytest.raises(MeshIOError, match="locked"):
            save(octahedron(), locked / "o.ply")
        assert listing(locked) == []
    finally:
        locked.chmod(0o700)


def test_save_onto_a_directory(tmp_path):
    (tmp_path / "d.ply").mkdir()
    with pytest.raises(MeshIOError, match="directory"):
        save(octahedron(), tmp_path / "d.ply")


def test_save_rejects_unknown_extension(tmp_path):
    with pytest.raises(MeshIOError) as info:
        save(octahedron(), tmp_path / "o.fbx")
    msg = str(info.value)
    assert "o.fbx" in msg and all("." + ext in msg for ext in SUPPORTED_FORMATS)
    assert listing(tmp_path) == []


def test_save_rejects_a_mesh_without_faces(tmp_path):
    with pytest.raises(MeshError, match="no faces"):
        save(Mesh(np.zeros((3, 3)), np.zeros((0, 3), int)), tmp_path / "e.ply")
    assert listing(tmp_path) == []


def test_save_rejects_other_objects(tmp_path):
    with pytest.raises(TypeError, match="lodkit.Mesh"):
        save((np.zeros((3, 3)), [[0, 1, 2]]), tmp_path / "t.ply")


def test_save_rejects_an_invalid_open3d_mesh_naming_the_file(tmp_path):
    m = octahedron(attributes=False).to_open3d()
    np.asarray(m.vertices)[1] = np.nan
    with pytest.raises(MeshError, match=r"o\.ply.*NaN"):
        save(m, tmp_path / "o.ply")
    assert listing(tmp_path) == []


# ------------------------------------------------------------------ load errors
def test_load_missing_file(tmp_path):
    path = tmp_path / "missing.ply"
    with pytest.raises(MeshIOError, match="no such file") as info:
        load(path)
    assert str(path) in str(info.value)
    assert isinstance(info.value, OSError) and info.value.errno == errno.ENOENT


def test_load_unknown_extension(tmp_path):
    path = tmp_path / "mesh.xyz"
    path.write_text("0 0 0\n")
    with pytest.raises(MeshIOError) as info:
        load(path)
    msg = str(info.value)
    assert str(path) in msg and "'.xyz'" in msg and ".ply" in msg and ".glb" in msg
    with pytest.raises(MeshIOError, match="no extension"):
        load(tmp_path / "mesh")


def test_load_a_directory(tmp_path):
    (tmp_path / "d.obj").mkdir()
    with pytest.raises(MeshIOError, match="directory"):
        load(tmp_path / "d.obj")


@pytest.mark.parametrize("fmt", SUPPORTED_FORMATS)
def test_load_empty_file(tmp_path, fmt):
    (tmp_path / f"e.{fmt}").write_bytes(b"")
    with pytest.raises(MeshIOError, match="empty"):
        load(tmp_path / f"e.{fmt}")


@pytest.mark.parametrize("fmt", SUPPORTED_FORMATS)
@pytest.mark.parametrize("content", [b"this is not a mesh\n" * 20, bytes(range(256)) * 8], ids=["text", "binary"])
def test_load_garbage(tmp_path, fmt, content):
    path = tmp_path / f"garbage.{fmt}"
    path.write_bytes(content)
    with pytest.raises(MeshIOError) as info:
        load(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(
    "name, content",
    [
        ("points.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                       b"property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n"),
        ("points.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"),
        ("points.off", b"OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n"),
    ],
)
def test_load_file_without_triangles(tmp_path, name, content):
    (tmp_path / name).write_bytes(content)
    with pytest.raises(MeshIOError, match="no triangles") as info:
        load(tmp_path / name)
    assert name in str(info.value)


def test_load_truncated_ply_is_refused_before_open3d_allocates(tmp_path):
    # a header claiming a billion vertices made Open3D try to allocate ~24 GB
    header = (b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\n"
              b"property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n"
              b"end_header\n")
    (tmp_path / "big.ply").write_bytes(header + b"\0" * 100)
    with pytest.raises(MeshIOError, match="truncated or corrupt"):
        load(tmp_path / "big.ply")
    (tmp_path / "big.off").write_bytes(b"OFF\n1000000000 1 0\n0 0 0\n")
    with pytest.raises(MeshIOError, match="truncated or corrupt"):
        load(tmp_path / "big.off")


@pytest.mark.parametrize("fmt", ["ply", "off"])
@pytest.mark.parametrize("cut", [3, 40, 300])   # bytes cut off the end
def test_load_truncated_data(tmp_path, fmt, cut):
    # Open3D returns the faces it read before the end of the data, logging only a warning
    save(grid(), tmp_path / f"g.{fmt}")
    data = (tmp_path / f"g.{fmt}").read_bytes()
    (tmp_path / f"cut.{fmt}").write_bytes(data[: len(data) - cut])
    with pytest.raises(MeshIOError, match="truncated or corrupt") as info:
        load(tmp_path / f"cut.{fmt}")
    assert f"cut.{fmt}" in str(info.value)


def test_load_nan_coordinates_raises_mesh_error_naming_the_file(tmp_path):
    path = tmp_path / "nan.obj"
    path.write_text("v 0 0 0\nv 1 nan 0\nv 0 1 inf\nf 1 2 3\n")
    with pytest.raises(MeshError, match="NaN or inf") as info:
        load(path)
    assert str(path) in str(info.value)
    assert not isinstance(info.value, MeshIOError)


def test_load_out_of_range_face_raises_mesh_error_naming_the_file(tmp_path):
    # Open3D's OFF reader passes index 7 of 3 vertices through
    path = tmp_path / "bad.off"
    path.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
    with pytest.raises(MeshError, match="outside") as info:
        load(path)
    assert str(path) in str(info.value)


def test_load_does_not_print_open3d_warnings(tmp_path, capfd):
    (tmp_path / "g.ply").write_bytes(b"not a ply at all")
    (tmp_path / "g.glb").write_bytes(b"glTF" + bytes(100))
    for name in ("g.ply", "g.glb"):
        with pytest.raises(MeshIOError):
            load(tmp_path / name)
    save(octahedron(), tmp_path / "o.stl")          # Open3D warns about dropped attributes
    out, err = capfd.readouterr()
    assert "Open3D" not in out + err


# ------------------------------------------------------------------ Mesh <-> Open3D
def test_from_open3d_copies_the_arrays():
    m = o3d.geometry.TriangleMesh.create_octahedron()
    m.compute_vertex_normals()
    mesh = Mesh.from_open3d(m)
    np.asarray(m.vertices)[0] = 99.0
    np.asarray(m.vertex_normals)[0] = 0.0
    assert mesh.vertices[0, 0] != 99.0 and np.linalg.norm(mesh.normals[0]) > 0.5


def test_from_open3d_splits_seams_keeping_vertex_indices():
    m = seamed_octahedron()
    m.vertex_colors = o3d.utility.Vector3dVector(np.eye(3)[[0, 1, 2, 0, 1, 2]])
    mesh = Mesh.from_open3d(m)
    assert mesh.n_vertices == 7
    np.testing.assert_array_equal(mesh.vertices[:6], np.asarray(m.vertices))   # originals in place
    np.testing.assert_array_equal(mesh.vertices[6], mesh.vertices[0])          # the seam copy
    np.testing.assert_array_equal(mesh.colors[6], mesh.colors[0])
    np.testing.assert_array_equal(mesh.uvs[0], [0.9, 0.5])   # exact: parsed from text; uv of first use
    np.testing.assert_array_equal(mesh.uvs[6], [0.1, 0.5])   # exact: parsed from text
    # every corner sees the position and uv it had
    corner = np.asarray(m.triangle_uvs)
    np.testing.assert_array_equal(mesh.uvs[mesh.faces.reshape(-1)], corner)
    np.testing.assert_array_equal(mesh.vertices[mesh.faces], np.asarray(m.vertices)[OCTA_FACES])


def test_from_open3d_out_of_range_faces_with_uvs_is_a_mesh_error():
    m = seamed_octahedron()
    np.asarray(m.triangles)[0, 0] = 17
    with pytest.raises(MeshError, match="outside"):
        Mesh.from_open3d(m)


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(1, 8),
    data=st.data(),
)
def test_split_at_uv_seams_properties(n, data):
    m = data.draw(st.integers(1, 10))
    face = st.lists(st.integers(0, n - 1), min_size=3, max_size=3)
    faces = np.array(data.draw(st.lists(face, min_size=m, max_size=m)))
    palette = np.array([[0.0, 0.0], [0.5, 0.25], [1.0, 1.0]])
    corner_uv = palette[data.draw(st.lists(st.integers(0, 2), min_size=3 * m, max_size=3 * m))]
    vertices = np.arange(3 * n, dtype=float).reshape(n, 3)
    colors = np.linspace(0, 1, 3 * n).reshape(n, 3)
    nv, nf, uvs, extra = _split_at_uv_seams(vertices, faces, corner_uv, {"colors": colors, "normals": None})
    assert nv.shape[0] == uvs.shape[0] == extra["colors"].shape[0] and extra["normals"] is None
    np.testing.assert_array_equal(nv[:n], vertices)                   # input vertices keep their index
    np.testing.assert_array_equal(nv[nf], vertices[faces])            # every corner keeps its position
    np.testing.assert_array_equal(uvs[nf.reshape(-1)], corner_uv)     # ... and its uv
    pairs = {(int(v), *uv) for v, uv in zip(faces.reshape(-1), corner_uv)}
    assert nv.shape[0] == n + len(pairs) - len({p[0] for p in pairs})  # one vertex per distinct pair


# ------------------------------------------------------------------ real meshes
def test_real_bunny_ply():
    mesh = load(shared_mesh("bunny.ply"))
    assert (mesh.n_vertices, mesh.n_faces) == (35947, 69451)   # unreferenced vertices kept
    assert mesh.attributes() == {}                              # confidence/intensity ignored


def test_real_cow_obj_keeps_the_file_order():
    path = shared_mesh("cow.obj")
    mesh = load(path)
    assert (mesh.n_vertices, mesh.n_faces) == (2903, 5804)
    rows = [line.split() for line in path.read_text().splitlines()]
    v = np.array([r[1:4] for r in rows if r and r[0] == "v"], dtype=float)
    f = np.array([[int(t.split("/")[0]) - 1 for t in r[1:4]] for r in rows if r and r[0] == "f"])
    np.testing.assert_allclose(mesh.vertices, v, rtol=1e-6)   # Open3D parses OBJ as float32
    np.testing.assert_array_equal(mesh.faces, f)


def test_real_spot_obj_has_the_files_uvs():
    path = shared_mesh("spot_triangulated.obj")
    mesh = load(path)
    assert mesh.n_faces == 5856 and mesh.uvs is not None
    assert mesh.n_vertices == 3225                    # 2930 positions split along uv seams
    assert np.unique(mesh.vertices, axis=0).shape[0] == 2930
    rows = [line.split() for line in path.read_text().splitlines()]
    v = np.array([r[1:4] for r in rows if r and r[0] == "v"], dtype=float)
    vt = np.array([r[1:3] for r in rows if r and r[0] == "vt"], dtype=float)
    fv = np.array([[int(t.split("/")[0]) - 1 for t in r[1:4]] for r in rows if r and r[0] == "f"])
    ft = np.array([[int(t.split("/")[1]) - 1 for t in r[1:4]] for r in rows if r and r[0] == "f"])
    np.testing.assert_allclose(mesh.vertices[mesh.faces], v[fv], rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(mesh.uvs[mesh.faces], vt[ft], rtol=0, atol=1e-7)


def test_real_colored_airplane_ply_has_colours():
    mesh = load(shared_mesh("colored_airplane.ply"))
    assert (mesh.n_vertices, mesh.n_faces) == (7017, 10796)
    assert mesh.colors is not None and mesh.colors.shape == (7017, 4)     # alpha kept
    assert 0.0 <= mesh.colors.min() and mesh.colors.max() <= 1.0
    assert np.unique(np.round(mesh.colors * 255), axis=0).shape[0] == 1115   # MANIFEST.md


def test_real_inf_nan_obj_raises_mesh_error():
    path = shared_mesh("broken_inf_nan.obj")
    with pytest.raises(MeshError, match="NaN or inf") as info:
        load(path)
    assert str(path) in str(info.value)


def test_real_test_nm_obj_normals_are_unit_or_dropped():
    # MeshLab wrote zero normals for its 17 unreferenced vertices (Open3D drops those
    # vertices) and unnormalised ones (length 3..6) for the others
    mesh = load(shared_mesh("broken_test_nm.obj"))
    assert (mesh.n_vertices, mesh.n_faces) == (97, 170)
    assert mesh.normals is not None
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("name", ["fandisk.obj", "boot.obj", "mountain.obj", "broken_bunny_res2.ply",
                                  "broken_deg_faces.obj", "broken_non_manifold_wrap.obj"])
def test_real_meshes_load(mesh_dir, name):
    mesh = load(mesh_dir / name)
    assert mesh.n_faces > 0 and mesh.vertices.dtype == np.float64 and mesh.faces.dtype == np.int32


@pytest.mark.parametrize("fmt", SUPPORTED_FORMATS)
def test_real_spot_round_trips_through_every_format(tmp_path, fmt):
    mesh = load(shared_mesh("spot_triangulated.obj"))
    save(mesh, tmp_path / f"spot.{fmt}")
    loaded = load(tmp_path / f"spot.{fmt}")
    assert loaded.n_faces == mesh.n_faces
    # STL has no uvs, so welding merges the seam copies back into 2930 positions
    assert loaded.n_vertices == (2930 if fmt == "stl" else 3225)
    assert (loaded.uvs is not None) == ("uvs" in CARRIES[fmt])
    def corners(m):
        return m.vertices[m.faces]

    np.testing.assert_allclose(corners(loaded), corners(mesh), rtol=0, atol=1e-5)


def test_real_bunny_ply_round_trip_is_exact(tmp_path):
    mesh = load(shared_mesh("bunny.ply"))
    save(mesh, tmp_path / "bunny.ply")
    loaded = load(tmp_path / "bunny.ply")
    np.testing.assert_array_equal(loaded.vertices, mesh.vertices)
    np.testing.assert_array_equal(loaded.faces, mesh.faces)


def test_atomic_write_replaces_whole_or_leaves_the_target(tmp_path):
    from lodkit.io import atomic_write

    target = tmp_path / "out.txt"
    atomic_write(target, lambda fh: fh.write("first"))
    assert target.read_text() == "first"

    def broken(fh):
        fh.write("half")
        raise RuntimeError("disk on fire")

    with pytest.raises(RuntimeError, match="disk on fire"):
        atomic_write(target, broken)
    assert target.read_text() == "first"                       # untouched
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]  # no temporary left behind
    atomic_write(target, lambda fh: fh.write(b"\x00bytes"), binary=True)
    assert target.read_bytes() == b"\x00bytes"


@pytest.mark.parametrize("fmt", ["glb", "gltf"])
def test_gltf_declares_only_what_it_uses_and_colours_are_vertex_colours(tmp_path, fmt):
    import json
    import struct

    mesh = octahedron()
    mesh = Mesh(mesh.vertices, mesh.faces, normals=mesh.normals, colors=mesh.colors)     # colours, no uvs
    path = tmp_path / f"c.{fmt}"
    save(mesh, path)
    raw = path.read_bytes()
    if fmt == "glb":
        (n,) = struct.unpack_from("<I", raw, 12)
        assert len(raw) == struct.unpack_from("<I", raw, 8)[0] and n % 4 == 0
        doc = json.loads(raw[20:20 + n])
    else:
        doc = json.loads(raw)
    assert "extensionsUsed" not in doc and "extensionsRequired" not in doc
    prims = [p for m in doc["meshes"] for p in m["primitives"]]
    assert all("COLOR_0" in p["attributes"] and "material" not in p for p in prims)
    back = load(path)
    rows = np.argmin(np.linalg.norm(back.vertices[:, None] - mesh.vertices[None], axis=2), axis=1)
    np.testing.assert_allclose(back.colors[:, :3], mesh.colors[rows, :3], atol=COLOR_TOL[fmt])
    trimesh = pytest.importorskip("trimesh")
    tm = trimesh.load(path, force="mesh")
    assert tm.visual.kind == "vertex"                 # COLOR_0 read as vertex colours, not a texture
    assert len(tm.visual.vertex_colors) == len(tm.vertices)


def test_big_endian_ply_with_polygons_and_extra_elements(tmp_path):
    head = (b"ply\nformat binary_big_endian 1.0\ncomment x\nelement vertex 4\nproperty double x\n"
            b"property double y\nproperty double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
            b"element face 1\nproperty list uchar uint vertex_indices\nproperty float quality\n"
            b"element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n")
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    rows = np.zeros(4, dtype=[("p", ">f8", (3,)), ("c", "u1", (3,))])
    rows["p"] = v
    rows["c"] = [[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]]
    face = bytes([4]) + np.array([0, 1, 2, 3], ">u4").tobytes() + np.array([0.5], ">f4").tobytes()
    edge = np.array([0, 1], ">i4").tobytes()
    (tmp_path / "be.ply").write_bytes(head + rows.tobytes() + face + edge)
    mesh = load(tmp_path / "be.ply")
    np.testing.assert_array_equal(mesh.vertices, v)
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2], [0, 2, 3]])
    np.testing.assert_array_equal(mesh.colors[2], [0, 0, 1])
    notes = " ".join(mesh.metadata["load_notes"])
    assert "fan-triangulated" in notes and "quality" in notes and "'edge'" in notes
