"""A stability region from the linear analysis against the same grid simulated.

For two cases, a ``--size`` x ``--size`` region (``mfcontrol.analyze_region``) is timed
against a simulated sweep of the same case over the same two keys (``mfcontrol sweep``'s
own engine through :func:`mfcontrol.api.run.simulate.simulate_many`, on a
``--simulated`` x ``--simulated`` corner of the grid, the case's horizon), both per cell,
in one process after a warm-up of each:

- ``bench-lag3``: a PID on 1/(s+1)^3, over kp x ki (a loop of degree 6);
- ``motor-noise-ipi-algebraic``: an i-PI with the algebraic estimator (window 40) on the
  DC motor, over alpha x kp (a loop of degree 46: its poles are the eigenvalues of a
  46 x 46 matrix per cell).

Timings are printed, never asserted. Run::

    python benchmarks/bench_region.py [--size 200] [--simulated 16]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import mfcontrol
from mfcontrol.api.run.simulate import simulate_many
from mfcontrol.experiments.cases import resolve_case

CASES = {
    "bench-lag3": ("controller.kp", (-1.0, 1.2), "controller.ki", (-2.0, 0.8)),
    "motor-noise-ipi-algebraic": ("controller.alpha", (0.0, 3.0), "controller.kp",
                                  (0.0, 3.0)),
}


def _axes(case: str, n: int) -> list[str]:
    kx, (x0, x1), ky, (y0, y1) = CASES[case]
    return [f"{kx}=logspace({x0},{x1},{n})", f"{ky}=logspace({y0},{y1},{n})"]


def _simulated(case: str, n: int) -> float:
    """Seconds of a simulated sweep of n x n members of the case over the same keys."""
    kx, (x0, x1), ky, (y0, y1) = CASES[case]
    _, cfg = resolve_case(case)
    cfgs = [cfg.with_overrides({kx: float(x), ky: float(y)})
            for y in np.logspace(y0, y1, n) for x in np.logspace(x0, x1, n)]
    started = time.perf_counter()
    simulate_many(cfgs)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=200)
    parser.add_argument("--simulated", type=int, default=16)
    args = parser.parse_args()
    for case in CASES:
        mfcontrol.analyze_region(case, _axes(case, 4))  # warm-up: imports, kernels
        _simulated(case, 2)
        started = time.perf_counter()
        reg = mfcontrol.analyze_region(case, _axes(case, args.size))
        region_s = time.perf_counter() - started
        sim_s = _simulated(case, args.simulated)
        per_region = region_s / reg.stable.size
        per_sim = sim_s / args.simulated ** 2
        print(f"{case}: region {args.size} x {args.size} in {region_s:.1f} s "
              f"({per_region * 1e3:.3f} ms a cell, {int(reg.stable.sum()):,} stable); "
              f"simulated {args.simulated} x {args.simulated} in {sim_s:.1f} s "
              f"({per_sim * 1e3:.2f} ms a member); the analysis is "
              f"{per_sim / per_region:.1f}x faster a cell")


if __name__ == "__main__":
    main()
