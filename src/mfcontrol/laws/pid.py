"""The discrete PID of Astrom and Hagglund (Feedback Systems / Advanced PID Control): the
baseline every comparison needs.

Per sample, in this order (``Ti = kp / ki``, ``Td = kd / kp``)::

    P = kp (b r - y)
    D = ad D - bd (y - y_old),   ad = Td / (Td + N h),  bd = kp Td N / (Td + N h)
    v = P + I + D
    u = sat(v)
    I = I + ki h (r - y) + (h / Tt) (u - v)
    y_old = y

a setpoint weight b on the proportional term, a derivative on the measurement filtered with time
constant Td / N (backward difference: stable for every h; the coefficients are computed from h at
every sample, so a live call may pass its own dt), and back-calculation anti-windup with tracking
time Tt. ``y_old`` starts at the first measurement (no derivative kick); ``I`` and ``D`` start at 0,
or, after a bumpless switch to automatic,
``I`` starts so that the first output equals the output held in manual.
"""

import math

from .._jit import step_jit

# parameter rows
KP = 0
KI = 1
KD = 2
N = 3  # derivative filter: time constant Td / N
B = 4  # setpoint weight
TT = 5  # tracking time of back-calculation (s); inf: none
OUT_MIN = 6
OUT_MAX = 7
N_PARAMS = 8

# state rows
K = 0  # samples seen
I = 1  # noqa: E741 (the integral term, as the textbook names it)
D = 2
Y_OLD = 3
START = 4  # the output the first sample's integral is set to give (NaN: none)
# the last sample's terms, for inspection
C_P = 5
C_I = 6
C_D = 7
C_UNLIM = 8
N_STATE = 9
#: the terms of the last output by signal name (a live controller's ``components`` and
#: the engine's recorded trajectory rows read these)
COMPONENTS = (("P", C_P), ("I", C_I), ("D", C_D))


def tracking_time(kp: float, ki: float, kd: float, Tt: float | None) -> float:
    """Tt as given, or its default: sqrt(Ti Td) when ki and kd are non-zero, else Ti
    (inf without an integral: nothing to track)."""
    if ki == 0.0:
        return math.inf
    if Tt is not None:
        return Tt
    ti = kp / ki
    return math.sqrt(ti * kd / kp) if kd != 0.0 else ti


@step_jit
def reset(CS, j, start):
    """Forget the history; ``start`` (NaN for none) is the output the first sample gives."""
    for row in range(N_STATE):
        CS[row, j] = 0.0
    CS[START, j] = start


#: from this sample on the law depends on k only through its state (the first sample
#: sets y_old and the bumpless start): a loop over members may run every later sample
#: through :func:`steady_step`
STEADY = 1.0


@step_jit
def _terms(CP, CS, j, y, r, h):
    """The proportional and derivative terms of this sample."""
    kp, kd, n = CP[KP, j], CP[KD, j], CP[N, j]
    p = kp * (CP[B, j] * r - y)
    # the state read whatever kd: a load under the branch keeps a loop over members
    # from vectorising (the branch's arithmetic becomes a select)
    d_old, y_old = CS[D, j], CS[Y_OLD, j]
    d = 0.0
    if kd != 0.0:
        td = kd / kp
        ad = td / (td + n * h)
        bd = kp * td * n / (td + n * h)
        d = ad * d_old - bd * (y - y_old)
    return p, d


@step_jit
def _output(CP, CS, j, y, r, h, p, i, d):
    """The output from the terms, limited; the integral updated with back-calculation;
    the terms into the state. Returns the limited output."""
    v = p + i + d
    lo, hi = CP[OUT_MIN, j], CP[OUT_MAX, j]
    u = hi if v > hi else (lo if v < lo else v)
    CS[C_P, j] = p
    CS[C_I, j] = i
    CS[C_D, j] = d
    CS[C_UNLIM, j] = v
    CS[I, j] = i + CP[KI, j] * h * (r - y) + (h / CP[TT, j]) * (u - v)
    CS[D, j] = d
    CS[Y_OLD, j] = y
    CS[K, j] = CS[K, j] + 1.0
    return u


@step_jit
def step(CP, CS, j, y, r, h):
    """One sample: measurement y, setpoint r and period h in; the limited output out."""
    if CS[K, j] == 0.0:
        CS[Y_OLD, j] = y
    p, d = _terms(CP, CS, j, y, r, h)
    i = CS[I, j]
    start = CS[START, j]
    if start == start:  # bumpless: the integral that makes v the held output
        i = start - p - d
        CS[START, j] = math.nan  # used once
    return _output(CP, CS, j, y, r, h, p, i, d)


@step_jit
def steady_step(CP, CS, j, y, r, h):
    """:func:`step` for a sample from :data:`STEADY` on, the bumpless start used (START
    NaN): its first-sample branches compiled out, so that a loop over members
    vectorises. Returns (u limited, u unlimited)."""
    p, d = _terms(CP, CS, j, y, r, h)
    return _output(CP, CS, j, y, r, h, p, CS[I, j], d), CS[C_UNLIM, j]
