"""Realistic loops in sweeps: mfcontrol against the paper's exact sweep and against JAX.

Four loops, each swept over 1,024 members (32 x 32 values of two parameters, the last
key fastest) of 10,000 samples:

1. ``motor i-PI``: the DC motor of ``bench_engine.py`` (a numba ODE in the in-place form,
   RK4, h = 1 ms, speed reference 60 rad/s, load torque 0.05 N m from 5 s) behind a
   sensor with Gaussian noise (0.5 rad/s, seed 1) and a delay of 2 samples, and an
   actuator with a delay of 3 samples and a rate limit of 2000 V/s, under the i-PI with
   the algebraic estimator of F (window M = 40; alpha 50, ki 50, output +-24 V);
   ``controller.kp`` x ``plant.J`` through ``mfcontrol.sweep``;
2. ``motor PID``: the same loop under ``mfcontrol.PID`` (the PI of ``motor-noise-pid``,
   kp 0.2, ki 0.54), kp x J;
3. ``motor ADRC``: the built-in case ``motor-noise-adrc`` (the library's DC motor, the
   sensor and actuator of loop 1, the ADRC of order 1: b0 50, wo 40 rad/s),
   ``controller.wc`` x ``plant.J`` through the case API (no JAX twin: timed against the
   paper's sweep only);
4. ``bench-lag3 i-PI``: the built-in case ``bench-lag3`` (1/(s+1)^3 stepped by its exact
   zero-order hold, 1 % sensor noise, an input load step at 20 s) with
   ``controller.law = "i-PI"`` (its algebraic estimator, window 10; alpha 30, ki 0.3,
   output +-10), run for 200 s (10,000 samples of 20 ms); ``controller.kp`` x
   ``plant.time_scale`` through the case API (``mfcontrol.api.run.batch``, what ``mfcontrol
   sweep`` runs).

Every member of a sweep has the same noise seed: ``mfcontrol.sweep`` sweeps
``sensor.seed`` only as an axis of its own, in the product. Each member's noise is a
hash of (seed, sample), so its stream is the one of its single run either way
(``tests/test_benchmarks.py`` checks the loops against their single runs and their
docstring).

Measured in one process, medians of interleaved rounds (a slow spell of the shared
machine hits every path alike) after a warm-up call that compiles or loads the kernels:

* mfcontrol: the whole sweep call (building the members, then the engine, both cores),
  per member-sample;
* the paper's exact sweep, the baseline: ``voltage-stable-standard`` over
  ``controller.alpha=logspace(0,2,1024)`` by ``batch.run_range`` (what ``mfcontrol
  sweep`` runs, exact arithmetic: the paper's sweep kernel, generic, as
  ``bench_batch.py`` times it), per member-sample; each loop's ratio to it (target: at
  most 3);
* JAX: each loop written out in ``jax.numpy`` as a JAX user would (``lax.scan`` over the
  samples, ``vmap`` over the members, ``pmap`` over two CPU devices, one per core,
  float64, jit-compiled), in mfcontrol's order of operations per sample
  (``engine/compose.py``'s member loop): the plant's output y_k; the sensor's reading
  ``y_k + n_k``, delayed; the law; the metrics (IAE of the true y, TV of the applied u);
  the actuator's delay, then its rate limit; the plant stepped with that input held. The
  algebraic estimator is a dot product with its FIR weights
  (``mfcontrol.laws.estimators.weights``) over ring buffers of the last M + 1 samples
  (mfcontrol slides moments instead); the noise is mfcontrol's counter-based hash
  (SplitMix64, Box-Muller) in uint64 arithmetic, so JAX sees the same noise (checked
  apart: the uniform variates bit for bit, the Gaussian ones to rounding of log and
  cos); the LTI plant is discretised by ``jax.scipy.linalg.expm``. mfcontrol / JAX time
  (target: at most 0.5).

Checked, not only timed: every member's IAE and TV(u) from JAX against mfcontrol's
sweep, to a relative :data:`REL_TOL` (the same loop, summed in another order: not bit
for bit); the script exits with an error if they disagree. Timings are printed, never
asserted. JAX is not a dependency of mfcontrol (``pip install jax``); without it the JAX
columns are skipped. Run::

    python benchmarks/bench_realistic.py [--repeats 7]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

import mfcontrol
from bench_engine import CHANGES, LOAD, SPEED, T_END, T_LOAD, H, motor  # noqa: I001 (siblings)
from bench_jax import ALPHA, KI, U_MAX, ipi_step, motor_rhs, rk4
from mfcontrol.api.run import batch
from mfcontrol.engine import compose
from mfcontrol.experiments.cases import resolve_case
from mfcontrol.laws.estimators import weights
from mfcontrol.numerics import grid as time_grid

SIDE = 32  # values per axis: 32 x 32 = 1,024 members
NOISE_STD, SEED = 0.5, 1  # rad/s
SENSOR_DELAY, ACTUATOR_DELAY, RATE_LIMIT = 2, 3, 2000.0  # samples, samples, V/s
WINDOW = 40  # the algebraic estimator's window, samples
PID_KP, PID_KI = 0.2, 0.54  # motor-noise-pid's PI
#: the swept axes of the motor loops, by law (every member settled under the noise and
#: the delays)
MOTOR_AXES = {"ipi": {"controller.kp": np.linspace(5.0, 40.0, SIDE),
                      "plant.J": np.linspace(3e-4, 8e-4, SIDE)},
              "pid": {"controller.kp": np.linspace(0.1, 0.4, SIDE),
                      "plant.J": np.linspace(3e-4, 8e-4, SIDE)}}
#: bench-lag3 under the i-PI: the law and the gain that make every member of its axes
#: settled (the case ships a PI), and a horizon of 10,000 of its 20 ms samples
LAG3 = ("bench-lag3", {"controller.law": "i-PI", "controller.alpha": 30.0,
                       "sim.t_end": 200.0})
LAG3_AXES = {"controller.kp": np.linspace(1.0, 2.0, SIDE),
             "plant.time_scale": np.linspace(0.8, 1.25, SIDE)}
#: the built-in DC motor under the ADRC of order 1 (``motor-noise-adrc``) behind the motor
#: loops' sensor and actuator: its observer and law over the block, as the PID's
ADRC = ("motor-noise-adrc", {"sensor.delay": 2, "actuator.delay": 3,
                             "actuator.rate_limit": 2000.0})
ADRC_AXES = {"controller.wc": np.linspace(5.0, 20.0, SIDE),
             "plant.J": np.linspace(3e-4, 8e-4, SIDE)}
#: the baseline: the paper's case and the sweep of the issue's example
PAPER = ("voltage-stable-standard", {})
PAPER_AXES = {"controller.alpha": np.logspace(0, 2, SIDE * SIDE)}
#: how far JAX's IAE and TV(u) may lie from mfcontrol's, relative: the same arithmetic
#: but for the estimator (a FIR against mfcontrol's sliding moments), the order XLA gives
#: a few sums, the noise's log and cos and the LTI's matrix exponential, over 10,000
#: samples of a closed loop
REL_TOL = 1e-9


# ---------------------------------------------------------------------------------------
# the loops in mfcontrol


@dataclass(frozen=True)
class Loop:
    """A loop swept in mfcontrol.

    Attributes
    ----------
    name : str
        What the script prints.
    axes : dict of ndarray
        The swept keys and their values; the members are their product, the last key
        fastest.
    n_samples : int
        Samples of each member.
    sweep : callable
        ``sweep()`` runs every member and returns the table: one row per member, the
        columns ``member``, the swept keys and the metrics (``iae``, ``tv_u``, ...).
    single : callable
        ``single(m)`` is the single run (a :class:`mfcontrol.Result`) of member m.
    """

    name: str
    axes: dict[str, np.ndarray]
    n_samples: int
    sweep: Callable[[], Mapping[str, np.ndarray]]
    single: Callable[[int], mfcontrol.Result]

    @property
    def n_members(self) -> int:
        return int(np.prod([v.size for v in self.axes.values()]))

    def values(self, m: int) -> dict[str, float]:
        """The swept values of member m."""
        idx = np.unravel_index(m, [v.size for v in self.axes.values()])
        return {k: float(v[i]) for (k, v), i in zip(self.axes.items(), idx, strict=True)}


def motor_sensor() -> mfcontrol.Sensor:
    """The motor loops' sensor: Gaussian noise, then a delay."""
    return mfcontrol.Sensor(noise="gaussian", noise_std=NOISE_STD, seed=SEED,
                            delay=SENSOR_DELAY)


