"""The two kernels, divergence handling and properties that must hold for any input."""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mfcontrol
from mfcontrol import scenario
from mfcontrol.experiments.cases import resolve_case


def _cfg(case, **over):
    return resolve_case(case, over)[1]


def test_chunk_members_equal_single_runs_bit_for_bit():
    cfgs = [_cfg("voltage-unstable-variational", **{"controller.Gamma": g, "sim.t_end": 3e-3})
            for g in (5e-8, 5e-6)] + [_cfg("voltage-unstable-variational",
                                           **{"controller.eps_M": 1e3, "sim.t_end": 3e-3})]
    many = mfcontrol.simulate_many(cfgs)
    for cfg, member in zip(cfgs, many, strict=True):
        single = mfcontrol.simulate(cfg)
        for key in ("y", "duty", "u_raw", "gamma"):
            np.testing.assert_array_equal(member.signals[key], single.signals[key])
        assert member.metrics == single.metrics


def test_divergence_is_flagged_and_the_trajectory_kept_up_to_it():
    r = mfcontrol.run_case("voltage-stable-standard", {"sim.diverge_above": 1.0})
    m = r.metrics
    assert m["diverged"] and not m["stable"]
    k = m["n_samples"]
    assert r.time.size == k < 10_000
    assert m["t_diverge"] == (k * 0.01) / 10_000
    assert np.all(np.isfinite(r.signals["y"])) and np.all(np.abs(r.signals["y"]) <= 1.0)


def test_a_diverging_member_does_not_spoil_the_others():
    ok = _cfg("voltage-stable-standard", **{"sim.t_end": 2e-3})
    bad = _cfg("voltage-stable-standard", **{"sim.t_end": 2e-3, "controller.kp": 4.0,
                                             "controller.p_error": "y-r"})
    alone = mfcontrol.simulate(ok)
    mixed = mfcontrol.simulate_many([bad, ok, bad])
    np.testing.assert_array_equal(mixed[1].signals["y"], alone.signals["y"])
    assert mixed[1].metrics == alone.metrics


def test_scenario_time_grid_is_the_published_one():
    scn = scenario.build([_cfg("voltage-stable-standard")])
    k = np.arange(10_000)
    np.testing.assert_array_equal(scn.time(), (k * 0.01) / 10_000)
    assert list(scn.ev_steps) == [4000, 6000]


finite = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(alpha=st.floats(0.01, 100), kp=st.floats(-10, 10), gamma0=st.floats(-5, 5),
       Gamma=st.floats(-1e-4, 1e-4), eps=st.floats(-10, 10), dR=st.floats(-4, 20),
       lo=st.floats(0, 0.5), width=st.floats(0, 0.5),
       law=st.sampled_from(["ip", "variational"]),
       fidelity=st.sampled_from(["published", "paper"]),
       output=st.sampled_from(["voltage", "power"]))
def test_duty_always_within_limits_and_outputs_finite(alpha, kp, gamma0, Gamma, eps, dR, lo,
                                                      width, law, fidelity, output):
    r = mfcontrol.run_case("voltage-stable-standard", {
        "controller.law": law, "fidelity": fidelity, "plant.output": output,
        "controller.alpha": alpha, "controller.kp": kp, "controller.gamma0": gamma0,
        "controller.Gamma": Gamma, "controller.eps_M": eps, "plant.dR": dR,
        "controller.duty_min": lo, "controller.duty_max": lo + width,
        "sim.t_end": 1e-3, "sim.diverge_above": 1e300})
    d = r.signals["duty"]
    assert np.all((d >= lo) & (d <= lo + width))
    # a clipped duty cycle keeps the passive converter bounded, whatever the law does
    assert np.all(np.isfinite(r.signals["y"]))
    m = r.metrics
    assert all(np.isfinite(m[k]) for k in ("iae", "ise", "itae", "tv_duty"))
    assert m["tv_duty"] >= 0 and m["iae"] >= 0


@settings(max_examples=15, deadline=None)
@given(values=st.lists(st.floats(1e-10, 1e-5), min_size=1, max_size=4))
def test_sweep_members_equal_independent_runs(values):
    cfg = _cfg("sweep-Gamma", **{"sim.t_end": 1e-3, "sweep.values": values})
    sweep = mfcontrol.simulate_sweep(cfg)
    for v, member in zip(values, sweep.members, strict=True):
        single = mfcontrol.run_case("voltage-unstable-variational",
                                    {"controller.Gamma": v, "sim.t_end": 1e-3})
        np.testing.assert_array_equal(member.signals["y"], single.signals["y"])
