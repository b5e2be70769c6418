"""Transitional alias of :mod:`gearuq.probability` (the module formerly named ``reliability``).

``gearuq.reliability`` is meant to be the *function* :func:`gearuq.probability.reliability`;
the module holding it is :mod:`gearuq.probability`. This file only keeps
``from gearuq.reliability import Band, ...`` working in code that has not moved to
``from gearuq.probability import ...`` yet. Importing it binds this module to the package
attribute, so it forwards calls to the function: ``gearuq.reliability(ds, bands)`` works in
every import order. Remove this file once no import of ``gearuq.reliability`` is left.
"""

from __future__ import annotations

import sys
import types
from typing import Any

from gearuq import probability as _probability
from gearuq.probability import *  # noqa: F403 - re-export the public names
from gearuq.probability import __all__ as _public

__all__ = list(_public)


def __getattr__(name: str) -> Any:
    # private helpers (e.g. _as_bands) still imported by code not yet moved
    return getattr(_probability, name)


class _CallableModule(types.ModuleType):
    """Module type that forwards calls to :func:`gearuq.probability.reliability`."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return _probability.reliability(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
