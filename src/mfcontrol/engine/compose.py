"""The closed loop of any plant and any law, compiled once: the general engine.

Each sample k (t_k = (k t_end) / N, the single run's formula): scheduled parameter changes
due at k (then the plant's ``prepare``), the measurement y_k = output(x_k) before the plant
step, the reference r_k, the law (:func:`mfcontrol.laws.intelligent.step` or
:func:`mfcontrol.laws.recursive_ip.step`, the functions the live controllers call), the
metrics fold of every kernel (:func:`mfcontrol.engine.metrics.fold_metrics`, with its
divergence test; the vectorised loop below runs its steady samples through the same
functions' pieces), then the plant advanced over [t_k, t_k + h] with the applied input held:
by the one RK4 (:mod:`mfcontrol.numerics.rk4`), the one Dormand-Prince 5(4)
(:mod:`mfcontrol.numerics.dopri45`) or the plant's exact step.

The plant comes in as the addresses of its compiled functions
(:mod:`mfcontrol.numerics.signatures`),
so this one kernel, compiled once and cached on disk, runs every plant: the converters,
the first-order plant, LTI models and your own ODE. Where the plant has it, a member
advances by its one-member step (:func:`member_step`: f and g compiled in, one call a
sample instead of five; the same arithmetic). Members (columns of the law arrays,
rows of the plant arrays) run one after another, each a single run; :func:`run` spreads
them over threads (the kernel releases the GIL).

Sweeps run in the vectorised loop (:func:`block_kernel`, chosen by :func:`loop_for`):
members in blocks of :data:`LANES`, the plant's step and output compiled over the block
(:mod:`mfcontrol.numerics.blocks`: the library's plants, LTI models and your own ODE)
or, where it has none (the adaptive integrator), each member's plant on its own
functions; the loop's elements (sensor, actuator, disturbance, substeps) around the law
lane by lane, and, past the start-up, the law (``steady_step`` of every law, the
algebraic estimator's window included) and the metrics fold, as loops over the block
that the compiler turns into vector instructions. Each member is still its single run,
bit for bit.

The paper's buck under the recursive law keeps its own tuned kernels
(:mod:`mfcontrol.engine.paper_single`, :mod:`mfcontrol.engine.paper_sweep`): state in registers and
members vectorised. Both fold the metrics with the same function, step the law with the
same function and integrate the buck with the same arithmetic.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache
from typing import Any

import numpy as np
from numba import carray, njit, types
from numba.core import config as numba_config

from .. import _jit
from ..elements import actuator, delay, disturbance, layout, noise, sensor
from ..laws import adrc, estimators, intelligent, pid, recursive_ip, reference, variational_gain
from ..numerics import blocks, dopri45, grid, rk4
from ..numerics import signatures as sig
from . import metrics as engine_metrics
from . import paper_single, trajectory

# law kinds
RECURSIVE_IP = paper_single.RECURSIVE_IP
INTELLIGENT = 1
PID = 2
ADRC = 3
# integrators
RK4 = 0
DP45 = 1
EXACT = 2
INTEGRATORS = {"rk4": RK4, "rk45": DP45, "exact": EXACT}

# trajectory rows; the law's component rows follow from T_COMP on, then the plant states
T_COMP = trajectory.T_X0


@_jit.step_jit
def _law(law_kind, cp, cs, lane, ym, r, law_dt, external, alpha):
    """The law of the member in column ``lane`` on its measurement ym (what the sensor
    delivered): returns (u, a, g, gamma): the output the metrics see (before the
    limits), the applied output, the gain and gamma (NaN for the PID and the ADRC: no
    adaptive gain)."""
    if law_kind == INTELLIGENT:
        if external:  # as the live controller writes it (engine.live)
            cs[variational_gain.ALPHA_EXT, lane] = alpha
        a = intelligent.step(cp, cs, lane, ym, r, law_dt)
        u = cs[intelligent.C_UNLIM, lane]
        gamma = cs[variational_gain.G1, lane]
        return u, a, gamma, gamma
    if law_kind == PID:
        a = pid.step(cp, cs, lane, ym, r, law_dt)
        return cs[pid.C_UNLIM, lane], a, np.nan, np.nan
    if law_kind == ADRC:
        a = adrc.step(cp, cs, lane, ym, r, law_dt)
        return cs[adrc.C_UNLIM, lane], a, np.nan, np.nan
    return recursive_ip.step(cp, cs, lane, ym, r)


@_jit.step_jit
def _sample(law_kind, cp, cs, lane, mj, S, k, t, h, y, ym, r, law_dt, external, alpha,
            a_prev, bound):
    """Sample k of the member in column ``lane`` after its output y and measurement ym:
    the divergence test on y, the law on ym, the metrics fold of y, as the vectorised
    loop runs its start-up samples and the samples with a bad measurement. Returns
    (ok, u, a, g, gamma); with ok False the member stops at this sample."""
    if not engine_metrics.measurement_ok(y, r, bound):
        # flagged before the law runs: the controller's memory ends at the last good
        # sample, as a loop of live calls would leave it
        engine_metrics.member_metrics(mj, S, lane, k, t, h, y, r, 0.0, 0.0, a_prev, 0.0)
        return False, 0.0, 0.0, 0.0, 0.0
    u, a, g, gamma = _law(law_kind, cp, cs, lane, ym, r, law_dt, external, alpha)
    ok = engine_metrics.member_metrics(mj, S, lane, k, t, h, y, r, u, a, a_prev, gamma)
    return ok, u, a, g, gamma


@_jit.step_jit
def _advance(integ, rhs, advance, t, x, u, p, h, rtol, atol, dt, w):
    """One member's plant over [t, t + h] with u held, in place, by the integrator
    ``integ``: the one RK4, the one Dormand-Prince 5(4) (``dt`` the step it carries from
    sample to sample, returned) or the plant's exact step. ``w``: scratch of
    max(5, :data:`mfcontrol.numerics.dopri45.N_WORK`) rows of the state's size."""
    if integ == RK4:
        rk4.step(rhs, t, x, u, p, h, w)
    elif integ == DP45:
        dt = dopri45.integrate(rhs, t, x, u, p, h, rtol, atol, dt, w)
    else:
        advance(t, sig.pointer(x), u, sig.pointer(p), h, x.size, p.size)
    return dt


@_jit.step_jit
def _events_at(k, j, ev_k, ev_col, ev_add, ev_val, p, lane, never):
    """Member j's scheduled changes due at sample k applied to its parameters, column
    ``lane`` of p; returns the sample of its next change after k (``never`` if none). With
    k = -1 it applies nothing and returns the first."""
    nxt = never
    for e in range(ev_col.size):
        ke = ev_k[e, j]
        if ke == k:
            c = ev_col[e]
            p[c, lane] = p[c, lane] + ev_val[e, j] if ev_add[e] else ev_val[e, j]
        elif ke > k:
            nxt = min(nxt, ke)
    return nxt


