"""The sliding-window algebraic estimator of F, checked against facts.

* its O(1) sliding moments give the direct FIR sum of the integral (``weights``), for
  every kernel (the delay-reduced one for every Jacobi weight it takes, whose weights are
  also numpy's weighted least-squares line);
* the held kernel returns F to rounding under any held input; the trapezoid kernel's
  error is its closed form;
* it recovers a known F from signals that obey the ultra-local model, at t - T/2;
* for F constant or linear in t it is exact up to the quadrature rule's error, which for
  polynomial signals is known in closed form (Euler-Maclaurin);
* the per-sample work does not depend on M (structurally, not by timing).
"""

import itertools
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numpy.lib.stride_tricks import sliding_window_view
from numpy.polynomial import Polynomial

from mfcontrol.laws import estimators as est

U_BEFORE = 123.0  # u_{-1}, pushed with y_0: never inside a full window, must not leak

MOMENT_ROWS = range(est.Y_MOM, est.RING)

# Rounding tolerance of the moment form against the direct sum, relative to the size of
# the summed terms sum |w_i x_i| (the estimate itself can cancel to ~0, so it cannot be
# the reference). Both forms round a few ulps per term; the moments add the binomial
# shifts (factors <= 6) over the < M slides since the last resync, each error weighing at
# most ~64x a window weight (a phantom sample at most 1.5 M outside the window, U_4 of
# n = 2). M = 64 gives a bound of order 64 * 64 * 10 ulps ~ 1e-11; what is seen is ~1e-15.
RTOL_SCALE = 1e-10


def make_state(M, base=0, members=1):
    CS = np.full((base + est.n_state(M), members), np.nan)  # reset must clear every row
    for j in range(members):
        est.reset(CS, j, base, M)
    return CS


#: no delay-reduced coefficients (the other kernels read none)
NO_JACOBI = np.zeros((est.N_JACOBI, 1))


def jacobi(M, kappa=1, mu=1, lag=0.0):
    """The delay-reduced kernel's coefficients in a law's parameter rows (from
    est.JACOBI; the rows before it NaN: the kernel must not read them)."""
    CP = np.full((est.JACOBI + est.N_JACOBI, 1), np.nan)
    CP[est.JACOBI:, 0] = est.jacobi_rows(M, kappa, mu, lag)
    return CP


def run(order, M, h, alpha, y, u, base=0, kernel="trapezoid", lag=0.0, kappa=1, mu=1):
    """Push y_k, u_{k-1} one by one; return the estimates (NaN while the window fills)."""
    CS = make_state(M, base)
    f = np.empty(y.size)
    code = est.KERNELS[kernel]
    CP = jacobi(M, kappa, mu, lag) if kernel == "delay-reduced" else NO_JACOBI
    for k in range(y.size):
        est.push(CS, 0, base, M, y[k], u[k - 1] if k else U_BEFORE,
                 est.moment_order(float(order), code))
        f[k] = est.estimate(CS, 0, base, M, h, alpha, order, code, CP)
    return f


def direct(order, M, h, alpha, y, u, kernel="trapezoid", lag=None, kappa=None, mu=None):
    """The FIR form over every full window (k = M .. N-1), and the size of its terms."""
    wy, wu = est.weights(order, M, h, alpha, kernel, lag, kappa, mu)
    Y = sliding_window_view(y, M + 1)
    U = sliding_window_view(u[:-1], M)
    return Y @ wy + U @ wu, np.abs(Y * wy).sum(1) + np.abs(U * wu).sum(1)


def check_equals_direct(order, M, h, alpha, y, u, kernel="trapezoid"):
    f = run(order, M, h, alpha, y, u, base=3, kernel=kernel)
    assert np.isnan(f[:M]).all()
    d, scale = direct(order, M, h, alpha, y, u, kernel)
    assert np.isfinite(f[M:]).all()
    # A sliding sum keeps the rounding of every sample that passed through it until the
    # next resync (at most M samples later), including samples whose FIR weight is zero
    # (u at s = 0): 1.0 there absorbs a 1e-94 beside it (found by hypothesis). So the error
    # is relative to the largest samples since then, times the weights' sizes.
    wy, wu = est.weights(order, M, h, alpha, kernel)
    ay, au = np.abs(y), np.abs(u)
    # run() pushes U_BEFORE as u_{-1} with y_0: it passes through the sums too
    au = np.concatenate([[abs(U_BEFORE)], au])  # au[k] is now |u_{k-1}|
    since_resync = np.array([
        ay[max(0, k - 2 * M - 1): k + 1].max() * np.abs(wy).sum()
        + au[max(0, k - 2 * M - 1): k + 2].max() * np.abs(wu).sum()
        for k in range(M, y.size)])
    since_resync = np.maximum(since_resync, scale)
    np.testing.assert_array_less(np.abs(f[M:] - d), RTOL_SCALE * since_resync + 1e-300)


