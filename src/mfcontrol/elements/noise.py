"""Measurement noise as a function of (seed, sample): counter-based, no generator state.

Sample k of the noise with seed s is a hash of (s, k) (SplitMix64's finaliser, the
mixing function of Steele, Lea and Flood, 2014), turned into a uniform variate on (0, 1)
from its top 53 bits and into a Gaussian one by the Box-Muller transform. Nothing is
carried from sample to sample, so a member of a sweep, its single run, a sweep resumed
from its finished chunks and a run on another Dask worker draw the same noise for the
same seed, and
members never share a stream by accident (a different seed gives an unrelated sequence).
"""

import math

import numpy as np

from .._jit import step_jit

NONE = 0.0
GAUSSIAN = 1.0
UNIFORM = 2.0
KINDS = {"none": NONE, "gaussian": GAUSSIAN, "uniform": UNIFORM}

#: seeds are whole numbers from 0 to this (exclusive): they travel as float64 rows
MAX_SEED = 2**53

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
_TWO = np.uint64(2)


@step_jit
def _mix(z):
    """SplitMix64's finaliser: a bijection of uint64 whose outputs pass BigCrush."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@step_jit
def uniform(seed, k, stream):
    """A uniform variate on the open interval (0, 1): draw ``stream`` (0 or 1) of sample
    k with this seed (seed and k whole numbers >= 0, given as floats or integers)."""
    key = _mix(np.uint64(seed) * _GOLDEN) + np.uint64(k) * _TWO + np.uint64(stream)
    z = _mix(key * _GOLDEN)
    return (float(z >> _S11) + 0.5) * (1.0 / 9007199254740992.0)


# log and cos of the Gaussian transform, written out in IEEE arithmetic (the polynomials of
# fdlibm / musl, accurate to about an ulp): a loop over the members of a sweep's block
# turns them into vector instructions, where calls to the C library's log and cos run
# one member at a time (measured: most of a noisy loop's time), and every member keeps
# the bits of its single run, which calls the same functions
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_LG1, _LG2, _LG3, _LG4, _LG5, _LG6, _LG7 = (
    6.666666666666735130e-01, 3.999999999940941908e-01, 2.857142874366239149e-01,
    2.222219843214978396e-01, 1.818357216161805012e-01, 1.531383769920937332e-01,
    1.479819860511658591e-01)
_C1, _C2, _C3, _C4, _C5, _C6 = (
    4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05,
    -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11)
_S1, _S2, _S3, _S4, _S5, _S6 = (
    -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04,
    2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10)


@step_jit
def log_unit(x):
    """ln x for x in [2^-63, 1) (a uniform variate): x = 2^e m with m in [sqrt(2)/2,
    sqrt(2)) by exact scalings by powers of two (a binary search of selects, no bit
    manipulation), then fdlibm's ln m = f - (f^2/2 - s (f^2/2 + R(s^2))), s = f / (2 + f),
    f = m - 1."""
    m = x
    e = 0.0
    for step in (32, 16, 8, 4, 2, 1):
        scale = 2.0 ** step
        low = m * scale < 2.0
        m = m * scale if low else m
        e = e - step if low else e
    big = m > 1.4142135623730951
    m = 0.5 * m if big else m
    e = e + 1.0 if big else e
    f = m - 1.0  # exact (Sterbenz)
    s = f / (2.0 + f)
    z = s * s
    w = z * z
    t1 = w * (_LG2 + w * (_LG4 + w * _LG6))
    t2 = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7)))
    hfsq = 0.5 * f * f
    return e * _LN2_HI - ((hfsq - (s * (hfsq + t1 + t2) + e * _LN2_LO)) - f)


@step_jit
def cos_turns(u):
    """cos(2 pi u) for u in [0, 1]: the argument reduced in turns by exact subtractions
    (symmetries about 1/2 and 1/4, and cos(2 pi t) = sin(2 pi (1/4 - t)) beyond 1/8), then
    musl's kernels of cos and sin on [0, pi/4]."""
    t = 1.0 - u if u > 0.5 else u
    neg = t > 0.25
    t = 0.5 - t if neg else t
    use_sin = t > 0.125
    x = 2.0 * math.pi * (0.25 - t if use_sin else t)
    z = x * x
    w = z * z
    r = z * (_C1 + z * (_C2 + z * _C3)) + w * w * (_C4 + z * (_C5 + z * _C6))
    hz = 0.5 * z
    c0 = 1.0 - hz
    c = c0 + (((1.0 - c0) - hz) + z * r)
    rs = _S2 + z * (_S3 + z * _S4) + z * w * (_S5 + z * _S6)
    v = z * x
    sn = x + v * (_S1 + z * rs)
    value = sn if use_sin else c
    return -value if neg else value


@step_jit
def sample(kind, std, seed, k):
    """Noise sample k: 0 for ``NONE``; zero mean and standard deviation ``std`` for
    ``GAUSSIAN`` (Box-Muller) and ``UNIFORM`` (on [-std sqrt 3, std sqrt 3])."""
    if kind == GAUSSIAN:
        u1 = uniform(seed, k, 0)
        u2 = uniform(seed, k, 1)
        return std * math.sqrt(-2.0 * log_unit(u1)) * cos_turns(u2)
    if kind == UNIFORM:
        return std * math.sqrt(3.0) * (2.0 * uniform(seed, k, 0) - 1.0)
    return 0.0
