"""The general closed loop with plant objects."""

import math

import numpy as np
import pytest

import mfcontrol
from mfcontrol import Change, simulate_loop
from mfcontrol.api.model.plants import LTI, FirstOrder

control = pytest.importorskip("control")


def test_scheduled_change_acts_and_the_plant_is_left_as_given():
    plant = FirstOrder(a=-1.0, b=1.0, w=0.0)
    ctrl = mfcontrol.IP(alpha=1.0, kp=10.0, sample_time=1e-3)
    res = simulate_loop(plant, ctrl, 1.0, t_end=1.0,
                        changes=[Change(0.5, "w", 2.0), Change(0.7, "w", -1.0, add=True)])
    assert plant.params["w"] == 0.0
    F = res.signals["F_hat"]
    t = res.time
    assert abs(F[(t > 0.45) & (t < 0.5)].mean() - (-1.0)) < 0.05   # F = a y + w, y ~ 1
    assert abs(F[(t > 0.65) & (t < 0.7)].mean() - 1.0) < 0.05
    assert abs(F[t > 0.9].mean() - 0.0) < 0.05
    assert res.metrics["settled"]


def test_a_schedule_that_passed_is_checked_again_once_the_plant_has_changed():
    # a schedule that passed on a plant is not applied and undone again while the plant
    # keeps its parameters; once they change, it is: here the same addition overflows
    plant = FirstOrder(a=-1.0, b=1.0, w=0.0)
    changes = [Change(0.5, "w", 1e308, add=True)]
    for _ in range(2):
        simulate_loop(plant, mfcontrol.IP(alpha=1.0, kp=10.0, sample_time=1e-3), 1.0,
                      t_end=0.01, changes=changes)
    plant.set_param("w", 1e308)
    with pytest.raises(mfcontrol.ConfigError, match="^w = inf: must be a finite number"):
        simulate_loop(plant, mfcontrol.IP(alpha=1.0, kp=10.0, sample_time=1e-3), 1.0,
                      t_end=0.01, changes=changes)
    assert plant.params["w"] == 1e308


def test_python_control_transfer_function_as_plant():
    plant = LTI.from_control(control.tf([2.0], [1.0, 3.0]))     # 2 / (s + 3)
    res = simulate_loop(plant, mfcontrol.IP(alpha=2.0, kp=8.0, sample_time=1e-3), 0.5,
                        t_end=1.5)
    # F = -3 y is estimated one sample late; the error still decays as exp(-kp t)
    t = res.time
    late = t > 0.2
    expected = 0.5 * np.exp(-8.0 * t[late])
    np.testing.assert_allclose(-res.error[late], expected, rtol=0.02)


def test_python_control_system_passed_directly():
    sys = control.tf([2.0], [1.0, 3.0])
    a = simulate_loop(sys, mfcontrol.IP(alpha=2.0, kp=8.0, sample_time=1e-3), 0.5, t_end=0.2)
    b = simulate_loop(LTI.from_control(sys), mfcontrol.IP(alpha=2.0, kp=8.0, sample_time=1e-3),
                      0.5, t_end=0.2)
    np.testing.assert_array_equal(a.signals["y"], b.signals["y"])


def test_rk45_and_rk4_agree():
    a = simulate_loop(FirstOrder(-1.0, 1.0, integrator="rk45"),
                      mfcontrol.IP(alpha=1.0, kp=5.0, sample_time=1e-2), 1.0, t_end=1.0)
    b = simulate_loop(FirstOrder(-1.0, 1.0), mfcontrol.IP(alpha=1.0, kp=5.0, sample_time=1e-2),
                      1.0, t_end=1.0)
    np.testing.assert_allclose(a.signals["y"], b.signals["y"], atol=1e-8)


def test_divergence_is_a_flagged_result():
    # kp < 0: the error obeys e' = +50 e and grows without bound
    res = simulate_loop(FirstOrder(a=-1.0, b=1.0), mfcontrol.IP(alpha=1.0, kp=-50.0,
                        sample_time=0.01), 1.0, t_end=5.0, diverge_above=1e6)
    assert res.metrics["diverged"] and not res.metrics["settled"]
    assert res.time.size == res.metrics["n_samples"] < 500
    assert np.all(np.abs(res.signals["y"]) <= 1e6)


def test_reference_as_function_and_array():
    h, n = 1e-3, 500
    t = (np.arange(n) * (n * h)) / n  # the loop's grid: t_k = (k t_end) / N
    f = simulate_loop(FirstOrder(-1.0, 1.0), mfcontrol.IP(1.0, 10.0, sample_time=h),
                      lambda tk: np.sin(2 * tk), t_end=n * h)
    a = simulate_loop(FirstOrder(-1.0, 1.0), mfcontrol.IP(1.0, 10.0, sample_time=h),
                      np.sin(2 * t), t_end=n * h)
    np.testing.assert_array_equal(f.signals["y"], a.signals["y"])


