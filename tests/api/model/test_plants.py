"""The plant objects against exact solutions, against each other and at their edges."""

import doctest
import warnings

import control
import numba
import numpy as np
import pytest
from scipy.linalg import expm

from mfcontrol.api.model import plants as models
from mfcontrol.api.model.plants import LTI, ODE, Boost, Buck, FirstOrder, Plant
from mfcontrol.errors import ConfigError


def _run(plant, u, h, n, t0=0.0):
    x = plant.x0
    traj = [x]
    for k in range(n):
        x = plant.step(t0 + k * h, x, u, h)
        traj.append(x)
    return np.array(traj)


# --- Buck -----------------------------------------------------------------------------------


def _buck_exact(coupling, d, t, E=20.0, L=1e-3, R=10.0, C=10e-6):
    """x(t) from rest of the buck's linear ODE x' = A x + b under a held duty cycle."""
    A = np.array([[0.0, -1 / L], [1 / C, -1 / (R * C)]])
    b = np.array([E * d / L, E * d / L if coupling == "published" else 0.0])
    x_inf = -np.linalg.solve(A, b)
    return np.array([x_inf - expm(A * tk) @ x_inf for tk in t]), A, b


@pytest.mark.parametrize("coupling", ["published", "textbook"])
def test_buck_rk4_matches_the_exact_solution(coupling):
    h, n = 2e-6, 1000
    traj = _run(Buck(coupling=coupling), 0.5, h, n)
    x, _, _ = _buck_exact(coupling, 0.5, h * np.arange(n + 1))
    scale = np.max(np.abs(x), axis=0)
    assert np.all(np.max(np.abs(traj - x), axis=0) < 1e-9 * scale)


@pytest.mark.parametrize("coupling", ["published", "textbook"])
def test_buck_derivative_is_A_x_plus_b(coupling):
    _, A, b = _buck_exact(coupling, 0.3, [0.0])
    x = np.array([1.2, 7.5])
    np.testing.assert_allclose(Buck(coupling=coupling).derivative(0.0, x, 0.3), A @ x + b,
                               rtol=1e-14)


def test_buck_power_output_is_v_times_i():
    assert Buck(output="power").output(np.array([1.5, 8.0])) == 12.0
    assert Buck().output(np.array([1.5, 8.0])) == 8.0


def test_step_leaves_its_input_alone_and_returns_a_new_state():
    for plant in (Buck(), Boost(), FirstOrder(-1.0, 1.0), LTI([[-1.0]], [1.0], [1.0]),
                  ODE(lambda t, x, u, p: -x + u, lambda x, p: x[0], (0.0,))):
        x = plant.x0 + 0.5
        before = x.copy()
        x1 = plant.step(0.0, x, 1.0, 1e-3)
        np.testing.assert_array_equal(x, before)
        assert x1.shape == x.shape and not np.shares_memory(x1, x)
        assert isinstance(plant.output(x1), float)


def test_x0_is_a_copy():
    plant = Buck(x0=(1.0, 2.0))
    plant.x0[0] = 99.0
    np.testing.assert_array_equal(plant.x0, [1.0, 2.0])


# --- RK45 against RK4 -----------------------------------------------------------------------


def _pendulum(t, x, u, p):
    return np.array([x[1], -p[0] * np.sin(x[0]) - p[1] * x[1] + u])


def _angle(x, p):
    return x[0]


@pytest.mark.parametrize("make, u, h, n", [
    (lambda **kw: Buck(coupling="published", **kw), 0.5, 1e-6, 300),
    (lambda **kw: Boost(**kw), 0.4, 1e-6, 300),
    (lambda **kw: FirstOrder(-3.0, 2.0, w=0.5, x0=1.0, **kw), 1.0, 1e-2, 100),
    (lambda **kw: LTI([[0.0, 1.0], [-4.0, -0.4]], [0.0, 1.0], [1.0, 0.0], **kw), 1.0, 1e-2, 300),
    (lambda **kw: ODE(_pendulum, _angle, (1.0, 0.0), {"k": 9.81, "c": 0.3}, **kw), 0.2, 1e-3,
     1000),
])
def test_rk45_and_rk4_agree_on_smooth_problems(make, u, h, n):
    rk4 = _run(make(integrator="rk4"), u, h, n)
    rk45 = _run(make(integrator="rk45", rtol=1e-11, atol=1e-12), u, h, n)
    scale = np.max(np.abs(rk4), axis=0)
    assert np.max(np.abs(rk4 - rk45) / scale) < 1e-8


