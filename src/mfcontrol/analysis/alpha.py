"""The gain alpha of the ultra-local model ``y^(n) = F + alpha u``, from data or from a
plant, and the range of alpha the backward-difference i-P (i-PD) is stable over.

From data (:func:`estimate_alpha`): the input of a step test (or any piecewise-constant
input, a PRBS) is held over each sample, so the relations of the model between samples
are exact rather than numerical derivatives of noisy data. For n = 1 and F constant
over a sample, ``(y_{j+1} - y_j)/h = F + alpha u_j``; for n = 2,
``(y_{j+2} - 2 y_{j+1} + y_j)/h^2 = F + alpha (u_j + u_{j+1})/2``. Summed from the start
of a window these read ``y(t) = P(t) + alpha I_n(t)``: ``I_n`` is the n-th integral of the
held input (exact at the samples) and P a polynomial that holds F's own n-th integral and
the n constants the differences remove. Fitting y itself by least squares is the
regression of the differences weighted by the covariance that white sensor noise gives
them (their generalised least squares): unbiased like the differences' ordinary least
squares, but of the smallest variance for that noise (Gauss-Markov), and with a
standard error that is right for it, where the differences' would be wrong (differences
of white noise are correlated).

F moves with the plant's state, so the fit is local: a window around each change of u,
its own polynomial for F, and alpha shared by all the windows (pooled). Within a window
F is modelled as a polynomial in time plus its first three responses to the input,
``kappa_1 I_{n+1} + kappa_2 I_{n+2} + kappa_3 I_{n+3}``: a change of u bends F's
trajectory (for a linear plant ``kappa_k = C A^{n-1+k} B``, the Markov parameters after
alpha), which no polynomial follows through the change. What is left, the next terms
and F's own motion beyond the polynomial, biases alpha by a power of ``T / tau``, T the
half-window and ``tau = min_k |alpha / kappa_k|^(1/k)`` the time scale on which F answers
the input; the default window is chosen from an estimate of tau
(:func:`estimate_alpha`).

From a plant (:func:`plant_alpha`): alpha is the high-frequency gain of the plant's
linearisation at an operating point, ``C A^{n-1} B``, when the relative degree from u to
y is n (``C A^k B = 0`` for k < n - 1). :func:`open_loop` simulates a plant under a given
input for the data route.

The bound (:func:`backward_difference_bound`): the range of alpha for which the i-P (or
i-PD) with the backward-difference estimator is stable on the pure plant
``y^(n) = beta u`` under a zero-order hold, from the Jury (Schur-Cohn) conditions on the
closed loop's characteristic polynomial.
"""

from __future__ import annotations

import math
import numbers
import sys
import warnings
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from ..errors import ConfigError
from ..laws import estimators
from . import linearise

__all__ = ["AlphaBounds", "AlphaEstimate", "backward_difference_bound", "estimate_alpha",
           "open_loop", "plant_alpha"]

#: how far a sample time may lie from the uniform grid through the first and last, in
#: sample periods: a logger's rounding (microseconds at 1 kHz is 5e-4), not jitter
T_TOLERANCE = 1e-3
#: changes of u smaller than this fraction of the largest are not given a window of their
#: own (their information, ~ du^2, is under a millionth of the largest change's): a
#: recorded input's rounding is not a step. Every change still enters the integrals.
CHANGE_FRACTION = 1e-3
#: the default half-window, as a fraction of the time scale tau on which F answers the
#: input: the bias left is then about 1e-4 of alpha or less (measured on lags of order 1
#: and 2 sampled at 100 and 1000 samples per tau; 1e-3 on a resonance with 2 % damping)
WINDOW_OF_TAU = 0.5
#: how many responses of F to the input each window models (kappa_1 I_{n+1}, ...)
INPUT_TERMS = 3
#: a kappa sets the window only beyond this many standard errors: the window shrinks on
#: firm evidence alone (a chance kappa costs more variance than it saves bias: on
#: simulated order-2 step tests the RMS error at 3 was up to 50 times that at 5)
SIGNIFICANCE = 5.0


# ---------------------------------------------------------------------------------------
# validation: every refusal is one line, "name = value: what is allowed" (ConfigError)


class _Described(str):
    """A value described in words, shown as such (not quoted) in a refusal."""

    def __repr__(self) -> str:
        return str(self)


def _integer(name: str, value: Any, allowed: tuple[int, ...] | None = None,
             low: int | None = None, high: int | None = None) -> int:
    ok = isinstance(value, numbers.Integral) and not isinstance(value, bool)
    if ok and allowed is not None:
        ok = int(value) in allowed
    if ok and low is not None:
        ok = int(value) >= low
    if ok and high is not None:
        ok = int(value) <= high
    if not ok:
        if allowed is not None:
            what = "must be " + " or ".join(str(a) for a in allowed)
        else:
            what = f"must be a whole number from {low} to {high}"
        raise ConfigError(name, value, what)
    return int(value)


def _real(name: str, value: Any, *, positive: bool = False,
          nonnegative: bool = False) -> float:
    v = math.nan
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        try:
            v = float(value)
        except OverflowError:
            v = math.inf
    ok = math.isfinite(v) and (v > 0 or not positive) and (v >= 0 or not nonnegative)
    if not ok:
        raise ConfigError(name, value, "must be a finite number" +
                          (" > 0" if positive else " >= 0" if nonnegative else ""))
    return v


def _series(name: str, value: Any) -> np.ndarray:
    """A 1-D float64 array of finite real numbers (a fresh copy)."""
    arr = None
    if not isinstance(value, str | bytes):
        try:
            raw = np.asarray(value)
            if raw.dtype.kind in "biuf":  # bools, integers, floats: real numbers
                arr = np.array(raw, dtype=np.float64)
            elif raw.dtype.kind == "O":  # a list of numbers of several types
                arr = np.array(raw.tolist(), dtype=np.float64)
        except (TypeError, ValueError, OverflowError):
            arr = None
    if arr is None:
        raise ConfigError(name, value, "must be a 1-D array of real numbers", limit=60)
    if arr.ndim != 1:
        raise ConfigError(f"{name}.shape", arr.shape, "must be one-dimensional (n,)")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        i = int(bad[0])
        raise ConfigError(f"{name}[{i}]", float(arr[i]), "must be finite (no NaN or inf)")
    return arr


