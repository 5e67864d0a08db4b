"""The intelligent law's estimators of F in a closed loop, checked against facts.

* with the trapezoid kernel the algebraic i-P has a finite DC gain: its steady-state error
  is ``-alpha u / (kp M^2)``; with the held kernel it is zero;
* the order-2 backward difference of the held kernel (``alpha (u_{k-1} + u_{k-2}) / 2``)
  keeps the loop on y'' = beta u stable down to alpha = beta/3, the trapezoid's
  (``alpha u_{k-1}``) only down to beta/2: the linear analysis's spectral radius and a
  simulated loop agree;
* the algebraic estimator's start: holding the output until the window is full keeps a
  loop the full estimator holds, where the backward difference standing in blows it up.
"""

import math

import control
import numpy as np
import pytest

import mfcontrol
from mfcontrol.analysis.loop import LinearLoop


def integrate(ctrl, beta, h, n_steps, order, r=1.0, a=0.0):
    """The loop of ``ctrl`` on y^(n) = a y + beta u (n = 1) or y'' = beta u (n = 2),
    stepped exactly over each sample under the held output; returns (y, u) per sample."""
    y = v = 0.0
    ys, us = np.empty(n_steps), np.empty(n_steps)
    if order == 1:
        decay = np.exp(a * h)
        gain = beta * (h if a == 0.0 else np.expm1(a * h) / a)
    for k in range(n_steps):
        u = ctrl(y, setpoint=r)
        ys[k], us[k] = y, u
        if order == 1:
            y = decay * y + gain * u
        else:
            y, v = y + h * v + 0.5 * h * h * beta * u, v + h * beta * u
        if not np.isfinite(y) or abs(y) > 1e12:
            ys[k + 1:], us[k + 1:] = np.inf, np.nan
            break
    return ys, us


@pytest.mark.parametrize("M", [4, 10])
def test_the_trapezoid_i_P_has_the_closed_form_steady_state_error(M):
    # y' = -y + 2 u: at rest y = 2 u; the i-P's e = -alpha u / (kp M^2) (trapezoid)
    h, alpha, kp, r = 0.01, 4.0, 20.0, 1.0
    trap = mfcontrol.IP(alpha=alpha, kp=kp, sample_time=h, estimator="algebraic", window=M,
                        kernel="trapezoid")
    y, u = integrate(trap, 2.0, h, 4000, 1, r=r, a=-1.0)
    predicted = -alpha * u[-1] / (kp * M**2)
    assert y[-1] - r == pytest.approx(predicted, rel=1e-6)
    assert abs(predicted) > 5e-4  # large enough to be told from zero
    held = mfcontrol.IP(alpha=alpha, kp=kp, sample_time=h, estimator="algebraic", window=M)
    y, _ = integrate(held, 2.0, h, 4000, 1, r=r, a=-1.0)
    assert abs(y[-1] - r) < 1e-9


@pytest.mark.parametrize("kernel,stable,unstable", [("trapezoid", 1.9, 2.1),
                                                    ("held", 2.9, 3.1)])
@pytest.mark.parametrize("law,gains", [("IPD", {"kp": 1.0, "kd": 2.0}),
                                       ("IPID", {"kp": 1.0, "ki": 0.2, "kd": 2.0})])
def test_order_two_backward_difference_stability_bounds(kernel, stable, unstable, law, gains):
    h, beta = 0.01, 1.0
    plant = control.tf([beta], [1.0, 0.0, 0.0])
    for ratio, holds in ((stable, True), (unstable, False)):
        ctrl = getattr(mfcontrol, law)(alpha=beta / ratio, sample_time=h, order=2,
                                       kernel=kernel, **gains)
        radius = LinearLoop(ctrl.linear_filter(), plant).spectral_radius()
        assert (radius < 1.0) == holds, (ratio, radius)
        y, _ = integrate(ctrl, beta, h, 3000, 2)
        # the simulated loop agrees: tracks, or grows without bound
        if holds:
            assert abs(y[-1] - 1.0) < 1e-3
        else:
            assert not np.isfinite(y[-1]) or abs(y[-1]) > 1e3


