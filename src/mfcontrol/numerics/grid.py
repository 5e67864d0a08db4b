"""The time grid: N samples t_k = (k t_end) / N over [0, t_end), N = t_end / h.

Every run, every kernel and every schedule uses these few lines: the sample times are
computed as ``(k * t_end) / N`` (not ``k * h``) so that the last sample is exact and a
change scheduled at a time lands on the same sample in every driver.
"""

import functools
import math

import numpy as np

from .._jit import step_jit
from ..errors import ConfigError, as_float

#: most samples one run may have (its trajectory alone would need 9 x 8 bytes a sample)
MAX_STEPS = 100_000_000


def n_samples(t_end: float, h: float, t_end_key: str = "t_end", h_key: str = "h") -> int:
    """N = t_end / h, checked: both finite and > 0, N a whole number >= 2, at most
    :data:`MAX_STEPS`. Errors name ``t_end_key`` / ``h_key``."""
    if not (h > 0 and math.isfinite(as_float(h))):
        raise ConfigError(h_key, h, "must be a finite number > 0")
    if not (t_end > 0 and math.isfinite(as_float(t_end))):
        raise ConfigError(t_end_key, t_end, "must be a finite number > 0")
    n = t_end / h
    if not n <= MAX_STEPS:  # also catches an overflow to inf
        raise ConfigError(t_end_key, t_end, f"must be at most {MAX_STEPS:,} steps of "
                          f"{h_key} = {h!r}")
    if abs(n - round(n)) > 1e-9 * n or round(n) < 2:
        raise ConfigError(t_end_key, t_end, f"must be a whole number (>= 2) of {h_key} = "
                          f"{h!r} steps")
    return round(n)


#: most memory one recorded run (every signal at every sample) may take; a sweep keeps
#: metrics only and runs any horizon up to MAX_STEPS in bounded memory
MAX_RECORD_BYTES = 2 * 2**30


def check_recording(n: int, rows: int, t_end: float, t_end_key: str = "t_end") -> None:
    """Refuse, before allocating it, a recorded trajectory of ``n`` samples of ``rows``
    signals larger than :data:`MAX_RECORD_BYTES`, with the figure and the ways out."""
    need = 8 * n * rows
    if need > MAX_RECORD_BYTES:
        raise ConfigError(t_end_key, t_end, f"{n:,} samples of {rows} recorded signals "
                          f"would take {need / 2**30:.1f} GiB, more than the "
                          f"{MAX_RECORD_BYTES / 2**30:.0f} GiB a recorded run may use: "
                          "shorten the run, lengthen the sample time, or run it as a sweep "
                          "(mfcontrol sweep, mfcontrol.sweep), which keeps the metrics only")


#: most members of one sweep: its table of metrics (about 200 bytes a member) under 2 GiB
MAX_MEMBERS = 10_000_000


def check_members(n: int, key: str, value: object) -> None:
    """Refuse a sweep of more than :data:`MAX_MEMBERS` members at once, with its size."""
    if n > MAX_MEMBERS:
        raise ConfigError(key, value, f"{n:,} members: at most {MAX_MEMBERS:,} in one sweep "
                          f"(its table of metrics alone would take {n * 200 / 2**30:,.0f} "
                          "GiB); split the grid over several sweeps")


def times(n: int, t_end: float) -> np.ndarray:
    """The sample times t_k = (k t_end) / n, exactly as every kernel computes them."""
    t = np.arange(n, dtype=np.float64)  # k exact in a double (n <= MAX_STEPS)
    t *= t_end  # in place: the same two roundings, without two temporaries
    t /= n
    return t


@step_jit
def time(k, t_end, n):
    """t_k inside a kernel: the same expression as :func:`times`."""
    return (k * t_end) / n


@functools.lru_cache(maxsize=4096)  # a sweep asks it of every member, mostly the same
def first_sample_at(t_event: float, t_end: float, n: int) -> int:
    """First k with t_k >= t_event (n if never), t_k evaluated in float64 exactly as the
    kernels do: a guess from the real quotient, then corrected."""
    def t(k: int) -> float:
        return (k * t_end) / n

    if not t_event <= t_end:  # never within the run (and t_event * n may overflow)
        return n
    k = min(max(math.ceil(t_event * n / t_end), 0), n)
    while k > 0 and t(k - 1) >= t_event:
        k -= 1
    while k < n and t(k) < t_event:
        k += 1
    return k