def _uniform_step(t: np.ndarray) -> float:
    """The sample period of t, refused unless t is increasing and uniform to within
    :data:`T_TOLERANCE` of a period."""
    n = t.size
    h = float((t[-1] - t[0]) / (n - 1))
    if not h > 0:
        raise ConfigError("t[-1]", float(t[-1]), f"must be later than t[0] = "
                          f"{float(t[0])!r} (t increasing)")
    grid = t[0] + h * np.arange(n)
    off = np.abs(t - grid)
    k = int(np.argmax(off))
    if off[k] > T_TOLERANCE * h:
        raise ConfigError(f"t[{k}]", float(t[k]), f"must be uniformly sampled: "
                          f"t[0] + {k} dt = {float(grid[k]):.9g} with dt = {h:.9g}, to "
                          f"{T_TOLERANCE:g} dt")
    return h


# ---------------------------------------------------------------------------------------
# the estimate from data


@dataclass(frozen=True)
class AlphaEstimate:
    """Alpha of the ultra-local model estimated from recorded data
    (:func:`estimate_alpha`).

    Attributes
    ----------
    alpha : float
        The estimate, in units of y per second^n per unit of u.
    stderr : float
        Its standard error under white sensor noise (estimated from the residuals).
        It does not hold the bias of a window too long for the plant (see
        :func:`estimate_alpha`).
    interval : tuple of float
        ``(low, high)``: the confidence interval (Student's t on the residuals'
        degrees of freedom).
    confidence : float
        The interval's level (0.95 by default).
    order : int
        The model order n.
    changes : int
        How many changes of u were fitted (each one window).
    samples : int
        How many distinct samples the windows hold.
    window : float
        The length of each window (units of t), centred on its change (clipped by the
        record's ends).
    """

    alpha: float
    stderr: float
    interval: tuple[float, float]
    confidence: float
    order: int
    changes: int
    samples: int
    window: float

    def __repr__(self) -> str:
        g = _g
        return (f"AlphaEstimate(alpha={g(self.alpha)}, stderr={g(self.stderr)}, "
                f"interval=({g(self.interval[0])}, {g(self.interval[1])}), "
                f"confidence={g(self.confidence)}, order={self.order}, "
                f"changes={self.changes}, samples={self.samples}, "
                f"window={g(self.window)})")

    def __str__(self) -> str:
        # alpha to the standard error's second significant digit, as a measurement reads
        digits = 6
        if self.stderr > 0 and self.alpha != 0:
            digits = max(2, min(12, 2 + int(math.floor(math.log10(abs(self.alpha)))
                                        - int(math.floor(math.log10(self.stderr))))))

        def f(x: float) -> str:
            return f"{x:.{digits}g}"

        return (f"alpha = {f(self.alpha)} +/- {self.stderr:.2g} "
                f"({100 * self.confidence:g}% interval {f(self.interval[0])} to "
                f"{f(self.interval[1])}; order {self.order}, {self.changes} change"
                f"{'s' * (self.changes != 1)}, {self.samples} samples, window "
                f"{self.window:.6g})")


def _g(x: float) -> str:
    return f"{x:.6g}"


def _held_integrals(du: np.ndarray, count: int) -> np.ndarray:
    """``I_1 .. I_count`` (rows) of the held signal du (du[j] over [j, j + 1), one sample
    as the time unit) at the samples, from 0 at the first: exact, each being the Taylor
    polynomial of the integrals below it over one sample:
    ``I_k(j + 1) = I_k(j) + sum_{i < k} I_i(j) / (k - i)!`` with ``I_0 = du``."""
    m = du.size
    out = np.zeros((count + 1, m))
    out[0] = du
    for k in range(1, count + 1):
        inc = np.zeros(m)
        for i in range(k):
            inc += out[i] / math.factorial(k - i)
        out[k, 1:] = np.cumsum(inc[:-1])
    return out[1:]


def _orthonormal(cols: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Q, R, kept)``: an orthonormal basis Q of the columns' span and ``cols[:, kept]
    = Q R``, by modified Gram-Schmidt twice (stable to rounding: "twice is enough"); a
    column within 1e-10 of the span of those before it is dropped. Written out rather
    than LAPACK's QR: on these tall, thin matrices (thousands x 8) a threaded BLAS spends
    10 times the arithmetic in overhead."""
    q_cols: list[np.ndarray] = []
    r = np.zeros((cols.shape[1], cols.shape[1]))
    kept = []
    for j in range(cols.shape[1]):
        v = cols[:, j].copy()
        size = math.sqrt(float(v @ v))
        for _ in range(2):
            for i, q in enumerate(q_cols):
                c = float(q @ v)
                r[i, j] += c
                v -= c * q
        norm = math.sqrt(float(v @ v))
        if norm > 1e-10 * size:
            r[len(q_cols), j] = norm
            q_cols.append(v / norm)
            kept.append(j)
    k = len(q_cols)
    return np.column_stack(q_cols), r[:k][:, kept], np.array(kept)


class _Window(NamedTuple):
    start: int
    stop: int
    basis: np.ndarray   # orthonormal basis of the nuisance columns (rows x rank)
    R: np.ndarray       # the kept nuisance columns = basis R
    kept: np.ndarray    # which nuisance columns are kept (independent)
    scale: np.ndarray   # the scale of each nuisance column
    y: np.ndarray        # y in the window
    x: np.ndarray        # the alpha column (I_n, sample units)
    r: np.ndarray        # x less its projection on the nuisance columns
    yr: np.ndarray       # y less its projection on the nuisance columns


def _windows(y: np.ndarray, u: np.ndarray, order: int, degree: int, centres: np.ndarray,
             half: int, side: int) -> list[_Window]:
    """The window of each change in ``centres`` (sample m: u_m != u_{m-1}), ``half``
    samples on each side, clipped by the record; a window with fewer than ``side``
    samples on a side, or where alpha is not identifiable, is left out."""
    n = y.size
    out = []
    for m in centres:
        start, stop = max(m - half, 0), min(m + half + 1, n)
        if m - start < side or stop - 1 - m < side:
            continue
        du = u[start:stop] - u[m - 1]
        integrals = _held_integrals(du, order + INPUT_TERMS)
        x = integrals[order - 1]
        tau = (np.arange(start, stop) - m) / half
        cols = np.column_stack([np.polynomial.chebyshev.chebvander(tau, degree + order),
                                integrals[order:].T])
        scale = np.abs(cols).max(axis=0)
        scale[scale == 0] = 1.0
        cols = cols / scale
        basis, R, kept = _orthonormal(cols)
        r = x - basis @ (basis.T @ x)
        if not np.linalg.norm(r) > 1e-8 * np.linalg.norm(x):
            continue
        yw = y[start:stop]
        out.append(_Window(start, stop, basis, R, kept, scale, yw, x, r,
                           yw - basis @ (basis.T @ yw)))
    return out


class _Fit(NamedTuple):
    alpha: float     # sample units: alpha h^n
    variance: float  # of alpha, sample units
    sigma2: float    # of the sensor noise
    dof: float
    samples: int


def _pooled(windows: list[_Window], n: int) -> _Fit:
    """Alpha shared by the windows, each with its own nuisance columns: least squares on
    the stacked windows (Frisch-Waugh: alpha from the residualised columns). Windows may
    overlap, so a sample may enter more than once; the variance is the exact one for
    white noise on y (``alpha = v . y``, v the weights summed per sample), and the noise
    variance comes from the residuals' expected sum of squares for that stacking."""
    sxx = sum(float(w.r @ w.r) for w in windows)
    sxy = sum(float(w.r @ w.yr) for w in windows)
    a = sxy / sxx
    weight = np.zeros(n)  # v sxx: each sample's weight in alpha, summed over windows
    used = np.zeros(n, dtype=bool)
    rss = 0.0
    rows = rank = 0
    for w in windows:
        weight[w.start:w.stop] += w.r
        used[w.start:w.stop] = True
        e = w.yr - a * w.r
        rss += float(e @ e)
        rows += w.stop - w.start
        rank += w.basis.shape[1]
    v2 = float(weight @ weight)
    dof = rows - rank - v2 / sxx
    if not dof > 0.5:  # unreachable with `side` samples a side; a guard against 0/0
        raise ValueError("the windows leave no degrees of freedom for the noise: give a "
                         "longer window or more samples")
    sigma2 = rss / dof
    return _Fit(a, sigma2 * v2 / sxx**2, sigma2, dof, int(used.sum()))


