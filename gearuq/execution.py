"""Executors and chunked, resumable model evaluation.

:func:`evaluate_chunks` cuts a design (drawn once, up front, by the caller) into contiguous
chunks of samples, evaluates each chunk with ``model.response`` through an executor and
concatenates the chunk results in sample order. Because every chunk is a slice of the same
design, the result is bit-identical for any chunk size and any executor, provided the model
treats its samples independently (a model whose output for one sample depends on the other
samples in its batch breaks this, whatever the engine does).

Executors (:func:`resolve_executor`)
------------------------------------
``"serial"``
    In the calling process, chunk after chunk.
``"processes"``
    A :class:`concurrent.futures.ProcessPoolExecutor` with the ``"spawn"`` start method
    (safe with threads, identical on Linux, macOS and Windows). The model is serialised once
    with cloudpickle (so models built from lambdas or closures work) and rebuilt in each
    worker; the classes it uses must be importable there (installed packages, or modules on
    ``sys.path``, which spawned workers inherit). As with every spawn-based pool, a script
    that starts a run at import time needs an ``if __name__ == "__main__":`` guard.
``"dask"`` / a ``distributed.Client`` / a scheduler address ``"tcp://host:port"``
    dask.distributed: the model is scattered once to every worker, chunks are submitted as
    tasks. An address creates a client that is closed afterwards; a given client is left
    open. ``"dask"`` uses the current default client.
any :class:`concurrent.futures.Executor`
    Used as is (left open); the serialised model travels with every task.
``None``
    ``"processes"`` if the machine has more than one CPU and more than one chunk is to be
    computed, else ``"serial"``.

Failures and durability
-----------------------
A chunk whose evaluation raises an exception is not lost: its samples get status 4
(``model_error``) with NaN outputs (inputs are kept), the message goes into the Dataset
attribute ``errors`` (JSON) and a :class:`RuntimeWarning` is issued; the other chunks are
unaffected. Executor-level failures (a crashed worker process, a lost dask worker) are treated
the same way. If every chunk fails there is nothing to return and a RuntimeError is raised.
With ``store=DIR`` every finished chunk is written to ``DIR/chunk_NNNNNN.nc``
(temporary file, then atomic rename) next to ``DIR/manifest.json``, which holds a fingerprint
of the call. Rerunning the same call loads the stored chunks instead of recomputing them; a
store whose fingerprint differs raises :class:`StoreMismatchError`. Failed chunks are not
stored, so a rerun retries them. Only one run may use a store at a time.
"""

from __future__ import annotations

import concurrent.futures as cf
import hashlib
import json
import math
import multiprocessing
import os
import pickle
import sys
import time
import traceback
import warnings
from collections.abc import Iterable, Iterator, Mapping
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from gearuq._version import __version__
from gearuq.model import STATUS_MODEL_ERROR, Model

__all__ = [
    "Runner",
    "SerialRunner",
    "ProcessRunner",
    "FuturesRunner",
    "DaskRunner",
    "ChunkStore",
    "StoreMismatchError",
    "resolve_executor",
    "evaluate_chunks",
    "default_chunk_size",
    "chunk_bounds",
]

#: Largest default chunk (samples).
MAX_DEFAULT_CHUNK = 10_000


# =========================================================================== chunking
def default_chunk_size(n_samples: int) -> int:
    """Default chunk size: about 32 chunks, at least 64 samples each, at most 10 000.

    It depends on ``n_samples`` only (not on the executor), so a stored run can be resumed
    with a different executor.
    """
    c = max(math.ceil(n_samples / 32), min(n_samples, 64))
    return int(max(1, min(c, MAX_DEFAULT_CHUNK)))


def chunk_bounds(n_samples: int, chunk_size: int) -> list[tuple[int, int]]:
    """``[(start, stop), ...]`` of consecutive chunks covering ``range(n_samples)``."""
    return [(s, min(s + chunk_size, n_samples)) for s in range(0, n_samples, chunk_size)]


