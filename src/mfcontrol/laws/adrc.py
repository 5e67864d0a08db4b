"""Linear active disturbance rejection control (ADRC) of order 1 or 2: the standard
competitor of model-free control, discrete as practitioners run it.

The plant is taken as ``y^(n) = f + b0 u`` (n = 1 or 2): b0 is a rough input gain (the
counterpart of the ultra-local model's alpha) and f, the "total disturbance", collects
everything else, as F does. An extended state observer (ESO) estimates the state
``x = (y, .., y^(n-1), f)`` and the control law cancels f and places the remaining
chain of integrators (Gao 2003, "Scaling and bandwidth-parameterization based controller
tuning")::

    n = 1:  u = (kp (r - x1) - x2) / b0,            kp = wc
    n = 2:  u = (kp (r - x1) - kd x2 - x3) / b0,    kp = wc^2, kd = 2 wc

so that the closed loop behaves as ``(s + wc)^n`` (wc: the controller's bandwidth, rad/s).

The observer is the continuous ESO ``x' = A x + B u``, ``y = C x`` (A the chain of n + 1
integrators, B = b0 at row n, C the first row) discretised by the zero-order hold
(Miklosovic, Radke and Gao 2006), as a *current* observer: the sample's measurement
corrects the prediction before the output is computed, so u_k reads y_k without a
sample's lag (Herbst 2013, "A simulative study on active disturbance rejection control
(ADRC) as a control tool for practitioners"). Per sample, with ``z`` the prediction of
x_k made at the previous sample::

    x_k   = z + L (y_k - z1)                      correction
    u_k   = sat(v_k),  v_k the law above on x_k   output, limited
    z     = Ad x_k + Bd u_{k-d}                   prediction of x_{k+1}

with the exact ZOH matrices of the integrator chain (h the sample period)::

    n = 1:  Ad = [[1, h], [0, 1]],                       Bd = b0 (h, 0)
    n = 2:  Ad = [[1, h, h^2/2], [0, 1, h], [0, 0, 1]],  Bd = b0 (h^2/2, h, 0)

and the observer gain that puts every eigenvalue of the estimation error's matrix
``(I - L C) Ad`` at ``beta = exp(-wo h)``, the ZOH image of a continuous ESO with all its
poles at -wo (wo: the observer's bandwidth, rad/s; Herbst's closed forms)::

    n = 1:  L = (1 - beta^2, (1 - beta)^2 / h)
    n = 2:  L = (1 - beta^3, 3 (1 - beta)^2 (1 + beta) / (2 h), (1 - beta)^3 / h^2)

The observer is fed the *applied* (limited) output: it then estimates what the plant
received, so nothing winds up (ADRC's own anti-windup). With a known input delay of d
samples (``delay``, the actuator's and the sensor's together) it is fed u_{k-d} instead,
the input that acts on the plant over the coming period: the observer and the plant see
the same input, and the delay's effect is not taken for a disturbance (the simplest delay
compensation of the ADRC literature; the law keeps its last d outputs for it).

Start: the prediction starts at rest on the first measurement, ``z = (y_0, 0, .., 0)``,
so the observer adds no transient of its own; f's estimate starts at 0, or, after a
bumpless switch to automatic (:func:`reset` with a start), at the value that makes the
first output equal the output held in manual: ``f = -b0 u`` is what holds a plant at rest
under u. Coefficients are computed from h at every sample, so a live call may pass its own
dt.
"""

import math

from .._jit import step_jit
from . import tunable as _tunable
from .intelligent import MAX_DELAY

# parameter rows
ORDER = 0  # n: 1 or 2
B0 = 1  # the input gain b0 of y^(n) = f + b0 u
WC = 2  # the controller's bandwidth (rad/s)
WO = 3  # the observer's bandwidth (rad/s)
OUT_MIN = 4
OUT_MAX = 5
DELAY = 6  # the loop's known input delay d, samples
N_PARAMS = 7

