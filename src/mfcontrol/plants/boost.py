"""Averaged boost converter in continuous conduction, states x = (i_L, v_C), input d (duty).

::

    L di/dt = E - (1 - d) v,     C dv/dt = (1 - d) i - v / R

Output: ``v``. For a constant duty cycle D the equilibrium is ``v = E / (1 - D)``,
``i = v / ((1 - D) R)``.

Non-minimum phase from d to v. Linearised around an operating point (D, I, V), with
``D' = 1 - D``::

    v(s) / d(s) = (V / D') (1 - s L / (D'^2 R)) / (1 + s L / (D'^2 R) + s^2 L C / D'^2)

has a right-half-plane zero at ``s = D'^2 R / L`` (rad/s): raising d first diverts the
inductor current from the capacitor (``C dv/dt`` drops by ``I dd``), so v dips before it
rises towards its higher equilibrium. The zero moves towards the origin as D grows or R
drops (heavier load); it bounds the bandwidth a voltage loop can reach.

Between samples d is held and the engine advances the state with its integrator (the one
RK4 of :mod:`mfcontrol.numerics.rk4` by default) on :func:`rhs`.
"""

from .._jit import step_jit
from ..numerics import signatures as sig

# parameter rows
E = 0
L = 1
R = 2
C = 3
INV_L = 4  # derived: 1/L
INV_C = 5  # derived: 1/C
INV_RC = 6  # derived: 1/(R C)
N_PARAMS = 7
#: physical parameters a schedule may change, by name
PARAM_ROWS = {"E": E, "L": L, "R": R, "C": C}

# state rows
I_L = 0
V_C = 1
N_STATE = 2
STATE_NAMES = ("i_L", "v_C")


@step_jit
def coefficients(inductance, resistance, capacitance):
    """The derived coefficients (1/L, 1/C, 1/(R C))."""
    return 1.0 / inductance, 1.0 / capacitance, 1.0 / (resistance * capacitance)


@step_jit
def _field(e_in, inv_l, inv_c, inv_rc, i, v, dp):
    """The model's right-hand side from plain floats: the one place it is written."""
    return (e_in - dp * v) * inv_l, dp * i * inv_c - v * inv_rc


# the plant as the general engine takes it (mfcontrol.numerics.signatures): p is a column
# of the rows above


@sig.compiled(sig.RHS)
def rhs(t, x, d, p, dxdt, nx, np_):
    dxdt[I_L], dxdt[V_C] = _field(p[E], p[INV_L], p[INV_C], p[INV_RC], x[I_L], x[V_C], 1.0 - d)


@sig.compiled(sig.OUTPUT)
def measured(x, p, nx, np_):
    return x[V_C]


@sig.compiled(sig.PREPARE)
def derive(p, h, nx, np_):
    p[INV_L], p[INV_C], p[INV_RC] = coefficients(p[L], p[R], p[C])
