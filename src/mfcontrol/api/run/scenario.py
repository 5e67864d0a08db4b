"""From resolved configurations to the engine's arrays, and back to named results.

A *scenario* is the set of float64 arrays the kernel runs: one column per member. Members
of one scenario share the plant model, the law, the time grid and the number of scheduled
changes; every numeric parameter may differ between them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ...config.resolve import Config
from ...elements import layout
from ...engine import metrics, paper_single, trajectory
from ...laws import recursive_ip
from ...numerics import grid
from ...plants import buck
from .. import params
from . import from_config, loop


@dataclass
class Scenario:
    n_steps: int
    h: float
    t_end: float
    plant_kind: int
    PP: np.ndarray
    X0: np.ndarray
    law_kind: int
    CP: np.ndarray
    RP: np.ndarray
    ev_steps: np.ndarray
    ev_k: np.ndarray
    ev_row: np.ndarray
    ev_add: np.ndarray
    ev_val: np.ndarray
    S: np.ndarray
    state_names: tuple[str, ...]
    #: every member's first load step (``iae_load`` counts from it; inf: none)
    load_t0: np.ndarray

    @property
    def n_members(self) -> int:
        return self.X0.shape[1]

    def time(self) -> np.ndarray:
        """Sample times t_k = (k t_end) / N, computed exactly as the kernel does."""
        return grid.times(self.n_steps, self.t_end)


def n_steps(cfg: Config) -> int:
    """Samples in a configuration's run (validated when it was resolved)."""
    return grid.n_samples(cfg["sim.t_end"], cfg["sim.h"], "sim.t_end", "sim.h")


def axis_columns(base: Config, key: str, values: np.ndarray) -> dict[str, np.ndarray]:
    """The one-member arrays (``PP``, ``X0``, ``CP``, ``RP``, ``ev_val``) for every value
    of one swept key at once, one column per value: the same translators as
    :func:`build`, given an array where they read ``key``. The values must have been
    validated (:func:`mfcontrol.api.run.batch.make_grid`)."""
    cfg = Config({**base.values, key: np.asarray(values, dtype=float)})
    n = n_steps(base)
    m = np.size(values)
    events = _events(cfg, n)
    ev_val = np.zeros((len(events), m))
    for e, ev in enumerate(events):
        ev_val[e] = ev[3]
    ones = np.ones(m)
    return {**{name: col * ones for name, col in _columns(cfg).items()}, "ev_val": ev_val}


def _columns(cfg: Config) -> dict[str, np.ndarray]:
    """The kernel's column arrays of a configuration (one column, or one per value where a
    key holds an array): where each comes from, in one place for :func:`build` and
    :func:`axis_columns`."""
    return {"PP": params.buck_column(cfg), "X0": params.buck_state_column(cfg),
            "CP": params.recursive_law_column(cfg), "RP": params.reference_column(cfg)}


def _events(cfg: Config, n: int) -> list[tuple[int, int, bool, float]]:
    """(sample, parameter row, additive?, value) for every scheduled change, in order:
    the changes of :func:`mfcontrol.api.run.from_config.changes` (the paper's kernels take no
    general schedule)."""
    return [(grid.first_sample_at(c.time, cfg["sim.t_end"], n), buck.PARAM_ROWS[c.name],
             c.add, c.value) for c in from_config.changes(cfg)]


def build(configs: Sequence[Config]) -> Scenario:
    """Stack the members' configurations into one scenario."""
    first = configs[0]
    n = n_steps(first)
    for c in configs[1:]:
        for key in ("plant.model", "controller.law", "sim.h", "sim.t_end"):
            if c[key] != first[key]:
                raise ValueError(f"members of one scenario must share {key}")
        if len(c["plant.change_times"]) != len(first["plant.change_times"]):
            raise ValueError("members of one scenario must share the number of load changes")
    events = [_events(c, n) for c in configs]
    n_ev = len(events[0])
    ev_k = np.array([[ev[e][0] for ev in events] for e in range(n_ev)], dtype=np.int64)
    ev_k = ev_k.reshape(n_ev, len(configs))
    ev_val = np.array([[ev[e][3] for ev in events] for e in range(n_ev)]).reshape(ev_k.shape)
    ev_row = np.array([e[1] for e in events[0]], dtype=np.int64)
    ev_add = np.array([e[2] for e in events[0]], dtype=np.bool_)
    ev_steps = np.unique(ev_k[ev_k < n]) if n_ev else np.zeros(0, dtype=np.int64)
    columns = [_columns(c) for c in configs]
    stacked = {name: np.hstack([col[name] for col in columns]) for name in columns[0]}
    return Scenario(
        n_steps=n, h=first["sim.h"], t_end=first["sim.t_end"],
        plant_kind=paper_single.BUCK, law_kind=paper_single.RECURSIVE_IP,
        PP=stacked["PP"], X0=stacked["X0"], CP=stacked["CP"], RP=stacked["RP"],
        S=params.metric_settings(first),
        ev_steps=ev_steps.astype(np.int64), ev_k=ev_k, ev_row=ev_row, ev_add=ev_add,
        ev_val=ev_val, state_names=buck.STATE_NAMES,
        load_t0=np.concatenate([loop.load_step_of(layout.column(), [from_config.changes(c)],
                                                  c["sim.t_end"], n) for c in configs]),
    )


