"""Alpha of the ultra-local model: estimated from step tests against plants of known gain,
read from plants' linearisations, and the backward-difference i-P's stability bounds
against the spectral radius of the closed loop built here and by the library's own
analysis (:class:`mfcontrol.analysis.loop.LinearLoop`)."""

import dataclasses
import functools
import math
import warnings

import numpy as np
import pytest

import mfcontrol
from mfcontrol.analysis.alpha import (
    AlphaBounds,
    AlphaEstimate,
    backward_difference_bound,
    estimate_alpha,
    open_loop,
    plant_alpha,
)

control = pytest.importorskip("control")

#: sensor noise of one LSB of a 12-bit converter over 2.5 V (the lag's output spans 2 V)
LSB_12BIT = 2.5 / 4096
#: a 16-bit encoder's resolution over the double lag's travel of 0.7 (position, order 2)
LSB_16BIT = 0.7 / 65536


@functools.cache
def first_order_response() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """y' = -2 y + 3 u (alpha = 3) stepped every 1.5 s, sampled at 1 kHz."""
    plant = mfcontrol.FirstOrder(a=-2.0, b=3.0, integrator="exact")
    u = np.repeat([0.0, 1.0, -0.5, 0.5, 0.0], 1500)
    t, y = open_loop(plant, u, 1e-3)
    return t, y, u


def first_order_test(seed: int, sigma: float = LSB_12BIT):
    """The first-order step test with sensor noise of standard deviation sigma."""
    t, y, u = first_order_response()
    return t, y + sigma * np.random.default_rng(seed).standard_normal(y.size), u


@pytest.fixture(scope="module")
def double_lag():
    """y'' = -y' - y/4 + u/2 (a double pole at -1/2, alpha = 1/2), stepped every 2 s."""
    plant = mfcontrol.LTI([[0.0, 1.0], [-0.25, -1.0]], [0.0, 0.5], [1.0, 0.0],
                          integrator="exact")
    u = np.repeat([0.0, 1.0, -1.0, 0.5, 0.0], 2000)
    t, y = open_loop(plant, u, 1e-3)
    return plant, t, y, u


# ---------------------------------------------------------------------------------------
# estimate_alpha


def test_a_noisy_first_order_step_test_gives_b_to_1_percent():
    t, y, u = first_order_test(seed=0)
    est = estimate_alpha(t, y, u)
    assert est.alpha == pytest.approx(3.0, rel=0.01)
    assert est.interval[0] < 3.0 < est.interval[1]
    assert est.stderr < 0.005 * 3.0
    assert (est.order, est.changes, est.confidence) == (1, 4, 0.95)
    # the window is chosen from the plant's own time scale, 1/2 s: 2 x 0.5 x tau
    assert est.window == pytest.approx(0.5, rel=0.1)


def test_a_noisy_second_order_step_test_gives_b_to_1_percent(double_lag):
    _, t, y, u = double_lag
    noisy = y + LSB_16BIT * np.random.default_rng(1).standard_normal(y.size)
    est = estimate_alpha(t, noisy, u, order=2)
    assert est.alpha == pytest.approx(0.5, rel=0.01)
    assert est.interval[0] < 0.5 < est.interval[1]
    assert est.order == 2 and est.changes == 4


def test_a_prbs_gives_b_to_1_percent():
    plant = mfcontrol.FirstOrder(a=-2.0, b=3.0, integrator="exact")
    bits = np.random.default_rng(5).integers(0, 2, 150) * 2.0 - 1.0
    u = np.repeat(bits, 40)  # a bit every 40 ms: overlapping windows
    t, y = open_loop(plant, u, 1e-3)
    y = y + LSB_12BIT * np.random.default_rng(2).standard_normal(y.size)
    est = estimate_alpha(t, y, u)
    assert est.alpha == pytest.approx(3.0, rel=0.01)
    assert est.interval[0] < 3.0 < est.interval[1]
    assert est.changes > 50


