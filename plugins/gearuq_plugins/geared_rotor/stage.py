"""The geared rotor built from a :class:`gearuq.GearStage`.

What the stage feeds: the pair, the tooth compliance (its material, the bore of the gear seat),
the nominal values (design torque and speed, the backlash, the end inertias), each bearing's
own radial and axial stiffness and damping, each gear's ISO 1328-1 class (or its measured
single pitch deviations), each gear's tip and root relief of any shape (linear, parabolic,
arc), the lead crowning and helix slope deviations, the pitch-deviation germ of its tooth
numbers, and the FE rotor itself (:func:`gearuq.rotor.stage.stage_rotor`).

How the parameters act (docs/stage.md, "What each model takes"):

- bearings: four equal bearings (Yuan, Liu and Liu's file) keep the parameters
  ``bearing_stiffness``, ``bearing_axial_stiffness``, ``bearing_damping`` (absolute values, as
  the paper's route); bearings that differ get instead the common scale factors
  ``bearing_stiffness_scale``, ``bearing_axial_stiffness_scale``, ``bearing_damping_scale``
  (nominal 1) on the stage's values, so a random factor moves every bearing alike and keeps
  the drawing's proportions between them;
- classes: ``iso_grade`` is the pinion's class; a wheel of another class adds
  ``iso_grade_wheel`` (the name ``mesh_excitation`` uses);
- reliefs: one parabolic tip relief shared by both gears stays on ``tip_relief_amount`` /
  ``tip_relief_length`` (the paper's route); any other relief travels as the stage's
  clearance map with one amount parameter per relief (``pinion_tip_relief_amount``...);
- measured single pitch deviations are a deterministic realisation: that gear's germ
  parameters are dropped and its cumulative deviations are the measured ones.

Refused with the reason: other than two bearings per shaft (the model's four bearing
outputs).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from gearuq.model import Parameter

#: The absolute bearing parameters and their scale-factor counterparts (unequal bearings).
BEARING_PARAMETERS = ("bearing_stiffness", "bearing_axial_stiffness", "bearing_damping")
BEARING_SCALES = tuple(f"{name}_scale" for name in BEARING_PARAMETERS)
_BEARING_KEYS = ("radial_stiffness", "axial_stiffness", "damping")


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


def equal_bearings(stage: Any) -> bool:
    """Whether the stage's four bearings have one radial, one axial stiffness and one damping
    (then the model keeps its absolute bearing parameters)."""
    bearings = stage.pinion_shaft.bearings + stage.wheel_shaft.bearings
    return all(len({getattr(b, key) for b in bearings}) == 1 for key in _BEARING_KEYS)


def shared_parabolic_tip(stage: Any) -> bool:
    """Whether the stage's reliefs are one parabolic tip relief shared by both gears (or
    none), with no helix slope deviation: the paper's route of ``tip_relief_amount``."""
    tips = (stage.pinion.tip_relief, stage.wheel.tip_relief)
    if stage.pinion.root_relief or stage.wheel.root_relief or \
            stage.pinion.helix_slope_deviation or stage.wheel.helix_slope_deviation:
        return False
    if tips == (None, None):
        return True
    lengths = [stage.relief_length(g, "tip") for g in ("pinion", "wheel")]
    return None not in tips and all(r.shape == "parabolic" for r in tips) and \
        tips[0].amount == tips[1].amount and abs(lengths[0] - lengths[1]) <= 1e-9


def relief_keys(stage: Any) -> tuple[str, ...]:
    """The stage's reliefs carried by its clearance map (``"pinion_tip"``...); empty on the
    paper's route."""
    if shared_parabolic_tip(stage):
        return ()
    return tuple(f"{gear}_{kind}" for kind in ("tip", "root") for gear in ("pinion", "wheel")
                 if getattr(getattr(stage, gear), f"{kind}_relief") is not None)


def measured_cumulative(stage: Any, gear: str) -> np.ndarray | None:
    """Cumulative pitch deviations [m] of a gear's measured single pitch deviations, or None.

    ``F_p,k = sum_{j <= k} f_pt,j`` with the tooth mean removed (the germ's convention: a
    common shift of all teeth turns the gear rigidly), so ``f_pt,k = F_p,k - F_p,k-1``.
    """
    spd = getattr(stage, gear).single_pitch_deviations
    if spd is None:
        return None
    fp = np.cumsum(np.asarray(spd, dtype=float)) * 1e-6
    return fp - fp.mean()


