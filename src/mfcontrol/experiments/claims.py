"""The paper's claims put to the test where its section IV does not: under sensor noise,
at a digital controller's sample time, and with the gain frozen along its recorded path.

The paper's runs have no sensor noise, sample at h = 1 us and read the adaptation's
effect from the trajectories alone, and its "symplectic" integrator is never tested as
one. Four studies of ``voltage-unstable-variational`` (dR = 5 ohm), each a table the
reproduction report prints and writes as CSV (the fourth in :func:`symplectic_lines`):

* :func:`noise_study`: the same run under Gaussian sensor noise, several seeds; how far
  gamma moves from its noise-free path, at a quarter, half and all of the run, with each
  gamma integrator. The variational update adds Gamma times the error's backward
  difference at every sample. The first-order integrator (the published code's) sums it
  once: the noise's differences telescope, and what they leave in gamma stays bounded.
  The second-order integrator (eq. 32 as printed) sums it twice: its rate keeps an offset
  from the noise of the adaptation's first samples, nothing brings it back, and gamma's
  deviation grows about linearly in time (``growth`` is the exponent fitted over the
  three times). The second-order integrator runs once more with the multi-rate update
  (``controller.adapt_every`` = :data:`SLOW_EVERY`): gamma moves every m samples on the
  force's mean, the paper's perspective of adapting on a slower time scale.
* :func:`sample_time_study`: the standard and the variational law with a control period
  of 20 us (a 50 kHz digital controller), the plant still integrated every 1 us
  (``sim.substeps``); the laws' gains as the cases set them, Gamma per sample as printed
  and, for the variational law, also Gamma = h^2 / K_gamma with the paper's K_gamma (400
  times larger at 20 us).
* :func:`frozen_gain_study`: the linear analysis (:func:`mfcontrol.analyze`) of the
  variational loop with gamma frozen at the smallest and the largest value the run
  records, at each load the run sees, against the standard law's. The frozen analysis
  holds while gamma moves slowly against the loop's slowest mode: the table gives the
  largest relative change of gamma per sample next to that mode's decay per sample,
  1 - rho.
* :func:`symplectic_study`: eq. (32) as printed is the Stormer-Verlet step of
  K_gamma gamma'' = e_dot - eps_M. With a force independent of gamma (the open loop)
  every consistent one-step discretisation is a shear of determinant 1, so the claim
  can only be tested with a force that depends on gamma conservatively: a spring
  f = -c gamma, 10^6 steps, where the law's step (:func:`mfcontrol.laws.variational_gain.
  next_gamma`) keeps the energy in a closed-form band while explicit Euler grows it and
  implicit Euler damps it geometrically, and the published first-order step has no
  momentum at all. In the paper's loop the force is not conservative and the loop
  contracts phase volume (the frozen loop's determinant per sample < 1): there is no
  invariant to keep, and what can be checked is that the recorded gamma satisfies the
  printed recursion, the discrete momentum balance, to rounding.

The power cases (``power-standard``, ``power-variational``: the buck's output power
v_C i_L, a nonlinear map) are linearised at one operating point, the reference the run
ends at. One more study covers the range their run passes through:

* :func:`operating_range_study`: the linear loop's spectral radius, growth rate per
  second and time constant at a handful of levels from the reference's lowest to its
  highest, at each load the run sees, the variational law with gamma frozen at gamma0
  and at the ends of its recorded path; a level whose steady state needs a duty outside
  the law's limits has no operating point and is recorded as such.
  :func:`operating_range_lines` puts it in words for the report.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ..api.results.result import Result
from ..laws import recursive_ip
from .analyze import analyze
from .cases import resolve_case, run_config

if TYPE_CHECKING:
    import pandas as pd

CASE = "voltage-unstable-variational"
STANDARD = "voltage-unstable-standard"
#: sensor noise levels (V, standard deviation): a 12-bit converter's step on 20 V is
#: about 5 mV; 1 mV is a quiet sensor, 10 mV a plain one
NOISE_STDS = (1e-3, 1e-2)
SEEDS = (1, 2, 3, 4, 5)
INTEGRATORS = ("first-order", "second-order")
#: the multi-rate update's period in the noise study (samples: 20 us at h = 1 us, a
#: digital controller's period)
SLOW_EVERY = 20
#: the noise study's gamma updates: (integrator, adapt_every)
UPDATES = (("first-order", 1), ("second-order", 1), ("second-order", SLOW_EVERY))
#: a digital controller's period (s) and the substeps that keep the plant at 1 us
DIGITAL_H = 20e-6
SUBSTEPS = 20
#: the fractions of the run at which gamma's deviation is read
FRACTIONS = (0.25, 0.5, 1.0)
#: the nonlinear (power) cases whose loop is linearised over its operating range
POWER_CASES = ("power-standard", "power-variational")
#: the operating levels, as fractions of the way from the reference's lowest value in the
#: run to its highest: in steps of four at the low end, where the power's small-signal
#: gain (dp/dduty, proportional to the duty, so to sqrt(p)) changes fastest, then evenly
LEVEL_FRACTIONS = (0.0, 1 / 256, 1 / 64, 1 / 16, 1 / 4, 1 / 2, 3 / 4, 1.0)
#: Gamma c of the conservative test: its squared angle per step, w^2 (w = sqrt(Gamma c))
GAMMA_C = (1e-3, 1e-2, 1e-1)
#: the conservative test's horizon, steps
HORIZON = 10**6
#: the discretisations of K_gamma gamma'' = f in the conservative test: the law's two
#: integrators, and the two Euler steps of the first-order form (gamma' = v, K_gamma v' = f)
DISCRETISATIONS = ("second-order", "first-order", "explicit-euler", "implicit-euler")
#: the conservative test rescales its state by a power of two when its size leaves
#: [1/_RESCALE, _RESCALE]
_RESCALE = 2.0**300



def _run(fidelity: str, overrides: dict[str, Any], case: str = CASE) -> Result:
    """One run of ``case`` (a single run, not a sweep) under ``fidelity``."""
    _, cfg = resolve_case(case, {"fidelity": fidelity, **overrides})
    r = run_config(cfg, case)
    assert isinstance(r, Result), case
    return r


def noise_study(fidelity: str):
    """Gamma's deviation from its noise-free path under sensor noise (a DataFrame: one
    row per integrator and noise level)."""
    import pandas as pd

    rows = []
    for integrator, every in UPDATES:
        update = {"controller.integrator": integrator, "controller.adapt_every": every}
        clean = _run(fidelity, update)
        g0 = clean.signals["gamma"]
        n = g0.size
        at = [max(0, round(f * n) - 1) for f in FRACTIONS]
        for std in NOISE_STDS:
            dev, iae, adapt, settled = [], [], [], 0
            for seed in SEEDS:
                r = _run(fidelity, {**update, "sensor.noise": "gaussian",
                                    "sensor.noise_std": std, "sensor.seed": seed})
                dev.append(r.signals["gamma"][at] - g0[at])
                iae.append(r.metrics["iae"])
                adapt.append(r.metrics["adaptation_error"])
                settled += bool(r.metrics["settled"])
            spread = np.sqrt(np.mean(np.square(dev), axis=0))  # RMS over the seeds
            growth = np.polyfit(np.log(FRACTIONS), np.log(np.maximum(spread, 1e-300)), 1)[0]
            rows.append({"integrator": integrator, "adapt_every": every,
                         "noise_std": std, "seeds": len(SEEDS),
                         "gamma0": float(g0[0]),
                         **{f"gamma_dev_{round(f * 100)}pct": float(s)
                            for f, s in zip(FRACTIONS, spread, strict=True)},
                         "growth": float(growth),
                         "iae_clean": float(clean.metrics["iae"]),
                         "iae_noisy_mean": float(np.mean(iae)),
                         # the optimisation's distance from its stationary point
                         "adaptation_error_clean": float(clean.metrics["adaptation_error"]),
                         "adaptation_error_noisy_mean": float(np.mean(adapt)),
                         "settled": settled})
    return pd.DataFrame(rows)


def sample_time_study(fidelity: str):
    """The standard and the variational law at 1 us and at :data:`DIGITAL_H` (a
    DataFrame: one row per law, period and Gamma)."""
    import pandas as pd

    _, cfg = resolve_case(CASE, {"fidelity": fidelity})
    h, gamma_rate = cfg["sim.h"], cfg["controller.Gamma"]
    k_gamma = h * h / gamma_rate  # Gamma = h^2 / K_gamma (eq. 32)
    digital = {"sim.h": DIGITAL_H, "sim.substeps": SUBSTEPS}
    runs = [("standard i-P", h, None, {}, STANDARD),
            ("standard i-P", DIGITAL_H, None, digital, STANDARD),
            ("variational", h, gamma_rate, {}, CASE),
            ("variational, Gamma per sample as printed", DIGITAL_H, gamma_rate, digital,
             CASE),
            ("variational, Gamma = h^2 / K_gamma", DIGITAL_H, DIGITAL_H**2 / k_gamma,
             {**digital, "controller.Gamma": DIGITAL_H**2 / k_gamma}, CASE)]
    rows = []
    for law, period, rate, over, case in runs:
        r = _run(fidelity, over, case)
        m = r.metrics
        rows.append({"law": law, "period_s": period, "Gamma": rate,
                     "settled": bool(m["settled"]), "max_abs_e": float(m["max_abs_e"]),
                     "iae": float(m["iae"]), "diverged": bool(m.get("diverged", False))})
    return pd.DataFrame(rows)


def frozen_gain_study(fidelity: str):
    """The linear loop's spectral radius with gamma frozen along the run's recorded path,
    at each load the run sees, beside the standard law's (a DataFrame: one row per load)."""
    import pandas as pd

    _, cfg = resolve_case(CASE, {"fidelity": fidelity})
    gamma = _run(fidelity, {}).signals["gamma"]
    # the largest relative change of gamma in one sample
    rate = float(np.max(np.abs(np.diff(gamma)) / np.abs(gamma[1:]))) if gamma.size > 1 \
        else 0.0
    R, C, dR, dC = (cfg[k] for k in ("plant.R", "plant.C", "plant.dR", "plant.dC"))
    rows = []
    for changes in range(len(cfg["plant.change_times"] or []) + 1):
        load = {"plant.R": R + changes * dR, "plant.C": C + changes * dC,
                "plant.change_times": []}
        standard = analyze(STANDARD, overrides={"fidelity": fidelity, **load})
        radii = [analyze(CASE, overrides={"fidelity": fidelity, **load},
                         gamma=float(g)).margins["spectral_radius"]
                 for g in (gamma.min(), gamma.max())]
        worst = max(radii)
        rows.append({"load_changes": changes, "R_ohm": R + changes * dR,
                     "standard_radius": standard.margins["spectral_radius"],
                     "gamma_min": float(gamma.min()), "gamma_max": float(gamma.max()),
                     "variational_radius_worst": worst,
                     "slowest_decay_per_sample": 1.0 - worst,
                     "gamma_change_per_sample_max": rate})
    return pd.DataFrame(rows)


