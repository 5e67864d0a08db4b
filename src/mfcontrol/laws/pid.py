"""The discrete PID of Astrom and Hagglund (Feedback Systems / Advanced PID Control): the
baseline every comparison needs.

Per sample, in this order (``Ti = kp / ki``, ``Td = kd / kp``)::

    y_f = F(y)                   the measurement filter (y itself for Tf = 0)
    P = kp (b r - y_f)
    D = ad D + bd ((c r - y_f) - (c r_old - y_old)),
                                 ad = Td / (Td + N h),  bd = kp Td N / (Td + N h)
    v = P + I + D
    u = sat(v)
    I = I + ki h (r - y_f) + (h / Tt) (u - v)
    y_old = y_f, r_old = r

setpoint weights b on the proportional term and c on the derivative (0: the derivative of
the measurement alone), a derivative filtered with time constant Td / N (backward
difference: stable for every h; the coefficients are computed from h at every sample, so a
live call may pass its own dt), and back-calculation anti-windup with tracking time Tt.
``y_old`` starts at the first measurement and ``r_old`` at the first setpoint (no
derivative kick); ``I`` and ``D`` start at 0, or, after a bumpless switch to automatic,
``I`` starts so that the first output equals the output held in manual.

The measurement filter is Astrom and Hagglund's second-order one (Advanced PID Control,
the filter they recommend on every PID's measurement, so that the derivative and the
proportional term do not pass the noise on)::

    F(s) = 1 / (1 + s Tf + (s Tf)^2 / 2)

(damping 1/sqrt(2), unit DC gain), discretised by the backward difference, as the
derivative is: its transfer function in the backward shift q is F at s = (1 - q) / h,
stable for every h. Its state (y_f, y_f') starts at (y_0, 0): at rest at the first
measurement, so that the filter adds no transient of its own.
"""

import math

from .._jit import step_jit
from . import tunable as _tunable

# parameter rows
KP = 0
KI = 1
KD = 2
N = 3  # derivative filter: time constant Td / N
B = 4  # setpoint weight
TT = 5  # tracking time of back-calculation (s); inf: none
OUT_MIN = 6
OUT_MAX = 7
TF = 8  # the measurement filter's time constant (s); 0: none
C = 9  # setpoint weight of the derivative
N_PARAMS = 10

# state rows
K = 0  # samples seen
I = 1  # the integral term  # noqa: E741 (the textbook's name)
D = 2  # the derivative term
Y_OLD = 3  # the last sample's (filtered) measurement
START = 4  # the output the first sample's integral is set to give (NaN: none)
# the last sample's terms, for inspection
C_P = 5  # the last sample's proportional term
C_I = 6  # the last sample's integral term
C_D = 7  # the last sample's derivative term
C_UNLIM = 8  # the last sample's output before the limits
# after the terms (rows a snapshot from before them lacks at its end): the measurement
# filter's state and the last setpoint
YF = 9  # the filtered measurement y_f
YF_D = 10  # its derivative y_f'
R_OLD = 11  # the last sample's setpoint
N_STATE = 12
#: the names of the rows a step's overflow guard checks, with the output (the C export's
#: guard checks these only; :mod:`mfcontrol.engine.live` checks every row). After a step
#: from a finite memory, with a finite measurement and setpoint and valid parameters, u
#: and I are finite exactly when every row is (START aside: NaN after any step):
#: - I bounds the unlimited output v = p + i + d. Beyond a limit, u - v is infinite, and so
#:   is I's back-calculation term h / Tt (u - v) (NaN with an infinite Tt: 0 inf). Within
#:   the limits u is v.
#: - A finite v has finite terms p, i, d (rows C_P, C_I, C_D, C_UNLIM, D): one infinite
#:   term makes the sum infinite or NaN.
#: - The filtered y (YF, Y_OLD) reaches I through ki h (r - y), and v through
#:   p = kp (b r - y) (NaN when kp or ki is 0: 0 inf); its derivative YF_D reaches y as
#:   y_f + h y_f'.
#: - R_OLD is the setpoint; K is a finite count plus one.
#: Tested on hostile memories and samples in tests/laws/test_pid.py.
GUARDED = ("I",)
#: the terms of the last output by signal name (a live controller's ``components`` and
#: the engine's recorded trajectory rows read these)
COMPONENTS = (("P", C_P), ("I", C_I), ("D", C_D))
#: the rows a running controller may retune, (field, row, what): every row
#: (:mod:`mfcontrol.laws.tunable`)
TUNABLE = (
    ("kp", KP, "proportional gain"),
    ("ki", KI, "integral gain (1/s)"),
    ("kd", KD, "derivative gain (s); 0, or of kp's sign"),
    ("n", N, "derivative filter: time constant Td / N, N > 0"),
    ("b", B, "setpoint weight of the proportional term"),
    ("c", C, "setpoint weight of the derivative"),
    ("tf", TF, "measurement filter's time constant (s), >= 0 (0: none)"),
    ("tt", TT, "anti-windup tracking time (s), > 0 (INFINITY: none, only with ki 0)"),
    ("out_min", OUT_MIN, "lower output limit (-INFINITY: none)"),
    ("out_max", OUT_MAX, "upper output limit (INFINITY: none), >= out_min"),
)


