"""The rule-tuned reference PIDs against facts: a FOPDT's closed-form step response fitted
back, Skogestad's half-rule examples, SIMC and AMIGO gains computed by hand, and the closed
loops they give on the FOPDT (delay by a Pade approximation) stable."""

import math

import numpy as np
import pytest

from mfcontrol.analysis.tuning_rules import (
    Fopdt,
    Gains,
    Sopdt,
    amigo,
    fit_fopdt,
    fopdt_of,
    series_to_parallel,
    simc,
    sopdt_of,
)

control = pytest.importorskip("control")


def step(t, K, T, L, u=1.0, y0=0.0):
    """The closed-form FOPDT step response."""
    return y0 + K * u * np.where(t >= L, 1.0 - np.exp(-(t - L) / T), 0.0)


# --- fit_fopdt ---------------------------------------------------------------------------

@pytest.mark.parametrize("K, T, L, u, y0", [(2.0, 3.0, 1.0, 1.0, 0.0),
                                            (-0.7, 0.5, 2.2, 4.0, 10.0),
                                            (5.0, 10.0, 0.0, -0.2, 1.0),
                                            (1.0, 1.0, 9.0, 1.0, 0.0)])
def test_fit_recovers_an_exact_fopdt(K, T, L, u, y0):
    t = np.linspace(0.0, L + 8 * T, 600)
    fit = fit_fopdt(t, step(t, K, T, L, u, y0), u_step=u, y0=y0)
    assert fit.model.K == pytest.approx(K, rel=1e-6)
    assert fit.model.T == pytest.approx(T, rel=1e-6)
    assert fit.model.L == pytest.approx(L, rel=1e-6, abs=1e-6 * T)
    assert fit.rms < 1e-8 * abs(K * u)


def test_fit_with_noise_is_close():
    rng = np.random.default_rng(20240532)
    K, T, L = 1.5, 4.0, 1.3
    t = np.linspace(0.0, 40.0, 800)
    y = step(t, K, T, L) + rng.normal(0.0, 0.01 * K, t.size)
    fit = fit_fopdt(t, y, u_step=1.0, y0=0.0)
    for got, want in ((fit.model.K, K), (fit.model.T, T), (fit.model.L, L)):
        assert got == pytest.approx(want, rel=0.03)
    assert fit.rms == pytest.approx(0.01 * K, rel=0.15)  # the residual is the noise


def test_fit_of_a_higher_order_plant_reports_its_misfit():
    """A fourth-order lag is no FOPDT: the fit is near the half rule's and its residual is
    well above rounding (the number a caller reads to judge the model)."""
    s = control.tf("s")
    plant = 1 / (s + 1) ** 4
    t = np.linspace(0.0, 30.0, 1500)
    _, y = control.step_response(plant, t)
    fit = fit_fopdt(t, y, u_step=1.0)
    half = fopdt_of(plant)  # T 1.5, L 2.5
    assert fit.model.K == pytest.approx(1.0, rel=0.01)
    assert fit.model.T + fit.model.L == pytest.approx(half.T + half.L, rel=0.1)
    assert 1e-4 < fit.rms < 0.05


# --- half rule -----------------------------------------------------------------------------

def test_half_rule_two_lags_and_delay():
    """Skogestad 2003: e^-s / ((6 s + 1)(2 s + 1)) -> T = 6 + 2/2, L = 1 + 2/2."""
    s = control.tf("s")
    m = fopdt_of(1 / ((6 * s + 1) * (2 * s + 1)), delay=1.0)
    assert (m.K, m.T, m.L) == pytest.approx((1.0, 7.0, 2.0))


def test_half_rule_papers_seven_lag_example():
    """Skogestad 2003's worked example (-0.3s+1)(0.08s+1) / ((2s+1)(s+1)(0.4s+1)(0.2s+1)
    (0.05s+1)^3): FOPDT T 2.5, L 1.47; SOPDT T1 2, T2 1.2, L 0.77 (the inverse response
    0.3 counts as delay; the zero 0.08 cancels against the lag 0.2, leaving 0.12)."""
    s = control.tf("s")
    g = (-0.3 * s + 1) * (0.08 * s + 1) / ((2 * s + 1) * (s + 1) * (0.4 * s + 1)
                                           * (0.2 * s + 1) * (0.05 * s + 1) ** 3)
    m = fopdt_of(g)
    assert (m.K, m.T, m.L) == pytest.approx((1.0, 2.5, 1.47))
    m2 = sopdt_of(g)
    assert (m2.K, m2.T1, m2.T2, m2.L) == pytest.approx((1.0, 2.0, 1.2, 0.77))


