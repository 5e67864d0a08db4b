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
        assert len(mfcontrol.api.run.batch.parse_grid(cfg["benchmark.robustness"])) == 2


def test_same_budget_seed_and_objective_for_every_controller(run):
    entries, out = run
    assert [e.controller for e in entries] == ["PID", "i-P", "i-PI"]
    for e in entries:
        s = json.loads((out / PLANT / e.controller / "summary.json").read_text())
        assert (s["budget"], s["seed"], s["objective"]) == (BUDGET, 1, "iae + 0.01*tv_u")
        assert BUDGET - 6 < s["evaluations"] <= BUDGET and s["stopped"] == "budget"


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
        n_settled, n_map = map(int, row.settled_map.split("/"))
        # a member that scores finite is stable (an unstable one scores inf)
        assert n_map == 25 and n_settled >= int(np.isfinite(e.map_scores).sum())
        # the map's member (i, j) is the run of the i-th value of the first axis and the
        # j-th of the second
        (ky, vy), (kx, vx) = list(mfcontrol.api.run.batch.parse_grid(
            best["benchmark.robustness"]).items())
        for i, j in ((0, 4), (4, 0), (2, 2)):
            m = mfcontrol.simulate(best.with_overrides({ky: float(vy[i]),
                                                        kx: mfcontrol.config.resolve.axis_value(
                                                            kx, vx[j])})).metrics
            obj = mfcontrol.api.results.objective.Objective.parse(best["benchmark.objective"])
            assert e.map_scores[i, j] == obj.score_run(m)
        finite = e.map_scores[np.isfinite(e.map_scores)]
        assert row.worst_map_settled == (finite.max() if finite.size else math.inf)
    md = (out / "report.md").read_text()
    for e in entries:
        assert f"| {PLANT} | {e.controller} |" in md
    assert "## What the table shows" in md and "loses to the PID" in md
    assert "at a bound of their search space" in md
    for png in ("robustness.png", f"{PLANT}/comparison.png",
                f"{PLANT}/PID/convergence.png"):
        assert (out / png).stat().st_size > 20_000


def test_every_tuned_loop_has_its_linear_analysis(run):
    entries, out = run
    table = pd.read_csv(out / "results.csv")
    md = (out / "report.md").read_text()
    assert "## Each tuned loop, linear" in md and "Tuned loops with Ms above 2: PID" in md
    for e, row in zip(entries, table.itertuples(), strict=True):
        _, best = cases.resolve_case(out / PLANT / e.controller / "best.toml")
        m = mfcontrol.analyze(best).margins
        assert row.Ms == pytest.approx(m["Ms"], rel=1e-12)
        assert row.noise_gain_h2 == pytest.approx(m["noise_gain_h2"], rel=1e-12)
        assert bool(row.linear_stable) is m["stable"]
        assert f"| {PLANT} | {e.controller} | {'stable' if m['stable'] else 'unstable'} |" in md


def test_a_second_call_resumes_the_finished_tunings(run, monkeypatch):
    entries, out = run

    def no_tuning(*args, **kwargs):
        raise AssertionError("a finished tuning ran again")

    monkeypatch.setattr("mfcontrol.experiments.tune.tune", no_tuning)
    again = bm.benchmark([PLANT], budget=BUDGET, seed=1, out=out)
    assert [e.tuned for e in again] == [e.tuned for e in entries]
    assert [e.objective for e in again] == [e.objective for e in entries]


def test_a_plant_without_a_benchmark_table_is_refused(tmp_path):
    with pytest.raises(mfcontrol.ConfigError, match="a benchmark case must give it"):
        bm.benchmark(["first-order-ip-algebraic"], budget=10, out=tmp_path)


def _user_plant(tmp_path, name="my-plant.toml", **changes):
    text = (cases.CASES_DIR / "bench-lag3.toml").read_text()
    text = text.replace("t_end = 40.0", "t_end = 24.0").replace("t0 = 20.0", "t0 = 12.0")
    for old, new in changes.items():
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_plant_given_as_a_file_writes_its_report(tmp_path):
    plant = _user_plant(tmp_path)
    entries = bm.benchmark([str(plant)], budget=12, out=tmp_path / "out")
    md = (tmp_path / "out" / "report.md").read_text()
    assert "| my-plant | PID |" in md and "Benchmark set (Astrom-Hagglund)" in md
    assert len(entries) == 3


