"""The one translator from a resolved configuration to what the engines run.

* parameter columns of the paper's kernels (:func:`buck_column`,
  :func:`recursive_law_column`, :func:`reference_column`, :func:`buck_state_column`): one
  column per member, or one column per value of a swept key given as an array;
* plant and controller objects and the schedule (:func:`plant`, :func:`controller`,
  :func:`changes`), what the general engine (:mod:`mfcontrol.api.run.loop`) runs. A positional
  law's constructor fills its own parameter column (:mod:`mfcontrol.laws.intelligent`),
  the live :class:`~mfcontrol.api.model.controllers.RecursiveIP` calls
  :func:`recursive_law_column`.
"""

from __future__ import annotations

import math

import numpy as np

from ..config.options import POSITIONAL
from ..config.resolve import Config, keys_read
from ..elements import layout
from ..engine import metrics as engine_metrics
from ..laws import recursive_ip, reference, variational_gain
from ..plants import buck
from .model.controllers import IP, IPD, IPI, IPID, PID, IntelligentController, RecursiveIP
from .model.elements import Actuator, Disturbance, Sensor, column
from .model.schedule import Change


def plant(cfg: Config):
    from .model.plants import LTI, Boost, Buck, DCMotor, FirstOrder

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


def transfer_function_state_space(cfg: Config) -> tuple[np.ndarray, np.ndarray,
                                                         np.ndarray]:
    """(A, B, C) of K G(time_scale s) for the lti model: scipy's controllable canonical
    realisation of the (strictly proper) transfer function ``plant.num / plant.den``, with
    the coefficient of s^i scaled by time_scale^i (every time constant multiplied)."""
    from scipy import signal

    tau = cfg["plant.time_scale"]
    num, den = (np.trim_zeros(np.asarray(cfg[k], dtype=float), "f")
                for k in ("plant.num", "plant.den"))
    num = cfg["plant.gain"] * num * tau ** np.arange(num.size - 1, -1, -1.0)
    den = den * tau ** np.arange(den.size - 1, -1, -1.0)
    A, B, C, _ = signal.tf2ss(num, den)
    return A, B.reshape(-1), C.reshape(-1)


def controller(cfg: Config) -> IntelligentController | RecursiveIP | PID:
    law = cfg["controller.law"]
    limits = (cfg["controller.duty_min"], cfg["controller.duty_max"])
    if law == "pid":
        return PID(cfg["controller.kp"], cfg["controller.ki"], cfg["controller.kd"],
                   sample_time=cfg["sim.h"], N=cfg["controller.N"], b=cfg["controller.b"],
                   Tt=cfg["controller.Tt"], output_limits=limits)
    if law not in POSITIONAL:
        # the controller keys its parameter column reads, given to the live controller
        # (which builds the same column from them)
        read = keys_read(recursive_law_column, cfg, cfg["sim.h"])
        keys = {k.removeprefix("controller.") for k in read
                if k.startswith("controller.")} - {"alpha", "kp"}
        return RecursiveIP(cfg["controller.alpha"], cfg["controller.kp"],
                           sample_time=cfg["sim.h"],
                           **{k: cfg[f"controller.{k}"] for k in sorted(keys)})
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
    # each law reads only its own gains (a translator's reads say what a key affects)
    a, kp = cfg["controller.alpha"], cfg["controller.kp"]
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
        return kind(**{k: cfg[f"{name}.{k}"] for k in kind.__dataclass_fields__})

    return column(section("sensor", Sensor), section("actuator", Actuator),
                  section("disturbance", Disturbance), cfg["sim.substeps"])


def ideal_loop(cfg: Config) -> bool:
    """No sensor, actuator or disturbance element, one integration step per sample: the
    loop the paper's kernels run."""
    return layout.plain(elements(cfg))


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
    from ..errors import ConfigError
    from .model.schedule import _check_changes

    p, ch = plant(cfg), changes(cfg)
    try:
        _check_changes(p, ch)
    except ConfigError as exc:
        raise ConfigError("plant.schedule", f"{exc.key} = {exc.value!r}", exc.allowed) from None
    return p, ch


def metric_settings(cfg: Config) -> np.ndarray:
    """The kernels' metric settings vector of a (validated) configuration."""
    return engine_metrics.settings(cfg["metrics.settle_time"], cfg["sim.t_end"],
                                   cfg["metrics.final_window"], cfg["sim.diverge_above"])


def _width(cfg: Config) -> int:
    """Columns a translator writes: 1, or the length of the one swept key's values when
    :func:`axis_columns` has put an array of them in the configuration."""
    return max((np.size(v) for k, v in cfg.values.items()
                if isinstance(v, np.ndarray)), default=1)