def start_metrics(scn: Scenario) -> np.ndarray:
    """The members' metric rows at the start: zeros, and the loop metrics' start and what
    they measure (the reference step of RP, the first load step)."""
    M = np.zeros((metrics.N_METRICS, scn.n_members))
    metrics.start(M, *loop.step_metrics_of(scn.RP), scn.load_t0)
    return M


def execute(scn: Scenario, keep: Sequence[int] | None = None, *, fast: bool = False):
    """Run every member from its initial state; return (metrics M, trajectories traj).

    ``traj[row, m, k]`` holds the kept members (all by default), NaN after divergence.
    Each member runs through the single-run kernel (sweeps use :mod:`mfcontrol.api.run.batch`);
    ``fast``: through its fast mode (:data:`mfcontrol.engine.paper_single.run_single_fast`).
    """
    run_single = paper_single.run_single_fast if fast else paper_single.run_single
    n = scn.n_members
    keep_arr = list(range(n)) if keep is None else list(keep)
    n_rows = trajectory.T_X0 + scn.X0.shape[0]
    single = n == 1 and keep_arr == [0]  # the kernel writes the result itself, no buffer
    grid.check_recording(scn.n_steps, n_rows * (len(keep_arr) + (not single)), scn.t_end,
                         "sim.t_end")
    M = start_metrics(scn)
    CS = np.zeros((recursive_ip.N_STATE, n))
    paper_single.reset_members(scn.law_kind, scn.CP, CS)
    if single:  # the common case
        traj = np.empty((n_rows, 1, scn.n_steps))
        run_single(scn.n_steps, scn.h, scn.t_end, scn.plant_kind, scn.PP.copy(),
                   scn.X0.copy(), scn.law_kind, scn.CP, CS, scn.RP, scn.ev_steps,
                   scn.ev_k, scn.ev_row, scn.ev_add, scn.ev_val, scn.S, M, traj[:, 0, :])
        traj[:, 0, int(M[metrics.M_N_SAMPLES, 0]):] = np.nan  # never written: diverged
        metrics.adaptation(M, scn.CP, True)
        return M, traj
    traj = np.full((n_rows, len(keep_arr), scn.n_steps), np.nan)
    one = np.empty((n_rows, scn.n_steps))
    X = scn.X0.copy()
    for j in range(n):
        Mj = M[:, j:j + 1].copy()
        run_member(scn, j, X, CS, Mj, one, fast=fast)
        M[:, j] = Mj[:, 0]
        if j in keep_arr:
            done = int(Mj[metrics.M_N_SAMPLES, 0])
            traj[:, keep_arr.index(j), :done] = one[:, :done]
    metrics.adaptation(M, scn.CP, True)
    return M, traj


def run_member(scn: Scenario, j: int, X: np.ndarray, CS: np.ndarray, M: np.ndarray,
               traj: np.ndarray, *, n_steps: int | None = None, t_end: float | None = None,
               fast: bool = False) -> None:
    """Member j of ``scn`` through the single-run kernel, from the states ``X[:, j]`` and
    ``CS[:, j]`` (advanced in place), for ``n_steps`` samples over ``t_end`` (the
    scenario's by default): its metrics into ``M[:, 0]``, its trajectory into
    ``traj[row, k]``."""
    run_single = paper_single.run_single_fast if fast else paper_single.run_single
    col = slice(j, j + 1)
    Xj, CSj = X[:, col].copy(), CS[:, col].copy()
    run_single(scn.n_steps if n_steps is None else n_steps, scn.h,
               scn.t_end if t_end is None else t_end, scn.plant_kind, scn.PP[:, col].copy(),
               Xj, scn.law_kind, scn.CP[:, col].copy(), CSj, scn.RP[:, col].copy(),
               scn.ev_steps, scn.ev_k[:, col].copy(), scn.ev_row, scn.ev_add,
               scn.ev_val[:, col].copy(), scn.S, M, traj)
    X[:, j], CS[:, j] = Xj[:, 0], CSj[:, 0]