def _load_spans(times: np.ndarray, ref: np.ndarray, changes: list[float]
                ) -> list[tuple[float, float]]:
    """The reference's (lowest, highest) while each load holds: load k from the first
    sample at or after ``changes[k - 1]`` (as the engine applies it) to the sample before
    ``changes[k]``; (nan, nan) for a load the run never reaches."""
    edges = [-math.inf, *changes, math.inf]
    spans = []
    for start, stop in zip(edges[:-1], edges[1:], strict=True):
        held = ref[(times >= start) & (times < stop)]
        spans.append((float(held.min()), float(held.max())) if held.size
                     else (math.nan, math.nan))
    return spans


def _operating_point(a: Any, level: float, limits: tuple[float, float]) -> tuple[str, float]:
    """Whether the analysis ``a`` stands on an operating point the run can hold at
    ``level``: ``("ok", duty)``, else why not (no steady state; a duty outside the law's
    limits, where the law's output is clipped and the linear loop is not the run's)."""
    point = a.operating_point
    # analyze falls back to the initial state with u = 0 when it finds no steady state,
    # and says so in its notes: that fallback is no operating point
    if point is None or any(n.startswith("no steady state") for n in a.notes):
        return "no steady state", math.nan
    duty = float(point["u"])
    lo, hi = limits
    if duty < lo:
        return f"its duty {duty:.3g} is below the limit {lo:g}", duty
    if duty > hi:
        return f"its duty {duty:.3g} is above the limit {hi:g}", duty
    return "ok", duty


