"""A bounded fuzzer over the command line and the live API (issue 14): no traceback, no
silent NaN, every refusal one line naming the key. The tallies are printed in the test
summary ("counts")."""

from __future__ import annotations

import contextlib
import io
import json
import math
import string
import tomllib
from collections import Counter

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mfcontrol
from mfcontrol.cli import main
from mfcontrol.config.options import BY_KEY

CASES = ["voltage-stable-standard", "motor-noise-ipi", "first-order-ip-algebraic", "buck-ipi",
         "bench-lag3"]
#: values that broke things before, or sit at an edge
EDGES = ["nan", "inf", "-inf", "1e309", "-1e309", "0", "-0.0", "-1", "1e-320", "5e-324",
         "1e308", "99999999999999999999999", "abc", '"abc"', "[]", "[1,2]", "[nan]", "[[1]]",
         "{a=1}", "true", "", '"', "[", "1,2", "0x10", "1_000", "[1,'a']", "[[[[[[[[[[1]]]]]]]]]]",
         "[{t=1, name='R', set=5}]", "[{t=-1, name='R', set=5}]", "[{t=1, name='J', add=-9}]",
         "2", "0.5", "10", "1e-9", "3", "[0.001]", "ip", "pid", "i-PID", "algebraic", "rk45",
         "exact", "second-order", "paper"]
SAFE = "".join(c for c in string.printable if c not in "=\"'\\" + string.whitespace)
#: the numbers a run is fuzzed over: the plant's and the controller's (the loop elements'
#: switch compiled variants, whose first compilation would dominate this test's time)
NUMERIC = sorted(k for k, o in BY_KEY.items() if o.kind in ("float", "int")
                 and k.startswith(("plant.", "controller.")))

keys = st.one_of(st.sampled_from(sorted(BY_KEY)), st.sampled_from(sorted(BY_KEY)),
                 st.text(SAFE, min_size=1, max_size=14))
values = st.one_of(st.sampled_from(EDGES), st.floats().map(repr),
                   st.integers(-10**25, 10**25).map(str), st.text(SAFE, max_size=10),
                   st.lists(st.floats(), max_size=3).map(lambda v: f"[{', '.join(map(repr, v))}]"))


def _cli(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = main(argv)
        except SystemExit as exc:  # argparse's own errors
            rc = exc.code
    return rc, out.getvalue(), err.getvalue()


def _one_line_naming(err: str, key: str) -> None:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mfcontrol"), err
    assert key.strip() in lines[0], (key, err)


def _finite(value) -> bool:
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, dict):
        return all(_finite(v) for v in value.values())
    if isinstance(value, list):
        return all(_finite(v) for v in value)
    return True


@pytest.fixture(scope="module")
def tally():
    return Counter()


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=st.sampled_from(CASES), key=keys, value=values)
def test_show_with_any_setting(case, key, value, tally):
    """`mfcontrol show CASE --set KEY=VALUE`: the resolved case, or one line naming KEY."""
    # --set=K=V: with a space, argparse takes a KEY starting with "-" for an option
    rc, out, err = _cli(["show", case, f"--set={key}={value}"])
    if rc == 0:
        assert _finite(tomllib.loads(out)), out  # nothing non-finite accepted silently
        tally["show accepted"] += 1
    else:
        assert rc == 2
        _one_line_naming(err, key)
        tally["show refused"] += 1


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=st.sampled_from(CASES[:2]), key=st.sampled_from(NUMERIC),
       value=st.one_of(st.sampled_from(EDGES[:12]), st.floats(-1e6, 1e6).map(repr),
                       st.sampled_from(["1e30", "-1e30", "1e-30", "1e15", "7", "1e6"])))
