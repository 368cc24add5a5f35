"""Progressive meshes: extraction equals simplify(), save/load, the cursor, ``lodkit lods``."""
from __future__ import annotations

import csv
import json
import os
import zipfile

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import lodkit
from conftest import shared_mesh
from lodkit.cli import main
from lodkit.errors import MeshIOError, OptionError
from lodkit.progressive import FORMAT_VERSION, ProgressiveMesh, progressive
from test_qem import uv_sphere
from test_simplify import manifold_meshes


def assert_same(level, result):
    """``level`` (a Level) is exactly ``result`` (a SimplifyResult): bit for bit."""
    a, b = level.mesh, result.mesh
    if not isinstance(a, lodkit.Mesh):
        a, b = lodkit.Mesh.from_open3d(a), lodkit.Mesh.from_open3d(b)
    np.testing.assert_array_equal(a.faces, b.faces)
    assert a.vertices.tobytes() == b.vertices.tobytes()
    np.testing.assert_array_equal(level.vertex_map, result.vertex_map)
    np.testing.assert_array_equal(level.face_map, result.face_map)
    for name in ("normals", "colors", "uvs"):
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None) == (y is None), name
        if x is not None:
            assert x.tobytes() == y.tobytes(), name
    assert level.error == result.error


def assert_same_level(x, y):
    np.testing.assert_array_equal(x.mesh.faces, y.mesh.faces)
    assert x.mesh.vertices.tobytes() == y.mesh.vertices.tobytes()
    np.testing.assert_array_equal(x.vertex_map, y.vertex_map)
    np.testing.assert_array_equal(x.face_map, y.face_map)
    for name in ("normals", "colors", "uvs"):
        u, v = getattr(x.mesh, name), getattr(y.mesh, name)
        assert (u is None) == (v is None)
        if u is not None:
            assert u.tobytes() == v.tobytes()
    assert x.error == y.error and x.step == y.step


def hexagon_fan():
    """Six triangles around a centre vertex (6) on a plane."""
    ang = np.arange(6) * np.pi / 3
    v = np.zeros((7, 3))
    v[:6, 0], v[:6, 1] = np.cos(ang), np.sin(ang)
    f = np.array([[i, (i + 1) % 6, 6] for i in range(6)])
    return lodkit.Mesh(v, f)


# ---------------------------------------------------------------------- small exact cases
def test_hexagon_fan_one_collapse():
    """Under boundary='lock' only the centre can go, into a ring vertex: one step, two
    faces die, the other four take the ring vertex for the centre."""
    mesh = hexagon_fan()
    pm = progressive(mesh, boundary="lock")
    assert pm.n_steps == 1
    np.testing.assert_array_equal(pm.faces_per_step, [6, 4])
    rec = pm.records
    assert rec["removed"].tolist() == [6]
    k = int(rec["kept"][0])
    assert 0 <= k < 6
    np.testing.assert_array_equal(rec["position"][0], mesh.vertices[k])
    np.testing.assert_array_equal(rec["position_before"][0], mesh.vertices[k])
    dead = sorted(rec["dead_faces"][0].tolist())
    assert dead == sorted([k, (k - 1) % 6])          # face i is (i, i+1, 6)
    base = pm.level(step=1)
    survivors = [i for i in range(6) if i not in dead]
    np.testing.assert_array_equal(base.face_map, survivors)
    np.testing.assert_array_equal(base.vertex_map, np.arange(6))
    expect = np.where(mesh.faces[survivors] == 6, k, mesh.faces[survivors])
    np.testing.assert_array_equal(base.mesh.faces, expect)
    np.testing.assert_array_equal(base.mesh.vertices, mesh.vertices[:6])
    # at(faces=N) for every N
    assert pm.at(faces=6).n_faces == 6 and pm.at(faces=5).n_faces == 4
    assert pm.at(faces=0).n_faces == 4                 # nothing further to collapse
    # step 0 is the input
    top = pm.level(step=0)
    np.testing.assert_array_equal(top.mesh.faces, mesh.faces)
    np.testing.assert_array_equal(top.mesh.vertices, mesh.vertices)
    assert top.error == 0.0
    # the cursor starts at the base mesh and splits the centre back
    assert pm.step == 1
    np.testing.assert_array_equal(pm.current.faces, expect)
    assert pm.refine() == 0
    np.testing.assert_array_equal(pm.current.faces, mesh.faces)
    assert pm.refine() == 0                            # nothing before the input
    assert pm.coarsen(5) == 1


