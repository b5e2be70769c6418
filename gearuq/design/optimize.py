"""Design under uncertainty: search a design space, then confirm the choice independently.

:func:`optimize_design` runs one of four strategies on a :class:`DesignProblem` and returns
one labelled Dataset (the chosen design, its confirmation with intervals, the landscape, the
runs spent and a status in words):

=============  ==================================================================================
strategy       how the measures are estimated during the search
=============  ==================================================================================
``reweight``   one pool of runs shared by every design through likelihood ratios (only when
               the design variables shift input laws); smooth in the design, so SLSQP uses it
               directly; where the weights degenerate at the candidate, a batch is drawn there
``surrogate``  a Gaussian process over the design space fitted to common-random-number
               estimates at a Latin hypercube of designs, the estimates' errors as its noise;
               constraints use its upper band; the landscape carries its error
``crn``        a fresh Monte Carlo run at every design the optimiser asks for, with the same
               seed (common random numbers); COBYLA
``nested``     the naive nested loop: a fresh run with a new seed at every design; COBYLA
=============  ==================================================================================

Every search runs at the problem's model options (the cheap fidelity); the chosen design is
then confirmed by :func:`evaluate_design` with a fresh seed at ``confirm_options`` (the
expensive fidelity).
"""

from __future__ import annotations

import json
import math
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr
from scipy import optimize, stats
from scipy.stats import qmc

from gearuq.design.measures import Estimate, Probability
from gearuq.design.pool import RunPool
from gearuq.design.problem import DesignProblem, evaluate_design
from gearuq.runs import provenance, resolve_seed

__all__ = ["optimize_design", "STRATEGIES", "DESIGN_STATUS"]

STRATEGIES = ("reweight", "surrogate", "crn", "nested")

#: The result's ``status`` codes (0: every check passed); reasons in words in the attrs.
DESIGN_STATUS = {
    0: "ok",
    1: "not_converged",
    3: "weights_degenerate",
    4: "constraint_undecided",
    5: "constraint_violated",
    6: "confirmation_unreliable",
}

Estimator = Callable[[np.ndarray], dict[str, Estimate]]


# ====================================================================== transforms
def _probit(p: float, floor: float) -> float:
    return float(stats.norm.ppf(min(max(p, floor), 1.0 - 1e-15)))


class _Scaled:
    """Objective and constraint functions on the unit box, in well-scaled units.

    Probabilities enter as probits (``Phi^-1(pf)``: a cap of 1e-3 and one of 1e-6 are then
    equally far from 0.5), other measures divided by a scale fixed at the start.
    """

    def __init__(self, problem: DesignProblem, estimate: Estimator, floor: float,
                 start: np.ndarray) -> None:
        self.p, self.estimate, self.floor = problem, estimate, floor
        self.span = problem.upper - problem.lower
        self.cache: dict[tuple, dict[str, Estimate]] = {}
        first = self.at(start)
        self.scale = {m.name: max(abs(first[m.name].value), 1e-300)
                      for m in problem.measures if not isinstance(m, Probability)}
        if callable(problem.objective) and not hasattr(problem.objective, "kind"):
            self.cost_scale = max(abs(problem.cost(self.design(start))), 1e-300)

    def design(self, u: np.ndarray) -> np.ndarray:
        return self.p.lower + np.clip(u, 0.0, 1.0) * self.span

    def at(self, u: np.ndarray) -> dict[str, Estimate]:
        key = tuple(np.round(np.clip(u, 0, 1), 12))
        if key not in self.cache:
            self.cache[key] = self.estimate(self.design(np.asarray(key)))
        return self.cache[key]

    def _value(self, m: Any, est: Estimate, pick: str = "value") -> float:
        v = getattr(est, pick)
        if isinstance(m, Probability):
            return _probit(v, self.floor)
        return v / self.scale[m.name]

    def objective(self, u: np.ndarray) -> float:
        obj = self.p.objective
        if hasattr(obj, "kind"):
            return self._value(obj, self.at(u)[obj.name])
        return self.p.cost(self.design(u)) / self.cost_scale

    def margins(self, u: np.ndarray, conservative: bool = False) -> np.ndarray:
        """One margin per constraint bound, >= 0 where it holds (in scaled units); with
        ``conservative`` a cap is met by the interval's upper end, a floor by its lower."""
        est = self.at(u)
        out = []
        for c in self.p.constraints:
            m = c.measure
            v = self._value(m, est[m.name], "upper" if conservative else "value")
            if c.upper is not None:
                cap = _probit(c.upper, self.floor) if isinstance(m, Probability) \
                    else c.upper / self.scale[m.name]
                out.append(cap - v)
            if c.lower is not None:
                v = self._value(m, est[m.name], "lower" if conservative else "value")
                floor = _probit(c.lower, self.floor) if isinstance(m, Probability) \
                    else c.lower / self.scale[m.name]
                out.append(v - floor)
        return np.array(out)


