"""The loop's elements as Python objects: the sensor, the actuator and the disturbance
that :func:`mfcontrol.simulate_loop` and :func:`mfcontrol.sweep` put around a plant and a
controller, with the options and checks of the case keys ``[sensor]``, ``[actuator]``
and ``[disturbance]`` (the user guide's option table); the engine runs them
(:mod:`mfcontrol.elements`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import MISSING, dataclass, field, fields

import numpy as np

from ...config import options
from ...config.reads import CHOICES
from ...config.resolve import check_elements, check_value
from ...elements import disturbance, layout, noise


def _checked(obj, section: str) -> None:
    """Every field through its case key's check, then the checks across them, as a case
    file's (one-line errors naming the key); then a field given (other than its default)
    that the element would not read under the others is refused, as a case file's key
    that the run would not read."""
    keys = {}
    for f in fields(obj):
        value = getattr(obj, f.name)
        if isinstance(value, np.ndarray):
            value = value.tolist()
        keys[f"{section}.{f.name}"] = check_value(f"{section}.{f.name}", value)
        object.__setattr__(obj, f.name, keys[f"{section}.{f.name}"])
    check_elements(keys)
    given = {f"{section}.{f.name}": getattr(obj, f.name) for f in fields(obj)
             if getattr(obj, f.name) != _default(f)}
    unused = {key: v for key, v in given.items() if unread(key, keys)}
    if unused:  # worded as a case's key (what to set), from the element's choices
        from ...config.reads import refuse_unread
        from ...config.resolve import resolve

        def reads(cfg) -> set[str]:
            return {key for key in keys if not unread(key, cfg)}

        # (as a case's keys but the delays, checked against a case's run length)
        cfg = resolve({k: v for k, v in given.items() if not k.endswith(".delay")})
        refuse_unread(cfg, unused, reads,
                      among=[k for k in CHOICES if k.startswith(section + ".")])


def _default(f) -> object:
    return f.default_factory() if f.default is MISSING else f.default


@dataclass(frozen=True)
class Sensor:
    """What the controller receives of the plant's output y: ``y_meas[k] = s_{k - delay}``
    with ``s_k = Q(y_k + n_k)`` (:mod:`mfcontrol.elements.sensor`). ``noise`` not given is
    ``"gaussian"`` with a ``noise_std`` other than 0, else ``"none"``; an option the
    sensor would not read (a seed without noise) is refused.

    Examples
    --------
    >>> import mfcontrol
    >>> s = mfcontrol.Sensor(noise="gaussian", noise_std=0.01, seed=3, delay=2)
    >>> s.delay
    2
    """

    noise: str | None = None
    noise_std: float = 0.0
    seed: int = 0
    quantum: float = 0.0
    delay: int = 0

    def __post_init__(self):
        if self.noise is None:  # a noise level given means gaussian noise, as in a case
            object.__setattr__(self, "noise", "none" if self.noise_std == 0 else "gaussian")
        _checked(self, "sensor")


@dataclass(frozen=True)
class Actuator:
    """What reaches the plant of the controller's output u: delayed by ``delay`` samples
    (0 before the first command arrives), then moved at most ``rate_limit`` (units per
    second; 0: none) from the last value (:mod:`mfcontrol.elements.actuator`)."""

    delay: int = 0
    rate_limit: float = 0.0

    def __post_init__(self):
        _checked(self, "actuator")


@dataclass(frozen=True)
class Disturbance:
    """d(t) added to the plant's input (``at="input"``, after the actuator) or to its
    output y (``at="output"``; the metrics judge that y): ``kind`` step (``amplitude``
    from ``t0`` on), ramp (``amplitude (t - t0)``), sine (``amplitude sin(2 pi
    frequency (t - t0))``) or table (linear in ``times``/``values``, held outside;
    :mod:`mfcontrol.elements.disturbance`). An option its kind does not read (an
    amplitude without a kind, a frequency but for a sine) is refused.

    Examples
    --------
    >>> import mfcontrol
    >>> load = mfcontrol.Disturbance("step", amplitude=-0.5, t0=1.0, at="input")
    >>> load.kind, load.at
    ('step', 'input')
    """

    kind: str = "none"
    amplitude: float = 0.0
    t0: float = 0.0
    frequency: float = 0.0
    times: Sequence[float] = field(default_factory=list)
    values: Sequence[float] = field(default_factory=list)
    at: str = "input"

    def __post_init__(self):
        _checked(self, "disturbance")


def _document(cls: type, section: str) -> None:
    """Each field's documentation is its case key's (config/options.py), not a copy."""
    keys = [f"{section}.{f.name}" for f in fields(cls)]
    cls.__doc__ = options.with_parameters(cls.__doc__, options.numpydoc_parameters(keys))


for _cls, _section in ((Sensor, "sensor"), (Actuator, "actuator"),
                       (Disturbance, "disturbance")):
    _document(_cls, _section)


def unread(key: str, settings) -> str:
    """Why an element option ``key`` (``"sensor.seed"``, ...) has no effect under the
    other options ``settings`` (a mapping of the dotted keys), "" when it has one: a
    sweep over it would give identical members."""
    section, _, name = key.partition(".")
    if section == "sensor" and name in ("noise_std", "seed") \
            and settings["sensor.noise"] == "none":
        return "sensor.noise is none"
    if section == "disturbance" and name != "kind":
        kind = settings["disturbance.kind"]
        if kind == "none":
            return "disturbance.kind is none"
        if name == "frequency" and kind != "sine":
            return f"only a sine has a frequency (disturbance.kind is {kind})"
        if name in ("amplitude", "t0") and kind == "table":
            return "a table has times and values"
        if name in ("times", "values") and kind != "table":
            return f"only a table has times and values (disturbance.kind is {kind})"
    return ""


#: the elements' defaults, none acting: made and checked once, for every element not given
_DEFAULTS = (Sensor(), Actuator(), Disturbance())


def column(sensor: Sensor | None = None, actuator: Actuator | None = None,
           disturbance_: Disturbance | None = None, substeps: int = 1) -> np.ndarray:
    """One member's elements as the engine's LP column
    (:mod:`mfcontrol.elements.layout`)."""
    s = sensor or _DEFAULTS[0]
    a = actuator or _DEFAULTS[1]
    d = disturbance_ or _DEFAULTS[2]
    return layout.column(
        noise=noise.KINDS[s.noise or "none"], noise_std=s.noise_std, seed=s.seed, quantum=s.quantum,
        sensor_delay=s.delay, actuator_delay=a.delay, rate_limit=a.rate_limit,
        substeps=substeps, kind=disturbance.KINDS[d.kind], at=disturbance.PLACES[d.at],
        amplitude=d.amplitude, t0=d.t0, frequency=d.frequency, times=d.times,
        values=d.values)
