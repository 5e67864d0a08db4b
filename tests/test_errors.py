"""Refusals are one line: ``mfcontrol.errors.shown`` and ``ConfigError`` (issue 29)."""

import numpy as np

from mfcontrol.errors import ConfigError, shown


def test_a_value_whose_repr_spans_lines_is_shown_on_one():
    """numpy prints each row of a matrix on its own line: LTI(A=...) refused in two."""
    a = np.array([[np.nan, 0.0], [0.0, -2.0]])
    assert shown(a) == "array([[nan,  0.], [ 0., -2.]])"
    message = str(ConfigError("A", a, "must hold finite numbers only"))
    assert message == "A = array([[nan,  0.], [ 0., -2.]]): must hold finite numbers only"
    assert shown("two\nlines") == "'two\\nlines'"  # a string's newline is escaped already


def test_a_refusal_of_a_size_shows_the_start_of_the_value():
    """A value is shown in full unless the refusal asks for a limit (its size is the
    point: a 10 MB description was printed whole)."""
    text = "z" * 10_000
    assert str(ConfigError("k", text, "too long")) == f"k = {text!r}: too long"
    short = str(ConfigError("k", text, "too long", limit=20))
    assert short == f"k = '{'z' * 19}... (10002 characters): too long"
