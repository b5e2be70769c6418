"""``helical_pair``: lumped 10-DOF bend-twist-axial-swing helical gear pair (seed 000).

Each gear has five DOFs: radial x (along the line of centres), tangential y, axial z, swing
(rocking about the tangential axis y) and torsion about its axis z. The mesh is a single
spring-damper along the normal line of action through the pitch point, with time-varying
stiffness (seed cosine form or Fourier series), static transmission error excitation and a
half-backlash dead zone; supports are spring-dampers with bearing-clearance dead zones.
Equations, nondimensionalisation, parameter sources and every deviation from the seed are in
docs/theory/helical_pair.md.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gearuq.model import Model, Option, Output, Parameter

__all__ = ["HelicalPair", "DOFS", "SEED_TABLE2"]

#: DOF names in state order: (symbol, SI unit, meaning)
DOFS = (
    ("x_p", "m", "pinion radial displacement (along the line of centres)"),
    ("y_p", "m", "pinion tangential displacement"),
    ("z_p", "m", "pinion axial displacement"),
    ("theta_py", "rad", "pinion swing (rocking about the tangential axis)"),
    ("theta_pz", "rad", "pinion torsional vibration angle"),
    ("x_g", "m", "gear radial displacement"),
    ("y_g", "m", "gear tangential displacement"),
    ("z_g", "m", "gear axial displacement"),
    ("theta_gy", "rad", "gear swing (rocking about the tangential axis)"),
    ("theta_gz", "rad", "gear torsional vibration angle (positive in the driven sense)"),
)
_ROT = {3, 4, 8, 9}
_PINION_ROT = {3, 4}

#: Seed 000 Table 2: (mean, standard deviation) of the normal random parameters.
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
    _P("z1", "1", 34, 8, 200, "pinion (driving) teeth, seed Table 1", integer=True),
    _P("z2", "1", 84, 8, 400, "gear (driven) teeth, seed Table 1", integer=True),
    _P("m_n", "m", 6e-3, 5e-4, 5e-2, "normal module, seed Table 1"),
    _P("beta", "degree", 17.0, 0.0, 40.0, "helix angle, seed Table 1"),
    _P("alpha_n", "degree", 25.0, 14.0, 30.0, "normal pressure angle, seed Table 1"),
    _P("x_shift_p", "1", 0.0, -0.5, 1.0, "pinion profile shift coefficient"),
    _P("x_shift_g", "1", 0.0, -0.5, 1.0, "gear profile shift coefficient"),
    _P("B1", "m", 7e-2, 5e-3, 0.5, "pinion face width, seed Tables 1-2"),
    _P("B2", "m", 7e-2, 5e-3, 0.5, "gear face width, seed Tables 1-2"),
    _P("rho", "kg m-3", 7.85e3, 1.0e3, 2.0e4, "material density, seed Table 2"),
    _P("s", "1", 0.1, 0.0, 0.9, "mesh stiffness variation coefficient, seed Eq. 11 / Table 2"),
    _P("n", "rpm", 4000.0, 1.0, 3.0e4, "pinion speed, seed Table 2 (Fig. 4: 3600)"),
    _P("T", "N m", 2600.0, 0.0, 1.0e6, "pinion input torque, seed Fig. 4"),
    _P("b5", "m", 2e-5, 0.0, 1e-3, "half backlash on the mesh, seed Table 2"),
    _P("b1", "m", 5.35e-5, 0.0, 1e-3, "pinion radial half clearance (Table 1: 0.107 mm / 2)"),
    _P("b2", "m", 3.75e-5, 0.0, 1e-3, "gear radial half clearance (Table 1: 0.075 mm / 2)"),
    _P("b3", "m", 7.4e-5, 0.0, 1e-3, "pinion axial half clearance (Table 1: 0.148 mm / 2)"),
    _P("b4", "m", 0.0, 0.0, 1e-3, "gear axial half clearance (Table 1: 0)"),
    _P("k_r", "N m-1", 5.968e6, 1e4, 1e13, "radial support stiffness per gear, seed Table 1"),
    _P("k_a", "N m-1", 5.968e6, 1e4, 1e13, "axial support stiffness per gear, seed Table 1"),
    _P("span", "m", 0.1, 1e-3, 2.0, "bearing distance from gear centre (both sides; ours)"),
    _P("zeta_m", "1", 0.08, 0.0, 0.5, "mesh damping ratio, seed Table 1 (range 0.03-0.17)"),
    _P("zeta_s", "1", 0.05, 0.0, 0.5, "support damping ratio (ours; not in the seed)"),
    _P("e_0", "m", 0.0, -1e-3, 1e-3, "constant static error e_0, seed: 0"),
    _P("e_a", "m", 1.08e-5, 0.0, 2e-4, "static error amplitude (seed '108 um' read as 10.8 um)"),
    _P("phi", "rad", 0.0, -2 * math.pi, 2 * math.pi, "static error phase"),
    _P("C_R", "1", 1.0, 0.1, 1.0, "ISO 6336-1 gear blank factor (1: solid)"),
)


_O = Option
_OPTIONS = (
    _O("time", "tau", "unit of t: nondimensional tau = omega_n t (as the seed) or seconds",
       choices=("tau", "s")),
    _O("method", "dop853", "Runge-Kutta method of the batched integrator",
       choices=("dopri5", "dop853", "rk4")),
    _O("rtol", 1e-6, "relative tolerance of the step control", lower=1e-13, upper=0.1),
    _O("atol", 1e-8, "absolute tolerance (nondimensional states)", lower=0.0, upper=1.0),
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
)


def _outputs() -> tuple[Output, ...]:
    outs = []
    for i, (_, _, meaning) in enumerate(DOFS):
        outs.append(Output(f"p{i + 1}", "1", ("sample", "time"),
                           f"nondimensional {meaning} (seed p{i + 1})"))
    for i in range(len(DOFS)):
        outs.append(Output(f"dp{i + 1}", "1", ("sample", "time"),
                           f"nondimensional velocity d p{i + 1} / d tau"))
    for name, unit, meaning in DOFS:
        outs.append(Output(name, unit, ("sample", "time"), meaning))
    for name, unit, meaning in DOFS:
        outs.append(Output(f"{name}_dot", f"{unit} s-1", ("sample", "time"), f"rate of {meaning}"))
    outs += [
        Output("mesh_force", "N", ("sample", "time"),
               "dynamic mesh force along the normal line of action (k f(delta) + c delta')"),
        Output("dte", "m", ("sample", "time"),
               "dynamic transmission error: relative normal displacement of the contact points"),
        Output("mesh_deflection", "m", ("sample", "time"),
               "mesh deflection delta = dte - e(t) (contact when |delta| > b5)"),
        Output("omega_n", "rad s-1", ("sample",), "time scale sqrt(k_m / m_e)"),
        Output("mesh_frequency", "Hz", ("sample",), "mesh frequency z1 n / 60"),
        Output("k_mesh", "N m-1", ("sample",), "mean mesh stiffness (ISO 6336-1 method B)"),
        Output("contact_ratio", "1", ("sample",), "transverse contact ratio epsilon_alpha"),
        Output("m_p", "kg", ("sample",), "pinion mass (solid cylinder blank)"),
        Output("m_g", "kg", ("sample",), "gear mass (solid cylinder blank)"),
    ]
    return tuple(outs)


_STATE_OUTPUTS = {f"p{i + 1}": i for i in range(10)} | {f"dp{i + 1}": 10 + i for i in range(10)}
for _i, (_name, _, _) in enumerate(DOFS):
    _STATE_OUTPUTS[_name] = _i
    _STATE_OUTPUTS[f"{_name}_dot"] = 10 + _i
_MESH_OUTPUTS = ("mesh_force", "dte", "mesh_deflection")


class HelicalPair(Model):
    """Lumped 10-DOF helical gear pair with backlash, bearing clearances and TVMS.

    Parameters
    ----------
    length_scale : float
        Length L [m] of the nondimensional displacements p_i = u_i / L (default 1e-5 m, the
        order of the half backlash; fixed so that p is comparable across samples and b5 = 0
        is allowed).
    stiffness_harmonics : sequence of (a_n, b_n), optional
        Fourier coefficients of k(t)/k_m (seed Eq. 6); when given they replace the seed's
        ``1 + s cos(omega tau)`` and ``s`` is ignored.
    use_virtual_teeth : bool
        ISO 6336 q' with virtual numbers of teeth (standard, default) or with z as the seed
        prints it.
    """

    name = "helical_pair"
    description = "lumped 10-DOF helical gear pair with backlash, clearances, TVMS (seed 000)"
    version = "1.0"
    time_units = "1"
    time_long_name = "nondimensional time tau = omega_n t"
    internally_parallel = True  # the batched integrator runs sample blocks in threads
    parameters = _PARAMETERS
    outputs = _outputs()
    options = _OPTIONS

    def __init__(
        self,
        length_scale: float = 1e-5,
        stiffness_harmonics: Any = None,
        use_virtual_teeth: bool = True,
    ) -> None:
        from gearuq_plugins.helical_pair.layout import MAX_HARMONICS

        if not (length_scale > 0 and math.isfinite(length_scale)):
            raise ValueError(f"length_scale: must be a positive length in m, got {length_scale}")
        self.length_scale = float(length_scale)
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

    def settings(self) -> dict[str, Any]:
        """Construction options (recorded as provenance)."""
        return {
            "length_scale": self.length_scale,
            "stiffness_harmonics": self.stiffness_harmonics.tolist(),
            "use_virtual_teeth": self.use_virtual_teeth,
        }

    @staticmethod
    def default_space():
        """Seed 000 Table 2: six independent normal parameters (B1, B2, b5, rho, s, n)."""
        import chaospy as cp

        from gearuq.space import ParameterSpace

        return ParameterSpace({k: cp.Normal(mu, sd) for k, (mu, sd) in SEED_TABLE2.items()})

    # ------------------------------------------------------------------ physics set-up
    def gear_data(self, params: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Geometry, masses, inertias and ISO 6336 mesh stiffness per sample (SI)."""
        from gearuq_plugins.helical_pair.physics import gear_data

        return gear_data(params, use_virtual_teeth=self.use_virtual_teeth)

    def coefficients(self, params: dict[str, np.ndarray]) -> tuple[np.ndarray, dict]:
        """Per-sample nondimensional coefficient vectors of the kernel and the SI data."""
        from gearuq_plugins.helical_pair.physics import coefficients

        gd = self.gear_data(params)
        return coefficients(params, gd, self.length_scale, self.stiffness_harmonics), gd

    def initial_state(self, coef: np.ndarray, kind: str = "static") -> np.ndarray:
        """Initial states: static equilibrium at tau = 0 ("static") or rest at zero ("zero")."""
        from gearuq_plugins.helical_pair.physics import initial_state

        return initial_state(coef, kind)

    def ode_problem(self, params: dict | None = None, *, initial: str = "static") -> dict:
        """The raw first-order problem, for benchmarks and external solvers.

        Returns
        -------
        dict
            ``rhs`` and ``switch`` (numba functions ``f(tau, y, p, out)``), ``n_switch``,
            ``rhs_numpy`` (the same equations in plain NumPy, ``f(tau, y, p) -> dy``),
            ``rhs_sides`` (the rhs for ``solve_batch(..., freeze_sides=True)``),
            ``y0`` (n, 20) initial states, ``coef`` (n, N_COEF) per-sample coefficients and
            ``state_names`` (p1..p10, dp1..dp10). Time is nondimensional tau.
        """
        from gearuq_plugins.helical_pair import kernel
        from gearuq_plugins.helical_pair.layout import N_SWITCH
        from gearuq_plugins.helical_pair.physics import rhs_numpy

        coef, _ = self.coefficients(self.validate_params(params))
        return {
            "rhs": kernel.rhs, "switch": kernel.switch, "n_switch": N_SWITCH,
            "rhs_sides": kernel.rhs_sides,
            "rhs_numpy": rhs_numpy,
            "y0": self.initial_state(coef, initial), "coef": coef,
            "state_names": [f"p{i + 1}" for i in range(10)] + [f"dp{i + 1}" for i in range(10)],
        }

    def _time_attrs(self, options):
        if options.get("time", "tau") == "s":
            return {"units": "s", "long_name": "time t"}
        return {"units": "1", "long_name": self.time_long_name}

    def _evaluate(self, params, t, outputs, **options):
        from gearuq_plugins.helical_pair.physics import simulate

        return simulate(self, params, t, outputs, **options)
