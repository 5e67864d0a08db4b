"""The loop's elements in the compiled engine: the delay identities, quantisation, rate
limit, disturbances, the plant's substeps against a run at the fine step, the step and
load metrics against the trajectory, and sweeps of the new keys bit for bit."""

import hashlib
import math

import numpy as np
import pytest

import mfcontrol
from mfcontrol import (
    IPI,
    LTI,
    PID,
    Actuator,
    ConfigError,
    DCMotor,
    Disturbance,
    FirstOrder,
    Sensor,
)
from mfcontrol.api.run import batch
from mfcontrol.experiments.cases import resolve_case


def _ipi(h=1e-3):
    return IPI(alpha=50.0, kp=20.0, ki=50.0, sample_time=h, output_limits=(-24, 24))


def _run(**kw):
    kw.setdefault("t_end", 0.5)
    return mfcontrol.simulate_loop(DCMotor(), _ipi(), 60.0, **kw)


@pytest.mark.parametrize("d", [1, 7])
def test_an_actuator_delay_shifts_u_by_whole_samples(d):
    s = _run(actuator=Actuator(delay=d)).signals
    assert np.array_equal(s["u_plant"][d:], s["u"][:-d])
    assert np.all(s["u_plant"][:d] == 0.0)
    assert np.array_equal(s["y_meas"], s["y"])


@pytest.mark.parametrize("d", [1, 7])
def test_a_sensor_delay_shifts_y_by_whole_samples(d):
    s = _run(sensor=Sensor(delay=d), t_end=0.5).signals
    assert np.array_equal(s["y_meas"][d:], s["y"][:-d])
    assert np.all(s["y_meas"][:d] == s["y"][0])
    assert np.array_equal(s["u_plant"], s["u"])


#: the general engine's runs before the loop's elements existed (commit 69445f7): y, u and
#: u_raw hashed, IAE and TV(u) in full; the elements at their defaults change no bit
BEFORE = [
    ("buck-ipi", {"sim.t_end": 2e-3}, "408b641fc0ef598f", 1.4324317834225378e-06,
     0.17166357147933642),
    # the estimators' old discretisation and start, by name: the same bits as before
    ("boost-ipd", {"sim.t_end": 0.01, "controller.kernel": "trapezoid"}, "9f81486ee883cc04",
     0.0034817240776807146, 0.1224536098012948),
    ("first-order-ip-algebraic", {"sim.t_end": 1.0, "controller.kernel": "trapezoid",
                                  "controller.startup": "backward-difference"},
     "69a23bee0ad31ff4",
     0.003571969976349426, 6.33029937748667),
]


@pytest.mark.parametrize(("case", "over", "digest", "iae", "tv"), BEFORE,
                         ids=[b[0] for b in BEFORE])
def test_without_elements_the_general_engine_runs_as_before(case, over, digest, iae, tv):
    r = mfcontrol.run_case(case, over)
    got = hashlib.sha256(np.concatenate([r.signals["y"], r.signals["u"],
                                         r.signals["u_raw"]]).tobytes()).hexdigest()[:16]
    assert (got, r.metrics["iae"], r.metrics["tv_u"]) == (digest, iae, tv)
    assert np.array_equal(r.signals["y_meas"], r.signals["y"])
    assert np.array_equal(r.signals["u_plant"], r.signals["u"])


def test_noise_is_what_the_seed_draws_and_the_measurement_lies_on_the_quantum_grid():
    q = 0.25
    a = _run(sensor=Sensor("gaussian", 0.5, seed=4, quantum=q))
    b = _run(sensor=Sensor("gaussian", 0.5, seed=4, quantum=q))
    c = _run(sensor=Sensor("gaussian", 0.5, seed=5, quantum=q))
    assert np.array_equal(a.signals["y_meas"], b.signals["y_meas"])
    assert not np.array_equal(a.signals["y_meas"], c.signals["y_meas"])
    n = a.signals["y_meas"] / q
    assert np.array_equal(n, np.round(n))
    # the noise is the sensor's: the plant's y is not on the grid
    assert not np.array_equal(a.signals["y"] / q, np.round(a.signals["y"] / q))


def test_a_rate_limit_bounds_every_step_of_the_plant_input():
    rate, h = 200.0, 1e-3
    s = _run(actuator=Actuator(rate_limit=rate)).signals
    steps = np.abs(np.diff(np.concatenate([[0.0], s["u_plant"]])))
    assert steps.max() <= rate * h * (1 + 1e-12)
    assert steps.max() == pytest.approx(rate * h)  # it binds
    assert np.any(s["u_plant"] != s["u"])


