"""Command line: ``mfcontrol cases | show | run | analyze | sweep | map | reproduce | tune |
compare | benchmark | export-c | tuner``.

Thin by design: parse, call the library, print. Bad input ends with one line on stderr and
exit code 2; an interrupted command ends with exit code 130.
"""

from __future__ import annotations

import argparse
import atexit
import dataclasses
import errno
import gc
import math
import os
import shutil
import sys
import textwrap
import time
import warnings
from pathlib import Path
from typing import Any

from . import files
from ._version import __version__
from .config.toml import parse_assignment
from .errors import CaseError, ConfigError, as_float

EXIT_USAGE = 2
#: errors of a path the user gave (exit 2, like any bad input); others (a full disk) exit 1
_PATH_ERRORS = {errno.EACCES, errno.EPERM, errno.EROFS, errno.ENOENT, errno.ENOTDIR,
                errno.EISDIR, errno.EEXIST, errno.ENAMETOOLONG}


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, no usage dump
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def _overrides(pairs: list[str] | None) -> dict:
    out = {}
    for text in pairs or []:
        key, value = parse_assignment(text)
        out[key] = value
    return out


def _out_dir(path: str | None, default: Path | None = None) -> Path:
    """``--out`` as a folder (``default`` when not given): refused in one line when empty
    (it would write into the current folder) or an existing file."""
    if path is None and default is not None:
        return default
    if path is None or not path.strip():
        raise ConfigError("--out", path, "must name a folder (it is empty)")
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise ConfigError("--out", path, "must be a folder (it is an existing file)")
    return out


def _writable(out: Path) -> Path:
    """``out``, checked before a long job (not after its first results) and without
    creating it: its nearest existing folder must be writable."""
    near = out
    while not near.exists() and near != near.parent:
        near = near.parent
    if not near.is_dir():
        raise ConfigError("--out", str(out), f"cannot be created ({near} is a file)")
    if not os.access(near, os.W_OK | os.X_OK):
        raise ConfigError("--out", str(out), f"cannot be written ({near}: permission denied)")
    return out


def _out_file(path: str) -> Path:
    """``--out`` as a file: refused in one line when empty or an existing folder."""
    if not path.strip():
        raise ConfigError("--out", path, "must name a file (it is empty)")
    if Path(path).is_dir():
        raise ConfigError("--out", path, "must name a file (it is an existing folder)")
    return Path(path)


def _cmd_cases(args) -> int:
    from .experiments import cases

    names = cases.names()
    width = max(len(n) for n in names)
    # each description wrapped to the terminal (80 columns when not one), indented under
    # its first line
    columns = max(shutil.get_terminal_size().columns, width + 40)
    for n in names:
        print(textwrap.fill(cases.describe(n), columns, initial_indent=f"{n:<{width}}  ",
                            subsequent_indent=" " * (width + 2)))
    return 0


def _cmd_show(args) -> int:
    from .api.run.simulate import shown_keys
    from .experiments import cases

    _, cfg = cases.resolve_case(args.case, _overrides(args.set), command="run")
    sys.stdout.write(cfg.to_toml(shown_keys(cfg)))
    return 0


def _cmd_run(args) -> int:
    from .api.results.result import SweepResult
    from .api.run.simulate import shown_keys
    from .experiments import cases

    name, cfg = cases.resolve_case(args.case, _overrides(args.set), command="run")
    out = _out_dir(args.out, Path("results") / name)
    result = cases.run_config(cfg, name, fast=args.fast)
    out.mkdir(parents=True, exist_ok=True)  # after the run: a refused run writes nothing
    result.to_csv(out / "trajectory.csv")
    files.write_text(out / "metrics.json", result.metrics_json() + "\n")
    files.write_text(out / "config.toml", cfg.to_toml(shown_keys(cfg)))
    if isinstance(result, SweepResult):
        result.plot(out / "figure.png", kind="error")
        result.plot(out / "figure-gamma.png", kind="gamma")
        for v, member in zip(result.values, result.members, strict=True):
            print(f"{result.key} = {v:g}: settled = {member.metrics['settled']}, "
                  f"IAE = {member.metrics['iae']:.4g}")
    else:
        result.plot(out / "figure.png")
        m = result.metrics
        print(f"{name}: settled = {m['settled']}, IAE = {m['iae']:.4g}, "
              f"max |e| after settle = {m['max_abs_e']:.4g}, TV(u) = {m['tv_u']:.4g}")
    print(f"wrote {out}/trajectory.csv, metrics.json, config.toml, figure.png")
    return 0


