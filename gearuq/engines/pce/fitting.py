"""Fitting a chaos expansion: training data from a Dataset or arrays, regression, quadrature.

The functions here turn labelled data into a :class:`~gearuq.engines.pce.state.ChaosFit`;
:meth:`gearuq.engines.pce.PolynomialChaos.fit` calls them.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from gearuq.engines.pce.basis import basis_matrix, multi_indices, q_norm
from gearuq.engines.pce.regression import (
    corrected_loo,
    few_blas_threads,
    fit_columns,
    least_squares,
    loo_residuals,
    pca,
    relative_error,
)
from gearuq.engines.pce.state import ChaosFit, ChaosSettings, OutputInfo
from gearuq.space import ParameterSpace

__all__ = ["TrainingData", "training_data", "fit_quadrature", "fit_regression"]

#: ``order="auto"`` stops after this many degrees in a row without a smaller error.
DEGREE_PATIENCE = 2


@dataclass
class TrainingData:
    """What :meth:`PolynomialChaos.fit` extracts from its inputs (valid samples only)."""

    x: dict[str, np.ndarray]
    y: dict[str, np.ndarray]  # output -> (n_valid, n_columns)
    outputs: dict[str, OutputInfo]
    t: np.ndarray
    valid: np.ndarray
    source: dict[str, Any]


# =========================================================================== training data
def training_data(space: ParameterSpace, inputs: Any, outputs: Any, t: Any,
                   status: Any) -> TrainingData:
    """Inputs, outputs (valid samples, flattened columns) and labels from a Dataset or arrays."""
    if isinstance(inputs, xr.Dataset):
        if t is not None or status is not None:
            raise ValueError("t/status: taken from the Dataset; give them only with arrays")
        return _from_result(space, inputs, outputs)
    if not isinstance(inputs, Mapping):
        raise TypeError(f"inputs: expected an xarray Dataset or a mapping of arrays, got "
                        f"{type(inputs).__name__}")
    if not isinstance(outputs, Mapping) or not outputs:
        raise ValueError("outputs: with array inputs give a mapping output name -> array")
    missing = [k for k in space.names if k not in inputs]
    if missing:
        raise ValueError(f"inputs: missing parameter(s) {missing} of the space {space.names}")
    x = {k: np.asarray(inputs[k], dtype=float).ravel() for k in space.names}
    n = x[space.names[0]].size
    tt = np.zeros(0) if t is None else np.atleast_1d(np.asarray(t, dtype=float))
    ys, infos = {}, {}
    for o, v in outputs.items():
        y = np.asarray(v, dtype=float)
        if y.shape[0] != n or y.ndim > 2 or (y.ndim == 2 and y.shape[1] != tt.size):
            raise ValueError(f"output {o!r}: shape {y.shape} does not fit {n} samples"
                             + (f" x {tt.size} instants" if tt.size else " (give t= for "
                                                                         "2-D outputs)"))
        dims = ("time",) if y.ndim == 2 else ()
        infos[o] = OutputInfo(dims, y.shape[1:])
        ys[o] = y.reshape(n, -1)
    st = np.zeros(n, dtype=int) if status is None else np.asarray(status).ravel()
    if st.size != n:
        raise ValueError(f"status: {st.size} values for {n} samples")
    return _valid_only(x, ys, infos, tt, st == 0, {"model": "data"})


def _from_result(space: ParameterSpace, ds: xr.Dataset, outputs: Any) -> TrainingData:
    missing = [k for k in space.names if k not in ds]
    if missing:
        raise ValueError(f"inputs: the Dataset has no variable(s) {missing} of the space "
                         f"{space.names}")
    if outputs is None:
        names = [k for k, v in ds.data_vars.items()
                 if v.attrs.get("role") == "output" and "sample" in v.dims]
    else:
        names = [outputs] if isinstance(outputs, str) else list(outputs)
    bad = [o for o in names if o not in ds or "sample" not in ds[o].dims]
    if bad or not names:
        raise ValueError(f"outputs: {bad or names} not output variables over 'sample' of the "
                         f"Dataset; it has {list(ds.data_vars)}")
    n = ds.sizes["sample"]
    x = {k: np.asarray(ds[k].values, dtype=float) for k in space.names}
    timed = "time" in ds.coords and any("time" in ds[o].dims for o in names)
    tt = np.asarray(ds["time"].values, dtype=float) if timed else np.zeros(0)
    ys, infos = {}, {}
    for o in names:
        da = ds[o].transpose("sample", ...)
        rest = tuple(d for d in da.dims if d != "sample")
        coords = {d: (ds[d].dims, np.asarray(ds[d].values), dict(ds[d].attrs))
                  for d in rest if d != "time" and d in ds.coords}
        infos[o] = OutputInfo(rest, tuple(da.shape[1:]), str(da.attrs.get("units", "")),
                              str(da.attrs.get("long_name", "")), coords)
        ys[o] = np.asarray(da.values, dtype=float).reshape(n, -1)
    st = np.asarray(ds["status"].values) if "status" in ds else np.zeros(n, dtype=int)
    source = {"model": str(ds.attrs.get("model", "data")),
              "model_version": str(ds.attrs.get("model_version", "")),
              "time_units": str(ds["time"].attrs.get("units", "s")) if timed else "s",
              "time_long_name": str(ds["time"].attrs.get("long_name", "time")) if timed
              else "time",
              "parameters": {k: {"units": str(ds[k].attrs.get("units", "1")),
                                 "description": str(ds[k].attrs.get("long_name", ""))}
                             for k in space.names}}
    return _valid_only(x, ys, infos, tt, st == 0, source)


def _valid_only(x, ys, infos, t, valid, source) -> TrainingData:
    for o, y in ys.items():
        if not np.all(np.isfinite(y[valid])):
            raise ValueError(f"output {o!r}: non-finite values in samples with status 0")
    return TrainingData({k: v[valid] for k, v in x.items()},
                         {o: y[valid] for o, y in ys.items()}, infos, t, valid, source)


# =========================================================================== fitting
def _new_fit(data: TrainingData, **kw: Any) -> ChaosFit:
    return ChaosFit(outputs=data.outputs, t=data.t, n_evaluations=int(data.valid.size),
                    n_failed=int((~data.valid).sum()), source=data.source, **kw)


def fit_quadrature(z: np.ndarray, data: TrainingData, settings: ChaosSettings,
                    kinds: list[str], weights: Any) -> ChaosFit:
    """Spectral projection ``c = Psi^T (w y)``; least squares if nodes failed."""
    if weights is None:
        raise ValueError("weights: method='quadrature' needs the quadrature weights of the "
                         "design (gearuq.polynomial_chaos designs and passes them)")
    w = np.asarray(weights, dtype=float).ravel()
    if w.size != data.valid.size:
        raise ValueError(f"weights: {w.size} weights for {data.valid.size} design points")
    idx = multi_indices(z.shape[1], int(settings.order), settings.truncation)
    psi = basis_matrix(z, idx, kinds)
    full = bool(data.valid.all())
    if not full:
        warnings.warn(f"{int((~data.valid).sum())} quadrature node(s) failed; coefficients by "
                      "least squares on the valid nodes", RuntimeWarning, stacklevel=3)
    coefs, loo, loo_t, corr = {}, {}, {}, {}
    with few_blas_threads(psi.size):
        for o, y in data.y.items():
            coefs[o] = (psi.T @ (w[:, None] * y) if full
                        else np.linalg.lstsq(psi, y, rcond=None)[0])
            loo[o], loo_t[o], corr[o] = math.nan, np.full(y.shape[1], math.nan), math.nan
            if psi.shape[0] > psi.shape[1]:  # LOO of a least-squares refit on the nodes
                try:
                    c_ls, h, trace = least_squares(psi, y)
                    loo[o], loo_t[o] = relative_error(loo_residuals(psi, y, c_ls, h), y)
                    corr[o] = corrected_loo(loo[o], psi.shape[0], psi.shape[1], trace)
                except np.linalg.LinAlgError:
                    pass
    fit = _new_fit(data, indices=idx, coefficients=_shaped(coefs, data), order=int(
        settings.order), loo_error=loo, loo_error_t=loo_t, corrected_loo_error=corr)
    fit.info.update({"n_terms_candidate": int(idx.shape[0])})
    return fit


def _shaped(coefs: dict[str, np.ndarray], data: TrainingData) -> dict[str, np.ndarray]:
    return {o: c.reshape(c.shape[0], *data.outputs[o].shape) for o, c in coefs.items()}


def fit_regression(z: np.ndarray, data: TrainingData, settings: ChaosSettings,
                    kinds: list[str]) -> ChaosFit:
    """Least squares or sparse least squares, one degree or the best of ``1..max_order``.

    The basis is evaluated once for the largest degree; a lower degree uses the columns of
    its (nested) index set. ``order="auto"`` stops after two degrees in a row that do not
    lower the selection error (LOO for regression, corrected LOO for sparse).
    """
    orders = settings.orders
    idx_all = multi_indices(z.shape[1], orders[-1], settings.truncation)
    n = z.shape[0]
    if settings.method == "regression" and n <= _n_terms(idx_all, orders[0], settings):
        raise ValueError(
            f"n_samples: {n} valid samples ({int((~data.valid).sum())} failed) are not more "
            f"than the {_n_terms(idx_all, orders[0], settings)} basis terms of order "
            f"{orders[0]} ({z.shape[1]} parameters); give more samples (typically 2-3x) or "
            "use method='sparse'")
    if settings.method == "sparse" and n < 3:
        raise ValueError(f"n_samples: sparse regression needs at least 3 samples, got {n}")
    psi_all = basis_matrix(z, idx_all, kinds)
    with few_blas_threads(psi_all.size):
        return _best_degree(psi_all, idx_all, data, settings)


def _best_degree(psi_all: np.ndarray, idx_all: np.ndarray, data: TrainingData,
                 settings: ChaosSettings) -> ChaosFit:
    """Fit the degrees of ``settings.orders`` on nested column sets; keep the best one."""
    orders = settings.orders
    n = psi_all.shape[0]
    norms = q_norm(idx_all, settings.truncation)
    weights = {o: max(float(np.var(y, axis=0, ddof=1).sum()), 1e-300) if n > 1 else 1.0
               for o, y in data.y.items()}
    best, tried, worse = None, [], 0
    for p in orders:
        cols = np.flatnonzero(norms <= p + 1e-9)
        if settings.method == "regression" and n <= cols.size:
            break
        res = _fit_degree(psi_all[:, cols], data, settings)
        tried.append(p)
        key = "corrected" if settings.method == "sparse" else "loo"
        score = sum(res[key][o] * weights[o] for o in data.y) / sum(weights.values())
        if best is None or score < best[0]:
            best, worse = (score, p, cols, res), 0
        else:
            worse += 1
            if worse >= DEGREE_PATIENCE:
                break
    _, order, cols, res = best
    keep = np.zeros(cols.size, dtype=bool)
    keep[0] = True
    for c in res["coef"].values():
        keep |= np.any(c != 0, axis=1)
    if settings.method == "regression":
        keep[:] = True
    coefs = {o: c[keep] for o, c in res["coef"].items()}
    fit = _new_fit(data, indices=idx_all[cols][keep], coefficients=_shaped(coefs, data),
                   order=order, loo_error=res["loo"], loo_error_t=res["loo_t"],
                   corrected_loo_error=res["corrected"], compression=res["compression"])
    fit.info.update({"n_terms_candidate": int(cols.size), "orders_tried": tried,
                     "n_terms_selected": int(keep.sum())})
    return fit


def _n_terms(idx_all: np.ndarray, order: int, settings: ChaosSettings) -> int:
    return int(np.sum(q_norm(idx_all, settings.truncation) <= order + 1e-9))


def _fit_degree(psi: np.ndarray, data: TrainingData, settings: ChaosSettings
                ) -> dict[str, Any]:
    """Fit every output on one candidate basis; coefficients and errors per output."""
    out: dict[str, Any] = {"coef": {}, "loo": {}, "loo_t": {}, "corrected": {},
                           "compression": {}}
    n = psi.shape[0]
    for o, y in data.y.items():
        compress = settings.compress if y.shape[1] > 1 else None
        if compress is not None:
            target, comps, ybar, info = pca(y, compress)
        else:
            target, comps, ybar, info = y, None, None, None
        try:
            r = fit_columns(psi, target, settings.method, settings.solver)
        except np.linalg.LinAlgError:
            raise ValueError("basis matrix is rank deficient on this design; use more "
                             "samples or a lower order") from None
        coef, res = r["coef"], r["loo_residuals"]
        if comps is not None:
            recon = ybar + target @ comps
            info["relative_error"] = relative_error(recon - y, y)[0]
            res = res @ comps + (y - recon)  # the discarded part counts as error
            coef = coef @ comps
            coef[0] += ybar
            out["compression"][o] = info
        out["coef"][o] = coef
        out["loo"][o], out["loo_t"][o] = relative_error(res, y)
        out["corrected"][o] = corrected_loo(out["loo"][o], n, int(r["columns"].size),
                                            r["trace"])
    return out
