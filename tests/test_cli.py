"""The ``mfcontrol`` command line, run for real in a subprocess.

Requirement: bad input gets one line on stderr naming the key, the value and what is
allowed, exit code 2, no traceback (unknown case or file, unknown key, malformed value,
non-positive h/L/C/R/alpha/t_end, NaN or inf anywhere, malformed TOML). The happy paths
(``cases``, ``show``, ``run``, ``--version``) are checked too.

Every error command of ERRORS is checked twice: in-process through ``mfcontrol.cli.main``
(fast, so the whole matrix is affordable) and, for the CORE subset that covers each
category, as the real command in a subprocess. The subprocesses only parse and validate,
so one module fixture starts them all at once, a few in parallel.
"""

from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
import tomllib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

import mfcontrol
from mfcontrol.cli import main
from mfcontrol.experiments.cases import CASES_DIR

CASE = "voltage-stable-standard"
SHORT = ["--set", "sim.t_end=0.001"]  # 1000 samples: every run stays short
HUGE_INT = "1" + "0" * 400  # a valid TOML integer far beyond the float range

ALL_CASES = (
    "voltage-stable-standard", "voltage-stable-variational", "voltage-unstable-standard",
    "voltage-unstable-variational", "power-standard", "power-variational", "sweep-Gamma",
    "sweep-epsM",
    "buck-ipi", "boost-ipd", "first-order-ip-algebraic",
    "map-alpha-dR-standard", "map-alpha-dR-variational", "map-Gamma-epsM",
    "motor-noise-ipi", "motor-noise-ipi-algebraic", "motor-noise-pid", "motor-noise-adrc",
    "buck-50khz-noise",
    "bench-boost", "bench-buck", "bench-dc-motor", "bench-delay-lag-t1", "bench-delay-lag-t10",
    "bench-fourpole", "bench-integrating-delay", "bench-lag3", "bench-lag8", "bench-nonminimum",
)


def _env() -> dict[str, str]:
    return {**os.environ, "MPLBACKEND": "Agg"}


def cli(*args: str, cwd: Path | str | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mfcontrol.cli", *args], cwd=cwd,
                          capture_output=True, text=True, env=_env(), timeout=600)


def assert_usage_error(proc: subprocess.CompletedProcess, *needles: str) -> str:
    """Exit code 2, nothing on stdout, exactly one non-empty line on stderr, no traceback,
    and every needle (key, value, what is allowed) in that line."""
    detail = f"rc={proc.returncode}\nstdout={proc.stdout!r}\nstderr={proc.stderr!r}"
    assert "Traceback" not in proc.stderr, detail
    assert proc.returncode == 2, detail
    assert proc.stdout == "", detail
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, detail
    line = lines[0]
    assert line.strip(), detail
    assert proc.stderr == line + "\n", detail
    assert "error:" in line, detail
    for needle in needles:
        assert needle in line, f"{needle!r} not in {line!r}"
    return line


# ---------------------------------------------------------------------------------------
# bad input: one line, exit code 2, no traceback
# ---------------------------------------------------------------------------------------

#: case files written into the fixture's folder ({d} in the commands below)
FILES: dict[str, bytes] = {
    "deep.toml": b"[controller]\nalpha = " + b"[" * 5000 + b"]" * 5000 + b"\n",
    "nan-alpha.toml": b"[controller]\nalpha = nan\n",
    "inf-E.toml": b"[plant]\nE = inf\n",
    "neg-inf-kp.toml": b"[controller]\nkp = -inf\n",
    "nan-change.toml": b"[plant]\nchange_times = [4e-3, nan]\n",
    "nan-ramp2.toml": b"[reference]\nt_ramp2 = +nan\n",
    "nan-sweep.toml": b'[sweep]\nkey = "controller.Gamma"\nvalues = [5e-8, inf]\n',
    "nan-top.toml": b"fidelity = nan\n",
    "bad-table.toml": b"[plant\nE = 3.0\n",
    "bad-pair.toml": b"[controller]\nalpha =\n",
    "bad-dup.toml": b"[plant]\nE = 1.0\nE = 2.0\n",
    "bad-string.toml": b'description = "unterminated\n',
    "bad-bytes.toml": b"\xff\xfe[plant]\nE = 1.0\n",
    "unknown-key.toml": b"[controller]\nalpah = 3.0\n",
    "unknown-table.toml": b"[plantt]\nE = 3.0\n",
    "wrong-type.toml": b'[sim]\nh = "fast"\n',
    "zero-h.toml": b"[sim]\nh = 0.0\n",
    "huge-int.toml": b"[controller]\nalpha = " + HUGE_INT.encode() + b"\n",
    # issue 28: keys the run would not read
    "ki-on-ip.toml": b'[plant]\nmodel = "first-order"\n[controller]\nlaw = "i-P"\n'
                     b'alpha = 1.0\nki = 3.0\n[sim]\nh = 1e-3\nt_end = 1.0\n',
    # a benchmark case with a key none of its controllers reads
    "bench-unread.toml": (CASES_DIR / "bench-lag3.toml").read_bytes().replace(
        b"[controller]\n", b"[controller]\nrate_sign = \"minus\"\n"),
}

