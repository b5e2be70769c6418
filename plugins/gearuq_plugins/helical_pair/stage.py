"""The helical pair built from a :class:`gearuq.GearStage`: its parameters' nominal values.

Data flows one way: the stage (drawing units) -> nominal values in the model's units -> a
new parameter tuple (ranges widened only where a stage value lies outside them) and the
factor that turns the model's ISO 6336-1 mesh stiffness into the stage's one.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

from gearuq.model import Parameter

#: parameters a stage adds when its wheel shaft differs from its pinion shaft
WHEEL_SUPPORT = {
    "k_r_wheel": ("N m-1", "radial support stiffness of the wheel (sum of its shaft's bearings)"),
    "k_a_wheel": ("N m-1", "axial support stiffness of the wheel (sum of its shaft's bearings)"),
    "span_wheel": ("m", "equivalent bearing distance of the wheel, sqrt(tilt / radial)"),
}


def shaft_support(shaft: Any) -> dict[str, float]:
    """Lumped support of one shaft [N/m, N/m, m]: sums, and the equivalent span.

    Two equal bearings symmetric about the gear give their distance from it exactly; any
    other layout the span that keeps the tilt stiffness, ``sqrt(sum k (z - z_g)^2 /
    sum k)`` (the radial-tilt coupling ``sum k (z - z_g)`` of an off-centre gear is not in
    the lumped model: docs/stage.md).
    """
    from gearuq.gears.stage import to_si

    lumped = shaft.support()
    arms = {round(abs(b.position - shaft.gear_position), 9) for b in shaft.bearings}
    stiff = {b.radial_stiffness for b in shaft.bearings}
    if len(arms) == 1 and len(stiff) == 1:
        span = to_si(arms.pop(), "1e-3")
    else:
        span = math.sqrt(lumped["tilt"] / lumped["radial"])
    return {"k_r": lumped["radial"], "k_a": lumped["axial"], "span": span}


def stage_nominal(stage: Any, mesh: Any) -> dict[str, float]:
    """Nominal values of the helical pair's parameters from a stage (model units)."""
    from gearuq.gears.stage import to_si

    op = stage.operation
    values: dict[str, float] = {
        "z1": stage.teeth[0], "z2": stage.teeth[1],
        "m_n": to_si(stage.normal_module, "1e-3"), "beta": stage.helix_angle,
        "alpha_n": stage.normal_pressure_angle, "x_shift_p": stage.profile_shift[0],
        "x_shift_g": stage.profile_shift[1], "B1": to_si(stage.face_width[0], "1e-3"),
        "B2": to_si(stage.face_width[1], "1e-3"), "rho": stage.material.density,
        "n": op.speed_design, "T": op.torque_design, "b5": to_si(stage.backlash, "5e-7"),
    }
    if mesh.source == "ltca":
        # the same LTCA: error amplitude and stiffness variation over one mesh cycle
        values["e_a"] = to_si(0.5 * mesh.ste_ptp, "1e-6")
        values["s"] = 0.5 * mesh.tangent_ptp / mesh.tangent_mean
    for gear, shaft, radial, axial in (("pinion", stage.pinion_shaft, "b1", "b3"),
                                       ("wheel", stage.wheel_shaft, "b2", "b4")):
        if shaft is None:
            continue
        values[radial] = to_si(min(b.radial_clearance for b in shaft.bearings), "5e-7")
        values[axial] = to_si(min(b.axial_clearance for b in shaft.bearings), "5e-7")
        support = shaft_support(shaft)
        if gear == "pinion":
            values |= support
        else:
            values |= {f"{k}_wheel": v for k, v in support.items()}
    if all(values.get(f"{k}_wheel") == values.get(k) for k in ("k_r", "k_a", "span")):
        for k in ("k_r", "k_a", "span"):
            values.pop(f"{k}_wheel", None)  # equal shafts: the pinion's parameters serve both
    return values


def from_stage(stage: Any, parameters: tuple[Parameter, ...], *,
               use_virtual_teeth: bool) -> tuple[tuple[Parameter, ...], float]:
    """The model's parameters with the stage's nominal values, and its stiffness factor.

    The factor is the stage's mesh stiffness over the model's own ISO 6336-1 value at the
    nominal geometry (exactly 1.0 when the stage takes ISO 6336-1, as Li, Hu and Han's file).
    """
    import numpy as np

    from gearuq.gears.stage import GearStage, stage_mesh_stiffness
    from gearuq_plugins.helical_pair.physics import gear_data

    if not isinstance(stage, GearStage):
        raise TypeError(f"stage={stage!r} must be a gearuq.GearStage")
    mesh = stage_mesh_stiffness(stage)
    values = stage_nominal(stage, mesh)
    out = []
    for p in parameters:
        if p.name in values:
            v = values[p.name]
            p = replace(p, nominal=v, lower=min(p.lower, v), upper=max(p.upper, v))
        if p.name in ("k_r", "k_a", "span") and "k_r_wheel" in values:
            p = replace(p, description=p.description.replace("per gear", "of the pinion")
                        + " (pinion shaft of the stage)")
        out.append(p)
    base = {p.name: p for p in parameters}
    for name, (units, text) in WHEEL_SUPPORT.items():
        if name in values:
            twin = base[name.removesuffix("_wheel")]
            out.append(Parameter(name, units, values[name], twin.lower, twin.upper, text))
    factor = 1.0
    if mesh.source == "ltca":
        nominal = {p.name: np.array([float(p.nominal)]) for p in out}
        k_iso = float(gear_data(nominal, use_virtual_teeth=use_virtual_teeth)["k_mesh"][0])
        factor = mesh.value_N_per_m / k_iso
    return tuple(out), factor
