"""Failure analysis: failure modes, intervals, the evaluator, the one report form, estimation
from existing samples, out-crossing, and one module per rare-event method.

Built bottom-up; each floor imports only the floors below it:

==================  ============================================================================
module              what it holds
==================  ============================================================================
``intervals``       binomial intervals (Wilson, Clopper-Pearson), ``beta`` <-> ``pf``, the
                    mean-value index
``modes``           failure modes: :class:`Band`, :class:`LimitState`, series / parallel /
                    cut-set systems
``samples``         :func:`reliability`: instantaneous, system and first-passage estimates from
                    samples that already exist (a Monte Carlo result)
``evaluator``       :class:`LimitStateEvaluator`: standard normal space <-> physical
                    parameters, model runs counted, invalid runs and time grids recorded
``report``          :func:`failure_report`, the one report form, and the status table
``methods.*``       ``mc``, ``form`` (FORM and SORM), ``importance``, ``subset``, ``akmcs``
``api``             :func:`failure_probability` and the method table
``outcrossing``     Rice rates, first passage between instants (Hermite), PHI2
==================  ============================================================================

The names below are imported lazily (``import gearuq.failure`` stays cheap).
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "Band": "modes", "LimitState": "modes", "System": "modes", "SeriesSystem": "modes",
    "ParallelSystem": "modes", "cut_set_system": "modes", "as_limit_state": "modes",
    "wilson_interval": "intervals", "clopper_pearson_interval": "intervals",
    "binomial_interval": "intervals", "beta_from_pf": "intervals", "pf_from_beta": "intervals",
    "mean_value_beta": "intervals", "INTERVAL_METHODS": "intervals",
    "reliability": "samples",
    "LimitStateEvaluator": "evaluator",
    "failure_report": "report", "REPORT_STATUS": "report", "STATUS_TEXT": "report",
    "ReportStatus": "report", "describe_status": "report",
    "failure_probability": "api", "method_settings": "api", "validate_settings": "api",
    "METHODS": "api", "METHOD_TABLE": "api",
    "rice_rate": "outcrossing", "first_passage": "outcrossing", "phi2": "outcrossing",
    "hermite_crossing": "outcrossing",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(f"gearuq.failure.{_LAZY[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'gearuq.failure' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
