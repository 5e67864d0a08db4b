"""``mfcontrol.make_controller``: the live controller of a case is the one its runs use."""

import numpy as np
import pytest

import mfcontrol

CASES = ["voltage-stable-standard", "voltage-stable-variational", "buck-ipi", "boost-ipd",
         "first-order-ip-algebraic", "motor-noise-ipi", "motor-noise-ipi-algebraic",
         "motor-noise-pid", "buck-50khz-noise", "bench-lag3"]


@pytest.mark.parametrize("case", CASES)
def test_the_live_controller_of_a_case_gives_its_runs_control_bit_for_bit(case):
    short = {"sim.t_end": 2e-3} if case.startswith(("voltage", "buck", "boost")) else \
        {"sim.t_end": 3.0}
    r = mfcontrol.run_case(case, short)
    ctrl = mfcontrol.make_controller(case, short)
    # what the controller received: the sensor's output, or y in an ideal loop
    y = r.signals.get("y_meas", r.signals["y"])
    u = [ctrl(a, setpoint=b) for a, b in zip(y, r.signals["y_ref"], strict=True)]
    np.testing.assert_array_equal(u, r.signals["u"])


def test_overrides_and_configurations():
    _, cfg = mfcontrol.experiments.cases.resolve_case("motor-noise-pid")
    a = mfcontrol.make_controller(cfg, {"controller.kp": 0.3})
    b = mfcontrol.make_controller("motor-noise-pid", {"controller.kp": 0.3})
    assert type(a) is type(b) is mfcontrol.PID
    assert [a(1.0, setpoint=2.0) for _ in range(3)] == [b(1.0, setpoint=2.0) for _ in range(3)]
    with pytest.raises(mfcontrol.ConfigError, match="controller.kp"):
        mfcontrol.make_controller("motor-noise-pid", {"controller.kp": "x"})


def test_a_folder_named_as_a_built_in_case_does_not_hide_it(tmp_path, monkeypatch):
    """A folder named as the case in the working directory (an export's --out, say) made
    `mfcontrol export-c motor-noise-ipi` fail with "case file 'motor-noise-ipi' not
    found". The built-in case is taken; a folder that is no case's name is refused as a
    folder."""
    from mfcontrol.errors import CaseError
    from mfcontrol.experiments.cases import resolve_case

    monkeypatch.chdir(tmp_path)
    (tmp_path / "motor-noise-ipi").mkdir()
    name, cfg = resolve_case("motor-noise-ipi")
    assert name == "motor-noise-ipi" and cfg["controller.law"] == "i-PI"
    (tmp_path / "results").mkdir()
    with pytest.raises(CaseError, match="'results' is a folder, not a case"):
        resolve_case("results")
    (tmp_path / "mine.toml").mkdir()
    with pytest.raises(CaseError, match="case file 'mine.toml' not found"):
        resolve_case("mine.toml")
