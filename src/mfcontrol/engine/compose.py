"""The closed loop of any plant and any law, compiled once: the general engine.

Each sample k (t_k = (k t_end) / N, the single run's formula): scheduled parameter changes
due at k (then the plant's ``prepare``), the measurement y_k = output(x_k) before the plant
step, the reference r_k, the law (:func:`mfcontrol.laws.intelligent.step` or
:func:`mfcontrol.laws.recursive_ip.step`, the functions the live controllers call), the
metrics fold of every kernel (:func:`mfcontrol.engine.metrics.fold_metrics`, with its
divergence test), then the plant advanced over [t_k, t_k + h] with the applied input held:
by the one RK4 (:mod:`mfcontrol.numerics.rk4`), the one Dormand-Prince 5(4)
(:mod:`mfcontrol.numerics.dopri45`) or the plant's exact step.

The plant comes in as the addresses of its compiled functions
(:mod:`mfcontrol.numerics.signatures`),
so this one kernel, compiled once and cached on disk, runs every plant: the converters,
the first-order plant, LTI models and your own ODE. Members (columns of the law arrays,
rows of the plant arrays) run one after another, each a single run; :func:`run` spreads
them over threads (the kernel releases the GIL).

The paper's buck under the recursive law keeps its own tuned kernels
(:mod:`mfcontrol.engine.paper_single`, :mod:`mfcontrol.engine.paper_sweep`): state in registers and
members vectorised. Both fold the metrics with the same function, step the law with the
same function and integrate the buck with the same arithmetic.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache

import numpy as np
from numba import njit, types

from .. import _jit
from ..laws import intelligent, recursive_ip, reference, variational_gain
from ..numerics import dopri45, grid, rk4
from ..numerics import signatures as sig
from . import metrics as engine_metrics
from . import paper_single, trajectory

# law kinds
RECURSIVE_IP = paper_single.RECURSIVE_IP
INTELLIGENT = 1
# integrators
RK4 = 0
DP45 = 1
EXACT = 2
INTEGRATORS = {"rk4": RK4, "rk45": DP45, "exact": EXACT}

# trajectory rows; the law's component rows follow from T_COMP on, then the plant states
T_COMP = trajectory.T_X0


def _make_loop(fast):
    """The member loop, compiled exact or with the fast mode's flags (``fast`` only tells
    numba's cache the two apart)."""
    FAST = fast

    def member_loop(law_kind, integ, rhs, output, prepare, advance, n_steps, h, t_end, law_dt,
                    X, P, CP, CS, R, RP, AL, ev_k, ev_col, ev_add, ev_val, S, M, tol, DT, j0, j1,
                    traj, comp_rows):
        """Members j0 .. j1-1 from their present state, for n_steps samples.

        ``X[j]``/``P[j]``: plant state/parameters of member j; ``CP[:, j]``/``CS[:, j]``:
        law parameters/state; ``R[j or 0, k]`` the reference when R has rows, else
        ``reference.value(RP, j, t)``; ``AL[j or 0, k]``, when AL has rows, the alpha of an
        external gain (written to the law's ``ALPHA_EXT`` row before it runs); event e sets
        (or adds, ``ev_add[e]``) ``ev_val[e, j]`` to ``P[j, ev_col[e]]`` at sample
        ``ev_k[e, j]``; ``M[:, j]`` the metrics;
        ``DT[j]`` the adaptive integrator's carried step. When ``traj`` has n_steps columns,
        member j0's trajectory is recorded there (rows as ``trajectory.T_REF`` .. ``T_GAIN``,
        the CS rows ``comp_rows`` from :data:`T_COMP` on, then the states).
        """
        rhs = sig.as_rhs(rhs)
        output = sig.as_output(output)
        prepare = sig.as_prepare(prepare)
        advance = sig.as_advance(advance)
        n_x = X.shape[1]
        n_p = P.shape[1]
        w = np.empty((max(5, dopri45.N_WORK), n_x))
        n_ev = ev_col.size
        record = traj.shape[1] == n_steps
        t_x0 = T_COMP + comp_rows.size
        own_ref = R.shape[0] > 1
        use_series = R.shape[0] > 0
        own_alpha = AL.shape[0] > 1
        external = AL.shape[0] > 0
        rtol, atol = tol[0], tol[1]
        bound = S[engine_metrics.S_DIVERGE_ABOVE]
        # each member's law columns and metrics are copied to one contiguous column while it
        # runs: in place, a member's rows lie a whole row of members apart (measured: a
        # 1,024-member batch 1.8x slower per sample than a 64-member one)
        cp = np.empty((CP.shape[0], 1))
        cs = np.empty((CS.shape[0], 1))
        mj = np.empty((M.shape[0], 1))
        for j in range(j0, j1):
            for i in range(CP.shape[0]):
                cp[i, 0] = CP[i, j]
            for i in range(CS.shape[0]):
                cs[i, 0] = CS[i, j]
            for i in range(M.shape[0]):
                mj[i, 0] = M[i, j]
            x = X[j]
            p = P[j]
            prepare(sig.pointer(p), h, n_x, n_p)
            next_ev = n_steps
            for e in range(n_ev):
                next_ev = min(next_ev, ev_k[e, j])
            a_prev = 0.0
            dt_carry = DT[j]
            ref_row = j if own_ref else 0
            for k in range(n_steps):
                t = grid.time(k, t_end, n_steps)
                if k == next_ev:
                    next_ev = n_steps
                    for e in range(n_ev):
                        ke = ev_k[e, j]
                        if ke == k:
                            c = ev_col[e]
                            p[c] = p[c] + ev_val[e, j] if ev_add[e] else ev_val[e, j]
                        elif ke > k:
                            next_ev = min(next_ev, ke)
                    prepare(sig.pointer(p), h, n_x, n_p)
                y = output(sig.pointer(x), sig.pointer(p), n_x, n_p)
                if use_series:
                    r = R[ref_row, k]
                else:
                    r = reference.value(RP, j, t)
                if not engine_metrics.measurement_ok(y, r, bound):
                    # flagged before the law runs: the controller's memory ends at the last
                    # good sample, as a loop of live calls would leave it
                    engine_metrics.member_metrics(mj, S, 0, k, t, h, y, r, 0.0, 0.0, a_prev, 0.0)
                    break
                if law_kind == INTELLIGENT:
                    if external:  # as the live controller writes it (engine.live)
                        cs[variational_gain.ALPHA_EXT, 0] = AL[j if own_alpha else 0, k]
                    a = intelligent.step(cp, cs, 0, y, r, law_dt)
                    u = cs[intelligent.C_UNLIM, 0]
                    gamma = cs[variational_gain.G1, 0]
                    g = gamma
                else:
                    u, a, g, gamma = recursive_ip.step(cp, cs, 0, y, r)
                if not engine_metrics.member_metrics(mj, S, 0, k, t, h, y, r, u, a, a_prev, gamma):
                    break
                a_prev = a
                if record and j == j0:
                    trajectory.record(traj, k, r, y, u, a, gamma, g)
                    for c in range(comp_rows.size):
                        traj[T_COMP + c, k] = cs[comp_rows[c], 0]
                    for i in range(n_x):
                        traj[t_x0 + i, k] = x[i]
                if integ == RK4:
                    rk4.step(rhs, t, x, a, p, h, w)
                elif integ == DP45:
                    dt_carry = dopri45.integrate(rhs, t, x, a, p, h, rtol, atol, dt_carry, w)
                else:
                    advance(t, sig.pointer(x), a, sig.pointer(p), h, n_x, n_p)
            DT[j] = dt_carry
            for i in range(CS.shape[0]):
                CS[i, j] = cs[i, 0]
            for i in range(M.shape[0]):
                M[i, j] = mj[i, 0]
        return FAST

    return member_loop


