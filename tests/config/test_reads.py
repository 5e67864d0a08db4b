"""No option is dropped in silence (issue 28, item 1): a key set that the run will not read
is an error that says why and what to set, and a key it accepts changes the run.

The walk below sets every option of the table, one at a time and to values its own check
allows, on a short run of every plant under every law and of every choice of the loop's
elements, estimators, adaptations, references, integrators and fidelities; each setting
is either refused by :func:`mfcontrol.experiments.cases.check_reads` with one line naming
the key (and then changes nothing) or accepted (and then some value of it changes the
run's trajectory or metrics). :func:`walk` returns what breaks that; a test shows it
catches a key read but unused, as the paper's law read gamma0 without adapting.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import pytest

import mfcontrol
from mfcontrol import ConfigError, resolve
from mfcontrol.config.options import BY_KEY, OPTIONS, PLANT_PARAMETERS
from mfcontrol.experiments.cases import CASES_DIR, check_reads

# ---------------------------------------------------------------------------------------
# the contexts: every plant under every law, then every other choice on a few of them,
# each a short run in which every option that is read acts (events inside the horizon,
# output limits reached, gains nonzero)
# ---------------------------------------------------------------------------------------

#: each plant's run: 600 samples, a reference that moves, limits the control reaches
PLANTS: dict[str, dict[str, Any]] = {
    "buck": {"plant.model": "buck", "sim.h": 1e-6, "sim.t_end": 6e-4,
             "reference.slope": 1e4, "reference.level": 2.5, "reference.t_ramp2": 4e-4,
             "reference.slope2": 1e3, "plant.change_times": [2e-4, 3e-4],
             "metrics.settle_time": 1e-4},
    "boost": {"plant.model": "boost", "sim.h": 1e-5, "sim.t_end": 6e-3, "plant.i0": 2.0,
              "plant.v0": 20.0, "reference.kind": "smooth-step", "reference.initial": 20.0,
              "reference.final": 24.0, "reference.t0": 1e-3, "reference.duration": 1e-3,
              "plant.change_times": [3e-3], "metrics.settle_time": 1e-3},
    "first-order": {"plant.model": "first-order", "sim.h": 1e-3, "sim.t_end": 0.6,
                    "reference.kind": "smooth-step", "reference.t0": 0.05,
                    "reference.duration": 0.1, "metrics.settle_time": 0.1,
                    "plant.schedule": [{"t": 0.3, "name": "w", "set": 0.5}]},
    "dc-motor": {"plant.model": "dc-motor", "sim.h": 1e-3, "sim.t_end": 0.6,
                 "reference.kind": "smooth-step", "reference.final": 60.0,
                 "reference.t0": 0.05, "reference.duration": 0.1,
                 "metrics.settle_time": 0.1,
                 "plant.schedule": [{"t": 0.3, "name": "load", "set": 0.05}]},
    "lti": {"plant.model": "lti", "plant.den": [1.0, 2.0, 1.0], "sim.h": 0.02,
            "sim.t_end": 12.0, "reference.kind": "smooth-step", "reference.t0": 1.0,
            "reference.duration": 1.0, "metrics.settle_time": 1.0},
}

#: each law's gains and limits (per plant where the scale differs): limits the control
#: reaches, so that the anti-windup's options act
_POSITIONAL = {"controller.kp": 20.0, "controller.ki": 5.0, "controller.kd": 0.5}
LAWS: dict[str, dict[str, dict[str, Any]]] = {
    "ip": {"buck": {"controller.alpha": 10.0}, "boost": {"controller.alpha": 1e3,
                                                          "controller.output_gain": 1e-3}},
    "variational": {"buck": {}, "boost": {"controller.gamma0": 1e-3,
                                          "controller.output_gain": 1e-3}},
    "i-P": {"buck": {"controller.alpha": 5e4, "controller.kp": 3e3},
            "boost": {"controller.alpha": 1e7, "controller.kp": 1e3},
            "first-order": {"controller.alpha": 1.0, "controller.kp": 5.0},
            "dc-motor": {"controller.alpha": 50.0, "controller.kp": 20.0},
            "lti": {"controller.alpha": 1.0, "controller.kp": 2.0}},
    "pid": {"buck": {"controller.kp": 0.02, "controller.ki": 100.0, "controller.kd": 1e-6},
            "boost": {"controller.kp": 0.002, "controller.ki": 5.0, "controller.kd": 1e-7},
            "first-order": {"controller.kp": 2.0, "controller.ki": 3.0, "controller.kd": 0.1},
            "dc-motor": {"controller.kp": 0.2, "controller.ki": 0.54, "controller.kd": 0.01},
            "lti": {"controller.kp": 1.0, "controller.ki": 0.5, "controller.kd": 0.3}},
}
#: limits the control reaches on each plant
LIMITS = {"buck": (0.0, 0.6), "boost": (0.0, 0.5), "first-order": (-1.5, 1.5),
          "dc-motor": (-6.0, 6.0), "lti": (-1.0, 1.2)}
#: the PID's, lower (its output stays smaller on the converters and the lti plant)
LIMITS_PID = {**LIMITS, "buck": (0.0, 0.06), "boost": (0.0, 0.05), "lti": (-1.0, 0.9)}


def context(plant: str, law: str, **more: Any) -> dict[str, Any]:
    """A case: the plant's run, the law with its gains, limits, and ``more`` (dotted keys
    written with __ for the dot: ``sensor__noise="gaussian"``)."""
    out = {**PLANTS[plant], "controller.law": law}
    if law in ("ip", "variational"):
        out.update(LAWS[law][plant])
    elif law == "pid":
        out.update(LAWS["pid"][plant])
    else:
        out.update(LAWS["i-P"][plant])
        out.update({k: v * {"buck": 30.0, "boost": 100.0}.get(plant, 1.0)
                    for k, v in _POSITIONAL.items()
                    if k == "controller.ki" and law in ("i-PI", "i-PID")
                    or k == "controller.kd" and law in ("i-PD", "i-PID")})
    if law not in ("ip", "variational"):
        out["controller.duty_min"], out["controller.duty_max"] = (
            LIMITS_PID if law == "pid" else LIMITS)[plant]
    out.update({k.replace("__", "."): v for k, v in more.items()})
    return out


BASES = [(plant, law) for plant in PLANTS
         for law in ("ip", "variational", "i-P", "i-PI", "i-PD", "i-PID", "pid")
         if law not in ("ip", "variational") or plant in ("buck", "boost")]
#: every other choice of the table, on a positional law and on the paper's law
CHOICES: list[tuple[str, str, dict[str, Any]]] = [
    # the reference moving from the start: the estimator's start-up acts
    ("dc-motor", "i-PID", {"controller__estimator": "algebraic", "controller__window": 10,
                           "reference__t0": 0.0}),
    ("dc-motor", "i-PI", {"controller__order": 2}),
    ("dc-motor", "i-PI", {"controller__adapt": "variational", "controller__gamma0": 0.02,
                          "controller__Gamma": 1e-6, "controller__alpha": None}),
    ("dc-motor", "i-PI", {"controller__anti_windup": "back-calculation"}),
    ("dc-motor", "i-PI", {"controller__anti_windup": "none"}),
    ("buck", "ip", {"controller__anti_windup": "clamp"}),
    ("buck", "variational", {"controller__anti_windup": "back-calculation"}),
    ("buck", "variational", {"fidelity": "paper"}),
    ("buck", "variational", {"controller__rate_term": True, "controller__k_gamma": 1e-3}),
    ("buck", "variational", {"controller__gain": "alpha"}),
    ("buck", "ip", {"plant__output": "power", "reference__slope": 1e3,
                    "reference__level": 0.25, "reference__t_ramp2": None,
                    "reference__slope2": None, "controller__alpha": 3.0}),
    ("buck", "i-PI", {"reference__kind": "smooth-step", "reference__final": 2.5,
                      "reference__t0": 5e-5, "reference__duration": 1e-4,
                      "reference__slope": None, "reference__level": None,
                      "reference__t_ramp2": None, "reference__slope2": None}),
    ("dc-motor", "i-PI", {"sensor__noise": "gaussian", "sensor__noise_std": 0.5}),
    ("dc-motor", "i-PI", {"sensor__noise": "uniform", "sensor__noise_std": 0.5}),
    ("lti", "pid", {"sensor__quantum": 0.01, "sensor__delay": 2, "actuator__delay": 3,
                    "actuator__rate_limit": 5.0, "sim__substeps": 2}),
    ("dc-motor", "i-PI", {"disturbance__kind": "step", "disturbance__amplitude": -3.0,
                          "disturbance__t0": 0.3}),
    ("dc-motor", "i-PI", {"disturbance__kind": "ramp", "disturbance__amplitude": -5.0,
                          "disturbance__t0": 0.3, "disturbance__at": "output"}),
    ("dc-motor", "i-PI", {"disturbance__kind": "sine", "disturbance__amplitude": 2.0,
                          "disturbance__frequency": 5.0, "disturbance__t0": 0.2}),
    ("dc-motor", "i-PI", {"disturbance__kind": "table", "disturbance__times": [0.2, 0.4],
                          "disturbance__values": [1.0, -2.0]}),
    ("lti", "i-PI", {"sim__integrator": "exact"}),
    ("first-order", "i-PI", {"sim__integrator": "rk45"}),
]
CONTEXTS = [context(p, law) for p, law in BASES] + [context(p, law, **m) for p, law, m in CHOICES]
IDS = [f"{p}-{law}" for p, law in BASES] + [
    f"{p}-{law}-" + "-".join(f"{k.split('__')[-1]}={v}" for k, v in m.items())[:60]
    for p, law, m in CHOICES]

# ---------------------------------------------------------------------------------------
# the values each option is set to: two that its check allows, apart from the present
# ---------------------------------------------------------------------------------------

#: keys the walk leaves to other tests: the case's label and the sweep a run becomes
NOT_WALKED = ("description", "sweep.key", "sweep.values")
#: a scale for options whose default is 0 or none
_SCALE = {"sensor.noise_std": 0.3, "sensor.quantum": 0.05, "actuator.rate_limit": 0.3,
          "disturbance.amplitude": 1.0, "disturbance.frequency": 7.0,
          "controller.k_aw": 3e4, "controller.Tt": 0.05, "reference.slope2": 500.0,
          "plant.load": 0.02, "plant.w": 0.3, "plant.i0": 0.5, "plant.v0": 0.4,
          "plant.y0": 0.2, "controller.ki": 2.0, "controller.kd": 0.05,
          "reference.initial": 0.3, "plant.dR": 2.0, "plant.dC": 1e-6}
#: options set in time (s) or as a share of the horizon
_TIMES = ("reference.t0", "reference.duration", "reference.t_ramp2", "disturbance.t0")


def values_to_try(key: str, cfg) -> list[Any]:
    """Two values of ``key`` other than ``cfg``'s (or its other choices), scaled to the
    run so that an option that is read acts on it."""
    o, v, t_end = BY_KEY[key], cfg[key], cfg["sim.t_end"]
    if o.choices or o.kind == "bool":
        others = [True, False] if o.kind == "bool" else (
            [int(c) for c in o.choices] if o.kind == "int" else list(o.choices))
        return [c for c in others if c != v]
    if key in _TIMES:
        return [0.25 * t_end, 0.55 * t_end]
    if key == "metrics.settle_time":
        return [0.0, 0.01 * t_end, 0.99 * t_end, 2.0 * t_end]
    if key in ("plant.change_times", "disturbance.times"):
        return [[0.3 * t_end] * len(v or [1]), [0.6 * t_end] * len(v or [1])]
    if key == "disturbance.values":
        return [[x + 1.0 for x in v] or [1.0], [x - 2.0 for x in v] or [-2.0]]
    if key == "plant.schedule":
        names = PLANT_PARAMETERS[cfg["plant.model"]]
        return [[{"t": 0.5 * t_end, "name": n, "add" if n in ("w", "load") else "set":
                  (0.3 if n in ("w", "load") else cfg[f"plant.{n}"] * 1.5)}]
                for n in names[:2]]
    if key == "plant.num":
        return [[2.0], [1.0, 1.0]]
    if key == "plant.den":
        return [[1.0, 3.0, 1.0], [1.0, 1.0]]
    if o.kind in ("strs",):  # the benchmark's settings
        return [["controller.kp=1:2"]] if key != "benchmark.objective" else []
    if key == "benchmark.objective":
        return ["iae+tv_u"]
    if o.kind == "int":
        if key == "controller.window":
            return [max(2, v // 2 & ~1), v + 6]
        return [v + 2, v + 5] if key != "sensor.seed" else [v + 7]
    if key == "metrics.settled_tol":
        return [1e-300, 1e300]
    if key == "sim.diverge_above":
        return [1e-9]
    if key == "metrics.final_window":
        return [0.9, 0.05]
    if key in ("controller.duty_min", "controller.duty_max"):  # limits that bite
        lo, hi = cfg["controller.duty_min"], cfg["controller.duty_max"]
        shares = (0.02, 0.4) if key.endswith("max") else (0.6, 0.9)
        return [lo + share * (hi - lo) for share in shares]
    if v is None or v == 0:
        s = _SCALE.get(key, 0.5)
        return [s, 2.0 * s]
    return [v * 1.5, v * 0.6]


# ---------------------------------------------------------------------------------------
# the walk
# ---------------------------------------------------------------------------------------


def _outcome(cfg) -> tuple:
    """Everything a run gives: its trajectory and metrics."""
    r = mfcontrol.simulate(cfg)
    return r.metrics, r.signals, r.states


def _same(a: tuple, b: tuple) -> bool:
    for x, y in zip(a, b, strict=True):
        if x.keys() != y.keys():
            return False
        for k in x:
            p, q = np.asarray(x[k]), np.asarray(y[k])
            if p.shape != q.shape or not np.array_equal(p, q, equal_nan=p.dtype.kind == "f"):
                return False
    return True


def _set(base, key: str, value: Any):
    """``base`` with ``key`` set as ``--set`` sets it, and whether the check accepts it
    (None when the value is refused by the option's own checks). A choice that leaves a
    key of the case unread (the law switched to an i-P leaves ki) is refused naming that
    key: the case is taken without it, as its user would write it."""
    unset: dict[str, None] = {}
    for _ in range(4):
        try:
            cfg = base.with_overrides({key: value, **unset})
        except ConfigError:
            return None, None, None
        try:
            check_reads(cfg, "run", {key: value})
            return cfg, True, None
        except ConfigError as exc:
            if exc.key == key:
                return cfg, False, exc
            unset[exc.key] = None
    return None, None, None


def walk(settings: Mapping[str, Any], keys=None) -> tuple[list[str], dict[str, str]]:
    """Set each option of ``keys`` (all) on the case ``settings``, as ``--set`` would, to
    each value of :func:`values_to_try`: what breaks the rule (a key accepted that changes
    neither the run nor, for a choice, which options the run reads; a key refused that
    changes the run; a refusal that is not one line naming the key), and the refusals."""
    from mfcontrol.api.run.simulate import keys_read_by_run

    base = resolve(settings)
    check_reads(base, "run", case=base)  # the case itself sets only keys its run reads
    before, read = _outcome(base), keys_read_by_run(base)
    problems: list[str] = []
    refused: dict[str, str] = {}
    for o in OPTIONS:
        if o.key in NOT_WALKED or (keys is not None and o.key not in keys):
            continue
        accepted = changed = False
        for value in values_to_try(o.key, base):
            if o.key in refused:  # its refusal's words are checked: now only the outcome
                cfg = base.with_overrides({o.key: value})
                assert o.key not in keys_read_by_run(cfg), o.key
                if not _same(_outcome(cfg), before):
                    problems.append(f"{o.key} = {value!r}: refused, but it changes the run")
                continue
            cfg, ok, exc = _set(base, o.key, value)
            if cfg is None:
                continue  # refused by the option's own checks: not a key dropped
            if not ok:
                msg = str(exc)
                if "\n" in msg or not msg.startswith(f"{o.key} = ") or "not read" not in msg \
                        and "read by mfcontrol" not in msg:
                    problems.append(f"{o.key}: refused with {msg!r}")
                refused[o.key] = msg
                if not _same(_outcome(cfg), before):
                    problems.append(f"{o.key} = {value!r}: refused, but it changes the run")
                continue
            accepted = True
            choice = bool(o.choices) or o.kind == "bool"
            changed = changed or not _same(_outcome(cfg), before) or (
                choice and keys_read_by_run(cfg) != read)
        if accepted and not changed:
            problems.append(f"{o.key}: accepted, but no value of it changes the run")
    return problems, refused


@pytest.mark.parametrize("settings", CONTEXTS, ids=IDS)
def test_every_option_set_is_read_or_refused(settings, record_property):
    problems, refused = walk(settings)
    assert not problems, "\n".join(problems)
    record_property("counts", f"{len(refused)} options refused")


def test_the_walk_catches_a_key_read_but_unused(monkeypatch):
    """The walk fails on a translator that reads a key the law then ignores: the paper's
    standard law read gamma0 (and Gamma, eps_M) though only the variational law uses
    them, so `--set controller.gamma0=...` under it was accepted and changed nothing."""
    from mfcontrol.api import params

    settings = context("buck", "ip")
    problems, refused = walk(settings, keys={"controller.gamma0", "controller.Gamma"})
    assert not problems and refused.keys() == {"controller.gamma0", "controller.Gamma"}
    assert refused["controller.gamma0"] == ('controller.gamma0 = 1.5: not read with '
                                            'controller.law = "ip": set controller.law = '
                                            '"variational", or remove it')
    original = params.recursive_law_column

    def reading_gamma0(cfg, h=None):
        cfg["controller.gamma0"]  # read, not used: as before issue 28
        return original(cfg, h)

    monkeypatch.setattr(params, "recursive_law_column", reading_gamma0)
    problems, _ = walk(settings, keys={"controller.gamma0"})
    assert problems == ["controller.gamma0: accepted, but no value of it changes the run"]


# ---------------------------------------------------------------------------------------
# the commands: which keys each reads, case files and --set
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", mfcontrol.case_names())
def test_every_builtin_case_sets_only_keys_a_command_running_it_reads(case):
    from mfcontrol.experiments.cases import resolve_case

    for command in ("run", "sweep") + (("benchmark",) * case.startswith("bench")):
        resolve_case(case, command=command)


def test_a_case_file_may_hold_the_keys_of_the_commands_that_run_it(tmp_path):
    """The benchmark's cases set an i-P's estimator under a PID: the benchmark reads it
    (it tunes an i-P and an i-PI on the case), so run takes the file; without a
    [benchmark] table nothing reads it. --set is for the command given."""
    from mfcontrol.experiments.cases import resolve_case

    resolve_case("bench-buck", command="run")
    text = (CASES_DIR / "bench-buck.toml").read_text()
    mine = tmp_path / "pid-with-an-estimator.toml"
    mine.write_text(text[:text.index("[benchmark]")])
    with pytest.raises(ConfigError, match='controller.estimator = \'algebraic\': not read with '
                       'controller.law = "pid"'):
        resolve_case(mine, command="run")
    with pytest.raises(ConfigError, match="controller.window = 30: not read"):
        resolve_case("bench-buck", {"controller.window": 30}, command="run")
    resolve_case("bench-buck", {"controller.window": 30, "controller.law": "i-PI"},
                 command="run")
    # the Python entry points check as the command line does
    with pytest.raises(ConfigError, match="controller.ki = 3.0: not read"):
        mfcontrol.run_case("first-order-ip-algebraic", {"controller.ki": 3.0})
    with pytest.raises(ConfigError, match="controller.alpha = 5.0: not read"):
        mfcontrol.make_controller("motor-noise-pid", {"controller.alpha": 5.0})
    cfg = resolve({"plant.model": "dc-motor", "controller.law": "pid"})
    with pytest.raises(ConfigError, match="controller.window = 30: not read"):
        mfcontrol.make_controller(cfg, {"controller.window": 30})


def test_a_key_set_on_compared_cases_must_be_read_by_one_of_them():
    # the PID reads no estimator window, the algebraic i-PI does: the window reaches it
    c = mfcontrol.compare(["motor-noise-pid", "motor-noise-ipi-algebraic"],
                          {"sim.t_end": 0.5, "controller.window": 20})
    assert c.configs[1]["controller.window"] == 20
    with pytest.raises(ConfigError, match="controller.window = 20: not read by any case "
                       "compared; motor-noise-pid: not read with"):
        mfcontrol.compare(["motor-noise-pid", "motor-noise-ipi"],
                          {"sim.t_end": 0.5, "controller.window": 20})


def test_a_sweep_case_reads_what_its_members_read():
    # the checks across options read every key of a sweep case (they check each member
    # as a copy of the whole configuration): what its run reads is its members'
    from mfcontrol.api.run.simulate import keys_read_by_run
    from mfcontrol.experiments.cases import resolve_case

    _, cfg = resolve_case("sweep-Gamma")
    read = keys_read_by_run(cfg)
    assert {"sweep.key", "sweep.values", "controller.Gamma", "controller.gamma0"} <= read
    assert not read & {"plant.J", "controller.ki", "controller.window", "controller.alpha"}


def test_the_variational_law_reads_alpha_only_as_its_gain():
    # its gain starts from gamma0 and adapts: alpha was read and ignored (the paper's
    # variational cases set alpha = 10, and --set controller.alpha=5 changed nothing)
    from mfcontrol.api.run.simulate import keys_read_by_run

    base = {"controller.law": "variational"}
    assert "controller.alpha" not in keys_read_by_run(resolve(base))
    assert "controller.alpha" in keys_read_by_run(resolve({**base, "controller.gain": "alpha"}))
    assert "controller.alpha" in keys_read_by_run(resolve({"controller.law": "ip"}))
    positional = {"plant.model": "dc-motor", "controller.law": "i-PI"}
    assert "controller.alpha" in keys_read_by_run(resolve(positional))
    assert "controller.alpha" not in keys_read_by_run(
        resolve({**positional, "controller.adapt": "variational"}))
