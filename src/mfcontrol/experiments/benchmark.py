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
  ``benchmark.robustness``, with noise): its worst member and how many are stable.

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

import json
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..api import batch
from ..api.objective import Objective
from ..config.resolve import Config
from ..errors import ConfigError
from . import cases
from .tune import parse_parameters

#: the controllers compared: (name in the report, controller.law, benchmark key)
CONTROLLERS = (("PID", "pid", "benchmark.pid"), ("i-P", "i-P", "benchmark.ip"),
               ("i-PI", "i-PI", "benchmark.ipi"))
#: points per tuning when no budget is given
DEFAULT_BUDGET = 1500


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
    objective: float
    iae_setpoint: float
    iae_load: float
    tv_u_noise: float
    worst: float
    n_stable: int
    n_map: int
    stable: bool
    tuning_seconds: float
    map_scores: np.ndarray

    def row(self) -> dict[str, Any]:
        return {"plant": self.plant, "controller": self.controller,
                "gains": ", ".join(f"{k.removeprefix('controller.')} {v:.3g}"
                                   for k, v in self.tuned.items()),
                "objective": self.objective, "iae_setpoint": self.iae_setpoint,
                "iae_load": self.iae_load, "tv_u_noise": self.tv_u_noise,
                "worst_map": self.worst, "stable_map": f"{self.n_stable}/{self.n_map}",
                "stable": self.stable, "tuning_s": round(self.tuning_seconds, 1)}


def _setting(cfg: Config, key: str) -> list[str]:
    value = cfg[key]
    if not value:
        raise ConfigError(key, value, "a benchmark case must give it (see bench-lag3)")
    return list(value)


def _tuned(plant: str, cfg: Config, name: str, law: str, key: str, budget: int, seed: int,
           out: Path, progress: Callable[[float, str], None] | None,
           at: tuple[int, int]) -> tuple[Config, dict, float]:
    """Tune one controller (or take a finished tuning from ``out``)."""
    from .tune import tune

    params = _setting(cfg, key)
    try:
        tuned_keys = [p.key for p in parse_parameters(params)]
    except ConfigError as exc:
        raise ConfigError(key, params, exc.allowed) from None
    log = [k for k in cfg["benchmark.log"] if k in tuned_keys]
    objective = cfg["benchmark.objective"]
    base = cfg.with_overrides({"controller.law": law})
    summary = out / "summary.json"
    if summary.is_file() and (out / "best.toml").is_file():
        old = json.loads(summary.read_text())
        if (old.get("budget"), old.get("seed"), old.get("objective")) == (
                budget, seed, objective) and old.get("stopped") != "interrupted":
            _, best = cases.resolve_case(out / "best.toml")
            return (best.with_overrides({"sweep.grid": None}), old["parameters"],
                    float(old["seconds"]))

    def step(done: int, total: int, best: float) -> None:
        if progress:
            progress((at[0] + done / total) / at[1],
                     f"{plant} {name}: {done}/{total} points, best {best:.4g}")

    # no controller starts from the case's values: the PID's are a tuning rule's
    r = tune(base, params, objective=objective, budget=budget, seed=seed, log=log,
             progress=step, start_from_case=False)
    r.case = f"{plant} ({name})"
    r.save(out)
    if r.stopped == "interrupted":
        raise KeyboardInterrupt
    return r.config, r.best, r.seconds


def _evaluate(plant: str, name: str, cfg: Config, tuned: dict, seconds: float) -> Entry:
    from ..api.simulate import simulate

    obj = Objective.parse(cfg["benchmark.objective"], "benchmark.objective")
    quiet = simulate(cfg.with_overrides({"sensor.noise": "none"})).metrics
    noisy = simulate(cfg).metrics
    axes = batch.parse_grid(_setting(cfg, "benchmark.robustness"))
    grid = batch.make_grid(cfg, axes)
    cols = batch.run_grid(grid)
    scores = obj.score(cols).reshape(grid.shape)
    nominal = float(obj.score({k: np.array([noisy[k]]) for k in
                               (*obj.metrics, "diverged", "stable")})[0])
    return Entry(plant=plant, controller=name, config=cfg, tuned=tuned, objective=nominal,
                 iae_setpoint=quiet["iae"] - (quiet["iae_load"] if math.isfinite(
                     quiet["iae_load"]) else 0.0),
                 iae_load=quiet["iae_load"], tv_u_noise=noisy["tv_u"],
                 worst=float(scores[np.isfinite(scores)].max()) if np.isfinite(
                     scores).any() else math.inf,
                 n_stable=int(np.sum(cols["stable"])),
                 n_map=grid.n_members, stable=bool(noisy["stable"] and quiet["stable"]),
                 tuning_seconds=seconds, map_scores=scores)