def test_at_step_zero_is_the_cleaned_input():
    mesh = lodkit.Mesh(np.vstack([hexagon_fan().vertices, [[5.0, 5, 5]]]),
                       np.vstack([hexagon_fan().faces, [[0, 0, 1]]]))   # unused vertex, degenerate face
    pm = progressive(mesh)
    top = pm.level(step=0)
    r = lodkit.simplify(mesh, target_faces=6)
    assert_same(top, r)
    assert top.n_faces == 6 and pm.n_input_faces == 7
    for n in range(7):
        assert_same(pm.level(faces=n), lodkit.simplify(mesh, target_faces=n))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(manifold_meshes(), st.lists(st.floats(0.0, 1.0), min_size=1, max_size=3),
       st.sampled_from(["optimal", "endpoint"]), st.sampled_from(["preserve", "lock", "free"]))
def test_at_equals_simplify_property(case, ratios, placement, boundary):
    _, mesh = case
    pm = progressive(mesh, placement=placement, boundary=boundary)
    for r in ratios:
        n = int(round(r * mesh.n_faces))
        assert_same(pm.level(faces=n), lodkit.simplify(mesh, target_faces=n, placement=placement, boundary=boundary))


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(manifold_meshes(), st.lists(st.tuples(st.booleans(), st.integers(1, 40)), min_size=1, max_size=25))
def test_cursor_random_walk_matches_at(case, moves):
    """refine / coarsen walk to the same meshes at() extracts, from any start."""
    _, mesh = case
    pm = progressive(mesh)
    cur = pm.cursor(step=pm.n_steps // 2 if pm.stops[pm.n_steps // 2] else 0)
    for up, n in moves:
        before = cur.step
        after = cur.refine(n) if up else cur.coarsen(n)
        assert (after <= before) if up else (after >= before)
        assert 0 <= after <= pm.n_steps and pm.stops[after]
        assert cur.n_faces == pm.faces_per_step[after]
        assert_same_level(cur.level(), pm.level(step=after))


def test_cursor_matches_at_on_every_step_of_a_uv_mesh():
    """spot has uv seams: seam pairs are one step for the cursor, in both directions."""
    mesh = lodkit.load(shared_mesh("spot_triangulated.obj"))
    pm = progressive(mesh)
    assert (~pm.stops).sum() > 50                       # seam pairs happened
    cur = pm.cursor()
    seen = [cur.step]
    while cur.step > 0:
        cur.refine(37)
        seen.append(cur.step)
        assert_same_level(cur.level(), pm.level(step=cur.step))
    assert seen[-1] == 0
    cur.seek(pm.n_steps)
    assert_same_level(cur.level(), pm.level(step=pm.n_steps))
    inside = int(np.flatnonzero(~pm.stops)[0])
    with pytest.raises(OptionError, match="seam pair"):
        pm.at(step=inside)


# ---------------------------------------------------------------------- real meshes
@pytest.fixture(scope="module")
def bunny():
    return lodkit.load(shared_mesh("bunny.ply"))


@pytest.fixture(scope="module")
def bunny_pm(bunny):
    return progressive(bunny)


@pytest.mark.parametrize("ratio", [0.5, 0.1, 0.02])
def test_bunny_at_equals_simplify(bunny, bunny_pm, ratio):
    n = int(round(ratio * bunny.n_faces))
    level = bunny_pm.level(faces=n)
    assert_same(level, lodkit.simplify(bunny, target_faces=n))
    assert_same_level(level, bunny_pm.level(ratio=ratio))


def test_bunny_lods_chain(bunny, bunny_pm):
    meshes = bunny_pm.lods([0.5, 10000, 0.02])
    assert [m.n_faces for m in meshes] == [bunny_pm.at(ratio=0.5).n_faces, 10000, bunny_pm.at(ratio=0.02).n_faces]
    assert meshes[0].n_faces > meshes[1].n_faces > meshes[2].n_faces
    for bad in (0.0, 1.5, True, "10", -3):
        with pytest.raises(OptionError):
            bunny_pm.lods([bad])


def test_bunny_error_targets(bunny, bunny_pm):
    """at(error=E): the longest run of collapses none over E, which is simplify run to the
    face count it reaches; simplify(max_error=E) skips over-budget candidates and goes on,
    so it may go further, never less far, with an error <= E as well."""
    errs = bunny_pm.errors_per_step
    assert np.all(np.diff(errs) >= 0) and errs[0] == 0.0
    for e in (2e-3,):
        level = bunny_pm.level(error=e)
        assert level.error <= e
        if level.step < bunny_pm.n_steps:
            assert errs[level.step + 1] > e             # the next collapse is over E
        assert_same(level, lodkit.simplify(bunny, target_faces=level.n_faces))
        direct = lodkit.simplify(bunny, max_error=e)
        assert direct.error <= e and direct.mesh.n_faces <= level.n_faces


def test_max_error_build_equals_simplify_max_error():
    """Built with max_error=E, the run is simplify(max_error=E)'s: its base mesh is that
    result and every at(faces=N) is simplify(target_faces=N, max_error=E)."""
    mesh = lodkit.load(shared_mesh("cow.obj"))
    pm = progressive(mesh, max_error=3e-3)
    assert_same(pm.level(step=pm.n_steps), lodkit.simplify(mesh, max_error=3e-3))
    n = int(0.4 * mesh.n_faces)
    assert_same(pm.level(faces=n), lodkit.simplify(mesh, target_faces=n, max_error=3e-3))


@pytest.mark.parametrize("name,options", [
    ("cow.obj", {}),                                   # a pinch vertex: split slots, welded back
    ("spot_triangulated.obj", {}),                     # uv seams: pair collapses
    ("spot_triangulated.obj", {"metric": "appearance"}),
    ("colored_airplane.ply", {}),                      # vertex colours
    ("fandisk.obj", {"metric": "melod", "placement": "endpoint"}),
])
def test_real_meshes_at_equals_simplify(name, options):
    mesh = lodkit.load(shared_mesh(name))
    pm = progressive(mesh, **options)
    f0 = mesh.n_faces
    for n in (int(0.7 * f0), int(0.2 * f0), int(0.03 * f0), 10):
        assert_same(pm.level(faces=n), lodkit.simplify(mesh, target_faces=n, **options))


def test_open3d_in_open3d_out():
    o3d = pytest.importorskip("open3d")
    mesh = o3d.io.read_triangle_mesh(str(shared_mesh("colored_airplane.ply")))
    pm = progressive(mesh)
    out = pm.at(faces=2000)
    assert isinstance(out, o3d.geometry.TriangleMesh)
    assert_same(pm.level(faces=2000), lodkit.simplify(mesh, target_faces=2000))


def test_min_faces_and_bad_targets(bunny):
    small = lodkit.load(shared_mesh("cow.obj"))
    pm = progressive(small, min_faces=1000)
    assert pm.faces_per_step[-1] <= 1000 < pm.faces_per_step[-2]
    assert_same(pm.level(faces=1500), lodkit.simplify(small, target_faces=1500))
    with pytest.raises(OptionError, match="min_faces"):
        pm.at(faces=999)
    for kw in ({}, {"faces": 10, "error": 0.1}, {"faces": -1}, {"faces": 2.5}, {"ratio": 2.0},
               {"error": -1.0}, {"step": pm.n_steps + 1}, {"step": -1}):
        with pytest.raises(OptionError):
            pm.at(**kw)
    with pytest.raises(OptionError):
        progressive(small, min_faces=-2)
    with pytest.raises(OptionError, match="pair_threshold"):
        progressive(small, pair_threshold=0.01)


def test_triangle_collapse_runs():
    """operator='triangle' records each triangle collapse as two edge collapses, the first
    marked open: one step, and the equality holds."""
    mesh = lodkit.load(shared_mesh("cow.obj"))
    try:
        pm = progressive(mesh, operator="triangle")
    except TypeError:
        pytest.skip("this simplify() has no operator= option")
    assert (~pm.stops).sum() > 100
    for n in (3000, 500):
        assert_same(pm.level(faces=n), lodkit.simplify(mesh, target_faces=n, operator="triangle"))
    cur = pm.cursor()
    cur.refine(400)
    assert_same_level(cur.level(), pm.level(step=cur.step))


def test_vertex_removal_metrics_are_refused():
    mesh = lodkit.Mesh(*uv_sphere(12, 8))
    for name in ("schroeder", "volume", ["schroeder"]):
        with pytest.raises(OptionError, match="removes vertices"):
            progressive(mesh, metric=name)


# ---------------------------------------------------------------------- files
def test_save_load_round_trip_is_exact(tmp_path):
    mesh = lodkit.load(shared_mesh("spot_triangulated.obj"))
    pm = progressive(mesh)
    path = tmp_path / "spot.npz"
    pm.save(path)
    back = ProgressiveMesh.load(path)
    assert back.n_steps == pm.n_steps and back.info == pm.info
    np.testing.assert_array_equal(back.faces_per_step, pm.faces_per_step)
    np.testing.assert_array_equal(back.errors_per_step, pm.errors_per_step)
    np.testing.assert_array_equal(back.stops, pm.stops)
    for s in np.flatnonzero(pm.stops)[::23]:
        assert_same_level(back.level(step=int(s)), pm.level(step=int(s)))
    assert_same_level(back.level(step=pm.n_steps), pm.level(step=pm.n_steps))
    for key, value in pm.records.items():
        np.testing.assert_array_equal(back.records[key], value)
    # compact: compressed, indices as int32, identity slot maps left out
    held = sum(np.asarray(v).nbytes for v in pm._d.values())
    assert path.stat().st_size < 0.8 * held
    with np.load(path) as z:
        assert z["removed"].dtype == np.int32 and z["corners"].dtype == np.int32
        for k in ("input_vertex", "input_face"):
            identity = np.array_equal(pm._d[k], np.arange(pm._d[k].shape[0]))
            assert (k in z.files) != identity
        assert int(z["format_version"]) == FORMAT_VERSION


@pytest.fixture(scope="module")
def small_pm():
    return progressive(hexagon_fan(), boundary="lock")


def test_save_is_atomic(tmp_path, small_pm, monkeypatch):
    path = tmp_path / "pm.npz"
    path.write_bytes(b"old contents")

    def boom(fh, **arrays):
        fh.write(b"partial")
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(np, "savez_compressed", boom)
    with pytest.raises(RuntimeError, match="disk on fire"):
        small_pm.save(path)
    assert path.read_bytes() == b"old contents"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pm.npz"]
    with pytest.raises(MeshIOError, match="does not exist"):
        small_pm.save(tmp_path / "missing" / "pm.npz")
    with pytest.raises(MeshIOError, match="directory"):
        small_pm.save(tmp_path)


def _rewrite(src, dst, change):
    with np.load(src) as z:
        arrays = {k: z[k] for k in z.files}
    change(arrays)
    np.savez(dst, **arrays)


@pytest.mark.parametrize("change,message", [
    (lambda a: a.update(format=np.array("something-else")), "not a lodkit progressive"),
    (lambda a: a.pop("format"), "not a lodkit progressive"),
    (lambda a: a.update(format_version=np.array(FORMAT_VERSION + 1)), "format version"),
    (lambda a: a.pop("removed"), "missing array 'removed'"),
    (lambda a: a.update(kept=a["kept"][:-1]), "rows"),
    (lambda a: a.update(corners=a["corners"] + 100), "out of range"),
    (lambda a: a.update(removed=np.zeros_like(a["removed"]) + 6, kept=np.full_like(a["kept"], 6)),
     "inconsistent"),
    (lambda a: a.update(info=np.array("{not json")), "info"),
])
def test_load_refuses_wrong_files(tmp_path, small_pm, change, message):
    good = tmp_path / "good.npz"
    small_pm.save(good)
    bad = tmp_path / "bad.npz"
    _rewrite(good, bad, change)
    with pytest.raises(MeshIOError, match=message):
        ProgressiveMesh.load(bad)


def test_load_refuses_damaged_files(tmp_path, small_pm):
    good = tmp_path / "good.npz"
    small_pm.save(good)
    data = good.read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[: len(data) // 2])
    (tmp_path / "junk.npz").write_bytes(b"\x00" * 100)
    for name in ("cut.npz", "junk.npz"):
        with pytest.raises(MeshIOError, match="cannot load"):
            ProgressiveMesh.load(tmp_path / name)
    with pytest.raises(MeshIOError, match="no such file"):
        ProgressiveMesh.load(tmp_path / "nothing.npz")
    assert zipfile.is_zipfile(good)


# ---------------------------------------------------------------------- lodkit lods
def test_cli_lods(tmp_path, capsys):
    src = shared_mesh("cow.obj")
    mesh = lodkit.load(src)
    out = tmp_path / "chain"
    assert main(["lods", str(src), "--ratios", "0.5,0.1,0.02", "--out-dir", str(out), "--format", "ply"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    rows = list(csv.DictReader((out / "summary.csv").open()))
    assert [r["level"] for r in summary["levels"]] == [0, 1, 2, 3]      # 0: the original
    assert len(rows) == 4
    original = lodkit.load(out / summary["levels"][0]["file"])
    assert summary["levels"][0]["file"] == "cow_lod0.ply" and summary["levels"][0]["ratio"] == 1.0
    assert original.n_faces == mesh.n_faces == int(rows[0]["faces"])
    np.testing.assert_array_equal(original.faces, mesh.faces)
    for row, lv, ratio in zip(rows[1:], summary["levels"][1:], (0.5, 0.1, 0.02)):
        direct = lodkit.simplify(mesh, target_ratio=ratio)
        written = lodkit.load(out / lv["file"])
        assert written.n_faces == direct.mesh.n_faces == lv["faces"] == int(row["faces"])
        assert lv["vertices"] == direct.mesh.n_vertices == int(row["vertices"])
        assert lv["error"] == direct.error == float(row["error"])
        np.testing.assert_array_equal(written.faces, direct.mesh.faces)
    assert "lod3" in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == ["cow_lod0.ply", "cow_lod1.ply", "cow_lod2.ply",
                                                     "cow_lod3.ply", "summary.csv", "summary.json"]
    assert (os.stat(out / "summary.json").st_mode & 0o444) == 0o444


def test_cli_lods_formats_and_metric(tmp_path):
    src = shared_mesh("colored_airplane.ply")
    for fmt in ("obj", "glb"):
        out = tmp_path / fmt
        assert main(["lods", str(src), "--ratios", "0.2", "--out-dir", str(out), "--format", fmt,
                     "--metric", "appearance", "-q"]) == 0
        summary = json.loads((out / "summary.json").read_text())
        assert summary["metrics"] == ["appearance"]
        assert [lv["level"] for lv in summary["levels"]] == [0, 1]
        for lv in summary["levels"]:
            assert lodkit.load(out / lv["file"]).n_faces == lv["faces"]


@pytest.mark.parametrize("argv,message", [
    (["--ratios", "0.5,0"], "must be in"),
    (["--ratios", "0.5,x"], "not a number|must be"),
    (["--ratios", "0.5,,0.1"], "comma-separated"),
    (["--ratios", "0.5", "--format", "stl"], "invalid choice"),
    (["--ratios", "0.5", "--metric", "no_such_metric"], "no_such_metric"),
])
def test_cli_lods_errors(tmp_path, capsys, argv, message):
    src = tmp_path / "fan.ply"
    lodkit.save(hexagon_fan(), src)
    out = tmp_path / "out"
    assert main(["lods", str(src), "--out-dir", str(out), *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("lodkit: error:") and len(err.strip().splitlines()) == 1
    import re
    assert re.search(message, err), err
    assert not out.exists()


def test_cli_lods_bad_paths(tmp_path, capsys):
    src = tmp_path / "fan.ply"
    lodkit.save(hexagon_fan(), src)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["lods", str(src), "--ratios", "0.5", "--out-dir", str(blocker)]) == 2
    assert "not a directory" in capsys.readouterr().err
    assert main(["lods", str(src), "--ratios", "0.5", "--out-dir", str(tmp_path / "a" / "b")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["lods", str(tmp_path / "nope.ply"), "--ratios", "0.5", "--out-dir", str(tmp_path / "o")]) == 2
    assert "nope.ply" in capsys.readouterr().err


def test_batch_metric_runs_are_prefixes_too():
    """The pass driver (batch metrics) also stops at the target inside a pass, so a run
    to N is a prefix of the run to the coarsest."""
    from test_metrics import MidpointBatch

    mesh = lodkit.Mesh(*uv_sphere(24, 14))
    pm = progressive(mesh, metric=MidpointBatch())
    for n in (500, 120, 20):
        assert_same(pm.level(faces=n), lodkit.simplify(mesh, target_faces=n, metric=MidpointBatch()))


def test_records_replay_to_the_base_mesh():
    """Hoppe's reading: replaying the records (in input numbering) on the input faces, each
    collapse relabelling removed -> kept and dropping its dead faces, gives the base mesh;
    position_before is where the kept vertex was before its collapse."""
    v, f = uv_sphere(24, 14)
    v = np.vstack([v, v[:5] + 3.0])                  # an unused vertex block: renumbering
    mesh = lodkit.Mesh(v, np.vstack([f[:7], [[0, 0, 3]], f[7:]]))   # and a degenerate face
    pm = progressive(mesh)
    assert pm.faces_per_step[-1] < 10
    rec = pm.records
    faces = mesh.faces.astype(np.int64).copy()
    alive = np.ones(len(faces), dtype=bool)
    where = mesh.vertices.copy()
    for i in range(pm.n_steps):
        r, k = rec["removed"][i], rec["kept"][i]
        np.testing.assert_array_equal(rec["position_before"][i], where[k])
        where[k] = rec["position"][i]
        dead = rec["dead_faces"][i]
        dead = dead[dead >= 0]
        assert alive[dead].all() and ((faces[dead] == r).any(1) & (faces[dead] == k).any(1)).all()
        alive[dead] = False
        faces[alive & (faces == r).any(1)] = np.where(faces[alive & (faces == r).any(1)] == r, k,
                                                      faces[alive & (faces == r).any(1)])
    base = pm.level(step=pm.n_steps)
    alive[7] = False                                  # the degenerate face is dropped up front
    np.testing.assert_array_equal(np.flatnonzero(alive), base.face_map)
    np.testing.assert_array_equal(faces[alive], base.vertex_map[base.mesh.faces])
    np.testing.assert_array_equal(where[base.vertex_map], base.mesh.vertices)


def test_built_in_cursor_is_thread_safe(small_pm):
    """Four threads refining and coarsening the built-in cursor: afterwards (and at each
    read) the current mesh is the one at the cursor's step; per-thread cursors agree too."""
    import threading

    pm = small_pm
    errors = []
    barrier = threading.Barrier(4)

    def work(seed):
        try:
            walk(seed)
        except Exception as exc:         # a thread's exception must fail the test
            errors.append(repr(exc))

    def walk(seed):
        rng = np.random.default_rng(seed)
        own = pm.cursor()
        barrier.wait()
        for _ in range(30):
            pm.refine(int(rng.integers(1, 50)))
            pm.coarsen(int(rng.integers(1, 50)))
            level = pm.current_level()
            if not np.array_equal(level.mesh.faces, pm.at(step=level.step).faces):
                errors.append(level.step)
            own.seek(int(rng.integers(0, pm.n_steps + 1)))
            if not np.array_equal(own.mesh.faces, pm.at(step=own.step).faces):
                errors.append(("own", own.step))

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    at = pm.at(step=pm.step)
    assert np.array_equal(pm.current.faces, at.faces) and np.array_equal(pm.current.vertices, at.vertices)


def test_absolute_errors_are_scaled_once():
    """progressive(..., absolute=True) reports errors in model units, as simplify does (they
    were multiplied by the diagonal twice)."""
    import lodkit
    from lodkit.demo import demo_mesh

    base = demo_mesh(4000)
    mesh = lodkit.Mesh(base.vertices * 7.5, base.faces)
    pm = lodkit.progressive(mesh, absolute=True)
    rel = lodkit.progressive(mesh)
    for n in (2000, 600, int(pm.faces_per_step[-1])):
        r = lodkit.simplify(mesh, target_faces=n, absolute=True)
        step = int(np.searchsorted(-pm.faces_per_step, -n))        # the first step at n faces or fewer
        assert pm.errors_per_step[step] == pytest.approx(r.error, rel=1e-9)
    # the same run in relative units, times the diagonal
    diag = float(np.linalg.norm(mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0)))
    assert pm.errors_per_step[-1] == pytest.approx(rel.errors_per_step[-1] * diag, rel=1e-9)
