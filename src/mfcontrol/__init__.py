"""mfcontrol: model-free control (Fliess-Join intelligent controllers), the variational /
symplectic gain tuning of Michel (CCTA 2025), and a power-electronics test bench.

Quick use::

    import mfcontrol
    result = mfcontrol.run_case("voltage-stable-variational", overrides={"fidelity": "paper"})
    result.metrics["iae"], result.to_pandas().head()
"""

from importlib import import_module
from typing import TYPE_CHECKING

from ._version import __version__

# Public names and the module that defines each, imported on first use: `import mfcontrol`
# (and the command line's start, --help, --version) no longer waits 1.6 s for numpy,
# scipy and numba, and a Ctrl-C in that time reaches the command's own handling.
_EXPORTS = {
    ".analysis.alpha": ("AlphaEstimate", "backward_difference_bound", "estimate_alpha",
                        "plant_alpha"),
    ".analysis.filters": ("LinearFilter",),
    ".analysis.loop": ("LinearLoop",),
    ".analysis.tuning_rules": ("Fopdt", "Sopdt", "amigo", "fit_fopdt", "fopdt_of", "simc",
                               "sopdt_of"),
    ".api.model.controllers": ("ADRC", "IP", "IPD", "IPI", "IPID", "PID",
                               "IntelligentController", "RecursiveIP"),
    ".api.model.elements": ("Actuator", "Disturbance", "Sensor"),
    ".api.model.plants": ("LTI", "ODE", "Boost", "Buck", "DCMotor", "FirstOrder", "Plant"),
    ".api.model.schedule": ("Change",),
    ".api.run.loop": ("LoopResult", "simulate_loop"),
    ".api.results.result": ("Result", "SweepResult"),
    ".api.run.simulate": ("simulate", "simulate_many", "simulate_sweep"),
    ".api.run.sweep": ("LoopSweepResult", "sweep"),
    ".cexport": ("export_c",),
    ".config.resolve": ("Config", "resolve"),
    ".errors": ("CaseError", "ConfigError", "PlantFunctionError"),
    ".experiments.cases": ("make_controller", "run_case", "case_names"),
    ".experiments.analyze": ("Analysis", "Region", "analyze", "analyze_region"),
    ".experiments.compare": ("Comparison", "compare"),
    ".experiments.tune": ("TuneResult", "tune"),
    ".experiments.statistics": ("PairedComparison", "Restarts", "paired_comparison",
                                "restart_summary"),
}
# public name: name in its module
_RENAMED = {"case_names": "names", "analyze_region": "region", "paired_comparison": "paired",
            "restart_summary": "restarts"}
_MODULE_OF = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = ["__version__", *_MODULE_OF]


#: the subpackages, reachable as attributes (mfcontrol.experiments.cases...) as when the
#: package imported everything at once
_SUBPACKAGES = ("analysis", "api", "cexport", "config", "elements", "engine", "errors",
                "experiments", "laws", "numerics", "plants")


def __getattr__(name: str):
    module = _MODULE_OF.get(name)
    if module is not None:
        value = getattr(import_module(module, __name__), _RENAMED.get(name, name))
    elif name in _SUBPACKAGES:
        for defining in _EXPORTS:  # everything `import mfcontrol` used to bind
            import_module(defining, __name__)
        value = import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module 'mfcontrol' has no attribute {name!r}")
    globals()[name] = value  # the next access is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


if TYPE_CHECKING:  # what a type checker and an editor see: the same names, eagerly
    from .analysis.alpha import (
        AlphaEstimate,
        backward_difference_bound,
        estimate_alpha,
        plant_alpha,
    )
    from .analysis.filters import LinearFilter
    from .analysis.loop import LinearLoop
    from .analysis.tuning_rules import (
        Fopdt,
        Sopdt,
        amigo,
        fit_fopdt,
        fopdt_of,
        simc,
        sopdt_of,
    )
    from .api.model.controllers import (
        ADRC,
        IP,
        IPD,
        IPI,
        IPID,
        PID,
        IntelligentController,
        RecursiveIP,
    )
    from .api.model.elements import Actuator, Disturbance, Sensor
    from .api.model.plants import LTI, ODE, Boost, Buck, DCMotor, FirstOrder, Plant
    from .api.model.schedule import Change
    from .api.results.result import Result, SweepResult
    from .api.run.loop import LoopResult, simulate_loop
    from .api.run.simulate import simulate, simulate_many, simulate_sweep
    from .api.run.sweep import LoopSweepResult, sweep
    from .cexport import export_c
    from .config.resolve import Config, resolve
    from .errors import CaseError, ConfigError, PlantFunctionError
    from .experiments.analyze import Analysis, Region, analyze
    from .experiments.analyze import region as analyze_region
    from .experiments.cases import make_controller, run_case
    from .experiments.cases import names as case_names
    from .experiments.compare import Comparison, compare
    from .experiments.statistics import PairedComparison, Restarts
    from .experiments.statistics import paired as paired_comparison
    from .experiments.statistics import restarts as restart_summary
    from .experiments.tune import TuneResult, tune
