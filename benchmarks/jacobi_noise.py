"""The delay-reduced kernel's noise gain for each Jacobi weight (kappa, mu) and lag.

The standard deviation of F_hat under white sensor noise on y is sigma times the root
sum of squares of the y weights (:func:`mfcontrol.laws.estimators.weights`); printed as
its ratio to the held kernel's at the same window, for M = 20 (the figures of
docs/theory.md; ``tests/laws/test_estimators.py`` holds them to this table). The lags:
0 (the newest sample), M/4, M/2 and the weight's own mean position (``mean``: the
minimal, q = 0, estimator of the weight). No timing: the figures are exact arithmetic.

    python benchmarks/jacobi_noise.py [M]
"""

import sys

import numpy as np

from mfcontrol.laws import estimators


def noise_ratio(M: int, kappa: int, mu: int, lag: float) -> float:
    """The delay-reduced kernel's noise gain over the held kernel's, window M."""
    wy = estimators.weights(1, M, 1.0, 1.0, "delay-reduced", lag, kappa, mu)[0]
    held = estimators.weights(1, M, 1.0, 1.0, "held")[0]
    return float(np.sqrt(np.sum(wy**2) / np.sum(held**2)))


def mean_lag(M: int, kappa: int, mu: int) -> float:
    """lag at the weight's mean position (the q = 0 estimator)."""
    x = np.arange(M) + 0.5 - 0.5 * M
    w = (0.5 * M - x) ** kappa * (0.5 * M + x) ** mu
    return float(0.5 * M - (w * x).sum() / w.sum())


def table(M: int = 20) -> list[tuple[int, int, float, float, float, float, float]]:
    """Rows (kappa, mu, mean lag, ratio at lag 0, M/4, M/2, mean lag)."""
    rows = []
    for kappa in range(estimators.MAX_JACOBI + 1):
        for mu in range(estimators.MAX_JACOBI + 1 - kappa):
            m = mean_lag(M, kappa, mu)
            rows.append((kappa, mu, m, *(noise_ratio(M, kappa, mu, lag)
                                         for lag in (0.0, 0.25 * M, 0.5 * M, m))))
    return rows


if __name__ == "__main__":
    M = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    print(f"M = {M}: noise std over the held kernel's")
    print("| kappa | mu | mean lag | lag 0 | lag M/4 | lag M/2 | lag = mean |")
    print("|---|---|---|---|---|---|---|")
    for kappa, mu, m, *r in table(M):
        print(f"| {kappa} | {mu} | {m:.2f} | " + " | ".join(f"{x:.2f}" for x in r) + " |")
