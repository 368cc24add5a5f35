"""lodkit._progress.Progress: the text progress bar simplify() draws on stderr."""
from __future__ import annotations

import io

from lodkit._progress import Progress


def test_disabled_bar_writes_nothing():
    stream = io.StringIO()
    bar = Progress(100, enabled=False, stream=stream)
    bar.update(50)
    bar.close()
    assert stream.getvalue() == ""


def test_line_format():
    bar = Progress(27000, enabled=True, stream=io.StringIO())
    bar.done = 12345
    line = bar.line()
    assert line.endswith(" 46% 12345/27000")
    inner = line[1:line.index("]")]
    assert len(inner) == Progress.width and set(inner) <= {"#", "."}
    assert inner.count("#") == round(12345 / 27000 * Progress.width)


def test_redraws_are_rate_limited_and_close_ends_the_line():
    stream = io.StringIO()
    bar = Progress(1000, enabled=True, stream=stream)
    for done in range(1001):
        bar.update(done)
    bar.close()
    bar.close()                                     # a second close does nothing
    text = stream.getvalue()
    assert text.endswith("\r[" + "#" * Progress.width + "] 100% 1000/1000\n")
    assert text.count("\r") <= 3                    # the first update, maybe one more, and close


def test_values_are_clamped_and_zero_total_is_complete():
    bar = Progress(10, stream=io.StringIO())
    bar.done = 25
    assert bar.line().endswith("100% 10/10")
    bar.done = -3
    assert bar.line().endswith("  0% 0/10")
    empty = Progress(0, stream=io.StringIO())
    assert empty.line().endswith("100% 0/0")


def test_broken_stream_disables_the_bar():
    class Closed(io.StringIO):
        def write(self, text):
            raise OSError("broken pipe")

    bar = Progress(10, enabled=True, stream=Closed())
    bar.update(5)                                   # must not raise
    assert bar.enabled is False
    bar.close()


def test_context_manager_closes():
    stream = io.StringIO()
    with Progress(4, stream=stream) as bar:
        bar.update(4)
    assert stream.getvalue().endswith("100% 4/4\n")