def _make_loop(fast):
    """The member loop, compiled exact or with the fast mode's flags (``fast`` only tells
    numba's cache the two apart)."""
    FAST = fast

    def member_loop(law_kind, integ, rhs, output, prepare, advance, step, n_steps, h, t_end,
                    law_dt, X, P, CP, CS, R, RP, AL, LP, ev_k, ev_col, ev_add, ev_val, S, M, tol,
                    DT, j0, j1, traj, comp_rows):
        """Members j0 .. j1-1 from their present state, for n_steps samples.

        ``X[j]``/``P[j]``: plant state/parameters of member j; ``CP[:, j]``/``CS[:, j]``:
        law parameters/state; ``R[j or 0, k]`` the reference when R has rows, else
        ``reference.value(RP, j, t)``; ``AL[j or 0, k]``, when AL has rows, the alpha of an
        external gain (written to the law's ``ALPHA_EXT`` row before it runs); event e sets
        (or adds, ``ev_add[e]``) ``ev_val[e, j]`` to ``P[j, ev_col[e]]`` at sample
        ``ev_k[e, j]``; ``LP[:, j]`` the loop's elements (rows of
        :mod:`mfcontrol.elements.layout`: the law sees the sensor's reading of y, the
        plant receives the actuator's output plus an input disturbance, over ``substeps``
        integration steps of h / substeps); ``M[:, j]`` the metrics, of the true y;
        ``DT[j]`` the adaptive integrator's carried step. When ``traj`` has n_steps columns,
        member j0's trajectory is recorded there (rows as ``trajectory.T_REF`` .. ``T_U_PLANT``,
        the CS rows ``comp_rows`` from :data:`T_COMP` on, then the states). ``step``, when
        not 0: the plant's step of one member by ``integ`` with f and g compiled in (a
        one-lane :class:`mfcontrol.numerics.blocks.Block`), called once a sample where
        the RK4 calls f four times and g once through their addresses; it returns the new
        state's output, which the next sample measures unless a scheduled change came
        between. The same arithmetic either way.
        """
        own_step = step != 0
        step = sig.as_member_step(step)
        rhs = sig.as_rhs(rhs)
        output = sig.as_output(output)
        prepare = sig.as_prepare(prepare)
        advance = sig.as_advance(advance)
        n_x = X.shape[1]
        n_p = P.shape[1]
        w = np.empty((max(5, dopri45.N_WORK), n_x))
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
        DP = LP[layout.DISTURBANCE:]
        # the delays' rings, sized for the longest delay of these members
        d_max = np.zeros(2, dtype=np.int64)
        for j in range(j0, j1):
            d_max[0] = max(d_max[0], int(LP[layout.SENSOR + sensor.DELAY, j]))
            d_max[1] = max(d_max[1], int(LP[layout.ACTUATOR + actuator.DELAY, j]))
        ring_y = np.empty(d_max[0] + 1)
        ring_u = np.empty(d_max[1] + 1)
        for j in range(j0, j1):
            for i in range(CP.shape[0]):
                cp[i, 0] = CP[i, j]
            for i in range(CS.shape[0]):
                cs[i, 0] = CS[i, j]
            for i in range(M.shape[0]):
                mj[i, 0] = M[i, j]
            x = X[j]
            p = P[j]
            s_kind = LP[layout.SENSOR + sensor.NOISE, j]
            s_std = LP[layout.SENSOR + sensor.STD, j]
            s_key = noise.seed_key(LP[layout.SENSOR + sensor.SEED, j])
            s_q = LP[layout.SENSOR + sensor.QUANTUM, j]
            s_d = int(LP[layout.SENSOR + sensor.DELAY, j])
            a_d = int(LP[layout.ACTUATOR + actuator.DELAY, j])
            rate = LP[layout.ACTUATOR + actuator.RATE, j]
            dist = DP[disturbance.KIND, j] != disturbance.NONE
            d_out = dist and DP[disturbance.AT, j] == disturbance.OUTPUT
            d_in = dist and not d_out
            sub = int(LP[layout.SUBSTEPS, j])
            hs = h / sub if sub > 1 else h  # the plant's step
            # the same test at every sample, which the processor predicts: the ideal loop
            # costs next to nothing more than before the elements existed
            acting = layout.acting(LP, j)
            y_first = 0.0
            u_act = 0.0
            prepare(sig.pointer(p), hs, n_x, n_p)
            next_ev = _events_at(-1, j, ev_k, ev_col, ev_add, ev_val, P.T, j, n_steps)
            a_prev = 0.0
            dt_carry = DT[j]
            ref_row = j if own_ref else 0
            y_next = output(sig.pointer(x), sig.pointer(p), n_x, n_p)
            for k in range(n_steps):
                t = grid.time(k, t_end, n_steps)
                if k == next_ev:
                    next_ev = _events_at(k, j, ev_k, ev_col, ev_add, ev_val, P.T, j, n_steps)
                    prepare(sig.pointer(p), hs, n_x, n_p)
                    y_next = output(sig.pointer(x), sig.pointer(p), n_x, n_p)
                y = y_next
                if d_out:
                    y = y + disturbance.value(DP, j, t)
                if use_series:
                    r = R[ref_row, k]
                else:
                    r = reference.value(RP, j, t)
                # _sample's step written out: called from here it measured 5-10% slower
                # single runs (100,000-sample DC-motor runs, interleaved with and without)
                if not engine_metrics.measurement_ok(y, r, bound):
                    engine_metrics.member_metrics(mj, S, 0, k, t, h, y, r, 0.0, 0.0, a_prev, 0.0)
                    break
                ym = y
                if acting:
                    n_a, n_b = noise.unit(s_kind, s_key, k)
                    ym = sensor.read_unit(s_kind, s_std, n_a, n_b, s_q, y)
                    if k == 0:
                        y_first = ym
                    ym = delay.delayed(ring_y, s_d, k, ym, y_first)
                alpha = AL[j if own_alpha else 0, k] if external else 0.0
                u, a, g, gamma = _law(law_kind, cp, cs, 0, ym, r, law_dt, external, alpha)
                if not engine_metrics.member_metrics(mj, S, 0, k, t, h, y, r, u, a, a_prev, gamma):
                    break
                a_prev = a
                u_plant = a
                if acting:
                    u_act = actuator.rate_limited(delay.delayed(ring_u, a_d, k, a, 0.0), u_act,
                                                  rate, h)
                    u_plant = u_act + disturbance.value(DP, j, t) if d_in else u_act
                if record and j == j0:
                    trajectory.record(traj, k, r, y, u, a, gamma, g)
                    if acting:
                        trajectory.record_io(traj, k, ym, u_plant)
                    for c in range(comp_rows.size):
                        traj[T_COMP + c, k] = cs[comp_rows[c], 0]
                    for i in range(n_x):
                        traj[t_x0 + i, k] = x[i]
                if sub == 1 and own_step:
                    y_next = step(t, sig.pointer(x), u_plant, sig.pointer(p), h,
                                  sig.pointer(w))
                elif sub == 1:
                    dt_carry = _advance(integ, rhs, advance, t, x, u_plant, p, h, rtol, atol,
                                        dt_carry, w)
                    y_next = output(sig.pointer(x), sig.pointer(p), n_x, n_p)
                else:  # at the times of the grid of h / sub (bit for bit a run at that h),
                    # an input disturbance evaluated at each of them
                    for i in range(sub):
                        ti = grid.time(k * sub + i, t_end, n_steps * sub)
                        ui = u_act + disturbance.value(DP, j, ti) if d_in else u_plant
                        if own_step:
                            y_next = step(ti, sig.pointer(x), ui, sig.pointer(p), hs,
                                          sig.pointer(w))
                        else:
                            dt_carry = _advance(integ, rhs, advance, ti, x, ui, p, hs, rtol,
                                                atol, dt_carry, w)
                    if not own_step:
                        y_next = output(sig.pointer(x), sig.pointer(p), n_x, n_p)
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
    types.int64, types.int64, types.intp, types.intp, types.intp, types.intp, types.intp,
    types.int64, types.float64, types.float64, types.float64,
    _m, _m, _m, _m, _m, _m, _m, _m, _i2, _i1, types.boolean[::1], _m, _v, _m, _v, _v,
    types.int64, types.int64, _m, _i1)


@lru_cache(maxsize=2)
def member_kernel(fast: bool = False):
    """The compiled member loop (exact IEEE arithmetic, or the fast mode's flags); loaded
    from numba's disk cache after the first compilation, which takes about 20 s."""
    return _compile(_make_loop, SIGNATURE, fast)


def _dispatcher(make, fast: bool):
    """The loop ``make(fast)`` as a dispatcher cached on disk, not compiled yet."""
    options: dict[str, Any] = dict(error_model="numpy", cache=True, nogil=True)
    if fast:
        options["fastmath"] = _jit.FASTMATH
    return njit(**options)(make(bool(fast)))


def _compile(make, signature, fast: bool):
    """The loop ``make(fast)`` compiled for ``signature`` (or loaded from the disk cache)."""
    fn = _dispatcher(make, fast)
    fn.compile(signature)
    fn.disable_compile()
    return fn


#: members a block of the vectorised loop runs side by side
LANES = blocks.LANES
#: member-samples from which a sweep compiles your ODE's block functions when they compile
#: once per process (f and g with no source file, or closures: about 1.5 to 3 s) to run
#: in the vectorised loop: about what they save there against f member by member
#: (measured on the DC motor of benchmarks/bench_engine.py, 1,024 members of 10,000
#: samples on two cores: about 0.49 -> 0.13 ms per member, some 36 ns per member-sample)
BLOCK_WORTH = 80_000_000
#: the same for block functions kept in numba's disk cache once compiled (your ODE
#: defined in a file): their compilation is paid once per machine, so a sweep of 1,024
#: members of 10,000 samples, which saves about a quarter of it in its own process,
#: compiles them for every later one
BLOCK_WORTH_KEPT = 10_000_000
#: the same while the vectorised loop itself is not compiled yet on this machine (about
#: 2 min, once: then it is in numba's disk cache)
BLOCK_WORTH_COLD = 700_000_000
#: member-samples from which the member loop compiles your ODE's one-member RK4 step (f
#: inlined; compiled once per process, about 0.5 s): about what it saves against f called
#: four times through its address (some 30 ns a sample on the DC motor of
#: benchmarks/bench_single_loop.py)
MEMBER_STEP_WORTH = 20_000_000


def member_step(member, integ: int, work: int, fast: bool) -> int:
    """The address of the plant's one-member step (``member``, a one-lane
    :class:`mfcontrol.numerics.blocks.Block`, or None) for the member loop, or 0: f and
    g through their addresses. Taken for its integrator (the RK4 or the plant's exact
    step) in exact arithmetic (the fast mode fuses the RK4's arithmetic, which the step
    does not) when it costs no compilation worth
    weighing (a library plant's, compiled once per machine, or your own ODE's compiled in
    this process already) or from :data:`MEMBER_STEP_WORTH`
    member-samples on; 0 where numba cannot compile it over f (it is not asked again)."""
    if (member is None or fast or integ not in (RK4, EXACT)
            or INTEGRATORS[member.integrator] != integ
            or member.step.failed
            or not (member.cheap or member.kept or work >= MEMBER_STEP_WORTH)):
        return 0
    try:
        return member.step.address
    except sig.COMPILE_ERRORS:
        return 0


@_jit.step_jit
def _into_lane(A, j, a, lane):
    """Column j of A into column ``lane`` of a (one member's rows, either way)."""
    for i in range(A.shape[0]):
        a[i, lane] = A[i, j]


@_jit.step_jit
def _member_of(b0, lane, nb):
    """The member in column ``lane`` of the block of nb members from member b0: a part
    block's spare lanes hold copies of member b0."""
    return b0 + lane if lane < nb else b0


@_jit.step_jit
def _keep_member(by_block, lane, j, xs, xb, cs, mj, dtc, X, CS, M, DT):
    """Member j, in column ``lane`` of a block, written back where it stopped or ended:
    its plant state (from the member-contiguous rows ``xs`` and its carried step when it
    ran on its own functions, else from the block's columns), law memory and metrics."""
    if not by_block:
        _into_lane(xs.T, lane, xb, lane)
        DT[j] = dtc[lane]
    _into_lane(xb, lane, X.T, j)
    _into_lane(cs, lane, CS, j)
    _into_lane(mj, lane, M, j)


