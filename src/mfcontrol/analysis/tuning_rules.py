"""Rule-tuned reference PIDs: the gains the textbook rules give from a first-order-plus-dead-time
(FOPDT) model of the plant, with no search budget.

The model ``G(s) = K e^(-L s) / (T s + 1)`` comes from a recorded step response
(:func:`fit_fopdt`, least squares) or from a transfer function (:func:`fopdt_of`, Skogestad's
half rule; :func:`sopdt_of` keeps a second time constant for SIMC's PID). Two rules turn it
into gains in the parallel form of :class:`mfcontrol.PID`, ``u = kp (b r - y) + ki int e +
kd de/dt`` (``Ti = kp / ki``, ``Td = kd / kp``):

- :func:`simc`: Skogestad's SIMC rules (S. Skogestad, "Simple analytic rules for model
  reduction and PID controller tuning", J. Process Control 13 (2003) 291-309);
- :func:`amigo`: Astrom and Hagglund's AMIGO rules (K. J. Astrom, T. Hagglund, Advanced PID
  Control, ISA 2006, ch. 7; first in "Revisiting the Ziegler-Nichols step response method
  for PID control", J. Process Control 14 (2004) 635-650).

These are references, not tuned results: what a reader gets from the plant's model and a
formula, to set beside the gains a search finds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, NamedTuple

import numpy as np

from ..errors import ConfigError


def _finite(key: str, value: Any, allowed: str, *, low: float = -math.inf,
            low_open: bool = False, nonzero: bool = False) -> float:
    """``value`` as a float, refused (one line naming ``key``) unless finite and above
    ``low`` (strictly with ``low_open``) and, with ``nonzero``, not zero."""
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ConfigError(key, value, allowed) from None
    if not math.isfinite(x) or x < low or (low_open and x == low) or (nonzero and x == 0.0):
        raise ConfigError(key, value, allowed)
    return x


#: what each model field holds: (allowed, keyword arguments of _finite)
_FIELDS: dict[str, tuple[str, dict[str, Any]]] = {
    "K": ("must be a finite, non-zero gain", {"nonzero": True}),
    "T": ("must be a finite time constant > 0", {"low": 0.0, "low_open": True}),
    "T1": ("must be a finite time constant > 0", {"low": 0.0, "low_open": True}),
    "T2": ("must be a finite time constant >= 0", {"low": 0.0}),
    "L": ("must be a finite dead time >= 0", {"low": 0.0}),
}


def _check_fields(model: Any, *names: str) -> None:
    """Each named field of a frozen model as a checked float (written past the dataclass's
    own __setattr__, which a frozen one refuses)."""
    for name in names:
        allowed, kw = _FIELDS[name]
        object.__setattr__(model, name, _finite(name, getattr(model, name), allowed, **kw))


@dataclass(frozen=True)
class Fopdt:
    """A first-order-plus-dead-time model ``K e^(-L s) / (T s + 1)``.

    Parameters
    ----------
    K : float
        Static gain (output per unit input), finite and non-zero.
    T : float
        Time constant (s), > 0.
    L : float
        Dead time (s), >= 0.

    Examples
    --------
    >>> m = Fopdt(K=2.0, T=3.0, L=1.0)
    >>> m.tau
    0.25
    """

    K: float
    T: float
    L: float

    def __post_init__(self) -> None:
        _check_fields(self, "K", "T", "L")

    @property
    def tau(self) -> float:
        """The normalised dead time ``L / (L + T)``, in [0, 1): 0 lag-dominated, near 1
        delay-dominated (the AMIGO rules' parameter)."""
        return self.L / (self.L + self.T)


@dataclass(frozen=True)
class Sopdt:
    """A second-order-plus-dead-time model ``K e^(-L s) / ((T1 s + 1) (T2 s + 1))``,
    ``T1 >= T2 >= 0`` (the model SIMC's PID rule is written for).

    Parameters
    ----------
    K : float
        Static gain (output unit per input unit), nonzero.
    T1, T2 : float
        The two time constants (s), ``T1 >= T2 >= 0``.
    L : float
        Dead time (s), >= 0.

    Examples
    --------
    >>> Sopdt(K=1.0, T1=2.0, T2=1.2, L=0.77).T2
    1.2
    """

    K: float
    T1: float
    T2: float
    L: float

    def __post_init__(self) -> None:
        _check_fields(self, "K", "T1", "T2", "L")
        if self.T2 > self.T1:
            raise ConfigError("T2", self.T2, f"must be a finite time constant in [0, T1 = "
                              f"{self.T1}]")


class FopdtFit(NamedTuple):
    """What :func:`fit_fopdt` returns: the model and the root mean square of the fit's
    residual ``y - y_model`` (in the output's unit): large beside the response's size, the
    response is not a FOPDT's and the rules built on the model mean little."""

    model: Fopdt
    rms: float


class Gains(NamedTuple):
    """PID gains in :class:`mfcontrol.PID`'s parallel form, with the setpoint weight b:
    ``mfcontrol.PID(**gains._asdict(), sample_time=h)`` builds the controller."""

    kp: float
    ki: float
    kd: float
    b: float


def _step_model(t: np.ndarray, K: float, T: float, L: float, y0: float,
                u_step: float) -> np.ndarray:
    """The FOPDT's response to a step of ``u_step`` at t = 0 from rest at ``y0``."""
    s = np.clip(t - L, 0.0, None)
    return y0 + K * u_step * -np.expm1(-s / T)


#: fewest samples fit_fopdt takes: three parameters and enough samples beyond them that
#: the residual says something of the fit
MIN_SAMPLES = 10
#: the largest excursion past the final value (or before the start, against the step) that
#: still counts as essentially monotone, as a fraction of the final change: a FOPDT cannot
#: follow an overshoot or an inverse response, and AMIGO is for monotone responses
MONOTONE_SLACK = 0.1
#: the record must reach L + SETTLE_T * T: 3 T is 95 % of the rise (the gain is read off the end)
SETTLE_T = 3.0


def fit_fopdt(t: Any, y: Any, u_step: float, y0: float | None = None) -> FopdtFit:
    """Fit a FOPDT model to a step response recorded from rest.

    The plant rests at ``y0`` and its input is stepped by ``u_step`` at t = 0. K, T and L
    minimise the squared error over the whole record (``scipy.optimize.least_squares``,
    bounds T > 0, L >= 0), started from the two-point method: with ``t28`` and ``t63`` the
    first times the response passes 28.3 % and 63.2 % of its final change (those of a FOPDT
    are ``L + T / 3`` and ``L + T``), ``T = 1.5 (t63 - t28)``, ``L = t63 - T``, and K the
    final change (the mean of the last tenth of the record) over ``u_step``.

    Parameters
    ----------
    t : array_like
        Sample times (s), strictly increasing, at least 10 of them.
    y : array_like
        The output at those times.
    u_step : float
        The input's step (non-zero).
    y0 : float, optional
        The output at rest before the step; default ``y[0]`` (the record starts at rest).

    Returns
    -------
    FopdtFit
        The model and the residual's root mean square.

    Raises
    ------
    ValueError
        Data of the wrong shape or not finite, a response that is not essentially monotone
        (an overshoot or an inverse response over 10 % of the final change), no response,
        or a record that ends before ``L + 3 T`` of the fitted model (not settled: the gain
        and the time constant are then guesses).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 20.0, 401)
    >>> y = 2.0 * np.clip(1.0 - np.exp(-(t - 1.0) / 3.0), 0.0, None)  # K 2, T 3, L 1
    >>> fit = fit_fopdt(t, y, u_step=1.0)
    >>> [round(v, 6) for v in (fit.model.K, fit.model.T, fit.model.L)], fit.rms < 1e-9
    ([2.0, 3.0, 1.0], True)
    """
    from scipy.optimize import least_squares

    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.ndim != 1 or t.size < MIN_SAMPLES:
        raise ConfigError("t", f"an array of shape {t.shape}",
                          f"must be one-dimensional with at least {MIN_SAMPLES} samples")
    if y.shape != t.shape:
        raise ConfigError("y", f"an array of shape {y.shape}",
                          f"must have the shape of t, {t.shape}")
    if not (np.isfinite(t).all() and np.isfinite(y).all()):
        raise ConfigError("t, y", "arrays holding NaN or infinity", "must be finite")
    if not (np.diff(t) > 0).all():
        raise ConfigError("t", f"times from {t[0]} to {t[-1]}", "must be strictly increasing")
    u = _finite("u_step", u_step, "must be a finite, non-zero input step", nonzero=True)
    rest = float(y[0]) if y0 is None else _finite("y0", y0, "must be a finite output level")

    # the final change: the mean of the last tenth, which noise moves less than the last sample
    dy = y - rest
    final = float(dy[-max(t.size // 10, 1):].mean())
    spread = float(np.abs(dy).max())
    if spread == 0.0 or abs(final) < 1e-12 * max(abs(rest), 1.0):
        raise ConfigError("y", f"a response of final change {final:g}",
                          "must respond to the step (it stays at rest)")
    along = dy / final  # 0 at rest, 1 settled, whatever the sign of the step and the gain
    if along.max() > 1.0 + MONOTONE_SLACK or along.min() < -MONOTONE_SLACK:
        raise ConfigError("y", f"a response from {along.min():.3g} to {along.max():.3g} "
                          "of its final change", "must be essentially monotone (no overshoot "
                          f"or inverse response past {MONOTONE_SLACK:.0%}): a FOPDT cannot "
                          "follow it")

    # the two-point start: the first crossings, linearly interpolated between samples
    def crossing(level: float) -> float:
        i = int(np.argmax(along >= level))
        if i == 0:
            return float(t[0])
        a, b = along[i - 1], along[i]
        return float(t[i - 1] + (level - a) / (b - a) * (t[i] - t[i - 1]))

    t28, t63 = crossing(1.0 - math.exp(-1.0 / 3.0)), crossing(1.0 - math.exp(-1.0))
    span = float(t[-1] - t[0])
    T_start = max(1.5 * (t63 - t28), 1e-3 * span)
    L_start = max(t63 - T_start, 0.0)
    x0 = np.array([final / u, T_start, L_start])

    def residual(x: np.ndarray) -> np.ndarray:
        return _step_model(t, x[0], x[1], x[2], rest, u) - y

    # T's lower bound: positive and far below any time the record resolves
    T_min = 1e-9 * max(span, 1e-300)
    sol = least_squares(residual, x0, bounds=([-np.inf, T_min, 0.0], [np.inf, np.inf, np.inf]),
                        x_scale=np.array([abs(x0[0]), max(T_start, T_min), max(span, 1e-300)]),
                        xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=2000)
    K, T, L = (float(v) for v in sol.x)
    end = L + SETTLE_T * T
    if t[-1] < end:
        raise ConfigError("t", f"a record ending at {t[-1]:g} s",
                          f"must reach the response's settling, L + {SETTLE_T:g} T = {end:g} s "
                          f"of the fitted model (T {T:g}, L {L:g}): record the step for longer")
    rms = float(np.sqrt(np.mean(sol.fun ** 2)))
    return FopdtFit(Fopdt(K=K, T=T, L=L), rms)


#: roots within this fraction of their cluster's mean are one multiple root: np.roots splits
#: an m-fold root into a ring of radius about eps^(1/m) (1 % of the root for (s + 1)^8),
#: whose mean is accurate to rounding
CLUSTER = 0.05


def _real_roots(plant_tf: Any, roots: np.ndarray, what: str) -> np.ndarray:
    """The roots of a polynomial with real roots, each multiple root's ring of computed
    roots replaced by its mean; refused where a root is complex."""
    clusters: list[list[complex]] = []
    for z in sorted(roots, key=lambda z: (z.real, z.imag)):
        for c in clusters:
            centre = complex(np.mean(c))
            if abs(z - centre) <= CLUSTER * abs(centre):
                c.append(z)
                break
        else:
            clusters.append([z])
    out: list[float] = []
    for c in clusters:
        centre = complex(np.mean(c))
        if abs(centre.imag) > 1e-8 * abs(centre):
            raise ConfigError("plant_tf", plant_tf, f"must have real poles and zeros (a "
                              f"complex {what} {centre:.4g} is not a time constant)")
        out.extend([centre.real] * len(c))
    return np.array(out)


def _factors(plant_tf: Any) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """``(K, lags, inverse, leads)`` of a stable SISO transfer function with real poles and
    zeros: the static gain, the poles' time constants, the right-half-plane zeros' time
    constants (inverse response) and the left-half-plane zeros'."""
    num = den = None
    dt = getattr(plant_tf, "dt", None)
    if hasattr(plant_tf, "num") and hasattr(plant_tf, "den"):
        num, den = plant_tf.num, plant_tf.den
        # python-control keeps SISO polynomials as [[array]]: take the one entry
        while isinstance(num, (list, tuple)) or (isinstance(num, np.ndarray)
                                                 and num.dtype == object):
            if len(num) != 1:
                raise ConfigError("plant_tf", plant_tf, "must be single-input single-output")
            num, den = num[0], den[0]
    if num is None or den is None:
        raise ConfigError("plant_tf", plant_tf, "must be a python-control or scipy.signal "
                          "transfer function")
    if dt not in (None, 0, 0.0):
        raise ConfigError("plant_tf", plant_tf, "must be continuous-time (its dt is "
                          f"{dt}): the half rule is written for s-domain time constants")
    num = np.trim_zeros(np.atleast_1d(np.asarray(num, dtype=float)), "f")
    den = np.trim_zeros(np.atleast_1d(np.asarray(den, dtype=float)), "f")
    if num.size == 0 or den.size == 0 or num.size > den.size:
        raise ConfigError("plant_tf", plant_tf, "must be a proper, non-zero transfer function")
    poles = _real_roots(plant_tf, np.roots(den), "pole")
    zeros = _real_roots(plant_tf, np.roots(num), "zero")
    if (poles >= 0).any():
        raise ConfigError("plant_tf", plant_tf, "must be stable with no integrator (every "
                          "pole < 0): the half rule gives a FOPDT of a self-regulating plant")
    if (zeros == 0).any():
        raise ConfigError("plant_tf", plant_tf, "must have no zero at s = 0 (no static gain)")
    K = float(np.polyval(num, 0.0) / np.polyval(den, 0.0))
    return K, -1.0 / poles, 1.0 / zeros[zeros > 0], -1.0 / zeros[zeros < 0]


def _half_rule(plant_tf: Any, delay: float, order: int) -> tuple[float, list[float], float]:
    """``(K, [T1] or [T1, T2], L)`` by Skogestad's half rule (2003, section 2)."""
    L0 = _finite("delay", delay, "must be a finite dead time >= 0", low=0.0)
    K, lags, inverse, leads = _factors(plant_tf)
    taus = sorted(lags, reverse=True)
    # A left-half-plane zero T0 is cancelled against the closest larger lag tau0 by
    # Skogestad's rule T3, (T0 s + 1) / (tau0 s + 1) ~ 1 / ((tau0 - T0) s + 1), valid while
    # tau0 <= 5 L_eff (checked below, once the effective delay is known). The paper's other
    # branches (a zero above its lag, or a lag past 5 L_eff, which change the gain) are not
    # implemented: such a plant is refused rather than approximated differently.
    cancelled: list[float] = []
    for T0 in sorted(leads):
        larger = [x for x in taus if x >= T0]
        if not larger:
            raise ConfigError("plant_tf", plant_tf, f"must have a lag at least as slow as each "
                              f"left-half-plane zero (zero time constant {T0:g}): only "
                              "Skogestad's rule T3 (a zero cancelled by a slower lag) is "
                              "implemented")
        tau0 = min(larger)
        taus.remove(tau0)
        taus.append(tau0 - T0)
        cancelled.append(tau0)
    taus = sorted(taus, reverse=True) + [0.0] * (order + 1)
    kept = taus[:order]
    # the half rule: the largest neglected lag is split, half to the last kept lag and half
    # to the delay; every smaller lag and every inverse-response time constant is delay
    kept[-1] += taus[order] / 2.0
    L = L0 + taus[order] / 2.0 + sum(taus[order + 1:]) + float(np.sum(inverse))
    for tau0 in cancelled:
        if tau0 > 5.0 * L:
            raise ConfigError("plant_tf", plant_tf, f"must have its left-half-plane zeros "
                              f"cancelled by lags <= 5 L (lag {tau0:g} > 5 x {L:g}): only "
                              "that case of Skogestad's rule T3 is implemented")
    if kept[0] <= 0.0:
        raise ConfigError("plant_tf", plant_tf, "must have at least one pole (a pure gain has "
                          "no time constant)")
    return K, kept, L


def fopdt_of(plant_tf: Any, delay: float = 0.0) -> Fopdt:
    """The FOPDT model of a transfer function by Skogestad's half rule.

    For ``k e^(-delay s) prod(T0j s + 1) / prod(tau_i s + 1)`` with real poles, lags sorted
    ``tau_1 >= tau_2 >= ...`` (Skogestad 2003, eq. 9-10):

    - ``T = tau_1 + tau_2 / 2``;
    - ``L = delay + tau_2 / 2 + sum(tau_i, i >= 3) + sum(T0j of right-half-plane zeros)``
      (an inverse response counts as delay);
    - a left-half-plane zero ``T0`` is first cancelled against the closest lag
      ``tau0 >= T0`` by rule T3, ``(T0 s + 1) / (tau0 s + 1) ~ 1 / ((tau0 - T0) s + 1)``,
      which holds for ``tau0 <= 5 L``; plants outside that case are refused;
    - ``K`` is the static gain.

    Parameters
    ----------
    plant_tf : control.TransferFunction or scipy.signal.TransferFunction
        A continuous-time, stable SISO transfer function with real poles and zeros.
    delay : float
        The plant's own dead time (s), which neither library's transfer function holds.

    Returns
    -------
    Fopdt

    Examples
    --------
    >>> import control
    >>> s = control.tf("s")
    >>> fopdt_of(1 / ((6 * s + 1) * (2 * s + 1)), delay=1.0)
    Fopdt(K=1.0, T=7.0, L=2.0)
    """
    K, (T,), L = _half_rule(plant_tf, delay, 1)
    return Fopdt(K=K, T=T, L=L)


def sopdt_of(plant_tf: Any, delay: float = 0.0) -> Sopdt:
    """The second-order-plus-dead-time model of a transfer function by Skogestad's half rule:
    as :func:`fopdt_of`, with the lags ``tau_1`` and ``tau_2 + tau_3 / 2`` and
    ``L = delay + tau_3 / 2 + sum(tau_i, i >= 4) + sum(T0j of right-half-plane zeros)``.
    The model is the same whichever lag is called T1: T1 is the larger (with equal lags,
    1 / (s + 1)^3, the second is the larger, 1.5 against 1).

    Parameters
    ----------
    plant_tf : python-control TransferFunction
        A stable continuous plant with real poles (and real zeros), as :func:`fopdt_of`.
    delay : float
        The plant's own dead time (s), added to the one the half rule finds.

    Examples
    --------
    >>> import control
    >>> s = control.tf("s")
    >>> m = sopdt_of((-0.3 * s + 1) * (0.08 * s + 1) / ((2 * s + 1) * (s + 1) * (0.4 * s + 1)
    ...              * (0.2 * s + 1) * (0.05 * s + 1) ** 3))
    >>> round(m.T1, 6), round(m.T2, 6), round(m.L, 6)
    (2.0, 1.2, 0.77)
    """
    K, (a, b), L = _half_rule(plant_tf, delay, 2)
    T1, T2 = max(a, b), min(a, b)
    return Sopdt(K=K, T1=T1, T2=T2, L=L)


def series_to_parallel(Kc: float, Ti: float, Td: float) -> tuple[float, float, float]:
    """``(kp, ki, kd)`` of the series (interacting) PID ``Kc (Ti s + 1) (Td s + 1) / (Ti s)``:
    expanded, it is ``Kc (Ti + Td) / Ti + Kc / (Ti s) + Kc Td s``, so ``kp = Kc (1 + Td /
    Ti)``, ``ki = Kc / Ti``, ``kd = Kc Td``.

    Examples
    --------
    >>> series_to_parallel(2.0, 4.0, 1.0)
    (2.5, 0.5, 2.0)
    """
    return Kc * (1.0 + Td / Ti), Kc / Ti, Kc * Td


Kind = Literal["PI", "PID"]


def _check_kind(kind: Any) -> None:
    if kind not in ("PI", "PID"):
        raise ConfigError("kind", kind, 'must be "PI" or "PID"')


def simc(model: Fopdt | Sopdt, tau_c: float | None = None, kind: Kind = "PI") -> Gains:
    """Skogestad's SIMC gains (2003, eq. 19-21 and section 4) in :class:`mfcontrol.PID`'s
    parallel form.

    With ``K``, ``T1`` (``T`` of a :class:`Fopdt`), ``T2`` and ``L`` of the model and the
    closed-loop time constant ``tau_c`` (default ``L``, Skogestad's "tight" choice, gain
    margin about 3):

    - PI (a :class:`Fopdt`, or a :class:`Sopdt`'s ``T1`` with ``T2`` dropped, as the paper
      does for a PI): ``Kc = T1 / (K (tau_c + L))``, ``Ti = min(T1, 4 (tau_c + L))``;
      ``kp = Kc``, ``ki = Kc / Ti``, ``kd = 0``;
    - PID (a :class:`Sopdt` only): the same ``Kc`` and ``Ti`` with ``Td = T2``, in the
      series form ``Kc (Ti s + 1) (Td s + 1) / (Ti s)``, converted to the parallel form by
      :func:`series_to_parallel`. SIMC gives a FOPDT no derivative, so a :class:`Fopdt`
      with ``kind="PID"`` is refused rather than given one the paper does not give.

    SIMC sets no setpoint weight: ``b = 1``.

    Parameters
    ----------
    model : Fopdt or Sopdt
    tau_c : float, optional
        Desired closed-loop time constant (s), >= 0; ``tau_c + L`` must be > 0.
    kind : {"PI", "PID"}
        A PI from either model, a PID from a :class:`Sopdt`.

    Returns
    -------
    Gains
        ``kp``, ``ki`` (1/s times kp's unit), ``kd`` (s times kp's unit), ``b = 1``.

    Examples
    --------
    The half rule's FOPDT of Skogestad's seven-lag example (2003, section 3; Kc 0.85,
    Ti 2.5):

    >>> simc(Fopdt(K=1.0, T=2.5, L=1.47))
    Gains(kp=0.8503..., ki=0.3401..., kd=0.0, b=1.0)
    """
    _check_kind(kind)
    if not isinstance(model, (Fopdt, Sopdt)):
        raise ConfigError("model", model, "must be a Fopdt or a Sopdt")
    if kind == "PID" and isinstance(model, Fopdt):
        raise ConfigError("model", model, 'must be a Sopdt for kind="PID": SIMC gives a '
                          "FOPDT a PI (use sopdt_of, or kind=\"PI\")")
    T1 = model.T if isinstance(model, Fopdt) else model.T1
    tc = model.L if tau_c is None else _finite("tau_c", tau_c, "must be a finite time >= 0",
                                               low=0.0)
    if tc + model.L <= 0.0:
        raise ConfigError("tau_c", tau_c, "must be > 0 when the model has no dead time "
                          "(Kc = T / (K (tau_c + L)) is otherwise infinite)")
    Kc = T1 / (model.K * (tc + model.L))
    Ti = min(T1, 4.0 * (tc + model.L))
    if kind == "PI":
        return Gains(Kc, Kc / Ti, 0.0, 1.0)
    assert isinstance(model, Sopdt)
    kp, ki, kd = series_to_parallel(Kc, Ti, model.T2)
    return Gains(kp, ki, kd, 1.0)


def amigo(model: Fopdt, kind: Kind = "PI") -> Gains:
    """Astrom and Hagglund's AMIGO gains for a FOPDT model (Advanced PID Control, 2006,
    sections 7.6 and 7.7; J. Process Control 14 (2004) 635-650), in :class:`mfcontrol.PID`'s
    parallel form.

    With ``K``, ``T``, ``L`` and ``tau = L / (L + T)`` of the model:

    - PI: ``K Kp = 0.15 + (0.35 - L T / (L + T)^2) T / L``,
      ``Ti = 0.35 L + 13 L T^2 / (T^2 + 12 L T + 7 L^2)``;
    - PID: ``K Kp = 0.2 + 0.45 T / L``, ``Ti = (0.4 L + 0.8 T) / (L + 0.1 T) L``,
      ``Td = 0.5 L T / (0.3 L + T)``;

    ``kp = Kp``, ``ki = Kp / Ti``, ``kd = Kp Td`` (the book's PID is the parallel
    ``Kp (b r - y) + Kp / Ti int e + Kp Td d(c r - y)/dt``, as mfcontrol's with ``c = 0``).
    Setpoint weight: ``b = 0`` for ``tau <= 0.5``, ``b = 1`` above, for both kinds. The
    formulas were checked against two independent secondary sources (the Modelica Buildings
    library's AMIGO blocks and a published Python implementation); the setpoint-weight rule
    against secondary sources only, the book's own text was not available to check it.
    The rules were fitted for processes with essentially monotone step responses.

    Parameters
    ----------
    model : Fopdt
        With dead time ``L > 0`` (the rules divide by it).
    kind : {"PI", "PID"}
        Which of the two rules.

    Returns
    -------
    Gains
        ``kp``, ``ki``, ``kd`` (0 for a PI) and the rule's setpoint weight ``b``.

    Examples
    --------
    >>> [round(g, 6) for g in amigo(Fopdt(K=1.0, T=1.0, L=1.0))]  # tau 0.5: b 0
    [0.25, 0.25, 0.0, 0.0]
    """
    _check_kind(kind)
    if not isinstance(model, Fopdt):
        raise ConfigError("model", model, "must be a Fopdt (AMIGO is written for K, T, L)")
    K, T, L = model.K, model.T, model.L
    if L <= 0.0:
        raise ConfigError("model.L", L, "must be > 0 for AMIGO (its formulas divide by the "
                          "dead time)")
    b = 0.0 if model.tau <= 0.5 else 1.0
    if kind == "PI":
        kp = (0.15 + (0.35 - L * T / (L + T) ** 2) * T / L) / K
        Ti = 0.35 * L + 13.0 * L * T ** 2 / (T ** 2 + 12.0 * L * T + 7.0 * L ** 2)
        return Gains(kp, kp / Ti, 0.0, b)
    kp = (0.2 + 0.45 * T / L) / K
    Ti = (0.4 * L + 0.8 * T) / (L + 0.1 * T) * L
    Td = 0.5 * L * T / (0.3 * L + T)
    return Gains(kp, kp / Ti, kp * Td, b)