def buck_column(cfg: Config) -> np.ndarray:
    """The buck's parameter column (rows of :mod:`mfcontrol.plants.buck`)."""
    col = np.zeros((buck.N_PARAMS, _width(cfg)))
    col[buck.E] = cfg["plant.E"]
    col[buck.L] = cfg["plant.L"]
    col[buck.R] = cfg["plant.R"]
    col[buck.C] = cfg["plant.C"]
    col[buck.COUPLING] = buck.COUPLINGS[cfg["plant.coupling"]]
    col[buck.OUTPUT] = buck.OUTPUTS[cfg["plant.output"]]
    return col


def recursive_law_column(cfg: Config, h: float | None = None) -> np.ndarray:
    """The recursive law's parameter column (rows of :mod:`mfcontrol.laws.recursive_ip`):
    the one translator of its options, for cases, sweeps and the live
    :class:`~mfcontrol.api.model.controllers.RecursiveIP` alike. ``h``: the sample period
    back-calculation uses (default ``sim.h``)."""
    col = np.zeros((recursive_ip.N_PARAMS, _width(cfg)))
    variational = cfg["controller.law"] == "variational"
    col[variational_gain.MODE] = (variational_gain.VARIATIONAL if variational
                                  else variational_gain.CONSTANT)
    col[variational_gain.INV_ALPHA] = 1 / cfg["controller.alpha"]
    col[variational_gain.GAMMA0] = cfg["controller.gamma0"]
    col[variational_gain.GAMMA_RATE] = cfg["controller.Gamma"]
    col[variational_gain.EPS_M] = cfg["controller.eps_M"]
    col[variational_gain.ORDER] = 2.0 if cfg["controller.integrator"] == "second-order" else 1.0
    col[recursive_ip.KP] = cfg["controller.kp"]
    col[recursive_ip.HD] = cfg["controller.deriv_scale"]
    col[recursive_ip.U0] = cfg["controller.u0"]
    col[recursive_ip.P_SIGN] = 1.0 if cfg["controller.p_error"] == "r-y" else -1.0
    col[recursive_ip.P_CURRENT] = 1.0 if cfg["controller.p_sample"] == "current" else 0.0
    if variational and cfg["controller.rate_term"]:
        sign = 1.0 if cfg["controller.rate_sign"] == "plus" else -1.0
        col[recursive_ip.RATE_COEF] = sign * cfg["controller.k_gamma"]
    col[recursive_ip.USE_GAMMA] = 1.0 if cfg["controller.gain"] == "gamma" else 0.0
    col[recursive_ip.OUT_GAIN] = cfg["controller.output_gain"]
    col[recursive_ip.OUT_MIN] = cfg["controller.duty_min"]
    col[recursive_ip.OUT_MAX] = cfg["controller.duty_max"]
    col[recursive_ip.AW_COEF] = anti_windup_coefficient(cfg, h)
    return col


def anti_windup_coefficient(cfg: Config, h: float | None = None) -> float:
    """Share of the excess over the limit that the recursive law sheds each sample
    (back-calculation: k_aw h, at most 1; ``h`` defaults to ``sim.h``)."""
    mode = cfg["controller.anti_windup"]
    if mode in ("auto", "none"):
        return 0.0
    if mode == "clamp":
        return 1.0
    k_aw = cfg["controller.k_aw"]
    return 1.0 if k_aw is None else np.minimum(1.0, k_aw * (cfg["sim.h"] if h is None else h))


def reference_column(cfg: Config) -> np.ndarray:
    """The reference's parameter column (rows of :mod:`mfcontrol.laws.reference`)."""
    col = np.zeros((reference.N_PARAMS, _width(cfg)))
    col[reference.KIND] = reference.KINDS[cfg["reference.kind"]]
    if cfg["reference.kind"] == "smooth-step":
        col[reference.INITIAL] = cfg["reference.initial"]
        col[reference.FINAL] = cfg["reference.final"]
        col[reference.T0] = cfg["reference.t0"]
        col[reference.DURATION] = cfg["reference.duration"]
        return col
    col[reference.SLOPE] = cfg["reference.slope"]
    col[reference.LEVEL] = cfg["reference.level"]
    t2 = cfg["reference.t_ramp2"]
    col[reference.T_RAMP2] = math.inf if t2 is None else t2
    col[reference.SLOPE2] = cfg["reference.slope2"]
    return col


def buck_state_column(cfg: Config) -> np.ndarray:
    """The buck's initial state column."""
    col = np.zeros((buck.N_STATE, _width(cfg)))
    col[buck.I_L] = cfg["plant.i0"]
    col[buck.V_C] = cfg["plant.v0"]
    return col
