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
def prepare(PP, j):
    """Recompute the derived coefficients after any parameter change."""
    PP[A12, j] = -1.0 / PP[L, j]
    PP[A21, j] = 1.0 / PP[C, j]
    PP[A22, j] = -1.0 / (PP[R, j] * PP[C, j])


@step_jit
def output(PP, X, j):
    v = X[V_C, j]
    return v * X[I_L, j] if PP[OUTPUT, j] != 0.0 else v


@step_jit
def _rhs(PP, j, i, v, b, cb):
    """dx/dt = A x + (b, cb): b = d/L*E, cb = b (published coupling) or 0 (textbook)."""
    return PP[A12, j] * v + b, (PP[A21, j] * i + PP[A22, j] * v) + cb


@step_jit
def deriv(PP, X, j, d):
    """(di/dt, dv/dt) of member j under duty cycle d."""
    b = d / PP[L, j] * PP[E, j]
    return _rhs(PP, j, X[I_L, j], X[V_C, j], b, PP[COUPLING, j] * b)


@step_jit
def _increment(PP, j, i, v, b, cb, h):
    di, dv = _rhs(PP, j, i, v, b, cb)
    return h * di, h * dv


@step_jit
def step(PP, X, j, d, h):
    """Advance member j by one RK4 step of size h with duty cycle d held."""
    i = X[I_L, j]
    v = X[V_C, j]
    b = d / PP[L, j] * PP[E, j]
    cb = PP[COUPLING, j] * b
    p1, q1 = _increment(PP, j, i, v, b, cb, h)
    p2, q2 = _increment(PP, j, i + p1 / 2, v + q1 / 2, b, cb, h)
    p3, q3 = _increment(PP, j, i + p2 / 2, v + q2 / 2, b, cb, h)
    p4, q4 = _increment(PP, j, i + p3, v + q3, b, cb, h)
    X[I_L, j] = i + (p1 + 2 * (p2 + p3) + p4) / 6
    X[V_C, j] = v + (q1 + 2 * (q2 + q3) + q4) / 6
