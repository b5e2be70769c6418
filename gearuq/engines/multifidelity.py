"""Multifidelity Monte Carlo: control variates from cheaper models, the allocation from a pilot.

:func:`multifidelity_estimate` estimates a mean, a variance or an exceedance probability of an
expensive model's quantity with the help of cheaper models over the same parameter space
(Peherstorfer, Willcox and Gunzburger 2016, "Optimal model management for multifidelity
Monte Carlo estimation", SIAM J. Sci. Comput. 38, A3163):

1. **Pilot**: every model on the same ``pilot`` draws; their costs (seconds per sample,
   measured unless given) and the correlations ``rho_k`` of their quantities with the
   expensive one (model 0), standard deviations ``sigma_k``.
2. **Model selection and allocation**: models ordered by ``|rho_k|``; a model is kept only if
   it satisfies MFMC's cost-correlation condition ``w_{k-1}/w_k > (rho_{k-1}^2 - rho_k^2) /
   (rho_k^2 - rho_{k+1}^2)`` (greedily, cheapest violations dropped first). Sample counts
   ``m_k = m_0 r_k`` with ``r_k = sqrt(w_0 (rho_k^2 - rho_{k+1}^2) / (w_k (1 - rho_1^2)))``
   and ``m_0`` from the budget ``sum_k w_k m_k = B``; the sample sets are nested.
3. **Estimate**: ``y = ybar_0(m_0) + sum_k alpha_k (ybar_k(m_k) - ybar_k(m_{k-1}))`` with
   ``alpha_k = rho_k sigma_0 / sigma_k``: unbiased whatever the cheap models; its variance
   ``sigma_0^2/m_0 + sum_k (1/m_{k-1} - 1/m_k)(alpha_k^2 sigma_k^2 - 2 alpha_k rho_k sigma_0
   sigma_k)``, with the moments re-estimated on the run's ``m_0`` shared samples, gives a
   normal interval.

Statistics: ``"mean"`` of a scalar output; ``"probability"`` of failure ``P(g <= 0)`` for a
limit state (the mean of the indicator; a moderate probability: the indicator's correlation
across fidelities decides the gain); ``"variance"``: the same estimator on the unbiased
sample variances of the nested sets, ``alpha_k`` from the correlation of the squared
deviations (Qian, Peherstorfer, O'Malley, Vesselinov and Willcox 2018), its interval from the
same formula with the squared deviations' moments (asymptotic).

``estimator="acvmf"`` is the approximate control variate of Gorodetsky, Geraci, Eldred and
Jakeman (2020, "A generalized approximate control variate framework for multifidelity
uncertainty quantification", J. Comput. Phys. 408, 109257), its MF variant: every cheap model
runs on the expensive model's ``N`` samples and on the first ``r_i N`` of one shared pool,
``y = ybar_0 + sum_i alpha_i (ybar_i(N) - ybar_i(r_i N))``; with ``F_ij = 1 - 1/min(r_i,
r_j)``, ``alpha = -(C o F)^-1 (c o diag F)`` and ``Var = (sigma_0^2 - (c o f)^T (C o F)^-1
(c o f)) / N``; the ratios ``r_i >= 1`` minimise that variance for the budget (numerically,
from MFMC's ratios). Unlike MFMC it needs no ordering by correlation and keeps every model:
it can only gain from one more (up to the optimiser), where MFMC must drop a model that
breaks its condition.

The report gives the variance reduction against plain Monte Carlo of the expensive model at
the same cost, ``sigma_0^2 w_0 / (B Var)``, the pilot included in the cost or not (both).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from gearuq.execution import evaluate_chunks
from gearuq.failure.modes import as_limit_state
from gearuq.model import Model
from gearuq.runs import provenance, resolve_model, resolve_seed
from gearuq.space import ParameterSpace

__all__ = ["multifidelity_estimate", "mfmc_allocation", "acvmf_allocation", "STATISTICS",
           "ESTIMATORS"]

#: Statistics :func:`multifidelity_estimate` estimates.
STATISTICS = ("mean", "variance", "probability")
#: Estimators :func:`multifidelity_estimate` offers.
ESTIMATORS = ("mfmc", "acvmf")


def mfmc_allocation(costs: Sequence[float], rho: Sequence[float], budget: float
                    ) -> tuple[np.ndarray, list[int]]:
    """MFMC sample counts for models already ordered by ``|rho|`` (model 0 first).

    Parameters
    ----------
    costs : sequence of float
        Cost per sample of each model (> 0).
    rho : sequence of float
        Correlation of each model's quantity with model 0's (``rho[0] = 1``).
    budget : float
        Total cost to spend.

    Returns
    -------
    m : ndarray of float
        Sample counts (not rounded) of the kept models, nondecreasing.
    kept : list of int
        Indices of the kept models (those meeting the cost-correlation condition).
    """
    w = np.asarray(costs, dtype=float)
    r = np.abs(np.asarray(rho, dtype=float))
    kept = list(range(len(w)))
    while True:
        rr = np.append(r[kept], 0.0)
        ww = w[kept]
        bad = [j for j in range(1, len(kept))
               if not ww[j - 1] / ww[j] > (rr[j - 1] ** 2 - rr[j] ** 2)
               / max(rr[j] ** 2 - rr[j + 1] ** 2, 1e-300)]
        if not bad:
            break
        kept.pop(bad[-1])
    rr = np.append(r[kept], 0.0)
    ww = w[kept]
    if len(kept) == 1:
        ratios = np.ones(1)
    else:
        ratios = np.concatenate([[1.0], np.sqrt(ww[0] * (rr[1:-1] ** 2 - rr[2:] ** 2)
                                                / (ww[1:] * (1.0 - rr[1] ** 2)))])
    m0 = budget / float(ww @ ratios)
    return m0 * ratios, kept


def _mfmc_variance(m: np.ndarray, sigma: np.ndarray, rho: np.ndarray) -> float:
    """Variance of the MFMC estimator with optimal ``alpha_k = rho_k sigma_0 / sigma_k``."""
    var = sigma[0] ** 2 / m[0]
    for k in range(1, m.size):
        alpha = rho[k] * sigma[0] / sigma[k]
        var += (1 / m[k - 1] - 1 / m[k]) * (alpha**2 * sigma[k] ** 2
                                           - 2 * alpha * rho[k] * sigma[0] * sigma[k])
    return float(var)


def _acvmf_terms(cov: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``C o F`` and ``c o f`` of ACV-MF for ratios ``r`` (cheap models only)."""
    rmin = np.minimum.outer(r, r)
    big_f = 1.0 - 1.0 / rmin
    f = 1.0 - 1.0 / r
    return cov[1:, 1:] * big_f, cov[0, 1:] * f


