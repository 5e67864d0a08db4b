"""From resolved configurations to the engine's arrays, and back to named results.

A *scenario* is the set of float64 arrays the kernel runs: one column per member. Members
of one scenario share the plant model, the law, the time grid and the number of scheduled
changes; every numeric parameter may differ between them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from . import references
from .config import Config
from .engine import kernel
from .laws import gain, recursive_ip
from .plants import buck


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

    @property
    def n_members(self) -> int:
        return self.X0.shape[1]

    def time(self) -> np.ndarray:
        """Sample times t_k = (k t_end) / N, computed exactly as the kernel does."""
        return (np.arange(self.n_steps) * self.t_end) / self.n_steps


def n_steps(cfg: Config) -> int:
    return round(cfg["sim.t_end"] / cfg["sim.h"])


def _first_sample_at(t_event: float, t_end: float, n: int) -> int:
    """First k with t_k >= t_event (n if never), t_k = (k t_end)/n evaluated in float64
    exactly as the kernel does: a guess from the real quotient, then corrected."""
    def t(k: int) -> float:
        return (k * t_end) / n

    k = min(max(math.ceil(t_event * n / t_end), 0), n)
    while k > 0 and t(k - 1) >= t_event:
        k -= 1
    while k < n and t(k) < t_event:
        k += 1
    return k


def _width(cfg: Config) -> int:
    """Columns a translator writes: 1, or the length of the one swept key's values when
    :func:`axis_columns` has put an array of them in the configuration."""
    return max((np.size(v) for k, v in cfg.values.items()
                if isinstance(v, np.ndarray)), default=1)


def _plant_column(cfg: Config) -> np.ndarray:
    col = np.zeros((buck.N_PARAMS, _width(cfg)))
    col[buck.E] = cfg["plant.E"]
    col[buck.L] = cfg["plant.L"]
    col[buck.R] = cfg["plant.R"]
    col[buck.C] = cfg["plant.C"]
    col[buck.COUPLING] = buck.COUPLINGS[cfg["plant.coupling"]]
    col[buck.OUTPUT] = buck.OUTPUTS[cfg["plant.output"]]
    return col


def _law_column(cfg: Config) -> np.ndarray:
    col = np.zeros((recursive_ip.N_PARAMS, _width(cfg)))
    variational = cfg["controller.law"] == "variational"
    col[gain.MODE] = gain.VARIATIONAL if variational else gain.CONSTANT
    col[gain.INV_ALPHA] = 1 / cfg["controller.alpha"]
    col[gain.GAMMA0] = cfg["controller.gamma0"]
    col[gain.GAMMA_RATE] = cfg["controller.Gamma"]
    col[gain.EPS_M] = cfg["controller.eps_M"]
    col[gain.ORDER] = 2.0 if cfg["controller.integrator"] == "second-order" else 1.0
    col[recursive_ip.KP] = cfg["controller.kp"]
    col[recursive_ip.HD] = cfg["controller.deriv_scale"]
    col[recursive_ip.U0] = cfg["controller.u0"]
    col[recursive_ip.P_SIGN] = 1.0 if cfg["controller.p_error"] == "r-y" else -1.0
    col[recursive_ip.P_CURRENT] = 1.0 if cfg["controller.p_sample"] == "current" else 0.0
    if variational and cfg["controller.rate_term"]:
        sign = 1.0 if cfg["controller.rate_sign"] == "plus" else -1.0
        col[recursive_ip.RATE_COEF] = sign * cfg["controller.k_gamma"]
    col[recursive_ip.USE_GAMMA] = 1.0 if cfg["controller.gain"] == "gamma" else 0.0
    col[recursive_ip.OUT_GAIN] = cfg["controller.output_gain"]
    col[recursive_ip.OUT_MIN] = cfg["controller.duty_min"]
    col[recursive_ip.OUT_MAX] = cfg["controller.duty_max"]
    col[recursive_ip.AW_COEF] = anti_windup_coefficient(cfg)
    return col


def anti_windup_coefficient(cfg: Config) -> float:
    """Share of the excess over the limit that the recursive law sheds each sample."""
    mode = cfg["controller.anti_windup"]
    if mode in ("auto", "none"):
        return 0.0
    if mode == "clamp":
        return 1.0
    k_aw = cfg["controller.k_aw"]
    return 1.0 if k_aw is None else np.minimum(1.0, k_aw * cfg["sim.h"])


def _reference_column(cfg: Config) -> np.ndarray:
    col = np.zeros((references.N_PARAMS, _width(cfg)))
    col[references.KIND] = references.KINDS[cfg["reference.kind"]]
    if cfg["reference.kind"] == "smooth-step":
        col[references.INITIAL] = cfg["reference.initial"]
        col[references.FINAL] = cfg["reference.final"]
        col[references.T0] = cfg["reference.t0"]
        col[references.DURATION] = cfg["reference.duration"]
        return col
    col[references.SLOPE] = cfg["reference.slope"]
    col[references.LEVEL] = cfg["reference.level"]
    t2 = cfg["reference.t_ramp2"]
    col[references.T_RAMP2] = math.inf if t2 is None else t2
    col[references.SLOPE2] = cfg["reference.slope2"]
    return col


def _state_column(cfg: Config) -> np.ndarray:
    col = np.zeros((buck.N_STATE, _width(cfg)))
    col[buck.I_L] = cfg["plant.i0"]
    col[buck.V_C] = cfg["plant.v0"]
    return col


def axis_columns(base: Config, key: str, values: np.ndarray) -> dict[str, np.ndarray]:
    """The one-member arrays (``PP``, ``X0``, ``CP``, ``RP``, ``ev_val``) for every value
    of one swept key at once, one column per value: the same translators as
    :func:`build`, given an array where they read ``key``. The values must have been
    validated (:func:`mfcontrol.batch.make_grid`)."""
    cfg = Config({**base.values, key: np.asarray(values, dtype=float)})
    n = n_steps(base)
    m = np.size(values)
    events = _events(cfg, n)
    ev_val = np.zeros((len(events), m))
    for e, ev in enumerate(events):
        ev_val[e] = ev[3]
    return {"PP": _plant_column(cfg) * np.ones(m), "X0": _state_column(cfg) * np.ones(m),
            "CP": _law_column(cfg) * np.ones(m), "RP": _reference_column(cfg) * np.ones(m),
            "ev_val": ev_val}


def _events(cfg: Config, n: int) -> list[tuple[int, int, bool, float]]:
    """(sample, parameter row, additive?, value) for every scheduled change, in order."""
    out = []
    for t_change in cfg["plant.change_times"]:
        k = _first_sample_at(t_change, cfg["sim.t_end"], n)
        out.append((k, buck.R, True, cfg["plant.dR"]))
        out.append((k, buck.C, True, cfg["plant.dC"]))
    return out


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
    X0 = np.column_stack([_state_column(c) for c in configs])
    S = kernel.settings(first["metrics.settle_time"],
                        first["sim.t_end"] * (1 - first["metrics.final_window"]),
                        first["sim.diverge_above"])
    return Scenario(
        n_steps=n, h=first["sim.h"], t_end=first["sim.t_end"],
        plant_kind=kernel.BUCK,
        PP=np.hstack([_plant_column(c) for c in configs]),
        X0=X0,
        law_kind=kernel.RECURSIVE_IP,
        CP=np.hstack([_law_column(c) for c in configs]),
        RP=np.hstack([_reference_column(c) for c in configs]),
        ev_steps=ev_steps.astype(np.int64), ev_k=ev_k, ev_row=ev_row, ev_add=ev_add,
        ev_val=ev_val, S=S, state_names=buck.STATE_NAMES,
    )


def execute(scn: Scenario, keep: Sequence[int] | None = None, *, fast: bool = False):
    """Run every member from its initial state; return (metrics M, trajectories traj).

    ``traj[row, m, k]`` holds the kept members (all by default), NaN after divergence.
    Each member runs through the single-run kernel (sweeps use :mod:`mfcontrol.batch`);
    ``fast``: through its fast mode (:data:`mfcontrol.engine.kernel.run_single_fast`).
    """
    run_single = kernel.run_single_fast if fast else kernel.run_single
    n = scn.n_members
    keep_arr = list(range(n)) if keep is None else list(keep)
    n_rows = kernel.T_X0 + scn.X0.shape[0]
    M = np.zeros((kernel.N_METRICS, n))
    CS = np.zeros((recursive_ip.N_STATE, n))
    kernel.reset_members(scn.law_kind, scn.CP, CS)
    if n == 1 and keep_arr == [0]:  # the common case: the kernel writes the result itself
        traj = np.empty((n_rows, 1, scn.n_steps))
        run_single(scn.n_steps, scn.h, scn.t_end, scn.plant_kind, scn.PP.copy(),
                   scn.X0.copy(), scn.law_kind, scn.CP, CS, scn.RP, scn.ev_steps,
                   scn.ev_k, scn.ev_row, scn.ev_add, scn.ev_val, scn.S, M, traj[:, 0, :])
        traj[:, 0, int(M[kernel.M_N_SAMPLES, 0]):] = np.nan  # never written: diverged
        return M, traj
    traj = np.full((n_rows, len(keep_arr), scn.n_steps), np.nan)
    one = np.empty((n_rows, scn.n_steps))
    X = scn.X0.copy()
    for j in range(n):
        Mj = np.zeros((kernel.N_METRICS, 1))
        run_member(scn, j, X, CS, Mj, one, fast=fast)
        M[:, j] = Mj[:, 0]
        if j in keep_arr:
            done = int(Mj[kernel.M_N_SAMPLES, 0])
            traj[:, keep_arr.index(j), :done] = one[:, :done]
    return M, traj


def run_member(scn: Scenario, j: int, X: np.ndarray, CS: np.ndarray, M: np.ndarray,
               traj: np.ndarray, *, n_steps: int | None = None, t_end: float | None = None,
               fast: bool = False) -> None:
    """Member j of ``scn`` through the single-run kernel, from the states ``X[:, j]`` and
    ``CS[:, j]`` (advanced in place), for ``n_steps`` samples over ``t_end`` (the
    scenario's by default): its metrics into ``M[:, 0]``, its trajectory into
    ``traj[row, k]``."""
    run_single = kernel.run_single_fast if fast else kernel.run_single
    col = slice(j, j + 1)
    Xj, CSj = X[:, col].copy(), CS[:, col].copy()
    run_single(scn.n_steps if n_steps is None else n_steps, scn.h,
               scn.t_end if t_end is None else t_end, scn.plant_kind, scn.PP[:, col].copy(),
               Xj, scn.law_kind, scn.CP[:, col].copy(), CSj, scn.RP[:, col].copy(),
               scn.ev_steps, scn.ev_k[:, col].copy(), scn.ev_row, scn.ev_add,
               scn.ev_val[:, col].copy(), scn.S, M, traj)
    X[:, j], CS[:, j] = Xj[:, 0], CSj[:, 0]
