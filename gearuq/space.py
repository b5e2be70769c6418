"""Parameter spaces: named random variables, Gaussian-copula dependence and sampling rules.

A :class:`ParameterSpace` is an ordered set of named univariate marginals (chaospy
distributions) with an optional Gaussian copula (Nataf model). It draws reproducible designs
with the rules ``"random"``, ``"lhs"``, ``"sobol"`` and ``"halton"`` from one integer seed,
converts itself to a chaospy joint distribution and to a SALib problem, and serialises to JSON
so that results carry the exact space they were computed from.

Every draw goes the same way: a uniform design ``U`` of shape ``(n, d)`` (:meth:`sample_unit`)
is mapped to physical values (:meth:`transform`). Without dependence each column goes through
its marginal's inverse cdf, ``x_j = F_j^{-1}(u_j)``. With a correlation matrix ``R`` the
columns are first mapped to standard normals ``z = Phi^{-1}(u)``, correlated with the Cholesky
factor ``L`` of ``R`` (``z' = L z``) and mapped back, ``x_j = F_j^{-1}(Phi(z'_j))``; this is
the Rosenblatt transform of chaospy's ``Nataf`` copula, so :meth:`to_chaospy` and
:meth:`transform` agree (to round-off). The correlation matrix is that of the underlying
normals; rank (Spearman, Kendall) or Pearson targets are converted on request
(``correlation_type``), the Pearson one by solving the Nataf integral.

Quantiles of the named kinds below come from the closed-form scipy.stats equivalent of the
chaospy distribution (chaospy inverts e.g. the Weibull numerically to ~1e-11 relative, worse in
the far tails); other chaospy distributions use their own ``dist.inv``.

Distribution kinds
------------------
=============  ============================================  ==================================
kind           parameters                                    chaospy class
=============  ============================================  ==================================
normal         mean, std                                     ``Normal(mean, std)``
lognormal      mu, sigma (of ln X) [, shift]; or mean, std   ``LogNormal(mu, sigma, shift)``
               of X itself (converted to mu, sigma)
uniform        lower, upper                                  ``Uniform(lower, upper)``
loguniform     lower, upper of X (0 < lower < upper)         ``LogUniform(ln lower, ln upper)``
truncnormal    mean, std (of the parent normal), lower,      ``TruncNormal(lower, upper, mean,
               upper                                         std)``
weibull        shape, scale [, shift]                        ``Weibull(shape, scale, shift)``
gumbel         loc, scale (maximum / right-skewed Gumbel)    ``LogWeibull(scale, loc)``
triangular     lower, mode, upper                            ``Triangle(lower, mode, upper)``
gamma          shape, scale [, shift]                        ``Gamma(shape, scale, shift)``
=============  ============================================  ==================================

Note that in chaospy 4.3 ``chaospy.Gumbel`` is the Gumbel *copula*; the Gumbel distribution is
``chaospy.LogWeibull``. Any other univariate chaospy distribution can be given directly; it is
stored by its ``repr`` (kind ``"chaospy"``) and rebuilt from it by a restricted parser.
"""

from __future__ import annotations

import ast
import json
import math
import warnings
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import chaospy as cp
import numpy as np
from scipy import optimize, special, stats
from scipy.stats import qmc

__all__ = ["ParameterSpace", "Marginal", "RULES", "KINDS", "as_generator"]

#: Sampling rules understood by :meth:`ParameterSpace.sample_unit`.
RULES = ("random", "lhs", "sobol", "halton")

#: Distribution kinds with their required parameters (optional ones after ``|``).
KINDS: dict[str, tuple[tuple[str, ...], dict[str, float]]] = {
    "normal": (("mean", "std"), {}),
    "lognormal": (("mu", "sigma"), {"shift": 0.0}),
    "uniform": (("lower", "upper"), {}),
    "loguniform": (("lower", "upper"), {}),
    "truncnormal": (("mean", "std", "lower", "upper"), {}),
    "weibull": (("shape", "scale"), {"shift": 0.0}),
    "gumbel": (("loc", "scale"), {}),
    "triangular": (("lower", "mode", "upper"), {}),
    "gamma": (("shape", "scale"), {"shift": 0.0}),
}

_ALIASES = {
    "norm": "normal",
    "gaussian": "normal",
    "lognorm": "lognormal",
    "unif": "uniform",
    "logunif": "loguniform",
    "truncnorm": "truncnormal",
    "truncated_normal": "truncnormal",
    "triang": "triangular",
    "triangle": "triangular",
    "logweibull": "gumbel",
    "gumbel_r": "gumbel",
}

#: Correlation inputs accepted by the constructor.
CORRELATION_TYPES = ("normal", "spearman", "kendall", "pearson")

_RNG = int | np.integer | np.random.Generator | np.random.SeedSequence | None


# =========================================================================== helpers
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


def _check_n(n: Any) -> int:
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)):
        raise ValueError(f"n: expected a positive integer number of samples, got {n!r}")
    if n <= 0:
        raise ValueError(f"n: number of samples must be positive, got {n}")
    return int(n)


