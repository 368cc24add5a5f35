"""Every input error is one clear lodkit error (issue 18), and unusual but valid inputs work:
read-only and memory-mapped arrays, tiny and huge coordinates."""
from __future__ import annotations

import os

import numpy as np
import pytest

import lodkit
from lodkit.demo import demo_mesh

TET_V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
TET_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


@pytest.fixture(scope="module")
def small():
    return demo_mesh(2000)


def _read_only(a):
    a = np.array(a)
    a.flags.writeable = False
    return a


@pytest.mark.parametrize("kw", [{}, {"metric": "melod"}, {"metric": "schroeder"}, {"metric": "volume"},
                                {"driver": "pass"}, {"operator": "triangle"}])
def test_read_only_arrays_are_accepted_and_left_alone(small, kw):
    V, F = _read_only(small.vertices), _read_only(small.faces)
    mesh = lodkit.Mesh(V, F, colors=_read_only(small.colors))
    ref = lodkit.simplify(lodkit.Mesh(small.vertices.copy(), small.faces.copy(), colors=small.colors.copy()),
                          target_ratio=0.3, **kw)
    out = lodkit.simplify(mesh, target_ratio=0.3, **kw)
    assert np.array_equal(out.mesh.faces, ref.mesh.faces) and np.array_equal(out.mesh.vertices, ref.mesh.vertices)
    assert np.array_equal(V, small.vertices) and np.array_equal(F, small.faces)
    V_out, F_out = lodkit.simplify((V, F), target_ratio=0.3, **kw).mesh        # a tuple in, a tuple out
    assert len(F_out) == ref.mesh.n_faces


def test_memory_mapped_arrays_are_accepted(small, tmp_path):
    np.save(tmp_path / "v.npy", small.vertices)
    np.save(tmp_path / "f.npy", small.faces)
    V = np.load(tmp_path / "v.npy", mmap_mode="r")
    F = np.load(tmp_path / "f.npy", mmap_mode="r")
    locked = np.load(tmp_path / "f.npy", mmap_mode="r")[:5, 0]
    mesh = lodkit.Mesh(V, F)
    assert lodkit.simplify(mesh, target_ratio=0.3, locked=locked).mesh.n_faces > 0
    assert lodkit.progressive(mesh).n_steps > 0
    assert lodkit.cluster(mesh, target_faces=300).mesh.n_faces > 0
    assert lodkit.evaluate(mesh, mesh, samples=1000).distance.hausdorff == 0.0
    del V, F, locked, mesh


@pytest.mark.parametrize("kw, says", [
    ({"target_ratio": "abc"}, "target_ratio must be a number, got 'abc'"),
    ({"target_ratio": [0.5]}, "target_ratio must be a number, got [0.5]"),
    ({"target_ratio": True}, "target_ratio must be a number"),
    ({"target_faces": "10"}, "target_faces must be a non-negative integer"),
    ({"max_error": "x"}, "max_error must be a number, got 'x'"),
    ({"target_ratio": 0.5, "max_normal_angle": "abc"}, "max_normal_angle must be a number, got 'abc'"),
    ({"target_ratio": 0.5, "min_quality": "abc"}, "min_quality must be a number"),
    ({"target_ratio": 0.5, "boundary_weight": [1]}, "boundary_weight must be a number"),
    ({"target_ratio": 0.5, "progress": "yes"}, "progress must be True, False or a callable"),
])
def test_bad_options_are_option_errors(small, kw, says):
    with pytest.raises(lodkit.OptionError) as info:
        lodkit.simplify(small, **kw)
    assert says in str(info.value)


@pytest.mark.parametrize("faces, says", [
    ([[0, 1, 2], [1, 3]], "face 1 has 2 indices"),
    ([[0, 1, 2, 3], [0, 1, 2]], "face 0 has 4 indices"),
])
def test_ragged_face_lists(faces, says):
    V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]
    for call in (lambda: lodkit.Mesh(V, faces), lambda: lodkit.simplify((V, faces), target_ratio=0.5)):
        with pytest.raises(lodkit.MeshError, match=says):
            call()


