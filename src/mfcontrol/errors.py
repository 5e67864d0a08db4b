"""Errors raised at the edge of the library, worded for the person who made them."""

import math
import re
from typing import Any


class ConfigError(ValueError):
    """An invalid configuration: the message names the key, the value and what is allowed.

    Parameters
    ----------
    key : str
        The option (a dotted key such as ``"controller.kp"``, or a flag such as ``--dask``).
    value : object
        The value refused.
    allowed : str
        What is allowed, in words.
    limit : int, optional
        Show at most this many characters of the value: for refusals of a value's size
        (a 10 MB description), whose point is that it is too long to print. Otherwise the
        value is shown in full.
    """

    def __init__(self, key: str, value: object, allowed: str, *, limit: int | None = None):
        self.key = key
        self.value = value
        self.allowed = allowed
        super().__init__(f"{key} = {shown(value, limit)}: {allowed}")


def as_float(v: Any) -> float:
    """float(v) of a number given by the user, an integer beyond the float range read as
    infinite (then refused by the caller's finiteness test, never an OverflowError)."""
    try:
        return float(v)
    except OverflowError:
        return math.inf


def shown(value: object, limit: int | None = None) -> str:
    """``repr(value)`` for a one-line message: an integer too long to print (Python refuses
    past 4,300 digits) by its size, a repr over several lines (a 2-D array's) on one;
    with ``limit``, anything longer cut."""
    try:
        text = repr(value)
    except ValueError:  # an integer past the int-to-str limit, or a container holding one
        if isinstance(value, int):
            return f"an integer of {value.bit_length()} bits (beyond the float range)"
        return f"a {type(value).__name__} holding too long an integer"
    if "\n" in text:  # a refusal is one line: numpy puts each row of a matrix on its own
        text = re.sub(r"\s*\n\s*", " ", text)
    if limit is None or len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(text)} characters)"


class CaseError(ValueError):
    """An unknown case name, a missing case file or a file that is not valid TOML."""


class PlantFunctionError(RuntimeError):
    """Your own plant function (an :class:`~mfcontrol.ODE`'s ``f`` or ``g``) raised during a
    run: the message names the function, the time and the state; the exception it raised
    is the ``__cause__``.

    The compiled engine cannot carry an exception out of compiled code: a raising f or g
    makes the member's state or output NaN, which flags the run as diverged at that
    sample. A single run then replays that one step in Python to tell what raised; a
    sweep's member keeps the flag (``diverged``, ``t_diverge``).
    """