def _num(name: str, kind: str, key: str, value: Any) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(
            f"parameter {name!r}: {kind} {key} must be a number, got {value!r}"
        ) from None
    if math.isnan(x):
        raise ValueError(f"parameter {name!r}: {kind} {key} is NaN")
    return x


def _canonical_kind(name: str, kind: Any) -> str:
    if not isinstance(kind, str):
        raise ValueError(
            f"parameter {name!r}: distribution type must be a string, got {kind!r}; "
            f"valid: {', '.join(KINDS)}"
        )
    k = kind.strip().lower()
    k = _ALIASES.get(k, k)
    if k not in KINDS:
        raise ValueError(
            f"parameter {name!r}: unknown distribution type {kind!r}; valid: {', '.join(KINDS)}"
        )
    return k


def _lognormal_from_moments(name: str, mean: float, std: float) -> tuple[float, float]:
    if mean <= 0:
        raise ValueError(f"parameter {name!r}: lognormal mean must be > 0, got {mean!r}")
    if std <= 0:
        raise ValueError(f"parameter {name!r}: lognormal std must be > 0, got {std!r}")
    s2 = math.log1p((std / mean) ** 2)
    return math.log(mean) - 0.5 * s2, math.sqrt(s2)


def _weibull_shape_from_cov(name: str, cov: float) -> float:
    """Solve Gamma(1+2/k)/Gamma(1+1/k)^2 - 1 = cov^2 for the Weibull shape k."""

    def f(logk: float) -> float:
        k = math.exp(logk)
        lg1 = special.gammaln(1 + 1 / k)
        lg2 = special.gammaln(1 + 2 / k)
        return math.expm1(lg2 - 2 * lg1) - cov**2

    try:
        return math.exp(optimize.brentq(f, math.log(0.05), math.log(500.0), xtol=1e-14))
    except ValueError:
        raise ValueError(
            f"parameter {name!r}: no Weibull shape in [0.05, 500] gives coefficient of "
            f"variation {cov:g}"
        ) from None


