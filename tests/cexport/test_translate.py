"""The translator: what it refuses (naming the function and line), how it writes values."""

from __future__ import annotations

import math
import re
import subprocess

import numpy as np
import pytest

from mfcontrol.cexport.translate import CP, CS, INT, REAL, J, Options, TranslationError, Translator
from mfcontrol.laws import intelligent

from . import harness


def _translate(fn, kinds, real="double"):
    tr = Translator(Options("t", real, "t_params", {}))
    return tr.source([tr.function(fn, kinds)])


def loops_while(CS, j):
    while CS[0, j] < 1.0:
        CS[0, j] += 1.0


def writes_parameter(CP, CS, j):
    CP[0, j] = 1.0


def squares(x):
    return x ** 2


def keyword_call(x):
    return squares(x=x)


def float_modulus(x):
    return x % 2.0


def parameter_row_from_state(CP, CS, j):
    return CP[int(CS[0, j]), j]


def builtin_as_statement(x):
    abs(x)  # found by typing the translator: a TypeError, not a TranslationError
    return x


def mixed_returns(x):
    if x > 0.0:
        return x
    return


@pytest.mark.parametrize("fn,kinds,what", [
    (loops_while, (CS, J), "statement While"),
    (writes_parameter, (CP, CS, J), "writes a parameter"),
    (squares, (REAL,), "operator Pow"),
    (keyword_call, (REAL,), "keyword arguments"),
    (float_modulus, (REAL,), "% or // of floating-point values"),
    (parameter_row_from_state, (CP, CS, J), "a parameter row that is not a constant"),
    (mixed_returns, (REAL,), "returns a value on one path and none on another"),
    (builtin_as_statement, (REAL,), "abs\\(\\) as a statement: its value is unused"),
])
def test_refuses_what_c_cannot_say_the_same_way(fn, kinds, what):
    with pytest.raises(TranslationError, match=rf"{fn.__name__} \(line \d+\): {what}"):
        _translate(fn, kinds)


def test_values_are_written_to_round_trip():
    d, f = Options("p", "double", "P", {}), Options("p", "float", "P", {})
    assert d.literal(0.1) == "0.1" and float(d.literal(0.1)) == 0.1
    assert f.literal(0.1) == "0.1f"
    assert d.literal(1e-300) == "1e-300"
    assert d.literal(math.inf) == "((double)INFINITY)"
    assert f.literal(-math.inf) == "(-(float)INFINITY)"
    assert d.literal(math.nan) == "((double)NAN)"
    assert d.literal(3) == "3" and d.literal(True) == "1"


def counts(CS, j, n):
    total = 0
    for i in range(n - 1, 0, -1):
        total += i % 3
    CS[0, j] = total / n
    return total


def test_integers_stay_integers_and_true_division_is_floating():
    text = _translate(counts, (CS, J, INT))
    assert "long total = 0;" in text and "long i = 0;" in text
    assert "cs[0] = (((t_real)total) / n);" in text


def python_semantics(CS, j, a, b, x, y):
    CS[0, j] = a % b
    CS[1, j] = a // b
    CS[2, j] = max(x, y)
    CS[3, j] = min(x, y)
    CS[4, j] = abs(-5)
    CS[5, j] = abs(a - 10)
    i, last = 0, 0
    for i in range(b, a, -2):
        last = i
        i = 100  # rebinding the loop variable does not change the iteration
    CS[6, j] = i * 1000.0 + last


CASES = [(-7, 3, 0.0, -0.0), (7, -3, math.nan, 1.0), (7, 3, 1.0, math.nan), (-7, -3, 2.0, 1.0),
         (9, 2, -0.0, 0.0), (8, -4, 3.0, 3.0)]


def test_the_c_computes_what_python_computes(tmp_path):
    """Integer % and // floor, max/min keep the first argument unless the second compares
    greater (smaller), a loop variable holds its last value after the loop: the C prints
    the same bits as Python computes, NaN and signed zeros included."""
    code = _translate(python_semantics, (CS, J, INT, INT, REAL, REAL))
    calls = "\n".join(
        f"    t_test_translate_python_semantics(cs, {a}, {b}, {_c(x)}, {_c(y)});\n"
        "    for (i = 0; i < 7; i++) printf(\"%a\\n\", cs[i]);" for a, b, x, y in CASES)
    (tmp_path / "t.c").write_text(
        "#include <math.h>\n#include <stdio.h>\ntypedef double t_real;\n" + code
        + "\nint main(void)\n{\n    double cs[7];\n    int i;\n" + calls
        + "\n    return 0;\n}\n")
    subprocess.run([harness.compiler(), *harness.CFLAGS, str(tmp_path / "t.c"), "-o",
                    str(tmp_path / "t"), "-lm"], check=True)
    out = subprocess.run([str(tmp_path / "t")], capture_output=True, text=True,
                         check=True).stdout.split()
    expected = []
    for a, b, x, y in CASES:
        cs = np.zeros((7, 1))
        python_semantics(cs, 0, a, b, x, y)
        expected += [_hex(v) for v in cs[:, 0]]
    assert [v.replace("-nan", "nan") for v in out] == expected


def _c(x: float) -> str:
    return "NAN" if math.isnan(x) else f"(double){x!r}"


def _hex(v: float) -> str:
    """What C's %a prints."""
    if math.isnan(v):
        return "nan"
    if v == 0.0:
        return "-0x0p+0" if math.copysign(1.0, v) < 0 else "0x0p+0"
    text = float.hex(float(v))  # 0x1.c000000000000p+2 -> 0x1.cp+2
    mantissa, exp = text.split("p")
    return mantissa.rstrip("0").rstrip(".") + "p" + exp


def value_or(x, y):
    return x or y


def test_refuses_and_or_of_values():
    with pytest.raises(TranslationError, match="`and`/`or` of values"):
        _translate(value_or, (REAL, REAL))


def test_parameters_come_from_the_table_and_state_from_cs():
    text = _translate(intelligent.step, (CP, CS, J, REAL, REAL, REAL))
    # by the names the Python gives the rows (an enum of the file)
    assert "t_params[T_INTELLIGENT_EST]" in text
    assert re.search(rf"\bT_INTELLIGENT_EST *= {intelligent.EST}\b", text)
    assert "cs[T_INTELLIGENT_U1]" in text
    assert "/* mfcontrol.laws.intelligent.step */" in text


def chain(n):
    a, b, c, d, e, f, g = 0, 0, 0, 0, 0, 0, 0
    for _ in range(n):
        a = b
        b = c
        c = d
        d = e
        e = f
        f = g
        g = 0.5
    return a


def test_kinds_settle_however_long_the_chain():
    """A value passed along seven variables makes the first one a float only six passes
    in: the inference runs to its fixed point (it once stopped at five, giving long)."""
    text = _translate(chain, (INT,))
    assert "static t_real t_test_translate_chain(t_real *cs, long n)" in text
    assert "t_real a = 0;" in text


def calls_in_max(CS, j):
    return max(0.0, bump(CS, j))


def bump(CS, j):
    CS[0, j] += 1.0
    return CS[0, j]


def test_refuses_a_call_that_max_would_evaluate_twice():
    with pytest.raises(TranslationError, match=r"a call inside max\(\): assign it first"):
        _translate(calls_in_max, (CS, J))


def test_an_if_on_one_comparison_has_one_pair_of_parentheses():
    text = _translate(intelligent.step, (CP, CS, J, REAL, REAL, REAL))
    assert "if (d > 0.0) {" in text and "if ((d > 0.0))" not in text
    assert "if (algebraic) {" in text  # clang's -Wparentheses-equality: `if ((a == b))`
