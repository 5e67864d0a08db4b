"""The live controllers: closed-form behaviour, invariants and the API contract."""

import json
import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mfcontrol
from mfcontrol import IP, IPD, IPI, IPID, RecursiveIP


def _integrator_loop(ctrl, n, h, alpha, w, r=1.0, y0=0.0):
    """Plant y' = w + alpha u (F = w constant), integrated exactly with u held."""
    y, ys, us = y0, [], []
    for _ in range(n):
        u = ctrl(y, setpoint=r)
        ys.append(y)
        us.append(u)
        y = y + h * (w + alpha * u)
    return np.array(ys), np.array(us)


def test_ip_error_decays_as_exp_minus_kp_t():
    # With F constant, the backward difference gives F exactly from the second sample on,
    # so the loop is e_{k+1} = (1 - kp h) e_k: the Euler image of e' = -kp e.
    h, kp, alpha, w = 1e-4, 5.0, 2.0, 3.0
    ctrl = IP(alpha=alpha, kp=kp, sample_time=h)
    y, _ = _integrator_loop(ctrl, 20_000, h, alpha, w)
    e = y - 1.0
    k0 = 3
    k = np.arange(k0, e.size)
    np.testing.assert_allclose(e[k], e[k0] * (1 - kp * h) ** (k - k0), rtol=1e-9)
    t = k * h
    continuous = e[k0] * np.exp(-kp * (t - t[0]))
    # (1 - kp h)^n vs exp(-kp n h): relative gap ~ kp^2 h t / 2
    assert np.max(np.abs(e[k] - continuous)) <= 2 * kp**2 * h * t[-1] * abs(e[k0])
    assert ctrl.components["F_hat"] == pytest.approx(w, rel=1e-9)


def test_ip_with_algebraic_estimator_tracks_a_first_order_plant():
    from mfcontrol.api.model.plants import FirstOrder

    ctrl = IP(alpha=1.0, kp=10.0, sample_time=1e-3, estimator="algebraic", window=20)
    res = mfcontrol.simulate_loop(FirstOrder(a=-2.0, b=1.0, w=0.5), ctrl, 1.0, t_end=2.0)
    assert res.metrics["settled"]
    assert abs(res.error[-1]) < 1e-3


@pytest.mark.parametrize("cls,args", [(IP, (1.0, 2.0)), (IPI, (1.0, 2.0, 0.5)),
                                      (IPD, (1.0, 2.0, 0.5)), (IPID, (1.0, 2.0, 0.5, 0.1))])
def test_unknown_keywords_raise_type_error(cls, args):
    with pytest.raises(TypeError):
        cls(*args, sample_time=0.01, sampletime=0.01)


@pytest.mark.parametrize("kwargs,needle", [
    ({"alpha": -1.0}, "alpha = -1.0"), ({"alpha": float("nan")}, "alpha = nan"),
    ({"sample_time": 0.0}, "sample_time = 0.0"), ({"output_limits": (2, 1)}, "output_limits"),
    ({"estimator": "magic"}, "estimator = 'magic'"), ({"order": 3}, "order = 3"),
    ({"estimator": "algebraic", "window": 1}, "window = 1"),
    ({"anti_windup": "sometimes"}, "anti_windup"), ({"kp": "fast"}, "kp = 'fast'"),
    ({"order": True}, "order = True")])
def test_invalid_values_raise_value_error_naming_them(kwargs, needle):
    args = {"alpha": 1.0, "kp": 1.0, "sample_time": 0.01, **kwargs}
    with pytest.raises(ValueError, match=needle.replace("(", r"\(").replace(")", r"\)")):
        IP(**args)


def test_nan_measurement_holds_the_output_and_is_counted():
    ctrl = IP(alpha=1.0, kp=2.0, sample_time=0.01)
    for y in (0.0, 0.1, 0.2):
        u = ctrl(y, setpoint=1.0)
    before = ctrl.snapshot()
    assert ctrl(float("nan")) == u and ctrl(float("inf")) == u
    assert ctrl.nan_count == 2
    after = ctrl.snapshot()
    assert after["state"] == before["state"]
    assert after["skipped"] == 0.02  # the next derivative spans the two periods


# --- issue 14: faults found by fuzzing, each with the test that failed before ---------------

def test_a_dropout_derivative_spans_the_time_since_the_last_sample_taken():
    # y = 0, .01, NaN, .03: the backward difference after the dropout is (.03 - .01) / 2h,
    # as a controller called with dt = 2h at that sample computes (it divided by h)
    a = IP(alpha=50.0, kp=10.0, sample_time=1e-3)
    b = IP(alpha=50.0, kp=10.0, sample_time=1e-3)
    for y in (0.0, 0.01):
        a(y, 0.0), b(y, 0.0)
    a(math.nan, 0.0)
    assert a(0.03, 0.0) == b(0.03, 0.0, dt=2e-3)
    assert a.components == b.components
    assert a(0.04, 0.0) == b(0.04, 0.0)  # and one period again after it


def test_the_pid_integral_spans_a_dropout_too():
    a = mfcontrol.PID(kp=2.0, ki=1.0, kd=0.1, sample_time=0.1)
    b = mfcontrol.PID(kp=2.0, ki=1.0, kd=0.1, sample_time=0.1)
    a(0.0, 1.0), b(0.0, 1.0)
    a(math.inf, 1.0)
    assert a(0.5, 1.0) == b(0.5, 1.0, dt=0.2)