S = "show"
T = ["tune", "first-order-ip-algebraic"]
ERRORS = [
    # tuner: refused before any server starts
    pytest.param(["tuner", "nope", "--no-browser"], ["unknown case 'nope'"],
                 id="tuner-unknown-case"),
    pytest.param(["tuner", "voltage-stable-standard", "--no-browser", "--set",
                  "controller.alpha=-1"], ["controller.alpha", "-1", "> 0"],
                 id="tuner-bad-set"),
    pytest.param(["tuner", "{d}/nan-alpha.toml", "--no-browser"], ["controller.alpha", "nan"],
                 id="tuner-bad-file"),
    pytest.param(["tuner", "voltage-stable-standard", "--no-browser", "--port", "70000"],
                 ["--port", "70000", "0 to 65535"], id="tuner-bad-port"),
    # tune, compare, benchmark
    pytest.param([*T, "--param", "controller.kp"], ["--param", "KEY=LO:HI"],
                 id="tune-param-without-range"),
    pytest.param([*T, "--param", "controller.kp=5:1"], ["--param", "LO < HI"],
                 id="tune-empty-range"),
    pytest.param([*T, "--param", "controller.alpha=0:2"], ["controller.alpha", "> 0"],
                 id="tune-range-outside-the-option"),
    pytest.param([*T, "--param", "controller.kp=1:2", "--objective", "iea"],
                 ["--objective", "'iea'", "iae"], id="tune-bad-objective"),
    pytest.param([*T, "--param", "controller.kp=1:2", "--budget", "3"], ["--budget", ">= 10"],
                 id="tune-small-budget"),
    pytest.param([*T, "--param", "controller.kp=1:2", "--log", "controller.alpha"],
                 ["--log", "controller.alpha", "tuned key"], id="tune-log-of-untuned-key"),
    pytest.param([*T, "--param", "controller.kp=1:2", "--scenarios", "plant.a=x"],
                 ["plant.a", "linspace"], id="tune-bad-scenarios"),
    pytest.param([*T, "--param", "controller.kp=1:2", "--aggregate", "median"],
                 ["--aggregate", "median"], id="tune-bad-aggregate"),
    pytest.param(["tune", "nope", "--param", "controller.kp=1:2"], ["'nope'", "unknown case"],
                 id="tune-unknown-case"),
    pytest.param(["compare", "motor-noise-pid"], ["at least two"], id="compare-one-case"),
    pytest.param(["compare", "motor-noise-pid", "nope"], ["'nope'", "unknown case"],
                 id="compare-unknown-case"),
    pytest.param(["benchmark", "--plants", "first-order-ip-algebraic"],
                 ["benchmark.", "a benchmark case must give it"],
                 id="benchmark-plant-without-table"),
    pytest.param(["benchmark", "--plants", "nope"], ["'nope'", "unknown case"],
                 id="benchmark-unknown-plant"),
    pytest.param(["benchmark", "--plants", "bench-lag3", "--ms", "0.5"],
                 ["--ms = 0.5: must be a finite number > 1"], id="benchmark-ms-below-1"),
    pytest.param(["benchmark", "--plants", "bench-lag3", "--ms", "two"],
                 ["--ms = 'two': must be a finite number > 1"], id="benchmark-ms-not-a-number"),
    pytest.param(["benchmark", "--quick", "--restarts", "1"],
                 ["--restarts = 1: must be a whole number >= 2"], id="benchmark-one-restart"),
    # issue 14: faults found by fuzzing
    pytest.param([S, "{d}/deep.toml"], ["deep.toml", "nested too deeply"], id="deep-file"),
    pytest.param([S, CASE, "--set", "controller.alpha=" + "[" * 3000 + "]" * 3000],
                 ["controller.alpha", "nested too deeply"], id="deep-set"),
    pytest.param(["sweep", CASE, "--grid", "controller.alpha=linspace(1,2,1000000000000)",
                  "--out", "{d}/huge-grid"],
                 ["1,000,000,000,000 values", "at most 10,000,000 on one axis"],
                 id="huge-grid-axis"),
    pytest.param([S, "sweep-Gamma", "--set", "sweep.values=[]"],
                 ["sweep.values = []", "at least one value"], id="empty-sweep-values"),
    # export-c
    pytest.param(["export-c", CASE, "--prefix", "9lives", "--out", "{d}/c-prefix"],
                 ["prefix = '9lives'", "must be a C identifier"], id="export-c-bad-prefix"),
    pytest.param(["export-c", "motor-noise-ipi-algebraic", "--float", "float",
                  "--set", "controller.window=5000", "--out", "{d}/c-window"],
                 ["controller.window = 5000", "at most 4,095 samples in a float export"],
                 id="export-c-float-window"),
    pytest.param(["export-c", "nope"], ["'nope'", "unknown case"], id="export-c-unknown-case"),
    pytest.param(["export-c", CASE, "--input-limits", "5", "1", "--out", "{d}/c-lim"],
                 ["input_limits = (5.0, 1.0)", "low must not exceed high"],
                 id="export-c-input-limits-reversed"),
    pytest.param(["export-c", CASE, "--input-limits", "nan", "1", "--out", "{d}/c-lim"],
                 ["--input-limits = 'nan'", "finite number or none"],
                 id="export-c-input-limits-nan"),
    # unknown case or file
    pytest.param([S, "nope"], ["'nope'", "unknown case", "built-in cases are",
                               "voltage-stable-standard", ".toml"], id="unknown-case"),
    pytest.param([S, "nope.toml"], ["'nope.toml'", "not found"], id="missing-file"),
    pytest.param([S, "{d}/missing/case.toml"], ["case.toml", "not found"],
                 id="missing-file-in-missing-folder"),
    pytest.param([S, "{d}"], ["is a folder, not a case"], id="folder-instead-of-file"),
    pytest.param(["run", "nope", "--out", "{d}/out-unknown"], ["'nope'", "unknown case"],
                 id="run-unknown-case"),
    pytest.param(["run", "nope.toml", *SHORT], ["'nope.toml'", "not found"],
                 id="run-missing-file"),
    # unknown key
    pytest.param([S, CASE, "--set", "controller.alpah=3"],
                 ["controller.alpah = 3", "unknown key", "did you mean controller.alpha?"],
                 id="unknown-key"),
    pytest.param([S, CASE, "--set", "bogus=1"], ["bogus = 1", "unknown key"],
                 id="unknown-key-no-suggestion"),
    pytest.param([S, "{d}/unknown-key.toml"], ["controller.alpah = 3.0", "unknown key",
                                               "did you mean controller.alpha?"],
                 id="unknown-key-in-file"),
    pytest.param([S, "{d}/unknown-table.toml"], ["plantt.E = 3.0", "unknown key",
                                                 "did you mean plant.E?"],
                 id="unknown-table-in-file"),
    # malformed value
    pytest.param([S, CASE, "--set", "controller.alpha=abc"],
                 ["controller.alpha", "'abc'", "must be a finite number > 0"],
                 id="malformed-number"),
    pytest.param([S, CASE, "--set", "controller.alpha="],
                 ["controller.alpha", "''", "must be a finite number > 0"], id="empty-value"),
    pytest.param([S, CASE, "--set", "controller.kp=1,5"],
                 ["controller.kp", "'1,5'", "must be a finite number"], id="decimal-comma"),
    pytest.param([S, CASE, "--set", "sim.h=true"],
                 ["sim.h", "True", "must be a finite number > 0"], id="bool-for-number"),
    pytest.param([S, CASE, "--set", "controller.rate_term=yes"],
                 ["controller.rate_term", "'yes'", "must be true or false"],
                 id="malformed-bool"),
    pytest.param([S, CASE, "--set", "plant.change_times=0.004"],
                 ["plant.change_times", "0.004", "must be a list of finite numbers >= 0"],
                 id="number-for-list"),
    pytest.param([S, CASE, "--set", "plant.change_times=[0.004, x]"],
                 ["plant.change_times", "must be a list of finite numbers >= 0"],
                 id="malformed-list"),
    pytest.param([S, CASE, "--set", "description=3"],
                 ["description", "3", "must be a string"], id="number-for-string"),
    pytest.param([S, "{d}/wrong-type.toml"], ["sim.h", "'fast'", "must be a finite number > 0"],
                 id="string-for-number-in-file"),
    # choices
    pytest.param([S, CASE, "--set", "fidelity=wrong"],
                 ["fidelity", "'wrong'", "must be one of published, paper"], id="bad-fidelity"),
    pytest.param([S, CASE, "--set", "controller.law=PID"],
                 ["controller.law", "'PID'",
                  "must be one of ip, variational, i-P, i-PI, i-PD, i-PID, pid"], id="bad-law"),
    pytest.param([S, CASE, "--set", "sensor.delay=99999999"],
                 ["sensor.delay", "99999999", "must be a whole number from 0 to 1,000,000"],
                 id="sensor-delay-past-the-run"),
    pytest.param([S, CASE, "--set", "sensor.noise=pink"],
                 ["sensor.noise", "'pink'", "must be one of none, gaussian, uniform"],
                 id="bad-noise"),
    pytest.param([S, CASE, "--set", "plant.coupling=loose"],
                 ["plant.coupling", "'loose'", "must be one of published, textbook"],
                 id="bad-coupling"),
    pytest.param([S, CASE, "--set", "controller.integrator=third-order"],
                 ["controller.integrator", "'third-order'",
                  "must be one of first-order, second-order"], id="bad-integrator"),
    # --set without '='
    pytest.param([S, CASE, "--set", "controller.alpha"],
                 ["controller.alpha", "expected key=value"], id="set-without-equals"),
    pytest.param([S, CASE, "--set", "=3"], ["=3", "expected key=value"], id="set-without-key"),
    # non-positive h, L, C, R, alpha, t_end (and the other positive options)
    *[pytest.param([S, CASE, "--set", f"{key}={raw}"],
                   [f"{key} = {shown}", "must be a finite number > 0"], id=f"{key}={raw}")
      for key, raw, shown in [
          ("sim.h", "0", "0"), ("sim.h", "-1e-6", "-1e-06"), ("plant.L", "-1", "-1"),
          ("plant.L", "0.0", "0.0"), ("plant.C", "0", "0"), ("plant.C", "-1e-5", "-1e-05"),
          ("plant.R", "-5", "-5"), ("plant.R", "-0.0", "-0.0"),
          ("controller.alpha", "0", "0"), ("controller.alpha", "-10", "-10"),
          ("sim.t_end", "-1", "-1"), ("sim.t_end", "0", "0"), ("plant.E", "0", "0"),
          ("controller.deriv_scale", "0", "0"), ("controller.output_gain", "-1", "-1"),
          ("sim.diverge_above", "0", "0"), ("metrics.settled_tol", "0", "0")]],
    pytest.param([S, "{d}/zero-h.toml"], ["sim.h = 0.0", "must be a finite number > 0"],
                  id="zero-h-in-file"),
    pytest.param(["run", CASE, "--set", "sim.h=0", "--out", "{d}/out-zero-h"],
                 ["sim.h = 0", "must be a finite number > 0"], id="run-zero-h"),
    pytest.param(["run", CASE, "--set", "plant.R=-5", *SHORT],
                 ["plant.R = -5", "must be a finite number > 0"], id="run-negative-R"),
    # other range checks
    pytest.param([S, CASE, "--set", "metrics.final_window=1.5"],
                 ["metrics.final_window = 1.5", "must be a number in (0, 1]"],
                 id="fraction-above-1"),
    pytest.param([S, CASE, "--set", "metrics.settle_time=-1"],
                 ["metrics.settle_time = -1", "must be a finite number >= 0"],
                 id="negative-settle-time"),
    pytest.param([S, CASE, "--set", "plant.change_times=[-0.001]"],
                 ["plant.change_times = [-0.001]", "must be a list of finite numbers >= 0"],
                 id="negative-change-time"),
    # consistency between keys
    pytest.param([S, CASE, "--set", "sim.t_end=0.0010005"],
                 ["sim.t_end = 0.0010005", "must be a whole number (>= 2) of sim.h"],
                 id="t_end-not-whole-steps"),
    pytest.param([S, CASE, "--set", "controller.duty_min=0.95"],
                 ["controller.duty_min = 0.95", "must not exceed controller.duty_max = 0.9"],
                 id="duty_min-above-duty_max"),
    pytest.param([S, CASE, "--set", "plant.dR=-6"],
                 ["plant.dR = -6.0", "must keep plant.R > 0 after 2 load changes"],
                 id="dR-makes-R-negative"),
    pytest.param([S, CASE, "--set", "sweep.key=controller.law", "--set", "sweep.values=[1.0]"],
                 ["sweep.key = 'controller.law'", "must name a numeric option"],
                 id="sweep-key-not-numeric"),
    # NaN or inf anywhere: on the command line ...
    pytest.param([S, CASE, "--set", "controller.kp=nan"],
                 ["controller.kp = nan", "must be a finite number"], id="nan-kp"),
    pytest.param([S, CASE, "--set", "plant.E=inf"],
                 ["plant.E = inf", "must be a finite number > 0"], id="inf-E"),
    pytest.param([S, CASE, "--set", "controller.Gamma=-inf"],
                 ["controller.Gamma = -inf", "must be a finite number"], id="neg-inf-Gamma"),
    pytest.param([S, CASE, "--set", "sim.h=nan"],
                 ["sim.h = nan", "must be a finite number > 0"], id="nan-h"),
    pytest.param([S, CASE, "--set", "controller.alpha=1e400"],
                 ["controller.alpha = inf", "must be a finite number > 0"],
                 id="float-literal-overflows-to-inf"),
    pytest.param([S, CASE, "--set", "plant.change_times=[0.004, nan]"],
                 ["plant.change_times = [0.004, nan]", "must be a list of finite numbers"],
                 id="nan-in-list"),
    pytest.param([S, CASE, "--set", "sweep.key=controller.Gamma",
                  "--set", "sweep.values=[1e-8, nan]"],
                 ["sweep.values = [1e-08, nan]", "must be a list of finite numbers"],
                 id="nan-in-sweep-values"),
    pytest.param(["run", CASE, "--set", "controller.kp=nan", "--out", "{d}/out-nan"],
                 ["controller.kp = nan", "must be a finite number"], id="run-nan-kp"),
    # ... and inside a case file (TOML has nan and inf literals)
    pytest.param([S, "{d}/nan-alpha.toml"],
                 ["controller.alpha = nan", "must be a finite number > 0"], id="file-nan"),
    pytest.param([S, "{d}/inf-E.toml"], ["plant.E = inf", "must be a finite number > 0"],
                 id="file-inf"),
    pytest.param([S, "{d}/neg-inf-kp.toml"], ["controller.kp = -inf", "must be a finite number"],
                 id="file-neg-inf"),
    pytest.param([S, "{d}/nan-change.toml"],
                 ["plant.change_times = [0.004, nan]", "must be a list of finite numbers"],
                 id="file-nan-in-list"),
    pytest.param([S, "{d}/nan-ramp2.toml"],
                 ["reference.t_ramp2 = nan", "must be a finite number >= 0"],
                 id="file-nan-optional-key"),
    pytest.param([S, "{d}/nan-sweep.toml"],
                 ["sweep.values = [5e-08, inf]", "must be a list of finite numbers"],
                 id="file-inf-in-sweep"),
    pytest.param([S, "{d}/nan-top.toml"], ["fidelity = nan", "must be one of published, paper"],
                 id="file-nan-for-choice"),
    pytest.param(["run", "{d}/nan-alpha.toml", *SHORT],
                 ["controller.alpha = nan", "must be a finite number > 0"], id="run-file-nan"),
    # malformed TOML
    pytest.param([S, "{d}/bad-table.toml"], ["bad-table.toml", "is not valid TOML", "line 1"],
                 id="toml-unclosed-table"),
    pytest.param([S, "{d}/bad-pair.toml"], ["bad-pair.toml", "is not valid TOML", "line 2"],
                 id="toml-missing-value"),
    pytest.param([S, "{d}/bad-dup.toml"], ["bad-dup.toml", "is not valid TOML", "line 3"],
                 id="toml-duplicate-key"),
    pytest.param([S, "{d}/bad-string.toml"], ["bad-string.toml", "is not valid TOML"],
                 id="toml-unterminated-string"),
    pytest.param([S, "{d}/bad-bytes.toml"], ["bad-bytes.toml", "cannot be read"],
                 id="not-utf8"),
    pytest.param(["run", "{d}/bad-table.toml", *SHORT], ["bad-table.toml", "is not valid TOML"],
                 id="run-malformed-toml"),
    # argument errors (argparse) follow the same rule
    pytest.param([S], ["the following arguments are required: case"], id="show-without-case"),
    pytest.param(["frobnicate"], ["invalid choice", "'frobnicate'"], id="unknown-command"),
    pytest.param(["reproduce", "--fidelity", "wrong"],
                 ["--fidelity", "'wrong'", "published", "paper", "both"],
                 id="reproduce-bad-fidelity"),
    pytest.param([S, CASE, "--bogus"], ["unrecognized arguments: --bogus"],
                 id="unknown-option"),
    # regressions: each of these once ended in a traceback and exit code 1
    pytest.param([S, CASE, "--set", f"controller.alpha={HUGE_INT}"],
                 ["controller.alpha = 1000000", "must be a finite number > 0"],
                 id="huge-integer"),
    pytest.param([S, "{d}/huge-int.toml"],
                 ["controller.alpha = 1000000", "must be a finite number > 0"],
                 id="huge-integer-in-file"),
    pytest.param([S, CASE, "--set", "sim.t_end=1e308"], ["sim.t_end = 1e+308", "sim.h"],
                 id="t_end-over-h-overflows"),
    pytest.param([S, CASE, "--set", "sim.h=5e-324"], ["sim.t_end", "sim.h = 5e-324"],
                 id="tiny-h-overflows"),
    pytest.param(["run", CASE, *SHORT, "--set", "sweep.key=sim.h",
                  "--set", "sweep.values=[1e-6, 2e-6]", "--out", "{d}/out-sweep-h"],
                 ["sweep.key = 'sim.h'", "must name a numeric option"], id="sweep-over-sim.h"),
    pytest.param([S, CASE, "--set", "sweep.key=sim.t_end", "--set", "sweep.values=[0.001]"],
                 ["sweep.key = 'sim.t_end'", "must name a numeric option"],
                 id="sweep-over-sim.t_end"),
    pytest.param([S, CASE, "--set", "controller.alpah=37.5"],
                 ["controller.alpah = 37.5", "unknown key"], id="unknown-key-names-its-value"),
    # issue 14 item 9: a built-in name with a path in it ran the built-in file and wrote
    # results/../cases/...
    pytest.param(["run", "../cases/voltage-stable-standard", *SHORT],
                 ["unknown case '../cases/voltage-stable-standard'"], id="case-name-with-path"),
    # issue 14 item 6: a recorded run of 10^8 samples tried to allocate 7.5 GiB
    pytest.param(["run", CASE, "--set", "sim.t_end=100", "--out", "{d}/out-long"],
                 ["sim.t_end = 100.0", "100,000,000 samples", "GiB", "sweep"],
                 id="recorded-run-too-long"),
    pytest.param(["run", "motor-noise-ipi", "--set", "sim.t_end=100000", "--out",
                  "{d}/out-long-motor"], ["sim.t_end = 100000.0", "GiB", "sweep"],
                 id="recorded-loop-too-long"),
]


