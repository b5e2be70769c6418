"""Gaussian copula (Nataf model): correlation input, checks and conversion to normal space.

The dependence of a :class:`~gearuq.space.ParameterSpace` is a Gaussian copula: the
correlation matrix ``R`` of the underlying standard normals ``z = Phi^-1(F(x))``. Rank
(Spearman, Kendall) correlations of the variables convert to ``R`` exactly
(``2 sin(pi rho_S / 6)``, ``sin(pi tau / 2)``); a Pearson (product-moment) correlation by
solving the Nataf integral.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from scipy import optimize

from gearuq.space.marginals import Marginal

__all__ = ["CORRELATION_TYPES", "parse_correlation", "check_correlation", "pearson_to_normal",
           "normal_correlation"]

#: Correlation inputs accepted by the constructor.
CORRELATION_TYPES = ("normal", "spearman", "kendall", "pearson")


def parse_correlation(corr: Any, names: list[str]) -> np.ndarray | None:
    """A ``(d, d)`` matrix from a matrix or a ``{(a, b): rho}`` mapping (None: independent)."""
    d = len(names)
    if corr is None:
        return None
    if isinstance(corr, Mapping):
        r = np.eye(d)
        for key, value in corr.items():
            if not (isinstance(key, tuple) and len(key) == 2):
                raise ValueError(
                    f"correlation: mapping keys must be (name, name) pairs, got {key!r}"
                )
            a, b = key
            for nm in (a, b):
                if nm not in names:
                    raise ValueError(
                        f"correlation: unknown parameter {nm!r}; valid: {', '.join(names)}"
                    )
            if a == b:
                raise ValueError(f"correlation: pair ({a!r}, {b!r}) is a diagonal entry")
            i, j = names.index(a), names.index(b)
            v = float(value)
            r[i, j] = r[j, i] = v
        return r
    r = np.array(corr, dtype=float)
    if r.shape != (d, d):
        raise ValueError(
            f"correlation: expected a {d}x{d} matrix for parameters {names}, got shape {r.shape}"
        )
    return r


def check_correlation(r: np.ndarray, names: list[str], what: str = "correlation") -> None:
    """Finite, unit diagonal, symmetric, entries in [-1, 1], positive definite; or ValueError."""
    d = len(names)
    if not np.all(np.isfinite(r)):
        i, j = np.argwhere(~np.isfinite(r))[0]
        raise ValueError(f"{what}[{i}, {j}] ({names[i]!r}, {names[j]!r}) is not finite")
    for i in range(d):
        if abs(r[i, i] - 1.0) > 1e-12:
            raise ValueError(
                f"{what}: diagonal entry for {names[i]!r} is {float(r[i, i])!r}, must be 1"
            )
    asym = np.abs(r - r.T)
    if asym.max() > 1e-12:
        i, j = np.unravel_index(np.argmax(asym), asym.shape)
        raise ValueError(
            f"{what}: not symmetric: [{i}, {j}] ({names[i]!r}, {names[j]!r}) = "
            f"{float(r[i, j])!r} but [{j}, {i}] = {float(r[j, i])!r}"
        )
    off = np.abs(r - np.eye(d))
    if off.max() > 1.0:
        i, j = np.unravel_index(np.argmax(off), off.shape)
        raise ValueError(
            f"{what}: entry ({names[i]!r}, {names[j]!r}) = {float(r[i, j])!r} outside [-1, 1]"
        )
    try:
        np.linalg.cholesky(r)
    except np.linalg.LinAlgError:
        w = np.linalg.eigvalsh(r)
        raise ValueError(
            f"{what}: matrix is not positive definite (smallest eigenvalue {w.min():.3g}); "
            f"parameters {names}"
        ) from None


def pearson_to_normal(mi: Marginal, mj: Marginal, rho: float, n_nodes: int = 48) -> float:
    """Nataf correction: normal-space correlation giving Pearson ``rho`` between mi and mj.

    Solves ``E[(X_i - m_i)(X_j - m_j)] / (s_i s_j) = rho`` for the correlation ``r`` of the
    underlying normals, the expectation by two-dimensional Gauss-Hermite quadrature.
    """
    if rho == 0.0:
        return 0.0
    z, w = np.polynomial.hermite_e.hermegauss(n_nodes)
    w = w / math.sqrt(2 * math.pi)
    gi = mi.from_normal(z)
    gj0 = mj.from_normal(z)
    ci = gi - w @ gi
    si = math.sqrt(w @ ci**2)
    mean_j = w @ gj0
    sj = math.sqrt(w @ (gj0 - mean_j) ** 2)

    def pearson(r: float) -> float:
        zz = r * z[:, None] + math.sqrt(max(1 - r * r, 0.0)) * z[None, :]
        gj = mj.from_normal(zz) - mean_j
        return float(w @ (ci[:, None] * gj) @ w) / (si * sj)

    lo, hi = pearson(-1.0), pearson(1.0)
    if not lo <= rho <= hi:
        raise ValueError(
            f"correlation: Pearson correlation {rho:g} between {mi.name!r} and {mj.name!r} is "
            f"not reachable with a Gaussian copula for these marginals; feasible range "
            f"[{lo:.6f}, {hi:.6f}]"
        )
    if rho == lo:
        return -1.0
    if rho == hi:
        return 1.0
    return float(optimize.brentq(lambda r: pearson(r) - rho, -1.0, 1.0, xtol=1e-13))



def normal_correlation(correlation: Any, correlation_type: str, marginals: Mapping[str, Marginal]
                       ) -> tuple[np.ndarray | None, dict[str, Any] | None]:
    """The normal-space correlation of a Gaussian copula from the user's input.

    Parameters
    ----------
    correlation : array_like, mapping or None
        ``(d, d)`` matrix in parameter order, ``{("a", "b"): rho}``, or None (independent).
    correlation_type : {"normal", "spearman", "kendall", "pearson"}
        What ``correlation`` holds (see :class:`~gearuq.space.ParameterSpace`).
    marginals : mapping
        Name -> :class:`Marginal`, in parameter order (Pearson conversion needs them).

    Returns
    -------
    r : ndarray or None
        Correlation of the underlying standard normals; None when independent.
    given : dict or None
        The user's rank/Pearson matrix for the record (``{"type", "matrix"}``), else None.
    """
    names = list(marginals)
    if correlation_type not in CORRELATION_TYPES:
        raise ValueError(
            f"correlation_type: unknown {correlation_type!r}; valid: "
            f"{', '.join(CORRELATION_TYPES)}"
        )
    given = parse_correlation(correlation, names)
    if given is None:
        return None, None
    what = "correlation" if correlation_type == "normal" else f"{correlation_type} correlation"
    check_correlation(given, names, what)
    record = None
    if correlation_type == "normal":
        r = given
    else:
        record = {"type": correlation_type, "matrix": given.tolist()}
        r = np.eye(len(names))
        for i in range(len(names)):
            for j in range(i + 1, len(names)):
                v = given[i, j]
                if correlation_type == "spearman":
                    v = 2.0 * math.sin(math.pi * v / 6.0)
                elif correlation_type == "kendall":
                    v = math.sin(math.pi * v / 2.0)
                else:
                    v = pearson_to_normal(marginals[names[i]], marginals[names[j]], float(v))
                r[i, j] = r[j, i] = v
        check_correlation(r, names, "correlation of the underlying normals (converted)")
    if np.array_equal(r, np.eye(len(names))):
        return None, record
    return r, record
