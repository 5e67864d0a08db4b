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


def test_a_signal_it_does_not_hold_says_which_it_does_and_where_time_is():
    # review (issue 28): r.signals["t"] was a bare KeyError while the CSV and the
    # DataFrame call time t
    import pytest

    r = mfcontrol.run_case("first-order-ip-algebraic", {"sim.t_end": 0.1})
    with pytest.raises(KeyError, match=r"time is Result\.time .*the signals are y_ref, y,"):
        r.signals["t"]
    with pytest.raises(KeyError, match="'v': the signals are y_ref"):
        r.signals["v"]
    assert r.signals.get("t") is None and "y" in r.signals  # a dict otherwise


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
    from mfcontrol.api.model.plants import FirstOrder

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


def test_the_csv_writer_writes_what_pandas_writes_byte_for_byte(tmp_path):
    # NaN (an empty field), infinities, signed zero, the extremes, 17 digits; a header
    # with names the csv module quotes; more rows than one formatted block
    from mfcontrol.api.results import result as result_module

    rng = np.random.default_rng(1)
    special = np.array([np.nan, -np.nan, np.inf, -np.inf, -0.0, 0.0, 5e-324, 1.7976931348623157e308,
                        -1e-300, 0.1, 1 / 3, 2.0**53 + 2, 123456789012345678.0])
    n = result_module._CSV_ROWS + 7
    cols = {"t": np.concatenate([special, rng.standard_normal(n)]),
            'odd, "name"': np.concatenate([special[::-1], rng.standard_normal(n) * 1e10]),
            "": np.concatenate([special, np.exp(rng.standard_normal(n) * 50)])}
    assert result_module.write_csv(tmp_path / "ours.csv", cols)
    pd.DataFrame(cols).to_csv(tmp_path / "pandas.csv", index=False, float_format="%.17g")
    assert (tmp_path / "ours.csv").read_bytes() == (tmp_path / "pandas.csv").read_bytes()
    back = pd.read_csv(tmp_path / "ours.csv", keep_default_na=True)
    for i, column in enumerate(cols.values()):
        np.testing.assert_array_equal(back.iloc[:, i].to_numpy(), column)
    # what it does not cover it leaves to pandas, writing nothing
    assert not result_module.write_csv(tmp_path / "no.csv", {"a": np.zeros(3, np.float32)})
    assert not result_module.write_csv(tmp_path / "no.csv", {"a": np.zeros(3), "b": np.zeros(2)})
    assert not (tmp_path / "no.csv").exists()


def test_a_result_csv_is_pandas_own(tmp_path):
    from mfcontrol.api.model.plants import FirstOrder

    def mine(y, setpoint):  # the Python driver: components absent, NaN columns
        return 2.0 * (setpoint - y)

    runs = [mfcontrol.run_case("sweep-epsM", {"sim.t_end": 1e-3}),
            mfcontrol.simulate_loop(FirstOrder(-1.0, 1.0), mine, 1.0, t_end=0.05, h=1e-3)]
    for j, r in enumerate(runs):
        r.to_csv(tmp_path / f"{j}.csv")
        r.to_pandas().to_csv(tmp_path / f"{j}-pandas.csv", index=False, float_format="%.17g")
        assert (tmp_path / f"{j}.csv").read_bytes() == \
            (tmp_path / f"{j}-pandas.csv").read_bytes()
