"""The exported C is the Python controller: bit for bit in double, within a derived bound
in float, and the float build keeps the paper's voltage loop stable.

Every case below is compiled with the system C compiler under
``-std=c99 -O2 -Wall -Wextra -Werror -pedantic -ffp-contract=off`` and driven with the
measurements and references of a closed-loop run of its case, then noisy samples, NaN,
infinities, values that overflow the law, a manual period and the bumpless return to
automatic: the same operations as the live Python controller.
"""

from __future__ import annotations

import ctypes
import functools
import inspect
import math
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import mfcontrol
from mfcontrol.cexport import c_source
from mfcontrol.cexport.source import MAX_WINDOW, law_of
from mfcontrol.errors import ConfigError

from . import harness as H
from . import running_error as RE

N_RUN = 1500  # samples of the closed-loop run fed to both controllers


@functools.cache
def closed_loop(case: str) -> tuple[np.ndarray, np.ndarray]:
    """The measurements and references of the first N_RUN samples of the case's run."""
    _, cfg = mfcontrol.experiments.cases.resolve_case(case)
    res = mfcontrol.run_case(case, {"sim.t_end": N_RUN * cfg["sim.h"]})
    return res.signals["y_meas"][:N_RUN], res.signals["y_ref"][:N_RUN]


def operations(case: str) -> np.ndarray:
    y, r = closed_loop(case)
    rng = np.random.default_rng(7)
    scale = max(float(np.abs(y).max()), 1e-3)
    noisy = y[-1] + 0.05 * scale * rng.standard_normal(300)
    ref = np.full(300, r[-1])
    tail = y[-1] + 0.01 * scale * rng.standard_normal(50)
    special = [
        (H.STEP, np.nan, r[-1]), (H.STEP, np.inf, r[-1]), (H.STEP, -np.inf, r[-1]),
        (H.STEP, 1e300, r[-1]), (H.STEP, -1e300, 1e300),  # the law overflows: held,
        # and the second overflow in a row restarts the law from its last output
        (H.STEP, y[-1], r[-1]), (H.STEP, y[-1], r[-1]), (H.STEP, y[-1], r[-1]),
        # finite outliers: taken (1e39), or rejected where the step would overflow
        (H.STEP, 1e39, r[-1]), (H.STEP, y[-1], r[-1]), (H.STEP, y[-1], r[-1]),
        (H.STEP, -1e200, r[-1]), (H.STEP, y[-1], r[-1]), (H.STEP, y[-1], r[-1]),
        (H.STEP, 1e308, r[-1]), (H.STEP, y[-1], r[-1]), (H.STEP, y[-1], r[-1]),
        (H.STEP, y[-1], r[-1]),
        (H.STEP, y[-1], r[-1]), (H.STEP, np.nan, r[-1]), (H.STEP, np.nan, r[-1]),
        (H.STEP, y[-1], r[-1]),  # a dropout: the derivatives span three periods
        (H.MANUAL, 0.5 * r[-1] + 0.1, 0.0), (H.STEP, y[-1], r[-1]), (H.STEP, y[-2], r[-1]),
        (H.AUTO, 0.0, 0.0),
    ]
    return np.vstack([H.steps(y, r), H.steps(noisy, ref), np.array(special, float),
                      H.steps(tail, ref[:50]), [(H.MANUAL, -1e9, 0.0), (H.AUTO, 0.0, 0.0)],
                      H.steps(tail[::-1], ref[:50])])


RECURSIVE = "voltage-stable-standard"
INTELLIGENT = "motor-noise-ipi-algebraic"
# (case whose run drives the controller, overrides that build the controller): every law
# family and option the live controllers have
VARIANTS = [
    (RECURSIVE, {}),
    (RECURSIVE, {"controller.law": "variational"}),
    (RECURSIVE, {"controller.law": "variational", "controller.integrator": "second-order"}),
    (RECURSIVE, {"controller.law": "variational", "controller.rate_term": True,
                 "controller.rate_sign": "minus", "controller.k_gamma": 0.5}),
    (RECURSIVE, {"controller.law": "variational", "controller.gain": "alpha"}),
    (RECURSIVE, {"controller.p_error": "y-r", "controller.p_sample": "current"}),
    (RECURSIVE, {"controller.anti_windup": "clamp", "controller.duty_max": 0.3}),
    (RECURSIVE, {"controller.anti_windup": "back-calculation", "controller.k_aw": 2e5,
                 "controller.duty_max": 0.3}),
    (RECURSIVE, {"controller.output_gain": 0.5, "controller.u0": 0.2}),
    (INTELLIGENT, {}),
    (INTELLIGENT, {"controller.law": "i-P", "controller.estimator": "backward-difference"}),
    (INTELLIGENT, {"controller.law": "i-PD", "controller.order": 2, "controller.kd": 1.0}),
    (INTELLIGENT, {"controller.law": "i-PID", "controller.order": 2, "controller.kd": 0.5,
                   "controller.estimator": "backward-difference",
                   "controller.anti_windup": "back-calculation"}),
    (INTELLIGENT, {"controller.law": "i-PID", "controller.order": 2, "controller.kd": 0.5,
                   "controller.window": 20, "controller.adapt": "variational",
                   "controller.gamma0": 0.02, "controller.Gamma": 1e-9,
                   "controller.integrator": "second-order"}),
    (INTELLIGENT, {"controller.anti_windup": "none", "controller.duty_min": -2.0,
                   "controller.duty_max": 2.0}),
    (INTELLIGENT, {"controller.anti_windup": "back-calculation", "controller.k_aw": 5.0,
                   "controller.duty_min": -2.0, "controller.duty_max": 2.0}),
    (INTELLIGENT, {"controller.law": "i-P", "controller.window": 7}),
    ("motor-noise-pid", {}),
    ("motor-noise-pid", {"controller.kd": 0.05, "controller.N": 5.0, "controller.b": 0.5,
                         "controller.Tt": 0.2, "controller.duty_min": -2.0,
                         "controller.duty_max": 2.0}),
    ("motor-noise-adrc", {}),
    ("motor-noise-adrc", {"controller.order": 2, "controller.wc": 15.0,
                          "controller.wo": 60.0, "controller.delay": 3,
                          "controller.duty_min": -2.0, "controller.duty_max": 2.0}),
    ("buck-ipi", {}),
    ("boost-ipd", {}),
    ("first-order-ip-algebraic", {}),
    ("first-order-ip-algebraic", {"controller.kernel": "delay-reduced",
                                  "controller.lag": 3.0}),
    ("first-order-ip-algebraic", {"controller.kernel": "delay-reduced",
                                  "controller.lag": 13.0, "controller.kappa": 2,
                                  "controller.mu": 0}),
]


def _id(variant) -> str:
    case, over = variant
    return case + "".join(f"-{k.split('.')[-1]}={v}" for k, v in over.items())


@pytest.mark.parametrize("variant", VARIANTS, ids=[_id(v) for v in VARIANTS])
def test_double_export_is_bit_for_bit_the_python_controller(variant, tmp_path):
    case, overrides = variant
    ops = operations(case)
    exe = H.build(c_source(mfcontrol.make_controller(case, overrides)), tmp_path)
    u_c, nan_c = H.run_binary(exe, ops)
    u_py, nan_py = H.run_python(mfcontrol.make_controller(case, overrides), ops)
    assert u_c.shape == u_py.shape
    differ = np.flatnonzero(u_c.view(np.int64) != u_py.view(np.int64))
    assert differ.size == 0, f"first difference at step {differ[0]}: " \
                             f"C {u_c[differ[0]]!r}, Python {u_py[differ[0]]!r}"
    assert nan_c == nan_py >= 5  # three NaNs, two infinities (and overflows, by law)