# issue 28 item 1: a key set that the command will not read is refused, saying why and
# what to set (the issue's examples word for word)
ISSUE_28 = [
    pytest.param(["run", "first-order-ip-algebraic", "--set", "controller.ki=3.0"],
                 ['mfcontrol: error: controller.ki = 3.0: not read with controller.law = '
                  '"i-P": set controller.law = "i-PI", "i-PID" or "pid", or remove it'],
                 id="issue28-ki-on-an-i-P"),
    pytest.param(["run", "first-order-ip-algebraic", "--set", "disturbance.amplitude=1"],
                 ['mfcontrol: error: disturbance.amplitude = 1.0: not read with '
                  'disturbance.kind = "none": set disturbance.kind = "step", "ramp" or '
                  '"sine", or remove it'], id="issue28-amplitude-without-a-disturbance"),
    pytest.param(["run", "motor-noise-ipi", "--set", "controller.window=40"],
                 ['mfcontrol: error: controller.window = 40: not read with '
                  'controller.estimator = "backward-difference": set controller.estimator = '
                  '"algebraic", or remove it'], id="issue28-window-with-backward-differences"),
    pytest.param(["run", "{d}/ki-on-ip.toml"],
                 ['controller.ki = 3.0: not read with controller.law = "i-P"'],
                 id="issue28-unread-key-in-a-case-file"),
    pytest.param([S, "motor-noise-ipi", "--set", "fidelity=paper"],
                 ["fidelity = 'paper': not read with plant.model = \"dc-motor\" and "
                  "controller.adapt = \"constant\": set plant.model = \"buck\" (and unset "
                  "plant.schedule) or controller.adapt = \"variational\", or remove it"],
                 id="issue28-show-fidelity-of-a-motor"),
    pytest.param([S, "motor-noise-pid", "--set", "controller.window=30"],
                 ['controller.window = 30: not read with controller.law = "pid": set '
                  'controller.law = "i-P", "i-PI", "i-PD" or "i-PID" with '
                  'controller.estimator = "algebraic", or remove it'],
                 id="issue28-two-choices-away"),
    pytest.param([S, "bench-buck", "--set", "controller.window=30"],
                 ['controller.window = 30: not read with controller.law = "pid"'],
                 id="issue28-set-is-for-this-command"),
    pytest.param([S, "motor-noise-ipi", "--set", "plant.R=3"],
                 ['plant.R = 3.0: not read with plant.model = "dc-motor": set plant.model = '
                  '"buck" or "boost" (and unset plant.schedule), or remove it'],
                 id="issue28-another-plants-key"),
    pytest.param([S, CASE, "--set", "benchmark.objective=iae"],
                 ["benchmark.objective = 'iae': read by mfcontrol benchmark only"],
                 id="issue28-another-commands-key"),
    pytest.param(["run", CASE, "--set", "sweep.key=controller.Gamma", "--set",
                  "sweep.values=[1e-8, 1e-7]", "--out", "{d}/out-unread-sweep"],
                 ["sweep.key = 'controller.Gamma': not read with controller.law = \"ip\"",
                  "or sweep another key"], id="issue28-sweep-key-unread"),
    pytest.param(["sweep", "first-order-ip-algebraic", "--grid", "controller.ki=1,2",
                  "--out", "{d}/out-unread-grid"],
                 ["controller.ki = [1.0, 2.0]: not read", "or vary another key"],
                 id="issue28-grid-axis-unread"),
    pytest.param(["sweep", "map-alpha-dR-standard", "--grid", "plant.dR=1,2", "--set",
                  "sweep.grid=['plant.dR=3,4']", "--out", "{d}/out-two-grids"],
                 ["sweep.grid", "--grid replaces it"], id="issue28-grid-twice"),
    pytest.param([*T, "--param", "controller.ki=0:1"],
                 ["controller.ki = [0.0, 1.0]: not read with controller.law = \"i-P\""],
                 id="issue28-tune-unread-key"),
    pytest.param([*T, "--param", "controller.kp=1:2", "--set", "controller.kd=1"],
                 ["controller.kd = 1.0: not read with controller.law = \"i-P\""],
                 id="issue28-tune-set-unread"),
    pytest.param(["compare", "motor-noise-pid", "motor-noise-ipi", "--set",
                  "controller.window=20", "--out", "{d}/out-unread-compare"],
                 ["controller.window = 20: not read by any case compared"],
                 id="issue28-compare-unread-by-all"),
    pytest.param(["export-c", "motor-noise-pid", "--set", "controller.alpha=5", "--out",
                  "{d}/out-unread-c"],
                 ['controller.alpha = 5.0: not read with controller.law = "pid"'],
                 id="issue28-export-c-unread"),
    pytest.param(["tuner", CASE, "--no-browser", "--set", "controller.ki=1"],
                 ['controller.ki = 1.0: not read with controller.law = "ip"'],
                 id="issue28-tuner-unread"),
    pytest.param(["benchmark", "--plants", "{d}/bench-unread.toml", "--out",
                  "{d}/out-unread-bench"],
                 ["controller.rate_sign = 'minus': not read by this run (sign of the rate "
                  "term"],
                 id="issue28-benchmark-unread"),
]
ERRORS += ISSUE_28