def _check_chunk_size(chunk_size: Any, n: int) -> int:
    if chunk_size is None:
        return default_chunk_size(n)
    if isinstance(chunk_size, (bool, np.bool_)) or not isinstance(chunk_size, (int, np.integer)):
        raise ValueError(f"chunk_size: expected a positive integer, got {chunk_size!r}")
    if chunk_size <= 0:
        raise ValueError(f"chunk_size: must be positive, got {chunk_size}")
    return int(min(chunk_size, n))


# =========================================================================== the chunk task
def _evaluate_chunk(
    model: Model, params: dict[str, np.ndarray], t: Any, outputs: Any, options: dict[str, Any]
) -> tuple:
    """Evaluate one chunk; return ``("ok", ds)`` or ``("error", message, traceback)``."""
    try:
        ds = model.response(params, t, outputs=outputs, **options)
    except Exception as exc:  # noqa: BLE001 - any model failure is flagged, not raised
        return ("error", f"{type(exc).__name__}: {exc}", traceback.format_exc(limit=20))
    return ("ok", ds)


def _dumps(model: Model) -> bytes:
    try:
        import cloudpickle

        return cloudpickle.dumps(model)
    except ImportError:  # pragma: no cover - cloudpickle comes with dask
        return pickle.dumps(model)


def _serialise_model(model: Model, executor_name: str) -> bytes:
    try:
        return _dumps(model)
    except Exception as exc:  # noqa: BLE001
        raise ValueError(
            f"model {model.name!r} cannot be pickled for executor {executor_name!r} "
            f"({type(exc).__name__}: {exc}); use executor='serial' or make the model picklable "
            f"(module-level functions, no open files or locks)"
        ) from exc


_WORKER_MODELS: dict[str, Model] = {}


def _payload_task(
    key: str, payload: bytes, params: dict, t: Any, outputs: Any, options: dict
) -> tuple:
    """Worker side: rebuild the model once per worker process (cached by digest), evaluate."""
    model = _WORKER_MODELS.get(key)
    if model is None:
        try:
            model = pickle.loads(payload)
        except Exception as exc:  # noqa: BLE001 - reported as a chunk error
            return ("error", f"cannot unpickle the model in the worker: "
                    f"{type(exc).__name__}: {exc}", traceback.format_exc(limit=20))
        _WORKER_MODELS.clear()
        _WORKER_MODELS[key] = model
    return _evaluate_chunk(model, params, t, outputs, options)


# =========================================================================== runners
Task = tuple[int, dict[str, np.ndarray]]


class Runner:
    """Runs chunk tasks; yields ``(chunk_index, result)`` as they complete."""

    name = "runner"
    n_workers = 1

    def run(
        self, model: Model, tasks: list[Task], t: Any, outputs: Any, options: dict[str, Any]
    ) -> Iterator[tuple[int, tuple]]:
        """Evaluate ``tasks``; yield ``(index, result)`` in completion order."""
        raise NotImplementedError

    def close(self, abort: bool = False) -> None:
        """Release resources this runner owns (``abort``: the run was interrupted)."""

    def __enter__(self) -> Runner:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"{type(self).__name__}(n_workers={self.n_workers})"


class SerialRunner(Runner):
    """Evaluate chunks one after the other in the calling process."""

    name = "serial"

    def run(self, model, tasks, t, outputs, options):
        for index, params in tasks:
            yield index, _evaluate_chunk(model, params, t, outputs, options)


