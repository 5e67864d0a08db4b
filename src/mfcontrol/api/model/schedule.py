"""A plant's scheduled parameter changes: :class:`Change`, a schedule's check against the
plant (:func:`_check_changes`), and :func:`restored`, which gives a plant back its
parameters after a run, a sweep member or a check has changed them.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

from ...errors import ConfigError


@dataclass(frozen=True)
class Change:
    """At the first sample with t_k >= ``time``, set plant parameter ``name`` to ``value``
    (or add ``value`` to it when ``add`` is true).

    Parameters
    ----------
    time : float
        When (s); applied before that sample's plant step.
    name : str
        A parameter of the plant (``plant.params``' keys, e.g. ``"R"`` of a buck).
    value : float
        The new value, or the increment when ``add``.
    add : bool
        Add ``value`` to the parameter instead of setting it.

    Examples
    --------
    >>> import mfcontrol
    >>> load = mfcontrol.Change(5.0, "tau", 0.05)  # a DC motor's load torque from 5 s
    >>> load.time, load.add
    (5.0, False)
    """

    time: float
    name: str
    value: float
    add: bool = False


@contextmanager
def restored(plant):
    """Within the block, change the plant's parameters at will; afterwards they are as
    they were (a schedule, a sweep member, a check acts on one run only)."""
    original = dict(plant.params)
    try:
        yield original
    finally:
        _restore(plant, original)


def _restore(plant, original: Mapping[str, float]) -> None:
    """Set back every parameter of the plant that differs from ``original``."""
    now = plant.params  # built anew at each read (an ODE's): read once
    for key, value in original.items():
        if now[key] != value:
            plant.set_param(key, value)


def _check_changes(plant, changes: Sequence[Change]) -> None:
    """Every change names a parameter of the plant and leaves it valid (the plant's own
    checks, applied in order to the plant and undone)."""
    global _last_passed
    if not changes:
        return
    changes = tuple(changes)
    original = dict(plant.params)
    last = _last_passed  # read once: another thread may replace it
    if last is not None and last[0]() is plant and last[1] == original and last[2] == changes:
        return
    try:  # restored's work, without its generator (every run of a schedule checks it)
        for c in changes:
            if not isinstance(c, Change):
                raise TypeError(f"changes: {c!r} is not a mfcontrol.Change")
            if not (isinstance(c.time, int | float) and math.isfinite(c.time)):
                raise ConfigError("Change.time", c.time, "must be a finite number (s)")
            if c.name not in original:
                raise ConfigError(c.name, c.value, "unknown parameter; allowed: "
                                  + (", ".join(original) or "none"))
            plant.set_param(c.name, plant.params[c.name] + c.value if c.add else c.value)
    finally:
        _restore(plant, original)
    try:
        _last_passed = (weakref.ref(plant), original, changes)
    except TypeError:  # a plant without weak references: checked at every run
        pass


#: the last schedule that passed (:func:`_check_changes`): (a weak reference to the plant,
#: its parameters then, the changes). The same changes on the same plant with the same
#: parameters pass again without being applied and undone (a run repeated in a loop)
_last_passed: tuple | None = None
