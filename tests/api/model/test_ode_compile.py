"""What of your own ODE compiles when: once per machine for functions defined in a file
(numba's disk cache, under :func:`mfcontrol.plants.ode.identity`), once per process for
the rest, and never again for a new plant object from the same functions.

The subprocess tests run with the test run's numba cache, where the engine's kernels are
compiled once for every test (the ``vectorised_kernels`` fixture): minutes on a cold cache,
which a folder of their own made them pay again. Each writes its plant with the path of
its own folder in f's source, so that the plant's identity, and with it its disk cache
entries, is new to the cache: neither an earlier run nor another test makes them pass."""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import numpy as np
import pytest
from numba.core.ccallback import CFunc

import mfcontrol
from mfcontrol.api.model.plants import ODE
from mfcontrol.numerics import signatures as sig
from mfcontrol.plants import ode

TIMEOUT = 1500  # s: a first process compiles the engine's kernels on a shared, loaded machine

#: a plant module of yours; PLACE is replaced to make each test's functions its own (f's
#: source, a comment, is part of the identity its compiled code is cached under)
PLANT = '''
import os
import numpy as np

GAIN = float(os.environ.get("PLANT_GAIN", "1.0"))


def f(t, x, u, p, dxdt):
    # PLACE
    dxdt[0] = x[1]
    dxdt[1] = GAIN * u - p[0] * x[0] - p[1] * x[1]


def g(x, p):
    return x[0]
'''

#: one process: a single run, a sweep, what its ODE functions loaded from the disk cache
CHILD = '''
import json
import sys

import numpy as np

import mfcontrol
from mfcontrol.engine import compose
from mfcontrol.numerics import signatures as sig

sys.path.insert(0, sys.argv[1])
module = __import__(sys.argv[2])
vectorise = {"yes": True, "auto": None}[sys.argv[3]]
chosen = []
loop_for = compose.loop_for


def spy(*args, **kw):
    chosen.append(loop_for(*args, **kw))
    return chosen[-1]


compose.loop_for = spy
plant = mfcontrol.ODE(module.f, module.g, x0=(0.0, 0.0), params={"k": 4.0, "c": 1.0})
ctrl = mfcontrol.IPI(alpha=2.0, kp=4.0, ki=2.0, sample_time=1e-3)
res = mfcontrol.simulate_loop(plant, ctrl, 1.0, t_end=0.2)
sweep = mfcontrol.sweep(plant, ctrl, 1.0, t_end=0.2, vectorise=vectorise,
                        grid={"plant.k": [2.0, 3.0, 4.0, 5.0], "controller.kp": [1, 2, 3, 4]})
engine = plant.engine()
x, p = np.array([0.5, -0.25]), np.array([4.0, 1.0])
dx = np.empty(2)
module.f(0.0, x, 1.0, p, dx)
functions = (*engine.functions[:2], engine.block.step, engine.block.output)
print(json.dumps({
    "y": res.signals["y"].tolist(), "iae": sweep.table["iae"].tolist(), "chosen": chosen,
    "hits": [fn.cfunc.cache_hits for fn in functions],
    "rhs": sig.call_rhs(engine.functions[0].address, 0.0, x, 1.0, p).tolist(),
    "f": dx.tolist()}))
'''


@pytest.fixture(scope="module")
def cache_dir():
    """numba's cache of this file's subprocesses: the tests' own (NUMBA_CACHE_DIR, or
    None: numba's default places), so that a child loads the engine's kernels that other
    tests compiled (minutes on a cold cache, where a fresh folder made every run compile
    them once more). The plants' functions are never in it before their test: their
    source holds the test's folder (:func:`_write_plant`)."""
    return os.environ.get("NUMBA_CACHE_DIR")


def _write_plant(folder: Path, name: str, place: str, **edits: str) -> None:
    # the test's folder, new to every run, in f's source: an identity no cache holds yet
    text = PLANT.replace("PLACE", f"{place} in {folder.resolve()}")
    for old, new in edits.items():
        text = text.replace(old, new)
    (folder / f"{name}.py").write_text(text)