def _time_scale(windows: list[_Window], fit: _Fit) -> float:
    """tau (samples): the time scale on which F answers the input, ``min_k |alpha /
    kappa_k|^(1/k)`` over each window's kappas (alpha held at the pooled value) that are
    significant, beyond :data:`SIGNIFICANCE` standard errors; the median over the
    windows, inf where none is (F does not visibly answer: the window may be long)."""
    taus = []
    for w in windows:
        # the nuisance coefficients, alpha held: R c = basis' (y - alpha x), and their
        # variances sigma^2 diag((R'R)^-1)
        r_inv = np.linalg.inv(w.R)
        coef = r_inv @ (w.basis.T @ (w.y - fit.alpha * w.x))
        var = fit.sigma2 * np.einsum("ij,ij->i", r_inv, r_inv)
        first = w.scale.size - INPUT_TERMS  # the input's terms are the last columns
        tau = math.inf
        for i, col in enumerate(w.kept):
            k = int(col) - first + 1
            if k >= 1 and coef[i] != 0 and abs(coef[i]) > SIGNIFICANCE * math.sqrt(var[i]):
                kappa = coef[i] / w.scale[col]
                tau = min(tau, abs(fit.alpha / kappa) ** (1.0 / k))
        taus.append(tau)
    return float(np.median(taus)) if taus else math.inf


