"""``mesh_excitation``: LTCA mesh excitations of a helical pair with random pitch deviations.

The loaded tooth contact analysis of ``gearuq.gears`` (Yuan et al. (2020), Sec. 2.1) run as a model:
each sample is one long period (``lcm(z1, z2)`` mesh cycles) at one torque, with the
sample's tip/root relief, lead crowning and one realisation of the random cumulative pitch
deviations (sine + normal scatter, Yuan et al. (2020) Sec. 3, or ISO 1328 tolerances). Outputs are
the
static transmission error, the long-period mesh stiffness (secant, Yuan et al. Eq. 4, and tangent),
the composite mesh error (Yuan et al. Eq. 5), their mean and peak-to-peak values, the partial
contact loss and the mesh-order spectrum with its shaft-order sidebands.

The model's "time" is the mesh position in mesh cycles (``tau``; the pinion has turned
``tau`` base pitches); instants beyond the long period wrap around it. Theory, units and
choices: docs/theory/mesh_excitation.md and docs/theory/ltca.md.
"""

from __future__ import annotations

import math
import os
from typing import Any

from gearuq.model import Model, Option, Output, Parameter, bounded_below

__all__ = ["MeshExcitation"]

_S, _ST, _SO = ("sample",), ("sample", "time"), ("sample", "order")
_OUTPUTS = (
    Output("ste", "um", _ST, "static transmission error (normal approach of the flanks)"),
    Output("lpms", "N/um", _ST, "long-period mesh stiffness, secant (Yuan et al. Eq. 4)"),
    Output("lpms_tangent", "N/um", _ST, "long-period mesh stiffness, tangent dP/dSTE"),
    Output("cms", "um", _ST, "composite mesh error (Yuan et al. Eq. 5)"),
    Output("ste_mean", "um", _S, "mean STE over the long period"),
    Output("ste_ptp", "um", _S, "peak-to-peak STE over the long period"),
    Output("lpms_mean", "N/um", _S, "mean secant LPMS over the long period"),
    Output("lpms_ptp", "N/um", _S, "peak-to-peak secant LPMS over the long period"),
    Output("lpms_tangent_mean", "N/um", _S, "mean tangent LPMS over the long period"),
    Output("lpms_tangent_ptp", "N/um", _S, "peak-to-peak tangent LPMS over the long period"),
    Output("cms_mean", "um", _S, "mean CMS over the long period"),
    Output("cms_ptp", "um", _S, "peak-to-peak CMS over the long period"),
    Output("contact_loss_fraction", "1", _S,
           "share of the long-period positions with partial contact loss (more than 5 % of "
           "the design contact pattern unloaded)"),
    Output("unloaded_share_max", "1", _S,
           "largest unloaded share of the design contact pattern over the long period"),
    Output("ste_spectrum", "um", _SO,
           "amplitude of the STE at shaft orders, mesh orders and their sidebands"),
    Output("lpms_tangent_spectrum", "N/um", _SO,
           "amplitude of the tangent LPMS at the same orders"),
)
# stiffnesses, peak-to-peak values, fractions and amplitudes: never negative (the STE and
# the composite mesh error are signed)
_OUTPUTS = bounded_below(_OUTPUTS, [
    "lpms", "lpms_tangent", "ste_ptp", "lpms_mean", "lpms_ptp", "lpms_tangent_mean",
    "lpms_tangent_ptp", "cms_ptp", "contact_loss_fraction", "unloaded_share_max",
    "ste_spectrum", "lpms_tangent_spectrum"])

_OPTIONS = (
    Option("positions_per_cycle", 24, "mesh positions per mesh cycle", kind=int, lower=4,
           upper=1000),
    Option("n_pts", 20, "points per line of contact", kind=int, lower=2, upper=400),
    Option("n_mesh_orders", 3, "mesh orders in the spectra (< positions_per_cycle / 2)",
           kind=int, lower=1, upper=100),
    Option("n_sidebands", 3, "sidebands +-i shaft orders around each mesh order", kind=int,
           lower=0, upper=50),
    Option("sideband_shaft", "pinion", "shaft whose orders label the sidebands",
           choices=("pinion", "wheel")),
    Option("amplitude_reading", "sine",
           "Yuan, Liu and Liu's '15 um amplitude': sine amplitude or largest cumulative deviation "
           "(pitch_model='seeded' only)",
           choices=("sine", "largest")),
    Option("pitch_model", "germ",
           "random pitch deviations: 'germ' (smooth in the standard normals pitch_xi_p_*, "
           "pitch_xi_g_*) or 'seeded' (the realisation of pitch_seed, for the published "
           "figures)",
           choices=("germ", "seeded")),
    Option("pitch_harmonics", None, "tooth-index harmonics kept in each gear's germ "
           "(1..z//2; None: all, the exact germ of z-1 normals per gear)", kind=int,
           lower=1, upper=500, allow_none=True),
    Option("ltca_route", "full",
           "how the long period is solved: 'full' (the LTCA at every position, cost in "
           "proportion to lcm(z1, z2)) or 'table' (one line-load table per designed "
           "modification and torque level, then one scalar equation per position; "
           "docs/theory/mesh_excitation.md)",
           choices=("full", "table")),
    Option("threads", None, "threads over samples (None: all cores of this process)",
           kind=int, lower=1, upper=1024, allow_none=True),
)


