"""The chunk task: evaluate one slice of a design, isolating the samples that fail.

A chunk whose evaluation raises is bisected (in the same process) until every failing sample
stands alone, so only the samples that really fail get status 4 (``model_error``), each with
its exception type and message; the others keep their results. The task optionally writes its
result into a chunk store itself (workers write their own chunks), so that large results never
travel back to, or accumulate in, the calling process.
"""

from __future__ import annotations

import os
import time
import traceback
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from gearuq.model import STATUS_MODEL_ERROR, Model, Request

__all__ = ["ChunkResult", "run_chunk", "failed_like", "group_failures"]


@dataclass
class ChunkResult:
    """What a chunk task hands back to the driver.

    Attributes
    ----------
    index : int
        Chunk number.
    start, stop : int
        Global sample range ``[start, stop)``.
    ds : xarray.Dataset or None
        The chunk's result (``None`` when it was written to a store, or when every sample
        failed and no template exists in this task).
    failures : list of dict
        ``{"sample", "error", "traceback"}`` per failed sample (global sample index).
    n_bytes : int
        Size of the chunk's result in memory.
    stored : bool
        The chunk was written to the store by the task.
    n_evaluations : int
        Samples passed to ``model.evaluate`` by the task, every call counted: a chunk that
        raised and was bisected counts its first try and every re-run of its pieces.
    cpu_seconds : float
        CPU time of the process that ran the task, spent on it (``time.process_time``), so a
        run can report its CPU cost beside its wall time whatever executor it used.
    pid : int
        Process that ran the task (the driver tells worker CPU from its own by it).
    """

    index: int
    start: int
    stop: int
    ds: xr.Dataset | None = None
    failures: list[dict[str, Any]] = field(default_factory=list)
    n_bytes: int = 0
    stored: bool = False
    n_evaluations: int = 0
    cpu_seconds: float = 0.0
    pid: int = 0


def _error_text(exc: BaseException) -> tuple[str, str]:
    return f"{type(exc).__name__}: {exc}", traceback.format_exc(limit=8)[-3000:]


def _evaluate_range(
    model: Model, params: Mapping[str, np.ndarray], request: Request, lo: int, hi: int,
    pieces: list[tuple[int, int, xr.Dataset]], failures: list[tuple[int, str, str]],
    counter: list[int], first_error: tuple[str, str] | None = None,
) -> None:
    """Evaluate samples ``[lo, hi)``; on an exception, bisect down to single samples.

    ``counter[0]`` grows by the samples of every call to ``model.evaluate`` (re-runs too).
    """
    if first_error is None:
        counter[0] += hi - lo
        try:
            ds = model.evaluate({k: a[lo:hi] for k, a in params.items()}, request)
        except Exception as exc:  # noqa: BLE001 - any model failure is isolated, not raised
            first_error = _error_text(exc)
        else:
            if ds.sizes.get("sample") != hi - lo:
                first_error = (f"model returned {ds.sizes.get('sample')} samples for "
                               f"{hi - lo}", "")
            else:
                pieces.append((lo, hi, ds))
                return
    if hi - lo == 1:
        failures.append((lo, *first_error))
        return
    mid = (lo + hi) // 2
    _evaluate_range(model, params, request, lo, mid, pieces, failures, counter)
    _evaluate_range(model, params, request, mid, hi, pieces, failures, counter)


def _fill_value(dtype: np.dtype) -> Any:
    kinds = {"f": np.nan, "c": np.nan, "i": -1, "b": False, "M": np.datetime64("NaT"),
             "m": np.timedelta64("NaT")}
    if dtype.kind == "u":
        return np.iinfo(dtype).max
    return kinds.get(dtype.kind, "")


