"""Multi-fidelity importance sampling: a cheap model finds where failure lives, the expensive
one is run only on draws from a density fitted there (Peherstorfer, Cui, Marzouk and Willcox
2016).

1. **Explore on the low-fidelity model** ``LF`` (any :class:`~gearuq.model.Model` whose
   parameters include every random parameter of the space, a surrogate or a fidelity link):
   subset simulation on ``LF`` with the same limit state (or ``low_fidelity_limit_state``)
   gives the last level's failing samples, distributed about as the standard normal restricted
   to ``LF``'s failure domain.
2. **Fit the biasing density**: a Gaussian mixture in the standard normal space, the number of
   components chosen by BIC up to ``max_components`` (scikit-learn ``GaussianMixture``), plus
   a **defensive** standard normal component of share ``defensive``. The defensive share
   bounds every weight by ``1 / defensive``: a failure region of the expensive model that
   ``LF`` does not see still has a sampling density, so the estimator is **unbiased whatever
   ``LF``'s quality**; a useless ``LF`` costs at most the variance of sampling with the
   defensive share alone.
3. **Estimate on the high-fidelity model**: ``pf = mean(1_F w)`` over draws of the mixture, in
   batches until the CoV reaches ``target_cov`` or ``max_samples``; interval ``pf +- z se``.

**Biasing families** (``biasing``), each with the defensive component above:

* ``"gaussian"`` (default): the Gaussian mixture of step 2.
* ``"vmfn"``: a von Mises-Fisher-Nakagami mixture (:mod:`gearuq.failure.methods.vmfn`;
  Papaioannou, Geyer and Straub, "Improved cross entropy-based importance sampling with a
  flexible mixture model", RESS 2019): direction and radius apart, for shell-like failure
  sets. With ``explore="ce"`` it is fitted by multi-level cross-entropy on ``LF`` from the
  standard normal (independent weighted draws; subset simulation's few Markov-chain seeds
  crowd a shell into one direction). Measured: round shells ``|u|^2 >= c`` at Pf 1e-6 in 20
  and 60 dimensions at 200-400 expensive runs, CoV <= 0.1, 38 of 40 intervals holding; an
  ellipsoidal shell with unequal axes in 60 dimensions is *not* covered (one vMF direction
  per component cannot spread unevenly across 59 others: degenerate weights, status 3, or
  no failure reached in 25 levels).
* ``"quadratic"``: the exponentially tilted Gaussian of a quadratic form fitted on ``LF``
  (:mod:`gearuq.failure.methods.quadratic`), ``N((I - 2tA)^-1 t b, (I - 2tA)^-1)`` with
  ``E_t[Q]`` on the failure level: for a response that is the RMS of something linear in
  the germ (``response_offset``: its square is the form). Weights are bounded on the
  failure set whatever the number of directions the shell spans; ``n_fit`` cheap runs (half
  on a widened standard normal, half on the first tilt) fit the ``(d + 1)(d + 2) / 2``
  coefficients, so it needs ``n_fit`` above that. Measured on the 60-dimensional ellipsoidal
  shell at Pf 1.2e-6: CoV 0.16 at 1000 expensive runs, every interval holding.

The same checks as importance sampling set the status: degenerate or heavy-tailed weights
(3), invalid runs (6, interval over both readings); ``LF`` finding no failure gives
a density of the defensive component alone, i.e. crude Monte Carlo on the expensive model,
with status 8 said in words. High- and low-fidelity runs and their wall times are reported
apart (``n_model_runs`` counts the expensive model only); the cheap model's own
importance-sampling estimate with the fitted density (``pf_low_fidelity_is``, its CoV and
effective sample size) says how well the density fits before the expensive runs are judged.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from gearuq.failure.evaluator import LimitStateEvaluator
from gearuq.failure.methods import subset
from gearuq.failure.methods.importance import (
    Mixture,
    sample_until,
    weight_diagnostics,
    weight_status,
)
from gearuq.failure.methods.quadratic import fit_quadratic, tilted_gaussian
from gearuq.failure.methods.vmfn import VMFNMixture, fit_vmfn
from gearuq.failure.report import Reason, failure_report
from gearuq.model import Model, Option

#: Progress of the cheap-model exploration (one line per level, at INFO).
LOG = logging.getLogger("gearuq.failure.mfis")

__all__ = ["SETTINGS", "run_mfis", "fit_mixture", "informative_directions",
           "weighted_directions"]


def _check_model(value: Any) -> Any:
    if value is None:
        raise ValueError("low_fidelity: required for method 'mfis' (a Model or a registered "
                         "model name over the same parameter space)")
    if not isinstance(value, (Model, str)):
        raise ValueError(f"low_fidelity: expected a Model or a registered model name, got "
                         f"{type(value).__name__}")
    return value


def _check_mapping(value: Any) -> Any:
    if value is not None and not isinstance(value, Mapping):
        raise ValueError(f"low_fidelity_options: expected a mapping, got {value!r}")
    return value


def _check_times(value: Any) -> Any:
    if value is None:
        return None
    t = np.asarray(value, dtype=float)
    if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ValueError("low_fidelity_t: expected finite, strictly increasing output instants "
                         f"(1-D), got {value!r}")
    return t


SETTINGS = (
    Option("low_fidelity", None, "the cheap model (Model or registered name) that explores the "
           "failure domain; its parameters must include every random parameter of the space",
           kind="any", check=_check_model, allow_none=True),
    Option("low_fidelity_options", None, "declared model options of the cheap model",
           kind="any", check=_check_mapping, allow_none=True),
    Option("low_fidelity_t", None, "output instants of the cheap model (default: the "
           "expensive model's); fewer instants make a time-dependent cheap model cheaper",
           kind="any", check=_check_times, allow_none=True),
    Option("low_fidelity_limit_state", None, "limit state on the cheap model's outputs "
           "(default: the same as the expensive model's)", kind="any", allow_none=True),
    Option("n_per_level", 2000, "samples per level of the exploration on the cheap model",
           lower=100),
    Option("explore", "subset", "how the cheap model's failure domain is explored: 'subset' "
           "(subset simulation; the density is fitted to its last level) or 'ce' (multi-level "
           "cross-entropy with the biasing family itself, from the standard normal: independent "
           "importance-weighted draws at every level, no Markov chains whose few seeds can "
           "crowd a shell-like domain into one direction; only with biasing='vmfn')",
           kind="str", choices=("subset", "ce")),
    Option("fit_to", "last_level", "samples the mixture is fitted to: 'last_level' (every valid "
           "sample of subset simulation's last level, a superset of the cheap model's failure "
           "domain that reaches back to its boundary) or 'failing' (only its failing samples)",
           kind="str", choices=("last_level", "failing")),
    Option("min_std", 1.0, "smallest standard deviation of a mixture component along any axis "
           "(standard normal units); 1 keeps the weights' tail light where the failure domain "
           "reaches behind the component's mean", lower=0.05, upper=3.0),
    Option("subspace", "auto", "fit the mixture in the directions where the explored samples "
           "differ from standard normal draws by more than sampling noise ('auto'), standard "
           "normal across them; or in every direction ('full')", kind="str",
           choices=("auto", "full")),
    Option("max_components", 4, "largest number of mixture components (chosen by BIC)",
           lower=1, upper=20),
    Option("biasing", "gaussian", "family of the biasing density: 'gaussian' (a Gaussian "
           "mixture), 'vmfn' (a von Mises-Fisher-Nakagami mixture, Papaioannou, Geyer and "
           "Straub, RESS 2019: direction and radius apart, for round shell-like failure "
           "domains) or 'quadratic' (the standard normal exponentially tilted by a quadratic "
           "form fitted on the cheap model: for an RMS response nearly linear in a random "
           "germ, whose failure set is the outside of an ellipsoid)", kind="str",
           choices=("gaussian", "vmfn", "quadratic")),
    Option("n_fit", 2400, "biasing='quadratic': cheap runs for the quadratic fit (half on a "
           "widened standard normal, half on the first tilted density)", lower=50),
    Option("fit_std", 1.5, "biasing='quadratic': standard deviation of the first fit design",
           lower=0.5, upper=5.0),
    Option("response_offset", None, "biasing='quadratic': a with the response a - g (e.g. the "
           "limit X of g = X - y); its square is fitted as the quadratic form (an RMS "
           "response), or g itself when None", kind="any", allow_none=True),
    Option("whiten", False, "biasing='vmfn': fit each component in coordinates scaled by "
           "the square root of the failing draws' second moment (an elliptical shell, for a "
           "failure set {u^T A u > c} with unequal eigenvalues of A)"),
    Option("lf_refine", 0, "cross-entropy steps of the biasing density on the cheap model "
           "after the fit to subset simulation's samples (each n_refine cheap runs: the "
           "density is refitted to the importance-weighted failing draws)", lower=0, upper=10),
    Option("n_refine", 1000, "cheap-model draws per cross-entropy step", lower=50),
    Option("defensive", 0.1, "share of the defensive standard normal component", lower=0.01,
           upper=0.9),
    Option("n_samples", 500, "expensive-model samples per batch", lower=10),
    Option("target_cov", 0.1, "stop when the CoV of pf reaches this", lower=1e-4, upper=1.0),
    Option("max_samples", 10_000, "largest number of expensive-model samples", lower=10),
)


def informative_directions(u: np.ndarray, chain_factor: float = 10.0) -> np.ndarray:
    """Orthonormal directions (columns, ``d x r``) along which the points ``u`` differ from
    standard normal draws by more than sampling noise.

    The second moment ``S = u^T u / n`` of ``n`` standard normal points has its eigenvalues
    inside the Marchenko-Pastur edge ``(1 + sqrt(d / n_eff))^2``; a direction of ``S`` above it
    is where the failure domain pulls the points (a shift or a spread). Subset simulation's
    points are Markov-chain states in chains of length ``1 / p0`` = 10, so at worst one
    independent point per chain: ``n_eff = n / chain_factor``. Directions below the
    edge would only be narrowed, which ``min_std`` undoes anyway. With none above the edge,
    the direction of the mean.
    """
    n, d = u.shape
    second = u.T @ u / n
    val, vec = np.linalg.eigh(second)
    edge = (1.0 + math.sqrt(d / max(n / chain_factor, 1.0))) ** 2
    keep = vec[:, val > edge]
    if keep.shape[1] == 0:
        mean = u.mean(axis=0)
        norm = float(np.linalg.norm(mean))
        keep = (mean / norm)[:, None] if norm > 0 else np.eye(d)[:, :1]
    return keep


def weighted_directions(u: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Orthonormal directions (``d x r``) along which importance-weighted points ``u`` differ
    from standard normal draws by more than sampling noise: the eigenvectors of their weighted
    second moment above the Marchenko-Pastur edge ``(1 + sqrt(d / n_eff))^2``, ``n_eff`` the
    weights' effective sample size (independent draws, unlike subset simulation's chains);
    with none above it, the direction of the weighted mean."""
    d = u.shape[1]
    w = np.asarray(weights, dtype=float)
    w = w / w.sum()
    n_eff = 1.0 / float(np.sum(w**2))
    second = (u * w[:, None]).T @ u
    val, vec = np.linalg.eigh(0.5 * (second + second.T))
    keep = vec[:, val > (1.0 + math.sqrt(d / n_eff)) ** 2]
    if keep.shape[1] == 0:
        mean = w @ u
        norm = float(np.linalg.norm(mean))
        keep = (mean / norm)[:, None] if norm > 0 else np.eye(d)[:, :1]
    return keep