# ====================================================================== optimisers
def _grid(problem: DesignProblem, per_dim: int) -> list[np.ndarray]:
    k = len(problem.variables)
    per_dim = max(2, min(per_dim, int(round(4096 ** (1.0 / k)))))
    return [np.linspace(0.0, 1.0, per_dim) for _ in range(k)]


def _rank(sc: _Scaled, u: np.ndarray) -> tuple[float, float]:
    """Constraint violation first, then the objective: the smaller, the better the design."""
    viol = float(np.sum(np.maximum(-sc.margins(u), 0.0))) if sc.p.constraints else 0.0
    return viol, sc.objective(u)


def _grid_start(sc: _Scaled, axes: list[np.ndarray],
                extra: Sequence[np.ndarray] = ()) -> np.ndarray:
    """The best grid point or ``extra`` design (the supplied start designs) that meets every
    constraint (else the least violating)."""
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))
    best, best_key = pts[0], (math.inf, math.inf)
    for u in [*pts, *extra]:
        key = _rank(sc, u)
        if key < best_key:
            best, best_key = u, key
    return best


def _keep_best(sc: _Scaled, u: np.ndarray, starts: Sequence[np.ndarray]) -> np.ndarray:
    """The optimiser's end point unless a supplied start design ranks better on the same
    estimates: the search never ends worse than a design it was given (the classic RBDO
    guarantee when the deterministic optimum is among them)."""
    best = min([u, *starts], key=lambda v: _rank(sc, v))
    return np.asarray(best, dtype=float)


def _slsqp(sc: _Scaled, u0: np.ndarray, conservative: bool = False
           ) -> optimize.OptimizeResult:
    cons = ([{"type": "ineq", "fun": lambda u: sc.margins(u, conservative)}]
            if sc.p.constraints else [])
    return optimize.minimize(sc.objective, u0, method="SLSQP", bounds=[(0, 1)] * u0.size,
                             constraints=cons,
                             options={"maxiter": 200, "ftol": 1e-9, "eps": 1e-4})


def _cobyla(sc: _Scaled, u0: np.ndarray, max_evaluations: int) -> optimize.OptimizeResult:
    k = u0.size
    cons = [{"type": "ineq", "fun": (lambda u, j=j: u[j])} for j in range(k)]
    cons += [{"type": "ineq", "fun": (lambda u, j=j: 1.0 - u[j])} for j in range(k)]
    if sc.p.constraints:
        cons.append({"type": "ineq", "fun": lambda u: sc.margins(u)})
    return optimize.minimize(sc.objective, u0, method="COBYLA", constraints=cons,
                             options={"maxiter": max_evaluations, "rhobeg": 0.1,
                                      "tol": 1e-4})


