"""Small first calls without compiling: a numba kernel run as plain Python while it pays.

A fresh install has no compiled kernels: the first call of a model compiles them (10-30 s of
CPU), even when the call asks for one sample that the same code, interpreted by Python, answers
in a fraction of a second. :class:`FirstCallRoute` chooses per call, the way one rents before
buying (the ski-rental rule, whose total cost is at most twice the better choice's): while the
kernel is neither compiled in this process nor in numba's on-disk cache, calls whose predicted
interpreted CPU fits into a per-process allowance run the kernel's own Python source
(:func:`interpreted`: the same functions with every kernel they call also interpreted); the
first call that would overrun the allowance compiles, and every later one runs compiled.
The interpreted route computes the same operations in the same order in IEEE double
precision, so its results agree with the compiled kernel's to rounding (the kernels' tests
compare the two); the cost is Python's speed, about 100 times slower per call, which is why the
allowance is small.

What a machine spends interpreting is also counted across processes, in a small ledger
beside numba's cache (``gearuq_firstcall.json`` in ``NUMBA_CACHE_DIR``, else in the user's
cache folder; ``GEARUQ_FIRSTCALL_LEDGER`` names another file): once the interpreted CPU of
all processes together would pass the compile's cost, the next call compiles, so that a
machine running many small first calls pays at most the compile twice, never forever.

The environment variable ``GEARUQ_KERNELS`` forces a route: ``compiled`` (always compile, as
before) or ``interpreted`` (never compile: for tests and debugging); unset or ``auto`` chooses
as above.
"""

from __future__ import annotations

import contextlib
import contextvars
import json
import os
import sys
import threading
import time
import types
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

#: Interpreted CPU seconds a process may spend on one kernel before the kernel is compiled.
DEFAULT_ALLOWANCE_CPU = 2.0
#: Predicted CPU seconds from which an interpreted call says so (a shorter one goes unnoticed,
#: and a notice for it would only be noise).
NOTICE_MIN_CPU = 0.2
_ROUTES = ("auto", "compiled", "interpreted")
_forced: contextvars.ContextVar[str | None] = contextvars.ContextVar("gearuq_kernels",
                                                                   default=None)


@contextlib.contextmanager
def kernels_route(route: str) -> Iterator[None]:
    """Force the route of every first call made inside the block (over ``GEARUQ_KERNELS``).

    A small first call of a model runs its uncompiled kernels as plain Python and compiles
    nothing (see :mod:`gearuq._firstcall`). A warm-up call before a timing, or before worker
    processes start, must compile instead, or the compile falls into the timed call or into
    every worker: make it inside ``kernels_route("compiled")``. The route holds in this thread
    (and the tasks it starts with a copy of its context), not in other processes; these load
    what the warm-up left in numba's on-disk cache.

    Parameters
    ----------
    route : {"compiled", "interpreted", "auto"}
        ``"compiled"`` for a warm-up or precompile step, ``"interpreted"`` for tests and
        debugging (never compile), ``"auto"`` for the default rule.

    Examples
    --------
    >>> import gearuq
    >>> with gearuq.kernels_route("compiled"):  # doctest: +SKIP
    ...     model.response(warm_up_sample, t)   # compiles (or loads) the kernels once
    """
    if route not in _ROUTES:
        raise ValueError(f"route={route!r} is not a route; valid: {', '.join(_ROUTES)}")
    token = _forced.set(route)
    try:
        yield
    finally:
        _forced.reset(token)


def ledger_path() -> Path:
    """The file that counts interpreted CPU seconds per kernel across processes."""
    named = os.environ.get("GEARUQ_FIRSTCALL_LEDGER")
    if named:
        return Path(named)
    base = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"),
        "gearuq")
    return Path(base) / "gearuq_firstcall.json"


def _read_ledger() -> dict[str, float]:
    try:
        data = json.loads(ledger_path().read_text(encoding="utf-8"))
        return {str(k): float(v) for k, v in data.items()}
    except (OSError, ValueError, AttributeError, TypeError):  # none yet, or unreadable
        return {}


def _charge_ledger(label: str, seconds: float) -> None:
    """Add ``seconds`` to ``label``'s count (atomic replace; a read-only folder is skipped:
    each process then keeps to its own allowance)."""
    path = ledger_path()
    data = _read_ledger()
    data[label] = data.get(label, 0.0) + seconds
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
        tmp.write_text(json.dumps(data), encoding="utf-8")
        os.replace(tmp, path)
    except OSError:
        pass