def estimate_alpha(t: npt.ArrayLike, y: npt.ArrayLike, u: npt.ArrayLike, order: int = 1, *,
                   window: float | None = None, degree: int = 2,
                   confidence: float = 0.95) -> AlphaEstimate:
    """Alpha of the ultra-local model ``y^(n) = F + alpha u`` from a step test's record.

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times, uniform (to 0.1 % of a period), increasing.
    y : array_like, shape (N,)
        The measured output, y[k] at t[k].
    u : array_like, shape (N,)
        The input, u[k] held from t[k] to t[k + 1] (a zero-order hold): one or several
        steps, a staircase or a PRBS. At least one change is needed, with
        ``max(degree + order, order + 3) + 2`` samples on each side of it (6 for order 1,
        7 for order 2, at the default degree).
    order : {1, 2}
        The model order n.
    window : float, optional
        The length of the fit around each change (units of t), centred on it. By
        default it is chosen from the data: tau, the time scale on which F answers the
        input (``min_k |alpha / kappa_k|^(1/k)`` over the kappas the data show beyond
        five standard errors), found by a first fit over windows as long as the median
        spacing of the changes, then refined (at most five times); never longer than
        that spacing, and that spacing where the data show no kappa. The result's
        ``window`` says what was used. A longer window averages more noise but lets more
        of F's motion through the model: give one when the standard error is too large
        for you and the plant is slow against it.
    degree : int
        The degree of the polynomial in time that models F's own motion within a window
        (0 to 4; 2 by default, which costs no variance over 1: the term it adds is of
        the parity the estimate is orthogonal to on a symmetric window).
    confidence : float
        The level of :attr:`AlphaEstimate.interval`, in (0, 1).

    Returns
    -------
    AlphaEstimate
        alpha, its standard error and interval, and what was used.

    Raises
    ------
    ValueError
        (a :class:`mfcontrol.ConfigError`) for a bad argument, with one line naming it,
        its value and what is allowed: arrays of different lengths or not 1-D, values
        that are not finite, t not uniform, no usable change of u, ...

    Warns
    -----
    RuntimeWarning
        When alpha is within two standard errors of 0: the input's effect on y^(n) does
        not jump when u does, as when the plant's relative degree exceeds the order.

    Notes
    -----
    Within each window, with u held, ``y(t) = P(t) + alpha I_n(t) + sum_k kappa_k
    I_{n+k}(t)`` (k = 1 to 3), I_k the k-th integral of the held input from the window's
    start (exact at the samples) and P a polynomial of degree ``degree + n``: F is that
    polynomial's n-th derivative plus its responses to the input. This is the relation
    ``(y_{j+1} - y_j)/h = F_j + alpha u_j`` (n = 1) or ``(y_{j+2} - 2 y_{j+1} + y_j)/h^2
    = F_j + alpha (u_j + u_{j+1})/2`` (n = 2) summed, so the least squares on y are the
    generalised least squares of those differences for white sensor noise. Alpha is
    shared by the windows; P and the kappas are each window's own (F moves with the
    plant's state). The standard error is exact for white sensor noise, overlapping
    windows (a PRBS) included; coloured noise or a plant not smooth within the window
    (a dead time, a switching converter's ripple) are outside it. A plant whose relative
    degree exceeds n has no jump of y^(n): the estimate is then the change of y^(n) seen
    at the window's scale (a DC motor's speed once its current has settled, for n = 1)
    and depends on the window; :func:`plant_alpha` tells a model's relative degree.

    Examples
    --------
    Three steps of u on y' = -y + 2 u (alpha = 2), sampled every 10 ms, with sensor
    noise of 1 mV:

    >>> import numpy as np
    >>> from mfcontrol.analysis.alpha import estimate_alpha
    >>> h = 0.01
    >>> t = h * np.arange(900)
    >>> u = np.repeat([0.0, 1.0, -0.5], 300)
    >>> y = np.zeros(t.size)
    >>> for k in range(t.size - 1):  # the exact zero-order hold of the lag
    ...     y[k + 1] = np.exp(-h) * y[k] + 2.0 * (1 - np.exp(-h)) * u[k]
    >>> y += 1e-3 * np.random.default_rng(1).standard_normal(t.size)
    >>> est = estimate_alpha(t, y, u)
    >>> est.changes, bool(abs(est.alpha - 2.0) < 3 * est.stderr)
    (2, True)
    >>> lo, hi = est.interval
    >>> bool(lo < 2.0 < hi)
    True
    """
    t_arr, y_arr, u_arr = (_series(name, v) for name, v in (("t", t), ("y", y), ("u", u)))
    for name, arr in (("y", y_arr), ("u", u_arr)):
        if arr.shape != t_arr.shape:
            raise ConfigError(f"{name}.shape", arr.shape, f"must equal t.shape = "
                              f"{t_arr.shape} (one {name} per sample time)")
    order = _integer("order", order, (1, 2))
    degree = _integer("degree", degree, low=0, high=4)
    confidence = _real("confidence", confidence)
    if not 0 < confidence < 1:
        raise ConfigError("confidence", confidence, "must be between 0 and 1 (exclusive)")
    # samples a window needs on each side: the polynomial and the input's terms pinned
    side = max(degree + order, order + INPUT_TERMS) + 2
    if t_arr.size < 2 * side + 1:
        raise ConfigError("t.shape", t_arr.shape, f"must hold at least {2 * side + 1} "
                          f"samples (order {order}, degree {degree})")
    h = _uniform_step(t_arr)
    if window is not None:
        window = _real("window", window, positive=True)
        half = int(math.floor(window / (2 * h) * (1 + 1e-9)))
        if half < side:
            raise ConfigError("window", window, f"must span at least {2 * side} samples "
                              f"({2 * side * h:.6g} at dt = {h:.6g}) for order {order} "
                              f"and degree {degree}")

    du = np.diff(u_arr)
    largest = float(np.abs(du).max())
    if largest == 0:
        raise ConfigError("u", _Described(f"{float(u_arr[0])!r} at every sample"),
                          "must change at least once (a step test)")
    centres = np.flatnonzero(np.abs(du) > CHANGE_FRACTION * largest) + 1
    n = t_arr.size

    def fitted(half: int) -> tuple[list[_Window], _Fit]:
        windows = _windows(y_arr, u_arr, order, degree, centres, half, side)
        if not windows:
            raise ConfigError("u", _Described("changes at t = "
                                              + _changes_text(t_arr, centres)),
                              f"must have {side} samples on each side of a change, "
                              f"within the record" + ("" if window is None else
                                                      f" and the window of {2 * half} samples"))
        return windows, _pooled(windows, n)

    if window is None:
        gaps = np.diff(centres)
        # windows no longer than the changes' spacing; one change: the record's longer side
        cap = int(np.median(gaps)) // 2 if gaps.size else max(centres[0], n - 1 - centres[0])
        cap = max(int(cap), side)
        half = cap
        windows, fit = fitted(half)
        for _ in range(5):
            tau = _time_scale(windows, fit)
            new = cap if not math.isfinite(tau) else \
                int(min(max(round(WINDOW_OF_TAU * tau), side), cap))
            if abs(new - half) <= max(1, 0.1 * half):
                break
            half = new
            windows, fit = fitted(half)
    else:
        windows, fit = fitted(half)

    from scipy.special import stdtrit  # Student's t quantile (scipy.stats: 0.8 s import)

    scale = h ** order  # sample units to units of t
    alpha = fit.alpha / scale
    se = math.sqrt(fit.variance) / scale
    q = float(stdtrit(fit.dof, 0.5 + confidence / 2))
    est = AlphaEstimate(alpha, se, (alpha - q * se, alpha + q * se), confidence, order,
                        len(windows), fit.samples, 2 * half * h)
    if abs(alpha) <= 2 * se:
        warnings.warn(f"alpha = {alpha:.3g} is within two standard errors ({se:.2g}) of "
                      f"0: y^({order}) does not jump with u; is the plant's relative degree "
                      f"above {order}?", RuntimeWarning, stacklevel=2)
    return est


def _changes_text(t: np.ndarray, centres: np.ndarray) -> str:
    shown = ", ".join(f"{t[m]:.6g}" for m in centres[:4])
    return shown + (f", ... ({centres.size} in all)" if centres.size > 4 else "")


# ---------------------------------------------------------------------------------------
# alpha of a plant object: the high-frequency gain of its linearisation


