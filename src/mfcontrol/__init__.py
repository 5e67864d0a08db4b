"""mfcontrol: model-free control (Fliess-Join intelligent controllers), the variational /
symplectic gain tuning of Michel (CCTA 2025), and a power-electronics test bench.

Quick use::

    import mfcontrol
    result = mfcontrol.run_case("voltage-stable-variational", overrides={"fidelity": "paper"})
    result.metrics["iae"], result.to_pandas().head()
"""

from ._version import __version__
from .config import Config, resolve
from .controller import IP, IPD, IPI, IPID, IntelligentController, RecursiveIP
from .errors import CaseError, ConfigError
from .experiments.cases import names as case_names
from .experiments.cases import run_case
from .loop import Change, LoopResult, simulate_loop
from .loop_sweep import LoopSweepResult, sweep
from .result import Result, SweepResult
from .simulate import simulate, simulate_many, simulate_sweep

__all__ = [
    "IP", "IPD", "IPI", "IPID", "IntelligentController", "RecursiveIP",
    "CaseError", "Config", "ConfigError", "Result", "SweepResult", "__version__",
    "Change", "LoopResult", "LoopSweepResult", "simulate_loop", "sweep",
    "case_names", "resolve", "run_case", "simulate", "simulate_many", "simulate_sweep",
]
