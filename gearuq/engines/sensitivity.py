"""Global sensitivity as design -> evaluate -> analyse: Sobol' indices and Morris screening.

Each method is three small steps, usable one by one (the way SALib splits ``sample`` and
``analyze``) or through a thin pipeline:

* Sobol' Monte Carlo: :func:`saltelli_design` -> :func:`gearuq.execution.evaluate_chunks`
  (chunked, storable, resumable) -> :func:`sobol_analysis` (of any evaluated Saltelli design);
* Sobol' from a surrogate: :func:`gearuq.engines.pce.polynomial_chaos` (or
  ``PolynomialChaos(space).fit(any labelled result)``) -> :func:`sobol_from_chaos`;
* Morris: :func:`morris_design` -> evaluate -> :func:`morris_analysis`.

:func:`sobol_indices` and :func:`morris_screening` chain the three (``store=`` makes them
resumable).

Sobol' Monte Carlo: SALib's Saltelli design (``SALib.sample.sobol.sample``, scrambled Sobol'
base points, ``N (D + 2)`` model runs, ``N (2D + 2)`` with second order) and either SALib's
analyser (``estimator="saltelli"``: Saltelli 2010 first order, Jansen total order, bootstrap
half-widths) or the Jansen (1999) estimators written here (``estimator="jansen"``:
``S_i = (V - E[(f_B - f_ABi)^2]/2)/V``, ``ST_i = E[(f_A - f_ABi)^2]/(2V)``) with the same
bootstrap. Every output column (time instant) is analysed, so time-dependent outputs give
``S1(t)``, ``ST(t)``.

SALib's estimators assume independent inputs; a correlated space is rejected by the Monte
Carlo routes with a clear error. The PCE route accepts it and returns the indices of the
Nataf innovations in parameter order, labelled as such (see
:meth:`gearuq.engines.pce.PolynomialChaos.sobol`).

Results are Datasets over ``(output, parameter[, time])``. Estimates that are negative, or
whose interval crosses zero, are flagged in ``S1_flag`` / ``ST_flag`` (1 = not distinguishable
from zero at the confidence level) and listed in ``attrs["note"]``. Interval ends that were not
estimated (the PCE route) are NaN, never a copy of the estimate.
"""

from __future__ import annotations

import math
import os
import time
import warnings
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from gearuq.model import Model, Request
from gearuq.runs import (
    check_positive_int,
    merge_model_options,
    provenance,
    resolve_model_and_space,
    resolve_seed,
    space_json,
)
from gearuq.space import ParameterSpace

__all__ = ["sobol_indices", "morris_screening", "saltelli_design", "sobol_analysis",
           "sobol_from_chaos", "morris_design", "morris_analysis", "ranking", "ESTIMATORS"]

#: Monte Carlo Sobol' estimators.
ESTIMATORS = ("saltelli", "jansen")
_LONG = {"S1": "first-order", "ST": "total", "S2": "second-order"}


# =========================================================================== checks
def _check_base(n_base: Any, power_of_two: bool = True) -> int:
    if isinstance(n_base, (bool, np.bool_)) or not isinstance(n_base, (int, np.integer)) \
            or n_base < 2:
        raise ValueError(f"n_base: expected an integer >= 2, got {n_base!r}")
    if power_of_two and n_base & (n_base - 1):
        # the Saltelli design draws a Sobol' sequence, balanced only at powers of 2
        below = 1 << (int(n_base).bit_length() - 1)
        raise ValueError(f"n_base: {n_base} is not a power of 2 (the Sobol' sequence of the "
                         f"design is balanced only at powers of 2); valid: e.g. {below} or "
                         f"{2 * below}")
    return int(n_base)


def _check_confidence(confidence: Any) -> float:
    if not isinstance(confidence, (int, float)) or not 0 < confidence < 1:
        raise ValueError(f"confidence: must lie in (0, 1), got {confidence!r}")
    return float(confidence)


def _require_independent(space: ParameterSpace, what: str) -> None:
    if not space.independent:
        raise ValueError(
            f"{what}: SALib's estimators assume independent inputs but this space has a "
            "correlation matrix; use method='pce' (indices of the Nataf innovations in "
            "parameter order, labelled as such) or an independent space")


def _space_of(ds: xr.Dataset, space: ParameterSpace | None) -> ParameterSpace:
    if space is not None:
        return space
    if "space" not in ds.attrs:
        raise ValueError("space: the Dataset records no space (attrs['space']); pass space=")
    return ParameterSpace.from_json(ds.attrs["space"])


