"""Results show a few lines, not their arrays (issue 15: a 500-sample run printed 60 kB)."""

import numpy as np
import pytest

import mfcontrol
from mfcontrol.api.results import display


@pytest.fixture(scope="module")
def results():
    plant = mfcontrol.FirstOrder(a=-1.0, b=1.0)
    ctrl = mfcontrol.IP(alpha=1.0, kp=5.0, sample_time=1e-3)
    return {
        "run": mfcontrol.run_case("voltage-stable-standard"),
        "loop": mfcontrol.simulate_loop(plant, ctrl, 1.0, t_end=2.0, name="tank <1>"),
        "diverged": mfcontrol.run_case("voltage-stable-standard",
                                       {"controller.alpha": 0.01}),
        "sweep case": mfcontrol.run_case("sweep-Gamma"),
        "sweep": mfcontrol.sweep(plant, ctrl, 1.0, grid={"controller.kp": [2.0, 5.0, 10.0]},
                                 t_end=0.5, keep=1),
        "comparison": mfcontrol.compare(["first-order-ip-algebraic",
                                         "first-order-ip-algebraic"]),
    }


def test_every_result_repr_is_short_and_says_what_it_is(results):
    for name, res in results.items():
        text = repr(res)
        assert len(text) < 1000 and text.count("\n") <= 9, (name, text)
        assert "array(" not in text and "Config(" not in text, (name, text)
    assert "2,000 samples over 2 s, settled" in repr(results["loop"])
    assert "IAE " in repr(results["run"]) and "states i_L, v_C" in repr(results["run"])
    d = results["diverged"]
    if d.metrics["diverged"]:
        assert "diverged at t = " in repr(d)
    else:
        assert ("not settled" in repr(d)) != d.metrics["settled"]
    assert "5 members over controller.Gamma" in repr(results["sweep case"])
    sweep = repr(results["sweep"])
    assert "3 members over controller.kp = 2..10 (3)" in sweep and "IAE " in sweep
    assert repr(results["comparison"]).startswith("<Comparison of 2 cases")


def test_notebooks_get_an_escaped_html_table(results):
    for res in results.values():
        html = res._repr_html_()
        assert html.startswith("<table><caption>mfcontrol ") and len(html) < 4000
    assert "tank &lt;1&gt;" in results["loop"]._repr_html_()


def test_formatting_rules():
    assert display.fmt(np.float64("nan")) == "-" and display.fmt(True) == "yes"
    assert display.fmt(12345) == "12,345" and display.fmt(0.000123456) == "0.000123"
    assert display.names([str(i) for i in range(15)], at_most=3) == "0, 1, 2 and 12 more"
    assert display.metric_ranges({"iae": [np.nan, 1.0, 3.0]}) == "IAE 1..3"
