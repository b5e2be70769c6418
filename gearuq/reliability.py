"""Reliability from response samples: bands, instantaneous / system / first-passage estimates.

A *limit state* in gearuq is an allowed **band** ``[lower, upper]`` on one model output (either
side may be open). A sample *fails* a band at an instant when its value lies outside the closed
interval (values equal to a limit are safe); with ``absolute=True`` the band applies to
``|value|``, which suits vibration amplitudes.

:func:`reliability` turns a Monte Carlo result Dataset (dims ``sample`` and optionally ``time``,
a per-sample ``status`` flag, see :mod:`gearuq.model`) into

- per-band ("mode") and series-system failure probabilities at every instant,
- first-passage (cumulative) failure probabilities over the time window,
- confidence intervals (Wilson score or Clopper-Pearson) on every probability,
- the generalised reliability index ``beta = Phi^-1(R) = -Phi^-1(pf)`` with its interval,
  finite even when no (or every) sample fails: it is then a one-sided bound and flagged.

Samples whose ``status`` is nonzero (the solver gave up) are neither safe nor failed: they are
excluded from the estimates, counted (``n_invalid``) and their possible effect is shown by
``pf_if_invalid_failed`` / ``pf_if_invalid_safe``.

The mean-value (Cornell) index :func:`mean_value_beta` is offered separately and labelled as
such: it equals ``Phi^-1(R)`` only for a normally distributed response.
"""

from __future__ import annotations

import json
import math
import sys
import types
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

__all__ = [
    "Band",
    "reliability",
    "mean_value_beta",
    "beta_from_pf",
    "pf_from_beta",
    "wilson_interval",
    "clopper_pearson_interval",
    "binomial_interval",
    "INTERVAL_METHODS",
]

#: Accepted names of the binomial confidence-interval methods.
INTERVAL_METHODS = ("wilson", "clopper-pearson")

SYSTEM_MODE = "system"


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


def _interval_method(interval: str) -> str:
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
    if _interval_method(method) == "wilson":
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


