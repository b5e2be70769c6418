"""``geared_rotor``: finite-element helical geared rotor with LTCA excitation.

Yuan, Liu and Liu, "Quasi-static characteristics and vibration responses analysis of helical
geared rotor system with random cumulative pitch deviations", Applied Sciences 10 (2020), part 2.

The rotor of Yuan et al. (2020) (Sec. 2.2): two stepped Timoshenko shafts of 13 elements, the 30/30
helical pair on rigid gear bodies, four rolling-element bearings and the 12-DOF mesh element
along the normal line of action. Each sample runs the loaded tooth contact analysis of
``gearuq.gears`` at its torque, with its tip relief and its realisation of the random
cumulative pitch deviations, linearises the mesh with the tangent stiffness over the long
period (one shaft revolution of the 30/30 pair), reduces the rotor to the modes below a
cut-off taken from the excitation band and solves the periodic steady state over the long
period by harmonic balance on the mesh approach, with contact loss by alternating
frequency-time Newton iterations. Outputs: dynamic transmission error, mesh force, bearing
forces and accelerations (in time, as RMS values and as spectra at the shaft orders with
the mesh harmonics and the sidebands ``f_m +- i f_s`` labelled), and over a whole speed
range per sample the largest RMS DTE ``dte_rms_max`` and its speed. The pitch deviations
are, by default, a smooth function of declared standard normals (``pitch_xi_p_*``,
``pitch_xi_g_*``), so every engine can explore them; the paper's own realisation stays available
as ``pitch_model="seeded"``. Theory, parameter sources and the deviations from Yuan, Liu and Liu:
docs/theory/geared_rotor.md.
"""

from __future__ import annotations

import math
from typing import Any

from gearuq.gears.deviations import pitch_germ_names
from gearuq.model import Model, Option, Output, Parameter, bounded_below

__all__ = ["GearedRotor"]

_S, _ST, _SO, _SBT = ("sample",), ("sample", "time"), ("sample", "order"), (
    "sample", "bearing", "time")
_SR, _SM, _SRM = ("sample", "range_speed"), ("sample", "mesh_harmonic"), (
    "sample", "range_speed", "mesh_harmonic")