# =========================================================================== marginals
class Marginal:
    """One named univariate random variable.

    Parameters
    ----------
    name : str
        Parameter name.
    kind : str
        One of :data:`KINDS`, ``"truncated"`` (a truncated base marginal) or ``"chaospy"``
        (any univariate chaospy distribution, stored by its ``repr``).
    params : dict
        Distribution parameters (see the module docstring); for ``"truncated"`` the keys
        ``lower``, ``upper`` and ``base`` (a spec dict), for ``"chaospy"`` the key ``expr``.
    dist : chaospy.Distribution
        The chaospy distribution (:meth:`ParameterSpace.to_chaospy`; also the inverse cdf of
        kinds without a scipy.stats equivalent).
    """

    def __init__(self, name: str, kind: str, params: dict[str, Any], dist: cp.Distribution):
        self.name = name
        self.kind = kind
        self.params = params
        self.dist = dist
        self._scipy = _scipy_equivalent(kind, params)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_spec(cls, name: str, spec: Mapping[str, Any]) -> Marginal:
        """Build a marginal from a spec dict such as ``{"dist": "normal", "mean": 1, "std": 2}``.

        Raises
        ------
        ValueError
            Unknown type, missing/unknown keys, or invalid values (naming ``name``).
        """
        spec = dict(spec)
        spec.pop("name", None)
        if "dist" not in spec and "kind" in spec:
            spec["dist"] = spec.pop("kind")
        if "dist" not in spec:
            raise ValueError(
                f"parameter {name!r}: spec needs a 'dist' entry naming the distribution type; "
                f"valid: {', '.join(KINDS)}"
            )
        raw_kind = spec.pop("dist")
        if isinstance(raw_kind, str) and raw_kind.lower() == "truncated":
            return cls._truncated_from_spec(name, spec)
        if isinstance(raw_kind, str) and raw_kind.lower() == "chaospy":
            if set(spec) != {"expr"}:
                raise ValueError(f"parameter {name!r}: a 'chaospy' spec needs exactly 'expr'")
            dist = _parse_chaospy_expr(name, spec["expr"])
            return cls(name, "chaospy", {"expr": str(spec["expr"])}, dist)
        kind = _canonical_kind(name, raw_kind)
        if kind == "lognormal" and ("mean" in spec or "std" in spec):
            if "mu" in spec or "sigma" in spec:
                raise ValueError(
                    f"parameter {name!r}: give lognormal either mean/std (of the variable) or "
                    f"mu/sigma (of its logarithm), not both"
                )
            missing = [k for k in ("mean", "std") if k not in spec]
            if missing:
                raise ValueError(f"parameter {name!r}: lognormal needs {', '.join(missing)}")
            mean = _num(name, kind, "mean", spec.pop("mean"))
            std = _num(name, kind, "std", spec.pop("std"))
            spec["mu"], spec["sigma"] = _lognormal_from_moments(name, mean, std)
        required, optional = KINDS[kind]
        missing = [k for k in required if k not in spec]
        unknown = [k for k in spec if k not in required and k not in optional]
        if missing or unknown:
            valid = list(required) + list(optional)
            if kind == "lognormal":
                valid += ["(or mean, std)"]
            what = []
            if missing:
                what.append(f"missing {', '.join(missing)}")
            if unknown:
                what.append(f"unknown {', '.join(map(repr, unknown))}")
            raise ValueError(
                f"parameter {name!r}: {kind} spec {'; '.join(what)}; keys: {', '.join(valid)}"
            )
        params = {k: _num(name, kind, k, spec[k]) for k in required}
        for k, default in optional.items():
            params[k] = _num(name, kind, k, spec.get(k, default))
        _validate_params(name, kind, params)
        return cls(name, kind, params, _build(kind, params))

    @classmethod
    def _truncated_from_spec(cls, name: str, spec: dict[str, Any]) -> Marginal:
        unknown = set(spec) - {"base", "lower", "upper"}
        if unknown or "base" not in spec:
            raise ValueError(
                f"parameter {name!r}: a 'truncated' spec needs 'base' (a spec) and optional "
                f"'lower', 'upper'; got keys {sorted(spec)}"
            )
        base = cls.from_spec(name, spec["base"])
        lower = _num(name, "truncated", "lower", spec.get("lower", -math.inf))
        upper = _num(name, "truncated", "upper", spec.get("upper", math.inf))
        return base.truncate(lower, upper)

    @classmethod
    def from_chaospy(cls, name: str, dist: Any) -> Marginal:
        """Wrap a univariate chaospy distribution, recognising the named kinds."""
        if not isinstance(dist, cp.Distribution):
            raise ValueError(
                f"parameter {name!r}: expected a chaospy distribution or a spec dict, got "
                f"{type(dist).__name__} {dist!r}"
            )
        if len(dist) != 1:
            raise ValueError(
                f"parameter {name!r}: expected a univariate distribution, got {len(dist)}-D "
                f"{dist!r}; give dependence through the correlation argument"
            )
        try:
            probe = np.asarray(dist.inv(np.array([0.25, 0.5, 0.75])), dtype=float)
            if not np.all(np.isfinite(probe)):
                raise ValueError("non-finite quantiles")
        except Exception as exc:  # noqa: BLE001 - report any chaospy failure clearly
            raise ValueError(
                f"parameter {name!r}: chaospy distribution {dist!r} cannot evaluate its inverse "
                f"cdf ({type(exc).__name__}: {exc})"
            ) from None
        expr = repr(dist)
        parsed = _recognise(name, dist)
        if parsed is not None:
            kind, params = parsed
            _validate_params(name, kind, params)
            return cls(name, kind, params, _build(kind, params))
        try:
            rebuilt = _parse_chaospy_expr(name, expr)
            u = np.linspace(0.01, 0.99, 7)
            same = np.array_equal(np.asarray(rebuilt.inv(u)), np.asarray(dist.inv(u)))
        except Exception:  # noqa: BLE001 - any failure means "not serialisable"
            same = False
        return cls(name, "chaospy", {"expr": expr if same else None}, dist)

    # ------------------------------------------------------------------ transforms
    def inv(self, u: Any) -> np.ndarray:
        """Inverse cdf (quantile function) at probabilities ``u``.

        Named kinds use the closed-form scipy.stats quantile of the same distribution
        (chaospy inverts some, e.g. Weibull, numerically to ~1e-11); other chaospy
        distributions use ``dist.inv``. ``u`` is clipped to ``[tiny, 1 - 2**-53]`` so an
        exact 0 or 1 never yields an infinite value.
        """
        u = np.clip(np.asarray(u, dtype=float), _U_MIN, _U_MAX)
        if self._scipy is not None:
            return np.asarray(self._scipy.ppf(u), dtype=float)
        return np.asarray(self.dist.inv(u.ravel()), dtype=float).reshape(u.shape)

    def cdf(self, x: Any) -> np.ndarray:
        """Cumulative distribution function at ``x``."""
        x = np.asarray(x, dtype=float)
        if self._scipy is not None:
            return np.asarray(self._scipy.cdf(x), dtype=float)
        return np.asarray(self.dist.fwd(x.ravel()), dtype=float).reshape(x.shape)

    def pdf(self, x: Any) -> np.ndarray:
        """Probability density at ``x``."""
        x = np.asarray(x, dtype=float)
        if self._scipy is not None:
            return np.asarray(self._scipy.pdf(x), dtype=float)
        return np.asarray(self.dist.pdf(x.ravel()), dtype=float).reshape(x.shape)

    def from_normal(self, z: np.ndarray) -> np.ndarray:
        """Map standard normal values to this marginal, ``F^{-1}(Phi(z))``.

        Normal marginals use ``mean + std * z`` directly; other named kinds use the survival
        function for ``z > 0`` (``F^{-1}(Phi(z)) = S^{-1}(Phi(-z))``) so the upper tail keeps
        its precision.
        """
        z = np.asarray(z, dtype=float)
        if self.kind == "normal":
            return self.params["mean"] + self.params["std"] * z
        if self._scipy is not None:
            upper = z > 0
            x = np.asarray(self._scipy.ppf(np.clip(special.ndtr(np.where(upper, 0.0, z)),
                                                   _U_MIN, _U_MAX)), dtype=float)
            if np.any(upper):
                q = np.clip(special.ndtr(-z[upper]), _U_MIN, _U_MAX)
                x[upper] = self._scipy.isf(q)
            return x
        return self.inv(special.ndtr(z))

    def mean(self) -> float:
        """Mean (closed form for named kinds, chaospy or numerical otherwise)."""
        if self._scipy is not None:
            return float(self._scipy.mean())
        try:
            return float(cp.E(self.dist))
        except Exception:  # noqa: BLE001 - chaospy raises several types
            return _numeric_moment(self, 1)

    def std(self) -> float:
        """Standard deviation (closed form for named kinds, chaospy or numerical otherwise)."""
        if self._scipy is not None:
            return float(self._scipy.std())
        try:
            return float(cp.Std(self.dist))
        except Exception:  # noqa: BLE001
            m = _numeric_moment(self, 1)
            return math.sqrt(max(_numeric_moment(self, 2) - m * m, 0.0))

    def truncate(self, lower: float = -math.inf, upper: float = math.inf) -> Marginal:
        """Return this marginal truncated to ``[lower, upper]``.

        A normal becomes a ``truncnormal``; other kinds become a ``"truncated"`` marginal
        built on :class:`chaospy.Trunc`.
        """
        if not lower < upper:
            raise ValueError(
                f"parameter {self.name!r}: truncation lower {lower!r} must be < upper {upper!r}"
            )
        if self.kind == "normal":
            p = {**self.params, "lower": float(lower), "upper": float(upper)}
            _validate_params(self.name, "truncnormal", p)
            return Marginal(self.name, "truncnormal", p, _build("truncnormal", p))
        if self.kind == "truncnormal":
            p = dict(self.params)
            p["lower"] = max(p["lower"], float(lower))
            p["upper"] = min(p["upper"], float(upper))
            _validate_params(self.name, "truncnormal", p)
            return Marginal(self.name, "truncnormal", p, _build("truncnormal", p))
        mass = float(self.cdf(upper)) - float(self.cdf(lower))
        if not mass > 0:
            raise ValueError(
                f"parameter {self.name!r}: truncation to [{lower:g}, {upper:g}] keeps no "
                f"probability of {self.describe()}"
            )
        kwargs = {}
        if math.isfinite(lower):
            kwargs["lower"] = float(lower)
        if math.isfinite(upper):
            kwargs["upper"] = float(upper)
        dist = cp.Trunc(self.dist, **kwargs)
        params = {"base": self.to_spec(with_name=False), "lower": float(lower),
                  "upper": float(upper)}
        return Marginal(self.name, "truncated", params, dist)

    # ------------------------------------------------------------------ description
    def to_spec(self, with_name: bool = True) -> dict[str, Any]:
        """Spec dict that :meth:`from_spec` turns back into this marginal.

        Raises
        ------
        ValueError
            For a chaospy distribution whose ``repr`` cannot be parsed back.
        """
        if self.kind == "chaospy" and self.params.get("expr") is None:
            raise ValueError(
                f"parameter {self.name!r}: chaospy distribution {self.dist!r} cannot be "
                f"serialised (its repr does not rebuild it); use a named kind instead"
            )
        out: dict[str, Any] = {"name": self.name} if with_name else {}
        out["dist"] = self.kind
        out.update({k: _json_number(v) for k, v in self.params.items()})
        return out

    def describe(self) -> str:
        """Short text such as ``normal(mean=1, std=0.1)``."""
        if self.kind == "chaospy":
            return repr(self.dist)
        if self.kind == "truncated":
            base = Marginal.from_spec(self.name, self.params["base"]).describe()
            lo, hi = self.params["lower"], self.params["upper"]
            return f"truncated({base}, lower={lo:g}, upper={hi:g})"
        args = ", ".join(f"{k}={v:g}" for k, v in self.params.items())
        return f"{self.kind}({args})"

    def __repr__(self) -> str:
        return f"{self.name} ~ {self.describe()}"


