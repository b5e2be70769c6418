"""The polynomial basis of a chaos expansion: multi-indices, orthonormal polynomials, germ maps.

The expansion lives in the *germ*: the independent standardised variables behind a
parameter space. An independent uniform marginal gets a Legendre germ ``z = 2 F(x) - 1`` on
``[-1, 1]``; every other marginal, and every parameter of a correlated space, a standard
normal germ through the Nataf map ``z = L^-1 Phi^-1(F(x))`` with ``L`` the Cholesky factor of
the normal-space correlation (for a normal marginal the exact affine map ``(x - mean)/std``,
so polynomial models stay polynomial).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import chaospy as cp
import numpy as np
from scipy import linalg, special

from gearuq.space import ParameterSpace

__all__ = ["multi_indices", "univariate", "basis_matrix", "Germ", "GERMS"]

#: Germ choices: ``"auto"`` (Legendre for independent uniforms, Hermite otherwise) or
#: ``"normal"`` (Hermite everywhere).
GERMS = ("auto", "normal")


def multi_indices(dim: int, order: int, truncation: float = 1.0) -> np.ndarray:
    """Multi-indices of total degree <= ``order`` kept by the hyperbolic q-norm truncation.

    Parameters
    ----------
    dim : int
        Number of germ variables.
    order : int
        Largest total degree.
    truncation : float
        ``q`` in (0, 1]: keep ``alpha`` with ``(sum_i alpha_i^q)^(1/q) <= order``. ``q = 1`` is
        the full total-degree set; smaller ``q`` drops high-order interactions first.

    Returns
    -------
    ndarray of int, shape (P, dim)
        Graded (by total degree) multi-indices, the constant term first. The set of a lower
        order is a subset of the set of a higher one (same ``q``).
    """
    idx = np.asarray(cp.glexindex(0, order + 1, dimensions=dim, graded=True), dtype=int)
    idx = idx.reshape(-1, dim)
    if truncation < 1.0:
        idx = idx[q_norm(idx, truncation) <= order + 1e-9]
    return idx


def q_norm(indices: np.ndarray, truncation: float) -> np.ndarray:
    """Hyperbolic q-norm ``(sum_i alpha_i^q)^(1/q)`` of each multi-index (row)."""
    if truncation >= 1.0:
        return indices.sum(axis=1).astype(float)
    return np.sum(indices.astype(float) ** truncation, axis=1) ** (1.0 / truncation)


def univariate(z: np.ndarray, kind: str, degree: int) -> np.ndarray:
    """Orthonormal polynomials of degrees ``0..degree`` at ``z``, shape ``(degree + 1, n)``.

    ``kind="normal"``: probabilists' Hermite ``He_k / sqrt(k!)`` (standard normal weight);
    ``kind="uniform"``: Legendre ``sqrt(2k + 1) P_k`` (uniform weight on ``[-1, 1]``); both
    by their three-term recurrences, exact and cheap on 10^6 points.
    """
    out = np.empty((degree + 1, z.size))
    out[0] = 1.0
    if degree == 0:
        return out
    if kind == "normal":  # He_{k+1} = z He_k - k He_{k-1}, normalised by sqrt(k!)
        out[1] = z
        for k in range(1, degree):
            out[k + 1] = (z * out[k] - math.sqrt(k) * out[k - 1]) / math.sqrt(k + 1)
        return out
    # Legendre: (k+1) P_{k+1} = (2k+1) z P_k - k P_{k-1}
    p_prev, p = np.ones_like(z), z.copy()
    out[1] = math.sqrt(3.0) * p
    for k in range(1, degree):
        p_prev, p = p, ((2 * k + 1) * z * p - k * p_prev) / (k + 1)
        out[k + 1] = math.sqrt(2 * k + 3) * p
    return out


def basis_matrix(z: np.ndarray, indices: np.ndarray, kinds: list[str]) -> np.ndarray:
    """The orthonormal basis at germ points ``z`` ``(n, d)``: matrix ``(n, P)``."""
    n = z.shape[0]
    psi = np.ones((n, indices.shape[0]))
    for j, kind in enumerate(kinds):
        deg = int(indices[:, j].max()) if indices.size else 0
        if deg == 0:
            continue
        psi *= univariate(z[:, j], kind, deg)[indices[:, j]].T
    return psi


class Germ:
    """The map between physical parameters of a space and its independent germ.

    Parameters
    ----------
    space : ParameterSpace
        The input space.
    germ : {"auto", "normal"}
        ``"auto"``: Legendre germ for independent uniform marginals, Hermite otherwise;
        ``"normal"``: Hermite everywhere.
    kinds : list of str, optional
        Germ kind per parameter (``"normal"`` or ``"uniform"``), when rebuilding a saved
        surrogate; overrides ``germ``.
    """

    def __init__(self, space: ParameterSpace, germ: str = "auto",
                 kinds: list[str] | None = None) -> None:
        if germ not in GERMS:
            raise ValueError(f"germ: unknown {germ!r}; valid: {', '.join(GERMS)}")
        self.space = space
        self.names = space.names
        corr = space.correlation
        self.chol = None if corr is None else np.linalg.cholesky(corr)
        if kinds is None:
            kinds = ["uniform" if (germ == "auto" and self.chol is None
                                   and space.marginal(k).kind == "uniform") else "normal"
                     for k in self.names]
        elif len(kinds) != len(self.names) or not set(kinds) <= {"normal", "uniform"} or (
                self.chol is not None and "uniform" in kinds):
            raise ValueError(f"germ kinds {kinds!r} do not fit the space {self.names}")
        self.kinds = list(kinds)

    def joint(self) -> cp.Distribution:
        """chaospy distribution of the germ (for quadrature rules)."""
        return cp.J(*(cp.Normal(0, 1) if k == "normal" else cp.Uniform(-1, 1)
                      for k in self.kinds))

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Uniform design ``(n, d)`` -> germ points ``(n, d)``."""
        u = np.clip(u, 1e-16, 1 - 2**-53)
        return np.column_stack([special.ndtri(u[:, j]) if k == "normal" else 2 * u[:, j] - 1
                                for j, k in enumerate(self.kinds)])

    def to_physical(self, z: np.ndarray) -> dict[str, np.ndarray]:
        """Germ points ``(n, d)`` -> parameter dict."""
        zc = z if self.chol is None else z @ self.chol.T
        out = {}
        for j, (name, kind) in enumerate(zip(self.names, self.kinds, strict=True)):
            m = self.space.marginal(name)
            out[name] = m.from_normal(zc[:, j]) if kind == "normal" else m.inv((zc[:, j] + 1) / 2)
        return out

    def from_physical(self, x: Mapping[str, Any]) -> np.ndarray:
        """Parameter dict -> germ points ``(n, d)``."""
        cols = []
        for name, kind in zip(self.names, self.kinds, strict=True):
            m = self.space.marginal(name)
            v = np.asarray(x[name], dtype=float)
            if kind == "uniform":
                cols.append(2.0 * m.cdf(v) - 1.0)
            elif m.kind == "normal":  # exact affine map, no cdf round trip in the tails
                cols.append((v - m.params["mean"]) / m.params["std"])
            else:
                cols.append(special.ndtri(np.clip(m.cdf(v), 0.0, 1.0)))
        z = np.column_stack(cols)
        if self.chol is not None:
            z = linalg.solve_triangular(self.chol, z.T, lower=True).T
        return z

    def labels(self) -> list[str]:
        """What each germ variable stands for.

        Independent space: the parameter names. Correlated space: the Cholesky (Nataf)
        innovations in parameter order, ``"x1"``, ``"x2 | x1"``, ``"x3 | x1, x2"``: the first
        carries all of ``x1`` including what it shares with the others, each later one only
        the part of its parameter not explained by the parameters before it.
        """
        if self.chol is None:
            return list(self.names)
        return [n if j == 0 else f"{n} | {', '.join(self.names[:j])}"
                for j, n in enumerate(self.names)]
