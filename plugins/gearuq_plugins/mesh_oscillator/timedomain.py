"""Time responses of the mesh oscillator through the shared integrator.

:func:`time_problem` builds the kernel rows of a model: the exact force-deflection function
(``time_model="exact"``: the segments or table kernel, or the expanded kernel for polynomial
forces, where the expansion is exact) or its truncated Taylor-Fourier expansion (Eq. 11).
:func:`time_block` integrates every sample at its ``frequency_ratio`` and fills the
time-dependent outputs.

EP: Eritenel and Parker (2013), the paper this model follows (docs/models.md).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gearuq_plugins.mesh_oscillator import kernels as K
from gearuq_plugins.mesh_oscillator import slowflow as sf
from gearuq_plugins.mesh_oscillator import sweeps
from gearuq_plugins.mesh_oscillator.model import STATUS_KV_WINDOW


def expanded_rows(system: Any) -> sweeps.OscillatorProblem:
    """Kernel rows of the expanded equation of motion (EP Eq. 11)."""
    return sweeps.expanded_problem(system.alpha, system.phi, system.e, system.psi, system.mu,
                                   system.q, system.rho, system.q_exponent)


def time_problem(model: Any, system: Any, options: dict[str, Any]) -> sweeps.OscillatorProblem:
    """Kernel rows of the time-domain model chosen by ``options["time_model"]``."""
    if not model.dimensional or options["time_model"] == "expanded":
        return expanded_rows(system)
    ex = system.expansion
    kind, block, n_switch = model.force.kernel_block(
        ex.mean_deflection, ex.scale, ex.stiffness, ex.phase_reference, system.values, None)
    n = block.shape[0]
    rows = sweeps.header(n, n_switch, system.mu, system.alpha[:, 0, 0], system.q, system.rho,
                         system.q_exponent, block.shape[1])
    rows[:, K.H_BLOCK:K.H_BLOCK + block.shape[1]] = block
    return sweeps.OscillatorProblem(kind, rows, n_switch)


def initial_linear(coefs: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """State ``(u, u')`` at ``theta = 0`` of the linear steady state at ``omega``, (n, 2)
    (at rest where none exists: no damping, ``omega = 1``)."""
    q = coefs[:, sf.C_Q1] * omega ** coefs[:, sf.C_QEXP]
    force = q * np.exp(-1j * coefs[:, sf.C_R1]) - coefs[:, sf.C_A01]
    den = 1.0 - omega**2 + 2j * coefs[:, sf.C_MU] * omega
    # undamped exactly at resonance there is no linear steady state: start at rest (x_m)
    z = np.where(den == 0.0, 0.0, force / np.where(den == 0.0, 1.0, den))
    return np.stack([z.real, -omega * z.imag], axis=1)


def _perturbation_state(coefs: np.ndarray, omega: np.ndarray, options: dict[str, Any]):
    """(a, gamma, separation mean shift) of the upward-sweep steady state at each sample's
    ``omega`` (:func:`slowflow.separation_mean_shift`)."""
    from gearuq_plugins.mesh_oscillator.perturbation import frequency_response

    grids = np.linspace(np.maximum(0.5 * omega, omega - 0.3), omega, 31).T
    res = frequency_response(coefs, grids, order=options["order"],
                             separation=options["separation"])
    a = res.path("up")[:, -1]
    gam = res.path("up", "phase")[:, -1]
    sep = res.path("up", "separation")[:, -1, :]
    shift = np.array([sf.separation_mean_shift(a[i], gam[i], coefs[i], sep[i])
                      if np.isfinite(a[i]) else np.nan for i in range(a.size)])
    return a, gam, shift, res.status


def series_force(system: Any, u: np.ndarray, theta: np.ndarray, contact: np.ndarray
                 ) -> np.ndarray:
    """``(1 + H) f~(u, theta)`` of Eq. (mo-force-series), in units of ``d beta_10`` (n, nt)."""
    alpha, phi = system.alpha, system.phi
    out = np.zeros(u.shape)
    for i in range(alpha.shape[1]):
        coef = alpha[:, i, 0, None] + sum(
            alpha[:, i, r, None] * np.cos(r * theta - phi[:, i, r, None])
            for r in range(1, alpha.shape[2]))
        out += coef * u**i
    return np.where(contact, out, 0.0)


def dynamic_factor(force: np.ndarray, static: np.ndarray, span: np.ndarray,
                   status: np.ndarray) -> np.ndarray:
    """``K_v`` = largest mesh force over the output instants / the static mesh force.

    ``force`` (n, nt) and ``static`` (n,) in one unit; ``span`` (n,) is the instants' span in
    mesh periods. A sample whose window is shorter than a period gets status 20
    (``kv_window_short``) unless its integration already failed.
    """
    short = (span < 1.0 - 1e-9) & (status == 0)
    status[short] = STATUS_KV_WINDOW
    return np.max(force, axis=1) / static


def _force_values(model, system, params, u, theta, contact, options):
    """Mesh force [N] at the output instants (exact or expanded, as integrated)."""
    ex = system.expansion
    n, nt = u.shape
    out = np.zeros((n, nt))
    if options["time_model"] == "expanded":
        return series_force(system, u, theta, contact) * (ex.stiffness * ex.scale)[:, None]
    x = ex.mean_deflection[:, None] + ex.scale[:, None] * u
    phase = ((theta + ex.phase_reference[:, None]) / (2.0 * math.pi)) % 1.0
    for i in range(n):
        vals = None if system.values is None else {k: v[i:i + 1] for k, v in
                                                   system.values.items()}
        out[i] = model.force.force(x[i][None, :, None], phase[i], vals)[0, :, 0]
    return out


def time_block(model, system, params, t, outputs, options, out, extra, status) -> None:
    """Integrate every sample at its ``frequency_ratio`` and fill the time outputs."""
    from gearuq.ode import solve_batch
    from gearuq_plugins.mesh_oscillator.evaluate import settle_schedule

    if t.size and t[0] < 0.0:
        raise ValueError(f"t: instants must be >= 0 (start of the response), got {t[0]}")
    if "kv" in outputs and t.size < 2:
        raise ValueError(f"t: kv is the largest mesh force over the output instants; give at "
                         f"least two instants spanning one mesh period, got {t.size}")
    n = system.mu.size
    omega = params["frequency_ratio"]
    wn = system.expansion.natural_frequency if model.dimensional else np.ones(n)
    tt = t[None, :] * wn[:, None] if options["time"] == "s" else np.broadcast_to(t, (n, t.size))
    settle = settle_schedule(system.mu, omega, options, status)
    offset = 2.0 * math.pi * settle / omega
    t_abs = tt + offset[:, None]
    # the integrator needs strictly increasing instants: integrate the distinct ones
    _, first, inverse = np.unique(t, return_index=True, return_inverse=True)
    t_eval = np.ascontiguousarray(t_abs[:, first])
    problem = time_problem(model, system, options)
    params_rows = sweeps._with_schedule(problem.rows, np.zeros((n, 1)), omega[:, None])
    coefs = system.coefficients()
    y0 = (initial_linear(coefs, omega) if options["initial"] == "linear"
          else np.zeros((n, 2)))
    rhs, switch = problem.functions()
    periods = settle + np.ceil(tt[:, -1] * omega / (2 * math.pi)) + 1
    res = solve_batch(rhs, y0, params_rows, t_eval, method=options["ode_method"],
                      rtol=options["rtol"], atol=options["atol"], switch=switch,
                      n_switch=problem.n_switch, freeze_sides=True, save=np.array([0]),
                      max_steps=int(400 * periods.max()) + 10_000)
    u = res.y[:, :, 0][:, inverse]
    status[res.status != 0] = res.status[res.status != 0]
    theta = omega[:, None] * t_abs
    uc = np.stack([sweeps.boundary_row(problem.kind, problem.rows[i], theta[i])
                   for i in range(n)])
    contact = u >= uc
    out["u"] = u
    out["contact"] = contact.astype(np.int8)
    extra["ode_steps_time"] = ("sample", res.n_steps, {"units": "1",
                                                       "long_name": "accepted steps"})
    if "u_perturbation" in outputs:
        a, gam, shift, st = _perturbation_state(coefs, omega, options)
        up = np.empty_like(u)
        for i in range(n):
            for j in range(theta.shape[1]):
                up[i, j] = sf.approximate_solution(a[i], gam[i], coefs[i], shift[i],
                                                  theta[i, j])
        out["u_perturbation"] = up
    if model.dimensional:
        ex = system.expansion
        out["dte"] = ex.mean_deflection[:, None] + ex.scale[:, None] * u
        if "mesh_force" in outputs or "kv" in outputs:
            out["mesh_force"] = _force_values(model, system, params, u, theta, contact,
                                              options)
    if "kv" in outputs:
        # static mesh force: the mean load, F_0 [N] or alpha_0_0 in units of d beta_10
        force, static = ((out["mesh_force"], params["mean_force"]) if model.dimensional
                         else (series_force(system, u, theta, contact), system.alpha[:, 0, 0]))
        span = (theta[:, -1] - theta[:, 0]) / (2.0 * math.pi)
        out["kv"] = dynamic_factor(force, static, span, status)