def motor_actuator() -> mfcontrol.Actuator:
    """The motor loops' actuator: a delay, then a rate limit."""
    return mfcontrol.Actuator(delay=ACTUATOR_DELAY, rate_limit=RATE_LIMIT)


def motor_controller(law: str, kp: float | None = None):
    """The motor loops' controller: ``"ipi"``, the i-PI of ``bench_engine.py`` with the
    algebraic estimator, or ``"pid"``, the PI of ``motor-noise-pid``."""
    if law == "ipi":
        return mfcontrol.IPI(alpha=ALPHA, kp=20.0 if kp is None else kp, ki=KI,
                             sample_time=H, output_limits=(-U_MAX, U_MAX),
                             estimator="algebraic", window=WINDOW)
    return mfcontrol.PID(kp=PID_KP if kp is None else kp, ki=PID_KI, sample_time=H,
                         output_limits=(-U_MAX, U_MAX))


def motor_loop(law: str, axes: Mapping[str, np.ndarray] | None = None,
               t_end: float = T_END) -> Loop:
    """The DC motor of ``bench_engine.py`` with :func:`motor_sensor` and
    :func:`motor_actuator` under :func:`motor_controller` (``law``), swept over ``axes``
    (``controller.kp`` and plant parameters; default :data:`MOTOR_AXES`) by
    ``mfcontrol.sweep``."""
    axes = {k: np.asarray(v, dtype=float) for k, v in (axes or MOTOR_AXES[law]).items()}
    elements = {"sensor": motor_sensor(), "actuator": motor_actuator()}
    plant = motor()

    def sweep() -> Mapping[str, np.ndarray]:
        return mfcontrol.sweep(plant, motor_controller(law), SPEED, grid=axes, t_end=t_end,
                               changes=CHANGES, **elements).table

    def single(m: int) -> mfcontrol.Result:
        values = loop.values(m)
        member = motor()
        for key, v in values.items():
            if key.startswith("plant."):
                member.set_param(key.removeprefix("plant."), v)
        return mfcontrol.simulate_loop(member, motor_controller(law, values.get(
            "controller.kp")), SPEED, t_end=t_end, changes=CHANGES, **elements)

    name = {"ipi": "motor i-PI (algebraic, M = 40)", "pid": "motor PID"}[law]
    loop = Loop(name, axes, time_grid.n_samples(t_end, H), sweep, single)
    return loop