def operating_range_study(fidelity: str) -> pd.DataFrame:
    """The linear loop of each power case over the operating range its run covers.

    The power output v_C i_L is a nonlinear map of the buck's state, so its linear loop
    depends on where it is taken: :func:`mfcontrol.analyze` takes it at the reference the
    run ends at. Here it is taken at each of :data:`LEVEL_FRACTIONS` of the way from the
    reference's lowest value in the run to its highest, at each load the run sees
    (``plant.R + k * plant.dR``, ``plant.C + k * plant.dC`` after ``k`` load changes),
    the variational law with gamma frozen at gamma0 and at the smallest and largest gamma
    its run records.

    Parameters
    ----------
    fidelity : str
        The fidelity preset (``"published"`` or ``"paper"``).

    Returns
    -------
    pandas.DataFrame
        One row per case, gamma, load and level: ``case``, ``law`` (``"standard i-P"``,
        ``"variational i-P"``), ``gamma_role``
        (``"gamma0"``, ``"gamma_min"``, ``"gamma_max"``; ``"-"`` for the standard law),
        ``gamma`` (nan for the standard law), ``load_changes``, ``R_ohm``, ``level``
        (W), ``in_run`` (the run passes this level while this load holds),
        ``own_point`` (the point :func:`mfcontrol.analyze` takes by default), ``status``
        (``"ok"``, or why the level has no operating point), ``duty`` (the steady state's
        duty), ``spectral_radius``, ``growth_per_s`` (ln(rho) / h: negative is a decay),
        ``time_constant_s`` (-1 / growth, where it decays) and ``doubling_time_s``
        (ln 2 / growth, where it grows); the last four nan where ``status`` is not
        ``"ok"``.
    """
    import pandas as pd

    rows = []
    for case in POWER_CASES:
        _, cfg = resolve_case(case, {"fidelity": fidelity})
        # the run itself says what range it covers: its reference sample by sample, and
        # (variational) the gammas its adaptation passes through
        run = _run(fidelity, {}, case)
        ref = run.signals["y_ref"]
        low, high = float(ref.min()), float(ref.max())
        levels = [low + f * (high - low) for f in LEVEL_FRACTIONS]
        if cfg["controller.law"] == "variational":
            gamma = run.signals["gamma"]
            gammas: list[tuple[str, float | None]] = [
                ("gamma0", float(cfg["controller.gamma0"])),
                ("gamma_min", float(gamma.min())), ("gamma_max", float(gamma.max()))]
        else:
            gammas = [("-", None)]
        changes = list(cfg["plant.change_times"] or [])
        spans = _load_spans(run.time, ref, changes)
        limits = (cfg["controller.duty_min"], cfg["controller.duty_max"])
        R, C, dR, dC = (cfg[k] for k in ("plant.R", "plant.C", "plant.dR", "plant.dC"))
        # the point analyze takes by default (the reference the run ends at, the load at
        # t = 0, gamma0): the one the report's single analysis stands on
        own = analyze(case, overrides={"fidelity": fidelity}).operating_point
        # a level the run passes, to the rounding of the reference's own arithmetic (and
        # of the steady-state search's, for the default point)
        tol = 1e-9 * max(abs(low), abs(high), 1.0)
        for role, g in gammas:
            for k, (r_lo, r_hi) in enumerate(spans):
                load = {"fidelity": fidelity, "plant.R": R + k * dR, "plant.C": C + k * dC,
                        "plant.change_times": []}
                for level in levels:
                    a = analyze(case, overrides=load, gamma=g, operating_point=level)
                    status, duty = _operating_point(a, level, limits)
                    rho = a.margins["spectral_radius"] if status == "ok" else math.nan
                    # the loop's slowest mode grows (decays) by rho per control period
                    growth = math.log(rho) / a.sample_time if rho > 0 else math.nan
                    rows.append({
                        "case": case,
                        "law": "standard i-P" if g is None else "variational i-P",
                        "gamma_role": role, "gamma": math.nan if g is None else g,
                        "load_changes": k, "R_ohm": R + k * dR, "level": level,
                        "in_run": bool(r_lo - tol <= level <= r_hi + tol),
                        "own_point": bool(own is not None and k == 0
                                          and role in ("-", "gamma0")
                                          and abs(level - own["y"]) <= tol),
                        "status": status, "duty": duty, "spectral_radius": rho,
                        "growth_per_s": growth,
                        "time_constant_s": -1.0 / growth if growth < 0 else math.nan,
                        "doubling_time_s": math.log(2.0) / growth if growth > 0
                        else math.nan})
    return pd.DataFrame(rows)


def _pace(growth: float) -> str:
    """A growth rate (1/s) as the time it sets: a decay's time constant, a growth's
    doubling time."""
    if not math.isfinite(growth):
        return "-"
    if growth < 0:
        return f"{-1e3 / growth:.3g} ms"
    if growth > 0:
        return f"doubles in {math.log(2.0) * 1e3 / growth:.3g} ms"
    return "no decay"


def _spread(frame: pd.DataFrame, by: list[str]) -> float:
    """The largest relative spread of the growth rate within the groups ``by``."""
    g = frame.groupby(by)["growth_per_s"]
    spread = (g.max() - g.min()) / g.apply(lambda v: float(np.abs(v).max()))
    return float(spread.max()) if spread.size else 0.0