# --- 1. the sliding moments are the direct sum ------------------------------------------------

WINDOWS = [(1, 2), (1, 3), (1, 4), (1, 7), (1, 64), (2, 2), (2, 4), (2, 10), (2, 64)]
#: (order, M, kernel): the held kernel takes any M at order 2
CASES = ([(n, M, "trapezoid") for n, M in WINDOWS]
         + [(n, M, "held") for n, M in WINDOWS + [(2, 3), (2, 7)]])
moderate = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)


@st.composite
def short_runs(draw):
    order, M, kernel = draw(st.sampled_from(CASES))
    n = M + 1 + draw(st.integers(0, 3 * M))
    # fill=nothing(): every sample drawn on its own, no repeated background value
    y = draw(arrays(np.float64, n, elements=moderate, fill=st.nothing()))
    u = draw(arrays(np.float64, n, elements=moderate, fill=st.nothing()))
    h = draw(st.sampled_from([1e-4, 1e-3, 0.1, 1.0]))
    alpha = draw(st.floats(-100.0, 100.0))
    return order, M, h, alpha, y, u, kernel


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(short_runs())
def test_moments_equal_direct_sum(case):
    check_equals_direct(*case)


@pytest.mark.parametrize("order,M,kernel", CASES)
@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), offset=moderate, y_amp=st.floats(1e-3, 1e3),
       u_amp=st.floats(1e-3, 1e3), alpha=st.floats(-100.0, 100.0))
def test_long_runs_stay_equal_to_direct_sum(order, M, kernel, seed, offset, y_amp, u_amp,
                                            alpha):
    # 20 M samples: 20 resyncs, and drift would have grown between them
    rng = np.random.default_rng(seed)
    n = 20 * M + M // 2 + 1
    y = offset + y_amp * rng.standard_normal(n)
    u = u_amp * rng.uniform(-1.0, 1.0, n)
    check_equals_direct(order, M, 1e-3, alpha, y, u, kernel)


def test_a_non_finite_sample_is_forgotten_at_the_next_resync_after_it_leaves():
    order, M, h, alpha = 2, 8, 1e-3, 2.0
    rng = np.random.default_rng(1)
    y, u = rng.standard_normal(200), rng.standard_normal(200)
    m = 37
    y[m] = np.nan
    f = run(order, M, h, alpha, y, u)
    d, _ = direct(order, M, h, alpha, y, u)
    k_left = m + M + 1  # first window without it
    k_sync = math.ceil((k_left + 1) / M) * M - 1  # first resync at or after it, as a sample
    assert k_sync - m <= 2 * M
    assert np.isnan(f[m:k_sync]).all()
    np.testing.assert_allclose(f[k_sync:], d[k_sync - M:], rtol=1e-12, atol=1e-9)


def test_invalid_windows():
    with pytest.raises(ValueError, match="even"):
        est.weights(2, 5, 1e-3, 1.0, "trapezoid")
    with pytest.raises(ValueError, match="kernel = 'simpson'"):
        est.check_window(1, 4, "simpson")
    est.check_window(2, 5, "held")  # the held kernel has no Simpson pattern
    for order, M in ((3, 4), (1, 1), (1, 4.0), (2, 0)):
        with pytest.raises(ValueError):
            est.check_window(order, M)
    # compiled code cannot raise: an odd Simpson window gives NaN
    rng = np.random.default_rng(0)
    assert np.isnan(run(2, 5, 1e-3, 1.0, rng.random(20), rng.random(20))).all()


# --- 2. a known F is recovered at t - T/2 --------------------------------------------------


