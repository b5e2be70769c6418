"""One entry point for failure probabilities, one report form, and the shared evaluator.

:func:`failure_probability` runs any of the rare-event methods on a model, a parameter space
and a limit state, and returns the same labelled Dataset for each:

==============  ===============================================================================
method          what it does
==============  ===============================================================================
``mc``          crude Monte Carlo / LHS / QMC, optionally as independent randomised replicates
``form``        first-order reliability method (iHLRF design point search, multiple starts)
``sorm``        FORM + curvatures: Breitung, Hohenbichler-Rackwitz, Tvedt
``importance``  importance sampling around the FORM design point(s) (a mixture for several)
``subset``      subset simulation (modified Metropolis), also for first passage over time
``akmcs``       active-learning Kriging on a Monte Carlo population (AK-MCS, AK-SYS)
==============  ===============================================================================

Every method works in the independent standard normal space ``u`` of the
:class:`~gearuq.space.ParameterSpace`: ``z = L u`` (``L`` the Cholesky factor of the Gaussian
copula's correlation, identity when independent) and ``x_j = F_j^{-1}(Phi(z_j))``. Model runs
go through :func:`gearuq.execution.evaluate_chunks` (chunked, failure-isolating, resumable with
a store), and every run is counted.

The report (:func:`failure_report`) holds ``pf``, its interval ``pf_lower``/``pf_upper`` (what
kind is in ``attrs["interval_kind"]``), ``cov_pf``, ``beta`` with its interval, ``n_model_runs``,
``n_invalid``, ``wall_time``, a ``status`` flag, the method settings and, where relevant, the
design point(s) in physical and standard space with importance factors.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from scipy import linalg, special, stats

from gearuq.engines.common import provenance, resolve_model_and_space, resolve_seed
from gearuq.limitstate import System, as_limit_state
from gearuq.model import Model, Option, Request
from gearuq.space import ParameterSpace

__all__ = ["failure_probability", "failure_report", "LimitStateEvaluator", "METHODS",
           "REPORT_STATUS", "validate_settings", "method_settings"]

#: Method names accepted by :func:`failure_probability`.
METHODS = ("mc", "form", "sorm", "importance", "subset", "akmcs")

#: Meaning of the report's ``status`` flag.
REPORT_STATUS = {
    0: "ok",
    1: "not_converged",
    2: "model_failure",
    3: "weights_degenerate",
    4: "upper_bound_only",
    5: "approximation_invalid",
}


# =========================================================================== settings
def method_settings(method: str) -> tuple[Option, ...]:
    """The declared settings of a method (name, default, valid values, meaning)."""
    method = _check_method(method)
    if method == "mc":
        return MC_SETTINGS
    if method in ("form", "sorm"):
        from gearuq.engines import form

        return form.FORM_SETTINGS if method == "form" else form.SORM_SETTINGS
    if method == "importance":
        from gearuq.engines import importance

        return importance.SETTINGS
    if method == "subset":
        from gearuq.engines import subset

        return subset.SETTINGS
    from gearuq.engines import akmcs

    return akmcs.SETTINGS


def validate_settings(method: str, settings: Mapping[str, Any]) -> dict[str, Any]:
    """Check method settings; return every declared setting with defaults filled in.

    Raises
    ------
    ValueError
        Unknown setting (the message lists the valid ones) or a bad value.
    """
    declared = method_settings(method)
    names = [o.name for o in declared]
    unknown = sorted(set(settings) - set(names))
    if unknown:
        valid = ", ".join(f"{o.name} ({o.valid_text()})" for o in declared)
        raise ValueError(f"method {method!r}: unknown setting(s) {', '.join(map(repr, unknown))};"
                         f" valid: {valid}")
    return {o.name: o.validate(settings.get(o.name, o.default), f"method {method!r}")
            for o in declared}


def _check_method(method: Any) -> str:
    key = str(method).strip().lower().replace("-", "").replace("_", "")
    aliases = {"montecarlo": "mc", "is": "importance", "ss": "subset"}
    key = aliases.get(key, key)
    if key not in METHODS:
        raise ValueError(f"method: unknown {method!r}; valid: {', '.join(METHODS)}")
    return key


MC_SETTINGS = (
    Option("n_samples", 10_000, "samples per replicate", lower=1),
    Option("rule", "random", "sampling rule", choices=("random", "lhs", "sobol", "halton")),
    Option("replicates", 1, "independent randomised designs; >= 2 gives a Student-t interval "
           "valid for LHS and QMC designs", lower=1),
    Option("batch_size", 20_000, "largest design evaluated at once (random rule; bounds the "
           "memory of time-dependent outputs)", lower=1),
)


# =========================================================================== the evaluator
class LimitStateEvaluator:
    """Evaluate a limit state at points of the standard normal space, counting model runs.

    Parameters
    ----------
    model : Model or str
    space : ParameterSpace or mapping
    limit_state : LimitState, System, Band or output name
    t : array_like, optional
        Output instants (time-dependent limit states use ``min_t g(t)``).
    model_options : mapping, optional
        Declared model options.
    executor, chunk_size :
        As in :func:`gearuq.execution.evaluate_chunks`.
    store : path-like, optional
        Directory; every evaluation ``tag`` gets its own chunk store below it, so an
        interrupted run resumes where it stopped.
    engine : str
        Name recorded in the stores' fingerprints.
    seed : int, optional
        Recorded in the stores' fingerprints.
    """

    def __init__(self, model: Model | str, space: ParameterSpace | Mapping[str, Any],
                 limit_state: Any, t: Any = None, *, model_options: Mapping[str, Any] | None
                 = None, executor: Any = None, chunk_size: int | None = None,
                 store: str | os.PathLike | None = None, engine: str = "failure_probability",
                 seed: int | None = None, fingerprint: Mapping[str, Any] | None = None) -> None:
        self.model, self.space = resolve_model_and_space(model, space)
        self.limit_state = as_limit_state(limit_state)
        known = set(self.model.output_names) | set(self.model.parameter_names)
        unknown = [v for v in self.limit_state.variables if v not in known]
        if unknown:
            raise ValueError(
                f"limit state {self.limit_state.name!r}: unknown output(s) "
                f"{', '.join(map(repr, unknown))} of model {self.model.name!r}; valid outputs: "
                f"{', '.join(self.model.output_names)}")
        outputs = [v for v in self.limit_state.variables if v in self.model.output_names]
        if not outputs:
            raise ValueError(f"limit state {self.limit_state.name!r} reads no model output "
                             f"(only inputs {list(self.limit_state.variables)})")
        self.request: Request = self.model.prepare(t, outputs=outputs, **dict(model_options or {}))
        self.names = self.space.names
        self.dim = self.space.dim
        corr = self.space.correlation
        self.chol = None if corr is None else np.linalg.cholesky(corr)
        self.marginals = [self.space.marginal(n) for n in self.names]
        self.leaves = self.limit_state.leaves()
        self.executor, self.chunk_size = executor, chunk_size
        self.store = None if store is None else Path(store)
        self.engine, self.seed = engine, seed
        self.extra_fingerprint = dict(fingerprint or {})
        self.n_runs = 0
        self.n_invalid = 0
        self.errors: list[str] = []

    # ------------------------------------------------------------------ maps
    def to_correlated(self, u: np.ndarray) -> np.ndarray:
        """Correlated standard normals ``z = L u``."""
        u = np.atleast_2d(np.asarray(u, dtype=float))
        return u if self.chol is None else u @ self.chol.T

    def to_physical(self, u: Any) -> dict[str, np.ndarray]:
        """Physical parameter values of standard normal points ``u`` (n, dim)."""
        z = self.to_correlated(u)
        return {n: m.from_normal(z[:, j]) for j, (n, m) in enumerate(
            zip(self.names, self.marginals, strict=True))}

    def to_standard(self, x: Mapping[str, Any]) -> np.ndarray:
        """Standard normal points of physical values (inverse of :meth:`to_physical`)."""
        cols = []
        for n, m in zip(self.names, self.marginals, strict=True):
            p = np.clip(np.asarray(m.cdf(np.asarray(x[n], dtype=float)), dtype=float), 0, 1)
            cols.append(special.ndtri(p))
        z = np.column_stack(cols)
        if self.chol is None:
            return z
        return linalg.solve_triangular(self.chol, z.T, lower=True).T

    def in_range(self, u: Any) -> np.ndarray:
        """Whether each point's physical values lie in the model's valid ranges."""
        x = self.to_physical(u)
        ok = np.ones(np.atleast_2d(u).shape[0], dtype=bool)
        for n in self.names:
            par = self.model.parameter(n)
            ok &= (x[n] >= par.lower) & (x[n] <= par.upper)
        return ok

    def outside_range(self, u: Any) -> list[str]:
        """Messages for points whose physical values leave the model's valid ranges."""
        x = self.to_physical(u)
        out = []
        for n in self.names:
            par = self.model.parameter(n)
            bad = (x[n] < par.lower) | (x[n] > par.upper)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                out.append(f"parameter {n!r} = {x[n][i]:.6g} (u = {np.atleast_2d(u)[i]}) is "
                           f"outside the model's valid range {par.range_text()}")
        return out

    # ------------------------------------------------------------------ evaluation
    def evaluate(self, u: Any, tag: str) -> dict[str, np.ndarray]:
        """Run the model at points ``u`` (n, dim) and return the limit state.

        Returns
        -------
        dict
            ``g`` (n,) system/first-passage limit-state value (NaN where invalid), ``leaf``
            (n, n_leaves) component values, ``status`` (n,) int (0 = ok), ``x`` the physical
            points.

        Raises
        ------
        ValueError
            If a point's physical value leaves the model's valid range (names the parameter,
            the value and the range).
        """
        from gearuq.execution import evaluate_chunks

        u = np.atleast_2d(np.asarray(u, dtype=float))
        if u.shape[1] != self.dim or not np.all(np.isfinite(u)):
            raise ValueError(f"evaluate: expected finite points of shape (n, {self.dim}), got "
                             f"{u.shape}")
        bad = self.outside_range(u)
        if bad:
            p_out = {k: v for k, v in self.space.check_range(self.model).items() if v > 0}
            hint = (f"; the space puts probability {p_out} outside the valid range: truncate "
                    "the marginal(s)" if p_out else "")
            raise ValueError(f"{self.engine} ({tag}): {bad[0]}{hint}")
        x = self.to_physical(u)
        n = u.shape[0]
        store = None if self.store is None else self.store / tag
        fp = {"engine": self.engine, "tag": tag, "seed": self.seed,
              "limit_state": self.limit_state.to_json(), **self.extra_fingerprint}
        try:
            # small designs (a gradient, an MCMC step) are one chunk; large ones chunk by the
            # driver's default (at most 64 MB of result per chunk)
            ds = evaluate_chunks(self.model, x, self.request, executor=self.executor,
                                 chunk_size=self.chunk_size or (n if n <= 4096 else None),
                                 store=store, progress=False, fingerprint=fp)
        except RuntimeError as exc:  # every sample failed: flag them, keep going
            self.errors.append(f"{tag}: {str(exc).split(chr(10))[0][:300]}")
            self.n_runs += n
            self.n_invalid += n
            nan = np.full(n, np.nan)
            return {"g": nan, "leaf": np.full((n, len(self.leaves)), np.nan),
                    "status": np.full(n, 4, dtype=np.int8), "x": x}
        return self._limit_state_values(ds, x, n, tag)

    def _limit_state_values(self, ds: xr.Dataset, x: dict[str, np.ndarray], n: int,
                            tag: str) -> dict[str, np.ndarray]:
        status = np.asarray(ds["status"].values).astype(np.int8)
        leaf = np.column_stack([leaf.sample_values(ds) for leaf in self.leaves])
        if isinstance(self.limit_state, System):
            g, _ = self.limit_state.combine(leaf)
        else:
            g = leaf[:, 0].copy()
        nonfinite = (status == 0) & ~np.isfinite(g)
        if nonfinite.any():  # the limit-state function gave NaN on valid outputs: flag it
            self.errors.append(f"{tag}: limit state non-finite at {int(nonfinite.sum())} "
                               "valid sample(s)")
            status[nonfinite] = 3
        invalid = status != 0
        g[invalid] = np.nan
        leaf[invalid] = np.nan
        if invalid.any() and "failures" in ds.attrs:
            groups = json.loads(ds.attrs["failures"])
            self.errors += [f"{tag}: {len(g['samples'])} sample(s): {g['error'][:300]}"
                            for g in groups]
        self.n_runs += n
        self.n_invalid += int(invalid.sum())
        return {"g": g, "leaf": leaf, "status": status, "x": x}

    def fingerprint_settings(self) -> dict[str, Any]:
        """Description for provenance."""
        return {"limit_state": self.limit_state.to_json(), "n_leaves": len(self.leaves)}


