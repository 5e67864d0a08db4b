"""log, cos and sin written out in IEEE arithmetic: the polynomials of fdlibm and musl,
accurate to about an ulp, with their arguments reduced by exact operations.

Why not the C library's: a loop over the members of a sweep's block turns these into
vector instructions, where calls to the C library run one member at a time (measured:
26 against 6 ns per member-sample for the sensor's Gaussian noise, most of a noisy loop's
time), and every member keeps the bits of its single run, which calls the same
functions (a vector library's log or sin would differ from the scalar one in the last
bits). The sensor's noise (:mod:`mfcontrol.elements.noise`) and the sine disturbance
(:mod:`mfcontrol.elements.disturbance`) use them.
"""

import math

import numpy as np

from .._jit import step_jit

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
def sin_turns(x):
    """sin(2 pi x) for any finite x in turns: its fraction of a turn (exact), moved by a
    quarter turn onto :func:`cos_turns`."""
    frac = x - np.floor(x)
    u = frac - 0.25
    return cos_turns(u + 1.0 if u < 0.0 else u)
