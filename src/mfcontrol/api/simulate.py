"""Run resolved configurations through the compiled engine."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from .._version import __version__
from ..config.resolve import Config, axis_value
from ..engine import trajectory
from ..numerics import grid
from . import metrics, scenario
from .result import Result, SweepResult


def _result(name: str, cfg: Config, scn: scenario.Scenario, M, traj, j: int, m: int,
            fast: bool = False) -> Result:
    met = metrics.from_kernel(M, j, cfg["metrics.stable_tol"])
    n = met["n_samples"]
    signals, states = trajectory.named_rows(traj[:, m, :n], (), scn.state_names)
    return Result(name=name, config=cfg, time=scn.time()[:n], signals=signals, states=states,
                  metrics=met, version=__version__, arithmetic="fast" if fast else "exact")


def compiled(cfg: Config) -> bool:
    """Whether the paper's tuned kernel covers this configuration (the paper's laws on the
    buck with RK4); everything else runs in the general engine
    (:mod:`mfcontrol.engine.compose`) with the same laws."""
    return (cfg["plant.model"] == "buck" and cfg["controller.law"] in ("ip", "variational")
            and cfg["sim.integrator"] == "rk4" and not cfg["plant.schedule"])


def simulate(cfg: Config, name: str = "", *, fast: bool = False) -> Result:
    """Simulate one resolved configuration and return its full trajectory and metrics.

    Parameters
    ----------
    cfg : Config
        A resolved configuration (see :func:`mfcontrol.resolve`).
    name : str
        The result's name.
    fast : bool
        The compiled engine's fast mode (fused multiply-adds, reciprocals; on the paper's
        buck also the plant's RK4 step as its linear map): within about 1e-12 relative of
        the default, which is bit for bit the published arithmetic (``Result.arithmetic``
        says which). Every configuration has it.

    Examples
    --------
    >>> import mfcontrol
    >>> from mfcontrol.experiments.cases import resolve_case
    >>> _, cfg = resolve_case("voltage-stable-standard")
    >>> exact, fast = mfcontrol.simulate(cfg), mfcontrol.simulate(cfg, fast=True)
    >>> abs(fast.metrics["iae"] / exact.metrics["iae"] - 1) < 1e-12
    True
    """
    if not compiled(cfg):
        return _simulate_loop(cfg, name, fast)
    return simulate_many([cfg], name=name, fast=fast)[0]


def _simulate_loop(cfg: Config, name: str, fast: bool = False) -> Result:
    from . import params
    from .loop import compiled_run, law_arrays

    n = scenario.n_steps(cfg)
    t_end = cfg["sim.t_end"]
    t = grid.times(n, t_end)
    plant, changes = params.plant_and_changes(cfg)
    ctrl = params.controller(cfg)
    S = params.metric_settings(cfg)
    # the reference evaluated in the kernel, as a batch of these members evaluates it
    res = compiled_run(plant, plant.engine(), ctrl, law_arrays(ctrl), np.zeros((0, n)),
                       params.reference_column(cfg), changes, t,
                       cfg["sim.h"], t_end, S, cfg["metrics.stable_tol"], name, fast)
    return dataclasses.replace(res, config=cfg, changes=())


def general_metrics(cfgs: Sequence[Config], *, fast: bool = False,
                    vectorise: bool | None = None) -> np.ndarray:
    """The metrics (kernel rows, one column per member) of configurations that share a
    model, law and time grid, in one batch of the general engine (``vectorise`` as
    :func:`mfcontrol.api.loop.run_members` takes it)."""
    from . import params
    from .loop import law_arrays

    members = [params.plant_and_changes(c) for c in cfgs]
    return batch_metrics(cfgs[0], [p.engine() for p, _ in members], [ch for _, ch in members],
                         [law_arrays(params.controller(c)) for c in cfgs],
                         np.hstack([params.reference_column(c) for c in cfgs]), fast=fast,
                         vectorise=vectorise)


def batch_metrics(first: Config, plants: Sequence[Any], changes: Sequence[Sequence[Any]],
                  laws: Sequence[Any], RP: np.ndarray, *, fast: bool = False,
                  vectorise: bool | None = None) -> np.ndarray:
    """The metrics of members given as their engine plants, scheduled changes, law arrays
    and reference columns (``RP[:, j]``), built from configurations that share the time
    grid and metric settings of ``first``, in one batch of the general engine."""
    from . import params
    from .loop import run_members

    n = scenario.n_steps(first)
    M, _, _ = run_members(plants, laws, np.zeros((0, n)), changes, t_end=first["sim.t_end"],
                          h=first["sim.h"], S=params.metric_settings(first), fast=fast,
                          RP=RP, vectorise=vectorise)
    return M


def simulate_many(cfgs: Sequence[Config], name: str = "", *,
                  fast: bool = False) -> list[Result]:
    """Simulate members that share a model, law and time grid in one kernel call
    (``fast`` as in :func:`simulate`)."""
    if not all(compiled(c) for c in cfgs):
        return [simulate(c, name=name, fast=fast) for c in cfgs]
    scn = scenario.build(cfgs)
    M, traj = scenario.execute(scn, fast=fast)
    return [_result(name, c, scn, M, traj, j, j, fast) for j, c in enumerate(cfgs)]


def simulate_sweep(cfg: Config, name: str = "", *, fast: bool = False) -> SweepResult:
    """Every value of ``sweep.key`` on the same, freshly reset scenario (``fast`` as in
    :func:`simulate`)."""
    key, values = cfg["sweep.key"], list(cfg["sweep.values"])
    members = [_member(cfg, key, v) for v in values]
    results = simulate_many(members, name=name, fast=fast)
    for v, r in zip(values, results, strict=True):
        r.label = f"{key} = {v:g}"
    return SweepResult(name=name, config=cfg, key=key, values=values, members=results,
                       version=__version__)


def _member(cfg: Config, key: str, value: float) -> Config:
    return cfg.with_overrides({key: axis_value(key, value), "sweep.key": None,
                               "sweep.values": None})
