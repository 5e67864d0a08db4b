"""Run resolved configurations through the compiled engine."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from ..._version import __version__
from ...config.options import BY_KEY
from ...config.resolve import Config, _check_consistency, axis_value, keys_read
from ...elements import layout
from ...engine import trajectory
from ...numerics import grid
from .. import params
from ..results import metrics
from ..results.result import Result, SweepResult
from . import from_config, scenario
from .loop import compiled_run, law_arrays, run_members, stacked, warn_alpha


def _result(name: str, cfg: Config, scn: scenario.Scenario, M, traj, j: int, m: int,
            fast: bool = False) -> Result:
    met = metrics.from_kernel(M, j, cfg["metrics.settled_tol"])
    n = met["n_samples"]
    signals, states = trajectory.named_rows(traj[:, m, :n], (), scn.state_names)
    return Result(name=name, config=cfg, time=scn.time()[:n], signals=signals, states=states,
                  metrics=met, version=__version__, arithmetic="fast" if fast else "exact")


def compiled(cfg: Config) -> bool:
    """Whether the paper's tuned kernel covers this configuration (the paper's laws on the
    buck with RK4); everything else runs in the general engine
    (:mod:`mfcontrol.engine.compose`) with the same laws."""
    return (cfg["plant.model"] == "buck" and cfg["controller.law"] in ("ip", "variational")
            and cfg["sim.integrator"] == "rk4" and not cfg["plant.schedule"]
            and from_config.ideal_loop(cfg))


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
    if _backward_difference(cfg):
        warn_alpha(from_config.controller(cfg), from_config.plant_and_changes(cfg)[0])
    if not compiled(cfg):
        return _simulate_loop(cfg, name, fast)
    return simulate_many([cfg], name=name, fast=fast)[0]


def _backward_difference(cfg: Config) -> bool:
    """Whether a positional law with a constant gain estimates F by the backward
    difference (at least at its start): the runs whose alpha :func:`warn_alpha` checks,
    told from the configuration before anything is built for it."""
    if cfg["controller.law"] not in from_config.POSITIONAL:
        return False
    if cfg["controller.adapt"] != "constant" or cfg["controller.delay"] > 0:
        return False
    return (cfg["controller.estimator"] != "algebraic"
            or cfg["controller.startup"] == "backward-difference")


def _simulate_loop(cfg: Config, name: str, fast: bool = False) -> Result:
    n = scenario.n_steps(cfg)
    t_end = cfg["sim.t_end"]
    t = grid.times(n, t_end)
    plant, changes = from_config.plant_and_changes(cfg)
    ctrl = from_config.controller(cfg)
    S = params.metric_settings(cfg)
    # the reference evaluated in the kernel, as a batch of these members evaluates it
    res = compiled_run(plant, plant.engine(), ctrl, law_arrays(ctrl), np.zeros((0, n)),
                       params.reference_column(cfg), changes, t,
                       cfg["sim.h"], t_end, S, cfg["metrics.settled_tol"], name, fast,
                       LP=from_config.elements(cfg), t_end_key="sim.t_end")
    return dataclasses.replace(res, config=cfg, changes=())


def member_parts() -> dict[str, Callable[[Config], Any]]:
    """How a member of the general engine is built from its configuration, part by part,
    by the translators a single run calls (:mod:`mfcontrol.api.run.from_config`,
    :mod:`mfcontrol.api.params`): ``"plant"``, its engine plant and scheduled changes;
    ``"law"``, its law's arrays;
    ``"reference"``, its reference column; ``"elements"``, its loop elements' column."""
    def plant(cfg: Config) -> tuple[Any, list]:
        p, changes = from_config.plant_and_changes(cfg)
        return p.engine(), changes

    return {"plant": plant, "law": lambda cfg: law_arrays(from_config.controller(cfg)),
            "reference": params.reference_column, "elements": from_config.elements}