# state rows
K = 0  # samples seen
Z1 = 1  # the observer's prediction of x_k, first state: y
Z2 = 2  # its second state: y' (n = 2) or f (n = 1)
Z3 = 3  # its third state: f (n = 2)
START = 4  # the output the first sample is set to give (NaN: none)
# the last sample's terms, for inspection
C_P = 5  # kp (r - x1) / b0
C_D = 6  # -kd x2 / b0 (n = 2; 0 for n = 1)
C_F = 7  # the total disturbance's estimate f (the output's term is -f / b0)
C_UNLIM = 8  # the last sample's output before the limits
HEAD = 9  # the delay's ring: the slot of u_{k-d}, read then overwritten by u_k
N_STATE = 10  # the ring's d slots follow: n_state(d) rows in all
#: the terms of the last output by signal name (a live controller's ``components`` and
#: the engine's recorded trajectory rows read these)
COMPONENTS = (("P", C_P), ("D", C_D), ("F_hat", C_F))
# MAX_DELAY (imported): the longest delay the law compensates, samples, the intelligent
# laws' own bound (a ring of that many outputs here)
#: the rows a running controller may retune, (field, row, what); the order and the delay
#: fix the law's structure (:mod:`mfcontrol.laws.tunable`)
TUNABLE = (
    ("b0", B0, "input gain b0 of y^(n) = f + b0 u, nonzero, of the plant's sign"),
    ("wc", WC, "controller bandwidth (rad/s), > 0"),
    ("wo", WO, "observer bandwidth (rad/s), > 0"),
    ("out_min", OUT_MIN, "lower output limit (-INFINITY: none)"),
    ("out_max", OUT_MAX, "upper output limit (INFINITY: none), >= out_min"),
)


def tunable(cp) -> tuple[tuple[str, int, str], ...]:
    """:data:`TUNABLE`, whatever the parameter column ``cp`` (the laws' common form)."""
    return TUNABLE


def invalid_row(CP, j):
    """The first row of :data:`TUNABLE` whose value the law is not defined for, or -1."""
    b0 = CP[B0, j]
    if not (math.isfinite(b0) and b0 != 0.0):
        return B0
    if not _tunable.positive(CP[WC, j]):
        return WC
    if not _tunable.positive(CP[WO, j]):
        return WO
    if not _tunable.limits_ok(CP[OUT_MIN, j], CP[OUT_MAX, j]):
        return OUT_MAX
    return -1


def problem(b0: float, delay: int) -> tuple[str, str] | None:
    """What the law cannot run of an input gain and a compensated delay (a whole number
    of samples >= 0): (the option at fault, "b0" or "delay", what is allowed), or None.
    The one statement of these rules: the live controller and the configuration refuse
    them in their own keys' names."""
    if b0 == 0.0 or not math.isfinite(b0):
        return "b0", "must be a finite nonzero number (the plant's input gain, of its sign)"
    if delay > MAX_DELAY:
        return "delay", f"must be a whole number of samples from 0 to {MAX_DELAY:,}"
    return None


def n_state(delay: int) -> int:
    """State rows of a law that compensates ``delay`` samples."""
    return N_STATE + delay


@step_jit
def gains(order, wc):
    """(kp, kd) of the bandwidth parameterisation: the closed loop's n poles at -wc
    (kd = 0 for n = 1)."""
    if order == 1.0:
        return wc, 0.0
    return wc * wc, 2.0 * wc


@step_jit
def observer_gains(order, wo, h):
    """The current observer's gain (l1, l2, l3; l3 = 0 for n = 1): every eigenvalue of
    (I - L C) Ad at exp(-wo h)."""
    beta = math.exp(-wo * h)
    c = 1.0 - beta
    if order == 1.0:
        return 1.0 - beta * beta, c * c / h, 0.0
    return 1.0 - beta * beta * beta, 1.5 * c * c * (1.0 + beta) / h, c * c * c / (h * h)


@step_jit
def coefficients(CP, j, h):
    """What a sample computes from the parameters and its period h alone, in the order
    :func:`step_at` takes them: the observer's gains (:func:`observer_gains`). A C export
    computes them when its parameters are set, and again only for a longer period."""
    return observer_gains(CP[ORDER, j], CP[WO, j], h)


@step_jit
def reset(CP, CS, j, start):
    """Forget the history; ``start`` (NaN for none) is the output the first sample gives
    (and what the delay's ring holds: the output applied before the start)."""
    for row in range(N_STATE):
        CS[row, j] = 0.0
    CS[START, j] = start
    held = 0.0 if start != start else start
    for i in range(int(CP[DELAY, j])):
        CS[N_STATE + i, j] = held