def _number_flag(flag: str, text: str, *, positive: bool = False,
                 allowed: str | None = None) -> float:
    """A flag's number: finite (and > 0 with ``positive``), else one line naming it."""
    try:
        value = as_float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and (value > 0 or not positive)):
        raise ConfigError(flag, text, allowed or "must be a finite number"
                          + (" > 0" if positive else ""))
    return value


def _cmd_analyze(args) -> int:
    from .experiments import cases
    from .experiments.analyze import analyze, region, region_axes

    gamma = None if args.gamma is None else _number_flag("--gamma", args.gamma, positive=True)
    level = None if args.at is None else _number_flag("--at", args.at)
    name, cfg = cases.resolve_case(args.case, _overrides(args.set), command="run")
    axes = region_axes(cfg, args.region) if args.region else None
    out = _writable(_out_dir(args.out, Path("results") / name))
    try:
        result = analyze(cfg, gamma=gamma, operating_point=level)
    except ConfigError:
        raise
    except ValueError as exc:  # --at on a linear plant; a law that needs --gamma, or a
        # PID given one
        flag, text = (("--at", args.at) if str(exc).startswith("operating_point")
                      else ("--gamma", args.gamma))
        raise ConfigError(flag, text, str(exc).split(": ", 1)[-1]) from None
    result = dataclasses.replace(result, name=name)
    print(f"{name}: linear loop sampled every {result.sample_time:g} s")
    print(textwrap.indent(result.summary(), "  "))
    written = result.write(out)
    if axes is not None:
        started = time.perf_counter()
        reg = dataclasses.replace(region(cfg, axes, gamma=gamma,
                                         operating_point=level), name=name)
        print(f"region: {reg.stable.sum():,} of {reg.stable.size:,} cells stable "
              f"({time.perf_counter() - started:.1f} s)")
        written += reg.write(out)
    print(f"wrote {out}/{', '.join(p.name for p in written)}")
    return 0


def _cmd_sweep(args) -> int:
    from .api.run.batch import parse_grid
    from .experiments import cases
    from .experiments.sweeps import Progress, run_sweep

    overrides = _overrides(args.set)
    if args.grid and overrides.get("sweep.grid") is not None:
        raise ConfigError("sweep.grid", overrides["sweep.grid"], "--grid replaces it: give "
                          "one of the two")
    name, cfg = cases.resolve_case(args.case, overrides, command="sweep")
    axes = parse_grid(args.grid or cfg["sweep.grid"] or [])
    cfg = cfg.with_overrides({"sweep.key": None, "sweep.values": None, "sweep.grid": None})
    out = _out_dir(args.out, Path("results") / "sweeps" / name)
    if args.keep is not None and args.keep < 0:
        raise ConfigError("--keep", args.keep, "must be a whole number >= 0")
    if args.chunk is not None and args.chunk < 1:
        raise ConfigError("--chunk", args.chunk, "must be a whole number >= 1")
    total = 1
    for v in axes.values():
        total *= v.size
    bar = Progress(total)
    try:
        try:
            path = run_sweep(name, cfg, overrides, axes, out, keep=args.keep or 0,
                             chunk=args.chunk or 4096, dask=args.dask, progress=bar,
                             fast=args.fast)
        finally:
            bar.close()  # ends the progress line before any message
    except KeyboardInterrupt:
        print(f"mfcontrol: interrupted; finished chunks are kept in {out}/chunks: run the "
              "same command again to resume", file=sys.stderr)
        return 130
    print(f"wrote {path}")
    return 0


