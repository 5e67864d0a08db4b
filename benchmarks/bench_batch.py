"""Batch throughput: many 10,000-sample buck runs at once, against two baselines.

Measured in one process, medians of repeated runs after warm-up (compilation):

* batch: ``mfcontrol.api.run.batch.run_range`` over N members of the voltage-stable case (standard
  and variational law), all cores; simulations per second and ns per scenario-sample, for
  the three kernels: generic (what small sweeps run, cached on disk), specialised (the
  parameters all members share compiled in; exact, bit-identical) and fast (specialised,
  with fused multiply-adds, hoisted reciprocals and the plant's RK4 step as its linear
  map: within 1e-12 relative). The one-off compilation of a specialised kernel is
  printed apart;
* single: one member through the single-run kernel (engine only);
* baseline 1: the plain Python loop of the same case (benchmarks/bench_single.py);
* baseline 2: the same closed loop the way a python-control user writes it: one discrete
  ``control.nlsys`` whose update holds the plant's RK4 step and the controller, run by
  ``control.input_output_response``.

Prints the figures and the ratios; asserts nothing (machines are shared and noisy).

* memory (``--memory``): a 1,000,000-member metrics-only sweep (100 samples each, into a
  temporary folder through the same code as ``mfcontrol sweep``), and the process's peak
  resident memory.

Run:  python benchmarks/bench_batch.py [--members 4096] [--repeats 3] [--memory]
"""

from __future__ import annotations

import argparse
import importlib.util
import statistics
import time
from pathlib import Path

import control
import numpy as np

import mfcontrol
from mfcontrol.api.run import batch, scenario
from mfcontrol.experiments.cases import resolve_case


def median_time(fn, repeats: int) -> float:
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def python_control_loop(n: int = 10_000):
    """The standard voltage case as one python-control discrete system (plain Python)."""
    T, h, E, L, alpha, kp, hd = 0.01, 1e-6, 20.0, 1e-3, 10.0, 2.0, 1e-3

    def update(t, x, u, params):
        i, v, y_prev, r_prev, u_prev, k, R, C = x
        r = u[0]
        y = v
        un = 1.0 if k == 0 else (u_prev - (1 / alpha) * ((y - y_prev) / hd - (r - r_prev) / hd)
                                 + kp * (r - y_prev))
        d = min(max(un / 2000, 1e-3), 0.9)
        if k == 4000 or k == 6000:
            R, C = R + 1.0, C + 1e-9

        def f(i, v):
            b = d / L * E
            return h * (-v / L + b), h * ((i / C - v / (R * C)) + b)

        a1, b1 = f(i, v)
        a2, b2 = f(i + a1 / 2, v + b1 / 2)
        a3, b3 = f(i + a2 / 2, v + b2 / 2)
        a4, b4 = f(i + a3, v + b3)
        return [i + (a1 + 2 * (a2 + a3) + a4) / 6, v + (b1 + 2 * (b2 + b3) + b4) / 6, y, r,
                un, k + 1, R, C]

    sys = control.nlsys(update, lambda t, x, u, p: x[1], inputs=1, outputs=1, states=8, dt=h)
    t = (np.arange(n) * T) / n
    r = np.where(t < 5e-3, np.minimum(1000 * t, 2.5), 2.5 + 1000 * (t - 5e-3))
    return lambda: control.input_output_response(sys, t, r, X0=[0, 0, 0, 0, 0, 0, 10.0, 10e-6])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--members", type=int, default=4096)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--memory", action="store_true", help="also the 1,000,000-member sweep")
    args = ap.parse_args()
    spec = importlib.util.spec_from_file_location(
        "bench_single", Path(__file__).with_name("bench_single.py"))
    bench_single = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench_single)
    _, cfg = resolve_case("voltage-stable-standard")
    t_python = median_time(bench_single.python_baseline, 1)
    t_pc = median_time(python_control_loop(), 1)
    scn = scenario.build([cfg])
    t_single = median_time(lambda: scenario.execute(scn), 20)
    n_steps = scn.n_steps
    print(f"mfcontrol {mfcontrol.__version__}, {n_steps} samples per simulation")
    print(f"plain Python loop, one run:          {t_python * 1e3:10.2f} ms")
    print(f"python-control nlsys, one run:       {t_pc * 1e3:10.2f} ms")
    print(f"single-run kernel (engine), one run: {t_single * 1e3:10.3f} ms   "
          f"({t_python / t_single:,.0f}x plain Python, {t_pc / t_single:,.0f}x python-control)")
    kernels = {"generic": dict(specialise=False), "specialised": dict(specialise=True),
               "fast": dict(fast=True)}
    for case in ("voltage-stable-standard", "voltage-stable-variational"):
        _, base = resolve_case(case)
        # members differ (so nothing is shared by accident): kp spread over a small range
        grid = batch.make_grid(base, {"controller.kp": np.linspace(1.9, 2.1, args.members)})
        changes = batch._cell_changes(grid)
        runs = {}
        for name, opts in kernels.items():
            t0 = time.perf_counter()
            batch.run_range(grid, 0, 1, changes, **opts)
            compile_s = time.perf_counter() - t0
            runs[name] = (compile_s, lambda g=grid, c=changes, o=opts: batch.run_range(
                g, 0, g.n_members, c, **o))
        times = {name: [] for name in kernels}
        for _ in range(args.repeats):  # interleaved, so a slow spell hits every kernel
            for name, (_, fn) in runs.items():
                t0 = time.perf_counter()
                fn()
                times[name].append(time.perf_counter() - t0)
        for name, (compile_s, _) in runs.items():
            t = statistics.median(times[name])
            per_sim = t / grid.n_members
            print(f"batch {case:27s} {name:11s} {grid.n_members / t:8,.0f} sims/s "
                  f"{per_sim / n_steps * 1e9:5.2f} ns/scenario-sample "
                  f"{t_python / per_sim:6,.0f}x plain Python {t_pc / per_sim:7,.0f}x "
                  f"python-control  (first call {compile_s:.1f} s)")


    if args.memory:
        memory()


def memory() -> None:
    import resource
    import tempfile

    from mfcontrol.experiments.sweeps import run_sweep

    _, base = resolve_case("voltage-stable-standard", {"sim.t_end": 1e-4})
    axes = {"controller.alpha": np.logspace(0, 2, 1000), "plant.dR": np.linspace(0, 10, 1000)}
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        run_sweep("voltage-stable-standard", base, {"sim.t_end": 1e-4}, axes, Path(tmp),
                  chunk=8192)
        dt = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"1,000,000-member metrics-only sweep (100 samples each): {dt:.1f} s, "
          f"peak resident memory {peak:,.0f} MiB (target: under 2 GiB)")


if __name__ == "__main__":
    main()
