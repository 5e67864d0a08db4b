"""Reference trajectories y*(t), evaluated in compiled code at each sample time.

ramp-hold-ramp (the paper's references)::

    r(t) = slope * t   if slope * t <= level   else level       (t < t_ramp2)
    r(t) = level + slope2 * (t - t_ramp2)                        (t >= t_ramp2)

smooth-step (no corners, so no kicks from the reference derivatives a law feeds forward)::

    x = clip((t - t0) / duration, 0, 1),   r(t) = initial + (final - initial) (1 - cos(pi x)) / 2

with duration = 0 a plain step at t0.
"""

import math

from ._jit import step_jit

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
def value(RP, j, t):
    if RP[KIND, j] == SMOOTH_STEP:
        d = RP[DURATION, j]
        x = (t - RP[T0, j]) / d if d > 0.0 else (1.0 if t >= RP[T0, j] else 0.0)
        x = min(max(x, 0.0), 1.0)
        a = RP[INITIAL, j]
        return a + (RP[FINAL, j] - a) * (1.0 - math.cos(math.pi * x)) / 2.0
    slope_t = RP[SLOPE, j] * t
    r = slope_t if slope_t <= RP[LEVEL, j] else RP[LEVEL, j]
    if t >= RP[T_RAMP2, j]:
        r = RP[LEVEL, j] + RP[SLOPE2, j] * (t - RP[T_RAMP2, j])
    return r