@pytest.mark.parametrize("dt", [0.0, -0.01, math.nan, math.inf, "x"])
def test_a_bad_dt_is_refused_and_changes_nothing(dt):
    ctrl = IP(alpha=1.0, kp=1.0, sample_time=0.01, output_limits=(-1, 1))
    ctrl(0.0, 1.0)
    before = ctrl.snapshot()
    with pytest.raises(ValueError, match=r"dt = .*: must be a finite number > 0"):
        ctrl(0.1, 1.0, dt=dt)
    assert ctrl.snapshot() == before


@pytest.mark.parametrize("setpoint", ["abc", math.nan, math.inf, [1.0], True])
def test_a_bad_setpoint_is_refused_and_not_stored(setpoint):
    ctrl = IP(alpha=1.0, kp=1.0, sample_time=0.01)
    ctrl(0.0, 1.0)
    with pytest.raises(ValueError, match="setpoint = .*: must be a finite number"):
        ctrl(0.1, setpoint)
    assert ctrl.setpoint == 1.0
    assert math.isfinite(ctrl(0.1))  # later calls work


def test_a_measurement_that_is_not_a_number_is_refused():
    ctrl = mfcontrol.PID(kp=1.0, sample_time=0.01)
    with pytest.raises(ValueError, match="y = 'abc': the measurement must be a number"):
        ctrl("abc", 1.0)
    assert ctrl.setpoint == 0.0  # the refused call's setpoint was kept (found by the fuzzer)


def test_a_bumpless_start_that_overflows_is_refused_and_changes_nothing():
    """Found by the fuzzer: RecursiveIP's raw start last_output / output_gain overflowed to
    inf, which the law then used and the snapshot could not hold."""
    ctrl = RecursiveIP(alpha=10.0, kp=2.0, output_gain=5e-324)
    ctrl.set_auto_mode(False, last_output=1.0)  # clamped to the default duty limit 0.9
    before = ctrl.snapshot()
    with pytest.raises(ValueError, match="last_output = 0.9: the raw control"):
        ctrl.set_auto_mode(True)
    assert ctrl.snapshot() == before and not ctrl.auto_mode


def test_recursive_snapshot_after_a_bumpless_start_continues_from_it():
    a = RecursiveIP(alpha=10.0, kp=2.0)
    a(0.0, 0.0)
    a.set_auto_mode(False, last_output=0.3)
    a.set_auto_mode(True)
    b = RecursiveIP.from_snapshot(json.loads(json.dumps(a.snapshot())))
    assert a(0.01, 0.0) == b(0.01, 0.0) == 0.3  # was 0.001: the start was not in it
    a.reset()
    assert a(0.0, 0.0) == RecursiveIP(alpha=10.0, kp=2.0)(0.0, 0.0)  # built u0, not 0.3


def test_recursive_ip_refuses_a_positional_law():
    with pytest.raises(ValueError, match="law = 'i-P': RecursiveIP is the paper's law"):
        RecursiveIP(law="i-P")


@pytest.mark.parametrize("bad,needle", [
    (None, "snapshot = None: must be the dict"), ("x", "snapshot = 'x'"),
    ({"controller": "IP"}, "snapshot lacks params, state"),
    ({"state": "abc"}, "snapshot state = 'abc'"), ({"state": [1.0]}, "state has 1 values"),
    ({"nan_count": "z"}, "nan_count = 'z'"), ({"nan_count": -1}, "nan_count = -1"),
    ({"auto_mode": "yes"}, "auto_mode = 'yes'"), ({"last_output": None}, "last_output = None"),
    ({"setpoint": math.nan}, "setpoint = nan"), ({"params": 3}, "parameters differ"),
    ({"controller": "PID"}, "snapshot is of a 'PID' controller"),
])
def test_a_refused_restore_leaves_the_controller_as_it_was(bad, needle):
    ctrl = IP(alpha=1.0, kp=1.0, sample_time=0.01, estimator="algebraic", window=4)
    other = IP(alpha=1.0, kp=1.0, sample_time=0.01, estimator="algebraic", window=4)
    for y in (0.0, 0.3, 0.5, 0.2, 0.1, 0.4):
        ctrl(y, 1.0)
        other(y + 1.0, 2.0)
    before = ctrl.snapshot()
    snap = {**other.snapshot(), **bad} if isinstance(bad, dict) and "controller" not in bad \
        or bad == {"controller": "PID"} else bad
    if bad == {"controller": "IP"}:
        snap = bad
    with pytest.raises(ValueError, match=needle.replace("(", r"\(")):
        ctrl.restore(snap)
    assert ctrl.snapshot() == before


def test_components_add_up_to_the_output():
    ctrl = IPID(alpha=2.0, kp=3.0, ki=1.0, kd=0.5, sample_time=0.01)
    for y in (0.0, 0.1, 0.25, 0.3, 0.32):
        u = ctrl(y, setpoint=1.0)
    c = ctrl.components
    bracket = c["F_hat"] - c["feedforward"] + c["P"] + c["I"] + c["D"]
    assert u == pytest.approx(-bracket / 2.0, rel=1e-12)


def test_external_gain_uses_the_alpha_given_at_each_call():
    a = IP(alpha=1.0, kp=2.0, sample_time=0.01, gain="external")
    b = IP(alpha=4.0, kp=2.0, sample_time=0.01)
    for y in (0.0, 0.1, 0.3, 0.4):
        assert a(y, setpoint=1.0, alpha=4.0) == b(y, setpoint=1.0)
    with pytest.raises(ValueError, match="alpha"):
        a(0.5, setpoint=1.0)


def test_variational_gain_adapts():
    ctrl = IP(alpha=1.0, kp=2.0, sample_time=0.01, gain="variational", gamma0=1.0,
              Gamma=1e-3, eps_M=0.1)
    for y in np.linspace(0, 1, 20):
        ctrl(float(y), setpoint=1.0)
    assert ctrl.gamma != 1.0