@pytest.mark.parametrize("order,M", [(1, 100), (2, 20), (2, 100)])
def test_recovers_known_F_at_the_window_centre(order, M):
    h, alpha = 1e-3, 3.0
    T = M * h
    t = h * np.arange(3000)
    w1, w2, w3 = 0.9, 1.7, 1.3  # rad/s: omega T <= 0.17, F smooth over the window

    def yd(t, d):
        return (w1**d * np.sin(w1 * t + 0.3 + d * np.pi / 2)
                + 0.5 * w2**d * np.cos(w2 * t + d * np.pi / 2))

    def u_of(t):
        return 0.2 * np.sin(w3 * t) + 0.1

    def F(t):  # y^(n) = F + alpha u
        return yd(t, order) - alpha * u_of(t)

    f = run(order, M, h, alpha, yd(t, 0), u_of(t))
    k = np.arange(M, t.size)
    amp = np.abs(F(t)).max()
    err = np.abs(f[k] - F(t[k] - T / 2))
    assert err.max() < 1e-3 * amp
    # and the delay is real: the value at t itself is measurably worse
    assert np.abs(f[k] - F(t[k])).max() > 5 * err.max()


# --- 3. exact for F constant or linear, up to the quadrature rule's own error ---------------

BERNOULLI = {2: 1 / 6, 4: -1 / 30, 6: 1 / 42, 8: -1 / 30, 10: 5 / 66}


def trapezoid_error(p, T, h):
    """Trapezoid(h) minus the integral over [0, T] of a polynomial of degree <= 10.

    Euler-Maclaurin, whose remainder vanishes for such a polynomial.
    """
    assert p.degree() <= 10
    return sum(b * h**m / math.factorial(m) * (p.deriv(m - 1)(T) - p.deriv(m - 1)(0))
               for m, b in BERNOULLI.items())


def simpson_error(p, T, h):
    # composite Simpson on step h is Richardson's (4 trap(h) - trap(2h)) / 3
    return (4.0 * trapezoid_error(p, T, h) - trapezoid_error(p, T, 2.0 * h)) / 3.0


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("M", [2, 4, 10, 40])
@pytest.mark.parametrize("f1", [0.0, -7.0], ids=["F-constant", "F-linear"])
@pytest.mark.parametrize("u_coef", [(), (0.4, -2.0, 30.0)], ids=["u-zero", "u-quadratic"])
def test_exact_for_constant_and_linear_F_up_to_the_rule_error(order, M, f1, u_coef):
    h, alpha = 1e-3, 1.5
    T = M * h
    F = Polynomial([2.5, f1])
    u = Polynomial(u_coef or [0.0])
    y = (F + alpha * u).integ(order, k=[0.3, -1.1][:order])  # y^(n) = F + alpha u, exactly
    t = h * np.arange(3 * M + 1)
    f = run(order, M, h, alpha, y(t), u(t))
    _, scale = direct(order, M, h, alpha, y(t), u(t))
    s = Polynomial([0.0, 1.0])
    for k in range(M, t.size):
        local = Polynomial([t[k] - T, 1.0])  # s -> t - T + s
        if order == 1:
            integrand = (T - 2 * s) * y(local) + alpha * s * (T - s) * u(local)
            rule_part = -6.0 / T**3 * trapezoid_error(integrand, T, h)
        else:
            integrand = ((T**2 - 6 * T * s + 6 * s**2) * y(local)
                         - alpha / 2 * s**2 * (T - s) ** 2 * u(local))
            rule_part = 60.0 / T**5 * simpson_error(integrand, T, h)
        # the integral itself is F(t - T/2) exactly; only the rule's error is added.
        # Rounding: relative to the summed terms, as in RTOL_SCALE (n = 2 and a short window
        # amplify it, ~60 |y| / T^2); ~4e-15 of them is seen.
        err = abs(f[k] - (F(t[k] - T / 2) + rule_part))
        assert err <= 1e-12 * scale[k - M]


@pytest.mark.parametrize("order,bias", [(1, lambda M: 2 / M**2), (2, lambda M: 24 / M**4)])
def test_constant_F_without_input_bias_closed_form(order, bias):
    # the docstring's statement: F (1 + 2/M^2) for n = 1, F (1 + 24/M^4) for n = 2
    h = 1e-3
    for M in (2, 4, 6, 50):
        t = h * np.arange(2 * M)
        y = 0.7 + 4.0 * t**order / math.factorial(order)  # F = 4, u = 0
        f = run(order, M, h, 9.0, y, np.zeros_like(t))
        np.testing.assert_allclose(f[M:], 4.0 * (1 + bias(M)), rtol=1e-9)


# --- 3b. the held kernel is exact under a held input; the trapezoid's error, closed form ------


