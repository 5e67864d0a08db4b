"""The metrics fold: running error integrals, maxima, total variation and the divergence
test, sample by sample, as plain floats every kernel calls (the general engine, the
paper's single-run and sweep kernels, and a loop driven from Python).

Rows: ``M[M_*, j]`` member j's running metrics; ``S[S_*]`` the settings they use.
"""

import numpy as np

from .._jit import kernel_jit, step_jit
from ..laws import variational_gain

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
# the loop metrics (:func:`loop_sums`): what any plant's loop is judged by besides the
# error integrals
M_ENERGY = 11  # sum u_k^2 h
# the step window: from the reference step's t0 to the load step (a load step starts
# another response, which iae_load judges)
M_PEAK = 12  # max over the step window of sign(step) (y - final): the overshoot's peak
M_T10 = 13  # first t in the step window with y 10 % of the step on (inf: never)
M_T90 = 14  # ... 90 %
M_T_IN = 15  # t + h after the last sample outside 2 % of the step around its final value
M_E_FINAL = 16  # sum of r - y over the stability window
M_N_FINAL = 17  # its samples
M_IAE_LOAD = 18  # sum |e| h from the load step on
M_T_LAST = 19  # the step window's last sample time (-inf: none yet)
# what the loop metrics are measured against, written before a run (:func:`start`)
M_STEP_T0 = 20  # the reference step's time (a step from STEP_FROM to STEP_TO)
M_STEP_FROM = 21
M_STEP_TO = 22  # NaN: the reference is no step
M_LOAD_T0 = 23  # the load (disturbance) step's time; inf: none
# the variational gain's adaptation error integrated up to the last sample run (the
# state row variational_gain.ADAPT, copied by the drivers; NaN for another gain or law:
# :func:`adaptation`)
M_ADAPT = 24
N_METRICS = 25

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


def adaptation_of(value, mode):
    """The adaptation error ``value`` of a member whose gain adaptation is ``mode``
    (floats, or arrays element-wise): NaN unless the gain is variational, where the
    metric does not apply (a constant, external or rls gain). The one statement of
    where it applies: the drivers (:func:`adaptation`) and the live controllers'
    ``adaptation_error`` call it."""
    return np.where(mode == variational_gain.VARIATIONAL, value, np.nan)


def adaptation(M: np.ndarray, CP: np.ndarray, law_has_gain: bool) -> None:
    """The adaptation error's row of M, copied by the drivers from the law's state, made
    NaN where it does not apply (:func:`adaptation_of`; ``law_has_gain`` False: a law
    without the gain adaptation's rows, the PID)."""
    M[M_ADAPT] = (adaptation_of(M[M_ADAPT], CP[variational_gain.MODE]) if law_has_gain
                  else np.nan)


def start(M: np.ndarray, step_t0, step_from, step_to, load_t0) -> None:
    """The loop metrics' start and what they are measured against (one value, or one per
    member, each): a reference step from ``step_from`` to ``step_to`` at ``step_t0``
    (``step_to`` NaN: none), a load step at ``load_t0`` (inf: none)."""
    M[M_T10] = M[M_T90] = np.inf
    M[M_T_IN] = M[M_T_LAST] = -np.inf
    M[M_STEP_T0] = step_t0
    M[M_STEP_FROM] = step_from
    M[M_STEP_TO] = step_to
    M[M_LOAD_T0] = load_t0


@step_jit
def energy_sum(energy, a, h):
    """A sample of the applied input a folded into the control's energy, sum a^2 h."""
    return energy + a * a * h


@step_jit
def in_step_window(t, step_t0, step_to, load_t0):
    """Whether time t lies in the step window: the reference steps (``step_to`` not NaN),
    from ``step_t0`` on and before the load step."""
    return step_to == step_to and t >= step_t0 and t < load_t0


@step_jit
def step_response(peak, t10, t90, t_in, t, h, y, step_from, step_to):
    """A sample (t, y) of the step window folded into the step response's peak, 10 % and
    90 % times and settling (2 %) time."""
    delta = step_to - step_from
    size = abs(delta)
    sign = 1.0 if delta >= 0.0 else -1.0
    peak = np.fmax(peak, sign * (y - step_to))
    rise = sign * (y - step_from)
    t10 = np.fmin(t10, t if rise >= 0.1 * size else np.inf)
    t90 = np.fmin(t90, t if rise >= 0.9 * size else np.inf)
    t_in = np.fmax(t_in, t + h if abs(y - step_to) > 0.02 * size else -np.inf)
    return peak, t10, t90, t_in


@step_jit
def final_sum(e_final, n_final, y, r):
    """A sample of the stability window folded into its error sum and sample count."""
    return e_final + (r - y), n_final + 1.0


@step_jit
def load_sum(iae_load, h, y, r):
    """A sample from the load step on folded into its IAE."""
    return iae_load + abs(y - r) * h


@step_jit
def loop_sums(energy, peak, t10, t90, t_in, t_last, e_final, n_final, iae_load, t, h, y, r,
              a, step_t0, step_from, step_to, load_t0, final_start):
    """Sample (t, y, r, a) folded into the loop metrics: the control's energy, a step
    response's peak, 10 % and 90 % times and settling (2 %) time, the mean error over the
    stability window, the IAE after a load step. The tests on the step, the window and
    the load are the same for a member at every sample (a scalar loop predicts them, a
    loop over members turns them into selects); a sum left alone keeps its bits, as a
    sum weighted by 0 would."""
    energy = energy_sum(energy, a, h)
    if in_step_window(t, step_t0, step_to, load_t0):
        peak, t10, t90, t_in = step_response(peak, t10, t90, t_in, t, h, y, step_from,
                                             step_to)
        t_last = t
    if t >= final_start:
        e_final, n_final = final_sum(e_final, n_final, y, r)
    if t >= load_t0:
        iae_load = load_sum(iae_load, h, y, r)
    return energy, peak, t10, t90, t_in, t_last, e_final, n_final, iae_load


@step_jit
def fold_loop_sums(M, j, t, h, y, r, a, final_start):
    """:func:`loop_sums` on member j's rows of M."""
    (M[M_ENERGY, j], M[M_PEAK, j], M[M_T10, j], M[M_T90, j], M[M_T_IN, j], M[M_T_LAST, j],
     M[M_E_FINAL, j], M[M_N_FINAL, j], M[M_IAE_LOAD, j]) = loop_sums(
        M[M_ENERGY, j], M[M_PEAK, j], M[M_T10, j], M[M_T90, j], M[M_T_IN, j],
        M[M_T_LAST, j], M[M_E_FINAL, j], M[M_N_FINAL, j], M[M_IAE_LOAD, j], t, h, y, r, a,
        M[M_STEP_T0, j], M[M_STEP_FROM, j], M[M_STEP_TO, j], M[M_LOAD_T0, j], final_start)


@step_jit
def measurement_ok(y, r, bound):
    """y_k is finite and within the bound, and the error's metrics stay finite: the
    divergence test on the measurement (a law runs only on a sample that passes it)."""
    e = y - r
    # & on the three tests, not ``and``: no branches, so a loop over members vectorises
    return np.isfinite(y) & (abs(y) <= bound) & np.isfinite(e * e)


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
    if alive != 0.0:
        fold_loop_sums(M, j, t, h, y, r, a, S[S_FINAL_START])
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