@pytest.mark.parametrize("order", [1, 2])
def test_the_held_input_relations_are_exact(order):
    # y^(n) = F(t) + alpha u with F a quadratic in time, integrated exactly under the hold:
    # alpha to rounding, at any window
    h, alpha = 0.01, 1.7
    t = h * np.arange(1200)
    u = np.repeat([0.0, 1.0, -0.5, 0.5], 300)
    held_1 = np.concatenate([[0.0], np.cumsum(h * u[:-1])])  # int u, exact at samples
    if order == 1:
        free = t + t**2 - 0.1 * t**3            # int F, F = 1 + 2 t - 0.3 t^2
        y = free + alpha * held_1
    else:
        held_2 = np.concatenate([[0.0], np.cumsum(h * held_1[:-1] + h * h / 2 * u[:-1])])
        free = 0.3 + 0.2 * t + t**2 / 2 - t**3 / 6 + t**4 / 40  # F = 1 - t + 0.3 t^2
        y = free + alpha * held_2
    for window in (None, 0.2, 2.0):
        est = estimate_alpha(t, y, u, order, window=window)
        assert est.alpha == pytest.approx(alpha, rel=1e-9, abs=0.0)


def test_the_interval_covers_the_truth_and_the_standard_error_is_the_spread():
    runs = [estimate_alpha(*first_order_test(seed, sigma=4 * LSB_12BIT)) for seed in range(40)]
    alphas = np.array([r.alpha for r in runs])
    covered = sum(r.interval[0] < 3.0 < r.interval[1] for r in runs)
    assert covered >= 34  # 95 % nominal; P(fewer than 34 of 40) < 2 %
    ratio = np.mean([r.stderr for r in runs]) / alphas.std()
    assert 0.7 < ratio < 1.4


def test_the_interval_is_students_t_at_the_level_asked():
    t, y, u = first_order_test(seed=3)
    wide, narrow = estimate_alpha(t, y, u, confidence=0.99), estimate_alpha(t, y, u,
                                                                          confidence=0.5)
    assert wide.alpha == narrow.alpha
    # many degrees of freedom: the normal quantiles 2.576 and 0.674
    assert (wide.interval[1] - wide.alpha) / wide.stderr == pytest.approx(2.576, rel=1e-3)
    assert (narrow.interval[1] - narrow.alpha) / narrow.stderr == pytest.approx(0.674,
                                                                                rel=1e-3)


def test_a_plant_whose_output_does_not_jump_is_warned_about():
    t = 0.01 * np.arange(400)
    u = np.repeat([0.0, 1.0], 200)
    y = np.random.default_rng(0).standard_normal(t.size)  # noise alone: no alpha
    with pytest.warns(RuntimeWarning, match="within two standard errors"):
        estimate_alpha(t, y, u)


def test_the_estimate_reads_well_and_is_frozen():
    t, y, u = first_order_test(seed=0)
    est = estimate_alpha(t, y, u)
    text = repr(est)
    assert text.startswith("AlphaEstimate(alpha=3.0") and "interval=(" in text
    assert eval(text, {"AlphaEstimate": AlphaEstimate}).alpha == pytest.approx(est.alpha,
                                                                               rel=1e-5)
    assert str(est).startswith("alpha = 3.0") and "95% interval" in str(est)
    with pytest.raises(dataclasses.FrozenInstanceError):
        est.alpha = 1.0  # type: ignore[misc]


T = 0.01 * np.arange(100)
STEP = np.repeat([0.0, 1.0], 50)