def test_bumpless_transfer_from_manual():
    ctrl = IPI(alpha=1.0, kp=2.0, ki=1.0, sample_time=0.01, output_limits=(-10, 10))
    for y in (0.0, 0.1, 0.2):
        ctrl(y, setpoint=1.0)
    ctrl.set_auto_mode(False, last_output=3.5)
    assert ctrl(0.3) == 3.5  # manual: the output stays where the operator put it
    ctrl.set_auto_mode(True)
    outs = [ctrl(0.3 + 1e-4 * i, setpoint=0.3 + 1e-4 * i) for i in range(4)]
    assert outs[0] == 3.5 and abs(outs[-1] - 3.5) < 0.1  # continues from it, no jump


def test_recursive_ip_live_equals_the_simulator():
    r = mfcontrol.run_case("voltage-stable-variational", {"sim.t_end": 2e-3})
    ctrl = RecursiveIP(alpha=10.0, kp=2.0, law="variational", gamma0=1.0)
    out = [ctrl(y, setpoint=ref) for y, ref in zip(r.signals["y"], r.signals["y_ref"],
                                                  strict=True)]
    np.testing.assert_array_equal(out, r.signals["u"])
    assert ctrl.components["gamma"] == r.signals["gamma"][-1]


@pytest.mark.parametrize("overrides", [
    {}, {"controller.law": "variational"},
    {"controller.anti_windup": "back-calculation", "controller.k_aw": 2e4},
    {"controller.anti_windup": "back-calculation", "fidelity": "paper"},
    {"controller.law": "variational", "controller.rate_term": True,
     "controller.rate_sign": "minus", "sim.h": 2e-6},
    {"controller.p_error": "y-r", "controller.p_sample": "previous", "controller.u0": 0.2},
])
def test_the_controller_of_a_configuration_has_the_kernels_parameter_column(overrides):
    # the live controller of a case is built from the keys the column translator reads
    from mfcontrol.api import params
    from mfcontrol.api.run import from_config
    from mfcontrol.experiments.cases import resolve_case

    cfg = resolve_case("voltage-stable-standard")[1].with_overrides(overrides)
    ctrl = from_config.controller(cfg)
    np.testing.assert_array_equal(ctrl._CP[:, 0],
                                  params.recursive_law_column(cfg, cfg["sim.h"])[:, 0])


def test_recursive_ip_rejects_unknown_and_invalid_keys():
    with pytest.raises(TypeError, match="gamma_0"):
        RecursiveIP(alpha=10.0, kp=2.0, gamma_0=1.0)
    with pytest.raises(ValueError, match="alpha = -1"):
        RecursiveIP(alpha=-1.0, kp=2.0)


# ---- properties ----------------------------------------------------------------------

measurements = st.floats(allow_nan=True, allow_infinity=True, width=64)
finite_measurements = st.floats(-1e3, 1e3)


def _controller(kind, lo, width, aw, h):
    common = {"sample_time": h, "output_limits": (lo, lo + width), "anti_windup": aw}
    if kind.startswith("adrc"):  # its observer is its anti-windup: no option for it
        return mfcontrol.ADRC(order=1 if kind == "adrc" else 2, b0=1.5, wc=3.0, wo=15.0,
                              sample_time=h, output_limits=(lo, lo + width))
    return {"ip": lambda: IP(1.5, 3.0, **common),
            "ipi": lambda: IPI(1.5, 3.0, 2.0, **common),
            "ipd": lambda: IPD(1.5, 3.0, 0.2, **common),
            "ipid": lambda: IPID(1.5, 3.0, 2.0, 0.2, **common),
            "alg": lambda: IPI(1.5, 3.0, 2.0, estimator="algebraic", window=4, **common)}[kind]()


kinds = st.sampled_from(["ip", "ipi", "ipd", "ipid", "alg", "adrc", "adrc2"])
aws = st.sampled_from(["clamp", "back-calculation", "none"])


@settings(max_examples=60, deadline=None)
@given(kind=kinds, aw=aws, lo=st.floats(-100, 100), width=st.floats(0, 50),
       ys=st.lists(measurements, max_size=60), h=st.floats(1e-5, 1.0))
def test_output_within_limits_and_never_nan(kind, aw, lo, width, ys, h):
    ctrl = _controller(kind, lo, width, aw, h)
    for y in ys:
        u = ctrl(y, setpoint=1.0)
        assert math.isfinite(u)
        assert lo <= u <= lo + width


@settings(max_examples=40, deadline=None)
@given(kind=kinds, aw=aws, ys=st.lists(finite_measurements, min_size=2, max_size=40),
       cut=st.integers(0, 40))
def test_restore_then_continue_is_identical(kind, aw, ys, cut):
    cut = min(cut, len(ys))
    a = _controller(kind, -20.0, 40.0, aw, 0.01)
    for y in ys[:cut]:
        a(y, setpoint=0.5)
    snap = a.snapshot()
    b = type(a).from_snapshot(json.loads(json.dumps(snap)))
    c = pickle.loads(pickle.dumps(a))
    rest = [a(y, setpoint=0.5) for y in ys[cut:]]
    assert [b(y, setpoint=0.5) for y in ys[cut:]] == rest
    assert [c(y, setpoint=0.5) for y in ys[cut:]] == rest


@settings(max_examples=30, deadline=None)
@given(aw=st.sampled_from(["clamp", "back-calculation"]), sat=st.integers(20, 300),
       ki=st.floats(0.5, 20.0))
