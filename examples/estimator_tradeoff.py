"""
Estimating F: noise against delay
=================================

An intelligent controller acts on an estimate ``F_hat`` of the unknown part ``F`` of the
ultra-local model ``y' = F + alpha u``. This example measures, from closed-loop runs,
what each estimator of F costs: how much sensor noise reaches ``F_hat`` and how late
``F_hat`` sees a change of F.

The plant is ``y' = w + 50 u``, a speed (rad/s) under a voltage (V): a ``FirstOrder``
plant with ``a = 0``, ``b = 50`` and the disturbance ``w``, so the true F is ``w`` and
known exactly. It steps from 0 to 20 rad/s² at t = 0.5 s. An i-P (``alpha = 50``,
``kp = 10`` 1/s, 1 kHz) holds the speed at 60 rad/s, once with backward differences
and once with the algebraic estimator for each window M = 5, 10, 20, 40 and 80 samples.
Each runs twice: without noise, to measure the delay (the time ``F_hat`` takes to
reach half of the step, interpolated between samples), and with 0.004 rad/s of Gaussian
sensor noise, to measure the noise (the standard deviation of ``F_hat - F`` over the
steady 0.15 s to 0.5 s).

What the runs give. Backward differences see the step half a sample late (0.5 ms) and
turn the 0.004 rad/s of sensor noise into 5.5 rad/s² of noise on ``F_hat``, a quarter
of the step. The algebraic estimator trades one for the other: its delay is half its
window, exactly (2.5, 5, 10, 20 and 40 ms for M = 5, 10, 20, 40 and 80, with the default
``kernel="held"``; the literature's trapezoid kernel, which puts the held input half a
sample out of line, measures 2.3, 4.8 and 9.8 ms for the first three), and its noise
falls from 1.1 to 0.019 rad/s², as the delay to the power -1.49 (the slope fitted
through the five windows). With M = 80 the noise is nearly 300 times smaller than with
backward differences, for a delay 80 times longer. The dotted line and the cross are the
closed forms of the theory page (delay ``M h/2`` and noise
``2 sqrt(3) sigma / (h M^1.5)``; ``h/2`` and ``sqrt(2) sigma / h``): the measured noise
is within 3 % of them for backward differences and for M = 40 and 80, and within 10 %
for the short windows (9 % below at M = 5, 6 % above at M = 10 and 20), where the
sampled sum departs from the continuous integral and the loop feeds part of the noise
back. The window is the
knob that sets where a loop sits on this curve: long enough for the sensor's noise,
short against the loop's dynamics.

Run: ``python examples/estimator_tradeoff.py [figure.png]``
(default figure: ``results/examples/estimator_tradeoff.png``)
"""

import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

import mfcontrol
from mfcontrol import Change, FirstOrder, Sensor

H = 1e-3  # sample time (s)
GAIN = 50.0  # b of the plant and alpha of the i-P (rad/s^2 per V)
KP = 10.0  # 1/s
SPEED = 60.0  # setpoint and initial speed (rad/s)
F_STEP, T_STEP, T_END = 20.0, 0.5, 0.8  # rad/s^2, s, s
NOISE = 0.004  # sensor noise std (rad/s)
STEADY = (0.15, T_STEP)  # window where the noise is measured (s)
WINDOWS = (5, 10, 20, 40, 80)
SHOWN = {0: "tab:gray", 5: "tab:orange", 20: "tab:green", 80: "tab:blue"}  # panel (a)


def _run(window: int, noise: bool) -> mfcontrol.Result:
    """One closed-loop run; window 0 is backward differences."""
    est = {} if window == 0 else {"estimator": "algebraic", "window": window}
    ctrl = mfcontrol.IP(GAIN, KP, sample_time=H, **est)
    sensor = Sensor(noise="gaussian", noise_std=NOISE, seed=1) if noise else None
    return mfcontrol.simulate_loop(FirstOrder(a=0.0, b=GAIN, w=0.0, x0=SPEED), ctrl, SPEED,
                                   t_end=T_END, changes=[Change(T_STEP, "w", F_STEP)],
                                   sensor=sensor)


def _label(window: int) -> str:
    return "backward difference" if window == 0 else f"algebraic, M = {window}"


def measure(window: int) -> dict:
    """Delay (s) and noise (rad/s^2) of one estimator, measured from its runs."""
    clean, noisy = _run(window, False), _run(window, True)
    t = clean.time
    after = t >= T_STEP - 1e-9
    true_f = np.where(after, F_STEP, 0.0)
    f_hat = clean.signals["F_hat"]
    k = np.flatnonzero(after & (f_hat >= F_STEP / 2))[0]  # first sample past half the step
    # the crossing, interpolated between that sample and the one before
    crossing = t[k - 1] + (F_STEP / 2 - f_hat[k - 1]) / (f_hat[k] - f_hat[k - 1]) * H
    steady = (t >= STEADY[0]) & (t < STEADY[1])
    error = noisy.signals["F_hat"] - true_f
    return {"window": window, "delay": crossing - T_STEP, "noise": float(np.std(error[steady])),
            "time": t, "F_hat": noisy.signals["F_hat"], "true_F": true_f}