def tunable(cp) -> tuple[tuple[str, int, str], ...]:
    """:data:`TUNABLE`, whatever the parameter column ``cp`` (the laws' common form)."""
    return TUNABLE


def invalid_row(CP, j):
    """The first row of :data:`TUNABLE` whose value the law is not defined for, or -1."""
    kp = CP[KP, j]
    if not math.isfinite(kp):
        return KP
    if not math.isfinite(CP[KI, j]):
        return KI
    kd = CP[KD, j]
    if not (math.isfinite(kd) and _tunable.same_sign_or_zero(kd, kp)):
        return KD
    if not _tunable.positive(CP[N, j]):
        return N
    if not math.isfinite(CP[B, j]):
        return B
    if not math.isfinite(CP[C, j]):
        return C
    tf = CP[TF, j]
    if not (math.isfinite(tf) and tf >= 0.0):
        return TF
    tt = CP[TT, j]
    # a tracking time of INFINITY (none) only without an integral: one would wind up
    if not (tt > 0.0 and (math.isfinite(tt) or CP[KI, j] == 0.0)):
        return TT
    if not _tunable.limits_ok(CP[OUT_MIN, j], CP[OUT_MAX, j]):
        return OUT_MAX
    return -1


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
def coefficients(CP, j, h):
    """What a sample computes from the parameters and its period h alone, in the order
    :func:`step_at` takes them: ki h, h / Tt, the derivative's ad and bd (0 without one),
    the measurement filter's c = 2 h / Tf^2 and 1 + c (h + Tf) (0 without one). A C export
    computes them when its parameters are set, and again only for a longer period."""
    kp, kd, n, tf = CP[KP, j], CP[KD, j], CP[N, j], CP[TF, j]
    ad = 0.0
    bd = 0.0
    if kd != 0.0:
        td = kd / kp
        ad = td / (td + n * h)
        bd = kp * td * n / (td + n * h)
    fc = 0.0
    fden = 0.0
    if tf > 0.0:
        fc = 2.0 * h / (tf * tf)
        fden = 1.0 + fc * (h + tf)
    return CP[KI, j] * h, h / CP[TT, j], ad, bd, fc, fden


@step_jit
def filter_step(x, xd, y, h, fc, fden):
    """The measurement filter's backward-difference step from its state (y_f, y_f') =
    (x, xd) on the sample y: the new state. The implicit step of
    ``(Tf^2 / 2) x'' + Tf x' + x = y`` solved in closed form:
    ``xd+ = (xd + c (y - x)) / (1 + c (h + Tf))``, ``x+ = x + h xd+``, c = 2 h / Tf^2
    (``fc`` and ``fden``: :func:`coefficients`)."""
    xd = (xd + fc * (y - x)) / fden
    return x + h * xd, xd