def _cmd_map(args) -> int:
    from .experiments import maps

    where = {}
    for text in args.where or []:
        key, value = parse_assignment(text)
        where[key] = value
    try:
        path = maps.draw_map(Path(args.folder), args.x, args.y, args.metric,
                             path=None if args.out is None else _out_file(args.out),
                             where=where or None)
    except (ValueError, KeyError) as exc:
        raise CaseError(str(exc)) from None
    print(f"wrote {path}")
    return 0


def _cmd_reproduce(args) -> int:
    from .experiments.reproduce import reproduce

    fidelities = ["published", "paper"] if args.fidelity == "both" else [args.fidelity]
    report = reproduce(_out_dir(args.out), fidelities,
                       progress=lambda msg: print(msg, file=sys.stderr, flush=True))
    print(f"wrote {report}")
    return 0


def _cmd_tune(args) -> int:
    from .experiments import cases
    from .experiments.tune import DEFAULT_BUDGET, tune

    # bad input before work
    name, _ = cases.resolve_case(args.case, _overrides(args.set), command="run")
    out = _out_dir(args.out, Path("results") / "tune" / name)
    t_start = time.perf_counter()
    shown = []

    def progress(done: int, budget: int, best: float) -> None:
        shown.append(done)
        rate = done / max(time.perf_counter() - t_start, 1e-9)
        sys.stderr.write(f"\r[tune] {done:,}/{budget:,} points ({100 * done / budget:.0f} %), "
                         f"best {args.objective} = {best:.6g}, {rate:,.0f} points/s   ")
        sys.stderr.flush()

    try:
        result = tune(args.case, args.param or [], objective=args.objective,
                      scenarios=args.scenarios, aggregate_by=args.aggregate,
                      budget=DEFAULT_BUDGET if args.budget is None else args.budget,
                      seed=args.seed, log=args.log or [], overrides=_overrides(args.set),
                      out=out, progress=progress, constraints=args.constraint or ())
    finally:
        if shown:  # the progress line ends; an error's line starts on its own
            sys.stderr.write("\n")
    if result.evaluations == 0:
        print("mfcontrol: interrupted before any point was evaluated", file=sys.stderr)
        return 130
    own = ", ".join(f"{k} = {v:.6g}" if v is not None else f"{k} unset"
                    for k, v in result.start.items())
    own += (": not evaluated" if result.start_value != result.start_value
            else f": {result.start_value:.6g}")
    where = (f" ({args.aggregate} over {result.n_scenarios} scenarios; this "
             f"case's own run, which mfcontrol run best.toml gives: {result.nominal:.6g})"
             if result.scenarios else "")
    if math.isinf(result.value):
        met = f" and met {', '.join(result.constraints)}" if result.constraints else ""
        print(f"{name}: no point was valid and settled{met} in {result.evaluations} points: "
              "widen or move the bounds")
    else:
        best = ", ".join(f"{k} = {v:.6g}" for k, v in result.best.items())
        met = f", meeting {', '.join(result.constraints)}" if result.constraints else ""
        print(f"{name}: best {args.objective} = {result.value:.6g}{where} at {best}{met} "
              f"({result.evaluations} points, {result.runs} runs, {result.seconds:.1f} s, "
              f"{result.stopped}); the case's own {own}")
    print(f"wrote {out}/best.toml, summary.json, history.parquet, convergence.png")
    if result.stopped == "interrupted":
        print("mfcontrol: interrupted; the best so far is written", file=sys.stderr)
        return 130
    return 0


def _cmd_compare(args) -> int:
    from .experiments.compare import compare

    out = _out_dir(args.out, Path("results") / "compare")
    comp = compare(args.cases, _overrides(args.set), out=out)
    sys.stdout.write(comp.markdown())
    print(f"wrote {out}/comparison.csv, comparison.md, comparison.png")
    return 0


