"""Run resolved configurations through the compiled engine."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from . import metrics, scenario
from ._version import __version__
from .config import Config
from .engine import kernel
from .errors import ConfigError
from .result import Result, SweepResult


def _result(name: str, cfg: Config, scn: scenario.Scenario, M, traj, j: int, m: int,
            fast: bool = False) -> Result:
    met = metrics.from_kernel(M, j, cfg["metrics.stable_tol"])
    n = met["n_samples"]
    rows = traj[:, m, :n]
    signals = {
        "y_ref": rows[kernel.T_REF], "y": rows[kernel.T_Y], "duty": rows[kernel.T_APPLIED],
        "u_raw": rows[kernel.T_U], "gamma": rows[kernel.T_GAMMA], "gain": rows[kernel.T_GAIN],
    }
    states = {s: rows[kernel.T_X0 + i] for i, s in enumerate(scn.state_names)}
    return Result(name=name, config=cfg, time=scn.time()[:n], signals=signals, states=states,
                  metrics=met, version=__version__, arithmetic="fast" if fast else "exact")


def compiled(cfg: Config) -> bool:
    """Whether the compiled kernel covers this configuration (the paper's laws on the buck
    with RK4); everything else runs through the general loop with the same laws."""
    return (cfg["plant.model"] == "buck" and cfg["controller.law"] in ("ip", "variational")
            and cfg["sim.integrator"] == "rk4" and not cfg["plant.schedule"])


def check_fast(cfg: Config, key: str = "fast") -> None:
    """Refuse the fast mode (asked for by ``key``) for a configuration outside the
    compiled kernel, which alone has it."""
    if not compiled(cfg):
        raise ConfigError(key, True, "only the compiled kernel (the paper's laws on the "
                          "buck, sim.integrator = rk4, no plant.schedule) has a fast mode")


def simulate(cfg: Config, name: str = "", *, fast: bool = False) -> Result:
    """Simulate one resolved configuration and return its full trajectory and metrics.

    Parameters
    ----------
    cfg : Config
        A resolved configuration (see :func:`mfcontrol.resolve`).
    name : str
        The result's name.
    fast : bool
        Run the compiled kernel in its fast mode (fused arithmetic, the plant's RK4 step
        as its linear map): about 2.5x faster, within about 1e-13 relative of the
        default, which is bit for bit the published arithmetic (``Result.arithmetic``
        says which). Only configurations the compiled kernel covers (the paper's laws on
        the buck, RK4) have it; others raise :class:`mfcontrol.errors.ConfigError`.

    Examples
    --------
    >>> import mfcontrol
    >>> from mfcontrol.experiments.cases import resolve_case
    >>> _, cfg = resolve_case("voltage-stable-standard")
    >>> exact, fast = mfcontrol.simulate(cfg), mfcontrol.simulate(cfg, fast=True)
    >>> abs(fast.metrics["iae"] / exact.metrics["iae"] - 1) < 1e-12
    True
    """
    if fast:
        check_fast(cfg)
    if not compiled(cfg):
        return _simulate_loop(cfg, name)
    return simulate_many([cfg], name=name, fast=fast)[0]


def _simulate_loop(cfg: Config, name: str) -> Result:
    from . import from_config
    from .loop import simulate_loop

    n = scenario.n_steps(cfg)
    t = (np.arange(n) * cfg["sim.t_end"]) / n
    ctrl = from_config.controller(cfg)
    res = simulate_loop(
        from_config.plant(cfg), ctrl, from_config.reference(cfg, t), t_end=cfg["sim.t_end"],
        h=cfg["sim.h"], changes=from_config.changes(cfg),
        settle_time=cfg["metrics.settle_time"], final_window=cfg["metrics.final_window"],
        stable_tol=cfg["metrics.stable_tol"], diverge_above=cfg["sim.diverge_above"],
        name=name)
    s = res.signals
    recursive = "u_raw" in s
    gamma = s["gamma"]
    signals = {"y_ref": s["y_ref"], "y": s["y"], "duty": s["u"],
               "u_raw": s["u_raw"] if recursive else s["unlimited"], "gamma": gamma,
               "gain": s["gain"] if recursive else gamma}
    return Result(name=name, config=cfg, time=res.time, signals=signals, states=res.states,
                  metrics=res.metrics, version=__version__)


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
    return cfg.with_overrides({key: value, "sweep.key": None, "sweep.values": None})