@pytest.mark.parametrize("kernel", ["held", "trapezoid"])
def test_holding_the_start_keeps_a_loop_the_full_window_holds(kernel):
    # y' = u sampled at 10 ms, M = 20, kp = 5, alpha = 0.1: the full estimator's loop is
    # stable, the backward difference's needs alpha > (2 + kp h) / 4 = 0.51
    h, M, kp, alpha = 0.01, 20, 5.0, 0.1
    common = {"alpha": alpha, "kp": kp, "sample_time": h, "estimator": "algebraic",
              "window": M, "kernel": kernel}
    radius = LinearLoop(mfcontrol.IP(**common).linear_filter(),
                        control.tf([1.0], [1.0, 0.0])).spectral_radius()
    assert radius < 1.0
    bd = mfcontrol.IP(**common, startup="backward-difference")
    y, _ = integrate(bd, 1.0, h, 1000, 1)
    assert not np.isfinite(y[-1]) or np.abs(y).max() > 1e6  # blown up by its start
    held = mfcontrol.IP(**common)  # startup="hold", the default
    y, u = integrate(held, 1.0, h, 1000, 1)
    assert np.all(u[:M] == 0.0)  # the starting output, held while the window fills
    assert np.abs(y).max() < 2.0 and abs(y[-1] - 1.0) < 1e-6


@pytest.mark.parametrize("d", [5, 20])
def test_a_compensated_delay_holds_the_loop_it_broke(d):
    # y' = -y + u behind d samples of input delay: the i-PI pairing y with u_{k-1}
    # diverges; pairing it with u_{k-1-d}, the input the plant received, holds it, and the
    # prediction over the delay damps it further. The linear analysis (the loop's delay)
    # says the same before the runs.
    h = 0.01
    plant = control.tf([1.0], [1.0, 1.0])

    def run(**options):
        ctrl = mfcontrol.IPI(alpha=1.0, kp=5.0, ki=2.0, sample_time=h, **options)
        radius = LinearLoop(ctrl.linear_filter(), plant, delay=d).spectral_radius()
        y, sent = 0.0, [0.0] * d
        out = []
        decay, gain = np.exp(-h), -np.expm1(-h)
        for _ in range(3000):
            sent.append(ctrl(y, setpoint=1.0))
            y = decay * y + gain * sent.pop(0)
            out.append(y)
            if abs(y) > 1e9:
                break
        return radius, np.array(out)

    radius, y = run()
    assert radius > 1.0 and np.abs(y).max() > 1e6
    radius, y = run(delay=d)
    assert radius < 1.0 and abs(y[-1] - 1.0) < 1e-6
    overshoot = y.max() - 1.0
    radius, y = run(delay=d, predict=True)
    assert radius < 1.0 and abs(y[-1] - 1.0) < 1e-6
    assert y.max() - 1.0 < overshoot


def test_the_readme_motor_holds_20_samples_of_actuator_delay_with_compensation():
    # the README's own example (an i-PI on a DC motor at 1 kHz) behind 20 samples of
    # actuator delay: lost without compensation, held with it. (The prediction over the
    # delay does not hold this one at these gains: the motor's current lags the voltage,
    # which the order-1 model's prediction ignores; docs/theory.md)
    def motor(t, x, u, p, dxdt):
        dxdt[0] = (p[2] * x[1] - p[1] * x[0] - p[5]) / p[0]
        dxdt[1] = (u - p[3] * x[1] - p[2] * x[0]) / p[4]

    plant = mfcontrol.ODE(motor, lambda x, p: x[0], x0=(0.0, 0.0),
                          params={"J": 5e-4, "b": 1e-4, "k": 0.05, "R": 2.0, "L": 2e-3,
                                  "tau": 0.0})
    load = [mfcontrol.Change(1.0, "tau", 0.05)]
    lag = mfcontrol.Actuator(delay=20)

    def run(**options):
        ctrl = mfcontrol.IPI(alpha=50.0, kp=20.0, ki=50.0, sample_time=1e-3,
                             output_limits=(-24, 24), **options)
        return mfcontrol.simulate_loop(plant, ctrl, 60.0, t_end=2.0, changes=load,
                                       actuator=lag)

    assert not run().metrics["settled"]
    res = run(delay=20)
    assert res.metrics["settled"] and abs(res.signals["y"][-1] - 60.0) < 0.05


