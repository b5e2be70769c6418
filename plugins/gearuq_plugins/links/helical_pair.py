"""``helical_pair -> mesh_oscillator``: the lumped pair's mesh as a single-DOF oscillator.

The pair's mesh (Li, Hu and Han) is a spring ``k_m (1 + s cos theta)`` acting on the mesh
deflection ``delta = x - e(theta)`` beyond the half backlash ``b5``, with damping on
``delta'``, where ``x`` is the dynamic transmission error along the normal line of action and
``e = e_0 + e_a sin(theta + phi)`` the static error. In contact on the drive flank this is
exactly the force-deflection function ``f = k(theta) (x - g(theta))`` of the mesh oscillator
(Eritenel and Parker) with the unloaded transmission error ``g = b5 + e(theta)``; the
expansion (mean deflection, Taylor-Fourier coefficients) is exact for it and is written here
in closed form, so the link drives the oscillator's nondimensional model (every coefficient
a per-sample parameter). The oscillator's steady state is integrated over one excitation
period (from rest at the mean deflection, as the pair starts from its static equilibrium)
and the link rebuilds the mesh force ``k(theta) max(x - g, 0) + c delta'`` at the pair's own
output instants. Equations and what is neglected: docs/theory/fidelity_links.md.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gearuq.links import FidelityLink, LinkContext, LinkOutput, LowFidelityInputs
from gearuq.model import Model, Option

__all__ = ["build", "NEGLECTS", "oscillator_inputs", "equivalent_mass"]

#: What the single-DOF oscillator leaves out of the 10-DOF pair, one sentence each.
NEGLECTS = (
    "The bearings' radial and axial clearances (dead zones b1-b4) and their stiffness and "
    "damping: the supports are taken as infinitely soft at mesh frequencies (equivalent_mass="
    "'mesh_line') or the gear bodies as held in translation (equivalent_mass='torsional').",
    "The gear bodies' own dynamics beyond the mesh mode: the radial, tangential, axial and "
    "swing degrees of freedom enter only through the equivalent mass, not as modes of their "
    "own (no coupling resonances, no support modes).",
    "The axial and swing coupling of the helical mesh: the mesh force acts on one coordinate, "
    "the dynamic transmission error along the normal line of action.",
    "Back-flank contact: the oscillator's contact loss is one-sided, so a deflection beyond "
    "the whole backlash 2 b5 is free flight instead of an impact on the back flank.",
    "The start-up transient: the link gives the periodic steady state reached from rest at "
    "the mean deflection; the pair's outputs before the transient has decayed (tau < about "
    "3 / (zeta_m Omega)) differ.",
    "The pair's optional Fourier stiffness (stiffness_harmonics): the link uses Li, Hu and Han's "
    "cosine form 1 + s cos(theta) and refuses a pair built with harmonics.",
)


def equivalent_mass(gear: dict[str, np.ndarray], kind: str) -> np.ndarray:
    """Mass [kg] of the normal mesh deflection for the gear data of the pair (SI).

    ``"torsional"``: the gear bodies only turn, ``m = I_p I_g / (I_p r_bg^2 + I_g r_bp^2) /
    cos^2(beta_b)`` (base radii ``r_b = r cos(alpha_t)``; the ``cos^2 beta_b`` projects the
    transverse base-circle motion onto the normal line of action).
    ``"mesh_line"``: each gear body is free in all its five coordinates (supports much softer
    than the mesh), ``1/m = sum_i v_i^2 / M_i`` over the ten coordinates with ``v`` the mesh
    direction (the mobility of the mesh line).
    """
    alpha_n, beta = gear["alpha_n"], gear["beta"]
    ny = np.cos(alpha_n) * np.cos(beta)
    nz = np.cos(alpha_n) * np.sin(beta)
    if kind == "torsional":
        alpha_t = np.arctan(np.tan(alpha_n) / np.cos(beta))
        cos_bb = np.sqrt(1.0 - (np.sin(beta) * np.cos(alpha_n)) ** 2)
        rbp = gear["r_p"] * np.cos(alpha_t)
        rbg = gear["r_g"] * np.cos(alpha_t)
        ip, ig = gear["J_pz"], gear["J_gz"]
        return ip * ig / (ip * rbg**2 + ig * rbp**2) / cos_bb**2
    if kind != "mesh_line":
        raise ValueError(f"equivalent_mass: {kind!r} is not 'mesh_line' or 'torsional'")
    mobility = 0.0
    for m, j_swing, j_twist, r in ((gear["m_p"], gear["J_py"], gear["J_pz"], gear["r_p"]),
                                   (gear["m_g"], gear["J_gy"], gear["J_gz"], gear["r_g"])):
        # translations: nx^2 + ny^2 + nz^2 = 1; swing arm nz, torsion arm ny (pitch radius)
        mobility = mobility + 1.0 / m + nz**2 * r**2 / j_swing + ny**2 * r**2 / j_twist
    return 1.0 / mobility


def _wrap(a: np.ndarray) -> np.ndarray:
    return (np.asarray(a) + math.pi) % (2.0 * math.pi) - math.pi


def oscillator_inputs(high: Model, params: dict[str, np.ndarray], equivalent: str
                      ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Nondimensional oscillator parameters of pair samples, and the SI scales behind them.

    Returns ``(inputs, scales)``: ``inputs`` the ``mesh_oscillator`` parameters (Eritenel and Parker
    Eqs. 11-14 with the phases taken relative to the excitation's first harmonic),
    ``scales`` ``k`` [N/m], ``mass`` [kg], ``d`` [m], ``phase_shift`` ``Phi_01`` [rad],
    ``omega_high`` (the pair's time scale) and ``omega_osc`` [rad/s], ``xi`` mesh
    frequency [rad/s], ``force`` mean normal force [N].
    """
    gear = high.gear_data(params)
    k = gear["k_mesh"]
    mass = equivalent_mass(gear, equivalent)
    ny = np.cos(gear["alpha_n"]) * np.cos(gear["beta"])
    force = params["T"] / (gear["r_p"] * ny)  # normal force: ny W = T / r_p
    s, e_a, phi = params["s"], params["e_a"], params["phi"]
    d = force / k + 0.5 * s * e_a * np.sin(phi)  # x_m - g_0 (mean of f(x_m) = F_0)
    eps = e_a / d
    c1, s1 = s - eps * np.sin(phi), -eps * np.cos(phi)  # first harmonic of f/(k d) at u = 0
    shift = np.arctan2(s1, c1)
    omega_osc = np.sqrt(k / mass)
    m_torsion = 1.0 / (gear["r_p"] ** 2 / gear["J_pz"] + gear["r_g"] ** 2 / gear["J_gz"])
    omega_high = np.sqrt(k / m_torsion)  # the pair's tau = omega_n t
    xi = 2.0 * math.pi * params["n"] * params["z1"] / 60.0
    ratio = xi / omega_osc
    mu = params["zeta_m"] * omega_osc / omega_high  # same c = 2 zeta_m m_e omega_n
    inputs = {
        "alpha_0_0": force / (k * d),
        "alpha_0_1": np.hypot(c1, s1),
        "alpha_0_2": 0.5 * s * eps, "phi_0_2": _wrap(-(phi + 0.5 * math.pi) - 2.0 * shift),
        "alpha_1_1": s, "phi_1_1": _wrap(-shift),
        "e_1": eps, "psi_1": _wrap(0.5 * math.pi - phi - shift),
        # damping acts on delta' = x' - e': its e' part is a load harmonic c e'
        "q_1": 2.0 * mu * ratio * eps, "rho_1": _wrap(-phi - shift),
        "damping_ratio": mu, "frequency_ratio": ratio,
        "alpha_2_0": np.zeros_like(k), "alpha_3_0": np.zeros_like(k),
    }
    scales = {"k": k, "mass": mass, "d": d, "phase_shift": shift, "omega_high": omega_high,
              "omega_osc": omega_osc, "xi": xi, "force": force}
    return inputs, scales


