"""lodkit.simplify_large: tiles simplified with their shared vertices locked, welded exactly.

Small meshes and small tiles, so that several tiles and rounds run in a few seconds; the
engine is "sync" or "threads" except where Dask itself is the point.
"""
from __future__ import annotations

import numpy as np
import pytest

import lodkit
from conftest import shared_mesh
from lodkit import cli
from lodkit.demo import demo_mesh
from lodkit.errors import MeshIOError, OptionError
from lodkit.io.stream import to_binary_ply
from lodkit.large import open_source, simplify_large
from lodkit.topology import topology


def torus(nu: int = 120, nv: int = 60, wobble: float = 0.15) -> lodkit.Mesh:
    """A closed, bumpy torus (genus 1) of 2 * nu * nv faces."""
    u = 2 * np.pi * np.arange(nu) / nu
    v = 2 * np.pi * np.arange(nv) / nv
    U, V = np.meshgrid(u, v, indexing="ij")
    r = 0.3 * (1 + wobble * np.sin(5 * U) * np.cos(3 * V))
    pts = np.stack([(1 + r * np.cos(V)) * np.cos(U), (1 + r * np.cos(V)) * np.sin(U), r * np.sin(V)], -1)
    iu, iv = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = iu * nv + iv
    b = ((iu + 1) % nu) * nv + iv
    c = ((iu + 1) % nu) * nv + (iv + 1) % nv
    d = iu * nv + (iv + 1) % nv
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return lodkit.Mesh(pts.reshape(-1, 3), faces.astype(np.int32))


def check_same_shape(before: lodkit.Mesh, after: lodkit.Mesh) -> None:
    """Manifold, oriented, crack-free: the genus, the boundary loops and components kept."""
    a, b = topology(before), topology(after)
    assert b.is_manifold and b.is_oriented
    assert b.n_boundary_edges == 0 if a.is_closed else b.n_boundary_loops == a.n_boundary_loops
    assert (b.genus, b.n_components) == (a.genus, a.n_components)


def check_vertex_map(mesh: lodkit.Mesh, result) -> None:
    vm = result.vertex_map
    assert vm.shape == (result.mesh.n_vertices,) and len(np.unique(vm)) == len(vm)
    assert vm.min() >= 0 and vm.max() < mesh.n_vertices
    # each output vertex stands near the input vertex it comes from
    gap = np.linalg.norm(result.mesh.vertices - mesh.vertices[vm], axis=1)
    assert gap.max() < 0.1 * mesh.bbox_diagonal()


@pytest.mark.parametrize("ratio, last", [(0.1, "in-core"), (0.6, "tiles")])
def test_closed_torus_stays_closed(tmp_path, ratio, last):
    mesh = torus()
    lodkit.save(mesh, tmp_path / "in.ply")
    result = simplify_large(tmp_path / "in.ply", tmp_path / "out.ply", target_ratio=ratio, tile_faces=1500,
                            in_core_faces=3000, scheduler="sync")
    kinds = [r["kind"] for r in result.rounds]
    assert kinds[0] == "tiles" and kinds[-1] == last and kinds.count("tiles") >= 2
    assert result.rounds[0]["tiles"] >= 4
    # a grid cell holding more than two tiles' worth (the tube folds through it) is split
    assert all(r["largest_tile"] <= 2 * 1500 for r in result.rounds if r["kind"] == "tiles")
    out = lodkit.load(tmp_path / "out.ply")
    assert np.array_equal(out.faces, result.mesh.faces) and np.array_equal(out.vertices, result.mesh.vertices)
    check_same_shape(mesh, out)
    target = round(ratio * mesh.n_faces)
    if last == "in-core":
        assert out.n_faces == target
    else:  # the tiled rounds stop at a global error picked from sampled curves: near the target
        assert abs(out.n_faces - target) <= 0.05 * target
    check_vertex_map(mesh, result)
    assert 0 < result.error < 0.05


