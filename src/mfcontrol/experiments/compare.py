"""``mfcontrol compare``: several cases on one scenario, side by side.

Each case runs as ``mfcontrol run`` runs it (``--set`` applies to all of them, so one
noise seed or plant change reaches every case). The cases should differ in their
controller only; any other key they differ in is listed in the report, since the
comparison is then not of controllers alone.

Layout of ``OUT``::

    comparison.csv   one row per case: every metric column
    comparison.md    the main metrics as a table, and what differs between the cases
    comparison.png   outputs on one axis, controls below, the metrics table beside
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..api.results import display
from ..api.results import metrics as _metrics
from ..api.results.metrics import COLUMNS
from ..api.results.result import Result
from ..config.resolve import Config
from ..errors import ConfigError

if TYPE_CHECKING:
    import pandas as pd

#: the columns of the markdown table and the figure's table: (metric, header)
SHOWN = (*((m, _metrics.SHORT[m]) for m in ("iae", "iae_load", "tv_u")),
         ("overshoot", "overshoot %"), ("settling_time", "settling (s)"), ("settled", "settled"))
#: keys that may differ between compared cases without changing the scenario
_OWN = ("description", "controller.", "sweep.")


@dataclass
class Comparison(display.Shown):
    """The runs of :func:`compare` and what they share.

    Attributes
    ----------
    names : list of str
        The cases compared, in order.
    configs : list of Config
        Their resolved configurations (with the common ``--set`` overrides).
    results : list of Result
        Their runs.
    """

    names: list[str]
    configs: list[Config]
    results: list[Result] = field(repr=False)

    def _summary(self) -> list[tuple[str, str]]:
        return [(f"{n} ({controller_label(c)})", f"{display.verdict(r.metrics)}; "
                 f"{display.metric_line(r.metrics)}")
                for n, c, r in zip(self.names, self.configs, self.results, strict=True)]

    def __repr__(self) -> str:
        lines = [f"{k}: {v}" for k, v in self._summary()]
        return (f"<Comparison of {len(self.names)} cases\n " + "\n ".join(lines[:8])
                + (f"\n and {len(lines) - 8} more" if len(lines) > 8 else "") + ">")


    def differences(self) -> dict[str, list[Any]]:
        """Keys outside ``controller.*`` whose values differ between the cases."""
        public = [c.public() for c in self.configs]
        out = {}
        for k in sorted({k for p in public for k in p}):
            if k.startswith(_OWN):
                continue
            vals = [p.get(k) for p in public]
            if any(v != vals[0] for v in vals[1:]):
                out[k] = vals
        return out

    def rows(self) -> list[dict[str, Any]]:
        return [{"case": n, "controller": controller_label(c),
                 **{k: r.metrics[k] for k in COLUMNS}}
                for n, c, r in zip(self.names, self.configs, self.results, strict=True)]

    def to_pandas(self) -> pd.DataFrame:
        import pandas as pd

        return pd.DataFrame(self.rows())

    def _headers(self) -> list[str]:
        """The shown metrics' names with their units in the first case's plant's words."""
        from ..api.results.plotting import units

        y_unit, u_unit = units(self.configs[0])
        out = []
        for key, head in SHOWN:
            unit = _metrics.unit_of(key, y_unit, u_unit) if key in _metrics.LABELS else ""
            # those with a unit in their name already (overshoot %, settling (s)) keep it
            shown = unit not in ("", "1") and " (" not in head and "%" not in head
            out.append(f"{head} ({unit})" if shown else head)
        return out

    def markdown(self) -> str:
        head = ["case", "controller", *self._headers()]
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for row in self.rows():
            lines.append("| " + " | ".join([row["case"], row["controller"],
                                             *(format_number(row[k]) for k, _ in SHOWN)]) + " |")
        diff = self.differences()
        text = "\n".join(lines) + "\n"
        if diff:
            text += ("\nThe cases also differ outside their controllers, so this compares "
                     "more than controllers:\n\n" + "\n".join(
                         f"- `{k}`: " + ", ".join(f"{n} = {v!r}" for n, v in
                                                 zip(self.names, vals, strict=True))
                         for k, vals in diff.items()) + "\n")
        else:
            text += "\nThe cases share every plant, reference, loop and simulation key.\n"
        return text

    def save(self, out: str | Path, title: str | None = None) -> Path:
        """Write comparison.csv, comparison.md and comparison.png into ``out``."""
        from ..api.results.plotting import comparison

        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        self.to_pandas().to_csv(out / "comparison.csv", index=False)
        (out / "comparison.md").write_text(
            f"# Comparison: {', '.join(self.names)}\n\nMetrics of the true output y "
            "(`mfcontrol run` on each case).\n\n" + self.markdown())
        table = [[n, *(format_number(r.metrics[k], 3) for k, _ in SHOWN)]
                 for n, r in zip(self.names, self.results, strict=True)]
        # the unit on a line of its own: the figure's columns are narrow
        header = ["case", *(h.replace("overshoot %", "oversh. (%)").replace(" (", "\n(")
                            for h in self._headers())]
        labels = [controller_label(c) if controller_label(c).startswith(n)
                  else f"{n}: {controller_label(c)}"
                  for n, c in zip(self.names, self.configs, strict=True)]
        comparison(self.results, labels, table, header,
                   title or f"{len(self.names)} controllers on one scenario",
                   out / "comparison.png")
        return out


