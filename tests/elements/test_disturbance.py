"""d(t) of every kind against its formula, and a table against numpy.interp."""

import numpy as np
import pytest

from mfcontrol.api.model.elements import Disturbance, column
from mfcontrol.elements import disturbance, layout


def _values(dist: Disturbance, t: np.ndarray) -> np.ndarray:
    DP = column(disturbance_=dist)[layout.DISTURBANCE:]
    return np.array([disturbance.value(DP, 0, float(tk)) for tk in t])


T = np.linspace(0.0, 2.0, 401)


@pytest.mark.parametrize(("dist", "expected"), [
    (Disturbance("step", amplitude=-0.5, t0=0.7), lambda t: np.where(t >= 0.7, -0.5, 0.0)),
    (Disturbance("ramp", amplitude=3.0, t0=0.5), lambda t: np.where(t >= 0.5, 3 * (t - 0.5), 0)),
    # the turns f (t - t0) as the double they are, their sine to long-double precision
    # (numpy's 2 pi f (t - t0) rounds the angle differently: about 1e-15 apart)
    (Disturbance("sine", amplitude=2.0, t0=0.25, frequency=5.0),
     lambda t: np.where(t >= 0.25, 2 * np.sin(2 * np.arccos(np.longdouble(-1))
                                              * (5 * (t - 0.25)).astype(np.longdouble)),
                        0.0).astype(float)),
    (Disturbance(), lambda t: np.zeros_like(t)),
])
def test_each_kind_is_its_formula(dist, expected):
    np.testing.assert_allclose(_values(dist, T), expected(T), rtol=0, atol=1e-15)


def test_a_table_interpolates_as_numpy_does():
    times, values = [0.2, 0.5, 0.5, 1.0, 1.7], [1.0, -2.0, 4.0, 4.0, 0.0]
    got = _values(Disturbance("table", times=times, values=values), T)
    keep = ~np.isclose(T, 0.5)  # where the table jumps, numpy takes either side
    np.testing.assert_allclose(got[keep], np.interp(T, times, values)[keep], rtol=0,
                               atol=1e-14)
    one = _values(Disturbance("table", times=[1.0], values=[3.0]), T)
    assert np.all(one == 3.0)