def _json_number(v: Any) -> Any:
    """Infinite bounds as the strings "inf"/"-inf" so the JSON stays standard."""
    if isinstance(v, float) and not math.isfinite(v):
        return "inf" if v > 0 else "-inf"
    return v


def _validate_params(name: str, kind: str, p: dict[str, float]) -> None:
    def need(cond: bool, msg: str) -> None:
        if not cond:
            raise ValueError(f"parameter {name!r}: {kind} {msg}")

    for k, v in p.items():
        if kind == "truncnormal" and k in ("lower", "upper"):
            continue
        need(math.isfinite(v), f"{k} must be finite, got {v!r}")
    if kind == "normal":
        need(p["std"] > 0, f"std must be > 0, got {p['std']!r}")
    elif kind == "lognormal":
        need(p["sigma"] > 0, f"sigma must be > 0, got {p['sigma']!r}")
    elif kind == "uniform":
        need(p["lower"] < p["upper"],
             f"lower {p['lower']!r} must be < upper {p['upper']!r}")
    elif kind == "loguniform":
        need(p["lower"] > 0, f"lower must be > 0, got {p['lower']!r}")
        need(p["lower"] < p["upper"],
             f"lower {p['lower']!r} must be < upper {p['upper']!r}")
    elif kind == "truncnormal":
        need(p["std"] > 0, f"std must be > 0, got {p['std']!r}")
        need(p["lower"] < p["upper"],
             f"lower {p['lower']!r} must be < upper {p['upper']!r}")
        mass = special.ndtr((p["upper"] - p["mean"]) / p["std"]) - special.ndtr(
            (p["lower"] - p["mean"]) / p["std"])
        need(mass > 1e-300,
             f"[{p['lower']:g}, {p['upper']:g}] holds no probability of normal(mean="
             f"{p['mean']:g}, std={p['std']:g})")
    elif kind in ("weibull", "gamma"):
        need(p["shape"] > 0, f"shape must be > 0, got {p['shape']!r}")
        need(p["scale"] > 0, f"scale must be > 0, got {p['scale']!r}")
    elif kind == "gumbel":
        need(p["scale"] > 0, f"scale must be > 0, got {p['scale']!r}")
    elif kind == "triangular":
        need(p["lower"] < p["upper"],
             f"lower {p['lower']!r} must be < upper {p['upper']!r}")
        need(p["lower"] <= p["mode"] <= p["upper"],
             f"mode {p['mode']!r} must lie in [lower, upper] = [{p['lower']!r}, {p['upper']!r}]")