def test_a_snapshot_from_before_the_kernel_continues_bit_for_bit():
    # snapshots taken by mfcontrol at e29fdec (before kernel, startup and delay existed,
    # and the state row of u_{k-2}): from_snapshot builds the controller they ran
    # (kernel "trapezoid", startup "backward-difference") and continues it exactly
    import json
    from pathlib import Path

    data = json.loads((Path(__file__).parents[1] / "data"
                       / "snapshots-before-kernel.json").read_text())
    for name, case in data.items():
        cls = getattr(mfcontrol, case["snapshot"]["controller"])
        ctrl = cls.from_snapshot(case["snapshot"])
        out = [ctrl(y, setpoint=1.0) for y in case["measurements"]]
        assert out == case["outputs"], name
    # a pickle of the older layout is refused in words, not read past its end
    import pickle

    ctrl = mfcontrol.IP(alpha=1.0, kp=10.0, sample_time=0.01)
    state = ctrl.__getstate__()
    state["_CP"] = state["_CP"][:-4]
    fresh = mfcontrol.IP.__new__(mfcontrol.IP)
    with pytest.raises(ValueError, match="pickled by an older mfcontrol"):
        fresh.__setstate__(state)
    assert pickle.loads(pickle.dumps(ctrl)).snapshot()["params"] == ctrl.snapshot()["params"]
    # layout 4 put a state row in and kept the parameter count: a pickle of layout 3 has
    # every parameter row and one state row fewer, and its step would read the rows at
    # the wrong offsets; refused by its state rows (an algebraic one's too)
    for law in (ctrl, mfcontrol.IPI(alpha=1.0, kp=10.0, ki=1.0, sample_time=0.01,
                                    estimator="algebraic", window=8)):
        state = law.__getstate__()
        state["_CS"] = state["_CS"][:-1]
        fresh = type(law).__new__(type(law))
        with pytest.raises(ValueError, match="its parameter or state layout changed"):
            fresh.__setstate__(state)
    pid = mfcontrol.PID(kp=1.0, ki=1.0, sample_time=0.01)
    state = pid.__getstate__()
    state["_CP"] = state["_CP"][:-2]  # a PID from before its filter's rows
    fresh = mfcontrol.PID.__new__(mfcontrol.PID)
    with pytest.raises(ValueError, match="PID was pickled by an older mfcontrol"):
        fresh.__setstate__(state)
    assert pickle.loads(pickle.dumps(pid)).snapshot()["params"] == pid.snapshot()["params"]


def test_a_snapshot_from_before_the_multi_rate_rows_continues_bit_for_bit():
    # snapshots taken at f012638, before the gain adaptation's multi-rate sum and count
    # (two state rows after gamma's): from_snapshot puts them in and continues exactly
    import json
    from pathlib import Path

    data = json.loads((Path(__file__).parents[1] / "data"
                       / "snapshots-before-multi-rate.json").read_text())
    for name, case in data.items():
        assert "layout" not in case["snapshot"]
        cls = getattr(mfcontrol, case["snapshot"]["controller"])
        ctrl = cls.from_snapshot(case["snapshot"])
        out = [ctrl(y, setpoint=1.0) for y in case["measurements"]]
        assert out == case["outputs"], name
        assert ctrl.snapshot()["layout"] == 4


