"""Von Mises-Fisher-Nakagami mixture: a biasing density for shell-like failure domains.

Papaioannou, Geyer and Straub, "Improved cross entropy-based importance sampling with a
flexible mixture model", Reliability Engineering and System Safety 191 (2019) 106564.

A point ``z`` of an ``r``-dimensional standard normal space is written as a radius
``R = |z|`` and a direction ``a = z / R``. Each component draws the direction from a
von Mises-Fisher density on the unit sphere (mean direction ``mu``, concentration ``kappa``;
``kappa = 0`` is uniform) and the radius from a Nakagami density (shape ``m``, spread
``Omega = E[R^2]``):

    q_k(z) = f_N(R; m_k, Omega_k) f_vMF(a; mu_k, kappa_k) / R^(r - 1).

The standard normal itself is of this form (uniform direction, ``R ~ chi_r``), so a failure
set ``{|W u| > c}`` (the RMS of a response linear in the germ) is covered by a single
component with a Nakagami radius just beyond the shell, where a Gaussian mixture either
misses most of the shell or inflates its variance in every direction. The parameters are
fitted by weighted expectation-maximisation (the cross-entropy update of the paper): the
weights are the importance weights of failing samples, or equal for samples of the failure
domain (e.g. the last level of subset simulation on a cheap model).

:class:`VMFNMixture` works in ``r`` directions (orthonormal ``basis``, ``d x r``) and is
standard normal across them, so the importance weights ``phi_d / q`` depend only on the
projection; it carries a **defensive** standard normal component of share ``a`` that bounds
every weight by ``1 / a``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special

__all__ = ["VMFNMixture", "fit_vmfn", "log_vmf_norm", "sample_vmf"]

#: Nakagami shape bounds (0.5: the half-normal; the upper bound keeps the radius spread
#: from vanishing on a few samples).
M_BOUNDS = (0.5, 1e5)
#: Smallest standard deviation of a component's radius (standard normal units). The
#: cross-entropy fit of the elite draws of a narrow radius density is narrower still, and the
#: levels feed that back until the radius is frozen short of the failure domain; the radius of
#: the standard normal itself spreads by about 0.7.
RADIUS_STD_MIN = 0.3
#: Largest von Mises-Fisher concentration.
KAPPA_MAX = 1e5


def log_vmf_norm(kappa: np.ndarray, r: int) -> np.ndarray:
    """``log C_r(kappa)``: the von Mises-Fisher normalising constant on the sphere of
    ``R^r`` (``C_r(0) = 1 / area``)."""
    kappa = np.asarray(kappa, dtype=float)
    nu = r / 2.0 - 1.0
    log_area = math.log(2.0) + (r / 2.0) * math.log(math.pi) - special.gammaln(r / 2.0)
    small = kappa < 1e-8
    k = np.where(small, 1.0, kappa)
    with np.errstate(divide="ignore"):
        val = nu * np.log(k) - (r / 2.0) * math.log(2 * math.pi) - (
            np.log(special.ive(nu, k)) + k)
    return np.where(small, -log_area, val)


def sample_vmf(mu: np.ndarray, kappa: float, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` unit vectors from the von Mises-Fisher density (Wood 1994 for ``r >= 2``)."""
    r = mu.size
    if n == 0:
        return np.empty((0, r))
    if kappa < 1e-8:
        g = rng.standard_normal((n, r))
        return g / np.linalg.norm(g, axis=1, keepdims=True)
    if r == 1:
        p_plus = 1.0 / (1.0 + math.exp(-2.0 * kappa * float(mu[0])))
        return np.where(rng.random(n) < p_plus, 1.0, -1.0)[:, None]
    p = r - 1.0
    b = p / (2.0 * kappa + math.sqrt(4.0 * kappa**2 + p**2))
    x0 = (1.0 - b) / (1.0 + b)
    c = kappa * x0 + p * math.log(1.0 - x0**2)
    w = np.empty(n)
    todo = np.arange(n)
    while todo.size:
        z = rng.beta(p / 2.0, p / 2.0, todo.size)
        wt = (1.0 - (1.0 + b) * z) / (1.0 - (1.0 - b) * z)
        ok = kappa * wt + p * np.log(1.0 - x0 * wt) - c >= np.log(rng.random(todo.size))
        w[todo[ok]] = wt[ok]
        todo = todo[~ok]
    v = rng.standard_normal((n, r))
    v -= np.outer(v @ mu, mu)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return w[:, None] * mu[None, :] + np.sqrt(np.clip(1.0 - w**2, 0.0, None))[:, None] * v