def test_a_controller_built_in_python_exports_too(tmp_path):
    ctrl = mfcontrol.IPID(alpha=2.0, kp=4.0, ki=1.0, kd=2.0, sample_time=0.01,
                          estimator="algebraic", window=10, output_limits=(-5, 5))
    rng = np.random.default_rng(2)
    y = np.cumsum(0.01 * rng.standard_normal(400))
    ops = H.steps(y, np.where(np.arange(400) > 40, 1.0, 0.0))
    u_c, _ = H.run_binary(H.build(c_source(ctrl), tmp_path), ops)
    u_py, _ = H.run_python(ctrl, ops)
    assert np.array_equal(u_c, u_py)


@pytest.mark.parametrize("make", [
    lambda **kw: mfcontrol.IPI(alpha=1.0, kp=4.0, ki=1.0, sample_time=0.01,
                               gain="variational", output_limits=(-24, 24), **kw),
    lambda **kw: mfcontrol.PID(kp=2.0, ki=1.0, kd=0.1, sample_time=0.01, **kw),
    lambda **kw: mfcontrol.RecursiveIP(law="variational", **kw),
    lambda **kw: mfcontrol.ADRC(order=2, b0=3.0, wc=5.0, wo=30.0, sample_time=0.01,
                                output_limits=(-24, 24), **kw),
], ids=["i-PI", "PID", "recursive", "ADRC"])
def test_input_limits_and_outliers_export_bit_for_bit(make, tmp_path):
    # outliers inside and outside the limits, overflows and a memory restart
    rng = np.random.default_rng(3)
    y = list(np.cumsum(0.01 * rng.standard_normal(200)))
    y[50], y[80], y[81], y[120], y[160] = 11.0, 1e39, -1e300, -1e308, 1e308
    ops = H.steps(np.array(y), np.ones(200))
    for limits in [(None, None), (-10.0, 10.0), (None, 10.0), (-10.0, None)]:
        ctrl = make(input_limits=limits)
        src = c_source(ctrl)
        u_c, nan_c = H.run_binary(H.build(src, tmp_path / str(limits)), ops)
        u_py, nan_py = H.run_python(make(input_limits=limits), ops)
        assert np.array_equal(u_c, u_py) and nan_c == nan_py
        assert ("input limits [" in src.header) == (limits != (None, None))


@st.composite
def intelligent_controllers(draw):
    order = draw(st.sampled_from([1, 2]))
    estimator = draw(st.sampled_from(["backward-difference", "algebraic"]))
    window = None
    if estimator == "algebraic":
        window = draw(st.integers(1, 15)) * 2 if order == 2 else draw(st.integers(2, 30))
    gains = st.floats(-50.0, 50.0, allow_subnormal=False)
    lo = draw(st.none() | st.floats(-10.0, 0.0))
    hi = draw(st.none() | st.floats(0.0, 10.0))
    gain = draw(st.sampled_from(["constant", "variational", "rls"]))
    anti_windup = draw(st.sampled_from(["clamp", "back-calculation", "none"]))
    # the options of a choice, drawn under it (the controller refuses them elsewhere)
    options = {"k_aw": draw(st.none() | st.floats(0.0, 1e3))} \
        if anti_windup == "back-calculation" else {}
    if gain == "variational":
        options.update(
            gamma0=draw(st.none() | st.floats(0.01, 10.0)), Gamma=draw(st.floats(-1e-3, 1e-3)),
            eps_M=draw(st.floats(-1.0, 1.0)),
            integrator=draw(st.sampled_from(["first-order", "second-order"])),
            adapt_every=draw(st.integers(1, 4)))
    if gain == "rls":
        options.update(forgetting=draw(st.floats(0.9, 1.0)),
                       alpha_limits=(draw(st.none() | st.floats(0.01, 0.1)),
                                     draw(st.none() | st.floats(100.0, 1e3))))
    if estimator == "algebraic":
        kernels = ["held", "trapezoid"] + (["delay-reduced"] if order == 1 else [])
        options["kernel"] = draw(st.sampled_from(kernels))
        if options["kernel"] == "trapezoid" and order == 2:
            window += window % 2  # Simpson's rule
        if options["kernel"] == "delay-reduced":
            options["lag"] = draw(st.floats(0.0, float(window)))
            options["kappa"] = draw(st.integers(0, 2))
            options["mu"] = draw(st.integers(0, 2 - options["kappa"]))
    make = functools.partial(
        mfcontrol.IPID,
        alpha=draw(st.floats(0.1, 100.0)), kp=draw(gains), ki=draw(gains), kd=draw(gains),
        sample_time=draw(st.sampled_from([1e-6, 1e-3, 0.01, 0.1])), order=order,
        estimator=estimator, window=window, output_limits=(lo, hi),
        anti_windup=anti_windup, gain=gain, starting_output=draw(st.floats(-5.0, 5.0)),
        **options)
    try:
        return make()
    except ValueError:  # an rls gain whose exact estimate the loop could not hold
        assume(False)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(ctrl=intelligent_controllers(), seed=st.integers(0, 2**32 - 1))