class MeshExcitation(Model):
    """LTCA mesh excitations (STE, LPMS, CMS, spectra) of a helical pair per random sample.

    Parameters
    ----------
    pair : HelicalGearPair or None
        The gear pair; ``None``: Yuan, Liu and Liu's pair (30/30, m_n 6 mm, 18 deg, b 40 mm).
    stage : GearStage or None
        A stage instead of ``pair``: its pair, its material in the compliance, and as
        nominal values its design torque, its ISO 1328 classes, its reliefs (any shape, per
        gear) and its lead crowning; measured pitch deviations are refused with the reason
        (docs/stage.md, "What each model takes").
    coupling_length : float or None
        Face-width coupling length of the compliance [m]; ``None``: the cantilever-plate
        calibration (:func:`gearuq.gears.face_coupling.plate_coupling_length`).
    bore_ratio : float
        Bore over root radius of the fillet foundation (0.5 assumed; Yuan, Liu and Liu give no
        bore).
    hertz : bool
        Include Weber's nonlinear contact approach (default True).
    """

    name = "mesh_excitation"
    description = ("LTCA mesh excitations (STE, LPMS, CMS, spectra) with random pitch errors "
                   "(after Yuan, Liu and Liu 2020)")
    version = "1.0"
    time_units = "mesh cycles"
    time_long_name = "mesh position tau (pinion turned by tau base pitches)"
    internally_parallel = True  # samples run in threads; the compiled LTCA drops the GIL
    outputs = _OUTPUTS
    options = _OPTIONS

    def __init__(
        self,
        pair: Any = None,
        *,
        stage: Any = None,
        coupling_length: float | None = None,
        bore_ratio: float = 0.5,
        hertz: bool = True,
    ) -> None:
        from gearuq.gears.compliance import ComplianceModel
        from gearuq.gears.geometry import HelicalGearPair, seed002_pair

        material: dict[str, float] = {}
        nominal: dict[str, float] = {}
        added: tuple[Parameter, ...] = ()
        self.stage_relief = None
        if stage is not None:
            if pair is not None:
                raise ValueError("give pair= or stage=, not both (the stage holds its pair)")
            pair, material, nominal, added, self.stage_relief = _from_stage(stage)
        if pair is None:
            pair = seed002_pair()
        if not isinstance(pair, HelicalGearPair):
            raise ValueError(f"pair={pair!r} must be a gearuq.gears.HelicalGearPair")
        self.pair = pair
        self.stage = stage
        # validates coupling_length and bore_ratio with clear messages
        self.compliance = ComplianceModel(pair, coupling_length=coupling_length,
                                          bore_ratio=bore_ratio, hertz=bool(hertz), **material)
        self.parameters = _with_nominal(_parameters(pair), nominal) + added
        self._cache: dict[Any, Any] = {}

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["_cache"] = {}  # prepared grids are rebuilt in each worker, not shipped
        return state

    def settings(self) -> dict[str, Any]:
        """Construction options (recorded as provenance)."""
        p = self.pair
        return {
            "pair": {"mn": p.mn, "z1": p.z1, "z2": p.z2, "alpha_n": p.alpha_n, "beta": p.beta,
                     "b1": p.b1, "b2": p.b2, "x1": p.x1, "x2": p.x2, "ha_star": p.ha_star,
                     "hf_star": p.hf_star, "rho_f_star": p.rho_f_star, "a": p.a, "b": p.b},
            "coupling_length_m": float(self.compliance.coupling_length),
            "bore_ratio": self.compliance.bore_ratio,
            "hertz": bool(self.compliance.hertz),
        } | ({} if getattr(self, "stage", None) is None else {"stage": self.stage.to_dict()})

    def default_space(self, pitch_harmonics: int | None = None) -> Any:
        """Yuan, Liu and Liu's random input: torque 200-1000 N m and the pitch-deviation germ.

        ``torque`` uniform on Yuan, Liu and Liu's load range; the germ ``pitch_xi_p_*`` and
        ``pitch_xi_g_*`` independent standard normals (all ``z - 1`` per gear, or those of
        ``pitch_harmonics`` harmonics; pass the same value as the option), amplitude 15 um
        and sigma 3 um at their nominal values. Continuous: every engine can explore the
        scatter (the seeded realisation is the option ``pitch_model="seeded"``).
        """
        from gearuq.gears.deviations import pitch_germ_dimension, pitch_germ_names
        from gearuq.space import ParameterSpace

        spec = {"torque": {"dist": "uniform", "lower": 200.0, "upper": 1000.0}}
        for gear, z in ((1, self.pair.z1), (2, self.pair.z2)):
            n = pitch_germ_dimension(z, pitch_harmonics)
            spec |= {k: {"dist": "normal", "mean": 0.0, "std": 1.0}
                     for k in pitch_germ_names(z, gear)[:n]}
        return ParameterSpace(spec)

    def _evaluate(self, params, t, outputs, **options):
        from gearuq_plugins.mesh_excitation.physics import evaluate

        if options["threads"] is None:
            options = {**options, "threads": len(os.sched_getaffinity(0))
                       if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)}
        return evaluate(self, params, t, outputs, **options)


