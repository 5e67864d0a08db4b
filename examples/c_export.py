"""
The controller in C, bit for bit
================================

``mfcontrol.export_c`` writes a case's controller as dependency-free C99 (a header and
a source file), translated from the same law functions the simulators run. This example
exports the i-PI of ``motor-noise-ipi-algebraic`` (a DC motor's speed loop at 1 kHz:
``alpha = 50``, ``kp = 20``, ``ki = 50``, the algebraic estimator of F over 40 samples,
output limited to ±24 V), compiles it with a small test harness using the system C
compiler (``cc -std=c99 -O2 -ffp-contract=off``, in a temporary folder), and runs one
measurement sequence through the C controller and through the Python live controller
(``mfcontrol.make_controller``).

The sequence is the case's own run: 10,000 noisy speed readings (0.5 rad/s of sensor
noise) and its setpoint, with a sensor dropout of five NaN readings at 3 s, which both
controllers must reject by holding their last output (u holds its starting value for
the first 40 samples, while the estimator's window fills; the step of u at 5 s answers
the case's load torque). The numbers cross the process
boundary as hexadecimal floats (``float.hex`` in, ``%a`` out), so nothing is rounded
on the way.

What the run gives. The C outputs equal the Python outputs bit for bit: the largest
difference over the 10,000 samples is 0.0 V, and both counted the 5 rejected readings.
Before the dropout the Python controller also returns exactly the ``u`` of the case's
simulated run, which fed it the same readings. Without a C compiler the example says
so in one line and draws the Python side only.

Run: ``python examples/c_export.py [figure.png]``
(default figure: ``results/examples/c_export.png``)
"""

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

import mfcontrol

CASE = "motor-noise-ipi-algebraic"
DROPOUT = slice(3000, 3005)  # samples whose reading is lost (NaN)
LOAD_TIME = 5.0  # s: the case's load torque steps in

HARNESS = r"""
#include <stdio.h>
#include <stdlib.h>
#include "motor.h"

/* one "y setpoint" pair per line (hexadecimal floats) in, one control per line out */
int main(void) {
    motor_state s;
    char y[64], r[64];
    motor_init(&s);
    while (scanf("%63s %63s", y, r) == 2)
        printf("%a\n", motor_step(&s, strtod(y, NULL), strtod(r, NULL)));
    printf("rejected %lu\n", s.nan_count);
    return 0;
}
"""


def _compiler() -> str | None:
    for name in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def run_c(measured: np.ndarray, setpoints: np.ndarray) -> tuple[np.ndarray, int] | str:
    """The exported controller's outputs and rejected count, or why it could not run."""
    cc = _compiler()
    if cc is None:
        return "no C compiler found (cc, gcc, clang or $CC)"
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        mfcontrol.export_c(CASE, out=folder, prefix="motor")
        (folder / "harness.c").write_text(HARNESS)
        build = subprocess.run([cc, "-std=c99", "-O2", "-ffp-contract=off", "harness.c",
                                "motor.c", "-lm", "-o", "harness"], cwd=folder,
                               capture_output=True, text=True)
        if build.returncode != 0:
            return f"the C compiler {cc} failed: {build.stderr.strip().splitlines()[-1:]}"
        feed = "".join(f"{y.hex()} {r.hex()}\n" for y, r in zip(measured, setpoints,
                                                                 strict=True))
        ran = subprocess.run([str(folder / "harness")], input=feed, capture_output=True,
                             text=True, check=True)
    lines = ran.stdout.split()
    rejected = int(lines[-1])
    return np.array([float.fromhex(v) for v in lines[:-2]]), rejected


