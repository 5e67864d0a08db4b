"""Run results: time, signals, plant states, metrics, the resolved configuration, version."""

from __future__ import annotations

import csv
import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ... import files
from ..._version import __version__
from ...config.resolve import Config
from . import display

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

#: the signals every run records, in file order (a law's components may follow)
SIGNALS = ("y_ref", "y", "y_meas", "u", "u_plant", "u_raw", "gamma", "gain")


class _Files(display.Shown):
    """What every result type writes: the trajectory as CSV and the metrics as JSON."""

    name: str
    version: str

    def to_pandas(self) -> pd.DataFrame:  # pragma: no cover - every result type defines it
        raise NotImplementedError

    def _metrics_payload(self) -> dict[str, Any]:  # pragma: no cover
        raise NotImplementedError

    def _columns(self) -> dict[str, np.ndarray] | None:
        """The trajectory's columns in file order, or None where only the DataFrame has
        them."""
        return None

    def to_csv(self, path: str | Path) -> Path:
        """Write the trajectory; floats keep all 17 significant digits."""
        path = Path(path)
        columns = self._columns()

        def write(tmp: Path) -> None:
            if columns is None or not write_csv(tmp, columns):
                self.to_pandas().to_csv(tmp, index=False, float_format="%.17g")

        files.replace_with(path, write)  # whole or not at all (a full disk, a kill)
        return path

    def metrics_json(self) -> str:
        """Metrics as JSON, with the case name and the mfcontrol version (NaN as null)."""
        payload = {"case": self.name, "mfcontrol": self.version, **self._metrics_payload()}
        return json.dumps(_jsonable(payload), indent=2)


class Signals(dict):
    """A run's signals by name (a dict): a name it does not hold is a KeyError that lists
    the names it does, and says where time is (``Result.time``; the column ``t`` of the
    CSV and the DataFrame)."""

    def __missing__(self, key: Any) -> np.ndarray:
        where = (" time is Result.time (the column t of the CSV and the DataFrame);"
                 if key in ("t", "time") else "")
        raise KeyError(f"{key!r}:{where} the signals are {', '.join(self)}")


class _Trajectory(_Files):
    """A single trajectory: time, signals (y_ref, y, ...) and plant states."""

    time: np.ndarray
    signals: dict[str, np.ndarray]
    states: dict[str, np.ndarray]
    metrics: dict[str, Any]

    @property
    def error(self) -> np.ndarray:
        """Tracking error y - y*."""
        return self.signals["y"] - self.signals["y_ref"]

    def _columns(self) -> dict[str, np.ndarray]:
        return {"t": self.time, **self.signals, **self.states}

    def to_pandas(self) -> pd.DataFrame:
        """Trajectory as a DataFrame: t, then the signals, then the plant states."""
        import pandas as pd  # here: about 0.5 s of import, for to_pandas only

        return pd.DataFrame(self._columns())

    def _metrics_payload(self) -> dict[str, Any]:
        return dict(self.metrics)


