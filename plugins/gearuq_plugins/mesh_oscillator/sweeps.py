"""Numerical time integration of the mesh oscillator: time responses and frequency sweeps.

A frequency sweep is one integration per sample and direction with a piecewise-constant
excitation frequency (:func:`gearuq_plugins.mesh_oscillator.kernels.schedule`): at each grid
frequency the oscillator runs ``settle`` periods, continuing from the state the previous
frequency left (so it stays on the branch it is on until that branch ends, as in a test-rig
run-up or run-down), then ``measure`` periods sampled ``points`` times per period. From the
samples: the fundamental amplitude and phase (discrete Fourier transform at the excitation
frequency), the mean, the smallest contact margin (refined by a parabola through the
smallest sample and its neighbours), the fraction of the period out of contact and a
settling indicator (spread of the per-period amplitudes over the measured periods).

All samples and both directions run in one call of :func:`gearuq.ode.solve_batch`.

EP: Eritenel and Parker (2013), the paper this model follows (docs/models.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from gearuq_plugins.mesh_oscillator import kernels as K


@dataclass
class OscillatorProblem:
    """Per-sample coefficient rows of one kernel (without schedule and frozen sides).

    Attributes
    ----------
    kind : int
        :data:`kernels.KIND_EXPANDED`, ``KIND_SEGMENTS`` or ``KIND_TABLE``.
    rows : ndarray, shape (n, n_par)
        Header and kernel block of every sample (the schedule offset is filled later).
    n_switch : int
        Number of switching functions.
    """

    kind: int
    rows: np.ndarray
    n_switch: int

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.rows.shape[0]

    def boundary(self, theta: np.ndarray) -> np.ndarray:
        """Contact boundary ``u_c(theta)`` per sample, shape ``(n, theta.size)``."""
        out = np.empty((self.n, theta.size))
        for i in range(self.n):
            out[i] = boundary_row(self.kind, self.rows[i], theta)
        return out

    def functions(self) -> tuple[Any, Any]:
        """The numba ``rhs`` and ``switch`` of the kernel."""
        rhs_name, switch_name = K.KERNELS[self.kind]
        return getattr(K, rhs_name), getattr(K, switch_name)


def header(n: int, n_switch: int, mu: np.ndarray, f0: np.ndarray, q: np.ndarray,
           rho: np.ndarray, q_exponent: float, block_len: int) -> np.ndarray:
    """Header rows (see :mod:`.kernels`) with room for a kernel block of ``block_len``."""
    q = np.atleast_2d(q)
    nq = q.shape[1]
    rows = np.zeros((n, K.H_BLOCK + block_len + 2 * nq))
    rows[:, K.H_NSWITCH] = n_switch
    rows[:, K.H_MU] = mu
    rows[:, K.H_F0] = f0
    rows[:, K.H_QOFF] = K.H_BLOCK + block_len
    rows[:, K.H_NQ] = nq
    rows[:, K.H_QEXP] = q_exponent
    rows[:, K.H_BLOCK + block_len:K.H_BLOCK + block_len + nq] = q
    rows[:, K.H_BLOCK + block_len + nq:] = rho
    return rows


def boundary_row(kind: int, row: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Contact boundary of one sample (first segment for ``segments``)."""
    b = K.H_BLOCK
    if kind == K.KIND_EXPANDED:
        n_ord, n_h = int(row[b]), int(row[b + 1])
        nn = (n_ord + 1) * (n_h + 1)
        e_off = b + 2 + 2 * nn
        uc = -np.ones_like(theta)
        for r in range(1, n_h + 1):
            uc += row[e_off + r - 1] * np.cos(r * theta - row[e_off + n_h + r - 1])
        return uc
    if kind == K.KIND_SEGMENTS:
        nh = int(row[b + 1])
        off = b + 2 + 1 + 2 * nh + 1
        n_seg = int(row[b])
        width = 1 + 2 * (2 * nh + 1)
        clear = [fourier_values(row, b + 2 + j * width + 2 + 2 * nh, nh, theta)
                 for j in range(n_seg)]
        del off
        return np.min(clear, axis=0)
    nh = int(row[b + 1])
    return fourier_values(row, b + 2 + int(row[b]), nh, theta)