# =========================================================================== Band
class Band:
    """Allowed interval on one model output: the limit state of a failure mode.

    Parameters
    ----------
    output : str
        Name of the output variable in the result Dataset.
    lower, upper : float, optional
        Closed band limits in the output's units; ``None`` (or -inf/+inf) leaves a side open.
        At least one side must be given and ``lower < upper``.
    name : str, optional
        Label of the failure mode (default: the output name, with ``|...|`` for absolute bands).
    absolute : bool
        Apply the band to ``|value|`` (vibration amplitudes, signed deflections).
    select : mapping, optional
        ``xarray`` label selection applied to the output first, e.g. ``{"dof": "x1"}``. Dims
        other than ``sample`` and ``time`` that remain after selection expand the band into one
        mode per element, labelled ``"name[dof=x1]"``.

    Notes
    -----
    A sample fails at an instant when ``value < lower`` or ``value > upper`` (``|value|`` when
    ``absolute``); a value equal to a limit is safe.
    """

    __slots__ = ("output", "lower", "upper", "name", "absolute", "select")

    def __init__(
        self,
        output: str,
        lower: float | None = None,
        upper: float | None = None,
        *,
        name: str | None = None,
        absolute: bool = False,
        select: Mapping[str, Any] | None = None,
    ) -> None:
        if not isinstance(output, str) or not output:
            raise ValueError(f"Band: output must be a non-empty string, got {output!r}")
        lo = -math.inf if lower is None else float(lower)
        up = math.inf if upper is None else float(upper)
        if math.isnan(lo) or math.isnan(up):
            raise ValueError(f"Band on {output!r}: limits must not be NaN (lower={lower}, "
                             f"upper={upper})")
        if lo >= up:
            raise ValueError(
                f"Band on {output!r}: lower={lo:g} must be < upper={up:g}"
            )
        if lo == -math.inf and up == math.inf:
            raise ValueError(f"Band on {output!r}: both sides open; give lower and/or upper")
        if absolute and up <= 0:
            raise ValueError(
                f"Band on {output!r}: absolute band needs upper > 0 (|value| >= 0), got {up:g}"
            )
        if name is not None and (not isinstance(name, str) or not name):
            raise ValueError(f"Band on {output!r}: name must be a non-empty string")
        self.output = output
        self.lower = lo
        self.upper = up
        self.absolute = bool(absolute)
        self.select = dict(select) if select else {}
        self.name = name if name is not None else (f"|{output}|" if absolute else output)

    # ------------------------------------------------------------------ helpers
    def __repr__(self) -> str:
        parts = [repr(self.output)]
        if self.lower > -math.inf:
            parts.append(f"lower={self.lower!r}")
        if self.upper < math.inf:
            parts.append(f"upper={self.upper!r}")
        parts.append(f"name={self.name!r}")
        if self.absolute:
            parts.append("absolute=True")
        if self.select:
            parts.append(f"select={self.select!r}")
        return f"Band({', '.join(parts)})"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Band):
            return NotImplemented
        return all(getattr(self, s) == getattr(other, s) for s in self.__slots__)

    def __hash__(self) -> int:
        return hash((self.output, self.lower, self.upper, self.name, self.absolute))

    def describe(self) -> str:
        """Human-readable safe set, e.g. ``"-1 <= |y| <= 2"``."""
        v = f"|{self.output}|" if self.absolute else self.output
        if self.lower > -math.inf and self.upper < math.inf:
            return f"{self.lower:g} <= {v} <= {self.upper:g}"
        if self.lower > -math.inf:
            return f"{v} >= {self.lower:g}"
        return f"{v} <= {self.upper:g}"

    def fails(self, values: Any) -> np.ndarray:
        """Boolean failure indicator of ``values`` (True = outside the band).

        Raises
        ------
        ValueError
            If ``values`` contains NaN (a NaN is neither safe nor failed).
        """
        v = np.asarray(values, dtype=float)
        if np.isnan(v).any():
            raise ValueError(
                f"Band {self.name!r}: {int(np.isnan(v).sum())} NaN value(s); a NaN is neither "
                "safe nor failed"
            )
        if self.absolute:
            v = np.abs(v)
        return (v < self.lower) | (v > self.upper)

    def pf_from_distribution(self, dist: Any) -> float:
        """Probability of leaving the band under a (frozen scipy) distribution of the output.

        Uses ``cdf``/``sf`` tails separately so small probabilities keep full precision.
        """
        pf = 0.0
        if self.absolute:
            pf += float(dist.sf(self.upper)) + float(dist.cdf(-self.upper))
            if self.lower > 0:
                pf += float(dist.cdf(self.lower)) - float(dist.cdf(-self.lower))
        else:
            if self.upper < math.inf:
                pf += float(dist.sf(self.upper))
            if self.lower > -math.inf:
                pf += float(dist.cdf(self.lower))
        return min(max(pf, 0.0), 1.0)


def _as_bands(bands: Any) -> list[Band]:
    if isinstance(bands, Band):
        return [bands]
    out: list[Band] = []
    if isinstance(bands, Mapping):
        for key, spec in bands.items():
            if isinstance(spec, Band):
                out.append(spec)
            elif isinstance(spec, Mapping):
                out.append(Band(key, **spec))
            elif isinstance(spec, Sequence) and not isinstance(spec, str) and len(spec) == 2:
                out.append(Band(key, spec[0], spec[1]))
            else:
                raise ValueError(
                    f"bands[{key!r}]: expected (lower, upper), a Band or a dict of Band "
                    f"arguments, got {spec!r}"
                )
    elif isinstance(bands, Iterable) and not isinstance(bands, str):
        for b in bands:
            if not isinstance(b, Band):
                raise ValueError(f"bands: expected Band objects, got {type(b).__name__}")
            out.append(b)
    else:
        raise ValueError(
            "bands: expected a Band, a list of Bands or a dict {output: (lower, upper)}"
        )
    if not out:
        raise ValueError("bands: empty; give at least one band")
    return out