@_jit.step_jit
def _prepare_lane(prepare, pb, ps, lane, h, n_x):
    """What member ``lane``'s plant derives from its parameters (``prepare``), as its
    single run derives it, at the start and after each of its scheduled changes: column
    ``lane`` of pb into row ``lane`` of ps, prepared there (where the plant's own
    functions read it), and back into the column (where the block functions read it)."""
    n_p = pb.shape[0]
    for i in range(n_p):
        ps[lane, i] = pb[i, lane]
    prepare(sig.pointer(ps[lane]), h, n_x, n_p)
    for i in range(n_p):
        pb[i, lane] = ps[lane, i]


@_jit.step_jit
def _prepare_lanes(prepare, pb, ps, raw, h, n_x):
    """:func:`_prepare_lane` for every lane of a block, where a lane whose parameters
    are those of the lane before it (bit for bit, :func:`_same_bits`: a sweep's
    consecutive members mostly share their plant) takes that lane's prepared ones
    instead: the same values, without deriving them again (the lti model's zero-order
    hold is a matrix exponential, about 1.5 us a member). ``raw``: room for a lane's
    parameters before they are prepared."""
    n_p = pb.shape[0]
    for lane in range(LANES):
        same = lane > 0
        for i in range(n_p):
            same = same and _same_bits(pb[i, lane], raw[i])
        for i in range(n_p):
            raw[i] = pb[i, lane]
        if same:
            for i in range(n_p):
                pb[i, lane] = pb[i, lane - 1]
                ps[lane, i] = ps[lane - 1, i]
        else:
            _prepare_lane(prepare, pb, ps, lane, h, n_x)


# Rows of a block's law buffer D (LANES members a row). Every row the vectorised law and
# metrics fold touch lies a compile-time constant distance from the buffer's start, so
# the compiler needs no run-time alias checks to vectorise the loops over members.
_CP0 = 0  # the law's parameters, any law's rows
_N_CP = max(intelligent.N_PARAMS, recursive_ip.N_PARAMS, pid.N_PARAMS, adrc.N_PARAMS)
_Y = _CP0 + _N_CP  # y_k of every member (the plant's output, with an output disturbance)
_R = _Y + 1  # r_k
_U = _R + 1  # the law's applied output at sample k
_UM = _U + 1  # the law's output as the metrics see it (u_k before the limits)
_G = _UM + 1  # gamma_k
_AP = _G + 1  # the input applied at the previous sample
_YM = _AP + 1  # what the law reads: the sensor's reading of y_k (y_k without a sensor)
_UP = _YM + 1  # what the plant receives over the coming step (after the actuator)
_SY = _UP + 1  # the algebraic estimator's window sums (estimators.sums) of y ...
_SU = _SY + 1  # ... and of u
_YO = _SU + 1  # the samples leaving the estimator's window: y ...
_UO = _YO + 1  # ... and u
# a member's constant gain as the intelligent law takes it (intelligent.fixed_gain),
# computed once a block: alpha and the algebraic estimator's two coefficients
_ALPHA = _UO + 1
_CY = _ALPHA + 1
_CU = _CY + 1
_M0 = _CU + 1  # the metrics, in the rows of engine.metrics
_CS0 = _M0 + engine_metrics.N_METRICS  # the law's state (as many rows as it has)
_DIVERGED = _M0 + engine_metrics.M_DIVERGED


@_jit.step_jit
def _law_out(D, i, applied, u, gamma):
    """Member i's law outputs into the block's rows: the applied input, the output the
    metrics see, gamma. Returns 1 if a live member's output is not finite."""
    D[_U, i] = applied
    D[_UM, i] = u
    D[_G, i] = gamma
    return 1 if D[_DIVERGED, i] == 0.0 and not np.isfinite(u) else 0


@_jit.step_jit
def _law_views(D, n_cp, n_cs):
    """The law's parameter and state rows of a block as arrays of their own, at constant
    distances from D's start: a slice of D would clamp its bounds to D's run-time size,
    which hides the distances from the compiler (the loop then does not vectorise:
    measured 18 against 7 ns per member-sample)."""
    base = sig.pointer(D)
    return (carray(sig.offset(base, _CP0 * LANES), (n_cp, LANES)),
            carray(sig.offset(base, _CS0 * LANES), (n_cs, LANES)))


@_jit.step_jit
def _moments_lanes(D, half, par_in, par_out, n_y, n_u):
    """:func:`mfcontrol.laws.estimators.moments_push` for every member of a block, the
    leaving and entering samples in rows ``_YO``, ``_UO``, ``_YM`` and the law's U1, the
    parities and the moment counts literals: every row at a constant distance, so the
    loop vectorises (measured 26 against 3 ns per member-sample, with the ring's moves
    apart)."""
    _, cs = _law_views(D, intelligent.N_PARAMS, intelligent.EST_BASE + estimators.RING)
    for i in range(LANES):
        estimators.moments_push(cs, i, intelligent.EST_BASE, half, par_in, par_out,
                                D[_YO, i], D[_UO, i], D[_YM, i], cs[intelligent.U1, i], n_y,
                                n_u)


@_jit.step_jit
def _moments_parities(D, half, par_in, par_out, n_y, n_u):
    """:func:`_moments_lanes` with the parities made literals (n_y, n_u: literals)."""
    if par_in == 0 and par_out == 0:
        _moments_lanes(D, half, 0, 0, n_y, n_u)
    elif par_in == 0:
        _moments_lanes(D, half, 0, 1, n_y, n_u)
    elif par_out == 0:
        _moments_lanes(D, half, 1, 0, n_y, n_u)
    else:
        _moments_lanes(D, half, 1, 1, n_y, n_u)


#: the rows of the law state's view in :func:`_estimator_lanes`: those of the longest
#: window, a constant, not the block's own: the view's row count is what a negative row
#: index wraps by, and with it known the compiler keeps the ring's rows at distances it
#: can see from the block's other rows and vectorises the loops (measured 8.1 against
#: 5.2 ns per member-sample, one thread)
_EST_VIEW_ROWS = intelligent.EST_BASE + estimators.n_state(estimators.MAX_WINDOW)


@_jit.step_jit
def _estimator_lanes(D, M, order, kernel, live):
    """The algebraic estimator's sample for every member of a block, all at the same
    sample with the same window M and model order (what :func:`intelligent.step` does
    first: :func:`mfcontrol.laws.estimators.push`): y_k (the measurement) and the
    applied u_{k-1} pushed, then the window's sums into rows ``_SY``, ``_SU`` (NaN until
    the window is full). The ring's slots are computed once for the block, from lane
    ``live``, a live member's (a member that stopped before its law ran at some sample
    pushed one sample fewer); the ring's moves, the moments, the count, the resync every
    M samples and the sums run as loops of their own over the members: O(1) per
    member-sample."""
    cp, cs = _law_views(D, intelligent.N_PARAMS, _EST_VIEW_ROWS)
    base = intelligent.EST_BASE
    n = int(cs[base + estimators.COUNT, live])
    slot, after = estimators.slots(n, M)
    y_row = base + estimators.RING + slot
    u_row = base + estimators.RING + M + 1
    for i in range(LANES):  # push_at's reads and writes of the ring
        D[_YO, i] = cs[y_row, i]
        D[_UO, i] = cs[u_row + after, i]
        cs[y_row, i] = D[_YM, i]
        cs[u_row + slot, i] = cs[intelligent.U1, i]
    half = 0.5 * M
    par_in, par_out = n % 2, (n + M + 1) % 2
    # the moments the order and kernel carry, constants in each branch
    moments = int(estimators.moment_order(float(order), kernel))
    if moments == 1:
        n_y, n_u = estimators.moments_of(1)
        _moments_parities(D, half, par_in, par_out, n_y, n_u)
    else:
        n_y, n_u = estimators.moments_of(2)
        _moments_parities(D, half, par_in, par_out, n_y, n_u)
    count = estimators.counted(n, M)
    for i in range(LANES):
        cs[base + estimators.COUNT, i] = count
    if estimators.resync_due(n, M):
        estimators.resync_members(cs, 0, LANES, base, M, moments)
    full, oldest, newest, parity = estimators.window(cs, live, base, M)
    # the kernel a literal in each loop (the block's members share it)
    if full and kernel == estimators.HELD:
        for i in range(LANES):
            D[_SY, i], D[_SU, i] = estimators.sums_at(cs, i, base, M, order, oldest, newest,
                                                      parity, estimators.HELD, cp)
    elif full and kernel == estimators.DELAY_REDUCED:
        # each member its own (kappa, mu, lag): its coefficient rows
        for i in range(LANES):
            D[_SY, i], D[_SU, i] = estimators.sums_at(
                cs, i, base, M, order, oldest, newest, parity, estimators.DELAY_REDUCED, cp)
    elif full:
        for i in range(LANES):
            D[_SY, i], D[_SU, i] = estimators.sums_at(cs, i, base, M, order, oldest, newest,
                                                      parity, estimators.TRAPEZOID, cp)
    else:
        for i in range(LANES):
            D[_SY, i] = np.nan
            D[_SU, i] = np.nan


@_jit.step_jit
def _intelligent_lanes(D, dt, simple, algebraic, fixed):
    """A sample past the start-up of the intelligent law
    (:func:`mfcontrol.laws.intelligent.steady_step`, ``simple``, ``algebraic`` and
    ``fixed`` as it takes them: pass literals; with ``algebraic``,
    :func:`_estimator_lanes` ran first; with ``fixed``, every member's constant gain is
    in rows ``_ALPHA``, ``_CY``, ``_CU``), for every member of a block at once: the loop
    vectorises. Members whose measurement is bad must not be in the block (the caller
    runs such a sample member by member). Returns how many live members have a
    non-finite output (they stop at this sample)."""
    cp, cs = _law_views(D, intelligent.N_PARAMS, intelligent.EST_BASE)
    n_bad = 0
    for i in range(LANES):
        u, u_unlim, gamma = intelligent.steady_step(cp, cs, i, D[_YM, i], D[_R, i], dt,
                                                    simple, algebraic, D[_SY, i], D[_SU, i],
                                                    fixed, D[_ALPHA, i], D[_CY, i],
                                                    D[_CU, i])
        n_bad += _law_out(D, i, u, u_unlim, gamma)
    return n_bad


