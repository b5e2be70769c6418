"""Executors: where chunk tasks run (in-process, local processes, dask.distributed).

Executors (:func:`resolve_executor`)
------------------------------------
``"serial"``
    In the calling process, chunk after chunk.
``"processes"``
    A :class:`concurrent.futures.ProcessPoolExecutor` with the ``"spawn"`` start method
    (safe with threads, identical on Linux, macOS and Windows). The model is serialised once
    with cloudpickle (so models built from lambdas or closures work) and rebuilt in each
    worker; the classes it uses must be importable there. As with every spawn-based pool, a
    script that starts a run at import time needs an ``if __name__ == "__main__":`` guard:
    asking for processes from unguarded script code is refused with that advice, and the
    automatic choice never picks processes there.
``"dask"`` / a ``distributed.Client`` / a scheduler address ``"tcp://host:port"``
    dask.distributed: the model is scattered once to every worker, chunks are submitted as
    tasks (workers write their own chunks when a store is used). An address creates a client
    that is closed afterwards; a given client is left open.
any :class:`concurrent.futures.Executor`
    Used as is (left open).
``None``
    Chosen by the driver (:func:`gearuq.execution.evaluate_chunks`) from a timed first chunk.
"""

from __future__ import annotations

import ast
import concurrent.futures as cf
import hashlib
import multiprocessing
import os
import pickle
import sys
import threading
import traceback
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from gearuq.execution import lifeline
from gearuq.execution.tasks import ChunkResult, run_chunk
from gearuq.model import Model, Request

__all__ = [
    "Task",
    "ExecutorFailure",
    "Runner",
    "SerialRunner",
    "ProcessRunner",
    "FuturesRunner",
    "DaskRunner",
    "resolve_executor",
    "main_is_guarded",
    "workers_for_run",
]


@dataclass
class Task:
    """One chunk to evaluate: its number, first global sample and parameter slices."""

    index: int
    start: int
    params: dict[str, np.ndarray]

    @property
    def size(self) -> int:
        """Samples in the chunk."""
        return len(next(iter(self.params.values())))


@dataclass
class ExecutorFailure:
    """A chunk the executor could not run (crashed worker, lost dask worker, pickling)."""

    message: str
    traceback: str = ""


Outcome = ChunkResult | ExecutorFailure


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


def _payload_task(key: str, payload: bytes, task: Task, request: Request,
                  store_path: str | None) -> Outcome:
    """Worker side: rebuild the model once per worker process (cached by digest), run."""
    model = _WORKER_MODELS.get(key)
    if model is None:
        try:
            model = pickle.loads(payload)
        except Exception as exc:  # noqa: BLE001 - reported as an executor failure
            return ExecutorFailure(f"cannot unpickle the model in the worker: "
                                   f"{type(exc).__name__}: {exc}", traceback.format_exc(limit=8))
        _WORKER_MODELS.clear()
        _WORKER_MODELS[key] = model
    return run_chunk(model, task.params, request, task.index, task.start, store_path)


def _future_outcome(fut: Any) -> Outcome:
    """Outcome of a chunk future; an executor-level exception becomes an ExecutorFailure."""
    try:
        return fut.result()
    except Exception as exc:  # noqa: BLE001 - e.g. BrokenProcessPool, KilledWorker
        return ExecutorFailure(f"executor failure: {type(exc).__name__}: {exc}",
                               "".join(traceback.format_exception(exc, limit=5)))


def _run_on(executor: cf.Executor, name: str, model: Model, tasks: list[Task],
            request: Request, store_path: str | None) -> Iterator[tuple[Task, Outcome]]:
    """Submit every task to a concurrent.futures executor with the pickled model; yield
    ``(task, outcome)`` as they complete; cancel what is left if the caller stops early."""
    payload = _serialise_model(model, name)
    key = hashlib.sha256(payload).hexdigest()
    futures = {executor.submit(_payload_task, key, payload, t, request, store_path): t
               for t in tasks}
    try:
        for fut in cf.as_completed(futures):
            yield futures[fut], _future_outcome(fut)
    finally:
        for fut in futures:
            fut.cancel()


