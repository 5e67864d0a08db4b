"""Grids of members: specs, validation, and members equal to single runs."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mfcontrol
from mfcontrol.api.run import batch
from mfcontrol.engine import paper_sweep
from mfcontrol.experiments.cases import resolve_case


def test_specs():
    np.testing.assert_array_equal(batch.parse_spec("k", "1, 2.5,3e-1"), [1.0, 2.5, 0.3])
    np.testing.assert_array_equal(batch.parse_spec("k", "linspace(0, 1, 5)"),
                                  np.linspace(0, 1, 5))
    np.testing.assert_array_equal(batch.parse_spec("k", "logspace(-1,2,4)"),
                                  np.logspace(-1, 2, 4))


@pytest.mark.parametrize("spec", ["", "a,b", "linspace(0,1)", "logspace(0,1,x)",
                                  "linspace(0,inf,3)", "linspace(0,1,0)"])
def test_bad_specs_name_the_key(spec):
    with pytest.raises(mfcontrol.ConfigError, match="controller.alpha"):
        batch.parse_spec("controller.alpha", spec)


@pytest.mark.parametrize("spec, what", [
    ("logspace(0, 400, 3)", "logspace's exponents must be at most 308.25"),
    ("logspace(0,308.3,2)", "logspace's exponents must be at most 308.25"),
    ("linspace(-1e308, 1e308, 3)", "linspace's ends and their difference must be within"),
])
def test_a_range_beyond_the_floats_is_refused_without_numpy_warnings(spec, what):
    """Issue 29: numpy's RuntimeWarning (overflow) printed before the refusal, which named
    the value it made (inf, nan) rather than the spec given."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a warning would raise here, not pass silently
        with pytest.raises(mfcontrol.ConfigError) as info:
            batch.parse_spec("controller.kp", spec)
    assert str(info.value).startswith(f"controller.kp = {spec!r}: gives values beyond the "
                                      "float range")
    assert what in str(info.value)
    np.testing.assert_array_equal(batch.parse_spec("k", "logspace(0, 308, 2)"), [1.0, 1e308])


@pytest.mark.parametrize("items,needle", [
    (["controller.alpah=1,2"], "controller.alpah"), (["sim.h=1e-6,2e-6"], "sim.h"),
    (["controller.law=1,2"], "controller.law"), (["plant.R"], "KEY=SPEC"),
    (["plant.R=1,2", "plant.R=3"], "twice"), ([], "at least one")])
def test_bad_grids(items, needle):
    with pytest.raises(mfcontrol.ConfigError, match=needle):
        batch.parse_grid(items)


def test_axis_values_are_validated():
    _, base = resolve_case("voltage-stable-standard")
    with pytest.raises(mfcontrol.ConfigError, match="controller.alpha"):
        batch.make_grid(base, {"controller.alpha": np.array([1.0, -1.0])})


@pytest.mark.parametrize("key", ["metrics.settle_time", "metrics.settled_tol",
                                 "sim.diverge_above"])
def test_settings_shared_by_all_members_cannot_be_swept(key):
    # the kernel reads them once for every member: sweeping them would silently do nothing
    with pytest.raises(mfcontrol.ConfigError, match="shared"):
        batch.parse_grid([f"{key}=1,2"])


_, BASE = resolve_case("voltage-unstable-variational", {"sim.t_end": 2e-3})
keys = st.sampled_from([("controller.Gamma", (1e-9, 1e-5)), ("controller.kp", (0.5, 4.0)),
                        ("plant.dR", (0.0, 10.0)), ("controller.gamma0", (0.1, 2.0)),
                        ("plant.C", (5e-6, 2e-5)), ("reference.level", (1.0, 4.0))])


@settings(max_examples=15, deadline=None)
@given(picked=st.lists(keys, min_size=1, max_size=3, unique_by=lambda k: k[0]),
       sizes=st.lists(st.integers(1, 3), min_size=3, max_size=3),
       fidelity=st.sampled_from(["published", "paper"]), data=st.data())