def test_a_snapshot_from_before_the_adaptation_error_row_continues_bit_for_bit():
    # snapshots of layout 3, taken at 192082f before the gain adaptation's adaptation
    # error row (a state row after its multi-rate rows, which moves every law row after
    # it): from_snapshot puts it in, and every law continues exactly, the rls gain's rows
    # and the delay queue included. The delay-reduced kernel's coefficients have been
    # computed in exact rationals since (its Jacobi weights): the same kernel to
    # rounding, so that snapshot continues within rounding, not bit for bit
    import json
    from pathlib import Path

    data = json.loads((Path(__file__).parents[1] / "data"
                       / "snapshots-before-adaptation-error.json").read_text())
    for name, case in data.items():
        assert case["snapshot"]["layout"] == 3
        cls = getattr(mfcontrol, case["snapshot"]["controller"])
        ctrl = cls.from_snapshot(case["snapshot"])
        out = [ctrl(y, setpoint=1.0) for y in case["measurements"]]
        if case["snapshot"]["params"].get("kernel") == "delay-reduced":
            np.testing.assert_allclose(out, case["outputs"], rtol=1e-12, err_msg=name)
            assert out != case["outputs"]  # (if equal, this case may say bit for bit)
        else:
            assert out == case["outputs"], name
        assert ctrl.snapshot()["layout"] == 4
        # the error counts from the snapshot on, for the gains that adapt
        params = case["snapshot"]["params"]
        if "variational" in (params.get("gain"), params.get("law")):
            assert ctrl.adaptation_error > 0, name
        else:
            assert math.isnan(ctrl.adaptation_error), name


def test_multi_rate_gamma_holds_between_updates_in_the_intelligent_law():
    ctrl = mfcontrol.IPI(alpha=2.0, kp=5.0, ki=1.0, sample_time=0.01, gain="variational",
                         gamma0=0.5, Gamma=1e-3, adapt_every=4)
    ys = np.cumsum(np.random.default_rng(3).normal(0, 0.05, 40))
    gammas = []
    for y in ys:
        ctrl(y, setpoint=1.0)
        gammas.append(ctrl.gamma)
    g = np.array(gammas)
    moves = np.flatnonzero(np.diff(g)) + 1
    assert moves.size > 3 and (np.diff(moves) == 4).all()
    with pytest.raises(ValueError, match="adapt_every = 0: must be a whole number >= 1"):
        mfcontrol.IPI(alpha=2.0, kp=5.0, ki=1.0, sample_time=0.01, gain="variational",
                      adapt_every=0)
    with pytest.raises(ValueError, match="adapt_every = 4: only the variational gain"):
        mfcontrol.IPI(alpha=2.0, kp=5.0, ki=1.0, sample_time=0.01, adapt_every=4)


def test_kernel_and_startup_are_refused_where_they_change_nothing():
    with pytest.raises(ValueError, match="kernel = 'trapezoid': the order-1 backward"):
        mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.1, kernel="trapezoid")
    with pytest.raises(ValueError, match="startup = 'hold': only the algebraic"):
        mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.1, startup="hold")
    with pytest.raises(ValueError, match="predict = True: the prediction over the delay is "
                       "of order 1: set order=1"):
        mfcontrol.IPD(alpha=1.0, kp=1.0, kd=1.0, sample_time=0.1, delay=2, predict=True)
    assert mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.1).snapshot()["params"]["kernel"] \
        is None


@pytest.mark.parametrize("kernel,lag,jacobi", [
    ("held", None, {}), ("delay-reduced", 0.0, {}), ("delay-reduced", 2.0, {}),
    ("delay-reduced", 5.0, {}), ("delay-reduced", 0.0, {"kappa": 2, "mu": 0}),
    ("delay-reduced", 7.5, {"kappa": 0, "mu": 1}), ("delay-reduced", 10.0, {"kappa": 0,
                                                                           "mu": 0})])