def test_anti_windup_recovers_within_a_bounded_number_of_samples(aw, sat, ki):
    # A load disturbance w = -3 on y' = -y + u + w pins the output at its upper limit for
    # `sat` samples (setpoint held). Once it is gone, the loop without integral action
    # leaves the limit after some samples; with anti-windup the i-PI must follow within a
    # few samples of it, however long the saturation lasted. Without, it lags far behind.
    h = 0.01

    def recovery(ki_, anti_windup):
        ctrl = IPI(1.0, 2.0, ki_, sample_time=h, output_limits=(-1.0, 1.0),
                   anti_windup=anti_windup)
        y = 0.0
        for k in range(sat + 2000):
            w = -3.0 if k < sat else 0.0
            u = ctrl(y, setpoint=0.5)
            y += h * (-y + u + w)
            if k >= sat and u < 1.0:
                return k - sat
        return 2000

    reference = recovery(0.0, aw)
    assert recovery(ki, aw) <= reference + 5
    if sat >= 100 and ki >= 2.0:
        assert recovery(ki, "none") > reference + 20


@settings(max_examples=40, deadline=None)
@given(kind=st.sampled_from(["ip", "ipid", "alg", "pid", "recursive", "variational",
                             "adrc2"]),
       ys=st.lists(measurements, max_size=40), switch=st.integers(0, 40))
def test_the_in_line_call_equals_the_general_one(kind, ys, switch):
    """Plain finite floats at the nominal period take a shorter path (issue 14 item 11);
    numpy scalars and an explicit dt take the general one: same outputs bit for bit,
    through NaNs, a setpoint change and a manual spell."""
    def build():
        if kind == "pid":
            return mfcontrol.PID(2.0, 1.0, 0.05, sample_time=0.01, output_limits=(-5, 5))
        if kind in ("recursive", "variational"):
            adapting = {"law": "variational", "gamma0": 0.1} if kind == "variational" else {}
            return RecursiveIP(alpha=10.0, kp=2.0, **adapting)
        return _controller(kind, -5.0, 10.0, "clamp", 0.01)

    fast, general = build(), build()
    general_kw = {} if kind in ("recursive", "variational") else {"dt": 0.01}
    out_fast, out_general = [], []
    for k, y in enumerate(ys):
        r = 0.5 if k < switch else -0.25
        if k == switch // 2:
            for c in (fast, general):
                c.set_auto_mode(False, last_output=0.3)
        if k == switch // 2 + 2:
            for c in (fast, general):
                c.set_auto_mode(True)
        out_fast.append(fast(y, setpoint=r))
        out_general.append(general(np.float64(y), setpoint=np.float64(r), **general_kw))
    assert np.array_equal(np.array(out_fast).view(np.int64), np.array(out_general).view(np.int64))
    assert fast.nan_count == general.nan_count
    assert fast.components.keys() == general.components.keys()
    assert np.array_equal(list(fast.components.values()), list(general.components.values()),
                          equal_nan=True)


def test_the_live_benchmark_feeds_plain_floats():
    """A sensor read gives Python floats; numpy scalars slowed simple-pid's arithmetic and
    flattered mfcontrol (issue 14 item 11: the README said 0.58x, it was 0.93x)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[3] / "benchmarks" / "bench_live.py"
    spec = importlib.util.spec_from_file_location("bench_live", path)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    assert {type(y) for y in bench.measurements(50)} == {float}


def test_alpha_and_the_setpoint_attribute_are_checked_on_every_path():
    """Found in review: the in-line call ignored alpha= on a controller without an external
    gain, and ``ctrl.setpoint = ...`` took anything (a numpy float made snapshots not JSON)."""
    ctrl = IP(alpha=1.0, kp=2.0, sample_time=0.01)
    for y in (0.5, np.float64(0.5)):  # the in-line and the general path
        with pytest.raises(ValueError, match="alpha = 2.0: only a controller built with "
                                             "gain='external'"):
            ctrl(y, setpoint=1.0, alpha=2.0)
    with pytest.raises(ValueError, match="setpoint = 'x': must be a finite number"):
        ctrl.setpoint = "x"
    ctrl.setpoint = np.float32(0.25)
    assert type(ctrl.setpoint) is float
    json.dumps(ctrl.snapshot())


def test_a_pickle_without_the_bound_step_loads():
    """The compiled step is bound on unpickling; a state from before it was (no _kernel,
    a public setpoint, RecursiveIP components as a dict) loads too."""
    for ctrl in (IP(alpha=1.0, kp=2.0, sample_time=0.01), RecursiveIP(alpha=10.0, kp=2.0)):
        ctrl(0.1, setpoint=1.0)
        state = pickle.loads(pickle.dumps(ctrl.__getstate__()))  # its own arrays
        state["setpoint"] = state.pop("_setpoint")
        if isinstance(ctrl, RecursiveIP):
            state["_components"] = dict(zip(("u_raw", "gain", "gamma"), state["_components"],
                                            strict=True))
        old = type(ctrl).__new__(type(ctrl))
        old.__setstate__(state)
        assert old(0.2, setpoint=1.0) == ctrl(0.2, setpoint=1.0)


@pytest.mark.parametrize("cls", [IP, IPI, IPD, IPID])
def test_help_shows_every_option(cls):
    """help(mfcontrol.IP) showed IP(alpha, kp, **options) and no option (issue 15)."""
    import inspect
    import pydoc

    sig = inspect.signature(cls)
    assert {"sample_time", "estimator", "window", "anti_windup", "gain", "output_limits"} \
        <= set(sig.parameters)
    assert sig.parameters["order"].default == (2 if cls in (IPD, IPID) else 1)
    text = pydoc.render_doc(cls, renderer=pydoc.plaintext)
    assert "anti_windup : {" in text and "Examples" in text
    assert text.index("Parameters") < text.index("Examples")
    cls(*[1.0] * (len([p for p in sig.parameters.values() if p.default is p.empty]) - 1),
        sample_time=0.01)  # the signature is the one the class takes


def test_recursive_ip_documents_the_keys_its_law_reads():
    """help(RecursiveIP) lists the case keys from config/options.py; the list is what the
    law's translator reads, under every variant (found by running it)."""
    from mfcontrol.api.model.controllers import RECURSIVE_KEYS
    from mfcontrol.api.params import recursive_law_column
    from mfcontrol.config.resolve import keys_read, resolve

    read = set()
    for over in ({}, {"controller.anti_windup": "back-calculation"},
                 {"controller.law": "variational", "controller.rate_term": True,
                  "controller.integrator": "second-order"}):
        cfg = resolve(over)
        read |= keys_read(recursive_law_column, cfg, cfg["sim.h"])
    assert set(RECURSIVE_KEYS) == read
    doc = mfcontrol.RecursiveIP.__doc__
    assert all(f"\n{key.split('.')[1]} : " in doc for key in RECURSIVE_KEYS)