@pytest.mark.parametrize(("change", "needle"), [
    (('robustness = ["plant.gain=0.5,0.71,1,1.41,2", "plant.time_scale=0.67,0.82,1,1.22,1.5"]',
      'robustness = ["plant.gain=0.5,1,2"]'), "exactly two"),
    (('log = ["controller.kp"', 'log = ["controller.N", "controller.kp"'), "benchmark.log"),
    (('pid = ["controller.kp=0.01:10"', 'pid = ["controller.kp=0:10"'), "benchmark.pid"),
])
def test_a_bad_benchmark_table_is_refused_before_any_work(tmp_path, change, needle):
    plant = _user_plant(tmp_path, **{change[0]: change[1]})
    with pytest.raises(mfcontrol.ConfigError, match=needle):
        bm.benchmark([str(plant)], budget=12, out=tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_two_plants_of_one_name_are_refused(tmp_path):
    a = _user_plant(tmp_path)
    (tmp_path / "b").mkdir()
    b = _user_plant(tmp_path / "b")
    with pytest.raises(mfcontrol.ConfigError, match="collide"):
        bm.benchmark([str(a), str(b)], budget=12, out=tmp_path / "out")


def test_a_tuning_with_other_inputs_is_not_reused(tmp_path, monkeypatch):
    plant = _user_plant(tmp_path)
    bm.benchmark([str(plant)], budget=12, out=tmp_path / "out")
    calls = []
    real = mfcontrol.experiments.tune.tune

    def counted(*args, **kwargs):
        calls.append(args[1])
        return real(*args, **kwargs)

    monkeypatch.setattr("mfcontrol.experiments.tune.tune", counted)
    plant.write_text(plant.read_text().replace('"controller.kd=0.000001:10"',
                                               '"controller.kd=0.001:1"'))
    bm.benchmark([str(plant)], budget=12, out=tmp_path / "out")
    assert len(calls) == 1  # the PID's space changed: its tuning runs again, no other


def test_a_search_that_finds_nothing_is_reported_as_such(tmp_path, monkeypatch):
    plant = _user_plant(tmp_path)
    real = mfcontrol.experiments.tune.tune

    def nothing_stable(base, params, **kwargs):
        r = real(base, params, **kwargs)
        if base["controller.law"] == "i-P":
            r.value = math.inf
        return r

    monkeypatch.setattr("mfcontrol.experiments.tune.tune", nothing_stable)
    entries = bm.benchmark([str(plant)], budget=12, out=tmp_path / "out")
    ip = next(e for e in entries if e.controller == "i-P")
    assert not ip.settled and math.isinf(ip.objective) and ip.tuned == {}
    md = (tmp_path / "out" / "report.md").read_text()
    assert "| my-plant | i-P | no settled point found |" in md


def _entry(controller, objective, settled=True, tuned=None, n_linear_stable=25):
    return bm.Entry(plant="p", controller=controller, config=None, tuned=tuned or {},
                    evaluations=10, objective=objective, iae_setpoint=objective,
                    iae_load=objective, tv_u_noise=objective, worst=objective, n_settled=25,
                    n_map=25, settled=settled, tuning_seconds=1.0, map_scores=np.zeros((5, 5)),
                    n_linear_stable=n_linear_stable)


def test_findings_name_winners_losers_and_bounds():
    spaces = {"p": {"PID": (["controller.kp=0.1:10"], ["controller.kp"]),
                    "i-P": (["controller.kp=0.1:10"], []), "i-PI": (["controller.kp=0.1:10"], [])}}
    entries = [_entry("PID", 2.0, tuned={"controller.kp": 10.0}),
               _entry("i-P", 1.0, settled=False, tuned={"controller.kp": 5.0}),
               _entry("i-PI", 3.0, tuned={"controller.kp": 0.1}, n_linear_stable=11)]
    text = "\n".join(bm._findings(entries, ["p"], spaces))
    # the two verdicts on the map, each in its own sentence
    assert "robustness map (the plant as it is at t = 0" in text
    assert text.endswith("bounded oscillation): i-PI on p (11/25).")
    # the unstable i-P is never best although its numbers are lowest
    assert "Best on the tuned objective: PID on 1 (p); i-P on none; i-PI on none." in text
    assert "i-P on p (not settled), i-PI on p (1.5x the PID's)" in text
    assert "PID kp on p (upper, 10), i-PI kp on p (lower, 0.1)" in text
