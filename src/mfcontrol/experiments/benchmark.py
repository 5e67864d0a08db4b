"""``mfcontrol benchmark``: PIDs (searched and rule-tuned), an i-P, an i-PI and an ADRC on
every plant of the benchmark set, scored on held-out noise seeds and compared by paired
statistics.

The benchmark set is the built-in cases named ``bench-*``: the Astrom-Hagglund PID
benchmark processes, the DC motor, the buck and the boost, each with its setpoint, a load
disturbance and sensor noise, and a ``[benchmark]`` table: the objective, the search
space of each searched controller and the plant changes of its robustness map.

How the comparison is made fair (issue 32):

* **Same freedom, budget and objective.** The searched controllers are the rows of
  :data:`CONTROLLERS`: the PID tunes kp, ki, kd and its measurement filter Tf (four keys),
  the i-P alpha, kp and its estimator's window (three), the i-PI alpha, kp, ki and the
  window (four), the ADRC of order 1 its input gain b0 and its two bandwidths wc and wo
  (three); each case's ``benchmark.pid``, ``benchmark.ip``, ``benchmark.ipi``,
  ``benchmark.adrc`` give the bounds. Every search (:func:`mfcontrol.tune`) has the
  same budget, the same objective (``benchmark.objective``), starts from a random
  population (not from the case's gains) and spends its whole budget.
* **Same robustness.** Every searched point must meet ``Ms <= ms`` (default
  :data:`DEFAULT_MS`) on its linear loop (:func:`mfcontrol.analyze`); a point that misses
  it fails.
* **Restarts and held-out seeds.** Each searched controller is tuned from
  ``restarts`` optimiser seeds on the training noise seeds (``sensor.seed`` as
  scenarios, the mean over them); the best restart is kept and the restarts' spread
  reported (:func:`mfcontrol.experiments.statistics.restarts`). Every kept tuning is then
  scored on held-out noise seeds, disjoint from the training ones, as one batch run.
* **Rule-tuned references.** A SIMC and an AMIGO PID from a FOPDT model of the plant
  (:mod:`mfcontrol.analysis.tuning_rules`; from the plant's transfer function where it is
  linear, else from an open-loop step response), no search budget, scored alike.
* **The setpoint enters every controller the same way**: each case's own reference
  (a step on the Astrom-Hagglund processes, a smooth step on the others), the full
  error on every law (the PID's setpoint weight b stays 1, the rule-tuned PIDs' too:
  the ultra-local laws have no counterpart to it).
* **Paired statistics**: on each plant every controller against the searched PID on the
  same held-out seeds (:func:`mfcontrol.experiments.statistics.paired`), the intervals
  widened by Bonferroni over every comparison of the run; a win is written only where
  the widened interval excludes zero.
* **Sensitivity**: every kept tuning re-scored at half and twice the sample time (the
  delays and the estimator's window kept in seconds) and with one sample of extra
  actuator delay; the servo (before the load) and regulator (from the load on) IAE apart.

Layout of ``OUT``::

    report.md                 the tables, the verdicts and the figures
    results.csv               one row per (plant, controller)
    pareto.png                IAE against TV(u): each family's searched points' front
    robustness.png            every robustness map: plants in rows, controllers in columns
    PLANT/comparison.png      the controllers on the plant's scenario
    PLANT/CONTROLLER/         scores.json (held-out scores); for a searched controller
                              restart-S/ per optimiser seed: best.toml, summary.json,
                              history.parquet, convergence.png

A tuning or a scoring whose result is in place with the same inputs is not run again:
an interrupted benchmark resumes where it stopped.
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..api.results.objective import Objective
from ..api.run import batch
from ..config.resolve import Config
from ..errors import ConfigError
from . import cases, statistics
from .tune import check_search, parse_parameters

#: the searched controllers: (name in the report, controller.law, the case's key of its
#: search space). A row whose key a case leaves unset is skipped on that plant; the
#: first row is the reference every other controller is compared with
CONTROLLERS = (("PID", "pid", "benchmark.pid"), ("i-P", "i-P", "benchmark.ip"),
               ("i-PI", "i-PI", "benchmark.ipi"), ("ADRC", "adrc", "benchmark.adrc"))
#: the rule-tuned references (no search): their names in the report
RULES = ("PID SIMC", "PID AMIGO")
#: points per restart when no budget is given
DEFAULT_BUDGET = 2000
#: the bound on every searched loop's peak sensitivity. Astrom and Hagglund's usual range
#: is 1.2 to 2; 2 is its loose end, which still guarantees a gain margin of 2 and a phase
#: margin of 29 degrees, and leaves the searches room for performance
DEFAULT_MS = 2.0
#: the family-wise error rate of the paired comparisons (Bonferroni over all of them)
ALPHA = 0.05


@dataclass(frozen=True)
class Scale:
    """How much work a benchmark does.

    Attributes
    ----------
    budget : int
        Points per restart.
    restarts : int
        Optimiser seeds per searched controller.
    train_seeds : tuple of int
        The noise seeds (``sensor.seed``) every searched point runs on.
    held_out : tuple of int
        The noise seeds every kept tuning is scored on, disjoint from ``train_seeds``.
    plants : tuple of str or None
        The default plants (None: the whole set).
    """

    budget: int
    restarts: int
    train_seeds: tuple[int, ...]
    held_out: tuple[int, ...]
    plants: tuple[str, ...] | None = None


#: ``mfcontrol benchmark``
FULL = Scale(budget=DEFAULT_BUDGET, restarts=3, train_seeds=(1, 2, 3),
             held_out=tuple(range(1001, 1031)))
#: ``mfcontrol benchmark --quick``: two plants, fewer points and seeds, the same report
QUICK = Scale(budget=150, restarts=3, train_seeds=(1, 2),
              held_out=tuple(range(1001, 1013)), plants=("bench-lag3", "bench-dc-motor"))
#: the held-out re-scorings beside the nominal one
VARIANTS = ("h/2", "2h", "delay+1")
#: the scores compared with the searched PID's, one Bonferroni family: the objective,
#: then the servo IAE (before the load step) and the regulator IAE (from it)
COMPARED = ("objective", "servo", "regulator")


def plants() -> list[str]:
    """The built-in cases of the benchmark set."""
    return [n for n in cases.names() if n.startswith("bench-")]


@dataclass
class Entry:
    """One controller on one plant: how it was tuned and how it scored.

    ``scores`` holds per held-out seed the objective (``"objective"``), the servo and
    regulator IAE, TV(u), and the objective of each of :data:`VARIANTS`; empty where the
    controller has no tuning (the search found no point meeting the bound, or the rule
    has no model of the plant: ``note`` says which).
    """

    plant: str
    controller: str
    kind: str  # "searched" or "rule"
    config: Config | None
    tuned: dict[str, float]
    note: str = ""
    restart_values: list[float] = field(default_factory=list)
    evaluations: int = 0
    tuning_seconds: float = 0.0
    scores: dict[str, np.ndarray] = field(default_factory=dict)
    linear: dict[str, Any] = field(default_factory=dict)
    map_scores: np.ndarray = field(default_factory=lambda: np.zeros(0))
    n_map: int = 0
    n_settled: int = 0
    #: against the searched PID on the objective (None: this is it, or no comparison
    #: could be made: ``comparison_note`` says why)
    comparison: statistics.PairedComparison | None = None
    comparison_note: str = ""
    #: against the searched PID on the servo and the regulator IAE apart (where made)
    parts: dict[str, statistics.PairedComparison] = field(default_factory=dict)

    def mean(self, key: str = "objective") -> float:
        s = self.scores.get(key)
        return float(np.mean(s)) if s is not None and s.size else math.nan

    def row(self) -> dict[str, Any]:
        c = self.comparison
        spread = _restarts(self.restart_values)
        return {"plant": self.plant, "controller": self.controller, "kind": self.kind,
                "gains": _gains(self.tuned) or self.note,
                "points": self.evaluations,
                "restarts": len(self.restart_values),
                "restart_best": spread.best if spread else math.nan,
                "restart_spread": spread.spread if spread else math.nan,
                "objective": self.mean(),
                **{f"objective_{k}": self.mean(k) for k in VARIANTS},
                "iae_servo": self.mean("servo"), "iae_regulator": self.mean("regulator"),
                "tv_u": self.mean("tv_u"),
                "held_out_seeds": int(self.scores["objective"].size) if self.scores else 0,
                "not_settled_seeds": int(np.sum(~np.isfinite(self.scores["objective"])))
                if self.scores else 0,
                **{f"linear_{k}" if k == "stable" else k: self.linear.get(k, math.nan)
                   for k in LINEAR},
                "settled_map": f"{self.n_settled}/{self.n_map}",
                "vs_pid_difference": c.mean_difference if c else math.nan,
                "vs_pid_low": c.low if c else math.nan,
                "vs_pid_high": c.high if c else math.nan,
                "vs_pid_wilcoxon_p": c.wilcoxon_p if c else math.nan,
                "vs_pid_verdict": c.verdict if c else self.comparison_note,
                **{f"vs_pid_{k}_verdict": self.parts[k].verdict if k in self.parts else ""
                   for k in COMPARED[1:]},
                "tuning_s": round(self.tuning_seconds, 1)}


#: what the report gives of each loop's linear analysis
LINEAR = ("stable", "Ms", "gain_margin", "phase_margin_deg", "delay_margin_s",
          "noise_gain_h2")


def _gains(tuned: dict[str, float]) -> str:
    return ", ".join(f"{k.removeprefix('controller.')} {v:.3g}" for k, v in tuned.items())


def _restarts(values: list[float]) -> statistics.Restarts | None:
    finite = [v for v in values if math.isfinite(v)]
    return statistics.restarts(finite) if len(finite) >= statistics.MIN_RESTARTS else None


def _setting(cfg: Config, key: str) -> list[str]:
    value = cfg[key]
    if not value:
        raise ConfigError(key, value, "a benchmark case must give it (see bench-lag3)")
    return list(value)


@dataclass(frozen=True)
class _Plant:
    """A plant of the benchmark as checked before any work: its case and what each
    searched controller's tuning takes."""

    label: str
    config: Config
    spaces: dict[str, tuple[list[str], list[str]]]  # controller -> (params, log keys)
    robustness: dict[str, np.ndarray]