def test_every_member_equals_its_single_run(picked, sizes, fidelity, data):
    base = BASE.with_overrides({"fidelity": fidelity})
    axes = {k: np.linspace(lo, hi, n) for (k, (lo, hi)), n in zip(picked, sizes, strict=False)}
    grid = batch.make_grid(base, axes)
    cols = batch.run_grid(grid, chunk=5)
    m = data.draw(st.integers(0, grid.n_members - 1))
    single = mfcontrol.simulate(grid.config(m)).metrics
    for name in batch.METRIC_COLUMNS:
        a, b = cols[name][m], single[name]
        assert a == b or (np.isnan(a) and np.isnan(b)), name


def test_cases_outside_the_papers_kernel_run_in_the_general_engine():
    _, base = resolve_case("first-order-ip-algebraic", {"sim.t_end": 0.5})
    grid = batch.make_grid(base, {"controller.kp": np.array([2.0, 5.0])})
    cols = batch.run_grid(grid)
    assert cols["settled"].tolist() == [True, True]
    assert cols["iae"][1] == mfcontrol.simulate(grid.config(1)).metrics["iae"]
    # with a fast mode of their own, close to the exact runs and not equal to them
    fast = batch.run_grid(grid, fast=True)
    np.testing.assert_allclose(fast["iae"], cols["iae"], rtol=1e-10)
    assert mfcontrol.simulate(grid.config(1), fast=True).metrics["iae"] == fast["iae"][1]