def _build(kind: str, p: dict[str, float]) -> cp.Distribution:
    if kind == "normal":
        return cp.Normal(p["mean"], p["std"])
    if kind == "lognormal":
        return cp.LogNormal(p["mu"], p["sigma"], shift=p["shift"])
    if kind == "uniform":
        return cp.Uniform(p["lower"], p["upper"])
    if kind == "loguniform":
        # chaospy's LogUniform takes the bounds of ln X
        return cp.LogUniform(math.log(p["lower"]), math.log(p["upper"]))
    if kind == "truncnormal":
        return cp.TruncNormal(p["lower"], p["upper"], p["mean"], p["std"])
    if kind == "weibull":
        return cp.Weibull(p["shape"], p["scale"], p["shift"])
    if kind == "gumbel":
        return cp.LogWeibull(scale=p["scale"], shift=p["loc"])
    if kind == "triangular":
        return cp.Triangle(p["lower"], p["mode"], p["upper"])
    if kind == "gamma":
        return cp.Gamma(p["shape"], p["scale"], p["shift"])
    raise AssertionError(kind)  # pragma: no cover


_U_MIN = np.finfo(float).tiny
_U_MAX = 1.0 - 2.0**-53


def _scipy_equivalent(kind: str, p: Mapping[str, Any]) -> Any:
    """Frozen scipy.stats distribution equal to a named kind (None for other kinds)."""
    if kind == "normal":
        return stats.norm(p["mean"], p["std"])
    if kind == "lognormal":
        return stats.lognorm(p["sigma"], loc=p["shift"], scale=math.exp(p["mu"]))
    if kind == "uniform":
        return stats.uniform(p["lower"], p["upper"] - p["lower"])
    if kind == "loguniform":
        return stats.loguniform(p["lower"], p["upper"])
    if kind == "truncnormal":
        a = (p["lower"] - p["mean"]) / p["std"]
        b = (p["upper"] - p["mean"]) / p["std"]
        return stats.truncnorm(a, b, loc=p["mean"], scale=p["std"])
    if kind == "weibull":
        return stats.weibull_min(p["shape"], loc=p["shift"], scale=p["scale"])
    if kind == "gumbel":
        return stats.gumbel_r(p["loc"], p["scale"])
    if kind == "triangular":
        width = p["upper"] - p["lower"]
        return stats.triang((p["mode"] - p["lower"]) / width, loc=p["lower"], scale=width)
    if kind == "gamma":
        return stats.gamma(p["shape"], loc=p["shift"], scale=p["scale"])
    return None


def _numeric_moment(m: Marginal, k: int) -> float:
    from scipy import integrate

    val, _ = integrate.quad(lambda u: float(m.inv(np.array([u]))[0]) ** k, 0.0, 1.0, limit=200)
    return float(val)


# ------------------------------------------------------------------ chaospy repr handling
def _literal(node: ast.AST) -> Any:
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(
        node.value, bool
    ):
        return node.value
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        v = _literal(node.operand)
        return -v if isinstance(node.op, ast.USub) else v
    if isinstance(node, ast.Name) and node.id in ("inf", "nan"):
        return float(node.id)
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name):
            raise ValueError("only chaospy constructor calls are allowed")
        cls = getattr(cp, node.func.id, None)
        if not (isinstance(cls, type) and issubclass(cls, cp.Distribution)):
            raise ValueError(f"{node.func.id!r} is not a chaospy distribution")
        args = [_literal(a) for a in node.args]
        kwargs = {kw.arg: _literal(kw.value) for kw in node.keywords if kw.arg}
        return cls(*args, **kwargs)
    raise ValueError(f"unsupported expression element {ast.dump(node)[:60]}")


