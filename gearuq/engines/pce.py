"""Polynomial chaos expansions (PCE) on chaospy: regression, sparse regression, quadrature.

:func:`polynomial_chaos` fits ``y(x) ~ sum_k c_k psi_k(z(x))`` where ``z`` is the *germ*: the
independent standardised variables behind the parameter space and ``psi_k`` the orthonormal
polynomials of the germ (probabilists' Hermite for standard normals, Legendre for
``U(-1, 1)``). Working in the germ rather than in physical units keeps the basis well
conditioned whatever the scale of a parameter (seed 000 has ``b5 = 2e-5 m`` with std
``3.3e-9 m``; a raw monomial of degree 6 in it would be numerically useless) and lets one
code cover every marginal and the Gaussian copula:

- an independent uniform marginal gets a Legendre germ ``z = 2 F(x) - 1`` (exact for
  polynomial models in ``x``, e.g. Ishigami);
- every other marginal, and every parameter of a correlated space, gets a standard normal
  germ through the Nataf map ``z = L^-1 Phi^-1(F(x))`` (``space.to_normal`` then
  decorrelation by the Cholesky factor ``L`` of the normal-space correlation). For normal
  marginals this is the affine map ``(x - mean)/std`` so polynomial models stay polynomial.

The multi-indices (total degree, hyperbolic q-norm truncation) and the quadrature rules
(Gauss, Smolyak sparse grids) come from chaospy; the orthonormal univariate polynomials are
evaluated by their three-term recurrences, which is exact and fast on 10^6 points.

Methods
-------
``"regression"``
    Ordinary least squares on a random / LHS / Sobol design (default size ``oversampling``
    x basis size), all output columns (time instants) solved together as one multi-RHS
    problem through one QR factorisation. The leave-one-out (LOO) error is closed form,
    ``e_i = r_i / (1 - h_i)`` with ``h`` the diagonal of the hat matrix.
``"sparse"``
    Hybrid LARS (or OMP) of scikit-learn: the regressor path picks candidate bases, each is
    refitted by least squares and the one with the smallest LOO error is kept (Blatman and
    Sudret 2011). For vector outputs the selection runs on the leading principal components
    and the union of the selected terms is refitted on every column (shared basis).
``"quadrature"``
    Spectral projection ``c_k = sum_i w_i y_i psi_k(z_i)`` on a Gauss tensor grid or a
    Smolyak sparse grid (``sparse_grid=True``) of the germ.

``order="auto"`` fits degrees ``1..max_order`` on one design and keeps the smallest LOO
error. Failed model samples (``status != 0``) are excluded from the fit and counted in
``n_failed``; they are never used.
"""

from __future__ import annotations

import json
import math
import time
import warnings
from collections.abc import Iterable, Mapping
from typing import Any

import chaospy as cp
import numpy as np
import xarray as xr
from scipy import linalg, special

from gearuq.model import Evaluation, Model, Output, Parameter
from gearuq.space import RULES, ParameterSpace

__all__ = [
    "PolynomialChaos",
    "polynomial_chaos",
    "multi_indices",
    "surrogate_reliability",
    "compare_mc_surrogate",
    "METHODS",
]

#: Fitting methods of :func:`polynomial_chaos`.
METHODS = ("regression", "sparse", "quadrature")
#: Rows of the basis matrix evaluated at once when predicting (bounds the memory).
_PREDICT_CHUNK = 20_000


# =========================================================================== basis
def multi_indices(dim: int, order: int, truncation: float = 1.0) -> np.ndarray:
    """Multi-indices of total degree <= ``order`` kept by the hyperbolic q-norm truncation.

    Parameters
    ----------
    dim : int
        Number of germ variables.
    order : int
        Largest total degree.
    truncation : float
        ``q`` in (0, 1]: keep ``alpha`` with ``(sum_i alpha_i^q)^(1/q) <= order``. ``q = 1`` is
        the full total-degree set; smaller ``q`` drops high-order interactions first.

    Returns
    -------
    ndarray of int, shape (P, dim)
        Graded (by total degree) multi-indices, the constant term first.
    """
    idx = np.asarray(cp.glexindex(0, order + 1, dimensions=dim, graded=True), dtype=int)
    idx = idx.reshape(-1, dim)
    if truncation < 1.0:
        qn = np.sum(idx.astype(float) ** truncation, axis=1) ** (1.0 / truncation)
        idx = idx[qn <= order + 1e-9]
    return idx


def _univariate(z: np.ndarray, kind: str, degree: int) -> np.ndarray:
    """Orthonormal polynomials of degrees 0..degree at ``z`` -> (degree+1, n)."""
    out = np.empty((degree + 1, z.size))
    out[0] = 1.0
    if degree == 0:
        return out
    if kind == "normal":  # He_{n+1} = z He_n - n He_{n-1}, normalised by sqrt(n!)
        out[1] = z
        for n in range(1, degree):
            out[n + 1] = (z * out[n] - math.sqrt(n) * out[n - 1]) / math.sqrt(n + 1)
        return out
    # Legendre on [-1, 1] w.r.t. the density 1/2: (n+1) P_{n+1} = (2n+1) z P_n - n P_{n-1}
    p_prev, p = np.ones_like(z), z.copy()
    out[1] = math.sqrt(3.0) * p
    for n in range(1, degree):
        p_prev, p = p, ((2 * n + 1) * z * p - n * p_prev) / (n + 1)
        out[n + 1] = math.sqrt(2 * n + 3) * p
    return out


def _basis_matrix(z: np.ndarray, indices: np.ndarray, kinds: list[str]) -> np.ndarray:
    """Orthonormal basis evaluated at germ points ``z`` (n, d) -> (n, P)."""
    n = z.shape[0]
    psi = np.ones((n, indices.shape[0]))
    for j, kind in enumerate(kinds):
        deg = int(indices[:, j].max()) if indices.size else 0
        if deg == 0:
            continue
        uni = _univariate(z[:, j], kind, deg)
        psi *= uni[indices[:, j]].T
    return psi


