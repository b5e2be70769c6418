"""Design under uncertainty: the design whose failure probability (or quantile, or moment)
is best given the scatter of its inputs.

==================  ===========================================================================
module              what it holds
==================  ===========================================================================
``variables``       :class:`DesignVariable` (bounds; shifts an input law or sets a parameter),
                    :func:`space_at`, :func:`model_at`
``measures``        :class:`Probability`, :class:`Quantile`, :class:`Moment`, :class:`Constraint`
                    and their weighted estimators with intervals
``pool``            :class:`RunPool`: runs shared across designs by likelihood ratios
``problem``         :class:`DesignProblem`, :func:`evaluate_design` (one fresh run at a design)
``optimize``        :func:`optimize_design`: the strategies (reweight, surrogate, crn, nested),
                    the independent confirmation and the one result Dataset
``levels``          :func:`optimize_levels`: a categorical variable (a model option), the
                    design optimised per level and the levels compared on paired runs
==================  ===========================================================================

The guide is docs/design.md. Names are imported lazily (``import gearuq.design`` stays cheap).
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "DesignVariable": "variables", "space_at": "variables", "model_at": "variables",
    "Probability": "measures", "Quantile": "measures", "Moment": "measures",
    "Constraint": "measures", "Estimate": "measures", "effective_size": "measures",
    "RunPool": "pool",
    "DesignProblem": "problem", "evaluate_design": "problem",
    "optimize_design": "optimize", "STRATEGIES": "optimize", "DESIGN_STATUS": "optimize",
    "optimize_levels": "levels", "paired_failures": "levels", "at_level": "levels",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(f"gearuq.design.{_LAZY[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'gearuq.design' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
