"""One atomic writer for every file lodkit writes (lodkit/io/atomic.py): a temporary beside
the target with a recognisable name, checked, fsynced, renamed; on any failure the old file
is untouched and nothing is left behind, also under a file size limit (ulimit -f) and after
SIGKILL (issue 18, item 2)."""
from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from conftest import lodkit_subprocess_env
from lodkit.errors import ImageIOError, MeshIOError
from lodkit.io import atomic_write, load, save
from lodkit.io.atomic import TEMP_PATTERN, clean_stale_temporaries, temporary_name
from lodkit.mesh import Mesh

resource = pytest.importorskip("resource")

TETRA_V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
TETRA_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
LIMIT = 100 * 1024


def listing(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir())


def big_mesh(n: int = 120) -> Mesh:
    """A height field of 2*(n-1)^2 faces: about 1 MB as binary PLY, more as OBJ."""
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    v = np.stack([x, y, 0.1 * np.sin(7 * x) * np.cos(5 * y)], axis=-1).reshape(-1, 3)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return Mesh(v, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]))


def limited(limit: int):
    """preexec_fn: a file size limit, SIGXFSZ ignored (so a write past it fails with EFBIG
    instead of killing the process; an ignored signal stays ignored across exec)."""
    def setup():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, hard))
    return setup


def run_python(code: str, cwd: Path, preexec=None, **kw):
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          cwd=cwd, env=lodkit_subprocess_env(), preexec_fn=preexec, timeout=600, **kw)


# ------------------------------------------------------------------ file size limit
def test_cli_simplify_to_obj_under_a_file_size_limit(tmp_path):
    pytest.importorskip("lodkit._core.decimate")
    save(big_mesh(), tmp_path / "in.ply")               # ~0.8 MB: written before the limit
    proc = subprocess.run([sys.executable, "-m", "lodkit", "simplify", str(tmp_path / "in.ply"),
                           str(tmp_path / "new.obj"), "--ratio", "0.9"], capture_output=True, text=True,
                          cwd=tmp_path, env=lodkit_subprocess_env(), preexec_fn=limited(LIMIT), timeout=600)
    assert proc.returncode != 0, proc.stdout
    assert "File too large" in proc.stderr and "new.obj" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr
    assert listing(tmp_path) == ["in.ply"]                 # no new.obj, no temporary


def test_save_over_an_existing_ply_under_a_file_size_limit(tmp_path):
    save(Mesh(TETRA_V, TETRA_F), tmp_path / "old.ply")
    before = (tmp_path / "old.ply").read_bytes()
    np.save(tmp_path / "v.npy", big_mesh().vertices)
    np.save(tmp_path / "f.npy", big_mesh().faces)
    proc = run_python("""
        import numpy as np, lodkit
        from lodkit.errors import MeshIOError
        m = lodkit.Mesh(np.load("v.npy"), np.load("f.npy"))
        try:
            lodkit.save(m, "old.ply")
        except MeshIOError as exc:
            print("refused:", exc, "errno", exc.errno)
        else:
            print("saved")
    """, tmp_path, preexec=limited(LIMIT))
    assert proc.returncode == 0, proc.stderr
    assert "refused:" in proc.stdout and "file size limit" in proc.stdout, proc.stdout
    assert f"errno {errno.EFBIG}" in proc.stdout
    assert (tmp_path / "old.ply").read_bytes() == before
    assert listing(tmp_path) == ["f.npy", "old.ply", "v.npy"]


# ------------------------------------------------------------------ SIGKILL
def test_sigkill_during_a_save_leaves_a_temporary_the_next_write_removes(tmp_path):
    save(Mesh(TETRA_V, TETRA_F), tmp_path / "old.ply")
    before = (tmp_path / "old.ply").read_bytes()
    child = subprocess.Popen([sys.executable, "-c", textwrap.dedent("""
        import os, sys, time, numpy as np, lodkit
        import lodkit.io.atomic as atomic

        def stall(fd):                      # the data is written; kill us before the rename
            print("ready", flush=True)
            time.sleep(120)
        atomic.os.fsync = stall
        v = np.random.default_rng(0).random((50, 3))
        lodkit.save(lodkit.Mesh(v, [[0, 1, 2]] * 10), "old.ply")
    """)], stdout=subprocess.PIPE, text=True, cwd=tmp_path, env=lodkit_subprocess_env())
    try:
        assert child.stdout.readline().strip() == "ready"
        left = [n for n in listing(tmp_path) if n != "old.ply"]
        assert len(left) == 1 and TEMP_PATTERN.match(left[0]), left
        assert left[0].startswith(".old.ply.lodkit-tmp-")
    finally:
        child.send_signal(signal.SIGKILL)
        child.wait()
        child.stdout.close()
    assert (tmp_path / "old.ply").read_bytes() == before        # the target never changed
    assert len(listing(tmp_path)) == 2
    save(Mesh(TETRA_V, TETRA_F), tmp_path / "other.obj")         # any write into the directory
    assert listing(tmp_path) == ["old.ply", "other.obj"]


