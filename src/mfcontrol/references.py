"""Reference trajectories y*(t), evaluated in compiled code at each sample time.

ramp-hold-ramp (the paper's references)::

    r(t) = slope * t   if slope * t <= level   else level       (t < t_ramp2)
    r(t) = level + slope2 * (t - t_ramp2)                        (t >= t_ramp2)
"""

from ._jit import step_jit

RAMP_HOLD_RAMP = 0
KINDS = {"ramp-hold-ramp": RAMP_HOLD_RAMP}

# parameter rows
KIND = 0
SLOPE = 1
LEVEL = 2
T_RAMP2 = 3  # +inf: no second ramp
SLOPE2 = 4
N_PARAMS = 5


@step_jit
def value(RP, j, t):
    slope_t = RP[SLOPE, j] * t
    r = slope_t if slope_t <= RP[LEVEL, j] else RP[LEVEL, j]
    if t >= RP[T_RAMP2, j]:
        r = RP[LEVEL, j] + RP[SLOPE2, j] * (t - RP[T_RAMP2, j])
    return r
