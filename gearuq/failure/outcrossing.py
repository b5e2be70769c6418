"""Time-variant reliability: out-crossing rates (Rice, PHI2) and first passage on a time grid.

Three questions about a response ``y(t)`` and a level ``u`` (failure: ``y >= u``):

* **How often does it cross?** :func:`rice_rate` estimates the up-crossing rate
  ``nu+(u, t) = int_0^inf v f(u, v; t) dv`` (Rice 1944) from response samples that carry the
  derivative output too (``dp1`` for ``p1`` in ``helical_pair``), by a kernel estimate of the
  joint density of value and derivative, by a Gaussian fit of it (exact for Gaussian
  responses), or by counting grid crossings.
* **What does a random-variable model say?** :func:`phi2` is the PHI2 method
  (Andrieu-Renaud, Sudret and Lemaire 2004) in its asymptotic form (Sudret 2008): two FORM
  analyses per instant give ``beta(t)`` and ``alpha(t)``; then
  ``nu+(t) = |alpha'(t)| phi(beta) Psi(beta'(t) / |alpha'(t)|)``, ``Psi(x) = phi(x) - x Phi(-x)``.
* **How far is a grid from continuous time?** :func:`first_passage` compares the grid estimate
  (fails if ``y >= u`` at an output instant) with a per-sample cubic Hermite reconstruction
  between instants (value and derivative at both ends: a crossing between instants is found
  exactly up to the interpolation error) and with the Poisson-Rice estimate
  ``1 - (1 - P(y(t0) >= u)) exp(-int nu+ dt)``; it also gives the grid's resolution of the
  response (instants per mean zero-crossing period and the worst-case peak loss of a harmonic
  sampled at that spacing).

All three read lazily loaded (dask) results one stored chunk at a time.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from gearuq.failure.api import validate_settings
from gearuq.failure.evaluator import LimitStateEvaluator
from gearuq.failure.intervals import wilson_interval
from gearuq.failure.methods.form import design_point_search
from gearuq.failure.samples import sample_blocks, valid_samples

__all__ = ["rice_rate", "first_passage", "phi2", "hermite_crossing"]

RICE_METHODS = ("kde", "gaussian", "count")


# =========================================================================== helpers
def _signed(ds: xr.Dataset, output: str, derivative: str | None, side: str
            ) -> tuple[xr.DataArray, xr.DataArray | None, float]:
    if side not in ("upper", "lower"):
        raise ValueError(f"side: expected 'upper' or 'lower', got {side!r}")
    for name in (output, derivative):
        if name is not None and name not in ds.variables:
            outs = [k for k, v in ds.data_vars.items() if v.attrs.get("role") == "output"]
            raise ValueError(f"output {name!r} not in the Dataset; available outputs: "
                             f"{', '.join(outs or map(str, ds.data_vars))}")
    y = ds[output]
    if "time" not in y.dims or "sample" not in y.dims:
        raise ValueError(f"output {output!r} must have dims 'sample' and 'time', got {y.dims}")
    sign = 1.0 if side == "upper" else -1.0
    dy = None if derivative is None else ds[derivative]
    if dy is not None and dy.dims != y.dims:
        raise ValueError(f"derivative {derivative!r} has dims {dy.dims}, {output!r} has {y.dims}")
    return y, dy, sign


def _blocks(ds: xr.Dataset, names: list[str]) -> tuple[np.ndarray, list[tuple[int, int]]]:
    valid, _ = valid_samples(ds)
    return valid, sample_blocks(ds, names, valid.size, ds.sizes["time"])


def _values(da: xr.DataArray, start: int, stop: int, valid: np.ndarray, sign: float
            ) -> np.ndarray:
    v = sign * np.asarray(da.isel(sample=slice(start, stop)).transpose("sample", "time").values,
                          dtype=float)[valid[start:stop]]
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{da.name!r}: non-finite value in a sample with status 0")
    return v


# =========================================================================== Rice
def rice_rate(
    ds: xr.Dataset,
    output: str,
    level: float,
    *,
    derivative: str | None = None,
    method: str = "kde",
    side: str = "upper",
    bandwidth: float | None = None,
    confidence: float = 0.95,
) -> xr.Dataset:
    """Up-crossing rate of ``level`` by ``output`` at every output instant, from samples.

    Parameters
    ----------
    ds : xarray.Dataset
        Result with ``output`` (and ``derivative``) over ``sample`` and ``time``.
    output : str
        Response ``y``.
    level : float
        Level ``u``.
    derivative : str, optional
        Output holding ``dy/dt`` in the same time units (required by "kde" and "gaussian").
    method : {"kde", "gaussian", "count"}
        ``"kde"``: ``nu+ = mean(K_h(y_i - u) max(v_i, 0))`` with a Gaussian kernel of width
        ``h`` (default Silverman's ``1.06 s_y n^-1/5`` per instant), standard error from the
        summands. ``"gaussian"``: Rice's formula for jointly Gaussian ``(y, v)`` with the
        sample mean and covariance per instant (``f_Y(u) [s phi(m/s) + m Phi(m/s)]``, ``m``,
        ``s`` the conditional mean and std of ``v`` given ``y = u``). ``"count"``: fraction of
        samples crossing between consecutive instants over the step (at the midpoints; misses
        double crossings within a step).
    side : {"upper", "lower"}
        Up-crossings of ``u`` (failure ``y >= u``) or down-crossings (failure ``y <= u``).
    bandwidth : float, optional
        Kernel width in output units (``"kde"``).
    confidence : float
        Two-sided level of the normal interval (``"kde"`` and ``"count"``).

    Returns
    -------
    xarray.Dataset
        ``rate`` over ``time`` (units: 1 / time units), ``rate_lower``, ``rate_upper``,
        ``n_valid``; attrs with the method and level.
    """
    if method not in RICE_METHODS:
        raise ValueError(f"method: unknown {method!r}; valid: {', '.join(RICE_METHODS)}")
    if method != "count" and derivative is None:
        raise ValueError(f"method {method!r} needs the derivative output (derivative=...)")
    y, dy, sign = _signed(ds, output, derivative, side)
    u = sign * float(level)
    valid, blocks = _blocks(ds, [output] + ([derivative] if derivative else []))
    n = int(valid.sum())
    t = np.asarray(ds["time"].values, dtype=float)
    z = stats.norm.isf((1 - confidence) / 2)
    if method == "count":
        rate, se, times = _count_rate(y, valid, blocks, u, sign, t)
    elif method == "gaussian":
        rate, se, times = _gaussian_rate(y, dy, valid, blocks, u, sign), np.full(t.size, np.nan), t
    else:
        rate, se, times = _kde_rate(y, dy, valid, blocks, u, sign, bandwidth), None, t
        rate, se = rate
    t_units = str(ds["time"].attrs.get("units", ""))
    unit = f"{t_units}-1" if t_units and t_units != "1" else "1"
    out = xr.Dataset(
        {"rate": ("time", rate, {"units": unit, "long_name": f"{'up' if sign > 0 else 'down'}-"
                                 f"crossing rate of {level:g} by {output}"}),
         "rate_lower": ("time", np.maximum(rate - z * se, 0.0), {"units": unit}),
         "rate_upper": ("time", rate + z * se, {"units": unit}),
         "n_valid": ((), np.int64(n), {"units": "1"})},
        coords={"time": ("time", times, dict(ds["time"].attrs))})
    out.attrs.update({"method": method, "level": float(level), "side": side, "output": output,
                      "derivative": derivative or "none", "confidence": confidence})
    return out


def _kde_rate(y: xr.DataArray, dy: xr.DataArray, valid: np.ndarray, blocks: list, u: float,
              sign: float, bandwidth: float | None) -> tuple[np.ndarray, np.ndarray]:
    n_t = y.sizes["time"]
    if bandwidth is None:  # Silverman from the streamed moments (first pass)
        m1, m2, n = np.zeros(n_t), np.zeros(n_t), 0
        for a, b in blocks:
            v = _values(y, a, b, valid, sign)
            m1 += v.sum(0)
            m2 += (v * v).sum(0)
            n += v.shape[0]
        sd = np.sqrt(np.maximum(m2 / n - (m1 / n) ** 2, 0.0))
        h = 1.06 * sd * n ** -0.2
    else:
        h = np.full(n_t, float(bandwidth))
        n = int(valid.sum())
    if np.any(~(h > 0)):
        raise ValueError("rice_rate: zero spread of the output at some instant; give bandwidth")
    s1, s2 = np.zeros(n_t), np.zeros(n_t)
    for a, b in blocks:
        v = _values(y, a, b, valid, sign)
        d = _values(dy, a, b, valid, sign)
        term = stats.norm.pdf((v - u) / h) / h * np.maximum(d, 0.0)
        s1 += term.sum(0)
        s2 += (term * term).sum(0)
    rate = s1 / n
    se = np.sqrt(np.maximum(s2 / n - rate**2, 0.0) / n)
    return rate, se


def _gaussian_rate(y: xr.DataArray, dy: xr.DataArray, valid: np.ndarray, blocks: list,
                   u: float, sign: float) -> np.ndarray:
    n_t = y.sizes["time"]
    acc = {k: np.zeros(n_t) for k in ("y", "v", "yy", "vv", "yv")}
    n = 0
    for a, b in blocks:
        v = _values(y, a, b, valid, sign)
        d = _values(dy, a, b, valid, sign)
        for k, arr in (("y", v), ("v", d), ("yy", v * v), ("vv", d * d), ("yv", v * d)):
            acc[k] += arr.sum(0)
        n += v.shape[0]
    my, mv = acc["y"] / n, acc["v"] / n
    syy = acc["yy"] / n - my**2
    svv = acc["vv"] / n - mv**2
    syv = acc["yv"] / n - my * mv
    sy = np.sqrt(np.maximum(syy, 1e-300))
    m = mv + syv / syy * (u - my)
    s = np.sqrt(np.maximum(svv - syv**2 / syy, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        tail = np.where(s > 0, s * stats.norm.pdf(m / s) + m * stats.norm.cdf(m / s),
                        np.maximum(m, 0.0))
    return stats.norm.pdf((u - my) / sy) / sy * tail


def _count_rate(y: xr.DataArray, valid: np.ndarray, blocks: list, u: float, sign: float,
                t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if t.size < 2:
        raise ValueError("rice_rate(method='count'): needs at least two instants")
    k, n = np.zeros(t.size - 1), 0
    for a, b in blocks:
        v = _values(y, a, b, valid, sign)
        k += ((v[:, :-1] < u) & (v[:, 1:] >= u)).sum(0)
        n += v.shape[0]
    p = k / n
    dt = np.diff(t)
    return p / dt, np.sqrt(p * (1 - p) / n) / dt, 0.5 * (t[1:] + t[:-1])


# =========================================================================== first passage
def hermite_crossing(y0: np.ndarray, y1: np.ndarray, d0: np.ndarray, d1: np.ndarray,
                     dt: np.ndarray | float, level: float) -> np.ndarray:
    """Whether the cubic Hermite interpolant between two instants reaches ``level``.

    ``y0, y1`` values and ``d0, d1`` derivatives at the ends of steps of length ``dt``
    (arrays broadcast). The interpolant's interior extrema are the roots of its derivative,
    a quadratic in the step fraction; the maximum over ``[0, 1]`` is compared with ``level``.
    """
    y0, y1, d0, d1 = (np.asarray(a, dtype=float) for a in (y0, y1, d0, d1))
    m0, m1 = d0 * dt, d1 * dt
    # p(s) = h00 y0 + h10 m0 + h01 y1 + h11 m1; p'(s) = a s^2 + b s + c
    a = 6 * y0 + 3 * m0 - 6 * y1 + 3 * m1
    b = -6 * y0 - 4 * m0 + 6 * y1 - 2 * m1
    c = m0
    peak = np.maximum(y0, y1)
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = b * b - 4 * a * c
        root = np.sqrt(np.maximum(disc, 0.0))
        cands = [(-b + root) / (2 * a), (-b - root) / (2 * a),
                 np.where(b != 0, -c / b, np.nan)]
    for i, s in enumerate(cands):
        if i < 2:
            s = np.where((a != 0) & (disc >= 0), s, np.nan)
        else:
            s = np.where(a == 0, s, np.nan)
        inside = (s > 0) & (s < 1)
        s = np.where(inside, s, 0.0)
        s2, s3 = s * s, s * s * s
        p = ((2 * s3 - 3 * s2 + 1) * y0 + (s3 - 2 * s2 + s) * m0
             + (-2 * s3 + 3 * s2) * y1 + (s3 - s2) * m1)
        peak = np.where(inside, np.maximum(peak, p), peak)
    return peak >= level


def first_passage(
    ds: xr.Dataset,
    output: str,
    level: float,
    *,
    derivative: str | None = None,
    side: str = "upper",
    confidence: float = 0.95,
    rice: str = "kde",
) -> xr.Dataset:
    """First-passage probability ``P(max_t y(t) >= level)`` over the window, three ways.

    Parameters
    ----------
    ds : xarray.Dataset
        Result with ``output`` (and ``derivative``) over ``sample`` and ``time``.
    output, level, derivative, side :
        As in :func:`rice_rate`. Without ``derivative`` only the grid estimate and the
        half-grid check are given.
    confidence : float
        Level of the Wilson intervals.
    rice : {"kde", "gaussian"}
        Rate estimate used by the Poisson-Rice correction.

    Returns
    -------
    xarray.Dataset
        ``pf_grid`` (fails at an output instant) with ``pf_grid_lower/upper``;
        ``pf_half_grid`` (every other instant) and ``grid_gap`` (their difference);
        with a derivative: ``pf_hermite`` (+ interval; failure anywhere on the Hermite
        reconstruction) and ``pf_rice`` (Poisson with the Rice rate), the mean zero-crossing
        period ``period``, ``points_per_period`` and ``peak_loss`` = ``(pi dt / T)^2 / 2``,
        the worst relative peak a harmonic of period ``T`` loses between instants ``dt``
        apart. ``attrs["verdict"]`` says whether the grid resolves the first passage.
    """
    y, dy, sign = _signed(ds, output, derivative, side)
    u = sign * float(level)
    valid, blocks = _blocks(ds, [output] + ([derivative] if derivative else []))
    t = np.asarray(ds["time"].values, dtype=float)
    if t.size < 2:
        raise ValueError("first_passage: needs at least two output instants")
    dt = np.diff(t)
    k_grid = k_half = k_herm = 0
    n = 0
    sums = np.zeros(2)  # within-sample squared deviations of y and y' (zero-crossing period)
    for a, b in blocks:
        v = _values(y, a, b, valid, sign)
        grid_fail = (v >= u).any(axis=1)
        k_grid += int(grid_fail.sum())
        k_half += int((v[:, ::2] >= u).any(axis=1).sum())
        n += v.shape[0]
        if dy is not None:
            d = _values(dy, a, b, valid, sign)
            between = hermite_crossing(v[:, :-1], v[:, 1:], d[:, :-1], d[:, 1:], dt, u)
            k_herm += int((grid_fail | between.any(axis=1)).sum())
            # deviations from each sample's own time mean: the period is a property of the
            # time history, not of the scatter between samples
            sums += [np.sum((v - v.mean(axis=1, keepdims=True)) ** 2),
                     np.sum((d - d.mean(axis=1, keepdims=True)) ** 2)]
    lo, up = wilson_interval(k_grid, n, confidence)
    data: dict[str, Any] = {
        "pf_grid": ((), k_grid / n, {"units": "1", "long_name":
                    "first passage on the output instants only"}),
        "pf_grid_lower": ((), float(lo), {"units": "1"}),
        "pf_grid_upper": ((), float(up), {"units": "1"}),
        "pf_half_grid": ((), k_half / n, {"units": "1", "long_name":
                         "first passage on every other instant"}),
        "grid_gap": ((), (k_grid - k_half) / n, {"units": "1", "long_name":
                     "pf_grid - pf_half_grid: estimate of the probability the grid misses"}),
        "n_valid": ((), np.int64(n), {"units": "1"}),
    }
    verdict = ""
    if dy is not None:
        data.update(_continuous_estimates(ds, output, derivative, level, side, rice, k_herm, n,
                                          sums, dt, confidence, t))
        gap = data["pf_hermite"][1] - k_grid / n
        verdict = ("the grid resolves the first passage (Hermite reconstruction adds "
                   f"{gap:.3g})" if gap <= 0.5 * (up - k_grid / n) else
                   f"the grid misses crossings: Hermite reconstruction adds {gap:.3g} "
                   f"({gap / max(data['pf_hermite'][1], 1e-300):.0%} of the continuous-time "
                   f"estimate); use pf_hermite or refine the grid")
    else:
        gap = (k_grid - k_half) / n
        verdict = ("no derivative given: the half-grid gap " + f"{gap:.3g}"
                   + (" is below half the interval width" if gap <= 0.5 * (up - k_grid / n)
                      else " exceeds half the interval width: refine the grid or give the "
                      "derivative output"))
    out = xr.Dataset(data)
    out.attrs.update({"output": output, "level": float(level), "side": side,
                      "derivative": derivative or "none", "confidence": confidence,
                      "verdict": verdict, "window": f"[{t[0]:g}, {t[-1]:g}]",
                      "n_instants": int(t.size)})
    return out


def _continuous_estimates(ds: xr.Dataset, output: str, derivative: str, level: float,
                          side: str, rice: str, k_herm: int, n: int, sums: np.ndarray,
                          dt: np.ndarray, confidence: float, t: np.ndarray) -> dict[str, Any]:
    lo, up = wilson_interval(k_herm, n, confidence)
    rate = rice_rate(ds, output, level, derivative=derivative, method=rice, side=side)
    nu = rate["rate"].values
    integral = float(np.sum(0.5 * (nu[1:] + nu[:-1]) * dt))
    sign = 1.0 if side == "upper" else -1.0
    v0 = sign * np.asarray(ds[output].isel(time=0).values, dtype=float)
    valid, _ = _blocks(ds, [output])
    p0 = float(np.mean(v0[valid] >= sign * level))
    pf_rice = 1.0 - (1.0 - p0) * math.exp(-integral)
    var_y, var_v = sums[0], sums[1]
    period = 2 * math.pi * math.sqrt(var_y / var_v) if var_v > 0 else math.inf
    step = float(np.max(dt))
    return {
        "pf_hermite": ((), k_herm / n, {"units": "1", "long_name":
                       "first passage anywhere on the cubic Hermite reconstruction"}),
        "pf_hermite_lower": ((), float(lo), {"units": "1"}),
        "pf_hermite_upper": ((), float(up), {"units": "1"}),
        "pf_rice": ((), pf_rice, {"units": "1", "long_name":
                    "Poisson-Rice: 1 - (1 - P(y(t0) >= u)) exp(-int nu+ dt); conservative when "
                    "crossings cluster (a sample near the level crosses many times)"}),
        "expected_crossings": ((), integral, {"units": "1", "long_name":
                               "int nu+ dt over the window"}),
        "period": ((), period, {"units": str(ds["time"].attrs.get("units", "")), "long_name":
                   "mean zero-crossing period 2 pi sqrt(var y / var y'), variances over time "
                   "within each sample"}),
        "points_per_period": ((), period / step, {"units": "1", "long_name":
                              "period / largest step of the grid"}),
        "peak_loss": ((), 0.5 * (math.pi * step / period) ** 2, {"units": "1", "long_name":
                      "worst relative peak loss of a harmonic of that period between "
                      "instants, (pi dt / T)^2 / 2"}),
    }


# =========================================================================== PHI2
def phi2(
    model: Any,
    space: Any,
    limit_state: Any,
    t: Any,
    *,
    dt: float | None = None,
    model_options: Mapping[str, Any] | None = None,
    executor: Any = None,
    store: str | os.PathLike | None = None,
    **form_settings: Any,
) -> xr.Dataset:
    """Out-crossing rate and first-passage bounds of a time-dependent limit state by PHI2.

    Parameters
    ----------
    model, space, limit_state :
        As in :func:`gearuq.failure_probability`; ``g(x, t)`` must depend on time through a
        time-dependent output.
    t : array_like
        Instants at which the rate is computed (sorted; at least two for the integral).
    dt : float, optional
        Time step of the finite differences of ``beta`` and ``alpha`` (default: 1e-3 times
        the smallest spacing of ``t``, or 1e-3 for a single instant).
    model_options : mapping, optional
        Declared model options.
    **form_settings
        FORM settings (see :data:`gearuq.engines.form.FORM_SETTINGS`).

    Returns
    -------
    xarray.Dataset
        Over ``time``: ``beta``, ``rate`` (PHI2 out-crossing rate into failure), ``beta_dot``,
        ``alpha_dot_norm``; scalars ``pf_initial = Phi(-beta(t0))``, ``expected_crossings``
        (trapezoidal integral of the rate), ``pf_upper_bound = pf_initial +
        expected_crossings`` and ``pf_poisson = 1 - (1 - pf_initial) exp(-expected
        crossings)``, ``n_model_runs``.
    """
    s = validate_settings("form", form_settings)
    times = np.atleast_1d(np.asarray(t, dtype=float))
    if times.ndim != 1 or not np.all(np.diff(times) > 0):
        raise ValueError("t: expected increasing instants")
    if dt is None:
        dt = 1e-3 * (float(np.min(np.diff(times))) if times.size > 1 else 1.0)
    if not dt > 0:
        raise ValueError(f"dt: must be positive, got {dt!r}")
    t0 = time.perf_counter()
    runs = 0
    beta = np.empty(times.size)
    rate = np.empty(times.size)
    beta_dot = np.empty(times.size)
    alpha_dot = np.empty(times.size)
    u_start = None
    for k, tk in enumerate(times):
        pair = []
        for j, instant in enumerate((tk, tk + dt)):
            ev = LimitStateEvaluator(model, space, limit_state, [instant],
                                     model_options=model_options, executor=executor,
                                     store=None if store is None else os.path.join(
                                         str(store), f"t{k}_{j}"), engine="phi2")
            start = np.zeros(ev.dim) if u_start is None else u_start
            rec = design_point_search(ev, start, s, f"phi2/t{k}/{j}")
            runs += ev.n_runs
            if not rec["converged"]:
                raise RuntimeError(f"phi2: FORM did not converge at t = {instant:g} "
                                   f"({rec['error'] or 'max_iter reached'})")
            b = float(np.linalg.norm(rec["u"]))
            if rec["g_start"] <= 0 and not np.any(start):
                b = -b
            pair.append((b, rec["u"] / b if b else rec["u"]))
            u_start = rec["u"]
        (b0, a0), (b1, a1) = pair
        beta[k] = b0
        beta_dot[k] = (b1 - b0) / dt
        alpha_dot[k] = float(np.linalg.norm(a1 - a0)) / dt
        rate[k] = _phi2_rate(b0, beta_dot[k], alpha_dot[k])
    return _phi2_report(times, beta, beta_dot, alpha_dot, rate, runs, dt, t0)


def _phi2_rate(beta: float, beta_dot: float, alpha_dot: float) -> float:
    """``|alpha'| phi(beta) Psi(beta' / |alpha'|)``, ``Psi(x) = phi(x) - x Phi(-x)``."""
    if alpha_dot == 0:
        return 0.0
    x = beta_dot / alpha_dot
    return alpha_dot * stats.norm.pdf(beta) * (stats.norm.pdf(x) - x * stats.norm.sf(x))


def _phi2_report(times: np.ndarray, beta: np.ndarray, beta_dot: np.ndarray,
                 alpha_dot: np.ndarray, rate: np.ndarray, runs: int, dt: float, t0: float
                 ) -> xr.Dataset:
    integral = float(np.sum(0.5 * (rate[1:] + rate[:-1]) * np.diff(times))) \
        if times.size > 1 else 0.0
    pf0 = float(stats.norm.sf(beta[0]))
    out = xr.Dataset(
        {"beta": ("time", beta, {"units": "1", "long_name": "FORM index at t"}),
         "beta_dot": ("time", beta_dot, {"long_name": "d beta / dt"}),
         "alpha_dot_norm": ("time", alpha_dot, {"long_name": "|d alpha / dt|"}),
         "rate": ("time", rate, {"long_name": "PHI2 out-crossing rate into failure"}),
         "pf_initial": ((), pf0, {"units": "1", "long_name": "Phi(-beta(t0))"}),
         "expected_crossings": ((), integral, {"units": "1", "long_name":
                                "trapezoidal integral of the rate"}),
         "pf_upper_bound": ((), min(pf0 + integral, 1.0), {"units": "1", "long_name":
                            "first-passage upper bound pf_initial + int nu dt"}),
         "pf_poisson": ((), 1 - (1 - pf0) * math.exp(-integral), {"units": "1",
                        "long_name": "Poisson approximation of the first passage"}),
         "n_model_runs": ((), np.int64(runs), {"units": "1"}),
         "wall_time": ((), time.perf_counter() - t0, {"units": "s"})},
        coords={"time": ("time", times)})
    out.attrs.update({"method": "PHI2 (asymptotic form, Sudret 2008)", "dt": dt})
    return out
