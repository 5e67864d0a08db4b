"""The PID against its difference equations written out here, against the closed form of
the discrete loop on a first-order plant, and its live API."""

import math

import numpy as np
import pytest
import scipy.signal

import mfcontrol
from mfcontrol import PID, FirstOrder


def reference_pid(ys, rs, h, kp, ki, kd, N, b, Tt, lo, hi, c=0.0, Tf=0.0):
    """Astrom and Hagglund's discrete PID, as the issue writes it, in plain Python; with
    the measurement filter 1 / (1 + s Tf + (s Tf)^2 / 2) written as the implicit
    (backward-difference) step of its two states, solved by numpy, not in closed form."""
    Td = kd / kp if kp != 0 else 0.0
    if Tt is None and ki != 0:
        Ti = kp / ki
        Tt = math.sqrt(Ti * Td) if kd != 0 else Ti
    ad = Td / (Td + N * h)
    bd = kp * Td * N / (Td + N * h)
    I = D = 0.0  # noqa: E741
    y_old, r_old = ys[0], rs[0]
    x = np.array([ys[0], 0.0])  # (y_f, y_f') at rest at the first measurement
    if Tf > 0:
        A = np.array([[0.0, 1.0], [-2.0 / Tf**2, -2.0 / Tf]])
        B = np.array([0.0, 2.0 / Tf**2])
    out = []
    for y_raw, r in zip(ys, rs, strict=True):
        if Tf > 0:  # x_k = x_{k-1} + h (A x_k + B y_k)
            x = np.linalg.solve(np.eye(2) - h * A, x + h * B * y_raw)
        y = x[0] if Tf > 0 else y_raw
        P = kp * (b * r - y)
        D = ad * D + bd * ((c * r - y) - (c * r_old - y_old))
        v = P + I + D
        u = min(max(v, lo), hi)
        I = I + ki * h * (r - y) + ((h / Tt) * (u - v) if ki != 0 else 0.0)  # noqa: E741
        y_old, r_old = y, r
        out.append(u)
    return np.array(out)


@pytest.mark.parametrize(("gains", "limits"), [
    ((2.0, 1.5, 0.3, 10.0, 1.0, None), (-1.0, 1.0)),  # saturating, default Tt = sqrt(Ti Td)
    ((2.0, 1.5, 0.0, 10.0, 0.5, None), (-1.0, 1.0)),  # PI: Tt = Ti, setpoint weight
    ((1.0, 0.0, 0.2, 5.0, 1.0, None), (-np.inf, np.inf)),  # PD, no limits
    ((3.0, 2.0, 0.1, 8.0, 1.0, 0.05), (-0.5, 2.0)),  # a given tracking time
    # the measurement filter and the derivative's setpoint weight
    ((2.0, 1.5, 0.3, 10.0, 0.7, None, 0.5, 0.02), (-1.0, 1.0)),
    ((1.0, 0.0, 0.2, 5.0, 1.0, None, 1.0, 0.005), (-np.inf, np.inf)),
])
def test_the_live_pid_is_its_difference_equations(gains, limits):
    kp, ki, kd, N, b, Tt, *more = gains
    c, Tf = more or (0.0, 0.0)
    h = 0.01
    rng = np.random.default_rng(3)
    ys = np.cumsum(rng.normal(0, 0.05, 400))
    rs = np.where(np.arange(400) < 200, 1.0, -0.5)
    ctrl = PID(kp, ki, kd, sample_time=h, N=N, b=b, Tt=Tt, c=c, Tf=Tf,
               output_limits=tuple(None if math.isinf(x) else x for x in limits))
    got, limited = [], 0
    for y, r in zip(ys, rs, strict=True):
        got.append(ctrl(y, setpoint=r))
        limited += ctrl.components["unlimited"] != got[-1]
    want = reference_pid(ys, rs, h, kp, ki, kd, N, b, Tt, *limits, c=c, Tf=Tf)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    # the limits bind (and back-calculation acts) where there are limits
    assert (limited > 20) == (not math.isinf(limits[0]))