def fit_mixture(u: np.ndarray, max_components: int, defensive: float, seed: int,
                min_std: float = 1.0, subspace: str = "auto") -> Mixture:
    """Gaussian mixture (components by BIC) fitted to points ``u`` of the standard normal
    space, with a defensive standard normal component; with fewer than ``2 (r + 1)`` points
    one component at their mean with the unit covariance.

    With ``subspace="auto"`` the mixture is fitted in the ``r`` informative directions of
    :func:`informative_directions` only and is standard normal across them: in many
    dimensions, a fitted mean and covariance carry sampling noise in every direction, and the
    weights ``phi / q`` multiply that noise over all of them (on the 60-input rotor study
    the full fit gave degenerate weights at Pf ~ 0.1). ``"full"`` fits all ``d`` directions.

    Every component's covariance has its eigenvalues kept in ``[min_std^2, 9]``. A component
    narrower than the failure set it stands for starves its edges, and one narrower than the
    standard normal along the direction towards the origin gives weights ``phi / q`` that grow
    without bound behind its mean (heavy-tailed weights); ``min_std = 1`` bounds that growth.
    """
    from sklearn.mixture import GaussianMixture
    from threadpoolctl import threadpool_limits

    n, d = u.shape
    basis = informative_directions(u) if subspace == "auto" and n > 0 else np.eye(d)
    z = u @ basis
    r = basis.shape[1]
    if n < 2 * (r + 1):
        centre = u.mean(axis=0)[None, :] if n else np.zeros((1, d))
        return Mixture(centre, np.eye(d)[None], np.ones(1), defensive)
    best, best_bic = None, math.inf
    kinds = "full" if n >= 10 * r else "diag"
    with threadpool_limits(1):
        for k in range(1, max_components + 1):
            if n < k * 2 * (r + 1):
                break
            gm = GaussianMixture(k, covariance_type=kinds, reg_covar=1e-3,
                                 random_state=seed % 2**32, n_init=2).fit(z)
            bic = gm.bic(z)
            if bic < best_bic:
                best, best_bic = gm, bic
    covs = best.covariances_ if kinds == "full" else np.array([np.diag(c) for c in
                                                                best.covariances_])
    val, vec = np.linalg.eigh(covs)
    covs = np.einsum("kij,kj,klj->kil", vec, np.clip(val, min_std**2, 9.0), vec)
    # back to the full space: the fitted part in the informative directions, the standard
    # normal across them
    means = best.means_ @ basis.T
    full = np.eye(d)[None] + np.einsum("ia,kab,jb->kij", basis, covs - np.eye(r)[None], basis)
    mix = Mixture(means, full, best.weights_, defensive)
    mix.n_directions = r
    return mix


