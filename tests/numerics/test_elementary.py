"""log, cos and sin written out in IEEE arithmetic: within an ulp of the C library's (or
of long-double values), exact where the argument reduction makes them exact."""

import math

import numpy as np
from numba import njit

from mfcontrol.numerics import elementary

N = 200_000
#: pi to long-double precision (numpy's pi is a double)
PI = np.arccos(np.longdouble(-1))


@njit(cache=False)
def _apply(which, x):
    out = np.empty(x.size)
    for i in range(x.size):
        if which == 0:
            out[i] = elementary.log_unit(x[i])
        elif which == 1:
            out[i] = elementary.cos_turns(x[i])
        else:
            out[i] = elementary.sin_turns(x[i])
    return out


def test_log_of_a_uniform_variate_is_the_c_librarys_to_an_ulp():
    # the uniform variates' whole range, 2^-54 up to 1 - 2^-54, and the reduction's edges
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.random(N), np.exp(-37.0 * rng.random(N)),
                        [2.0**-54, 0.5, 1 - 2.0**-53, math.sqrt(0.5), np.nextafter(0.5, 1)]])
    got = _apply(0, x)
    assert np.all(np.abs(got - np.log(x)) <= np.spacing(np.abs(np.log(x))))


def test_cos_and_sin_of_turns_are_within_an_ulp_of_one_and_exact_at_quarter_turns():
    rng = np.random.default_rng(1)
    u = np.concatenate([rng.random(N), [1e-300, np.nextafter(0.5, 0)]])
    exact = np.cos(2 * PI * u.astype(np.longdouble))
    assert float(np.max(np.abs(_apply(1, u) - exact))) < 3e-16
    x = rng.uniform(-50.0, 50.0, N)  # any number of turns
    exact = np.sin(2 * PI * x.astype(np.longdouble))
    assert float(np.max(np.abs(_apply(2, x) - exact))) < 3e-16
    quarters = np.arange(9) / 4 - 1.0  # -1, -3/4, ..., 1 turn
    assert list(_apply(1, np.arange(5) / 4)) == [1.0, 0.0, -1.0, 0.0, 1.0]
    assert list(_apply(2, quarters)) == [0.0, 1.0, 0.0, -1.0, 0.0, 1.0, 0.0, -1.0, 0.0]