def case_loop(name: str, case: str, overrides: Mapping[str, object],
              axes: Mapping[str, np.ndarray]) -> Loop:
    """A built-in case with ``overrides``, swept over ``axes`` through the case API
    (``batch.make_grid``, ``batch.run_range``: what ``mfcontrol sweep CASE`` runs)."""
    _, cfg = resolve_case(case, dict(overrides))
    g = batch.make_grid(cfg, batch.parse_grid(dict(axes)))
    return Loop(name, dict(g.axes), time_grid.n_samples(cfg["sim.t_end"], cfg["sim.h"]),
                lambda: batch.run_range(g, 0, g.n_members),
                lambda m: mfcontrol.simulate(g.config(m)))


def lag3_loop(axes: Mapping[str, np.ndarray] | None = None,
              t_end: float | None = None) -> Loop:
    """``bench-lag3`` under the i-PI (:data:`LAG3`), swept over ``axes`` (default
    :data:`LAG3_AXES`) for ``t_end`` seconds (default 200)."""
    case, overrides = LAG3
    if t_end is not None:
        overrides = {**overrides, "sim.t_end": t_end}
    return case_loop("bench-lag3 i-PI (algebraic, M = 10)", case, overrides,
                     LAG3_AXES if axes is None else axes)


def paper_loop() -> Loop:
    """The baseline: the paper's case swept over :data:`PAPER_AXES`."""
    return case_loop("paper's exact sweep", *PAPER, PAPER_AXES)


