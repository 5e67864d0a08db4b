"""The closed-loop kernels.

Each sample: scheduled parameter changes due at t_k (before that sample's plant step, as
published), the measurement y_k (before the plant step) and the reference r_k, the control
law, streaming metrics and divergence flags, then one plant step with the applied input
held. Two kernels run this loop with the same scalar functions of the laws, plants and
metrics (``recursive_ip.advance``, ``buck.rk4``, ``fold_metrics``):

* :func:`run_single`: one member, from SoA columns (``X[row, j]`` plant state, ``PP`` plant
  parameters, ``CS``/``CP`` controller state/parameters, ``RP`` reference, ``M`` metrics),
  recording the full trajectory;
* :func:`run_packed`: a block of members whose every quantity sits in one array, for sweeps.
"""

import numpy as np

from .. import references
from .._jit import kernel_jit, step_jit
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
def fold_metrics(alive, t_div, n_done, iae, ise, itae, max_e_s, max_e_f, max_r, tv, g_final,
                 k, t, h, y, r, u, a, a_prev, gamma, settle, final_start, bound):
    """Sample k folded into the running metrics, from plain floats: the one place the
    metrics are written. Selects instead of branches, so a loop over members vectorises.
    A member that has diverged (alive = 0) keeps its metrics as they were."""
    bad = not (np.isfinite(y) and np.isfinite(u) and abs(y) <= bound)
    t_div = t if (alive != 0.0 and bad) else t_div
    alive = 0.0 if bad else alive
    live = alive != 0.0
    e = y - r
    ae = abs(e)
    iae = iae + ae * h if live else iae
    ise = ise + e * e * h if live else ise
    itae = itae + t * ae * h if live else itae
    max_e_s = ae if (live and t >= settle and ae > max_e_s) else max_e_s
    max_e_f = ae if (live and t >= final_start and ae > max_e_f) else max_e_f
    ar = abs(r)
    max_r = ar if (live and ar > max_r) else max_r
    tv = tv + abs(a - a_prev) if (live and k > 0) else tv
    g_final = gamma if live else g_final
    n_done = k + 1.0 if live else n_done
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


@step_jit
def member_output(kind, PP, X, j):
    if kind == BUCK:
        return buck.output(PP, X, j)
    return np.nan


@step_jit
def member_law(kind, CP, CS, j, y, r):
    if kind == RECURSIVE_IP:
        return recursive_ip.step(CP, CS, j, y, r)
    return np.nan, np.nan, np.nan, np.nan


@step_jit
def member_plant_step(kind, PP, X, j, a, h):
    if kind == BUCK:
        buck.step(PP, X, j, a, h)


@kernel_jit
def run_single(n_steps, h, t_end, plant_kind, PP, X, law_kind, CP, CS, RP,
               ev_steps, ev_k, ev_row, ev_add, ev_val, S, M, traj):
    """The sample loop for one member (column 0) with its trajectory
    ``traj[row, k]``: no member loops, so nothing is spent on loop set-up each sample."""
    n_x = X.shape[0]
    plant_prepare_all(plant_kind, PP, 1)
    p_ev = 0
    a_prev = 0.0
    for k in range(n_steps):
        t = (k * t_end) / n_steps
        if p_ev < ev_steps.size and ev_steps[p_ev] == k:
            apply_events(k, ev_k, ev_row, ev_add, ev_val, PP, 1)
            plant_prepare_all(plant_kind, PP, 1)
            p_ev += 1
        y = member_output(plant_kind, PP, X, 0)
        r = references.value(RP, 0, t)
        u, a, g, gamma = member_law(law_kind, CP, CS, 0, y, r)
        if not member_metrics(M, S, 0, k, t, h, y, r, u, a, a_prev, gamma):
            break
        a_prev = a
        traj[T_REF, k] = r
        traj[T_Y, k] = y
        traj[T_U, k] = u
        traj[T_APPLIED, k] = a
        traj[T_GAMMA, k] = gamma
        traj[T_GAIN, k] = g
        for s in range(n_x):
            traj[T_X0 + s, k] = X[s, 0]
        member_plant_step(plant_kind, PP, X, 0, a, h)


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


@kernel_jit
def reference_series(RP, t, out):
    """The reference of member 0 at every time in t (for loops driven from Python)."""
    for k in range(t.size):
        out[k] = references.value(RP, 0, t[k])


# ---- the packed batch kernel: the buck under the paper's law ------------------------------
# Every per-member quantity lives in one array D[row, j], so the member loop addresses a
# single block of memory: the compiler then needs no run-time alias checks between a
# dozen arrays, and the loop of scalar, branch-free step functions vectorises.
P_PP = 0
P_X = P_PP + buck.N_PARAMS
P_CP = P_X + buck.N_STATE
P_CS = P_CP + recursive_ip.N_PARAMS
P_M = P_CS + recursive_ip.N_STATE
P_APREV = P_M + N_METRICS
P_ROWS = P_APREV + 1
#: members per packed block (not a power of two times 512 bytes: no 4 KiB set aliasing)
BLOCK = 120