def _output_names(ds: xr.Dataset, outputs: Any) -> tuple[list[str], tuple[str, ...]]:
    """Outputs to analyse (default: role 'output') and their common non-sample dims."""
    if outputs is None:
        names = [k for k, v in ds.data_vars.items()
                 if v.attrs.get("role") == "output" and "sample" in v.dims]
    else:
        names = [outputs] if isinstance(outputs, str) else list(dict.fromkeys(outputs))
    missing = [o for o in names if o not in ds or "sample" not in ds[o].dims]
    if missing or not names:
        raise ValueError(f"outputs: {missing or names} are not variables over 'sample' of the "
                         f"Dataset; it has {list(ds.data_vars)}")
    dims = {o: tuple(d for d in ds[o].dims if d != "sample") for o in names}
    if len(set(dims.values())) > 1:
        raise ValueError(f"outputs: analyse outputs with the same dims together, got {dims}")
    return names, dims[names[0]]


def _columns(ds: xr.Dataset, names: list[str]) -> np.ndarray:
    """``(n, n_outputs, n_columns)`` array of the outputs (loads lazily stored data)."""
    cols = []
    for o in names:
        da = ds[o].transpose("sample", ...)
        cols.append(np.asarray(da.values, dtype=float).reshape(da.shape[0], -1))
    return np.stack(cols, axis=1)


def _all_ok(ds: xr.Dataset, what: str, why: str) -> int:
    """Number of runs; a ValueError if any has nonzero status."""
    status = np.asarray(ds["status"].values) if "status" in ds else np.zeros(ds.sizes["sample"])
    n_failed = int(np.count_nonzero(status))
    if n_failed:
        raise ValueError(f"{what}: {n_failed} of {status.size} model runs failed (status != 0); "
                         f"{why}")
    return int(status.size)


def _base_coords(ds: xr.Dataset, dims: tuple[str, ...]) -> dict[str, Any]:
    return {d: (ds[d].dims, np.asarray(ds[d].values), dict(ds[d].attrs))
            for d in dims if d in ds.coords}


#: Meanings of ``S1_flag`` / ``ST_flag`` (and ``S2_flag``).
SOBOL_FLAGS = {0: "ok",
               1: "not distinguishable from zero (negative, or its interval crosses 0)",
               2: "impossible value (above 1, or S1 above ST beyond both intervals): "
                  "sampling error dominates; increase n_base",
               3: "undefined (the output does not vary over the design)"}


def _flag(ds: xr.Dataset, keys: Iterable[str], confidence: float) -> xr.Dataset:
    notes = []
    for k in keys:
        if k not in ds:
            continue
        est = ds[k]
        crosses = (est < 0) | (ds[f"{k}_lower"] < 0) if f"{k}_lower" in ds else est < 0
        impossible = est > 1.0
        if k == "S1" and {"ST", "S1_lower", "ST_upper"} <= set(ds.data_vars):
            # S1 <= ST for each input, and sum S1 <= 1 over independent inputs: broken
            # beyond the intervals only by sampling error
            impossible = (impossible | (ds["S1_lower"] > ds["ST_upper"])
                          | (ds["S1_lower"].clip(min=0).sum("parameter") > 1.0))
            total = est.sum("parameter", skipna=True)
            if float(total.max()) > 1.05:
                notes.append(f"S1: the first-order indices of an output sum to up to "
                             f"{float(total.max()):.2f} (at most 1 for independent inputs): "
                             "sampling error is large; increase n_base")
        undefined = est.isnull()
        flag = xr.where(undefined, 3, xr.where(impossible, 2, xr.where(crosses, 1, 0)))
        ds[f"{k}_flag"] = flag.astype(np.int8)
        ds[f"{k}_flag"].attrs = {
            "long_name": f"quality of {k} at the {confidence:.0%} level (see flag_meanings)",
            "units": "1", "flag_values": np.array(sorted(SOBOL_FLAGS), dtype=np.int8),
            "flag_meanings": " ".join(v.split(" (")[0].replace(" ", "_")
                                      for v in SOBOL_FLAGS.values())}
        neg = int((est < 0).sum())
        counts = {code: int((flag == code).sum()) for code in (1, 2, 3)}
        if counts[1]:
            notes.append(f"{k}: {neg} negative estimate(s), {counts[1]} flagged 1 (negative or "
                         "interval crossing 0): read them as zero within sampling error")
        notes += [f"{k}: {counts[code]} flagged {code}: {SOBOL_FLAGS[code]}"
                  for code in (2, 3) if counts[code]]
    ds.attrs["note"] = "; ".join(notes) if notes else "no negative estimate or interval at 0"
    return ds


