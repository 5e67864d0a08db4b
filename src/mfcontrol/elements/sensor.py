"""The sensor between the plant's output and the controller: noise, quantisation, delay.

Sample k: ``s_k = Q(y_k + n_k)``, with n_k the noise (:mod:`.noise`) and
``Q(v) = quantum * floor(v / quantum + 1/2)`` (rounding to the nearest multiple; none for
quantum 0); the controller receives ``y_meas[k] = s_{k-d}``, and ``s_0`` while k < d (the
sensor has read the initial output since before the start). With neither noise nor a
quantum, ``y_meas[k] = y[k - d]``.
"""

import numpy as np

from .._jit import step_jit
from . import noise

# parameter rows
NOISE = 0  # noise.KINDS
STD = 1  # noise standard deviation (output units)
SEED = 2
QUANTUM = 3  # 0: none
DELAY = 4  # whole samples
N_PARAMS = 5


@step_jit
def read(kind, std, seed, quantum, k, y):
    """s_k: the output y_k with sample k of the noise, quantised (before the delay)."""
    a, b = noise.unit(kind, noise.seed_key(seed), k)
    return read_unit(kind, std, a, b, quantum, y)


@step_jit
def read_unit(kind, std, a, b, quantum, y):
    """:func:`read` with sample k of the noise given as its unit factors
    (:func:`mfcontrol.elements.noise.unit`), which members sharing a seed share."""
    v = y
    if kind != noise.NONE:
        v = v + noise.scaled(kind, std, a, b)
    if quantum > 0.0:
        n = v / quantum
        # from 2^52 on every float is a whole number: rounding is the identity (and a
        # tiny quantum would overflow n to inf)
        if abs(n) < 4503599627370496.0:
            v = quantum * np.floor(n + 0.5)
    return v