def test_any_intelligent_controller_is_bit_for_bit(tmp_path_factory, ctrl, seed):
    rng = np.random.default_rng(seed)
    n = 200
    y = np.cumsum(rng.normal(0.0, 0.05, n))
    y[rng.random(n) < 0.03] = np.nan  # dropouts
    r = np.repeat(rng.normal(0.0, 1.0, 4), n // 4)
    ops = np.vstack([H.steps(y, r), [(H.MANUAL, 0.7, 0.0), (H.AUTO, 0.0, 0.0)],
                     H.steps(y[::-1], r)])
    exe = H.build(c_source(ctrl), tmp_path_factory.mktemp("c"))
    u_c, nan_c = H.run_binary(exe, ops)
    u_py, nan_py = H.run_python(type(ctrl).from_snapshot(ctrl.snapshot()), ops)
    assert np.array_equal(u_c.view(np.int64), u_py.view(np.int64)) and nan_c == nan_py


# --- float ------------------------------------------------------------------------------

FLOAT_VARIANTS = [
    (RECURSIVE, {}),
    (RECURSIVE, {"controller.law": "variational"}),
    (INTELLIGENT, {}),
    ("boost-ipd", {}),
    (INTELLIGENT, {"controller.law": "i-P", "controller.estimator": "backward-difference",
                   "controller.adapt": "variational", "controller.gamma0": 0.02,
                   "controller.Gamma": 1e-9}),
    ("motor-noise-pid", {"controller.kd": 0.05}),
    ("motor-noise-adrc", {}),
    ("motor-noise-adrc", {"controller.order": 2, "controller.wc": 15.0,
                          "controller.wo": 60.0, "controller.delay": 2}),
]
N_FLOAT = 600  # samples; the bound is checked at every CHECK-th
CHECK = 25


@pytest.mark.parametrize("variant", FLOAT_VARIANTS, ids=[_id(v) for v in FLOAT_VARIANTS])
def test_float_export_stays_within_the_first_order_rounding_bound(variant, tmp_path):
    """|u_float - u_double| <= 2^-24 sum |d u / d z| |z| over every rounded value z
    (:mod:`running_error`), evaluated along the run."""
    case, overrides = variant
    y, r = (a[:N_FLOAT] for a in closed_loop(case))
    ops = H.steps(y, r)
    src = c_source(mfcontrol.make_controller(case, overrides), real="float")
    u_f, nan_count = H.run_binary(H.build(src, tmp_path), ops)
    u_d, _ = H.run_python(mfcontrol.make_controller(case, overrides), ops)
    ctrl = mfcontrol.make_controller(case, overrides)
    values, bound = RE.carried_outputs(ctrl, law_of(ctrl), y, r, every=CHECK)
    assert np.array_equal(values, u_d)  # the tape ran the law itself
    assert nan_count == 0
    checked = ~np.isnan(bound)
    err, limit = np.abs(u_f - u_d)[checked], RE.U_FLOAT * bound[checked]
    ratio = err / np.maximum(limit, 1e-300)
    print(f"{_id(variant)}: max |u_float - u_double| {err.max():.3g}, "
          f"largest share of the bound {ratio.max():.3f}")
    assert (err <= limit).all()
    # not vacuous: float really differs, and the bound is not loose by orders of magnitude
    # (0.1% to 13% of it used on these variants)
    assert err.max() > 0 and ratio.max() > 1e-4


class _CController:
    """A compiled controller called through ctypes, shaped like a live controller."""

    def __init__(self, path, src):
        self.lib = ctypes.CDLL(str(path))
        real = ctypes.c_float if src.real == "float" else ctypes.c_double
        self.step = self.lib[f"{src.prefix}_step"]
        self.step.restype = real
        self.step.argtypes = [ctypes.c_void_p, real, real]
        # the struct: the state, its backup, three scalars; generously sized
        self.state = ctypes.create_string_buffer(8 * (2 * src.n_state + 8))
        self.lib[f"{src.prefix}_init"](self.state)

    def __call__(self, y, setpoint=0.0):
        return float(self.step(self.state, y, setpoint))


def test_float_build_keeps_the_paper_voltage_loop_stable(tmp_path):
    case = "voltage-stable-standard"
    _, cfg = mfcontrol.experiments.cases.resolve_case(case)
    exact = mfcontrol.run_case(case)
    src = c_source(mfcontrol.make_controller(case), real="float")
    ctrl = _CController(H.build(src, tmp_path, shared=True), src)
    plant, changes = mfcontrol.api.run.from_config.plant_and_changes(cfg)
    res = mfcontrol.simulate_loop(plant, ctrl, exact.signals["y_ref"], t_end=cfg["sim.t_end"],
                                  h=cfg["sim.h"], changes=changes)
    assert res.engine == "python"
    assert res.metrics["settled"] and not res.metrics["diverged"]
    assert exact.metrics["settled"]
    gap = np.abs(res.signals["y"] - exact.signals["y"]).max()
    print(f"float C in the loop: IAE {res.metrics['iae']:.6g} (double {exact.metrics['iae']:.6g}),"
          f" max |y_float - y_double| {gap:.3g} V")
    assert res.metrics["iae"] == pytest.approx(exact.metrics["iae"], rel=1e-3)


# --- refusals -----------------------------------------------------------------------------

def test_refusals_name_the_key_and_what_is_allowed():
    ip = mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.01)
    with pytest.raises(ConfigError, match="prefix = '9lives': must be a C identifier"):
        c_source(ip, prefix="9lives")
    with pytest.raises(ConfigError, match="real = 'half': must be one of double, float"):
        c_source(ip, real="half")
    with pytest.raises(ConfigError, match="gain = 'external'"):
        c_source(mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.01, gain="external"))
    for kp in (1e300, 1e-40):
        odd = mfcontrol.IP(alpha=1.0, kp=kp, sample_time=0.01)
        with pytest.raises(ConfigError, match=re.escape(f"kp = {kp!r}: it is outside the "
                                                        "range of a normal float")):
            c_source(odd, real="float")
        c_source(odd)  # fine in double
    with pytest.raises(ConfigError, match=re.escape("controller.alpha = 1e+39: 1/alpha = "
                                                    "1e-39 is outside the range")):
        mfcontrol.cexport.export.source_of("motor-noise-ipi", {"controller.alpha": 1e39},
                                           real="float")
    for real, M in MAX_WINDOW.items():
        ok = mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.01, estimator="algebraic", window=M)
        c_source(ok, real=real)
        over = mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.01, estimator="algebraic",
                            window=M + 1)
        with pytest.raises(ConfigError, match=f"window = {M + 1}: at most {M:,} samples in "
                                              f"a {real} export"):
            c_source(over, real=real)
    with pytest.raises(TypeError, match="cannot export a str"):
        c_source("IP")


def test_the_files_say_what_they_hold():
    src = c_source(mfcontrol.make_controller("motor-noise-ipi-algebraic"), prefix="motor",
                   real="float", description="case motor-noise-ipi-algebraic")
    for text in (src.header, src.source):
        assert f"mfcontrol {mfcontrol.__version__}" in text
        assert "case motor-noise-ipi-algebraic" in text and "window = 40" in text
    assert "typedef float motor_real;" in src.header
    assert "#define MOTOR_SAMPLE_TIME 0.001" in src.header
    assert "motor_real motor_step(motor_state *s, motor_real y, motor_real setpoint);" \
        in src.header
    # the law comes from its Python source: each translated function names it
    assert "/* mfcontrol.laws.estimators.push_spread */" in src.source
    assert "#include <math.h>" in src.source
    assert "malloc" not in src.source and "static mfc" not in src.source
    # no file-scope state: the only data are the const parameter table and defaults
    for line in src.source.splitlines():
        if line.startswith(("static", "const")) and "(" not in line:
            assert line.startswith(("static const motor_real motor_fixed[",
                                    "const motor_params motor_default_params = {"))


def test_a_non_finite_manual_output_is_not_taken(tmp_path):
    """The live controller refuses set_auto_mode(False, last_output=nan); the C cannot
    raise: it keeps the last output and counts the rejected value."""
    case = INTELLIGENT
    y, r = closed_loop(case)
    ops = np.vstack([H.steps(y[:300], r[:300]), [(H.MANUAL, np.nan, 0.0), (H.AUTO, 0.0, 0.0)],
                     H.steps(y[300:600], r[300:600])])
    u_c, nan_c = H.run_binary(H.build(c_source(mfcontrol.make_controller(case)), tmp_path),
                              ops)
    ctrl = mfcontrol.make_controller(case)
    with pytest.raises(ValueError, match="last_output = nan"):
        ctrl.set_auto_mode(False, last_output=math.nan)
    # what the C did: manual holding the last output, then the bumpless return
    ctrl = mfcontrol.make_controller(case)
    first, _ = H.run_python(ctrl, ops[:300])
    ctrl.set_auto_mode(False)
    ctrl.set_auto_mode(True)
    rest, nan_py = H.run_python(ctrl, ops[302:])
    u_py = np.concatenate([first, rest])
    assert np.isfinite(u_c).all()
    assert np.array_equal(u_c, u_py) and nan_c == nan_py + 1


