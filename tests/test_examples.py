"""Each example runs, saves its figure and does what its docstring says."""

import runpy
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _run(name, tmp_path, monkeypatch):
    out = tmp_path / f"{name}.png"
    monkeypatch.setattr(sys, "argv", [name, str(out)])
    ns = runpy.run_path(str(EXAMPLES / f"{name}.py"), run_name="not_main")
    result = ns["main"](str(out))
    assert out.stat().st_size > 10_000
    return result


def test_own_plant_ode(tmp_path, monkeypatch):
    res = _run("own_plant_ode", tmp_path, monkeypatch)
    assert res.metrics["settled"] and abs(res.error[-1]) < 1e-3


def test_live_loop(tmp_path, monkeypatch):
    t, w, r, v, ctrl = _run("live_loop", tmp_path, monkeypatch)
    assert ctrl.nan_count == 5
    assert abs(w[-1] - r[-1]) < 0.5
    assert abs(v).max() <= 24


def test_boost_ipd(tmp_path, monkeypatch):
    res = _run("boost_ipd", tmp_path, monkeypatch)
    assert res.metrics["settled"]
    t = res.time
    assert abs(res.error[(t > 0.03) & (t < 0.04)]).max() < 1e-3  # holds 30 V before the load
    assert abs(res.error[t > 0.055]).max() < 1e-3  # and after it


def test_realistic_loops(tmp_path, monkeypatch):
    runs, delayed = _run("realistic_loops", tmp_path, monkeypatch)
    tv = {name: res.metrics["tv_u"] for name, res in runs.items()}
    # the docstring's claims: backward differences chatter, the algebraic estimator and
    # the PI do not; the algebraic i-PI tracks best; 20 samples of delay leave only the PI
    assert tv["motor-noise-ipi"] > 30 * max(tv["motor-noise-ipi-algebraic"],
                                            tv["motor-noise-pid"])
    iae = {name: res.metrics["iae"] for name, res in runs.items()}
    assert min(iae, key=iae.get) == "motor-noise-ipi-algebraic"
    assert [res.metrics["settled"] for res in delayed.values()] == [False, False, True]


def test_default_figure_goes_to_results(tmp_path, monkeypatch):
    """Run from any folder with no argument, an example writes results/examples/NAME.png
    (ignored by git) and nothing else in the working folder (it wrote NAME.png there)."""
    monkeypatch.chdir(tmp_path)
    ns = runpy.run_path(str(EXAMPLES / "own_plant_ode.py"), run_name="not_main")
    ns["main"]()
    assert [p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")
            if p.is_file()] == ["results/examples/own_plant_ode.png"]


def test_estimator_tradeoff(tmp_path, monkeypatch):
    rows = _run("estimator_tradeoff", tmp_path, monkeypatch)
    h = 1e-3
    bd, algebraic = rows[0], rows[1:]
    assert bd["window"] == 0 and [r["window"] for r in algebraic] == [5, 10, 20, 40, 80]
    # backward differences: half a sample late, sqrt(2) sigma / h of noise (5.5 rad/s^2)
    assert 0.4 * h < bd["delay"] < 0.6 * h
    assert 5.0 < bd["noise"] < 6.0
    # the algebraic estimator: a delay of half its window, noise falling as the window grows
    for r in algebraic:
        assert abs(r["delay"] - r["window"] * h / 2) < 0.1 * r["window"] * h / 2
        assert 0.85 < r["noise"] / r["closed_form"] < 1.15  # within 3 %, or 10 % (M <= 20)
        assert r["delay"] == pytest.approx(r["window"] * h / 2, rel=1e-3)  # the held kernel
    noise = [r["noise"] for r in rows]
    delay = [r["delay"] for r in rows]
    assert noise == sorted(noise, reverse=True) and delay == sorted(delay)
    # the longest window: far less noise, far more delay than backward differences
    assert algebraic[-1]["noise"] < bd["noise"] / 200
    assert algebraic[-1]["delay"] > 60 * bd["delay"]
    slope = np.polyfit(np.log(delay[1:]), np.log(noise[1:]), 1)[0]
    assert -1.6 < slope < -1.45


