"""Discrete linear ADRC written from the papers in matrix form, independently of
:mod:`mfcontrol.laws.adrc`: the extended state observer's continuous matrices (Gao 2003),
their zero-order hold by the matrix exponential of the augmented matrix (Miklosovic,
Radke and Gao 2006), the current observer's gain placed by Ackermann's formula with every
eigenvalue at exp(-wo h) (Herbst 2013), and the bandwidth-parameterised control law.
Used by the tests only; slow and plain on purpose."""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
import scipy.signal


def matrices(order: int, b0: float, h: float):
    """(Ad, Bd, C) of the ESO of order ``order`` at sample period h, by expm."""
    m = order + 1
    A = np.diag(np.ones(m - 1), 1)  # the chain of integrators, f constant
    B = np.zeros((m, 1))
    B[order - 1, 0] = b0
    aug = np.zeros((m + 1, m + 1))
    aug[:m, :m] = A
    aug[:m, m:] = B
    e = scipy.linalg.expm(aug * h)
    C = np.zeros((1, m))
    C[0, 0] = 1.0
    return e[:m, :m], e[:m, m:], C


def current_observer_gain(Ad: np.ndarray, C: np.ndarray, beta: float) -> np.ndarray:
    """L with every eigenvalue of (I - L C) Ad at beta: the eigenvalues of Ad - Ad L C
    (its transpose's: Ad^T - C^T (Ad L)^T) placed by Ackermann's formula on the pair
    (Ad^T, C^T); L = Ad^-1 (Ad L). (I - L C) Ad and Ad (I - L C) = Ad - Ad L C are
    similar, so their eigenvalues agree."""
    m = Ad.shape[0]
    At, Ct = Ad.T, C.T
    ctrb = np.hstack([np.linalg.matrix_power(At, i) @ Ct for i in range(m)])
    coeffs = np.poly(np.full(m, beta))  # (z - beta)^m
    phi = sum(c * np.linalg.matrix_power(At, m - i) for i, c in enumerate(coeffs))
    k = np.zeros((1, m))
    k[0, -1] = 1.0
    gain = k @ np.linalg.solve(ctrb, phi)  # Ackermann: Ad^T - Ct gain has the poles
    return np.linalg.solve(Ad, gain.T)


def control_row(order: int, wc: float, b0: float) -> tuple[np.ndarray, float]:
    """(K, k_r): v = k_r r - K x."""
    if order == 1:
        kp = wc
        K = np.array([kp, 1.0])
    else:
        kp, kd = wc * wc, 2.0 * wc
        K = np.array([kp, kd, 1.0])
    return K / b0, kp / b0


def reference_adrc(ys, rs, h, order, b0, wc, wo, lo=-math.inf, hi=math.inf, delay=0,
                   start=None):
    """The outputs u_k for the measurements ys and setpoints rs."""
    Ad, Bd, C = matrices(order, b0, h)
    L = current_observer_gain(Ad, C, math.exp(-wo * h))
    K, kr = control_row(order, wc, b0)
    m = order + 1
    z = np.zeros(m)
    z[0] = ys[0]
    held = 0.0 if start is None else start
    past = [held] * delay  # the outputs in flight, oldest first
    out = []
    for k, (y, r) in enumerate(zip(ys, rs, strict=True)):
        x = z + L[:, 0] * (y - z[0])
        if k == 0 and start is not None:  # f set so that v is the held output
            x[-1] = 0.0
            x[-1] = b0 * (kr * r - K @ x - start)
        v = kr * r - K @ x
        u = min(max(v, lo), hi)
        past.append(u)
        u_obs = past.pop(0)
        z = Ad @ x + Bd[:, 0] * u_obs
        out.append(u)
    return np.array(out)


def transfer_functions(order, b0, wc, wo, h):
    """The unlimited controller as two discrete transfer functions (C_y, C_r), u = C_y y +
    C_r r, as scipy's (num, den) in descending powers of z: the current-observer state
    space of (y, r) to u, converted by scipy.signal.ss2tf (Herbst's transfer-function
    form, computed rather than transcribed)."""
    Ad, Bd, C = matrices(order, b0, h)
    L = current_observer_gain(Ad, C, math.exp(-wo * h))
    K, kr = control_row(order, wc, b0)
    m = order + 1
    M = np.eye(m) - L @ C  # x = M z + L y
    # u = -K M z - K L y + kr r ; z+ = Ad x + Bd u
    Cc = -K[None, :] @ M
    Dc = np.array([[-(K @ L[:, 0]), kr]])
    Ac = Ad @ M + Bd @ Cc
    Bc = np.hstack([Ad @ L + Bd * Dc[0, 0], Bd * Dc[0, 1]])
    out = []
    for i in range(2):
        num, den = scipy.signal.ss2tf(Ac, Bc, Cc, Dc, input=i)
        out.append((num[0], den))
    return out
