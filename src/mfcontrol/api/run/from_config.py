"""A resolved configuration's loop as the objects the general engine
(:mod:`mfcontrol.api.run.loop`) runs: the plant and its schedule (:func:`plant`,
:func:`changes`, :func:`plant_and_changes`), the controller (:func:`controller`) and the
loop elements' column (:func:`elements`). The parameter columns of the paper's kernels
come from :mod:`mfcontrol.api.params`.
"""

from __future__ import annotations

import numpy as np

from ...config.options import BY_KEY, POSITIONAL
from ...config.resolve import Config, keys_read
from ...elements import layout
from ...errors import ConfigError
from ..model.controllers import ADRC, IP, IPD, IPI, IPID, PID, IntelligentController, RecursiveIP
from ..model.elements import Actuator, Disturbance, Sensor, column, unread
from ..model.plants import LTI, Boost, Buck, DCMotor, FirstOrder
from ..model.schedule import Change, _check_changes
from ..params import recursive_law_column, transfer_function_state_space


def plant(cfg: Config):
    model, integ = cfg["plant.model"], cfg["sim.integrator"]
    if model == "dc-motor":
        return DCMotor(**{k: cfg[f"plant.{k}"] for k in ("J", "friction", "Km", "Ra", "La",
                                                          "load")},
                       x0=(cfg["plant.y0"], cfg["plant.i0"]), integrator=integ)
    if model == "lti":
        return LTI(*transfer_function_state_space(cfg), integrator=integ)
    if model == "first-order":
        return FirstOrder(cfg["plant.a"], cfg["plant.b"], cfg["plant.w"],
                          x0=cfg["plant.y0"], integrator=integ)
    x0 = (cfg["plant.i0"], cfg["plant.v0"])
    electrical = {k: cfg[f"plant.{k}"] for k in ("E", "L", "R", "C")}
    if model == "boost":
        return Boost(**electrical, x0=x0, integrator=integ)
    return Buck(**electrical, coupling=cfg["plant.coupling"], output=cfg["plant.output"],
                x0=x0, integrator=integ)


def controller(cfg: Config) -> IntelligentController | RecursiveIP | PID | ADRC:
    law = cfg["controller.law"]
    limits = (cfg["controller.duty_min"], cfg["controller.duty_max"])
    if law == "adrc":
        return ADRC(cfg["controller.order"], cfg["controller.b0"], cfg["controller.wc"],
                    cfg["controller.wo"], sample_time=cfg["sim.h"], output_limits=limits,
                    delay=cfg["controller.delay"])
    if law == "pid":
        return PID(cfg["controller.kp"], cfg["controller.ki"], cfg["controller.kd"],
                   sample_time=cfg["sim.h"], N=cfg["controller.N"], b=cfg["controller.b"],
                   c=cfg["controller.c"], Tf=cfg["controller.Tf"], Tt=cfg["controller.Tt"],
                   output_limits=limits)
    if law not in POSITIONAL:
        # the controller keys its parameter column reads, given to the live controller
        # (which builds the same column from them)
        read = keys_read(recursive_law_column, cfg, cfg["sim.h"])
        keys = {k.removeprefix("controller.") for k in read if k.startswith("controller.")}
        return RecursiveIP(sample_time=cfg["sim.h"],
                           **{k: cfg[f"controller.{k}"] for k in sorted(keys)})
    options = {
        "sample_time": cfg["sim.h"], "order": cfg["controller.order"],
        "output_limits": limits, "estimator": cfg["controller.estimator"],
        "window": cfg["controller.window"] if cfg["controller.estimator"] == "algebraic"
        else None,
        "anti_windup": ("clamp" if cfg["controller.anti_windup"] == "auto"
                        else cfg["controller.anti_windup"]),
        "gain": cfg["controller.adapt"],
    }
    # the options of a choice made, read only under it (what is read is what matters:
    # mfcontrol show and a run's config.toml print these keys)
    if options["estimator"] == "algebraic" or options["order"] == 2:
        options["kernel"] = cfg["controller.kernel"]
        if options["kernel"] == "delay-reduced":
            options["lag"] = cfg["controller.lag"]
            options["kappa"] = cfg["controller.kappa"]
            options["mu"] = cfg["controller.mu"]
    if options["estimator"] == "algebraic":
        options["startup"] = cfg["controller.startup"]
    options["delay"] = cfg["controller.delay"]
    if options["delay"] > 0:
        options["predict"] = cfg["controller.predict"]
    if options["anti_windup"] == "back-calculation":
        options["k_aw"] = cfg["controller.k_aw"]
    if options["gain"] == "variational":
        options.update(gamma0=cfg["controller.gamma0"], Gamma=cfg["controller.Gamma"],
                       eps_M=cfg["controller.eps_M"], integrator=cfg["controller.integrator"],
                       adapt_every=cfg["controller.adapt_every"])
    if options["gain"] == "rls":
        options.update(forgetting=cfg["controller.forgetting"],
                       alpha_limits=(cfg["controller.alpha_min"], cfg["controller.alpha_max"]))
    # each law reads only its own gains (a translator's reads say what a key affects);
    # an adapting gain starts from gamma0, alpha then unused (the option's default stands
    # in, unread)
    a = BY_KEY["controller.alpha"].default if options["gain"] == "variational" \
        else cfg["controller.alpha"]
    kp = cfg["controller.kp"]
    if law == "i-P":
        return IP(a, kp, **options)
    if law == "i-PI":
        return IPI(a, kp, cfg["controller.ki"], **options)
    if law == "i-PD":
        return IPD(a, kp, cfg["controller.kd"], **options)
    return IPID(a, kp, cfg["controller.ki"], cfg["controller.kd"], **options)