def _low_fidelity(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int
                  ) -> LimitStateEvaluator:
    from gearuq.registry import get_model

    lf = _check_model(s["low_fidelity"])
    lf = get_model(lf) if isinstance(lf, str) else lf
    missing = [n for n in ev.names if n not in lf.parameter_names]
    if missing:
        raise ValueError(
            f"low_fidelity: model {lf.name!r} has no parameter(s) {', '.join(map(repr, missing))}"
            f" of the parameter space; its parameters: {', '.join(lf.parameter_names)}. Wrap it "
            "in a fidelity link that maps the space onto its inputs")
    limit = s["low_fidelity_limit_state"] or ev.limit_state
    t = ev.request.t if s["low_fidelity_t"] is None else s["low_fidelity_t"]
    # the cheap side runs on the same executor and chunking as the expensive one (without
    # chunk_size a design of a few thousand runs is one chunk, i.e. one worker)
    return LimitStateEvaluator(lf, ev.space, limit, t,
                               model_options=s["low_fidelity_options"], executor=ev.executor,
                               chunk_size=ev.chunk_size,
                               store=None if ev.store is None else ev.store / "low_fidelity",
                               engine="failure_probability/mfis/low_fidelity", seed=seed)


def run_mfis(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float
             ) -> xr.Dataset:
    """Multi-fidelity importance sampling; see the module docstring."""
    t0 = time.perf_counter()
    if s["explore"] == "ce" and s["biasing"] != "vmfn":
        raise ValueError(f"explore: 'ce' needs biasing='vmfn', got biasing={s['biasing']!r}")
    ev_lf = _low_fidelity(ev, s, seed)
    if s["biasing"] == "quadratic":
        mix, refine, reasons = _quadratic(ev_lf, s, seed)
        t_lf = time.perf_counter() - t0
        est = sample_until(ev, mix, s, confidence, np.random.SeedSequence([seed, 31]), "mfis")
        walk = subset.Walk([{"p": refine.get("pf", math.nan)}], np.empty((0, ev.dim)),
                           np.empty(0))
        return _report(ev, s, seed, confidence, est, mix, walk, ev_lf, reasons, t0, t_lf,
                       refine)
    if s["explore"] == "ce":
        mix, walk, refine, reasons = _cross_entropy(ev_lf, s, seed)
        t_lf = time.perf_counter() - t0
        if refine.get("n_fail", 0) == 0:
            mix = Mixture(np.zeros((1, ev.dim)), np.eye(ev.dim)[None], np.ones(1),
                          1.0 - 1e-12)
        else:
            mix, more = _refine(ev_lf, mix, s, seed)
            refine = more or refine
        est = sample_until(ev, mix, s, confidence, np.random.SeedSequence([seed, 31]), "mfis")
        return _report(ev, s, seed, confidence, est, mix, walk, ev_lf, reasons, t0, t_lf,
                       refine)
    sub = {o.name: o.default for o in subset.SETTINGS}
    sub["n_per_level"] = s["n_per_level"]
    walk = subset.simulate(ev_lf, sub, seed)
    t_lf = time.perf_counter() - t0
    reasons: list[Reason] = []
    fail_u = walk.failing() if walk.levels else np.empty((0, ev.dim))
    fit_u = fail_u if s["fit_to"] == "failing" else walk.u[np.isfinite(walk.g)]
    refine: dict[str, float] = {}
    if fail_u.shape[0] == 0:
        mix = Mixture(np.zeros((1, ev.dim)), np.eye(ev.dim)[None], np.ones(1), 1.0 - 1e-12)
        reasons.append((8, "the low-fidelity model found no failure: the expensive model is "
                        "sampled by crude Monte Carlo (the defensive component alone)"))
    else:
        mix = _fit(fit_u, None, s, seed)
        mix, refine = _refine(ev_lf, mix, s, seed)
    est = sample_until(ev, mix, s, confidence, np.random.SeedSequence([seed, 31]), "mfis")
    return _report(ev, s, seed, confidence, est, mix, walk, ev_lf, reasons, t0, t_lf, refine)


