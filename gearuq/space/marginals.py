"""Univariate marginals: named distribution kinds on chaospy, with closed-form quantiles.

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
import math
from collections.abc import Mapping
from typing import Any

import chaospy as cp
import numpy as np
from scipy import optimize, special, stats

__all__ = ["Marginal", "KINDS", "as_number", "mass_outside", "from_moments", "U_MIN", "U_MAX"]

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


def as_number(name: str, kind: str, key: str, value: Any) -> float:
    """``value`` as a float, or a ValueError naming the parameter, kind and key."""
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
            mean = as_number(name, kind, "mean", spec.pop("mean"))
            std = as_number(name, kind, "std", spec.pop("std"))
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
        params = {k: as_number(name, kind, k, spec[k]) for k in required}
        for k, default in optional.items():
            params[k] = as_number(name, kind, k, spec.get(k, default))
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
        lower = as_number(name, "truncated", "lower", spec.get("lower", -math.inf))
        upper = as_number(name, "truncated", "upper", spec.get("upper", math.inf))
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
        u = np.clip(np.asarray(u, dtype=float), U_MIN, U_MAX)
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
                                                   U_MIN, U_MAX)), dtype=float)
            if np.any(upper):
                q = np.clip(special.ndtr(-z[upper]), U_MIN, U_MAX)
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


U_MIN = np.finfo(float).tiny
U_MAX = 1.0 - 2.0**-53


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
    if kind == "truncated":
        try:  # the base marginal's own scipy equivalent, if its kind has one
            base_scipy = Marginal.from_spec("base", p["base"])._scipy
        except (TypeError, ValueError):
            base_scipy = None
        if base_scipy is not None:
            return _TruncatedFrozen(base_scipy, p["lower"], p["upper"])
    return None


class _TruncatedFrozen:
    """A scipy.stats frozen distribution truncated to ``[lower, upper]``, in closed form.

    ``ppf(u) = F^-1(F(a) + u (F(b) - F(a)))`` and, for the upper tail, ``isf(q) = S^-1(S(b)
    + q (S(a) - S(b)))``. chaospy's ``Trunc`` inverts numerically and was off by percents
    (a Gumbel(3, 2) truncated to [2, 9]: 9.0 at 0.999 where the exact quantile is 8.968).
    """

    def __init__(self, base: Any, lower: float, upper: float) -> None:
        self.base, self.lower, self.upper = base, float(lower), float(upper)
        self.f_lo = float(base.cdf(lower)) if math.isfinite(lower) else 0.0
        self.f_hi = float(base.cdf(upper)) if math.isfinite(upper) else 1.0
        self.s_lo = float(base.sf(lower)) if math.isfinite(lower) else 1.0
        self.s_hi = float(base.sf(upper)) if math.isfinite(upper) else 0.0
        self.mass = self.s_lo - self.s_hi

    def ppf(self, u: Any) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        x = self.base.ppf(self.f_lo + u * (self.f_hi - self.f_lo))
        return np.clip(x, self.lower, self.upper)

    def isf(self, q: Any) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        return np.clip(self.base.isf(self.s_hi + q * self.mass), self.lower, self.upper)

    def cdf(self, x: Any) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        return np.clip((self.base.cdf(x) - self.f_lo) / (self.f_hi - self.f_lo), 0.0, 1.0)

    def pdf(self, x: Any) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        inside = (x >= self.lower) & (x <= self.upper)
        return np.where(inside, self.base.pdf(x) / self.mass, 0.0)

    def _moment(self, k: int) -> float:
        return float(self.base.expect(lambda v: v**k, lb=self.lower, ub=self.upper,
                                      conditional=True))

    def mean(self) -> float:
        return self._moment(1)

    def std(self) -> float:
        m = self._moment(1)
        return math.sqrt(max(self._moment(2) - m * m, 0.0))


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



def mass_outside(m: Marginal, lower: float, upper: float) -> float:
    """Probability ``m`` puts outside ``[lower, upper]``."""
    p = 0.0
    if math.isfinite(lower):
        p += float(m.cdf(lower))
    if math.isfinite(upper):
        p += 1.0 - float(m.cdf(upper))
    return max(p, 0.0)


def from_moments(
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
