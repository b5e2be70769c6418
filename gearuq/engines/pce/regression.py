"""Least squares, leave-one-out errors and sparse basis selection for chaos expansions.

* :func:`least_squares`: one QR for every output column; LOO residuals in closed form.
* :func:`greedy_path`: least angle regression (LAR, Efron et al. 2004) or orthogonal
  matching pursuit (OMP) over the basis columns, with the hybrid step of Blatman and Sudret
  (2011) done incrementally: every prefix of the path is refitted by least squares and its
  leave-one-out error computed *as the path grows*, by Gram-Schmidt updates of an orthonormal
  basis of the active columns (hat diagonal ``h += q_k^2``, residual ``r -= q_k (q_k^T r)``,
  trace of ``(Psi^T Psi)^-1`` from the inverse triangular factor). A step costs
  ``O(n (P + k))``; the path stops when the corrected LOO error has not improved for a while.
* :func:`corrected_loo`: the LOO error times Chapelle's factor
  ``T = n/(n - P) (1 + tr((Psi^T Psi)^-1))`` (Blatman 2009, eq. 3.42; OpenTURNS'
  ``CorrectedLeaveOneOut``), the criterion used to pick the basis along the path and the
  degree.

LOO errors are relative: mean squared LOO residual over the sample variance of the output.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import linalg

__all__ = ["SOLVERS", "few_blas_threads", "least_squares", "loo_residuals", "relative_error",
           "corrected_loo", "SparsePath", "greedy_path", "fit_columns", "pca"]

#: Sparse selection rules.
SOLVERS = ("lars", "omp")
#: Columns whose remainder after orthogonalisation falls below this fraction of their norm are
#: numerically dependent on the active ones and skipped.
_DEPENDENT = 1e-10


#: Basis matrices up to this many entries are fitted with one BLAS thread (see below).
SMALL_PROBLEM = 4_000_000


@contextlib.contextmanager
def few_blas_threads(n_entries: int) -> Iterator[None]:
    """One BLAS thread while fitting a basis matrix of ``n_entries`` entries or fewer.

    The greedy path and the refits are many small matrix products and QRs (512 x 60, say);
    a threaded BLAS gains nothing on them and, on a loaded machine, spin-waiting threads made
    one such QR take from 1 ms to 0.9 s (measured). Larger problems keep every thread.
    Without ``threadpoolctl`` nothing changes.
    """
    from gearuq._threads import one_blas_thread

    if n_entries > SMALL_PROBLEM:
        yield
        return
    with one_blas_thread("blas"):
        yield


def least_squares(psi: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares coefficients ``(P, m)``, hat diagonal ``(n,)`` and ``tr((Psi^T Psi)^-1)``.

    Raises
    ------
    numpy.linalg.LinAlgError
        For a numerically rank-deficient basis matrix.
    """
    q, r = np.linalg.qr(psi, mode="reduced")
    d = np.abs(np.diag(r))
    if d.size and d.min() <= 1e-12 * d.max():
        raise np.linalg.LinAlgError("rank-deficient basis matrix")
    coef = linalg.solve_triangular(r, q.T @ y, lower=False)
    h = np.sum(q * q, axis=1)
    r_inv = linalg.solve_triangular(r, np.eye(r.shape[0]), lower=False)
    return coef, h, float(np.sum(r_inv * r_inv))


