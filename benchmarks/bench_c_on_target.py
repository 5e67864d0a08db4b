"""What an exported controller costs on a Cortex-M: code size, instructions and cycles per
step, mean and worst, for the Cortex-M4F (float, its FPU) and the Cortex-M0 (float and
double in software), the PID and the backward-difference i-PID in fixed point (q31) on
both, and the PID in q15 on the M0, beside the x86 figures of ``bench_c_export.py`` (same
controllers).

Each export is cross-compiled with Debian's arm-none-eabi-gcc (``-O2`` and the export's
flags), its object's ``text`` read with ``arm-none-eabi-size``, and driven with its case's
closed-loop samples under ``qemu-system-arm -singlestep -d exec``, which logs every
instruction the emulated core executes: the instructions between two markers around each
step, less those around a call of an empty function of the same signature, are the step's.
Three samples in a row at a third of the run are rejected (NaN; in fixed point a code beyond
the input limits): the worst step includes the one that spans them (a 64-bit division or two
in fixed point, the longer period's coefficients in float), the mean does not. qemu does not
model timing: the cycles are the Arm manuals' per-instruction counts applied to the
instructions executed (``mfcontrol.cexport.cortex_m_cycles``: no wait states; exact on the
M0 with its single-cycle multiplier; on the M4F a low and a high count, whose high one
bounds the step). A board's cycle counter (DWT CYCCNT) would measure them; this machine has
none. The M0 build runs on the Cortex-M3 of ``mps2-an385``, which executes ARMv6-M code as
an M0 would (qemu has no M0 board with the RAM). With the algebraic estimator, the run spans
two resyncs (2M + 2 samples). Needs arm-none-eabi-gcc, libnewlib-arm-none-eabi and
qemu-system-arm.

Run::

    python benchmarks/bench_c_on_target.py
"""

from __future__ import annotations

import math
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import mfcontrol
from bench_c_export import CONTROLLERS, closed_loop
from mfcontrol.cexport import CFLAGS, c_source, cortex_m, cortex_m_cycles
from mfcontrol.cexport.fixed_point import WORDS, code
from mfcontrol.cexport.translate import Options

TARGETS = [("Cortex-M4F", "m4f", "float"), ("Cortex-M0", "m0", "float"),
           ("Cortex-M0", "m0", "double"), ("Cortex-M4F", "m4f", "q31"),
           ("Cortex-M0", "m0", "q31"), ("Cortex-M0", "m0", "q15")]
# (label, mfcontrol.cexport.cortex_m target, real)
#: the controllers measured in fixed point (q31 exports the PID and the i-P family with the
#: backward difference; the measurement range it needs is the run's largest |y| or |r| up
#: to a power of two)
Q31_LAWS = ("PID", "i-PID, backward difference")  # the PID's variants too
#: and in q15 (the PID only: on a Cortex-M0, where its 32-bit products are one MULS each)
Q15_LAWS = ("PID",)
BASELINE = 3  # calls of the empty function first


DROPOUT = 3  # samples rejected in a row, at a third of the run


