"""The geared rotor built from a :class:`gearuq.GearStage`.

What the stage feeds: the pair, the tooth compliance (its material, the bore of the gear seat),
the nominal values (design torque and speed, ISO class, a shared parabolic tip relief, the
bearings' stiffness and damping, the end inertias, the backlash), the pitch-deviation germ of
its tooth numbers, and the FE rotor itself (:func:`gearuq.rotor.stage.stage_rotor`). What the
model cannot take is refused with the reason: other than two bearings per shaft, bearings
that differ (the
model has one radial, one axial stiffness and one damping for all four), per-gear ISO classes
or reliefs other than one shared parabolic tip relief.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

from gearuq.model import Parameter


def _refuse(stage: Any, text: str) -> None:
    raise ValueError(f"stage {stage.name!r}: {text} (geared_rotor; docs/stage.md, 'What each "
                     "model takes')")


def check_stage(stage: Any) -> None:
    """Refuse, naming the field, what the geared rotor cannot take from ``stage``."""
    from gearuq.gears.stage import GearStage

    if not isinstance(stage, GearStage):
        raise TypeError(f"stage={stage!r} must be a gearuq.GearStage")
    for name in ("pinion_shaft", "wheel_shaft"):
        shaft = getattr(stage, name)
        if shaft is None or len(shaft.bearings) != 2:
            _refuse(stage, f"[{name}] needs exactly two bearings (the model's four bearings)")
    bearings = stage.pinion_shaft.bearings + stage.wheel_shaft.bearings
    for key in ("radial_stiffness", "axial_stiffness", "damping"):
        if len({getattr(b, key) for b in bearings}) != 1:
            _refuse(stage, f"the bearings' {key} differ; the model has one value for all four")
    if stage.pinion.iso_grade != stage.wheel.iso_grade:
        _refuse(stage, "[pinion] and [wheel] iso_grade differ; the model has one ISO class")
    for gear in ("pinion", "wheel"):
        data = getattr(stage, gear)
        if data.root_relief is not None or data.lead_crowning or data.helix_slope_deviation \
                or data.single_pitch_deviations is not None:
            _refuse(stage, f"[{gear}] root relief, crowning, helix slope and measured pitch "
                    "deviations are not taken (tip relief only)")
    tips = (stage.pinion.tip_relief, stage.wheel.tip_relief)
    if tips != (None, None):
        lengths = [stage.relief_length(g, "tip") for g in ("pinion", "wheel")]
        if None in tips or any(r.shape != "parabolic" for r in tips) or \
                tips[0].amount != tips[1].amount or abs(lengths[0] - lengths[1]) > 1e-9:
            _refuse(stage, "[pinion.tip_relief] and [wheel.tip_relief] must be one parabolic "
                    "relief shared by both gears")


def stage_nominal(stage: Any) -> dict[str, float]:
    """Nominal values of the model's parameters (model units) from a checked stage."""
    from gearuq.gears.stage import to_si

    b = stage.pinion_shaft.bearings[0]
    values = {"torque": stage.operation.torque_design, "speed": stage.operation.speed_design,
              "iso_grade": float(stage.pinion.iso_grade or 0),
              "bearing_stiffness": to_si(b.radial_stiffness, "1e6"),
              "bearing_axial_stiffness": to_si(b.axial_stiffness, "1e6"),
              "bearing_damping": b.damping, "backlash": stage.backlash,
              "drive_inertia": stage.pinion_shaft.end_inertia,
              "load_inertia": stage.wheel_shaft.end_inertia}
    tip = stage.pinion.tip_relief
    values["tip_relief_amount"] = 0.0 if tip is None else tip.amount
    if tip is not None:
        values["tip_relief_length"] = stage.relief_length("pinion", "tip")
    return values


