"""The actuator between the controller and the plant: a delay, then a rate limit.

Sample k: ``w_k = u_{k-d}`` (0 while k < d: nothing has been commanded yet), then
``u_act[k] = u_act[k-1] + clip(w_k - u_act[k-1], -rate h, rate h)`` with ``u_act[-1] = 0``
(no limit for rate 0). An input disturbance adds to ``u_act`` after it
(:mod:`.disturbance`): the plant receives ``u_plant = u_act + d_in``.
"""

from .._jit import step_jit

# parameter rows
DELAY = 0  # whole samples
RATE = 1  # units of u per second; 0: none
N_PARAMS = 2


@step_jit
def rate_limited(w, prev, rate, h):
    """w moved at most ``rate h`` away from the actuator's previous output."""
    if rate > 0.0:
        step = rate * h
        return min(max(w, prev - step), prev + step)
    return w