def failed_like(template: xr.Dataset, inputs: Mapping[str, np.ndarray]) -> xr.Dataset:
    """Samples with status 4 shaped like ``template``: inputs kept, outputs NaN (or -1).

    Parameters
    ----------
    template : xarray.Dataset
        Any successful result of the same request (one sample is enough).
    inputs : mapping
        Parameter name -> values of the failed samples (validated where possible).
    """
    m = len(next(iter(inputs.values())))
    out = template.isel(sample=np.zeros(m, dtype=int))
    for name in list(out.variables):
        var = out.variables[name]
        if "sample" not in var.dims or name == "sample":
            continue
        if name == "status":
            values = np.full(m, STATUS_MODEL_ERROR, dtype=var.dtype)
        elif name in inputs:
            values = np.asarray(inputs[name], dtype=var.dtype)
        else:
            values = np.full(var.shape, _fill_value(var.dtype), dtype=var.dtype)
        new = var.copy(data=values)
        if name in out.coords:
            out = out.assign_coords({name: new})
        else:
            out[name] = new
    return out.assign_coords(sample=np.arange(m))


def inputs_of(model: Model, params: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Validated (nominal-filled) inputs, or the raw arrays when validation itself fails."""
    try:
        return model.validate_params(params)
    except (ValueError, TypeError):
        return {k: np.asarray(v, dtype=float) for k, v in params.items()}


def _assemble(
    model: Model, params: Mapping[str, np.ndarray], n: int,
    pieces: list[tuple[int, int, xr.Dataset]], failed: list[int],
) -> xr.Dataset:
    """Successful pieces and templated failed samples, in sample order."""
    if len(pieces) == 1 and not failed:
        return pieces[0][2]
    template = pieces[0][2]
    parts = list(pieces)
    for i in failed:
        inputs = inputs_of(model, {k: a[i:i + 1] for k, a in params.items()})
        parts.append((i, i + 1, failed_like(template, inputs)))
    parts.sort(key=lambda p: p[0])
    ds = xr.concat([p[2] for p in parts], dim="sample", data_vars="minimal",
                   coords="minimal", compat="override", join="override",
                   combine_attrs="override")
    return ds.assign_coords(sample=np.arange(n))


def run_chunk(
    model: Model,
    params: Mapping[str, np.ndarray],
    request: Request,
    index: int,
    start: int,
    store_path: str | None = None,
) -> ChunkResult:
    """Evaluate one chunk (samples ``start .. start + n - 1``), isolating failures.

    Parameters
    ----------
    model : Model
    params : mapping
        Parameter name -> the chunk's slice of the design.
    request : Request
        Prepared by ``model.prepare``.
    index, start : int
        Chunk number and global index of its first sample.
    store_path : str, optional
        Chunk store directory: the task writes its result there (atomically, with a
        checksum) and returns no data.
    """
    cpu_start = time.process_time()
    n = len(next(iter(params.values())))
    pieces: list[tuple[int, int, xr.Dataset]] = []
    raw: list[tuple[int, str, str]] = []
    counter = [0]
    _evaluate_range(model, params, request, 0, n, pieces, raw, counter)
    failures = [{"sample": start + i, "error": e, "traceback": tb} for i, e, tb in raw]
    result = ChunkResult(index=index, start=start, stop=start + n, failures=failures,
                         n_evaluations=counter[0], pid=os.getpid())
    if not pieces:
        result.cpu_seconds = time.process_time() - cpu_start
        return result  # every sample failed: the driver templates them from another chunk
    ds = _assemble(model, params, n, pieces, [i for i, _, _ in raw])
    ds = ds.assign_coords(sample=np.arange(start, start + n))
    if failures:
        ds.attrs["failures"] = group_failures(failures)
    result.n_bytes = int(ds.nbytes)
    if store_path is not None:
        from gearuq.execution.store import write_chunk

        write_chunk(store_path, index, ds)
        result.stored = True
    else:
        result.ds = ds
    result.cpu_seconds = time.process_time() - cpu_start
    return result


def group_failures(failures: list[dict[str, Any]]) -> str:
    """JSON list of ``{"error", "samples", "traceback"}``, one entry per distinct message."""
    import json

    groups: dict[str, dict[str, Any]] = {}
    for f in sorted(failures, key=lambda r: r["sample"]):
        g = groups.setdefault(f["error"], {"error": f["error"], "samples": [],
                                           "traceback": f.get("traceback", "")})
        g["samples"].append(int(f["sample"]))
    return json.dumps(list(groups.values()))
