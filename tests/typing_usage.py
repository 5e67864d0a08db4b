"""The public API used as a user uses it, with the types a user expects written on each
assignment. Never run, never collected (no ``test_`` prefix): tests/test_typing.py has
mypy check it together with the package, so a wrong public annotation fails there.
Nothing runs at import: every use is inside a function that nothing calls."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

import mfcontrol


def live_controllers() -> None:
    ip = mfcontrol.IP(alpha=2.0, kp=5.0, sample_time=0.01, output_limits=(-10, 10))
    u: float = ip(0.0, setpoint=1.0)
    u = ip(0.02, dt=0.02)
    terms: dict[str, float] = ip.components
    gamma: float = ip.gamma
    ip.setpoint = 2.0
    setpoint: float = ip.setpoint
    limits: tuple[float | None, float | None] = ip.output_limits
    period: float = ip.sample_time

    ipi = mfcontrol.IPI(alpha=1.0, kp=10.0, ki=5.0, sample_time=0.01,
                        output_limits=(None, 5.0), estimator="algebraic", window=10)
    u = ipi(0.1, setpoint=1.0)
    ipi.set_auto_mode(False, last_output=0.5)
    ipi.set_auto_mode(True)
    ipi.reset()
    n_nan: int = ipi.nan_count

    ext = mfcontrol.IPID(alpha=1.0, kp=4.0, ki=1.0, kd=2.0, sample_time=0.01,
                         gain="external")
    u = ext(0.0, setpoint=1.0, alpha=2.0)

    pid = mfcontrol.PID(kp=2.0, ki=1.0, sample_time=0.1, output_limits=(0, 10), Tt=0.5)
    u = pid(0.5, setpoint=1.0, dt=0.1)
    snap: dict[str, Any] = pid.snapshot()
    copy: mfcontrol.PID = mfcontrol.PID.from_snapshot(snap)
    copy.restore(snap)
    last: float = copy.last_output

    rip = mfcontrol.RecursiveIP(alpha=10.0, kp=2.0, law="variational", gamma0=1.0)
    u = rip(2.0e-5, setpoint=1e-3)
    rip_period: float | None = rip.sample_time
    raw: dict[str, float] = rip.components

    ctrl: (mfcontrol.IntelligentController | mfcontrol.RecursiveIP | mfcontrol.PID
           | mfcontrol.ADRC) = mfcontrol.make_controller("motor-noise-ipi-algebraic",
                                                         {"sim.h": 1e-3})
    adrc = mfcontrol.ADRC(order=2, b0=1.0, wc=2.0, wo=10.0, sample_time=0.01)
    f_hat: float = adrc.components["F_hat"]
    estimate: np.ndarray = adrc.estimate
    print(f_hat, estimate)
    print(u, terms, gamma, setpoint, limits, period, n_nan, last, rip_period, raw, ctrl)


def loops() -> None:
    def f(t: float, x: np.ndarray, u: float, p: np.ndarray) -> np.ndarray:
        return np.array([x[1], -p[0] * np.sin(x[0]) - p[1] * x[1] + u])

    def g(x: np.ndarray, p: np.ndarray) -> float:
        return float(x[0])

    pendulum = mfcontrol.ODE(f, g, x0=(0.5, 0.0), params={"g_over_l": 9.81, "damping": 0.2})
    x: np.ndarray = pendulum.x0
    x = pendulum.step(0.0, x, 0.0, 0.01)
    y: float = pendulum.output(x)
    params: dict[str, float] = pendulum.params

    ctrl = mfcontrol.IPI(alpha=1.0, kp=10.0, ki=5.0, sample_time=0.01)
    r: mfcontrol.Result = mfcontrol.simulate_loop(pendulum, ctrl, 0.2, t_end=2.0)
    r = mfcontrol.simulate_loop(
        mfcontrol.LTI(A=[[0.0, 1.0], [-1.0, -0.5]], B=[[0.0], [1.0]], C=[[1.0, 0.0]]),
        mfcontrol.PID(kp=2.0, ki=1.0, sample_time=0.01), lambda t: 1.0 if t > 0.1 else 0.0,
        t_end=1.0)
    first_order = mfcontrol.FirstOrder(a=-1.0, b=1.0)
    loop: mfcontrol.LoopResult = mfcontrol.simulate_loop(
        first_order, ctrl, np.ones(100), t_end=1.0, h=0.01,
        changes=[mfcontrol.Change(time=0.5, name="a", value=-2.0)],
        sensor=mfcontrol.Sensor(), actuator=mfcontrol.Actuator(),
        disturbance=mfcontrol.Disturbance())
    metrics: dict[str, Any] = loop.metrics
    iae: float = r.metrics["iae"]
    t: np.ndarray = r.time
    u: np.ndarray = r.signals["u"]
    frame = r.to_pandas()
    csv: Path = r.to_csv("run.csv")
    fig = r.plot("run.png")
    fig.savefig("again.png")

    swept: mfcontrol.LoopSweepResult = mfcontrol.sweep(
        first_order, ctrl, 1.0, grid={"controller.kp": [1.0, 5.0], "plant.a": [-1.0, -2.0]},
        t_end=1.0, keep=1)
    members: int = swept.n_members
    table: dict[str, np.ndarray] = swept.table
    kept: dict[int, mfcontrol.Result] = swept.kept
    sweep_frame = swept.to_pandas()
    print(y, params, metrics, iae, t, u, frame, csv, members, table, kept, sweep_frame)


def cases() -> None:
    names: list[str] = mfcontrol.case_names()
    run: mfcontrol.Result | mfcontrol.SweepResult = mfcontrol.run_case(
        "voltage-stable-variational", overrides={"fidelity": "paper"})
    if isinstance(run, mfcontrol.Result):
        iae: float = run.metrics["iae"]
        cfg: mfcontrol.Config | None = run.config
        frame = run.to_pandas()
        print(iae, cfg, frame.head())
    else:
        rows: list[dict[str, Any]] = run.metrics
        key: str = run.key
        member: mfcontrol.Result = run.members[0]
        print(rows, key, member)

    config: mfcontrol.Config = mfcontrol.resolve({"plant.model": "first-order"})
    law: Any = config["controller.law"]
    one: mfcontrol.Result = mfcontrol.simulate(config, name="first order")
    many: list[mfcontrol.Result] = mfcontrol.simulate_many([config, config])
    tuned: mfcontrol.TuneResult = mfcontrol.tune(
        "first-order-ip-algebraic", ["controller.kp=1:50"], budget=40,
        overrides={"sim.t_end": 1.0})
    best: dict[str, float] = tuned.best
    value: float = tuned.value
    best_config: mfcontrol.Config = tuned.config

    comparison: mfcontrol.Comparison = mfcontrol.compare(
        ["motor-noise-pid", "motor-noise-ipi-algebraic"], out="results/compare")
    table: list[dict[str, Any]] = comparison.rows()
    differences: dict[str, list[Any]] = comparison.differences()
    text: str = comparison.markdown()
    comparison_frame = comparison.to_pandas()

    header, source = mfcontrol.export_c("motor-noise-ipi-algebraic", out="c", prefix="motor")
    files: tuple[Path, Path] = (header, source)
    print(names, law, one, many, best, value, best_config, table, differences, text,
          comparison_frame, files)


def errors() -> None:
    try:
        mfcontrol.resolve({"controller.alpha": -1.0})
    except mfcontrol.ConfigError as exc:
        key: str = exc.key
        print(key)
    except mfcontrol.CaseError:
        pass
    version: str = mfcontrol.__version__
    print(version)
