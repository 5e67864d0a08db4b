"""Running error analysis (Higham, *Accuracy and Stability of Numerical Algorithms*, 3.3)
of a law evaluated in float: the bound the float export is held to.

Each operation the law performs, z = x op y, is rounded in float: fl(z) = z (1 + d) with
|d| <= u = 2^-24; so are the inputs, the parameters and the sample time where float
cannot hold them. To first order in u, the output's error is the sum over all those
roundings of (d out / d z) z d, so::

    |u_float - u_double| <= u * sum over rounded values z of |d out / d z| |z|

The run records every operation on a tape with its partial derivatives; the adjoints
d out / d z come from one reverse sweep per output checked. Signed sensitivities keep
the cancellation of the laws' recurrences (the i-P's u_{k-1} - gamma (alpha u_{k-1} ...),
the variational gain's 2 gamma_{k-1} - gamma_{k-2}), which a bound propagated in absolute
values loses: that one grows geometrically and says nothing. The bound holds as long as
the float and the double evaluation take the same branches (a clip near its limit may
not). The law runs from its own source
(the numba functions' Python), with ``float()`` made to return a carried value; plain
Python numbers (integers, the estimator's window constants) are taken to be exact in float,
true for windows up to 128 samples.
"""

from __future__ import annotations

import math
import types

import numpy as np

U_FLOAT = 2.0 ** -24


def _inexact(v: float) -> bool:
    return math.isfinite(v) and float(np.float32(v)) != v


class Tape:
    """Every rounded operation of a run: its value and its partial derivatives."""

    def __init__(self):
        self.parents: list[tuple] = []  # per node: ((parent, d node / d parent), ...)
        self.size: list[float] = []  # per node: |value| if rounding it is an error, else 0

    def node(self, value: float, rounded: bool, *links) -> int:
        self.parents.append(links)
        self.size.append(abs(value) if rounded else 0.0)
        return len(self.size) - 1

    def bound(self, out: int) -> float:
        """sum over nodes of |d out / d node| |node|: the first-order bound, in units of u,
        on the error of node ``out`` (reverse accumulation of the adjoints)."""
        adj = np.zeros(out + 1)
        adj[out] = 1.0
        total = 0.0
        for i in range(out, -1, -1):
            a = adj[i]
            if a == 0.0:
                continue
            total += abs(a) * self.size[i]
            for parent, d in self.parents[i]:
                adj[parent] += a * d
        return total


TAPE = Tape()


class Carried:
    """A double value and its node on the tape (its float rounding error's history)."""

    __slots__ = ("v", "i")

    def __init__(self, v, i=None):
        self.v = float(v)
        # a fresh value: an input, parameter or constant, rounded when float cannot hold it
        self.i = TAPE.node(self.v, _inexact(self.v)) if i is None else i

    @staticmethod
    def of(x):
        return x if isinstance(x, Carried) else Carried(x)

    def __add__(self, other):
        o = Carried.of(other)
        v = self.v + o.v
        return Carried(v, TAPE.node(v, True, (self.i, 1.0), (o.i, 1.0)))

    __radd__ = __add__

    def __sub__(self, other):
        o = Carried.of(other)
        v = self.v - o.v
        return Carried(v, TAPE.node(v, True, (self.i, 1.0), (o.i, -1.0)))

    def __rsub__(self, other):
        return Carried.of(other) - self

    def __mul__(self, other):
        o = Carried.of(other)
        v = self.v * o.v
        return Carried(v, TAPE.node(v, True, (self.i, o.v), (o.i, self.v)))

    __rmul__ = __mul__

    def __truediv__(self, other):
        o = Carried.of(other)
        v = self.v / o.v
        return Carried(v, TAPE.node(v, True, (self.i, 1.0 / o.v), (o.i, -v / o.v)))

    def __rtruediv__(self, other):
        return Carried.of(other) / self

    def __neg__(self):
        return Carried(-self.v, TAPE.node(-self.v, False, (self.i, -1.0)))

    def __abs__(self):  # exact, as a negation: no rounding of its own
        return -self if self.v < 0.0 else self

    def __float__(self):
        return self.v

    def __int__(self):
        return int(self.v)

    def __eq__(self, o):
        return self.v == float(o)

    def __ne__(self, o):
        return self.v != float(o)

    def __lt__(self, o):
        return self.v < float(o)

    def __le__(self, o):
        return self.v <= float(o)

    def __gt__(self, o):
        return self.v > float(o)

    def __ge__(self, o):
        return self.v >= float(o)

    __hash__ = None


class _Math:
    """The math module with exp on carried values (one rounding of the C library's exp,
    whose float version is within about half an ulp)."""

    def __getattr__(self, name):
        return getattr(math, name)

    @staticmethod
    def exp(x):
        x = Carried.of(x)
        v = math.exp(x.v)
        return Carried(v, TAPE.node(v, True, (x.i, v)))


class _Module:
    """A law module whose compiled functions are replaced by their carried Python."""

    def __init__(self, module):
        self._module = module

    def __getattr__(self, name):
        return _replace(getattr(self._module, name))


def _replace(value):
    if hasattr(value, "py_func"):
        return python_of(value)
    if isinstance(value, types.ModuleType) and value.__name__.startswith("mfcontrol."):
        return _Module(value)
    if value is math:
        return _Math()
    return value


_PYTHON: dict = {}


def python_of(fn):
    """``fn``'s Python source as a function over carried values (calls followed)."""
    py = getattr(fn, "py_func", fn)
    if py not in _PYTHON:
        g: dict = {}
        _PYTHON[py] = types.FunctionType(py.__code__, g, py.__name__, py.__defaults__,
                                         py.__closure__)
        # filled after registering: the module's functions refer to one another
        g.update({name: _replace(value) for name, value in py.__globals__.items()
                  if not name.startswith("__") or name == "__builtins__"})
        g["float"] = Carried
        g["to_fixed_tuple"] = lambda column, n: tuple(column)
    return _PYTHON[py]


def carried_outputs(ctrl, law, y, r, every: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The law of live controller ``ctrl`` (fresh) run on the tape on samples (y, r),
    every one finite: (the double outputs, the bound in units of u of every ``every``-th
    output's float error, NaN for the others)."""
    global TAPE
    TAPE = Tape()
    CP = np.array([[Carried(v)] for v in ctrl._CP[:, 0]], dtype=object)
    CS = np.array([[0.0] for _ in range(ctrl._CS.shape[0])], dtype=object)
    reset = python_of(law.reset)
    if law.name == "pid":
        reset(CS, 0, math.nan)
    elif law.name == "adrc":
        reset(CP, CS, 0, math.nan)
    else:
        reset(CP, CS, 0)
    step = python_of(law.module.step)  # (the coefficients computed as the C computes them)
    dt = Carried(getattr(ctrl, "_dt", 0.0) or 0.0)
    values, nodes = [], []
    for yk, rk in zip(y, r, strict=True):
        if law.name == "recursive":
            out = step(CP, CS, 0, Carried(yk), Carried(rk))[1]  # the applied output
        else:
            out = step(CP, CS, 0, Carried(yk), Carried(rk), dt)
        out = Carried.of(out)
        values.append(out.v)
        nodes.append(out.i)
    bounds = np.full(len(nodes), np.nan)
    for k in range(every - 1, len(nodes), every):
        bounds[k] = TAPE.bound(nodes[k])
    return np.array(values), bounds
