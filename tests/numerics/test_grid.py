"""The time grid: which sample an event falls on."""

import math

from mfcontrol.numerics.grid import first_sample_at


def test_an_event_falls_on_the_first_sample_at_or_after_it():
    assert first_sample_at(0.0, 1.0, 10) == 0
    assert first_sample_at(0.25, 1.0, 10) == 3  # t_3 = 0.3
    assert first_sample_at(0.3, 1.0, 10) == 3


def test_an_event_past_the_end_is_never_even_at_1e308():
    assert first_sample_at(1e308, 1.0, 10) == 10  # was an OverflowError
    assert first_sample_at(math.inf, 1.0, 10) == 10
    assert first_sample_at(0.95, 1.0, 10) == 10  # after the last sample, t_9 = 0.9
