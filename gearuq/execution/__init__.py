"""Chunked, resumable, failure-isolating model evaluation on serial, process or dask executors.

Modules: :mod:`~gearuq.execution.driver` (:func:`evaluate_chunks`),
:mod:`~gearuq.execution.runners` (executors), :mod:`~gearuq.execution.tasks` (the chunk task
with failure isolation), :mod:`~gearuq.execution.store` (durable chunk stores),
:mod:`~gearuq.execution.fingerprint` (code-aware fingerprints).
"""

from gearuq.execution.driver import (
    AllSamplesFailedError,
    available_memory,
    chunk_bounds,
    default_chunk_size,
    design_digest,
    estimate_bytes_per_sample,
    evaluate_chunks,
)
from gearuq.execution.fingerprint import function_digest, model_fingerprint
from gearuq.execution.runners import (
    DaskRunner,
    ExecutorFailure,
    FuturesRunner,
    ProcessRunner,
    Runner,
    SerialRunner,
    Task,
    main_is_guarded,
    resolve_executor,
    workers_for_run,
)
from gearuq.execution.store import (
    ChunkStore,
    IntegrityError,
    StoreLockedError,
    StoreMismatchError,
)

__all__ = [
    "evaluate_chunks",
    "default_chunk_size",
    "chunk_bounds",
    "estimate_bytes_per_sample",
    "available_memory",
    "design_digest",
    "model_fingerprint",
    "function_digest",
    "Runner",
    "SerialRunner",
    "ProcessRunner",
    "FuturesRunner",
    "DaskRunner",
    "Task",
    "ExecutorFailure",
    "resolve_executor",
    "main_is_guarded",
    "workers_for_run",
    "ChunkStore",
    "StoreMismatchError",
    "StoreLockedError",
    "IntegrityError",
    "AllSamplesFailedError",
]