#: from this sample on the law depends on k only through its state (the first sample
#: sets the observer at rest and takes the bumpless start): a loop over members may run
#: every later sample through :func:`steady_step`
STEADY = 1.0


@step_jit
def _corrected(CS, j, y, l1, l2, l3):
    """x_k from the prediction and y_k: (x1, x2, x3)."""
    z1, z2, z3 = CS[Z1, j], CS[Z2, j], CS[Z3, j]
    e = y - z1
    return z1 + l1 * e, z2 + l2 * e, z3 + l3 * e


@step_jit
def _terms(CP, j, order, x1, x2, x3, r):
    """(P, D, f) of the law on x_k: v = P + D - f / b0."""
    b0 = CP[B0, j]
    kp, kd = gains(order, CP[WC, j])
    if order == 1.0:
        return kp * (r - x1) / b0, 0.0, x2
    return kp * (r - x1) / b0, -kd * x2 / b0, x3


@step_jit
def _output(CP, CS, j, order, x1, x2, x3, p, d, f, h):
    """The limited output from the terms; the prediction of x_{k+1} with the input that
    acts over the coming period; the terms into the state. Returns the limited output."""
    b0 = CP[B0, j]
    v = p + d - f / b0
    lo, hi = CP[OUT_MIN, j], CP[OUT_MAX, j]
    u = hi if v > hi else (lo if v < lo else v)
    CS[C_P, j] = p
    CS[C_D, j] = d
    CS[C_F, j] = f
    CS[C_UNLIM, j] = v
    u_obs = u
    n_delay = int(CP[DELAY, j])
    if n_delay > 0:  # the ring: u_{k-d} out, u_k in its slot
        slot = int(CS[HEAD, j])
        u_obs = CS[N_STATE + slot, j]
        CS[N_STATE + slot, j] = u
        CS[HEAD, j] = 0.0 if slot + 1 == n_delay else slot + 1.0
    bu = b0 * u_obs
    if order == 1.0:
        CS[Z1, j] = x1 + h * (x2 + bu)
        CS[Z2, j] = x2
    else:
        CS[Z1, j] = x1 + h * (x2 + 0.5 * h * (x3 + bu))
        CS[Z2, j] = x2 + h * (x3 + bu)
        CS[Z3, j] = x3
    CS[K, j] = CS[K, j] + 1.0
    return u


@step_jit
def step_at(CP, CS, j, y, r, h, l1, l2, l3):
    """:func:`step` given the period's :func:`coefficients`."""
    order = CP[ORDER, j]
    if CS[K, j] == 0.0:  # at rest on the first measurement: no observer transient
        CS[Z1, j] = y
        CS[Z2, j] = 0.0
        CS[Z3, j] = 0.0
    x1, x2, x3 = _corrected(CS, j, y, l1, l2, l3)
    p, d, f = _terms(CP, j, order, x1, x2, x3, r)
    start = CS[START, j]
    if start == start:  # bumpless: the disturbance estimate that makes v the held output
        f = CP[B0, j] * (p + d - start)
        if order == 1.0:
            x2 = f
        else:
            x3 = f
        CS[START, j] = math.nan  # used once
    return _output(CP, CS, j, order, x1, x2, x3, p, d, f, h)


@step_jit
def step(CP, CS, j, y, r, h):
    """One sample: measurement y, setpoint r and period h in; the limited output out."""
    l1, l2, l3 = coefficients(CP, j, h)
    return step_at(CP, CS, j, y, r, h, l1, l2, l3)


@step_jit
def steady_step(CP, CS, j, y, r, h):
    """:func:`step` for a sample from :data:`STEADY` on, the bumpless start used (START
    NaN): its first-sample branches compiled out, so that a loop over members
    vectorises. Returns (u limited, u unlimited)."""
    order = CP[ORDER, j]
    l1, l2, l3 = coefficients(CP, j, h)
    x1, x2, x3 = _corrected(CS, j, y, l1, l2, l3)
    p, d, f = _terms(CP, j, order, x1, x2, x3, r)
    return _output(CP, CS, j, order, x1, x2, x3, p, d, f, h), CS[C_UNLIM, j]
