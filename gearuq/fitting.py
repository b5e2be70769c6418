"""Distribution fitting and model selection for response samples.

:func:`fit_distributions` fits candidate families by maximum likelihood (``scipy.stats``),
ranks them by AIC (BIC rank shown too), reports Kolmogorov-Smirnov and Anderson-Darling
statistics with honest p-values, and, given a threshold or band, the failure probability of
the fitted tail next to the empirical one.

Decisions
---------
Location parameter (``floc``)
    Positive-support families (lognormal, Rayleigh, Weibull, gamma, exponential) are fitted
    by default in their standard 2-parameter form (1-parameter for Rayleigh and exponential)
    with ``loc`` **fixed at 0**: response magnitudes (amplitudes, RMS values, peak loads) have a
    natural origin at zero, and 3-parameter maximum likelihood with a free threshold is
    ill-posed (the likelihood is unbounded as ``loc -> min(x)`` for Weibull shape < 1,
    lognormal and gamma shape < 1) and unstable to fit. ``floc=<value>`` fixes the origin
    elsewhere; ``floc="free"`` fits ``loc`` too (3-parameter forms; Rayleigh and exponential
    become 2-parameter) and counts it in AIC/BIC. Real-line families (normal, Gumbel,
    logistic, GEV) always fit their ``loc``. Note that ``floc=None`` means *the default (0 for
    positive families)* here, unlike ``scipy.stats.rv_continuous.fit`` where ``floc=None``
    frees ``loc``.
Data outside a positive family's support
    With a fixed ``loc``, a positive-support family needs every sample ``> loc``. If any is not,
    that family is **skipped** and the reason is stored in ``fit_status`` (the data are never
    shifted silently); pass ``floc="free"`` or shift the data yourself.
p-values
    With ``bootstrap=B > 0``, ``ks_pvalue`` and ``ad_pvalue`` come from a *parametric
    bootstrap*: ``B`` samples of size ``n`` are drawn from the fitted distribution, each is
    refitted with the same ``loc`` policy and its statistics computed against its own fit, so
    the p-values account for the estimated parameters; ``p = (1 + #{T* >= T}) / (B + 1)``.
    The bootstrap refits also give standard errors of the parameters (``*_se``) and a
    percentile interval on the fitted tail probability. ``ks_pvalue_naive`` is always given:
    the classical Kolmogorov-Smirnov p-value for a *fully specified* distribution, which does
    NOT account for the estimated parameters (it is too large, i.e. too lenient).
Invalid samples
    With a ``status`` (keyword, or a ``status`` coordinate on a DataArray) samples with nonzero
    status are dropped and counted (``n_invalid``). Any remaining non-finite value raises.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from gearuq.failure.intervals import wilson_interval
from gearuq.failure.modes import Band

__all__ = [
    "FAMILIES",
    "DEFAULT_CANDIDATES",
    "FitResult",
    "fit_distributions",
    "ks_statistic",
    "ad_statistic",
]


@dataclass(frozen=True)
class Family:
    """A candidate family: its scipy distribution, shape name and support type."""

    name: str
    dist: Any
    shape: str | None
    positive: bool
    description: str

    @property
    def scipy_name(self) -> str:
        """Name of the ``scipy.stats`` distribution."""
        return str(self.dist.name)


#: Available candidate families by gearuq name.
FAMILIES: dict[str, Family] = {
    f.name: f
    for f in (
        Family("lognormal", stats.lognorm, "s", True, "lognormal; s = sigma of ln x, "
               "scale = exp(mu of ln x)"),
        Family("rayleigh", stats.rayleigh, None, True, "Rayleigh (amplitude envelope of a "
               "narrow-band Gaussian response)"),
        Family("normal", stats.norm, None, False, "normal; loc = mean, scale = std"),
        Family("weibull", stats.weibull_min, "c", True, "Weibull (minimum); c = shape"),
        Family("gamma", stats.gamma, "a", True, "gamma; a = shape"),
        Family("exponential", stats.expon, None, True, "exponential; scale = mean - loc"),
        Family("gumbel", stats.gumbel_r, None, False, "Gumbel for maxima (right-skewed)"),
        Family("gumbel_min", stats.gumbel_l, None, False, "Gumbel for minima (left-skewed)"),
        Family("logistic", stats.logistic, None, False, "logistic"),
        Family("genextreme", stats.genextreme, "c", False, "generalised extreme value "
               "(scipy sign: c = -xi)"),
    )
}

_ALIASES = {
    "lognorm": "lognormal", "norm": "normal", "gaussian": "normal",
    "weibull_min": "weibull", "expon": "exponential", "gumbel_r": "gumbel",
    "gumbel_l": "gumbel_min", "gev": "genextreme",
}

#: Candidates fitted by default.
DEFAULT_CANDIDATES: tuple[str, ...] = (
    "lognormal", "rayleigh", "normal", "weibull", "gamma", "exponential", "gumbel",
)

_TAILS = ("upper", "lower", "two-sided")


class _Skip(Exception):
    """A candidate that is not fitted, with the reason."""


# =========================================================================== statistics
def ks_statistic(x: Any, dist: Any) -> float:
    """Kolmogorov-Smirnov statistic ``D = sup |F_n(x) - F(x)|`` of samples against ``dist``.

    Parameters
    ----------
    x : array_like
        1-D samples.
    dist : frozen scipy distribution or callable cdf
        Hypothesised distribution.
    """
    y = np.sort(np.asarray(x, dtype=float))
    n = y.size
    cdf = dist.cdf if hasattr(dist, "cdf") else dist
    f = np.asarray(cdf(y), dtype=float)
    i = np.arange(1, n + 1)
    return float(max(np.max(i / n - f), np.max(f - (i - 1) / n)))


def ad_statistic(x: Any, dist: Any) -> float:
    """Anderson-Darling statistic of samples against a fully specified distribution.

    ``A^2 = -n - (1/n) sum_i (2i - 1) [ln F(x_(i)) + ln(1 - F(x_(n+1-i)))]`` with ``x_(i)`` the
    sorted samples; ``ln F`` and ``ln(1 - F)`` come from ``logcdf``/``logsf`` for accuracy in
    the tails. Returns ``inf`` if a sample lies outside the support.

    Parameters
    ----------
    x : array_like
        1-D samples.
    dist : frozen scipy distribution
        Must provide ``logcdf`` and ``logsf``.
    """
    y = np.sort(np.asarray(x, dtype=float))
    n = y.size
    with np.errstate(divide="ignore"):
        lc = np.asarray(dist.logcdf(y), dtype=float)
        ls = np.asarray(dist.logsf(y), dtype=float)
    i = np.arange(1, n + 1)
    s = np.sum((2 * i - 1) * (lc + ls[::-1]))
    if not np.isfinite(s):
        return math.inf
    return float(-n - s / n)


# =========================================================================== input handling
def _prepare(samples: Any, status: Any) -> tuple[np.ndarray, int, str, str]:
    """Return (finite 1-D samples, n_invalid, units, name)."""
    units, name = "", "samples"
    if isinstance(samples, xr.Dataset):
        raise ValueError(
            "fit_distributions: give one output as a DataArray (e.g. ds['y'].isel(time=-1)) "
            "and its status (status=ds['status']), not a whole Dataset"
        )
    if isinstance(samples, xr.DataArray):
        if samples.ndim != 1:
            raise ValueError(
                f"fit_distributions: samples must be 1-D over 'sample'; got dims {samples.dims}"
                " - select one time/dof first (e.g. .isel(time=-1) or .sel(dof=...))"
            )
        units = str(samples.attrs.get("units", ""))
        name = str(samples.name) if samples.name is not None else name
        if status is None and "status" in samples.coords:
            status = samples.coords["status"].values
        x = np.asarray(samples.values, dtype=float)
    else:
        try:
            x = np.asarray(samples, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"fit_distributions: samples must be real numbers (a 1-D array "
                             f"or a DataArray over 'sample'), got {str(samples)[:60]!r} "
                             f"({type(samples).__name__})") from None
        if x.ndim != 1:
            raise ValueError(f"fit_distributions: samples must be 1-D, got shape {x.shape}")
    if x.size == 0:
        raise ValueError("fit_distributions: samples are empty")
    n_invalid = 0
    if status is not None:
        st = np.asarray(status.values if isinstance(status, xr.DataArray) else status)
        if st.shape != x.shape:
            raise ValueError(f"status shape {st.shape} does not match samples shape {x.shape}")
        ok = st == 0
        n_invalid = int((~ok).sum())
        x = x[ok]
        if x.size == 0:
            raise ValueError(
                f"fit_distributions: all {n_invalid} samples have nonzero status; nothing to fit"
            )
    bad = ~np.isfinite(x)
    if bad.any():
        hint = "" if status is not None else (
            "; if they come from failed solver runs pass status=... so they are dropped")
        raise ValueError(
            f"fit_distributions: {int(bad.sum())} of {x.size} valid sample(s) are non-finite "
            f"(NaN/inf){hint}"
        )
    if x.size < 3:
        raise ValueError(f"fit_distributions: need at least 3 valid samples, got {x.size}")
    if np.all(x == x[0]):
        raise ValueError(
            f"fit_distributions: all {x.size} samples equal {x[0]:g}; no distribution can be "
            "fitted to constant data"
        )
    return x, n_invalid, units, name


def _resolve_candidates(candidates: Any) -> list[str]:
    if isinstance(candidates, str):
        candidates = [candidates]
    names: list[str] = []
    unknown = []
    for c in candidates:
        key = str(c).strip().lower()
        key = _ALIASES.get(key, key)
        if key not in FAMILIES:
            unknown.append(c)
        elif key not in names:
            names.append(key)
    if unknown:
        raise ValueError(
            f"unknown candidate distribution(s) {', '.join(map(repr, unknown))}; valid: "
            f"{', '.join(FAMILIES)} (aliases: {', '.join(_ALIASES)})"
        )
    if not names:
        raise ValueError("candidates: empty; give at least one family")
    return names


def _loc_policy(floc: Any) -> float | None:
    """Return the fixed loc for positive families, or None for free loc."""
    if floc is None:
        return 0.0
    if isinstance(floc, str):
        if floc.strip().lower() == "free":
            return None
        raise ValueError(f"floc must be a number, None (= 0) or 'free', got {floc!r}")
    val = float(floc)
    if not math.isfinite(val):
        raise ValueError(f"floc must be finite, got {floc!r}")
    return val


def _threshold_band(threshold: Any, tail: str) -> Band | None:
    if threshold is None:
        return None
    if isinstance(threshold, Band):
        return Band("samples", threshold.lower, threshold.upper, name=threshold.name,
                    absolute=threshold.absolute)
    tail_key = str(tail).strip().lower().replace("_", "-")
    if tail_key not in _TAILS:
        raise ValueError(f"tail {tail!r} unknown; valid: {', '.join(_TAILS)}")
    if tail_key == "two-sided":
        if not (isinstance(threshold, Sequence) and len(threshold) == 2):
            raise ValueError(
                "tail='two-sided' needs threshold=(lower, upper) (either may be None)")
        try:
            return Band("samples", threshold[0], threshold[1], name="band")
        except ValueError as exc:  # said of the argument given, not of an inner band
            raise ValueError(f"threshold={tuple(threshold)!r}: "
                             f"{str(exc).split(': ', 1)[-1]}") from None
    if isinstance(threshold, Sequence):
        raise ValueError(
            f"threshold {threshold!r} is a pair: use tail='two-sided' for a band")
    try:
        thr = float(threshold)
    except (TypeError, ValueError):
        raise ValueError(f"threshold: {threshold!r} is not a number") from None
    if not math.isfinite(thr):
        raise ValueError(f"threshold: {threshold!r} is not a finite number; give the level "
                         "whose exceedance probability is wanted")
    if tail_key == "upper":
        return Band("samples", None, thr, name="upper_tail")
    return Band("samples", thr, None, name="lower_tail")


# =========================================================================== fitting
def _fit(fam: Family, x: np.ndarray, loc: float | None) -> tuple[float, ...]:
    """Maximum-likelihood parameters ``(*shapes, loc, scale)``; raises _Skip."""
    fixed = fam.positive and loc is not None
    if fixed and np.min(x) <= loc:
        bad = int(np.sum(x <= loc))
        raise _Skip(
            f"skipped: {bad} sample(s) <= loc={loc:g} (min {np.min(x):.6g}) outside the "
            f"support of positive family {fam.name}; use floc='free' or shift the data"
        )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            params = fam.dist.fit(x, floc=loc) if fixed else fam.dist.fit(x)
        except Exception as exc:  # scipy raises several types (FitError, RuntimeError, ...)
            raise _Skip(f"failed: {type(exc).__name__}: {exc}") from exc
    params = tuple(float(p) for p in params)
    if not all(math.isfinite(p) for p in params) or params[-1] <= 0:
        raise _Skip(f"failed: non-finite or non-positive parameters {params}")
    return params


def _n_free(fam: Family, loc: float | None) -> int:
    return (1 if fam.shape else 0) + (0 if (fam.positive and loc is not None) else 1) + 1


def _loglik(dist: Any, x: np.ndarray) -> float:
    with np.errstate(divide="ignore"):
        ll = float(np.sum(dist.logpdf(x)))
    return ll if not math.isnan(ll) else -math.inf


@dataclass
class FitResult:
    """Result of :func:`fit_distributions`.

    Attributes
    ----------
    dataset : xarray.Dataset
        All numbers over the ``candidate`` dim, sorted by AIC (fitted first, then skipped).
    """

    dataset: xr.Dataset

    @property
    def best(self) -> str:
        """Name of the family with the lowest AIC."""
        return str(self.dataset.attrs["best"])

    @property
    def ranking(self) -> list[str]:
        """Fitted candidate names by increasing AIC."""
        ds = self.dataset
        return [str(c) for c, r in zip(ds["candidate"].values, ds["aic_rank"].values,
                                       strict=True) if r > 0]

    def frozen(self, name: str | None = None) -> Any:
        """Frozen ``scipy.stats`` distribution of candidate ``name`` (default: the best)."""
        name = self.best if name is None else _resolve_candidates([name])[0]
        ds = self.dataset
        if name not in ds["candidate"].values:
            raise ValueError(
                f"candidate {name!r} was not part of this fit; fitted: "
                f"{', '.join(map(str, ds['candidate'].values))}")
        row = ds.sel(candidate=name)
        if int(row["aic_rank"]) < 1:
            raise ValueError(f"candidate {name!r} was not fitted: {row['fit_status'].item()}")
        fam = FAMILIES[name]
        args = (float(row["shape"]),) if fam.shape else ()
        return fam.dist(*args, loc=float(row["loc"]), scale=float(row["scale"]))

    def pdf(self, name: str | None, x: Any) -> np.ndarray:
        """Fitted probability density of ``name`` (None = best) at ``x``."""
        return self.frozen(name).pdf(np.asarray(x, dtype=float))

    def cdf(self, name: str | None, x: Any) -> np.ndarray:
        """Fitted cumulative distribution of ``name`` (None = best) at ``x``."""
        return self.frozen(name).cdf(np.asarray(x, dtype=float))

    @property
    def table(self) -> str:
        """Plain-text ranking table."""
        ds = self.dataset
        boot = "ks_pvalue" in ds
        thr = "pf_fit" in ds
        head = (f"{'AIC#':>4} {'BIC#':>4} {'candidate':<12} {'parameters':<40} {'loglik':>12} "
                f"{'dAIC':>9} {'KS':>7} {'AD':>8}")
        head += f" {'pKS':>6} {'pAD':>6}" if boot else f" {'pKS*':>6}"
        if thr:
            head += f" {'pf_fit':>10}"
        lines = [head]
        for c in ds["candidate"].values:
            r = ds.sel(candidate=c)
            if int(r["aic_rank"]) < 1:
                lines.append(f"{'-':>4} {'-':>4} {str(c):<12} {r['fit_status'].item()}")
                continue
            fam = FAMILIES[str(c)]
            ps = []
            if fam.shape:
                ps.append(f"{fam.shape}={float(r['shape']):.4g}")
            ps.append(f"loc={float(r['loc']):.4g}" + ("(fixed)" if int(r["loc_fixed"]) else ""))
            ps.append(f"scale={float(r['scale']):.4g}")
            line = (f"{int(r['aic_rank']):>4} {int(r['bic_rank']):>4} {str(c):<12} "
                    f"{', '.join(ps):<40} {float(r['loglik']):>12.4f} "
                    f"{float(r['delta_aic']):>9.3f} {float(r['ks_statistic']):>7.4f} "
                    f"{float(r['ad_statistic']):>8.4f}")
            if boot:
                line += f" {float(r['ks_pvalue']):>6.3f} {float(r['ad_pvalue']):>6.3f}"
            else:
                line += f" {float(r['ks_pvalue_naive']):>6.3f}"
            if thr:
                line += f" {float(r['pf_fit']):>10.3e}"
            lines.append(line)
        if boot:
            lines.append(f"p-values: parametric bootstrap, B={ds.attrs['bootstrap']} "
                         "(account for the estimated parameters)")
        else:
            lines.append("pKS*: classical KS p-value, NOT accounting for estimated parameters "
                         "(too lenient); use bootstrap=B for valid p-values")
        if thr:
            lines.append(
                f"empirical pf = {float(ds['pf_empirical']):.3e} "
                f"[{float(ds['pf_empirical_lower']):.3e}, {float(ds['pf_empirical_upper']):.3e}]"
                f" ({int(ds['n_exceed'])}/{int(ds.attrs['n'])}, Wilson "
                f"{100 * float(ds.attrs['confidence']):g}%)")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.table


def fit_distributions(
    samples: Any,
    candidates: Sequence[str] | str = DEFAULT_CANDIDATES,
    *,
    floc: float | str | None = None,
    bootstrap: int = 0,
    rng: np.random.Generator | int | None = None,
    threshold: float | tuple[float | None, float | None] | Band | None = None,
    tail: str = "upper",
    status: Any = None,
    confidence: float = 0.95,
) -> FitResult:
    """Fit candidate distributions by maximum likelihood and rank them by AIC.

    Parameters
    ----------
    samples : array_like or xarray.DataArray
        1-D response samples (a DataArray over ``sample``; a ``status`` coordinate is used as
        ``status``).
    candidates : sequence of str
        Family names among :data:`FAMILIES` (``lognormal``, ``rayleigh``, ``normal``,
        ``weibull``, ``gamma``, ``exponential``, ``gumbel``, ``gumbel_min``, ``logistic``,
        ``genextreme``; scipy names such as ``lognorm`` are accepted as aliases).
    floc : float, "free" or None
        Location of positive-support families: ``None`` (default) fixes it at 0 (2-parameter
        forms, 1-parameter Rayleigh/exponential), a number fixes it there, ``"free"`` fits it.
        Real-line families always fit ``loc``. See the module notes.
    bootstrap : int
        Number of parametric-bootstrap replicates for p-values, parameter standard errors and
        the tail-probability interval (0 = none; then only ``ks_pvalue_naive``).
    rng : numpy.random.Generator or int, optional
        Random source of the bootstrap (pass a seed for reproducible p-values).
    threshold : float, (lower, upper) or Band, optional
        Failure definition for the tail probability: with ``tail="upper"`` failure is
        ``x > threshold``, ``"lower"``: ``x < threshold``, ``"two-sided"``: outside
        ``(lower, upper)``. A :class:`~gearuq.failure.modes.Band` (its limits and ``absolute``
        flag) may be given instead, then ``tail`` is ignored.
    tail : {"upper", "lower", "two-sided"}
        See ``threshold``.
    status : array_like, optional
        Per-sample status; samples with nonzero status are dropped and counted.
    confidence : float
        Level of the Wilson interval on the empirical pf and of bootstrap intervals.

    Returns
    -------
    FitResult
        ``.dataset`` (dim ``candidate`` sorted by AIC; variables ``shape``, ``loc``,
        ``scale``, ``loc_fixed``, ``n_params``, ``loglik``, ``aic``, ``bic``, ``delta_aic``,
        ``aic_weight``, ``aic_rank``, ``bic_rank``, ``ks_statistic``, ``ks_pvalue_naive``,
        ``ad_statistic``, ``fit_status``; with bootstrap ``ks_pvalue``, ``ad_pvalue``,
        ``shape_se``, ``loc_se``, ``scale_se``, ``n_bootstrap_ok``; with threshold ``pf_fit``,
        ``beta_fit`` (and ``pf_fit_lower/upper`` with bootstrap), ``pf_empirical``,
        ``pf_empirical_lower/upper``, ``n_exceed``), ``.best``, ``.table``, ``.frozen(name)``,
        ``.pdf(name, x)``, ``.cdf(name, x)``.

    Raises
    ------
    ValueError
        Empty or non-finite valid samples, unknown candidates, bad ``floc``/``tail``/
        ``threshold``/``bootstrap``, or no candidate could be fitted.
    """
    x, n_invalid, units, var_name = _prepare(samples, status)
    names = _resolve_candidates(candidates)
    loc = _loc_policy(floc)
    if isinstance(bootstrap, bool) or int(bootstrap) != bootstrap or bootstrap < 0:
        raise ValueError(f"bootstrap must be a non-negative integer, got {bootstrap!r}")
    if not 0.0 < float(confidence) < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    band = _threshold_band(threshold, tail)
    gen = np.random.default_rng(rng)
    rows = [_fit_candidate(FAMILIES[name], x, loc, band, int(bootstrap), gen,
                           1.0 - float(confidence)) for name in names]
    order = _rank(rows)
    out = _fit_dataset(order, units, int(bootstrap), band)
    if band is not None:
        _add_empirical(out, band, x, float(confidence))
    loc_text = ("free (fitted) for every family" if loc is None else
                f"fixed at {loc:g} for positive-support families; fitted for real-line families")
    out.attrs.update({
        "description": "maximum-likelihood distribution fits ranked by AIC",
        "variable": var_name,
        "units": units,
        "best": order[0]["candidate"],
        "n": int(x.size),
        "n_invalid": int(n_invalid),
        "loc_policy": loc_text,
        "bootstrap": int(bootstrap),
        "confidence": float(confidence),
        "pvalue_method": (
            f"parametric bootstrap with B={int(bootstrap)} refits (accounts for estimated "
            "parameters)" if bootstrap else
            "none; ks_pvalue_naive ignores the estimated parameters (too lenient)"),
    })
    if band is not None:
        out.attrs.update({
            "threshold_lower": float(band.lower),
            "threshold_upper": float(band.upper),
            "threshold_absolute": int(band.absolute),
            "failure_definition": band.describe().replace("samples", "x") + " is safe",
        })
    return FitResult(out)


def _fit_candidate(fam: Family, x: np.ndarray, loc: float | None, band: Band | None,
                   n_boot: int, gen: np.random.Generator, alpha: float) -> dict[str, Any]:
    """Fit one family: parameters, likelihood criteria, GoF statistics, tail pf, bootstrap."""
    n = x.size
    fixed = fam.positive and loc is not None
    row: dict[str, Any] = {"candidate": fam.name, "scipy_name": fam.scipy_name,
                           "loc_fixed": int(fixed), "n_params": _n_free(fam, loc)}
    try:
        params = _fit(fam, x, loc)
    except _Skip as exc:
        row["fit_status"] = str(exc)
        return row
    dist = fam.dist(*params)
    k = row["n_params"]
    ll = _loglik(dist, x)
    row.update({
        "fit_status": "ok",
        "shape": params[0] if fam.shape else math.nan,
        "loc": params[-2], "scale": params[-1],
        "loglik": ll, "aic": 2 * k - 2 * ll, "bic": k * math.log(n) - 2 * ll,
        "ks_statistic": ks_statistic(x, dist),
        "ad_statistic": ad_statistic(x, dist),
    })
    row["ks_pvalue_naive"] = float(stats.kstwo.sf(row["ks_statistic"], n))
    if band is not None:
        row["pf_fit"] = band.pf_from_distribution(dist)
    if n_boot:
        row.update(_bootstrap(fam, dist, n, loc, band, n_boot, gen, alpha, row))
    return row


def _bootstrap(fam: Family, dist: Any, n: int, loc: float | None, band: Band | None,
               n_boot: int, gen: np.random.Generator, alpha: float,
               row: dict[str, Any]) -> dict[str, Any]:
    """Parametric bootstrap: p-values, parameter standard errors, pf_fit interval."""
    ks_b, ad_b, par_b, pf_b = [], [], [], []
    for _ in range(n_boot):
        xb = dist.rvs(size=n, random_state=gen)
        try:
            pb = _fit(fam, xb, loc)
        except _Skip:
            continue
        db = fam.dist(*pb)
        ks_b.append(ks_statistic(xb, db))
        ad_b.append(ad_statistic(xb, db))
        par_b.append(pb)
        if band is not None:
            pf_b.append(band.pf_from_distribution(db))
    nb = len(ks_b)
    out: dict[str, Any] = {"n_bootstrap_ok": nb}
    if not nb:
        return out
    out["ks_pvalue"] = (1 + np.sum(np.asarray(ks_b) >= row["ks_statistic"])) / (nb + 1)
    out["ad_pvalue"] = (1 + np.sum(np.asarray(ad_b) >= row["ad_statistic"])) / (nb + 1)
    pa = np.asarray(par_b)
    sd = pa.std(axis=0, ddof=1) if nb > 1 else np.full(pa.shape[1], math.nan)
    out["shape_se"] = float(sd[0]) if fam.shape else math.nan
    out["loc_se"] = math.nan if row["loc_fixed"] else float(sd[-2])
    out["scale_se"] = float(sd[-1])
    if band is not None:
        out["pf_fit_lower"] = float(np.quantile(pf_b, alpha / 2))
        out["pf_fit_upper"] = float(np.quantile(pf_b, 1 - alpha / 2))
    return out


def _rank(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Fitted candidates by AIC (with ranks, dAIC, Akaike weights), then the skipped ones."""
    fitted = [r for r in rows if r["fit_status"] == "ok"]
    if not fitted:
        raise ValueError(
            "fit_distributions: no candidate could be fitted:\n"
            + "\n".join(f"  {r['candidate']}: {r['fit_status']}" for r in rows)
        )
    fitted.sort(key=lambda r: (r["aic"], r["candidate"]))
    skipped = [r for r in rows if r["fit_status"] != "ok"]
    aic_min = fitted[0]["aic"]
    finite = [r for r in fitted if math.isfinite(r["aic"])]
    wsum = sum(math.exp(-0.5 * (r["aic"] - aic_min)) for r in finite) if finite else 1.0
    bic_sorted = sorted(fitted, key=lambda r: (r["bic"], r["candidate"]))
    bic_rank = {r["candidate"]: i + 1 for i, r in enumerate(bic_sorted)}
    for i, r in enumerate(fitted):
        r["aic_rank"] = i + 1
        r["bic_rank"] = bic_rank[r["candidate"]]
        r["delta_aic"] = r["aic"] - aic_min
        r["aic_weight"] = (math.exp(-0.5 * r["delta_aic"]) / wsum
                           if math.isfinite(r["aic"]) else 0.0)
    for r in skipped:
        r["aic_rank"] = -1
        r["bic_rank"] = -1
    return fitted + skipped