# ---------------------------------------------------------------------------------------
# mfcontrol's noise, written for numpy or jax.numpy (``xp``)

_GOLDEN = 0x9E3779B97F4A7C15
_M1, _M2 = 0xBF58476D1CE4E5B9, 0x94D049BB133111EB


def _mix(z, xp):
    """SplitMix64's finaliser on uint64 arrays (:func:`mfcontrol.elements.noise._mix`)."""
    u = xp.uint64
    with np.errstate(over="ignore"):  # uint64 products wrap, by design
        z = (z ^ (z >> u(30))) * u(_M1)
        z = (z ^ (z >> u(27))) * u(_M2)
    return z ^ (z >> u(31))


def noise_key(seed, xp=np):
    """What a sample's hash takes from the seed alone (the same at every sample)."""
    with np.errstate(over="ignore"):
        return _mix(xp.asarray(seed, dtype=xp.uint64) * xp.uint64(_GOLDEN), xp)


def uniform(key, k, stream: int, xp=np):
    """:func:`mfcontrol.elements.noise.uniform` of sample k (whole numbers >= 0) from the
    seed's :func:`noise_key`: a variate on (0, 1) from the hash's top 53 bits."""
    u = xp.uint64
    with np.errstate(over="ignore"):
        z = _mix((key + xp.asarray(k).astype(u) * u(2) + u(stream)) * u(_GOLDEN), xp)
    return ((z >> u(11)).astype(xp.float64) + 0.5) * (1.0 / 9007199254740992.0)


def gaussian(key, k, std: float, xp=np):
    """Sample k of mfcontrol's Gaussian noise of standard deviation ``std`` (Box-Muller
    on the two streams, :func:`mfcontrol.elements.noise.sample`)."""
    return (std * xp.sqrt(-2.0 * xp.log(uniform(key, k, 0, xp)))
            * xp.cos(2.0 * xp.pi * uniform(key, k, 1, xp)))


# ---------------------------------------------------------------------------------------
# the loops in JAX


def _delay_line(buf, v, d: int):
    """(v_{k-d}, the line after v_k): ``buf`` holds the last d values, oldest first."""
    import jax.numpy as jnp

    if d == 0:
        return v, buf
    return buf[0], jnp.concatenate([buf[1:], v[None]])