def _fit(u: np.ndarray, weights: np.ndarray | None, s: Mapping[str, Any], seed: int,
         basis: np.ndarray | None = None) -> Mixture | VMFNMixture:
    """The biasing density of the ``biasing`` family fitted to (weighted) points ``u``."""
    if s["biasing"] == "gaussian":
        return fit_mixture(u, s["max_components"], s["defensive"], seed, s["min_std"],
                           s["subspace"])
    if basis is None:
        d = u.shape[1]
        basis = informative_directions(u) if s["subspace"] == "auto" else np.eye(d)
    return fit_vmfn(u, weights, basis, s["defensive"], s["max_components"], seed,
                    whiten=s["whiten"])


def _cheap_estimate(c: np.ndarray) -> dict[str, float]:
    """The cheap model's importance estimate from ``c`` (the weight of each failing draw, 0
    elsewhere): pf, its CoV, the effective sample size and the number of failing draws."""
    pf = float(c.mean())
    pos = c[c > 0]
    return {"pf": pf, "cov": float(c.std(ddof=1) / math.sqrt(c.size) / pf) if pf > 0
            else math.inf, "ess": float(pos.sum() ** 2 / np.sum(pos**2)) if pos.size else 0.0,
            "n_fail": float(pos.size)}


def _quadratic(ev_lf: LimitStateEvaluator, s: Mapping[str, Any], seed: int
               ) -> tuple[Mixture, dict[str, float], list[Reason]]:
    """Fit ``Q(u)`` on the cheap model, tilt, refit with the tilted draws, tilt again
    (:mod:`gearuq.failure.methods.quadratic`); the second stage's draws also give the cheap
    model's importance estimate with this density."""
    d = ev_lf.dim
    off = s["response_offset"]
    if off is not None and not (isinstance(off, (int, float)) and math.isfinite(off)):
        raise ValueError(f"response_offset: expected a finite number or None, got {off!r}")

    def target(g: np.ndarray) -> tuple[np.ndarray, float]:
        return ((float(off) - g) ** 2, float(off) ** 2) if off is not None else (-g, 0.0)

    n1 = s["n_fit"] // 2
    rng = np.random.default_rng(np.random.SeedSequence([seed, 53]))
    u1 = s["fit_std"] * rng.standard_normal((n1, d))
    g1 = ev_lf.evaluate(u1, "mfis/quadratic_fit0")["g"]
    ok = np.isfinite(g1)
    q1, level = target(g1[ok])
    a, b, c0, r2 = fit_quadratic(u1[ok], q1)
    mu, sigma, t = tilted_gaussian(a, b, c0, level)
    mix = Mixture(mu[None], sigma[None], np.ones(1), s["defensive"])
    u2 = mix.sample(s["n_fit"] - n1, rng)
    res = ev_lf.evaluate(u2, "mfis/quadratic_fit1")
    w = np.exp(mix.log_weights(u2))
    c = np.where((res["status"] == 0) & (res["g"] <= 0.0), w, 0.0)
    u_all = np.vstack([u1[ok], u2[np.isfinite(res["g"])]])
    q_all, _ = target(np.concatenate([g1[ok], res["g"][np.isfinite(res["g"])]]))
    a, b, c0, r2 = fit_quadratic(u_all, q_all)
    mu, sigma, t = tilted_gaussian(a, b, c0, level)
    info = {**_cheap_estimate(c), "r2": r2, "tilt": t}
    LOG.info("quadratic fit R^2 %.4f, tilt %.4g, largest variance %.3g, cheap pf %.3g",
             r2, t, float(np.linalg.eigvalsh(sigma).max()), info["pf"])
    mix = Mixture(mu[None], sigma[None], np.ones(1), s["defensive"])
    mix.n_directions = d
    return mix, info, []