def held_input_run(order, M, h, F, alpha, u, y0=0.4, v0=-1.3):
    """Exact samples of y^(n) = F + alpha u under the held input u (u_j over
    [t_j, t_{j+1})), from y_0 = y0 (and y'_0 = v0 for n = 2)."""
    y = np.empty(u.size + 1)
    y[0], v = y0, v0
    for j, uj in enumerate(u):
        a = F + alpha * uj
        if order == 1:
            y[j + 1] = y[j] + h * a
        else:
            y[j + 1] = y[j] + h * v + 0.5 * a * h * h
            v += a * h
    return y


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("M", [2, 3, 4, 9, 20, 64])
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), F=st.floats(-50.0, 50.0), alpha=st.floats(-20.0, 20.0),
       h=st.sampled_from([1e-5, 1e-3, 0.1]))
def test_the_held_kernel_returns_F_under_any_held_input(order, M, seed, F, alpha, h):
    u = np.random.default_rng(seed).uniform(-1.0, 1.0, 3 * M + 5)
    y = held_input_run(order, M, h, F, alpha, u)
    f = run(order, M, h, alpha, y, np.append(u, 0.0), kernel="held")
    # relative to the largest term: |alpha u| and F (y's size enters through rounding of
    # the differences, ~ |y| eps / h^n per term)
    scale = abs(F) + abs(alpha) + np.abs(y).max() * 1e3 * (1.0 if order == 1 else 1.0 / h)
    assert np.abs(f[M:] - F).max() <= 1e-10 * max(scale, 1.0)


@pytest.mark.parametrize("M", [2, 4, 5, 20])
@pytest.mark.parametrize("F,alpha,u", [(3.0, 2.0, 0.0), (3.0, 2.0, 1.0), (-1.0, 0.5, -4.0)])
def test_trapezoid_error_under_a_constant_input_closed_form(M, F, alpha, u):
    # F_hat = F + (2 F + 3 alpha u) / M^2: the y part gains 1 + 2/M^2, the u part's
    # trapezoid sum of s (T - s) is T^3/6 (1 - 1/M^2)
    h = 1e-3
    y = held_input_run(1, M, h, F, alpha, np.full(2 * M, u))
    f = run(1, M, h, alpha, y, np.full(y.size, u))
    np.testing.assert_allclose(f[M:], F + (2.0 * F + 3.0 * alpha * u) / M**2, rtol=1e-10,
                               atol=1e-10)
    g = run(1, M, h, alpha, y, np.full(y.size, u), kernel="held")
    np.testing.assert_allclose(g[M:], F, rtol=1e-10, atol=1e-10)


def test_trapezoid_error_under_a_moving_input_is_the_issues_measurement():
    # y' = 3 + 2 u, u = +-1 at random: the trapezoid's error is about 0.8 alpha |du| / M,
    # 1.125 at most at M = 4 (a window whose u alternates); the held kernel's is rounding
    # (an independent implementation's figure); its worst case over all 16 patterns of a
    # window of 4
    h, F, alpha = 0.01, 3.0, 2.0
    worst = held_worst = 0.0
    for pattern in itertools.product([-1.0, 1.0], repeat=4):
        u = np.array(pattern * 2)
        y = held_input_run(1, 4, h, F, alpha, u)
        worst = max(worst, np.abs(run(1, 4, h, alpha, y, np.append(u, 0.0))[4:] - F).max())
        held = run(1, 4, h, alpha, y, np.append(u, 0.0), kernel="held")
        held_worst = max(held_worst, np.abs(held[4:] - F).max())
    assert worst == pytest.approx(1.125, rel=1e-9)
    assert held_worst < 1e-12


# --- 4. the per-sample work does not grow with M ----------------------------------------------
# Not timed: timings are noisy and would test the machine. The O(M) part of push is the
# resync; everything else is a fixed number of row updates. We check (a) that a push writes
# a fixed set of rows whatever M (the moments, the counter and one ring slot for y and u)
# and (b) that the moments are carried from sample to sample, the recomputation from the
# ring happening only when the counter reaches a multiple of M.


