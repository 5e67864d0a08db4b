import json

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

import mfcontrol

COLUMNS = ["t", "y_ref", "y", "y_meas", "u", "u_plant", "u_raw", "gamma", "gain", "i_L",
           "v_C"]


def test_result_carries_config_version_and_frames(tmp_path):
    r = mfcontrol.run_case("voltage-stable-variational", {"sim.t_end": 1e-3})
    assert r.version == mfcontrol.__version__
    assert r.config["controller.law"] == "variational"
    df = r.to_pandas()
    assert list(df.columns) == COLUMNS and len(df) == 1000
    path = r.to_csv(tmp_path / "t.csv")
    back = pd.read_csv(path)
    np.testing.assert_array_equal(back["u_raw"].to_numpy(), r.signals["u_raw"])
    meta = json.loads(r.metrics_json())
    assert meta["case"] == "voltage-stable-variational" and meta["t_diverge"] is None


def test_plots_save_png(tmp_path):
    r = mfcontrol.run_case("voltage-stable-variational", {"sim.t_end": 1e-3})
    fig = r.plot(tmp_path / "run.png")
    assert isinstance(fig, Figure) and len(fig.axes) == 3
    assert (tmp_path / "run.png").read_bytes()[:4] == b"\x89PNG"
    s = mfcontrol.run_case("sweep-epsM", {"sim.t_end": 1e-3})
    s.plot(tmp_path / "g.png", kind="gamma")
    s.plot(tmp_path / "e.png", kind="error")
    assert len(s.to_pandas()) == 3 * 1000


def test_one_result_type_with_the_same_signal_names_on_every_path():
    from mfcontrol.api.plants import FirstOrder

    case = mfcontrol.run_case("first-order-ip-algebraic", {"sim.t_end": 0.5})
    paper = mfcontrol.run_case("voltage-stable-standard", {"sim.t_end": 1e-3})
    loop = mfcontrol.simulate_loop(FirstOrder(-1.0, 1.0), mfcontrol.IPI(
        alpha=1.0, kp=5.0, ki=1.0, sample_time=0.01), 1.0, t_end=0.5)

    class Mine:  # a controller of the user's: the Python driver runs it
        sample_time = 0.01

        def __call__(self, y, setpoint=None):
            return 5.0 * (setpoint - y)

    python = mfcontrol.simulate_loop(FirstOrder(-1.0, 1.0), Mine(), 1.0, t_end=0.5)
    for r in (case, paper, loop, python):
        assert type(r) is mfcontrol.Result
        assert list(r.signals)[:8] == ["y_ref", "y", "y_meas", "u", "u_plant", "u_raw",
                                       "gamma", "gain"]
        # no sensor or actuator: what they pass on is what they were given
        assert np.array_equal(r.signals["y_meas"], r.signals["y"], equal_nan=True)
        assert np.array_equal(r.signals["u_plant"], r.signals["u"], equal_nan=True)
    assert python.engine == "python" and np.all(np.isnan(python.signals["gamma"]))
    assert (case.config is not None, loop.config) == (True, None)
    assert list(case.to_pandas().columns)[:9] == ["t", "y_ref", "y", "y_meas", "u", "u_plant",
                                                  "u_raw", "gamma", "gain"]