def test_the_estimates_delay_sets_the_i_ps_error_on_a_ramp_in_F(kernel, lag, jacobi):
    # y' = b t + alpha u, held input: F_hat_k = F(t_k - tau) exactly (tau = lag h, or
    # M h / 2 for the held kernel), and the i-P settles where the plant's mean F over the
    # coming interval, F(t_k + h/2), exceeds F_hat_k by kp e: e = b (h/2 + tau) / kp
    M, h, alpha, kp, b = 10, 1e-2, 2.0, 5.0, 3.0
    ctrl = mfcontrol.IP(alpha=alpha, kp=kp, sample_time=h, estimator="algebraic", window=M,
                        kernel=kernel, **({} if lag is None else {"lag": lag}), **jacobi)
    y, e = 0.0, []
    for k in range(600):
        u = ctrl(y, setpoint=0.0)
        e.append(y)
        t = k * h
        y += h * (b * (t + 0.5 * h) + alpha * u)
    tau = (0.5 * M if lag is None else lag) * h
    assert e[-1] == pytest.approx(b * (0.5 * h + tau) / kp, rel=1e-6)
    params = ctrl.snapshot()["params"]
    assert params["lag"] == lag
    if kernel == "delay-reduced":
        assert (params["kappa"], params["mu"]) == (jacobi.get("kappa", 1), jacobi.get("mu", 1))
        again = type(ctrl).from_snapshot(ctrl.snapshot())
        np.testing.assert_array_equal(again._CP, ctrl._CP)
    else:
        assert params["kappa"] is None and params["mu"] is None


def test_the_delay_reduced_kernel_is_refused_where_it_cannot_run():
    with pytest.raises(ValueError, match="kernel = 'delay-reduced': weighs the algebraic"):
        mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.1, order=2, kernel="delay-reduced")
    with pytest.raises(ValueError, match="kernel = 'delay-reduced': the delay-reduced kernel "
                       "is of model order 1"):
        mfcontrol.IPD(alpha=1.0, kp=1.0, kd=1.0, sample_time=0.1, estimator="algebraic",
                      window=8, kernel="delay-reduced")
    with pytest.raises(ValueError, match=r"lag = 8.5: must be from 0 to M = 8 samples"):
        mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.1, estimator="algebraic", window=8,
                     kernel="delay-reduced", lag=8.5)
    with pytest.raises(ValueError, match=r"mu = 2: kappa \+ mu must be at most 2 \(here "
                       r"kappa = 1, mu = 2\)"):
        mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.1, estimator="algebraic", window=8,
                     kernel="delay-reduced", mu=2)
    with pytest.raises(ValueError, match="kappa = 1.5: must be a whole number from 0 to 2"):
        mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.1, estimator="algebraic", window=8,
                     kernel="delay-reduced", kappa=1.5)
    with pytest.raises(ValueError, match="kappa = -1: must be a whole number from 0 to 2"):
        mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.1, estimator="algebraic", window=8,
                     kernel="delay-reduced", kappa=-1, mu=0)
    with pytest.raises(ValueError, match="mu = 0: only the delay-reduced kernel has a mu"):
        mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.1, estimator="algebraic", window=8,
                     mu=0)
    with pytest.raises(ValueError, match="lag = 1.0: only the delay-reduced kernel has a lag"):
        mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.1, estimator="algebraic", window=8,
                     lag=1.0)