@pytest.mark.parametrize("args, kwargs, message", [
    ((T, T, STEP), {"order": 3}, "order = 3: must be 1 or 2"),
    ((T, T, STEP), {"order": 1.0}, "order = 1.0: must be 1 or 2"),
    ((T, T, STEP), {"order": True}, "order = True: must be 1 or 2"),
    ((T, T[:-1], STEP), {}, "y.shape = (99,): must equal t.shape = (100,)"),
    ((T, T, STEP[:-1]), {}, "u.shape = (99,): must equal t.shape = (100,)"),
    ((T, np.where(T > 0.5, np.nan, T), STEP), {}, "y[51] = nan: must be finite"),
    ((np.where(T > 0.5, np.inf, T), T, STEP), {}, "t[51] = inf: must be finite"),
    ((T, "y", STEP), {}, "y = 'y': must be a 1-D array of real numbers"),
    ((T, T + 1j, STEP), {}, "y = array([0.  +1.j, 0.01+1.j"),
    ((T.reshape(10, 10), T, STEP), {}, "t.shape = (10, 10): must be one-dimensional"),
    ((T[::-1], T, STEP), {}, "t[-1] = 0.0: must be later than t[0] = 0.99"),
    ((np.where(T > 0.5, T + 0.002, T), T, STEP), {}, "t[50] = 0.5: must be uniformly"),
    ((T, T, np.ones(100)), {}, "u = 1.0 at every sample: must change at least once"),
    ((T, T, np.repeat([0.0, 1.0], [3, 97])), {}, "u = changes at t = 0.03: must have 6 "
                                                 "samples on each side"),
    ((T[:9], T[:9], STEP[:9]), {}, "t.shape = (9,): must hold at least 13 samples"),
    ((T, T, STEP), {"window": 0.05}, "window = 0.05: must span at least 12 samples"),
    ((T, T, STEP), {"window": -1.0}, "window = -1.0: must be a finite number > 0"),
    ((T, T, STEP), {"window": math.nan}, "window = nan: must be a finite number > 0"),
    ((T, T, STEP), {"degree": 5}, "degree = 5: must be a whole number from 0 to 4"),
    ((T, T, STEP), {"confidence": 1.0}, "confidence = 1.0: must be between 0 and 1"),
    ((T, T, STEP), {"confidence": "95%"}, "confidence = '95%': must be a finite number"),
])
def test_every_bad_input_is_refused_on_one_line_naming_it(args, kwargs, message):
    with pytest.raises(ValueError) as info:
        estimate_alpha(*args, **kwargs)
    text = str(info.value)
    assert text.startswith(message) and "\n" not in text


# ---------------------------------------------------------------------------------------
# plant_alpha and open_loop


def test_the_plant_route_gives_the_known_gains():
    assert plant_alpha(mfcontrol.FirstOrder(a=-2.0, b=3.0)) == pytest.approx(3.0, rel=1e-9)
    # relative degree 1 and 2 of the same realisation: C B and C A B
    A = [[0.0, 1.0], [-0.25, -1.0]]
    assert plant_alpha(mfcontrol.LTI(A, [0.0, 0.5], [1.0, 0.0]), order=2) == \
        pytest.approx(0.5, rel=1e-9)
    assert plant_alpha(mfcontrol.LTI(A, [1.0, 0.5], [1.0, 0.0])) == pytest.approx(1.0)
    # python-control systems, read from their own matrices
    assert plant_alpha(control.tf([3.0], [1.0, 2.0])) == pytest.approx(3.0, rel=1e-12)
    assert plant_alpha(control.tf([0.5], [1.0, 1.0, 0.25]), order=2) == \
        pytest.approx(0.5, rel=1e-12)
    # the motor's speed through its current: Km / (J La); the buck's voltage: E / (L C)
    assert plant_alpha(mfcontrol.DCMotor(), order=2) == pytest.approx(0.05 / (5e-4 * 2e-3),
                                                                     rel=1e-7)
    assert plant_alpha(mfcontrol.Buck(E=20.0), order=2) == pytest.approx(20.0 / 1e-3 / 1e-5,
                                                                        rel=1e-7)
    # the published coupling puts E d / L into v' itself: relative degree 1
    assert plant_alpha(mfcontrol.Buck(E=20.0, coupling="published")) == \
        pytest.approx(20.0 / 1e-3, rel=1e-7)


