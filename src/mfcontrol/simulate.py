"""Run resolved configurations through the compiled engine."""

from __future__ import annotations

from collections.abc import Sequence

from . import metrics, scenario
from ._version import __version__
from .config import Config
from .engine import kernel
from .result import Result, SweepResult


def _result(name: str, cfg: Config, scn: scenario.Scenario, M, traj, j: int, m: int) -> Result:
    met = metrics.from_kernel(M, j, cfg["metrics.stable_tol"])
    n = met["n_samples"]
    rows = traj[:, m, :n]
    signals = {
        "y_ref": rows[kernel.T_REF], "y": rows[kernel.T_Y], "duty": rows[kernel.T_APPLIED],
        "u_raw": rows[kernel.T_U], "gamma": rows[kernel.T_GAMMA], "gain": rows[kernel.T_GAIN],
    }
    states = {s: rows[kernel.T_X0 + i] for i, s in enumerate(scn.state_names)}
    return Result(name=name, config=cfg, time=scn.time()[:n], signals=signals, states=states,
                  metrics=met, version=__version__)


def simulate(cfg: Config, name: str = "") -> Result:
    """Simulate one resolved configuration and return its full trajectory and metrics."""
    return simulate_many([cfg], name=name)[0]


def simulate_many(cfgs: Sequence[Config], name: str = "") -> list[Result]:
    """Simulate members that share a model, law and time grid in one kernel call."""
    scn = scenario.build(cfgs)
    M, traj = scenario.execute(scn)
    return [_result(name, c, scn, M, traj, j, j) for j, c in enumerate(cfgs)]


def simulate_sweep(cfg: Config, name: str = "") -> SweepResult:
    """Every value of ``sweep.key`` on the same, freshly reset scenario."""
    key, values = cfg["sweep.key"], list(cfg["sweep.values"])
    members = [_member(cfg, key, v) for v in values]
    results = simulate_many(members, name=name)
    for v, r in zip(values, results, strict=True):
        r.label = f"{key} = {v:g}"
    return SweepResult(name=name, config=cfg, key=key, values=values, members=results,
                       version=__version__)


def _member(cfg: Config, key: str, value: float) -> Config:
    return cfg.with_overrides({key: value, "sweep.key": None, "sweep.values": None})
