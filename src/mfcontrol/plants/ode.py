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

What compiles when. The compiled functions are known by :func:`identity`, a digest of
all that numba compiles from f and g: their bytecode and source, the values of the
globals they read (numba freezes those as constants when it compiles), their defaults,
and the same of the jit functions and classes of yours they call, wherever those are
defined. A new plant object from functions of the same identity takes the functions
already compiled in the process. Where f and g and everything they call are defined in
a file and close over no values, the compiled functions are kept in numba's disk cache
under that identity: compiled once per machine, then loaded. Any change to what they
compile from, in their file or another, gives a new identity, compiled anew; none can
load the old code. Functions defined in a REPL or by ``exec`` (no source file) and
closures compile once per process (closures vary freely with their values: each would
leave files in the cache). numba's own ``cache=True`` differs in two ways: it drops a
function's cache when the function's file changes (here an edit elsewhere in the file
keeps it, an edit of what f or g compile from does not), and it loads the value a
global had when compiled even if the global has since changed in another process (it
sees edits of the file only, not of another module or of a value computed at import);
here the value is part of the identity. What the identity does not follow: functions of
installed packages and the standard library (known by name: their code changes with
their version, which numba's key does not hold either).
"""

from __future__ import annotations

import enum
import hashlib
import inspect
import os
import sys
import sysconfig
from collections.abc import Callable
from types import CodeType, FunctionType, ModuleType
from typing import Any

import numpy as np
from numba import njit
from numba.core import types as nb_types
from numba.core.dispatcher import Dispatcher

from .. import _jit
from ..numerics import signatures as sig

#: what :func:`identity` hashes first: a new recipe gives new identities
_RECIPE = "mfcontrol ODE identity 1"


class NotCompilable(Exception):
    """numba could not compile the plant's functions (the reason is the message)."""


def python_function(fn: Callable[..., Any]) -> Callable[..., Any]:
    """The Python function behind ``fn`` (a numba dispatcher's ``py_func``)."""
    return getattr(fn, "py_func", fn)


def arity(fn: Callable[..., Any]) -> int:
    """Number of positional parameters of ``fn`` (of its Python function)."""
    params = inspect.signature(python_function(fn)).parameters.values()
    return sum(p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) for p in params)


# ---------------------------------------------------------------------------------------------
# identity


def identity(f: Callable[..., Any], g: Callable[..., Any]) -> tuple[str, bool] | None:
    """A digest of all that numba compiles from f and g, and whether their compiled code
    may be kept in numba's disk cache under it (f, g and the functions of yours they call
    all defined in a file, closing over no values); None where something they read has
    no reproducible description (an object numba would have to freeze that is neither a
    number, string, array, tuple, enum member nor a function or class): then they compile
    once per plant object, as numba does for a new function."""
    walk = _Walk()
    try:
        text = "\n".join((_RECIPE, walk.function(python_function(f)),
                          walk.function(python_function(g))))
    except (_Unknown, RecursionError):
        return None
    return hashlib.sha256(text.encode()).hexdigest(), walk.on_disk


class _Unknown(Exception):
    """A value with no reproducible description."""


def _library_roots() -> tuple[str, ...]:
    paths = sysconfig.get_paths()
    return tuple({os.path.realpath(paths[k]) + os.sep
                  for k in ("stdlib", "platstdlib", "purelib", "platlib") if k in paths})


#: where the standard library and installed packages live
_LIBRARY = _library_roots()


def _in_library(module: ModuleType | None) -> bool:
    """Whether ``module`` is the standard library's or an installed package's."""
    if module is None:
        return False
    file = getattr(module, "__file__", None)
    if file is None:
        return module.__name__ in sys.builtin_module_names
    return os.path.realpath(file).startswith(_LIBRARY)


def _name(obj: Any) -> str:
    return f"{getattr(obj, '__module__', None)}.{getattr(obj, '__qualname__', None)}"


def _hash(text: str | bytes) -> str:
    return hashlib.sha256(text.encode() if isinstance(text, str) else text).hexdigest()