def main(path: str | Path = Path("results", "examples", "c_export.png")) -> dict:
    run = mfcontrol.run_case(CASE)
    measured = run.signals["y_meas"].copy()
    measured[DROPOUT] = np.nan
    setpoints = run.signals["y_ref"]

    ctrl = mfcontrol.make_controller(CASE)
    u_py = np.array([ctrl(y, setpoint=r) for y, r in zip(measured, setpoints, strict=True)])
    same_as_run = bool(np.array_equal(u_py[:DROPOUT.start], run.signals["u"][:DROPOUT.start]))

    c_side = run_c(measured, setpoints)
    out = {"u_python": u_py, "python_rejected": ctrl.nan_count, "same_as_run": same_as_run,
           "u_c": None, "c_rejected": None, "max_diff": None, "note": None}
    if isinstance(c_side, str):
        out["note"] = c_side
    else:
        out["u_c"], out["c_rejected"] = c_side
        out["max_diff"] = float(np.max(np.abs(out["u_c"] - u_py)))

    t = run.time
    fig = Figure(figsize=(10, 8), layout="constrained")
    ax = fig.subplots(3, 1, sharex=True, height_ratios=(1, 1, 0.7))
    ax[0].plot(t, measured, color="0.55", lw=0.5, label="measured speed (0.5 rad/s noise)")
    ax[0].plot(t, setpoints, color="k", ls="--", lw=1.0, label="setpoint")
    ax[0].set_ylabel(r"speed $\omega$ (rad/s)")
    ax[0].set_title("the measurement sequence fed to both controllers", fontsize=10)
    ax[0].legend(fontsize=8, loc="lower right")
    ax[1].plot(t, u_py, color="tab:blue", lw=2.2, alpha=0.5, label="Python live controller")
    if out["u_c"] is not None:
        ax[1].plot(t, out["u_c"], color="tab:red", lw=0.6, label="exported C, compiled")
    ax[1].set_ylabel("voltage $u$ (V)")
    ax[1].set_title("the controllers' outputs", fontsize=10)
    ax[1].legend(fontsize=8, loc="upper right")
    if out["u_c"] is not None:
        ax[2].plot(t, (out["u_c"] - u_py) * 1e12, color="tab:purple", lw=1.0)
        ax[2].set_ylim(-1, 1)
        ax[2].set_title(f"difference, C minus Python: largest |difference| "
                        f"{out['max_diff']:g} V over {len(t):,} samples (bit for bit)",
                        fontsize=10)
    else:
        ax[2].text(0.5, 0.5, out["note"] + ": the C side was not run", ha="center",
                   va="center", transform=ax[2].transAxes)
        ax[2].set_title("difference, C minus Python", fontsize=10)
    ax[2].set_ylabel("$u_C - u_{Python}$ (pV)")
    ax[2].set_xlabel("time $t$ (s)")
    for a in ax:
        a.grid(True, alpha=0.3)
        a.axvline(t[DROPOUT.start], color="tab:orange", lw=0.8, ls=":")
        a.axvline(LOAD_TIME, color="0.45", lw=0.8, ls=":")
    ax[0].annotate("load torque 0.05 N m", xy=(LOAD_TIME, 0.05),
                   xycoords=("data", "axes fraction"), xytext=(4, 0),
                   textcoords="offset points", fontsize=8, color="0.3")
    ax[0].annotate("sensor dropout:\n5 NaN readings", xy=(t[DROPOUT.start], 0.08),
                   xycoords=("data", "axes fraction"), xytext=(4, 0),
                   textcoords="offset points", fontsize=8, color="tab:orange")
    fig.suptitle(f"The i-PI of {CASE} exported to C99 and run on the same readings")
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)

    if out["note"] is not None:
        print(f"{out['note']}: drew the Python side only; wrote {path}")
    else:
        print(f"C export of {CASE}: largest |u_C - u_Python| {out['max_diff']:g} V over "
              f"{len(t):,} samples, rejected readings C {out['c_rejected']} / Python "
              f"{out['python_rejected']}; Python equals the simulated run before the dropout: "
              f"{same_as_run}; wrote {path}")
    return out


if __name__ == "__main__":
    main(*sys.argv[1:2])
