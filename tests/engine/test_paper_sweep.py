"""The sweep kernel: specialised and generic, exact and fast, and its tiles with the rerun
of a tile in which a member went bad."""

import math

import numpy as np
import pytest

import mfcontrol
from mfcontrol.api.run import batch
from mfcontrol.engine import paper_sweep
from mfcontrol.experiments.cases import resolve_case
from mfcontrol.laws import recursive_ip

ALL = batch.METRIC_COLUMNS  # the loop metrics too


def _same(a, b):
    return a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b))


@pytest.mark.parametrize("specialise", [False, True])
def test_members_going_bad_in_different_tiles_equal_their_single_runs(specialise):
    # the output crosses the bound at a time set by the ramp's slope: in the start-up
    # samples, inside tiles, on a tile's first and last sample, and never
    base = resolve_case("voltage-stable-standard",
                        {"sim.t_end": 3e-3, "sim.diverge_above": 1.2})[1]
    slopes = [1e6, 5e3, 1200 / 1.024, 1200 / 1.279, 1200 / 1.280, 700.0, 400.0, 300.0]
    grid = batch.make_grid(base, {"reference.slope": np.array(slopes)})
    cols = batch.run_grid(grid, specialise=specialise)
    assert cols["diverged"].any() and not cols["diverged"].all()
    for m in range(grid.n_members):
        single = mfcontrol.simulate(grid.config(m)).metrics
        for name in ALL:
            assert _same(cols[name][m], single[name]), (m, name, cols[name][m], single[name])


@pytest.mark.parametrize("case", ["voltage-stable-standard", "voltage-unstable-variational"])
def test_a_member_dead_early_keeps_its_metrics_through_later_plain_tiles(case):
    # blown up within the first tile; 11 more tiles run without the per-sample test (the
    # variational law's adaptation error too: a state row the tiles copy)
    base = resolve_case(case, {
        "sim.t_end": 3e-3, "controller.duty_min": -1e300, "controller.duty_max": 1e300,
        "sim.diverge_above": 1e6})[1]
    grid = batch.make_grid(base, {"controller.kp": np.array([2.0, -5e4])})
    cols = batch.run_grid(grid, specialise=True)
    single = mfcontrol.simulate(grid.config(1)).metrics
    assert cols["diverged"].tolist() == [False, True]
    assert single["n_samples"] < paper_sweep.TILE
    for name in ALL:
        assert _same(cols[name][1], single[name]), name


def test_the_loop_metrics_of_members_through_a_load_change_equal_their_single_runs():
    # a step reference (step metrics) and the load change at 1.5 ms (iae_load), a member
    # that blows up after the change (dead: it keeps what it had) and one that never
    # settles
    base = resolve_case("voltage-stable-standard", {
        "sim.t_end": 3e-3, "plant.change_times": [1.5e-3], "reference.kind": "smooth-step",
        "reference.initial": 0.0, "reference.final": 2.5, "reference.t0": 1e-4,
        "reference.duration": 0.0, "controller.duty_min": -1e300,
        "controller.duty_max": 1e300, "sim.diverge_above": 1e6})[1]
    grid = batch.make_grid(base, {"controller.kp": np.array([2.0, 0.5, -3e2, 40.0])})
    cols = batch.run_grid(grid)
    assert cols["diverged"].any() and np.isfinite(cols["iae_load"]).sum() >= 2
    assert np.isfinite(cols["settling_time"]).any()
    for m in range(grid.n_members):
        single = mfcontrol.simulate(grid.config(m)).metrics
        for name in ALL:
            assert _same(cols[name][m], single[name]), (m, name, cols[name][m], single[name])


def _blow_ups():
    # negative gains blow up at times spread over many tiles, under one shared reference
    base = resolve_case("voltage-stable-standard", {
        "sim.t_end": 3e-3, "controller.duty_min": -1e300, "controller.duty_max": 1e300,
        "sim.diverge_above": 1e6})[1]
    return batch.make_grid(base, {"controller.kp": np.r_[2.0, -np.logspace(0.5, 4.7, 12)]})