def test_stale_temporaries_of_live_processes_are_kept(tmp_path):
    mine = tmp_path / temporary_name(tmp_path / "x.ply")
    mine.write_bytes(b"in progress")
    done = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    dead = tmp_path / f".y.ply.lodkit-tmp-{int(done.stdout)}-0123abcd.ply"
    dead.write_bytes(b"left by a killed process")
    other = tmp_path / ".y.ply.tmp-123-0123abcd"                  # not lodkit's pattern
    other.write_bytes(b"not ours")
    assert clean_stale_temporaries(tmp_path) == [dead.name]
    assert listing(tmp_path) == sorted([mine.name, other.name])


# ------------------------------------------------------------------ modes
def test_read_only_target_is_refused(tmp_path):
    target = tmp_path / "ro.ply"
    save(Mesh(TETRA_V, TETRA_F), target)
    before = target.read_bytes()
    target.chmod(0o444)
    try:
        with pytest.raises(MeshIOError, match="read-only") as info:
            save(Mesh(TETRA_V[[1, 0, 2, 3]], TETRA_F), target)
        assert info.value.errno == errno.EACCES and str(target) in str(info.value)
        with pytest.raises(MeshIOError, match="read-only"):
            atomic_write(target, lambda fh: fh.write("x"))
        assert target.read_bytes() == before and listing(tmp_path) == ["ro.ply"]
        assert target.stat().st_mode & 0o777 == 0o444
    finally:
        target.chmod(0o644)


def test_existing_target_keeps_its_mode(tmp_path):
    target = tmp_path / "private.ply"
    save(Mesh(TETRA_V, TETRA_F), target)
    target.chmod(0o600)
    save(Mesh(TETRA_V, TETRA_F), target)
    assert target.stat().st_mode & 0o777 == 0o600


def test_the_umask_is_never_touched(tmp_path, monkeypatch):
    def forbidden(mask):
        raise AssertionError("os.umask called")

    monkeypatch.setattr(os, "umask", forbidden)
    save(Mesh(TETRA_V, TETRA_F), tmp_path / "a.ply")
    atomic_write(tmp_path / "a.json", lambda fh: fh.write("{}"))
    import lodkit.viz as viz
    viz.write_png(tmp_path / "a.png", np.zeros((4, 5, 3), np.uint8))
    assert listing(tmp_path) == ["a.json", "a.ply", "a.png"]


# ------------------------------------------------------------------ every writer uses it
def test_png_goes_through_the_atomic_writer(tmp_path, monkeypatch):
    import lodkit.io.atomic as atomic
    import lodkit.viz as viz

    img = (np.arange(4 * 5 * 3) % 256).astype(np.uint8).reshape(4, 5, 3)
    viz.write_png(tmp_path / "a.png", img)
    before = (tmp_path / "a.png").read_bytes()
    o3d = pytest.importorskip("open3d")
    np.testing.assert_array_equal(np.asarray(o3d.io.read_image(str(tmp_path / "a.png"))), img)

    def refuse(src, dst):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(atomic.os, "replace", refuse)
    with pytest.raises(ImageIOError, match="No space left"):
        viz.write_png(tmp_path / "a.png", img[::-1].copy())
    assert (tmp_path / "a.png").read_bytes() == before and listing(tmp_path) == ["a.png"]


def test_atomic_write_text_failure_leaves_nothing(tmp_path):
    (tmp_path / "r.json").write_text("old")

    def broken(fh):
        fh.write("{half")
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(MeshIOError, match="No space left"):
        atomic_write(tmp_path / "r.json", broken)
    assert (tmp_path / "r.json").read_text() == "old" and listing(tmp_path) == ["r.json"]


def test_a_save_reads_back_what_it_wrote(tmp_path):
    m = big_mesh(20)
    for fmt in ("ply", "obj", "off", "stl", "glb", "gltf"):
        save(m, tmp_path / f"m.{fmt}")
        assert load(tmp_path / f"m.{fmt}").n_faces == m.n_faces
    assert all(TEMP_PATTERN.match(n) is None for n in listing(tmp_path))
