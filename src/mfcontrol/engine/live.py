"""Compiled entry points for controllers driven one sample at a time from Python.

One numba call per sample: the argument list is kept short and scalar so that the call
costs little more than numba's own dispatch.
"""

import numba
import numpy as np

from .._jit import kernel_jit, step_jit
from ..laws import adrc, intelligent, pid, recursive_ip, variational_gain

_ENTRY_POINTS: dict = {}


def entry_point(kernel, *args):
    """``kernel``'s compiled code for the types of ``args``, called without numba's
    per-call dispatch (which types every argument again: about a third of a live call).
    A controller passes its own arrays, whose types never change, so the code found here
    stays right for every later call. Where nothing is compiled (``NUMBA_DISABLE_JIT``)
    the kernel itself is returned."""
    types = tuple(numba.typeof(a) for a in args)
    fn = _ENTRY_POINTS.get((kernel, types))
    if fn is None:
        if hasattr(kernel, "overloads"):
            if types not in kernel.overloads:
                kernel.compile(types)
            fn = kernel.overloads[types].entry_point
        else:  # a plain Python function
            fn = kernel
        _ENTRY_POINTS[kernel, types] = fn
    return fn


@step_jit
def _copy(src, dst):
    for i in range(src.size):
        dst[i] = src[i]


@step_jit
def _kept_if_finite(u, CS, backup, nan_row):
    """u when it and the whole memory after the step are finite (row ``nan_row`` may be
    NaN: the PID's used-up start; -1 for none), else NaN with the state restored from
    ``backup``. The memory is checked, not only u: a limited u is finite while an overflowed
    integral or derivative behind it is not, and a sample let into the memory that way made
    every later step overflow (the controller never recovered)."""
    ok = np.isfinite(u)
    if ok:
        for i in range(CS.shape[0]):
            v = CS[i, 0]
            if not np.isfinite(v) and not (i == nan_row and v != v):
                ok = False
                break
    if ok:
        return u
    _copy(backup, CS[:, 0])
    return np.nan


@kernel_jit
def intelligent_step(CP, CS, backup, y, r, dt, alpha):
    """One sample of an intelligent controller (member 0); ``alpha`` is used in external
    gain mode only. A step that overflows (finite but huge inputs can: a non-finite output or
    memory) leaves the state as it was and returns NaN, for the caller to hold its last
    output."""
    _copy(CS[:, 0], backup)
    # read in that mode only: the state stays the engine's
    if CP[variational_gain.MODE, 0] == variational_gain.EXTERNAL:
        CS[variational_gain.ALPHA_EXT, 0] = alpha
    return _kept_if_finite(intelligent.step(CP, CS, 0, y, r, dt), CS, backup, -1)


@kernel_jit
def intelligent_reset(CP, CS):
    intelligent.reset(CP, CS, 0)


@kernel_jit
def recursive_step(CP, CS, backup, y, r):
    """One sample of the paper's recursive i-P (member 0): (u_raw, applied, gain, gamma);
    a step that overflows restores the state and returns NaNs, as above."""
    _copy(CS[:, 0], backup)
    u, applied, g, gamma = recursive_ip.step(CP, CS, 0, y, r)
    if np.isnan(_kept_if_finite(u * 0.0 + applied, CS, backup, -1)):  # u or applied not finite
        return np.nan, np.nan, np.nan, np.nan
    return u, applied, g, gamma


@kernel_jit
def recursive_reset(CP, CS):
    recursive_ip.reset(CP, CS, 0)


@kernel_jit
def pid_step(CP, CS, backup, y, r, dt):
    """One sample of a PID (member 0); a step that overflows restores the state and
    returns NaN, as above."""
    _copy(CS[:, 0], backup)
    return _kept_if_finite(pid.step(CP, CS, 0, y, r, dt), CS, backup, pid.START)


@kernel_jit
def pid_reset(CS, start):
    pid.reset(CS, 0, start)


@kernel_jit
def adrc_step(CP, CS, backup, y, r, dt):
    """One sample of an ADRC (member 0); a step that overflows restores the state and
    returns NaN, as above."""
    _copy(CS[:, 0], backup)
    return _kept_if_finite(adrc.step(CP, CS, 0, y, r, dt), CS, backup, adrc.START)


@kernel_jit
def adrc_reset(CP, CS, start):
    adrc.reset(CP, CS, 0, start)


@kernel_jit
def intelligent_pure(CP, state, y, r, dt, alpha):
    """The step as a pure function of (state, inputs): (u, next state); ``state`` unchanged."""
    CS = state.copy().reshape((state.size, 1))
    if CP[variational_gain.MODE, 0] == variational_gain.EXTERNAL:
        CS[variational_gain.ALPHA_EXT, 0] = alpha
    u = intelligent.step(CP, CS, 0, y, r, dt)
    return u, CS[:, 0]


@kernel_jit
def pid_pure(CP, state, y, r, dt):
    CS = state.copy().reshape((state.size, 1))
    u = pid.step(CP, CS, 0, y, r, dt)
    return u, CS[:, 0]


@kernel_jit
def adrc_pure(CP, state, y, r, dt):
    CS = state.copy().reshape((state.size, 1))
    u = adrc.step(CP, CS, 0, y, r, dt)
    return u, CS[:, 0]


@kernel_jit
def recursive_pure(CP, state, y, r):
    CS = state.copy().reshape((state.size, 1))
    _, applied, _, _ = recursive_ip.step(CP, CS, 0, y, r)
    return applied, CS[:, 0]
