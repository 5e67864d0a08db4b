"""Know a controller before you run it: :func:`analyze` builds a case's loop (or a live
controller's, on a plant you give) as the linear loop it is between its limits, and gives
its poles, margins, sensitivity peaks, noise gain and figures.

The pieces are :mod:`mfcontrol.analysis`: each law's equivalent filter
(:mod:`~mfcontrol.analysis.filters`), the plant linearised and sampled as the engine
integrates it (:mod:`~mfcontrol.analysis.linearise`), and the closed loop
(:mod:`~mfcontrol.analysis.loop`). This module composes them and says, in
:attr:`Analysis.notes`, what the linear loop leaves out of the run.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import files
from .._version import __version__
from ..analysis import linearise
from ..analysis.filters import LinearFilter
from ..analysis.loop import LinearLoop
from ..api.model.controllers import ADRC, PID, RecursiveIP
from ..config.resolve import Config

#: the margins' keys in the order they are printed, with their words
#: a steady-state error smaller than this is an integrating loop's 0, summed in floats
#: to some 1e-13: shown as 0 (the summary, the tuner)
ROUNDING = 1e-9

SUMMARY = (("stable", "stable (linear loop)"), ("spectral_radius", "spectral radius"),
           ("Ms", "Ms (peak |S|)"), ("Mt", "Mt (peak |T|)"), ("gain_margin", "gain margin"),
           ("phase_margin_deg", "phase margin (deg)"), ("delay_margin_s", "delay margin (s)"),
           ("delay_margin_samples", "delay margin (samples)"),
           ("bandwidth_rad_s", "bandwidth r -> y (rad/s)"),
           ("steady_state_error", "steady-state error per unit step of r"),
           ("noise_gain_peak", "noise gain, peak |C_y S|"),
           ("noise_gain_h2", "noise gain, H2 (std u / std n)"))


@dataclass(frozen=True)
class Analysis:
    """A controller's loop as a linear system: what :func:`analyze` returns.

    Attributes
    ----------
    name : str
        The case's name (or ``""``).
    loop : LinearLoop
        The law's filter closed around the sampled plant and the loop's delay.
    margins : dict
        :meth:`LinearLoop.margins`: ``stable``, ``spectral_radius``, ``Ms``, ``Mt``,
        ``gain_margin``, ``phase_margin_deg``, ``delay_margin_s``,
        ``delay_margin_samples``, ``bandwidth_rad_s``, ``steady_state_error``,
        ``noise_gain_peak``, ``noise_gain_h2``.
    operating_point : dict or None
        Where a nonlinear plant was linearised: its state ``x``, input ``u`` and output
        ``y``; None for a plant that is linear.
    notes : tuple of str
        What the linear loop leaves out of the run (limits, noise, a moving gain, a
        schedule), and how the plant was made linear and discrete.
    """

    name: str
    loop: LinearLoop
    margins: dict[str, Any]
    operating_point: dict[str, Any] | None
    notes: tuple[str, ...]

    @property
    def controller(self) -> LinearFilter:
        """The law's linear filter ``A(q) u = B_y(q) y + B_r(q) r``."""
        return self.loop.controller

    @property
    def sample_time(self) -> float:
        return self.loop.controller.dt

    def transfer_functions(self):
        """(C_y, C_r): u's python-control transfer functions from y and from r."""
        return self.controller.transfer_functions()

    def poles(self) -> np.ndarray:
        """The closed loop's poles (z)."""
        return self.loop.poles()

    def to_dict(self) -> dict[str, Any]:
        """Everything as plain JSON values: an infinite margin (no crossing) is the
        string ``"inf"``, an undefined one (an unstable loop's steady state) null."""
        def plain(v: Any) -> Any:
            if isinstance(v, bool | str) or v is None:
                return v
            if isinstance(v, dict):
                return {k: plain(w) for k, w in v.items()}
            if isinstance(v, list | tuple | np.ndarray):
                return [plain(w) for w in v]
            return files.json_number(float(v))

        poles = self.poles()
        return {
            "case": self.name, "mfcontrol": __version__, "sample_time": self.sample_time,
            "margins": plain(self.margins),
            "operating_point": plain(self.operating_point),
            "loop_delay_samples": self.loop.delay,
            "controller": {"a": plain(self.controller.a), "b_y": plain(self.controller.b_y),
                           "b_r": plain(self.controller.b_r),
                           "form": "A(q) u = B_y(q) y + B_r(q) r, q = z^-1, coefficient of "
                                   "q^i at index i"},
            "poles": {"real": plain(poles.real), "imag": plain(poles.imag)},
            "notes": list(self.notes),
        }

    def plot(self, path: str | Path | None = None, title: str | None = None):
        """Bode (the gains of L, S, T and C_y S, and L's phase), Nyquist with the Ms
        circle, and the closed-loop poles (:func:`mfcontrol.api.results.plotting.plot_analysis`).
        Returns the matplotlib Figure; saved to ``path`` when given."""
        from ..api.results.plotting import plot_analysis

        return plot_analysis(self, path, title)

    def write(self, folder: str | Path) -> list[Path]:
        """``analysis.json`` and ``analysis.png`` in ``folder``; returns their paths."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        out = [folder / "analysis.json", folder / "analysis.png"]
        files.write_text(out[0], json.dumps(self.to_dict(), indent=2) + "\n")
        self.plot(out[1])
        return out

    def summary(self) -> str:
        """The margins and the notes, a line each."""
        def shown(key: str, v: Any) -> str:
            if isinstance(v, bool):
                return str(v)
            if key == "steady_state_error" and abs(v) < ROUNDING:
                return "0 (to rounding)"
            return f"{v:.4g}"

        lines = [f"{words}: {shown(key, self.margins[key])}" for key, words in SUMMARY]
        if self.operating_point is not None:
            p = self.operating_point
            lines.append(f"linearised at y = {p['y']:.4g}, u = {p['u']:.4g}")
        return "\n".join(lines + [f"note: {n}" for n in self.notes])

    def __repr__(self) -> str:
        m = self.margins
        return (f"Analysis({self.name or 'loop'}: stable={m['stable']}, Ms={m['Ms']:.3g}, "
                f"GM={m['gain_margin']:.3g}, PM={m['phase_margin_deg']:.3g} deg)")


def _sampled_plant(plant: Any, h: float, substeps: int, level: float | None,
                   notes: list[str], limits: tuple[float, float] = (-math.inf, math.inf)
                   ) -> tuple[Any, dict[str, Any] | None]:
    """The plant as a discrete python-control system at the sample period h, and where it
    was linearised (None: linear)."""
    import control

    if isinstance(plant, control.StateSpace | control.TransferFunction):
        if substeps != 1:
            raise ValueError(f"substeps = {substeps!r}: a python-control plant is stepped "
                             "by its zero-order hold over the whole sample")
        return plant, None  # LinearLoop takes it (a continuous one by its ZOH)
    missing = [m for m in ("derivative", "output", "x0") if not hasattr(plant, m)]
    if missing:
        raise TypeError(f"plant: a mfcontrol.Plant (derivative, output, x0) or a "
                        f"python-control system, not {type(plant).__name__}")
    integrator = getattr(plant, "integrator", "exact")
    if integrator == "rk45":
        notes.append("the plant's adaptive integrator (rk45) is taken as the exact "
                     "zero-order hold (its tolerances put it within about 1e-9 of it)")
    point = None
    if all(hasattr(plant, m) for m in "ABC"):  # mfcontrol.LTI: its own matrices
        A, B, C = (np.asarray(getattr(plant, m), dtype=float) for m in "ABC")
    else:
        x0 = np.asarray(plant.x0, dtype=float)
        found = None
        if level is not None:
            # inputs to start the search from: 0, then the law's range (its middle, ends)
            lo, hi = limits
            starts = [0.0] + ([(lo + hi) / 2, lo, hi] if math.isfinite(lo + hi) else [])
            found = linearise.steady_state(plant.derivative, plant.output, level, x0,
                                           tuple(starts))
        if found is None:
            x, u = x0, 0.0
        else:
            x, u = found
        A, B, C = linearise.jacobians(plant.derivative, plant.output, x, u)
        # a plant whose Jacobians are the same far apart is linear: nothing to say
        far = [(x, u), (x + np.maximum(np.abs(x), 1.0), u + max(abs(u), 1.0))]
        if not linearise.is_linear(plant.derivative, plant.output, far, first=(A, B, C)):
            point = {"x": x.tolist(), "u": float(u), "y": float(plant.output(x))}
            if found is None:
                notes.append(f"no steady state with output {level!r} was found from the "
                             "initial state: the plant is linearised at its initial state "
                             "with u = 0")
            notes.append(f"the plant is nonlinear: linearised at y = {point['y']:.6g}, "
                         f"u = {point['u']:.6g}; the analysis holds near that point")
    Ad, Bd = linearise.discretise(A, B, h, integrator, substeps)
    return control.ss(Ad, Bd[:, None], C.reshape(1, -1), 0.0, h), point


def _law(ctrl: Any, gamma: float | None, notes: list[str]) -> LinearFilter:
    """The controller's filter, its gain held where it moves (said in ``notes``)."""
    if not hasattr(ctrl, "linear_filter"):
        raise TypeError(f"controller: an mfcontrol controller (IP, IPI, IPD, IPID, PID, "
                        f"ADRC, RecursiveIP), not {type(ctrl).__name__}")
    if getattr(ctrl, "sample_time", None) is None:
        raise ValueError("sample_time = None: the controller needs the sample time of "
                         "the loop to be analysed")
    if isinstance(ctrl, PID | ADRC):
        if gamma is not None:
            raise ValueError(f"gamma = {gamma!r}: a {type(ctrl).__name__} has no gain gamma")
        return ctrl.linear_filter()
    held = _held_gamma(ctrl, gamma)
    if held is not None:
        notes.append(f"the gain moves in the run; the analysis holds it at gamma = "
                     f"{held:.6g}" + ("" if gamma is not None else " (its start, gamma0)"))
    return ctrl.linear_filter(gamma=held)


