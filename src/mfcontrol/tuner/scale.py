"""Where a slider puts a number: over log10 of it for a positive gain (a gain is tuned in
decades), in whole steps for a whole-number option, linearly otherwise. Pure arithmetic,
no web code: the page's sliders move a coordinate, these turn it into the value and back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ..config.options import BY_KEY
from .session import DIGITS, log_scale

#: decades either side of a gain's value on its slider; one for a plant or a time
DECADES_GAIN = 2.0
DECADES_OTHER = 1.0
#: positions of a linear slider
LINEAR_STEPS = 200
#: the largest magnitude a slider offers: the largest float that is still one when shown
#: to DIGITS digits (1.798e308 is not: it reads back as inf)
LARGEST = 1.797e308
#: the log slider's ends: a coordinate past them is no float (or 0) at all
MAX_LOG, MIN_LOG = math.log10(LARGEST), -323.0


@dataclass(frozen=True)
class Scale:
    """A slider's range for an option around a value.

    Attributes
    ----------
    start, end, step : float
        The slider's coordinate range and step.
    log : bool
        The coordinate is log10 of the value.
    whole : bool
        The value is a whole number.
    """

    start: float
    end: float
    step: float
    log: bool = False
    whole: bool = False

    def coordinate(self, value: float) -> float:
        """The slider position of a value, clipped to the range."""
        c = math.log10(value) if self.log else float(value)
        return min(max(c, self.start), self.end)

    def value(self, coordinate: float) -> float | int:
        """The option's value at a slider position, rounded to
        :data:`~mfcontrol.tuner.session.DIGITS` significant digits (whole numbers for a
        whole-number option). Never raises: a position the browser sent past the float
        range gives inf, one that is no number NaN, which the option then refuses in
        words (an exception here would end in the server's log, the page silent)."""
        if not math.isfinite(coordinate):
            return math.nan
        if self.whole:
            return int(round(coordinate))
        if self.log:
            try:
                v = 10.0 ** coordinate
            except OverflowError:
                return math.inf
        else:  # on a step, within the range (a step past the largest float is inf)
            v = min(max(round(coordinate / self.step) * self.step, self.start), self.end)
        return float(f"{v:.{DIGITS}g}")

    def holds(self, value: Any) -> bool:
        """Whether the slider can show this value (on its scale, within its range)."""
        if value is None or isinstance(value, bool) or not isinstance(value, int | float):
            return False
        if self.log and not value > 0:
            return False
        c = math.log10(value) if self.log else float(value)
        return self.start <= c <= self.end


def scale_for(key: str, value: Any) -> Scale:
    """The slider range of an option around its value: log10 of a positive gain (or of
    an option that must be positive) over :data:`DECADES_GAIN` decades either side
    (:data:`DECADES_OTHER` outside the controller); whole numbers from the least allowed
    to 4x the value (at least 20 more); otherwise value +- 2 |value| (+-1 at 0), not below
    0 for an option that must be >= 0, in :data:`LINEAR_STEPS` steps. Neither goes past
    :data:`LARGEST` (a typed 1e308 put the end of its slider at 1e310). An unset option
    (None) gets 0 .. 1."""
    o = BY_KEY[key]
    if value is None:
        return Scale(0.0, 1.0, 1.0 / LINEAR_STEPS)
    if o.kind == "int":
        low = 1 if o.check == "positive" else (0 if o.check == "nonnegative" else
                                               min(value, 0) - 20)
        return Scale(float(low), float(max(4 * value, value + 20)), 1.0, whole=True)
    v = float(value)
    if log_scale(key, v):
        d = DECADES_GAIN if key.startswith("controller.") else DECADES_OTHER
        c = math.log10(v)
        return Scale(max(c - d, MIN_LOG), min(c + d, MAX_LOG), 0.01, log=True)
    half = 2.0 * abs(v) if v != 0 else 1.0
    if not math.isfinite(v - half) or not math.isfinite(v + half):
        half = 0.5 * abs(v)  # near the largest float: a range the slider can still hold
    low, high = max(v - half, -LARGEST), min(v + half, LARGEST)
    if o.check in ("nonnegative", "positive", "fraction"):
        low = max(low, 0.0)
    if o.check == "fraction":
        high = min(high, 1.0)
    return Scale(low, high, (high - low) / LINEAR_STEPS)