def test_recursive_law_takes_its_period_from_sample_time_or_h():
    from mfcontrol import Buck

    with pytest.raises(mfcontrol.ConfigError, match="h = None: required: the RecursiveIP"):
        mfcontrol.simulate_loop(Buck(), mfcontrol.RecursiveIP(), 2.5, t_end=1e-3)
    a = mfcontrol.simulate_loop(Buck(), mfcontrol.RecursiveIP(sample_time=1e-6), 2.5,
                                t_end=1e-3)
    b = mfcontrol.simulate_loop(Buck(), mfcontrol.RecursiveIP(), 2.5, t_end=1e-3, h=1e-6)
    np.testing.assert_array_equal(a.signals["y"], b.signals["y"])
    # back-calculation sheds k_aw h of the excess: h is the controller's sample_time
    from mfcontrol.laws import recursive_ip

    c = mfcontrol.RecursiveIP(anti_windup="back-calculation", k_aw=1e3, sample_time=1e-5)
    assert c._CP[recursive_ip.AW_COEF, 0] == 1e3 * 1e-5


def test_a_bad_reference_or_alpha_is_a_one_line_error_not_a_divergence():
    # a NaN reference used to come back as a plant that diverged at t = 0
    plant = FirstOrder(a=-1.0, b=1.0)
    ip = mfcontrol.IP(alpha=1.0, kp=5.0, sample_time=0.01)
    with pytest.raises(mfcontrol.ConfigError, match=r"reference = nan: must be finite .*t = 0\.0"):
        simulate_loop(plant, ip, float("nan"), t_end=1.0)
    with pytest.raises(mfcontrol.ConfigError, match=r"reference = inf: .*t = 0\.5"):
        simulate_loop(plant, ip, lambda t: 1.0 if t < 0.5 else math.inf, t_end=1.0)
    with pytest.raises(mfcontrol.ConfigError,
                       match=r"reference = 'an array of shape \(3,\)': .*\(100 samples\)"):
        simulate_loop(plant, ip, [1.0, 2.0, 3.0], t_end=1.0)
    ext = mfcontrol.IP(alpha=1.0, kp=5.0, sample_time=0.01, gain="external")
    for bad in (1e-310, True, "2"):
        with pytest.raises(mfcontrol.ConfigError, match="^alpha = "):
            simulate_loop(plant, ext, 1.0, t_end=1.0, alpha=bad)


def test_your_own_controller_is_given_alpha_at_every_sample():
    # it used to be refused ("only for a controller with gain='external'")
    class Mine:
        def __call__(self, y, setpoint=None, alpha=1.0):
            return (setpoint - y) / alpha

    h, n = 0.01, 100
    res = simulate_loop(FirstOrder(a=-1.0, b=1.0), Mine(), 1.0, t_end=n * h, h=h,
                        alpha=lambda t: 1.0 + t)
    plant, x, us = FirstOrder(a=-1.0, b=1.0), FirstOrder(a=-1.0, b=1.0).x0, []
    for tk in res.time:  # t_k = k t_end / N, the library's grid
        us.append((1.0 - plant.output(x)) / (1.0 + tk))
        x = plant.step(tk, x, us[-1], h)
    np.testing.assert_array_equal(res.signals["u"], us)

    class NoAlpha:
        def __call__(self, y, setpoint=None):
            return 0.0

    with pytest.raises(mfcontrol.ConfigError, match="^alpha = 2.0: your controller must take"):
        simulate_loop(FirstOrder(a=-1.0, b=1.0), NoAlpha(), 1.0, t_end=1.0, h=h, alpha=2.0)


def _same_run(a, b):
    assert list(a.signals) == list(b.signals) and list(a.states) == list(b.states)
    for k in a.signals:
        np.testing.assert_array_equal(a.signals[k], b.signals[k])
    for k in a.states:
        np.testing.assert_array_equal(a.states[k], b.states[k])
    np.testing.assert_array_equal(a.time, b.time)


def test_elements_not_given_are_the_default_elements_bit_for_bit():
    # no element given takes a column built once; the default objects take the checked
    # path: the same run, metrics and controller memory
    from mfcontrol import Actuator, Disturbance, Sensor

    changes = [Change(0.5, "w", 1.0)]
    ctrl_a, ctrl_b = (mfcontrol.IPI(alpha=2.0, kp=8.0, ki=4.0, sample_time=1e-3)
                      for _ in range(2))
    a = simulate_loop(FirstOrder(-1.0, 1.0), ctrl_a, 1.0, t_end=1.0, changes=changes)
    b = simulate_loop(FirstOrder(-1.0, 1.0), ctrl_b, 1.0, t_end=1.0, changes=changes,
                      sensor=Sensor(), actuator=Actuator(), disturbance=Disturbance(),
                      substeps=1)
    _same_run(a, b)
    assert a.metrics == b.metrics
    np.testing.assert_array_equal(ctrl_a._CS, ctrl_b._CS)
    # the column is the run's own: changing it changes no later run
    from mfcontrol.api.run import loop

    loop._elements(n=1000)[:] = 7.0
    assert not np.any(loop._elements(n=1000) == 7.0)


