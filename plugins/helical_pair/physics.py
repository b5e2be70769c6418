"""Set-up of the helical-pair equations: geometry, inertia, coefficients, solve, outputs.

Everything here is vectorised over samples; the per-sample coefficient vectors feed the
compiled kernel (kernel.py) through the generic batched integrator ``gearuq.ode``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gearuq.model import Evaluation
from gearuq_plugins.helical_pair.layout import (
    I_B5,
    I_BETA,
    I_CPHI,
    I_EPS0,
    I_EPSA,
    I_ETA,
    I_G,
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
    N_COEF,
    N_DOF,
    N_STATE,
    N_SWITCH,
)

_GEOMETRY_KEYS = ("z1", "z2", "m_n", "beta", "alpha_n", "x_shift_p", "x_shift_g", "C_R")


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


def gear_data(params: dict[str, np.ndarray], *, use_virtual_teeth: bool = True) -> dict:
    """Geometry, blank masses and inertias, ISO mesh stiffness per sample (SI units).

    Blank model: each gear is a solid steel cylinder of its reference diameter and face
    width (no bore, no web): m = rho pi r^2 B, polar J = m r^2 / 2, diametral
    J_d = m (3 r^2 + B^2) / 12.
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
        "k_mesh": c_ga[inverse] * (b_eff * 1e3) * 1e6,
    }


def coefficients(
    params: dict[str, np.ndarray], gd: dict, length_scale: float, harmonics: np.ndarray
) -> np.ndarray:
    """Per-sample coefficient vectors (n, N_COEF) of the nondimensional equations."""
    n = gd["r_p"].shape[0]
    L = length_scale
    r_p, r_g = gd["r_p"], gd["r_g"]
    # generalised (length-coordinate) masses: rotations as pitch-radius arc lengths
    M = np.stack([
        gd["m_p"], gd["m_p"], gd["m_p"], gd["J_py"] / r_p**2, gd["J_pz"] / r_p**2,
        gd["m_g"], gd["m_g"], gd["m_g"], gd["J_gy"] / r_g**2, gd["J_gz"] / r_g**2,
    ], axis=1)
    m_e = 1.0 / (1.0 / M[:, 4] + 1.0 / M[:, 9])  # = J_p J_g / (J_p r_g^2 + J_g r_p^2)
    k_m = gd["k_mesh"]
    omega_n = np.sqrt(k_m / m_e)
    # unit normal of the mesh force on the gear at the pitch point (radial, tangential, axial)
    nx = np.sin(gd["alpha_n"])
    ny = np.cos(gd["alpha_n"]) * np.cos(gd["beta"])
    nz = np.cos(gd["alpha_n"]) * np.sin(gd["beta"])
    v = np.stack([nx, ny, nz, -nz, ny, -nx, -ny, -nz, -nz, -ny], axis=1)
    # supports: two bearings at +-span share k_r; swing stiffness k_r span^2 (moment/rad)
    k_sw = params["k_r"] * params["span"] ** 2
    k = np.stack([
        params["k_r"], params["k_r"], params["k_a"], k_sw / r_p**2, np.zeros(n),
        params["k_r"], params["k_r"], params["k_a"], k_sw / r_g**2, np.zeros(n),
    ], axis=1)
    eta = k / (M * omega_n[:, None] ** 2)
    xi = 2.0 * params["zeta_s"][:, None] * np.sqrt(eta)  # c = 2 zeta sqrt(k M)
    zero = np.zeros(n)
    clear = np.stack([params["b1"], params["b1"], params["b3"], zero, zero,
                      params["b2"], params["b2"], params["b4"], zero, zero], axis=1) / L
    g = np.zeros((n, N_DOF))
    force_scale = L * omega_n**2
    # balanced torques: T_g = T r_g / r_p, so both equal the tangential force T / r_p
    g[:, 4] = (params["T"] / r_p) / (M[:, 4] * force_scale)
    g[:, 9] = -(params["T"] / r_p) / (M[:, 9] * force_scale)

    coef = np.zeros((n, N_COEF))
    coef[:, I_OMEGA] = 2 * np.pi * params["n"] * params["z1"] / 60.0 / omega_n
    coef[:, I_S] = params["s"]
    coef[:, I_EPS0] = params["e_0"] / L
    coef[:, I_EPSA] = params["e_a"] / L
    coef[:, I_PHI] = params["phi"]
    coef[:, I_CPHI] = np.cos(params["phi"])
    coef[:, I_SPHI] = np.sin(params["phi"])
    coef[:, I_ZETA] = params["zeta_m"]
    coef[:, I_V:I_V + N_DOF] = v
    coef[:, I_MU:I_MU + N_DOF] = m_e[:, None] / M
    coef[:, I_ETA:I_ETA + N_DOF] = eta
    coef[:, I_XI:I_XI + N_DOF] = xi
    coef[:, I_BETA:I_BETA + N_DOF] = clear
    coef[:, I_B5] = params["b5"] / L
    coef[:, I_G:I_G + N_DOF] = g
    coef[:, I_NHARM] = harmonics.shape[0]
    coef[:, I_HARM:I_HARM + harmonics.size] = harmonics.ravel()[None, :]
    gd.update({"omega_n": omega_n, "m_e": m_e, "M": M, "L": L,
               "mesh_frequency": params["n"] * params["z1"] / 60.0})
    return coef


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


