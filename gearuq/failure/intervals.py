"""Binomial confidence intervals and reliability indices.

Wilson score and Clopper-Pearson intervals on a failure count, the generalised reliability
index ``beta = -Phi^-1(pf)`` and its inverse, and the mean-value (Cornell) index, labelled as
such because it equals ``Phi^-1(R)`` only for a normally distributed response.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

__all__ = [
    "INTERVAL_METHODS",
    "wilson_interval",
    "clopper_pearson_interval",
    "binomial_interval",
    "interval_method",
    "beta_from_pf",
    "pf_from_beta",
    "mean_value_beta",
]

#: Accepted names of the binomial confidence-interval methods.
INTERVAL_METHODS = ("wilson", "clopper-pearson")


# =========================================================================== intervals
def _check_counts(k: Any, n: Any, confidence: float) -> tuple[np.ndarray, np.ndarray, float]:
    if not 0.0 < float(confidence) < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    k_arr = np.asarray(k, dtype=float)
    n_arr = np.asarray(n, dtype=float)
    k_arr, n_arr = np.broadcast_arrays(k_arr, n_arr)
    if np.any(~np.isfinite(k_arr)) or np.any(~np.isfinite(n_arr)):
        raise ValueError("k and n must be finite")
    if np.any(n_arr < 1):
        raise ValueError(f"n must be >= 1 (got min n = {np.min(n_arr):g})")
    if np.any(k_arr < 0) or np.any(k_arr > n_arr):
        raise ValueError("k must satisfy 0 <= k <= n")
    return k_arr, n_arr, float(confidence)


def wilson_interval(k: Any, n: Any, confidence: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Wilson score interval for a binomial proportion (vectorised).

    Parameters
    ----------
    k : array_like
        Number of "successes" (here: failures), ``0 <= k <= n``.
    n : array_like
        Number of trials (valid samples), ``n >= 1``; broadcast against ``k``.
    confidence : float
        Two-sided confidence level, e.g. 0.95.

    Returns
    -------
    lower, upper : ndarray
        Interval ends, exactly 0 where ``k = 0`` and exactly 1 where ``k = n``.

    Notes
    -----
    With ``z = Phi^-1(1 - alpha/2)`` and ``p = k/n``::

        centre = (p + z^2/(2n)) / (1 + z^2/n)
        half   = z sqrt(p(1-p)/n + z^2/(4n^2)) / (1 + z^2/n)

    Its coverage is close to nominal on average (it can dip below nominal for some ``p``),
    which makes it the usual default for Monte Carlo failure probabilities.
    """
    k_arr, n_arr, conf = _check_counts(k, n, confidence)
    z = stats.norm.isf((1.0 - conf) / 2.0)
    p = k_arr / n_arr
    denom = 1.0 + z * z / n_arr
    centre = (p + z * z / (2.0 * n_arr)) / denom
    half = z * np.sqrt(p * (1.0 - p) / n_arr + z * z / (4.0 * n_arr * n_arr)) / denom
    lower = np.clip(centre - half, 0.0, 1.0)
    upper = np.clip(centre + half, 0.0, 1.0)
    lower = np.where(k_arr == 0, 0.0, lower)
    upper = np.where(k_arr == n_arr, 1.0, upper)
    return lower, upper


def clopper_pearson_interval(
    k: Any, n: Any, confidence: float = 0.95
) -> tuple[np.ndarray, np.ndarray]:
    """Clopper-Pearson ("exact") interval for a binomial proportion (vectorised).

    Parameters
    ----------
    k, n, confidence
        As in :func:`wilson_interval`.

    Returns
    -------
    lower, upper : ndarray
        ``lower = B^-1(alpha/2; k, n-k+1)`` (0 where ``k = 0``) and
        ``upper = B^-1(1-alpha/2; k+1, n-k)`` (1 where ``k = n``), with ``B^-1`` the beta
        quantile. For ``k = 0`` the upper end is ``1 - (alpha/2)^(1/n)``.

    Notes
    -----
    The coverage is at least the nominal level for every ``p`` (conservative).
    """
    k_arr, n_arr, conf = _check_counts(k, n, confidence)
    alpha = 1.0 - conf
    with np.errstate(invalid="ignore", divide="ignore"):
        lower = stats.beta.ppf(alpha / 2.0, k_arr, n_arr - k_arr + 1.0)
        upper = stats.beta.isf(alpha / 2.0, k_arr + 1.0, n_arr - k_arr)
    lower = np.where(k_arr == 0, 0.0, lower)
    upper = np.where(k_arr == n_arr, 1.0, upper)
    return np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)


