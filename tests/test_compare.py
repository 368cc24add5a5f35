"""lodkit.compare and ``lodkit compare``: runs, the table, the plots, the contact sheet, the report.

Small and fast: the 1500-face demo surface, two metrics (and Open3D as a peer), two ratios,
a few thousand samples, and the numpy renderer for the contact sheet (Open3D's renderer
is lodkit.render's business and tested there).
"""
from __future__ import annotations

import csv
import io
import json
import sys
from contextlib import redirect_stderr, redirect_stdout

import numpy as np
import pytest

pytest.importorskip("open3d")
pytest.importorskip("matplotlib")

import lodkit  # noqa: E402
from lodkit.cli import main  # noqa: E402
from lodkit.compare import PEERS, MissingDependencyError, compare  # noqa: E402
from lodkit.demo import demo_mesh  # noqa: E402
from lodkit.errors import OptionError, UnknownMetricError  # noqa: E402
from lodkit.evaluate import evaluate  # noqa: E402

SAMPLES = 3000
RATIOS = [0.5, 0.1]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _simplify_available() -> bool:
    try:
        import lodkit._core.decimate  # noqa: F401
    except ImportError:
        return False
    return True


pytestmark = pytest.mark.skipif(not _simplify_available(), reason="lodkit's Cython core is not built")


@pytest.fixture(scope="module")
def mesh():
    return demo_mesh(1500)


