"""The laws' tunable rows and their check (mfcontrol.laws.tunable) agree with the live
controllers' constructors: a value a constructor takes passes ``invalid_row``, and a value
it refuses fails it, row by row (the C export's setter runs ``invalid_row`` translated:
tests/cexport holds the two equal)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mfcontrol
from mfcontrol.laws import adrc, intelligent, pid, recursive_ip
from mfcontrol.laws import variational_gain as vg

SPECIAL = [math.nan, math.inf, -math.inf, 0.0, -1.0, 2.5, 1e300, -1e300]
_inv = np.float64(1.0)

# (controller, law module, [(keyword, row, value -> row value)]): the keywords that write
# one tunable row each (the PID's Tt is not one: its row is the tracking time resolved,
# INFINITY without an integral, which no keyword gives)
CONTROLLERS = [
    (lambda: mfcontrol.PID(kp=2.0, ki=1.0, kd=0.1, sample_time=0.01, Tt=0.5,
                           output_limits=(-5, 5)), pid,
     [("kp", pid.KP, float), ("kd", pid.KD, float), ("N", pid.N, float),
      ("b", pid.B, float), ("c", pid.C, float), ("Tf", pid.TF, float)]),
    (lambda: mfcontrol.ADRC(order=2, b0=3.0, wc=5.0, wo=20.0, sample_time=0.01,
                            output_limits=(-5, 5)), adrc,
     [("b0", adrc.B0, float), ("wc", adrc.WC, float), ("wo", adrc.WO, float)]),
    (lambda: mfcontrol.IPID(alpha=10.0, kp=2.0, ki=1.0, kd=0.1, sample_time=0.01,
                            anti_windup="back-calculation", k_aw=2.0, output_limits=(-5, 5)),
     intelligent,
     [("kp", intelligent.KP, float), ("ki", intelligent.KI, float),
      ("kd", intelligent.KD, float), ("k_aw", intelligent.K_AW, float),
      ("alpha", vg.INV_ALPHA, lambda v: float(_inv / np.float64(v)))]),
    (lambda: mfcontrol.IPI(alpha=10.0, kp=2.0, ki=1.0, sample_time=0.01, gain="variational",
                           gamma0=0.1, Gamma=1e-3, eps_M=0.1), intelligent,
     [("gamma0", vg.GAMMA0, float), ("Gamma", vg.GAMMA_RATE, float),
      ("eps_M", vg.EPS_M, float)]),
    (lambda: mfcontrol.RecursiveIP(alpha=10.0, kp=2.0), recursive_ip,
     [("kp", recursive_ip.KP, float),
      ("alpha", vg.INV_ALPHA, lambda v: float(_inv / np.float64(v))),
      ("duty_min", recursive_ip.OUT_MIN, float), ("duty_max", recursive_ip.OUT_MAX, float)]),
]
IDS = ["PID", "ADRC", "IPID", "IPI-variational", "RecursiveIP"]


def _valid(law, cp) -> bool:
    return law.invalid_row(cp[:, None], 0) == -1


@pytest.mark.parametrize("make,law,keys", CONTROLLERS, ids=IDS)
def test_a_value_the_constructor_takes_passes_and_one_it_refuses_fails(make, law, keys):
    with np.errstate(all="ignore"):
        for key, row, to_row in keys:
            for value in SPECIAL:
                ctrl = make()
                try:
                    ctrl.retune(**{key: value})
                except ValueError:
                    cp = make()._CP[:, 0].copy()
                    cp[row] = to_row(value)
                    assert not _valid(law, cp), (key, value)
                else:
                    assert _valid(law, ctrl._CP[:, 0]), (key, value)
                    assert row in {r for _, r, _ in law.tunable(ctrl._CP[:, 0])}


@pytest.mark.parametrize("make,law,keys", CONTROLLERS, ids=IDS)
def test_output_limits_out_of_order_or_nan_fail(make, law, keys):
    cp = make()._CP[:, 0]
    assert _valid(law, cp)
    lo, hi = law.OUT_MIN, law.OUT_MAX
    for a, b in [(1.0, -1.0), (math.nan, 1.0), (-1.0, math.nan), (math.inf, math.inf),
                 (-math.inf, -math.inf)]:
        bad = cp.copy()
        bad[lo], bad[hi] = a, b
        assert not _valid(law, bad), (a, b)
    infinite = [] if law is recursive_ip else [(-math.inf, math.inf)]  # a duty's are finite
    for a, b in [*infinite, (0.0, 0.0), (-1.0, 1.0)]:
        good = cp.copy()
        good[lo], good[hi] = a, b
        assert _valid(law, good), (a, b)


def test_every_case_s_controller_is_valid_as_built():
    for name in mfcontrol.experiments.cases.names():
        try:
            ctrl = mfcontrol.make_controller(name)
        except (ValueError, mfcontrol.errors.ConfigError):
            continue  # a case without a live controller (an external gain, say)
        law = ctrl._LAW
        assert _valid(law, ctrl._CP[:, 0]), name
        rows = [row for _, row, _ in law.tunable(ctrl._CP[:, 0])]
        assert len(set(rows)) == len(rows)
        names = [name for name, _, _ in law.tunable(ctrl._CP[:, 0])]
        assert all(n.isidentifier() and n == n.lower() for n in names)


def test_the_pid_tracking_time_row_takes_infinity_only_without_an_integral():
    """Review: a P export (tt INFINITY) given ki in C had no anti-windup, which no
    constructor builds (retune(ki=1) computes Tt)."""
    cp = mfcontrol.PID(kp=2.0, ki=1.0, sample_time=0.01)._CP[:, 0].copy()
    for ki in (1.0, 0.0):
        cp[pid.KI] = ki
        for value, ok in [(math.inf, ki == 0.0), (0.5, True), (0.0, False), (-1.0, False),
                          (math.nan, False)]:
            cp[pid.TT] = value
            assert _valid(pid, cp) is ok, (ki, value)
    with pytest.raises(ValueError, match="Tt = inf"):
        mfcontrol.PID(kp=2.0, ki=1.0, sample_time=0.01, Tt=math.inf)