def keys_read_by_run(cfg: Config) -> set[str]:
    """The options a run of ``cfg`` reads: those its translators read (the paper's
    kernel's scenario, or each part of :func:`member_parts`), with the time grid, the
    metric settings and the checks across options, found by running the translators
    (:func:`mfcontrol.config.resolve.keys_read`), not the simulation (a test checks that
    the simulation reads no other); ``fidelity`` when it presets a key read that is not
    set; a sweep case's keys and what its members read. Any other option cannot change
    the run."""
    key = cfg["sweep.key"]
    if key is not None:  # every member's run (the swept value may change what is read)
        read = {"sweep.key", "sweep.values"}
        for v in cfg["sweep.values"]:
            read |= keys_read_by_run(_member(cfg, key, v))
        return read
    # the engine's choice, the time grid, the metrics' settings and settling verdict
    read = keys_read(lambda c: (compiled(c), scenario.n_steps(c), params.metric_settings(c),
                                c["metrics.settled_tol"]), cfg)
    read |= keys_read(_check_consistency, cfg)
    if compiled(cfg):
        read |= keys_read(lambda c: scenario.build([c]), cfg)
    else:
        for build in member_parts().values():
            read |= keys_read(build, cfg)
    read.discard("_explicit")
    # the fidelity that presets keys the run reads, read with them (as shown with them)
    if any(BY_KEY[k].preset for k in read):
        read.add("fidelity")
    return read


def shown_keys(cfg: Config) -> set[str]:
    """The options worth showing of ``cfg`` (``mfcontrol show``, a run's config.toml):
    those it sets and those its single run reads (``fidelity`` with the keys it
    presets). The others are the defaults of plants, laws and elements it does not use,
    which cannot change the run: a file of these keys resolves to the same run."""
    return {"description"} | set(cfg.explicit) | keys_read_by_run(cfg)


def general_metrics(cfgs: Sequence[Config], *, fast: bool = False,
                    vectorise: bool | None = None) -> np.ndarray:
    """The metrics (kernel rows, one column per member) of configurations that share a
    model, law and time grid, in one batch of the general engine (``vectorise`` as
    :func:`mfcontrol.api.run.loop.run_members` takes it)."""
    parts = {name: [build(c) for c in cfgs] for name, build in member_parts().items()}
    return batch_metrics(cfgs[0], parts, fast=fast, vectorise=vectorise)[0]


def batch_metrics(first: Config, parts: Mapping[str, Sequence[Any]], *, fast: bool = False,
                  vectorise: bool | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(M, CS): the metrics and law memory of members given as their parts (each part's
    list as :func:`member_parts` builds it, one item per member), built from
    configurations that share the time grid and metric settings of ``first``, in one
    batch of the general engine."""
    n = scenario.n_steps(first)
    M, _, CS, _ = run_members([ep for ep, _ in parts["plant"]], parts["law"], np.zeros((0, n)),
                           [ch for _, ch in parts["plant"]], t_end=first["sim.t_end"],
                           h=first["sim.h"], S=params.metric_settings(first), fast=fast,
                           RP=stacked(parts["reference"]),
                           LP=stacked(parts["elements"], layout.stack), vectorise=vectorise)
    return M, CS


def simulate_many(cfgs: Sequence[Config], name: str = "", *,
                  fast: bool = False) -> list[Result]:
    """Simulate members that share a model, law and time grid in one kernel call
    (``fast`` as in :func:`simulate`).

    Parameters
    ----------
    cfgs : sequence of Config
        The members' resolved configurations.
    name : str
        Prefix of the results' names.
    fast : bool
        The engine's fast mode (within about 1e-13 relative of the exact arithmetic).

    Returns
    -------
    list of Result
        One per member, each equal to its single run."""
    if not all(compiled(c) for c in cfgs):
        return [simulate(c, name=name, fast=fast) for c in cfgs]
    scn = scenario.build(cfgs)
    M, traj = scenario.execute(scn, fast=fast)
    return [_result(name, c, scn, M, traj, j, j, fast) for j, c in enumerate(cfgs)]


def simulate_sweep(cfg: Config, name: str = "", *, fast: bool = False) -> SweepResult:
    """Every value of ``sweep.key`` on the same, freshly reset scenario (``fast`` as in
    :func:`simulate`).

    Parameters
    ----------
    cfg : Config
        A resolved configuration with ``sweep.key`` and ``sweep.values``.
    name : str
        The result's name.
    fast : bool
        The engine's fast mode.

    Returns
    -------
    SweepResult"""
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
