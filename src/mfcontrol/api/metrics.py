"""Names and meaning of the per-run metrics, and the stability rule.

All metrics stream out of the kernel over the samples k = 0 .. N-1 (up to divergence),
with e_k = y_k - y*_k and h the sample period:

=================  ===========================================================
iae                sum |e_k| h
ise                sum e_k^2 h
itae               sum t_k |e_k| h
max_abs_e          max |e_k| over t_k >= metrics.settle_time (1 ms)
tv_u               sum |u_k - u_{k-1}|, the total variation of the applied control
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

from ..engine import metrics as engine_metrics

STABILITY_RULE = (
    "A run is *stable* when it did not diverge (no NaN/inf, |y| within sim.diverge_above) "
    "and its tracking error over the last metrics.final_window of the horizon (default "
    "20 %) stays within metrics.stable_tol (default 10 %) of the largest reference value: "
    "max |y - y*| over the final window <= stable_tol * max |y*|. A loop that oscillates "
    "with growing amplitude or sits on a duty limit fails it; a loop that has settled "
    "after a load change passes."
)


#: the metric columns of a sweep table, in order
COLUMNS = ("iae", "ise", "itae", "max_abs_e", "tv_u", "final_gamma", "max_abs_e_final",
           "max_abs_ref", "diverged", "t_diverge", "n_samples", "stable")


def is_stable(diverged, max_abs_e_final, max_abs_ref, tol):
    """The stability rule; works on floats and, element-wise, on arrays."""
    return np.logical_and(~np.asarray(diverged, dtype=bool) & np.isfinite(max_abs_e_final),
                          np.asarray(max_abs_e_final) <= tol * np.asarray(max_abs_ref))


def table(M: np.ndarray, tol: float) -> dict[str, np.ndarray]:
    """Named metrics of every member (columns of the kernel's metric rows)."""
    diverged = M[engine_metrics.M_DIVERGED] != 0.0
    out = {
        "iae": M[engine_metrics.M_IAE].copy(),
        "ise": M[engine_metrics.M_ISE].copy(),
        "itae": M[engine_metrics.M_ITAE].copy(),
        "max_abs_e": M[engine_metrics.M_MAX_E_SETTLED].copy(),
        "tv_u": M[engine_metrics.M_TV].copy(),
        "final_gamma": M[engine_metrics.M_FINAL_GAMMA].copy(),
        "diverged": diverged,
        "t_diverge": np.where(diverged, M[engine_metrics.M_T_DIVERGE], math.nan),
        "max_abs_e_final": M[engine_metrics.M_MAX_E_FINAL].copy(),
        "max_abs_ref": M[engine_metrics.M_MAX_ABS_R].copy(),
        "n_samples": M[engine_metrics.M_N_SAMPLES].astype(np.int64),
    }
    out["stable"] = is_stable(diverged, out["max_abs_e_final"], out["max_abs_ref"], tol)
    return out


def from_kernel(M: np.ndarray, j: int, tol: float) -> dict:
    """Named metrics of member j, as plain Python values. NaN is always ``math.nan``: one
    object, so that two runs with equal metrics give dicts that compare equal."""
    out = {k: v.item() for k, v in table(M[:, j:j + 1], tol).items()}
    return {k: math.nan if isinstance(v, float) and v != v else v for k, v in out.items()}
