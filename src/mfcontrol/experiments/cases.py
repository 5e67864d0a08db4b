"""Built-in cases (TOML files shipped in the package) and user case files."""

from __future__ import annotations

import tomllib
from collections.abc import Collection, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..api.results.result import Result, SweepResult
from ..api.run.simulate import _member, keys_read_by_run, simulate, simulate_sweep
from ..config.options import OPTIONS
from ..config.resolve import Config, resolve
from ..config.toml import flatten
from ..errors import CaseError, ConfigError

if TYPE_CHECKING:
    from ..api.model.controllers import ADRC, PID, IntelligentController, RecursiveIP

CASES_DIR = Path(__file__).parent / "cases"


def names() -> list[str]:
    """Names of the built-in cases."""
    return sorted(p.stem for p in CASES_DIR.glob("*.toml"))


def _path(name_or_path: str | Path) -> tuple[str, Path]:
    p = Path(name_or_path)
    # a folder named as a built-in case (an --out folder, say) does not hide the case
    if p.suffix == ".toml" or (p.exists() and not p.is_dir()):
        if not p.is_file():
            raise CaseError(f"case file {str(p)!r} not found")
        return p.stem, p
    if p.is_dir() and str(name_or_path) not in names():
        raise CaseError(f"{str(p)!r} is a folder, not a case: give a built-in case's name "
                        "or the path of a .toml file")
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
    except ValueError:  # an integer past Python's int-to-str limit (4,300 digits)
        raise CaseError(f"case file {str(path)!r} holds too long a number: options are "
                        "numbers within the float range") from None
    except RecursionError:
        raise CaseError(f"case file {str(path)!r} is nested too deeply: options are "
                        "numbers, strings, true/false or lists of numbers") from None
    try:
        return name, flatten(table)
    except RecursionError:
        raise CaseError(f"case file {str(path)!r} is nested too deeply: options are "
                        "numbers, strings, true/false or lists of numbers") from None


def resolve_case(name_or_path: str | Path, overrides: Mapping[str, Any] | None = None, *,
                 command: str | None = None) -> tuple[str, Config]:
    """Load a case and resolve it with ``overrides`` (dotted keys) on top; with
    ``command``, refuse a key set that the command will not read (:func:`check_reads`)."""
    name, settings = load(name_or_path)
    cfg = resolve({**settings, **dict(overrides or {})})
    if command is not None:
        check_reads(cfg, command, overrides or {},
                    case=resolve(settings) if overrides else cfg)
    return name, cfg


#: what :func:`check_reads` knows of each command's reads: ``run`` (also show, tune,
#: compare, export-c and the tuner: a run of the case, or its controller), ``sweep`` (a
#: grid over its run) and ``benchmark``
COMMANDS = ("run", "sweep", "benchmark")


def keys_read_by(command: str, cfg: Config) -> set[str]:
    """The options ``mfcontrol COMMAND`` reads of the case ``cfg`` (see :data:`COMMANDS`):
    found by running the translators, as :func:`mfcontrol.api.run.simulate.keys_read_by_run`
    finds a run's."""
    if command == "sweep":  # the grid replaces a sweep case's own sweep
        base = cfg.with_overrides({"sweep.key": None, "sweep.values": None,
                                   "sweep.grid": None})
        return keys_read_by_run(base) | {"description", "sweep.grid"}
    if command == "benchmark":  # every controller it tunes, on the case as it is
        from .benchmark import CONTROLLERS

        read = {o.key for o in OPTIONS if o.key.startswith("benchmark.")} | {"description"}
        for _, law, _ in CONTROLLERS:
            read |= keys_read_by_run(cfg.with_overrides({"controller.law": law}))
        return read
    if command != "run":
        raise ValueError(f"command = {command!r}: must be one of {', '.join(COMMANDS)}")
    return keys_read_by_run(cfg) | {"description"}