# =========================================================================== Sobol' MC
def saltelli_design(space: ParameterSpace, n_base: int, *, second_order: bool = False,
                    rng: Any = None) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """SALib's Saltelli design of a space, and its layout.

    Parameters
    ----------
    space : ParameterSpace
        Independent inputs (kinds SALib lacks are sampled uniformly in probability and
        mapped by their inverse cdf).
    n_base : int
        Base sample size N (a power of 2); the design has ``N (D + 2)`` rows
        (``N (2D + 2)`` with ``second_order``), SALib's order ``A, AB_1..AB_D, [BA_1..BA_D,] B``
        per base row.
    second_order : bool
        Add the ``BA`` blocks for second-order indices.
    rng : int, Generator or None
        Seed of the scrambling (``None``: a fresh seed, recorded in the layout).

    Returns
    -------
    design : dict
        Parameter name -> values ``(n_runs,)``.
    layout : dict
        ``design="saltelli"``, ``n_base``, ``second_order``, ``seed``, ``space`` (JSON): what
        :func:`sobol_analysis` needs; store it in the result's attrs.
    """
    from SALib.sample import sobol as sobol_sample

    _require_independent(space, "saltelli_design")
    n_base = _check_base(n_base)
    seed = resolve_seed(rng)
    problem = space.to_salib(unsupported="unit")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # SALib's power-of-2 reminder
        xs = sobol_sample.sample(problem, n_base, calc_second_order=bool(second_order),
                                 scramble=True, seed=seed)
    layout = {"design": "saltelli", "n_base": n_base, "second_order": int(bool(second_order)),
              "seed": seed, "space": space_json(space)}
    return space.from_salib(xs, problem), layout


