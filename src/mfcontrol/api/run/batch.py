"""Sweeps at scale: every member of a parameter grid over one case, in chunks, on all cores.

A grid is a product of axes, one per swept key (``KEY=SPEC``, SPEC ``a,b,c``,
``linspace(a,b,n)`` or ``logspace(a,b,n)``). Member m has the m-th combination in C order
(the last key varies fastest). Members are built by the same code as a single run: for
each axis value a one-member scenario is built from the configuration with that value
set, and the array cells it changes are written into the members that have that value.
So member m computes exactly what ``mfcontrol.simulate`` computes for its configuration.
Cases the paper's kernel does not cover run in batches of the general engine
(:mod:`mfcontrol.engine.compose`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...config.options import BY_KEY
from ...config.reads import refuse_unread
from ...config.resolve import Config, _check_consistency, axis_value, check_axis, keys_read
from ...engine import metrics as engine_metrics
from ...engine import paper_single, paper_sweep
from ...errors import ConfigError
from ...laws import recursive_ip, reference
from ...numerics.grid import check_members
from .. import params
from ..results import metrics as _metrics
from . import from_config, scenario
from .simulate import batch_metrics, compiled, general_metrics, keys_read_by_run, member_parts

_SPEC = re.compile(r"^\s*(linspace|logspace)\s*\(\s*([^,]+),\s*([^,]+),\s*([^,)]+)\)\s*$")
METRIC_COLUMNS = _metrics.COLUMNS
#: values of one axis at most: a 10-million-value axis is 80 MB and, at 10,000 samples a
#: member, days of computing; more is a mistake to refuse at once, not a MemoryError later
MAX_AXIS = 10_000_000


def parse_spec(key: str, spec: str) -> np.ndarray:
    """Values of one axis from ``a,b,c``, ``linspace(a,b,n)`` or ``logspace(a,b,n)``
    (logspace takes decimal exponents, as numpy's)."""
    allowed = "must be a,b,c or linspace(a,b,n) or logspace(a,b,n) with numbers a, b, n"
    m = _SPEC.match(spec)
    too_many = 0
    try:
        if m:
            a, b, n = float(m[2]), float(m[3]), int(m[4])
            if n < 1 or not (math.isfinite(a) and math.isfinite(b)):
                raise ValueError
            if n > MAX_AXIS:
                too_many = n
                raise ValueError
            # numpy's overflow warning would print before the refusal below: the one line
            with np.errstate(all="ignore"):
                values = (np.linspace if m[1] == "linspace" else np.logspace)(a, b, n)
        else:
            values = np.array([float(x) for x in spec.split(",")])
    except ValueError:
        if too_many:
            raise ConfigError(key, spec, f"{too_many:,} values: at most {MAX_AXIS:,} on one "
                              "axis (split the range over several sweeps)") from None
        raise ConfigError(key, spec, allowed) from None
    if values.size == 0:
        raise ConfigError(key, spec, allowed)
    if m and not np.all(np.isfinite(values)):  # named by the spec, not the inf or NaN made
        raise ConfigError(key, spec, _beyond(m[1]))
    return values


def _beyond(form: str) -> str:
    """What a linspace or logspace whose values leave the float range must be instead."""
    top = np.finfo(float).max
    if form == "logspace":
        return (f"gives values beyond the float range (about {top:.1e}): logspace's "
                f"exponents must be at most {math.log10(top):.2f}")
    return (f"gives values beyond the float range: linspace's ends and their difference "
            f"must be within about {top:.1e}")


def check_member_key(key: str, flag: str = "--grid") -> None:
    """Refuse a key that members of one batch cannot differ in: not a numeric option, or
    one that changes the time grid (sim.h, sim.t_end, sweep.*) or a setting all members
    share (metrics.*, sim.diverge_above). For sweep axes, tuned keys and scenarios."""
    o = BY_KEY.get(key)
    if o is None or o.kind not in ("float", "int") or key.startswith("sweep.") or key in (
            "sim.h", "sim.t_end"):
        raise ConfigError(flag, key, "must name a numeric option that keeps the time "
                          "grid (not sim.h, sim.t_end or sweep.*)")
    if key.startswith("metrics.") or key == "sim.diverge_above":
        raise ConfigError(flag, key, "is a setting shared by all members of a sweep; "
                          "set it with --set")


def parse_grid(items: Sequence[str] | Mapping[str, Any],
               flag: str = "--grid") -> dict[str, np.ndarray]:
    """``["KEY=SPEC", ...]`` (or a mapping of keys to specs or to lists of values) to
    axes; each key once, each one :func:`check_member_key` allows (``flag`` names the
    option in messages)."""
    pairs = items.items() if isinstance(items, Mapping) else [
        tuple(s.split("=", 1)) if "=" in s else (s, None) for s in items]
    grid: dict[str, np.ndarray] = {}
    for key, spec in pairs:
        key = key.strip()
        if spec is None:
            raise ConfigError(flag, key, "expected KEY=SPEC")
        check_member_key(key, flag)
        if key in grid:
            raise ConfigError(flag, key, "is given twice")
        if isinstance(spec, list | tuple | np.ndarray):  # values given as such
            spec = ",".join(repr(float(v)) if isinstance(v, int | float | np.number)
                            else str(v) for v in np.ravel(np.asarray(spec, dtype=object)))
        grid[key] = parse_spec(key, str(spec))
    if not grid:
        raise ConfigError(flag, "", "give at least one KEY=SPEC")
    return grid


@dataclass
class Grid:
    """Members over axes of swept keys, in C order (the last dimension varies fastest).

    Each key of ``axes`` is a dimension of its own, except the keys of ``points``: their
    values, of one length, are read together as a list of points (point i sets each of
    them to its i-th value) and form the first dimension, which the other axes multiply
    (a tuner's population times its scenarios)."""

    base: Config
    axes: dict[str, np.ndarray]
    points: tuple[str, ...] = ()

    @property
    def dims(self) -> dict[str, int]:
        """The dimension each key indexes."""
        out = dict.fromkeys(self.points, 0)
        first = 1 if self.points else 0
        for k in self.axes:
            if k not in out:
                out[k] = first
                first += 1
        return out

    @property
    def shape(self) -> tuple[int, ...]:
        lead = (self.axes[self.points[0]].size,) if self.points else ()
        return lead + tuple(v.size for k, v in self.axes.items() if k not in self.points)

    @property
    def n_members(self) -> int:
        return math.prod(self.shape)

    def indices(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Each key's value index for members start .. stop-1."""
        idx = np.unravel_index(np.arange(start, stop), self.shape)
        return {k: idx[d] for k, d in self.dims.items()}

    def values(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Each swept key's value for members start .. stop-1."""
        return {k: self.axes[k][i] for k, i in self.indices(start, stop).items()}

    def config(self, member: int) -> Config:
        return self.base.with_overrides({k: axis_value(k, v[0]) for k, v in
                                         self.values(member, member + 1).items()})


def make_grid(base: Config, axes: Mapping[str, np.ndarray],
              points: tuple[str, ...] = ()) -> Grid:
    """Validate every axis value against the base configuration: the option's own check
    on the whole axis at once, and the checks across options for each value of the keys
    they involve (:func:`mfcontrol.config.resolve.check_axis`); ``points`` as
    :class:`Grid` takes them (the checks across options see one key's value at a time:
    a caller that needs each point's combination checked builds its configuration)."""
    if points and len({np.size(axes[k]) for k in points}) != 1:
        raise ValueError("the keys of points must have values of one length")
    # before validating 10^7-value axes for minutes
    check_members(math.prod(np.size(v) for k, v in axes.items() if k not in points[1:]),
                  "--grid", " x ".join(f"{k} ({np.size(v):,})" for k, v in axes.items()))
    for key, values in axes.items():
        check_axis(base, key, np.asarray(values, dtype=float))
    # an axis the run does not read would give identical members (a noise level without
    # noise, a disturbance's amplitude without one)
    refuse_unread(base, {k: np.asarray(v).tolist() for k, v in axes.items()},
                  keys_read_by_run, instead="vary another key (every member would be "
                  "the same)")
    return Grid(base=base, axes={k: np.asarray(v, dtype=float) for k, v in axes.items()},
                points=tuple(points))


_ARRAYS = ("PP", "X0", "CP", "RP", "ev_k", "ev_val")


def _cell_changes(grid: Grid) -> dict[str, dict[tuple[str, int], np.ndarray]]:
    """For each key: the (array, row) cells of a one-member scenario its axis writes, each
    with its value for every axis value (the base value where that value leaves it)."""
    ref = scenario.build([grid.base])
    out: dict[str, dict] = {}
    owner: dict[tuple[str, int], str] = {}
    for key, values in grid.axes.items():
        cells: dict[tuple[str, int], np.ndarray] = {}
        # every value of the axis through the translators at once (one column each)
        columns = scenario.axis_columns(grid.base, key, values)
        for name in _ARRAYS:
            if name not in columns:  # the event samples: no numeric option moves them
                continue
            a, b = getattr(ref, name), columns[name]
            same = (a == b) | (np.isnan(a) & np.isnan(b))
            for row in np.flatnonzero(~same.all(axis=1)):
                other = owner.setdefault((name, int(row)), key)
                if other != key:
                    raise ConfigError("--grid", key, f"changes the same model quantity as "
                                      f"{other}: sweep one of them")
                cells[name, int(row)] = b[row].copy()
        out[key] = cells
    return out


def build_members(grid: Grid, start: int, stop: int,
                  changes: dict | None = None) -> scenario.Scenario:
    """The scenario of members start .. stop-1 of a compiled grid."""
    changes = _cell_changes(grid) if changes is None else changes
    n = stop - start
    scn = scenario.build([grid.base])
    tiled = {name: np.repeat(getattr(scn, name), n, axis=1) for name in _ARRAYS}
    for key, axis_index in grid.indices(start, stop).items():
        # one row write per changed cell for all members at once (a loop over members or
        # values costs microseconds per member, more than simulating it)
        for (name, row), per_value in changes[key].items():
            tiled[name][row] = per_value[axis_index]
    ev_k = tiled["ev_k"].astype(np.int64)
    steps = np.unique(ev_k[ev_k < scn.n_steps]) if ev_k.size else np.zeros(0, np.int64)
    return scenario.Scenario(
        n_steps=scn.n_steps, h=scn.h, t_end=scn.t_end, plant_kind=scn.plant_kind,
        PP=tiled["PP"], X0=tiled["X0"], law_kind=scn.law_kind, CP=tiled["CP"], RP=tiled["RP"],
        ev_steps=steps.astype(np.int64), ev_k=ev_k, ev_row=scn.ev_row, ev_add=scn.ev_add,
        ev_val=tiled["ev_val"], S=scn.S, state_names=scn.state_names,
        load_t0=np.repeat(scn.load_t0, n))


def _varying(changes: dict, scn: scenario.Scenario) -> tuple[set[int], bool]:
    """The packed rows that differ between members of the whole grid (written by a swept
    key or a scheduled change), and whether the reference differs: decided per grid, not
    per chunk, so that every chunk of a sweep runs the same compiled kernel."""
    rows = {paper_sweep.P_PP + int(r) for r in scn.ev_row}
    offset = {"PP": paper_sweep.P_PP, "CP": paper_sweep.P_CP}
    cells = [cell for per_key in changes.values() for cell in per_key]
    rows |= {offset[name] + row for name, row in cells if name in offset}
    return rows, any(name == "RP" for name, _ in cells)


def _blocks(a: np.ndarray, n_blocks: int) -> np.ndarray:
    """(rows, n) -> (n_blocks, rows, BLOCK), the last block padded with copies of member 0,
    in memory aligned to 64 bytes: the kernels' vector loads of a row then never straddle
    a cache line (unaligned, the fast kernel runs about 40% slower)."""
    rows, n = a.shape
    size = n_blocks * rows * paper_sweep.BLOCK
    buf = np.empty(size + 8, dtype=a.dtype)
    skip = (-buf.ctypes.data % 64) // buf.itemsize
    out = buf[skip:skip + size].reshape(n_blocks, rows, paper_sweep.BLOCK)
    full = n // paper_sweep.BLOCK
    block = paper_sweep.BLOCK
    out[:full] = a[:, :full * block].reshape(rows, full, block).transpose(1, 0, 2)
    if full < n_blocks:
        rest = n - full * paper_sweep.BLOCK
        out[full, :, :rest] = a[:, full * paper_sweep.BLOCK:]
        out[full, :, rest:] = a[:, :1]
    return out


#: scenario-samples of a grid from which the compiled path specialises its kernel by
#: default: compiling one takes about 4 s and saves about 1 ns per scenario-sample
SPECIALISE_ABOVE = 4e9


def run_range(grid: Grid, start: int, stop: int, changes: dict | None = None, *,
              fast: bool = False, specialise: bool | None = None) -> dict[str, np.ndarray]:
    """Metrics of members start .. stop-1, as columns (swept keys first).

    Parameters
    ----------
    grid : Grid
        The sweep.
    start, stop : int
        The members to run.
    changes : dict, optional
        ``_cell_changes(grid)``, when the caller runs several ranges of one grid.
    fast : bool
        The fast mode (fused multiply-adds, reciprocals of shared divisors, the plant's
        RK4 step as its linear map; about 3x faster): members agree with their single
        runs to about 1e-13 relative instead of bit for bit.
        Implies ``specialise``.
    specialise : bool, optional
        Compile a kernel with the parameters every member of the grid shares built in
        (see :func:`mfcontrol.engine.paper_sweep.block_kernel`); None: for grids of more than
        :data:`SPECIALISE_ABOVE` scenario-samples, and with ``fast``. Exact results are
        the same either way.
    """
    values = grid.values(start, stop)
    tol = grid.base["metrics.settled_tol"]
    if paper_grid(grid):
        changes = _cell_changes(grid) if changes is None else changes
        scn = build_members(grid, start, stop, changes)
        n = stop - start
        n_blocks = -(-n // paper_sweep.BLOCK)
        CS = np.zeros((recursive_ip.N_STATE, n))
        paper_single.reset_members(scn.law_kind, scn.CP, CS)
        paper_single.plant_prepare_all(scn.plant_kind, scn.PP, n)
        rows = np.vstack([scn.PP, scn.X0, scn.CP, CS, scenario.start_metrics(scn),
                          np.zeros((paper_sweep.P_ROWS - paper_sweep.P_APREV, n))])
        varying, ref_varies = _varying(changes, scn)
        if specialise is None:
            specialise = grid.n_members * scn.n_steps >= SPECIALISE_ABOVE
        constants = paper_sweep.shared_constants(rows, varying) if (specialise or fast) else None
        steps = bool(np.any(scn.RP[reference.KIND] == reference.SMOOTH_STEP))
        run = paper_sweep.block_kernel(constants, not ref_varies, fast, steps)
        D = _blocks(rows, n_blocks)
        run(scn.n_steps, scn.h, scn.t_end, D, _blocks(scn.RP, n_blocks), scn.ev_steps,
            _blocks(scn.ev_k, n_blocks), scn.ev_row, scn.ev_add, _blocks(scn.ev_val, n_blocks),
            scn.S)
        first = paper_sweep.P_M
        M = D[:, first:first + engine_metrics.N_METRICS].transpose(1, 0, 2).reshape(
            engine_metrics.N_METRICS, -1)[:, :n]
        engine_metrics.adaptation(M, scn.CP, True)
        met = _metrics.table(M, tol)
    else:  # the general engine, every member of the range in one batch
        met = _metrics.table(_general_batch(grid, start, stop, fast), tol)
    cols: dict[str, np.ndarray] = {"member": np.arange(start, stop, dtype=np.int64), **values}
    cols.update({name: met[name] for name in METRIC_COLUMNS})
    return cols


def paper_grid(grid: Grid) -> bool:
    """Whether the paper's sweep kernel runs every member of the grid: its base is a
    configuration it covers (:func:`mfcontrol.api.run.simulate.compiled`) and no axis is read
    by the translator of the loop's elements (the kernel has none)."""
    return compiled(grid.base) and not set(grid.axes) & keys_read(from_config.elements, grid.base)


def _general_batch(grid: Grid, start: int, stop: int, fast: bool) -> np.ndarray:
    """Metrics (kernel rows) of members start .. stop-1 of a grid the paper's kernel does
    not cover, in one batch of the general engine.

    Each member's parts (:func:`mfcontrol.api.run.simulate.member_parts`: its plant with its
    schedule, its law, its reference) are what its single run builds from its
    configuration, but each part is built once per distinct setting of the swept keys it
    reads: the plant and the controller of an n x m grid of a plant key and a controller
    key are n + m configurations, not n m (each about 0.3 ms, more than simulating a
    member). Which part reads a key is found by building the parts of member ``start``;
    a key read by none or by more than one part (or by the settings every member
    shares) is swept the plain way, a configuration per member, and so is a grid with
    keys of different parts among those the checks across options read (each part's
    configuration is checked with its own keys set only)."""
    parts = member_parts()
    probe = grid.config(start)
    shared = keys_read(lambda c: (scenario.n_steps(c), params.metric_settings(c)), probe)
    checked = keys_read(_check_consistency, probe)
    reads = {part: keys_read(build, probe) for part, build in parts.items()}
    owner: dict[str, str] = {}
    for key in grid.axes:
        readers = [part for part, keys in reads.items() if key in keys]
        if len(readers) != 1 or key in shared:
            owner.clear()
            break
        owner[key] = readers[0]
    if not owner or len({owner[k] for k in grid.axes if k in checked}) > 1:
        return general_metrics([grid.config(m) for m in range(start, stop)], fast=fast)
    keys = list(grid.axes)
    ix = grid.indices(start, stop)
    idx = [ix[k] for k in keys]
    members: dict[str, list] = {}
    for part, build in parts.items():
        mine = [c for c, k in enumerate(keys) if owner[k] == part]
        # the distinct settings of this part's keys, and which one each member has
        at = np.stack([np.asarray(idx[c], dtype=np.int64) for c in mine], axis=1) if mine \
            else np.zeros((stop - start, 0), dtype=np.int64)
        settings, which = _distinct_rows(at)
        built = [build(grid.base.with_overrides(  # the configuration with them set, checked
            {keys[c]: axis_value(keys[c], grid.axes[keys[c]][i])
             for c, i in zip(mine, row.tolist(), strict=True)})) for row in settings]
        members[part] = [built[w] for w in which.reshape(-1).tolist()]
    return batch_metrics(grid.base, members, fast=fast)[0]


def _distinct_rows(at: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(at, axis=0, return_inverse=True)`` (the distinct rows of an integer
    array, sorted, and the index of each row among them), without its cost for no
    column or one (a structured view and a sort of rows)."""
    if at.shape[1] == 0:
        return np.zeros((1, 0), dtype=at.dtype), np.zeros(at.shape[0], dtype=np.int64)
    if at.shape[1] == 1:
        values, which = np.unique(at[:, 0], return_inverse=True)
        return values[:, None], which
    return np.unique(at, axis=0, return_inverse=True)


def chunks(n_members: int, size: int) -> Iterator[tuple[int, int, int]]:
    """(index, start, stop) of consecutive chunks."""
    for i, start in enumerate(range(0, n_members, size)):
        yield i, start, min(n_members, start + size)


def run_grid(grid: Grid, chunk: int = 4096,
             progress: Callable[[int, int], None] | None = None, *, fast: bool = False,
             specialise: bool | None = None) -> dict[str, np.ndarray]:
    """Every member's metrics, in memory (the CLI writes chunks to disk instead);
    ``fast`` and ``specialise`` as in :func:`run_range`."""
    changes = _cell_changes(grid) if paper_grid(grid) else None
    parts = []
    done = 0
    for _, a, b in chunks(grid.n_members, chunk):
        parts.append(run_range(grid, a, b, changes, fast=fast, specialise=specialise))
        done += b - a
        if progress:
            progress(done, grid.n_members)
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