def _check_plant(plant: str | Path, scale: Scale) -> _Plant:
    """Everything a plant's tunings and scoring will check, checked now (a mistake in
    the last plant's table must not end a long run)."""
    label, cfg = cases.resolve_case(plant, command="benchmark")
    obj = cfg["benchmark.objective"]
    Objective.parse(obj, "benchmark.objective")
    log = list(cfg["benchmark.log"])
    spaces: dict[str, tuple[list[str], list[str]]] = {}
    tuned: set[str] = set()
    axes = batch.parse_grid(_setting(cfg, "benchmark.robustness"), "benchmark.robustness")
    if len(axes) != 2:
        raise ConfigError("benchmark.robustness", cfg["benchmark.robustness"],
                          "must give exactly two KEY=SPEC axes (a map)")
    train = {"sensor.seed": np.asarray(scale.train_seeds, dtype=float)}
    for i, (name, law, key) in enumerate(CONTROLLERS):
        if cfg[key] is None and i > 0:  # a controller this plant does not search
            continue
        params = _setting(cfg, key)
        base = cfg.with_overrides({"controller.law": law})
        try:  # the bounds as the tuning will check them
            pars = parse_parameters(params)
            mine = [k for k in log if any(p.key == k for p in pars)]
            pars = parse_parameters(params, mine)
            check_search(base, pars, Objective.parse(obj), scale.budget, train)
        except ConfigError as exc:
            raise ConfigError(key, params, f"{exc.key} = {exc.value!r}: {exc.allowed}") \
                from None
        try:
            grid = batch.make_grid(base, axes)
            if batch.paper_grid(grid):  # two keys writing one model quantity are refused
                batch._cell_changes(grid)
        except ConfigError as exc:
            raise ConfigError("benchmark.robustness", f"{exc.key} = {exc.value}",
                              f"{exc.allowed} (under {name})") from None
        spaces[name] = (params, mine)
        tuned |= {p.key for p in pars}
    unused = [k for k in log if k not in tuned]
    if unused:
        raise ConfigError("benchmark.log", unused, "must name keys of the searched "
                          "controllers' spaces (" + ", ".join(k for _, _, k in CONTROLLERS)
                          + ")")
    return _Plant(label, cfg, spaces, axes)


