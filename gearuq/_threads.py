"""One BLAS thread for small dense linear algebra, at the cost of a context switch.

``threadpoolctl.threadpool_limits`` finds the loaded thread-pool libraries anew on every call:
it walks every shared library of the process (``dl_iterate_phdr``) and opens each candidate.
With gearuq's stack loaded that took about 5 ms a call, and the geared rotor limits its BLAS
once per speed solved: 14 s of a 70 s quick design study went there (docs/benchmarks.md,
"threadpoolctl's scan"). One :class:`threadpoolctl.ThreadpoolController`, made on the first
use, holds the libraries found then; later limits reuse it (about 0.02 ms a call).

A library loaded after that first use would not be limited. The BLAS that matters here is
the one numpy and scipy load at import, before any of gearuq's solvers runs. A forked worker
inherits the controller together with the libraries it describes.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["one_blas_thread"]

_controller: Any = None
_lock = threading.Lock()


def _get_controller() -> Any:
    """The process's controller (made once; ``False`` without threadpoolctl)."""
    global _controller
    if _controller is None:
        with _lock:
            if _controller is None:
                try:
                    from threadpoolctl import ThreadpoolController
                except ImportError:  # pragma: no cover - a dependency of gearuq
                    _controller = False
                else:
                    _controller = ThreadpoolController()
    return _controller


@contextmanager
def one_blas_thread(user_api: str | None = None) -> Iterator[None]:
    """Limit the thread pools to one thread inside the block, restoring them after it.

    Parameters
    ----------
    user_api : {None, "blas", "openmp"}
        Which pools: ``None`` limits all of them (as ``threadpool_limits(1)``).
    """
    controller = _get_controller()
    if controller is False:  # pragma: no cover - threadpoolctl missing
        yield
        return
    with controller.limit(limits=1, user_api=user_api):
        yield
