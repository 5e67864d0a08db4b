"""``mfcontrol sweep``: a grid over a case, written to disk chunk by chunk.

Layout of ``OUT``::

    sweep.json                 what was asked (case, overrides, grid, chunk size, version)
    chunks/chunk-000012.parquet  each finished chunk, written atomically as it completes
    results.parquet            all members (swept values and metrics), once every chunk is done
    trajectories/member-N.csv  with --keep: the full trajectories of N members

A chunk file exists only when its chunk is complete, so an interrupted or crashed sweep
loses nothing it finished; running the same command again skips the finished chunks. A
different sweep into the same folder is refused. Each chunk carries its sweep's mark and
its members (in the file's metadata), and is read whole before it is skipped: a chunk
that is cut short, empty, unreadable, has the wrong rows or comes from another sweep is
computed again (said on stderr), never counted or mixed in; a folder where a chunk
belongs is refused. Temporary files a killed process left are removed. One process at a
time owns a folder: it holds an operating-system lock on ``OUT/.lock`` (``filelock``),
which the system releases when the process ends, however it ends; a second sweep into
the folder meanwhile is refused.
"""

from __future__ import annotations

import hashlib
import json
import logging
import signal
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from filelock import FileLock, Timeout

from .. import files
from .._version import __version__
from ..api.run import batch
from ..api.run.simulate import simulate
from ..api.run.sweep import keep_members
from ..config.resolve import Config
from ..errors import ConfigError

CHUNK = 4096


_IDENTITY = ("case", "overrides", "grid", "chunk", "arithmetic", "columns")


def _chunk_path(chunk_dir: Path, i: int) -> Path:
    """Where chunk i of a sweep folder lives (the one place its name is made)."""
    return chunk_dir / f"chunk-{i:06d}.parquet"


def _manifest(case: str, overrides: dict[str, Any], grid: batch.Grid, chunk: int,
              fast: bool) -> dict:
    return {"case": case, "overrides": overrides,
            "grid": {k: v.tolist() for k, v in grid.axes.items()}, "chunk": chunk,
            "arithmetic": "fast" if fast else "exact", "n_members": grid.n_members,
            # the metric columns: a folder written with other ones (tv_duty, before it was
            # tv_u) is not resumed into a mixed table
            "columns": list(batch.METRIC_COLUMNS), "mfcontrol": __version__}


