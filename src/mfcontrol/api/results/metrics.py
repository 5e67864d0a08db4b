"""Names and meaning of the per-run metrics, and the settling rule.

All metrics stream out of the kernel over the samples k = 0 .. N-1 (up to divergence),
with e_k = y_k - y*_k and h the sample period:

=================  ===========================================================
iae                sum |e_k| h
ise                sum e_k^2 h
itae               sum t_k |e_k| h
max_abs_e          max |e_k| over t_k >= metrics.settle_time (1 ms)
tv_u               sum |u_k - u_{k-1}|, the total variation of the applied control
final_gamma        gamma at the last sample (1/alpha for the standard law)
diverged           a NaN/inf appeared or |y| exceeded sim.diverge_above
t_diverge          time of the first such sample (NaN if none)
max_abs_e_final    max |e_k| over the settling window (last 20 % of the horizon)
max_abs_ref        max |y*_k| over the run
settled            see :func:`is_settled` (a tracking test, not a stability one)
energy_u           sum u_k^2 h, the energy of the controller's (limited) output u, as
                   tv_u (not of u_plant, what an actuator passed on)
steady_state_error mean of y*_k - y_k over the settling window
overshoot          on a step reference (from y0 to y1 at t0): the largest excursion past
                   y1, in % of |y1 - y0| (0 if none)
rise_time          10 % to 90 % of the step: between the first samples that reach them
settling_time      from t0 until y stays within 2 % of |y1 - y0| around y1 (NaN if it
                   does not by the end of the step window)
iae_load           sum |e_k| h from the first load step on: a step disturbance's t0 or
                   the first scheduled plant change (NaN without either)
adaptation_error   the variational gain's adaptation error: sum |e_dot_k - eps_M| h over
                   the samples where gamma adapts (k >= 3), the integral of the force of
                   the discrete Euler-Lagrange equation that moves gamma, zero where the
                   online optimisation is stationary
                   (:mod:`mfcontrol.laws.variational_gain`); NaN for another gain
=================  ===========================================================

The step metrics (overshoot, rise_time, settling_time) need a step reference: a case's
``smooth-step`` reference, or a constant one given to :func:`mfcontrol.simulate_loop`
(a step from the plant's initial output at t = 0); NaN otherwise. They judge the step
window, from the step to the first load step (which starts a response of its own, judged
by ``iae_load``) or the end; a step window without a sample (a load step at or before
the reference step) gives NaN. Times count from the step's t0: a smooth-step's duration is
part of the rise and settling times (``duration = 0`` is a plain step). Every kernel folds
every metric, the paper's tuned ones too.
"""

from __future__ import annotations

import math

import numpy as np

from ...engine import metrics as engine_metrics

SETTLED_RULE = (
    "A run is *settled* when it did not diverge (no NaN/inf, |y| within sim.diverge_above) "
    "and its tracking error over the last metrics.final_window of the horizon (default "
    "20 %) stays within metrics.settled_tol (default 10 %) of the largest reference value: "
    "max |y - y*| over the final window <= settled_tol * max |y*|. A loop that oscillates "
    "with growing amplitude or sits on a duty limit fails it; a loop that has settled "
    "after a load change passes."
)


#: the loop metrics (:func:`_loop_metrics`)
LOOP_METRICS = ("energy_u", "steady_state_error", "overshoot", "rise_time", "settling_time",
                "iae_load")
#: the metric columns of a sweep table, in order
COLUMNS = ("iae", "ise", "itae", "max_abs_e", "tv_u", "final_gamma", "max_abs_e_final",
           "max_abs_ref", "diverged", "t_diverge", "n_samples", "settled", *LOOP_METRICS,
           "adaptation_error")