# ---------------------------------------------------------------------------------------
# issue 28 item 1: an option the law would not read is refused, never dropped
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(("make", "error", "line"), [
    (lambda: IP(1.0, 2.0, ki=3.0, sample_time=1e-3), TypeError,
     "IP() got an unexpected keyword argument 'ki': an i-P has no integral term (IPI and "
     "IPID have one)"),
    (lambda: IPI(1.0, 2.0, 1.0, kd=3.0, sample_time=1e-3), TypeError,
     "IPI() got an unexpected keyword argument 'kd': an i-PI has no derivative term (IPD "
     "and IPID have one)"),
    (lambda: IPD(1.0, 2.0, 1.0, ki=3.0, sample_time=1e-3), TypeError,
     "IPD() got an unexpected keyword argument 'ki': an i-PD has no integral term (IPI and "
     "IPID have one)"),
    (lambda: IPI(1.0, 2.0, 1.0, k_aw=3.0, sample_time=1e-3), ValueError,
     "k_aw = 3.0: only back-calculation anti-windup reads it: set "
     "anti_windup='back-calculation', or remove it"),
    (lambda: IPI(1.0, 2.0, 1.0, Gamma=1e-6, sample_time=1e-3), ValueError,
     "Gamma = 1e-06: only the variational gain reads it: set gain='variational', or "
     "remove it"),
    (lambda: IP(1.0, 2.0, gamma0=0.5, sample_time=1e-3), ValueError,
     "gamma0 = 0.5: only the variational gain reads it: set gain='variational', or remove "
     "it"),
    (lambda: IPI(1.0, 2.0, 1.0, window=40, sample_time=1e-3), ValueError,
     "window = 40: only the algebraic estimator has one"),
    (lambda: RecursiveIP(gamma0=2.0), ValueError,
     'gamma0 = 2.0: not read with law = "ip": set law = "variational", or remove it'),
    (lambda: RecursiveIP(law="variational", k_gamma=2.0), ValueError,
     "k_gamma = 2.0: not read with rate_term = false: set rate_term = true, or remove it"),
    (lambda: RecursiveIP(k_aw=5.0), ValueError,
     'k_aw = 5.0: not read with anti_windup = "auto": set anti_windup = '
     '"back-calculation", or remove it'),
    (lambda: RecursiveIP(order=2), ValueError, "order = 2: not read by this law"),
])
def test_an_option_the_law_would_not_read_is_refused(make, error, line):
    with pytest.raises(error) as info:
        make()
    assert str(info.value).startswith(line), str(info.value)


def test_the_options_a_law_reads_are_taken():
    # the same options, under the choice that reads them
    IPI(1.0, 2.0, 1.0, k_aw=3.0, anti_windup="back-calculation", sample_time=1e-3)
    IPI(1.0, 2.0, 1.0, Gamma=1e-6, gamma0=0.5, gain="variational", sample_time=1e-3)
    RecursiveIP(law="variational", gamma0=2.0, rate_term=True, k_gamma=2.0)
    RecursiveIP(anti_windup="back-calculation", k_aw=5.0, sample_time=1e-6)
    # a snapshot's parameters build the controller again
    ctrl = IP(1.0, 2.0, sample_time=1e-3)
    assert IP.from_snapshot(ctrl.snapshot()).snapshot()["params"] == ctrl.snapshot()["params"]


def test_integers_beyond_the_float_range_are_refused_or_counted_never_an_overflow():
    huge, endless = 10**400, 10**5000  # the second past Python's int-to-str limit
    for value in (huge, endless):
        with pytest.raises(ValueError, match=r"^alpha = (an integer of \d+ bits \(beyond "
                           r"the float range\)|10{400}): must be "
                           r"a finite number > 0$"):
            mfcontrol.IP(alpha=value, kp=1.0, sample_time=0.01)
        with pytest.raises(ValueError, match=r"^output_limits\[0\] = (an integer|10)"):
            mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.01, output_limits=(value, 1.0))
    ctrl = mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.01)
    assert ctrl(huge, setpoint=1.0) == ctrl.last_output  # a measurement: counted, held
    assert ctrl.nan_count == 1
    snap = ctrl.snapshot()
    snap["last_output"] = huge
    with pytest.raises(ValueError, match=r"snapshot last_output = 10{400}: "):
        ctrl.restore(snap)
    with pytest.raises(mfcontrol.ConfigError, match=r"^t_end = 10{400}: "):
        mfcontrol.simulate_loop(mfcontrol.FirstOrder(-1.0, 1.0), ctrl, 1.0, t_end=huge)