# =========================================================================== reliability
_VAR_DOC = {
    "n_failures": ("number of valid samples outside the band", "int"),
    "pf": ("failure probability estimate k/n over valid samples", "float"),
    "pf_lower": ("lower confidence bound of the failure probability", "float"),
    "pf_upper": ("upper confidence bound of the failure probability", "float"),
    "r": ("reliability R = 1 - pf", "float"),
    "r_lower": ("lower confidence bound of R (= 1 - pf_upper)", "float"),
    "r_upper": ("upper confidence bound of R (= 1 - pf_lower)", "float"),
    "beta": (
        "generalised reliability index Phi^-1(R) = -Phi^-1(pf); where no sample fails it is the "
        "lower bound -Phi^-1(pf_upper), where all fail the upper bound -Phi^-1(pf_lower) "
        "(see the *_is_*_bound flags)",
        "float",
    ),
    "beta_lower": ("lower confidence bound of beta, -Phi^-1(pf_upper) (-inf if pf_upper=1)",
                   "float"),
    "beta_upper": ("upper confidence bound of beta, -Phi^-1(pf_lower) (+inf if pf_lower=0)",
                   "float"),
    "beta_is_lower_bound": ("1 where no valid sample failed and beta is a lower bound", "flag"),
    "beta_is_upper_bound": ("1 where every valid sample failed and beta is an upper bound",
                            "flag"),
    "cov_pf": (
        "coefficient of variation of the pf estimator sqrt((1 - pf)/(n pf)) (+inf where pf=0)",
        "float",
    ),
    "pf_if_invalid_failed": (
        "conservative pf counting invalid (status != 0) samples as failed: "
        "(k + n_invalid)/(n + n_invalid)",
        "float",
    ),
    "pf_if_invalid_safe": (
        "optimistic pf counting invalid (status != 0) samples as safe: k/(n + n_invalid)",
        "float",
    ),
}


def _var_name(stem: str, first_passage: bool) -> str:
    """``pf_lower`` -> ``pf_first_passage_lower`` etc."""
    if not first_passage:
        return stem
    for head in ("n_failures", "cov_pf", "beta", "pf", "r"):
        if stem == head or stem.startswith(head + "_"):
            if head == "n_failures":
                return "n_failures_first_passage"
            return head + "_first_passage" + stem[len(head):]
    raise AssertionError(stem)  # pragma: no cover


def _estimates(
    k: np.ndarray, n: int, n_invalid: int, confidence: float, method: str
) -> dict[str, np.ndarray]:
    k = np.asarray(k, dtype=np.int64)
    kf = k.astype(float)
    pf = kf / n
    lo, up = binomial_interval(kf, float(n), confidence, method)
    none_fail = k == 0
    all_fail = k == n
    beta_lower = stats.norm.isf(up)
    beta_upper = stats.norm.isf(lo)
    with np.errstate(divide="ignore", invalid="ignore"):
        beta = stats.norm.isf(pf)
        cov = np.where(none_fail, np.inf, np.sqrt((1.0 - pf) / (n * pf)))
    beta = np.where(none_fail, beta_lower, beta)
    beta = np.where(all_fail, beta_upper, beta)
    total = n + n_invalid
    return {
        "n_failures": k.astype(np.int32),
        "pf": pf,
        "pf_lower": lo,
        "pf_upper": up,
        "r": 1.0 - pf,
        "r_lower": 1.0 - up,
        "r_upper": 1.0 - lo,
        "beta": beta,
        "beta_lower": beta_lower,
        "beta_upper": beta_upper,
        "beta_is_lower_bound": none_fail.astype(np.int8),
        "beta_is_upper_bound": all_fail.astype(np.int8),
        "cov_pf": cov,
        "pf_if_invalid_failed": (kf + n_invalid) / total,
        "pf_if_invalid_safe": kf / total,
    }


def _select_time(ds: xr.Dataset, time: Any) -> xr.Dataset:
    if time is None:
        return ds
    if "time" not in ds.dims:
        raise ValueError("time: the Dataset has no 'time' dimension to select from")
    if isinstance(time, slice):
        out = ds.sel(time=time)
    elif isinstance(time, tuple) and len(time) == 2:
        out = ds.sel(time=slice(time[0], time[1]))
    else:
        t = np.atleast_1d(np.asarray(time, dtype=float))
        out = ds.sel(time=t, method="nearest")
    if out.sizes.get("time", 0) == 0:
        raise ValueError(f"time: selection {time!r} contains no output instant")
    return out