def loo_residuals(psi: np.ndarray, y: np.ndarray, coef: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Leave-one-out residuals ``r_i / (1 - h_i)`` of a least-squares fit (exact)."""
    res = y - psi @ coef
    with np.errstate(divide="ignore", invalid="ignore"):
        return res / (1.0 - h)[:, None]


def relative_error(res: np.ndarray, y: np.ndarray) -> tuple[float, np.ndarray]:
    """Mean square of ``res`` over the variance of ``y``: variance-weighted scalar, per column."""
    mse = np.mean(res * res, axis=0)
    var = np.var(y, axis=0, ddof=1) if y.shape[0] > 1 else np.zeros(y.shape[1])
    tot = float(var.sum())
    with np.errstate(divide="ignore", invalid="ignore"):
        per = np.where(var > 0, mse / var, np.where(mse > 0, np.inf, 0.0))
    scalar = float(mse.sum() / tot) if tot > 0 else (0.0 if mse.sum() == 0 else math.inf)
    if not np.all(np.isfinite(res)):
        scalar = math.inf
    return scalar, per


def corrected_loo(loo: float, n: int, n_terms: int, trace_inverse_gram: float) -> float:
    """Chapelle's correction ``loo * n/(n - P) * (1 + tr((Psi^T Psi)^-1))`` (inf if n <= P)."""
    if n <= n_terms:
        return math.inf
    return loo * n / (n - n_terms) * (1.0 + trace_inverse_gram)


@dataclass
class SparsePath:
    """A greedy path and the errors of its least-squares refits.

    Attributes
    ----------
    order : list of int
        Basis columns in the order they entered (the constant column 0 first).
    loo, corrected : ndarray
        LOO and corrected LOO errors of the prefixes ``order[:k + 1]``, ``k = 1..``.
    best : int
        Number of columns of the prefix with the smallest corrected LOO error.
    """

    order: list[int]
    loo: np.ndarray
    corrected: np.ndarray
    best: int

    @property
    def selected(self) -> np.ndarray:
        """The columns of the best prefix, sorted."""
        return np.sort(np.asarray(self.order[:self.best], dtype=int))


class _OrthoLOO:
    """Gram-Schmidt basis of the active columns with LOO errors updated per column."""

    def __init__(self, n: int, kmax: int, y: np.ndarray) -> None:
        self.n = n
        self.q = np.empty((n, kmax + 1))
        self.q[:, 0] = 1.0 / math.sqrt(n)
        self.r_inv = np.zeros((kmax + 1, kmax + 1))
        self.r_inv[0, 0] = 1.0 / math.sqrt(n)
        self.k = 1
        self.res = y - y.mean()
        self.var = float(self.res @ self.res) / (n - 1)
        self.h = np.full(n, 1.0 / n)
        self.trace = 1.0 / n

    def add(self, column: np.ndarray) -> tuple[float, float] | None:
        """Append a column; its (LOO, corrected LOO), or None if it is dependent."""
        k, q = self.k, self.q[:, :self.k]
        v = column.copy()
        r1 = q.T @ v
        v -= q @ r1
        r2 = q.T @ v  # second pass: classical Gram-Schmidt twice is orthogonal to round-off
        v -= q @ r2
        norm = math.sqrt(float(v @ v))
        if norm <= _DEPENDENT * math.sqrt(float(column @ column)):
            return None
        qk = v / norm
        self.q[:, k] = qk
        top = -(self.r_inv[:k, :k] @ (r1 + r2)) / norm
        self.r_inv[:k, k] = top
        self.r_inv[k, k] = 1.0 / norm
        self.trace += float(top @ top) + 1.0 / (norm * norm)
        self.res -= qk * float(qk @ self.res)
        self.h += qk * qk
        self.k = k + 1
        if self.var <= 0:
            return 0.0, 0.0
        if self.h.max() >= 1.0 - 1e-12:
            return math.inf, math.inf
        e = self.res / (1.0 - self.h)
        loo = float(e @ e) / self.n / self.var
        return loo, corrected_loo(loo, self.n, self.k, self.trace)


def _standardised(psi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centred unit-norm non-constant columns (LAR's convention) and which are usable."""
    x = psi[:, 1:] - psi[:, 1:].mean(axis=0)
    norms = np.sqrt(np.einsum("ij,ij->j", x, x))
    usable = norms > 1e-12 * max(float(norms.max(initial=0.0)), 1e-300)
    x[:, usable] /= norms[usable]
    x[:, ~usable] = 0.0
    return x, usable


def greedy_path(psi: np.ndarray, y: np.ndarray, solver: str = "lars", *,
                patience: int = 20, max_terms: int | None = None) -> SparsePath:
    """Hybrid LAR / OMP: the greedy order of the columns and the LOO error of every prefix.

    Parameters
    ----------
    psi : ndarray (n, P)
        Basis matrix; column 0 must be the constant polynomial (always kept).
    y : ndarray (n,)
        One output column.
    solver : {"lars", "omp"}
        Least angle regression (the next column is the one whose correlation with the
        residual of the *LAR* estimate catches up first along the equiangular direction) or
        orthogonal matching pursuit (the column most correlated with the least-squares
        residual).
    patience : int
        The path stops once it has gone ``max(patience, best)`` columns past the best prefix
        (``best`` its size) without a smaller corrected LOO error.
    max_terms : int, optional
        Largest number of columns (default ``n - 2``).

    Returns
    -------
    SparsePath
    """
    if solver not in SOLVERS:
        raise ValueError(f"solver: unknown {solver!r}; valid: {', '.join(SOLVERS)}")
    n = psi.shape[0]
    x, free = _standardised(psi)
    kmax = max(1, min(int(free.sum()), n - 2, max_terms or n))
    ortho = _OrthoLOO(n, kmax, y)
    lar = _LarState(x, y, kmax) if solver == "lars" else None
    order, loo, corr = [0], [], []
    best, best_err = 1, math.inf
    corr_now = x.T @ ortho.res
    while free.any() and len(order) - 1 < kmax:
        scores = np.abs(corr_now) if lar is None else lar.scores()
        j = int(np.argmax(np.where(free, scores, -np.inf)))
        if not np.isfinite(scores[j]) or not free[j]:
            break
        free[j] = False
        added = lar is None or lar.activate(j)
        errors = ortho.add(psi[:, j + 1]) if added else None
        if errors is None:  # numerically dependent on the active columns: skip it for good
            if added and lar is not None:
                lar.active.pop()
            if lar is not None and not lar.step(free):
                break
            continue
        order.append(j + 1)
        loo.append(errors[0])
        corr.append(errors[1])
        if errors[1] < best_err:
            best, best_err = len(order), errors[1]
        elif len(order) - best > max(patience, best):
            break
        if lar is None:
            corr_now = x.T @ ortho.res
        elif not lar.step(free):
            break
    return SparsePath(order, np.asarray(loo), np.asarray(corr), best)


class _LarState:
    """Least angle regression on standardised columns, Cholesky factor updated per column."""

    def __init__(self, x: np.ndarray, y: np.ndarray, kmax: int) -> None:
        self.x = x
        self.c = x.T @ (y - y.mean())  # correlations with the residual of the LAR estimate
        self.chol = np.zeros((kmax, kmax))
        self.xa = np.empty((x.shape[0], kmax))
        self.active: list[int] = []
        self.gamma_next: np.ndarray | None = None

    def scores(self) -> np.ndarray:
        """Selection score: |c| on the first step, then minus the LAR step length."""
        return np.abs(self.c) if self.gamma_next is None else -self.gamma_next

    def activate(self, j: int) -> bool:
        """Add column ``j`` to the Cholesky factor; False if it is (nearly) dependent."""
        k = len(self.active)
        col = self.x[:, j]
        if k:
            g = self.xa[:, :k].T @ col
            low = linalg.solve_triangular(self.chol[:k, :k], g, lower=True, check_finite=False)
            d = 1.0 - float(low @ low)
        else:
            low, d = np.zeros(0), 1.0
        if d <= _DEPENDENT:
            return False
        self.chol[k, :k] = low
        self.chol[k, k] = math.sqrt(d)
        self.xa[:, k] = col
        self.active.append(j)
        return True

    def step(self, free: np.ndarray) -> bool:
        """Move along the equiangular direction to the next event; False when none is left."""
        k = len(self.active)
        c_active = self.c[self.active]
        signs = np.sign(c_active)
        w = linalg.cho_solve((self.chol[:k, :k], True), signs, check_finite=False)
        norm = 1.0 / math.sqrt(max(float(signs @ w), np.finfo(float).tiny))
        a = self.x.T @ (self.xa[:, :k] @ (w * norm))
        c_max = float(np.abs(c_active).max())
        tiny = np.finfo(float).eps * max(c_max, 1e-300)
        with np.errstate(divide="ignore", invalid="ignore"):
            g1 = (c_max - self.c) / (norm - a)
            g2 = (c_max + self.c) / (norm + a)
        g1[~free | ~(g1 > tiny)] = np.inf
        g2[~free | ~(g2 > tiny)] = np.inf
        gamma = np.minimum(g1, g2)
        j = int(np.argmin(gamma))
        if not np.isfinite(gamma[j]):
            return False
        self.c -= gamma[j] * a
        # the next column is the first to catch up; scores() ranks by the step length
        self.gamma_next = gamma
        return True


def fit_columns(psi: np.ndarray, y: np.ndarray, method: str, solver: str = "lars",
                n_select: int = 5) -> dict[str, Any]:
    """Fit every column of ``y`` ``(n, m)`` on one shared basis.

    ``method="regression"``: least squares on all columns of ``psi``. ``"sparse"``: a greedy
    path per target (for ``m > 1``, the ``n_select`` leading principal components of ``y``),
    the union of the selected columns refitted by least squares on every output column.

    Returns
    -------
    dict
        ``coef`` ``(P, m)`` (zeros outside the selected columns), ``loo_residuals``
        ``(n, m)``, ``columns`` (kept), ``trace`` (``tr((Psi^T Psi)^-1)`` of the kept columns).

    Raises
    ------
    numpy.linalg.LinAlgError
        Rank-deficient basis on this design.
    """
    if method == "sparse":
        if y.shape[1] == 1:
            targets = y
        else:  # selection on the leading principal components, union of the supports
            yc = y - y.mean(axis=0)
            u, s, _ = np.linalg.svd(yc, full_matrices=False)
            keep = max(1, min(n_select, int(np.sum(s > 1e-12 * (s[0] if s.size else 0)))))
            targets = u[:, :keep] * s[:keep]
        chosen: set[int] = set()
        for j in range(targets.shape[1]):
            chosen.update(int(c) for c in greedy_path(psi, targets[:, j], solver).selected)
        cols = np.array(sorted(chosen))
    else:
        cols = np.arange(psi.shape[1])
    sub = psi[:, cols]
    coef_sub, h, trace = least_squares(sub, y)
    coef = np.zeros((psi.shape[1], y.shape[1]))
    coef[cols] = coef_sub
    return {"coef": coef, "loo_residuals": loo_residuals(sub, y, coef_sub, h),
            "columns": cols, "trace": trace}


def pca(y: np.ndarray, compress: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """PCA of the centred columns: scores ``(n, k)``, components ``(k, m)``, mean, info.

    ``compress``: a number of components (int >= 1) or an energy fraction in (0, 1].
    """
    ybar = y.mean(axis=0)
    yc = y - ybar
    _, s, vt = np.linalg.svd(yc, full_matrices=False)
    energy = s**2
    total = energy.sum()
    if isinstance(compress, float) and 0.0 < compress <= 1.0:
        frac = np.cumsum(energy) / total if total > 0 else np.ones_like(energy)
        k = int(np.searchsorted(frac, compress - 1e-15) + 1)
    elif isinstance(compress, (int, np.integer)) and not isinstance(compress, bool) \
            and compress >= 1:
        k = int(compress)
    else:
        raise ValueError(f"compress: expected a number of components (int >= 1) or an energy "
                         f"fraction in (0, 1], got {compress!r}")
    k = min(k, vt.shape[0])
    lost = float(energy[k:].sum() / total) if total > 0 else 0.0
    return yc @ vt[:k].T, vt[:k], ybar, {"components": k, "energy_lost": lost}