def _layout(ds: xr.Dataset, d: int, n_base: int | None, second_order: bool | None
            ) -> tuple[int, bool]:
    """Base size and second-order flag from arguments, attrs, or the number of runs."""
    n = ds.sizes["sample"]
    if second_order is None:
        second_order = bool(int(ds.attrs.get("second_order", 0)))
    step = 2 * d + 2 if second_order else d + 2
    if n_base is None:
        n_base = int(ds.attrs.get("n_base", n // step))
    if n_base * step != n:
        raise ValueError(
            f"design: {n} runs do not form a Saltelli design of {d} parameters with "
            f"n_base={n_base} and second_order={second_order} ({n_base * step} runs)")
    return int(n_base), bool(second_order)


def sobol_analysis(
    ds: xr.Dataset,
    *,
    outputs: str | Iterable[str] | None = None,
    space: ParameterSpace | None = None,
    n_base: int | None = None,
    second_order: bool | None = None,
    estimator: str = "saltelli",
    n_bootstrap: int = 200,
    confidence: float = 0.95,
    rng: Any = None,
) -> xr.Dataset:
    """Sobol' indices of a model evaluated on a Saltelli design (:func:`saltelli_design`).

    Parameters
    ----------
    ds : xarray.Dataset
        The evaluated design in SALib's row order (e.g. from
        :func:`gearuq.execution.evaluate_chunks`; lazily loaded results are fine).
    outputs : str or list of str, optional
        Outputs to analyse (same dims); default: the variables with ``role="output"``.
    space, n_base, second_order : optional
        The design's space and layout; default from ``ds.attrs`` (the layout of
        :func:`saltelli_design`), ``n_base`` else from the number of runs.
    estimator : {"saltelli", "jansen"}
        SALib's ``analyze.sobol`` or the Jansen estimators.
    n_bootstrap : int
        Bootstrap resamples of the intervals.
    confidence : float
        Level of the intervals (normal approximation to the bootstrap spread, as SALib).
    rng : int, Generator or None
        Seed of the bootstrap (``None``: fresh, recorded in ``attrs["bootstrap_seed"]``).

    Returns
    -------
    xarray.Dataset
        Over ``(output, parameter[, time])``: ``S1``, ``ST`` with ``*_conf`` (half-width),
        ``*_lower``, ``*_upper``, ``*_flag``; ``S2`` over ``(output, parameter, parameter_2
        [, time])`` for a second-order design.

    Raises
    ------
    ValueError
        Unknown estimator, a Dataset that is not a Saltelli design, or failed runs (the
        estimators need every run of the design).
    """
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator: unknown {estimator!r}; valid: {', '.join(ESTIMATORS)}")
    confidence = _check_confidence(confidence)
    n_bootstrap = check_positive_int("n_bootstrap", n_bootstrap)
    space = _space_of(ds, space)
    _require_independent(space, "sobol_analysis")
    names, rest = _output_names(ds, outputs)
    n_base, second_order = _layout(ds, space.dim, n_base, second_order)
    n_runs = _all_ok(ds, "sobol_analysis", "the Saltelli estimators need every run of the "
                     "design. Use method='pce' (failed samples excluded) or remove the cause")
    seed = resolve_seed(rng)
    y = _columns(ds, names)  # (n_runs, n_out, m)
    keys = ["S1", "ST"] + (["S2"] if second_order else [])
    if estimator == "saltelli":
        est, conf = _salib_sobol(space, y.reshape(n_runs, -1), n_base, second_order,
                                 n_bootstrap, confidence, seed, keys)
    else:
        est, conf = _jansen_bootstrap(y.reshape(n_runs, -1), space.dim, n_base, second_order,
                                      n_bootstrap, confidence, seed, keys)
    out = _sobol_dataset(ds, names, rest, space.names, est, conf, keys, confidence)
    out.attrs.update({
        "method": "mc", "estimator": estimator, "n_base": n_base,
        "second_order": int(second_order), "n_bootstrap": n_bootstrap,
        "confidence": confidence, "bootstrap_seed": seed, "n_model_evaluations": n_runs,
        "n_failed": 0, "space": space_json(space),
        "interval_note": "estimate +- z * bootstrap standard deviation (normal approximation)",
    })
    return _flag(out, keys[:2], confidence)


def _salib_sobol(space, y, n_base, second_order, n_bootstrap, confidence, seed, keys):
    """SALib's analyser, one output column at a time."""
    from SALib.analyze import sobol as sobol_analyze

    d, m = space.dim, y.shape[1]
    problem = space.to_salib(unsupported="unit")
    est = {k: np.full((d, d, m) if k == "S2" else (d, m), np.nan) for k in keys}
    conf = {k: np.full_like(v, np.nan) for k, v in est.items()}
    for c in range(m):
        if np.var(y[:, c]) == 0:
            continue
        with warnings.catch_warnings(), np.errstate(divide="ignore", invalid="ignore"):
            warnings.simplefilter("ignore")
            r = sobol_analyze.analyze(problem, y[:, c], calc_second_order=second_order,
                                      num_resamples=n_bootstrap, conf_level=confidence,
                                      seed=seed)
        for k in keys:
            est[k][..., c] = r[k]
            conf[k][..., c] = r[f"{k}_conf"]
    return est, conf


def _jansen(a: np.ndarray, b: np.ndarray, ab: np.ndarray, ba: np.ndarray | None,
            second_order: bool) -> dict[str, np.ndarray]:
    """Jansen first/total (and Saltelli 2002 second-order) on arrays (N, m), (D, N, m)."""
    v = np.var(np.concatenate([a, b], axis=0), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = {"S1": (v - 0.5 * np.mean((b[None] - ab) ** 2, axis=1)) / v,
               "ST": 0.5 * np.mean((a[None] - ab) ** 2, axis=1) / v}
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


def _jansen_bootstrap(y, d, n_base, second_order, n_bootstrap, confidence, seed, keys):
    """Jansen estimates on the whole design and bootstrap half-widths."""
    step = 2 * d + 2 if second_order else d + 2
    yy = y.reshape(n_base, step, -1)
    a, b = yy[:, 0], yy[:, -1]
    ab = np.moveaxis(yy[:, 1:d + 1], 1, 0)
    ba = np.moveaxis(yy[:, d + 1:2 * d + 1], 1, 0) if second_order else None
    est = _jansen(a, b, ab, ba, second_order)
    gen = np.random.default_rng(seed)
    boot: dict[str, list[np.ndarray]] = {k: [] for k in keys}
    for _ in range(n_bootstrap):
        i = gen.integers(0, n_base, n_base)
        r = _jansen(a[i], b[i], ab[:, i], None if ba is None else ba[:, i], second_order)
        for k in keys:
            boot[k].append(r[k])
    z = stats.norm.ppf(0.5 + confidence / 2)
    with warnings.catch_warnings():  # the S2 diagonal is NaN by construction
        warnings.simplefilter("ignore", RuntimeWarning)
        conf = {k: z * np.nanstd(np.stack(boot[k]), axis=0, ddof=1) for k in keys}
    return est, conf


def _sobol_dataset(ds, names, rest, parameters, est, conf, keys, confidence) -> xr.Dataset:
    """Estimates ``(D[, D], n_out * m)`` -> Dataset over (output, parameter[, ...])."""
    shape_rest = tuple(ds[names[0]].transpose("sample", ...).shape[1:])
    out = xr.Dataset(coords={"output": names, "parameter": parameters,
                             **_base_coords(ds, rest)})
    n_out = len(names)
    for k in keys:
        lead = ("parameter", "parameter_2") if k == "S2" else ("parameter",)
        nl = len(lead)
        e = np.moveaxis(est[k].reshape(*est[k].shape[:nl], n_out, *shape_rest), nl, 0)
        c = np.moveaxis(conf[k].reshape(*conf[k].shape[:nl], n_out, *shape_rest), nl, 0)
        dims = ("output", *lead, *rest)
        out[k] = (dims, e, {"long_name": f"{_LONG[k]} Sobol index", "units": "1"})
        out[f"{k}_conf"] = (dims, c, {"long_name": f"{confidence:.0%} bootstrap half-width",
                                      "units": "1"})
        out[f"{k}_lower"] = out[k] - out[f"{k}_conf"]
        out[f"{k}_upper"] = out[k] + out[f"{k}_conf"]
        if k == "S2":
            out = out.assign_coords(parameter_2=parameters)
    return out


# =========================================================================== Sobol' PCE
def sobol_from_chaos(pce: Any, outputs: str | Iterable[str] | None = None, *,
                     second_order: bool = False, confidence: float = 0.95) -> xr.Dataset:
    """Sobol' indices of a fitted polynomial chaos surrogate, in the schema of
    :func:`sobol_analysis`.

    The indices are exact for the surrogate; their error is that of the surrogate
    (``loo_error``, ``corrected_loo_error``, ``holdout_error`` per output). No sampling
    interval is estimated: ``*_conf``, ``*_lower`` and ``*_upper`` are NaN. For a correlated
    space the indices are those of the Nataf innovations in parameter order (coordinate
    ``germ_variable``; a UserWarning says so).
    """
    names = list(pce.output_names) if outputs is None else (
        [outputs] if isinstance(outputs, str) else list(outputs))
    parts = [pce.sobol(o, second_order=second_order).drop_vars(["mean", "variance"])
             for o in names]
    ds = xr.concat(parts, dim=xr.DataArray(names, dims="output", name="output"),
                   combine_attrs="drop_conflicts")
    for k in ("S1", "ST") + (("S2",) if second_order else ()):
        for end in ("conf", "lower", "upper"):
            ds[f"{k}_{end}"] = xr.full_like(ds[k], np.nan)
            ds[f"{k}_{end}"].attrs = {"long_name": f"{end} of {k}: not estimated on the PCE "
                                                   "route (NaN)", "units": "1"}
    for key, values in (("loo_error", pce.loo_error),
                        ("corrected_loo_error", pce.corrected_loo_error),
                        ("holdout_error", pce.holdout_error)):
        ds[key] = ("output", [float(values.get(o, math.nan)) for o in names],
                   {"long_name": f"relative {key.replace('_', ' ')} of the surrogate",
                    "units": "1"})
    ds.attrs["dependence_note"] = parts[0].attrs.get("note", "")
    ds.attrs.update({
        "method": "pce", "estimator": "pce_analytic", "pce_order": pce.order,
        "pce_method": pce.method, "pce_terms": pce.n_terms,
        "n_model_evaluations": pce.n_evaluations, "n_failed": pce.n_failed,
        "interval_note": "no sampling interval: the PCE indices are exact for the surrogate "
                         "(conf/lower/upper are NaN); its accuracy is loo_error, "
                         "corrected_loo_error and holdout_error",
    })
    return _flag(ds, ("S1", "ST"), confidence)


# =========================================================================== pipeline
def _evaluate_design(model: Model, design: Mapping[str, np.ndarray], layout: dict[str, Any],
                     request: Request, engine: str, **execution: Any) -> xr.Dataset:
    """Run a sensitivity design through the chunked, storable path; its layout (the
    structure the analysis needs) goes into the store fingerprint and the result attrs."""
    from gearuq.execution import evaluate_chunks

    model.validate_params(design)
    ds = evaluate_chunks(model, design, request, fingerprint={"engine": engine, **layout},
                         **execution)
    ds.attrs.update(layout)
    return ds


def sobol_indices(
    model: Model | str,
    space: ParameterSpace | Mapping[str, Any] | None,
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
    executor: Any = None,
    pce_order: int | str = "auto",
    pce_options: dict[str, Any] | None = None,
    store: str | os.PathLike | None = None,
    chunk_size: int | None = None,
    progress: bool | None = False,
    model_options: Mapping[str, Any] | None = None,
    **options: Any,
) -> xr.Dataset:
    # Long only by its documented keywords; the body is design -> evaluate -> analyse.
    """Sobol' first, total (and second) order indices: design -> evaluate -> analyse.

    Parameters
    ----------
    model : Model or str
        The model.
    space : ParameterSpace, mapping or None
        Random inputs (the MC route needs independent ones; ``None``: the model's default).
    t : array_like, optional
        Output instants for time-dependent outputs (indices per instant).
    n_base : int
        ``method="mc"``: SALib base sample size N (a power of 2); the model runs
        ``N (D + 2)`` times (``N (2D + 2)`` with ``second_order``). ``method="pce"``: the PCE
        design size.
    outputs : str or list of str, optional
        Outputs to analyse (same dims); default all.
    estimator, n_bootstrap, confidence
        See :func:`sobol_analysis`.
    second_order : bool
        Also compute ``S2``.
    rng : int, Generator or None
        Seed of the design and the bootstrap (``None``: fresh, recorded in ``attrs["seed"]``).
    method : {"mc", "pce"}
        Monte Carlo estimators or analytic indices of a polynomial chaos surrogate.
    executor, chunk_size, progress
        Passed to :func:`gearuq.execution.evaluate_chunks`.
    pce_order, pce_options
        ``order`` and extra keywords of :func:`gearuq.engines.pce.polynomial_chaos`.
    store : path-like, optional
        Directory of a durable, resumable evaluation (same arguments and seed resume it).
    model_options : mapping, optional
        Declared model options (solver/fidelity settings, see ``gearuq models NAME``); every
        engine accepts this spelling, validated before the design is drawn.
    **options
        Deprecated: model options as keywords (still accepted for one release, with a
        DeprecationWarning naming the ``model_options={...}`` spelling to use).

    Returns
    -------
    xarray.Dataset
        See :func:`sobol_analysis` / :func:`sobol_from_chaos`; provenance attributes
        (``engine``, ``model``, ``seed``, ``options``, ...), ``n_model_evaluations``,
        ``wall_time_s``.

    Raises
    ------
    ValueError
        Correlated space (MC), unknown estimator/method, bad ``n_base``, bad options, failed
        samples in the Saltelli design (the estimator needs every run).
    """
    if method not in ("mc", "pce"):
        raise ValueError(f"method: unknown {method!r}; valid: mc, pce")
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator: unknown {estimator!r}; valid: {', '.join(ESTIMATORS)}")
    n_base = _check_base(n_base, power_of_two=method == "mc")  # chaos: any training size
    confidence = _check_confidence(confidence)
    wall0 = time.perf_counter()
    model, space = resolve_model_and_space(model, space)
    if method == "mc":
        _require_independent(space, "sobol_indices")
    options = merge_model_options(model_options, options, "sobol_indices")
    request = model.prepare(t, outputs=outputs, **options)
    names = list(request.outputs)
    _output_dims(model, names)
    seed = resolve_seed(rng)
    if method == "pce":
        from gearuq.engines.pce import polynomial_chaos

        kw = {"rule": "sobol" if n_base & (n_base - 1) == 0 else "lhs", **(pce_options or {})}
        pce = polynomial_chaos(model, space, request.t, order=pce_order, outputs=names,
                               n_samples=n_base, rng=seed, executor=executor, store=store,
                               chunk_size=chunk_size, progress=progress, **kw,
                               model_options=options)
        out = sobol_from_chaos(pce, names, second_order=second_order, confidence=confidence)
        out.attrs["n_base"] = n_base
    else:
        design, layout = saltelli_design(space, n_base, second_order=second_order, rng=seed)
        ds = _evaluate_design(model, design, layout, request, "sobol_indices", executor=executor,
                              store=store, chunk_size=chunk_size, progress=progress)
        out = sobol_analysis(ds, outputs=names, space=space, estimator=estimator,
                             n_bootstrap=n_bootstrap, confidence=confidence, rng=seed)
    out.attrs.update(provenance("sobol_indices", model, request, space, seed, method=method))
    out.attrs["wall_time_s"] = time.perf_counter() - wall0
    return out


def _output_dims(model: Model, names: list[str]) -> tuple[str, ...]:
    dims = {o: tuple(d for d in model.output(o).dims if d != "sample") for o in names}
    if len(set(dims.values())) > 1:
        raise ValueError(f"outputs: analyse outputs with the same dims together, got {dims}")
    return dims[names[0]]


# =========================================================================== Morris
def _check_levels(num_levels: Any) -> int:
    if isinstance(num_levels, (bool, np.bool_)) or not isinstance(
            num_levels, (int, np.integer)) or num_levels < 2 or num_levels % 2:
        raise ValueError(f"num_levels: expected an even integer >= 2, got {num_levels!r}")
    return int(num_levels)


def morris_design(space: ParameterSpace, n_trajectories: int, *, num_levels: int = 4,
                  rng: Any = None) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """SALib's Morris trajectories mapped to the space, and their layout.

    The trajectories live in the unit hypercube of probabilities; a level ``u`` is mapped to
    the cell midpoint ``(u (L - 1) + 1/2) / L`` before the inverse cdf, so unbounded marginals
    (normal) never meet ``F^-1(0) = -inf``.

    Returns
    -------
    design : dict
        Parameter name -> values ``(n_trajectories (D + 1),)``.
    layout : dict
        ``design="morris"``, ``num_levels``, ``n_trajectories``, ``seed``, ``space`` (JSON).
    """
    from SALib.sample import morris as morris_sample

    _require_independent(space, "morris_design")
    if isinstance(n_trajectories, (bool, np.bool_)) or not isinstance(
            n_trajectories, (int, np.integer)) or n_trajectories < 2:
        raise ValueError(f"n_trajectories: expected an integer >= 2, got {n_trajectories!r}")
    num_levels = _check_levels(num_levels)
    seed = resolve_seed(rng)
    d = space.dim
    problem = {"num_vars": d, "names": space.names, "bounds": [[0.0, 1.0]] * d}
    xu = morris_sample.sample(problem, int(n_trajectories), num_levels=num_levels,
                              seed=seed)
    layout = {"design": "morris", "num_levels": num_levels,
              "n_trajectories": int(n_trajectories), "seed": seed, "space": space_json(space)}
    return space.transform((xu * (num_levels - 1) + 0.5) / num_levels), layout


def morris_analysis(
    ds: xr.Dataset,
    *,
    outputs: str | Iterable[str] | None = None,
    space: ParameterSpace | None = None,
    num_levels: int | None = None,
    n_bootstrap: int = 200,
    confidence: float = 0.95,
    rng: Any = None,
) -> xr.Dataset:
    """Morris elementary effects of a model evaluated on :func:`morris_design` trajectories.

    The grid levels are recovered from the inputs through the marginal cdfs, so any result
    over the design (stored, resumed, lazily loaded) can be analysed.

    Returns
    -------
    xarray.Dataset
        Over ``(output, parameter[, time])``: ``mu``, ``mu_star``, ``sigma``,
        ``mu_star_conf`` and ``rank`` (1 = largest ``mu_star``).
    """
    from SALib.analyze import morris as morris_analyze

    space = _space_of(ds, space)
    _require_independent(space, "morris_analysis")
    num_levels = _check_levels(int(ds.attrs.get("num_levels", 4)) if num_levels is None
                               else num_levels)
    confidence = _check_confidence(confidence)
    names, rest = _output_names(ds, outputs)
    n_runs = _all_ok(ds, "morris_analysis", "elementary effects need every run of a "
                     "trajectory")
    seed = resolve_seed(rng)
    d = space.dim
    if n_runs % (d + 1):
        raise ValueError(f"design: {n_runs} runs are not whole trajectories of {d + 1} points")
    u = np.column_stack([space.cdf(k, np.asarray(ds[k].values, dtype=float))
                         for k in space.names])
    xu = np.round((u * num_levels - 0.5) * (num_levels - 1)) / (num_levels - 1)
    problem = {"num_vars": d, "names": space.names, "bounds": [[0.0, 1.0]] * d}
    flat = _columns(ds, names).reshape(n_runs, -1)
    keys = ("mu", "mu_star", "sigma", "mu_star_conf")
    res = {k: np.full((d, flat.shape[1]), np.nan) for k in keys}
    for c in range(flat.shape[1]):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = morris_analyze.analyze(problem, xu, flat[:, c], num_resamples=n_bootstrap,
                                       conf_level=confidence, num_levels=num_levels,
                                       seed=seed)
        for k in keys:
            res[k][:, c] = np.asarray(r[k], dtype=float)
    shape_rest = tuple(ds[names[0]].transpose("sample", ...).shape[1:])
    out = xr.Dataset(coords={"output": names, "parameter": space.names,
                             **_base_coords(ds, rest)})
    for k in keys:
        out[k] = (("output", "parameter", *rest),
                  np.moveaxis(res[k].reshape(d, len(names), *shape_rest), 1, 0))
    order = np.argsort(np.argsort(-np.nan_to_num(out["mu_star"].values, nan=-np.inf), axis=1),
                       axis=1) + 1
    out["rank"] = (out["mu_star"].dims, order.astype(np.int16),
                   {"long_name": "rank by mu_star (1 = most influential)"})
    out.attrs.update({
        "method": "morris", "num_levels": num_levels, "n_trajectories": n_runs // (d + 1),
        "bootstrap_seed": seed, "n_model_evaluations": n_runs, "space": space_json(space),
        "units_note": "elementary effects per unit of probability (unit-hypercube steps)",
    })
    return out


def morris_screening(
    model: Model | str,
    space: ParameterSpace | Mapping[str, Any] | None,
    t: Any = None,
    *,
    n_trajectories: int,
    num_levels: int = 4,
    outputs: str | Iterable[str] | None = None,
    rng: Any = None,
    executor: Any = None,
    n_bootstrap: int = 200,
    confidence: float = 0.95,
    store: str | os.PathLike | None = None,
    chunk_size: int | None = None,
    progress: bool | None = False,
    model_options: Mapping[str, Any] | None = None,
    **options: Any,
) -> xr.Dataset:
    """Morris elementary-effects screening: :func:`morris_design` -> evaluate ->
    :func:`morris_analysis`.

    Effects are per unit of probability (steps in the unit hypercube), which makes
    ``mu_star`` comparable across parameters of different units. ``store=`` makes the run
    resumable; ``rng=None`` draws a fresh seed, recorded in ``attrs["seed"]``.

    Parameters
    ----------
    model_options : mapping, optional
        Declared model options; the other parameters are those of :func:`sobol_indices`.
    **options
        Deprecated: model options as keywords (still accepted for one release, with a
        DeprecationWarning naming the ``model_options={...}`` spelling to use).

    Returns
    -------
    xarray.Dataset
        Over ``(output, parameter[, time])``: ``mu``, ``mu_star``, ``sigma``,
        ``mu_star_conf`` and ``rank`` (1 = largest ``mu_star``); attrs
        ``n_model_evaluations`` = ``n_trajectories (D + 1)`` and provenance.
    """
    wall0 = time.perf_counter()
    model, space = resolve_model_and_space(model, space)
    _require_independent(space, "morris_screening")
    options = merge_model_options(model_options, options, "morris_screening")
    request = model.prepare(t, outputs=outputs, **options)
    _output_dims(model, list(request.outputs))
    seed = resolve_seed(rng)
    design, layout = morris_design(space, n_trajectories, num_levels=num_levels, rng=seed)
    ds = _evaluate_design(model, design, layout, request, "morris_screening", executor=executor,
                          store=store, chunk_size=chunk_size, progress=progress)
    out = morris_analysis(ds, outputs=list(request.outputs), space=space,
                          num_levels=layout["num_levels"], n_bootstrap=n_bootstrap,
                          confidence=confidence, rng=seed)
    out.attrs.update(provenance("morris_screening", model, request, space, seed))
    out.attrs["wall_time_s"] = time.perf_counter() - wall0
    return out


def ranking(values: Any) -> list[int]:
    """Ranks (1 = largest) of a 1-D array of importance measures."""
    v = np.nan_to_num(np.asarray(values, dtype=float), nan=-math.inf)
    return list((np.argsort(np.argsort(-v)) + 1).astype(int))