def main(path: str | Path = Path("results", "examples", "estimator_tradeoff.png")) -> list[dict]:
    rows = [measure(w) for w in (0, *WINDOWS)]
    alg = rows[1:]
    slope = np.polyfit(np.log([r["delay"] for r in alg]), np.log([r["noise"] for r in alg]), 1)[0]

    fig = Figure(figsize=(11, 4.6), layout="constrained")
    left, right = fig.subplots(1, 2, width_ratios=(1.35, 1))
    for row in rows:
        if row["window"] not in SHOWN:
            continue
        t = row["time"]
        zoom = (t >= 0.45) & (t <= 0.6)
        bd = row["window"] == 0
        left.plot(t[zoom] * 1e3, row["F_hat"][zoom], color=SHOWN[row["window"]],
                  lw=0.6 if bd else 1.4, alpha=0.7 if bd else 1.0, label=_label(row["window"]))
    t = rows[0]["time"]
    zoom = (t >= 0.45) & (t <= 0.6)
    left.plot(t[zoom] * 1e3, rows[0]["true_F"][zoom], "k--", lw=1.2, label="true F")
    left.annotate(f"F steps by {F_STEP:g} rad/s² at {T_STEP * 1e3:g} ms",
                  xy=(T_STEP * 1e3, F_STEP), xytext=(455, 33), fontsize=9,
                  arrowprops={"arrowstyle": "->", "color": "0.3"})
    left.set_ylim(-15, 40)
    left.set_xlabel("time $t$ (ms)")
    left.set_ylabel(r"estimate $\hat F$ (rad/s²)")
    left.set_title(f"(a) estimates of F with {NOISE:g} rad/s of sensor noise", fontsize=10)
    left.legend(fontsize=8, loc="lower right", ncols=2)

    for row in rows:
        bd = row["window"] == 0
        right.plot(row["delay"] * 1e3, row["noise"], "s" if bd else "o", ms=7,
                   color="tab:gray" if bd else "tab:blue")
        text = "backward difference" if bd else f"M = {row['window']}"
        right.annotate(text, (row["delay"] * 1e3, row["noise"]), xytext=(8, -3),
                       textcoords="offset points", fontsize=8)
    right.plot([r["delay"] * 1e3 for r in alg], [r["noise"] for r in alg], color="tab:blue",
               lw=1, label=f"algebraic estimator (log-log slope {slope:.2f})")
    # the closed forms of the theory page, for comparison with the measured points
    windows = np.geomspace(4, 100, 50)
    right.plot(windows * H / 2 * 1e3, 2 * np.sqrt(3) * NOISE / (H * windows**1.5),
               color="0.5", ls=":", lw=1.2,
               label=r"closed form $2\sqrt{3}\,\sigma / (h M^{3/2})$ at delay $M h/2$")
    right.plot([H / 2 * 1e3], [np.sqrt(2) * NOISE / H], "x", color="0.3", ms=9,
               label=r"closed form $\sqrt{2}\,\sigma / h$ at delay $h/2$")
    right.set_xscale("log")
    right.set_yscale("log")
    right.set_xlim(0.3, 90)
    right.set_ylim(0.01, 20)
    right.set_xticks([0.5, 1, 2, 5, 10, 20, 50], ["0.5", "1", "2", "5", "10", "20", "50"])
    right.set_xlabel("delay: time to half of the step of F (ms)")
    right.set_ylabel(r"noise: std of $\hat F - F$ in steady state (rad/s²)")
    right.set_title("(b) each estimator's noise against its delay", fontsize=10)
    right.legend(fontsize=7.5, loc="lower left")
    for ax in (left, right):
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("Estimators of F on y' = F + 50 u: a longer algebraic window trades delay "
                 "for noise")
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)

    print("estimators of F: " + "; ".join(
        f"{_label(r['window'])}: delay {r['delay'] * 1e3:.2g} ms, noise {r['noise']:.3g} rad/s^2"
        for r in rows))
    theory = [np.sqrt(2) * NOISE / H] + [2 * np.sqrt(3) * NOISE / (H * w**1.5) for w in WINDOWS]
    for row, closed in zip(rows, theory, strict=True):
        row["closed_form"] = closed
    print(f"algebraic noise ~ delay^{slope:.2f}; measured / closed-form noise "
          + ", ".join(f"{r['noise'] / r['closed_form']:.2f}" for r in rows) + f"; wrote {path}")
    return rows


if __name__ == "__main__":
    main(*sys.argv[1:2])
