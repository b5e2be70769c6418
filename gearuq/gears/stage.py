"""A user's gear stage: one frozen, validated description every gear model builds from.

A :class:`GearStage` holds what a gear drawing and a shaft layout state, in the units they
state it (mm, degrees, um, N/um, N m, rpm): the pair by its ISO 21771 basic data, per gear its
ISO 1328-1 accuracy and its flank modifications (tip and root relief: linear, parabolic or
arc, amount and start diameter or start roll length, with a drawing tolerance), the material,
each shaft as sections with the gear's and the bearings' positions, the operating range and
which inputs are random. Everything else is derived: the :class:`HelicalGearPair` (SI), relief
lengths along the path of contact, the one mesh stiffness of the stage
(:func:`stage_mesh_stiffness`), lumped supports of the shafts.

A TOML file holds a stage (:meth:`GearStage.from_toml`, :meth:`GearStage.to_toml`, an exact
round trip); the shipped stages are listed by :meth:`GearStage.examples`. The file format,
the conventions and the choices are in docs/stage.md.
"""

from __future__ import annotations

import functools
import math
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import MISSING, dataclass, field, fields, replace
from decimal import Decimal
from importlib import resources
from pathlib import Path
from typing import Any

import tomllib

from gearuq.gears.geometry import HelicalGearPair

__all__ = [
    "Bearing",
    "GearData",
    "GearStage",
    "Material",
    "Operation",
    "Relief",
    "Shaft",
    "StageMeshStiffness",
    "StiffnessBandWarning",
    "STIFFNESS_BAND",
    "stage_mesh_stiffness",
]

_DEG = math.pi / 180.0  # the same factor as gearuq.gears.geometry (bit-identical pairs)
RELIEF_SHAPES = ("linear", "parabolic", "arc")
#: Measured envelope of LTCA mean mesh stiffness over ISO 6336-1 c_gamma_alpha b (258 pairs,
#: docs/theory/ltca.md Sec. 4: 0.77-1.09), rounded outward; outside it a stage warns.
STIFFNESS_BAND = (0.75, 1.10)


def to_si(value: float, scale: str) -> float:
    """``value * scale`` rounded once, as the decimal the user wrote times a power of ten.

    ``to_si(6.0, "1e-3")`` is the double nearest 0.006, the same as the literal ``6e-3``, so a
    stage file reproduces the built-in configurations bit for bit.
    """
    return float(Decimal(repr(float(value))) * Decimal(scale))