def test_a_used_recursive_controller_exports_as_built(tmp_path):
    """The live RecursiveIP restarts from a manual output by rewriting its u0 in place;
    the export starts from the u0 it was built with."""
    ops = operations(RECURSIVE)[:500]
    used = mfcontrol.make_controller(RECURSIVE)
    used.set_auto_mode(False, last_output=0.3)
    used.set_auto_mode(True)
    src = c_source(used)
    assert src.source == c_source(mfcontrol.make_controller(RECURSIVE)).source
    u_c, _ = H.run_binary(H.build(src, tmp_path), ops)
    u_py, _ = H.run_python(mfcontrol.make_controller(RECURSIVE), ops)
    assert np.array_equal(u_c, u_py)
    assert "#define MFC_SAMPLE_TIME 1e-06" in src.header


def test_the_float_estimator_keeps_counting_past_float_precision_limits(tmp_path):
    """A float count would stop at 2^24 samples; the wrapped one keeps the window sliding:
    after 40 wraps of a window of 6 samples the float C still follows the double."""
    ctrl = mfcontrol.IPI(alpha=2.0, kp=4.0, ki=1.0, sample_time=0.01, estimator="algebraic",
                         window=6, output_limits=(-50, 50))
    n = 40 * 6 * 7 + 11
    t = 0.01 * np.arange(n)
    ops = H.steps(np.sin(t) + 0.1 * np.sin(7 * t), np.sin(t + 0.05))
    u_f, _ = H.run_binary(H.build(c_source(ctrl, real="float"), tmp_path), ops)
    u_d, _ = H.run_python(type(ctrl).from_snapshot(ctrl.snapshot()), ops)
    np.testing.assert_allclose(u_f, u_d, rtol=1e-3, atol=1e-3)


def test_comments_cannot_be_closed_by_a_description():
    src = c_source(mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.01),
                   description="case evil*/name.toml /* x")
    assert "evil* /name.toml / * x" in src.header and "evil*/" not in src.source


def test_two_exports_compile_in_one_translation_unit_with_gcc_and_clang(tmp_path):
    """Unity builds: every name is prefixed. clang too (its -Wparentheses-equality once
    failed every export under -Werror, its -Wenum-float-conversion every intelligent and
    recursive one); CI installs it and sets MFCONTROL_REQUIRE_CLANG=1."""
    import os
    import shutil
    import subprocess

    cases = (("a", INTELLIGENT, False), ("b", RECURSIVE, False), ("c", "motor-noise-pid", False),
             ("d", "voltage-stable-variational", True), ("e", "motor-noise-adrc", True))
    for prefix, case, frozen in cases:
        for real in ("double", "float"):
            src = c_source(mfcontrol.make_controller(case), prefix=prefix + real[0], real=real,
                           frozen=frozen)
            (tmp_path / f"{src.prefix}.h").write_text(src.header)
            (tmp_path / f"{src.prefix}.c").write_text(src.source)
    (tmp_path / "unity.c").write_text("".join(f'#include "{p}{r}.c"\n' for p, _, _ in cases
                                              for r in "df") + "int main(void) { return 0; }\n")
    clang = shutil.which("clang")
    if clang is None and os.environ.get("MFCONTROL_REQUIRE_CLANG"):
        pytest.fail("no clang on this machine (Debian: clang)")
    for cc in [H.compiler(), clang]:
        if cc:
            subprocess.run([cc, *H.CFLAGS, str(tmp_path / "unity.c"), "-o",
                            str(tmp_path / "unity"), "-lm"], check=True)


def test_bit_for_bit_without_the_contraction_flag(tmp_path):
    """The file turns contraction off itself: compiled for this CPU (with FMA where it has
    one) in GNU C without -ffp-contract=off, where gcc contracts by default."""
    import subprocess

    case = INTELLIGENT
    src = c_source(mfcontrol.make_controller(case, {"controller.law": "i-PID",
                                                    "controller.order": 2,
                                                    "controller.kd": 0.5}))
    exe = H.build(src, tmp_path)
    flags = ["-std=gnu99", "-O2", "-march=native", "-Wall", "-Werror"]
    subprocess.run([H.compiler(), *flags, "-I", str(tmp_path), str(tmp_path / "mfc.c"),
                    str(tmp_path / "main.c"), "-o", str(exe), "-lm"], check=True)
    ops = operations(case)
    u_c, _ = H.run_binary(exe, ops)
    u_py, _ = H.run_python(mfcontrol.make_controller(case, {
        "controller.law": "i-PID", "controller.order": 2, "controller.kd": 0.5}), ops)
    assert np.array_equal(u_c.view(np.int64), u_py.view(np.int64))


def test_a_subclass_of_a_live_controller_exports():
    class Motor(mfcontrol.IPI):
        def __init__(self):
            super().__init__(alpha=50.0, kp=20.0, ki=50.0, sample_time=1e-3)

    assert "alpha = 50.0" in c_source(Motor()).header


def test_float_range_errors_name_what_the_user_set():
    with pytest.raises(ConfigError, match=re.escape("sample_time = 1e-50: it is outside")):
        c_source(mfcontrol.PID(kp=2.0, ki=1.0, sample_time=1e-50), real="float")
    with pytest.raises(ConfigError, match=re.escape("controller.duty_max = 1e+39: it is")):
        mfcontrol.cexport.export.source_of("motor-noise-pid", {"controller.duty_max": 1e39},
                                           real="float")


def test_a_nan_setpoint_is_held_and_counted_in_c_and_refused_in_python(tmp_path):
    ctrl = mfcontrol.make_controller(INTELLIGENT)
    ops = np.vstack([H.steps(*closed_loop(INTELLIGENT))[:100], [(H.STEP, 1.0, np.nan)]])
    u_c, nan_c = H.run_binary(H.build(c_source(ctrl), tmp_path), ops)
    assert u_c[-1] == u_c[-2] and nan_c == 1
    with pytest.raises(ValueError, match="setpoint = nan: must be a finite number"):
        ctrl(1.0, setpoint=math.nan)


def test_the_banner_names_the_law_as_the_command_line_does(tmp_path):
    # issue 28: the header called an IPI an "intelligent law"; a user who ran
    # controller.law = "i-PI" finds that name in it
    import mfcontrol
    from mfcontrol.cexport.source import _law_label

    assert _law_label(mfcontrol.IPI(alpha=10, kp=2, ki=1, sample_time=1e-3)) == "i-PI"
    assert _law_label(mfcontrol.PID(kp=1, ki=1, sample_time=1e-3)) == "pid"
    assert _law_label(mfcontrol.ADRC(sample_time=1e-3)) == "adrc"
    assert _law_label(mfcontrol.RecursiveIP(alpha=10, kp=2)) == "ip"
    h, _ = mfcontrol.export_c(mfcontrol.IPD(alpha=10, kp=2, kd=0.1, sample_time=1e-3),
                              out=tmp_path)
    assert h.read_text().startswith("/* mfc: i-PD controller (mfcontrol.IPD)")


# -- hostile input (issue 33) ------------------------------------------------------------
_HOSTILE = [math.nan, math.inf, -math.inf, 1e308, -1e308, 1.7976931348623157e308, 5e-324,
            -5e-324, 2.2e-310, 1e39, -1e39]


def hostile_operations(case: str) -> np.ndarray:
    """A closed-loop run, then every hostile value as the measurement, the setpoint, both,
    and the manual output, each followed by ordinary samples and a return to automatic."""
    y, r = closed_loop(case)
    y0, r0 = y[199], r[199]
    rows = []
    for v in _HOSTILE:
        rows += [(H.STEP, v, r0), (H.STEP, y0, r0), (H.STEP, y0, v), (H.STEP, y0, r0),
                 (H.STEP, v, v), (H.STEP, y0, r0), (H.STEP, y0, v), (H.STEP, y0, v),
                 (H.STEP, y0, r0), (H.MANUAL, v, 0.0), (H.STEP, y0, r0), (H.AUTO, 0.0, 0.0),
                 (H.STEP, y0, r0), (H.STEP, y0, r0)]
    return np.vstack([H.steps(y[:200], r[:200]), np.array(rows, float),
                      H.steps(y[200:260], r[200:260])])