def test_half_rule_takes_scipy_and_gain_and_multiple_roots():
    from scipy import signal

    # 3 / ((4 s + 1)(s + 1)) = 3 / (4 s^2 + 5 s + 1)
    m = fopdt_of(signal.TransferFunction([3.0], [4.0, 5.0, 1.0]), delay=0.5)
    assert (m.K, m.T, m.L) == pytest.approx((3.0, 4.5, 1.0))
    m0 = fopdt_of(signal.lti([3.0], [4.0, 5.0, 1.0]))  # no delay of its own: L = 1 / 2
    assert (m0.K, m0.T, m0.L) == pytest.approx((3.0, 4.5, 0.5))
    # the benchmark's 1 / (s + 1)^8: np.roots scatters the 8-fold root; T 1.5, L 6.5
    s = control.tf("s")
    m8 = fopdt_of(1 / (s + 1) ** 8)
    assert (m8.T, m8.L) == pytest.approx((1.5, 6.5), rel=1e-9)


# --- SIMC and AMIGO against hand-computed numbers --------------------------------------

A = Fopdt(K=2.0, T=4.0, L=1.0)  # tau 0.2
B = Fopdt(K=0.5, T=1.0, L=3.0)  # tau 0.75


@pytest.mark.parametrize("model, tau_c, want", [
    # Kc = T / (K (tau_c + L)), Ti = min(T, 4 (tau_c + L)), ki = Kc / Ti
    (A, None, (1.0, 0.25)),        # 4 / (2 * 2), Ti = min(4, 8) = 4
    (A, 3.0, (0.5, 0.125)),        # 4 / (2 * 4), Ti = min(4, 16) = 4
    (B, None, (1 / 3, 1 / 3)),     # 1 / (0.5 * 6), Ti = min(1, 24) = 1
    (Fopdt(1.0, 20.0, 0.5), None, (20.0, 5.0)),  # Ti = min(20, 4) = 4: the integral cap
])
def test_simc_pi_by_hand(model, tau_c, want):
    g = simc(model, tau_c)
    assert (g.kp, g.ki, g.kd, g.b) == pytest.approx((*want, 0.0, 1.0))


def test_simc_papers_worked_example():
    """Skogestad 2003, the seven-lag example: PI from the FOPDT Kc 0.85, Ti 2.5; PID from
    the SOPDT Kc 1.30, Ti 2, Td 1.2 (series form), tau_c = L each time."""
    pi = simc(Fopdt(1.0, 2.5, 1.47))
    assert pi.kp == pytest.approx(0.85, abs=0.005)
    assert pi.kp / pi.ki == pytest.approx(2.5)
    pid = simc(Sopdt(1.0, 2.0, 1.2, 0.77), kind="PID")
    Kc = 2.0 / (2 * 0.77)
    assert Kc == pytest.approx(1.30, abs=0.005)
    assert (pid.kp, pid.ki, pid.kd) == pytest.approx((Kc * (1 + 1.2 / 2.0), Kc / 2.0, Kc * 1.2))


def test_series_to_parallel_is_the_same_controller():
    """Kc (Ti s + 1)(Td s + 1) / (Ti s) and kp + ki / s + kd s agree at every frequency."""
    Kc, Ti, Td = 1.7, 3.0, 0.8
    kp, ki, kd = series_to_parallel(Kc, Ti, Td)
    for w in (0.01, 0.3, 1.0, 7.0, 100.0):
        s = 1j * w
        assert kp + ki / s + kd * s == pytest.approx(Kc * (Ti * s + 1) * (Td * s + 1) / (Ti * s))


