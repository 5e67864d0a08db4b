"""``mfcontrol benchmark`` on one shortened plant with a tiny budget: every searched
controller had the same budget, objective, bound and training seeds; the kept tuning is
the best restart; the table's numbers are the kept tunings' runs on the held-out seeds;
the rule-tuned PIDs are the rules' gains; a win is written only where the widened
interval excludes zero; a second call resumes."""

import json
import math

import numpy as np
import pandas as pd
import pytest

import mfcontrol
from mfcontrol.analysis import tuning_rules as rules
from mfcontrol.experiments import benchmark as bm
from mfcontrol.experiments import cases, statistics

BUDGET = 60  # with seed 1, every searched controller finds a point meeting the bound
RESTARTS = 2


def _user_plant(tmp_path, name="my-plant.toml", **changes):
    """bench-lag3 over a shorter horizon (24 s, the load at 12 s)."""
    text = (cases.CASES_DIR / "bench-lag3.toml").read_text()
    text = text.replace("t_end = 40.0", "t_end = 24.0").replace("t0 = 20.0", "t0 = 12.0")
    for old, new in changes.items():
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    d = tmp_path_factory.mktemp("benchmark")
    plant = _user_plant(d)
    out = d / "out"
    entries = bm.benchmark([str(plant)], budget=BUDGET, restarts=RESTARTS, seed=1,
                           quick=True, out=out)
    return entries, out


def test_every_benchmark_case_is_complete():
    assert len(bm.plants()) >= 10
    for name in bm.plants():
        _, cfg = cases.resolve_case(name)
        assert cfg["sensor.noise"] != "none"
        assert cfg["disturbance.kind"] != "none" or cfg["plant.schedule"] or \
            cfg["plant.change_times"]
        assert cfg["reference.kind"] == "smooth-step"
        spaces = {key: bm.parse_parameters(cfg[key], [
            k for k in cfg["benchmark.log"] if any(p.startswith(k + "=") for p in cfg[key])])
            for _, _, key in bm.CONTROLLERS}
        # comparable freedom: the PID's measurement filter is searched, on a log scale
        assert [p.key for p in spaces["benchmark.pid"]] == [
            "controller.kp", "controller.ki", "controller.kd", "controller.Tf"]
        assert all(p.log for p in spaces["benchmark.pid"])
        assert [len(spaces[k]) for k in ("benchmark.pid", "benchmark.ip",
                                         "benchmark.ipi", "benchmark.adrc")] == [4, 3, 4, 3]
        assert [p.key for p in spaces["benchmark.adrc"]] == [
            "controller.b0", "controller.wc", "controller.wo"]
        assert len(mfcontrol.api.run.batch.parse_grid(cfg["benchmark.robustness"])) == 2


def test_held_out_seeds_are_not_training_seeds():
    for scale in (bm.FULL, bm.QUICK):
        assert not set(scale.held_out) & set(scale.train_seeds)
        assert scale.restarts >= 3 and len(scale.held_out) >= statistics.MIN_PAIRS
    assert len(bm.FULL.held_out) >= 30


def test_same_budget_objective_bound_and_seeds_for_every_search(run):
    entries, out = run
    assert [e.controller for e in entries] == ["PID", "i-P", "i-PI", "ADRC", "PID SIMC",
                                               "PID AMIGO"]
    for e in entries[:4]:
        assert e.kind == "searched" and len(e.restart_values) == RESTARTS
        for seed in (1, 2):
            s = json.loads((out / "my-plant" / e.controller / f"restart-{seed}" /
                            "summary.json").read_text())
            assert (s["budget"], s["seed"], s["objective"]) == (BUDGET, seed,
                                                                "iae + 0.01*tv_u")
            assert s["constraints"] == ["Ms<=2"] and s["aggregate"] == "mean"
            assert s["scenarios"] == {"sensor.seed": [float(k) for k in
                                                      bm.QUICK.train_seeds]}
            assert BUDGET - 6 < s["evaluations"] <= BUDGET and s["stopped"] == "budget"