def test_a_constant_reference_or_alpha_is_checked_as_that_value_at_every_sample():
    # a number is checked once, an array at every sample: the same runs, the same errors
    plant = FirstOrder(a=-1.0, b=1.0)
    n = 100

    def run(reference, alpha=None):
        ext = mfcontrol.IP(alpha=1.0, kp=5.0, sample_time=0.01, gain="external")
        return simulate_loop(plant, ext, reference, t_end=n * 0.01, alpha=alpha)

    _same_run(run(1.5, alpha=2.0), run(np.full(n, 1.5), alpha=np.full(n, 2.0)))
    for value in (math.nan, math.inf, -math.inf, 0.0, -0.0, -2.0, 5e-324, 1e308):
        for key in ("reference", "alpha"):
            errors = []
            for given in (value, np.full(n, value)):
                try:
                    run(given, 1.0) if key == "reference" else run(1.0, given)
                except mfcontrol.ConfigError as exc:
                    errors.append(str(exc))
                else:
                    errors.append(None)
            assert errors[0] == errors[1], (key, value, errors)


def test_metric_settings_are_checked_at_every_run():
    # checks that passed are remembered; a failure is not, and numpy's numbers are checked
    plant = FirstOrder(a=-1.0, b=1.0)
    ip = mfcontrol.IP(alpha=1.0, kp=5.0, sample_time=0.01)
    for _ in range(2):
        with pytest.raises(mfcontrol.ConfigError, match="^final_window = 1.5"):
            simulate_loop(plant, ip, 1.0, t_end=1.0, final_window=1.5)
        with pytest.raises(mfcontrol.ConfigError, match="^settled_tol = .*-1.0.*> 0"):
            simulate_loop(plant, ip, 1.0, t_end=1.0, settled_tol=np.float64(-1.0))
        with pytest.raises(mfcontrol.ConfigError, match="^settle_time = True"):
            simulate_loop(plant, ip, 1.0, t_end=1.0, settle_time=True)
    a = simulate_loop(plant, mfcontrol.IP(1.0, 5.0, sample_time=0.01), 1.0, t_end=1.0,
                      final_window=0.5)
    b = simulate_loop(plant, mfcontrol.IP(1.0, 5.0, sample_time=0.01), 1.0, t_end=1.0,
                      final_window=np.float64(0.5))
    assert a.metrics == b.metrics


def test_the_event_arrays_of_members_read_each_schedule_once_and_refuse_a_mismatch():
    from mfcontrol.api.run.loop import _event_arrays

    columns = {"tau": 3, "J": 1}
    shared = [Change(0.5, "tau", 0.05), Change(0.7, "J", 1e-4, add=True)]
    own = [Change(0.25, "tau", 0.1), Change(0.9, "J", 2e-4, add=True)]
    ev_k, ev_col, ev_add, ev_val = _event_arrays([shared, own, shared], columns, 1.0, 100)
    np.testing.assert_array_equal(ev_k, [[50, 25, 50], [70, 90, 70]])
    np.testing.assert_array_equal(ev_val, [[0.05, 0.1, 0.05], [1e-4, 2e-4, 1e-4]])
    np.testing.assert_array_equal(ev_col, [3, 1])
    np.testing.assert_array_equal(ev_add, [False, True])
    ev_k, ev_col, ev_add, ev_val = _event_arrays([[], []], columns, 1.0, 100)
    assert ev_k.shape == ev_val.shape == (0, 2) and ev_col.size == ev_add.size == 0
    for members in ([[], shared], [shared, []], [shared, own[::-1]]):
        with pytest.raises(ValueError, match="must change the same parameters"):
            _event_arrays(members, columns, 1.0, 100)


def test_distinct_finds_each_object_once_in_order_and_where_each_item_is():
    from mfcontrol.api.run.loop import distinct

    a, b, c = [1.0], [1.0], [2.0]  # a and b equal, not the same object
    objs, at = distinct([a, b, a, c, b, a])
    assert len(objs) == 3 and objs[0] is a and objs[1] is b and objs[2] is c
    assert at.tolist() == [0, 1, 0, 2, 1, 0] and at.dtype == np.int64
    objs, at = distinct([])
    assert objs == [] and at.size == 0
    # items made while iterating (rows of an array, a generator's): each is held while
    # distinct runs, so no object's id is taken by the next one
    objs, at = distinct(np.arange(8.0).reshape(4, 2))
    assert len(objs) == 4 and at.tolist() == [0, 1, 2, 3]
    objs, at = distinct(float(x) * 1e300 for x in range(3))
    assert [o / 1e300 for o in objs] == [0.0, 1.0, 2.0] and at.tolist() == [0, 1, 2]
