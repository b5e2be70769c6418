"""Saving and rebuilding a chaos surrogate: ``to_dataset`` / ``from_dataset``.

They live beside :class:`~gearuq.engines.pce.surrogate.PolynomialChaos` (they read and set its
fitted state); this module keeps their old import path.
"""

from __future__ import annotations

from gearuq.engines.pce.surrogate import from_dataset, to_dataset

__all__ = ["to_dataset", "from_dataset"]
