"""Spaces made around a model's nominal values (the model object is given, never looked up)."""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from typing import Any

from gearuq.space.marginals import Marginal, as_number, from_moments, mass_outside

__all__ = ["marginals_around_nominal"]


def marginals_around_nominal(
    model: Any,
    relative_std: Mapping[str, float] | None = None,
    *,
    std: Mapping[str, float] | None = None,
    dist: str | Mapping[str, str] = "normal",
    outside: str = "raise",
    tol: float = 1e-6,
) -> dict[str, Marginal]:
    """Marginals of :meth:`gearuq.space.ParameterSpace.around_nominal` (see there)."""
    if isinstance(model, str) or not callable(getattr(model, "parameter", None)):
        raise ValueError(
            f"model: expected a model object with declared parameters, got {model!r}; "
            "a space does not look models up by name: pass gearuq.get_model(name)")
    if outside not in ("raise", "warn", "truncate", "ignore"):
        raise ValueError(
            f"outside: unknown {outside!r}; valid: raise, warn, truncate, ignore"
        )
    relative_std = dict(relative_std or {})
    std = dict(std or {})
    both = sorted(set(relative_std) & set(std))
    if both:
        raise ValueError(f"parameter(s) {both} given both relative_std and std")
    order = list(relative_std) + [k for k in std if k not in relative_std]
    if not order:
        raise ValueError("around_nominal: give relative_std and/or std for some parameter")
    marginals: dict[str, Marginal] = {}
    for name in order:
        par = model.parameter(name)
        mean = float(par.nominal)
        if name in relative_std:
            rel = as_number(name, "relative", "std", relative_std[name])
            if rel <= 0:
                raise ValueError(f"parameter {name!r}: relative std must be > 0, got {rel!r}")
            if mean == 0:
                raise ValueError(
                    f"parameter {name!r}: nominal is 0, a relative std is meaningless; "
                    f"give an absolute std instead"
                )
            sd = rel * abs(mean)
        else:
            sd = as_number(name, "absolute", "std", std[name])
            if sd <= 0:
                raise ValueError(f"parameter {name!r}: std must be > 0, got {sd!r}")
        kind = dist.get(name, "normal") if isinstance(dist, Mapping) else dist
        m = from_moments(name, str(kind), mean, sd, par.lower, par.upper)
        p_out = mass_outside(m, par.lower, par.upper)
        if p_out > tol and outside != "ignore":
            msg = (
                f"parameter {name!r}: {m.describe()} puts probability {p_out:.3g} outside "
                f"the model's valid range {par.range_text()}"
            )
            if outside == "raise":
                raise ValueError(
                    msg + "; pass outside='truncate' to truncate it to the range, or use a "
                    "smaller std"
                )
            if outside == "warn":
                warnings.warn(msg, UserWarning, stacklevel=3)
            else:
                m = m.truncate(par.lower, par.upper)
        marginals[name] = m
    return marginals
