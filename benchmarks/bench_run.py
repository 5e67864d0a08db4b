"""Lean runs: ``mfcontrol run`` and a warm ``mfcontrol sweep`` against a bare ``mfcontrol
cases``, and ``simulate_loop``'s overhead above the engine.

Measured in one process, as medians of interleaved rounds (a slow spell of a shared
machine hits every path alike), after a warm-up of each (the first use of the compiled
kernels compiles them or loads them from numba's disk cache):

(a) CPU time (user + system, ``resource.getrusage`` of the waited-for children) of
    ``mfcontrol run voltage-stable-standard --out <tmp>`` against a bare
    ``mfcontrol cases``, each in a new subprocess. Target: at most 3x.
(b) A 1,000-sample ``simulate_loop`` of the DC motor of ``bench_engine.py`` (a numba ODE
    in the in-place form, an i-PI, h = 1 ms, 1 s, a load change at 0.5 s), the
    controller built before the clock starts, against the engine's own time for the same
    run: :func:`mfcontrol.engine.compose.run`, the lowest-level call ``simulate_loop``
    makes, timed on copies of the very arrays that call received. Target: at most
    150 us of overhead.
(c) CPU time of a warm second process of
    ``mfcontrol sweep voltage-stable-standard --grid 'controller.alpha=logspace(0,2,1024)'``
    (the paper's sweep kernels loaded from numba's disk cache) against the same bare
    ``mfcontrol cases``. Target: at most 4x.

Timings are printed, never asserted. Run::

    python benchmarks/bench_run.py [--rounds 7] [--loop-calls 200]
"""

from __future__ import annotations

import argparse
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

import mfcontrol
from bench_engine import controller, motor  # noqa: I001 (a sibling script: run from anywhere)
from mfcontrol.engine import compose

CASE = "voltage-stable-standard"
RUN_TARGET = 3.0
SWEEP_GRID = "controller.alpha=logspace(0,2,1024)"
SWEEP_TARGET = 4.0
OVERHEAD_TARGET_S = 150e-6
SPEED, H, T_END = 60.0, 1e-3, 1.0
CHANGES = [mfcontrol.Change(0.5, "tau", 0.05)]
#: the clock of (b): this thread's CPU time, which a core shared with other processes does
#: not inflate as it does the wall clock (both paths run on this thread alone)
CLOCK = time.thread_time


def _cli(*args: str) -> list[str]:
    # the installed command's own start (its console script imports mfcontrol.cli.main)
    exe = shutil.which("mfcontrol")
    return [exe, *args] if exe else [sys.executable, "-m", "mfcontrol.cli", *args]


def child_cpu(cmd: list[str]) -> float:
    """CPU seconds (user + system) of one subprocess running ``cmd`` to its end."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    # the progress lines a sweep writes to stderr kept off the report (shown on a failure)
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode:
        sys.exit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stderr}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def bench_cli(rounds: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        run = _cli("run", CASE, "--out", str(Path(tmp) / "out"))
        cases = _cli("cases")

        def sweep() -> float:  # a new folder each time: a sweep resumes from a finished one
            out = tempfile.mkdtemp(dir=tmp)
            return child_cpu(_cli("sweep", CASE, "--grid", SWEEP_GRID, "--out", out))

        child_cpu(run)  # warm: the kernels compiled or in numba's cache, files in the page cache
        child_cpu(cases)
        sweep()
        t_run, t_cases, t_sweep = [], [], []
        for _ in range(rounds):
            t_run.append(child_cpu(run))
            t_cases.append(child_cpu(cases))
            t_sweep.append(sweep())
    run_s, cases_s = statistics.median(t_run), statistics.median(t_cases)
    sweep_s = statistics.median(t_sweep)
    print(f"(a) mfcontrol run {CASE}: {run_s:.3f} s CPU; mfcontrol cases: {cases_s:.3f} s CPU "
          f"(medians of {rounds} rounds)")
    ratio = run_s / cases_s
    print(f"    ratio {ratio:.2f}x (target <= {RUN_TARGET:g}x): "
          f"{'met' if ratio <= RUN_TARGET else 'NOT met'}")
    ratio = sweep_s / cases_s
    print(f"(c) mfcontrol sweep {CASE} --grid '{SWEEP_GRID}', a warm process: {sweep_s:.3f} s "
          f"CPU, {ratio:.2f}x mfcontrol cases (target <= {SWEEP_TARGET:g}x): "
          f"{'met' if ratio <= SWEEP_TARGET else 'NOT met'}")


def compose_call(run_loop: Callable[[], object]) -> tuple[tuple, dict]:
    """The arguments (args, kwargs) that ``run_loop()`` (a ``simulate_loop`` call) passes
    to ``compose.run``: the engine's own call, to time apart from the Python around it
    (``bench_single_loop.py`` takes it too)."""
    seen = {}
    inner = compose.run

    def spy(*args, **kwargs):
        seen["call"] = (args, kwargs)
        return inner(*args, **kwargs)

    compose.run = spy
    try:
        run_loop()
    finally:
        compose.run = inner
    return seen["call"]


def run_fresh(args: tuple, kwargs: dict, clock: Callable[[], float]) -> float:
    """The time of one ``compose.run`` on fresh copies of its arrays (it writes its
    states, memory and metrics in place), by ``clock``."""
    fresh = [a.copy() if isinstance(a, np.ndarray) else a for a in args]
    t0 = clock()
    compose.run(*fresh, **kwargs)
    return clock() - t0


def bench_loop(rounds: int, calls: int) -> None:
    plant = motor()
    args, kwargs = compose_call(lambda: mfcontrol.simulate_loop(
        plant, controller(), SPEED, t_end=T_END, changes=CHANGES))
    n = args[3]

    def engine_once() -> float:
        return run_fresh(args, kwargs, CLOCK)

    def loop_once() -> float:
        ctrl = controller()  # the caller's object, built before the clock starts
        t0 = CLOCK()
        mfcontrol.simulate_loop(plant, ctrl, SPEED, t_end=T_END, changes=CHANGES)
        return CLOCK() - t0

    engine_once(), loop_once()  # warm
    per_loop, per_engine = [], []
    for _ in range(rounds):  # interleaved: each round a median of both
        loop_t, engine_t = [], []
        for _ in range(calls):
            loop_t.append(loop_once())
            engine_t.append(engine_once())
        per_loop.append(statistics.median(loop_t))
        per_engine.append(statistics.median(engine_t))
    loop_s, engine_s = statistics.median(per_loop), statistics.median(per_engine)
    over = loop_s - engine_s
    print(f"(b) simulate_loop, DC motor, {n:,} samples: {loop_s * 1e6:.0f} us; the engine "
          f"(compose.run) {engine_s * 1e6:.0f} us")
    print(f"    overhead {over * 1e6:.0f} us (target <= {OVERHEAD_TARGET_S * 1e6:.0f} us): "
          f"{'met' if over <= OVERHEAD_TARGET_S else 'NOT met'}; "
          f"{loop_s / engine_s:.2f}x the engine")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--loop-calls", type=int, default=200,
                    help="calls of each path per round in (b)")
    args = ap.parse_args()
    bench_loop(args.rounds, args.loop_calls)
    bench_cli(args.rounds)


if __name__ == "__main__":
    main()