_P = Parameter
_PARAMETERS = (
    _P("torque", "N m", 1000.0, 10.0, 5000.0, "pinion torque (Yuan et al. (2020): 200-1000 N m)"),
    _P("speed", "rpm", 4000.0, 1.0, 20000.0,
       "pinion speed (Yuan, Liu and Liu (2020): 4000 rpm in Figs. 11-16, 25-8000 rpm in Fig. 17)"),
    _P("pitch_amplitude", "um", 15.0, 0.0, 200.0,
       "sine amplitude of the random cumulative pitch deviations (Yuan et al. (2020): 15 um); with "
       "the germ, the once-per-revolution coefficients have standard deviation "
       "amplitude / sqrt(2); unused when iso_grade > 0"),
    _P("pitch_sigma", "um", 3.0, 0.0, 50.0,
       "standard deviation of the pitch scatter (Yuan et al. (2020): 3 um); unused when "
       "iso_grade > 0"),
    _P("iso_grade", "1", 0, 0, 12,
       "ISO 1328-1 flank tolerance class 1-12 setting amplitude F_pT/2 and sigma "
       "f_pT/(3 sqrt 2) per gear; 0: use pitch_amplitude and pitch_sigma", integer=True),
    _P("pitch_seed", "1", 2020.0, 0.0, 2.0**32 - 1.0,
       "realisation of the random pitch deviations with pitch_model='seeded': its integer "
       "part seeds numpy.random.default_rng (as in mesh_excitation)"),
    _P("pitch_phase_pinion", "rad", 0.0, 0.0, 2.0 * math.pi,
       "phase of the pinion's once-per-revolution sine; used only with pitch_model='seeded' "
       "and pitch_phases='parameters' (default: drawn from pitch_seed)"),
    _P("pitch_phase_wheel", "rad", 0.0, 0.0, 2.0 * math.pi,
       "phase of the wheel's sine; used only with pitch_model='seeded' and "
       "pitch_phases='parameters'"),
    *(_P(name, "1", 0.0, -math.inf, math.inf,
         f"{'pinion' if g == 1 else 'wheel'} pitch-deviation germ, standard normal: "
         f"{'cosine' if i % 2 == 0 else 'sine'} coefficient of tooth-index harmonic "
         f"{i // 2 + 1} (pitch_model='germ'; docs/theory/mesh_excitation.md)")
      for g in (1, 2) for i, name in enumerate(pitch_germ_names(30, g))),
    _P("tip_relief_amount", "um", 0.0, 0.0, 200.0,
       "tip relief e_max on pinion and wheel (parabolic as Yuan et al. Eq. 12, or the shape "
       "of the option tip_relief_shape); 0: unmodified"),
    _P("tip_relief_length", "mm", 11.4, 0.0, 28.594,
       "tip relief length along the path of contact (LTCA optimum at 1000 N m: 11.4 mm)"),
    _P("lead_crowning", "um", 0.0, 0.0, 2000.0,
       "lead crowning C_b summed over both gears (gearuq.gears.deviations: the clearance "
       "C_b (2 y / b - 1)^2 across the face width); 0: uncrowned; a stage's nominal is the sum "
       "of its two gears' lead_crowning (each at most 1000 um)"),
    _P("bearing_stiffness", "N m-1", 5.0e8, 1.0e7, 1.0e11,
       "radial stiffness of each of the four bearings (ours; Yuan, Liu and Liu print none)"),
    _P("bearing_axial_stiffness", "N m-1", 2.0e8, 1.0e7, 1.0e11,
       "axial stiffness of each bearing (ours)"),
    _P("bearing_damping", "N s m-1", 0.0, 0.0, 1.0e6,
       "radial and axial viscous damping of each bearing"),
    _P("drive_inertia", "kg m2", 0.03, 1e-4, 100.0,
       "polar inertia turning with the free end of shaft 1 (drive side: a coupling hub of "
       "twice the 70 mm shaft-end diameter, 108 mm long; ours, Yuan, Liu and Liu print none)"),
    _P("load_inertia", "kg m2", 0.03, 1e-4, 100.0,
       "polar inertia turning with the free end of shaft 2 (load side; as drive_inertia)"),
    _P("damping_ratio", "1", 0.05, 0.0, 0.5,
       "modal damping ratio of every elastic mode (mesh and structure)"),
    _P("backlash", "um", 100.0, 0.0, 2000.0,
       "normal backlash: back-flank contact when the flanks part by more"),
)

