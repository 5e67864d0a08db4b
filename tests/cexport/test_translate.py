"""The translator: what it refuses (naming the function and line), how it writes values."""

from __future__ import annotations

import math

import pytest

from mfcontrol.cexport.translate import CP, CS, INT, REAL, J, Options, TranslationError, Translator
from mfcontrol.laws import intelligent


def _translate(fn, kinds, real="double"):
    tr = Translator(Options("t", real, "t_params", {}))
    tr.function(fn, kinds)
    return tr.source()


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
    assert "for (i = (n - 1); i > tmp1_; i += -1)" in text
    assert "cs[0] = (((t_real)total) / n);" in text


def test_parameters_come_from_the_table_and_state_from_cs():
    text = _translate(intelligent.step, (CP, CS, J, REAL, REAL, REAL))
    assert f"t_params[{intelligent.EST}]" in text
    assert f"cs[{intelligent.U1}]" in text
    assert "/* mfcontrol.laws.intelligent.step */" in text
