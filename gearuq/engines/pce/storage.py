"""Saving and rebuilding a chaos surrogate: ``to_dataset`` / ``from_dataset``."""

from __future__ import annotations

import json
import math
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from gearuq._version import __version__
from gearuq.engines.pce.basis import Germ
from gearuq.engines.pce.state import ChaosFit, OutputInfo
from gearuq.space import ParameterSpace

if TYPE_CHECKING:
    from gearuq.engines.pce.surrogate import PolynomialChaos

__all__ = ["to_dataset", "from_dataset"]

_KIND = "gearuq_polynomial_chaos"


def to_dataset(pce: PolynomialChaos) -> xr.Dataset:
    """The Dataset of :meth:`PolynomialChaos.to_dataset` (see there)."""
    fit = pce._require_fitted()
    ds = xr.Dataset(coords={"term": np.arange(pce.n_terms), "parameter": pce.space.names})
    if fit.t.size:
        ds = ds.assign_coords(time=("time", fit.t, {"units": pce.time_units,
                                                     "long_name": pce.time_long_name}))
    ds["multi_index"] = (("term", "parameter"), fit.indices,
                         {"long_name": "degree of each germ variable in each basis term"})
    outputs = {}
    for o, m in fit.outputs.items():
        for d, (dims, values, attrs) in m.coords.items():
            if d not in ds.coords:
                ds = ds.assign_coords({d: (dims, values, attrs)})
        ds[f"coef_{o}"] = (("term", *m.dims), fit.coefficients[o],
                           {"units": m.units, "long_name": f"chaos coefficients of {o}"})
        ds[f"loo_{o}"] = ((), fit.loo_error.get(o, math.nan),
                          {"long_name": f"relative LOO error of {o}"})
        ds[f"loo_t_{o}"] = (m.dims, np.asarray(fit.loo_error_t[o]).reshape(m.shape),
                            {"long_name": f"relative LOO error of {o} per column"})
        outputs[o] = {"dims": list(m.dims), "units": m.units, "long_name": m.long_name}
    ds.attrs.update({
        "gearuq_version": __version__, "kind": _KIND, "space": pce.space.to_json(),
        "germ": " ".join(pce.germ_kinds), "method": pce.method, "order": fit.order,
        "n_terms": pce.n_terms, "source_model": pce.source_model,
        "n_evaluations": fit.n_evaluations, "n_failed": fit.n_failed,
        "settings": json.dumps(pce.settings(), default=repr),
        "fit": json.dumps({"outputs": outputs, "source": fit.source, "info": fit.info,
                           "compression": fit.compression,
                           "corrected_loo_error": fit.corrected_loo_error,
                           "holdout_error": fit.holdout_error}, default=_json_default),
    })
    return ds


def _json_default(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    return repr(v)


def from_dataset(cls: type[PolynomialChaos], ds: xr.Dataset) -> PolynomialChaos:
    """Rebuild a ``cls`` surrogate from the Dataset of :func:`to_dataset`."""
    if ds.attrs.get("kind") != _KIND or "multi_index" not in ds:
        raise ValueError("from_dataset: not a saved polynomial chaos surrogate (expected "
                         "the Dataset of PolynomialChaos.to_dataset())")
    space = ParameterSpace.from_json(ds.attrs["space"])
    stored = json.loads(ds.attrs["settings"])
    settings = {k: stored[k] for k in ("method", "truncation", "max_order", "solver",
                                       "compress", "germ")}
    pce = cls(space, order=int(ds.attrs["order"]), **settings)
    pce._germ = Germ(space, settings["germ"], kinds=str(ds.attrs["germ"]).split())
    record = json.loads(ds.attrs["fit"])
    infos, coefs, loo, loo_t = {}, {}, {}, {}
    for o, meta in record["outputs"].items():
        dims = tuple(meta["dims"])
        coords = {d: (ds[d].dims, np.asarray(ds[d].values), dict(ds[d].attrs))
                  for d in dims if d != "time" and d in ds.coords}
        coef = np.asarray(ds[f"coef_{o}"].transpose("term", *dims).values, dtype=float)
        infos[o] = OutputInfo(dims, coef.shape[1:], meta["units"], meta["long_name"], coords)
        coefs[o] = coef
        loo[o] = float(ds[f"loo_{o}"].values)
        loo_t[o] = np.asarray(ds[f"loo_t_{o}"].values, dtype=float).ravel()
    t = np.asarray(ds["time"].values, dtype=float) if "time" in ds.coords else np.zeros(0)
    fit = ChaosFit(
        indices=np.asarray(ds["multi_index"].values, dtype=int), coefficients=coefs,
        outputs=infos, t=t, order=int(ds.attrs["order"]),
        n_evaluations=int(ds.attrs["n_evaluations"]), n_failed=int(ds.attrs["n_failed"]),
        loo_error=loo, loo_error_t=loo_t,
        corrected_loo_error={k: float(v) for k, v in record["corrected_loo_error"].items()},
        holdout_error={k: float(v) for k, v in record["holdout_error"].items()},
        compression=record["compression"], info=record["info"], source=record["source"])
    pce._set_fitted(fit)
    return pce
