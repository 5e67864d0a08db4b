"""Adaptive Dormand-Prince 5(4) over one sample, the input held: the library's one RK45.

The method, error norm and step-size rule are those of ``scipy.integrate.solve_ivp``'s
``RK45`` (Dormand & Prince 1980; Hairer, Norsett & Wanner, *Solving ODEs I*, II.4 and
II.5): the fifth-order solution is kept, the embedded fourth-order one estimates the
error, ``scale = atol + max(|x|, |x_new|) rtol``, a step is accepted when the RMS of
``err / scale`` is at most 1, and the next step is the present one times
``0.9 norm^(-1/5)``, kept in [0.2, 10] (at most 1 right after a rejection). The step a
sample ends on carries over to the next sample, as a continuous run would carry it.
"""

import math

from .._jit import step_jit
from .signatures import pointer

C2, C3, C4, C5 = 1 / 5, 3 / 10, 4 / 5, 8 / 9
A21 = 1 / 5
A31, A32 = 3 / 40, 9 / 40
A41, A42, A43 = 44 / 45, -56 / 15, 32 / 9
A51, A52, A53, A54 = 19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729
A61, A62, A63, A64, A65 = 9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656
B1, B3, B4, B5, B6 = 35 / 384, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84
E1, E3, E4, E5, E6, E7 = (-71 / 57600, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525,
                          1 / 40)
SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
#: steps tried over one sample before the integrator gives up: a step this much shorter
#: than the sample means a plant too stiff for an explicit method (each sample would cost
#: seconds, and a compiled run cannot be interrupted until it returns)
MAX_STEPS = 100_000
#: scratch rows :func:`integrate` needs, times the state size
N_WORK = 9


@step_jit
def integrate(rhs, t, x, u, p, h, rtol, atol, dt, w):
    """Advance ``x`` in place from t to t + h with u held; return the step size to start
    the next sample with. ``dt`` is the step to try first (<= 0: h). ``w``: scratch of
    shape (:data:`N_WORK`, n). A step that cannot be made (the state is no longer finite)
    leaves x NaN, which the engine flags as divergence; so does a step size that
    collapses (underflows, or more than :data:`MAX_STEPS` steps in the sample), and the
    step size returned is then minus the last one tried.
    """
    n = x.size
    m = p.size
    k1, k2, k3, k4, k5, k6, k7, xt, xn = w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7], w[8]
    xp, pp, tp, np_ = pointer(x), pointer(p), pointer(xt), pointer(xn)
    q1, q2, q3, q4, q5, q6, q7 = (pointer(k1), pointer(k2), pointer(k3), pointer(k4),
                                  pointer(k5), pointer(k6), pointer(k7))
    t_end = t + h
    dt = h if not (dt > 0.0) else min(dt, h)
    rhs(t, xp, u, pp, q1, n, m)
    rejected = False
    steps = 0
    while t < t_end:
        tried = dt
        steps += 1
        last = t + dt >= t_end
        if last:
            dt = t_end - t
        # the floor applies to the step the rule asks for; the last one, clipped to the
        # sample's end, may be as short as it needs (scipy checks before clipping too)
        if not (tried > 1e-14 * max(abs(t), h)) or not math.isfinite(tried) \
                or steps > MAX_STEPS:
            for i in range(n):
                x[i] = math.nan
            return -abs(tried)
        for i in range(n):
            xt[i] = x[i] + dt * (A21 * k1[i])
        rhs(t + C2 * dt, tp, u, pp, q2, n, m)
        for i in range(n):
            xt[i] = x[i] + dt * (A31 * k1[i] + A32 * k2[i])
        rhs(t + C3 * dt, tp, u, pp, q3, n, m)
        for i in range(n):
            xt[i] = x[i] + dt * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i])
        rhs(t + C4 * dt, tp, u, pp, q4, n, m)
        for i in range(n):
            xt[i] = x[i] + dt * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i])
        rhs(t + C5 * dt, tp, u, pp, q5, n, m)
        for i in range(n):
            xt[i] = x[i] + dt * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i]
                                 + A65 * k5[i])
        rhs(t + dt, tp, u, pp, q6, n, m)
        for i in range(n):
            xn[i] = x[i] + dt * (B1 * k1[i] + B3 * k3[i] + B4 * k4[i] + B5 * k5[i]
                                 + B6 * k6[i])
        rhs(t + dt, np_, u, pp, q7, n, m)
        acc = 0.0
        for i in range(n):
            err = dt * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i]
                        + E7 * k7[i])
            scale = atol + max(abs(x[i]), abs(xn[i])) * rtol
            acc += (err / scale) ** 2
        norm = math.sqrt(acc / n)
        if not math.isfinite(norm):
            for i in range(n):
                x[i] = math.nan
            return dt
        if norm <= 1.0:
            factor = MAX_FACTOR if norm == 0.0 else min(MAX_FACTOR, SAFETY * norm ** -0.2)
            if rejected:
                factor = min(1.0, factor)
            t = t_end if last else t + dt
            for i in range(n):
                x[i] = xn[i]
                k1[i] = k7[i]  # first same as last
            # a sample that ends on a step clipped to it carries the step it tried, unless
            # the error asks for a smaller one
            dt = dt * factor if (factor < 1.0 or not last) else max(tried, dt * factor)
            rejected = False
        else:
            dt = dt * max(MIN_FACTOR, SAFETY * norm ** -0.2)
            rejected = True
    return dt