@pytest.mark.parametrize("order", est.ORDERS)
@pytest.mark.parametrize("M", [4, 64, 512])
def test_push_writes_a_fixed_set_of_rows(M, order):
    base, j = 5, 1
    CS = make_state(M, base, members=3)
    CS[:base] = -1.0
    rng = np.random.default_rng(M)
    for _ in range(M + 2):
        est.push(CS, j, base, M, rng.standard_normal(), rng.standard_normal(), order)
    n_writes = []
    for _ in range(2 * M):
        count = int(CS[base + est.COUNT, j])
        before = CS.copy()
        est.push(CS, j, base, M, rng.standard_normal(), rng.standard_normal(), order)
        changed = np.flatnonzero((CS != before).any(axis=1))
        assert not (CS[:, [0, 2]] != before[:, [0, 2]]).any()  # other members untouched
        assert (changed >= base).all()  # rows before base untouched
        if (count + 1) % M:
            slot = count % (M + 1)
            allowed = {est.COUNT, *MOMENT_ROWS, est.RING + slot, est.RING + M + 1 + slot}
            assert set(changed - base) <= allowed
            n_writes.append(changed.size)
    assert max(n_writes) <= 3 + len(MOMENT_ROWS)  # independent of M


@pytest.mark.parametrize("M", [2, 7, 40])
def test_order_one_carries_its_moments_with_the_bits_they_have_beside_all(M):
    # n = 1 reads Y_1, U_0 and U_2 only, and a slide of S_p reads the moments below p:
    # so it carries Y_0, Y_1 and U_0 .. U_2 (estimators.moments_of) and leaves the rest
    # at zero. What it carries must be bit for bit what n = 2's full set holds, through
    # pushes and resyncs, so that its estimates are those it gave with every moment.
    rng = np.random.default_rng(M)
    one, full = make_state(M), make_state(M)
    n_y, n_u = est.moments_of(1)
    kept = [est.Y_MOM + est.N_YMOM * par + p for par in (0, 1) for p in range(n_y)]
    kept += [est.U_MOM + est.N_UMOM * par + p for par in (0, 1) for p in range(n_u)]
    left = sorted(set(MOMENT_ROWS) - set(kept))
    assert (n_y, n_u) == (2, 3) and len(left) == 6
    for _ in range(5 * M + 3):
        y, u = rng.standard_normal(2) * 10.0
        est.push(one, 0, 0, M, y, u, 1)
        est.push(full, 0, 0, M, y, u, 2)
        np.testing.assert_array_equal(one[kept], full[kept])
        assert not one[left].any()
        # (the delay-reduced kernel reads order 2's set: est.moment_order)
        for kernel in (est.HELD, est.TRAPEZOID):
            np.testing.assert_array_equal(est.sums(one, 0, 0, M, 1, kernel, NO_JACOBI),
                                          est.sums(full, 0, 0, M, 1, kernel, NO_JACOBI))


def test_moments_are_carried_and_recomputed_only_every_M_samples():
    M = 6
    CS = make_state(M)
    rng = np.random.default_rng(3)
    for _ in range(2 * M + 1):
        est.push(CS, 0, 0, M, rng.standard_normal(), rng.standard_normal(), 2)
    CS[est.Y_MOM + 1, 0] += 1e3  # corrupt a running sum at count 2M + 1
    rows = list(MOMENT_ROWS)
    for count in range(2 * M + 2, 4 * M + 1):
        est.push(CS, 0, 0, M, rng.standard_normal(), rng.standard_normal(), 2)
        assert CS[est.COUNT, 0] == count
        fresh = CS.copy()
        est.resync(fresh, 0, 0, M, 2)  # the moments recomputed from the ring
        if count < 3 * M:  # the corruption is carried: push did not look at the ring
            assert not np.allclose(CS[rows], fresh[rows])
        else:  # recomputed at count 3M, clean since
            np.testing.assert_allclose(CS[rows], fresh[rows], rtol=1e-12, atol=1e-12)
            if count % M == 0:
                np.testing.assert_array_equal(CS[rows], fresh[rows])


@pytest.mark.parametrize("M", [2, 3, 8])
def test_the_sample_count_wraps_and_the_estimates_do_not_notice(M):
    # The count must stay exact in a float32 and a 32-bit C long however long a controller
    # runs (the float export): it wraps by M (M + 1), a multiple of every modulus it is
    # read with, once the window is full. Before, it grew without bound.
    period = M * (M + 1)
    n = 7 * period + 5
    rng = np.random.default_rng(M)
    y, u = rng.standard_normal(n), rng.standard_normal(n)
    CS = make_state(M)
    counts = []
    for k in range(n):
        est.push(CS, 0, 0, M, y[k], u[k - 1] if k else U_BEFORE, 1)
        counts.append(CS[est.COUNT, 0])
    counts = np.array(counts)
    assert counts.max() < M + 1 + period
    assert (counts[M:] >= M + 1).all()  # a full window stays full
    assert (counts[: M + 1] == np.arange(1, M + 2)).all()
    check_equals_direct(2 if M % 2 == 0 else 1, M, 1e-3, 3.0, y, u)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(order=st.sampled_from(est.ORDERS), half_m=st.integers(1, 12), odd=st.booleans(),
       seed=st.integers(0, 2**32 - 1), resets=st.lists(st.integers(0, 200), max_size=2),
       scale=st.sampled_from([1.0, 1e150, 1e300]))
