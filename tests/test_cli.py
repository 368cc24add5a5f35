"""The ``lodkit`` command, run in-process through lodkit.cli.main."""
from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import lodkit
from lodkit.cli import main

REPO = Path(__file__).resolve().parents[1]
# where the lodkit under test lives (the installed copy in CI, the source tree in a dev
# checkout): subprocesses must import that one, not an unbuilt source tree
LODKIT_ROOT = Path(lodkit.__file__).resolve().parents[1]


def _simplify_available() -> bool:
    try:
        import lodkit._core.decimate  # noqa: F401
        from lodkit.api import simplify  # noqa: F401
    except ImportError:
        return False
    return True


needs_simplify = pytest.mark.skipif(
    not _simplify_available(), reason="lodkit.simplify or its Cython core is not built yet"
)

TETRAHEDRON = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
TETRA_VERTICES = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])


@pytest.fixture
def tetra_ply(tmp_path) -> Path:
    """A closed tetrahedron written by Open3D itself (not by lodkit.save)."""
    o3d = pytest.importorskip("open3d")
    m = o3d.geometry.TriangleMesh()
    m.vertices = o3d.utility.Vector3dVector(TETRA_VERTICES)
    m.triangles = o3d.utility.Vector3iVector(TETRAHEDRON.astype(np.int32))
    path = tmp_path / "tetra.ply"
    assert o3d.io.write_triangle_mesh(str(path), m)
    return path


@pytest.fixture
def surface_ply(tmp_path) -> Path:
    """The demo surface at 2000 faces, with normals and colours, written by Open3D."""
    pytest.importorskip("open3d")
    import open3d as o3d

    from lodkit.demo import demo_mesh

    path = tmp_path / "surface.ply"
    assert o3d.io.write_triangle_mesh(str(path), demo_mesh(2000).to_open3d())
    return path


def one_error_line(capsys) -> str:
    """The single stderr line of a failed command (and no traceback)."""
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("lodkit: error: "), err
    assert "Traceback" not in err
    return lines[0]


# ---------------------------------------------------------------------- info
def test_info_table(tetra_ply, capsys):
    assert main(["info", str(tetra_ply)]) == 0
    out = capsys.readouterr().out
    rows = dict(re.split(r"\s{2,}", line, maxsplit=1) for line in out.splitlines())
    assert rows["vertices"].startswith("4 ")
    assert rows["faces"].startswith("4 ")
    assert rows["manifold"] == "yes"
    assert rows["closed"] == "yes"
    assert rows["genus"] == "0"
    assert rows["components"] == "1"
    assert rows["euler characteristic"] == "2"
    assert float(rows["bbox diagonal"]) == pytest.approx(np.sqrt(3))
    assert rows["attributes"] == "none"


