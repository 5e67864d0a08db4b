"""What a running controller may change: the laws' tunable parameter rows and the checks
their values pass.

Each law module declares ``tunable(cp)``, the rows a controller with the parameter
column ``cp`` may retune while it runs, as ``(field, row, what)`` triples (``field`` the C
export's struct member, ``what`` its meaning and unit; the PID's and the ADRC's are the
constant ``TUNABLE``), and ``invalid_row(CP, j)``, the first tunable row holding a value the
law is not defined for, or -1. Every other row fixes the law's structure (its order, its
estimator and window, the gain's mode, a delay): the state's size or the code's branches,
which the C export folds into the code. ``invalid_row`` is plain Python in the laws'
subset, so the C export translates it into the setter's check
(:mod:`mfcontrol.cexport`); the live controllers' constructors check the same values with
messages naming their keywords (``tests/laws/test_tunable.py`` holds the two to each
other).
"""

import math


def limits_ok(lo, hi):
    """Output limits as the laws hold them: the low one finite or -inf, the high one finite
    or +inf, low <= high (NaN fails every test)."""
    return (math.isfinite(lo) or lo < 0.0) and (math.isfinite(hi) or hi > 0.0) and lo <= hi


def positive(x):
    """A finite number > 0."""
    return math.isfinite(x) and x > 0.0


def same_sign_or_zero(x, ref):
    """``x`` is 0, or has the sign of a nonzero ``ref`` (Td = kd / kp >= 0)."""
    return x == 0.0 or (x > 0.0 and ref > 0.0) or (x < 0.0 and ref < 0.0)
