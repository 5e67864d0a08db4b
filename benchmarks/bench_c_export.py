"""What an exported controller costs on a target: code size and instructions per call.

Each controller is exported (``mfcontrol.export_c``), compiled as the tests compile it
(``cc -std=c99 -O2 -ffp-contract=off``), its object's ``text`` size read with ``size``,
and its step driven with the case's own closed-loop measurements (10,000 samples) under
``valgrind --tool=callgrind --toggle-collect=PREFIX_step``: instructions counted inside
the step only, which repeat exactly from run to run (times on this shared machine do not).
With the algebraic estimator a step every M samples resyncs the moments (the export
spreads that work over the samples, so it copies them in); that step's count (what a
control interrupt's deadline must allow) and an ordinary one's come from runs of 2M - 2,
2M - 1 and 2M samples.
Each controller is measured in the default build, its gains and limits members of a
parameter struct that ``PREFIX_set_params`` changes at run time, and in the ``frozen``
build (every parameter a constant folded into the code, no setter).
The PIDs are measured against a PID written by hand (``handwritten/pid.c``: the same law,
its coefficients computed once, the memory written after the check instead of backed
up), driven with the same samples; the script checks that it returns the same bits (the
sums of the outputs are equal) and prints the export's instructions per call over its.
The Python live controller's time per call on the same samples is printed beside it for
scale. Needs cc, size and valgrind. Run (words after it: only the controllers whose label
starts with one, ``PID`` for the PIDs)::

    python benchmarks/bench_c_export.py
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import mfcontrol
from mfcontrol.cexport import CFLAGS, c_source

N = 10_000
IPID = {"controller.law": "i-PID", "controller.order": 2, "controller.kd": 0.5,
        "controller.ki": 50.0}
#: (label, case, overrides): the i-PID with the algebraic estimator first
CONTROLLERS = [
    ("i-PID, algebraic estimator (window 40), order 2", "motor-noise-ipi-algebraic", IPID),
    ("i-PI, algebraic estimator (window 40), order 1", "motor-noise-ipi-algebraic", {}),
    ("i-PID, backward difference, order 2", "motor-noise-ipi-algebraic",
     {**IPID, "controller.estimator": "backward-difference"}),
    ("paper's recursive i-P", "voltage-stable-standard", {}),
    ("paper's variational i-P", "voltage-stable-variational", {}),
    ("PID", "motor-noise-pid", {}),
    ("PID, kd 0.05, measurement filter Tf 2 ms", "motor-noise-pid",
     {"controller.kd": 0.05, "controller.Tf": 0.002}),
    ("ADRC, order 1", "motor-noise-adrc", {}),
    ("ADRC, order 2", "motor-noise-adrc", {"controller.order": 2, "controller.wc": 15.0,
                                           "controller.wo": 60.0}),
]

_MAIN = r"""
#include <stdio.h>
#include "mfc.h"
int main(void)
{
    static mfc_state s;
    double yr[2], sum = 0;
    mfc_init(&s);
    while (fread(yr, sizeof yr, 1, stdin) == 1) sum += (double)mfc_step(&s, yr[0], yr[1]);
    printf("%.17g\n", sum);
    return 0;
}
"""


def instructions(folder: Path, inputs: np.ndarray, function: str = "mfc_step") -> int:
    """Instructions executed inside ``function`` over the rows (y, r) of ``inputs``."""
    (folder / "input.bin").write_bytes(np.ascontiguousarray(inputs).tobytes())
    out = folder / "callgrind.out"
    with open(folder / "input.bin", "rb") as stdin:
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                        f"--toggle-collect={function}", "./drive"], cwd=folder, stdin=stdin,
                       check=True, capture_output=True)
    return int(re.search(r"^summary:\s+(\d+)", out.read_text(), flags=re.M).group(1))


def closed_loop(case: str, overrides: dict, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The measurements and setpoints of the first ``n`` samples of the case's run: what
    the exported controller is driven with."""
    _, cfg = mfcontrol.experiments.cases.resolve_case(case, overrides)
    run = mfcontrol.run_case(case, {**overrides, "sim.t_end": n * cfg["sim.h"]})
    return run.signals["y_meas"][:n], run.signals["y_ref"][:n]


def _sum_of_outputs(folder: Path, inputs: np.ndarray) -> str:
    """What ``folder/drive`` prints: the sum of its outputs over ``inputs``, exactly."""
    return subprocess.run(["./drive"], cwd=folder, input=np.ascontiguousarray(inputs)
                          .tobytes(), check=True, capture_output=True).stdout.decode().strip()


HANDWRITTEN = Path(__file__).parent / "handwritten"