# ---------------------------------------------------------------------- checks
def _number(where: str, value: Any, lo: float = -math.inf, hi: float = math.inf, *,
            text: str | None = None, closed_lo: bool = True, closed_hi: bool = True) -> float:
    """A finite real in [lo, hi] (open ends as told), else an error naming ``where``."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise TypeError(f"{where}={value!r} must be a number")
    v = float(value)
    ok = math.isfinite(v) and (v >= lo if closed_lo else v > lo) and (
        v <= hi if closed_hi else v < hi)
    if not ok:
        rng = text or f"{'[' if closed_lo else '('}{lo:g}, {hi:g}{']' if closed_hi else ')'}"
        if not math.isfinite(v):  # NaN is not outside [-inf, inf]: it is not a number
            bounded = math.isfinite(lo) or math.isfinite(hi) or text
            raise ValueError(f"{where}={value!r} is not a finite number"
                             + (f"; valid: {rng}" if bounded else ""))
        raise ValueError(f"{where}={value!r} is outside its valid range {rng}")
    return v


def _integer(where: str, value: Any, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{where}={value!r} must be an integer in [{lo}, {hi}]")
    if not lo <= value <= hi:
        raise ValueError(f"{where}={value!r} is outside its valid range [{lo}, {hi}]")
    return int(value)


def _pair_of(where: str, value: Any) -> tuple[Any, Any]:
    if isinstance(value, str | bytes) or not isinstance(value, Sequence) or len(value) != 2:
        raise TypeError(f"{where}={value!r} must be a pair [pinion, wheel]")
    return value[0], value[1]


def _known_keys(where: str, data: Mapping[str, Any], cls: type,
                supplied: tuple[str, ...] = ()) -> None:
    """Refuse keys that are not fields of ``cls`` (a typo fails at the read, by name), and
    name the required fields that are missing (``supplied``: those other tables give)."""
    if not isinstance(data, Mapping):
        raise TypeError(f"{where} must be a table, got {data!r}")
    valid = {f.name for f in fields(cls)}
    unknown = sorted(set(data) - valid)
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {unknown}; valid keys: {sorted(valid)}")
    missing = [f.name for f in fields(cls) if f.init and f.default is MISSING
               and f.default_factory is MISSING and f.name not in data
               and f.name not in supplied]
    if missing:
        raise ValueError(f"{where}: required key(s) {missing} missing (docs/stage.md lists "
                         "each key with its unit and valid range)")


# ---------------------------------------------------------------------- parts of a stage
@dataclass(frozen=True)
class Relief:
    """A profile modification (tip or root relief) as a drawing states it.

    Parameters
    ----------
    shape : {"linear", "parabolic", "arc"}
        Linear: ``C v / L``; parabolic: ``C (v / L)^2``; arc: a circular arc tangent to the
        involute at the start, ``R - sqrt(R^2 - v^2)`` with ``R = (L^2 + C^2) / (2 C)``
        (``v``: roll distance from the start of the modification, ``L``: its length to the
        end of the active profile).
    amount : float
        Relief ``C`` [um] at the end of the active profile (tip: the tip circle), measured
        normal to the profile in the transverse plane (along the line of action), >= 0.
    start_diameter : float or None
        Diameter [mm] where the modification starts (give this or ``start_roll_length``).
    start_roll_length : float or None
        Roll length [mm] of the start point from the gear's base-circle tangency point,
        ``sqrt(d^2 - d_b^2) / 2``.
    amount_tolerance : float
        Drawing tolerance +- [um] on ``amount`` (0 <= tolerance <= amount); a study may
        draw the amount in ``amount +- tolerance``.
    """

    shape: str
    amount: float
    start_diameter: float | None = None
    start_roll_length: float | None = None
    amount_tolerance: float = 0.0

    def __post_init__(self) -> None:
        if self.shape not in RELIEF_SHAPES:
            raise ValueError(f"shape={self.shape!r} is not one of {RELIEF_SHAPES}")
        object.__setattr__(self, "amount", _number("amount [um]", self.amount, 0.0, 1000.0))
        object.__setattr__(self, "amount_tolerance", _number(
            "amount_tolerance [um]", self.amount_tolerance, 0.0, self.amount,
            text=f"[0, amount={self.amount:g}] um"))
        given = [n for n in ("start_diameter", "start_roll_length")
                 if getattr(self, n) is not None]
        if len(given) != 1:
            raise ValueError("give exactly one of start_diameter [mm] or start_roll_length "
                             f"[mm], got {given or 'none'}")
        name = given[0]
        object.__setattr__(self, name, _number(f"{name} [mm]", getattr(self, name), 0.0,
                                               1e5, closed_lo=False))

    def start_roll(self, base_diameter_mm: float) -> float:
        """Roll length [mm] of the start point from the base-circle tangency point."""
        if self.start_roll_length is not None:
            return self.start_roll_length
        d = self.start_diameter
        if d <= base_diameter_mm:
            raise ValueError(f"start_diameter={d!r} mm is below the base circle "
                             f"d_b={base_diameter_mm:.4f} mm: valid range (d_b, d_a]")
        return 0.5 * math.sqrt(d * d - base_diameter_mm**2)

    def profile(self, v: Any, length: float) -> Any:
        """Relief [um] at roll distance ``v`` [mm] past the start (0 before it)."""
        import numpy as np

        v = np.clip(np.asarray(v, dtype=float), 0.0, length)
        if self.amount == 0.0 or length <= 0.0:
            return np.zeros_like(v)
        if self.shape == "linear":
            return self.amount * v / length
        if self.shape == "parabolic":
            return self.amount * (v / length) ** 2
        radius = (length**2 + self.amount**2 * 1e-6) / (2.0 * self.amount * 1e-3)  # mm
        return (radius - np.sqrt(radius**2 - v**2)) * 1e3


@dataclass(frozen=True)
class GearData:
    """Accuracy and flank modifications of one gear.

    Parameters
    ----------
    iso_grade : int or None
        ISO 1328-1 flank tolerance class 1-12 (``None``: not stated).
    single_pitch_deviations : tuple of float or None
        Measured single pitch deviations ``f_pt`` [um], one per tooth in the order the teeth
        enter mesh; their sum must be ~0 (a closed circle).
    tip_relief, root_relief : Relief or None
        Profile modifications.
    lead_crowning : float
        Lead crowning ``C_b`` [um], >= 0.
    helix_slope_deviation : float
        Helix slope deviation ``f_Hbeta`` [um] over the face width, signed in the mesh:
        positive opens the gap towards the face end ``y = b`` of the contact (the two gears'
        values add). The LTCA of the stage (:meth:`GearStage.flank_deviations`) takes it as
        the clearance ``f_Hbeta (y / b - 1/2)``.
    """

    iso_grade: int | None = None
    single_pitch_deviations: tuple[float, ...] | None = None
    tip_relief: Relief | None = None
    root_relief: Relief | None = None
    lead_crowning: float = 0.0
    helix_slope_deviation: float = 0.0

    def __post_init__(self) -> None:
        if self.iso_grade is not None:
            _integer("iso_grade", self.iso_grade, 1, 12)
        if self.single_pitch_deviations is not None:
            vals = tuple(_number(f"single_pitch_deviations[{i}] [um]", v, -1000.0, 1000.0)
                         for i, v in enumerate(self.single_pitch_deviations))
            if abs(sum(vals)) > 1e-6 * max(1.0, sum(abs(v) for v in vals)) + 1e-9:
                raise ValueError(f"single_pitch_deviations sum to {sum(vals)!r} um; valid: 0 "
                                 "(the pitches of a gear close the circle)")
            object.__setattr__(self, "single_pitch_deviations", vals)
        for name in ("tip_relief", "root_relief"):
            v = getattr(self, name)
            if v is not None and not isinstance(v, Relief):
                raise TypeError(f"{name}={v!r} must be a Relief")
        object.__setattr__(self, "lead_crowning",
                           _number("lead_crowning [um]", self.lead_crowning, 0.0, 1000.0))
        object.__setattr__(self, "helix_slope_deviation", _number(
            "helix_slope_deviation [um]", self.helix_slope_deviation, -1000.0, 1000.0))


@dataclass(frozen=True)
class Material:
    """Material of gears and shafts.

    Parameters
    ----------
    name : str
        Label.
    young_modulus : float
        [MPa] (N/mm^2, as drawings and gear software state it), in (1e3, 1e6).
    poisson_ratio : float
        In (0, 0.5).
    density : float
        [kg/m^3], in (100, 30000).
    """

    name: str = "steel"
    young_modulus: float = 206000.0
    poisson_ratio: float = 0.3
    density: float = 7850.0

    def __post_init__(self) -> None:
        if not isinstance(self.name, str):
            raise TypeError(f"[material] name={self.name!r} must be a string")
        object.__setattr__(self, "young_modulus", _number(
            "[material] young_modulus [MPa]", self.young_modulus, 1e3, 1e6))
        object.__setattr__(self, "poisson_ratio", _number(
            "[material] poisson_ratio", self.poisson_ratio, 0.0, 0.5, closed_lo=False,
            closed_hi=False))
        object.__setattr__(self, "density", _number(
            "[material] density [kg/m3]", self.density, 100.0, 30000.0))


@dataclass(frozen=True)
class Bearing:
    """One bearing on a shaft.

    Parameters
    ----------
    position : float
        Axial position of the bearing centre [mm] from the shaft's first end.
    radial_stiffness : float
        [N/um], > 0 (the same in both radial directions).
    axial_stiffness : float
        [N/um], >= 0 (0: a floating bearing).
    damping : float
        Radial and axial viscous damping [N s/m], >= 0.
    radial_clearance, axial_clearance : float
        Operating clearance [um] (total; the dead zone is +- half of it), >= 0.
    """

    position: float
    radial_stiffness: float
    axial_stiffness: float = 0.0
    damping: float = 0.0
    radial_clearance: float = 0.0
    axial_clearance: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _number("position [mm]", self.position))
        object.__setattr__(self, "radial_stiffness", _number(
            "radial_stiffness [N/um]", self.radial_stiffness, 0.0, 1e7, closed_lo=False))
        for name, unit in (("axial_stiffness", "N/um"), ("damping", "N s/m"),
                           ("radial_clearance", "um"), ("axial_clearance", "um")):
            object.__setattr__(self, name, _number(f"{name} [{unit}]", getattr(self, name),
                                                   0.0, 1e9))


@dataclass(frozen=True)
class Shaft:
    """A shaft as sections, with its gear and bearings.

    Parameters
    ----------
    sections : tuple of (length, outer_diameter, inner_diameter)
        [mm], from the shaft's first end (the drive end of the pinion shaft, the end facing
        the same way on the wheel shaft).
    gear_position : float
        Axial position of the middle of the gear's face [mm] from the first end.
    bearings : tuple of Bearing
        At least one.
    end_inertia : float
        Polar inertia [kg m^2] turning with one end of the shaft (drive or load side:
        coupling, motor rotor); 0: none.
    end_inertia_at : {"first", "last"}
        The end that carries ``end_inertia``.
    """

    sections: tuple[tuple[float, float, float], ...]
    gear_position: float
    bearings: tuple[Bearing, ...]
    end_inertia: float = 0.0
    end_inertia_at: str = "first"

    def __post_init__(self) -> None:
        if not isinstance(self.sections, Sequence) or len(self.sections) == 0:
            raise ValueError(f"sections={self.sections!r}: at least one [length, outer, "
                             "inner] row in mm")
        rows = []
        for i, row in enumerate(self.sections):
            if isinstance(row, str) or not isinstance(row, Sequence) or len(row) != 3:
                raise TypeError(f"sections[{i}]={row!r} must be [length, outer_diameter, "
                                "inner_diameter] in mm")
            length = _number(f"sections[{i}] length [mm]", row[0], 0.0, 1e5, closed_lo=False)
            outer = _number(f"sections[{i}] outer_diameter [mm]", row[1], 0.0, 1e5,
                            closed_lo=False)
            inner = _number(f"sections[{i}] inner_diameter [mm]", row[2], 0.0, outer,
                            closed_hi=False, text=f"[0, outer_diameter={outer:g}) mm")
            rows.append((length, outer, inner))
        object.__setattr__(self, "sections", tuple(rows))
        object.__setattr__(self, "gear_position",
                           _number("gear_position [mm]", self.gear_position))
        bearings = tuple(self.bearings)
        if not bearings or not all(isinstance(b, Bearing) for b in bearings):
            raise ValueError(f"bearings={self.bearings!r}: at least one Bearing")
        object.__setattr__(self, "bearings", bearings)
        for i, b in enumerate(bearings):
            if not 0.0 <= b.position <= self.length:
                raise ValueError(f"bearings[{i}] position={b.position!r} mm is off the shaft: "
                                 f"valid range [0, {self.length:g}] mm (sum of the sections)")
        object.__setattr__(self, "end_inertia",
                           _number("end_inertia [kg m2]", self.end_inertia, 0.0, 1e4))
        if self.end_inertia_at not in ("first", "last"):
            raise ValueError(f"end_inertia_at={self.end_inertia_at!r} is not one of "
                             "('first', 'last')")

    @property
    def length(self) -> float:
        """Total length [mm]."""
        return math.fsum(s[0] for s in self.sections)

    def section_at(self, z: float) -> tuple[float, float, float]:
        """The section (length, outer, inner) [mm] containing the position ``z`` [mm]."""
        end = 0.0
        for s in self.sections:
            end += s[0]
            if z <= end + 1e-12:
                return s
        return self.sections[-1]

    def support(self) -> dict[str, float]:
        """Lumped support of a rigid shaft at its gear (SI).

        ``radial`` = sum of the radial stiffnesses [N/m], ``axial`` likewise, ``tilt`` =
        sum of ``k_r (z_b - z_g)^2`` [N m/rad] about the gear centre.
        """
        zg = to_si(self.gear_position, "1e-3")
        radial = math.fsum(to_si(b.radial_stiffness, "1e6") for b in self.bearings)
        axial = math.fsum(to_si(b.axial_stiffness, "1e6") for b in self.bearings)
        tilt = math.fsum(to_si(b.radial_stiffness, "1e6") * (to_si(b.position, "1e-3") - zg)
                         ** 2 for b in self.bearings)
        return {"radial": radial, "axial": axial, "tilt": tilt}


@dataclass(frozen=True)
class Operation:
    """Operating range, on the pinion.

    Parameters
    ----------
    torque : (float, float)
        Pinion torque range [N m], 0 < min <= max.
    speed : (float, float)
        Pinion speed range [rpm], 0 < min <= max.
    design_torque : float or None
        [N m] within the range; ``None``: the largest torque.
    design_speed : float or None
        [rpm] within the range; ``None``: the largest speed.
    """

    torque: tuple[float, float] = (100.0, 1000.0)
    speed: tuple[float, float] = (100.0, 3000.0)
    design_torque: float | None = None
    design_speed: float | None = None

    def __post_init__(self) -> None:
        for name, unit in (("torque", "N m"), ("speed", "rpm")):
            lo, hi = _pair_of(f"[operation] {name}", getattr(self, name))
            lo = _number(f"[operation] {name}[0] [{unit}]", lo, 0.0, 1e7, closed_lo=False)
            hi = _number(f"[operation] {name}[1] [{unit}]", hi, lo, 1e7,
                         text=f"[{name}[0]={lo:g}, 1e7] {unit}")
            object.__setattr__(self, name, (lo, hi))
            design = f"design_{name}"
            if getattr(self, design) is not None:
                object.__setattr__(self, design, _number(
                    f"[operation] {design} [{unit}]", getattr(self, design), lo, hi))

    @property
    def torque_design(self) -> float:
        """Design torque [N m] (given, else the top of the range)."""
        return self.torque[1] if self.design_torque is None else self.design_torque

    @property
    def speed_design(self) -> float:
        """Design speed [rpm] (given, else the top of the range)."""
        return self.speed[1] if self.design_speed is None else self.design_speed


_PAIR_NAMES = {  # HelicalGearPair argument -> the stage file's name
    "mn": "normal_module", "z1": "teeth[0]", "z2": "teeth[1]",
    "alpha_n": "normal_pressure_angle", "beta": "helix_angle", "b1": "face_width[0]",
    "b2": "face_width[1]", "x1": "profile_shift[0]", "x2": "profile_shift[1]",
    "ha_star": "addendum_factor", "hf_star": "dedendum_factor",
    "rho_f_star": "root_radius_factor", "a": "centre_distance",
    "eps_alpha": "transverse contact ratio eps_alpha",
}


# ---------------------------------------------------------------------- the stage
@dataclass(frozen=True)
class GearStage:
    """One helical (or spur) gear stage, as drawings state it (immutable, validated).

    Parameters
    ----------
    normal_module : float
        ``m_n`` [mm].
    teeth : (int, int)
        ``z1`` (pinion, driving), ``z2`` (wheel).
    normal_pressure_angle : float
        ``alpha_n`` [deg].
    helix_angle : float
        ``beta`` [deg], 0 for a spur stage.
    face_width : (float, float)
        ``b1, b2`` [mm].
    profile_shift : (float, float)
        ``x1, x2`` (ISO 21771 signs), default 0.
    addendum_factor, dedendum_factor, root_radius_factor : float
        Basic rack ``h_aP*, h_fP*, rho_fP*`` (ISO 53 A: 1.0, 1.25, 0.38).
    centre_distance : float or None
        Working centre distance [mm]; ``None``: the zero-backlash one for ``x1 + x2``.
    tip_diameters : (float, float) or None
        [mm] when not ``d + 2 m_n (h_aP* + x)`` (tip shortening).
    backlash : float
        Normal circumferential backlash allowance ``j_n`` [um] (the tooth thinning that makes
        it is within the tolerance and not part of the geometry), >= 0.
    pinion, wheel : GearData
        Accuracy and flank modifications per gear.
    material : Material
        Gears and shafts.
    pinion_shaft, wheel_shaft : Shaft or None
        Needed by the models with shafts and bearings.
    operation : Operation
        Torque and speed ranges.
    random : tuple of (name, spec)
        Random inputs by model parameter name, each a ``gearuq.ParameterSpace`` spec (a
        mapping such as ``{"dist": "uniform", "lower": 5, "upper": 11}``), stored as sorted
        ``(key, value)`` tuples so the stage stays hashable; see :attr:`random_inputs`.
    reliability : tuple of (key, value)
        The limit of ``gearuq run``'s reliability step (``[reliability]`` in the file):
        ``model`` (a registered gear model, built from the stage), ``output``, ``lower`` and/or
        ``upper`` (the allowed band, in the output's units), ``method`` (default
        ``"subset"``), ``seed``, ``n_base`` (Sobol' base sample, default 128),
        ``model_options`` and ``method_settings`` (tables); see
        :attr:`reliability_settings`.
    stiffness_source : {"ltca", "iso6336"}
        Source of the stage's one mesh stiffness (:func:`stage_mesh_stiffness`): the LTCA
        (default) or ISO 6336-1 method B (Li, Hu and Han's model, kept for its file).
    name, description, source : str
        Label, one line, and where the data come from.

    Raises
    ------
    ValueError, TypeError
        A value out of its range or of the wrong type, or an impossible stage (undercut,
        pointed tip, tip interference, transverse contact ratio below 1, a bearing off its
        shaft, a gear face beyond its shaft, a relief starting outside the active profile).
        The message names the file's parameter and the limit.

    Examples
    --------
    >>> stage = GearStage.example("e_axle_27_79")
    >>> stage.teeth, stage.is_hunting_tooth, stage.long_period_mesh_cycles
    ((27, 79), True, 2133)
    >>> round(stage.summary()["eps_alpha"], 3)
    1.496
    """

    normal_module: float
    teeth: tuple[int, int]
    normal_pressure_angle: float
    helix_angle: float
    face_width: tuple[float, float]
    profile_shift: tuple[float, float] = (0.0, 0.0)
    addendum_factor: float = 1.0
    dedendum_factor: float = 1.25
    root_radius_factor: float = 0.38
    centre_distance: float | None = None
    tip_diameters: tuple[float, float] | None = None
    backlash: float = 0.0
    pinion: GearData = field(default_factory=GearData)
    wheel: GearData = field(default_factory=GearData)
    material: Material = field(default_factory=Material)
    pinion_shaft: Shaft | None = None
    wheel_shaft: Shaft | None = None
    operation: Operation = field(default_factory=Operation)
    random: tuple[tuple[str, tuple[tuple[str, Any], ...]], ...] = ()
    reliability: tuple[tuple[str, Any], ...] = ()
    stiffness_source: str = "ltca"
    name: str = "stage"
    description: str = ""
    source: str = ""

    # ------------------------------------------------------------------ validation
    def __post_init__(self) -> None:
        z1, z2 = _pair_of("[pair] teeth", self.teeth)
        object.__setattr__(self, "teeth", (_integer("[pair] teeth[0]", z1, 5, 10000),
                                           _integer("[pair] teeth[1]", z2, 5, 10000)))
        set_ = functools.partial(object.__setattr__, self)
        set_("normal_module", _number("[pair] normal_module [mm]", self.normal_module, 0.0,
                                      1000.0, closed_lo=False))
        set_("normal_pressure_angle", _number("[pair] normal_pressure_angle [deg]",
                                              self.normal_pressure_angle, 0.0, 45.0,
                                              closed_lo=False, closed_hi=False))
        set_("helix_angle", _number("[pair] helix_angle [deg]", self.helix_angle, 0.0, 45.0,
                                    closed_hi=False))
        for name, lo, hi, unit in (("face_width", 0.0, 1e4, "mm"),
                                   ("profile_shift", -3.0, 3.0, "")):
            a, b = _pair_of(f"[pair] {name}", getattr(self, name))
            set_(name, tuple(_number(f"[pair] {name}[{i}]{' [' + unit + ']' if unit else ''}",
                                     v, lo, hi, closed_lo=name != "face_width")
                             for i, v in enumerate((a, b))))
        for name in ("addendum_factor", "dedendum_factor"):
            set_(name, _number(f"[pair] {name}", getattr(self, name), 0.0, 3.0,
                               closed_lo=False, closed_hi=False))
        set_("root_radius_factor", _number("[pair] root_radius_factor",
                                           self.root_radius_factor, 0.0, 1.0, closed_hi=False))
        if self.centre_distance is not None:
            set_("centre_distance", _number("[pair] centre_distance [mm]",
                                            self.centre_distance, 0.0, 1e5, closed_lo=False))
        if self.tip_diameters is not None:
            da = _pair_of("[pair] tip_diameters", self.tip_diameters)
            set_("tip_diameters", tuple(_number(f"[pair] tip_diameters[{i}] [mm]", v, 0.0,
                                                1e5, closed_lo=False)
                                        for i, v in enumerate(da)))
        set_("backlash", _number("[pair] backlash [um]", self.backlash, 0.0, 1e4))
        for name, cls in (("pinion", GearData), ("wheel", GearData), ("material", Material),
                          ("operation", Operation)):
            if not isinstance(getattr(self, name), cls):
                raise TypeError(f"{name}={getattr(self, name)!r} must be a {cls.__name__}")
        if self.stiffness_source not in ("ltca", "iso6336"):
            raise ValueError(f"stiffness_source={self.stiffness_source!r} is not one of "
                             "('ltca', 'iso6336')")
        for name in ("name", "description", "source"):
            if not isinstance(getattr(self, name), str):
                raise TypeError(f"{name}={getattr(self, name)!r} must be a string")
        pair = self._build_pair()
        object.__setattr__(self, "_pair", pair)
        self._check_gears(pair)
        self._check_shafts(pair)
        self._check_random()
        self._check_reliability()

    def _build_pair(self) -> HelicalGearPair:
        try:
            return HelicalGearPair(
                mn=to_si(self.normal_module, "1e-3"), z1=self.teeth[0], z2=self.teeth[1],
                alpha_n=self.normal_pressure_angle * _DEG, beta=self.helix_angle * _DEG,
                b1=to_si(self.face_width[0], "1e-3"), b2=to_si(self.face_width[1], "1e-3"),
                x1=self.profile_shift[0], x2=self.profile_shift[1],
                ha_star=self.addendum_factor, hf_star=self.dedendum_factor,
                rho_f_star=self.root_radius_factor,
                a=None if self.centre_distance is None else to_si(self.centre_distance,
                                                                   "1e-3"),
                tip_diameters=None if self.tip_diameters is None else tuple(
                    to_si(d, "1e-3") for d in self.tip_diameters),
            )
        except ValueError as exc:
            text = str(exc)
            text = re.sub(r"\b(mn|z1|z2|alpha_n|beta|b1|b2|x1|x2|ha_star|hf_star|rho_f_star|a|"
                          r"eps_alpha)\b(?==|/|:)",
                          lambda m: f"{_PAIR_NAMES[m.group(1)]} ({m.group(1)})", text, count=1)
            raise ValueError(f"[pair] {text} (SI units in the limit: m, rad)") from None

    def _check_gears(self, pair: HelicalGearPair) -> None:
        for label, gear, z in (("pinion", self.pinion, pair.z1), ("wheel", self.wheel, pair.z2)):
            spd = gear.single_pitch_deviations
            if spd is not None and len(spd) != z:
                raise ValueError(f"[{label}] single_pitch_deviations has {len(spd)} values; "
                                 f"valid: one per tooth ({z})")
            for kind in ("tip", "root"):
                if getattr(gear, f"{kind}_relief") is not None:
                    try:
                        self.relief_length(label, kind)
                    except ValueError as exc:
                        raise ValueError(f"[{label}.{kind}_relief] {exc}") from None

    def _check_shafts(self, pair: HelicalGearPair) -> None:
        for label, shaft, b, df in (("pinion_shaft", self.pinion_shaft, self.face_width[0],
                                     pair.df1 * 1e3),
                                    ("wheel_shaft", self.wheel_shaft, self.face_width[1],
                                     pair.df2 * 1e3)):
            if shaft is None:
                continue
            if not isinstance(shaft, Shaft):
                raise TypeError(f"{label}={shaft!r} must be a Shaft")
            lo, hi = shaft.gear_position - b / 2, shaft.gear_position + b / 2
            if lo < -1e-9 or hi > shaft.length + 1e-9:
                raise ValueError(
                    f"[{label}] gear_position={shaft.gear_position!r} mm with face width "
                    f"{b:g} mm puts the face [{lo:g}, {hi:g}] mm beyond the shaft's sections "
                    f"[0, {shaft.length:g}] mm; valid gear_position range "
                    f"[{b / 2:g}, {shaft.length - b / 2:g}] mm")
            seat = shaft.section_at(shaft.gear_position)[1]
            if seat >= df:
                raise ValueError(
                    f"[{label}] the section under the gear (outer diameter {seat:g} mm) is not "
                    f"below the gear's root diameter d_f={df:.3f} mm: valid outer diameter "
                    f"range (0, {df:.3f}) mm")

    def _check_random(self) -> None:
        if not isinstance(self.random, tuple):
            raise TypeError("random must be a tuple of (name, spec) pairs; use "
                            "GearStage.from_dict for a mapping")
        for item in self.random:
            if len(item) != 2 or not isinstance(item[0], str):
                raise TypeError(f"random entry {item!r} must be (name, spec)")
            spec = dict(item[1])
            if not isinstance(spec.get("dist"), str):
                raise ValueError(f"[random.{item[0]}] needs dist = \"normal\" | \"uniform\" | "
                                 f"... (gearuq.ParameterSpace), got {spec!r}")

    def _check_reliability(self) -> None:
        if not self.reliability:
            return
        valid = {"model", "output", "lower", "upper", "method", "seed", "n_base",
                 "model_options", "method_settings"}
        settings = self.reliability_settings
        unknown = sorted(set(settings) - valid)
        if unknown:
            raise ValueError(f"[reliability]: unknown key(s) {unknown}; valid keys: "
                             f"{sorted(valid)}")
        for key in ("model", "output"):
            if not isinstance(settings.get(key), str):
                raise ValueError(f"[reliability] needs {key} = \"...\" (a string), got "
                                 f"{settings.get(key)!r}")
        if "lower" not in settings and "upper" not in settings:
            raise ValueError("[reliability] needs lower and/or upper (the allowed band of "
                             "the output)")
        for key in ("lower", "upper"):
            if key in settings:
                _number(f"[reliability] {key}", settings[key])
        if "n_base" in settings:
            n_base = _integer("[reliability] n_base", settings["n_base"], 8, 1 << 20)
            if n_base & (n_base - 1):  # the Saltelli design is balanced at powers of 2
                raise ValueError(f"[reliability] n_base={n_base} is not a power of 2; valid: "
                                 "8, 16, 32, ..., 1048576")
        if "seed" in settings:
            _integer("[reliability] seed", settings["seed"], 0, 2**63 - 1)
        if not self.random:
            raise ValueError("[reliability] needs random inputs ([random.NAME] tables)")

    @property
    def reliability_settings(self) -> dict[str, Any]:
        """The ``[reliability]`` table as a dict (``model_options`` as a dict)."""
        out = dict(self.reliability)
        for key in ("model_options", "method_settings"):
            if key in out:
                out[key] = dict(out[key])
        return out

    # ------------------------------------------------------------------ derived geometry
    @property
    def pair(self) -> HelicalGearPair:
        """The pair in SI units (ISO 21771 geometry, validated at construction)."""
        return self._pair  # type: ignore[attr-defined]

    @property
    def is_hunting_tooth(self) -> bool:
        """Whether ``z1`` and ``z2`` are coprime (every tooth meets every tooth)."""
        return math.gcd(*self.teeth) == 1

    @property
    def long_period_mesh_cycles(self) -> int:
        """Mesh cycles after which the tooth pairing repeats, ``lcm(z1, z2)``."""
        return math.lcm(*self.teeth)

    def mesh_frequency(self, speed_rpm: float) -> float:
        """Mesh frequency ``z1 n / 60`` [Hz] at pinion speed ``speed_rpm``."""
        return self.teeth[0] * speed_rpm / 60.0

    def _roll_limits(self, gear: str) -> tuple[float, float, float]:
        """Base diameter [mm] and the roll lengths [mm] of the active root and tip."""
        p = self.pair
        if gear == "pinion":
            return p.db1 * 1e3, p.g_f1 * 1e3, (p.g_f1 + p.g_alpha) * 1e3
        return p.db2 * 1e3, p.g_f2 * 1e3, (p.g_f2 + p.g_alpha) * 1e3

    def relief_length(self, gear: str, kind: str) -> float:
        """Length [mm] of a relief along the path of contact (0 when there is none).

        Tip relief: from its start to the end of the active profile at the tip; root relief:
        from its start down to the start of the active profile.
        """
        data = self.pinion if gear == "pinion" else self.wheel
        relief = getattr(data, f"{kind}_relief")
        if relief is None:
            return 0.0
        db, root, tip = self._roll_limits(gear)
        start = relief.start_roll(db)
        length = tip - start if kind == "tip" else start - root
        if not 0.0 < length <= tip - root + 1e-9:
            where = ("start_diameter" if relief.start_diameter is not None
                     else "start_roll_length")
            d_lo, d_hi = (2.0 * math.sqrt(r * r + (db / 2) ** 2) for r in (root, tip))
            raise ValueError(
                f"{where}={getattr(relief, where)!r} mm starts the {kind} relief outside the "
                f"active profile: valid roll lengths ({root:.4f}, {tip:.4f}) mm, diameters "
                f"({d_lo:.4f}, {d_hi:.4f}) mm")
        return length

    def profile_relief(self, s_mm: Any, amounts: Mapping[str, float] | None = None) -> Any:
        """Total profile relief [um] of both gears at path positions ``s`` [mm] from T1.

        ``s`` is the pinion's roll length (gearuq.gears.contact: contact runs from
        ``s_A = g_f1`` to ``s_E = s_A + g_alpha``); the wheel's roll length is
        ``T1T2 - s``. ``amounts`` replaces relief amounts [um] by key
        ``"pinion_tip"``, ``"wheel_root"``, ... (a sampled amount; the shape, start and
        length stay the drawing's).
        """
        import numpy as np

        s = np.asarray(s_mm, dtype=float)
        p = self.pair
        t1t2 = p.centre_distance * math.sin(p.alpha_wt) * 1e3
        total = np.zeros_like(s)
        for gear, roll in (("pinion", s), ("wheel", t1t2 - s)):
            data = self.pinion if gear == "pinion" else self.wheel
            db = self._roll_limits(gear)[0]
            for kind in ("tip", "root"):
                relief = getattr(data, f"{kind}_relief")
                if relief is None:
                    continue
                start = relief.start_roll(db)
                length = self.relief_length(gear, kind)
                if amounts and f"{gear}_{kind}" in amounts:
                    relief = replace(relief, amount=float(amounts[f"{gear}_{kind}"]),
                                     amount_tolerance=0.0)
                v = roll - start if kind == "tip" else start - roll
                total = total + np.where(v > 0.0, relief.profile(v, length), 0.0)
        return total

    def relief_clearance(self, amounts: Mapping[str, float] | None = None) -> Any:
        """The reliefs and helix slope deviations as ``FlankDeviations.user``:
        ``f(s, y, k1, k2)`` -> normal clearance [m].

        ``None`` when the stage has neither; ``amounts`` as in :meth:`profile_relief`.
        """
        if not any(getattr(g, f"{k}_relief") is not None
                   for g in (self.pinion, self.wheel) for k in ("tip", "root")) and not (
                self.pinion.helix_slope_deviation or self.wheel.helix_slope_deviation):
            return None
        return _ProfileClearance(self, math.cos(self.pair.beta_b), amounts)

    def flank_deviations(self) -> Any:
        """The stage's designed flank modifications as a :class:`FlankDeviations`.

        Every relief shape and per-gear values (as a normal-clearance map), the lead
        crowning of both gears; no pitch deviations (the same on every tooth).
        """
        from gearuq.gears.deviations import FlankDeviations

        crowning = to_si(self.pinion.lead_crowning + self.wheel.lead_crowning, "1e-6")
        return FlankDeviations(crowning=crowning, user=self.relief_clearance())

    # ------------------------------------------------------------------ random inputs
    @property
    def random_inputs(self) -> dict[str, dict[str, Any]]:
        """The random inputs as ``{parameter: spec}`` (a ``gearuq.ParameterSpace`` spec)."""
        return {name: dict(spec) for name, spec in self.random}

    # ------------------------------------------------------------------ dict / TOML
    def to_dict(self) -> dict[str, Any]:
        """The stage as the nested tables of its file (``None`` values left out)."""
        pair = {k: getattr(self, k) for k in (
            "normal_module", "teeth", "normal_pressure_angle", "helix_angle", "face_width",
            "profile_shift", "addendum_factor", "dedendum_factor", "root_radius_factor",
            "centre_distance", "tip_diameters", "backlash")}
        out: dict[str, Any] = {"name": self.name, "description": self.description,
                               "source": self.source, "stiffness_source": self.stiffness_source,
                               "pair": _plain(pair)}
        out["pinion"], out["wheel"] = _plain(self.pinion), _plain(self.wheel)
        out["material"] = _plain(self.material)
        for name in ("pinion_shaft", "wheel_shaft"):
            if getattr(self, name) is not None:
                out[name] = _plain(getattr(self, name))
        out["operation"] = _plain(self.operation)
        if self.random:
            out["random"] = self.random_inputs
        if self.reliability:
            out["reliability"] = self.reliability_settings
        return _drop_none(out)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> GearStage:
        """Build a stage from the tables of a file (see docs/stage.md for every key)."""
        if not isinstance(data, Mapping):
            raise TypeError(f"a stage must be a table, got {type(data).__name__}")
        tables = {"name", "description", "source", "stiffness_source", "pair", "pinion",
                  "wheel", "material", "pinion_shaft", "reliability", "wheel_shaft",
                  "operation", "random"}
        unknown = sorted(set(data) - tables)
        if unknown:
            raise ValueError(f"unknown table(s) or key(s) {unknown}; valid: {sorted(tables)}")
        if "pair" not in data:
            raise ValueError("a stage needs a [pair] table (normal_module, teeth, "
                             "normal_pressure_angle, helix_angle, face_width)")
        pair = dict(data["pair"]) if isinstance(data["pair"], Mapping) else data["pair"]
        _known_keys("[pair]", pair, cls, supplied=tuple(tables))
        for key in ("pinion", "wheel", "material", "pinion_shaft", "wheel_shaft",
                    "operation", "random", "reliability", "name", "description", "source",
                    "stiffness_source"):
            if key in pair:
                raise ValueError(f"[pair] {key}: not a [pair] key")
        kwargs: dict[str, Any] = dict(pair)
        for key in ("teeth", "face_width", "profile_shift", "tip_diameters"):
            if key in kwargs:
                kwargs[key] = tuple(_pair_of(f"[pair] {key}", kwargs[key]))
        for gear in ("pinion", "wheel"):
            if gear in data:
                kwargs[gear] = _gear_from(gear, data[gear])
        if "material" in data:
            _known_keys("[material]", data["material"], Material)
            kwargs["material"] = Material(**data["material"])
        for name in ("pinion_shaft", "wheel_shaft"):
            if name in data:
                kwargs[name] = _shaft_from(name, data[name])
        if "operation" in data:
            _known_keys("[operation]", data["operation"], Operation)
            op = dict(data["operation"])
            for key in ("torque", "speed"):
                if key in op:
                    op[key] = tuple(_pair_of(f"[operation] {key}", op[key]))
            kwargs["operation"] = Operation(**op)
        if "random" in data:
            rnd = data["random"]
            if not isinstance(rnd, Mapping) or not all(isinstance(v, Mapping)
                                                       for v in rnd.values()):
                raise TypeError("[random] must hold one table per parameter, e.g. "
                                "[random.torque] dist = \"uniform\" ...")
            kwargs["random"] = tuple((k, tuple(sorted((kk, _freeze(vv)) for kk, vv in
                                                      v.items())))
                                     for k, v in sorted(rnd.items()))
        if "reliability" in data:
            rel = data["reliability"]
            if not isinstance(rel, Mapping):
                raise TypeError("[reliability] must be a table")
            kwargs["reliability"] = tuple(
                (k, tuple(sorted((kk, _freeze(vv)) for kk, vv in v.items()))
                 if isinstance(v, Mapping) else _freeze(v)) for k, v in sorted(rel.items()))
        for key in ("name", "description", "source", "stiffness_source"):
            if key in data:
                kwargs[key] = data[key]
        return cls(**kwargs)

    @classmethod
    def from_toml(cls, path: str | Path) -> GearStage:
        """Read a stage file (TOML, read by the standard library's ``tomllib``)."""
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"stage file {str(path)!r}: " + (
                "a folder, not a file" if path.is_dir() else "no such file"))
        try:
            # utf-8-sig: a byte-order mark some editors write is not TOML's, and is dropped
            data = tomllib.loads(path.read_bytes().decode("utf-8-sig"))
        except UnicodeDecodeError:
            raise ValueError(f"{path}: not a text file; a stage file is TOML text "
                             "(docs/stage.md)") from None
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{path}: not valid TOML: {exc}") from None
        try:
            return cls.from_dict(data)
        except (ValueError, TypeError) as exc:
            raise type(exc)(f"{path.name}: {exc}") from None

    def to_toml(self, path: str | Path | None = None) -> str:
        """Write the stage as TOML (to ``path`` if given) and return the text.

        ``GearStage.from_toml(path) == stage`` holds exactly: floats are written as their
        shortest round-trip decimal.
        """
        text = _toml_document(self.to_dict())
        if path is not None:
            Path(path).write_text(text, encoding="utf-8")
        return text

    # ------------------------------------------------------------------ stiffness
    def mesh_stiffness(self, **options: Any) -> StageMeshStiffness:
        """The stage's one mesh stiffness (:func:`stage_mesh_stiffness`)."""
        return stage_mesh_stiffness(self, **options)

    # ------------------------------------------------------------------ shipped stages
    @staticmethod
    def examples() -> list[str]:
        """Names of the shipped stage files (``GearStage.example(name)`` reads one)."""
        folder = resources.files("gearuq.gears") / "stages"
        return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))

    @classmethod
    def example(cls, name: str) -> GearStage:
        """Read the shipped stage ``name`` (one of :meth:`examples`)."""
        names = cls.examples()
        if name not in names:
            raise ValueError(f"name={name!r} is not a shipped stage; valid: {names}")
        with resources.as_file(resources.files("gearuq.gears") / "stages" /
                               f"{name}.toml") as path:
            return cls.from_toml(path)

    # ------------------------------------------------------------------ stiffness
    def summary(self) -> dict[str, float]:
        """Main derived quantities in drawing units (mm, deg) for tables and reports."""
        p = self.pair
        mm = {k: getattr(p, k) * 1e3 for k in ("d1", "d2", "db1", "db2", "da1", "da2", "df1",
                                                "df2", "centre_distance", "pbt", "pbn",
                                                "g_alpha")}
        return {**mm, "alpha_wt_deg": math.degrees(p.alpha_wt),
                "beta_b_deg": math.degrees(p.beta_b), "eps_alpha": p.eps_alpha,
                "eps_beta": p.eps_beta, "eps_gamma": p.eps_gamma}