_OUTPUTS = (
    Output("dte", "m", _ST, "dynamic transmission error: cos(beta_b)(r_b1 theta_p + r_b2 "
           "theta_g) of the gear bodies, normal direction"),
    Output("mesh_force", "N", _ST, "dynamic mesh force along the normal line of action"),
    Output("mesh_approach", "m", _ST, "mesh approach delta = v . q (equals the LTCA STE "
           "quasi-statically)"),
    Output("bearing_force_x", "N", _SBT, "bearing reaction force, x (line of centres)"),
    Output("bearing_force_y", "N", _SBT, "bearing reaction force, y (tangential)"),
    Output("bearing_force_z", "N", _SBT, "bearing reaction force, z (axial)"),
    Output("bearing_acceleration_x", "m s-2", _SBT, "shaft acceleration at the bearing, x"),
    Output("bearing_acceleration_y", "m s-2", _SBT, "shaft acceleration at the bearing, y"),
    Output("bearing_acceleration_z", "m s-2", _SBT, "shaft acceleration at the bearing, z"),
    Output("dte_rms", "m", _S, "RMS of the DTE about its mean over the long period"),
    Output("dte_mesh_band_rms", "m", _S, "RMS of the DTE orders >= f_m / 2 (mesh harmonics "
           "and their sidebands: the part the mesh dynamics shapes)"),
    Output("dte_mean", "m", _S, "mean DTE (static transmission error of the rotor)"),
    Output("dte_ptp", "m", _S, "peak-to-peak DTE over the long period"),
    Output("mesh_force_rms", "N", _S, "RMS of the mesh force about its mean"),
    Output("mesh_force_min", "N", _S, "smallest mesh force (0: contact loss)"),
    Output("bearing1_acceleration_y_rms", "m s-2", _S,
           "RMS acceleration at bearing 1 along y (Yuan et al. Figs. 12, 16)"),
    Output("contact_loss_fraction", "1", _S, "share of the long period with the teeth apart"),
    Output("dte_rms_max", "m", _S, "largest RMS DTE over the speed range speed_min..speed_max "
           "(n_speeds equally spaced speeds; the parameter speed is not used)"),
    Output("speed_at_dte_rms_max", "rpm", _S, "speed of the range at which dte_rms_max is "
           "reached"),
    Output("kv_max", "1", _S, "largest dynamic factor K_v over the speed range speed_min.."
           "speed_max: K_v(n) = largest mesh force over the long period / static normal "
           "mesh force (ISO 6336-1's definition; 1 in the quasi-static limit); the peak is "
           "located between the grid speeds (peaks_refined, peak_speed_tol)"),
    Output("speed_at_kv_max", "rpm", _S, "speed at which kv_max is reached"),
    Output("kv_over_speed", "1", _SR, "K_v at each grid speed of the range"),
    Output("dte_mesh_band_rms_max", "m", _S, "largest mesh-band RMS DTE (orders >= f_m / 2) "
           "over the speed range, peak located"),
    Output("speed_at_dte_mesh_band_rms_max", "rpm", _S, "speed of dte_mesh_band_rms_max"),
    Output("dte_mesh_band_rms_over_speed", "m", _SR, "mesh-band RMS DTE at each grid speed"),
    Output("dte_mesh_order_max", "m", _SM, "largest DTE amplitude at mesh harmonic m f_m "
           "(m = 1..range_mesh_harmonics) over the speed range, peak located"),
    Output("speed_at_dte_mesh_order_max", "rpm", _SM, "speed of dte_mesh_order_max"),
    Output("dte_mesh_order_over_speed", "m", _SRM, "DTE amplitude at the mesh harmonics at "
           "each grid speed"),
    Output("bearing1_acceleration_y_mesh_order_max", "m s-2", _SM, "largest bearing-1 y "
           "acceleration amplitude at mesh harmonic m f_m over the speed range (the whine "
           "the housing sees), peak located"),
    Output("speed_at_bearing1_acceleration_y_mesh_order_max", "rpm", _SM,
           "speed of bearing1_acceleration_y_mesh_order_max"),
    Output("bearing1_acceleration_y_mesh_order_over_speed", "m s-2", _SRM,
           "bearing-1 y acceleration amplitude at the mesh harmonics at each grid speed"),
    Output("kv_iso_max", "1", _S, "largest ISO 6336-1:2019 Method B K_v over the grid speeds "
           "of the range, for the sample's torque, tip relief and accuracy class (iso_grade, "
           "the coarser of iso_grade and iso_grade_wheel for a stage with two classes, "
           "or kv_iso_class when a class is 0); K_A = 1, case-hardened running-in"),
    Output("speed_at_kv_iso_max", "rpm", _S, "grid speed of kv_iso_max"),
    Output("kv_iso_over_speed", "1", _SR, "ISO 6336-1 Method B K_v at each grid speed"),
    Output("pitch_total_deviation_pinion", "m", _S, "total cumulative pitch deviation F_p "
           "of the pinion (ISO 1328-1: largest minus smallest cumulative deviation over the "
           "teeth); acceptance to a class is F_p <= F_pT"),
    Output("pitch_total_deviation_wheel", "m", _S, "total cumulative pitch deviation F_p of "
           "the wheel"),
    Output("pitch_acceptance_margin", "1", _S, "inspection margin min over both gears of "
           "1 - F_p / F_pT (class iso_grade, or kv_iso_class when iso_grade = 0): the pair "
           "passes inspection where it is >= 0"),
    Output("ste_ptp", "m", _S, "peak-to-peak LTCA STE of the excitation"),
    Output("mesh_frequency", "Hz", _S, "mesh frequency z1 n / 60"),
    Output("shaft_frequency", "Hz", _S, "pinion shaft frequency n / 60"),
    Output("dte_spectrum", "m", _SO, "DTE amplitude at the orders of the long period"),
    Output("mesh_force_spectrum", "N", _SO, "mesh-force amplitude at the same orders"),
    Output("bearing1_acceleration_y_spectrum", "m s-2", _SO,
           "bearing-1 y acceleration amplitude at the same orders"),
)
# RMS, peak-to-peak, amplitude, fraction, speed and frequency outputs cannot be negative (a
# failure band beyond that bound is refused by name; gearuq.model.Output.valid_min)
_OUTPUTS = bounded_below(_OUTPUTS, [
    "dte_rms", "dte_mesh_band_rms", "dte_ptp", "mesh_force_rms", "mesh_force_min",
    "bearing1_acceleration_y_rms", "contact_loss_fraction", "dte_rms_max",
    "speed_at_dte_rms_max", "kv_max", "speed_at_kv_max", "kv_over_speed",
    "dte_mesh_band_rms_max", "speed_at_dte_mesh_band_rms_max", "dte_mesh_band_rms_over_speed",
    "dte_mesh_order_max", "speed_at_dte_mesh_order_max", "dte_mesh_order_over_speed",
    "bearing1_acceleration_y_mesh_order_max",
    "speed_at_bearing1_acceleration_y_mesh_order_max",
    "bearing1_acceleration_y_mesh_order_over_speed", "kv_iso_max", "speed_at_kv_iso_max",
    "kv_iso_over_speed", "pitch_total_deviation_pinion", "pitch_total_deviation_wheel",
    "ste_ptp", "mesh_frequency", "shaft_frequency", "dte_spectrum", "mesh_force_spectrum",
    "bearing1_acceleration_y_spectrum"])