class _InputMap:
    """The link's input map (a picklable object holding the pair model)."""

    def __init__(self, high: Model) -> None:
        self.high = high

    def __call__(self, params: dict[str, np.ndarray], **options: Any) -> LowFidelityInputs:
        inputs, _ = oscillator_inputs(self.high, params, options["equivalent_mass"])
        n_pts = options["points_per_period"]
        # one excitation period of the slowest sample in the oscillator's time T
        period = 2.0 * math.pi / float(np.nanmin(inputs["frequency_ratio"]))
        t_low = np.arange(n_pts) * (period / n_pts)
        return LowFidelityInputs(inputs, {"initial": "rest", "time": "nondimensional"}, t_low)


class _MeshForce:
    """Transform: the oscillator's ``u`` over one period -> the pair's mesh force at its
    own output instants (``k(theta) max(x - g, 0) + c delta'``)."""

    def __init__(self, high: Model) -> None:
        self.high = high

    def __call__(self, u: np.ndarray, ctx: LinkContext) -> np.ndarray:
        p = ctx.params
        _, sc = oscillator_inputs(self.high, p, ctx.options["equivalent_mass"])
        ratio = ctx.low_params["frequency_ratio"]
        t = np.zeros(1) if ctx.t is None else ctx.t
        omega_high_ratio = sc["xi"] / sc["omega_high"]
        if ctx.options["time"] == "s":
            theta = sc["xi"][:, None] * t[None, :]
        else:
            theta = omega_high_ratio[:, None] * t[None, :]
        th_model = theta - sc["phase_shift"][:, None]
        n, nt = theta.shape
        two_pi = 2.0 * math.pi
        u_at = np.empty((n, nt))
        du_at = np.empty((n, nt))
        for i in range(n):
            # the steady state is periodic in the oscillator's phase theta_m = Omega T
            ph = (ratio[i] * ctx.low_t) % two_pi
            order = np.argsort(ph)
            ph, ui = ph[order], u[i, order]
            grid = np.linspace(0.0, two_pi, 257)[:-1]
            ug = np.interp(grid, ph, ui, period=two_pi)
            dug = (np.roll(ug, -1) - np.roll(ug, 1)) / (2.0 * (grid[1] - grid[0]))
            u_at[i] = np.interp(th_model[i], grid, ug, period=two_pi)
            du_at[i] = np.interp(th_model[i], grid, dug, period=two_pi)
        d, k, e_a, phi = (sc["d"][:, None], sc["k"][:, None], p["e_a"][:, None],
                          p["phi"][:, None])
        gap = d * (1.0 + u_at) - e_a * np.sin(theta + phi)  # x - g
        stiffness = k * (1.0 + p["s"][:, None] * np.cos(theta))
        # c delta' with c = 2 zeta_m k / omega_n and d/dt = xi d/dtheta
        damping = (2.0 * p["zeta_m"][:, None] * k * omega_high_ratio[:, None]
                   * (d * du_at - e_a * np.cos(theta + phi)))
        return stiffness * np.maximum(gap, 0.0) + damping