def test_a_run_with_any_number(case, key, value, tally):
    """A short run of the case with one number changed: metrics without a NaN unless the
    run is flagged as not stable, or one line naming the key. (The library path of
    `mfcontrol run`, without its files: the files are written from these metrics.)"""
    from mfcontrol.errors import ConfigError
    from mfcontrol.experiments import cases

    t_end = {"voltage-stable-standard": 0.0005, "motor-noise-ipi": 1.0}[case]
    try:
        name, cfg = cases.resolve_case(case, {"sim.t_end": t_end,
                                              key: tomllib.loads(f"v = {value}")["v"]})
        res = cases.run_config(cfg, name)
    except ConfigError as exc:
        assert str(exc).count("\n") == 0 and key in str(exc), str(exc)
        tally["run refused"] += 1
        return
    m = json.loads(res.metrics_json())
    if m["settled"]:
        assert all(math.isfinite(m[k]) for k in ("iae", "ise", "max_abs_e", "tv_u")), m
        tally["run stable"] += 1
    else:
        tally["run flagged not stable"] += 1


def test_the_command_line_run_writes_its_files_or_refuses(tmp_path, tally):
    """A few real `mfcontrol run` commands (the path above, then the files)."""
    for i, (key, value) in enumerate([("controller.alpha", "1e30"), ("controller.alpha", "nan"),
                                      ("plant.R", "1e-300"), ("controller.kp", "-1e6")]):
        rc, _, err = _cli(["run", "voltage-stable-standard", "--set", "sim.t_end=0.0005",
                           "--set", f"{key}={value}", "--out", str(tmp_path / str(i))])
        if rc == 0:
            m = json.loads((tmp_path / str(i) / "metrics.json").read_text())
            assert not m["settled"] or math.isfinite(m["iae"])
            tally["cli run written"] += 1
        else:
            _one_line_naming(err, key)
            tally["cli run refused"] += 1


# --- the live API ------------------------------------------------------------------------

numbers = st.one_of(st.floats(), st.integers(-10**30, 10**30), st.sampled_from(
    [0.0, 1.0, 2.5, 0.01, np.float64(2.0), np.int64(4), np.float32(0.1), True, None, "1",
     [1], 5e-324, 1e300]))
OPTIONS = {
    "IP": ["sample_time", "order", "output_limits", "estimator", "window", "anti_windup",
           "k_aw", "gain", "gamma0", "Gamma", "eps_M", "integrator", "setpoint",
           "starting_output", "input_limits"],
    "IPID": ["sample_time", "order", "output_limits", "estimator", "window", "anti_windup",
             "gain", "setpoint", "input_limits"],
    "PID": ["sample_time", "N", "b", "Tt", "output_limits", "setpoint", "input_limits"],
    "RecursiveIP": ["setpoint", "sample_time", "law", "gamma0", "Gamma", "eps_M",
                    "integrator", "deriv_scale", "output_gain", "duty_min", "duty_max",
                    "input_limits"],
}
CHOICES = {"order": [1, 2, 3, True], "estimator": ["backward-difference", "algebraic", "x"],
           "window": [None, 2, 3, 4, 40, 10**9, 2.0, -1],
           "anti_windup": ["clamp", "back-calculation", "none", "y"],
           "gain": ["constant", "variational", "external", 1],
           "integrator": ["first-order", "second-order", "z"],
           "law": ["ip", "variational", "i-P", 3],
           "output_limits": [(None, None), (-1, 1), (1, -1), (0, 0), (math.nan, 1),
                             (-math.inf, math.inf), [0, 10], 5, (0, 1, 2)],
           "input_limits": [(None, None), (-1, 1), (1, -1), (math.nan, 1), (-10, None),
                            5, (10**400, None)]}
N_ARGS = {"IP": 2, "IPID": 4, "PID": 3, "RecursiveIP": 2}


VALID = {"order": [1, 2], "estimator": ["backward-difference"], "window": [None],
         "anti_windup": ["clamp", "back-calculation", "none"],
         "gain": ["constant", "variational"], "integrator": ["first-order", "second-order"],
         "law": ["ip", "variational"], "output_limits": [(None, None), (-1, 1), [0, 10]],
         "input_limits": [(None, None), (-10, 10), (None, 100.0)]}


