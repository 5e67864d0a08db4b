"""The counter-based noise: statistics within their sampling error, reproducible by seed,
independent of the order samples are drawn in."""

import math

import numpy as np
import pytest
from numba import njit

from mfcontrol.elements import noise

N = 200_000


@njit(cache=False)
def _draw(kind, std, seed, n):
    out = np.empty(n)
    for k in range(n):
        out[k] = noise.sample(kind, std, seed, k)
    return out


@pytest.mark.parametrize("kind", [noise.GAUSSIAN, noise.UNIFORM])
def test_mean_and_standard_deviation_within_their_sampling_error(kind):
    std = 0.5
    x = _draw(kind, std, 12345.0, N)
    # 4.5 standard errors: a false alarm about once in 150,000 runs
    assert abs(x.mean()) < 4.5 * std / math.sqrt(N)
    # the standard error of the sample standard deviation: sigma sqrt((kurtosis - 1)/4n)
    kurtosis = 3.0 if kind == noise.GAUSSIAN else 1.8
    assert abs(x.std() - std) < 4.5 * std * math.sqrt((kurtosis - 1) / (4 * N))


def test_uniform_noise_lies_on_its_interval_and_gaussian_tails_are_gaussian():
    std = 2.0
    u = _draw(noise.UNIFORM, std, 7.0, N)
    assert np.all(np.abs(u) <= std * math.sqrt(3.0))
    g = _draw(noise.GAUSSIAN, std, 7.0, N)
    beyond = np.mean(np.abs(g) > 2 * std)  # P(|z| > 2) = 0.0455
    assert abs(beyond - 0.0455) < 4.5 * math.sqrt(0.0455 * 0.9545 / N)


def test_the_same_seed_gives_the_same_noise_and_another_seed_unrelated_noise():
    a = _draw(noise.GAUSSIAN, 1.0, 3.0, N)
    assert np.array_equal(a, _draw(noise.GAUSSIAN, 1.0, 3.0, N))
    b = _draw(noise.GAUSSIAN, 1.0, 4.0, N)
    assert abs(np.corrcoef(a, b)[0, 1]) < 4.5 / math.sqrt(N)
    # successive samples are uncorrelated too (white noise)
    assert abs(np.corrcoef(a[:-1], a[1:])[0, 1]) < 4.5 / math.sqrt(N)


def test_a_sample_depends_on_seed_and_index_only():
    forward = _draw(noise.UNIFORM, 1.0, 99.0, 50)
    backward = [noise.sample(noise.UNIFORM, 1.0, 99.0, k) for k in range(49, -1, -1)]
    assert np.array_equal(forward, backward[::-1])


def test_no_noise_is_zero_and_uniform_variates_stay_inside_the_open_interval():
    assert noise.sample(noise.NONE, 5.0, 1.0, 10) == 0.0
    largest_seed = noise.MAX_SEED - 1
    for k in (0, 1, 2**40):
        v = noise.uniform(largest_seed, k, 1)
        assert 0.0 < v < 1.0

