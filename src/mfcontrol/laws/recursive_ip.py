"""The paper's recursive i-P law (eq. 8) and its variational form (eq. 33).

For k >= 1, with ``e_dot_k = (y_k - y_{k-1})/hd - (r_k - r_{k-1})/hd``::

    u_k = (u_{k-1} - g_k * e_dot_k) + s * (Kp * (r_k - y_p))  [+ c * ((gamma_k - gamma_{k-1}) / hd)]

* ``g_k`` is gamma_k (``gain = gamma``) or 1/alpha (``gain = alpha``, eq. 33 literally);
  gamma_k comes from :mod:`mfcontrol.laws.gain`.
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

from .._jit import step_jit
from . import gain

# parameter rows (after the gain adaptation rows)
KP = gain.N_PARAMS + 0
HD = gain.N_PARAMS + 1
U0 = gain.N_PARAMS + 2
P_SIGN = gain.N_PARAMS + 3
P_CURRENT = gain.N_PARAMS + 4
RATE_COEF = gain.N_PARAMS + 5
USE_GAMMA = gain.N_PARAMS + 6
OUT_GAIN = gain.N_PARAMS + 7
OUT_MIN = gain.N_PARAMS + 8
OUT_MAX = gain.N_PARAMS + 9
AW_COEF = gain.N_PARAMS + 10  # 0 published (winds up), 1 clamp, k_aw h back-calculation
N_PARAMS = gain.N_PARAMS + 11

# state rows (after the gain adaptation rows)
U_PREV = gain.N_STATE + 0
Y_PREV = gain.N_STATE + 1
R_PREV = gain.N_STATE + 2
K = gain.N_STATE + 3
N_STATE = gain.N_STATE + 4


@step_jit
def reset(CP, CS, j):
    gain.reset(CP, CS, j)
    CS[U_PREV, j] = 0.0
    CS[Y_PREV, j] = 0.0
    CS[R_PREV, j] = 0.0
    CS[K, j] = 0.0


@step_jit
def clip(x, lo, hi):
    # comparisons in the published order: an upper hit wins, NaN passes through
    return hi if x > hi else (lo if x < lo else x)


@step_jit
def step(CP, CS, j, y, r):
    """One sample: measurement y_k and reference r_k in, (u_k, applied, g_k, gamma_k) out."""
    k = CS[K, j]
    if k == 0.0:
        u = CP[U0, j]
        g = gain.initial(CP, j)
        gamma = g
    else:
        hd = CP[HD, j]
        y_prev = CS[Y_PREV, j]
        e_dot = (y - y_prev) / hd - (r - CS[R_PREV, j]) / hd
        gamma, gamma_prev = gain.update(CP, CS, j, k, e_dot)
        g = gamma if CP[USE_GAMMA, j] != 0.0 else CP[gain.INV_ALPHA, j]
        y_p = y if CP[P_CURRENT, j] != 0.0 else y_prev
        u = (CS[U_PREV, j] - g * e_dot) + CP[P_SIGN, j] * (CP[KP, j] * (r - y_p))
        c = CP[RATE_COEF, j]
        if c != 0.0:
            u = u + c * ((gamma - gamma_prev) / hd)
    applied = clip(CP[OUT_GAIN, j] * u, CP[OUT_MIN, j], CP[OUT_MAX, j])
    c = CP[AW_COEF, j]
    CS[U_PREV, j] = u if c == 0.0 else u + c * (applied / CP[OUT_GAIN, j] - u)
    CS[Y_PREV, j] = y
    CS[R_PREV, j] = r
    CS[K, j] = k + 1.0
    return u, applied, g, gamma
