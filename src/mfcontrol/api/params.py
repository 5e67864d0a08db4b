"""The one translator from a resolved configuration to the engines' arrays: parameter
columns of the paper's kernels (:func:`buck_column`, :func:`recursive_law_column`,
:func:`reference_column`, :func:`buck_state_column`), one column per member, or one column
per value of a swept key given as an array; the metric settings; an LTI model's state
space.

It builds on no other module of :mod:`mfcontrol.api`: the live
:class:`~mfcontrol.api.model.controllers.RecursiveIP` fills its column through
:func:`recursive_law_column` as a case and a sweep do. A positional law's constructor fills
its own parameter column (:mod:`mfcontrol.laws.intelligent`); the plant, controller and
schedule objects a configuration describes are built by
:mod:`mfcontrol.api.run.from_config`.
"""

from __future__ import annotations

import math

import numpy as np

from ..config.resolve import Config
from ..engine import metrics as engine_metrics
from ..errors import ConfigError
from ..laws import recursive_ip, reference, variational_gain
from ..plants import buck

#: a numerator's leading coefficients at most this far from 0, once divided by the
#: denominator's first, are dropped (``scipy.signal.normalize``'s rule, which
#: :func:`controllable_canonical` follows to give the bits of ``scipy.signal.tf2ss``)
NUMERATOR_ZERO = 1e-14


def controllable_canonical(num: np.ndarray, den: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(A, B, C) of num / den, strictly proper, in the controllable canonical form:
    ``scipy.signal.tf2ss``'s realisation with its arithmetic, so the same bits (a test
    checks), without its generality's cost (measured 16 against 35 us for this function
    and ``tf2ss``; a sweep over a transfer function's key builds one per value) or its
    import (0.7-0.8 s).

    The polynomials' leading zeros are dropped and both divided by the denominator's
    first coefficient; then the numerator's leading coefficients within
    :data:`NUMERATOR_ZERO` of 0 are dropped (at least one kept), as scipy does. Returns
    None when what is left has no state (a denominator of degree 0) or is not strictly
    proper: the translator's scaling can underflow the denominator's leading
    coefficients to 0.

    Examples
    --------
    >>> A, B, C = controllable_canonical(np.array([2.0]), np.array([1.0, 3.0, 2.0]))
    >>> A.tolist(), B.tolist(), C.tolist()
    ([[-3.0, -2.0], [1.0, 0.0]], [1.0, 0.0], [0.0, 2.0])
    """
    den = np.trim_zeros(den, "f")
    if den.size < 2:
        return None
    num, den = num / den[0], den / den[0]
    lead = 0
    while lead < num.size - 1 and abs(num[lead]) <= NUMERATOR_ZERO:
        lead += 1
    num = num[lead:]
    n = den.size - 1
    if num.size > n:
        return None
    num = np.concatenate([np.zeros(den.size - num.size), num])
    A = np.eye(n, k=-1)
    A[0] = -den[1:]
    B = np.zeros(n)
    B[0] = 1.0
    return A, B, num[1:] - num[0] * den[1:]


def transfer_function_state_space(cfg: Config) -> tuple[np.ndarray, np.ndarray,
                                                         np.ndarray]:
    """(A, B, C) of K G(time_scale s) for the lti model: the controllable canonical
    realisation (:func:`controllable_canonical`) of the (strictly proper) transfer
    function ``plant.num / plant.den``, with the coefficient of s^i scaled by
    time_scale^i (every time constant multiplied)."""
    tau = cfg["plant.time_scale"]
    num, den = (np.trim_zeros(np.asarray(cfg[k], dtype=float), "f")
                for k in ("plant.num", "plant.den"))
    # an overflow is told below, by the key that made it
    with np.errstate(all="ignore"):
        num = cfg["plant.gain"] * num * tau ** np.arange(num.size - 1, -1, -1.0)
        den = den * tau ** np.arange(den.size - 1, -1, -1.0)
        abc = controllable_canonical(num, den)
    if abc is None:  # den's leading coefficients underflowed: the scaling did it
        raise ConfigError("plant.time_scale", tau, "scales the denominator's leading "
                          "coefficient to 0 (below the float range), which leaves a transfer "
                          "function that is not strictly proper: choose one nearer 1")
    if not all(np.all(np.isfinite(m)) for m in abc):
        key = "plant.time_scale" if tau != 1.0 else "plant.den"
        raise ConfigError(key, tau if tau != 1.0 else cfg["plant.den"],
                          "gives a model whose state-space matrices are not finite (its "
                          "scaled coefficients leave the float range): choose one nearer 1"
                          if tau != 1.0 else "gives a model whose state-space matrices are "
                          "not finite (coefficients out of the float range)")
    return abc


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
    back-calculation and the variational law's adaptation error use (default ``sim.h``)."""
    col = np.zeros((recursive_ip.N_PARAMS, _width(cfg)))
    variational = cfg["controller.law"] == "variational"
    col[variational_gain.MODE] = (variational_gain.VARIATIONAL if variational
                                  else variational_gain.CONSTANT)
    # the adaptation's options, read only by the law that adapts (the standard law's gain
    # is 1/alpha whatever they are: a key read is a key that can change the run), and
    # alpha only by a law whose gain it is (the variational law's starts from gamma0;
    # its 1/alpha is then never used)
    col[variational_gain.INV_ALPHA] = 1.0
    if not variational or cfg["controller.gain"] == "alpha":
        col[variational_gain.INV_ALPHA] = 1 / cfg["controller.alpha"]
    col[variational_gain.ORDER] = 1.0
    col[variational_gain.EVERY] = 1.0
    col[recursive_ip.USE_GAMMA] = 1.0
    if variational:
        col[variational_gain.GAMMA0] = cfg["controller.gamma0"]
        col[variational_gain.GAMMA_RATE] = cfg["controller.Gamma"]
        col[variational_gain.EPS_M] = cfg["controller.eps_M"]
        col[variational_gain.ORDER] = (2.0 if cfg["controller.integrator"] == "second-order"
                                       else 1.0)
        col[variational_gain.EVERY] = cfg["controller.adapt_every"]
        col[recursive_ip.USE_GAMMA] = 1.0 if cfg["controller.gain"] == "gamma" else 0.0
        # the adaptation error's time step: read by the law that adapts
        col[recursive_ip.H] = cfg["sim.h"] if h is None else h
    col[recursive_ip.KP] = cfg["controller.kp"]
    col[recursive_ip.HD] = cfg["controller.deriv_scale"]
    col[recursive_ip.U0] = cfg["controller.u0"]
    col[recursive_ip.P_SIGN] = 1.0 if cfg["controller.p_error"] == "r-y" else -1.0
    col[recursive_ip.P_CURRENT] = 1.0 if cfg["controller.p_sample"] == "current" else 0.0
    if variational and cfg["controller.rate_term"]:
        sign = 1.0 if cfg["controller.rate_sign"] == "plus" else -1.0
        col[recursive_ip.RATE_COEF] = sign * cfg["controller.k_gamma"]
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
    if t2 is not None:  # (a second slope without its start would change nothing)
        col[reference.SLOPE2] = cfg["reference.slope2"]
    return col


def buck_state_column(cfg: Config) -> np.ndarray:
    """The buck's initial state column."""
    col = np.zeros((buck.N_STATE, _width(cfg)))
    col[buck.I_L] = cfg["plant.i0"]
    col[buck.V_C] = cfg["plant.v0"]
    return col
