"""Single-run speed: one 10,000-sample ``voltage-stable-standard`` case.

Measured, after warm-up (the first call compiles the numba kernel, or loads it from the
on-disk cache), as the median wall-clock time (``time.perf_counter``) of repeated runs:

* baseline   a plain Python loop (floats and lists, no numpy, no numba) computing the
             same trajectory, run in this same process;
* (a)        ``mfcontrol.simulate(cfg)`` end to end: scenario packing, kernel, Result;
* (b)        ``scenario.execute(scn)`` on a prebuilt scenario: the engine alone;
* (c), (d)   the same two in the fast mode (``fast=True``: fused arithmetic, the plant's
             RK4 step as its linear map; within about 1e-13 relative of (a)).

The paths are timed in interleaved rounds, so that a slow spell of a shared machine hits
them alike. It prints the medians (and minima), the ratios against the baseline, whether
(a) meets the project target of at most 1 ms per 10,000-sample run, and whether the
engine, exact (b) and fast (d), meets the sweep issue's 0.2 ms. Timings are printed,
never asserted: machines are shared and noisy, so only medians and same-process ratios
mean anything. Before timing, the baseline's y, duty and u_raw are checked against
``mfcontrol.simulate`` to 1e-12 absolute; the script exits non-zero if they differ.

Run it with::

    python benchmarks/bench_single.py [--repeats 50] [--baseline-repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable, Sequence

import numpy as np

import mfcontrol
from mfcontrol.api.run import scenario
from mfcontrol.experiments.cases import resolve_case

CASE = "voltage-stable-standard"
TARGET_S = 1e-3
ENGINE_TARGET_S = 0.2e-3
TOLERANCE = 1e-12


def python_baseline() -> tuple[list[float], list[float], list[float]]:
    """Benchmark baseline only: the ``voltage-stable-standard`` case as a plain Python loop.

    Not part of mfcontrol and not meant for use: it exists so that the compiled engine can
    be compared with a straightforward pure-Python implementation of the same algorithm
    (floats and lists, no numpy in the loop, no numba). The case's constants are written
    out; the start-up check proves it matches ``mfcontrol.simulate`` for this case.

    Returns the lists (y, duty, u_raw), one value per sample.
    """
    n = 10000
    t_end = 0.01
    h = 1e-6
    # buck converter, published coupling (E d / L on both derivatives)
    e_src, ind, res, cap = 20.0, 1e-3, 10.0, 10e-6
    i, v = 0.0, 0.0
    a12 = -1 / ind
    a21 = 1 / cap
    a22 = -1 / (res * cap)
    # load changes: first sample with t_k >= 4 ms, then first with t_k >= 6 ms
    change_times = [4e-3, 6e-3]
    d_res, d_cap = 1.0, 1e-9
    next_change = 0
    # recursive i-P law
    inv_alpha = 1 / 10.0
    kp = 2.0
    hd = 1e-3
    out_gain = 1 / 2000
    d_min, d_max = 1e-3, 0.9
    u = 1.0
    y_prev = 0.0
    r_prev = 0.0

    ys: list[float] = []
    duties: list[float] = []
    us: list[float] = []
    for k in range(n):
        t = (k * t_end) / n
        if next_change < len(change_times) and t >= change_times[next_change]:
            res += d_res
            cap += d_cap
            a12 = -1 / ind
            a21 = 1 / cap
            a22 = -1 / (res * cap)
            next_change += 1
        # measurement (before the plant step) and ramp-hold-ramp reference
        y = v
        slope_t = 1000.0 * t
        r = slope_t if slope_t <= 2.5 else 2.5
        if t >= 5e-3:
            r = 2.5 + 1000.0 * (t - 5e-3)
        # control law; the recursion carries the unclipped u
        if k > 0:
            e_dot = (y - y_prev) / hd - (r - r_prev) / hd
            u = (u - inv_alpha * e_dot) + kp * (r - y_prev)
        d = out_gain * u
        d = d_max if d > d_max else (d_min if d < d_min else d)
        y_prev = y
        r_prev = r
        ys.append(y)
        duties.append(d)
        us.append(u)
        # one RK4 step (increment form) with d held
        b = d / ind * e_src
        p1 = h * (a12 * v + b)
        q1 = h * ((a21 * i + a22 * v) + b)
        i2 = i + p1 / 2
        v2 = v + q1 / 2
        p2 = h * (a12 * v2 + b)
        q2 = h * ((a21 * i2 + a22 * v2) + b)
        i3 = i + p2 / 2
        v3 = v + q2 / 2
        p3 = h * (a12 * v3 + b)
        q3 = h * ((a21 * i3 + a22 * v3) + b)
        i4 = i + p3
        v4 = v + q3
        p4 = h * (a12 * v4 + b)
        q4 = h * ((a21 * i4 + a22 * v4) + b)
        i = i + (p1 + 2 * (p2 + p3) + p4) / 6
        v = v + (q1 + 2 * (q2 + q3) + q4) / 6
    return ys, duties, us


def check_baseline(result: mfcontrol.Result) -> float:
    """Largest absolute difference between the baseline and ``result``; exit if too big."""
    ys, duties, us = python_baseline()
    worst = 0.0
    for name, ours in (("y", ys), ("u", duties), ("u_raw", us)):
        theirs = np.asarray(result.signals[name])
        if theirs.shape != (len(ours),):
            sys.exit(f"baseline check failed: {name} has {theirs.shape} samples from "
                     f"mfcontrol.simulate, {len(ours)} from the baseline")
        diff = np.abs(np.asarray(ours) - theirs)
        if not np.all(diff <= TOLERANCE):  # NaN fails this too
            k = int(np.argmax(np.where(np.isnan(diff), np.inf, diff)))
            sys.exit(f"baseline check failed: {name} differs from mfcontrol.simulate by "
                     f"{diff[k]:.3g} at sample {k} (tolerance {TOLERANCE:g}); "
                     "the baseline does not compute the same case")
        worst = max(worst, float(diff.max()))
    return worst


def interleaved_times(paths: Sequence[tuple[Callable[[], object], int]],
                      rounds: int) -> list[list[float]]:
    """Seconds per call of each ``(fn, repeats)`` path, measured in interleaved rounds.

    Each path's repeats are spread evenly over ``rounds`` rounds, and every round runs all
    paths, so slow spells of a shared machine hit the baseline and the compiled paths alike
    and the ratios stay meaningful.
    """
    times: list[list[float]] = [[] for _ in paths]
    for r in range(rounds):
        for (fn, repeats), out in zip(paths, times, strict=True):
            for _ in range(repeats * (r + 1) // rounds - repeats * r // rounds):
                t0 = time.perf_counter()
                fn()
                out.append(time.perf_counter() - t0)
    return times


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=50,
                        help="timed runs of each compiled path (default 50)")
    parser.add_argument("--baseline-repeats", type=int, default=3,
                        help="timed runs of the plain Python baseline (default 3)")
    args = parser.parse_args(argv)
    if args.repeats < 1 or args.baseline_repeats < 1:
        parser.error("repeat counts must be at least 1")

    _, cfg = resolve_case(CASE)
    t0 = time.perf_counter()
    first = mfcontrol.simulate(cfg)  # compiles, or loads the numba cache
    first_call = time.perf_counter() - t0
    worst = check_baseline(first)
    scn = scenario.build([cfg])
    for _ in range(3):  # warm-up of both compiled paths
        mfcontrol.simulate(cfg)
        scenario.execute(scn)
        mfcontrol.simulate(cfg, fast=True)
        scenario.execute(scn, fast=True)

    paths = [
        ("plain Python loop (baseline)", python_baseline, args.baseline_repeats),
        ("(a) mfcontrol.simulate, end to end", lambda: mfcontrol.simulate(cfg), args.repeats),
        ("(b) scenario.execute, engine only", lambda: scenario.execute(scn), args.repeats),
        ("(c) simulate(fast=True), end to end", lambda: mfcontrol.simulate(cfg, fast=True),
         args.repeats),
        ("(d) execute(fast=True), engine only", lambda: scenario.execute(scn, fast=True),
         args.repeats),
    ]
    rounds = min(args.repeats, args.baseline_repeats)
    times = interleaved_times([(fn, reps) for _, fn, reps in paths], rounds)
    t_base, t_sim = statistics.median(times[0]), statistics.median(times[1])

    n = scn.n_steps
    print(f"case {CASE}: {n} samples, mfcontrol {mfcontrol.__version__}")
    print(f"first call (compile or cache load): {first_call:.3f} s")
    print(f"baseline check: y, duty, u_raw match to {worst:.3g} (tolerance {TOLERANCE:g})")
    print()
    print(f"{'path':<36} {'repeats':>7} {'median s':>11} {'median ms':>10} {'min ms':>9} "
          f"{'baseline/x':>11}")
    for (label, _, reps), ts in zip(paths, times, strict=True):
        t = statistics.median(ts)
        print(f"{label:<36} {reps:>7} {t:>11.3e} {t * 1e3:>10.3f} {min(ts) * 1e3:>9.3f} "
              f"{t_base / t:>10.1f}x")
    print()
    verdict = "meets" if t_sim <= TARGET_S else "MISSES"
    print(f"(a) {verdict} the {TARGET_S * 1e3:g} ms target: median {t_sim * 1e3:.3f} ms "
          f"per {n}-sample run; ratio {t_base / t_sim:.0f}x vs the baseline (aim: 300x)")
    for label, ts in (("(b) exact", times[2]), ("(d) fast", times[4])):
        t = statistics.median(ts)
        verdict = "meets" if t <= ENGINE_TARGET_S else "MISSES"
        print(f"engine {label} {verdict} the {ENGINE_TARGET_S * 1e3:g} ms target: "
              f"median {t * 1e3:.3f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
