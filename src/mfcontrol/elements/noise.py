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
from ..numerics import elementary

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
def seed_key(seed):
    """What sample k's draws of a seed start from (the hash of the seed alone): computed
    once per member, not once per sample, where a loop draws many samples of one seed."""
    return _mix(np.uint64(seed) * _GOLDEN)


@step_jit
def uniform_keyed(key0, k, stream):
    """:func:`uniform` from the seed's :func:`seed_key`."""
    z = _mix((key0 + np.uint64(k) * _TWO + np.uint64(stream)) * _GOLDEN)
    return (float(z >> _S11) + 0.5) * (1.0 / 9007199254740992.0)


@step_jit
def uniform(seed, k, stream):
    """A uniform variate on the open interval (0, 1): draw ``stream`` (0 or 1) of sample
    k with this seed (seed and k whole numbers >= 0, given as floats or integers)."""
    return uniform_keyed(seed_key(seed), k, stream)


@step_jit
def unit(kind, key0, k):
    """Sample k of the noise of standard deviation 1 as two factors (a, b), for the seed
    whose :func:`seed_key` is ``key0``: sqrt(-2 ln u1) and cos(2 pi u2) for
    ``GAUSSIAN`` (Box-Muller), 2 u - 1 and 1 for ``UNIFORM``, zeros for ``NONE``.
    :func:`scaled` turns them into the sample; members that share a seed share them
    (a sweep's block draws them once per sample)."""
    if kind == GAUSSIAN:
        u1 = uniform_keyed(key0, k, 0)
        u2 = uniform_keyed(key0, k, 1)
        return math.sqrt(-2.0 * elementary.log_unit(u1)), elementary.cos_turns(u2)
    if kind == UNIFORM:
        return 2.0 * uniform_keyed(key0, k, 0) - 1.0, 1.0
    return 0.0, 0.0


@step_jit
def scaled(kind, std, a, b):
    """The noise sample of standard deviation ``std`` from its :func:`unit` factors, in
    the order of operations of :func:`sample` (bit for bit)."""
    if kind == GAUSSIAN:
        return std * a * b
    if kind == UNIFORM:
        return std * math.sqrt(3.0) * a
    return 0.0


@step_jit
def sample(kind, std, seed, k):
    """Noise sample k: 0 for ``NONE``; zero mean and standard deviation ``std`` for
    ``GAUSSIAN`` (Box-Muller) and ``UNIFORM`` (on [-std sqrt 3, std sqrt 3])."""
    a, b = unit(kind, seed_key(seed), k)
    return scaled(kind, std, a, b)
