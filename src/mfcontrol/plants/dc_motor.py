"""Separately excited DC motor driven by its armature voltage, states x = (omega, i)::

    J domega/dt = Km i - friction omega - load
    La di/dt    = u - Ra i - Km omega

Output: the speed ``omega`` (rad/s); input: the armature voltage u (V). ``load`` is the
load torque (N m), a parameter, so a schedule applies a load step. Km is both the torque
constant (N m/A) and the back-emf constant (V s/rad), equal in SI units. At rest under a
constant u the speed settles at ``omega = (Km u - Ra load) / (Km^2 + Ra friction)``.

Between samples u is held and the engine advances the state with its integrator (the one
RK4 of :mod:`mfcontrol.numerics.rk4` by default) on :func:`rhs`.
"""

from .._jit import step_jit
from ..numerics import signatures as sig

# parameter rows
J = 0
FRICTION = 1
KM = 2
RA = 3
LA = 4
LOAD = 5
N_PARAMS = 6
#: physical parameters a schedule may change, by name
PARAM_ROWS = {"J": J, "friction": FRICTION, "Km": KM, "Ra": RA, "La": LA, "load": LOAD}

# state rows
OMEGA = 0
I_A = 1
N_STATE = 2
STATE_NAMES = ("omega", "i_a")


@step_jit
def field(inertia, friction, km, ra, la, load, omega, i, u):
    """(domega/dt, di/dt) from plain floats: the one place the model is written."""
    return (km * i - friction * omega - load) / inertia, (u - ra * i - km * omega) / la


@step_jit
def speed_at_rest(friction, km, ra, load, u):
    """The steady speed under a constant voltage u (the model's equilibrium)."""
    return (km * u - ra * load) / (km * km + ra * friction)


# the plant as the general engine takes it (mfcontrol.numerics.signatures): p is a column
# of the rows above


@sig.compiled(sig.RHS)
def rhs(t, x, u, p, dxdt, nx, np_):
    dxdt[OMEGA], dxdt[I_A] = field(p[J], p[FRICTION], p[KM], p[RA], p[LA], p[LOAD], x[OMEGA],
                                   x[I_A], u)


@sig.compiled(sig.OUTPUT)
def measured(x, p, nx, np_):
    return x[OMEGA]
