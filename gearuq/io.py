"""netCDF save/load of gearuq results with their provenance."""

from __future__ import annotations

import errno
import hashlib
import json
import os
import secrets
import shutil
import socket
import threading
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from gearuq._checks import check_bool
from gearuq._version import __version__

#: Attribute that marks a file as a gearuq result.
MARKER = "gearuq_version"


#: Held around every netCDF file operation of gearuq (see :func:`netcdf_lock`).
_NETCDF_LOCK = threading.RLock()


def netcdf_lock() -> threading.RLock:
    """The process-wide lock around gearuq's netCDF reads and writes.

    HDF5 as built into the netCDF4 wheels is not thread-safe, and xarray's netCDF4 backend
    holds its own lock only while it fetches a file handle, not while it reads attributes or
    defines variables. Two threads of one process inside HDF5 at once (dask workers with
    ``processes=False`` writing chunks while the driver loads another) crash the interpreter,
    so every save, load, store open and direct ``netCDF4`` call in gearuq holds this lock for
    its whole duration. It is re-entrant. Data read later from a lazily opened result goes
    through xarray's own per-read lock only: a user thread computing such a result while
    another thread of the same process saves or loads a file is not guarded by this lock.
    """
    return _NETCDF_LOCK


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


CHECKSUM = "checksum"
#: Global attribute listing the variables that carry a checksum (itself covered by the global
#: checksum), so that a deleted variable checksum is noticed.
CHECKSUMMED = "checksummed_variables"
_HASHABLE = "biufcUSO"


def _canonical(attrs: dict[str, Any]) -> str:
    """Attributes as text that survives the netCDF round trip (a 1-element array attribute
    comes back as a scalar, ints come back as int64)."""
    out = {}
    for k, v in sorted(attrs.items()):
        if k == CHECKSUM:
            continue
        out[k] = v if isinstance(v, str) else repr(np.atleast_1d(np.asarray(v)).tolist())
    return json.dumps(out)


