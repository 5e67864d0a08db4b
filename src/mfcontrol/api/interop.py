"""python-control interoperability.

``as_nlsys(controller)`` turns a live controller into a discrete-time
``control.NonlinearIOSystem`` with inputs ``y`` (measurement) and ``r`` (reference), output
``u`` and a state vector that holds all of the controller's memory. python-control may
call the update and output functions several times per step, so both are pure: they
compute from a copy of the state. The output at step k depends on the inputs at step k
(the controller reacts to y_k), so close the loop with a plant whose output depends on its
state only.
"""

from __future__ import annotations

import numpy as np

from ..engine import live
from .controllers import IntelligentController, RecursiveIP


def as_nlsys(controller, dt: float | None = None, name: str = "mfcontrol"):
    """A discrete-time ``control.NonlinearIOSystem`` running ``controller``'s law.

    Parameters
    ----------
    controller : IntelligentController or RecursiveIP
        Its parameters define the law; its current state is the system's initial state
        (``x0 = as_nlsys_state(controller)``). The live object itself is not modified.
    dt : float, optional
        Sample period; defaults to the controller's ``sample_time`` (RecursiveIP needs it).

    Examples
    --------
    >>> import control, mfcontrol
    >>> from mfcontrol.api.interop import as_nlsys
    >>> sys = as_nlsys(mfcontrol.IP(alpha=1.0, kp=5.0, sample_time=0.01))
    >>> sys.ninputs, sys.noutputs, sys.isdtime()
    (2, 1, True)
    """
    import control

    CP = controller._CP
    if isinstance(controller, IntelligentController):
        h = controller.sample_time if dt is None else float(dt)

        def law(x, y, r):
            return live.intelligent_pure(CP, np.asarray(x, dtype=float), float(y), float(r),
                                         h, 1.0)
    elif isinstance(controller, RecursiveIP):
        if dt is None:
            raise ValueError("dt = None: RecursiveIP has no sample_time, pass dt")
        h = float(dt)

        def law(x, y, r):
            return live.recursive_pure(CP, np.asarray(x, dtype=float), float(y), float(r))
    else:
        raise TypeError(f"controller = {controller!r}: expected an mfcontrol controller")

    def update(t, x, u, params):
        return law(x, u[0], u[1])[1]

    def output(t, x, u, params):
        return np.array([law(x, u[0], u[1])[0]])

    return control.nlsys(update, output, inputs=["y", "r"], outputs=["u"],
                         states=controller._CS.shape[0], dt=h, name=name)


def as_nlsys_state(controller) -> np.ndarray:
    """The controller's current memory as the system's state vector."""
    return controller._CS[:, 0].copy()