def test_the_kept_tuning_is_the_best_restart(run):
    entries, out = run
    assert all(e.config is not None for e in entries[:4])
    for e in entries[:4]:
        values = [json.loads((out / "my-plant" / e.controller / f"restart-{s}" /
                              "summary.json").read_text()) for s in (1, 2)]
        best = min(values, key=lambda v: v["best"] if isinstance(v["best"], float)
                   else math.inf)
        if e.config is None:
            continue
        assert e.tuned == best["parameters"]
        assert e.restart_values == [v["best"] if isinstance(v["best"], float) else math.inf
                                    for v in values]


def test_the_table_is_the_kept_tunings_runs_on_the_held_out_seeds(run):
    entries, out = run
    table = pd.read_csv(out / "results.csv")
    assert list(table["controller"]) == [e.controller for e in entries]
    for e, row in zip(entries, table.itertuples(), strict=True):
        if e.config is None:
            continue
        obj = mfcontrol.api.results.objective.Objective.parse(e.config["benchmark.objective"])
        seed = bm.QUICK.held_out[3]
        m = mfcontrol.simulate(e.config.with_overrides({"sensor.seed": seed})).metrics
        assert e.scores["objective"][3] == pytest.approx(obj.score_run(m), rel=1e-12)
        assert e.scores["regulator"][3] == pytest.approx(m["iae_load"], rel=1e-12)
        assert e.scores["servo"][3] == pytest.approx(m["iae"] - m["iae_load"], rel=1e-12)
        assert row.objective == pytest.approx(np.mean(e.scores["objective"]), rel=1e-12)
        assert row.held_out_seeds == len(bm.QUICK.held_out)
        lin = mfcontrol.analyze(e.config).margins
        assert row.Ms == pytest.approx(lin["Ms"], rel=1e-12)


def test_the_sample_time_variants_keep_delays_and_windows_in_seconds():
    _, cfg = cases.resolve_case("bench-delay-lag-t1")
    cfg = cfg.with_overrides({"controller.law": "i-PI"})
    v = bm._variants(cfg)
    assert (v["h/2"]["sim.h"], v["h/2"]["actuator.delay"], v["h/2"]["controller.window"]) == (
        0.01, 100, 20)
    assert (v["2h"]["sim.h"], v["2h"]["actuator.delay"], v["2h"]["controller.window"]) == (
        0.04, 25, 5)
    assert v["delay+1"]["actuator.delay"] == 51 and v["delay+1"]["sim.h"] == 0.02


def test_the_rule_tuned_pids_are_the_rules_gains(run):
    entries, _ = run
    model = rules.fopdt_of(_lag3_tf(), delay=0.01)
    simc, amigo = entries[4], entries[5]
    # SIMC's PID on the half rule's second-order model (its lags 1.5 and 1)
    assert simc.tuned == pytest.approx(
        dict(zip(("controller.kp", "controller.ki", "controller.kd"),
                 rules.simc(rules.sopdt_of(_lag3_tf(), delay=0.01), kind="PID")[:3],
                 strict=True)))
    assert amigo.tuned == pytest.approx(
        dict(zip(("controller.kp", "controller.ki", "controller.kd"),
                 rules.amigo(model, kind="PID")[:3], strict=True)))
    assert amigo.config["controller.b"] == 1.0 and not amigo.restart_values


def _lag3_tf():
    import control

    return control.tf([1.0], [1.0, 3.0, 3.0, 1.0])


def test_a_plant_without_a_model_has_no_rule_tuned_row_but_says_why():
    _, cfg = cases.resolve_case("bench-integrating-delay")
    plant = bm._Plant("x", cfg, {}, {})
    rows = bm._rule_rows(plant)
    assert [r[0] for r in rows] == list(bm.RULES)
    assert all(r[1] is None and "no model" in r[3] and "integrator" in r[3] for r in rows)


