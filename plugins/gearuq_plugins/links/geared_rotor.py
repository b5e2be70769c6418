"""``geared_rotor -> mesh_oscillator``: the finite-element rotor's mesh as a single-DOF oscillator.

The rotor (Yuan, Liu and Liu) linearises its mesh about the loaded tooth contact analysis
(LTCA) of each sample, ``F = k_t(tau) (delta - e_t(tau))`` over the long period (one pinion
revolution of the 30/30 pair), and solves its periodic steady state per speed on a modal
model of the two shafts, four bearings and the gear bodies. The link keeps the same LTCA (the
``mesh_excitation`` model reached through the registry, with the rotor's compliance on the
110 mm gear seat and the rotor's discretisation) and the same damping ratio, and replaces the
rotor by the mesh oscillator of Eritenel and Parker: a single DOF along the line of action
with the gear bodies' equivalent mass and the LTCA's mean tangent stiffness. Each harmonic
``j`` of the long period of the static transmission error (STE) is carried through the
oscillator's linear harmonic solution (its ``linear_amplitude``, the amplification
``|1 - Omega^2 + 2 i mu Omega|^-1``), and the RMS DTE at each speed of the range follows
from Parseval; ``dte_rms_max`` is its largest value over the speed range and
``speed_at_dte_rms_max`` where. Equations, what is neglected and the measured correlation:
docs/theory/fidelity_links.md.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gearuq.links import FidelityLink, LinkContext, LinkOutput, LowFidelityInputs
from gearuq.model import Model, Option

__all__ = ["build", "NEGLECTS", "equivalent_mass", "rms_over_speeds"]

#: What the single-DOF oscillator leaves out of the finite-element rotor, one sentence each.
NEGLECTS = (
    "The shafts' bending, torsion and axial flexibility and the four bearings: the mesh "
    "sees one mode, the gear bodies turning against the mesh stiffness, instead of the "
    "rotor's mesh-coupled modes (their frequencies, about 2.1 and 2.5 kHz with the default "
    "end inertias, and their participations); bearing stiffness does not enter.",
    "The drive and load inertias on the shaft ends and the low-frequency modes they create "
    "(the 411 Hz mode and its resonance near 815 rpm).",
    "The parametric excitation: the oscillator carries the LTCA's STE through the mean "
    "tangent stiffness (STE excitation), so the coupling of the long-period harmonics by "
    "the varying stiffness k_t(tau) is left out.",
    "Contact loss and back-flank contact (the linear harmonic solution assumes full contact, "
    "as the rotor finds at every speed of its 25-8000 rpm sweep).",
    "Gyroscopic terms (less than 0.01 % on the mesh modes at 8000 rpm in the rotor).",
    "The difference between the DTE of the gear bodies' rotations and the mesh approach: "
    "both are the oscillator's single coordinate.",
)

_EXCITATION_KEYS = ("torque", "tip_relief_amount", "tip_relief_length", "pitch_amplitude",
                    "pitch_sigma", "iso_grade")
#: unit forcing of the oscillator: small enough that its perturbation solution (computed
#: alongside) stays in contact, so no sample is flagged for separation
_UNIT = 1e-3
_SEAT_DIAMETER = 0.110  # the rotor's gear seat: bore of the gear blanks (fillet foundation)
#: long periods beyond this many mesh cycles take mesh_excitation's line-load table route
_MAX_DENSE = 120


def equivalent_mass(kind: str = "gear_bodies", stage: Any = None) -> float:
    """Mass [kg] of the normal mesh deflection of the rotor's gear pair.

    ``"gear_bodies"``: the two rigid gear bodies of the rotor (``gearuq.rotor.examples.
    seed002_rotor``: 40 mm wide, bore 110 mm, polar inertia ``I`` each; or with ``stage``
    the bodies of :func:`gearuq.rotor.stage.stage_rotor`) turning about their axes,
    ``m = I_p I_g / (I_p r_bg^2 + I_g r_bp^2) / cos^2(beta_b)`` with the base radii ``r_b``;
    the ``cos^2 beta_b`` projects the transverse base-circle motion onto the normal line of
    action.
    """
    if kind != "gear_bodies":
        raise ValueError(f"equivalent_mass={kind!r} is not one of: 'gear_bodies'")
    from gearuq.gears.geometry import seed002_pair
    from gearuq.rotor.examples import seed002_rotor
    from gearuq.rotor.stage import stage_rotor

    # the stiffness does not change the bodies
    rotor = seed002_rotor(1e9, pair=seed002_pair()) if stage is None else stage_rotor(
        stage, 1e9)
    mesh = rotor.meshes[0]
    by_node = {e.node: e for e in rotor.elements if type(e).__name__ == "DiskElement"}
    ip, ig = by_node[mesh.pinion_node].polar_inertia, by_node[mesh.gear_node].polar_inertia
    rbp, rbg = mesh.base_radius_pinion, mesh.base_radius_gear
    return ip * ig / (ip * rbg**2 + ig * rbp**2) / math.cos(mesh.base_helix_angle) ** 2


def _speeds(options: dict[str, Any]) -> np.ndarray:
    if not options["speed_min"] < options["speed_max"]:
        raise ValueError(
            f"speed_min={options['speed_min']!r} rpm must be below speed_max="
            f"{options['speed_max']!r} rpm (valid: 1 <= speed_min < speed_max <= 20000)")
    return np.linspace(options["speed_min"], options["speed_max"], options["n_speeds"])


def _grid(omega_lo: float, omega_hi: float) -> np.ndarray:
    """Frequency ratios where the oscillator is solved: geometric over the whole band, fine
    near the resonance (steps of 3.3e-4 on 0.8-1.2: the linear interpolation of a peak of
    half-width mu >= 0.01 is then within 1.4e-4 of it)."""
    parts = [np.geomspace(omega_lo, omega_hi, 600), np.linspace(0.3, 3.0, 1351),
             np.linspace(0.8, 1.2, 1201)]
    grid = np.unique(np.concatenate(parts))
    return grid[(grid >= omega_lo) & (grid <= omega_hi)]


class _InputMap:
    """LTCA of every sample through ``mesh_excitation``; the oscillator's inputs and grid."""

    def __init__(self, excitation: Model, mass: float, n_cycles: int = 30,
                 keys: tuple[str, ...] = _EXCITATION_KEYS, z1: int = 30) -> None:
        self.z1 = int(z1)
        self.excitation = excitation
        self.mass = mass
        self.n_cycles = int(n_cycles)  # mesh cycles of the long period, lcm(z1, z2)
        self.keys = keys

    @property
    def fundamental_order(self) -> float:
        """Pinion order of the long period's fundamental, ``z1 / lcm(z1, z2)``."""
        return self.z1 / self.n_cycles

    def ltca(self, params: dict[str, np.ndarray], options: dict[str, Any]
             ) -> tuple[np.ndarray, np.ndarray]:
        """STE [m] over the long period (one row per sample) and the mean tangent stiffness
        [N/m]; NaN rows where the LTCA cannot carry the load."""
        ppc, n_cycles = options["positions_per_cycle"], self.n_cycles
        tau = np.arange(n_cycles * ppc) / ppc
        germ = [k for k in params if k.startswith(("pitch_xi_p_", "pitch_xi_g_"))]
        ex = {k: params[k] for k in (*self.keys, *germ)}
        # a hunting-tooth long period: the line-load table, as the rotor's excitation
        route = {"ltca_route": "table"} if n_cycles > _MAX_DENSE else {}
        ds = self.excitation.response(ex, tau, outputs=["ste", "lpms_tangent"],
                                      positions_per_cycle=ppc, n_pts=options["n_pts"],
                                      pitch_model="germ",
                                      pitch_harmonics=options["pitch_harmonics"], threads=1,
                                      **route)
        ste = np.asarray(ds["ste"].values, dtype=float) * 1e-6
        k_mean = np.mean(np.asarray(ds["lpms_tangent"].values, dtype=float), axis=1) * 1e6
        bad = np.asarray(ds["status"].values) != 0
        ste[bad], k_mean[bad] = np.nan, np.nan
        return ste, k_mean

    def __call__(self, params: dict[str, np.ndarray], **options: Any) -> LowFidelityInputs:
        ste, k_mean = self.ltca(params, options)
        omega_n = np.sqrt(k_mean / self.mass)
        speeds = _speeds(options)
        H = options["range_mesh_harmonics"] * self.n_cycles
        # long-period fundamental w0 = 2 pi f_m / lcm(z1, z2) (one pinion revolution for 30/30)
        w0 = 2.0 * math.pi * speeds / 60.0 * self.fundamental_order
        finite = np.isfinite(omega_n)
        wn = omega_n[finite] if finite.any() else np.array([1.0])
        lo = 0.5 * float(w0[0] / wn.max())
        hi = 1.01 * float(H * w0[-1] / wn.min())
        grid = _grid(lo, hi)
        n = ste.shape[0]
        c = np.fft.rfft(np.nan_to_num(ste), axis=1) / ste.shape[1]
        inputs = {
            "damping_ratio": params["damping_ratio"],
            "alpha_0_1": np.full(n, _UNIT), "alpha_0_0": np.ones(n),
            "e_1": np.zeros(n), "alpha_2_0": np.zeros(n), "alpha_3_0": np.zeros(n),
            # a sample whose LTCA failed gets a NaN input: flagged by the link, not run
            "frequency_ratio": np.where(finite, 1.0, np.nan),
        }
        return LowFidelityInputs(
            inputs, {"frequencies": grid, "method": "perturbation", "order": 1},
            carry={"ste_harmonics": np.abs(c[:, 1:H + 1]), "omega_n": omega_n,
                   "fundamental_order": np.full(n, self.fundamental_order),
                   "mesh_stiffness": k_mean, "ste_ptp": np.ptp(ste, axis=1)})


