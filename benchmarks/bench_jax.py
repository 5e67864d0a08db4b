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


def jax_sweep(kp: np.ndarray, inertia: np.ndarray):
    """A compiled function of (kp, J) arrays of shape (devices, members per device) that
    returns every member's IAE."""
    import jax
    import jax.numpy as jnp
    from jax import lax

    jax.config.update("jax_enable_x64", True)
    n = round(T_END / H)
    k_load = grid.first_sample_at(T_LOAD, T_END, n)
    gamma = 1.0 / ALPHA

    def f(x0, x1, u, inertia, tau):
        return ((K_T * x1 - B_F * x0 - tau) / inertia, (u - R_A * x1 - K_T * x0) / L_A)

    def member(kp, inertia):
        def sample(carry, k):
            x0, x1, y1, r1, u1, integ, e1, iae = carry
            tau = jnp.where(k >= k_load, LOAD, 0.0)
            y, r = x0, SPEED
            e = y - r
            # the i-PI of mfcontrol.laws.intelligent.step, operation for operation
            yd = (y - y1) / H
            rd = (r - r1) / H
            f_hat = yd - (1.0 / gamma) * u1
            integ_new = integ + e * H
            base = f_hat - rd + kp * e + 0.0 * ((e - e1) / H)
            u_unlim = -gamma * (base + KI * integ_new)
            u = jnp.clip(u_unlim, -U_MAX, U_MAX)
            pushed = -gamma * KI * (integ_new - integ)
            undo = (u != u_unlim) & (((u_unlim > U_MAX) & (pushed > 0.0))
                                     | ((u_unlim < -U_MAX) & (pushed < 0.0)))
            integ_new = jnp.where(undo, integ, integ_new)
            u_unlim = jnp.where(undo, -gamma * (base + KI * integ_new), u_unlim)
            u = jnp.where(undo, jnp.clip(u_unlim, -U_MAX, U_MAX), u)
            started = k >= 1  # before the first derivative the output holds u_init = 0
            u = jnp.where(started, u, u1)
            integ_new = jnp.where(started, integ_new, integ)
            # the plant: one RK4 step with u held
            a0, a1 = f(x0, x1, u, inertia, tau)
            a0, a1 = H * a0, H * a1
            b0, b1 = f(x0 + a0 / 2, x1 + a1 / 2, u, inertia, tau)
            b0, b1 = H * b0, H * b1
            c0, c1 = f(x0 + b0 / 2, x1 + b1 / 2, u, inertia, tau)
            c0, c1 = H * c0, H * c1
            d0, d1 = f(x0 + c0, x1 + c1, u, inertia, tau)
            x0 = x0 + (a0 + 2 * (b0 + c0) + H * d0) / 6
            x1 = x1 + (a1 + 2 * (b1 + c1) + H * d1) / 6
            return (x0, x1, y, r, u, integ_new, e, iae + abs(e) * H), None

        zero = jnp.zeros(())
        init = (zero, zero, zero, zero, zero, zero, zero, zero)
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
