"""The general compiled engine: every loop family against the paper's case and python-control.

Measured in one process, as medians of interleaved rounds (a slow spell of a shared
machine hits every path alike), after a warm-up call (which compiles or loads the kernels
from numba's disk cache):

1. Per-sample cost of single runs, end to end (``mfcontrol.simulate(cfg)``), of the built-in
   cases ``buck-ipi``, ``boost-ipd`` and ``first-order-ip-algebraic`` as a ratio to the
   paper's ``voltage-stable-standard``. Target (issue 10): at most 3x.
2. A DC motor (J = 5e-4, b = 1e-4, k = 0.05, R = 2, L = 2e-3; load torque 0.05 N m from 5 s)
   written as a numba ODE in the in-place form, under an i-PI, h = 1 ms, 10 s:
   a single run (``simulate_loop``) and a 1,024-member sweep (``mfcontrol.sweep``, kp x
   J) per simulation, by default and with ``vectorise=True``, against the same loop in
   python-control (one discrete ``nlsys`` holding plant and controller,
   ``input_output_response``; the median of three runs). Targets: 300x and 5,000x.
   Beside them, the floor of any engine that runs this plant member by member in scalar
   code: the plant's RK4 steps alone (f compiled in, 16 members side by side so that the
   core overlaps their dependency chains, both cores), no law, metrics or reference. A
   ratio to python-control above it needs members vectorised (SIMD) through f: the same
   steps with the members' states contiguous, where LLVM vectorises f, bit for bit equal.
3. ``simulate_loop`` linear in the horizon: the time of 200,000 samples over 20 times the
   time of 10,000 (1.0 is linear).
4. Sweeps of the built-in cases ``buck-ipi``, ``boost-ipd`` and
   ``first-order-ip-algebraic`` (1,024 members, kp x a plant parameter): the engine's
   batch of the members (``batch_metrics``) in the member loop and in
   the vectorised loop (the library plant's block functions), per member-sample on both
   cores, the members' plants and laws built beforehand; and the whole of what
   ``mfcontrol sweep CASE`` runs per member (building the members, then the batch).

Timings are printed, never asserted. Run::

    python benchmarks/bench_engine.py [--repeats 7] [--members 1024]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import mfcontrol
from bench_batch import median_time  # noqa: I001 (a sibling script: run from anywhere)
from mfcontrol.api.model.plants import ODE
from mfcontrol.api.run import batch
from mfcontrol.api.run.simulate import batch_metrics, member_parts
from mfcontrol.engine import compose
from mfcontrol.experiments.cases import resolve_case

J, B_F, K_T, R_A, L_A = 5e-4, 1e-4, 0.05, 2.0, 2e-3
H, T_END, T_LOAD, LOAD = 1e-3, 10.0, 5.0, 0.05
SPEED = 60.0


def motor_f(t, x, u, p, dxdt):
    """DC motor, x = (omega, i), p = (J, b, k, R, L, tau_load); in place."""
    dxdt[0] = (p[2] * x[1] - p[1] * x[0] - p[5]) / p[0]
    dxdt[1] = (u - p[3] * x[1] - p[2] * x[0]) / p[4]


def motor_g(x, p):
    return x[0]


def motor() -> ODE:
    return ODE(motor_f, motor_g, x0=(0.0, 0.0),
               params={"J": J, "b": B_F, "k": K_T, "R": R_A, "L": L_A, "tau": 0.0})


def controller(kp: float = 20.0) -> mfcontrol.IPI:
    return mfcontrol.IPI(alpha=50.0, kp=kp, ki=50.0, sample_time=H, output_limits=(-24, 24))


CHANGES = [mfcontrol.Change(T_LOAD, "tau", LOAD)]


def _member_parameters(n_members: int) -> np.ndarray:
    """The motor's parameters, one row per member, J differing between them (so that a
    layout mistake shows in the final states)."""
    P = np.tile([J, B_F, K_T, R_A, L_A, 0.0], (n_members, 1))
    P[:, 0] *= 1.0 + np.arange(n_members) / n_members
    return P


def plant_floor(members: int, n: int = round(T_END / H),
                lanes: int = 16) -> tuple[float, np.ndarray]:
    """Seconds per simulation of the motor's RK4 steps alone: ``members`` members, n
    samples, in blocks of ``lanes`` members stepped stage by stage (f compiled in, the
    block's rows as views of raw memory, which carry no reference count), the members split
    over the cores. The input is held at 1 V: the plant's arithmetic does not depend on
    where u comes from."""
    from concurrent.futures import ThreadPoolExecutor

    from numba import carray, njit

    from mfcontrol.numerics.rk4 import combine, half, whole
    from mfcontrol.numerics.signatures import pointer

    f = njit(inline="always", error_model="numpy")(motor_f)

    @njit(error_model="numpy", nogil=True)
    def blocks(Xa, Pa, Wa, n, lanes, h):
        for b0 in range(0, Xa.shape[0], lanes):
            X = carray(pointer(Xa[b0:]), (lanes, 2))
            P = carray(pointer(Pa[b0:]), (lanes, 6))
            W = carray(pointer(Wa), (5, lanes, 2))
            for _ in range(n):
                for s in range(4):
                    src = X if s == 0 else W[4]
                    for i in range(lanes):
                        f(0.0, src[i], 1.0, P[i], W[s, i])
                    for i in range(lanes):
                        for c in range(2):
                            if s == 3:
                                X[i, c] = combine(X[i, c], W[0, i, c], W[1, i, c], W[2, i, c],
                                                  h * W[3, i, c])
                            else:
                                W[s, i, c] *= h
                                W[4, i, c] = (whole(X[i, c], W[s, i, c]) if s == 2
                                              else half(X[i, c], W[s, i, c]))
        return Xa[0, 0]

    per_core = max(1, members // (2 * lanes)) * lanes  # whole blocks only
    members = 2 * per_core
    P = _member_parameters(per_core)
    parts = [(np.zeros((per_core, 2)), P.copy(), np.zeros((5, lanes, 2))) for _ in range(2)]
    assert per_core % lanes == 0  # blocks() reads whole blocks of raw memory
    blocks(*parts[0], 10, lanes, H)  # compile
    parts[0][0][:] = 0.0
    t0 = time.perf_counter()
    with ThreadPoolExecutor(2) as pool:
        list(pool.map(lambda part: blocks(*part, n, lanes, H), parts))
    return (time.perf_counter() - t0) / members, parts[0][0].copy()


def plant_floor_simd(members: int, n: int = round(T_END / H),
                     lanes: int = 64) -> tuple[float, np.ndarray]:
    """As :func:`plant_floor`, with the block laid out member-contiguous: state i of the
    block's members in one row (``X[i, l]``), f called on the column views ``X[:, l]`` of
    raw memory. LLVM then vectorises f itself over the members (SIMD), which the
    member-major layout of :func:`plant_floor` does not allow."""
    from concurrent.futures import ThreadPoolExecutor

    from numba import carray, njit

    from mfcontrol.numerics.rk4 import combine, half, whole
    from mfcontrol.numerics.signatures import pointer

    f = njit(inline="always", error_model="numpy")(motor_f)

    @njit(inline="always", error_model="numpy")
    def stage(S, X, U, P, F, XT, h, to_end, t):
        """F = h f(S) for every member, and the next trial state XT from it."""
        for i in range(X.shape[1]):
            f(t, S[:, i], U[i], P[:, i], F[:, i])
        for c in range(X.shape[0]):
            for i in range(X.shape[1]):
                F[c, i] *= h
                XT[c, i] = whole(X[c, i], F[c, i]) if to_end else half(X[c, i], F[c, i])

    @njit(error_model="numpy", nogil=True)
    def blocks(Xa, Pa, Ua, Wa, n, lanes, h):
        for b0 in range(0, Xa.shape[0], 2 * lanes):
            X = carray(pointer(Xa[b0:]), (2, lanes))
            P = carray(pointer(Pa[3 * b0:]), (6, lanes))
            U = carray(pointer(Ua), (lanes,))
            W = carray(pointer(Wa), (5, 2, lanes))
            F1, F2, F3, F4, XT = W[0], W[1], W[2], W[3], W[4]
            for _ in range(n):
                stage(X, X, U, P, F1, XT, h, False, 0.0)
                stage(XT, X, U, P, F2, XT, h, False, 0.0)
                stage(XT, X, U, P, F3, XT, h, True, 0.0)
                for i in range(lanes):
                    f(0.0, XT[:, i], U[i], P[:, i], F4[:, i])
                for c in range(2):
                    for i in range(lanes):
                        X[c, i] = combine(X[c, i], F1[c, i], F2[c, i], F3[c, i], h * F4[c, i])
        return Xa[0]

    per_core = max(1, members // (2 * lanes)) * lanes  # whole blocks only
    members = 2 * per_core
    n_blocks = per_core // lanes
    # block b holds members b lanes .. (b + 1) lanes - 1: parameter k of its member l at
    # [b, k, l], state i at [b, i, l]
    P = _member_parameters(per_core).reshape(n_blocks, lanes, 6).transpose(0, 2, 1).ravel()
    parts = [(np.zeros(2 * per_core), P.copy(), np.ones(lanes), np.zeros(10 * lanes))
             for _ in range(2)]
    blocks(*parts[0], 10, lanes, H)  # compile
    parts[0][0][:] = 0.0
    t0 = time.perf_counter()
    with ThreadPoolExecutor(2) as pool:
        list(pool.map(lambda part: blocks(*part, n, lanes, H), parts))
    states = parts[0][0].reshape(n_blocks, 2, lanes).transpose(0, 2, 1).reshape(per_core, 2)
    return (time.perf_counter() - t0) / members, states.copy()


def python_control_run(n: int = round(T_END / H)) -> np.ndarray:
    """The DC-motor loop in python-control: one discrete nlsys (plant RK4 step in numpy and
    the live controller's pure step), simulated by ``input_output_response``."""
    import control

    from mfcontrol.engine import live

    ctrl = controller()
    CP = ctrl._CP
    n_cs = ctrl._CS.shape[0]
    p0 = np.array([J, B_F, K_T, R_A, L_A, 0.0])

    def f(x, u, p):
        out = np.empty(2)
        motor_f(0.0, x, u, p, out)
        return out

    def update(t, z, r, params):
        x, cs = z[:2], z[2:]
        p = p0.copy()
        p[5] = LOAD if t >= T_LOAD else 0.0
        u, cs_next = live.intelligent_pure(CP, cs, x[0], float(r[0]), H, 1.0)
        f1 = H * f(x, u, p)
        f2 = H * f(x + f1 / 2, u, p)
        f3 = H * f(x + f2 / 2, u, p)
        f4 = H * f(x + f3, u, p)
        return np.concatenate([x + (f1 + 2 * (f2 + f3) + f4) / 6, cs_next])

    sys = control.nlsys(update, lambda t, z, r, params: z[:1], inputs=1, outputs=1,
                        states=2 + n_cs, dt=H)
    t = np.arange(n) * H
    z0 = np.concatenate([np.zeros(2), ctrl._CS[:, 0]])
    return control.input_output_response(sys, t, np.full(n, SPEED), X0=z0).outputs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--members", type=int, default=1024)
    args = ap.parse_args()

    print("1. per-sample cost of single runs, ratio to voltage-stable-standard (target <= 3)")
    cases = ["voltage-stable-standard", "buck-ipi", "boost-ipd", "first-order-ip-algebraic"]
    cfgs = {c: resolve_case(c)[1] for c in cases}
    samples = {c: round(cfg["sim.t_end"] / cfg["sim.h"]) for c, cfg in cfgs.items()}
    for cfg in cfgs.values():
        mfcontrol.simulate(cfg)  # warm-up: compile or load
    per = {c: [] for c in cases}
    for _ in range(args.repeats):
        for c in cases:
            per[c].append(median_time(lambda c=c: mfcontrol.simulate(cfgs[c]), 1) / samples[c])
    base = statistics.median(per[cases[0]])
    for c in cases:
        ns = statistics.median(per[c]) * 1e9
        print(f"   {c:26s} {samples[c]:7d} samples  {ns:7.1f} ns/sample  "
              f"ratio {ns / (base * 1e9):5.2f}")

    print("2. DC motor i-PI, numba ODE in place, 10,000 samples")
    compose.block_kernel()  # the vectorised loop, compiled or loaded: the warm state
    plant = motor()
    mfcontrol.simulate_loop(plant, controller(), SPEED, t_end=T_END, changes=CHANGES)
    single = median_time(lambda: mfcontrol.simulate_loop(
        plant, controller(), SPEED, t_end=T_END, changes=CHANGES), args.repeats)
    ours = mfcontrol.simulate_loop(plant, controller(), SPEED, t_end=T_END, changes=CHANGES)
    python_control_run(200)  # warm-up: compiles the live step it calls
    # the median of three runs: the noisiest figure here, and every ratio's baseline
    pc_y = python_control_run()
    pc = median_time(python_control_run, 3)
    agree = float(np.max(np.abs(pc_y.reshape(-1) - ours.signals["y"])))  # the same loop
    side = int(round(args.members ** 0.5))
    grid = {"controller.kp": np.linspace(5.0, 40.0, side),
            "plant.J": np.linspace(3e-4, 8e-4, args.members // side)}
    mfcontrol.sweep(plant, controller(), SPEED, grid=grid, t_end=T_END, changes=CHANGES)
    sweep = median_time(lambda: mfcontrol.sweep(plant, controller(), SPEED, grid=grid,
                                                t_end=T_END, changes=CHANGES), 3)
    n_members = side * (args.members // side)
    member = median_time(lambda: mfcontrol.sweep(plant, controller(), SPEED, grid=grid,
                                                 t_end=T_END, changes=CHANGES,
                                                 vectorise=False), 3)
    mfcontrol.sweep(plant, controller(), SPEED, grid=grid, t_end=T_END, changes=CHANGES,
                    vectorise=True)  # compiles the plant's block functions
    vec = median_time(lambda: mfcontrol.sweep(plant, controller(), SPEED, grid=grid,
                                              t_end=T_END, changes=CHANGES, vectorise=True), 3)
    print(f"   python-control {pc * 1e3:8.1f} ms/run (max |y difference| {agree:.1e})")
    print(f"   single run     {single * 1e3:8.3f} ms/run   {pc / single:9.0f}x python-control "
          f"(target 300x)")
    print(f"   sweep          {sweep / n_members * 1e3:8.4f} ms/sim   "
          f"{pc / (sweep / n_members):9.0f}x python-control (target 5,000x), "
          f"{n_members / sweep:,.0f} sims/s (default: the vectorised loop with f member by "
          f"member unless the block functions are compiled)")
    print(f"   sweep, vectorise=False {member / n_members * 1e3:8.4f} ms/sim   "
          f"{pc / (member / n_members):9.0f}x python-control (the member loop)")
    print(f"   sweep, vectorise=True {vec / n_members * 1e3:8.4f} ms/sim   "
          f"{pc / (vec / n_members):9.0f}x python-control (blocks of 64 members: f, g, the "
          f"law and the metrics vectorised over them)")
    floor = min(plant_floor(n_members)[0] for _ in range(3))
    print(f"   plant alone    {floor * 1e3:8.4f} ms/sim   {pc / floor:9.0f}x python-control: the "
          f"scalar floor (RK4 of f only, 16 members side by side, both cores)")
    simd = min(plant_floor_simd(n_members)[0] for _ in range(3))
    # the same arithmetic: 50 steps, before the motor settles, every member (J differs)
    same = np.array_equal(plant_floor(256, n=50)[1], plant_floor_simd(256, n=50)[1])
    assert same, "the member-contiguous steps differ from the scalar ones"
    print(f"   plant, SIMD    {simd * 1e3:8.4f} ms/sim   {pc / simd:9.0f}x python-control: the "
          f"same, members contiguous (64 a block), f vectorised over them; the same final "
          f"state bit for bit: {same}")

    print("3. simulate_loop against the horizon (1.0: linear)")
    short = median_time(lambda: mfcontrol.simulate_loop(
        plant, controller(), SPEED, t_end=10.0, changes=CHANGES), args.repeats)
    long = median_time(lambda: mfcontrol.simulate_loop(
        plant, controller(), SPEED, t_end=200.0, changes=CHANGES), 3)
    print(f"   10,000 samples {short * 1e3:.2f} ms, 200,000 samples {long * 1e3:.2f} ms: "
          f"{long / (20 * short):.2f}")

    print("4. built-in cases swept, 1,024 members (kp x a plant parameter), both cores")
    sweeps = {"buck-ipi": ("controller.kp", "linspace(1e3,5e3,32)", "plant.R",
                           "linspace(5,20,32)"),
              "boost-ipd": ("controller.kp", "linspace(2e7,8e7,32)", "plant.R",
                            "linspace(5,20,32)"),
              "first-order-ip-algebraic": ("controller.kp", "linspace(1,10,32)", "plant.a",
                                           "linspace(-2,0,32)")}
    for c, (k1, v1, k2, v2) in sweeps.items():
        g = batch.make_grid(cfgs[c], batch.parse_grid({k1: v1, k2: v2}))
        members = [g.config(m) for m in range(g.n_members)]
        parts = {name: [build(m) for m in members]
                 for name, build in member_parts().items()}
        per_ms = samples[c] * g.n_members

        def engine(vectorise, parts=parts, c=c):
            return batch_metrics(cfgs[c], parts, vectorise=vectorise)

        loop = median_time(lambda: engine(False), 3)
        vec = median_time(lambda: engine(None), 3)
        whole = median_time(lambda g=g: batch.run_range(g, 0, g.n_members), 3)
        print(f"   {c:26s} member loop {loop / per_ms * 1e9:5.1f} ns/member-sample, "
              f"vectorised {vec / per_ms * 1e9:5.1f} ({loop / vec:4.1f}x); "
              f"mfcontrol sweep {whole / g.n_members * 1e6:5.0f} us/member")


if __name__ == "__main__":
    main()
