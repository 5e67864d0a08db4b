"""Zero-order-hold discretisation of x' = A x + B u: ``x+ = Ad x + Bd u`` with
``[[Ad, Bd], [0, 1]] = expm([[A, B], [0, 0]] h)``.

Compiled, because a scheduled change of A or B inside a run recomputes it there. The
matrix exponential is the scaling-and-squaring Pade method (Higham, *SIAM J. Matrix Anal.
Appl.* 26, 2005) with the [6/6] approximant after scaling to ``||M||_1 <= 1/2``, where its
truncation error is below 1e-17: tested against ``scipy.linalg.expm`` and
``scipy.signal.cont2discrete`` to 1e-12.
"""

import math

import numpy as np

from .._jit import kernel_jit

# [6/6] Pade coefficients of exp: c_k = (12 - k)! 6! / (12! k! (6 - k)!)
_PADE6 = (1.0, 1 / 2, 5 / 44, 1 / 66, 1 / 792, 1 / 15840, 1 / 665280)


@kernel_jit
def expm(M):
    """exp(M) of a square float64 matrix."""
    n = M.shape[0]
    norm = 0.0
    for j in range(n):
        s = 0.0
        for i in range(n):
            s += abs(M[i, j])
        norm = max(norm, s)
    squarings = 0
    if norm > 0.5:
        squarings = int(math.ceil(math.log2(norm / 0.5)))
    X = M / (2.0 ** squarings)
    eye = np.eye(n)
    P = eye.copy()  # X^k, k = 0..6
    N = _PADE6[0] * eye
    D = _PADE6[0] * eye
    sign = 1.0
    for k in range(1, 7):
        P = P @ X
        sign = -sign
        N = N + _PADE6[k] * P
        D = D + (sign * _PADE6[k]) * P
    E = np.ascontiguousarray(np.linalg.solve(D, N))  # solve returns Fortran order
    for _ in range(squarings):
        E = E @ E
    return E


@kernel_jit
def discretise(A, B, h, Ad, Bd):
    """Ad, Bd (written in place) of x' = A x + B u over a sample h, u held."""
    n = A.shape[0]
    M = np.zeros((n + 1, n + 1))
    for i in range(n):
        for j in range(n):
            M[i, j] = A[i, j] * h
        M[i, n] = B[i] * h
    E = expm(M)
    for i in range(n):
        for j in range(n):
            Ad[i, j] = E[i, j]
        Bd[i] = E[i, n]
