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
N_PARAMS = 6

# state rows
G1 = 0  # gamma_{k-1}
G2 = 1  # gamma_{k-2}
ALPHA_EXT = 2  # external mode: alpha for the coming sample
N_STATE = 3

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


@step_jit
def next_gamma(mode, k, e_dot, g1, g2, inv_alpha, gamma0, rate, eps_m, order, alpha_ext):
    """gamma_k from plain floats: the one place the adaptation is written. The branches
    are uniform or predictable, cost nothing in a single run, and are if-converted where a
    loop over members is vectorised."""
    if mode == VARIATIONAL:
        if k < STEADY:
            return gamma0
        second = g2 if order == 2.0 else g1
        return ((e_dot - eps_m) * rate + 2.0 * g1) - second
    if mode == EXTERNAL:
        return 1.0 / alpha_ext
    return inv_alpha


@step_jit
def update(CP, CS, j, k, e_dot):
    """Advance to sample k (>= 1) given the error derivative; return (gamma_k, gamma_{k-1})."""
    g1 = CS[G1, j]
    g = next_gamma(CP[MODE, j], k, e_dot, g1, CS[G2, j], CP[INV_ALPHA, j], CP[GAMMA0, j],
                   CP[GAMMA_RATE, j], CP[EPS_M, j], CP[ORDER, j], CS[ALPHA_EXT, j])
    CS[G2, j] = g1
    CS[G1, j] = g
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