def check_reads(cfg: Config, command: str, given: Mapping[str, Any] | Collection[str] = (),
                *, case: Config | None = None) -> None:
    """Refuse an option of ``cfg`` that is set but that ``mfcontrol COMMAND`` will not read,
    with one line that says why and what to set (:func:`mfcontrol.config.reads.why_unread`).

    A key ``given`` for this command (``--set``, ``overrides``) must be read by it. The keys
    of the ``case`` file (the configuration it resolves to alone) must be read by its own
    run or by this command, or be the keys of the other commands that run it: ``[sweep]``,
    and ``[benchmark]`` with, in a case that has one, the keys the benchmark's controllers
    read (an i-P's estimator in a PID's case). A key of the file that an override leaves
    unread (a case's ki once the law is switched to an i-P) is the override's choice, not
    an error. A sweep case's swept key must be read by its members."""
    from ..config.reads import refuse_unread, why_unread

    read = keys_read_by(command, cfg)
    explicit = cfg.explicit
    set_here = {k: explicit[k] for k in given if k in explicit}
    refuse_unread(cfg, set_here, keys_read_by_run, read=read)
    if case is not None:
        own = {k: v for k, v in case.explicit.items() if k not in set_here}
        for_others = {"description", "sweep.key", "sweep.values", "sweep.grid"}
        if any(k.startswith("benchmark.") for k in own):
            for_others |= keys_read_by("benchmark", case)
        refuse_unread(case, own, keys_read_by_run,
                      read=keys_read_by(command, case) | keys_read_by_run(case) | for_others)
    key = cfg["sweep.key"]
    if command == "run" and key is not None:
        members = keys_read_by_run(cfg) - {"sweep.key", "sweep.values"}
        if key not in members:
            member = _member(cfg, key, cfg["sweep.values"][0])
            raise ConfigError("sweep.key", key, why_unread(
                member, key, keys_read_by_run, instead="sweep another key"))


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
        ``{"fidelity": "paper", "plant.dR": 5.0}``. A key the run would not read (an
        integral gain under an i-P) is refused, as any key of the case that no command
        running it reads (:func:`check_reads`).

    Returns
    -------
    Result or SweepResult
        A sweep case (one with ``[sweep]``) returns one member per swept value.

    Examples
    --------
    >>> import mfcontrol
    >>> r = mfcontrol.run_case("voltage-stable-standard", overrides={"sim.t_end": 1e-3})
    >>> r.metrics["settled"], round(float(r.signals["y"][-1]), 3)
    (True, 0.926)
    """
    name, cfg = resolve_case(name_or_path, overrides, command="run")
    return run_config(cfg, name)


def run_config(cfg: Config, name: str = "", *, fast: bool = False) -> Result | SweepResult:
    """Run a resolved configuration: a sweep when it has ``sweep.key``, else one run
    (``fast``: the compiled kernel's fast mode, see :func:`mfcontrol.simulate`)."""
    if cfg["sweep.key"] is not None:
        return simulate_sweep(cfg, name=name, fast=fast)
    return simulate(cfg, name=name, fast=fast)


def make_controller(case: str | Path | Config, overrides: Mapping[str, Any] | None = None,
                    *, input_limits: tuple[float | None, float | None] | None = None
                    ) -> IntelligentController | RecursiveIP | PID | ADRC:
    """The live controller of a case: the object a sampling loop (or exported C) runs, built
    by the translator every run of the case uses
    (:func:`mfcontrol.api.run.from_config.controller`).

    Parameters
    ----------
    case : str, Path or Config
        A built-in case, a case file or a resolved configuration.
    overrides : mapping, optional
        Dotted keys set on the case first (as ``--set``); each must be one the case's
        run reads (:func:`check_reads`).
    input_limits : (low, high), optional
        The measurement's valid range (the sensor's; None for no limit), as
        ``export-c --input-limits`` gives it: a sample outside is rejected as a NaN is.
        A fixed-point export's scale comes from it, so this builds the controller an
        export was made from (``like=`` of
        :func:`mfcontrol.cexport.fixed_point.fixed_params_c`).

    Returns
    -------
    IP, IPI, IPD, IPID, PID, ADRC or RecursiveIP
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

    if isinstance(case, Config):
        cfg = case.with_overrides(dict(overrides or {}))
        check_reads(cfg, "run", overrides or {})
    else:
        cfg = resolve_case(case, overrides, command="run")[1]
    ctrl = controller(cfg)
    if input_limits is not None:
        try:
            ctrl._take_input_limits(input_limits)
        except ValueError as exc:
            raise ConfigError("input_limits", input_limits,
                              str(exc).partition(": ")[2]) from None
    return ctrl
