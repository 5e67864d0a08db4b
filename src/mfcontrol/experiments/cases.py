"""Built-in cases (TOML files shipped in the package) and user case files."""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..api.results.result import Result, SweepResult
from ..api.run.simulate import simulate, simulate_sweep
from ..config.resolve import Config, resolve
from ..config.toml import flatten
from ..errors import CaseError

if TYPE_CHECKING:
    from ..api.model.controllers import PID, IntelligentController, RecursiveIP

CASES_DIR = Path(__file__).parent / "cases"


def names() -> list[str]:
    """Names of the built-in cases."""
    return sorted(p.stem for p in CASES_DIR.glob("*.toml"))


def _path(name_or_path: str | Path) -> tuple[str, Path]:
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
        if not p.is_file():
            raise CaseError(f"case file {str(p)!r} not found")
        return p.stem, p
    builtin = CASES_DIR / f"{name_or_path}.toml"
    # a name, not a path: "../cases/x" would name a built-in file and write outside results/
    if str(name_or_path) not in names():
        raise CaseError(f"unknown case {str(name_or_path)!r}: built-in cases are "
                        f"{', '.join(names())}; or give the path of a .toml file")
    return str(name_or_path), builtin


def load(name_or_path: str | Path) -> tuple[str, dict[str, Any]]:
    """The case's name and its settings as dotted keys (not yet validated)."""
    name, path = _path(name_or_path)
    try:
        table = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise CaseError(f"case file {str(path)!r} is not valid TOML: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CaseError(f"case file {str(path)!r} cannot be read: {exc}") from None
    except RecursionError:
        raise CaseError(f"case file {str(path)!r} is nested too deeply: options are "
                        "numbers, strings, true/false or lists of numbers") from None
    try:
        return name, flatten(table)
    except RecursionError:
        raise CaseError(f"case file {str(path)!r} is nested too deeply: options are "
                        "numbers, strings, true/false or lists of numbers") from None


def resolve_case(name_or_path: str | Path,
                 overrides: Mapping[str, Any] | None = None) -> tuple[str, Config]:
    """Load a case and resolve it with ``overrides`` (dotted keys) on top."""
    name, settings = load(name_or_path)
    return name, resolve({**settings, **dict(overrides or {})})


def describe(name: str) -> str:
    return load(name)[1].get("description", "")


def run_case(name_or_path: str | Path,
             overrides: Mapping[str, Any] | None = None) -> Result | SweepResult:
    """Run a built-in case or a case file.

    Parameters
    ----------
    name_or_path : str or Path
        A built-in case name (see ``mfcontrol cases``) or the path of a TOML case file.
    overrides : mapping, optional
        Dotted configuration keys to set on top of the case, e.g.
        ``{"fidelity": "paper", "plant.dR": 5.0}``.

    Returns
    -------
    Result or SweepResult
        A sweep case (one with ``[sweep]``) returns one member per swept value.

    Examples
    --------
    >>> import mfcontrol
    >>> r = mfcontrol.run_case("voltage-stable-standard", overrides={"sim.t_end": 1e-3})
    >>> r.metrics["stable"], round(float(r.signals["y"][-1]), 3)
    (True, 0.926)
    """
    name, cfg = resolve_case(name_or_path, overrides)
    return run_config(cfg, name)


def run_config(cfg: Config, name: str = "", *, fast: bool = False) -> Result | SweepResult:
    """Run a resolved configuration: a sweep when it has ``sweep.key``, else one run
    (``fast``: the compiled kernel's fast mode, see :func:`mfcontrol.simulate`)."""
    if cfg["sweep.key"] is not None:
        return simulate_sweep(cfg, name=name, fast=fast)
    return simulate(cfg, name=name, fast=fast)


def make_controller(case: str | Path | Config, overrides: Mapping[str, Any] | None = None
                    ) -> IntelligentController | RecursiveIP | PID:
    """The live controller of a case: the object a sampling loop (or exported C) runs, built
    by the translator every run of the case uses
    (:func:`mfcontrol.api.run.from_config.controller`).

    Parameters
    ----------
    case : str, Path or Config
        A built-in case, a case file or a resolved configuration.
    overrides : mapping, optional
        Dotted keys set on the case first (as ``--set``).

    Returns
    -------
    IP, IPI, IPD, IPID, PID or RecursiveIP
        A fresh controller with the case's gains, limits, estimator and sample time
        (``sim.h``); call it with each measurement and setpoint.

    Examples
    --------
    Fed the measurements and references of the case's own run, it gives the run's control
    bit for bit:

    >>> import mfcontrol
    >>> r = mfcontrol.run_case("motor-noise-ipi-algebraic", {"sim.t_end": 1.0})
    >>> ctrl = mfcontrol.make_controller("motor-noise-ipi-algebraic")
    >>> u = [ctrl(y, setpoint=ref) for y, ref in zip(r.signals["y_meas"], r.signals["y_ref"])]
    >>> bool((u == r.signals["u"]).all())
    True
    """
    from ..api.run.from_config import controller

    cfg = case.with_overrides(dict(overrides or {})) if isinstance(case, Config) else \
        resolve_case(case, overrides)[1]
    return controller(cfg)