def jax_member(*, h: float, x0, output, advance, law, noise_std: float,
               sensor_delay: int = 0, actuator_delay: int = 0, rate_limit: float = 0.0,
               prepare=lambda p: p):
    """One member of a realistic loop in ``jax.numpy``: ``member(p, shared) -> (IAE,
    TV(u))``, in the order of mfcontrol's member loop (``engine/compose.py``).

    ``p``: the member's parameters (a dict of arrays; ``p["noise_key"]`` is its seed's
    :func:`noise_key`), made into what the plant and the law read by ``prepare(p)``
    once; ``shared``: what every member sees at sample k, one array each over the
    samples (``"k"``, the reference ``"r"``, and the plant's own inputs). ``x0(p)``,
    ``output(x, p) -> y``, ``advance(x, u, p, at_k) -> x`` (u held over the sample);
    ``law = (init(p), step(memory, y_meas, r, k, p) -> (memory, u applied))``.
    """
    import jax.numpy as jnp
    from jax import lax

    law_init, law_step = law
    step = rate_limit * h  # the actuator's largest move per sample

    def member(p, shared):
        p = prepare(p)

        def sample(carry, at_k):
            x, memory, s_line, a_line, u_act, iae, tv, a_prev = carry
            k, r = at_k["k"], at_k["r"]
            y = output(x, p)
            s = y + gaussian(p["noise_key"], k, noise_std, jnp)
            # the reading s_0 stands for the ones before it
            s_line = jnp.where(k == 0, s, s_line)
            y_meas, s_line = _delay_line(s_line, s, sensor_delay)
            memory, a = law_step(memory, y_meas, r, k, p)
            iae = iae + abs(y - r) * h
            tv = tv + abs(a - a_prev) * jnp.where(k > 0, 1.0, 0.0)
            w, a_line = _delay_line(a_line, a, actuator_delay)  # 0 before the first command
            u_act = jnp.clip(w, u_act - step, u_act + step) if rate_limit > 0.0 else w
            x = advance(x, u_act, p, at_k)
            return (x, memory, s_line, a_line, u_act, iae, tv, a), None

        zero = jnp.zeros(())
        init = (x0(p), law_init(p), jnp.zeros(sensor_delay), jnp.zeros(actuator_delay),
                zero, zero, zero, zero)
        carry, _ = lax.scan(sample, init, shared)
        return carry[5], carry[6]

    return member


def jax_algebraic_ipi(*, alpha: float, ki: float, lo: float, hi: float, h: float,
                      window: int):
    """The i-PI with the algebraic estimator as ``(init, step)`` for :func:`jax_member`
    (``p["kp"]`` the member's gain): F_hat is the FIR of
    :func:`mfcontrol.laws.estimators.weights` over ring buffers of the last M + 1
    measurements and M applied inputs (the held kernel, mfcontrol's default), the output
    held until the window is full (the default ``startup = "hold"``,
    :func:`bench_jax.ipi_step`)."""
    import jax.numpy as jnp
    from jax import lax

    gamma = 1.0 / alpha
    m1 = window + 1
    # oldest first; the law's alpha is 1/gamma
    wy, wu = weights(1, window, h, 1.0 / gamma, "held")
    # the weights rotated onto the rings: y_k lives in slot k % (M + 1), u_k in k % M, so
    # at sample k ring slot j holds y_{k-M+((j-k-1) % (M+1))} and u_{k-M+((j-k) % M)}
    wy_rings = jnp.asarray(np.stack([np.roll(wy, s + 1) for s in range(m1)]))
    wu_rings = jnp.asarray(np.stack([np.roll(wu, s) for s in range(window)]))

    def init(p):
        zero = jnp.zeros(())
        return (zero,) * 5, jnp.zeros(m1), jnp.zeros(window)

    def step(memory, y, r, k, p):
        law, ring_y, ring_u = memory
        ring_y = lax.dynamic_update_index_in_dim(ring_y, y, k % m1, 0)
        # u_{k-1} in its slot (u_{-1}, the held start, at k = 0)
        ring_u = lax.dynamic_update_index_in_dim(ring_u, law[2], (k + window - 1) % window, 0)
        f_alg = ring_y @ wy_rings[k % m1] + ring_u @ wu_rings[k % window]
        f_alg = jnp.where(k >= window, f_alg, jnp.nan)
        law, u = ipi_step(law, y, r, k, p["kp"], gamma=gamma, ki=ki, lo=lo, hi=hi, h=h,
                          f_alg=f_alg, hold=window)
        return (law, ring_y, ring_u), u

    return init, step