@st.composite
def controllers(draw):
    """Half the time every argument sensible (a controller is built and called), else
    each argument possibly garbage."""
    name = draw(st.sampled_from(sorted(OPTIONS)))
    sensible = st.floats(0.1, 10)
    fuzzed = draw(st.booleans())
    value = st.one_of(sensible, numbers) if fuzzed else sensible
    args = [draw(value) for _ in range(N_ARGS[name])]
    kw = {}
    for option in draw(st.lists(st.sampled_from(OPTIONS[name]), max_size=4, unique=True)):
        if option in CHOICES:
            kw[option] = draw(st.sampled_from(CHOICES[option] if fuzzed else VALID[option]))
        else:
            kw[option] = draw(value)
    if name != "RecursiveIP" and ("sample_time" not in kw or not fuzzed):
        kw["sample_time"] = 0.01
    return name, args, kw


calls = st.lists(st.tuples(
    st.one_of(st.floats(), st.sampled_from([0.5, np.float64(0.3), "a", None, 1e300])),
    st.one_of(st.none(), st.floats(), st.sampled_from(["x", np.float32(2)])),
    st.one_of(st.none(), st.floats(), st.sampled_from([0.01, 1e-300]))), max_size=25)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(spec=controllers(), sequence=calls, switch=st.one_of(st.none(), st.floats()))
def test_live_controllers_take_anything(spec, sequence, switch, tally):
    """Any constructor arguments: a controller or one line naming the parameter. Any call:
    a finite output within the limits, or one line naming y, setpoint, dt or alpha with
    nothing changed. A snapshot always round-trips."""
    name, args, kw = spec
    cls = getattr(mfcontrol, name)
    try:
        ctrl = cls(*args, **kw)
    except (ValueError, TypeError) as exc:
        msg = str(exc)
        assert msg and "\n" not in msg
        tally["controllers refused"] += 1
        return
    tally["controllers built"] += 1
    lo, hi = getattr(ctrl, "output_limits", (None, None))
    for k, (y, setpoint, dt) in enumerate(sequence):
        if k == len(sequence) // 2 and switch is not None:
            try:
                ctrl.set_auto_mode(False, last_output=switch)
                ctrl.set_auto_mode(True)
            except ValueError as exc:
                assert "last_output" in str(exc)
        kwargs = {"setpoint": setpoint}
        if name != "RecursiveIP":
            kwargs["dt"] = dt
        if getattr(ctrl, "_external", False):
            kwargs["alpha"] = 2.0
        before = ctrl.snapshot()
        try:
            u = ctrl(y, **kwargs)
        except ValueError as exc:
            assert "\n" not in str(exc)
            assert str(exc).split(" ")[0] in ("y", "setpoint", "dt", "alpha"), str(exc)
            after = ctrl.snapshot()
            assert json.dumps(after) == json.dumps(before)  # refused: nothing changed
            tally["calls refused"] += 1
            continue
        assert isinstance(u, float) and math.isfinite(u), u
        assert (lo is None or u >= lo) and (hi is None or u <= hi)
        tally["calls answered"] += 1
    snap = json.loads(json.dumps(ctrl.snapshot()))
    again = cls.from_snapshot(snap)
    assert json.dumps(again.snapshot()) == json.dumps(ctrl.snapshot())


# --- issue 29: extreme finite samples, huge integers, raising functions, damaged folders ---

ALGEBRAIC_WINDOW = 10
#: controllers that hold y' = -y + u (Euler, h = 0.01) at 1 from 0: every law family
STABLE = {
    "PID": lambda lim: mfcontrol.PID(kp=2.0, ki=1.0, kd=0.1, sample_time=0.01,
                                     output_limits=(-24, 24), input_limits=lim),
    "i-PI algebraic": lambda lim: mfcontrol.IPI(
        alpha=1.0, kp=4.0, ki=1.0, sample_time=0.01, estimator="algebraic",
        window=ALGEBRAIC_WINDOW, output_limits=(-24, 24), input_limits=lim),
    "i-PI variational": lambda lim: mfcontrol.IPI(
        alpha=1.0, kp=4.0, ki=1.0, sample_time=0.01, gain="variational",
        integrator="second-order", output_limits=(-24, 24), input_limits=lim),
    "i-PD": lambda lim: mfcontrol.IPD(alpha=1.0, kp=4.0, kd=0.05, order=1, sample_time=0.01,
                                      output_limits=(-24, 24), input_limits=lim),
    "recursive variational": lambda lim: mfcontrol.RecursiveIP(law="variational",
                                                               input_limits=lim),
}
extremes = st.one_of(st.sampled_from([1e308, -1e308, 1.7976931348623157e308, 1e200, -1e39]),
                     st.floats(1e30, 1.7e308), st.floats(-1.7e308, -1e30))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(law=st.sampled_from(sorted(STABLE)), spikes=st.lists(extremes, min_size=1, max_size=3),
       at=st.integers(5, 150), limited=st.booleans())