def _mode_arrays(
    ds: xr.Dataset, band: Band, valid: np.ndarray, has_time: bool
) -> list[tuple[str, dict[str, Any], np.ndarray]]:
    """Failure indicators (n_valid, n_time) for each mode produced by ``band``."""
    if band.output not in ds.data_vars:
        outs = [k for k, v in ds.data_vars.items() if v.attrs.get("role") == "output"]
        valid_names = outs or list(ds.data_vars)
        raise ValueError(
            f"band {band.name!r}: output {band.output!r} not in the Dataset; "
            f"available outputs: {', '.join(valid_names)}"
        )
    da = ds[band.output]
    if "sample" not in da.dims:
        raise ValueError(f"band {band.name!r}: output {band.output!r} has no 'sample' dim")
    if band.select:
        try:
            da = da.sel(band.select)
        except (KeyError, ValueError) as exc:
            raise ValueError(
                f"band {band.name!r}: select={band.select!r} failed on output "
                f"{band.output!r} with dims {da.dims}: {exc}"
            ) from exc
    extra = [d for d in da.dims if d not in ("sample", "time")]
    order = ["sample", *extra] + (["time"] if "time" in da.dims else [])
    da = da.transpose(*order)
    values = np.asarray(da.values, dtype=float)[valid]
    bad = ~np.isfinite(values)
    if bad.any():
        rows = np.flatnonzero(bad.reshape(values.shape[0], -1).any(axis=1))
        sample_ids = np.asarray(ds["sample"].values)[valid][rows] if "sample" in ds.coords else rows
        raise ValueError(
            f"output {band.output!r}: {int(bad.sum())} non-finite value(s) in "
            f"{rows.size} sample(s) with status 0 (first: sample {sample_ids[0]}); a valid "
            "sample must be finite - the model should have flagged it with a nonzero status"
        )
    meta = {
        "output": band.output,
        "lower": band.lower,
        "upper": band.upper,
        "absolute": int(band.absolute),
        "output_units": str(da.attrs.get("units", "")),
        "definition": band.describe(),
    }
    n_t = ds.sizes["time"] if has_time else 1
    time_dep = "time" in da.dims
    extra_shape = tuple(da.sizes[d] for d in extra)
    out = []
    for idx in np.ndindex(*extra_shape) if extra else [()]:
        sub = values[(slice(None), *idx)]
        f = band.fails(sub)
        f = f.reshape(f.shape[0], -1) if time_dep else np.repeat(f[:, None], n_t, axis=1)
        label = band.name
        if extra:
            parts = []
            for d, i in zip(extra, idx, strict=True):
                lab = da[d].values[i] if d in da.coords else i
                parts.append(f"{d}={lab}")
            label = f"{band.name}[{', '.join(parts)}]"
        out.append((label, meta, f))
    return out