def _first_order_run(ctrl, n, beta=50.0, h=1e-3, period=500):
    """y' = -y + beta u under the held input, a square-wave setpoint; the alphas used."""
    y, alphas = 0.0, []
    for k in range(n):
        ctrl(y, setpoint=1.0 if (k // period) % 2 == 0 else -1.0)
        alphas.append(1.0 / ctrl.gamma)
        y = y * math.exp(-h) + beta * ctrl.last_output * (1.0 - math.exp(-h))
    return np.array(alphas)


def test_the_rls_gain_is_least_squares_with_its_prior():
    # forgetting 1: the recursion is the batch least-squares fit of y'_k = F + alpha u_{k-1}
    # with the prior (F, alpha) = (0, alpha0), variances RLS_P0_F, RLS_P0_ALPHA (the
    # regression divided by alpha0), to rounding
    from mfcontrol.laws import intelligent as law
    from mfcontrol.laws import variational_gain as vg

    h, a0 = 1e-3, 10.0
    ctrl = mfcontrol.IPI(alpha=a0, kp=20.0, ki=50.0, sample_time=h, gain="rls",
                         forgetting=1.0)
    ys, us = [], []
    y = 0.0
    for k in range(300):
        ys.append(y)
        us.append(ctrl(y, setpoint=1.0 if k < 150 else -1.0))
        y = y * math.exp(-h) + 50.0 * us[-1] * (1.0 - math.exp(-h))
    ys, us = np.array(ys), np.array(us)
    z = (ys[1:] - ys[:-1]) / h / a0  # from sample 1 on, y'_k with u_{k-1}
    phi = np.column_stack([np.ones(z.size), us[:-1]])
    prior = np.diag([1 / vg.RLS_P0_F, 1 / vg.RLS_P0_ALPHA])
    theta = np.linalg.solve(phi.T @ phi + prior, phi.T @ z + prior @ [0.0, 1.0])
    cs = ctrl._CS[:, 0]
    np.testing.assert_allclose([cs[law.RLS_F], cs[law.RLS_A]], theta, rtol=1e-9)
    assert 1.0 / ctrl.gamma == pytest.approx(a0 * theta[1], rel=1e-12)


def test_the_rls_gain_finds_the_plants_gain_and_keeps_its_limits():
    h, beta = 1e-3, 50.0
    # the held input's exact discrete gain of y' = -y + beta u: beta (1 - e^-h) / h
    exact = beta * (1.0 - math.exp(-h)) / h
    alphas = _first_order_run(mfcontrol.IPI(alpha=10.0, kp=20.0, ki=50.0, sample_time=h,
                                            gain="rls"), 3000)
    # F = -y moves with the loop: the forgetting window sees it, within 0.2 %
    assert alphas[-1] == pytest.approx(exact, rel=2e-3)
    assert alphas[0] == 10.0  # the start, before the first derivative
    clipped = _first_order_run(mfcontrol.IPI(alpha=10.0, kp=20.0, ki=50.0, sample_time=h,
                                             gain="rls", alpha_limits=(5.0, 20.0)), 3000)
    assert clipped.max() == 20.0 and clipped.min() >= 5.0


def test_the_rls_gain_does_not_wind_up_at_rest():
    # a constant input excites nothing: the covariance stops at its cap instead of
    # growing by 1/lambda per sample
    from mfcontrol.laws import intelligent as law
    from mfcontrol.laws import variational_gain as vg

    ctrl = mfcontrol.IP(alpha=10.0, kp=5.0, sample_time=1e-3, gain="rls", forgetting=0.9)
    for _ in range(5000):
        ctrl(0.0, setpoint=0.0)
    cs = ctrl._CS[:, 0]
    assert cs[law.RLS_P11] + cs[law.RLS_P22] <= (vg.RLS_P0_F + vg.RLS_P0_ALPHA) / 0.9
    assert 1.0 / ctrl.gamma == 10.0


def test_the_rls_gain_is_refused_where_its_exact_estimate_breaks_the_bound():
    # the backward difference on y' = beta u with alpha = beta needs kp h < 2
    with pytest.raises(ValueError, match=r"gain = 'rls': the exact estimate alpha = beta"):
        mfcontrol.IP(alpha=1.0, kp=300.0, sample_time=0.01, gain="rls")
    mfcontrol.IP(alpha=1.0, kp=150.0, sample_time=0.01, gain="rls")
    with pytest.raises(ValueError, match=r"forgetting = 1.5: must be in \(0, 1\]"):
        mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.01, gain="rls", forgetting=1.5)
    with pytest.raises(ValueError, match=r"alpha_limits = \[2.0, 10.0\]: must be > 0 and at "
                       "most the starting alpha = 1"):
        mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.01, gain="rls", alpha_limits=(2, 10))
    with pytest.raises(ValueError, match="forgetting = 0.9: only the rls gain reads it"):
        mfcontrol.IP(alpha=1.0, kp=1.0, sample_time=0.01, forgetting=0.9)