#: issue 30: the analysis's flags
ERRORS += [
    pytest.param(["analyze", "power-variational", "--gamma", "-1", "--out", "{d}/out-an"],
                 ["--gamma = '-1': must be a finite number > 0"], id="analyze-negative-gamma"),
    pytest.param(["analyze", "bench-lag3", "--gamma", "2", "--out", "{d}/out-an"],
                 ["--gamma = '2': a PID has no gain gamma"], id="analyze-gamma-of-a-pid"),
    pytest.param(["analyze", "boost-ipd", "--at", "nan", "--out", "{d}/out-an"],
                 ["--at = 'nan': must be a finite number"], id="analyze-at-nan"),
    pytest.param(["analyze", "bench-lag3", "--at", "2", "--out", "{d}/out-an"],
                 ["--at = '2': the plant is linear, so there is no operating point to "
                  "choose"], id="analyze-at-on-a-linear-plant"),
    pytest.param(["analyze", "bench-lag3", "--set", "controller.alpha=3", "--out",
                  "{d}/out-an"],
                 ['controller.alpha = 3.0: not read with controller.law = "pid"'],
                 id="analyze-unread-key"),
    pytest.param(["analyze", "bench-lag3", "--region", "controller.kp=1,2,3", "--out",
                  "{d}/out-an"],
                 ["--region = 'controller.kp': give two axes"], id="analyze-one-axis"),
    pytest.param(["tune", "bench-lag3", "--param", "controller.kp=0.1:3", "--constraint",
                  "Ms=1.6", "--out", "{d}/out-tune-c"],
                 ["--constraint = 'Ms=1.6': must be KEY<=VALUE or KEY>=VALUE"],
                 id="tune-constraint-without-a-bound"),
]


#: the subset also run as the real command: at least one of every category, and the
#: regressions
CORE = {
    "unknown-case", "missing-file", "run-unknown-case", "unknown-key", "unknown-key-in-file",
    "malformed-number", "bad-fidelity", "set-without-equals", "sim.h=0", "plant.L=-1",
    "plant.C=0", "plant.R=-5", "controller.alpha=0", "sim.t_end=-1", "run-zero-h",
    "t_end-not-whole-steps", "nan-kp", "inf-E", "nan-in-list", "file-nan", "file-inf",
    "run-file-nan", "toml-unclosed-table", "run-malformed-toml", "show-without-case",
    "reproduce-bad-fidelity", "huge-integer", "t_end-over-h-overflows", "sweep-over-sim.h",
    "unknown-key-names-its-value", "export-c-float-window", "recorded-run-too-long",
    "case-name-with-path", "tuner-unknown-case", "tuner-bad-set", "issue28-ki-on-an-i-P",
    "issue28-amplitude-without-a-disturbance", "issue28-window-with-backward-differences",
}
CORE_ERRORS = [p for p in ERRORS if p.id in CORE]
assert len(CORE_ERRORS) == len(CORE)