# --- one extreme sample never locks a controller (issue 29, item 4) ---------------------

_OUTLIER_LAWS = {
    "PID": lambda **kw: mfcontrol.PID(kp=2.0, ki=1.0, kd=0.1, sample_time=0.01,
                                      output_limits=(-24, 24), **kw),
    "i-PI algebraic": lambda **kw: IPI(alpha=1.0, kp=4.0, ki=1.0, sample_time=0.01,
                                       estimator="algebraic", window=10,
                                       output_limits=(-24, 24), **kw),
    "i-PI variational": lambda **kw: IPI(alpha=1.0, kp=4.0, ki=1.0, sample_time=0.01,
                                         gain="variational", output_limits=(-24, 24), **kw),
    "i-PID": lambda **kw: IPID(alpha=1.0, kp=4.0, ki=1.0, kd=0.05, sample_time=0.01,
                               order=1, output_limits=(-24, 24), **kw),
    "recursive variational": lambda **kw: RecursiveIP(law="variational", **kw),
    "ADRC": lambda **kw: mfcontrol.ADRC(order=2, b0=1.0, wc=3.0, wo=15.0, sample_time=0.01,
                                        output_limits=(-24, 24), **kw),
}


def _with_outlier(ctrl, outlier, n=600, at=100):
    """Outputs of a loop on y' = -y + u (Euler, h = 0.01) whose sample ``at`` reads
    ``outlier`` instead of y."""
    y, out = 0.0, []
    for k in range(n):
        u = ctrl(outlier if k == at else y, setpoint=1.0)
        y += 0.01 * (-y + u)
        out.append(u)
    return np.array(out)


@pytest.mark.parametrize("law", list(_OUTLIER_LAWS))
def test_a_sample_whose_step_overflows_never_enters_the_memory(law):
    # y = 1e308 overflows every law's step: the sample is rejected as a NaN is, bit for
    # bit. Before, a limited output let the overflowed integral or derivative in, and
    # every later step overflowed: the PID held -24 for good.
    make = _OUTLIER_LAWS[law]
    ctrl = make()
    spiked = _with_outlier(ctrl, 1e308)
    assert np.array_equal(spiked, _with_outlier(make(), math.nan))
    assert ctrl.nan_count == 1 and ctrl.restarts == 0


@pytest.mark.parametrize("law", list(_OUTLIER_LAWS))
@pytest.mark.parametrize("outlier", [1e39, -1e200, 1e308, 11.0])
def test_a_measurement_outside_the_input_limits_is_rejected_as_a_nan(law, outlier):
    make = _OUTLIER_LAWS[law]
    ctrl = make(input_limits=(-10, 10))
    assert np.array_equal(_with_outlier(ctrl, outlier), _with_outlier(make(), math.nan))
    assert ctrl.nan_count == 1 and ctrl.input_limits == (-10, 10)


@pytest.mark.parametrize("law", list(_OUTLIER_LAWS))
def test_a_memory_that_overflows_restarts_the_law_from_its_last_output(law):
    # a memory every step overflows from (here restored from a snapshot: the same as a
    # finite outlier the law took and cannot digest): rejected once, then restarted
    # bumpless; before, every later sample was rejected
    make = _OUTLIER_LAWS[law]
    ctrl = make()
    for y in (0.0, 0.01, 0.02, 0.03):
        held = ctrl(y, setpoint=1.0)
    snap = ctrl.snapshot()
    snap["state"] = [1.7e308 if v == v else v for v in snap["state"]]
    ctrl.restore(snap)
    assert ctrl(0.04, setpoint=1.0) == held and ctrl.restarts == 0
    assert ctrl(0.05, setpoint=1.0) == held and ctrl.restarts == 1 and ctrl.nan_count == 2
    outputs = _with_outlier(ctrl, 0.0, n=50)
    assert np.all(np.isfinite(outputs)) and ctrl.nan_count == 2
    # the restart and the count of overflows in a row travel with a snapshot
    again = type(ctrl).from_snapshot(ctrl.snapshot())
    assert (again.restarts, again._overflows) == (1, 0)
    assert again(0.5, setpoint=1.0) == ctrl(0.5, setpoint=1.0)


def test_input_limits_are_checked_and_kept_out_of_snapshots_when_unset():
    with pytest.raises(ValueError, match=r"^input_limits = \(2, 1\): low must not exceed "
                                         r"high$"):
        IP(alpha=1.0, kp=1.0, sample_time=0.01, input_limits=(2, 1))
    with pytest.raises(ValueError, match=r"^input_limits\[0\] = nan: must be a finite"):
        mfcontrol.PID(kp=1.0, sample_time=0.01, input_limits=(math.nan, 1))
    plain = IP(alpha=1.0, kp=1.0, sample_time=0.01)
    assert "input_limits" not in plain.snapshot()["params"]
    assert plain.input_limits == (None, None)
    # a snapshot from before the restart rule (no overflows, no restarts) restores
    snap = plain.snapshot()
    del snap["overflows"], snap["restarts"]
    plain.restore(snap)
    bounded = IP(alpha=1.0, kp=1.0, sample_time=0.01, input_limits=(None, 5.0))
    assert IP.from_snapshot(bounded.snapshot()).input_limits == (None, 5.0)
    assert bounded(6.0) == 0.0 and bounded.nan_count == 1
    assert bounded(-1e300) == 0.0 and bounded.nan_count == 1  # no lower limit: taken