def elements(cfg: Config) -> np.ndarray:
    """The loop's elements (``[sensor]``, ``[actuator]``, ``[disturbance]``,
    ``sim.substeps``) as the engine's LP column."""
    def section(name: str, kind):
        # an option its element's kind does not use is not read (the element's default
        # stands in: the same run)
        return kind(**{k: cfg[f"{name}.{k}"] for k in kind.__dataclass_fields__
                       if not unread(f"{name}.{k}", cfg)})

    return column(section("sensor", Sensor), section("actuator", Actuator),
                  section("disturbance", Disturbance), cfg["sim.substeps"])


def ideal_loop(cfg: Config) -> bool:
    """No sensor, actuator or disturbance element, one integration step per sample: the
    loop the paper's kernels run."""
    return layout.plain(elements(cfg))


#: the converters' load changes: the parameter each adds to and the key it comes from
_LOAD_KEYS = {"R": "plant.dR", "C": "plant.dC"}


def _load_changes(cfg: Config) -> list[Change]:
    """The converters' load changes (R += dR, C += dC at each of ``change_times``)."""
    out = []
    if cfg["plant.model"] in ("buck", "boost"):
        for t in cfg["plant.change_times"]:
            out += [Change(t, name, cfg[key], add=True) for name, key in _LOAD_KEYS.items()]
    return out


def changes(cfg: Config) -> list[Change]:
    """The converters' load changes (R += dR, C += dC) and the general schedule."""
    out = _load_changes(cfg)
    for e in cfg["plant.schedule"]:
        out.append(Change(e["t"], e["name"], e.get("set", e.get("add")), add="add" in e))
    return out


def plant_and_changes(cfg: Config):
    """The plant and its schedule, the schedule checked against the plant's own rules
    (a value that would make a parameter invalid is refused here, at the edge)."""
    p, ch = plant(cfg), changes(cfg)
    try:  # the load changes alone: a failure is their key's (plant.dR, plant.dC)
        _check_changes(p, _load_changes(cfg))
    except ConfigError as exc:
        key = _LOAD_KEYS[exc.key]
        raise ConfigError(key, cfg[key], f"must leave {exc.key} "
                          f"{exc.allowed.removeprefix('must be ')} at each change "
                          f"(it would be {exc.value!r})") from None
    try:
        _check_changes(p, ch)
    except ConfigError as exc:
        raise ConfigError("plant.schedule", f"{exc.key} = {exc.value!r}", exc.allowed) from None
    return p, ch