def _row(r):
    """Offset of packed row r in a block: a compile-time constant, so every access is a
    fixed distance from every other and the compiler needs no alias checks."""
    return r * BLOCK


# offsets of the rows the member loop reads and writes
_L, _E, _A12, _A21, _A22, _CPL, _OUT = (_row(P_PP + r) for r in (
    buck.L, buck.E, buck.A12, buck.A21, buck.A22, buck.COUPLING, buck.OUTPUT))
_I, _V = _row(P_X + buck.I_L), _row(P_X + buck.V_C)
(_MODE, _INVA, _G0, _GR, _EPS, _ORD, _KP, _HD, _U0, _PS, _PC, _RC, _UG, _OG, _LO, _HI,
 _AW) = (_row(P_CP + r) for r in (
    gain.MODE, gain.INV_ALPHA, gain.GAMMA0, gain.GAMMA_RATE, gain.EPS_M, gain.ORDER,
    recursive_ip.KP, recursive_ip.HD, recursive_ip.U0, recursive_ip.P_SIGN,
    recursive_ip.P_CURRENT, recursive_ip.RATE_COEF, recursive_ip.USE_GAMMA,
    recursive_ip.OUT_GAIN, recursive_ip.OUT_MIN, recursive_ip.OUT_MAX, recursive_ip.AW_COEF))
_UP, _YP, _RP, _G1, _G2 = (_row(P_CS + r) for r in (
    recursive_ip.U_PREV, recursive_ip.Y_PREV, recursive_ip.R_PREV, gain.G1, gain.G2))
(_DIV, _TDIV, _NS, _IAE, _ISE, _ITAE, _MXS, _MXF, _MXR, _TV, _GF) = (_row(P_M + r) for r in (
    M_DIVERGED, M_T_DIVERGE, M_N_SAMPLES, M_IAE, M_ISE, M_ITAE, M_MAX_E_SETTLED,
    M_MAX_E_FINAL, M_MAX_ABS_R, M_TV, M_FINAL_GAMMA))
_AP = _row(P_APREV)


@kernel_jit
def run_packed(n_steps, h, t_end, D2, RP, ev_steps, ev_k, ev_row, ev_add, ev_val, S):
    """The buck under the recursive law for the BLOCK members of D2[row, j], from sample 0
    (state reset). Same functions, same arithmetic as :func:`run_single`; the metrics are
    left in D2's rows."""
    D = D2.ravel()
    R = np.empty(BLOCK)
    PP = D2[P_PP:P_X]
    settle, final_start, bound = S[S_SETTLE], S[S_FINAL_START], S[S_DIVERGE_ABOVE]
    for j in range(BLOCK):
        buck.prepare(PP, j)
    p_ev = 0
    for k in range(n_steps):
        t = (k * t_end) / n_steps
        if p_ev < ev_steps.size and ev_steps[p_ev] == k:
            apply_events(k, ev_k, ev_row, ev_add, ev_val, PP, BLOCK)
            for j in range(BLOCK):
                buck.prepare(PP, j)
            p_ev += 1
        for j in range(BLOCK):
            R[j] = references.value(RP, j, t)
        kf = float(k)
        for j in range(BLOCK):
            i, v, r = D[_I + j], D[_V + j], R[j]
            y = buck.measure(i, v, D[_OUT + j])
            u, a, g, gamma, carried, g1, g2 = recursive_ip.advance(
                kf, y, r, D[_UP + j], D[_YP + j], D[_RP + j], D[_G1 + j], D[_G2 + j],
                D[_MODE + j], D[_INVA + j], D[_G0 + j], D[_GR + j], D[_EPS + j], D[_ORD + j],
                D[_KP + j], D[_HD + j], D[_U0 + j], D[_PS + j], D[_PC + j], D[_RC + j],
                D[_UG + j], D[_OG + j], D[_LO + j], D[_HI + j], D[_AW + j])
            D[_UP + j], D[_YP + j], D[_RP + j], D[_G1 + j], D[_G2 + j] = carried, y, r, g1, g2
            (alive, D[_TDIV + j], D[_NS + j], D[_IAE + j], D[_ISE + j], D[_ITAE + j],
             D[_MXS + j], D[_MXF + j], D[_MXR + j], D[_TV + j], D[_GF + j]) = fold_metrics(
                1.0 - D[_DIV + j], D[_TDIV + j], D[_NS + j], D[_IAE + j], D[_ISE + j],
                D[_ITAE + j], D[_MXS + j], D[_MXF + j], D[_MXR + j], D[_TV + j], D[_GF + j],
                k, t, h, y, r, u, a, D[_AP + j], gamma, settle, final_start, bound)
            D[_DIV + j] = 1.0 - alive
            D[_AP + j] = a
            D[_I + j], D[_V + j] = buck.rk4(i, v, a, D[_L + j], D[_E + j], D[_A12 + j],
                                            D[_A21 + j], D[_A22 + j], D[_CPL + j], h)
