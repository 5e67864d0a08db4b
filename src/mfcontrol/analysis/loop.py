"""A law's linear filter closed around a discrete plant: poles, margins, sensitivities.

The loop: ``y = P(z) u`` (the plant stepped by its zero-order hold, as the engine steps an
LTI plant), ``u = C_y(z) y + C_r(z) r`` (the law's :class:`~mfcontrol.analysis.filters.
LinearFilter`). The loop gain is ``L = -C_y P`` (the law's feedback path: u acts against y),
the sensitivity ``S = 1 / (1 + L)``, the complementary sensitivity ``T = L / (1 + L)``,
and measurement noise n (y_meas = y + n) reaches u through ``C_y S``.

What holds where: the loop is the law within its output limits, at a fixed gain, on the
linear plant given; a saturating output, a moving gain or a nonlinear plant away from the
point it was linearised at are outside it.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.polynomial import polynomial as poly

from ..numerics import zoh
from .filters import LinearFilter, _padded

#: frequencies per decade of the grid on which the peaks (Ms, Mt, the noise gain) are
#: taken, over the six decades below the Nyquist frequency
POINTS_PER_DECADE = 2000
#: the longest impulse response :meth:`LinearLoop.noise_gain_h2` sums (a slower loop's
#: norm comes from its Lyapunov equation)
H2_MOST_SAMPLES = 4_000_000


def _discrete(plant: Any, dt: float) -> Any:
    """``plant`` as a discrete SISO python-control system of sample time dt: a continuous
    one (or an object with the matrices ``A``, ``B``, ``C`` of x' = A x + B u, y = C x,
    as :class:`mfcontrol.LTI`) by its zero-order hold."""
    import control

    if not isinstance(plant, control.StateSpace | control.TransferFunction):
        matrices = [getattr(plant, m, None) for m in "ABC"]
        if any(m is None for m in matrices):
            raise TypeError(f"plant: a python-control StateSpace or TransferFunction, or "
                            f"a mfcontrol.LTI, not {type(plant).__name__}")
        a, b, c = (np.asarray(m, dtype=float) for m in matrices)
        plant = control.ss(a, b.reshape(-1, 1), c.reshape(1, -1), 0.0)
    if not plant.issiso():
        raise ValueError("plant: must have one input and one output")
    if plant.isctime():
        # the zero-order hold the engine steps an LTI plant by (numerics/zoh.py)
        ss = control.ss(plant)
        a = np.ascontiguousarray(ss.A, dtype=float)
        b = np.ascontiguousarray(np.asarray(ss.B, dtype=float)[:, 0])
        ad, bd = np.empty_like(a), np.empty_like(b)
        zoh.discretise(a, b, float(dt), ad, bd)
        return control.ss(ad, bd[:, None], ss.C, ss.D, dt)
    if plant.dt is True or not math.isclose(plant.dt, dt, rel_tol=1e-12):
        raise ValueError(f"plant.dt = {plant.dt!r}: must be the controller's sample time "
                         f"{dt!r}, or 0 (a continuous system, discretised by its "
                         "zero-order hold)")
    return plant


@dataclass(frozen=True)
class LinearLoop:
    """A law's linear filter closed around a discrete plant: its poles and margins.

    Parameters
    ----------
    controller : LinearFilter
        The law, from a live controller's ``linear_filter()``.
    plant : control.TransferFunction, control.StateSpace or mfcontrol.LTI
        A SISO linear plant. A continuous one (a python-control system with dt = 0, or
        a :class:`mfcontrol.LTI`) is discretised by its zero-order hold at the
        controller's sample time, as the engine steps an LTI plant exactly; a discrete
        one must have the controller's sample time. ``loop.plant`` is the discrete
        system the loop uses.
    delay : int
        Samples of delay in the loop besides the plant's own (the sensor's and the
        actuator's delays together): the law sees ``q^delay P``.

    Examples
    --------
    A PI on 1 / (s + 1), sampled every 0.1 s:

    >>> import control, mfcontrol
    >>> from mfcontrol.analysis.loop import LinearLoop
    >>> pi = mfcontrol.PID(kp=2.0, ki=1.0, sample_time=0.1).linear_filter()
    >>> m = LinearLoop(pi, control.tf([1.0], [1.0, 1.0])).margins()
    >>> m["stable"], round(m["Ms"], 3), round(m["phase_margin_deg"], 1)
    (True, 1.108, 98.2)
    """

    controller: LinearFilter
    plant: Any
    delay: int = 0

    def __post_init__(self) -> None:
        # frozen: the plant as the loop uses it, discrete at the controller's sample time
        object.__setattr__(self, "plant", _discrete(self.plant, self.controller.dt))
        if isinstance(self.delay, bool) or int(self.delay) != self.delay or self.delay < 0:
            raise ValueError(f"delay = {self.delay!r}: must be a whole number of samples "
                             ">= 0")
        object.__setattr__(self, "delay", int(self.delay))

    @functools.cached_property
    def plant_polynomials(self) -> tuple[np.ndarray, np.ndarray]:
        """``(N_p, D_p)``: the plant behind the loop's delay, ``q^delay P``, as polynomials
        in q = z^-1, ascending (derived once: the margins evaluate the loop at every step
        of their root finding)."""
        import control

        tf = control.ss2tf(self.plant) if isinstance(self.plant, control.StateSpace) \
            else self.plant
        num = np.atleast_1d(np.squeeze(tf.num[0][0])).astype(float)
        den = np.atleast_1d(np.squeeze(tf.den[0][0])).astype(float)
        # descending powers of z, over the denominator's degree: ascending powers of q;
        # the loop's delay is q^delay more on the numerator
        n = den.size
        num = np.concatenate([np.zeros(n - num.size + self.delay), num])
        return num, den

    def characteristic(self) -> np.ndarray:
        """The closed loop's characteristic polynomial in q = z^-1 (ascending):
        ``A D_p - B_y N_p``, the plant ``P = N_p / D_p``."""
        num, den = self.plant_polynomials
        c = self.controller
        return poly.polysub(poly.polymul(c.a, den), poly.polymul(c.b_y, num))

    def poles(self) -> np.ndarray:
        """The closed loop's poles (roots in z of the characteristic polynomial)."""
        # a polynomial in q of degree d is z^-d times the same coefficients in
        # descending powers of z
        return np.roots(np.trim_zeros(self.characteristic(), "b"))

    def frequency_response(self, omega: np.ndarray) -> dict[str, np.ndarray]:
        """L, S, T, the noise-to-control gain C_y S and the setpoint-to-output response
        ``T_ry = P C_r S`` at the frequencies ``omega`` (rad/s, below the Nyquist
        frequency pi / dt)."""
        c = self.controller
        q = np.exp(-1j * np.asarray(omega) * c.dt)
        num, den = self.plant_polynomials
        plant = poly.polyval(q, num) / poly.polyval(q, den)
        c_y = poly.polyval(q, c.b_y) / poly.polyval(q, c.a)
        c_r = poly.polyval(q, c.b_r) / poly.polyval(q, c.a)
        loop = -c_y * plant
        s = 1.0 / (1.0 + loop)
        return {"L": loop, "S": s, "T": loop * s, "CS": c_y * s, "Try": plant * c_r * s}

    def setpoint_dc_gain(self) -> float:
        """``T_ry(1)``: the output's steady state per unit of a constant setpoint,
        ``N_p B_r / (A D_p - B_y N_p)`` at z = 1, each factor summed alone (where the law
        integrates, A(1) is an exact 0 and the gain an exact ratio, not a difference of
        near-equal sums); nan when the denominator vanishes."""
        num, den = self.plant_polynomials
        c = self.controller
        n1, d1, a1, by1, br1 = (float(np.sum(p)) for p in (num, den, c.a, c.b_y, c.b_r))
        char = a1 * d1 - by1 * n1
        if char == 0.0:
            return math.nan
        return n1 * br1 / char

    def noise_gain_h2(self) -> float:
        """The H2 norm of ``C_y S``: a white measurement noise of standard deviation
        sigma moves the output u by ``noise_gain_h2 * sigma`` (standard deviation, in the
        steady state of a stable loop); inf for an unstable one. The root sum of squares
        of its impulse response, run until the slowest pole has decayed by 1e-9
        (:data:`H2_MOST_SAMPLES` at most; beyond, from the discrete Lyapunov equation)."""
        from scipy import linalg, signal

        radius = self.spectral_radius()
        if radius >= 1.0:
            return math.inf
        num, den = self.plant_polynomials
        # C_y S = B_y D_p / (A D_p - B_y N_p), polynomials in q: lfilter's own form
        n = poly.polymul(self.controller.b_y, den)
        d = self.characteristic()
        samples = math.ceil(math.log(1e-9) / math.log(radius)) + n.size + d.size \
            if radius > 0.0 else n.size + d.size
        if samples <= H2_MOST_SAMPLES:
            impulse = np.zeros(samples)
            impulse[0] = 1.0
            return float(math.sqrt(np.sum(signal.lfilter(n, d, impulse) ** 2)))
        size = max(n.size, d.size)
        A, B, C, D = signal.tf2ss(_padded(n, size), _padded(d, size))
        W = linalg.solve_discrete_lyapunov(A, B @ B.T, method="bilinear")
        return float(math.sqrt(max((C @ W @ C.T)[0, 0] + D[0, 0] ** 2, 0.0)))

    def spectral_radius(self) -> float:
        """The largest modulus of a closed-loop pole: below 1, the linear loop is
        asymptotically stable."""
        return float(np.abs(self.poles()).max(initial=0.0))

    def margins(self) -> dict[str, float | bool]:
        """The loop's robustness, as a dict:

        - ``spectral_radius``: the largest modulus of a pole; ``stable``: below 1 (asymptotic
          stability of the linear loop);
        - ``Ms``, ``Mt``: the peaks of ``|S|`` and ``|T|`` (robustness: Ms <= 1.4 .. 2 is the
          usual range);
        - ``gain_margin``: the factor on the loop gain that brings the Nyquist curve to
          -1 where its phase crosses -180 degrees (the crossing whose factor is nearest 1
          when there are several, as ``control.stability_margins``; inf without one);
        - ``phase_margin_deg``: 180 degrees plus L's phase where ``|L|`` crosses 1 (the
          smallest in size over the crossings; inf without one);
        - ``delay_margin_s`` and ``delay_margin_samples``: the smallest extra loop delay
          that destabilises the loop, over every gain crossover (inf without one);
        - ``noise_gain_peak``: the peak of ``|C_y S|``, how much measurement noise the
          output sees at the worst frequency; ``noise_gain_h2``: its H2 norm
          (:meth:`noise_gain_h2`), what a white noise's standard deviation is multiplied
          by on its way to u;
        - ``steady_state_error``: ``1 - T_ry(1)``, the error left per unit of a constant
          setpoint (0 where the loop integrates; nan for an unstable loop);
        - ``bandwidth_rad_s``: the first frequency where the setpoint response
          ``|T_ry|`` falls 3 dB below its DC value (inf if it never does below the
          Nyquist frequency).

        Crossings are found on a grid of :data:`POINTS_PER_DECADE` frequencies a decade
        over the six decades below the Nyquist frequency, then solved for exactly
        (``scipy.optimize.brentq``). The margins of an unstable loop are returned too;
        they do not mean much there.
        """
        from scipy.optimize import brentq

        c = self.controller
        nyquist = math.pi / c.dt
        omega = np.logspace(math.log10(nyquist) - 6, math.log10(nyquist),
                            6 * POINTS_PER_DECADE)
        resp = self.frequency_response(omega)
        loop = resp["L"]

        def at(w: float) -> complex:
            return complex(self.frequency_response(np.array([w]))["L"][0])

        def crossings(f: np.ndarray, g, where: np.ndarray | None = None) -> list[float]:
            """Where f changes sign between two grid points (both in ``where``), solved
            for on g(w) = 0."""
            change = np.sign(f[:-1]) * np.sign(f[1:]) < 0
            if where is not None:
                change &= where[:-1] & where[1:]
            return [brentq(g, omega[k], omega[k + 1], xtol=1e-14 * omega[k + 1])
                    for k in np.flatnonzero(change)]

        # gain crossovers: |L| = 1
        w_gc = crossings(np.abs(loop) - 1.0, lambda w: abs(at(w)) - 1.0)
        phase_margins = [(math.degrees(np.angle(at(w))) + 360.0) % 360.0 - 180.0
                         for w in w_gc]
        # phase crossovers: L crossing the negative real axis (and at the Nyquist
        # frequency, where L is real)
        w_pc = crossings(loop.imag, lambda w: at(w).imag, where=loop.real < 0)
        gains = [-1.0 / crossing.real for crossing in map(at, w_pc) if crossing.real < 0]
        if loop[-1].real < 0:
            gains.append(-1.0 / loop[-1].real)
        delays = [math.radians(pm % 360.0) / w for pm, w in zip(phase_margins, w_gc,
                                                                 strict=True)]
        radius = self.spectral_radius()
        delay = float(min(delays, default=math.inf))
        stable = radius < 1.0
        dc = self.setpoint_dc_gain() if stable else math.nan
        # bandwidth: |T_ry| crossing |T_ry(1)| / sqrt(2) (python-control's definition)
        drop = np.abs(resp["Try"]) - abs(dc) / math.sqrt(2.0)
        w_bw = crossings(drop, lambda w: abs(self.frequency_response(np.array([w]))["Try"][0])
                         - abs(dc) / math.sqrt(2.0)) if stable and dc != 0.0 else []
        return {
            "stable": stable,
            "spectral_radius": radius,
            "Ms": float(np.abs(resp["S"]).max()),
            "Mt": float(np.abs(resp["T"]).max()),
            "gain_margin": min(gains, key=lambda g: abs(math.log(g)), default=math.inf),
            "phase_margin_deg": min(phase_margins, key=abs, default=math.inf),
            "delay_margin_s": delay,
            "delay_margin_samples": delay / c.dt,
            "noise_gain_peak": float(np.abs(resp["CS"]).max()),
            "noise_gain_h2": self.noise_gain_h2(),
            "steady_state_error": 1.0 - dc,
            "bandwidth_rad_s": w_bw[0] if w_bw else (math.inf if stable else math.nan),
        }
