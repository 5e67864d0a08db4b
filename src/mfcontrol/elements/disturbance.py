"""A disturbance d(t), added to the plant's input or to its output.

* ``step``: ``amplitude`` from ``t0`` on (0 before);
* ``ramp``: ``amplitude (t - t0)`` from ``t0`` on (amplitude in units per second);
* ``sine``: ``amplitude sin(2 pi frequency (t - t0))`` from ``t0`` on;
* ``table``: linear interpolation of ``values`` over ``times`` (nondecreasing), held at
  the first and last value outside them, as :func:`numpy.interp`.

At the input it adds to what the actuator delivers (a load on the plant's input); at the
output to the plant's output y, the controlled variable that the metrics judge and the
sensor reads.
"""

from .._jit import step_jit
from ..numerics import elementary

NONE = 0.0
STEP = 1.0
RAMP = 2.0
SINE = 3.0
TABLE = 4.0
KINDS = {"none": NONE, "step": STEP, "ramp": RAMP, "sine": SINE, "table": TABLE}
INPUT = 0.0
OUTPUT = 1.0
PLACES = {"input": INPUT, "output": OUTPUT}

# parameter rows; a table's times, then its values, follow from TABLE0 on
KIND = 0
AT = 1
AMPLITUDE = 2
T0 = 3
FREQUENCY = 4
N_TABLE = 5
TABLE0 = 6


def n_params(n_table: int) -> int:
    """Rows for a table of n_table points."""
    return TABLE0 + 2 * n_table


@step_jit
def value(DP, j, t):
    """d(t) of member j (its rows at column j of DP)."""
    kind = DP[KIND, j]
    if kind == TABLE:
        n = int(DP[N_TABLE, j])
        if t <= DP[TABLE0, j]:
            return DP[TABLE0 + n, j]
        for i in range(1, n):
            t1 = DP[TABLE0 + i, j]
            if t < t1:
                t0 = DP[TABLE0 + i - 1, j]
                v0 = DP[TABLE0 + n + i - 1, j]
                v1 = DP[TABLE0 + n + i, j]
                return v0 + (v1 - v0) * (t - t0) / (t1 - t0)
        return DP[TABLE0 + 2 * n - 1, j]
    t0 = DP[T0, j]
    if kind == NONE or t < t0:
        return 0.0
    a = DP[AMPLITUDE, j]
    if kind == STEP:
        return a
    if kind == RAMP:
        return a * (t - t0)
    # in turns, by the library's own sine: a loop over a block's members vectorises it
    return a * elementary.sin_turns(DP[FREQUENCY, j] * (t - t0))
