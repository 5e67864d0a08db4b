"""Zero-order-hold discretisation of x' = A x + B u: ``x+ = Ad x + Bd u`` with
``[[Ad, Bd], [0, 1]] = expm([[A, B], [0, 0]] h)``.

Compiled, because a scheduled change of A or B inside a run recomputes it there. The
matrix exponential is the scaling-and-squaring Pade method (Higham, *SIAM J. Matrix Anal.
Appl.* 26, 2005) with the [13/13] approximant, as ``scipy.linalg.expm`` computes it for
matrices of larger norm: tested against ``scipy.linalg.expm`` and
``scipy.signal.cont2discrete`` to 1e-12.
"""

import math

import numpy as np

from .._jit import kernel_jit

# the [13/13] Pade approximant of exp (Higham 2005, Table 2.3): b_0 .. b_13
_B13 = (64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0,
        129060195264000.0, 10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0,
        40840800.0, 960960.0, 16380.0, 182.0, 1.0)
#: the 1-norm up to which [13/13] is accurate to double precision unscaled (Higham's theta_13)
THETA_13 = 5.371920351148152


@kernel_jit
def expm(M):
    """exp(M) of a square float64 matrix: scaling so that ||M||_1 <= theta_13, the [13/13]
    Pade approximant, then squaring (Higham 2005, the algorithm of scipy.linalg.expm for
    matrices of that norm)."""
    n = M.shape[0]
    norm = 0.0
    for j in range(n):
        s = 0.0
        for i in range(n):
            s += abs(M[i, j])
        norm = max(norm, s)
    squarings = 0
    if norm > THETA_13:
        squarings = int(math.ceil(math.log2(norm / THETA_13)))
    A = np.ascontiguousarray(M / (2.0 ** squarings))
    b = _B13
    eye = np.eye(n)
    A2 = A @ A
    A4 = A2 @ A2
    A6 = A4 @ A2
    U = A @ (A6 @ (b[13] * A6 + b[11] * A4 + b[9] * A2)
             + b[7] * A6 + b[5] * A4 + b[3] * A2 + b[1] * eye)
    V = (A6 @ (b[12] * A6 + b[10] * A4 + b[8] * A2)
         + b[6] * A6 + b[4] * A4 + b[2] * A2 + b[0] * eye)
    E = np.ascontiguousarray(np.linalg.solve(V - U, V + U))  # solve returns Fortran order
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