# =========================================================================== runners
class Runner:
    """Runs chunk tasks; yields ``(task, outcome)`` as they complete."""

    name = "runner"
    n_workers = 1
    #: CPU seconds that runs through this runner spent in other processes than the caller
    #: (added by :func:`gearuq.execution.evaluate_chunks`): a study that keeps one pool for
    #: all its stages reads its workers' CPU here
    worker_cpu_seconds = 0.0

    def run(self, model: Model, tasks: list[Task], request: Request,
            store_path: str | None = None) -> Iterator[tuple[Task, Outcome]]:
        """Evaluate ``tasks``; yield ``(task, outcome)`` in completion order."""
        raise NotImplementedError

    def close(self, abort: bool = False) -> None:
        """Release resources this runner owns (``abort``: the run was interrupted)."""

    def __enter__(self) -> Runner:
        return self

    def __exit__(self, exc_type: Any, *exc: Any) -> None:
        # an interrupted block terminates running workers: nothing is left behind
        self.close(abort=exc_type is not None)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(n_workers={self.n_workers})"


class SerialRunner(Runner):
    """Evaluate chunks one after the other in the calling process."""

    name = "serial"

    def run(self, model, tasks, request, store_path=None):
        for task in tasks:
            yield task, run_chunk(model, task.params, request, task.index, task.start,
                                  store_path)


class ProcessRunner(Runner):
    """Local process pool (``spawn`` start method).

    The pool starts on first use and lives until :meth:`close`, so a runner passed as
    ``executor=`` to several runs pays the worker start-up (about a second or two: each
    spawned worker imports numpy, xarray and the caller's main module) only once::

        with ProcessRunner(4) as runner:
            a = monte_carlo(model, space, n_samples=10_000, rng=1, executor=runner)
            b = monte_carlo(model, space, n_samples=10_000, rng=2, executor=runner)

    A worker that dies (segfault, out-of-memory kill) breaks the pool: the chunks that had
    not finished come back as :class:`ExecutorFailure` and the next :meth:`run` starts a
    fresh pool (the driver retries them, then isolates the culprit). Conversely, workers end
    within a fraction of a second when the calling process dies, and never write a chunk
    after it is gone (:mod:`gearuq.execution.lifeline`).

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
            # the parent-death signal follows the thread that starts a worker: use it only
            # when that is the main thread (workers are started by the submitting thread)
            main = threading.current_thread() is threading.main_thread()
            parent = None if self.mp_context == "forkserver" else os.getpid()
            self._pool = cf.ProcessPoolExecutor(
                max_workers=self.n_workers,
                mp_context=multiprocessing.get_context(self.mp_context),
                initializer=lifeline.install, initargs=(parent, main),
            )
        return self._pool

    def run(self, model, tasks, request, store_path=None):
        if self.mp_context == "spawn":
            check_main_guard("processes")
        try:
            yield from _run_on(self._get_pool(), self.name, model, tasks, request, store_path)
        finally:
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

    def run(self, model, tasks, request, store_path=None):
        yield from _run_on(self.executor, self.name, model, tasks, request, store_path)


class DaskRunner(Runner):
    """dask.distributed client; the model is scattered once to all workers.

    With a store, each worker writes its own chunk files (the store directory must be on a
    file system the workers share with the caller) and sends back only a small summary.

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

    def run(self, model, tasks, request, store_path=None):
        from distributed import as_completed

        _serialise_model(model, self.name)  # fail early with a clear message
        model_future = self.client.scatter(model, broadcast=True, hash=False)
        futures = {
            self.client.submit(run_chunk, model_future, t.params, request, t.index, t.start,
                               store_path, pure=False): t
            for t in tasks
        }
        try:
            for fut in as_completed(list(futures)):
                yield futures[fut], _future_outcome(fut)
        finally:
            self.client.cancel(list(futures) + [model_future])

    def close(self, abort: bool = False) -> None:
        if self.owns:
            self.client.close()


