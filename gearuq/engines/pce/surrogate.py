"""The polynomial chaos surrogate: settings, fit on labelled data, analytic results, storage.

:class:`PolynomialChaos` follows the estimator pattern: its constructor takes the space and
the fitting settings, :meth:`PolynomialChaos.fit` takes data (a labelled Monte Carlo
Dataset, or arrays) and returns the fitted surrogate, whose state is one
:class:`ChaosFit`. A fitted surrogate is a :class:`gearuq.model.Model` itself, gives moments
and Sobol' indices from its coefficients, and round-trips through
:meth:`~PolynomialChaos.to_dataset` / :meth:`~PolynomialChaos.from_dataset` (and so through
netCDF).
"""

from __future__ import annotations

import json
import math
import time
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from gearuq._version import __version__
from gearuq.engines.pce.basis import GERMS, Germ, basis_matrix, multi_indices, q_norm
from gearuq.engines.pce.regression import (
    SOLVERS,
    corrected_loo,
    few_blas_threads,
    fit_columns,
    least_squares,
    loo_residuals,
    pca,
    relative_error,
)
from gearuq.model import STATUS_NONFINITE, Evaluation, Model, Output, Parameter
from gearuq.space import ParameterSpace

__all__ = ["PolynomialChaos", "ChaosSettings", "ChaosFit", "OutputInfo", "METHODS"]

#: Fitting methods.
METHODS = ("regression", "sparse", "quadrature")
#: Rows of the basis matrix evaluated at once when predicting (bounds the memory).
_PREDICT_CHUNK = 20_000
#: ``order="auto"`` stops after this many degrees in a row without a smaller error.
_DEGREE_PATIENCE = 2

_SPARSE_NOTE = (
    "the LOO error of a sparse basis is optimistic: the basis was chosen to make it small "
    "(selection bias; on Ishigami the hold-out error is about 2x the corrected LOO); judge a "
    "sparse surrogate by its hold-out error (n_holdout=, validate())")


@dataclass(frozen=True)
class ChaosSettings:
    """How a chaos expansion is fitted (the estimator's hyper-parameters).

    Attributes
    ----------
    order : int or "auto"
        Total degree, or ``"auto"``: the degree in ``1..max_order`` with the smallest
        leave-one-out error (``"regression"``) or corrected leave-one-out error
        (``"sparse"``), tried upwards and stopped after two degrees without improvement.
    method : {"regression", "sparse", "quadrature"}
        Least squares, sparse least squares (hybrid LAR/OMP), or spectral projection with
        quadrature weights.
    truncation : float
        Hyperbolic q-norm of the basis, in (0, 1].
    max_order : int
        Largest degree tried by ``order="auto"``.
    solver : {"lars", "omp"}
        Greedy path of the sparse method.
    compress : int or float, optional
        PCA across the non-sample dims of each output: a number of components or an energy
        fraction in (0, 1].
    germ : {"auto", "normal"}
        Legendre germ for independent uniform marginals (``"auto"``) or Hermite everywhere.
    """

    order: int | str = "auto"
    method: str = "regression"
    truncation: float = 1.0
    max_order: int = 6
    solver: str = "lars"
    compress: int | float | None = None
    germ: str = "auto"

    def __post_init__(self) -> None:
        object.__setattr__(self, "order", check_order(self.order))
        if self.method not in METHODS:
            raise ValueError(f"method: unknown {self.method!r}; valid: {', '.join(METHODS)}")
        if self.solver not in SOLVERS:
            raise ValueError(f"solver: unknown {self.solver!r}; valid: {', '.join(SOLVERS)}")
        if self.germ not in GERMS:
            raise ValueError(f"germ: unknown {self.germ!r}; valid: {', '.join(GERMS)}")
        if self.order == "auto" and self.method == "quadrature":
            raise ValueError("order='auto' needs method 'regression' or 'sparse' (a LOO error)")
        if isinstance(self.truncation, bool) or not isinstance(self.truncation, (int, float)) \
                or not 0 < float(self.truncation) <= 1:
            raise ValueError(f"truncation: q-norm must lie in (0, 1], got {self.truncation!r}")
        if isinstance(self.max_order, bool) or not isinstance(self.max_order, (int, np.integer)) \
                or self.max_order < 1:
            raise ValueError(f"max_order: expected an integer >= 1, got {self.max_order!r}")
        c = self.compress
        if c is not None and not ((isinstance(c, float) and 0.0 < c <= 1.0) or (
                isinstance(c, (int, np.integer)) and not isinstance(c, bool) and c >= 1)):
            raise ValueError(f"compress: expected a number of components (int >= 1) or an "
                             f"energy fraction in (0, 1], got {c!r}")

    @property
    def orders(self) -> list[int]:
        """Degrees to try."""
        return list(range(1, self.max_order + 1)) if self.order == "auto" else [int(self.order)]


def check_order(order: Any) -> int | str:
    """A non-negative integer degree or ``"auto"``, or a ValueError naming ``order``."""
    if isinstance(order, str):
        if order != "auto":
            raise ValueError(f"order: expected a non-negative integer or 'auto', got {order!r}")
        return order
    if isinstance(order, (bool, np.bool_)) or not isinstance(order, (int, np.integer)):
        raise ValueError(f"order: expected a non-negative integer or 'auto', got {order!r}")
    if order < 0:
        raise ValueError(f"order: polynomial degree must be >= 0, got {order}")
    return int(order)


@dataclass(frozen=True)
class OutputInfo:
    """Labels of one fitted output: non-sample dims, their shape and coordinates, units."""

    dims: tuple[str, ...]
    shape: tuple[int, ...]
    units: str = ""
    long_name: str = ""
    coords: dict[str, tuple] = field(default_factory=dict)

    @property
    def time_dependent(self) -> bool:
        """Whether the output has a ``time`` dim."""
        return "time" in self.dims