def _cross_entropy(ev_lf: LimitStateEvaluator, s: Mapping[str, Any], seed: int
                   ) -> tuple[VMFNMixture, subset.Walk, dict[str, float], list[Reason]]:
    """Multi-level cross-entropy on the cheap model (Rubinstein and Kroese 2004) with the
    von Mises-Fisher-Nakagami family (Papaioannou, Geyer and Straub 2019).

    Level ``t`` draws ``n_per_level`` points of ``h_t`` (``h_0``: the standard normal, a
    uniform direction and a chi radius), takes the threshold ``gamma_t`` at the ``p0 = 0.1``
    quantile of ``g`` (0 once it is reached) and refits the density to the draws with
    ``g <= gamma_t`` weighted by ``phi / h_t``. The last level's weighted failing draws give
    the cheap model's importance-sampling estimate. Invalid cheap runs count as safe here (the
    cheap model only shapes the density; the estimate is the expensive model's).
    """
    d = ev_lf.dim
    n, p0 = s["n_per_level"], 0.1
    mix = VMFNMixture(np.eye(d)[:1], np.zeros(1), np.array([d / 2.0]), np.array([float(d)]),
                      np.ones(1), s["defensive"], np.eye(d))
    levels: list[dict[str, Any]] = []
    reasons: list[Reason] = []
    info: dict[str, float] = {"n_fail": 0.0}
    u = np.empty((0, d))
    g = np.empty(0)
    for t in range(_MAX_CE_LEVELS):
        rng = np.random.default_rng(np.random.SeedSequence([seed, 41, t]))
        u = mix.sample(n, rng)
        res = ev_lf.evaluate(u, f"mfis/ce{t}")
        g = np.where(res["status"] == 0, res["g"], np.inf)
        w = np.exp(mix.log_weights(u))
        gamma = max(float(np.quantile(g, p0)), 0.0)
        c = np.where(g <= gamma, w, 0.0)
        pos = c[c > 0]
        levels.append({"p": float(c.mean()), "threshold": gamma})
        LOG.info("cross-entropy level %d: threshold %.4g, %d elite draws, %d cheap runs", t,
                 gamma, pos.size, ev_lf.n_runs)
        if gamma <= 0.0:
            info = _cheap_estimate(c)
        if not np.isfinite(gamma) or pos.size < 2:
            reasons.append((8, f"cross-entropy level {t}: too few finite cheap-model values "
                            "to go on; the density may miss part of the failure domain"))
            break
        basis = weighted_directions(u, c) if s["subspace"] == "auto" else mix.basis
        mix = fit_vmfn(u, c, basis, s["defensive"], s["max_components"], seed + t,
                       whiten=s["whiten"])
        if gamma <= 0.0:
            break
    else:
        reasons.append((8, f"cross-entropy did not reach the failure domain of the cheap model "
                        f"in {_MAX_CE_LEVELS} levels"))
    info["levels"] = float(len(levels))
    # the cheap model's pf is the last level's importance estimate (not a product of levels)
    walk = subset.Walk([{"p": info.get("pf", math.nan)}], u, g)
    return mix, walk, info, reasons


