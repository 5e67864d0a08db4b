"""
An i-P in your own sampling loop, as with simple-pid
====================================================

A DC motor's speed w (rad/s) under voltage v: ``J w' = k i - b w - load``,
``L i' = v - R i - k w``, integrated here with small Euler sub-steps to stand for "the
real world". Every 1 ms the loop reads the speed, calls the controller, and applies the
voltage. On the way: the sensor drops out (NaN) for 5 ms (the controller holds its
output and counts the events), and at t = 0.3 s the controller's state is saved and
restored into a fresh controller, as after a restart, and control continues without a
bump.

Run: ``python examples/live_loop.py [figure.png]``
(default figure: ``results/examples/live_loop.png``)
"""

import json
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

import mfcontrol

J, B, K, R, L = 0.002, 0.01, 0.1, 1.0, 0.5e-3  # up to 120 rad/s at 24 V


def motor(w, i, v, load, dt, substeps=20):
    h = dt / substeps
    for _ in range(substeps):
        w, i = w + h * (K * i - B * w - load) / J, i + h * (v - R * i - K * w) / L
    return w, i


def main(path: str | Path = Path("results", "examples", "live_loop.png")):
    h = 1e-3
    # w' ~ K/(J R) v = 50 v: alpha = 50; kp = 30 1/s sets the error decay. No integral
    # term: F_hat absorbs the load torque, the i-P needs no I action to reject it.
    ctrl = mfcontrol.IP(alpha=50.0, kp=30.0, sample_time=h, output_limits=(-24, 24))
    w = i = 0.0
    log = []
    for k in range(700):
        t = k * h
        load = 0.02 if t >= 0.4 else 0.0
        measured = np.nan if 0.2 <= t < 0.205 else w
        if k == 300:  # save, "restart", restore
            snap = json.loads(json.dumps(ctrl.snapshot()))
            ctrl = mfcontrol.IP.from_snapshot(snap)
        v = ctrl(measured, setpoint=60.0 if t < 0.5 else 30.0)
        log.append((t, w, 60.0 if t < 0.5 else 30.0, v))
        w, i = motor(w, i, v, load, h)
    t, w, r, v = np.array(log).T
    fig = Figure(figsize=(8, 5.8), layout="constrained")
    ax = fig.subplots(2, 1, sharex=True)
    ax[0].plot(t * 1e3, w, color="tab:red", label="speed $\\omega$")
    ax[0].plot(t * 1e3, r, "--", color="tab:blue", label="setpoint $\\omega^*$")
    ax[0].set_ylabel("speed $\\omega$ (rad/s)")
    ax[0].legend()
    ax[1].plot(t * 1e3, v, color="tab:green")
    ax[1].set_ylabel("voltage $v$ (V)")
    ax[1].set_xlabel("time $t$ (ms)")
    for a in ax:
        a.grid(True, alpha=0.3)
        a.axvspan(200, 205, color="0.85")
        a.axvline(300, color="0.6", ls=":")
        a.axvline(400, color="0.6", ls="-.")
    fig.suptitle("i-P in a hand-written loop: sensor dropout (shaded), state restored "
                 "(dotted), load step (dash-dot)", fontsize=10)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    err = abs(w[-1] - r[-1])
    print(f"motor i-P: final error {err:.2e} rad/s, NaN readings held: {ctrl.nan_count}, "
          f"wrote {path}")
    return t, w, r, v, ctrl


if __name__ == "__main__":
    main(*sys.argv[1:2])