def _acvmf_variance(cov: np.ndarray, r: np.ndarray, n: float) -> float:
    """Variance of the optimal ACV-MF estimator with ``n`` expensive samples."""
    cf, cvec = _acvmf_terms(cov, r)
    gain = float(cvec @ np.linalg.lstsq(cf, cvec, rcond=None)[0])
    return (cov[0, 0] - gain) / n


def acvmf_allocation(costs: Sequence[float], cov: np.ndarray, budget: float
                     ) -> tuple[float, np.ndarray]:
    """ACV-MF: expensive samples ``N`` and ratios ``r_i >= 1`` minimising the variance.

    Parameters
    ----------
    costs : sequence of float
        Cost per sample, the expensive model first.
    cov : ndarray (K, K)
        Covariance of the models' quantities.
    budget : float

    Returns
    -------
    n : float
        Expensive-model samples (not rounded).
    r : ndarray
        Ratio of each cheap model's samples to ``n``.
    """
    from scipy import optimize

    w = np.asarray(costs, dtype=float)
    cov = np.asarray(cov, dtype=float)
    sd = np.sqrt(np.diag(cov))
    rho = cov[0] / (sd[0] * np.where(sd > 0, sd, 1.0))

    def objective(z: np.ndarray) -> float:
        r = 1.0 + np.exp(z)
        n = budget / (w[0] + w[1:] @ r)
        return math.log(max(_acvmf_variance(cov, r, n), 1e-300))

    # start: the two-model MFMC ratio of each cheap model alone
    r0 = np.sqrt(w[0] * rho[1:] ** 2 / (w[1:] * np.maximum(1 - rho[1:] ** 2, 1e-6)))
    z0 = np.log(np.maximum(r0 - 1.0, 1e-3))
    best = optimize.minimize(objective, z0, method="Nelder-Mead",
                             options={"xatol": 1e-6, "fatol": 1e-10, "maxiter": 4000})
    r = 1.0 + np.exp(best.x)
    return budget / (w[0] + w[1:] @ r), r


