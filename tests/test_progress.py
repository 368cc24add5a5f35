"""lodkit._progress: the tqdm bar simplify() draws on stderr, the callable hook, make()."""
from __future__ import annotations

import io
import re

import pytest

from lodkit._progress import Callback, Progress, make


def test_disabled_bar_writes_nothing():
    stream = io.StringIO()
    bar = Progress(100, enabled=False, stream=stream)
    bar.update(50)
    bar.close()
    assert stream.getvalue() == ""


def test_bar_shows_percent_count_and_rate_and_ends_the_line():
    stream = io.StringIO()
    bar = Progress(27000, enabled=True, stream=stream)
    for done in range(0, 27001, 1000):
        bar.update(done)
    bar.close()
    bar.close()                                     # a second close does nothing
    text = stream.getvalue()
    last = text.rstrip("\n").split("\r")[-1]
    assert re.search(r"100%\|.*\| 27000/27000 \[", last), last
    assert "faces/s" in last
    assert text.endswith("\n") and text.count("\n") == 1


def test_values_are_clamped_and_a_running_total_is_taken():
    bar = Progress(10, stream=io.StringIO())
    bar.update(4)
    bar.update(25)
    assert bar.done == 10
    bar.update(-3)
    assert bar.done == 0
    bar.close()


def test_broken_stream_disables_the_bar():
    class Closed(io.StringIO):
        def write(self, text):
            raise OSError("broken pipe")

    bar = Progress(10, enabled=True, stream=Closed())
    bar.update(5)                                   # must not raise
    bar.close()
    assert bar.enabled is False


def test_context_manager_closes():
    stream = io.StringIO()
    with Progress(4, stream=stream) as bar:
        bar.update(4)
    assert stream.getvalue().endswith("\n") and "4/4" in stream.getvalue()


def test_callback_gets_done_and_total_and_a_final_call():
    calls = []
    with Callback(lambda done, total: calls.append((done, total)), 100) as cb:
        cb.update(30)
        cb.update(250)
    assert calls == [(30, 100), (100, 100), (100, 100)]


@pytest.mark.parametrize("value", [False, None, 0])
def test_make_off(value):
    assert make(value, 10) is None


def test_make_bar_and_callable():
    stream = io.StringIO()
    bar = make(True, 10, stream=stream)
    assert isinstance(bar, Progress)
    bar.close()
    seen = []
    cb = make(lambda d, t: seen.append(d), 10)
    assert isinstance(cb, Callback)
    cb.update(3)
    assert seen == [3]


def test_simplify_reports_to_a_callable_and_gives_the_same_mesh():
    pytest.importorskip("lodkit._core.decimate")
    import numpy as np

    import lodkit
    from lodkit.demo import demo_mesh

    mesh = demo_mesh(20_000)
    calls = []
    with_hook = lodkit.simplify(mesh, target_ratio=0.05, progress=lambda d, t: calls.append((d, t)))
    plain = lodkit.simplify(mesh, target_ratio=0.05)
    assert len(calls) >= 2
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)          # a running total
    assert calls[-1][0] == calls[-1][1] == calls[0][1]
    np.testing.assert_array_equal(with_hook.mesh.faces, plain.mesh.faces)
    np.testing.assert_array_equal(with_hook.mesh.vertices, plain.mesh.vertices)
