"""The time grid: which sample an event falls on."""

import math

import pytest

from mfcontrol.errors import ConfigError
from mfcontrol.numerics import grid
from mfcontrol.numerics.grid import first_sample_at


def test_an_event_falls_on_the_first_sample_at_or_after_it():
    assert first_sample_at(0.0, 1.0, 10) == 0
    assert first_sample_at(0.25, 1.0, 10) == 3  # t_3 = 0.3
    assert first_sample_at(0.3, 1.0, 10) == 3


def test_an_event_past_the_end_is_never_even_at_1e308():
    assert first_sample_at(1e308, 1.0, 10) == 10  # was an OverflowError
    assert first_sample_at(math.inf, 1.0, 10) == 10
    assert first_sample_at(0.95, 1.0, 10) == 10  # after the last sample, t_9 = 0.9


def test_a_recorded_run_too_large_is_refused_with_its_figure():
    grid.check_recording(1_000_000, 12, 1.0, "sim.t_end")  # 96 MB: fine
    with pytest.raises(ConfigError, match=r"sim.t_end = 100.0: 100,000,000 samples of 10 "
                                          r"recorded signals would take 7.5 GiB"):
        grid.check_recording(100_000_000, 10, 100.0, "sim.t_end")


def test_simulate_loop_refuses_a_horizon_it_cannot_record():
    import mfcontrol

    plant = mfcontrol.FirstOrder(a=-1.0, b=1.0)
    for ctrl in (mfcontrol.IP(1.0, 1.0, sample_time=1e-3),  # the compiled engine
                 lambda y, setpoint=None: 0.0):  # the Python driver
        with pytest.raises(ConfigError, match=r"^t_end = 50000.0: 50,000,000 samples"):
            mfcontrol.simulate_loop(plant, ctrl, 1.0, t_end=5e4, h=1e-3)
