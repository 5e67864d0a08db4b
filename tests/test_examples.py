"""Each example runs, saves its figure and does what its docstring says."""

import runpy
import sys
from pathlib import Path

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
    assert res.metrics["stable"] and abs(res.error[-1]) < 1e-3


def test_live_loop(tmp_path, monkeypatch):
    t, w, r, v, ctrl = _run("live_loop", tmp_path, monkeypatch)
    assert ctrl.nan_count == 5
    assert abs(w[-1] - r[-1]) < 0.5
    assert abs(v).max() <= 24


def test_boost_ipd(tmp_path, monkeypatch):
    res = _run("boost_ipd", tmp_path, monkeypatch)
    assert res.metrics["stable"]
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
    assert [res.metrics["stable"] for res in delayed.values()] == [False, False, True]


def test_default_figure_goes_to_results(tmp_path, monkeypatch):
    """Run from any folder with no argument, an example writes results/examples/NAME.png
    (ignored by git) and nothing else in the working folder (it wrote NAME.png there)."""
    monkeypatch.chdir(tmp_path)
    ns = runpy.run_path(str(EXAMPLES / "own_plant_ode.py"), run_name="not_main")
    ns["main"]()
    assert [p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")
            if p.is_file()] == ["results/examples/own_plant_ode.png"]
