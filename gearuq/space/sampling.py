"""Sampling rules on the unit hypercube, reproducible from one seed.

Every draw of a :class:`~gearuq.space.ParameterSpace` starts here: a uniform design ``U`` of
shape ``(n, d)`` by one of the rules ``"random"``, ``"lhs"``, ``"sobol"``, ``"halton"``, mapped
to physical values afterwards by the copula and the marginals.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.stats import qmc

__all__ = ["RULES", "SeedLike", "as_generator", "check_n", "check_rule", "unit_design"]

#: Sampling rules understood by :meth:`ParameterSpace.sample_unit`.
RULES = ("random", "lhs", "sobol", "halton")

#: What a seed argument accepts.
SeedLike = int | np.integer | np.random.Generator | np.random.SeedSequence | None


def as_generator(rng: Any = None) -> np.random.Generator:
    """Return a :class:`numpy.random.Generator` from a seed, SeedSequence or Generator.

    Parameters
    ----------
    rng : int, numpy.random.SeedSequence, numpy.random.Generator or None
        ``None`` gives fresh OS entropy (not reproducible). A Generator is used as is.
    """
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None or isinstance(rng, np.random.SeedSequence):
        return np.random.default_rng(rng)
    if isinstance(rng, (bool, np.bool_)) or not isinstance(rng, (int, np.integer)):
        raise TypeError(
            f"rng: expected an int seed, numpy Generator, SeedSequence or None, got {rng!r}"
        )
    if rng < 0:
        raise ValueError(f"rng: seed must be a non-negative integer, got {rng}")
    return np.random.default_rng(int(rng))


def check_n(n: Any) -> int:
    """``n`` as a positive int, or a ValueError naming it."""
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)):
        raise ValueError(f"n: expected a positive integer number of samples, got {n!r}")
    if n <= 0:
        raise ValueError(f"n: number of samples must be positive, got {n}")
    return int(n)


def check_rule(rule: Any) -> str:
    """``rule`` lower-cased if it is one of :data:`RULES`, or a ValueError listing them."""
    if not isinstance(rule, str) or rule.lower() not in RULES:
        raise ValueError(f"rule: unknown sampling rule {rule!r}; valid: {', '.join(RULES)}")
    return rule.lower()


def unit_design(n: int, dim: int, rule: str = "random", rng: SeedLike = None) -> np.ndarray:
    """Uniform design ``(n, dim)`` on the unit hypercube (see
    :meth:`gearuq.space.ParameterSpace.sample_unit`)."""
    n = check_n(n)
    rule = check_rule(rule)
    gen = as_generator(rng)
    d = int(dim)
    if rule == "random":
        return gen.random((n, d))
    if rule == "lhs":
        u = np.empty((n, d))
        for j in range(d):
            u[:, j] = (gen.permutation(n) + gen.random(n)) / n
        return u
    engine_cls = qmc.Sobol if rule == "sobol" else qmc.Halton
    try:
        engine = engine_cls(d, scramble=True, rng=gen)
    except TypeError:  # scipy < 1.15 names the argument seed
        engine = engine_cls(d, scramble=True, seed=gen)
    return engine.random(n)
