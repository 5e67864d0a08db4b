"""One member's loop elements as one column of the engine's ``LP`` array: the sensor's
rows, the actuator's, the plant's integration substeps per control period, then the
disturbance's (:mod:`.sensor`, :mod:`.actuator`, :mod:`.disturbance` declare the rows;
this module places them)."""

import numpy as np

from .._jit import step_jit
from . import actuator, disturbance, sensor

SENSOR = 0
ACTUATOR = SENSOR + sensor.N_PARAMS
SUBSTEPS = ACTUATOR + actuator.N_PARAMS  # integration steps of h / substeps per sample
DISTURBANCE = SUBSTEPS + 1


def n_rows(n_table: int = 0) -> int:
    """Rows of a column whose disturbance table has n_table points."""
    return DISTURBANCE + disturbance.n_params(n_table)


#: the rows whose value, when not 0, makes an element act on a member's loop (each is
#: >= 0 by its option's check): noise, quantum, the two delays, the rate limit, a
#: disturbance
ACTING_ROWS = (SENSOR + sensor.NOISE, SENSOR + sensor.QUANTUM, SENSOR + sensor.DELAY,
               ACTUATOR + actuator.DELAY, ACTUATOR + actuator.RATE,
               DISTURBANCE + disturbance.KIND)


@step_jit
def acting(LP, j):
    """Whether a sensor, actuator or disturbance acts on member j's loop (the test the
    engine makes once per member; substeps are apart)."""
    for r in ACTING_ROWS:
        if LP[r, j] != 0.0:
            return True
    return False


def plain(LP: np.ndarray) -> bool:
    """Whether every member's loop is the ideal one (no element acts, one integration step
    per sample): the loop of the paper's kernels and of the engine's vectorised sweeps,
    which read none of these rows."""
    return bool(np.all(LP[list(ACTING_ROWS)] == 0.0) and np.all(LP[SUBSTEPS] == 1.0))


def column(*, noise: float = 0.0, noise_std: float = 0.0, seed: float = 0.0,
           quantum: float = 0.0, sensor_delay: float = 0.0, actuator_delay: float = 0.0,
           rate_limit: float = 0.0, substeps: float = 1.0, kind: float = 0.0, at: float = 0.0,
           amplitude: float = 0.0, t0: float = 0.0, frequency: float = 0.0,
           times=(), values=()) -> np.ndarray:
    """The column (n_rows(len(times)), 1) of these elements' numeric values (the kinds
    as the modules' constants); checked values only (the API checks them)."""
    n = len(times)
    col = np.zeros((n_rows(n), 1))
    s, a, d = SENSOR, ACTUATOR, DISTURBANCE
    col[s + sensor.NOISE] = noise
    col[s + sensor.STD] = noise_std
    col[s + sensor.SEED] = seed
    col[s + sensor.QUANTUM] = quantum
    col[s + sensor.DELAY] = sensor_delay
    col[a + actuator.DELAY] = actuator_delay
    col[a + actuator.RATE] = rate_limit
    col[SUBSTEPS] = substeps
    col[d + disturbance.KIND] = kind
    col[d + disturbance.AT] = at
    col[d + disturbance.AMPLITUDE] = amplitude
    col[d + disturbance.T0] = t0
    col[d + disturbance.FREQUENCY] = frequency
    col[d + disturbance.N_TABLE] = n
    col[d + disturbance.TABLE0:d + disturbance.TABLE0 + n, 0] = times
    col[d + disturbance.TABLE0 + n:d + disturbance.TABLE0 + 2 * n, 0] = values
    return col


def stack(columns) -> np.ndarray:
    """Members' columns side by side, the shorter tables padded (their point counts stay
    their own): one LP array."""
    rows = max(c.shape[0] for c in columns)
    out = np.zeros((rows, len(columns)))
    for j, c in enumerate(columns):
        out[:c.shape[0], j] = c[:, 0]
    return out
