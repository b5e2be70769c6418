"""Time integration of the geared rotor: reduced model on the batched integrator, and the
full finite-element model by Newmark's average-acceleration rule (for checks).

Reduced model (:func:`integrate_reduced`): the modal equations of
:mod:`gearuq.rotor.reduction` with the algebraic static correction of the mesh, run by
:func:`gearuq.ode.solve_batch` for many speeds in one call, with the contact-loss and
back-flank switching located by the integrator (frozen sides, as in the helical pair).

Full model (:func:`newmark_full`): ``M q'' + (C + Omega G) q' + K q = f - v r(delta, t)`` on
all DOFs, average acceleration (unconditionally stable, second order, no numerical
damping). The mesh law is piecewise linear in ``delta = v . q``; at each step the scalar
equation ``delta = delta_b - beta r(delta)`` is solved in closed form on the branch that is
consistent with its own result (switching inside a step is not located: a check solver, to
be run with small steps).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gearuq.rotor.harmonic_balance import PeriodicSolution, PreparedExcitation
from gearuq.rotor.reduction import ModalModel

__all__ = ["TimeResponse", "integrate_reduced", "newmark_full", "pack"]


@dataclass
class TimeResponse:
    """Time histories of the mesh and the output channels.

    Attributes
    ----------
    t : ndarray, (n_t,)
        Instants [s].
    delta, force : ndarray, (n_samples, n_t)
        Mesh approach [m] and mesh force [N].
    channels : dict
        Name -> (n_samples, n_t) (accelerations from the modal part only for the reduced
        model; exact second derivatives for Newmark).
    status : ndarray of int
        Integrator status per sample (0 ok).
    stats : dict
        Solver statistics.
    """

    t: np.ndarray
    delta: np.ndarray
    force: np.ndarray
    channels: dict[str, np.ndarray]
    status: np.ndarray
    stats: dict


def _real_series(one_sided: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cosine and sine coefficients of ``sum_j c_j e^{i j w0 t}`` (real signal)."""
    c = np.asarray(one_sided, dtype=complex)
    cos = 2.0 * c.real
    sin = -2.0 * c.imag
    cos[0], sin[0] = c[0].real, 0.0
    return cos, sin


def pack(model: ModalModel, prep: PreparedExcitation, speed: float, period: float,
         backlash: float = math.inf) -> np.ndarray:
    """Coefficient vector of :mod:`gearuq.rotor._kernels` for one speed."""
    n = model.n_modes
    w2 = model.omega**2
    D = model.damping + speed * model.gyroscopic
    k_hat = np.asarray(prep.stiffness_harmonics)
    nh = k_hat.size - 1
    ke_hat = np.fft.rfft(prep.ke_grid)[:nh + 1] / prep.n_time
    kc, ks = _real_series(k_hat)
    kec, kes = _real_series(ke_hat)
    delta_res = model.mesh_static - model.mesh @ (model.load / w2)
    head = [n, nh, 2.0 * math.pi / period, model.mean_stiffness, model.mesh_residual,
            delta_res, backlash if math.isfinite(backlash) else 1e301]
    return np.concatenate([head, w2, D.ravel(order="F"), model.mesh, model.load, kc, ks, kec,
                           kes])


def _branch_delta(dm, k, ke, kbar, hres, backlash):
    """Mesh approach and force from ``delta_m`` on the consistent branch (vectorised)."""
    one = 1.0 - hres * kbar
    g0 = k * dm - ke * one
    g1 = k * dm - (ke - k * backlash) * one if math.isfinite(backlash) else np.ones_like(dm)
    den = 1.0 + hres * (k - kbar)
    d_contact = (dm + hres * ke) / den
    d_back = (dm + hres * (ke - k * backlash)) / den if math.isfinite(backlash) else d_contact
    d_sep = dm / one
    delta = np.where(g0 > 0, d_contact, np.where(g1 < 0, d_back, d_sep))
    force = np.where(g0 > 0, k * d_contact - ke,
                     np.where(g1 < 0, k * d_back - ke + k * backlash, 0.0))
    return delta, force