def handwritten_pid(case: str, overrides: dict, folder: Path) -> tuple[int, float, str]:
    """(text bytes, instructions per call, the sum of its outputs) of the hand-written PID
    (``handwritten/pid.c``) with the case's parameters, on the case's samples."""
    from mfcontrol.laws import pid

    ctrl = mfcontrol.make_controller(case, overrides)
    cp = ctrl._CP[:, 0]

    def c(v: float) -> str:
        return repr(float(v)) if np.isfinite(v) else ("INFINITY" if v > 0 else "-INFINITY")
    values = [cp[row] for row in (pid.KP, pid.KI, pid.KD, pid.N, pid.B, pid.C, pid.TF,
                                  pid.TT, pid.OUT_MIN, pid.OUT_MAX)] + [ctrl.sample_time]
    (folder / "main.c").write_text(
        "#include <math.h>\n#include <stdio.h>\n#include \"pid.h\"\nint main(void)\n{\n"
        f"    static hpid s;\n    const hpid_params p = {{{', '.join(map(c, values))}}};\n"
        "    double yr[2], sum = 0;\n    hpid_init(&s, &p);\n"
        "    while (fread(yr, sizeof yr, 1, stdin) == 1) sum += hpid_step(&s, yr[0], yr[1]);\n"
        '    printf("%.17g\\n", sum);\n    return 0;\n}\n')
    subprocess.run(["cc", *CFLAGS, "-c", str(HANDWRITTEN / "pid.c"), "-o", "pid.o"],
                   cwd=folder, check=True)
    size = subprocess.run(["size", "pid.o"], cwd=folder, check=True, capture_output=True,
                          text=True).stdout.splitlines()[1].split()
    subprocess.run(["cc", *CFLAGS, "-g", "-I", str(HANDWRITTEN), "main.c",
                    str(HANDWRITTEN / "pid.c"), "-o", "drive", "-lm"], cwd=folder, check=True)
    y, r = closed_loop(case, overrides, N)
    yr = np.column_stack([y, r])
    return int(size[0]), instructions(folder, yr, "hpid_step") / N, _sum_of_outputs(folder, yr)


def measure(case: str, overrides: dict, real: str, folder: Path, frozen: bool = False):
    """(text bytes of the object, instructions per call, (ordinary step, resync step) or
    None, Python seconds per call, the sum of the outputs as the driver prints it)."""
    y, r = closed_loop(case, overrides, N)
    src = c_source(mfcontrol.make_controller(case, overrides), real=real, frozen=frozen)
    (folder / "mfc.h").write_text(src.header)
    (folder / "mfc.c").write_text(src.source)
    (folder / "main.c").write_text(_MAIN)
    subprocess.run(["cc", *CFLAGS, "-c", "mfc.c", "-o", "mfc.o"], cwd=folder, check=True)
    size = subprocess.run(["size", "mfc.o"], cwd=folder, check=True, capture_output=True,
                          text=True).stdout.splitlines()[1].split()
    subprocess.run(["cc", *CFLAGS, "-g", "main.c", "mfc.c", "-o", "drive", "-lm"], cwd=folder,
                   check=True)
    yr = np.column_stack([y, r])
    per_call = instructions(folder, yr) / N
    total = _sum_of_outputs(folder, yr)
    ctrl = mfcontrol.make_controller(case, overrides)
    steps = None
    if ctrl._params.get("estimator") == "algebraic":
        M = ctrl._params["window"]  # the step of sample 2M - 1 resyncs
        i0, i1, i2 = (instructions(folder, yr[:n]) for n in (2 * M - 2, 2 * M - 1, 2 * M))
        steps = (i1 - i0, i2 - i1)
    ys, rs = y.tolist(), r.tolist()  # plain floats, as a sensor read gives them
    mfcontrol.make_controller(case, overrides)(ys[0], setpoint=rs[0])  # compiled, warm
    t0 = time.perf_counter()
    for yk, rk in zip(ys, rs, strict=True):
        ctrl(yk, setpoint=rk)
    py = (time.perf_counter() - t0) / N
    return int(size[0]), per_call, steps, py, total


def main() -> None:
    missing = [tool for tool in ("cc", "size", "valgrind") if shutil.which(tool) is None]
    if missing:
        sys.exit(f"bench_c_export: needs {', '.join(missing)}")
    print(f"{N:,} calls each, compiled with cc {' '.join(CFLAGS)}")
    print(f"{'controller':<50} {'real':<7} {'build':<8} {'text (bytes)':>12} "
          f"{'instr/call':>11} {'ordinary':>9} {'resync':>7} {'Python us/call':>15}")
    with tempfile.TemporaryDirectory() as tmp:
        for label, case, overrides in CONTROLLERS:
            if sys.argv[1:] and not any(label.startswith(word) for word in sys.argv[1:]):
                continue
            per_build, sums = {}, {}
            for real in ("double", "float"):
                for build in ("tunable", "frozen"):
                    folder = Path(tmp) / f"{case}-{len(overrides)}-{real}-{build}"
                    folder.mkdir()
                    text, instr, steps, py, total = measure(case, overrides, real, folder,
                                                            frozen=build == "frozen")
                    if real == "double":
                        per_build[build], sums[build] = instr, total
                    ordinary, resync = ((f"{steps[0]:,}", f"{steps[1]:,}") if steps
                                        else ("", ""))
                    print(f"{label:<50} {real:<7} {build:<8} {text:>12,} {instr:>11,.0f} "
                          f"{ordinary:>9} {resync:>7} {py * 1e6:>15.2f}", flush=True)
            if case == "motor-noise-pid":
                folder = Path(tmp) / f"hand-{len(overrides)}"
                folder.mkdir()
                text, instr, total = handwritten_pid(case, overrides, folder)
                same = total == sums["tunable"] == sums["frozen"]
                print(f"{label + ', hand-written':<50} {'double':<7} {'':<8} {text:>12,} "
                      f"{instr:>11,.0f}   same bits: {'yes' if same else 'NO'}; the export "
                      f"over it: {per_build['tunable'] / instr:.2f}x tunable, "
                      f"{per_build['frozen'] / instr:.2f}x frozen", flush=True)


if __name__ == "__main__":
    main()
