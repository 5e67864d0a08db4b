"""``mfcontrol reproduce``: every result of the paper's section IV, in one folder.

Layout of ``OUT``::

    report.md                       figures, comparison tables, the findings in words
    FIDELITY/CASE.png, CASE.csv     each single case (output + reference, duty cycle)
    FIDELITY/CASE-gamma.png         gamma(t) for the variational cases
    FIDELITY/SWEEP-gamma.png, SWEEP-error.png, SWEEP.csv
    FIDELITY/comparison-CASE.csv    the table behind each comparison
    FIDELITY/claims-STUDY.csv       the claims under noise, at 20 us, with gamma frozen,
                                    as a symplectic integrator, over the power cases'
                                    operating range

Each file is written as soon as its run finishes, so an interrupted reproduction keeps
everything it finished.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from ..api.results.plotting import (
    plot_gamma,
    plot_long_horizon,
    plot_run,
    plot_sweep,
    title_in_words,
    units,
)
from ..api.results.result import Result, SweepResult
from . import claims, maps, report
from .cases import resolve_case, run_case, run_config

SINGLE = (
    "voltage-stable-standard", "voltage-stable-variational",
    "voltage-unstable-standard", "voltage-unstable-variational",
    "power-standard", "power-variational",
)
SWEEPS = ("sweep-Gamma", "sweep-epsM")
VARIATIONAL = tuple(c for c in SINGLE if c.endswith("variational"))
MAPS = ("map-alpha-dR-standard", "map-alpha-dR-variational", "map-Gamma-epsM")
#: the common x axis of the two alpha x dR maps: alpha, or 1/gamma0 for the variational law
GAIN_AXIS = "alpha (variational: 1/gamma0)"
LONG_HORIZON = 0.1  # s


def run_map(case: str, fidelity: str):
    """All members of a map case's grid, as a DataFrame."""
    import pandas as pd

    from ..api.run import batch

    _, cfg = resolve_case(case, {"fidelity": fidelity})
    axes = batch.parse_grid(cfg["sweep.grid"])
    grid = batch.make_grid(cfg.with_overrides({"sweep.grid": None}), axes)
    return pd.DataFrame(batch.run_grid(grid))


def gain_axis(frame):
    """The alpha x dR maps on one x axis: alpha (standard) or 1/gamma0 (variational)."""
    frame = frame.copy()
    if "controller.gamma0" in frame:
        frame[GAIN_AXIS] = 1 / frame.pop("controller.gamma0")
    else:
        frame[GAIN_AXIS] = frame.pop("controller.alpha")
    return frame


#: a fidelity in words, for figure titles
_AS = {"published": "as the published code computes it", "paper": "with the printed equations"}


def _single(case: str, overrides: Mapping[str, Any]) -> Result:
    """The run of a case that is one run (not a sweep), with ``overrides``: as
    ``run_case``, but for the baselines a variational case's options may go unread
    (the standard law, ``controller.law = "ip"``, has no gamma0)."""
    name, cfg = resolve_case(case, overrides)
    r = run_config(cfg, name)
    assert isinstance(r, Result), case
    return r


def long_horizon(fidelity: str) -> list[tuple[str, str, Result]]:
    """The variational cases over 100 ms with both gamma integrators. The reference holds
    2.5 V after its first ramp (the paper's second ramp would pass E = 20 V)."""
    rows = []
    for case in ("voltage-stable-variational", "voltage-unstable-variational"):
        for order in ("first-order", "second-order"):
            r = _single(case, {"fidelity": fidelity, "sim.t_end": LONG_HORIZON,
                                "controller.integrator": order, "reference.t_ramp2": None})
            rows.append((case, order, r))
    return rows


def comparison_rows(case: str, fidelity: str) -> list[tuple[str, Result]]:
    """The runs compared for one variational case under one fidelity."""
    base = _single(case, {"fidelity": fidelity})
    assert base.config is not None  # a case run
    # the paper's alpha is its standard case's (the variational law has none)
    alpha = resolve_case(case.replace("-variational", "-standard"))[1]["controller.alpha"]
    gamma0 = base.config["controller.gamma0"]
    rows = [
        (f"standard i-P, alpha = {alpha:g} (paper)",
         _single(case, {"fidelity": fidelity, "controller.law": "ip",
                        "controller.alpha": alpha})),
        (f"standard i-P, alpha = 1/gamma0 = {1 / gamma0:g} (equal gain)",
         _single(case, {"fidelity": fidelity, "controller.law": "ip",
                        "controller.alpha": 1 / gamma0})),
    ]
    if fidelity == "published":
        rows.append(("variational, as published", base))
    else:
        rows.append(("variational, as printed", base))
        rows.append(("variational, as printed, gain = alpha (eq. 33 literally)",
                     _single(case, {"fidelity": fidelity, "controller.gain": "alpha"})))
    return rows


