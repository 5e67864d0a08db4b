"""The DC-motor i-PI sweep of ``bench_engine.py``: mfcontrol's general engine against JAX.

The issue asks every loop family to keep the paper's standing against JAX (jit + vmap +
scan, float64, sharded on both cores). This script measures it for the general engine's
sweep: the same DC motor (numba ODE in the in-place form) under the same i-PI
(constant gain, backward-difference F, clamp anti-windup, output limits +-24 V), the
same 1,024 members (kp x J), the same load step at 5 s, 10,000 samples of 1 ms.

JAX runs the loop written out in ``jax.numpy``: one ``lax.scan`` over the samples of a
member, ``vmap`` over the members, ``pmap`` over two CPU devices (one per core), float64.
It is checked against mfcontrol's members: the IAE of every member (JAX sums |e| h with its
own summation order, so to a relative 1e-9, not bit for bit).

JAX is not a dependency of mfcontrol; install it to run this (``pip install jax``). Run::

    python benchmarks/bench_jax.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("XLA_FLAGS", "--xla_force_host_platform_device_count=2")

import numpy as np  # noqa: E402

import mfcontrol  # noqa: E402
from bench_batch import median_time  # noqa: E402, I001 (a sibling script)
from bench_engine import (  # noqa: E402
    B_F,
    CHANGES,
    K_T,
    L_A,
    LOAD,
    R_A,
    SPEED,
    T_END,
    T_LOAD,
    H,
    J,
    controller,
    motor,
)
from mfcontrol.numerics import grid  # noqa: E402

KI, ALPHA, U_MAX = 50.0, 50.0, 24.0


def rk4(f, x, u, h):
    """One RK4 step of ``f(x, u) -> dx/dt`` (states as tuples of arrays) with u held, in
    the increment form and operation order of :mod:`mfcontrol.numerics.rk4`, so that a
    float64 run follows mfcontrol's to rounding."""
    f1 = tuple(h * d for d in f(x, u))
    f2 = tuple(h * d for d in f(tuple(xi + fi / 2 for xi, fi in zip(x, f1, strict=True)), u))
    f3 = tuple(h * d for d in f(tuple(xi + fi / 2 for xi, fi in zip(x, f2, strict=True)), u))
    f4 = f(tuple(xi + fi for xi, fi in zip(x, f3, strict=True)), u)
    return tuple(xi + (a + 2 * (b + c) + h * d) / 6
                 for xi, a, b, c, d in zip(x, f1, f2, f3, f4, strict=True))


def motor_rhs(inertia, tau):
    """The DC motor of ``bench_engine.motor_f`` as ``f(x, u)``, x = (omega, i), for
    :func:`rk4`: the same expressions in the same order."""
    return lambda x, u: ((K_T * x[1] - B_F * x[0] - tau) / inertia,
                         (u - R_A * x[1] - K_T * x[0]) / L_A)


def ipi_step(law, y, r, k, kp, *, gamma, ki, lo, hi, h, f_alg=None, hold=1):
    """One sample of the i-PI as :func:`mfcontrol.laws.intelligent.step` computes it
    (model order 1, constant gain gamma = 1/alpha, clamp anti-windup, output limits),
    operation for operation, in ``jax.numpy``.

    ``law`` is (y_{k-1}, r_{k-1}, u_{k-1} applied, integral, e_{k-1}), all 0 before the
    first sample. F_hat is the backward difference, or ``f_alg`` where that is given and
    not NaN (the algebraic estimator, NaN until its window is full). Returns the law's
    next memory and u_k applied; before sample ``hold`` (1: the first derivative; the
    algebraic estimator's window M under its default ``startup = "hold"``) the output
    holds ``u_{-1}`` = 0."""
    import jax.numpy as jnp

    y1, r1, u1, integ1, e1 = law
    e = y - r
    yd = (y - y1) / h
    rd = (r - r1) / h
    f_hat = yd - (1.0 / gamma) * u1
    if f_alg is not None:
        f_hat = jnp.where(jnp.isnan(f_alg), f_hat, f_alg)
    # the bracket of intelligent.output (kd = 0: its term kept for the same bits)
    integ = integ1 + e * h
    base = f_hat - rd + kp * e + 0.0 * ((e - e1) / h)
    u_unlim = -gamma * (base + ki * integ)
    u = jnp.clip(u_unlim, lo, hi)
    pushed = -gamma * ki * (integ - integ1)
    undo = (u != u_unlim) & (((u_unlim > hi) & (pushed > 0.0))
                             | ((u_unlim < lo) & (pushed < 0.0)))
    integ = jnp.where(undo, integ1, integ)
    u = jnp.where(undo, jnp.clip(-gamma * (base + ki * integ), lo, hi), u)
    started = k >= hold  # before, the output holds u_init = 0 (intelligent.held)
    u = jnp.where(started, u, u1)
    integ = jnp.where(started, integ, integ1)
    return (y, r, u, integ, e), u