# ====================================================================== strategies
def _search_reweight(problem: DesignProblem, s: Mapping[str, Any], seed: int,
                     run_kw: dict) -> dict[str, Any]:
    n = s["n_samples"]
    pool = RunPool(problem.space, problem.variables)
    ds = problem.run_spread(n, seed, **run_kw)
    pool.add(None, ds, problem.values_of(ds), seed, "first batch, spread over the design box")
    history, n_naive, prev = [], 0, None
    reasons: list[tuple[int, str]] = []
    u = 0.5 * np.ones(len(problem.variables))
    for it in range(s["max_batches"]):
        h = pool.mixture_pdf()

        def est(d: np.ndarray, h: np.ndarray = h) -> dict[str, Estimate]:
            return pool.estimate_all(problem.measures, d, problem.confidence, h)

        sc = _Scaled(problem, est, 0.1 / pool.n_runs, u)
        u0 = _grid_start(sc, _grid(problem, s["grid"]), s["starts"])
        n_grid = len(sc.cache)
        res = _slsqp(sc, u0)
        u = _keep_best(sc, np.clip(res.x, 0, 1), s["starts"])
        # the designs SLSQP asked for (the start grid is this strategy's own extra)
        n_naive += (len(sc.cache) - n_grid + 1) * n
        d = sc.design(u)
        ess = pool.ess(d, h)
        fails = {m.name: sc.at(u)[m.name].ess for m in problem.measures
                 if isinstance(m, Probability)}
        ok = ess >= s["min_ess"] and all(f >= s["min_failures"] for f in fails.values())
        moved = math.inf if prev is None else float(np.max(np.abs(u - prev)))
        history.append({"batch": it, "design": d.tolist(), "ess": ess, "n_runs": pool.n_runs,
                        "failure_ess": fails, "optimiser": str(res.message)})
        if ok and moved <= s["xtol"]:
            break
        prev = u
        if it == s["max_batches"] - 1:
            if not ok:
                reasons.append((3, f"after {s['max_batches']} batches the weights at the chosen "
                                   f"design are still thin (effective sample size {ess:.0f}, "
                                   f"failures {fails}): the search estimate is not trusted, "
                                   "only the confirmation run is"))
            else:
                reasons.append((1, f"the design still moved by {moved:.3g} of its range in the "
                                   f"last of {s['max_batches']} batches"))
            break
        why = (f"weights degenerate at the candidate (effective sample size {ess:.0f} < "
               f"{s['min_ess']}, or failures {fails} < {s['min_failures']}): re-sampled there"
               if not ok else "candidate moved: a batch drawn there to check it")
        bseed = int(np.random.SeedSequence([seed, it + 1]).generate_state(1)[0])
        ds = problem.run(d, n, bseed, **run_kw)
        pool.add(d, ds, problem.values_of(ds), bseed, why)
    h = pool.mixture_pdf()
    land = _landscape(problem, s["grid"],
                      lambda d: pool.estimate_all(problem.measures, d, problem.confidence, h),
                      at=sc.design(u))
    return {"design": sc.design(u), "search": sc.at(u), "n_runs": pool.n_runs,
            "n_naive": n_naive, "history": history, "landscape": land, "reasons": reasons,
            "batches": [{"design": None if b.design is None else b.design.tolist(),
                         "size": b.size, "seed": b.seed, "reason": b.reason}
                        for b in pool.batches]}


def _search_loop(problem: DesignProblem, s: Mapping[str, Any], seed: int, run_kw: dict,
                 common: bool) -> dict[str, Any]:
    n, calls = s["n_samples"], [0]

    def est(d: np.ndarray) -> dict[str, Estimate]:
        calls[0] += 1
        sd = seed if common else int(np.random.SeedSequence([seed, calls[0]])
                                      .generate_state(1)[0])
        ds = problem.run(d, n, sd, **run_kw)
        vals = problem.values_of(ds)
        return {m.name: m.estimate(vals[m.name], None, problem.confidence)
                for m in problem.measures}

    u0 = (np.asarray(s["x0"], float) - problem.lower) / (problem.upper - problem.lower) \
        if s["x0"] is not None else s["starts"][0] if s["starts"] \
        else 0.5 * np.ones(len(problem.variables))
    sc = _Scaled(problem, est, 0.5 / n, u0)
    res = _cobyla(sc, u0, s["max_evaluations"])
    u = np.clip(res.x, 0, 1)
    reasons = [] if res.success else [(1, f"COBYLA stopped: {res.message}")]
    history = [{"design": sc.design(np.asarray(k)).tolist(),
                "objective": float(sc.objective(np.asarray(k)))} for k in sc.cache]
    return {"design": sc.design(u), "search": sc.at(u), "n_runs": calls[0] * n,
            "n_naive": calls[0] * n, "history": history, "landscape": None,
            "reasons": reasons, "batches": []}


