"""Your own ODE whose f or g raises mid-run: an error naming the function and the time in a
single run, a member flagged as diverged at that time in a sweep (never a "settled" run
on made-up numbers), in every path the engine takes (f and g through their addresses,
the one-member step with f compiled in, the vectorised block, the adaptive integrator)."""

import math

import numpy as np
import pytest

import mfcontrol
from mfcontrol import ODE, PlantFunctionError
from mfcontrol.engine import compose


def _f(t, x, u, p, dxdt):
    # raises for the members whose p[0] exceeds 1, once t > 0.5
    if p[0] > 1.0 and t > 0.5:
        raise ValueError("k out of range")
    dxdt[0] = -p[0] * x[0] + u


def _f_returning(t, x, u, p):
    if p[0] > 1.0 and t > 0.5:
        raise ValueError("k out of range")
    return np.array([-p[0] * x[0] + u])


def _g(x, p):
    return x[0]


def _g_raising(x, p):
    if p[0] > 1.0 and x[0] > 0.5:
        raise ZeroDivisionError("no output here")
    return x[0]


def _plant(k=2.0, f=_f, g=_g, integrator="rk4"):
    return ODE(f, g, x0=(0.0,), params={"k": k}, integrator=integrator)


def _ctrl():
    return mfcontrol.IPI(alpha=1.0, kp=5.0, ki=2.0, sample_time=0.01)


PATHS = {
    "addresses": {},  # f and g through their addresses (short runs)
    "member step": {"MEMBER_STEP_WORTH": 0},  # f and g compiled into one step
}


@pytest.mark.parametrize("path", list(PATHS))
@pytest.mark.parametrize("f", [_f, _f_returning], ids=["in-place", "returning"])
def test_a_raising_f_is_an_error_naming_f_and_the_time(path, f, monkeypatch, capfd):
    for name, value in PATHS[path].items():
        monkeypatch.setattr(compose, name, value)
    with pytest.raises(PlantFunctionError, match=r"^f\(t, x, u, p(, dxdt)?\) raised "
                       r"ValueError: k out of range at t = 0\.505 s \(x = \[") as info:
        mfcontrol.simulate_loop(_plant(f=f), _ctrl(), 1.0, t_end=2.0)
    assert isinstance(info.value.__cause__, ValueError)
    # numba printed nothing for every sample (it used to: "Exception ignored")
    assert "Exception ignored" not in capfd.readouterr().err
    # the same plant where f does not raise runs to the end
    assert mfcontrol.simulate_loop(_plant(k=0.5, f=f), _ctrl(), 1.0,
                                   t_end=2.0).metrics["settled"]


def test_a_raising_g_is_an_error_naming_g():
    with pytest.raises(PlantFunctionError, match=r"^g\(x, p\) raised ZeroDivisionError: "
                       r"no output here at t = "):
        mfcontrol.simulate_loop(_plant(g=_g_raising), _ctrl(), 1.0, t_end=2.0)


def test_a_raising_f_under_the_adaptive_integrator_is_an_error():
    with pytest.raises(PlantFunctionError, match="k out of range at t = 0.5"):
        mfcontrol.simulate_loop(_plant(integrator="rk45"), _ctrl(), 1.0, t_end=2.0)


def test_an_f_that_returns_nan_is_a_flagged_divergence_not_an_error():
    def f(t, x, u, p, dxdt):
        dxdt[0] = math.nan if t > 0.5 else -x[0] + u

    res = mfcontrol.simulate_loop(ODE(f, _g, x0=(0.0,)), _ctrl(), 1.0, t_end=2.0)
    assert res.metrics["diverged"] and not res.metrics["settled"]
    assert res.metrics["t_diverge"] == pytest.approx(0.51)


@pytest.mark.parametrize("vectorise", [False, True], ids=["member loop", "vectorised"])
@pytest.mark.parametrize("f", [_f, _f_returning], ids=["in-place", "returning"])
@pytest.mark.usefixtures("vectorised_kernels")  # compiled once a run
def test_in_a_sweep_the_raising_members_diverge_and_the_others_keep_their_bits(vectorise, f):
    ks = [0.5, 2.0, 0.8, 3.0]
    sw = mfcontrol.sweep(_plant(f=f), _ctrl(), 1.0, grid={"plant.k": ks}, t_end=2.0,
                         vectorise=vectorise)
    table = sw.table
    assert list(table["diverged"]) == [False, True, False, True]
    assert list(table["settled"]) == [True, False, True, False]
    np.testing.assert_array_equal(table["t_diverge"][[1, 3]], [0.51, 0.51])
    for j in (0, 2):  # bit for bit the single run of a plant that never raises
        one = mfcontrol.simulate_loop(_plant(k=ks[j], f=f), _ctrl(), 1.0, t_end=2.0)
        assert one.metrics["iae"] == table["iae"][j]


@pytest.mark.parametrize("vectorise", [False, True], ids=["member loop", "vectorised"])
@pytest.mark.usefixtures("vectorised_kernels")  # compiled once a run
def test_in_a_sweep_a_raising_g_makes_its_member_diverge(vectorise):
    sw = mfcontrol.sweep(_plant(g=_g_raising), _ctrl(), 1.0, grid={"plant.k": [0.5, 2.0]},
                         t_end=2.0, vectorise=vectorise)
    assert list(sw.table["diverged"]) == [False, True]