def _is_dispatcher(obj: Any) -> bool:
    return hasattr(obj, "py_func") and hasattr(obj, "overloads")


def interpreted(kernel: Any, overrides: dict[str, Callable] | None = None) -> Callable:
    """Plain-Python twin of a numba kernel: its ``py_func``, with every numba kernel it reaches
    through its module globals (and those kernels' callees, recursively) replaced by theirs.

    Parameters
    ----------
    kernel : numba dispatcher
        An ``@njit`` function.
    overrides : dict, optional
        Python functions to use instead of named kernels (by ``__name__``), e.g. a numpy
        version of an inner loop that is slow in Python.

    Returns
    -------
    callable
        The twin; floating-point warnings are silenced as in compiled code.
    """
    if not _is_dispatcher(kernel):
        raise TypeError(f"kernel: expected a numba @njit function, got {type(kernel).__name__}")
    overrides = dict(overrides or {})
    twins: dict[int, Callable] = {}
    spaces: dict[int, dict[str, Any]] = {}

    def twin(disp: Any) -> Callable:
        f = disp.py_func
        if id(f) in twins:
            return twins[id(f)]
        if f.__name__ in overrides:
            twins[id(f)] = overrides[f.__name__]
            return twins[id(f)]
        # one copy of each module's globals, shared by the twins of that module's kernels
        space = spaces.get(id(f.__globals__))
        fill = space is None
        if fill:
            space = spaces[id(f.__globals__)] = dict(f.__globals__)
        cells = None
        if f.__closure__:
            cells = tuple(types.CellType(twin(c.cell_contents)
                                         if _is_dispatcher(c.cell_contents)
                                         else c.cell_contents) for c in f.__closure__)
        new = types.FunctionType(f.__code__, space, f.__name__, f.__defaults__, cells)
        twins[id(f)] = new
        if fill:
            for name, value in list(space.items()):
                if _is_dispatcher(value):
                    space[name] = twin(value)
        return new

    body = twin(kernel)

    def call(*args: Any) -> Any:
        # a kernel that takes numba functions as arguments (an ODE right-hand side) gets
        # their twins, so that nothing compiles
        args = tuple(twin(a) if _is_dispatcher(a) else a for a in args)
        with np.errstate(all="ignore"):
            return body(*args)

    call.__name__ = f"interpreted_{kernel.py_func.__name__}"
    call.__doc__ = kernel.py_func.__doc__
    return call


def kernel_ready(kernel: Any, args: tuple) -> bool:
    """True when calling ``kernel(*args)`` will not compile: the signature of ``args`` is
    compiled in this process or stored in numba's on-disk cache (looked up in the cache's
    index, without loading it)."""
    try:
        sig = tuple(kernel.typeof_pyval(a) for a in args)
        if kernel.overloads.get(sig) is not None:
            return True
    except Exception:  # numba's private layout changed: assume it would compile
        return False
    return signature_cached(kernel, sig)


def signature_cached(kernel: Any, sig: Any) -> bool:
    """True when numba's on-disk cache holds ``kernel`` compiled for ``sig`` (an argument
    type tuple, as a lazy call compiles it, or the signature object given to ``njit``)."""
    try:
        cache = kernel._cache
        if not hasattr(cache, "_index_key"):  # caching off
            return False
        key = cache._index_key(sig, kernel.targetctx.codegen())
        return key in cache._cache_file._load_index()
    except Exception:  # numba's private cache layout changed: assume it would compile
        return False