def rms_over_speeds(ste_harmonics: np.ndarray, omega_n: np.ndarray, amplification: Any,
                    speeds: np.ndarray, fundamental_order: float = 1.0) -> np.ndarray:
    """RMS DTE [m] at every speed, ``(n_samples, n_speeds)``.

    ``ste_harmonics`` ``|STE_j|`` [m], ``j = 1..H``, of the long period; ``amplification``
    ``(i, Omega) -> |A|``, the oscillator's amplification of sample ``i`` at the frequency
    ratios ``Omega``; ``DTE_j = A(j w0 / omega_n) STE_j`` and
    ``rms^2 = 2 sum_j |DTE_j|^2`` (Parseval, the mean removed), with the long period's
    fundamental ``w0 = fundamental_order 2 pi n / 60`` (``z1 / lcm(z1, z2)``: 1 for the
    30/30 pair, whose long period is one pinion revolution, 1/79 for 27/79).
    """
    n, H = ste_harmonics.shape
    j = np.arange(1, H + 1)
    w0 = 2.0 * math.pi * np.asarray(speeds, dtype=float) / 60.0 * fundamental_order
    out = np.empty((n, w0.size))
    for i in range(n):
        ratio = j[None, :] * w0[:, None] / omega_n[i]
        amp = amplification(i, ratio)
        out[i] = np.sqrt(2.0 * np.sum((amp * ste_harmonics[i][None, :]) ** 2, axis=1))
    return out