def test_extreme_finite_samples_never_lock_a_live_controller(law, spikes, at, limited, tally):
    """A burst of 1 to 3 extreme finite samples: with input_limits every one is rejected
    (and the run is the run with NaNs there, bit for bit); without them a sample whose step
    overflows is rejected and no more than RESTART_AFTER samples in a row ever are (the
    law restarts): after the burst every normal sample is answered."""
    from mfcontrol.api.model.controllers import RESTART_AFTER

    def loop(ctrl, burst):
        y, out, taken = 0.0, [], []
        for k in range(300):
            sample = burst[k - at] if 0 <= k - at < len(burst) else y
            before = ctrl.nan_count
            u = ctrl(sample, setpoint=1.0)
            assert math.isfinite(u)
            taken.append(ctrl.nan_count == before)
            y += 0.01 * (-y + u)
            out.append(u)
        return np.array(out), taken

    lim = (-10.0, 10.0) if limited else (None, None)
    out, taken = loop(STABLE[law](lim), spikes)
    after = taken[at + len(spikes):]
    if limited:
        nans = [math.nan] * len(spikes)
        assert np.array_equal(out, loop(STABLE[law](lim), nans)[0])
        tally["extreme samples rejected by input_limits"] += len(spikes)
    # a sample of the burst the law took may make the next ones overflow (a second-order
    # gain one sample later): at most RESTART_AFTER are rejected, in a row (then the law
    # restarts from its last output), and every sample after them is taken. (1,500 random
    # bursts: never more than 2 rejected, the last at the third sample after the burst.)
    # The algebraic i-PI weighs a sample by its place in the window, which changes as it
    # slides: its overflow may come at any of the M + 1 samples it stays in the window,
    # and with startup "hold" the law computes nothing over its first M samples (a burst
    # then is taken, and overflows once the window is live)
    rejected = [i for i, ok in enumerate(after) if not ok]
    assert len(rejected) <= RESTART_AFTER, (law, spikes, rejected)
    if rejected:
        assert rejected == list(range(rejected[0], rejected[-1] + 1)), (law, spikes, rejected)
    in_window = ALGEBRAIC_WINDOW + 1 if law == "i-PI algebraic" else 0
    assert all(after[in_window + RESTART_AFTER + 1:]), (law, spikes, rejected)
    tally["extreme samples survived"] += len(spikes)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(digits=st.integers(4_301, 6_000), where=st.sampled_from(
    ["controller.kp", "plant.R", "sim.t_end", "controller.window"]), sign=st.sampled_from("-+"))
def test_integers_too_long_for_python_are_one_line(digits, where, sign, tally):
    """An integer of more than 4,300 digits (Python's int-to-str limit) in --set."""
    rc, _, err = _cli(["show", "voltage-stable-standard", f"--set={where}={sign}{'9' * digits}"])
    assert rc == 2
    _one_line_naming(err, where)
    assert len(err) < 400  # the number is shown shortened
    with pytest.raises(ValueError) as info:
        mfcontrol.IPI(alpha=1.0, kp=int(sign + "9" * 400), ki=1.0, sample_time=0.01)
    assert "\n" not in str(info.value) and str(info.value).startswith("kp = ")
    tally["huge integers refused"] += 1


