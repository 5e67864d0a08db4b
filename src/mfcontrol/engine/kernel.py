"""The closed-loop kernels.

Each sample: scheduled parameter changes due at t_k (before that sample's plant step, as
published), the measurement y_k (before the plant step) and the reference r_k, the control
law, streaming metrics and divergence flags, then one plant step with the applied input
held. Two kernels run this loop with the same scalar functions of the laws, plants and
metrics (``recursive_ip.advance``, ``buck.rk4``, ``fold_metrics``/``accumulate``):

* :func:`run_single`: one member, from SoA columns (``X[row, j]`` plant state, ``PP`` plant
  parameters, ``CS``/``CP`` controller state/parameters, ``RP`` reference, ``M`` metrics),
  recording the full trajectory; :func:`run_single_fast` is the same loop in the fast
  mode of the sweeps (fused arithmetic, the plant's RK4 step as its linear map);
* :func:`mfcontrol.engine.packed.block_kernel`: blocks of members for sweeps.
"""

import numpy as np

from .. import references
from .._jit import fast_kernel_jit, kernel_jit, step_jit
from ..laws import gain, recursive_ip
from ..plants import buck

# plant kinds
BUCK = 0
# law kinds
RECURSIVE_IP = 0

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

def settings(settle_time: float, final_start: float, diverge_above: float) -> np.ndarray:
    """The metric settings vector S of the kernels."""
    S = np.zeros(N_SETTINGS)
    S[S_SETTLE] = settle_time
    S[S_FINAL_START] = final_start
    S[S_DIVERGE_ABOVE] = diverge_above
    return S


# trajectory rows; plant states follow from T_X0 on
T_REF = 0
T_Y = 1
T_U = 2
T_APPLIED = 3
T_GAMMA = 4
T_GAIN = 5
T_X0 = 6


@step_jit
def plant_prepare_all(kind, PP, n):
    if kind == BUCK:
        for j in range(n):
            buck.prepare(PP, j)


@step_jit
def apply_events(k, ev_k, ev_row, ev_add, ev_val, PP, n):
    """Apply every scheduled change due at sample k; events run in their listed order."""
    for e in range(ev_row.size):
        row = ev_row[e]
        for j in range(n):
            if ev_k[e, j] == k:
                PP[row, j] = PP[row, j] + ev_val[e, j] if ev_add[e] else ev_val[e, j]


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


