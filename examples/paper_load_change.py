"""
The paper's buck converter: a load change that only the variational law survives
=================================================================================

L. Michel's CCTA 2025 paper tunes the gain of an i-P online by a variational law. Its
test bench is an averaged buck converter (E = 20 V, L = 1 mH, C = 10 µF, R = 10 ohm)
whose output voltage follows a ramp to 2.5 V, a hold and a second ramp from 5 ms, while
the load changes twice, at 4 ms and at 6 ms (R += 5 ohm and C += 1 nF each time). The
built-in cases ``voltage-unstable-standard`` (the recursive i-P with ``alpha = 10``) and
``voltage-unstable-variational`` (the variational law from ``gamma0 = 1``) run it as the
published code does (``mfcontrol.run_case``, 10,000 samples of 1 µs).

What the runs give. The standard i-P rings after the first load change (up to 0.78 V
off the reference in the zoomed 0.9 ms) and the second one sets off an oscillation that
grows until the duty cycle hits its limit of 0.9 at 8.2 ms; the error reaches 13.7 V and
the run does not settle. (The 0.78 V is the first 0.9 ms; by 6 ms the ringing has
grown to 1.56 V.) The variational law absorbs both changes: 0.18 V at 4 ms and
0.12 V at 6 ms, and 0.049 V from the reference at the end. Over the 10 ms its gain
gamma moves from 1 to 0.99995, so what makes the difference is mostly where it starts:
a standard i-P with ``alpha = 1/gamma0 = 1`` gives the same voltage to within 6 µV
(the paper's authors' code, reproduced bit for bit, and ``mfcontrol reproduce`` say
the same). The two lower panels zoom on the transients.

Run: ``python examples/paper_load_change.py [figure.png]``
(default figure: ``results/examples/paper_load_change.png``)
"""

import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

import mfcontrol

CASES = {"voltage-unstable-standard": ("standard i-P, alpha = 10", "tab:red"),
         "voltage-unstable-variational": ("variational law, gamma0 = 1", "tab:blue")}
ZOOMS = (((3.9, 4.9), (1.4, 3.4)), ((5.9, 6.9), (2.8, 5.0)))  # (ms, V) of each zoom


def _mark_changes(ax, top: bool = True) -> None:
    for tc, what in ((4.0, "load change 1:\nR +5 ohm, C +1 nF"),
                     (6.0, "load change 2:\nR +5 ohm, C +1 nF")):
        ax.axvline(tc, color="0.4", lw=0.8, ls=":")
        if top:
            ax.annotate(what, xy=(tc, 1.0), xycoords=("data", "axes fraction"),
                        xytext=(-3, -4), textcoords="offset points", rotation=90,
                        ha="right", va="top", fontsize=7.5, color="0.3")


def main(path: str | Path = Path("results", "examples", "paper_load_change.png")) -> dict:
    runs = {name: mfcontrol.run_case(name) for name in CASES}
    equal_gain = mfcontrol.run_case("voltage-unstable-standard",
                                    overrides={"controller.alpha": 1.0})
    std, var = runs.values()
    t_ms = std.time * 1e3

    fig = Figure(figsize=(10, 9), layout="constrained")
    grid = fig.add_gridspec(3, 2, height_ratios=(1.25, 0.8, 1))
    volt = fig.add_subplot(grid[0, :])
    duty = fig.add_subplot(grid[1, :], sharex=volt)
    volt.plot(t_ms, std.signals["y_ref"], color="k", ls="--", lw=1.0, label="reference $v^*$")
    for name, res in runs.items():
        label, colour = CASES[name]
        volt.plot(t_ms, res.signals["y"], color=colour, lw=1.1, label=label)
        duty.plot(t_ms, res.signals["u"], color=colour, lw=1.0, label=label)
    volt.set_ylim(-8, 22)
    volt.set_ylabel("output voltage $v$ (V)")
    volt.set_title("output voltage over the whole run (grey boxes: the zooms below)",
                   fontsize=10)
    volt.legend(loc="upper left", fontsize=8.5)
    for (lo, hi), (bottom, top) in ZOOMS:
        volt.add_patch(Rectangle((lo, bottom), hi - lo, top - bottom, fill=False, ec="0.3",
                                 lw=0.9))
    duty.set_ylabel("duty cycle $d$ (1)")
    duty.set_xlabel("time $t$ (ms)")
    duty.set_title("duty cycle (limits 0.001 and 0.9)", fontsize=10)
    for ax in (volt, duty):
        ax.grid(True, alpha=0.3)
        _mark_changes(ax, top=ax is duty)

    for col, ((lo, hi), (bottom, top)) in enumerate(ZOOMS):
        ax = fig.add_subplot(grid[2, col])
        m = (t_ms >= lo) & (t_ms <= hi)
        ax.plot(t_ms[m], std.signals["y_ref"][m], color="k", ls="--", lw=1.0)
        for name, res in runs.items():
            label, colour = CASES[name]
            ax.plot(t_ms[m], res.signals["y"][m], color=colour, lw=1.3, label=label)
        ax.set_xlim(lo, hi)
        ax.set_ylim(bottom, top)
        ax.set_xlabel("time $t$ (ms)")
        ax.set_ylabel("output voltage $v$ (V)")
        ax.set_title(f"zoom on load change {col + 1} at {lo + 0.1:g} ms"
                     + ("\n(the standard i-P goes off the scale)" if col else "\n"), fontsize=10)
        ax.grid(True, alpha=0.3)
        _mark_changes(ax, top=False)
        if col == 0:
            ax.legend(loc="lower left", fontsize=8)

    fig.suptitle("Buck converter under the paper's destabilising load changes: "
                 "standard i-P against the variational law")
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)

    t = std.time
    first = (t >= 4e-3) & (t < 6e-3)
    second = t >= 6e-3
    rail = float(t[np.flatnonzero((std.signals["u"] >= 0.9) & (t > 4e-3))[0]])
    out = {
        "settled": {name: res.metrics["settled"] for name, res in runs.items()},
        "max_e_first": {name: float(np.abs(res.error[first]).max()) for name, res in runs.items()},
        "max_e_second": {name: float(np.abs(res.error[second]).max())
                         for name, res in runs.items()},
        "final_e": float(abs(var.error[-1])),
        "t_rail": rail,
        "gamma_end": float(var.signals["gamma"][-1]),
        "equal_gain_diff": float(np.abs(equal_gain.signals["y"] - var.signals["y"]).max()),
        "runs": runs,
    }
    print(f"standard i-P: settled={std.metrics['settled']}, max |e| "
          f"{out['max_e_first'][std.name]:.2f} V after 4 ms, "
          f"{out['max_e_second'][std.name]:.1f} V after 6 ms, duty at 0.9 from {rail * 1e3:.1f} ms")
    print(f"variational: settled={var.metrics['settled']}, max |e| "
          f"{out['max_e_first'][var.name]:.3f} V after 4 ms, "
          f"{out['max_e_second'][var.name]:.3f} V after 6 ms, gamma 1 -> {out['gamma_end']:.5f}; "
          f"standard i-P with alpha = 1 within {out['equal_gain_diff']:.1e} V; wrote {path}")
    return out


if __name__ == "__main__":
    main(*sys.argv[1:2])
