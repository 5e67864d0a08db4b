"""Plant objects with one small interface, for a general closed-loop simulator.

Every plant holds its current physical parameters and steps a state vector it does not own::

    x = plant.x0                      # a fresh copy of the initial state
    y = plant.output(x)               # y_k, measured before u_k is computed
    x = plant.step(t, x, u, h)        # one sample with u held over [t, t + h]

``integrator`` picks how a sample is integrated: ``"rk4"`` (one classical RK4 step,
the library's convention), ``"rk45"`` (``scipy.integrate.solve_ivp`` with ``method="RK45"``
over [t, t + h], u held, to ``rtol``/``atol``) or, for linear plants, ``"exact"`` (the
exact zero-order-hold solution).

The converter and first-order plants run their compiled step functions
(:mod:`mfcontrol.plants.buck`, :mod:`~mfcontrol.plants.boost`,
:mod:`~mfcontrol.plants.first_order`) on one-member ``(rows, 1)`` columns, so a plant object
integrates exactly what the batch engine integrates. :class:`LTI` and :class:`ODE` step in
NumPy. Subclass :class:`Plant` for another model: ``output``, ``derivative``, ``params`` and
``set_param`` are enough, RK4 and RK45 come with the base class.
"""

from __future__ import annotations

import math
import numbers
import warnings
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from ...errors import ConfigError, PlantFunctionError, as_float
from ...numerics import blocks, rk4
from ...numerics import signatures as sig
from ...plants import boost, buck, dc_motor, first_order, lti, ode

__all__ = ["LTI", "ODE", "Boost", "Buck", "FirstOrder", "Plant", "EnginePlant"]


class EnginePlant(NamedTuple):
    """A plant as the compiled engine runs it (:mod:`mfcontrol.engine.compose`)."""

    #: (rhs, output, prepare, advance), compiled with :mod:`mfcontrol.numerics.signatures`
    functions: tuple[Any, Any, Any, Any]
    #: the parameter vector (a fresh copy)
    p: np.ndarray
    #: the initial state (a fresh copy)
    x0: np.ndarray
    #: "rk4", "rk45" or "exact"
    integrator: str
    #: (rtol, atol) of "rk45"
    tol: tuple[float, float]
    #: parameter names a schedule may change, and their entries in p
    columns: Mapping[str, int]
    #: (step, output) over a block of members, the plant's functions compiled in
    #: (:mod:`mfcontrol.numerics.blocks`), for plants that have them
    block: blocks.Block | None = None
    #: the same for one member (its RK4 step with f compiled in, for the member loop)
    member: blocks.Block | None = None

# ---------------------------------------------------------------------------------------------
# validation


def _number(name: str, value: Any, positive: bool = False) -> float:
    """``value`` as a float, or ConfigError (a ValueError) naming ``name`` and the range."""
    v = math.nan
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        v = as_float(value)
    if not (math.isfinite(v) and (v > 0 or not positive)):
        raise ConfigError(name, value, "must be a finite number" + (" > 0" if positive else ""))
    return v


def _choice(name: str, value: Any, choices: Sequence[str]) -> str:
    if not isinstance(value, str) or value not in choices:
        raise ConfigError(name, value, "must be one of " + ", ".join(choices))
    return value


def _vector(name: str, value: Any, n: int, what: str) -> np.ndarray:
    """A fresh float64 array of shape (n,), from n numbers (or one number when n == 1)."""
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = None
    if arr is not None and arr.ndim == 0 and n == 1:
        arr = arr.reshape(1)
    if arr is None or arr.shape != (n,) or not np.all(np.isfinite(arr)):
        raise ConfigError(name, value, f"must be {n} finite number{'s' * (n != 1)} ({what})")
    return arr


# ---------------------------------------------------------------------------------------------
# the interface