@pytest.mark.parametrize("integrator", ["rk4", "rk45"])
def test_a_blow_up_is_a_non_finite_state_not_an_exception(integrator):
    plant = Boost(integrator=integrator)
    assert np.all(np.isnan(plant.step(0.0, plant.x0, float("nan"), 1e-6)))
    plant = FirstOrder(1e3, 1.0, x0=1e300, integrator=integrator)
    with np.errstate(over="ignore", invalid="ignore"), warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        x = plant.step(0.0, plant.x0, 1.0, 1.0)
    assert not np.all(np.isfinite(x))
    # RK4 overflows to inf silently; RK45 gives up, says so, and returns NaN
    assert any("RK45 failed" in str(m.message) for m in w) == (integrator == "rk45")


# --- FirstOrder -----------------------------------------------------------------------------


def test_first_order_integrators():
    a, b, w, y0, u, h, n = -2.0, 1.5, 0.25, 1.0, 2.0, 0.01, 200
    t = h * np.arange(n + 1)
    g = b * u + w
    y = np.exp(a * t) * y0 + np.expm1(a * t) / a * g
    np.testing.assert_allclose(_run(FirstOrder(a, b, w, y0, integrator="exact"), u, h, n)[:, 0],
                               y, rtol=1e-13)
    np.testing.assert_allclose(_run(FirstOrder(a, b, w, y0), u, h, n)[:, 0], y, rtol=1e-8)


def test_first_order_disturbance_can_be_scheduled():
    plant = FirstOrder(-1.0, 1.0, integrator="exact")
    x = plant.step(0.0, plant.x0, 0.0, 50.0)
    assert plant.output(x) == 0.0
    plant.set_param("w", 2.0)
    assert plant.output(plant.step(50.0, x, 0.0, 50.0)) == pytest.approx(2.0, rel=1e-12)
    assert plant.params == {"a": -1.0, "b": 1.0, "w": 2.0}


# --- LTI ------------------------------------------------------------------------------------


def _lag_systems():
    return {"tf": control.tf([1.0], [1.0, 1.0]), "ss": control.ss(-1.0, 1.0, 1.0, 0.0)}


@pytest.mark.parametrize("kind", ["tf", "ss"])
@pytest.mark.parametrize("integrator, tol", [("rk4", 1e-9), ("exact", 1e-14), ("rk45", 1e-8)])
def test_lti_first_order_lag_step_response(kind, integrator, tol):
    h, n = 1e-2, 500
    plant = LTI.from_control(_lag_systems()[kind], integrator=integrator)
    traj = _run(plant, 1.0, h, n)
    y = np.array([plant.output(x) for x in traj])
    np.testing.assert_allclose(y, 1 - np.exp(-h * np.arange(n + 1)), rtol=tol, atol=tol)


def test_lti_second_order_step_response_from_a_transfer_function():
    # 1 / ((s + 1)(s + 2)): y(t) = 1/2 - e^-t + e^-2t / 2, whatever realisation ss() picks
    plant = LTI.from_control(control.tf([1.0], [1.0, 3.0, 2.0]), integrator="exact")
    h, n = 0.01, 400
    t = h * np.arange(n + 1)
    y = [plant.output(x) for x in _run(plant, 1.0, h, n)]
    np.testing.assert_allclose(y, 0.5 - np.exp(-t) + np.exp(-2 * t) / 2, atol=1e-13)


def test_from_control_rejects_what_a_siso_continuous_plant_cannot_be():
    with pytest.raises(ValueError, match="continuous-time"):
        LTI.from_control(control.tf([1.0], [1.0, -0.5], 0.1))
    mimo = control.ss([[-1.0, 0.0], [0.0, -2.0]], np.eye(2), np.eye(2), np.zeros((2, 2)))
    with pytest.raises(ValueError, match="SISO"):
        LTI.from_control(mimo)
    with pytest.raises(ValueError, match="D = 1.0: must be 0: a sampled loop measures y_k"):
        LTI.from_control(control.tf([1.0, 2.0], [1.0, 1.0]))  # biproper: feedthrough 1
    with pytest.raises(TypeError, match="StateSpace"):
        LTI.from_control(([1.0], [1.0, 1.0]))