@functools.cache
def sanitizer_flags() -> tuple[str, ...]:
    """AddressSanitizer and UBSan flags where this compiler has them, else ()."""
    import subprocess
    import tempfile
    from pathlib import Path

    flags = ("-fsanitize=address,undefined", "-fno-sanitize-recover=all",
             "-fno-omit-frame-pointer")
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "t.c").write_text("int main(void) { return 0; }\n")
        done = subprocess.run([H.compiler(), *flags, f"{d}/t.c", "-o", f"{d}/t"],
                              capture_output=True, timeout=600)
        if done.returncode:
            return ()
        return flags if subprocess.run([f"{d}/t"], timeout=600).returncode == 0 else ()


def _limits_of(ctrl) -> tuple[float, float]:
    lo, hi = ctrl._OUT_ROWS
    return float(ctrl._CP[lo, 0]), float(ctrl._CP[hi, 0])


@pytest.mark.parametrize("variant", VARIANTS, ids=[_id(v) for v in VARIANTS])
def test_hostile_inputs_leave_every_export_sound(variant, tmp_path):
    """NaN, +-inf, the largest doubles, denormals and values past the float range as the
    measurement, the setpoint and the manual output: the double export stays the Python
    controller bit for bit (outputs, nan_count and the final memory), every output is
    finite and within the output limits, in double and in float, and neither build trips
    AddressSanitizer or UBSan. Before issue 33 a +-inf setpoint that the output clamp
    turned into a rail was taken into the state (the PID then held +24 V for good)."""
    case, overrides = variant
    ops = hostile_operations(case)
    ctrl = mfcontrol.make_controller(case, overrides)
    lo, hi = _limits_of(ctrl)
    flags = sanitizer_flags()
    exe = H.build(c_source(ctrl), tmp_path / "d", flags=flags)
    u_c, nan_c = H.run_binary(exe, ops, state=tmp_path / "state")
    py = mfcontrol.make_controller(case, overrides)
    u_py, nan_py = H.run_python(py, ops)
    differ = np.flatnonzero(u_c.view(np.int64) != u_py.view(np.int64))
    assert differ.size == 0, f"first difference at step {differ[0]}: " \
                             f"C {u_c[differ[0]]!r}, Python {u_py[differ[0]]!r}"
    assert nan_c == nan_py
    memory = np.fromfile(tmp_path / "state", dtype=float)[:py._CS.shape[0]]
    assert np.array_equal(memory.view(np.int64), py._CS[:, 0].view(np.int64))
    assert np.isfinite(u_c).all() and (lo <= u_c).all() and (u_c <= hi).all()
    exe = H.build(c_source(ctrl, real="float", prefix="f"), tmp_path / "f", flags=flags)
    u_f, _ = H.run_binary(exe, ops, state=tmp_path / "fstate")
    lo_f, hi_f = np.float32(lo), np.float32(hi)  # the limits as the float build holds them
    assert np.isfinite(u_f).all() and (lo_f <= u_f).all() and (u_f <= hi_f).all()


def test_an_infinite_setpoint_is_refused_and_counted_not_taken(tmp_path):
    """Issue 33's finding: the exported PID took an infinite setpoint when the output clamp
    made the output finite, then sat at its rail with a NaN integrator. Now the sample is
    rejected as a NaN measurement is, and the next ordinary sample gives what it would
    have given had the rejected sample been a NaN measurement."""
    case = "motor-noise-pid"
    y, r = closed_loop(case)
    ops = np.vstack([H.steps(y[:300], r[:300]), [(H.STEP, y[300], np.inf)],
                     H.steps(y[301:400], r[301:400])])
    u_c, nan_c = H.run_binary(H.build(c_source(mfcontrol.make_controller(case)), tmp_path),
                              ops)
    nan_ops = ops.copy()
    nan_ops[300] = (H.STEP, np.nan, r[300])
    u_nan, _ = H.run_python(mfcontrol.make_controller(case), nan_ops)
    assert nan_c == 1 and u_c[300] == u_c[299]
    assert np.array_equal(u_c, u_nan)


def test_a_manual_output_is_clamped_to_the_output_limits(tmp_path):
    """Issue 33: after set_manual(1e308) and set_auto the exported recursive law returned
    1e308 at every later step, outside its limits. A manual output is clamped, in the live
    controller and in the C, and the law restarts from the clamped value."""
    ctrl = mfcontrol.make_controller(RECURSIVE, {"controller.duty_max": 0.6})
    ctrl.set_auto_mode(False, last_output=1e308)
    assert ctrl(0.0) == 0.6 == ctrl.last_output
    y, r = closed_loop(RECURSIVE)
    ops = np.vstack([H.steps(y[:100], r[:100]), [(H.MANUAL, 1e308, 0.0)],
                     H.steps(y[100:102], r[100:102]), [(H.AUTO, 0.0, 0.0)],
                     H.steps(y[102:300], r[102:300])])
    src = c_source(mfcontrol.make_controller(RECURSIVE, {"controller.duty_max": 0.6}))
    u_c, _ = H.run_binary(H.build(src, tmp_path), ops)
    u_py, _ = H.run_python(mfcontrol.make_controller(RECURSIVE, {"controller.duty_max": 0.6}),
                           ops)
    assert np.array_equal(u_c, u_py)
    assert u_c[100] == u_c[101] == 0.6 and u_c.max() <= 0.6


def test_a_state_never_initialised_is_refused(tmp_path):
    """A zeroed static state never passed to init used to read as manual mode and return
    0.0 in silence: now step returns NaN and no function changes the state. An
    initialised state's one mode word reads automatic or manual."""
    import subprocess

    src = c_source(mfcontrol.make_controller("motor-noise-pid"), prefix="m")
    (tmp_path / "m.h").write_text(src.header)
    (tmp_path / "m.c").write_text(src.source)
    (tmp_path / "main.c").write_text(r"""
#include <math.h>
#include <string.h>
#include "m.h"
int main(void)
{
    static m_state s, zero;
    double u;
    m_set_manual(&s, 1.0);
    m_set_auto(&s);
    u = m_step(&s, 0.5, 1.0);
    if (!isnan(u) || memcmp(&s, &zero, sizeof s) != 0) return 1;
    m_init(&s);
    u = m_step(&s, 0.5, 1.0);
    if (!isfinite(u) || s.mode != M_AUTO) return 2;
    m_set_manual(&s, 1.0);
    if (s.mode != M_MANUAL || m_step(&s, 0.5, 1.0) != 1.0) return 3;
    m_set_auto(&s);
    return s.mode == M_AUTO ? 0 : 4;
}
""")
    subprocess.run([H.compiler(), *H.CFLAGS, str(tmp_path / "m.c"), str(tmp_path / "main.c"),
                    "-o", str(tmp_path / "t"), "-lm"], check=True, timeout=600)
    assert subprocess.run([str(tmp_path / "t")], timeout=600).returncode == 0


