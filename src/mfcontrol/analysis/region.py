"""Many loops at once: the spectral radius, Ms and the peak noise gain of many laws'
filters around one sampled plant, vectorised (a stability region of 40,000 cells is a few
stacked eigenvalue problems and one polynomial evaluation on a grid, not 40,000 loops).

The same quantities as :meth:`mfcontrol.analysis.loop.LinearLoop.margins` takes one loop
at a time: the poles are the roots of ``A D_p - B_y N_p`` (here the eigenvalues of its
companion matrices, in batches), the peaks are the maxima of ``|S| = |A D_p / char|`` and
``|C_y S| = |B_y D_p / char|`` over a grid of frequencies (coarser than the one loop's:
``tests/analysis/test_region.py`` holds the two together, to 1e-3 with 2,000 points).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numpy.polynomial import polynomial as poly

from .filters import LinearFilter

#: companion matrices whose eigenvalues are taken in one call (memory: BATCH d^2 floats)
BATCH = 1024


def _stacked(polys: Sequence[np.ndarray]) -> np.ndarray:
    """Polynomials (ascending) as the rows of one array, zero-padded."""
    width = max(p.size for p in polys)
    out = np.zeros((len(polys), width))
    for i, p in enumerate(polys):
        out[i, :p.size] = p
    return out


def _difference(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a - b, polynomials (ascending) of any lengths."""
    out = np.zeros(max(a.size, b.size))
    out[:a.size] += a
    out[:b.size] -= b
    return out


def _evaluated(coef: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Each row of ``coef`` (ascending) evaluated at every point of ``q`` (on the unit
    circle): (rows, points), as two real matrix products with the powers of q."""
    powers = q[None, :] ** np.arange(coef.shape[1])[:, None]
    return coef @ powers.real + 1j * (coef @ powers.imag)


def spectral_radii(characteristic: np.ndarray) -> np.ndarray:
    """The largest modulus of a root in z of each row of ``characteristic``: polynomials in
    q = z^-1, ascending, each with a nonzero constant term."""
    c = characteristic / characteristic[:, :1]
    # trailing zero coefficients are roots at z = 0: they do not move the radius
    d = max(int(np.max(np.nonzero(np.any(c != 0.0, axis=0))[0])), 0)
    out = np.zeros(c.shape[0])
    if d == 0:
        return out

    def radii(start: int) -> None:
        rows = c[start:start + BATCH, 1:d + 1]
        comp = np.zeros((rows.shape[0], d, d))
        comp[:, 0, :] = -rows  # z^d + c_1 z^(d-1) + ... + c_d
        idx = np.arange(d - 1)
        comp[:, idx + 1, idx] = 1.0
        with np.errstate(all="ignore"):
            eig = np.linalg.eigvals(comp)
        out[start:start + rows.shape[0]] = np.abs(eig).max(axis=1)

    # LAPACK releases the interpreter's lock: the batches run on every core
    starts = range(0, c.shape[0], BATCH)
    if len(starts) == 1:
        radii(0)
    else:
        with ThreadPoolExecutor(max_workers=min(len(starts), os.cpu_count() or 1)) as pool:
            list(pool.map(radii, starts))
    return out


def loops(filters: Sequence[LinearFilter], num: np.ndarray, den: np.ndarray,
          points: int = 400) -> dict[str, np.ndarray]:
    """``spectral_radius``, ``stable``, ``Ms`` and ``noise_gain_peak`` of each filter closed
    around the plant ``N_p / D_p`` (its polynomials in q, the loop's delay in ``num``, as
    :attr:`LinearLoop.plant_polynomials` gives them), the peaks over ``points``
    frequencies log-spaced over the five decades below the Nyquist frequency."""
    dt = filters[0].dt
    if any(not math.isclose(f.dt, dt, rel_tol=1e-12) for f in filters):
        raise ValueError("filters: must share one sample time")
    a = _stacked([f.a for f in filters])
    b_y = _stacked([f.b_y for f in filters])
    char = _stacked([_difference(np.convolve(f.a, den), np.convolve(f.b_y, num))
                     for f in filters])
    radius = spectral_radii(char)
    nyquist = math.pi / dt
    omega = np.logspace(math.log10(nyquist) - 5, math.log10(nyquist), points)
    q = np.exp(-1j * omega * dt)
    d_p = poly.polyval(q, den)
    ch = _evaluated(char, q)
    with np.errstate(all="ignore"):
        ms = np.abs(_evaluated(a, q) * d_p / ch).max(axis=1)
        noise = np.abs(_evaluated(b_y, q) * d_p / ch).max(axis=1)
    return {"spectral_radius": radius, "stable": radius < 1.0, "Ms": ms,
            "noise_gain_peak": noise}