class _Quantity:
    """The scalar per sample each model contributes: an output, or a failure indicator."""

    def __init__(self, spec: Any, statistic: str) -> None:
        self.statistic = statistic
        if statistic == "probability":
            self.limit = as_limit_state(spec)
            self.outputs = [v for v in self.limit.variables]
            self.name = self.limit.name
        else:
            if not isinstance(spec, str):
                raise ValueError(f"quantity: statistic {statistic!r} needs an output name, got "
                                 f"{spec!r} (a limit state goes with statistic='probability')")
            self.limit, self.outputs, self.name = None, [spec], spec

    def values(self, ds: xr.Dataset) -> np.ndarray:
        if self.limit is not None:
            return (self.limit.sample_values(ds) <= 0.0).astype(float)
        da = ds[self.outputs[0]]
        if da.dims != ("sample",):
            raise ValueError(f"quantity {self.name!r}: expected a scalar output per sample, got "
                             f"dims {da.dims}; use a limit state with statistic='probability'")
        return np.asarray(da.values, dtype=float)


def multifidelity_estimate(
    models: Sequence[Model | str],
    space: ParameterSpace,
    quantity: Any | Sequence[Any],
    t: Any = None,
    *,
    statistic: str = "mean",
    estimator: str = "mfmc",
    budget: float,
    pilot: int = 100,
    costs: Sequence[float] | None = None,
    rng: Any = None,
    executor: Any = None,
    confidence: float = 0.95,
    model_options: Sequence[Mapping[str, Any] | None] | None = None,
) -> xr.Dataset:
    """Multifidelity Monte Carlo estimate of a statistic of ``models[0]``'s quantity.

    Parameters
    ----------
    models : sequence of Model or str
        The expensive model first, then cheaper ones over the same parameter space (each must
        take every parameter of ``space``).
    space : ParameterSpace
        Random parameters.
    quantity : str, LimitState or a sequence of them (one per model)
        An output name (statistics ``"mean"``, ``"variance"``) or a limit state
        (``"probability"``: ``P(g <= 0)``).
    t : array_like, optional
        Output instants (time-dependent limit states use their first-passage value).
    statistic : {"mean", "variance", "probability"}
    estimator : {"mfmc", "acvmf"}
        Multifidelity Monte Carlo or the approximate control variate (MF variant).
    budget : float
        Cost to spend after the pilot, in the units of ``costs`` (seconds when measured).
    pilot : int
        Pilot samples run on every model (>= 10).
    costs : sequence of float, optional
        Cost per sample of each model (> 0); measured in the pilot when not given.
    rng, executor, confidence :
        As in :func:`gearuq.monte_carlo`.
    model_options : sequence of mappings, optional
        Declared options per model.

    Returns
    -------
    xarray.Dataset
        ``estimate``, ``estimate_lower``/``upper``, ``std_error``, ``variance_reduction``
        (against plain Monte Carlo of model 0 at the same cost), per ``fidelity``: ``cost``,
        ``correlation``, ``alpha``, ``n_samples`` (0 for a model left out by the selection);
        the pilot's runs and cost; provenance.

    Raises
    ------
    ValueError
        Fewer than two models, a model missing a parameter of the space, a budget or a cost
        <= 0, a budget below two samples of model 0, a pilot below 10, an unknown statistic,
        a model whose statistic is constant over the pilot, or a cheaper model perfectly
        correlated with model 0 (then the cheaper model alone answers).
    """
    if statistic not in STATISTICS:
        raise ValueError(f"statistic: unknown {statistic!r}; valid: {', '.join(STATISTICS)}")
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator: unknown {estimator!r}; valid: {', '.join(ESTIMATORS)}")
    models = [resolve_model(m) for m in models]
    if len(models) < 2:
        raise ValueError(f"models: give the expensive model and at least one cheaper one, got "
                         f"{len(models)}")
    for m in models:
        missing = [n for n in space.names if n not in m.parameter_names]
        if missing:
            raise ValueError(f"models: {m.name!r} has no parameter(s) "
                             f"{', '.join(map(repr, missing))} of the space; wrap it in a "
                             "fidelity link that maps the space onto its inputs")
    if not (isinstance(budget, (int, float)) and math.isfinite(budget) and budget > 0):
        raise ValueError(f"budget: must be a positive number, got {budget!r}")
    if isinstance(pilot, bool) or not isinstance(pilot, (int, np.integer)) or pilot < 10:
        raise ValueError(f"pilot: expected an integer >= 10, got {pilot!r}")
    if costs is not None:
        costs = [float(c) for c in costs]
        if len(costs) != len(models) or not all(c > 0 and math.isfinite(c) for c in costs):
            raise ValueError(f"costs: expected {len(models)} positive numbers, got {costs!r}")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence: must lie in (0, 1), got {confidence!r}")
    specs = list(quantity) if isinstance(quantity, (list, tuple)) else [quantity] * len(models)
    if len(specs) != len(models):
        raise ValueError(f"quantity: give one or {len(models)}, got {len(specs)}")
    quantities = [_Quantity(q, statistic) for q in specs]
    options = list(model_options) if model_options is not None else [None] * len(models)
    requests = [m.prepare(t, outputs=q.outputs, **dict(o or {}))
                for m, q, o in zip(models, quantities, options, strict=True)]
    seed = resolve_seed(rng)
    t0 = time.perf_counter()

    def run(k: int, x: dict[str, np.ndarray], tag: str) -> tuple[np.ndarray, float]:
        start = time.perf_counter()
        ds = evaluate_chunks(models[k], x, requests[k], executor=executor, progress=False,
                             fingerprint={"engine": "multifidelity", "tag": tag,
                                          "seed": seed})
        q = quantities[k].values(ds)
        bad = np.asarray(ds["status"].values) != 0
        if bad.any():
            raise RuntimeError(f"model {models[k].name!r}: {int(bad.sum())} invalid sample(s) "
                               f"in {tag}; multifidelity estimates need every run")
        return q, (time.perf_counter() - start) / max(len(q), 1)

    x_pilot = space.sample(pilot, rule="random", rng=seed)
    pilot_q, measured = zip(*(run(k, x_pilot, "pilot") for k in range(len(models))),
                            strict=True)
    w = np.asarray(costs if costs is not None else measured, dtype=float)
    if budget < 2.0 * w[0]:
        # every estimator runs models[0] at least twice (a variance needs two samples)
        unit = " s (measured in the pilot)" if costs is None else ""
        raise ValueError(
            f"budget={budget!r} buys fewer than the 2 samples of models[0] ({models[0].name!r}) "
            f"every estimator needs, at {w[0]:.3g}{unit} per sample; valid: a budget of at "
            f"least {2.0 * w[0]:.3g}")
    stat = _statistic_samples(np.array(pilot_q), statistic)
    spread = np.array([np.ptp(s) for s in stat])
    flat = [k for k in range(len(models)) if spread[k] == 0]
    if 0 in flat or (flat and estimator == "acvmf"):
        k = flat[0]
        raise ValueError(f"models[{k}] ({models[k].name!r}) gives the same {statistic} at all "
                         f"{pilot} pilot samples: " + (
                             "the pilot cannot size the estimator (for a probability: no "
                             "failure, or only failures, among them); enlarge the pilot"
                             if k == 0 else "it carries nothing to correlate; leave it out "
                             "(the default estimator, 'mfmc', leaves it out itself)"))
    # a cheaper model constant over the pilot (a failure indicator that never fired there)
    # correlates with nothing: rho = 0, which the selection below leaves out
    rho = np.array([0.0 if spread[k] == 0 else np.corrcoef(stat[0], s)[0, 1]
                    for k, s in enumerate(stat)])
    perfect = [k for k in range(1, len(models)) if abs(rho[k]) > 1.0 - 1e-12]
    if perfect:
        k = perfect[0]
        raise ValueError(f"models[{k}] ({models[k].name!r}) is perfectly correlated with "
                         f"models[0] in the pilot (rho = {rho[k]:.12g}): it is the same "
                         "quantity up to a linear map; use it alone (a fidelity link), not as "
                         "a control variate")
    if estimator == "acvmf":
        n_hf, ratios = acvmf_allocation(w, np.cov(stat), budget)
        kept = list(range(len(models)))
        m = np.concatenate([[max(int(n_hf), 2)], np.maximum(
            np.floor(ratios * max(int(n_hf), 2)).astype(int), max(int(n_hf), 2) + 1)])
    else:
        order = [0] + sorted(range(1, len(models)), key=lambda k: -abs(rho[k]))
        m_float, kept_pos = mfmc_allocation(w[order], rho[order], budget)
        kept = [order[i] for i in kept_pos]
        m = np.maximum(np.floor(m_float).astype(int), 2)
        m = np.maximum.accumulate(m)
    x_all = space.sample(int(m.max()), rule="random", rng=seed + 1)
    ys = []
    for i, k in enumerate(kept):
        x_k = {name: v[: m[i]] for name, v in x_all.items()}
        ys.append(run(k, x_k, f"level{i}")[0])
    if estimator == "acvmf":
        est, var, alpha, sig, rho_run = _combine_acvmf(ys, m, statistic)
    else:
        est, var, alpha, sig, rho_run = _combine(ys, m, statistic)
    z = stats.norm.isf((1 - confidence) / 2)
    se = math.sqrt(max(var, 0.0))
    spent = float(np.dot(w[kept], m))
    mc_var = sig[0] ** 2 / max(spent / w[0], 1.0)
    pilot_cost = float(pilot * w.sum())
    mc_var_all = sig[0] ** 2 / max((spent + pilot_cost) / w[0], 1.0)
    n_models = len(models)
    full = np.zeros(n_models, dtype=np.int64)
    alpha_full = np.full(n_models, np.nan)
    rho_full = np.full(n_models, np.nan)
    for i, k in enumerate(kept):
        full[k] = m[i]
        alpha_full[k] = alpha[i]
        rho_full[k] = rho_run[i]
    out = xr.Dataset(
        {
            "estimate": ((), est, {"units": "1" if statistic == "probability" else "output",
                                   "long_name": f"multifidelity estimate of the {statistic}"}),
            "estimate_lower": ((), est - z * se, {"long_name": "lower end of the interval"}),
            "estimate_upper": ((), est + z * se, {"long_name": "upper end of the interval"}),
            "std_error": ((), se, {"long_name": "standard error of the estimate"}),
            "variance_reduction": ((), mc_var / var if var > 0 else math.inf, {
                "units": "1", "long_name": "plain MC variance of model 0 at the same cost / "
                                           "this estimator's (pilot not counted)"}),
            "variance_reduction_with_pilot": ((), mc_var_all / var if var > 0 else math.inf, {
                "units": "1", "long_name": "the same with the pilot's cost counted"}),
            "cost": (("fidelity",), w, {"units": "s" if costs is None else "1",
                                        "long_name": "cost per sample"}),
            "pilot_correlation": (("fidelity",), rho, {"units": "1", "long_name":
                                  "correlation with model 0 in the pilot"}),
            "correlation": (("fidelity",), rho_full, {"units": "1", "long_name":
                            "correlation with model 0 on the run's shared samples"}),
            "alpha": (("fidelity",), alpha_full, {"units": "1", "long_name":
                      "control-variate weight"}),
            "n_samples": (("fidelity",), full, {"units": "1", "long_name":
                          "samples run on each model (0: left out by the selection)"}),
            "budget_spent": ((), spent, {"long_name": "cost spent after the pilot"}),
            "pilot_cost": ((), pilot_cost, {"long_name": "cost of the pilot"}),
            "wall_time": ((), time.perf_counter() - t0, {"units": "s"}),
        },
        coords={"fidelity": ("fidelity", [m_.name for m_ in models])},
    )
    out.attrs.update(provenance("multifidelity_estimate", models[0], requests[0], space, seed,
                                statistic=statistic, estimator=estimator,
                                budget=float(budget), pilot=int(pilot),
                                models=[m_.name for m_ in models]))
    if spent > 1.001 * budget:
        out.attrs["message"] = (f"the budget {budget:.4g} was exceeded: {spent:.4g} spent, because "
                                "each model kept runs at least 2 samples (and each lower "
                                "fidelity more than the one above it)")
        warnings.warn(out.attrs["message"], RuntimeWarning, stacklevel=2)
    out.attrs["interval_kind"] = ("normal, estimator variance from the run's shared samples "
                                  "(Peherstorfer et al. 2016)")
    return out