#: each metric in words, and its unit: {y} stands for the output's unit, {u} the input's
LABELS = {
    "iae": ("IAE, the integral of |e|", "{y} s"),
    "ise": ("ISE, the integral of e^2", "{y}^2 s"),
    "itae": ("ITAE, the integral of t |e|", "{y} s^2"),
    "max_abs_e": ("largest |e| after the settling time", "{y}"),
    "tv_u": ("total variation of u", "{u}"),
    "final_gamma": ("gain gamma at the end", "1"),
    "max_abs_e_final": ("largest |e| over the settling window", "{y}"),
    "max_abs_ref": ("largest |reference|", "{y}"),
    "energy_u": ("energy of u", "{u}^2 s"),
    "steady_state_error": ("steady-state error", "{y}"),
    "overshoot": ("overshoot", "%"),
    "rise_time": ("rise time", "s"),
    "settling_time": ("settling time", "s"),
    "iae_load": ("IAE after the load step", "{y} s"),
    "adaptation_error": ("adaptation error, the integral of |e' - eps_M|", "{y}/s s"),
    "t_diverge": ("time of divergence", "s"),
    "n_samples": ("samples run", "1"),
    "settled": ("settled (1) or not (0)", "1"),
    "diverged": ("diverged (1) or not (0)", "1"),
}


#: short names for tables and summaries (the words of each are in LABELS)
SHORT = {"iae": "IAE", "ise": "ISE", "itae": "ITAE", "max_abs_e": "max |e|", "tv_u": "TV(u)",
         "settled": "settled", "iae_load": "IAE load", "overshoot": "overshoot",
         "rise_time": "rise time", "settling_time": "settling time",
         "final_gamma": "final gamma", "energy_u": "energy of u",
         "adaptation_error": "adaptation error"}


def label(metric: str, y_unit: str = "output unit", u_unit: str = "input unit") -> str:
    """``metric`` in words with its unit, for an axis or a colour bar:
    ``label("max_abs_e", "V")`` is ``"largest |e| after the settling time (V)"``."""
    words = LABELS.get(metric, (metric, ""))[0]
    unit = unit_of(metric, y_unit, u_unit)
    return f"{words} ({unit})" if unit else words


def unit_of(metric: str, y_unit: str = "output unit", u_unit: str = "input unit") -> str:
    """The unit of ``metric`` for an output in ``y_unit`` and an input in ``u_unit``
    (``""`` for a dimensionless one): ``unit_of("iae", "rad/s")`` is ``"rad"``."""
    unit = LABELS.get(metric, (metric, ""))[1]

    def power(u: str) -> str:  # a compound unit squared keeps its parentheses
        return f"({u})" if ("/" in u or " " in u) else u

    unit = (unit.replace("{y}^2", power(y_unit) + "^2").replace("{u}^2", power(u_unit) + "^2")
            .format(y=y_unit, u=u_unit))
    # a rate integrated over time: "rad/s s" is "rad", "rad/s s^2" is "rad s"
    for one in ("1^2 ", "1 "):  # a dimensionless signal (squared) over time: "s", not "1 s"
        if unit.startswith(one):
            unit = unit[len(one):]
            break
    for per_s, times in (("/s s^2", " s"), ("/s s", "")):
        if unit.endswith(per_s) and not unit.endswith(")" + per_s):
            unit = unit[: -len(per_s)] + times
            break
    return unit


def is_settled(diverged, max_abs_e_final, max_abs_ref, tol):
    """The settling rule; works on floats and, element-wise, on arrays."""
    return np.logical_and(~np.asarray(diverged, dtype=bool) & np.isfinite(max_abs_e_final),
                          np.asarray(max_abs_e_final) <= tol * np.asarray(max_abs_ref))


def table(M: np.ndarray, tol: float) -> dict[str, np.ndarray]:
    """Named metrics of every member (columns of the kernel's metric rows)."""
    diverged = M[engine_metrics.M_DIVERGED] != 0.0
    out = {
        "iae": M[engine_metrics.M_IAE].copy(),
        "ise": M[engine_metrics.M_ISE].copy(),
        "itae": M[engine_metrics.M_ITAE].copy(),
        "max_abs_e": M[engine_metrics.M_MAX_E_SETTLED].copy(),
        "tv_u": M[engine_metrics.M_TV].copy(),
        "final_gamma": M[engine_metrics.M_FINAL_GAMMA].copy(),
        "diverged": diverged,
        "t_diverge": np.where(diverged, M[engine_metrics.M_T_DIVERGE], math.nan),
        "max_abs_e_final": M[engine_metrics.M_MAX_E_FINAL].copy(),
        "max_abs_ref": M[engine_metrics.M_MAX_ABS_R].copy(),
        "n_samples": M[engine_metrics.M_N_SAMPLES].astype(np.int64),
    }
    out["settled"] = is_settled(diverged, out["max_abs_e_final"], out["max_abs_ref"], tol)
    out.update(_loop_metrics(M))
    out["adaptation_error"] = M[engine_metrics.M_ADAPT].copy()
    return out


