"""A plant as the sampled loop sees it: linearised at an operating point, then stepped
from sample to sample as the engine integrates it.

Any plant with ``derivative(t, x, u)``, ``output(x)`` and ``x0`` (every
:class:`mfcontrol.Plant`) is linearised by central differences around an operating
point, by default the steady state whose output is a given level (:func:`steady_state`).
The continuous linearisation ``x' = A x + B u, y = C x`` is then made discrete over one
sample the way the engine integrates the plant (:func:`discretise`): the zero-order hold
for ``integrator="exact"``, RK4's own linear map for ``"rk4"`` (one RK4 step of a linear
system is the fourth-order Taylor polynomial of the exponential, so the analysis holds
the loop the engine runs, not an idealisation of it), ``substeps`` of them per sample.

At an equilibrium the Jacobian of one RK4 step of the nonlinear plant is RK4's map of its
linearisation (every stage sits at the equilibrium), so the two routes agree.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..numerics import zoh

Derivative = Callable[[float, np.ndarray, float], np.ndarray]
Output = Callable[[np.ndarray], float]


def _steps(x: np.ndarray, u: float) -> tuple[np.ndarray, float]:
    """Central-difference steps: relative to each value, at least an absolute floor
    (a cube root of the machine epsilon balances truncation and rounding)."""
    rel = np.finfo(float).eps ** (1.0 / 3.0)
    return rel * np.maximum(np.abs(x), 1.0), rel * max(abs(u), 1.0)


def jacobians(derivative: Derivative, output: Output, x: np.ndarray, u: float,
              t: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C)``: the plant's linearisation at state ``x`` and input ``u`` (time
    ``t``), ``A = df/dx``, ``B = df/du``, ``C = dg/dx``, by central differences (exact to
    rounding where the plant is linear)."""
    x = np.asarray(x, dtype=float)
    n = x.size
    dx, du = _steps(x, u)
    A, C = np.empty((n, n)), np.empty(n)
    for i in range(n):
        e = np.zeros(n)
        e[i] = dx[i]
        A[:, i] = (np.asarray(derivative(t, x + e, u)) - np.asarray(derivative(t, x - e, u))) \
            / (2.0 * dx[i])
        C[i] = (output(x + e) - output(x - e)) / (2.0 * dx[i])
    B = (np.asarray(derivative(t, x, u + du)) - np.asarray(derivative(t, x, u - du))) / (2 * du)
    return A, B, C


def steady_state(derivative: Derivative, output: Output, y: float, x_guess: np.ndarray,
                 u_guesses: tuple[float, ...] = (0.0,), t: float = 0.0
                 ) -> tuple[np.ndarray, float] | None:
    """The equilibrium ``f(x, u) = 0`` whose output ``g(x)`` is ``y``; None when none is
    found. Searched from each input in ``u_guesses`` in turn (``scipy.optimize.root``,
    Powell's hybrid method), from ``x_guess`` and then from the equilibrium under that
    input alone: a converter's output, flat at zero current, needs a start where it is
    not."""
    from scipy.optimize import root

    x_guess = np.asarray(x_guess, dtype=float)
    n = x_guess.size
    for u0 in u_guesses:
        with np.errstate(all="ignore"):
            # the derivative's size at the start: what "at rest" is measured against
            size = max(float(np.abs(np.asarray(derivative(t, x_guess, u0))).max()), 1.0)

            def held(x: np.ndarray, u0: float = u0) -> np.ndarray:
                return np.asarray(derivative(t, x, u0), dtype=float)

            def residual(z: np.ndarray) -> np.ndarray:
                f = np.asarray(derivative(t, z[:n], z[n]), dtype=float)
                return np.append(f, output(z[:n]) - y)

            first = root(held, x_guess, method="hybr", tol=1e-12)
            for x_start in (x_guess, first.x):
                sol = root(residual, np.append(x_start, u0), method="hybr", tol=1e-12)
                # the solver's own test is relative to its steps: hold the point to the
                # equations
                r = residual(sol.x)
                if np.all(np.isfinite(r)) and np.abs(r[:n]).max() <= 1e-9 * size \
                        and abs(r[n]) <= 1e-9 * max(abs(y), 1.0):
                    return sol.x[:n].copy(), float(sol.x[n])
    return None


def discretise(A: np.ndarray, B: np.ndarray, h: float, integrator: str = "exact",
               substeps: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """``(Ad, Bd)`` of ``x_{k+1} = Ad x_k + Bd u_k`` over one sample period ``h``, the
    input held, as the engine integrates: ``substeps`` steps of ``h / substeps``, each the
    zero-order hold (``"exact"``, and ``"rk45"``, whose tolerances make it that to about
    1e-9) or one RK4 step (``"rk4"``)."""
    A = np.ascontiguousarray(A, dtype=float)
    B = np.ascontiguousarray(np.reshape(B, -1), dtype=float)
    n = A.shape[0]
    hs = h / substeps
    if integrator == "rk4":
        M = hs * A
        eye = np.eye(n)
        M2 = M @ M
        M3 = M2 @ M
        ad = eye + M + M2 / 2.0 + M3 / 6.0 + M3 @ M / 24.0
        bd = hs * (eye + M / 2.0 + M2 / 6.0 + M3 / 24.0) @ B
    elif integrator in ("exact", "rk45"):
        ad, bd = np.empty_like(A), np.empty_like(B)
        zoh.discretise(A, B, float(hs), ad, bd)
    else:
        raise ValueError(f"integrator = {integrator!r}: must be one of exact, rk4, rk45")
    Ad, Bd = np.eye(n), np.zeros(n)
    for _ in range(substeps):  # the input held across the substeps
        Ad, Bd = ad @ Ad, ad @ Bd + bd
    return Ad, Bd


def is_linear(derivative: Derivative, output: Output, points: list[tuple[np.ndarray, float]],
              t: float = 0.0, rtol: float = 1e-6,
              first: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> bool:
    """Whether the plant's Jacobians are the same at every one of ``points`` (state,
    input), to ``rtol`` of their size: the linearisation then holds everywhere.
    ``first``: the Jacobians at ``points[0]`` when the caller has them already."""
    if first is None:
        first = jacobians(derivative, output, *points[0], t=t)
    for x, u in points[1:]:
        other = jacobians(derivative, output, x, u, t=t)
        for a, b in zip(first, other, strict=True):
            size = max(np.abs(a).max(initial=0.0), np.abs(b).max(initial=0.0), math.ulp(1.0))
            if np.abs(a - b).max(initial=0.0) > rtol * size:
                return False
    return True