def test_the_spread_resync_gives_the_resync_bits_without_an_O_M_step(order, half_m, odd, seed,
                                                                     resets, scale):
    # issue 33: the C export's worst step was the resync (O(M), 6-7x the mean). The spread
    # form adds each sample, as it arrives, to the moments of the next resync's window, and
    # copies them in at the resync: every row push writes must hold push's bits, through
    # resets, the count's wrap, and values large enough to overflow the moments to inf
    # (the resync then gives inf or NaN, and so must the spread form).
    M = 2 * half_m + (1 if odd and order == 1 else 0)
    n = 3 * M * (M + 1) + 7  # past the count's wrap
    rng = np.random.default_rng(seed)
    y, u = scale * rng.standard_normal(n), scale * rng.standard_normal(n)
    plain = make_state(M)
    spread = np.full((est.n_state_spread(M), 1), np.nan)  # the spread rows start as garbage
    est.reset(spread, 0, 0, M)
    rows = est.n_state(M)
    for k in range(n):
        if k in resets:
            est.reset(plain, 0, 0, M)
            est.reset(spread, 0, 0, M)
        est.push(plain, 0, 0, M, y[k], u[k], order)
        est.push_spread(spread, 0, 0, M, y[k], u[k], order)
        same = plain[:rows, 0].view(np.int64) == spread[:rows, 0].view(np.int64)
        assert same.all(), f"sample {k}: rows {np.flatnonzero(~same)} differ"


def test_a_spread_push_does_work_independent_of_M():
    # the point of the spread form: no step loops over the window (structural, not timed):
    # every push writes the same number of rows, the resync's included
    for M in (4, 64, 512):
        CS = np.zeros((est.n_state_spread(M), 1))
        rng = np.random.default_rng(M)
        writes = []
        for k in range(3 * M):
            before = CS.copy()
            est.push_spread(CS, 0, 0, M, rng.standard_normal(), rng.standard_normal(), 2)
            if k > M:
                writes.append(int((CS != before).any(axis=1).sum()))
        assert max(writes) <= 3 + 2 * est.SPREAD_ROWS


#: every Jacobi weight the window's moments slide in O(1)
JACOBI_WEIGHTS = [(kappa, mu) for kappa in range(3) for mu in range(3 - kappa)]


def held_ramp(M, n, alpha, seed):
    """y exactly under y' = 3 + 40 t + alpha u with u = +-1 held (random), and u, t."""
    h = 1e-2
    u = np.random.default_rng(seed).choice([-1.0, 1.0], n)
    t = h * np.arange(n)
    # the exact integral of y' over each interval
    y = np.concatenate([[0.0], np.cumsum(h * (3.0 + 40.0 * (t[:-1] + 0.5 * h))
                                         + h * alpha * u[:-1])])
    return h, y, u, t


@pytest.mark.parametrize("M", [2, 3, 5, 8, 20, 64])
@pytest.mark.parametrize("kappa,mu", JACOBI_WEIGHTS)
def test_the_delay_reduced_kernel_is_exact_for_an_affine_F_at_its_lag(M, kappa, mu):
    # under a held +-1 input, F = 3 + 40 t (a ramp): F_hat = F(t_k - lag h) to rounding,
    # for every Jacobi weight and every lag from 0 to M (M/2 with kappa = mu = 1: the
    # held kernel's point, weights and all), and the moments give the FIR form of the
    # definition over a long run (many resyncs)
    alpha, n = 2.0, 6 * M + 40
    h, y, u, t = held_ramp(M, n, alpha, M + 10 * kappa + mu)
    k = np.arange(M, n)
    for lag in (0.0, 0.25, 0.5 * M, 0.8 * M, float(M)):
        f = run(1, M, h, alpha, y, u, kernel="delay-reduced", lag=lag, kappa=kappa, mu=mu)
        truth = 3.0 + 40.0 * (t[k] - lag * h)
        np.testing.assert_allclose(f[k], truth, rtol=1e-10, atol=0)
        fd, size = direct(1, M, h, alpha, y, u, "delay-reduced", lag, kappa, mu)
        np.testing.assert_allclose(f[M:], fd, rtol=0, atol=1e-12 * size.max())
        if (kappa, mu, lag) == (1, 1, 0.5 * M):
            held = est.weights(1, M, h, alpha, "held")
            for a, b in zip(est.weights(1, M, h, alpha, "delay-reduced", lag), held,
                            strict=True):
                np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max())


