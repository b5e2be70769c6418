"""Set-up of the helical-pair equations: geometry, inertia, coefficients, static states.

Everything here is vectorised over samples and free of numba. Data flows one way:
``gear_data(params)`` (SI) -> ``coefficients(params, gear)`` (the kernel's per-sample vectors
and the derived scales, as new arrays) -> ``equilibrium`` / ``initial_state`` /
``static_state``. The second half is the plain-NumPy twin of the compiled equations
(``rhs_numpy``), an independent implementation used by the tests, the benchmark baseline and
the mesh-force outputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gearuq_plugins.helical_pair.layout import (
    I_B5,
    I_BETA,
    I_CPHI,
    I_EPS0,
    I_EPSA,
    I_ETA,
    I_G,
    I_GATE,
    I_HARM,
    I_MU,
    I_NHARM,
    I_OMEGA,
    I_PHI,
    I_S,
    I_SPHI,
    I_V,
    I_XI,
    I_ZETA,
    INTERNAL_LENGTH,
    N_COEF,
    N_DOF,
    N_STATE,
)

_GEOMETRY_KEYS = ("z1", "z2", "m_n", "beta", "alpha_n", "x_shift_p", "x_shift_g", "C_R")
#: Generalised-coordinate indices of the rotations (arc lengths on the pitch radius).
ROTATIONS = (3, 4, 8, 9)


def _iso_per_width(row: tuple[float, ...], use_virtual_teeth: bool) -> tuple[float, float]:
    """ISO 6336-1 c_gamma_alpha [N/(mm um)] and eps_alpha for one geometry."""
    from gearuq.gears.geometry import HelicalGearPair
    from gearuq.gears.iso6336 import mesh_stiffness

    z1, z2, m_n, beta, alpha_n, x_p, x_g, c_r = row
    pair = HelicalGearPair(
        mn=m_n, z1=int(z1), z2=int(z2), alpha_n=math.radians(alpha_n),
        beta=math.radians(beta), b1=1.0, b2=1.0, x1=x_p, x2=x_g,
    )
    ms = mesh_stiffness(pair, C_R=c_r, use_virtual_teeth=use_virtual_teeth)
    return ms.c_gamma_alpha, ms.eps_alpha


def gear_data(params: dict[str, np.ndarray], *, use_virtual_teeth: bool = True,
              stiffness_factor: float = 1.0) -> dict:
    """Geometry, blank masses and inertias, ISO mesh stiffness per sample (SI units).

    Blank model: each gear is a solid steel cylinder of its reference diameter and face
    width (no bore, no web): m = rho pi r^2 B, polar J = m r^2 / 2, diametral
    J_d = m (3 r^2 + B^2) / 12. ``stiffness_factor`` scales the ISO mesh stiffness (a
    stage's LTCA value over ISO at its nominal geometry; 1.0 leaves it bit for bit).
    """
    rows = np.stack([params[k] for k in _GEOMETRY_KEYS], axis=1)
    unique, inverse = np.unique(rows, axis=0, return_inverse=True)
    c_ga = np.empty(len(unique))
    eps_a = np.empty(len(unique))
    for j, row in enumerate(unique):
        try:
            c_ga[j], eps_a[j] = _iso_per_width(tuple(row), use_virtual_teeth)
        except ValueError as exc:
            i = int(np.flatnonzero(inverse.ravel() == j)[0])
            raise ValueError(f"invalid gear geometry at sample {i}: {exc}") from exc
    inverse = inverse.ravel()
    beta = np.radians(params["beta"])
    alpha_n = np.radians(params["alpha_n"])
    r_p = params["m_n"] * params["z1"] / (2.0 * np.cos(beta))
    r_g = params["m_n"] * params["z2"] / (2.0 * np.cos(beta))
    b_eff = np.minimum(params["B1"], params["B2"])
    m_p = params["rho"] * np.pi * r_p**2 * params["B1"]
    m_g = params["rho"] * np.pi * r_g**2 * params["B2"]
    return {
        "r_p": r_p, "r_g": r_g, "b": b_eff, "beta": beta, "alpha_n": alpha_n,
        "m_p": m_p, "m_g": m_g,
        "J_pz": 0.5 * m_p * r_p**2, "J_gz": 0.5 * m_g * r_g**2,
        "J_py": m_p * (3 * r_p**2 + params["B1"] ** 2) / 12.0,
        "J_gy": m_g * (3 * r_g**2 + params["B2"] ** 2) / 12.0,
        "c_gamma_alpha": c_ga[inverse], "eps_alpha": eps_a[inverse],
        # c_gamma_alpha [N/(mm um)] * b [mm] -> N/um -> * 1e6 N/m
        "k_mesh": c_ga[inverse] * (b_eff * 1e3) * 1e6 * stiffness_factor,
    }


@dataclass(frozen=True)
class PairSystem:
    """Everything the integration and the outputs need about a batch of samples.

    Attributes
    ----------
    coef : ndarray, shape (n, N_COEF)
        Per-sample coefficient vectors of the nondimensional equations (``layout.py``).
    gear : dict of ndarray
        SI data per sample: geometry and masses (:func:`gear_data`) and the derived scales
        ``omega_n`` [rad/s], ``m_e`` [kg], ``M`` (n, 10) generalised masses, ``mesh_frequency``
        [Hz].
    """

    coef: np.ndarray
    gear: dict[str, np.ndarray]

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return self.coef.shape[0]


def build_system(
    params: dict[str, np.ndarray],
    *,
    harmonics: np.ndarray,
    use_virtual_teeth: bool = True,
    gated: bool = False,
    stiffness_factor: float = 1.0,
) -> PairSystem:
    """Gear data and coefficients of every sample (the whole set-up in one call)."""
    gear = gear_data(params, use_virtual_teeth=use_virtual_teeth,
                     stiffness_factor=stiffness_factor)
    coef, derived = coefficients(params, gear, harmonics, gated=gated)
    return PairSystem(coef=coef, gear={**gear, **derived})


def generalised_masses(gear: dict[str, np.ndarray]) -> np.ndarray:
    """Masses (n, 10) of the length coordinates; rotations as pitch-radius arc lengths."""
    r_p, r_g = gear["r_p"], gear["r_g"]
    return np.stack([
        gear["m_p"], gear["m_p"], gear["m_p"], gear["J_py"] / r_p**2, gear["J_pz"] / r_p**2,
        gear["m_g"], gear["m_g"], gear["m_g"], gear["J_gy"] / r_g**2, gear["J_gz"] / r_g**2,
    ], axis=1)


def mesh_direction(gear: dict[str, np.ndarray]) -> np.ndarray:
    """v (n, 10) = d delta / d u: the mesh deflection per unit of each length coordinate.

    The unit normal of the mesh force on the gear at the pitch point has the components
    (sin a_n, cos a_n cos b, cos a_n sin b) along (radial, tangential, axial).
    """
    nx = np.sin(gear["alpha_n"])
    ny = np.cos(gear["alpha_n"]) * np.cos(gear["beta"])
    nz = np.cos(gear["alpha_n"]) * np.sin(gear["beta"])
    return np.stack([nx, ny, nz, -nz, ny, -nx, -ny, -nz, -nz, -ny], axis=1)


def support_stiffness(params: dict[str, np.ndarray], gear: dict[str, np.ndarray]) -> np.ndarray:
    """Support stiffness (n, 10) of each length coordinate [N/m]; torsion has none.

    Two bearings at +-span share k_r, so the swing stiffness is k_r span^2 (moment per
    radian), divided by r^2 for the arc-length coordinate. The wheel takes ``k_r_wheel``,
    ``k_a_wheel``, ``span_wheel`` when a stage declares them (its shafts differ), else the
    pinion's values.
    """
    k_sw = params["k_r"] * params["span"] ** 2
    k_r_g = params.get("k_r_wheel", params["k_r"])
    k_a_g = params.get("k_a_wheel", params["k_a"])
    k_sw_g = k_r_g * params.get("span_wheel", params["span"]) ** 2
    zero = np.zeros_like(k_sw)
    return np.stack([
        params["k_r"], params["k_r"], params["k_a"], k_sw / gear["r_p"] ** 2, zero,
        k_r_g, k_r_g, k_a_g, k_sw_g / gear["r_g"] ** 2, zero,
    ], axis=1)


def coefficients(
    params: dict[str, np.ndarray],
    gear: dict[str, np.ndarray],
    harmonics: np.ndarray,
    *,
    gated: bool = False,
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Per-sample coefficient vectors (n, N_COEF) of the nondimensional equations.

    Returns the vectors and a new dict of derived scales (``omega_n``, ``m_e``, ``M``,
    ``mesh_frequency``); ``gear`` is not modified.
    """
    n = gear["r_p"].shape[0]
    L = INTERNAL_LENGTH
    M = generalised_masses(gear)
    m_e = 1.0 / (1.0 / M[:, 4] + 1.0 / M[:, 9])  # = J_p J_g / (J_p r_g^2 + J_g r_p^2)
    omega_n = np.sqrt(gear["k_mesh"] / m_e)
    eta = support_stiffness(params, gear) / (M * omega_n[:, None] ** 2)
    zero = np.zeros(n)
    clear = np.stack([params["b1"], params["b1"], params["b3"], zero, zero,
                      params["b2"], params["b2"], params["b4"], zero, zero], axis=1) / L
    # balanced torques: T_g = T r_g / r_p, so both equal the tangential force T / r_p
    force_scale = L * omega_n**2
    tangential = params["T"] / gear["r_p"]

    coef = np.zeros((n, N_COEF))
    coef[:, I_OMEGA] = 2 * np.pi * params["n"] * params["z1"] / 60.0 / omega_n
    coef[:, I_S] = params["s"]
    coef[:, I_EPS0] = params["e_0"] / L
    coef[:, I_EPSA] = params["e_a"] / L
    coef[:, I_PHI] = params["phi"]
    coef[:, I_CPHI] = np.cos(params["phi"])
    coef[:, I_SPHI] = np.sin(params["phi"])
    coef[:, I_ZETA] = params["zeta_m"]
    coef[:, I_V:I_V + N_DOF] = mesh_direction(gear)
    coef[:, I_MU:I_MU + N_DOF] = m_e[:, None] / M
    coef[:, I_ETA:I_ETA + N_DOF] = eta
    coef[:, I_XI:I_XI + N_DOF] = 2.0 * params["zeta_s"][:, None] * np.sqrt(eta)
    coef[:, I_BETA:I_BETA + N_DOF] = clear
    coef[:, I_B5] = params["b5"] / L
    coef[:, I_G + 4] = tangential / (M[:, 4] * force_scale)
    coef[:, I_G + 9] = -tangential / (M[:, 9] * force_scale)
    coef[:, I_NHARM] = harmonics.shape[0]
    coef[:, I_HARM:I_HARM + harmonics.size] = harmonics.ravel()[None, :]
    coef[:, I_GATE] = 1.0 if gated else 0.0
    # the normal mesh force that carries the torque alone: its torsional component (the
    # pinion's tangential direction, mesh_direction's column 4) balances T / r_p
    derived = {"omega_n": omega_n, "m_e": m_e, "M": M,
               "mesh_frequency": params["n"] * params["z1"] / 60.0,
               "static_mesh_force": tangential / coef[:, I_V + 4]}
    return coef, derived


# --------------------------------------------------------------------------------------------
# Static states (closed form)
# --------------------------------------------------------------------------------------------

def _inverse_dead_zone(f: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Displacement whose dead-zone function equals f (0 -> 0, the centre of the gap)."""
    return f + np.sign(f) * b


def equilibrium(coef: np.ndarray, kappa: np.ndarray, eps: np.ndarray) -> np.ndarray:
    """Static equilibrium q (n, 10) under the mean torque for a frozen stiffness and error.

    ``kappa`` and ``eps`` (n,) are the stiffness factor and the error held constant. The mesh
    force W follows from the pinion torque balance, the supports and the swing are deflected
    by it (a support with no load sits at the centre of its clearance), and the torsional
    coordinates are split so that the rigid-body rotation M_5 q_5 + M_10 q_10 is zero. With
    no torque the mesh sits at the centre of the backlash.
    """
    n = coef.shape[0]
    v = coef[:, I_V:I_V + N_DOF]
    mu = coef[:, I_MU:I_MU + N_DOF]
    eta = coef[:, I_ETA:I_ETA + N_DOF]
    beta = coef[:, I_BETA:I_BETA + N_DOF]
    ny = v[:, 4]
    # nondimensional mesh force W from the pinion torque balance: g_4 = v_4 mu_4 W
    w = coef[:, I_G + 4] / (ny * mu[:, 4])
    b5 = coef[:, I_B5]
    d0 = np.where(w > 0, w / kappa + b5, np.where(w < 0, w / kappa - b5, 0.0))
    q = np.zeros((n, N_DOF))
    for i in (0, 1, 2, 3, 5, 6, 7, 8):
        with np.errstate(divide="ignore", invalid="ignore"):
            f = np.where(eta[:, i] > 0, -v[:, i] * mu[:, i] * w / eta[:, i], 0.0)
        q[:, i] = _inverse_dead_zone(f, beta[:, i])
    others = (v * q).sum(axis=1)
    span = (d0 + eps - others) / ny  # required q_pz - q_gz
    m4 = 1.0 / mu[:, 4]  # proportional to the generalised masses M_4, M_9
    m9 = 1.0 / mu[:, 9]
    q[:, 4] = span * m9 / (m4 + m9)
    q[:, 9] = -span * m4 / (m4 + m9)
    return q


def static_state(coef: np.ndarray) -> np.ndarray:
    """The sample's own static equilibrium q (n, 10): mean stiffness, constant error e_0.

    This is the state the vibration outputs ``v_i = p_i - p_i,static`` are measured from:
    the equilibrium of the time-invariant part of the system (the stiffness harmonics and
    the error amplitude have zero mean).
    """
    n = coef.shape[0]
    return equilibrium(coef, np.ones(n), coef[:, I_EPS0].copy())


def initial_state(coef: np.ndarray, kind: str = "static") -> np.ndarray:
    """Initial states (n, 20).

    ``"static"``: equilibrium under the mean torque with the stiffness and error *at tau = 0*
    (kappa(0), eps(0)), velocities zero, so the run starts close to the operating point and
    the transient comes only from the excitation. It equals :func:`static_state` only when
    kappa(0) = 1 and eps(0) = e_0 (s = 0 and e_a sin(phi) = 0). ``"zero"``: all displacements
    and velocities zero (the torque is applied suddenly at tau = 0).
    """
    n = coef.shape[0]
    y0 = np.zeros((n, N_STATE))
    if kind == "zero":
        return y0
    if kind != "static":
        raise ValueError(f"initial: unknown kind {kind!r}; valid: 'static', 'zero'")
    kappa0 = stiffness_factor(np.zeros((n, 1)), coef)[:, 0]
    eps0 = error_excitation(np.zeros((n, 1)), coef)[0][:, 0]
    y0[:, :N_DOF] = equilibrium(coef, kappa0, eps0)
    return y0


# --------------------------------------------------------------------------------------------
# Plain-NumPy twin of the compiled equations (kernel.py); shares no code with it
# --------------------------------------------------------------------------------------------

def stiffness_factor(tau: np.ndarray, coef: np.ndarray) -> np.ndarray:
    """k(tau)/k_m for each sample (rows of coef) at instants tau (n, nt) -- NumPy twin."""
    om = coef[:, I_OMEGA][:, None]
    nh = int(coef[0, I_NHARM])
    if nh == 0:
        return 1.0 + coef[:, I_S][:, None] * np.cos(om * tau)
    kappa = np.ones(np.broadcast(om, tau).shape)
    for j in range(nh):
        h = (j + 1) * om * tau
        kappa = kappa + (coef[:, I_HARM + 2 * j][:, None] * np.cos(h)
                         + coef[:, I_HARM + 2 * j + 1][:, None] * np.sin(h))
    return kappa


def error_excitation(tau: np.ndarray, coef: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """eps(tau) = e(t)/L and its tau-derivative for each sample -- NumPy twin of the kernel."""
    om = coef[:, I_OMEGA][:, None]
    ph = om * tau + coef[:, I_PHI][:, None]
    eps = coef[:, I_EPS0][:, None] + coef[:, I_EPSA][:, None] * np.sin(ph)
    deps = coef[:, I_EPSA][:, None] * om * np.cos(ph)
    return eps, deps


def dead_zone(x: np.ndarray, b: np.ndarray | float) -> np.ndarray:
    """Vectorised backlash function."""
    return np.where(x > b, x - b, np.where(x < -b, x + b, 0.0))


def mesh_force(kappa: np.ndarray, d: np.ndarray, dd: np.ndarray, coef: np.ndarray) -> np.ndarray:
    """Nondimensional mesh force (n, nt) from kappa, d and d' (n, nt) -- NumPy twin.

    Rows with ``coef[:, I_GATE] == 0``: kappa f(d) + 2 zeta d' (damping at all times). Gated
    rows: zero inside the backlash, in contact the flank force limited to compression.
    """
    b5 = coef[:, I_B5][:, None]
    damping = 2 * coef[:, I_ZETA][:, None] * dd
    ungated = kappa * dead_zone(d, b5) + damping
    gated = np.where(d > b5, np.maximum(kappa * (d - b5) + damping, 0.0),
                     np.where(d < -b5, np.minimum(kappa * (d + b5) + damping, 0.0), 0.0))
    return np.where(coef[:, I_GATE][:, None] != 0.0, gated, ungated)


def rhs_numpy(tau: float, y: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Pure-NumPy twin of ``kernel.rhs`` (one sample): the baseline a user would write.

    Used by ``gearuq bench integrator`` as the plain scipy baseline and by the tests as an
    independent implementation of the equations.
    """
    q, dq = y[:N_DOF], y[N_DOF:]
    v = p[I_V:I_V + N_DOF]
    tau2 = np.array([[tau]])
    eps, deps = error_excitation(tau2, p[None, :])
    d = np.array([[v @ q - eps[0, 0]]])
    dd = np.array([[v @ dq - deps[0, 0]]])
    fm = mesh_force(stiffness_factor(tau2, p[None, :]), d, dd, p[None, :])[0, 0]
    acc = (p[I_G:I_G + N_DOF] - p[I_ETA:I_ETA + N_DOF] * dead_zone(q, p[I_BETA:I_BETA + N_DOF])
           - p[I_XI:I_XI + N_DOF] * dq - v * p[I_MU:I_MU + N_DOF] * fm)
    return np.concatenate([dq, acc])


def contact_eigenvalues(coef: np.ndarray, n_phase: int = 64) -> np.ndarray:
    """Eigenvalues (n, 40) of the pair linearised in contact, at its stiffest and softest mesh.

    In contact with every support outside its clearance the equations are linear,
    ``q'' = -K q - C q' + ...`` with ``K = diag(eta) + kappa (mu v) v^T`` and
    ``C = diag(xi) + 2 zeta (mu v) v^T`` (nondimensional, as :func:`rhs_numpy`); ``kappa`` is
    taken at the largest and the smallest of the stiffness factor over a mesh period
    (``n_phase`` instants). A support inside its clearance or a tooth pair apart only removes
    stiffness, so these bound the fastest modes an explicit step must follow.
    """
    n = coef.shape[0]
    tau = (2.0 * np.pi / coef[:, I_OMEGA])[:, None] * np.arange(n_phase)[None, :] / n_phase
    kappa = stiffness_factor(tau, coef)
    v, mu = coef[:, I_V:I_V + N_DOF], coef[:, I_MU:I_MU + N_DOF]
    mesh = (mu * v)[:, :, None] * v[:, None, :]  # (n, 10, 10)
    damping = (np.eye(N_DOF)[None] * coef[:, I_XI:I_XI + N_DOF][:, None, :]
               + 2.0 * coef[:, I_ZETA][:, None, None] * mesh)
    out = []
    for k in (kappa.max(axis=1), kappa.min(axis=1)):
        stiff = np.eye(N_DOF)[None] * coef[:, I_ETA:I_ETA + N_DOF][:, None, :] \
            + k[:, None, None] * mesh
        a = np.zeros((n, 2 * N_DOF, 2 * N_DOF))
        a[:, :N_DOF, N_DOF:] = np.eye(N_DOF)
        a[:, N_DOF:, :N_DOF] = -stiff
        a[:, N_DOF:, N_DOF:] = -damping
        out.append(np.linalg.eigvals(a))
    return np.concatenate(out, axis=1)

