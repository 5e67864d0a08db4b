"""``mfcontrol benchmark``: a PID, an i-P and an i-PI tuned alike on every plant of the set.

The benchmark set is the built-in cases named ``bench-*``: the Astrom-Hagglund PID
benchmark processes, the DC motor, the buck and the boost, each with its setpoint step,
a load disturbance and sensor noise, and a ``[benchmark]`` table: the objective, the
search space of each controller and the plant changes of its robustness map.

On each plant every controller is tuned by :func:`mfcontrol.tune` with the same budget,
seed, objective and scenario (the case as shipped: setpoint, load and noise together),
then its best configuration is evaluated on

* setpoint tracking and load rejection without noise: IAE before the load step
  (``iae - iae_load``) and from it on (``iae_load``);
* noise sensitivity: TV(u), the total variation of the control, with the case's noise;
* robustness: the objective over the robustness map (the plant changes of
  ``benchmark.robustness``, with noise): its worst member, how many
  settle (track within ``metrics.settled_tol``) and how many have a stable linear loop.

Layout of ``OUT``::

    report.md                 the table, the figures and what they show
    results.csv               the table's numbers, one row per (plant, controller)
    robustness.png            every map: plants in rows, controllers in columns
    PLANT/comparison.png      the three tuned controllers on the plant's scenario
    PLANT/CONTROLLER/         the tuning's best.toml, summary.json, history.parquet,
                              convergence.png

A tuning whose summary.json is in place (same budget, seed and objective) is not run
again: an interrupted benchmark resumes where it stopped.
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..api.results.objective import Objective
from ..api.run import batch
from ..config.resolve import Config
from ..errors import ConfigError
from . import cases
from .tune import check_search, parse_parameters

#: the controllers compared: (name in the report, controller.law, benchmark key)
CONTROLLERS = (("PID", "pid", "benchmark.pid"), ("i-P", "i-P", "benchmark.ip"),
               ("i-PI", "i-PI", "benchmark.ipi"))
#: points per tuning when no budget is given
DEFAULT_BUDGET = 3000


def plants() -> list[str]:
    """The built-in cases of the benchmark set."""
    return [n for n in cases.names() if n.startswith("bench-")]


@dataclass
class Entry:
    """One controller on one plant: its tuning and its evaluation."""

    plant: str
    controller: str
    config: Config
    tuned: dict[str, float]
    evaluations: int
    objective: float
    iae_setpoint: float
    iae_load: float
    tv_u_noise: float
    worst: float
    n_settled: int
    n_map: int
    settled: bool
    tuning_seconds: float
    map_scores: np.ndarray
    #: the tuned loop's linear analysis (:func:`mfcontrol.analyze`): the keys of
    #: :data:`LINEAR`, nan where the search found no settled point
    linear: dict[str, Any] = field(default_factory=dict)
    #: how many members of the robustness map have a stable linear loop (spectral radius
    #: below 1, :func:`mfcontrol.analyze`); 0 where the search found no settled point
    n_linear_stable: int = 0

    def row(self) -> dict[str, Any]:
        return {"plant": self.plant, "controller": self.controller,
                "gains": ", ".join(f"{k.removeprefix('controller.')} {v:.3g}"
                                   for k, v in self.tuned.items()) or "no settled point found",
                "points": self.evaluations, "objective": self.objective,
                "iae_setpoint": self.iae_setpoint, "iae_load": self.iae_load,
                "tv_u_noise": self.tv_u_noise, "worst_map_settled": self.worst,
                "settled_map": f"{self.n_settled}/{self.n_map}",
                "linear_stable_map": f"{self.n_linear_stable}/{self.n_map}",
                "settled": self.settled,
                "tuning_s": round(self.tuning_seconds, 1),
                **{f"linear_{k}" if k == "stable" else k: self.linear.get(k, math.nan)
                   for k in LINEAR}}


#: what the report gives of each tuned loop's linear analysis
LINEAR = ("stable", "Ms", "gain_margin", "phase_margin_deg", "delay_margin_s",
          "noise_gain_h2")


def _setting(cfg: Config, key: str) -> list[str]:
    value = cfg[key]
    if not value:
        raise ConfigError(key, value, "a benchmark case must give it (see bench-lag3)")
    return list(value)


@dataclass(frozen=True)
class _Plant:
    """A plant of the benchmark as checked before any work: its case and what each
    controller's tuning takes."""

    label: str
    config: Config
    spaces: dict[str, tuple[list[str], list[str]]]  # controller -> (params, log keys)
    robustness: dict[str, np.ndarray]


