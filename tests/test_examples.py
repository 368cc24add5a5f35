"""docs/examples/: each script runs headless with --png and writes a non-blank picture.

The scripts run in subprocesses (as a user runs them), on a small sphere written to a
file and on the built-in demo surface; PYTHONPATH points at this lodkit. The renderer
choice of this process is passed down (LODKIT_RENDER_BACKEND) so each script does not
probe Open3D again.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import lodkit
import lodkit.render as lr

REPO = Path(lodkit.__file__).resolve().parents[1]          # the lodkit under test
EXAMPLES = Path(__file__).resolve().parents[1] / "docs" / "examples"   # the checkout's scripts
o3d = pytest.importorskip("open3d", reason="the examples read meshes and write PNG files through Open3D")


def has_progressive() -> bool:
    return hasattr(lodkit, "progressive") and hasattr(getattr(lodkit, "ProgressiveMesh", None), "at")


@pytest.fixture(scope="module")
def sphere_file(tmp_path_factory):
    s = o3d.geometry.TriangleMesh.create_sphere(1.0, 12)
    path = tmp_path_factory.mktemp("mesh") / "sphere.ply"
    lodkit.save(lodkit.Mesh.from_open3d(s), path)
    return path


def run(script: str, args: list[str], png: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
               LODKIT_RENDER_BACKEND=lr.backend())
    proc = subprocess.run([sys.executable, str(EXAMPLES / script), *args, "--png", str(png), "--size", "120x90"],
                          env=env, capture_output=True, text=True, timeout=240)
    assert proc.returncode == 0, f"{script} failed:\n{proc.stdout}\n{proc.stderr[-3000:]}"
    assert png.is_file(), proc.stdout
    return proc


def check_picture(png: Path, min_panels: int) -> np.ndarray:
    img = np.asarray(o3d.io.read_image(str(png)))
    assert img.ndim == 3 and img.shape[2] == 3
    assert img.shape[1] >= min_panels * 120                         # one panel per level, side by side
    fg = (img != 255).any(axis=2)
    # a drawn mesh, not just labels: many pixels, and a real spread of colours
    assert fg.mean() > 0.1
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 50
    return img


def test_view_lods_on_a_file(sphere_file, tmp_path):
    png = tmp_path / "lods.png"
    proc = run("view_lods.py", [str(sphere_file), "--ratios", "0.5,0.1"], png)
    check_picture(png, 3)
    n = lodkit.load(sphere_file).n_faces
    assert f"original {n} faces" in proc.stdout
    assert f"0.5: {round(0.5 * n)} faces" in proc.stdout


@pytest.mark.skipif(not has_progressive(), reason="lodkit.progressive (ProgressiveMesh) has not landed yet")
def test_progressive_viewer_on_a_file(sphere_file, tmp_path):
    png = tmp_path / "strip.png"
    proc = run("progressive_viewer.py", [str(sphere_file)], png)
    check_picture(png, 5)
    assert "collapse records" in proc.stdout


@pytest.mark.parametrize("by, says", [("importance", "visual importance from 0"), ("cost", "log10 cost (qem)"),
                                      ("order", "removal step / all from 0 to 1")])
def test_color_by_cost_on_a_file(sphere_file, tmp_path, by, says):
    png = tmp_path / f"{by}.png"
    proc = run("color_by_cost.py", [str(sphere_file), "--by", by], png)
    img = check_picture(png, 1)
    assert says in proc.stdout
    # the colour bar: a column of viridis colours from yellow (top) to dark blue (bottom)
    yellowish = (img[..., 0] > 200) & (img[..., 1] > 200) & (img[..., 2] < 90)
    assert yellowish.any()


def test_a_script_runs_on_the_builtin_mesh(tmp_path):
    png = tmp_path / "demo.png"
    proc = run("view_lods.py", ["--demo-faces", "2000", "--ratios", "0.1"], png)
    check_picture(png, 2)
    from lodkit.demo import demo_mesh

    assert f"demo surface: original {demo_mesh(2000).n_faces} faces" in proc.stdout