class _ProfileClearance:
    """``user(s, y, k1, k2)`` of FlankDeviations: the stage's reliefs and helix slope
    deviations as normal clearance [m] (transverse values times ``cos(beta_b)``, as the
    LTCA's own reliefs and crowning)."""

    #: the map ignores the tooth indices, so the line-load table may hold it
    #: (:mod:`gearuq.gears.long_period`)
    same_on_every_tooth = True

    def __init__(self, stage: GearStage, cos_bb: float,
                 amounts: Mapping[str, float] | None = None) -> None:
        self.stage, self.cos_bb, self.amounts = stage, cos_bb, amounts

    def __call__(self, s: Any, y: Any, k1: Any, k2: Any) -> Any:
        import numpy as np

        stage = self.stage
        relief = stage.profile_relief(np.asarray(s) * 1e3, self.amounts) * 1e-6
        slope = to_si(stage.pinion.helix_slope_deviation + stage.wheel.helix_slope_deviation,
                      "1e-6")
        if slope:
            relief = relief + slope * (np.asarray(y) / stage.pair.face_width - 0.5)
        return np.broadcast_to(relief * self.cos_bb, np.broadcast_shapes(
            np.shape(s), np.shape(y), np.shape(k1), np.shape(k2)))


def _freeze(value: Any) -> Any:
    return tuple(value) if isinstance(value, list) else value


