"""Per-call cost of the live controllers, side by side with simple-pid.

Each controller is called once per sample on the same precomputed measurement sequence
(a noisy first-order response), with an explicit ``dt`` where the API takes one, so that
no clock read is timed. The paths run in interleaved rounds in one process, so a slow
spell of a shared machine hits them alike; the script prints the median per-call time of
each and its ratio to simple-pid's. Timings are printed, never asserted.

Run:  python benchmarks/bench_live.py [--calls 20000] [--rounds 7]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from simple_pid import PID

import mfcontrol


def measurements(n: int) -> list[float]:
    rng = np.random.default_rng(0)
    t = np.arange(n) * 1e-3
    # plain Python floats, as a sensor read gives them (numpy scalars slow pure-Python
    # arithmetic down and flattered mfcontrol against simple-pid)
    return (1 - np.exp(-5 * t) + 1e-3 * rng.standard_normal(n)).tolist()


def make_paths(h: float):
    pid = PID(2.0, 1.0, 0.01, setpoint=1.0, sample_time=None, output_limits=(-10, 10))
    ip = mfcontrol.IP(alpha=1.0, kp=2.0, sample_time=h, output_limits=(-10, 10))
    ipid = mfcontrol.IPID(alpha=1.0, kp=2.0, ki=1.0, kd=0.01, sample_time=h,
                          output_limits=(-10, 10))
    ipi_alg = mfcontrol.IPI(alpha=1.0, kp=2.0, ki=1.0, sample_time=h, estimator="algebraic",
                            window=50, output_limits=(-10, 10))
    rip = mfcontrol.RecursiveIP(alpha=10.0, kp=2.0)
    mpid = mfcontrol.PID(2.0, 1.0, 0.01, sample_time=h, output_limits=(-10, 10))
    return {
        "simple-pid PID(y, dt=h)": lambda y: pid(y, dt=h),
        "mfcontrol IP(y, setpoint=1)": lambda y: ip(y, setpoint=1.0),
        "mfcontrol IPID(y, setpoint=1)": lambda y: ipid(y, setpoint=1.0),
        "mfcontrol IPI algebraic M=50": lambda y: ipi_alg(y, setpoint=1.0),
        "mfcontrol RecursiveIP(y, setpoint=1)": lambda y: rip(y, setpoint=1.0),
        "mfcontrol PID(y, setpoint=1)": lambda y: mpid(y, setpoint=1.0),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=20_000)
    ap.add_argument("--rounds", type=int, default=7)
    args = ap.parse_args()
    ys = measurements(args.calls)
    h = 1e-3
    paths = make_paths(h)
    for call in paths.values():  # warm-up: compile or load the cache
        for y in ys[:100]:
            call(y)
    times: dict[str, list[float]] = {name: [] for name in paths}
    for _ in range(args.rounds):
        for name, call in make_paths(h).items():
            t0 = time.perf_counter()
            for y in ys:
                call(y)
            times[name].append((time.perf_counter() - t0) / len(ys))
    base = statistics.median(times["simple-pid PID(y, dt=h)"])
    print(f"mfcontrol {mfcontrol.__version__}: {args.calls} calls x {args.rounds} rounds, "
          "median per call")
    print(f"{'controller':40s} {'us/call':>9s} {'vs simple-pid':>14s}")
    for name, ts in times.items():
        med = statistics.median(ts)
        print(f"{name:40s} {med * 1e6:9.2f} {med / base:13.2f}x")


if __name__ == "__main__":
    main()