class FirstCallRoute:
    """Compiled or interpreted, per call, for one kernel (see the module docstring).

    Parameters
    ----------
    kernel : numba dispatcher
        The kernel.
    label : str
        What the kernel is, in words, for the one-line notice ("the mesh oscillator's
        continuation").
    unit_cpu : float
        Interpreted CPU seconds per unit of work before any has been measured (the caller
        says what a unit is: a sample, a sample times a frequency...); later calls use the
        measured mean.
    compile_cpu : float
        Typical CPU seconds of the compile, quoted in the notice, and the most the
        interpreted calls of all processes together may spend (the ledger) before compiling.
    allowance_cpu : float
        Interpreted CPU seconds this process may spend before the kernel is compiled.
    overrides : dict, optional
        Passed to :func:`interpreted`.
    ready : callable, optional
        ``ready(args) -> bool``: whether the compiled route would not compile (default
        :func:`kernel_ready`); for a kernel that is not a lazy dispatcher.
    twin : callable, optional
        Makes the plain-Python callable (default ``interpreted(kernel, overrides)``).
    """

    def __init__(self, kernel: Any, label: str, *, unit_cpu: float, compile_cpu: float,
                 allowance_cpu: float = DEFAULT_ALLOWANCE_CPU,
                 overrides: dict[str, Callable] | None = None,
                 ready: Callable[[tuple], bool] | None = None,
                 twin: Callable[[], Callable] | None = None) -> None:
        if not unit_cpu > 0.0:
            raise ValueError(f"unit_cpu={unit_cpu!r} must be > 0 (CPU seconds per unit)")
        if not allowance_cpu >= 0.0:
            raise ValueError(f"allowance_cpu={allowance_cpu!r} must be >= 0 (CPU seconds)")
        self.kernel = kernel
        self.label = label
        self.compile_cpu = compile_cpu
        self.allowance_cpu = allowance_cpu
        self._ready = ready or (lambda args: kernel_ready(kernel, args))
        self._make_twin = twin or (lambda: interpreted(kernel, overrides))
        self._twin: Callable | None = None
        self._unit_cpu = unit_cpu
        self._spent_cpu = 0.0
        self._units = 0.0
        self._calls = 0
        self._settled = False
        self._noticed = False
        self._pending_cpu = 0.0
        self._lock = threading.Lock()

    @property
    def spent_cpu(self) -> float:
        """Interpreted CPU seconds spent so far in this process."""
        return self._spent_cpu

    @property
    def interpreted_calls(self) -> int:
        """Calls that ran interpreted so far in this process."""
        return self._calls

    def choose(self, units: float, args: tuple) -> tuple[Callable, str]:
        """The callable to run ``args`` with (``units`` of work) and its route, ``"compiled"``
        or ``"interpreted"``; an interpreted callable is to be called once: it charges its
        CPU to the allowance and the ledger."""
        route = _forced.get() or os.environ.get("GEARUQ_KERNELS", "auto") or "auto"
        if route not in _ROUTES:
            raise ValueError(f"GEARUQ_KERNELS={route!r} is not a route; valid: "
                             f"{', '.join(_ROUTES)}")
        if route == "compiled" or (route == "auto" and self._settled):
            return self.kernel, "compiled"
        predicted = units * self._unit_cpu
        if route == "auto" and (
                self._ready(args)
                # calls still running in other threads count with their prediction
                or self._spent_cpu + self._pending_cpu + predicted > self.allowance_cpu
                or _read_ledger().get(self.label, 0.0) + predicted > self.compile_cpu):
            # compiled or about to be: later calls need not look at the cache or the ledger
            self._settled = True
            return self.kernel, "compiled"
        if self._twin is None:
            self._twin = self._make_twin()
        if not self._noticed and route == "auto" and predicted >= NOTICE_MIN_CPU:
            self._noticed = True
            self._notice(units)
        with self._lock:
            self._pending_cpu += predicted
        return self._charged(units, predicted), "interpreted"

    def _charged(self, units: float, predicted: float) -> Callable:
        def run(*args: Any) -> Any:
            cpu = time.thread_time()
            try:
                return self._twin(*args)
            finally:
                spent = time.thread_time() - cpu
                with self._lock:
                    self._pending_cpu -= predicted
                    self._spent_cpu += spent
                    self._units += units
                    self._calls += 1
                    self._unit_cpu = self._spent_cpu / max(self._units, 1e-300)
                    _charge_ledger(self.label, spent)
        return run

    def _notice(self, units: float) -> None:
        if os.environ.get("GEARUQ_QUIET_COMPILE"):
            return
        print(f"gearuq: {self.label} is not compiled yet: this small call runs it as plain "
              f"Python (about {units * self._unit_cpu:.1f} s of CPU; up to "
              f"{self.allowance_cpu:.0f} s per process); a larger call compiles it (about "
              f"{self.compile_cpu:.0f} s of CPU, once per install; `gearuq compile` does it "
              "ahead)", file=sys.stderr, flush=True)