# =========================================================================== germ maps
class _Germ:
    """The map between physical parameters and the independent germ of a space."""

    def __init__(self, space: ParameterSpace, germ: str = "auto") -> None:
        if germ not in ("auto", "normal"):
            raise ValueError(f"germ: unknown {germ!r}; valid: auto, normal")
        self.space = space
        self.names = space.names
        corr = space.correlation
        self.chol = None if corr is None else np.linalg.cholesky(corr)
        self.kinds = [
            "uniform" if (germ == "auto" and self.chol is None
                          and space.marginal(k).kind == "uniform") else "normal"
            for k in self.names
        ]

    def joint(self) -> cp.Distribution:
        """chaospy distribution of the germ (for quadrature rules)."""
        return cp.J(*(cp.Normal(0, 1) if k == "normal" else cp.Uniform(-1, 1)
                      for k in self.kinds))

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Uniform design (n, d) -> germ points (n, d)."""
        u = np.clip(u, 1e-16, 1 - 2**-53)
        return np.column_stack([special.ndtri(u[:, j]) if k == "normal" else 2 * u[:, j] - 1
                                for j, k in enumerate(self.kinds)])

    def to_physical(self, z: np.ndarray) -> dict[str, np.ndarray]:
        """Germ points (n, d) -> parameter dict."""
        zc = z if self.chol is None else z @ self.chol.T
        out = {}
        for j, (name, kind) in enumerate(zip(self.names, self.kinds, strict=True)):
            m = self.space.marginal(name)
            out[name] = m.from_normal(zc[:, j]) if kind == "normal" else m.inv((zc[:, j] + 1) / 2)
        return out

    def from_physical(self, x: Mapping[str, np.ndarray]) -> np.ndarray:
        """Parameter dict -> germ points (n, d)."""
        cols = []
        for name, kind in zip(self.names, self.kinds, strict=True):
            m = self.space.marginal(name)
            v = np.asarray(x[name], dtype=float)
            if kind == "uniform":
                cols.append(2.0 * m.cdf(v) - 1.0)
            elif m.kind == "normal":  # exact affine map, no cdf round trip in the tails
                cols.append((v - m.params["mean"]) / m.params["std"])
            else:
                cols.append(special.ndtri(np.clip(m.cdf(v), 0.0, 1.0)))
        z = np.column_stack(cols)
        if self.chol is not None:
            z = linalg.solve_triangular(self.chol, z.T, lower=True).T
        return z


# =========================================================================== least squares
def _ols(psi: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares coefficients (P, m) and hat-matrix diagonal (n,) through one QR."""
    q, r = np.linalg.qr(psi, mode="reduced")
    d = np.abs(np.diag(r))
    if d.size and d.min() <= 1e-12 * d.max():
        raise np.linalg.LinAlgError("rank-deficient basis matrix")
    coef = linalg.solve_triangular(r, q.T @ y, lower=False)
    h = np.sum(q * q, axis=1)
    return coef, h


def _loo_residuals(psi: np.ndarray, y: np.ndarray, coef: np.ndarray, h: np.ndarray) -> np.ndarray:
    res = y - psi @ coef
    with np.errstate(divide="ignore", invalid="ignore"):
        return res / (1.0 - h)[:, None]


def _rel_error(res: np.ndarray, y: np.ndarray) -> tuple[float, np.ndarray]:
    """Relative mean-square error: variance-weighted scalar and per column."""
    mse = np.mean(res * res, axis=0)
    var = np.var(y, axis=0, ddof=1) if y.shape[0] > 1 else np.zeros(y.shape[1])
    tot = float(var.sum())
    with np.errstate(divide="ignore", invalid="ignore"):
        per = np.where(var > 0, mse / var, np.where(mse > 0, np.inf, 0.0))
    scalar = float(mse.sum() / tot) if tot > 0 else (0.0 if mse.sum() == 0 else math.inf)
    if not np.all(np.isfinite(res)):
        scalar = math.inf
    return scalar, per


def _loo_of_subset(psi: np.ndarray, y: np.ndarray, cols: np.ndarray) -> float:
    try:
        coef, h = _ols(psi[:, cols], y)
    except np.linalg.LinAlgError:
        return math.inf
    if np.any(h > 1 - 1e-10):
        return math.inf
    return _rel_error(_loo_residuals(psi[:, cols], y, coef, h), y)[0]


def _select_sparse(psi: np.ndarray, y: np.ndarray, solver: str) -> np.ndarray:
    """Hybrid LARS / OMP: the candidate basis along the path with the smallest LOO error."""
    from sklearn.linear_model import lars_path, orthogonal_mp

    n, p = psi.shape
    kmax = max(1, min(n - 2, p - 1))
    yc = y - y.mean()
    x = psi[:, 1:]
    candidates: list[np.ndarray] = []
    if solver == "lars":
        _, active, _ = lars_path(x, yc, method="lar", max_iter=kmax)
        active = [int(a) + 1 for a in active]
        candidates = [np.array([0, *active[:s]]) for s in range(1, len(active) + 1)]
    elif solver == "omp":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            path = orthogonal_mp(x, yc, n_nonzero_coefs=kmax, return_path=True)
        path = np.asarray(path).reshape(x.shape[1], -1)
        for s in range(path.shape[1]):
            nz = np.flatnonzero(path[:, s]) + 1
            candidates.append(np.array([0, *nz]))
    else:
        raise ValueError(f"solver: unknown {solver!r}; valid: lars, omp")
    if not candidates:
        return np.array([0])
    # LOO on a geometric grid of path lengths with early stopping: the full path costs
    # O(n s^3) per step and the LOO curve is smooth enough for this
    sizes = sorted({*range(1, min(len(candidates), 20) + 1),
                    *np.unique(np.geomspace(1, len(candidates), 40).astype(int))})
    best, best_err, worse = candidates[0], math.inf, 0
    for s in sizes:
        err = _loo_of_subset(psi, y[:, None], candidates[s - 1])
        if err < best_err:
            best, best_err, worse = candidates[s - 1], err, 0
        else:
            worse += 1
            if worse >= 8:
                break
    return best


