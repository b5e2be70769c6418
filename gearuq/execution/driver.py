"""The driver: evaluate a design chunk by chunk, never losing, mixing or hoarding results.

:func:`evaluate_chunks` cuts a design (drawn once, up front, by the caller) into contiguous
chunks of samples and evaluates each with ``model.evaluate(params, request)`` through an
executor. Because every chunk is a slice of the same design, the result is bit-identical for
any chunk size and any executor, provided the model treats its samples independently.

* **Failures stay where they are.** A chunk that raises is bisected until only the samples
  that really fail carry status 4 (``model_error``), each with its exception in the
  ``failures`` attribute. A chunk whose worker dies (segfault, out-of-memory kill, lost dask
  worker) is retried once; if it fails again its samples are bisected through the executor,
  so a sample that kills its worker is flagged alone.
* **Memory stays bounded.** Without a store, the result arrays are allocated once and filled
  chunk by chunk (no concatenation copy); a run estimated not to fit in memory is refused
  before it starts, naming ``store=``. With a store, chunks are written by whoever computed
  them (worker processes write their own files) and the result is a lazily loaded Dataset
  over the stored chunks.
* **Stores are safe.** See :mod:`gearuq.execution.store` (lock, code-aware fingerprint,
  checksums).
"""

from __future__ import annotations

import errno
import json
import math
import os
import sys
import time
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from gearuq.execution.fingerprint import model_fingerprint
from gearuq.execution.runners import (
    ExecutorFailure,
    ProcessRunner,
    Runner,
    SerialRunner,
    Task,
    main_is_guarded,
    resolve_executor,
)
from gearuq.execution.store import ChunkStore, write_chunk
from gearuq.execution.tasks import ChunkResult, failed_like, group_failures, inputs_of
from gearuq.io import netcdf_lock
from gearuq.model import STATUS_MODEL_ERROR, Model, Request

__all__ = ["evaluate_chunks", "AllSamplesFailedError", "default_chunk_size", "chunk_bounds",
           "estimate_bytes_per_sample", "available_memory", "design_digest"]

#: Largest default chunk (samples).
MAX_DEFAULT_CHUNK = 10_000
#: Largest default chunk (bytes of result), so a few chunks in flight stay small.
MAX_CHUNK_BYTES = 64 * 2**20
#: Assumed start-up cost of a pool of spawned worker processes (import numpy, xarray,
#: the model's module, unpickle the model), used by the automatic executor choice.
PROCESS_STARTUP_S = 3.0
#: Results above this size are announced before the run.
ANNOUNCE_BYTES = 512 * 2**20


class AllSamplesFailedError(RuntimeError):
    """Every sample of a design failed: nothing to return.

    Attributes
    ----------
    n_evaluations : int
        Samples passed to the model before giving up, re-runs of bisected chunks included,
        so a caller can still count what the attempt cost.
    """

    def __init__(self, message: str, n_evaluations: int) -> None:
        super().__init__(message)
        self.n_evaluations = int(n_evaluations)


# =========================================================================== sizes
def estimate_bytes_per_sample(model: Model, request: Request, n_inputs: int | None = None) -> int:
    """Bytes one sample of the result takes (float64 outputs; extra dims other than time
    are unknown before a first chunk and counted once)."""
    n_t = 0 if request.t is None else int(request.t.size)
    total = 8 * (n_inputs if n_inputs is not None else len(model.parameters)) + 16
    for name in request.outputs:
        size = 1
        for dim in model.output(name).dims[1:]:
            size *= n_t if dim == "time" else 1
        total += 8 * size
    return int(total)


