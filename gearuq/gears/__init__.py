"""Shared gear mechanics used by the plugins (plugins never import each other).

- :mod:`gearuq.gears.geometry`: involute helical pair geometry, contact ratios
- :mod:`gearuq.gears.iso6336`: ISO 6336-1 method B tooth stiffness
- :mod:`gearuq.gears.contact`: lines of contact in the plane of action
- :mod:`gearuq.gears.compliance`: tooth compliance (potential energy + fillet foundation,
  face-width coupling) and Hertzian line contact
- :mod:`gearuq.gears.face_coupling`: face-width coupling length from cantilever-plate theory
- :mod:`gearuq.gears.deviations`: pitch deviations, reliefs, crowning as initial clearances
- :mod:`gearuq.gears.ltca`: loaded tooth contact analysis over the long period (STE, LPMS
  secant and tangent, CMS, force-deflection function)
- :mod:`gearuq.gears.stage`: a user's gear stage (pair, accuracy, modifications, shafts,
  bearings, operation), read from TOML, the one description every gear model builds from
- :mod:`gearuq.gears.long_period`: the long period from a line-load table, at a cost that
  does not grow with ``lcm(z1, z2)``

Submodules are imported on use so that ``import gearuq`` stays light; the main functions are
also reachable as ``gearuq.gears.<name>`` (resolved lazily), e.g.
``gearuq.gears.force_deflection``. ``gearuq.gears.ltca`` is the *module*; the solver is
``gearuq.gears.ltca.ltca``.
"""

from __future__ import annotations

import importlib
from typing import Any

#: public name -> submodule that defines it (lazy attribute access, PEP 562)
_LAZY = {
    "HelicalGearPair": "geometry",
    "seed000_pair": "geometry",
    "seed002_pair": "geometry",
    "iso_tr_6336_30_example1": "geometry",
    "mesh_stiffness": "iso6336",
    "contact_grid": "contact",
    "long_period_cycles": "contact",
    "ComplianceModel": "compliance",
    "plate_coupling_length": "face_coupling",
    "FlankDeviations": "deviations",
    "random_cumulative_pitch_deviations": "deviations",
    "force_deflection": "ltca",
    "force_at_deflection": "ltca",
    "stiffness_at_deflection": "ltca",
    "normal_force_from_torque": "ltca",
    "tip_relief_map": "ltca",
    "GearStage": "stage",
    "stage_mesh_stiffness": "stage",
    "LongPeriodSettings": "long_period",
    "line_load_table": "long_period",
    "long_period_ltca": "long_period",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(f"gearuq.gears.{_LAZY[name]}"), name)
    raise AttributeError(f"module 'gearuq.gears' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
