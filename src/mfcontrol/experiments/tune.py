"""``mfcontrol tune``: gains found by simulation, a whole population per batch call.

The search is scipy's differential evolution with ``vectorized=True``: every generation
is one call of the batch engine (:func:`mfcontrol.api.run.batch.run_range`) on a grid whose
first dimension is the population (:class:`mfcontrol.api.run.batch.Grid`'s ``points``) and
whose other dimensions are the scenarios. Each member's score is the objective
(:mod:`mfcontrol.api.results.objective`) of its run; a point's value is the worst or the mean over
its scenarios. A point whose configuration is invalid (the checks across options) or
whose run diverged scores ``inf``. The case's own values of the tuned keys start in the
first population when they lie within the bounds (unless ``start_from_case=False``), so
the result is never worse than them on the same scenarios.

Layout of ``OUT``::

    best.toml            the case with the best values: ``mfcontrol run`` reproduces its
                         nominal objective, ``mfcontrol sweep`` its scenarios (sweep.grid)
    summary.json         objective, best value, the best parameters, evaluations, time
    history.parquet      every run: generation, point, scenario, parameters, metrics, score
    convergence.png      every point's value and the best so far against evaluations
"""

from __future__ import annotations

import json
import math
import re
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import files
from .._version import __version__
from ..api.results import display
from ..api.results.objective import AGGREGATES, Objective, aggregate
from ..api.run import batch, scenario
from ..api.run.simulate import shown_keys
from ..config.options import BY_KEY, gain_adapts
from ..config.resolve import Config, axis_value
from ..errors import ConfigError

#: most evaluations (points) one search may be given: a bound on its work, said up front
MAX_BUDGET = 1_000_000
#: evaluations (points) when no budget is given
DEFAULT_BUDGET = 600
_RANGE = re.compile(r"^\s*([^=\s]+)\s*=\s*([^:]+):([^:]+)\s*$")


@dataclass(frozen=True)
class Parameter:
    """A tuned key, its bounds and how it is searched (log10 of it, whole numbers)."""

    key: str
    low: float
    high: float
    log: bool = False

    @property
    def integer(self) -> bool:
        return BY_KEY[self.key].kind == "int"

    def bounds(self) -> tuple[float, float]:
        return (math.log10(self.low), math.log10(self.high)) if self.log else (self.low,
                                                                               self.high)

    def value(self, x: np.ndarray) -> np.ndarray:
        """The key's values from the optimiser's coordinates."""
        v = 10.0 ** np.asarray(x, dtype=float) if self.log else np.asarray(x, dtype=float)
        if self.integer:
            return np.clip(np.round(v), math.ceil(self.low), math.floor(self.high))
        return np.clip(v, self.low, self.high)

    def coordinate(self, v: float) -> float:
        return math.log10(v) if self.log else float(v)


def parse_parameters(items: Sequence[str] | Mapping[str, tuple[float, float]],
                     log: Sequence[str] = ()) -> list[Parameter]:
    """``["KEY=LO:HI", ...]`` (or ``{KEY: (LO, HI)}``) and the keys searched on a log
    scale, checked: each key once, a numeric option, LO < HI finite, LO > 0 on a log
    scale."""
    pairs: list[tuple[str, Any, Any, str]] = []
    if isinstance(items, Mapping):
        for k, v in items.items():
            if not isinstance(v, tuple | list) or len(v) != 2:
                raise ConfigError("--param", f"{k}={v!r}", "expected (LO, HI)")
            pairs.append((k, v[0], v[1], f"{k}={v[0]}:{v[1]}"))
    else:
        for text in items:
            m = _RANGE.match(str(text))
            if not m:
                raise ConfigError("--param", text, "expected KEY=LO:HI, e.g. controller.kp=1:100")
            pairs.append((m[1], m[2], m[3], text))
    out: list[Parameter] = []
    for key, lo, hi, text in pairs:
        batch.check_member_key(key, "--param")
        try:
            low, high = float(lo), float(hi)
        except (TypeError, ValueError):
            raise ConfigError("--param", text, "LO and HI must be numbers") from None
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise ConfigError("--param", text, "must have finite LO < HI")
        if any(p.key == key for p in out):
            raise ConfigError("--param", key, "is given twice")
        out.append(Parameter(key, low, high, key in log))
    for p in out:
        if p.integer and math.ceil(p.low) > math.floor(p.high):
            raise ConfigError("--param", f"{p.key}={p.low:g}:{p.high:g}", "a whole-number "
                              "key needs a whole number between LO and HI")
    for key in log:
        logged = next((p for p in out if p.key == key), None)
        if logged is None:
            raise ConfigError("--log", key, "must name a tuned key (give it with --param)")
        if logged.low <= 0:
            raise ConfigError("--log", key, f"needs LO > 0 (got {logged.low:g})")
    if not out:
        raise ConfigError("--param", "", "give at least one KEY=LO:HI")
    return out


