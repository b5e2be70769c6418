"""gearuq: reliability and uncertainty quantification of gear dynamics.

The public API is imported lazily so that ``import gearuq`` and ``gearuq.list_models()``
stay cheap (no numba, chaospy or dask import until an engine is used).
"""

from __future__ import annotations

import importlib
import sys
from typing import Any

from gearuq._version import __version__

if "chaospy" in sys.modules or "numpoly" in sys.modules:
    # imported before gearuq, they set the root logger to DEBUG: numba then formats its
    # compile log (a quarter of a cold compile); undo it now, before anything compiles
    from gearuq._chaospy import undo_chaospy_logging

    undo_chaospy_logging()

_LAZY = {
    # models, studies, registry
    "list_models": "gearuq.registry",
    "get_model": "gearuq.registry",
    "register_model": "gearuq.registry",
    "describe_models": "gearuq.registry",
    "list_studies": "gearuq.registry",
    "get_study": "gearuq.registry",
    "get_link": "gearuq.registry",
    "list_links": "gearuq.registry",
    "FidelityLink": "gearuq.links",
    "Model": "gearuq.model",
    "Parameter": "gearuq.model",
    "Output": "gearuq.model",
    "Option": "gearuq.model",
    "Request": "gearuq.model",
    "FunctionModel": "gearuq.model",
    # parameter space
    "ParameterSpace": "gearuq.space",
    # engines
    "monte_carlo": "gearuq.engines.montecarlo",
    "estimate_mean": "gearuq.engines.montecarlo",
    "polynomial_chaos": "gearuq.engines.pce",
    "PolynomialChaos": "gearuq.engines.pce",
    "compare_mc_surrogate": "gearuq.engines.pce",
    "sobol_indices": "gearuq.engines.sensitivity",
    "sobol_analysis": "gearuq.engines.sensitivity",
    "morris_screening": "gearuq.engines.sensitivity",
    "failure_probability": "gearuq.failure.api",
    "multifidelity_estimate": "gearuq.engines.multifidelity",
    # reliability, limit states, fitting
    "reliability": "gearuq.failure.samples",
    "Band": "gearuq.failure.modes",
    "LimitState": "gearuq.failure.modes",
    "SeriesSystem": "gearuq.failure.modes",
    "ParallelSystem": "gearuq.failure.modes",
    "cut_set_system": "gearuq.failure.modes",
    "ReportStatus": "gearuq.failure.report",
    "describe_status": "gearuq.failure.report",
    "fit_distributions": "gearuq.fitting",
    # I/O
    "save": "gearuq.io",
    "load": "gearuq.io",
    # the gear stage
    "GearStage": "gearuq.gears.stage",
    "export_csv": "gearuq.io",
    # first calls: compiled or plain-Python kernels
    "kernels_route": "gearuq._firstcall",
}

_SUBMODULES = {
    "model", "registry", "space", "ode", "engines", "failure", "interop",
    "fitting", "signal", "execution", "io", "plot", "cli", "gears", "rotor", "testing",
    "links",
    "design",
}

__all__ = ["__version__", *_LAZY]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    if name in _SUBMODULES:
        return importlib.import_module(f"gearuq.{name}")
    raise AttributeError(f"module 'gearuq' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