def _cmd_benchmark(args) -> int:
    from .experiments.benchmark import DEFAULT_MS, benchmark, print_progress

    out = _writable(_out_dir(args.out, Path("results") / "benchmark"))
    bar = print_progress()
    try:
        benchmark(args.plants, budget=args.budget, seed=args.seed, restarts=args.restarts,
                  ms=DEFAULT_MS if args.ms is None else _number_flag(
                      "--ms", args.ms, allowed="must be a finite number > 1, e.g. 2.0"),
                  quick=args.quick, out=out, progress=bar)
    except KeyboardInterrupt:
        print(f"\nmfcontrol: interrupted; finished tunings and scorings are kept in {out}: "
              "run the same command again to resume", file=sys.stderr)
        return 130
    finally:
        if bar.drawn:  # type: ignore[attr-defined]
            sys.stderr.write("\n")
    print(f"wrote {out}/report.md, results.csv, pareto.png, robustness.png and a folder per "
          "plant")
    return 0


def _limit(flag: str, text: str) -> float | None:
    """A limit given on the command line: a finite number, or none."""
    if text.strip().lower() == "none":
        return None
    return _number_flag(flag, text, allowed="each limit must be a finite number or none")


def _cmd_export_c(args) -> int:
    from .cexport import CFLAGS, export_c
    from .experiments import cases

    name, cfg = cases.resolve_case(args.case, _overrides(args.set), command="run")
    out = _out_dir(args.out, Path("results") / name / "c")
    sets = "".join(f" --set {text}" for text in args.set or [])
    limits = None
    if args.input_limits is not None:
        low, high = (_limit("--input-limits", text) for text in args.input_limits)
        limits = (low, high)
        sets += f" --input-limits {' '.join(args.input_limits)}"
    if args.frozen:
        sets += " --frozen"
    header, source = export_c(cfg, out=out, prefix=args.prefix, real=args.float,
                              description=f"case {args.case}{sets}", input_limits=limits,
                              frozen=args.frozen)
    build = "frozen" if args.frozen else f"tunable with {args.prefix}_set_params"
    print(f"wrote {header} and {source} ({cfg['controller.law']}, {args.float}, {build}); "
          f"compile with: cc {' '.join(CFLAGS)} -c {source}")
    key = cfg["sweep.key"]
    if key is not None:  # the controller of one setting, not of the sweep: said, not silent
        print(f"note: {name} sweeps {key}; this is the controller of its base setting, "
              f"{key} = {cfg[key]!r} (--set {key}=VALUE exports another)", file=sys.stderr)
    return 0


