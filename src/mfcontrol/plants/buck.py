"""Averaged buck converter in continuous conduction, states x = (i_L, v_C).

textbook coupling (the paper's equations)::

    di/dt = (E d - v) / L,     dv/dt = (i - v/R) / C

published coupling (what the published code integrates: its scalar input term
``E d / L`` is broadcast onto both derivatives)::

    di/dt = (E d - v) / L,     dv/dt = (i - v/R) / C + E d / L

Between samples the duty cycle d is held and the state advances by one classical RK4 step
in increment form, ``x + (f1 + 2 (f2 + f3) + f4) / 6`` with ``f = h * (A x + b)``,
``A = [[0, -1/L], [1/C, -1/(R C)]]`` and ``b = d / L * E``: the published arithmetic,
operation for operation, so that the published trajectories are reproduced exactly.
Output: ``v`` (voltage control) or ``v * i`` (power control).
"""

from .._jit import step_jit
from ..numerics import signatures as sig
from ..numerics.rk4 import combine, half, whole

# parameter rows
E = 0
L = 1
R = 2
C = 3
COUPLING = 4  # 1.0 published, 0.0 textbook
OUTPUT = 5  # 0.0 voltage, 1.0 power
A12 = 6  # derived: -1/L
A21 = 7  # derived: 1/C
A22 = 8  # derived: -1/(R C)
N_PARAMS = 9
#: the parameter rows :func:`rk4` and :func:`rk4_map` take after the state, in order
RK4_ROWS = (L, E, A12, A21, A22, COUPLING)
#: physical parameters a schedule may change, by name
PARAM_ROWS = {"E": E, "L": L, "R": R, "C": C}

# state rows
I_L = 0
V_C = 1
N_STATE = 2
STATE_NAMES = ("i_L", "v_C")
OUTPUTS = {"voltage": 0.0, "power": 1.0}
COUPLINGS = {"published": 1.0, "textbook": 0.0}


@step_jit
def coefficients(inductance, resistance, capacitance):
    """The derived coefficients (A12, A21, A22) = (-1/L, 1/C, -1/(R C))."""
    return -1.0 / inductance, 1.0 / capacitance, -1.0 / (resistance * capacitance)


@step_jit
def prepare(PP, j):
    """Recompute the derived coefficients after any parameter change."""
    PP[A12, j], PP[A21, j], PP[A22, j] = coefficients(PP[L, j], PP[R, j], PP[C, j])


@step_jit
def output(PP, X, j):
    return measure(X[I_L, j], X[V_C, j], PP[OUTPUT, j])


@step_jit
def measure(i, v, power):
    return v * i if power != 0.0 else v


@step_jit
def _rhs(a12, a21, a22, i, v, b, cb):
    """dx/dt = A x + (b, cb): b = d/L*E, cb = b (published coupling) or 0 (textbook)."""
    return a12 * v + b, (a21 * i + a22 * v) + cb


@step_jit
def deriv(PP, X, j, d):
    """(di/dt, dv/dt) of member j under duty cycle d."""
    b = d / PP[L, j] * PP[E, j]
    return _rhs(PP[A12, j], PP[A21, j], PP[A22, j], X[I_L, j], X[V_C, j], b,
                PP[COUPLING, j] * b)


@step_jit
def rk4(i, v, d, inductance, e_in, a12, a21, a22, coupling, h):
    """One RK4 step from plain floats (the arithmetic of :mod:`mfcontrol.numerics.rk4`),
    the buck's state in registers: the paper's kernels call this."""
    b = d / inductance * e_in
    cb = coupling * b
    p1, q1 = _rhs(a12, a21, a22, i, v, b, cb)
    p1, q1 = h * p1, h * q1
    p2, q2 = _rhs(a12, a21, a22, half(i, p1), half(v, q1), b, cb)
    p2, q2 = h * p2, h * q2
    p3, q3 = _rhs(a12, a21, a22, half(i, p2), half(v, q2), b, cb)
    p3, q3 = h * p3, h * q3
    p4, q4 = _rhs(a12, a21, a22, whole(i, p3), whole(v, q3), b, cb)
    p4, q4 = h * p4, h * q4
    return combine(i, p1, p2, p3, p4), combine(v, q1, q2, q3, q4)


@step_jit
def rk4_map(inductance, e_in, a12, a21, a22, coupling, h):
    """The RK4 step of :func:`rk4` as the linear map it is for this plant:
    ``x+ = F x + g d`` with ``F = I + M S``, ``g = h S beta``, ``M = h A``,
    ``S = I + M/2 (I + M/3 (I + M/4))`` and ``beta = E/L (1, coupling)``.

    The same polynomial of ``h A``, evaluated in another order: within a few ulps of
    :func:`rk4` per step, not bit-identical (only the opt-in fast modes use it: sweeps
    with ``fast=True`` and ``simulate(cfg, fast=True)``). Returns
    ``(f11, f12, f21, f22, g1, g2)``.
    """
    m12, m21, m22 = h * a12, h * a21, h * a22  # M = h A, whose (1, 1) entry is 0
    # S by Horner, from the inside: P = I + M/4, then I + M/3 P, then I + M/2 (that)
    p11, p12, p21, p22 = 1.0, m12 / 4, m21 / 4, 1.0 + m22 / 4
    q11, q12 = 1.0 + (m12 * p21) / 3, (m12 * p22) / 3
    q21, q22 = (m21 * p11 + m22 * p21) / 3, 1.0 + (m21 * p12 + m22 * p22) / 3
    s11, s12 = 1.0 + (m12 * q21) / 2, (m12 * q22) / 2
    s21, s22 = (m21 * q11 + m22 * q21) / 2, 1.0 + (m21 * q12 + m22 * q22) / 2
    f11, f12 = 1.0 + m12 * s21, m12 * s22
    f21, f22 = m21 * s11 + m22 * s21, 1.0 + (m21 * s12 + m22 * s22)
    beta = e_in / inductance
    return (f11, f12, f21, f22, h * (s11 + s12 * coupling) * beta,
            h * (s21 + s22 * coupling) * beta)


@step_jit
def rk4_linear(i, v, d, f11, f12, f21, f22, g1, g2):
    """One step of the map of :func:`rk4_map`: two multiply-adds per state, and a
    dependency chain of one fused step instead of four stages."""
    return (f11 * i + f12 * v) + g1 * d, (f21 * i + f22 * v) + g2 * d


@step_jit
def step(PP, X, j, d, h):
    """Advance member j by one RK4 step of size h with duty cycle d held."""
    X[I_L, j], X[V_C, j] = rk4(X[I_L, j], X[V_C, j], d, PP[L, j], PP[E, j], PP[A12, j],
                               PP[A21, j], PP[A22, j], PP[COUPLING, j], h)


# the plant as the general engine takes it (mfcontrol.numerics.signatures): p is a column
# of the rows above


@sig.compiled(sig.RHS)
def rhs(t, x, d, p, dxdt, nx, np_):
    b = d / p[L] * p[E]
    dxdt[I_L], dxdt[V_C] = _rhs(p[A12], p[A21], p[A22], x[I_L], x[V_C], b, p[COUPLING] * b)


@sig.compiled(sig.OUTPUT)
def measured(x, p, nx, np_):
    return measure(x[I_L], x[V_C], p[OUTPUT])


@sig.compiled(sig.PREPARE)
def derive(p, h, nx, np_):
    p[A12], p[A21], p[A22] = coefficients(p[L], p[R], p[C])