def _gear_from(label: str, data: Any) -> GearData:
    _known_keys(f"[{label}]", data, GearData)
    kw = dict(data)
    for kind in ("tip_relief", "root_relief"):
        if kind in kw:
            _known_keys(f"[{label}.{kind}]", kw[kind], Relief)
            try:
                kw[kind] = Relief(**kw[kind])
            except (ValueError, TypeError) as exc:
                raise type(exc)(f"[{label}.{kind}] {exc}") from None
    if "single_pitch_deviations" in kw:
        kw["single_pitch_deviations"] = tuple(kw["single_pitch_deviations"])
    try:
        return GearData(**kw)
    except (ValueError, TypeError) as exc:
        raise type(exc)(f"[{label}] {exc}") from None


def _shaft_from(label: str, data: Any) -> Shaft:
    _known_keys(f"[{label}]", data, Shaft)
    kw = dict(data)
    bearings = []
    for i, b in enumerate(kw.get("bearings", ())):
        _known_keys(f"[[{label}.bearings]] {i}", b, Bearing)
        try:
            bearings.append(Bearing(**b))
        except (ValueError, TypeError) as exc:
            raise type(exc)(f"[[{label}.bearings]] {i}: {exc}") from None
    kw["bearings"] = tuple(bearings)
    if "sections" in kw:
        if not isinstance(kw["sections"], list | tuple):
            raise TypeError(f"[{label}] sections={kw['sections']!r} must be a list of "
                            "[length, outer_diameter, inner_diameter] rows in mm")
        kw["sections"] = tuple(tuple(r) if isinstance(r, list | tuple) else r
                               for r in kw["sections"])
    try:
        return Shaft(**kw)
    except (ValueError, TypeError) as exc:
        raise type(exc)(f"[{label}] {exc}") from None