def test_a_nonlinear_plants_alpha_is_taken_at_its_operating_point():
    # the buck's power v i: d acts through L i' = E d - v, so alpha = v E / L at rest
    buck = mfcontrol.Buck(E=20.0, output="power")
    assert plant_alpha(buck, y=10.0) == pytest.approx(math.sqrt(10.0 * 10.0) * 20.0 / 1e-3,
                                                      rel=1e-6)
    assert plant_alpha(buck, x=[1.0, 10.0], u=0.5) == pytest.approx(10.0 * 20.0 / 1e-3,
                                                                    rel=1e-6)
    with pytest.raises(ValueError, match=r"^x = array\(\[0., 0.\]\): is an operating point "
                                         "where u does not reach y"):
        plant_alpha(buck)


@pytest.mark.parametrize("plant, order, message", [
    (mfcontrol.DCMotor(), 1, "order = 1: must be 2, the plant's relative degree at x = "
                             "[0. 0.], u = 0 (C B = 0, C A B = 50000): y' does not jump"),
    (mfcontrol.FirstOrder(a=-1.0, b=2.0), 2, "order = 2: must be 1, the plant's relative "
                                             "degree at x = [0.], u = 0 (C B = 2, C A B = "
                                             "-2): y' jumps with u"),
    (control.tf([3.0], [1.0, 2.0, 1.0, 1.0]), 2, "order = 2: cannot fit: the plant's "
                                                 "relative degree is 3"),
    (control.tf([1.0, 1.0], [1.0, 2.0]), 1, "plant.D = 1.0: must be 0"),
    (control.tf([1.0], [1.0, 2.0], 0.1), 1, "plant.dt = 0.1: must be 0"),
    (mfcontrol.FirstOrder(a=-1.0, b=2.0), 0, "order = 0: must be 1 or 2"),
])
def test_a_relative_degree_other_than_the_order_is_refused(plant, order, message):
    with pytest.raises(ValueError) as info:
        plant_alpha(plant, order)
    assert str(info.value).startswith(message) and "\n" not in str(info.value)


def test_plant_alpha_refuses_bad_operating_points():
    lag = mfcontrol.FirstOrder(a=-1.0, b=2.0)
    with pytest.raises(ValueError, match=r"^x.shape = \(2,\): must be the plant's state"):
        plant_alpha(lag, x=[0.0, 1.0])
    with pytest.raises(ValueError, match=r"^u = nan: must be a finite number"):
        plant_alpha(lag, u=math.nan)
    with pytest.raises(TypeError, match="plant must be a mfcontrol plant"):
        plant_alpha("lag")


@pytest.mark.parametrize("order", [1, 2])
def test_the_plant_and_data_routes_agree(order, double_lag):
    if order == 1:
        plant = mfcontrol.FirstOrder(a=-2.0, b=3.0, integrator="exact")
        u = np.repeat([0.0, 1.0, -0.5, 0.5], 1000)
        t, y = open_loop(plant, u, 1e-3)
    else:
        plant, t, y, u = double_lag
    assert estimate_alpha(t, y, u, order).alpha == pytest.approx(plant_alpha(plant, order),
                                                                 rel=1e-3)


def test_open_loop_measures_before_the_input_acts_and_refuses_a_blow_up():
    plant = mfcontrol.FirstOrder(a=-1.0, b=1.0, integrator="exact")
    t, y = open_loop(plant, [1.0, 1.0, 1.0], 0.5, t0=2.0)
    np.testing.assert_allclose(t, [2.0, 2.5, 3.0])
    np.testing.assert_allclose(y, [0.0, 1 - math.exp(-0.5), 1 - math.exp(-1.0)], rtol=1e-12)
    with pytest.raises(ValueError, match=r"^dt = 0.0: must be a finite number > 0"):
        open_loop(plant, [1.0], 0.0)
    with pytest.raises(FloatingPointError, match="not finite"):
        open_loop(mfcontrol.FirstOrder(a=700.0, b=1.0, integrator="exact"), np.ones(5), 1.0)


