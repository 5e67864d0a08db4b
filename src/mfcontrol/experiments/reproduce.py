"""``mfcontrol reproduce``: every result of the paper's section IV, in one folder.

Layout of ``OUT``::

    report.md                       figures, comparison tables, the findings in words
    FIDELITY/CASE.png, CASE.csv     each single case (output + reference, duty cycle)
    FIDELITY/CASE-gamma.png         gamma(t) for the variational cases
    FIDELITY/SWEEP-gamma.png, SWEEP-error.png, SWEEP.csv
    FIDELITY/comparison-CASE.csv    the table behind each comparison

Each file is written as soon as its run finishes, so an interrupted reproduction keeps
everything it finished.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from ..plotting import plot_gamma, plot_run, plot_sweep
from ..result import Result, SweepResult
from . import report
from .cases import run_case

SINGLE = (
    "voltage-stable-standard", "voltage-stable-variational",
    "voltage-unstable-standard", "voltage-unstable-variational",
    "power-standard", "power-variational",
)
SWEEPS = ("sweep-Gamma", "sweep-epsM")
VARIATIONAL = tuple(c for c in SINGLE if c.endswith("variational"))


def comparison_rows(case: str, fidelity: str) -> list[tuple[str, Result]]:
    """The runs compared for one variational case under one fidelity."""
    base = run_case(case, {"fidelity": fidelity})
    alpha = base.config["controller.alpha"]
    gamma0 = base.config["controller.gamma0"]
    rows = [
        (f"standard i-P, alpha = {alpha:g} (paper)",
         run_case(case, {"fidelity": fidelity, "controller.law": "ip"})),
        (f"standard i-P, alpha = 1/gamma0 = {1 / gamma0:g} (equal gain)",
         run_case(case, {"fidelity": fidelity, "controller.law": "ip",
                         "controller.alpha": 1 / gamma0})),
    ]
    if fidelity == "published":
        rows.append(("variational, as published", base))
    else:
        rows.append(("variational, as printed", base))
        rows.append(("variational, as printed, gain = alpha (eq. 33 literally)",
                     run_case(case, {"fidelity": fidelity, "controller.gain": "alpha"})))
    return rows


def reproduce(out: Path, fidelities: list[str],
              progress: Callable[[str], None] = lambda msg: None) -> Path:
    """Run every case and study under each fidelity; write figures, data and report.md."""
    out.mkdir(parents=True, exist_ok=True)
    runs: dict[str, dict[str, Result | SweepResult]] = {}
    tables: dict[str, dict[str, list[tuple[str, Result]]]] = {}
    total = len(fidelities) * (len(SINGLE) + len(SWEEPS) + len(VARIATIONAL))
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
            r = run_case(case, {"fidelity": fid})
            runs[fid][case] = r
            r.to_csv(folder / f"{case}.csv")
            plot_run(r, folder / f"{case}.png", title=f"{case} ({fid})", with_gamma=False)
            if case in VARIATIONAL:
                plot_gamma(r, folder / f"{case}-gamma.png",
                           title=f"{case} ({fid}): evolution of gamma")
            tick(f"{fid}/{case}")
        for case in SWEEPS:
            s = run_case(case, {"fidelity": fid})
            runs[fid][case] = s
            s.to_csv(folder / f"{case}.csv")
            plot_sweep(s, "gamma", folder / f"{case}-gamma.png",
                       title=f"{case} ({fid}): gamma for several {s.key.split('.')[-1]}")
            plot_sweep(s, "error", folder / f"{case}-error.png",
                       title=f"{case} ({fid}): tracking error for several "
                             f"{s.key.split('.')[-1]}")
            tick(f"{fid}/{case}")
        tables[fid] = {}
        for case in VARIATIONAL:
            rows = comparison_rows(case, fid)
            tables[fid][case] = rows
            report.table_frame(rows).to_csv(folder / f"comparison-{case}.csv", index=False)
            tick(f"{fid}/comparison {case}")
    path = out / "report.md"
    path.write_text(report.render(runs, tables, fidelities), encoding="utf-8")
    return path
