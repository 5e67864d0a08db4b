"""The two kernels, divergence handling and properties that must hold for any input."""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mfcontrol
from mfcontrol.api.run import scenario
from mfcontrol.experiments.cases import resolve_case


def _cfg(case, **over):
    return resolve_case(case, over)[1]


def _batch_metrics(base, key, values):
    from mfcontrol.api.run import batch

    grid = batch.make_grid(base, {key: np.asarray(values, dtype=float)})
    return grid, batch.run_grid(grid)


def test_packed_batch_members_equal_single_runs_bit_for_bit():
    base = _cfg("voltage-unstable-variational", **{"sim.t_end": 3e-3, "fidelity": "paper"})
    grid, cols = _batch_metrics(base, "controller.Gamma", [5e-8, 5e-6, 1e-4, 3e-4])
    for m in range(grid.n_members):
        single = mfcontrol.simulate(grid.config(m)).metrics
        for name in ("iae", "ise", "itae", "max_abs_e", "tv_u", "final_gamma", "settled"):
            assert cols[name][m] == single[name], (m, name)


def test_divergence_is_flagged_and_the_trajectory_kept_up_to_it():
    r = mfcontrol.run_case("voltage-stable-standard", {"sim.diverge_above": 1.0})
    m = r.metrics
    assert m["diverged"] and not m["settled"]
    k = m["n_samples"]
    assert r.time.size == k < 10_000
    assert m["t_diverge"] == (k * 0.01) / 10_000
    assert np.all(np.isfinite(r.signals["y"])) and np.all(np.abs(r.signals["y"]) <= 1.0)


def test_a_diverging_member_does_not_spoil_the_others():
    # output_gain 1e3 with unclipped limits: members blow up to inf at different speeds
    base = _cfg("voltage-stable-standard", **{"sim.t_end": 2e-3, "controller.duty_min": -1e300,
                                              "controller.duty_max": 1e300,
                                              "sim.diverge_above": 1e6})
    grid, cols = _batch_metrics(base, "controller.kp", [2.0, -5e3, 2.0, -5e4])
    assert cols["diverged"].tolist() == [False, True, False, True]
    alone = mfcontrol.simulate(grid.config(0)).metrics
    for m in (0, 2):
        assert cols["iae"][m] == alone["iae"] and cols["tv_u"][m] == alone["tv_u"]
    assert all(np.isfinite(cols["t_diverge"][[1, 3]]))


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
    # each law's gain: alpha for the standard law, gamma0 adapting for the variational
    gain = {"controller.alpha": alpha} if law == "ip" else {
        "controller.gamma0": gamma0, "controller.Gamma": Gamma, "controller.eps_M": eps}
    r = mfcontrol.run_case("voltage-stable-standard", {
        "controller.law": law, "fidelity": fidelity, "plant.output": output,
        "controller.kp": kp, **gain, "plant.dR": dR,
        "controller.duty_min": lo, "controller.duty_max": lo + width,
        "sim.t_end": 1e-3, "sim.diverge_above": 1e300})
    d = r.signals["u"]
    assert np.all((d >= lo) & (d <= lo + width))
    # a clipped duty cycle keeps the passive converter bounded, whatever the law does
    assert np.all(np.isfinite(r.signals["y"]))
    m = r.metrics
    assert all(np.isfinite(m[k]) for k in ("iae", "ise", "itae", "tv_u"))
    assert m["tv_u"] >= 0 and m["iae"] >= 0


@settings(max_examples=15, deadline=None)
@given(values=st.lists(st.floats(1e-10, 1e-5), min_size=1, max_size=4))
def test_sweep_members_equal_independent_runs(values):
    cfg = _cfg("sweep-Gamma", **{"sim.t_end": 1e-3, "sweep.values": values})
    sweep = mfcontrol.simulate_sweep(cfg)
    for v, member in zip(values, sweep.members, strict=True):
        single = mfcontrol.run_case("voltage-unstable-variational",
                                    {"controller.Gamma": v, "sim.t_end": 1e-3})
        np.testing.assert_array_equal(member.signals["y"], single.signals["y"])
