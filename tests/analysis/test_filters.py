"""Each law's equivalent linear filter against the law itself, simulated, and against
closed forms: the i-P = PI equivalence and the integrator's stability bound."""

import math

import numpy as np
import pytest

import mfcontrol
from mfcontrol import LTI

control = pytest.importorskip("control")

H = 0.01
#: 1 / ((s + 1) (s + 2)), stepped exactly (zero-order hold)
A = [[0.0, 1.0], [-2.0, -3.0]]
B = [0.0, 1.0]
C = [1.0, 0.0]
#: samples the closed loop is held to after the start-up
N_HELD = 2000


def reference(t):
    """A step and a sine: every mode of the loop excited, through the setpoint's
    derivatives too."""
    return 1.0 + 0.3 * math.sin(3.0 * t) + (0.5 if t >= 5.0 else 0.0)


#: controllers that keep the loop asymptotically stable, and the first sample whose law
#: equation, and the one before it, are past the start-up (the output held for n samples,
#: the algebraic window filling, the PID's first sample)
CONTROLLERS = {
    "i-P": (lambda: mfcontrol.IP(alpha=50.0, kp=5.0, sample_time=H), 2),
    "i-PI": (lambda: mfcontrol.IPI(alpha=50.0, kp=2.0, ki=1.0, sample_time=H), 2),
    "i-P algebraic": (lambda: mfcontrol.IP(alpha=50.0, kp=5.0, sample_time=H,
                                           estimator="algebraic", window=10), 11),
    "i-PI algebraic": (lambda: mfcontrol.IPI(alpha=50.0, kp=2.0, ki=1.0, sample_time=H,
                                             estimator="algebraic", window=20), 21),
    "i-PD order 2": (lambda: mfcontrol.IPD(alpha=1.0, kp=4.0, kd=4.0, sample_time=H), 3),
    "i-PID order 2": (lambda: mfcontrol.IPID(alpha=1.0, kp=4.0, ki=1.0, kd=4.0,
                                             sample_time=H), 3),
    "i-PID order 2 algebraic": (lambda: mfcontrol.IPID(
        alpha=1.0, kp=4.0, ki=1.0, kd=4.0, sample_time=H, estimator="algebraic",
        window=20), 21),
    "PI": (lambda: mfcontrol.PID(kp=2.0, ki=1.5, sample_time=H), 2),
    "PID weighted": (lambda: mfcontrol.PID(kp=3.0, ki=2.0, kd=0.4, N=8.0, b=0.5,
                                           sample_time=H), 2),
    "P": (lambda: mfcontrol.PID(kp=2.0, sample_time=H), 2),
    "PID filtered": (lambda: mfcontrol.PID(kp=3.0, ki=2.0, kd=0.4, N=8.0, b=0.5, c=0.3,
                                           Tf=0.05, sample_time=H), 2),
    # ADRC: the plant's y'' = u - 3 y' - 2 y gives b0 = 1 for the second order; the first
    # order's b0 is a rough guess, as in practice
    "ADRC order 1": (lambda: mfcontrol.ADRC(order=1, b0=0.5, wc=1.0, wo=5.0,
                                            sample_time=H), 1),
    "ADRC order 2": (lambda: mfcontrol.ADRC(order=2, b0=1.0, wc=5.0, wo=25.0,
                                            sample_time=H), 1),
    "ADRC order 2 delay": (lambda: mfcontrol.ADRC(order=2, b0=1.0, wc=3.0, wo=15.0,
                                                  sample_time=H, delay=2), 1),
    # the paper's recursive i-P: a PI in velocity form (kp 2, ki 2 / s with hd = 1 s),
    # its P term on y_{k-1} as published, and as printed on y_k
    "recursive i-P": (lambda: mfcontrol.RecursiveIP(
        alpha=0.5, kp=0.02, sample_time=H, deriv_scale=1.0, output_gain=1.0,
        duty_min=-100.0, duty_max=100.0), 1),
    "recursive i-P as printed": (lambda: mfcontrol.RecursiveIP(
        alpha=0.5, kp=0.02, sample_time=H, deriv_scale=1.0, output_gain=2.0,
        duty_min=-100.0, duty_max=100.0, p_sample="current", u0=0.0), 1),
}