class _StageRelief:
    """A stage's reliefs with each amount read from a sample's parameter values."""

    def __init__(self, stage: Any, keys: tuple[str, ...]) -> None:
        self.stage, self.keys = stage, keys

    def __call__(self, values: dict[str, float]) -> Any:
        return self.stage.relief_clearance({k: values[f"{k}_relief_amount"]
                                            for k in self.keys})


def _from_stage(stage: Any) -> tuple[Any, dict[str, float], dict[str, float],
                                     tuple[Parameter, ...], _StageRelief | None]:
    """What a stage sets: pair, material, nominal values, added parameters, relief map.

    One parabolic relief shared by both gears maps onto the ``*_relief_*`` parameters (the
    built-in LTCA path); any other relief (linear, arc, per gear) is carried as the stage's
    clearance map with one amount parameter per relief (``pinion_tip_relief_amount``...).
    Different ISO classes add ``iso_grade_wheel``; helix slope deviations travel in the
    clearance map. Measured pitch deviations are refused: the model's pitch deviations are
    random.
    """
    from gearuq.gears.stage import GearStage, to_si

    if not isinstance(stage, GearStage):
        raise TypeError(f"stage={stage!r} must be a gearuq.GearStage")
    nominal: dict[str, float] = {"torque": stage.operation.torque_design,
                                 "crowning": stage.pinion.lead_crowning
                                 + stage.wheel.lead_crowning}
    added: list[Parameter] = []
    grades = [stage.pinion.iso_grade or 0, stage.wheel.iso_grade or 0]
    nominal["iso_grade"] = float(grades[0])
    if grades[1] != grades[0]:
        added.append(Parameter("iso_grade_wheel", "1", grades[1], 0, 12,
                               "ISO 1328-1 class of the wheel (the stage's; iso_grade is then "
                               "the pinion's); 0: pitch_amplitude and pitch_sigma",
                               integer=True))
    for gear in ("pinion", "wheel"):
        data = getattr(stage, gear)
        if data.single_pitch_deviations is not None:
            raise ValueError(f"stage {stage.name!r}: [{gear}] single_pitch_deviations is not "
                             "taken by mesh_excitation (its pitch deviations are random, from "
                             "the germ or the ISO class)")
    # a helix slope deviation travels in the stage's clearance map, so the reliefs go too
    slope = bool(stage.pinion.helix_slope_deviation or stage.wheel.helix_slope_deviation)
    keys: list[str] = []
    for kind in ("tip", "root"):
        reliefs = [getattr(stage.pinion, f"{kind}_relief"),
                   getattr(stage.wheel, f"{kind}_relief")]
        lengths = [stage.relief_length(g, kind) for g in ("pinion", "wheel")]
        shared = (not slope and None not in reliefs
                  and all(r.shape == "parabolic" for r in reliefs)
                  and reliefs[0].amount == reliefs[1].amount
                  and abs(lengths[0] - lengths[1]) <= 1e-9)
        if shared:
            nominal[f"{kind}_relief_amount"] = reliefs[0].amount
            nominal[f"{kind}_relief_length"] = lengths[0]
            continue
        for gear, relief, length in zip(("pinion", "wheel"), reliefs, lengths, strict=True):
            if relief is None:
                continue
            keys.append(f"{gear}_{kind}")
            added.append(Parameter(
                f"{gear}_{kind}_relief_amount", "um", relief.amount, 0.0, 200.0,
                f"{relief.shape} {kind} relief of the {gear} (the stage's: "
                f"{relief.amount:g} +- {relief.amount_tolerance:g} um over {length:.3f} mm of "
                "the path of contact, along the line of action)"))
    material = {"E": to_si(stage.material.young_modulus, "1e6"),
                "nu": stage.material.poisson_ratio}
    relief = _StageRelief(stage, tuple(keys)) if keys or slope else None
    return stage.pair, material, nominal, tuple(added), relief