def interval_method(interval: str) -> str:
    key = str(interval).strip().lower().replace("_", "-")
    if key in ("cp", "exact"):
        key = "clopper-pearson"
    if key not in INTERVAL_METHODS:
        raise ValueError(
            f"interval {interval!r} unknown; valid: {', '.join(map(repr, INTERVAL_METHODS))}"
        )
    return key


def binomial_interval(
    k: Any, n: Any, confidence: float = 0.95, method: str = "wilson"
) -> tuple[np.ndarray, np.ndarray]:
    """Dispatch to :func:`wilson_interval` or :func:`clopper_pearson_interval` by name."""
    if interval_method(method) == "wilson":
        return wilson_interval(k, n, confidence)
    return clopper_pearson_interval(k, n, confidence)


# =========================================================================== beta helpers
def beta_from_pf(pf: Any) -> Any:
    """Generalised reliability index ``beta = -Phi^-1(pf) = Phi^-1(1 - pf)``.

    Computed with the normal inverse survival function, so it stays accurate for tiny ``pf``.
    Returns ``+inf`` for ``pf = 0`` and ``-inf`` for ``pf = 1`` (:func:`reliability` never
    reports those: it gives the one-sided bound from the confidence interval instead).
    """
    out = stats.norm.isf(np.asarray(pf, dtype=float))
    return float(out) if np.ndim(out) == 0 else out


def pf_from_beta(beta: Any) -> Any:
    """Failure probability ``pf = Phi(-beta)`` of a generalised reliability index."""
    out = stats.norm.sf(np.asarray(beta, dtype=float))
    return float(out) if np.ndim(out) == 0 else out


def mean_value_beta(samples: Any, lower: float | None = None, upper: float | None = None) -> Any:
    """Mean-value (Cornell) reliability index of response samples.

    ``beta_MV = (mu - lower) / sigma`` for a lower limit, ``(upper - mu) / sigma`` for an upper
    limit and the minimum of both for a two-sided band, with ``mu`` the sample mean and
    ``sigma`` the sample standard deviation (``ddof=1``).

    .. warning::
       This is the **mean-value (Cornell) index**, a second-moment measure. It equals the
       generalised index ``Phi^-1(R)`` reported by :func:`reliability` only when the response
       is normally distributed (and, for a two-sided band, only when the other side's
       probability is negligible). Do not convert it with ``Phi(-beta)`` for skewed
       responses such as vibration amplitudes.

    Parameters
    ----------
    samples : array_like or xarray.DataArray
        Response samples along axis 0 (or along dim ``sample`` for a DataArray); extra
        axes/dims (e.g. ``time``) give one index each.
    lower, upper : float, optional
        Band limits; at least one is required.

    Returns
    -------
    float, ndarray or xarray.DataArray
        ``beta_MV``; a DataArray carries ``attrs["long_name"]`` naming it as the Cornell index.
    """
    if lower is None and upper is None:
        raise ValueError("mean_value_beta: give lower and/or upper")
    if lower is not None and upper is not None and lower >= upper:
        raise ValueError(f"mean_value_beta: lower={lower!r} must be < upper={upper!r}")
    if isinstance(samples, xr.DataArray):
        dim = "sample" if "sample" in samples.dims else samples.dims[0]
        if not bool(np.isfinite(samples).all()):
            raise ValueError("mean_value_beta: samples contain non-finite values")
        if samples.sizes[dim] < 2:
            raise ValueError("mean_value_beta: at least 2 samples are needed")
        mu = samples.mean(dim)
        sigma = samples.std(dim, ddof=1)
    else:
        arr = np.asarray(samples, dtype=float)
        if arr.ndim == 0 or arr.shape[0] < 2:
            raise ValueError("mean_value_beta: at least 2 samples are needed")
        if not np.all(np.isfinite(arr)):
            raise ValueError(
                f"mean_value_beta: samples contain {int(np.sum(~np.isfinite(arr)))} "
                "non-finite value(s)"
            )
        mu = arr.mean(axis=0)
        sigma = arr.std(axis=0, ddof=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        sides = []
        if lower is not None:
            sides.append((mu - lower) / sigma)
        if upper is not None:
            sides.append((upper - mu) / sigma)
        beta = sides[0] if len(sides) == 1 else np.minimum(sides[0], sides[1])
    if isinstance(beta, xr.DataArray):
        beta.attrs = {
            "units": "1",
            "long_name": "mean-value (Cornell) reliability index beta_MV = (mu - limit)/sigma",
            "note": "equals Phi^-1(R) only for a normally distributed response",
        }
        return beta
    return float(beta) if np.ndim(beta) == 0 else np.asarray(beta)