def _matrices(plant: Any, x: npt.ArrayLike | None, u: float | None, y: float | None,
              t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None,
                                 float, str]:
    """(A, B, C) of ``plant`` at its operating point, the point (x, u) and the point in
    words ("" for a python-control system, whose point is irrelevant)."""
    # a python-control system exists only once python-control is imported: not importing
    # it here saves a single run's warning check the 0.85 s of its import
    control = sys.modules.get("control")
    if control is not None and isinstance(plant, control.StateSpace | control.TransferFunction):
        if not plant.isctime():
            raise ConfigError("plant.dt", plant.dt, "must be 0: a continuous-time system")
        if (plant.ninputs, plant.noutputs) != (1, 1):
            raise ConfigError("plant", _Described(f"a system with {plant.ninputs} inputs "
                                                  f"and {plant.noutputs} outputs"),
                              "must be SISO")
        ss = control.ss(plant)
        if float(np.asarray(ss.D).reshape(-1)[0]) != 0.0:
            raise ConfigError("plant.D", float(np.asarray(ss.D).reshape(-1)[0]),
                              "must be 0: a feedthrough is relative degree 0, no "
                              "ultra-local model of order 1 or 2 fits it")
        return (np.asarray(ss.A, dtype=float), np.asarray(ss.B, dtype=float).reshape(-1),
                np.asarray(ss.C, dtype=float).reshape(-1), None, 0.0, "")
    if not all(hasattr(plant, name) for name in ("derivative", "output", "x0")):
        raise TypeError(f"plant must be a mfcontrol plant (derivative, output, x0) or a "
                        f"python-control StateSpace or TransferFunction, not "
                        f"{type(plant).__name__}")
    x_guess = np.asarray(plant.x0, dtype=float)
    if x is not None:
        x_arr = _series("x", np.atleast_1d(np.asarray(x, dtype=float))
                        if isinstance(x, numbers.Real) else x)
        if x_arr.shape != x_guess.shape:
            raise ConfigError("x.shape", x_arr.shape, f"must be the plant's state shape "
                              f"{x_guess.shape}")
        x_guess = x_arr
    u_op = 0.0 if u is None else _real("u", u)
    if y is not None:
        y_op = _real("y", y)
        found = linearise.steady_state(plant.derivative, plant.output, y_op, x_guess,
                                       (u_op,) if u is not None else (0.0, 1.0, 0.5), t)
        if found is None:
            raise ConfigError("y", y, "must be an output level the plant can rest at "
                              "(no equilibrium found from x0; give x and u instead)")
        x_guess, u_op = found
    where = f"at x = {np.array2string(x_guess, precision=6)}, u = {u_op:.6g}"
    A, B, C = linearise.jacobians(plant.derivative, plant.output, x_guess, u_op, t)
    return A, B, C, x_guess, u_op, where


def plant_alpha(plant: Any, order: int = 1, *, x: npt.ArrayLike | None = None,
                u: float | None = None, y: float | None = None, t: float = 0.0) -> float:
    """Alpha of a plant: the high-frequency gain ``C A^{n-1} B`` of its linearisation.

    With u held, ``y^(n) = C A^n x + C A^{n-1} B u`` when the relative degree from u to
    y is n (``C A^k B = 0`` for k < n - 1): the part of y^(n) that jumps with u is
    ``C A^{n-1} B u``, the rest is F. That gain is the alpha of the ultra-local model,
    the ``beta`` of :func:`backward_difference_bound`.

    Parameters
    ----------
    plant : mfcontrol.Plant or control.StateSpace or control.TransferFunction
        A plant object (``derivative``, ``output``, ``x0``: every :class:`mfcontrol.Plant`,
        :class:`mfcontrol.LTI`, :class:`mfcontrol.ODE`, ...), linearised by central
        differences (:func:`mfcontrol.analysis.linearise.jacobians`), or a continuous
        SISO python-control system (its own matrices; the operating point is then
        irrelevant).
    order : {1, 2}
        The model order n.
    x : array_like, optional
        The operating state; the plant's ``x0`` by default.
    u : float, optional
        The operating input; 0 by default.
    y : float, optional
        An output level: the operating point is then the equilibrium with that output
        (:func:`mfcontrol.analysis.linearise.steady_state`, searched from ``x`` or
        ``x0`` and ``u``), for a nonlinear plant whose gain depends on it.
    t : float
        The time, for a plant whose derivative depends on it.

    Returns
    -------
    float
        ``C A^{n-1} B`` at the operating point.

    Raises
    ------
    ValueError
        When the relative degree at the operating point is not ``order`` (the message
        gives it and the Markov parameters that show it), when ``u`` does not reach y
        there, or for a bad argument.
    TypeError
        ``plant`` is none of the above.

    Examples
    --------
    >>> import mfcontrol
    >>> from mfcontrol.analysis.alpha import plant_alpha
    >>> plant_alpha(mfcontrol.FirstOrder(a=-1.0, b=2.5))
    2.5

    The DC motor's speed answers its voltage through the current: relative degree 2,
    alpha = Km / (J La) for n = 2, and n = 1 is refused:

    >>> motor = mfcontrol.DCMotor()
    >>> round(plant_alpha(motor, order=2), 6), round(0.05 / (5e-4 * 2e-3), 6)
    (50000.0, 50000.0)
    >>> plant_alpha(motor, order=1)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    mfcontrol.errors.ConfigError: order = 1: must be 2, the plant's relative degree at ...
    """
    order = _integer("order", order, (1, 2))
    t = _real("t", t)
    A, B, C, x_op, u_op, where = _matrices(plant, x, u, y, t)
    if not (np.isfinite(A).all() and np.isfinite(B).all() and np.isfinite(C).all()):
        raise ConfigError("plant", _Described(f"a {type(plant).__name__}"),
                          "must have a finite linearisation"
                          + (f" {where}" if where else "") + " (its parameters overflow)")
    n = A.shape[0]
    markov, bound = [], []
    Ak_B = B.copy()
    with np.errstate(all="ignore"):  # powers of A may overflow: checked below
        for k in range(max(n, order)):
            markov.append(float(C @ Ak_B))
            # what C A^k B could be: a zero is a zero against it (the Jacobians'
            # differences leave ~1e-11 of it on a nonlinear plant)
            bound.append(float(np.linalg.norm(C) * np.linalg.norm(A, 2) ** k
                               * np.linalg.norm(B)))
            Ak_B = A @ Ak_B
    if not all(math.isfinite(m) for m in markov[:order]):
        raise ConfigError("plant", _Described(f"a {type(plant).__name__}"),
                          "must have finite Markov parameters C A^k B"
                          + (f" {where}" if where else "") + " (its parameters overflow)")
    zero = [abs(m) <= 1e-7 * s for m, s in zip(markov, bound, strict=True)]
    names = ["C B", "C A B"] + [f"C A^{k} B" for k in range(2, len(markov))]
    if all(zero):
        if where:
            raise ConfigError("x", x_op, f"is an operating point where u does not reach y "
                              f"(u = {u_op:.6g}; C A^k B = 0 for every k): give another "
                              "x, u or y")
        raise ConfigError("plant", _Described(f"a {type(plant).__name__}"),
                          "must let u reach y (C A^k B = 0 for every k)")
    degree = zero.index(False) + 1
    if degree != order:
        shown = ", ".join(f"{names[k]} = {0 if zero[k] else markov[k]:.6g}"
                          for k in range(max(degree, order)))
        at = f" {where}" if where else ""
        if degree <= 2:
            # the lowest derivative that jumps, or the order's that does not
            jump = f"y{chr(39) * degree} jumps" if degree < order else \
                f"y{chr(39) * order} does not jump"
            raise ConfigError("order", order, f"must be {degree}, the plant's relative "
                              f"degree{at} ({shown}): {jump} with u")
        raise ConfigError("order", order, f"cannot fit: the plant's relative degree{at} is "
                          f"{degree} ({shown}), beyond the model's orders 1 and 2")
    return markov[order - 1]


