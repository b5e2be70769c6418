"""Import chaospy (and numpoly) without changing the caller's logging configuration.

On import both call ``logging.basicConfig(level=DEBUG, filename=os.devnull)``: the root
logger drops to DEBUG and gets a handler, so every library logs at DEBUG from then on (numba
compiles about 25 % slower with its debug logging on) and a user's own ``basicConfig`` becomes
a no-op. This module is imported before anything else imports chaospy and undoes both.
"""

from __future__ import annotations

import logging

_root = logging.getLogger()
_level, _handlers = _root.level, list(_root.handlers)

import chaospy  # noqa: E402, F401 - the guarded import itself

_root.setLevel(_level)
for _h in list(_root.handlers):
    if _h not in _handlers:
        _root.removeHandler(_h)
        _h.close()
