"""Gain adaptation: the key gain ``gamma`` (the role of 1/alpha) of a model-free law.

Modes
-----
constant
    ``gamma_k = 1/alpha`` for every k (the standard law).
external
    ``gamma_k = 1/alpha_k`` with alpha_k supplied by the caller at every sample (written
    to the state row ``ALPHA_EXT`` before the step).
variational
    The symplectic integrator of Michel (CCTA 2025), eq. (32), with the published
    indexing: ``gamma_0 = gamma_1 = gamma_2 = gamma0`` and, for k >= 3,
    ``gamma_k = ((e_dot_k - eps_M) * Gamma + 2 gamma_{k-1}) - gamma_prev``
    where ``gamma_prev`` is ``gamma_{k-2}`` (second order, as printed) or
    ``gamma_{k-1}`` (first order, what the published code computes). Both orders share
    this one expression, evaluated in the published code's floating-point order.

    Multi-rate (``EVERY`` = m > 1, the paper's perspective of adapting on a slower time
    scale, after the multi-rate variational integrators it cites): gamma is updated every
    m control samples and held between. The discrete Euler-Lagrange step is then taken at
    the macro step H = m h: the force f = e_dot - eps_M enters as its mean over the m
    samples (the rectangle rule for the integral of dL/dgamma over the macro step), and
    Gamma, which is h^2 / K_gamma (second order) or carries one h (first order), becomes
    m^2 Gamma or m Gamma::

        gamma_{K+1} = m^order Gamma mean(f over the last m samples) + 2 gamma_K - second

    ``second`` as above, at the macro steps. m = 1 is the per-sample law, bit for bit.

    The adaptation error: the force ``f_k = e_dot_k - eps_M`` is K_p times the model-free
    Lagrangian's dL/dgamma, the right-hand side of the discrete Euler-Lagrange equation
    ``K_gamma (gamma_{k+1} - 2 gamma_k + gamma_{k-1}) / h^2 = f_k``: zero where the
    optimisation is stationary (gamma no longer accelerates; the error dynamics the
    Lagrangian is built on hold with e_dot = eps_M). Its integral over the run,
    ``sum |f_k| h`` over the adapting samples k >= 3 (row ``ADAPT``; every sample's force
    counts, whatever m), measures how far the online optimisation stayed from its
    stationary point: the metric ``adaptation_error``, in y's unit (a rate of y
    integrated over time).
rls
    ``gamma_k = 1/alpha_k`` with alpha_k estimated online by recursive least squares on
    the ultra-local model's exact relation under the held input, ``y^(n)_k = F + alpha
    v_k`` (v the input the plant received, :func:`mfcontrol.laws.intelligent.held_input`),
    F and alpha both unknown, with exponential forgetting ``FORGET`` and the estimate
    clipped to [``ALPHA_LO``, ``ALPHA_HI``] (:func:`rls_step`; the intelligent laws run
    it and write alpha_k to ``ALPHA_EXT``, which this mode then reads as the external
    one does).

Columns are SoA: ``CP[row, j]`` holds parameters and ``CS[row, j]`` state of member j.
"""

import math

from .._jit import step_jit
from . import tunable as _tunable

# parameter rows
MODE = 0
INV_ALPHA = 1
GAMMA0 = 2
GAMMA_RATE = 3  # the paper's Gamma
EPS_M = 4
ORDER = 5
EVERY = 6  # the multi-rate update: gamma moves every EVERY control samples (1: each)
FORGET = 7  # rls: the forgetting factor lambda, 0 < lambda <= 1
ALPHA_LO = 8  # rls: the estimate's clip
ALPHA_HI = 9
N_PARAMS = 10

# state rows
G1 = 0  # gamma_{k-1}
G2 = 1  # gamma_{k-2}
ALPHA_EXT = 2  # external mode: alpha for the coming sample
ACC = 3  # multi-rate: the force f summed over the samples since the last update
CNT = 4  # multi-rate: those samples' count
ADAPT = 5  # variational: the adaptation error integrated since the reset (adaptation_error)
N_STATE = 6

