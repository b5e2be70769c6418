"""The parameter space: named marginals, an optional Gaussian copula, sampling and transforms.

Every draw goes the same way: a uniform design ``U`` of shape ``(n, d)``
(:meth:`ParameterSpace.sample_unit`, :mod:`gearuq.space.sampling`) is mapped to physical values
(:meth:`ParameterSpace.transform`). Without dependence each column goes through its marginal's
inverse cdf, ``x_j = F_j^{-1}(u_j)``. With a correlation matrix ``R`` the columns are first
mapped to standard normals ``z = Phi^{-1}(u)``, correlated with the Cholesky factor ``L`` of
``R`` (``z' = L z``) and mapped back, ``x_j = F_j^{-1}(Phi(z'_j))``; this is the Rosenblatt
transform of chaospy's ``Nataf`` copula, so :meth:`ParameterSpace.to_chaospy` and
:meth:`ParameterSpace.transform` agree (to round-off).
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import chaospy as cp
import numpy as np
from scipy import special

from gearuq.space.adapters import from_salib, to_chaospy, to_salib
from gearuq.space.copula import normal_correlation
from gearuq.space.marginals import U_MAX, U_MIN, Marginal, mass_outside
from gearuq.space.nominal import marginals_around_nominal
from gearuq.space.sampling import SeedLike, unit_design

__all__ = ["ParameterSpace"]


class ParameterSpace:
    """Named random variables with an optional Gaussian copula.

    Parameters
    ----------
    marginals : mapping
        Parameter name -> a univariate chaospy distribution (``cp.Normal(2e-5, 3e-9)``), a spec
        dict (``{"dist": "normal", "mean": 2e-5, "std": 3e-9}``) or a :class:`Marginal`.
        Order is kept.
    correlation : array_like or mapping, optional
        ``(d, d)`` matrix in parameter order, or ``{("a", "b"): rho, ...}``; ``None`` means
        independent parameters.
    correlation_type : {"normal", "spearman", "kendall", "pearson"}
        What ``correlation`` holds. ``"normal"`` (default): the correlation of the underlying
        standard normals of the Gaussian copula, used as is. ``"spearman"`` / ``"kendall"``:
        rank correlations of the variables, converted exactly with ``2 sin(pi rho_S / 6)`` and
        ``sin(pi tau / 2)``. ``"pearson"``: product-moment correlations of the variables,
        converted by solving the Nataf integral (Gauss-Hermite quadrature and root finding);
        raises if a target is not reachable for the marginals.

    Examples
    --------
    >>> import chaospy as cp
    >>> space = ParameterSpace({"b5": cp.Normal(2e-5, 3.3e-9), "s": cp.Uniform(0.05, 0.15)})
    >>> x = space.sample(4, rule="lhs", rng=1)
    >>> sorted(x), x["s"].shape
    (['b5', 's'], (4,))
    """

    def __init__(
        self,
        marginals: Mapping[str, Any],
        correlation: Any = None,
        *,
        correlation_type: str = "normal",
    ) -> None:
        if not isinstance(marginals, Mapping) or not marginals:
            raise ValueError("ParameterSpace needs a non-empty mapping name -> distribution")
        self._marginals: dict[str, Marginal] = {}
        for name, value in marginals.items():
            if not isinstance(name, str) or not name.isidentifier():
                raise ValueError(f"parameter name {name!r} is not a valid identifier")
            if isinstance(value, Marginal):
                m = value if value.name == name else Marginal(
                    name, value.kind, value.params, value.dist)
            elif isinstance(value, Mapping):
                m = Marginal.from_spec(name, value)
            else:
                m = Marginal.from_chaospy(name, value)
            self._marginals[name] = m
        self._corr, self._correlation_input = normal_correlation(
            correlation, correlation_type, self._marginals)
        self._chol = None if self._corr is None else np.linalg.cholesky(self._corr)

    # ------------------------------------------------------------------ builders
    @classmethod
    def from_spec(
        cls,
        specs: Iterable[Mapping[str, Any]],
        correlation: Any = None,
        *,
        correlation_type: str = "normal",
    ) -> ParameterSpace:
        """Build a space from spec dicts, each with ``name``, ``dist`` and its parameters.

        Parameters
        ----------
        specs : iterable of dict
            e.g. ``[{"name": "b5", "dist": "normal", "mean": 2e-5, "std": 3.3e-9},
            {"name": "s", "dist": "uniform", "lower": 0.05, "upper": 0.15}]``. See the module
            docstring for the kinds and their parameters; ``"lognormal"`` takes either
            ``mu``/``sigma`` of ``ln X`` or ``mean``/``std`` of ``X``.
        correlation, correlation_type
            As in the constructor.
        """
        marginals: dict[str, Marginal] = {}
        for i, spec in enumerate(specs):
            if not isinstance(spec, Mapping):
                raise ValueError(f"spec #{i}: expected a dict, got {spec!r}")
            name = spec.get("name")
            if not isinstance(name, str):
                raise ValueError(f"spec #{i}: needs a string 'name', got {spec!r}")
            if name in marginals:
                raise ValueError(f"spec #{i}: duplicate parameter name {name!r}")
            marginals[name] = Marginal.from_spec(name, spec)
        return cls(marginals, correlation, correlation_type=correlation_type)

    @classmethod
    def normal(cls, correlation: Any = None, **params: tuple[float, float]) -> ParameterSpace:
        """Independent (or correlated) normals from ``name=(mean, std)`` keywords."""
        return cls.from_spec(
            [{"name": k, "dist": "normal", **dict(zip(("mean", "std"), _pair(k, v),
                                                        strict=True))}
             for k, v in params.items()],
            correlation,
        )

    @classmethod
    def uniform(cls, correlation: Any = None, **params: tuple[float, float]) -> ParameterSpace:
        """Uniforms from ``name=(lower, upper)`` keywords."""
        return cls.from_spec(
            [{"name": k, "dist": "uniform", **dict(zip(("lower", "upper"), _pair(k, v),
                                                        strict=True))}
             for k, v in params.items()],
            correlation,
        )

    @classmethod
    def around_nominal(
        cls,
        model: Any,
        relative_std: Mapping[str, float] | None = None,
        *,
        std: Mapping[str, float] | None = None,
        dist: str | Mapping[str, str] = "normal",
        correlation: Any = None,
        correlation_type: str = "normal",
        outside: str = "raise",
        tol: float = 1e-6,
    ) -> ParameterSpace:
        """Make some of a model's parameters random around their nominal values.

        Parameters
        ----------
        model : Model
            The model object (a space never looks models up by name: pass
            ``gearuq.get_model(name)``); its ``parameters`` give the nominal values (used as
            means) and the valid ranges.
        relative_std : mapping, optional
            Name -> coefficient of variation (std / |nominal|).
        std : mapping, optional
            Name -> absolute standard deviation (for parameters with nominal 0, say).
        dist : str or mapping
            ``"normal"`` (default), ``"lognormal"``, ``"uniform"``, ``"gumbel"``, ``"weibull"``
            or ``"truncnormal"`` (normal truncated to the valid range); a mapping gives
            one per parameter. Each is matched by mean and standard deviation (for
            ``"truncnormal"`` those of the parent normal before truncation).
        correlation, correlation_type
            As in the constructor (order: the order of the random parameters as given).
        outside : {"raise", "warn", "truncate", "ignore"}
            What to do when a distribution puts more than ``tol`` probability outside the
            model's valid range: raise a ValueError (default), warn, truncate it to the range,
            or ignore (the model will then reject out-of-range draws).
        tol : float
            Probability outside the valid range that is tolerated.

        Returns
        -------
        ParameterSpace
            Only the named parameters; the others keep their nominal values when evaluated.
        """
        marginals = marginals_around_nominal(model, relative_std, std=std, dist=dist,
                                             outside=outside, tol=tol)
        return cls(marginals, correlation, correlation_type=correlation_type)


    # ------------------------------------------------------------------ basic properties
    @property
    def names(self) -> list[str]:
        """Parameter names in order."""
        return list(self._marginals)

    @property
    def dim(self) -> int:
        """Number of random parameters."""
        return len(self._marginals)

    def __len__(self) -> int:
        return self.dim

    def __iter__(self):
        return iter(self._marginals)

    def __contains__(self, name: object) -> bool:
        return name in self._marginals

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ParameterSpace):
            return NotImplemented
        try:
            return self.to_dict() == other.to_dict()
        except ValueError:
            return self is other

    __hash__ = None  # type: ignore[assignment]

    @property
    def correlation(self) -> np.ndarray | None:
        """Correlation matrix of the underlying standard normals (``None``: independent)."""
        return None if self._corr is None else self._corr.copy()

    @property
    def correlation_input(self) -> dict[str, Any] | None:
        """The rank/Pearson correlation given by the user before conversion, if any."""
        return None if self._correlation_input is None else dict(self._correlation_input)

    @property
    def independent(self) -> bool:
        """Whether the parameters are independent."""
        return self._corr is None

    def marginal(self, name: str) -> Marginal:
        """The :class:`Marginal` of parameter ``name``."""
        try:
            return self._marginals[name]
        except KeyError:
            raise ValueError(
                f"space has no parameter {name!r}; valid: {', '.join(self.names)}"
            ) from None

    def __repr__(self) -> str:
        parts = "; ".join(repr(m) for m in self._marginals.values())
        dep = "independent" if self._corr is None else (
            "Gaussian copula R=" + np.array2string(self._corr, precision=3, separator=", ")
            .replace("\n", ""))
        return f"ParameterSpace({parts}; {dep})"

    def mean(self) -> dict[str, float]:
        """Marginal means."""
        return {k: m.mean() for k, m in self._marginals.items()}

    def std(self) -> dict[str, float]:
        """Marginal standard deviations."""
        return {k: m.std() for k, m in self._marginals.items()}

    def cdf(self, name: str, x: Any) -> np.ndarray:
        """Marginal cdf of parameter ``name`` at ``x``."""
        return self.marginal(name).cdf(x)

    def ppf(self, name: str, q: Any) -> np.ndarray:
        """Marginal quantile function of parameter ``name`` at probabilities ``q``."""
        return self.marginal(name).inv(q)

    def check_range(self, model: Any) -> dict[str, float]:
        """Probability each marginal puts outside ``model``'s valid range of that parameter."""
        return {
            k: mass_outside(m, model.parameter(k).lower, model.parameter(k).upper)
            for k, m in self._marginals.items()
        }

    # ------------------------------------------------------------------ sampling
    def sample_unit(self, n: int, rule: str = "random", rng: SeedLike = None) -> np.ndarray:
        """Uniform design on the unit hypercube.

        Parameters
        ----------
        n : int
            Number of points.
        rule : {"random", "lhs", "sobol", "halton"}
            ``"random"``: i.i.d. uniforms from a numpy Generator. ``"lhs"``: Latin hypercube,
            per dimension a random permutation of the ``n`` strata plus a uniform offset in
            each. ``"sobol"``: scrambled Sobol' (scipy.stats.qmc; balance needs ``n`` a power
            of 2, scipy warns otherwise). ``"halton"``: scrambled Halton.
        rng : int, Generator, SeedSequence or None
            Seed. The same integer gives the same design for every rule.

        Returns
        -------
        ndarray of shape (n, dim)
            Points in ``[0, 1)``, one column per parameter in :attr:`names` order.
        """
        return unit_design(n, self.dim, rule, rng)


    def transform(self, u: Any) -> dict[str, np.ndarray]:
        """Map a uniform design ``(n, dim)`` to parameter values through copula and marginals.

        Returns
        -------
        dict
            Name -> array of shape ``(n,)``.
        """
        u = np.asarray(u, dtype=float)
        if u.ndim != 2 or u.shape[1] != self.dim:
            raise ValueError(
                f"transform: expected a design of shape (n, {self.dim}), got {u.shape}"
            )
        if np.any((u < 0) | (u > 1)) or not np.all(np.isfinite(u)):
            raise ValueError("transform: design values must lie in [0, 1]")
        if self._chol is None:
            return {k: m.inv(u[:, j]) for j, (k, m) in enumerate(self._marginals.items())}
        z = special.ndtri(np.clip(u, U_MIN, U_MAX)) @ self._chol.T
        return {k: m.from_normal(z[:, j]) for j, (k, m) in enumerate(self._marginals.items())}

    def to_normal(self, x: Mapping[str, Any]) -> np.ndarray:
        """Map parameter values to the underlying correlated standard normals ``(n, dim)``."""
        cols = [special.ndtri(np.clip(self._marginals[k].cdf(x[k]), 0, 1)) for k in self.names]
        return np.column_stack(cols)

    def sample(self, n: int, rule: str = "random", rng: SeedLike = None) -> dict[str, np.ndarray]:
        """Draw ``n`` parameter samples; ``transform(sample_unit(n, rule, rng))``.

        Examples
        --------
        >>> space = ParameterSpace.normal(x=(0.0, 1.0))
        >>> bool((space.sample(8, rng=3)["x"] == space.sample(8, rng=3)["x"]).all())
        True
        """
        return self.transform(self.sample_unit(n, rule, rng))

    # ------------------------------------------------------------------ conversions
    def to_chaospy(self) -> cp.Distribution:
        """Joint chaospy distribution (see :func:`gearuq.space.adapters.to_chaospy`)."""
        return to_chaospy(self)

    def to_salib(self, unsupported: str = "raise") -> dict[str, Any]:
        """SALib problem dict (see :func:`gearuq.space.adapters.to_salib`)."""
        return to_salib(self, unsupported)

    def from_salib(self, x: Any, problem: Mapping[str, Any] | None = None
                   ) -> dict[str, np.ndarray]:
        """Parameter dict from a SALib sample matrix (see
        :func:`gearuq.space.adapters.from_salib`)."""
        return from_salib(self, x, problem)

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict[str, Any]:
        """Plain-data description (see :meth:`to_json`)."""
        return {
            "gearuq_space": 1,
            "parameters": [m.to_spec() for m in self._marginals.values()],
            "correlation": None if self._corr is None else self._corr.tolist(),
            "correlation_input": self._correlation_input,
        }

    def to_json(self, indent: int | None = None) -> str:
        """JSON text with names, distribution types, their parameters and the correlation.

        ``correlation`` is the normal-space matrix actually used, so :meth:`from_json`
        reproduces identical samples; ``correlation_input`` keeps the user's rank/Pearson
        matrix (if any) for the record.
        """
        return json.dumps(self.to_dict(), indent=indent, allow_nan=False)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ParameterSpace:
        """Inverse of :meth:`to_dict`."""
        if not isinstance(data, Mapping) or "parameters" not in data:
            raise ValueError("from_dict: not a gearuq ParameterSpace description")
        space = cls.from_spec(data["parameters"], data.get("correlation"))
        space._correlation_input = data.get("correlation_input")
        return space

    @classmethod
    def from_json(cls, text: str) -> ParameterSpace:
        """Inverse of :meth:`to_json`."""
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"from_json: invalid JSON: {exc}") from None
        return cls.from_dict(data)


def _pair(name: str, v: Any) -> tuple[float, float]:
    if not (isinstance(v, Sequence) and len(v) == 2):
        raise ValueError(f"parameter {name!r}: expected a pair of numbers, got {v!r}")
    return v[0], v[1]
