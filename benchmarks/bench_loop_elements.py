"""What the loop's elements cost: the DC-motor case under its i-PI (10,000 samples, h =
1 ms), a single run and a 256-member sweep (16 sensor seeds, or 16 values of kp without
noise, x 16 values of ki), with each element switched on alone and all together, as
ratios to the same runs without any (the ideal loop, in the same process: interleaved
rounds, medians, after a warm-up that compiles or loads the kernels).

Every variant's sweep runs the engine's vectorised loop (the elements act lane by lane
within it); the single run's ratio is what the elements cost in the member loop.

Timings are printed, never asserted. Run::

    python benchmarks/bench_loop_elements.py [--repeats 7]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import mfcontrol
from mfcontrol.api.run import batch
from mfcontrol.experiments.cases import resolve_case

CASE = "motor-noise-ipi-algebraic"
IDEAL = {"sensor.noise": "none"}
VARIANTS = {
    "ideal (no element)": {},
    "sensor noise 0.5 rad/s": {"sensor.noise": "gaussian"},
    "sensor quantum 0.1 + delay 2": {"sensor.quantum": 0.1, "sensor.delay": 2},
    "actuator delay 5 + rate limit": {"actuator.delay": 5, "actuator.rate_limit": 1e4},
    "input disturbance (sine)": {"disturbance.kind": "sine", "disturbance.amplitude": 1.0,
                                 "disturbance.frequency": 2.0},
    "10 substeps": {"sim.substeps": 10},
    "all of them": {"sensor.noise": "gaussian", "sensor.quantum": 0.1, "sensor.delay": 2,
                    "actuator.delay": 5, "actuator.rate_limit": 1e4,
                    "disturbance.kind": "sine", "disturbance.amplitude": 1.0,
                    "disturbance.frequency": 2.0, "sim.substeps": 10},
}


def _timer(fn):
    def once() -> float:
        t0 = time.perf_counter()
        fn()
        return time.perf_counter() - t0
    return once


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    single, sweep = {}, {}
    for name, over in VARIANTS.items():
        _, cfg = resolve_case(CASE, {**IDEAL, **over})
        single[name] = _timer(lambda cfg=cfg: mfcontrol.simulate(cfg))
        # the seed sweeps the noise where there is noise, the kp otherwise (a key every
        # member reads: a grid over a seed without noise is refused)
        first = ("sensor.seed", np.arange(16.0)) if cfg["sensor.noise"] != "none" else (
            "controller.kp", np.linspace(10.0, 30.0, 16))
        grid = batch.make_grid(cfg, {first[0]: first[1],
                                     "controller.ki": np.linspace(20.0, 80.0, 16)})
        sweep[name] = _timer(lambda grid=grid: batch.run_grid(grid))
    times: dict[str, dict[str, list[float]]] = {"single": {}, "sweep": {}}
    for what, fns in (("single", single), ("sweep", sweep)):
        for fn in fns.values():
            fn()  # warm-up: compile or load from the disk cache
        for _ in range(args.repeats):
            for name, fn in fns.items():  # interleaved: a slow spell hits every variant
                times[what].setdefault(name, []).append(fn())
    base = {what: statistics.median(times[what]["ideal (no element)"]) for what in times}
    print(f"{CASE}, 10,000 samples; medians of {args.repeats} interleaved rounds")
    print(f"{'variant':34s} {'single run':>18s} {'256-member sweep':>26s}")
    for name in VARIANTS:
        s = statistics.median(times["single"][name])
        w = statistics.median(times["sweep"][name])
        print(f"{name:34s} {s * 1e3:7.2f} ms {s / base['single']:5.2f}x "
              f"{w / 256 * 1e6:9.1f} us/member {w / base['sweep']:5.2f}x")


if __name__ == "__main__":
    main()