def test_comparisons_are_paired_and_widened_by_bonferroni(run):
    entries, out = run
    pid = entries[0]
    made = [(e, "objective", e.comparison) for e in entries[1:] if e.comparison] + [
        (e, k, c) for e in entries[1:] for k, c in e.parts.items()]
    # the objective, the servo and the regulator IAE of each controller whose held-out
    # runs all settled (the rule-tuned PIDs' do not on this short horizon)
    assert len(made) == 3 * sum(1 for e in entries[1:] if e.comparison) > 0
    assert all(e.comparison_note.endswith("did not settle") for e in entries[1:]
               if e.scores and not e.comparison)
    confidence, n_resamples = bm.bonferroni(len(made))
    assert confidence == 1 - bm.ALPHA / len(made)
    for e, key, c in made:
        assert c == statistics.paired(e.scores[key], pid.scores[key], confidence=confidence,
                                      n_resamples=n_resamples)
    md = (out / "report.md").read_text()
    assert "Bonferroni" in md and f"{len(made)} comparisons" in md


def _entry(plant, name, scores):
    return bm.Entry(plant=plant, controller=name, kind="searched", config=None, tuned={},
                    scores={"objective": np.asarray(scores, dtype=float)})


def test_a_win_is_never_written_where_the_interval_contains_zero():
    rng = np.random.default_rng(3)
    b = rng.uniform(3.0, 4.0, 30)
    d = rng.normal(0.0, 0.2, 30)
    d -= d.mean()
    # on 20 plants: a difference whose 95 % interval excludes zero, but not the interval
    # widened over the 20 comparisons; and one that is zero on average
    shift = 2.3 * d.std(ddof=1) / math.sqrt(d.size)
    narrow = statistics.paired(b - shift + d, b)
    wide = statistics.paired(b - shift + d, b, confidence=1 - 0.05 / 20)
    assert narrow.verdict == "A better" and wide.verdict == "no significant difference"
    entries = []
    for i in range(20):
        p = f"plant-{i}"
        entries += [_entry(p, "PID", b), _entry(p, "i-PI", b - shift + d if i == 0 else b + d)]
    assert bm._compare_all(entries) == 20
    for e in entries[1::2]:
        assert e.comparison.low <= 0 <= e.comparison.high
        assert e.comparison.verdict == "no significant difference"
        assert "beats" not in bm.verdict(e) and "No significant difference" in bm.verdict(e)
    lines = bm._findings(entries, {})
    assert lines[0].startswith("- i-PI beats the searched PID on no plant; loses on none")


def test_a_win_is_written_where_the_interval_excludes_zero():
    b = np.linspace(3.0, 4.0, 12)
    entries = [_entry("p", "PID", b), _entry("p", "i-PI", b - 0.3 + 0.01 * np.sin(b * 9))]
    bm._compare_all(entries)
    assert entries[1].comparison.high < 0
    assert bm.verdict(entries[1]).startswith("i-PI beats PID on p")


def test_a_seed_that_did_not_settle_is_not_compared():
    b = np.linspace(3.0, 4.0, 12)
    a = b.copy()
    a[4] = math.inf
    entries = [_entry("p", "PID", b), _entry("p", "i-P", a)]
    assert bm._compare_all(entries) == 0
    assert bm.verdict(entries[1]) == ("i-P on p: not compared: 1 of 12 held-out seeds did "
                                      "not settle")


def test_the_report_and_its_figures(run):
    entries, out = run
    md = (out / "report.md").read_text()
    for e in entries:
        assert f"| my-plant | {e.controller} |" in md
    for words in ("## Held-out scores", "## Robustness of each loop",
                  "## What the numbers support", "the i-P is a PI controller",
                  "Ms <= 2", "held-out noise seeds", "servo", "regulator", "h/2", "2h",
                  "delay+1"):
        assert words in md, words
    for png in ("robustness.png", "pareto.png", "my-plant/comparison.png",
                "my-plant/PID/restart-1/convergence.png"):
        assert (out / png).stat().st_size > 20_000


def test_a_second_call_resumes_the_finished_tunings_and_scorings(run, monkeypatch):
    entries, out = run

    def no_work(*args, **kwargs):
        raise AssertionError("a finished tuning or scoring ran again")

    monkeypatch.setattr("mfcontrol.experiments.tune.tune", no_work)
    monkeypatch.setattr(bm, "_run_seeds", no_work)
    plant = out.parent / "my-plant.toml"
    again = bm.benchmark([str(plant)], budget=BUDGET, restarts=RESTARTS, seed=1, quick=True,
                         out=out)
    assert [e.tuned for e in again] == [e.tuned for e in entries]
    for a, b in zip(again, entries, strict=True):
        assert a.scores.keys() == b.scores.keys()
        for k in a.scores:
            np.testing.assert_array_equal(a.scores[k], b.scores[k])


