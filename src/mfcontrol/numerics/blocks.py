"""A plant's step and output over a block of members laid out member-contiguous, the
plant's own functions compiled in: LLVM vectorises them over the members.

A block holds :data:`LANES` members; state i of member l is ``X[i, l]`` and parameter c is
``P[c, l]``, so that the same quantity of neighbouring members lies side by side. The
plant's functions are called on the column views ``X[:, l]``, ``P[:, l]`` of raw memory
(no reference counts), and the loop over the members becomes vector instructions:
measured on the DC motor of ``benchmarks/bench_engine.py``, about 6 ns per member-step on
one core against about 30 ns for the same steps member by member, and some 60 ns for
steps through the plant's compiled functions one member at a time (each RK4 a chain of
four calls that the core cannot overlap with the next member's). Each member's
arithmetic is its single run's: the one RK4 of :mod:`mfcontrol.numerics.rk4`
(:func:`~mfcontrol.numerics.rk4.half`, :func:`~mfcontrol.numerics.rk4.whole`,
:func:`~mfcontrol.numerics.rk4.combine` in the same order) or the plant's own exact step,
so a member of a block gives the bits of its single run.

The functions are built per plant, with the plant's numbers of states and parameters and
the block's size compiled in (the loops over them unrolled: measured 1.5x faster than
with the sizes as arguments): :func:`of_ode` for your own ODE (numba compiles them in
about 3 s, once per machine for functions defined in a file, then loaded from numba's
disk cache: the engine uses them for work that repays the first compilation, or once
they are compiled), :func:`of_library` for the library's plants (compiled once per
machine, then loaded from numba's disk cache).

With ``lanes=1`` the same builders give one member's step, f and g compiled in, which
returns the new state's output (signature ``MEMBER_STEP``): the member loop of a single
run calls it once a sample where the RK4 would call f four times and g once through
their addresses (measured on the DC motor of ``benchmarks/bench_single_loop.py``: about
135 -> 100 ns per sample of the whole loop).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from functools import cache
from types import ModuleType
from typing import Any, NamedTuple

import numpy as np
from numba import carray, njit

from .. import _jit
from . import rk4
from . import signatures as sig

#: members a block holds side by side
LANES = 64


class Block(NamedTuple):
    """A plant's block functions and what they were built for."""

    step: sig.Lazy
    output: sig.Lazy
    n_x: int
    n_p: int
    #: the integrator the step is: "rk4", or "exact" (the plant's own exact step)
    integrator: str = "rk4"
    #: the members a block holds: :data:`LANES`, or 1: one member's step with the plant
    #: compiled in (signature ``MEMBER_STEP``: it returns the new state's output), which
    #: the member loop calls once a sample where the RK4 calls f four times and g once
    #: through their addresses (``output`` is then not used)
    lanes: int = LANES

    @property
    def _used(self) -> tuple[sig.Lazy, ...]:
        return (self.step,) if self.lanes == 1 else (self.step, self.output)

    @property
    def cheap(self) -> bool:
        """Whether using them costs no compilation worth weighing: compiled in this
        process already, a library plant's (compiled once per machine, 2 to 3.5 s, then
        loaded from numba's disk cache in under half a second), or your own ODE's found in
        that cache (compiled on this machine before)."""
        return all(f.compiled or f.cached or f.saved for f in self._used)

    @property
    def kept(self) -> bool:
        """Whether, once compiled, they are kept in numba's disk cache: their compilation
        is paid once per machine, not once per process."""
        return all(f.kept for f in self._used)


def _inline(fn: Callable[..., Any], key: tuple | None, inline: bool = True):
    """fn compiled to be inlined (``inline=False``: called), with an identity numba's disk
    cache finds again when ``key`` (what the block functions are built for) is given."""
    d = njit(inline="always" if inline else "never", error_model="numpy")(fn)
    if key is not None:
        _jit.stable_identity(d, *key)
    return d


