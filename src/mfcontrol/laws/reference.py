"""Reference trajectories y*(t), evaluated in compiled code at each sample time.

ramp-hold-ramp (the paper's references)::

    r(t) = slope * t   if slope * t <= level   else level       (t < t_ramp2)
    r(t) = level + slope2 * (t - t_ramp2)                        (t >= t_ramp2)

smooth-step (no corners, so no kicks from the reference derivatives a law feeds forward)::

    x = clip((t - t0) / duration, 0, 1),   r(t) = initial + (final - initial) (1 - cos(pi x)) / 2

with duration = 0 a plain step at t0.
"""

import math

from .._jit import step_jit

RAMP_HOLD_RAMP = 0
SMOOTH_STEP = 1
KINDS = {"ramp-hold-ramp": RAMP_HOLD_RAMP, "smooth-step": SMOOTH_STEP}

# parameter rows
KIND = 0
SLOPE = 1
LEVEL = 2
T_RAMP2 = 3  # +inf: no second ramp
SLOPE2 = 4
N_PARAMS = 5
# smooth-step rows (the same rows, read for that kind)
INITIAL = 1
FINAL = 2
T0 = 3
DURATION = 4


@step_jit
def parameters(RP, j):
    """Member j's reference: (kind, and its four parameters in row order)."""
    return RP[KIND, j], RP[1, j], RP[2, j], RP[3, j], RP[4, j]


@step_jit
def evaluate(kind, p1, p2, p3, p4, t):
    """r(t) from the parameters of :func:`parameters`: the one place the references are
    written (a loop that holds them in locals needs no reload at every sample)."""
    if kind == SMOOTH_STEP:
        initial, final, t0, duration = p1, p2, p3, p4
        x = (t - t0) / duration if duration > 0.0 else (1.0 if t >= t0 else 0.0)
        x = min(max(x, 0.0), 1.0)
        # the cosine at either end of the ramp is known, cos(0) = 1 and cos(pi) = -1 in
        # double (pi rounded is 1.2e-16 from pi, where the cosine is -1 within 1e-32): a
        # plain step and most samples of a smooth one need no call to cos (a test checks
        # the bits)
        c = 1.0 if x == 0.0 else (-1.0 if x == 1.0 else math.cos(math.pi * x))
        return initial + (final - initial) * (1.0 - c) / 2.0
    slope, level, t_ramp2, slope2 = p1, p2, p3, p4
    slope_t = slope * t
    r = slope_t if slope_t <= level else level
    if t >= t_ramp2:
        r = level + slope2 * (t - t_ramp2)
    return r


@step_jit
def value(RP, j, t):
    """r(t) of member j."""
    kind, p1, p2, p3, p4 = parameters(RP, j)
    return evaluate(kind, p1, p2, p3, p4, t)
