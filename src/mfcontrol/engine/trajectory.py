"""A recorded trajectory's rows: the signals every run records, then a law's components,
then the plant states; the one place they get their names."""

from .._jit import step_jit

# trajectory rows; plant states follow from T_X0 on
T_REF = 0
T_Y = 1
T_U = 2
T_APPLIED = 3
T_GAMMA = 4
T_GAIN = 5
T_Y_MEAS = 6
T_U_PLANT = 7
T_X0 = 8


def named_rows(rows, components=(), state_names=()):
    """(signals, states) of recorded trajectory rows: the signals every run records (rows
    T_REF .. T_GAIN), a law's components after them, then the plant states; the one place
    a trajectory's rows get their names."""
    signals = {"y_ref": rows[T_REF], "y": rows[T_Y], "y_meas": rows[T_Y_MEAS],
               "u": rows[T_APPLIED], "u_plant": rows[T_U_PLANT], "u_raw": rows[T_U],
               "gamma": rows[T_GAMMA], "gain": rows[T_GAIN]}
    for i, key in enumerate(components):
        signals[key] = rows[T_X0 + i]
    x0 = T_X0 + len(components)
    return signals, {s: rows[x0 + i] for i, s in enumerate(state_names)}


@step_jit
def record(traj, k, r, y, u, a, gamma, g):
    """Sample k's signals into the trajectory rows T_REF .. T_U_PLANT, for a loop without
    sensor or actuator (y measured as it is, a applied as it is; a loop with them writes
    :func:`record_io`'s rows after this)."""
    traj[T_REF, k] = r
    traj[T_Y, k] = y
    traj[T_U, k] = u
    traj[T_APPLIED, k] = a
    traj[T_GAMMA, k] = gamma
    traj[T_GAIN, k] = g
    traj[T_Y_MEAS, k] = y
    traj[T_U_PLANT, k] = a


@step_jit
def record_io(traj, k, y_meas, u_plant):
    """Sample k's measured output and the input that reached the plant (what the sensor
    and the actuator made of y and u: rows T_Y_MEAS, T_U_PLANT)."""
    traj[T_Y_MEAS, k] = y_meas
    traj[T_U_PLANT, k] = u_plant