@dataclass
class ChaosFit:
    """The fitted state of a :class:`PolynomialChaos`.

    Attributes
    ----------
    indices : ndarray (P, d)
        Multi-indices of the kept basis terms.
    coefficients : dict
        Output -> coefficients ``(P, *output shape)``.
    outputs : dict
        Output -> :class:`OutputInfo`.
    t : ndarray
        Instants of time-dependent outputs (empty otherwise).
    order : int
        Degree of the expansion (the chosen one for ``order="auto"``).
    n_evaluations, n_failed : int
        Model runs used (including failed ones and hold-out runs) and runs excluded.
    loo_error, corrected_loo_error : dict
        Output -> relative leave-one-out error of the least-squares fit on the kept basis
        (mean square over variance, variance-weighted over columns), and the same times
        Chapelle's factor ``n/(n - P) (1 + tr((Psi^T Psi)^-1))``.
    loo_error_t : dict
        Output -> LOO error per column (instant).
    holdout_error : dict
        Output -> relative error on an independent validation set (when one was given).
    compression : dict
        Output -> ``{"components", "energy_lost", "relative_error"}`` when PCA was used.
    info : dict
        Design size, basis sizes, degrees tried, wall times, rule and seed of the design.
    source : dict
        ``model``, ``model_version``, ``time_units``, ``time_long_name`` and
        ``parameters`` (name -> {"units", "description"}) of the fitted model.
    """

    indices: np.ndarray
    coefficients: dict[str, np.ndarray]
    outputs: dict[str, OutputInfo]
    t: np.ndarray
    order: int
    n_evaluations: int
    n_failed: int
    loo_error: dict[str, float]
    loo_error_t: dict[str, np.ndarray]
    corrected_loo_error: dict[str, float]
    holdout_error: dict[str, float] = field(default_factory=dict)
    compression: dict[str, dict[str, float]] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)
    source: dict[str, Any] = field(default_factory=dict)


@dataclass
class _TrainingData:
    """What :meth:`PolynomialChaos.fit` extracts from its inputs (valid samples only)."""

    x: dict[str, np.ndarray]
    y: dict[str, np.ndarray]  # output -> (n_valid, n_columns)
    outputs: dict[str, OutputInfo]
    t: np.ndarray
    valid: np.ndarray
    source: dict[str, Any]


