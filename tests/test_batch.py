"""lodkit.batch and `lodkit batch`: LOD chains for many files, on Dask, threads or in process.

The outputs must be the files a serial loop of ``simplify`` writes, bit for bit; a bad
file is a failed row; a re-run skips what is done.  Schedulers and workers started here
listen on 127.0.0.1 only, and every wait has a timeout.
"""
from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import lodkit
from conftest import lodkit_subprocess_env, shared_mesh_dir
from lodkit import cli
from lodkit.batch import find_inputs
from lodkit.demo import demo_mesh
from lodkit.errors import DependencyError, OptionError

RATIOS = [0.5, 0.1]


def write_meshes(directory: Path, sizes=(600, 900, 1200, 1500)) -> list:
    """Small generated meshes, one file each (different sizes, so different outputs)."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for i, n in enumerate(sizes):
        path = directory / f"mesh{i}.ply"
        lodkit.save(demo_mesh(n), path)
        paths.append(path)
    return paths


def serial_levels(path: Path, tmp: Path, ratios=RATIOS) -> list:
    """The bytes a plain serial loop writes: simplify(load(path), target_ratio=r) -> save."""
    mesh = lodkit.load(path)
    out = []
    for i, r in enumerate(ratios):
        dest = tmp / f"serial_{path.stem}_{i}.ply"
        lodkit.save(lodkit.simplify(mesh, target_ratio=r).mesh, dest)
        out.append(dest.read_bytes())
    return out


def assert_same_as_serial(paths, out_dir: Path, tmp: Path, ratios=RATIOS) -> None:
    for path in paths:
        expected = serial_levels(path, tmp, ratios)
        for i, data in enumerate(expected):
            got = (out_dir / f"{path.stem}_lod{i}.ply").read_bytes()
            assert got == data, f"{path.name} level {i} differs from the serial simplify output"


@pytest.fixture(scope="module")
def dask_client():
    """A LocalCluster of two single-threaded worker processes on loopback, shared by the module."""
    distributed = pytest.importorskip("distributed", reason="dask.distributed not installed (lodkit[dask])")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                       dashboard_address=None)
    client = distributed.Client(cluster, set_as_default=False)
    client.wait_for_workers(2, timeout=120)
    yield client
    client.close()
    cluster.close()


# ------------------------------------------------------------------- same outputs as serial
def test_sync_batch_equals_serial_simplify(tmp_path):
    paths = write_meshes(tmp_path / "in", sizes=(600, 900))
    result = lodkit.batch(tmp_path / "in", tmp_path / "out", ratios=RATIOS, scheduler="sync")
    assert [r["status"] for r in result.rows] == ["ok", "ok"]
    assert_same_as_serial(paths, tmp_path / "out", tmp_path)
    row = result.rows[0]
    assert [lv["faces"] for lv in row["levels"]] == [
        lodkit.simplify(lodkit.load(paths[0]), target_ratio=r).mesh.n_faces for r in RATIOS]


def test_largest_inputs_go_first_and_the_manifest_keeps_the_input_order(tmp_path, monkeypatch):
    """Longest processing time first: the tasks are submitted largest file first (a large
    mesh left to the end would keep one worker busy while the others wait); the rows and
    the manifest stay in the input order."""
    batch_module = sys.modules["lodkit.batch"]     # (lodkit.batch is also the function)

    paths = write_meshes(tmp_path / "in", sizes=(600, 3000, 1200))
    ran = []
    real = batch_module.run_item

    def recording(job, *args):
        ran.append(Path(job["input"]).name)
        return real(job, *args)

    monkeypatch.setattr(batch_module, "run_item", recording)
    result = lodkit.batch(paths, tmp_path / "out", ratios=RATIOS, scheduler="sync")
    by_size = sorted(paths, key=lambda p: p.stat().st_size, reverse=True)
    assert ran == [p.name for p in by_size] == ["mesh1.ply", "mesh2.ply", "mesh0.ply"]
    assert [Path(r["input"]).name for r in result.rows] == ["mesh0.ply", "mesh1.ply", "mesh2.ply"]
    with open(result.manifest["csv"], newline="") as fh:
        names = [Path(row["input"]).name for row in csv.DictReader(fh)]
    assert names == ["mesh0.ply", "mesh1.ply", "mesh2.ply"]


def test_four_meshes_on_four_threads_equal_serial_runs(tmp_path):
    """The core runs without the GIL: four meshes simplified at once on four threads give
    the files four serial runs give, bit for bit."""
    paths = write_meshes(tmp_path / "in", sizes=(3000, 3400, 3800, 4200))
    result = lodkit.batch(paths, tmp_path / "out", ratios=RATIOS, scheduler="threads", workers=4)
    assert result.n_ok == 4
    assert len({r["worker"] for r in result.rows}) >= 2      # not all on one thread
    assert_same_as_serial(paths, tmp_path / "out", tmp_path)


def test_local_cluster_equals_serial_simplify(tmp_path, dask_client):
    paths = write_meshes(tmp_path / "in")
    result = lodkit.batch(paths, tmp_path / "out", ratios=RATIOS, client=dask_client)
    assert result.n_ok == 4
    assert all(r["worker"].startswith("tcp://127.0.0.1:") for r in result.rows)
    assert_same_as_serial(paths, tmp_path / "out", tmp_path)


def test_shared_meshes_in_a_batch(tmp_path):
    directory = shared_mesh_dir()
    if directory is None or not (directory / "cow.obj").is_file():
        pytest.skip("real test meshes not found (cow.obj, fandisk.obj)")
    paths = [directory / "cow.obj", directory / "fandisk.obj"]
    result = lodkit.batch(paths, tmp_path / "out", ratios=[0.2], scheduler="threads", workers=2)
    assert result.n_ok == 2
    for path in paths:
        expected = lodkit.simplify(lodkit.load(path), target_ratio=0.2).mesh
        got = lodkit.load(tmp_path / "out" / f"{path.stem}_lod0.ply")
        assert np.array_equal(got.faces, expected.faces)
        assert np.array_equal(got.vertices, expected.vertices)


# ------------------------------------------------------------------- manifest and resume
def test_manifest_resume_and_failed_rows(tmp_path):
    paths = write_meshes(tmp_path / "in", sizes=(600, 900, 1200))
    bad = tmp_path / "in" / "broken.ply"
    bad.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 99999999\n")
    out = tmp_path / "out"
    first = lodkit.batch(tmp_path / "in", out, ratios=RATIOS, scheduler="threads", workers=2)
    status = {r["key"]: r["status"] for r in first.rows}
    assert status == {"broken": "failed", "mesh0": "ok", "mesh1": "ok", "mesh2": "ok"}
    failed = next(r for r in first.rows if r["key"] == "broken")
    assert "broken.ply" in failed["error"]

    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["counts"] == {"ok": 3, "skipped": 0, "failed": 1, "pending": 0}
    assert manifest["settings"]["ratios"] == RATIOS
    ok = next(r for r in manifest["items"] if r["key"] == "mesh0")
    assert len(ok["sha256"]) == 64 and ok["seconds"] >= 0 and ok["worker"]
    assert [lv["file"] for lv in ok["levels"]] == ["mesh0_lod0.ply", "mesh0_lod1.ply"]
    assert all(lv["error"] >= 0 for lv in ok["levels"])
    with open(out / "manifest.csv", newline="") as fh:
        rows = {r["key"]: r for r in csv.DictReader(fh)}
    assert rows["mesh1"]["status"] == "ok" and len(rows["mesh1"]["faces"].split(";")) == 2
    assert rows["broken"]["status"] == "failed" and rows["broken"]["error"]

    # the second run skips every ok input and tries the failed one again
    mtime = (out / "mesh0_lod0.ply").stat().st_mtime_ns
    second = lodkit.batch(tmp_path / "in", out, ratios=RATIOS, scheduler="threads", workers=2)
    assert {r["key"]: r["status"] for r in second.rows} == {**status, **{f"mesh{i}": "skipped" for i in range(3)}}
    assert (out / "mesh0_lod0.ply").stat().st_mtime_ns == mtime
    assert second.rows[1]["levels"] == first.rows[1]["levels"]

    # a changed file, a deleted output or other settings run again
    lodkit.save(demo_mesh(700), paths[0])
    (out / "mesh1_lod1.ply").unlink()
    third = lodkit.batch(tmp_path / "in", out, ratios=RATIOS, scheduler="sync")
    assert {r["key"]: r["status"] for r in third.rows}["mesh0"] == "ok"
    assert {r["key"]: r["status"] for r in third.rows}["mesh1"] == "ok"
    assert {r["key"]: r["status"] for r in third.rows}["mesh2"] == "skipped"
    fourth = lodkit.batch(tmp_path / "in", out, ratios=[0.3], scheduler="sync")
    assert fourth.n_skipped == 0 and fourth.n_ok == 3
    fifth = lodkit.batch(tmp_path / "in", out, ratios=[0.3], scheduler="sync", resume=False)
    assert fifth.n_skipped == 0


def test_inputs_folders_globs_and_keys(tmp_path):
    write_meshes(tmp_path / "lib" / "a", sizes=(600,))
    write_meshes(tmp_path / "lib" / "b", sizes=(600,))
    (tmp_path / "lib" / "notes.txt").write_text("not a mesh")
    found = find_inputs([tmp_path / "lib"])
    assert [key for _, key in found] == ["a/mesh0", "b/mesh0"]
    # outputs inside an input folder are not inputs the next time
    result = lodkit.batch(tmp_path / "lib", tmp_path / "lib" / "out", ratios=[0.5], scheduler="sync")
    assert (tmp_path / "lib" / "out" / "a" / "mesh0_lod0.ply").is_file()
    again = lodkit.batch(tmp_path / "lib", tmp_path / "lib" / "out", ratios=[0.5], scheduler="sync")
    assert len(again.rows) == len(result.rows) == 2 and again.n_skipped == 2
    # a glob; two files that would write the same outputs; nothing found
    globbed = lodkit.batch(str(tmp_path / "lib" / "a" / "*.ply"), tmp_path / "g", ratios=[0.5], scheduler="sync")
    assert [r["key"] for r in globbed.rows] == ["mesh0"]
    with pytest.raises(OptionError, match="would both write mesh0_lod"):
        lodkit.batch(str(tmp_path / "lib" / "[ab]" / "*.ply"), tmp_path / "x", scheduler="sync")
    with pytest.raises(OptionError, match="no file matches"):
        lodkit.batch(str(tmp_path / "*.obj"), tmp_path / "x", scheduler="sync")
    with pytest.raises(OptionError, match="no such file"):
        lodkit.batch(tmp_path / "missing.ply", tmp_path / "x", scheduler="sync")


@pytest.mark.parametrize("options, message", [
    ({"ratios": [0.5, 2.0]}, "ratios must be"),
    ({"format": "stl"}, "format must be"),
    ({"target_faces": 10}, "passes only"),
    ({"scheduler": "nonsense"}, "scheduler must be"),
    ({"scheduler": "threads", "workers": 0}, "workers must be"),
    ({"metric": "no_such_metric"}, "no_such_metric"),
])
def test_bad_options(tmp_path, options, message):
    write_meshes(tmp_path / "in", sizes=(600,))
    with pytest.raises(OptionError, match=message):
        lodkit.batch(tmp_path / "in", tmp_path / "out", **options)


def test_without_dask_a_clear_error(tmp_path, monkeypatch):
    write_meshes(tmp_path / "in", sizes=(600,))
    monkeypatch.setitem(sys.modules, "distributed", None)      # import distributed -> ImportError
    with pytest.raises(DependencyError, match=r"pip install 'lodkit\[dask\]'"):
        lodkit.batch(tmp_path / "in", tmp_path / "out")
    # threads and sync need no Dask
    assert lodkit.batch(tmp_path / "in", tmp_path / "out", scheduler="threads").n_ok == 1
    assert cli.main(["batch", str(tmp_path / "in"), "--out-dir", str(tmp_path / "out2")]) == cli.EXIT_USAGE


# ------------------------------------------------------------------- the command line
def test_cli_batch(tmp_path, capsys):
    write_meshes(tmp_path / "in", sizes=(600, 900))
    (tmp_path / "in" / "bad.obj").write_text("v 0 0 0\nf 1 2 3\n")
    args = ["batch", str(tmp_path / "in"), "--out-dir", str(tmp_path / "out"), "--ratios", "0.5,0.2",
            "--scheduler", "threads", "--threads", "2"]
    assert cli.main(args) == cli.EXIT_FAILED
    captured = capsys.readouterr()
    assert "3 inputs: 2 done, 0 skipped (already done), 1 failed" in captured.out
    assert "1 of 3 inputs failed" in captured.err and "bad.obj" in captured.err
    (tmp_path / "in" / "bad.obj").unlink()
    assert cli.main(args) == cli.EXIT_OK
    assert "2 inputs: 0 done, 2 skipped" in capsys.readouterr().out
    assert cli.main(args[:-2] + ["--quiet", "--force"]) == cli.EXIT_OK
    assert capsys.readouterr().out == ""
    assert cli.main(["batch", str(tmp_path / "in"), "--out-dir", str(tmp_path / "o"), "--threads", "2"]) \
        == cli.EXIT_USAGE
    assert "--threads goes with --scheduler threads" in capsys.readouterr().err


def _wait_for(predicate, timeout: float, what: str):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.2)
    raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")


def test_cli_batch_on_a_running_scheduler(tmp_path):
    """`dask scheduler` and `dask worker` started as Dask's own commands, on loopback; the
    batch connects with --scheduler."""
    pytest.importorskip("distributed", reason="dask.distributed not installed (lodkit[dask])")
    paths = write_meshes(tmp_path / "in", sizes=(600, 900))
    env = lodkit_subprocess_env()
    sched_file = tmp_path / "scheduler.json"
    procs = []
    try:
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
             "--scheduler-file", str(sched_file)], cwd=tmp_path, env=env,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        _wait_for(lambda: sched_file.is_file() and sched_file.stat().st_size > 0, 60, "the scheduler")
        address = json.loads(sched_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "dask", "worker", address, "--host", "127.0.0.1", "--nworkers", "1",
             "--nthreads", "1", "--no-dashboard"], cwd=tmp_path, env=env,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        out = tmp_path / "out"
        run = subprocess.run([sys.executable, "-m", "lodkit", "batch", str(tmp_path / "in"), "--out-dir", str(out),
                              "--ratios", ",".join(map(str, RATIOS)), "--scheduler", address],
                             cwd=tmp_path, env=env, capture_output=True, text=True, timeout=240)
        assert run.returncode == 0, run.stderr
        assert "2 inputs: 2 done" in run.stdout
        workers = {r["worker"] for r in json.loads((out / "manifest.json").read_text())["items"]}
        assert len(workers) == 1 and workers.pop().startswith("tcp://127.0.0.1:")
        assert_same_as_serial(paths, out, tmp_path)
    finally:
        for proc in reversed(procs):
            proc.send_signal(signal.SIGTERM)
        for proc in reversed(procs):
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=30)


def test_a_worker_killed_in_the_middle(tmp_path, dask_client):
    """One worker process dies (SIGKILL) while the batch runs: Dask runs its task again
    elsewhere, the batch completes, every file is there and loads, the manifest is complete."""
    paths = write_meshes(tmp_path / "in", sizes=tuple(range(20_000, 32_000, 1000)))
    out = tmp_path / "out"
    pids = dask_client.run(os.getpid)
    victim = sorted(pids.values())[0]
    killed = []

    def kill_after_first_output():
        try:
            _wait_for(lambda: any(out.glob("*_lod*.ply")), 120, "the first output")
        except AssertionError:
            return
        os.kill(victim, signal.SIGKILL)
        killed.append(victim)

    killer = threading.Thread(target=kill_after_first_output, daemon=True)
    killer.start()
    result = lodkit.batch(paths, out, ratios=RATIOS, client=dask_client)
    assert killed == [victim], "the worker was not killed before the batch ended"
    killer.join(timeout=60)
    assert result.n_ok == len(paths), [r["error"] for r in result.rows]
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["counts"]["ok"] == len(paths) and len(manifest["items"]) == len(paths)
    for path in paths:
        for i in range(len(RATIOS)):
            assert lodkit.load(out / f"{path.stem}_lod{i}.ply").n_faces > 0
    dask_client.wait_for_workers(2, timeout=120)      # the nanny restarted it, for the next tests


def test_a_cluster_without_workers_fails_instead_of_waiting(tmp_path, monkeypatch):
    """Workers that never start (lodkit missing on them, a broken environment) used to
    leave the batch waiting for ever; after the grace period it is one clear error."""
    distributed = pytest.importorskip("distributed", reason="dask.distributed not installed (lodkit[dask])")
    import lodkit._executor as executor

    monkeypatch.setattr(executor, "NO_WORKER_GRACE", 1.0)
    monkeypatch.setattr(executor, "_POLL", 0.3)
    paths = write_meshes(tmp_path / "in", sizes=(600,))
    with distributed.LocalCluster(n_workers=0, processes=True, host="127.0.0.1", dashboard_address=None) as cluster, \
            distributed.Client(cluster, set_as_default=False) as client:
        t0 = time.monotonic()
        with pytest.raises(lodkit.LodkitError, match="no worker"):
            lodkit.batch(paths, tmp_path / "out", ratios=RATIOS, client=client)
        assert time.monotonic() - t0 < 30


def test_batch_polish_equals_serial_polished_simplify(tmp_path):
    """batch(..., polish=True) and `lodkit batch --polish`: each level is simplify(polish=True)'s."""
    from lodkit.cli import main
    paths = write_meshes(tmp_path / "in", sizes=(900,))
    result = lodkit.batch(paths, tmp_path / "out", ratios=RATIOS, scheduler="sync", polish=True)
    assert [r["status"] for r in result.rows] == ["ok"]
    mesh = lodkit.load(paths[0])
    for i, r in enumerate(RATIOS):
        want = lodkit.simplify(mesh, target_ratio=r, polish=True).mesh
        plain = lodkit.simplify(mesh, target_ratio=r).mesh
        got = lodkit.load(tmp_path / "out" / f"{paths[0].stem}_lod{i}.ply")
        np.testing.assert_allclose(got.vertices, want.vertices, rtol=0, atol=1e-6)   # PLY stores float32
        assert np.abs(got.vertices - plain.vertices).max() > 1e-5
    assert main(["batch", str(paths[0]), "--out-dir", str(tmp_path / "cli"), "--ratios", "0.2", "--polish",
                 "--scheduler", "sync", "--quiet"]) == 0
    got = lodkit.load(tmp_path / "cli" / f"{paths[0].stem}_lod0.ply")
    want = lodkit.simplify(mesh, target_ratio=0.2, polish=True).mesh
    np.testing.assert_allclose(got.vertices, want.vertices, rtol=0, atol=1e-6)