def _run(folder: Path, name: str, cache_dir: str | None, vectorise: str, **env: str):
    """One process: (its result, numba's cache log lines)."""
    child = folder / "child.py"
    child.write_text(CHILD)
    environ = {**os.environ, "NUMBA_DEBUG_CACHE": "1", **env}
    if cache_dir is not None:
        environ["NUMBA_CACHE_DIR"] = str(cache_dir)
    proc = subprocess.run([sys.executable, str(child), str(folder), name, vectorise],
                          capture_output=True, text=True, env=environ, timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    return json.loads(lines[-1]), [line for line in lines if line.startswith("[cache]")]


def _ode_lines(log: list[str], what: str) -> list[str]:
    """The log's lines of ``what`` ("saved", "loaded") about an ODE's functions."""
    return [line for line in log if f"data {what}" in line
            and ("ode._compile" in line or "blocks._build" in line
                 or "blocks._guard_block" in line)]


@pytest.mark.usefixtures("vectorised_kernels")  # the engine's part cached: the ODE's left
def test_an_ode_from_a_file_compiles_once_per_machine(tmp_path, cache_dir):
    _write_plant(tmp_path, "plant_once", "once")
    first, log = _run(tmp_path, "plant_once", cache_dir, "yes")
    assert first["chosen"] == ["member", "block"]
    assert first["hits"] == [0, 0, 0, 0]
    assert len(_ode_lines(log, "saved")) == 4  # rhs, output, block step, block output
    # a second process: nothing compiles, the ODE's functions and the engine's alike, and
    # the sweep takes the block functions by itself (found in the disk cache)
    second, log = _run(tmp_path, "plant_once", cache_dir, "auto")
    assert not [line for line in log if "data saved" in line], log
    assert len(_ode_lines(log, "loaded")) == 4
    assert second["hits"] == [1, 1, 1, 1]
    assert second["chosen"] == ["member", "block"]
    assert second["y"] == first["y"] and second["iae"] == first["iae"]


@pytest.mark.usefixtures("vectorised_kernels")
@pytest.mark.parametrize("edit", ["source", "constant", "environment"])
def test_an_edited_ode_compiles_anew_and_runs_the_new_code(tmp_path, cache_dir, edit):
    name = f"plant_{edit}"
    _write_plant(tmp_path, name, edit)
    first, _ = _run(tmp_path, name, cache_dir, "yes")
    env = {}
    if edit == "source":  # f itself
        _write_plant(tmp_path, name, edit, **{"- p[1] * x[1]": "- 2.0 * p[1] * x[1]"})
    elif edit == "constant":  # a global f reads, in its file
        _write_plant(tmp_path, name, edit, **{'"1.0"))': '"1.0")) * 3.0'})
    else:  # the same file, a global computed at import that differs from process to process
        env["PLANT_GAIN"] = "3.0"
    second, log = _run(tmp_path, name, cache_dir, "yes", **env)
    assert second["hits"] == [0, 0, 0, 0]
    assert len(_ode_lines(log, "saved")) == 4
    assert second["rhs"] == second["f"] != first["f"]  # the compiled rhs is the new f
    assert second["y"] != first["y"]
    assert second["iae"] != first["iae"]


# --- one process --------------------------------------------------------------------------


def _spring(t, x, u, p, dxdt):
    dxdt[0] = x[1]
    dxdt[1] = u - p[0] * x[0] - p[1] * x[1]


def _position(x, p):
    return x[0]


def _damped(c):
    def f(t, x, u, p):
        return np.array([x[1], u - p[0] * x[0] - c * x[1]])
    return f


def _compiles(monkeypatch) -> list[str]:
    """The C callables of ODEs numba compiles or loads from here on, by name."""
    names: list[str] = []
    compile_ = CFunc.compile

    def counted(self):
        if "_compile.<locals>" in self.__qualname__ or "_build.<locals>" in self.__qualname__:
            names.append(self.__qualname__)
        return compile_(self)

    monkeypatch.setattr(CFunc, "compile", counted)
    return names


def test_a_second_ode_object_from_the_same_functions_compiles_nothing(monkeypatch):
    first = ODE(_spring, _position, (1.0, 0.0), {"k": 4.0, "c": 0.5}).engine()
    for fn in (*first.functions, first.block.step, first.block.output):
        assert fn.address
    names = _compiles(monkeypatch)
    # other initial state and parameter values, a jit function of the same f: the same
    # compiled functions
    for f in (_spring, numba.njit(_spring)):
        second = ODE(f, _position, (0.0, 2.0), {"k": 1.0, "c": 0.1}).engine()
        assert second.functions == first.functions
        assert second.block is first.block and second.block.cheap
        for fn in (*second.functions, second.block.step, second.block.output):
            assert fn.address
    assert names == []
    # other sizes: new block functions, the same single-run ones
    third = ODE(_spring, _position, (1.0, 0.0), {"k": 4.0, "c": 0.5, "unused": 0.0}).engine()
    assert third.functions == first.functions and third.block is not first.block
    assert names == []


def test_closures_compile_per_value_and_once_per_process(monkeypatch):
    names = _compiles(monkeypatch)
    results = {}
    for c in (0.5, 2.0, 0.5):
        plant = ODE(_damped(c), _position, (1.0, 0.0), {"k": 4.0})
        ctrl = mfcontrol.IPI(alpha=2.0, kp=4.0, ki=2.0, sample_time=1e-3)
        res = mfcontrol.simulate_loop(plant, ctrl, 0.0, t_end=0.05)
        results.setdefault(c, []).append(res.signals["y"])
        assert ode.identity(plant._f, _position)[1] is False  # closures: not on disk
    assert len(names) == 4  # rhs and output of each value, once
    assert not np.array_equal(results[0.5][0], results[2.0][0])
    np.testing.assert_array_equal(results[0.5][0], results[0.5][1])


def test_a_global_changed_in_the_process_compiles_anew(tmp_path, monkeypatch):
    _write_plant(tmp_path, "plant_global", "global")
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module("plant_global")
    x, p = np.array([0.5, -0.25]), np.array([4.0, 1.0])
    rhs = []
    for gain in (1.0, 3.0):
        monkeypatch.setattr(module, "GAIN", gain)
        functions = ODE(module.f, module.g, (0.0, 0.0), {"k": 4.0, "c": 1.0}).engine().functions
        rhs.append(sig.call_rhs(functions[0].address, 0.0, x, 1.0, p))
    assert rhs[1][1] - rhs[0][1] == pytest.approx(2.0)


# --- the identity ---------------------------------------------------------------------------


def test_the_identity_follows_what_numba_compiles(tmp_path, monkeypatch):
    (tmp_path / "ident_helpers.py").write_text(textwrap.dedent('''
        import numba
        SCALE = 2.0

        @numba.njit
        def scaled(v):
            return SCALE * v
    '''))
    (tmp_path / "ident_plant.py").write_text(textwrap.dedent('''
        import math
        import numpy as np
        import ident_helpers
        from ident_helpers import scaled
        NAMES = {"a", "b", "c"}

        def f(t, x, u, p):
            return np.array([scaled(x[0]) + ident_helpers.SCALE * math.sin(u)])

        def g(x, p):
            return x[0]
    '''))
    monkeypatch.syspath_prepend(str(tmp_path))
    helpers = importlib.import_module("ident_helpers")
    plant = importlib.import_module("ident_plant")
    digest, on_disk = ode.identity(plant.f, plant.g)
    assert on_disk and ode.identity(plant.f, plant.g) == (digest, True)
    assert ode.identity(numba.njit(plant.f), plant.g) == (digest, True)
    # a helper in another file, edited: a new identity
    (tmp_path / "ident_helpers.py").write_text(
        (tmp_path / "ident_helpers.py").read_text().replace("SCALE * v", "SCALE * v + 1.0"))
    importlib.reload(helpers)
    plant = importlib.reload(plant)
    edited = ode.identity(plant.f, plant.g)[0]
    assert edited != digest
    # a module's constant read through the module
    monkeypatch.setattr(helpers, "SCALE", 3.0)
    assert ode.identity(plant.f, plant.g)[0] not in (digest, edited)


def test_functions_without_a_file_or_closing_over_values_are_kept_in_the_process():
    namespace = {"np": np}
    exec("def f(t, x, u, p):\n    return np.array([-x[0] + u])\n", namespace)
    digest, on_disk = ode.identity(namespace["f"], _position)
    assert not on_disk
    assert ode.identity(_damped(1.0), _position)[1] is False
    assert ode.identity(_damped(1.0), _position) != ode.identity(_damped(2.0), _position)
    assert ode.identity(_spring, lambda x, p: x[0])[1] is True  # a lambda in a file

    class Opaque:
        pass

    thing = Opaque()

    def reads_an_object(t, x, u, p):
        return np.array([thing is None])

    assert ode.identity(reads_an_object, _position) is None  # no description: per object


def test_functions_of_a_module_gone_from_sys_modules_are_kept_in_the_process(tmp_path):
    # review: runpy.run_path's module (examples run by the tests) is gone once it returns;
    # numba then names it "<dynamic>" in the compiled code's environment, and a later
    # process that loaded the entry kept on disk failed ("No module named '<dynamic>'")
    import runpy

    path = tmp_path / "gone_plant.py"
    path.write_text("import numpy as np\n\n\ndef f(t, x, u, p):\n"
                    "    return np.array([-x[0] + u])\n")
    ns = runpy.run_path(str(path), run_name="gone_plant_module")
    assert "gone_plant_module" not in sys.modules
    assert ode.identity(ns["f"], _position)[1] is False


def test_the_identity_is_the_same_in_every_process(tmp_path, monkeypatch):
    # sets iterate in an order that varies with the process (string hashes)
    (tmp_path / "ident_same.py").write_text(textwrap.dedent('''
        import numpy as np
        NAMES = {"a", "b", "c", "d"}
        TABLE = np.linspace(0.0, 1.0, 5)

        def f(t, x, u, p):
            return np.array([-x[0] + u * TABLE[2] * ("b" in NAMES)])

        def g(x, p):
            return x[0]
    '''))
    code = ("import sys; sys.path.insert(0, sys.argv[1]); import ident_same as m; "
            "from mfcontrol.plants import ode; print(ode.identity(m.f, m.g)[0])")
    digests = {subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True,
                              text=True, check=True, timeout=TIMEOUT,
                              env={**os.environ, "PYTHONHASHSEED": seed}).stdout.strip()
               for seed in ("1", "2", "3")}
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module("ident_same")
    assert digests == {ode.identity(module.f, module.g)[0]}
