"""What a design is judged by: failure probabilities, quantiles and moments of outputs.

Each measure is estimated from model runs and their likelihood-ratio weights (all ones for
runs drawn at the design itself), with an interval:

- :class:`Probability` ``P(g <= 0)``: the unbiased importance-sampling mean ``mean(w 1[g <= 0])``;
  with unit weights the Clopper-Pearson interval (exact coverage), otherwise a normal interval
  from the weighted variance. Invalid runs are counted safe, and the upper end covers the
  reading that counts them failed (as :mod:`gearuq.failure.methods.mc` does).
- :class:`Quantile`: the self-normalised weighted quantile; its interval from order statistics
  at the weights' effective sample size (distribution-free for unit weights).
- :class:`Moment` ``mean`` or ``std``: self-normalised weighted moments, normal interval at the
  effective sample size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import xarray as xr
from scipy import stats

from gearuq.failure.intervals import clopper_pearson_interval
from gearuq.failure.modes import LimitState, System, as_limit_state

__all__ = ["Probability", "Quantile", "Moment", "Constraint", "Estimate", "effective_size"]


class Estimate(NamedTuple):
    """A measure's value with its interval and the effective sample size behind it."""

    value: float
    lower: float
    upper: float
    ess: float


def effective_size(w: np.ndarray) -> float:
    """Kish's effective sample size ``(sum w)^2 / sum w^2`` (0 for no positive weight)."""
    w = np.asarray(w, dtype=float)
    s2 = float(np.sum(w * w))
    return float(np.sum(w)) ** 2 / s2 if s2 > 0 else 0.0


def _name_ok(name: str) -> str:
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"measure name: {name!r} is not a valid identifier")
    return name


@dataclass(frozen=True)
class Probability:
    """Failure probability ``P(g <= 0)`` of a limit state.

    Parameters
    ----------
    limit_state : LimitState, System, Band or str
        As in :func:`gearuq.failure_probability` (an output name means the output is ``g``).
    name : str
        Label in results (default ``"pf"``).
    """

    limit_state: Any
    name: str = "pf"
    units = "1"
    kind = "probability"

    def __post_init__(self) -> None:
        object.__setattr__(self, "limit_state", as_limit_state(self.limit_state))
        _name_ok(self.name)

    @property
    def outputs(self) -> tuple[str, ...]:
        """Result variables read."""
        return tuple(self.limit_state.outputs)

    def sample_values(self, ds: xr.Dataset) -> np.ndarray:
        """``g`` per sample (NaN where the run is invalid)."""
        g = np.asarray(self.limit_state.sample_values(ds), dtype=float)
        return np.where(np.asarray(ds["status"].values) == 0, g, np.nan)

    def estimate(self, g: np.ndarray, w: np.ndarray | None, confidence: float) -> Estimate:
        """Estimate from ``g`` values (NaN = invalid run) and weights (``None``: all one)."""
        n = g.size
        bad = ~np.isfinite(g)
        fail = np.where(bad, False, g <= 0.0)
        if w is None:
            k, k_bad = int(fail.sum()), int(bad.sum())
            lo = float(clopper_pearson_interval(k, n, confidence)[0])
            up = float(clopper_pearson_interval(k + k_bad, n, confidence)[1])
            return Estimate(k / n, lo, up, float(k))
        z = stats.norm.isf((1.0 - confidence) / 2.0)
        terms = w * fail
        pf = float(terms.mean())
        se = float(terms.std(ddof=1) / math.sqrt(n)) if n > 1 else math.inf
        worst = w * (fail | bad)
        up = float(worst.mean()) + z * (float(worst.std(ddof=1) / math.sqrt(n)) if n > 1
                                         else math.inf)
        return Estimate(pf, max(pf - z * se, 0.0), min(up, 1.0), effective_size(terms))


@dataclass(frozen=True)
class _OutputMeasure:
    """A measure of one scalar output (the base of :class:`Quantile` and :class:`Moment`)."""

    output: str

    @property
    def outputs(self) -> tuple[str, ...]:
        """Result variables read."""
        return (self.output,)

    def sample_values(self, ds: xr.Dataset) -> np.ndarray:
        """The output per sample (NaN where the run is invalid)."""
        return _scalar_output(ds, self.output)


@dataclass(frozen=True)
class Quantile(_OutputMeasure):
    """The ``level`` quantile of a scalar output.

    Parameters
    ----------
    output : str
        Output name (per sample, no time dim).
    level : float
        In ``(0, 1)``, e.g. 0.99.
    name : str
        Label (default ``"q<level>_<output>"``).
    units : str
        Units of the output (recorded in results).
    """

    level: float
    name: str = ""
    units: str = ""
    kind = "quantile"

    def __post_init__(self) -> None:
        if not 0.0 < float(self.level) < 1.0:
            raise ValueError(f"Quantile level: {self.level!r} must lie in (0, 1)")
        if not self.name:
            tag = f"{self.level:g}".replace(".", "")
            object.__setattr__(self, "name", f"q{tag}_{self.output}")
        _name_ok(self.name)

    def estimate(self, y: np.ndarray, w: np.ndarray | None, confidence: float) -> Estimate:
        """Weighted quantile with an order-statistic interval at the effective size."""
        ok = np.isfinite(y)
        y, w = y[ok], (np.ones(ok.sum()) if w is None else np.asarray(w)[ok])
        if y.size == 0 or np.sum(w) <= 0:
            return Estimate(math.nan, math.nan, math.nan, 0.0)
        order = np.argsort(y)
        ys, cw = y[order], np.cumsum(w[order]) / np.sum(w)
        n_eff = effective_size(w)

        def at(p: float) -> float:
            return float(ys[min(np.searchsorted(cw, p), ys.size - 1)])

        # ranks of the distribution-free interval, mapped to probabilities at n_eff
        alpha = 1.0 - confidence
        lo_p = stats.binom.ppf(alpha / 2, max(int(n_eff), 1), self.level) / max(n_eff, 1.0)
        up_p = (stats.binom.isf(alpha / 2, max(int(n_eff), 1), self.level) + 1) / max(n_eff, 1.0)
        lower = at(float(lo_p)) if lo_p > 0 else -math.inf
        upper = at(float(up_p)) if up_p <= 1 else math.inf
        return Estimate(at(self.level), lower, upper, n_eff)