class PolynomialChaos(Model):
    """A polynomial chaos expansion over a parameter space; a gearuq Model once fitted.

    Parameters
    ----------
    space : ParameterSpace
        The input space (its names become the surrogate's parameters).
    order, method, truncation, max_order, solver, compress, germ
        Fitting settings, see :class:`ChaosSettings`.

    Examples
    --------
    >>> import gearuq
    >>> from gearuq.testing.problems import ishigami_model, ishigami_space
    >>> space = ishigami_space()
    >>> ds = gearuq.monte_carlo(ishigami_model(), space, n_samples=400, rule="sobol", rng=1,
    ...                         executor="serial")
    >>> pce = PolynomialChaos(space, order=8, method="sparse").fit(ds)
    >>> round(float(pce.mean()), 1)
    3.5
    """

    version = "2"

    def __init__(self, space: ParameterSpace, *, order: int | str = "auto",
                 method: str = "regression", truncation: float = 1.0, max_order: int = 6,
                 solver: str = "lars", compress: int | float | None = None,
                 germ: str = "auto") -> None:
        if not isinstance(space, ParameterSpace):
            raise TypeError(f"space: expected a ParameterSpace, got {type(space).__name__}")
        self.space = space
        self.settings_ = ChaosSettings(order, method, truncation, max_order, solver, compress,
                                       germ)
        self._germ = Germ(space, germ)
        self.fitted: ChaosFit | None = None
        self.name = "pce"
        self.description = f"polynomial chaos ({method}, order {order}), not fitted"

    # ------------------------------------------------------------------ fitting
    def fit(self, inputs: xr.Dataset | Mapping[str, Any],
            outputs: Mapping[str, Any] | str | Iterable[str] | None = None, *,
            t: Any = None, status: Any = None, weights: Any = None) -> PolynomialChaos:
        """Fit the expansion on labelled data; return ``self``.

        Parameters
        ----------
        inputs : xarray.Dataset or mapping
            A result over ``sample`` holding the space's parameters as variables and the
            outputs (e.g. from :func:`gearuq.monte_carlo`, lazily loaded ones included);
            samples with nonzero ``status`` are excluded and counted. Or a mapping parameter
            name -> array ``(n,)``.
        outputs : str, list of str or mapping, optional
            With a Dataset: the outputs to fit (default: variables with ``role="output"``).
            With a mapping of inputs: output name -> array ``(n,)`` or ``(n, n_t)``.
        t : array_like, optional
            Instants of ``(n, n_t)`` array outputs (mapping inputs only).
        status : array_like, optional
            Per-sample status of mapping inputs (nonzero: excluded).
        weights : array_like, optional
            Quadrature weights of the design (``method="quadrature"``, required there).

        Raises
        ------
        ValueError
            Missing parameters or outputs, no valid sample, non-finite outputs of valid
            samples, a design too small for the basis, or weights that do not fit.
        """
        wall0 = time.perf_counter()
        data = _training_data(self.space, inputs, outputs, t, status)
        if not data.valid.any():
            raise ValueError(f"no valid sample: all {data.valid.size} samples have status != 0")
        z = self._germ.from_physical(data.x)
        if self.settings_.method == "quadrature":
            fit = _fit_quadrature(z, data, self.settings_, self._germ.kinds, weights)
        else:
            if weights is not None:
                raise ValueError("weights: only method='quadrature' uses quadrature weights")
            fit = _fit_regression(z, data, self.settings_, self._germ.kinds)
        fit.info.update({"n_design": int(data.valid.size),
                         "fit_time_s": time.perf_counter() - wall0})
        self._set_fitted(fit)
        return self

    def _set_fitted(self, fit: ChaosFit) -> None:
        """Install a fitted state and the Model metadata that follows from it."""
        self.fitted = fit
        src = fit.source
        model = src.get("model", "data")
        self.name = f"pce[{model}]"
        self.description = (f"polynomial chaos surrogate of {model} ({self.settings_.method}, "
                            f"order {fit.order})")
        self.time_units = src.get("time_units", "s")
        self.time_long_name = src.get("time_long_name", "time")
        mean = self.space.mean()
        meta = src.get("parameters", {})
        self.parameters = tuple(
            Parameter(k, meta.get(k, {}).get("units", "1"), float(mean[k]),
                      description=meta.get(k, {}).get("description", ""))
            for k in self.space.names)
        self.outputs = tuple(Output(k, m.units, ("sample", *m.dims), m.long_name)
                             for k, m in fit.outputs.items())

    def validate(self, inputs: xr.Dataset | Mapping[str, Any],
                 outputs: Mapping[str, Any] | str | Iterable[str] | None = None, *,
                 t: Any = None, status: Any = None, record: bool = True) -> dict[str, float]:
        """Relative error of the surrogate on independent data (a hold-out set).

        Same inputs as :meth:`fit`. Returns output -> mean squared error over the variance of
        the data (variance-weighted over instants); with ``record`` it is stored in
        ``holdout_error`` and the samples are added to ``n_evaluations``.
        """
        fit = self._require_fitted()
        names = list(fit.outputs) if outputs is None else outputs
        data = _training_data(self.space, inputs, names, t, status)
        pred = self.response(data.x, data.t if data.t.size else None, outputs=list(data.y))
        errors = {}
        for o, y in data.y.items():
            p = pred[o].transpose("sample", ...).values.reshape(y.shape[0], -1)
            errors[o] = relative_error(p - y, y)[0]
        if record:
            fit.holdout_error.update(errors)
            fit.n_evaluations += int(data.valid.size)
            fit.n_failed += int((~data.valid).sum())
        return errors

    # ------------------------------------------------------------------ state access
    def _require_fitted(self) -> ChaosFit:
        if self.fitted is None:
            raise ValueError("this PolynomialChaos is not fitted; call fit(...) first (or use "
                             "gearuq.polynomial_chaos, which designs, evaluates and fits)")
        return self.fitted

    @property
    def method(self) -> str:
        """Fitting method."""
        return self.settings_.method

    @property
    def germ_kinds(self) -> list[str]:
        """``"normal"`` (Hermite) or ``"uniform"`` (Legendre) per parameter."""
        return list(self._germ.kinds)

    @property
    def order(self) -> int:
        """Degree of the fitted expansion."""
        return self._require_fitted().order

    @property
    def indices(self) -> np.ndarray:
        """Multi-indices ``(P, d)`` of the kept terms."""
        return self._require_fitted().indices

    @property
    def coefficients(self) -> dict[str, np.ndarray]:
        """Output -> coefficients ``(P, *output shape)``."""
        return self._require_fitted().coefficients

    @property
    def n_terms(self) -> int:
        """Number of basis polynomials kept."""
        return int(self.indices.shape[0])

    @property
    def t(self) -> np.ndarray:
        """Fitted instants (empty without time-dependent outputs)."""
        return self._require_fitted().t

    @property
    def n_evaluations(self) -> int:
        """Model runs used, failed and hold-out runs included."""
        return self._require_fitted().n_evaluations

    @property
    def n_failed(self) -> int:
        """Runs excluded because their status was nonzero."""
        return self._require_fitted().n_failed

    @property
    def loo_error(self) -> dict[str, float]:
        """Output -> relative leave-one-out error (see :class:`ChaosFit`)."""
        return self._require_fitted().loo_error

    @property
    def corrected_loo_error(self) -> dict[str, float]:
        """Output -> corrected relative leave-one-out error."""
        return self._require_fitted().corrected_loo_error

    @property
    def loo_error_t(self) -> dict[str, np.ndarray]:
        """Output -> LOO error per instant."""
        return self._require_fitted().loo_error_t

    @property
    def holdout_error(self) -> dict[str, float]:
        """Output -> hold-out error (empty without a validation set)."""
        return self._require_fitted().holdout_error

    @property
    def compression(self) -> dict[str, dict[str, float]]:
        """Output -> PCA information (when compressed)."""
        return self._require_fitted().compression

    @property
    def fit_info(self) -> dict[str, Any]:
        """Design and basis sizes, degrees tried, wall times."""
        return self._require_fitted().info

    @property
    def source_model(self) -> str:
        """Name of the fitted model."""
        return self._require_fitted().source.get("model", "data")

    def settings(self) -> dict[str, Any]:
        """Provenance of the surrogate (its fitting settings and size)."""
        out = {"method": self.method, "order": self.settings_.order,
               "truncation": float(self.settings_.truncation), "solver": self.settings_.solver,
               "germ": self.settings_.germ, "max_order": self.settings_.max_order,
               "compress": self.settings_.compress}
        if self.fitted is not None:
            out.update({"order": self.order, "n_terms": self.n_terms,
                        "source_model": self.source_model})
        return out

    def __repr__(self) -> str:
        head = f"PolynomialChaos({', '.join(self.space.names)}; {self.method}"
        if self.fitted is None:
            return head + f", order={self.settings_.order!r}; not fitted)"
        loo = ", ".join(f"{o} {v:.1e}" for o, v in self.loo_error.items())
        return (head + f", order {self.order}, {self.n_terms} terms, "
                f"{self.n_evaluations} runs; fitted to {self.source_model}; LOO {loo})")

    def summary(self) -> str:
        """A readable report: source, basis, design, and per output moments and errors."""
        if self.fitted is None:
            return repr(self)
        fit = self.fitted
        info = fit.info
        dep = "independent" if self.space.independent else "Gaussian copula"
        lines = [
            f"{self.description}",
            f"  space: {self.space.dim} parameters ({dep}), germ "
            + ", ".join(f"{n}:{'Legendre' if k == 'uniform' else 'Hermite'}"
                        for n, k in zip(self.space.names, self.germ_kinds, strict=True)),
            f"  basis: {self.n_terms} terms kept of {info.get('n_terms_candidate', '?')} "
            f"(degree {fit.order}, q-norm {self.settings_.truncation:g}"
            + (f", degrees tried {info['orders_tried']}" if "orders_tried" in info else "")
            + ")",
            f"  design: {self.n_evaluations} model runs ({self.n_failed} failed, excluded)",
        ]
        for o in fit.outputs:
            mean = np.asarray(self.mean(o)).ravel()
            std = np.sqrt(np.asarray(self.variance(o)).ravel())
            s = (f"  {o}: mean {_span(mean)}, std {_span(std)}; LOO "
                 f"{fit.loo_error.get(o, math.nan):.2e}, corrected LOO "
                 f"{fit.corrected_loo_error.get(o, math.nan):.2e}")
            if o in fit.holdout_error:
                s += f", hold-out {fit.holdout_error[o]:.2e}"
            if o in fit.compression:
                c = fit.compression[o]
                s += f", PCA {c['components']} comp. (energy lost {c['energy_lost']:.1e})"
            lines.append(s)
        if self.method == "sparse":
            lines.append("  note: " + _SPARSE_NOTE)
        if not self.space.independent:
            lines.append("  note: Sobol' indices refer to the Nataf innovations in parameter "
                         "order (see sobol())")
        return "\n".join(lines)

    # ------------------------------------------------------------------ model contract
    def response(self, params, t=None, *, outputs=None, **options):  # noqa: D102
        fit = self._require_fitted()
        names = self.validate_outputs(outputs)
        if t is None and any(fit.outputs[o].time_dependent for o in names):
            t = fit.t
        return super().response(params, t, outputs=names, **options)

    response.__doc__ = Model.response.__doc__

    def _coef_at(self, name: str, t: np.ndarray) -> np.ndarray:
        """Coefficients at instants ``t`` (linear interpolation between fitted instants)."""
        fit = self._require_fitted()
        c = fit.coefficients[name]
        if not fit.outputs[name].time_dependent:
            return c
        if t.shape == fit.t.shape and np.array_equal(t, fit.t):
            return c
        lo, hi = fit.t.min(), fit.t.max()
        if t.min() < lo - 1e-12 * max(1, abs(lo)) or t.max() > hi + 1e-12 * max(1, abs(hi)):
            raise ValueError(
                f"t: surrogate {self.name!r} was fitted on [{lo:g}, {hi:g}]; instants outside "
                "that window cannot be predicted")
        axis = 1 + fit.outputs[name].dims.index("time")
        if fit.t.size == 1:
            return np.repeat(c, t.size, axis=axis)
        moved = np.moveaxis(c, axis, -1)
        flat = moved.reshape(-1, fit.t.size)
        out = np.stack([np.interp(t, fit.t, row) for row in flat])
        return np.moveaxis(out.reshape(*moved.shape[:-1], t.size), -1, axis)

    def _evaluate(self, params, t, outputs, **options):
        fit = self._require_fitted()
        n = next(iter(params.values())).shape[0]
        z = self._germ.from_physical(params)
        coefs = {o: self._coef_at(o, t) for o in outputs}
        data = {o: np.empty((n, *coefs[o].shape[1:])) for o in outputs}
        for s in range(0, n, _PREDICT_CHUNK):
            psi = basis_matrix(z[s:s + _PREDICT_CHUNK], fit.indices, self.germ_kinds)
            for o in outputs:
                c = coefs[o]
                data[o][s:s + _PREDICT_CHUNK] = (psi @ c.reshape(c.shape[0], -1)).reshape(
                    psi.shape[0], *c.shape[1:])
        coords = {k: v for o in outputs for k, v in fit.outputs[o].coords.items()}
        status = np.zeros(n, dtype=np.int8)
        for o in outputs:
            status[~np.isfinite(data[o].reshape(n, -1)).all(axis=1)] = STATUS_NONFINITE
        return Evaluation(data=data, status=status, coords=coords,
                          attrs={"surrogate": self.description})

    def predict(self, params: Mapping[str, Any], output: str | None = None,
                t: Any = None) -> np.ndarray:
        """Surrogate values of one output as a plain array ``(n, ...)``."""
        output = output or self.output_names[0]
        return self.response(params, t, outputs=[output])[output].values

    # ------------------------------------------------------------------ analytic results
    def _coords_of(self, name: str) -> dict[str, Any]:
        fit = self._require_fitted()
        m = fit.outputs[name]
        coords = {}
        for d in m.dims:
            if d == "time":
                coords["time"] = ("time", fit.t, {"units": self.time_units})
            elif d in m.coords:
                dims, values, attrs = m.coords[d]
                coords[d] = (dims, values, attrs)
        return coords

    def _check_output(self, output: str | None) -> str:
        fit = self._require_fitted()
        if output is None:
            if len(fit.outputs) != 1:
                raise ValueError(f"output: this surrogate has outputs {list(fit.outputs)}; "
                                 "name one")
            return next(iter(fit.outputs))
        if output not in fit.coefficients:
            raise ValueError(f"output {output!r} not fitted; fitted: {list(fit.outputs)}")
        return output

    def mean(self, output: str | None = None) -> xr.DataArray:
        """Mean of an output: the constant coefficient (orthonormal basis)."""
        o = self._check_output(output)
        m = self.fitted.outputs[o]
        return xr.DataArray(self.coefficients[o][0], dims=m.dims, coords=self._coords_of(o),
                            attrs={"units": m.units, "long_name": f"PCE mean of {o}"})

    def variance(self, output: str | None = None) -> xr.DataArray:
        """Variance of an output: the sum of the squared non-constant coefficients."""
        o = self._check_output(output)
        m = self.fitted.outputs[o]
        v = np.sum(self.coefficients[o][1:] ** 2, axis=0)
        return xr.DataArray(v, dims=m.dims, coords=self._coords_of(o),
                            attrs={"units": f"({m.units})2", "long_name": f"PCE variance of {o}"})

    def sobol(self, output: str | None = None, *, second_order: bool = False) -> xr.Dataset:
        """First-order, total (and second-order) Sobol' indices from the coefficients.

        ``S_i`` sums the squared coefficients of terms in ``z_i`` alone, ``ST_i`` those of
        every term containing ``z_i``, both over the variance.

        For a correlated space the germ variables are the Cholesky (Nataf) innovations in
        parameter order, so the indices are *not* those of the physical parameters: the first
        parameter's are its full indices (its own effect plus everything it shares with the
        others), each later one's only the part not explained by the parameters before it
        (coordinate ``germ_variable``, e.g. ``"x2 | x1"``). They change when the space lists
        the parameters in another order; a UserWarning says so.

        Returns
        -------
        xarray.Dataset
            ``S1``, ``ST`` over ``(parameter, *output dims)``, ``S2`` over
            ``(parameter, parameter_2, ...)`` on request, ``mean`` and ``variance``.
        """
        o = self._check_output(output)
        c2 = self.coefficients[o] ** 2
        s1, st, s2 = _sobol_from_squares(c2, self.indices, second_order)
        m = self.fitted.outputs[o]
        coords = {"parameter": self.space.names, **self._coords_of(o)}
        ds = xr.Dataset(coords=coords)
        ds["S1"] = (("parameter", *m.dims), s1, {"long_name": "first-order Sobol index",
                                                 "units": "1"})
        ds["ST"] = (("parameter", *m.dims), st, {"long_name": "total Sobol index",
                                                 "units": "1"})
        if second_order:
            ds = ds.assign_coords(parameter_2=self.space.names)
            ds["S2"] = (("parameter", "parameter_2", *m.dims), s2,
                        {"long_name": "second-order Sobol index", "units": "1"})
        ds["mean"] = self.mean(o)
        ds["variance"] = self.variance(o)
        ds.attrs.update({
            "method": "pce", "output": o, "pce_method": self.method, "order": self.order,
            "n_terms": self.n_terms, "n_model_evaluations": self.n_evaluations,
            "loo_error": self.loo_error.get(o, math.nan),
            "corrected_loo_error": self.corrected_loo_error.get(o, math.nan),
            "note": "independent inputs",
        })
        if not self.space.independent:
            ds = ds.assign_coords(germ_variable=("parameter", self._germ.labels()))
            ds.attrs["note"] = (
                "correlated space: indices of the independent germ variables (Nataf/Cholesky "
                "innovations in parameter order, coordinate germ_variable), not of the "
                "dependent physical parameters; they depend on the parameter order")
            warnings.warn(
                f"Sobol' indices of a correlated space are those of the Nataf innovations "
                f"{self._germ.labels()}: they depend on the order of the parameters in the "
                "space", UserWarning, stacklevel=2)
        return ds

    # ------------------------------------------------------------------ reliability
    def reliability(self, bands: Any, *, n_samples: int = 10**6, rng: Any = None,
                    confidence: float = 0.95, time: Any = None,
                    space: ParameterSpace | None = None, **kwargs: Any) -> xr.Dataset:
        """Failure probabilities of the surrogate on ``n_samples`` random draws.

        Evaluates the surrogate on ``space.sample(n_samples, "random", seed)`` (the fitted
        space unless another one with the same names is given, e.g. a shifted design for a
        what-if study; only at the instants ``time`` when given, which keeps 10^6 samples x
        instants in memory) and passes the result to :func:`gearuq.probability.reliability`.
        The interval is the sampling interval of the surrogate's Pf only; it does not include
        the surrogate error (see :func:`gearuq.engines.pce.compare_mc_surrogate`).
        ``rng=None`` draws a fresh seed, recorded in ``attrs["seed"]``.
        """
        from gearuq.engines.common import check_positive_int, resolve_seed
        from gearuq.probability import _as_bands, reliability

        self._require_fitted()
        sampling = self.space if space is None else space
        if sampling.names != self.space.names:
            raise ValueError(f"space names {sampling.names} differ from the surrogate's "
                             f"{self.space.names}")
        band_list = _as_bands(bands)
        outs = list(dict.fromkeys(b.output for b in band_list))
        n_samples = check_positive_int("n_samples", n_samples)
        seed = resolve_seed(rng)
        t = None if time is None else np.atleast_1d(np.asarray(time, dtype=float))
        t0 = _now()
        ds = self.response(sampling.sample(n_samples, "random", seed), t, outputs=outs)
        rel = reliability(ds, band_list, confidence=confidence, **kwargs)
        rel.attrs.update({"engine": "pce_surrogate", "surrogate": self.description,
                          "n_surrogate_samples": n_samples, "seed": seed,
                          "n_model_evaluations": self.n_evaluations,
                          "surrogate_wall_time_s": _now() - t0})
        return rel

    # ------------------------------------------------------------------ storage
    def to_dataset(self) -> xr.Dataset:
        """Everything needed to rebuild the surrogate, as a netCDF-safe Dataset.

        :meth:`from_dataset` turns it back into an identical surrogate (bit-identical
        predictions); ``gearuq.save``/``gearuq.load`` round-trip it.
        """
        return _to_dataset(self)

    @classmethod
    def from_dataset(cls, ds: xr.Dataset) -> PolynomialChaos:
        """Rebuild a surrogate saved by :meth:`to_dataset` (e.g. after ``gearuq.load``).

        Raises
        ------
        ValueError
            If ``ds`` is not a saved polynomial chaos surrogate.
        """
        return _from_dataset(cls, ds)


