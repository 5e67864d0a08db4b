"""The sensor's reading: noise added, then rounding to the quantum's grid."""

import numpy as np

from mfcontrol.elements import noise, sensor


def test_a_quantised_reading_lies_on_the_grid_within_half_a_quantum():
    q = 0.0048828125  # 20 V over 12 bits
    y = np.random.default_rng(1).uniform(-3, 3, 1000)
    s = np.array([sensor.read(noise.GAUSSIAN, 0.01, 5.0, q, k, y[k]) for k in range(y.size)])
    n = s / q
    assert np.array_equal(n, np.round(n))
    clean = y + np.array([noise.sample(noise.GAUSSIAN, 0.01, 5.0, k) for k in range(y.size)])
    assert np.all(np.abs(s - clean) <= q / 2)


def test_without_noise_or_quantum_the_reading_is_y():
    for y in (0.0, -0.0, 1.5, -1e300):
        v = sensor.read(noise.NONE, 0.3, 1.0, 0.0, 4, y)
        assert v == y and np.signbit(v) == np.signbit(y)