def _guarded(f: Callable[..., Any], g: Callable[..., Any], form: str, key: tuple | None):
    """One member's RK4 step and output that catch what your f and g raise: the state
    becomes NaN, the output NaN.

    numba catches an exception only across a call, not inside code it inlined into the
    ``try``: f and g are called here, not inlined (the slow path: a block runs it only
    after its fast step raised)."""
    fc, gc = _inline(f, key and key + ("f", "called"), False), \
        _inline(g, key and key + ("g", "called"), False)
    if form == "in-place":
        def derivative(t, x, u, p, out):
            try:
                fc(t, x, u, p, out)
                return True
            except Exception:  # noqa: BLE001 (whatever f raises: the member's state is NaN)
                out[:] = np.nan
                return False
    else:
        def derivative(t, x, u, p, out):
            try:
                d = fc(t, x, u, p)
                for i in range(out.shape[0]):
                    out[i] = d[i]
                return True
            except Exception:  # noqa: BLE001
                out[:] = np.nan
                return False

    derivative = _inline(derivative, key and key + ("guarded derivative",), False)

    def step(t, x, u, p, h, f1, f2, f3, f4, xt):
        """One RK4 step of x, u held, the arithmetic of :func:`_build`'s; NaN if f raised."""
        ok = derivative(t, x, u, p, f1)
        for i in range(x.shape[0]):
            f1[i] = h * f1[i]
            xt[i] = rk4.half(x[i], f1[i])
        ok = derivative(t + h / 2, xt, u, p, f2) and ok
        for i in range(x.shape[0]):
            f2[i] = h * f2[i]
            xt[i] = rk4.half(x[i], f2[i])
        ok = derivative(t + h / 2, xt, u, p, f3) and ok
        for i in range(x.shape[0]):
            f3[i] = h * f3[i]
            xt[i] = rk4.whole(x[i], f3[i])
        ok = derivative(t + h, xt, u, p, f4) and ok
        for i in range(x.shape[0]):
            x[i] = rk4.combine(x[i], f1[i], f2[i], f3[i], h * f4[i]) if ok else np.nan

    def output(x, p):
        try:
            return float(gc(x, p))
        except Exception:  # noqa: BLE001 (whatever g raises: the member's output is NaN)
            return np.nan

    return (_inline(step, key and key + ("guarded step",), False),
            _inline(output, key and key + ("guarded output",), False))


def _build(f: Callable[..., Any], g: Callable[..., Any], form: str, n_x: int, n_p: int,
           key: tuple | None, identity: str | None = None, lanes: int = LANES) -> Block:
    """The block functions of right-hand side (or exact step) ``f`` and output ``g``.

    ``form``: ``"in-place"``, f(t, x, u, p, dxdt); ``"returning"``, f(t, x, u, p) -> dx/dt;
    ``"library"``, f(t, x, u, p, dxdt, nx, np) and g(x, p, nx, np) as the library's plant
    functions take them (:mod:`mfcontrol.numerics.signatures`); ``"exact"``, f the
    library's exact step, advance(t, x, u, p, h, nx, np). Cached on disk with ``key``
    (numba's own key, the closures' cells pickled with identities derived from ``key``)
    or ``identity`` (:class:`mfcontrol._jit.IdentityCache`: all the compiled code
    depends on but this file, the package's own code)."""
    nx, np_, b = int(n_x), int(n_p), int(lanes)
    # your own f and g may raise (the library's functions do not): the member that raised
    # gets NaN, which the loop flags as diverged at that sample, and its block-mates their
    # own bits (numba would print the exception and go on with made-up numbers)
    guard = _guarded(f, g, form, key) if form in ("in-place", "returning") else None
    fi, gi = _inline(f, key and key + ("f",)), _inline(g, key and key + ("g",))
    if form in ("library", "exact"):
        # the library's functions take the sizes as well: given them here, they take the
        # forms below (the in-place right-hand side, the exact step, g(x, p))
        f_sized, g_sized = fi, gi

        def f_given_sizes(t, x, u, p, dxdt_or_h):
            f_sized(t, x, u, p, dxdt_or_h, nx, np_)

        def g_given_sizes(x, p):
            return g_sized(x, p, nx, np_)

        fi = _inline(f_given_sizes, key and key + ("f", "sizes"))
        gi = _inline(g_given_sizes, key and key + ("g", "sizes"))
        form = "in-place" if form == "library" else form

    if form == "in-place":
        def derivatives(t, S, U, P, F):
            for lane in range(S.shape[1]):
                fi(t, S[:, lane], U[lane], P[:, lane], F[:, lane])
    else:
        def derivatives(t, S, U, P, F):
            for lane in range(S.shape[1]):
                d = fi(t, S[:, lane], U[lane], P[:, lane])
                for i in range(S.shape[0]):
                    F[i, lane] = d[i]
    derivatives = _inline(derivatives, key and key + ("derivatives",))

    def increments(X, F, XT, h, to_end):
        for i in range(X.shape[0]):
            for lane in range(X.shape[1]):
                F[i, lane] = h * F[i, lane]
                XT[i, lane] = (rk4.whole(X[i, lane], F[i, lane]) if to_end
                               else rk4.half(X[i, lane], F[i, lane]))
    increments = _inline(increments, key and key + ("increments",))

    if b == 1:
        return _member(fi, gi, form, nx, np_, key, identity or key is not None, guard)
    if form == "exact":
        def step(t, xp, up, pp, h, wp):
            """The plant's exact step for every member of the block, its input U[l] held."""
            X = carray(xp, (nx, b), np.float64)
            U = carray(up, (b,), np.float64)
            P = carray(pp, (np_, b), np.float64)
            for lane in range(b):
                fi(t, X[:, lane], U[lane], P[:, lane], h)
    else:
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
                    X[i, lane] = rk4.combine(X[i, lane], F1[i, lane], F2[i, lane],
                                             F3[i, lane], h * F4[i, lane])

    def output(xp, pp, yp):
        """Y[l] = g(x, p) of every member of the block."""
        X = carray(xp, (nx, b), np.float64)
        P = carray(pp, (np_, b), np.float64)
        Y = carray(yp, (b,), np.float64)
        for lane in range(b):
            Y[lane] = gi(X[:, lane], P[:, lane])

    if guard is not None:
        step, output = _guard_block(step, output, guard, nx, np_, b, key)
    cache = key is not None
    return Block(sig.Lazy(sig.BLOCK_STEP, step, cache=identity or cache),
                 sig.Lazy(sig.BLOCK_OUTPUT, output, cache=identity or cache), nx, np_,
                 "exact" if form == "exact" else "rk4", b)