class VMFNMixture:
    """Defensive von Mises-Fisher-Nakagami mixture in ``r`` directions of ``R^d``.

    Parameters
    ----------
    mu : ndarray (K, r)
        Mean directions (unit vectors).
    kappa, m, omega, shares : ndarray (K,)
        Concentrations, Nakagami shapes and spreads, component shares (normalised here).
    defensive : float
        Share of the standard normal component of ``R^d``.
    basis : ndarray (d, r)
        Orthonormal columns: the directions in which the mixture lives (standard normal
        across them).
    scale : ndarray (r, r), optional
        Symmetric positive definite ``S``: the mixture is one of ``v = S^-1 z`` and
        ``z = S v`` (an elliptical shell; ``q_z(z) = q_v(S^-1 z) / det S``). ``None``: the
        identity.
    """

    def __init__(self, mu: np.ndarray, kappa: np.ndarray, m: np.ndarray, omega: np.ndarray,
                 shares: np.ndarray, defensive: float, basis: np.ndarray,
                 scale: np.ndarray | None = None) -> None:
        self.mu = np.atleast_2d(np.asarray(mu, dtype=float))
        self.kappa = np.asarray(kappa, dtype=float)
        self.m = np.asarray(m, dtype=float)
        self.omega = np.asarray(omega, dtype=float)
        self.shares = np.asarray(shares, dtype=float) / np.sum(shares)
        self.defensive = float(defensive)
        self.basis = np.asarray(basis, dtype=float)
        self.n_directions = self.basis.shape[1]
        self.scale = None if scale is None else np.asarray(scale, dtype=float)
        if self.scale is not None:
            val, vec = np.linalg.eigh(self.scale)
            self._inv_scale = (vec / val) @ vec.T
            self._log_det = float(np.sum(np.log(val)))
        if not 0.0 < self.defensive < 1.0:
            raise ValueError(f"defensive: must lie in (0, 1), got {defensive!r}")

    @property
    def n_components(self) -> int:
        """Number of von Mises-Fisher-Nakagami components (defensive excluded)."""
        return int(self.mu.shape[0])

    def component_log_pdf_r(self, z: np.ndarray) -> np.ndarray:
        """``log pi_k q_k(z)`` (n, K) in the ``r``-dimensional space."""
        if self.scale is not None:
            return self._component_log_pdf_v(z @ self._inv_scale) - self._log_det
        return self._component_log_pdf_v(z)

    def _component_log_pdf_v(self, z: np.ndarray) -> np.ndarray:
        r = self.n_directions
        rad = np.maximum(np.linalg.norm(z, axis=1), 1e-300)
        a = z / rad[:, None]
        m, om = self.m[None, :], self.omega[None, :]
        log_nak = (math.log(2.0) + m * np.log(m) - special.gammaln(m) - m * np.log(om)
                   + (2 * m - 1) * np.log(rad)[:, None] - m * rad[:, None] ** 2 / om)
        log_vmf = log_vmf_norm(self.kappa, r)[None, :] + self.kappa[None, :] * (a @ self.mu.T)
        return (np.log(self.shares)[None, :] + log_nak + log_vmf
                - (r - 1) * np.log(rad)[:, None])

    def log_weights(self, u: np.ndarray) -> np.ndarray:
        """``log(phi_d(u) / h(u))``, ``h = a phi_d + (1 - a) phi_{d-r} q_r``; at most
        ``log(1 / a)``."""
        z = u @ self.basis
        r = self.n_directions
        log_phi_r = -0.5 * np.sum(z * z, axis=1) - 0.5 * r * math.log(2 * math.pi)
        log_q = special.logsumexp(self.component_log_pdf_r(z), axis=1)
        ratio = np.column_stack([np.full(z.shape[0], math.log(self.defensive)),
                                 math.log1p(-self.defensive) + log_q - log_phi_r])
        return -special.logsumexp(ratio, axis=1)

    def sample_r(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` draws of the mixture in the ``r``-dimensional space (no defensive part)."""
        which = rng.choice(self.n_components, size=n, p=self.shares)
        out = np.empty((n, self.n_directions))
        for k in range(self.n_components):
            sel = np.flatnonzero(which == k)
            rad = np.sqrt(rng.gamma(self.m[k], self.omega[k] / self.m[k], sel.size))
            out[sel] = rad[:, None] * sample_vmf(self.mu[k], float(self.kappa[k]), sel.size,
                                                 rng)
        return out if self.scale is None else out @ self.scale

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` draws of ``h`` in ``R^d``."""
        d = self.basis.shape[0]
        u = rng.standard_normal((n, d))
        mixed = rng.random(n) >= self.defensive
        k = int(mixed.sum())
        if k:
            zz = self.sample_r(k, rng)
            um = u[mixed]
            um -= (um @ self.basis) @ self.basis.T  # the standard normal across the basis
            u[mixed] = um + zz @ self.basis.T
        return u

    def describe(self) -> str:
        """Components in words: share, concentration, radius mean and spread."""
        parts = []
        for k in range(self.n_components):
            mean_r = math.exp(special.gammaln(self.m[k] + 0.5) - special.gammaln(self.m[k])
                              + 0.5 * math.log(self.omega[k] / self.m[k]))
            parts.append(f"share {self.shares[k]:.2f}, kappa {self.kappa[k]:.3g}, radius "
                         f"{mean_r:.2f} (m {self.m[k]:.3g})")
        return f"{self.n_directions} directions; " + "; ".join(parts)


def _m_step(z: np.ndarray, rad: np.ndarray, a: np.ndarray, resp: np.ndarray
            ) -> tuple[np.ndarray, ...]:
    """Weighted maximum-likelihood parameters (Papaioannou et al. 2019, Eqs. 34-39):
    ``resp`` (n, K) are sample weight times responsibility."""
    r = z.shape[1]
    tot = resp.sum(axis=0)
    keep = tot > 1e-12 * tot.sum()
    resp, tot = resp[:, keep], tot[keep]
    shares = tot / tot.sum()
    mean_dir = (resp.T @ a) / tot[:, None]
    raw = np.maximum(np.linalg.norm(mean_dir, axis=1), 1e-300)
    mu = mean_dir / raw[:, None]
    # n_eff uniform directions have a mean resultant of squared length 1 / n_eff: without
    # this correction kappa ~ r / sqrt(n_eff) grows from noise alone, and the cross-entropy
    # levels feed it back until the density collapses onto one direction
    n_eff = tot**2 / np.maximum(np.sum(resp**2, axis=0), 1e-300)
    sq = np.clip((raw**2 - 1.0 / n_eff) / np.maximum(1.0 - 1.0 / n_eff, 1e-12), 0.0, None)
    length = np.clip(np.sqrt(sq), 1e-12, 1 - 1e-9)
    if r == 1:
        kappa = np.arctanh(length)  # the two-point vMF: E[a mu] = tanh(kappa)
    else:
        kappa = length * (r - length**2) / (1.0 - length**2)  # Banerjee et al. 2005
    kappa = np.where(length < 1e-6, 0.0, np.clip(kappa, 0.0, KAPPA_MAX))
    r2 = rad**2
    omega = (resp.T @ r2) / tot
    var = (resp.T @ r2**2) / tot - omega**2
    m = np.clip(omega**2 / np.maximum(var, 1e-300), *M_BOUNDS)
    # std(R) ~ sqrt(Omega / (4 m)) for a large shape: keep it at least RADIUS_STD_MIN
    m = np.clip(m, M_BOUNDS[0], np.maximum(omega / (4.0 * RADIUS_STD_MIN**2), M_BOUNDS[0]))
    return mu, kappa, m, omega, shares


def _weighted_log_lik(mix: VMFNMixture, z: np.ndarray, w: np.ndarray) -> tuple[float, np.ndarray]:
    lp = mix.component_log_pdf_r(z)
    tot = special.logsumexp(lp, axis=1)
    return float(w @ tot), np.exp(lp - tot[:, None])


def fit_vmfn(u: np.ndarray, weights: np.ndarray | None, basis: np.ndarray, defensive: float,
             max_components: int, seed: int, n_iter: int = 200, whiten: bool = False
             ) -> VMFNMixture:
    """Fit a von Mises-Fisher-Nakagami mixture to (weighted) points of the failure domain.

    Parameters
    ----------
    u : ndarray (n, d)
        Points in the standard normal space.
    weights : ndarray (n,) or None
        Non-negative sample weights (importance weights of failing samples; ``None``: equal).
    basis : ndarray (d, r)
        Orthonormal directions in which the mixture is fitted.
    defensive : float
        Share of the standard normal component.
    max_components : int
        Largest number of components; the number is chosen by BIC with the weights'
        effective sample size, each number started from spherical k-means on the
        directions.
    seed : int
    n_iter : int
        Largest number of EM iterations.
    whiten : bool
        Fit in ``v = S^-1 z`` with ``S`` the square root of the points' weighted second
        moment (eigenvalues kept in ``[1, 100]``, then scaled to determinant 1): an
        ellipsoidal shell ``{z^T A z > c}`` becomes nearly a round one, which a single
        uniform-direction component covers.

    Returns
    -------
    VMFNMixture
    """
    w = np.ones(u.shape[0]) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != (u.shape[0],) or np.any(w < 0) or not np.all(np.isfinite(w)):
        raise ValueError("weights: expected finite non-negative weights, one per point")
    sel = w > 0
    z, w = u[sel] @ basis, w[sel] / w[sel].sum()
    n, r = z.shape
    scale = None
    if whiten and n > 1:
        val, vec = np.linalg.eigh((z * w[:, None]).T @ z)
        val = np.clip(val, 1.0, 100.0)
        val /= np.exp(np.mean(np.log(val)))  # the radius carries the overall size
        scale = (vec * np.sqrt(val)) @ vec.T
        z = z @ ((vec / np.sqrt(val)) @ vec.T)
    if n == 0:
        raise ValueError("fit_vmfn: no point with a positive weight")
    ess = 1.0 / float(np.sum(w**2))
    rad = np.maximum(np.linalg.norm(z, axis=1), 1e-300)
    a = z / rad[:, None]
    rng = np.random.default_rng(seed)
    best, best_bic = None, math.inf
    n_par = r + 2  # direction (r - 1) + kappa + m + Omega ... + share
    for k in range(1, max_components + 1):
        if ess < 5 * k * n_par and k > 1:
            break
        # spherical k-means on the directions for the start
        centres = a[rng.choice(n, size=k, replace=False, p=w)] if k > 1 else a[:1]
        lab = np.zeros(n, dtype=int)
        for _ in range(20):
            lab = np.argmax(a @ centres.T, axis=1) if k > 1 else lab
            centres = np.array([(w[lab == j] @ a[lab == j]) if np.any(lab == j) else centres[j]
                                for j in range(k)])
            centres /= np.maximum(np.linalg.norm(centres, axis=1, keepdims=True), 1e-12)
        resp = np.zeros((n, k))
        resp[np.arange(n), lab] = 1.0
        mix = VMFNMixture(*_m_step(z, rad, a, resp * w[:, None]), defensive, basis)
        old = -math.inf
        for _ in range(n_iter):
            ll, resp = _weighted_log_lik(mix, z, w)
            mix = VMFNMixture(*_m_step(z, rad, a, resp * w[:, None]), defensive, basis)
            if ll - old < 1e-8 * max(1.0, abs(ll)):
                break
            old = ll
        ll, _ = _weighted_log_lik(mix, z, w)
        bic = -2.0 * ess * ll + (mix.n_components * (n_par + 1) - 1) * math.log(ess)
        if bic < best_bic:
            best, best_bic = mix, bic
    assert best is not None
    if scale is not None:  # the same parameters, now of v = S^-1 z
        best = VMFNMixture(best.mu, best.kappa, best.m, best.omega, best.shares, defensive,
                           basis, scale)
    return best