def _limits(ctrl: Any) -> tuple[float, float]:
    """The controller's output limits (infinite where it has none)."""
    given: tuple[float | None, float | None]
    if isinstance(ctrl, RecursiveIP):  # its limits are the duty's, in its column
        from ..laws import recursive_ip

        given = (float(ctrl._CP[recursive_ip.OUT_MIN, 0]),
                 float(ctrl._CP[recursive_ip.OUT_MAX, 0]))
    else:
        given = getattr(ctrl, "output_limits", (None, None))
    lo, hi = given
    return (-math.inf if lo is None else float(lo), math.inf if hi is None else float(hi))


def _loop(ctrl: Any, plant: Any, gamma: float | None, delay: int, substeps: int,
          level: float | None, notes: list[str], name: str) -> Analysis:
    filt = _law(ctrl, gamma, notes)
    sampled, point = _sampled_plant(plant, filt.dt, substeps, level, notes, _limits(ctrl))
    loop = LinearLoop(filt, sampled, delay=delay)
    return Analysis(name, loop, loop.margins(), point, tuple(notes))


def _held_gamma(ctrl: Any, gamma: float | None) -> float | None:
    """The gamma at which to hold a law whose gain moves: the one given, else the
    variational law's start gamma0 or the rls law's 1/alpha; None for a law whose gain is
    constant."""
    from ..laws import variational_gain as gain_law

    CP = getattr(ctrl, "_CP", None)
    if CP is None or CP.shape[0] <= gain_law.MODE or isinstance(ctrl, PID | ADRC):
        return gamma
    mode = CP[gain_law.MODE, 0]
    if mode == gain_law.CONSTANT or gamma is not None:
        return gamma
    if mode == gain_law.VARIATIONAL:
        return float(CP[gain_law.GAMMA0, 0])
    if mode == gain_law.RLS:  # where its estimate starts
        return float(CP[gain_law.INV_ALPHA, 0])
    raise ValueError("gamma = None: this controller's gain is given from outside at every "
                     "call (gain='external'); give the gamma (1/alpha) to analyse it at")


