"""Import chaospy (and numpoly) without changing the caller's logging configuration.

On import both call ``logging.basicConfig(level=DEBUG, filename=os.devnull)``: the root
logger drops to DEBUG and gets a handler, so every library logs at DEBUG from then on (numba
compiles about 25 % slower with its debug logging on, and a signal arriving while numba's
compiler formats a record is reported as ``--- Logging error ---`` instead of stopping the
run) and a user's own ``basicConfig`` becomes a no-op. This module is imported before anything
else of gearuq imports chaospy and undoes both; when chaospy was imported before gearuq,
``import gearuq`` calls :func:`undo_chaospy_logging` itself.
"""

from __future__ import annotations

import logging
import os

_root = logging.getLogger()
_level, _handlers = _root.level, list(_root.handlers)


def _chaospy_log_paths() -> set[str]:
    """The files chaospy's and numpoly's ``basicConfig`` log to (os.devnull by default)."""
    return {os.path.abspath(os.environ.get(var, os.devnull))
            for var in ("CHAOSPY_LOGPATH", "NUMPOLY_LOGPATH")}


def undo_chaospy_logging() -> bool:
    """Remove the root handler chaospy's (or numpoly's) import installed, and the DEBUG level.

    Only a root ``FileHandler`` writing to chaospy's or numpoly's log path (os.devnull unless
    ``CHAOSPY_LOGPATH`` / ``NUMPOLY_LOGPATH`` say otherwise) is removed; the root level goes
    back to WARNING (logging's default) only when it is DEBUG, the level that call set. A
    configuration of the user's own is left alone.

    Returns
    -------
    bool
        True when a handler was removed.
    """
    root = logging.getLogger()
    paths = _chaospy_log_paths()
    ours = [h for h in root.handlers if isinstance(h, logging.FileHandler)
            and os.path.abspath(h.baseFilename) in paths]
    for handler in ours:
        root.removeHandler(handler)
        handler.close()
    if ours and root.level == logging.DEBUG:
        root.setLevel(logging.WARNING)
    return bool(ours)


import chaospy  # noqa: E402, F401 - the guarded import itself

_root.setLevel(_level)
for _h in list(_root.handlers):
    if _h not in _handlers:
        _root.removeHandler(_h)
        _h.close()
undo_chaospy_logging()  # chaospy imported before this module: its basicConfig ran earlier