_O = Option
_OPTIONS = (
    _O("n_mesh_harmonics", None, "mesh harmonics kept in the steady state (H = n x lcm(z1, "
       "z2)); None: from the speed, every harmonic below harmonic_band, at least 4 and at "
       "most what the LTCA resolves ((positions_per_cycle - 1) // 2)", kind=int, lower=1,
       upper=199, allow_none=True),
    _O("harmonic_band", 10500.0, "with n_mesh_harmonics=None: mesh harmonics up to this "
       "frequency [Hz] (1.5 x the 7.0 kHz mode, the highest that loads the mesh by > 1 %)",
       lower=100.0, upper=1e6),
    _O("cutoff_factor", 1.5, "modes kept up to this factor times the highest harmonic",
       lower=1.0, upper=50.0),
    _O("positions_per_cycle", 24, "LTCA positions per mesh cycle (> 2 n_mesh_harmonics)",
       kind=int, lower=4, upper=400),
    _O("n_pts", 20, "LTCA points per line of contact", kind=int, lower=2, upper=200),
    _O("n_sidebands", 14, "sidebands +-i f_s labelled around each mesh harmonic (14: every "
       "order nearer to a mesh harmonic than to the next, where the largest sidebands can "
       "sit)", kind=int, lower=0, upper=14),
    _O("pitch_model", "germ", "random pitch deviations: 'germ' (smooth in the standard "
       "normals pitch_xi_p_*, pitch_xi_g_*: every engine can explore them) or 'seeded' "
       "(the realisation of pitch_seed, as in Yuan, Liu and Liu's figures)",
       choices=("germ", "seeded")),
    _O("pitch_harmonics", None, "tooth-index harmonics kept in each gear's germ (1-15; "
       "None: all 15, the exact germ of 29 normals per gear)", kind=int, lower=1, upper=15,
       allow_none=True),
    _O("pitch_phases", "seed", "sine phases of the pitch deviations: drawn with the scatter "
       "from pitch_seed, or taken from pitch_phase_pinion / pitch_phase_wheel (smooth inputs "
       "for surrogates; the scatter still comes from pitch_seed)",
       choices=("seed", "parameters")),
    _O("speed_min", 25.0, "lowest speed of the range of dte_rms_max (25 rpm: Fig. 17 of "
       "Yuan et al. 2020)",
       lower=1.0, upper=20000.0),
    _O("speed_max", 8000.0, "highest speed of the range (8000 rpm as Yuan et al. 2020); > "
       "speed_min",
       lower=1.0, upper=20000.0),
    _O("n_speeds", 160, "equally spaced speeds of the range (both ends included)", kind=int,
       lower=2, upper=100000),
    _O("range_mesh_harmonics", 3, "mesh harmonics of the steady states of the range (the "
       "RMS converges faster than dte_ptp: docs/theory/geared_rotor.md Sec. 9)", kind=int,
       lower=1, upper=20),
    _O("range_cutoff_factor", 1.0, "modal cut-off factor of the range", lower=1.0,
       upper=50.0),
    _O("peaks_refined", 2, "local maxima of the grid located by golden-section search per "
       "peak output (kv_max and the *_max of the mesh band and orders); 0: the grid's "
       "maximum", kind=int, lower=0, upper=20),
    _O("pitch_tolerance_law", "untruncated_iso", "law of the pitch deviations of an ISO "
       "class (iso_grade > 0): 'untruncated_iso' (amplitude F_pT/2, scatter f_pT/(3 sqrt 2): "
       "about half of these gears exceed F_pT, i.e. fail inspection) or 'capable_process' "
       "(the same shape scaled so that process_share_beyond of the gears exceed F_pT; "
       "condition on pitch_acceptance_margin >= 0 for the gears that pass inspection)",
       choices=("untruncated_iso", "capable_process")),
    _O("process_share_beyond", 0.05, "with pitch_tolerance_law='capable_process': share of "
       "the process beyond F_pT (rejected at inspection), per gear", lower=1e-6, upper=0.5),
    _O("kv_iso_class", 6, "ISO 1328-1 accuracy class of kv_iso_* for samples with "
       "iso_grade = 0 (their pitch deviations are not given as a class)", kind=int, lower=1,
       upper=12),
    _O("sweep_direction", "up", "speeds of the range swept 'up' (a run-up), or 'up_and_down' "
       "(the run-up, then a run-down over its contact-loss ranges; each range output the "
       "larger of the two: where the teeth separate two periodic responses can coexist, "
       "docs/theory/geared_rotor.md)", choices=("up", "up_and_down")),
    _O("aperiodic_response", "invalid", "what a speed of the range without a periodic "
       "response reports (the time integration did not return to itself: subharmonic, "
       "quasi-periodic or chaotic rattle): 'invalid' (the sample is flagged: status 18, "
       "or 21 during a peak's search) or 'window_max' (K_v the largest mesh force over "
       "the integration's last 10 long periods, counted in aperiodic_speeds; "
       "docs/theory/geared_rotor.md)",
       choices=("invalid", "window_max")),
    _O("peak_speed_tol", 1.0, "width of the final speed bracket of a located peak", lower=1e-3,
       upper=1000.0, units="rpm"),
    _O("end_inertias", "parameters", "drive and load inertias on the shaft ends: the "
       "parameters drive_inertia / load_inertia, or 'none' (Yuan, Liu and Liu's rotor as printed, "
       "whose 448 Hz mode has no inertia at the shaft ends)", choices=("parameters", "none")),
    _O("long_period_solver", "gmres", "a stage whose long period exceeds 120 mesh cycles "
       "(a hunting-tooth pair): steady states on every harmonic by GMRES, or on the "
       "spectral orders (docs/theory/geared_rotor.md)", choices=("gmres", "spectral_orders")),
    _O("spectral_energy", 0.99, "with long_period_solver='spectral_orders': share of the "
       "excitation's energy held by the long-period harmonics kept", lower=1e-3, upper=1.0),
    _O("tip_relief_shape", "parabolic", "shape of the tip relief of tip_relief_amount / "
       "tip_relief_length on both gears: 'parabolic' (Yuan, Liu and Liu Eq. 12), 'linear' "
       "or 'arc' (the profiles of a stage's relief, gearuq.gears.stage.Relief)",
       choices=("parabolic", "linear", "arc")),
    _O("gmres_tol", 1e-6, "with long_period_solver='gmres': relative residual tolerance of "
       "each GMRES solve (1e-6: outputs within 1e-5 of the converged balance, "
       "docs/theory/geared_rotor.md)", lower=1e-14, upper=0.1),
    _O("verify", False, "check contact-loss solutions by time integration (stability)"),
    _O("tol", 1e-9, "harmonic-balance tolerance (max |residual| / max |delta|)", lower=1e-14,
       upper=1e-3),
    _O("moment_arm", "pitch_point", "mesh element arms: re-derived (pitch point) or as "
       "Yuan, Liu and Liu "
       "Eq. 8 prints them (base circles)", choices=("pitch_point", "base_circle")),
)