_OPTIONS = (
    Option("equivalent_mass", "mesh_line", "mass of the oscillator: 'mesh_line' (each gear body "
           "free in its five coordinates: supports much softer than the mesh) or 'torsional' "
           "(the bodies only turn: inertias and base radii)",
           choices=("mesh_line", "torsional")),
    Option("points_per_period", 128, "oscillator output instants over one excitation period "
           "(the steady state is rebuilt from them by periodic interpolation)",
           lower=16, upper=4096),
    Option("time", "tau", "unit of t, as the pair's option: nondimensional tau = omega_n t or "
           "seconds", choices=("tau", "s")),
)


def build(pair: Model | str = "helical_pair", oscillator: Model | str = "mesh_oscillator",
          *, stage: Any = None, **low_options: Any) -> FidelityLink:
    """The link ``helical_pair -> mesh_oscillator`` (output ``mesh_force``).

    Parameters
    ----------
    pair, oscillator : Model or str
        The pair (a ``helical_pair`` instance, e.g. ``with_nominal(...)``, or its name) and the
        nondimensional mesh oscillator.
    stage : GearStage, optional
        Build the pair from this stage (``get_model("helical_pair", stage=stage)``: its
        masses, supports and mesh stiffness); the oscillator's inputs follow from it.
    **low_options
        Fixed options of the oscillator's time integration (``rtol``, ``atol``,
        ``settle_tolerance``, ``ode_method``); defaults ``rtol=1e-5``, ``atol=1e-7``,
        ``settle_tolerance=0.01`` (the peak force then moves by < 0.1 % of its spread
        against the oscillator's own defaults, at 40 % less cost).
    """
    from gearuq.registry import get_model

    if stage is not None and not isinstance(pair, str):
        raise ValueError("give stage= with the pair's name, not a built pair (the stage "
                         "builds it)")
    high = (get_model(pair, **({} if stage is None else {"stage": stage}))
            if isinstance(pair, str) else pair)
    low = get_model(oscillator) if isinstance(oscillator, str) else oscillator
    harmonics = getattr(high, "stiffness_harmonics", np.zeros((0, 2)))
    if np.size(harmonics):
        raise ValueError("pair: the link maps Li, Hu and Han's stiffness 1 + s cos(theta); a pair "
                         "built with stiffness_harmonics is not supported")
    if getattr(low, "dimensional", False):
        raise ValueError("oscillator: the link drives the nondimensional mesh oscillator "
                         "(get_model('mesh_oscillator') without a force)")
    produces = ("alpha_0_0", "alpha_0_1", "alpha_0_2", "phi_0_2", "alpha_1_1", "phi_1_1",
                "e_1", "psi_1", "q_1", "rho_1", "damping_ratio", "frequency_ratio",
                "alpha_2_0", "alpha_3_0")
    return FidelityLink(
        high, low, _InputMap(high), produces,
        {"u": LinkOutput("mesh_force", _MeshForce(high))},
        reads=("z1", "z2", "m_n", "beta", "alpha_n", "x_shift_p", "x_shift_g", "B1", "B2",
               "rho", "s", "n", "T", "zeta_m", "e_0", "e_a", "phi", "C_R"),
        neglects=NEGLECTS, options=_OPTIONS,
        low_options={"rtol": 1e-5, "atol": 1e-7, "settle_tolerance": 0.01, **low_options},
        description="helical pair seen as the single-DOF mesh oscillator (exact expansion of "
                    "its piecewise-linear mesh; periodic steady state at the pair's speed)",
        version="1")
