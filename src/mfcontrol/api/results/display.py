"""How results show themselves: a repr of a few lines for a terminal and an HTML table for a
notebook, instead of every array they hold (a 500-sample run printed 60 kB).

>>> from mfcontrol.api.results.display import metric_line, verdict
>>> m = {"iae": 6.5e-4, "max_abs_e": 0.19, "tv_u": 0.77, "settled": True, "diverged": False}
>>> verdict(m), metric_line(m)
('settled', 'IAE 0.00065, max |e| 0.19, TV(u) 0.77')
"""

from __future__ import annotations

import html
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from .metrics import SHORT

#: the metrics a summary shows, with their labels
MAIN = tuple((m, SHORT[m]) for m in ("iae", "max_abs_e", "tv_u", "iae_load"))


def fmt(value: Any) -> str:
    """A number in 3 significant digits, a bool as yes/no, NaN as a dash."""
    if isinstance(value, bool | np.bool_):
        return "yes" if value else "no"
    if isinstance(value, int | np.integer):
        return f"{int(value):,}"
    if isinstance(value, float | np.floating):
        return "-" if not math.isfinite(value) else f"{float(value):.3g}"
    return str(value)


def verdict(metrics: Mapping[str, Any]) -> str:
    """settled, not settled, or where it diverged."""
    if metrics.get("diverged"):
        t = metrics.get("t_diverge", math.nan)
        return f"diverged at t = {fmt(t)} s" if t == t else "diverged"
    return "settled" if metrics.get("settled") else "not settled"


def metric_line(metrics: Mapping[str, Any]) -> str:
    """The main metrics that exist and are numbers."""
    return ", ".join(f"{label} {fmt(metrics[key])}" for key, label in MAIN
                     if key in metrics and metrics[key] == metrics[key])


def metric_ranges(table: Mapping[str, Any]) -> str:
    """Each main metric's range over the members (finite values only)."""
    parts = []
    for key, label in MAIN:
        if key not in table:
            continue
        v = np.asarray(table[key], dtype=float)
        v = v[np.isfinite(v)]
        if v.size:
            parts.append(f"{label} {fmt(v.min())}..{fmt(v.max())}")
    return ", ".join(parts)


def names(items: Iterable[str], at_most: int = 12) -> str:
    """A list of names, shortened past ``at_most``."""
    items = list(items)
    more = len(items) - at_most
    return ", ".join(items[:at_most]) + (f" and {more} more" if more > 0 else "")


def html_table(title: str, rows: Sequence[tuple[str, str]]) -> str:
    """A two-column table with a caption, everything escaped."""
    body = "".join(f"<tr><th style='text-align:left'>{html.escape(k)}</th>"
                   f"<td style='text-align:left'>{html.escape(v)}</td></tr>" for k, v in rows)
    return f"<table><caption>{html.escape(title)}</caption>{body}</table>"


class Shown:
    """A result that shows itself from its ``_summary()`` rows: as an HTML table in a
    notebook (its ``__repr__`` writes the same rows as a few lines)."""

    def _summary(self) -> list[tuple[str, str]]:  # pragma: no cover - each result has one
        raise NotImplementedError

    def _repr_html_(self) -> str:
        return html_table(f"mfcontrol {type(self).__name__}", self._summary())
