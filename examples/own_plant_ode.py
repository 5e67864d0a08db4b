"""
Your own plant: a tank's level under an i-P
===========================================

A gravity-drained tank: level h (m), pump flow u (m³/s) in, outflow through an
orifice:

``A dh/dt = u - a sqrt(2 g h)``

Nothing of this model is given to the controller: the i-P only assumes
``h' = F + alpha u`` and estimates F (the outflow, and the unknown leak that opens at
t = 60 s) at every sample. ``alpha = 1/A`` is the right order of magnitude ("h' and
alpha u of the same size"); ``kp = 0.2`` 1/s sets the error decay,
``e(t) ~ exp(-kp t)``. The model is an ``ODE`` plant of your own: numba compiles its
right-hand side ``f(t, x, u, p)`` and its output ``g(x, p)``, and the loop runs in the
compiled engine.

Run: ``python examples/own_plant_ode.py [figure.png]``
(default figure: ``results/examples/own_plant_ode.png``)
"""

import sys
from pathlib import Path

import numpy as np

import mfcontrol
from mfcontrol.api.model.plants import ODE

AREA, ORIFICE, G = 0.5, 0.01, 9.81


def tank(t, x, u, p):
    area, orifice, leak = p
    h = max(x[0], 0.0)
    return np.array([(u - (orifice + leak) * np.sqrt(2 * G * h)) / area])


def level(x, p):
    return x[0]


def main(path: str | Path = Path("results", "examples", "own_plant_ode.png")) -> mfcontrol.Result:
    plant = ODE(tank, level, x0=[0.2], params={"area": AREA, "orifice": ORIFICE, "leak": 0.0})
    ctrl = mfcontrol.IP(alpha=1 / AREA, kp=0.2, sample_time=0.1, output_limits=(0.0, 0.2))
    setpoint = lambda t: 1.0 if t < 100 else 0.6  # noqa: E731
    res = mfcontrol.simulate_loop(plant, ctrl, setpoint, t_end=150.0,
                                  changes=[mfcontrol.Change(60.0, "leak", 0.005)])
    fig = res.plot(None, title="Tank level under an i-P: a leak opens at 60 s",
                   output_label="level h (m)", input_label="pump flow u (m$^3$/s)")
    top = fig.axes[0]
    for x, text in ((60.0, "leak opens"), (100.0, "setpoint 1 m → 0.6 m")):
        top.annotate(text, xy=(x, 0.03), xycoords=("data", "axes fraction"), xytext=(-3, 0),
                     textcoords="offset points", rotation=90, ha="right", va="bottom",
                     fontsize=8, color="0.3")
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    m = res.metrics
    print(f"tank i-P: settled={m['settled']} IAE={m['iae']:.3f} m s, "
          f"final error={res.error[-1]:+.2e} m, wrote {path}")
    return res


if __name__ == "__main__":
    main(*sys.argv[1:2])
