"""Conversions of a parameter space to the libraries gearuq builds on: chaospy and SALib."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import chaospy as cp
import numpy as np

__all__ = ["to_chaospy", "to_salib", "from_salib", "SpaceLike"]


class SpaceLike(Protocol):
    """What the adapters read of a parameter space (:class:`gearuq.ParameterSpace` is one):
    typed by its shape, so that this module needs no import of the space it serves."""

    @property
    def names(self) -> Sequence[str]: ...

    @property
    def dim(self) -> int: ...

    @property
    def independent(self) -> bool: ...

    @property
    def correlation(self) -> Any: ...

    def marginal(self, name: str) -> Any: ...


def to_chaospy(space: SpaceLike) -> cp.Distribution:
    """Joint chaospy distribution.

    Returns ``chaospy.J(*marginals)`` for independent parameters and
    ``chaospy.Nataf(chaospy.J(*marginals), R)`` with ``R`` = ``space.correlation`` (the
    normal-space matrix) otherwise. ``Nataf.inv`` equals ``space.transform`` to round-off.
    Note that chaospy cannot compute moments or build orthogonal polynomials for the
    dependent ``Nataf`` distribution; polynomial chaos should work in the independent
    standard-normal space instead.
    """
    joint = cp.J(*(space.marginal(k).dist for k in space.names))
    if space.independent:
        return joint
    return cp.Nataf(joint, space.correlation)


def to_salib(space: SpaceLike, unsupported: str = "raise") -> dict[str, Any]:
    """SALib problem dict (``num_vars``, ``names``, ``bounds``, ``dists``).

    Conventions (SALib 1.6 ``_nonuniform_scale_samples``): ``unif`` [lower, upper],
    ``norm`` [mean, std], ``lognorm`` [mu, sigma] of ln X, ``truncnorm``
    [lower, upper, mean, std], ``triang`` [lower, upper, (mode-lower)/(upper-lower)],
    ``logunif`` [lower, upper], ``weibull`` [shape, scale, shift].

    Parameters
    ----------
    unsupported : {"raise", "unit"}
        For kinds SALib lacks (gumbel, gamma, shifted lognormal, truncated, chaospy):
        raise a ValueError (default), or give SALib a ``unif`` [0, 1] factor holding the
        marginal's cdf value (uniform in probability); map SALib's sample matrix with
        :func:`from_salib`, which applies the inverse cdf to those columns. The problem
        then lists them in ``"gearuq_unit"``.

    Raises
    ------
    ValueError
        For a correlated space (SALib's Sobol' estimators assume independent inputs) or
        an unsupported kind with ``unsupported="raise"``.
    """
    if unsupported not in ("raise", "unit"):
        raise ValueError(f"unsupported: unknown {unsupported!r}; valid: raise, unit")
    if not space.independent:
        raise ValueError(
            "to_salib: SALib assumes independent inputs but this space has a correlation "
            "matrix; sample it with ParameterSpace.sample instead"
        )
    bounds: list[list[float]] = []
    dists: list[str] = []
    unit: list[str] = []
    for k in space.names:
        m = space.marginal(k)
        p = m.params
        entry: tuple[str, list[float]] | None = None
        if m.kind == "uniform":
            entry = ("unif", [p["lower"], p["upper"]])
        elif m.kind == "normal":
            entry = ("norm", [p["mean"], p["std"]])
        elif m.kind == "lognormal" and p["shift"] == 0:
            entry = ("lognorm", [p["mu"], p["sigma"]])
        elif m.kind == "loguniform":
            entry = ("logunif", [p["lower"], p["upper"]])
        elif m.kind == "truncnormal":
            entry = ("truncnorm", [p["lower"], p["upper"], p["mean"], p["std"]])
        elif m.kind == "triangular":
            c = (p["mode"] - p["lower"]) / (p["upper"] - p["lower"])
            if c < 1:  # SALib rejects a peak at the upper end
                entry = ("triang", [p["lower"], p["upper"], c])
        elif m.kind == "weibull":
            entry = ("weibull", [p["shape"], p["scale"], p["shift"]])
        if entry is None:
            if unsupported == "raise":
                raise ValueError(
                    f"to_salib: parameter {k!r} ({m.describe()}) has no SALib equivalent; "
                    f"SALib supports normal, lognormal (no shift), uniform, loguniform, "
                    f"truncnormal, triangular (mode < upper), weibull; pass "
                    f"unsupported='unit' to sample it uniformly in probability"
                )
            entry = ("unif", [0.0, 1.0])
            unit.append(k)
        dists.append(entry[0])
        bounds.append([float(v) for v in entry[1]])
    problem: dict[str, Any] = {
        "num_vars": space.dim,
        "names": space.names,
        "bounds": bounds,
        "dists": dists,
    }
    if unit:
        problem["gearuq_unit"] = unit
    return problem


def from_salib(space: SpaceLike, x: Any, problem: Mapping[str, Any] | None = None
               ) -> dict[str, np.ndarray]:
    """Turn a SALib sample matrix ``(N, dim)`` into a parameter dict.

    Columns listed in ``problem["gearuq_unit"]`` (see :func:`to_salib`) are probabilities
    and go through the marginal's inverse cdf; the others are already physical values.
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 2 or x.shape[1] != space.dim:
        raise ValueError(f"from_salib: expected shape (N, {space.dim}), got {x.shape}")
    unit = set((problem or {}).get("gearuq_unit", ()))
    return {
        k: (space.marginal(k).inv(x[:, j]) if k in unit else x[:, j].copy())
        for j, k in enumerate(space.names)
    }

