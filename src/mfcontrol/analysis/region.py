"""Many loops at once: the spectral radius, Ms and the peak noise gain of many laws'
filters around one sampled plant, vectorised (a stability region of 40,000 cells is a few
stacked eigenvalue problems and one polynomial evaluation on a grid, not 40,000 loops).

The same quantities as :meth:`mfcontrol.analysis.loop.LinearLoop.margins` takes one loop
at a time: the poles are the eigenvalues of the closed loop's state space
(:func:`~mfcontrol.analysis.loop.closed_loop`, stacked and taken in batches), the peaks
the maxima of ``|S|`` and ``|C_y S|`` over a grid of frequencies, the plant's response
computed once (coarser than the one loop's grid: ``tests/analysis/test_region.py`` holds
the two together, to 1e-3 with 2,000 points).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .filters import LinearFilter
from .loop import LinearLoop, closed_loop, frequencies

#: closed-loop matrices whose eigenvalues are taken in one call (memory: BATCH d^2 floats)
BATCH = 1024


def _stacked(polys: Sequence[np.ndarray]) -> np.ndarray:
    """Polynomials (ascending) as the rows of one array, zero-padded."""
    width = max(p.size for p in polys)
    out = np.zeros((len(polys), width))
    for i, p in enumerate(polys):
        out[i, :p.size] = p
    return out


def _evaluated(coef: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Each row of ``coef`` (ascending) evaluated at every point of ``q`` (on the unit
    circle): (rows, points), as two real matrix products with the powers of q."""
    powers = q[None, :] ** np.arange(coef.shape[1])[:, None]
    return coef @ powers.real + 1j * (coef @ powers.imag)


def spectral_radii(matrices: np.ndarray) -> np.ndarray:
    """The largest modulus of an eigenvalue of each matrix of a stack (rows, d, d), in
    batches of :data:`BATCH` on every core."""
    out = np.zeros(matrices.shape[0])

    def radii(start: int) -> None:
        with np.errstate(all="ignore"):
            eig = np.linalg.eigvals(matrices[start:start + BATCH])
        out[start:start + eig.shape[0]] = np.abs(eig).max(axis=1, initial=0.0)

    # LAPACK releases the interpreter's lock: the batches run on every core
    starts = range(0, matrices.shape[0], BATCH)
    if len(starts) == 1:
        radii(0)
    else:
        with ThreadPoolExecutor(max_workers=min(len(starts), os.cpu_count() or 1)) as pool:
            list(pool.map(radii, starts))
    return out


def loops(filters: Sequence[LinearFilter], plant: LinearLoop,
          points: int = 400) -> dict[str, np.ndarray]:
    """``spectral_radius``, ``stable``, ``Ms`` and ``noise_gain_peak`` of each filter closed
    around the sampled plant and the delay of ``plant`` (a loop built once: its plant's
    state space and frequency response serve every filter), the peaks over ``points``
    frequencies log-spaced over the five decades below the Nyquist frequency."""
    dt = plant.controller.dt
    if any(not math.isclose(f.dt, dt, rel_tol=1e-12) for f in filters):
        raise ValueError("filters: must share the plant's sample time")
    closed = [closed_loop(*plant.plant_matrices, plant.delay, f)[0] for f in filters]
    # one size for the stack: a smaller loop padded with zero rows and columns (poles at
    # z = 0, which do not move the radius)
    size = max(m.shape[0] for m in closed)
    stack = np.zeros((len(closed), size, size))
    for i, m in enumerate(closed):
        stack[i, :m.shape[0], :m.shape[0]] = m
    radius = spectral_radii(stack)
    omega = frequencies(dt, points)
    q = np.exp(-1j * omega * dt)
    p = plant.plant_response(omega)
    with np.errstate(all="ignore"):
        c_y = _evaluated(_stacked([f.b_y for f in filters]), q) \
            / _evaluated(_stacked([f.a for f in filters]), q)
        s = 1.0 / (1.0 - c_y * p)
        ms = np.abs(s).max(axis=1)
        noise = np.abs(c_y * s).max(axis=1)
    return {"spectral_radius": radius, "stable": radius < 1.0, "Ms": ms,
            "noise_gain_peak": noise}
