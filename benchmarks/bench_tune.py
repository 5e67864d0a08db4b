"""What a tuner's generation costs beyond its simulations: ``mfcontrol.tune`` on
``first-order-ip-algebraic`` (4,000 samples a run, i-P with the algebraic estimator,
kp and alpha tuned, a population of 30), against the batch engine running the same
points (``batch.run_range`` on a grid of them) in the same process.

The difference is the tuner's own work per point: checking the point, building its law
for the general engine, the history's rows. Timings are printed, never asserted. Run::

    python benchmarks/bench_tune.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import mfcontrol
from mfcontrol.api.run import batch
from mfcontrol.experiments.cases import resolve_case

CASE = "first-order-ip-algebraic"
PARAMS = ["controller.kp=1:100", "controller.alpha=0.2:5"]
BUDGET = 300


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    _, cfg = resolve_case(CASE)
    rng = np.random.default_rng(0)
    points = {"controller.kp": rng.uniform(1, 100, 30), "controller.alpha": rng.uniform(0.2, 5, 30)}
    grid = batch.Grid(base=cfg, axes=points, points=tuple(points))
    mfcontrol.tune(CASE, PARAMS, budget=60)  # warm-up: compile or load the kernels
    batch.run_range(grid, 0, grid.n_members)
    tune_s, batch_s = [], []
    for _ in range(args.repeats):
        t = time.perf_counter()
        r = mfcontrol.tune(CASE, PARAMS, budget=BUDGET, tol=0.0)
        tune_s.append((time.perf_counter() - t) / r.evaluations)
        t = time.perf_counter()
        for _ in range(BUDGET // grid.n_members):
            batch.run_range(grid, 0, grid.n_members)
        batch_s.append((time.perf_counter() - t) / (BUDGET // grid.n_members * 30))
    per_point, per_run = statistics.median(tune_s), statistics.median(batch_s)
    print(f"{CASE}, {BUDGET} points, population 30 (medians of {args.repeats}):")
    print(f"  tune:            {per_point * 1e3:7.3f} ms per point ({1 / per_point:,.0f} points/s)")
    print(f"  batch alone:     {per_run * 1e3:7.3f} ms per point ({1 / per_run:,.0f} points/s)")
    print(f"  ratio tune / batch: {per_point / per_run:.2f}")


if __name__ == "__main__":
    main()