def _loop_metrics(M: np.ndarray) -> dict[str, np.ndarray]:
    """The loop metrics from their folded rows (:func:`mfcontrol.engine.metrics.loop_sums`)."""
    em = engine_metrics
    size = np.abs(M[em.M_STEP_TO] - M[em.M_STEP_FROM])
    # a step, and a step window that holds a sample
    step = np.isfinite(size) & (size > 0) & np.isfinite(M[em.M_T_LAST])
    t10, t90, t_in = M[em.M_T10], M[em.M_T90], M[em.M_T_IN]
    with np.errstate(invalid="ignore", divide="ignore"):
        rise = np.where(step & np.isfinite(t10) & np.isfinite(t90), t90 - t10, math.nan)
        # y inside the band from t_in on; outside at the window's last sample: not settled
        settled = step & (t_in <= M[em.M_T_LAST])
        settling = np.where(settled, np.maximum(t_in, M[em.M_STEP_T0]) - M[em.M_STEP_T0],
                            math.nan)
        return {
            "energy_u": M[em.M_ENERGY].copy(),
            "steady_state_error": np.where(M[em.M_N_FINAL] > 0,
                                           M[em.M_E_FINAL] / M[em.M_N_FINAL], math.nan),
            "overshoot": np.where(step, 100.0 * M[em.M_PEAK] / size, math.nan),
            "rise_time": rise,
            "settling_time": settling,
            "iae_load": np.where(np.isfinite(M[em.M_LOAD_T0]), M[em.M_IAE_LOAD], math.nan),
        }


def _maximum(a: float, b: float) -> float:
    """``np.maximum`` of two floats: NaN when either is NaN, else a when a >= b."""
    return a if a >= b or a != a else b


def from_kernel(M: np.ndarray, j: int, tol: float) -> dict:
    """Named metrics of member j, as plain Python values. NaN is always ``math.nan``: one
    object, so that two runs with equal metrics give dicts that compare equal.

    What :func:`table` gives for that member, bit for bit, in the same order (held so by
    tests/api/results/test_metrics.py), computed on Python floats: one run's metrics in a few
    microseconds instead of numpy's per-call cost on one-element arrays."""
    em, nan = engine_metrics, math.nan
    m = M[:, j].tolist()
    diverged = m[em.M_DIVERGED] != 0.0
    e_final, ref = m[em.M_MAX_E_FINAL], m[em.M_MAX_ABS_R]
    size = abs(m[em.M_STEP_TO] - m[em.M_STEP_FROM])
    # the loop metrics, as _loop_metrics: a step, and a step window that holds a sample
    step = math.isfinite(size) and size > 0 and math.isfinite(m[em.M_T_LAST])
    t10, t90, t_in, t0 = m[em.M_T10], m[em.M_T90], m[em.M_T_IN], m[em.M_STEP_T0]
    out = {
        "iae": m[em.M_IAE], "ise": m[em.M_ISE], "itae": m[em.M_ITAE],
        "max_abs_e": m[em.M_MAX_E_SETTLED], "tv_u": m[em.M_TV],
        "final_gamma": m[em.M_FINAL_GAMMA], "diverged": diverged,
        "t_diverge": m[em.M_T_DIVERGE] if diverged else nan,
        "max_abs_e_final": e_final, "max_abs_ref": ref,
        "n_samples": int(m[em.M_N_SAMPLES]),
        "settled": not diverged and math.isfinite(e_final) and e_final <= tol * ref,
        "energy_u": m[em.M_ENERGY],
        "steady_state_error": (m[em.M_E_FINAL] / m[em.M_N_FINAL] if m[em.M_N_FINAL] > 0
                               else nan),
        "overshoot": 100.0 * m[em.M_PEAK] / size if step else nan,
        "rise_time": (t90 - t10 if step and math.isfinite(t10) and math.isfinite(t90)
                      else nan),
        "settling_time": _maximum(t_in, t0) - t0 if step and t_in <= m[em.M_T_LAST] else nan,
        "iae_load": m[em.M_IAE_LOAD] if math.isfinite(m[em.M_LOAD_T0]) else nan,
        "adaptation_error": m[em.M_ADAPT],
    }
    return {k: nan if isinstance(v, float) and v != v else v for k, v in out.items()}
