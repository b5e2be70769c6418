"""Gaussian mixtures for multi-fidelity importance sampling: the directions in which
explored points differ from standard normal draws, and a defensive mixture fitted there
(:class:`~gearuq.failure.methods.biasing.Gaussian`)."""

from __future__ import annotations

import math

import numpy as np

from gearuq.failure.methods.importance import Mixture

__all__ = ["informative_directions", "weighted_directions", "fit_mixture"]


def informative_directions(u: np.ndarray, chain_factor: float = 10.0) -> np.ndarray:
    """Orthonormal directions (columns, ``d x r``) along which the points ``u`` differ from
    standard normal draws by more than sampling noise.

    The second moment ``S = u^T u / n`` of ``n`` standard normal points has its eigenvalues
    inside the Marchenko-Pastur edge ``(1 + sqrt(d / n_eff))^2``; a direction of ``S`` above it
    is where the failure domain pulls the points (a shift or a spread). Subset simulation's
    points are Markov-chain states in chains of length ``1 / p0`` = 10, so at worst one
    independent point per chain: ``n_eff = n / chain_factor``. Directions below the
    edge would only be narrowed, which ``min_std`` undoes anyway. With none above the edge,
    the direction of the mean.
    """
    n, d = u.shape
    second = u.T @ u / n
    val, vec = np.linalg.eigh(second)
    edge = (1.0 + math.sqrt(d / max(n / chain_factor, 1.0))) ** 2
    keep = vec[:, val > edge]
    if keep.shape[1] == 0:
        mean = u.mean(axis=0)
        norm = float(np.linalg.norm(mean))
        keep = (mean / norm)[:, None] if norm > 0 else np.eye(d)[:, :1]
    return keep


def weighted_directions(u: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Orthonormal directions (``d x r``) along which importance-weighted points ``u`` differ
    from standard normal draws by more than sampling noise: the eigenvectors of their weighted
    second moment above the Marchenko-Pastur edge ``(1 + sqrt(d / n_eff))^2``, ``n_eff`` the
    weights' effective sample size (independent draws, unlike subset simulation's chains);
    with none above it, the direction of the weighted mean."""
    d = u.shape[1]
    w = np.asarray(weights, dtype=float)
    w = w / w.sum()
    n_eff = 1.0 / float(np.sum(w**2))
    second = (u * w[:, None]).T @ u
    val, vec = np.linalg.eigh(0.5 * (second + second.T))
    keep = vec[:, val > (1.0 + math.sqrt(d / n_eff)) ** 2]
    if keep.shape[1] == 0:
        mean = w @ u
        norm = float(np.linalg.norm(mean))
        keep = (mean / norm)[:, None] if norm > 0 else np.eye(d)[:, :1]
    return keep


def fit_mixture(u: np.ndarray, max_components: int, defensive: float, seed: int,
                min_std: float = 1.0, subspace: str = "auto") -> Mixture:
    """Gaussian mixture (components by BIC) fitted to points ``u`` of the standard normal
    space, with a defensive standard normal component; with fewer than ``2 (r + 1)`` points
    one component at their mean with the unit covariance.

    With ``subspace="auto"`` the mixture is fitted in the ``r`` informative directions of
    :func:`informative_directions` only and is standard normal across them: in many
    dimensions, a fitted mean and covariance carry sampling noise in every direction, and the
    weights ``phi / q`` multiply that noise over all of them (on the 60-input rotor study
    the full fit gave degenerate weights at Pf ~ 0.1). ``"full"`` fits all ``d`` directions.

    Every component's covariance has its eigenvalues kept in ``[min_std^2, 9]``. A component
    narrower than the failure set it stands for starves its edges, and one narrower than the
    standard normal along the direction towards the origin gives weights ``phi / q`` that grow
    without bound behind its mean (heavy-tailed weights); ``min_std = 1`` bounds that growth.
    """
    from sklearn.mixture import GaussianMixture

    from gearuq._threads import one_blas_thread

    n, d = u.shape
    basis = informative_directions(u) if subspace == "auto" and n > 0 else np.eye(d)
    z = u @ basis
    r = basis.shape[1]
    if n < 2 * (r + 1):
        centre = u.mean(axis=0)[None, :] if n else np.zeros((1, d))
        return Mixture(centre, np.eye(d)[None], np.ones(1), defensive)
    best, best_bic = None, math.inf
    kinds = "full" if n >= 10 * r else "diag"
    with one_blas_thread():
        for k in range(1, max_components + 1):
            if n < k * 2 * (r + 1):
                break
            gm = GaussianMixture(k, covariance_type=kinds, reg_covar=1e-3,
                                 random_state=seed % 2**32, n_init=2).fit(z)
            bic = gm.bic(z)
            if bic < best_bic:
                best, best_bic = gm, bic
    covs = best.covariances_ if kinds == "full" else np.array([np.diag(c) for c in
                                                                best.covariances_])
    val, vec = np.linalg.eigh(covs)
    covs = np.einsum("kij,kj,klj->kil", vec, np.clip(val, min_std**2, 9.0), vec)
    # back to the full space: the fitted part in the informative directions, the standard
    # normal across them
    means = best.means_ @ basis.T
    full = np.eye(d)[None] + np.einsum("ia,kab,jb->kij", basis, covs - np.eye(r)[None], basis)
    mix = Mixture(means, full, best.weights_, defensive)
    mix.n_directions = r
    return mix