@pytest.mark.parametrize("model, kind, want", [
    # PI: K Kp = 0.15 + (0.35 - L T / (L + T)^2) T / L,
    #     Ti = 0.35 L + 13 L T^2 / (T^2 + 12 L T + 7 L^2)
    # A: K Kp = 0.15 + (0.35 - 4 / 25) 4 = 0.91, Ti = 0.35 + 13 * 16 / 71
    # B: K Kp = 0.15 + (0.35 - 3 / 16) / 3 = 0.6125 / 3, Ti = 1.05 + 39 / 100 = 1.44
    (A, "PI", (0.91 / 2, 0.455 / (0.35 + 208 / 71), 0.0, 0.0)),
    (B, "PI", (0.6125 / 1.5, 0.6125 / 1.5 / 1.44, 0.0, 1.0)),
    # PID: K Kp = 0.2 + 0.45 T / L; Ti = (0.4 L + 0.8 T) / (L + 0.1 T) L; Td = 0.5 L T / (0.3 L + T)
    (A, "PID", (1.0, 1.4 / 3.6, 2.0 / 4.3, 0.0)),
    (B, "PID", (0.7, 0.7 / (2.0 / 3.1 * 3), 0.7 * 1.5 / 1.9, 1.0)),
])
def test_amigo_by_hand(model, kind, want):
    assert tuple(amigo(model, kind)) == pytest.approx(want, rel=1e-9)


def test_amigo_setpoint_weight_switches_at_half():
    assert amigo(Fopdt(1.0, 1.0, 1.0)).b == 0.0  # tau 0.5 exactly: b 0
    assert amigo(Fopdt(1.0, 1.0, 1.01)).b == 1.0
    assert amigo(Fopdt(1.0, 1.01, 1.0), "PID").b == 0.0


def test_gains_build_the_librarys_pid():
    import mfcontrol

    g = amigo(A, "PID")
    ctrl = mfcontrol.PID(**g._asdict(), sample_time=0.1)
    assert isinstance(g, Gains) and ctrl is not None


# --- closed loops on the FOPDT are stable ---------------------------------------------------

def _closed_loop_poles(model, g, N=10.0):
    """Poles of the loop of the parallel PID (derivative filtered by Td / N, as
    mfcontrol.PID's) around K e^-Ls / (Ts + 1), the delay by a 10th-order Pade."""
    s = control.tf("s")
    num, den = control.pade(model.L, 10)
    plant = model.K / (model.T * s + 1) * control.tf(num, den)
    c = g.kp + g.ki / s
    if g.kd:
        c = c + g.kd * s / (1 + g.kd / (g.kp * N) * s)
    return control.poles(control.feedback(c * plant, 1))


TAUS = np.linspace(0.1, 0.9, 9)


@pytest.mark.parametrize("tau", TAUS)
@pytest.mark.parametrize("rule", ["simc PI", "amigo PI", "amigo PID"])
def test_rule_closed_loop_is_stable(tau, rule):
    model = Fopdt(K=1.3, T=1.0, L=tau / (1 - tau))
    g = simc(model) if rule == "simc PI" else amigo(model, rule.split()[1])
    assert _closed_loop_poles(model, g).real.max() < 0


def test_the_stability_check_can_fail():
    """Ten times SIMC's gain is past its gain margin (about 3): the same check sees it."""
    model = Fopdt(K=1.0, T=1.0, L=1.0)
    g = simc(model)
    assert _closed_loop_poles(model, Gains(10 * g.kp, 10 * g.ki, 0.0, 1.0)).real.max() > 0


# --- refusals: one line, naming the argument --------------------------------------------

def _refused(match, fn, *args, **kwargs):
    with pytest.raises(ValueError, match=match) as info:
        fn(*args, **kwargs)
    assert "\n" not in str(info.value)
    return str(info.value)


T_OK = np.linspace(0.0, 30.0, 300)
Y_OK = step(T_OK, 1.0, 3.0, 1.0)


