"""First-order plant with a constant disturbance, state x = (y,)::

    dy/dt = a y + b u + w

Output: ``y``. ``w`` is a parameter, so a schedule can switch the disturbance on or off.

With the input u held over [t, t + h] the engine integrates :func:`rhs` (the one RK4 of
:mod:`mfcontrol.numerics.rk4` by default), or, with ``integrator = "exact"``, steps by the
closed form :func:`advance`, ``y(t + h) = e^{a h} y + (e^{a h} - 1) / a (b u + w)``
(``y + h (b u + w)`` for a = 0), the reference the RK4 step is measured against.
"""

import math

from .._jit import step_jit
from ..numerics import signatures as sig

# parameter rows
A = 0
B = 1
W = 2
N_PARAMS = 3
#: physical parameters a schedule may change, by name
PARAM_ROWS = {"a": A, "b": B, "w": W}

# state rows
Y = 0
N_STATE = 1
STATE_NAMES = ("y",)


@step_jit
def exact(a, g, y, h):
    """y(t + h) from y(t) under y' = a y + g: the one place the closed form is written."""
    ah = a * h
    # expm1 keeps (e^{ah} - 1)/a accurate when |a h| is small, where e^{ah} - 1 cancels;
    # testing a h (not a) also covers an a so small that a h underflows to 0
    em1 = math.expm1(ah)
    phi = em1 / a if ah != 0.0 else h
    return y + (em1 * y + phi * g)


# the plant as the general engine takes it (mfcontrol.numerics.signatures): p is a column
# of the rows above


@sig.compiled(sig.RHS)
def rhs(t, x, u, p, dxdt, nx, np_):
    dxdt[Y] = p[A] * x[Y] + (p[B] * u + p[W])


@sig.compiled(sig.OUTPUT)
def measured(x, p, nx, np_):
    return x[Y]


@sig.compiled(sig.ADVANCE)
def advance(t, x, u, p, h, nx, np_):
    x[Y] = exact(p[A], p[B] * u + p[W], x[Y], h)