def _guard_block(step, output, guard, nx: int, np_: int, b: int, key: tuple | None):
    """The block's step and output, run as they are, and when your f or g raised in them,
    run again member by member through ``guard`` (:func:`_guarded`): NaN for the members
    that raised, their own bits for the others. The step writes X only after its last
    derivative, so it runs again from the same states."""
    fast_step = _inline(step, key and key + ("fast step",), False)
    fast_output = _inline(output, key and key + ("fast output",), False)
    lane_step, lane_output = guard

    def step_by_member(t, xp, up, pp, h, wp):
        X = carray(xp, (nx, b), np.float64)
        U = carray(up, (b,), np.float64)
        P = carray(pp, (np_, b), np.float64)
        W = carray(wp, (5, nx, b), np.float64)
        for lane in range(b):
            lane_step(t, X[:, lane], U[lane], P[:, lane], h, W[0][:, lane], W[1][:, lane],
                      W[2][:, lane], W[3][:, lane], W[4][:, lane])

    step_by_member = _inline(step_by_member, key and key + ("step by member",), False)

    def guarded_step(t, xp, up, pp, h, wp):
        """One RK4 step of every member of the block, its input U[l] held; a member whose
        f raised gets a NaN state."""
        try:
            fast_step(t, xp, up, pp, h, wp)
        except Exception:  # noqa: BLE001 (your f raised: again member by member)
            step_by_member(t, xp, up, pp, h, wp)

    def guarded_output(xp, pp, yp):
        """Y[l] = g(x, p) of every member of the block; NaN where g raised."""
        try:
            fast_output(xp, pp, yp)
        except Exception:  # noqa: BLE001 (your g raised: again member by member)
            X = carray(xp, (nx, b), np.float64)
            P = carray(pp, (np_, b), np.float64)
            Y = carray(yp, (b,), np.float64)
            for lane in range(b):
                Y[lane] = lane_output(X[:, lane], P[:, lane])

    return guarded_step, guarded_output


def _guard_member(step, guard, nx: int, np_: int, key: tuple | None):
    """One member's step, run as it is, and when your f or g raised in it, run again
    through ``guard`` (:func:`_guarded`) from the state it started from (kept: the step
    writes x before it calls g): a NaN state or output where the original raised."""
    fast_step = _inline(step, key and key + ("fast member step",), False)
    member_step, member_output = guard

    def guarded_step(t, xp, u, pp, h, wp):
        """One RK4 step of one member, u held; returns y of the new state (NaN, and a NaN
        state, if your f raised; NaN if your g raised)."""
        x = carray(xp, (nx,), np.float64)
        p = carray(pp, (np_,), np.float64)
        W = carray(wp, (6, nx), np.float64)
        x0 = W[5]
        for i in range(nx):
            x0[i] = x[i]
        try:
            return fast_step(t, xp, u, pp, h, wp)
        except Exception:  # noqa: BLE001 (your f or g raised: again, guarded)
            pass
        for i in range(nx):
            x[i] = x0[i]
        member_step(t, x, u, p, h, W[0], W[1], W[2], W[3], W[4])
        return member_output(x, p)

    return guarded_step