def rhs_numpy(tau: float, y: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Pure-NumPy twin of ``kernel.rhs`` (one sample): the baseline a user would write.

    Used by ``gearuq bench integrator`` as the plain scipy baseline and by the tests as an
    independent implementation of the equations.
    """
    q, dq = y[:N_DOF], y[N_DOF:]
    v = p[I_V:I_V + N_DOF]
    tau2 = np.array([[tau]])
    eps, deps = error_excitation(tau2, p[None, :])
    d = v @ q - eps[0, 0]
    dd = v @ dq - deps[0, 0]
    fm = stiffness_factor(tau2, p[None, :])[0, 0] * dead_zone(d, p[I_B5]) + 2 * p[I_ZETA] * dd
    acc = (p[I_G:I_G + N_DOF] - p[I_ETA:I_ETA + N_DOF] * dead_zone(q, p[I_BETA:I_BETA + N_DOF])
           - p[I_XI:I_XI + N_DOF] * dq - v * p[I_MU:I_MU + N_DOF] * fm)
    return np.concatenate([dq, acc])


def _inverse_dead_zone(f: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Displacement whose dead-zone function equals f (0 -> 0, the centre of the gap)."""
    return f + np.sign(f) * b


def initial_state(coef: np.ndarray, kind: str = "static") -> np.ndarray:
    """Initial states (n, 20).

    ``"static"``: equilibrium under the mean torque with the stiffness and error at tau = 0,
    the rigid-body rotation coordinate set to zero, velocities zero (so the run starts close
    to the operating point and the transient comes only from the excitation). ``"zero"``:
    all displacements and velocities zero (the torque is applied suddenly at tau = 0).
    """
    n = coef.shape[0]
    y0 = np.zeros((n, N_STATE))
    if kind == "zero":
        return y0
    if kind != "static":
        raise ValueError(f"initial: unknown kind {kind!r}; valid: 'static', 'zero'")
    v = coef[:, I_V:I_V + N_DOF]
    mu = coef[:, I_MU:I_MU + N_DOF]
    eta = coef[:, I_ETA:I_ETA + N_DOF]
    beta = coef[:, I_BETA:I_BETA + N_DOF]
    ny = v[:, 4]
    # nondimensional mesh force W from the pinion torque balance: g_4 = v_4 mu_4 W
    w = coef[:, I_G + 4] / (ny * mu[:, 4])
    kappa0 = stiffness_factor(np.zeros((n, 1)), coef)[:, 0]
    d0 = np.where(w > 0, w / kappa0 + coef[:, I_B5], np.where(w < 0, w / kappa0 - coef[:, I_B5],
                                                              0.0))
    q = np.zeros((n, N_DOF))
    for i in (0, 1, 2, 3, 5, 6, 7, 8):
        with np.errstate(divide="ignore", invalid="ignore"):
            f = np.where(eta[:, i] > 0, -v[:, i] * mu[:, i] * w / eta[:, i], 0.0)
        q[:, i] = _inverse_dead_zone(f, beta[:, i])
    eps0 = error_excitation(np.zeros((n, 1)), coef)[0][:, 0]
    others = (v * q).sum(axis=1)
    span = (d0 + eps0 - others) / ny  # required q_pz - q_gz
    m4 = 1.0 / mu[:, 4]  # proportional to the generalised masses M_4, M_9
    m9 = 1.0 / mu[:, 9]
    q[:, 4] = span * m9 / (m4 + m9)
    q[:, 9] = -span * m4 / (m4 + m9)
    y0[:, :N_DOF] = q
    return y0


def _needed_states(outputs: list[str]) -> np.ndarray:
    from gearuq_plugins.helical_pair import _MESH_OUTPUTS, _STATE_OUTPUTS

    if any(o in _MESH_OUTPUTS for o in outputs):
        return np.arange(N_STATE)
    return np.array(sorted({_STATE_OUTPUTS[o] for o in outputs if o in _STATE_OUTPUTS}),
                    dtype=np.int64)


def simulate(
    model: Any,
    params: dict[str, np.ndarray],
    t: np.ndarray,
    outputs: list[str],
    *,
    time: str = "tau",
    method: str = "dop853",
    rtol: float = 1e-6,
    atol: float = 1e-8,
    max_step: float = np.inf,
    max_steps: int = 2_000_000,
    fixed_step: float | None = None,
    events: bool = True,
    freeze_sides: bool = True,
    initial: str = "static",
    parallel: bool = True,
) -> Evaluation:
    """Integrate the equations for every sample and build the requested outputs.

    Parameters
    ----------
    time : {"tau", "s"}
        Unit of ``t``: nondimensional tau = omega_n t (default, as in the seed) or seconds
        (each sample is then integrated to its own tau = omega_n t).
    method, rtol, atol, max_step, max_steps, fixed_step, parallel
        Integrator settings (see :func:`gearuq.ode.solve_batch`). DOP853 with frozen
        sides is the default: on this model it is both faster and more accurate than
        Dormand-Prince 5(4) for every rtol <= 1e-5 (docs/benchmarks.md).
    events : bool
        Locate every dead-zone switching instant (default) or step across the kinks.
    freeze_sides : bool
        With events: evaluate every stage of a step on the branch of the dead zones that
        holds at the step start (``kernel.rhs_sides``), so no stage straddles a kink; the
        step is cut at the located crossing (default; keeps DOP853 at its order).
    initial : {"static", "zero"}
        Initial state (see :func:`initial_state`).
    """
    from gearuq_plugins.helical_pair import _MESH_OUTPUTS, _ROT, _STATE_OUTPUTS

    if time not in ("tau", "s"):
        raise ValueError(f"time: unknown unit {time!r}; valid: 'tau', 's'")
    coef, gd = model.coefficients(params)
    n = coef.shape[0]
    L = gd["L"]
    omega_n = gd["omega_n"]
    data: dict[str, np.ndarray] = {}
    status = np.zeros(n, dtype=np.int8)
    attrs: dict[str, Any] = {"length_scale_m": L, "time_axis": time,
                             "initial_state": initial}
    extra: dict[str, tuple] = {}
    save = _needed_states(outputs)
    if save.size:
        from gearuq.ode import solve_batch
        from gearuq_plugins.helical_pair import kernel

        if t.size == 0:
            raise ValueError("t: give output instants for time-dependent outputs")
        if t[0] < 0:
            raise ValueError(f"t: instants must be >= 0 (start of the run), got {t[0]}")
        tau = t[None, :] * omega_n[:, None] if time == "s" else t
        y0 = initial_state(coef, initial)
        frozen = bool(events and freeze_sides)
        res = solve_batch(
            kernel.rhs_sides if frozen else kernel.rhs, y0, coef, tau, t0=0.0, method=method,
            rtol=rtol, atol=atol, max_step=max_step, max_steps=max_steps,
            fixed_step=fixed_step, switch=kernel.switch if events else None,
            n_switch=N_SWITCH if events else 0, save=save, parallel=parallel,
            freeze_sides=frozen,
        )
        status[:] = res.status
        attrs.update({f"solver_{k}": v for k, v in res.settings().items()})
        attrs["solver_events"] = int(events)
        extra["n_steps"] = ("sample", res.n_steps, {"units": "1", "long_name": "accepted steps"})
        extra["n_events"] = ("sample", res.n_events,
                             {"units": "1", "long_name": "located dead-zone switchings"})
        col = {int(s): j for j, s in enumerate(save)}
        Y = res.y
        tau2 = np.broadcast_to(tau, (n, t.size))
        for o in outputs:
            if o in _STATE_OUTPUTS:
                idx = _STATE_OUTPUTS[o]
                q = Y[:, :, col[idx]]
                if o.startswith("p") or o.startswith("dp"):
                    data[o] = q
                    continue
                dof = idx % N_DOF
                scale = np.full(n, L)
                if dof in _ROT:
                    scale = L / (gd["r_p"] if dof < 5 else gd["r_g"])
                if idx >= N_DOF:  # velocity: d/dt = omega_n d/dtau
                    scale = scale * omega_n
                data[o] = q * scale[:, None]
        if any(o in _MESH_OUTPUTS for o in outputs):
            v = coef[:, I_V:I_V + N_DOF]
            qs = Y[:, :, :N_DOF]
            dqs = Y[:, :, N_DOF:]
            rel = np.einsum("nti,ni->nt", qs, v)
            drel = np.einsum("nti,ni->nt", dqs, v)
            eps, deps = error_excitation(tau2, coef)
            d = rel - eps
            kappa = stiffness_factor(tau2, coef)
            fm = kappa * dead_zone(d, coef[:, I_B5][:, None]) + 2 * coef[:, I_ZETA][:, None] * (
                drel - deps)
            data["mesh_force"] = fm * (gd["k_mesh"] * L)[:, None]
            data["dte"] = rel * L
            data["mesh_deflection"] = d * L
    per_sample = {
        "omega_n": omega_n, "mesh_frequency": gd["mesh_frequency"], "k_mesh": gd["k_mesh"],
        "contact_ratio": gd["eps_alpha"], "m_p": gd["m_p"], "m_g": gd["m_g"],
    }
    for o in outputs:
        if o in per_sample:
            data[o] = per_sample[o]
    return Evaluation(data=data, status=status, attrs=attrs, extra=extra)