def _parse_chaospy_expr(name: str, expr: Any) -> cp.Distribution:
    """Rebuild a chaospy distribution from its repr without ``eval``."""
    if not isinstance(expr, str):
        raise ValueError(f"parameter {name!r}: chaospy expression must be a string, got {expr!r}")
    try:
        tree = ast.parse(expr, mode="eval")
        dist = _literal(tree.body)
    except Exception as exc:  # noqa: BLE001 - chaospy constructors raise various types
        raise ValueError(f"parameter {name!r}: cannot rebuild chaospy {expr!r}: {exc}") from None
    if not isinstance(dist, cp.Distribution) or len(dist) != 1:
        raise ValueError(f"parameter {name!r}: {expr!r} is not a univariate chaospy distribution")
    return dist


_RECOGNISED = {
    "Normal": ("normal", {"mu": "mean", "sigma": "std"}),
    "Uniform": ("uniform", {"lower": "lower", "upper": "upper"}),
    "TruncNormal": ("truncnormal", {"mu": "mean", "sigma": "std", "lower": "lower",
                                    "upper": "upper"}),
    "Weibull": ("weibull", {"shape": "shape", "scale": "scale", "shift": "shift"}),
    "LogWeibull": ("gumbel", {"shift": "loc", "scale": "scale"}),
    "Triangle": ("triangular", {"lower": "lower", "midpoint": "mode", "upper": "upper"}),
    "Gamma": ("gamma", {"shape": "shape", "scale": "scale", "shift": "shift"}),
    "LogNormal": ("lognormal", {"mu": "mu", "sigma": "sigma", "shift": "shift", "scale": None}),
}


def _recognise(name: str, dist: cp.Distribution) -> tuple[str, dict[str, float]] | None:
    """Map a plain chaospy distribution with numeric arguments to a named kind."""
    import inspect

    cls_name = type(dist).__name__
    if cls_name not in _RECOGNISED:
        return None
    try:
        call = ast.parse(repr(dist), mode="eval").body
        if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Name)
                and call.func.id == cls_name):
            return None
        args = [_literal(a) for a in call.args]
        kwargs = {kw.arg: _literal(kw.value) for kw in call.keywords if kw.arg}
        bound = inspect.signature(type(dist)).bind(*args, **kwargs)
        bound.apply_defaults()
    except (SyntaxError, ValueError, TypeError):
        return None
    values = dict(bound.arguments)
    if not all(isinstance(v, (int, float)) for v in values.values()):
        return None
    kind, mapping = _RECOGNISED[cls_name]
    if cls_name == "LogNormal" and values.get("scale", 1) != 1:
        return None
    params = {new: float(values[old]) for old, new in mapping.items() if new is not None}
    order = KINDS[kind][0] + tuple(KINDS[kind][1])
    return kind, {k: params[k] for k in order}


# =========================================================================== correlation
def _parse_correlation(corr: Any, names: list[str]) -> np.ndarray | None:
    d = len(names)
    if corr is None:
        return None
    if isinstance(corr, Mapping):
        r = np.eye(d)
        for key, value in corr.items():
            if not (isinstance(key, tuple) and len(key) == 2):
                raise ValueError(
                    f"correlation: mapping keys must be (name, name) pairs, got {key!r}"
                )
            a, b = key
            for nm in (a, b):
                if nm not in names:
                    raise ValueError(
                        f"correlation: unknown parameter {nm!r}; valid: {', '.join(names)}"
                    )
            if a == b:
                raise ValueError(f"correlation: pair ({a!r}, {b!r}) is a diagonal entry")
            i, j = names.index(a), names.index(b)
            v = float(value)
            r[i, j] = r[j, i] = v
        return r
    r = np.array(corr, dtype=float)
    if r.shape != (d, d):
        raise ValueError(
            f"correlation: expected a {d}x{d} matrix for parameters {names}, got shape {r.shape}"
        )
    return r


def _check_correlation(r: np.ndarray, names: list[str], what: str = "correlation") -> None:
    d = len(names)
    if not np.all(np.isfinite(r)):
        i, j = np.argwhere(~np.isfinite(r))[0]
        raise ValueError(f"{what}[{i}, {j}] ({names[i]!r}, {names[j]!r}) is not finite")
    for i in range(d):
        if abs(r[i, i] - 1.0) > 1e-12:
            raise ValueError(
                f"{what}: diagonal entry for {names[i]!r} is {float(r[i, i])!r}, must be 1"
            )
    asym = np.abs(r - r.T)
    if asym.max() > 1e-12:
        i, j = np.unravel_index(np.argmax(asym), asym.shape)
        raise ValueError(
            f"{what}: not symmetric: [{i}, {j}] ({names[i]!r}, {names[j]!r}) = "
            f"{float(r[i, j])!r} but [{j}, {i}] = {float(r[j, i])!r}"
        )
    off = np.abs(r - np.eye(d))
    if off.max() > 1.0:
        i, j = np.unravel_index(np.argmax(off), off.shape)
        raise ValueError(
            f"{what}: entry ({names[i]!r}, {names[j]!r}) = {float(r[i, j])!r} outside [-1, 1]"
        )
    try:
        np.linalg.cholesky(r)
    except np.linalg.LinAlgError:
        w = np.linalg.eigvalsh(r)
        raise ValueError(
            f"{what}: matrix is not positive definite (smallest eigenvalue {w.min():.3g}); "
            f"parameters {names}"
        ) from None