def _case_notes(cfg: Config) -> list[str]:
    """What a case's run has that its linear loop does not."""
    notes = []
    lo, hi = cfg["controller.duty_min"], cfg["controller.duty_max"]
    if math.isfinite(lo) or math.isfinite(hi):
        notes.append(f"the output limits [{lo:g}, {hi:g}] are outside the analysis: it "
                     "holds while the law's output stays within them")
    if cfg["sensor.noise"] != "none":
        notes.append("sensor noise is outside the loop's dynamics: noise_gain_h2 and "
                     "noise_gain_peak say what it does to u")
    if cfg["sensor.quantum"] > 0:
        notes.append("the sensor's quantisation is left out (a nonlinearity)")
    if cfg["actuator.rate_limit"] > 0:
        notes.append("the actuator's rate limit is left out (the analysis holds while it "
                     "is not reached)")
    if cfg["plant.schedule"] or (cfg["plant.model"] in ("buck", "boost")
                                 and cfg["plant.change_times"]):
        notes.append("the plant is taken with its parameters at t = 0: the scheduled "
                     "changes (load steps) are not in the analysis")
    return notes


def analyze(case_or_controller: Any, plant: Any = None,
            overrides: Mapping[str, Any] | None = None, *, gamma: float | None = None,
            operating_point: float | None = None, sensor: Any = None,
            actuator: Any = None, substeps: int = 1) -> Analysis:
    """The loop of a case, or of a controller on a plant, as the linear system it is
    between its limits: poles, margins, sensitivity peaks, noise gain and figures.

    Parameters
    ----------
    case_or_controller : str, Path, Config or controller
        A built-in case name, a case file, a resolved configuration, or a live controller
        (``IP``, ``IPI``, ``IPD``, ``IPID``, ``PID``, ``ADRC``, ``RecursiveIP`` with its
        ``sample_time``).
    plant : python-control system or mfcontrol.Plant
        Required with a controller (a case has its own). A python-control system (a
        continuous one by its zero-order hold; a discrete one at the controller's sample
        time); a :class:`mfcontrol.LTI` by its matrices; any other plant (the converters,
        :class:`mfcontrol.ODE`) linearised by central differences at ``operating_point``.
        Plants are made discrete as the engine integrates them (``integrator``: the
        zero-order hold, or RK4's own linear map).
    overrides : mapping, optional
        Dotted keys set on the case first (as ``--set``).
    gamma : float, optional
        The gain at which to hold a law whose gain moves (variational, external, rls);
        default the variational law's gamma0, the rls law's starting 1/alpha.
    operating_point : float, optional
        The output level at which to linearise a nonlinear plant: the steady state with
        that output. Default: the reference at the end of the case's run (with a
        controller, its setpoint). Refused for a linear plant, where it would change
        nothing.
    sensor, actuator : mfcontrol.Sensor, mfcontrol.Actuator, optional
        With a controller: their delays (samples) are the loop's; a case has its own.
    substeps : int
        With a controller and a mfcontrol plant: integration steps per sample
        (``simulate_loop``'s ``substeps``).

    Returns
    -------
    Analysis
        ``.margins`` (a dict), ``.poles()``, ``.transfer_functions()``, ``.plot()``,
        ``.write(folder)``, ``.notes``.

    Examples
    --------
    >>> import mfcontrol
    >>> a = mfcontrol.analyze("bench-lag3")
    >>> a.margins["stable"], round(a.margins["Ms"], 2)
    (True, 1.38)

    A live controller on a python-control plant:

    >>> import control
    >>> pi = mfcontrol.PID(kp=2.0, ki=1.0, sample_time=0.1)
    >>> round(mfcontrol.analyze(pi, control.tf([1.0], [1.0, 1.0])).margins["Ms"], 3)
    1.108
    """
    if isinstance(case_or_controller, str | Path | Config):
        if plant is not None or sensor is not None or actuator is not None:
            raise TypeError("plant, sensor, actuator: a case has its own (set its keys "
                            "with overrides)")
        result = _analyze_case(case_or_controller, overrides, gamma, operating_point)
    else:
        if overrides:
            raise TypeError("overrides: for a case; a controller's parameters are its own")
        if plant is None:
            raise TypeError("plant: required with a controller (the loop it closes)")
        delay = sum(int(getattr(e, "delay", 0)) for e in (sensor, actuator) if e is not None)
        level = operating_point
        if level is None:
            level = float(getattr(case_or_controller, "setpoint", 0.0))
        result = _loop(case_or_controller, plant, gamma, delay, substeps, level, [], "")
    if operating_point is not None and result.operating_point is None:
        # a linear plant has one linearisation: the level asked for would change nothing
        raise ValueError(f"operating_point = {operating_point!r}: the plant is linear, so "
                         "there is no operating point to choose (it applies to a nonlinear "
                         "plant: the boost, the buck's power output, an ODE)")
    return result


