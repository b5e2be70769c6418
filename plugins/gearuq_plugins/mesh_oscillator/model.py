"""The ``mesh_oscillator`` plugin class: parameters, options, outputs and their assembly.

Two kinds of instance:

- ``MeshOscillator()`` (default): the nondimensional equation of motion of Eritenel and Parker
  (Eqs. 11-12) with its coefficients as parameters; the nominal values are the example system of
  Eritenel and Parker Fig. 4.
- ``MeshOscillator(force=...)``: a dimensional gear mesh ``m x'' + c x' + C f(x, t) = F(t)``
  with a force-deflection function from :mod:`.forces` (LTCA table, user table, analytic);
  the parameters are the equivalent mass, damping ratio, mean load and load harmonic (and a
  family parameter such as a relief amount); the expansion gives the nondimensional system.

Outputs come in three groups, computed only when asked for: frequency responses over the
``frequency`` grid (no ``t`` needed), the expansion (per sample), and time responses over
``t``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from gearuq._firstcall import kernels_route
from gearuq.model import Model, Option, Output, Parameter, bounded_below

_P = Parameter
_NONDIMENSIONAL_PARAMETERS = (
    _P("alpha_0_0", "1", 2 / 3, 1e-3, 100.0,
       "mean load over (mean tangent stiffness x d), Eritenel and Parker Eq. 13 (Fig. 4: 2/3)"),
    _P("alpha_0_1", "1", 2 / 75, 0.0, 10.0,
       "first harmonic of the excitation from f (phase reference), Eritenel and Parker "
       "Fig. 4: 2/75"),
    _P("alpha_0_2", "1", 0.0, 0.0, 10.0, "second harmonic of the excitation from f"),
    _P("phi_0_2", "rad", 0.0, -math.pi, math.pi, "phase of alpha_0_2"),
    _P("alpha_1_1", "1", 0.0, 0.0, 0.9, "first harmonic of the linear mesh stiffness"),
    _P("phi_1_1", "rad", 0.0, -math.pi, math.pi, "phase of alpha_1_1"),
    _P("alpha_1_2", "1", 0.0, 0.0, 0.9,
       "second harmonic of the linear mesh stiffness (principal parametric resonance)"),
    _P("phi_1_2", "rad", 0.0, -math.pi, math.pi, "phase of alpha_1_2"),
    _P("alpha_2_0", "1", 0.25, -10.0, 10.0, "quadratic stiffness, Eritenel and Parker Fig. 4: 1/4"),
    _P("alpha_2_1", "1", 0.0, 0.0, 10.0, "first harmonic of the quadratic stiffness"),
    _P("phi_2_1", "rad", 0.0, -math.pi, math.pi, "phase of alpha_2_1"),
    _P("alpha_3_0", "1", -1 / 24, -10.0, 10.0, "cubic stiffness, Eritenel and Parker "
       "Fig. 4: -1/24"),
    _P("e_1", "1", 0.1, 0.0, 0.99, "first harmonic of the unloaded deflection / d, Fig. 4: 0.1"),
    _P("psi_1", "rad", 0.0, -math.pi, math.pi, "phase of e_1, Eritenel and Parker Fig. 4: 0"),
    _P("e_2", "1", 0.0, 0.0, 0.99, "second harmonic of the unloaded deflection / d"),
    _P("psi_2", "rad", 0.0, -math.pi, math.pi, "phase of e_2"),
    _P("q_1", "1", 0.0, 0.0, 10.0, "first harmonic of the applied load / (k d)"),
    _P("rho_1", "rad", 0.0, -math.pi, math.pi, "phase of q_1"),
    _P("damping_ratio", "1", 0.0082, 0.0, 0.5, "damping ratio mu, Eritenel and Parker "
       "Fig. 4: 0.0082"),
    _P("frequency_ratio", "1", 1.0, 1e-3, 10.0,
       "mesh frequency / natural frequency Omega of the time response"),
)

_DIMENSIONAL_PARAMETERS = (
    _P("mass", "kg", 1.0, 1e-9, 1e9,
       "equivalent mass of the mesh, I_p I_g / (I_p r_g^2 + I_g r_p^2) (Eritenel and Parker)"),
    _P("damping_ratio", "1", 0.02, 0.0, 0.5, "damping ratio c / (2 m omega_n), "
       "Eritenel and Parker: 2-5 %"),
    _P("mean_force", "N", 1000.0, 1e-6, 1e9, "mean mesh force F_0 (torque / base radius)"),
    _P("load_harmonic", "N", 0.0, 0.0, 1e9,
       "first harmonic of the applied load at the mesh frequency F_1"),
    _P("load_phase", "rad", 0.0, -math.pi, math.pi, "phase R_1 of the load harmonic"),
    _P("frequency_ratio", "1", 1.0, 1e-3, 10.0,
       "mesh frequency / natural frequency Omega of the time response"),
)

_O = Output
_FREQ = ("sample", "frequency")
_BRANCH = ("sample", "frequency", "branch")
_COMMON_OUTPUTS = (
    _O("amplitude_up", "1", _FREQ, "fundamental amplitude a of the stable response reached "
       "by an upward frequency sweep (nondimensional, over d)"),
    _O("amplitude_down", "1", _FREQ, "fundamental amplitude a reached by a downward sweep"),
    _O("separation_up", "1", _FREQ, "fraction of the period out of contact, upward sweep"),
    _O("separation_down", "1", _FREQ, "fraction of the period out of contact, downward sweep"),
    _O("region_up", "1", _FREQ, "response region 1-4 of Eritenel and Parker Fig. 4, upward sweep"),
    _O("region_down", "1", _FREQ, "response region 1-4 of Eritenel and Parker Fig. 4, "
       "downward sweep"),
    _O("linear_amplitude", "1", _FREQ, "amplitude of the linear time-invariant response"),
    _O("branch_amplitude", "1", _BRANCH,
       "amplitude of every steady state (perturbation): lower, middle, upper branch"),
    _O("branch_phase", "rad", _BRANCH, "phase gamma of every steady state (perturbation)"),
    _O("branch_stable", "1", _BRANCH, "1 stable, 0 unstable (slow-flow Jacobian, Eq. 38)"),
    _O("n_branches", "1", _FREQ, "number of steady states at the frequency (perturbation)"),
    _O("peak_amplitude", "1", ("sample",), "largest stable amplitude over the frequency grid"),
    _O("peak_frequency_ratio", "1", ("sample",), "Omega of the largest stable amplitude"),
    _O("u", "1", ("sample", "time"), "nondimensional deflection u = (x - x_m) / d"),
    _O("contact", "1", ("sample", "time"), "1 in contact, 0 out of contact"),
    _O("kv", "1", ("sample",), "dynamic factor K_v: largest mesh force over the output "
       "instants t (after settling) over the static mesh force, the mean load (alpha_0_0, "
       "F_0); 1 without excitation and in the quasi-static limit"),
    _O("u_perturbation", "1", ("sample", "time"),
       "approximate solution (Eritenel and Parker Eq. 28) on the upward-sweep branch at "
       "frequency_ratio"),
)
_DIMENSIONAL_OUTPUTS = (
    _O("dte_amplitude_up", "m", _FREQ, "fundamental amplitude of the dynamic transmission "
       "error a d, upward sweep"),
    _O("dte_amplitude_down", "m", _FREQ, "fundamental DTE amplitude a d, downward sweep"),
    _O("peak_dte_amplitude", "m", ("sample",), "largest stable DTE amplitude over the grid"),
    _O("mean_deflection", "m", ("sample",), "mean deflection x_m under the mean load (Eq. 4)"),
    _O("deflection_scale", "m", ("sample",), "d = x_m - g_0 (Eq. 13)"),
    _O("natural_frequency", "rad s-1", ("sample",), "omega_n = sqrt(beta_10 / m)"),
    _O("mesh_stiffness", "N m-1", ("sample",), "mean tangent mesh stiffness beta_10"),
    _O("secant_stiffness", "N m-1", ("sample",), "mean load / d"),
    _O("expansion_error", "1", ("sample",),
       "largest |f - truncated Taylor-Fourier series| over the vibration window / F_0"),
    _O("alpha", "1", ("sample", "order", "harmonic"), "alpha_{i,r} (Eq. 13)"),
    _O("alpha_phase", "rad", ("sample", "order", "harmonic"), "phi_{i,r} (Eq. 14)"),
    _O("dte", "m", ("sample", "time"), "dynamic transmission error x(t)"),
    _O("mesh_force", "N", ("sample", "time"), "mesh force C f(x, t)"),
)
# amplitudes, fractions, counts, frequencies and stiffnesses: never negative
_COMMON_OUTPUTS = bounded_below(_COMMON_OUTPUTS, [
    "amplitude_up", "amplitude_down", "separation_up", "separation_down", "linear_amplitude",
    "branch_amplitude", "n_branches", "peak_amplitude", "peak_frequency_ratio", "kv"])
_DIMENSIONAL_OUTPUTS = bounded_below(_DIMENSIONAL_OUTPUTS, [
    "dte_amplitude_up", "dte_amplitude_down", "peak_dte_amplitude", "natural_frequency",
    "mesh_stiffness", "secant_stiffness", "expansion_error"])
_PERTURBATION_ONLY = {"branch_amplitude", "branch_phase", "branch_stable", "n_branches"}
_TIME_OUTPUTS = {"u", "contact", "u_perturbation", "dte", "mesh_force", "kv"}
_EXPANSION_OUTPUTS = {"mean_deflection", "deflection_scale", "natural_frequency",
                      "mesh_stiffness", "secant_stiffness", "expansion_error", "alpha",
                      "alpha_phase"}
BRANCHES = ("lower", "middle", "upper")

STATUS_CURVE = 16
STATUS_SEPARATION = 17
STATUS_FORCE_PEAK = 18
STATUS_UNSETTLED = 19
STATUS_KV_WINDOW = 20
STATUS_MEANINGS = {STATUS_CURVE: "perturbation_curve_incomplete",
                   STATUS_SEPARATION: "separation_beyond_validity",
                   STATUS_FORCE_PEAK: "deflection_beyond_force_maximum",
                   STATUS_UNSETTLED: "sweep_not_settled",
                   STATUS_KV_WINDOW: "kv_window_short"}
#: The reasons in words, written into the dataset attribute ``status_reasons`` for the codes
#: that occur.
STATUS_REASONS = {
    STATUS_FORCE_PEAK: "the response reaches deflections where the force-deflection function "
    "no longer increases (tangent stiffness <= 0, beyond its maximum): no steady state of "
    "this kind exists there and a time integration may escape; the numbers are kept",
    STATUS_UNSETTLED: "the transient cannot decay to settle_tolerance within "
    "max_settle_periods (no or very little damping): the measured amplitudes include it",
    STATUS_KV_WINDOW: "the output instants span less than one mesh period: kv is the "
    "largest mesh force over them, only a lower bound of the dynamic factor",
}


def _check_frequencies(value: Any) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim != 1 or arr.size < 1 or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ValueError("frequencies must be a 1-D array of finite values > 0")
    if np.any(np.diff(arr) <= 0):
        raise ValueError("frequencies must be strictly increasing")
    return arr


_OPTIONS = (
    Option("method", "perturbation", "frequency response by the multiple-scales solution or "
           "by numerical sweeps (time integration)", choices=("perturbation", "sweep")),
    Option("order", 2, "perturbation order: 1 (Eritenel and Parker Eq. 27) or 2 (Eq. 31)",
           choices=(1, 2)),
    Option("separation", "closed_form", "separation-function harmonics: closed form for one "
           "contact loss per period (Eqs. 34-35) or numerical (Eqs. 32-33)",
           choices=("closed_form", "numerical")),
    Option("frequency_min", 0.8, "lowest frequency of the grid", lower=1e-6),
    Option("frequency_max", 1.2, "highest frequency of the grid", lower=1e-6),
    Option("n_frequencies", 201, "number of grid frequencies (1: frequency_min alone, "
           "frequency_max unused; frequencies=[...] gives any grid)", lower=1, upper=100_000),
    Option("frequencies", None, "explicit increasing frequency grid (overrides min/max/n)",
           kind="any", allow_none=True, check=_check_frequencies),
    Option("frequency_units", "ratio", "grid in Omega = mesh frequency / omega_n or in Hz "
           "(mesh frequency; dimensional models only)", choices=("ratio", "Hz")),
    Option("taylor_order", 3, "Taylor order n of the expansion (Eq. 3)", lower=1, upper=8),
    Option("harmonics", 2, "Fourier harmonics p of the expansion (Eq. 5)", lower=1,
           upper=64),
    Option("expansion", "auto", "Taylor derivatives at x_m or least-squares fit over the "
           "vibration window ('auto': derivatives for smooth f)",
           choices=("auto", "taylor", "fit")),
    Option("fit_window", 1.0, "half-width of the fit and error window, in units of d",
           lower=0.05, upper=5.0),
    Option("time_model", "exact", "force integrated in time: the exact f or its truncated "
           "expansion (Eq. 11); the nondimensional model is always the expansion",
           choices=("exact", "expanded")),
    Option("time", "nondimensional", "unit of t: nondimensional T = omega_n t or seconds",
           choices=("nondimensional", "s")),
    Option("initial", "linear", "time response start: at rest at x_m or on the linear "
           "steady state", choices=("rest", "linear")),
    Option("settle_periods", None, "excitation periods discarded before t = 0 and at each "
           "sweep frequency (None: from the damping and settle_tolerance)", kind="int",
           lower=0, allow_none=True),
    Option("settle_tolerance", 1e-3, "decay of a unit transient wanted in the settle periods",
           lower=1e-12, upper=0.5),
    Option("max_settle_periods", 5000, "cap on the settle periods per sweep frequency (an "
           "undamped or nearly undamped sample would need millions); a sample whose transient "
           "cannot decay within it is flagged (status 19)", kind="int", lower=1,
           upper=10_000_000),
    Option("measure_periods", 4, "periods measured per sweep frequency", lower=1, upper=1000),
    Option("points_per_period", 32, "samples per measured period", lower=8, upper=4096),
    Option("rtol", 1e-8, "relative tolerance of the integrator", lower=1e-13, upper=0.1),
    Option("atol", 1e-10, "absolute tolerance of the integrator (nondimensional)",
           lower=0.0, upper=1.0),
    Option("ode_method", "dop853", "integration method", choices=("dopri5", "dop853")),
    Option("region_tolerance", 0.05, "relative change of the linear amplitude caused by the "
           "stiffness nonlinearity at the response amplitude (backbone shift) that separates "
           "region 1 from region 2", lower=0.0, upper=10.0),
    Option("onset_separation", 0.02, "largest fraction of the period out of contact still "
           "counted as the onset (region 3) rather than developed contact loss (region 4)",
           lower=0.0, upper=1.0),
    Option("max_separation", 0.5, "perturbation: a sweep path out of contact for more than "
           "this fraction of the period is flagged (status 17): the theory assumes short "
           "separations", lower=0.0, upper=1.0),
)


@dataclass
class System:
    """Nondimensional system of ``n`` samples (see :class:`expansion.Expansion`)."""

    alpha: np.ndarray
    phi: np.ndarray
    e: np.ndarray
    psi: np.ndarray
    q: np.ndarray
    rho: np.ndarray
    mu: np.ndarray
    q_exponent: float
    expansion: Any = None
    values: dict | None = None

    def coefficients(self) -> np.ndarray:
        """Perturbation coefficient rows."""
        from gearuq_plugins.mesh_oscillator.expansion import coefficient_rows

        return coefficient_rows(self.alpha, self.phi, self.e, self.psi, self.q, self.rho,
                                self.mu, self.q_exponent)


class MeshOscillator(Model):
    """SDOF gear-mesh oscillator with a general periodic force-deflection function.

    After Eritenel and Parker, "Nonlinear vibration of gears with tooth surface
    modifications", ASME Journal of Vibration and Acoustics.

    Parameters
    ----------
    force : ForceDeflection, optional
        Force-deflection function (:mod:`gearuq_plugins.mesh_oscillator.forces`); ``None``:
        the nondimensional model with Eritenel and Parker's coefficients as parameters.
    load_harmonic_scaling : {"constant", "frequency_squared"}
        The load harmonic has a constant amplitude, or one proportional to ``Omega^2``
        (inertial forcing, e.g. a transmission-error excitation seen in relative
        coordinates).
    nominal : dict, optional
        Nominal values replacing the defaults (e.g. ``{"mass": 0.4, "mean_force": 5e3}``).
    stage : GearStage, optional
        Build the dimensional model from a stage instead of ``force``: the force-deflection
        function is the stage's LTCA over one mesh cycle (every relief shape, per gear) on a
        load grid over its torque range, the nominal mass the gear bodies' equivalent mass
        and the nominal mean force the design torque's (``nominal`` still overrides);
        docs/stage.md.
    """

    name = "mesh_oscillator"
    description = ("SDOF gear mesh with a general force-deflection function: multiple-scales "
                   "and numerical frequency response, contact loss, stability (after Eritenel "
                   "and Parker)")
    version = "1.0"
    time_units = "1"
    time_long_name = "nondimensional time T = omega_n t"
    options = _OPTIONS
    #: the perturbation runs sample blocks in threads and the sweeps use the threaded
    #: integrator: engines evaluate serially by default
    internally_parallel = True

    def __init__(self, force: Any = None, *, load_harmonic_scaling: str = "constant",
                 nominal: Mapping[str, float] | None = None, stage: Any = None) -> None:
        from gearuq_plugins.mesh_oscillator.forces import ForceDeflection

        self.stage = stage
        if stage is not None:
            from gearuq.gears.stage import GearStage
            from gearuq_plugins.mesh_oscillator.stage import stage_force, stage_nominal

            if not isinstance(stage, GearStage):
                raise TypeError(f"stage={stage!r} must be a gearuq.GearStage")
            if force is not None:
                raise ValueError("give force= or stage=, not both (the stage's LTCA gives "
                                 "the force-deflection function)")
            force = stage_force(stage)
            nominal = stage_nominal(stage) | dict(nominal or {})

        if force is not None and not isinstance(force, ForceDeflection):
            raise ValueError(f"force: expected a ForceDeflection or None, got "
                             f"{type(force).__name__}")
        if load_harmonic_scaling not in ("constant", "frequency_squared"):
            raise ValueError(f"load_harmonic_scaling={load_harmonic_scaling!r}: valid "
                             "'constant', 'frequency_squared'")
        self.force = force
        self.load_harmonic_scaling = load_harmonic_scaling
        params = _NONDIMENSIONAL_PARAMETERS if force is None else (
            _DIMENSIONAL_PARAMETERS + tuple(force.parameters))
        nominal = dict(nominal or {})
        unknown = sorted(set(nominal) - {p.name for p in params})
        if unknown:
            raise ValueError(f"nominal: unknown parameter(s) {unknown}; valid: "
                             f"{[p.name for p in params]}")
        self.parameters = tuple(
            Parameter(p.name, p.units, float(nominal[p.name]), p.lower, p.upper,
                      p.description, p.integer) if p.name in nominal else p for p in params)
        self.outputs = _COMMON_OUTPUTS + (() if force is None else _DIMENSIONAL_OUTPUTS)

    @property
    def dimensional(self) -> bool:
        """Whether the model has a dimensional force-deflection function."""
        return self.force is not None

    def precompile(self, verbose: bool = False) -> float:
        """Compile (or load from the numba cache) every kernel a call can use; seconds.

        The perturbation (continuation and slow flow, first and second order, closed-form
        and numerical separation: one compiled signature), the right-hand sides and
        switching functions of the three time-domain kernels (expanded, contact segments,
        load-deflection table) with the integrator variants a call can choose (DOP853 and
        DOPRI5, frozen sides) are compiled on their first use and cached on disk; from an
        empty cache that costs minutes on a loaded machine. Run this once after installing
        so that no later first call pays it. ``verbose`` prints each item with its time.
        """
        import time

        from gearuq_plugins.mesh_oscillator.forces import LoadDeflectionTable, SegmentForce

        phase = np.arange(8) / 8.0
        loads = np.array([1.0, 2.0, 4.0])
        table = LoadDeflectionTable(loads, phase, np.broadcast_to(
            (loads / 100.0)[:, None], (3, 8)).copy(), np.zeros(8))
        opts = {"n_frequencies": 3, "frequency_min": 0.9, "frequency_max": 1.1,
                "settle_periods": 1, "measure_periods": 1}
        items = [("perturbation and approximate solution", MeshOscillator(),
                  {"method": "perturbation", "outputs": ["amplitude_up", "u_perturbation"]})]
        for kind, model in (("expanded", MeshOscillator()),
                            ("segments", MeshOscillator(SegmentForce.linear(100.0))),
                            ("table", MeshOscillator(table))):
            for ode in ("dop853", "dopri5"):
                items.append((f"sweep {kind} kernel, {ode}", model,
                              {"method": "sweep", "ode_method": ode, **opts}))
        start = time.perf_counter()
        for label, model, options in items:
            t0 = time.perf_counter()
            nominal = {"mean_force": 2.0, "mass": 1.0} if model.dimensional else {}
            outputs = options.pop("outputs", ["amplitude_up"])
            with kernels_route("compiled"):  # small calls would otherwise run interpreted
                model.response(nominal, [0.0, 1.0], outputs=outputs, **options)
            if verbose:
                print(f"mesh_oscillator: {label}: {time.perf_counter() - t0:.1f} s",
                      flush=True)
        return time.perf_counter() - start

    def settings(self) -> dict[str, Any]:
        """Construction options (provenance)."""
        out = {"force": None if self.force is None else self.force.describe(),
               "load_harmonic_scaling": self.load_harmonic_scaling}
        if getattr(self, "stage", None) is not None:
            out["stage"] = self.stage.to_dict()
        return out

    def check_option_combination(self, options):
        """The frequency grid's ends must not cross (checked before any run, not per sample)."""
        lo, hi, k = options["frequency_min"], options["frequency_max"], options["n_frequencies"]
        if options["frequencies"] is None and k > 1 and not hi > lo:
            raise ValueError(f"model {self.name!r}: frequency_max={hi!r} must exceed "
                             f"frequency_min={lo!r} (n_frequencies={k})")

    def default_space(self):
        """Random damping, mean load (torque) and, for families, the modification: uniform
        +-30 % damping, normal mean load with 10 % CoV, uniform modification over its range
        (a documented example for reliability studies, not a measured scatter)."""
        import chaospy as cp

        from gearuq.space import ParameterSpace

        nominal = self.nominal()
        zeta = nominal["damping_ratio"]
        marg = {"damping_ratio": cp.Uniform(0.7 * zeta, 1.3 * zeta)}
        if self.dimensional:
            marg["mean_force"] = cp.TruncNormal(0.5 * nominal["mean_force"],
                                                1.5 * nominal["mean_force"],
                                                nominal["mean_force"],
                                                0.1 * nominal["mean_force"])
            for p in self.force.parameters:
                marg[p.name] = cp.Uniform(p.lower, p.upper)
        else:
            marg["alpha_0_1"] = cp.Uniform(0.7 * nominal["alpha_0_1"],
                                           1.3 * nominal["alpha_0_1"])
        return ParameterSpace(marg)

    def _time_attrs(self, options):
        if options.get("time") == "s":
            return {"units": "s", "long_name": "time t"}
        return {"units": "1", "long_name": self.time_long_name}

    # ------------------------------------------------------------------ evaluation
    def system(self, params: Mapping[str, np.ndarray], options: Mapping[str, Any]) -> System:
        """Nondimensional system of validated parameters (expansion for dimensional models)."""
        from gearuq_plugins.mesh_oscillator.expansion import expand

        q_exp = 2.0 if self.load_harmonic_scaling == "frequency_squared" else 0.0
        n = next(iter(params.values())).shape[0]
        if self.force is None:
            alpha = np.zeros((n, 4, 3))
            phi = np.zeros((n, 4, 3))
            alpha[:, 1, 0] = 1.0
            for i, r in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 0), (2, 1), (3, 0)):
                alpha[:, i, r] = params[f"alpha_{i}_{r}"]
                if r > 0 and f"phi_{i}_{r}" in params:
                    phi[:, i, r] = params[f"phi_{i}_{r}"]
            e = np.stack([params["e_1"], params["e_2"]], axis=1)
            psi = np.stack([params["psi_1"], params["psi_2"]], axis=1)
            return System(alpha, phi, e, psi, params["q_1"][:, None], params["rho_1"][:, None],
                          params["damping_ratio"], q_exp)
        values = {p.name: params[p.name] for p in self.force.parameters}
        ex = expand(self.force, mass=params["mass"], mean_force=params["mean_force"],
                    damping_ratio=params["damping_ratio"],
                    load_harmonic=params["load_harmonic"], load_phase=params["load_phase"],
                    order=options["taylor_order"], harmonics=options["harmonics"],
                    method=options["expansion"], window=options["fit_window"],
                    values=values or None)
        return System(ex.alpha, ex.phi, ex.e, ex.psi, ex.q, ex.rho, ex.mu, q_exp, ex,
                      values or None)

    def _evaluate(self, params, t, outputs, **options):
        from gearuq_plugins.mesh_oscillator import evaluate

        return evaluate.evaluate(self, params, t, outputs, options)
