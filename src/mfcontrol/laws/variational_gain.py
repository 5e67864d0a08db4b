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

Columns are SoA: ``CP[row, j]`` holds parameters and ``CS[row, j]`` state of member j.
"""

from .._jit import step_jit

# parameter rows
MODE = 0
INV_ALPHA = 1
GAMMA0 = 2
GAMMA_RATE = 3  # the paper's Gamma
EPS_M = 4
ORDER = 5
EVERY = 6  # the multi-rate update: gamma moves every EVERY control samples (1: each)
N_PARAMS = 7

# state rows
G1 = 0  # gamma_{k-1}
G2 = 1  # gamma_{k-2}
ALPHA_EXT = 2  # external mode: alpha for the coming sample
ACC = 3  # multi-rate: the force f summed over the samples since the last update
CNT = 4  # multi-rate: those samples' count
N_STATE = 5

#: the first sample from which gamma_k no longer depends on k itself (only on the
#: state): a kernel may pass STEADY for every k >= STEADY and compile out the start-up
STEADY = 3.0

CONSTANT = 0
VARIATIONAL = 1
EXTERNAL = 2
MODES = {"constant": CONSTANT, "variational": VARIATIONAL, "external": EXTERNAL}


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


@step_jit
def next_gamma(mode, k, e_dot, g1, g2, acc, cnt, inv_alpha, gamma0, rate, eps_m, order,
               every, alpha_ext):
    """gamma_k from plain floats: the one place the adaptation is written.

    (g1, g2) are gamma at the last two updates (every sample unless multi-rate), (acc,
    cnt) the multi-rate sum of the force and its count. Returns (gamma_k, g1, g2, acc,
    cnt) to carry. The branches are uniform or predictable, cost nothing in a single run,
    and are if-converted where a loop over members is vectorised."""
    if mode == VARIATIONAL:
        if k < STEADY:
            return gamma0, gamma0, g1, 0.0, 0.0
        second = g2 if order == 2.0 else g1
        if every <= 1.0:  # per sample (0: a column built before EVERY existed)
            g = ((e_dot - eps_m) * rate + 2.0 * g1) - second
            return g, g, g1, acc, cnt
        acc = acc + (e_dot - eps_m)
        cnt = cnt + 1.0
        if cnt < every:  # between updates gamma holds
            return g1, g1, g2, acc, cnt
        # the macro step's Gamma: m^2 Gamma (second order) or m Gamma, on the mean force
        scale = every * every if order == 2.0 else every
        g = ((acc / every) * (rate * scale) + 2.0 * g1) - second
        return g, g, g1, 0.0, 0.0
    if mode == EXTERNAL:
        g = 1.0 / alpha_ext
        return g, g, g1, acc, cnt
    return inv_alpha, inv_alpha, g1, acc, cnt


@step_jit
def update(CP, CS, j, k, e_dot):
    """Advance to sample k (>= 1) given the error derivative; return (gamma_k, gamma_{k-1})."""
    g1 = CS[G1, j]
    g, CS[G1, j], CS[G2, j], CS[ACC, j], CS[CNT, j] = next_gamma(
        CP[MODE, j], k, e_dot, g1, CS[G2, j], CS[ACC, j], CS[CNT, j], CP[INV_ALPHA, j],
        CP[GAMMA0, j], CP[GAMMA_RATE, j], CP[EPS_M, j], CP[ORDER, j], CP[EVERY, j],
        CS[ALPHA_EXT, j])
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