def _argv(args: list[str], d: Path) -> tuple[str, ...]:
    return tuple(a.replace("{d}", str(d)) for a in args)


@pytest.fixture(scope="module")
def case_dir(tmp_path_factory) -> Path:
    """A fresh folder holding FILES; the commands run with it as working directory."""
    d = tmp_path_factory.mktemp("cli-errors")
    for name, text in FILES.items():
        (d / name).write_bytes(text)
    return d


@pytest.fixture(scope="module")
def error_runs(case_dir) -> dict[tuple[str, ...], subprocess.CompletedProcess]:
    """Run every command of CORE_ERRORS once as a subprocess, a few at a time."""
    commands = sorted({_argv(p.values[0], case_dir) for p in CORE_ERRORS})
    with ThreadPoolExecutor(max_workers=max(2, min(8, (os.cpu_count() or 2) * 2))) as pool:
        procs = pool.map(lambda c: cli(*c, cwd=case_dir), commands)
        return dict(zip(commands, procs, strict=True))


@pytest.mark.parametrize(("args", "needles"), CORE_ERRORS)
def test_bad_input_is_one_line_exit_2(error_runs, case_dir, args, needles):
    assert_usage_error(error_runs[_argv(args, case_dir)], *needles)


@pytest.mark.parametrize(("args", "needles"), ERRORS)
def test_bad_input_is_one_line_exit_2_in_process(case_dir, monkeypatch, capsys, args, needles):
    """The same contract through ``mfcontrol.cli.main``: an exception escaping ``main``
    (which would be a traceback) fails the test."""
    monkeypatch.chdir(case_dir)
    argv = list(_argv(args, case_dir))
    try:
        rc = main(argv)
    except SystemExit as exc:  # argparse errors exit from inside parse_args
        rc = exc.code
    out, err = capsys.readouterr()
    assert_usage_error(subprocess.CompletedProcess(argv, rc, out, err), *needles)


def test_run_rejects_bad_input_before_writing_anything(error_runs, case_dir):
    # the run-* commands above named these output folders; none may have been created
    assert error_runs
    for name in ("out-unknown", "out-zero-h", "out-nan", "out-sweep-h", "out-long"):
        assert not (case_dir / name).exists()
    assert not (case_dir / "results").exists()


def test_unknown_case_message_lists_every_builtin_case(error_runs, case_dir):
    line = assert_usage_error(error_runs[_argv([S, "nope"], case_dir)])
    for name in ALL_CASES:
        assert name in line


# ---------------------------------------------------------------------------------------
# happy paths
# ---------------------------------------------------------------------------------------


def test_tuner_without_the_ui_extra_is_one_line(monkeypatch, capsys):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "bokeh" else real(name, *a))
    rc = main(["tuner", "voltage-stable-standard", "--no-browser"])
    out, err = capsys.readouterr()
    line = assert_usage_error(subprocess.CompletedProcess([], rc, out, err))
    assert line.endswith("needs the ui extra: pip install 'mfcontrol[ui]'")


def test_version():
    proc = cli("--version")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == f"mfcontrol {mfcontrol.__version__}"
    assert proc.stderr == ""


def test_cases_lists_every_builtin_case():
    proc = subprocess.run([sys.executable, "-m", "mfcontrol.cli", "cases"],
                          capture_output=True, text=True, timeout=120,
                          env={**_env(), "COLUMNS": "80"})
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    lines = proc.stdout.splitlines()
    # review (issue 28): lines of up to 293 characters; each description is wrapped to
    # the terminal's width now, indented under its case's name
    assert max(len(line) for line in lines) <= 80
    entries = [line for line in lines if not line.startswith(" ")]
    assert len(entries) == len(ALL_CASES)
    listed = [line.split()[0] for line in entries]
    assert sorted(listed) == sorted(ALL_CASES)
    assert sorted(listed) == sorted(mfcontrol.case_names())
    for line in entries:  # a description follows every name
        assert len(line.split(maxsplit=1)) == 2


def _show(*args: str, cwd: Path | None = None) -> tuple[str, dict]:
    proc = cli("show", *args, cwd=cwd)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    return proc.stdout, tomllib.loads(proc.stdout)


def test_show_paper_fidelity_presets():
    _, cfg = _show("voltage-stable-variational", "--set", "fidelity=paper")
    assert cfg["fidelity"] == "paper"
    assert cfg["controller"]["integrator"] == "second-order"
    assert cfg["controller"]["rate_term"] is True
    assert cfg["controller"]["gain"] == "gamma"
    assert cfg["plant"]["coupling"] == "textbook"
    # the rest of the case is still there
    assert cfg["controller"]["law"] == "variational"
    assert cfg["plant"]["dR"] == 1.0


def test_show_published_fidelity_is_the_default():
    _, cfg = _show("voltage-stable-variational")
    assert cfg["fidelity"] == "published"
    assert cfg["controller"]["integrator"] == "first-order"
    assert cfg["controller"]["rate_term"] is False
    assert cfg["controller"]["gain"] == "gamma"
    assert cfg["plant"]["coupling"] == "published"


def test_show_explicit_keys_beat_the_preset():
    _, cfg = _show("voltage-stable-variational", "--set", "fidelity=paper",
                   "--set", "plant.coupling=published", "--set", "controller.rate_term=false")
    assert cfg["plant"]["coupling"] == "published"
    assert cfg["controller"]["rate_term"] is False
    assert cfg["controller"]["integrator"] == "second-order"  # still from the preset


def test_show_set_values_are_parsed_as_toml():
    _, cfg = _show(CASE, "--set", "controller.alpha=5", "--set", "plant.change_times=[1e-3]",
                   "--set", "description=hello world", "--set", "controller.law=variational",
                   "--set", "controller.gain=alpha", "--set", "controller.rate_term=true")
    assert cfg["controller"]["alpha"] == 5.0
    assert isinstance(cfg["controller"]["alpha"], float)
    assert cfg["plant"]["change_times"] == [1e-3]
    assert cfg["description"] == "hello world"
    assert cfg["controller"]["rate_term"] is True


def test_show_output_round_trips_as_a_case_file(tmp_path):
    first, _ = _show("sweep-Gamma", "--set", "fidelity=paper", "--set", "plant.dR=2.5")
    (tmp_path / "x.toml").write_text(first)
    second, cfg = _show("x.toml", cwd=tmp_path)
    assert second == first
    assert cfg["sweep"]["values"] == [5e-10, 5e-9, 5e-8, 5e-7, 5e-6]


def test_show_output_round_trips_with_a_multiline_description(tmp_path):
    (tmp_path / "a.toml").write_text('description = "two\\nlines"\n[controller]\nalpha = 5.0\n')
    first, cfg = _show("a.toml", cwd=tmp_path)
    assert cfg["description"] == "two\nlines"
    (tmp_path / "b.toml").write_text(first)
    second, _ = _show("b.toml", cwd=tmp_path)
    assert second == first


def _read_csv(path: Path) -> tuple[list[str], list[list[str]]]:
    with path.open(newline="") as f:
        header, *rows = list(csv.reader(f))
    return header, rows


