"""Per-sample pipeline of the ``geared_rotor`` plugin: LTCA -> rotor -> steady state -> outputs.

Every sample: the flank deviations of its parameters (pitch-deviation germ shared with the
``mesh_excitation`` plugin, so one seed gives one realisation in both), the LTCA over the long
period on a cached contact setup, the tangent linearisation (:class:`MeshExcitation`), the
paper's rotor with the sample's bearings, the modal reduction for its speed and the harmonic-
balance steady state. LTCA results and rotor reductions are cached per model instance, so a
speed sweep at fixed torque and deviations runs the LTCA and the eigen-solution once.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from gearuq.model import Evaluation
from gearuq_plugins.geared_rotor.long_period import MAX_DENSE_LONG_PERIOD

#: Status codes of this plugin (beyond the shared 0-4).
STATUS_HB_NOT_CONVERGED = 16
STATUS_SINGULAR = 17
STATUS_NO_PERIODIC = 18
STATUS_LTCA_FAILED = 19
STATUS_BACK_FLANK_TRUNCATED = 20
#: every grid speed converged, but a steady state failed while a resonance peak was being
#: located: that maximum is the largest value found before it (a lower bound of the peak)
STATUS_PEAK_NOT_LOCATED = 21
STATUS_MEANINGS = {
    STATUS_BACK_FLANK_TRUNCATED: "back_flank_contact_solved_on_spectral_orders_only",
    STATUS_HB_NOT_CONVERGED: "harmonic_balance_not_converged",
    STATUS_SINGULAR: "singular_harmonic_balance_system",
    STATUS_NO_PERIODIC: "no_stable_periodic_response",
    STATUS_LTCA_FAILED: "ltca_cannot_carry_the_load",
    STATUS_PEAK_NOT_LOCATED: "steady_state_failed_while_locating_a_peak",
}
_FROM_SOLVER = {0: 0, 1: STATUS_HB_NOT_CONVERGED, 2: STATUS_SINGULAR, 3: STATUS_NO_PERIODIC,
                4: STATUS_BACK_FLANK_TRUNCATED}
#: Outputs over the speed range -> (quantity of DynamicRange, kind).
_DYNAMIC_OUTPUTS = {
    "kv_max": ("kv", "max"), "speed_at_kv_max": ("kv", "speed"),
    "kv_over_speed": ("kv", "curve"),
    "dte_mesh_band_rms_max": ("dte_mesh_band_rms", "max"),
    "speed_at_dte_mesh_band_rms_max": ("dte_mesh_band_rms", "speed"),
    "dte_mesh_band_rms_over_speed": ("dte_mesh_band_rms", "curve"),
    "dte_mesh_order_max": ("dte_mesh_orders", "max"),
    "speed_at_dte_mesh_order_max": ("dte_mesh_orders", "speed"),
    "dte_mesh_order_over_speed": ("dte_mesh_orders", "curve"),
    "bearing1_acceleration_y_mesh_order_max": ("acceleration_mesh_orders", "max"),
    "speed_at_bearing1_acceleration_y_mesh_order_max": ("acceleration_mesh_orders", "speed"),
    "bearing1_acceleration_y_mesh_order_over_speed": ("acceleration_mesh_orders", "curve"),
}
_RANGE_OUTPUTS = ("dte_rms_max", "speed_at_dte_rms_max", *_DYNAMIC_OUTPUTS)
#: Outputs of a stage whose long period is beyond the dense balance (the speed range).
LONG_PERIOD_OUTPUTS = _RANGE_OUTPUTS
#: Outputs that need neither the LTCA nor the rotor (the drawing's numbers).
_CHEAP_OUTPUTS = ("kv_iso_max", "speed_at_kv_iso_max", "kv_iso_over_speed",
                  "pitch_total_deviation_pinion", "pitch_total_deviation_wheel",
                  "pitch_acceptance_margin")
_BEARINGS = ("bearing 1", "bearing 2", "bearing 3", "bearing 4")
_SEAT_DIAMETER = 0.110  # gear seat of both shafts (Yuan, Liu and Liu Sec. 2.2): the gear-blank bore


def seed_pair() -> Any:
    """The helical pair of Yuan, Liu and Liu (2020), Table 1."""
    from gearuq.gears.geometry import seed002_pair

    return seed002_pair()


def compliance_model(pair: Any) -> Any:
    """Tooth compliance with the fillet foundation on the real bore (the 110 mm gear seat)."""
    from gearuq.gears.compliance import ComplianceModel

    return ComplianceModel(pair, bore_ratio=_SEAT_DIAMETER / pair.df1)


def gear_grade(values: dict[str, float], gear: int) -> int:
    """ISO 1328-1 class of the pinion (``gear=1``) or the wheel: ``iso_grade``, or for the
    wheel of a stage whose classes differ ``iso_grade_wheel``."""
    if gear == 2 and "iso_grade_wheel" in values:
        return int(values["iso_grade_wheel"])
    return int(values["iso_grade"])


def pitch_amplitude_sigma(pair: Any, values: dict[str, float], gear: int,
                          law: tuple[str, float] = ("untruncated_iso", 0.05)
                          ) -> tuple[float, float]:
    """Sine amplitude and scatter sigma [m] of one gear: ISO grade or the parameters.

    ``law``: ``(pitch_tolerance_law, process_share_beyond)``; with ``"capable_process"`` an
    ISO grade sets the process of :func:`gearuq.gears.deviations.capable_pitch_scatter`.
    """
    from gearuq.gears.deviations import capable_pitch_scatter, iso1328_pitch_tolerances

    grade = gear_grade(values, gear)
    if grade > 0:
        z = pair.z1 if gear == 1 else pair.z2
        f_pT, F_pT = iso1328_pitch_tolerances(pair.d1 if gear == 1 else pair.d2, pair.mn,
                                              grade)
        if law[0] == "capable_process":
            return capable_pitch_scatter(z, f_pT, F_pT, law[1])
        return 0.5 * F_pT, f_pT / (3.0 * math.sqrt(2.0))
    return values["pitch_amplitude"] / 1e6, values["pitch_sigma"] / 1e6


class SharedTipRelief:
    """One tip relief of the same shape, amount and length on pinion and wheel, as the normal
    clearance map ``FlankDeviations.user(s, y, k1, k2)`` [m].

    The profile is the stage's :meth:`gearuq.gears.stage.Relief.profile` (linear, parabolic
    or arc in the roll distance ``v`` from the start of the relief), so the rotor's relief
    and ``mesh_excitation``'s relief of a stage are one formula. The pinion's tip is at the
    end of the path of contact ``s_E``, the wheel's at its start ``s_A``; the transverse
    relief is turned to the normal direction by ``cos(beta_b)``, as the LTCA's own reliefs.

    Parameters
    ----------
    pair : HelicalGearPair
        The pair (its path of contact and base helix angle).
    shape : {"linear", "parabolic", "arc"}
        Shape of the relief.
    amount : float
        Relief [um] at the tip (end of the active profile), along the line of action.
    length : float
        Length [mm] of the relief along the path of contact.
    """

    #: the map ignores the tooth indices, so the long-period line-load table may hold it
    same_on_every_tooth = True

    def __init__(self, pair: Any, shape: str, amount: float, length: float) -> None:
        from gearuq.gears.stage import Relief

        # the start is not used by Relief.profile (it takes the roll distance from it)
        self.relief = Relief(shape, amount, start_roll_length=1.0)
        self.length = float(length)
        self.s_A, self.s_E = pair.g_f1 * 1e3, (pair.g_f1 + pair.g_alpha) * 1e3
        self.cos_bb = math.cos(pair.beta_b)

    def __call__(self, s: Any, y: Any, k1: Any, k2: Any) -> np.ndarray:
        s_mm = np.asarray(s, dtype=float) * 1e3
        total = np.zeros_like(s_mm)
        for v in (s_mm - (self.s_E - self.length), (self.s_A + self.length) - s_mm):
            total = total + np.where(v > 0.0, self.relief.profile(v, self.length), 0.0)
        return np.broadcast_to(total * 1e-6 * self.cos_bb, np.broadcast_shapes(
            np.shape(s), np.shape(y), np.shape(k1), np.shape(k2)))


def sample_deviations(pair: Any, values: dict[str, float], phases: str = "seed",
                      pitch_model: str = "germ", pitch_harmonics: int | None = None,
                      law: tuple[str, float] = ("untruncated_iso", 0.05),
                      tip_shape: str = "parabolic") -> Any:
    """Flank deviations of one sample: pitch deviations (germ or seeded) and tip relief.

    ``tip_shape``: the shape of the shared tip relief ``tip_relief_amount`` /
    ``tip_relief_length``; ``"parabolic"`` is the LTCA's own relief (Yuan, Liu and Liu
    Eq. 12), ``"linear"`` and ``"arc"`` travel as a :class:`SharedTipRelief` map.

    ``pitch_model="germ"``: each gear's cumulative deviations are the smooth expansion
    :func:`gearuq.gears.deviations.cumulative_pitch_from_normals` of its standard normals
    ``pitch_xi_p_*`` / ``pitch_xi_g_*``. ``"seeded"``: the realisation of ``pitch_seed``;
    ``phases="parameters"`` then replaces its two sine phases by ``pitch_phase_pinion`` and
    ``pitch_phase_wheel`` (the scatter stays the paper's).
    """
    from gearuq.gears.deviations import (
        FlankDeviations,
        cumulative_pitch_from_germ,
        cumulative_pitch_from_normals,
        pitch_deviation_germ,
        pitch_germ_from_values,
    )

    fp = []
    if pitch_model == "germ":
        for gear, z in ((1, pair.z1), (2, pair.z2)):
            amp, sigma = pitch_amplitude_sigma(pair, values, gear, law)
            xi = pitch_germ_from_values(values, z, gear, pitch_harmonics)
            fp.append(cumulative_pitch_from_normals(xi, z, amplitude=amp, sigma=sigma))
    else:
        germ = list(pitch_deviation_germ(pair.z1, pair.z2, int(values["pitch_seed"])))
        if phases == "parameters":
            germ[0], germ[2] = values["pitch_phase_pinion"], values["pitch_phase_wheel"]
        for gear, phase, normals in ((1, germ[0], germ[1]), (2, germ[2], germ[3])):
            amp, sigma = pitch_amplitude_sigma(pair, values, gear, law)
            fp.append(cumulative_pitch_from_germ(phase, normals, amplitude=amp, sigma=sigma))
    amount, length = values["tip_relief_amount"] / 1e6, values["tip_relief_length"] / 1e3
    if tip_shape != "parabolic" and amount > 0:
        return FlankDeviations(Fp1=fp[0], Fp2=fp[1], user=SharedTipRelief(
            pair, tip_shape, values["tip_relief_amount"], values["tip_relief_length"]))
    tip = (amount, length) if amount > 0 else None
    return FlankDeviations(Fp1=fp[0], Fp2=fp[1], tip_relief1=tip, tip_relief2=tip)


def check_germ(params: dict[str, np.ndarray], pair: Any, options: dict[str, Any]) -> None:
    """Refuse, before anything runs, germ values the kept germ cannot represent."""
    from gearuq.gears.deviations import pitch_germ_from_values

    if options["pitch_model"] != "germ":
        return
    for gear, z in ((1, pair.z1), (2, pair.z2)):
        worst = {k: float(v[np.argmax(v != 0)].item()) for k, v in params.items()
                 if k.startswith(("pitch_xi_p_", "pitch_xi_g_")) and np.any(v != 0)}
        pitch_germ_from_values(worst, z, gear, options["pitch_harmonics"])


def _cached(model: Any, key: tuple, build: Any) -> Any:
    cache = model._cache
    if key in cache:
        cache[key] = cache.pop(key)  # most recently used last
        return cache[key]
    value = build()
    if model.cache_size:
        cache[key] = value
        while len(cache) > model.cache_size + 1:  # +1: the setup entry stays
            oldest = next(k for k in cache if k[0] != "setup")
            cache.pop(oldest)
    return value


_LTCA_KEYS = ("torque", "pitch_amplitude", "pitch_sigma", "iso_grade", "pitch_seed",
              "pitch_phase_pinion", "pitch_phase_wheel", "tip_relief_amount",
              "tip_relief_length", "lead_crowning")
_GERM_KEYS = tuple(f"{p}{i}" for p in ("pitch_xi_p_", "pitch_xi_g_") for i in range(1, 30))
_ROTOR_KEYS = ("bearing_stiffness", "bearing_axial_stiffness", "bearing_damping",
               "bearing_stiffness_scale", "bearing_axial_stiffness_scale",
               "bearing_damping_scale", "damping_ratio", "backlash", "drive_inertia",
               "load_inertia")


def _stage_ltca_keys(model: Any) -> tuple[str, ...]:
    """Parameters of a stage that change its LTCA: the wheel's class, per-relief amounts."""
    flanks = getattr(model, "flanks", None)
    return () if flanks is None else ("iso_grade_wheel", *flanks.value_keys)


def model_deviations(model: Any, pair: Any, values: dict[str, float],
                     options: dict[str, Any]) -> Any:
    """Flank deviations of one sample of ``model``: :func:`sample_deviations` with the lead
    crowning ``lead_crowning`` and, for a stage, its measured pitch deviations, reliefs and
    slopes."""
    law = (options["pitch_tolerance_law"], options["process_share_beyond"])
    dev = sample_deviations(pair, values, options["pitch_phases"], options["pitch_model"],
                            options["pitch_harmonics"], law, options["tip_relief_shape"])
    if values.get("lead_crowning", 0.0):  # um, both gears; a stage's nominal is its own
        from gearuq.gears.stage import to_si

        dev = replace(dev, crowning=to_si(values["lead_crowning"], "1e-6"))
    flanks = getattr(model, "flanks", None)
    return dev if flanks is None else flanks.apply(dev, values)


def problem_for(model: Any, values: dict[str, float], options: dict[str, Any], *,
                speed_range: bool = False) -> Any:
    """The :class:`GearedRotorProblem` of one sample (LTCA and reduction cached).

    ``speed_range=True``: the problem of the range outputs, with ``range_mesh_harmonics``
    and ``range_cutoff_factor`` instead of ``n_mesh_harmonics`` and ``cutoff_factor`` (the
    same LTCA excitation).
    """
    from gearuq.gears.ltca import ltca_setup
    from gearuq.rotor.examples import seed002_rotor
    from gearuq.rotor.excitation import MeshExcitation
    from gearuq.rotor.geared import GearedRotorProblem
    stage = getattr(model, "stage", None)
    pair = seed_pair() if stage is None else stage.pair
    ppc, n_pts = options["positions_per_cycle"], options["n_pts"]
    long_period = math.lcm(pair.z1, pair.z2) > MAX_DENSE_LONG_PERIOD
    if long_period and not speed_range:
        raise ValueError(f"a long period of {math.lcm(pair.z1, pair.z2)} mesh cycles is "
                         "solved over the speed range only (outputs "
                         f"{', '.join(LONG_PERIOD_OUTPUTS)})")
    setup = None if long_period else _cached(
        model, ("setup", ppc, n_pts),
        lambda: ltca_setup(pair, compliance=compliance_model(pair) if stage is None
                           else model.compliance, positions_per_cycle=ppc, n_pts=n_pts))
    germ_keys = _GERM_KEYS if stage is None else tuple(
        k for k in values if k.startswith(("pitch_xi_p_", "pitch_xi_g_")))
    law = (options["pitch_tolerance_law"], options["process_share_beyond"])
    lkey = ("ltca", ppc, n_pts, options["pitch_phases"], options["pitch_model"],
            options["pitch_harmonics"], options["tip_relief_shape"]) + law + tuple(
        values[k] for k in _LTCA_KEYS) + tuple(values.get(k, 0.0) for k in germ_keys) + tuple(
        values.get(k, 0.0) for k in _stage_ltca_keys(model))
    deviations = model_deviations(model, pair, values, options)
    excitation = _cached(model, lkey, (lambda: _table_excitation(model, pair, values["torque"],
                                                                 deviations, ppc, n_pts))
                         if long_period else (lambda: MeshExcitation.from_setup(
                             setup, values["torque"], deviations=deviations)))
    harmonics, cutoff_factor = ((options["range_mesh_harmonics"], options["range_cutoff_factor"])
                                if speed_range else (mesh_harmonics(options, values["speed"],
                                                                    pair.z1),
                                                     options["cutoff_factor"]))
    H = harmonics * excitation.n_cycles
    rkey = ("rotor", H, cutoff_factor, options["moment_arm"], options["end_inertias"],
            (options["long_period_solver"], options["spectral_energy"],
             options["gmres_tol"]) if long_period
            else None) + lkey + tuple(
        values.get(k, 0.0) for k in _ROTOR_KEYS)

    ends = options["end_inertias"] == "parameters"

    def build() -> Any:
        if long_period:  # a hunting-tooth stage: spectral orders of the long period
            from gearuq_plugins.geared_rotor.long_period import LongPeriodProblem
            from gearuq_plugins.geared_rotor.stage import StageRotorFactory

            return LongPeriodProblem(
                StageRotorFactory(stage, values, options["moment_arm"], ends), excitation,
                pair.z1, mesh_harmonics=harmonics, solver=options["long_period_solver"],
                spectral_energy=options["spectral_energy"], gmres_tol=options["gmres_tol"],
                damping_ratio=values["damping_ratio"], cutoff_factor=cutoff_factor,
                backlash=values["backlash"] * 1e-6)
        if stage is not None:  # the stage's FE rotor (gearuq.rotor.stage)
            from gearuq_plugins.geared_rotor.stage import StageRotorFactory

            factory: Any = StageRotorFactory(stage, values, options["moment_arm"], ends)
            return GearedRotorProblem(factory, excitation, pair.z1,
                                      damping_ratio=values["damping_ratio"], n_harmonics=H,
                                      cutoff_factor=cutoff_factor,
                                      backlash=values["backlash"] * 1e-6)

        def factory(k: float) -> Any:
            return seed002_rotor(
                k, pair=pair, bearing_radial_stiffness=values["bearing_stiffness"],
                bearing_axial_stiffness=values["bearing_axial_stiffness"],
                bearing_damping=values["bearing_damping"], moment_arm=options["moment_arm"],
                drive_inertia=values["drive_inertia"] if ends else None,
                load_inertia=values["load_inertia"] if ends else None)

        return GearedRotorProblem(factory, excitation, pair.z1,
                                  damping_ratio=values["damping_ratio"], n_harmonics=H,
                                  cutoff_factor=cutoff_factor,
                                  backlash=values["backlash"] * 1e-6)

    return _cached(model, rkey, build)


def _table_excitation(model: Any, pair: Any, torque: float, deviations: Any, ppc: int,
                      n_pts: int) -> Any:
    """Excitation over a long period from a line-load table built for this torque."""
    from gearuq.gears.long_period import LongPeriodSettings, long_period_ltca
    from gearuq.rotor.sideband_balance import excitation_from_long_period

    ds = long_period_ltca(pair, deviations, torque=torque, compliance=model.compliance,
                          settings=LongPeriodSettings(positions_per_cycle=ppc, n_pts=n_pts),
                          keep_lines=False)
    return excitation_from_long_period(ds)


def mesh_harmonics(options: dict[str, Any], speed: float, z1: int = 30) -> int:
    """Mesh harmonics of a steady state: the option, or chosen from the speed.

    ``n_mesh_harmonics=None``: every mesh harmonic up to ``harmonic_band`` Hz, at least 4,
    at most the ``(positions_per_cycle - 1) // 2`` the LTCA samples resolve (measured
    accuracy: docs/theory/geared_rotor.md Sec. 9.1).
    """
    if options["n_mesh_harmonics"] is not None:
        return int(options["n_mesh_harmonics"])
    top = (options["positions_per_cycle"] - 1) // 2
    f_mesh = z1 * speed / 60.0  # z1 = 30 for Yuan, Liu and Liu's pair
    return int(min(top, max(4, math.ceil(options["harmonic_band"] / f_mesh - 1e-9))))


def order_coordinates(H: int, n_cycles: int, z1: int, n_sidebands: int) -> dict[str, tuple]:
    """Coordinates of the ``order`` dimension: index, pinion order and a readable label."""
    j = np.arange(H + 1)
    labels = []
    for k in j:
        mesh, side = divmod(int(k), n_cycles)
        if side > n_cycles // 2:
            mesh, side = mesh + 1, side - n_cycles
        if mesh >= 1 and side == 0:
            labels.append("f_m" if mesh == 1 else f"{mesh} f_m")
        elif mesh >= 1 and abs(side) <= n_sidebands:
            m = "f_m" if mesh == 1 else f"{mesh} f_m"
            labels.append(f"{m} {'+' if side > 0 else '-'} {abs(side)} f_s")
        else:
            labels.append("0" if k == 0 else ("f_s" if k == 1 else f"{k} f_s"))
    return {
        "order": ("order", j, {"long_name": "harmonic of the long period (one pinion "
                               "revolution for the 30/30 pair)", "units": "1"}),
        "pinion_order": ("order", j * z1 / n_cycles, {"units": "1",
                         "long_name": "frequency / pinion shaft frequency"}),
        "order_label": ("order", np.array(labels), {
            "long_name": "f_s shaft frequency, f_m mesh frequency, sidebands f_m +- i f_s"}),
    }


def _amplitudes(c: np.ndarray) -> np.ndarray:
    amp = 2.0 * np.abs(c)
    amp[0] = abs(c[0].real)
    return amp


def _put_spectrum(out: np.ndarray, i: int, c: np.ndarray) -> None:
    """Amplitudes of one sample; orders above its own H are zero (its steady state is
    band-limited to H; with ``n_mesh_harmonics=None`` H depends on the sample's speed)."""
    amp = _amplitudes(c)
    out[i] = 0.0
    out[i, :amp.size] = amp


def _ptp(c: np.ndarray, n_time: int) -> float:
    """Peak-to-peak of a band-limited signal on 8 times the AFT grid (>= 32 instants per
    period of its highest harmonic: the sampled peak is within 0.5 % of that harmonic's
    amplitude of the true one)."""
    n = 8 * n_time
    full = np.zeros(n // 2 + 1, dtype=complex)
    full[:c.size] = c
    return float(np.ptp(np.fft.irfft(full * n, n=n)))


def _rms(c: np.ndarray) -> float:
    return float(math.sqrt(2.0 * np.sum(np.abs(c[1:]) ** 2)))


def _fill_sample(data: dict, i: int, sol: Any, prob: Any, t: np.ndarray, outputs: list[str],
                 speed: float) -> None:
    from gearuq.rotor.harmonic_balance import contact_loss_share, mesh_force_at, synthesize

    T = sol.period
    ch = sol.channels
    scalars = {  # evaluated only when asked for (the fine-grid ones cost FFTs)
        "dte_rms": lambda: _rms(ch["dte"]), "dte_mean": lambda: float(ch["dte"][0].real),
        "dte_mesh_band_rms": lambda: float(math.sqrt(2.0 * np.sum(
            np.abs(ch["dte"][prob.excitation.n_cycles // 2:]) ** 2))),
        "dte_ptp": lambda: _ptp(ch["dte"], prob.prep.n_time),
        "mesh_force_rms": lambda: _rms(sol.force), "mesh_force_min": lambda: sol.min_force,
        "bearing1_acceleration_y_rms": lambda: _rms(ch["bearing 1 acceleration y"]),
        "contact_loss_fraction": lambda: contact_loss_share(prob.prep, sol, prob.backlash),
        "ste_ptp": lambda: float(np.ptp(prob.excitation.ste)),
        "mesh_frequency": lambda: prob.pinion_teeth * speed / 60.0,
        "shaft_frequency": lambda: speed / 60.0,
    }
    for name in outputs:
        if name in scalars:
            data[name][i] = scalars[name]()
        elif name == "dte":
            data[name][i] = synthesize(ch["dte"], t, T)
        elif name == "mesh_approach":
            data[name][i] = synthesize(sol.delta, t, T)
        elif name == "mesh_force":
            data[name][i] = mesh_force_at(prob.prep, sol, t, prob.backlash)
        elif name.startswith(("bearing_force_", "bearing_acceleration_")):
            kind, axis = ("force", name[-1]) if "force" in name else ("acceleration", name[-1])
            for b, label in enumerate(_BEARINGS):
                data[name][i, b] = synthesize(ch[f"{label} {kind} {axis}"], t, T)
        elif name == "dte_spectrum":
            _put_spectrum(data[name], i, ch["dte"])
        elif name == "mesh_force_spectrum":
            _put_spectrum(data[name], i, sol.force)
        elif name == "bearing1_acceleration_y_spectrum":
            _put_spectrum(data[name], i, ch["bearing 1 acceleration y"])


def iso_class(values: dict[str, float], options: dict[str, Any], gear: int | None = None
              ) -> int:
    """Accuracy class of ISO 6336-1's K_v: ``iso_grade``, or ``kv_iso_class`` when it is 0.

    ``gear=None``: the pair's, the coarser of the two gears' classes (ISO 6336-1 takes the
    larger pitch deviation of the pair); ``gear=1`` or ``2``: that gear's.
    """
    grades = [gear_grade(values, g) for g in ((1, 2) if gear is None else (gear,))]
    if 0 in grades:
        return int(options["kv_iso_class"])
    return max(grades)


def _fill_cheap(data: dict, i: int, values: dict[str, float], options: dict[str, Any],
                speeds: np.ndarray, names: list[str], pair: Any, model: Any) -> None:
    """ISO 6336-1 Method B K_v over the range and the total cumulative pitch deviations of
    ``pair`` (Yuan, Liu and Liu's, or the stage's)."""
    from gearuq.gears.deviations import iso1328_pitch_tolerances
    from gearuq.gears.iso6336 import pair_dynamic_factor_method_b

    if any(n.startswith(("kv_iso", "speed_at_kv_iso")) for n in names):
        iso = pair_dynamic_factor_method_b(
            pair, values["torque"], speeds, accuracy_grade=iso_class(values, options),
            tip_relief_um=values["tip_relief_amount"] if getattr(model, "flanks", None) is None
            else model.flanks.tip_relief_um(values))
        j = int(np.argmax(iso.kv))
        for name, value in (("kv_iso_max", iso.kv[j]), ("speed_at_kv_iso_max", speeds[j]),
                            ("kv_iso_over_speed", iso.kv)):
            if name in data:
                data[name][i] = value
    if any(n.startswith(("pitch_total", "pitch_acceptance")) for n in names):
        dev = model_deviations(model, pair, values, options)
        totals = (float(np.ptp(dev.Fp1)), float(np.ptp(dev.Fp2)))
        for name, fp in zip(("pitch_total_deviation_pinion", "pitch_total_deviation_wheel"),
                            totals, strict=True):
            if name in data:
                data[name][i] = fp
        if "pitch_acceptance_margin" in data:
            F_pT = [iso1328_pitch_tolerances(d, pair.mn, iso_class(values, options, g))[1]
                    for g, d in ((1, pair.d1), (2, pair.d2))]
            data["pitch_acceptance_margin"][i] = min(1.0 - fp / tol
                                                     for fp, tol in zip(totals, F_pT, strict=True))


def _fill_dynamic(data: dict, i: int, dyn: Any, names: list[str]) -> None:
    """Range outputs of one sample from its :class:`DynamicRange`."""
    for name in names:
        quantity, kind = _DYNAMIC_OUTPUTS[name]
        curve = getattr(dyn, quantity)
        if kind == "curve":
            data[name][i] = curve
        elif curve.ndim == 1:
            value, speed, _ = dyn.peaks[quantity]
            data[name][i] = value if kind == "max" else speed
        else:
            for c in range(curve.shape[1]):
                value, speed, _ = dyn.peaks[f"{quantity}_{c + 1}"]
                data[name][i, c] = value if kind == "max" else speed


def evaluate(model: Any, params: dict[str, np.ndarray], t: np.ndarray, outputs: list[str],
             **options: Any) -> Evaluation:
    """Run every sample; failures are flagged per sample (NaN outputs), never dropped."""
    from gearuq.gears.contact import long_period_cycles
    from gearuq.rotor.geared import single_threaded_blas

    pair = seed_pair() if getattr(model, "stage", None) is None else model.stage.pair
    n_cycles = long_period_cycles(pair)
    chosen = options["n_mesh_harmonics"]
    if chosen is not None and 2 * chosen >= options["positions_per_cycle"]:
        raise ValueError(
            f"n_mesh_harmonics={options['n_mesh_harmonics']} needs positions_per_cycle > "
            f"{2 * options['n_mesh_harmonics']} (got {options['positions_per_cycle']}): the "
            "LTCA samples must resolve the harmonics kept")
    check_germ(params, pair, options)
    if t.size and float(np.min(t)) < 0.0:
        raise ValueError(
            f"t contains negative instants (smallest {float(np.min(t))!r} s); valid range "
            "[0, inf) s: the periodic steady state has no start, shift t by whole periods")
    if not options["speed_min"] < options["speed_max"]:
        raise ValueError(
            f"speed_min={options['speed_min']!r} rpm must be below speed_max="
            f"{options['speed_max']!r} rpm (the range of dte_rms_max; valid: 1 <= speed_min < "
            "speed_max <= 20000)")
    if 2 * options["range_mesh_harmonics"] >= options["positions_per_cycle"]:
        raise ValueError(
            f"range_mesh_harmonics={options['range_mesh_harmonics']} needs positions_per_cycle "
            f"> {2 * options['range_mesh_harmonics']} (got {options['positions_per_cycle']})")
    speeds = np.linspace(options["speed_min"], options["speed_max"], options["n_speeds"])
    ranged = [o for o in outputs if o in _RANGE_OUTPUTS]
    cheap = [o for o in outputs if o in _CHEAP_OUTPUTS]
    single = [o for o in outputs if o not in _RANGE_OUTPUTS and o not in _CHEAP_OUTPUTS]
    long_period = n_cycles > MAX_DENSE_LONG_PERIOD
    if long_period and single:
        raise ValueError(
            f"outputs={single!r} are outside what a long period of {n_cycles} mesh cycles "
            "gives (beyond the dense balance's "
            f"{MAX_DENSE_LONG_PERIOD}): valid outputs {LONG_PERIOD_OUTPUTS + _CHEAP_OUTPUTS}")
    n = next(iter(params.values())).shape[0]
    speed_values = params.get("speed", np.full(n, model.parameter("speed").nominal))
    per_sample = [mesh_harmonics(options, float(v), pair.z1) for v in speed_values]
    H = max(per_sample, default=mesh_harmonics(options, 4000.0, pair.z1)) * n_cycles
    sizes = {"time": t.size, "order": H + 1, "bearing": 4, "range_speed": speeds.size,
             "mesh_harmonic": options["range_mesh_harmonics"]}
    shapes = {o.name: (n,) + tuple(sizes[d] for d in o.dims[1:]) for o in model.outputs}
    data = {name: np.full(shapes[name], np.nan) for name in outputs}
    status = np.zeros(n, dtype=np.int8)
    extra = {k: np.full(n, np.nan) for k in ("n_modes", "hb_iterations", "hb_residual",
                                              "drift", "range_newton_iterations",
                                              "n_mesh_harmonics", "peak_refinement_runs",
                                              "run_down_speeds", "kv_grid_max_run_up",
                                              "aperiodic_speeds")}
    branch = np.full(n, -1, dtype=np.int8)
    with single_threaded_blas():
        for i in range(n):
            values = {k: float(v[i]) for k, v in params.items()}
            if cheap:
                _fill_cheap(data, i, values, options, speeds, cheap, pair, model)
            if not (single or ranged):
                continue
            try:
                prob = problem_for(model, values, options) if single else None
                rng_prob = (problem_for(model, values, options, speed_range=True) if ranged
                            else None)
            except ValueError:
                status[i] = STATUS_LTCA_FAILED
                continue
            dynamic = [o for o in ranged if o in _DYNAMIC_OUTPUTS]
            if dynamic or (long_period and ranged):  # spectral orders: the dynamic sweep
                dyn = rng_prob.dynamics_over_speeds(
                    speeds, mesh_orders=options["range_mesh_harmonics"], tol=options["tol"],
                    refine=sorted({_DYNAMIC_OUTPUTS[o][0] for o in dynamic}),
                    peaks_refined=options["peaks_refined"],
                    speed_tol=options["peak_speed_tol"],
                    sweep_direction=options["sweep_direction"],
                    aperiodic_response=options["aperiodic_response"])
                status[i] = _FROM_SOLVER[dyn.worst_status()]
                if status[i] == 0 and dyn.refinement_status != 0:
                    status[i] = STATUS_PEAK_NOT_LOCATED
                _fill_dynamic(data, i, dyn, dynamic)
                extra["range_newton_iterations"][i] = float(dyn.iterations.sum())
                extra["peak_refinement_runs"][i] = float(dyn.refinement_runs)
                extra["run_down_speeds"][i] = float(dyn.run_down_speeds)
                extra["aperiodic_speeds"][i] = float(dyn.aperiodic_speeds)
                if np.any(np.isfinite(dyn.kv_run_up)):
                    extra["kv_grid_max_run_up"][i] = float(np.nanmax(dyn.kv_run_up))
                if "dte_rms_max" in ranged or "speed_at_dte_rms_max" in ranged:
                    j = int(np.nanargmax(dyn.dte_rms)) if np.any(np.isfinite(dyn.dte_rms)) \
                        else 0
                    for name, value in (("dte_rms_max", dyn.dte_rms[j]),
                                        ("speed_at_dte_rms_max", speeds[j])):
                        if name in data and np.isfinite(dyn.dte_rms[j]):
                            data[name][i] = value
            elif rng_prob is not None:
                res = rng_prob.rms_over_speeds(speeds, tol=options["tol"])
                peak, at, code = res.maximum()
                status[i] = _FROM_SOLVER[code]
                for name, value in (("dte_rms_max", peak), ("speed_at_dte_rms_max", at)):
                    if name in data and np.isfinite(peak):
                        data[name][i] = value
                extra["range_newton_iterations"][i] = float(res.iterations.sum())
            if prob is None:
                continue
            sol = prob.steady_state(values["speed"], tol=options["tol"])
            if options["verify"] and sol.branch != "full_contact" and sol.status in (0, 1):
                sol = prob.verify(sol, values["speed"])
            status[i] = max(int(status[i]), _FROM_SOLVER[sol.status])
            extra["n_modes"][i] = prob.reduced(values["speed"]).n_modes
            extra["n_mesh_harmonics"][i] = prob.n_harmonics / n_cycles
            extra["hb_iterations"][i] = sol.iterations
            extra["hb_residual"][i] = sol.residual
            extra["drift"][i] = sol.drift
            branch[i] = {"full_contact": 0, "contact_loss": 1, "back_flank_contact": 2}[
                sol.branch]
            if sol.status in (0, 3):
                _fill_sample(data, i, sol, prob, t, single, values["speed"])
    coords = {"bearing": ("bearing", np.array(_BEARINGS), {}),
              "range_speed": ("range_speed", speeds, {"units": "rpm", "long_name":
                              "grid speeds of the range (pinion)"}),
              "mesh_harmonic": ("mesh_harmonic",
                                np.arange(1, options["range_mesh_harmonics"] + 1),
                                {"units": "1", "long_name": "mesh harmonic m of m f_m"})}
    coords.update(order_coordinates(H, n_cycles, pair.z1, options["n_sidebands"]))
    return Evaluation(
        data=data, status=status, status_meanings=STATUS_MEANINGS, coords=coords,
        extra={
            "n_modes": ("sample", extra["n_modes"], {"units": "1",
                        "long_name": "modes kept by the reduction"}),
            "hb_iterations": ("sample", extra["hb_iterations"], {"units": "1"}),
            "peak_refinement_runs": ("sample", extra["peak_refinement_runs"], {
                "units": "1", "long_name": "steady states solved to locate the peaks of the "
                "range outputs beyond the grid (NaN: not computed)"}),
            "run_down_speeds": ("sample", extra["run_down_speeds"], {
                "units": "1", "long_name": "grid speeds solved by the run-down over the "
                "run-up's contact-loss ranges (sweep_direction='up_and_down'; NaN: range not "
                "computed)"}),
            "aperiodic_speeds": ("sample", extra["aperiodic_speeds"], {
                "units": "1", "long_name": "grid speeds whose K_v was read from the time "
                "integration's last long periods (no periodic response there; on the sweep "
                "that supplied it) plus the distinct speeds of the peak search read so "
                "(aperiodic_response='window_max'; NaN: range not computed)"}),
            "kv_grid_max_run_up": ("sample", extra["kv_grid_max_run_up"], {
                "units": "1", "long_name": "largest K_v of the run-up's grid speeds (beside "
                "kv_max, which also has the run-down and the located peaks)"}),
            "n_mesh_harmonics": ("sample", extra["n_mesh_harmonics"], {"units": "1",
                                 "long_name": "mesh harmonics of the steady state"}),
            "hb_residual": ("sample", extra["hb_residual"], {"units": "1"}),
            "range_newton_iterations": ("sample", extra["range_newton_iterations"], {
                "units": "1", "long_name": "Newton iterations over the speed range (0: full "
                "contact everywhere; NaN: range not computed)"}),
            "stability_drift": ("sample", extra["drift"], {"units": "1", "long_name":
                                "time-integration check (NaN: not checked)"}),
            "branch": ("sample", branch, {"flag_values": np.array([-1, 0, 1, 2], np.int8),
                       "flag_meanings": "not_solved full_contact contact_loss "
                       "back_flank_contact", "units": "1"}),
        },
        attrs={"n_harmonics": H, "long_period_mesh_cycles": n_cycles,
               "speed_range_rpm": f"{options['speed_min']:g}..{options['speed_max']:g} in "
                                  f"{options['n_speeds']} speeds",
               "solver": "harmonic balance on the mesh approach (AFT for contact loss)"},
    )
