"""``export_c``: a case's (or any live controller's) law as ``PREFIX.h`` and ``PREFIX.c``."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..api.model.controllers import _Controller
from ..config.resolve import Config
from ..errors import ConfigError
from ..files import write_text
from .source import CSource, c_source


def export_c(case: str | Path | Config | Any, overrides: Mapping[str, Any] | None = None, *,
             out: str | Path = ".", prefix: str = "mfc", real: str = "double",
             description: str | None = None,
             input_limits: tuple[float | None, float | None] | None = None,
             frozen: bool = False) -> tuple[Path, Path]:
    """Write the controller of a case as C99: ``OUT/PREFIX.h`` and ``OUT/PREFIX.c``.

    The C is translated from the same law functions the simulators run. The law's
    tunable parameters (gains, limits: :mod:`mfcontrol.laws.tunable`) are named members
    of ``PREFIX_params``, which ``PREFIX_set_params`` checks and changes at run time as
    the live controller's ``retune`` does; the rows that fix the law's structure are
    constants the compiler folds (every row with ``frozen``). Compiled without
    floating-point contraction
    (``cc -std=c99 -O2 -ffp-contract=off``), the double build returns what
    :func:`mfcontrol.make_controller` returns, bit for bit, for any sequence of
    measurements, setpoints and manual/automatic switches.

    Parameters
    ----------
    case : str, Path, Config or live controller
        A built-in case, a case file, a resolved configuration, or a controller built in
        Python (``IP``, ``IPI``, ``IPD``, ``IPID``, ``PID``, ``ADRC``, ``RecursiveIP``).
    overrides : mapping, optional
        Dotted keys set on the case first (as ``--set``); not for a controller.
    out : str or Path
        Folder of the two files (created if missing).
    prefix : str
        Prefix of the files and of every exported name (``PREFIX_step``...).
    real : {"double", "float", "q31", "q15"}
        Number type of the exported code. ``"q31"`` is fixed point for a core without a
        floating-point unit: the PID (:mod:`mfcontrol.cexport.fixed_point`) and the i-P,
        i-PI, i-PD and i-PID with the backward difference and a constant gain
        (:mod:`mfcontrol.cexport.fixed_point_intelligent`), with ``input_limits`` for the
        measurement's scale; ``"q15"`` the PID in 16-bit codes (about half q31's cycles on
        a Cortex-M0, for codes of 2^-15 of the scale). The coefficients are in a parameter
        struct unless ``frozen`` (:func:`mfcontrol.cexport.fixed_point.fixed_params_c`
        writes one for new gains).
    description : str, optional
        What the files' leading comment says they came from (default: the case and its
        overrides, or the controller's repr).
    input_limits : (low, high), optional
        The measurement's valid range (the sensor's; None for no limit) given to a case's
        controller: a sample outside is rejected as a NaN is. A controller built in Python
        takes its own ``input_limits=``.
    frozen : bool
        Every parameter a constant and no setter (the least code).

    Returns
    -------
    (Path, Path)
        The header and the source written.

    Examples
    --------
    >>> import mfcontrol, tempfile
    >>> folder = tempfile.mkdtemp()
    >>> h, c = mfcontrol.export_c("motor-noise-ipi-algebraic", out=folder, prefix="motor")
    >>> h.name, c.name
    ('motor.h', 'motor.c')
    >>> print(next(line for line in h.read_text().splitlines() if "motor_step(" in line))
    motor_real motor_step(motor_state *s, motor_real y, motor_real setpoint);
    >>> print(next(line for line in h.read_text().splitlines() if "_set_params(" in line))
    int motor_set_params(motor_state *s, const motor_params *p);

    ``motor_real`` is ``double`` here and ``float`` with ``real="float"``; ``motor_params``
    holds ``kp``, ``ki``, ``inv_alpha`` (1 / alpha) and the output limits.
    """
    src = source_of(case, overrides, prefix=prefix, real=real, description=description,
                    input_limits=input_limits, frozen=frozen)
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    header, source = folder / f"{prefix}.h", folder / f"{prefix}.c"
    write_text(header, src.header)  # whole or not at all
    write_text(source, src.source)
    return header, source


def source_of(case, overrides=None, *, prefix: str = "mfc", real: str = "double",
              description: str | None = None,
              input_limits: tuple[float | None, float | None] | None = None,
              frozen: bool = False) -> CSource:
    """The :class:`CSource` :func:`export_c` writes."""
    from ..experiments.cases import make_controller

    if isinstance(case, _Controller):
        if overrides:
            raise ConfigError("overrides", dict(overrides), "apply to a case, not to a "
                              "controller built in Python")
        if input_limits is not None:
            raise ConfigError("input_limits", input_limits, "build the controller with "
                              "input_limits=, not its export")
        return c_source(case, prefix=prefix, real=real, frozen=frozen,
                        description=description or repr(case))
    ctrl = make_controller(case, overrides, input_limits=input_limits)
    what = case if isinstance(case, str | Path) else getattr(case, "name", "a configuration")
    sets = "".join(f" --set {k}={v!r}" for k, v in (overrides or {}).items())
    return c_source(ctrl, prefix=prefix, real=real, key_prefix="controller.", frozen=frozen,
                    description=description or f"case {what}{sets}")