def _pearson_to_normal(mi: Marginal, mj: Marginal, rho: float, n_nodes: int = 48) -> float:
    """Nataf correction: normal-space correlation giving Pearson ``rho`` between mi and mj.

    Solves ``E[(X_i - m_i)(X_j - m_j)] / (s_i s_j) = rho`` for the correlation ``r`` of the
    underlying normals, the expectation by two-dimensional Gauss-Hermite quadrature.
    """
    if rho == 0.0:
        return 0.0
    z, w = np.polynomial.hermite_e.hermegauss(n_nodes)
    w = w / math.sqrt(2 * math.pi)
    gi = mi.from_normal(z)
    gj0 = mj.from_normal(z)
    ci = gi - w @ gi
    si = math.sqrt(w @ ci**2)
    mean_j = w @ gj0
    sj = math.sqrt(w @ (gj0 - mean_j) ** 2)

    def pearson(r: float) -> float:
        zz = r * z[:, None] + math.sqrt(max(1 - r * r, 0.0)) * z[None, :]
        gj = mj.from_normal(zz) - mean_j
        return float(w @ (ci[:, None] * gj) @ w) / (si * sj)

    lo, hi = pearson(-1.0), pearson(1.0)
    if not lo <= rho <= hi:
        raise ValueError(
            f"correlation: Pearson correlation {rho:g} between {mi.name!r} and {mj.name!r} is "
            f"not reachable with a Gaussian copula for these marginals; feasible range "
            f"[{lo:.6f}, {hi:.6f}]"
        )
    if rho == lo:
        return -1.0
    if rho == hi:
        return 1.0
    return float(optimize.brentq(lambda r: pearson(r) - rho, -1.0, 1.0, xtol=1e-13))


