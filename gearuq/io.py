"""netCDF save/load of gearuq results with their provenance."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from gearuq._version import __version__

#: Attribute that marks a file as a gearuq result.
MARKER = "gearuq_version"


def _safe_attr(value: Any) -> Any:
    """Map an attribute value to a type netCDF can store (CF style: no bool, None, dict)."""
    if isinstance(value, (bool, np.bool_)):
        return np.int8(value)
    if value is None:
        return "none"
    if isinstance(value, dict):
        return json.dumps(value, default=str, sort_keys=True)
    if isinstance(value, (list, tuple)):
        if value and all(isinstance(v, (int, float, np.integer, np.floating)) for v in value):
            return np.asarray(value)
        return json.dumps(list(value), default=str)
    return value


def sanitize_attrs(ds: xr.Dataset) -> xr.Dataset:
    """Return a shallow copy whose attributes (global and per variable) are netCDF-safe."""
    out = ds.copy()
    out.attrs = {k: _safe_attr(v) for k, v in ds.attrs.items()}
    for name in list(out.variables):
        out[name].attrs = {k: _safe_attr(v) for k, v in ds[name].attrs.items()}
    return out


def save(ds: xr.Dataset, path: str | os.PathLike, *, compress: bool = False) -> Path:
    """Write a result to netCDF4 atomically (temp file, then rename).

    Parameters
    ----------
    ds : xarray.Dataset
        A gearuq result (``gearuq_version`` is added to attrs if missing).
    path : path-like
        Target ``.nc`` file; parent folders are created.
    compress : bool
        zlib level 1 on large numeric variables. Off by default: double-precision responses
        shrink by only ~10 % while writing takes several times longer.

    Returns
    -------
    pathlib.Path
        The written path.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ds = sanitize_attrs(ds)
    ds.attrs.setdefault(MARKER, __version__)
    encoding = {
        name: {"zlib": True, "complevel": 1}
        for name, var in ds.data_vars.items()
        if compress and var.dtype.kind in "fiu" and var.size > 1024
    }
    fd, tmp = tempfile.mkstemp(suffix=".nc.tmp", dir=path.parent)
    os.close(fd)
    try:
        ds.to_netcdf(tmp, engine="netcdf4", encoding=encoding)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return path


def load(path: str | os.PathLike) -> xr.Dataset:
    """Read a gearuq result written by :func:`save` fully into memory.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If the file is not netCDF or not a gearuq result (no ``gearuq_version`` attribute).
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no such result file: {path}")
    try:
        with xr.open_dataset(
            path, engine="netcdf4", decode_times=False, decode_timedelta=False
        ) as handle:
            ds = handle.load()
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path} is not a readable netCDF file: {exc}") from exc
    if MARKER not in ds.attrs:
        raise ValueError(
            f"{path} is not a gearuq result: the global attribute {MARKER!r} is missing"
        )
    return ds
