"""Plant and controller objects, and the schedule, built from a resolved configuration:
what the general engine (:mod:`mfcontrol.loop`, :mod:`mfcontrol.engine.compose`) runs."""

from __future__ import annotations

from .config import POSITIONAL, Config
from .controller import IP, IPD, IPI, IPID, IntelligentController, RecursiveIP
from .loop import Change


def plant(cfg: Config):
    from .plants.models import Boost, Buck, FirstOrder

    model, integ = cfg["plant.model"], cfg["sim.integrator"]
    if model == "first-order":
        return FirstOrder(cfg["plant.a"], cfg["plant.b"], cfg["plant.w"],
                          x0=cfg["plant.y0"], integrator=integ)
    x0 = (cfg["plant.i0"], cfg["plant.v0"])
    electrical = {k: cfg[f"plant.{k}"] for k in ("E", "L", "R", "C")}
    if model == "boost":
        return Boost(**electrical, x0=x0, integrator=integ)
    return Buck(**electrical, coupling=cfg["plant.coupling"], output=cfg["plant.output"],
                x0=x0, integrator=integ)


def controller(cfg: Config) -> IntelligentController | RecursiveIP:
    law = cfg["controller.law"]
    limits = (cfg["controller.duty_min"], cfg["controller.duty_max"])
    if law not in POSITIONAL:
        keys = ("law", "gamma0", "Gamma", "eps_M", "k_gamma", "integrator", "rate_term",
                "rate_sign", "gain", "deriv_scale", "output_gain", "duty_min", "duty_max",
                "p_sample", "p_error", "u0", "anti_windup", "k_aw")
        return RecursiveIP(cfg["controller.alpha"], cfg["controller.kp"],
                           **{k: cfg[f"controller.{k}"] for k in keys})
    options = {
        "sample_time": cfg["sim.h"], "order": cfg["controller.order"],
        "output_limits": limits, "estimator": cfg["controller.estimator"],
        "window": cfg["controller.window"] if cfg["controller.estimator"] == "algebraic"
        else None,
        "anti_windup": ("clamp" if cfg["controller.anti_windup"] == "auto"
                        else cfg["controller.anti_windup"]),
        "k_aw": cfg["controller.k_aw"], "gain": cfg["controller.adapt"],
        "gamma0": cfg["controller.gamma0"], "Gamma": cfg["controller.Gamma"],
        "eps_M": cfg["controller.eps_M"], "integrator": cfg["controller.integrator"],
    }
    a, kp, ki, kd = (cfg[f"controller.{k}"] for k in ("alpha", "kp", "ki", "kd"))
    if law == "i-P":
        return IP(a, kp, **options)
    if law == "i-PI":
        return IPI(a, kp, ki, **options)
    if law == "i-PD":
        return IPD(a, kp, kd, **options)
    return IPID(a, kp, ki, kd, **options)


def changes(cfg: Config) -> list[Change]:
    """The converters' load changes (R += dR, C += dC) and the general schedule."""
    out = []
    if cfg["plant.model"] in ("buck", "boost"):
        for t in cfg["plant.change_times"]:
            out += [Change(t, "R", cfg["plant.dR"], add=True),
                    Change(t, "C", cfg["plant.dC"], add=True)]
    for e in cfg["plant.schedule"]:
        out.append(Change(e["t"], e["name"], e.get("set", e.get("add")), add="add" in e))
    return out


def plant_and_changes(cfg: Config):
    """The plant and its schedule, the schedule checked against the plant's own rules
    (a value that would make a parameter invalid is refused here, at the edge)."""
    from .errors import ConfigError
    from .loop import _check_changes

    p, ch = plant(cfg), changes(cfg)
    try:
        _check_changes(p, ch)
    except ConfigError as exc:
        raise ConfigError("plant.schedule", f"{exc.key} = {exc.value!r}", exc.allowed) from None
    return p, ch
