"""The RK4 step and the output of a block of members laid out member-contiguous, the
plant's own f and g compiled in: LLVM vectorises them over the members.

A block holds :data:`LANES` members; state i of member l is ``X[i, l]`` and parameter c is
``P[c, l]``, so that the same quantity of neighbouring members lies side by side. f and g
are called on the column views ``X[:, l]``, ``P[:, l]`` of raw memory (no reference
counts), and the loop over the members becomes vector instructions: measured on the
DC motor of ``benchmarks/bench_engine.py``, about 6 ns per member-step on one core
against about 30 ns for the same steps member by member. Each member's arithmetic is
the one RK4 of :mod:`mfcontrol.numerics.rk4` (:func:`~mfcontrol.numerics.rk4.half`,
:func:`~mfcontrol.numerics.rk4.whole`, :func:`~mfcontrol.numerics.rk4.combine` in the same
order), so a member of a block gives the bits of its single run.

The two functions are built per plant (:func:`compiled`), with the plant's numbers of
states and parameters and the block's size compiled in (the loops over them unrolled:
measured 1.5x faster than with the sizes as arguments): numba compiles them in about
3 s, once per plant and process, which is why the engine uses them only for work that
repays it (:func:`mfcontrol.engine.compose.run`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from numba import carray, njit

from . import signatures as sig
from .rk4 import combine, half, whole

#: members a block holds side by side
LANES = 64


class Block(NamedTuple):
    """A plant's block functions and the sizes compiled into them."""

    step: sig.Lazy
    output: sig.Lazy
    n_x: int
    n_p: int


def compiled(f: Callable[..., Any], g: Callable[..., Any], in_place: bool, n_x: int,
             n_p: int):
    """(step, output): the block functions of the plant with right-hand side ``f`` (in
    place, ``f(t, x, u, p, dxdt)``, or returning, ``f(t, x, u, p)``), output ``g(x, p)``,
    n_x states and n_p parameters, as :class:`~mfcontrol.numerics.signatures.Lazy`
    C-callables of the signatures ``BLOCK_STEP`` and ``BLOCK_OUTPUT`` (a :class:`Block`);
    compiled on first use, not cached."""
    nx, np_, b = int(n_x), int(n_p), LANES
    fi = njit(inline="always", error_model="numpy")(f)
    gi = njit(inline="always", error_model="numpy")(g)

    if in_place:
        @njit(inline="always", error_model="numpy")
        def derivatives(t, S, U, P, F):
            for lane in range(S.shape[1]):
                fi(t, S[:, lane], U[lane], P[:, lane], F[:, lane])
    else:
        @njit(inline="always", error_model="numpy")
        def derivatives(t, S, U, P, F):
            for lane in range(S.shape[1]):
                d = fi(t, S[:, lane], U[lane], P[:, lane])
                for i in range(S.shape[0]):
                    F[i, lane] = d[i]

    @njit(inline="always", error_model="numpy")
    def increments(X, F, XT, h, to_end):
        for i in range(X.shape[0]):
            for lane in range(X.shape[1]):
                F[i, lane] = h * F[i, lane]
                XT[i, lane] = (whole(X[i, lane], F[i, lane]) if to_end
                               else half(X[i, lane], F[i, lane]))

    def step(t, xp, up, pp, h, wp):
        """One RK4 step of every member of the block, its input U[l] held."""
        X = carray(xp, (nx, b), np.float64)
        U = carray(up, (b,), np.float64)
        P = carray(pp, (np_, b), np.float64)
        W = carray(wp, (5, nx, b), np.float64)
        F1, F2, F3, F4, XT = W[0], W[1], W[2], W[3], W[4]
        derivatives(t, X, U, P, F1)
        increments(X, F1, XT, h, False)
        derivatives(t + h / 2, XT, U, P, F2)
        increments(X, F2, XT, h, False)
        derivatives(t + h / 2, XT, U, P, F3)
        increments(X, F3, XT, h, True)
        derivatives(t + h, XT, U, P, F4)
        for i in range(nx):
            for lane in range(b):
                X[i, lane] = combine(X[i, lane], F1[i, lane], F2[i, lane], F3[i, lane],
                                     h * F4[i, lane])

    def output(xp, pp, yp):
        """Y[l] = g(x, p) of every member of the block."""
        X = carray(xp, (nx, b), np.float64)
        P = carray(pp, (np_, b), np.float64)
        Y = carray(yp, (b,), np.float64)
        for lane in range(b):
            Y[lane] = gi(X[:, lane], P[:, lane])

    return Block(sig.Lazy(sig.BLOCK_STEP, step, cache=False),
                 sig.Lazy(sig.BLOCK_OUTPUT, output, cache=False), nx, np_)