class Plant(ABC):
    """Base class of the plant objects: a continuous-time model sampled with u held.

    A subclass defines :meth:`output`, :meth:`derivative`, :attr:`params` and
    :meth:`set_param`; :meth:`step` then integrates one sample with RK4 or RK45. It
    overrides ``_rk4`` (a compiled step) or ``_exact`` (integrator ``"exact"``) when it has
    a better one.

    Parameters
    ----------
    state_names : sequence of str
        Names of the state components, in order.
    x0 : array_like
        Initial state, one finite number per state.
    integrator : {"rk4", "rk45"}
        How :meth:`step` integrates a sample; subclasses may allow ``"exact"``. Whatever
        the integrator, a blow-up gives a NaN/inf state rather than an exception (RK45
        also warns when it fails).
    rtol, atol : float
        Tolerances of the ``"rk45"`` integrator (ignored by the others).

    Attributes
    ----------
    state_names : tuple of str
        Names of the state components.
    integrator : str
        The integrator chosen.

    Examples
    --------
    A damped oscillator, x'' = -x - 0.5 x' + u, measured by its position:

    >>> import numpy as np
    >>> from mfcontrol import Plant
    >>> class Oscillator(Plant):
    ...     def __init__(self, **kw):
    ...         super().__init__(("x", "v"), (1.0, 0.0), **kw)
    ...     def output(self, x):
    ...         return float(x[0])
    ...     def derivative(self, t, x, u):
    ...         return np.array([x[1], -x[0] - 0.5 * x[1] + u])
    ...     @property
    ...     def params(self):
    ...         return {}
    ...     def set_param(self, name, value):
    ...         raise ValueError(f"{name}: this plant has no parameters")
    >>> p = Oscillator()
    >>> x = p.step(0.0, p.x0, 0.0, 0.1)
    >>> round(p.output(x), 6)
    0.995086
    """

    _integrators: tuple[str, ...] = ("rk4", "rk45")
    state_names: tuple[str, ...]

    def __init__(self, state_names: Sequence[str], x0: npt.ArrayLike, *,
                 integrator: str = "rk4", rtol: float = 1e-9, atol: float = 1e-12):
        self.state_names = tuple(state_names)
        self._x0 = _vector("x0", x0, len(self.state_names), ", ".join(self.state_names))
        self.integrator = _choice("integrator", integrator, self._integrators)
        self._rtol = _number("rtol", rtol, positive=True)
        self._atol = _number("atol", atol, positive=True)
        self._step = {"rk4": self._rk4, "rk45": self._rk45, "exact": self._exact}[integrator]

    @property
    def x0(self) -> np.ndarray:
        """The initial state: a fresh copy on every access."""
        return self._x0.copy()

    @property
    @abstractmethod
    def params(self) -> dict[str, float]:
        """The current physical parameters, by name (a copy)."""
        raise NotImplementedError

    @abstractmethod
    def set_param(self, name: str, value: float) -> None:
        """Change one parameter (a scheduled change); ValueError for an unknown name or value."""
        raise NotImplementedError

    @abstractmethod
    def output(self, x: np.ndarray) -> float:
        """The measured output at state x."""
        raise NotImplementedError

    @abstractmethod
    def derivative(self, t: float, x: np.ndarray, u: float) -> np.ndarray:
        """dx/dt at time t, state x and input u."""
        raise NotImplementedError

    def step(self, t: float, x: np.ndarray, u: float, h: float) -> np.ndarray:
        """The state at t + h from x at t with u held; x itself is left unchanged."""
        return self._step(float(t), x, float(u), float(h))

    def _rk4(self, t: float, x: np.ndarray, u: float, h: float) -> np.ndarray:
        def f(s: float, y: np.ndarray) -> np.ndarray:
            return np.asarray(self.derivative(s, y, u), dtype=np.float64)

        x = np.asarray(x, dtype=np.float64)
        f1 = h * f(t, x)
        f2 = h * f(t + h / 2, rk4.half(x, f1))
        f3 = h * f(t + h / 2, rk4.half(x, f2))
        f4 = h * f(t + h, rk4.whole(x, f3))
        return rk4.combine(x, f1, f2, f3, f4)

    def _rk45(self, t: float, x: np.ndarray, u: float, h: float) -> np.ndarray:
        x = np.array(x, dtype=np.float64)
        # a blow-up is data, as with RK4 (NaN/inf states that a simulator flags as diverged),
        # not an exception that would end a sweep of runs
        if not (math.isfinite(u) and np.all(np.isfinite(x))):
            return np.full_like(x, np.nan)
        from scipy.integrate import solve_ivp  # here: 0.2 s of import that only rk45 needs

        sol = solve_ivp(lambda s, y: self.derivative(s, y, u), (t, t + h), x, method="RK45",
                        rtol=self._rtol, atol=self._atol)
        if not sol.success:
            warnings.warn(f"RK45 failed over [{t!r}, {t + h!r}] ({sol.message}); the state is "
                          "set to NaN", RuntimeWarning, stacklevel=3)
            return np.full_like(x, np.nan)
        return sol.y[:, -1].copy()

    def _exact(self, t: float, x: np.ndarray, u: float, h: float) -> np.ndarray:
        raise NotImplementedError  # only reachable where "exact" is allowed and overridden

    def engine(self) -> EnginePlant | None:
        """The plant as the compiled engine runs it, or None: a subclass written in Python
        runs through the Python driver (:func:`mfcontrol.api.run.loop.simulate_loop` says so)."""
        return None

    def _engine(self, functions, p: np.ndarray, columns: Mapping[str, int],
                block: blocks.Block | None = None,
                member: blocks.Block | None = None) -> EnginePlant:
        return EnginePlant(functions, np.array(p, dtype=np.float64), self.x0, self.integrator,
                           (self._rtol, self._atol), columns, block, member)

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        return f"{type(self).__name__}({args}, integrator={self.integrator!r})"