def test_progressive_names_itself_for_an_unknown_option(small):
    with pytest.raises(lodkit.OptionError, match=r"progressive\(\) got an unexpected keyword argument 'foo'"):
        lodkit.progressive(small, foo=1)


def test_evaluate_refuses_too_many_samples(small):
    with pytest.raises(lodkit.OptionError, match="samples=10000000000 is more than evaluate"):
        lodkit.evaluate(small, small, samples=10**10)


@pytest.mark.parametrize("key", ["target_faces", "target_vertices"])
def test_cluster_target_above_the_input(small, key):
    with pytest.raises(lodkit.OptionError, match=f"{key}=1000000000 is more than the mesh's"):
        lodkit.cluster(small, **{key: 10**9})


@pytest.mark.parametrize("scale", [1e-170, 1e-100, 1e100, 1e200])
def test_tiny_and_huge_coordinates_are_normalised(small, scale):
    """The run is made in coordinates divided by the bbox diagonal: at any scale it is a
    simplification of the same quality (the normalised positions differ in their last bits,
    so the collapse order may too: errors agree within a factor of 2), and evaluate()
    measures the same distances as on the mesh brought back to unit size (rel 1e-6)."""
    ref = lodkit.simplify(small, target_ratio=0.3)
    mesh = lodkit.Mesh(small.vertices * scale, small.faces)
    out = lodkit.simplify(mesh, target_ratio=0.3)
    assert out.mesh.n_faces == ref.mesh.n_faces
    assert 0.5 * ref.error < out.error < 2.0 * ref.error
    assert len(lodkit.simplify((TET_V * scale, TET_F), target_faces=2).mesh[1]) == 4     # a tetrahedron stays
    ev = lodkit.evaluate(mesh, out.mesh, samples=2000)
    back = lodkit.evaluate(small, lodkit.Mesh(out.mesh.vertices / scale, out.mesh.faces), samples=2000)
    assert ev.distance.hausdorff == pytest.approx(back.distance.hausdorff, rel=1e-6)
    assert ev.distance_model.hausdorff == pytest.approx(back.distance.hausdorff * ev.diagonal, rel=1e-6)
    assert ev.diagonal == pytest.approx(small.bbox_diagonal() * scale, rel=1e-12)
    assert lodkit.cluster(mesh, target_faces=300).mesh.n_faces > 0
    assert lodkit.simplify(mesh, target_ratio=0.3, pair_threshold=0.01).mesh.n_faces > 0


def test_coinciding_vertices_are_still_an_error():
    with pytest.raises(lodkit.MeshError, match="coincide"):
        lodkit.simplify((np.zeros((4, 3)), TET_F), target_faces=2)


def test_compare_checks_metric_options_before_any_work_or_directory(small, tmp_path, monkeypatch):
    import lodkit.api

    out = tmp_path / "report"
    monkeypatch.setattr(lodkit.api, "simplify", lambda *a, **k: pytest.fail("ran before checking the metrics"))
    for metrics, says in ([["qem", ("importance", {"weight": 2})], "needs values="],
                          [["qem", ("curvature", {"merge": "median"})], "option 'merge' must be one of"]):
        with pytest.raises(lodkit.OptionError, match=says):
            lodkit.compare(small, metrics=metrics, ratios=[0.5], out=out)
        assert not out.exists()


def test_compare_leaves_no_directory_when_a_run_fails_on_its_options(small, tmp_path):
    out = tmp_path / "report"
    wrong = np.ones(small.n_vertices + 1)          # one value too many: known once the mesh is
    with pytest.raises(lodkit.OptionError, match="values must have shape"):
        lodkit.compare(small, metrics=["qem", ("importance", {"values": wrong})], ratios=[0.5], out=out)
    assert not out.exists() and os.listdir(tmp_path) == []


def test_importance_works_with_values(small):
    heights = small.vertices[:, 2] - small.vertices[:, 2].min()
    r = lodkit.simplify(small, target_ratio=0.3, metric=["qem", ("importance", {"values": heights, "weight": 2})])
    assert r.mesh.n_faces > 0