def _single_loop(fast):
    """The single-run loop, exact or in the fast mode (``fast``: the plant's RK4 step as
    the linear map of :func:`buck.rk4_map`, computed after every parameter change)."""
    MATRIX = fast

    def run_single(n_steps, h, t_end, plant_kind, PP, X, law_kind, CP, CS, RP,
                   ev_steps, ev_k, ev_row, ev_add, ev_val, S, M, traj):
        """The sample loop for one member (column 0) with its trajectory ``traj[row, k]``.

        The buck under the recursive law (the kinds the compiled path covers), with the
        plant state, the law's memory and the metrics in local variables for the whole run
        and written back at the end: each sample's result feeds the next through registers,
        not through a store and a load, which is what bounds a single run."""
        plant_prepare_all(plant_kind, PP, 1)
        p_ev = 0
        i, v = X[buck.I_L, 0], X[buck.V_C, 0]
        u_prev, y_prev, r_prev = (CS[recursive_ip.U_PREV, 0], CS[recursive_ip.Y_PREV, 0],
                                  CS[recursive_ip.R_PREV, 0])
        g1, g2, k0 = CS[gain.G1, 0], CS[gain.G2, 0], CS[recursive_ip.K, 0]
        alive, t_div, n_done = 1.0 - M[M_DIVERGED, 0], M[M_T_DIVERGE, 0], M[M_N_SAMPLES, 0]
        iae, ise, itae = M[M_IAE, 0], M[M_ISE, 0], M[M_ITAE, 0]
        max_e_s, max_e_f, max_r = M[M_MAX_E_SETTLED, 0], M[M_MAX_E_FINAL, 0], M[M_MAX_ABS_R, 0]
        tv, g_final = M[M_TV, 0], M[M_FINAL_GAMMA, 0]
        settle, final_start, bound = S[S_SETTLE], S[S_FINAL_START], S[S_DIVERGE_ABOVE]
        a_prev = 0.0
        n_run = 0
        # the parameters in locals: loaded once, not at every sample (the compiler cannot
        # hoist the loads itself past the stores into traj, which might alias them)
        (mode, inv_alpha, gamma0, rate, eps_m, order, kp, hd, u0, p_sign, p_current,
         rate_coef, use_gamma, out_gain, lo, hi, aw_coef) = recursive_ip.parameters(CP, 0)
        out_sel, ind, e_in, a12, a21, a22, cpl = _plant(PP)
        ref_kind, ref1, ref2, ref3, ref4 = references.parameters(RP, 0)
        # read only in the fast mode
        f11, f12, f21, f22, gd1, gd2 = buck.rk4_map(ind, e_in, a12, a21, a22, cpl, h)
        for k in range(n_steps):
            t = (k * t_end) / n_steps
            if p_ev < ev_steps.size and ev_steps[p_ev] == k:
                apply_events(k, ev_k, ev_row, ev_add, ev_val, PP, 1)
                plant_prepare_all(plant_kind, PP, 1)
                out_sel, ind, e_in, a12, a21, a22, cpl = _plant(PP)
                if MATRIX:
                    f11, f12, f21, f22, gd1, gd2 = buck.rk4_map(ind, e_in, a12, a21, a22,
                                                                 cpl, h)
                p_ev += 1
            y = buck.measure(i, v, out_sel)
            r = references.evaluate(ref_kind, ref1, ref2, ref3, ref4, t)
            u, a, g, gamma, u_prev, g1, g2 = recursive_ip.advance(
                k0 + k, y, r, u_prev, y_prev, r_prev, g1, g2, mode, inv_alpha, gamma0, rate,
                eps_m, order, kp, hd, u0, p_sign, p_current, rate_coef, use_gamma, out_gain,
                lo, hi, aw_coef)
            y_prev, r_prev = y, r
            n_run = k + 1
            (alive, t_div, n_done, iae, ise, itae, max_e_s, max_e_f, max_r, tv,
             g_final) = fold_metrics(alive, t_div, n_done, iae, ise, itae, max_e_s, max_e_f,
                                     max_r, tv, g_final, k, t, h, y, r, u, a, a_prev, gamma,
                                     settle, final_start, bound)
            if alive == 0.0:
                break
            a_prev = a
            record(traj, k, r, y, u, a, gamma, g)
            traj[T_X0 + buck.I_L, k] = i
            traj[T_X0 + buck.V_C, k] = v
            if MATRIX:
                i, v = buck.rk4_linear(i, v, a, f11, f12, f21, f22, gd1, gd2)
            else:
                i, v = buck.rk4(i, v, a, ind, e_in, a12, a21, a22, cpl, h)
        X[buck.I_L, 0], X[buck.V_C, 0] = i, v
        CS[recursive_ip.U_PREV, 0], CS[recursive_ip.Y_PREV, 0] = u_prev, y_prev
        CS[recursive_ip.R_PREV, 0], CS[recursive_ip.K, 0] = r_prev, k0 + n_run
        CS[gain.G1, 0], CS[gain.G2, 0] = g1, g2
        M[M_DIVERGED, 0], M[M_T_DIVERGE, 0], M[M_N_SAMPLES, 0] = 1.0 - alive, t_div, n_done
        M[M_IAE, 0], M[M_ISE, 0], M[M_ITAE, 0] = iae, ise, itae
        M[M_MAX_E_SETTLED, 0], M[M_MAX_E_FINAL, 0], M[M_MAX_ABS_R, 0] = max_e_s, max_e_f, max_r
        M[M_TV, 0], M[M_FINAL_GAMMA, 0] = tv, g_final

    return run_single


def named_rows(rows, components=(), state_names=()):
    """(signals, states) of recorded trajectory rows: the signals every run records (rows
    T_REF .. T_GAIN), a law's components after them, then the plant states; the one place
    a trajectory's rows get their names."""
    signals = {"y_ref": rows[T_REF], "y": rows[T_Y], "u": rows[T_APPLIED], "u_raw": rows[T_U],
               "gamma": rows[T_GAMMA], "gain": rows[T_GAIN]}
    for i, key in enumerate(components):
        signals[key] = rows[T_X0 + i]
    x0 = T_X0 + len(components)
    return signals, {s: rows[x0 + i] for i, s in enumerate(state_names)}


@step_jit
def record(traj, k, r, y, u, a, gamma, g):
    """Sample k's signals into the trajectory rows T_REF .. T_GAIN."""
    traj[T_REF, k] = r
    traj[T_Y, k] = y
    traj[T_U, k] = u
    traj[T_APPLIED, k] = a
    traj[T_GAMMA, k] = gamma
    traj[T_GAIN, k] = g


@step_jit
def _plant(PP):
    return (PP[buck.OUTPUT, 0], PP[buck.L, 0], PP[buck.E, 0], PP[buck.A12, 0],
            PP[buck.A21, 0], PP[buck.A22, 0], PP[buck.COUPLING, 0])



#: one member with its trajectory, bit for bit the published arithmetic
run_single = kernel_jit(_single_loop(False))
#: the same in the fast mode: within about 1e-13 relative of :data:`run_single`
run_single_fast = fast_kernel_jit(_single_loop(True))


@kernel_jit
def reset_members(law_kind, CP, CS):
    """Put every member's controller memory in its initial state."""
    if law_kind == RECURSIVE_IP:
        for j in range(CS.shape[1]):
            recursive_ip.reset(CP, CS, j)


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