def test_paper_load_change(tmp_path, monkeypatch):
    out = _run("paper_load_change", tmp_path, monkeypatch)
    std, var = "voltage-unstable-standard", "voltage-unstable-variational"
    assert out["settled"] == {std: False, var: True}
    # the standard i-P rings after 4 ms and blows up after 6 ms, the duty at 0.9 by 8.2 ms
    assert out["max_e_first"][std] > 1.0 and out["max_e_second"][std] > 10.0
    assert 8.0e-3 < out["t_rail"] < 8.5e-3
    # the variational law: 0.18 V and 0.12 V, 0.049 V at the end
    assert out["max_e_first"][var] < 0.2 and out["max_e_second"][var] < 0.15
    assert out["final_e"] < 0.06
    # gamma barely moves; a standard i-P at alpha = 1/gamma0 is the same loop to 6 uV
    assert 0.9999 < out["gamma_end"] < 1.0
    assert out["equal_gain_diff"] < 1e-5


def test_robustness_map(tmp_path, monkeypatch):
    out = _run("robustness_map", tmp_path, monkeypatch)
    frame = out["frame"]
    assert len(frame) == 17 * 13
    # stable above a boundary alpha ~ b/2: 0.42 to 0.54 of Km/(J Ra) on this grid
    assert 0.35 < out["ratio"].min() and out["ratio"].max() < 0.6
    for _, rows in frame.groupby("plant.J"):
        rows = rows.sort_values("controller.alpha")
        settled = rows["settled"].astype(bool).to_numpy()
        first = int(np.argmax(settled))
        assert settled[first:].all() and not settled[:first].any()  # one boundary per row
    assert out["n_diverged"] >= 70 and out["n_settled"] + out["n_diverged"] >= len(frame) - 3
    lo, hi = out["iae_range"]
    assert 4.5 < lo < 5.2 and 7.0 < hi < 8.0


def test_tune_against_pid(tmp_path, monkeypatch):
    out = _run("tune_against_pid", tmp_path, monkeypatch)
    tuned, runs = out["tuned"], out["runs"]
    assert all(res.metrics["settled"] for res in runs.values())
    # with 1,500 points each the i-PI scores about 5 % better than the PID, on every part
    ratio = tuned["i-PI"].value / tuned["PID"].value
    assert 0.9 < ratio < 1.0
    m = {name: res.metrics for name, res in runs.items()}
    assert m["i-PI"]["iae"] < m["PID"]["iae"]
    assert m["i-PI"]["iae_load"] < m["PID"]["iae_load"]
    assert m["i-PI"]["tv_u"] < 0.8 * m["PID"]["tv_u"]
    assert tuned["PID"].best["controller.kd"] < 1e-5  # at its lower bound: a PI
    # compare ran the tuned configurations: its objective is the tuned value
    for name in tuned:
        assert abs(m[name]["iae"] + 0.01 * m[name]["tv_u"] - tuned[name].value) < 1e-9


def test_python_control_plant(tmp_path, monkeypatch):
    out = _run("python_control_plant", tmp_path, monkeypatch)
    assert out["step_diff"] < 1e-9  # equals control.step_response
    assert np.allclose(out["poles"], -20.0, atol=1e-2)
    m = {name: res.metrics for name, res in out["runs"].items()}
    assert all(v["settled"] for v in m.values())
    assert m["i-PD"]["iae"] < m["PID"]["iae"] / 50
    assert m["i-PD"]["iae_load"] < m["PID"]["iae_load"] / 20
    assert np.abs(out["runs"]["i-PD"].error).max() < 2e-3  # within 2 um
    # the held kernel's order-2 estimate: no ringing at the command's steps
    assert m["i-PD"]["tv_u"] < m["PID"]["tv_u"]


def test_c_export(tmp_path, monkeypatch):
    out = _run("c_export", tmp_path, monkeypatch)
    assert out["python_rejected"] == 5 and out["same_as_run"]
    if out["note"] is not None:  # no C compiler on this machine: the Python side only
        pytest.skip(out["note"])
    assert out["max_diff"] == 0.0 and out["c_rejected"] == 5
    assert np.array_equal(out["u_c"], out["u_python"])


def test_c_export_without_a_compiler(tmp_path, monkeypatch, capsys):
    """No C compiler: one printed line that says so, the Python side drawn, no error."""
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))
    out = _run("c_export", tmp_path, monkeypatch)
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 1 and "no C compiler found" in lines[0]
    assert out["u_c"] is None and out["max_diff"] is None