def test_an_interrupted_benchmark_resumes_after_its_last_finished_tuning(tmp_path,
                                                                          monkeypatch):
    plant = _user_plant(tmp_path)
    kwargs = {"budget": 12, "restarts": 2, "quick": True, "out": tmp_path / "out"}

    def ctrl_c(fraction, text):
        if text.startswith("my-plant i-P restart 1/2"):
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        bm.benchmark([str(plant)], progress=ctrl_c, **kwargs)
    assert not (tmp_path / "out" / "report.md").exists()
    real = mfcontrol.experiments.tune.tune
    tuned = []

    def counted(base, params, **kw):
        tuned.append((base["controller.law"], kw["seed"]))
        return real(base, params, **kw)

    monkeypatch.setattr("mfcontrol.experiments.tune.tune", counted)
    bm.benchmark([str(plant)], **kwargs)
    # the PID's two restarts were finished: only the interrupted and the later ones run
    assert tuned == [("i-P", 0), ("i-P", 1), ("i-PI", 0), ("i-PI", 1), ("adrc", 0),
                     ("adrc", 1)]
    assert (tmp_path / "out" / "report.md").is_file()


def test_a_controller_a_plant_does_not_search_is_skipped(tmp_path):
    # a row of CONTROLLERS (here the ADRC's) whose key a plant leaves unset
    line = next(x for x in (cases.CASES_DIR / "bench-lag3.toml").read_text().splitlines()
                if x.startswith("adrc = "))
    assert list(bm._check_plant("bench-lag3", bm.QUICK).spaces) == ["PID", "i-P", "i-PI",
                                                                       "ADRC"]
    logged = ', "controller.b0", "controller.wc", "controller.wo"'
    plant = bm._check_plant(str(_user_plant(tmp_path, **{line: "", logged: ""})), bm.QUICK)
    assert list(plant.spaces) == ["PID", "i-P", "i-PI"]


def test_a_search_that_finds_nothing_is_reported_as_such(tmp_path, monkeypatch):
    plant = _user_plant(tmp_path)
    real = mfcontrol.experiments.tune.tune

    def nothing_stable(base, params, **kwargs):
        r = real(base, params, **kwargs)
        if base["controller.law"] == "i-P":
            r.value = math.inf
        return r

    monkeypatch.setattr("mfcontrol.experiments.tune.tune", nothing_stable)
    entries = bm.benchmark([str(plant)], budget=12, restarts=2, quick=True,
                           out=tmp_path / "out")
    ip = next(e for e in entries if e.controller == "i-P")
    assert ip.config is None and ip.tuned == {} and not ip.scores
    md = (tmp_path / "out" / "report.md").read_text()
    assert "| my-plant | i-P | no point met Ms <= 2 and settled in 2 restarts |" in md
    assert "i-P not compared: no tuning" in md or "not compared: no tuning" in md


def test_a_plant_without_a_benchmark_table_is_refused(tmp_path):
    with pytest.raises(mfcontrol.ConfigError, match="a benchmark case must give it"):
        bm.benchmark(["first-order-ip-algebraic"], budget=10, out=tmp_path)


@pytest.mark.parametrize(("kwargs", "needle"), [
    ({"ms": 1.0}, "--ms = 1.0: must be a finite number > 1"),
    ({"ms": math.nan}, "--ms = nan"),
    ({"restarts": 1}, "--restarts = 1: must be a whole number >= 2"),
])
def test_bad_settings_are_refused_before_any_work(tmp_path, kwargs, needle):
    with pytest.raises(mfcontrol.ConfigError, match=needle.replace("+", r"\+")):
        bm.benchmark(["bench-lag3"], out=tmp_path / "out", **kwargs)
    assert not (tmp_path / "out").exists()


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