def test_a_controller_with_input_limits_simulates_in_python_and_is_refused_by_sweep():
    plant = mfcontrol.FirstOrder(a=-1.0, b=1.0)
    ctrl = IPI(alpha=1.0, kp=4.0, ki=1.0, sample_time=0.01, input_limits=(-10, 10))
    free = IPI(alpha=1.0, kp=4.0, ki=1.0, sample_time=0.01)
    # the Python driver (which honours the limits) and the compiled engine agree
    res = mfcontrol.simulate_loop(plant, ctrl, 1.0, t_end=3.0)
    ref = mfcontrol.simulate_loop(plant, free, 1.0, t_end=3.0)
    np.testing.assert_allclose(res.signals["y"], ref.signals["y"], rtol=1e-12, atol=1e-15)
    assert res.metrics["settled"]
    with pytest.raises(mfcontrol.ConfigError, match="without input_limits"):
        mfcontrol.sweep(plant, ctrl, 1.0, t_end=0.5, grid={"controller.kp": [1.0, 2.0]})


# --- ADRC --------------------------------------------------------------------------------

def test_adrc_bumpless_switch_starts_from_the_manual_output():
    """Back in automatic, the disturbance estimate is set so that the first output is the
    one held in manual (f = -b0 u holds a plant at rest), and the loop goes on from it."""
    ctrl = mfcontrol.ADRC(order=1, b0=2.0, wc=4.0, wo=20.0, sample_time=0.01,
                          output_limits=(-10, 10))
    for y in (0.0, 0.1, 0.2):
        ctrl(y, setpoint=1.0)
    ctrl.set_auto_mode(False, last_output=3.0)
    ctrl.set_auto_mode(True)
    assert ctrl(0.5, setpoint=1.0) == pytest.approx(3.0, abs=1e-12)
    assert ctrl.components["F_hat"] == pytest.approx(2.0 * (4.0 * (1.0 - 0.5) / 2.0 - 3.0))
    assert ctrl(0.5, setpoint=1.0) != 3.0  # and the law runs on


@pytest.mark.parametrize(("kwargs", "needle"), [
    ({"order": 3}, "order = 3: must be one of 1, 2"),
    ({"b0": 0.0}, "b0 = 0.0: must be a finite nonzero number"),
    ({"wc": -1.0}, "wc = -1.0"),
    ({"wo": 0.0}, "wo = 0.0"),
    ({"delay": -1}, "delay = -1: must be a whole number of samples from 0 to 100,000"),
    ({"delay": 1.5}, "delay = 1.5"),
])
def test_adrc_refuses_bad_parameters_naming_them(kwargs, needle):
    with pytest.raises(ValueError, match=needle):
        mfcontrol.ADRC(**{"sample_time": 0.01, **kwargs})


def test_adrc_estimate_and_components():
    ctrl = mfcontrol.ADRC(order=2, b0=1.0, wc=2.0, wo=10.0, sample_time=0.01)
    u = ctrl(0.3, setpoint=1.0)
    c = ctrl.components
    assert c["unlimited"] == u == pytest.approx(c["P"] + c["D"] - c["F_hat"])
    assert c["P"] == pytest.approx(4.0 * (1.0 - 0.3))  # at rest on y_0: y_hat = y_0
    assert ctrl.estimate.shape == (3,)
    assert "ADRC(order=2, b0=1.0" in repr(ctrl)


# retune: the controllers of every law family, run a while, then retuned
_RETUNED = [
    (lambda: mfcontrol.PID(kp=2.0, ki=1.0, kd=0.1, sample_time=0.01, output_limits=(-5, 5)),
     {"kp": 1.0, "ki": 3.0}),
    (lambda: mfcontrol.ADRC(order=1, b0=3.0, wc=5.0, wo=20.0, sample_time=0.01),
     {"wc": 8.0, "b0": 2.0}),
    (lambda: IPI(alpha=10.0, kp=2.0, ki=1.0, sample_time=0.01), {"kp": 3.0, "alpha": 8.0}),
    (lambda: IPID(alpha=10.0, kp=2.0, ki=1.0, kd=0.1, sample_time=0.01, estimator="algebraic",
                  window=10), {"kd": 0.2}),
    (lambda: RecursiveIP(alpha=10.0, kp=2.0, sample_time=0.01), {"kp": 3.0, "alpha": 5.0}),
]


def _run(ctrl, n=30, start=0):
    return [ctrl(0.5 + 0.01 * math.sin(k), setpoint=1.0) for k in range(start, start + n)]


@pytest.mark.parametrize("make,changes", _RETUNED)
def test_a_retune_is_bumpless_and_is_a_controller_built_with_the_new_parameters(make,
                                                                                changes):
    """retune(): the next output continues from the last one (the law restarts from it,
    as a manual-to-automatic switch does), and from there on the controller is one built
    with the new parameters and switched the same way, bit for bit."""
    ctrl = make()
    _run(ctrl)
    last = ctrl.last_output
    ctrl.retune(**changes)
    after = _run(ctrl, 40, 30)
    rebuilt = type(ctrl)(**{**make()._params, **changes})
    rebuilt.set_auto_mode(False, last_output=last)
    rebuilt.set_auto_mode(True)
    assert after == _run(rebuilt, 40, 30)
    assert after[0] == pytest.approx(last, abs=0.2 * (1 + abs(last)))
    plain = make()
    _run(plain)
    assert after != _run(plain, 40, 30)  # the new parameters act
    # a snapshot carries the new parameters
    clone = type(ctrl).from_snapshot(ctrl.snapshot())
    assert _run(clone, 5, 70) == _run(ctrl, 5, 70)


