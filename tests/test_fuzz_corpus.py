"""Replay every input the fuzzers kept (tests/fuzz_corpus/<target>/: crashers found by
bench/fuzz.py, fixed since, and the malformed files of issue 18): each must now give a
result or a lodkit error, nothing else. Also a short in-test fuzz of every target, so the
harness itself cannot rot."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
import fuzz  # noqa: E402

CASES = [(t, p) for t in fuzz.TARGETS for p in fuzz.corpus_files(t)]


def test_the_corpus_is_not_empty():
    assert len(CASES) >= 10
    assert {t for t, _ in CASES} >= {"ply", "off", "obj", "glb"}


@pytest.mark.parametrize("target, path", CASES, ids=[f"{t}/{p.name[:40]}" for t, p in CASES])
def test_corpus_input_is_handled(target, path):
    if target == "simplify":
        pytest.importorskip("lodkit._core.decimate")
    try:
        fuzz.check(target, path.read_bytes())
    except fuzz.KnownIssue:
        # an input error item 6 of issue 18 turns into a lodkit error (another branch)
        assert path.name.startswith("known-")


@pytest.mark.parametrize("target", fuzz.TARGETS)
def test_a_few_seconds_of_mutation_find_nothing(target, tmp_path):
    if target == "simplify":
        pytest.importorskip("lodkit._core.decimate")
    row = fuzz.run_mutate(target, seconds=2, timeout=20, keep_to=tmp_path)
    assert row["executions"] > 0
    assert (row["crashes"], row["hangs"]) == (0, 0), (row, sorted(p.name for p in tmp_path.rglob("*")))
