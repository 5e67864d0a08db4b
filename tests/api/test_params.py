"""The translator's transfer-function plant (``plant.model = "lti"``)."""

import warnings

import control
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import mfcontrol
from mfcontrol.api import params
from mfcontrol.api.run import from_config

LTI = {"plant.model": "lti", "controller.law": "pid", "controller.kp": 1.0,
       "controller.ki": 0.5, "reference.kind": "smooth-step", "sim.h": 0.01,
       "sim.t_end": 20.0, "sim.integrator": "exact", "controller.duty_min": -10.0,
       "controller.duty_max": 10.0}


@pytest.mark.parametrize(("num", "den", "gain", "tau"), [
    ([1.0], [1.0, 3.0, 3.0, 1.0], 1.0, 1.0),
    ([-0.5, 1.0], [1.0, 3.0, 3.0, 1.0], 2.0, 1.5),
    ([0.0, 2.0], [4.0, 1.0], 1.0, 0.5),
    ([1.0], [1.0, 0.0], 0.7, 2.0),
])
def test_state_space_is_the_scaled_transfer_function(num, den, gain, tau):
    cfg = mfcontrol.resolve({**LTI, "plant.num": num, "plant.den": den, "plant.gain": gain,
                             "plant.time_scale": tau})
    A, B, C = params.transfer_function_state_space(cfg)
    got = control.ss2tf(A, B.reshape(-1, 1), C.reshape(1, -1), 0.0)
    # K G(tau s) at a few complex frequencies, against python-control's G
    g = control.tf(num, den)
    for w in (0.1j, 0.7 + 1j, 3j):
        assert np.isclose(got(w), gain * g(tau * w), rtol=1e-10)


def test_an_lti_run_equals_the_same_plant_given_as_an_object():
    cfg = mfcontrol.resolve({**LTI, "plant.num": [1.0], "plant.den": [1.0, 3.0, 3.0, 1.0]})
    run = mfcontrol.simulate(cfg)
    plant = mfcontrol.LTI(*params.transfer_function_state_space(cfg), integrator="exact")
    loop = mfcontrol.simulate_loop(plant, from_config.controller(cfg), t_end=20.0, h=0.01,
                                   reference=1.0)
    assert run.metrics["settled"]
    assert np.array_equal(run.signals["u"], loop.signals["u"])


@pytest.mark.parametrize(("settings", "key", "needle"), [
    ({"plant.num": [1.0, 0.0], "plant.den": [1.0, 1.0]}, "plant.num", "strictly proper"),
    ({"plant.num": [0.0], "plant.den": [1.0, 1.0]}, "plant.num", "nonzero"),
    ({"plant.den": [0.0, 1.0]}, "plant.den", "first is nonzero"),
    ({"plant.den": [2.0]}, "plant.den", "degree >= 1"),
    ({"plant.time_scale": 0.0}, "plant.time_scale", "> 0"),
    ({"plant.schedule": [{"t": 1.0, "name": "gain", "set": 2.0}]}, "plant.schedule",
     "[disturbance]"),
    ({"plant.model": "buck"}, "sim.integrator", "zero-order hold"),
])
def test_bad_transfer_functions_are_named(settings, key, needle):
    with pytest.raises(mfcontrol.ConfigError) as info:
        mfcontrol.resolve({**LTI, **settings})
    assert info.value.key == key and needle in str(info.value)


_coefficient = st.floats(-1e3, 1e3, allow_nan=False).filter(lambda c: c == 0 or abs(c) > 1e-3)


@settings(max_examples=300, deadline=None)
@given(st.lists(_coefficient, min_size=1, max_size=6), st.lists(_coefficient, min_size=2,
       max_size=7), st.floats(1e-3, 1e3), st.sampled_from([1.0, 1e-8, 1e8]))
def test_the_realisation_has_the_bits_of_scipys_tf2ss(num, den, tau, scale):
    from scipy import signal

    # scaled as the translator scales K G(tau s): tiny and huge coefficients included
    den = np.array(den) * tau ** np.arange(len(den) - 1, -1, -1.0)
    num = np.array(num) * scale * tau ** np.arange(len(num) - 1, -1, -1.0)
    den = np.trim_zeros(den, "f")
    num = np.trim_zeros(num, "f")
    assume(den.size >= 2 and num.size >= 1 and num.size < den.size)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", signal.BadCoefficients)
        want = signal.tf2ss(num, den)[:3]
    got = params.controllable_canonical(num, den)
    for w, g in zip(want, got, strict=True):
        np.testing.assert_array_equal(np.asarray(w).reshape(-1).view(np.uint64),
                                      np.asarray(g).reshape(-1).view(np.uint64))
    assert got[0].shape == want[0].shape and got[1].shape == (den.size - 1,)


def test_a_time_scale_that_underflows_the_denominator_is_named():
    # tau^3 underflows: the scaled denominator loses its leading coefficient and the
    # transfer function its strict properness
    cfg = mfcontrol.resolve({**LTI, "plant.num": [1.0, 0.0, 0.0], "plant.den": [1.0, 3.0,
                             3.0, 1.0], "plant.time_scale": 1e-110})
    with pytest.raises(mfcontrol.ConfigError) as info:
        params.transfer_function_state_space(cfg)
    assert info.value.key == "plant.time_scale"