def _search_surrogate(problem: DesignProblem, s: Mapping[str, Any], seed: int,
                      run_kw: dict) -> dict[str, Any]:
    """Latin hypercube of designs, then ``n_infill`` designs at the surrogate's optimum."""
    n, k = s["n_samples"], len(problem.variables)
    floor = 0.5 / n
    # the supplied start designs first (run with the same common random numbers)
    units = [*s["starts"], *qmc.LatinHypercube(d=k, seed=seed).random(s["n_designs"])]
    ests = [_crn_estimate(problem, u, n, seed, run_kw) for u in units]
    n_first = len(units)
    n_naive, infill = 0, 0
    while True:
        est = _fit_surrogate(problem, np.array(units), ests, n, floor, seed)
        sc = _Scaled(problem, est, floor, 0.5 * np.ones(k))
        u0 = _grid_start(sc, _grid(problem, s["grid"]), s["starts"])
        n_grid = len(sc.cache)
        res = _slsqp(sc, u0, conservative=s["conservative"])
        u = _keep_best(sc, np.clip(res.x, 0, 1), s["starts"])
        n_naive += (len(sc.cache) - n_grid + 1) * n
        dist = [float(np.max(np.abs(u - v))) for v in units]
        near = min(dist)
        if near < s["xtol"] and s["starts"]:
            # within xtol of a design already run: that design, whose estimate is a run's and
            # not the surrogate's, is the choice (so a supplied start design is kept exactly)
            u = np.asarray(units[int(np.argmin(dist))], dtype=float)
        if infill >= s["n_infill"] or near < s["xtol"]:
            break
        # the surrogate's optimum is where its error matters most: run it there
        units.append(u)
        ests.append(_crn_estimate(problem, u, n, seed, run_kw))
        infill += 1
    land = _landscape(problem, s["grid"], est, at=sc.design(u))
    history = [{"design": (problem.lower + uu * (problem.upper - problem.lower)).tolist(),
                "infill": i >= n_first, "start": i < len(s["starts"]),
                **{m: e[m].value for m in e}}
               for i, (uu, e) in enumerate(zip(units, ests, strict=True))]
    return {"design": sc.design(u), "search": sc.at(u), "n_runs": len(units) * n,
            "n_naive": n_naive, "history": history, "landscape": land,
            "reasons": [] if res.success else [(1, f"SLSQP on the surrogate: {res.message}")],
            "batches": []}


def _crn_estimate(problem: DesignProblem, u: np.ndarray, n: int, seed: int, run_kw: dict
                  ) -> dict[str, Estimate]:
    ds = problem.run(problem.lower + u * (problem.upper - problem.lower), n, seed, **run_kw)
    vals = problem.values_of(ds)
    return {m.name: m.estimate(vals[m.name], None, problem.confidence)
            for m in problem.measures}


def _fit_surrogate(problem: DesignProblem, units: np.ndarray, ests: list[dict[str, Estimate]],
                   n: int, floor: float, seed: int) -> Estimator:
    """A Gaussian process per measure; returns the estimator of its mean and band."""
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import ConstantKernel, Matern

    k = units.shape[1]
    z = stats.norm.isf((1.0 - problem.confidence) / 2.0)
    gps = {}
    for m in problem.measures:
        y, noise = _surrogate_targets(m, [e[m.name] for e in ests], n, floor, z)
        kernel = ConstantKernel(1.0, (1e-3, 1e3)) * Matern(
            length_scale=np.full(k, 0.3), length_scale_bounds=(0.1, 10.0), nu=2.5)
        gp = GaussianProcessRegressor(kernel=kernel, alpha=noise, normalize_y=True,
                                      n_restarts_optimizer=3, random_state=seed)
        with warnings.catch_warnings():
            # a length scale at its upper bound (10 widths of the design box) says the
            # measure barely changes along that variable: an answer, not a failed fit (a
            # length scale at the lower bound still warns)
            warnings.filterwarnings("ignore", message=".*close to the specified upper bound",
                                    category=ConvergenceWarning)
            gps[m.name] = (gp.fit(units, y), m)

    def est(d: np.ndarray) -> dict[str, Estimate]:
        u = ((d - problem.lower) / (problem.upper - problem.lower))[None, :]
        out = {}
        for name, (gp, m) in gps.items():
            mu, sd = gp.predict(u, return_std=True)
            mu, sd = float(mu[0]), float(sd[0])
            if isinstance(m, Probability):
                out[name] = Estimate(float(stats.norm.cdf(mu)),
                                     float(stats.norm.cdf(mu - z * sd)),
                                     float(stats.norm.cdf(mu + z * sd)), math.nan)
            else:
                out[name] = Estimate(mu, mu - z * sd, mu + z * sd, math.nan)
        return out

    return est