def _cmd_tuner(args) -> int:
    import importlib.util

    if importlib.util.find_spec("bokeh") is None:
        raise CaseError("needs the ui extra: pip install 'mfcontrol[ui]'")
    from .experiments import cases
    from .tuner.server import serve

    cases.resolve_case(args.case, _overrides(args.set), command="run")  # before the server

    if args.port is not None and not 0 <= args.port <= 65535:
        raise ConfigError("--port", args.port, "must be a whole number from 0 to 65535")
    try:
        serve(args.case, _overrides(args.set), port=args.port or 0,
              open_browser=not args.no_browser)
    except OSError as exc:
        if exc.errno != errno.EADDRINUSE:
            raise
        raise ConfigError("--port", args.port, "is in use on 127.0.0.1: choose another, "
                          "or 0 for a free one") from None
    except KeyboardInterrupt:
        print("mfcontrol: tuner stopped", file=sys.stderr)
        return 130
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="mfcontrol", description="Model-free control: intelligent controllers, "
                "variational gain tuning and a buck converter test bench.")
    p.add_argument("--version", action="version", version=f"mfcontrol {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    s = sub.add_parser("cases", help="list the built-in cases")
    s.set_defaults(func=_cmd_cases)

    setting: dict[str, Any] = {
        "action": "append", "metavar": "KEY=VALUE",
        "help": "set a configuration key (repeatable), e.g. controller.alpha=5; a key the "
                "command would not read is an error"}
    s = sub.add_parser("show", help="print a case's fully resolved configuration as TOML")
    s.add_argument("case", help="built-in case name or path of a .toml file")
    s.add_argument("--set", **setting)
    s.set_defaults(func=_cmd_show)

    s = sub.add_parser("run", help="run one case: trajectory.csv, metrics.json, figure.png")
    s.add_argument("case", help="built-in case name or path of a .toml file")
    s.add_argument("--set", **setting)
    s.add_argument("--out", help="output folder (default results/CASE)")
    s.add_argument("--fast", action="store_true", help="the compiled kernel's fast mode, "
                   "about 2.5x faster: within about 1e-13 relative of the default, which is "
                   "bit for bit the published arithmetic (metrics.json says which)")
    s.set_defaults(func=_cmd_run)

    s = sub.add_parser("analyze", help="a case's loop as the linear system it is within its "
                       "limits: poles, Ms, margins, noise gain (analysis.json, analysis.png)")
    s.add_argument("case", help="built-in case name or path of a .toml file")
    s.add_argument("--set", **setting)
    s.add_argument("--gamma", help="the gain gamma (1/alpha) at which to hold a law whose "
                   "gain moves (default: the variational law's gamma0)")
    s.add_argument("--at", metavar="Y", help="the output level at which to linearise a "
                   "nonlinear plant (its steady state there; default: the reference at the "
                   "end of the run)")
    s.add_argument("--region", action="append", metavar="KEY=SPEC",
                   help="an axis of a stability region, given twice, as sweep --grid takes "
                   "it, e.g. --region 'controller.alpha=logspace(0,3,100)' --region "
                   "'controller.kp=logspace(0,3,100)': region.csv and region.png (the "
                   "stable cells and Ms, from the analysis: no simulation)")
    s.add_argument("--out", help="output folder (default results/CASE)")
    s.set_defaults(func=_cmd_analyze)

    s = sub.add_parser("sweep", help="run a case over a grid of parameters (results.parquet)")
    s.add_argument("case", help="built-in case name or path of a .toml file")
    s.add_argument("--grid", action="append", metavar="KEY=SPEC",
                   help="swept key and values: a,b,c | linspace(a,b,n) | logspace(a,b,n); "
                        "several --grid combine as a product")
    s.add_argument("--set", **setting)
    s.add_argument("--out", help="output folder (default results/sweeps/CASE)")
    s.add_argument("--keep", type=int, help="also write the trajectories of N members")
    s.add_argument("--chunk", type=int, help="members per chunk file (default 4096)")
    s.add_argument("--dask", metavar="ADDRESS", help="run chunks on a Dask scheduler, or "
                   "local:N for a local cluster of N worker processes")
    s.add_argument("--fast", action="store_true", help="fast mode of the paper's buck "
                   "kernel, about 3x faster: fused multiply-adds, hoisted reciprocals and "
                   "the plant's RK4 step as its linear map; members within about 1e-13 "
                   "relative of their exact runs (default: bit-identical to single runs); "
                   "other cases' sweeps stay exact where they run in the vectorised loop "
                   "(their default once it is compiled on the machine)")
    s.set_defaults(func=_cmd_sweep)

    s = sub.add_parser("map", help="heatmap of a sweep's metric, with the boundary of "
                       "its settled runs")
    s.add_argument("folder", help="a sweep's output folder")
    s.add_argument("--x", required=True, help="swept key on the x axis")
    s.add_argument("--y", required=True, help="swept key on the y axis")
    s.add_argument("--metric", default="iae", help="metric column (default iae)")
    s.add_argument("--where", action="append", metavar="KEY=VALUE",
                   help="fix the other swept keys")
    s.add_argument("--out", help="PNG path (default FOLDER/map-METRIC-X-Y.png)")
    s.set_defaults(func=_cmd_map)

    s = sub.add_parser("reproduce", help="reproduce every result of the paper's section IV")
    s.add_argument("--out", default="results", help="output folder (default results)")
    s.add_argument("--fidelity", choices=("published", "paper", "both"), default="both",
                   help="published: the options as the published code sets them (its "
                   "trajectories, bit for bit); paper: the printed plant coupling, gamma "
                   "integrator and rate term (it keeps the published P term on y_{k-1}, "
                   "derivative divisor and gamma on the derivative error); both (default): "
                   "each in its own folder")
    s.set_defaults(func=_cmd_reproduce)

    s = sub.add_parser("tune", help="tune a case's gains by simulation (differential "
                       "evolution, a population per batch): best.toml, summary.json, "
                       "history.parquet, convergence.png")
    s.add_argument("case", help="built-in case name or path of a .toml file")
    s.add_argument("--param", action="append", metavar="KEY=LO:HI", required=True,
                   help="a tuned key and its bounds (repeatable), e.g. controller.kp=1:100")
    s.add_argument("--log", action="append", metavar="KEY",
                   help="search this tuned key on a log scale (its LO must be > 0)")
    s.add_argument("--objective", default="iae", help="a metric or a weighted sum such as "
                   "'iae+0.01*tv_u' (default iae); a diverged or unsettled run scores inf")
    s.add_argument("--scenarios", action="append", metavar="KEY=SPEC",
                   help="run every point on each member of this grid (as sweep --grid: "
                        "a,b,c | linspace(a,b,n) | logspace(a,b,n)), e.g. plant.a=-2,-1,-0.5")
    s.add_argument("--aggregate", choices=("max", "mean"), default="max",
                   help="a point's value over its scenarios: the worst (default) or the mean")
    s.add_argument("--budget", type=int, help="points to evaluate at most (default 600)")
    s.add_argument("--seed", type=int, default=0, help="the optimiser's seed (default 0)")
    s.add_argument("--constraint", action="append", metavar="KEY<=VALUE",
                   help="a bound on each point's linear analysis (repeatable), e.g. "
                   "'Ms<=1.6' or 'delay_margin_s>=0.05' (mfcontrol analyze's keys): a point "
                   "that misses it counts as failed")
    s.add_argument("--set", **setting)
    s.add_argument("--out", help="output folder (default results/tune/CASE)")
    s.set_defaults(func=_cmd_tune)

    s = sub.add_parser("compare", help="run several cases on one scenario: comparison.csv, "
                       "comparison.md, comparison.png")
    s.add_argument("cases", nargs="+", help="two or more built-in case names or .toml files")
    s.add_argument("--set", **setting)
    s.add_argument("--out", help="output folder (default results/compare)")
    s.set_defaults(func=_cmd_compare)

    s = sub.add_parser("benchmark", help="tune PIDs, an i-P, an i-PI and an ADRC alike on "
                       "every plant of the benchmark set (bench-* cases), score them on "
                       "held-out noise seeds and write report.md")
    s.add_argument("--plants", nargs="+", metavar="CASE",
                   help="benchmark cases to run (default: every bench-* case; two with "
                        "--quick)")
    s.add_argument("--budget", type=int, help="points per restart, the same for every "
                   "searched controller (default 2000; 150 with --quick)")
    s.add_argument("--restarts", type=int, help="optimiser seeds per searched controller "
                   "(default 3)")
    s.add_argument("--seed", type=int, default=0, help="the first restart's optimiser seed "
                   "(default 0)")
    s.add_argument("--ms", help="the bound on every searched loop's peak sensitivity Ms "
                   "(default 2.0)")
    s.add_argument("--quick", action="store_true", help="two plants, fewer points and seeds, "
                   "the same report (a few minutes)")
    s.add_argument("--out", help="output folder (default results/benchmark)")
    s.set_defaults(func=_cmd_benchmark)

    s = sub.add_parser("export-c", help="write a case's controller as C99 (PREFIX.h, PREFIX.c): "
                       "no dependency but <math.h>, bit for bit the Python controller in double")
    s.add_argument("case", help="built-in case name or path of a .toml file")
    s.add_argument("--set", **setting)
    s.add_argument("--out", help="output folder (default results/CASE/c)")
    s.add_argument("--prefix", default="mfc", help="file name and prefix of every C name "
                   "(default mfc: mfc.h, mfc_step...)")
    s.add_argument("--real", "--float", dest="float",
                   choices=("double", "float", "q31", "q15"), default="double",
                   help="number type of the C (default double; q31: fixed point for a core "
                   "without an FPU: the PID, and the i-P family with the backward "
                   "difference and a constant gain; q15: the PID in 16-bit codes, about "
                   "half q31's cycles on a Cortex-M0; both with --input-limits for the "
                   "measurement's scale)")
    s.add_argument("--input-limits", nargs=2, metavar=("LOW", "HIGH"),
                   help="the measurement's valid range (the sensor's; 'none' for no limit): "
                   "a sample outside is rejected as a NaN is, the output held")
    s.add_argument("--frozen", action="store_true",
                   help="every parameter a constant folded into the code, no "
                   "PREFIX_set_params (default: gains and limits in a parameter struct, "
                   "checked and changed at run time)")
    s.set_defaults(func=_cmd_export_c)

    s = sub.add_parser("tuner", help="tune a case interactively in the browser: sliders, "
                       "plots and metrics redrawn at every change, a frozen reference run, "
                       "robustness maps, tuning (needs the ui extra)")
    s.add_argument("case", nargs="?", default="voltage-stable-standard",
                   help="built-in case name or path of a .toml file (default "
                        "voltage-stable-standard)")
    s.add_argument("--set", **setting)
    s.add_argument("--port", type=int, help="port on 127.0.0.1 (default 0: a free one)")
    s.add_argument("--no-browser", action="store_true",
                   help="print the address without opening a browser")
    s.set_defaults(func=_cmd_tuner)
    return p


#: commands that end soon after they start, their garbage (a figure, a result) freed
#: with the process
_SHORT = frozenset({"cases", "show", "run", "analyze", "map", "export-c"})


def _own_process(command: str) -> None:
    """The cyclic garbage collector of a command's own process, tuned for what it holds:
    hundreds of thousands of objects that live as long as it does (numba's, scipy's and
    matplotlib's modules), few cycles to free."""
    # the young generation is collected every 700 new objects by default: a run walked its
    # imports' objects 400 times over (0.2 s of CPU)
    if command in _SHORT:
        gc.disable()
    elif command != "tuner":  # the one server, running for hours: the default thresholds
        gc.set_threshold(100_000, 50, 100)  # a long command's cycles are still freed
    # Python's last collections at exit walk every object left (0.4 s of CPU after a run);
    # frozen, they go back to the system with the process's memory. Every file is closed
    # by then
    atexit.register(gc.freeze)


def _warning_line(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: Any = None, line: str | None = None) -> None:
    """A warning as one line, as the command's errors are: no source file and line."""
    print(f"mfcontrol: warning: {message}", file=sys.stderr if file is None else file)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if argv is None:  # the command's own process (its console script, python -m)
        _own_process(args.command)
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _warning_line
            return args.func(args)
    except (ConfigError, CaseError) as exc:
        print(f"mfcontrol: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("mfcontrol: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader went away (`mfcontrol cases | head -1`): no traceback; stdout goes
        # to devnull so that Python's flush at exit does not raise again
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except OSError as exc:
        # a file or folder that cannot be made, read or written (a read-only place, a full
        # disk), or a lost connection (Dask): what, and where when it is a path, one line
        if exc.filename is None:
            print(f"mfcontrol: error: {type(exc).__name__}: {exc}", file=sys.stderr)
            return 1
        # os.replace names its source, a temporary file; the file meant is the target
        where = exc.filename2 if exc.filename2 is not None else exc.filename
        print(f"mfcontrol: error: {where}: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_USAGE if exc.errno in _PATH_ERRORS else 1


if __name__ == "__main__":
    sys.exit(main())
