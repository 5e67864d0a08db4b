"""``mfcontrol compare``: each case's row is its own run; what differs is said."""

import pandas as pd
import pytest

import mfcontrol
from mfcontrol.experiments.compare import compare, controller_label

SHORT = {"sim.t_end": 2.0}
CASES = ["motor-noise-pid", "motor-noise-ipi-algebraic"]


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("compare")
    return compare(CASES, SHORT, out=out), out


def test_each_row_is_the_cases_own_run(written):
    comp, out = written
    table = pd.read_csv(out / "comparison.csv")
    assert table["case"].tolist() == CASES
    for name, row in zip(CASES, table.itertuples(), strict=True):
        m = mfcontrol.run_case(name, SHORT).metrics
        assert row.iae == m["iae"] and row.tv_u == m["tv_u"] and row.settled == m["settled"]
    assert table["controller"].tolist() == ["PI (kp 0.2, ki 0.54)",
                                            "i-PI, algebraic F (M 40) (alpha 50, kp 20, "
                                            "ki 50)"]


def test_markdown_has_the_numbers_and_says_the_scenario_is_shared(written):
    comp, out = written
    md = (out / "comparison.md").read_text()
    for r in comp.results:
        assert f"{r.metrics['iae']:.4g}" in md
    assert "share every plant, reference, loop and simulation key" in md
    assert (out / "comparison.png").stat().st_size > 20_000


def test_the_metrics_carry_the_plants_units(written):
    # issue 28: the table had no units; the motor's speed is in rad/s, its input in V
    comp, out = written
    head = comp.markdown().split("\n")[0]
    assert "| IAE (rad) | IAE load (rad) | TV(u) (V) | overshoot % | settling (s) | settled |" \
        in head


def test_a_difference_outside_the_controller_is_reported():
    comp = compare(CASES, SHORT)
    comp.configs[1] = comp.configs[1].with_overrides({"plant.J": 1e-3})
    assert comp.differences() == {"plant.J": [5e-4, 1e-3]}
    assert "differ outside their controllers" in comp.markdown()
    assert "`plant.J`" in comp.markdown()


def test_labels_name_law_estimator_and_gains():
    _, cfg = mfcontrol.experiments.cases.resolve_case("motor-noise-ipi")
    assert controller_label(cfg) == "i-PI, backward-difference F (alpha 50, kp 20, ki 50)"
    # review (issue 28): two i-PIs that differ in their estimators had the same label
    _, alg = mfcontrol.experiments.cases.resolve_case("motor-noise-ipi-algebraic")
    assert controller_label(alg).startswith("i-PI, algebraic F (M 40) (alpha")
    assert controller_label(cfg.with_overrides({"controller.law": "pid", "controller.kd":
                                                0.01})) == "PID (kp 20, ki 50, kd 0.01)"


@pytest.mark.parametrize(("cases", "needle"), [
    (["motor-noise-pid"], "at least two"), (["motor-noise-pid", "sweep-Gamma"], "sweep case"),
    (["motor-noise-pid", "nope"], "unknown case"),
])
def test_bad_input(cases, needle):
    with pytest.raises((mfcontrol.ConfigError, mfcontrol.CaseError), match=needle):
        compare(cases)
