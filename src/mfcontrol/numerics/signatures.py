"""The compiled signatures of a plant's functions, as the engine calls them.

A plant is four functions over plain float64 arrays (``x`` the state, ``p`` the parameter
vector)::

    rhs(t, x, u, p, dxdt)      dx/dt written into dxdt (in place: no allocation per call)
    output(x, p) -> y          the measured output
    prepare(p, h)              derived coefficients, after any parameter change
    advance(t, x, u, p, h)     an exact step over [t, t + h] with u held (integrator "exact")

The compiled forms are C-callable (``numba.cfunc``) and reach the engine as their
addresses, which the kernel turns back into functions (:func:`as_rhs` and its siblings).
So one compiled kernel serves every plant, built-in or yours, and is cached on disk: a new
plant compiles its own small functions, never the kernel. (numba's own first-class
function arguments cost 40 to 120 us of dispatch per kernel call, more than a short run;
an integer address costs nothing.) A C call passes plain values, so each array is a data
pointer with its size, ``nx`` (state) or ``np`` (parameters); :func:`vector` rebuilds the
array view. Their signatures, in that order::

    rhs(t, x*, u, p*, dxdt*, nx, np)
    output(x*, p*, nx, np) -> y
    prepare(p*, h, nx, np)
    advance(t, x*, u, p*, h, nx, np)
"""

from typing import Any

import numpy as np
from numba import carray, njit, types
from numba.core import cgutils, sigutils
from numba.core.ccallback import CFunc
from numba.core.errors import NumbaError, UnsupportedBytecodeError
from numba.extending import intrinsic

from .. import _jit

_ptr = types.CPointer(types.float64)
_n = types.int64

RHS = types.void(types.float64, _ptr, types.float64, _ptr, _ptr, _n, _n)
OUTPUT = types.float64(_ptr, _ptr, _n, _n)
PREPARE = types.void(_ptr, types.float64, _n, _n)
ADVANCE = types.void(types.float64, _ptr, types.float64, _ptr, types.float64, _n, _n)
#: a block of members laid out member-contiguous (:mod:`mfcontrol.numerics.blocks`),
#: its sizes compiled in
BLOCK_STEP = types.void(types.float64, _ptr, _ptr, _ptr, types.float64, _ptr)
BLOCK_OUTPUT = types.void(_ptr, _ptr, _ptr)
#: one member's step with the plant compiled in, returning the output of the new state:
#: (t, x*, u, p*, h, scratch*) -> y
MEMBER_STEP = types.float64(types.float64, _ptr, types.float64, _ptr, types.float64, _ptr)

#: what numba raises when it cannot compile a function: its own errors, and the bytecode
#: it does not take (an ``import`` inside f, say), which is not one of them
COMPILE_ERRORS = (NumbaError, UnsupportedBytecodeError)

RHS_T = types.FunctionType(RHS)
OUTPUT_T = types.FunctionType(OUTPUT)
PREPARE_T = types.FunctionType(PREPARE)
ADVANCE_T = types.FunctionType(ADVANCE)
BLOCK_STEP_T = types.FunctionType(BLOCK_STEP)
BLOCK_OUTPUT_T = types.FunctionType(BLOCK_OUTPUT)
MEMBER_STEP_T = types.FunctionType(MEMBER_STEP)


class Lazy:
    """A C-callable compiled (or loaded from numba's disk cache) on first use, so that
    importing the package does not load every plant's code.

    ``cache``: True, kept in numba's disk cache under numba's own key (the function's
    bytecode and its closure's cells, pickled: the library's functions, compiled once
    per machine); a string, kept there under this identity instead
    (:class:`mfcontrol._jit.IdentityCache`: your own ODE's, whose cells hold your
    functions); False, compiled in every process."""

    def __init__(self, sig, py_func, cache: bool | str = True):
        self._sig = sig
        self.py_func = py_func
        self._cache = cache
        self._compiled = None
        self._error = None
        self._saved = False
        self.__doc__ = py_func.__doc__
        self.__name__ = py_func.__name__

    @property
    def compiled(self) -> bool:
        """Whether it has been compiled (or loaded) in this process."""
        return self._compiled is not None

    @property
    def cached(self) -> bool:
        """Whether it is one of the library's functions, kept in numba's disk cache: compiled
        once per machine, so counted as there from the start."""
        return self._cache is True

    @property
    def kept(self) -> bool:
        """Whether, once compiled, it is kept in numba's disk cache for later processes (a
        library function, or one of your own with an identity: defined in a file)."""
        return self._cache is not False

    @property
    def saved(self) -> bool:
        """Whether its compiled code is in numba's disk cache now: the cache's index looked
        up, nothing loaded or compiled (your own ODE's, once compiled on this machine)."""
        if not self._saved and self._cache is not False and self._error is None:
            try:
                probe = self._probe()
                key = probe._cache._index_key(probe._sig,
                                              probe._targetdescr.target_context.codegen())
                self._saved = key in probe._cache._cache_file._load_index()
            except Exception:  # noqa: BLE001 (numba's cache internals moved: not saved)
                self._saved = False
        return self._saved

    @property
    def failed(self) -> bool:
        """Whether numba could not compile it (then :attr:`cfunc` raises that again)."""
        return self._error is not None

    def _probe(self) -> Any:
        """The C callable (a numba CFunc, whose cache internals it reaches: Any), not
        compiled yet, with its disk cache (if any)."""
        fn: Any = CFunc(self.py_func, sigutils.normalize_signature(self._sig), {},
                   {"error_model": "numpy"})
        if isinstance(self._cache, str):
            fn._cache = _jit.IdentityCache(self.py_func, self._cache)
        elif self._cache:
            fn.enable_caching()
        return fn

    @property
    def cfunc(self):
        if self._error is not None:
            raise self._error
        if self._compiled is None:
            try:
                fn = self._probe()
                fn.compile()
            except COMPILE_ERRORS as exc:
                self._error = exc
                raise
            self._compiled = fn
        return self._compiled

    @property
    def address(self) -> int:
        """The function's address, for the engine."""
        return self.cfunc.address