def test_an_input_disturbance_adds_after_the_actuator_and_an_output_one_to_y():
    dist = Disturbance("step", amplitude=-2.0, t0=0.2, at="input")
    s = _run(disturbance=dist, actuator=Actuator(delay=2)).signals
    t = np.arange(s["u"].size) * 1e-3
    expected = np.concatenate([[0.0, 0.0], s["u"][:-2]]) + np.where(t >= 0.2, -2.0, 0.0)
    assert np.array_equal(s["u_plant"], expected)
    out = _run(disturbance=Disturbance("sine", amplitude=3.0, frequency=10.0, at="output"))
    d = 3.0 * np.sin(2 * math.pi * 10.0 * out.time)
    np.testing.assert_allclose(out.signals["y"] - out.states["omega"], d, atol=1e-12)
    assert np.array_equal(out.signals["y_meas"], out.signals["y"])


@pytest.mark.parametrize("plant", [
    DCMotor(),
    FirstOrder(-3.0, 2.0, integrator="exact"),
    LTI([[0.0, 1.0], [-40.0, -2.0]], [[0.0], [40.0]], [[1.0, 0.0]], integrator="exact"),
    DCMotor(integrator="rk45"),
], ids=["rk4", "first-order exact", "LTI exact", "rk45"])
def test_substeps_integrate_at_the_fine_step_on_its_grid(plant):
    """substeps = m at h is the run at h / m sampled every m-th sample when the
    controller's output is the same: here pinned by its limits."""
    m, h, t_end = 5, 1e-3, 0.2
    kw = dict(t_end=t_end, changes=[mfcontrol.Change(0.1, list(plant.params)[0], 1.0,
                                                     add=True)])

    def pinned(step):
        return PID(1.0, sample_time=step, output_limits=(0.7, 0.7))

    coarse = mfcontrol.simulate_loop(plant, pinned(h), 1.0, h=h, substeps=m, **kw)
    fine = mfcontrol.simulate_loop(plant, pinned(h / m), 1.0, h=h / m, **kw)
    assert np.array_equal(coarse.signals["y"], fine.signals["y"][::m])
    for name in coarse.states:
        assert np.array_equal(coarse.states[name], fine.states[name][::m])


def test_the_loop_metrics_are_those_of_the_trajectory():
    res = _run(t_end=2.0, changes=[mfcontrol.Change(1.0, "load", 0.05)],
               sensor=Sensor("uniform", 0.2, seed=2))
    m, s, t, h = res.metrics, res.signals, res.time, 1e-3
    y, r, u = s["y"], s["y_ref"], s["u"]
    assert m["energy_u"] == pytest.approx(np.sum(u * u * h), rel=1e-12)
    e = np.abs(y - r)
    assert m["iae_load"] == pytest.approx(np.sum(e[t >= 1.0] * h), rel=1e-12)
    # a step from the motor at rest (0) to 60 at t = 0, judged until the load step
    w = t < 1.0
    assert m["overshoot"] == pytest.approx(max(0.0, (y[w] - 60).max()) / 60 * 100, rel=1e-12)
    t10, t90 = t[w][np.argmax(y[w] >= 6.0)], t[w][np.argmax(y[w] >= 54.0)]
    assert m["rise_time"] == pytest.approx(t90 - t10, abs=1e-12)
    outside = np.flatnonzero(w & (np.abs(y - 60) > 0.02 * 60))
    assert m["settling_time"] == pytest.approx(t[outside[-1]] + h, abs=1e-12)
    final = t >= 2.0 * 0.8
    assert m["steady_state_error"] == pytest.approx(np.mean((r - y)[final]), rel=1e-10)


def test_step_metrics_are_nan_without_a_step_and_a_run_that_never_settles_says_so():
    ramp = mfcontrol.simulate_loop(DCMotor(), _ipi(), lambda t: 10 * t, t_end=0.5)
    assert all(math.isnan(ramp.metrics[k]) for k in ("overshoot", "rise_time",
                                                     "settling_time", "iae_load"))
    slow = mfcontrol.simulate_loop(DCMotor(), PID(0.01, sample_time=1e-3), 60.0, t_end=0.2)
    assert math.isnan(slow.metrics["settling_time"]) and slow.metrics["overshoot"] == 0.0


def test_the_python_driver_refuses_elements_in_one_line():
    class Mine:
        def __call__(self, y, setpoint=0.0):
            return 0.0

    with pytest.raises(ConfigError, match="^sensor = Sensor.*only the compiled engine runs"):
        mfcontrol.simulate_loop(DCMotor(), Mine(), 1.0, t_end=0.1, h=1e-3,
                                sensor=Sensor(delay=1))
    with pytest.raises(ConfigError, match="^sensor.delay = 100: must be fewer samples"):
        _run(t_end=0.1, sensor=Sensor(delay=100))
    with pytest.raises(ConfigError, match="^substeps = 0: must be a whole number > 0"):
        _run(substeps=0)
    with pytest.raises(ConfigError, match="^sensor.noise = 'pink': must be one of"):
        Sensor("pink")


