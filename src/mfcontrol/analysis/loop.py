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

from . import linearise
from .filters import LinearFilter

#: frequencies per decade of the grid on which the peaks (Ms, Mt, the noise gain) are
#: taken, over the six decades below the Nyquist frequency
POINTS_PER_DECADE = 2000


def frequencies(dt: float, points: int, decades: float = 5.0) -> np.ndarray:
    """``points`` frequencies (rad/s), log-spaced over ``decades`` below the Nyquist
    frequency pi / dt, the last at it: the grid of every peak, plot and crossing search."""
    nyquist = math.pi / dt
    return np.logspace(math.log10(nyquist) - decades, math.log10(nyquist), points)


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
        # the zero-order hold the engine steps an LTI plant by
        ss = control.ss(plant)
        ad, bd = linearise.discretise(ss.A, np.asarray(ss.B, dtype=float)[:, 0], float(dt))
        return control.ss(ad, bd[:, None], ss.C, ss.D, dt)
    if plant.dt is True or not math.isclose(plant.dt, dt, rel_tol=1e-12):
        raise ValueError(f"plant.dt = {plant.dt!r}: must be the controller's sample time "
                         f"{dt!r}, or 0 (a continuous system, discretised by its "
                         "zero-order hold)")
    return plant


def closed_loop(Ad: np.ndarray, Bd: np.ndarray, Cp: np.ndarray, delay: int,
                c: LinearFilter) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C, D)`` of the law ``c`` closed around the sampled plant ``(Ad, Bd, Cp)``
    behind ``delay`` samples (:attr:`LinearLoop.state_space`)."""
    N = c.order
    a, by, br = (np.concatenate([p, np.zeros(N + 1 - p.size)]) for p in (c.a, c.b_y,
                                                                         c.b_r))
    n, d = Ad.shape[0], delay
    size = n + N + d
    # u = z_1 + by0 (Cp x + noise) + br0 r, as a row over the state and the inputs
    u_x = np.zeros(size)
    u_x[:n] = by[0] * Cp
    if N:
        u_x[n] = 1.0
    u_in = np.array([br[0], by[0]])
    A = np.zeros((size, size))
    B = np.zeros((size, 2))
    # the law: z_i' = z_{i+1} + by_i (y + noise) + br_i r - a_i u
    law = slice(n, n + N)
    A[law, :n] = np.outer(by[1:], Cp)
    A[law] -= np.outer(a[1:], u_x)
    A[n + np.arange(N - 1), n + 1 + np.arange(N - 1)] += 1.0
    B[law, 0] = br[1:]
    B[law, 1] = by[1:]
    B[law] -= np.outer(a[1:], u_in)
    # the delay line: its first cell takes u, each the one before; the plant the last
    for i in range(d):
        row = n + N + i
        if i == 0:
            A[row] = u_x
            B[row] = u_in
        else:
            A[row, row - 1] = 1.0
    A[:n, :n] = Ad
    if d:
        A[:n, n + N + d - 1] += Bd
    else:
        A[:n] += np.outer(Bd, u_x)
        B[:n] += np.outer(Bd, u_in)
    C = np.zeros((2, size))
    C[0, :n] = Cp
    C[1] = u_x
    D = np.zeros((2, 2))
    D[1] = u_in
    return A, B, C, D


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
        in q = z^-1, ascending: the terms of :meth:`characteristic` (the poles and the
        frequency response come from the plant's state space instead)."""
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
        ``A D_p - B_y N_p``, the plant ``P = N_p / D_p``. For reading, not for root
        finding: :meth:`poles` takes them from the state space."""
        num, den = self.plant_polynomials
        c = self.controller
        return poly.polysub(poly.polymul(c.a, den), poly.polymul(c.b_y, num))

    @functools.cached_property
    def plant_matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(Ad, Bd, C) of the sampled plant, as given or as python-control realises it."""
        import control

        ss = control.ss(self.plant)
        if np.any(np.asarray(ss.D) != 0.0):
            raise ValueError("plant: must be strictly proper (D = 0): y_k is measured "
                             "before u_k is computed")
        return (np.asarray(ss.A, dtype=float), np.asarray(ss.B, dtype=float)[:, 0],
                np.asarray(ss.C, dtype=float)[0])

    @functools.cached_property
    def state_space(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C, D)`` of the closed loop, state ``[plant x, law z, delay line]``,
        inputs ``(r, n)`` (the setpoint; a noise added to the measurement), outputs
        ``(y, u)`` (the plant's output; the law's). The law is in the transposed direct
        form its difference equation runs in (``scipy.signal.lfilter``'s), the plant in
        its own state space: its poles are never taken from polynomial coefficients,
        whose roots move by eps^(1/m) where m poles cluster (a lag of order 8 sampled
        fast has eight poles within 0.05 of each other)."""
        return closed_loop(*self.plant_matrices, self.delay, self.controller)

    @functools.cached_property
    def _poles(self) -> np.ndarray:
        # once: the margins read them for the radius and again for the noise gain
        return np.linalg.eigvals(self.state_space[0])

    def poles(self) -> np.ndarray:
        """The closed loop's poles: the eigenvalues of :attr:`state_space`'s matrix (its
        realisation adds poles at z = 0 where the law's or the plant's order exceeds the
        loop's)."""
        return self._poles.copy()

    def plant_response(self, omega: np.ndarray) -> np.ndarray:
        """``q^delay P`` at the frequencies ``omega`` (rad/s), from the plant's state
        space: ``C (zI - Ad)^-1 Bd``."""
        Ad, Bd, Cp = self.plant_matrices
        z = np.exp(1j * np.asarray(omega) * self.controller.dt)
        eye = np.eye(Ad.shape[0])
        x = np.linalg.solve(z[:, None, None] * eye - Ad, np.broadcast_to(
            Bd.astype(complex), (z.size, Bd.size))[..., None])[..., 0]
        return (x @ Cp) * z ** -float(self.delay)

    def frequency_response(self, omega: np.ndarray) -> dict[str, np.ndarray]:
        """L, S, T, the noise-to-control gain C_y S and the setpoint-to-output response
        ``T_ry = P C_r S`` at the frequencies ``omega`` (rad/s, below the Nyquist
        frequency pi / dt)."""
        c = self.controller
        q = np.exp(-1j * np.asarray(omega) * c.dt)
        plant = self.plant_response(omega)
        c_y = poly.polyval(q, c.b_y) / poly.polyval(q, c.a)
        c_r = poly.polyval(q, c.b_r) / poly.polyval(q, c.a)
        loop = -c_y * plant
        s = 1.0 / (1.0 + loop)
        return {"L": loop, "S": s, "T": loop * s, "CS": c_y * s, "Try": plant * c_r * s}

    def setpoint_dc_gain(self) -> float:
        """``T_ry(1)``: the output's steady state per unit of a constant setpoint, from
        the closed loop's state space; nan when the loop has a pole at z = 1."""
        A, B, C, D = self.state_space
        try:
            x = np.linalg.solve(np.eye(A.shape[0]) - A, B[:, 0])
        except np.linalg.LinAlgError:
            return math.nan
        return float(C[0] @ x + D[0, 0])

    def noise_gain_h2(self) -> float:
        """The H2 norm of ``C_y S``: a white measurement noise of standard deviation
        sigma moves the output u by ``noise_gain_h2 * sigma`` (standard deviation, in the
        steady state of a stable loop); inf for an unstable one. From the closed loop's
        discrete Lyapunov equation (:attr:`state_space`, from the noise to u)."""
        from scipy import linalg

        if self.spectral_radius() >= 1.0:
            return math.inf
        A, B, C, D = self.state_space
        b = B[:, 1:2]
        W = linalg.solve_discrete_lyapunov(A, b @ b.T, method="bilinear")
        return float(math.sqrt(max(float(C[1] @ W @ C[1]) + D[1, 1] ** 2, 0.0)))

    def spectral_radius(self) -> float:
        """The largest modulus of a closed-loop pole: below 1, the linear loop is
        asymptotically stable."""
        return float(np.abs(self._poles).max(initial=0.0))

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
        omega = frequencies(c.dt, 6 * POINTS_PER_DECADE, decades=6)
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