@pytest.mark.parametrize("kappa,mu", JACOBI_WEIGHTS)
def test_the_delay_reduced_moments_give_the_fir_form_over_a_long_random_run(kappa, mu):
    # random y and u (no model): the running moments, resynced every M samples, against
    # the FIR weights of the definition, relative to the size of the summed terms
    M, h, alpha = 20, 1e-3, 3.0
    rng = np.random.default_rng(10 * kappa + mu)
    y, u = rng.standard_normal((2, 50 * M)) * 5.0
    for lag in (0.0, 7.3, 16.0):
        f = run(1, M, h, alpha, y, u, kernel="delay-reduced", lag=lag, kappa=kappa, mu=mu)
        fd, size = direct(1, M, h, alpha, y, u, "delay-reduced", lag, kappa, mu)
        err = np.abs(f[M:] - fd) / size
        assert err.max() < 1e-12, err.max()


@pytest.mark.parametrize("M", [2, 3, 8, 20])
@pytest.mark.parametrize("kappa,mu", JACOBI_WEIGHTS)
def test_the_delay_reduced_weights_are_numpys_weighted_least_squares_line(M, kappa, mu):
    # an independent construction: np.polyfit's weighted line (its w multiplies the
    # residuals, so sqrt of the Jacobi weight) through the relations phi_j at their
    # centres, read at x* = M/2 - lag; the relations are linear in the samples, so the
    # line's value at x* over a random window is the FIR form's
    h, alpha = 1e-2, 1.7
    rng = np.random.default_rng(M)
    x = np.arange(M) + 0.5 - 0.5 * M
    w = (0.5 * M - x) ** kappa * (0.5 * M + x) ** mu
    for lag in (0.0, 1.5, 0.5 * M, float(M)):
        wy, wu = est.weights(1, M, h, alpha, "delay-reduced", lag, kappa, mu)
        for _ in range(3):
            y, u = rng.standard_normal(M + 1), rng.standard_normal(M)
            phi = np.diff(y) / h - alpha * u
            line = np.polyfit(x, phi, 1, w=np.sqrt(w))
            expected = np.polyval(line, 0.5 * M - lag)
            got = wy @ y + wu @ u
            assert got == pytest.approx(expected, rel=1e-11, abs=1e-11 * np.abs(phi).max())


def test_the_delay_reduced_weighted_mean_is_the_jacobi_weights_q0_estimator():
    # lag at the weight's mean position: the slope's term drops out, the relations'
    # weights are w itself, normalised (the minimal estimator, q = 0); away from it they
    # are not
    M = 20
    x = np.arange(M) + 0.5 - 0.5 * M
    for kappa, mu in JACOBI_WEIGHTS:
        w = (0.5 * M - x) ** kappa * (0.5 * M + x) ** mu
        lag = 0.5 * M - (w * x).sum() / w.sum()
        wu = est.weights(1, M, 1.0, 1.0, "delay-reduced", lag, kappa, mu)[1]
        np.testing.assert_allclose(-wu, w / w.sum(), rtol=0, atol=1e-15)
        off = est.weights(1, M, 1.0, 1.0, "delay-reduced", lag + 1.0, kappa, mu)[1]
        assert np.abs(off + w / w.sum()).max() > 1e-3


def test_the_delay_reduced_kernels_noise_grows_as_its_lag_shrinks():
    # the y weights' root sum of squares, the estimate's standard deviation per unit of
    # white sensor noise: the held point (lag M/2) is the least noisy of the family
    M, h = 20, 1e-3
    gain = [np.sqrt(np.sum(est.weights(1, M, h, 1.0, "delay-reduced", lag)[0] ** 2))
            for lag in (10.0, 5.0, 0.0)]
    assert gain[0] < gain[1] < gain[2]
    held = np.sqrt(np.sum(est.weights(1, M, h, 1.0, "held")[0] ** 2))
    assert gain[0] == pytest.approx(held, rel=1e-12)
    # the variance of a line's value at x* is var(centre) (1 + x*^2 / sigma^2) for
    # uncorrelated relations; the relations share their end samples, so only a bound:
    # at lag 0 between 2 and 4 times the held kernel's
    assert 2.0 < gain[2] / held < 4.0