# =========================================================================== the surrogate
class PolynomialChaos(Model):
    """A fitted polynomial chaos expansion; a :class:`gearuq.model.Model` itself.

    It answers ``response(params, t=None, *, outputs=None)`` with the same Dataset schema as
    the model it replaces (``t=None`` means the instants it was fitted on; other instants
    inside that window are interpolated linearly) and gives moments and Sobol' indices
    analytically from its coefficients.

    Attributes
    ----------
    space : ParameterSpace
        The input space (the surrogate's parameters are its names).
    indices : ndarray (P, d)
        Multi-indices of the basis.
    coefficients : dict
        Output name -> coefficient array ``(P, *output shape without sample)``.
    germ_kinds : list of str
        ``"normal"`` (Hermite) or ``"uniform"`` (Legendre) per parameter.
    method, order : str, int
        How it was fitted.
    n_evaluations : int
        Model evaluations used (including failed ones and any hold-out set).
    n_failed : int
        Design samples excluded because their status was nonzero.
    loo_error : dict
        Output -> relative leave-one-out error (mean square / variance, variance-weighted over
        time); ``loo_error_t`` per time instant.
    holdout_error : dict
        Output -> relative hold-out error (empty when no hold-out set was asked for).
    compression : dict
        Output -> ``{"components", "energy_lost", "relative_error"}`` when PCA was used.
    fit_info : dict
        Design size, basis size, wall times, options.
    """

    version = "1"

    def __init__(
        self,
        *,
        space: ParameterSpace,
        germ: _Germ,
        indices: np.ndarray,
        coefficients: dict[str, np.ndarray],
        output_meta: dict[str, dict[str, Any]],
        t: np.ndarray,
        source: Model,
        method: str,
        order: int,
        n_evaluations: int,
        n_failed: int,
        loo_error: dict[str, float],
        loo_error_t: dict[str, np.ndarray],
        holdout_error: dict[str, float] | None = None,
        compression: dict[str, dict[str, float]] | None = None,
        fit_info: dict[str, Any] | None = None,
    ) -> None:
        self.space = space
        self._germ = germ
        self.germ_kinds = list(germ.kinds)
        self.indices = np.asarray(indices, dtype=int)
        self.coefficients = coefficients
        self._meta = output_meta
        self.t = np.asarray(t, dtype=float)
        self.method = method
        self.order = int(order)
        self.n_evaluations = int(n_evaluations)
        self.n_failed = int(n_failed)
        self.loo_error = dict(loo_error)
        self.loo_error_t = dict(loo_error_t)
        self.holdout_error = dict(holdout_error or {})
        self.compression = dict(compression or {})
        self.fit_info = dict(fit_info or {})
        self.source_model = source.name
        self.name = f"pce[{source.name}]"
        self.description = f"polynomial chaos surrogate of {source.name} ({method}, order {order})"
        self.time_units = source.time_units
        self.time_long_name = source.time_long_name
        mean = space.mean()
        params = []
        for k in space.names:
            try:
                units = source.parameter(k).units
                desc = source.parameter(k).description
            except ValueError:
                units, desc = "1", ""
            params.append(Parameter(k, units, float(mean[k]), description=desc))
        self.parameters = tuple(params)
        self.outputs = tuple(
            Output(k, m["units"], ("sample", *m["dims"]), m["long_name"])
            for k, m in output_meta.items())

    # ------------------------------------------------------------------ model contract
    @property
    def n_terms(self) -> int:
        """Number of basis polynomials."""
        return int(self.indices.shape[0])

    def settings(self) -> dict[str, Any]:
        """Provenance of the surrogate."""
        return {"method": self.method, "order": self.order, "n_terms": self.n_terms,
                "source_model": self.source_model}

    def response(self, params, t=None, *, outputs=None, **options):  # noqa: D102
        names = self.validate_outputs(outputs)
        if t is None and any(self.output(o).time_dependent for o in names):
            t = self.t
        return super().response(params, t, outputs=names, **options)

    response.__doc__ = Model.response.__doc__

    def _coef_at(self, name: str, t: np.ndarray) -> np.ndarray:
        c = self.coefficients[name]
        if "time" not in self._meta[name]["dims"]:
            return c
        if t.shape == self.t.shape and np.array_equal(t, self.t):
            return c
        lo, hi = self.t.min(), self.t.max()
        if t.min() < lo - 1e-12 * max(1, abs(lo)) or t.max() > hi + 1e-12 * max(1, abs(hi)):
            raise ValueError(
                f"t: surrogate {self.name!r} was fitted on [{lo:g}, {hi:g}]; instants outside "
                "that window cannot be predicted")
        if self.t.size == 1:
            return np.repeat(c, t.size, axis=1)
        flat = c.reshape(c.shape[0], c.shape[1], -1)
        out = np.empty((c.shape[0], t.size, flat.shape[2]))
        for k in range(flat.shape[2]):
            for p in range(c.shape[0]):
                out[p, :, k] = np.interp(t, self.t, flat[p, :, k])
        return out.reshape(c.shape[0], t.size, *c.shape[2:])

    def _evaluate(self, params, t, outputs, **options):
        n = next(iter(params.values())).shape[0]
        z = self._germ.from_physical(params)
        coefs = {o: self._coef_at(o, t) for o in outputs}
        data = {o: np.empty((n, *coefs[o].shape[1:])) for o in outputs}
        for s in range(0, n, _PREDICT_CHUNK):
            psi = _basis_matrix(z[s:s + _PREDICT_CHUNK], self.indices, self.germ_kinds)
            for o in outputs:
                c = coefs[o]
                data[o][s:s + _PREDICT_CHUNK] = (psi @ c.reshape(c.shape[0], -1)).reshape(
                    psi.shape[0], *c.shape[1:])
        coords = {}
        for o in outputs:
            for k, v in self._meta[o]["coords"].items():
                coords[k] = v
        status = np.zeros(n, dtype=np.int8)
        for o in outputs:
            status[~np.isfinite(data[o].reshape(n, -1)).all(axis=1)] = 3
        return Evaluation(data=data, status=status, coords=coords,
                          attrs={"surrogate": self.description})

    def predict(self, params: Mapping[str, Any], output: str | None = None,
                t: Any = None) -> np.ndarray:
        """Surrogate values of one output as a plain array ``(n, ...)``."""
        output = output or self.output_names[0]
        ds = self.response(params, t, outputs=[output])
        return ds[output].values

    # ------------------------------------------------------------------ analytic results
    def _coords_of(self, name: str) -> dict[str, Any]:
        m = self._meta[name]
        coords = {}
        for d in m["dims"]:
            if d == "time":
                coords["time"] = ("time", self.t, {"units": self.time_units})
            elif d in m["coords"]:
                dims, values, attrs = m["coords"][d]
                coords[d] = (dims, values, attrs)
        return coords

    def _check_output(self, output: str | None) -> str:
        if output is None:
            if len(self.outputs) != 1:
                raise ValueError(f"output: this surrogate has outputs {self.output_names}; "
                                 "name one")
            return self.output_names[0]
        if output not in self.coefficients:
            raise ValueError(f"output {output!r} not fitted; fitted: {self.output_names}")
        return output

    def mean(self, output: str | None = None) -> xr.DataArray:
        """Mean of an output: the constant coefficient (orthonormal basis)."""
        o = self._check_output(output)
        m = self._meta[o]
        return xr.DataArray(self.coefficients[o][0], dims=m["dims"], coords=self._coords_of(o),
                            attrs={"units": m["units"], "long_name": f"PCE mean of {o}"})

    def variance(self, output: str | None = None) -> xr.DataArray:
        """Variance of an output: the sum of the squared non-constant coefficients."""
        o = self._check_output(output)
        m = self._meta[o]
        v = np.sum(self.coefficients[o][1:] ** 2, axis=0)
        return xr.DataArray(v, dims=m["dims"], coords=self._coords_of(o),
                            attrs={"units": f"({m['units']})2",
                                   "long_name": f"PCE variance of {o}"})

    def sobol(self, output: str | None = None, *, second_order: bool = False) -> xr.Dataset:
        """First-order, total (and second-order) Sobol' indices from the coefficients.

        ``S_i`` sums the squared coefficients of terms in ``z_i`` alone, ``ST_i`` those of
        every term containing ``z_i``, both over the variance. For a correlated space they
        are the indices of the independent germ variables (of the Nataf decorrelation, in
        parameter order), not of the dependent physical inputs.

        Returns
        -------
        xarray.Dataset
            ``S1``, ``ST`` over ``(parameter, *output dims)``, ``S2`` over
            ``(parameter, parameter_2, ...)`` on request, ``mean`` and ``variance``.
        """
        o = self._check_output(output)
        c2 = self.coefficients[o] ** 2
        idx = self.indices
        var = c2[1:].sum(axis=0)
        nz = idx > 0
        only = nz & (nz.sum(axis=1) == 1)[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            s1 = np.stack([c2[only[:, i]].sum(axis=0) / var for i in range(idx.shape[1])])
            st = np.stack([c2[nz[:, i]].sum(axis=0) / var for i in range(idx.shape[1])])
        m = self._meta[o]
        coords = {"parameter": self.space.names, **self._coords_of(o)}
        ds = xr.Dataset(coords=coords)
        ds["S1"] = (("parameter", *m["dims"]), s1, {"long_name": "first-order Sobol index"})
        ds["ST"] = (("parameter", *m["dims"]), st, {"long_name": "total Sobol index"})
        if second_order:
            d = idx.shape[1]
            s2 = np.full((d, d, *var.shape), np.nan)
            for i in range(d):
                for j in range(i + 1, d):
                    sel = nz[:, i] & nz[:, j] & (nz.sum(axis=1) == 2)
                    with np.errstate(divide="ignore", invalid="ignore"):
                        s2[i, j] = s2[j, i] = c2[sel].sum(axis=0) / var
            ds = ds.assign_coords(parameter_2=self.space.names)
            ds["S2"] = (("parameter", "parameter_2", *m["dims"]), s2,
                        {"long_name": "second-order Sobol index"})
        ds["mean"] = self.mean(o)
        ds["variance"] = self.variance(o)
        ds.attrs.update({
            "method": "pce", "output": o, "pce_method": self.method, "order": self.order,
            "n_terms": self.n_terms, "n_model_evaluations": self.n_evaluations,
            "loo_error": self.loo_error.get(o, math.nan),
            "note": ("indices of the independent germ variables (Nataf decorrelation)"
                     if self.space.correlation is not None else "independent inputs"),
        })
        return ds

    def summary(self) -> str:
        """One line per output: basis, design, LOO and hold-out errors."""
        lines = [f"{self.description}: {self.n_terms} terms, {self.n_evaluations} model "
                 f"evaluations ({self.n_failed} failed, excluded)"]
        for o in self.output_names:
            s = f"  {o}: LOO {self.loo_error.get(o, math.nan):.3e}"
            if o in self.holdout_error:
                s += f", hold-out {self.holdout_error[o]:.3e}"
            if o in self.compression:
                c = self.compression[o]
                s += f", PCA {c['components']} comp. (energy lost {c['energy_lost']:.2e})"
            lines.append(s)
        return "\n".join(lines)

    def to_dataset(self) -> xr.Dataset:
        """Coefficients, multi-indices and errors as a netCDF-safe Dataset (for the record)."""
        ds = xr.Dataset(coords={"term": np.arange(self.n_terms), "parameter": self.space.names})
        ds["multi_index"] = (("term", "parameter"), self.indices)
        for o in self.output_names:
            m = self._meta[o]
            ds[f"coef_{o}"] = (("term", *m["dims"]), self.coefficients[o], {"units": m["units"]})
            if "time" in m["dims"] and "time" not in ds.coords:
                ds = ds.assign_coords(time=("time", self.t))
            ds[f"loo_{o}"] = ((), self.loo_error.get(o, math.nan))
        ds.attrs.update({"space": self.space.to_json(), "germ": " ".join(self.germ_kinds),
                         **{k: (json.dumps(v) if isinstance(v, (dict, list)) else v)
                            for k, v in self.settings().items()},
                         "n_evaluations": self.n_evaluations, "n_failed": self.n_failed})
        return ds

    # ------------------------------------------------------------------ reliability
    def reliability(self, bands: Any, *, n_samples: int = 10**6, rng: Any = None,
                    confidence: float = 0.95, time: Any = None, **kwargs: Any) -> xr.Dataset:
        """Failure probabilities of the surrogate on ``n_samples`` random draws.

        Evaluates the surrogate on ``space.sample(n_samples, "random", rng)`` (only at the
        instants ``time`` when given, which keeps 10^6 samples x instants in memory) and
        passes the result to :func:`gearuq.reliability.reliability`. The interval is the
        sampling interval of the surrogate's Pf only; it does not include the surrogate
        error (see :func:`compare_mc_surrogate`).
        """
        from gearuq.reliability import _as_bands, reliability

        band_list = _as_bands(bands)
        outs = list(dict.fromkeys(b.output for b in band_list))
        t = None if time is None else np.atleast_1d(np.asarray(time, dtype=float))
        t0 = _now()
        x = self.space.sample(int(n_samples), "random", rng)
        ds = self.response(x, t, outputs=outs)
        rel = reliability(ds, band_list, confidence=confidence, **kwargs)
        rel.attrs.update({"engine": "pce_surrogate", "surrogate": self.description,
                          "n_surrogate_samples": int(n_samples),
                          "n_model_evaluations": self.n_evaluations,
                          "surrogate_wall_time_s": _now() - t0})
        return rel


def _now() -> float:
    return time.perf_counter()


def surrogate_reliability(pce: PolynomialChaos, space: ParameterSpace | None, bands: Any,
                          **kwargs: Any) -> xr.Dataset:
    """Reliability from a surrogate on many samples; ``pce.reliability`` with an optional space.

    ``space`` (if given and different from ``pce.space``) must have the same names; it then
    replaces the sampling distribution (e.g. a shifted design for what-if studies).
    """
    if space is not None and space is not pce.space:
        if space.names != pce.space.names:
            raise ValueError(f"space names {space.names} differ from the surrogate's "
                             f"{pce.space.names}")
        old = pce.space
        pce.space = space
        try:
            return pce.reliability(bands, **kwargs)
        finally:
            pce.space = old
    return pce.reliability(bands, **kwargs)


# =========================================================================== fitting
def _check_order(order: Any) -> int | str:
    if isinstance(order, str):
        if order != "auto":
            raise ValueError(f"order: expected a non-negative integer or 'auto', got {order!r}")
        return order
    if isinstance(order, (bool, np.bool_)) or not isinstance(order, (int, np.integer)):
        raise ValueError(f"order: expected a non-negative integer or 'auto', got {order!r}")
    if order < 0:
        raise ValueError(f"order: polynomial degree must be >= 0, got {order}")
    return int(order)


def _compress(y: np.ndarray, compress: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """PCA of the centred columns: scores (n, k), components (k, m), mean (m,), info."""
    ybar = y.mean(axis=0)
    yc = y - ybar
    _, s, vt = np.linalg.svd(yc, full_matrices=False)
    energy = s**2
    total = energy.sum()
    if isinstance(compress, float) and 0.0 < compress <= 1.0:
        frac = np.cumsum(energy) / total if total > 0 else np.ones_like(energy)
        k = int(np.searchsorted(frac, compress - 1e-15) + 1)
    elif isinstance(compress, (int, np.integer)) and not isinstance(compress, bool) \
            and compress >= 1:
        k = int(compress)
    else:
        raise ValueError(f"compress: expected a number of components (int >= 1) or an energy "
                         f"fraction in (0, 1], got {compress!r}")
    k = min(k, vt.shape[0])
    lost = float(energy[k:].sum() / total) if total > 0 else 0.0
    scores = yc @ vt[:k].T
    return scores, vt[:k], ybar, {"components": k, "energy_lost": lost}


def _fit_columns(psi: np.ndarray, y: np.ndarray, method: str, solver: str,
                 n_select: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Fit all columns of ``y`` on a shared basis.

    Returns coefficients (P_full, m), LOO residuals (n, m), the kept column set and h.
    """
    p = psi.shape[1]
    if method == "sparse":
        if y.shape[1] == 1:
            targets = y
        else:  # selection on the leading principal components, union of the supports
            yc = y - y.mean(axis=0)
            u, s, _ = np.linalg.svd(yc, full_matrices=False)
            keep = max(1, min(n_select, int(np.sum(s > 1e-12 * (s[0] if s.size else 0)))))
            targets = u[:, :keep] * s[:keep]
        sel: set[int] = set()
        for j in range(targets.shape[1]):
            sel.update(int(c) for c in _select_sparse(psi, targets[:, j], solver))
        cols = np.array(sorted(sel))
    else:
        cols = np.arange(p)
    sub = psi[:, cols]
    coef_sub, h = _ols(sub, y)
    loo = _loo_residuals(sub, y, coef_sub, h)
    coef = np.zeros((p, y.shape[1]))
    coef[cols] = coef_sub
    return coef, loo, cols, h


def polynomial_chaos(
    model: Model | str,
    space: ParameterSpace,
    t: Any = None,
    *,
    order: int | str,
    method: str = "regression",
    outputs: str | Iterable[str] | None = None,
    n_samples: int | None = None,
    rule: str = "sobol",
    rng: Any = None,
    sparse_grid: bool = False,
    truncation: float = 1.0,
    compress: int | float | None = None,
    executor: Any = "serial",
    oversampling: float = 2.0,
    solver: str = "lars",
    max_order: int = 6,
    n_holdout: int = 0,
    germ: str = "auto",
    chunk_size: int | None = None,
    progress: bool | None = False,
    **options: Any,
) -> PolynomialChaos:
    """Fit a polynomial chaos surrogate of ``model`` over ``space``.

    Parameters
    ----------
    model : Model or str
        Model instance or registered name.
    space : ParameterSpace
        Random inputs (names must be model parameters; the others stay nominal).
    t : array_like, optional
        Output instants (required for time-dependent outputs); the surrogate is fitted on
        them, all instants at once.
    order : int or "auto"
        Total polynomial degree (>= 0); ``"auto"`` picks the degree in ``1..max_order`` with
        the smallest leave-one-out error on one design (regression and sparse only).
    method : {"regression", "sparse", "quadrature"}
        Least squares, hybrid LARS/OMP sparse least squares, or spectral projection.
    outputs : str or list of str, optional
        Outputs to fit (default: all). Each has its own coefficients; design and basis are
        shared.
    n_samples : int, optional
        Design size for regression/sparse (default ``ceil(oversampling * P)`` with ``P`` the
        basis size, of the largest degree for ``order="auto"``). Regression needs
        ``n_samples > P``.
    rule : {"random", "lhs", "sobol", "halton"}
        Design rule (scrambled Sobol' by default).
    rng : int or Generator, optional
        Seed of the design (and of the hold-out set).
    sparse_grid : bool
        Quadrature: Smolyak sparse grid instead of the Gauss tensor grid.
    truncation : float
        Hyperbolic q-norm of the basis, in (0, 1].
    compress : int or float, optional
        PCA across the non-sample dims (time) of each output: number of components (int) or
        energy fraction (float in (0, 1]). The energy lost and the training error of the
        reconstruction are reported in ``compression`` and included in the LOO error.
    executor : optional
        As in :func:`gearuq.engines.montecarlo.monte_carlo` (default ``"serial"``).
    oversampling : float
        Default design size over basis size for regression / sparse.
    solver : {"lars", "omp"}
        Sparse regressor path.
    max_order : int
        Largest degree tried by ``order="auto"``.
    n_holdout : int
        Size of an independent random validation set (0: none); its relative error is
        stored in ``holdout_error`` and its evaluations are counted.
    germ : {"auto", "normal"}
        ``"auto"``: Legendre germ for independent uniform marginals, Hermite otherwise;
        ``"normal"``: Hermite everywhere.
    chunk_size, progress
        Passed to :func:`gearuq.execution.evaluate_chunks`.
    **options
        Model options.

    Returns
    -------
    PolynomialChaos

    Raises
    ------
    ValueError
        Negative or non-integer order, unknown method/rule/solver, parameters not in the model,
        a design smaller than the basis, no valid sample.
    """
    from gearuq.engines.montecarlo import resolve_model_and_space, resolve_seed
    from gearuq.execution import evaluate_chunks

    wall0 = _now()
    model, space = resolve_model_and_space(model, space)
    if method not in METHODS:
        raise ValueError(f"method: unknown {method!r}; valid: {', '.join(METHODS)}")
    if solver not in ("lars", "omp"):
        raise ValueError(f"solver: unknown {solver!r}; valid: lars, omp")
    order = _check_order(order)
    if order == "auto" and method == "quadrature":
        raise ValueError("order='auto' needs method 'regression' or 'sparse' (a LOO error)")
    if not 0 < float(truncation) <= 1:
        raise ValueError(f"truncation: q-norm must lie in (0, 1], got {truncation!r}")
    if not isinstance(rule, str) or rule.lower() not in RULES:
        raise ValueError(f"rule: unknown sampling rule {rule!r}; valid: {', '.join(RULES)}")
    if order == "auto" and (not isinstance(max_order, int) or max_order < 1):
        raise ValueError(f"max_order: expected an integer >= 1, got {max_order!r}")
    request = model.prepare(t, outputs=outputs, **options)
    names, t_arr = list(request.outputs), request.t
    seed = resolve_seed(rng)
    g = _Germ(space, germ)
    d = space.dim
    orders = list(range(1, max_order + 1)) if order == "auto" else [order]
    index_sets = {p: multi_indices(d, p, truncation) for p in orders}
    p_big = index_sets[orders[-1]].shape[0]

    # ---- design
    weights = None
    if method == "quadrature":
        nodes, weights = cp.generate_quadrature(order, g.joint(), rule="gaussian",
                                                sparse=bool(sparse_grid))
        z = np.asarray(nodes, dtype=float).T.reshape(-1, d)
        weights = np.asarray(weights, dtype=float)
    else:
        if n_samples is None:
            n = int(math.ceil(oversampling * p_big))
            if rule.lower() == "sobol":  # Sobol' balance needs a power of 2
                n = 1 << (n - 1).bit_length()
        else:
            n = n_samples
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"n_samples: expected a positive integer, got {n_samples!r}")
        p_small = index_sets[orders[0]].shape[0]
        if method == "regression" and n <= p_small:
            raise ValueError(
                f"n_samples: design of {n} samples is not larger than the basis of {p_small} "
                f"terms (order {orders[0]}, {d} parameters); give n_samples > {p_small} "
                f"(typically 2-3x) or use method='sparse'")
        if method == "sparse" and n < 3:
            raise ValueError(f"n_samples: sparse regression needs at least 3 samples, got {n}")
        u = space.sample_unit(int(n), rule.lower(), seed)
        z = g.from_unit(u)
    x = g.to_physical(z)
    try:
        model.validate_params(x)
    except ValueError as exc:
        raise ValueError(f"design: {exc}") from None

    t_eval = _now()
    ds = evaluate_chunks(model, x, request, chunk_size=chunk_size,
                         executor=executor, progress=progress)
    t_eval = _now() - t_eval
    status = np.asarray(ds["status"].values)
    valid = status == 0
    n_eval = int(status.size)
    n_failed = int((~valid).sum())
    if valid.sum() == 0:
        raise ValueError(f"no valid model sample: all {n_eval} design points failed")
    zv = z[valid]

    meta: dict[str, dict[str, Any]] = {}
    ys: dict[str, np.ndarray] = {}
    for o in names:
        da = ds[o]
        rest = [dd for dd in da.dims if dd != "sample"]
        da = da.transpose("sample", *rest)
        coords = {}
        for dd in rest:
            if dd != "time" and dd in ds.coords:
                coords[dd] = (ds[dd].dims, ds[dd].values, dict(ds[dd].attrs))
        meta[o] = {"dims": tuple(rest), "shape": da.shape[1:], "units": da.attrs.get("units", ""),
                   "long_name": da.attrs.get("long_name", ""), "coords": coords}
        yv = da.values.reshape(status.size, -1)[valid]
        if not np.all(np.isfinite(yv)):
            raise ValueError(f"output {o!r}: non-finite values in samples with status 0")
        ys[o] = yv

    # ---- fit
    t_fit = _now()
    coefs: dict[str, np.ndarray] = {}
    loo: dict[str, float] = {}
    loo_t: dict[str, np.ndarray] = {}
    comp_info: dict[str, dict[str, float]] = {}
    chosen_order = orders[0]
    if method == "quadrature":
        psi = _basis_matrix(zv, index_sets[order], g.kinds)
        idx = index_sets[order]
        full = valid.all()
        for o in names:
            y = ys[o]
            if full:
                c = psi.T @ (weights[:, None] * y)
            else:  # the rule is broken by the missing nodes: least squares on the valid ones
                c = np.linalg.lstsq(psi, y, rcond=None)[0]
            coefs[o] = c
            if psi.shape[0] > psi.shape[1]:
                try:
                    c_ls, h = _ols(psi, y)
                    loo[o], loo_t[o] = _rel_error(_loo_residuals(psi, y, c_ls, h), y)
                except np.linalg.LinAlgError:
                    loo[o], loo_t[o] = math.nan, np.full(y.shape[1], math.nan)
            else:
                loo[o], loo_t[o] = math.nan, np.full(y.shape[1], math.nan)
        if not full:
            warnings.warn(f"{n_failed} quadrature node(s) failed; coefficients by least "
                          "squares on the valid nodes", RuntimeWarning, stacklevel=2)
    else:
        best = None
        for p in orders:
            idx_p = index_sets[p]
            if method == "regression" and zv.shape[0] <= idx_p.shape[0]:
                if order != "auto":
                    raise ValueError(
                        f"n_samples: {zv.shape[0]} valid samples ({n_failed} failed) are not "
                        f"more than the {idx_p.shape[0]} basis terms of order {p}")
                break
            psi_p = _basis_matrix(zv, idx_p, g.kinds)
            res = _fit_all(psi_p, ys, names, method, solver, compress)
            score = sum(res[1][o] * max(float(np.var(ys[o], axis=0, ddof=1).sum()), 1e-300)
                        for o in names) / sum(max(float(np.var(ys[o], axis=0, ddof=1).sum()),
                                                  1e-300) for o in names)
            if best is None or score < best[0]:
                best = (score, p, idx_p, res)
        if best is None:
            raise ValueError(f"n_samples: {zv.shape[0]} valid samples are too few for any "
                             "order in 1..max_order")
        _, chosen_order, idx, (coefs, loo, loo_t, comp_info) = best
    n_candidate = int(idx.shape[0])
    if method == "sparse":  # keep only the selected terms: prediction cost scales with them
        nz = np.zeros(idx.shape[0], dtype=bool)
        nz[0] = True
        for c in coefs.values():
            nz |= np.any(c != 0, axis=1)
        idx = idx[nz]
        coefs = {o: c[nz] for o, c in coefs.items()}
    for o in names:
        coefs[o] = coefs[o].reshape(coefs[o].shape[0], *meta[o]["shape"])
    t_fit = _now() - t_fit

    # ---- surrogate
    pce = PolynomialChaos(
        space=space, germ=g, indices=idx, coefficients=coefs, output_meta=meta,
        t=t_arr if t_arr is not None else np.zeros(0), source=model, method=method,
        order=chosen_order, n_evaluations=n_eval, n_failed=n_failed, loo_error=loo,
        loo_error_t=loo_t, compression=comp_info,
        fit_info={"n_design": n_eval, "n_terms_candidate": n_candidate,
                  "rule": rule if method != "quadrature" else
                  ("smolyak" if sparse_grid else "gauss_tensor"),
                  "seed": seed, "truncation": float(truncation), "solver": solver,
                  "orders_tried": orders, "model_time_s": t_eval, "fit_time_s": t_fit},
    )
    if method == "sparse":
        pce.fit_info["n_terms_selected"] = int(idx.shape[0])
    if n_holdout:
        xh = space.sample(int(n_holdout), "random", seed + 1)
        dh = evaluate_chunks(model, xh, request, executor=executor, progress=progress)
        ok = np.asarray(dh["status"].values) == 0
        pred = pce.response({k: v[ok] for k, v in xh.items()}, t_arr, outputs=names)
        for o in names:
            yt = dh[o].transpose("sample", ...).values.reshape(ok.size, -1)[ok]
            yp = pred[o].transpose("sample", ...).values.reshape(int(ok.sum()), -1)
            pce.holdout_error[o] = _rel_error(yp - yt, yt)[0]
        pce.n_evaluations += int(ok.size)
        pce.n_failed += int((~ok).sum())
    pce.fit_info["wall_time_s"] = _now() - wall0
    return pce


def _fit_all(psi: np.ndarray, ys: dict[str, np.ndarray], names: list[str], method: str,
             solver: str, compress: Any) -> tuple[dict, dict, dict, dict]:
    coefs, loo, loo_t, comp = {}, {}, {}, {}
    for o in names:
        y = ys[o]
        if compress is not None and y.shape[1] > 1:
            scores, comps, ybar, info = _compress(y, compress)
            recon = ybar + scores @ comps
            info["relative_error"] = _rel_error(recon - y, y)[0]
            try:
                c, loo_res, _, _ = _fit_columns(psi, scores, method, solver)
            except np.linalg.LinAlgError:
                raise ValueError("basis matrix is rank deficient on this design; use more "
                                 "samples or a lower order") from None
            full = c @ comps
            full[0] += ybar
            res = loo_res @ comps + (y - recon)
            coefs[o] = full
            loo[o], loo_t[o] = _rel_error(res, y)
            comp[o] = info
        else:
            try:
                c, loo_res, _, _ = _fit_columns(psi, y, method, solver)
            except np.linalg.LinAlgError:
                raise ValueError("basis matrix is rank deficient on this design; use more "
                                 "samples or a lower order") from None
            coefs[o] = c
            loo[o], loo_t[o] = _rel_error(loo_res, y)
    return coefs, loo, loo_t, comp


# =========================================================================== MC vs surrogate
def compare_mc_surrogate(
    model: Model | str,
    space: ParameterSpace,
    bands: Any,
    t: Any = None,
    *,
    n_mc: int,
    order: int | str = 2,
    method: str = "regression",
    n_samples: int | None = None,
    n_surrogate: int = 10**6,
    rng: int = 0,
    executor: Any = "serial",
    confidence: float = 0.95,
    mc: xr.Dataset | None = None,
    mc_wall_time: float | None = None,
    **pce_options: Any,
) -> xr.Dataset:
    """Monte Carlo and PCE-surrogate failure probabilities side by side.

    Parameters
    ----------
    model, space, t
        As in :func:`polynomial_chaos`.
    bands
        Failure modes (see :func:`gearuq.reliability.reliability`); the outputs they name
        are fitted.
    n_mc : int
        Monte Carlo samples of the model (ignored when ``mc`` is given).
    order, method, n_samples, **pce_options
        Passed to :func:`polynomial_chaos`.
    n_surrogate : int
        Samples of the surrogate.
    rng : int
        Seed (Monte Carlo uses ``rng``, the design ``rng + 1``, the surrogate draw ``rng + 2``).
    mc, mc_wall_time : optional
        A precomputed Monte Carlo result and its wall time (reused as reference).

    Returns
    -------
    xarray.Dataset
        Over ``approach`` (``monte_carlo``, ``pce``) and ``mode``: ``pf``, ``pf_lower``,
        ``pf_upper``; over ``approach``: ``n_model_evaluations``, ``wall_time``; and
        ``pce_in_mc_interval`` / ``loo_error`` / ``evaluation_ratio`` as attributes-like
        variables. Times are for this machine only.
    """
    from gearuq.engines.montecarlo import monte_carlo
    from gearuq.reliability import _as_bands, reliability

    band_list = _as_bands(bands)
    outs = list(dict.fromkeys(b.output for b in band_list))
    if mc is None:
        t0 = _now()
        mc = monte_carlo(model, space, t, n_samples=n_mc, rng=rng, outputs=outs,
                         executor=executor, progress=False)
        mc_wall_time = _now() - t0
    rel_mc = reliability(mc, band_list, confidence=confidence)
    t0 = _now()
    pce = polynomial_chaos(model, space, t, order=order, method=method, outputs=outs,
                           n_samples=n_samples, rng=rng + 1, executor=executor, **pce_options)
    t_fit = _now() - t0
    rel_pce = pce.reliability(band_list, n_samples=n_surrogate, rng=rng + 2,
                              confidence=confidence)
    t_pce = _now() - t0
    if "time" in rel_mc.dims:
        rel_mc = rel_mc.isel(time=-1)
        rel_pce = rel_pce.isel(time=-1)
    keys = ("pf", "pf_lower", "pf_upper")
    out = xr.Dataset(coords={"approach": ["monte_carlo", "pce"], "mode": rel_mc["mode"].values})
    for k in keys:
        out[k] = (("approach", "mode"), np.stack([rel_mc[k].values, rel_pce[k].values]))
    out["n_model_evaluations"] = ("approach", [int(mc.sizes["sample"]), pce.n_evaluations])
    out["wall_time"] = ("approach", [float(mc_wall_time or math.nan), t_pce],
                        {"units": "s", "long_name": "wall time on this machine"})
    inside = (rel_pce["pf"].values >= rel_mc["pf_lower"].values) & (
        rel_pce["pf"].values <= rel_mc["pf_upper"].values)
    out["pce_in_mc_interval"] = ("mode", inside.astype(np.int8))
    out["pce_loo_error"] = float(np.mean([pce.loo_error[o] for o in outs]))
    out.attrs.update({"pce": pce.description, "pce_fit_time_s": t_fit,
                      "n_surrogate_samples": int(n_surrogate), "confidence": confidence,
                      "evaluation_ratio": pce.n_evaluations / int(mc.sizes["sample"])})
    return out
