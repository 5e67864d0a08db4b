"""What a tuner minimises: weighted sums of metrics, inf for failed runs."""

import numpy as np
import pytest

from mfcontrol.api.results.objective import METRICS, Objective, aggregate
from mfcontrol.errors import ConfigError


@pytest.mark.parametrize(("text", "terms"), [
    ("iae", (("iae", 1.0),)),
    ("iae+0.01*tv_u", (("iae", 1.0), ("tv_u", 0.01))),
    ("ise + 1e-4 * tv_u", (("ise", 1.0), ("tv_u", 1e-4))),
    ("2e-3*tv_u+iae", (("tv_u", 0.002), ("iae", 1.0))),
    ("iae-1e+2*ise", (("iae", 1.0), ("ise", -100.0))),
    ("tv_u*3 + iae_load", (("tv_u", 3.0), ("iae_load", 1.0))),
    ("-overshoot", (("overshoot", -1.0),)),
])
def test_parse(text, terms):
    assert Objective.parse(text).terms == terms


@pytest.mark.parametrize("text", ["", "  ", "iea", "iae+", "2*iae*3", "iae**2", "settled",
                                  "diverged", "n_samples", "iae + nan*ise", "1e999*iae",
                                  "iae; rm -rf", 3])
def test_parse_refuses_with_the_metrics_listed(text):
    with pytest.raises(ConfigError) as info:
        Objective.parse(text)
    assert info.value.key == "--objective"
    assert "iae" in info.value.allowed and "tv_u" in info.value.allowed


def test_every_metric_named_in_the_list_parses():
    for name in METRICS:
        assert Objective.parse(f"0.5*{name}").metrics == (name,)


def test_score_is_the_weighted_sum_and_inf_for_failed_runs():
    obj = Objective.parse("iae + 0.5*tv_u")
    table = {"iae": np.array([1.0, 1.0, 1.0, np.nan]),
             "tv_u": np.array([2.0, 2.0, 2.0, 2.0]),
             "diverged": np.array([False, True, False, False]),
             "settled": np.array([True, False, False, True])}
    assert obj.score(table).tolist() == [2.0, np.inf, np.inf, np.inf]


def test_aggregate_worst_and_mean():
    s = np.array([[1.0, 3.0], [2.0, np.inf]])
    assert aggregate(s, "max").tolist() == [3.0, np.inf]
    assert aggregate(s, "mean").tolist() == [2.0, np.inf]
    with pytest.raises(ConfigError, match="max, mean"):
        aggregate(s, "median")
