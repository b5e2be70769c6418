"""``helical_pair``: lumped 10-DOF bend-twist-axial-swing helical gear pair (Li, Hu and Han).

Each gear has five DOFs: radial x (along the line of centres), tangential y, axial z, swing
(rocking about the tangential axis y) and torsion about its axis z. The mesh is a single
spring-damper along the normal line of action through the pitch point, with time-varying
stiffness (Li, Hu and Han's cosine form or Fourier series), static transmission error excitation
and a half-backlash dead zone; supports are spring-dampers with bearing-clearance dead zones.
Equations, nondimensionalisation, parameter sources and every deviation from Li, Hu and Han are in
docs/theory/helical_pair.md.

Modules, in the order data flows through them: ``physics`` (set-up: geometry, coefficients,
static states; and the NumPy twin of the equations), ``simulate`` (integration through
``gearuq.ode``), ``outputs`` (declarations and values of the outputs); ``kernel`` holds the
compiled right-hand side and ``layout`` the coefficient layout they share.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gearuq.model import Model, Option, Parameter
from gearuq_plugins.helical_pair.outputs import DOFS, OUTPUTS, STATUS_MEANINGS

__all__ = ["HelicalPair", "DOFS", "SEED_TABLE2"]

#: Li, Hu and Han Table 2: (mean, standard deviation) of the normal random parameters.
SEED_TABLE2 = {
    "B1": (7e-2, 1e-3 / 3),
    "B2": (7e-2, 1e-3 / 3),
    "b5": (2e-5, 1e-8 / 3),
    "rho": (7.85e3, 1.0 / 3),
    "s": (0.1, 1e-3 / 3),
    "n": (4000.0, 1.0 / 3),
}

_P = Parameter
_PARAMETERS = (
    _P("z1", "1", 34, 8, 200, "pinion (driving) teeth, Li, Hu and Han Table 1", integer=True),
    _P("z2", "1", 84, 8, 400, "gear (driven) teeth, Li, Hu and Han Table 1", integer=True),
    _P("m_n", "m", 6e-3, 5e-4, 5e-2, "normal module, Li, Hu and Han Table 1"),
    _P("beta", "degree", 17.0, 0.0, 40.0, "helix angle, Li, Hu and Han Table 1"),
    _P("alpha_n", "degree", 25.0, 14.0, 30.0, "normal pressure angle, Li, Hu and Han Table 1"),
    _P("x_shift_p", "1", 0.0, -0.5, 1.0, "pinion profile shift coefficient"),
    _P("x_shift_g", "1", 0.0, -0.5, 1.0, "gear profile shift coefficient"),
    _P("B1", "m", 7e-2, 5e-3, 0.5, "pinion face width, Li, Hu and Han Tables 1-2"),
    _P("B2", "m", 7e-2, 5e-3, 0.5, "gear face width, Li, Hu and Han Tables 1-2"),
    _P("rho", "kg m-3", 7.85e3, 1.0e3, 2.0e4, "material density, Li, Hu and Han Table 2"),
    _P("s", "1", 0.1, 0.0, 0.9, "mesh stiffness variation coefficient, Li, Hu and Han Eq. 11 / "
       "Table 2"),
    _P("n", "rpm", 4000.0, 1.0, 3.0e4, "pinion speed, Li, Hu and Han Table 2 (Fig. 4: 3600)"),
    _P("T", "N m", 2600.0, 0.0, 1.0e6, "pinion input torque, Li, Hu and Han Fig. 4"),
    _P("b5", "m", 2e-5, 0.0, 1e-3, "half backlash on the mesh, Li, Hu and Han Table 2"),
    _P("b1", "m", 5.35e-5, 0.0, 1e-3, "pinion radial half clearance (Table 1: 0.107 mm / 2)"),
    _P("b2", "m", 3.75e-5, 0.0, 1e-3, "gear radial half clearance (Table 1: 0.075 mm / 2)"),
    _P("b3", "m", 7.4e-5, 0.0, 1e-3, "pinion axial half clearance (Table 1: 0.148 mm / 2)"),
    _P("b4", "m", 0.0, 0.0, 1e-3, "gear axial half clearance (Table 1: 0)"),
    _P("k_r", "N m-1", 5.968e6, 1e4, 1e13, "radial support stiffness per gear, Li, Hu and "
       "Han Table 1"),
    _P("k_a", "N m-1", 5.968e6, 1e4, 1e13, "axial support stiffness per gear, Li, Hu and "
       "Han Table 1"),
    _P("span", "m", 0.1, 1e-3, 2.0, "bearing distance from gear centre (both sides; ours)"),
    _P("zeta_m", "1", 0.08, 0.0, 0.5, "mesh damping ratio, Li, Hu and Han Table 1 "
       "(range 0.03-0.17)"),
    _P("zeta_s", "1", 0.05, 0.0, 0.5, "support damping ratio (ours; not in Li, Hu and Han)"),
    _P("e_0", "m", 0.0, -1e-3, 1e-3, "constant static error e_0, Li, Hu and Han: 0"),
    _P("e_a", "m", 1.08e-5, 0.0, 2e-4, "static error amplitude (Li, Hu and Han's '108 um' "
       "read as 10.8 um)"),
    _P("phi", "rad", 0.0, -2 * math.pi, 2 * math.pi, "static error phase"),
    _P("C_R", "1", 1.0, 0.1, 1.0, "ISO 6336-1 gear blank factor (1: solid)"),
)


def _check_length_scale(value: Any) -> float | str:
    """Valid values of the option ``length_scale``: a length > 0 in m, or "b5"."""
    if isinstance(value, str):
        if value != "b5":
            raise ValueError("a string must be 'b5' (each sample's half backlash)")
        return value
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ValueError("expected a length in m or 'b5'")
    if not (math.isfinite(value) and value > 0):
        raise ValueError("a length must be finite and > 0 m")
    return float(value)


_O = Option
_OPTIONS = (
    _O("time", "tau", "unit of t: nondimensional tau = omega_n t (as Li, Hu and Han) or seconds",
       choices=("tau", "s")),
    _O("method", "dop853", "Runge-Kutta method of the batched integrator",
       choices=("dopri5", "dop853", "rk4")),
    _O("rtol", 1e-6, "relative tolerance of the step control", lower=1e-13, upper=0.1),
    _O("atol", 1e-8, "absolute tolerance of the states in units of 10 um (1e-8: 0.1 pm)",
       lower=0.0, upper=1.0),
    _O("max_step", math.inf, "largest step in tau (inf: no bound)", lower=1e-9),
    _O("max_steps", 2_000_000, "step attempts per sample before status step_limit_reached",
       lower=1),
    _O("fixed_step", None, "fixed step in tau without error control (None: adaptive)",
       kind="float", lower=1e-9, allow_none=True),
    _O("events", True, "locate every dead-zone switching instant (else step across kinks)"),
    _O("freeze_sides", True, "with events: each step stays on one branch of the dead zones"),
    _O("initial", "static", "initial state: static equilibrium or rest at zero",
       choices=("static", "zero")),
    _O("parallel", True, "run sample blocks in threads (bit-identical to serial)"),
    _O("mesh_damping", "always",
       "'always': c_m delta' acts also across the open backlash (seed); 'in_contact': no mesh "
       "force in the gap, flank force clipped to compression", choices=("always", "in_contact")),
    _O("length_scale", 1e-5,
       "unit L of p, dp, v: a length in m, or 'b5' (each sample's half backlash, as "
       "Li, Hu and Han; "
       "b5 = 0 is flagged)", kind="any", units="m", check=_check_length_scale),
)

_SOLVER_OPTIONS = ("method", "rtol", "atol", "max_step", "max_steps", "fixed_step", "events",
                   "freeze_sides", "initial", "parallel")


class HelicalPair(Model):
    """Lumped 10-DOF helical gear pair with backlash, bearing clearances and TVMS.

    Parameters
    ----------
    stiffness_harmonics : sequence of (a_n, b_n), optional
        Fourier coefficients of k(t)/k_m (Li, Hu and Han Eq. 6); when given they replace the
        paper's ``1 + s cos(omega tau)`` and ``s`` is ignored.
    use_virtual_teeth : bool
        ISO 6336 q' with virtual numbers of teeth (standard, default) or with z as Li, Hu and Han
        prints it.
    stage : GearStage or None
        Build from a stage (docs/stage.md): the nominal geometry, face widths, density,
        design torque and speed, half backlash, bearing clearances and lumped supports come
        from it, and the mesh stiffness is the stage's one (:func:`gearuq.gears.stage.
        stage_mesh_stiffness`), applied as its ratio to ISO 6336-1 at the nominal geometry
        so that sampled geometry still moves it. Shafts that differ add the parameters
        ``k_r_wheel``, ``k_a_wheel``, ``span_wheel``.

    Notes
    -----
    The unit of the nondimensional outputs is the option ``length_scale`` (per call), not a
    constructor setting: it changes what p, dp and v are measured in, not the physics or the
    integration (which always runs in units of 10 um), so one model instance answers both
    scalings and the execution layer fingerprints it with the other options.
    """

    name = "helical_pair"
    description = ("lumped 10-DOF helical gear pair with backlash, clearances, TVMS (after Li, Hu "
                   "and Han)")
    version = "1.1"
    time_units = "1"
    time_long_name = "nondimensional time tau = omega_n t"
    internally_parallel = True  # the batched integrator runs sample blocks in threads
    parameters = _PARAMETERS
    outputs = OUTPUTS
    options = _OPTIONS

    def __init__(self, stiffness_harmonics: Any = None, use_virtual_teeth: bool = True, *,
                 stage: Any = None) -> None:
        from gearuq_plugins.helical_pair.layout import MAX_HARMONICS

        harm = np.zeros((0, 2)) if stiffness_harmonics is None else np.asarray(
            stiffness_harmonics, dtype=float).reshape(-1, 2)
        if harm.shape[0] > MAX_HARMONICS:
            raise ValueError(f"stiffness_harmonics: at most {MAX_HARMONICS} harmonics, "
                             f"got {harm.shape[0]}")
        if not np.all(np.isfinite(harm)):
            raise ValueError("stiffness_harmonics: non-finite coefficient")
        if harm.size and np.abs(harm).sum() >= 1.0:
            raise ValueError("stiffness_harmonics: sum of |a_n| + |b_n| must be < 1 so that the "
                             f"mesh stiffness stays positive, got {np.abs(harm).sum():g}")
        self.stiffness_harmonics = harm
        self.use_virtual_teeth = bool(use_virtual_teeth)
        self.stage = stage
        self.stiffness_factor = 1.0
        if stage is not None:
            from gearuq_plugins.helical_pair.stage import from_stage

            self.parameters, self.stiffness_factor = from_stage(
                stage, _PARAMETERS, use_virtual_teeth=self.use_virtual_teeth)

    def settings(self) -> dict[str, Any]:
        """Construction options (recorded as provenance)."""
        out = {
            "stiffness_harmonics": self.stiffness_harmonics.tolist(),
            "use_virtual_teeth": self.use_virtual_teeth,
        }
        if self.stage is not None:
            out |= {"stage": self.stage.to_dict(), "stiffness_factor": self.stiffness_factor}
        return out

    def default_space(self):
        """Li, Hu and Han Table 2: six independent normal parameters (B1, B2, b5, rho, s, n).

        Built from a stage, the same six normals are centred on the stage's nominals, each
        with Table 2's coefficient of variation (an example scatter, not a measured one): the
        paper's 70 mm face widths and 4000 rpm are not the stage's.
        """
        import chaospy as cp

        from gearuq.space import ParameterSpace

        if self.stage is None:
            return ParameterSpace({k: cp.Normal(mu, sd) for k, (mu, sd) in SEED_TABLE2.items()})
        nominal = {p.name: p.nominal for p in self.parameters}
        return ParameterSpace({k: cp.Normal(nominal[k], sd / mu * abs(nominal[k]))
                               for k, (mu, sd) in SEED_TABLE2.items()})

    # ------------------------------------------------------------------ physics set-up
    def system(self, params: dict[str, np.ndarray], *, mesh_damping: str = "always"):
        """Set-up of validated parameter samples: a ``physics.PairSystem``."""
        from gearuq_plugins.helical_pair.physics import build_system

        if mesh_damping not in ("always", "in_contact"):
            raise ValueError(f"mesh_damping: {mesh_damping!r} is not 'always' or 'in_contact'")
        return build_system(params, harmonics=self.stiffness_harmonics,
                            use_virtual_teeth=self.use_virtual_teeth,
                            gated=mesh_damping == "in_contact",
                            stiffness_factor=self.stiffness_factor)

    def gear_data(self, params: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Geometry, masses, inertias and ISO 6336 mesh stiffness per sample (SI)."""
        from gearuq_plugins.helical_pair.physics import gear_data

        return gear_data(params, use_virtual_teeth=self.use_virtual_teeth,
                         stiffness_factor=self.stiffness_factor)

    def coefficients(self, params: dict[str, np.ndarray], *,
                     mesh_damping: str = "always") -> tuple[np.ndarray, dict]:
        """Per-sample nondimensional coefficient vectors of the kernel and the SI data."""
        system = self.system(params, mesh_damping=mesh_damping)
        return system.coef, system.gear

    @staticmethod
    def initial_state(coef: np.ndarray, kind: str = "static") -> np.ndarray:
        """Initial states: static equilibrium at tau = 0 ("static") or rest at zero ("zero")."""
        from gearuq_plugins.helical_pair.physics import initial_state

        return initial_state(coef, kind)

    @staticmethod
    def static_state(coef: np.ndarray) -> np.ndarray:
        """Each sample's static equilibrium q (n, 10): mean stiffness, constant error e_0."""
        from gearuq_plugins.helical_pair.physics import static_state

        return static_state(coef)

    def ode_problem(self, params: dict | None = None, *, initial: str = "static",
                    mesh_damping: str = "always") -> dict:
        """The raw first-order problem, for benchmarks and external solvers.

        Returns
        -------
        dict
            ``rhs`` and ``switch`` (numba functions ``f(tau, y, p, out)``), ``n_switch``,
            ``rhs_numpy`` (the same equations in plain NumPy, ``f(tau, y, p) -> dy``),
            ``rhs_sides`` (the rhs for ``solve_batch(..., freeze_sides=True)``),
            ``y0`` (n, 20) initial states, ``coef`` (n, N_COEF) per-sample coefficients and
            ``state_names`` (p1..p10, dp1..dp10). Time is nondimensional tau, lengths in
            units of 10 um.
        """
        from gearuq_plugins.helical_pair import kernel
        from gearuq_plugins.helical_pair.layout import N_SWITCH, N_SWITCH_GATED
        from gearuq_plugins.helical_pair.physics import rhs_numpy

        coef, _ = self.coefficients(self.validate_params(params), mesh_damping=mesh_damping)
        return {
            "rhs": kernel.rhs, "switch": kernel.switch, "rhs_sides": kernel.rhs_sides,
            "n_switch": N_SWITCH_GATED if mesh_damping == "in_contact" else N_SWITCH,
            "rhs_numpy": rhs_numpy,
            "y0": self.initial_state(coef, initial), "coef": coef,
            "state_names": [f"p{i + 1}" for i in range(10)] + [f"dp{i + 1}" for i in range(10)],
        }

    def precompile(self) -> float:
        """Compile (or load from the numba cache) what a default call needs; returns seconds.

        The compiled right-hand side, switching functions and the integrator variant of the
        default options (DOP853, frozen sides) are built on their first use and cached on
        disk: from an empty cache that costs seconds (docs/benchmarks.md, ``gearuq bench
        startup``). Run this once after installing so that no later first call pays it.
        """
        import time

        from gearuq._firstcall import kernels_route

        start = time.perf_counter()
        with kernels_route("compiled"):  # a small call would otherwise run interpreted
            self.response({}, [0.0, 1.0], outputs=["p1"])
        return time.perf_counter() - start

    def _time_attrs(self, options):
        if options.get("time", "tau") == "s":
            return {"units": "s", "long_name": "time t"}
        return {"units": "1", "long_name": self.time_long_name}

    def _evaluate(self, params, t, outputs, **options):
        """Set-up -> integration (only if a state is needed) -> outputs.

        Repeated instants in ``t`` (allowed, as by every model: ``t`` need only be
        non-decreasing) are integrated once; their columns are copies. The integrator needs
        strictly increasing output instants, and every output is a pointwise function of the
        state at its instant, so the copies are exact.
        """
        distinct, where = np.unique(t, return_inverse=True)
        if distinct.size < t.size:
            ev = self._evaluate(params, distinct, outputs, **options)
            return _repeat_instants(ev, where.ravel(),
                                    {o: self.output(o).dims for o in outputs})
        from gearuq.model import Evaluation
        from gearuq_plugins.helical_pair.outputs import assemble, describe_scale, needed_states
        from gearuq_plugins.helical_pair.simulate import integrate

        system = self.system(params, mesh_damping=options["mesh_damping"])
        n = system.n_samples
        save = needed_states(outputs)
        attrs = {"time_axis": options["time"], "initial_state": options["initial"],
                 "mesh_damping": options["mesh_damping"], **describe_scale(
                     options["length_scale"])}
        tau, states, extra = None, None, {}
        status = np.zeros(n, dtype=np.int8)
        if save.size:
            if t[0] < 0:
                raise ValueError(f"t: instants must be >= 0 (start of the run), got {t[0]}")
            tau = t[None, :] * system.gear["omega_n"][:, None] if options["time"] == "s" else t
            traj = integrate(system, tau, save, **{k: options[k] for k in _SOLVER_OPTIONS})
            states, status, extra = traj.states, traj.status, traj.extra
            attrs.update(traj.attrs)
        data, status = assemble(system, outputs, states=states, save=save, tau=tau,
                                length_scale=options["length_scale"], status=status)
        return Evaluation(data=data, status=status, status_meanings=dict(STATUS_MEANINGS),
                          attrs=attrs, extra=extra)


def _repeat_instants(ev: Any, where: np.ndarray, dims: dict[str, tuple[str, ...]]) -> Any:
    """``ev`` computed at distinct instants, expanded to the requested ones (``where``: the
    distinct instant of each requested one) along every ``time`` axis."""

    def expand(d: Any, values: Any) -> Any:
        d = (d,) if isinstance(d, str) else tuple(d)
        return np.take(values, where, axis=d.index("time")) if "time" in d else values

    ev.data = {k: expand(dims.get(k, ()), v) for k, v in ev.data.items()}
    ev.extra = {k: (d, expand(d, v), a) for k, (d, v, a) in ev.extra.items()}
    ev.coords = {k: (d, expand(d, v), a) for k, (d, v, a) in ev.coords.items()}
    return ev