@pytest.mark.parametrize("make,changes", _RETUNED)
def test_a_retune_before_any_sample_is_a_controller_built_with_them(make, changes):
    """Review: a retune before the first sample (parameters loaded at start) restarted the
    law from the held 0, and the integral kept -P."""
    ctrl = make()
    ctrl.retune(**changes)
    assert _run(ctrl) == _run(type(ctrl)(**{**make()._params, **changes}))


@pytest.mark.parametrize("make,changes", _RETUNED)
def test_a_retune_that_changes_nothing_is_no_restart(make, changes):
    ctrl, plain = make(), make()
    _run(ctrl)
    _run(plain)
    ctrl.retune(**{k: ctrl._params[k] for k in changes})
    assert _run(ctrl, 20, 30) == _run(plain, 20, 30)


def test_a_refused_retune_changes_nothing():
    ctrl = mfcontrol.PID(kp=2.0, ki=1.0, kd=0.1, sample_time=0.01, output_limits=(-5, 5))
    _run(ctrl)
    before = json.dumps(ctrl.snapshot())
    for changes, needle in [({"kp": math.nan}, "kp = nan"), ({"kd": -1.0}, "sign of kp"),
                            ({"N": 0.0}, "N = 0.0"), ({"sample_time": 0.1}, "period"),
                            ({"setpoint": 2.0}, "setpoint"),
                            ({"output_limits": (3, 1)}, "output_limits")]:
        with pytest.raises(ValueError, match=needle):
            ctrl.retune(**changes)
        assert json.dumps(ctrl.snapshot()) == before
    with pytest.raises(TypeError, match="unexpected keyword"):
        ctrl.retune(gain=1.0)


@pytest.mark.parametrize("make,changes", [
    (lambda: IPI(alpha=10.0, kp=2.0, ki=1.0, sample_time=0.01, estimator="algebraic",
                 window=10), {"window": 20}),
    (lambda: IPI(alpha=10.0, kp=2.0, ki=1.0, sample_time=0.01), {"anti_windup": "none"}),
    (lambda: IPI(alpha=10.0, kp=2.0, ki=1.0, sample_time=0.01), {"order": 2, "kp": 3.0}),
    (lambda: mfcontrol.ADRC(order=1, b0=3.0, wc=5.0, wo=20.0, sample_time=0.01),
     {"delay": 2}),
])
def test_what_fixes_the_law_s_structure_is_not_retuned(make, changes):
    ctrl = make()
    _run(ctrl)
    before = json.dumps(ctrl.snapshot())
    key = next(iter(changes))
    with pytest.raises(ValueError, match=f"{key} = .*fixes the law's structure"):
        ctrl.retune(**changes)
    assert json.dumps(ctrl.snapshot()) == before


def test_a_retune_in_manual_clamps_the_held_output_and_auto_restarts_from_it():
    ctrl = mfcontrol.PID(kp=2.0, ki=1.0, sample_time=0.01, output_limits=(-5, 5))
    _run(ctrl)
    ctrl.set_auto_mode(False, last_output=4.0)
    ctrl.retune(output_limits=(-2, 2))
    assert ctrl.last_output == 2.0 and not ctrl.auto_mode
    assert ctrl(0.3, setpoint=1.0) == 2.0  # manual: held
    ctrl.set_auto_mode(True)
    assert ctrl(0.3, setpoint=1.0) == 2.0  # bumpless from the clamped output


@pytest.mark.parametrize("make", [
    lambda: mfcontrol.ADRC(order=2, b0=1.5, wc=3.0, wo=15.0, sample_time=1.0,
                           output_limits=(1.0, 1.0)),
    lambda: mfcontrol.PID(kp=2.0, ki=1.0, sample_time=0.1, output_limits=(1.0, 3.0)),
    lambda: RecursiveIP(alpha=10.0, kp=2.0, duty_min=0.2, duty_max=0.9),
])
def test_the_output_held_before_any_sample_is_within_the_output_limits(make):
    """Found by hypothesis (test_output_within_limits_and_never_nan): an order-2 ADRC with
    limits (1, 1) whose first sample, 2e307, overflows its step returned the output held
    before any sample, 0, outside its limits. That output is 0 clamped to the limits."""
    ctrl = make()
    lo, hi = (float(ctrl._CP[row, 0]) for row in ctrl._OUT_ROWS)
    assert lo <= ctrl.last_output <= hi
    assert lo <= ctrl(1.9974368165136842e+307, setpoint=1.0) <= hi
    assert lo <= ctrl(math.nan) <= hi


@pytest.mark.parametrize("make,limits", [
    (lambda: RecursiveIP(alpha=10.0, kp=2.0, duty_min=0.0, duty_max=0.9),
     {"duty_min": 0.5}),
    (lambda: mfcontrol.PID(kp=2.0, ki=1.0, sample_time=0.01, output_limits=(-5, 5)),
     {"output_limits": (2.0, 5.0)}),
])
def test_a_retune_in_automatic_clamps_the_held_output_to_the_new_limits(make, limits):
    """A rejected sample right after a retune whose limits leave the last output out
    returned that output: the recursive law's bumpless start kept it unclamped. The
    restart is from the last output clamped to the new limits, as in manual."""
    ctrl = make()
    for _ in range(5):
        ctrl(0.0, setpoint=0.1)
    lo = limits.get("duty_min", limits.get("output_limits", (None,))[0])
    assert ctrl.last_output < lo
    ctrl.retune(**limits)
    assert ctrl(math.nan, setpoint=0.1) == lo  # held, within the new limits