#: the first sample from which gamma_k no longer depends on k itself (only on the
#: state): a kernel may pass STEADY for every k >= STEADY and compile out the start-up
STEADY = 3.0

CONSTANT = 0
VARIATIONAL = 1
EXTERNAL = 2
RLS = 3
MODES = {"constant": CONSTANT, "variational": VARIATIONAL, "external": EXTERNAL, "rls": RLS}

#: rls: the prior's variances of F / alpha0 (in u's units) and of alpha / alpha0, the
#: regression being normalised by the starting alpha0: a standard deviation of 100 u
#: for F and of 10 alpha0 for alpha, weak against any few samples of data. Their sum
#: caps the covariance's trace (forgetting stops there: no wind-up without excitation)
RLS_P0_F = 1e4
RLS_P0_ALPHA = 1e2


def tunable(mode: float) -> tuple[tuple[str, int, str], ...]:
    """The rows of the gain a running controller may retune under ``mode``, (field, row,
    what) (:mod:`mfcontrol.laws.tunable`): 1/alpha for a constant gain, the adaptation's
    rows for the variational one; the external gain has none, and the rls gain's alpha,
    forgetting and clip are checked together where it is built (:func:`rls_problem`), so
    they stay as built."""
    if mode == CONSTANT:
        return (("inv_alpha", INV_ALPHA, "1 / alpha, the constant gain (> 0)"),)
    if mode == VARIATIONAL:
        return (("gamma0", GAMMA0, "the variational gain's start"),
                ("gamma_rate", GAMMA_RATE, "the variational gain's rate Gamma"),
                ("eps_m", EPS_M, "the variational gain's bound eps_M"))
    return ()


def invalid_row(CP, j):
    """The first row of :func:`tunable` whose value the gain is not defined for, or -1."""
    mode = CP[MODE, j]
    if mode == CONSTANT:
        inv = CP[INV_ALPHA, j]
        # alpha itself finite: 1 / inv, tested only once inv > 0
        if not (_tunable.positive(inv) and math.isfinite(1.0 / inv)):
            return INV_ALPHA
    elif mode == VARIATIONAL:
        if not math.isfinite(CP[GAMMA0, j]):
            return GAMMA0
        if not math.isfinite(CP[GAMMA_RATE, j]):
            return GAMMA_RATE
        if not math.isfinite(CP[EPS_M, j]):
            return EPS_M
    return -1


def rls_limits(alpha: float, lo: float | None, hi: float | None) -> tuple[float, float]:
    """The rls estimate's clip: ``lo`` and ``hi`` as given, each by default a decade
    around the starting alpha (alpha / 10, 10 alpha). The one statement of the default:
    the live controllers and the configuration take it from here."""
    return alpha / 10.0 if lo is None else lo, alpha * 10.0 if hi is None else hi


def rls_problem(alpha: float, forgetting: float, lo: float, hi: float
                ) -> tuple[str, str] | None:
    """What the rls gain cannot take, as (the option at fault: "forgetting", "alpha_min"
    or "alpha_max", what is allowed), or None: 0 < forgetting <= 1 and a clip
    0 < lo <= alpha <= hi around the starting alpha. The one statement of these rules:
    the live controllers and the configuration refuse them in their own keys' names."""
    if not 0.0 < forgetting <= 1.0:
        return "forgetting", "must be in (0, 1]: 1 remembers every sample, 0.99 about 100"
    if not 0.0 < lo <= alpha:
        return "alpha_min", f"must be > 0 and at most the starting alpha = {alpha:g}"
    if not hi >= alpha:
        return "alpha_max", f"must be at least the starting alpha = {alpha:g}"
    return None


@step_jit
def initial(CP, j):
    """gamma_0: gamma0 when adapting, 1/alpha otherwise."""
    return CP[GAMMA0, j] if CP[MODE, j] == VARIATIONAL else CP[INV_ALPHA, j]


@step_jit
def reset(CP, CS, j):
    g = initial(CP, j)
    CS[G1, j] = g
    CS[G2, j] = g
    CS[ALPHA_EXT, j] = 1.0 / CP[INV_ALPHA, j]
    CS[ACC, j] = 0.0
    CS[CNT, j] = 0.0
    CS[ADAPT, j] = 0.0


