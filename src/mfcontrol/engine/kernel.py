"""The closed-loop kernel: any number of members (scenarios) over one time grid.

One kernel serves a single run (one member, full trajectory) and the batch engine (many
members, metrics only or a few kept trajectories). Each time step runs in stages, each a
loop over members with the kind dispatch outside it, so that the member loop is straight-line
code the compiler can vectorise:

1. scheduled parameter changes (before that sample's plant step, as published),
2. measurement y_k (before the plant step) and reference r_k,
3. the control law,
4. streaming metrics and divergence flags,
5. trajectory recording of kept members,
6. one plant step with the applied input held.

Arrays are SoA: ``X[row, j]`` plant state, ``PP`` plant parameters, ``CS``/``CP`` controller
state/parameters, ``RP`` reference parameters, ``M[row, j]`` metrics of member j.
"""

import numpy as np

from .. import references
from .._jit import kernel_jit, step_jit
from ..laws import recursive_ip
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
def plant_output_stage(kind, PP, X, Y, n):
    if kind == BUCK:
        for j in range(n):
            Y[j] = buck.output(PP, X, j)


@step_jit
def plant_step_stage(kind, PP, X, A, n, h):
    if kind == BUCK:
        for j in range(n):
            buck.step(PP, X, j, A[j], h)


@step_jit
def law_stage(kind, CP, CS, Y, R, U, A, G, GAM, n):
    if kind == RECURSIVE_IP:
        for j in range(n):
            U[j], A[j], G[j], GAM[j] = recursive_ip.step(CP, CS, j, Y[j], R[j])


@step_jit
def apply_events(k, ev_k, ev_row, ev_add, ev_val, PP, n):
    """Apply every scheduled change due at sample k; events run in their listed order."""
    for e in range(ev_row.size):
        row = ev_row[e]
        for j in range(n):
            if ev_k[e, j] == k:
                PP[row, j] = PP[row, j] + ev_val[e, j] if ev_add[e] else ev_val[e, j]


@step_jit
def member_metrics(M, S, j, k, t, h, y, r, u, a, a_prev, gamma):
    """Fold sample k of member j into its metrics; return False once it has diverged."""
    if M[M_DIVERGED, j] != 0.0:
        return False
    if not (np.isfinite(y) and np.isfinite(u) and abs(y) <= S[S_DIVERGE_ABOVE]):
        M[M_DIVERGED, j] = 1.0
        M[M_T_DIVERGE, j] = t
        return False
    e = y - r
    ae = abs(e)
    M[M_IAE, j] += ae * h
    M[M_ISE, j] += e * e * h
    M[M_ITAE, j] += t * ae * h
    if t >= S[S_SETTLE] and ae > M[M_MAX_E_SETTLED, j]:
        M[M_MAX_E_SETTLED, j] = ae
    if t >= S[S_FINAL_START] and ae > M[M_MAX_E_FINAL, j]:
        M[M_MAX_E_FINAL, j] = ae
    ar = abs(r)
    if ar > M[M_MAX_ABS_R, j]:
        M[M_MAX_ABS_R, j] = ar
    if k > 0:
        M[M_TV, j] += abs(a - a_prev)
    M[M_FINAL_GAMMA, j] = gamma
    M[M_N_SAMPLES, j] = k + 1
    return True


@step_jit
def metrics_stage(k, t, h, Y, R, U, A, A_prev, GAM, M, S, n):
    alive_count = 0
    for j in range(n):
        if member_metrics(M, S, j, k, t, h, Y[j], R[j], U[j], A[j], A_prev[j], GAM[j]):
            alive_count += 1
        A_prev[j] = A[j]
    return alive_count


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
    """The same loop as :func:`run_chunk` for one member (column 0) and its trajectory
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
def run_chunk(n_steps, h, t_end, plant_kind, PP, X, law_kind, CP, CS, RP,
              ev_steps, ev_k, ev_row, ev_add, ev_val, S, M, keep, traj):
    """Simulate all members of one chunk from their current state for n_steps samples.

    Sample k is at ``t_k = (k * t_end) / n_steps``. ``ev_steps`` lists, sorted and unique,
    the samples at which any member has a scheduled change. ``keep`` lists the members
    whose trajectories go to ``traj[row, m, k]``; samples after a member diverges are not
    written.
    """
    n = X.shape[1]
    Y = np.empty(n)
    R = np.empty(n)
    U = np.empty(n)
    A = np.empty(n)
    A_prev = np.zeros(n)
    G = np.empty(n)
    GAM = np.empty(n)
    n_x = X.shape[0]
    plant_prepare_all(plant_kind, PP, n)
    p_ev = 0
    for k in range(n_steps):
        t = (k * t_end) / n_steps
        if p_ev < ev_steps.size and ev_steps[p_ev] == k:
            apply_events(k, ev_k, ev_row, ev_add, ev_val, PP, n)
            plant_prepare_all(plant_kind, PP, n)
            p_ev += 1
        plant_output_stage(plant_kind, PP, X, Y, n)
        for j in range(n):
            R[j] = references.value(RP, j, t)
        law_stage(law_kind, CP, CS, Y, R, U, A, G, GAM, n)
        alive = metrics_stage(k, t, h, Y, R, U, A, A_prev, GAM, M, S, n)
        for m in range(keep.size):
            jj = keep[m]
            if M[M_DIVERGED, jj] == 0.0:
                traj[T_REF, m, k] = R[jj]
                traj[T_Y, m, k] = Y[jj]
                traj[T_U, m, k] = U[jj]
                traj[T_APPLIED, m, k] = A[jj]
                traj[T_GAMMA, m, k] = GAM[jj]
                traj[T_GAIN, m, k] = G[jj]
                for s in range(n_x):
                    traj[T_X0 + s, m, k] = X[s, jj]
        if alive == 0:
            break
        plant_step_stage(plant_kind, PP, X, A, n, h)


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
