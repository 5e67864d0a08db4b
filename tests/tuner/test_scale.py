"""Where a slider puts a number."""

from __future__ import annotations

import math

from mfcontrol.tuner.scale import DECADES_GAIN, scale_for


def test_a_gain_is_slid_over_decades_of_log10():
    s = scale_for("controller.alpha", 10.0)
    assert s.log and (s.start, s.end) == (1.0 - DECADES_GAIN, 1.0 + DECADES_GAIN)
    assert s.coordinate(10.0) == 1.0
    assert s.value(math.log10(2.0417379446695296)) == 2.042  # four digits
    assert s.value(1.0) == 10.0


def test_a_plant_value_spans_one_decade_and_a_signed_one_is_linear():
    s = scale_for("plant.R", 10.0)
    assert s.log and s.end - s.start == 2.0
    lin = scale_for("plant.dR", 1.0)
    assert not lin.log and (lin.start, lin.end) == (-1.0, 3.0)
    zero = scale_for("plant.v0", 0.0)
    assert (zero.start, zero.end) == (-1.0, 1.0)
    assert scale_for("actuator.rate_limit", 0.0).start == 0.0  # must be >= 0


def test_a_whole_number_steps_by_one():
    s = scale_for("controller.window", 20)
    assert s.whole and s.step == 1.0 and s.start == 1.0 and s.end == 80.0
    assert s.value(33.4) == 33 and isinstance(s.value(33.4), int)


def test_holds_tells_when_the_slider_must_move():
    s = scale_for("controller.kp", 2.0)
    assert s.holds(3.0) and not s.holds(-1.0) and not s.holds(1e6) and not s.holds(None)
    assert scale_for("controller.kp", -1.0).holds(-2.0)  # a negative gain: linear


def test_a_huge_value_gets_a_finite_slider():
    """plant.dR = 1e308 gave the slider the range -inf .. inf (review)."""
    import math

    s = scale_for("plant.dR", 1e308)
    assert math.isfinite(s.start) and math.isfinite(s.end) and s.start < 1e308 < s.end


def test_no_slider_reaches_past_the_floats_and_no_position_raises():
    """Issue 29: a typed 1e308 put alpha's slider end at 10^310 (an OverflowError when
    slid there) and a linear slider's end at inf."""
    for key, v in (("controller.alpha", 1e308), ("plant.R", 1.7e308),
                   ("plant.i0", 1.7e308), ("plant.i0", -1.7e308)):
        s = scale_for(key, v)
        for end in (s.start, s.end):
            assert math.isfinite(end) and math.isfinite(s.value(end)), (key, v, end)
    s = scale_for("controller.alpha", 1e308)
    assert s.value(s.end + 2.0) == math.inf  # a position the browser sent: refused later
    assert math.isnan(s.value(math.nan)) and math.isnan(scale_for("sensor.delay", 3).value(
        math.inf))