# =========================================================================== lasting workers
_PROCESS_NAMES = ("processes", "process", "local")


@contextmanager
def workers_for_run(executor: Any) -> Iterator[Any]:
    """``executor`` for a method that evaluates the model many times (one call per step).

    ``"processes"`` becomes one :class:`ProcessRunner` for the whole method, so its steps
    (levels, batches, probes) reuse the same workers instead of starting new ones at each
    step (each costs seconds of imports and compiled kernels); anything else is passed
    through unchanged. A study that chains several methods keeps its workers for all of them
    the same way: ``with ProcessRunner() as pool:`` and ``executor=pool`` for each call (a
    given runner, pool or client is left open by the calls).
    """
    if isinstance(executor, str) and executor.strip().lower() in _PROCESS_NAMES:
        with ProcessRunner() as pool:
            yield pool
    else:
        yield executor


# =========================================================================== main guard
def _guard_lines(source: str) -> list[tuple[int, int]]:
    """Line ranges of ``if __name__ == "__main__":`` blocks at module level."""
    spans = []
    for node in ast.parse(source).body:
        if isinstance(node, ast.If) and isinstance(node.test, ast.Compare):
            names = {getattr(n, "id", None) for n in ast.walk(node.test)}
            consts = {getattr(n, "value", None) for n in ast.walk(node.test)}
            if "__name__" in names and "__main__" in consts:
                spans.append((node.lineno, node.end_lineno or node.lineno))
    return spans


def main_is_guarded() -> bool:
    """Whether spawned workers can safely re-import the calling script.

    ``False`` only when the call comes from module-level code of a ``__main__`` script file
    outside an ``if __name__ == "__main__":`` block (workers would re-run that code). An
    interactive session, ``python -c``, a test runner or a call inside the guard is safe.
    """
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or not path:
        return True
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_globals is main.__dict__ and frame.f_code.co_name == "<module>":
            try:
                with open(path, encoding="utf-8") as fh:
                    spans = _guard_lines(fh.read())
            except (OSError, SyntaxError, ValueError):
                return True  # cannot tell: do not block
            return any(a <= frame.f_lineno <= b for a, b in spans)
        frame = frame.f_back
    return True


def check_main_guard(executor_name: str) -> None:
    """Refuse spawned worker processes from unguarded script code, with the fix."""
    if not main_is_guarded():
        raise ValueError(
            f"executor={executor_name!r}: worker processes are started with 'spawn' and "
            "re-import the calling script, which would run this call again; put the script's "
            "code under `if __name__ == \"__main__\":`, or use executor='serial' (or None, "
            "which picks serial here)")


# =========================================================================== resolution
def resolve_executor(executor: Any = None, n_workers: int | None = None) -> Runner:
    """Turn an executor specification into a :class:`Runner`.

    Parameters
    ----------
    executor : None, str, distributed.Client, concurrent.futures.Executor or Runner
        ``None`` or ``"serial"`` (in-process), ``"processes"``, ``"dask"`` (current default
        dask client), a dask scheduler address such as ``"tcp://127.0.0.1:8786"``, a
        ``distributed.Client``, any ``concurrent.futures.Executor``, or a ready
        :class:`Runner`. (The automatic choice for ``None`` is made by
        :func:`gearuq.execution.evaluate_chunks`, which times a first chunk.)
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
        return SerialRunner()
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

            try:
                client = Client(executor)
            except OSError as exc:  # refused, unreachable or silent past dask's timeout
                raise ValueError(f"executor={executor!r}: no dask scheduler answered there "
                                 f"({exc}); start one (`dask scheduler`) or choose 'serial' "
                                 "or 'processes'") from exc
            return DaskRunner(client, owns=True)
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