def _plain(obj: Any) -> Any:
    """Dataclasses and tuples as dicts and lists (for the writer)."""
    if hasattr(obj, "__dataclass_fields__"):
        return {f.name: _plain(getattr(obj, f.name)) for f in fields(obj)}
    if isinstance(obj, Mapping):
        return {k: _plain(v) for k, v in obj.items()}
    if isinstance(obj, tuple | list):
        return [_plain(v) for v in obj]
    return obj


def _drop_none(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _drop_none(v) for k, v in obj.items() if v is not None}
    if isinstance(obj, list):
        return [_drop_none(v) for v in obj]
    return obj


# ---------------------------------------------------------------------- a small TOML writer
_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _toml_key(key: str) -> str:
    return key if _BARE_KEY.match(key) else _toml_string(key)


def _toml_string(s: str) -> str:
    out = s.replace("\\", "\\\\").replace('"', '\\"')
    out = "".join(c if c >= " " or c == "\t" else f"\\u{ord(c):04x}" for c in out)
    return f'"{out}"'


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        text = repr(v)  # shortest round-trip decimal
        return text if any(c in text for c in ".eEn") else text + ".0"
    if isinstance(v, str):
        return _toml_string(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, Mapping):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"cannot write {v!r} ({type(v).__name__}) as TOML")