def _sha(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def _inputs(plant: _Plant, name: str, budget: int, seed: int, scale: Scale,
            ms: float) -> dict[str, Any]:
    """What a tuning depends on: a finished tuning with the same inputs is reused."""
    params, log = plant.spaces[name]
    # the case without what this tuning does not read (the description, the robustness
    # map, the other controllers' spaces): editing those does not run it again
    case = plant.config.with_overrides({k: None for k in plant.config.explicit
                                        if k == "description" or k.startswith("benchmark.")})
    return {"case_sha256": _sha(case.to_toml()), "params": params, "log": log,
            "objective": plant.config["benchmark.objective"], "budget": budget,
            "seed": seed, "train_seeds": list(scale.train_seeds),
            "constraints": [f"Ms<={ms:g}"], "mfcontrol": __version__}


@dataclass
class _Restart:
    config: Config | None
    values: dict[str, float]
    value: float
    evaluations: int
    seconds: float


def _tuned(plant: _Plant, name: str, law: str, seed: int, scale: Scale, ms: float,
           out: Path, step: Callable[[int, int, float], None]) -> _Restart:
    """One restart of one controller's tuning (or a finished one with the same inputs,
    taken from ``out``)."""
    from .tune import tune

    params, log = plant.spaces[name]
    inputs = _inputs(plant, name, scale.budget, seed, scale, ms)
    marker = out / "benchmark.json"
    if marker.is_file() and (out / "best.toml").is_file() and (out / "summary.json").is_file():
        try:
            same = json.loads(marker.read_text()) == inputs
        except (OSError, ValueError):
            same = False
        if same:
            old = json.loads((out / "summary.json").read_text())
            _, best = cases.resolve_case(out / "best.toml")
            found = isinstance(old["best"], float | int)
            return _Restart(best.with_overrides({"sweep.grid": None}) if found else None,
                            old["parameters"], float(old["best"]) if found else math.inf,
                            int(old["evaluations"]), float(old["seconds"]))
    # no controller starts from the case's values (the PID's are a tuning rule's), and
    # every search spends the whole budget (none stops early on a collapsed population)
    r = tune(plant.config.with_overrides({"controller.law": law}), params,
             objective=inputs["objective"], budget=scale.budget, seed=seed, log=log,
             scenarios={"sensor.seed": list(scale.train_seeds)}, aggregate_by="mean",
             constraints=inputs["constraints"], progress=step, start_from_case=False,
             tol=0.0)
    r.case = f"{plant.label} ({name}, restart {seed})"
    marker.unlink(missing_ok=True)
    r.save(out)
    if r.stopped == "interrupted":
        raise KeyboardInterrupt
    marker.write_text(json.dumps(inputs, indent=2) + "\n")  # last: the tuning is whole
    found = math.isfinite(r.value)
    # the case with the best values, without the training scenarios
    return _Restart(r.config if found else None, r.best, r.value if found else math.inf,
                    r.evaluations, r.seconds)


# ---------------------------------------------------------------------------------------
# the rule-tuned references


def _fopdt_models(cfg: Config) -> tuple[Any, Any, str]:
    """The plant's FOPDT model (and SOPDT, None where there is none) and how they were
    found: Skogestad's half rule on its transfer function where the plant is linear, else
    a least-squares fit of its open-loop step response. Delays: the loop's (sensor and
    actuator, in samples) plus half a sample for the zero-order hold. Raises ConfigError
    with the reasons when neither gives a model."""
    import control

    from ..analysis import linearise
    from ..analysis import tuning_rules as rules
    from ..analysis.alpha import open_loop
    from ..api.run import from_config

    plant = from_config.plant(cfg)
    h = cfg["sim.h"]
    loop_delay = (cfg["sensor.delay"] + cfg["actuator.delay"]) * h
    delay = loop_delay + h / 2
    x0 = np.asarray(plant.x0, dtype=float)
    reasons = []
    if all(hasattr(plant, m) for m in "ABC"):  # mfcontrol.LTI
        abc = tuple(np.asarray(getattr(plant, m), dtype=float) for m in "ABC")
    else:
        abc = linearise.jacobians(plant.derivative, plant.output, x0, 0.0)
        far = [(x0, 0.0), (x0 + np.maximum(np.abs(x0), 1.0), 1.0)]
        if not linearise.is_linear(plant.derivative, plant.output, far, first=abc):
            abc = None
            reasons.append("no transfer function: the plant is nonlinear")
    if abc is not None:
        A, B, C = abc
        tf = control.ss2tf(A, B.reshape(-1, 1), C.reshape(1, -1), np.zeros((1, 1)))
        # the conversion leaves rounding (1e-15) where a numerator coefficient is zero,
        # which the half rule would read as zeros far out in the complex plane
        num = np.asarray(tf.num[0][0], dtype=float)
        num = np.where(np.abs(num) < 1e-9 * np.abs(num).max(), 0.0, num)
        tf = control.tf(np.trim_zeros(num, "f"), tf.den[0][0])
        try:
            fo = rules.fopdt_of(tf, delay)
            try:
                so = rules.sopdt_of(tf, delay)
            except ConfigError:
                so = None
            return fo, so, "the half rule on the plant's transfer function"
        except ConfigError as exc:
            reasons.append(f"half rule: {exc}")
    # the open-loop step from rest at u = 0, a quarter of the input's range
    lo, hi = cfg["controller.duty_min"], cfg["controller.duty_max"]
    rest = np.asarray(plant.derivative(0.0, x0, 0.0), dtype=float)
    if np.abs(rest).max() > 1e-9 * max(np.abs(x0).max(), 1.0):
        reasons.append("no step response: the plant is not at rest at its initial state "
                       "with u = 0")
        raise ConfigError("rule-tuned PID", cfg["plant.model"], "; ".join(reasons))
    u_step = 0.25 * (hi - lo) if math.isfinite(hi - lo) else 1.0
    n = int(round(cfg["sim.t_end"] / h))
    try:
        t, y = open_loop(plant, np.full(n, u_step), h)
        fit = rules.fit_fopdt(t, y, u_step)
    except (ConfigError, FloatingPointError) as exc:
        reasons.append(f"step fit: {exc}")
        raise ConfigError("rule-tuned PID", cfg["plant.model"], "; ".join(reasons)) from None
    m = fit.model
    return (rules.Fopdt(K=m.K, T=m.T, L=m.L + loop_delay + h / 2), None,
            f"a fit of the open-loop step response (rms {fit.rms:.3g})")


def _rule_rows(plant: _Plant) -> list[tuple[str, Config | None, dict[str, float], str]]:
    """(name, configuration or None, gains, note) of each of :data:`RULES`."""
    from ..analysis import tuning_rules as rules

    cfg = plant.config.with_overrides({"controller.law": "pid"})
    try:
        fo, so, how = _fopdt_models(cfg)
    except ConfigError as exc:
        return [(name, None, {}, f"no model: {exc.allowed}") for name in RULES]
    out: list[tuple[str, Config | None, dict[str, float], str]] = []
    for name in RULES:
        try:
            if name == "PID SIMC":
                pid = so is not None and so.T2 > 0
                g = rules.simc(so if pid else fo, kind="PID" if pid else "PI")
                model = (f"SOPDT K {so.K:.3g}, T1 {so.T1:.3g}, T2 {so.T2:.3g}, L {so.L:.3g}"
                         if pid else f"FOPDT K {fo.K:.3g}, T {fo.T:.3g}, L {fo.L:.3g}")
                note = f"SIMC {'PID' if pid else 'PI'} (tau_c = L) on the {model} of {how}"
            else:
                g = rules.amigo(fo, kind="PID")
                note = (f"AMIGO PID on the FOPDT K {fo.K:.3g}, T {fo.T:.3g}, L {fo.L:.3g} "
                        f"of {how}")
        except ConfigError as exc:
            out.append((name, None, {}, f"no gains: {exc}"))
            continue
        # the full error on the setpoint, as every other controller (the rule's b dropped)
        gains = {"controller.kp": g.kp, "controller.ki": g.ki, "controller.kd": g.kd}
        out.append((name, cfg.with_overrides({**gains, "controller.b": 1.0}), gains, note))
    return out


# ---------------------------------------------------------------------------------------
# scoring on the held-out seeds


def _variants(cfg: Config) -> dict[str, Config]:
    """The configuration at half and twice the sample time (the loop's delays and the
    estimator's window kept in seconds, so that only the sampling changes: a dead time of
    50 samples at h is 100 at h/2) and with one more sample of actuator delay."""
    from ..api.run.simulate import keys_read_by_run

    read = keys_read_by_run(cfg)

    def resampled(f: float) -> Config:
        ch: dict[str, Any] = {"sim.h": cfg["sim.h"] * f}
        for key in ("sensor.delay", "actuator.delay"):
            ch[key] = int(round(cfg[key] / f))
        if "controller.window" in read:
            ch["controller.window"] = max(2, int(round(cfg["controller.window"] / f)))
        if "controller.delay" in read:  # a compensated delay, in samples too
            ch["controller.delay"] = int(round(cfg["controller.delay"] / f))
        return cfg.with_overrides(ch)

    return {"h/2": resampled(0.5), "2h": resampled(2.0),
            "delay+1": cfg.with_overrides({"actuator.delay": cfg["actuator.delay"] + 1})}


def _run_seeds(cfg: Config, seeds: tuple[int, ...]) -> dict[str, np.ndarray]:
    """One batch run of ``cfg`` over the noise seeds: each seed's metrics."""
    grid = batch.make_grid(cfg, {"sensor.seed": np.asarray(seeds, dtype=float)})
    return batch.run_grid(grid)


def _scored(cfg: Config, seeds: tuple[int, ...], out: Path) -> dict[str, np.ndarray]:
    """The held-out scores of one configuration (or those in ``out/scores.json`` for the
    same configuration and seeds)."""
    path = out / "scores.json"
    key = {"config_sha256": _sha(cfg.to_toml()), "seeds": list(seeds),
           "variants": list(VARIANTS), "mfcontrol": __version__}
    if path.is_file():
        try:
            old = json.loads(path.read_text())
            if old["inputs"] == key:
                return {k: np.asarray(v, dtype=float) for k, v in old["scores"].items()}
        except (OSError, ValueError, KeyError):
            pass
    obj = Objective.parse(cfg["benchmark.objective"], "benchmark.objective")
    cols = _run_seeds(cfg, seeds)
    load = cols["iae_load"]
    has_load = np.isfinite(load)
    scores = {"objective": obj.score(cols),
              # without a load step the whole run is the setpoint's
              "servo": cols["iae"] - np.where(has_load, load, 0.0),
              "regulator": np.where(has_load, load, np.nan), "tv_u": cols["tv_u"]}
    for name, variant in _variants(cfg).items():
        scores[name] = obj.score(_run_seeds(variant, seeds))
    out.mkdir(parents=True, exist_ok=True)
    # Python's json writes and reads inf and nan (a seed that did not settle, no load)
    path.write_text(json.dumps({"inputs": key, "scores": {
        k: [float(x) for x in v] for k, v in scores.items()}}) + "\n")
    return scores


def _robustness(plant: _Plant, e: Entry) -> None:
    """The linear analysis of the entry's loop and its robustness map."""
    from .analyze import analyze

    shape = tuple(v.size for v in plant.robustness.values())
    e.n_map = math.prod(shape)
    if e.config is None:
        e.map_scores = np.full(shape, np.inf)
        return
    e.linear = {k: analyze(e.config).margins[k] for k in LINEAR}
    obj = Objective.parse(e.config["benchmark.objective"], "benchmark.objective")
    grid = batch.make_grid(e.config, plant.robustness)
    cols = batch.run_grid(grid)
    e.map_scores = obj.score(cols).reshape(grid.shape)
    e.n_settled = int(np.sum(cols["settled"]))


# ---------------------------------------------------------------------------------------


def benchmark(plant_names: Sequence[str | Path] | None = None, *,
              budget: int | None = None, seed: int = 0, restarts: int | None = None,
              ms: float = DEFAULT_MS, quick: bool = False,
              out: str | Path = "results/benchmark",
              progress: Callable[[float, str], None] | None = None) -> list[Entry]:
    """Tune, score and compare the controllers of :data:`CONTROLLERS` and the rule-tuned
    PIDs of :data:`RULES` on plants of the benchmark set.

    Parameters
    ----------
    plant_names : list of str, optional
        Benchmark cases (``bench-*``, or case files with a ``[benchmark]`` table);
        default: the whole set, or :data:`QUICK`'s two plants with ``quick``.
    budget : int, optional
        Points per restart, the same for every searched controller (default: the
        scale's, :data:`DEFAULT_BUDGET` or :data:`QUICK`'s).
    seed : int
        The first restart's optimiser seed; restart i uses ``seed + i``.
    restarts : int, optional
        Optimiser seeds per searched controller (default 3).
    ms : float
        The bound on every searched loop's peak sensitivity, > 1.
    quick : bool
        :data:`QUICK`'s scale: fewer plants, points and seeds, the same report.
    out : str or Path
        The report's folder (see the module's documentation).
    progress : callable, optional
        Called with the fraction done and a line of text as the work goes on.

    Returns
    -------
    list of Entry
        One per (plant, controller), in order.

    Examples
    --------
    >>> import mfcontrol.experiments.benchmark as bm
    >>> [name for name, _, _ in bm.CONTROLLERS], bm.RULES
    (['PID', 'i-P', 'i-PI', 'ADRC'], ('PID SIMC', 'PID AMIGO'))
    """
    scale = QUICK if quick else FULL
    if budget is not None:
        scale = replace(scale, budget=budget)
    if restarts is not None:
        if isinstance(restarts, bool) or not isinstance(restarts, int) \
                or restarts < statistics.MIN_RESTARTS:
            raise ConfigError("--restarts", restarts, f"must be a whole number >= "
                              f"{statistics.MIN_RESTARTS} (a spread needs two)")
        scale = replace(scale, restarts=restarts)
    if isinstance(ms, bool) or not isinstance(ms, int | float) or not math.isfinite(ms) \
            or ms <= 1.0:
        raise ConfigError("--ms", ms, "must be a finite number > 1 (the peak sensitivity "
                          "of any loop is at least 1), e.g. 2.0")
    names = list(plant_names or scale.plants or plants())
    if not names:
        raise ConfigError("--plants", names, "give at least one plant")
    out = Path(out)
    checked: dict[str, _Plant] = {}
    for name in names:  # every plant checked before any work
        plant = _check_plant(name, scale)
        if plant.label in checked:
            raise ConfigError("--plants", str(name), f"has the name {plant.label!r} of "
                              "another plant: their folders would collide")
        checked[plant.label] = plant
    started = time.perf_counter()
    n_tunings = sum(len(p.spaces) for p in checked.values()) * scale.restarts
    done = [0]  # tunings finished, for the progress bar
    entries: list[Entry] = []
    for plant in checked.values():
        rows: list[Entry] = []
        for name, law, _ in CONTROLLERS:
            if name not in plant.spaces:
                continue
            kept: list[_Restart] = []
            for i in range(scale.restarts):
                def step(k: int, total: int, best: float, i: int = i, name: str = name,
                         plant: _Plant = plant) -> None:
                    if progress:
                        progress((done[0] + k / total) / n_tunings,
                                 f"{plant.label} {name} restart {i + 1}/{scale.restarts}: "
                                 f"{k}/{total} points, best {best:.4g}")

                kept.append(_tuned(plant, name, law, seed + i, scale, ms,
                                   out / plant.label / name / f"restart-{seed + i}", step))
                done[0] += 1
            best = min(range(len(kept)), key=lambda j: kept[j].value)
            r = kept[best]
            note = "" if r.config is not None else (
                f"no point met Ms <= {ms:g} and settled in {scale.restarts} restarts")
            rows.append(Entry(plant=plant.label, controller=name, kind="searched",
                              config=r.config, tuned=r.values if r.config else {},
                              note=note, restart_values=[k.value for k in kept],
                              evaluations=sum(k.evaluations for k in kept),
                              tuning_seconds=sum(k.seconds for k in kept)))
        for name, cfg, gains, note in _rule_rows(plant):
            rows.append(Entry(plant=plant.label, controller=name, kind="rule", config=cfg,
                              tuned=gains, note=note))
        if progress:
            progress(done[0] / n_tunings, f"{plant.label}: scoring on "
                     f"{len(scale.held_out)} held-out seeds")
        for e in rows:
            if e.config is not None:
                e.scores = _scored(e.config, scale.held_out,
                                   out / plant.label / e.controller.replace(" ", "-"))
            _robustness(plant, e)
        _plant_figure(plant.label, rows, out / plant.label)
        entries.extend(rows)
    _compare_all(entries)
    seconds = time.perf_counter() - started
    write_report(entries, out, scale=scale, seed=seed, ms=ms, seconds=seconds,
                 plants_=checked)
    return entries


def _compare_all(entries: list[Entry]) -> int:
    """Each entry against the searched PID of its plant on the held-out seeds, on each
    score of :data:`COMPARED`, the intervals widened by Bonferroni over every comparison
    made (of every score); the number made."""
    ref = CONTROLLERS[0][0]
    pids = {e.plant: e for e in entries if e.controller == ref}
    pairs = []
    for e in entries:
        pid = pids.get(e.plant)
        if e.controller == ref or pid is None:
            continue
        if not e.scores or not pid.scores:
            e.comparison_note = "not compared: " + ("no tuning" if not e.scores
                                                    else f"no tuned {ref}")
            continue
        for key in COMPARED:
            if key not in e.scores or key not in pid.scores:
                continue
            bad = ~(np.isfinite(e.scores[key]) & np.isfinite(pid.scores[key]))
            if key == "regulator" and bad.all():
                continue  # no load step: no regulator score
            if bad.any():
                if key == "objective":  # nor on its parts: a run that failed has no score
                    e.comparison_note = (f"not compared: {int(bad.sum())} of {bad.size} "
                                         "held-out seeds did not settle")
                    break
                continue
            pairs.append((e, pid, key))
    confidence, n_resamples = bonferroni(len(pairs))
    for e, pid, key in pairs:
        c = statistics.paired(e.scores[key], pid.scores[key], confidence=confidence,
                              n_resamples=n_resamples)
        if key == "objective":
            e.comparison = c
        else:
            e.parts[key] = c
    return len(pairs)


def bonferroni(m: int) -> tuple[float, int]:
    """The confidence of each of ``m`` intervals whose family-wise error is :data:`ALPHA`
    (``1 - ALPHA / m``), and the bootstrap resamples it takes: the interval's ends are
    tail quantiles of the resamples, so that about 50 lie beyond each end.

    Examples
    --------
    >>> bonferroni(1), bonferroni(40)
    ((0.95, 10000), (0.99875, 80000))
    """
    tail = ALPHA / max(m, 1)
    # from the tail itself, not 1 - confidence: 1 - (1 - x) rounds, and 100 / it came out
    # a hair above 80,000 for m = 40 (80,001 resamples)
    return 1.0 - tail, max(10_000, math.ceil(round(100 / tail, 6)))


def verdict(e: Entry) -> str:
    """What the report says of an entry against the searched PID: a sentence naming a
    winner only where the (widened) interval excludes zero."""
    if e.comparison is None:
        return f"{e.controller} on {e.plant}: {e.comparison_note}"
    return e.comparison.sentence(e.controller, CONTROLLERS[0][0], e.plant)


def _plant_figure(plant: str, entries: list[Entry], out: Path) -> None:
    from .compare import compare

    shown = [e for e in entries if e.config is not None]
    if len(shown) < 2:
        return
    comp = compare([e.config for e in shown if e.config is not None])
    comp.names = [e.controller for e in shown]
    comp.save(out, title=f"{plant}: the tuned controllers on the plant's scenario "
              "(noise seed of the case)")


def pareto_front(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Indices of the points that no other point beats on both x and y (smaller is
    better), sorted by x.

    Examples
    --------
    >>> pareto_front(np.array([1.0, 2.0, 3.0, 2.5]), np.array([3.0, 1.0, 0.5, 2.0])).tolist()
    [0, 1, 2]
    """
    order = np.lexsort((y, x))
    keep, best = [], math.inf
    for i in order:
        if y[i] < best:
            keep.append(int(i))
            best = y[i]
    return np.array(keep, dtype=int)


def _searched_points(out: Path, plant: str, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Mean TV(u) and IAE over the training seeds of every point of every restart's
    search that met the bound and settled (its value finite)."""
    import pandas as pd

    frames = []
    for path in sorted((out / plant / name).glob("restart-*/history.parquet")):
        h = pd.read_parquet(path, columns=["point", "tv_u", "iae", "value"])
        h = h[np.isfinite(h["value"])]
        frames.append(h.groupby("point")[["tv_u", "iae"]].mean())
    if not frames:
        return np.zeros(0), np.zeros(0)
    both = pd.concat(frames)
    return both["tv_u"].to_numpy(), both["iae"].to_numpy()


def _pareto_figure(entries: list[Entry], out: Path, labels: list[str],
                   plants_: dict[str, _Plant]) -> Path:
    from matplotlib.figure import Figure
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    from ..api.results.plotting import save_figure, units

    n = len(labels)
    cols = min(n, 3)
    rows = math.ceil(n / cols)
    fig = Figure(figsize=(4.6 * cols, 3.8 * rows + 0.6), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    colours = dict(zip([c for c, _, _ in CONTROLLERS] + list(RULES),
                       ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple",
                        "tab:brown", "tab:gray"], strict=False))
    for ax, p in zip(axes, labels, strict=False):
        y_unit, u_unit = units(plants_[p].config)
        for e in (e for e in entries if e.plant == p):
            colour = colours.get(e.controller, "black")
            if e.kind == "searched":
                x, y = _searched_points(out, p, e.controller)
                ok = (x > 0) & (y > 0)
                x, y = x[ok], y[ok]
                if x.size:
                    ax.scatter(x, y, s=3, color=colour, alpha=0.12, linewidths=0)
                    front = pareto_front(x, y)
                    ax.step(x[front], y[front], where="post", color=colour, lw=1.5,
                            label=f"{e.controller}: searched points' front")
            if e.scores:
                ax.plot(e.mean("tv_u"), e.mean("servo") + np.nan_to_num(e.mean("regulator")),
                        "*" if e.kind == "searched" else "D", color=colour, ms=11,
                        mec="black", label=f"{e.controller}: "
                        f"{'kept' if e.kind == 'searched' else 'rule'}, held-out mean")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"TV(u), total variation of the control ({u_unit})")
        ax.set_ylabel("IAE (s)" if y_unit == "1" else f"IAE ({y_unit} s)")
        ax.set_title(p, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        for axis, (low, high) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
            # labels at 1, 2, 5 of each decade on a short axis, the decades on a long one
            # (matplotlib's minor labels collide on an axis of one or two decades)
            short = math.log10(high / low) < 2.2 if low > 0 else False
            axis.set_major_locator(LogLocator(10, subs=(1.0, 2.0, 5.0) if short else (1.0,)))
            axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            axis.set_minor_formatter(NullFormatter())
    for ax in axes[n:]:
        ax.set_visible(False)
    # one legend for all: the colours are the controllers' on every plant
    shown: dict[str, Any] = {}
    for ax in axes[:n]:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            shown.setdefault(label, handle)
    fig.legend(list(shown.values()), list(shown), loc="outside lower center",
               ncol=min(len(shown), 4), fontsize=8)
    fig.suptitle("Performance against noise sensitivity: IAE over TV(u) of every searched "
                 "point that met the Ms bound\n(mean over the training seeds; stars and "
                 "diamonds: the kept tunings on the held-out seeds)")
    path = out / "pareto.png"
    save_figure(fig, path)
    return path


def write_report(entries: list[Entry], out: Path, *, scale: Scale, seed: int, ms: float,
                 seconds: float, plants_: dict[str, _Plant]) -> Path:
    """report.md, results.csv, pareto.png and robustness.png from the entries."""
    import pandas as pd

    from ..api.results.plotting import robustness_maps, save_figure
    from .compare import format_number as num

    out.mkdir(parents=True, exist_ok=True)
    pd.DataFrame([e.row() for e in entries]).to_csv(out / "results.csv", index=False)
    labels = list(plants_)
    names = list(dict.fromkeys(e.controller for e in entries))
    by = {(e.plant, e.controller): e for e in entries}
    empty = {p: np.full(tuple(v.size for v in plants_[p].robustness.values()), np.inf)
             for p in labels}
    fig = robustness_maps(
        [[by[p, c].map_scores if (p, c) in by else empty[p] for c in names] for p in labels],
        labels, names, [plants_[p].robustness for p in labels],
        [plants_[p].config["benchmark.objective"] for p in labels])
    # a controller with no tuning on a plant has no map: said, not drawn as 25 failures
    for i, p in enumerate(labels):
        for j, name in enumerate(names):
            e = by.get((p, name))
            if e is None or e.config is None:
                ax = fig.axes[i * len(names) + j]
                ax.clear()
                ax.set_axis_off()
                ax.set_title(f"{p}: {name}", fontsize=9)
                ax.text(0.5, 0.5, "no tuning" if e is None or e.kind == "searched" else
                        "no rule-tuned gains:\nno FOPDT model", ha="center", va="center",
                        fontsize=9, transform=ax.transAxes)
    save_figure(fig, out / "robustness.png")
    _pareto_figure(entries, out, labels, plants_)
    made = [c for e in entries for c in ([e.comparison] if e.comparison else [])
            + list(e.parts.values())]
    level = made[0].confidence if made else 1 - ALPHA
    searched = ", ".join(f"`{k}`" for _, _, k in CONTROLLERS)
    lines = [
        "# Benchmark: PIDs, i-P, i-PI and ADRC on the benchmark set", "",
        f"mfcontrol {__version__}; {len(labels)} plants. This run: {seconds:.0f} s "
        "(compilation included when the cache was cold; tunings and scorings found "
        "finished in the folder are not run again); the searches themselves: "
        f"{sum(e.tuning_seconds for e in entries):.0f} s (their summary.json).", "",
        "## How the controllers were tuned and scored", "",
        f"- **Searched** ({', '.join(c for c, _, _ in CONTROLLERS)}): differential "
        f"evolution, {scale.restarts} restarts (optimiser seeds {seed} to "
        f"{seed + scale.restarts - 1}) of {scale.budget} points each, from a random first "
        "population, minimising the plant's `benchmark.objective`, the mean over the "
        f"training noise seeds (`sensor.seed` {', '.join(map(str, scale.train_seeds))}); "
        f"every point's linear loop had to meet **Ms <= {ms:g}** (`mfcontrol analyze`; "
        "Astrom and Hagglund's usual range is 1.2 to 2, and Ms <= 2 guarantees a gain "
        "margin of 2 and a phase margin of 29 degrees). The search spaces are each case's "
        f"{searched}: " + "; ".join(
            f"the {c} tunes {', '.join(keys)}" for c, keys in _searched_keys(plants_).items())
        + " (Tf: the PID's measurement filter; window: the estimator's, in samples). The "
        "restart with the best training value is kept; *restarts* gives its value and the "
        "restarts' spread (worst minus best).",
        f"- **Rule-tuned** ({', '.join(RULES)}): SIMC (a PID from the half rule's "
        "second-order model where it has a second lag, else a PI; tau_c = L) and AMIGO's "
        "PID, from a FOPDT model of the plant (the half rule on its transfer function "
        "where the plant is linear, else a fit of its open-loop step response; the loop's "
        "dead time plus half a sample). No search budget; no Ms bound (their Ms is "
        "reported); derivative filter N 10, no measurement filter, as the case sets.",
        "- **The setpoint** enters every controller the same way: each case's own "
        "reference (a step on the Astrom-Hagglund processes, a smooth step on the motor, "
        "buck and boost) and the full error; the PIDs' setpoint weight b is 1 (the rule's "
        "b of AMIGO is dropped): the i-P, i-PI and ADRC have no counterpart to it, and a tuned "
        "b would give the PID a freedom the others lack.",
        f"- **Scores**: every kept tuning on {len(scale.held_out)} held-out noise seeds "
        f"({scale.held_out[0]} to {scale.held_out[-1]}, none a training seed), one batch "
        "run. *objective* is the plant's objective, mean and 95 % bootstrap interval over "
        "the seeds; *servo* the IAE before the load step, *regulator* the IAE from it "
        "(n/a: no load step), *TV(u)* the total variation of the control. *h/2*, *2h*: "
        "the objective's mean at half and twice the sample time (the delays and the "
        "estimator's window kept in seconds, the noise's standard deviation per sample "
        "unchanged); *delay+1*: with one more sample of actuator "
        "delay. inf: some seed did not settle.",
        f"- **Significance**: each controller against the searched PID on the same "
        f"held-out seeds (`statistics.paired`: the bootstrap BCa interval of the mean "
        f"difference) on the objective, and on the servo and the regulator IAE apart. "
        f"Multiple comparisons: **Bonferroni** over all of them, the intervals widened to "
        f"{100 * level:.4g} % ({len(made)} comparisons, family-wise error {ALPHA:g}). A win "
        "is written only where the widened interval excludes zero; otherwise *no "
        "significant difference* (n.s.).", "",
        "What is known beforehand: with backward differences the i-P is a PI controller "
        "and the i-PI a PI plus a double integral (d'Andrea-Novel, Fliess, Join, Mounier, "
        "Steux, 2010), and the first-order ADRC, within its limits, a PI with a first-order "
        "low-pass on its feedback (Herbst 2013's transfer-function form; "
        "`ADRC.linear_filter()` gives the discrete one exactly); the comparison measures "
        "how well each parametrisation is found by the same search, not a different kind "
        "of control.", "",
        "## Held-out scores", "",
        "| plant | controller | tuning | objective, mean [95 % interval] | servo IAE | "
        "regulator IAE | TV(u) | h/2 | 2h | delay+1 | restarts: best, spread | "
        "against the searched PID | servo, regulator against it |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for e in entries:
        obj = e.scores.get("objective")
        if obj is None:
            cell = "n/a"
        elif not np.all(np.isfinite(obj)) or obj.size < statistics.MIN_PAIRS:
            cell = f"{num(e.mean())}" + (f" ({int(np.sum(~np.isfinite(obj)))} of "
                                         f"{obj.size} not settled)"
                                         if not np.all(np.isfinite(obj)) else "")
        else:
            m, lo, hi = statistics.mean_interval(obj)
            cell = f"{num(m)} [{num(lo)}, {num(hi)}]"
        rs = _restart_cell(e)
        tuning = _gains(e.tuned) if e.tuned else e.note
        if e.kind == "rule" and e.tuned:
            tuning += f" ({e.note})"
        c = e.comparison
        against = ("(reference)" if e.controller == CONTROLLERS[0][0] else
                   e.comparison_note if c is None else
                   ("no significant difference" if c.verdict == "no significant difference"
                    else f"**{e.controller if c.verdict == 'A better' else 'PID'} better**")
                   + f": {num(c.mean_difference)} [{num(c.low)}, {num(c.high)}], "
                   f"Wilcoxon p {c.wilcoxon_p:.2g}")
        lines.append(f"| {e.plant} | {e.controller} | {tuning} | {cell} | "
                     f"{num(e.mean('servo'))} | {num(e.mean('regulator'))} | "
                     f"{num(e.mean('tv_u'))} | "
                     + " | ".join(num(e.mean(k)) for k in VARIANTS)
                     + f" | {rs} | {against} | {_parts_cell(e)} |")
    lines += ["", "## Robustness of each loop", "",
              "`mfcontrol analyze` of each kept loop (the law's filter on the plant, "
              "linearised at the reference where it is nonlinear, no noise, no saturation): "
              "*Ms* the peak sensitivity, the gain, phase and delay margins, the *noise "
              "gain* (H2 norm from white sensor noise to u); *map*: how many members of "
              "the robustness map (`benchmark.robustness`, noise on) settle.", "",
              "| plant | controller | linear | Ms | gain margin | phase margin (deg) | "
              "delay margin (s) | noise gain | map |", "|---|---|---|---|---|---|---|---|---|"]
    for e in entries:
        lin = e.linear
        if not lin:
            lines.append(f"| {e.plant} | {e.controller} | n/a | | | | | | |")
            continue
        lines.append(f"| {e.plant} | {e.controller} | "
                     f"{'stable' if lin['stable'] else 'unstable'} | {num(lin['Ms'])} | "
                     f"{num(lin['gain_margin'])} | {num(lin['phase_margin_deg'])} | "
                     f"{num(lin['delay_margin_s'])} | {num(lin['noise_gain_h2'])} | "
                     f"{e.n_settled}/{e.n_map} |")
    spaces = {p: plants_[p].spaces for p in labels}
    lines += ["", "## What the numbers support", "", *_findings(entries, spaces), "",
              "Each comparison in full:", ""]
    lines += [f"- {verdict(e)}." for e in entries if e.controller != CONTROLLERS[0][0]]
    lines += ["", "## Figures", "",
              "IAE against TV(u) (the noise's cost in control activity) of every searched "
              "point that met the bound, and each family's front; the kept tunings on the "
              "held-out seeds:", "", "![Pareto fronts](pareto.png)", "",
              "Robustness maps (objective over the plant changes; crosses: members that did "
              "not settle or diverged):", "", "![robustness maps](robustness.png)", ""]
    for p in labels:
        lines += [f"### {p}", "", f"{plants_[p].config['description']}", "",
                  f"![{p}: the controllers on the plant's scenario]({p}/comparison.png)", ""]
    path = out / "report.md"
    path.write_text("\n".join(lines))
    return path


def _searched_keys(plants_: dict[str, _Plant]) -> dict[str, dict[str, None]]:
    """Each searched controller's tuned keys (short names, in order) over the plants."""
    keys: dict[str, dict[str, None]] = {}
    for plant in plants_.values():
        for name, (params, log) in plant.spaces.items():
            for par in parse_parameters(params, log):
                keys.setdefault(name, {})[par.key.removeprefix("controller.")] = None
    return keys


def _parts_cell(e: Entry) -> str:
    """Who is better on the servo and on the regulator IAE, where compared."""
    words = {"A better": e.controller, "B better": CONTROLLERS[0][0],
             "no significant difference": "n.s."}
    return "; ".join(f"{k}: {words[c.verdict]}" for k, c in e.parts.items())


def _restart_cell(e: Entry) -> str:
    """The restarts' best value and spread, or how many found a point."""
    from .compare import format_number as num

    if e.kind == "rule":
        return ""
    spread = _restarts(e.restart_values)
    found = sum(map(math.isfinite, e.restart_values))
    if spread is None:
        return f"{found} of {len(e.restart_values)} found a point"
    missing = "" if found == len(e.restart_values) else \
        f", {len(e.restart_values) - found} found none"
    return (f"{num(spread.best)}, {num(spread.spread)} "
            f"({100 * spread.relative_spread:.0f} %{missing})")


def _findings(entries: list[Entry],
              spaces: dict[str, dict[str, tuple[list[str], list[str]]]]) -> list[str]:
    """Plain sentences computed from the comparisons: only the significant ones name a
    winner."""
    ref = CONTROLLERS[0][0]
    out = []
    for name in dict.fromkeys(e.controller for e in entries if e.controller != ref):
        mine = [e for e in entries if e.controller == name]
        better = [e.plant for e in mine if e.comparison and e.comparison.verdict == "A better"]
        worse = [e.plant for e in mine if e.comparison and e.comparison.verdict == "B better"]
        same = [e.plant for e in mine if e.comparison
                and e.comparison.verdict == "no significant difference"]
        none = [e.plant for e in mine if e.comparison is None]
        parts = [f"{name} beats the searched {ref} on {', '.join(better)}" if better else
                 f"{name} beats the searched {ref} on no plant",
                 f"loses to it on {', '.join(worse)}" if worse else "loses on none",
                 f"no significant difference on {', '.join(same)}" if same else "",
                 f"not compared on {', '.join(none)}" if none else ""]
        out.append("- " + "; ".join(p for p in parts if p) + ".")
        for key, what in (("servo", "servo IAE"), ("regulator", "regulator IAE")):
            won = [e.plant for e in mine if key in e.parts
                   and e.parts[key].verdict == "A better"]
            lost = [e.plant for e in mine if key in e.parts
                    and e.parts[key].verdict == "B better"]
            if any(key in e.parts for e in mine):
                out.append(f"  - On the {what} alone: better on "
                           f"{', '.join(won) if won else 'no plant'}, worse on "
                           f"{', '.join(lost) if lost else 'none'}, no significant "
                           "difference elsewhere it was compared.")
    at_bound = []
    for e in entries:
        if e.kind != "searched" or e.plant not in spaces or e.controller not in spaces[e.plant]:
            continue
        params, log = spaces[e.plant][e.controller]
        for par in parse_parameters(params, log):
            v = e.tuned.get(par.key)
            if v is None or not v > 0 and par.log:
                continue
            for bound, side in ((par.low, "lower"), (par.high, "upper")):
                # near: within a factor 1.25 on a log scale (ki 0.0011 against 0.001 says
                # the search wanted less), within 1 % of the range on a linear one
                if (abs(math.log10(v / bound)) < 0.1 if par.log
                        else abs(v - bound) <= 0.01 * (par.high - par.low)):
                    at_bound.append(f"{e.controller} {par.key.removeprefix('controller.')} on "
                                    f"{e.plant} ({side}, {bound:g})")
    out.append("- Searched values at or near a bound of their search space (the best may lie "
               "beyond it): " + (", ".join(at_bound) if at_bound else "none") + ".")
    fragile = [f"{e.controller} on {e.plant} ({e.n_settled}/{e.n_map})" for e in entries
               if e.config is not None and e.n_settled < e.n_map]
    out.append("- Not settled somewhere on the robustness map: "
               + (", ".join(fragile) if fragile else "none") + ".")
    over = [f"{e.controller} on {e.plant} ({e.linear['Ms']:.3g})" for e in entries
            if e.linear and e.linear["stable"] and e.linear["Ms"] > 2.0]
    out.append("- Loops with Ms above 2 (the rule-tuned ones are not bounded): "
               + (", ".join(over) if over else "none") + ".")
    return out


def print_progress(stream=sys.stderr) -> Callable[[float, str], None]:
    """A progress callback that redraws a bar and a line of text on ``stream``."""
    t0 = time.perf_counter()

    def show(fraction: float, text: str) -> None:
        show.drawn = True  # type: ignore[attr-defined]
        filled = int(round(24 * fraction))
        bar = "#" * filled + "-" * (24 - filled)
        line = (f"\r[{bar}] {100 * fraction:3.0f} % {time.perf_counter() - t0:,.0f} s  "
                f"{text}")
        stream.write(line.ljust(110))
        stream.flush()

    show.drawn = False  # type: ignore[attr-defined]
    return show
