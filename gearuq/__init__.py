"""gearuq: reliability and uncertainty quantification of gear dynamics.

The public API is imported lazily so that ``import gearuq`` and ``gearuq.list_models()``
stay cheap (no numba, chaospy or dask import until an engine is used).
"""

from __future__ import annotations

import importlib
from typing import Any

from gearuq._version import __version__

_LAZY = {
    "list_models": "gearuq.registry",
    "get_model": "gearuq.registry",
    "register_model": "gearuq.registry",
    "describe_models": "gearuq.registry",
    "Model": "gearuq.model",
    "Parameter": "gearuq.model",
    "Output": "gearuq.model",
    "FunctionModel": "gearuq.model",
    "ParameterSpace": "gearuq.space",
    "monte_carlo": "gearuq.engines.montecarlo",
    "polynomial_chaos": "gearuq.engines.pce",
    "PolynomialChaos": "gearuq.engines.pce",
    "sobol_indices": "gearuq.engines.sensitivity",
    "morris_screening": "gearuq.engines.sensitivity",
    "reliability": "gearuq.reliability",
    "Band": "gearuq.reliability",
    "fit_distributions": "gearuq.fitting",
    "save": "gearuq.io",
    "load": "gearuq.io",
}

_SUBMODULES = {
    "model", "registry", "space", "ode", "engines", "reliability", "fitting", "signal",
    "execution", "io", "plot", "cli", "gears", "testing",
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