# =========================================================================== report
def failure_report(
    ev: LimitStateEvaluator,
    method: str,
    *,
    pf: float,
    pf_lower: float = math.nan,
    pf_upper: float = math.nan,
    cov: float = math.nan,
    interval_kind: str,
    confidence: float,
    settings: Mapping[str, Any],
    seed: int | None,
    wall_time: float,
    status: int = 0,
    message: str = "",
    pf_is_upper_bound: bool = False,
    design_points: Sequence[Mapping[str, Any]] | None = None,
    extra: Mapping[str, tuple] | None = None,
    extra_attrs: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """The one report form of every reliability method.

    Parameters
    ----------
    ev : LimitStateEvaluator
        Gives the model, space, limit state, run counts and errors.
    method : str
        Method name.
    pf, pf_lower, pf_upper, cov : float
        Estimate, interval (NaN when the method has none) and coefficient of variation.
    interval_kind : str
        What the interval is (recorded in the attrs).
    design_points : list of dict, optional
        Each with ``u`` (dim,), ``beta``; physical values, alpha and importance factors are
        derived here.
    extra : mapping, optional
        Method-specific variables ``name -> (dims, values, attrs)``.

    Returns
    -------
    xarray.Dataset
        See the module docstring; scalars ``pf``, ``pf_lower``, ``pf_upper``, ``cov_pf``,
        ``beta``, ``beta_lower``, ``beta_upper``, ``n_model_runs``, ``n_invalid``,
        ``wall_time``, ``status``, ``pf_is_upper_bound``.
    """
    beta, beta_lo, beta_up = (float(stats.norm.isf(p)) if np.isfinite(p) else math.nan
                              for p in (pf, pf_upper, pf_lower))
    flag = {"units": "1", "flag_values": np.array(sorted(REPORT_STATUS), dtype=np.int8),
            "flag_meanings": " ".join(REPORT_STATUS[k] for k in sorted(REPORT_STATUS))}
    data: dict[str, Any] = {
        "pf": ((), float(pf), {"units": "1", "long_name": "failure probability estimate"}),
        "pf_lower": ((), float(pf_lower), {"units": "1", "long_name":
                     "lower end of the interval of pf (see attrs interval_kind)"}),
        "pf_upper": ((), float(pf_upper), {"units": "1", "long_name":
                     "upper end of the interval of pf (see attrs interval_kind)"}),
        "cov_pf": ((), float(cov), {"units": "1", "long_name":
                   "coefficient of variation of the pf estimator"}),
        "beta": ((), beta, {"units": "1", "long_name": "generalised reliability index "
                            "-Phi^-1(pf)"}),
        "beta_lower": ((), beta_lo, {"units": "1", "long_name": "-Phi^-1(pf_upper)"}),
        "beta_upper": ((), beta_up, {"units": "1", "long_name": "-Phi^-1(pf_lower)"}),
        "n_model_runs": ((), np.int64(ev.n_runs), {"units": "1", "long_name":
                         "model evaluations (samples) used, all stages included"}),
        "n_invalid": ((), np.int64(ev.n_invalid), {"units": "1", "long_name":
                      "model evaluations with nonzero status (counted, never dropped "
                      "silently; see attrs errors)"}),
        "wall_time": ((), float(wall_time), {"units": "s", "long_name": "wall-clock time"}),
        "status": ((), np.int8(status), {**flag, "long_name": "outcome of the method"}),
        "pf_is_upper_bound": ((), np.int8(pf_is_upper_bound), {
            "units": "1", "long_name": "1 where no failure was observed and pf is the upper "
            "end of the interval, not an estimate"}),
    }
    coords: dict[str, Any] = {}
    if design_points:
        data.update(_design_point_vars(ev, design_points))
        coords["parameter"] = ("parameter", np.array(ev.names, dtype=str))
        coords["design_point"] = ("design_point", np.arange(len(design_points)))
    for k, v in (extra or {}).items():
        data[k] = v
    out = xr.Dataset(data, coords=coords)
    out.attrs.update(provenance("failure_probability", ev.model, ev.request, ev.space, seed,
                                method=method, settings=dict(settings)))
    out.attrs.update({
        "method": method,
        "interval_kind": interval_kind,
        "confidence": float(confidence),
        "limit_state": ev.limit_state.to_json(),
        "failure_definition": "a sample fails where the limit state g <= 0 (boundary fails); "
                              "time-dependent g: first passage, min over the output instants",
        "message": message or REPORT_STATUS[int(status)],
    })
    if ev.errors:
        out.attrs["errors"] = json.dumps(ev.errors[:50])
    out.attrs.update(dict(extra_attrs or {}))
    return out


def _design_point_vars(ev: LimitStateEvaluator, design_points: Sequence[Mapping[str, Any]]
                       ) -> dict[str, Any]:
    """Design points in both spaces, alpha and importance factors per design point."""
    u = np.array([np.asarray(dp["u"], dtype=float) for dp in design_points])
    betas = np.array([float(dp["beta"]) for dp in design_points])
    x = ev.to_physical(u)
    xs = np.column_stack([x[n] for n in ev.names])
    with np.errstate(invalid="ignore", divide="ignore"):
        alpha = u / np.linalg.norm(u, axis=1, keepdims=True)
    # importance of the physical parameters: gamma = L^-T alpha / |L^-T alpha| (Der Kiureghian)
    gamma = alpha if ev.chol is None else linalg.solve_triangular(
        ev.chol.T, alpha.T, lower=False).T
    with np.errstate(invalid="ignore", divide="ignore"):
        gamma = gamma / np.linalg.norm(gamma, axis=1, keepdims=True)
    dims = ("design_point", "parameter")
    units = "; ".join(f"{n}: {ev.model.parameter(n).units}" for n in ev.names)
    return {
        "beta_design_point": (("design_point",), betas, {
            "units": "1", "long_name": "distance of the design point from the origin"}),
        "design_point_u": (dims, u, {"units": "1", "long_name":
                           "design point in the independent standard normal space"}),
        "design_point_x": (dims, xs, {"units": units, "long_name":
                           "design point in physical parameters (units per parameter)"}),
        "alpha": (dims, alpha, {"units": "1", "long_name":
                  "unit vector u*/beta towards the design point (independent normal space)"}),
        "importance_factor": (dims, gamma**2, {"units": "1", "long_name": (
            "importance factors gamma^2 of the physical parameters, gamma = L^-T alpha / "
            "|L^-T alpha| (equals alpha^2 for independent inputs); they sum to 1")}),
    }


# =========================================================================== crude MC
def run_mc(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float
           ) -> xr.Dataset:
    """Crude Monte Carlo (or LHS / QMC), with randomised replicates when asked."""
    from gearuq.probability import binomial_interval

    t0 = time.perf_counter()
    counts = []
    for r in range(s["replicates"]):
        k, n = 0, 0
        for b, u in enumerate(_mc_designs(ev, s, seed, r)):
            res = ev.evaluate(u, f"mc/rep{r}/batch{b}")
            ok = res["status"] == 0
            k += int(np.sum(res["g"][ok] <= 0.0))
            n += int(ok.sum())
        if n == 0:
            raise RuntimeError(f"mc: no valid sample in replicate {r}; errors: {ev.errors[:3]}")
        counts.append((k, n))
    k_tot = sum(k for k, _ in counts)
    n_tot = sum(n for _, n in counts)
    status, bound = 0, False
    if s["replicates"] == 1 or k_tot == 0:
        lo, up = (float(v) for v in binomial_interval(k_tot, n_tot, confidence, "wilson"))
        pf = k_tot / n_tot
        cov = math.sqrt((1 - pf) / (n_tot * pf)) if pf > 0 else math.inf
        kind = ("binomial (Wilson) on all samples: "
                + ("valid (i.i.d.)" if s["rule"] == "random" else
                   "conservative for LHS (Owen 1997)" if s["rule"] == "lhs" else
                   "not guaranteed for QMC; use replicates >= 2"))
        if k_tot == 0:
            pf, bound, status = up, True, 4
    else:
        p = np.array([k / n for k, n in counts])
        pf = float(p.mean())
        se = float(p.std(ddof=1) / math.sqrt(p.size))
        q = stats.t.isf((1 - confidence) / 2, p.size - 1)
        lo, up = max(pf - q * se, 0.0), pf + q * se
        cov = se / pf if pf > 0 else math.inf
        kind = (f"Student-t over {p.size} independent randomised replicates "
                f"(rule={s['rule']!r}); valid for any design")
    msg = ("no failure observed: pf is the upper end of the interval, not an estimate"
           if bound else "")
    return failure_report(ev, "mc", pf=pf, pf_lower=lo, pf_upper=up, cov=cov,
                          interval_kind=kind, confidence=confidence, settings=s, seed=seed,
                          wall_time=time.perf_counter() - t0, status=status, message=msg,
                          pf_is_upper_bound=bound,
                          extra={"n_failures": ((), np.int64(k_tot), {
                              "units": "1", "long_name": "failed valid samples"})})


def _mc_designs(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, r: int):
    """Standard normal designs of one replicate (random: in batches; others: whole)."""
    n = s["n_samples"]
    if s["rule"] == "random":
        for b, start in enumerate(range(0, n, s["batch_size"])):
            m = min(s["batch_size"], n - start)
            rng = np.random.default_rng(np.random.SeedSequence([seed, r, b]))
            yield rng.standard_normal((m, ev.dim))
        return
    rep_seed = int(np.random.SeedSequence([seed, r]).generate_state(1, np.uint64)[0] % 2**63)
    unit = ev.space.sample_unit(n, rule=s["rule"], rng=rep_seed)
    yield special.ndtri(np.clip(unit, 1e-300, 1 - 2**-53))


# =========================================================================== entry point
def failure_probability(
    model: Model | str,
    space: ParameterSpace | Mapping[str, Any] | None,
    limit_state: Any,
    t: Any = None,
    *,
    method: str = "subset",
    rng: Any = None,
    executor: Any = None,
    store: str | os.PathLike | None = None,
    chunk_size: int | None = None,
    confidence: float = 0.95,
    model_options: Mapping[str, Any] | None = None,
    **settings: Any,
) -> xr.Dataset:
    """Failure probability ``P(g <= 0)`` of a model over a parameter space, by any method.

    Parameters
    ----------
    model : Model or str
        A model instance or registered name.
    space : ParameterSpace, mapping or None
        Random parameters (``None``: the model's default space).
    limit_state : LimitState, System, Band or str
        Failure where ``g <= 0`` (:mod:`gearuq.limitstate`); an output name means the output
        is ``g``. A time-dependent ``g`` is taken over the output instants ``t`` as a first
        passage (``min_t g``).
    t : array_like, optional
        Output instants (required for time-dependent outputs).
    method : {"mc", "form", "sorm", "importance", "subset", "akmcs"}
        See the module docstring; :func:`method_settings` lists each method's settings.
    rng : int, Generator or None
        Seed (``None``: fresh, recorded in ``attrs["seed"]``).
    executor, chunk_size :
        As in :func:`gearuq.monte_carlo`.
    store : path-like, optional
        Directory for a resumable run: every evaluation stage is stored (one chunk store per
        stage); calling again with the same arguments and seed resumes.
    confidence : float
        Two-sided confidence level of the interval.
    model_options : mapping, optional
        Declared model options (solver/fidelity settings).
    **settings
        Method settings (validated; unknown names raise with the list of valid ones).

    Returns
    -------
    xarray.Dataset
        The report (see :func:`failure_report`): ``pf``, ``pf_lower``, ``pf_upper``,
        ``cov_pf``, ``beta``..., ``n_model_runs``, ``wall_time``, ``status``, design points
        where relevant, and method-specific variables.

    Raises
    ------
    ValueError
        Unknown method or setting, bad setting value, a limit state on an unknown output,
        ambiguous limit-state input, a point outside the model's valid range.

    Examples
    --------
    >>> from gearuq.testing.reliability_problems import offset_model, offset_space
    >>> rep = failure_probability(offset_model(), offset_space(), "g", method="form")
    >>> round(float(rep["beta"]), 6)
    4.5
    """
    key = _check_method(method)
    if not 0.0 < float(confidence) < 1.0:
        raise ValueError(f"confidence: must lie in (0, 1), got {confidence!r}")
    s = validate_settings(key, settings)
    seed = resolve_seed(rng)
    ev = LimitStateEvaluator(model, space, limit_state, t, model_options=model_options,
                             executor=executor, chunk_size=chunk_size, store=store,
                             engine=f"failure_probability/{key}", seed=seed,
                             fingerprint={"settings": s})
    if key == "mc":
        return run_mc(ev, s, seed, confidence)
    if key in ("form", "sorm"):
        from gearuq.engines.form import run_form

        return run_form(ev, s, seed, confidence, second_order=key == "sorm")
    if key == "importance":
        from gearuq.engines.importance import run_importance

        return run_importance(ev, s, seed, confidence)
    if key == "subset":
        from gearuq.engines.subset import run_subset

        return run_subset(ev, s, seed, confidence)
    from gearuq.engines.akmcs import run_akmcs

    return run_akmcs(ev, s, seed, confidence)