class _RangeOutput:
    """Transform: the oscillator's amplification on its grid -> ``dte_rms_max`` or its
    speed (``which``)."""

    def __init__(self, which: str) -> None:
        self.which = which

    def __call__(self, values: np.ndarray, ctx: LinkContext) -> np.ndarray:
        grid = ctx.low_coords["frequency"]
        amp = ctx.low_data["linear_amplitude"] / _UNIT

        def amplification(i: int, ratio: np.ndarray) -> np.ndarray:
            # below the grid the response is quasi-static (|A| -> 1 as Omega -> 0)
            return np.interp(ratio, grid, amp[i], left=1.0, right=amp[i, -1])

        rms = rms_over_speeds(ctx.carried["ste_harmonics"], ctx.carried["omega_n"],
                              amplification, _speeds(ctx.options),
                              float(ctx.carried["fundamental_order"][0]))
        k = np.argmax(rms, axis=1)
        if self.which == "speed":
            return _speeds(ctx.options)[k]
        return rms[np.arange(rms.shape[0]), k]


_OPTIONS = (
    Option("speed_min", 25.0, "lowest speed of the range [rpm] (as the rotor's option)",
           lower=1.0, upper=20000.0),
    Option("speed_max", 8000.0, "highest speed of the range [rpm]; > speed_min", lower=1.0,
           upper=20000.0),
    Option("n_speeds", 160, "equally spaced speeds of the range (both ends included)",
           kind=int, lower=2, upper=100000),
    Option("range_mesh_harmonics", 3, "mesh harmonics kept (H = lcm(z1, z2) x this harmonics "
           "of the "
           "long period, as the rotor's option)", kind=int, lower=1, upper=11),
    Option("positions_per_cycle", 24, "LTCA positions per mesh cycle (the rotor's default)",
           kind=int, lower=8, upper=400),
    Option("n_pts", 20, "LTCA points per line of contact (the rotor's default)", kind=int,
           lower=2, upper=200),
    Option("pitch_harmonics", None, "tooth-index harmonics of the germ (as the rotor's "
           "option)", kind=int, lower=1, upper=15, allow_none=True),
)


