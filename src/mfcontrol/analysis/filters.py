"""Every law as the linear filter it is between its limits: ``A(q) u = B_y(q) y + B_r(q) r``.

Without saturation, with a given gain, every law of :mod:`mfcontrol.laws` is a linear
time-invariant difference equation in the measurement y, the setpoint r and its own
output u. Written in the delay operator q = z^-1 (``q y_k = y_{k-1}``), with
``D = 1 - q`` the backward difference and h the sample period:

Intelligent law (:mod:`mfcontrol.laws.intelligent`), ``e = y - r``, gain gamma::

    u = -gamma (F_hat - r^(n) + kp e + ki h e / D + kd D e / h),   y^(n) = (D / h)^n y
    with a compensated delay of d samples, F_hat's u terms are q^d times these, and
    with its prediction e = y - r + h (d F_hat + S u / gamma), S = q + ... + q^d
    F_hat = (D / h)^n y - (q / gamma) u         backward difference (n = 1; n = 2, trapezoid)
    F_hat = (D / h)^2 y - (q + q^2) u / (2 gamma)   backward difference (n = 2, held)
    F_hat = W_y(q) y + W_u(q) u                 algebraic estimator, window M

with the algebraic estimator's FIR weights (:func:`mfcontrol.laws.estimators.weights`,
exact arithmetic: the law slides moments that sum to the same thing, up to rounding).
Multiplied by D when there is an integral term (ki != 0), to clear its denominator.

PID (:mod:`mfcontrol.laws.pid`), ``a_d = Td / (Td + N h)``, ``b_d = kp Td N / (Td + N h)``,
y_f = y / F(q) the filtered measurement (F = 1 without the filter, else the filter's
denominator at s = (1 - q) / h: ``1 + Tf s + Tf^2 s^2 / 2``)::

    u = kp (b r - y_f) + ki h q (r - y_f) / D + b_d D (c r - y_f) / (1 - a_d q)

(the integral is updated after the output, with the sample's error: it reaches u one
sample later).

ADRC (:mod:`mfcontrol.laws.adrc`), the observer's prediction z, its correction
``x = (I - L C) z + L y``, the law ``u = k_r r - K x`` (``k_r = kp / b0``, ``K = (kp, kd,
1) / b0``; ``(kp, 1) / b0`` for n = 1) and the prediction ``z = q (Ad x + Bd q^d u)``
give, with ``Phi = Ad (I - L C)`` and ``Delta(q) = det(I - q Phi) = (1 - beta q)^(n+1)``
(every eigenvalue at beta = exp(-wo h))::

    (Delta + q^(d+1) N_u) u = -(q N_y + K L Delta) y + k_r Delta r

where ``N_v(q) = Delta(q) K (I - L C) (I - q Phi)^-1 v`` for v = Bd (N_u) and v = Ad L
(N_y), polynomials of degree n (the series ``sum_i q^i K (I - L C) Phi^i v`` times Delta,
cut at degree n: exact by Cayley-Hamilton).

The paper's recursive i-P (:mod:`mfcontrol.laws.recursive_ip`), derivative scale hd,
output gain G, ``s`` the sign of its proportional term and ``y_p`` = q y (published) or
y (as printed)::

    D u_raw = -(g / hd) D (y - r) + s kp (r - y_p),     u = G u_raw (the applied output)

What the filter leaves out, by construction: the output limits and the anti-windup they
trigger, the start-up (the output held for the first n samples, or the algebraic estimator's
first M; or the backward difference standing in until its window is full), the variational gain's
motion (the filter holds gamma at a value you give), and rounding. Past the start-up and
within the limits the law's outputs satisfy the filter's equation to rounding
(``tests/analysis/test_filters.py`` holds every law family to it on simulated runs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..laws import adrc, estimators, intelligent, pid, recursive_ip
from ..laws import variational_gain as gain_law


@dataclass(frozen=True)
class LinearFilter:
    """``A(q) u = B_y(q) y + B_r(q) r``: a law's linear equivalent, its three polynomials
    in the delay q = z^-1. Built by a live controller's ``linear_filter()``.

    Parameters
    ----------
    a, b_y, b_r : numpy.ndarray
        The polynomials' coefficients, that of q^i at index i; ``a[0] = 1``.
    dt : float
        The sample period (s).

    Examples
    --------
    A PI (kp 2, ki 1, h 0.1): ``u_k - u_{k-1} = -2 y_k + 1.9 y_{k-1} + 2 r_k - 1.9 r_{k-1}``.

    >>> import mfcontrol
    >>> f = mfcontrol.PID(kp=2.0, ki=1.0, sample_time=0.1).linear_filter()
    >>> f.a.tolist(), f.b_y.tolist(), f.order
    ([1.0, -1.0], [-2.0, 1.9], 1)
    >>> c_y, c_r = f.transfer_functions()   # python-control, dt = 0.1
    """

    a: np.ndarray
    b_y: np.ndarray
    b_r: np.ndarray
    dt: float

    @property
    def order(self) -> int:
        """The highest delay the equation reaches: how many past samples it reads."""
        return max(self.a.size, self.b_y.size, self.b_r.size) - 1

    def transfer_functions(self):
        """(C_y, C_r): ``u = C_y(z) y + C_r(z) r`` as python-control discrete
        ``TransferFunction`` objects with sample time ``dt``. The feedback path is C_y:
        the loop gain with a plant P is ``L = -C_y P``."""
        import control

        n = self.order + 1
        den = _padded(self.a, n)
        return (control.tf(_padded(self.b_y, n), den, self.dt),
                control.tf(_padded(self.b_r, n), den, self.dt))

    def residual(self, u: np.ndarray, y: np.ndarray, r: np.ndarray) -> np.ndarray:
        """``A u - B_y y - B_r r`` at every sample from :attr:`order` on (earlier samples
        would reach before the record): zero, to rounding, where the law ran linearly."""
        k0 = self.order
        out = np.zeros(u.size - k0)
        for coef, x, sign in ((self.a, u, 1.0), (self.b_y, y, -1.0), (self.b_r, r, -1.0)):
            for i, c in enumerate(coef):
                out += sign * c * x[k0 - i:x.size - i]
        return out


def _padded(c: np.ndarray, n: int) -> np.ndarray:
    return np.concatenate([c, np.zeros(n - c.size)])


def _trimmed(c: np.ndarray) -> np.ndarray:
    """``c`` without trailing zero coefficients (one zero left of a zero polynomial)."""
    nonzero = np.flatnonzero(c)
    return c[:nonzero[-1] + 1].astype(float) if nonzero.size else np.zeros(1)


# numpy.polynomial's functions check and convert their arguments at every call: a
# stability region builds tens of thousands of filters, so the two operations it needs
# are written here on plain float arrays
_mul = np.convolve


def _add(a: np.ndarray | list[float], b: np.ndarray | list[float]) -> np.ndarray:
    """The sum of two polynomials (ascending coefficients) of any lengths."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.size < b.size:
        a, b = b, a
    out = a.copy()
    out[:b.size] += b
    return out