def test_on_a_first_order_plant_the_loop_is_its_closed_form():
    """y' = a y + b u sampled exactly with u held: y+ = phi y + g u. With the PID's state
    (I, D, y_old) the loop is linear; scipy's dlsim of its state space is the closed
    form to compare with (no saturation)."""
    a, bu, h, kp, ki, kd, N, b = -2.0, 3.0, 0.01, 1.2, 4.0, 0.05, 10.0, 0.7
    phi, g = math.exp(a * h), (math.exp(a * h) - 1) / a * bu
    Td = kd / kp
    Tt = math.sqrt(kp / ki * Td)
    ad, bd, tr = Td / (Td + N * h), kp * Td * N / (Td + N * h), h / Tt  # tr: unused, no sat
    del tr
    # state s = (y, I, D, y_old) before sample k; input r; u = kp (b r - y) + I + D' with
    # D' = ad D - bd (y - y_old)
    #   u = -kp y + I + ad D - bd y + bd y_old + kp b r
    cu = np.array([-kp - bd, 1.0, ad, bd])
    du = kp * b
    A = np.zeros((4, 4))
    B = np.zeros((4, 1))
    A[0] = phi * np.eye(4)[0] + g * cu  # y+ = phi y + g u
    B[0] = g * du
    A[1] = np.array([-ki * h, 1.0, 0.0, 0.0])  # I+ = I + ki h (r - y)
    B[1] = ki * h
    A[2] = np.array([-bd, 0.0, ad, bd])  # D+ = D'
    A[3] = np.array([1.0, 0.0, 0.0, 0.0])  # y_old+ = y
    C = np.array([[1.0, 0.0, 0.0, 0.0]])
    n = 300
    # y_old starts at the first measurement (y0 = 0.4)
    _, y_closed, _ = scipy.signal.dlsim((A, B, C, np.zeros((1, 1)), h), np.ones(n),
                                         x0=[0.4, 0.0, 0.0, 0.4])
    res = mfcontrol.simulate_loop(FirstOrder(a, bu, x0=0.4, integrator="exact"),
                                  PID(kp, ki, kd, sample_time=h, N=N, b=b), 1.0, t_end=n * h)
    np.testing.assert_allclose(res.signals["y"], y_closed[:, 0], rtol=1e-12, atol=1e-12)


def test_the_engine_runs_what_the_live_pid_computes():
    plant = FirstOrder(-1.0, 2.0, integrator="exact")
    kw = dict(sample_time=1e-2, N=8.0, output_limits=(-1.0, 1.0))
    res = mfcontrol.simulate_loop(plant, PID(1.5, 2.0, 0.1, **kw), 1.0, t_end=3.0)
    assert res.engine == "compiled"
    live, x = PID(1.5, 2.0, 0.1, **kw), plant.x0
    us = []
    for k in range(res.time.size):
        u = live(plant.output(x), setpoint=1.0)
        us.append(u)
        x = plant.step(k * 1e-2, x, u, 1e-2)
    assert np.array_equal(res.signals["u"], us)
    assert set(res.signals) >= {"P", "I", "D", "u_raw"}
    assert math.isnan(res.metrics["final_gamma"])


def test_live_api_snapshot_bumpless_nan_and_components():
    ctrl = PID(2.0, 1.0, 0.2, sample_time=0.1, output_limits=(0.0, 10.0))
    for y in (0.0, 0.2, 0.5):
        ctrl(y, setpoint=1.0)
    snap = ctrl.snapshot()
    after = [ctrl(y, setpoint=1.0) for y in (0.6, 0.7)]
    again = PID.from_snapshot(snap)
    assert [again(y, setpoint=1.0) for y in (0.6, 0.7)] == after
    assert set(ctrl.components) == {"P", "I", "D", "unlimited"}
    # a NaN measurement holds the output and is counted
    held = ctrl(float("nan"))
    assert held == after[-1] and ctrl.nan_count == 1
    # manual at 3.0, back to automatic: the first output is 3.0 (no bump)
    ctrl.set_auto_mode(False, last_output=3.0)
    assert ctrl(0.9) == 3.0
    ctrl.set_auto_mode(True)
    assert ctrl(0.9, setpoint=1.0) == pytest.approx(3.0, abs=1e-15)
    assert ctrl(0.9, setpoint=1.0) != 3.0


def test_the_measurement_filter_follows_its_continuous_step_response():
    # 1 / (1 + s Tf + (s Tf)^2 / 2): poles (-1 +- i) / Tf, step response
    # 1 - e^(-t/Tf) (cos(t/Tf) + sin(t/Tf)); the backward difference is O(h) from it.
    # A P controller with b = 0 outputs -kp y_f: the filter's output itself
    Tf, h = 0.5, 1e-4
    ctrl = PID(kp=1.0, b=0.0, Tf=Tf, sample_time=h)
    t = h * np.arange(30_000)
    y = np.where(t > 0, 1.0, 0.0)  # at rest at 0, a unit step from the second sample
    out = -np.array([ctrl(v, setpoint=0.0) for v in y])
    tau = (t - h) / Tf
    exact = np.where(t > 0, 1.0 - np.exp(-tau) * (np.cos(tau) + np.sin(tau)), 0.0)
    assert np.max(np.abs(out - exact)) < 2 * h / Tf
    # and the linear analysis' filter is the law's: the same outputs to rounding, and a
    # unit DC gain
    f = ctrl.linear_filter()
    # (to 1e-6: its coefficients are of order (Tf / h)^2, and their sums cancel)
    assert -np.sum(f.b_y) / np.sum(f.a) == pytest.approx(1.0, rel=1e-6)
    rebuilt = scipy.signal.lfilter(f.b_y, f.a, y)
    np.testing.assert_allclose(-rebuilt, out, atol=1e-12)