def _is_table_array(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, Mapping) for x in v)


def _toml_table(prefix: str, table: Mapping[str, Any], lines: list[str]) -> None:
    scalars = {k: v for k, v in table.items()
               if not isinstance(v, Mapping) and not _is_table_array(v)}
    if prefix and (scalars or not table):
        lines += ["", f"[{prefix}]"]
    lines += [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in scalars.items()]
    for k, v in table.items():
        name = f"{prefix}.{_toml_key(k)}" if prefix else _toml_key(k)
        if isinstance(v, Mapping):
            _toml_table(name, v, lines)
        elif _is_table_array(v):
            for item in v:
                lines += ["", f"[[{name}]]"]
                lines += [f"{_toml_key(kk)} = {_toml_value(vv)}" for kk, vv in item.items()]


def _toml_document(data: Mapping[str, Any]) -> str:
    lines: list[str] = ["# gearuq gear stage (docs/stage.md): lengths mm, angles deg, "
                        "reliefs um, stiffness N/um"]
    _toml_table("", data, lines)
    return "\n".join(lines).lstrip("\n") + "\n"


# ---------------------------------------------------------------------- mesh stiffness
@dataclass(frozen=True)
class StageMeshStiffness:
    """The one mesh stiffness of a stage and its check against ISO 6336-1.

    Attributes
    ----------
    value : float
        **The stage's mesh stiffness** [N/um], the one every model built from the stage uses:
        the LTCA's mean tangent stiffness (``source="ltca"``) or ISO 6336-1 ``c_gamma_alpha
        b`` (``source="iso6336"``, the choice of Li, Hu and Han's model).
    source : str
        ``"ltca"`` or ``"iso6336"`` (the stage's ``stiffness_source``).
    tangent_mean : float
        LTCA: mean over one mesh cycle of the tangent stiffness ``dP/dSTE`` at the design
        torque, designed flank modifications, no pitch deviations, normal direction [N/um]
        (a linearisation about the loaded static state, what the dynamics sees).
    secant_mean : float
        LTCA: mean over the cycle of ``P / STE``, normal direction [N/um].
    iso_c_gamma_b : float
        ISO 6336-1 method B ``c_gamma_alpha b`` [N/um] (solid blanks, transverse).
    tangent_ptp : float
        LTCA: peak-to-peak of the tangent stiffness over the cycle [N/um].
    ste_ptp : float
        LTCA: peak-to-peak static transmission error over the cycle [um] (normal).
    ratio : float
        ``secant_mean cos^2(beta_b) / iso_c_gamma_b``: LTCA over ISO like for like (secant,
        transverse convention), the quantity whose band was measured.
    band : (float, float)
        :data:`STIFFNESS_BAND`.
    torque : float
        Design torque [N m].
    positions_per_cycle, n_pts : int
        LTCA discretisation.
    """

    value: float
    source: str
    tangent_mean: float
    secant_mean: float
    tangent_ptp: float
    ste_ptp: float
    iso_c_gamma_b: float
    ratio: float
    band: tuple[float, float]
    torque: float
    positions_per_cycle: int
    n_pts: int

    @property
    def within_band(self) -> bool:
        """Whether the LTCA and ISO 6336-1 agree within the measured band."""
        return self.band[0] <= self.ratio <= self.band[1]

    @property
    def value_N_per_m(self) -> float:
        """:attr:`value` in N/m."""
        return self.value * 1e6