def jax_pid(*, ki: float, lo: float, hi: float, h: float):
    """:func:`mfcontrol.laws.pid.step` with kd = 0 (a PI), b = 1 and tracking time Ti =
    kp / ki, as ``(init, step)`` for :func:`jax_member` (``p["kp"]`` the member's gain)."""
    import jax.numpy as jnp

    def init(p):
        return jnp.zeros(())

    def step(integral, y, r, k, p):
        kp = p["kp"]
        v = kp * (1.0 * r - y) + integral + 0.0  # P + I + D, D = 0
        u = jnp.clip(v, lo, hi)
        integral = integral + ki * h * (r - y) + (h / (kp / ki)) * (u - v)
        return integral, u

    return init, step


def jax_motor(law: str, table: Mapping[str, np.ndarray]):
    """The motor loop of :func:`motor_loop` in JAX: (member, parameters, shared)."""
    import jax.numpy as jnp

    n = round(T_END / H)
    k_load = time_grid.first_sample_at(T_LOAD, T_END, n)
    shared = {"k": np.arange(n), "r": np.full(n, SPEED),
              "tau": np.where(np.arange(n) >= k_load, LOAD, 0.0)}
    if law == "ipi":
        control = jax_algebraic_ipi(alpha=ALPHA, ki=KI, lo=-U_MAX, hi=U_MAX, h=H, window=WINDOW)
    else:
        control = jax_pid(ki=PID_KI, lo=-U_MAX, hi=U_MAX, h=H)
    member = jax_member(
        h=H, x0=lambda p: (jnp.zeros(()), jnp.zeros(())), output=lambda x, p: x[0],
        advance=lambda x, u, p, at_k: rk4(motor_rhs(p["J"], at_k["tau"]), x, u, H),
        law=control, noise_std=NOISE_STD, sensor_delay=SENSOR_DELAY,
        actuator_delay=ACTUATOR_DELAY, rate_limit=RATE_LIMIT)
    params = {"kp": table["controller.kp"], "J": table["plant.J"],
              "noise_key": noise_key(np.full(table["member"].size, SEED))}
    return member, params, shared


def jax_lag3(table: Mapping[str, np.ndarray], t_end: float | None = None):
    """``bench-lag3`` under the i-PI (:func:`lag3_loop`) in JAX, written from its resolved
    configuration: (member, parameters, shared)."""
    import jax.numpy as jnp
    from jax.scipy.linalg import expm
    from scipy import signal

    case, overrides = LAG3
    _, cfg = resolve_case(case, {**overrides, **({} if t_end is None else
                                                 {"sim.t_end": t_end})})
    h, t_end = cfg["sim.h"], cfg["sim.t_end"]
    n = round(t_end / h)
    t = time_grid.times(n, t_end)
    assert cfg["reference.kind"] == "smooth-step" and cfg["reference.duration"] == 0.0
    assert cfg["disturbance.kind"] == "step" and cfg["disturbance.at"] == "input"
    shared = {"k": np.arange(n),
              "r": np.where(t >= cfg["reference.t0"], cfg["reference.final"],
                            cfg["reference.initial"]),
              "load": np.where(t >= cfg["disturbance.t0"], cfg["disturbance.amplitude"], 0.0)}
    # K G(tau s) as a state-space model (scipy's controllable canonical form), per member
    num, den = np.asarray(cfg["plant.num"], float), np.asarray(cfg["plant.den"], float)
    models = [signal.tf2ss(cfg["plant.gain"] * num * tau ** np.arange(num.size - 1, -1, -1.0),
                           den * tau ** np.arange(den.size - 1, -1, -1.0))
              for tau in table["plant.time_scale"]]
    n_x = den.size - 1

    def prepare(p):
        """The zero-order-hold discretisation over h: expm([[A, B], [0, 0]] h)."""
        top = jnp.concatenate([p["A"], p["B"][:, None]], axis=1)
        e = expm(jnp.concatenate([top, jnp.zeros((1, n_x + 1))]) * h)
        return {**p, "Ad": e[:n_x, :n_x], "Bd": e[:n_x, n_x]}

    member = jax_member(
        h=h, x0=lambda p: jnp.zeros(n_x), output=lambda x, p: p["C"] @ x,
        advance=lambda x, u, p, at_k: p["Ad"] @ x + p["Bd"] * (u + at_k["load"]),
        law=jax_algebraic_ipi(alpha=cfg["controller.alpha"], ki=cfg["controller.ki"],
                              lo=cfg["controller.duty_min"], hi=cfg["controller.duty_max"],
                              h=h, window=cfg["controller.window"]),
        noise_std=cfg["sensor.noise_std"], sensor_delay=cfg["sensor.delay"],
        actuator_delay=cfg["actuator.delay"], rate_limit=cfg["actuator.rate_limit"],
        prepare=prepare)
    params = {"kp": table["controller.kp"], "A": np.stack([a for a, _, _, _ in models]),
              "B": np.stack([b[:, 0] for _, b, _, _ in models]),
              "C": np.stack([c[0] for _, _, c, _ in models]),
              "noise_key": noise_key(np.full(table["member"].size, cfg["sensor.seed"]))}
    return member, params, shared


