"""Tie worker processes to the run that started them.

A local worker pool survives its parent when the parent is killed (SIGKILL, out-of-memory
kill): the workers keep the pool's queues open, finish the chunks already queued to them,
write them into the store, and then wait forever for more. A killed run must instead stop
at once and never write after it is gone, because a new run may already own the store.

Each worker of a :class:`~gearuq.execution.ProcessRunner` calls :func:`install` when it
starts. Three independent guards follow:

* on Linux the kernel sends the worker SIGKILL when its parent dies
  (``prctl(PR_SET_PDEATHSIG)``); this works even while the worker is busy in compiled code
  that holds the GIL;
* everywhere, a daemon thread compares ``os.getppid()`` with the parent's pid every
  :data:`POLL_S` seconds and ends the process when they differ (an orphan is adopted by
  another process, so its parent pid changes);
* :func:`check_parent` is called by the chunk writer before it writes and again before it
  commits a chunk, so a worker that outlives its parent by a moment still writes nothing.

In the calling process and in dask workers (whose nannies handle this themselves) nothing is
installed and :func:`check_parent` does nothing.
"""

from __future__ import annotations

import os
import sys
import threading
import time

__all__ = ["ParentGoneError", "install", "check_parent", "parent_alive", "POLL_S"]

#: Seconds between two checks of the parent pid by the watchdog thread.
POLL_S = 0.25
#: Exit code of a worker that ends because its parent is gone.
EXIT_ORPHANED = 70

_PARENT: int | None = None  # pid of the run that started this worker (None: not a worker)

_PR_SET_PDEATHSIG = 1  # from <linux/prctl.h>


class ParentGoneError(RuntimeError):
    """The run that started this worker is gone; its results must not be written."""


def parent_alive() -> bool:
    """Whether the process that started this worker still runs (always true elsewhere)."""
    return _PARENT is None or os.getppid() == _PARENT


def check_parent(what: str) -> None:
    """Raise :class:`ParentGoneError` if this is a worker whose parent is gone.

    Parameters
    ----------
    what : str
        What was about to be done (for the message), e.g. ``"write chunk_000003.nc"``.
    """
    if not parent_alive():
        raise ParentGoneError(
            f"refusing to {what}: the run that started this worker (pid {_PARENT}) is gone")


def _kill_with_parent() -> bool:
    """Ask Linux to SIGKILL this process when its parent dies; ``False`` if unavailable."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes
        import signal

        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch(parent: int) -> None:
    while True:
        time.sleep(POLL_S)
        if os.getppid() != parent:
            os._exit(EXIT_ORPHANED)  # no cleanup: nothing of a dead run may be written


def install(parent: int | None, kill_with_parent: bool = True) -> None:
    """Worker initializer: end this process when its parent ends.

    Parameters
    ----------
    parent : int or None
        Pid of the process that started the worker, or ``None`` when an intermediary
        started it (multiprocessing's ``forkserver``, which itself ends with the run): the
        current parent is watched then.
    kill_with_parent : bool
        Also use Linux's parent-death signal. The kernel sends it when the *thread* that
        started the worker ends, so the caller passes ``True`` only when the pool is started
        from its main thread.
    """
    global _PARENT
    if parent is None:
        parent = os.getppid()
    _PARENT = parent
    if kill_with_parent:
        _kill_with_parent()
    if os.getppid() != parent:  # the parent died before the guard was in place
        os._exit(EXIT_ORPHANED)
    threading.Thread(target=_watch, args=(parent,), name="gearuq-lifeline",
                     daemon=True).start()