@_jit.step_jit
def _intelligent_gain(D, dt, simple, algebraic, fixed):
    """:func:`_intelligent_lanes` with ``fixed`` a literal (``simple``, ``algebraic``:
    literals)."""
    if fixed:
        return _intelligent_lanes(D, dt, simple, algebraic, True)
    return _intelligent_lanes(D, dt, simple, algebraic, False)


@_jit.step_jit
def _recursive_lanes(D):
    """As :func:`_intelligent_lanes`, for the paper's recursive law
    (:func:`mfcontrol.laws.recursive_ip.steady_step`)."""
    cp, cs = _law_views(D, recursive_ip.N_PARAMS, recursive_ip.N_STATE)
    n_bad = 0
    for i in range(LANES):
        u, applied, _, gamma = recursive_ip.steady_step(cp, cs, i, D[_YM, i], D[_R, i])
        n_bad += _law_out(D, i, applied, u, gamma)
    return n_bad


@_jit.step_jit
def _pid_lanes(D, dt):
    """As :func:`_intelligent_lanes`, for the PID (:func:`mfcontrol.laws.pid.steady_step`;
    no adaptive gain: gamma NaN)."""
    cp, cs = _law_views(D, pid.N_PARAMS, pid.N_STATE)
    n_bad = 0
    for i in range(LANES):
        u, v = pid.steady_step(cp, cs, i, D[_YM, i], D[_R, i], dt)
        n_bad += _law_out(D, i, u, v, np.nan)
    return n_bad


@_jit.step_jit
def _adrc_lanes(D, dt):
    """As :func:`_intelligent_lanes`, for the ADRC (:func:`mfcontrol.laws.adrc.steady_step`;
    no adaptive gain: gamma NaN)."""
    cp, cs = _law_views(D, adrc.N_PARAMS, adrc.N_STATE)
    n_bad = 0
    for i in range(LANES):
        u, v = adrc.steady_step(cp, cs, i, D[_YM, i], D[_R, i], dt)
        n_bad += _law_out(D, i, u, v, np.nan)
    return n_bad


@_jit.step_jit
def _sense_lanes(D, acting, sensor_p, keys, shared, shared_key, k, ring_y, y_first,
                 delays, d_shared, quantised, drawn):
    """What the law reads, for every member of a block: y_k through its sensor
    (:func:`mfcontrol.elements.sensor.read`, then its delay) where an element acts on
    its loop (``acting``), y_k itself elsewhere, into row ``_YM``. ``sensor_p``: the
    block's sensor rows (:mod:`mfcontrol.elements.sensor`), a column per member;
    ``keys`` each member's noise :func:`~mfcontrol.elements.noise.seed_key`; ``shared``
    the noise kind of a block whose noisy members all have that kind and the seed whose
    key is ``shared_key`` (a sweep's, unless it sweeps the seed), -1 otherwise
    (:func:`_block_noise`): its draws are made once for the block, each member scaling
    them by its standard deviation (the hash and the Box-Muller transform do not
    vectorise: about 12 ns a member-sample).
    ``ring_y`` the block's delay ring (:func:`mfcontrol.elements.delay.delayed_lane`),
    run when some member has a delay (``delays``); ``d_shared`` the delay of every
    member of the block, or -1 where they differ (:func:`_block_delay`). Three loops,
    not one: each touches few arrays, so the compiler vectorises the first (one loop
    over the rings, the reading and the first reading measured 53 against 10 ns per
    member-sample). ``quantised``: some member of the block quantises. ``drawn``: the
    shared noise's unit factors at every sample (:func:`_draw_series`), or no columns."""
    if quantised:
        _readings(D, acting, sensor_p, keys, shared, shared_key, k, True, drawn)
    else:
        _readings(D, acting, sensor_p, keys, shared, shared_key, k, False, drawn)
    if k == 0:
        for lane in range(LANES):
            y_first[lane] = D[_YM, lane]
    if delays:  # a member without a delay (one without elements too) gets its reading back
        slot = k % ring_y.shape[0]
        if d_shared > 0:
            into, out = _ring_rows(ring_y, slot, d_shared)
            for lane in range(LANES):
                D[_YM, lane] = delay.delayed_rows(into, out, lane, d_shared, k, D[_YM, lane],
                                                  y_first[lane])
        elif d_shared < 0:
            for lane in range(LANES):
                D[_YM, lane] = delay.delayed_lane(
                    ring_y, lane, int(sensor_p[sensor.DELAY, lane]), slot, k, D[_YM, lane],
                    y_first[lane])


@_jit.step_jit
def _readings(D, acting, sensor_p, keys, shared, shared_key, k, quantised, drawn):
    """The sensors' readings of y_k before their delays (:func:`_sensed`), the noise
    drawn once for the block where its members share it (``shared`` >= 0), or read from
    ``drawn`` where it has columns. ``quantised`` (a literal): some member quantises;
    without, the loop has no quantisation (whose division a loop over members computes
    for every member)."""
    if shared >= 0.0:
        if drawn.shape[1] > 0:
            a0, b0 = drawn[0, k], drawn[1, k]
        else:
            a0, b0 = noise.unit(shared, shared_key, k)
        for lane in range(LANES):
            _sensed(D, acting, sensor_p, lane, a0, b0, quantised)
    else:
        for lane in range(LANES):
            a, b = noise.unit(sensor_p[sensor.NOISE, lane], keys[lane], k)
            _sensed(D, acting, sensor_p, lane, a, b, quantised)


@_jit.step_jit
def _sensed(D, acting, sensor_p, lane, a, b, quantised):
    """Member ``lane``'s reading of y_k (row ``_Y``) with its noise's unit factors a, b
    (:func:`mfcontrol.elements.sensor.read_unit`) into row ``_YM`` where an element acts
    on its loop (y_k elsewhere); ``quantised`` as :func:`_readings` takes it."""
    y = D[_Y, lane]
    quantum = sensor_p[sensor.QUANTUM, lane] if quantised else 0.0
    ym = sensor.read_unit(sensor_p[sensor.NOISE, lane], sensor_p[sensor.STD, lane], a, b,
                          quantum, y)
    D[_YM, lane] = ym if acting[lane] else y


#: the longest run whose shared noise is drawn ahead (:func:`_draw_series`: 16 bytes a
#: sample); a longer one draws it in each block
SERIES_MAX = 1 << 20


@_jit.step_jit
def _draw_series(drawn, kind, key):
    """The unit factors (:func:`mfcontrol.elements.noise.unit`) of noise ``kind`` with
    seed key ``key`` at every sample into ``drawn`` (2 rows): drawn once for every
    block that shares them (a sweep's one seed), not once a block (a hash, a log and a
    cosine a sample: about 0.7 ns a member-sample in a block of 64)."""
    for k in range(drawn.shape[1]):
        drawn[0, k], drawn[1, k] = noise.unit(kind, key, k)


@_jit.step_jit
def _block_noise(sensor_p, keys):
    """(kind, seed key) of the noise every noisy member of a block draws when they share
    a kind and a seed (their draws are then the same; kind NONE without noisy members),
    (-1, key) where they differ."""
    kind0 = noise.NONE
    key0 = keys[0]
    for lane in range(LANES):
        kind = sensor_p[sensor.NOISE, lane]
        if kind == noise.NONE:
            continue
        if kind0 == noise.NONE:
            kind0, key0 = kind, keys[lane]
        elif kind != kind0 or keys[lane] != key0:
            return -1.0, key0
    return kind0, key0


@_jit.step_jit
def _actuate_lanes(D, acting, actuator_p, d_in, DP, members, ring_u, u_act, d_shared, any_in,
                   d_shared_column, dval, k, t, h):
    """What the plant receives, for every member of a block: the law's applied output
    through its actuator (delay, then rate limit) plus an input disturbance where an
    element acts on its loop, the output itself elsewhere, into row ``_UP``; ``u_act``
    keeps each actuator's output. ``members[lane]``: the member whose disturbance
    column of DP the lane reads; ``d_shared`` as :func:`_sense_lanes` takes it;
    ``any_in``, ``d_shared_column`` and ``dval`` whether some member has an input
    disturbance, whether they share it and room for its values
    (:func:`_disturbance_lanes`). One loop over the members per delay form, the
    disturbance added in it by selects, written out in each (a loop of its own for the
    disturbance, whose store only some members take, measured 0.80 against 0.67 ns a
    member-sample, one thread; the same selects in a helper function that numba inlines
    measured 15 ns, so they are written out in each loop)."""
    if any_in:
        _disturbance_lanes(DP, members, d_shared_column, t, dval)
    if d_shared > 0:
        into, out = _ring_rows(ring_u, k % ring_u.shape[0], d_shared)
        for lane in range(LANES):
            a = D[_U, lane]
            w = delay.delayed_rows(into, out, lane, d_shared, k, a, 0.0)
            u = actuator.rate_limited(w, u_act[lane], actuator_p[actuator.RATE, lane], h)
            u_act[lane] = u
            v = u + dval[lane] if acting[lane] & d_in[lane] else u  # dval read if any_in
            D[_UP, lane] = v if acting[lane] else a
    elif d_shared == 0:  # no delay: the ring is not read
        for lane in range(LANES):
            a = D[_U, lane]
            u = actuator.rate_limited(a, u_act[lane], actuator_p[actuator.RATE, lane], h)
            u_act[lane] = u
            v = u + dval[lane] if acting[lane] & d_in[lane] else u  # dval read if any_in
            D[_UP, lane] = v if acting[lane] else a
    else:
        for lane in range(LANES):
            a = D[_U, lane]
            w = delay.delayed_lane(ring_u, lane, int(actuator_p[actuator.DELAY, lane]),
                                   k % ring_u.shape[0], k, a, 0.0)
            u = actuator.rate_limited(w, u_act[lane], actuator_p[actuator.RATE, lane], h)
            u_act[lane] = u
            v = u + dval[lane] if acting[lane] & d_in[lane] else u  # dval read if any_in
            D[_UP, lane] = v if acting[lane] else a


