"""Shared rotor finite elements (one element type per module) and their assembly.

- :mod:`gearuq.rotor.element`: the :class:`Element` interface, DOF order, materials
- :mod:`gearuq.rotor.shaft`: :class:`TimoshenkoShaftElement`, :class:`ShaftLine`
- :mod:`gearuq.rotor.disk`: :class:`DiskElement`
- :mod:`gearuq.rotor.bearing`: :class:`BearingElement`
- :mod:`gearuq.rotor.mesh`: :class:`HelicalMeshElement` (12-DOF mesh along the normal LOA)
- :mod:`gearuq.rotor.assembly`: :class:`Rotor` (global M, K, C, G; statics)
- :mod:`gearuq.rotor.modal`: real and complex modes, Campbell data
- :mod:`gearuq.rotor.examples`: ``friswell_example()``, ``seed002_rotor()``
- :mod:`gearuq.rotor.excitation`: :class:`MeshExcitation` (LTCA -> tangent k(t), e(t))
- :mod:`gearuq.rotor.reduction`: modal reduction with static correction
- :mod:`gearuq.rotor.harmonic_balance`: periodic steady state (AFT for contact loss)
- :mod:`gearuq.rotor.time_integration`: reduced model on ``solve_batch``, Newmark full model
- :mod:`gearuq.rotor.geared`: :class:`GearedRotorProblem` (rotor + excitation + torque)
- :mod:`gearuq.rotor.sideband_balance`: steady state on a sparse set of long-period orders
  (hunting-tooth pairs)

Theory and checks: docs/theory/geared_rotor.md.
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "Element": "gearuq.rotor.element",
    "Material": "gearuq.rotor.element",
    "steel": "gearuq.rotor.element",
    "TimoshenkoShaftElement": "gearuq.rotor.shaft",
    "ShaftLine": "gearuq.rotor.shaft",
    "DiskElement": "gearuq.rotor.disk",
    "BearingElement": "gearuq.rotor.bearing",
    "HelicalMeshElement": "gearuq.rotor.mesh",
    "Rotor": "gearuq.rotor.assembly",
    "undamped_modes": "gearuq.rotor.modal",
    "complex_modes": "gearuq.rotor.modal",
    "campbell": "gearuq.rotor.modal",
    "friswell_example": "gearuq.rotor.examples",
    "seed002_rotor": "gearuq.rotor.examples",
    "MeshExcitation": "gearuq.rotor.excitation",
    "reduce_rotor": "gearuq.rotor.reduction",
    "prepare_excitation": "gearuq.rotor.harmonic_balance",
    "solve_periodic": "gearuq.rotor.harmonic_balance",
    "integrate_reduced": "gearuq.rotor.time_integration",
    "newmark_full": "gearuq.rotor.time_integration",
    "GearedRotorProblem": "gearuq.rotor.geared",
    "torque_load": "gearuq.rotor.geared",
    "solve_periodic_orders": "gearuq.rotor.sideband_balance",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'gearuq.rotor' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