def test_a_snapshot_from_before_the_filter_rows_continues_bit_for_bit():
    # its state had the nine rows up to the terms; the filter's and r_old's follow
    ctrl = PID(kp=2.0, ki=1.0, kd=0.2, sample_time=0.01)
    ys = np.cumsum(np.random.default_rng(5).normal(0, 0.1, 60))
    for y in ys[:30]:
        ctrl(y, setpoint=1.0)
    snap = ctrl.snapshot()
    old = {**snap, "state": snap["state"][:9], "layout": 3}
    again = PID.from_snapshot(old)
    assert [again(y, setpoint=1.0) for y in ys[30:]] == [ctrl(y, setpoint=1.0)
                                                          for y in ys[30:]]
    assert "Tf" not in snap["params"] and "c" not in snap["params"]


@pytest.mark.parametrize(("kwargs", "message"), [
    (dict(kp=1.0, Tf=-0.1), "Tf = -0.1: must be a finite number >= 0"),
    (dict(kp=0.0, kd=1.0), "kd = 1.0: must have the sign of kp"),
    (dict(kp=1.0, ki=-1.0), "ki = -1.0: must have the sign of kp"),
    (dict(kp=1.0, N=0.0), "N = 0.0: must be a finite number > 0"),
    (dict(kp=1.0, Tt=-1.0), "Tt = -1.0: must be a finite number > 0"),
])
def test_bad_options_get_one_line(kwargs, message):
    with pytest.raises(ValueError, match="^" + message.replace("(", r"\(")):
        PID(sample_time=0.1, **kwargs)


# --- the overflow guard's rows (pid.GUARDED) ----------------------------------------------
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from mfcontrol.laws import pid  # noqa: E402

#: finite values, the extreme ones (overflow's neighbourhood, denormals) drawn often
_FINITE = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False),
    st.sampled_from([0.0, -0.0, 5e-324, 1.0, -1.0, 1e154, -1e154, 1e300, -1e300,
                     1.7976931348623157e308, -1.7976931348623157e308]))


@st.composite
def _pid_sample(draw):
    """A valid parameter column, a finite memory (START NaN or finite), y, r and h."""
    CP = np.zeros((pid.N_PARAMS, 1))
    kp = draw(st.one_of(st.just(0.0), _FINITE))
    CP[pid.KP] = kp
    CP[pid.KI] = draw(st.one_of(st.just(0.0), _FINITE))
    CP[pid.KD] = draw(st.one_of(st.just(0.0), _FINITE.map(lambda x: math.copysign(x, kp))))
    CP[pid.N] = draw(_FINITE.map(abs).filter(lambda x: x > 0.0))
    CP[pid.B] = draw(_FINITE)
    CP[pid.C] = draw(st.one_of(st.just(0.0), _FINITE))
    CP[pid.TF] = draw(st.one_of(st.just(0.0), _FINITE.map(abs)))
    CP[pid.TT] = draw(st.one_of(st.just(math.inf), _FINITE.map(abs).filter(lambda x: x > 0)))
    lo = draw(st.one_of(st.just(-math.inf), _FINITE))
    hi = draw(st.one_of(st.just(math.inf), _FINITE))
    CP[pid.OUT_MIN], CP[pid.OUT_MAX] = min(lo, hi), max(lo, hi)
    CS = np.array([[draw(_FINITE)] for _ in range(pid.N_STATE)])
    CS[pid.K] = draw(st.sampled_from([0.0, 1.0, 7.0, 2.0**53]))
    CS[pid.START] = draw(st.one_of(st.just(math.nan), _FINITE))
    y, r = draw(_FINITE), draw(_FINITE)
    h = draw(st.sampled_from([1e-3, 2e-3, 1e-6, 1.0]))
    return CP, CS, y, r, h


@settings(max_examples=3000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_pid_sample())
def test_the_guarded_rows_and_the_output_are_finite_exactly_when_the_memory_is(sample):
    """pid.GUARDED: the C export's overflow guard checks u and these rows only, the live
    controller every row; on valid parameters, a finite memory and finite samples (the
    guard's precondition: what it let through before, and the input guard's) they take the
    same decision, hostile magnitudes included."""
    CP, CS, y, r, h = sample
    if pid.invalid_row(CP, 0) >= 0:
        return
    u = pid.step(CP, CS, 0, y, r, h)
    every_row = math.isfinite(u) and all(
        math.isfinite(v) or (row == pid.START and v != v) for row, v in enumerate(CS[:, 0]))
    guarded = math.isfinite(u) and all(math.isfinite(CS[getattr(pid, name), 0])
                                        for name in pid.GUARDED)
    assert guarded == every_row
    assert CS[pid.START, 0] != CS[pid.START, 0]  # NaN after any step: never checked