@_jit.step_jit
def _disturbance_lanes(DP, members, shared, t, dval):
    """d(t) of every member of a block (:func:`mfcontrol.elements.disturbance.value`;
    ``members[lane]``: the member whose column of DP the lane reads) into ``dval``:
    evaluated once when the block's members have the same disturbance (``shared``: a
    sweep's, unless it sweeps the disturbance), member by member otherwise (a loop that
    does not vectorise: a table's search)."""
    if shared:
        v = disturbance.value(DP, members[0], t)
        for lane in range(LANES):
            dval[lane] = v
    else:
        for lane in range(LANES):
            dval[lane] = disturbance.value(DP, members[lane], t)


@_jit.step_jit
def _same_bits(a, b):
    """Whether a and b are the same number: equal with the same sign (+0 and -0 give
    results of different signs), or both NaN."""
    return (a == b and math.copysign(1.0, a) == math.copysign(1.0, b)) or (a != a and b != b)


@_jit.step_jit
def _same_columns(A, members):
    """Whether the block's members (``members[lane]``) have the same column of A, bit
    for bit (:func:`_same_bits`)."""
    j0 = members[0]
    for lane in range(LANES):
        j = members[lane]
        for i in range(A.shape[0]):
            if not _same_bits(A[i, j], A[i, j0]):
                return False
    return True


@_jit.step_jit
def _ring_rows(ring, slot, d):
    """A block's delay ring's row ``slot`` (where sample k goes, ``slot`` = k % its
    rows) and the row of sample k - d, as arrays of their own
    (:func:`mfcontrol.elements.delay.delayed_rows`)."""
    base = sig.pointer(ring)
    back = delay.back_slot(ring.shape[0], slot, d)
    return (carray(sig.offset(base, slot * LANES), (LANES,)),
            carray(sig.offset(base, back * LANES), (LANES,)))


@_jit.step_jit
def _block_delay(rows, row):
    """The delay (row ``row`` of an element's rows) of every member of a block, or -1
    where they differ."""
    d = int(rows[row, 0])
    for lane in range(LANES):
        if int(rows[row, lane]) != d:
            return -1
    return d


@_jit.step_jit
def _accumulate_lane(D, i, k, t, h, a, settle, final_start):
    """Sample k folded into lane i's sums and maxima of a block
    (:func:`mfcontrol.engine.metrics.accumulate`), its sample count and final gamma; a,
    the applied input, kept in row ``_AP`` for the next sample's."""
    M, EM = _M0, engine_metrics
    (D[M + EM.M_IAE, i], D[M + EM.M_ISE, i], D[M + EM.M_ITAE, i],
     D[M + EM.M_MAX_E_SETTLED, i], D[M + EM.M_MAX_E_FINAL, i], D[M + EM.M_MAX_ABS_R, i],
     D[M + EM.M_TV, i]) = EM.accumulate(
        D[M + EM.M_IAE, i], D[M + EM.M_ISE, i], D[M + EM.M_ITAE, i],
        D[M + EM.M_MAX_E_SETTLED, i], D[M + EM.M_MAX_E_FINAL, i], D[M + EM.M_MAX_ABS_R, i],
        D[M + EM.M_TV, i], k, t, h, D[_Y, i], D[_R, i], a, D[_AP, i], settle, final_start)
    D[M + EM.M_N_SAMPLES, i] = k + 1.0
    D[M + EM.M_FINAL_GAMMA, i] = D[_G, i]
    D[_AP, i] = a


@_jit.step_jit
def _fold_windows(D, k, t, h, settle, final_start, in_step, in_final, after_load):
    """:func:`_fold_lanes` for a block whose members make the same tests on the loop
    metrics' windows (:func:`_windows_shared`). The
    tests of :func:`mfcontrol.engine.metrics.loop_sums` on the step window, the
    stability window and the load step are made once for the block at this sample
    (``in_step``, ``in_final``, ``after_load``), and a sum outside its window is left
    alone, not computed and selected away: the values ``loop_sums`` gives. Each window's
    sums are a loop of their own (a loop that touches few rows vectorises). Most samples
    of a run lie in one window: past the load step alone, measured 1.0 against 2.2 ns
    per member-sample, one thread."""
    M, EM = _M0, engine_metrics
    for i in range(LANES):
        a = D[_U, i]
        _accumulate_lane(D, i, k, t, h, a, settle, final_start)
        D[M + EM.M_ENERGY, i] = EM.energy_sum(D[M + EM.M_ENERGY, i], a, h)
    if in_step:
        for i in range(LANES):
            (D[M + EM.M_PEAK, i], D[M + EM.M_T10, i], D[M + EM.M_T90, i],
             D[M + EM.M_T_IN, i]) = EM.step_response(
                D[M + EM.M_PEAK, i], D[M + EM.M_T10, i], D[M + EM.M_T90, i],
                D[M + EM.M_T_IN, i], t, h, D[_Y, i], D[M + EM.M_STEP_FROM, i],
                D[M + EM.M_STEP_TO, i])
            D[M + EM.M_T_LAST, i] = t
    if in_final:
        for i in range(LANES):
            D[M + EM.M_E_FINAL, i], D[M + EM.M_N_FINAL, i] = EM.final_sum(
                D[M + EM.M_E_FINAL, i], D[M + EM.M_N_FINAL, i], D[_Y, i], D[_R, i])
    if after_load:
        for i in range(LANES):
            D[M + EM.M_IAE_LOAD, i] = EM.load_sum(D[M + EM.M_IAE_LOAD, i], h, D[_Y, i],
                                                  D[_R, i])


@_jit.step_jit
def _windows_shared(mj):
    """Whether every lane of a block makes the same tests on the loop metrics' windows
    (:func:`mfcontrol.engine.metrics.in_step_window`, ``t >= load_t0``): the same step
    time and load step time, bit for bit (:func:`_same_bits`), and a step or none
    alike. What the step goes from and to may differ: each lane reads its own."""
    EM = engine_metrics
    for lane in range(LANES):
        if not (_same_bits(mj[EM.M_STEP_T0, lane], mj[EM.M_STEP_T0, 0])
                and _same_bits(mj[EM.M_LOAD_T0, lane], mj[EM.M_LOAD_T0, 0])
                and (mj[EM.M_STEP_TO, lane] == mj[EM.M_STEP_TO, lane])
                == (mj[EM.M_STEP_TO, 0] == mj[EM.M_STEP_TO, 0])):
            return False
    return True


@_jit.step_jit
def _fold_lanes(D, k, t, h, settle, final_start):
    """Sample k folded into the metrics of every member of a block, none of which went
    bad at it: :func:`mfcontrol.engine.metrics.fold_metrics` for a live member whose
    sample passes the divergence test is :func:`~mfcontrol.engine.metrics.accumulate`,
    the sample count and the final gamma, and so is this loop, with no select on a
    member's state (which the compiler would turn into masked stores, microcoded and
    slow on AMD cores: measured 9.8 against 1.7 ns per member-sample). A stopped member's
    rows take garbage: the block kept its metrics when it stopped."""
    M, EM = _M0, engine_metrics
    for i in range(LANES):
        a = D[_U, i]
        _accumulate_lane(D, i, k, t, h, a, settle, final_start)
        (D[M + EM.M_ENERGY, i], D[M + EM.M_PEAK, i], D[M + EM.M_T10, i], D[M + EM.M_T90, i],
         D[M + EM.M_T_IN, i], D[M + EM.M_T_LAST, i], D[M + EM.M_E_FINAL, i],
         D[M + EM.M_N_FINAL, i], D[M + EM.M_IAE_LOAD, i]) = EM.loop_sums(
            D[M + EM.M_ENERGY, i], D[M + EM.M_PEAK, i], D[M + EM.M_T10, i], D[M + EM.M_T90, i],
            D[M + EM.M_T_IN, i], D[M + EM.M_T_LAST, i], D[M + EM.M_E_FINAL, i],
            D[M + EM.M_N_FINAL, i], D[M + EM.M_IAE_LOAD, i], t, h, D[_Y, i], D[_R, i], a,
            D[M + EM.M_STEP_T0, i], D[M + EM.M_STEP_FROM, i], D[M + EM.M_STEP_TO, i],
            D[M + EM.M_LOAD_T0, i], final_start)


