"""python-control interoperability.

``as_nlsys(controller)`` turns a live controller into a discrete-time
``control.NonlinearIOSystem`` with inputs ``y`` (measurement) and ``r`` (reference), and
``alpha`` for a controller with ``gain="external"``, output
``u`` and a state vector that holds all of the controller's memory. python-control may
call the update and output functions several times per step, so both are pure: they
compute from a copy of the state. The output at step k depends on the inputs at step k
(the controller reacts to y_k), so close the loop with a plant whose output depends on its
state only.
"""

from __future__ import annotations

import numpy as np

from ..engine import live
from .model.controllers import ADRC, PID, IntelligentController, RecursiveIP


def as_nlsys(controller, dt: float | None = None, name: str = "mfcontrol"):
    """A discrete-time ``control.NonlinearIOSystem`` running ``controller``'s law.

    Parameters
    ----------
    controller : IntelligentController, PID, ADRC or RecursiveIP
        Its parameters define the law; its current state is the system's initial state
        (``x0 = as_nlsys_state(controller)``). The live object itself is not modified.
    dt : float, optional
        Sample period; defaults to the controller's ``sample_time`` (a RecursiveIP
        without one needs it).

    Examples
    --------
    >>> import control, mfcontrol
    >>> from mfcontrol.api.interop import as_nlsys
    >>> sys = as_nlsys(mfcontrol.IP(alpha=1.0, kp=5.0, sample_time=0.01))
    >>> sys.ninputs, sys.noutputs, sys.isdtime()
    (2, 1, True)
    """
    import control  # here: python-control takes about 2 s to import

    CP = controller._CP
    inputs = ["y", "r"]
    h: float | None
    if isinstance(controller, IntelligentController):
        h = controller.sample_time if dt is None else float(dt)
        if controller._external:  # alpha is an input, as it is an argument of each call
            inputs.append("alpha")

        def law(x, u):
            return live.intelligent_pure(CP, np.asarray(x, dtype=float), float(u[0]),
                                         float(u[1]), h, float(u[2]) if len(u) > 2 else 1.0)
    elif isinstance(controller, PID | ADRC):
        h = controller.sample_time if dt is None else float(dt)
        pure = live.pid_pure if isinstance(controller, PID) else live.adrc_pure

        def law(x, u):
            return pure(CP, np.asarray(x, dtype=float), float(u[0]), float(u[1]), h)
    elif isinstance(controller, RecursiveIP):
        h = controller.sample_time if dt is None else float(dt)
        if h is None:
            raise ValueError("dt = None: this RecursiveIP has no sample_time, pass dt")

        def law(x, u):
            return live.recursive_pure(CP, np.asarray(x, dtype=float), float(u[0]),
                                       float(u[1]))
    else:
        raise TypeError(f"controller = {controller!r}: expected an mfcontrol controller")

    def update(t, x, u, params):
        return law(x, u)[1]

    def output(t, x, u, params):
        return np.array([law(x, u)[0]])

    return control.nlsys(update, output, inputs=inputs, outputs=["u"],
                         states=controller._CS.shape[0], dt=h, name=name)


def as_nlsys_state(controller) -> np.ndarray:
    """The controller's current memory as the system's state vector."""
    return controller._CS[:, 0].copy()