def _series_values(p_row: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n, nh = int(p_row[0]), int(p_row[1])
    w0 = p_row[2]
    base = 7 + n + n * n + 2 * n
    m = nh + 1
    j = np.arange(m)
    C, S = np.cos(np.outer(t, j) * w0), np.sin(np.outer(t, j) * w0)
    kc, ks = p_row[base:base + m], p_row[base + m:base + 2 * m]
    kec, kes = p_row[base + 2 * m:base + 3 * m], p_row[base + 3 * m:base + 4 * m]
    return C @ kc + S @ ks, C @ kec + S @ kes


def initial_state(model: ModalModel, solution: PeriodicSolution | None = None,
                  speed: float = 0.0) -> np.ndarray:
    """Modal state at t = 0: static under the load, or on a harmonic-balance solution."""
    n = model.n_modes
    w2 = model.omega**2
    if solution is None:
        return np.concatenate([model.load / w2, np.zeros(n)])
    H = solution.n_harmonics
    w = 2.0 * math.pi / solution.period * np.arange(H + 1)
    D = model.damping + speed * model.gyroscopic
    eta = np.zeros((H + 1, n), dtype=complex)
    for j in range(H + 1):
        Z = np.diag(w2 - w[j] ** 2) + 1j * w[j] * D
        f = -model.mesh * solution.remainder[j] + (model.load if j == 0 else 0.0)
        eta[j] = np.linalg.solve(Z, f)
    q0 = eta[0].real + 2.0 * eta[1:].sum(axis=0).real
    v0 = 2.0 * (1j * w[1:, None] * eta[1:]).sum(axis=0).real
    return np.concatenate([q0, v0])


def integrate_reduced(
    model: ModalModel,
    prep: PreparedExcitation,
    speeds: Sequence[float],
    periods: Sequence[float],
    t_eval: np.ndarray,
    *,
    backlash: float = math.inf,
    y0: np.ndarray | None = None,
    rtol: float = 1e-8,
    atol_scale: float = 1e-6,
    method: str = "dop853",
    channels: Sequence[str] = (),
    max_steps: int = 5_000_000,
) -> TimeResponse:
    """Integrate the reduced model for several speeds in one batched call.

    Parameters
    ----------
    model : ModalModel
        Reduced rotor (one mode set for the whole batch).
    prep : PreparedExcitation
        Excitation (its stiffness harmonics are the series used in time).
    speeds : sequence of float
        Reference speeds [rad/s], one per sample.
    periods : sequence of float
        Long periods [s], one per sample.
    t_eval : ndarray, (n_t,) or (n_samples, n_t)
        Output instants [s].
    backlash : float
        Normal backlash [m].
    y0 : ndarray, (n_samples, 2 n), optional
        Initial modal states (default: static under the load).
    rtol, atol_scale : float
        Tolerances; ``atol`` is ``atol_scale`` times the static modal amplitudes.
    method : str
        ``solve_batch`` method.
    channels : sequence of str
        Model channels to recover at ``t_eval``.
    max_steps : int
        Step budget per sample.
    """
    from gearuq.ode import solve_batch
    from gearuq.rotor import _kernels

    speeds = np.asarray(speeds, dtype=float)
    P = np.stack([pack(model, prep, s, T, backlash) for s, T in
                  zip(speeds, periods, strict=True)])
    n = model.n_modes
    if y0 is None:
        y0 = np.tile(initial_state(model), (speeds.size, 1))
    scale = np.abs(model.load / model.omega**2).max() + 1e-30
    vscale = scale * model.omega.max()
    atol = np.concatenate([np.full(n, atol_scale * scale), np.full(n, atol_scale * vscale)])
    res = solve_batch(_kernels.rhs_sides, y0, P, t_eval, rtol=rtol, atol=atol, method=method,
                      switch=_kernels.switch, n_switch=2, freeze_sides=True,
                      max_steps=max_steps)
    tt = np.atleast_2d(np.asarray(t_eval, dtype=float))
    if tt.shape[0] == 1:
        tt = np.repeat(tt, speeds.size, axis=0)
    eta, deta = res.y[:, :, :n], res.y[:, :, n:]
    dm = eta @ model.mesh + (model.mesh_static - model.mesh @ (model.load / model.omega**2))
    delta = np.empty_like(dm)
    force = np.empty_like(dm)
    for i in range(speeds.size):
        k, ke = _series_values(P[i], tt[i])
        delta[i], force[i] = _branch_delta(dm[i], k, ke, model.mean_stiffness,
                                           model.mesh_residual, backlash)
    r = force - model.mean_stiffness * delta
    out = {}
    for name in channels:
        ch = model.channels[name]
        load_res = ch["static"] - ch["a"] @ (model.load / model.omega**2)
        if ch["derivative"] == 2:
            acc = -(eta * model.omega**2) @ ch["a"]  # eta'' from the modal equations
            acc = acc - (deta @ model.damping.T) @ ch["a"]
            acc = acc + (model.load - model.mesh * r[..., None]) @ ch["a"]
            out[name] = acc
            continue
        y = eta @ ch["a"] + load_res - ch["a_res"] * r
        if ch["b"] is not None:
            y = y + deta @ ch["b"]
        out[name] = y
    return TimeResponse(t=tt, delta=delta, force=force, channels=out, status=res.status,
                        stats={"n_steps": res.n_steps, "n_rhs": res.n_rhs,
                               "n_events": res.n_events, "n_modes": n})


def newmark_full(
    M: np.ndarray,
    C: np.ndarray,
    K: np.ndarray,
    load: np.ndarray,
    v: np.ndarray,
    prep: PreparedExcitation,
    period: float,
    dt: float,
    n_steps: int,
    *,
    q0: np.ndarray,
    backlash: float = math.inf,
    outputs: dict[str, np.ndarray] | None = None,
    record_from: int = 0,
) -> TimeResponse:
    """Average-acceleration Newmark integration of the full model.

    Parameters
    ----------
    M, C, K : ndarray
        Full matrices (``C`` includes ``Omega G``; ``K`` contains ``k_bar v v^T``).
    load : ndarray
        Constant load [N, N m].
    v : ndarray
        Mesh direction vector.
    prep : PreparedExcitation
        Excitation (the same band-limited ``k`` and ``k e`` as the other solvers).
    period : float
        Long period [s].
    dt : float
        Time step [s].
    n_steps : int
        Number of steps.
    q0 : ndarray
        Initial displacement (zero velocity; acceleration from the equations).
    backlash : float
        Normal backlash [m].
    outputs : dict, optional
        Name -> displacement vector ``a`` (``a . q`` recorded).
    record_from : int
        First step recorded.
    """
    kbar = prep.mean_stiffness
    k_hat = np.asarray(prep.stiffness_harmonics)
    ke_hat = np.fft.rfft(prep.ke_grid)[:k_hat.size] / prep.n_time
    kc, ks = _real_series(k_hat)
    kec, kes = _real_series(ke_hat)
    w0 = 2.0 * math.pi / period
    j = np.arange(k_hat.size)

    def series(t: float) -> tuple[float, float]:
        c, s = np.cos(j * w0 * t), np.sin(j * w0 * t)
        return float(c @ kc + s @ ks), float(c @ kec + s @ kes)

    def mesh_r(delta_b: float, beta: float, t: float) -> tuple[float, float, float]:
        """Solve delta = delta_b - beta r(delta) on the consistent branch."""
        k, ke = series(t)
        d = (delta_b + beta * ke) / (1.0 + beta * (k - kbar))
        F = k * d - ke
        if F > 0:
            return d, F - kbar * d, F
        if math.isfinite(backlash):
            d = (delta_b + beta * (ke - k * backlash)) / (1.0 + beta * (k - kbar))
            F = k * d - ke + k * backlash
            if F < 0:
                return d, F - kbar * d, F
        d = delta_b / (1.0 - beta * kbar)
        return d, -kbar * d, 0.0

    a0, a1 = 4.0 / dt**2, 2.0 / dt
    Keff = K + a0 * M + a1 * C
    Kinv = np.linalg.inv(Keff)
    Kv = Kinv @ v
    beta = float(v @ Kv)
    q = np.asarray(q0, dtype=float).copy()
    qd = np.zeros_like(q)
    d0, r0, _ = mesh_r(float(v @ q), 0.0, 0.0)
    qdd = np.linalg.solve(M, load - v * r0 - K @ q)
    outputs = outputs or {}
    rec_t, rec_d, rec_f = [], [], []
    rec_o = {name: [] for name in outputs}
    for step in range(1, n_steps + 1):
        t = step * dt
        b = load + M @ (a0 * q + (4.0 / dt) * qd + qdd) + C @ (a1 * q + qd)
        qb = Kinv @ b
        d, r, F = mesh_r(float(v @ qb), beta, t)
        q_new = qb - Kv * r
        qd_new = a1 * (q_new - q) - qd
        qdd = a0 * (q_new - q) - (4.0 / dt) * qd - qdd
        q, qd = q_new, qd_new
        if step >= record_from:
            rec_t.append(t)
            rec_d.append(d)
            rec_f.append(F)
            for name, a in outputs.items():
                rec_o[name].append(float(a @ q))
    return TimeResponse(
        t=np.asarray(rec_t)[None], delta=np.asarray(rec_d)[None],
        force=np.asarray(rec_f)[None],
        channels={k: np.asarray(v_)[None] for k, v_ in rec_o.items()},
        status=np.zeros(1, dtype=np.int8), stats={"n_steps": n_steps, "dt": dt})