def _check_plant(plant: str | Path, budget: int) -> _Plant:
    """Everything a plant's tunings and evaluation will check, checked now (a mistake in
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
    for name, law, key in CONTROLLERS:
        params = _setting(cfg, key)
        base = cfg.with_overrides({"controller.law": law})
        try:  # the bounds as the tuning will check them
            pars = parse_parameters(params)
            mine = [k for k in log if any(p.key == k for p in pars)]
            pars = parse_parameters(params, mine)
            check_search(base, pars, Objective.parse(obj), budget)
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
        raise ConfigError("benchmark.log", unused, "must name keys of benchmark.pid, "
                          "benchmark.ip or benchmark.ipi")
    return _Plant(label, cfg, spaces, axes)


def _inputs(plant: _Plant, name: str, budget: int, seed: int) -> dict[str, Any]:
    """What a tuning depends on: a finished tuning with the same inputs is reused."""
    params, log = plant.spaces[name]
    # the case without what this tuning does not read (the description, the robustness
    # map, the other controllers' spaces): editing those does not run it again
    case = plant.config.with_overrides({k: None for k in plant.config.explicit
                                        if k == "description" or k.startswith("benchmark.")})
    return {"case_sha256": hashlib.sha256(case.to_toml().encode()).hexdigest(),
            "params": params,
            "log": log, "objective": plant.config["benchmark.objective"], "budget": budget,
            "seed": seed, "mfcontrol": __version__}


def _tuned(plant: _Plant, name: str, law: str, budget: int, seed: int, out: Path,
           progress: Callable[[float, str], None] | None,
           at: tuple[int, int]) -> tuple[Config | None, dict, int, float]:
    """Tune one controller (or take a finished tuning with the same inputs from
    ``out``): its best configuration, values, points evaluated and seconds."""
    from .tune import tune

    params, log = plant.spaces[name]
    inputs = _inputs(plant, name, budget, seed)
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
            return (best.with_overrides({"sweep.grid": None}) if found else None,
                    old["parameters"], int(old["evaluations"]), float(old["seconds"]))

    def step(done: int, total: int, best: float) -> None:
        if progress:
            progress((at[0] + done / total) / at[1],
                     f"{plant.label} {name}: {done}/{total} points, best {best:.4g}")

    # no controller starts from the case's values (the PID's are a tuning rule's), and
    # every search spends the whole budget (none stops early on a collapsed population)
    r = tune(plant.config.with_overrides({"controller.law": law}), params,
             objective=inputs["objective"], budget=budget, seed=seed, log=log,
             progress=step, start_from_case=False, tol=0.0)
    r.case = f"{plant.label} ({name})"
    marker.unlink(missing_ok=True)
    r.save(out)
    if r.stopped == "interrupted":
        raise KeyboardInterrupt
    marker.write_text(json.dumps(inputs, indent=2) + "\n")  # last: the tuning is whole
    # a search that found no settled point has no tuned gains to evaluate
    return (r.config if math.isfinite(r.value) else None), r.best, r.evaluations, r.seconds


def _evaluate(plant: _Plant, name: str, cfg: Config | None, tuned: dict, evaluations: int,
              seconds: float) -> Entry:
    from ..api.run.simulate import simulate

    if cfg is None:  # the search found no settled point: nothing to evaluate
        shape = tuple(v.size for v in plant.robustness.values())
        return Entry(plant=plant.label, controller=name, config=plant.config, tuned={},
                     evaluations=evaluations, objective=math.inf, iae_setpoint=math.nan,
                     iae_load=math.nan, tv_u_noise=math.nan, worst=math.inf, n_settled=0,
                     n_map=math.prod(shape), settled=False, tuning_seconds=seconds,
                     map_scores=np.full(shape, np.inf))
    from .analyze import analyze, linear_margins

    obj = Objective.parse(cfg["benchmark.objective"], "benchmark.objective")
    margins = analyze(cfg).margins
    quiet = simulate(cfg.with_overrides({"sensor.noise": "none"})).metrics
    noisy = simulate(cfg).metrics
    grid = batch.make_grid(cfg, plant.robustness)
    cols = batch.run_grid(grid)
    scores = obj.score(cols).reshape(grid.shape)
    # the analysis's verdict on each member beside the run's (which tracks, with noise)
    radius = linear_margins([grid.config(j) for j in range(grid.n_members)],
                            ["spectral_radius"], list(plant.robustness))["spectral_radius"]
    finite = np.isfinite(scores)
    load = quiet["iae_load"]
    return Entry(plant=plant.label, controller=name, config=cfg, tuned=tuned,
                 evaluations=evaluations, objective=obj.score_run(noisy),
                 # without a load step the whole run is the setpoint's
                 iae_setpoint=quiet["iae"] - (load if math.isfinite(load) else 0.0),
                 iae_load=load, tv_u_noise=noisy["tv_u"],
                 worst=float(scores[finite].max()) if finite.any() else math.inf,
                 n_settled=int(np.sum(cols["settled"])), n_map=grid.n_members,
                 n_linear_stable=int(np.sum(radius < 1.0)),
                 settled=bool(noisy["settled"] and quiet["settled"]),
                 tuning_seconds=seconds, map_scores=scores,
                 linear={k: margins[k] for k in LINEAR})


def benchmark(plant_names: Sequence[str | Path] | None = None, *,
              budget: int = DEFAULT_BUDGET, seed: int = 0,
              out: str | Path = "results/benchmark",
              progress: Callable[[float, str], None] | None = None) -> list[Entry]:
    """Tune and evaluate a PID, an i-P and an i-PI on plants of the benchmark set.

    Parameters
    ----------
    plant_names : list of str, optional
        Benchmark cases (``bench-*``, or case files with a ``[benchmark]`` table);
        default: the whole set (:func:`plants`).
    budget : int
        Points per tuning at most, the same for every controller (the tuning of a key
        set whose population does not divide the budget uses a few points fewer).
    seed : int
        The tuner's seed, the same for every tuning.
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
    >>> bm.plants()[:3], [name for name, _, _ in bm.CONTROLLERS]
    (['bench-boost', 'bench-buck', 'bench-dc-motor'], ['PID', 'i-P', 'i-PI'])
    """
    names = list(plant_names or plants())
    if not names:
        raise ConfigError("--plants", names, "give at least one plant")
    out = Path(out)
    checked: dict[str, _Plant] = {}
    for name in names:  # every plant checked before any work
        plant = _check_plant(name, budget)
        if plant.label in checked:
            raise ConfigError("--plants", str(name), f"has the name {plant.label!r} of "
                              "another plant: their folders would collide")
        checked[plant.label] = plant
    entries: list[Entry] = []
    started = time.perf_counter()
    total = len(checked) * len(CONTROLLERS)
    for plant in checked.values():
        tuned = []
        for name, law, _ in CONTROLLERS:
            best, values, evaluations, seconds = _tuned(
                plant, name, law, budget, seed, out / plant.label / name, progress,
                (len(entries), total))
            entry = _evaluate(plant, name, best, values, evaluations, seconds)
            entries.append(entry)
            tuned.append(entry)
        _plant_figure(plant.label, tuned, out / plant.label)
    seconds = time.perf_counter() - started
    write_report(entries, out, budget=budget, seed=seed, seconds=seconds,
                 plants_={p.label: p for p in checked.values()})
    return entries


def _plant_figure(plant: str, entries: list[Entry], out: Path) -> None:
    from .compare import compare

    shown = [e for e in entries if e.tuned]  # those whose search found a settled point
    if len(shown) < 2:
        return
    comp = compare([e.config for e in shown])
    comp.names = [e.controller for e in shown]
    comp.save(out, title=f"{plant}: {', '.join(comp.names)} tuned alike (the plant's "
              "scenario, with noise)")


def write_report(entries: list[Entry], out: Path, *, budget: int, seed: int,
                 seconds: float, plants_: dict[str, _Plant]) -> Path:
    """report.md, results.csv and robustness.png from the entries."""
    import pandas as pd

    from ..api.results.plotting import robustness_maps
    from .compare import format_number as num

    out.mkdir(parents=True, exist_ok=True)
    table = pd.DataFrame([e.row() for e in entries])
    table.to_csv(out / "results.csv", index=False)
    labels = list(plants_)
    by = {(e.plant, e.controller): e for e in entries}
    robustness_maps(
        [[by[p, c].map_scores for c, _, _ in CONTROLLERS] for p in labels],
        labels, [c for c, _, _ in CONTROLLERS], [plants_[p].robustness for p in labels],
        [plants_[p].config["benchmark.objective"] for p in labels], out / "robustness.png")
    points = sorted({e.evaluations for e in entries})
    lines = [
        "# Benchmark: PID, i-P and i-PI tuned alike on the benchmark set", "",
        f"mfcontrol {__version__}; {len(labels)} plants, {len(CONTROLLERS)} controllers. "
        f"Every tuning: differential evolution with a budget of {budget} points (used: "
        f"{points[0]} to {points[-1]}, the column *points*: every search spends the "
        "whole budget, but a population that does not divide it leaves a few points "
        f"unused), seed {seed}, from a random first "
        "population (no controller starts from the case's own gains), minimising the "
        "plant's `benchmark.objective` on the plant's case as shipped (its reference, "
        "disturbance and noise together). The search spaces are each case's "
        "`benchmark.pid`, `benchmark.ip` and `benchmark.ipi` (in each tuning's "
        "summary.json); keys they leave out keep the case's values. The whole run took "
        f"{seconds:.0f} s (compilation included when the cache was cold; tunings found "
        "finished in the folder are not run again).", "",
        "Columns: *objective* is the tuned objective on that scenario; *IAE setpoint* "
        "and *IAE load* come from the same run without noise, before and from the load "
        "step (n/a: the case has none); *TV(u) noise* is the total variation of the "
        "control with the noise; *settled map* is how many members of the robustness map "
        "(the plant changes of `benchmark.robustness`, noise on) settle, i.e. track "
        "within `metrics.settled_tol` of the reference over the run's last "
        "`metrics.final_window` (a tracking test, not a stability one), *linear map* how "
        "many have a stable linear loop (`mfcontrol analyze`: every pole inside the unit "
        "circle, no noise, no saturation), *worst (settled)* the objective's worst value "
        "over those that settle (inf: none does); *settled* is the nominal run's verdict "
        "with and without noise. A controller whose nominal run does not settle is never "
        "named best below.", "",
        "| plant | controller | gains | points | objective | IAE setpoint | IAE load | "
        "TV(u) noise | settled map | linear map | worst (settled) | settled |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for e in entries:
        r = e.row()
        lines.append(f"| {e.plant} | {e.controller} | {r['gains']} | {e.evaluations} | "
                     f"{num(e.objective)} | {num(e.iae_setpoint)} | {num(e.iae_load)} | "
                     f"{num(e.tv_u_noise)} | {r['settled_map']} | {r['linear_stable_map']} | "
                     f"{num(e.worst)} | {'yes' if e.settled else 'no'} |")
    lines += ["", "## Each tuned loop, linear", "",
              "The tuned controllers' loops as `mfcontrol analyze` sees them (the law's "
              "filter on the plant, linearised at the reference where it is nonlinear, "
              "within the output limits, without noise): *linear* is the linear loop's "
              "stability (every pole inside the unit circle), *Ms* the peak sensitivity "
              "(1.4 to 2 is the usual range), the gain, phase and delay margins, and the "
              "*noise gain*, the H2 norm from white sensor noise to u (the factor on the "
              "noise's standard deviation).", "",
              "| plant | controller | linear | Ms | gain margin | phase margin (deg) | "
              "delay margin (s) | noise gain |", "|---|---|---|---|---|---|---|---|"]
    for e in entries:
        m = e.linear
        if not m:
            lines.append(f"| {e.plant} | {e.controller} | n/a | | | | | |")
            continue
        lines.append(f"| {e.plant} | {e.controller} | "
                     f"{'stable' if m['stable'] else 'unstable'} | {num(m['Ms'])} | "
                     f"{num(m['gain_margin'])} | {num(m['phase_margin_deg'])} | "
                     f"{num(m['delay_margin_s'])} | {num(m['noise_gain_h2'])} |")
    fragile = {c: sum(1 for e in entries if e.controller == c and e.linear
                      and e.linear["stable"] and e.linear["Ms"] > 2.0)
               for c, _, _ in CONTROLLERS}
    lines += ["", "Tuned loops with Ms above 2: " + ", ".join(
        f"{c} {n} of {sum(1 for e in entries if e.controller == c)}"
        for c, n in fragile.items()) + ". The tuning's objective does not ask for "
        "robustness; these figures say what it gave."]
    spaces = {p: plants_[p].spaces for p in labels}
    lines += ["", "## What the table shows", "", *_findings(entries, labels, spaces), "",
              "## Figures", "",
              "Robustness maps (objective over the plant changes; crosses: members that did "
              "not settle or diverged):", "", "![robustness maps](robustness.png)", ""]
    for p in labels:
        lines += [f"### {p}", "", f"{plants_[p].config['description']}", "",
                  f"![{p}: the three tuned controllers]({p}/comparison.png)", ""]
    path = out / "report.md"
    path.write_text("\n".join(lines))
    return path


def _findings(entries: list[Entry], plants_: list[str],
              spaces: dict[str, dict[str, tuple[list[str], list[str]]]]) -> list[str]:
    """Plain sentences computed from the table: who wins what among the settled
    controllers, where the intelligent ones lose, and where any is fragile."""
    out = []
    names = [c for c, _, _ in CONTROLLERS]

    def winner(p: str, attr: str) -> str | None:
        vals = {e.controller: (-e.n_settled, e.worst) if attr == "robust" else
                (getattr(e, attr),) for e in entries if e.plant == p and e.settled}
        vals = {c: v for c, v in vals.items() if all(math.isfinite(x) for x in v[1:]
                                                     if attr == "robust") and
                (attr == "robust" or math.isfinite(v[0]))}
        return min(vals, key=lambda c: (vals[c], names.index(c))) if vals else None

    for attr, what in (("objective", "the tuned objective"),
                       ("iae_setpoint", "setpoint tracking (IAE without noise)"),
                       ("iae_load", "load rejection (IAE from the load step, no noise)"),
                       ("tv_u_noise", "the quietest control under noise (TV(u))"),
                       ("robust", "robustness (most settled members of the map, then the "
                        "lowest worst value)")):
        won = {p: winner(p, attr) for p in plants_}
        wins = {c: [p for p in plants_ if won[p] == c] for c in names}
        parts = [f"{c} on {len(ps)} ({', '.join(ps)})" if ps else f"{c} on none"
                 for c, ps in wins.items()]
        nobody = [p for p in plants_ if won[p] is None]
        if nobody:
            parts.append(f"no settled controller with a number on {', '.join(nobody)}")
        out.append(f"- Best on {what}: " + "; ".join(parts) + ".")
    lost = []
    for p in plants_:
        pid = next(e for e in entries if e.plant == p and e.controller == "PID")
        for e in entries:
            if e.plant != p or e.controller == "PID":
                continue
            if not e.settled and pid.settled:
                lost.append(f"{e.controller} on {p} (not settled)")
            elif e.settled and pid.settled and e.objective > pid.objective:
                lost.append(f"{e.controller} on {p} "
                            f"({e.objective / pid.objective:.3g}x the PID's)")
    out.append("- Where an intelligent controller loses to the PID on the tuned objective: "
               + (", ".join(lost) if lost else "nowhere") + ".")
    at_bound = []
    for e in entries:
        params, log = spaces[e.plant][e.controller]
        for par in parse_parameters(params, log):
            v = e.tuned.get(par.key)
            if v is None or not v > 0 and par.log:
                continue
            for bound, side in ((par.low, "lower"), (par.high, "upper")):
                if (abs(math.log(v / bound)) < 0.01 if par.log
                        else abs(v - bound) <= 0.001 * (par.high - par.low)):
                    at_bound.append(f"{e.controller} {par.key.removeprefix('controller.')} on "
                                    f"{e.plant} ({side}, {bound:g})")
    out.append("- Tuned values at a bound of their search space (the best may lie beyond "
               "it): " + (", ".join(at_bound) if at_bound else "none") + ".")
    fragile = [f"{e.controller} on {e.plant} ({e.n_settled}/{e.n_map})" for e in entries
               if e.n_settled < e.n_map]
    out.append("- Not settled somewhere on the robustness map: "
               + (", ".join(fragile) if fragile else "none") + ".")
    linear = [f"{e.controller} on {e.plant} ({e.n_linear_stable}/{e.n_map})" for e in entries
              if e.tuned and e.n_linear_stable < e.n_map]
    out.append("- A linear loop unstable somewhere on the robustness map (the plant as it is "
               "at t = 0, before any load step; the output limits can hold such a loop in a "
               "bounded oscillation): " + (", ".join(linear) if linear else "none") + ".")
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
