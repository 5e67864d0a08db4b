"""Continuous-time SISO state-space model x' = A x + B u, y = C x, as the engine runs it.

Parameter vector (one column)::

    p[0]          n, the state size
    A_OFF ...     A, n x n, row-major
    then          B (n), C (n), and the derived Ad (n x n), Bd (n) of the zero-order-hold
                  discretisation over the sample h, recomputed by :func:`derive` after
                  every parameter change (:mod:`mfcontrol.numerics.zoh`)
    then          n values of scratch, where :func:`advance` puts the new state while it
                  still reads the old (an array allocated at every step would cost more
                  than the step, and keep a loop over a sweep's members from vectorising)

``integrator = "exact"`` steps ``x+ = Ad x + Bd u`` (:func:`advance`), exact for u held;
``"rk4"`` and ``"rk45"`` integrate :func:`rhs`.
"""

import numpy as np

from ..numerics import signatures as sig
from ..numerics import zoh

A_OFF = 1


def size(n: int) -> int:
    """Length of the parameter vector of an n-state model."""
    return A_OFF + 2 * n * n + 4 * n


def offsets(n: int) -> tuple[int, int, int, int, int]:
    """Offsets of A, B, C, Ad, Bd in the parameter vector."""
    a = A_OFF
    b = a + n * n
    c = b + n
    ad = c + n
    bd = ad + n * n
    return a, b, c, ad, bd


def pack(A: np.ndarray, B: np.ndarray, C: np.ndarray) -> np.ndarray:
    """The parameter vector of (A, B, C); Ad and Bd are left for :func:`derive`."""
    n = A.shape[0]
    p = np.zeros(size(n))
    a, b, c, _, _ = offsets(n)
    p[0] = n
    p[a:b] = A.reshape(-1)
    p[b:c] = B
    p[c:c + n] = C
    return p


def names(n: int) -> dict[str, int]:
    """Schedule names ("A[i,j]", "B[i]", "C[i]") and their entries in the vector."""
    a, b, c, _, _ = offsets(n)
    out = {f"A[{i},{j}]": a + i * n + j for i in range(n) for j in range(n)}
    out.update({f"B[{i}]": b + i for i in range(n)})
    out.update({f"C[{i}]": c + i for i in range(n)})
    return out


@sig.compiled(sig.RHS)
def rhs(t, x, u, p, dxdt, nx, np_):
    n = nx
    b = A_OFF + n * n
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += p[A_OFF + i * n + j] * x[j]
        dxdt[i] = s + p[b + i] * u


@sig.compiled(sig.OUTPUT)
def measured(x, p, nx, np_):
    n = nx
    c = A_OFF + n * n + n
    y = 0.0
    for i in range(n):
        y += p[c + i] * x[i]
    return y


@sig.compiled(sig.PREPARE)
def derive(pp, h, nx, np_):
    p = sig.vector(pp, np_)
    n = nx
    b = A_OFF + n * n
    ad = b + 2 * n
    bd = ad + n * n
    A = np.ascontiguousarray(p[A_OFF:b]).reshape((n, n))
    Ad = np.empty((n, n))
    Bd = np.empty(n)
    zoh.discretise(A, np.ascontiguousarray(p[b:b + n]), h, Ad, Bd)
    for i in range(n):
        for j in range(n):
            p[ad + i * n + j] = Ad[i, j]
        p[bd + i] = Bd[i]


@sig.compiled(sig.ADVANCE)
def advance(t, x, u, p, h, nx, np_):
    n = nx
    ad = A_OFF + 2 * n + n * n
    bd = ad + n * n
    xn = bd + n  # x is read to the end: the new state goes to the scratch first
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += p[ad + i * n + j] * x[j]
        p[xn + i] = s + p[bd + i] * u
    for i in range(n):
        x[i] = p[xn + i]