def _dropout(n: int) -> list[int]:
    """The samples of a run of ``n`` that are rejected."""
    return list(range(n // 3, n // 3 + DROPOUT))

_MAIN = r"""
#include <math.h>
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
    if real in WORDS:  # the codes, at the export's measurement scale
        def row(values):
            return ",\n".join(f"    {code(float(v), scale, WORDS[real].bits)}" for v in values)
        return (f"typedef mfc_{real} mfc_real;\n"
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


@dataclass
class Cost:
    """What one export costs per step on one target: its code size, then the mean over
    the steady steps and the worst over every step of its instructions and of the low and
    high cycle counts of :mod:`mfcontrol.cexport.cortex_m_cycles`, and the sample where
    the most instructions ran."""

    text: int
    instructions: tuple[float, int]
    low: tuple[float, int]
    high: tuple[float, int]
    worst_at: int


def measure(case: str, overrides: dict, real: str, target: str,
            folder: Path, frozen: bool = False, small_multiplier: bool = False) -> Cost:
    """What the export of ``case`` costs on ``target`` (closed-loop samples of its case)."""
    ctrl = mfcontrol.make_controller(case, overrides)
    M = ctrl._params.get("window") if ctrl._params.get("estimator") == "algebraic" else None
    n = 2 * M + 2 + DROPOUT if M else 100  # two resyncs, the dropout aside
    y, r = closed_loop(case, overrides, n)
    scale = 1.0
    if real in WORDS:
        span = 2.0 ** math.ceil(math.log2(max(np.abs(y).max(), np.abs(r).max())))
        ctrl._take_input_limits((-span, span))
        scale = 2.0 * span  # Y_SCALE: twice the input limits' magnitude
    # a dropout: rejected samples (NaN; in fixed point a code beyond the input limits), the
    # step that spans them, which the worst step includes
    dropout = _dropout(n)
    y = y.copy()
    y[dropout] = 4.0 * span if real in WORDS else math.nan
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
    # (instructions, low cycles, high cycles) per call
    counts = np.array(cortex_m_cycles.run(folder / "drive.elf", target,
                                          small_multiplier=small_multiplier))
    steps = counts[BASELINE:] - counts[:BASELINE].min(axis=0)  # less the empty call's
    ordinary = np.ones(len(steps), bool)  # the mean: neither the dropout nor its end
    ordinary[dropout + [dropout[-1] + 1]] = False
    steady = steps[ordinary & (np.arange(len(steps)) >= (M + 1 if M else 2))]

    def stat(column: int) -> tuple[float, int]:
        return float(steady[:, column].mean()), int(steps[:, column].max())
    return Cost(text, stat(0), stat(1), stat(2), int(np.argmax(steps[:, 0])))


def main() -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frozen", action="store_true", help="the frozen exports (every "
                        "parameter a constant, no setter) instead of the tunable ones")
    parser.add_argument("--small-multiplier", action="store_true", help="count the M0's "
                        "MULS at 32 cycles (the small multiplier some parts have), not 1")
    parser.add_argument("--real", choices=sorted({real for _, _, real in TARGETS}),
                        help="only this number type (default: every one)")
    parser.add_argument("labels", nargs="*", help="only the controllers whose label starts "
                        "with one of these (default: every one), e.g. PID")
    args = parser.parse_args()
    missing = cortex_m.missing_tools()
    if missing:
        sys.exit(f"bench_c_on_target: needs {', '.join(missing)} (Debian: "
                 f"{cortex_m.PACKAGES})")
    print(f"one step under qemu, {'frozen' if args.frozen else 'tunable'} exports compiled "
          f"with arm-none-eabi-gcc {' '.join(CFLAGS)}: instructions, and cycles from the "
          "TRM's timings (no wait states; on the M4F low..high, on the M0 exact), mean of the "
          "steady steps / worst of all")
    print(f"{'controller':<50} {'target':<11} {'real':<7} {'text (B)':>9} "
          f"{'instructions':>15} {'cycles':>28} {'worst at':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        for label, case, overrides in CONTROLLERS:
            if args.labels and not label.startswith(tuple(args.labels)):
                continue
            for name, target, real in TARGETS:
                if args.real and real != args.real:
                    continue
                if (real == "q31" and not label.startswith(Q31_LAWS)
                        or real == "q15" and not label.startswith(Q15_LAWS)):
                    continue
                folder = Path(tmp) / f"{case}-{len(overrides)}-{target}-{real}"
                folder.mkdir()
                c = measure(case, overrides, real, target, folder, frozen=args.frozen,
                            small_multiplier=args.small_multiplier)
                ins = f"{c.instructions[0]:,.0f} / {c.instructions[1]:,}"
                if c.low == c.high:
                    cyc = f"{c.high[0]:,.0f} / {c.high[1]:,}"
                else:
                    cyc = (f"{c.low[0]:,.0f}..{c.high[0]:,.0f} / "
                           f"{c.low[1]:,}..{c.high[1]:,}")
                print(f"{label:<50} {name:<11} {real:<7} {c.text:>9,} {ins:>15} {cyc:>28} "
                      f"{c.worst_at:>9}", flush=True)


if __name__ == "__main__":
    main()