@pytest.mark.parametrize("make, needles", [
    (lambda: control.tf([1.0], [1.0, 0.5], 0.1),
     ["sys.dt = 0.1: must be 0", "a TransferFunction with 1 input, 1 output, denominator "
      "of degree 1"]),
    (lambda: control.ss(-np.eye(2), np.eye(2), np.eye(2), np.zeros((2, 2))),
     ["sys = 'a StateSpace with 2 inputs, 2 outputs, 2 states': must have one input and "
      "one output (SISO)"]),
    (lambda: control.tf([1.0, 0.0, 0.0], [1.0, 1.0]),
     ["sys = 'a TransferFunction with 1 input, 1 output, denominator of degree 1': must be "
      "a proper system", "non-proper"]),
    (lambda: control.ss([[np.nan, 0.0], [0.0, -2.0]], [[1.0], [1.0]], [[1.0, 1.0]], 0.0),
     ["sys = 'a StateSpace with 1 input, 1 output, 2 states': must have finite "
      "coefficients (its state space's A holds NaN or inf)"]),
    (lambda: control.tf([1.0], [1.0, np.inf]), ["A and C hold NaN or inf"]),
    (lambda: control.tf([2.0], [1.0]),
     ["sys = 'a TransferFunction with 1 input, 1 output, denominator of degree 0': must "
      "have at least one state (a static gain"]),
], ids=["discrete", "mimo", "improper", "nan", "inf-tf", "static-gain"])
def test_from_control_refusals_are_one_line_that_describes_the_system(make, needles):
    """Issue 29: a NaN in A was refused with the matrix printed over two lines, an
    improper system by python-control's own ValueError and a static gain by the shape of
    an empty A; each is one line naming sys, described by its type, inputs, outputs and
    order."""
    with pytest.raises(ConfigError) as info:
        LTI.from_control(make())
    message = str(info.value)
    assert "\n" not in message
    for needle in needles:
        assert needle in message, message


def test_from_control_keyword_refusals_are_one_line():
    sys = control.ss(-np.eye(2), [[1.0], [1.0]], [[1.0, 1.0]], 0.0)
    with pytest.raises(ConfigError, match=r"^x0 = array\(\[\[0\., 0\.\], \[0\., 0\.\]\]\): "
                                          r"must be 2 finite numbers \(x\[0\], x\[1\]\)$"):
        LTI.from_control(sys, x0=np.zeros((2, 2)))


def test_lti_shapes_and_values_are_checked():
    with pytest.raises(ValueError, match="A = .*square"):
        LTI([[1.0, 2.0]], [1.0], [1.0])
    with pytest.raises(ValueError, match=r"B = .*\(2,\) or \(2, 1\)"):
        LTI(np.eye(2), [1.0, 2.0, 3.0], [1.0, 0.0])
    with pytest.raises(ValueError, match=r"C = .*\(2,\) or \(1, 2\)"):
        LTI(np.eye(2), [1.0, 0.0], [[1.0], [0.0]])
    with pytest.raises(ValueError, match="A = .*finite"):
        LTI([[np.nan]], [1.0], [1.0])
    with pytest.raises(ValueError, match="x0 = "):
        LTI(np.eye(2), [1.0, 0.0], [1.0, 0.0], x0=(1.0,))
    # column B, row C and a scalar one-state system are all fine
    assert LTI(-np.eye(2), [[1.0], [0.0]], [[1.0, 0.0]]).B.shape == (2,)
    assert LTI(-1.0, 1.0, 1.0).params == {"A[0,0]": -1.0, "B[0]": 1.0, "C[0]": 1.0}


def test_lti_set_param_invalidates_the_exact_discretisation():
    plant = LTI([[-1.0]], [1.0], [1.0], integrator="exact")
    plant.step(0.0, plant.x0, 1.0, 0.1)
    plant.set_param("A[0,0]", -2.0)
    x = plant.step(0.0, plant.x0, 1.0, 0.1)
    assert x[0] == pytest.approx(-np.expm1(-0.2) / 2, rel=1e-14)
    with pytest.raises(ValueError, match=r"allowed: A\[i,j\], B\[i\], C\[i\]"):
        plant.set_param("A[1,0]", 1.0)


# --- ODE ------------------------------------------------------------------------------------


def test_ode_python_and_numba_functions_give_the_same_trajectory():
    params = {"k": 9.81, "c": 0.3}
    py = _run(ODE(_pendulum, _angle, (1.0, 0.0), params), 0.2, 1e-3, 500)
    jit = _run(ODE(numba.njit(_pendulum), numba.njit(_angle), (1.0, 0.0), params), 0.2, 1e-3, 500)
    np.testing.assert_allclose(jit, py, rtol=1e-14, atol=1e-15)


def test_ode_rk4_against_a_linear_closed_form():
    # x' = -k x + u: a first-order lag through the generic path
    plant = ODE(lambda t, x, u, p: -p[0] * x + u, lambda x, p: x[0], 0.0, {"k": 2.0})
    h, n = 1e-2, 200
    y = [plant.output(x) for x in _run(plant, 1.0, h, n)]
    np.testing.assert_allclose(y, -np.expm1(-2.0 * h * np.arange(n + 1)) / 2, rtol=1e-8)


def test_ode_receives_time():
    # x' = t: x(t) = t^2 / 2, which RK4 integrates exactly
    plant = ODE(lambda t, x, u, p: np.array([t]), lambda x, p: x[0], 0.0)
    assert plant.output(_run(plant, 0.0, 0.1, 10)[-1]) == pytest.approx(0.5, rel=1e-14)