def _statistic_samples(q: np.ndarray, statistic: str) -> np.ndarray:
    """Per-sample values whose mean is the statistic (squared deviations for a variance)."""
    if statistic == "variance":
        return (q - q.mean(axis=1, keepdims=True)) ** 2
    return q


def _sample_statistic(statistic: str, y: np.ndarray) -> float:
    """The statistic of one sample set: the unbiased variance, or the mean (a probability is
    the mean of the failure indicator)."""
    return float(np.var(y, ddof=1) if statistic == "variance" else np.mean(y))


def _combine(ys: list[np.ndarray], m: np.ndarray, statistic: str
             ) -> tuple[float, float, np.ndarray, np.ndarray, np.ndarray]:
    """MFMC estimate and its variance from nested samples ``ys[i][:m[i]]``."""
    shared = np.array([y[: m[0]] for y in ys])
    base = _statistic_samples(shared, statistic)
    sig = base.std(axis=1, ddof=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = np.array([np.corrcoef(base[0], b)[0, 1] if sig[i] > 0 else 0.0
                        for i, b in enumerate(base)])
        alpha = np.where(sig > 0, rho * sig[0] / np.where(sig > 0, sig, 1.0), 0.0)
    rho = np.nan_to_num(rho)

    est = _sample_statistic(statistic, ys[0][: m[0]])
    for i in range(1, len(ys)):
        est += alpha[i] * (_sample_statistic(statistic, ys[i][: m[i]])
                           - _sample_statistic(statistic, ys[i][: m[i - 1]]))
    var = _mfmc_variance(m.astype(float), np.where(sig > 0, sig, 1e-300), rho)
    return float(est), var, alpha, sig, rho


def _combine_acvmf(ys: list[np.ndarray], m: np.ndarray, statistic: str
                   ) -> tuple[float, float, np.ndarray, np.ndarray, np.ndarray]:
    """ACV-MF estimate and variance; ``ys[0]`` on ``m[0]`` samples, ``ys[i]`` on ``m[i]``
    (the first ``m[0]`` shared with the expensive model)."""
    n = int(m[0])
    shared = _statistic_samples(np.array([y[:n] for y in ys]), statistic)
    cov = np.cov(shared)
    sig = np.sqrt(np.diag(cov))
    rho = cov[0] / (sig[0] * np.where(sig > 0, sig, 1.0))
    r = m[1:] / n
    cf, cvec = _acvmf_terms(cov, r)
    alpha = np.concatenate([[1.0], -np.linalg.lstsq(cf, cvec, rcond=None)[0]])

    est = _sample_statistic(statistic, ys[0][:n])
    for i in range(1, len(ys)):
        est += alpha[i] * (_sample_statistic(statistic, ys[i][:n])
                           - _sample_statistic(statistic, ys[i][: m[i]]))
    return float(est), _acvmf_variance(cov, r, n), alpha, sig, rho