def _normalised(a: np.ndarray, b_y: np.ndarray, b_r: np.ndarray, dt: float) -> LinearFilter:
    a0 = a[0]
    return LinearFilter(_trimmed(a / a0), _trimmed(b_y / a0), _trimmed(b_r / a0), dt)


def _difference(n: int, dt: float) -> np.ndarray:
    """(D / h)^n as a polynomial in q."""
    out = np.ones(1)
    for _ in range(n):
        out = _mul(out, np.array([1.0, -1.0]) / dt)
    return out


def intelligent_filter(CP: np.ndarray, dt: float, gamma: float | None = None) -> LinearFilter:
    """The intelligent law of parameter column ``CP`` (:mod:`mfcontrol.laws.intelligent`'s
    rows) at sample period ``dt``, as a :class:`LinearFilter`.

    ``gamma``: the gain the filter holds. Default 1/alpha for a constant gain; required
    for the variational, external and rls gains, whose gamma moves (the filter is then
    the law frozen at that gamma)."""
    mode = CP[gain_law.MODE]
    if gamma is None:
        if mode != gain_law.CONSTANT:
            kind = {gain_law.VARIATIONAL: "variational", gain_law.RLS: "rls"}.get(
                mode, "external")
            raise ValueError(f"gamma = None: a {kind} gain moves; give the gamma (1/alpha) "
                             "at which to analyse the law")
        gamma = CP[gain_law.INV_ALPHA]
    if not (math.isfinite(gamma) and gamma > 0):
        raise ValueError(f"gamma = {gamma!r}: must be a finite number > 0")
    n = int(CP[intelligent.N_ORDER])
    kp, ki, kd = CP[intelligent.KP], CP[intelligent.KI], CP[intelligent.KD]
    dn = _difference(n, dt)
    delta = np.array([1.0, -1.0])
    if CP[intelligent.EST] == intelligent.ALGEBRAIC:
        m = int(CP[intelligent.M_WIN])
        kernel = estimators.kernel_name(CP[intelligent.KERNEL])
        jacobi: dict = {}
        if kernel == "delay-reduced":
            jacobi = {"lag": float(CP[intelligent.LAG]), "kappa": int(CP[intelligent.KAPPA]),
                      "mu": int(CP[intelligent.MU])}
        wy, wu = estimators.weights(n, m, dt, 1.0 / gamma, kernel, **jacobi)
        # oldest first: y_{k-M} .. y_k and u_{k-M} .. u_{k-1}; q^i is i samples back
        f_y = wy[::-1]
        f_u = np.concatenate([[0.0], wu[::-1]])
    else:
        f_y = dn
        if n == 2 and CP[intelligent.KERNEL] == estimators.HELD:
            f_u = np.array([0.0, -0.5 / gamma, -0.5 / gamma])  # (u_{k-1} + u_{k-2}) / 2
        else:
            f_u = np.array([0.0, -1.0 / gamma])
    d = int(CP[intelligent.DELAY])
    if d > 0:  # the estimator pairs y with the input the plant received, d samples older
        f_u = np.concatenate([np.zeros(d), f_u])
    # the error terms kp + kd D / h (+ ki h / D), cleared of the integral's D
    k_e = _add([kp], kd * delta / dt)
    if ki != 0.0:
        k_e = _add(_mul(k_e, delta), [ki * dt])
        clear = delta
    else:
        clear = np.array([1.0])
    a = _mul(clear, _add([1.0], gamma * f_u))
    p_y = np.array([1.0])
    if d > 0 and CP[intelligent.PREDICT] != 0.0:
        # e = p_y y + p_u u - r: y predicted over the delay by the model
        p_y = _add([1.0], dt * d * f_y)
        in_flight = np.concatenate([[0.0], np.ones(d)]) / gamma
        p_u = dt * _add(d * f_u, in_flight)
        a = _add(a, gamma * _mul(k_e, p_u))
    b_y = -gamma * _add(_mul(clear, f_y), _mul(k_e, p_y))
    b_r = gamma * _add(_mul(clear, dn), k_e)
    return _normalised(a, b_y, b_r, dt)


