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


def test_the_spectral_radius_of_known_matrices():
    rotation = 1.2 * np.array([[0.6, -0.8], [0.8, 0.6]])  # eigenvalues of modulus 1.2
    stack = np.array([rotation, np.diag([0.3, -0.5]), np.zeros((2, 2))])
    np.testing.assert_allclose(region.spectral_radii(stack), [1.2, 0.5, 0.0], rtol=1e-12)


def test_the_batch_is_the_one_loop_analysis():
    filters = [mfcontrol.IPI(alpha=a, kp=kp, ki=1.0, sample_time=H).linear_filter()
               for a in (2.0, 10.0, 50.0) for kp in (0.5, 2.0, 8.0)]
    filters += [mfcontrol.IP(alpha=50.0, kp=5.0, sample_time=H, estimator="algebraic",
                             window=w).linear_filter() for w in (5, 10, 30)]
    filters += [mfcontrol.PID(kp=kp, ki=2.0, kd=0.3, sample_time=H).linear_filter()
                for kp in (0.5, 5.0, 50.0)]
    out = region.loops(filters, LinearLoop(filters[0], PLANT, delay=2), points=2000)
    for j, f in enumerate(filters):
        m = LinearLoop(f, PLANT, delay=2).margins()
        assert out["spectral_radius"][j] == pytest.approx(m["spectral_radius"], rel=1e-9)
        assert bool(out["stable"][j]) is m["stable"]
        if m["stable"]:  # the peaks over two grids of frequencies
            assert out["Ms"][j] == pytest.approx(m["Ms"], rel=1e-3)
            assert out["noise_gain_peak"][j] == pytest.approx(m["noise_gain_peak"], rel=1e-3)
    assert 0 < out["stable"].sum() < len(filters)  # both kinds are in the batch