# ---------------------------------------------------------------------------------------
# backward_difference_bound


def closed_loop(alpha, beta, kp, h, order, kernel="trapezoid", kd=0.0):
    """The i-P (i-PD) with backward differences on y^(n) = beta u under a zero-order
    hold, r = 0, as the matrix of its state update, written from the difference equations
    (not from the characteristic polynomial the bound is derived from)."""
    if order == 1:
        # state (y_k, y_{k-1}, u_{k-1}); u_k = u_{k-1} - ((1 + kd) y'_k + kp y_k) / alpha
        u_row = np.array([-((1 + kd) / h + kp) / alpha, (1 + kd) / (h * alpha), 1.0])
        M = np.zeros((3, 3))
        M[0] = np.array([1.0, 0.0, 0.0]) + beta * h * u_row
        M[1, 0] = 1.0
        M[2] = u_row
        return M
    # state (y, y', y_{k-1}, y_{k-2}, u_{k-1}, u_{k-2})
    w1, w2 = (1.0, 0.0) if kernel == "trapezoid" else (0.5, 0.5)
    u_row = np.array([-(1 / h**2 + kd / h + kp) / alpha, 0.0, (2 / h**2 + kd / h) / alpha,
                      -1 / (h**2 * alpha), w1, w2])
    M = np.zeros((6, 6))
    M[0] = np.array([1.0, h, 0, 0, 0, 0]) + beta * h * h / 2 * u_row
    M[1] = np.array([0.0, 1.0, 0, 0, 0, 0]) + beta * h * u_row
    M[2, 0] = M[3, 2] = M[5, 4] = 1.0
    M[4] = u_row
    return M


def radius(*args, **kw) -> float:
    return float(np.abs(np.linalg.eigvals(closed_loop(*args, **kw))).max())


def crossing(near, *args, **kw):
    """The alpha where the spectral radius crosses 1, by bisection in +-10 % of near."""
    lo, hi = 0.9 * near, 1.1 * near
    f_lo = radius(lo, *args, **kw) - 1
    assert f_lo * (radius(hi, *args, **kw) - 1) < 0
    while hi - lo > 1e-9 * near:
        mid = 0.5 * (lo + hi)
        if (radius(mid, *args, **kw) - 1) * f_lo > 0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("kp, kd, h", [(10.0, 0.0, 1e-3), (5.0, 0.5, 0.01), (50.0, 0.0, 0.02)])
def test_order_1_bound_is_the_closed_form_and_the_crossing(kp, kd, h):
    beta = 100.0
    bound = backward_difference_bound(beta, kp, h, kd=kd)
    assert isinstance(bound, AlphaBounds) and bound.upper == math.inf
    assert bound.lower == pytest.approx(beta * (2 * (1 + kd) + kp * h) / 4, rel=1e-14)
    assert crossing(bound.lower, beta, kp, h, 1, kd=kd) == pytest.approx(bound.lower,
                                                                         rel=1e-6)
    # stable far above: the bound is the only one
    assert radius(100 * bound.lower, beta, kp, h, 1, kd=kd) < 1


@pytest.mark.parametrize("kernel", ["trapezoid", "held"])
@pytest.mark.parametrize("kp, kd, h", [(25.0, 10.0, 0.01), (100.0, 5.0, 0.01),
                                       (1.0, 0.0, 0.1), (400.0, 30.0, 0.005)])