def pid_filter(CP: np.ndarray, dt: float) -> LinearFilter:
    """The PID of parameter column ``CP`` (:mod:`mfcontrol.laws.pid`'s rows) at sample
    period ``dt``, as a :class:`LinearFilter`."""
    kp, ki, kd, n, b, c, tf = (CP[pid.KP], CP[pid.KI], CP[pid.KD], CP[pid.N], CP[pid.B],
                               CP[pid.C], CP[pid.TF])
    delta = np.array([1.0, -1.0])
    # each term over the common denominator D (1 - a_d q): D when there is an integral,
    # (1 - a_d q) when there is a derivative
    den_i = delta if ki != 0.0 else np.array([1.0])
    if kd != 0.0:
        td = kd / kp
        ad = td / (td + n * dt)
        bd = kp * td * n / (td + n * dt)
        den_d = np.array([1.0, -ad])
    else:
        bd = 0.0
        den_d = np.array([1.0])
    a = _mul(den_i, den_d)
    integral = _mul([0.0, ki * dt], den_d)  # ki h q / D, over the common denominator
    derivative = _mul(bd * delta, den_i)
    b_y = _add(-kp * a, -integral)
    b_y = _add(b_y, -derivative)
    b_r = _add(kp * b * a, integral)
    b_r = _add(b_r, c * derivative)
    if tf > 0.0:
        # u = (b_y y_f + b_r r) / a with y_f = y / F(q): a F u = b_y y + b_r F r
        e, g = tf / dt, tf * tf / (2.0 * dt * dt)
        f = np.array([1.0 + e + g, -e - 2.0 * g, g])
        a, b_r = _mul(a, f), _mul(b_r, f)
    return _normalised(a, b_y, b_r, dt)