def jax_sweep(member, params: Mapping[str, np.ndarray], shared: Mapping[str, np.ndarray]):
    """``run() -> (IAE, TV(u))`` of every member: ``member`` vmapped over the members and
    pmapped over the devices (one per core), the shared arrays to every member."""
    import jax

    devices = jax.local_device_count()
    split = {k: np.asarray(v).reshape(devices, -1, *np.shape(v)[1:]) for k, v in params.items()}
    fn = jax.pmap(jax.vmap(member, in_axes=(0, None)), in_axes=(0, None))

    def run():
        iae, tv = fn(split, shared)
        return np.asarray(iae).reshape(-1), np.asarray(tv).reshape(-1)

    return run


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a / b - 1.0)))


def noise_check(n: int = 2000) -> tuple[bool, float]:
    """mfcontrol's noise against :func:`uniform` and :func:`gaussian` in JAX for a few
    seeds: (the uniform variates bit for bit equal, the Gaussian ones' largest
    difference)."""
    import jax.numpy as jnp

    from mfcontrol.elements import noise

    seeds = (0, 1, 7, 123456789, 2**53 - 1)
    k = np.arange(n)
    same, diff = True, 0.0
    for seed in seeds:
        key = noise_key(seed, jnp)
        ours = np.array([[noise.uniform(seed, j, s) for j in k] for s in (0, 1)])
        theirs = np.array([np.asarray(uniform(key, jnp.asarray(k), s, jnp)) for s in (0, 1)])
        same &= bool(np.array_equal(ours, theirs))
        g = np.array([noise.sample(noise.GAUSSIAN, 1.0, seed, j) for j in k])
        diff = max(diff, float(np.max(np.abs(np.asarray(gaussian(key, jnp.asarray(k), 1.0,
                                                                   jnp)) - g))))
    return same, diff