def _member(fi, gi, form: str, nx: int, np_: int, key: tuple | None,
            cache: bool | str, guard=None) -> Block:
    """One member's step (``form`` and the inlined ``fi``, ``gi`` as :func:`_build` makes
    them), returning the output of the new state: the one RK4's arithmetic
    (:func:`mfcontrol.numerics.rk4.step`, operation for operation) or the plant's exact
    step, then g."""
    if form == "exact":
        def step(t, xp, u, pp, h, wp):
            """The plant's exact step of one member; returns y of the new state."""
            x = carray(xp, (nx,), np.float64)
            p = carray(pp, (np_,), np.float64)
            fi(t, x, u, p, h)
            return gi(x, p)
    else:
        if form == "in-place":
            def derivative(t, x, u, p, out):
                fi(t, x, u, p, out)
        else:
            def derivative(t, x, u, p, out):
                d = fi(t, x, u, p)
                for i in range(nx):
                    out[i] = d[i]
        derivative = _inline(derivative, key and key + ("derivative",))

        def step(t, xp, u, pp, h, wp):
            """One RK4 step of one member, u held; returns y of the new state."""
            x = carray(xp, (nx,), np.float64)
            p = carray(pp, (np_,), np.float64)
            W = carray(wp, (5, nx), np.float64)
            f1, f2, f3, f4, xt = W[0], W[1], W[2], W[3], W[4]
            derivative(t, x, u, p, f1)
            for i in range(nx):
                f1[i] = h * f1[i]
                xt[i] = rk4.half(x[i], f1[i])
            derivative(t + h / 2, xt, u, p, f2)
            for i in range(nx):
                f2[i] = h * f2[i]
                xt[i] = rk4.half(x[i], f2[i])
            derivative(t + h / 2, xt, u, p, f3)
            for i in range(nx):
                f3[i] = h * f3[i]
                xt[i] = rk4.whole(x[i], f3[i])
            derivative(t + h, xt, u, p, f4)
            for i in range(nx):
                x[i] = rk4.combine(x[i], f1[i], f2[i], f3[i], h * f4[i])
            return gi(x, p)

        if guard is not None:
            step = _guard_member(step, guard, nx, np_, key)

    def output(xp, pp, yp):
        """Not used (the step returns y)."""

    return Block(sig.Lazy(sig.MEMBER_STEP, step, cache=cache),
                 sig.Lazy(sig.BLOCK_OUTPUT, output, cache=False), nx, np_,
                 "exact" if form == "exact" else "rk4", 1)


#: block functions of your own ODEs built in this process, by what they depend on
_RECENT = _jit.Recent()


def of_ode(f: Callable[..., Any], g: Callable[..., Any], in_place: bool, n_x: int,
           n_p: int, identity: str | None = None, on_disk: bool = False,
           lanes: int = LANES) -> Block:
    """The block functions of your own ODE: right-hand side ``f`` (in place,
    ``f(t, x, u, p, dxdt)``, or returning, ``f(t, x, u, p)``), output ``g(x, p)``, n_x
    states and n_p parameters, as :class:`~mfcontrol.numerics.signatures.Lazy`
    C-callables of the signatures ``BLOCK_STEP`` and ``BLOCK_OUTPUT``, compiled on first
    use.

    ``identity``: a digest of all that f and g compile from
    (:func:`mfcontrol.plants.ode.identity`); every call with it, the same form and sizes
    gets the same functions in this process (compiled once), and with ``on_disk`` they
    are kept in numba's disk cache under it (compiled once per machine). None: new
    functions, compiled on first use in this process."""
    form = "in-place" if in_place else "returning"
    nx, np_ = int(n_x), int(n_p)
    if identity is None:
        return _build(f, g, form, nx, np_, None, lanes=lanes)
    key = _digest(identity, form, nx, np_, lanes, "rk4")
    return _RECENT.get((key, on_disk), lambda: _build(f, g, form, nx, np_, None,
                                                      key if on_disk else None, lanes))


def _digest(*parts: Any) -> str:
    return hashlib.sha256(repr(parts).encode()).hexdigest()


@cache
def of_library(module: ModuleType, integrator: str, n_x: int, n_p: int,
               lanes: int = LANES) -> Block | None:
    """The block functions of a library plant (a module of :mod:`mfcontrol.plants`, its
    ``rhs``, ``measured`` and, for ``integrator="exact"``, ``advance``), or None where
    the plant has none for that integrator (``"rk45"``). Compiled once per machine, then
    loaded from numba's disk cache."""
    key = (module.__name__, integrator, int(n_x), int(n_p)) + ((lanes,) if lanes != LANES else ())
    if integrator == "rk4":
        return _build(module.rhs.py_func, module.measured.py_func, "library", n_x, n_p, key,
                      lanes=lanes)
    if integrator == "exact" and hasattr(module, "advance"):
        return _build(module.advance.py_func, module.measured.py_func, "exact", n_x, n_p,
                      key, lanes=lanes)
    return None
