"""The classical fourth-order Runge-Kutta step, the library's one RK4.

In increment form, ``x + (f1 + 2 (f2 + f3) + f4) / 6`` with ``f = h * dx/dt``: the
published code's arithmetic, operation for operation, so that a plant integrated here
reproduces the published trajectories bit for bit.

The scheme's arithmetic is written once, in :func:`half`, :func:`whole` and
:func:`combine`, on floats or arrays alike. :func:`step` applies it to a compiled plant
(the engine); the paper's buck kernel (:func:`mfcontrol.plants.buck.rk4`, its state in
registers) and a plant written in Python (:meth:`mfcontrol.api.model.plants.Plant.step`) call
the same three functions.
"""

import numpy as np
from numba import njit

from .._jit import step_jit
from .signatures import as_rhs, pointer


@step_jit
def half(x, f):
    """The trial state of the second and third stages: x + f / 2."""
    return x + f / 2


@step_jit
def whole(x, f):
    """The trial state of the fourth stage: x + f."""
    return x + f


@step_jit
def combine(x, f1, f2, f3, f4):
    """The step's result from the four stage increments f = h dx/dt."""
    return x + (f1 + 2 * (f2 + f3) + f4) / 6


@step_jit
def step(rhs, t, x, u, p, h, w):
    """Advance ``x`` in place by one RK4 step of size h with u held; ``rhs`` in the
    pointer form of :mod:`mfcontrol.numerics.signatures`, ``x``, ``p`` float64 arrays.

    ``w`` is scratch of shape (5, n): the stage increments and the trial state.
    """
    n = x.size
    m = p.size
    f1, f2, f3, f4, xt = w[0], w[1], w[2], w[3], w[4]
    xp, pp = pointer(x), pointer(p)
    p1, p2, p3, p4, pt = pointer(f1), pointer(f2), pointer(f3), pointer(f4), pointer(xt)
    rhs(t, xp, u, pp, p1, n, m)
    for i in range(n):
        f1[i] = h * f1[i]
        xt[i] = half(x[i], f1[i])
    rhs(t + h / 2, pt, u, pp, p2, n, m)
    for i in range(n):
        f2[i] = h * f2[i]
        xt[i] = half(x[i], f2[i])
    rhs(t + h / 2, pt, u, pp, p3, n, m)
    for i in range(n):
        f3[i] = h * f3[i]
        xt[i] = whole(x[i], f3[i])
    rhs(t + h, pt, u, pp, p4, n, m)
    for i in range(n):
        x[i] = combine(x[i], f1[i], f2[i], f3[i], h * f4[i])


@njit(error_model="numpy", cache=True)
def step_once(rhs, t, x, u, p, h):
    """One RK4 step of the compiled rhs at address ``rhs``, in place, from Python."""
    step(as_rhs(rhs), t, x, u, p, h, np.empty((5, x.size)))
