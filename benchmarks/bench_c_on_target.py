"""What an exported controller costs on a Cortex-M: code size and instructions per step,
mean and worst, for the Cortex-M4F (float, its FPU) and the Cortex-M0 (float and double in
software), and the PID and the backward-difference i-PID in fixed point (q31) on both,
beside the x86 figures of ``bench_c_export.py`` (same controllers).

Each export is cross-compiled with Debian's arm-none-eabi-gcc (``-O2`` and the export's
flags), its object's ``text`` read with ``arm-none-eabi-size``, and driven with its case's
closed-loop samples under ``qemu-system-arm -singlestep -d exec``, which logs every
instruction the emulated core executes: the instructions between two markers around each
step, less those around a call of an empty function of the same signature, are the
step's. These are instructions, not cycles (qemu does not model timing; on an M4F most
instructions take one cycle, loads, divisions and the FPU's divide take more, and the M0's
software floating point is almost all single-cycle ALU work). The M0 build runs on the
Cortex-M3 of ``mps2-an385``, which executes ARMv6-M code as an M0 would (qemu has no M0
board with the RAM). With the algebraic estimator, the run spans two resyncs (2M + 2
samples). Needs arm-none-eabi-gcc, libnewlib-arm-none-eabi and qemu-system-arm. Run::

    python benchmarks/bench_c_on_target.py
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import numpy as np

import mfcontrol
from bench_c_export import CONTROLLERS, closed_loop
from mfcontrol.cexport import CFLAGS, c_source, cortex_m
from mfcontrol.cexport.fixed_point import code
from mfcontrol.cexport.translate import Options

TARGETS = [("Cortex-M4F", "m4f", "float"), ("Cortex-M0", "m0", "float"),
           ("Cortex-M0", "m0", "double"), ("Cortex-M4F", "m4f", "q31"),
           ("Cortex-M0", "m0", "q31")]  # (label, mfcontrol.cexport.cortex_m target, real)
#: the controllers measured in fixed point (q31 exports the PID and the i-P family with the
#: backward difference; the measurement range it needs is the run's largest |y| or |r| up
#: to a power of two)
Q31_LAWS = ("PID", "i-PID, backward difference")
BASELINE = 3  # calls of the empty function first

_MAIN = r"""
#include <stdio.h>
#include "mfc.h"
#include "samples.h"

__attribute__((noinline)) void mark_before(void) { __asm volatile (""); }
__attribute__((noinline)) void mark_after(void) { __asm volatile (""); }
__attribute__((noinline)) static mfc_real nothing(mfc_state *s, mfc_real y, mfc_real r)
{
    (void)s; (void)y;
    return r;
}