class StiffnessBandWarning(UserWarning):
    """The LTCA and ISO 6336-1 mesh stiffness of a stage disagree beyond the measured band."""


def stage_mesh_stiffness(stage: GearStage, *, positions_per_cycle: int = 24,
                         n_pts: int = 20) -> StageMeshStiffness:
    """The stage's mesh stiffness, with the LTCA (one mesh cycle, design torque) beside ISO.

    Warns (:class:`StiffnessBandWarning`) when the LTCA and ISO 6336-1 differ, like for like,
    beyond :data:`STIFFNESS_BAND`. The LTCA runs once per stage and discretisation (cached).
    """
    result = _stage_mesh_stiffness(stage, int(positions_per_cycle), int(n_pts))
    if not result.within_band:
        warnings.warn(
            f"stage {stage.name!r}: LTCA mean secant mesh stiffness (transverse convention) is "
            f"{result.ratio:.3f} x ISO 6336-1 c_gamma_alpha b = {result.iso_c_gamma_b:.1f} "
            f"N/um, outside the band {STIFFNESS_BAND} measured over 258 pairs "
            f"(docs/theory/ltca.md); the models use {result.source}: {result.value:.1f} N/um",
            StiffnessBandWarning, stacklevel=2)
    return result


def design_mesh_cycle(stage: GearStage, *, positions_per_cycle: int = 24,
                      n_pts: int = 20) -> Any:
    """LTCA of the stage over one mesh cycle at its design torque (no pitch deviations).

    The one computation behind the stage's mesh stiffness and ``gearuq run``'s mesh-cycle
    table: the stage's material, reliefs and crowning, ``keep_points=False``.

    Returns
    -------
    xarray.Dataset
        :func:`gearuq.gears.ltca.ltca`'s result.
    """
    from gearuq.gears.compliance import ComplianceModel
    from gearuq.gears.ltca import ltca

    compliance = ComplianceModel(stage.pair, E=to_si(stage.material.young_modulus, "1e6"),
                                 nu=stage.material.poisson_ratio)
    return ltca(stage.pair, torque=stage.operation.torque_design,
                deviations=stage.flank_deviations(), compliance=compliance,
                positions_per_cycle=positions_per_cycle, n_cycles=1, n_pts=n_pts,
                keep_points=False)


