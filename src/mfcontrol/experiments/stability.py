"""Linearised closed-loop stability of the voltage-controlled buck under a frozen gain.

With the duty cycle inside its limits and the gain g held constant, one sample of the loop
(law, then one RK4 plant step) is an affine map of z = (i_L, v_C, y_{k-1}, u_{k-1}). Its
Jacobian, taken by finite differences through the engine's own kernel (one step, five
members: the operating point and four perturbations), has eigenvalues whose largest modulus
rho decides stability: rho < 1 stable, rho > 1 a growing oscillation at ln(rho)/h per second.
Because the map is affine there, the differences are exact up to rounding.
"""

from __future__ import annotations

import numpy as np

from ..api.run import scenario
from ..config.resolve import Config
from ..engine import metrics, paper_single, trajectory
from ..laws import recursive_ip
from ..plants import buck


def spectral_radius(cfg: Config, gain: float, R: float, v_ref: float = 2.5) -> float:
    """Spectral radius of the linearised loop for a voltage-controlled buck ``cfg`` with the
    derivative gain frozen at ``gain`` and load resistance ``R``, around the steady state
    v_C = v_ref."""
    if cfg["plant.output"] != "voltage":
        raise ValueError("the linearisation covers voltage control only")
    base = cfg.with_overrides({
        "controller.law": "ip", "controller.alpha": 1 / gain, "plant.R": R,
        "plant.change_times": [], "reference.level": v_ref, "reference.t_ramp2": 0.0,
        "reference.slope2": 0.0, "sweep.key": None, "sweep.values": None,
    })
    scn = scenario.build([base] * 5)
    E, L, C = base["plant.E"], base["plant.L"], base["plant.C"]
    d = v_ref / E  # di/dt = 0
    coupling = buck.COUPLINGS[base["plant.coupling"]]
    z0 = np.array([v_ref / R - coupling * C * E * d / L, v_ref, v_ref,
                   d / base["controller.output_gain"]])
    eps = 1e-6 * np.maximum(np.abs(z0), 1.0)
    Z = np.tile(z0[:, None], (1, 5))
    for c in range(4):
        Z[c, c + 1] += eps[c]
    X = Z[:2].copy()
    CS = np.zeros((recursive_ip.N_STATE, 5))
    paper_single.reset_members(scn.law_kind, scn.CP, CS)
    CS[recursive_ip.K] = 1.0
    CS[recursive_ip.Y_PREV] = Z[2]
    CS[recursive_ip.U_PREV] = Z[3]
    CS[recursive_ip.R_PREV] = v_ref
    for j in range(5):  # one sample from each state, through the single-run kernel
        scenario.run_member(scn, j, X, CS, np.zeros((metrics.N_METRICS, 1)),
                            np.empty((trajectory.T_X0 + 2, 1)), n_steps=1, t_end=scn.h)
    Z1 = np.vstack([X, CS[recursive_ip.Y_PREV], CS[recursive_ip.U_PREV]])
    J = (Z1[:, 1:] - Z1[:, :1]) / eps
    return float(np.max(np.abs(np.linalg.eigvals(J))))


def growth_rate(rho: float, h: float) -> float:
    """Envelope growth rate (1/s) of the slowest-decaying mode; negative means decay."""
    return float(np.log(rho) / h)