# ---------------------------------------------------------------------------------------


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7, help="interleaved rounds (default 7)")
    args = ap.parse_args()
    loops = {"ipi": motor_loop("ipi"), "pid": motor_loop("pid"), "lag3": lag3_loop(),
             "adrc": case_loop("motor ADRC (order 1; no JAX twin)", *ADRC, ADRC_AXES)}
    paper = paper_loop()
    t0 = time.perf_counter()
    # the vectorised loop, compiled once per machine (about 2 min) or loaded: a sweep of
    # this size takes it only once it is on the machine, and runs the member loop before
    compose.block_kernel()
    tables = {name: loop.sweep() for name, loop in loops.items()}  # compiles or loads
    paper.sweep()
    print(f"mfcontrol {mfcontrol.__version__}: {paper.n_members:,} members x "
          f"{paper.n_samples:,} samples a sweep (warm-up {time.perf_counter() - t0:.0f} s)")
    for name, loop in loops.items():
        met = tables[name]
        print(f"   {loop.name}: {int(np.sum(met['settled']))}/{loop.n_members} members "
              f"settled, {int(np.sum(met['diverged']))} diverged, IAE "
              f"{np.min(met['iae']):.3g}..{np.max(met['iae']):.3g}; axes "
              + " x ".join(f"{k} {v.min():g}..{v.max():g}" for k, v in loop.axes.items()))

    runs: dict[str, Callable[[], object]] = {"paper": paper.sweep}
    runs.update({name: loop.sweep for name, loop in loops.items()})
    agree: dict[str, str] = {}
    ok = True
    try:
        import jax
    except ImportError:
        jax = None
        print("JAX is not installed (pip install jax): its columns are skipped")
    if jax is not None:
        jax.config.update("jax_enable_x64", True)
        same, diff = noise_check()
        print(f"JAX {jax.__version__} on {jax.local_device_count()} CPU devices; its noise: "
              f"uniform variates bit for bit {same}, Gaussian ones within {diff:.1e} of "
              "mfcontrol's (5 seeds x 2,000 samples)")
        ok &= same and diff < 1e-12
        builders = {"ipi": lambda t: jax_motor("ipi", t), "pid": lambda t: jax_motor("pid", t),
                    "lag3": jax_lag3}
        for name, build in builders.items():
            run = jax_sweep(*build(tables[name]))
            t0 = time.perf_counter()
            iae, tv = run()
            compile_s = time.perf_counter() - t0
            e_iae = _rel(iae, tables[name]["iae"])
            e_tv = _rel(tv, tables[name]["tv_u"])
            good = e_iae <= REL_TOL and e_tv <= REL_TOL
            ok &= good
            agree[name] = (f"IAE {e_iae:.0e}, TV(u) {e_tv:.0e} "
                           f"({'agree' if good else 'DISAGREE'}; first call {compile_s:.1f} s)")
            runs["jax " + name] = run

    times: dict[str, list[float]] = {k: [] for k in runs}
    for _ in range(args.repeats):  # interleaved: a slow spell hits every path alike
        for key, fn in runs.items():
            times[key].append(_once(fn))
    timed = {"paper": paper, **loops, **{"jax " + k: loop for k, loop in loops.items()}}
    per_ms = {k: [t / (timed[k].n_members * timed[k].n_samples) * 1e9 for t in v]
              for k, v in times.items()}

    def med(key: str) -> float:
        return statistics.median(per_ms[key])

    def ratio(a: str, b: str) -> float:
        return statistics.median(x / y for x, y in zip(per_ms[a], per_ms[b], strict=True))

    print(f"ns per member-sample, medians of {args.repeats} interleaved rounds; ratios "
          "per round, their median")
    print(f"   {'loop':36s} {'mfcontrol':>9s} {'paper':>7s} {'JAX':>7s}  "
          f"{'/paper (<= 3)':>13s} {'/JAX (<= 0.5)':>13s}  JAX agrees (relative, max)")
    for name, loop in loops.items():
        has_jax = "jax " + name in per_ms
        jax_ns = f"{med('jax ' + name):7.1f}" if has_jax else f"{'-':>7s}"
        to_jax = f"{ratio(name, 'jax ' + name):13.2f}" if has_jax else f"{'-':>13s}"
        print(f"   {loop.name:36s} {med(name):9.1f} {med('paper'):7.1f} {jax_ns}  "
              f"{ratio(name, 'paper'):13.2f} {to_jax}  {agree.get(name, '-')}")
    if not ok:
        raise SystemExit("JAX and mfcontrol disagree beyond the tolerance: the timings "
                         "above do not compare the same loops")


def _once(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()