@functools.lru_cache(maxsize=32)
def _stage_mesh_stiffness(stage: GearStage, positions_per_cycle: int,
                          n_pts: int) -> StageMeshStiffness:
    import numpy as np

    from gearuq.gears.iso6336 import mesh_stiffness

    pair = stage.pair
    torque = stage.operation.torque_design
    ds = design_mesh_cycle(stage, positions_per_cycle=positions_per_cycle, n_pts=n_pts)
    if int(ds["status"].max()) != 0:
        raise ValueError(f"stage {stage.name!r}: the LTCA did not converge at the design torque "
                         f"{torque:g} N m")
    iso = mesh_stiffness(pair).k_mesh_N_per_m * 1e-6
    tangent = float(np.mean(ds["lpms_tangent"].values))
    secant = float(np.mean(ds["lpms"].values))
    return StageMeshStiffness(
        value=tangent if stage.stiffness_source == "ltca" else iso,
        source=stage.stiffness_source, tangent_mean=tangent, secant_mean=secant,
        tangent_ptp=float(np.ptp(ds["lpms_tangent"].values)),
        ste_ptp=float(np.ptp(ds["ste"].values)), iso_c_gamma_b=iso,
        ratio=secant * math.cos(pair.beta_b) ** 2 / iso,
        band=STIFFNESS_BAND, torque=torque, positions_per_cycle=positions_per_cycle,
        n_pts=n_pts)
