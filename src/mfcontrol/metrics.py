"""Names and meaning of the per-run metrics, and the stability rule.

All metrics stream out of the kernel over the samples k = 0 .. N-1 (up to divergence),
with e_k = y_k - y*_k and h the sample period:

=================  ===========================================================
iae                sum |e_k| h
ise                sum e_k^2 h
itae               sum t_k |e_k| h
max_abs_e          max |e_k| over t_k >= metrics.settle_time (1 ms)
tv_duty            sum |d_k - d_{k-1}|, the total variation of the duty cycle
final_gamma        gamma at the last sample (1/alpha for the standard law)
diverged           a NaN/inf appeared or |y| exceeded sim.diverge_above
t_diverge          time of the first such sample (NaN if none)
max_abs_e_final    max |e_k| over the stability window (last 20 % of the horizon)
max_abs_ref        max |y*_k| over the run
stable             see :func:`is_stable`
=================  ===========================================================
"""

from __future__ import annotations

import math

import numpy as np

from .engine import kernel

STABILITY_RULE = (
    "A run is *stable* when it did not diverge (no NaN/inf, |y| within sim.diverge_above) "
    "and its tracking error over the last metrics.final_window of the horizon (default "
    "20 %) stays within metrics.stable_tol (default 10 %) of the largest reference value: "
    "max |y - y*| over the final window <= stable_tol * max |y*|. A loop that oscillates "
    "with growing amplitude or sits on a duty limit fails it; a loop that has settled "
    "after a load change passes."
)


def is_stable(diverged: bool, max_abs_e_final: float, max_abs_ref: float, tol: float) -> bool:
    if diverged or not math.isfinite(max_abs_e_final):
        return False
    return max_abs_e_final <= tol * max_abs_ref


def from_kernel(M: np.ndarray, j: int, tol: float) -> dict:
    """Named metrics of member j from the kernel's metric rows."""
    diverged = bool(M[kernel.M_DIVERGED, j])
    out = {
        "iae": float(M[kernel.M_IAE, j]),
        "ise": float(M[kernel.M_ISE, j]),
        "itae": float(M[kernel.M_ITAE, j]),
        "max_abs_e": float(M[kernel.M_MAX_E_SETTLED, j]),
        "tv_duty": float(M[kernel.M_TV, j]),
        "final_gamma": float(M[kernel.M_FINAL_GAMMA, j]),
        "diverged": diverged,
        "t_diverge": float(M[kernel.M_T_DIVERGE, j]) if diverged else math.nan,
        "max_abs_e_final": float(M[kernel.M_MAX_E_FINAL, j]),
        "max_abs_ref": float(M[kernel.M_MAX_ABS_R, j]),
        "n_samples": int(M[kernel.M_N_SAMPLES, j]),
    }
    out["stable"] = is_stable(diverged, out["max_abs_e_final"], out["max_abs_ref"], tol)
    return out
