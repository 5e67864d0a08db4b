"""Many loops at once against the one-loop analysis they vectorise, and the companion
matrices against known roots."""

import numpy as np
import pytest

import mfcontrol
from mfcontrol.analysis import region
from mfcontrol.analysis.loop import LinearLoop

control = pytest.importorskip("control")

H = 0.01
PLANT = control.c2d(control.tf([1.0], [1.0, 3.0, 2.0]), H)


def test_the_spectral_radius_of_known_roots():
    # (1 - 0.5 z^-1)(1 - 0.9 z^-1)(1 + 1.2 z^-1), and a row of another length
    rows = [np.polynomial.polynomial.polyfromroots([0.5, 0.9, -1.2])[::-1],
            np.array([1.0, -0.3, 0.0, 0.0])]
    rows[0] = rows[0] / rows[0][0]
    stacked = np.zeros((2, 4))
    stacked[0], stacked[1] = rows
    np.testing.assert_allclose(region.spectral_radii(stacked), [1.2, 0.3], rtol=1e-12)


def test_the_batch_is_the_one_loop_analysis():
    filters = [mfcontrol.IPI(alpha=a, kp=kp, ki=1.0, sample_time=H).linear_filter()
               for a in (2.0, 10.0, 50.0) for kp in (0.5, 2.0, 8.0)]
    filters += [mfcontrol.IP(alpha=50.0, kp=5.0, sample_time=H, estimator="algebraic",
                             window=w).linear_filter() for w in (5, 10, 30)]
    filters += [mfcontrol.PID(kp=kp, ki=2.0, kd=0.3, sample_time=H).linear_filter()
                for kp in (0.5, 5.0, 50.0)]
    num, den = LinearLoop(filters[0], PLANT, delay=2).plant_polynomials
    out = region.loops(filters, num, den, points=2000)
    for j, f in enumerate(filters):
        m = LinearLoop(f, PLANT, delay=2).margins()
        assert out["spectral_radius"][j] == pytest.approx(m["spectral_radius"], rel=1e-9)
        assert bool(out["stable"][j]) is m["stable"]
        if m["stable"]:  # the peaks over two grids of frequencies
            assert out["Ms"][j] == pytest.approx(m["Ms"], rel=1e-3)
            assert out["noise_gain_peak"][j] == pytest.approx(m["noise_gain_peak"], rel=1e-3)
    assert 0 < out["stable"].sum() < len(filters)  # both kinds are in the batch