def stage_nominal(stage: Any) -> dict[str, float]:
    """Nominal values of the model's parameters (model units) from a checked stage."""
    from gearuq.gears.stage import to_si

    values = {"torque": stage.operation.torque_design, "speed": stage.operation.speed_design,
              "iso_grade": float(stage.pinion.iso_grade or 0), "backlash": stage.backlash,
              "drive_inertia": stage.pinion_shaft.end_inertia,
              "load_inertia": stage.wheel_shaft.end_inertia}
    if equal_bearings(stage):
        b = stage.pinion_shaft.bearings[0]
        values |= {"bearing_stiffness": to_si(b.radial_stiffness, "1e6"),
                   "bearing_axial_stiffness": to_si(b.axial_stiffness, "1e6"),
                   "bearing_damping": b.damping}
    if (stage.wheel.iso_grade or 0) != (stage.pinion.iso_grade or 0):
        values["iso_grade_wheel"] = float(stage.wheel.iso_grade or 0)
    tip = stage.pinion.tip_relief
    if shared_parabolic_tip(stage):
        values["tip_relief_amount"] = 0.0 if tip is None else tip.amount
        if tip is not None:
            values["tip_relief_length"] = stage.relief_length("pinion", "tip")
    else:
        values["tip_relief_amount"] = 0.0
    for key in relief_keys(stage):
        gear, kind = key.split("_")
        values[f"{key}_relief_amount"] = getattr(getattr(stage, gear), f"{kind}_relief").amount
    values["lead_crowning"] = stage.pinion.lead_crowning + stage.wheel.lead_crowning
    return values


def _added_parameters(stage: Any) -> list[Parameter]:
    """Parameters the stage adds: the wheel's class, bearing scales, per-relief amounts."""
    added = []
    if not equal_bearings(stage):
        for name, text in zip(BEARING_SCALES, ("radial stiffness", "axial stiffness",
                                               "damping"), strict=True):
            added.append(Parameter(name, "1", 1.0, 0.01, 100.0,
                                   f"common factor on the {text} of every bearing of the "
                                   "stage (the stage's bearings differ: 1 is the drawing)"))
    if (stage.wheel.iso_grade or 0) != (stage.pinion.iso_grade or 0):
        added.append(Parameter("iso_grade_wheel", "1", 0, 0, 12,
                               "ISO 1328-1 class of the wheel (the stage's; iso_grade is then "
                               "the pinion's); 0: pitch_amplitude and pitch_sigma",
                               integer=True))
    for key in relief_keys(stage):
        gear, kind = key.split("_")
        relief = getattr(getattr(stage, gear), f"{kind}_relief")
        added.append(Parameter(
            f"{key}_relief_amount", "um", 0.0, 0.0, 200.0,
            f"{relief.shape} {kind} relief of the {gear} (the stage's: {relief.amount:g} +- "
            f"{relief.amount_tolerance:g} um over {stage.relief_length(gear, kind):.3f} mm of "
            "the path of contact, along the line of action)"))
    return added


def stage_parameters(stage: Any, parameters: tuple[Parameter, ...]) -> tuple[Parameter, ...]:
    """The model's parameters for the stage: its germ, its ranges and nominal values.

    Bearings that differ replace the absolute bearing parameters by scale factors; a gear
    with measured pitch deviations has no germ.
    """
    from gearuq.gears.deviations import pitch_germ_names

    values = stage_nominal(stage)
    g_alpha = math.floor(stage.pair.g_alpha * 1e6) / 1e3  # path of contact [mm], rounded down
    germ_template = next(p for p in parameters if p.name.startswith("pitch_xi_p_"))
    unequal = not equal_bearings(stage)
    out: list[Parameter] = []
    for p in parameters:
        if p.name.startswith(("pitch_xi_p_", "pitch_xi_g_")) or (
                unequal and p.name in BEARING_PARAMETERS):
            continue
        if p.name == "tip_relief_length":
            p = replace(p, upper=g_alpha, nominal=min(p.nominal, g_alpha),
                        description=f"tip relief length along the path of contact (at most "
                        f"g_alpha = {g_alpha:.3f} mm)")
        out.append(p)
        if p.name == "pitch_phase_wheel":
            for gear, label, z in ((1, "pinion", stage.teeth[0]), (2, "wheel", stage.teeth[1])):
                if getattr(stage, label).single_pitch_deviations is not None:
                    continue  # measured: a deterministic realisation, no germ
                for i, name in enumerate(pitch_germ_names(z, gear)):
                    out.append(replace(germ_template, name=name, description=(
                        f"{label} pitch-deviation germ, standard normal: "
                        f"{'cosine' if i % 2 == 0 else 'sine'} coefficient "
                        f"of tooth-index harmonic {i // 2 + 1} (z = {z})")))
    out.extend(_added_parameters(stage))
    return tuple(p.with_nominal(values[p.name]) if p.name in values else p for p in out)