def _now() -> float:
    return time.perf_counter()


def _span(values: np.ndarray) -> str:
    if values.size == 1:
        return f"{values[0]:.6g}"
    return f"{values.min():.4g}..{values.max():.4g}"


def _sobol_from_squares(c2: np.ndarray, idx: np.ndarray, second_order: bool
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """S1, ST (and S2) from squared coefficients ``(P, ...)`` and multi-indices ``(P, d)``."""
    var = c2[1:].sum(axis=0)
    nz = idx > 0
    n_vars = nz.sum(axis=1)
    only = nz & (n_vars == 1)[:, None]
    d = idx.shape[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        s1 = np.stack([c2[only[:, i]].sum(axis=0) / var for i in range(d)])
        st = np.stack([c2[nz[:, i]].sum(axis=0) / var for i in range(d)])
        if not second_order:
            return s1, st, None
        s2 = np.full((d, d, *var.shape), np.nan)
        for i in range(d):
            for j in range(i + 1, d):
                sel = nz[:, i] & nz[:, j] & (n_vars == 2)
                s2[i, j] = s2[j, i] = c2[sel].sum(axis=0) / var
    return s1, st, s2


# =========================================================================== training data
def _training_data(space: ParameterSpace, inputs: Any, outputs: Any, t: Any,
                   status: Any) -> _TrainingData:
    """Inputs, outputs (valid samples, flattened columns) and labels from a Dataset or arrays."""
    if isinstance(inputs, xr.Dataset):
        if t is not None or status is not None:
            raise ValueError("t/status: taken from the Dataset; give them only with arrays")
        return _from_result(space, inputs, outputs)
    if not isinstance(inputs, Mapping):
        raise TypeError(f"inputs: expected an xarray Dataset or a mapping of arrays, got "
                        f"{type(inputs).__name__}")
    if not isinstance(outputs, Mapping) or not outputs:
        raise ValueError("outputs: with array inputs give a mapping output name -> array")
    missing = [k for k in space.names if k not in inputs]
    if missing:
        raise ValueError(f"inputs: missing parameter(s) {missing} of the space {space.names}")
    x = {k: np.asarray(inputs[k], dtype=float).ravel() for k in space.names}
    n = x[space.names[0]].size
    tt = np.zeros(0) if t is None else np.atleast_1d(np.asarray(t, dtype=float))
    ys, infos = {}, {}
    for o, v in outputs.items():
        y = np.asarray(v, dtype=float)
        if y.shape[0] != n or y.ndim > 2 or (y.ndim == 2 and y.shape[1] != tt.size):
            raise ValueError(f"output {o!r}: shape {y.shape} does not fit {n} samples"
                             + (f" x {tt.size} instants" if tt.size else " (give t= for "
                                                                         "2-D outputs)"))
        dims = ("time",) if y.ndim == 2 else ()
        infos[o] = OutputInfo(dims, y.shape[1:])
        ys[o] = y.reshape(n, -1)
    st = np.zeros(n, dtype=int) if status is None else np.asarray(status).ravel()
    if st.size != n:
        raise ValueError(f"status: {st.size} values for {n} samples")
    return _valid_only(x, ys, infos, tt, st == 0, {"model": "data"})


def _from_result(space: ParameterSpace, ds: xr.Dataset, outputs: Any) -> _TrainingData:
    missing = [k for k in space.names if k not in ds]
    if missing:
        raise ValueError(f"inputs: the Dataset has no variable(s) {missing} of the space "
                         f"{space.names}")
    if outputs is None:
        names = [k for k, v in ds.data_vars.items()
                 if v.attrs.get("role") == "output" and "sample" in v.dims]
    else:
        names = [outputs] if isinstance(outputs, str) else list(outputs)
    bad = [o for o in names if o not in ds or "sample" not in ds[o].dims]
    if bad or not names:
        raise ValueError(f"outputs: {bad or names} not output variables over 'sample' of the "
                         f"Dataset; it has {list(ds.data_vars)}")
    n = ds.sizes["sample"]
    x = {k: np.asarray(ds[k].values, dtype=float) for k in space.names}
    timed = "time" in ds.coords and any("time" in ds[o].dims for o in names)
    tt = np.asarray(ds["time"].values, dtype=float) if timed else np.zeros(0)
    ys, infos = {}, {}
    for o in names:
        da = ds[o].transpose("sample", ...)
        rest = tuple(d for d in da.dims if d != "sample")
        coords = {d: (ds[d].dims, np.asarray(ds[d].values), dict(ds[d].attrs))
                  for d in rest if d != "time" and d in ds.coords}
        infos[o] = OutputInfo(rest, tuple(da.shape[1:]), str(da.attrs.get("units", "")),
                              str(da.attrs.get("long_name", "")), coords)
        ys[o] = np.asarray(da.values, dtype=float).reshape(n, -1)
    st = np.asarray(ds["status"].values) if "status" in ds else np.zeros(n, dtype=int)
    source = {"model": str(ds.attrs.get("model", "data")),
              "model_version": str(ds.attrs.get("model_version", "")),
              "time_units": str(ds["time"].attrs.get("units", "s")) if timed else "s",
              "time_long_name": str(ds["time"].attrs.get("long_name", "time")) if timed
              else "time",
              "parameters": {k: {"units": str(ds[k].attrs.get("units", "1")),
                                 "description": str(ds[k].attrs.get("long_name", ""))}
                             for k in space.names}}
    return _valid_only(x, ys, infos, tt, st == 0, source)


def _valid_only(x, ys, infos, t, valid, source) -> _TrainingData:
    for o, y in ys.items():
        if not np.all(np.isfinite(y[valid])):
            raise ValueError(f"output {o!r}: non-finite values in samples with status 0")
    return _TrainingData({k: v[valid] for k, v in x.items()},
                         {o: y[valid] for o, y in ys.items()}, infos, t, valid, source)


# =========================================================================== fitting
def _new_fit(data: _TrainingData, **kw: Any) -> ChaosFit:
    return ChaosFit(outputs=data.outputs, t=data.t, n_evaluations=int(data.valid.size),
                    n_failed=int((~data.valid).sum()), source=data.source, **kw)


def _fit_quadrature(z: np.ndarray, data: _TrainingData, settings: ChaosSettings,
                    kinds: list[str], weights: Any) -> ChaosFit:
    """Spectral projection ``c = Psi^T (w y)``; least squares if nodes failed."""
    if weights is None:
        raise ValueError("weights: method='quadrature' needs the quadrature weights of the "
                         "design (gearuq.polynomial_chaos designs and passes them)")
    w = np.asarray(weights, dtype=float).ravel()
    if w.size != data.valid.size:
        raise ValueError(f"weights: {w.size} weights for {data.valid.size} design points")
    idx = multi_indices(z.shape[1], int(settings.order), settings.truncation)
    psi = basis_matrix(z, idx, kinds)
    full = bool(data.valid.all())
    if not full:
        warnings.warn(f"{int((~data.valid).sum())} quadrature node(s) failed; coefficients by "
                      "least squares on the valid nodes", RuntimeWarning, stacklevel=3)
    coefs, loo, loo_t, corr = {}, {}, {}, {}
    with few_blas_threads(psi.size):
        for o, y in data.y.items():
            coefs[o] = (psi.T @ (w[:, None] * y) if full
                        else np.linalg.lstsq(psi, y, rcond=None)[0])
            loo[o], loo_t[o], corr[o] = math.nan, np.full(y.shape[1], math.nan), math.nan
            if psi.shape[0] > psi.shape[1]:  # LOO of a least-squares refit on the nodes
                try:
                    c_ls, h, trace = least_squares(psi, y)
                    loo[o], loo_t[o] = relative_error(loo_residuals(psi, y, c_ls, h), y)
                    corr[o] = corrected_loo(loo[o], psi.shape[0], psi.shape[1], trace)
                except np.linalg.LinAlgError:
                    pass
    fit = _new_fit(data, indices=idx, coefficients=_shaped(coefs, data), order=int(
        settings.order), loo_error=loo, loo_error_t=loo_t, corrected_loo_error=corr)
    fit.info.update({"n_terms_candidate": int(idx.shape[0])})
    return fit


def _shaped(coefs: dict[str, np.ndarray], data: _TrainingData) -> dict[str, np.ndarray]:
    return {o: c.reshape(c.shape[0], *data.outputs[o].shape) for o, c in coefs.items()}


def _fit_regression(z: np.ndarray, data: _TrainingData, settings: ChaosSettings,
                    kinds: list[str]) -> ChaosFit:
    """Least squares or sparse least squares, one degree or the best of ``1..max_order``.

    The basis is evaluated once for the largest degree; a lower degree uses the columns of
    its (nested) index set. ``order="auto"`` stops after two degrees in a row that do not
    lower the selection error (LOO for regression, corrected LOO for sparse).
    """
    orders = settings.orders
    idx_all = multi_indices(z.shape[1], orders[-1], settings.truncation)
    n = z.shape[0]
    if settings.method == "regression" and n <= _n_terms(idx_all, orders[0], settings):
        raise ValueError(
            f"n_samples: {n} valid samples ({int((~data.valid).sum())} failed) are not more "
            f"than the {_n_terms(idx_all, orders[0], settings)} basis terms of order "
            f"{orders[0]} ({z.shape[1]} parameters); give more samples (typically 2-3x) or "
            "use method='sparse'")
    if settings.method == "sparse" and n < 3:
        raise ValueError(f"n_samples: sparse regression needs at least 3 samples, got {n}")
    psi_all = basis_matrix(z, idx_all, kinds)
    with few_blas_threads(psi_all.size):
        return _best_degree(psi_all, idx_all, data, settings)


def _best_degree(psi_all: np.ndarray, idx_all: np.ndarray, data: _TrainingData,
                 settings: ChaosSettings) -> ChaosFit:
    """Fit the degrees of ``settings.orders`` on nested column sets; keep the best one."""
    orders = settings.orders
    n = psi_all.shape[0]
    norms = q_norm(idx_all, settings.truncation)
    weights = {o: max(float(np.var(y, axis=0, ddof=1).sum()), 1e-300) if n > 1 else 1.0
               for o, y in data.y.items()}
    best, tried, worse = None, [], 0
    for p in orders:
        cols = np.flatnonzero(norms <= p + 1e-9)
        if settings.method == "regression" and n <= cols.size:
            break
        res = _fit_degree(psi_all[:, cols], data, settings)
        tried.append(p)
        key = "corrected" if settings.method == "sparse" else "loo"
        score = sum(res[key][o] * weights[o] for o in data.y) / sum(weights.values())
        if best is None or score < best[0]:
            best, worse = (score, p, cols, res), 0
        else:
            worse += 1
            if worse >= _DEGREE_PATIENCE:
                break
    _, order, cols, res = best
    keep = np.zeros(cols.size, dtype=bool)
    keep[0] = True
    for c in res["coef"].values():
        keep |= np.any(c != 0, axis=1)
    if settings.method == "regression":
        keep[:] = True
    coefs = {o: c[keep] for o, c in res["coef"].items()}
    fit = _new_fit(data, indices=idx_all[cols][keep], coefficients=_shaped(coefs, data),
                   order=order, loo_error=res["loo"], loo_error_t=res["loo_t"],
                   corrected_loo_error=res["corrected"], compression=res["compression"])
    fit.info.update({"n_terms_candidate": int(cols.size), "orders_tried": tried,
                     "n_terms_selected": int(keep.sum())})
    return fit


def _n_terms(idx_all: np.ndarray, order: int, settings: ChaosSettings) -> int:
    return int(np.sum(q_norm(idx_all, settings.truncation) <= order + 1e-9))


def _fit_degree(psi: np.ndarray, data: _TrainingData, settings: ChaosSettings
                ) -> dict[str, Any]:
    """Fit every output on one candidate basis; coefficients and errors per output."""
    out: dict[str, Any] = {"coef": {}, "loo": {}, "loo_t": {}, "corrected": {},
                           "compression": {}}
    n = psi.shape[0]
    for o, y in data.y.items():
        compress = settings.compress if y.shape[1] > 1 else None
        if compress is not None:
            target, comps, ybar, info = pca(y, compress)
        else:
            target, comps, ybar, info = y, None, None, None
        try:
            r = fit_columns(psi, target, settings.method, settings.solver)
        except np.linalg.LinAlgError:
            raise ValueError("basis matrix is rank deficient on this design; use more "
                             "samples or a lower order") from None
        coef, res = r["coef"], r["loo_residuals"]
        if comps is not None:
            recon = ybar + target @ comps
            info["relative_error"] = relative_error(recon - y, y)[0]
            res = res @ comps + (y - recon)  # the discarded part counts as error
            coef = coef @ comps
            coef[0] += ybar
            out["compression"][o] = info
        out["coef"][o] = coef
        out["loo"][o], out["loo_t"][o] = relative_error(res, y)
        out["corrected"][o] = corrected_loo(out["loo"][o], n, int(r["columns"].size),
                                            r["trace"])
    return out


# =========================================================================== storage
_KIND = "gearuq_polynomial_chaos"


def _to_dataset(pce: PolynomialChaos) -> xr.Dataset:
    fit = pce._require_fitted()
    ds = xr.Dataset(coords={"term": np.arange(pce.n_terms), "parameter": pce.space.names})
    if fit.t.size:
        ds = ds.assign_coords(time=("time", fit.t, {"units": pce.time_units,
                                                     "long_name": pce.time_long_name}))
    ds["multi_index"] = (("term", "parameter"), fit.indices,
                         {"long_name": "degree of each germ variable in each basis term"})
    outputs = {}
    for o, m in fit.outputs.items():
        for d, (dims, values, attrs) in m.coords.items():
            if d not in ds.coords:
                ds = ds.assign_coords({d: (dims, values, attrs)})
        ds[f"coef_{o}"] = (("term", *m.dims), fit.coefficients[o],
                           {"units": m.units, "long_name": f"chaos coefficients of {o}"})
        ds[f"loo_{o}"] = ((), fit.loo_error.get(o, math.nan),
                          {"long_name": f"relative LOO error of {o}"})
        ds[f"loo_t_{o}"] = (m.dims, np.asarray(fit.loo_error_t[o]).reshape(m.shape),
                            {"long_name": f"relative LOO error of {o} per column"})
        outputs[o] = {"dims": list(m.dims), "units": m.units, "long_name": m.long_name}
    ds.attrs.update({
        "gearuq_version": __version__, "kind": _KIND, "space": pce.space.to_json(),
        "germ": " ".join(pce.germ_kinds), "method": pce.method, "order": fit.order,
        "n_terms": pce.n_terms, "source_model": pce.source_model,
        "n_evaluations": fit.n_evaluations, "n_failed": fit.n_failed,
        "settings": json.dumps(pce.settings(), default=repr),
        "fit": json.dumps({"outputs": outputs, "source": fit.source, "info": fit.info,
                           "compression": fit.compression,
                           "corrected_loo_error": fit.corrected_loo_error,
                           "holdout_error": fit.holdout_error}, default=_json_default),
    })
    return ds


def _json_default(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    return repr(v)


def _from_dataset(cls: type[PolynomialChaos], ds: xr.Dataset) -> PolynomialChaos:
    if ds.attrs.get("kind") != _KIND or "multi_index" not in ds:
        raise ValueError("from_dataset: not a saved polynomial chaos surrogate (expected "
                         "the Dataset of PolynomialChaos.to_dataset())")
    space = ParameterSpace.from_json(ds.attrs["space"])
    stored = json.loads(ds.attrs["settings"])
    settings = {k: stored[k] for k in ("method", "truncation", "max_order", "solver",
                                       "compress", "germ")}
    pce = cls(space, order=int(ds.attrs["order"]), **settings)
    pce._germ = Germ(space, settings["germ"], kinds=str(ds.attrs["germ"]).split())
    record = json.loads(ds.attrs["fit"])
    infos, coefs, loo, loo_t = {}, {}, {}, {}
    for o, meta in record["outputs"].items():
        dims = tuple(meta["dims"])
        coords = {d: (ds[d].dims, np.asarray(ds[d].values), dict(ds[d].attrs))
                  for d in dims if d != "time" and d in ds.coords}
        coef = np.asarray(ds[f"coef_{o}"].transpose("term", *dims).values, dtype=float)
        infos[o] = OutputInfo(dims, coef.shape[1:], meta["units"], meta["long_name"], coords)
        coefs[o] = coef
        loo[o] = float(ds[f"loo_{o}"].values)
        loo_t[o] = np.asarray(ds[f"loo_t_{o}"].values, dtype=float).ravel()
    t = np.asarray(ds["time"].values, dtype=float) if "time" in ds.coords else np.zeros(0)
    fit = ChaosFit(
        indices=np.asarray(ds["multi_index"].values, dtype=int), coefficients=coefs,
        outputs=infos, t=t, order=int(ds.attrs["order"]),
        n_evaluations=int(ds.attrs["n_evaluations"]), n_failed=int(ds.attrs["n_failed"]),
        loo_error=loo, loo_error_t=loo_t,
        corrected_loo_error={k: float(v) for k, v in record["corrected_loo_error"].items()},
        holdout_error={k: float(v) for k, v in record["holdout_error"].items()},
        compression=record["compression"], info=record["info"], source=record["source"])
    pce._set_fitted(fit)
    return pce