def reliability(
    ds: xr.Dataset,
    bands: Band | Sequence[Band] | Mapping[str, Any],
    *,
    confidence: float = 0.95,
    interval: str = "wilson",
    system: bool = True,
    first_passage: bool = True,
    time: Any = None,
) -> xr.Dataset:
    """Instantaneous, system and first-passage reliability of response samples.

    Parameters
    ----------
    ds : xarray.Dataset
        Model result with dim ``sample`` (and ``time`` for time-dependent outputs) and,
        normally, a per-sample ``status`` variable (0 = ok). Without ``status`` every sample is
        taken as valid (recorded in the attrs).
    bands : Band, list of Band or dict
        Failure modes. A dict maps an output name to ``(lower, upper)`` (``None`` = open side),
        to a :class:`Band` or to a dict of :class:`Band` keyword arguments.
    confidence : float
        Two-sided confidence level of the intervals.
    interval : {"wilson", "clopper-pearson"}
        Binomial interval method (see :func:`wilson_interval`, :func:`clopper_pearson_interval`).
    system : bool
        Add the series-system mode ``"system"``: a sample fails when ANY band fails at that
        instant. Computed from the same samples, so the dependence between modes is kept.
    first_passage : bool
        Add first-passage (cumulative) estimates ``*_first_passage``: a sample has failed by
        ``t`` if it left its band at any instant ``<= t`` of the (selected) window. Only when
        some band output depends on time.
    time : slice, (t0, t1), array_like or scalar, optional
        Restrict the window: a slice / pair selects by label, values select the nearest
        instants. The first-passage window starts at the first selected instant.

    Returns
    -------
    xarray.Dataset
        Dims ``mode`` (band labels, then ``"system"``) and ``time`` (if any band output has
        it). Variables (all units "1"): ``n_failures``, ``pf``, ``pf_lower``, ``pf_upper``,
        ``r``, ``r_lower``, ``r_upper``, ``beta``, ``beta_lower``, ``beta_upper``,
        ``beta_is_lower_bound``, ``beta_is_upper_bound`` (int8 flags), ``cov_pf``,
        ``pf_if_invalid_failed``, ``pf_if_invalid_safe``; the same with ``_first_passage``
        after the stem (``pf_first_passage``, ``pf_first_passage_upper``, ...); scalars
        ``n_samples``, ``n_valid``, ``n_invalid``. Mode coordinates ``output``, ``lower``,
        ``upper`` (+-inf for open sides; NaN for the system), ``absolute``, ``output_units``,
        ``definition``.

    Raises
    ------
    ValueError
        Unknown output, bad band, no valid sample, a non-finite output value in a valid
        (status 0) sample, duplicate mode labels, unsorted time.

    Notes
    -----
    ``beta = Phi^-1(R)`` is the generalised reliability index. Where no valid sample fails,
    ``pf = 0`` and ``beta`` reports the finite lower bound ``-Phi^-1(pf_upper)`` with
    ``beta_is_lower_bound = 1``; where every sample fails, ``beta = -Phi^-1(pf_lower)`` is an
    upper bound (``beta_is_upper_bound = 1``). The interval ends ``beta_upper`` (no failure)
    and ``beta_lower`` (all failed) are then infinite, which is exact.
    """
    if not isinstance(ds, xr.Dataset):
        raise ValueError(f"reliability: ds must be an xarray.Dataset, got {type(ds).__name__}")
    method = _interval_method(interval)
    if not 0.0 < float(confidence) < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    band_list = _as_bands(bands)
    if "sample" not in ds.dims:
        raise ValueError("reliability: the Dataset has no 'sample' dimension")
    ds = _select_time(ds, time)

    n_samples = int(ds.sizes["sample"])
    if n_samples == 0:
        raise ValueError("reliability: the Dataset has no samples")
    if "status" in ds.data_vars:
        status = np.asarray(ds["status"].values)
        if status.shape != (n_samples,):
            raise ValueError(f"status must have shape (n_samples,), got {status.shape}")
        valid = status == 0
        status_note = (
            "samples with nonzero status (solver failure) are excluded from every estimate; "
            "they are neither safe nor failed. n_invalid counts them; pf_if_invalid_failed / "
            "pf_if_invalid_safe show the estimate if they had all failed / all been safe"
        )
    else:
        valid = np.ones(n_samples, dtype=bool)
        status_note = "no status variable in the input: every sample was taken as valid"
    n_valid = int(valid.sum())
    n_invalid = n_samples - n_valid
    if n_valid == 0:
        raise ValueError(
            f"reliability: no valid sample (all {n_samples} have nonzero status); "
            "nothing can be estimated"
        )

    used_outputs = {b.output for b in band_list}
    missing = sorted(o for o in used_outputs if o not in ds.data_vars)
    if missing:
        outs = [k for k, v in ds.data_vars.items() if v.attrs.get("role") == "output"]
        raise ValueError(
            f"band output(s) {', '.join(map(repr, missing))} not in the Dataset; available "
            f"outputs: {', '.join(outs or list(ds.data_vars))}"
        )
    has_time = any("time" in ds[o].dims for o in used_outputs)
    if has_time:
        tvals = np.asarray(ds["time"].values)
        if tvals.size > 1 and np.any(np.diff(tvals.astype(float)) < 0):
            raise ValueError("reliability: time must be sorted in increasing order")
    n_t = ds.sizes["time"] if has_time else 1

    labels: list[str] = []
    metas: list[dict[str, Any]] = []
    k_inst: list[np.ndarray] = []
    k_fp: list[np.ndarray] = []
    sys_inst = np.zeros((n_valid, n_t), dtype=bool)
    for band in band_list:
        for label, meta, f in _mode_arrays(ds, band, valid, has_time):
            if label in labels or label == SYSTEM_MODE:
                raise ValueError(
                    f"duplicate or reserved mode label {label!r}; give each Band a distinct "
                    f"name=... (reserved: {SYSTEM_MODE!r})"
                )
            labels.append(label)
            metas.append(meta)
            k_inst.append(f.sum(axis=0))
            if first_passage and has_time:
                k_fp.append(np.logical_or.accumulate(f, axis=1).sum(axis=0))
            if system:
                sys_inst |= f
    if system:
        labels.append(SYSTEM_MODE)
        metas.append({
            "output": "*", "lower": math.nan, "upper": math.nan, "absolute": 0,
            "output_units": "", "definition": "series system: fails if any mode fails",
        })
        k_inst.append(sys_inst.sum(axis=0))
        if first_passage and has_time:
            k_fp.append(np.logical_or.accumulate(sys_inst, axis=1).sum(axis=0))

    dims: tuple[str, ...] = ("mode", "time") if has_time else ("mode",)

    def shape(a: list[np.ndarray]) -> np.ndarray:
        arr = np.stack(a)
        return arr if has_time else arr[:, 0]

    coords: dict[str, Any] = {
        "mode": ("mode", np.array(labels, dtype=str), {"long_name": "failure mode"}),
        "output": ("mode", np.array([m["output"] for m in metas], dtype=str),
                   {"long_name": "output variable of the band"}),
        "lower": ("mode", np.array([m["lower"] for m in metas], dtype=float),
                  {"long_name": "band lower limit (output units; -inf = open)"}),
        "upper": ("mode", np.array([m["upper"] for m in metas], dtype=float),
                  {"long_name": "band upper limit (output units; +inf = open)"}),
        "absolute": ("mode", np.array([m["absolute"] for m in metas], dtype=np.int8),
                     {"long_name": "1 if the band applies to |value|", "units": "1"}),
        "output_units": ("mode", np.array([m["output_units"] for m in metas], dtype=str),
                         {"long_name": "units of the band limits"}),
        "definition": ("mode", np.array([m["definition"] for m in metas], dtype=str),
                       {"long_name": "safe set of the mode"}),
    }
    if has_time:
        coords["time"] = ("time", ds["time"].values, dict(ds["time"].attrs))
    out = xr.Dataset(coords=coords)

    sets = [(False, shape(k_inst))]
    if first_passage and has_time:
        sets.append((True, shape(k_fp)))
    for fp, k in sets:
        for stem, arr in _estimates(k, n_valid, n_invalid, confidence, method).items():
            doc, kind = _VAR_DOC[stem]
            if fp:
                doc = "first-passage (failed at any instant <= t in the window): " + doc
            attrs = {"units": "1", "long_name": doc}
            if kind == "flag":
                attrs["flag_values"] = np.array([0, 1], dtype=np.int8)
                attrs["flag_meanings"] = "point_estimate bound"
            out[_var_name(stem, fp)] = (dims, arr, attrs)

    out["n_samples"] = ((), np.int32(n_samples), {"units": "1", "long_name": "samples in input"})
    out["n_valid"] = ((), np.int32(n_valid), {
        "units": "1", "long_name": "samples with status 0 used in every estimate"})
    out["n_invalid"] = ((), np.int32(n_invalid), {
        "units": "1", "long_name": "samples with nonzero status, excluded", "note": status_note})
    band_json = json.dumps([
        {"name": b.name, "output": b.output,
         "lower": None if b.lower == -math.inf else b.lower,
         "upper": None if b.upper == math.inf else b.upper,
         "absolute": b.absolute, "select": {k: str(v) for k, v in b.select.items()}}
        for b in band_list
    ])
    out.attrs.update({
        "description": (
            "Monte Carlo reliability: failure probability, reliability and generalised "
            "reliability index beta = Phi^-1(R) per failure mode"
            + (", series system" if system else "")
            + (" and first-passage over the time window" if first_passage and has_time else "")
        ),
        "confidence": float(confidence),
        "interval": method,
        "failure_definition": (
            "a sample fails a band at an instant when its value (|value| for absolute bands) "
            "is outside the closed interval [lower, upper]; values on a limit are safe"
        ),
        "beta_definition": (
            "generalised index beta = Phi^-1(R) = -Phi^-1(pf); zero/all failures give a "
            "finite one-sided bound flagged by beta_is_lower_bound / beta_is_upper_bound"
        ),
        "system_definition": "series: fails if any mode fails at that instant (same samples)",
        "invalid_samples": status_note,
        "n_samples": n_samples,
        "n_valid": n_valid,
        "n_invalid": n_invalid,
        "bands": band_json,
    })
    if "model" in ds.attrs:
        out.attrs["model"] = str(ds.attrs["model"])
    return out


# =========================================================================== package attribute
class _CallableModule(types.ModuleType):
    """Module type that forwards calls to :func:`reliability`.

    ``gearuq/__init__.py`` exposes the function lazily as ``gearuq.reliability``, but once this
    submodule has been imported (e.g. by ``from gearuq.reliability import Band`` or by
    :mod:`gearuq.fitting`) Python binds the *module* to that attribute. Making the module
    callable keeps ``gearuq.reliability(ds, bands)`` working in every import order.
    """

    def __call__(self, *args: Any, **kwargs: Any) -> xr.Dataset:
        return reliability(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
