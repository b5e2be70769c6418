"""Frequency response by the method of multiple scales (first or second order).

:func:`frequency_response` runs the compiled continuation of :mod:`.continuation` for every
sample (blocks of samples in threads, the kernels release the GIL) and returns every branch
at every grid frequency with its stability, the paths of upward and downward sweeps, the
separation data and the points where contact loss starts (EP Eqs. 36-37).

EP: Eritenel and Parker (2013), the paper this model follows (docs/models.md).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from gearuq._firstcall import FirstCallRoute
from gearuq_plugins.mesh_oscillator import continuation as ct
from gearuq_plugins.mesh_oscillator import slowflow as sf

#: Largest number of solutions kept per frequency (the theory gives one or three).
MAX_SOLUTIONS = 5
#: Largest number of points of a traced curve.
MAX_POINTS = 6000
#: Largest number of contact-loss onsets kept per sample.
MAX_ONSETS = 8
#: Small calls before the continuation is compiled run it as plain Python: about 3 ms of CPU
#: per sample and frequency with the closed-form separation (0.4-0.6 s for the default 201
#: frequencies), against 30 s for the compile (docs/benchmarks.md, "first minutes").
CONTINUATION_ROUTE = FirstCallRoute(
    ct.batch_response, "the mesh oscillator's continuation", unit_cpu=3e-3,
    compile_cpu=30.0)
#: The numerical separation costs about 80 times more per point interpreted (0.24 s per
#: sample and frequency measured), so it compiles from the first call on.
_NUMERICAL_WEIGHT = 80.0

TRACE_MEANINGS = {
    ct.TRACE_OK: "ok",
    ct.TRACE_START_FAILED: "no steady state found at the lowest frequency",
    ct.TRACE_STEP_UNDERFLOW: "continuation step underflow (the curve could not be followed)",
    ct.TRACE_TOO_MANY_POINTS: "continuation point limit reached",
    ct.TRACE_UNFORCED: "no forcing: the trivial solution",
    ct.TRACE_GRID_MISSED: "some grid frequencies were not reached by the traced curve",
}


@dataclass
class PerturbationResponse:
    """Perturbation frequency response of ``n`` samples on ``K`` frequencies.

    Attributes
    ----------
    amplitude, phase : ndarray, shape (n, K, MAX_SOLUTIONS)
        Every steady state ``(a, gamma)`` (NaN where fewer exist).
    position : ndarray, shape (n, K, MAX_SOLUTIONS)
        Place along the traced curve (orders the branches).
    stable : ndarray of int8, shape (n, K, MAX_SOLUTIONS)
        1 stable, 0 unstable, -1 no solution.
    separation : ndarray, shape (n, K, MAX_SOLUTIONS, N_SEP)
        Separation data (``slowflow.S_*``): Delta_0, Delta_1, nu_1, Delta_2, nu_2, contact
        margin and contact losses per period.
    count : ndarray of int, shape (n, K)
        Number of steady states.
    up, down : ndarray of int, shape (n, K)
        Index of the solution an upward / downward sweep lands on.
    onsets : ndarray, shape (n, MAX_ONSETS, 3)
        ``(Omega, a, gamma)`` where the contact margin changes sign along the curve, in the
        order of the curve (NaN-padded); ``n_onsets`` counts them.
    status : ndarray of int, shape (n,)
        Trace status (:data:`TRACE_MEANINGS`).
    n_points : ndarray of int, shape (n,)
        Points of the traced curve.
    """

    amplitude: np.ndarray
    phase: np.ndarray
    position: np.ndarray
    stable: np.ndarray
    separation: np.ndarray
    count: np.ndarray
    up: np.ndarray
    down: np.ndarray
    onsets: np.ndarray
    n_onsets: np.ndarray
    status: np.ndarray
    n_points: np.ndarray

    def path(self, which: str, field: str = "amplitude") -> np.ndarray:
        """Values of ``field`` along the ``"up"`` or ``"down"`` sweep path, shape (n, K)."""
        idx = self.up if which == "up" else self.down
        arr = getattr(self, field)
        safe = np.maximum(idx, 0)
        out = np.take_along_axis(arr, safe[..., None] if arr.ndim == 3 else
                                 safe[..., None, None], axis=2)
        out = out[..., 0] if arr.ndim == 3 else out[:, :, 0, :]
        if out.dtype.kind == "f":
            out = np.where((idx >= 0)[..., None] if out.ndim == 3 else idx >= 0, out, np.nan)
        return out


def frequency_response(coefs: np.ndarray, grids: np.ndarray, *, order: int = 2,
                       separation: str = "closed_form", parallel: bool = True,
                       ) -> PerturbationResponse:
    """Multiple-scales frequency response of every sample.

    Parameters
    ----------
    coefs : ndarray, shape (n, slowflow.N_COEF)
        Nondimensional coefficients (layout ``slowflow.C_*``).
    grids : ndarray, shape (n, K) or (K,)
        Strictly increasing excitation frequencies ``Omega`` per sample.
    order : {1, 2}
        First order (EP Eq. 27) or reconstituted second order (EP Eq. 31).
    separation : {"closed_form", "numerical"}
        Harmonics of the separation function from EP Eqs. 34-35 (one contact loss per
        period) or from the separation instants, Eqs. 32-33.
    parallel : bool
        Run blocks of samples in threads.

    Returns
    -------
    PerturbationResponse
    """
    if order not in (1, 2):
        raise ValueError(f"order={order!r} is outside its valid range: 1 or 2")
    if separation not in ("closed_form", "numerical"):
        raise ValueError(f"separation={separation!r}: valid 'closed_form', 'numerical'")
    # writable copies: numba types a read-only array apart, and a read-only argument (a
    # one-sample broadcast grid, a caller's frozen array) compiled the continuation a second
    # time (7 s of CPU)
    coefs = np.array(np.atleast_2d(coefs), dtype=float, order="C")
    n = coefs.shape[0]
    grids = np.array(np.broadcast_to(np.asarray(grids, dtype=float), (n, np.shape(grids)[-1])),
                     dtype=float, order="C")
    if grids.shape[1] < 1 or np.any(np.diff(grids, axis=1) <= 0) or np.any(grids <= 0):
        raise ValueError("frequencies must be > 0 and strictly increasing")
    k_grid = grids.shape[1]
    mode = sf.SEP_NUMERICAL if separation == "numerical" else sf.SEP_CLOSED_FORM
    shape = (n, k_grid, MAX_SOLUTIONS)
    sol = (np.full(shape, np.nan), np.full(shape, np.nan), np.full(shape, np.nan),
           np.full(shape, -1, np.int64), np.full(shape + (sf.N_SEP,), np.nan),
           np.zeros((n, k_grid), np.int64))
    up = np.full((n, k_grid), -1, np.int64)
    down = np.full((n, k_grid), -1, np.int64)
    onsets = np.full((n, MAX_ONSETS, 3), np.nan)
    n_onsets = np.zeros(n, np.int64)
    status = np.zeros(n, np.int64)
    n_points = np.zeros(n, np.int64)

    def args(lo: int, hi: int) -> tuple:
        return (coefs[lo:hi], order, mode, grids[lo:hi], MAX_POINTS,
                tuple(x[lo:hi] for x in sol), up[lo:hi], down[lo:hi], onsets[lo:hi],
                n_onsets[lo:hi], status[lo:hi], n_points[lo:hi])

    weight = _NUMERICAL_WEIGHT if mode == sf.SEP_NUMERICAL else 1.0
    kernel, route = CONTINUATION_ROUTE.choose(weight * n * k_grid, args(0, n))

    def run(lo: int, hi: int) -> None:
        kernel(*args(lo, hi))

    # the interpreted route holds the GIL: threads would only add overhead
    workers = min(os.cpu_count() or 1, n) if parallel and route == "compiled" else 1
    if workers <= 1:
        run(0, n)
    else:
        bounds = np.linspace(0, n, workers + 1).astype(int)
        with ThreadPoolExecutor(workers) as pool:
            list(pool.map(run, bounds[:-1], bounds[1:]))
    return PerturbationResponse(
        amplitude=sol[0], phase=sol[1], position=sol[2], stable=sol[3].astype(np.int8),
        separation=sol[4], count=sol[5], up=up, down=down, onsets=onsets,
        n_onsets=n_onsets, status=status, n_points=n_points)


def onset_first_order(coefs: np.ndarray) -> np.ndarray:
    """Frequencies where total contact loss starts, first order (EP Eq. 37), shape (n, 2).

    With ``alpha_{2,0} = e_1 = 0`` at first order, contact is lost at ``a = 1``; Eq. 27 with
    ``a = 1``, ``Delta_0 = 0`` gives ``sigma = 3/8 alpha_{3,0} -+ sqrt(F^2/4 - mu^2)`` with
    ``F = |q_1 e^{-i rho_1} - alpha_{0,1}|`` (the load harmonic taken at ``Omega = 1``).
    NaN where the forcing cannot reach ``a = 1`` (``F/2 < mu``). The principal parametric
    term ``alpha_{1,2}`` is not included (EP's Eq. 37 has none).
    """
    c = np.atleast_2d(coefs)
    force = np.abs(c[:, sf.C_Q1] * np.exp(-1j * c[:, sf.C_R1]) - c[:, sf.C_A01])
    disc = force**2 / 4.0 - c[:, sf.C_MU] ** 2
    root = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
    centre = 1.0 + 0.375 * c[:, sf.C_A30]
    return np.stack([centre - root, centre + root], axis=1)


def onset_amplitude(coefs: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    """Amplitude at the onset of total contact loss for a response phase ``gamma`` (Eq. 36).

    Contact is lost when ``R = |a e^{i gamma} - e_1 e^{i psi_1}|`` reaches
    ``1 - alpha_{2,0} a^2 / 2`` (Eq. 35 at ``tau = pi``). With the quadratic mean shift of
    Eq. 28 this is the quartic ``alpha20^2/4 a^4 - (1 + alpha20) a^2 + 2 e1 cos(gamma - psi1)
    a + 1 - e1^2 = 0`` (EP print ``alpha_{2,0} a / 2`` and a quadratic instead; see
    docs/theory/mesh_oscillator.md); the smallest positive root is returned (NaN if none).
    """
    c = np.atleast_2d(coefs)
    gamma = np.broadcast_to(np.asarray(gamma, dtype=float), (c.shape[0],))
    out = np.full(c.shape[0], np.nan)
    for i, row in enumerate(c):
        a20, e1 = row[sf.C_A20], row[sf.C_E1]
        poly = [a20**2 / 4.0, 0.0, -(1.0 + a20), 2.0 * e1 * np.cos(gamma[i] - row[sf.C_PSI1]),
                1.0 - e1**2]
        roots = np.roots(poly)
        real = roots[(np.abs(roots.imag) < 1e-10) & (roots.real > 0)].real
        if real.size:
            out[i] = real.min()
    return out
