"""mfcontrol: model-free control (Fliess-Join intelligent controllers), the variational /
symplectic gain tuning of Michel (CCTA 2025), and a power-electronics test bench.

Quick use::

    import mfcontrol
    result = mfcontrol.run_case("voltage-stable-variational", overrides={"fidelity": "paper"})
    result.metrics["iae"], result.to_pandas().head()
"""

from ._version import __version__
from .api.controllers import IP, IPD, IPI, IPID, PID, IntelligentController, RecursiveIP
from .api.elements import Actuator, Disturbance, Sensor
from .api.loop import Change, LoopResult, simulate_loop
from .api.plants import LTI, ODE, Boost, Buck, DCMotor, FirstOrder, Plant
from .api.result import Result, SweepResult
from .api.simulate import simulate, simulate_many, simulate_sweep
from .api.sweep import LoopSweepResult, sweep
from .cexport import export_c
from .config.resolve import Config, resolve
from .errors import CaseError, ConfigError
from .experiments.cases import make_controller, run_case
from .experiments.cases import names as case_names
from .experiments.compare import Comparison, compare
from .experiments.tune import TuneResult, tune

__all__ = [
    "IP", "IPD", "IPI", "IPID", "PID", "IntelligentController", "RecursiveIP",
    "Sensor", "Actuator", "Disturbance",
    "CaseError", "Config", "ConfigError", "Result", "SweepResult", "__version__",
    "Plant", "Buck", "Boost", "DCMotor", "FirstOrder", "LTI", "ODE",
    "Change", "LoopResult", "LoopSweepResult", "simulate_loop", "sweep",
    "case_names", "resolve", "run_case", "simulate", "simulate_many", "simulate_sweep",
    "Comparison", "TuneResult", "compare", "make_controller", "tune", "export_c",
]