@step_jit
def _filtered(CP, CS, j, y, h, fc, fden):
    """y_f of this sample, the filter's state advanced (y itself without a filter)."""
    if CP[TF, j] > 0.0:
        y, CS[YF_D, j] = filter_step(CS[YF, j], CS[YF_D, j], y, h, fc, fden)
    CS[YF, j] = y
    return y


@step_jit
def _terms(CP, CS, j, y, r, ad, bd):
    """The proportional and derivative terms of this sample, on the filtered y."""
    kp, kd, c = CP[KP, j], CP[KD, j], CP[C, j]
    p = kp * (CP[B, j] * r - y)
    # the state read whatever kd: a load under the branch keeps a loop over members
    # from vectorising (the branch's arithmetic becomes a select)
    d_old, y_old, r_old = CS[D, j], CS[Y_OLD, j], CS[R_OLD, j]
    d = 0.0
    if kd != 0.0:
        # c = 0: the measurement's difference alone (c r would be NaN for an infinite r)
        de = (y - y_old) if c == 0.0 else ((y - c * r) - (y_old - c * r_old))
        d = ad * d_old - bd * de
    return p, d


@step_jit
def _output(CP, CS, j, y, r, kih, htt, p, i, d):
    """The output from the terms, limited; the integral updated with back-calculation;
    the terms into the state. Returns the limited output."""
    v = p + i + d
    lo, hi = CP[OUT_MIN, j], CP[OUT_MAX, j]
    u = hi if v > hi else (lo if v < lo else v)
    CS[C_P, j] = p
    CS[C_I, j] = i
    CS[C_D, j] = d
    CS[C_UNLIM, j] = v
    CS[I, j] = i + kih * (r - y) + htt * (u - v)
    CS[D, j] = d
    CS[Y_OLD, j] = y
    CS[R_OLD, j] = r
    CS[K, j] = CS[K, j] + 1.0
    return u


@step_jit
def step_at(CP, CS, j, y, r, h, kih, htt, ad, bd, fc, fden):
    """:func:`step` given the period's :func:`coefficients`."""
    if CS[K, j] == 0.0:  # at rest at the first sample: no kick, no filter transient
        CS[Y_OLD, j] = y
        CS[R_OLD, j] = r
        CS[YF, j] = y
        CS[YF_D, j] = 0.0
    y = _filtered(CP, CS, j, y, h, fc, fden)
    p, d = _terms(CP, CS, j, y, r, ad, bd)
    i = CS[I, j]
    start = CS[START, j]
    if start == start:  # bumpless: the integral that makes v the held output
        i = start - p - d
        CS[START, j] = math.nan  # used once
    return _output(CP, CS, j, y, r, kih, htt, p, i, d)


@step_jit
def step(CP, CS, j, y, r, h):
    """One sample: measurement y, setpoint r and period h in; the limited output out."""
    kih, htt, ad, bd, fc, fden = coefficients(CP, j, h)
    return step_at(CP, CS, j, y, r, h, kih, htt, ad, bd, fc, fden)


@step_jit
def steady_step(CP, CS, j, y, r, h):
    """:func:`step` for a sample from :data:`STEADY` on, the bumpless start used (START
    NaN): its first-sample branches compiled out, so that a loop over members
    vectorises. Returns (u limited, u unlimited)."""
    kih, htt, ad, bd, fc, fden = coefficients(CP, j, h)
    y = _filtered(CP, CS, j, y, h, fc, fden)
    p, d = _terms(CP, CS, j, y, r, ad, bd)
    return _output(CP, CS, j, y, r, kih, htt, p, CS[I, j], d), CS[C_UNLIM, j]
