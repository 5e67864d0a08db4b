"""The exported C on Cortex-M: cross-compiled with Debian's arm-none-eabi-gcc and newlib,
run under qemu-system-arm, and compared bit for bit with the same export built for this
machine (and, in double, with the Python controller).

Targets: a Cortex-M4F (``mps2-an386``) with its single-precision FPU, for the float
export; code built for the Cortex-M0 (ARMv6-M, no FPU: float and double in software), for
both exports. qemu has no Cortex-M0 board with enough RAM for the test's data, so the M0
code runs on the Cortex-M3 of ``mps2-an385``, whose instruction set contains ARMv6-M's:
the instructions and the software arithmetic are the M0 build's; the timing is not.

The operations are compiled into the program (hexadecimal floating literals, exact); the
program prints the bits of every output through semihosting. Skipped without the tools
unless MFCONTROL_REQUIRE_ARM=1 (CI installs them and sets it).
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import mfcontrol
from mfcontrol.cexport import c_source, cortex_m
from mfcontrol.cexport.translate import Options

from . import harness as H
from .test_source import INTELLIGENT, RECURSIVE, operations

#: every law family, the options that change its arithmetic most, on each target and real
CASES = [
    (RECURSIVE, {}),
    (RECURSIVE, {"controller.law": "variational", "controller.integrator": "second-order"}),
    (INTELLIGENT, {}),
    (INTELLIGENT, {"controller.law": "i-PID", "controller.order": 2, "controller.kd": 0.5,
                   "controller.window": 20, "controller.adapt": "variational",
                   "controller.gamma0": 0.02, "controller.Gamma": 1e-9}),
    (INTELLIGENT, {"controller.law": "i-PD", "controller.order": 2, "controller.kd": 1.0,
                   "controller.estimator": "backward-difference"}),
    ("motor-noise-pid", {"controller.kd": 0.05, "controller.N": 5.0, "controller.b": 0.5}),
]
BUILDS = [("m4f", "float"), ("m0", "float"), ("m0", "double")]

_MAIN = r"""
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "@P@.h"
#include "ops.h"

int main(void)
{
    static @P@_state s;
    long i;
    @P@_init(&s);
    for (i = 0; i < N_OPS; i++) {
        if (OPS[i][0] == 0.0) {
            double u = (double)@P@_step(&s, (@P@_real)OPS[i][1], (@P@_real)OPS[i][2]);
            unsigned long w[2];
            memcpy(w, &u, sizeof w);
            printf("u %08lx%08lx\n", w[1], w[0]);
        } else if (OPS[i][0] == 1.0) {
            @P@_set_manual(&s, (@P@_real)OPS[i][1]);
        } else {
            @P@_set_auto(&s);
        }
    }
    printf("nan_count %lu\n", s.nan_count);
    return 0;
}
"""


def _require_tools() -> None:
    missing = cortex_m.missing_tools()
    if missing:
        if os.environ.get("MFCONTROL_REQUIRE_ARM"):
            pytest.fail(f"{', '.join(missing)} missing (Debian: {cortex_m.PACKAGES})")
        pytest.skip(f"no {', '.join(missing)} on this machine")


def _ops_header(ops: np.ndarray) -> str:
    literal = Options("t", "double", "", {}).literal  # as the export writes its constants
    rows = ",\n".join("{" + ", ".join(literal(float(v)) for v in row) + "}" for row in ops)
    return (f"#define N_OPS {len(ops)}L\n"
            f"static const double OPS[{len(ops)}][3] = {{\n{rows}\n}};\n")


def run_on_target(src, target: str, folder: Path, ops: np.ndarray) -> tuple[np.ndarray, int]:
    """The outputs and nan_count of the export on ``target`` under qemu."""
    _require_tools()
    flags, _ = cortex_m.TARGETS[target]
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{src.prefix}.h").write_text(src.header)
    (folder / f"{src.prefix}.c").write_text(src.source)
    (folder / "ops.h").write_text(_ops_header(ops))
    # the export under the tests' warnings; the driver without -Wconversion
    subprocess.run(["arm-none-eabi-gcc", *flags, *H.CFLAGS, "-c",
                    str(folder / f"{src.prefix}.c"), "-o", str(folder / "controller.o")],
                   check=True, timeout=600)
    elf = cortex_m.build(folder, target, ["controller.o"], _MAIN.replace("@P@", src.prefix))
    done = subprocess.run(cortex_m.qemu_command(elf, target), capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    lines = done.stdout.splitlines()
    u = np.array([int(line[2:], 16) for line in lines if line.startswith("u ")],
                 dtype=np.uint64).view(np.float64)
    count = next(int(line.split()[1]) for line in lines if line.startswith("nan_count"))
    return u, count


@pytest.mark.parametrize("target,real", BUILDS, ids=[f"{t}-{r}" for t, r in BUILDS])
@pytest.mark.parametrize("case,overrides", CASES,
                         ids=[c + "".join(f"-{k.split('.')[-1]}={v}" for k, v in o.items())
                              for c, o in CASES])
def test_the_export_computes_the_same_bits_on_cortex_m(case, overrides, target, real,
                                                       tmp_path):
    ops = operations(case)
    src = c_source(mfcontrol.make_controller(case, overrides), real=real)
    u_arm, nan_arm = run_on_target(src, target, tmp_path / "arm", ops)
    u_x86, nan_x86 = H.run_binary(H.build(src, tmp_path / "x86"), ops)
    assert u_arm.shape == u_x86.shape
    differ = np.flatnonzero(u_arm.view(np.int64) != u_x86.view(np.int64))
    assert differ.size == 0, f"first difference at step {differ[0]}: " \
                             f"{target} {u_arm[differ[0]]!r}, x86 {u_x86[differ[0]]!r}"
    assert nan_arm == nan_x86
    if real == "double":  # and so the Python controller's
        u_py, _ = H.run_python(mfcontrol.make_controller(case, overrides), ops)
        assert np.array_equal(u_arm.view(np.int64), u_py.view(np.int64))