@pytest.mark.parametrize("n", [1, 119, 120, 121, 500])
def test_blocks_are_aligned_and_padded_with_member_0(n):
    a = np.arange(3.0 * n).reshape(3, n) + 1.0
    out = batch._blocks(a, -(-n // paper_sweep.BLOCK))
    assert out.ctypes.data % 64 == 0 and out.flags.c_contiguous
    flat = out.transpose(1, 0, 2).reshape(3, -1)
    np.testing.assert_array_equal(flat[:, :n], a)
    assert (flat[:, n:] == a[:, :1]).all()


@pytest.mark.parametrize("case, axes", [
    ("buck-ipi", {"controller.kp": [1e3, 3e3], "plant.dR": [1.0, 5.0]}),
    ("boost-ipd", {"controller.kd": [0.0, 1e-3], "plant.R": [8.0, 12.0]}),
    ("first-order-ip-algebraic", {"controller.kp": [-40.0, 5.0], "plant.a": [-1.0, 2.0]}),
])
def test_toolkit_grid_members_equal_their_single_runs(case, axes):
    # the general engine runs the members of a range as one batch
    t_end = {"buck-ipi": 5e-3, "boost-ipd": 0.02, "first-order-ip-algebraic": 1.0}[case]
    _, base = resolve_case(case, {"sim.t_end": t_end})
    grid = batch.make_grid(base, {k: np.array(v) for k, v in axes.items()})
    cols = batch.run_grid(grid, chunk=3)
    for m in range(grid.n_members):
        single = mfcontrol.simulate(grid.config(m)).metrics
        for key in ("iae", "ise", "itae", "max_abs_e", "tv_u", "diverged", "n_samples"):
            assert cols[key][m] == single[key], (m, key)


def _grid_keys():
    from mfcontrol.config.options import OPTIONS

    return [o.key for o in OPTIONS if o.kind == "float" and not o.key.startswith(
        ("sweep.", "metrics.")) and o.key not in ("sim.h", "sim.t_end", "sim.diverge_above")]


@pytest.mark.parametrize("case", ["voltage-unstable-variational", "power-standard"])
@pytest.mark.parametrize("fidelity", ["published", "paper"])
def test_axis_translation_equals_one_scenario_per_member(case, fidelity):
    # the whole axis through the translators at once gives every member the arrays of
    # its own configuration, for every key a grid may sweep
    _, base = resolve_case(case, {"fidelity": fidelity, "controller.k_aw": 2e5,
                                  "reference.t_ramp2": 5e-3})
    for key in _grid_keys():
        v0 = base[key]
        values = np.array([v0 * 0.5, v0 * 1.5, v0 + 0.25]) if v0 else np.array([0.1, 0.3])
        try:
            grid = batch.make_grid(base, {key: values})
        except mfcontrol.ConfigError:
            continue  # a value this case does not allow
        scn = batch.build_members(grid, 0, grid.n_members)
        one = mfcontrol.api.run.scenario.build([grid.config(m) for m in range(grid.n_members)])
        for name in ("PP", "X0", "CP", "RP", "ev_k", "ev_val"):
            np.testing.assert_array_equal(getattr(scn, name), getattr(one, name),
                                          err_msg=f"{key} {name}")


def test_a_large_single_axis_sets_up_at_array_speed():
    # 77 us per value before (a scenario built per value); a fixed bound would be a timed
    # test, so this checks the work instead: no configuration is resolved per value
    _, base = resolve_case("voltage-stable-standard")
    import mfcontrol.config.resolve as module

    calls = []
    original = module._filled  # every resolution, by resolve or with_overrides, ends there
    try:
        module._filled = lambda explicit: calls.append(1) or original(explicit)
        base.with_overrides({"controller.alpha": 2.0})  # the patch sees a resolution
        assert calls == [1]
        grid = batch.make_grid(base, {"controller.alpha": np.logspace(0, 2, 4096)})
        batch._cell_changes(grid)
    finally:
        module._filled = original
    assert len(calls) <= 3


def test_an_integer_option_is_a_grid_axis_and_members_equal_single_runs():
    # the algebraic estimator's window M, swept: each member runs with int M, as its own
    # configuration would (a float M was refused with a message that showed the array)
    _, base = resolve_case("first-order-ip-algebraic", {"sim.t_end": 0.5})
    axes = batch.parse_grid(["controller.window=4,10,30", "controller.kp=2,8"])
    grid = batch.make_grid(base, axes)
    cols = batch.run_grid(grid)
    assert list(cols["controller.window"]) == [4, 4, 10, 10, 30, 30]
    for m in range(grid.n_members):
        cfg = grid.config(m)
        assert isinstance(cfg["controller.window"], int)
        single = mfcontrol.simulate(cfg).metrics
        for key in ("iae", "ise", "tv_u", "diverged", "n_samples"):
            assert cols[key][m] == single[key], (m, key)
    with pytest.raises(mfcontrol.ConfigError, match="controller.window = 4.5: must be a whole"):
        batch.make_grid(base, {"controller.window": np.array([4.0, 4.5])})


def test_a_general_grid_builds_each_part_once_per_distinct_setting(monkeypatch):
    # an n x m grid of a plant key and a controller key: n plants and m laws (and one
    # reference) built, not n m configurations; each member still its single run (a
    # range from a member past the first)
    from mfcontrol.api.run import simulate

    _, base = resolve_case("boost-ipd", {"sim.t_end": 0.01})
    axes = {"plant.R": np.linspace(8.0, 12.0, 5), "controller.kp": np.linspace(2e7, 6e7, 6)}
    grid = batch.make_grid(base, axes)
    parts, built = simulate.member_parts(), {}

    def counting(part, build):
        def counted(cfg):
            built[part] = built.get(part, 0) + 1
            return build(cfg)
        return counted

    monkeypatch.setattr(batch, "member_parts",
                        lambda: {part: counting(part, b) for part, b in parts.items()})
    start, stop = 7, grid.n_members
    cols = batch.run_range(grid, start, stop)
    # members 7 .. 29 hold R values 1 .. 4 and every kp; + the probes of who reads a key
    assert built == {"plant": 4 + 1, "law": 6 + 1, "reference": 1 + 1, "elements": 1 + 1}
    for m in range(start, stop):
        single = mfcontrol.simulate(grid.config(m)).metrics
        for key in ("iae", "ise", "itae", "max_abs_e", "tv_u", "diverged", "n_samples"):
            assert cols[key][m - start] == single[key], (m, key)


def test_a_general_grid_whose_keys_cannot_be_split_by_part_runs_a_configuration_per_member(
        monkeypatch):
    from mfcontrol.api.run import simulate

    # keys of two parts, both read by the checks across options (a key read by no part,
    # controller.window under backward differences, is refused as an axis: see
    # tests/config/test_reads.py)
    axes = {"controller.duty_max": [0.8, 0.9], "plant.R": [8.0, 12.0]}

    # a load change, whose check reads plant.R (no change: no check reads it)
    _, base = resolve_case("boost-ipd", {"sim.t_end": 0.005, "plant.change_times": [0.004]})
    grid = batch.make_grid(base, {k: np.array(v, dtype=float) for k, v in axes.items()})
    plain = []
    monkeypatch.setattr(batch, "general_metrics",
                        lambda cfgs, **kw: plain.append(len(cfgs))
                        or simulate.general_metrics(cfgs, **kw))
    cols = batch.run_range(grid, 0, grid.n_members)
    assert plain == [grid.n_members]
    for m in range(grid.n_members):
        assert cols["iae"][m] == mfcontrol.simulate(grid.config(m)).metrics["iae"]


@pytest.mark.parametrize(("case", "points", "axes"), [
    # the paper's kernel: a list of (alpha, kp) points times a load axis
    ("voltage-stable-standard", {"controller.alpha": [5.0, 10.0, 20.0],
                                 "controller.kp": [1.0, 2.0, 3.0]}, {"plant.dR": [1.0, 2.0]}),
    # the general engine: a tuner's population of (kp, ki) times plant variations
    ("motor-noise-pid", {"controller.kp": [0.1, 0.2, 0.4], "controller.ki": [0.3, 0.54, 1.0]},
     {"plant.J": [4e-4, 6e-4]}),
])
def test_a_grid_of_points_times_axes_equals_each_members_single_run(case, points, axes):
    _, cfg = resolve_case(case, {"sim.t_end": 2e-3 if case.startswith("voltage") else 1.0})
    grid = batch.make_grid(cfg, {k: np.array(v) for k, v in {**points, **axes}.items()},
                           points=tuple(points))
    assert grid.shape == (3, 2) and grid.n_members == 6
    cols = batch.run_range(grid, 0, grid.n_members)
    for m in range(grid.n_members):
        i, j = divmod(m, 2)  # the points vary slowest, then the axis
        setting = {**{k: v[i] for k, v in points.items()},
                   **{k: v[j] for k, v in axes.items()}}
        assert {k: cols[k][m] for k in setting} == setting
        single = mfcontrol.simulate(cfg.with_overrides(setting)).metrics
        assert cols["iae"][m] == single["iae"] and cols["tv_u"][m] == single["tv_u"]


def test_points_must_have_values_of_one_length():
    _, cfg = resolve_case("first-order-ip-algebraic")
    with pytest.raises(ValueError, match="one length"):
        batch.make_grid(cfg, {"controller.kp": np.array([1.0, 2.0]),
                              "controller.alpha": np.array([1.0])},
                        points=("controller.kp", "controller.alpha"))


def test_a_grid_of_too_many_members_is_refused_at_once():
    """Two axes of 10^7 values each passed the per-axis bound and then validated in silence
    for minutes towards 10^14 members (issue 14 item 6)."""
    _, base = resolve_case("voltage-stable-standard")
    big = np.linspace(1.0, 2.0, 10_000)
    with pytest.raises(mfcontrol.ConfigError, match=r"^--grid = 'controller.alpha \(10,000\) "
                                                     r"x plant.dR \(10,000\)': 100,000,000 "
                                                     r"members: at most 10,000,000"):
        batch.make_grid(base, {"controller.alpha": big, "plant.dR": big})
    # a tuner's points share one dimension: counted once
    assert batch.make_grid(base, {"controller.alpha": big, "controller.kp": big},
                           points=("controller.alpha", "controller.kp")).n_members == 10_000


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 3), st.lists(st.integers(0, 3), min_size=1, max_size=40),
       st.randoms(use_true_random=False))
def test_the_distinct_settings_of_members_are_numpys_unique_rows(n_keys, rows, rnd):
    # the members' setting indices of n_keys swept keys, one row per member
    at = np.array([[rnd.randrange(4) for _ in range(n_keys)] for _ in rows],
                  dtype=np.int64).reshape(len(rows), n_keys)
    settings, which = batch._distinct_rows(at)
    np.testing.assert_array_equal(settings[which.reshape(-1)], at)
    if n_keys:
        want, want_which = np.unique(at, axis=0, return_inverse=True)
        np.testing.assert_array_equal(settings, want)
        np.testing.assert_array_equal(which.reshape(-1), want_which.reshape(-1))
    else:
        assert settings.shape == (1, 0)