class _CompiledPlant(Plant):
    """A plant whose model is a compiled plant module: its parameter vector and the
    module's engine functions (``rhs``, ``measured``, ``derive``, ``advance``), the same
    the engine calls, so a plant object integrates exactly what a run integrates."""

    _module: Any
    _positive: frozenset[str] = frozenset()
    _nonnegative: frozenset[str] = frozenset()

    def _value(self, name: str, value: Any) -> float:
        """A parameter's value, checked: finite, and > 0 or >= 0 where the model needs."""
        v = _number(name, value, name in self._positive)
        if name in self._nonnegative and v < 0:
            raise ConfigError(name, value, "must be a finite number >= 0")
        return v

    def __init__(self, params: Mapping[str, Any], fixed: Mapping[int, float],
                 x0: npt.ArrayLike, **kw: Any):
        mod = self._module
        self._p = np.zeros(mod.N_PARAMS)
        for name, value in params.items():
            self._p[mod.PARAM_ROWS[name]] = self._value(name, value)
        for row, value in fixed.items():
            self._p[row] = value
        self._derive()
        super().__init__(mod.STATE_NAMES, x0, **kw)

    def _functions(self):
        mod = self._module
        return (mod.rhs, mod.measured, getattr(mod, "derive", sig.no_prepare),
                getattr(mod, "advance", sig.no_advance))

    def _derive(self) -> None:
        derive = getattr(self._module, "derive", None)
        if derive is not None:
            # h: what a plant that discretises would need; these derive from p alone
            sig.call_prepare(derive.address, self._p, 0.0, self._module.N_STATE)

    @property
    def params(self) -> dict[str, float]:
        return {name: float(self._p[row]) for name, row in self._module.PARAM_ROWS.items()}

    def set_param(self, name: str, value: float) -> None:
        rows = self._module.PARAM_ROWS
        if name not in rows:
            raise ConfigError(name, value, "unknown parameter; allowed: " + ", ".join(rows))
        self._p[rows[name]] = self._value(name, value)
        self._derive()

    def _state(self, x: npt.ArrayLike) -> np.ndarray:
        # always a fresh C-contiguous copy: the compiled step writes into it
        return np.array(x, dtype=np.float64).reshape(self._module.N_STATE)

    def output(self, x: np.ndarray) -> float:
        return float(sig.call_output(self._module.measured.address, self._state(x), self._p))

    def derivative(self, t: float, x: np.ndarray, u: float) -> np.ndarray:
        return sig.call_rhs(self._module.rhs.address, float(t), self._state(x), float(u),
                            self._p)

    def _rk4(self, t: float, x: np.ndarray, u: float, h: float) -> np.ndarray:
        x = self._state(x)
        rk4.step_once(self._module.rhs.address, float(t), x, float(u), self._p, float(h))
        return x

    def _exact(self, t: float, x: np.ndarray, u: float, h: float) -> np.ndarray:
        x = self._state(x)
        sig.call_advance(self._module.advance.address, float(t), x, float(u), self._p,
                         float(h))
        return x

    def engine(self) -> EnginePlant:
        mod = self._module
        return self._engine(self._functions(), self._p, mod.PARAM_ROWS,
                            blocks.of_library(mod, self.integrator, mod.N_STATE, mod.N_PARAMS),
                            blocks.of_library(mod, self.integrator, mod.N_STATE, mod.N_PARAMS,
                                              lanes=1))


class Buck(_CompiledPlant):
    """Averaged buck converter (:mod:`mfcontrol.plants.buck`), states (i_L, v_C), input d.

    Parameters
    ----------
    E, L, R, C : float
        Input voltage (V), inductance (H), load resistance (ohm), capacitance (F); all > 0.
    coupling : {"textbook", "published"}
        ``"published"`` adds the input term E d / L to dv/dt as well, as the published code
        does; ``"textbook"`` is the physical converter.
    output : {"voltage", "power"}
        The measured output: v_C, or v_C i_L.
    x0 : array_like
        Initial (i_L, v_C).
    integrator : {"rk4", "rk45"}
        ``"rk4"`` is the engine's RK4 (:mod:`mfcontrol.numerics.rk4`) on
        :func:`mfcontrol.plants.buck.rhs`.
    rtol, atol : float
        Tolerances of ``"rk45"``.

    Examples
    --------
    The textbook converter settles at v = E d:

    >>> from mfcontrol import Buck
    >>> plant = Buck(E=20.0, R=10.0)
    >>> x = plant.x0
    >>> for k in range(5000):
    ...     x = plant.step(k * 1e-6, x, 0.5, 1e-6)
    >>> round(plant.output(x), 6)
    10.0
    >>> plant.set_param("R", 5.0)
    >>> plant.params
    {'E': 20.0, 'L': 0.001, 'R': 5.0, 'C': 1e-05}
    """

    _module = buck
    _positive = frozenset({"E", "L", "R", "C"})

    def __init__(self, E: float = 20.0, L: float = 1e-3, R: float = 10.0, C: float = 10e-6, *,
                 coupling: str = "textbook", output: str = "voltage",
                 x0: npt.ArrayLike = (0.0, 0.0), integrator: str = "rk4",
                 rtol: float = 1e-9, atol: float = 1e-12):
        self.coupling = _choice("coupling", coupling, tuple(buck.COUPLINGS))
        self.output_kind = _choice("output", output, tuple(buck.OUTPUTS))
        super().__init__({"E": E, "L": L, "R": R, "C": C},
                         {buck.COUPLING: buck.COUPLINGS[coupling],
                          buck.OUTPUT: buck.OUTPUTS[output]},
                         x0, integrator=integrator, rtol=rtol, atol=atol)