def format_number(v: Any, digits: int = 4) -> str:
    """A table cell: yes/no, n/a for NaN (not defined), inf, or ``digits`` significant
    digits."""
    if isinstance(v, bool | np.bool_):
        return "yes" if v else "no"
    if isinstance(v, float):
        return "n/a" if math.isnan(v) else f"{v:.{digits}g}"
    return str(v)


def controller_label(cfg: Config) -> str:
    """The controller in a few words: its law, its estimator of F (the positional
    intelligent laws) and its gains, e.g. ``i-PI, algebraic F (M 40) (alpha 50, kp 10,
    ki 30)``."""
    from ..api.run.from_config import controller
    from ..config.resolve import keys_read

    law = cfg["controller.law"]
    # the gains the law's translator reads (each law reads only its own)
    read = keys_read(controller, cfg)
    keys = [k for k in ("alpha", "kp", "ki", "kd", "b0", "wc", "wo")
            if f"controller.{k}" in read]
    gains = ", ".join(f"{k} {cfg[f'controller.{k}']:.4g}" for k in keys
                      if not (law == "pid" and k != "kp" and cfg[f"controller.{k}"] == 0))
    name = {"pid": "PID" if cfg["controller.kd"] else "PI" if cfg["controller.ki"] else "P",
            "ip": "paper's i-P", "variational": "variational i-P"}.get(law, law)
    if law == "adrc":
        name = f"ADRC of order {cfg['controller.order']}"
    if "controller.estimator" in read:  # two i-PIs told apart by their estimators of F
        name += (f", algebraic F (M {cfg['controller.window']})"
                 if cfg["controller.estimator"] == "algebraic" else ", backward-difference F")
    return f"{name} ({gains})"


def _refuse_unread_by_all(names: Sequence[str], configs: Sequence[Config],
                          overrides: Mapping[str, Any]) -> None:
    """A key set on every case must be read by one of them at least (an integral gain
    reaches the i-PI and the PID compared with an i-P): else it changes nothing."""
    from ..api.run.simulate import keys_read_by_run
    from ..config.reads import why_unread

    given = [k for k, v in overrides.items() if v is not None]
    read = set().union(*(keys_read_by_run(c) for c in configs)) | {"description"}
    for key in (k for k in given if k not in read):
        why = why_unread(configs[0], key, keys_read_by_run, instead="remove it")
        raise ConfigError(key, overrides[key], f"not read by any case compared; "
                          f"{names[0]}: {why}")


def compare(cases: Sequence[str | Path | Config],
            overrides: Mapping[str, Any] | None = None,
            out: str | Path | None = None) -> Comparison:
    """Run several cases on one scenario and compare them.

    Parameters
    ----------
    cases : list of str, Path or Config
        Built-in cases, case files or resolved configurations (at least two).
    overrides : mapping, optional
        Keys set on every case (as ``--set``); each must be read by one of them at least.
    out : str or Path, optional
        Write comparison.csv, comparison.md and comparison.png there.

    Examples
    --------
    >>> import mfcontrol
    >>> c = mfcontrol.compare(["motor-noise-pid", "motor-noise-ipi-algebraic"],
    ...                       {"sim.t_end": 2.0})
    >>> [row["case"] for row in c.rows()], c.differences()
    (['motor-noise-pid', 'motor-noise-ipi-algebraic'], {})
    """
    from ..api.run.simulate import simulate
    from . import cases as _cases

    if len(cases) < 2:
        raise ConfigError("cases", list(cases), "give at least two cases to compare")
    names: list[str] = []
    configs: list[Config] = []
    for c in cases:
        if isinstance(c, Config):
            name, cfg = f"config {len(names) + 1}", c.with_overrides(dict(overrides or {}))
        else:  # the case's own keys checked (the common ones below)
            name, own = _cases.resolve_case(c, command="run")
            cfg = own.with_overrides(dict(overrides or {}))
        if cfg["sweep.key"] is not None:
            raise ConfigError("cases", name, "is a sweep case: compare runs single cases")
        names.append(name)
        configs.append(cfg)
    _refuse_unread_by_all(names, configs, overrides or {})
    if len(set(names)) < len(names):
        names = [f"{n} ({i + 1})" for i, n in enumerate(names)]
    results = [simulate(c, name=n) for n, c in zip(names, configs, strict=True)]
    comp = Comparison(names, configs, results)
    if out is not None:
        comp.save(out)
    return comp
