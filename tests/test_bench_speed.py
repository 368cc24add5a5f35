"""The bookkeeping of bench/speed.py: lodkit variants, within-round ratios, the report section.

No timing here: synthetic per-call records with hand-computed medians and ratios.
"""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parent.parent / "bench"
sys.path.insert(0, str(BENCH))

import speed  # noqa: E402


def test_variants_parse_and_bad_specs_stop_with_a_message():
    assert speed.parse_variants(['lodkit-ep={"placement": "endpoint"}']) == {"lodkit-ep": {"placement": "endpoint"}}
    for bad, words in [("noequals", "NAME=JSON"), ("x={not json", "not valid JSON"), ("x=[1]", "JSON object"),
                       ('meshoptimizer={"a": 1}', "peer")]:
        with pytest.raises(SystemExit, match=words):
            speed.parse_variants([bad])


def test_unknown_simplify_kwargs_fail_before_measuring():
    speed.check_variants({"lodkit-ep": {"placement": "endpoint"}})          # a real parameter
    with pytest.raises(SystemExit, match="no parameter.*no_such_option"):
        speed.check_variants({"lodkit-x": {"no_such_option": 2}})
    with pytest.raises(SystemExit, match="set by the benchmark"):
        speed.check_variants({"lodkit-x": {"target_ratio": 0.5}})


def _t(method, rnd, t, faces=10, cpu=None):
    return {"kind": "time", "method": method, "ratio": 0.1, "round": rnd, "time_s": t,
            "cpu_s": t if cpu is None else cpu, "faces": faces, "vertices": 7, "target": 10, "version": "v"}


def test_ratios_are_medians_of_within_round_ratios():
    lines = [_t("lodkit", 0, 1.0), _t("lodkit", 1, 4.0), _t("lodkit", 2, 2.0),
             _t("meshoptimizer", 0, 0.5), _t("meshoptimizer", 1, 1.0), _t("meshoptimizer", 2, 2.0, cpu=1.0),
             {"kind": "failed", "method": "pyfqmr", "ratio": 0.1, "round": 0, "error": "Boom: no"}]
    minfo = {"faces": 2_000_000, "vertices": 1_000_000}
    rows = speed.summarise("m", minfo, lines, ["lodkit", "meshoptimizer", "pyfqmr"], [0.1], {})
    by = {r["method"]: r for r in rows}
    mo = by["meshoptimizer"]
    assert mo["time_s"] == pytest.approx(1.0)                                # median of 0.5, 1, 2
    assert mo["x_lodkit"] == pytest.approx(0.5)                              # median of 0.5, 0.25, 1.0
    assert by["lodkit"]["x_meshopt"] == pytest.approx(2.0)                   # median of 2, 4, 1
    assert mo["mtri_per_s"] == pytest.approx(2.0) and mo["s_per_mface"] == pytest.approx(0.5)
    assert mo["threads_used"] == pytest.approx(1.0)                          # median of 1, 1, 0.5
    assert by["pyfqmr"]["status"] == "failed" and "Boom" in by["pyfqmr"]["error"]


def test_report_section_is_between_its_markers():
    lines = [_t("lodkit", 0, 1.0), _t("meshoptimizer", 0, 0.5)]
    rows = []
    for mesh, n in [("generated250k", 250_000), ("generated1m", 1_000_000)]:
        rows += speed.summarise(mesh, {"faces": n, "vertices": n // 2}, lines, ["lodkit", "meshoptimizer"], [0.1], {})
    doc = {"settings": {"rounds": 1, "seed": 13, "argv": "--quick"}, "rows": rows,
           "memory": [{"mesh": "generated1m", "ratio": 0.1, "method": "lodkit", "status": "ok",
                       "vertices_in": 1000, "rss_call_bytes": 300_000, "traced_bytes": 250_000}],
           "variants": {"lodkit-2t": {"threads": 2}}}
    text = speed.render(doc)
    assert text.startswith(speed.BEGIN) and text.rstrip().endswith(speed.END)
    assert "largest / smallest" in text and "| generated1m | 0.1 | lodkit | 0.3 | 300 | 0.2 | 250 |" in text