@step_jit
def next_gamma(mode, k, e_dot, g1, g2, acc, cnt, adapt, inv_alpha, gamma0, rate, eps_m,
               order, every, alpha_ext, h):
    """gamma_k from plain floats: the one place the adaptation is written.

    (g1, g2) are gamma at the last two updates (every sample unless multi-rate), (acc,
    cnt) the multi-rate sum of the force and its count, ``adapt`` the adaptation error
    integrated so far (``|e_dot - eps_m| h`` a sample, h the law's period). Returns
    (gamma_k, g1, g2, acc, cnt, adapt) to carry. The branches are uniform or
    predictable, cost nothing in a single run, and are if-converted where a loop over
    members is vectorised."""
    if mode == VARIATIONAL:
        if k < STEADY:
            return gamma0, gamma0, g1, 0.0, 0.0, adapt
        second = g2 if order == 2.0 else g1
        f = e_dot - eps_m
        adapt = adapt + abs(f) * h
        if every <= 1.0:  # per sample (0: a column built before EVERY existed)
            g = (f * rate + 2.0 * g1) - second
            return g, g, g1, acc, cnt, adapt
        acc = acc + f
        cnt = cnt + 1.0
        if cnt < every:  # between updates gamma holds
            return g1, g1, g2, acc, cnt, adapt
        # the macro step's Gamma: m^2 Gamma (second order) or m Gamma, on the mean force
        scale = every * every if order == 2.0 else every
        g = ((acc / every) * (rate * scale) + 2.0 * g1) - second
        return g, g, g1, 0.0, 0.0, adapt
    if mode == EXTERNAL or mode == RLS:
        g = 1.0 / alpha_ext
        return g, g, g1, acc, cnt, adapt
    return inv_alpha, inv_alpha, g1, acc, cnt, adapt


@step_jit
def update(CP, CS, j, k, e_dot, h):
    """Advance to sample k (>= 1) given the error derivative and the law's period h;
    return (gamma_k, gamma_{k-1})."""
    g1 = CS[G1, j]
    g, CS[G1, j], CS[G2, j], CS[ACC, j], CS[CNT, j], CS[ADAPT, j] = next_gamma(
        CP[MODE, j], k, e_dot, g1, CS[G2, j], CS[ACC, j], CS[CNT, j], CS[ADAPT, j],
        CP[INV_ALPHA, j], CP[GAMMA0, j], CP[GAMMA_RATE, j], CP[EPS_M, j], CP[ORDER, j],
        CP[EVERY, j], CS[ALPHA_EXT, j], h)
    return g, g1


@step_jit
def update_constant(CP, CS, j):
    """:func:`update` of a member whose mode is constant: the same state and values,
    without the other modes' arithmetic (a loop over members would compute every mode's
    and select, a division among them)."""
    g1 = CS[G1, j]
    g = CP[INV_ALPHA, j]
    CS[G2, j] = g1
    CS[G1, j] = g
    return g, g1


@step_jit
def rls_step(f, a, p11, p12, p22, z, v, lam, p_max):
    """One step of recursive least squares for ``z = f + a v`` (theta = (f, a), regressor
    (1, v)) with forgetting ``lam``, from plain floats: the one place it is written.
    Returns the new (f, a, p11, p12, p22), P the symmetric covariance. Forgetting divides
    P by lam only while its trace stays below ``p_max``: without excitation (v constant)
    P would otherwise grow without bound in the direction the data does not see, and the
    first excitation after a long rest would throw the estimate."""
    q1 = p11 + p12 * v  # P (1, v)
    q2 = p12 + p22 * v
    den = lam + (q1 + q2 * v)
    e = z - (f + a * v)
    k1 = q1 / den
    k2 = q2 / den
    f = f + k1 * e
    a = a + k2 * e
    p11 = p11 - k1 * q1
    p12 = p12 - k1 * q2
    p22 = p22 - k2 * q2
    if p11 + p22 < p_max:
        p11 = p11 / lam
        p12 = p12 / lam
        p22 = p22 / lam
    return f, a, p11, p12, p22
