"""Active-learning Kriging on a Monte Carlo population (AK-MCS, Echard et al. 2011).

A Kriging (Gaussian-process) surrogate of the limit state, built in the independent standard
normal space, classifies a Monte Carlo population as safe or failed. It is enriched one model
run at a time at the population point whose sign is most uncertain, by the learning function

    U(u) = |mu(u)| / sigma(u)      (mu, sigma: Kriging mean and standard deviation),

until ``min U >= u_stop`` (2 by default: every point's sign is right with probability
``Phi(2) = 0.977`` or more); then, if the population's own coefficient of variation
``sqrt((1 - pf) / (n pf))`` is above ``target_cov``, the population grows and learning goes on.

Systems (:class:`~gearuq.failure.modes.System`) are learnt component by component (AK-SYS,
Fauriat and Gayton 2014): one Kriging model per limit state, the system mean combined by
min/max, and ``U`` taken from the component that governs each point. Kinks of a series system
then live in the combination, not in a surrogate.

The report holds the population estimate ``pf``, the surrogate's own error on it -- the
population fractions failing under ``mu + z sigma`` and ``mu - z sigma``
(``pf_surrogate_lower``/``pf_surrogate_upper``) and the expected number of misclassified
points ``sum Phi(-U)`` -- and an interval that covers both errors: the Wilson interval of the
lower count's lower end to the upper count's upper end. The learning history (model runs,
Pf, min U per iteration) is in the ``iteration`` dim.

The Kriging model is scikit-learn's ``GaussianProcessRegressor`` with a constant times
anisotropic squared-exponential kernel plus a small white-noise term (numerical stability,
and tolerance of solver noise), hyper-parameters by maximum likelihood with restarts.
A discontinuous response defeats it (the squared-exponential kernel assumes smoothness): the
learning then needs many runs and may stop with misclassified points; the reported surrogate
interval shows it, and ``max_runs`` stops the run with status ``not_converged``.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from gearuq.failure.evaluator import LimitStateEvaluator
from gearuq.failure.modes import System
from gearuq.failure.report import failure_report
from gearuq.model import Option

__all__ = ["SETTINGS", "run_akmcs", "learning_function_u"]

SETTINGS = (
    Option("n_mc", 100_000, "Monte Carlo population (grows by this much while its CoV is "
           "above target_cov)", lower=100),
    Option("max_mc", 2_000_000, "largest population", lower=100),
    Option("target_cov", 0.05, "coefficient of variation of the population estimate to reach",
           lower=1e-4, upper=1.0),
    Option("n_initial", 12, "initial design (population points far apart, see "
           "initial_design)", lower=2),
    Option("max_runs", 300, "largest number of model runs", lower=2),
    Option("u_stop", 2.0, "stop when min U over the population reaches this", lower=0.0),
    Option("n_restarts", 2, "restarts of the Kriging hyper-parameter optimisation", lower=0),
    Option("refresh", 10, "every this many iterations: Kriging fit with random restarts and "
           "a full re-prediction of the population; in between one local fit from the previous "
           "hyper-parameters and only points with U < 5 re-predicted (a full prediction always "
           "confirms the stopping rule)", lower=1),
)

#: Points with U above this are not re-predicted between full refreshes.
ACTIVE_U = 5.0
#: Population points predicted per block (bounds memory).
BLOCK = 50_000


def learning_function_u(mu: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """``U = |mu| / sigma`` (``inf`` where ``sigma = 0``)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.abs(mu) / sigma
    return np.where(sigma > 0, u, np.inf)