def _make_block_loop(fast):
    """The vectorised member loop (exact arithmetic only: ``fast`` is not read)."""

    def block_loop(law_kind, integ, step, output, rhs, measured, prepare, advance, n_steps,
                   h, t_end, law_dt, X, P, CP, CS, R, RP, AL, LP, ev_k, ev_col, ev_add,
                   ev_val, S, M, tol, DT, j0, j1):
        """Members j0 .. j1-1, :data:`LANES` at a time, for n_steps samples; the arrays
        and the plant's functions (``rhs`` .. ``advance``) as :func:`member_loop` takes
        them. With the plant's block functions (``step``, ``output``: addresses, not 0;
        :mod:`mfcontrol.numerics.blocks`), a block's states and parameters are laid
        out member-contiguous and advanced by them, the plant's functions compiled over
        the members into vector instructions; with 0, each member's plant runs on its own
        functions, by the integrator ``integ``, as in its single run. Either way what
        ``prepare`` derives is derived per member, at the start and after its changes.
        The loop's elements (``LP``: sensor, actuator, disturbance; one number of
        substeps for every member) act around the law as in :func:`member_loop`, lane
        by lane. Once past its start-up samples the law (any law; the algebraic
        estimator's window when every member of the block has the same) and the
        metrics fold run over the members as one loop, vectorised; the start-up
        samples and a sample on which a member's measurement is bad run member by
        member (:func:`_sample`), and so does a block whose members are not all at the
        same law sample, mix estimators or windows, or hold a member that came in
        stopped. Each member is its single run, bit for bit. No trajectory. Returns how
        many block-samples ran with the law vectorised."""
        by_block = step != 0
        step = sig.as_block_step(step)
        output = sig.as_block_output(output)
        rhs = sig.as_rhs(rhs)
        measured = sig.as_output(measured)
        prepare = sig.as_prepare(prepare)
        advance = sig.as_advance(advance)
        rtol, atol = tol[0], tol[1]
        lanes = LANES
        n_x = X.shape[1]
        n_p = P.shape[1]
        n_cp, n_cs = CP.shape[0], CS.shape[0]
        own_ref = R.shape[0] > 1
        use_series = R.shape[0] > 0
        own_alpha = AL.shape[0] > 1
        external = AL.shape[0] > 0
        settle = S[engine_metrics.S_SETTLE]
        final_start = S[engine_metrics.S_FINAL_START]
        bound = S[engine_metrics.S_DIVERGE_ABOVE]
        if law_kind == INTELLIGENT:
            steady = intelligent.STEADY
        elif law_kind == PID:
            steady = pid.STEADY
        elif law_kind == ADRC:
            steady = adrc.STEADY
        else:
            steady = recursive_ip.STEADY
        if law_kind == INTELLIGENT:
            k_row = intelligent.K
        elif law_kind == PID:
            k_row = pid.K
        elif law_kind == ADRC:
            k_row = adrc.K
        else:
            k_row = recursive_ip.K
        # one number of substeps for every member (the caller's condition): the plant
        # steps over the block at the times of the grid of h / sub
        sub = int(LP[layout.SUBSTEPS, j0])
        hs = h / sub if sub > 1 else h
        DP = LP[layout.DISTURBANCE:]
        # the block's arrays are views of raw memory (carray): arrays with a reference
        # count would be counted up and down at every call of the law and the metrics
        # fold (atomic operations; measured 0.55 against 0.21 ms per member, when the
        # law ran member by member)
        n_law = _CS0 + n_cs
        n_w = max(5, dopri45.N_WORK)
        buf = np.zeros(lanes * (n_law + 7 * n_x + 2 * n_p) + n_w * n_x)
        base = sig.pointer(buf)
        D = carray(base, (n_law, lanes))
        cp = carray(sig.offset(base, lanes * _CP0), (n_cp, lanes))
        cs = carray(sig.offset(base, lanes * _CS0), (n_cs, lanes))
        mj = carray(sig.offset(base, lanes * _M0), (engine_metrics.N_METRICS, lanes))
        yb = sig.offset(base, lanes * _Y)
        up = sig.offset(base, lanes * _UP)
        xp = sig.offset(base, lanes * n_law)
        pp = sig.offset(base, lanes * (n_law + n_x))
        wp = sig.offset(base, lanes * (n_law + n_x + n_p))
        xb = carray(xp, (n_x, lanes))
        pb = carray(pp, (n_p, lanes))
        # without block functions: each member's state and parameters (with what its
        # prepare derives) contiguous, for its own functions, and their scratch
        xsp = sig.offset(wp, lanes * 5 * n_x)
        psp = sig.offset(wp, lanes * 6 * n_x)
        xs = carray(xsp, (lanes, n_x))
        ps = carray(psp, (lanes, n_p))
        ws = carray(sig.offset(wp, lanes * (6 * n_x + n_p)), (n_w, n_x))
        dtc = np.zeros(lanes)
        raw = np.zeros(n_p)  # a lane's parameters before prepare derives from them
        alive = np.zeros(lanes, dtype=np.bool_)
        next_ev = np.zeros(lanes, dtype=np.int64)
        # the loop's elements, a column per lane, and the delays' rings, sized for the
        # longest delay of these members
        acting = np.zeros(lanes, dtype=np.bool_)
        d_in = np.zeros(lanes, dtype=np.bool_)
        d_out = np.zeros(lanes, dtype=np.bool_)
        members = np.zeros(lanes, dtype=np.int64)
        sensor_p = np.zeros((sensor.N_PARAMS, lanes))
        actuator_p = np.zeros((actuator.N_PARAMS, lanes))
        y_first = np.zeros(lanes)
        u_act = np.zeros(lanes)
        keys = np.zeros(lanes, dtype=np.uint64)
        dval = np.zeros(lanes)
        d_y = 0
        d_u = 0
        for j in range(j0, j1):
            d_y = max(d_y, int(LP[layout.SENSOR + sensor.DELAY, j]))
            d_u = max(d_u, int(LP[layout.ACTUATOR + actuator.DELAY, j]))
        ring_y = np.zeros((d_y + 1, lanes))
        # the noise the blocks share, drawn for the first block that has it
        drawn = np.zeros((2, n_steps if n_steps <= SERIES_MAX else 0))
        drawn_kind = -1.0
        drawn_key = np.uint64(0)
        no_series = np.zeros((2, 0))
        ring_u = np.zeros((d_u + 1, lanes))
        n_vector = 0
        for b0 in range(j0, j1, lanes):
            nb = min(lanes, j1 - b0)
            any_acting = False
            any_in = False
            any_out = False
            for lane in range(lanes):
                j = _member_of(b0, lane, nb)
                _into_lane(X.T, j, xb, lane)
                _into_lane(P.T, j, pb, lane)
                _into_lane(CP, j, cp, lane)
                _into_lane(CS, j, cs, lane)
                _into_lane(M, j, mj, lane)
                alive[lane] = lane < nb
                if lane >= nb:  # never folded as a live member
                    D[_DIVERGED, lane] = 1.0
                D[_AP, lane] = 0.0
                D[_U, lane] = 0.0
                D[_UP, lane] = 0.0
                next_ev[lane] = _events_at(-1, j, ev_k, ev_col, ev_add, ev_val, pb, lane,
                                           n_steps)
                members[lane] = j
                acting[lane] = layout.acting(LP, j)
                dist = DP[disturbance.KIND, j] != disturbance.NONE
                d_out[lane] = dist and DP[disturbance.AT, j] == disturbance.OUTPUT
                d_in[lane] = dist and not d_out[lane]
                any_acting |= acting[lane]
                any_in |= d_in[lane]
                any_out |= d_out[lane]
                for i in range(sensor.N_PARAMS):
                    sensor_p[i, lane] = LP[layout.SENSOR + i, j]
                for i in range(actuator.N_PARAMS):
                    actuator_p[i, lane] = LP[layout.ACTUATOR + i, j]
                u_act[lane] = 0.0
                y_first[lane] = 0.0
                keys[lane] = noise.seed_key(sensor_p[sensor.SEED, lane])
            # what the block's members share is computed once a sample
            shared_noise, shared_key = _block_noise(sensor_p, keys)
            if any_acting and shared_noise > noise.NONE and drawn.shape[1] > 0 and (
                    shared_noise != drawn_kind or shared_key != drawn_key):
                _draw_series(drawn, shared_noise, shared_key)
                drawn_kind, drawn_key = shared_noise, shared_key
            series = (drawn if shared_noise == drawn_kind and shared_key == drawn_key
                      else no_series)
            dist_shared = _same_columns(DP, members)
            y_shared = _block_delay(sensor_p, sensor.DELAY)
            quantised = False
            for lane in range(lanes):
                quantised |= sensor_p[sensor.QUANTUM, lane] > 0.0
            u_shared = _block_delay(actuator_p, actuator.DELAY)
            _prepare_lanes(prepare, pb, ps, raw, hs, n_x)
            for lane in range(lanes):
                if not by_block:
                    _into_lane(xb, lane, xs.T, lane)
                    dtc[lane] = DT[_member_of(b0, lane, nb)]
            n_alive = nb
            # the vectorised law needs every member at the same law sample (a sweep's
            # members start together) and, for the intelligent law, one estimator (the
            # algebraic one with one window and model order: its ring's slots are the
            # block's)
            law_k0 = cs[k_row, 0]
            lanes_law = True
            simple = True
            algebraic = False
            m_win = 0
            order = 1
            kernel = estimators.TRAPEZOID
            block_steady = steady
            if law_kind == INTELLIGENT:
                algebraic = cp[intelligent.EST, 0] == intelligent.ALGEBRAIC
                m_win = int(cp[intelligent.M_WIN, 0])
                order = int(cp[intelligent.N_ORDER, 0])
                kernel = cp[intelligent.KERNEL, 0]
                # past the start's hold (the members share it: they share M and startup)
                block_steady = max(steady, intelligent.held(cp, 0, float(order), algebraic))
            count0 = cs[intelligent.EST_BASE + estimators.COUNT, 0] if algebraic else 0.0
            for lane in range(lanes):
                # a member that comes in stopped stops at its first sample, member by member
                lanes_law &= mj[engine_metrics.M_DIVERGED, lane] == 0.0 or lane >= nb
                lanes_law &= cs[k_row, lane] == law_k0
                if law_kind == INTELLIGENT:
                    lanes_law &= cp[intelligent.EST, lane] == cp[intelligent.EST, 0]
                    if algebraic:
                        lanes_law &= cp[intelligent.M_WIN, lane] == m_win
                        lanes_law &= cp[intelligent.N_ORDER, lane] == order
                        lanes_law &= cp[intelligent.KERNEL, lane] == kernel
                        lanes_law &= (cp[intelligent.STARTUP, lane]
                                      == cp[intelligent.STARTUP, 0])
                        lanes_law &= (cs[intelligent.EST_BASE + estimators.COUNT, lane]
                                      == count0)
                    # a compensated delay's queue is read at rows that depend on the
                    # member's window: member by member
                    lanes_law &= cp[intelligent.DELAY, lane] == 0.0
                    simple &= cp[intelligent.N_ORDER, lane] == 1.0
                    simple &= cp[intelligent.AW, lane] != intelligent.AW_BACK
                elif law_kind == PID:
                    # a bumpless start is taken at the first sample, member by member
                    start = cs[pid.START, lane]
                    lanes_law &= law_k0 == 0.0 or start != start
                elif law_kind == ADRC:
                    start = cs[adrc.START, lane]
                    lanes_law &= law_k0 == 0.0 or start != start
                    # the delay's ring lies past the rows the block's buffer holds
                    lanes_law &= cp[adrc.DELAY, lane] == 0.0
            # a constant gain in every member: its divisions made once, here
            fixed = law_kind == INTELLIGENT
            if fixed:
                for lane in range(lanes):
                    fixed &= cp[variational_gain.MODE, lane] == variational_gain.CONSTANT
            if fixed:
                for lane in range(lanes):
                    D[_ALPHA, lane], D[_CY, lane], D[_CU, lane] = intelligent.fixed_gain(
                        cp, lane, law_dt, simple)
            # one reference for the block when its members share it
            shared_ref = not own_ref
            if not use_series:
                for lane in range(nb):
                    for i in range(RP.shape[0]):
                        shared_ref &= _same_bits(RP[i, b0 + lane], RP[i, b0])
            # what the loop metrics are measured against, when the members share it: its
            # windows' tests made once a sample for the block
            windows_shared = _windows_shared(mj)
            step_t0 = mj[engine_metrics.M_STEP_T0, 0]
            step_to = mj[engine_metrics.M_STEP_TO, 0]
            load_t0 = mj[engine_metrics.M_LOAD_T0, 0]
            block_ev = n_steps
            for lane in range(nb):
                block_ev = min(block_ev, next_ev[lane])
            for k in range(n_steps):
                t = grid.time(k, t_end, n_steps)
                if k == block_ev:
                    block_ev = n_steps
                    for lane in range(nb):
                        if alive[lane]:
                            if k == next_ev[lane]:
                                next_ev[lane] = _events_at(k, b0 + lane, ev_k, ev_col,
                                                           ev_add, ev_val, pb, lane, n_steps)
                                _prepare_lane(prepare, pb, ps, lane, hs, n_x)
                            block_ev = min(block_ev, next_ev[lane])
                if by_block:
                    output(xp, pp, yb)
                else:  # a stopped or spare lane keeps its last y: nothing reads it
                    for lane in range(lanes):
                        if alive[lane]:
                            D[_Y, lane] = measured(sig.offset(xsp, lane * n_x),
                                                   sig.offset(psp, lane * n_p), n_x, n_p)
                if any_out:
                    _disturbance_lanes(DP, members, dist_shared, t, dval)
                    for lane in range(lanes):
                        if d_out[lane]:
                            D[_Y, lane] = D[_Y, lane] + dval[lane]
                if any_acting:
                    _sense_lanes(D, acting, sensor_p, keys, shared_noise, shared_key, k, ring_y,
                                 y_first, d_y > 0, y_shared, quantised, series)
                else:
                    for lane in range(lanes):
                        D[_YM, lane] = D[_Y, lane]
                if shared_ref:
                    r0 = R[0, k] if use_series else reference.value(RP, b0, t)
                    for lane in range(lanes):
                        D[_R, lane] = r0
                else:
                    for lane in range(lanes):
                        j = _member_of(b0, lane, nb)
                        D[_R, lane] = R[j, k] if use_series else reference.value(RP, j, t)
                vector = lanes_law and law_k0 + k >= block_steady
                if vector:
                    # every live member's measurement good: then the law runs for all as
                    # one loop (stopped and spare lanes too: their plant state is a copy
                    # of a live one's, their law memory and metrics garbage that nothing
                    # keeps, having been saved when they stopped)
                    n_bad = 0
                    for lane in range(lanes):
                        ok = engine_metrics.measurement_ok(D[_Y, lane], D[_R, lane], bound)
                        n_bad += alive[lane] & (not ok)  # no branch: the loop vectorises
                    vector = n_bad == 0
                went_bad = 0
                if vector:
                    n_vector += 1
                    if external and law_kind == INTELLIGENT:
                        for lane in range(lanes):
                            j = _member_of(b0, lane, nb)
                            cs[variational_gain.ALPHA_EXT, lane] = AL[j if own_alpha else 0, k]
                    if algebraic:
                        live = 0
                        while not alive[live]:
                            live += 1
                        _estimator_lanes(D, m_win, order, kernel, live)
                    if law_kind == INTELLIGENT and simple and algebraic:
                        n_bad = _intelligent_gain(D, law_dt, True, True, fixed)
                    elif law_kind == INTELLIGENT and simple:
                        n_bad = _intelligent_gain(D, law_dt, True, False, fixed)
                    elif law_kind == INTELLIGENT and algebraic:
                        n_bad = _intelligent_gain(D, law_dt, False, True, fixed)
                    elif law_kind == INTELLIGENT:
                        n_bad = _intelligent_gain(D, law_dt, False, False, fixed)
                    elif law_kind == PID:
                        n_bad = _pid_lanes(D, law_dt)
                    elif law_kind == ADRC:
                        n_bad = _adrc_lanes(D, law_dt)
                    else:
                        n_bad = _recursive_lanes(D)
                    if n_bad == 0 and windows_shared:
                        _fold_windows(D, k, t, h, settle, final_start,
                                      engine_metrics.in_step_window(t, step_t0, step_to,
                                                                    load_t0),
                                      t >= final_start, t >= load_t0)
                    elif n_bad == 0:
                        _fold_lanes(D, k, t, h, settle, final_start)
                    else:  # a single run's gated fold, member by member
                        for lane in range(lanes):
                            was = mj[engine_metrics.M_DIVERGED, lane] == 0.0
                            ok = engine_metrics.member_metrics(
                                mj, S, lane, k, t, h, D[_Y, lane], D[_R, lane], D[_UM, lane],
                                D[_U, lane], D[_AP, lane], D[_G, lane])
                            D[_AP, lane] = D[_U, lane]
                            went_bad += 1 if was and not ok else 0
                else:
                    for lane in range(nb):
                        if not alive[lane]:
                            continue
                        j = b0 + lane
                        alpha = AL[j if own_alpha else 0, k] if external else 0.0
                        ok, u, a, g, gamma = _sample(law_kind, cp, cs, lane, mj, S, k, t, h,
                                                     D[_Y, lane], D[_YM, lane], D[_R, lane],
                                                     law_dt, external, alpha, D[_AP, lane],
                                                     bound)
                        if ok:
                            D[_AP, lane] = a
                            D[_U, lane] = a
                        else:  # its metrics say so (M_DIVERGED)
                            went_bad += 1
                            D[_U, lane] = 0.0
                if went_bad > 0:
                    for lane in range(nb):
                        if alive[lane] and mj[engine_metrics.M_DIVERGED, lane] != 0.0:
                            alive[lane] = False
                            n_alive -= 1
                            # its state, law memory and metrics when it stopped
                            _keep_member(by_block, lane, b0 + lane, xs, xb, cs, mj, dtc,
                                         X, CS, M, DT)
                if n_alive == 0:
                    break
                if any_acting:
                    _actuate_lanes(D, acting, actuator_p, d_in, DP, members, ring_u, u_act,
                                   u_shared, any_in, dist_shared, dval, k, t, h)
                else:
                    for lane in range(lanes):
                        D[_UP, lane] = D[_U, lane]
                for i in range(sub):
                    ti = t
                    if sub > 1:
                        # at the times of the grid of h / sub (bit for bit a run at that
                        # h), an input disturbance evaluated at each of them
                        ti = grid.time(k * sub + i, t_end, n_steps * sub)
                        if any_in:
                            _disturbance_lanes(DP, members, dist_shared, ti, dval)
                            for lane in range(lanes):
                                if d_in[lane]:
                                    D[_UP, lane] = u_act[lane] + dval[lane]
                    if not by_block:
                        for lane in range(lanes):
                            if alive[lane]:
                                dtc[lane] = _advance(
                                    integ, rhs, advance, ti,
                                    carray(sig.offset(xsp, lane * n_x), (n_x,)), D[_UP, lane],
                                    carray(sig.offset(psp, lane * n_p), (n_p,)), hs, rtol,
                                    atol, dtc[lane], ws)
                        continue
                    if n_alive < lanes:
                        # a stopped or spare lane steps a copy of a live one: f never sees
                        # a state that no single run reaches (a diverged one, say)
                        src = 0
                        while not alive[src]:
                            src += 1
                        for lane in range(lanes):
                            if not alive[lane]:
                                D[_UP, lane] = D[_UP, src]
                                if i == 0:
                                    _into_lane(xb, src, xb, lane)
                                    _into_lane(pb, src, pb, lane)
                    step(ti, xp, up, pp, hs, wp)
            for lane in range(nb):
                if alive[lane]:
                    _keep_member(by_block, lane, b0 + lane, xs, xb, cs, mj, dtc, X, CS, M,
                                 DT)
        # a use of buf after the views of it: numba frees an array after its last use
        return n_vector if buf.size > 0 else -1

    return block_loop