def _case(case: Any, overrides: Mapping[str, Any] | None) -> tuple[str, Config]:
    from .cases import resolve_case

    if isinstance(case, Config):
        cfg = case.with_overrides(dict(overrides)) if overrides else case
        name = ""
    else:
        name, cfg = resolve_case(case, overrides, command="run")
    if cfg["sweep.key"] is not None:
        cfg = cfg.with_overrides({"sweep.key": None, "sweep.values": None})
    return name, cfg


def _reference_at_end(cfg: Config) -> float:
    """The reference the case's run ends at: where a nonlinear plant is linearised."""
    from ..api.params import reference_column
    from ..laws import reference

    col = reference_column(cfg)[:, 0]
    return float(reference.evaluate.py_func(*col[:5], cfg["sim.t_end"]))


def _case_loop(cfg: Config, gamma: float | None, level: float | None, notes: list[str]
               ) -> tuple[LinearLoop, dict[str, Any] | None]:
    """A case's loop: its law's filter around its plant, sampled as its run steps it
    (linearised at ``level``, default the reference the run ends at), behind its sensor's
    and actuator's delays; and where the plant was linearised."""
    from ..api.run import from_config

    ctrl = from_config.controller(cfg)
    filt = _law(ctrl, gamma, notes)
    at = _reference_at_end(cfg) if level is None else float(level)
    sampled, point = _sampled_plant(from_config.plant(cfg), filt.dt, cfg["sim.substeps"],
                                    at, notes, _limits(ctrl))
    return LinearLoop(filt, sampled, delay=cfg["sensor.delay"] + cfg["actuator.delay"]), point