@dataclass(frozen=True)
class Moment(_OutputMeasure):
    """The mean or standard deviation of a scalar output.

    Parameters
    ----------
    output : str
        Output name.
    moment : {"mean", "std"}
    name : str
        Label (default ``"<moment>_<output>"``).
    units : str
        Units of the output.
    """

    moment: str = "mean"
    name: str = ""
    units: str = ""
    kind = "moment"

    def __post_init__(self) -> None:
        if self.moment not in ("mean", "std"):
            raise ValueError(f"Moment moment: {self.moment!r}; valid: mean, std")
        if not self.name:
            object.__setattr__(self, "name", f"{self.moment}_{self.output}")
        _name_ok(self.name)

    def estimate(self, y: np.ndarray, w: np.ndarray | None, confidence: float) -> Estimate:
        """Self-normalised weighted moment with a normal interval at the effective size."""
        ok = np.isfinite(y)
        y, w = y[ok], (np.ones(ok.sum()) if w is None else np.asarray(w)[ok])
        if y.size < 2 or np.sum(w) <= 0:
            return Estimate(math.nan, math.nan, math.nan, 0.0)
        n_eff = effective_size(w)
        mean = float(np.sum(w * y) / np.sum(w))
        std = float(math.sqrt(max(np.sum(w * (y - mean) ** 2) / np.sum(w), 0.0)))
        z = stats.norm.isf((1.0 - confidence) / 2.0)
        if self.moment == "mean":
            half = z * std / math.sqrt(max(n_eff - 1.0, 1.0))
            return Estimate(mean, mean - half, mean + half, n_eff)
        # large-sample standard error of a standard deviation (normal kurtosis)
        half = z * std / math.sqrt(2.0 * max(n_eff - 1.0, 1.0))
        return Estimate(std, max(std - half, 0.0), std + half, n_eff)


Measure = Probability | Quantile | Moment


@dataclass(frozen=True)
class Constraint:
    """A cap (or floor) on a measure: ``measure <= upper`` and/or ``measure >= lower``.

    Parameters
    ----------
    measure : Probability, Quantile or Moment
    upper, lower : float, optional
        At least one.
    """

    measure: Any
    upper: float | None = None
    lower: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.measure, (Probability, Quantile, Moment)):
            raise TypeError(f"Constraint measure: expected Probability, Quantile or Moment, "
                            f"got {type(self.measure).__name__}")
        if self.upper is None and self.lower is None:
            raise ValueError(f"Constraint on {self.measure.name!r}: give upper or lower")
        for key in ("upper", "lower"):
            v = getattr(self, key)
            if v is not None and not math.isfinite(float(v)):
                raise ValueError(f"Constraint on {self.measure.name!r}: {key}={v!r} must be "
                                 "finite")
        if isinstance(self.measure, Probability) and self.upper is not None \
                and not 0.0 < float(self.upper) < 1.0:
            raise ValueError(f"Constraint on {self.measure.name!r}: a probability cap "
                             f"upper={self.upper!r} must lie in (0, 1)")

    def margin(self, value: float) -> float:
        """Signed distance to the bound: >= 0 where the constraint holds."""
        m = math.inf
        if self.upper is not None:
            m = min(m, float(self.upper) - value)
        if self.lower is not None:
            m = min(m, value - float(self.lower))
        return m

    def verdict(self, est: Estimate) -> str:
        """``"holds"``, ``"violated"`` or ``"undecided"`` (the interval straddles a bound)."""
        checks = []
        if self.upper is not None:
            checks.append("holds" if est.upper <= self.upper else
                          "violated" if est.lower > self.upper else "undecided")
        if self.lower is not None:
            checks.append("holds" if est.lower >= self.lower else
                          "violated" if est.upper < self.lower else "undecided")
        if "violated" in checks:
            return "violated"
        return "undecided" if "undecided" in checks else "holds"


def _scalar_output(ds: xr.Dataset, name: str) -> np.ndarray:
    if name not in ds:
        raise ValueError(f"output {name!r} is not in the result; has "
                         f"{', '.join(map(str, ds.data_vars))}")
    da = ds[name]
    if da.dims != ("sample",):
        raise ValueError(f"output {name!r} has dims {da.dims}; a quantile or moment needs one "
                         "value per sample")
    y = np.asarray(da.values, dtype=float)
    return np.where(np.asarray(ds["status"].values) == 0, y, np.nan)


def limit_state_of(measure: Any) -> LimitState | System | None:
    """The limit state of a probability measure (``None`` for others)."""
    return measure.limit_state if isinstance(measure, Probability) else None
