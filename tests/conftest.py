"""Suite-wide test hooks.

``GEARUQ_TEST_CPU_LOG=FILE`` appends one line per test to ``FILE``: the test id, its outcome and
the CPU seconds it used (set-up, call and tear-down; this process and the children it waited
for). On a shared machine wall time says little; these CPU seconds are what
``--durations`` cannot give, and what the suite's time budget is planned with
(docs/benchmarks.md, "test suite").

The suite runs on several processes (pytest-xdist, README command 2) that share numba's
on-disk cache. numba writes each file atomically, but a new entry is a read-modify-write of the
function's index: two workers saving different signatures of one function at once can both
pick the same data file, and the index then names a file holding the other signature's code
(numba issue 10128). Each save here holds an exclusive lock on a file beside the index, so
concurrent saves happen one after the other; loads need no lock (a half-saved entry is a cache
miss, which compiles).

The mesh oscillator's kernels take the longest to compile (about 40 s of CPU from an empty
cache); its test files are one xdist group (``--dist loadgroup`` in pyproject's addopts), so
one worker compiles them while the other runs other tests, instead of both compiling the same
kernels at once.
"""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest


def _serialise_numba_cache_saves() -> None:
    try:
        import fcntl

        from numba.core import caching
    except ImportError:  # no fcntl (Windows) or no numba: nothing to share
        return
    save = caching.IndexDataCacheFile.save
    if getattr(save, "serialised", False):
        return

    def locked_save(self: caching.IndexDataCacheFile, key: object, data: object) -> None:
        os.makedirs(self._cache_path, exist_ok=True)
        with open(self._index_path + ".lock", "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            try:
                save(self, key, data)
            finally:
                fcntl.flock(lock, fcntl.LOCK_UN)

    locked_save.serialised = True  # type: ignore[attr-defined]
    caching.IndexDataCacheFile.save = locked_save  # type: ignore[method-assign]


_serialise_numba_cache_saves()


def _cpu_seconds() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None) -> Iterator[None]:
    log = os.environ.get("GEARUQ_TEST_CPU_LOG")
    if not log:
        yield
        return
    start = _cpu_seconds()
    yield
    used = _cpu_seconds() - start
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    with open(log, "a", encoding="utf-8") as f:
        f.write(f"{used:.3f}\t{worker}\t{item.nodeid}\n")


#: Test files (name prefixes) run on one worker each under ``-n``: they share kernels that are
#: slow to compile.
COMPILE_GROUPS = {"test_mesh_oscillator": "mesh_oscillator"}


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        for prefix, group in COMPILE_GROUPS.items():
            if item.path.name.startswith(prefix):
                item.add_marker(pytest.mark.xdist_group(group))
