"""The metrics fold: running error integrals, maxima, total variation and the divergence
test, sample by sample, as plain floats every kernel calls (the general engine, the
paper's single-run and sweep kernels, and a loop driven from Python).

Rows: ``M[M_*, j]`` member j's running metrics; ``S[S_*]`` the settings they use.
"""

import numpy as np

from .._jit import kernel_jit, step_jit

# metric rows
M_IAE = 0
M_ISE = 1
M_ITAE = 2
M_MAX_E_SETTLED = 3
M_TV = 4
M_FINAL_GAMMA = 5
M_MAX_E_FINAL = 6
M_MAX_ABS_R = 7
M_DIVERGED = 8
M_T_DIVERGE = 9
M_N_SAMPLES = 10
N_METRICS = 11

# metric settings
S_SETTLE = 0
S_FINAL_START = 1
S_DIVERGE_ABOVE = 2
N_SETTINGS = 3

def settings(settle_time: float, t_end: float, final_window: float,
             diverge_above: float) -> np.ndarray:
    """The metric settings vector S of the kernels; the final window is the last
    ``final_window`` share of the horizon."""
    S = np.zeros(N_SETTINGS)
    S[S_SETTLE] = settle_time
    S[S_FINAL_START] = t_end * (1 - final_window)
    S[S_DIVERGE_ABOVE] = diverge_above
    return S


@step_jit
def sums(iae, ise, itae, tv, t, h, e, ae, da):
    """The running sums after a sample with error e (|e| = ae) at time t and a change
    da = |a_k - a_{k-1}| of the applied input: the one place their formulas are written
    (:func:`accumulate` and a sweep's plain tile use it)."""
    return iae + ae * h, ise + e * e * h, itae + t * ae * h, tv + da


@step_jit
def accumulate(iae, ise, itae, max_e_s, max_e_f, max_r, tv, k, t, h, y, r, a, a_prev,
               settle, final_start):
    """Sample k folded into the running sums and maxima, from plain floats. The maxima
    start at 0 and grow by selects on ``|e| * w`` with a window weight w in {0, 1} shared
    by every member (the same value as a guarded select for finite e), so a loop over
    members needs no per-member masks."""
    e = y - r
    ae = abs(e)
    iae, ise, itae, tv = sums(iae, ise, itae, tv, t, h, e, ae,
                              abs(a - a_prev) * (1.0 if k > 0 else 0.0))
    # np.fmax, not a select on the running value: a loop over members would turn that
    # select into a masked store, microcoded and about ten times slower on AMD cores. The
    # values are the same (every one >= +0, and a NaN is never folded in: fold_metrics
    # keeps a non-finite sample out, a sweep tile reruns it)
    max_e_s = np.fmax(ae * (1.0 if t >= settle else 0.0), max_e_s)
    max_e_f = np.fmax(ae * (1.0 if t >= final_start else 0.0), max_e_f)
    max_r = np.fmax(abs(r), max_r)
    return iae, ise, itae, max_e_s, max_e_f, max_r, tv


@step_jit
def measurement_ok(y, r, bound):
    """y_k is finite and within the bound, and the error's metrics stay finite: the
    divergence test on the measurement (a law runs only on a sample that passes it)."""
    e = y - r
    return np.isfinite(y) and abs(y) <= bound and np.isfinite(e * e)


@step_jit
def fold_metrics(alive, t_div, n_done, iae, ise, itae, max_e_s, max_e_f, max_r, tv, g_final,
                 k, t, h, y, r, u, a, a_prev, gamma, settle, final_start, bound):
    """Sample k folded into the running metrics with the divergence test: a member whose
    y or u is not finite, whose |y| exceeds ``bound``, or whose error would make a metric
    non-finite (a non-finite reference, or |e|^2 past the float range) is marked at this
    sample (alive = 0) and keeps its metrics, all finite, as they were from then on."""
    bad = not (measurement_ok(y, r, bound) and np.isfinite(u))
    t_div = t if (alive != 0.0 and bad) else t_div
    alive = 0.0 if bad else alive
    live = alive != 0.0
    n_iae, n_ise, n_itae, n_mxs, n_mxf, n_mxr, n_tv = accumulate(
        iae, ise, itae, max_e_s, max_e_f, max_r, tv, k, t, h, y, r, a, a_prev, settle,
        final_start)
    if live:
        iae, ise, itae, max_e_s, max_e_f, max_r, tv = (n_iae, n_ise, n_itae, n_mxs, n_mxf,
                                                       n_mxr, n_tv)
        g_final = gamma
        n_done = k + 1.0
    return alive, t_div, n_done, iae, ise, itae, max_e_s, max_e_f, max_r, tv, g_final


@step_jit
def member_metrics(M, S, j, k, t, h, y, r, u, a, a_prev, gamma):
    """Fold sample k of member j into its metrics; return False once it has diverged."""
    (alive, M[M_T_DIVERGE, j], M[M_N_SAMPLES, j], M[M_IAE, j], M[M_ISE, j], M[M_ITAE, j],
     M[M_MAX_E_SETTLED, j], M[M_MAX_E_FINAL, j], M[M_MAX_ABS_R, j], M[M_TV, j],
     M[M_FINAL_GAMMA, j]) = fold_metrics(
        1.0 - M[M_DIVERGED, j], M[M_T_DIVERGE, j], M[M_N_SAMPLES, j], M[M_IAE, j],
        M[M_ISE, j], M[M_ITAE, j], M[M_MAX_E_SETTLED, j], M[M_MAX_E_FINAL, j],
        M[M_MAX_ABS_R, j], M[M_TV, j], M[M_FINAL_GAMMA, j], k, t, h, y, r, u, a, a_prev,
        gamma, S[S_SETTLE], S[S_FINAL_START], S[S_DIVERGE_ABOVE])
    M[M_DIVERGED, j] = 1.0 - alive
    return alive != 0.0


@kernel_jit
def trajectory_metrics(t, h, y, r, u, applied, gamma, S, M):
    """Fold a recorded trajectory into metrics column 0 of M, sample by sample, with the
    same rule as the kernels (used by loops driven from Python)."""
    a_prev = 0.0
    for k in range(t.size):
        if not member_metrics(M, S, 0, k, t[k], h, y[k], r[k], u[k], applied[k], a_prev,
                              gamma[k]):
            break
        a_prev = applied[k]