@dataclass
class Result(_Trajectory):
    """One simulated run: of a case (``config`` holds its resolved configuration) or of a
    loop built from Python objects (:func:`mfcontrol.simulate_loop`; ``config`` is None).

    Attributes
    ----------
    name : str
        Case name (or file stem) the run came from, or the name given.
    time : ndarray
        Sample times t_k (s), up to divergence.
    signals : dict of ndarray
        ``y_ref`` reference, ``y`` output at t_k before that sample's plant step (with an output
        disturbance), ``y_meas`` what the controller received of it (after the sensor's noise,
        quantisation and delay; ``y`` without a sensor), ``u`` the controller's (limited) output
        (the duty cycle on a converter), ``u_plant`` what reached the plant (after the actuator's
        delay and rate limit and an input disturbance; ``u`` without them), ``u_raw`` the law's
        output before limiting (the recursive law's raw
        u_k, before its output gain), ``gamma`` the adaptive gain (1/alpha for a constant
        gain), ``gain`` what multiplied the derivative error; an intelligent controller
        adds its terms ``F_hat``, ``feedforward``, ``P``, ``I``, ``D``.
    states : dict of ndarray
        Plant states at t_k (``i_L``, ``v_C`` for the converters).
    metrics : dict
        See :mod:`mfcontrol.api.results.metrics`.
    version : str
        mfcontrol version that produced it.
    config : Config or None
        The fully resolved configuration of a case run.
    arithmetic : str
        ``"exact"`` (bit for bit the published arithmetic) or ``"fast"`` (the engine's
        fast mode, within about 1e-12 relative); in ``metrics.json`` too.
    changes : tuple of Change
        The scheduled parameter changes of a loop built from objects.
    engine : str
        ``"compiled"``, or ``"python"`` when the Python driver ran the loop
        (``engine_note`` says why).
    """

    name: str
    time: np.ndarray
    signals: dict[str, np.ndarray]
    states: dict[str, np.ndarray]
    metrics: dict[str, Any]
    version: str = __version__
    config: Config | None = None
    label: str = field(default="")
    arithmetic: str = field(default="exact")
    changes: tuple = ()
    engine: str = "compiled"
    engine_note: str = ""

    def __post_init__(self) -> None:
        self.signals = Signals(self.signals)

    def _metrics_payload(self) -> dict[str, Any]:
        return {"arithmetic": self.arithmetic, **self.metrics}

    def _summary(self) -> list[tuple[str, str]]:
        span = f"{self.time[-1] + (self.time[1] - self.time[0]):.3g} s" \
            if self.time.size > 1 else "-"
        return [("run", self.name or "(unnamed)"),
                ("samples", f"{self.time.size:,} samples over {span}"),
                ("verdict", display.verdict(self.metrics)),
                ("metrics", display.metric_line(self.metrics)),
                ("signals", display.names(self.signals, at_most=16)),
                ("states", display.names(self.states)),
                ("engine", f"{self.engine} engine, {self.arithmetic} arithmetic")]

    def __repr__(self) -> str:
        rows = dict(self._summary())
        return (f"<Result {rows['run']!r}: {rows['samples']}, {rows['verdict']}\n"
                f" {rows['metrics']}\n signals {rows['signals']}; states {rows['states']}\n"
                f" {rows['engine']}>")


    def plot(self, path: str | Path | None = None, title: str | None = None,
             output_label: str | None = None, input_label: str | None = None) -> Figure:
        """A case run: the paper's panels (output and reference, duty cycle, and gamma for
        adaptive laws). A loop built from objects, or labels given: output and reference
        on top, control below; labels should carry units (``"speed (rad/s)"``).

        Returns the matplotlib Figure; saves it as PNG when ``path`` is given.
        """
        from .plotting import plot_loop, plot_run  # here: matplotlib, about 0.6 s to import

        if self.config is not None and output_label is None and input_label is None:
            return plot_run(self, path=path, title=title)
        return plot_loop(self, path=path, title=title,
                         output_label=output_label or "output y",
                         input_label=input_label or "control u")