@dataclass
class TuneResult(display.Shown):
    """What :func:`tune` found.

    Attributes
    ----------
    best : dict
        The best values of the tuned keys.
    value : float
        Their objective value (the aggregate over the scenarios; ``inf`` if no point was
        valid and settled).
    nominal : float
        The objective of the best configuration's own run (no scenario set): what
        ``mfcontrol run best.toml`` reproduces.
    start, start_value : dict, float
        The case's own values of the tuned keys and their value (NaN when they were not
        evaluated: outside the bounds, or ``start_from_case=False``).
    config : Config
        The case with the best values.
    history : pandas.DataFrame
        Every run: generation, point, scenario, the tuned and scenario keys, the metric
        columns, the run's score and its point's value.
    """

    case: str
    objective: Objective
    aggregate: str
    parameters: list[Parameter]
    scenarios: dict[str, np.ndarray]
    best: dict[str, float]
    value: float
    nominal: float
    start: dict[str, float]
    start_value: float
    config: Config
    evaluations: int
    runs: int
    seconds: float
    stopped: str
    budget: int
    seed: int
    history: Any = field(repr=False)
    #: the bounds on the linear analysis every accepted point met (``Ms<=1.6``, ...)
    constraints: list[str] = field(default_factory=list)

    def _summary(self) -> list[tuple[str, str]]:
        best = ", ".join(f"{k} = {display.fmt(v)}" for k, v in self.best.items())
        start = ", ".join(f"{k} = {display.fmt(v)}" for k, v in self.start.items())
        return [("case", self.case), ("best", best),
                ("objective", f"{display.fmt(self.value)} (nominal run "
                              f"{display.fmt(self.nominal)}; start {start}: "
                              f"{display.fmt(self.start_value)})"),
                ("effort", f"{self.evaluations:,} points, {self.runs:,} runs in "
                           f"{self.seconds:.3g} s, stopped: {self.stopped}")]

    def __repr__(self) -> str:
        rows = dict(self._summary())
        return (f"<TuneResult {rows['case']!r}: {rows['best']}\n objective {rows['objective']}"
                f"\n {rows['effort']}>")


    @property
    def n_scenarios(self) -> int:
        """Scenarios each point ran on (1 without a scenario grid)."""
        return _n_scenarios(self.scenarios)

    def summary(self) -> dict[str, Any]:
        return {"case": self.case, "objective": self.objective.text,
                "aggregate": self.aggregate, "best": files.json_number(self.value),
                "nominal": files.json_number(self.nominal),
                "parameters": {k: v for k, v in self.best.items()},
                "bounds": {p.key: [p.low, p.high] for p in self.parameters},
                "log": [p.key for p in self.parameters if p.log],
                "start": {"parameters": self.start, "value": files.json_number(self.start_value)},
                "scenarios": {k: v.tolist() for k, v in self.scenarios.items()},
                "n_scenarios": self.n_scenarios,
                "evaluations": self.evaluations, "runs": self.runs, "budget": self.budget,
                "seed": self.seed, "stopped": self.stopped,
                "constraints": self.constraints,
                "seconds": round(self.seconds, 3), "mfcontrol": __version__}

    def save(self, out: str | Path) -> Path:
        """Write best.toml, summary.json, history.parquet and convergence.png into
        ``out``; return the folder."""
        from ..api.results.plotting import convergence

        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        scen = [f"{k}={','.join(repr(float(x)) for x in v)}"
                for k, v in self.scenarios.items()]
        cfg = self.config.with_overrides({"sweep.grid": scen or None})
        values = ", ".join(f"{k} = {v!r}" for k, v in self.best.items())
        head = (f"# tuned by mfcontrol {__version__} from {self.case}: {values}\n"
                f"# objective {self.objective.text}: {self.nominal!r} for this case's own run "
                "(mfcontrol run)")
        if self.evaluations == 0:
            head = (f"# tuning of {self.case} interrupted before any point was evaluated: "
                    "the case as it was")
        if self.scenarios and self.evaluations:
            head += (f";\n# {self.aggregate} over the {self.n_scenarios} "
                     f"scenarios of sweep.grid (mfcontrol sweep): {self.value!r}")
        (out / "best.toml").write_text(head + "\n" + cfg.to_toml(shown_keys(cfg)))
        (out / "summary.json").write_text(json.dumps(self.summary(), indent=2) + "\n")
        self.history.to_parquet(out / "history.parquet", index=False)
        per_point = self.history.drop_duplicates("point") if len(self.history) else \
            self.history
        where = (f", {self.aggregate} over {self.n_scenarios} scenarios"
                 if self.scenarios else "")
        convergence(per_point["point"].to_numpy(), per_point["value"].to_numpy(),
                    {p.key: per_point[p.key].to_numpy() for p in self.parameters},
                    self.objective.text, f"Tuning {self.case}\n{self.evaluations} of "
                    f"{self.budget} points by differential evolution{where} "
                    f"({_STOPPED[self.stopped]})", out / "convergence.png",
                    log=tuple(p.key for p in self.parameters if p.log))
        return out