class Boost(_CompiledPlant):
    """Averaged boost converter (:mod:`mfcontrol.plants.boost`), states (i_L, v_C), input d.

    ``L di/dt = E - (1 - d) v``, ``C dv/dt = (1 - d) i - v / R``; output v_C. Non-minimum
    phase from d to v: the linearisation around duty D has a right-half-plane zero at
    ``(1 - D)^2 R / L`` rad/s, so v first dips when d steps up.

    Parameters
    ----------
    E, L, R, C : float
        Input voltage (V), inductance (H), load resistance (ohm), capacitance (F); all > 0.
    x0 : array_like
        Initial (i_L, v_C).
    integrator : {"rk4", "rk45"}
        ``"rk4"`` is the engine's RK4 (:mod:`mfcontrol.numerics.rk4`) on
        :func:`mfcontrol.plants.boost.rhs`.
    rtol, atol : float
        Tolerances of ``"rk45"``.

    Examples
    --------
    At duty 0.5 the output settles at E / (1 - d) = 40 V:

    >>> from mfcontrol import Boost
    >>> plant = Boost(E=20.0)
    >>> x = plant.x0
    >>> for k in range(1000):
    ...     x = plant.step(k * 2e-5, x, 0.5, 2e-5)
    >>> round(plant.output(x), 6)
    40.0
    """

    _module = boost
    _positive = frozenset({"E", "L", "R", "C"})

    def __init__(self, E: float = 20.0, L: float = 1e-3, R: float = 10.0, C: float = 10e-6, *,
                 x0: npt.ArrayLike = (0.0, 0.0), integrator: str = "rk4",
                 rtol: float = 1e-9, atol: float = 1e-12):
        super().__init__({"E": E, "L": L, "R": R, "C": C}, {}, x0,
                         integrator=integrator, rtol=rtol, atol=atol)


class FirstOrder(_CompiledPlant):
    """First-order plant y' = a y + b u + w (:mod:`mfcontrol.plants.first_order`).

    Parameters
    ----------
    a, b : float
        Pole and input gain (any finite numbers; a > 0 is unstable).
    w : float
        Constant disturbance; ``set_param("w", ...)`` switches it.
    x0 : float
        Initial y.
    integrator : {"rk4", "rk45", "exact"}
        ``"exact"`` uses the closed-form solution under the held input.
    rtol, atol : float
        Tolerances of ``"rk45"``.

    Examples
    --------
    >>> from mfcontrol import FirstOrder
    >>> plant = FirstOrder(a=-1.0, b=1.0, integrator="exact")
    >>> y = plant.step(0.0, plant.x0, 1.0, 1.0)   # 1 - e^-1
    >>> round(plant.output(y), 12)
    0.632120558829
    """

    _module = first_order
    _integrators = ("rk4", "rk45", "exact")

    def __init__(self, a: float, b: float, w: float = 0.0, x0: float = 0.0, *,
                 integrator: str = "rk4", rtol: float = 1e-9, atol: float = 1e-12):
        super().__init__({"a": a, "b": b, "w": w}, {}, x0,
                         integrator=integrator, rtol=rtol, atol=atol)



class DCMotor(_CompiledPlant):
    """DC motor driven by its armature voltage (:mod:`mfcontrol.plants.dc_motor`), states
    (omega, i_a), output the speed omega (rad/s).

    Parameters
    ----------
    J : float
        Rotor inertia (kg m^2), > 0.
    friction : float
        Viscous friction (N m s), >= 0.
    Km : float
        Torque and back-emf constant (N m/A = V s/rad), > 0.
    Ra, La : float
        Armature resistance (ohm) and inductance (H), > 0.
    load : float
        Load torque (N m); ``set_param("load", ...)`` or a schedule steps it.
    x0 : array_like
        Initial (omega, i_a).
    integrator : {"rk4", "rk45"}
        ``"rk4"`` is the engine's RK4 on :func:`mfcontrol.plants.dc_motor.rhs`.
    rtol, atol : float
        Tolerances of ``"rk45"``.

    Examples
    --------
    Under 12 V with no load the speed settles at Km u / (Km^2 + Ra friction):

    >>> from mfcontrol import DCMotor
    >>> motor = DCMotor()
    >>> x = motor.x0
    >>> for k in range(20000):
    ...     x = motor.step(k * 1e-3, x, 12.0, 1e-3)
    >>> round(motor.output(x), 3), round(0.05 * 12 / (0.05**2 + 2 * 1e-4), 3)
    (222.222, 222.222)
    """

    _module = dc_motor
    _positive = frozenset({"J", "Km", "Ra", "La"})
    _nonnegative = frozenset({"friction"})

    def __init__(self, J: float = 5e-4, friction: float = 1e-4, Km: float = 0.05,
                 Ra: float = 2.0, La: float = 2e-3, load: float = 0.0, *,
                 x0: npt.ArrayLike = (0.0, 0.0), integrator: str = "rk4",
                 rtol: float = 1e-9, atol: float = 1e-12):
        super().__init__({"J": J, "friction": friction, "Km": Km, "Ra": Ra, "La": La,
                          "load": load}, {}, x0, integrator=integrator, rtol=rtol, atol=atol)