#: Largest number of cross-entropy levels on the cheap model.
_MAX_CE_LEVELS = 25


def _refine(ev_lf: LimitStateEvaluator, mix: Mixture | VMFNMixture, s: Mapping[str, Any],
            seed: int) -> tuple[Mixture | VMFNMixture, dict[str, float]]:
    """Cross-entropy steps on the cheap model: draw the density, weight the failing draws by
    ``phi / h``, refit. Returns the density and the last step's cheap-model importance
    estimate (pf, CoV, effective sample size), which says how well the density fits the
    cheap model's failure domain before any expensive run."""
    info: dict[str, float] = {}
    for step in range(s["lf_refine"]):
        rng = np.random.default_rng(np.random.SeedSequence([seed, 37, step]))
        u = mix.sample(s["n_refine"], rng)
        res = ev_lf.evaluate(u, f"mfis/refine{step}")
        w = np.exp(mix.log_weights(u))
        c = np.where((res["status"] == 0) & (res["g"] <= 0.0), w, 0.0)
        info = _cheap_estimate(c)
        if info["n_fail"] < 10:
            break  # too few failing draws to refit: keep the density
        if isinstance(mix, VMFNMixture):
            mix = _fit(u, c, s, seed + step + 1, basis=mix.basis)
        else:
            mix = mix.adapted(u, c)
    return mix, info