_STOPPED = {"budget": "budget spent", "converged": "population converged",
            "interrupted": "interrupted"}


def _n_scenarios(scenarios: Mapping[str, np.ndarray]) -> int:
    return math.prod(v.size for v in scenarios.values()) if scenarios else 1


def tune(case: str | Path | Config, params: Sequence[str] | Mapping[str, tuple[float, float]],
         *, objective: str = "iae", scenarios: Sequence[str] | Mapping[str, Any] | None = None,
         aggregate_by: str = "max", budget: int = DEFAULT_BUDGET, seed: int = 0,
         log: Sequence[str] = (), overrides: Mapping[str, Any] | None = None,
         out: str | Path | None = None,
         progress: Callable[[int, int, float], None] | None = None,
         start_from_case: bool = True, tol: float = 0.01,
         constraints: Sequence[str] = ()) -> TuneResult:
    """Minimise an objective over some keys of a case by simulation.

    Parameters
    ----------
    case : str, Path or Config
        A built-in case, a case file or a resolved configuration.
    params : list of "KEY=LO:HI", or {KEY: (LO, HI)}
        The tuned keys and their bounds.
    objective : str
        A metric or a weighted sum (:mod:`mfcontrol.api.results.objective`), default ``"iae"``.
    scenarios : list of "KEY=SPEC", or {KEY: SPEC or values}, optional
        Every point runs on each member of this grid (as ``mfcontrol sweep --grid`` takes
        it): plant variations, noise seeds. None: the case alone.
    aggregate_by : {"max", "mean"}
        A point's value over its scenarios: the worst or the mean.
    budget : int
        Points to evaluate at most (each runs every scenario); the search may stop
        earlier when its population has converged.
    seed : int
        The optimiser's seed: the same seed gives the same search.
    log : list of str
        Tuned keys searched on a log scale (their LO must be > 0).
    overrides : mapping, optional
        Keys set on the case first (as ``--set``).
    out : str or Path, optional
        Write best.toml, summary.json, history.parquet and convergence.png there.
    progress : callable, optional
        Called after each generation with (points evaluated, budget, best value).
    start_from_case : bool
        Put the case's own values of the tuned keys (when within the bounds) in the first
        population, so that the result is never worse than them. A comparison of
        controllers turns it off: no controller starts from a point chosen for it.
    tol : float
        Stop once every member of the population has a real value and their spread
        (standard deviation) is within this fraction of their mean (scipy's default
        rule); 0 spends the whole budget.
    constraints : list of str
        Bounds on the linear analysis of each point's loop (:func:`mfcontrol.analyze`),
        e.g. ``["Ms<=1.6", "delay_margin_s>=0.05"]``: a point that misses one counts as
        failed (its value inf, ranked by how far it misses). Checked on the case's own
        loop, not on each scenario. ``Ms``, ``noise_gain_peak`` and ``spectral_radius``
        cost a fraction of a run; the other margins 20 to 50 ms a point.

    Returns
    -------
    TuneResult
        Also when interrupted (Ctrl-C): the best so far, ``stopped = "interrupted"``.

    Examples
    --------
    >>> import mfcontrol
    >>> r = mfcontrol.tune("first-order-ip-algebraic", ["controller.kp=1:50"],
    ...                    budget=40, overrides={"sim.t_end": 1.0})
    >>> r.value <= r.start_value, r.value == r.nominal
    (True, True)
    """
    import pandas as pd
    from scipy.optimize import differential_evolution

    from . import cases

    t0 = time.perf_counter()
    if isinstance(case, Config):
        name, base = "config", case.with_overrides(dict(overrides or {}))
        cases.check_reads(base, "run", overrides or {})
    else:
        name, base = cases.resolve_case(case, overrides, command="run")
    if base["sweep.key"] is not None:
        raise ConfigError("case", name, "is a sweep case (sweep.key): tune a single case")
    base = base.with_overrides({"sweep.grid": None})
    obj = Objective.parse(objective)
    if aggregate_by not in AGGREGATES:
        raise ConfigError("--aggregate", aggregate_by, f"must be one of {', '.join(AGGREGATES)}")
    if not isinstance(seed, int | np.integer) or isinstance(seed, bool) or seed < 0:
        raise ConfigError("--seed", seed, "must be a whole number >= 0")
    if not isinstance(tol, int | float) or isinstance(tol, bool) or not 0 <= tol < 1:
        raise ConfigError("tol", tol, "must be a number in [0, 1)")
    pars = parse_parameters(params, log)
    from .analyze import Constraint, linear_margins

    bounds = [Constraint.parse(c) for c in constraints]
    scen = batch.parse_grid(scenarios, "--scenarios") if scenarios else {}
    for k in scen:
        if any(p.key == k for p in pars):
            raise ConfigError("--scenarios", k, "is also a tuned key (--param)")
    budget, per_dim, size = check_search(base, pars, obj, budget, scen)
    keys = tuple(p.key for p in pars)
    n_scen = _n_scenarios(scen)
    scen_grid = batch.Grid(base=base, axes=scen) if scen else None
    # scenario keys the checks across options read: each point is checked with each of
    # their values (else with the base's)
    from ..config.resolve import _check_consistency, keys_read

    checked = keys_read(_check_consistency, base)
    scen_settings = ([{k: axis_value(k, v[0]) for k, v in scen_grid.values(m, m + 1).items()
                       if k in checked} for m in range(n_scen)] if scen_grid else [{}])
    scen_settings = [dict(t) for t in {tuple(sorted(c.items())) for c in scen_settings}]

    rows: list[pd.DataFrame] = []
    state: dict[str, Any] = {"evals": 0, "runs": 0, "gen": 0, "best": math.inf,
                             "best_values": None, "converged": False, "error": None}

    # each key's own check is an interval that the bounds, checked above, enclose: only
    # keys the checks across options read need each point checked (a key they do not
    # read on this case's path cannot change it, since a key that changes the path is
    # read on it); that check costs more than the point's run
    combined = bool((set(keys) | set(scen)) & checked)

    def valid(point: dict[str, float]) -> bool:
        if not combined:
            return True
        try:
            for setting in scen_settings:
                base.with_overrides({**point, **setting})
            return True
        except ConfigError:
            return False

    def evaluate(X: np.ndarray) -> np.ndarray:
        try:
            return _evaluate(X)
        except (KeyboardInterrupt, _Abort):
            raise
        except Exception as exc:  # noqa: BLE001 - carried past scipy, re-raised below
            # scipy turns a ValueError (a ConfigError is one) into a RuntimeError about
            # its map-like callable: carry the original out instead
            state["error"] = exc
            raise _Abort from None

    def _evaluate(X: np.ndarray) -> np.ndarray:
        X = np.atleast_2d(np.asarray(X, dtype=float).T).T  # (D, S) even for one point
        values = {p.key: p.value(X[i]) for i, p in enumerate(pars)}
        if state["gen"] == 0 and inside:  # scipy's first point is the case's own values:
            for p in pars:                # run them exactly (10 ** log10(v) may not be v)
                values[p.key][0] = start[p.key]
        n = X.shape[1]
        ok = np.array([valid({k: axis_value(k, v[j]) for k, v in values.items()})
                       for j in range(n)], dtype=bool)
        scores = np.full(n, np.inf)
        seen = np.ones(n)  # what the optimiser sees of a failed point (see _PENALTY)
        frames = []
        cols = None
        if ok.any():
            grid = batch.Grid(base=base, axes={**{k: v[ok] for k, v in values.items()},
                                               **scen}, points=keys)
            cols = batch.run_range(grid, 0, grid.n_members)
            per_run = obj.score(cols)
            scores[ok] = aggregate(per_run.reshape(-1, n_scen), aggregate_by)
            seen[ok] = _badness(cols, n_scen, base["metrics.settled_tol"],
                                scenario.n_steps(base))
            linear: dict[str, np.ndarray] = {}
            if bounds:  # the analysis of each point's own loop; a miss fails the point
                idx = np.flatnonzero(ok)
                linear = linear_margins(
                    [base.with_overrides({k: axis_value(k, v[j]) for k, v in values.items()})
                     for j in idx], {b.key for b in bounds}, keys)
                miss = np.max([b.violation(linear[b.key]) for b in bounds], axis=0)
                failed = idx[miss > 0]
                scores[failed] = np.inf
                # above a point that meets them, below one whose run failed (0.1 and up)
                seen[failed] = np.maximum(seen[failed], 0.05 * np.minimum(miss[miss > 0], 1))
            point = np.flatnonzero(ok)[cols["member"] // n_scen] + state["evals"]
            frames.append(pd.DataFrame({"generation": state["gen"], "point": point,
                                        "scenario": cols["member"] % n_scen,
                                        "refused": False,
                                        **{k: v for k, v in cols.items() if k != "member"},
                                        **{f"linear_{k}": np.repeat(v, n_scen)
                                           for k, v in linear.items()},
                                        "score": per_run,
                                        "value": np.repeat(scores[ok], n_scen)}))
        bad = np.flatnonzero(~ok)
        if bad.size:
            frames.append(pd.DataFrame({"generation": state["gen"],
                                        "point": bad + state["evals"], "scenario": -1,
                                        "refused": True,
                                        **{k: v[bad] for k, v in values.items()},
                                        "diverged": False, "settled": False,
                                        "score": np.inf, "value": np.inf}))
        # the bookkeeping at once, so that an interrupt leaves it whole
        j = int(np.argmin(scores))
        rows.extend(frames)
        state["runs"] += int(ok.sum()) * n_scen
        if scores[j] < state["best"]:
            state["best"] = float(scores[j])
            state["best_values"] = {k: axis_value(k, v[j]) for k, v in values.items()}
        state["evals"] += n
        state["gen"] += 1
        if progress:
            progress(state["evals"], budget, state["best"])
        return np.where(np.isfinite(scores), scores, _PENALTY * (1.0 + seen))

    def converged(intermediate_result) -> bool:  # the name scipy looks for
        """Stop when every member of the population has a real value and they agree to
        ``tol`` (scipy's rule, which would also stop on a population of penalties)."""
        e = intermediate_result.population_energies
        if tol > 0 and np.all(e < _PENALTY) and np.std(e) <= tol * abs(np.mean(e)):
            state["converged"] = True
        return state["converged"]

    # the case's own values first: the result is never worse than them
    start = {p.key: base[p.key] for p in pars}
    inside = start_from_case and all(start[p.key] is not None and
                                     p.low <= start[p.key] <= p.high for p in pars)
    x_start = np.array([_inside(p, p.coordinate(start[p.key])) for p in pars]) \
        if inside else None
    maxiter = budget // size - 1
    stopped = "budget"
    try:
        differential_evolution(
            evaluate, [p.bounds() for p in pars], popsize=per_dim, maxiter=maxiter,
            rng=np.random.default_rng(seed), polish=False, vectorized=True,
            # scipy's own test, std <= atol + tol |mean|, would stop on a population of
            # equal penalties: never true with these, only the callback stops the search
            updating="deferred", init="latinhypercube", x0=x_start, tol=0.0, atol=-1.0,
            callback=converged,
            # whole numbers: scipy rounds its coordinates, which for a log-scaled key are
            # log10 of the value; Parameter.value rounds those itself
            integrality=[p.integer and not p.log for p in pars])
        if state["converged"]:
            stopped = "converged"
    except KeyboardInterrupt:
        stopped = "interrupted"
    except _Abort:
        raise state["error"] from None
    history = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(
        columns=["generation", "point", "scenario", *keys, "score", "value"])
    start_value = math.nan  # not evaluated: outside the bounds, or not asked for
    if inside and not history.empty:
        first = history[history["point"] == 0]
        start_value = float(first["value"].iloc[0]) if len(first) else math.nan
    best, best_cfg, value, nominal = start, base, math.nan, math.nan
    if state["best_values"] is not None:  # the values evaluated, not recomputed
        best = state["best_values"]
        best_cfg = base.with_overrides(best)
        value = state["best"]
        try:
            nominal = _nominal(best_cfg, obj)
        except KeyboardInterrupt:
            stopped = "interrupted"
    elif state["evals"]:
        value = math.inf  # evaluated, nothing valid and settled
    result = TuneResult(
        case=name, objective=obj, aggregate=aggregate_by, parameters=pars, scenarios=scen,
        best=best, value=value, nominal=nominal, start=start, start_value=start_value,
        config=best_cfg, evaluations=state["evals"], runs=state["runs"],
        seconds=time.perf_counter() - t0, stopped=stopped, budget=budget, seed=seed,
        history=history, constraints=[str(b) for b in bounds])
    if out is not None:
        result.save(out)
    return result


def check_search(base: Config, pars: list[Parameter], obj: Objective, budget: Any,
                 scenarios: Mapping[str, np.ndarray] | None = None) -> tuple[int, int, int]:
    """The checks of a search made before any run, for :func:`tune` and for a caller that
    checks many searches up front (the benchmark): the budget against the population
    (:func:`population`, whose result it returns), the bounds and scenarios as a grid
    checks its axes (a key the run does not read among them), an objective the case
    leaves undefined."""
    sizes = population(budget, len(pars))
    keys = tuple(p.key for p in pars)
    batch.make_grid(base, {**{p.key: np.array([p.low, p.high]) for p in pars},
                           **dict(scenarios or {})}, points=keys)
    _refuse_undefined_objective(obj, base)
    return sizes


def population(budget: Any, d: int) -> tuple[int, int, int]:
    """(budget, population per tuned key, population) of a search over d keys: scipy's
    default of 15 per key, fewer when the budget would allow fewer than four
    generations, at least five members (scipy's floor); the budget must hold two
    generations."""
    if not isinstance(budget, int | np.integer) or isinstance(budget, bool):
        raise ConfigError("--budget", budget, "must be a whole number")
    budget = int(budget)
    if budget > MAX_BUDGET:
        raise ConfigError("--budget", budget, f"must be at most {MAX_BUDGET:,} points (some "
                          "hours of runs: a search that large is better split)")
    per_dim = max(1, min(15 * d, budget // 4) // d)
    size = max(5, per_dim * d)
    if budget < max(10, 2 * size):
        raise ConfigError("--budget", budget, f"must be a whole number >= {max(10, 2 * size)} "
                          f"(two generations of {size} points for {d} tuned keys)")
    return budget, per_dim, size


def _inside(p: Parameter, c: float) -> float:
    """A start coordinate that scipy's scaling of the bounds keeps within them (a value on
    a bound can land 1e-16 outside, which scipy refuses); ``Parameter.value`` clips the
    value back onto the bound."""
    lo, hi = p.bounds()
    for _ in range(8):
        scaled = (c - 0.5 * (lo + hi)) * (1.0 / abs(hi - lo)) + 0.5
        if 0.0 <= scaled <= 1.0:
            break
        c = np.nextafter(c, 0.5 * (lo + hi))
    return float(c)


class _Abort(Exception):
    """Carries an error out of scipy's optimiser (see ``evaluate``)."""


def _refuse_undefined_objective(obj: Objective, base: Config) -> None:
    """An objective that the case leaves undefined (``iae_load`` without a load step
    within the horizon, a step metric without a step reference) would score inf at every
    point: refused before the search."""
    from ..api.run import from_config
    from ..api.run.loop import load_step_of

    names = set(obj.metrics)
    if "iae_load" in names:
        n = scenario.n_steps(base)
        load = load_step_of(from_config.elements(base), [from_config.changes(base)],
                            base["sim.t_end"], n)[0]
        if not math.isfinite(load):
            raise ConfigError("--objective", obj.text, "iae_load is not defined for this "
                              "case: it needs a load step (a step disturbance or a plant "
                              "schedule) within the horizon")
    if "adaptation_error" in names and not gain_adapts(base):
        raise ConfigError("--objective", obj.text, "adaptation_error is not defined for "
                          "this case: it needs the variational gain (controller.law = "
                          "variational, or controller.adapt = variational on an i-P, i-PI, "
                          "i-PD or i-PID)")
    step = names & {"overshoot", "rise_time", "settling_time"}
    if step and base["reference.kind"] != "smooth-step":
        raise ConfigError("--objective", obj.text, f"{', '.join(sorted(step))} is not "
                          "defined for this case: it needs a step reference "
                          "(reference.kind = smooth-step)")


#: what the optimiser sees of a point that scored inf: this times (1 + its badness). Not
#: inf, because a population that failed everywhere would stall scipy's search (it
#: evaluates an all-inf population again, the same points); graded, so that such a
#: population still moves towards points that fail less, and above any real objective
_PENALTY = 1e100


def _badness(cols: dict[str, np.ndarray], n_scen: int, tol: float, n: int) -> np.ndarray:
    """How badly each point's worst scenario failed, in [0, 1]: a settled run whose
    objective is not a number 0; a run not settled by the rule 0.1 .. 0.5 (its final error
    over the tolerance; 0.5 where that ratio is not a number); a diverged run 0.5 .. 1
    (the earlier in its n samples, the worse)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = cols["max_abs_e_final"] / (tol * cols["max_abs_ref"])
    graded = np.isfinite(ratio) & (ratio >= 1)
    unsettled = np.where(graded, 0.5 - 0.4 / np.where(graded, ratio, 1.0), 0.5)
    bad = np.where(cols["diverged"], 1.0 - 0.5 * cols["n_samples"] / n,
                   np.where(cols["settled"], 0.0, unsettled))
    return bad.reshape(-1, n_scen).max(axis=1)


def _nominal(cfg: Config, obj: Objective) -> float:
    """The objective of the configuration's single run, the way ``mfcontrol run`` runs it."""
    from ..api.run.simulate import simulate

    return obj.score_run(simulate(cfg).metrics)
