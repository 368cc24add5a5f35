"""`lodkit retile` and `lodkit optimize` on the command line, and both as methods of
lodkit.compare."""
from __future__ import annotations

import numpy as np
import open3d as o3d
import pytest

import lodkit
from lodkit.cli import main
from lodkit.geometry import weld_positions


@pytest.fixture
def sphere_ply(tmp_path):
    s = o3d.geometry.TriangleMesh.create_sphere(1.0, 12)
    m = lodkit.Mesh(*weld_positions(np.asarray(s.vertices), np.asarray(s.triangles)))
    path = tmp_path / "sphere.ply"
    lodkit.save(m, path)
    return path


def test_retile_cli(sphere_ply, tmp_path, capsys):
    out = tmp_path / "r.ply"
    assert main(["retile", str(sphere_ply), str(out), "--vertices", "60"]) == 0
    line = capsys.readouterr().out
    assert "triangle quality mean" in line and str(out) in line
    m = lodkit.load(out)
    assert m.n_vertices == 60
    assert lodkit.topology(m).genus == 0


def test_retile_cli_refine_is_the_api_call(sphere_ply, tmp_path):
    out = tmp_path / "r.ply"
    assert main(["retile", str(sphere_ply), str(out), "--vertices", "40", "--refine", "1", "--quiet"]) == 0
    api = lodkit.retile(lodkit.load(sphere_ply), 40, refine=1).mesh
    got = lodkit.load(out)
    # the same run: the same faces and, through the PLY's float64, the same positions
    np.testing.assert_array_equal(got.faces, api.faces)
    np.testing.assert_allclose(got.vertices, api.vertices, rtol=0, atol=1e-12)


def test_retile_cli_fit_is_the_api_call(sphere_ply, tmp_path):
    out = tmp_path / "r.ply"
    assert main(["retile", str(sphere_ply), str(out), "--vertices", "40", "--fit", "2", "--quiet"]) == 0
    api = lodkit.retile(lodkit.load(sphere_ply), 40, fit=2)
    assert api.report["fitted"] > 0
    got = lodkit.load(out)
    np.testing.assert_array_equal(got.faces, api.mesh.faces)
    np.testing.assert_allclose(got.vertices, api.mesh.vertices, rtol=0, atol=1e-12)


def test_optimize_cli_with_start(sphere_ply, tmp_path, capsys):
    start = tmp_path / "s.ply"
    out = tmp_path / "o.ply"
    assert main(["retile", str(sphere_ply), str(start), "--vertices", "40", "-q"]) == 0
    assert main(["optimize", str(sphere_ply), str(out), "--start", str(start), "--iterations", "2",
                 "--samples", "2000"]) == 0
    line = capsys.readouterr().out
    assert "energy" in line and "2 iterations" in line
    assert lodkit.load(out).n_faces > 0


def test_optimize_cli_vertices(sphere_ply, tmp_path):
    out = tmp_path / "o.ply"
    assert main(["optimize", str(sphere_ply), str(out), "--vertices", "50", "--iterations", "1", "-q"]) == 0
    assert abs(lodkit.load(out).n_vertices - 50) <= 5


def test_optimize_cli_creases_off_same_as_api(sphere_ply, tmp_path):
    from lodkit.optimize import optimize

    out = tmp_path / "o.ply"
    assert main(["optimize", str(sphere_ply), str(out), "--vertices", "40", "--iterations", "1",
                 "--creases", "0", "-q"]) == 0
    api = optimize(lodkit.load(sphere_ply), n_vertices=40, iterations=1, creases=None).mesh
    assert lodkit.load(out).n_faces == api.n_faces


@pytest.mark.parametrize("args,match", [
    (["retile", "{in}", "{out}", "--vertices", "2"], "n_vertices"),
    (["retile", "{in}", "{out}"], "--vertices"),
    (["optimize", "{in}", "{out}", "--start", "{missing}"], "cannot load"),
    (["retile", "{in}", "{out}", "--vertices", "10", "--adapt", "-1"], "adapt"),
])
def test_cli_errors_are_one_line(sphere_ply, tmp_path, capsys, args, match):
    argv = [a.format(**{"in": sphere_ply, "out": tmp_path / "x.ply", "missing": tmp_path / "nope.ply"})
            for a in args]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("lodkit: error:") and match in err[0]
    assert not (tmp_path / "x.ply").exists()


def test_compare_methods(sphere_ply):
    c = lodkit.compare(sphere_ply, metrics="qem", peers="retile,optimize", ratios=[0.3], samples=5000)
    by = {r.method: r for r in c.runs}
    for name in ("retile", "optimize"):
        assert by[name].error is None
        assert by[name].evaluation is not None
        assert abs(by[name].faces - by["qem"].faces) <= 0.1 * by["qem"].faces