def compiled(sig):
    """Decorator of a library plant function: a C-callable with ``sig``, compiled on first
    use and cached on disk; the engine takes its ``.address``."""
    return lambda py_func: Lazy(sig, py_func)


def _caster(function_type):
    @intrinsic
    def cast(typingctx, address):
        """The function at ``address`` (an integer), callable in compiled code."""
        def codegen(context, builder, signature, args):
            fn = cgutils.create_struct_proxy(function_type)(context, builder)
            fn.c_addr = builder.inttoptr(args[0], cgutils.voidptr_t)
            fn.py_addr = cgutils.get_null_value(cgutils.voidptr_t)
            fn.jit_addr = cgutils.get_null_value(cgutils.voidptr_t)
            return fn._getvalue()

        return function_type(types.intp), codegen

    return cast


as_rhs = _caster(RHS_T)
as_output = _caster(OUTPUT_T)
as_prepare = _caster(PREPARE_T)
as_advance = _caster(ADVANCE_T)
as_block_step = _caster(BLOCK_STEP_T)
as_block_output = _caster(BLOCK_OUTPUT_T)
as_member_step = _caster(MEMBER_STEP_T)


@intrinsic
def pointer(typingctx, arr):
    """The data pointer of a contiguous float64 array, for the calls above (a strided view
    would hand the callee the wrong elements: it does not type)."""
    if not isinstance(arr, types.Array) or arr.dtype != types.float64 or arr.layout != "C":
        return None

    def codegen(context, builder, signature, args):
        return context.make_array(signature.args[0])(context, builder, args[0]).data

    return _ptr(arr), codegen


@intrinsic
def offset(typingctx, ptr, n):
    """The pointer ``n`` floats past ``ptr``."""
    if ptr != _ptr or not isinstance(n, types.Integer):
        return None

    def codegen(context, builder, signature, args):
        return builder.gep(args[0], [args[1]])

    return _ptr(ptr, n), codegen


@njit(inline="always")
def vector(ptr, n):
    """The array view of n floats at ptr."""
    return carray(ptr, (n,), np.float64)


@compiled(PREPARE)
def no_prepare(p, h, nx, np_):
    """For plants with nothing derived from their parameters."""


@compiled(ADVANCE)
def no_advance(t, x, u, p, h, nx, np_):
    """For plants without an exact step (the engine never calls it for them)."""


# one call of a plant's functions from Python (plant objects, tests): by address, like
# the engine; rk4 and the exact step are the engine's own


@njit(error_model="numpy", cache=True)
def call_rhs(rhs, t, x, u, p):
    """dx/dt from the compiled rhs at ``rhs`` (an address)."""
    out = np.empty(x.size)
    as_rhs(rhs)(t, pointer(x), u, pointer(p), pointer(out), x.size, p.size)
    return out


@njit(error_model="numpy", cache=True)
def call_output(output, x, p):
    return as_output(output)(pointer(x), pointer(p), x.size, p.size)


@njit(error_model="numpy", cache=True)
def call_prepare(prepare, p, h, nx):
    as_prepare(prepare)(pointer(p), h, nx, p.size)


@njit(error_model="numpy", cache=True)
def call_advance(advance, t, x, u, p, h):
    as_advance(advance)(t, pointer(x), u, pointer(p), h, x.size, p.size)
