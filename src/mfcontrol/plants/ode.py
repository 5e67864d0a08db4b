"""Your own ODE x' = f(t, x, u, p), y = g(x, p), compiled for the engine.

``f`` comes in two forms, told apart by the number of its parameters:

* in place, ``f(t, x, u, p, dxdt)``: writes dx/dt into ``dxdt`` and returns nothing. No
  allocation per call: the fast form, the one the speed figures are for;
* returning, ``f(t, x, u, p) -> dx/dt`` (an array, list or tuple; python-control's
  ``updfcn`` form): each call builds its result, which costs an allocation for an array.

``g(x, p)`` returns the measured output. ``t``, ``u`` are floats, ``x``, ``p``, ``dxdt``
float64 arrays. Plain Python functions that numba can compile are compiled here; a
``numba.njit`` function is compiled again with the engine's signature. Anything numba
cannot compile raises :class:`NotCompilable`, and the caller runs the plant through the
Python driver instead.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

from numba import cfunc, njit
from numba.core.errors import NumbaError

from ..numerics import signatures as sig


class NotCompilable(Exception):
    """numba could not compile the plant's functions (the reason is the message)."""


def python_function(fn: Callable[..., Any]) -> Callable[..., Any]:
    """The Python function behind ``fn`` (a numba dispatcher's ``py_func``)."""
    return getattr(fn, "py_func", fn)


def arity(fn: Callable[..., Any]) -> int:
    """Number of positional parameters of ``fn`` (of its Python function)."""
    params = inspect.signature(python_function(fn)).parameters.values()
    return sum(p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) for p in params)


def compile_functions(f: Callable[..., Any], g: Callable[..., Any]):
    """(rhs, output) compiled with the engine's signatures; NotCompilable if numba cannot."""
    n_f = arity(f)
    if n_f not in (4, 5):
        raise TypeError(f"f must take (t, x, u, p) and return dx/dt, or (t, x, u, p, dxdt) "
                        f"and write it; it takes {n_f} parameters")
    if arity(g) != 2:
        raise TypeError("g must take (x, p) and return the output")
    try:
        inner = njit(error_model="numpy")(python_function(f))
        if n_f == 5:
            @cfunc(sig.RHS, error_model="numpy")
            def rhs(t, xp, u, pp, dp, nx, np_):
                inner(t, sig.vector(xp, nx), u, sig.vector(pp, np_), sig.vector(dp, nx))
        else:
            @cfunc(sig.RHS, error_model="numpy")
            def rhs(t, xp, u, pp, dp, nx, np_):
                d = inner(t, sig.vector(xp, nx), u, sig.vector(pp, np_))
                for i in range(nx):
                    dp[i] = d[i]

        inner_g = njit(error_model="numpy")(python_function(g))

        @cfunc(sig.OUTPUT, error_model="numpy")
        def output(xp, pp, nx, np_):
            return float(inner_g(sig.vector(xp, nx), sig.vector(pp, np_)))
    except NumbaError as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise NotCompilable(first) from exc
    return rhs, output