def fourier_values(row: np.ndarray, off: int, nh: int, theta: np.ndarray) -> np.ndarray:
    """NumPy twin of :func:`kernels.fourier` on an array of phases."""
    val = np.full_like(theta, row[off], dtype=float)
    for r in range(1, nh + 1):
        val += row[off + 2 * r - 1] * np.cos(r * theta) + row[off + 2 * r] * np.sin(r * theta)
    return val


def _with_schedule(rows: np.ndarray, t_start: np.ndarray, omegas: np.ndarray) -> np.ndarray:
    n, n_par = rows.shape
    k_seg = omegas.shape[1]
    out = np.zeros((n, n_par + 1 + 2 * k_seg))
    out[:, :n_par] = rows
    out[:, K.H_SCHED] = n_par
    out[:, n_par] = k_seg
    out[:, n_par + 1:n_par + 1 + k_seg] = t_start
    out[:, n_par + 1 + k_seg:] = omegas
    return out


@dataclass
class SweepResult:
    """Measured steady states at every grid frequency, shape ``(n, K)`` unless noted."""

    amplitude: np.ndarray
    phase: np.ndarray
    mean: np.ndarray
    margin: np.ndarray
    separation: np.ndarray
    unsettled: np.ndarray
    samples: np.ndarray  # (n, K, measure * points) of u
    status: np.ndarray  # (n,)
    n_steps: np.ndarray
    n_events: np.ndarray
    settings: dict


def integrate_schedule(problem: OscillatorProblem, omegas: np.ndarray, settle: np.ndarray,
                       measure: int, points: int, y0: np.ndarray, *, rtol: float = 1e-8,
                       atol: float = 1e-10, method: str = "dop853",
                       parallel: bool = True) -> SweepResult:
    """Integrate through the frequencies ``omegas[i]`` (per sample, in sweep order).

    Parameters
    ----------
    problem : OscillatorProblem
        Kernel rows.
    omegas : ndarray, shape (n, K)
        Excitation frequencies in the order they are visited.
    settle : ndarray of int, shape (n,)
        Periods discarded at each frequency (transient).
    measure, points : int
        Periods measured and samples per period.
    y0 : ndarray, shape (n, 2)
        Initial state at the first frequency.
    rtol, atol, method, parallel
        Integrator settings (:func:`gearuq.ode.solve_batch`).
    """
    from gearuq.ode import solve_batch

    n, k_seg = omegas.shape
    periods = np.broadcast_to(np.asarray(settle)[:, None] + measure, omegas.shape)
    durations = 2.0 * np.pi * periods / omegas
    t_start = np.concatenate([np.zeros((n, 1)), np.cumsum(durations, axis=1)[:, :-1]], axis=1)
    frac = np.arange(measure * points) / points  # periods after the settle window
    t_eval = (t_start[:, :, None] + 2.0 * np.pi * (settle[:, None, None] + frac[None, None, :])
              / omegas[:, :, None]).reshape(n, -1)
    params = _with_schedule(problem.rows, t_start, omegas)
    rhs, switch = problem.functions()
    steps_per_period = 400  # generous bound: a period needs 10-60 steps at rtol 1e-8
    res = solve_batch(rhs, y0, params, t_eval, method=method, rtol=rtol, atol=atol,
                      switch=switch, n_switch=problem.n_switch, freeze_sides=True,
                      save=np.array([0]), parallel=parallel,
                      max_steps=int(steps_per_period * periods.sum(axis=1).max()) + 10_000)
    u = res.y[:, :, 0].reshape(n, k_seg, measure * points)
    theta = 2.0 * np.pi * frac
    return _measure(problem, u, theta, measure, points, res)


