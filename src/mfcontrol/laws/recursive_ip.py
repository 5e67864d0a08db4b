"""The paper's recursive i-P law (eq. 8) and its variational form (eq. 33).

For k >= 1, with ``e_dot_k = (y_k - y_{k-1})/hd - (r_k - r_{k-1})/hd``::

    u_k = (u_{k-1} - g_k * e_dot_k) + s * (Kp * (r_k - y_p))  [+ c * ((gamma_k - gamma_{k-1}) / hd)]

* ``g_k`` is gamma_k (``gain = gamma``) or 1/alpha (``gain = alpha``, eq. 33 literally);
  gamma_k comes from :mod:`mfcontrol.laws.variational_gain`.
* ``y_p`` is y_{k-1} (published) or y_k (as printed); ``s`` is +1 for Kp (r - y)
  (published) or -1 for Kp (y - r) (as printed, positive feedback for Kp > 0).
* the bracketed rate term is the K_gamma dgamma/dt term of eq. (33), ``c = +K_gamma``
  as printed (``-K_gamma`` is the sign the published code writes, where it is always 0).

``u_0`` is a given constant (1 in the published code). The applied output is
``clip(output_gain * u_k, lo, hi)``. The published recursion carries the unclipped u_k
and so winds up while the output is limited; with anti-windup it carries
``u_k + c (u_sat - u_k)``, ``u_sat`` the applied output in u's units: c = 1 clamps the
recursion to the limit, 0 < c < 1 is back-calculation (c = k_aw h).
The operation order follows the published code so that results match it bit for bit.
"""

import math

from numba.np.unsafe.ndarray import to_fixed_tuple

from .._jit import step_jit
from . import variational_gain as vg

# The law's parameters: the gain adaptation's rows, then these. The row constants are the
# one declaration: the parameter tuple (:func:`parameters`), the engines' readers and the
# sweep kernel's specialisation (:mod:`mfcontrol.engine.paper_sweep`) all follow from
# them, so adding a parameter is a row here, a read in :func:`advance`, and the line of
# the translator (:func:`mfcontrol.api.params.recursive_law_column`) that fills it.
KP = vg.N_PARAMS + 0
HD = vg.N_PARAMS + 1
U0 = vg.N_PARAMS + 2
P_SIGN = vg.N_PARAMS + 3
P_CURRENT = vg.N_PARAMS + 4
RATE_COEF = vg.N_PARAMS + 5
USE_GAMMA = vg.N_PARAMS + 6
OUT_GAIN = vg.N_PARAMS + 7
OUT_MIN = vg.N_PARAMS + 8
OUT_MAX = vg.N_PARAMS + 9
AW_COEF = vg.N_PARAMS + 10  # 0 published (winds up), 1 clamp, k_aw h back-calculation
# the sample period h (s), the time step of the adaptation error's integral (the
# derivatives' divisor HD is the published scale, not the period)
H = vg.N_PARAMS + 11
N_PARAMS = vg.N_PARAMS + 12

# state rows (after the gain adaptation rows)
U_PREV = vg.N_STATE + 0  # u_{k-1}
Y_PREV = vg.N_STATE + 1  # y_{k-1}
R_PREV = vg.N_STATE + 2  # r_{k-1}
K = vg.N_STATE + 3  # samples taken
N_STATE = vg.N_STATE + 4

#: from this sample on :func:`advance` depends on k only through the state: a kernel may
#: pass STEADY for every k >= STEADY, which compiles out the start-up branches
STEADY = max(1.0, vg.STEADY)


def tunable(cp) -> tuple[tuple[str, int, str], ...]:
    """The rows a running controller may retune, (field, row, what), of a law with the
    parameter column ``cp`` (:mod:`mfcontrol.laws.tunable`): K_P, the limits and the
    gain's own (:func:`mfcontrol.laws.variational_gain.tunable`)."""
    return (("kp", KP, "proportional gain K_P"),
            ("out_min", OUT_MIN, "lower output limit (finite)"),
            ("out_max", OUT_MAX, "upper output limit (finite), >= out_min"),
            *vg.tunable(cp[vg.MODE]))


def invalid_row(CP, j):
    """The first row of :func:`tunable` whose value the law is not defined for, or -1."""
    if not math.isfinite(CP[KP, j]):
        return KP
    lo, hi = CP[OUT_MIN, j], CP[OUT_MAX, j]
    # finite, as its duty limits are (the output is a duty: its bounds are numbers)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        return OUT_MAX
    return vg.invalid_row(CP, j)


@step_jit
def reset(CP, CS, j):
    vg.reset(CP, CS, j)
    CS[U_PREV, j] = 0.0
    CS[Y_PREV, j] = 0.0
    CS[R_PREV, j] = 0.0
    CS[K, j] = 0.0


