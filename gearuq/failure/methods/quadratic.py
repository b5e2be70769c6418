"""Exponentially tilted Gaussian for a failure set shaped by a quadratic form.

When the response is the RMS of something linear in the germ, its square is a quadratic form
``Q(u) = u^T A u + b^T u + c0`` and the failure set ``{Q >= L}`` is the outside of an
ellipsoid (a shell). Tilting the standard normal by ``exp(t Q)`` gives a Gaussian again,

    q_t(u) = phi(u) exp(t Q(u)) / M(t) = N(u; mu_t, Sigma_t),
    Sigma_t = (I - 2 t A)^-1,  mu_t = t Sigma_t b,

and ``t`` is chosen so that ``E_t[Q] = L`` (the saddle point: the tilted draws sit on the
failure boundary). On the failure set the weight ``phi / q_t = M(t) exp(-t Q)`` is at most
``M(t) exp(-t L)``: no heavy tail, whatever the number of directions the shell spans
(Bucklew, "Introduction to rare event simulation", Springer 2004, for the large-deviation
argument). ``A``, ``b``, ``c0`` are fitted by least squares to cheap-model runs; a poor fit
costs variance, never bias (the defensive component and the weights keep the estimator
unbiased).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["fit_quadratic", "tilted_gaussian", "quadratic_features"]


def quadratic_features(u: np.ndarray) -> np.ndarray:
    """Columns ``1, u_i, u_i u_j (i <= j)`` of a full quadratic in ``u``."""
    n, d = u.shape
    iu, ju = np.triu_indices(d)
    return np.column_stack([np.ones(n), u, u[:, iu] * u[:, ju]])


def fit_quadratic(u: np.ndarray, q: np.ndarray, ridge: float = 1e-6
                  ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Least-squares ``Q(u) = u^T A u + b^T u + c0`` to values ``q``; returns ``A`` (symmetric),
    ``b``, ``c0`` and the coefficient of determination ``R^2`` on the fitted points."""
    n, d = u.shape
    x = quadratic_features(u)
    scale = float(np.std(q)) or 1.0
    lhs = x.T @ x + ridge * n * np.eye(x.shape[1])
    coef = np.linalg.solve(lhs, x.T @ (q / scale)) * scale
    c0, b = float(coef[0]), coef[1:d + 1]
    iu, ju = np.triu_indices(d)
    a = np.zeros((d, d))
    a[iu, ju] = coef[d + 1:]
    a = 0.5 * (a + a.T)  # the off-diagonal coefficients are split over (i, j) and (j, i)
    resid = q - x @ coef
    r2 = 1.0 - float(np.var(resid) / np.var(q)) if np.var(q) > 0 else math.nan
    return a, b, c0, r2


def tilted_gaussian(a: np.ndarray, b: np.ndarray, c0: float, level: float,
                    max_var: float = 100.0) -> tuple[np.ndarray, np.ndarray, float]:
    """Mean, covariance and tilt ``t`` of the Gaussian ``phi exp(t Q)`` with ``E_t[Q] = level``.

    ``t`` lies in ``[0, t_max)`` with ``I - 2 t A`` positive definite and every variance of
    ``Sigma_t`` at most ``max_var`` (a nearly singular tilt would give a density far wider
    than the failure set); the bisection stops at that bound if ``level`` is not reached.
    """
    d = a.shape[0]
    lam, vec = np.linalg.eigh(a)
    lam_max = float(lam.max())
    if lam_max <= 0 and not np.any(b):
        return np.zeros(d), np.eye(d), 0.0
    # 1 - 2 t lam >= 1 / max_var for every positive eigenvalue
    t_hi = (1.0 - 1.0 / max_var) / (2.0 * lam_max) if lam_max > 0 else 1.0

    def moments(t: float) -> tuple[np.ndarray, np.ndarray, float]:
        s_eig = 1.0 / (1.0 - 2.0 * t * lam)
        sigma = (vec * s_eig) @ vec.T
        mu = t * sigma @ b
        mean_q = float(np.sum(lam * s_eig) + mu @ a @ mu + b @ mu + c0)
        return mu, sigma, mean_q

    lo, hi = 0.0, t_hi
    if moments(hi)[2] < level:
        mu, sigma, _ = moments(hi)
        return mu, sigma, hi
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if moments(mid)[2] < level:
            lo = mid
        else:
            hi = mid
    mu, sigma, _ = moments(hi)
    return mu, sigma, hi