def _measure(problem: OscillatorProblem, u: np.ndarray, theta: np.ndarray, measure: int,
             points: int, res: Any) -> SweepResult:
    n, k_seg, m = u.shape
    phasor = np.exp(-1j * theta)
    c1 = 2.0 / m * (u * phasor).sum(axis=2)
    per_period = np.abs(2.0 / points * (u.reshape(n, k_seg, measure, points)
                                        * phasor[:points]).sum(axis=3))
    amp = np.abs(c1)
    spread = (per_period.max(axis=2) - per_period.min(axis=2)) / np.maximum(amp, 1e-300)
    uc = problem.boundary(theta[:points])  # (n, points): the boundary repeats every period
    marg = u.reshape(n, k_seg, measure, points)[:, :, -1, :] - uc[:, None, :]
    # smallest margin: parabola through the smallest sample and its periodic neighbours
    j = np.argmin(marg, axis=2)
    mm = np.take_along_axis(marg, j[..., None], 2)[..., 0]
    ml = np.take_along_axis(marg, ((j - 1) % points)[..., None], 2)[..., 0]
    mr = np.take_along_axis(marg, ((j + 1) % points)[..., None], 2)[..., 0]
    curv = ml - 2.0 * mm + mr
    with np.errstate(divide="ignore", invalid="ignore"):
        corr = np.where(curv > 0.0, (ml - mr) ** 2 / (8.0 * curv), 0.0)
    margin = mm - corr
    # fraction of the period out of contact: linear interpolation of the sign changes
    nxt = np.roll(marg, -1, axis=2)
    both = (marg < 0.0) & (nxt < 0.0)
    one = (marg < 0.0) != (nxt < 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        part = np.where(marg < 0.0, marg / (marg - nxt), nxt / (nxt - marg))
    sep = (both.sum(axis=2) + np.where(one, part, 0.0).sum(axis=2)) / points
    return SweepResult(
        amplitude=amp, phase=-np.angle(c1), mean=u.mean(axis=2), margin=margin,
        separation=sep, unsettled=spread, samples=u, status=res.status,
        n_steps=res.n_steps, n_events=res.n_events, settings=res.settings())


def settle_periods(mu: np.ndarray, omega_max: np.ndarray, tolerance: float,
                   minimum: int = 10) -> np.ndarray:
    """Periods for a transient of relative size 1 to decay below ``tolerance``, per sample.

    The free decay is ``exp(-mu T)`` and a period lasts ``2 pi / Omega``, so
    ``ceil(ln(1/tol) Omega / (2 pi mu))`` periods (at the sample's highest frequency, at
    least ``minimum``).
    """
    mu = np.maximum(np.asarray(mu, dtype=float), 1e-6)
    periods = np.ceil(math.log(1.0 / tolerance) * omega_max / (2.0 * math.pi * mu))
    return np.maximum(periods, minimum).astype(np.int64)


def expanded_problem(alpha: np.ndarray, phi: np.ndarray, e: np.ndarray, psi: np.ndarray,
                     mu: np.ndarray, q: np.ndarray, rho: np.ndarray,
                     q_exponent: float = 0.0) -> OscillatorProblem:
    """Rows of the expanded kernel (EP Eqs. 11-12).

    Parameters
    ----------
    alpha, phi : ndarray, shape (n, N + 1, R + 1)
        ``alpha[:, i, r]``, ``phi[:, i, r]``; ``alpha[:, 0, 0]`` is the mean load
        ``alpha_{0,0}`` and ``alpha[:, 1, 0]`` is 1 by the nondimensionalisation.
    e, psi : ndarray, shape (n, R)
        Harmonics ``r = 1..R`` of the contact boundary.
    mu : ndarray, shape (n,)
        Damping ratio.
    q, rho : ndarray, shape (n, R_q)
        External load harmonics ``r = 1..R_q``.
    q_exponent : float
        ``q_r`` scales with ``Omega^q_exponent``.
    """
    n, n1, r1 = alpha.shape
    nn = n1 * r1
    block = np.zeros((n, 2 + 2 * nn + 2 * (r1 - 1)))
    block[:, 0] = n1 - 1
    block[:, 1] = r1 - 1
    block[:, 2:2 + nn] = alpha.reshape(n, nn)
    block[:, 2 + nn:2 + 2 * nn] = phi.reshape(n, nn)
    block[:, 2 + 2 * nn:2 + 2 * nn + r1 - 1] = e[:, :r1 - 1]
    block[:, 2 + 2 * nn + r1 - 1:] = psi[:, :r1 - 1]
    rows = header(n, 1, mu, alpha[:, 0, 0], q, rho, q_exponent, block.shape[1])
    rows[:, K.H_BLOCK:K.H_BLOCK + block.shape[1]] = block
    return OscillatorProblem(K.KIND_EXPANDED, rows, 1)