@step_jit
def clip(x, lo, hi):
    # comparisons in the published order: an upper hit wins, NaN passes through
    return hi if x > hi else (lo if x < lo else x)


@step_jit
def error_rate(y, y_prev, r, r_prev, hd):
    """e_dot_k, the error's backward difference over the derivative scale ``hd``, in the
    published code's floating-point order (floats, or arrays element-wise: the claims
    recompute the law's force from a recorded run with it)."""
    return (y - y_prev) / hd - (r - r_prev) / hd


@step_jit
def advance(k, y, r, u_prev, y_prev, r_prev, g1, g2, acc, cnt, adapt, P):
    """One sample from plain floats: the one place the law is written.

    ``P`` holds the member's parameters, rows 0 .. N_PARAMS-1 of its column in row order
    (:func:`parameters`); a tuple, so that a sweep kernel may put compile-time constants
    in it. Returns (u_k, applied_k, gain_k, gamma_k, u carried to the next sample, gamma
    for G1, gamma for G2, the multi-rate sum and count, the adaptation error: see
    :func:`mfcontrol.laws.variational_gain.next_gamma`). Sample 0 gives u_0 and the
    initial gamma.
    """
    mode, inv_alpha, gamma0 = P[vg.MODE], P[vg.INV_ALPHA], P[vg.GAMMA0]
    out_gain, lo, hi, aw_coef = P[OUT_GAIN], P[OUT_MIN], P[OUT_MAX], P[AW_COEF]
    if k == 0.0:  # the same sample for every member: a uniform, predictable branch
        g0 = gamma0 if mode == vg.VARIATIONAL else inv_alpha
        u0 = P[U0]
        applied = clip(out_gain * u0, lo, hi)
        carried = u0 if aw_coef == 0.0 else u0 + aw_coef * (applied / out_gain - u0)
        return u0, applied, g0, g0, carried, g1, g2, acc, cnt, adapt
    hd = P[HD]
    e_dot = error_rate(y, y_prev, r, r_prev, hd)
    # the recursive law has no external gain: alpha_ext is never read
    gamma, g1_next, g2_next, acc, cnt, adapt = vg.next_gamma(
        mode, k, e_dot, g1, g2, acc, cnt, adapt, inv_alpha, gamma0, P[vg.GAMMA_RATE],
        P[vg.EPS_M], P[vg.ORDER], P[vg.EVERY], 1.0, P[H])
    g = gamma if P[USE_GAMMA] != 0.0 else inv_alpha
    y_p = y if P[P_CURRENT] != 0.0 else y_prev
    u = (u_prev - g * e_dot) + P[P_SIGN] * (P[KP] * (r - y_p))
    rate_coef = P[RATE_COEF]
    if rate_coef != 0.0:
        u = u + rate_coef * ((gamma - g1) / hd)
    applied = clip(out_gain * u, lo, hi)
    carried = u if aw_coef == 0.0 else u + aw_coef * (applied / out_gain - u)
    return u, applied, g, gamma, carried, g1_next, g2_next, acc, cnt, adapt


@step_jit
def parameters(CP, j):
    """Member j's parameter tuple, as :func:`advance` takes it."""
    return to_fixed_tuple(CP[:, j], N_PARAMS)


@step_jit
def _step_at(CP, CS, j, y, r, k):
    """One sample, the law evaluated as at sample k, its state advanced by one sample."""
    u, applied, g, gamma, carried, g1, g2, acc, cnt, adapt = advance(
        k, y, r, CS[U_PREV, j], CS[Y_PREV, j], CS[R_PREV, j], CS[vg.G1, j], CS[vg.G2, j],
        CS[vg.ACC, j], CS[vg.CNT, j], CS[vg.ADAPT, j], parameters(CP, j))
    CS[U_PREV, j] = carried
    CS[Y_PREV, j] = y
    CS[R_PREV, j] = r
    CS[vg.G1, j] = g1
    CS[vg.G2, j] = g2
    CS[vg.ACC, j] = acc
    CS[vg.CNT, j] = cnt
    CS[vg.ADAPT, j] = adapt
    CS[K, j] = CS[K, j] + 1.0
    return u, applied, g, gamma


@step_jit
def step(CP, CS, j, y, r):
    """One sample: measurement y_k and reference r_k in, (u_k, applied, g_k, gamma_k) out."""
    return _step_at(CP, CS, j, y, r, CS[K, j])


@step_jit
def steady_step(CP, CS, j, y, r):
    """:func:`step` for a sample k >= :data:`STEADY`, with the start-up's branches
    compiled out (a loop over members vectorises)."""
    return _step_at(CP, CS, j, y, r, STEADY)