def stage_parameters(stage: Any, parameters: tuple[Parameter, ...]) -> tuple[Parameter, ...]:
    """The model's parameters for the stage: its germ, its ranges and nominal values."""
    from gearuq.gears.deviations import pitch_germ_names

    values = stage_nominal(stage)
    g_alpha = math.floor(stage.pair.g_alpha * 1e6) / 1e3  # path of contact [mm], rounded down
    germ_template = next(p for p in parameters if p.name.startswith("pitch_xi_p_"))
    out: list[Parameter] = []
    for p in parameters:
        if p.name.startswith(("pitch_xi_p_", "pitch_xi_g_")):
            continue
        if p.name == "tip_relief_length":
            p = replace(p, upper=g_alpha, nominal=min(p.nominal, g_alpha),
                        description=f"tip relief length along the path of contact (at most "
                        f"g_alpha = {g_alpha:.3f} mm)")
        if p.name in values:
            v = values[p.name]
            p = replace(p, nominal=v, lower=min(p.lower, v), upper=max(p.upper, v))
        out.append(p)
        if p.name == "pitch_phase_wheel":
            for gear, z in ((1, stage.teeth[0]), (2, stage.teeth[1])):
                for i, name in enumerate(pitch_germ_names(z, gear)):
                    out.append(replace(germ_template, name=name, description=(
                        f"{'pinion' if gear == 1 else 'wheel'} pitch-deviation germ, "
                        f"standard normal: {'cosine' if i % 2 == 0 else 'sine'} coefficient "
                        f"of tooth-index harmonic {i // 2 + 1} (z = {z})")))
    return tuple(out)


def stage_compliance(stage: Any) -> Any:
    """Tooth compliance with the stage's material and the bore of the pinion's gear seat."""
    from gearuq.gears.compliance import ComplianceModel
    from gearuq.gears.stage import to_si

    pair = stage.pair
    seat = to_si(stage.pinion_shaft.section_at(stage.pinion_shaft.gear_position)[1], "1e-3")
    return ComplianceModel(pair, bore_ratio=seat / pair.df1,
                           E=to_si(stage.material.young_modulus, "1e6"),
                           nu=stage.material.poisson_ratio)


def is_paper_rotor(stage: Any) -> bool:
    """Whether the stage's pair, shafts and material are those of Yuan, Liu and Liu's file.

    Their rotor is then built as :func:`gearuq.rotor.examples.seed002_rotor` builds it, with
    the paper's 13 elements per shaft (a discretisation the stage file does not state), so the
    stage route reproduces today's results bit for bit.
    """
    from gearuq.gears.stage import GearStage

    paper = GearStage.example("yuan_liu_liu")
    return (stage.pair == paper.pair and stage.pinion_shaft == paper.pinion_shaft
            and stage.wheel_shaft == paper.wheel_shaft and stage.material == paper.material)


class StageRotorFactory:
    """``factory(k) -> Rotor`` of one sample: the stage's rotor with the sample's bearings,
    end inertias and moment arm (picklable)."""

    def __init__(self, stage: Any, values: dict[str, float], moment_arm: str,
                 ends: bool) -> None:
        self.stage, self.moment_arm, self.ends = stage, moment_arm, ends
        self.paper = is_paper_rotor(stage)
        self.bearings = (values["bearing_stiffness"], values["bearing_axial_stiffness"],
                         values["bearing_damping"])
        self.inertias = ((values["drive_inertia"] or None, values["load_inertia"] or None)
                         if ends else (None, None))

    def __call__(self, k: float) -> Any:
        from gearuq.rotor.examples import seed002_rotor
        from gearuq.rotor.stage import stage_rotor

        if self.paper:
            kr, ka, c = self.bearings
            return seed002_rotor(k, pair=self.stage.pair, bearing_radial_stiffness=kr,
                                 bearing_axial_stiffness=ka, bearing_damping=c,
                                 moment_arm=self.moment_arm, drive_inertia=self.inertias[0],
                                 load_inertia=self.inertias[1])
        return stage_rotor(self.stage, k, bearing_labels="numbered", bearings=self.bearings,
                           end_inertias=self.inertias, moment_arm=self.moment_arm)
