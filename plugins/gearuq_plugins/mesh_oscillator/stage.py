"""The mesh oscillator built from a :class:`gearuq.GearStage`.

The force-deflection function is the stage's own LTCA over one mesh cycle (its designed
reliefs of every shape, per gear, and its lead crowning: the same on every tooth, so one mesh
cycle is the period), on a load grid spanning the stage's torque range; the nominal mass is
the gear bodies' equivalent mass along the normal line of action and the nominal mean force
the design torque's.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: load grid: this many normal forces, geometric from LOAD_SPAN[0] x the smallest to
#: LOAD_SPAN[1] x the largest of the stage's torque range (vibration about a mean load
#: swings well beyond it; above the grid the table extrapolates along its tangent)
N_LOADS = 10
LOAD_SPAN = (0.1, 2.0)


def equivalent_mass(stage: Any) -> float:
    """Equivalent mass [kg] of the two gear bodies along the normal line of action.

    Each body a solid cylinder of its reference diameter and face width (as the helical
    pair model); the normal approach is ``cos(beta_b)(r_b1 theta_1 + r_b2 theta_2)``, so
    ``1/m = cos^2(beta_b) (r_b1^2 / J_1 + r_b2^2 / J_2)`` (Eritenel and Parker's
    ``I_p I_g / (I_p r_g^2 + I_g r_p^2)`` in the normal direction). The shafts' end
    inertias sit behind the shafts' torsional compliance and are left out.
    """
    from gearuq.gears.stage import to_si

    p = stage.pair
    rho = stage.material.density
    inv = 0.0
    for d, db, b in ((p.d1, p.db1, to_si(stage.face_width[0], "1e-3")),
                     (p.d2, p.db2, to_si(stage.face_width[1], "1e-3"))):
        r = d / 2
        inertia = 0.5 * rho * math.pi * r**4 * b
        inv += (db / 2) ** 2 / inertia
    return 1.0 / (math.cos(p.beta_b) ** 2 * inv)


def stage_force(stage: Any, *, positions_per_cycle: int = 32, n_pts: int = 20) -> Any:
    """The stage's :class:`LoadDeflectionTable` from its LTCA (one mesh cycle)."""
    from gearuq.gears.compliance import ComplianceModel
    from gearuq.gears.ltca import normal_force_from_torque
    from gearuq.gears.stage import to_si
    from gearuq_plugins.mesh_oscillator.forces import LoadDeflectionTable

    pair = stage.pair
    lo, hi = (normal_force_from_torque(pair, t) for t in stage.operation.torque)
    loads = np.geomspace(LOAD_SPAN[0] * lo, LOAD_SPAN[1] * hi, N_LOADS)
    compliance = ComplianceModel(pair, E=to_si(stage.material.young_modulus, "1e6"),
                                 nu=stage.material.poisson_ratio)
    return LoadDeflectionTable.from_ltca(pair, loads, positions_per_cycle=positions_per_cycle,
                                         n_pts=n_pts, deviations=stage.flank_deviations(),
                                         compliance=compliance)


def stage_nominal(stage: Any) -> dict[str, float]:
    """Nominal mass and mean force of the stage (design torque)."""
    from gearuq.gears.ltca import normal_force_from_torque

    return {"mass": equivalent_mass(stage),
            "mean_force": normal_force_from_torque(stage.pair, stage.operation.torque_design)}
