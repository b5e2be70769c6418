"""OpenTURNS interoperability: gearuq models and spaces in OpenTURNS, and back.

Needs the optional extra ``pip install gearuq[openturns]``.

* :func:`to_openturns_function` -- a gearuq model over the parameters of a
  :class:`~gearuq.space.ParameterSpace` as an ``ot.Function`` (vectorised: one OpenTURNS
  sample is one call of the model), so that any OpenTURNS algorithm (FORM, SORM, Monte
  Carlo on an event, subset sampling, chaos, Sobol' indices...) runs on a gear model;
* :func:`to_openturns_distribution` -- a :class:`~gearuq.space.ParameterSpace` as an
  ``ot.JointDistribution`` (``ot.ComposedDistribution`` before OpenTURNS 1.24), marginals and
  copula;
* :func:`from_openturns_distribution` -- an OpenTURNS distribution as a
  :class:`~gearuq.space.ParameterSpace`.

Marginals
---------
===================================  ===================================================
gearuq kind (parameters)             OpenTURNS distribution
===================================  ===================================================
normal (mean, std)                   ``Normal(mean, std)``
lognormal (mu, sigma, shift)         ``LogNormal(mu, sigma, shift)``
uniform (lower, upper)               ``Uniform(lower, upper)``
loguniform (lower, upper)            ``LogUniform(ln lower, ln upper)``
truncnormal (mean, std, lower,       ``TruncatedNormal(mean, std, lower, upper)`` (a
upper)                               ``TruncatedDistribution`` of a ``Normal`` when a
                                     bound is infinite)
weibull (shape, scale, shift)        ``WeibullMin(scale, shape, shift)``
gumbel (loc, scale), maximum         ``Gumbel(scale, loc)``
triangular (lower, mode, upper)      ``Triangular(lower, mode, upper)``
gamma (shape, scale, shift)          ``Gamma(shape, 1 / scale, shift)``; an OpenTURNS
                                     ``Exponential(lambda, gamma)`` comes back as gamma
                                     with shape 1
truncated (base, lower, upper)       ``TruncatedDistribution(base, bounds)``
===================================  ===================================================

A gearuq marginal of kind ``"chaospy"`` (an arbitrary chaospy distribution) has no
OpenTURNS counterpart and raises a ValueError, as does any OpenTURNS marginal outside the
table (Beta, Student, WeibullMax, Histogram, KernelMixture...).

Copula
------
A gearuq space is independent or has a Gaussian copula whose matrix
:attr:`~gearuq.space.ParameterSpace.correlation` is the correlation of the underlying
standard normals ``z = Phi^-1(F(x))``. That is exactly the matrix ``ot.NormalCopula(R)``
takes (its ``getShapeMatrix()``; not its Spearman or its Pearson correlation, which differ:
Spearman ``(6 / pi) asin(R / 2)``). Going back, ``IndependentCopula``, ``NormalCopula`` and
block-diagonal compositions of them (``BlockIndependentCopula``, ``ComposedCopula``) are
supported; any other copula (Clayton, Gumbel, Frank, Student...) raises a ValueError.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from gearuq.model import Model, Request, status_meanings
from gearuq.space import Marginal, ParameterSpace

__all__ = ["to_openturns_function", "to_openturns_distribution", "from_openturns_distribution",
           "SUPPORTED_MARGINALS", "SUPPORTED_COPULAS", "REDUCTIONS"]

#: OpenTURNS marginals :func:`from_openturns_distribution` understands -> gearuq kind.
SUPPORTED_MARGINALS = {
    "Normal": "normal",
    "LogNormal": "lognormal",
    "Uniform": "uniform",
    "LogUniform": "loguniform",
    "TruncatedNormal": "truncnormal",
    "WeibullMin": "weibull",
    "Gumbel": "gumbel",
    "Triangular": "triangular",
    "Gamma": "gamma",
    "Exponential": "gamma",
    "TruncatedDistribution": "truncated",
}

#: OpenTURNS copulas :func:`from_openturns_distribution` understands.
SUPPORTED_COPULAS = ("IndependentCopula", "NormalCopula",
                     "BlockIndependentCopula / ComposedCopula of these")

#: Named reductions of a time-dependent output (a number means the value at that instant).
REDUCTIONS = ("max", "min")

#: Relative finite-difference steps (times each marginal's standard deviation) of the
#: gradient and Hessian attached to the function.
GRADIENT_STEP = 1e-5
HESSIAN_STEP = 1e-4


def _openturns() -> Any:
    """The openturns module, or an ImportError that says how to install it."""
    try:
        import openturns
    except ImportError:
        raise ImportError(
            "gearuq.interop.openturns needs OpenTURNS: pip install gearuq[openturns] "
            "(or pip install openturns)"
        ) from None
    return openturns


def _joint_class(ot: Any) -> Any:
    """``ot.JointDistribution`` (OpenTURNS >= 1.24) or its older name ComposedDistribution."""
    cls = getattr(ot, "JointDistribution", None)
    return cls if cls is not None else ot.ComposedDistribution


# =========================================================================== function
class _Evaluator:
    """The callable behind the OpenTURNS function: one model call per OpenTURNS sample."""

    def __init__(self, model: Model, request: Request, inputs: list[str], outputs: list[str],
                 reducers: dict[str, Any]) -> None:
        self.model = model
        self.request = request
        self.inputs = inputs
        self.outputs = outputs
        self.reducers = reducers

    def sample(self, x: Any) -> np.ndarray:
        x = np.asarray(x, dtype=float).reshape(-1, len(self.inputs))
        n = x.shape[0]
        if n == 0:
            return np.zeros((0, len(self.outputs)))
        params = {name: x[:, j] for j, name in enumerate(self.inputs)}
        ds = self.model.evaluate(params, self.request)
        status = np.asarray(ds["status"].values, dtype=int)
        failed = np.flatnonzero(status != 0)
        if failed.size:
            i = int(failed[0])
            meanings = status_meanings(ds["status"])
            point = ", ".join(f"{k}={x[i, j]:.17g}" for j, k in enumerate(self.inputs))
            # OpenTURNS has no per-sample status: stop rather than hand it a made-up value
            raise RuntimeError(
                f"model {self.model.name!r}: {failed.size} of {n} sample(s) failed; first: "
                f"sample {i} ({point}) with status {status[i]} "
                f"({meanings.get(status[i], 'unknown')})"
            )
        cols = []
        for o in self.outputs:
            v = np.asarray(ds[o].values, dtype=float)
            reducer = self.reducers.get(o)
            cols.append(v if reducer is None else reducer(v))
        return np.column_stack(cols)

    def point(self, x: Any) -> list[float]:
        return self.sample(np.asarray(x, dtype=float)[None, :])[0].tolist()


def _reducers(model: Model, outputs: list[str], t: np.ndarray | None,
              reduce: Any) -> dict[str, Any]:
    """Per time-dependent output, a function ``(n, n_t) -> (n,)``; or a ValueError."""
    timed = []
    for o in outputs:
        dims = tuple(model.output(o).dims)
        if dims == ("sample",):
            continue
        if dims != ("sample", "time"):
            raise ValueError(
                f"outputs: {o!r} of model {model.name!r} has dims {dims}; an OpenTURNS "
                f"function output must be one number per sample (dims ('sample',)) or a time "
                f"series ('sample', 'time') reduced by reduce="
            )
        timed.append(o)
    if not timed:
        if reduce is not None:
            raise ValueError(
                f"reduce: {reduce!r} given but no requested output is time-dependent "
                f"({', '.join(outputs)}); leave reduce=None"
            )
        return {}
    valid = "'max', 'min' or an instant of t (a number)"
    if reduce is None:
        raise ValueError(
            f"reduce: output(s) {', '.join(map(repr, timed))} of model {model.name!r} are "
            f"time-dependent and an OpenTURNS function returns one number per output; give "
            f"reduce={valid}"
        )
    if isinstance(reduce, str):
        key = reduce.strip().lower()
        if key == "max":
            fn = _max
        elif key == "min":
            fn = _min
        else:
            raise ValueError(f"reduce: unknown reduction {reduce!r}; valid: {valid}")
        return {o: fn for o in timed}
    if isinstance(reduce, (bool, np.bool_)) or not isinstance(
            reduce, (int, float, np.integer, np.floating)):
        raise ValueError(f"reduce: expected {valid}, got {reduce!r}")
    instant = float(reduce)
    assert t is not None  # prepare() demands t for time-dependent outputs
    span = float(t[-1] - t[0]) if t.size > 1 else abs(float(t[0]))
    hit = np.flatnonzero(np.abs(t - instant) <= 1e-12 * max(span, 1.0))
    if not math.isfinite(instant) or hit.size == 0:
        raise ValueError(
            f"reduce: instant {reduce!r} is not one of the output instants t "
            f"({t.size} in [{t[0]:g}, {t[-1]:g}]); add it to t"
        )
    j = int(hit[0])
    return {o: (lambda v, j=j: v[:, j]) for o in timed}


def _max(v: np.ndarray) -> np.ndarray:
    return v.max(axis=1)


def _min(v: np.ndarray) -> np.ndarray:
    return v.min(axis=1)


def to_openturns_function(
    model: Model | str,
    space: ParameterSpace,
    outputs: str | Iterable[str],
    t: Any = None,
    reduce: str | float | None = None,
    **model_options: Any,
) -> Any:
    """A gearuq model as an OpenTURNS function of the space's parameters.

    Parameters
    ----------
    model : Model or str
        A model instance or a registered model name.
    space : ParameterSpace
        Its parameter names, in order, are the function's inputs (the ``input`` of
        :func:`to_openturns_distribution` of the same space). The model's other parameters
        keep their nominal values.
    outputs : str or list of str
        The function's outputs, in this order: outputs with one value per sample, or
        time-dependent outputs reduced to one value by ``reduce``.
    t : array_like, optional
        Output instants (required when a time-dependent output is asked for).
    reduce : {"max", "min"} or float, optional
        How a time-dependent output becomes one number per sample: its maximum or minimum
        over ``t``, or its value at the instant given (which must be one of ``t``). Required
        when an output is time-dependent, refused otherwise.
    **model_options
        Declared model options (solver or fidelity settings), validated here, once.

    Returns
    -------
    openturns.Function
        A ``PythonFunction`` with a vectorised ``func_sample`` (an OpenTURNS sample of
        ``n`` points is one model call on ``n`` samples), input and output descriptions set to
        the names, and centred finite-difference gradient and Hessian whose step for each
        input is ``1e-5`` (gradient) and ``1e-4`` (Hessian) times its standard deviation in
        ``space``, so parameters of any scale (a backlash of 2e-5 m, a speed of 4000 rpm) get
        a sensible step.

    Raises
    ------
    ValueError
        A space parameter the model does not have, an unknown output, an output with other
        dimensions than ``sample`` (and ``time``), a missing or unknown ``reduce``, or a bad
        model option (all before anything is evaluated).
    RuntimeError
        At evaluation, when a sample fails (model status not 0): OpenTURNS has no per-sample
        status, so the evaluation stops, naming the sample and the status, rather than return
        an invented number.

    Examples
    --------
    >>> import openturns as ot
    >>> from gearuq.testing.reliability_problems import (
    ...     resistance_load_model, resistance_load_space)
    >>> f = to_openturns_function(resistance_load_model(), resistance_load_space(), "g")
    >>> f([10.0, 4.0])
    class=Point name=Unnamed dimension=1 values=[6]
    """
    ot = _openturns()
    if isinstance(model, str):
        from gearuq.registry import get_model

        model = get_model(model)
    if not isinstance(model, Model):
        raise ValueError(f"model: expected a gearuq Model or a registered model name, got "
                         f"{type(model).__name__} {model!r}")
    if not isinstance(space, ParameterSpace):
        raise ValueError(f"space: expected a gearuq ParameterSpace, got {type(space).__name__}")
    inputs = space.names
    unknown = [k for k in inputs if k not in model.parameter_names]
    if unknown:
        raise ValueError(
            f"space: parameter(s) {', '.join(map(repr, unknown))} are not parameters of model "
            f"{model.name!r}; valid: {', '.join(model.parameter_names)}"
        )
    if outputs is None:
        raise ValueError(f"outputs: name the output(s) of the function; valid: "
                         f"{', '.join(model.output_names)}")
    request = model.prepare(t, outputs=outputs, **model_options)
    names = list(request.outputs)
    evaluator = _Evaluator(model, request, inputs, names,
                           _reducers(model, names, request.t, reduce))
    fn = ot.PythonFunction(len(inputs), len(names), func=evaluator.point,
                           func_sample=evaluator.sample)
    fn.setInputDescription(inputs)
    fn.setOutputDescription(names)
    fn.setName(model.name)
    scale = []
    for k in inputs:
        s = space.marginal(k).std()
        scale.append(s if math.isfinite(s) and s > 0 else 1.0)
    scale = np.asarray(scale)
    fn.setGradient(ot.CenteredFiniteDifferenceGradient(
        ot.Point(GRADIENT_STEP * scale), fn.getEvaluation()))
    fn.setHessian(ot.CenteredFiniteDifferenceHessian(
        ot.Point(HESSIAN_STEP * scale), fn.getEvaluation()))
    return fn


# =========================================================================== distributions
def _marginal_to_ot(ot: Any, m: Marginal) -> Any:
    """The OpenTURNS distribution of one gearuq marginal, or a ValueError."""
    p, kind = m.params, m.kind
    if kind == "normal":
        return ot.Normal(p["mean"], p["std"])
    if kind == "lognormal":
        return ot.LogNormal(p["mu"], p["sigma"], p["shift"])
    if kind == "uniform":
        return ot.Uniform(p["lower"], p["upper"])
    if kind == "loguniform":
        return ot.LogUniform(math.log(p["lower"]), math.log(p["upper"]))
    if kind == "truncnormal":
        lo, hi = p["lower"], p["upper"]
        if math.isfinite(lo) and math.isfinite(hi):
            return ot.TruncatedNormal(p["mean"], p["std"], lo, hi)
        return _truncate(ot, ot.Normal(p["mean"], p["std"]), lo, hi)
    if kind == "weibull":
        return ot.WeibullMin(p["scale"], p["shape"], p["shift"])
    if kind == "gumbel":
        return ot.Gumbel(p["scale"], p["loc"])
    if kind == "triangular":
        return ot.Triangular(p["lower"], p["mode"], p["upper"])
    if kind == "gamma":
        return ot.Gamma(p["shape"], 1.0 / p["scale"], p["shift"])
    if kind == "truncated":
        base = Marginal.from_spec(m.name, p["base"])
        return _truncate(ot, _marginal_to_ot(ot, base), float(p["lower"]), float(p["upper"]))
    raise ValueError(
        f"parameter {m.name!r}: {m.describe()} (kind {kind!r}) has no OpenTURNS counterpart; "
        f"supported kinds: normal, lognormal, uniform, loguniform, truncnormal, weibull, "
        f"gumbel, triangular, gamma, truncated (of these)"
    )


def _truncate(ot: Any, base: Any, lower: float, upper: float) -> Any:
    """``base`` truncated to ``[lower, upper]`` (either bound may be infinite)."""
    td = ot.TruncatedDistribution
    if math.isfinite(lower) and math.isfinite(upper):
        return td(base, lower, upper)
    if math.isfinite(lower):
        return td(base, lower, td.LOWER)
    if math.isfinite(upper):
        return td(base, upper, td.UPPER)
    return base


def to_openturns_distribution(space: ParameterSpace) -> Any:
    """A gearuq parameter space as an OpenTURNS joint distribution.

    Parameters
    ----------
    space : ParameterSpace
        Marginals of the kinds in the module docstring; independent or with a Gaussian
        copula.

    Returns
    -------
    openturns.JointDistribution
        (``ot.ComposedDistribution`` on OpenTURNS < 1.24.) The marginals in the space's
        order, described by the parameter names; the copula is ``IndependentCopula`` or
        ``NormalCopula(R)`` with ``R`` = :attr:`ParameterSpace.correlation`, the correlation
        of the underlying standard normals (which is what ``NormalCopula`` takes: its shape
        matrix, not its Spearman correlation).

    Raises
    ------
    ValueError
        A marginal without an OpenTURNS counterpart (kind ``"chaospy"``), naming the
        parameter and listing the supported kinds.

    Examples
    --------
    >>> space = ParameterSpace.normal(x=(0.0, 1.0), y=(1.0, 2.0))
    >>> d = to_openturns_distribution(space)
    >>> list(d.getDescription()), list(d.getMean())
    (['x', 'y'], [0.0, 1.0])
    """
    ot = _openturns()
    if not isinstance(space, ParameterSpace):
        raise ValueError(f"space: expected a gearuq ParameterSpace, got {type(space).__name__}")
    marginals = []
    for name in space.names:
        d = _marginal_to_ot(ot, space.marginal(name))
        d.setDescription([name])
        marginals.append(d)
    r = space.correlation
    if r is None:
        copula = ot.IndependentCopula(space.dim)
    else:
        copula = ot.NormalCopula(ot.CorrelationMatrix(r.tolist()))
    joint = _joint_class(ot)(marginals, copula)
    joint.setDescription(space.names)
    return joint


def _impl(ot: Any, d: Any) -> Any:
    """The implementation of an ``ot.Distribution`` wrapper (itself otherwise): an object of
    the concrete class (``ot.Normal``, ``ot.TruncatedDistribution``...), with its getters.

    A cast such as ``ot.TruncatedDistribution(d)`` would be ambiguous (OpenTURNS < 1.24 reads
    it as "truncate d to its own range")."""
    return d.getImplementation() if isinstance(d, ot.Distribution) else d


def _marginal_spec(ot: Any, name: str, d: Any) -> dict[str, Any]:
    """A gearuq spec dict of a univariate OpenTURNS distribution, or a ValueError."""
    impl = _impl(ot, d)  # the concrete class: ot.Normal, ot.Gumbel...
    cls = impl.getClassName()
    if cls == "Normal":
        return {"dist": "normal", "mean": impl.getMean()[0],
                "std": impl.getStandardDeviation()[0]}
    if cls == "LogNormal":
        return {"dist": "lognormal", "mu": impl.getMuLog(), "sigma": impl.getSigmaLog(),
                "shift": impl.getGamma()}
    if cls == "Uniform":
        return {"dist": "uniform", "lower": impl.getA(), "upper": impl.getB()}
    if cls == "LogUniform":
        return {"dist": "loguniform", "lower": math.exp(impl.getALog()),
                "upper": math.exp(impl.getBLog())}
    if cls == "TruncatedNormal":
        return {"dist": "truncnormal", "mean": impl.getMu(), "std": impl.getSigma(),
                "lower": impl.getA(), "upper": impl.getB()}
    if cls == "WeibullMin":
        return {"dist": "weibull", "shape": impl.getAlpha(), "scale": impl.getBeta(),
                "shift": impl.getGamma()}
    if cls == "Gumbel":
        return {"dist": "gumbel", "loc": impl.getGamma(), "scale": impl.getBeta()}
    if cls == "Triangular":
        return {"dist": "triangular", "lower": impl.getA(), "mode": impl.getM(),
                "upper": impl.getB()}
    if cls == "Gamma":
        return {"dist": "gamma", "shape": impl.getK(), "scale": 1.0 / impl.getLambda(),
                "shift": impl.getGamma()}
    if cls == "Exponential":
        return {"dist": "gamma", "shape": 1.0, "scale": 1.0 / impl.getLambda(),
                "shift": impl.getGamma()}
    if cls == "TruncatedDistribution":
        bounds = impl.getBounds()
        lower = bounds.getLowerBound()[0] if bounds.getFiniteLowerBound()[0] else -math.inf
        upper = bounds.getUpperBound()[0] if bounds.getFiniteUpperBound()[0] else math.inf
        base = _marginal_spec(ot, name, impl.getDistribution())
        if base["dist"] == "normal":
            return {"dist": "truncnormal", "mean": base["mean"], "std": base["std"],
                    "lower": lower, "upper": upper}
        return {"dist": "truncated", "base": base, "lower": lower, "upper": upper}
    raise ValueError(
        f"parameter {name!r}: OpenTURNS marginal {cls} ({impl}) has no gearuq counterpart; "
        f"supported: {', '.join(SUPPORTED_MARGINALS)}"
    )


def _normal_copula_matrix(ot: Any, copula: Any) -> np.ndarray | None:
    """Shape matrix of a Gaussian (or independent) copula; None when it is not one."""
    impl = _impl(ot, copula)
    cls = impl.getClassName()
    dim = impl.getDimension()
    if cls == "IndependentCopula":
        return np.eye(dim)
    if cls == "NormalCopula":
        return np.array(impl.getShapeMatrix(), dtype=float)
    if cls in ("BlockIndependentCopula", "ComposedCopula"):
        r = np.eye(dim)
        start = 0
        for block in impl.getCopulaCollection():
            sub = _normal_copula_matrix(ot, block)
            if sub is None:
                return None
            k = sub.shape[0]
            r[start:start + k, start:start + k] = sub
            start += k
        return r
    return None


def from_openturns_distribution(dist: Any, names: Iterable[str] | None = None
                                ) -> ParameterSpace:
    """An OpenTURNS distribution as a gearuq parameter space.

    Parameters
    ----------
    dist : openturns.Distribution
        A joint distribution (``JointDistribution``/``ComposedDistribution``, a multivariate
        ``Normal``...) or a univariate one, with marginals from the module docstring's table
        and an independent or normal copula (or a block-independent composition of them).
    names : iterable of str, optional
        Parameter names in order; default: the distribution's description, which must then
        be distinct Python identifiers (OpenTURNS' default ``X0, X1, ...`` are).

    Returns
    -------
    ParameterSpace
        The marginals and, for a normal copula, its shape matrix as the correlation of the
        underlying standard normals (``correlation_type="normal"``).

    Raises
    ------
    ValueError
        Not an OpenTURNS distribution, names that do not fit, or a marginal or copula that
        gearuq cannot represent (the message names it and lists the supported ones).

    Examples
    --------
    >>> import openturns as ot
    >>> d = ot.JointDistribution([ot.Normal(1.0, 0.1), ot.Gumbel(2.0, 3.0)])
    >>> d.setDescription(["a", "b"])
    >>> from_openturns_distribution(d)
    ParameterSpace(a ~ normal(mean=1, std=0.1); b ~ gumbel(loc=3, scale=2); independent)
    """
    ot = _openturns()
    if not isinstance(dist, (ot.Distribution, ot.DistributionImplementation)):
        raise ValueError(f"dist: expected an OpenTURNS distribution, got "
                         f"{type(dist).__name__} {dist!r}")
    dim = dist.getDimension()
    if names is None:
        labels = list(dist.getDescription())
        if len(labels) != dim or len(set(labels)) != dim or not all(
                isinstance(s, str) and s.isidentifier() for s in labels):
            raise ValueError(
                f"dist: its description {labels} is not {dim} distinct identifiers to name the "
                f"parameters; set it (dist.setDescription([...])) or pass names="
            )
    else:
        labels = [str(s) for s in names] if not isinstance(names, str) else [names]
        if len(labels) != dim:
            raise ValueError(f"names: expected {dim} names for a {dim}-D distribution, got "
                             f"{len(labels)}: {labels}")
        if len(set(labels)) != dim:
            raise ValueError(f"names: duplicate names in {labels}")
    marginals: Mapping[str, Any] = {
        name: _marginal_spec(ot, name, dist.getMarginal(i)) for i, name in enumerate(labels)}
    copula = dist.getCopula()
    r = _normal_copula_matrix(ot, copula)
    if r is None:
        cls = _impl(ot, copula).getClassName()
        raise ValueError(
            f"dist: copula {cls} ({copula}) has no gearuq counterpart (gearuq spaces are "
            f"independent or have a Gaussian copula); supported: "
            f"{', '.join(SUPPORTED_COPULAS)}"
        )
    corr = None if np.array_equal(r, np.eye(dim)) else r
    return ParameterSpace(dict(marginals), corr)