@pytest.mark.parametrize("specialise", [False, True])
def test_members_blowing_up_under_a_shared_reference_equal_their_single_runs(specialise):
    # the shared reference's r_{k-1} and max |r| are per-sample scalars in a plain tile
    grid = _blow_ups()
    cols = batch.run_grid(grid, specialise=specialise)
    assert cols["diverged"].sum() == 12
    assert len(set(cols["n_samples"][1:] // paper_sweep.TILE)) >= 6
    for m in range(grid.n_members):
        single = mfcontrol.simulate(grid.config(m)).metrics
        for name in ALL:
            assert _same(cols[name][m], single[name]), (m, name, cols[name][m], single[name])


def test_fast_arithmetic_finds_the_same_blow_ups():
    grid = _blow_ups()
    exact = batch.run_grid(grid)
    fast = batch.run_grid(grid, fast=True)
    for name in ("diverged", "n_samples", "settled"):
        assert fast[name].tolist() == exact[name].tolist(), name
    # the same sample; its time k t_end / n may differ by an ulp (a hoisted reciprocal)
    np.testing.assert_allclose(fast["t_diverge"], exact["t_diverge"], rtol=1e-15, atol=0)
    np.testing.assert_allclose(fast["iae"][0], exact["iae"][0], rtol=1e-12, atol=0)


@pytest.mark.parametrize("axes", [
    {"plant.R": np.array([5.0, 10.0, 20.0])},  # the plant's RK4 map differs per member
    {"plant.L": np.array([0.8e-3, 1e-3, 1.2e-3]), "plant.E": np.array([18.0, 22.0])},
    {"reference.slope": np.array([800.0, 1000.0, 1200.0])},  # a reference per member
])
def test_fast_arithmetic_is_within_1e_12_when_the_plant_or_reference_varies(axes):
    base = resolve_case("voltage-stable-variational")[1]
    grid = batch.make_grid(base, axes)
    exact = batch.run_grid(grid)
    fast = batch.run_grid(grid, fast=True)
    for name in ("iae", "ise", "itae", "max_abs_e", "tv_u", "final_gamma", "max_abs_ref"):
        np.testing.assert_allclose(fast[name], exact[name], rtol=1e-12, atol=0, err_msg=name)
    assert fast["settled"].tolist() == exact["settled"].tolist()


@pytest.mark.parametrize("case", ["voltage-stable-standard", "voltage-stable-variational",
                                  "power-variational"])
def test_fast_arithmetic_is_within_1e_12_of_the_exact_runs(case):
    base = resolve_case(case)[1]
    grid = batch.make_grid(base, {"controller.kp": np.linspace(1.9, 2.1, 3)})
    exact = batch.run_grid(grid)
    fast = batch.run_grid(grid, fast=True)
    for name in ("iae", "ise", "itae", "max_abs_e", "tv_u", "final_gamma"):
        np.testing.assert_allclose(fast[name], exact[name], rtol=1e-12, atol=0, err_msg=name)
    assert fast["settled"].tolist() == exact["settled"].tolist()
    # and it is another arithmetic, not the exact kernel under another name
    assert any(not np.array_equal(fast[n], exact[n]) for n in ("iae", "ise", "tv_u"))


def test_shared_constants_leave_swept_scheduled_and_derived_rows_to_the_data():
    D = np.arange(paper_sweep.P_ROWS * 2, dtype=float).reshape(paper_sweep.P_ROWS, 2)
    kp = paper_sweep.P_CP + 10 + 0  # recursive_ip.KP
    from mfcontrol.laws import recursive_ip
    from mfcontrol.plants import buck
    assert kp == paper_sweep.P_CP + recursive_ip.KP
    c = paper_sweep.shared_constants(D, {kp, paper_sweep.P_PP + buck.R})
    assert math.isnan(c[kp]) and math.isnan(c[paper_sweep.P_PP + buck.R])
    for derived in (buck.A12, buck.A21, buck.A22):  # recomputed from R in the kernel
        assert math.isnan(c[paper_sweep.P_PP + derived])
    assert c[paper_sweep.P_PP + buck.E] == D[paper_sweep.P_PP + buck.E, 0]
    assert all(math.isnan(c[r]) for r in range(paper_sweep.P_ROWS)
               if r not in paper_sweep.PARAM_ROWS)


def test_constants_outside_the_parameters_are_refused():
    bad = [math.nan] * paper_sweep.P_ROWS
    bad[paper_sweep.P_X] = 1.0  # a state row
    with pytest.raises(ValueError, match="constants"):
        paper_sweep.block_kernel(tuple(bad))


def _kp_going_bad_at(base, k):
    """A gain under which u overflows (to inf; |y| stays below 2) at sample k: the
    divergence sample falls as the gain grows, so a bisection on its exponent finds it."""
    def bad_sample(x):
        return mfcontrol.simulate(base.with_overrides({"controller.kp": 10.0 ** x})).metrics[
            "n_samples"]
    lo, hi = 305.3, 306.5
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if bad_sample(mid) > k else (lo, mid)
    assert bad_sample(hi) == k
    return 10.0 ** hi


def test_members_going_bad_on_a_tiles_first_or_last_sample_equal_their_single_runs():
    # plain tiles start at STEADY + m TILE, and at the settling time's sample. Going bad
    # on a tile's first sample once left n_samples at its start-up value; u overflowing on
    # a tile's last sample (y still finite) is seen only in the carried u at the tile's end
    base = resolve_case("voltage-stable-standard",
                        {"sim.t_end": 3e-3, "metrics.settle_time": 1.1e-3})[1]
    t = (np.arange(3000) * 3e-3) / 3000
    settle = int(np.searchsorted(t, 1.1e-3))
    edge = int(recursive_ip.STEADY) + 2 * paper_sweep.TILE
    for k in (edge - 1, edge, settle - 1, settle):
        # alone in its block: a neighbour's rerun of the tile before would mask a miss
        grid = batch.make_grid(base, {"controller.kp": np.array([2.0, _kp_going_bad_at(base, k)])})
        for specialise in (False, True):
            cols = batch.run_grid(grid, specialise=specialise)
            assert cols["n_samples"].tolist() == [3000, k]
            single = mfcontrol.simulate(grid.config(1)).metrics
            for name in ALL:
                assert _same(cols[name][1], single[name]), (k, name, cols[name][1],
                                                             single[name])


_CACHED_SWEEPS = """
import numpy as np
from mfcontrol.api.run import batch
from mfcontrol.experiments.cases import resolve_case
base = resolve_case("voltage-stable-standard", {"sim.t_end": 2e-3})[1]
grid = batch.make_grid(base, {"controller.alpha": np.logspace(0, 2, 8)})
batch.run_grid(grid)  # the generic kernel
batch.run_grid(grid, specialise=True)  # the shared parameters compiled in
batch.run_grid(grid, fast=True)  # the fast mode (specialised too)
"""


def test_a_second_process_loads_the_paper_sweep_kernels_from_the_disk_cache():
    # the tiles closed over plain-njit helpers and the fast kernels over a set of flags,
    # both of which pickle differently in every process: numba's cache key changed and
    # every new process compiled the kernels again (about 8 s of CPU per sweep)
    import os
    import subprocess
    import sys

    def run(debug):
        env = {**os.environ, "NUMBA_DEBUG_CACHE": "1" if debug else "0"}
        return subprocess.run([sys.executable, "-c", _CACHED_SWEEPS], env=env,
                              capture_output=True, text=True, timeout=900, check=True).stdout

    run(False)  # compiles what the machine's cache does not hold yet
    saved = [line for line in run(True).splitlines()
             if "data saved" in line and "paper_sweep" in line]
    assert saved == []


@pytest.mark.parametrize("specialise", [False, True])
def test_multi_rate_members_equal_their_single_runs(specialise):
    # the sum and count of the multi-rate update live in the block's rows: a sweep over
    # adapt_every (and one sharing it, specialised) gives each member's single run
    base = resolve_case("voltage-unstable-variational",
                        {"sim.t_end": 2e-3, "controller.integrator": "second-order",
                         "controller.Gamma": 1e-9})[1]
    grid = batch.make_grid(base, {"controller.adapt_every": np.array([1, 5, 50])})
    cols = batch.run_grid(grid, specialise=specialise)
    finals = set()
    for m in range(grid.n_members):
        single = mfcontrol.simulate(grid.config(m)).metrics
        finals.add(single["final_gamma"])
        for name in ALL:
            assert _same(cols[name][m], single[name]), (m, name, cols[name][m], single[name])
    assert len(finals) == 3  # the rate changes the run