SWEEPS = [
    # a paper case: the ideal member runs the paper's kernel alone, the sweep the general
    # engine (both fold every metric)
    ("voltage-stable-standard", {"sensor.delay": [0.0, 1.0], "sim.substeps": [1.0, 2.0]}),
    ("motor-noise-ipi", {"sensor.seed": [1.0, 2.0, 3.0], "sensor.noise_std": [0.0, 0.5]}),
    ("motor-noise-pid", {"actuator.delay": [0.0, 3.0], "actuator.rate_limit": [0.0, 500.0]}),
    ("buck-50khz-noise", {"sim.substeps": [1.0, 4.0], "sensor.quantum": [0.0, 0.01]}),
    ("motor-noise-ipi-algebraic", {"disturbance.amplitude": [0.5, -1.0]}),
]


@pytest.mark.parametrize(("case", "axes"), SWEEPS, ids=[c for c, _ in SWEEPS])
def test_sweeps_of_the_new_keys_equal_their_single_runs(case, axes):
    over = {"sim.t_end": 0.6} if case.startswith("motor") else {"sim.t_end": 0.002}
    if "disturbance.amplitude" in axes:
        over.update({"disturbance.kind": "step", "disturbance.t0": 0.3})
    _, base = resolve_case(case, over)
    grid = batch.make_grid(base, {k: np.array(v) for k, v in axes.items()})
    cols = batch.run_grid(grid)
    for m in range(grid.n_members):
        single = mfcontrol.simulate(grid.config(m)).metrics
        for name in batch.METRIC_COLUMNS:
            a, b = cols[name][m], single[name]
            assert a == b or (a != a and b != b), (m, name, a, b)


def test_a_step_window_without_samples_gives_no_step_metrics():
    # the load step at t = 0 comes before the reference's step at 0.2 s
    _, cfg = resolve_case("motor-noise-pid", {"sim.t_end": 0.5, "disturbance.kind": "step",
                                              "disturbance.amplitude": -1.0})
    m = mfcontrol.simulate(cfg).metrics
    assert all(math.isnan(m[k]) for k in ("overshoot", "rise_time", "settling_time"))
    assert math.isfinite(m["iae_load"])


def test_an_input_disturbance_is_evaluated_at_every_substep():
    """With substeps, a sine at the input changes within a control period: the run equals
    the run at the fine step whose controller is pinned, sample for sample."""
    m, h = 4, 1e-3
    dist = Disturbance("sine", amplitude=0.3, frequency=40.0)

    def run(step, sub):
        return mfcontrol.simulate_loop(
            DCMotor(), PID(1.0, sample_time=step, output_limits=(2.0, 2.0)), 1.0, h=step,
            t_end=0.1, substeps=sub, disturbance=dist)

    coarse, fine = run(h, m), run(h / m, 1)
    assert np.array_equal(coarse.states["omega"], fine.states["omega"][::m])


def test_the_object_sweep_takes_elements_and_equals_its_single_runs():
    plant, ctrl = DCMotor(), _ipi()
    sw = mfcontrol.sweep(plant, ctrl, 60.0, t_end=0.5,
                         sensor=Sensor("gaussian", 0.5), actuator=Actuator(rate_limit=5e3),
                         grid={"sensor.seed": [1, 2], "actuator.delay": [0, 3]})
    table = sw.to_pandas()
    assert len(table) == 4 and table["overshoot"].notna().all()
    for m in range(4):  # each member's single run, built here from its values
        seed, d = int(table["sensor.seed"][m]), int(table["actuator.delay"][m])
        res = mfcontrol.simulate_loop(DCMotor(), _ipi(), 60.0, t_end=0.5,
                                      sensor=Sensor("gaussian", 0.5, seed=seed),
                                      actuator=Actuator(delay=d, rate_limit=5e3))
        for name in batch.METRIC_COLUMNS:
            a, b = table[name][m], res.metrics[name]
            assert a == b or (a != a and b != b), (m, name, a, b)
    assert len(set(table["iae"])) == 4
    with pytest.raises(ConfigError, match="not a numeric option of the Sensor"):
        mfcontrol.sweep(plant, ctrl, 60.0, t_end=0.1, grid={"sensor.noise": [1.0]})