def operating_range_lines(table: pd.DataFrame) -> list[str]:
    """The report's lines on :func:`operating_range_study` (one fidelity's table): a
    paragraph, a table of the worst loop at each level, and the findings in words
    computed from the table.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`operating_range_study`'s table.

    Returns
    -------
    list of str
        Markdown lines, the first one empty.
    """
    laws = list(dict.fromkeys(table["law"]))
    levels = sorted(set(table["level"]))
    ok = table[table["status"] == "ok"]
    loads = sorted(set(table["R_ohm"]))
    nominal = table[table["load_changes"] == 0]
    own = table[table["own_point"]]
    var = table[table["gamma_role"] != "-"]
    gamma_words = ""
    if len(var):
        g0 = float(var[var["gamma_role"] == "gamma0"]["gamma"].iloc[0])
        gamma_words = (f", the variational law's gamma frozen at gamma0 = {g0:.4g} and at the "
                       f"ends of its recorded path ({var['gamma'].min():.6g} to "
                       f"{var['gamma'].max():.6g})")
    at = (f" at one operating point, the reference the run ends at "
          f"({own['level'].iloc[0]:.4g} W)" if len(own) else " at one operating point")
    out = ["", "The power output v_C i_L is a nonlinear map of the buck's state: the "
               f"analysis takes its loop{at}. Here it is linearised at {len(levels)} "
               f"levels from {levels[0]:.4g} to {levels[-1]:.4g} W, the range the "
               f"reference covers, at each load the run sees (R = {loads[0]:g} to "
               f"{loads[-1]:g} ohm){gamma_words}. Growth is ln(rho) / h per second "
               "(negative: a decay); each cell is the worst over the loads and, for the "
               "variational law, over the gammas "
               "(`mfcontrol.experiments.claims.operating_range_study`).", ""]
    out.append(f"| level (W) | duty at R = {loads[0]:g} ohm | R the run sees there (ohm) | "
               + " | ".join(f"{law} radius | {law} growth (1/s) | {law} time constant"
                            for law in laws) + " |")
    out.append("|" + "---|" * (3 + 3 * len(laws)))
    for level in levels:
        here = table[table["level"] == level]
        first = nominal[(nominal["level"] == level) & (nominal["law"] == laws[0])].iloc[0]
        duty = (f"{first['duty']:.4g}" if first["status"] == "ok"
                else f"none ({first['status']})")
        seen = here[here["in_run"] & (here["law"] == laws[0])]["R_ohm"]
        cells = [f"{level:.4g}" + (" (the analysis' point)" if here["own_point"].any()
                                   else ""), duty,
                 ", ".join(f"{r:g}" for r in sorted(set(seen))) or "-"]
        for law in laws:
            mine = ok[(ok["level"] == level) & (ok["law"] == law)]
            if mine.empty:
                cells += ["-", "-", "-"]
                continue
            growth = float(mine["growth_per_s"].max())
            cells += [f"{mine['spectral_radius'].max():.6f}", f"{growth:.4g}",
                      _pace(growth)]
        out.append("| " + " | ".join(cells) + " |")

    words = []
    for law in laws:
        mine = ok[ok["law"] == law]
        if mine.empty:
            words.append(f"The {law} has no operating point in the range.")
            continue
        every = "at every load" + (" and gamma" if (mine["gamma_role"] != "-").any() else "")
        bad = sorted(set(mine[mine["spectral_radius"] >= 1.0]["level"]))
        span = f"{mine['level'].min():.4g} to {mine['level'].max():.4g} W"
        if not bad:
            text = (f"The {law}'s linear loop is stable over the whole range where it has "
                    f"an operating point ({span}), {every}")
        else:
            good = sorted(set(mine["level"]) - set(bad))
            text = (f"The {law}'s linear loop is unstable at "
                    f"{', '.join(f'{lv:.4g}' for lv in bad)} W (at some load or gamma)")
            # where it loses stability: above or below a threshold, or here and there
            if not good:
                text += ", at every level with an operating point"
            elif good[-1] < bad[0]:
                text += f": stable up to {good[-1]:.4g} W, unstable from {bad[0]:.4g} W up"
            elif bad[-1] < good[0]:
                text += f": unstable up to {bad[-1]:.4g} W, stable from {good[0]:.4g} W up"
            else:
                text += f", stable at {', '.join(f'{lv:.4g}' for lv in good)} W"
        worst = mine.loc[mine["spectral_radius"].idxmax()]
        gamma_at = (f", gamma {worst['gamma']:.6g}" if worst["gamma_role"] != "-" else "")
        text += (f". Its worst radius, {worst['spectral_radius']:.6f} at "
                 f"{worst['level']:.4g} W (R = {worst['R_ohm']:g} ohm{gamma_at}), is "
                 f"{_e(abs(1.0 - worst['spectral_radius']))} from 1 "
                 f"({_pace(worst['growth_per_s'])})")
        home = own[own["law"] == law]
        if len(home) and worst["growth_per_s"] < 0 and home["growth_per_s"].iloc[0] < 0:
            ratio = home["growth_per_s"].iloc[0] / worst["growth_per_s"]
            text += (f": {ratio:.3g} times as slow as at the analysis' own point "
                     f"({_pace(home['growth_per_s'].iloc[0])} at "
                     f"{home['level'].iloc[0]:.4g} W)")
        # the grid crosses every level with every load; the run itself visits fewer
        passed = mine[mine["in_run"]]
        if len(passed) and not passed["spectral_radius"].max() == worst["spectral_radius"]:
            seen = passed.loc[passed["spectral_radius"].idxmax()]
            text += (f"; of the points the run passes, the worst is "
                     f"{seen['spectral_radius']:.6f} at {seen['level']:.4g} W "
                     f"(R = {seen['R_ohm']:g} ohm, {_pace(seen['growth_per_s'])})")
        # the radius along the levels, at each load and gamma
        falls = all(np.all(np.diff(g.sort_values("level")["spectral_radius"]) < 0)
                    for _, g in mine.groupby(["gamma_role", "load_changes"]))
        text += (". Its slowest mode decays faster as the power rises, monotonically "
                 f"{every}" if falls else
                 ". Its radius is not monotonic in the power at some load or gamma")
        # the worst growth at the two lowest levels: how it falls toward zero power
        low = mine.groupby("level")["growth_per_s"].max().sort_index()
        low = low[(low < 0) & (low.index > 0)]
        if low.size >= 2:
            exponent = (math.log(low.iloc[1] / low.iloc[0])
                        / math.log(low.index[1] / low.index[0]))
            text += (f"; between the two lowest levels its decay rate scales as the power "
                     f"to the {exponent:.2f}")
        words.append(text + ".")
    out += ["", " ".join(words)]

    more = []
    none = [lv for lv in levels if (nominal[nominal["level"] == lv]["status"] != "ok").all()]
    for lv in none:
        row = nominal[nominal["level"] == lv].iloc[0]
        more.append(f"At {lv:.4g} W there is no operating point ({row['status']}): the "
                    "law's output is clipped there and no linear loop describes it"
                    + ("; the run passes through it" if row["in_run"] else "") + ".")
    by_load = _spread(ok, ["law", "gamma_role", "level"])
    more.append(f"The loads change a growth rate by at most {100 * by_load:.2g} %")
    if (ok["gamma_role"] != "-").any():
        by_gamma = _spread(ok[ok["gamma_role"] != "-"], ["load_changes", "level"])
        more[-1] += (f", and freezing gamma anywhere on its recorded path by at most "
                     f"{100 * by_gamma:.2g} %")
    more[-1] += "."
    if len(laws) == 2:
        worst = ok.groupby(["law", "level"])["growth_per_s"].max()
        ratio = (worst[laws[0]] / worst[laws[1]]).dropna()
        if ratio.size:
            more.append(f"The {laws[0]}'s slowest mode decays {ratio.min():.3g} to "
                        f"{ratio.max():.3g} times as fast as the {laws[1]}'s over the "
                        "range.")
    out += ["", " ".join(more)]
    return out


def _stepper(scheme: str, gamma_c: float, rate: float
             ) -> Callable[[float, float], tuple[float, float]]:
    """One step of ``scheme`` for K_gamma gamma'' = -c gamma, Gamma = ``rate``,
    c = gamma_c / rate, on the state (gamma_{k-1}, gamma_k) for the law's integrators and
    (gamma_k, h v_k) for the Euler steps of the first-order form."""
    from ..laws import variational_gain as vg

    c = gamma_c / rate
    if scheme in ("second-order", "first-order"):
        # the law's own step, called as the loops call it (plain floats); eps_M = 0, so
        # the force fed as e_dot reaches the step without a rounding of e_dot - eps_M
        law, mode, k = vg.next_gamma, float(vg.VARIATIONAL), float(vg.STEADY)
        order = 2.0 if scheme == "second-order" else 1.0

        def position(g2: float, g1: float) -> tuple[float, float]:
            # (gamma, g1, g2, acc, cnt, adapt): an update at every step, gamma first
            return g1, law(mode, k, -c * g1, g1, g2, 0.0, 0.0, 0.0, 0.0, 0.0, rate, 0.0,
                           order, 1.0, 1.0, 1.0)[0]
        return position
    if scheme == "explicit-euler":
        def explicit(x: float, d: float) -> tuple[float, float]:
            return x + d, d - gamma_c * x  # x' = x + h v, h v' = h v + Gamma f(x)
        return explicit

    def implicit(x: float, d: float) -> tuple[float, float]:
        # h v' = h v + Gamma f(x'), x' = x + h v', solved for the linear force
        d = (d - gamma_c * x) / (1.0 + gamma_c)
        return x + d, d
    return implicit