def test_an_application_reads_the_state_by_the_names_in_the_header(tmp_path):
    """The rows of the law's memory are named in the header (PREFIX_MODULE_NAME, as in
    mfcontrol.laws): a firmware reads its PID's integral as s.cs.row[M_PID_I], or by
    name in the union's other view, s.cs.named.y_old: the values the live controller holds
    in those rows."""
    import subprocess

    from mfcontrol.laws import pid

    ctrl = mfcontrol.make_controller("motor-noise-pid")
    src = c_source(ctrl, prefix="m")
    assert "M_PID_I " in src.header and "M_PID_I " not in src.source
    (tmp_path / "m.h").write_text(src.header)
    (tmp_path / "m.c").write_text(src.source)
    samples = [(0.5, 1.0), (0.6, 1.0), (0.65, 2.0)]
    steps = "".join(f"    m_step(&s, {y!r}, {r!r});\n" for y, r in samples)
    (tmp_path / "main.c").write_text(
        "#include <stdio.h>\n#include \"m.h\"\nint main(void)\n{\n    static m_state s;\n"
        f"    m_init(&s);\n{steps}"
        "    printf(\"%.17g %.17g\\n\", (double)s.cs.row[M_PID_I], (double)s.cs.named.y_old);\n"
        "    return 0;\n}\n")
    exe = tmp_path / "t"
    subprocess.run([H.compiler(), *H.CFLAGS, str(tmp_path / "m.c"), str(tmp_path / "main.c"),
                    "-o", str(exe), "-lm"], check=True, timeout=600)
    got = subprocess.run([str(exe)], capture_output=True, text=True, check=True,
                         timeout=600).stdout.split()
    for y, r in samples:
        ctrl(y, setpoint=r)
    assert [float(v) for v in got] == [ctrl._CS[pid.I, 0], ctrl._CS[pid.Y_OLD, 0]]


def test_a_cpp_firmware_links_the_export_and_float_code_stays_float(tmp_path):
    """The header opens extern "C" for C++; the sample time is a literal of the export's
    type, so ``f * PREFIX_SAMPLE_TIME`` in a float build promotes nothing to double."""
    import shutil
    import subprocess

    cxx = shutil.which("c++") or shutil.which("g++") or shutil.which("clang++")
    for real in ("float", "double"):
        src = c_source(mfcontrol.make_controller(INTELLIGENT), prefix="m", real=real)
        (tmp_path / "m.h").write_text(src.header)
        (tmp_path / "m.c").write_text(src.source)
        (tmp_path / "use.c").write_text('#include "m.h"\n'
                                        "m_real ticks(m_real f) { return f * M_SAMPLE_TIME; }\n")
        for file in ("m.c", "use.c"):
            subprocess.run([H.compiler(), *H.CFLAGS, "-c", str(tmp_path / file), "-o",
                            str(tmp_path / (file + ".o"))], check=True, timeout=600)
        if cxx is None:
            continue
        (tmp_path / "main.cpp").write_text(
            '#include <cmath>\n#include "m.h"\n'
            "int main() { static m_state s; m_init(&s);\n"
            "  return std::isfinite(m_step(&s, (m_real)0.1, (m_real)0.2)) ? 0 : 1; }\n")
        subprocess.run([cxx, "-std=c++11", "-Wall", "-Wextra", "-Werror", "-I", str(tmp_path),
                        str(tmp_path / "main.cpp"), str(tmp_path / "m.c.o"), "-o",
                        str(tmp_path / "cpp"), "-lm"], check=True, timeout=600)
        assert subprocess.run([str(tmp_path / "cpp")], timeout=600).returncode == 0
    assert "#define M_SAMPLE_TIME 0.001f" in c_source(
        mfcontrol.make_controller(INTELLIGENT), prefix="m", real="float").header


_HOSTILE_TEXT = [
    "x *\\\n/ extern int injected; /\\\n* y",  # a backslash-newline closes the comment
    "x *\\  \n/ extern int injected; /\\\n* y",  # (gcc splices across trailing blanks)
    "ends in a trigraph ??/\nextern int injected;",
    "*/ extern int injected; /*",
    "a\r\nextern int injected;\u2028b\x0c\x00c",
    "**//*/*",
]


@pytest.mark.parametrize("text", _HOSTILE_TEXT, ids=range(len(_HOSTILE_TEXT)))
def test_hostile_text_stays_inert_comment(text, tmp_path):
    """Issue 33: a backslash-newline in a description or a --set text ended the banner's
    comment and what followed compiled; a trailing ??/ broke -Werror. Text now enters the
    C only as comment text: the preprocessed files hold no token of it, and they compile
    with -Werror (trigraphs on, as -std=c99 has them)."""
    import subprocess

    for real in ("double", "float"):
        src = c_source(mfcontrol.make_controller(INTELLIGENT), description=text, real=real)
        (tmp_path / "mfc.h").write_text(src.header)
        (tmp_path / "mfc.c").write_text(src.source)
        done = subprocess.run([H.compiler(), "-std=c99", "-E", "-I", str(tmp_path),
                               str(tmp_path / "mfc.c")], capture_output=True, text=True,
                              check=True, timeout=600)
        assert "injected" not in done.stdout
        subprocess.run([H.compiler(), *H.CFLAGS, "-Wtrigraphs", "-c", str(tmp_path / "mfc.c"),
                        "-o", str(tmp_path / "mfc.o")], check=True, timeout=600)


def test_the_cli_text_of_a_set_cannot_inject_code(tmp_path):
    """The command line puts its --set texts in the banner: the issue's injection, through
    the CLI, stays comment text."""
    import subprocess

    from mfcontrol.cli import main

    assert main(["export-c", "motor-noise-pid", "--out", str(tmp_path), "--set",
                 "description=x *\\\n/ extern int injected; /\\\n* y"]) == 0
    pre = subprocess.run([H.compiler(), "-std=c99", "-E", "-I", str(tmp_path),
                          str(tmp_path / "mfc.c")], capture_output=True, text=True,
                         check=True, timeout=600)
    assert "injected" not in pre.stdout


