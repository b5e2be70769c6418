"""Small argument checks shared by the public functions (no imports beyond numpy)."""

from __future__ import annotations

from typing import Any

import numpy as np


def check_bool(name: str, value: Any) -> bool:
    """``value`` if it is ``True`` or ``False`` (numpy's too), else a TypeError naming ``name``.

    A truthy string such as ``"no"`` would otherwise mean yes.
    """
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise TypeError(f"{name}: expected True or False, got {value!r}")
