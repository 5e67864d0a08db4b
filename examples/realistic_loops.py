"""
Why the estimator of F matters: a DC motor with a noisy sensor
==============================================================

A DC motor's speed loop with a noisy sensor and a load step, under an i-PI with
backward differences, the same i-PI with the algebraic estimator, and a PI (the
discrete PID of Astrom and Hagglund), each also with 20 samples of actuator delay.

The three shipped cases (``mfcontrol cases``: ``motor-noise-ipi``,
``motor-noise-ipi-algebraic``, ``motor-noise-pid``) share the motor (J = 5e-4 kg m²,
Km = 0.05 N m/A, Ra = 2 ohm, La = 2 mH), a smooth step of the speed to 60 rad/s,
0.5 rad/s of Gaussian sensor noise, a 0.05 N m load torque from 5 s, a 1 kHz
controller and a ±24 V supply.

What it shows. The backward difference ``y'_k = (y_k - y_(k-1)) / h`` turns 0.5 rad/s
of noise into some 700 rad/s² of noise on F_hat, and the i-P's ``F_hat / alpha`` term
feeds it straight into u: u chatters from rail to rail (total variation about
136,000 V over 10 s, against about 2,800 V with the algebraic estimator and 1,100 V with
the PI). The algebraic estimator integrates over a window of 40 samples instead of
differentiating: it tracks best (IAE about 1, against 5 and 10) and rejects the load
fastest. A delay of 20 samples (20 ms) in the actuator destabilises both intelligent
controllers, whose loops act within a few samples, while the slower PI holds: the speed
of a loop is bought with its delay margin.

Run: ``python examples/realistic_loops.py [figure.png]``
(default figure: ``results/examples/realistic_loops.png``)
"""

import sys
from pathlib import Path

from matplotlib.figure import Figure

import mfcontrol

CASES = {
    "motor-noise-ipi": "i-PI, backward differences",
    "motor-noise-ipi-algebraic": "i-PI, algebraic estimator (M = 40)",
    "motor-noise-pid": "PI (Astrom-Hagglund)",
}
SHORT = {"motor-noise-ipi": "i-PI\nbackward", "motor-noise-ipi-algebraic": "i-PI\nalgebraic",
         "motor-noise-pid": "PI"}
COLOURS = ("tab:red", "tab:blue", "tab:green")
DELAY = 20  # samples of actuator delay for the second set of runs


def main(path: str | Path = Path("results", "examples", "realistic_loops.png")):
    runs = {name: mfcontrol.run_case(name) for name in CASES}
    delayed = {name: mfcontrol.run_case(name, overrides={"actuator.delay": DELAY})
               for name in CASES}
    fig = Figure(figsize=(11, 8.5), layout="constrained")
    grid = fig.add_gridspec(4, 2, width_ratios=(2.2, 1))
    speed = fig.add_subplot(grid[0, 0])
    first = next(iter(runs.values()))
    speed.plot(first.time, first.signals["y_ref"], color="k", ls="--", lw=1.0,
               label="reference")
    for (name, res), colour in zip(runs.items(), COLOURS, strict=True):
        speed.plot(res.time, res.signals["y"], color=colour, lw=0.7, label=CASES[name])
    speed.set_ylabel("speed $\\omega$ (rad/s)")
    speed.set_ylim(44, 66)
    speed.legend(fontsize=8, loc="lower left", bbox_to_anchor=(0.14, 0.0))
    speed.set_title("speed around 60 rad/s (load step at 5 s)", fontsize=10)
    for row, ((name, res), colour) in enumerate(zip(runs.items(), COLOURS, strict=True), 1):
        ax = fig.add_subplot(grid[row, 0], sharex=speed)
        ax.plot(res.time, res.signals["u"], color=colour, lw=0.4)
        ax.set_ylabel("voltage $u$ (V)")
        ax.set_ylim(-26, 26)
        ax.set_title(f"controller output: {CASES[name]}", fontsize=10)
    for ax in fig.axes:
        ax.grid(True, alpha=0.3)
        ax.axvline(5.0, color="tab:orange", lw=0.8, ls=":")
    fig.axes[-1].set_xlabel("time $t$ (s)")
    table = fig.add_subplot(grid[:, 1])
    table.axis("off")
    rows = []
    for name in CASES:
        m, d = runs[name].metrics, delayed[name].metrics
        rows.append([SHORT[name], f"{m['iae']:.2f}", f"{m['tv_u']:,.0f}",
                     f"{m['iae_load']:.2f}", "settled" if d["settled"] else "not settled"])
    t = table.table(cellText=rows, colLabels=["controller", "IAE\n(rad)", "TV(u)\n(V)",
                                              "IAE after\nload (rad)",
                                              f"{DELAY}-sample\ndelay"],
                    colWidths=(0.2, 0.13, 0.2, 0.22, 0.22), loc="upper center",
                    cellLoc="center")
    t.auto_set_font_size(False)
    t.set_fontsize(8)
    t.scale(1.0, 3.2)
    table.set_title("metrics over 10 s", fontsize=10)
    fig.suptitle("DC motor speed loop, 0.5 rad/s sensor noise: the estimator of F decides")
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return runs, delayed


if __name__ == "__main__":
    main(*sys.argv[1:2])