def test_open_surface_keeps_its_boundary_and_is_close_to_in_core(tmp_path):
    mesh = demo_mesh(12_000)
    lodkit.save(mesh, tmp_path / "in.ply")
    result = simplify_large(tmp_path / "in.ply", tmp_path / "out.ply", target_ratio=0.1, tile_faces=1500,
                            scheduler="threads", workers=2)
    check_same_shape(mesh, result.mesh)
    check_vertex_map(mesh, result)
    ref = lodkit.simplify(mesh, target_ratio=0.1)
    # both stop at the target or one face below it (a last collapse may remove two faces),
    # whichever collapses came before
    target = ref.report["target_faces"]
    assert target - 1 <= result.mesh.n_faces <= target and target - 1 <= ref.mesh.n_faces <= target
    tiled = lodkit.evaluate(mesh, result.mesh, samples=20_000, seed=1).distance.mean
    whole = lodkit.evaluate(mesh, ref.mesh, samples=20_000, seed=1).distance.mean
    assert tiled < 2.5 * whole     # measured: 1.6 with these tiny tiles (docs/scale.md)


def test_engines_give_the_same_mesh(tmp_path):
    mesh = torus(80, 40)
    lodkit.save(mesh, tmp_path / "in.ply")
    outs = []
    for scheduler in ("sync", "threads"):
        r = simplify_large(tmp_path / "in.ply", tmp_path / f"{scheduler}.ply", target_ratio=0.2, tile_faces=800,
                           scheduler=scheduler, workers=3)
        outs.append(r)
    assert np.array_equal(outs[0].mesh.faces, outs[1].mesh.faces)
    assert np.array_equal(outs[0].mesh.vertices, outs[1].mesh.vertices)
    assert np.array_equal(outs[0].vertex_map, outs[1].vertex_map)


def test_on_a_local_dask_cluster(tmp_path):
    distributed = pytest.importorskip("distributed", reason="dask.distributed not installed (lodkit[dask])")
    mesh = torus(80, 40)
    lodkit.save(mesh, tmp_path / "in.ply")
    ref = simplify_large(tmp_path / "in.ply", tmp_path / "sync.ply", target_ratio=0.2, tile_faces=800,
                         scheduler="sync")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1", dashboard_address=None) as c, \
            distributed.Client(c, set_as_default=False) as client:
        got = simplify_large(tmp_path / "in.ply", tmp_path / "dask.ply", target_ratio=0.2, tile_faces=800,
                             client=client)
    assert np.array_equal(got.mesh.faces, ref.mesh.faces) and np.array_equal(got.mesh.vertices, ref.mesh.vertices)
    assert not list(tmp_path.glob(".lodkit-tiles-*"))        # the parts are cleaned up


def test_max_error_and_other_formats(tmp_path):
    mesh = torus(80, 40)
    lodkit.save(mesh, tmp_path / "in.obj")          # not memory-mapped: loaded once
    result = simplify_large(tmp_path / "in.obj", tmp_path / "out.ply", max_error=0.002, tile_faces=800,
                            scheduler="sync")
    assert result.error <= 0.002
    assert result.mesh.n_faces < mesh.n_faces
    check_same_shape(mesh, result.mesh)


def test_real_mesh_bunny(tmp_path):
    path = shared_mesh("bunny.ply")
    mesh = lodkit.load(path)
    result = simplify_large(path, tmp_path / "out.ply", target_ratio=0.05, tile_faces=10_000, scheduler="sync")
    assert result.rounds[0]["kind"] == "tiles"
    check_same_shape(mesh, result.mesh)
    check_vertex_map(mesh, result)


def test_ply_memory_map_reads_what_load_reads(tmp_path):
    mesh = torus(30, 20)
    lodkit.save(mesh, tmp_path / "in.ply")
    source = open_source(tmp_path / "in.ply")
    assert type(source).__name__ == "PlySource"
    v, f = source.arrays()
    assert np.array_equal(v, lodkit.load(tmp_path / "in.ply").vertices) and np.array_equal(f, mesh.faces)
    data = (tmp_path / "in.ply").read_bytes()
    (tmp_path / "short.ply").write_bytes(data[: len(data) - 100])
    with pytest.raises(MeshIOError, match="shorter than its PLY header"):
        open_source(tmp_path / "short.ply")