BLOCK_SIGNATURE = types.int64(
    types.int64, types.int64, types.intp, types.intp, types.intp, types.intp, types.intp,
    types.intp, types.int64, types.float64, types.float64, types.float64, _m, _m, _m, _m,
    _m, _m, _m, _m, _i2, _i1, types.boolean[::1], _m, _v, _m, _v, _v, types.int64,
    types.int64)


@lru_cache(maxsize=1)
def block_kernel():
    """The compiled vectorised member loop, exact arithmetic only (the fast mode's single
    runs fuse the RK4's arithmetic, which the plant's block step does not); cached on
    disk like :func:`member_kernel` (the user guide's Speed page, ``docs/guide/speed.md``,
    says what its first compilation costs)."""
    return _compile(_make_block_loop, BLOCK_SIGNATURE, False)


def loop_for(block, integ: int, n_members: int, n_steps: int, record: bool,
             vectorise: bool | None, fast: bool = False, uniform: bool = True) -> str:
    """Which loop runs a batch: ``"member"`` (:func:`member_kernel`), or the vectorised
    loop (:func:`block_kernel`) with each member's plant on its own functions,
    ``"lanes"``, or with the plant's block functions, ``"block"``.

    The vectorised loop runs any law and any loop elements (sensor, actuator,
    disturbance) when every member takes the same number of integration steps per
    sample (``uniform``), no trajectory, two members or more, and ``vectorise`` True, or
    None (automatic): for at least a quarter block of members, once the loop is compiled
    on this machine (in numba's disk cache), or from :data:`BLOCK_WORTH_COLD`
    member-samples on. It runs in exact arithmetic, ``fast`` or not (it has no fast
    mode: the fast flags measured no gain on its vectorised law), so a fast sweep is
    never slower than an exact one, and its members are their exact single runs. It
    takes the block functions (built for this integrator, and numba could compile them)
    when asked to, or automatically when they cost no compilation worth weighing (a
    library plant's, compiled once per machine; your own ODE's once compiled in this
    process or on this machine) or from :data:`BLOCK_WORTH_KEPT` member-samples on (your
    own ODE's from a file, compiled once per machine) or :data:`BLOCK_WORTH` (your own
    ODE's compiled once per process). Never automatically under Intel SVML (whose
    vector sin, exp, ... differ from the scalar ones in the last bits: a loop over a
    block's members, even of the reference, could change a member's bits)."""
    if record or n_members < 2 or vectorise is False or not uniform:
        return "member"
    has_block = (block is not None and INTEGRATORS[block.integrator] == integ
                 and not block.step.failed and not block.output.failed)
    if vectorise:
        return "block" if has_block else "lanes"
    work = n_members * n_steps
    # numba's config sets its names through globals(): its type stubs do not have them
    if (n_members < LANES // 4 or numba_config.USING_SVML  # type: ignore[attr-defined]
            or not (work >= BLOCK_WORTH_COLD or _block_kernel_ready())):
        return "member"
    if has_block and (work >= (BLOCK_WORTH_KEPT if block.kept else BLOCK_WORTH)
                      or block.cheap):
        return "block"
    return "lanes"