@pytest.mark.parametrize("flag", ["-ffast-math", "-ffinite-math-only"])
def test_a_build_that_removes_the_guards_is_refused(flag, tmp_path):
    """Issue 33 saw the exported PID take an infinite setpoint and sit at +24 V for good:
    that happens when the file is compiled with -ffast-math, under which gcc drops every
    isfinite() test (measured on the export before this change: the output stayed 24.0
    and nan_count 0). Such a build now stops with a message that says why."""
    import subprocess

    src = c_source(mfcontrol.make_controller("motor-noise-pid"))
    (tmp_path / "mfc.h").write_text(src.header)
    (tmp_path / "mfc.c").write_text(src.source)
    done = subprocess.run([H.compiler(), "-std=c99", "-O2", flag, "-c", str(tmp_path / "mfc.c"),
                           "-o", str(tmp_path / "mfc.o")], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode != 0 and "remove the NaN and infinity guards" in done.stderr


def test_a_reviewer_reads_the_rows_by_their_names():
    """Issue 33: parameters and state were unnamed rows (params[12], cs[17]). A tunable
    parameter is a named member of the parameter struct (cp->kp, s->params.out_min); every
    other row the C reads by a constant has the name the law's Python gives it, as an enum
    constant PREFIX_MODULE_NAME, and the fixed table says which row is which."""
    pid_ctrl = mfcontrol.make_controller("motor-noise-pid")
    src = c_source(pid_ctrl)
    assert "    mfc_real kp;" in src.header and "    mfc_real out_max;" in src.header
    assert "cp->kp" in src.source and "s->params.out_min" in src.source
    assert "    0.2 /* kp */," in src.source  # the defaults, by name
    assert "cs[MFC_PID_Y_OLD]" in src.source
    # every PID row is tunable: no fixed table
    assert "mfc_fixed" not in src.source
    frozen = c_source(pid_ctrl, frozen=True).source
    assert "    0.2 /* 0: MFC_PID_KP */," in frozen
    assert "mfc_fixed[MFC_PID_OUT_MIN]" in frozen and "cp->" not in frozen
    # a number in brackets only where the table is declared
    assert re.findall(r"mfc_fixed\[\d+", frozen) == ["mfc_fixed[10"]
    algebraic = c_source(mfcontrol.make_controller(INTELLIGENT)).source
    assert "MFC_ESTIMATORS_COUNT" in algebraic and "MFC_INTELLIGENT_U1" in algebraic
    assert "mfc_fixed[MFC_INTELLIGENT_M_WIN]" in algebraic and "cp->kp" in algebraic
    assert len(re.findall(r"mfc_fixed\[\d", algebraic)) == 1


# (case, overrides, the retune: the constructor's keywords as functions of its parameters)
RETUNES = [
    ("motor-noise-pid", {}, lambda p: {"kp": 1.5 * p["kp"], "ki": 0.5 * p["ki"],
                                       "output_limits": [-12.0, 12.0]}),
    ("motor-noise-pid", {"controller.kd": 0.05, "controller.Tt": 0.2},
     lambda p: {"kd": 0.02, "N": 8.0, "b": 0.7, "c": 0.5, "Tf": 0.002}),
    ("motor-noise-adrc", {"controller.order": 2, "controller.wc": 15.0,
                          "controller.wo": 60.0, "controller.delay": 3},
     lambda p: {"wc": 12.0, "wo": 50.0, "b0": 1.2 * p["b0"]}),
    (INTELLIGENT, {}, lambda p: {"kp": 1.5 * p["kp"], "ki": 0.7 * p["ki"],
                                 "alpha": 1.2 * p["alpha"]}),
    (INTELLIGENT, {"controller.law": "i-PID", "controller.order": 2, "controller.kd": 0.5,
                   "controller.estimator": "backward-difference",
                   "controller.anti_windup": "back-calculation"},
     lambda p: {"kd": 0.3, "k_aw": 3.0, "output_limits": [-5.0, 5.0]}),
    (RECURSIVE, {}, lambda p: {"kp": 1.2 * p["kp"], "alpha": 0.8 * p["alpha"]}),
    (RECURSIVE, {"controller.law": "variational"},
     lambda p: {"Gamma": 2.0 * p["Gamma"], "eps_M": 0.5 * p["eps_M"]}),
]


def _values(ctrl) -> dict[str, float]:
    """The export's parameter members as the live controller holds them."""
    cp = ctrl._CP[:, 0]
    return {name: float(cp[row]) for name, row, _ in ctrl._LAW.tunable(cp)}


@pytest.mark.parametrize("case,over,retune", RETUNES,
                         ids=[_id((c, o)) for c, o, _ in RETUNES])
def test_parameters_set_at_run_time_are_the_python_retune_bit_for_bit(case, over, retune,
                                                                        tmp_path):
    """Issue 33: gains and limits change at run time. The C's set_params equals the live
    controller's retune(): the same bumpless restart from the last output in automatic,
    the held output clamped in manual, a refused set (the member at fault returned) that
    changes nothing; then the same bits at every later sample. The set comes after a
    rejected sample: the restart's first step spans one period (review: the C's spanned
    two, the longer period's coefficients still chosen)."""
    ctrl = mfcontrol.make_controller(case, over)
    src = c_source(ctrl)
    changes = retune(ctrl._params)
    retuned = type(ctrl)(**{**ctrl._params, **changes})
    defaults = inspect.signature(type(ctrl)).parameters
    back = {k: ctrl._params.get(k, getattr(defaults.get(k), "default", None)) for k in changes}
    first = src.fields[0]  # kp, or the ADRC's b0: a NaN there is refused with code 1
    key = {"kp": "kp", "b0": "b0"}[first]
    bad = {**_values(ctrl), first: math.nan}
    y, r = closed_loop(case)
    ops = np.vstack([
        H.steps(y[:600], r[:600]), H.steps([math.nan], r[599:600]),
        H.set_params_rows(src, _values(retuned), 0), H.steps(y[600:900], r[600:900]),
        H.set_params_rows(src, bad, 1), H.steps(y[900:1000], r[900:1000]),
        [(H.MANUAL, float(np.median(r)), 0.0)],
        H.set_params_rows(src, _values(ctrl), 2),  # back, in manual
        [(H.AUTO, 0.0, 0.0)], H.steps(y[1000:1200], r[1000:1200]),
    ])
    exe = H.build(src, tmp_path)
    c_out, c_nan = H.run_binary(exe, ops)
    py_ctrl = mfcontrol.make_controller(case, over)
    py_out, py_nan = H.run_python(py_ctrl, ops, [
        (changes, 0), ({key: math.nan}, 1), (back, 0)])
    np.testing.assert_array_equal(c_out, py_out)
    assert c_nan == py_nan
    # the retune took: the outputs after it differ from a run without it
    plain, _ = H.run_python(mfcontrol.make_controller(case, over), np.vstack([
        H.steps(y[:600], r[:600]), H.steps([math.nan], r[599:600]),
        H.steps(y[600:900], r[600:900])]))
    assert not np.array_equal(plain[601:], np.delete(py_out, 601)[601:901])


@pytest.mark.parametrize("variant", VARIANTS, ids=[_id(v) for v in VARIANTS])
def test_the_setters_check_is_the_laws_invalid_row(variant, tmp_path):
    """The C's check of a parameter set is the law's invalid_row, translated: for sets with
    NaN, infinities, zeros, signs and limits out of order in every member, the code
    set_params returns names the member invalid_row names (0: taken)."""
    ctrl = mfcontrol.make_controller(*variant)
    src = c_source(ctrl)
    cp = ctrl._CP[:, 0]
    tunable = ctrl._LAW.tunable(cp)
    rng = np.random.default_rng(3)
    special = [math.nan, math.inf, -math.inf, 0.0, -0.0, -1.0, 1.0, 1e-300, 1e300, -2.5]
    base = _values(ctrl)
    sets = [base]
    for name in src.fields:
        sets += [{**base, name: v} for v in special]
    for _ in range(60):  # two members at once
        a, b = rng.choice(len(src.fields), 2, replace=False)
        sets.append({**base, src.fields[a]: rng.choice(special),
                     src.fields[b]: rng.choice(special)})
    expected = []
    for values in sets:
        col = cp.copy()
        for name, row, _ in tunable:
            col[row] = values[name]
        row = ctrl._LAW.invalid_row(col[:, None], 0)
        expected.append(0 if row < 0 else 1 + [r for _, r, _ in tunable].index(row))
    # every set tried on the exported state as built: set, then back to the base set
    ops = np.vstack([np.vstack([H.set_params_rows(src, v, 0),
                                H.set_params_rows(src, base, 0)]) for v in sets])
    out, _ = H.run_binary(H.build(src, tmp_path), ops)
    assert out[::2].tolist() == expected and not out[1::2].any()
    assert expected[0] == 0 and any(expected)


def test_a_frozen_export_folds_every_parameter_and_computes_the_same(tmp_path):
    """--frozen: every row a constant, no parameter struct and no setter; the same bits."""
    ctrl = mfcontrol.make_controller("motor-noise-pid", {"controller.kd": 0.05})
    frozen, tunable = c_source(ctrl, frozen=True), c_source(ctrl)
    assert "set_params" not in frozen.header and not frozen.fields
    assert "mfc_set_params" in tunable.header
    ops = operations("motor-noise-pid")
    a, _ = H.run_binary(H.build(frozen, tmp_path / "frozen"), ops)
    b, _ = H.run_binary(H.build(tunable, tmp_path / "tunable"), ops)
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("case,over", [
    ("motor-noise-pid", {"controller.duty_min": 1.0, "controller.duty_max": 3.0}),
    ("motor-noise-adrc", {"controller.duty_min": 1.0, "controller.duty_max": 1.0}),
    (RECURSIVE, {"controller.duty_min": 0.2}),
])
def test_the_output_held_before_any_sample_is_within_the_output_limits_in_c(case, over,
                                                                            tmp_path):
    """The output held before any sample is taken is 0 clamped to the output limits, in C
    as in Python (it was 0 in both, outside limits that exclude it)."""
    ctrl = mfcontrol.make_controller(case, over)
    ops = np.array([(H.STEP, np.nan, 1.0), (H.STEP, 1e308, 1.0), (H.STEP, np.inf, 1.0)])
    c_out, c_nan = H.run_binary(H.build(c_source(ctrl), tmp_path), ops)
    py_out, py_nan = H.run_python(mfcontrol.make_controller(case, over), ops)
    np.testing.assert_array_equal(c_out, py_out)
    lo, hi = (float(ctrl._CP[row, 0]) for row in ctrl._OUT_ROWS)
    assert c_out[0] == min(max(0.0, lo), hi) and c_nan == py_nan


@pytest.mark.parametrize("case,over,retune", RETUNES,
                         ids=[_id((c, o)) for c, o, _ in RETUNES])
def test_set_params_before_any_sample_starts_afresh_and_an_unchanged_set_is_no_restart(
        case, over, retune, tmp_path):
    """Review: set_params right after init (parameters loaded at boot) restarted the law
    from the held output, and the PID's integral kept -P; a set with the values running
    restarted it too. Now the first is the export built with them, the second nothing,
    as the live retune()."""
    ctrl = mfcontrol.make_controller(case, over)
    src = c_source(ctrl)
    changes = retune(ctrl._params)
    retuned = type(ctrl)(**{**ctrl._params, **changes})
    y, r = closed_loop(case)
    ops = np.vstack([H.set_params_rows(src, _values(retuned), 0), H.steps(y[:400], r[:400]),
                     H.set_params_rows(src, _values(retuned), 1), H.steps(y[400:600],
                                                                         r[400:600])])
    c_out, c_nan = H.run_binary(H.build(src, tmp_path), ops)
    py_out, py_nan = H.run_python(mfcontrol.make_controller(case, over), ops,
                                  [(changes, 0), (changes, 0)])
    np.testing.assert_array_equal(c_out, py_out)
    assert c_nan == py_nan
    # both are the controller built with the new parameters, never restarted
    built, _ = H.run_python(retuned, H.steps(y[:600], r[:600]))
    np.testing.assert_array_equal(np.delete(c_out, [0, 401]), built)


@pytest.mark.parametrize("case,keys", [("motor-noise-pid", ("output_limits",)),
                                       (RECURSIVE, ("duty_min", "duty_max"))])
def test_a_held_sample_after_set_params_is_within_the_new_limits(case, keys, tmp_path):
    """A rejected sample right after a retune whose limits exclude the last output
    returned that output (the recursive law's), outside the new limits; now the live
    retune and the C's set_params both restart from it clamped, with the same bits."""
    ctrl = mfcontrol.make_controller(case)
    src = c_source(ctrl)
    y, r = closed_loop(case)
    held = mfcontrol.make_controller(case)
    last = [held(v, setpoint=s) for v, s in zip(y[:300], r[:300], strict=True)][-1]
    lo, hi = (float(ctrl._CP[row, 0]) for row in ctrl._OUT_ROWS)
    # new limits that leave the last output out, on the side of the wider gap
    new = (lo, last - 0.25 * (last - lo)) if last - lo > hi - last else \
        (last + 0.25 * (hi - last), hi)
    changes = dict(zip(keys, [list(new)] if len(keys) == 1 else new, strict=True))
    ops = np.vstack([H.steps(y[:300], r[:300]),
                     H.set_params_rows(src, {**_values(ctrl), "out_min": new[0],
                                             "out_max": new[1]}, 0),
                     H.steps([math.nan], r[299:300]), H.steps(y[300:400], r[300:400])])
    c_out, _ = H.run_binary(H.build(src, tmp_path), ops)
    py_out, _ = H.run_python(mfcontrol.make_controller(case), ops, [(changes, 0)])
    np.testing.assert_array_equal(c_out, py_out)
    assert c_out[299] == last and not new[0] <= last <= new[1]
    assert c_out[300] == 0  # set_params's answer: taken
    assert np.all((c_out[301:] >= new[0]) & (c_out[301:] <= new[1]))  # the held one too


def test_the_memory_s_named_view_lies_on_its_rows(tmp_path):
    """Issue 33: the state was an unnamed row array (cs[17]). The memory is a union of its
    rows (what the law reads and writes) and the same rows by name: a debugger's watch
    shows s.cs.named.integ. For every law family, each named member is the row of the
    enum constant it is named after, and each array starts at the row its comment says
    (checked by the compiled C: the members' addresses)."""
    import subprocess

    from .test_on_target import CASES

    extra = [("motor-noise-adrc", {}), ("motor-noise-adrc", {"controller.delay": 3})]
    for k, (case, overrides) in enumerate(CASES + extra):
        src = c_source(mfcontrol.make_controller(case, overrides), prefix="m")
        body = src.header[src.header.index("the law's memory by name"):
                          src.header.index("} m_memory_rows;")]
        checks = []
        for member, row in re.findall(r"m_real (\w+); +/\*.*\((M_\w+|row \d+)\) \*/", body):
            checks.append(f"&s.cs.named.{member} == &s.cs.row[{row.removeprefix('row ')}]")
        for member, first in re.findall(r"m_real (\w+)\[\d+\]; +/\*.*rows (\d+) to", body):
            checks.append(f"&s.cs.named.{member}[0] == &s.cs.row[{first}]")
        # every row is in the view: the named members and the arrays
        named = len(re.findall(r"m_real \w+;", body))
        arrays = sum(int(n) for n in re.findall(r"m_real \w+\[(\d+)\];", body))
        assert named + arrays == src.n_state and named >= 9, case
        folder = tmp_path / str(k)
        folder.mkdir()
        (folder / "m.h").write_text(src.header)
        (folder / "m.c").write_text(src.source)
        (folder / "main.c").write_text(
            "#include <stdio.h>\n#include \"m.h\"\nint main(void)\n{\n    static m_state s;\n"
            + "".join(f"    if (!({c})) {{ puts(\"{c}\"); return 1; }}\n" for c in checks)
            + "    return 0;\n}\n")
        subprocess.run([H.compiler(), *H.CFLAGS, str(folder / "m.c"), str(folder / "main.c"),
                        "-o", str(folder / "t"), "-lm"], check=True, timeout=600)
        done = subprocess.run([str(folder / "t")], capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, f"{case}: {done.stdout}"
