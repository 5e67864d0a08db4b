"""Which path runs a configuration, and that both paths compute the same thing."""

import math

import numpy as np
import pytest

import mfcontrol
from mfcontrol.api.run.simulate import _simulate_loop, compiled
from mfcontrol.experiments.cases import resolve_case


@pytest.mark.parametrize("case", ["voltage-unstable-variational", "power-standard"])
@pytest.mark.parametrize("fidelity", ["published", "paper"])
@pytest.mark.parametrize("anti_windup", [{}, {"controller.anti_windup": "back-calculation",
                                              "controller.k_aw": 1e3, "sim.h": 1e-5}])
def test_general_loop_reproduces_the_compiled_kernel_bit_for_bit(case, fidelity, anti_windup):
    # the same law (RecursiveIP) and plant (Buck) objects, driven from Python; with
    # back-calculation the live law used to take k_aw h with the default h (1e-6)
    _, cfg = resolve_case(case, {"fidelity": fidelity, "sim.t_end": 5e-3, **anti_windup})
    assert compiled(cfg)
    kernel = mfcontrol.simulate(cfg)
    loop = _simulate_loop(cfg, "")
    for key in ("y_ref", "y", "u", "u_raw", "gamma"):
        np.testing.assert_array_equal(loop.signals[key], kernel.signals[key])
    np.testing.assert_array_equal(loop.states["v_C"], kernel.states["v_C"])
    # every metric, the loop metrics too (the reference is no step: NaN on both sides)
    assert loop.metrics == kernel.metrics
    assert all(math.isfinite(kernel.metrics[k]) for k in ("energy_u", "iae_load"))


@pytest.mark.parametrize("case,max_error", [
    ("buck-ipi", 0.1), ("boost-ipd", 10.0), ("first-order-ip-algebraic", 0.01)])
def test_toolkit_cases_hold_their_reference(case, max_error):
    r = mfcontrol.run_case(case)
    assert not compiled(r.config)
    assert r.metrics["settled"] and r.metrics["max_abs_e"] < max_error
    assert np.all((r.signals["u"] >= r.config["controller.duty_min"])
                  & (r.signals["u"] <= r.config["controller.duty_max"]))


def test_boost_case_settles_after_its_load_step():
    r = mfcontrol.run_case("boost-ipd")
    late = r.time > 0.055
    assert np.max(np.abs(r.error[late])) < 1e-3


def test_smooth_step_reference():
    r = mfcontrol.run_case("first-order-ip-algebraic", {"sim.t_end": 1.0})
    t, ref = r.time, r.signals["y_ref"]
    assert np.all(ref[t < 0.1] == 0.0) and np.all(ref[t >= 0.6] == 1.0)
    mid = np.argmin(np.abs(t - 0.35))
    assert ref[mid] == pytest.approx(0.5, abs=1e-12)
    assert np.all(np.diff(ref) >= 0)


def test_rk45_on_the_buck_agrees_with_rk4():
    a = mfcontrol.run_case("voltage-stable-standard", {"sim.t_end": 2e-3})
    b = mfcontrol.run_case("voltage-stable-standard", {"sim.t_end": 2e-3,
                                                       "sim.integrator": "rk45"})
    assert not compiled(b.config)
    np.testing.assert_allclose(b.signals["y"], a.signals["y"], atol=1e-9)


@pytest.mark.parametrize("overrides,key", [
    ({"plant.schedule": [{"t": 0.1, "name": "Q", "set": 1.0}]}, "plant.schedule"),
    ({"plant.schedule": [{"t": 0.1, "name": "w"}]}, "plant.schedule"),
    ({"plant.schedule": [{"t": -1.0, "name": "w", "add": 1.0}]}, "plant.schedule"),
    ({"controller.order": 2, "controller.window": 21, "controller.kernel": "trapezoid"},
     "controller.window"),
    ({"controller.law": "ip"}, "controller.law"),
    ({"controller.order": 3}, "controller.order"),
])
def test_toolkit_options_are_validated(overrides, key):
    with pytest.raises(mfcontrol.ConfigError) as err:
        resolve_case("first-order-ip-algebraic", overrides)
    assert err.value.key == key


@pytest.mark.parametrize("case", ["voltage-stable-standard", "voltage-stable-variational",
                                  "power-variational", "voltage-unstable-variational"])
@pytest.mark.parametrize("fidelity", ["published", "paper"])
def test_the_fast_single_run_is_within_1e_12_of_the_exact_one(case, fidelity):
    # the printed equations' second-order gamma integrator is "naturally unstable" (the
    # paper's words) and amplifies rounding: 1.1e-12 measured on voltage-stable-variational
    rtol = 1e-12 if fidelity == "published" else 1e-11
    _, cfg = resolve_case(case, {"fidelity": fidelity})
    exact, fast = mfcontrol.simulate(cfg), mfcontrol.simulate(cfg, fast=True)
    assert fast.metrics["n_samples"] == exact.metrics["n_samples"]
    assert fast.metrics["settled"] == exact.metrics["settled"]
    for key in ("iae", "ise", "itae", "max_abs_e", "tv_u", "final_gamma"):
        assert fast.metrics[key] == pytest.approx(exact.metrics[key], rel=rtol, abs=0), key
    for key in ("y", "u", "gamma"):
        np.testing.assert_allclose(fast.signals[key], exact.signals[key], rtol=rtol,
                                   atol=rtol * np.max(np.abs(exact.signals[key])))
    # another arithmetic, not the exact kernel under another name
    assert not np.array_equal(fast.signals["y"], exact.signals["y"])
    assert (exact.arithmetic, fast.arithmetic) == ("exact", "fast")