def test_order_2_bounds_are_the_spectral_radius_crossings(kernel, kp, kd, h):
    beta = 2.0
    bound = backward_difference_bound(beta, kp, h, 2, kd=kd, kernel=kernel)
    assert bound is not None
    for edge in bound:
        assert crossing(edge, beta, kp, h, 2, kernel, kd) == pytest.approx(edge, rel=1e-6)
    # stable between, unstable outside
    inside = math.sqrt(bound.lower * bound.upper)
    assert radius(inside, beta, kp, h, 2, kernel, kd) < 1
    assert radius(0.5 * bound.lower, beta, kp, h, 2, kernel, kd) > 1
    assert radius(2.0 * bound.upper, beta, kp, h, 2, kernel, kd) > 1


@pytest.mark.parametrize("kernel", ["held", "trapezoid"])
def test_the_bounds_are_the_librarys_own_laws(kernel):
    from mfcontrol.analysis.loop import LinearLoop

    beta, kp, kd, h = 2.0, 25.0, 10.0, 0.01
    bound = backward_difference_bound(beta, kp, h, 2, kd=kd, kernel=kernel)
    double = mfcontrol.LTI([[0.0, 1.0], [0.0, 0.0]], [0.0, beta], [1.0, 0.0])
    for edge, below_is_stable in ((bound.lower, False), (bound.upper, True)):
        for factor, stable in ((1 - 1e-6, below_is_stable), (1 + 1e-6, not below_is_stable)):
            law = mfcontrol.IPD(alpha=edge * factor, kp=kp, kd=kd, sample_time=h,
                                kernel=kernel)
            assert (LinearLoop(law.linear_filter(), double).spectral_radius() < 1) == stable
    # order 1, with and without a derivative term
    integrator = mfcontrol.LTI([[0.0]], [beta], [1.0])
    for kd in (0.0, 0.5):
        lower = backward_difference_bound(beta, kp, h, kd=kd).lower
        for factor, stable in ((1 - 1e-6, False), (1 + 1e-6, True)):
            law = mfcontrol.IPD(alpha=lower * factor, kp=kp, kd=kd, sample_time=h, order=1)
            assert (LinearLoop(law.linear_filter(), integrator).spectral_radius() < 1) == stable


def test_order_2_bounds_tend_to_their_limits_as_kp_vanishes():
    for b in (0.0, 0.1, 0.5):  # kd h
        trapezoid = backward_difference_bound(1.0, 1e-8, 1.0, 2, kd=b, kernel="trapezoid")
        held = backward_difference_bound(1.0, 1e-8, 1.0, 2, kd=b, kernel="held")
        assert trapezoid.lower == pytest.approx((2 + b) / (2 * (2 - b)), rel=1e-6)
        assert held.lower == pytest.approx((2 + b) / (6 - b), rel=1e-6)
    # the i-P: beta/2 to beta with the library's estimator, beta/3 to 2 beta/3 held
    trapezoid = backward_difference_bound(1.0, 1e-8, 1.0, 2, kernel="trapezoid")
    held = backward_difference_bound(1.0, 1e-8, 1.0, 2, kernel="held")
    assert trapezoid.upper == pytest.approx(1.0, rel=1e-3)
    assert held.upper == pytest.approx(2 / 3, rel=1e-3)
    # with kd the upper bound grows like beta kd / (kp h)
    assert backward_difference_bound(1.0, 1e-4, 1.0, 2, kd=0.01, kernel="trapezoid").upper == \
        pytest.approx(100.0, rel=0.05)


def test_gains_too_large_for_the_sample_period_have_no_stable_alpha():
    kp, kd, h = 0.25, 1.0, 1.0
    assert backward_difference_bound(1.0, kp, h, 2, kd=kd, kernel="trapezoid") is None
    alphas = np.geomspace(0.01, 100.0, 400)
    assert min(radius(a, 1.0, kp, h, 2, "trapezoid", kd) for a in alphas) > 1
    # the held estimator still has a range there
    assert backward_difference_bound(1.0, kp, h, 2, kd=kd, kernel="held") is not None