class _Surrogate:
    """One Kriging model per limit-state component."""

    def __init__(self, dim: int, n_leaves: int, n_restarts: int, seed: int) -> None:
        self.dim, self.n_leaves, self.n_restarts, self.seed = dim, n_leaves, n_restarts, seed
        self.models: list[Any] = []
        self.scale = np.ones(n_leaves)

    def fit(self, x: np.ndarray, y: np.ndarray, iteration: int, restart: bool) -> None:
        """Maximum-likelihood fit of each component model.

        Between restarts the optimiser starts from the previous hyper-parameters (one local
        optimisation); with ``restart`` it also tries ``n_restarts`` random starts.
        """
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.gaussian_process import GaussianProcessRegressor
        from sklearn.gaussian_process.kernels import (
            RBF,
            ConstantKernel,
            DotProduct,
            WhiteKernel,
        )

        from gearuq._threads import one_blas_thread

        previous = self.models
        self.models = []
        self.scale = np.sqrt(np.mean(y * y, axis=0))
        self.scale[~(self.scale > 0)] = 1.0
        for j in range(self.n_leaves):
            if previous and not restart:
                kernel = previous[j].kernel_
            else:
                kernel = (ConstantKernel(1.0, (1e-4, 1e4))
                          * RBF(np.ones(self.dim), (1e-2, 1e3))
                          + ConstantKernel(0.1, (1e-6, 1e3)) * DotProduct(1.0, (1e-3, 1e3))
                          + WhiteKernel(1e-8, (1e-12, 1e-3)))
            # zero prior mean on the RMS-scaled values: far from the data the prediction
            # reverts to g = 0 (the sign is unknown there), so U is small and the learning
            # explores instead of declaring unexplored regions safe
            gp = GaussianProcessRegressor(kernel, normalize_y=False,
                                          n_restarts_optimizer=self.n_restarts if restart else 0,
                                          random_state=(self.seed + 7919 * iteration + j)
                                          % 2**32)
            # the matrices are tiny: BLAS threads cost more than they save (20x on a busy
            # 2-core machine), so the fit runs single-threaded
            with warnings.catch_warnings(), one_blas_thread():
                warnings.simplefilter("ignore", ConvergenceWarning)
                gp.fit(x, y[:, j] / self.scale[j])
            self.models.append(gp)

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        mu = np.empty((x.shape[0], self.n_leaves))
        sd = np.empty_like(mu)
        for start in range(0, x.shape[0], BLOCK):
            block = x[start:start + BLOCK]
            for j, gp in enumerate(self.models):
                m, s = gp.predict(block, return_std=True)
                mu[start:start + BLOCK, j] = m * self.scale[j]
                sd[start:start + BLOCK, j] = s * self.scale[j]
        return mu, sd