def test_the_fast_single_run_finds_the_same_blow_up():
    _, cfg = resolve_case("voltage-stable-standard", {
        "sim.t_end": 3e-3, "controller.duty_min": -1e300, "controller.duty_max": 1e300,
        "sim.diverge_above": 1e6, "controller.kp": -500.0})
    exact, fast = mfcontrol.simulate(cfg), mfcontrol.simulate(cfg, fast=True)
    assert exact.metrics["diverged"] and fast.metrics["diverged"]
    assert fast.metrics["n_samples"] == exact.metrics["n_samples"]


@pytest.mark.parametrize("case", ["buck-ipi", "boost-ipd", "first-order-ip-algebraic"])
def test_every_case_has_a_fast_mode_close_to_its_exact_run(case):
    _, cfg = resolve_case(case)
    exact, fast = mfcontrol.simulate(cfg), mfcontrol.simulate(cfg, fast=True)
    assert (exact.arithmetic, fast.arithmetic) == ("exact", "fast")
    assert fast.metrics["iae"] == pytest.approx(exact.metrics["iae"], rel=1e-9)
    np.testing.assert_allclose(fast.signals["y"], exact.signals["y"], rtol=1e-9, atol=1e-9)


def test_a_toolkit_case_diverging_at_once_is_a_flagged_result():
    # issue 10: the general loop ended in KeyError: 'gamma' here
    r = mfcontrol.run_case("boost-ipd", overrides={"sim.diverge_above": 10})
    assert r.metrics["diverged"] and not r.metrics["settled"]
    assert r.time.size == r.metrics["n_samples"]


def test_a_non_finite_reference_is_flagged_not_returned_as_non_finite_metrics():
    # issue 10: came back with iae = inf and diverged = false
    r = mfcontrol.run_case("buck-ipi", overrides={"reference.slope": -1e308})
    assert r.metrics["diverged"]
    assert all(np.isfinite(r.metrics[k]) for k in ("iae", "ise", "itae", "tv_u"))


def test_a_sweep_case_may_vary_an_integer_option():
    _, cfg = resolve_case("first-order-ip-algebraic", {"sweep.key": "controller.window",
                                                        "sweep.values": [10, 20],
                                                        "sim.t_end": 0.5})
    res = mfcontrol.simulate_sweep(cfg)
    assert [m.config["controller.window"] for m in res.members] == [10, 20]
    assert res.members[0].metrics != res.members[1].metrics


def _short(case: str):
    """A built-in case's configuration cut to 300 samples (its window still fits)."""
    cfg = resolve_case(case)[1]
    return cfg.with_overrides({"sim.t_end": 300 * cfg["sim.h"]})


SINGLE_CASES = [c for c in mfcontrol.case_names() if resolve_case(c)[1]["sweep.key"] is None]


@pytest.mark.parametrize("case", SINGLE_CASES)
def test_a_run_reads_no_option_but_those_its_translators_read(case):
    # shown_keys (mfcontrol show, config.toml) leaves out what a run does not read: the
    # simulation itself must read nothing else
    from mfcontrol.api.run.simulate import keys_read_by_run, simulate
    from mfcontrol.config.resolve import keys_read

    cfg = _short(case)
    assert keys_read(simulate, cfg) - {"_explicit"} <= keys_read_by_run(cfg)


@pytest.mark.parametrize("case", ["first-order-ip-algebraic", "motor-noise-ipi-algebraic",
                                  "bench-lag3", "voltage-stable-variational", "boost-ipd"])
def test_the_shown_options_resolve_to_the_same_run(case, tmp_path):
    from mfcontrol.api.run.simulate import shown_keys

    cfg = _short(case)
    path = tmp_path / "case.toml"
    path.write_text(cfg.to_toml(shown_keys(cfg)))
    back = resolve_case(str(path))[1]
    a, b = mfcontrol.simulate(cfg), mfcontrol.simulate(back)
    np.testing.assert_equal(a.metrics, b.metrics)
    np.testing.assert_array_equal(a.signals["y"], b.signals["y"])


def test_show_leaves_out_the_options_of_plants_and_choices_not_taken():
    # review (issue 28): a first-order case's configuration carried every buck parameter
    # (E, L, R, C, change_times, ...), the DC motor's and the variational gain's
    from mfcontrol.api.run.simulate import shown_keys

    cfg = resolve_case("first-order-ip-algebraic")[1]
    shown = shown_keys(cfg)
    for key in ("plant.E", "plant.R", "plant.change_times", "plant.J", "plant.num",
                "controller.Gamma", "controller.k_aw", "sensor.noise_std"):
        assert key not in shown
    for key in ("plant.model", "plant.a", "plant.schedule", "controller.window",
                "sensor.noise", "sim.h", "metrics.settled_tol", "description"):
        assert key in shown
    noisy = shown_keys(resolve_case("motor-noise-ipi")[1])
    assert {"sensor.noise_std", "sensor.seed", "plant.J"} <= noisy


def test_a_load_change_that_breaks_the_plant_is_named_by_its_own_key():
    # tests/test_fuzz.py found `--set plant.dC=1e308` refused as "plant.schedule = 'C =
    # inf'": the key given was not the key named
    import pytest

    from mfcontrol.api.run.from_config import plant_and_changes
    from mfcontrol.config.resolve import resolve
    from mfcontrol.errors import ConfigError

    cfg = resolve({"plant.model": "buck", "plant.dC": 1e308,
                   "plant.change_times": [0.004, 0.006]})
    with pytest.raises(ConfigError, match=r"^plant\.dC = 1e\+308: must leave C a finite"):
        plant_and_changes(cfg)