class GearedRotor(Model):
    """Finite-element helical geared rotor of Yuan et al. (2020), driven by the LTCA mesh
    excitation.

    Parameters
    ----------
    cache_size : int
        Number of LTCA excitations and rotor reductions kept between calls (a speed sweep at
        fixed torque and deviations runs the LTCA once).
    stage : GearStage or None
        Build the rotor of a stage (docs/stage.md): its pair, shafts, each bearing's stiffness
        and damping (bearings that differ: common scale factors ``bearing_*_scale`` on the
        stage's values), end inertias, material and operating point, each gear's ISO class
        (``iso_grade``, ``iso_grade_wheel``) or measured pitch deviations, its reliefs of any
        shape per gear (``pinion_tip_relief_amount``...), crowning and helix slope, and its
        pitch-deviation germ (``pitch_xi_*`` for its tooth numbers). A long period beyond
        120 mesh cycles (a hunting-tooth pair) gives the speed-range outputs, from a
        line-load table excitation. Refused with the reason: other than two bearings per
        shaft.
    """

    name = "geared_rotor"
    description = ("FE helical geared rotor (after Yuan, Liu and Liu 2020): LTCA LPMS/CMS "
                   "excitation, contact loss, modal reduction, harmonic-balance steady state")
    version = "1.0"
    time_units = "s"
    parameters = _PARAMETERS
    outputs = _OUTPUTS
    options = _OPTIONS

    def __init__(self, cache_size: int = 32, *, stage: Any = None) -> None:
        if int(cache_size) != cache_size or cache_size < 0:
            raise ValueError(f"cache_size={cache_size!r} is outside its valid range: "
                             "integers >= 0")
        self.cache_size = int(cache_size)
        self._cache: dict = {}
        self.stage = stage
        if stage is not None:
            from gearuq_plugins.geared_rotor.stage import (
                StageFlanks,
                check_stage,
                stage_compliance,
                stage_parameters,
            )

            check_stage(stage)
            self.parameters = stage_parameters(stage, _PARAMETERS)
            self.compliance = stage_compliance(stage)
            self.flanks = StageFlanks(stage)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_cache"] = {}  # caches are rebuilt in each process
        return state

    def settings(self) -> dict[str, Any]:
        """Construction options (provenance)."""
        out: dict[str, Any] = {"cache_size": self.cache_size}
        if getattr(self, "stage", None) is not None:
            out["stage"] = self.stage.to_dict()
        return out

    def default_space(self, pitch_harmonics: int | None = None) -> Any:
        """Random inputs: torque, bearing stiffness, damping and the pitch-deviation germ.

        ``torque`` uniform on 800-1200 N m; ``bearing_stiffness`` lognormal (median 5e8 N/m,
        20 % scatter); ``damping_ratio`` uniform on 0.03-0.08; ``pitch_amplitude`` uniform on
        5-15 um and ``pitch_sigma`` on 1-3 um; the germ ``pitch_xi_p_*``, ``pitch_xi_g_*``
        independent standard normals (all 29 per gear, or those of ``pitch_harmonics``
        harmonics; pass the same value as the option). A stage other than the paper's: torque
        uniform on its operating range, and, when its bearings differ, the factor
        ``bearing_stiffness_scale`` lognormal (median 1, 20 % scatter) instead of
        ``bearing_stiffness``; without ``pitch_amplitude`` and ``pitch_sigma`` when both gears
        have an ISO class; a gear with measured pitch deviations has no germ. Every input
        is continuous, so FORM,
        subset simulation, surrogates and Sobol' indices see the pitch deviations. Speed is a
        study variable (or the range of ``dte_rms_max``), not a random input.
        """
        from gearuq.gears.deviations import pitch_germ_dimension
        from gearuq.space import ParameterSpace
        from gearuq_plugins.geared_rotor.stage import is_paper_rotor

        stage = getattr(self, "stage", None)
        teeth = (30, 30) if stage is None else stage.teeth  # a stage: its own germ
        names = set(self.parameter_names)
        germ = {name: {"dist": "normal", "mean": 0.0, "std": 1.0}
                for g, z in ((1, teeth[0]), (2, teeth[1]))
                for name in pitch_germ_names(z, g)[:pitch_germ_dimension(z, pitch_harmonics)]
                if name in names}  # a gear with measured deviations has no germ
        spec = {
            "torque": {"dist": "uniform", "lower": 800.0, "upper": 1200.0},
            "bearing_stiffness": {"dist": "lognormal", "mu": math.log(5.0e8), "sigma": 0.2},
            "damping_ratio": {"dist": "uniform", "lower": 0.03, "upper": 0.08},
            "pitch_amplitude": {"dist": "uniform", "lower": 5.0, "upper": 15.0},
            "pitch_sigma": {"dist": "uniform", "lower": 1.0, "upper": 3.0},
        }
        if stage is not None and "bearing_stiffness" not in names:
            # bearings that differ: the same 20 % scatter as a common factor on the stage's
            spec.pop("bearing_stiffness")
            spec["bearing_stiffness_scale"] = {"dist": "lognormal", "mu": 0.0, "sigma": 0.2}
        if stage is not None and not is_paper_rotor(stage):
            # a stage that is not the paper's: its own torque range
            spec["torque"] = {"dist": "uniform", "lower": stage.operation.torque[0],
                              "upper": stage.operation.torque[1]}
            if stage.pinion.iso_grade and stage.wheel.iso_grade:
                # both gears have a class: amplitude and sigma are unused
                spec.pop("pitch_amplitude")
                spec.pop("pitch_sigma")
        return ParameterSpace(spec | germ)

    def rotor_problem(self, params: dict[str, float] | None = None, *,
                      speed_range: bool = False, **options: Any) -> Any:
        """The :class:`gearuq.rotor.geared.GearedRotorProblem` of one parameter set.

        For analyses beyond the plugin's outputs (modal and Campbell data, sweeps along one
        branch): Yuan, Liu and Liu's rotor with the LTCA excitation of ``params`` (missing names
        take
        their nominal values), built exactly as :meth:`response` builds it;
        ``speed_range=True`` gives the problem behind ``dte_rms_max`` (the range options
        ``range_mesh_harmonics`` and ``range_cutoff_factor``).
        """
        from gearuq_plugins.geared_rotor.physics import problem_for

        values = {p.name: p.nominal for p in self.parameters} | dict(params or {})
        checked = self.validate_params({k: [v] for k, v in values.items()})
        return problem_for(self, {k: float(v[0]) for k, v in checked.items()},
                           self.validate_options(options), speed_range=speed_range)

    def _evaluate(self, params, t, outputs, **options):
        from gearuq_plugins.geared_rotor.physics import evaluate

        return evaluate(self, params, t, outputs, **options)
