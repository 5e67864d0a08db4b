"""What a tuner minimises: a weighted sum of run metrics, scored over a set of scenarios.

An objective is written as metrics with optional weights, ``"iae"``,
``"iae + 0.01*tv_u"``, ``"2*ise - 0.5 * final_gamma"``: the metric names of
:data:`mfcontrol.api.results.metrics.COLUMNS` that are numbers. A run that diverged, that the
settling rule calls not settled (:data:`mfcontrol.api.results.metrics.SETTLED_RULE`) or whose
weighted sum is not a finite number (a settling time that never came) scores ``inf``:
infinitely bad, so an optimiser moves away from it and never stops on it.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ...errors import ConfigError
from .metrics import COLUMNS

#: metrics an objective may weigh (the flags and counts of a run are not quantities to
#: minimise)
METRICS = tuple(c for c in COLUMNS if c not in ("diverged", "settled", "n_samples",
                                                  "t_diverge"))
#: how the scores of one member over its scenarios are combined
AGGREGATES = ("max", "mean")

_NUMBER = r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_TERM = re.compile(rf"^(?:({_NUMBER})\s*\*\s*)?([a-z_]+)(?:\s*\*\s*({_NUMBER}))?$")


@dataclass(frozen=True)
class Objective:
    """A weighted sum of metrics (see the module's documentation).

    Examples
    --------
    >>> from mfcontrol.api.results.objective import Objective
    >>> import numpy as np
    >>> obj = Objective.parse("iae + 0.01*tv_u")
    >>> obj.terms
    (('iae', 1.0), ('tv_u', 0.01))
    >>> table = {"iae": np.array([1.0, 2.0]), "tv_u": np.array([100.0, 0.0]),
    ...          "diverged": np.array([False, True]), "settled": np.array([True, False])}
    >>> obj.score(table).tolist()
    [2.0, inf]
    """

    text: str
    terms: tuple[tuple[str, float], ...]

    @classmethod
    def parse(cls, text: str, key: str = "--objective") -> Objective:
        allowed = ("must be a metric or a weighted sum of metrics such as "
                   f"'iae+0.01*tv_u'; metrics: {', '.join(METRICS)}")
        if not isinstance(text, str) or not text.strip():
            raise ConfigError(key, text, allowed)
        terms: list[tuple[str, float]] = []
        # split before each + or - that starts a term (not the sign of an exponent)
        for part in re.split(r"(?<!\d[eE])(?=[+-])", text.replace(" ", "")):
            if not part:
                continue
            sign = -1.0 if part[0] == "-" else 1.0
            m = _TERM.match(part.lstrip("+-"))
            if not m or (m[1] and m[3]) or m[2] not in METRICS:
                raise ConfigError(key, text, allowed)
            weight = sign * float(m[1] or m[3] or 1.0)
            if not math.isfinite(weight):
                raise ConfigError(key, text, allowed)
            terms.append((m[2], weight))
        if not terms:
            raise ConfigError(key, text, allowed)
        return cls(text.strip(), tuple(terms))

    @property
    def metrics(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(name for name, _ in self.terms))

    def score(self, table: Mapping[str, np.ndarray]) -> np.ndarray:
        """Each run's score (rows of a metrics table as :func:`mfcontrol.api.results.metrics.table`
        or a sweep writes it): the weighted sum, ``inf`` where the run diverged, is
        not settled or the sum is not finite."""
        with np.errstate(invalid="ignore", over="ignore"):
            value = sum(w * np.asarray(table[name], dtype=float) for name, w in self.terms)
        value = np.array(value, dtype=float, ndmin=1)
        bad = (np.asarray(table["diverged"], dtype=bool)
               | ~np.asarray(table["settled"], dtype=bool) | ~np.isfinite(value))
        value[bad] = np.inf
        return value

    def score_run(self, metrics: Mapping[str, object]) -> float:
        """The score of one run from its metrics (``Result.metrics``)."""
        return float(self.score({k: np.array([metrics[k]]) for k in
                                 (*self.metrics, "diverged", "settled")})[0])


def aggregate(scores: np.ndarray, how: str) -> np.ndarray:
    """Combine a (members, scenarios) array of scores into one per member: the worst
    (``"max"``) or the mean (``"mean"``); a member with an infinite score anywhere is
    infinite either way."""
    if how not in AGGREGATES:
        raise ConfigError("--aggregate", how, f"must be one of {', '.join(AGGREGATES)}")
    scores = np.asarray(scores, dtype=float)
    return scores.max(axis=1) if how == "max" else scores.mean(axis=1)
