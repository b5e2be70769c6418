"""Global sensitivity: Sobol' indices (Monte Carlo with SALib, or from a PCE) and Morris screening.

:func:`sobol_indices`
    ``method="mc"``: SALib's Saltelli design (``SALib.sample.sobol.sample``, scrambled Sobol'
    base points, ``N (D + 2)`` model runs, ``N (2D + 2)`` with second order) and either
    SALib's analyser (``estimator="saltelli"``: Saltelli 2010 first order, Jansen total
    order, bootstrap half-widths) or the Jansen (1999) estimators written here
    (``estimator="jansen"``: ``S_i = (V - E[(f_B - f_ABi)^2]/2)/V``,
    ``ST_i = E[(f_A - f_ABi)^2]/(2V)``) with the same bootstrap. Every output column (time
    instant) is analysed, so time-dependent outputs give ``S1(t)``, ``ST(t)``.
    ``method="pce"``: fits :func:`gearuq.engines.pce.polynomial_chaos` on ``n_base`` samples
    and returns its analytic indices.
:func:`morris_screening`
    SALib's Morris trajectories and elementary effects (``mu``, ``mu_star``, ``sigma``,
    ``mu_star_conf``) for a cheap ranking.

SALib's estimators assume independent inputs; a correlated space is rejected by the Monte
Carlo routes with a clear error (use ``method="pce"``, whose indices then refer to the
independent germ variables of the Nataf decorrelation).

Results are Datasets over ``(output, parameter[, time])``. Estimates that are negative, or
whose interval crosses zero, are flagged in ``S1_flag`` / ``ST_flag`` (1 = not distinguishable
from zero at the confidence level) and listed in ``attrs["note"]``.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Iterable
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from gearuq.model import Model
from gearuq.space import ParameterSpace

__all__ = ["sobol_indices", "morris_screening", "ESTIMATORS"]

#: Monte Carlo Sobol' estimators.
ESTIMATORS = ("saltelli", "jansen")


def _prepare(model: Any, space: Any, t: Any, outputs: Any, route: str,
             options: dict[str, Any] | None = None):
    from gearuq.engines.montecarlo import resolve_model_and_space

    model, space = resolve_model_and_space(model, space)
    if route == "mc" and space.correlation is not None:
        raise ValueError(
            "sobol_indices/morris_screening: SALib's estimators assume independent inputs but "
            "this space has a correlation matrix; use method='pce' (indices of the "
            "independent germ of the Nataf decorrelation) or an independent space")
    request = model.prepare(t, outputs=outputs, **(options or {}))
    names, t_arr = list(request.outputs), request.t
    dims = {o: tuple(d for d in model.output(o).dims if d != "sample") for o in names}
    if len(set(dims.values())) > 1:
        raise ValueError(f"outputs: analyse outputs with the same dims together, got {dims}")
    return model, names, t_arr, dims[names[0]], request


def _columns(ds: xr.Dataset, names: list[str], valid: np.ndarray | None = None) -> np.ndarray:
    """(n, n_outputs, n_cols) array of the outputs."""
    cols = []
    for o in names:
        da = ds[o].transpose("sample", ...)
        cols.append(da.values.reshape(da.shape[0], -1))
    return np.stack(cols, axis=1)


def _base_coords(ds: xr.Dataset, dims: tuple[str, ...]) -> dict[str, Any]:
    coords = {}
    for d in dims:
        if d in ds.coords:
            coords[d] = (ds[d].dims, ds[d].values, dict(ds[d].attrs))
    return coords


def _flag(ds: xr.Dataset, keys: Iterable[str], confidence: float) -> xr.Dataset:
    notes = []
    for k in keys:
        if k not in ds:
            continue
        est = ds[k]
        lower = ds.get(f"{k}_lower")
        flag = est < 0
        if lower is not None:
            flag = flag | (lower < 0)
        ds[f"{k}_flag"] = flag.astype(np.int8)
        ds[f"{k}_flag"].attrs = {
            "long_name": f"1 where {k} is negative or its {confidence:.0%} interval crosses 0 "
                         "(not distinguishable from zero)", "units": "1"}
        neg = int((est < 0).sum())
        cross = int(ds[f"{k}_flag"].sum())
        if cross:
            notes.append(f"{k}: {neg} negative estimate(s), {cross} flagged (negative or "
                         "interval crossing 0): read them as zero within sampling error")
    ds.attrs["note"] = "; ".join(notes) if notes else "no negative estimate or interval at 0"
    return ds


def _jansen(a: np.ndarray, b: np.ndarray, ab: np.ndarray, ba: np.ndarray | None,
            second_order: bool) -> dict[str, np.ndarray]:
    """Jansen first/total (and Saltelli 2002 second-order) on arrays (N, m), (D, N, m)."""
    v = np.var(np.concatenate([a, b], axis=0), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        s1 = (v - 0.5 * np.mean((b[None] - ab) ** 2, axis=1)) / v
        st = 0.5 * np.mean((a[None] - ab) ** 2, axis=1) / v
        out = {"S1": s1, "ST": st}
        if second_order and ba is not None:
            d = ab.shape[0]
            s2 = np.full((d, d, a.shape[1]), np.nan)
            # SALib's (Saltelli 2002) closed second-order estimator, on the first-order
            # estimates of Saltelli 2010 so it stays comparable
            s1s = np.mean(b[None] * (ab - a[None]), axis=1) / v
            for j in range(d):
                for k in range(j + 1, d):
                    vjk = np.mean(ba[j] * ab[k] - a * b, axis=0) / v
                    s2[j, k] = s2[k, j] = vjk - s1s[j] - s1s[k]
            out["S2"] = s2
    return out


def sobol_indices(
    model: Model | str,
    space: ParameterSpace,
    t: Any = None,
    *,
    n_base: int,
    outputs: str | Iterable[str] | None = None,
    estimator: str = "saltelli",
    second_order: bool = False,
    n_bootstrap: int = 200,
    confidence: float = 0.95,
    rng: Any = None,
    method: str = "mc",
    executor: Any = "serial",
    pce_order: int | str = "auto",
    pce_options: dict[str, Any] | None = None,
    **options: Any,
) -> xr.Dataset:
    """Sobol' first, total (and second) order indices with bootstrap intervals.

    Parameters
    ----------
    model : Model or str
        The model.
    space : ParameterSpace
        Independent random inputs (the MC route rejects correlated spaces).
    t : array_like, optional
        Output instants for time-dependent outputs (indices per instant).
    n_base : int
        ``method="mc"``: SALib base sample size N (a power of 2); the model runs
        ``N (D + 2)`` times (``N (2D + 2)`` with ``second_order``). ``method="pce"``: the PCE
        design size.
    outputs : str or list of str, optional
        Outputs to analyse (same dims); default all.
    estimator : {"saltelli", "jansen"}
        MC estimator: SALib's ``analyze.sobol`` or the Jansen estimators.
    second_order : bool
        Also compute ``S2``.
    n_bootstrap : int
        Bootstrap resamples of the MC intervals.
    confidence : float
        Level of the intervals (normal approximation to the bootstrap spread, as SALib).
    rng : int, optional
        Seed of the design (and of the bootstrap).
    method : {"mc", "pce"}
        Monte Carlo estimators or analytic indices of a polynomial chaos surrogate.
    executor : optional
        As in :func:`gearuq.engines.montecarlo.monte_carlo`.
    pce_order, pce_options
        ``order`` and extra keywords of :func:`gearuq.engines.pce.polynomial_chaos`.
    **options
        Model options.

    Returns
    -------
    xarray.Dataset
        Over ``(output, parameter[, time])``: ``S1``, ``ST`` with ``*_conf`` (half-width),
        ``*_lower``, ``*_upper``, ``*_flag``; ``S2`` over ``(output, parameter, parameter_2
        [, time])`` on request. Attributes: ``method``, ``estimator``, ``n_base``,
        ``n_model_evaluations``, ``n_failed``, ``wall_time_s``, ``note``.

    Raises
    ------
    ValueError
        Correlated space (MC), unknown estimator/method, bad ``n_base``, failed samples in
        the Saltelli design (the estimator needs every run; a note names how many).
    """
    if method not in ("mc", "pce"):
        raise ValueError(f"method: unknown {method!r}; valid: mc, pce")
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator: unknown {estimator!r}; valid: {', '.join(ESTIMATORS)}")
    if isinstance(n_base, (bool, np.bool_)) or not isinstance(n_base, (int, np.integer)) \
            or n_base < 2:
        raise ValueError(f"n_base: expected an integer >= 2, got {n_base!r}")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence: must lie in (0, 1), got {confidence!r}")
    wall0 = time.perf_counter()
    model, names, t_arr, rest, request = _prepare(model, space, t, outputs, method, options)
    seed = 0 if rng is None else int(rng)
    if method == "pce":
        from gearuq.engines.pce import polynomial_chaos

        kw = {"rule": "sobol" if n_base & (n_base - 1) == 0 else "lhs", **(pce_options or {})}
        pce = polynomial_chaos(model, space, t_arr, order=pce_order, outputs=names,
                               n_samples=int(n_base), rng=seed, executor=executor,
                               **kw, **options)
        parts = [pce.sobol(o, second_order=second_order).drop_vars(["mean", "variance"])
                 for o in names]
        ds = xr.concat(parts, dim=xr.DataArray(names, dims="output", name="output"),
                       combine_attrs="drop_conflicts")
        for k in ("S1", "ST"):
            ds[f"{k}_conf"] = xr.full_like(ds[k], np.nan)
            ds[f"{k}_lower"] = ds[k]
            ds[f"{k}_upper"] = ds[k]
        ds["loo_error"] = ("output", [pce.loo_error[o] for o in names])
        ds.attrs["dependence_note"] = parts[0].attrs.get("note", "")
        ds.attrs.update({"method": "pce", "estimator": "pce_analytic", "n_base": int(n_base),
                         "pce_order": pce.order, "pce_terms": pce.n_terms,
                         "n_model_evaluations": pce.n_evaluations, "n_failed": pce.n_failed,
                         "interval_note": "no sampling interval: the PCE indices are exact "
                                          "for the surrogate; its LOO error is loo_error"})
        ds = _flag(ds, ("S1", "ST"), confidence)
        ds.attrs["wall_time_s"] = time.perf_counter() - wall0
        return ds

    from SALib.analyze import sobol as sobol_analyze
    from SALib.sample import sobol as sobol_sample

    from gearuq.execution import evaluate_chunks

    problem = space.to_salib(unsupported="unit")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # SALib's power-of-2 reminder
        xs = sobol_sample.sample(problem, int(n_base), calc_second_order=second_order,
                                 scramble=True, seed=seed)
    design = space.from_salib(xs, problem)
    model.validate_params(design)
    ds_m = evaluate_chunks(model, design, request, executor=executor, progress=False)
    status = np.asarray(ds_m["status"].values)
    n_failed = int((status != 0).sum())
    if n_failed:
        raise ValueError(
            f"sobol_indices: {n_failed} of {status.size} model runs failed (status != 0); the "
            "Saltelli estimators need every run of the design. Use method='pce' (failed "
            "samples excluded) or remove the cause")
    y = _columns(ds_m, names)  # (n_runs, n_out, m)
    n_out, m = y.shape[1], y.shape[2]
    d = space.dim
    step = 2 * d + 2 if second_order else d + 2
    yy = y.reshape(int(n_base), step, n_out * m)
    a, b = yy[:, 0], yy[:, -1]
    ab = np.moveaxis(yy[:, 1:d + 1], 1, 0)
    ba = np.moveaxis(yy[:, d + 1:2 * d + 1], 1, 0) if second_order else None
    z = stats.norm.ppf(0.5 + confidence / 2)
    keys = ["S1", "ST"] + (["S2"] if second_order else [])
    est: dict[str, np.ndarray] = {}
    conf: dict[str, np.ndarray] = {}
    if estimator == "saltelli":
        est = {k: np.full((d, d, n_out * m) if k == "S2" else (d, n_out * m), np.nan)
               for k in keys}
        conf = {k: np.full_like(v, np.nan) for k, v in est.items()}
        for c in range(n_out * m):
            col = y.reshape(-1, n_out * m)[:, c]
            if np.var(col) == 0:
                continue
            with warnings.catch_warnings(), np.errstate(divide="ignore", invalid="ignore"):
                warnings.simplefilter("ignore")
                r = sobol_analyze.analyze(problem, col, calc_second_order=second_order,
                                          num_resamples=n_bootstrap, conf_level=confidence,
                                          seed=seed)
            for k in keys:
                est[k][..., c] = r[k]
                conf[k][..., c] = r[f"{k}_conf"]
    else:
        est = _jansen(a, b, ab, ba, second_order)
        gen = np.random.default_rng(seed)
        boot = {k: [] for k in keys}
        for _ in range(int(n_bootstrap)):
            i = gen.integers(0, int(n_base), int(n_base))
            r = _jansen(a[i], b[i], ab[:, i], None if ba is None else ba[:, i], second_order)
            for k in keys:
                boot[k].append(r[k])
        with warnings.catch_warnings():  # the S2 diagonal is NaN by construction
            warnings.simplefilter("ignore", RuntimeWarning)
            conf = {k: z * np.nanstd(np.stack(boot[k]), axis=0, ddof=1) for k in keys}

    shape_rest = tuple(ds_m[names[0]].transpose("sample", ...).shape[1:])
    coords = {"output": names, "parameter": space.names, **_base_coords(ds_m, rest)}
    out = xr.Dataset(coords=coords)
    for k in keys:
        lead = ("parameter", "parameter_2") if k == "S2" else ("parameter",)
        nl = len(lead)
        e = est[k].reshape(*est[k].shape[:nl], n_out, *shape_rest)
        e = np.moveaxis(e, nl, 0)
        c = np.moveaxis(conf[k].reshape(*conf[k].shape[:nl], n_out, *shape_rest), nl, 0)
        dims = ("output", *lead, *rest)
        long = {"S1": "first-order", "ST": "total", "S2": "second-order"}[k]
        out[k] = (dims, e, {"long_name": f"{long} Sobol index", "units": "1"})
        out[f"{k}_conf"] = (dims, c, {"long_name": f"{confidence:.0%} bootstrap half-width"})
        out[f"{k}_lower"] = out[k] - out[f"{k}_conf"]
        out[f"{k}_upper"] = out[k] + out[f"{k}_conf"]
        if k == "S2":
            out = out.assign_coords(parameter_2=space.names)
    out.attrs.update({
        "method": "mc", "estimator": estimator, "n_base": int(n_base),
        "second_order": int(second_order), "n_bootstrap": int(n_bootstrap),
        "confidence": confidence, "seed": seed, "n_model_evaluations": int(status.size),
        "n_failed": n_failed, "model": model.name, "space": space.to_json(),
        "interval_note": "estimate +- z * bootstrap standard deviation (normal approximation)",
    })
    out = _flag(out, keys[:2], confidence)
    out.attrs["wall_time_s"] = time.perf_counter() - wall0
    return out


def morris_screening(
    model: Model | str,
    space: ParameterSpace,
    t: Any = None,
    *,
    n_trajectories: int,
    num_levels: int = 4,
    outputs: str | Iterable[str] | None = None,
    rng: Any = None,
    executor: Any = "serial",
    n_bootstrap: int = 200,
    confidence: float = 0.95,
    **options: Any,
) -> xr.Dataset:
    """Morris elementary-effects screening via SALib.

    The trajectories live in the unit hypercube of probabilities (SALib problem ``unif``
    [0, 1] per parameter). A level ``u`` is mapped to the cell midpoint
    ``(u (L - 1) + 1/2) / L`` before the inverse cdf, so unbounded marginals (normal) never
    meet ``F^-1(0) = -inf``; the effects are therefore per unit of probability, which makes
    ``mu_star`` comparable across parameters of different units.

    Returns
    -------
    xarray.Dataset
        Over ``(output, parameter[, time])``: ``mu``, ``mu_star``, ``sigma``,
        ``mu_star_conf`` and ``rank`` (1 = largest ``mu_star``); attrs
        ``n_model_evaluations`` = ``n_trajectories (D + 1)``.
    """
    from SALib.analyze import morris as morris_analyze
    from SALib.sample import morris as morris_sample

    from gearuq.execution import evaluate_chunks

    if isinstance(n_trajectories, (bool, np.bool_)) or not isinstance(
            n_trajectories, (int, np.integer)) or n_trajectories < 2:
        raise ValueError(f"n_trajectories: expected an integer >= 2, got {n_trajectories!r}")
    if not isinstance(num_levels, (int, np.integer)) or num_levels < 2 or num_levels % 2:
        raise ValueError(f"num_levels: expected an even integer >= 2, got {num_levels!r}")
    wall0 = time.perf_counter()
    model, names, t_arr, rest, request = _prepare(model, space, t, outputs, "mc", options)
    seed = 0 if rng is None else int(rng)
    d = space.dim
    problem = {"num_vars": d, "names": space.names, "bounds": [[0.0, 1.0]] * d}
    xu = morris_sample.sample(problem, int(n_trajectories), num_levels=int(num_levels),
                              seed=seed)
    u = (xu * (num_levels - 1) + 0.5) / num_levels
    design = space.transform(u)
    model.validate_params(design)
    ds_m = evaluate_chunks(model, design, request, executor=executor, progress=False)
    status = np.asarray(ds_m["status"].values)
    if np.any(status != 0):
        raise ValueError(f"morris_screening: {int((status != 0).sum())} model runs failed; "
                         "elementary effects need every run of a trajectory")
    y = _columns(ds_m, names)
    n_out, m = y.shape[1], y.shape[2]
    keys = ("mu", "mu_star", "sigma", "mu_star_conf")
    res = {k: np.full((d, n_out * m), np.nan) for k in keys}
    flat = y.reshape(y.shape[0], -1)
    for c in range(n_out * m):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = morris_analyze.analyze(problem, xu, flat[:, c], num_resamples=n_bootstrap,
                                       conf_level=confidence, num_levels=int(num_levels),
                                       seed=seed)
        for k in keys:
            res[k][:, c] = np.asarray(r[k], dtype=float)
    shape_rest = tuple(ds_m[names[0]].transpose("sample", ...).shape[1:])
    out = xr.Dataset(coords={"output": names, "parameter": space.names,
                             **_base_coords(ds_m, rest)})
    for k in keys:
        v = np.moveaxis(res[k].reshape(d, n_out, *shape_rest), 1, 0)
        out[k] = (("output", "parameter", *rest), v)
    order = np.argsort(np.argsort(-np.nan_to_num(out["mu_star"].values, nan=-np.inf), axis=1),
                       axis=1) + 1
    out["rank"] = (out["mu_star"].dims, order.astype(np.int16),
                   {"long_name": "rank by mu_star (1 = most influential)"})
    out.attrs.update({
        "method": "morris", "n_trajectories": int(n_trajectories),
        "num_levels": int(num_levels), "seed": seed, "model": model.name,
        "n_model_evaluations": int(status.size), "wall_time_s": time.perf_counter() - wall0,
        "units_note": "elementary effects per unit of probability (unit-hypercube steps)",
    })
    return out


def ranking(values: Any) -> list[int]:
    """Ranks (1 = largest) of a 1-D array of importance measures."""
    v = np.nan_to_num(np.asarray(values, dtype=float), nan=-math.inf)
    return list((np.argsort(np.argsort(-v)) + 1).astype(int))