def reproduce(out: Path, fidelities: list[str],
              progress: Callable[[str], None] = lambda msg: None) -> Path:
    """Run every case and study under each fidelity; write figures, data and report.md."""
    out.mkdir(parents=True, exist_ok=True)
    runs: dict[str, dict[str, Result | SweepResult]] = {}
    tables: dict[str, dict[str, list[tuple[str, Result]]]] = {}
    maps_done: dict[str, dict] = {}
    horizons: dict[str, list] = {}
    studies: dict[str, dict[str, Any]] = {}
    total = len(fidelities) * (len(SINGLE) + len(SWEEPS) + len(VARIATIONAL) + len(MAPS) + 2)
    done = 0

    def tick(what: str) -> None:
        nonlocal done
        done += 1
        progress(f"[{done}/{total}] {what}")

    for fid in fidelities:
        folder = out / fid
        folder.mkdir(exist_ok=True)
        runs[fid] = {}
        for case in SINGLE:
            r = _single(case, {"fidelity": fid})
            runs[fid][case] = r
            r.to_csv(folder / f"{case}.csv")
            plot_run(r, folder / f"{case}.png", with_gamma=False,
                     title=title_in_words(r, case, _AS[fid]))
            if case in VARIATIONAL:
                plot_gamma(r, folder / f"{case}-gamma.png",
                           title=title_in_words(r, case, f"gain gamma over time, {_AS[fid]}"))
            tick(f"{fid}/{case}")
        for case in SWEEPS:
            s = run_case(case, {"fidelity": fid})
            assert isinstance(s, SweepResult), case
            runs[fid][case] = s
            s.to_csv(folder / f"{case}.csv")
            plot_sweep(s, "gamma", folder / f"{case}-gamma.png",
                       title=title_in_words(s, case, f"gain gamma of each member, {_AS[fid]}"))
            plot_sweep(s, "error", folder / f"{case}-error.png",
                       title=title_in_words(s, case, f"tracking error of each member, "
                                                     f"{_AS[fid]}"))
            tick(f"{fid}/{case}")
        tables[fid] = {}
        for case in VARIATIONAL:
            rows = comparison_rows(case, fid)
            tables[fid][case] = rows
            report.table_frame(rows).to_csv(folder / f"comparison-{case}.csv", index=False)
            tick(f"{fid}/comparison {case}")
        maps_done[fid] = {}
        for case in MAPS:
            frame = run_map(case, fid)
            frame.to_csv(folder / f"{case}.csv", index=False, float_format="%.17g")
            maps_done[fid][case] = frame
            tick(f"{fid}/{case} ({len(frame)} members)")
        std, var = (gain_axis(maps_done[fid][c]) for c in MAPS[:2])
        volts = units(resolve_case(MAPS[0])[1])  # the buck's voltage: V under a duty cycle
        maps.draw_maps_side_by_side(
            [(std, "standard i-P"), (var, "variational i-P")], GAIN_AXIS, "plant.dR",
            "max_abs_e", folder / "map-alpha-dR.png", units=volts)
        maps.heatmap(maps_done[fid]["map-Gamma-epsM"], "controller.Gamma", "controller.eps_M",
                     "max_abs_e", title=f"variational i-P, dR = 5 ohm ({fid}): largest |e| "
                     "after 1 ms", units=volts).savefig(folder / "map-Gamma-epsM.png", dpi=120)
        horizons[fid] = long_horizon(fid)
        plot_long_horizon(horizons[fid], folder / "long-horizon.png", fid)
        report.horizon_frame(horizons[fid]).to_csv(folder / "long-horizon.csv", index=False)
        tick(f"{fid}/long horizon")
        studies[fid] = {"noise": claims.noise_study(fid),
                        "sample_time": claims.sample_time_study(fid),
                        "frozen": claims.frozen_gain_study(fid),
                        "symplectic": claims.symplectic_study(fid),
                        "operating_range": claims.operating_range_study(fid)}
        for study, frame in studies[fid].items():
            frame.to_csv(folder / f"claims-{study}.csv", index=False, float_format="%.17g")
        tick(f"{fid}/claims under noise, at 20 us, with gamma frozen, as a symplectic "
             "integrator, over the operating range")
    path = out / "report.md"
    path.write_text(report.render(runs, tables, fidelities, maps_done, horizons, studies),
                    encoding="utf-8")
    return path
