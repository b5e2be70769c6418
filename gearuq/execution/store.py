"""Durable chunk stores: one netCDF file per chunk, a manifest, a lock and checksums.

A store is a directory::

    manifest.json            fingerprint of the call (model code, request, design, chunking)
    .lock                    exclusive lock of the run that uses the store (released on exit
                             or crash: it is an OS file lock, not a marker file)
    chunk_000000.nc          one chunk's result (netCDF4, fletcher32 on every variable)
    chunk_000000.nc.sha256   SHA-256 of that file, written after it

A chunk counts as stored only when its file and its checksum exist and agree; anything else
(an interrupted write, a flipped byte) is recomputed on resume with a warning, and reported
with the file's name when loaded directly.

A store that cannot be written (read-only media, no permission) is opened without the lock:
nobody can add to it, and its complete, verified chunks are reused; if chunks are missing the
run stops and says so. Worker processes never write a chunk after their run is gone
(:mod:`gearuq.execution.lifeline`).
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import math
import os
import sys
import time
import warnings
from collections.abc import Mapping
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from gearuq._version import __version__
from gearuq.execution.lifeline import check_parent
from gearuq.io import (
    CHECKSUMMED,
    IntegrityError,
    limit_chunk_cache,
    netcdf_lock,
    write_error,
    write_text_atomic,
)

__all__ = ["ChunkStore", "StoreMismatchError", "StoreLockedError", "IntegrityError",
           "write_chunk", "file_sha256", "jsonable"]

MANIFEST = "manifest.json"
LOCK = ".lock"
#: errno values of a store that cannot be written (read-only media, no permission).
_UNWRITABLE = (errno.EROFS, errno.EACCES, errno.EPERM)


class StoreMismatchError(ValueError):
    """A chunk store belongs to a different call than the one resuming it."""


class StoreLockedError(RuntimeError):
    """Another run holds the store's lock (and the caller asked not to wait)."""


def jsonable(obj: Any) -> Any:
    """Canonical JSON-compatible form (large arrays by digest, non-finite floats as text)."""
    from gearuq.model import array_digest

    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in sorted(obj.items(), key=lambda kv: str(kv[0]))}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist()) if obj.size <= 16 else array_digest(obj)
    if isinstance(obj, np.generic):
        return jsonable(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return repr(obj)
    if obj is None or isinstance(obj, (bool, int, float, str)):
        return obj
    return repr(obj)


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes (read in 8 MiB blocks)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 23), b""):
            h.update(block)
    return h.hexdigest()


def chunk_path(store: str | os.PathLike, index: int) -> Path:
    """File of chunk ``index`` in ``store``."""
    return Path(store) / f"chunk_{index:06d}.nc"


def write_chunk(store: str | os.PathLike, index: int, ds: xr.Dataset) -> Path:
    """Write one chunk atomically, then its checksum file (the chunk's commit record).

    In a worker process whose run is gone (killed), nothing is written: the chunk is written
    under a temporary name and renamed only after checking that the run still exists, so an
    orphaned worker never adds a chunk to a store that a new run may already own.

    Raises
    ------
    gearuq.execution.lifeline.ParentGoneError
        In a worker whose parent process is gone.
    OSError
        If the file cannot be written (the message names the file; a full device says so).
    """
    from gearuq.io import save

    path = chunk_path(store, index)
    check_parent(f"write {path}")
    part = path.with_name(f"{path.name}.{os.getpid()}.part.tmp")
    try:
        try:
            save(ds, part)
        except OSError as exc:  # name the chunk, not its temporary
            raise write_error(path, exc.__cause__ or exc, int(ds.nbytes)) from exc
        digest = file_sha256(part)
        check_parent(f"commit {path}")
        os.replace(part, path)
    finally:
        part.unlink(missing_ok=True)
    try:
        check_parent(f"commit {path}")
    except BaseException:
        path.unlink(missing_ok=True)  # no commit record: it would be discarded anyway
        raise
    write_text_atomic(path.with_name(path.name + ".sha256"), digest + "\n")
    return path


