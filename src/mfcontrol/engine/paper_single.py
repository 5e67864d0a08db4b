"""The paper's tuned single-run kernel: the buck under the recursive law.

Each sample: scheduled parameter changes due at t_k (before that sample's plant step, as
published), the measurement y_k (before the plant step) and the reference r_k, the control
law, streaming metrics and divergence flags, then one plant step with the applied input
held, with the scalar functions every kernel calls (``recursive_ip.advance``,
``buck.rk4``, :func:`mfcontrol.engine.metrics.fold_metrics` and ``loop_sums``).

:func:`run_single` runs one member from SoA columns (``X[row, j]`` plant state, ``PP``
plant parameters, ``CS``/``CP`` controller state/parameters, ``RP`` reference, ``M``
metrics), recording the full trajectory; :func:`run_single_fast` is the same loop in the
fast mode (fused arithmetic, the plant's RK4 step as its linear map). Sweeps of this case
run in :mod:`mfcontrol.engine.paper_sweep`; every other loop in
:mod:`mfcontrol.engine.compose`.
"""


from .._jit import fast_kernel_jit, kernel_jit, step_jit
from ..laws import recursive_ip, reference, variational_gain
from ..numerics import grid
from ..plants import buck
from .metrics import (
    M_ADAPT,
    M_DIVERGED,
    M_E_FINAL,
    M_ENERGY,
    M_FINAL_GAMMA,
    M_IAE,
    M_IAE_LOAD,
    M_ISE,
    M_ITAE,
    M_LOAD_T0,
    M_MAX_ABS_R,
    M_MAX_E_FINAL,
    M_MAX_E_SETTLED,
    M_N_FINAL,
    M_N_SAMPLES,
    M_PEAK,
    M_STEP_FROM,
    M_STEP_T0,
    M_STEP_TO,
    M_T10,
    M_T90,
    M_T_DIVERGE,
    M_T_IN,
    M_T_LAST,
    M_TV,
    S_DIVERGE_ABOVE,
    S_FINAL_START,
    S_SETTLE,
    fold_metrics,
    loop_sums,
)
from .trajectory import T_X0, record

# plant kinds
BUCK = 0
# law kinds
RECURSIVE_IP = 0

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
        g1, g2, k0 = CS[variational_gain.G1, 0], CS[variational_gain.G2, 0], CS[recursive_ip.K, 0]
        acc, cnt = CS[variational_gain.ACC, 0], CS[variational_gain.CNT, 0]
        adapt = CS[variational_gain.ADAPT, 0]
        adapt_final = M[M_ADAPT, 0]
        alive, t_div, n_done = 1.0 - M[M_DIVERGED, 0], M[M_T_DIVERGE, 0], M[M_N_SAMPLES, 0]
        iae, ise, itae = M[M_IAE, 0], M[M_ISE, 0], M[M_ITAE, 0]
        max_e_s, max_e_f, max_r = M[M_MAX_E_SETTLED, 0], M[M_MAX_E_FINAL, 0], M[M_MAX_ABS_R, 0]
        tv, g_final = M[M_TV, 0], M[M_FINAL_GAMMA, 0]
        energy, peak, t10, t90, t_in, t_last, e_fin, n_fin, iae_load = (
            M[M_ENERGY, 0], M[M_PEAK, 0], M[M_T10, 0], M[M_T90, 0], M[M_T_IN, 0],
            M[M_T_LAST, 0], M[M_E_FINAL, 0], M[M_N_FINAL, 0], M[M_IAE_LOAD, 0])
        step_t0, step_from, step_to, load_t0 = (M[M_STEP_T0, 0], M[M_STEP_FROM, 0],
                                                M[M_STEP_TO, 0], M[M_LOAD_T0, 0])
        settle, final_start, bound = S[S_SETTLE], S[S_FINAL_START], S[S_DIVERGE_ABOVE]
        a_prev = 0.0
        n_run = 0
        # the parameters in locals: loaded once, not at every sample (the compiler cannot
        # hoist the loads itself past the stores into traj, which might alias them)
        law = recursive_ip.parameters(CP, 0)
        out_sel, ind, e_in, a12, a21, a22, cpl = _plant(PP)
        ref_kind, ref1, ref2, ref3, ref4 = reference.parameters(RP, 0)
        # read only in the fast mode
        f11, f12, f21, f22, gd1, gd2 = buck.rk4_map(ind, e_in, a12, a21, a22, cpl, h)
        for k in range(n_steps):
            t = grid.time(k, t_end, n_steps)
            if p_ev < ev_steps.size and ev_steps[p_ev] == k:
                apply_events(k, ev_k, ev_row, ev_add, ev_val, PP, 1)
                plant_prepare_all(plant_kind, PP, 1)
                out_sel, ind, e_in, a12, a21, a22, cpl = _plant(PP)
                if MATRIX:
                    f11, f12, f21, f22, gd1, gd2 = buck.rk4_map(ind, e_in, a12, a21, a22,
                                                                 cpl, h)
                p_ev += 1
            y = buck.measure(i, v, out_sel)
            r = reference.evaluate(ref_kind, ref1, ref2, ref3, ref4, t)
            u, a, g, gamma, u_prev, g1, g2, acc, cnt, adapt = recursive_ip.advance(
                k0 + k, y, r, u_prev, y_prev, r_prev, g1, g2, acc, cnt, adapt, law)
            y_prev, r_prev = y, r
            n_run = k + 1
            (alive, t_div, n_done, iae, ise, itae, max_e_s, max_e_f, max_r, tv,
             g_final) = fold_metrics(alive, t_div, n_done, iae, ise, itae, max_e_s, max_e_f,
                                     max_r, tv, g_final, k, t, h, y, r, u, a, a_prev, gamma,
                                     settle, final_start, bound)
            if alive == 0.0:
                break
            adapt_final = adapt  # as the final gamma: up to the last live sample
            (energy, peak, t10, t90, t_in, t_last, e_fin, n_fin, iae_load) = loop_sums(
                energy, peak, t10, t90, t_in, t_last, e_fin, n_fin, iae_load, t, h, y, r, a,
                step_t0, step_from, step_to, load_t0, final_start)
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
        CS[variational_gain.G1, 0], CS[variational_gain.G2, 0] = g1, g2
        CS[variational_gain.ACC, 0], CS[variational_gain.CNT, 0] = acc, cnt
        CS[variational_gain.ADAPT, 0] = adapt
        M[M_DIVERGED, 0], M[M_T_DIVERGE, 0], M[M_N_SAMPLES, 0] = 1.0 - alive, t_div, n_done
        M[M_IAE, 0], M[M_ISE, 0], M[M_ITAE, 0] = iae, ise, itae
        M[M_MAX_E_SETTLED, 0], M[M_MAX_E_FINAL, 0], M[M_MAX_ABS_R, 0] = max_e_s, max_e_f, max_r
        M[M_TV, 0], M[M_FINAL_GAMMA, 0], M[M_ADAPT, 0] = tv, g_final, adapt_final
        (M[M_ENERGY, 0], M[M_PEAK, 0], M[M_T10, 0], M[M_T90, 0], M[M_T_IN, 0], M[M_T_LAST, 0],
         M[M_E_FINAL, 0], M[M_N_FINAL, 0], M[M_IAE_LOAD, 0]) = (
            energy, peak, t10, t90, t_in, t_last, e_fin, n_fin, iae_load)

    return run_single


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