def _described(sys: Any) -> str:
    """A python-control system in a few words, for a one-line message (its own text is a
    matrix or a fraction over several lines): its type, inputs, outputs and order."""
    def count(n: int, what: str) -> str:
        return f"{n} {what}{'s' * (n != 1)}"

    n = getattr(sys, "nstates", None)  # a StateSpace's (a TransferFunction's is None)
    if isinstance(n, int | np.integer):
        order = count(int(n), "state")
    else:
        try:
            degree = max(np.size(np.trim_zeros(np.ravel(d), "f")) - 1
                         for row in sys.den for d in row)
            order = f"denominator of degree {degree}"
        except (TypeError, ValueError, AttributeError):
            order = "order unknown"
    return (f"a {type(sys).__name__} with {count(sys.ninputs, 'input')}, "
            f"{count(sys.noutputs, 'output')}, {order}")


class LTI(Plant):
    """Continuous-time SISO state-space plant x' = A x + B u, y = C x.

    Parameters
    ----------
    A : array_like, shape (n, n)
    B : array_like, shape (n,) or (n, 1)
    C : array_like, shape (n,) or (1, n)
    D : float
        Must be 0. In a sampled loop y_k is measured before u_k is computed, so a
        feedthrough D u_k would make y_k depend on an input that does not exist yet (an
        algebraic loop); :meth:`output` therefore takes the state only. Model a fast
        feedthrough with a fast pole instead.
    x0 : array_like, optional
        Initial state; zeros by default.
    integrator : {"rk4", "rk45", "exact"}
        ``"exact"`` is the zero-order-hold discretisation ``expm([[A, B], [0, 0]] h)``,
        recomputed when h or a parameter changes.
    rtol, atol : float
        Tolerances of ``"rk45"``.

    Notes
    -----
    :attr:`params` holds every matrix entry under the names ``"A[i,j]"``, ``"B[i]"`` and
    ``"C[i]"``, so that a schedule can change any of them with :meth:`set_param`.

    Examples
    --------
    A first-order lag 1/(s + 1) under a unit step, integrated exactly:

    >>> import numpy as np
    >>> from mfcontrol import LTI
    >>> plant = LTI([[-1.0]], [1.0], [1.0], integrator="exact")
    >>> x = plant.x0
    >>> for k in range(10):
    ...     x = plant.step(0.1 * k, x, 1.0, 0.1)
    >>> bool(np.isclose(plant.output(x), 1 - np.exp(-1.0), rtol=1e-14))
    True
    """

    _integrators = ("rk4", "rk45", "exact")

    def __init__(self, A: npt.ArrayLike, B: npt.ArrayLike, C: npt.ArrayLike, D: float = 0.0,
                 x0: npt.ArrayLike | None = None, *, integrator: str = "rk4",
                 rtol: float = 1e-9, atol: float = 1e-12):
        self._A = self._matrix("A", A, None)
        n = self._A.shape[0]
        self._B = self._matrix("B", B, n)
        self._C = self._matrix("C", C, n)
        d = _number("D", D)
        if d != 0.0:
            raise ConfigError("D", D, "must be 0: a sampled loop measures y_k before it "
                              "computes u_k, so y = C x + D u would need u_k before it exists "
                              "(an algebraic loop); model a fast feedthrough with a fast pole")
        # (h its Ad, Bd were derived for or None, the parameter vector of plants/lti.py)
        self._packed: tuple[float | None, np.ndarray] | None = None
        super().__init__(tuple(f"x[{i}]" for i in range(n)), np.zeros(n) if x0 is None else x0,
                         integrator=integrator, rtol=rtol, atol=atol)

    @staticmethod
    def _matrix(name: str, value: Any, n: int | None) -> np.ndarray:
        try:
            arr = np.array(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise ConfigError(name, value, "must be an array of finite numbers") from None
        if arr.ndim == 0 and n in (None, 1):  # a number for a one-state system
            arr = arr.reshape((1, 1) if n is None else (1,))
        if n is None:
            ok = arr.ndim == 2 and arr.shape[0] == arr.shape[1] and arr.shape[0] >= 1
            shape = "a square n x n array, n >= 1"
        else:
            # B as a column, C as a row, or either as a flat vector
            ok = arr.shape in ((n,), (n, 1) if name == "B" else (1, n))
            shape = f"of shape ({n},) or " + (f"({n}, 1)" if name == "B" else f"(1, {n})")
            arr = arr.reshape(-1) if ok else arr
        if not ok:
            raise ConfigError(name, value, f"must be {shape} (got shape {arr.shape})")
        if not np.all(np.isfinite(arr)):
            raise ConfigError(name, value, "must hold finite numbers only")
        return arr

    @classmethod
    def from_control(cls, sys: Any, **kw: Any) -> LTI:
        """The plant of a continuous-time SISO python-control system.

        Parameters
        ----------
        sys : control.StateSpace or control.TransferFunction
            Converted with ``control.ss``; the state is that realisation's.
        **kw
            ``x0``, ``integrator``, ``rtol``, ``atol``, as for :class:`LTI`.

        Raises
        ------
        TypeError
            ``sys`` is neither a StateSpace nor a TransferFunction.
        ValueError
            ``sys`` is discrete-time, not SISO, improper, has a feedthrough (D != 0, e.g.
            a biproper transfer function), no state (a static gain) or coefficients that
            are not finite. Each refusal is one line that describes ``sys`` briefly
            (python-control's own text of a system spans several).
        """
        import control  # here: python-control takes about 2 s to import

        if not isinstance(sys, control.StateSpace | control.TransferFunction):
            raise TypeError(f"sys must be a control.StateSpace or control.TransferFunction, "
                            f"not {type(sys).__name__}")
        what = _described(sys)
        if not sys.isctime():
            raise ConfigError("sys.dt", sys.dt, f"must be 0 (a continuous-time system; sys is "
                              f"{what}): this plant integrates an ODE between samples")
        if (sys.ninputs, sys.noutputs) != (1, 1):
            raise ConfigError("sys", what, "must have one input and one output (SISO)")
        # the conversion's warnings (scipy's BadCoefficients) are held until it is known
        # that no refusal follows: a refusal is the only output
        with warnings.catch_warnings(record=True) as held, np.errstate(all="ignore"):
            warnings.simplefilter("always")
            try:
                ss = control.ss(sys)
            except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
                # python-control's reason (an improper transfer function's), on one line
                reason = " ".join(str(exc).split()) or type(exc).__name__
                raise ConfigError("sys", what, f"must be a proper system with a state-space "
                                  f"realisation ({reason})") from None
        matrices = {m: np.asarray(getattr(ss, m), dtype=float) for m in "ABCD"}
        bad = [m for m, arr in matrices.items() if not np.all(np.isfinite(arr))]
        if bad:
            raise ConfigError("sys", what, f"must have finite coefficients (its state "
                              f"space's {' and '.join(bad)} hold{'s' * (len(bad) == 1)} "
                              "NaN or inf)")
        if matrices["A"].shape[0] == 0:
            raise ConfigError("sys", what, "must have at least one state (a static gain has "
                              "none: give it a fast pole, k / (tau s + 1))")
        plant = cls(matrices["A"], matrices["B"], matrices["C"],
                    float(matrices["D"].reshape(-1)[0]), **kw)
        for w in held:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        return plant

    @property
    def A(self) -> np.ndarray:
        """The state matrix (a copy)."""
        return self._A.copy()

    @property
    def B(self) -> np.ndarray:
        """The input vector, shape (n,) (a copy)."""
        return self._B.copy()

    @property
    def C(self) -> np.ndarray:
        """The output vector, shape (n,) (a copy)."""
        return self._C.copy()

    def _entries(self) -> dict[str, tuple[np.ndarray, tuple[int, ...]]]:
        n = self._A.shape[0]
        out: dict[str, tuple[np.ndarray, tuple[int, ...]]] = {}
        for i in range(n):
            for j in range(n):
                out[f"A[{i},{j}]"] = (self._A, (i, j))
        for name, arr in (("B", self._B), ("C", self._C)):
            for i in range(n):
                out[f"{name}[{i}]"] = (arr, (i,))
        return out

    @property
    def params(self) -> dict[str, float]:
        return {name: float(arr[idx]) for name, (arr, idx) in self._entries().items()}

    def set_param(self, name: str, value: float) -> None:
        entries = self._entries()
        if name not in entries:
            n = self._A.shape[0] - 1
            raise ConfigError(name, value, f"unknown parameter; allowed: A[i,j], B[i], C[i] "
                              f"with i, j in 0..{n}")
        arr, idx = entries[name]
        arr[idx] = _number(name, value)
        self._packed = None

    # the Python-side calls run the engine's own functions (plants/lti.py), so that a
    # plant object steps exactly as a run does

    def _parameter_vector(self, h: float | None = None) -> np.ndarray:
        """The parameter vector; with ``h``, its Ad, Bd derived for that step (only the
        exact step reads them)."""
        if self._packed is None or (h is not None and self._packed[0] != h):
            p = lti.pack(self._A, self._B, self._C)
            if h is not None:
                sig.call_prepare(lti.derive.address, p, float(h), self._A.shape[0])
            self._packed = (h, p)
        return self._packed[1]

    def _state(self, x: npt.ArrayLike) -> np.ndarray:
        # always a fresh C-contiguous copy: the compiled step writes into it
        return np.array(x, dtype=np.float64).reshape(self._A.shape[0])

    def output(self, x: np.ndarray) -> float:
        return float(sig.call_output(lti.measured.address, self._state(x),
                                     self._parameter_vector()))

    def derivative(self, t: float, x: np.ndarray, u: float) -> np.ndarray:
        return sig.call_rhs(lti.rhs.address, float(t), self._state(x), float(u),
                            self._parameter_vector())

    def _rk4(self, t: float, x: np.ndarray, u: float, h: float) -> np.ndarray:
        x = self._state(x)
        rk4.step_once(lti.rhs.address, float(t), x, float(u), self._parameter_vector(), float(h))
        return x

    def engine(self) -> EnginePlant:
        n = self._A.shape[0]
        return self._engine((lti.rhs, lti.measured, lti.derive, lti.advance),
                            self._parameter_vector(), lti.names(n),
                            blocks.of_library(lti, self.integrator, n, lti.size(n)),
                            blocks.of_library(lti, self.integrator, n, lti.size(n), lanes=1))

    def _exact(self, t: float, x: np.ndarray, u: float, h: float) -> np.ndarray:
        x = self._state(x)
        h = float(h)
        sig.call_advance(lti.advance.address, float(t), x, float(u),
                         self._parameter_vector(h), h)
        return x


class ODE(Plant):
    """Any user ODE x' = f(t, x, u, p), y = g(x, p).

    Parameters
    ----------
    f : callable
        In place, ``f(t, x, u, p, dxdt)``, writing dx/dt into ``dxdt`` (the fast form: no
        allocation per call), or returning, ``f(t, x, u, p) -> dx/dt`` (an array, list or
        tuple of n numbers); told apart by the number of parameters. ``t``, ``u`` are
        floats, ``x`` and ``dxdt`` float64 arrays, ``p`` the parameter values as a float64
        array in the order of ``params``. The engine compiles f and g with numba (plain
        Python or ``numba.njit`` functions alike); if numba cannot, the loop runs through
        the Python driver, much slower, and the result's ``engine`` says ``"python"``.
    g : callable
        ``g(x, p) -> y`` (a float).
    x0 : array_like
        Initial state; its length sets n.
    params : mapping of str to float, optional
        Named parameters; :meth:`set_param` changes them.
    integrator : {"rk4", "rk45"}
        ``"rk4"`` is one NumPy RK4 step per sample.
    rtol, atol : float
        Tolerances of ``"rk45"``.
    state_names : sequence of str, optional
        Names of the state components; ``x[0]``, ``x[1]``, ... by default.

    Notes
    -----
    What compiles when (:mod:`mfcontrol.plants.ode`): f and g are known by a digest of
    what numba compiles from them (their code and source, the values of the globals they
    read, their defaults, and the same of the jit functions of yours they call). A new
    plant object from functions with the same digest reuses what this process compiled.
    With f, g and those functions defined in a file and closing over no values, the
    compiled functions are kept in numba's disk cache: compiled once per machine, then
    loaded in any process. An edit of any of them, or a global they read that differs
    from the last process (computed at import, say), compiles anew; an edit elsewhere in
    the file does not. Functions defined in a REPL or by ``exec`` (no source file) and
    closures compile once per process (per value a closure holds). numba freezes the
    globals f reads when it compiles, as for any jit function: a global changed later in
    the same process is seen by new plant objects (a new digest), not by one already
    compiled.

    Examples
    --------
    A damped pendulum driven by a torque u:

    >>> import numpy as np
    >>> from mfcontrol import ODE
    >>> def f(t, x, u, p):
    ...     return np.array([x[1], -p[0] * np.sin(x[0]) - p[1] * x[1] + u])
    >>> def g(x, p):
    ...     return x[0]
    >>> plant = ODE(f, g, x0=(0.5, 0.0), params={"g_over_l": 9.81, "damping": 0.2})
    >>> x = plant.x0
    >>> for k in range(100):
    ...     x = plant.step(0.01 * k, x, 0.0, 0.01)
    >>> plant.output(x) < 0.5
    True
    """

    def __init__(self, f: Callable[..., Any], g: Callable[..., Any], x0: npt.ArrayLike,
                 params: Mapping[str, float] | None = None, *, integrator: str = "rk4",
                 rtol: float = 1e-9, atol: float = 1e-12,
                 state_names: Sequence[str] | None = None):
        if not callable(f) or not callable(g):
            bad = "f" if not callable(f) else "g"
            raise TypeError(f"{bad} must be callable")
        self._f = f
        self._g = g
        params = dict(params or {})
        self._names = tuple(params)
        self._p = np.array([_number(k, v) for k, v in params.items()], dtype=np.float64)
        x0_arr = np.array(x0, dtype=np.float64)
        n = max(x0_arr.size, 1)
        names = tuple(f"x[{i}]" for i in range(n)) if state_names is None else state_names
        if len(names) != n:
            raise ConfigError("state_names", state_names, f"must name the {n} states of x0")
        super().__init__(names, x0, integrator=integrator, rtol=rtol, atol=atol)
        self._compiled = None
        self._block = None
        self._member = None
        self._identity: tuple[str | None, bool] = (None, False)
        #: why the Python driver runs this plant (None while it compiles)
        self.python_reason: str | None = None
        # one call of each up front: a wrong shape is reported here, not mid-run
        self._inplace = ode.arity(f) == 5
        dx = self._probe("f(t, x, u, p)", lambda: self.derivative(0.0, self.x0, 0.0))
        if dx.shape != (n,):
            raise ValueError(f"f(t, x, u, p) returned shape {dx.shape}; x0 has shape ({n},)")
        if self._inplace and np.isnan(dx).any():
            i = int(np.flatnonzero(np.isnan(dx))[0])
            raise ValueError(f"f(t, x, u, p, dxdt) left dxdt[{i}] unwritten (NaN) at t = 0, "
                             "x = x0, u = 0: write every entry")
        self._probe("g(x, p)", lambda: g(self.x0, self._p))

    def _probe(self, call: str, fn: Callable[[], Any]) -> Any:
        """``fn()``, the first call of f or g at x0; an index past x or p, or a name used
        as an index, is told with what x and p hold (numpy's own message names neither)."""
        try:
            return fn()
        except IndexError as exc:
            p = ", ".join(f"p[{i}] = {k}" for i, k in enumerate(self._names)) or "empty"
            raise ValueError(
                f"{call} at x = x0, u = 0: {exc}. x holds the {self.x0.size} state(s) of x0 "
                f"(x[0] .. x[{self.x0.size - 1}]); p is an array of the params in their "
                f"order ({p})") from exc

    @property
    def params(self) -> dict[str, float]:
        return dict(zip(self._names, self._p.tolist(), strict=True))

    def engine(self) -> EnginePlant | None:
        """The compiled plant; None (with the reason in :attr:`python_reason`) when numba
        cannot compile f or g, and the Python driver runs it."""
        if self._compiled is None and self.python_reason is None:
            # known by all that numba compiles from f and g: a plant object from the same
            # functions takes what is compiled already, and from a file numba's disk cache
            self._identity = ode.identity(self._f, self._g) or (None, False)
            try:
                self._compiled = ode.compile_functions(self._f, self._g, *self._identity)
            except ode.NotCompilable as exc:
                self.python_reason = f"numba cannot compile f or g: {exc}"
        if self._compiled is None:
            return None
        rhs, output = self._compiled
        if self._block is None:
            f, g = ode.python_function(self._f), ode.python_function(self._g)
            identity, on_disk = self._identity
            self._block = blocks.of_ode(f, g, self._inplace, self.x0.size, self._p.size,
                                        identity, on_disk)
            # the one-member step, f inlined into it, compiled once per process: kept in
            # numba's disk cache, a later process could not load it (numba pickles its
            # environment under a module name, "<dynamic>", it cannot import)
            self._member = blocks.of_ode(f, g, self._inplace, self.x0.size, self._p.size,
                                         identity, False, lanes=1)
        return self._engine((rhs, output, sig.no_prepare, sig.no_advance), self._p,
                            {name: i for i, name in enumerate(self._names)}, self._block,
                            self._member)

    def set_param(self, name: str, value: float) -> None:
        if name not in self._names:
            raise ConfigError(name, value, "unknown parameter; allowed: "
                              + (", ".join(self._names) or "none (no params given)"))
        self._p[self._names.index(name)] = _number(name, value)

    def output(self, x: np.ndarray) -> float:
        return float(self._g(np.asarray(x, dtype=np.float64), self._p))

    def replay_step(self, t: float, x: np.ndarray, u: float, h: float,
                    substeps: int = 1) -> None:
        """Replay in Python one sample's step from state ``x`` at ``t``, ``u`` held
        (``substeps`` steps of h / substeps), then g: :class:`PlantFunctionError` naming
        the function, the time and the state if f or g raises in it.

        The compiled engine turns what f or g raises into NaN (a diverged run); a single
        run calls this on the step that gave the NaN to tell the exception."""
        f = self._f
        f_py = ode.python_function(f)
        at: list[Any] = [t, x, u]

        def watched(t_, x_, u_, p_, *out):
            at[:] = [t_, np.array(x_, copy=True), u_]
            return f_py(t_, x_, u_, p_, *out)

        hs = h / substeps
        self._f = watched
        try:
            for i in range(substeps):
                x = self.step(t + i * hs, x, u, hs)
        except Exception as exc:  # noqa: BLE001 (whatever your f raises is told)
            raise PlantFunctionError(
                f"{'f(t, x, u, p, dxdt)' if self._inplace else 'f(t, x, u, p)'} raised "
                f"{type(exc).__name__}: {exc} at t = {at[0]:.9g} s (x = "
                f"{np.array2string(np.asarray(at[1]), precision=9)}, u = {at[2]:.9g})"
                ) from exc
        finally:
            self._f = f
        try:
            ode.python_function(self._g)(np.asarray(x, dtype=np.float64), self._p)
        except Exception as exc:  # noqa: BLE001 (whatever your g raises is told)
            raise PlantFunctionError(
                f"g(x, p) raised {type(exc).__name__}: {exc} at t = {t + h:.9g} s (x = "
                f"{np.array2string(np.asarray(x), precision=9)})") from exc

    def derivative(self, t: float, x: np.ndarray, u: float) -> np.ndarray:
        x = np.ascontiguousarray(x, dtype=np.float64)
        if self._inplace:
            out = np.full(x.size, np.nan)  # an entry f leaves unwritten shows as NaN
            self._f(float(t), x, float(u), self._p, out)
            return out
        return np.asarray(self._f(float(t), x, float(u), self._p), dtype=np.float64)