def _digest_variable(var: xr.Variable, attrs: dict[str, Any]) -> str:
    """BLAKE2b digest of a variable's dtype, shape, values and attributes.

    Values are read in slices along the first axis, so a lazily loaded (dask) variable is
    hashed without loading it whole; the C-order bytes of consecutive first-axis slices are
    the bytes of the whole array, so the digest does not depend on chunking.
    """
    h = hashlib.blake2b(digest_size=16)
    h.update(f"{var.dtype.str}|{var.shape}".encode())
    h.update(_canonical(attrs).encode())
    if var.ndim == 0:
        blocks = [np.asarray(var.values)]
    else:
        row = max(1, int(np.prod(var.shape[1:])) * max(var.dtype.itemsize, 1))
        step = max(1, (64 << 20) // row)
        blocks = (np.asarray(var[i:i + step].values) for i in range(0, var.shape[0], step))
    for block in blocks:
        if block.dtype.kind in "OUS":
            h.update("\x1f".join(map(str, block.ravel().tolist())).encode())
        else:
            h.update(np.ascontiguousarray(block).tobytes())
    return "blake2b:" + h.hexdigest()


def _global_digest(attrs: dict[str, Any]) -> str:
    h = hashlib.blake2b(digest_size=16)
    h.update(_canonical(attrs).encode())
    return "blake2b:" + h.hexdigest()


def _umask() -> int:
    """The process umask, read without changing it where the OS allows."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _as_path(path: Any, verb: str) -> Path:
    """``path`` as a Path, or an error saying what a path is (one file at a time)."""
    if not isinstance(path, (str, os.PathLike)):
        hint = "; give one file at a time" if isinstance(path, (list, tuple)) else ""
        raise TypeError(f"path: expected a file path (str or pathlib.Path), got "
                        f"{type(path).__name__} {path!r}{hint}")
    if not str(path).strip():
        raise ValueError(f"path: empty; give the file to {verb}, e.g. 'result.nc'")
    return Path(path)


#: Suffixes of other formats: a netCDF file under one of these names misleads its reader.
_NOT_NETCDF = {".csv", ".tsv", ".txt", ".json", ".xlsx", ".xls", ".parquet", ".zarr", ".png",
               ".pdf", ".h5", ".hdf5", ".npy", ".npz", ".pkl", ".pickle"}


def _storable(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with text held as Python objects made fixed-width text; refuses what netCDF
    would not give back as it was (dates, complex numbers, other Python objects), naming
    the variable."""
    text: dict[Any, xr.Variable] = {}
    for name, var in ds.variables.items():
        kind = var.dtype.kind
        if kind in "Mm":
            raise TypeError(f"save: variable {name!r} holds dates or durations ({var.dtype}); "
                            "they would come back as plain numbers: store them as numbers "
                            "with units (e.g. seconds since an epoch) or drop the variable")
        if kind == "c":
            raise TypeError(f"save: variable {name!r} is complex ({var.dtype}); store its real "
                            "and imaginary parts (or magnitude and phase) as two variables")
        if kind == "O":
            values = np.asarray(var.values).ravel()
            other = next((i for i, v in enumerate(values) if not isinstance(v, str)), None)
            if other is not None:
                raise TypeError(f"save: variable {name!r} holds Python objects "
                                f"({type(values[other]).__name__}: {values[other]!r}); a result "
                                "stores numbers or text: convert it, or drop the variable")
            text[name] = var.copy(data=np.asarray(var.values, dtype=str))
    if not text:
        return ds
    data = {k: v for k, v in text.items() if k in ds.data_vars}
    return ds.assign(data).assign_coords({k: v for k, v in text.items() if k not in data})


def save(ds: xr.Dataset, path: str | os.PathLike, *, compress: bool = False,
         checksum: bool = True) -> Path:
    """Write a result to netCDF4 atomically (temp file, then rename), with checksums.

    Every numeric variable is written with HDF5's fletcher32 filter (verified by the library
    on every read) and carries a ``checksum`` attribute (BLAKE2b of its values and
    attributes); the global attributes carry one too. :func:`load` verifies them and names the
    file and variable that do not match. The file gets the permissions of the user's umask
    (like any file the user creates). A lazily loaded (dask) Dataset is written chunk by chunk.

    Parameters
    ----------
    ds : xarray.Dataset
        A gearuq result (``gearuq_version`` is added to attrs if missing).
    path : path-like
        Target ``.nc`` file; parent folders are created.
    compress : bool
        zlib level 1 on large numeric variables. Off by default: double-precision responses
        shrink by only ~10 % while writing takes several times longer.
    checksum : bool
        Write the fletcher32 filter and the ``checksum`` attributes (default).

    Returns
    -------
    pathlib.Path
        The written path.

    Raises
    ------
    OSError
        If the file cannot be written; the message names it, and a full device is reported
        as such (``errno.ENOSPC``, with the free space and the file's size).

    Notes
    -----
    The temporary file is named after the host and process that write it; each save removes
    the temporaries of the same path left by processes of this host that no longer exist
    (a save killed mid-write).
    """
    if not isinstance(ds, xr.Dataset):
        raise TypeError(f"ds: expected an xarray.Dataset (a gearuq result), got "
                        f"{type(ds).__name__}")
    path = _as_path(path, "write")
    if path.is_dir():
        raise ValueError(f"path: {str(path)!r} is a folder; give a file name in it, e.g. "
                         f"{str(path / 'result.nc')!r}")
    blocker = next((p for p in path.parents if p.exists()), None)
    if blocker is not None and not blocker.is_dir():
        raise ValueError(f"path: {str(path)!r} cannot be written: {str(blocker)!r} is a file, "
                         "not a folder")
    if path.suffix.lower() in _NOT_NETCDF:
        raise ValueError(f"path: {str(path)!r} would hold netCDF under a {path.suffix} name; "
                         "give a .nc path (gearuq.export_csv, or `gearuq export --csv`, "
                         "writes CSV)")
    ds = _storable(ds)
    path.parent.mkdir(parents=True, exist_ok=True)
    ds = sanitize_attrs(ds)
    ds.attrs.setdefault(MARKER, __version__)
    encoding: dict[str, dict[str, Any]] = {}
    for name, var in ds.variables.items():
        var.encoding = {k: v for k, v in var.encoding.items()
                        if k in ("dtype", "_FillValue", "units", "calendar")}
        enc: dict[str, Any] = {}
        numeric = var.dtype.kind in "biuf"
        if compress and numeric and var.size > 1024 and name in ds.data_vars:
            enc.update({"zlib": True, "complevel": 1})
        if checksum and numeric and var.ndim > 0:
            enc["fletcher32"] = True
        if enc:
            encoding[str(name)] = enc
        if checksum and var.dtype.kind in _HASHABLE:
            var.attrs[CHECKSUM] = _digest_variable(var, var.attrs)
    if not checksum:  # drop stale checksums of an earlier save: they would not match
        ds.attrs.pop(CHECKSUM, None)
        ds.attrs.pop(CHECKSUMMED, None)
        for var in ds.variables.values():
            var.attrs.pop(CHECKSUM, None)
    if checksum:
        ds.attrs[CHECKSUMMED] = json.dumps(sorted(
            str(k) for k, v in ds.variables.items() if CHECKSUM in v.attrs))
        ds.attrs[CHECKSUM] = _global_digest(ds.attrs)
    clean_stale_temporaries(path)
    tmp = temporary_path(path)
    try:
        try:
            with netcdf_lock():
                ds.to_netcdf(tmp, engine="netcdf4", encoding=encoding)
            os.chmod(tmp, 0o666 & ~_umask())
            os.replace(tmp, path)
        finally:
            tmp.unlink(missing_ok=True)
    except (OSError, RuntimeError) as exc:
        raise write_error(path, exc, int(ds.nbytes)) from exc
    return path


# --------------------------------------------------------------------------- temporaries
def temporary_path(path: str | os.PathLike) -> Path:
    """A temporary file next to ``path`` whose name tells who writes it.

    ``<name>.<host>.<pid>.<random>.tmp``: a later save to the same path removes it if that
    process is gone (:func:`clean_stale_temporaries`).
    """
    path = Path(path)
    host = socket.gethostname().replace(".", "_") or "host"
    return path.with_name(f"{path.name}.{host}.{os.getpid()}.{secrets.token_hex(4)}.tmp")


def _pid_alive(pid: int) -> bool:
    """Whether process ``pid`` exists on this machine (``True`` when it cannot be told)."""
    if pid == os.getpid():
        return True
    if os.name != "posix":
        return True  # os.kill would terminate it on Windows: never guess there
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True  # exists, owned by another user
    return True


def clean_stale_temporaries(path: str | os.PathLike) -> list[Path]:
    """Remove temporaries of ``path`` left by writers that died (SIGKILL, power loss).

    Only files named by :func:`temporary_path` on this host whose process no longer exists
    are removed; a live writer's file, another host's and any other file are left alone.

    Returns
    -------
    list of pathlib.Path
        The removed files.
    """
    path = Path(path)
    host = socket.gethostname().replace(".", "_") or "host"
    removed = []
    try:
        candidates = list(path.parent.glob(f"{_glob_escape(path.name)}.*.tmp"))
    except OSError:
        return removed
    for tmp in candidates:
        middle = tmp.name[len(path.name) + 1:-len(".tmp")]
        parts = middle.rsplit(".", 2)
        if len(parts) != 3 or parts[0] != host or not parts[1].isdigit():
            continue
        if not _pid_alive(int(parts[1])):
            try:
                tmp.unlink()
            except OSError:
                continue
            removed.append(tmp)
    return removed


def _glob_escape(name: str) -> str:
    import glob

    return glob.escape(name)


# --------------------------------------------------------------------------- write errors
def _fmt_bytes(b: float) -> str:
    for unit in ("B", "KB", "MB", "GB", "TB"):
        if b < 1024 or unit == "TB":
            return f"{int(b)} B" if unit == "B" else f"{b:.1f} {unit}"
        b /= 1024
    return f"{b:.1f} TB"  # pragma: no cover


#: Below this many free bytes beyond what a file needs, a failed write is put down to space.
_SPACE_MARGIN = 1 << 20


def write_error(path: str | os.PathLike, exc: BaseException, need: int = 0) -> OSError:
    """An :class:`OSError` that names the file a write failed on, and a full device.

    HDF5 reports a full disk as ``RuntimeError: NetCDF: HDF error``, with neither the file
    nor the cause. The device is called full when the error says so (``ENOSPC``,
    ``EDQUOT``) or when it has less room than the file needs (``need`` bytes) plus a margin.

    Parameters
    ----------
    path : path-like
        The file being written.
    exc : BaseException
        The original error.
    need : int
        Approximate size of the file in bytes (0: unknown).
    """
    path = Path(path)
    code = getattr(exc, "errno", None)
    try:
        usage = shutil.disk_usage(path.parent)
    except OSError:
        usage = None
    full = code in (errno.ENOSPC, getattr(errno, "EDQUOT", -1)) or (
        usage is not None and usage.free < need + _SPACE_MARGIN)
    if full:
        room = "" if usage is None else (
            f": {_fmt_bytes(usage.free)} free of {_fmt_bytes(usage.total)}")
        size = f", and this file needs about {_fmt_bytes(need)}" if need else ""
        return OSError(errno.ENOSPC,
                       f"cannot write {path}: no space left on the device holding "
                       f"{path.parent}{room}{size}; free some space or write elsewhere "
                       f"({type(exc).__name__}: {exc})")
    return OSError(code if code is not None else errno.EIO,
                   f"cannot write {path}: {type(exc).__name__}: {exc}")


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write a small text file atomically (temporary file, then rename); errors name it."""
    path = Path(path)
    tmp = temporary_path(path)
    try:
        try:
            tmp.write_text(text)
            os.replace(tmp, path)
        finally:
            tmp.unlink(missing_ok=True)
    except OSError as exc:
        raise write_error(path, exc, len(text.encode())) from exc
    return path


class IntegrityError(ValueError):
    """A result file or a stored chunk whose contents do not match their checksums (the one
    class for both; ``gearuq.execution.IntegrityError`` is this one)."""


#: HDF5 chunk cache per variable of files opened lazily (netCDF-C's default is 64 MB).
CHUNK_CACHE_BYTES = 4 * 2**20


def limit_chunk_cache() -> None:
    """Shrink netCDF-C's per-variable chunk cache for files opened from now on.

    A lazily loaded result keeps every chunk file open; with the default 64 MB cache per
    variable each file keeps the last data read from it, and a streamed pass over a stored
    result ends up holding most of it in memory (measured: 100 000 x 400 values, +360 MB
    with the default, +70 MB with 4 MB). Whole-variable reads do not benefit from the cache.
    """
    import netCDF4

    with netcdf_lock():
        size, nelems, preemption = netCDF4.get_chunk_cache()
        if size > CHUNK_CACHE_BYTES:
            netCDF4.set_chunk_cache(CHUNK_CACHE_BYTES, nelems, preemption)


def _locate_read_error(path: Path, exc: Exception) -> IntegrityError:
    """Name the variable whose stored bytes cannot be read back (fletcher32 mismatch)."""
    import netCDF4

    try:
        with netcdf_lock(), netCDF4.Dataset(path) as nc:
            for name, var in nc.variables.items():
                try:
                    var[...]
                except (RuntimeError, OSError) as inner:
                    return IntegrityError(
                        f"{path}: variable {name!r} is corrupt (its stored checksum does not "
                        f"match: {inner})")
    except (RuntimeError, OSError):
        pass
    return IntegrityError(f"{path} is corrupt or not a readable netCDF file: {exc}")


def verify(ds: xr.Dataset, path: str | os.PathLike = "<dataset>") -> None:
    """Check the ``checksum`` attributes written by :func:`save`.

    Raises
    ------
    IntegrityError
        Naming ``path`` and the first variable (or the global attributes) that differ.
    """
    for name, var in ds.variables.items():
        want = var.attrs.get(CHECKSUM)
        if want is not None and _digest_variable(var, var.attrs) != want:
            raise IntegrityError(f"{path}: variable {name!r} does not match its checksum "
                                 "(the file was changed or damaged after it was written)")
    want = ds.attrs.get(CHECKSUM)
    if want is None:
        warnings.warn(
            f"{path} has no {CHECKSUM!r} attribute: its contents cannot be verified (it was "
            "written without checksums, by another program, or the attribute was removed); "
            "loading it unverified", RuntimeWarning, stacklevel=3)
        return
    if _global_digest(ds.attrs) != want:
        raise IntegrityError(f"{path}: the global attributes do not match their checksum")
    try:
        listed = json.loads(str(ds.attrs.get(CHECKSUMMED, "[]")))
    except ValueError:
        listed = []
    missing = [str(v) for v in listed if v in ds.variables
               and CHECKSUM not in ds.variables[v].attrs]
    gone = [str(v) for v in listed if v not in ds.variables]
    if gone:
        raise IntegrityError(f"{path}: variable(s) {', '.join(map(repr, gone))} were written "
                             "with a checksum but are missing from the file")
    if missing:
        warnings.warn(
            f"{path}: variable(s) {', '.join(map(repr, missing))} lost their {CHECKSUM!r} "
            "attribute after the file was written: their values cannot be verified; "
            "loading them unverified", RuntimeWarning, stacklevel=3)


def load(path: str | os.PathLike, *, lazy: bool = False, verify_checksums: bool = True
         ) -> xr.Dataset:
    """Read a gearuq result written by :func:`save`, verifying its checksums.

    Parameters
    ----------
    path : path-like
        The ``.nc`` file.
    lazy : bool
        Open with dask arrays instead of loading everything into memory (checksums are then
        verified slice by slice, which reads the file once).
    verify_checksums : bool
        Verify the ``checksum`` attributes (default); files written without them load as is.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    IntegrityError
        If a variable or the global attributes do not match their checksums (the message names
        the file and the variable).
    ValueError
        If ``path`` is a folder, not netCDF or not a gearuq result (no ``gearuq_version``
        attribute).
    """
    lazy = check_bool("lazy", lazy)
    verify_checksums = check_bool("verify_checksums", verify_checksums)
    path = _as_path(path, "read")
    if not path.exists():
        raise FileNotFoundError(f"no such result file: {path}")
    if path.is_dir():
        found = sorted(p.name for p in path.glob("*.nc"))[:5]
        raise ValueError(f"{path} is a folder, not a result file; give one .nc file"
                         + (f" (it holds {', '.join(found)})" if found else
                            " (it holds no .nc file)"))
    if lazy:
        limit_chunk_cache()
    try:
        with netcdf_lock():
            handle = xr.open_dataset(path, engine="netcdf4", decode_times=False,
                                     decode_timedelta=False, chunks={} if lazy else None)
            ds = handle if lazy else handle.load()
            if not lazy:
                handle.close()
    except AttributeError as exc:  # HDF5 checks its metadata: a damaged attribute
        raise IntegrityError(f"{path} is corrupt: its attributes cannot be read ({exc})"
                             ) from exc
    except (OSError, ValueError, RuntimeError) as exc:
        if isinstance(exc, RuntimeError) or "HDF error" in str(exc):
            raise _locate_read_error(path, exc) from exc
        raise ValueError(f"{path} is not a readable netCDF file: {exc}") from exc
    if MARKER not in ds.attrs:
        raise ValueError(
            f"{path} is not a gearuq result: the global attribute {MARKER!r} is missing"
        )
    if verify_checksums:
        try:
            verify(ds, path)
        except RuntimeError as exc:
            raise _locate_read_error(path, exc) from exc
    ds.attrs.pop(CHECKSUM, None)
    ds.attrs.pop(CHECKSUMMED, None)
    for var in ds.variables.values():
        var.attrs.pop(CHECKSUM, None)
    return ds


def _csv_header(name: str, attrs: dict[str, Any]) -> str:
    """``name [units]`` (``name`` alone when the variable declares no units)."""
    units = str(attrs.get("units", "")).strip()
    return f"{name} [{units}]" if units else str(name)


def export_csv(dataset: xr.Dataset, path: str | os.PathLike) -> list[Path]:
    """Write a result as CSV files a spreadsheet opens: one per group of variables sharing dims.

    Each file has one column per dimension (its coordinate values, or 0, 1, ... where the
    dimension has none) followed by one column per variable over exactly those dims, one row
    per point of the grid (long form). Every header reads ``name [units]`` (``name`` alone
    where the variable declares no units). Coordinates that are not dimensions (a mode's
    output name, say) are exported as variables. The global attributes (provenance) and each
    column's other attributes go to ``provenance.json`` beside the CSV files.

    Parameters
    ----------
    dataset : xarray.Dataset
        Any gearuq result (what a model, an engine or :func:`load` returns).
    path : path-like
        Folder to write into (created). Files: ``scalars.csv`` for 0-d variables,
        ``<dim1>-<dim2>....csv`` for the others (``sample.csv``, ``sample-time.csv``...),
        and ``provenance.json``.

    Returns
    -------
    list of Path
        The files written, CSV files first.

    Raises
    ------
    TypeError
        If ``dataset`` is not an xarray.Dataset.
    ValueError
        If ``path`` is empty or names an existing file, or the Dataset holds no variable.

    Notes
    -----
    Floats are written with as many digits as round-trip exactly. Text (a mode's label) is
    written as is; a cell never holds a list.
    """
    if not isinstance(dataset, xr.Dataset):
        raise TypeError(f"dataset: expected an xarray.Dataset, got {type(dataset).__name__}")
    if not str(path).strip():
        raise ValueError("path: an empty folder name; give a folder to write the CSV files into")
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"path: {folder} is a file; give a folder to write the CSV files into")
    flat = dataset.reset_coords()  # non-dimension coordinates become columns too
    groups: dict[tuple[str, ...], list[str]] = {}
    for name, var in flat.data_vars.items():
        groups.setdefault(tuple(str(d) for d in var.dims), []).append(str(name))
    if not groups:
        raise ValueError("dataset: holds no variable to export")
    folder.mkdir(parents=True, exist_ok=True)
    _remove_earlier_export(folder, {("-".join(d) or "scalars") + ".csv" for d in groups})
    written: list[Path] = []
    for dims, names in groups.items():
        file = folder / (("-".join(dims) or "scalars") + ".csv")
        columns: dict[str, np.ndarray] = {}
        if dims:
            grids = np.meshgrid(*[
                np.asarray(flat[d].values) if d in flat.coords else np.arange(flat.sizes[d])
                for d in dims], indexing="ij")
            for d, grid in zip(dims, grids, strict=True):
                attrs = dict(flat[d].attrs) if d in flat.coords else {}
                columns[_csv_header(d, attrs)] = grid.ravel()
        for name in names:
            var = flat[name]
            columns[_csv_header(name, var.attrs)] = np.asarray(var.transpose(*dims).values
                                                               ).ravel()
        pd.DataFrame(columns).to_csv(file, index=False, float_format=None)
        written.append(file)
    meta = {
        "attrs": {k: _json_safe(v) for k, v in dataset.attrs.items()},
        "variables": {str(n): {k: _json_safe(v) for k, v in flat[n].attrs.items()}
                      for n in list(flat.data_vars) + list(flat.coords)},
        "files": {f.name: "-".join(d) or "scalars" for f, d in zip(written, groups,
                                                                   strict=True)},
    }
    sidecar = folder / "provenance.json"
    sidecar.write_text(json.dumps(meta, indent=1) + "\n")
    return [*written, sidecar]


def _remove_earlier_export(folder: Path, keep: set[str]) -> None:
    """Remove the CSV files an earlier export listed in ``folder``'s provenance.json that this
    export does not rewrite: left beside the new ones, they would pass for part of it."""
    sidecar = folder / "provenance.json"
    try:
        listed = json.loads(sidecar.read_text()).get("files", {})
    except (OSError, ValueError, AttributeError):
        return
    stale = sorted(name for name in listed if name not in keep and Path(name).name == name
                   and name.endswith(".csv") and (folder / name).is_file())
    for name in stale:
        (folder / name).unlink()
    if stale:
        warnings.warn(f"{folder}: held an earlier export; its {', '.join(stale)} removed, so "
                      "that every file there belongs to this one", UserWarning, stacklevel=3)


def _json_safe(value: Any) -> Any:
    """An attribute as JSON: arrays as lists, numpy scalars as Python numbers."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, bytes):
        return value.decode(errors="replace")
    return value
