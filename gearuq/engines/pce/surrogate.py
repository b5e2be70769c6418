"""The polynomial chaos surrogate: fit on labelled data, predict, analytic results, storage.

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
from typing import Any

import numpy as np
import xarray as xr

from gearuq._version import __version__
from gearuq.engines.pce.basis import Germ, basis_matrix
from gearuq.engines.pce.fitting import fit_quadrature, fit_regression, training_data
from gearuq.engines.pce.regression import relative_error
from gearuq.engines.pce.state import METHODS, ChaosFit, ChaosSettings, OutputInfo
from gearuq.model import STATUS_NONFINITE, Evaluation, Model, Output, Parameter
from gearuq.space import ParameterSpace

__all__ = ["PolynomialChaos", "ChaosSettings", "ChaosFit", "OutputInfo", "METHODS",
           "SURROGATE_UNUSABLE_ERROR", "STATUS_SURROGATE_NOT_USABLE"]

#: Relative leave-one-out error (corrected where available, error variance over output
#: variance) from which a surrogate is not usable: its out-of-sample error then carries half
#: the output's variance or more, so its tails and its variance split are mostly its own error.
SURROGATE_UNUSABLE_ERROR = 0.5
#: Status carried by results built on a surrogate that is not usable; the same code as
#: ``surrogate_not_usable`` in the failure report's table (``gearuq.failure.ReportStatus``).
STATUS_SURROGATE_NOT_USABLE = 9

#: Rows of the basis matrix evaluated at once when predicting (bounds the memory).
_PREDICT_CHUNK = 20_000

_SPARSE_NOTE = (
    "the LOO error of a sparse basis is optimistic: the basis was chosen to make it small "
    "(selection bias; on Ishigami the hold-out error is about 2x the corrected LOO); judge a "
    "sparse surrogate by its hold-out error (n_holdout=, validate())")


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
        data = training_data(self.space, inputs, outputs, t, status)
        if not data.valid.any():
            raise ValueError(f"no valid sample: all {data.valid.size} samples have status != 0")
        z = self._germ.from_physical(data.x)
        if self.settings_.method == "quadrature":
            fit = fit_quadrature(z, data, self.settings_, self._germ.kinds, weights)
        else:
            if weights is not None:
                raise ValueError("weights: only method='quadrature' uses quadrature weights")
            fit = fit_regression(z, data, self.settings_, self._germ.kinds)
        fit.info.update({"n_design": int(data.valid.size),
                         "fit_time_s": time.perf_counter() - wall0})
        self._set_fitted(fit)
        code, message = self.surrogate_status()
        if code:
            warnings.warn(message, UserWarning, stacklevel=2)
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
        data = training_data(self.space, inputs, names, t, status)
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

    def surrogate_status(self) -> tuple[int, str]:
        """Whether the fitted surrogate is usable: ``(0, "")`` or ``(9, reason in words)``.

        Not usable when, for some output, the relative leave-one-out error (the corrected one
        where the design allows it, else the plain one; the hold-out error when larger) is at
        least :data:`SURROGATE_UNUSABLE_ERROR`. Sobol' indices and reliability results of the
        surrogate, and a failure-probability report run on it, carry this status.
        """
        fit = self._require_fitted()
        bad = []
        for o in fit.outputs:
            errs = [fit.corrected_loo_error.get(o, math.nan)]
            if not math.isfinite(errs[0]):
                errs = [fit.loo_error.get(o, math.nan)]
            errs.append(fit.holdout_error.get(o, math.nan))
            worst = max((e for e in errs if math.isfinite(e)), default=math.nan)
            if worst >= SURROGATE_UNUSABLE_ERROR:
                bad.append(f"{o} {worst:.2f}")
        if not bad:
            return 0, ""
        return STATUS_SURROGATE_NOT_USABLE, (
            f"the polynomial chaos surrogate is not usable: its relative leave-one-out error "
            f"({', '.join(bad)}) is at least {SURROGATE_UNUSABLE_ERROR}, so it explains at "
            f"most half of the variance of what it replaces; enlarge the design or the "
            f"degree, or use the model itself")

    def _status_attrs(self) -> dict[str, Any]:
        code, message = self.surrogate_status()
        return {"status": code, "status_text": (
            f"status {code}: {message}" if code else "status 0: ok")}

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
            **self._status_attrs(),
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
        instants in memory) and passes the result to :func:`gearuq.reliability`.
        The interval is the sampling interval of the surrogate's Pf only; it does not include
        the surrogate error (see :func:`gearuq.engines.pce.compare_mc_surrogate`).
        ``rng=None`` draws a fresh seed, recorded in ``attrs["seed"]``.
        """
        from gearuq.failure.modes import as_bands
        from gearuq.failure.samples import reliability
        from gearuq.runs import check_positive_int, resolve_seed

        self._require_fitted()
        sampling = self.space if space is None else space
        if sampling.names != self.space.names:
            raise ValueError(f"space names {sampling.names} differ from the surrogate's "
                             f"{self.space.names}")
        band_list = as_bands(bands)
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
                          "surrogate_wall_time_s": _now() - t0, **self._status_attrs()})
        return rel

    # ------------------------------------------------------------------ storage
    def to_dataset(self) -> xr.Dataset:
        """Everything needed to rebuild the surrogate, as a netCDF-safe Dataset.

        :meth:`from_dataset` turns it back into an identical surrogate (bit-identical
        predictions); ``gearuq.save``/``gearuq.load`` round-trip it.
        """
        return to_dataset(self)

    @classmethod
    def from_dataset(cls, ds: xr.Dataset) -> PolynomialChaos:
        """Rebuild a surrogate saved by :meth:`to_dataset` (e.g. after ``gearuq.load``).

        Raises
        ------
        ValueError
            If ``ds`` is not a saved polynomial chaos surrogate.
        """
        return from_dataset(cls, ds)


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


# ------------------------------------------------------------------ storage
# Beside the class they save and rebuild (they read its fitted state): no module in between.
_KIND = "gearuq_polynomial_chaos"


def to_dataset(pce: PolynomialChaos) -> xr.Dataset:
    """The Dataset of :meth:`PolynomialChaos.to_dataset` (see there)."""
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


def from_dataset(cls: type[PolynomialChaos], ds: xr.Dataset) -> PolynomialChaos:
    """Rebuild a ``cls`` surrogate from the Dataset of :func:`to_dataset`."""
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