def _run(ctrl, n_samples):
    plant = LTI(A, B, C, integrator="exact")
    return plant, mfcontrol.simulate_loop(plant, ctrl, reference, t_end=n_samples * H)


@pytest.mark.parametrize("name", CONTROLLERS)
def test_the_law_satisfies_its_filter_equation_past_the_start_up(name):
    make, steady = CONTROLLERS[name]
    ctrl = make()
    filt = ctrl.linear_filter()
    _, res = _run(ctrl, 1000)
    u, y, r = (res.signals[k] for k in ("u", "y", "y_ref"))
    # a loop that stays bounded (the test holds the law's equation, not its tuning)
    assert not res.metrics["diverged"] and np.abs(y).max() < 10.0
    resid = filt.residual(u, y, r)[max(0, steady - filt.order):]
    # rounding: relative to the size of the terms the equation sums
    scale = (np.abs(filt.a).sum() * np.abs(u).max() + np.abs(filt.b_y).sum() * np.abs(y).max()
             + np.abs(filt.b_r).sum() * np.abs(r).max())
    assert np.abs(resid).max() <= 1e-11 * scale
    # and it is not trivially satisfied: the filter of another law is not
    other = CONTROLLERS["i-P" if name != "i-P" else "PI"][0]().linear_filter()
    assert np.abs(other.residual(u, y, r)[50:]).max() > 1e-3 * scale


@pytest.mark.parametrize("name", CONTROLLERS)
def test_the_closed_loop_of_the_filter_and_the_plant_is_the_simulated_loop(name):
    # the test: the loop built from the analysis's C(z) and the plant's exact
    # discretisation (python-control's c2d), run as a linear system from the library's
    # state past the start-up, equals the library's simulation over 2,000 samples
    make, steady = CONTROLLERS[name]
    ctrl = make()
    filt = ctrl.linear_filter()
    k0 = steady + filt.order
    plant, res = _run(ctrl, k0 + N_HELD)
    sys_d = control.c2d(control.ss(A, np.array(B)[:, None], np.array(C)[None, :], 0.0), H,
                        "zoh")
    Ad, Bd, Cd = (np.asarray(m) for m in (sys_d.A, sys_d.B, sys_d.C))
    y_lib, u_lib, r = (res.signals[k] for k in ("y", "u", "y_ref"))
    x = np.array([res.states[s][k0] for s in plant.state_names])
    y, u = y_lib[:k0].tolist(), u_lib[:k0].tolist()
    for k in range(k0, r.size):
        y.append(float((Cd @ x)[0]))
        past = sum(filt.b_y[i] * y[k - i] for i in range(filt.b_y.size))
        past += sum(filt.b_r[i] * r[k - i] for i in range(filt.b_r.size))
        past -= sum(filt.a[i] * u[k - i] for i in range(1, filt.a.size))
        u.append(past)
        x = Ad @ x + Bd[:, 0] * past
    y, u = np.array(y), np.array(u)
    assert np.abs(y - y_lib)[k0:].max() <= 1e-9 * np.abs(y_lib).max()
    assert np.abs(u - u_lib)[k0:].max() <= 1e-9 * np.abs(u_lib).max()


