"""Tuning a realistic loop: loops a second of ``mfcontrol.tune`` on
``motor-noise-ipi-algebraic`` (the DC motor with Gaussian sensor noise and a load step
under the i-PI with the algebraic estimator, window 40; 10,000 samples a run), against
single runs of the same case (``mfcontrol.simulate``) in the same process.

Two searches, each of kp in 5..40 and ki in 10..100 with the tuner's defaults
(differential evolution, 30 points a generation, 15 per key): on the case alone
(one run a point) and on four noise seeds (``--scenarios sensor.seed=1,2,3,4``: four runs
a point). A generation's runs go through the sweep engine together, so the tuner's loops
a second against a single run's say what the batch gains. Only the public API is used,
so the script runs on earlier versions of the library too (``PYTHONPATH``). Timings are
printed, never asserted. Run::

    python benchmarks/bench_tune_realistic.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time

import mfcontrol
from mfcontrol.experiments.cases import resolve_case

CASE = "motor-noise-ipi-algebraic"
PARAMS = ["controller.kp=5:40", "controller.ki=10:100"]
SEARCHES = {"the case alone": (300, None), "4 noise seeds": (150, ["sensor.seed=1,2,3,4"])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="rounds (default 3)")
    args = parser.parse_args()
    _, cfg = resolve_case(CASE)
    with tempfile.TemporaryDirectory() as out:
        # warm-up: compile or load the kernels of both paths
        mfcontrol.tune(CASE, PARAMS, budget=30, out=out)
        mfcontrol.tune(CASE, PARAMS, budget=30, out=out, scenarios=SEARCHES["4 noise seeds"][1])
        mfcontrol.simulate(cfg)
        rates: dict[str, list[float]] = {name: [] for name in (*SEARCHES, "single runs")}
        runs: dict[str, int] = {}
        for _ in range(args.repeats):
            for name, (budget, scenarios) in SEARCHES.items():
                t = time.perf_counter()
                r = mfcontrol.tune(CASE, PARAMS, budget=budget, out=out, scenarios=scenarios)
                rates[name].append(r.runs / (time.perf_counter() - t))
                runs[name] = r.runs
            t = time.perf_counter()
            for _ in range(20):
                mfcontrol.simulate(cfg)
            rates["single runs"].append(20 / (time.perf_counter() - t))
    single = statistics.median(rates["single runs"])
    print(f"mfcontrol {mfcontrol.__version__} ({mfcontrol.__file__}): {CASE}, "
          f"10,000 samples a run; medians of {args.repeats} rounds")
    print(f"  single runs (mfcontrol.simulate): {single:8,.0f} loops/s")
    for name in SEARCHES:
        rate = statistics.median(rates[name])
        print(f"  tune, {name:15s} ({runs[name]:,} runs): {rate:8,.0f} loops/s, "
              f"{rate / single:.1f}x single runs")


if __name__ == "__main__":
    main()