def _oscillator(scheme: str, gamma_c: float, rate: float, steps: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The path of the conservative test from rest at gamma = 1 (gamma_{-1} = gamma_0,
    as the law starts, or v_0 = 0), steps 0 .. ``steps``.

    Returns ``(x, d, s)``: ``x_k`` = gamma_k and ``d_k`` = h v_k (gamma_{k+1} - gamma_k
    for the law's integrators; the velocity state for the Euler steps), both scaled by
    2^-s_k. The system is linear and homogeneous, so a power-of-two rescaling commutes
    with every step bit for bit: it lets explicit Euler grow, and the others decay, over
    the whole horizon without overflow or underflow.
    """
    step = _stepper(scheme, gamma_c, rate)
    position = scheme in ("second-order", "first-order")
    a, b = 1.0, (1.0 if position else 0.0)
    x_out: list[float] = []
    d_out: list[float] = []
    events = [(0, 0)]  # (first step at a scale, its exponent)
    exponent = 0
    for i in range(steps + 1):
        a2, b2 = step(a, b)
        x_out.append(b if position else a)
        d_out.append(b2 - b if position else b)
        a, b = a2, b2
        size = abs(a) + abs(b)
        if not 1.0 / _RESCALE < size < _RESCALE:
            shift = math.frexp(size)[1]
            a, b = math.ldexp(a, -shift), math.ldexp(b, -shift)
            exponent += shift
            events.append((i + 1, exponent))
    s = np.zeros(steps + 1, dtype=np.int64)
    for first, e in events:
        s[first:] = e
    return np.asarray(x_out), np.asarray(d_out), s


def _one_step_det(scheme: str, gamma_c: float, rate: float) -> float:
    """The determinant of one step's linear map, measured by stepping the unit states."""
    step = _stepper(scheme, gamma_c, rate)
    (a1, b1), (a2, b2) = step(1.0, 0.0), step(0.0, 1.0)
    return a1 * b2 - a2 * b1


@functools.lru_cache(maxsize=4)
def _conservative_rows(rate: float, steps: int) -> tuple[dict[str, Any], ...]:
    """The conservative test's rows: every discretisation at every :data:`GAMMA_C`."""
    rows = []
    for gamma_c in GAMMA_C:
        w = math.sqrt(gamma_c)
        # |eigenvalue| of each step's map: Verlet's lie on the unit circle (Gamma c < 4),
        # explicit Euler's are 1 +- i w, implicit Euler's their inverses; the first-order
        # law's one non-zero eigenvalue is 1 - Gamma c
        modulus = {"second-order": 1.0, "first-order": 1.0 - gamma_c,
                   "explicit-euler": math.sqrt(1.0 + gamma_c),
                   "implicit-euler": 1.0 / math.sqrt(1.0 + gamma_c)}
        for scheme in DISCRETISATIONS:
            x, d, s = _oscillator(scheme, gamma_c, rate, steps)
            # 2 Gamma H = d^2 + Gamma c x^2, H = p^2 / (2 K_gamma) + c gamma^2 / 2,
            # p_k = K_gamma d_k / h; in logs, the rescaling added back
            log_e = np.log(d * d + gamma_c * x * x) + (2.0 * math.log(2.0)) * s
            ratio = (log_e - log_e[0]) / math.log(10.0)  # log10(E_k / E_0)
            row: dict[str, Any] = {
                "setting": "conservative", "integrator": scheme, "Gamma_c": gamma_c,
                "steps": steps, "det_per_step": _one_step_det(scheme, gamma_c, rate),
                "modulus_measured": 10.0 ** (ratio[-1] / (2 * steps)),
                "modulus_closed_form": modulus[scheme],
                "log10_energy_ratio_end": float(ratio[-1]),
                "log10_energy_ratio_maxabs": float(np.max(np.abs(ratio)))}
            if scheme == "second-order":
                # Q_k = d_k^2 + Gamma c gamma_k gamma_{k+1} is the step's exact invariant;
                # with gamma_k = A cos(theta k + phi), cos theta = 1 - Gamma c / 2, the
                # energy is E_k = Ebar (1 + (w/2) sin(2 theta k + 2 phi + theta/2)), Ebar =
                # Q / (1 - Gamma c / 4): it stays within Ebar (1 +- w/2) for ever
                xs, ds = np.ldexp(x, s), np.ldexp(d, s)  # s = 0: Verlet is bounded
                q = ds * ds + gamma_c * xs * (xs + ds)
                energy = ds * ds + gamma_c * xs * xs
                mean = q[0] / (1.0 - gamma_c / 4.0)
                row["invariant_drift"] = float(np.max(np.abs(q / q[0] - 1.0)))
                row["energy_dev_max"] = float(np.max(np.abs(energy / mean - 1.0)))
                row["energy_dev_bound"] = w / 2.0
            else:
                row["invariant_drift"] = row["energy_dev_max"] = math.nan
                row["energy_dev_bound"] = math.nan
            factor2 = np.flatnonzero(np.abs(ratio) >= math.log10(2.0))
            row["steps_to_factor_2"] = int(factor2[0]) if factor2.size else -1
            rows.append(row)
    return tuple(rows)


def _loop_rows(fidelity: str) -> list[dict[str, Any]]:
    """The recorded run of :data:`CASE` under each integrator: its gamma against the
    recursions, and the frozen loop's volume change per sample."""
    _, cfg = resolve_case(CASE, {"fidelity": fidelity})
    rate, eps_m, hd = (cfg[k] for k in ("controller.Gamma", "controller.eps_M",
                                        "controller.deriv_scale"))
    R, C, dR, dC = (cfg[k] for k in ("plant.R", "plant.C", "plant.dR", "plant.dC"))
    rows = []
    for integrator in INTEGRATORS:
        sig = _run(fidelity, {"controller.integrator": integrator}).signals
        g, y, r = sig["gamma"], sig["y_meas"], sig["y_ref"]
        # the force as the law computes it (its own e_dot), at k >= 1
        e_dot = recursive_ip.error_rate(y[1:], y[:-1], r[1:], r[:-1], hd)
        f = (e_dot - eps_m)[2:]  # f_k for k >= 3, where the recursion starts
        g0, g1, g2 = g[3:], g[2:-1], g[1:-2]  # gamma_k, gamma_{k-1}, gamma_{k-2}
        own = (f * rate + 2.0 * g1) - (g2 if integrator == "second-order" else g1)
        # the printed recursion (eq. 32) is the discrete momentum balance
        # p_k - p_{k-1} = h f_k, p_k = K_gamma (gamma_{k+1} - gamma_k) / h, K_gamma =
        # h^2 / Gamma: in gamma's units, second difference = Gamma f_k
        balance = ((g0 - g1) - (g1 - g2)) - f * rate
        worst = float(np.max(np.abs(balance)))
        # the loop linearised with gamma frozen at the ends of its path, at each load:
        # the product of its poles is the determinant of its one-step map. gamma enters
        # one row of that map (u's), so the determinant is affine in gamma and its ends
        # bound it along the whole path
        dets = []
        for changes in range(len(cfg["plant.change_times"] or []) + 1):
            load = {"fidelity": fidelity, "plant.R": R + changes * dR,
                    "plant.C": C + changes * dC, "plant.change_times": []}
            for gamma in (g.min(), g.max()):
                poles = analyze(CASE, overrides=load, gamma=float(gamma)).poles()
                dets.append(float(abs(np.prod(poles))))
        rows.append({"setting": "loop", "integrator": integrator, "steps": int(g.size),
                     "gamma_min": float(g.min()), "gamma_max": float(g.max()),
                     "recursion_residual": float(np.max(np.abs(g0 - own))),
                     "balance_residual_ulp": worst / float(np.spacing(np.max(np.abs(g)))),
                     "balance_residual_rel": worst / (rate * float(np.max(np.abs(f)))),
                     "det_per_step": max(dets)})
    return rows


def symplectic_study(fidelity: str, steps: int = HORIZON) -> pd.DataFrame:
    """The symplectic claim tested where it can bite, and what it leaves in the loop.

    Eq. (32) as printed, ``gamma_{k+1} = Gamma (e_dot_k - eps_M) + 2 gamma_k -
    gamma_{k-1}`` with ``Gamma = h^2 / K_gamma``, is the Stormer-Verlet step (the discrete
    Euler-Lagrange equation) of ``K_gamma gamma'' = f``, ``f = e_dot - eps_M``, the
    Lagrangian ``K_gamma gamma'^2 / 2 + gamma f(t)``. With the discrete momentum
    ``p_k = K_gamma (gamma_{k+1} - gamma_k) / h`` it reads ``p_k - p_{k-1} = h f_k``.
    Symplecticity is a property of how a step treats a force that depends on the state:
    with ``f`` independent of gamma (the open loop), every consistent one-step
    discretisation of this Lagrangian is a shear of determinant 1, so it adds nothing.

    Two settings, rows of one table (``setting``):

    ``conservative``
        A restoring force ``f = -c gamma`` (an oscillator in gamma), ``Gamma c`` in
        :data:`GAMMA_C`, ``steps`` steps from rest at gamma = 1, Gamma the fidelity's.
        ``second-order`` (Verlet) and ``first-order`` (the published code's step) run
        through :func:`mfcontrol.laws.variational_gain.next_gamma`, the function the
        loops inline; ``explicit-euler`` and ``implicit-euler`` are the Euler steps of
        the same Lagrangian's first-order form (gamma' = v, K_gamma v' = f). Columns:
        the determinant of one step's map (``det_per_step``, measured by stepping unit
        states; on (gamma_{k-1}, gamma_k) for the law's steps), the modulus of its
        eigenvalues measured from the energy ratio over the horizon and in closed form,
        ``log10(E_N / E_0)`` and ``max_k |log10(E_k / E_0)|`` of ``E = p^2 / (2
        K_gamma) + c gamma^2 / 2``, the first step at which E has doubled or halved (-1:
        never). For Verlet also the largest relative deviation of E from its mean with
        its closed-form bound ``sqrt(Gamma c) / 2`` (``energy_dev_max``,
        ``energy_dev_bound``) and the drift of its exact discrete invariant
        ``Q_k = (gamma_{k+1} - gamma_k)^2 + Gamma c gamma_k gamma_{k+1}``.
    ``loop``
        The recorded run of :data:`CASE` with each integrator: the force is not
        conservative and the loop dissipates, so there is no invariant to keep. Columns:
        gamma's range; the largest residual of the recorded gamma against the law's own
        recursion, recomputed from the recorded y and r in the law's floating-point
        order (``recursion_residual``); the largest residual of the printed recursion,
        the discrete momentum balance (with K_gamma = h^2 / Gamma, the mass for which
        the printed step is the Euler-Lagrange equation: 2e-5 at the cases' Gamma =
        5e-8, not ``controller.k_gamma``), in ulps of gamma and relative to
        ``Gamma max |f|``; the largest determinant of the loop's one-step map (the
        product of its poles) with gamma frozen at either end of its path, at each load
        (``det_per_step``; gamma's own states are left out; the determinant is affine
        in gamma, so the ends bound it along the path).

    Parameters
    ----------
    fidelity : str
        ``"published"`` or ``"paper"``: the loop's settings and Gamma.
    steps : int, optional
        The conservative test's horizon (default :data:`HORIZON`).

    Returns
    -------
    pandas.DataFrame
        One row per setting, integrator and (conservative) ``Gamma_c``.
    """
    import pandas as pd

    _, cfg = resolve_case(CASE, {"fidelity": fidelity})
    # the spring test depends on Gamma alone: both fidelities share it (computed once)
    rows = [dict(r) for r in _conservative_rows(float(cfg["controller.Gamma"]), steps)]
    rows += _loop_rows(fidelity)
    return pd.DataFrame(rows)


def symplectic_lines(table: pd.DataFrame) -> list[str]:
    """The report's lines on :func:`symplectic_study`: two paragraphs and two tables,
    the findings in words computed from ``table``.

    Parameters
    ----------
    table : pandas.DataFrame
        What :func:`symplectic_study` returns.

    Returns
    -------
    list of str
        Markdown lines.
    """
    osc = table[table["setting"] == "conservative"]
    loop = table[table["setting"] == "loop"]
    steps = int(osc["steps"].iloc[0])
    out = ["", "Eq. (32) as printed is the Stormer-Verlet step of K_gamma gamma'' = f, f = "
               "e_dot - eps_M (Lagrangian K_gamma gamma'^2/2 + gamma f, Gamma = "
               "h^2/K_gamma); the published code's step, gamma_{k+1} = gamma_k + Gamma "
               "f_k, is first order. While f does not depend on gamma, every consistent "
               "one-step discretisation of that Lagrangian is a shear of determinant 1: "
               "being symplectic adds nothing. It bites when the force depends on gamma "
               f"conservatively: f = -c gamma, {steps:,} steps from rest, the law's two "
               "steps through its own `next_gamma`, beside explicit and implicit Euler of "
               "the first-order form (gamma' = v, K_gamma v' = f). E = p^2/(2 K_gamma) + "
               "c gamma^2/2, p_k = K_gamma (gamma_{k+1} - gamma_k)/h.", "",
           "| integrator | Gamma c | det of one step | abs eigenvalue, measured (closed "
           "form) | log10 E_N/E_0 | max abs log10 E_k/E_0 | max abs E_k/mean - 1 "
           "(bound) | drift of the invariant | steps until E doubles or halves |",
           "|---|---|---|---|---|---|---|---|---|"]
    for _, r in osc.iterrows():
        verlet = not math.isnan(r["energy_dev_max"])
        dev = (f"{_e(r['energy_dev_max'])} ({_e(r['energy_dev_bound'])})" if verlet
               else "-")
        drift = _e(r["invariant_drift"]) if verlet else "-"
        doubled = "never" if r["steps_to_factor_2"] < 0 else f"{int(r['steps_to_factor_2'])}"
        out.append(f"| {r['integrator']} | {r['Gamma_c']:g} | {r['det_per_step']:.6g} | "
                   f"{r['modulus_measured']:.9f} ({r['modulus_closed_form']:.9f}) | "
                   f"{_log(r['log10_energy_ratio_end'])} | "
                   f"{_log(r['log10_energy_ratio_maxabs'])[1:]} | {dev} | {drift} | {doubled} |")

    def of(scheme: str) -> pd.DataFrame:
        return osc[osc["integrator"] == scheme]

    verlet, first = of("second-order"), of("first-order")
    explicit, implicit = of("explicit-euler"), of("implicit-euler")
    bounded = bool((verlet["energy_dev_max"] <= verlet["energy_dev_bound"] * (1 + 1e-9))
                   .all() and (verlet["steps_to_factor_2"] < 0).all())
    tight = float((verlet["energy_dev_max"] / verlet["energy_dev_bound"]).min())
    words = [("The second-order step's map has determinant "
              f"{_span(verlet['det_per_step'], '.12g')} and keeps E within its closed-form "
              f"band, mean (1 +- sqrt(Gamma c)/2), at every Gamma c over all {steps:,} "
              f"steps, and fills it (at least {tight:.1%} of the half-width): bounded, "
              "not small. E never doubles or halves, and the invariant drifts by at most "
              f"{_e(float(verlet['invariant_drift'].max()))}, rounding."
              if bounded else
              "The second-order step's energy leaves its closed-form band at some Gamma c: "
              "the symplectic claim fails.")]
    for name, frame, direction in (("Explicit", explicit, "grows"),
                                   ("Implicit", implicit, "decays")):
        rel = float((frame["modulus_measured"] / frame["modulus_closed_form"] - 1.0)
                    .abs().max())
        worst = frame.iloc[int(np.argmax(frame["Gamma_c"].to_numpy()))]
        mild = frame.iloc[int(np.argmin(frame["Gamma_c"].to_numpy()))]
        words.append(f"{name} Euler's determinant is {_span(frame['det_per_step'], '.6g')}"
                     f"; E {direction} geometrically, the measured eigenvalue modulus "
                     + (f"matching the closed form to rounding ({rel:.1e} relative)"
                        if rel < 1e-9 else f"{rel:.1e} (relative) from the closed form")
                     + ": E_N/E_0 = "
                     f"10^{mild['log10_energy_ratio_end']:+.0f} at Gamma c = "
                     f"{mild['Gamma_c']:g} (factor 2 after {int(mild['steps_to_factor_2'])} "
                     f"steps), 10^{worst['log10_energy_ratio_end']:+.0f} at "
                     f"{worst['Gamma_c']:g}.")
    forgets = bool((first["det_per_step"] == 0.0).all())
    words.append("The published first-order step "
                 + ("forgets gamma_{k-1}: its map of (gamma_{k-1}, gamma_k) has "
                    "determinant 0, so it carries no momentum" if forgets else
                    "keeps gamma_{k-1}")
                 + "; gamma relaxes to the spring's rest with one eigenvalue "
                   f"{_span(first['modulus_measured'], '.6g')} (1 - Gamma c), a gradient "
                   "flow of the force, not a discretisation of the second-order "
                   "Lagrangian.")
    out += ["", " ".join(words)]

    out += ["", f"In the paper's loop (`{CASE}`, the recorded runs) f depends on gamma "
                "through the plant and is not conservative:", "",
            "| integrator | samples | gamma range | residual of its own recursion | "
            "momentum balance residual (ulp of gamma) | same, relative to Gamma max abs "
            "f | frozen loop's det per sample (largest) |",
            "|---|---|---|---|---|---|---|"]
    for _, r in loop.iterrows():
        out.append(f"| {r['integrator']} | {int(r['steps'])} | {r['gamma_min']:.6g} to "
                   f"{r['gamma_max']:.6g} | {_e(r['recursion_residual'])} | "
                   f"{_e(r['balance_residual_ulp'])} | {_e(r['balance_residual_rel'])} | "
                   f"{r['det_per_step']:.6f} |")
    det = float(loop["det_per_step"].max())
    samples = int(loop["steps"].max())
    exact = bool((loop["recursion_residual"] == 0.0).all())
    second = loop[loop["integrator"] == "second-order"].iloc[0]
    first_loop = loop[loop["integrator"] == "first-order"].iloc[0]
    out += ["", ("The loop dissipates: with gamma frozen anywhere on its path, at every "
                 f"load, its one-step map has determinant at most {det:.6f}, a phase "
                 f"volume at most about 10^{samples * math.log10(det):.0f} of its start after "
                 f"{samples:,} samples, so there is no invariant for a symplectic "
                 "integrator to keep. " if det < 1.0 else
                 "With gamma frozen somewhere on its path the loop's one-step map does not "
                 f"contract (determinant up to {det:.6f}). ")
            + ("The recorded gamma satisfies its own recursion bit for bit. " if exact
               else "The recorded gamma departs from its own recursion by up to "
                    f"{_e(float(loop['recursion_residual'].max()))}. ")
            + "The discrete momentum balance p_k - p_{k-1} = h f_k holds to "
              f"{_e(second['balance_residual_ulp'])} ulp of gamma with the second-order "
              f"integrator ({_e(second['balance_residual_rel'])} of Gamma max abs f); the "
              f"first-order one's residual is {first_loop['balance_residual_rel']:.3g} x "
              "Gamma max abs f, the force term itself: its gamma_{k-1} carries no "
              "momentum. What the loop can check of the claim is this exactness, not a "
              "conserved quantity."]
    return out


def _log(x: float) -> str:
    """A signed base-10 exponent: whole beyond 100, three digits below."""
    return f"{x:+.0f}" if abs(x) >= 100 else f"{x:+.3g}"


def _span(values: Any, fmt: str) -> str:
    """``a`` or ``a to b``: the range of ``values`` in format ``fmt``."""
    lo, hi = float(np.min(values)), float(np.max(values))
    return f"{lo:{fmt}}" if f"{lo:{fmt}}" == f"{hi:{fmt}}" else f"{lo:{fmt}} to {hi:{fmt}}"


def _every(m: int) -> str:
    return "sample" if m == 1 else f"{m} samples"


def _e(x: float) -> str:
    return f"{x:.2g}" if x and (abs(x) < 1e-3 or abs(x) >= 1e4) else f"{x:.4g}"


def section(fidelities: list[str], studies: dict[str, dict[str, Any]]) -> list[str]:
    """The report's section on the studies, per fidelity, with the findings in
    words computed from the tables."""
    out = ["", "## The claims under noise, at a digital sample time, with the gain frozen, "
               "as a symplectic integrator, over the operating range",
           "", "The paper's runs have no sensor noise and sample every 1 us. These studies "
               f"of `{CASE}` test what its figures do not (`mfcontrol.experiments.claims`; "
               "each table is a CSV next to this report)."]
    for fid in fidelities:
        noise, digital, frozen = (studies[fid][k] for k in ("noise", "sample_time", "frozen"))
        out += ["", f"### {fid}", "",
                f"Sensor noise ({len(SEEDS)} seeds each): RMS over the seeds of gamma's "
                "deviation from its noise-free path, at a quarter, half and all of the run.",
                "The adaptation error is the integral of |e' - eps_M| over the run (V): the "
                "force of the discrete Euler-Lagrange equation, zero where the online "
                "optimisation is stationary.",
                "", "| integrator | gamma updated every | noise std (V) | at 25 % | at 50 % "
                    "| at 100 % | growth exponent | IAE clean | IAE noisy (mean) "
                    "| adaptation error clean | adaptation error noisy (mean) | settled |",
                "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for _, r in noise.iterrows():
            out.append(f"| {r['integrator']} | {_every(r['adapt_every'])} | "
                       f"{r['noise_std']:g} | "
                       f"{_e(r['gamma_dev_25pct'])} | {_e(r['gamma_dev_50pct'])} | "
                       f"{_e(r['gamma_dev_100pct'])} | {r['growth']:+.2f} | "
                       f"{_e(r['iae_clean'])} | {_e(r['iae_noisy_mean'])} | "
                       f"{_e(r['adaptation_error_clean'])} | "
                       f"{_e(r['adaptation_error_noisy_mean'])} | "
                       f"{r['settled']}/{r['seeds']} |")
        words = []
        for integrator, every in UPDATES:
            growth = noise[(noise["integrator"] == integrator)
                           & (noise["adapt_every"] == every)]["growth"]
            name = f"the {integrator} integrator" + (
                f" updated every {every} samples" if every > 1 else "")
            if (growth.abs() < 0.4).all():
                words.append(f"with {name} gamma's deviation does not grow (exponents "
                             f"{growth.min():+.2f} to {growth.max():+.2f})")
            else:
                words.append(f"with {name} it grows with time (exponents "
                             f"{growth.min():+.2f} to {growth.max():+.2f}; 1 is linear)")
        loud = noise[noise["noise_std"] == max(NOISE_STDS)]
        end = {r["integrator"] + (f", every {r['adapt_every']}" if r["adapt_every"] > 1
                                  else ""): r["gamma_dev_100pct"] / r["gamma0"]
               for _, r in loud.iterrows()}
        clean, noisy = loud["iae_clean"].to_numpy(), loud["iae_noisy_mean"].to_numpy()
        change = float(np.max(np.abs(noisy / clean - 1.0)))
        out += ["", "Under noise, " + "; ".join(words) + f". At {max(NOISE_STDS):g} V the "
                    "deviation at the end is "
                    + ", ".join(f"{_e(v)} of gamma0 ({k})" for k, v in end.items())
                    + f", and the mean IAE moves by at most {change:.1%} from the noise-free "
                      "run's."]
        grown = (loud["adaptation_error_noisy_mean"] / loud["adaptation_error_clean"]).to_numpy()
        out += ["", f"At {max(NOISE_STDS):g} V the adaptation error is {grown.min():.3g} to "
                    f"{grown.max():.3g} times the noise-free run's: the force that drives "
                    "gamma is then mostly the noise's derivative, and the optimisation "
                    "never nears its stationary point."
                if grown.min() > 2.0 else
                f"At {max(NOISE_STDS):g} V the adaptation error is {grown.min():.3g} to "
                f"{grown.max():.3g} times the noise-free run's."]
        per_sample = loud[(loud["integrator"] == "second-order") & (loud["adapt_every"] == 1)]
        slow = loud[loud["adapt_every"] == SLOW_EVERY]
        if len(per_sample) and len(slow):
            ratio = float(slow["gamma_dev_100pct"].iloc[0]
                          / per_sample["gamma_dev_100pct"].iloc[0])
            out += ["", f"Updating gamma every {SLOW_EVERY} samples on the force's mean "
                        f"leaves {ratio:.0%} of the per-sample update's deviation at the end"
                    + (": the mean of the error's differences telescopes as their sum does, "
                       "so the slower time scale does not remove the drift."
                       if ratio > 0.5 else ".")]
        out += ["", f"At a digital controller's period ({DIGITAL_H * 1e6:g} us, the plant "
                    f"still integrated every {DIGITAL_H / SUBSTEPS * 1e6:g} us), the gains "
                    "as the cases set them:", "",
                "| law | period (s) | Gamma | settled | max abs e after 1 ms | IAE |",
                "|---|---|---|---|---|---|"]
        for _, r in digital.iterrows():
            rate = "-" if r["Gamma"] is None or (isinstance(r["Gamma"], float)
                                                  and math.isnan(r["Gamma"])) \
                else f"{r['Gamma']:.3g}"
            out.append(f"| {r['law']} | {r['period_s']:g} | {rate} | "
                       f"{'yes' if r['settled'] else 'no'} | {_e(r['max_abs_e'])} | "
                       f"{_e(r['iae'])} |")
        held = digital[(digital["period_s"] == DIGITAL_H)
                       & digital["law"].str.startswith("variational")]["settled"]
        std20 = digital[(digital["period_s"] == DIGITAL_H)
                        & (digital["law"] == "standard i-P")]["settled"].all()
        out += ["", "At 20 us the variational law "
                + ("holds the load change" if held.all() else
                   "does not hold the load change" if not held.any() else
                   "holds the load change with one choice of Gamma and not the other")
                + "; the standard i-P " + ("holds it." if std20 else "does not hold it.")]
        out += ["", "The loop linearised with gamma frozen along the run's path (the "
                    "variational law's worst radius over the gammas it records):", "",
                "| load changes | R (ohm) | standard i-P radius | variational radius, "
                "gamma frozen | gamma range | slowest decay per sample | largest "
                "relative change of gamma per sample |", "|---|---|---|---|---|---|---|"]
        for _, r in frozen.iterrows():
            out.append(f"| {int(r['load_changes'])} | {r['R_ohm']:g} | "
                       f"{r['standard_radius']:.6f} | {r['variational_radius_worst']:.6f} | "
                       f"{r['gamma_min']:.4g} to {r['gamma_max']:.4g} | "
                       f"{_e(r['slowest_decay_per_sample'])} | "
                       f"{_e(r['gamma_change_per_sample_max'])} |")
        valid = (frozen["gamma_change_per_sample_max"]
                 < 0.1 * frozen["slowest_decay_per_sample"]).all()
        lost = frozen[frozen["standard_radius"] > 1.0]["load_changes"]
        stable = (frozen["variational_radius_worst"] < 1.0).all()
        out += ["", ("The frozen loop is stable at every load, at both ends of the recorded "
                     "gamma" if stable else
                     "The frozen loop is unstable at some load or end of the recorded gamma")
                + (f"; the standard i-P's loop is unstable from load change "
                   f"{int(lost.min())} on" if len(lost) else "; so is the standard i-P's")
                + ". " + ("Gamma changes by less than a tenth of the slowest mode's decay "
                          "per sample, so the frozen analysis holds: what keeps the "
                          "variational loop stable is where its gain sits (gamma0), not "
                          "its motion." if valid else
                          "Gamma changes faster than a tenth of the slowest mode's decay "
                          "per sample somewhere: the frozen analysis stops being valid "
                          "there, and the motion of gamma itself matters.")]
        if "symplectic" in studies[fid]:
            out += symplectic_lines(studies[fid]["symplectic"])
        if "operating_range" in studies[fid]:
            out += operating_range_lines(studies[fid]["operating_range"])
    return out