def test_run_writes_the_four_files(tmp_path):
    out = tmp_path / "out"
    proc = cli("run", CASE, "--out", str(out), *SHORT, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    assert f"{CASE}: settled = True" in proc.stdout
    assert sorted(p.name for p in out.iterdir()) == [
        "config.toml", "figure.png", "metrics.json", "trajectory.csv"]
    header, rows = _read_csv(out / "trajectory.csv")
    assert header == ["t", "y_ref", "y", "y_meas", "u", "u_plant", "u_raw", "gamma", "gain",
                      "i_L", "v_C"]
    assert len(rows) == 1000
    assert all(len(r) == len(header) for r in rows)
    assert float(rows[0][0]) == 0.0
    assert float(rows[-1][0]) == pytest.approx(0.001 - 1e-6)
    metrics = json.loads((out / "metrics.json").read_text())
    for key in ("iae", "ise", "itae", "max_abs_e", "tv_u", "final_gamma", "settled"):
        assert key in metrics
    assert metrics["settled"] is True
    assert metrics["case"] == CASE
    config = tomllib.loads((out / "config.toml").read_text())
    assert config["sim"]["t_end"] == 0.001
    assert (out / "figure.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not (tmp_path / "results").exists()


def test_analyze_writes_the_json_and_the_figure_and_prints_the_margins(tmp_path, capsys):
    out = tmp_path / "an"
    assert main(["analyze", "voltage-stable-standard", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "Ms (peak |S|): 8.39" in text and "phase margin (deg): 7.259" in text
    assert "note: the output limits [0.001, 0.9]" in text
    data = json.loads((out / "analysis.json").read_text())
    assert data["case"] == "voltage-stable-standard" and data["margins"]["stable"] is True
    assert (out / "analysis.png").stat().st_size > 10_000


def test_analyze_writes_a_region(tmp_path, capsys):
    out = tmp_path / "an"
    assert main(["analyze", "bench-lag3", "--region", "controller.kp=logspace(-1,1,5)",
                 "--region", "controller.ki=logspace(-2,1,4)", "--out", str(out)]) == 0
    assert "region: " in capsys.readouterr().out
    rows = list(csv.DictReader((out / "region.csv").open()))
    assert len(rows) == 20 and {"controller.kp", "controller.ki", "stable"} <= set(rows[0])
    assert (out / "region.png").stat().st_size > 10_000


def test_run_fast_records_its_arithmetic_and_agrees_with_the_exact_run(tmp_path):
    metrics = {}
    for mode in ("exact", "fast"):
        out = tmp_path / mode
        flags = ("--fast",) if mode == "fast" else ()
        proc = cli("run", CASE, "--out", str(out), *SHORT, *flags, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        metrics[mode] = json.loads((out / "metrics.json").read_text())
        assert metrics[mode]["arithmetic"] == mode
    assert metrics["fast"]["iae"] == pytest.approx(metrics["exact"]["iae"], rel=1e-12)
    assert metrics["fast"]["iae"] != metrics["exact"]["iae"]


def test_run_fast_on_a_toolkit_case(tmp_path):
    proc = cli("run", "boost-ipd", "--fast", "--out", str(tmp_path / "out"), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert json.loads((tmp_path / "out" / "metrics.json").read_text())["arithmetic"] == "fast"


def test_run_a_toolkit_case_that_diverges_at_once(tmp_path):
    # issue 10: this ended in KeyError: 'gamma'
    proc = cli("run", "boost-ipd", "--set", "sim.diverge_above=10", "--out",
               str(tmp_path / "out"), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert json.loads((tmp_path / "out" / "metrics.json").read_text())["diverged"] is True


def test_run_user_case_file(tmp_path):
    text = (CASES_DIR / f"{CASE}.toml").read_text()
    assert "alpha = 10.0" in text
    case = tmp_path / "my-case.toml"
    case.write_text(text.replace("alpha = 10.0", "alpha = 5.0"))
    out = tmp_path / "out"
    proc = cli("run", str(case), "--out", str(out), *SHORT, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("my-case: ")
    config = tomllib.loads((out / "config.toml").read_text())
    assert config["controller"]["alpha"] == 5.0
    assert config["sim"]["t_end"] == 0.001
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["case"] == "my-case"
    assert metrics["final_gamma"] == pytest.approx(1 / 5.0)
    _, rows = _read_csv(out / "trajectory.csv")
    assert len(rows) == 1000
    # the config.toml the run wrote is what `show` prints for the same input
    expected, _ = _show(str(case), *SHORT)
    assert (out / "config.toml").read_text() == expected


def test_run_sweep_case_writes_the_gamma_figure(tmp_path):
    out = tmp_path / "out"
    proc = cli("run", "sweep-epsM", "--out", str(out), *SHORT, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in out.iterdir()) == [
        "config.toml", "figure-gamma.png", "figure.png", "metrics.json", "trajectory.csv"]
    assert len(proc.stdout.splitlines()) == 4  # one line per member, then "wrote ..."
    metrics = json.loads((out / "metrics.json").read_text())
    assert [m["controller.eps_M"] for m in metrics["members"]] == [1e-5, 0.1, 1e3]



def test_out_that_is_a_file_is_a_one_line_error(tmp_path):
    (tmp_path / "taken").write_text("x")
    proc = subprocess.run([sys.executable, "-m", "mfcontrol.cli", "run", "power-standard",
                           "--out", str(tmp_path / "taken"), "--set", "sim.t_end=0.001"],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "--out" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_show_checks_every_sweep_member_against_the_cross_key_rules():
    proc = subprocess.run([sys.executable, "-m", "mfcontrol.cli", "show", "sweep-Gamma",
                           "--set", "sweep.key=plant.dR", "--set", "sweep.values=[1.0, -20.0]"],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "plant.dR = -20.0" in proc.stderr


def test_a_reader_that_goes_away_gets_no_traceback():
    # `mfcontrol cases | head -1`: the pipe closes before everything is written
    proc = subprocess.Popen([sys.executable, "-m", "mfcontrol.cli", "cases"], env=_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # before the command (about a second of imports) writes anything
    err = proc.stderr.read().decode()
    proc.wait(timeout=60)
    assert "Traceback" not in err and "BrokenPipeError" not in err


def test_tune_writes_its_four_files_and_beats_the_shipped_gains(tmp_path):
    proc = cli("tune", "first-order-ip-algebraic", "--param", "controller.kp=1:100",
               "--param", "controller.alpha=0.2:5", "--budget", "40", "--set",
               "sim.t_end=1.0", "--out", str(tmp_path / "t"))
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "t" / "summary.json").read_text())
    assert summary["best"] <= summary["start"]["value"]
    assert summary["best"] == summary["nominal"]
    assert "[tune]" in proc.stderr and "best iae" in proc.stdout
    for name in ("best.toml", "history.parquet", "convergence.png"):
        assert (tmp_path / "t" / name).is_file()
    run = cli("run", str(tmp_path / "t" / "best.toml"), "--out", str(tmp_path / "r"))
    assert run.returncode == 0, run.stderr
    m = json.loads((tmp_path / "r" / "metrics.json").read_text())
    assert m["iae"] == summary["best"]


def test_compare_prints_its_table(tmp_path):
    proc = cli("compare", "motor-noise-pid", "motor-noise-ipi-algebraic", "--set",
               "sim.t_end=1.5", "--out", str(tmp_path))
    assert proc.returncode == 0, proc.stderr
    assert "| motor-noise-pid | PI (kp 0.2, ki 0.54) |" in proc.stdout
    assert (tmp_path / "comparison.csv").is_file()


def test_export_c_writes_a_header_and_a_source_that_compile(tmp_path):
    from tests.cexport.harness import CFLAGS, compiler

    proc = cli("export-c", "motor-noise-ipi-algebraic", "--set", "controller.kp=7",
               "--float", "float", "--prefix", "motor", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    folder = tmp_path / "results" / "motor-noise-ipi-algebraic" / "c"
    assert sorted(p.name for p in folder.iterdir()) == ["motor.c", "motor.h"]
    assert "wrote" in proc.stdout and "-ffp-contract=off" in proc.stdout
    header = (folder / "motor.h").read_text()
    assert "typedef float motor_real;" in header
    assert "case motor-noise-ipi-algebraic --set controller.kp=7" in header
    assert "kp = 7.0" in header
    subprocess.run([compiler(), *CFLAGS, "-c", str(folder / "motor.c"), "-o",
                    str(tmp_path / "motor.o")], check=True)


def test_export_c_takes_the_sensor_range(tmp_path):
    proc = cli("export-c", "motor-noise-pid", "--input-limits", "none", "5000", "--out",
               str(tmp_path / "c"))
    assert proc.returncode == 0, proc.stderr
    source = (tmp_path / "c" / "mfc.c").read_text()
    assert "if (!isfinite(y) || !isfinite(setpoint) || y > 5000.0) {" in source
    assert "--input-limits none 5000" in source  # the banner says how it was made


def test_export_c_frozen_and_in_fixed_point(tmp_path):
    """--frozen: no parameter struct nor setter; --real q31: the PID and the i-P family in
    integers, which needs the sensor's range."""
    from tests.cexport.harness import CFLAGS, compiler

    proc = cli("export-c", "motor-noise-pid", "--frozen", "--out", str(tmp_path / "f"))
    assert proc.returncode == 0 and "frozen" in proc.stdout, proc.stderr
    assert "set_params" not in (tmp_path / "f" / "mfc.h").read_text()
    proc = cli("export-c", "motor-noise-pid", "--out", str(tmp_path / "t"))
    assert "tunable with mfc_set_params" in proc.stdout
    assert "int mfc_set_params(mfc_state *s, const mfc_params *p);" in \
        (tmp_path / "t" / "mfc.h").read_text()
    proc = cli("export-c", "motor-noise-pid", "--real", "q31", "--out", str(tmp_path / "q"))
    assert proc.returncode == 2 and "input_limits" in proc.stderr
    assert "Traceback" not in proc.stderr
    proc = cli("export-c", "motor-noise-pid", "--real", "q31", "--input-limits", "-128",
               "128", "--out", str(tmp_path / "q"))
    assert proc.returncode == 0, proc.stderr
    assert "tunable with mfc_set_params" in proc.stdout  # the q31 PID has a setter
    source = tmp_path / "q" / "mfc.c"
    assert "typedef int32_t mfc_q31;" in (tmp_path / "q" / "mfc.h").read_text()
    assert not re.search(r"\b(double|float)\b", source.read_text())  # no floating type
    subprocess.run([compiler(), *CFLAGS, "-c", str(source), "-o", str(tmp_path / "q.o")],
                   check=True)
    # the i-P family with the backward difference too; not with a gain it cannot hold
    proc = cli("export-c", "motor-noise-ipi", "--real", "q31", "--input-limits", "-128",
               "128", "--out", str(tmp_path / "i"))
    assert proc.returncode == 0, proc.stderr
    assert "tunable with mfc_set_params" in proc.stdout
    assert not re.search(r"\b(double|float)\b", (tmp_path / "i" / "mfc.c").read_text())
    proc = cli("export-c", "motor-noise-ipi", "--real", "q31", "--input-limits", "-128",
               "128", "--set", "controller.adapt=variational", "--out", str(tmp_path / "v"))
    assert proc.returncode == 2 and "constant gain only" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr
    # q15: the PID in 16-bit codes; the i-P family is refused in one line
    proc = cli("export-c", "motor-noise-pid", "--real", "q15", "--input-limits", "-128",
               "128", "--out", str(tmp_path / "h"))
    assert proc.returncode == 0 and "q15" in proc.stdout, proc.stderr
    assert "typedef int16_t mfc_q15;" in (tmp_path / "h" / "mfc.h").read_text()
    subprocess.run([compiler(), *CFLAGS, "-c", str(tmp_path / "h" / "mfc.c"), "-o",
                    str(tmp_path / "h.o")], check=True)
    proc = cli("export-c", "motor-noise-ipi", "--real", "q15", "--input-limits", "-128",
               "128", "--out", str(tmp_path / "j"))
    assert proc.returncode == 2 and "real = 'q15': exports the PID only" in proc.stderr
    assert "Traceback" not in proc.stderr and len(proc.stderr.splitlines()) == 1


def test_export_c_of_a_sweep_case_says_it_exports_the_base_setting(tmp_path):
    # review (issue 28): the sweep's base point was exported without a word
    proc = cli("export-c", "sweep-Gamma", "--out", str(tmp_path / "c"))
    assert proc.returncode == 0, proc.stderr
    assert "note: sweep-Gamma sweeps controller.Gamma" in proc.stderr
    assert "controller.Gamma = 5e-08" in proc.stderr
    assert "note" not in cli("export-c", CASE, "--out", str(tmp_path / "d")).stderr


def test_a_change_after_the_run_never_happens(tmp_path):
    """plant.change_times = [1e308] was an OverflowError traceback."""
    proc = cli("run", CASE, "--set", "plant.change_times=[1e308]", "--set", "sim.t_end=1e-4",
               "--out", str(tmp_path / "r"))
    assert proc.returncode == 0, proc.stderr


def test_ctrl_c_while_the_command_loads_numpy_is_one_line(tmp_path):
    """Ctrl-C while numpy/numba load (a command's first 1.6 s) was a traceback from
    `import mfcontrol` (issue 14 item 9): the package now loads them inside the command.
    The signal goes when numpy's core library is in the process's memory map (Linux)."""
    import signal
    import time

    proc = subprocess.Popen([sys.executable, "-m", "mfcontrol.cli", "run",
                             "voltage-stable-standard", "--out", str(tmp_path / "o")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    maps = Path(f"/proc/{proc.pid}/maps")
    deadline = time.time() + 60
    while time.time() < deadline and proc.poll() is None:
        try:
            if "_multiarray_umath" in maps.read_text():
                break
        except OSError:
            break
        time.sleep(0.005)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    if proc.returncode == 0:  # it finished first: nothing to interrupt
        return
    assert proc.returncode == 130 and err.strip() == "mfcontrol: interrupted", err[-2000:]


# --- issue 14 item 8: outputs that cannot be written ------------------------------------

def _last_line(err: str) -> str:
    return err.replace("\r", "\n").strip().splitlines()[-1]


def test_an_output_folder_that_cannot_be_created_is_one_line(tmp_path, capsys):
    rc = main(["run", "voltage-stable-standard", "--set", "sim.t_end=0.001", "--out",
               "/proc/mfcontrol-test"])
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err
    assert _last_line(err) == ("mfcontrol: error: /proc/mfcontrol-test: "
                               "No such file or directory")


def test_a_full_disk_is_one_line_and_leaves_no_temporary_file(tmp_path, monkeypatch, capsys):
    import errno

    import pandas as pd

    def full(self, path, *args, **kwargs):
        Path(path).write_bytes(b"half a chunk")
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(pd.DataFrame, "to_parquet", full)
    out = tmp_path / "s"
    rc = main(["sweep", "voltage-stable-standard", "--grid", "plant.dR=0,5", "--set",
               "sim.t_end=0.002", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 1 and "Traceback" not in err
    assert _last_line(err).startswith(f"mfcontrol: error: {out}")
    assert _last_line(err).endswith(": No space left on device")
    assert not [p for p in out.rglob("*") if p.name.endswith(".tmp")]


def test_map_writes_into_a_folder_it_creates(tmp_path, capsys):
    out = tmp_path / "s"
    assert main(["sweep", "voltage-stable-standard", "--grid", "controller.alpha=1,10",
                 "--grid", "plant.dR=0,5", "--set", "sim.t_end=0.002", "--out", str(out)]) == 0
    png = tmp_path / "new" / "folder" / "map.png"
    assert main(["map", str(out), "--x", "controller.alpha", "--y", "plant.dR", "--out",
                 str(png)]) == 0
    assert png.stat().st_size > 10_000


def test_main_called_in_a_process_leaves_its_garbage_collector_alone(capsys):
    # the command's own process tunes its collector (mfcontrol.cli._own_process); a
    # caller's process (main(argv), as here) keeps its own settings
    import gc

    before = gc.isenabled(), gc.get_threshold(), gc.get_freeze_count()
    assert main(["cases"]) == 0
    assert (gc.isenabled(), gc.get_threshold(), gc.get_freeze_count()) == before


def test_a_noise_level_given_means_gaussian_noise(tmp_path, capsys):
    # issue 28 item 1: --set sensor.noise_std=0.5 gave the nominal IAE, exit 0 and no word,
    # sensor.noise still "none"; a level given means noise
    short = ["--set", "sim.t_end=1.0"]
    assert main(["run", "first-order-ip-algebraic", *short, "--out", str(tmp_path / "a")]) == 0
    assert main(["run", "first-order-ip-algebraic", *short, "--set", "sensor.noise_std=0.5",
                 "--out", str(tmp_path / "b")]) == 0
    capsys.readouterr()
    shown = tomllib.loads((tmp_path / "b" / "config.toml").read_text())
    assert shown["sensor"]["noise"] == "gaussian" and shown["sensor"]["noise_std"] == 0.5
    nominal, noisy = (json.loads((tmp_path / d / "metrics.json").read_text()) for d in "ab")
    assert noisy["tv_u"] > 10 * nominal["tv_u"]
    # the file it wrote runs the same
    assert main(["run", str(tmp_path / "b" / "config.toml"), "--out", str(tmp_path / "c")]) == 0
    again = json.loads((tmp_path / "c" / "metrics.json").read_text())
    assert again["iae"] == noisy["iae"]


def test_a_plant_too_stiff_for_rk45_is_one_line_with_the_time_and_the_step(tmp_path):
    # it used to run for hours, deaf to Ctrl-C (the compiled run never returned)
    proc = cli("run", "first-order-ip-algebraic", "--set", "plant.a=-1e9", "--set",
               "sim.integrator=rk45", "--out", str(tmp_path / "o"))
    line = assert_usage_error(proc, "sim.integrator = 'rk45'", "collapsed to", "at t = ",
                              "too stiff")
    assert "e-09 s" in line
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("value", ["1e-320", "1e300"])
def test_a_time_scale_that_overflows_the_model_names_the_time_scale(value, tmp_path):
    proc = cli("run", "bench-lag3", "--set", f"plant.time_scale={value}", "--out",
               str(tmp_path / "o"))
    assert_usage_error(proc, "plant.time_scale", "not finite")


def test_an_integer_too_long_for_python_is_one_line(tmp_path):
    # past 4,300 digits Python refuses to read an int: it was a traceback
    digits = "1" * 5000
    assert_usage_error(cli("run", "first-order-ip-algebraic", "--set",
                           f"controller.kp={digits}", "--out", str(tmp_path / "o")),
                       "controller.kp", "(5000 characters)", "too long a number")
    case = tmp_path / "big.toml"
    case.write_text(f'base = "first-order-ip-algebraic"\n[controller]\nkp = {digits}\n')
    assert_usage_error(cli("run", str(case), "--out", str(tmp_path / "o")),
                       "too long a number")
    # an integer beyond the float range but short enough to read
    assert_usage_error(cli("run", "first-order-ip-algebraic", "--set",
                           f"controller.kp={'1' * 400}", "--out", str(tmp_path / "o")),
                       "controller.kp = 1111111111", "finite number")


@pytest.mark.parametrize("key,value,allowed", [
    ("controller.kappa", "3", "kappa + mu must be at most 2"),
    ("controller.mu", "-1", "controller.mu = -1"),
    ("controller.kappa", "0.5", "controller.kappa"),
])
def test_a_jacobi_weight_the_kernel_cannot_take_is_one_line(tmp_path, key, value, allowed):
    assert_usage_error(cli("run", "first-order-ip-algebraic", "--set",
                           "controller.kernel=delay-reduced", "--set", f"{key}={value}",
                           "--out", str(tmp_path / "o")), key, value, allowed)


def test_a_dask_transport_we_cannot_use_is_one_line(tmp_path):
    assert_usage_error(cli("sweep", "first-order-ip-algebraic", "--grid",
                           "controller.kp=1,2", "--dask", "ucx://x:1", "--out",
                           str(tmp_path / "d")), "--dask", "tcp://")


def test_a_full_disk_during_run_leaves_no_cut_trajectory(tmp_path, monkeypatch, capsys):
    # the trajectory was left cut mid-row, which pandas reads as a shorter valid run
    import errno

    from mfcontrol.api.results import result

    def full(path, columns):
        Path(path).write_text("y_ref,y\n0.5,0.2")  # half a file, then the disk is full
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(result, "write_csv", full)
    out = tmp_path / "o"
    rc = main(["run", "first-order-ip-algebraic", "--set", "sim.t_end=0.5", "--out",
               str(out)])
    err = capsys.readouterr().err
    assert rc == 1 and _last_line(err).endswith(": No space left on device")
    assert list(out.iterdir()) == []  # nothing half-written, no temporary file


@pytest.mark.parametrize("args", [
    ["run", "first-order-ip-algebraic"],
    ["sweep", "first-order-ip-algebraic", "--grid", "controller.kp=1,2"],
    ["tune", "first-order-ip-algebraic", "--param", "controller.kp=1:10"],
    ["compare", "first-order-ip-algebraic"],
    ["benchmark"],
    ["export-c", "first-order-ip-algebraic"],
    ["reproduce"],
], ids=lambda a: a[0])
def test_an_empty_out_is_one_line_not_the_current_folder(args, tmp_path):
    proc = cli(*args, "--out", "", cwd=tmp_path)
    assert_usage_error(proc, "--out = ''", "must name a folder (it is empty)")
    assert list(tmp_path.iterdir()) == []


def test_map_out_without_a_suffix_says_the_png_it_wrote(tmp_path, capsys):
    out = tmp_path / "s"
    assert main(["sweep", "first-order-ip-algebraic", "--grid", "controller.kp=1,2",
                 "--grid", "controller.alpha=1,2", "--set", "sim.t_end=0.5", "--out",
                 str(out)]) == 0
    capsys.readouterr()
    assert main(["map", str(out), "--x", "controller.kp", "--y", "controller.alpha",
                 "--out", str(tmp_path / "m")]) == 0
    assert capsys.readouterr().out.strip() == f"wrote {tmp_path / 'm.png'}"
    assert (tmp_path / "m.png").stat().st_size > 10_000
    assert main(["map", str(out), "--x", "controller.kp", "--y", "controller.alpha",
                 "--out", ""]) == 2
    assert "--out = '': must name a file (it is empty)" in capsys.readouterr().err


def test_a_budget_beyond_any_search_is_one_line():
    assert_usage_error(cli("tune", "first-order-ip-algebraic", "--param", "controller.kp=1:10",
                           "--budget", "100000000000000000000"),
                       "--budget = 100000000000000000000", "at most 1,000,000")


# --- issue 29, items 6 and 9: small hostile files are refused up front, in one line -------


@pytest.mark.parametrize("table, needles", [
    ("[plant]\nchange_times = [" + ", ".join(["1e-3"] * 1001) + "]\ndR = 1e-3\n",
     ["plant.change_times = [0.001, 0.001", "must list at most 1,000 times (1,001 given)"]),
    ('description = "' + "x" * 10_000_000 + '"\n',
     ["description = 'xxx", "(10000002 characters)", "at most 2,000 characters"]),
    ('[plant]\nmodel = "lti"\nden = [' + ", ".join(["1.0"] * 401) + ']\n[controller]\n'
     'law = "i-P"\n',
     ["plant.den = [1.0, 1.0", "must have degree at most 20 (at most 21 coefficients; "
      "401 given)"]),
], ids=["change-times", "description", "den-degree"])
def test_a_hostile_size_is_one_short_line(table, needles, tmp_path):
    """1,000 change times cost half a minute in the figure, a 10 MB description and a
    degree-400 denominator over two minutes: refused before any work, the value cut."""
    case = tmp_path / "hostile.toml"
    case.write_text(table)
    line = assert_usage_error(cli("run", str(case), "--out", str(tmp_path / "o")), *needles)
    assert len(line) < 400
    assert not (tmp_path / "o").exists()


def test_a_grid_beyond_the_float_range_is_the_only_output(tmp_path):
    """numpy's RuntimeWarning (overflow in power, two lines) printed before the refusal."""
    assert_usage_error(cli("sweep", "first-order-ip-algebraic", "--grid",
                           "controller.kp=logspace(0,400,3)", "--out", str(tmp_path / "s")),
                       "controller.kp = 'logspace(0,400,3)'", "beyond the float range")