def benchmark(plant_names: Sequence[str] | None = None, *, budget: int = DEFAULT_BUDGET,
              seed: int = 0, out: str | Path = "results/benchmark",
              progress: Callable[[float, str], None] | None = None) -> list[Entry]:
    """Tune and evaluate a PID, an i-P and an i-PI on plants of the benchmark set.

    Parameters
    ----------
    plant_names : list of str, optional
        Benchmark cases (``bench-*``, or case files with a ``[benchmark]`` table);
        default: the whole set (:func:`plants`).
    budget : int
        Points per tuning, the same for every controller.
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
    entries: list[Entry] = []
    started = time.perf_counter()
    configs = {}
    for plant in names:  # every plant's settings checked before any work
        label, cfg = cases.resolve_case(plant)
        for _, law, key in CONTROLLERS:
            try:  # the bounds as the tuning will check them
                pars = parse_parameters(_setting(cfg, key))
                batch.make_grid(cfg.with_overrides({"controller.law": law}),
                                {p.key: np.array([p.low, p.high]) for p in pars},
                                points=tuple(p.key for p in pars))
            except ConfigError as exc:
                raise ConfigError(key, cfg[key], f"{exc.key} = {exc.value!r}: "
                                  f"{exc.allowed}") from None
        try:
            batch.make_grid(cfg, batch.parse_grid(_setting(cfg, "benchmark.robustness")))
        except ConfigError as exc:
            raise ConfigError("benchmark.robustness", f"{exc.key} = {exc.value}",
                              exc.allowed) from None
        Objective.parse(cfg["benchmark.objective"], "benchmark.objective")
        configs[label] = cfg
    total = len(configs) * len(CONTROLLERS)
    for plant, cfg in configs.items():
        tuned = []
        for name, law, key in CONTROLLERS:
            best, values, seconds = _tuned(plant, cfg, name, law, key, budget, seed,
                                           out / plant / name, progress,
                                           (len(entries), total))
            entry = _evaluate(plant, name, best, values, seconds)
            entries.append(entry)
            tuned.append(entry)
        _plant_figure(plant, tuned, out / plant)
    seconds = time.perf_counter() - started
    write_report(entries, out, budget=budget, seed=seed, seconds=seconds)
    return entries


def _plant_figure(plant: str, entries: list[Entry], out: Path) -> None:
    from .compare import compare

    comp = compare([e.config for e in entries])
    comp.names = [e.controller for e in entries]
    comp.save(out, title=f"{plant}: {', '.join(comp.names)} tuned alike (the plant's "
              "scenario, with noise)")


def write_report(entries: list[Entry], out: Path, *, budget: int, seed: int,
                 seconds: float) -> Path:
    """report.md, results.csv and robustness.png from the entries."""
    import pandas as pd

    from ..api.plotting import robustness_maps

    out.mkdir(parents=True, exist_ok=True)
    table = pd.DataFrame([e.row() for e in entries])
    table.to_csv(out / "results.csv", index=False)
    plants_ = list(dict.fromkeys(e.plant for e in entries))
    by = {(e.plant, e.controller): e for e in entries}
    first = {p: next(e for e in entries if e.plant == p) for p in plants_}
    axes = {p: batch.parse_grid(_setting(first[p].config, "benchmark.robustness"))
            for p in plants_}
    robustness_maps(
        [[by[p, c].map_scores for c, _, _ in CONTROLLERS] for p in plants_],
        plants_, [c for c, _, _ in CONTROLLERS], [axes[p] for p in plants_],
        [first[p].config["benchmark.objective"] for p in plants_], out / "robustness.png")

    def num(v: float) -> str:
        return "inf" if not math.isfinite(v) else f"{v:.4g}"

    lines = [
        "# Benchmark: PID, i-P and i-PI tuned alike on the benchmark set", "",
        f"mfcontrol {__version__}; {len(plants_)} plants, {len(CONTROLLERS)} controllers; "
        f"every tuning: differential evolution with {budget} points, seed {seed}, on the "
        "plant's shipped scenario (setpoint step, load step and sensor noise together), "
        "minimising the plant's `benchmark.objective`, from a random first population "
        "(no controller starts from the case's own gains); the search spaces are the case's "
        "`benchmark.pid`, `benchmark.ip` and `benchmark.ipi` (the i-P and the i-PI also "
        "tune their algebraic estimator's window, their own filter, as the PID keeps its "
        "derivative filter N = 10). The whole run took "
        f"{seconds:.0f} s (compilation included when the cache was cold).", "",
        "Columns: *objective* is the tuned objective on that scenario; *IAE setpoint* "
        "and *IAE load* come from the same run without noise, before and after the load "
        "step; *TV(u) noise* is the total variation of the control with the noise; "
        "*stable map* is how many members of the robustness map (the plant changes of "
        "`benchmark.robustness`, noise on) are stable, *worst map* the objective's worst "
        "value over those that are; *stable* is the nominal run's stability with and "
        "without noise. inf: no member or run was stable.", "",
        "| plant | controller | gains | objective | IAE setpoint | IAE load | TV(u) noise "
        "| worst map | stable map | stable |",
        "|---|---|---|---|---|---|---|---|---|---|"]
    for e in entries:
        r = e.row()
        lines.append(f"| {e.plant} | {e.controller} | {r['gains']} | {num(e.objective)} | "
                     f"{num(e.iae_setpoint)} | {num(e.iae_load)} | {num(e.tv_u_noise)} | "
                     f"{num(e.worst)} | {r['stable_map']} | {'yes' if e.stable else 'no'} |")
    lines += ["", "## What the table shows", "", *_findings(entries, plants_), "",
              "## Figures", "",
              "Robustness maps (objective over the plant changes; crosses: unstable or "
              "diverged members):", "", "![robustness maps](robustness.png)", ""]
    for p in plants_:
        lines += [f"### {p}", "", f"{cases.describe(p)}.", "",
                  f"![{p}: the three tuned controllers]({p}/comparison.png)", ""]
    path = out / "report.md"
    path.write_text("\n".join(lines))
    return path


def _findings(entries: list[Entry], plants_: list[str]) -> list[str]:
    """Plain sentences computed from the table: who wins what, and where the intelligent
    controllers lose."""
    out = []
    names = [c for c, _, _ in CONTROLLERS]

    def winner(p: str, attr: str) -> str:
        vals = {e.controller: (-e.n_stable, e.worst) if attr == "robust" else getattr(e, attr)
                for e in entries if e.plant == p}
        return min(vals, key=lambda c: (vals[c], names.index(c)))

    for attr, what in (("objective", "the tuned objective"),
                       ("iae_setpoint", "setpoint tracking (IAE without noise)"),
                       ("iae_load", "load rejection (IAE after the load step)"),
                       ("tv_u_noise", "the quietest control under noise (TV(u))"),
                       ("robust", "robustness (most stable members of the map, then the "
                        "lowest worst value)")):
        wins = {c: [p for p in plants_ if winner(p, attr) == c] for c in names}
        parts = [f"{c} on {len(ps)} ({', '.join(ps)})" if ps else f"{c} on none"
                 for c, ps in wins.items()]
        out.append(f"- Best on {what}: " + "; ".join(parts) + ".")
    lost = []
    for p in plants_:
        pid = next(e for e in entries if e.plant == p and e.controller == "PID")
        for e in entries:
            if e.plant == p and e.controller != "PID" and e.objective > pid.objective:
                how = (f"{e.objective / pid.objective:.3g}x the PID's"
                       if math.isfinite(e.objective) else "unstable")
                lost.append(f"{e.controller} on {p} ({how})")
    out.append("- Where an intelligent controller loses to the PID on the tuned objective: "
               + (", ".join(lost) if lost else "nowhere") + ".")
    fragile = [f"{e.controller} on {e.plant} ({e.n_stable}/{e.n_map})" for e in entries
               if e.n_stable < e.n_map]
    out.append("- Unstable somewhere on the robustness map: "
               + (", ".join(fragile) if fragile else "none") + ".")
    return out


def print_progress(stream=sys.stderr) -> Callable[[float, str], None]:
    """A progress callback that redraws a bar and a line of text on ``stream``."""
    t0 = time.perf_counter()

    def show(fraction: float, text: str) -> None:
        filled = int(round(24 * fraction))
        bar = "#" * filled + "-" * (24 - filled)
        line = (f"\r[{bar}] {100 * fraction:3.0f} % {time.perf_counter() - t0:,.0f} s  "
                f"{text}")
        stream.write(line.ljust(110))
        stream.flush()

    return show