def test_order_1_has_one_estimator():
    assert backward_difference_bound(1.0, 5.0, 0.01, kernel="held") == \
        backward_difference_bound(1.0, 5.0, 0.01, kernel="trapezoid")


@pytest.mark.parametrize("kwargs, message", [
    ({"beta": -1.0}, "beta = -1.0: must be a finite number > 0"),
    ({"beta": 0.0}, "beta = 0.0: must be a finite number > 0"),
    ({"kp": 0.0}, "kp = 0.0: must be a finite number > 0"),
    ({"kp": math.inf}, "kp = inf: must be a finite number > 0"),
    ({"dt": -0.1}, "dt = -0.1: must be a finite number > 0"),
    ({"order": 3}, "order = 3: must be 1 or 2"),
    ({"kd": -1.0}, "kd = -1.0: must be a finite number >= 0"),
    ({"kernel": "euler"}, "kernel = 'euler': must be one of trapezoid, held"),
])
def test_the_bound_refuses_bad_inputs_naming_them(kwargs, message):
    args = {"beta": 1.0, "kp": 1.0, "dt": 0.01} | kwargs
    with pytest.raises(ValueError) as info:
        backward_difference_bound(**args)
    assert str(info.value).startswith(message) and "\n" not in str(info.value)


def test_no_warning_on_a_clean_estimate():
    t, y, u = first_order_test(seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        estimate_alpha(t, y, u)


def test_a_run_warns_when_alpha_breaks_the_backward_difference_bound(tmp_path, capsys):
    import warnings

    from mfcontrol.analysis.alpha import alpha_warning
    from mfcontrol.cli import main

    plant = mfcontrol.FirstOrder(a=-1.0, b=100.0)
    low = mfcontrol.IP(alpha=40.0, kp=10.0, sample_time=1e-3)  # the bound: 50.25
    assert "alpha > 50.25" in alpha_warning(low, plant)
    with pytest.warns(RuntimeWarning, match=r"alpha = 40 is outside .* alpha > 50\.25"):
        mfcontrol.simulate_loop(plant, low, 1.0, t_end=0.05)
    # none where the bound holds, or does not apply: the full algebraic window from the
    # start (startup = "hold"), a variational gain, a plant of relative degree 2
    for ctrl, p in ((mfcontrol.IP(alpha=60.0, kp=10.0, sample_time=1e-3), plant),
                    (mfcontrol.IP(alpha=40.0, kp=10.0, sample_time=1e-3,
                                  estimator="algebraic", window=20), plant),
                    (mfcontrol.IP(alpha=40.0, kp=10.0, sample_time=1e-3, gain="variational",
                                  gamma0=1 / 40.0), plant),
                    (low, mfcontrol.DCMotor())):
        assert alpha_warning(ctrl, p) is None
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            mfcontrol.simulate_loop(p, ctrl, 1.0, t_end=0.01)
    # the command line: one line, and the run goes ahead
    code = main(["run", "first-order-ip-algebraic", "--set", "controller.alpha=0.1",
                 "--set", "controller.startup=backward-difference", "--set", "sim.t_end=0.1",
                 "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 0
    lines = [line for line in err.splitlines() if "warning" in line]
    assert len(lines) == 1 and lines[0].startswith("mfcontrol: warning: alpha = 0.1 is ")


def test_a_plant_beyond_floating_point_is_refused_and_never_warns_about_alpha():
    # found by the fuzz test: a motor of inductance 5e-324 H linearised to NaN, and the
    # alpha check raised "beta = nan" from a run
    import warnings

    from mfcontrol.analysis.alpha import alpha_warning

    motor = mfcontrol.DCMotor(La=5e-324)
    with pytest.raises(mfcontrol.ConfigError, match="^plant = a DCMotor: must have (a )?finite"):
        plant_alpha(motor, 1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert alpha_warning(mfcontrol.IPI(alpha=50.0, kp=20.0, ki=50.0, sample_time=1e-3),
                             motor) is None
