"""
Robustness map: how wrong may alpha be?
=======================================

The one model parameter an intelligent controller asks for is ``alpha`` in
``y' = F + alpha u``. This example sweeps it against the plant it should match: a DC
motor's speed under an i-PI (``kp = 20`` 1/s, ``ki = 50`` 1/s², backward differences,
1 kHz), for rotor inertias J from 1e-4 to 4e-3 kg m² (the library's ``DCMotor``:
Km = 0.05 N m/A, Ra = 2 ohm, La = 2 mH). The true input gain of the speed,
``b = Km / (J Ra)``, then runs from 250 down to 6.25 rad/s² per V. Each member steps the
speed to 60 rad/s and takes a 0.05 N m load torque at 1 s; the amplifier has no voltage
limit, so an unstable loop diverges instead of cycling on the rails.

``mfcontrol.sweep`` runs the 17 x 13 grid (221 runs of 2,000 samples) in well under a
second; the heat map is the library's own (``mfcontrol.experiments.maps.heatmap``, what
``mfcontrol map`` draws): the IAE of the members that settle (track within 10 % at the
end), the diverged ones in grey, the boundary of the settled members in red.

What the map shows. The boundary follows ``alpha J = constant``: on this grid the
smallest stable alpha is 0.42 to 0.54 times the true gain b (the white dashed line is b
itself; neighbouring alphas differ by a factor 1.33). With backward differences the
law corrects by ``F_hat / alpha`` at every sample, and the sampled loop's pole is about
``1 - b/alpha``: unstable once alpha is below b/2, where each correction overshoots by
more than it corrects. The motor's electrical lag (La/Ra = 1 ms, one sample) weakens
the first samples' response and moves the boundary a little below b/2 at small J. Two
members on the boundary neither settle nor diverge (hatched). Above the boundary
every member is stable up to the grid's largest alpha (50 times b at J = 4e-3), and only
gets slower: the IAE rises from 4.9 rad just above the boundary to 7.5 rad at
alpha = 316 and J = 4e-3. Overestimating alpha costs speed; underestimating it by more
than a factor of two loses the loop.

Run: ``python examples/robustness_map.py [figure.png]``
(default figure: ``results/examples/robustness_map.png``)
"""

import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

import mfcontrol
from mfcontrol import Change, DCMotor
from mfcontrol.experiments.maps import heatmap  # the map `mfcontrol map` draws

KM, RA = 0.05, 2.0  # N m/A, ohm: the DCMotor defaults
ALPHAS = np.logspace(0.5, 2.5, 17)  # 3.2 .. 316 rad/s^2 per V
INERTIAS = np.logspace(-4, np.log10(4e-3), 13)  # kg m^2


def main(path: str | Path = Path("results", "examples", "robustness_map.png")):
    ctrl = mfcontrol.IPI(alpha=50.0, kp=20.0, ki=50.0, sample_time=1e-3)
    sweep = mfcontrol.sweep(DCMotor(Km=KM, Ra=RA), ctrl, 60.0, t_end=2.0,
                            changes=[Change(1.0, "load", 0.05)],
                            grid={"controller.alpha": ALPHAS, "plant.J": INERTIAS})
    frame = sweep.to_pandas()

    fig = Figure(figsize=(8, 6.2), layout="constrained")
    ax = fig.subplots()
    heatmap(frame, "controller.alpha", "plant.J", "iae", ax=ax, log_color=False,
            title="IAE of the speed over 2 s (step to 60 rad/s, load torque at 1 s)")
    settled = frame[frame["settled"].astype(bool)]
    lo, hi = float(settled["iae"].min()), float(settled["iae"].max())
    # the colours span the settled members' IAE: the few unsettled members that did not
    # diverge (hatched) reach 1e7 and would flatten the rest into one colour
    ax.collections[0].set_clim(lo, hi)
    fig.axes[-1].set_ylabel("IAE, the integral of |e| over 2 s (rad)")
    b = KM / (INERTIAS * RA)
    ax.plot(b, INERTIAS, color="white", ls="--", lw=1.5)
    ax.annotate("alpha = true gain Km/(J Ra)", xy=(b[4], INERTIAS[4]), xytext=(12, 0),
                textcoords="offset points", color="white", fontsize=9, va="center")
    ax.set_xlabel(r"$\alpha$ of the i-PI (rad/s² per V)")
    ax.set_ylabel("rotor inertia $J$ (kg m²)")
    ax.set_xticks([5, 10, 20, 50, 100, 200], ["5", "10", "20", "50", "100", "200"])
    ax.set_yticks([1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 4e-3],
                  ["1e-4", "2e-4", "5e-4", "1e-3", "2e-3", "4e-3"])
    ax.minorticks_off()
    fig.suptitle("DC motor under an i-PI: stable where alpha exceeds about half the "
                 "true gain", fontsize=11)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)

    # the boundary, measured: the smallest settled alpha of each inertia, over the true gain
    smallest = settled.groupby("plant.J")["controller.alpha"].min()
    ratio = smallest.to_numpy() / (KM / (smallest.index.to_numpy() * RA))
    out = {"frame": frame, "ratio": ratio, "n_settled": len(settled),
           "n_diverged": int(frame["diverged"].sum()),
           "iae_range": (lo, hi)}
    print(f"alpha x J map: {out['n_settled']} of {len(frame)} settled, {out['n_diverged']} "
          f"diverged; smallest settled alpha {ratio.min():.2f} to {ratio.max():.2f} times "
          f"Km/(J Ra); IAE of the settled {out['iae_range'][0]:.1f} to "
          f"{out['iae_range'][1]:.1f} rad; wrote {path}")
    return out


if __name__ == "__main__":
    main(*sys.argv[1:2])
