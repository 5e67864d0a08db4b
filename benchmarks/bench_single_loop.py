"""A single run of the engine against a hand-written numba loop of the same arithmetic.

The DC motor of ``bench_engine.py`` (the library's ``DCMotor``: the same model) under an i-PI
(alpha = 50, kp = 20, ki = 50, h = 1 ms, limits +-24 V, clamping anti-windup), a load
step at 5 s, 100,000 samples: what ``mfcontrol.simulate_loop`` gives, against one
``@njit`` function written as a numba user would write this loop: the states, the law's
memory and the metric sums in local variables, f inlined into the RK4. It calls the
library's own float functions (the RK4's stages, the law's derivatives and bracket, the
metrics' fold), so it computes the same numbers: the same metrics and the same recorded
signals (y*, y, u, the applied u, gamma, the law's components, the states), checked bit
for bit against ``simulate_loop`` before anything is timed (the script exits non-zero if
they differ).

Each is timed per sample over long runs (the slope between 20,000 and 200,000 samples:
what each sample costs, without the fixed cost of a call): the hand-written loop, the
engine's own call (``compose.run`` on the arrays ``simulate_loop`` passes it, fresh
copies each time) and ``simulate_loop`` whole (which also builds the result). The ratios
to the hand-written loop are printed (target of issue 27: at most 2x). Medians (and
minima) of interleaved rounds on this shared machine; times are printed, never asserted.
Run::

    python benchmarks/bench_single_loop.py [--rounds 7]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np
from numba import njit

import mfcontrol
from bench_engine import LOAD, SPEED, T_LOAD, H, controller  # noqa: I001
from bench_run import compose_call, run_fresh
from mfcontrol.engine import metrics as em
from mfcontrol.laws import intelligent
from mfcontrol.numerics import grid, rk4

J, B_F, K_T, R_A, L_A = 5e-4, 1e-4, 0.05, 2.0, 2e-3
ROWS = ("y_ref", "y", "u_raw", "u", "gamma", "gain", "F_hat", "feedforward", "P", "I", "D")


@njit(inline="always", error_model="numpy")
def _f(x0, x1, u, tau):
    """The motor's right-hand side on plain floats: the ODE's arithmetic, in its order."""
    return (K_T * x1 - B_F * x0 - tau) / J, (u - R_A * x1 - K_T * x0) / L_A


@njit(error_model="numpy", cache=True)
def hand_written(n, t_end, k_load, load, inv_alpha, kp, ki, lo, hi, r, settle, final_start,
                 bound, step_t0, step_from, step_to, load_t0, traj):
    """The loop as a numba user writes it; returns the metrics (rows of engine.metrics)."""
    h = t_end / n
    x0 = x1 = 0.0
    tau = 0.0
    # the law's memory
    y1 = r1 = e1 = u1 = integ = 0.0
    # the metrics: sums and maxima
    alive, t_div, n_done = 1.0, 0.0, 0.0
    iae = ise = itae = mxs = mxf = mxr = tv = 0.0
    energy, peak, t10, t90, t_in, t_last = 0.0, 0.0, np.inf, np.inf, -np.inf, -np.inf
    e_final = n_final = iae_load = 0.0
    a_prev = 0.0
    gamma = inv_alpha
    for k in range(n):
        t = grid.time(k, t_end, n)
        if k == k_load:
            tau = load
        y = x0
        if not em.measurement_ok(y, r, bound):
            alive, t_div = 0.0, t
            break
        f_hat = rn = c_p = c_i = 0.0
        if k < 1:
            u = a = u1
        else:
            yd, rd, yn, rn = intelligent.derivatives(1.0, y, r, y1, 0.0, r1, 0.0, h)
            gamma = inv_alpha
            alpha = 1.0 / gamma
            f_hat = yn - alpha * u1
            e = y - r
            a, u, integ, _ = intelligent.output(f_hat, rn, gamma, e, integ, e1, h, kp, ki,
                                                0.0, lo, hi, intelligent.AW_CLAMP, 0.0)
            c_p = kp * e
            c_i = ki * integ
        y1, r1, e1, u1 = y, r, y - r, a
        (alive, t_div, n_done, iae, ise, itae, mxs, mxf, mxr, tv, _) = em.fold_metrics(
            alive, t_div, n_done, iae, ise, itae, mxs, mxf, mxr, tv, gamma, k, t, h, y, r,
            u, a, a_prev, gamma, settle, final_start, bound)
        if alive == 0.0:
            break
        energy, peak, t10, t90, t_in, t_last, e_final, n_final, iae_load = em.loop_sums(
            energy, peak, t10, t90, t_in, t_last, e_final, n_final, iae_load, t, h, y, r, a,
            step_t0, step_from, step_to, load_t0, final_start)
        a_prev = a
        traj[0, k] = r
        traj[1, k] = y
        traj[2, k] = u
        traj[3, k] = a
        traj[4, k] = gamma
        traj[5, k] = gamma
        traj[6, k] = f_hat
        traj[7, k] = rn
        traj[8, k] = c_p
        traj[9, k] = c_i
        traj[10, k] = 0.0
        traj[11, k] = x0
        traj[12, k] = x1
        # RK4, f inlined, with the library's stage arithmetic
        d0, d1 = _f(x0, x1, a, tau)
        f10, f11 = h * d0, h * d1
        d0, d1 = _f(rk4.half(x0, f10), rk4.half(x1, f11), a, tau)
        f20, f21 = h * d0, h * d1
        d0, d1 = _f(rk4.half(x0, f20), rk4.half(x1, f21), a, tau)
        f30, f31 = h * d0, h * d1
        d0, d1 = _f(rk4.whole(x0, f30), rk4.whole(x1, f31), a, tau)
        x0 = rk4.combine(x0, f10, f20, f30, h * d0)
        x1 = rk4.combine(x1, f11, f21, f31, h * d1)
    return np.array([iae, ise, itae, mxs, tv, mxf, mxr, energy, t_in, iae_load, n_done])


#: the library's DC motor: its one-member step (f and g compiled into one call) is
#: compiled once per machine; your own ODE's compiles once per process, from
#: compose.MEMBER_STEP_WORTH member-samples on
PLANT = mfcontrol.DCMotor(J=J, friction=B_F, Km=K_T, Ra=R_A, La=L_A)
CHANGES = [mfcontrol.Change(T_LOAD, "load", LOAD)]


def engine(n: int):
    return mfcontrol.simulate_loop(PLANT, controller(), SPEED, t_end=n * H, changes=CHANGES)


def plain(n: int):
    t_end = n * H
    traj = np.empty((13, n))
    k_load = grid.first_sample_at(T_LOAD, t_end, n)
    m = hand_written(n, t_end, k_load, LOAD, 1.0 / 50.0, 20.0, 50.0, -24.0, 24.0, SPEED,
                     0.0, t_end * (1 - 0.2), 1e12, 0.0, 0.0, SPEED, T_LOAD, traj)
    return m, traj


def check(n: int) -> None:
    """The hand-written loop's signals and metrics against the engine's, bit for bit."""
    res = engine(n)
    m, traj = plain(n)
    bad = []
    for i, name in enumerate(ROWS):
        got = res.signals[name] if name in res.signals else None
        if got is not None and not np.array_equal(got, traj[i]):
            bad.append(f"{name}: max |diff| {np.max(np.abs(got - traj[i])):.3g}")
    for i, name in enumerate(("omega", "i")):
        states = list(res.states.values())
        if not np.array_equal(states[i], traj[11 + i]):
            bad.append(f"state {name}: max |diff| {np.max(np.abs(states[i] - traj[11 + i])):.3g}")
    for name, v in (("iae", m[0]), ("ise", m[1]), ("itae", m[2]), ("tv_u", m[4])):
        if res.metrics[name] != v:
            bad.append(f"metric {name}: {res.metrics[name]!r} vs {v!r}")
    if bad:
        print("the hand-written loop differs from simulate_loop:\n  " + "\n  ".join(bad))
        sys.exit(1)
    print(f"   checked: {len(ROWS)} signals, 2 states and 4 metrics equal bit for bit "
          f"over {n:,} samples")


def engine_call(n: int):
    """The engine's own call for n samples: ``compose.run`` with the arrays
    ``simulate_loop`` passes it, fresh copies each time (it writes them in place)."""
    args, kwargs = compose_call(lambda: engine(n))
    return lambda: run_fresh(args, kwargs, time.perf_counter)


def timed(fn, n: int) -> float:
    t0 = time.perf_counter()
    fn(n)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=9)
    args = ap.parse_args()
    short, long = 20_000, 200_000
    engine(short)
    plain(short)  # compile (or load) both
    print("single run of the DC motor i-PI: the engine against a hand-written numba loop")
    check(long)
    calls = {n: engine_call(n) for n in (short, long)}
    paths = {"hand-written numba loop": lambda n: timed(plain, n),
             "engine (compose.run)": lambda n: calls[n](),
             "simulate_loop": lambda n: timed(engine, n)}
    per: dict[str, list[float]] = {k: [] for k in paths}
    for _ in range(args.rounds):
        for name, fn in paths.items():
            per[name].append((fn(long) - fn(short)) / (long - short))
    base = statistics.median(per["hand-written numba loop"])
    for name, v in per.items():
        med = statistics.median(v)
        print(f"   {name:24s} {med * 1e9:6.1f} ns/sample (min {min(v) * 1e9:5.1f}), "
              f"{med / base:4.2f}x the hand-written loop")
    print("   target (issue 27): the engine at most 2x")


if __name__ == "__main__":
    main()