def _with_nominal(parameters: tuple[Parameter, ...],
                  nominal: dict[str, float]) -> tuple[Parameter, ...]:
    """``parameters`` with the given nominal values, the range widened to hold them."""
    return tuple(p.with_nominal(nominal[p.name]) if p.name in nominal else p
                 for p in parameters)


def _parameters(pair: Any) -> tuple[Parameter, ...]:
    """Parameters whose relief-length range is the pair's path of contact."""
    from gearuq.gears.deviations import pitch_germ_names

    g_alpha_mm = pair.g_alpha * 1e3
    length = math.floor(g_alpha_mm * 1000.0) / 1000.0  # path of contact, rounded down
    _P = Parameter
    return (
        _P("torque", "N m", 600.0, 1.0, 5000.0, "pinion torque (Yuan et al. (2020): 200-1000 N m)"),
        _P("tip_relief_amount", "um", 0.0, 0.0, 200.0,
           "parabolic tip relief amount e_max on pinion and wheel (Yuan et al. Eq. 12), measured "
           "along the line of action in the transverse plane"),
        _P("tip_relief_length", "mm", 0.0, 0.0, length,
           f"tip relief length L along the path of contact (at most the active profile, "
           f"g_alpha = {g_alpha_mm:.3f} mm)"),
        _P("root_relief_amount", "um", 0.0, 0.0, 200.0,
           "parabolic root relief amount on pinion and wheel"),
        _P("root_relief_length", "mm", 0.0, 0.0, length,
           "root relief length along the path of contact (at most the active profile)"),
        _P("crowning", "um", 0.0, 0.0, 100.0, "lead crowning C_b (sum of both gears)"),
        _P("pitch_amplitude", "um", 15.0, 0.0, 200.0,
           "amplitude of the random cumulative pitch deviations (Yuan et al. (2020): 15 um; "
           "seeded: "
           "read as the option amplitude_reading says; germ: the once-per-revolution "
           "coefficients have standard deviation amplitude / sqrt(2)); unused when "
           "iso_grade > 0"),
        _P("pitch_sigma", "um", 3.0, 0.0, 50.0,
           "standard deviation of the pitch scatter (Yuan, Liu and Liu (2020): 3 um); unused when "
           "iso_grade > 0"),
        _P("iso_grade", "1", 0, 0, 12,
           "ISO 1328-1 flank tolerance class 1-12 setting amplitude F_pT/2 and sigma "
           "f_pT/(3 sqrt 2) per gear; 0: use pitch_amplitude and pitch_sigma", integer=True),
        _P("pitch_seed", "1", 2020.0, 0.0, 2.0**32 - 1.0,
           "realisation of the random pitch deviations with pitch_model='seeded': its "
           "integer part seeds numpy.random.default_rng (2020: the realisation of the LTCA "
           "study)"),
        *(_P(name, "1", 0.0, -math.inf, math.inf,
             f"{'pinion' if gear == 1 else 'wheel'} pitch-deviation germ, standard normal: "
             f"{'cosine' if i % 2 == 0 else 'sine'} coefficient of tooth-index harmonic "
             f"{i // 2 + 1} (pitch_model='germ'; docs/theory/mesh_excitation.md)")
          for gear, z in ((1, pair.z1), (2, pair.z2))
          for i, name in enumerate(pitch_germ_names(z, gear))),
    )