@pytest.mark.parametrize("options, error, message", [
    ({"tile_faces": 10}, OptionError, "tile_faces"),
    ({"target_ratio": 2.0}, OptionError, "target_ratio"),
    ({}, OptionError, "stop criterion"),
])
def test_bad_options(tmp_path, options, error, message):
    lodkit.save(torus(20, 10), tmp_path / "in.ply")
    with pytest.raises(error, match=message):
        simplify_large(tmp_path / "in.ply", tmp_path / "out.ply", **{"scheduler": "sync", **options})
    with pytest.raises(MeshIOError, match="unsupported file format"):
        simplify_large(tmp_path / "in.ply", tmp_path / "out.xyz", target_ratio=0.5)
    with pytest.raises(MeshIOError, match="no such file"):
        simplify_large(tmp_path / "missing.ply", tmp_path / "out.ply", target_ratio=0.5)


def test_cli_tiles(tmp_path, capsys):
    lodkit.save(torus(), tmp_path / "in.ply")
    args = ["simplify", str(tmp_path / "in.ply"), str(tmp_path / "out.ply"), "--ratio", "0.1", "--tiles",
            "--tile-faces", "1500", "--scheduler", "sync"]
    assert cli.main(args) == cli.EXIT_OK
    assert "tiled round(s)" in capsys.readouterr().out
    assert topology(lodkit.load(tmp_path / "out.ply")).is_closed
    assert cli.main(args + ["--boundary", "lock"]) == cli.EXIT_USAGE
    assert "--tiles takes one --metric" in capsys.readouterr().err
    assert cli.main(args[:-5] + ["--workers", "2"]) == cli.EXIT_USAGE
    assert "go with --tiles" in capsys.readouterr().err


# ---------------------------------------------------------------------- text inputs in blocks
def converted(path, tmp_path, size):
    out = tmp_path / "converted.ply"
    n = to_binary_ply(path, out, size=size)
    source = open_source(out)
    assert type(source).__name__ == "PlySource" and (source.n_vertices, source.n_faces) == n
    return source.arrays()


@pytest.mark.parametrize("size", [1, 97, 1 << 20])
def test_off_in_blocks_is_what_load_reads(tmp_path, size):
    """Blocks of 1 byte (every line its own block), odd sizes and one block: the same
    positions (float32-rounded as load rounds them) and triangles as lodkit.load."""
    mesh = torus(12, 8)
    lodkit.save(mesh, tmp_path / "in.off")
    v, f = converted(tmp_path / "in.off", tmp_path, size)
    ref = lodkit.load(tmp_path / "in.off")
    assert np.array_equal(v, ref.vertices) and np.array_equal(f, ref.faces)


OBJ_TEXT = b"""# a hand-made OBJ: comments, blank lines, vt/vn corners, a quad, relative indices
v 0 0 0
v 1 0 0
vt 0 0
vn 0 0 1

v 1 1 0   # a comment after values
v 0 1 0
vt 1 1
f 1/1/1 2/1/1 3/2/1 4/2/1
v 2 0 0.5
o part
f -4//1 -1//1 -3//1
"""


@pytest.mark.parametrize("size", [1, 13, 1 << 20])
def test_obj_in_blocks_positions_and_triangles(tmp_path, size):
    """Positions in 'v'-line order, the quad fan-triangulated, the relative indices of the
    last face counted from the 'v' lines before it, across any block cut; the corners are
    where lodkit.load puts them (load splits vertices at uv / normal changes, the block
    reader keeps one vertex per position)."""
    (tmp_path / "in.obj").write_bytes(OBJ_TEXT)
    v, f = converted(tmp_path / "in.obj", tmp_path, size)
    expected = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0.5]]
    assert np.array_equal(v, expected)   # exact: parsed from text, no arithmetic; exact in float32
    assert np.array_equal(f, [[0, 1, 2], [0, 2, 3], [1, 4, 2]])
    ref = lodkit.load(tmp_path / "in.obj")
    assert np.array_equal(v[f], ref.vertices[ref.faces])