def _report(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float,
            est: dict[str, float], mix: Mixture, walk: subset.Walk, ev_lf: LimitStateEvaluator,
            reasons: list[Reason], t0: float, t_lf: float, refine: Mapping[str, float]
            ) -> xr.Dataset:
    status, message, bound, pf, lower, upper = weight_status(
        est, s["target_cov"], "the low-fidelity model may lead away from the failure domain")
    weights, invalid = weight_diagnostics(est, "expensive-model samples")
    reasons += invalid
    extra = {
        "n_low_fidelity_runs": ((), np.int64(ev_lf.n_runs), {"units": "1", "long_name":
                                "runs of the low-fidelity model (not in n_model_runs)"}),
        "low_fidelity_wall_time": ((), float(t_lf), {"units": "s", "long_name":
                                   "wall time of the low-fidelity exploration"}),
        "high_fidelity_wall_time": ((), float(time.perf_counter() - t0 - t_lf), {
            "units": "s", "long_name": "wall time of the expensive-model sampling"}),
        "pf_low_fidelity": ((), walk.pf, {"units": "1", "long_name":
                            "subset-simulation estimate of the low-fidelity model"}),
        "n_components": ((), np.int64(getattr(mix, "n_components", None) or
                                      mix.means.shape[0]), {"units": "1", "long_name":
                         "components of the biasing density (defensive excluded)"}),
        "n_directions": ((), np.int64(getattr(mix, "n_directions", ev.dim)), {
            "units": "1", "long_name": "directions in which the biasing density was fitted "
                                       "(standard normal across them)"}),
        **weights,
    }
    if "pf" in refine:
        extra["pf_low_fidelity_is"] = ((), refine["pf"], {"units": "1", "long_name":
                                       "importance-sampling estimate of the cheap model's pf "
                                       "on the last cross-entropy step's draws"})
        extra["cov_low_fidelity_is"] = ((), refine["cov"], {"units": "1", "long_name":
                                        "its coefficient of variation"})
        extra["ess_low_fidelity_is"] = ((), refine["ess"], {"units": "1", "long_name":
                                        "effective sample size of its failing draws"})
    settings = {k: (v.name if isinstance(v, Model) else v) for k, v in s.items()}
    return failure_report(
        ev, "mfis", pf=pf, pf_lower=lower, pf_upper=upper, cov=est["cov"],
        interval_kind="normal approximation pf +- z se of the importance-sampling estimator "
                      "(expensive-model runs only)",
        confidence=confidence, settings=settings, seed=seed,
        wall_time=time.perf_counter() - t0, status=status, message=message, reasons=reasons,
        grid_gap=est["grid_gap"] if ev.time_dependent else math.nan, pf_is_upper_bound=bound,
        extra=extra, extra_attrs={"low_fidelity_model": ev_lf.model.name,
                                  "defensive_share": float(mix.defensive),
                                  "biasing_density": mix.describe() if isinstance(
                                      mix, VMFNMixture) else "Gaussian mixture",
                                  **({"quadratic_fit_r2": refine["r2"], "tilt": refine["tilt"]}
                                     if "r2" in refine else {})})
