"""Probability from response samples: bands, limit states, instantaneous / system /
first-passage estimates, binomial intervals and reliability indices.

This is the module behind :func:`gearuq.reliability`: estimation from samples that already
exist (a Monte Carlo result). A failure mode (:mod:`gearuq.failure.modes`) is

* an allowed **band** ``[lower, upper]`` on one model output (either side may be open): a
  sample *fails* at an instant when its value lies outside the closed interval (values equal
  to a limit are safe); with ``absolute=True`` the band applies to ``|value|``;
* or a **limit state** ``g <= 0`` (the boundary fails), or a
  series / parallel / cut-set **system** of limit states.

:func:`reliability` turns a Monte Carlo result Dataset (dims ``sample`` and optionally ``time``,
a per-sample ``status`` flag, see :mod:`gearuq.model`) into

- per-mode and series-system failure probabilities at every instant,
- first-passage (cumulative) failure probabilities over the time window, with a check of how
  far the time grid can be from continuous time,
- confidence intervals (Wilson score or Clopper-Pearson) on every probability, labelled by how
  valid they are for the design (i.i.d., Latin hypercube, QMC),
- the generalised reliability index ``beta = Phi^-1(R) = -Phi^-1(pf)`` with its interval,
  finite even when no (or every) sample fails: it is then a one-sided bound and flagged.

It streams: a lazily loaded, dask-backed result is read one stored chunk at a time, and the
failure counts, being additive, give the in-memory numbers exactly.

Samples whose ``status`` is nonzero (the solver gave up) are neither safe nor failed: they are
excluded from the estimates, counted (``n_invalid``) and their possible effect is shown by
``pf_if_invalid_failed`` / ``pf_if_invalid_safe``.

The mean-value (Cornell) index :func:`mean_value_beta` is offered separately and labelled as
such: it equals ``Phi^-1(R)`` only for a normally distributed response. Rare-event methods
(FORM/SORM, importance sampling, subset simulation, AK-MCS) are behind
:func:`gearuq.failure_probability`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from gearuq._checks import check_bool
from gearuq.failure.intervals import (
    binomial_interval,
    interval_method,
)
from gearuq.failure.modes import Band, LimitState, System, as_bands, time_window

__all__ = ["reliability", "SYSTEM_MODE", "sample_blocks", "valid_samples", "as_modes"]

SYSTEM_MODE = "system"


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
    """The instants of ``ds`` that ``time`` selects, refusing a selection that reaches outside
    them (a first passage there would be missed without a word, as
    :meth:`LimitState.check_window` refuses for a limit state's window)."""
    if time is None:
        return ds
    if "time" not in ds.dims:
        raise ValueError("time: the Dataset has no 'time' dimension to select from")
    instants = np.asarray(ds["time"].values, dtype=float)
    t_first, t_last = float(instants.min()), float(instants.max())
    tol = 1e-9 * max(1.0, abs(t_first), abs(t_last))
    if isinstance(time, slice):
        if time.step is not None:
            raise ValueError(f"time: slice step {time.step!r} is not supported; give "
                             "slice(t0, t1) or a pair (t0, t1)")
        t0 = t_first if time.start is None else time.start
        t1 = t_last if time.stop is None else time.stop
        time = (t0, t1)
    if isinstance(time, tuple):
        t0, t1 = time_window(time, "time")
        if t0 < t_first - tol or t1 > t_last + tol:
            raise ValueError(
                f"time: window [{t0:g}, {t1:g}] reaches outside the Dataset's instants "
                f"[{t_first:g}, {t_last:g}]; a first passage in the part without instants "
                "would be missed. Narrow the window or compute more instants")
        out = ds.sel(time=slice(t0, t1))
    else:
        try:
            t = np.atleast_1d(np.asarray(time, dtype=float))
        except (TypeError, ValueError):
            raise ValueError(f"time: {time!r} is not an instant, a list of instants, a pair "
                             "(t0, t1) or a slice") from None
        if t.ndim != 1 or not np.all(np.isfinite(t)):
            raise ValueError(f"time: instants must be finite numbers in a 1-D list, got "
                             f"{time!r}")
        outside = t[(t < t_first - tol) | (t > t_last + tol)]
        if outside.size:
            raise ValueError(f"time: instant(s) {outside.tolist()} outside the Dataset's "
                             f"instants [{t_first:g}, {t_last:g}]; the nearest instant would "
                             "stand for them without a word")
        out = ds.sel(time=t, method="nearest")
    if out.sizes.get("time", 0) == 0:
        raise ValueError(f"time: selection {time!r} contains no output instant (the Dataset's "
                         f"instants span [{t_first:g}, {t_last:g}], {instants.size} of them)")
    return out


# =========================================================================== modes
def as_modes(bands: Any) -> list[Any]:
    """Bands, limit states and systems as a list of failure modes."""
    if isinstance(bands, (Band, LimitState, System)):
        return [bands]
    if isinstance(bands, Mapping):
        return as_bands(bands)
    if isinstance(bands, Iterable) and not isinstance(bands, str):
        out = list(bands)
        for b in out:
            if not isinstance(b, (Band, LimitState, System)):
                raise ValueError(f"bands: expected Band, LimitState or System objects, got "
                                 f"{type(b).__name__}")
        if not out:
            raise ValueError("bands: empty; give at least one band")
        return out
    raise ValueError("bands: expected a Band, a LimitState, a System, a list of them or a dict "
                     "{output: (lower, upper)}")


def _mode_variables(mode: Any) -> list[str]:
    return [mode.output] if isinstance(mode, Band) else list(mode.variables)


def _band_modes(
    blk: xr.Dataset, band: Band, valid: np.ndarray, n_t: int, first_sample: int,
) -> list[tuple[str, dict[str, Any], np.ndarray]]:
    """Failure indicators ``(n_valid_in_block, n_t)`` of each mode produced by ``band``."""
    da = blk[band.output]
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
    band.check_reach(da.attrs.get("valid_min"), str(da.attrs.get("units", "")))
    values = np.asarray(da.values, dtype=float)[valid]
    _check_finite(values, band.output, blk, valid, first_sample)
    meta = {
        "output": band.output, "lower": band.lower, "upper": band.upper,
        "absolute": int(band.absolute), "output_units": str(da.attrs.get("units", "")),
        "definition": band.describe(),
    }
    time_dep = "time" in da.dims
    out = []
    for idx in np.ndindex(*(da.sizes[d] for d in extra)) if extra else [()]:
        f = band.fails(values[(slice(None), *idx)])
        f = f.reshape(f.shape[0], -1) if time_dep else np.repeat(f[:, None], n_t, axis=1)
        label = band.name
        if extra:
            parts = [f"{d}={da[d].values[i] if d in da.coords else i}"
                     for d, i in zip(extra, idx, strict=True)]
            label = f"{band.name}[{', '.join(parts)}]"
        out.append((label, meta, f))
    return out


def _limit_state_mode(
    blk: xr.Dataset, mode: Any, valid: np.ndarray, time: Any, n_t: int, first_sample: int,
) -> list[tuple[str, dict[str, Any], np.ndarray]]:
    """Failure indicator ``g <= 0`` of a LimitState or System over the block's valid samples."""
    g = mode.values(blk)
    if "time" in g.dims:
        g = g.transpose("sample", "time")
        # a valid sample must give a finite g inside the window (checked before the instants
        # outside it are filled with +inf: they cannot fail)
        _check_finite(np.asarray(g.values, dtype=float)[valid], mode.name, blk, valid,
                      first_sample)
        if time is not None and g.sizes["time"] != len(time):
            g = g.reindex(time=time, fill_value=np.inf)
        values = np.asarray(g.values, dtype=float)[valid]
    else:
        values = np.asarray(g.values, dtype=float)[valid]
        _check_finite(values, mode.name, blk, valid, first_sample)
    f = values <= 0.0
    f = f if f.ndim == 2 else np.repeat(f[:, None], n_t, axis=1)
    units = ""
    if len(_mode_variables(mode)) == 1:
        units = str(blk[_mode_variables(mode)[0]].attrs.get("units", ""))
    meta = {"output": ",".join(_mode_variables(mode)), "lower": math.nan, "upper": math.nan,
            "absolute": 0, "output_units": units,
            "definition": f"limit state g <= 0 (boundary fails): {mode.description}"}
    return [(mode.name, meta, f)]


def _check_finite(values: np.ndarray, what: str, blk: xr.Dataset, valid: np.ndarray,
                  first_sample: int) -> None:
    bad = ~np.isfinite(values)
    if bad.any():
        rows = np.flatnonzero(bad.reshape(values.shape[0], -1).any(axis=1))
        ids = (np.asarray(blk["sample"].values)[valid][rows] if "sample" in blk.coords
               else rows + first_sample)
        raise ValueError(
            f"output {what!r}: {int(bad.sum())} non-finite value(s) in {rows.size} sample(s) "
            f"with status 0 (first: sample {ids[0]}); a valid sample must be finite - the model "
            "should have flagged it with a nonzero status")


# =========================================================================== streaming counts
#: Largest number of (sample x instant) values processed at once for an in-memory Dataset.
_BLOCK_VALUES = 2**24


def sample_blocks(ds: xr.Dataset, names: Sequence[str], n: int, n_t: int
                   ) -> list[tuple[int, int]]:
    """Sample ranges to process one at a time: the dask chunks of a lazily loaded result
    (one stored chunk at a time), else blocks of at most :data:`_BLOCK_VALUES` values."""
    for name in names:
        chunks = ds[name].chunksizes.get("sample") if ds[name].chunks is not None else None
        if chunks:
            edges = np.concatenate([[0], np.cumsum(chunks)])
            return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=True)]
    size = max(1, _BLOCK_VALUES // max(1, n_t))
    return [(s, min(s + size, n)) for s in range(0, n, size)]


class _Counts:
    """Integer failure counts per mode, summed over sample blocks (additive, so streaming
    gives exactly the in-memory numbers)."""

    def __init__(self, n_t: int, system: bool, first_passage: bool) -> None:
        self.n_t, self.system, self.first_passage = n_t, system, first_passage
        self.labels: list[str] = []
        self.metas: list[dict[str, Any]] = []
        self.k_inst: list[np.ndarray] = []
        self.k_fp: list[np.ndarray] = []
        self.k_half: list[int] = []

    def add_block(self, block_modes: list[tuple[str, dict[str, Any], np.ndarray]],
                  n_block_valid: int) -> None:
        sys_f = np.zeros((n_block_valid, self.n_t), dtype=bool)
        first = not self.labels
        for i, (label, meta, f) in enumerate(block_modes):
            if first:
                if label in self.labels or label == SYSTEM_MODE:
                    raise ValueError(
                        f"duplicate or reserved mode label {label!r}; give each Band a "
                        f"distinct name=... (reserved: {SYSTEM_MODE!r})")
                self.labels.append(label)
                self.metas.append(meta)
                self.k_inst.append(np.zeros(self.n_t, dtype=np.int64))
                self.k_fp.append(np.zeros(self.n_t, dtype=np.int64))
                self.k_half.append(0)
            self._add(i, f)
            sys_f |= f
        if self.system:
            if first:
                self.labels.append(SYSTEM_MODE)
                self.metas.append({
                    "output": "*", "lower": math.nan, "upper": math.nan, "absolute": 0,
                    "output_units": "", "definition": "series system: fails if any mode fails"})
                self.k_inst.append(np.zeros(self.n_t, dtype=np.int64))
                self.k_fp.append(np.zeros(self.n_t, dtype=np.int64))
                self.k_half.append(0)
            self._add(len(self.labels) - 1, sys_f)

    def _add(self, i: int, f: np.ndarray) -> None:
        self.k_inst[i] += f.sum(axis=0)
        if self.first_passage:
            self.k_fp[i] += np.logical_or.accumulate(f, axis=1).sum(axis=0)
            self.k_half[i] += int(f[:, ::2].any(axis=1).sum())


# =========================================================================== reliability
def reliability(
    ds: xr.Dataset,
    bands: Any,
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
        taken as valid (recorded in the attrs). A lazily loaded, dask-backed result (what
        ``monte_carlo(..., store=DIR)`` returns) is processed one stored chunk at a time, never
        loaded whole; failure counts are additive over chunks, so the result is identical to
        the in-memory one.
    bands : Band, LimitState, System, list of them, or dict
        Failure modes. A dict maps an output name to ``(lower, upper)`` (``None`` = open side),
        to a :class:`Band` or to a dict of :class:`Band` keyword arguments. A
        :class:`~gearuq.failure.modes.LimitState` or :class:`~gearuq.failure.modes.System` fails
        where its ``g <= 0`` (the boundary fails; a band's limits are safe).
    confidence : float
        Two-sided confidence level of the intervals.
    interval : {"wilson", "clopper-pearson"}
        Binomial interval method (see :func:`wilson_interval`, :func:`clopper_pearson_interval`).
    system : bool
        Add the series-system mode ``"system"``: a sample fails when ANY mode fails at that
        instant. Computed from the same samples, so the dependence between modes is kept.
    first_passage : bool
        Add first-passage (cumulative) estimates ``*_first_passage``: a sample has failed by
        ``t`` if it failed at any output instant ``<= t`` of the (selected) window. Only when
        some mode depends on time. The grid check ``pf_first_passage_grid_gap`` says how
        much the estimate moves when every other instant is dropped.
    time : slice, (t0, t1), array_like or scalar, optional
        Restrict the window: a slice / pair selects by label, values select the nearest
        instants. The first-passage window starts at the first selected instant. A window or
        an instant outside the Dataset's instants is refused (ValueError), as
        ``LimitState(window=...)`` refuses it: the first passage there is unknown.

    Returns
    -------
    xarray.Dataset
        Dims ``mode`` (mode labels, then ``"system"``) and ``time`` (if any mode depends on
        it). Variables (all units "1"): ``n_failures``, ``pf``, ``pf_lower``, ``pf_upper``,
        ``r``, ``r_lower``, ``r_upper``, ``beta``, ``beta_lower``, ``beta_upper``,
        ``beta_is_lower_bound``, ``beta_is_upper_bound`` (int8 flags), ``cov_pf``,
        ``pf_if_invalid_failed``, ``pf_if_invalid_safe``; the same with ``_first_passage``
        after the stem (``pf_first_passage``, ``pf_first_passage_upper``, ...);
        ``pf_first_passage_grid_gap`` and ``first_passage_grid_warning`` per mode; scalars
        ``n_samples``, ``n_valid``, ``n_invalid``. Mode coordinates ``output``, ``lower``,
        ``upper`` (+-inf for open sides; NaN for limit states and the system), ``absolute``,
        ``output_units``, ``definition``. ``attrs["interval_validity"]`` says whether the
        binomial interval is valid for the design that produced ``ds`` (``attrs["rule"]``).

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
    method = interval_method(interval)
    if not 0.0 < float(confidence) < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    system = check_bool("system", system)
    first_passage = check_bool("first_passage", first_passage)
    modes = as_modes(bands)
    if "sample" not in ds.dims:
        raise ValueError("reliability: the Dataset has no 'sample' dimension")
    ds = _select_time(ds, time)
    valid, status_note = valid_samples(ds)
    n_samples, n_valid = valid.size, int(valid.sum())
    used = list(dict.fromkeys(v for m in modes for v in _mode_variables(m)))
    missing = [o for o in used if o not in ds.variables]
    if missing:
        outs = [k for k, v in ds.data_vars.items() if v.attrs.get("role") == "output"]
        raise ValueError(
            f"output(s) {', '.join(map(repr, missing))} not in the Dataset; available "
            f"outputs: {', '.join(outs or list(map(str, ds.data_vars)))}")
    has_time = any("time" in ds[o].dims for o in used)
    if time is not None and not has_time:
        raise ValueError(f"time={time!r} applies to nothing: no mode depends on time "
                         f"({', '.join(map(repr, used))} has no time dimension); leave it out")
    if has_time:
        tvals = np.asarray(ds["time"].values)
        if tvals.size > 1 and np.any(np.diff(tvals.astype(float)) < 0):
            raise ValueError("reliability: time must be sorted in increasing order")
    n_t = ds.sizes["time"] if has_time else 1
    counts = _Counts(n_t, system, first_passage and has_time)
    time_coord = ds["time"] if has_time else None
    for start, stop in sample_blocks(ds, used, n_samples, n_t):
        v = valid[start:stop]
        if not v.any() and counts.labels:
            continue
        blk = ds[used].isel(sample=slice(start, stop))
        found = []
        for mode in modes:
            if isinstance(mode, Band):
                found += _band_modes(blk, mode, v, n_t, start)
            else:
                found += _limit_state_mode(blk, mode, v, time_coord, n_t, start)
        counts.add_block(found, int(v.sum()))
    out = _assemble(ds, counts, has_time, n_valid, n_samples - n_valid, confidence, method)
    _describe(out, ds, modes, system, first_passage and has_time, status_note, n_samples,
              n_valid, confidence, method)
    return out


def valid_samples(ds: xr.Dataset) -> tuple[np.ndarray, str]:
    n_samples = int(ds.sizes["sample"])
    if n_samples == 0:
        raise ValueError("reliability: the Dataset has no samples")
    if "status" in ds.data_vars:
        status = np.asarray(ds["status"].values)
        if status.shape != (n_samples,):
            raise ValueError(f"status must have shape (n_samples,), got {status.shape}")
        valid = status == 0
        note = (
            "samples with nonzero status (solver failure) are excluded from every estimate; "
            "they are neither safe nor failed. n_invalid counts them; pf_if_invalid_failed / "
            "pf_if_invalid_safe show the estimate if they had all failed / all been safe")
    else:
        valid = np.ones(n_samples, dtype=bool)
        note = "no status variable in the input: every sample was taken as valid"
    if not valid.any():
        raise ValueError(
            f"reliability: no valid sample (all {n_samples} have nonzero status); "
            "nothing can be estimated")
    return valid, note


def _assemble(ds: xr.Dataset, counts: _Counts, has_time: bool, n_valid: int, n_invalid: int,
              confidence: float, method: str) -> xr.Dataset:
    """The result Dataset from the summed counts."""
    dims: tuple[str, ...] = ("mode", "time") if has_time else ("mode",)

    def shape(a: list[np.ndarray]) -> np.ndarray:
        arr = np.stack(a)
        return arr if has_time else arr[:, 0]

    metas = counts.metas
    coords: dict[str, Any] = {
        "mode": ("mode", np.array(counts.labels, dtype=str), {"long_name": "failure mode"}),
        "output": ("mode", np.array([m["output"] for m in metas], dtype=str),
                   {"long_name": "output variable(s) of the mode"}),
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
    sets = [(False, shape(counts.k_inst))]
    if counts.first_passage:
        sets.append((True, shape(counts.k_fp)))
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
    if counts.first_passage and ds.sizes["time"] >= 3:
        _grid_check(out, counts, n_valid)
    out["n_samples"] = ((), np.int32(n_valid + n_invalid),
                        {"units": "1", "long_name": "samples in input"})
    out["n_valid"] = ((), np.int32(n_valid), {
        "units": "1", "long_name": "samples with status 0 used in every estimate"})
    out["n_invalid"] = ((), np.int32(n_invalid), {
        "units": "1", "long_name": "samples with nonzero status, excluded"})
    return out


def _grid_check(out: xr.Dataset, counts: _Counts, n_valid: int) -> None:
    """How far the first-passage estimate on this time grid can be from continuous time.

    Dropping every other instant can only lose failures; the samples lost, ``d``, estimate
    the first-passage probability the full grid itself still misses if that loss shrinks at
    least linearly with the spacing (true for smooth responses as the grid is refined:
    ``M(h) = (M(2h) - M(h)) / (2^p - 1) <= M(2h) - M(h)`` for ``M(h) ~ h^p``, ``p >= 1``).
    """
    k_full = np.array([k[-1] for k in counts.k_fp], dtype=np.int64)
    gap = (k_full - np.array(counts.k_half, dtype=np.int64)) / n_valid
    half_width = out["pf_first_passage_upper"].isel(time=-1).values - \
        out["pf_first_passage"].isel(time=-1).values
    warn = (gap > 0) & (gap > 0.5 * half_width)
    out["pf_first_passage_grid_gap"] = ("mode", gap, {
        "units": "1",
        "long_name": (
            "first-passage Pf over the window on this grid minus the same on every other "
            "instant; estimates how much the continuous-time Pf can exceed the grid value "
            "(assuming the missed probability shrinks at least linearly with the spacing)")})
    out["first_passage_grid_warning"] = ("mode", warn.astype(np.int8), {
        "units": "1", "flag_values": np.array([0, 1], dtype=np.int8),
        "flag_meanings": "grid_resolves grid_too_coarse",
        "long_name": ("1 where the grid gap exceeds half the interval width: refine the time "
                      "grid or use gearuq.failure.outcrossing.first_passage with the derivative")})


_RULE_VALIDITY = {
    "random": "valid: i.i.d. samples (rule='random')",
    "lhs": ("conservative: the binomial interval assumes i.i.d. samples; a Latin hypercube's "
            "variance is at most n/(n-1) times the i.i.d. one (Owen 1997), so it is about as "
            "wide or wider than needed. For a real interval use failure_probability(..., "
            "method='mc', rule='lhs', replicates=R)"),
    "sobol": ("not guaranteed: the binomial interval assumes i.i.d. samples; for scrambled QMC "
              "designs and a discontinuous failure indicator it is neither exact nor proven "
              "conservative. Use failure_probability(..., method='mc', rule='sobol', "
              "replicates=R) for an interval from independent randomisations"),
}
_RULE_VALIDITY["halton"] = _RULE_VALIDITY["sobol"].replace("rule='sobol'", "rule='halton'")


def _describe(out: xr.Dataset, ds: xr.Dataset, modes: list[Any], system: bool, fp: bool,
              status_note: str, n_samples: int, n_valid: int, confidence: float,
              method: str) -> None:
    """Attributes of a reliability result."""
    out["n_invalid"].attrs["note"] = status_note
    rule = str(ds.attrs.get("rule", "")).lower()
    mode_json = json.dumps([_mode_json(m) for m in modes])
    out.attrs.update({
        "description": (
            "Monte Carlo reliability: failure probability, reliability and generalised "
            "reliability index beta = Phi^-1(R) per failure mode"
            + (", series system" if system else "")
            + (" and first-passage over the time window" if fp else "")),
        "confidence": float(confidence),
        "interval": method,
        "design_rule": rule or "unknown",
        "interval_validity": _RULE_VALIDITY.get(
            rule, "valid only if the samples are i.i.d. (the design rule is not recorded)"),
        "failure_definition": (
            "a sample fails a band at an instant when its value (|value| for absolute bands) "
            "is outside the closed interval [lower, upper] (values on a limit are safe); it "
            "fails a limit state where g <= 0 (the boundary fails)"),
        "beta_definition": (
            "generalised index beta = Phi^-1(R) = -Phi^-1(pf); zero/all failures give a "
            "finite one-sided bound flagged by beta_is_lower_bound / beta_is_upper_bound"),
        "system_definition": "series: fails if any mode fails at that instant (same samples)",
        "invalid_samples": status_note,
        "n_samples": n_samples,
        "n_valid": n_valid,
        "n_invalid": n_samples - n_valid,
        "bands": mode_json,
    })
    if "model" in ds.attrs:
        out.attrs["model"] = str(ds.attrs["model"])


def _mode_json(m: Any) -> dict[str, Any]:
    if isinstance(m, Band):
        return {"name": m.name, "output": m.output,
                "lower": None if m.lower == -math.inf else m.lower,
                "upper": None if m.upper == math.inf else m.upper,
                "absolute": m.absolute, "select": {k: str(v) for k, v in m.select.items()}}
    return m.to_dict()