def test_the_ip_with_backward_differences_is_a_pi():
    # u_k - u_{k-1} = -(1/alpha) ((e_k - e_{k-1}) / h + kp e_k): the PID's velocity form
    # with kp' = (1/h + kp) / alpha and ki' = kp / (alpha h)
    alpha, kp, h = 3.0, 7.0, 0.02
    ip = mfcontrol.IP(alpha=alpha, kp=kp, sample_time=h).linear_filter()
    pi = mfcontrol.PID(kp=(1 / h + kp) / alpha, ki=kp / (alpha * h),
                       sample_time=h).linear_filter()
    for a, b in ((ip.a, pi.a), (ip.b_y, pi.b_y), (ip.b_r, pi.b_r)):
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("kp", [1.0, 10.0, 40.0])
def test_the_integrators_stability_bound_comes_out_of_the_filter(kp):
    # y' = beta u under the i-P (backward differences, order 1) is stable iff
    # alpha > beta (2 + kp h) / 4 (the theory page's bound)
    beta, h = 5.0, 0.01
    plant = control.tf([beta * h], [1.0, -1.0], h)  # the integrator's exact step
    bound = beta * (2 + kp * h) / 4

    def radius(alpha):
        cy, _ = mfcontrol.IP(alpha=alpha, kp=kp, sample_time=h).linear_filter() \
            .transfer_functions()
        loop = control.feedback(plant, -cy)
        return np.abs(control.poles(loop)).max()

    assert radius(bound * (1 + 1e-6)) < 1.0 < radius(bound * (1 - 1e-6))


def test_a_moving_gain_needs_the_gamma_to_analyse_it_at():
    ctrl = mfcontrol.IP(alpha=2.0, kp=5.0, sample_time=H, gain="variational")
    with pytest.raises(ValueError, match="^gamma = None: a variational gain moves"):
        ctrl.linear_filter()
    frozen = ctrl.linear_filter(gamma=0.5)
    fixed = mfcontrol.IP(alpha=2.0, kp=5.0, sample_time=H).linear_filter()
    for a, b in ((frozen.a, fixed.a), (frozen.b_y, fixed.b_y), (frozen.b_r, fixed.b_r)):
        np.testing.assert_array_equal(a, b)


def test_transfer_functions_are_discrete_with_the_sample_time():
    cy, cr = CONTROLLERS["PID weighted"][0]().linear_filter().transfer_functions()
    assert cy.dt == cr.dt == H

    def at(w):  # both at z = exp(j w h)
        z = np.exp(1j * w * H)
        return complex(cy(z)), complex(cr(z))

    # at low frequency the integral dominates: equal and opposite from y and from r
    # (they differ by the setpoint weight's kp (1 - b) and the derivative, finite)
    low_y, low_r = at(1e-4)
    assert abs(low_y) > 1e4 and abs(low_y + low_r) < 1e-3 * abs(low_y)
    # at high frequency they are not: the derivative acts on y alone
    high_y, high_r = at(100.0)
    assert abs(high_y + high_r) > 0.5 * abs(high_r)


def test_the_filter_tells_an_unstable_loop_before_it_runs():
    # the i-P with alpha = 2 on this plant: the filter's loop has a pole outside the unit
    # circle, and the simulated loop grows; with alpha = 50 neither
    sys_d = control.c2d(control.ss(A, np.array(B)[:, None], np.array(C)[None, :], 0.0), H,
                        "zoh")
    for alpha, unstable in ((2.0, True), (50.0, False)):
        ctrl = mfcontrol.IP(alpha=alpha, kp=5.0, sample_time=H)
        cy, _ = ctrl.linear_filter().transfer_functions()
        radius = np.abs(control.poles(control.feedback(control.ss2tf(sys_d), -cy))).max()
        _, res = _run(ctrl, 3000)
        grew = np.abs(res.signals["y"][-500:]).max() > 100.0
        assert (radius > 1.0) == unstable == grew


def test_the_variational_recursive_law_needs_its_gamma():
    ctrl = mfcontrol.RecursiveIP(alpha=10.0, kp=2.0, law="variational", sample_time=1e-6)
    with pytest.raises(ValueError, match="^gamma = None: the variational law"):
        ctrl.linear_filter()
    held = ctrl.linear_filter(gamma=0.1)
    standard = mfcontrol.RecursiveIP(alpha=10.0, kp=2.0, sample_time=1e-6).linear_filter()
    np.testing.assert_array_equal(held.b_y, standard.b_y)
    with pytest.raises(ValueError, match="^sample_time = None"):
        mfcontrol.RecursiveIP(alpha=10.0, kp=2.0).linear_filter()