def jax_sweep(kp: np.ndarray, inertia: np.ndarray):
    """A compiled function of (kp, J) arrays of shape (devices, members per device) that
    returns every member's IAE."""
    import jax
    import jax.numpy as jnp
    from jax import lax

    jax.config.update("jax_enable_x64", True)
    n = round(T_END / H)
    k_load = grid.first_sample_at(T_LOAD, T_END, n)

    def member(kp, inertia):
        def sample(carry, k):
            x, law, iae = carry
            tau = jnp.where(k >= k_load, LOAD, 0.0)
            y, r = x[0], SPEED
            law, u = ipi_step(law, y, r, k, kp, gamma=1.0 / ALPHA, ki=KI, lo=-U_MAX,
                              hi=U_MAX, h=H)
            x = rk4(motor_rhs(inertia, tau), x, u, H)  # the plant: one RK4 step, u held
            return (x, law, iae + abs(y - r) * H), None

        zero = jnp.zeros(())
        init = ((zero, zero), (zero,) * 5, zero)
        carry, _ = lax.scan(sample, init, jnp.arange(n))
        return carry[-1]

    return jax.pmap(jax.vmap(member))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    try:
        import jax
    except ImportError:
        raise SystemExit("JAX is not installed: pip install jax") from None
    side = 32
    kps, inertias = np.linspace(5.0, 40.0, side), np.linspace(3e-4, 8e-4, side)
    plant = motor()
    gridspec = {"controller.kp": kps, "plant.J": inertias}
    ours = mfcontrol.sweep(plant, controller(), SPEED, grid=gridspec, t_end=T_END,
                           changes=CHANGES)
    table = ours.to_pandas()
    devices = jax.local_device_count()
    kp = table["controller.kp"].to_numpy().reshape(devices, -1)
    inertia = table["plant.J"].to_numpy().reshape(devices, -1)
    fn = jax_sweep(kp, inertia)
    t0 = time.perf_counter()
    iae = np.asarray(fn(kp, inertia)).reshape(-1)  # compile and check
    t_first = time.perf_counter() - t0
    rel = float(np.max(np.abs(iae / table["iae"].to_numpy() - 1)))
    t_jax = median_time(lambda: fn(kp, inertia).block_until_ready(), args.repeats)
    t_ours = median_time(lambda: mfcontrol.sweep(plant, controller(), SPEED, grid=gridspec,
                                                 t_end=T_END, changes=CHANGES), args.repeats)
    mfcontrol.sweep(plant, controller(), SPEED, grid=gridspec, t_end=T_END, changes=CHANGES,
                    vectorise=True)  # compiles the plant's block functions
    t_vec = median_time(lambda: mfcontrol.sweep(plant, controller(), SPEED, grid=gridspec,
                                                t_end=T_END, changes=CHANGES,
                                                vectorise=True), args.repeats)
    m = side * side
    print(f"DC motor i-PI, {m} members x {round(T_END / H)} samples, {devices} JAX devices "
          f"(J = {J}, nominal)")
    print(f"   JAX (jit + vmap + scan + pmap, float64) {t_jax / m * 1e3:8.4f} ms/sim "
          f"(its first call, compiling, {t_first:.1f} s)")
    print(f"   mfcontrol.sweep                          {t_ours / m * 1e3:8.4f} ms/sim")
    print(f"   mfcontrol.sweep(..., vectorise=True)     {t_vec / m * 1e3:8.4f} ms/sim")
    print(f"   mfcontrol / JAX time: {t_ours / t_jax:.2f}, vectorised {t_vec / t_jax:.2f} "
          f"(below 1: mfcontrol faster); IAE agree to {rel:.1e} relative")


if __name__ == "__main__":
    main()