def _surrogate_targets(m: Any, ests: list[Estimate], n: int, floor: float, z: float
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Values the Gaussian process fits and their noise variances (delta method)."""
    if isinstance(m, Probability):
        p = np.clip([e.value for e in ests], floor, 1 - floor)
        y = stats.norm.ppf(p)
        var_p = p * (1 - p) / n
        return y, var_p / stats.norm.pdf(y) ** 2
    y = np.array([e.value for e in ests])
    half = np.array([(e.upper - e.lower) / 2 for e in ests])
    return y, np.maximum((half / z) ** 2, 1e-12 * max(float(np.var(y)), 1e-300))


def _landscape(problem: DesignProblem, per_dim: int, est: Estimator,
               at: np.ndarray) -> dict[str, Any]:
    """Every measure on a grid over the first two design variables, any others held at the
    chosen design ``at`` (a slice through it: a grid over three or more would cost
    ``per_dim`` to that power)."""
    axes = [np.linspace(v.bounds[0], v.bounds[1], per_dim) for v in problem.variables[:2]]
    shape = tuple(a.size for a in axes)
    out = {m.name: np.full((3, *shape), np.nan) for m in problem.measures}
    out["ess"] = np.full(shape, np.nan)
    for idx in np.ndindex(*shape):
        d = np.array([axes[j][i] for j, i in enumerate(idx)] + list(at[len(axes):]), dtype=float)
        e = est(d)
        for m in problem.measures:
            out[m.name][(slice(None), *idx)] = (e[m.name].value, e[m.name].lower,
                                                e[m.name].upper)
        out["ess"][idx] = min((e[m.name].ess for m in problem.measures), default=math.nan)
    out["axes"] = axes
    return out


_SEARCH = {"reweight": _search_reweight, "surrogate": _search_surrogate,
           "crn": lambda p, s, seed, kw: _search_loop(p, s, seed, kw, True),
           "nested": lambda p, s, seed, kw: _search_loop(p, s, seed, kw, False)}


# ====================================================================== entry point
def optimize_design(
    problem: DesignProblem,
    *,
    strategy: str = "reweight",
    n_samples: int = 2000,
    rng: Any = None,
    confirm_samples: int | None = None,
    confirm_options: Mapping[str, Any] | None = None,
    x0: Any = None,
    start_designs: Any = None,
    max_batches: int = 6,
    min_ess: float | None = None,
    min_failures: float = 20.0,
    xtol: float = 0.01,
    grid: int = 21,
    n_designs: int = 16,
    n_infill: int = 0,
    conservative: bool = True,
    max_evaluations: int = 60,
    keep_confirmation_runs: bool = False,
    confirm_problem: DesignProblem | None = None,
    executor: Any = None,
    chunk_size: int | None = None,
) -> xr.Dataset:
    """Find the design that minimises the objective under the constraints, and confirm it.

    Parameters
    ----------
    problem : DesignProblem
    strategy : {"reweight", "surrogate", "crn", "nested"}
        See the module docstring. ``"reweight"`` needs every variable to shift an input law.
    n_samples : int
        Model runs per batch (``reweight``) or per design (the others).
    rng : int or None
        Seed of the search (``None``: fresh, recorded). The confirmation uses a seed drawn
        independently from it.
    confirm_samples : int, optional
        Runs of the independent confirmation (default ``n_samples``; 0 skips it, and the
        status then says nothing is vouched for).
    confirm_options : mapping, optional
        Model options of the confirmation (the expensive fidelity; default: the problem's).
    x0 : array_like, optional
        Start of ``crn`` / ``nested`` (default: the first of ``start_designs``, else the
        centre of the box).
    start_designs : array_like, optional
        Designs known beforehand (one per row, in the variables' units; e.g. the
        deterministic optimum), so that the search cannot end worse than them on its own
        estimates: ``surrogate`` runs them first (common random numbers) beside its Latin
        hypercube; ``surrogate`` and ``reweight`` start SLSQP from the best of them and the
        start grid, and keep the best of them if it ranks above SLSQP's end point
        (``surrogate`` then also takes a design already run, with its run's estimate, for an
        optimum within ``xtol`` of it);
        ``crn`` / ``nested`` start COBYLA at the first.
    max_batches : int
        ``reweight``: most batches (the first spread over the box).
    min_ess : float, optional
        ``reweight``: smallest effective sample size of the weights at the chosen design
        (default ``n_samples / 4``); below it a batch is drawn there.
    min_failures : float
        ``reweight``: smallest effective number of failures behind each probability there.
    xtol : float
        ``reweight``: stop when the design moves less than this share of its range.
    grid : int
        Points per variable of the landscape (and of the grid that starts SLSQP).
    n_designs : int
        ``surrogate``: designs of the Latin hypercube.
    n_infill : int
        ``surrogate``: further designs, each run at the surrogate's current optimum (common
        random numbers) and added to its fit; stops early when the optimum is within ``xtol``
        of a design already run.
    conservative : bool
        ``surrogate``: constraints on the upper end of the surrogate's band.
    max_evaluations : int
        ``crn`` / ``nested``: most designs COBYLA may ask for.
    keep_confirmation_runs : bool
        Keep the confirmation's outputs in the result (``run_<output>``, ``run_status``), e.g.
        for a response band.
    confirm_problem : DesignProblem, optional
        The problem of the confirmation when the expensive fidelity is more than model
        options (another model, other output instants): same variable and measure names.
    executor, chunk_size
        As in :func:`gearuq.monte_carlo`.

    Returns
    -------
    xarray.Dataset
        ``design_<var>`` (the choice), ``search_<measure>`` (the search's estimate there),
        ``confirm_<measure>`` with ``_lower`` / ``_upper`` (fresh seed, ``confirm_options``),
        ``objective``, ``landscape_<measure>`` (with ``_lower`` / ``_upper``) over
        ``grid_<var>`` of the first two variables (any others held at the chosen design:
        ``attrs["landscape_held"]``), ``history_*`` of the search,
        ``n_model_runs_search``, ``n_model_runs_confirm``, ``n_model_runs_naive`` (the runs a
        nested loop would have spent on the same designs at the same sample size) and
        ``status`` with ``attrs["message"]`` and ``attrs["status_reasons"]``.

    Raises
    ------
    ValueError
        Unknown strategy, ``reweight`` on a problem whose variables set model parameters,
        bad counts.
    """
    if strategy not in STRATEGIES:
        raise ValueError(f"strategy: unknown {strategy!r}; valid: {', '.join(STRATEGIES)}")
    if strategy == "reweight" and not problem.shifts_only:
        raise ValueError("strategy='reweight' needs every design variable to shift an input "
                         "law of an independent space; use 'surrogate' or 'crn'")
    s = _settings(locals(), problem)
    judge = _check_confirm_problem(problem, confirm_problem)
    seed = resolve_seed(rng)
    t0 = time.perf_counter()
    run_kw = {"executor": executor, "chunk_size": chunk_size}
    found = _SEARCH[strategy](problem, s, seed, run_kw)
    found["wall_time_search"] = time.perf_counter() - t0
    confirm = None
    if s["confirm_samples"] > 0:
        cseed = int(np.random.SeedSequence([seed, 2**31 - 1]).generate_state(1)[0])
        confirm = evaluate_design(judge, found["design"], n_samples=s["confirm_samples"],
                                  rng=cseed, model_options=confirm_options,
                                  keep_runs=keep_confirmation_runs, **run_kw)
    return _result(problem, strategy, s, seed, found, confirm, confirm_options,
                   time.perf_counter() - t0)


def _check_confirm_problem(problem: DesignProblem, other: DesignProblem | None
                           ) -> DesignProblem:
    if other is None:
        return problem
    if not isinstance(other, DesignProblem):
        raise TypeError(f"confirm_problem: expected a DesignProblem, got {type(other).__name__}")
    for what, a, b in (("variables", problem.names, other.names),
                       ("measures", [m.name for m in problem.measures],
                        [m.name for m in other.measures])):
        if a != b:
            raise ValueError(f"confirm_problem: its {what} {b} differ from the search's {a}")
    return other


def _settings(given: Mapping[str, Any], problem: DesignProblem) -> dict[str, Any]:
    s = {k: given[k] for k in ("n_samples", "confirm_samples", "x0", "max_batches", "min_ess",
                               "min_failures", "xtol", "grid", "n_designs", "n_infill",
                               "conservative",
                               "max_evaluations")}
    for key in ("n_samples", "max_batches", "grid", "n_designs", "max_evaluations"):
        v = s[key]
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"{key}: {v!r} must be a positive integer")
    if isinstance(s["n_infill"], bool) or not isinstance(s["n_infill"], (int, np.integer)) \
            or s["n_infill"] < 0:
        raise ValueError(f"n_infill: {s['n_infill']!r} must be an integer >= 0")
    s["confirm_samples"] = s["n_samples"] if s["confirm_samples"] is None \
        else int(s["confirm_samples"])
    if s["confirm_samples"] < 0:
        raise ValueError(f"confirm_samples: {s['confirm_samples']!r} must be >= 0")
    s["min_ess"] = s["n_samples"] / 4 if s["min_ess"] is None else float(s["min_ess"])
    s["starts"] = _start_units(given["start_designs"], problem)
    if s["grid"] < 2:
        raise ValueError(f"grid: {s['grid']!r} must be >= 2")
    return s


def _start_units(designs: Any, problem: DesignProblem) -> list[np.ndarray]:
    """``start_designs`` on the unit box, checked against the design bounds."""
    if designs is None:
        return []
    d = np.atleast_2d(np.asarray(designs, dtype=float))
    k = len(problem.variables)
    if d.ndim != 2 or d.shape[1] != k or not np.all(np.isfinite(d)):
        raise ValueError(f"start_designs: shape {d.shape} must be (m, {k}) of finite numbers "
                         f"(one row per design, columns {problem.names})")
    outside = (d < problem.lower) | (d > problem.upper)
    if outside.any():
        i, j = map(int, np.argwhere(outside)[0])
        raise ValueError(f"start_designs: row {i} has {problem.names[j]}={float(d[i, j])!r} "
                         f"outside its bounds [{problem.lower[j]}, {problem.upper[j]}]")
    return list((d - problem.lower) / (problem.upper - problem.lower))


def _result(problem: DesignProblem, strategy: str, s: Mapping[str, Any], seed: int,
            found: Mapping[str, Any], confirm: xr.Dataset | None,
            confirm_options: Mapping[str, Any] | None, wall: float) -> xr.Dataset:
    d = found["design"]
    data: dict[str, Any] = {}
    coords: dict[str, Any] = {}
    for v, x in zip(problem.variables, d, strict=True):
        data[f"design_{v.name}"] = ((), float(x), {
            "units": v.units, "long_name": f"chosen {v.name} (sets {v.target}, {v.role})",
            "design_bounds": [float(v.lower), float(v.upper)]})
    for m in problem.measures:
        data[f"search_{m.name}"] = ((), float(found["search"][m.name].value), {
            "units": m.units, "long_name": f"search estimate of {m.name} at the chosen design"})
        if confirm is not None:
            for suffix in ("", "_lower", "_upper"):
                data[f"confirm_{m.name}{suffix}"] = ((), float(confirm[m.name + suffix]), {
                    "units": m.units, "long_name": f"{m.name} from the independent confirmation"
                    + (f" ({suffix[1:]} end of the {problem.confidence:.0%} interval)"
                       if suffix else "")})
    objective = (problem.cost(d) if not hasattr(problem.objective, "kind") else
                 float(confirm[problem.objective.name]) if confirm is not None else
                 float(found["search"][problem.objective.name].value))
    data["objective"] = ((), objective, {"units": getattr(problem.objective, "units", ""),
                                         "long_name": "objective at the chosen design"})
    land = found["landscape"]
    if land:
        dims = tuple(f"grid_{v.name}" for v in problem.variables[:2])
        for v, axis in zip(problem.variables[:2], land["axes"], strict=True):
            coords[f"grid_{v.name}"] = (f"grid_{v.name}", axis, {"units": v.units})
        for m in problem.measures:
            for i, suffix in enumerate(("", "_lower", "_upper")):
                data[f"landscape_{m.name}{suffix}"] = (dims, land[m.name][i], {
                    "units": m.units, "long_name": f"{m.name} over the design box"
                    + (f" ({suffix[1:]} end)" if suffix else "")})
        data["landscape_ess"] = (dims, land["ess"], {
            "units": "1", "long_name": "smallest effective sample size behind the landscape "
                                        "(reweight: of the weighted failures)"})
    hist = found["history"]
    if hist:
        for j, v in enumerate(problem.variables):
            data[f"history_{v.name}"] = (("evaluation",), np.array(
                [h["design"][j] for h in hist]), {"units": v.units})
    n_confirm = 0 if confirm is None else int(confirm["n_model_runs"])
    for key, value, what in (("n_model_runs_search", found["n_runs"], "runs of the search"),
                             ("n_model_runs_confirm", n_confirm, "runs of the confirmation"),
                             ("n_model_runs_naive", found["n_naive"],
                              "runs a nested loop would spend on the same designs")):
        data[key] = ((), np.int64(value), {"units": "1", "long_name": what})
    status, reasons = _status(problem, found, confirm)
    data["status"] = ((), np.int8(status), {
        "flag_values": np.array(list(DESIGN_STATUS), dtype=np.int8),
        "flag_meanings": " ".join(DESIGN_STATUS.values()), "role": "status"})
    ds = xr.Dataset(data, coords=coords)
    if confirm is not None:
        ds = ds.merge(confirm[[v for v in confirm.data_vars if str(v).startswith("run_")]])
    ds.attrs.update(provenance(f"design/{strategy}", problem.model, None, problem.space, seed,
                               strategy=strategy, **{k: v for k, v in s.items()
                                                     if v is not None
                                                     and k not in ("x0", "starts")}))
    ds.attrs.update({
        "design_variables": json.dumps([v.__dict__ for v in problem.variables]),
        "search_options": json.dumps(problem.model_options, default=repr),
        "confirm_options": json.dumps(problem.model_options if confirm_options is None
                                      else dict(confirm_options), default=repr),
        "confidence": problem.confidence,
        "constraints": json.dumps([{"measure": c.measure.name, "upper": c.upper,
                                    "lower": c.lower} for c in problem.constraints]),
        "constraint_verdicts": "{}" if confirm is None else confirm.attrs["constraint_verdicts"],
        "batches": json.dumps(found["batches"]),
        "search_history": json.dumps(hist, default=float),
        "start_designs": json.dumps([(problem.lower + u * (problem.upper - problem.lower))
                                     .tolist() for u in s["starts"]]),
        "confirm_seed": -1 if confirm is None else int(confirm.attrs["seed"]),
        "landscape_held": json.dumps({v.name: float(x) for v, x in
                                      zip(problem.variables[2:], d[2:], strict=True)}),
        "message": "; ".join(r for _, r in reasons) or "ok: " + _ok_text(problem),
        "status_reasons": json.dumps([r for _, r in reasons]),
        "wall_time": wall,
    })
    return ds


def _ok_text(problem: DesignProblem) -> str:
    if problem.constraints:
        return ("every constraint holds over the whole confirmation interval at "
                f"{problem.confidence:.0%}")
    return "the chosen design's measures were confirmed by an independent run"


def _status(problem: DesignProblem, found: Mapping[str, Any], confirm: xr.Dataset | None
            ) -> tuple[int, list[tuple[int, str]]]:
    reasons = list(found["reasons"])
    if confirm is None:
        reasons.append((6, "no confirmation run (confirm_samples=0): nothing is vouched for "
                           "beyond the search's own estimate"))
    else:
        verdicts = json.loads(confirm.attrs["constraint_verdicts"])
        for c in problem.constraints:
            name = c.measure.name
            lo, up = float(confirm[name + "_lower"]), float(confirm[name + "_upper"])
            bound = c.upper if c.upper is not None else c.lower
            if verdicts[name] == "undecided":
                reasons.append((4, f"constraint {name}: its confirmation interval "
                                   f"[{lo:.4g}, {up:.4g}] straddles the bound {bound:g}; "
                                   "more confirmation runs would decide it"))
            elif verdicts[name] == "violated":
                reasons.append((5, f"constraint {name}: its confirmation interval "
                                   f"[{lo:.4g}, {up:.4g}] lies beyond the bound {bound:g}"))
        if int(confirm["n_invalid"]):
            reasons.append((6, f"{int(confirm['n_invalid'])} confirmation runs were invalid; "
                               "the probability intervals cover both readings of them"))
        obj = problem.objective
        if isinstance(obj, Probability) and float(confirm[obj.name]) == 0.0:
            reasons.append((6, f"{obj.name}: no failure in the confirmation run; its upper "
                               f"end {float(confirm[obj.name + '_upper']):.3g} is a bound, "
                               "not an estimate"))
    worst = max((code for code, _ in reasons), default=0)
    return worst, reasons