_VAR_DOC = {
    "shape": "shape parameter (lognormal s, Weibull c, gamma a, GEV c; NaN if none)",
    "loc": "location parameter",
    "scale": "scale parameter",
    "loglik": "maximised log-likelihood",
    "aic": "Akaike information criterion 2k - 2 lnL",
    "bic": "Bayesian information criterion k ln(n) - 2 lnL",
    "delta_aic": "AIC minus the lowest AIC",
    "aic_weight": "Akaike weight exp(-dAIC/2) / sum",
    "ks_statistic": "Kolmogorov-Smirnov statistic D against the fitted distribution",
    "ks_pvalue_naive": (
        "classical KS p-value for a fully specified distribution; does NOT account for the "
        "estimated parameters (too lenient)"),
    "ad_statistic": "Anderson-Darling statistic A^2 against the fitted distribution",
    "ks_pvalue": "parametric-bootstrap KS p-value (accounts for estimated parameters)",
    "ad_pvalue": "parametric-bootstrap AD p-value (accounts for estimated parameters)",
    "shape_se": "bootstrap standard error of shape",
    "loc_se": "bootstrap standard error of loc (NaN if fixed)",
    "scale_se": "bootstrap standard error of scale",
    "pf_fit": "failure probability from the fitted distribution",
    "pf_fit_lower": "lower bootstrap percentile bound of pf_fit",
    "pf_fit_upper": "upper bootstrap percentile bound of pf_fit",
}


