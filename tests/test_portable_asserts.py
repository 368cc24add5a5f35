"""The test suite must pass on any CPU (issue 18): floating-point sums differ in their last
bits between CPUs and numpy builds, so no test compares a computed float with a literal by
``==`` / ``!=``.  This test reads every test file (ast) and lists such comparisons.

Allowed without a word: literals that are whole numbers (``0.0``, ``1.0``, ``90.0``): an
exact result on every machine -- a zero error of a flat mesh, a value clamped to a bound,
a count or an index held in a float, an option echoed back.  Any other float literal
compared exactly needs ``# exact: <why>`` on its line (an option echoed back as given, a
constant of the code); a computed value is compared with a stated tolerance
(``pytest.approx(x, rel=...)``, ``np.allclose``) or with another run on the same machine.
Also checked: ``np.array_equal`` / ``assert_array_equal`` / ``assert_equal`` against
literal floats.
"""
from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parent
EXACT_CALLS = {"array_equal", "assert_array_equal", "assert_equal"}


def _float_literals(node) -> list[float]:
    """The float literals of a literal value (nested tuples, lists, sets, dict values),
    not those inside calls or other expressions."""
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        return _float_literals(node.operand)
    if isinstance(node, ast.Constant):
        return [node.value] if isinstance(node.value, float) else []
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return [v for e in node.elts for v in _float_literals(e)]
    if isinstance(node, ast.Dict):
        return [v for e in node.values for v in _float_literals(e)]
    return []


def _direct_float(node) -> float | None:
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        node = node.operand
    if isinstance(node, ast.Constant) and isinstance(node.value, float):
        return node.value
    return None


def _whole(v: float) -> bool:
    return v == int(v) and abs(v) <= 2**53


def offending(source: str, name: str = "<test>") -> list[str]:
    """``file:line: text`` of every exact comparison with a non-whole float literal whose
    line has no ``# exact:`` justification."""
    lines = source.splitlines()
    found = []
    for node in ast.walk(ast.parse(source)):
        bad: list[float] = []
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            for i, op in enumerate(node.ops):
                if isinstance(op, (ast.Eq, ast.NotEq)):
                    for side in (operands[i], operands[i + 1]):
                        v = _direct_float(side)
                        if v is not None and not _whole(v):
                            bad.append(v)
                        elif isinstance(side, (ast.Tuple, ast.List)):
                            bad += [v for v in _float_literals(side) if not _whole(v)]
        elif isinstance(node, ast.Call):
            fn = node.func
            fname = fn.attr if isinstance(fn, ast.Attribute) else getattr(fn, "id", "")
            if fname in EXACT_CALLS:
                for arg in node.args:
                    if isinstance(arg, (ast.List, ast.Tuple, ast.Constant, ast.UnaryOp)):
                        bad += [v for v in _float_literals(arg) if not _whole(v)]
        if bad:
            span = lines[node.lineno - 1:getattr(node, "end_lineno", node.lineno)]
            if not any("# exact:" in line for line in span):
                found.append(f"{name}:{node.lineno}: {lines[node.lineno - 1].strip()}")
    return found


def test_no_test_compares_a_float_literal_exactly():
    found = []
    for path in sorted(TESTS.rglob("*.py")):
        found += offending(path.read_text(), str(path.relative_to(TESTS)))
    assert not found, "exact float comparisons (use a tolerance, or '# exact: why'):\n" + "\n".join(found)


def test_the_scanner_finds_what_it_should():
    assert offending("assert a.error == 1.8482975099007456e-3\n")
    assert offending("assert -0.25 != x\n")
    assert offending("assert f(x) == (1, 0.1)\n")
    assert offending("assert np.array_equal(x, [0.5, 1.0])\n")
    assert not offending("assert a.error == 0.0 and b == 1.0\n")
    assert not offending("assert [f(ratio=0.5)] == [3]\n")
    assert not offending("assert m.weight == 2.5   # exact: the option as given\n")
    assert not offending("assert a.error == pytest.approx(1.848e-3, rel=1e-9)\n")