class ProcessRunner(Runner):
    """Local process pool (``spawn`` start method).

    The pool starts on first use and lives until :meth:`close`, so a runner passed as
    ``executor=`` to several runs pays the worker start-up (about a second or two: each
    spawned worker imports numpy, xarray and the caller's main module) only once::

        with ProcessRunner(4) as runner:
            a = monte_carlo(model, space, n_samples=10_000, rng=1, executor=runner)
            b = monte_carlo(model, space, n_samples=10_000, rng=2, executor=runner)

    The model travels with each task as cloudpickle bytes and is unpickled once per worker.

    Parameters
    ----------
    n_workers : int, optional
        Worker processes (default ``os.cpu_count()``).
    mp_context : str
        multiprocessing start method; ``"spawn"`` by default.
    """

    name = "processes"

    def __init__(self, n_workers: int | None = None, mp_context: str = "spawn") -> None:
        if n_workers is not None and int(n_workers) < 1:
            raise ValueError(f"n_workers: must be positive, got {n_workers}")
        self.n_workers = int(n_workers or os.cpu_count() or 1)
        self.mp_context = mp_context
        self._pool: cf.ProcessPoolExecutor | None = None

    def _get_pool(self) -> cf.ProcessPoolExecutor:
        if self._pool is None:
            self._pool = cf.ProcessPoolExecutor(
                max_workers=self.n_workers,
                mp_context=multiprocessing.get_context(self.mp_context),
            )
        return self._pool

    def run(self, model, tasks, t, outputs, options):
        payload = _serialise_model(model, self.name)
        key = hashlib.sha256(payload).hexdigest()
        pool = self._get_pool()
        futures = {
            pool.submit(_payload_task, key, payload, p, t, outputs, options): i for i, p in tasks
        }
        try:
            for fut in cf.as_completed(futures):
                yield futures[fut], _future_result(fut)
        finally:
            for fut in futures:
                fut.cancel()
            if getattr(self._pool, "_broken", False):
                self.close(abort=True)  # a broken pool cannot be reused

    def close(self, abort: bool = False) -> None:
        """Shut the pool down; ``abort=True`` terminates running workers (interrupted run)."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        if abort:
            for proc in list(getattr(pool, "_processes", {}).values()):
                proc.terminate()
        pool.shutdown(wait=not abort, cancel_futures=True)


class FuturesRunner(Runner):
    """A user-supplied :class:`concurrent.futures.Executor` (left open)."""

    name = "futures"

    def __init__(self, executor: cf.Executor) -> None:
        self.executor = executor
        self.n_workers = int(getattr(executor, "_max_workers", 1) or 1)

    def run(self, model, tasks, t, outputs, options):
        payload = _serialise_model(model, self.name)
        key = hashlib.sha256(payload).hexdigest()
        futures = {
            self.executor.submit(_payload_task, key, payload, p, t, outputs, options): i
            for i, p in tasks
        }
        try:
            for fut in cf.as_completed(futures):
                yield futures[fut], _future_result(fut)
        finally:
            for fut in futures:
                fut.cancel()


class DaskRunner(Runner):
    """dask.distributed client; the model is scattered once to all workers.

    Parameters
    ----------
    client : distributed.Client
        Connected client.
    owns : bool
        Close the client in :meth:`close` (when it was created from an address).
    """

    name = "dask"

    def __init__(self, client: Any, owns: bool = False) -> None:
        self.client = client
        self.owns = owns
        try:
            self.n_workers = max(1, len(client.scheduler_info().get("workers", {})))
        except Exception:  # noqa: BLE001 - informational only
            self.n_workers = 1

    def run(self, model, tasks, t, outputs, options):
        from distributed import as_completed

        _serialise_model(model, self.name)  # fail early with a clear message
        model_future = self.client.scatter(model, broadcast=True, hash=False)
        futures = {
            self.client.submit(_evaluate_chunk, model_future, p, t, outputs, options,
                               pure=False): i
            for i, p in tasks
        }
        try:
            for fut in as_completed(list(futures)):
                yield futures[fut], _future_result(fut)
        finally:
            self.client.cancel(list(futures) + [model_future])

    def close(self, abort: bool = False) -> None:
        if self.owns:
            self.client.close()


def _future_result(fut: Any) -> tuple:
    """Result of a chunk future; an executor-level failure becomes an error result."""
    try:
        return fut.result()
    except Exception as exc:  # noqa: BLE001 - e.g. BrokenProcessPool, KilledWorker
        hint = ""
        if type(exc).__name__ == "BrokenProcessPool":
            hint = (" (worker processes are started with 'spawn' and re-import the calling "
                    "script: put the script's code under `if __name__ == \"__main__\":`, or "
                    "pass executor='serial')")
        return ("error", f"executor failure: {type(exc).__name__}: {exc}{hint}",
                "".join(traceback.format_exception(exc, limit=5)))


def resolve_executor(executor: Any = None, n_workers: int | None = None) -> Runner:
    """Turn an executor specification into a :class:`Runner`.

    Parameters
    ----------
    executor : None, str, distributed.Client, concurrent.futures.Executor or Runner
        ``None`` (``"processes"`` when ``os.cpu_count() > 1``, else ``"serial"``; models with
        ``internally_parallel = True`` run serially by default in :func:`evaluate_chunks`),
        ``"serial"``, ``"processes"``, ``"dask"`` (current default dask client), a dask
        scheduler address such as ``"tcp://127.0.0.1:8786"``, a ``distributed.Client``, any
        ``concurrent.futures.Executor``, or a ready :class:`Runner`.
    n_workers : int, optional
        Worker processes for ``"processes"``.

    Raises
    ------
    ValueError
        For an unknown specification (the message lists the valid ones).
    """
    if isinstance(executor, Runner):
        return executor
    if executor is None:
        executor = "processes" if (os.cpu_count() or 1) > 1 else "serial"
    if isinstance(executor, str):
        key = executor.strip().lower()
        if key == "serial":
            return SerialRunner()
        if key in ("processes", "process", "local"):
            return ProcessRunner(n_workers)
        if key == "dask":
            from distributed import get_client

            try:
                return DaskRunner(get_client(), owns=False)
            except ValueError as exc:
                raise ValueError(
                    "executor='dask': no dask client is running; create a distributed.Client "
                    "or pass a scheduler address 'tcp://host:port'"
                ) from exc
        if "://" in key:
            from distributed import Client

            return DaskRunner(Client(executor), owns=True)
        raise ValueError(
            f"executor: unknown {executor!r}; valid: 'serial', 'processes', 'dask', a scheduler "
            f"address 'tcp://host:port', a distributed.Client or a concurrent.futures.Executor"
        )
    if type(executor).__name__ == "Client" and hasattr(executor, "scatter"):
        return DaskRunner(executor, owns=False)
    if isinstance(executor, cf.Executor):
        return FuturesRunner(executor)
    raise ValueError(
        f"executor: unsupported object {executor!r}; valid: 'serial', 'processes', 'dask', a "
        f"scheduler address, a distributed.Client or a concurrent.futures.Executor"
    )


# =========================================================================== store
class StoreMismatchError(ValueError):
    """A chunk store belongs to a different call than the one resuming it."""


def _jsonable(obj: Any) -> Any:
    """Canonical JSON-compatible form (arrays by digest when large)."""
    if isinstance(obj, Mapping):
        return {str(k): _jsonable(v) for k, v in sorted(obj.items(), key=lambda kv: str(kv[0]))}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        if obj.size <= 16:
            return _jsonable(obj.tolist())
        return array_digest(obj)
    if isinstance(obj, (np.generic,)):
        return obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return repr(obj)
    if obj is None or isinstance(obj, (bool, int, float, str)):
        return obj
    return repr(obj)


def array_digest(a: Any) -> dict[str, Any]:
    """Short description of an array: dtype, shape and SHA-256 of its bytes."""
    a = np.ascontiguousarray(np.asarray(a))
    return {
        "dtype": str(a.dtype),
        "shape": list(a.shape),
        "sha256": hashlib.sha256(a.tobytes()).hexdigest(),
    }


def design_digest(design: Mapping[str, np.ndarray]) -> str:
    """SHA-256 over the parameter names and values of a design."""
    h = hashlib.sha256()
    for k in sorted(design):
        a = np.ascontiguousarray(np.asarray(design[k], dtype=float))
        h.update(k.encode())
        h.update(a.tobytes())
    return h.hexdigest()


class ChunkStore:
    """Directory of per-chunk netCDF files plus a ``manifest.json`` fingerprint.

    Parameters
    ----------
    path : path-like
        Directory (created if missing). It must be empty or a store of the same call.
    fingerprint : dict
        JSON-able description of the call; compared on reopening.

    Raises
    ------
    StoreMismatchError
        If the directory holds a store with a different fingerprint.
    ValueError
        If the directory holds other files but no manifest.
    """

    MANIFEST = "manifest.json"

    def __init__(self, path: str | os.PathLike, fingerprint: Mapping[str, Any]) -> None:
        self.path = Path(path)
        self.fingerprint = _jsonable(dict(fingerprint))
        self.path.mkdir(parents=True, exist_ok=True)
        # Temp files left by an interrupted write; young ones may belong to another process
        # writing to the same store right now, so only those older than 10 minutes go.
        now = time.time()
        for stale in self.path.glob("*.tmp"):
            try:
                if now - stale.stat().st_mtime > 600.0:
                    stale.unlink(missing_ok=True)
            except FileNotFoundError:
                pass
        manifest = self.path / self.MANIFEST
        if manifest.exists():
            try:
                stored = json.loads(manifest.read_text())["fingerprint"]
            except (ValueError, KeyError) as exc:
                raise ValueError(f"store {self.path}: unreadable manifest ({exc})") from None
            if stored != self.fingerprint:
                raise StoreMismatchError(self._mismatch_text(stored))
        else:
            others = [p.name for p in self.path.iterdir()]
            if others:
                raise ValueError(
                    f"store {self.path}: directory is not empty ({', '.join(sorted(others)[:5])}"
                    f"{', ...' if len(others) > 5 else ''}) and has no {self.MANIFEST}; use an "
                    f"empty or new directory"
                )
            self._write_manifest()

    def _mismatch_text(self, stored: Mapping[str, Any]) -> str:
        diffs = []
        for key in sorted(set(stored) | set(self.fingerprint)):
            a, b = stored.get(key, "<absent>"), self.fingerprint.get(key, "<absent>")
            if a != b:
                diffs.append(f"{key}: store has {_short(a)}, this call has {_short(b)}")
        return (
            f"store {self.path} holds chunks of a different run; differences: "
            + "; ".join(diffs)
            + ". Use another store directory, or repeat the original call exactly."
        )

    def _write_manifest(self) -> None:
        data = {
            "format": "gearuq-chunk-store",
            "format_version": 1,
            "gearuq_version": __version__,
            "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "fingerprint": self.fingerprint,
        }
        tmp = self.path / f"{self.MANIFEST}.{os.getpid()}.tmp"
        tmp.write_text(json.dumps(data, indent=1, sort_keys=True))
        os.replace(tmp, self.path / self.MANIFEST)

    def chunk_path(self, index: int) -> Path:
        """File of chunk ``index``."""
        return self.path / f"chunk_{index:06d}.nc"

    def stored_chunks(self) -> list[int]:
        """Indices of the chunks on disk."""
        out = []
        for p in self.path.glob("chunk_*.nc"):
            try:
                out.append(int(p.stem.split("_")[1]))
            except (IndexError, ValueError):
                continue
        return sorted(out)

    def load(self, index: int) -> xr.Dataset | None:
        """Load chunk ``index`` fully into memory (``None`` if missing or unreadable)."""
        from gearuq.io import load

        path = self.chunk_path(index)
        if not path.exists():
            return None
        try:
            ds = load(path)
        except (OSError, ValueError) as exc:
            warnings.warn(f"store: unreadable chunk {path.name} is recomputed ({exc})",
                          RuntimeWarning, stacklevel=3)
            path.unlink(missing_ok=True)
            return None
        ds.encoding = {}
        for v in ds.variables.values():
            v.encoding = {}
        return ds

    def write(self, index: int, ds: xr.Dataset) -> None:
        """Write chunk ``index`` atomically (temporary file, then rename)."""
        from gearuq.io import save

        save(ds, self.chunk_path(index))


def _short(v: Any, limit: int = 120) -> str:
    s = json.dumps(v, sort_keys=True) if not isinstance(v, str) else repr(v)
    return s if len(s) <= limit else s[: limit - 3] + "..."


# =========================================================================== failed chunks
def _fill_value(dtype: np.dtype) -> Any:
    if dtype.kind in "fc":
        return np.nan
    if dtype.kind == "i":
        return -1
    if dtype.kind == "u":
        return np.iinfo(dtype).max
    if dtype.kind == "b":
        return False
    if dtype.kind == "M":
        return np.datetime64("NaT")
    if dtype.kind == "m":
        return np.timedelta64("NaT")
    return ""


def _failed_from_template(
    template: xr.Dataset, inputs: Mapping[str, np.ndarray], start: int, stop: int
) -> xr.Dataset:
    """A chunk of ``stop - start`` failed samples shaped like ``template``."""
    m = stop - start
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
    return out.assign_coords(sample=np.arange(start, stop))


def _chunk_inputs(model: Model, params: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    try:
        return model.validate_params(params)
    except (ValueError, TypeError):
        return {k: np.asarray(v, dtype=float) for k, v in params.items()}


# =========================================================================== progress
def _progress_bar(progress: Any, total: int, initial: int, desc: str) -> Any:
    if progress is False:
        return None
    from tqdm.auto import tqdm

    kwargs: dict[str, Any] = {"total": total, "initial": initial, "unit": "sample",
                              "desc": desc, "dynamic_ncols": True}
    if progress is None:
        kwargs["delay"] = 2.0
        if not (hasattr(sys.stderr, "isatty") and sys.stderr.isatty()):
            kwargs["mininterval"] = 10.0
    return tqdm(**kwargs)


# =========================================================================== main entry
def evaluate_chunks(
    model: Model,
    design: Mapping[str, Any],
    t: Any = None,
    outputs: str | Iterable[str] | None = None,
    options: Mapping[str, Any] | None = None,
    chunk_size: int | None = None,
    executor: Any = None,
    store: str | os.PathLike | None = None,
    progress: bool | None = None,
    *,
    n_workers: int | None = None,
    fingerprint: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """Evaluate ``model`` on a design, chunk by chunk, through an executor.

    Parameters
    ----------
    model : Model
        The model (must be picklable for process and dask executors).
    design : mapping
        Parameter name -> array ``(n,)``; drawn once by the caller. Parameters not given take
        the model's nominal values.
    t : array_like, optional
        Output instants passed to ``model.response``.
    outputs : str or list of str, optional
        Outputs to compute (default: all).
    options : mapping, optional
        Model options passed to ``model.response``.
    chunk_size : int, optional
        Samples per chunk (default :func:`default_chunk_size`).
    executor : optional
        See :func:`resolve_executor`. ``None`` evaluates serially when at most one chunk is to
        be computed.
    store : path-like, optional
        Directory for durable, resumable runs (one netCDF file per chunk + manifest).
    progress : bool, optional
        ``True`` always shows a tqdm bar, ``False`` never; ``None`` shows it only once a run
        has lasted 2 s (and refreshes at most every 10 s when stderr is not a terminal).
    n_workers : int, optional
        Worker processes for ``executor="processes"``.
    fingerprint : mapping, optional
        Extra provenance for the store manifest (the caller's space, rule, seed, ...). The
        model name, version and settings, a digest of the design, ``t``, ``outputs``,
        ``options`` and ``chunk_size`` are always included.

    Returns
    -------
    xarray.Dataset
        All chunks concatenated along ``sample`` (coordinate ``0..n-1``). Attributes: the
        model's, plus ``executor``, ``chunk_size``, ``n_chunks``, ``n_failed`` (samples with
        nonzero status) and, when chunks failed, ``errors`` (JSON list).

    Raises
    ------
    ValueError
        Bad design, chunk size or executor; :class:`StoreMismatchError` for a foreign store.
    RuntimeError
        If every chunk failed (nothing to return; the message holds the first error).
    """
    options = dict(options or {})
    params = {k: np.asarray(v, dtype=float) for k, v in design.items()}
    if not params:
        raise ValueError("design: empty; give at least one parameter array")
    lengths = {k: a.shape for k, a in params.items()}
    if any(a.ndim != 1 for a in params.values()) or len({a.shape[0] for a in params.values()}) != 1:
        raise ValueError(f"design: expected 1-D arrays of one common length, got shapes {lengths}")
    n = next(iter(params.values())).shape[0]
    if n == 0:
        raise ValueError("design: zero samples")
    outputs = model.validate_outputs(outputs)
    t_arr = None if t is None else np.asarray(t, dtype=float)
    chunk_size = _check_chunk_size(chunk_size, n)
    bounds = chunk_bounds(n, chunk_size)

    chunks: dict[int, xr.Dataset] = {}
    chunk_store = None
    if store is not None:
        fp = {
            "model": model.name,
            "model_version": str(model.version),
            "model_settings": model.settings(),
            "design_sha256": design_digest(params),
            "n_samples": n,
            "t": None if t_arr is None else array_digest(t_arr),
            "outputs": outputs,
            "options": options,
            "chunk_size": chunk_size,
            **dict(fingerprint or {}),
        }
        chunk_store = ChunkStore(store, fp)
        for i in chunk_store.stored_chunks():
            if i < len(bounds):
                ds = chunk_store.load(i)
                if ds is not None and ds.sizes.get("sample") == bounds[i][1] - bounds[i][0]:
                    chunks[i] = ds
    todo = [(i, {k: a[s:e] for k, a in params.items()})
            for i, (s, e) in enumerate(bounds) if i not in chunks]

    # Models whose evaluation already uses every core (compiled kernels running sample blocks
    # in threads) gain nothing from worker processes and would pay their start-up and compile
    # cost: they run serially unless an executor is asked for.
    internally_parallel = bool(getattr(model, "internally_parallel", False))
    if not todo or (executor is None and (len(todo) == 1 or internally_parallel)):
        runner: Runner = SerialRunner()
    else:
        runner = resolve_executor(executor, n_workers)
    errors: list[dict[str, Any]] = []
    done_samples = sum(bounds[i][1] - bounds[i][0] for i in chunks)
    bar = _progress_bar(progress, n, done_samples, desc=model.name) if todo else None
    finished = False
    try:
        for i, result in runner.run(model, todo, t_arr, outputs, options):
            s, e = bounds[i]
            if result[0] == "ok":
                ds = result[1]
                if ds.sizes.get("sample") != e - s:
                    result = ("error", f"model returned {ds.sizes.get('sample')} samples for a "
                              f"chunk of {e - s}", "")
            if result[0] == "ok":
                ds = ds.assign_coords(sample=np.arange(s, e))
                chunks[i] = ds
                if chunk_store is not None:
                    chunk_store.write(i, ds)
            else:
                errors.append({"chunk": i, "start": s, "stop": e, "error": result[1],
                               "traceback": result[2][-4000:]})
            if bar is not None:
                bar.update(e - s)
        finished = True
    finally:
        if bar is not None:
            bar.close()
        if runner is not executor:
            runner.close(abort=not finished)

    if errors:
        errors.sort(key=lambda r: r["chunk"])
        if not chunks:
            raise RuntimeError(
                f"model {model.name!r}: every chunk failed ({len(errors)} of {len(bounds)}); "
                f"first error: {errors[0]['error']}\n{errors[0]['traceback']}"
            )
        template = chunks[min(chunks)]
        for err in errors:
            i, s, e = err["chunk"], err["start"], err["stop"]
            inputs = _chunk_inputs(model, {k: a[s:e] for k, a in params.items()})
            chunks[i] = _failed_from_template(template, inputs, s, e)
        n_bad = sum(e["stop"] - e["start"] for e in errors)
        warnings.warn(
            f"model {model.name!r}: {len(errors)} of {len(bounds)} chunk(s) raised; their "
            f"{n_bad} sample(s) have status {STATUS_MODEL_ERROR} (model_error) and NaN outputs. "
            f"First error (samples {errors[0]['start']}..{errors[0]['stop'] - 1}): "
            f"{errors[0]['error']}",
            RuntimeWarning,
            stacklevel=2,
        )

    parts = [chunks[i] for i in range(len(bounds))]
    if len(parts) == 1:
        result_ds = parts[0]
    else:
        result_ds = xr.concat(parts, dim="sample", data_vars="minimal", coords="minimal",
                              compat="override", join="exact", combine_attrs="override")
    result_ds.attrs = dict(parts[0].attrs)
    result_ds.attrs.pop("errors", None)
    result_ds.attrs.update({
        "executor": runner.name,
        "chunk_size": chunk_size,
        "n_chunks": len(bounds),
        "n_failed": int(np.count_nonzero(result_ds["status"].values)),
    })
    if errors:
        result_ds.attrs["errors"] = json.dumps(errors)
    return result_ds