def default_chunk_size(n_samples: int, bytes_per_sample: int | None = None) -> int:
    """Default chunk size: about 32 chunks, at least 64 samples, at most 10 000 samples
    and at most :data:`MAX_CHUNK_BYTES` of result.

    It depends on the call only (not on the executor), so a stored run can be resumed with a
    different executor.
    """
    c = max(math.ceil(n_samples / 32), min(n_samples, 64))
    c = min(c, MAX_DEFAULT_CHUNK)
    if bytes_per_sample:
        c = min(c, max(1, MAX_CHUNK_BYTES // int(bytes_per_sample)))
    return int(max(1, c))


def chunk_bounds(n_samples: int, chunk_size: int) -> list[tuple[int, int]]:
    """``[(start, stop), ...]`` of consecutive chunks covering ``range(n_samples)``."""
    return [(s, min(s + chunk_size, n_samples)) for s in range(0, n_samples, chunk_size)]


def _check_chunk_size(chunk_size: Any, n: int, bytes_per_sample: int) -> int:
    if chunk_size is None:
        return default_chunk_size(n, bytes_per_sample)
    if isinstance(chunk_size, (bool, np.bool_)) or not isinstance(chunk_size, (int, np.integer)):
        raise ValueError(f"chunk_size: expected a positive integer, got {chunk_size!r}")
    if chunk_size <= 0:
        raise ValueError(f"chunk_size: must be positive, got {chunk_size}")
    return int(min(chunk_size, n))


def available_memory() -> int:
    """Bytes of memory available to a new allocation (MemAvailable on Linux)."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return 8 * 2**30


def _fmt_bytes(b: float) -> str:
    for unit in ("B", "KB", "MB", "GB", "TB"):
        if b < 1024 or unit == "TB":
            return f"{b:.1f} {unit}" if unit != "B" else f"{int(b)} B"
        b /= 1024
    return f"{b:.1f} TB"  # pragma: no cover


def design_digest(design: Mapping[str, np.ndarray]) -> str:
    """SHA-256 over the parameter names and values of a design."""
    import hashlib

    h = hashlib.sha256()
    for k in sorted(design):
        h.update(k.encode())
        h.update(np.ascontiguousarray(np.asarray(design[k], dtype=float)).tobytes())
    return h.hexdigest()


def _check_memory_limit(memory_limit: Any) -> float:
    """``memory_limit`` as bytes (default: 60 % of the available memory), validated."""
    if memory_limit is None:
        return 0.6 * available_memory()
    if isinstance(memory_limit, (bool, np.bool_, str, bytes)):
        limit = math.nan
    else:
        try:
            limit = float(memory_limit)
        except (TypeError, ValueError):
            limit = math.nan
    if not limit > 0:  # also rejects NaN
        raise ValueError(
            f"memory_limit: {memory_limit!r} is not valid; give the bytes a result held in "
            "memory may take, a number > 0 (inf: no limit), or None for 60 % of the "
            "available memory")
    return limit


def _check_memory(n: int, bps: int, limit: float, store: Any, measured: bool) -> None:
    if store is not None:
        return
    need = n * bps
    what = "measured on the first chunk" if measured else "estimated"
    if need > limit:
        raise MemoryError(
            f"the result of {n} samples needs about {_fmt_bytes(need)} ({what}), more than "
            f"the memory limit {_fmt_bytes(limit)}; pass store=DIR to stream chunks to disk "
            "(the result is then loaded lazily), ask for fewer outputs or instants, or raise "
            "memory_limit")
    if need > ANNOUNCE_BYTES and not measured:
        print(f"gearuq: the result will take about {_fmt_bytes(need)} in memory "
              f"({n} samples x {_fmt_bytes(bps)}); store=DIR streams it to disk instead",
              file=sys.stderr)


# =========================================================================== assembly
class _Accumulator:
    """Result arrays allocated once from the first chunk and filled in place."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.template: xr.Dataset | None = None
        self.arrays: dict[str, np.ndarray] = {}

    def add(self, start: int, ds: xr.Dataset) -> None:
        if self.template is None:
            self.template = ds.isel(sample=slice(0, 1)).copy(deep=True)
            for name, var in ds.variables.items():
                if "sample" in var.dims and name != "sample":
                    if var.dims[0] != "sample":
                        raise ValueError(f"variable {name!r}: 'sample' must be its first dim")
                    self.arrays[name] = np.empty((self.n, *var.shape[1:]), dtype=var.dtype)
        stop = start + ds.sizes["sample"]
        for name, arr in self.arrays.items():
            arr[start:stop] = ds[name].values

    def build(self) -> xr.Dataset:
        t = self.template
        assert t is not None
        coords = {}
        for name, var in t.coords.items():
            if name == "sample":
                coords[name] = ("sample", np.arange(self.n), var.attrs)
            elif "sample" in var.dims:
                coords[name] = (var.dims, self.arrays[name], var.attrs)
            else:
                coords[name] = var
        data = {}
        for name, var in t.data_vars.items():
            data[name] = (var.dims, self.arrays[name], var.attrs) if "sample" in var.dims \
                else var
        ds = xr.Dataset(data, coords=coords, attrs=dict(t.attrs))
        return ds[list(t.data_vars)].assign_coords(ds.coords)


# =========================================================================== the driver
class _Run:
    """State of one evaluate_chunks call (kept off the function to keep it readable)."""

    def __init__(self, model: Model, request: Request, params: dict[str, np.ndarray],
                 bounds: list[tuple[int, int]], store: ChunkStore | None, bar: Any,
                 memory_limit: float, bps: int) -> None:
        self.model, self.request, self.params = model, request, params
        self.bounds, self.store, self.bar = bounds, store, bar
        self.memory_limit, self.bps = memory_limit, bps
        self.n = bounds[-1][1]
        self.acc = None if store is not None else _Accumulator(self.n)
        self.failures: list[dict[str, Any]] = []
        self.all_failed: dict[int, ChunkResult] = {}
        self.template: xr.Dataset | None = None
        self.measured = False
        # samples passed to the model: re-runs of bisected chunks and attempts whose worker
        # died count too, so the cost reported is the cost paid
        self.n_evaluations = 0
        self.cpu_seconds = 0.0  # CPU of every process that ran a chunk of this call
        self.worker_cpu_seconds = 0.0  # ... of those that were not this process

    def task(self, i: int) -> Task:
        s, e = self.bounds[i]
        return Task(i, s, {k: a[s:e] for k, a in self.params.items()})

    def accept(self, res: ChunkResult) -> None:
        """File a finished chunk: into the store or the accumulator."""
        self.failures.extend(res.failures)
        self.n_evaluations += res.n_evaluations
        self.cpu_seconds += res.cpu_seconds
        if res.pid and res.pid != os.getpid():
            self.worker_cpu_seconds += res.cpu_seconds
        if res.ds is None and not res.stored:
            self.all_failed[res.index] = res
        else:
            if not self.measured and res.n_bytes:
                self.measured = True
                bps = res.n_bytes / max(1, res.stop - res.start)
                _check_memory(self.n, int(bps), self.memory_limit,
                              self.store, measured=True)
            if res.ds is not None:
                if self.template is None:
                    self.template = res.ds.isel(sample=slice(0, 1)).copy(deep=True)
                if self.store is not None and not res.stored:
                    write_chunk(self.store.path, res.index, res.ds)
                elif self.acc is not None:
                    self.acc.add(res.start, res.ds)
            elif self.template is None and self.store is not None:
                self.template = self.store.load(res.index).isel(sample=slice(0, 1))
        if self.bar is not None:
            self.bar.update(res.stop - res.start)

    def isolate(self, runner: Runner, task: Task, failure: ExecutorFailure) -> ChunkResult:
        """Bisect a chunk whose worker keeps dying, one piece at a time through ``runner``."""
        pieces: list[ChunkResult] = []
        failed: list[dict[str, Any]] = []
        dead = [0]  # samples of attempts whose worker died (their evaluation was paid for)

        def go(t: Task, err: ExecutorFailure | None) -> None:
            if err is None:
                outcome = next(iter(runner.run(self.model, [t], self.request, None)))[1]
                if isinstance(outcome, ChunkResult):
                    pieces.append(outcome)
                    return
                err = outcome
                dead[0] += t.size
            if t.size == 1:
                failed.append({"sample": t.start, "error": err.message,
                               "traceback": err.traceback[-3000:]})
                return
            half = t.size // 2
            for lo, hi in ((0, half), (half, t.size)):
                go(Task(t.index, t.start + lo, {k: a[lo:hi] for k, a in t.params.items()}), None)

        go(task, failure)
        return self._merge(task, pieces, failed, dead[0])

    def _merge(self, task: Task, pieces: list[ChunkResult],
               failed: list[dict[str, Any]], n_dead: int = 0) -> ChunkResult:
        res = ChunkResult(task.index, task.start, task.start + task.size,
                          failures=failed + [f for p in pieces for f in p.failures],
                          n_evaluations=n_dead + sum(p.n_evaluations for p in pieces),
                          cpu_seconds=sum(p.cpu_seconds for p in pieces),
                          # -1: pieces ran in several processes (isolation runs in workers)
                          pid=pieces[0].pid if len({p.pid for p in pieces}) == 1 else -1)
        good = [p for p in pieces if p.ds is not None]
        if not good:
            return res
        template = good[0].ds
        parts = [(p.start, p.ds) for p in good]
        bad = sorted({f["sample"] for f in res.failures} - {
            int(s) for p in good for s in p.ds["sample"].values})
        for s in bad:
            i = s - task.start
            inputs = inputs_of(self.model, {k: a[i:i + 1] for k, a in task.params.items()})
            parts.append((s, failed_like(template, inputs).assign_coords(sample=[s])))
        parts.sort(key=lambda p: p[0])
        ds = xr.concat([p[1] for p in parts], dim="sample", data_vars="minimal",
                       coords="minimal", compat="override", join="override",
                       combine_attrs="override")
        res.ds = ds.assign_coords(sample=np.arange(res.start, res.stop))
        res.n_bytes = int(res.ds.nbytes)
        return res

    def fill_all_failed(self) -> None:
        """Template the chunks of which every sample failed from a successful chunk."""
        if not self.all_failed:
            return
        if self.template is None:
            first = self.failures[0] if self.failures else {"error": "?", "traceback": ""}
            raise AllSamplesFailedError(
                f"model {self.model.name!r}: every sample failed ({self.n}); first error: "
                f"{first['error']}\n{first.get('traceback', '')}", self.n_evaluations)
        for i, res in sorted(self.all_failed.items()):
            s, e = self.bounds[i]
            inputs = inputs_of(self.model, {k: a[s:e] for k, a in self.params.items()})
            ds = failed_like(self.template, inputs).assign_coords(sample=np.arange(s, e))
            ds.attrs["failures"] = group_failures(res.failures)
            if self.store is not None:
                write_chunk(self.store.path, i, ds)
            else:
                self.acc.add(s, ds)
        self.all_failed.clear()


def _choose_runner(executor: Any, n_workers: int | None, model: Model, run: _Run,
                   todo: list[int]) -> tuple[Runner, str, list[int]]:
    """The runner for the remaining chunks and why; may evaluate the first chunk to time it."""
    if executor is not None:
        runner = resolve_executor(executor, n_workers)
        return runner, "asked for", todo
    cpus = os.cpu_count() or 1
    if len(todo) <= 1:
        return SerialRunner(), "auto: one chunk to compute", todo
    if getattr(model, "internally_parallel", False):
        return SerialRunner(), "auto: the model already uses every core", todo
    if cpus < 2 and n_workers is None:
        return SerialRunner(), "auto: one CPU", todo
    if not main_is_guarded():
        return SerialRunner(), ("auto: serial, because the calling script has no "
                                "`if __name__ == \"__main__\":` guard (worker processes would "
                                "re-run it)"), todo
    first = todo[0]
    t0 = time.perf_counter()
    res = next(iter(SerialRunner().run(model, [run.task(first)], run.request,
                                       None if run.store is None else str(run.store.path))))[1]
    elapsed = time.perf_counter() - t0
    run.accept(res)
    rest = todo[1:]
    done_size = run.bounds[first][1] - run.bounds[first][0]
    rest_size = sum(run.bounds[i][1] - run.bounds[i][0] for i in rest)
    serial_estimate = elapsed * rest_size / max(1, done_size)
    workers = int(n_workers or cpus)
    parallel_estimate = PROCESS_STARTUP_S + serial_estimate / workers
    if parallel_estimate < 0.75 * serial_estimate:
        return ProcessRunner(workers), (
            f"auto: processes ({workers}), the rest would take about {serial_estimate:.1f} s "
            f"serially (first chunk {elapsed:.2f} s)"), rest
    return SerialRunner(), (
        f"auto: serial, the rest takes about {serial_estimate:.2f} s serially (first chunk "
        f"{elapsed:.3f} s), less than worker processes would cost to start"), rest


def _run_rounds(runner: Runner, run: _Run, todo: list[int]) -> None:
    """Evaluate ``todo``; retry executor failures once, then isolate them."""
    store_path = None if run.store is None else str(run.store.path)
    tasks = [run.task(i) for i in todo]
    for attempt in (1, 2):
        failed: list[tuple[Task, ExecutorFailure]] = []
        for task, outcome in runner.run(run.model, tasks, run.request, store_path):
            if isinstance(outcome, ExecutorFailure):
                failed.append((task, outcome))
                run.n_evaluations += task.size  # the dead worker was evaluating them
            else:
                run.accept(outcome)
        if not failed:
            return
        if attempt == 1:
            warnings.warn(
                f"model {run.model.name!r}: {len(failed)} chunk(s) failed in the executor "
                f"({failed[0][1].message}); retrying them once", RuntimeWarning, stacklevel=4)
            tasks = [t for t, _ in failed]
    for task, failure in failed:
        run.accept(run.isolate(runner, task, failure))


def evaluate_chunks(
    model: Model,
    design: Mapping[str, Any],
    request: Request,
    *,
    chunk_size: int | None = None,
    executor: Any = None,
    store: str | os.PathLike | None = None,
    progress: bool | None = None,
    n_workers: int | None = None,
    fingerprint: Mapping[str, Any] | None = None,
    memory_limit: float | None = None,
    wait: float = math.inf,
) -> xr.Dataset:
    """Evaluate ``model`` on a design, chunk by chunk, through an executor.

    Parameters
    ----------
    model : Model
        The model (must be picklable for process and dask executors).
    design : mapping
        Parameter name -> array ``(n,)``; drawn once by the caller. Parameters not given take
        the model's nominal values.
    request : Request
        From ``model.prepare(t, outputs=..., **options)``: outputs, instants and options,
        validated once.
    chunk_size : int, optional
        Samples per chunk (default :func:`default_chunk_size`, which also caps a chunk's
        result at 64 MB).
    executor : optional
        See :func:`gearuq.execution.resolve_executor`. ``None`` chooses: serial for a single
        chunk, a model that already uses every core, one CPU or a script without a
        ``__main__`` guard; otherwise the first chunk is timed in-process and worker
        processes are used only if they would pay for their start-up. The choice and its
        reason are recorded in ``attrs["executor"]`` / ``attrs["executor_reason"]``.
    store : path-like, optional
        Directory for a durable, resumable run (see :class:`gearuq.execution.ChunkStore`).
        The result is then a lazily loaded Dataset over the stored chunks and memory stays
        bounded whatever ``n``.
    progress : bool, optional
        ``True`` always shows a tqdm bar, ``False`` never; ``None`` shows it only once a run
        has lasted 2 s.
    n_workers : int, optional
        Worker processes for ``executor="processes"``.
    fingerprint : mapping, optional
        Extra provenance for the store manifest (the caller's engine, space, rule, seed...).
        The model's code fingerprint, the request, a digest of the design and the chunk size
        are always included.
    memory_limit : float, optional
        Bytes a result held in memory may take, > 0 (``inf``: no limit; default: 60 % of the
        available memory); larger runs without a store are refused before they start.
    wait : float
        Seconds to wait for a store that another run holds (default: as long as it takes).

    Returns
    -------
    xarray.Dataset
        All samples in order (coordinate ``0..n-1``). Attributes: the model's, plus
        ``executor``, ``executor_reason``, ``chunk_size``, ``n_chunks``, ``n_failed``
        (samples with nonzero status), ``n_model_errors``, ``n_evaluations`` (samples
        passed to the model in this call, every re-run of a bisected chunk and every attempt
        whose worker died included), ``cpu_seconds`` (CPU time of every process that ran a
        chunk of this call, workers included; ``worker_cpu_seconds`` the part spent in other
        processes than the caller), ``n_reused_samples`` (taken from a store, not
        run again), and, when samples raised,
        ``failures`` (JSON list of ``{"error", "samples", "traceback"}``), and
        ``store`` / ``reused_chunks`` for stored runs.

    Raises
    ------
    ValueError
        Bad design, chunk size or executor; :class:`StoreMismatchError` for a foreign store.
    MemoryError
        A result that would not fit in ``memory_limit`` without a store.
    OSError
        A chunk cannot be written (the message names the file; a full device says so), or
        a store that cannot be written lacks chunks.
    AllSamplesFailedError
        A RuntimeError: every sample failed (nothing to return; the message holds the first
        error, ``n_evaluations`` what the attempt cost).
    """
    params = {k: np.asarray(v, dtype=float) for k, v in design.items()}
    if not params:
        raise ValueError("design: empty; give at least one parameter array")
    shapes = {k: a.shape for k, a in params.items()}
    if any(a.ndim != 1 for a in params.values()) or len({a.shape[0] for a in params.values()}) != 1:
        raise ValueError(f"design: expected 1-D arrays of one common length, got shapes {shapes}")
    n = next(iter(params.values())).shape[0]
    if n == 0:
        raise ValueError("design: zero samples")
    if not isinstance(request, Request) or request.model != model.name:
        raise ValueError(f"request: expected a Request from {model.name!r}.prepare(...)")
    bps = estimate_bytes_per_sample(model, request)
    chunk_size = _check_chunk_size(chunk_size, n, bps)
    bounds = chunk_bounds(n, chunk_size)
    limit = _check_memory_limit(memory_limit)
    _check_memory(n, bps, limit, store, measured=False)

    chunk_store = None
    if store is not None:
        fp = {**model_fingerprint(model), **request.fingerprint(),
              "model": model.name, "design_sha256": design_digest(params), "n_samples": n,
              "chunk_size": chunk_size, **dict(fingerprint or {})}
        chunk_store = ChunkStore(store, fp, wait=wait)
    try:
        reused = [] if chunk_store is None else chunk_store.valid_chunks(
            {i: e - s for i, (s, e) in enumerate(bounds)})
        todo = [i for i in range(len(bounds)) if i not in set(reused)]
        if chunk_store is not None and chunk_store.read_only and todo:
            raise OSError(
                errno.EROFS,
                f"store {chunk_store.path} cannot be written ({chunk_store.read_only}) and "
                f"{len(todo)} of its {len(bounds)} chunks are missing or corrupt; copy it to "
                "writable storage to complete it, or use another store directory")
        done = sum(bounds[i][1] - bounds[i][0] for i in reused)
        bar = _progress_bar(progress, n, done, model.name) if todo else None
        run = _Run(model, request, params, bounds, chunk_store, bar, limit, bps)
        if chunk_store is not None and reused:
            run.template = chunk_store.load(reused[0]).isel(sample=slice(0, 1))
        runner, reason, todo = _choose_runner(executor, n_workers, model, run, todo)
        finished = False
        try:
            _run_rounds(runner, run, todo)
            run.fill_all_failed()
            finished = True
        finally:
            if bar is not None:
                bar.close()
            runner.worker_cpu_seconds += run.worker_cpu_seconds
            if runner is not executor:
                runner.close(abort=not finished)
        if chunk_store is not None:
            ds = chunk_store.open(list(range(len(bounds))))
        else:
            ds = run.acc.build()
    finally:
        if chunk_store is not None:
            chunk_store.close()
    return _finish(ds, run, runner, reason, chunk_size, bounds, chunk_store, reused)


def _finish(ds: xr.Dataset, run: _Run, runner: Runner, reason: str, chunk_size: int,
            bounds: list, store: ChunkStore | None, reused: list[int]) -> xr.Dataset:
    """Attributes of the assembled result; one warning for samples that raised."""
    status = np.asarray(ds["status"].values)
    ds.attrs.pop("failures", None)
    failures = list(run.failures)
    if store is not None:  # failures of reused chunks live in their files
        for i in reused:
            text = json.loads(_chunk_attr(store, i, "failures") or "[]")
            failures += [{"sample": s, "error": g["error"], "traceback": g["traceback"]}
                         for g in text for s in g["samples"]]
    ds.attrs.update({
        "executor": runner.name,
        "executor_reason": reason,
        "chunk_size": chunk_size,
        "n_chunks": len(bounds),
        "n_failed": int(np.count_nonzero(status)),
        "n_model_errors": int(np.count_nonzero(status == STATUS_MODEL_ERROR)),
        "n_evaluations": int(run.n_evaluations),
        "cpu_seconds": float(run.cpu_seconds),
        "worker_cpu_seconds": float(run.worker_cpu_seconds),
        "n_reused_samples": int(sum(bounds[i][1] - bounds[i][0] for i in reused)),
    })
    if store is not None:
        ds.attrs["store"] = str(store.path)
        ds.attrs["reused_chunks"] = len(reused)
    if failures:
        ds.attrs["failures"] = group_failures(failures)
        first = min(failures, key=lambda f: f["sample"])
        warnings.warn(
            f"model {run.model.name!r}: {len(failures)} sample(s) raised and have status "
            f"{STATUS_MODEL_ERROR} (model_error), the other {run.n - len(failures)} are "
            f"unaffected; first (sample {first['sample']}): {first['error']}",
            RuntimeWarning, stacklevel=3)
    return ds


def _chunk_attr(store: ChunkStore, index: int, name: str) -> str | None:
    import netCDF4

    with netcdf_lock(), netCDF4.Dataset(store.chunk_path(index)) as nc:
        return getattr(nc, name, None)


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