def _mark(manifest: dict) -> str:
    """The sweep's mark, written into each of its chunks: a digest of what identifies it."""
    text = json.dumps({k: manifest[k] for k in _IDENTITY}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def _write_chunk(frame, path: Path, mark: str, a: int, b: int) -> None:
    """Chunk file of members a..b-1, atomically, with the sweep's mark and its members in
    the file's metadata."""
    import pyarrow as pa  # type: ignore[import-untyped]
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    table = pa.Table.from_pandas(frame, preserve_index=False)
    table = table.replace_schema_metadata({**(table.schema.metadata or {}),
                                           b"mfcontrol.sweep": mark.encode(),
                                           b"mfcontrol.members": f"{a}:{b}".encode()})
    files.replace_with(path, lambda tmp: pq.write_table(table, tmp))


def _chunk_damage(path: Path, mark: str, a: int, b: int) -> str | None:
    """Why the chunk file of members a..b-1 cannot be taken as done (None: it can)."""
    import pyarrow as pa  # type: ignore[import-untyped]
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    if path.is_dir():
        raise ConfigError("--out", str(path.parent.parent), f"holds a folder where a chunk "
                          f"belongs ({path}): remove it to resume")
    try:
        table = pq.read_table(path)
    except (OSError, pa.ArrowException, ValueError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        return f"is unreadable ({first[:120]})"
    meta = table.schema.metadata or {}
    if meta.get(b"mfcontrol.sweep") != mark.encode():
        return "is not this sweep's (no mark, or another sweep's)"
    if meta.get(b"mfcontrol.members") != f"{a}:{b}".encode() or table.num_rows != b - a:
        rows = f"{table.num_rows} row" + ("" if table.num_rows == 1 else "s")
        return f"holds {rows}, not members {a} to {b - 1}"
    if "member" in table.column_names and \
            table.column("member").to_pylist() != list(range(a, b)):
        return f"does not hold members {a} to {b - 1}"
    return None


def _remove_leftovers(out: Path) -> None:
    """The temporary files of writes a killed process never finished (this process holds
    the folder's lock: no other is writing them)."""
    for folder in (out, out / "chunks", out / "trajectories"):
        for tmp in folder.glob(".*.tmp"):
            if tmp.is_file():
                tmp.unlink(missing_ok=True)


def _check_folder(out: Path, manifest: dict) -> None:
    path = out / "sweep.json"
    if path.exists():
        try:
            old = json.loads(path.read_text())
            if not isinstance(old, dict):
                raise ValueError
        except (ValueError, UnicodeDecodeError, RecursionError):
            raise ConfigError("--out", str(out), "holds a sweep.json that is not a sweep's "
                              "(unreadable or cut short): remove it to start the sweep over, "
                              "or choose another folder") from None
        old.setdefault("arithmetic", "exact")  # written before there was a fast mode
        same = {k: old.get(k) for k in _IDENTITY} == {k: manifest[k] for k in _IDENTITY}
        if not same:
            raise ConfigError("--out", str(out), "holds a different sweep (see its sweep.json):"
                              " choose another folder")
    else:
        files.replace_with(path, lambda tmp: tmp.write_text(json.dumps(manifest, indent=2)))


def _write_atomic(frame, path: Path) -> None:
    files.replace_with(path, lambda tmp: frame.to_parquet(tmp, index=False))


def _lock(out: Path) -> FileLock:
    """The folder's lock, taken, or the one-line refusal when another process holds it."""
    lock = FileLock(out / ".lock")
    try:
        lock.acquire(timeout=0)
    except Timeout:
        raise ConfigError("--out", str(out), "is being written by another running sweep: "
                          "wait for it to end, or choose another folder") from None
    return lock


def _chunk_frame(grid_spec: dict, index: int):
    """Compute one chunk from a plain description (used locally and on Dask workers)."""
    import pandas as pd

    from ..config.resolve import resolve

    base = resolve(grid_spec["base"])
    grid = batch.Grid(base=base, axes={k: np.asarray(v) for k, v in grid_spec["grid"].items()})
    start = index * grid_spec["chunk"]
    stop = min(grid.n_members, start + grid_spec["chunk"])
    return pd.DataFrame(batch.run_range(grid, start, stop, fast=grid_spec["fast"]))


class Progress:
    """Members done, rate and time left, on one line of stderr."""

    def __init__(self, total: int, stream=None):
        # sys.stderr when drawn, not when this was defined (a replaced stderr, pytest's)
        self.total, self.stream = total, stream or sys.stderr
        self.t0 = time.perf_counter()
        self.done0: int | None = None

    def __call__(self, done: int) -> None:
        if self.done0 is None:
            self.done0 = done
        elapsed = time.perf_counter() - self.t0
        rate = (done - self.done0) / elapsed if elapsed > 0 else 0.0
        left = (self.total - done) / rate if rate > 0 else float("nan")
        eta = f"{left:,.0f} s left" if left == left else "..."
        self.stream.write(f"\r[sweep] {done:,}/{self.total:,} members "
                          f"({100 * done / self.total:.1f} %), {rate:,.0f} members/s, {eta}   ")
        self.stream.flush()

    def close(self) -> None:
        if self.done0 is not None:  # a line drawn ends; an error before any is one line
            self.stream.write("\n")


def run_sweep(case: str, cfg: Config, overrides: dict[str, Any], axes: dict[str, np.ndarray],
              out: Path, *, keep: int = 0, chunk: int = CHUNK, dask: str | None = None,
              progress: Callable[[int], None] | None = None, fast: bool = False) -> Path:
    """Run (or resume) a sweep into ``out``; return the path of results.parquet.
    ``fast``: the batch kernel's fast arithmetic (see :func:`mfcontrol.api.run.batch.run_range`);
    a folder holds one kind, and resuming with the other is refused."""

    grid = batch.make_grid(cfg, axes)
    manifest = _manifest(case, overrides, grid, chunk, fast)
    if dask:
        _dask_workers(dask)  # a bad address or a missing Dask before anything is written
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError("--out", str(out), f"cannot be created ({exc.strerror})") from None
    with _lock(out):
        _check_folder(out, manifest)
        return _run_locked(grid, cfg, manifest, out, keep=keep, chunk=chunk, dask=dask,
                           progress=progress, fast=fast)


def _run_locked(grid, cfg, manifest, out, *, keep, chunk, dask, progress, fast) -> Path:
    import pandas as pd

    chunk_dir = out / "chunks"
    chunk_dir.mkdir(exist_ok=True)
    _remove_leftovers(out)
    mark = _mark(manifest)
    all_chunks = list(batch.chunks(grid.n_members, chunk))
    todo = []
    for i, a, b in all_chunks:
        path = _chunk_path(chunk_dir, i)
        if not (path.exists() or path.is_symlink()):
            todo.append((i, a, b))
        elif (damage := _chunk_damage(path, mark, a, b)) is not None:
            sys.stderr.write(f"mfcontrol: {path} {damage}: computing it again\n")
            todo.append((i, a, b))
    done = grid.n_members - sum(b - a for _, a, b in todo)
    if progress:
        progress(done)
    spec = {"base": cfg.explicit, "grid": manifest["grid"], "chunk": chunk, "fast": fast}
    if keep:  # the kept trajectories first: one too long to record stops the sweep at once
        _keep(grid, keep, out, fast)
    if dask:
        done = _run_dask(dask, spec, todo, chunk_dir, done, progress, mark)
    else:
        changes = batch._cell_changes(grid) if batch.paper_grid(grid) else None
        for i, a, b in todo:
            frame = pd.DataFrame(batch.run_range(grid, a, b, changes, fast=fast))
            _write_chunk(frame, _chunk_path(chunk_dir, i), mark, a, b)
            done += b - a
            if progress:
                progress(done)
    frames = [pd.read_parquet(_chunk_path(chunk_dir, i)) for i, _, _ in all_chunks]
    results = pd.concat(frames, ignore_index=True)
    if len(results) != grid.n_members:  # every chunk was checked: a fault of ours
        raise RuntimeError(f"{len(results)} rows for {grid.n_members} members in {chunk_dir}")
    path = out / "results.parquet"
    _write_atomic(results, path)
    return path


def _dask_workers(address: str) -> int | None:
    """Check ``--dask``: N of ``local:N`` (None for a scheduler address), Dask installed."""
    try:
        import dask.distributed  # noqa: F401
    except ModuleNotFoundError:
        raise ConfigError("--dask", address, "needs Dask: pip install 'mfcontrol[dask]'"
                          ) from None
    if not address.startswith("local:"):
        if "://" not in address and ":" not in address:
            raise ConfigError("--dask", address, "must be local:N or a scheduler address "
                              "such as tcp://host:8786")
        scheme = address.split("://", 1)[0] if "://" in address else "tcp"
        if scheme not in ("tcp", "tls", "ws", "wss"):
            # Dask's other transports (ucx, inproc) need packages or a process of their own
            raise ConfigError("--dask", address, "must be local:N or a scheduler address "
                              "over tcp://, tls://, ws:// or wss://")
        return None
    text = address.split(":", 1)[1]
    if not text.isdigit() or not 1 <= int(text) <= 1024:
        raise ConfigError("--dask", address, "must be local:N with N workers, 1 to 1024")
    return int(text)


def _quiet_logs() -> None:
    """Silence Dask's logs below CRITICAL in this process (run on each local worker)."""
    for name in ("distributed", "tornado"):
        logging.getLogger(name).setLevel(logging.CRITICAL)


def _connect(address: str):
    """A Dask client for ``--dask ADDRESS``, and the local cluster it made (or None)."""
    from dask.distributed import Client, LocalCluster

    n = _dask_workers(address)
    if n is None:
        try:
            return Client(address, timeout="10s"), None
        except (OSError, ValueError, TypeError, TimeoutError) as exc:
            raise ConfigError("--dask", address, f"no Dask scheduler answered there ({exc})"
                              ) from None
    # TLS with credentials made for this cluster and dropped with it: no other process can
    # submit work to it.
    # A Ctrl-C in a terminal reaches the whole process group: the worker processes start
    # with SIGINT ignored (an ignored signal stays ignored across their exec), so that only
    # this process stops, closes the cluster and prints one line.
    main = threading.current_thread() is threading.main_thread()  # signal's rule
    handler = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               dashboard_address=None, security=True,
                               silence_logs=logging.CRITICAL)
    finally:
        if main:
            signal.signal(signal.SIGINT, handler)
    try:
        client = Client(cluster)
    except BaseException:
        cluster.close()
        raise
    # a worker whose heartbeat met the scheduler closing (after a Ctrl-C) logged a
    # CommClosedError traceback; silence_logs above reaches this process and the nannies,
    # not the worker processes. A failed task still reaches fut.result() with its error.
    client.run(_quiet_logs)
    return client, cluster


def _run_dask(address: str, spec: dict, todo, chunk_dir: Path, done: int, progress,
              mark: str) -> int:
    from dask.distributed import as_completed

    client, cluster = _connect(address)
    try:
        futures = {client.submit(_chunk_frame, spec, i, pure=False): (i, a, b)
                   for i, a, b in todo}
        for fut in as_completed(futures):
            i, a, b = futures[fut]
            _write_chunk(fut.result(), _chunk_path(chunk_dir, i), mark, a, b)
            done += b - a
            if progress:
                progress(done)
    finally:
        # closing ends the scheduler's comms while messages may still be on their way (after
        # a Ctrl-C): the scheduler, in this process, logs that at CRITICAL, with a
        # traceback, over the one line the command prints. Its logs are off while it closes
        # (a failed task has already reached fut.result() with its error)
        loggers = [logging.getLogger(name) for name in ("distributed", "tornado")]
        levels = [lg.level for lg in loggers]
        for lg in loggers:
            lg.setLevel(logging.CRITICAL + 1)
        try:
            client.close()
            if cluster is not None:
                cluster.close()
        finally:
            for lg, level in zip(loggers, levels, strict=True):
                lg.setLevel(level)
    return done


def _keep(grid: batch.Grid, keep: int, out: Path, fast: bool) -> None:
    folder = out / "trajectories"
    folder.mkdir(exist_ok=True)
    for m in keep_members(grid.n_members, keep):
        path = folder / f"member-{m}.csv"
        if not path.exists():
            # the single-run kernel in the sweep's arithmetic: exact, it is bit-identical
            # to the member's batch run; fast, within about 1e-13 of it
            simulate(grid.config(int(m)), name=f"member {m}", fast=fast).to_csv(path)