def test_fit_refusals():
    _refused(r"^t = .*at least 10 samples", fit_fopdt, T_OK[:5], Y_OK[:5], 1.0)
    _refused(r"^y = .*shape of t", fit_fopdt, T_OK, Y_OK[:-1], 1.0)
    _refused(r"^t = .*strictly increasing", fit_fopdt, T_OK[::-1], Y_OK, 1.0)
    _refused(r"^t, y = .*finite", fit_fopdt, T_OK, np.where(T_OK > 5, np.nan, Y_OK), 1.0)
    _refused(r"^u_step = 0.0: must be a finite, non-zero", fit_fopdt, T_OK, Y_OK, 0.0)
    _refused(r"^y = .*must respond", fit_fopdt, T_OK, np.zeros_like(T_OK), 1.0)
    # an underdamped response overshoots 30 %: not essentially monotone
    overshoot = 1 - np.exp(-0.4 * T_OK) * np.cos(1.0 * T_OK)
    _refused(r"^y = .*essentially monotone", fit_fopdt, T_OK, overshoot, 1.0)
    # (1 - 3 s) / (s + 1)^2 dips the wrong way first
    s = control.tf("s")
    _, inverse = control.step_response((1 - 3 * s) / (s + 1) ** 2, T_OK)
    assert inverse.min() < -0.3
    _refused(r"^y = .*essentially monotone", fit_fopdt, T_OK, inverse, 1.0)
    # cut off at L + T: the gain would be a guess
    short = np.linspace(0.0, 4.0, 50)
    _refused(r"^t = .*must reach the response's settling", fit_fopdt, short,
             step(short, 1.0, 3.0, 1.0), 1.0)


@pytest.mark.parametrize("kwargs, match", [
    ({"K": 1.0, "T": -2.0, "L": 1.0}, r"^T = -2.0: must be a finite time constant > 0$"),
    ({"K": 1.0, "T": 0.0, "L": 1.0}, r"^T = 0.0: "),
    ({"K": 0.0, "T": 1.0, "L": 1.0}, r"^K = 0.0: must be a finite, non-zero gain$"),
    ({"K": 1.0, "T": 1.0, "L": -0.1}, r"^L = -0.1: must be a finite dead time >= 0$"),
    ({"K": math.inf, "T": 1.0, "L": 0.0}, r"^K = inf: "),
    ({"K": 1.0, "T": "x", "L": 0.0}, r"^T = 'x': "),
])
def test_model_refusals(kwargs, match):
    _refused(match, Fopdt, **kwargs)


def test_rule_refusals():
    _refused(r"^T2 = 3.0: must be a finite time constant in \[0, T1 = 2.0\]", Sopdt,
             1.0, 2.0, 3.0, 0.5)
    _refused(r"^kind = 'PD': must be \"PI\" or \"PID\"", simc, A, kind="PD")
    _refused(r"^tau_c = -1.0: must be a finite time >= 0", simc, A, -1.0)
    _refused(r"^tau_c = 0.0: must be > 0 when the model has no dead time", simc,
             Fopdt(1.0, 1.0, 0.0), 0.0)
    _refused(r"^model = .*must be a Sopdt for kind=\"PID\"", simc, A, kind="PID")
    _refused(r"^model.L = 0.0: must be > 0 for AMIGO", amigo, Fopdt(1.0, 1.0, 0.0))
    _refused(r"^model = .*must be a Fopdt", amigo, Sopdt(1.0, 2.0, 1.0, 0.5))


def test_half_rule_refusals():
    s = control.tf("s")
    _refused(r"^plant_tf = .*no integrator", fopdt_of, 1 / (s * (s + 1)))
    _refused(r"^plant_tf = .*complex pole", fopdt_of, 1 / (s ** 2 + 0.4 * s + 1))
    _refused(r"^plant_tf = .*continuous-time", fopdt_of, control.c2d(1 / (s + 1), 0.1))
    _refused(r"^plant_tf = .*rule T3", fopdt_of, (2 * s + 1) / (s + 1))
    _refused(r"^plant_tf = .*at least one pole", fopdt_of, control.tf([2.0], [1.0]))
    _refused(r"^delay = -1.0: must be a finite dead time >= 0", fopdt_of, 1 / (s + 1),
             delay=-1.0)
    _refused(r"^plant_tf = 'G': must be a python-control or scipy.signal", fopdt_of, "G")


def test_sopdt_of_equal_lags_orders_them():
    """The half rule on 1/(s+1)^3 keeps the lags 1 and 1 + 1/2: the second is the larger.
    The model is symmetric in its lags; it was refused (T2 > T1), and the benchmark's
    SIMC fell back to a PI on 1/(s+1)^3, 1/(s+1)^8 and the non-minimum-phase process."""
    import control

    m = sopdt_of(control.tf([1.0], [1.0, 3.0, 3.0, 1.0]))
    assert (m.K, m.T1, m.T2, m.L) == pytest.approx((1.0, 1.5, 1.0, 0.5))
    gains = simc(m, kind="PID")
    assert gains.kd > 0
