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
cache); its test files are one xdist group (``--dist loadgroup`` in pyproject's addopts;
:data:`COMPILE_GROUPS`), so one worker compiles them while the other runs other tests, instead
of both compiling the same kernels at once. For the same reason each worker starts by making
the first call of its share of the models (:data:`WARM_UP_CPU`, split greedily by compile
cost), so that from an empty cache the two workers compile different kernels side by side;
with a filled cache this loads them (about a second).

The suite's processes write bytecode (``.pyc`` files, and pytest's rewritten test modules)
even where the environment sets ``PYTHONDONTWRITEBYTECODE``: without them every process
compiles the source of every module it imports, about 10 s of CPU for gearuq's stack and as
much again for the test modules, and the two workers did it twice over. The odd worker
imports the libraries only the tests use before its warm-up, so the even one, busy compiling
kernels meanwhile, loads them compiled when it collects. From a fresh clone this took the
suite from 139-142 to 101-127 s of wall (docs/benchmarks.md, "First minutes, twelfth round").
``GEARUQ_TEST_BYTECODE=0`` keeps the environment's setting.
"""

from __future__ import annotations

import os
import sys
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

# Interpreted first calls (gearuq._firstcall) are counted in a ledger across processes; the
# suite keeps its own, so that its runs neither read nor fill the user's.
if "GEARUQ_FIRSTCALL_LEDGER" not in os.environ:
    import tempfile

    os.environ["GEARUQ_FIRSTCALL_LEDGER"] = os.path.join(
        tempfile.mkdtemp(prefix="gearuq-ledger-"), "gearuq_firstcall.json")


if os.environ.get("GEARUQ_TEST_BYTECODE", "1") != "0":
    sys.dont_write_bytecode = False


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
COMPILE_GROUPS = {"test_mesh_oscillator": "mesh_oscillator",
                  # compares the mesh oscillator's compiled continuation with its Python twin
                  "test_firstcall": "mesh_oscillator",
                  # hunting-tooth stages: the long period's LTCA and sideband kernels (about
                  # 10 s of CPU from an empty cache), which both workers compiled at once
                  "test_hunting": "hunting"}


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    # first: pytest-xdist's own hook reads the xdist_group marks to name each test's group
    # (a suffix of its id); run after it, the marks added here were ignored and the group's
    # files ran on both workers
    for item in items:
        for prefix, group in COMPILE_GROUPS.items():
            if item.path.name.startswith(prefix):
                item.add_marker(pytest.mark.xdist_group(group))


#: CPU seconds of each model's first call from an empty numba cache (``gearuq bench startup``,
#: docs/benchmarks.md; the mesh oscillator's after its kernels took one signature each): the
#: weights of the warm-up split between workers. The split is {mesh_oscillator,
#: linear_oscillator} against the rest, 34.6 against at most 42.9 s (less: the geared rotor
#: and the mesh excitation share the tooth-contact kernels, compiled once on that worker).
WARM_UP_CPU = {"mesh_oscillator": 32.6, "geared_rotor": 15.3, "helical_pair": 14.2,
               "mesh_excitation": 13.4, "linear_oscillator": 2.0}


def warm_up_share(worker: int, n_workers: int) -> list[str]:
    """The models worker ``worker`` of ``n_workers`` warms up: greedy longest-first split."""
    loads = [0.0] * n_workers
    shares: list[list[str]] = [[] for _ in range(n_workers)]
    for name, cost in sorted(WARM_UP_CPU.items(), key=lambda kv: -kv[1]):
        k = loads.index(min(loads))
        loads[k] += cost
        shares[k].append(name)
    return shares[worker]


def pytest_sessionstart(session: pytest.Session) -> None:
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    n_workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if not worker.startswith("gw") or n_workers < 2:
        return

    import numpy as np

    import gearuq
    from gearuq._firstcall import kernels_route
    from gearuq.bench.core import MODEL_FIRST_CALLS

    if int(worker[2:]) % 2:
        # the libraries only the tests use, before the warm-up: with bytecode written, the
        # other worker finds them compiled when it collects (measured: before gearuq's
        # imports instead, the suite took 20-30 s longer)
        import importlib

        for module in ("chaospy", "hypothesis", "matplotlib.pyplot", "netCDF4", "openturns"):
            try:
                importlib.import_module(module)
            except ImportError:  # an optional library: the tests that need it skip
                pass

    for name in warm_up_share(int(worker[2:]), n_workers):
        spec = MODEL_FIRST_CALLS[name]
        t = None if spec["t"] is None else np.linspace(*spec["t"][:2], int(spec["t"][2]))
        try:
            # compiled: a small first call would otherwise run interpreted and compile nothing
            with kernels_route("compiled"):
                gearuq.get_model(name).response({}, t, outputs=spec["outputs"])
        except Exception as err:  # the model's own tests report it; the warm-up only times
            print(f"conftest warm-up of {name} failed: {err!r}", file=sys.stderr)


@pytest.fixture
def separating_long_period():
    """A long-period problem whose teeth separate: ``(problem, speeds)``.

    A synthetic 7/11 pattern over 77 mesh cycles on Yuan, Liu and Liu's rotor (GMRES route),
    losing contact over up to 36 % of the long period on the 12 speeds of 3000-5200 rpm (at
    3400 rpm Newton's method stagnates). Built fresh for each test (its solver keeps state).
    """
    import numpy as np

    from gearuq.rotor.examples import seed002_rotor
    from gearuq.rotor.excitation import MeshExcitation
    from gearuq_plugins.geared_rotor.long_period import LongPeriodProblem

    L = 77
    exc = MeshExcitation.synthetic(
        6e8, 1.5e4, n_cycles=L, positions_per_cycle=12,
        stiffness_harmonics={L: 0.15, 2 * L: 0.05j},
        error_harmonics={7: 3e-6, 11: 2e-6j, L: 12e-6, L - 7: 3e-6, L + 11: 2e-6},
        mean_error=1e-6)
    problem = LongPeriodProblem(lambda k: seed002_rotor(k), exc, pinion_teeth=30,
                                mesh_harmonics=3)
    return problem, np.linspace(3000.0, 5200.0, 12)
