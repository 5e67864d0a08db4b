"""What your own ODE costs to compile: the first time on a machine, in a second process,
and as a second plant object in one process.

The plant is the DC motor of the README and the user guide's own-plant page, ``f`` in
place and ``g``, written to a module file in a temporary folder. Each round writes it with
a new comment in ``f`` (a new identity: nothing of it is in numba's cache yet) and runs
two fresh processes on one numba cache of its own (``NUMBA_CACHE_DIR`` in a temporary
folder, so the machine's cache plays no part):

* first ever     the first process, first plant object: ``ODE(f, g, ...)``, its
                 ``engine()`` (the single-run functions) and its block functions (the
                 vectorised loop's), compiled;
* second object  the same process, a second ``ODE(f, g, ...)`` from the same functions
                 (other initial state and parameters), the same three steps;
* warm process   the second process, first plant object: the same three steps, with the
                 first process's compiled code in numba's disk cache.

Nothing runs the engine, whose kernels are not compiled here. Before the steps each
process imports the package and compiles a one-line function, numba's start-up that any
run pays (about half a second), printed apart. Each step is timed as wall
time and as the process's CPU time (less disturbed by other work on a shared machine);
the medians over the rounds are printed with the ratios of the first-ever compile to the
other two. The script checks that the warm process loaded every function from the cache
(numba's ``cache_hits``) and says so when it did not (as before the ODE's functions had an
identity). Timings are printed, never asserted.

Run it with::

    python benchmarks/bench_ode_compile.py [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

PLANT = '''
def motor(t, x, u, p, dxdt):
    # round {round}
    dxdt[0] = (p[2] * x[1] - p[1] * x[0] - p[5]) / p[0]
    dxdt[1] = (u - p[3] * x[1] - p[2] * x[0]) / p[4]


def speed(x, p):
    return x[0]
'''

CHILD = '''
import json
import sys
import time

import numba

from mfcontrol import ODE

sys.path.insert(0, sys.argv[1])
module = __import__(sys.argv[2])
params = {"J": 5e-4, "b": 1e-4, "k": 0.05, "R": 2.0, "L": 2e-3, "tau": 0.0}
# numba's start-up in a process (its compiler and target set up), which any run pays
# whatever it compiles or loads: measured apart
wall, cpu = time.perf_counter(), time.process_time()
numba.cfunc("float64(float64)")(lambda v: v + 1.0)
out = {"start-up": (time.perf_counter() - wall, time.process_time() - cpu)}
for which, x0 in (("first", (0.0, 0.0)), ("second", (1.0, 0.5))):
    wall, cpu = time.perf_counter(), time.process_time()
    plant = ODE(module.motor, module.speed, x0, params)
    engine = plant.engine()
    single = time.perf_counter() - wall, time.process_time() - cpu
    engine.block.step.address, engine.block.output.address
    total = time.perf_counter() - wall, time.process_time() - cpu
    functions = (*engine.functions[:2], engine.block.step, engine.block.output)
    out[which] = {"single": single, "total": total,
                  "hits": [getattr(fn, "cfunc", fn).cache_hits for fn in functions]}
print(json.dumps(out))
'''


def _process(folder: Path, name: str, cache: Path) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    env.pop("NUMBA_DEBUG_CACHE", None)
    proc = subprocess.run([sys.executable, "-c", CHILD, str(folder), name],
                          capture_output=True, text=True, env=env, check=True, timeout=900)
    return json.loads(proc.stdout.splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=3, help="rounds of two processes")
    args = parser.parse_args(argv)
    rows: dict[str, list[dict]] = {"first ever": [], "second object": [], "warm process": []}
    start_up: list[float] = []
    loaded = True
    with tempfile.TemporaryDirectory() as tmp:
        folder, cache = Path(tmp), Path(tmp) / "numba-cache"
        for k in range(args.rounds):
            name = f"bench_ode_plant_{k}"
            (folder / f"{name}.py").write_text(PLANT.format(round=f"{k} {os.getpid()}"))
            cold = _process(folder, name, cache)
            warm = _process(folder, name, cache)
            rows["first ever"].append(cold["first"])
            rows["second object"].append(cold["second"])
            rows["warm process"].append(warm["first"])
            start_up += [cold["start-up"][1], warm["start-up"][1]]
            loaded &= warm["first"]["hits"] == [1, 1, 1, 1]
            print(f"round {k + 1}/{args.rounds}: first ever {cold['first']['total'][0]:.2f} s, "
                  f"warm process {warm['first']['total'][0]:.3f} s", file=sys.stderr)

    def median(which: str, part: str, clock: int) -> float:
        return statistics.median(r[part][clock] for r in rows[which])

    print(f"Your own ODE (the user guide's DC motor), medians of {args.rounds} rounds; "
          "single: ODE(...) and engine(), total: with the block functions")
    print(f"{'':16}{'single wall':>13}{'single CPU':>12}{'total wall':>12}{'total CPU':>11}"
          f"{'first / this (CPU)':>20}")
    first_cpu = median("first ever", "total", 1)
    for which in rows:
        cells = [median(which, part, clock) for part in ("single", "total") for clock in (0, 1)]
        ratio = first_cpu / max(cells[3], 1e-9)
        print(f"{which:16}" + "".join(f"{c * 1e3:>10.1f} ms" if i % 2 == 0
                                      else f"{c * 1e3:>9.1f} ms" for i, c in enumerate(cells))
              + f"{ratio:>19.0f}x")
    print(f"numba's start-up in every process, apart: {statistics.median(start_up) * 1e3:.0f} "
          "ms CPU (median)")
    print("warm process: every function loaded from numba's disk cache" if loaded else
          "warm process: NOT every function was loaded from numba's disk cache (cache_hits)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
