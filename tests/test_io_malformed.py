"""Malformed files: each is one clear lodkit error naming the file, never a crash, never
wrong data (the reproducers of issue 18, item 1). lodkit reads every format with its own
numpy code (lodkit/io/), so these run in-process; one test also runs the CLI on the file
that made Open3D's reader segfault."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from conftest import lodkit_subprocess_env
from lodkit.errors import LodkitError, MeshError, MeshIOError
from lodkit.io import load, save
from lodkit.mesh import Mesh

TETRA_V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
TETRA_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])

ASCII_PLY_HEAD = (b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                  b"property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                  b"0 0 0\n1 0 0\n1 1 0\n0 1 0\n")


def icosphere() -> Mesh:
    """A 320-face sphere (icosahedron subdivided twice), with colours with alpha."""
    t = (1 + 5 ** 0.5) / 2
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t],
                  [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                  [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    verts = list(map(tuple, v))
    for _ in range(2):
        cache, faces = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                verts.append(tuple((np.array(verts[a]) + np.array(verts[b])) / 2))
                cache[key] = len(verts) - 1
            return cache[key]
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            faces += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        f = np.array(faces)
    v = np.array(verts)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    rng = np.random.default_rng(3)
    return Mesh(v, f, colors=np.concatenate([rng.random((len(v), 3)), rng.random((len(v), 1))], axis=1))


def expect_load_error(path, match, cls=MeshIOError):
    with pytest.raises(cls, match=match) as info:
        load(path)
    assert str(path) in str(info.value)
    return info.value


# ------------------------------------------------------------------ out-of-range indices
@pytest.mark.parametrize("bad", [b"1000000", b"-7", b"9", b"4"])
def test_ascii_ply_face_index_out_of_range(tmp_path, bad):
    path = tmp_path / "r1.ply"
    path.write_bytes(ASCII_PLY_HEAD + b"4 0 1 2 " + bad + b"\n")
    expect_load_error(path, "outside 0..3", MeshError)


@pytest.mark.parametrize("bad", [b"1000000", b"-7", b"9"])
def test_off_face_index_out_of_range(tmp_path, bad):
    path = tmp_path / "r1.off"
    path.write_bytes(b"OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 " + bad + b"\n")
    expect_load_error(path, "outside 0..3", MeshError)


def test_binary_ply_index_out_of_range(tmp_path):
    save(Mesh(TETRA_V, TETRA_F), tmp_path / "t.ply")
    data = bytearray((tmp_path / "t.ply").read_bytes())
    data[-4:] = np.array([7], "<i4").tobytes()
    (tmp_path / "bad.ply").write_bytes(bytes(data))
    expect_load_error(tmp_path / "bad.ply", "outside 0..3", MeshError)


def test_cli_info_on_the_file_that_crashed_open3d(tmp_path):
    path = tmp_path / "r1.ply"
    path.write_bytes(ASCII_PLY_HEAD + b"4 0 1 2 1000000\n")
    proc = subprocess.run([sys.executable, "-m", "lodkit", "info", str(path)], capture_output=True, text=True,
                          cwd=tmp_path, env=lodkit_subprocess_env(), timeout=300)
    assert proc.returncode not in (0, -11, 139), proc
    assert "outside 0..3" in proc.stderr and "Traceback" not in proc.stderr
    assert "RPly" not in proc.stdout + proc.stderr


# ------------------------------------------------------------------ counts against the data
def test_binary_ply_undercounting_its_vertices(tmp_path):
    save(Mesh(TETRA_V, TETRA_F), tmp_path / "t.ply")
    data = (tmp_path / "t.ply").read_bytes().replace(b"element vertex 4", b"element vertex 3")
    (tmp_path / "under.ply").write_bytes(data)
    expect_load_error(tmp_path / "under.ply", "truncated or corrupt")


@pytest.mark.parametrize("ascii", [False, True], ids=["binary", "ascii"])
def test_ply_header_declaring_fewer_faces_than_the_file_holds(tmp_path, ascii):
    save(icosphere(), tmp_path / "s.ply", ascii=ascii)
    data = (tmp_path / "s.ply").read_bytes().replace(b"element face 320", b"element face 220")
    (tmp_path / "fewer.ply").write_bytes(data)
    expect_load_error(tmp_path / "fewer.ply", "more than its header declares")


def test_off_header_declaring_fewer_faces_than_the_file_holds(tmp_path):
    save(icosphere(), tmp_path / "s.off")
    data = (tmp_path / "s.off").read_bytes().replace(b"\n162 320 0\n", b"\n162 220 0\n")
    (tmp_path / "fewer.off").write_bytes(data)
    expect_load_error(tmp_path / "fewer.off", "more data line")


def test_stl_count_disagreeing_with_the_size(tmp_path):
    save(icosphere(), tmp_path / "s.stl")
    data = bytearray((tmp_path / "s.stl").read_bytes())
    data[80:84] = np.array([300], "<u4").tobytes()
    (tmp_path / "bad.stl").write_bytes(bytes(data))
    expect_load_error(tmp_path / "bad.stl", "declares 300 triangles")


# ------------------------------------------------------------------ flipped bytes
@pytest.mark.parametrize("fmt", ["ply", "stl", "glb", "off", "obj"])
def test_flipped_bytes_give_a_mesh_or_a_lodkit_error(tmp_path, fmt):
    """A few flipped bytes anywhere (coloured binary PLY: the issue's crash) load as a valid
    Mesh (a flipped coordinate is still a coordinate) or raise a lodkit error; nothing else."""
    save(icosphere(), tmp_path / f"s.{fmt}")
    good = (tmp_path / f"s.{fmt}").read_bytes()
    rng = np.random.default_rng(18)
    outcomes = {"loaded": 0, "refused": 0}
    for trial in range(60):
        data = bytearray(good)
        for at in rng.integers(0, len(data), size=int(rng.integers(1, 6))):
            data[at] ^= int(rng.integers(1, 256))
        path = tmp_path / f"f{trial}.{fmt}"
        path.write_bytes(bytes(data))
        try:
            mesh = load(path)
        except LodkitError as exc:
            assert str(path) in str(exc)
            outcomes["refused"] += 1
        else:
            assert isinstance(mesh, Mesh) and mesh.n_faces > 0
            assert mesh.faces.max() < mesh.n_vertices
            outcomes["loaded"] += 1
    if fmt != "stl":          # a binary STL is floats after its count: flips there still load
        assert outcomes["refused"] > 0
    assert outcomes["refused"] + outcomes["loaded"] == 60


# ------------------------------------------------------------------ polygons
def test_obj_quad_and_triangle_are_both_kept(tmp_path):
    path = tmp_path / "mixed.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\nf 1 2 5\n")
    mesh = load(path)
    assert mesh.n_faces == 3                                     # the quad as two triangles
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2], [0, 2, 3], [0, 1, 4]])
    assert any("fan-triangulated" in note for note in mesh.metadata["load_notes"])


def test_all_quad_obj_loads(tmp_path):
    # a cube of six quads
    v = "".join(f"v {x} {y} {z}\n" for x in (0, 1) for y in (0, 1) for z in (0, 1))
    f = "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n"
    (tmp_path / "cube.obj").write_text(v + f)
    mesh = load(tmp_path / "cube.obj")
    assert (mesh.n_vertices, mesh.n_faces) == (8, 12)
    assert "6 polygon faces" in mesh.metadata["load_notes"][0]


def test_ply_and_off_polygons_are_fan_triangulated(tmp_path):
    (tmp_path / "q.ply").write_bytes(ASCII_PLY_HEAD + b"4 0 1 2 3\n")
    (tmp_path / "q.off").write_bytes(b"OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n")
    for name in ("q.ply", "q.off"):
        mesh = load(tmp_path / name)
        np.testing.assert_array_equal(mesh.faces, [[0, 1, 2], [0, 2, 3]])
        assert "load_notes" in mesh.metadata


def test_binary_ply_with_mixed_polygons(tmp_path):
    head = (b"ply\nformat binary_little_endian 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
            b"property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n")
    verts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1]], "<f4").tobytes()
    faces = bytes([4]) + np.array([0, 1, 2, 3], "<i4").tobytes() + bytes([3]) + np.array([0, 1, 4], "<i4").tobytes()
    (tmp_path / "m.ply").write_bytes(head + verts + faces)
    mesh = load(tmp_path / "m.ply")
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2], [0, 2, 3], [0, 1, 4]])


@pytest.mark.parametrize("face", [b"2 0 1", b"1 0", b"0"])
def test_faces_with_fewer_than_three_corners_are_refused(tmp_path, face):
    (tmp_path / "d.off").write_bytes(b"OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n" + face + b"\n")
    expect_load_error(tmp_path / "d.off", "at least 3")


# ------------------------------------------------------------------ glTF
@pytest.mark.parametrize("writer", ["lodkit", "open3d"])
@pytest.mark.parametrize("key", [b'"indices"', b'"POSITION"', b'"count"', b'"bufferView"', b'"mode"'])
def test_glb_with_a_corrupted_key_is_refused(tmp_path, writer, key):
    sphere = icosphere()
    path = tmp_path / "s.glb"
    if writer == "lodkit":
        save(sphere, path)
    else:
        o3d = pytest.importorskip("open3d")
        tm = o3d.t.geometry.TriangleMesh.from_legacy(Mesh(sphere.vertices, sphere.faces).to_open3d())
        with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
            assert o3d.t.io.write_triangle_mesh(str(path), tm)
    data = path.read_bytes()
    if key not in data:
        pytest.skip(f"{writer}'s GLB has no {key.decode()} key")
    assert load(path).n_faces == 320
    corrupt = data.replace(key, key[:-2] + bytes([key[-2] ^ 1]) + b'"', 1)
    (tmp_path / "bad.glb").write_bytes(corrupt)
    expect_load_error(tmp_path / "bad.glb", "unknown|has no|not read")


def test_glb_index_out_of_range(tmp_path):
    save(Mesh(TETRA_V, TETRA_F), tmp_path / "t.glb")
    data = bytearray((tmp_path / "t.glb").read_bytes())
    data[-4:] = np.array([9], "<u4").tobytes()               # the last index
    (tmp_path / "bad.glb").write_bytes(bytes(data))
    expect_load_error(tmp_path / "bad.glb", "out of range")


def test_truncated_glb(tmp_path):
    save(icosphere(), tmp_path / "s.glb")
    data = (tmp_path / "s.glb").read_bytes()
    (tmp_path / "cut.glb").write_bytes(data[:-100])
    expect_load_error(tmp_path / "cut.glb", "truncated or corrupt")


# ------------------------------------------------------------------ alpha and quietness
@pytest.mark.parametrize("fmt", ["ply", "off", "glb", "gltf"])
def test_alpha_is_kept_on_load(tmp_path, fmt):
    sphere = icosphere()
    save(sphere, tmp_path / f"s.{fmt}")
    mesh = load(tmp_path / f"s.{fmt}")
    assert mesh.colors.shape == (162, 4)
    tol = 0.5 / 255 + 1e-9 if fmt == "ply" else 1e-6
    np.testing.assert_allclose(mesh.colors, sphere.colors, rtol=0, atol=tol)


def test_bad_files_print_nothing(tmp_path, capfd):
    (tmp_path / "r1.ply").write_bytes(ASCII_PLY_HEAD + b"4 0 1 2 1000000\n")
    (tmp_path / "g.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 99\nend_header\n")
    (tmp_path / "g.glb").write_bytes(b"glTF" + bytes(100))
    for name in ("r1.ply", "g.ply", "g.glb"):
        with pytest.raises(LodkitError):
            load(tmp_path / name)
    out, err = capfd.readouterr()
    assert out + err == ""


def test_cli_info_shows_the_load_notes(tmp_path, capsys):
    from lodkit.cli import main

    (tmp_path / "q.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\nf 1 2 5\n")
    assert main(["info", str(tmp_path / "q.obj")]) == 0
    out = capsys.readouterr().out
    assert "load note" in out and "fan-triangulated into 2 triangles" in out
