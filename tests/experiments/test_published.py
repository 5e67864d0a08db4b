"""The published code's results, reproduced from the specification (not from its code)."""

import numpy as np

import mfcontrol


def test_voltage_stable_standard_matches_published_data(published_reference):
    r = mfcontrol.run_case("voltage-stable-standard", {"fidelity": "published"})
    ref = published_reference
    assert r.time.size == len(ref) == 10_000
    np.testing.assert_array_equal(r.time, ref["t"].to_numpy())
    for ours, theirs in (("y_ref", "y_ref"), ("y", "y"), ("u", "duty"), ("u_raw", "u_raw")):
        err = np.max(np.abs(r.signals[ours] - ref[theirs].to_numpy()))
        assert err <= 1e-12, f"{ours}: max abs error {err}"


def test_published_is_the_default_fidelity(published_reference):
    r = mfcontrol.run_case("voltage-stable-standard")
    assert r.config["plant.coupling"] == "published"
    assert np.max(np.abs(r.signals["u_raw"] - published_reference["u_raw"].to_numpy())) <= 1e-12


def test_paper_fidelity_is_a_different_model(published_reference):
    r = mfcontrol.run_case("voltage-stable-standard", {"fidelity": "paper"})
    assert r.config["plant.coupling"] == "textbook"
    assert np.max(np.abs(r.signals["y"] - published_reference["y"].to_numpy())) > 1e-3