@pytest.fixture(scope="module")
def report(mesh, tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    lines = []
    result = compare(mesh, metrics="qem,melod", peers=["open3d"], ratios=RATIOS, out=out, samples=SAMPLES,
                     seed=3, image_size=(160, 120), render_backend="numpy", log=lines.append)
    return result, out, lines


def _read_png(path):
    import matplotlib.image

    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE
    return matplotlib.image.imread(path)


def test_files_exist_and_nothing_else(report):
    result, out, lines = report
    names = {"hausdorff.png", "rms.png", "time.png", "contact_sheet.png", "results.csv", "results.json",
             "report.md", "report.html"}
    assert {p.name for p in out.iterdir()} == names          # no temporary files left behind
    assert set(result.files) == names
    assert all(result.files[n] == out / n for n in names)
    assert len(lines) == 6 and lines[0].startswith("qem @ 0.5: ")


def test_pngs_are_valid_and_not_blank(report):
    result, out, _ = report
    for name in ("hausdorff.png", "rms.png", "time.png", "contact_sheet.png"):
        img = _read_png(out / name)
        assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100
        rgb = img[..., :3]
        assert rgb.std() > 0.05, name                              # not one flat colour
        assert len(np.unique(rgb.reshape(-1, 3), axis=0)) > 50, name
    # the sheet: 3 methods x (the original + 2 ratios) of 160 x 120 pictures (plus padding)
    sheet = _read_png(out / "contact_sheet.png")
    assert sheet.shape[0] >= 3 * 120 and sheet.shape[1] >= 3 * 160


def test_runs_and_order(report, mesh):
    result, _, _ = report
    assert result.methods == ["qem", "melod", "open3d"]
    assert [(r.method, r.ratio) for r in result.runs] == [(m, q) for m in result.methods for q in RATIOS]
    for run in result.runs:
        assert run.error is None
        assert run.target_faces == round(run.ratio * mesh.n_faces)
        assert run.faces == run.mesh.n_faces
        assert run.seconds > 0
        assert run.kind == ("peer" if run.method == "open3d" else "metric")
        # an edge collapse removes two faces (one on a boundary), so a target can be
        # passed by one; Open3D may stop a little short or beyond as well
        assert abs(run.faces - run.target_faces) <= 2


def test_table_equals_evaluate_of_the_same_meshes(report, mesh):
    result, out, _ = report
    with open(out / "results.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert len(table) == len(result.runs)
    for row, run in zip(table, result.runs):
        assert (row["method"], float(row["ratio"]), int(row["faces"])) == (run.method, run.ratio, run.faces)
        # evaluated again from scratch, on a freshly simplified mesh for lodkit's own metrics
        again = run.mesh if run.kind == "peer" else \
            lodkit.simplify(mesh, target_faces=run.target_faces, metric=run.method).mesh
        ev = evaluate(mesh, again, samples=SAMPLES, seed=3)
        assert ev.as_dict() == run.evaluation.as_dict()
        assert float(row["hausdorff"]) == ev.distance.hausdorff
        assert float(row["mean"]) == ev.distance.mean
        assert float(row["rms"]) == ev.distance.rms
        assert float(row["hausdorff_model"]) == ev.distance_model.hausdorff
        assert float(row["normal_mean"]) == ev.normal_deviation.mean
        assert float(row["quality_min"]) == ev.quality_simplified.min
        # the demo surface has colours; lodkit and Open3D keep them
        assert float(row["color_rms"]) == ev.color.rms
        assert int(row["genus_change"]) == ev.topology_changes["genus"]
    data = json.loads((out / "results.json").read_text())
    assert data["n_faces"] == mesh.n_faces and data["ratios"] == RATIOS
    assert [r["evaluation"] for r in data["runs"]] == [r.evaluation.as_dict() for r in result.runs]


def test_reports_embed_the_pictures_and_the_table(report):
    result, out, _ = report
    md = (out / "report.md").read_text()
    for name in ("hausdorff.png", "rms.png", "time.png", "contact_sheet.png", "results.csv"):
        assert f"({name})" in md
    assert md.count("\n| qem |") == 2 and md.count("\n| melod |") == 2 and md.count("\n| open3d |") == 2
    html = (out / "report.html").read_text()
    assert html.startswith("<!DOCTYPE html>") and html.rstrip().endswith("</html>")
    assert html.count('src="data:image/png;base64,') == 4
    assert html.count("<tr>") == 1 + len(result.runs)
    run = result.run("melod", 0.1)
    assert f"{run.evaluation.distance.hausdorff:.4g}" in html
    assert f"{run.evaluation.distance.hausdorff:.4g}" in md


def test_bad_options_fail_before_any_work(mesh, tmp_path):
    out = tmp_path / "never"
    with pytest.raises(UnknownMetricError, match="unknown metric 'nope'.*qem"):
        compare(mesh, metrics="qem,nope", ratios=RATIOS, out=out)
    with pytest.raises(OptionError, match="unknown peer 'blender'.*open3d"):
        compare(mesh, peers="blender", out=out)
    with pytest.raises(OptionError, match=r"ratio must be in \(0, 1\]"):
        compare(mesh, ratios=[0.5, 1.5], out=out)
    with pytest.raises(OptionError, match="nothing to compare"):
        compare(mesh, metrics=[], peers=[], out=out)
    with pytest.raises(OptionError, match="listed twice"):
        compare(mesh, metrics="qem,qem", out=out)
    with pytest.raises(OptionError, match="may not set 'metric'"):
        compare(mesh, simplify_options={"metric": "qem"}, out=out)
    with pytest.raises(OptionError, match="render_backend"):
        compare(mesh, render_backend="povray", out=out)
    with pytest.raises(OptionError, match="samples"):
        compare(mesh, samples=0, out=out)
    with pytest.raises(lodkit.MeshIOError, match="no such file"):
        compare(tmp_path / "missing.ply", out=out)
    assert not out.exists()
    with pytest.raises(OptionError, match="boundary"):        # simplify's own check, not swallowed
        compare(mesh, ratios=[0.5], simplify_options={"boundary": "sideways"}, samples=100)


def test_missing_matplotlib_says_what_to_install(mesh, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)       # import matplotlib -> ImportError
    with pytest.raises(MissingDependencyError, match=r"pip install 'lodkit\[plot\]'"):
        compare(mesh, ratios=RATIOS, out=tmp_path / "x")
    assert not (tmp_path / "x").exists()
    # without an output directory nothing is plotted, so nothing is missing
    result = compare(mesh, ratios=[0.5], samples=500, out=None)
    assert result.files == {} and result.runs[0].evaluation is not None


def test_a_failing_method_is_reported_not_fatal(mesh, tmp_path, monkeypatch):
    def broken(V, F, C, target):
        raise RuntimeError("the peer fell over")

    module, package, _, text = PEERS["open3d"]
    monkeypatch.setitem(PEERS, "open3d", (module, package, broken, text))
    result = compare(mesh, metrics="qem", peers="open3d", ratios=RATIOS, out=tmp_path, samples=500,
                     contact_sheet=False)
    failed = [r for r in result.runs if r.method == "open3d"]
    assert all(r.error == "RuntimeError: the peer fell over" and r.evaluation is None for r in failed)
    assert all(r.error is None for r in result.runs if r.method == "qem")
    md = (tmp_path / "report.md").read_text()
    assert "failed: RuntimeError: the peer fell over" in md
    assert "contact_sheet.png" not in md and not (tmp_path / "contact_sheet.png").exists()
    rows = list(csv.DictReader(open(tmp_path / "results.csv", newline="")))
    assert rows[-1]["hausdorff"] == "" and rows[-1]["error"] == "RuntimeError: the peer fell over"
    _read_png(tmp_path / "hausdorff.png")                      # still plotted, qem only


def test_cli(tmp_path, mesh):
    path = tmp_path / "in.ply"
    lodkit.save(mesh, path)
    out = tmp_path / "cmp"
    buf, err = io.StringIO(), io.StringIO()
    with redirect_stdout(buf), redirect_stderr(err):
        code = main(["compare", str(path), "--metrics", "qem", "--ratios", "0.5,0.2", "--out", str(out),
                     "--samples", "1000", "--size", "96x72", "--render-backend", "numpy"])
    assert code == 0, err.getvalue()
    assert "2 runs (0 failed)" in buf.getvalue()
    assert "qem @ 0.2:" in err.getvalue()
    assert (out / "report.html").is_file() and (out / "contact_sheet.png").is_file()
    with redirect_stderr(err):
        assert main(["compare", str(path), "--metrics", "nope", "--out", str(out)]) == 2
        assert main(["compare", str(path), "--size", "big", "--out", str(out)]) == 2
        assert main(["compare", str(path), "--view", "sideways", "--out", str(out)]) == 2
    assert "unknown metric 'nope'" in err.getvalue()
    assert "expected WIDTHxHEIGHT" in err.getvalue()
    assert "view must be 'front'" in err.getvalue()


# ---------------------------------------------------------------------- the report's marks
def test_table_has_target_vertices_stop_reason_and_time(report):
    result, out, _ = report
    md = (out / "report.md").read_text()
    header = next(line for line in md.splitlines() if line.startswith("| method |"))
    cols = [c.strip() for c in header.strip("|").split("|")]
    assert cols[:7] == ["method", "ratio", "target", "faces", "vertices", "stop reason", "time (s)"]
    for run in result.runs:
        assert run.stop_reason == "target_faces" and not run.stopped_short
        assert run.vertices == len(np.unique(run.mesh.faces))
    row = next(line for line in md.splitlines() if line.startswith("| melod | 0.1 |"))
    cells = [c.strip().strip("*") for c in row.strip("|").split("|")]
    run = result.run("melod", 0.1)
    assert cells[2:6] == [str(run.target_faces), str(run.faces), str(run.vertices), "target faces"]
    with open(out / "results.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert {"target_faces", "vertices", "stop_reason", "stopped_short", "seconds"} <= set(table[0])


def test_best_value_per_ratio_is_marked(report):
    result, out, _ = report
    md = (out / "report.md").read_text()
    html = (out / "report.html").read_text()
    for ratio in RATIOS:
        runs = [r for r in result.runs if r.ratio == ratio]
        best = min(runs, key=lambda r: r.evaluation.distance.hausdorff)
        text = f"{best.evaluation.distance.hausdorff:.4g}"
        assert f"**{text}**" in md
        assert f'<td class="best">{text}</td>' in html
        for other in runs:
            if other.evaluation.distance.hausdorff > best.evaluation.distance.hausdorff:
                assert f"**{other.evaluation.distance.hausdorff:.4g}**" not in md


def _stops_short(V, F, C, target):
    """A peer that keeps every face (it 'stops short' of any target below the input)."""
    return V, F, C, 0.001


@pytest.fixture(scope="module")
def short_report(mesh, tmp_path_factory):
    out = tmp_path_factory.mktemp("short")
    saved = PEERS["open3d"]
    PEERS["open3d"] = (saved[0], saved[1], _stops_short, saved[3])
    try:
        result = compare(mesh, metrics="qem", peers="open3d", ratios=RATIOS, out=out, samples=500,
                         image_size=(96, 72), render_backend="numpy")
    finally:
        PEERS["open3d"] = saved
    return result, out


def test_a_run_short_of_its_target_is_marked_and_never_best(short_report, mesh):
    result, out = short_report
    short = [r for r in result.runs if r.method == "open3d"]
    assert all(r.stopped_short and r.stop_reason == "stopped_short" and r.faces == mesh.n_faces for r in short)
    assert all(not r.stopped_short for r in result.runs if r.method == "qem")
    md = (out / "report.md").read_text()
    for r in short:
        row = next(line for line in md.splitlines() if line.startswith(f"| open3d | {r.ratio:g} |"))
        assert f"{r.faces} ⚠ short" in row and "stopped short" in row
        assert "**" not in row                   # zero error, but not comparable: never "best"
    assert '<td class="short">' in (out / "report.html").read_text()
    rows = list(csv.DictReader(open(out / "results.csv", newline="")))
    assert [row["stopped_short"] for row in rows] == ["False", "False", "True", "True"]


def test_plots_have_plain_integer_face_ticks_and_ring_short_runs(short_report):
    from lodkit.compare import _curve_figure

    result, _ = short_report
    for key in ("hausdorff", "seconds"):
        fig = _curve_figure(result, key, "title", "y")
        fig.canvas.draw()
        ax = fig.axes[0]
        labels = [t.get_text() for t in ax.get_xticklabels()]
        assert labels == [str(t) for t in sorted({r.target_faces for r in result.runs})]
        assert all(s.isdigit() for s in labels)                  # "750", never "7.5×10²"
        assert not any(t.get_text() for t in ax.get_xticklabels(minor=True))
        rings = [line for line in ax.get_lines() if line.get_label() == "stopped short of its target"]
        assert len(rings) == 1 and sorted(rings[0].get_xdata()) == [r.faces for r in result.runs
                                                                   if r.stopped_short]


def test_contact_sheet_size_and_original_column(short_report):
    from lodkit.viz import annotated_sheet

    result, out = short_report
    sheet = _read_png(out / "contact_sheet.png")
    # 2 methods x (original + 2 ratios); the size depends on the pictures, not on the text
    images = [[np.zeros((72, 96, 3), np.uint8)] * 3] * 2
    like = annotated_sheet(images, labels=[["a\nb"] * 3] * 2, row_titles=["x", "y"], col_titles=["1", "2", "3"])
    assert sheet.shape[:2] == like.shape[:2]
    assert like.shape[0] > 2 * 72 and like.shape[1] > 3 * 96


def test_annotated_sheet_draws_text_and_keeps_pictures():
    from lodkit.viz import annotated_sheet

    a = np.full((40, 60, 3), 200, np.uint8)
    plain = annotated_sheet([[a, a]], labels=[["1", "2"]], pad=5)
    text = annotated_sheet([[a, a]], labels=[["123 faces", "x"]], pad=5)
    assert plain.shape == text.shape
    assert (text != plain).any()                                # the labels are drawn
    assert (text[5:45, 5:65] == 200).all()                      # the picture is untouched
    pixel = annotated_sheet([[a, a]], labels=[["123 faces", "x"]], font="pixel")
    assert pixel.dtype == np.uint8 and pixel.shape[1] >= 120
    with pytest.raises(OptionError):
        annotated_sheet([[a]], labels=[["x", "y"]])
    with pytest.raises(OptionError):
        annotated_sheet([[a]], font="comic")


def test_view_option(mesh, tmp_path):
    from lodkit.compare import _check_view
    from lodkit.viz import Camera

    assert _check_view("front") == "front"
    assert _check_view("180,10") == (180.0, 10.0)
    cam = Camera.front(mesh, 100, 80)
    assert _check_view(cam) is cam
    for bad in ("sideways", "1,2,3", "0,90"):
        with pytest.raises(OptionError, match="view"):
            compare(mesh, ratios=[0.5], view=bad, out=tmp_path / "v")


def test_polish_peer(mesh, tmp_path):
    """--peers polish: lodkit's QEM with polish=True beside plain qem; the same faces, a lower mean."""
    result = compare(mesh, metrics="qem", peers="polish", ratios=(0.2,), out=tmp_path, samples=2000,
                     contact_sheet=False)
    by = {r.method: r for r in result.runs}
    assert by["polish"].error is None and by["polish"].faces == by["qem"].faces
    assert by["polish"].evaluation.distance.mean < by["qem"].evaluation.distance.mean