def _analyze_case(case: Any, overrides: Mapping[str, Any] | None, gamma: float | None,
                  level: float | None) -> Analysis:
    name, cfg = _case(case, overrides)
    notes = _case_notes(cfg)
    loop, point = _case_loop(cfg, gamma, level, notes)
    return Analysis(name, loop, loop.margins(), point, tuple(notes))


@dataclass(frozen=True)
class Region:
    """A case's linear loop over a grid of two parameters: what :func:`region` returns.

    Attributes
    ----------
    name : str
        The case's name.
    x_key, y_key : str
        The two keys (``x`` varies along a row).
    x, y : numpy.ndarray
        Their values.
    spectral_radius, Ms, noise_gain_peak : numpy.ndarray
        Shape ``(y.size, x.size)``: the loop's largest pole modulus, its peak sensitivity
        and its peak noise-to-control gain at each cell (the peaks over a grid of
        frequencies; they mean little where the loop is unstable).
    point : tuple of float
        The case's own (x, y), marked on the figure.
    notes : tuple of str
        As :attr:`Analysis.notes`, of the case's own loop.
    """

    name: str
    x_key: str
    x: np.ndarray
    y_key: str
    y: np.ndarray
    spectral_radius: np.ndarray
    Ms: np.ndarray
    noise_gain_peak: np.ndarray
    point: tuple[float, float]
    notes: tuple[str, ...]

    @property
    def stable(self) -> np.ndarray:
        """The cells whose linear loop is asymptotically stable."""
        return self.spectral_radius < 1.0

    def to_pandas(self):
        """One row per cell: the two keys, ``spectral_radius``, ``stable``, ``Ms``,
        ``noise_gain_peak``."""
        import pandas as pd

        xx, yy = np.meshgrid(self.x, self.y)
        return pd.DataFrame({self.x_key: xx.ravel(), self.y_key: yy.ravel(),
                             "spectral_radius": self.spectral_radius.ravel(),
                             "stable": self.stable.ravel(), "Ms": self.Ms.ravel(),
                             "noise_gain_peak": self.noise_gain_peak.ravel()})

    def plot(self, path: str | Path | None = None, title: str | None = None):
        """The stable region, Ms in colour with its 1.4 and 2 contours, and the case's own
        point (:func:`mfcontrol.api.results.plotting.plot_region`)."""
        from ..api.results.plotting import plot_region

        return plot_region(self, path, title)

    def write(self, folder: str | Path) -> list[Path]:
        """``region.csv`` and ``region.png`` in ``folder``; returns their paths."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        out = [folder / "region.csv", folder / "region.png"]
        files.write_text(out[0], self.to_pandas().to_csv(index=False))
        self.plot(out[1])
        return out

    def __repr__(self) -> str:
        return (f"Region({self.name or 'loop'}: {self.y.size} {self.y_key} x {self.x.size} "
                f"{self.x_key}, {int(self.stable.sum()):,} of {self.stable.size:,} cells "
                "stable)")


def _typed(key: str, value: float) -> Any:
    """An axis value as its option takes it (a window is a whole number of samples)."""
    from ..config.options import BY_KEY

    return int(round(value)) if BY_KEY[key].kind == "int" else float(value)


def region_axes(cfg: Config, axes: Any) -> dict[str, np.ndarray]:
    """A region's two axes, parsed and checked against the case (each value valid, each
    key one its run reads): refused in one line before any work."""
    from ..api.run.batch import make_grid, parse_grid
    from ..errors import ConfigError

    grid = parse_grid(axes, flag="--region")
    if len(grid) != 2:
        raise ConfigError("--region", ", ".join(grid), "give two axes, KEY=SPEC each")
    make_grid(cfg, grid)
    return grid


def region(case: Any, axes: Any, overrides: Mapping[str, Any] | None = None, *,
           gamma: float | None = None, operating_point: float | None = None,
           points: int = 400) -> Region:
    """A case's linear loop over a grid of two of its keys: the stable region and Ms,
    from the analysis (no simulation).

    Parameters
    ----------
    case : str, Path or Config
        A built-in case name, a case file or a resolved configuration.
    axes : sequence of str, or mapping
        Two axes, as ``mfcontrol sweep --grid`` takes them: ``["controller.alpha=
        logspace(0,2,100)", "controller.kp=linspace(1,100,100)"]``, or a mapping of key
        to values.
        A controller key changes the law's filter only; another key (a plant's, a
        delay) also rebuilds the sampled plant, once per value.
    overrides, gamma, operating_point
        As :func:`analyze`.
    points : int
        Frequencies on which the peaks are taken (log-spaced over five decades below
        the Nyquist frequency).

    Returns
    -------
    Region

    Examples
    --------
    >>> import mfcontrol
    >>> r = mfcontrol.analyze_region("bench-lag3", ["controller.kp=logspace(-1,1,12)",
    ...                                             "controller.ki=logspace(-2,1,10)"])
    >>> r.spectral_radius.shape, bool(r.stable.any() and not r.stable.all())
    ((10, 12), True)
    """
    name, cfg = _case(case, overrides)
    (x_key, xs), (y_key, ys) = region_axes(cfg, axes).items()
    cells = [cfg.with_overrides({x_key: _typed(x_key, vx), y_key: _typed(y_key, vy)})
             for vy in ys for vx in xs]
    out = linear_margins(cells, ("spectral_radius", "Ms", "noise_gain_peak"),
                         (x_key, y_key), gamma=gamma, level=operating_point, points=points)
    shape = (ys.size, xs.size)
    own = analyze(cfg, gamma=gamma, operating_point=operating_point)
    return Region(name, x_key, xs, y_key, ys,
                  spectral_radius=out["spectral_radius"].reshape(shape),
                  Ms=out["Ms"].reshape(shape),
                  noise_gain_peak=out["noise_gain_peak"].reshape(shape),
                  point=(float(cfg[x_key]), float(cfg[y_key])), notes=own.notes)


#: the margins a constraint can bound (:func:`linear_margins`); the first three come from
#: the batch (:mod:`mfcontrol.analysis.region`), the others from each loop's margins
#: (about 20 to 50 ms a loop)
CONSTRAINABLE = ("spectral_radius", "Ms", "noise_gain_peak", "Mt", "gain_margin",
                 "phase_margin_deg", "delay_margin_s", "delay_margin_samples",
                 "bandwidth_rad_s", "noise_gain_h2", "steady_state_error")
_BATCHED = frozenset(CONSTRAINABLE[:3])
_OPS = ("<=", ">=")


@dataclass(frozen=True)
class Constraint:
    """A bound on one of a loop's margins, ``KEY<=VALUE`` or ``KEY>=VALUE``
    (:data:`CONSTRAINABLE`), as ``mfcontrol tune --constraint`` takes it."""

    key: str
    op: str
    bound: float

    @classmethod
    def parse(cls, text: str, flag: str = "--constraint") -> Constraint:
        from ..errors import ConfigError, as_float

        for op in _OPS:
            key, found, value = str(text).partition(op)
            if found:
                break
        else:
            raise ConfigError(flag, text, "must be KEY<=VALUE or KEY>=VALUE, e.g. 'Ms<=1.6'")
        key = key.strip()
        if key not in CONSTRAINABLE:
            raise ConfigError(flag, text, f"bounds one of {', '.join(CONSTRAINABLE)}")
        try:
            bound = as_float(value.strip())
        except ValueError:
            bound = math.nan
        if not math.isfinite(bound):
            raise ConfigError(flag, text, "must bound the key by a finite number")
        return cls(key, op, bound)

    def violation(self, values: np.ndarray) -> np.ndarray:
        """0 where the bound holds, else how far it is missed relative to the bound's
        size (inf where the margin is not a number: an unstable loop's)."""
        v = np.asarray(values, dtype=float)
        scale = max(abs(self.bound), 1e-12)
        over = (v - self.bound) if self.op == "<=" else (self.bound - v)
        with np.errstate(invalid="ignore"):
            return np.where(np.isnan(v), np.inf, np.maximum(over, 0.0) / scale)

    def __str__(self) -> str:
        return f"{self.key}{self.op}{self.bound:g}"


def linear_margins(cfgs: list[Config], keys: Any, varying: Any, *,
                   gamma: float | None = None, level: float | None = None,
                   points: int = 400) -> dict[str, np.ndarray]:
    """The margins ``keys`` (:data:`CONSTRAINABLE`) of each configuration's linear loop:
    each law's filter around its plant, batched where the keys allow it (the peaks then
    over ``points`` frequencies). The configurations differ only in the keys
    ``varying``: the plant is sampled once for each set of values of those that are not
    the controller's. ``gamma``, ``level``: as :func:`analyze`'s ``gamma`` and
    ``operating_point``."""
    from ..analysis import region as batch
    from ..api.run import from_config

    keys = list(keys)
    plant_keys = [k for k in varying if not k.startswith("controller.")]
    plants: dict[tuple, LinearLoop] = {}
    filters: list[LinearFilter] = []
    groups: list[tuple] = []
    for cfg in cfgs:
        group = tuple(repr(cfg[k]) for k in plant_keys)
        groups.append(group)
        if group not in plants:  # the first of its plant: the whole loop
            plants[group], _ = _case_loop(cfg, gamma, level, [])
            filters.append(plants[group].controller)
        else:
            filters.append(_law(from_config.controller(cfg), gamma, []))
    out = {k: np.full(len(cfgs), np.nan) for k in keys}
    for group, plant in plants.items():
        cells = [i for i, g in enumerate(groups) if g == group]
        if set(keys) <= _BATCHED:
            res = batch.loops([filters[i] for i in cells], plant, points)
            for k in keys:
                out[k][cells] = res[k]
            continue
        for i in cells:
            m = LinearLoop(filters[i], plant.plant, delay=plant.delay).margins()
            for k in keys:
                out[k][i] = m[k]
    return out