@pytest.mark.parametrize(("grid", "why", "unread"), [
    ({"sensor.seed": [1, 2]}, "sensor.noise is none",
     'sensor.seed = \\[1.0, 2.0\\]: not read with sensor.noise = "none": set sensor.noise = '
     '"gaussian" or "uniform", or vary another key'),
    ({"disturbance.amplitude": [1.0, 2.0]}, "disturbance.kind is none",
     'disturbance.amplitude = \\[1.0, 2.0\\]: not read with disturbance.kind = "none": set '
     'disturbance.kind = "step", "ramp" or "sine", or vary another key'),
])
def test_sweeping_an_element_option_without_effect_is_refused(grid, why, unread):
    with pytest.raises(ConfigError, match=f"has no effect here \\({why}\\)"):
        mfcontrol.sweep(DCMotor(), _ipi(), 60.0, t_end=0.1, grid=grid)
    _, base = resolve_case("motor-noise-pid", {"sensor.noise": "none"})
    with pytest.raises(ConfigError, match=unread):
        batch.make_grid(base, {k: np.array(v, dtype=float) for k, v in grid.items()})


def test_edge_values_of_the_elements():
    # a quantum so small that y / quantum overflows: rounding is the identity there
    tiny = _run(t_end=0.05, sensor=Sensor(quantum=1e-320))
    assert not tiny.metrics["diverged"]
    assert np.array_equal(tiny.signals["y_meas"], tiny.signals["y"])
    # NumPy integers and floats are numbers
    s = Sensor("uniform", np.float32(0.5), seed=np.int64(3), delay=np.int64(2))
    assert (s.seed, s.delay) == (3, 2) and isinstance(s.noise_std, float)
    assert _run(t_end=0.05, sensor=s, substeps=np.int64(2)).metrics["n_samples"] == 50
    # at most 1e8 plant steps in a run
    with pytest.raises(ConfigError, match="^substeps = 20000: must be a whole number from "
                                          "1 to 10,000"):
        _run(t_end=10.0, substeps=20_000)
    # the refusal names the element that acts, not an idle one before it
    class Mine:
        def __call__(self, y, setpoint=0.0):
            return 0.0

    with pytest.raises(ConfigError, match="^actuator = Actuator"):
        mfcontrol.simulate_loop(DCMotor(), Mine(), 1.0, t_end=0.1, h=1e-3, sensor=Sensor(),
                                actuator=Actuator(delay=2))


def test_a_load_change_no_sample_sees_gives_no_load_iae():
    # after the last sample (0.499 s) but before t_end
    res = _run(changes=[mfcontrol.Change(0.4995, "load", 0.05)])
    assert math.isnan(res.metrics["iae_load"])


# ---------------------------------------------------------------------------------------
# issue 28 item 1: an option the element would not read is refused, as a case's key is;
# a noise level given means gaussian noise
# ---------------------------------------------------------------------------------------


def test_a_noise_level_given_means_gaussian_noise():
    # Sensor(noise_std=0.5) had noise "none": the run was the nominal one
    assert Sensor(noise_std=0.5).noise == "gaussian"
    assert Sensor().noise == "none" and Sensor(noise="uniform", noise_std=0.1).noise == "uniform"
    quiet, noisy = _run(t_end=0.5), _run(t_end=0.5, sensor=Sensor(noise_std=0.5))
    assert not np.array_equal(quiet.signals["y_meas"], noisy.signals["y_meas"])
    assert mfcontrol.resolve({"sensor.noise_std": 0.5})["sensor.noise"] == "gaussian"
    assert mfcontrol.resolve({"sensor.noise_std": 0.5, "sensor.noise": "uniform"})[
        "sensor.noise"] == "uniform"


@pytest.mark.parametrize(("make", "line"), [
    (lambda: Sensor(seed=3), 'sensor.seed = 3: not read with sensor.noise = "none": set '
     'sensor.noise = "gaussian" or "uniform", or remove it'),
    (lambda: Sensor(noise="none", noise_std=0.5), 'sensor.noise_std = 0.5: not read with '
     'sensor.noise = "none": set sensor.noise = "gaussian" or "uniform", or remove it'),
    (lambda: Disturbance(amplitude=1.0), 'disturbance.amplitude = 1.0: not read with '
     'disturbance.kind = "none": set disturbance.kind = "step", "ramp" or "sine", or '
     'remove it'),
    (lambda: Disturbance("step", amplitude=1.0, frequency=3.0), 'disturbance.frequency = '
     '3.0: not read with disturbance.kind = "step": set disturbance.kind = "sine", or '
     'remove it'),
    (lambda: Disturbance("step", amplitude=1.0, times=[1.0]), 'disturbance.times = [1.0]: '
     'not read by this run (table: times (s), nondecreasing): remove it'),
    (lambda: Disturbance(at="output"), "disturbance.at = 'output': not read with "
     'disturbance.kind = "none": set disturbance.kind = "step", "ramp" or "sine", or '
     'remove it'),
])
def test_an_option_the_element_would_not_read_is_refused(make, line):
    with pytest.raises(ConfigError) as info:
        make()
    assert str(info.value) == line