class StageFlanks:
    """What a stage adds to a sample's flank deviations (picklable).

    Its measured cumulative pitch deviations replace the germ's for that gear; its reliefs
    off the paper's route, with each amount read from the sample (``pinion_tip_relief_amount``
    ...), and its helix slope deviations enter as the stage's clearance map (its lead crowning
    is the parameter ``lead_crowning``, whose nominal is the stage's).
    """

    def __init__(self, stage: Any) -> None:
        self.stage = stage
        self.keys = relief_keys(stage)
        self.measured = (measured_cumulative(stage, "pinion"),
                         measured_cumulative(stage, "wheel"))
        self.use_map = not shared_parabolic_tip(stage)

    @property
    def value_keys(self) -> tuple[str, ...]:
        """Parameter names the flanks read (they enter the LTCA's cache key)."""
        return tuple(f"{k}_relief_amount" for k in self.keys)

    def apply(self, deviations: Any, values: dict[str, float]) -> Any:
        """``deviations`` with the stage's measured pitch, reliefs and slopes."""
        changes: dict[str, Any] = {}
        for name, fp in zip(("Fp1", "Fp2"), self.measured, strict=True):
            if fp is not None:
                changes[name] = fp
        if self.use_map:
            clearance = self.stage.relief_clearance(
                {k: values[f"{k}_relief_amount"] for k in self.keys})
            if clearance is not None:
                changes["user"] = clearance
        return replace(deviations, **changes) if changes else deviations

    def tip_relief_um(self, values: dict[str, float]) -> float:
        """Tip relief [um] for ISO 6336-1's K_v: the shared amount, or the largest of the
        per-gear tip reliefs."""
        amounts = [values[f"{g}_tip_relief_amount"] for g in ("pinion", "wheel")
                   if f"{g}_tip" in self.keys]
        return max([values["tip_relief_amount"], *amounts])


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
    end inertias and moment arm (picklable).

    Equal bearings take the sample's absolute values; bearings that differ keep each its
    stage values times the sample's scale factors.
    """

    def __init__(self, stage: Any, values: dict[str, float], moment_arm: str,
                 ends: bool) -> None:
        self.stage, self.moment_arm, self.ends = stage, moment_arm, ends
        self.paper = is_paper_rotor(stage)
        names = BEARING_PARAMETERS if BEARING_PARAMETERS[0] in values else BEARING_SCALES
        self.scaled = names is BEARING_SCALES
        self.bearings = tuple(values[n] for n in names)
        self.inertias = ((values["drive_inertia"] or None, values["load_inertia"] or None)
                         if ends else (None, None))

    def __call__(self, k: float) -> Any:
        from gearuq.rotor.examples import seed002_rotor
        from gearuq.rotor.stage import stage_rotor

        if self.paper and not self.scaled:
            kr, ka, c = self.bearings
            return seed002_rotor(k, pair=self.stage.pair, bearing_radial_stiffness=kr,
                                 bearing_axial_stiffness=ka, bearing_damping=c,
                                 moment_arm=self.moment_arm, drive_inertia=self.inertias[0],
                                 load_inertia=self.inertias[1])
        if self.scaled:
            return stage_rotor(self.stage, k, bearing_labels="numbered",
                               bearing_scale=self.bearings, end_inertias=self.inertias,
                               moment_arm=self.moment_arm)
        return stage_rotor(self.stage, k, bearing_labels="numbered", bearings=self.bearings,
                           end_inertias=self.inertias, moment_arm=self.moment_arm)