def _block_kernel_ready() -> bool:
    """The vectorised loop is loaded in this process or compiled in numba's disk cache
    (looked up in the cache's index, not loaded)."""
    if block_kernel.cache_info().currsize:
        return True
    try:
        fn = _dispatcher(_make_block_loop, False)
        key = fn._cache._index_key(BLOCK_SIGNATURE, fn.targetctx.codegen())
        return key in fn._cache._cache_file._load_index()
    except Exception:  # noqa: BLE001 (numba's cache internals moved, or no cache: cold)
        return False


def threads_for(n_members: int, n_samples: int) -> int:
    """Worker threads for a batch: all cores once the batch is worth a thread's start-up."""
    if n_members < 2 or n_members * n_samples < 200_000:
        return 1
    return min(len(os.sched_getaffinity(0)), n_members)  # the cores this process may use


def run(law_kind, integ, plant_fns, n_steps, h, t_end, law_dt, X, P, CP, CS, R, RP, AL, LP,
        events, S, M, tol, DT, traj, comp_rows, *, fast=False, threads=None, block=None,
        vectorise=None, member=None):
    """Run every member (all columns) through the member loop or the vectorised loop
    (:func:`loop_for`; ``vectorise`` True, False or None, automatic); arrays in place.

    ``plant_fns`` is (rhs, output, prepare, advance); ``LP`` the loop elements' columns
    (:mod:`mfcontrol.elements.layout`); ``events`` (ev_k, ev_col, ev_add, ev_val). ``traj`` with
    n_steps columns records member 0 (then only one member runs).
    ``block``: the plant's block functions (:class:`mfcontrol.numerics.blocks.Block`),
    or None; ``member`` its one-member RK4 step (:func:`member_step`), or None. The
    vectorised loop leaves P as it was (the member loop writes the scheduled
    changes and what ``prepare`` derives into it; nothing reads P after a run). Returns
    how many block-samples ran with the law vectorised (0 in the member loop).
    """
    ev_k, ev_col, ev_add, ev_val = events
    m = X.shape[0]
    record = traj.shape[1] == n_steps
    n_threads = threads_for(m, n_steps) if threads is None else threads
    uniform = bool(np.all(LP[layout.SUBSTEPS] == LP[layout.SUBSTEPS, 0]))
    which = loop_for(block, integ, m, n_steps, record, vectorise, fast, uniform)
    block_fns = (0, 0)
    if which == "block":
        try:
            block_fns = (block[0].address, block[1].address)
        except sig.COMPILE_ERRORS:
            # f or g compile as a single run's functions but not over a block (an
            # operation that needs contiguous arrays, say): each member's plant runs on
            # its own functions, and loop_for will not ask again (the failure is kept)
            which = loop_for(None, integ, m, n_steps, record, vectorise, fast)
    rhs, output, prepare, advance = (f.address for f in plant_fns)
    if which != "member":
        _check_block(block if which == "block" else None, X, P, CP, CS, M, law_kind)
        fn = block_kernel()
        args = (law_kind, integ, *block_fns, rhs, output, prepare, advance, n_steps, h, t_end,
                law_dt, X, P, CP, CS, R, RP, AL, LP, ev_k, ev_col, ev_add, ev_val, S, M, tol,
                DT)
        tail = ()
        bounds = block_bounds(m, n_threads)
    else:
        fn = member_kernel(fast)
        step = member_step(member, integ, m * n_steps, fast)
        args = (law_kind, integ, rhs, output, prepare, advance, step, n_steps, h, t_end,
                law_dt, X, P, CP, CS, R, RP, AL, LP, ev_k, ev_col, ev_add, ev_val, S, M, tol,
                DT)
        tail = (traj, comp_rows)
        bounds = np.linspace(0, m, n_threads + 1).astype(int)
    if n_threads <= 1 or record:
        done = [fn(*args, 0, m, *tail)]
    else:
        with ThreadPoolExecutor(n_threads) as pool:
            done = list(pool.map(lambda ab: fn(*args, ab[0], ab[1], *tail),
                                 [(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)
                                  if b > a]))
    return sum(int(d) for d in done) if which != "member" else 0


def block_bounds(m: int, n_threads: int) -> np.ndarray:
    """Where ``n_threads`` threads split m members of the vectorised loop: at whole
    blocks, their shares of members as even as that allows (non-decreasing, from 0 to
    m; a thread may get none)."""
    cuts = (np.linspace(0, m, n_threads + 1) / LANES).round().astype(np.int64) * LANES
    cuts = np.minimum(cuts, m)
    cuts[-1] = m
    return cuts


def _check_block(block, X, P, CP, CS, M, law_kind) -> None:
    """The block functions (or None) and the vectorised loop's buffer lay out what these
    arrays hold: a mismatch would read and write past the buffer, so it is an error."""
    # without block functions, the plant's sizes are the arrays' own
    n_x, n_p = (X.shape[1], P.shape[1]) if block is None else (block.n_x, block.n_p)
    if law_kind == INTELLIGENT:
        n_cp = intelligent.N_PARAMS
        windows = CP[intelligent.M_WIN][CP[intelligent.EST] == intelligent.ALGEBRAIC]
        law_rows = intelligent.n_state(int(windows.max()) if windows.size else 0)
    elif law_kind == PID:
        n_cp, law_rows = pid.N_PARAMS, pid.N_STATE
    elif law_kind == ADRC:
        n_cp, law_rows = adrc.N_PARAMS, adrc.n_state(int(CP[adrc.DELAY].max(initial=0)))
    else:
        n_cp, law_rows = recursive_ip.N_PARAMS, recursive_ip.N_STATE
    if (X.shape[1], P.shape[1]) != (n_x, n_p) or CP.shape[0] != n_cp \
            or M.shape[0] != engine_metrics.N_METRICS or CS.shape[0] < law_rows:
        raise ValueError(
            f"the vectorised loop got {X.shape[1]} states, {P.shape[1]} parameters, "
            f"{CP.shape[0]} law parameters, {CS.shape[0]} law state rows and "
            f"{M.shape[0]} metric rows; its plant has {n_x} states and {n_p} "
            f"parameters, its law {n_cp} parameters and at least {law_rows} "
            f"state rows, and there are {engine_metrics.N_METRICS} metrics")
