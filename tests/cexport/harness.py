"""Compile an exported controller and drive it with the same operations as the Python one.

An operation is a row ``(op, a, b)``: op 0 steps with y = a and setpoint = b, op 1 switches
to manual with output a, op 2 back to automatic, op 3 sets the parameters (``set_params``)
to the values in the rows that follow, three a row (:func:`set_params_rows`). The binary
reads the rows from stdin as doubles and writes, as doubles, the output of every step and
the return code of every op 3, and finally the nan_count; given a file name, it writes its
final state's memory there (as doubles).
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from mfcontrol.cexport import CFLAGS as EXPORT_FLAGS

#: the flags the export recommends, with every warning a firmware build turns on an error
CFLAGS = [*EXPORT_FLAGS, "-Wall", "-Wextra", "-Werror", "-pedantic", "-Wconversion",
          "-Wdouble-promotion", "-Wshadow"]
STEP, MANUAL, AUTO, SET_PARAMS = 0.0, 1.0, 2.0, 3.0

_MAIN = r"""
#include <stdio.h>
#include "@P@.h"

int main(int argc, char **argv)
{
    static @P@_state s;
    double row[3];
    long i;
    @P@_init(&s);
    while (fread(row, sizeof row, 1, stdin) == 1) {
        if (row[0] == 0.0) {
            double u = (double)@P@_step(&s, (@P@_real)row[1], (@P@_real)row[2]);
            fwrite(&u, sizeof u, 1, stdout);
        } else if (row[0] == 1.0) {
            @P@_set_manual(&s, (@P@_real)row[1]);
        } else if (row[0] == 3.0) {
@SET@        } else {
            @P@_set_auto(&s);
        }
    }
    {
        double count = (double)s.nan_count;
        fwrite(&count, sizeof count, 1, stdout);
    }
    if (argc > 1) {
        FILE *f = fopen(argv[1], "wb");
        if (f == NULL) return 1;
        for (i = 0; i < @PU@_N_STATE; i++) {
            double v = (double)s.cs.row[i];
            fwrite(&v, sizeof v, 1, f);
        }
        fclose(f);
    }
    return 0;
}
"""


def _set_params_c(src) -> str:
    """main's op 3: read the members' values, three a row, then call set_params."""
    if not src.fields:
        return "            return 2; /* a frozen export has no setter */\n"
    n_rows = -(-len(src.fields) // 3)
    sets = "".join(f"            p.{name} = (@P@_real)v[{i}];\n"
                   for i, name in enumerate(src.fields))
    return ("            @P@_params p;\n"
            f"            double v[{3 * n_rows}], rc;\n"
            f"            if (fread(v, sizeof v, 1, stdin) != 1) return 3;\n{sets}"
            "            rc = (double)@P@_set_params(&s, &p);\n"
            "            fwrite(&rc, sizeof rc, 1, stdout);\n")


def set_params_rows(src, values: dict[str, float], index: int) -> np.ndarray:
    """The rows of an op 3 that sets the export's parameters to ``values`` (every member
    of ``src.fields``); ``index`` (its row's a) names it for :func:`run_python`."""
    v = [values[name] for name in src.fields]
    v += [0.0] * (-len(v) % 3)
    return np.vstack([[SET_PARAMS, index, 0.0], np.reshape(v, (-1, 3))])


def compiler() -> str:
    """The system C compiler; CI sets MFCONTROL_REQUIRE_CC=1 so that its absence fails."""
    cc = shutil.which(os.environ.get("CC", "cc"))
    if cc is None:
        if os.environ.get("MFCONTROL_REQUIRE_CC"):
            pytest.fail("no C compiler (cc) on this machine")
        pytest.skip("no C compiler (cc) on this machine")
    return cc


def build(src, folder: Path, *, shared: bool = False, flags: tuple[str, ...] = ()) -> Path:
    """Write the files, compile them (with the harness's main, or as a shared library),
    with ``flags`` after the harness's."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{src.prefix}.h").write_text(src.header)
    (folder / f"{src.prefix}.c").write_text(src.source)
    files = [str(folder / f"{src.prefix}.c")]
    if shared:
        out = folder / f"lib{src.prefix}.so"
        extra = ["-shared", "-fPIC"]
    else:
        (folder / "main.c").write_text(_MAIN.replace("@SET@", _set_params_c(src))
                                       .replace("@P@", src.prefix)
                                       .replace("@PU@", src.prefix.upper()))
        files.append(str(folder / "main.c"))
        out = folder / src.prefix
        extra = []
    done = subprocess.run([compiler(), *CFLAGS, *flags, *extra, "-I", str(folder), *files,
                           "-o", str(out), "-lm"], capture_output=True, text=True, timeout=600)
    if done.returncode:
        raise AssertionError(f"the export does not compile:\n{done.stderr[:4000]}")
    return out


def run_binary(exe: Path, ops: np.ndarray, state: Path | None = None
               ) -> tuple[np.ndarray, int]:
    """The outputs of every step and the final nan_count (the final memory in ``state``
    when given). A sanitizer's report fails the run."""
    done = subprocess.run([str(exe), *([str(state)] if state else [])],
                          input=np.ascontiguousarray(ops, float).tobytes(),
                          capture_output=True, timeout=600)
    if done.returncode or done.stderr:
        raise AssertionError(f"{exe.name} exited with {done.returncode}: "
                             f"{done.stderr.decode(errors='replace')[:2000]}")
    out = np.frombuffer(done.stdout, dtype=float)
    return out[:-1], int(out[-1])


def run_python(ctrl, ops: np.ndarray, retunes=()) -> tuple[np.ndarray, int]:
    """The same operations on the live Python controller. Where the live controller
    refuses a value with an exception (a non-finite setpoint or manual output), the C,
    which cannot raise, rejects and counts it: the Python side does what the C does (a
    rejected sample, a manual mode that keeps the last output) and counts it too.
    An op 3 is ``ctrl.retune(**changes)`` with ``(changes, code) = retunes[a]``: code 0 is
    taken (what the C returns), another is the C's code for a set the Python refuses."""
    out, refused = [], 0
    rows = iter(ops)
    for op, a, b in rows:
        if op == SET_PARAMS:
            changes, code = retunes[int(a)]
            for _ in range(-(-len(ctrl._LAW.tunable(ctrl._CP[:, 0])) // 3)):
                next(rows)  # the C's values
            if code == 0:
                ctrl.retune(**changes)
            else:
                with pytest.raises(ValueError):
                    ctrl.retune(**changes)
            out.append(float(code))
        elif op == STEP:
            if np.isfinite(b):
                out.append(ctrl(float(a), setpoint=float(b)))
            else:  # a rejected sample, as a NaN measurement is
                out.append(ctrl(np.nan))
        elif op == MANUAL:
            if np.isfinite(a):
                ctrl.set_auto_mode(False, last_output=float(a))
            else:
                ctrl.set_auto_mode(False)
                refused += 1
        else:
            ctrl.set_auto_mode(True)
    return np.array(out, dtype=float), ctrl.nan_count + refused


def steps(y, r) -> np.ndarray:
    return np.column_stack([np.full(len(y), STEP), y, r])