#: docs/theory.md's table (benchmarks/jacobi_noise.py): the noise std over the held
#: kernel's at M = 20, (kappa, mu) -> (the weight's mean lag, at lag 0, M/4, M/2, mean)
NOISE_TABLE = {(1, 1): (10.00, 3.89, 2.13, 1.00, 1.00), (0, 0): (10.00, 6.01, 3.43, 1.90, 1.90),
               (0, 1): (6.67, 7.93, 3.97, 1.00, 2.68), (1, 0): (13.32, 8.28, 4.31, 1.00, 2.68),
               (0, 2): (5.01, 10.37, 3.97, 3.02, 3.96),
               (2, 0): (14.99, 15.84, 9.35, 3.02, 3.96)}


def test_the_delay_reduced_noise_table_of_the_docs():
    M = 20
    x = np.arange(M) + 0.5 - 0.5 * M
    held = np.sqrt(np.sum(est.weights(1, M, 1.0, 1.0, "held")[0] ** 2))
    assert sorted(NOISE_TABLE) == sorted(JACOBI_WEIGHTS)
    for (kappa, mu), (mean, *ratios) in NOISE_TABLE.items():
        w = (0.5 * M - x) ** kappa * (0.5 * M + x) ** mu
        lag = 0.5 * M - (w * x).sum() / w.sum()
        assert lag == pytest.approx(mean, abs=0.005)
        for at, ratio in zip((0.0, 0.25 * M, 0.5 * M, lag), ratios, strict=True):
            wy = est.weights(1, M, 1.0, 1.0, "delay-reduced", at, kappa, mu)[0]
            assert np.sqrt(np.sum(wy**2)) / held == pytest.approx(ratio, abs=0.005)
    # the affine (q = 1) reading of (0, 1) or (1, 0) at the centre is the held kernel
    for M in (3, 8, 64):
        held_w = est.weights(1, M, 1.0, 1.0, "held")
        for kappa, mu in ((0, 1), (1, 0)):
            for a, b in zip(est.weights(1, M, 1.0, 1.0, "delay-reduced", 0.5 * M, kappa, mu),
                            held_w, strict=True):
                np.testing.assert_allclose(a, b, rtol=0, atol=1e-14 * np.abs(b).max())


def test_the_delay_reduced_kernels_rules():
    est.check_window(1, 8, "delay-reduced", 0.0)
    est.check_window(1, 8, "delay-reduced", 4.0)
    est.check_window(1, 8, "delay-reduced", 8.0, 2, 0)
    est.check_window(1, 8, "delay-reduced", 0.0, 0, 0)
    with pytest.raises(ValueError, match=r"lag = 8.5: must be from 0 to M = 8 samples"):
        est.check_window(1, 8, "delay-reduced", 8.5)
    with pytest.raises(ValueError, match=r"lag = -0.5: must be from 0 to M = 8 samples"):
        est.check_window(1, 8, "delay-reduced", -0.5)
    with pytest.raises(ValueError, match=r"mu = 2: kappa \+ mu must be at most 2 \(here "
                       r"kappa = 1, mu = 2\)"):
        est.check_window(1, 8, "delay-reduced", 0.0, 1, 2)
    with pytest.raises(ValueError, match=r"kappa = 3: kappa \+ mu must be at most 2"):
        est.check_window(1, 8, "delay-reduced", 0.0, 3)
    for bad in (-1, 1.0, 0.5, True):
        with pytest.raises(ValueError, match=f"kappa = {bad!r}: must be a whole number from "
                           "0 to 2"):
            est.check_window(1, 8, "delay-reduced", 0.0, bad, 0)
        with pytest.raises(ValueError, match=f"mu = {bad!r}: must be a whole number"):
            est.check_window(1, 8, "delay-reduced", 0.0, 0, bad)
    with pytest.raises(ValueError, match="kappa = 1: only the delay-reduced kernel has a "
                       "kappa"):
        est.check_window(1, 8, "held", None, 1)
    with pytest.raises(ValueError, match="kernel = 'delay-reduced': the delay-reduced kernel "
                       "is of model order 1"):
        est.check_window(2, 8, "delay-reduced", 0.0)
    with pytest.raises(ValueError, match="lag = 1.0: only the delay-reduced kernel"):
        est.check_window(1, 8, "held", 1.0)