def test_info_json(tetra_ply, capsys):
    assert main(["info", "--json", str(tetra_ply)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["bbox_diagonal"] == pytest.approx(np.sqrt(3))
    assert info["attributes"] == []
    topo = info["topology"]
    assert topo["n_faces"] == 4 and topo["n_edges"] == 6
    assert topo["genus"] == 0 and topo["is_closed"] is True and topo["is_manifold"] is True


def test_info_reports_attributes_and_boundary(surface_ply, capsys):
    assert main(["info", "--json", str(surface_ply)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["attributes"] == ["colors", "normals"]
    assert info["topology"]["n_boundary_loops"] == 1
    assert info["topology"]["genus"] == 0


def test_info_on_shared_mesh_with_uv_seams(capsys):
    from conftest import shared_mesh

    path = shared_mesh("spot_triangulated.obj")
    assert main(["info", "--json", str(path)]) == 0
    info = json.loads(capsys.readouterr().out)
    # 3225 (position, uv) vertices, but the shape is the closed genus-0 cow of 2930 positions
    assert info["n_vertices"] == 3225 and info["uv_seam_split_vertices"] == 3225 - 2930
    assert info["topology"]["is_closed"] and info["topology"]["genus"] == 0
    assert "uvs" in info["attributes"]


# ---------------------------------------------------------------------- errors
def test_missing_file(tmp_path, capsys):
    missing = tmp_path / "nope.ply"
    assert main(["info", str(missing)]) == 2
    line = one_error_line(capsys)
    assert str(missing) in line


def test_missing_input_for_simplify(tmp_path, capsys):
    assert main(["simplify", str(tmp_path / "nope.ply"), str(tmp_path / "out.ply"), "--ratio", "0.5"]) == 2
    assert "nope.ply" in one_error_line(capsys)
    assert not (tmp_path / "out.ply").exists()


def test_unreadable_file(tmp_path, capsys):
    junk = tmp_path / "junk.ply"
    junk.write_bytes(b"this is not a mesh\n" * 10)
    assert main(["info", str(junk)]) == 2
    assert "junk.ply" in one_error_line(capsys)


def test_directory_as_input(tmp_path, capsys):
    folder = tmp_path / "folder.ply"
    folder.mkdir()
    assert main(["info", str(folder)]) == 2
    one_error_line(capsys)


@pytest.mark.parametrize("ratio", ["1.5", "0", "-0.2", "abc", "nan"])
def test_invalid_ratio(tetra_ply, tmp_path, capsys, ratio):
    out = tmp_path / "out.ply"
    assert main(["simplify", str(tetra_ply), str(out), f"--ratio={ratio}"]) == 2
    assert "--ratio" in one_error_line(capsys)
    assert not out.exists()


@pytest.mark.parametrize("args", [
    ["--faces", "0"], ["--faces", "1.5"], ["--max-error", "-1"], ["--placement", "middle"],
    ["--boundary", "glue"], [],
], ids=["faces 0", "faces float", "negative error", "placement", "boundary", "no target"])
def test_invalid_options(tetra_ply, tmp_path, capsys, args):
    assert main(["simplify", str(tetra_ply), str(tmp_path / "out.ply"), *args]) == 2
    one_error_line(capsys)


def test_bad_output_path_fails_before_any_work(tetra_ply, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(lodkit, "load", lambda *a, **k: pytest.fail("loaded before checking the output"))
    assert main(["simplify", str(tetra_ply), str(tmp_path / "out.xyz"), "--ratio", "0.5"]) == 2
    assert "out.xyz" in one_error_line(capsys)
    assert main(["simplify", str(tetra_ply), str(tmp_path / "no" / "dir.ply"), "--ratio", "0.5"]) == 2
    assert "does not exist" in one_error_line(capsys)


def test_usage_errors(capsys):
    assert main(["bogus"]) == 2
    one_error_line(capsys)
    assert main(["info"]) == 2
    one_error_line(capsys)
    assert main([]) == 2                       # no command: the help, on stderr
    assert "usage" in capsys.readouterr().err


def test_help_exits_0(capsys):
    assert main(["--help"]) == 0
    assert "simplify" in capsys.readouterr().out
    assert main(["simplify", "--help"]) == 0
    assert "--max-error" in capsys.readouterr().out


def test_os_error_and_interrupt(tetra_ply, capsys, monkeypatch):
    def denied(path):
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(lodkit, "load", denied)
    assert main(["info", str(tetra_ply)]) == 2
    assert "Permission denied" in one_error_line(capsys)

    def interrupted(path):
        raise KeyboardInterrupt

    monkeypatch.setattr(lodkit, "load", interrupted)
    assert main(["info", str(tetra_ply)]) == 130
    assert "Traceback" not in capsys.readouterr().err


def test_lodkit_error_from_the_library_is_one_line(tetra_ply, capsys, monkeypatch):
    def broken(path):
        raise lodkit.MeshError("faces must have shape (m, 3),\n  got (4, 4)")

    monkeypatch.setattr(lodkit, "load", broken)
    assert main(["info", str(tetra_ply)]) == 2
    assert "got (4, 4)" in one_error_line(capsys)


def test_python_dash_m(tmp_path):
    # cwd outside the checkout: -m puts the current directory first on sys.path
    proc = subprocess.run([sys.executable, "-m", "lodkit", "--help"], capture_output=True, text=True,
                          cwd=tmp_path, env={"PYTHONPATH": str(LODKIT_ROOT), "PATH": ""}, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("usage: lodkit")


# ---------------------------------------------------------------------- simplify / demo
@needs_simplify
def test_simplify_end_to_end(surface_ply, tmp_path, capsys):
    out = tmp_path / "half.ply"
    assert main(["simplify", str(surface_ply), str(out), "--ratio", "0.5"]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""                       # stderr is not a terminal: no progress bar
    lines = captured.out.strip().splitlines()
    assert len(lines) == 1
    assert "2048 -> " in lines[0] and "target_faces" in lines[0] and str(out) in lines[0]
    result = lodkit.load(out)
    assert result.n_faces == pytest.approx(1024, abs=2)
    assert result.colors is not None and result.normals is not None


@pytest.fixture
def simplify_spy(monkeypatch):
    """The keyword arguments the CLI passes to lodkit.simplify (the real one still runs)."""
    seen = {}
    real = lodkit.simplify

    def spy(mesh, **kwargs):
        seen.update(kwargs)
        return real(mesh, **kwargs)

    monkeypatch.setattr(lodkit, "simplify", spy)
    return seen


@needs_simplify
def test_simplify_options_reach_the_library(surface_ply, tmp_path, capsys, simplify_spy):
    seen = simplify_spy
    out = tmp_path / "out.obj"
    argv = ["simplify", str(surface_ply), str(out), "--faces", "300", "--max-error", "0.01", "--absolute",
            "--metric", "qem", "--placement", "endpoint", "--boundary", "lock", "--max-normal-angle", "60",
            "--min-quality", "0.1", "--quiet"]
    assert main(argv) == 0
    assert capsys.readouterr().out == ""            # --quiet: no summary
    assert seen == dict(target_faces=300, max_error=0.01, absolute=True, metric="qem", placement="endpoint",
                        boundary="lock", max_normal_angle=60.0, min_quality=0.1, progress=False)
    assert lodkit.load(out).n_faces >= 300


@needs_simplify
def test_simplify_library_option_error(surface_ply, tmp_path, capsys):
    assert main(["simplify", str(surface_ply), str(tmp_path / "o.ply"), "--ratio", "0.5",
                 "--metric", "no-such-metric"]) == 2
    assert "no-such-metric" in one_error_line(capsys)
    assert not (tmp_path / "o.ply").exists()


@needs_simplify
def test_progress_bar_when_stderr_is_a_terminal(surface_ply, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("lodkit.cli._is_tty", lambda stream: True)
    assert main(["simplify", str(surface_ply), str(tmp_path / "o.ply"), "--ratio", "0.5"]) == 0
    err = capsys.readouterr().err
    assert "\r" in err and "100%" in err and "faces/s" in err       # tqdm's bar


@needs_simplify
def test_demo_command(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--faces", "4000"]) == 0
    text = capsys.readouterr().out
    assert "stop reason" in text
    files = sorted(p.name for p in out.iterdir())
    assert files == [f"demo_lod{i}.ply" for i in range(5)] + ["demo_lods.png"]
    assert f"picture of the levels: {out / 'demo_lods.png'}" in text


# ---------------------------------------------------------------------- metrics
@pytest.fixture
def builtin_metrics_only(monkeypatch):
    """lodkit's own metrics only, whatever plugins the environment has installed."""
    import lodkit.metrics

    monkeypatch.setenv(lodkit.metrics.DISCOVERY_ENV, "0")
    lodkit.metrics.refresh()
    yield
    lodkit.metrics.refresh()


@pytest.fixture
def broken_plugin(monkeypatch):
    """Discovery over two fake entry points: one that fails to import, one that works."""
    from importlib import metadata

    import lodkit.metrics

    class Dist:
        metadata = {"Name": "acme-metrics"}
        version = "0.3"

    def entry_point(name, value):
        ep = metadata.EntryPoint(name, value, lodkit.metrics.GROUP)
        return type("EP", (), {"name": name, "value": value, "dist": Dist, "load": staticmethod(ep.load)})()

    monkeypatch.delenv(lodkit.metrics.DISCOVERY_ENV, raising=False)
    monkeypatch.setattr(lodkit.metrics, "_entry_points", lambda: [
        entry_point("acme_broken", "acme_no_such_module:Metric"),
        entry_point("acme_qem", "lodkit.metrics.qem:QEM"),
    ])
    lodkit.metrics.refresh()
    yield
    lodkit.metrics.refresh()


def metrics_table(out: str) -> dict:
    lines = out.strip().splitlines()
    assert re.split(r"\s+", lines[0]) == ["name", "package", "version", "kind", "status"]
    rows = {}
    for line in lines[1:]:
        name, package, version, kind, status = re.split(r"\s{2,}", line, maxsplit=4)
        rows[(name, package)] = (version, kind, status)
    return rows


BUILTIN_KINDS = {"appearance": "quadric", "curvature": "kernel", "importance": "field", "melod": "kernel",
                 "normal_qem": "quadric", "qem": "quadric", "qem_native": "kernel",
                 "schroeder": "removal", "volume": "removal"}


def test_metrics_table(builtin_metrics_only, capsys):
    assert main(["metrics"]) == 0
    rows = metrics_table(capsys.readouterr().out)
    v = lodkit.__version__
    assert rows == {(name, "lodkit"): (v, BUILTIN_KINDS[name], "ok") for name in BUILTIN_KINDS}


def test_metrics_json(builtin_metrics_only, capsys):
    assert main(["metrics", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [(r["name"], r["package"], r["kind"], r["status"], r["ok"]) for r in rows] == [
        (name, "lodkit", BUILTIN_KINDS[name], "ok", True) for name in sorted(BUILTIN_KINDS)]
    assert all(r["version"] == lodkit.__version__ and r["description"] for r in rows)


def test_metrics_lists_a_broken_plugin_with_its_error(broken_plugin, capsys):
    assert main(["metrics"]) == 0
    rows = metrics_table(capsys.readouterr().out)
    assert rows[("acme_broken", "acme-metrics")] == (
        "0.3", "-", "import failed: ModuleNotFoundError: No module named 'acme_no_such_module'")
    assert rows[("acme_qem", "acme-metrics")] == ("0.3", "quadric", "ok")
    assert rows[("qem", "lodkit")][1:] == ("quadric", "ok")
    assert main(["metrics", "--json"]) == 0
    by_name = {r["name"]: r for r in json.loads(capsys.readouterr().out)}
    broken = by_name["acme_broken"]
    assert broken["ok"] is False and broken["kind"] is None and "acme_no_such_module" in broken["status"]
    assert broken["qualified"] == "acme-metrics:acme_broken" and broken["target"] == "acme_no_such_module:Metric"


def test_metrics_command_with_a_real_broken_distribution(tmp_path):
    """A .dist-info whose entry point cannot be imported: the command lists it, exit 0."""
    info = tmp_path / "acme_broken-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: acme-broken\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[lodkit.metrics]\nacme_broken = acme_no_such_module:X\n")
    env = {"PYTHONPATH": f"{tmp_path}{__import__('os').pathsep}{LODKIT_ROOT}", "PATH": ""}
    proc = subprocess.run([sys.executable, "-m", "lodkit", "metrics", "--json"], capture_output=True, text=True,
                          cwd=tmp_path, env=env, timeout=120)
    assert proc.returncode == 0, proc.stderr
    rows = {(r["name"], r["package"]): r for r in json.loads(proc.stdout)}
    assert rows[("acme_broken", "acme-broken")]["ok"] is False
    assert rows[("qem", "lodkit")]["status"] == "ok"


@pytest.mark.parametrize("text, spec", [
    ("qem", "qem"),
    ("importance:weight=2", ("importance", {"weight": 2})),
    ("importance:weight=2.5,merge=min,mode=add", ("importance", {"weight": 2.5, "merge": "min", "mode": "add"})),
    ("acme-metrics:curv", "acme-metrics:curv"),
    ("acme-metrics:curv:weight=1e-3,flag=true,off=False,n=-3",
     ("acme-metrics:curv", {"weight": 0.001, "flag": True, "off": False, "n": -3})),
    (" qem : weight = 2 ", ("qem", {"weight": 2})),
    ("acme:mode=yes,flag=TRUE,x=1.5e2,name=no", ("acme", {"mode": "yes", "flag": True, "x": 150.0, "name": "no"})),
])
def test_metric_option_parsing(text, spec):
    from lodkit.cli import _metric_option

    assert _metric_option(text) == spec


@pytest.mark.parametrize("text", ["", ":weight=2", "qem:weight=1,oops", "qem:=3", "qem:weight=1,weight=2",
                                  "qem::weight=1"])
def test_bad_metric_option_syntax(tetra_ply, tmp_path, capsys, text):
    assert main(["simplify", str(tetra_ply), str(tmp_path / "o.ply"), "--faces", "2", "--metric", text]) == 2
    assert "--metric" in one_error_line(capsys)


@needs_simplify
def test_metric_options_reach_the_library(surface_ply, tmp_path, simplify_spy):
    seen = simplify_spy
    argv = ["simplify", str(surface_ply), str(tmp_path / "o.ply"), "--ratio", "0.5", "--quiet",
            "--metric", "qem", "--metric", "qem_native:weight=0.5"]
    assert main(argv) == 0
    assert seen["metric"] == ["qem", ("qem_native", {"weight": 0.5})]   # exact: the option as given
    seen.clear()
    assert main(argv[:6]) == 0                       # no --metric: simplify's default
    assert "metric" not in seen


@needs_simplify
def test_simplify_with_qem_native(builtin_metrics_only, surface_ply, tmp_path, capsys):
    a, b = tmp_path / "a.ply", tmp_path / "b.ply"
    assert main(["simplify", str(surface_ply), str(a), "--ratio", "0.3", "--metric", "qem"]) == 0
    assert main(["simplify", str(surface_ply), str(b), "--ratio", "0.3", "--metric", "qem_native"]) == 0
    assert "target_faces" in capsys.readouterr().out
    ma, mb = lodkit.load(a), lodkit.load(b)
    assert np.array_equal(ma.faces, mb.faces) and np.array_equal(ma.vertices, mb.vertices)


@needs_simplify
def test_importance_needs_values_on_the_command_line(builtin_metrics_only, surface_ply, tmp_path, capsys):
    out = tmp_path / "o.ply"
    assert main(["simplify", str(surface_ply), str(out), "--ratio", "0.5",
                 "--metric", "qem", "--metric", "importance:weight=2"]) == 2
    line = one_error_line(capsys)
    assert "importance" in line and "values" in line
    assert not out.exists()


@pytest.mark.parametrize("metric, message", [
    ("kurvature", "unknown metric 'kurvature'; available: " + ", ".join(sorted(BUILTIN_KINDS))),
    ("qem:weight=-1", "metric 'qem': option 'weight' must be a number >= 0.0, got -1"),
    ("qem:wieght=1", "metric 'qem' has no option 'wieght'; its options: weight"),
    ("importance:merge=median", "option 'merge' must be one of"),
])
def test_bad_metric_fails_before_loading(builtin_metrics_only, tetra_ply, tmp_path, capsys, monkeypatch,
                                         metric, message):
    monkeypatch.setattr(lodkit, "load", lambda *a, **k: pytest.fail("loaded before checking --metric"))
    assert main(["simplify", str(tetra_ply), str(tmp_path / "o.ply"), "--faces", "2",
                 "--metric", "qem", "--metric", metric]) == 2
    assert message in one_error_line(capsys)


class _NoSystemLibrary:
    """An import finder that fails as Open3D's import does on a machine without libusb."""

    def find_spec(self, name, path=None, target=None):
        if name == "open3d" or name.startswith("open3d."):
            raise OSError("libusb-1.0.so.0: cannot open shared object file: No such file or directory")
        return None


@pytest.mark.parametrize("command", ["demo", "compare"])
def test_a_missing_system_library_is_not_needed(command, tmp_path, capsys, monkeypatch):
    """lodkit reads and writes files with its own code and renders with numpy when Open3D
    cannot be loaded: demo and compare work on a machine without Open3D's system libraries."""
    src = tmp_path / "in.ply"
    lodkit.save(lodkit.Mesh(np.eye(3) + [[0, 0, 0], [0, 0, 0], [0, 0, 1]], [[0, 1, 2], [0, 2, 1]]), src)
    monkeypatch.delitem(sys.modules, "open3d", raising=False)
    monkeypatch.setattr(sys, "meta_path", [_NoSystemLibrary(), *sys.meta_path])
    argv = (["demo", "--out", str(tmp_path / "d"), "--faces", "200"] if command == "demo"
            else ["compare", str(src), "--out", str(tmp_path / "c"), "--samples", "100", "-q"])
    code = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert code == 0 or (code == 2 and len(err.strip().splitlines()) == 1), err


def test_a_missing_system_library_is_one_clear_error(monkeypatch):
    """Where Open3D is needed (conversions, its renderer), a missing system library is one
    DependencyError naming the package to install."""
    from lodkit import deps

    monkeypatch.delitem(sys.modules, "open3d", raising=False)
    monkeypatch.setattr(sys, "meta_path", [_NoSystemLibrary(), *sys.meta_path])
    with pytest.raises(lodkit.DependencyError) as info:
        deps.open3d()
    message = str(info.value)
    assert "libusb-1.0.so.0" in message and "apt-get install libusb-1.0-0" in message and "\n" not in message


def test_getting_started_synopsis_is_argparse_s(tmp_path):
    """docs/getting-started.md's command-line synopsis is what the parser prints today."""
    import shutil

    from lodkit.cli import update_synopsis

    doc = Path(__file__).resolve().parents[1] / "docs" / "getting-started.md"
    if not doc.is_file():
        pytest.skip("docs/ is not beside the tests")
    copy = tmp_path / "gs.md"
    shutil.copy(doc, copy)
    assert not update_synopsis(copy), (
        "docs/getting-started.md's CLI synopsis is out of date; regenerate it with: "
        "python -c \"import lodkit.cli as c; c.update_synopsis('docs/getting-started.md')\"")
    assert "lodkit lods [-h] --ratios" in copy.read_text()