def _fit_dataset(order: list[dict[str, Any]], units: str, n_boot: int,
                 band: Band | None) -> xr.Dataset:
    """The ranked rows as a Dataset over ``candidate``."""

    def col(key: str, dtype: Any = float, fill: Any = math.nan) -> np.ndarray:
        return np.array([r.get(key, fill) for r in order], dtype=dtype)

    out = xr.Dataset(coords={"candidate": ("candidate", col("candidate", str, ""))})
    out["scipy_name"] = ("candidate", col("scipy_name", str, ""),
                         {"long_name": "scipy.stats distribution"})
    out["fit_status"] = ("candidate", col("fit_status", str, ""),
                         {"long_name": "'ok', or why the candidate was skipped/failed"})
    par_units = {"shape": "1", "loc": units, "scale": units, "shape_se": "1", "loc_se": units,
                 "scale_se": units}
    keys = ["shape", "loc", "scale", "loglik", "aic", "bic", "delta_aic", "aic_weight",
            "ks_statistic", "ks_pvalue_naive", "ad_statistic"]
    if n_boot:
        keys += ["ks_pvalue", "ad_pvalue", "shape_se", "loc_se", "scale_se"]
    if band is not None:
        keys += ["pf_fit"] + (["pf_fit_lower", "pf_fit_upper"] if n_boot else [])
    for key in keys:
        out[key] = ("candidate", col(key), {"units": par_units.get(key, "1"),
                                            "long_name": _VAR_DOC[key]})
    if band is not None:
        with np.errstate(divide="ignore"):
            out["beta_fit"] = ("candidate", stats.norm.isf(col("pf_fit")), {
                "units": "1", "long_name": "generalised index -Phi^-1(pf_fit)"})
    ints = (("loc_fixed", np.int8, 0, "1 if loc was fixed, not estimated"),
            ("n_params", np.int32, 0, "number of estimated parameters k"),
            ("aic_rank", np.int32, -1, "rank by AIC (1 = best; -1 = not fitted)"),
            ("bic_rank", np.int32, -1, "rank by BIC (1 = best; -1 = not fitted)"))
    for key, dtype, fill, doc in ints:
        out[key] = ("candidate", col(key, dtype, fill), {"units": "1", "long_name": doc})
    if n_boot:
        out["n_bootstrap_ok"] = ("candidate", col("n_bootstrap_ok", np.int32, 0),
                                 {"units": "1", "long_name": "bootstrap refits that succeeded"})
    return out


def _add_empirical(out: xr.Dataset, band: Band, x: np.ndarray, confidence: float) -> None:
    """Empirical failure probability of the same band, with its Wilson interval."""
    k_exc = int(band.fails(x).sum())
    lo, up = wilson_interval(k_exc, x.size, confidence)
    out["n_exceed"] = ((), np.int32(k_exc), {"units": "1",
                                              "long_name": "samples outside the band"})
    out["pf_empirical"] = ((), k_exc / x.size, {"units": "1",
                                                "long_name": "empirical failure probability"})
    out["pf_empirical_lower"] = ((), float(lo), {"units": "1", "long_name": "Wilson lower"})
    out["pf_empirical_upper"] = ((), float(up), {"units": "1", "long_name": "Wilson upper"})
