"""Say once what is happening when gearuq's numba kernels compile.

A fresh install compiles each model's kernels on their first call (tens of seconds on a
loaded machine); without a word, a first call looks hung. numba runs the ``init`` entry points
of the group ``numba_extensions`` before it compiles anything (pyproject registers
:func:`init`), and it announces each real compilation (not a load from its on-disk cache) as a
``numba:compile`` event; the listener installed here prints one line per package whose
kernels start compiling, on standard error, the first time only.
"""

from __future__ import annotations

import os
import sys
import threading
from typing import Any

#: Packages whose kernels are announced, with the words used for them.
_FAMILIES = {
    "gearuq.ode": "the batched ODE integrator's",
    "gearuq.gears": "the tooth-contact (LTCA) solver's",
    "gearuq.rotor": "the rotor's",
    "gearuq_plugins.helical_pair": "the helical pair's",
    "gearuq_plugins.mesh_oscillator": "the mesh oscillator's",
    "gearuq_plugins.geared_rotor": "the geared rotor's",
    "gearuq_plugins.mesh_excitation": "the mesh excitation's",
    "gearuq_plugins.linear_oscillator": "the linear oscillator's",
}
_announced: set[str] = set()
_lock = threading.Lock()


def family_of(module: str) -> str | None:
    """The announced package a module belongs to (None: not a gearuq kernel)."""
    for family in _FAMILIES:
        if module == family or module.startswith(family + "."):
            return family
    return None


def announce(module: str, stream: Any = None) -> bool:
    """Print the compile notice for ``module``'s package unless it was printed already.

    Parameters
    ----------
    module : str
        ``__module__`` of the function numba starts compiling.
    stream : file-like, optional
        Where to write (default: standard error at the time of the call).

    Returns
    -------
    bool
        True when a line was printed.
    """
    family = family_of(module)
    if family is None or os.environ.get("GEARUQ_QUIET_COMPILE"):
        return False
    with _lock:
        if family in _announced:
            return False
        _announced.add(family)
    print(f"gearuq: compiling {_FAMILIES[family]} numba kernels (once per install: later runs "
          "load them from the cache; `gearuq compile` does it ahead) ...",
          file=stream or sys.stderr, flush=True)
    return True


def init() -> None:
    """numba's extension hook: listen for compilations (called once, before any compile)."""
    from numba.core import event

    class _Notice(event.Listener):
        def on_start(self, ev: Any) -> None:
            dispatcher = (ev.data or {}).get("dispatcher")
            module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
            announce(module)

        def on_end(self, ev: Any) -> None:
            pass

    event.register("numba:compile", _Notice())
