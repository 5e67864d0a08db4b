"""``mfcontrol benchmark`` on one plant with a small budget: the report's numbers are the
tuned controllers' runs, every controller had the same budget, and a second call resumes."""

import json
import math

import numpy as np
import pandas as pd
import pytest

import mfcontrol
from mfcontrol.experiments import benchmark as bm
from mfcontrol.experiments import cases

PLANT = "bench-lag3"
BUDGET = 24


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("benchmark")
    return bm.benchmark([PLANT], budget=BUDGET, seed=1, out=out), out


def test_every_benchmark_case_is_complete():
    assert len(bm.plants()) >= 10
    for name in bm.plants():
        _, cfg = cases.resolve_case(name)
        assert cfg["sensor.noise"] != "none"
        assert cfg["disturbance.kind"] != "none" or cfg["plant.schedule"] or \
            cfg["plant.change_times"]
        assert cfg["reference.kind"] == "smooth-step"
        for key in ("benchmark.pid", "benchmark.ip", "benchmark.ipi"):
            assert bm.parse_parameters(cfg[key])
        assert len(mfcontrol.api.batch.parse_grid(cfg["benchmark.robustness"])) == 2


def test_same_budget_seed_and_objective_for_every_controller(run):
    entries, out = run
    assert [e.controller for e in entries] == ["PID", "i-P", "i-PI"]
    for e in entries:
        s = json.loads((out / PLANT / e.controller / "summary.json").read_text())
        assert (s["budget"], s["seed"], s["objective"]) == (BUDGET, 1, "iae + 0.01*tv_u")
        assert s["evaluations"] <= BUDGET


def test_the_table_is_the_tuned_controllers_runs(run):
    entries, out = run
    table = pd.read_csv(out / "results.csv")
    assert len(table) == 3
    for e, row in zip(entries, table.itertuples(), strict=True):
        _, best = cases.resolve_case(out / PLANT / e.controller / "best.toml")
        quiet = mfcontrol.simulate(best.with_overrides({"sensor.noise": "none"})).metrics
        noisy = mfcontrol.simulate(best).metrics
        assert row.iae_setpoint == pytest.approx(quiet["iae"] - quiet["iae_load"], rel=1e-12)
        assert row.iae_load == quiet["iae_load"] and row.tv_u_noise == noisy["tv_u"]
        assert e.map_scores.shape == (5, 5)
        n_stable, n_map = map(int, row.stable_map.split("/"))
        # a member that scores finite is stable (an unstable one scores inf)
        assert n_map == 25 and n_stable >= int(np.isfinite(e.map_scores).sum())
        assert row.worst_map == e.worst or (math.isinf(e.worst) and math.isinf(row.worst_map))
    md = (out / "report.md").read_text()
    for e in entries:
        assert f"| {PLANT} | {e.controller} |" in md
    assert "## What the table shows" in md and "loses to the PID" in md
    for png in ("robustness.png", f"{PLANT}/comparison.png",
                f"{PLANT}/PID/convergence.png"):
        assert (out / png).stat().st_size > 20_000


def test_a_second_call_resumes_the_finished_tunings(run, monkeypatch):
    entries, out = run

    def no_tuning(*args, **kwargs):
        raise AssertionError("a finished tuning ran again")

    monkeypatch.setattr("mfcontrol.experiments.tune.tune", no_tuning)
    again = bm.benchmark([PLANT], budget=BUDGET, seed=1, out=out)
    assert [e.tuned for e in again] == [e.tuned for e in entries]
    assert [e.objective for e in again] == [e.objective for e in entries]


def test_a_plant_without_a_benchmark_table_is_refused(tmp_path):
    with pytest.raises(mfcontrol.ConfigError, match="benchmark.pid"):
        bm.benchmark(["first-order-ip-algebraic"], budget=10, out=tmp_path)