# =========================================================================== the space
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
        names = self.names
        if correlation_type not in CORRELATION_TYPES:
            raise ValueError(
                f"correlation_type: unknown {correlation_type!r}; valid: "
                f"{', '.join(CORRELATION_TYPES)}"
            )
        given = _parse_correlation(correlation, names)
        self._correlation_input: dict[str, Any] | None = None
        self._corr: np.ndarray | None = None
        self._chol: np.ndarray | None = None
        if given is None:
            return
        what = "correlation" if correlation_type == "normal" else f"{correlation_type} correlation"
        _check_correlation(given, names, what)
        if correlation_type == "normal":
            r = given
        else:
            self._correlation_input = {"type": correlation_type, "matrix": given.tolist()}
            r = np.eye(len(names))
            for i in range(len(names)):
                for j in range(i + 1, len(names)):
                    v = given[i, j]
                    if correlation_type == "spearman":
                        v = 2.0 * math.sin(math.pi * v / 6.0)
                    elif correlation_type == "kendall":
                        v = math.sin(math.pi * v / 2.0)
                    else:
                        v = _pearson_to_normal(self._marginals[names[i]],
                                               self._marginals[names[j]], float(v))
                    r[i, j] = r[j, i] = v
            _check_correlation(r, names, "correlation of the underlying normals (converted)")
        if np.array_equal(r, np.eye(len(names))):
            return
        self._corr = r
        self._chol = np.linalg.cholesky(r)

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
        model : Model or str
            The model (or registered model name); its ``parameters`` give the nominal values
            (used as means) and the valid ranges.
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
        if isinstance(model, str):
            from gearuq.registry import get_model

            model = get_model(model)
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
                rel = _num(name, "relative", "std", relative_std[name])
                if rel <= 0:
                    raise ValueError(f"parameter {name!r}: relative std must be > 0, got {rel!r}")
                if mean == 0:
                    raise ValueError(
                        f"parameter {name!r}: nominal is 0, a relative std is meaningless; "
                        f"give an absolute std instead"
                    )
                sd = rel * abs(mean)
            else:
                sd = _num(name, "absolute", "std", std[name])
                if sd <= 0:
                    raise ValueError(f"parameter {name!r}: std must be > 0, got {sd!r}")
            kind = dist.get(name, "normal") if isinstance(dist, Mapping) else dist
            m = _from_moments(name, str(kind), mean, sd, par.lower, par.upper)
            p_out = _mass_outside(m, par.lower, par.upper)
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
                    warnings.warn(msg, UserWarning, stacklevel=2)
                else:
                    m = m.truncate(par.lower, par.upper)
            marginals[name] = m
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
            k: _mass_outside(m, model.parameter(k).lower, model.parameter(k).upper)
            for k, m in self._marginals.items()
        }

    # ------------------------------------------------------------------ sampling
    def sample_unit(self, n: int, rule: str = "random", rng: _RNG = None) -> np.ndarray:
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
        n = _check_n(n)
        rule = _check_rule(rule)
        gen = as_generator(rng)
        d = self.dim
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
        z = special.ndtri(np.clip(u, _U_MIN, _U_MAX)) @ self._chol.T
        return {k: m.from_normal(z[:, j]) for j, (k, m) in enumerate(self._marginals.items())}

    def to_normal(self, x: Mapping[str, Any]) -> np.ndarray:
        """Map parameter values to the underlying correlated standard normals ``(n, dim)``."""
        cols = [special.ndtri(np.clip(self._marginals[k].cdf(x[k]), 0, 1)) for k in self.names]
        return np.column_stack(cols)

    def sample(self, n: int, rule: str = "random", rng: _RNG = None) -> dict[str, np.ndarray]:
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
        """Joint chaospy distribution.

        Returns ``chaospy.J(*marginals)`` for independent parameters and
        ``chaospy.Nataf(chaospy.J(*marginals), R)`` with ``R`` = :attr:`correlation` (the
        normal-space matrix) otherwise. ``Nataf.inv`` equals :meth:`transform` to round-off.
        Note that chaospy cannot compute moments or build orthogonal polynomials for the
        dependent ``Nataf`` distribution; polynomial chaos should work in the independent
        standard-normal space instead.
        """
        joint = cp.J(*(m.dist for m in self._marginals.values()))
        if self._corr is None:
            return joint
        return cp.Nataf(joint, self._corr)

    def to_salib(self, unsupported: str = "raise") -> dict[str, Any]:
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
            :meth:`from_salib`, which applies the inverse cdf to those columns. The problem
            then lists them in ``"gearuq_unit"``.

        Raises
        ------
        ValueError
            For a correlated space (SALib's Sobol' estimators assume independent inputs) or
            an unsupported kind with ``unsupported="raise"``.
        """
        if unsupported not in ("raise", "unit"):
            raise ValueError(f"unsupported: unknown {unsupported!r}; valid: raise, unit")
        if self._corr is not None:
            raise ValueError(
                "to_salib: SALib assumes independent inputs but this space has a correlation "
                "matrix; sample it with ParameterSpace.sample instead"
            )
        bounds: list[list[float]] = []
        dists: list[str] = []
        unit: list[str] = []
        for k, m in self._marginals.items():
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
            "num_vars": self.dim,
            "names": self.names,
            "bounds": bounds,
            "dists": dists,
        }
        if unit:
            problem["gearuq_unit"] = unit
        return problem

    def from_salib(self, x: Any, problem: Mapping[str, Any] | None = None) -> dict[str, np.ndarray]:
        """Turn a SALib sample matrix ``(N, dim)`` into a parameter dict.

        Columns listed in ``problem["gearuq_unit"]`` (see :meth:`to_salib`) are probabilities
        and go through the marginal's inverse cdf; the others are already physical values.
        """
        x = np.asarray(x, dtype=float)
        if x.ndim != 2 or x.shape[1] != self.dim:
            raise ValueError(f"from_salib: expected shape (N, {self.dim}), got {x.shape}")
        unit = set((problem or {}).get("gearuq_unit", ()))
        return {
            k: (self._marginals[k].inv(x[:, j]) if k in unit else x[:, j].copy())
            for j, k in enumerate(self.names)
        }

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


# =========================================================================== builder helpers
def _pair(name: str, v: Any) -> tuple[float, float]:
    if not (isinstance(v, Sequence) and len(v) == 2):
        raise ValueError(f"parameter {name!r}: expected a pair of numbers, got {v!r}")
    return v[0], v[1]


def _check_rule(rule: Any) -> str:
    if not isinstance(rule, str) or rule.lower() not in RULES:
        raise ValueError(f"rule: unknown sampling rule {rule!r}; valid: {', '.join(RULES)}")
    return rule.lower()


def _mass_outside(m: Marginal, lower: float, upper: float) -> float:
    p = 0.0
    if math.isfinite(lower):
        p += float(m.cdf(lower))
    if math.isfinite(upper):
        p += 1.0 - float(m.cdf(upper))
    return max(p, 0.0)


def _from_moments(
    name: str, kind: str, mean: float, sd: float, lower: float, upper: float
) -> Marginal:
    """Marginal of kind ``kind`` with the given mean and standard deviation."""
    k = _canonical_kind(name, kind)
    if k == "normal":
        spec = {"dist": "normal", "mean": mean, "std": sd}
    elif k == "lognormal":
        spec = {"dist": "lognormal", "mean": mean, "std": sd}
    elif k == "uniform":
        h = math.sqrt(3.0) * sd
        spec = {"dist": "uniform", "lower": mean - h, "upper": mean + h}
    elif k == "gumbel":
        scale = sd * math.sqrt(6.0) / math.pi
        spec = {"dist": "gumbel", "loc": mean - np.euler_gamma * scale, "scale": scale}
    elif k == "weibull":
        if mean <= 0:
            raise ValueError(f"parameter {name!r}: Weibull needs a positive mean, got {mean!r}")
        shape = _weibull_shape_from_cov(name, sd / mean)
        scale = mean / math.exp(special.gammaln(1 + 1 / shape))
        spec = {"dist": "weibull", "shape": shape, "scale": scale}
    elif k == "truncnormal":
        spec = {"dist": "truncnormal", "mean": mean, "std": sd, "lower": lower, "upper": upper}
    else:
        raise ValueError(
            f"parameter {name!r}: around_nominal supports normal, lognormal, uniform, gumbel, "
            f"weibull, truncnormal; got {kind!r}"
        )
    return Marginal.from_spec(name, spec)