_m = types.float64[:, ::1]
_v = types.float64[::1]
_i2 = types.int64[:, ::1]
_i1 = types.int64[::1]
SIGNATURE = types.boolean(
    types.int64, types.int64, types.intp, types.intp, types.intp, types.intp,
    types.int64, types.float64, types.float64, types.float64,
    _m, _m, _m, _m, _m, _m, _m, _i2, _i1, types.boolean[::1], _m, _v, _m, _v, _v,
    types.int64, types.int64, _m, _i1)


@lru_cache(maxsize=2)
def member_kernel(fast: bool = False):
    """The compiled member loop (exact IEEE arithmetic, or the fast mode's flags); loaded
    from numba's disk cache after the first compilation, which takes about 20 s."""
    options = dict(error_model="numpy", cache=True, nogil=True)
    if fast:
        options["fastmath"] = set(_jit.FAST_FLAGS)
    fn = njit(**options)(_make_loop(bool(fast)))
    fn.compile(SIGNATURE)
    fn.disable_compile()
    return fn


def threads_for(n_members: int, n_samples: int) -> int:
    """Worker threads for a batch: all cores once the batch is worth a thread's start-up."""
    if n_members < 2 or n_members * n_samples < 200_000:
        return 1
    return min(len(os.sched_getaffinity(0)), n_members)  # the cores this process may use


def run(law_kind, integ, plant_fns, n_steps, h, t_end, law_dt, X, P, CP, CS, R, RP, AL,
        events, S, M, tol, DT, traj, comp_rows, *, fast=False, threads=None):
    """Run every member (all columns) through the member loop; arrays in place.

    ``plant_fns`` is (rhs, output, prepare, advance); ``events`` (ev_k, ev_col, ev_add,
    ev_val). ``traj`` with n_steps columns records member 0 (then only one member runs).
    """
    fn = member_kernel(fast)
    rhs, output, prepare, advance = (f.address for f in plant_fns)
    ev_k, ev_col, ev_add, ev_val = events
    m = X.shape[0]
    args = (law_kind, integ, rhs, output, prepare, advance, n_steps, h, t_end, law_dt, X, P,
            CP, CS, R, RP, AL, ev_k, ev_col, ev_add, ev_val, S, M, tol, DT)
    n_threads = threads_for(m, n_steps) if threads is None else threads
    if n_threads <= 1 or traj.shape[1] == n_steps:
        fn(*args, 0, m, traj, comp_rows)
        return
    bounds = np.linspace(0, m, n_threads + 1).astype(int)
    with ThreadPoolExecutor(n_threads) as pool:
        list(pool.map(lambda ab: fn(*args, ab[0], ab[1], traj, comp_rows),
                      zip(bounds[:-1], bounds[1:], strict=True)))
