"""Design variables: deterministic, bounded numbers that set where a model's inputs sit.

A design variable either moves the law of a random input (``role="location"``: the input is
its base law shifted so that its mean equals the design value, as a drawing's nominal
dimension moves the whole tolerance band) or sets a deterministic model parameter
(``role="parameter"``: the model's nominal value, through :meth:`Model.with_nominal`).

Only a location design leaves the model itself unchanged, so only it lets runs made at one
design be reused at another by likelihood-ratio reweighting (:mod:`gearuq.design.pool`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from gearuq.model import Model
from gearuq.space import ParameterSpace

__all__ = ["DesignVariable", "space_at", "model_at", "check_variables", "SHIFT_KEYS"]

#: Per distribution kind, the spec keys that move with a location shift.
SHIFT_KEYS: dict[str, tuple[str, ...]] = {
    "normal": ("mean",),
    "uniform": ("lower", "upper"),
    "truncnormal": ("mean", "lower", "upper"),
    "triangular": ("lower", "mode", "upper"),
    "gumbel": ("loc",),
    "lognormal": ("shift",),
    "weibull": ("shift",),
    "gamma": ("shift",),
}

ROLES = ("location", "parameter")


@dataclass(frozen=True)
class DesignVariable:
    """A deterministic design variable with bounds.

    Parameters
    ----------
    name : str
        Name of the design variable (a valid identifier).
    lower, upper : float
        Bounds of the design space, ``lower < upper``.
    target : str, optional
        The model parameter it sets (default: ``name``).
    role : {"location", "parameter"}
        ``"location"``: ``target`` is a random input of the space whose law is shifted so
        that its mean equals the design value (its scatter, e.g. a drawing tolerance, moves
        with it). ``"parameter"``: ``target`` is a deterministic model parameter set to the
        design value.
    units : str
        Units of the value (recorded in results).
    description : str
        What it means, in the user's words.

    Examples
    --------
    >>> DesignVariable("relief", 3.0, 30.0, target="tip_relief_amount", units="um").role
    'location'
    """

    name: str
    lower: float
    upper: float
    target: str = ""
    role: str = "location"
    units: str = ""
    description: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise ValueError(f"DesignVariable name: {self.name!r} is not a valid identifier")
        for key in ("lower", "upper"):
            value = getattr(self, key)
            if not isinstance(value, (int, float, np.floating, np.integer)) \
                    or not math.isfinite(float(value)):
                raise ValueError(f"DesignVariable {self.name!r}: {key}={value!r} must be a "
                                 "finite number")
        if not float(self.lower) < float(self.upper):
            raise ValueError(f"DesignVariable {self.name!r}: lower={self.lower!r} must be "
                             f"below upper={self.upper!r}")
        if self.role not in ROLES:
            raise ValueError(f"DesignVariable {self.name!r}: role={self.role!r}; valid: "
                             f"{', '.join(ROLES)}")
        if not self.target:
            object.__setattr__(self, "target", self.name)

    @property
    def bounds(self) -> tuple[float, float]:
        """``(lower, upper)`` as floats."""
        return float(self.lower), float(self.upper)


def check_variables(variables: Sequence[DesignVariable], model: Model,
                    space: ParameterSpace) -> tuple[DesignVariable, ...]:
    """Validate design variables against a model and its space; return them as a tuple.

    Raises
    ------
    TypeError
        An element is not a :class:`DesignVariable`.
    ValueError
        No variables, duplicate names or targets, a location target not in the space (or of
        a kind that cannot be shifted), a parameter target in the space or not a model
        parameter, or bounds outside the model's valid range.
    """
    variables = tuple(variables)
    if not variables:
        raise ValueError("variables: at least one DesignVariable is needed")
    for v in variables:
        if not isinstance(v, DesignVariable):
            raise TypeError(f"variables: expected DesignVariable, got {type(v).__name__}")
    for what in ("name", "target"):
        seen = [getattr(v, what) for v in variables]
        dup = sorted({s for s in seen if seen.count(s) > 1})
        if dup:
            raise ValueError(f"variables: duplicate {what}(s) {dup}")
    names = [p.name for p in model.parameters]
    for v in variables:
        if v.target not in names:
            raise ValueError(f"DesignVariable {v.name!r}: target={v.target!r} is not a "
                             f"parameter of model {model.name!r}")
        p = model.parameter(v.target)
        if v.role == "location":
            if v.target not in space:
                raise ValueError(f"DesignVariable {v.name!r}: role='location' needs "
                                 f"{v.target!r} in the space (random); space has "
                                 f"{', '.join(space.names)}")
            kind = space.marginal(v.target).kind
            if kind not in SHIFT_KEYS:
                raise ValueError(f"DesignVariable {v.name!r}: a {kind!r} law cannot be "
                                 f"shifted; valid kinds: {', '.join(SHIFT_KEYS)}")
        else:
            if v.target in space:
                raise ValueError(f"DesignVariable {v.name!r}: role='parameter' but "
                                 f"{v.target!r} is random in the space; use role='location'")
            if v.lower < p.lower or v.upper > p.upper:
                raise ValueError(f"DesignVariable {v.name!r}: bounds [{v.lower}, {v.upper}] "
                                 f"leave {v.target!r}'s valid range [{p.lower}, {p.upper}]")
    return variables


def _as_values(variables: Sequence[DesignVariable], values: Any) -> np.ndarray:
    if isinstance(values, Mapping):
        missing = [v.name for v in variables if v.name not in values]
        if missing:
            raise ValueError(f"design: missing value(s) for {missing}")
        values = [values[v.name] for v in variables]
    arr = np.asarray(values, dtype=float).reshape(-1)
    if arr.size != len(variables):
        raise ValueError(f"design: expected {len(variables)} values "
                         f"({', '.join(v.name for v in variables)}), got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"design: values must be finite, got {arr.tolist()}")
    return arr


def space_at(space: ParameterSpace, variables: Sequence[DesignVariable], values: Any
             ) -> ParameterSpace:
    """The space with each location variable's input law shifted to mean = its value.

    Parameters
    ----------
    space : ParameterSpace
        The base space (its location targets' means are the reference).
    variables : sequence of DesignVariable
    values : array_like or mapping
        One value per variable (order of ``variables``) or name -> value.

    Returns
    -------
    ParameterSpace
        Same names, same copula, same uniform-to-physical map up to the shifts: the same
        uniform design gives the same draws shifted (common random numbers across designs).
    """
    arr = _as_values(variables, values)
    shifts = {v.target: float(x) - space.marginal(v.target).mean()
              for v, x in zip(variables, arr, strict=True) if v.role == "location"}
    data = space.to_dict()
    for spec in data["parameters"]:
        delta = shifts.get(spec["name"])
        if delta is None:
            continue
        for key in SHIFT_KEYS[spec["dist"]]:
            spec[key] = float(spec.get(key, 0.0)) + delta
    return ParameterSpace.from_dict(data)


def model_at(model: Model, variables: Sequence[DesignVariable], values: Any) -> Model:
    """The model with each parameter variable's nominal value set to its design value."""
    arr = _as_values(variables, values)
    nominal = {v.target: float(x) for v, x in zip(variables, arr, strict=True)
               if v.role == "parameter"}
    return model.with_nominal(**nominal) if nominal else model


def location_shift_pdf(space: ParameterSpace, variable: DesignVariable, value: float,
                       x: np.ndarray) -> np.ndarray:
    """Density at ``x`` of ``variable``'s target law shifted to mean ``value``."""
    m = space.marginal(variable.target)
    return m.pdf(np.asarray(x, dtype=float) - (float(value) - m.mean()))


def spread_pdf(space: ParameterSpace, variable: DesignVariable, x: np.ndarray) -> np.ndarray:
    """Density at ``x`` of the target law with its mean drawn uniformly over the bounds.

    ``h(x) = (1 / (b - a)) int_a^b f(x - (d - mu)) dd = [F(x - a + mu) - F(x - b + mu)] /
    (b - a)``: the law of the first batch, which covers the whole design interval.
    """
    m = space.marginal(variable.target)
    a, b = variable.bounds
    mu = m.mean()
    x = np.asarray(x, dtype=float)
    return (m.cdf(x - a + mu) - m.cdf(x - b + mu)) / (b - a)