int main(void)
{
    static mfc_state s;
    mfc_real (*volatile step)(mfc_state *, mfc_real, mfc_real) = nothing;
    volatile mfc_real sink;
    long i;
    mfc_init(&s);
    for (i = 0; i < @BASELINE@ + N_SAMPLES; i++) {
        long k = i < @BASELINE@ ? 0 : i - @BASELINE@;
        if (i == @BASELINE@) step = mfc_step;
        mark_before();
        sink = step(&s, Y[k], R[k]);
        mark_after();
    }
    (void)sink;
    printf("done\n");
    return 0;
}
"""


def _samples_header(y: np.ndarray, r: np.ndarray, real: str, scale: float = 1.0) -> str:
    if real == "q31":  # the codes, at the export's measurement scale
        def row(values):
            return ",\n".join(f"    {code(float(v), scale)}" for v in values)
        return ("typedef mfc_q31 mfc_real;\n"
                f"#define N_SAMPLES {len(y)}L\n"
                f"static const mfc_real Y[{len(y)}] = {{\n{row(y)}\n}};\n"
                f"static const mfc_real R[{len(r)}] = {{\n{row(r)}\n}};\n")
    # each sample as the export writes its constants: the value in its real type, exact
    literal = Options("mfc", real, "", {}).literal

    def row(values):
        return ",\n".join(f"    {literal(float(v))}" for v in values)
    return (f"#define N_SAMPLES {len(y)}L\n"
            f"static const mfc_real Y[{len(y)}] = {{\n{row(y)}\n}};\n"
            f"static const mfc_real R[{len(r)}] = {{\n{row(r)}\n}};\n")


def _count(trace: Path, before: int, after: int) -> list[int]:
    """Instructions between each entry of mark_before and the next of mark_after."""
    counts, inside, n = [], False, 0
    pc = re.compile(rb"\[[0-9a-f]+/([0-9a-f]+)/")
    with open(trace, "rb") as log:
        for line in log:
            m = pc.search(line)
            if m is None:
                continue
            addr = int(m.group(1), 16)
            if addr == before:
                inside, n = True, 0
            elif addr == after and inside:
                counts.append(n)
                inside = False
            elif inside:
                n += 1
    return counts


def measure(case: str, overrides: dict, real: str, target: str,
            folder: Path, frozen: bool = False) -> tuple[int, float, int, int]:
    """(text bytes, mean instructions per steady step, worst step, its sample)."""
    ctrl = mfcontrol.make_controller(case, overrides)
    M = ctrl._params.get("window") if ctrl._params.get("estimator") == "algebraic" else None
    n = 2 * M + 2 if M else 100
    y, r = closed_loop(case, overrides, n)
    scale = 1.0
    if real == "q31":
        span = 2.0 ** math.ceil(math.log2(max(np.abs(y).max(), np.abs(r).max())))
        ctrl._take_input_limits((-span, span))
        scale = 2.0 * span  # Y_SCALE: twice the input limits' magnitude
    src = c_source(ctrl, real=real, prefix="mfc", frozen=frozen)
    (folder / "mfc.h").write_text(src.header)
    (folder / "mfc.c").write_text(src.source)
    (folder / "samples.h").write_text(_samples_header(y, r, real, scale))
    flags, _ = cortex_m.TARGETS[target]
    subprocess.run(["arm-none-eabi-gcc", *flags, *CFLAGS, "-c", "mfc.c", "-o", "mfc.o"],
                   cwd=folder, check=True)
    text = int(subprocess.run(["arm-none-eabi-size", "mfc.o"], cwd=folder, check=True,
                              capture_output=True, text=True).stdout.splitlines()[1].split()[0])
    cortex_m.build(folder, target, ["mfc.o"], _MAIN.replace("@BASELINE@", str(BASELINE)))
    symbols = dict(line.split()[::2][::-1] for line in subprocess.run(
        ["arm-none-eabi-nm", "drive.elf"], cwd=folder, check=True, capture_output=True,
        text=True).stdout.splitlines() if len(line.split()) == 3)
    before, after = (int(symbols[name], 16) & ~1 for name in ("mark_before", "mark_after"))
    trace = folder / "trace.fifo"
    os.mkfifo(trace)
    counts: list[int] = []
    reader = threading.Thread(target=lambda: counts.extend(_count(trace, before, after)))
    reader.start()
    subprocess.run([*cortex_m.qemu_command(folder / "drive.elf", target), "-singlestep",
                    "-d", "exec,nochain", "-D", str(trace)], cwd=folder, check=True,
                   capture_output=True, timeout=3600)
    reader.join()
    overhead = min(counts[:BASELINE])
    steps = np.array(counts[BASELINE:]) - overhead
    steady = steps[(M + 1 if M else 2):]
    worst = int(np.argmax(steps))
    return text, float(steady.mean()), int(steps[worst]), worst


def main() -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frozen", action="store_true", help="the frozen exports (every "
                        "parameter a constant, no setter) instead of the tunable ones")
    parser.add_argument("--real", choices=sorted({real for _, _, real in TARGETS}),
                        help="only this number type (default: every one)")
    parser.add_argument("labels", nargs="*", help="only the controllers whose label starts "
                        "with one of these (default: every one), e.g. PID")
    args = parser.parse_args()
    missing = cortex_m.missing_tools()
    if missing:
        sys.exit(f"bench_c_on_target: needs {', '.join(missing)} (Debian: "
                 f"{cortex_m.PACKAGES})")
    print(f"instructions per step under qemu, {'frozen' if args.frozen else 'tunable'} "
          f"exports compiled with arm-none-eabi-gcc {' '.join(CFLAGS)}")
    print(f"{'controller':<50} {'target':<11} {'real':<7} {'text (bytes)':>12} "
          f"{'mean':>8} {'worst':>8} {'at sample':>10}")
    with tempfile.TemporaryDirectory() as tmp:
        for label, case, overrides in CONTROLLERS:
            if args.labels and not label.startswith(tuple(args.labels)):
                continue
            for name, target, real in TARGETS:
                if args.real and real != args.real:
                    continue
                if real == "q31" and not label.startswith(Q31_LAWS):
                    continue
                if real == "q31" and "filter" in label:  # no measurement filter in q31 yet
                    continue
                folder = Path(tmp) / f"{case}-{len(overrides)}-{target}-{real}"
                folder.mkdir()
                text, mean, worst, at = measure(case, overrides, real, target, folder,
                                                frozen=args.frozen)
                print(f"{label:<50} {name:<11} {real:<7} {text:>12,} {mean:>8,.0f} "
                      f"{worst:>8,} {at:>10}", flush=True)


if __name__ == "__main__":
    main()
