"""The recursive i-P law, checked as identities on the trajectories it produces."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mfcontrol

SHORT = {"sim.t_end": 2e-3}


def _edot(r, hd):
    y, ref = r.signals["y"], r.signals["y_ref"]
    return (y[1:] - y[:-1]) / hd - (ref[1:] - ref[:-1]) / hd


def test_standard_law_recursion():
    r = mfcontrol.run_case("voltage-stable-standard", SHORT)
    s, c = r.signals, r.config
    assert s["u_raw"][0] == c["controller.u0"]
    e_dot = _edot(r, c["controller.deriv_scale"])
    expected = (s["u_raw"][:-1] - e_dot / c["controller.alpha"]
                + c["controller.kp"] * (s["y_ref"][1:] - s["y"][:-1]))
    np.testing.assert_allclose(s["u_raw"][1:], expected, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(s["gamma"], 1 / c["controller.alpha"])


def test_duty_is_the_clipped_scaled_control():
    r = mfcontrol.run_case("voltage-unstable-standard")
    c = r.config
    d = np.clip(c["controller.output_gain"] * r.signals["u_raw"], c["controller.duty_min"],
                c["controller.duty_max"])
    np.testing.assert_array_equal(r.signals["u"], d)
    assert r.signals["u"].max() == c["controller.duty_max"]  # it does saturate


@pytest.mark.parametrize("order,lag", [("first-order", 1), ("second-order", 2)])
def test_gamma_integrator_difference_equation(order, lag):
    r = mfcontrol.run_case("voltage-stable-variational",
                           {**SHORT, "controller.integrator": order, "controller.Gamma": 1e-6})
    c, g = r.config, r.signals["gamma"]
    e_dot = _edot(r, c["controller.deriv_scale"])  # e_dot[k-1] belongs to sample k
    assert g[0] == g[1] == g[2] == c["controller.gamma0"]
    k = np.arange(3, g.size)
    if lag == 1:
        lhs = g[k] - g[k - 1]
    else:
        lhs = g[k] - 2 * g[k - 1] + g[k - 2]
    rhs = c["controller.Gamma"] * (e_dot[k - 1] - c["controller.eps_M"])
    np.testing.assert_allclose(lhs, rhs, rtol=1e-6, atol=1e-15)


def test_rate_term_enters_u_with_its_sign():
    for sign, s in (("plus", 1.0), ("minus", -1.0)):
        r = mfcontrol.run_case("voltage-stable-variational",
                               {**SHORT, "fidelity": "paper", "controller.rate_sign": sign})
        c, sig = r.config, r.signals
        hd = c["controller.deriv_scale"]
        e_dot = _edot(r, hd)
        g = sig["gamma"]
        expected = ((sig["u_raw"][:-1] - g[1:] * e_dot)
                    + c["controller.kp"] * (sig["y_ref"][1:] - sig["y"][:-1])
                    + s * c["controller.k_gamma"] * (g[1:] - g[:-1]) / hd)
        np.testing.assert_allclose(sig["u_raw"][1:], expected, rtol=1e-12, atol=1e-9)


def test_gain_alpha_multiplies_the_derivative_error_by_one_over_alpha():
    r = mfcontrol.run_case("voltage-stable-variational",
                           {**SHORT, "fidelity": "paper", "controller.gain": "alpha"})
    np.testing.assert_array_equal(r.signals["gain"][1:], 1 / r.config["controller.alpha"])
    assert np.ptp(r.signals["gamma"]) > 0  # gamma still adapts, through the rate term


def test_variational_with_zero_Gamma_is_the_equal_gain_standard_law():
    var = mfcontrol.run_case("voltage-unstable-variational", {"controller.Gamma": 0.0})
    std = mfcontrol.run_case("voltage-unstable-standard", {"controller.alpha": 1.0})
    for key in ("y", "u", "u_raw"):
        np.testing.assert_array_equal(var.signals[key], std.signals[key])


def test_zero_k_gamma_rate_term_changes_nothing():
    a = mfcontrol.run_case("voltage-stable-variational",
                           {**SHORT, "controller.rate_term": True, "controller.k_gamma": 0.0})
    b = mfcontrol.run_case("voltage-stable-variational", {**SHORT, "controller.rate_term": False})
    np.testing.assert_array_equal(a.signals["u_raw"], b.signals["u_raw"])


def test_printed_p_term_is_positive_feedback():
    r = mfcontrol.run_case("voltage-stable-standard",
                           {"controller.p_error": "y-r", "controller.p_sample": "current"})
    assert not r.metrics["settled"]


def test_published_recursion_winds_up_and_anti_windup_stops_it():
    wound = mfcontrol.run_case("voltage-unstable-standard")
    c = wound.config
    lo, hi, g = c["controller.duty_min"], c["controller.duty_max"], c["controller.output_gain"]
    assert wound.signals["u_raw"].max() * g > 1.3 * hi  # published: far past the limit
    for mode, share in (("clamp", 1.0), ("back-calculation", 2e5 * c["sim.h"])):
        # (k_aw for back-calculation, the one mode that reads it)
        k_aw = {"controller.k_aw": 2e5} if mode == "back-calculation" else {}
        r = mfcontrol.run_case("voltage-unstable-standard", {"controller.anti_windup": mode,
                                                             **k_aw})
        u = r.signals["u_raw"] * g
        # the excess over a limit obeys x+ = (1 - c) x + step: at most step / c
        step = np.abs(np.diff(r.signals["u_raw"])).max() * g
        assert u.max() <= hi + step / share and u.min() >= lo - step / share
        # (it does not stabilise this loop: at R = 20 ohm the loop is linearly unstable)


def test_auto_anti_windup_keeps_the_published_behaviour(published_reference):
    r = mfcontrol.run_case("voltage-stable-standard", {"controller.anti_windup": "auto"})
    np.testing.assert_array_equal(r.signals["u_raw"], published_reference["u_raw"].to_numpy())


@settings(max_examples=60, deadline=None)
@given(k=st.integers(3, 10**9), y=st.floats(-10, 10), r=st.floats(-10, 10),
       state=st.lists(st.floats(-5, 5), min_size=6, max_size=6),
       count=st.integers(0, 3), mode=st.sampled_from([0.0, 1.0]),
       order=st.sampled_from([1.0, 2.0]), every=st.sampled_from([1.0, 4.0]),
       use_gamma=st.sampled_from([0.0, 1.0]), rate_coef=st.sampled_from([0.0, 0.3]))
def test_from_STEADY_on_the_law_depends_on_k_only_through_its_state(
        k, y, r, state, count, mode, order, every, use_gamma, rate_coef):
    # the sweep kernel passes STEADY for every later sample: that must change nothing
    from mfcontrol.laws.recursive_ip import STEADY, advance
    # the gain adaptation's rows (mode .. every, then the rls gain's three), the law's
    params = (mode, 0.1, 1.0, 1e-6, 0.01, order, every, 0.99, 0.01, 10.0,
              2.0, 1e-3, 1.0, 1.0, 0.0, rate_coef, use_gamma, 1 / 2000, 1e-3, 0.9, 0.0,
              1e-6)
    state = (*state, float(count), 0.25)  # ... the multi-rate count, the adaptation error
    assert advance(float(k), y, r, *state, params) == advance(STEADY, y, r, *state, params)


@pytest.mark.parametrize("order,lag", [("first-order", 1), ("second-order", 2)])
@pytest.mark.parametrize("m", [3, 10])
def test_multi_rate_gamma_is_the_integrator_at_the_macro_step(order, lag, m):
    # gamma moves every m samples, by the same difference equation at the step m h: the
    # force averaged over the m samples, Gamma scaled by m^lag; it holds in between
    r = mfcontrol.run_case("voltage-stable-variational",
                           {**SHORT, "controller.integrator": order, "controller.Gamma": 1e-6,
                            "controller.adapt_every": m})
    c, g = r.config, r.signals["gamma"]
    force = _edot(r, c["controller.deriv_scale"]) - c["controller.eps_M"]  # [k-1]: sample k
    assert (g[: m + 2] == c["controller.gamma0"]).all()  # held until the first update
    updates = np.arange(m + 2, g.size, m)
    held = np.setdiff1d(np.arange(3, g.size), updates)
    for k in held:  # gamma is the value of the last update
        last = updates[updates < k]
        assert g[k] == (g[last[-1]] if last.size else c["controller.gamma0"])
    mean = np.array([force[k - m:k].mean() for k in updates])  # samples k-m+1 .. k
    prev = np.concatenate([[c["controller.gamma0"]] * 2, g[updates]])  # at the macro steps
    if lag == 1:
        lhs = prev[2:] - prev[1:-1]
    else:
        lhs = prev[2:] - 2 * prev[1:-1] + prev[:-2]
    rhs = m**lag * c["controller.Gamma"] * mean
    np.testing.assert_allclose(lhs, rhs, rtol=1e-6, atol=1e-15)
    assert np.ptp(g) > 0  # it adapted


def test_multi_rate_follows_the_per_sample_law_under_a_constant_force():
    # f constant: per sample gamma_k = gamma0 + Gamma f n (n + 1) / 2 after n updates; at
    # the macro step the same curve sampled every m, gamma0 + m^2 Gamma f K (K + 1) / 2:
    # equal to O(m / n) (the macro step's Verlet is exact for a quadratic in time)
    from mfcontrol.laws.variational_gain import VARIATIONAL, next_gamma

    def run(every, n):
        g1 = g2 = 1.0
        acc = cnt = 0.0
        out = []
        for k in range(3, 3 + n):
            g, g1, g2, acc, cnt, _ = next_gamma(VARIATIONAL, float(k), 0.6, g1, g2, acc,
                                                cnt, 0.0, 1.0, 1.0, 1e-6, 0.1, 2.0,
                                                float(every), 1.0, 1.0)
            out.append(g)
        return np.array(out)

    n, m = 4000, 20
    per_sample, macro = run(1, n), run(m, n)
    K = n // m
    np.testing.assert_allclose(macro[m - 1::m][:K],
                               1.0 + m * m * 1e-6 * 0.5 * np.arange(1, K + 1)
                               * np.arange(2, K + 2) / 2, rtol=1e-12)
    assert abs(macro[-1] - per_sample[-1]) / abs(per_sample[-1] - 1.0) < 2 * m / n


def test_a_pickle_of_the_older_layout_is_refused_in_words():
    # the gain adaptation's rows grew (multi-rate, rls): a pickle from before would have
    # the compiled step read past its shorter columns
    import pickle

    ctrl = mfcontrol.RecursiveIP(alpha=10.0, kp=2.0, law="variational", sample_time=1e-6)
    ctrl(0.0, setpoint=1.0)
    again = pickle.loads(pickle.dumps(ctrl))
    assert again(1e-3, setpoint=1.0) == ctrl(1e-3, setpoint=1.0)
    for name in ("_CP", "_CS"):
        state = ctrl.__getstate__()
        state[name] = state[name][:-2]
        fresh = mfcontrol.RecursiveIP.__new__(mfcontrol.RecursiveIP)
        with pytest.raises(ValueError, match="pickled by an older mfcontrol"):
            fresh.__setstate__(state)