def build(rotor: Model | str = "geared_rotor", oscillator: Model | str = "mesh_oscillator",
          excitation: Model | None = None, *, stage: Any = None) -> FidelityLink:
    """The link ``geared_rotor -> mesh_oscillator`` (outputs ``dte_rms_max``,
    ``speed_at_dte_rms_max``).

    Parameters
    ----------
    rotor, oscillator : Model or str
        The rotor (its parameters and default space are the link's) and the nondimensional
        mesh oscillator.
    excitation : Model, optional
        The LTCA model; default ``get_model("mesh_excitation", bore_ratio=0.110 / d_f1)``,
        the rotor's compliance (fillet foundation on the 110 mm gear seat); for a rotor
        built from a stage, ``get_model("mesh_excitation", stage=stage, bore_ratio=...)``
        with the rotor's compliance (the stage's material and gear seat), which takes the
        stage's per-gear classes and reliefs under the rotor's parameter names.
    stage : GearStage, optional
        Build the rotor from this stage (``get_model("geared_rotor", stage=stage)``); give
        it with the rotor's name, not a built rotor (a built rotor brings its own stage).
    """
    from gearuq.gears.geometry import seed002_pair
    from gearuq.registry import get_model

    if stage is not None and not isinstance(rotor, str):
        raise ValueError("give stage= with the rotor's name, not a built rotor (the stage "
                         "builds it)")
    high = (get_model(rotor, **({} if stage is None else {"stage": stage}))
            if isinstance(rotor, str) else rotor)
    low = get_model(oscillator) if isinstance(oscillator, str) else oscillator
    stage = getattr(high, "stage", None)
    if stage is not None and stage.pair == seed002_pair():
        stage = None  # Yuan, Liu and Liu's file: the paper's bodies and LTCA, as before
    if getattr(low, "dimensional", False):
        raise ValueError("oscillator: the link drives the nondimensional mesh oscillator "
                         "(get_model('mesh_oscillator') without a force)")
    if excitation is None and stage is None:
        excitation = get_model("mesh_excitation",
                               bore_ratio=_SEAT_DIAMETER / seed002_pair().df1)
    elif excitation is None:  # the stage's LTCA with the rotor's compliance
        excitation = get_model("mesh_excitation", stage=stage,
                               bore_ratio=high.compliance.bore_ratio)
    germ = tuple(n for n in high.parameter_names if n.startswith(("pitch_xi_p_",
                                                                  "pitch_xi_g_")))
    # a stage's per-gear inputs of the LTCA: the wheel's class, each relief's amount
    staged = tuple(n for n in high.parameter_names
                   if n == "iso_grade_wheel" or n.endswith("_relief_amount")
                   and n != "tip_relief_amount")
    keys = (*_EXCITATION_KEYS, *staged)
    missing = sorted(set((*keys, *germ)) - set(excitation.parameter_names))
    if missing:
        raise ValueError(f"excitation: the LTCA model {excitation.name!r} lacks the rotor's "
                         f"parameter(s) {missing}")
    return FidelityLink(
        high, low, _InputMap(excitation, equivalent_mass(stage=stage),
                             30 if stage is None else stage.long_period_mesh_cycles, keys,
                             30 if stage is None else stage.teeth[0]),
        ("damping_ratio", "alpha_0_1", "alpha_0_0", "e_1", "alpha_2_0", "alpha_3_0",
         "frequency_ratio"),
        {"linear_amplitude": LinkOutput("dte_rms_max", _RangeOutput("rms")),
         "peak_amplitude": LinkOutput("speed_at_dte_rms_max", _RangeOutput("speed"),
                                      needs=("linear_amplitude",))},
        reads=("damping_ratio", *keys, *germ),
        neglects=NEGLECTS, options=_OPTIONS,
        description="geared rotor seen as the single-DOF mesh oscillator: the same LTCA's "
                    "STE harmonics through the oscillator's linear harmonic solution with the "
                    "gear bodies' equivalent mass and the same damping ratio",
        version="1", also_runs=(excitation,))