def open_loop(plant: Any, u: npt.ArrayLike, dt: float, *, x0: npt.ArrayLike | None = None,
              t0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A plant's open-loop response to a sampled input, for :func:`estimate_alpha`.

    Parameters
    ----------
    plant : mfcontrol.Plant
        Any plant object (``step``, ``output``, ``x0``), integrated as it integrates
        itself (its ``integrator``).
    u : array_like, shape (N,)
        The input, u[k] held over [t_k, t_k + dt).
    dt : float
        The sample period, > 0.
    x0 : array_like, optional
        The initial state; the plant's ``x0`` by default.
    t0 : float
        The first sample's time.

    Returns
    -------
    t, y : numpy.ndarray
        The sample times ``t0 + k dt`` and the outputs y_k at them (measured before
        u_k acts, as in a loop).

    Raises
    ------
    FloatingPointError
        The state left the finite numbers (an unstable plant or too large an input).

    Examples
    --------
    >>> import numpy as np, mfcontrol
    >>> from mfcontrol.analysis.alpha import estimate_alpha, open_loop
    >>> plant = mfcontrol.FirstOrder(a=-2.0, b=3.0, integrator="exact")
    >>> u = np.repeat([0.0, 1.0, 0.0], 200)
    >>> t, y = open_loop(plant, u, 0.005)
    >>> round(estimate_alpha(t, y, u).alpha, 3)
    3.0
    """
    u_arr = _series("u", u)
    dt = _real("dt", dt, positive=True)
    t0 = _real("t0", t0)
    x = np.asarray(plant.x0 if x0 is None else x0, dtype=float).copy()
    t = t0 + dt * np.arange(u_arr.size)
    y = np.empty(u_arr.size)
    for k in range(u_arr.size):
        y[k] = plant.output(x)
        if not (math.isfinite(y[k]) and np.all(np.isfinite(x))):
            raise FloatingPointError(f"the plant's state is not finite at t = {t[k]:.6g} "
                                     f"(k = {k}): an unstable plant, or too large an input")
        x = plant.step(t[k], x, u_arr[k], dt)
    return t, y


# ---------------------------------------------------------------------------------------
# the backward-difference i-P's stability bound on y^(n) = beta u


class AlphaBounds(NamedTuple):
    """The open interval of alpha over which a loop is stable
    (:func:`backward_difference_bound`).

    Attributes
    ----------
    lower : float
        The loop is unstable at and below it.
    upper : float
        ... and at and above it (inf for order 1).
    """

    lower: float
    upper: float


#: the backward difference's discretisations (the algebraic estimator's delay-reduced
#: kernel has none of its own: at order 1 the backward difference is the same)
KERNELS = ("trapezoid", "held")


def _characteristic(g: float, a: float, b: float, order: int, kernel: str) -> np.ndarray:
    """The closed loop's characteristic polynomial in z (descending), g = beta / alpha,
    a = kp h^n, b = kd h^(n-1) (see :func:`backward_difference_bound`)."""
    if order == 1:
        return np.array([1.0, g * (1 + b + a) - 2.0, 1.0 - g * (1 + b)])
    q = np.array([1 + a + b, -(2 + b), 1.0])  # (D^2 + b D + a) z^2 with D = 1 - 1/z
    cubed = np.array([1.0, -3.0, 3.0, -1.0])  # (z - 1)^3
    if kernel == "trapezoid":
        return np.polyadd(np.polymul([1.0, 0.0], cubed), 0.5 * g * np.polymul([1.0, 1.0], q))
    return np.polyadd(np.polymul([2.0, 1.0], cubed), g * np.polymul([1.0, 1.0], q))


def _schur_stable(p: np.ndarray) -> bool:
    """Whether every root of p (descending, real) is inside the unit circle: the
    Schur-Cohn (Jury) recursion, ``|a_d| < |a_0|`` then the same of
    ``(a_0 p(z) - a_d z^d p(1/z)) / z``."""
    a = np.asarray(p, dtype=float)
    while a.size > 1:
        if not abs(a[-1]) < abs(a[0]):
            return False
        a = (a[0] * a - a[-1] * a[::-1])[:-1]
    return True


def _crossings(a: float, b: float, kernel: str) -> list[float]:
    """The g = beta / alpha > 0 at which a pair of the loop's poles crosses the unit
    circle (order 2), ascending. ``P(e^{iw}) = 0`` with P linear in g, so g is real there
    only where ``d = 1 - cos w`` solves a quadratic, and then follows in closed form
    (:func:`backward_difference_bound`'s Notes). Written in d rather than cos w: a small
    kp h^2 puts a crossing near z = 1, where 1 - cos w would cancel."""
    m = a + b
    if kernel == "trapezoid":
        qa, qb, qc = 2.0, 2.0 - b, a          # 2 d^2 - (2 - b) d + a = 0
    else:
        qa, qb, qc = 4.0, 6.0 + a - b, 3.0 * a  # 4 d^2 - (6 + a - b) d + 3 a = 0
    disc = qb * qb - 4.0 * qa * qc
    if not (qb > 0 and disc > 0):  # no positive pair of distinct roots
        return []
    large = (qb + math.sqrt(disc)) / (2.0 * qa)
    gs = []
    for d in (large, qc / (qa * large)):      # the small root by Vieta: no cancellation
        if not 0.0 < d < 2.0:                 # cos w in (-1, 1)
            continue
        q2 = ((2.0 + m) * d - a) ** 2 + m * m * d * (2.0 - d)  # |Q(e^{iw})|^2
        if kernel == "trapezoid":
            g = 4.0 * d * d * (b + 2.0 * d) / q2
        else:
            g = 2.0 * d * d * (a + 3.0 * b + 4.0 * d) / q2
        if g > 0:
            gs.append(g)
    return sorted(gs)


def backward_difference_bound(beta: float, kp: float, dt: float, order: int = 1, *,
                              kd: float = 0.0, kernel: str = "held"
                              ) -> AlphaBounds | None:
    """The alphas for which the i-P (i-PD) with backward differences is stable on the
    pure plant ``y^(n) = beta u`` under a zero-order hold.

    The law is mfcontrol's (:class:`mfcontrol.IP`, :class:`mfcontrol.IPD` with
    ``estimator="backward-difference"``): ``u_k = -(F_hat_k - r^(n)_k + kp e_k +
    kd (e_k - e_{k-1})/h) / alpha``, ``e = y - r``, ``y'_k = (y_k - y_{k-1})/h``,
    ``y''_k = (y_k - 2 y_{k-1} + y_{k-2})/h^2``, and

    * order 1: ``F_hat_k = y'_k - alpha u_{k-1}``;
    * order 2, ``kernel="held"`` (the laws' default): ``F_hat_k = y''_k -
      alpha (u_{k-1} + u_{k-2})/2``, the relation a held input makes exact (y''_k of the
      double integrator is ``beta (u_{k-1} + u_{k-2})/2``);
    * order 2, ``kernel="trapezoid"`` (the literature's): ``F_hat_k = y''_k -
      alpha u_{k-1}``.

    Parameters
    ----------
    beta : float
        The plant's high-frequency gain (:func:`plant_alpha`), > 0. For a plant of
        negative gain pass ``|beta|``: the bounds are then those of ``-alpha``.
    kp : float
        The proportional gain, > 0 (kp = 0 leaves a pole at z = 1: never asymptotically
        stable).
    dt : float
        The sample period h, > 0.
    order : {1, 2}
        The model order n.
    kd : float
        The derivative gain, >= 0 (an i-PD).
    kernel : {"held", "trapezoid"}
        The estimator of order 2 (above), as the laws' ``kernel``; order 1 has one
        estimator and ignores it.

    Returns
    -------
    AlphaBounds or None
        ``(lower, upper)``: the loop is stable exactly for ``lower < alpha < upper``;
        None when no alpha stabilises it (order 2 with kp, kd too large for dt).

    Notes
    -----
    With ``g = beta / alpha``, ``a = kp h^n`` and ``b = kd h^(n-1)``, the closed loop's
    characteristic polynomial is, in z,

    * order 1: ``z^2 + (g (1 + b + a) - 2) z + 1 - g (1 + b)``. The Jury conditions
      (``P(1) = g a > 0``, ``P(-1) > 0``, ``|P(0)| < 1``) give exactly
      ``alpha > beta (2 (1 + kd) + kp h) / 4`` and no upper bound; with kd = 0,
      ``beta (2 + kp h) / 4``.
    * order 2: ``z (z - 1)^3 + (g/2) (z + 1) Q(z)`` ("trapezoid") or
      ``(2 z + 1)(z - 1)^3 + g (z + 1) Q(z)`` ("held"), with
      ``Q(z) = (1 + a + b) z^2 - (2 + b) z + 1``. ``P(1) = g a`` or ``2 g a`` and
      ``P(-1) = 8`` never vanish, so the loop changes stability only where a complex pair
      crosses the circle, at ``z = e^{iw}``; P being linear in g, g is real there only
      where ``d = 1 - cos w`` solves ``2 d^2 - (2 - b) d + a = 0`` ("trapezoid") or
      ``4 d^2 - (6 + a - b) d + 3 a = 0`` ("held"), and then
      ``g = 4 d^2 (b + 2 d) / |Q|^2`` or ``g = 2 d^2 (a + 3 b + 4 d) / |Q|^2``, where
      ``|Q|^2 = ((2 + a + b) d - a)^2 + (a + b)^2 d (2 - d)``. The two crossings bound
      the stable interval (``alpha = beta / g``), checked by the Jury (Schur-Cohn) test
      between them; without two (``(2 - b)^2 <= 8 a`` for "trapezoid") no alpha is
      stable. As kp h^2 -> 0 the lower bound tends to ``beta (2 + b) / (2 (2 - b))``
      ("trapezoid": beta/2 for the i-P) and ``beta (2 + b) / (6 - b)`` ("held":
      beta/3), and the upper one to beta and ``2 beta / 3`` for the i-P, to about
      ``beta kd / (kp h)`` with kd.
      The i-P of order 2 is unstable at ``alpha = beta`` with the held kernel (its
      F_hat is then exact, and ``e'' + kp e = 0`` sampled is unstable): order 2 wants
      an i-PD.

    Examples
    --------
    >>> from mfcontrol.analysis.alpha import backward_difference_bound
    >>> b = backward_difference_bound(100.0, kp=10.0, dt=1e-3)   # beta (2 + kp h) / 4
    >>> round(b.lower, 9), b.upper
    (50.25, inf)
    >>> b = backward_difference_bound(1.0, kp=25.0, dt=0.01, order=2, kd=10.0)
    >>> round(b.lower, 4), round(b.upper, 4)
    (0.3562, 26.8717)
    >>> b = backward_difference_bound(1.0, kp=25.0, dt=0.01, order=2, kd=10.0,
    ...                               kernel="trapezoid")
    >>> round(b.lower, 4), round(b.upper, 4)
    (0.5534, 38.9216)
    """
    beta = _real("beta", beta, positive=True)
    kp = _real("kp", kp, positive=True)
    dt = _real("dt", dt, positive=True)
    order = _integer("order", order, (1, 2))
    kd = _real("kd", kd, nonnegative=True)
    if not isinstance(kernel, str) or kernel not in KERNELS:
        raise ConfigError("kernel", kernel, "must be one of " + ", ".join(KERNELS))
    a, b = kp * dt ** order, kd * dt ** (order - 1)
    if order == 1:
        return AlphaBounds(beta * (2.0 * (1.0 + b) + a) / 4.0, math.inf)
    gs = _crossings(a, b, kernel)
    if len(gs) != 2:
        return None
    g_lo, g_hi = gs
    if not _schur_stable(_characteristic(math.sqrt(g_lo * g_hi), a, b, order, kernel)):
        return None
    return AlphaBounds(beta / g_hi, beta / g_lo)


def rls_bound_problem(kp: Any, kd: Any, dt: Any, order: int, estimator: str,
                      startup: str | None, kernel: str) -> str | None:
    """Why an rls gain cannot run with these gains, or None. The rls gain drives alpha to
    the plant's own high-frequency gain beta; where the estimator of F is the backward
    difference (at least at its start), the loop must then be stable at alpha = beta,
    the exact estimate (:func:`backward_difference_bound` at beta = 1). The one statement
    of the rule: the live controllers and the configuration refuse it in their keys'
    names."""
    backward = estimator != "algebraic" or startup == "backward-difference"
    try:
        kp, kd, dt = float(kp), float(kd), float(dt)
    except (TypeError, ValueError):
        return None  # refused by name where the gains are read
    if not backward or not kp > 0.0 or not dt > 0.0 or not kd >= 0.0:
        return None
    bound = backward_difference_bound(1.0, kp, dt, order, kd=kd,
                                      kernel="trapezoid" if kernel == "trapezoid" else "held")
    where = (f"at kp = {kp:g}, kd = {kd:g}, sample time {dt:g}: lower kp (and kd) or the "
             "sample time")
    if bound is None:
        return f"no alpha keeps the backward-difference loop stable {where}"
    if not bound.lower < 1.0 < bound.upper:
        return (f"the exact estimate alpha = beta (the plant's own gain) is outside the "
                f"backward-difference loop's stable range, {bound.lower:.4g} beta < alpha "
                f"< {bound.upper:.4g} beta, {where}")
    return None


def alpha_warning(controller: Any, plant: Any) -> str | None:
    """Why an intelligent controller's alpha breaks the backward-difference bound on a
    plant, or None: the check a single run makes before it starts (it warns, then runs).

    Applies where the backward difference estimates F (``estimator="backward-difference"``,
    or the algebraic estimator with ``startup="backward-difference"``, whose first
    samples use it), with a constant gain and no compensated delay: the plant's
    high-frequency gain beta (:func:`plant_alpha` at its initial state, when its relative
    degree is the law's order) and the law's kp, kd, sample time and kernel give the
    stable range of :func:`backward_difference_bound`. That range is the loop's on the
    plant's fast part, ``y^(n) = beta u``: outside it the loop fails within a few samples
    whatever the plant's slower dynamics. None when the check does not apply or the
    plant cannot be linearised.

    Examples
    --------
    >>> import mfcontrol
    >>> from mfcontrol.analysis.alpha import alpha_warning
    >>> plant = mfcontrol.FirstOrder(a=-1.0, b=100.0)
    >>> alpha_warning(mfcontrol.IP(alpha=100.0, kp=10.0, sample_time=1e-3), plant) is None
    True
    >>> import textwrap
    >>> message = alpha_warning(mfcontrol.IP(alpha=40.0, kp=10.0, sample_time=1e-3), plant)
    >>> print(textwrap.fill(message, 88))
    alpha = 40 is outside the range over which this law's backward-difference estimate of F
    is stable on the plant's fast part y' = beta u, beta = 100 (its high-frequency gain at
    x0): alpha > 50.25 (mfcontrol.backward_difference_bound)
    """
    from ..laws import intelligent
    from ..laws import variational_gain as gain_law

    cp = getattr(controller, "_CP", None)
    if not hasattr(controller, "linear_filter") or cp is None \
            or cp.shape[0] != intelligent.N_PARAMS:
        return None
    c = cp[:, 0]
    backward = c[intelligent.EST] == intelligent.BACKWARD or (
        c[intelligent.STARTUP] == intelligent.START_BACKWARD)
    if not backward or c[gain_law.MODE] != gain_law.CONSTANT or c[intelligent.DELAY] > 0 \
            or c[intelligent.KP] <= 0.0 or c[intelligent.KD] < 0.0:
        return None
    order = int(c[intelligent.N_ORDER])
    try:
        with np.errstate(all="ignore"):  # a plant beyond floating point: no warning here
            beta = plant_alpha(plant, order)
    except (ValueError, TypeError, ArithmeticError, np.linalg.LinAlgError):
        return None  # no high-frequency gain of that order: the bound does not apply
    alpha = 1.0 / c[gain_law.INV_ALPHA]
    if not (math.isfinite(beta) and math.isfinite(alpha)):
        return None  # a plant or gain beyond floating point: the run itself says so
    kernel = "trapezoid" if c[intelligent.KERNEL] == estimators.TRAPEZOID else "held"
    model = "y' = beta u" if order == 1 else "y'' = beta u"
    where = (f"on the plant's fast part {model}, beta = {beta:.4g} (its high-frequency "
             "gain at x0)")
    if beta <= 0.0:
        return (f"alpha = {alpha:.4g} has the opposite sign of the plant's gain {where}: "
                "the backward-difference loop is unstable there for every alpha > 0")
    try:
        bound = backward_difference_bound(beta, c[intelligent.KP], controller.sample_time,
                                          order, kd=c[intelligent.KD], kernel=kernel)
    except ValueError:  # gains beyond the bound's own checks (overflowing products)
        return None
    if bound is None:
        return (f"alpha = {alpha:.4g}: no alpha makes this law's backward-difference estimate "
                f"of F stable {where} with these kp, kd and sample time "
                "(mfcontrol.backward_difference_bound)")
    if bound.lower < alpha < bound.upper:
        return None
    allowed = f"alpha > {bound.lower:.4g}" if math.isinf(bound.upper) else \
        f"{bound.lower:.4g} < alpha < {bound.upper:.4g}"
    return (f"alpha = {alpha:.4g} is outside the range over which this law's "
            f"backward-difference estimate of F is stable {where}: {allowed} "
            "(mfcontrol.backward_difference_bound)")