# =========================================================================== the lock
class _FileLock:
    """Exclusive advisory lock on a file; the OS releases it when the process dies."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._fh: Any = None

    def try_acquire(self) -> bool:
        fh = open(self.path, "a+")  # noqa: SIM115 - held open for the lock's lifetime
        try:
            if sys.platform == "win32":  # pragma: no cover - exercised on Windows only
                import msvcrt

                msvcrt.locking(fh.fileno(), msvcrt.LK_NBLCK, 1)
            else:
                import fcntl

                fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.close()
            return False
        fh.seek(0)
        fh.truncate()
        fh.write(f"pid {os.getpid()} since {datetime.now(timezone.utc).isoformat()}\n")
        fh.flush()
        self._fh = fh
        return True

    def holder(self) -> str:
        try:
            return self.path.read_text().strip() or "another process"
        except OSError:
            return "another process"

    def release(self) -> None:
        fh, self._fh = self._fh, None
        if fh is not None:
            with contextlib.suppress(OSError):
                if sys.platform != "win32":
                    import fcntl

                    fcntl.flock(fh.fileno(), fcntl.LOCK_UN)
            fh.close()


# =========================================================================== the store
class ChunkStore:
    """Directory of per-chunk netCDF files with a manifest, a lock and checksums.

    Use as a context manager (or call :meth:`close`): the lock is held from construction to
    close. Opening a store that another run holds waits for it (a second identical run then
    finds the finished chunks and shares them) unless the other run is a different call,
    which is refused at once.

    Parameters
    ----------
    path : path-like
        Directory (created if missing). It must be empty or a store of the same call.
    fingerprint : dict
        JSON-able description of the call; compared on reopening.
    wait : float
        Seconds to wait for another run's lock (``inf``: as long as it takes; 0: fail at once
        with :class:`StoreLockedError`).

    Raises
    ------
    StoreMismatchError
        If the directory holds a store of a different call (the message lists the
        differences).
    StoreLockedError
        If the lock was not obtained within ``wait`` seconds.
    ValueError
        If the directory holds other files but no manifest.
    """

    MANIFEST = MANIFEST

    def __init__(self, path: str | os.PathLike, fingerprint: Mapping[str, Any],
                 *, wait: float = math.inf) -> None:
        self.path = Path(path)
        self.fingerprint = jsonable(dict(fingerprint))
        #: Why the store cannot be written (read-only media or no permission), or ``None``.
        self.read_only: str | None = None
        if self.path.exists() and not self.path.is_dir():
            raise ValueError(f"store: {str(self.path)!r} is an existing file, not a folder; "
                             "give a folder for the chunk store")
        if not self.path.is_dir():
            self.path.mkdir(parents=True, exist_ok=True)
        self._lock = _FileLock(self.path / LOCK)
        try:
            self._acquire(wait)
        except OSError as exc:
            if exc.errno not in _UNWRITABLE:
                raise
            self._open_read_only(exc)
            return
        try:
            self._check_or_create()
        except BaseException:
            self.close()
            raise
        self._clean_temporaries()

    def _open_read_only(self, exc: OSError) -> None:
        """Use a store that cannot be written: read its finished chunks, take no lock.

        Nobody can add to a store on read-only media, so there is nothing to lock against;
        every chunk that is read has a checksum record and is verified first.
        """
        self.read_only = f"{exc.strerror or exc}"
        stored = self._stored_fingerprint()
        if stored is None:
            raise ValueError(
                f"store {self.path} cannot be written ({self.read_only}) and holds no "
                f"{MANIFEST}: there is nothing to reuse; use a writable directory") from exc
        if stored != self.fingerprint:
            raise StoreMismatchError(self._mismatch_text(stored))

    # ------------------------------------------------------------------ lock + manifest
    def _acquire(self, wait: float) -> None:
        t0 = time.monotonic()
        told = False
        while not self._lock.try_acquire():
            self._check_manifest_only()  # a different call fails now, not after the other run
            if time.monotonic() - t0 >= wait:
                raise StoreLockedError(
                    f"store {self.path} is in use by {self._lock.holder()}; wait for it to "
                    "finish, or use another store directory")
            if not told:
                print(f"gearuq: store {self.path} is in use by {self._lock.holder()}; "
                      "waiting for it (its finished chunks will be reused)", file=sys.stderr)
                told = True
            time.sleep(0.2)

    def _stored_fingerprint(self) -> dict[str, Any] | None:
        manifest = self.path / MANIFEST
        if not manifest.exists():
            return None
        try:
            return json.loads(manifest.read_text())["fingerprint"]
        except (ValueError, KeyError) as exc:
            raise ValueError(f"store {self.path}: unreadable {MANIFEST} ({exc})") from None

    def _check_manifest_only(self) -> None:
        stored = self._stored_fingerprint()
        if stored is not None and stored != self.fingerprint:
            raise StoreMismatchError(self._mismatch_text(stored))

    def _check_or_create(self) -> None:
        stored = self._stored_fingerprint()
        if stored is not None:
            if stored != self.fingerprint:
                raise StoreMismatchError(self._mismatch_text(stored))
            return
        others = [p.name for p in self.path.iterdir() if p.name != LOCK]
        if others:
            raise ValueError(
                f"store {self.path}: directory is not empty ({', '.join(sorted(others)[:5])}"
                f"{', ...' if len(others) > 5 else ''}) and has no {MANIFEST}; use an empty or "
                "new directory")
        data = {"format": "gearuq-chunk-store", "format_version": 2,
                "gearuq_version": __version__,
                "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                "fingerprint": self.fingerprint}
        write_text_atomic(self.path / MANIFEST, json.dumps(data, indent=1, sort_keys=True))

    def _mismatch_text(self, stored: Mapping[str, Any]) -> str:
        diffs = []
        for key in sorted(set(stored) | set(self.fingerprint)):
            a, b = stored.get(key, "<absent>"), self.fingerprint.get(key, "<absent>")
            if a != b:
                diffs.append(f"{key}: store has {_short(a)}, this call has {_short(b)}")
        return (f"store {self.path} holds chunks of a different run; differences: "
                + "; ".join(diffs)
                + ". Use another store directory, or repeat the original call exactly.")

    def _clean_temporaries(self) -> None:
        # We hold the lock: no other run writes here, every temporary is a leftover.
        for stale in self.path.glob("*.tmp"):
            stale.unlink(missing_ok=True)
        for nc in self.path.glob("chunk_*.nc"):
            if not nc.with_name(nc.name + ".sha256").exists():
                nc.unlink(missing_ok=True)  # written, but its commit record never was

    def close(self) -> None:
        """Release the lock."""
        self._lock.release()

    def __enter__(self) -> ChunkStore:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # ------------------------------------------------------------------ chunks
    def chunk_path(self, index: int) -> Path:
        """File of chunk ``index``."""
        return chunk_path(self.path, index)

    def stored_chunks(self) -> list[int]:
        """Indices of the chunks whose file and checksum record are both on disk."""
        out = []
        for p in self.path.glob("chunk_*.nc"):
            if not p.with_name(p.name + ".sha256").exists():
                continue
            with contextlib.suppress(IndexError, ValueError):
                out.append(int(p.stem.split("_")[1]))
        return sorted(out)

    def _problem(self, index: int) -> str | None:
        """What is wrong with stored chunk ``index`` (``None``: it matches its record)."""
        path = self.chunk_path(index)
        side = path.with_name(path.name + ".sha256")
        try:
            expected = side.read_text().strip()
        except OSError as exc:
            return f"store chunk {path}: no checksum record ({exc})"
        actual = file_sha256(path)
        if actual != expected:
            return (f"store chunk {path} is corrupt: SHA-256 {actual[:16]}... differs from "
                    f"its record {expected[:16]}... in {side.name}")
        return None

    def verify(self, index: int) -> None:
        """Raise :class:`IntegrityError` naming the file if chunk ``index`` is corrupt."""
        problem = self._problem(index)
        if problem is not None:
            side = self.chunk_path(index).name + ".sha256"
            raise IntegrityError(f"{problem}; delete it (and {side}) and run the same call "
                                 "again with this store to recompute it")

    def valid_chunks(self, expected_sizes: Mapping[int, int]) -> list[int]:
        """Stored chunks that pass their checksum; corrupt ones are deleted with a warning
        (and so computed again by the run), or only reported in a read-only store."""
        good = []
        for i in self.stored_chunks():
            if i not in expected_sizes:
                continue
            problem = self._problem(i)
            if problem is None:
                good.append(i)
            elif self.read_only:
                warnings.warn(f"{problem}; the store cannot be written ({self.read_only}), so "
                              "it is left in place and cannot be recomputed here",
                              RuntimeWarning, stacklevel=3)
            else:
                self.discard(i)
                warnings.warn(f"{problem}; it was deleted and this run computes it again",
                              RuntimeWarning, stacklevel=3)
        return good

    def discard(self, index: int) -> None:
        """Delete chunk ``index`` and its checksum record."""
        path = self.chunk_path(index)
        path.with_name(path.name + ".sha256").unlink(missing_ok=True)
        path.unlink(missing_ok=True)

    def load(self, index: int) -> xr.Dataset | None:
        """Chunk ``index`` fully in memory, verified (``None`` if it is not stored)."""
        from gearuq.io import load

        if index not in self.stored_chunks():
            return None
        self.verify(index)
        ds = load(self.chunk_path(index))
        ds.encoding = {}
        for v in ds.variables.values():
            v.encoding = {}
        return ds

    def write(self, index: int, ds: xr.Dataset) -> None:
        """Write chunk ``index`` atomically, then its checksum record."""
        write_chunk(self.path, index, ds)

    def open(self, indices: list[int]) -> xr.Dataset:
        """The chunks ``indices`` as one lazily loaded Dataset (dask arrays, one per chunk)."""
        limit_chunk_cache()
        paths = [str(self.chunk_path(i)) for i in indices]
        with netcdf_lock():
            ds = xr.open_mfdataset(
                paths, engine="netcdf4", combine="nested", concat_dim="sample",
                data_vars="minimal", coords="minimal", compat="override", join="override",
                combine_attrs="override", decode_times=False, decode_timedelta=False,
                chunks={}, parallel=False,
            )
        for v in ds.variables.values():
            v.attrs.pop("checksum", None)
        ds.attrs.pop("checksum", None)
        ds.attrs.pop(CHECKSUMMED, None)
        return ds


def _short(v: Any, limit: int = 120) -> str:
    s = json.dumps(v, sort_keys=True) if not isinstance(v, str) else repr(v)
    return s if len(s) <= limit else s[: limit - 3] + "..."