def _names(code: CodeType) -> set[str]:
    """The global and attribute names ``code`` reads, nested functions' included."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, CodeType):
            names |= _names(const)
    return names


class _Walk:
    """Describes functions and the values they read, reproducibly from process to process
    (nothing that varies with the process: no addresses, no set order)."""

    def __init__(self) -> None:
        self.seen: set[int] = set()
        #: every function walked is in a file and a closure over nothing
        self.on_disk = True

    def function(self, fn: Any) -> str:
        if not isinstance(fn, FunctionType):
            raise _Unknown(type(fn).__name__)
        if id(fn) in self.seen:  # recursion, or a helper called twice
            return "again " + _name(fn)
        self.seen.add(id(fn))
        code = fn.__code__
        parts = [_name(fn), self.code(code), self.value(fn.__defaults__),
                 self.value(fn.__kwdefaults__)]
        if fn.__closure__:
            self.on_disk = False
            try:
                parts += [self.value(cell.cell_contents) for cell in fn.__closure__]
            except ValueError:  # an empty cell
                raise _Unknown("empty cell") from None
        try:
            if not os.path.isfile(code.co_filename):
                raise OSError(code.co_filename)
            parts.append(_hash(inspect.getsource(fn)))
        except (OSError, TypeError):
            self.on_disk = False  # a REPL's or exec's: its code is all there is
        if sys.modules.get(fn.__module__) is None:
            # a module gone from sys.modules (runpy.run_path's, once it returns): numba
            # names it "<dynamic>" in the compiled code's environment, which no later
            # process can import, so an entry kept on disk would fail to load there
            self.on_disk = False
        names = sorted(_names(code))
        for name in names:
            if name in fn.__globals__:
                value = fn.__globals__[name]
                parts.append(f"{name}={self.value(value)}")
                if isinstance(value, ModuleType) and not _in_library(value):
                    # a module of yours: the constants and functions read from it
                    attrs = vars(value)
                    parts += [f"{name}.{a}={self.value(attrs[a])}" for a in names
                              if a in attrs]
        return f"function({'; '.join(parts)})"

    def code(self, code: CodeType) -> str:
        shape = (code.co_argcount, code.co_posonlyargcount, code.co_kwonlyargcount,
                 code.co_flags, code.co_names, code.co_varnames, code.co_freevars,
                 code.co_cellvars)
        parts = [code.co_code.hex(), repr(shape),
                 getattr(code, "co_exceptiontable", b"").hex()]
        parts += [self.value(const) for const in code.co_consts]
        return f"code({'; '.join(parts)})"

    def value(self, v: Any) -> str:
        if v is None or v is Ellipsis or isinstance(v, bool | int | float | complex | str
                                                     | bytes):
            return f"{type(v).__name__}:{v!r}"
        if isinstance(v, CodeType):
            return self.code(v)
        if isinstance(v, np.ndarray):
            if v.dtype.hasobject:
                raise _Unknown("object array")
            return f"array({v.dtype.str}, {v.shape}, {_hash(np.ascontiguousarray(v).tobytes())})"
        if isinstance(v, np.generic):
            return f"{v.dtype.str}:{v!r}"
        if isinstance(v, enum.Enum):
            return f"{_name(type(v))}.{v.name}={self.value(v.value)}"
        if isinstance(v, tuple | list):
            return f"{_name(type(v))}({', '.join(self.value(x) for x in v)})"
        if isinstance(v, set | frozenset):
            return f"{type(v).__name__}({', '.join(sorted(self.value(x) for x in v))})"
        if isinstance(v, dict):
            return f"dict({', '.join(sorted(self.value(kv) for kv in v.items()))})"
        if isinstance(v, Dispatcher):  # a jit function of yours: its options and its code
            return f"jit({self.value(v.targetoptions)}, {self.function(v.py_func)})"
        if isinstance(v, FunctionType) and not _in_library(sys.modules.get(v.__module__)):
            return self.function(v)
        if isinstance(v, ModuleType):
            return "module " + v.__name__
        if isinstance(v, nb_types.Type):
            return f"numba type {v}"
        library = _in_library(sys.modules.get(getattr(v, "__module__", None) or ""))
        if isinstance(v, type) and not library:  # a class of yours (a jitclass, say)
            try:
                return f"class {_name(v)} {_hash(inspect.getsource(v))}"
            except (OSError, TypeError):
                raise _Unknown(_name(v)) from None
        if library and hasattr(v, "__name__"):
            return "library " + _name(v)  # numpy's and math's functions, classes, ufuncs
        raise _Unknown(type(v).__name__)


# ---------------------------------------------------------------------------------------------
# compiling


#: single-run functions of your own ODEs compiled in this process, by identity
_RECENT = _jit.Recent()


def compile_functions(f: Callable[..., Any], g: Callable[..., Any],
                      identity: str | None = None, on_disk: bool = False):
    """(rhs, output) compiled with the engine's signatures
    (:class:`~mfcontrol.numerics.signatures.Lazy`); NotCompilable if numba cannot.

    ``identity`` (:func:`identity`): every call with it gets the same functions in this
    process, compiled once; with ``on_disk`` they are kept in numba's disk cache under
    it. None: compiled anew."""
    n_f = arity(f)
    if n_f not in (4, 5):
        raise TypeError(f"f must take (t, x, u, p) and return dx/dt, or (t, x, u, p, dxdt) "
                        f"and write it; it takes {n_f} parameters")
    if arity(g) != 2:
        raise TypeError("g must take (x, p) and return the output")
    if identity is None:
        return _compile(f, g, n_f == 5, False)
    return _RECENT.get((identity, on_disk),
                       lambda: _compile(f, g, n_f == 5, identity if on_disk else False))


def _compile(f: Callable[..., Any], g: Callable[..., Any], in_place: bool,
             cache: str | bool):
    # f and g are called, not inlined, inside a try: what they raise makes the derivative
    # or the output NaN, which the loop flags as diverged at that sample (a C callable
    # cannot raise: numba would print the exception and go on with made-up numbers)
    inner = njit(error_model="numpy", inline="never")(python_function(f))
    if in_place:
        def rhs(t, xp, u, pp, dp, nx, np_):
            try:
                inner(t, sig.vector(xp, nx), u, sig.vector(pp, np_), sig.vector(dp, nx))
            except Exception:  # noqa: BLE001 (whatever f raises)
                for i in range(nx):
                    dp[i] = np.nan
    else:
        def rhs(t, xp, u, pp, dp, nx, np_):
            try:
                d = inner(t, sig.vector(xp, nx), u, sig.vector(pp, np_))
                for i in range(nx):
                    dp[i] = d[i]
            except Exception:  # noqa: BLE001 (whatever f raises)
                for i in range(nx):
                    dp[i] = np.nan

    inner_g = njit(error_model="numpy", inline="never")(python_function(g))

    def output(xp, pp, nx, np_):
        try:
            return float(inner_g(sig.vector(xp, nx), sig.vector(pp, np_)))
        except Exception:  # noqa: BLE001 (whatever g raises)
            return np.nan

    functions = sig.Lazy(sig.RHS, rhs, cache), sig.Lazy(sig.OUTPUT, output, cache)
    try:
        for fn in functions:
            fn.cfunc  # noqa: B018 (compiled or loaded now: a failure is told here, not mid-run)
    except sig.COMPILE_ERRORS as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise NotCompilable(first) from exc
    return functions