class _State:
    """Population, training set and current predictions of one AK-MCS run."""

    def __init__(self, ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int) -> None:
        self.ev, self.s, self.seed = ev, s, seed
        self.system = ev.limit_state if isinstance(ev.limit_state, System) else None
        self.n_leaves = len(ev.leaves)
        self.pop = np.empty((0, ev.dim))
        self.mu = np.empty((0, self.n_leaves))
        self.sd = np.empty((0, self.n_leaves))
        self.known = np.empty((0, self.n_leaves))  # true leaf values of trained points
        self.trained = np.empty(0, dtype=bool)
        self.x_train = np.empty((0, ev.dim))
        self.y_train = np.empty((0, self.n_leaves))
        self.n_blocks = 0
        self.surrogate = _Surrogate(ev.dim, self.n_leaves, s["n_restarts"], seed)

    def grow(self) -> None:
        rng = np.random.default_rng(np.random.SeedSequence([self.seed, 21, self.n_blocks]))
        new = rng.standard_normal((self.s["n_mc"], self.ev.dim))
        self.n_blocks += 1
        self.pop = np.vstack([self.pop, new])
        pad = np.full((new.shape[0], self.n_leaves), np.nan)
        self.mu, self.sd = np.vstack([self.mu, pad]), np.vstack([self.sd, pad])
        self.known = np.vstack([self.known, pad])
        self.trained = np.concatenate([self.trained, np.zeros(new.shape[0], dtype=bool)])

    def run(self, idx: np.ndarray, tag: str) -> None:
        res = self.ev.evaluate(self.pop[idx], tag)
        ok = res["status"] == 0
        self.trained[idx] = True  # a failed run is not retried at the same point
        self.known[idx[ok]] = res["leaf"][ok]
        self.x_train = np.vstack([self.x_train, self.pop[idx[ok]]])
        self.y_train = np.vstack([self.y_train, res["leaf"][ok]])

    def combine(self, leaf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.system is None:
            return leaf[:, 0], np.zeros(leaf.shape[0], dtype=int)
        return self.system.combine(leaf)

    def predict(self, where: np.ndarray | None) -> None:
        idx = np.arange(self.pop.shape[0]) if where is None else where
        if idx.size:
            self.mu[idx], self.sd[idx] = self.surrogate.predict(self.pop[idx])

    def learning(self) -> tuple[np.ndarray, np.ndarray]:
        """System mean and U per population point (trained points: true value, U = inf)."""
        mu = np.where(self.trained[:, None] & np.isfinite(self.known), self.known, self.mu)
        g, gov = self.combine(mu)
        rows = np.arange(g.size)
        u = learning_function_u(mu[rows, gov], self.sd[rows, gov])
        u[self.trained] = np.inf
        return g, u


def run_akmcs(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float
              ) -> xr.Dataset:
    """AK-MCS (AK-SYS for systems); see the module docstring."""
    t0 = time.perf_counter()
    st = _State(ev, s, seed)
    st.grow()
    st.run(initial_design(st.pop, s["n_initial"], seed), "akmcs/initial")
    history: list[tuple[int, float, float]] = []
    status, message, it, since_full = 1, "", 0, 0
    while True:
        if st.x_train.shape[0] < 2:
            status, message = 2, "fewer than two valid model runs to fit the Kriging model"
            break
        full = it == 0 or since_full + 1 >= s["refresh"]
        st.surrogate.fit(st.x_train, st.y_train, it, restart=full)
        _, u_prev = st.learning() if it else (None, None)
        st.predict(None if full else np.flatnonzero(u_prev < ACTIVE_U))
        since_full = 0 if full else since_full + 1
        g, u = st.learning()
        if u.min() >= s["u_stop"] and not full:
            st.predict(None)
            since_full = 0
            g, u = st.learning()
        pf_hat = float(np.mean(g <= 0))
        history.append((ev.n_runs, pf_hat, float(u.min())))
        if u.min() >= s["u_stop"]:
            cov = _population_cov(pf_hat, g.size)
            if cov > s["target_cov"] and st.pop.shape[0] + s["n_mc"] <= s["max_mc"]:
                st.grow()
                st.predict(np.arange(st.pop.shape[0] - s["n_mc"], st.pop.shape[0]))
                it += 1
                continue
            status = 0
            if cov > s["target_cov"]:
                status = 1
                message = (f"population CoV {cov:.3f} above target {s['target_cov']} at max_mc="
                           f"{s['max_mc']}: raise max_mc or use another method")
            break
        if ev.n_runs >= s["max_runs"]:
            message = (f"max_runs={s['max_runs']} reached with min U = {u.min():.3g} < "
                       f"{s['u_stop']}: some population points may be misclassified")
            break
        it += 1
        st.run(np.array([int(np.argmin(u))]), f"akmcs/iter{it}")
    return _report(ev, st, s, seed, confidence, history, status, message, t0)


def initial_design(pop: np.ndarray, n: int, seed: int, n_candidates: int = 5000
                   ) -> np.ndarray:
    """Indices of ``n`` population points chosen far apart (greedy maximin).

    From a random subset of the population, start at the point nearest the origin and add
    the candidate farthest from those chosen, repeatedly. The design then reaches into the
    tails of the population, where failure lives; a purely random initial design sees only
    the bulk, and the Kriging model can then declare an unexplored failure region safe with
    confidence (it did so on the helical pair, Pf 8e-3 reported as 0).
    """
    rng = np.random.default_rng(np.random.SeedSequence([seed, 22]))
    cand = rng.choice(pop.shape[0], size=min(n_candidates, pop.shape[0]), replace=False)
    pts = pop[cand]
    chosen = [int(np.argmin(np.sum(pts * pts, axis=1)))]
    dist = np.sum((pts - pts[chosen[0]]) ** 2, axis=1)
    while len(chosen) < min(n, cand.size):
        nxt = int(np.argmax(dist))
        chosen.append(nxt)
        dist = np.minimum(dist, np.sum((pts - pts[nxt]) ** 2, axis=1))
    return cand[np.array(chosen)]


def _population_cov(pf: float, n: int) -> float:
    return math.sqrt((1 - pf) / (n * pf)) if pf > 0 else math.inf


def _report(ev: LimitStateEvaluator, st: _State, s: Mapping[str, Any], seed: int,
            confidence: float, history: list[tuple[int, float, float]], status: int,
            message: str, t0: float) -> xr.Dataset:
    from gearuq.failure.intervals import wilson_interval

    if st.x_train.shape[0] < 2:
        return failure_report(ev, "akmcs", pf=math.nan, interval_kind="none",
                              confidence=confidence, settings=s, seed=seed,
                              wall_time=time.perf_counter() - t0, status=2, message=message)
    st.predict(None)
    g, u = st.learning()
    n = g.size
    z = stats.norm.isf((1 - confidence) / 2)
    mu = np.where(st.trained[:, None] & np.isfinite(st.known), st.known, st.mu)
    sd = np.where(st.trained[:, None], 0.0, st.sd)
    k = int(np.sum(g <= 0))
    k_low = int(np.sum(st.combine(mu + z * sd)[0] <= 0))
    k_high = int(np.sum(st.combine(mu - z * sd)[0] <= 0))
    lower = float(wilson_interval(k_low, n, confidence)[0])
    upper = float(wilson_interval(k_high, n, confidence)[1])
    pf, bound = k / n, False
    if k == 0:
        # nothing classified failed means no training run failed either (trained points
        # keep their true values): the surrogate never saw the failure domain, so the
        # population bound is only as good as an extrapolation it cannot check
        pf = upper = math.nan
        status = 8
        message = (
            f"no population point was classified as failed and none of the {ev.n_runs} model "
            "runs failed: the Kriging model has never seen the failure domain, so AK-MCS "
            "cannot bound pf (its population may hold failures it classifies safe); use "
            "subset simulation or importance sampling, or a larger n_initial"
            + (f"; {message}" if message else ""))
    hist = np.array(history)
    misclassified = float(np.sum(stats.norm.sf(u[np.isfinite(u)])))
    extra = {
        "n_population": ((), np.int64(n), {"units": "1", "long_name": "Monte Carlo population"}),
        "pf_surrogate_lower": ((), k_low / n, {"units": "1", "long_name":
                               "population fraction failing under mu + z sigma"}),
        "pf_surrogate_upper": ((), k_high / n, {"units": "1", "long_name":
                               "population fraction failing under mu - z sigma"}),
        "expected_misclassified": ((), misclassified, {"units": "1", "long_name":
                                   "sum of Phi(-U): expected wrongly classified points"}),
        "min_u": ((), float(u.min()), {"units": "1", "long_name": "final min U"}),
        "iteration_model_runs": (("iteration",), hist[:, 0].astype(np.int64),
                                 {"units": "1", "long_name": "model runs so far"}),
        "iteration_pf": (("iteration",), hist[:, 1], {"units": "1", "long_name":
                         "surrogate Pf on the population at each iteration"}),
        "iteration_min_u": (("iteration",), hist[:, 2], {"units": "1", "long_name":
                            "min U at each iteration"}),
    }
    kind = ("Wilson interval of the population, widened to the surrogate's own error "
            "(counts under mu +- z sigma)")
    cov = _population_cov(k / n, n) if k else math.inf
    return failure_report(ev, "akmcs", pf=pf, pf_lower=lower, pf_upper=upper, cov=cov,
                          interval_kind=kind, confidence=confidence, settings=s, seed=seed,
                          wall_time=time.perf_counter() - t0, status=status, message=message,
                          pf_is_upper_bound=bound, extra=extra)