def _raising_f(t, x, u, p, dxdt):
    if t > p[1]:
        raise ValueError("out of range")
    dxdt[0] = -p[0] * x[0] + u


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(when=st.floats(0.0, 0.3), k=st.floats(0.1, 5.0))
def test_a_user_function_that_raises_at_any_time_is_an_error_naming_it(when, k, tally):
    plant = mfcontrol.ODE(_raising_f, lambda x, p: x[0], x0=(0.0,),
                          params={"k": k, "t_raise": when})
    ctrl = mfcontrol.IPI(alpha=1.0, kp=5.0, ki=2.0, sample_time=0.01)
    with pytest.raises(mfcontrol.PlantFunctionError) as info:
        mfcontrol.simulate_loop(plant, ctrl, 1.0, t_end=0.5)
    msg = str(info.value)
    assert msg.startswith("f(t, x, u, p, dxdt) raised ValueError: out of range at t = ")
    assert "\n" not in msg
    tally["raising user functions named"] += 1


DAMAGES = ["cut", "empty", "garbage", "folder", "missing", "intact"]


@pytest.fixture(scope="module")
def finished_sweep(tmp_path_factory):
    """A finished 12-member sweep in 6 chunks, and its results."""
    import pandas as pd

    out = tmp_path_factory.mktemp("fuzz-sweep") / "whole"
    rc, _, err = _cli(["sweep", "voltage-stable-standard", "--grid",
                       "controller.alpha=logspace(-1,1,4)", "--grid", "plant.dR=0,2.5,5",
                       "--set", "sim.t_end=0.002", "--chunk", "2", "--out", str(out)])
    assert rc == 0, err
    return out, pd.read_parquet(out / "results.parquet")


@settings(max_examples=12, deadline=None, suppress_health_check=[
    HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(damage=st.lists(st.sampled_from(DAMAGES), min_size=6, max_size=6),
       cut=st.floats(0.0, 1.0))
def test_a_sweep_folder_damaged_anyhow_resumes_to_the_same_results(
        damage, cut, finished_sweep, tmp_path_factory, tally):
    import shutil

    import pandas as pd

    whole, results = finished_sweep
    folder = tmp_path_factory.mktemp("damaged") / "d"
    shutil.copytree(whole, folder)
    (folder / "results.parquet").unlink()
    for i, how in enumerate(damage):
        chunk = folder / "chunks" / f"chunk-{i:06d}.parquet"
        data = chunk.read_bytes()
        if how == "cut":
            chunk.write_bytes(data[:int(cut * (len(data) - 1))])
        elif how == "empty":
            chunk.write_bytes(b"")
        elif how == "garbage":
            chunk.write_bytes(bytes(range(256)) * 3)
        elif how == "missing":
            chunk.unlink()
        elif how == "folder":
            chunk.unlink()
            chunk.mkdir()
    (folder / "chunks" / ".chunk-000000.parquet.99999.tmp").write_bytes(b"left by kill -9")
    rc, _, err = _cli(["sweep", "voltage-stable-standard", "--grid",
                       "controller.alpha=logspace(-1,1,4)", "--grid", "plant.dR=0,2.5,5",
                       "--set", "sim.t_end=0.002", "--chunk", "2", "--out", str(folder)])
    if "folder" in damage:  # where a chunk belongs: refused in one line, nothing lost
        assert rc == 2 and "remove it to resume" in err and "Traceback" not in err
        tally["damaged sweep folders refused"] += 1
        return
    assert rc == 0, err
    pd.testing.assert_frame_equal(pd.read_parquet(folder / "results.parquet"), results)
    assert not list(folder.rglob("*.tmp"))
    tally["damaged sweep folders resumed"] += 1


def test_zz_report_the_counts(tally, record_property):
    """The tallies of this file's fuzzing, printed in the summary (runs last in the file)."""
    if not tally:  # run alone (-k, --lf): nothing to report
        pytest.skip("no fuzz test of this file ran in this process")
    record_property("counts", ", ".join(f"{k} {v:,}" for k, v in sorted(tally.items())))