@pytest.mark.parametrize("name, text, message", [
    ("bad.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "not defined before it"),
    ("bad.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 0 0 x\n", "not a number"),
    ("bad.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nbogus 1\n", "unknown statement"),
    ("bad.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1e39 0 0\nf 1 2 3\n", "NaN or infinite"),
    ("bad.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "has 3 vertices"),
    ("bad.off", b"OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n", "truncated"),
    ("bad.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n", "more data lines"),
    ("bad.off", b"OFF\n", "counts"),
])
def test_malformed_text_inputs_fail_cleanly(tmp_path, monkeypatch, name, text, message):
    """A malformed OBJ or OFF is one MeshIOError naming the file and what is wrong, also
    when the fault lies in a later block; nothing is left in the output folder."""
    (tmp_path / name).write_bytes(text)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    for size in (5, 1 << 20):
        monkeypatch.setattr(lodkit.io.stream, "BLOCK_BYTES", size)
        with pytest.raises(MeshIOError, match=message) as info:
            simplify_large(tmp_path / name, out_dir / "out.ply", target_ratio=0.5, tile_faces=100, scheduler="sync")
        assert name in str(info.value)
        assert list(out_dir.iterdir()) == []


def test_text_input_in_tiles_vertex_map_is_the_files_numbering(tmp_path):
    """An OBJ simplified in tiles (converted in blocks, never loaded whole): ``vertex_map``
    numbers the file's 'v' lines.  The vertices are shuffled in the file, so that
    lodkit.load's numbering (by first use in the faces) is another one."""
    mesh = torus(60, 30)
    perm = np.random.default_rng(1).permutation(mesh.n_vertices)
    inverse = np.argsort(perm)
    shuffled = lodkit.Mesh(mesh.vertices[perm], inverse[mesh.faces].astype(np.int32))
    lodkit.save(shuffled, tmp_path / "in.obj")
    result = simplify_large(tmp_path / "in.obj", tmp_path / "out.ply", target_ratio=0.2, tile_faces=800,
                            scheduler="sync")
    check_same_shape(mesh, result.mesh)
    file_v = np.array([ln.split()[1:4] for ln in (tmp_path / "in.obj").read_bytes().splitlines()
                       if ln.startswith(b"v ")], dtype=np.float32).astype(np.float64)
    vm = result.vertex_map
    assert len(np.unique(vm)) == len(vm) and vm.max() < len(file_v)
    gap = np.linalg.norm(result.mesh.vertices - file_v[vm], axis=1)
    assert gap.max() < 0.1 * mesh.bbox_diagonal()
    loaded = lodkit.load(tmp_path / "in.obj").vertices
    assert np.linalg.norm(result.mesh.vertices - loaded[vm], axis=1).max() > 0.3 * mesh.bbox_diagonal()


def test_big_endian_ply_is_memory_mapped(tmp_path):
    """A binary big-endian PLY is mapped like a little-endian one, and reads as load reads it."""
    mesh = torus(10, 6)
    v = mesh.vertices.astype(">f4")
    rec = np.empty(mesh.n_faces, dtype=[("n", "u1"), ("v", ">i4", (3,))])
    rec["n"], rec["v"] = 3, mesh.faces
    head = (f"ply\nformat binary_big_endian 1.0\nelement vertex {len(v)}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {mesh.n_faces}\nproperty list uchar int vertex_indices\nend_header\n")
    (tmp_path / "be.ply").write_bytes(head.encode() + v.tobytes() + rec.tobytes())
    source = open_source(tmp_path / "be.ply")
    assert type(source).__name__ == "PlySource"
    got_v, got_f = source.arrays()
    ref = lodkit.load(tmp_path / "be.ply")
    assert np.array_equal(got_v, ref.vertices) and np.array_equal(got_f, ref.faces)