def test_ode_checks_what_f_returns_and_its_params():
    with pytest.raises(ValueError, match="returned shape"):
        ODE(lambda t, x, u, p: np.zeros(3), lambda x, p: x[0], (0.0, 0.0))
    with pytest.raises(ValueError, match="k = inf: must be a finite number"):
        ODE(_pendulum, _angle, (0.0, 0.0), {"k": float("inf")})
    plant = ODE(_pendulum, _angle, (0.0, 0.0), {"k": 1.0, "c": 0.0}, state_names=("th", "om"))
    assert plant.state_names == ("th", "om")
    with pytest.raises(ValueError, match="unknown parameter; allowed: k, c"):
        plant.set_param("m", 1.0)


@pytest.mark.parametrize(("f", "g", "told"), [
    (lambda t, x, u, p: [x[1], u], lambda x, p: x[0], r"f\(t, x, u, p\) at x = x0.*index 1"),
    (lambda t, x, u, p: [-p["k"] * x[0] + u], lambda x, p: x[0], "only integers"),
    (lambda t, x, u, p: [u], lambda x, p: x[0] + p[2], r"g\(x, p\).*index 2"),
])
def test_an_ode_indexing_past_x0_or_params_says_what_x_and_p_hold(f, g, told):
    # review (issue 28): numpy's bare IndexError named neither x0 nor the params
    with pytest.raises(ValueError, match=told) as info:
        ODE(f, g, x0=[0.0], params={"k": 2.0, "c": 0.1})
    assert "1 state(s) of x0 (x[0] .. x[0])" in str(info.value)
    assert "(p[0] = k, p[1] = c)" in str(info.value)


# --- parameters and validation --------------------------------------------------------------


def test_set_param_changes_the_dynamics():
    plant = Buck()
    x = np.array([1.0, 5.0])
    before = plant.step(0.0, x, 0.5, 1e-6)
    plant.set_param("R", 5.0)
    after = plant.step(0.0, x, 0.5, 1e-6)
    assert plant.params["R"] == 5.0 and after[1] < before[1]  # more load current drawn
    # back to where it was: the derived coefficients follow the parameters
    plant.set_param("R", 10.0)
    np.testing.assert_array_equal(plant.step(0.0, x, 0.5, 1e-6), before)


@pytest.mark.parametrize("make", [Buck, Boost, lambda: FirstOrder(-1.0, 1.0)])
def test_unknown_parameter_names_list_the_allowed_ones(make):
    plant = make()
    with pytest.raises(ValueError, match="unknown parameter; allowed: "
                       + ", ".join(plant.params)):
        plant.set_param("nope", 1.0)


@pytest.mark.parametrize("make, message", [
    (lambda: Buck(L=-1.0), "L = -1.0: must be a finite number > 0"),
    (lambda: Buck(C=0), "C = 0: must be a finite number > 0"),
    (lambda: Boost(R=float("nan")), "R = nan: must be a finite number > 0"),
    (lambda: Buck(E="20"), "E = '20': must be a finite number > 0"),
    (lambda: Buck(coupling="paper"), "coupling = 'paper': must be one of published, textbook"),
    (lambda: Buck(output="current"), "output = 'current': must be one of voltage, power"),
    (lambda: Buck(x0=(1.0,)), r"x0 = \(1.0,\): must be 2 finite numbers \(i_L, v_C\)"),
    (lambda: Buck(integrator="euler"), "integrator = 'euler': must be one of rk4, rk45"),
    (lambda: Buck(integrator="exact"), "integrator = 'exact': must be one of rk4, rk45"),
    (lambda: Boost(rtol=0.0), "rtol = 0.0: must be a finite number > 0"),
    (lambda: FirstOrder(a=float("inf"), b=1.0), "a = inf: must be a finite number"),
    (lambda: FirstOrder(-1.0, True), "b = True: must be a finite number"),
])
def test_invalid_values_name_the_parameter(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_invalid_set_param_values_are_rejected_and_leave_the_plant_unchanged():
    plant = Boost()
    with pytest.raises(ValueError, match="C = -1e-06: must be a finite number > 0"):
        plant.set_param("C", -1e-6)
    assert plant.params["C"] == 10e-6


def test_unknown_keywords_are_type_errors():
    with pytest.raises(TypeError):
        Buck(Rload=5.0)
    with pytest.raises(TypeError):
        Plant()  # abstract


def test_docstring_examples():
    failed, attempted = doctest.testmod(models, optionflags=doctest.ELLIPSIS)
    assert attempted > 0 and failed == 0