def adrc_filter(CP: np.ndarray, dt: float) -> LinearFilter:
    """The ADRC of parameter column ``CP`` (:mod:`mfcontrol.laws.adrc`'s rows) at sample
    period ``dt``, as a :class:`LinearFilter`."""
    order, b0, wc, wo = CP[adrc.ORDER], CP[adrc.B0], CP[adrc.WC], CP[adrc.WO]
    n = int(order)
    m = n + 1
    d = int(CP[adrc.DELAY])
    kp, kd = adrc.gains(order, wc)
    L = np.array(adrc.observer_gains(order, wo, dt)[:m])
    # the zero-order hold of the chain of integrators (the law's prediction)
    Ad = np.eye(m)
    for i in range(1, m):
        Ad += np.diag(np.full(m - i, dt ** i / math.factorial(i)), i)
    Bd = np.array([dt ** (n - i) / math.factorial(n - i) * b0 if i < n else 0.0
                   for i in range(m)])
    K = (np.array([kp, 1.0]) if n == 1 else np.array([kp, kd, 1.0])) / b0
    corr = np.eye(m)
    corr[:, 0] -= L  # I - L C
    phi = Ad @ corr
    beta = math.exp(-wo * dt)
    delta = np.ones(1)
    for _ in range(m):
        delta = _mul(delta, [1.0, -beta])
    row = K @ corr

    def numerator(v: np.ndarray) -> np.ndarray:
        series, w = [], v
        for _ in range(m):
            series.append(row @ w)
            w = phi @ w
        return _mul(delta, series)[:m]

    n_u, n_y = numerator(Bd), numerator(Ad @ L)
    a = _add(delta, np.concatenate([np.zeros(d + 1), n_u]))
    b_y = -_add(np.concatenate([[0.0], n_y]), (K @ L) * delta)
    b_r = kp / b0 * delta
    return _normalised(a, b_y, b_r, dt)


def recursive_filter(CP: np.ndarray, dt: float, gamma: float | None = None) -> LinearFilter:
    """The paper's recursive i-P of parameter column ``CP`` (:mod:`mfcontrol.laws.
    recursive_ip`'s rows), its applied output ``G u`` at sample period ``dt``, as a
    :class:`LinearFilter`.

    ``gamma``: the gain to hold, required when the variational law's gamma is the gain
    (``gain = "gamma"``); the standard law's gain is 1/alpha. With gamma held, the
    variational form's rate term (K_gamma dgamma/dt) is zero."""
    g = CP[gain_law.INV_ALPHA]
    if CP[gain_law.MODE] != gain_law.CONSTANT and CP[recursive_ip.USE_GAMMA] != 0.0:
        if gamma is None:
            raise ValueError("gamma = None: the variational law's gain moves; give the "
                             "gamma at which to analyse the law")
        g = gamma
    if not (math.isfinite(g) and g > 0):
        raise ValueError(f"gamma = {g!r}: must be a finite number > 0")
    hd, kp, sign, out = (CP[recursive_ip.HD], CP[recursive_ip.KP], CP[recursive_ip.P_SIGN],
                         CP[recursive_ip.OUT_GAIN])
    delta = np.array([1.0, -1.0])
    # the proportional term reads y_{k-1} (published) or y_k (as printed)
    y_p = np.array([1.0]) if CP[recursive_ip.P_CURRENT] != 0.0 else np.array([0.0, 1.0])
    b_y = out * _add(-g / hd * delta, -sign * kp * y_p)
    b_r = out * _add(g / hd * delta, [sign * kp])
    return _normalised(delta, b_y, b_r, dt)