@dataclass
class SweepResult(_Files):
    """Members of a sweep case (``sweep.key`` over ``sweep.values``), each run on the same,
    freshly reset scenario.

    Attributes
    ----------
    name : str
        The case's name.
    config : Config
        The case's resolved configuration (its ``sweep.*`` keys included).
    key : str
        The swept key, e.g. ``"controller.Gamma"``.
    values : list of float
        The swept values, one per member.
    members : list of Result
        Each member's run, in the order of ``values``.
    version : str
        mfcontrol version that produced it.
    """

    name: str
    config: Config
    key: str
    values: list[float]
    members: list[Result]
    version: str

    @property
    def metrics(self) -> list[dict[str, Any]]:
        return [{self.key: v, **m.metrics} for v, m in zip(self.values, self.members, strict=True)]

    def _columns(self) -> dict[str, np.ndarray] | None:
        """to_pandas' columns, where its concatenation is a plain one: every member has
        the same columns and the swept values are floats (else None)."""
        parts = [m._columns() for m in self.members]
        if not parts or any(list(p) != list(parts[0]) for p in parts) or \
                not all(isinstance(v, float) for v in self.values):
            return None
        out = {self.key: np.concatenate([np.full(p["t"].size, v)
                                         for v, p in zip(self.values, parts, strict=True)])}
        for name in parts[0]:
            out[name] = np.concatenate([p[name] for p in parts])
        return out

    def to_pandas(self) -> pd.DataFrame:
        """All members' trajectories, long format, with a column naming the swept value."""
        import pandas as pd  # here: about 0.5 s of import, for to_pandas only

        frames = []
        for v, m in zip(self.values, self.members, strict=True):
            df = m.to_pandas()
            df.insert(0, self.key, v)
            frames.append(df)
        return pd.concat(frames, ignore_index=True)

    def _metrics_payload(self) -> dict[str, Any]:
        return {"sweep": self.key, "members": self.metrics}

    def _summary(self) -> list[tuple[str, str]]:
        table = {k: [m.metrics.get(k, math.nan) for m in self.members]
                 for k, _ in display.MAIN}
        settled = sum(bool(m.metrics.get("settled")) for m in self.members)
        return [("sweep", self.name),
                ("members", f"{len(self.members)} members over {self.key} = "
                            f"{display.fmt(min(self.values))}..{display.fmt(max(self.values))}"),
                ("settled", f"{settled} of {len(self.members)}"),
                ("metric ranges", display.metric_ranges(table))]

    def __repr__(self) -> str:
        rows = dict(self._summary())
        return (f"<SweepResult {rows['sweep']!r}: {rows['members']}, {rows['settled']} "
                f"settled\n {rows['metric ranges']}>")


    def plot(self, path: str | Path | None = None, kind: str = "gamma") -> Figure:
        """``kind='gamma'``: gamma(t) per member; ``kind='error'``: ``|y - y*|`` (log axis)."""
        from .plotting import plot_sweep  # here: matplotlib, about 0.6 s to import

        return plot_sweep(self, kind=kind, path=path)


#: rows formatted per write: a bounded string however long the trajectory (a sweep's)
_CSV_ROWS = 20_000


def write_csv(path: Path, columns: Mapping[str, np.ndarray]) -> bool:
    """Write float64 columns as pandas' ``to_csv(index=False, float_format="%.17g")``
    writes them, byte for byte (its header quoting and line ending, NaN as an empty
    field), without pandas: one ``%`` over a block of rows. Returns False, having written
    nothing, for columns it does not cover (another dtype, not 1-D, unequal lengths):
    the caller then asks pandas.
    """
    arrays = [np.asarray(c) for c in columns.values()]
    if not arrays or any(a.dtype != np.float64 or a.ndim != 1 or a.size != arrays[0].size
                         for a in arrays):
        return False
    table = np.column_stack(arrays)
    row = ",".join(["%.17g"] * len(arrays)) + os.linesep
    with open(path, "w", newline="", encoding="utf-8") as f:
        # the header through the csv module, as pandas writes it (quoted where a name
        # needs it)
        csv.writer(f, lineterminator=os.linesep).writerow(columns)
        for start in range(0, table.shape[0], _CSV_ROWS):
            block = table[start:start + _CSV_ROWS]
            text = (row * block.shape[0]) % tuple(block.ravel().tolist())
            # "%.17g" writes NaN as "nan" (never signed), pandas an empty field; no other
            # field holds the letters n, a, n in a row
            f.write(text.replace("nan", ""))
    return True


def _jsonable(obj):
    if isinstance(obj, dict):
        return {k: _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, np.generic):
        return obj.item()
    return obj
