"""Importance sampling around the FORM design point(s).

The sampling density in the independent standard normal space is a mixture of unit-variance
normals centred on the design points ``u*_k`` (one component when FORM finds one design
point), weighted by ``Phi(-beta_k)`` (or equally):

    h(u) = sum_k pi_k phi_d((u - u*_k) / sigma) / sigma^d.

The estimator is ``pf = mean(1[G(u_i) <= 0] w_i)``, ``w = phi_d(u) / h(u)`` computed in the log
domain, with variance ``var(1 w) / n``; the interval is the normal one, ``pf +- z se``
(clipped at 0), and sampling continues in batches until the coefficient of variation reaches
``target_cov`` (or ``max_samples``). The model runs of the FORM search are counted too.

Degenerate weights are reported, never hidden: the effective sample size of the failing
samples, ``ESS = (sum w)^2 / sum w^2``, and the largest share of one sample in the estimate.
When one sample carries more than half of the estimate, or ESS < 10, the status is
``weights_degenerate`` (typically a failure region the design points missed, or a density
too narrow in high dimension).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr
from scipy import special, stats

from gearuq.engines.failure import LimitStateEvaluator, failure_report
from gearuq.engines.form import FORM_SETTINGS, form_design_points
from gearuq.model import Option

__all__ = ["SETTINGS", "run_importance", "mixture_log_weights"]

SETTINGS = (
    Option("n_samples", 1000, "samples per batch", lower=2),
    Option("target_cov", 0.05, "stop when the CoV of pf reaches this", lower=1e-6, upper=1.0),
    Option("max_samples", 20_000, "largest number of importance samples", lower=2),
    Option("sampling_std", 1.0, "standard deviation of each mixture component", lower=0.05,
           upper=10.0),
    Option("weights", "probability", "mixture weights: proportional to Phi(-beta_k) or equal",
           choices=("probability", "equal")),
) + tuple(o for o in FORM_SETTINGS if o.name in ("n_starts", "start_radius", "fd_step",
                                                  "fd_scheme", "tol_u", "tol_g", "max_iter",
                                                  "max_line_search", "distinct"))


def mixture_log_weights(u: np.ndarray, centres: np.ndarray, mix: np.ndarray, sigma: float
                        ) -> np.ndarray:
    """``log(phi_d(u) / h(u))`` for the normal mixture ``h`` (dimension constants cancel)."""
    log_phi = -0.5 * np.sum(u * u, axis=1)
    sq = ((u[:, None, :] - centres[None, :, :]) ** 2).sum(axis=2)
    comp = np.log(mix)[None, :] - 0.5 * sq / sigma**2 - u.shape[1] * math.log(sigma)
    return log_phi - special.logsumexp(comp, axis=1)


def run_importance(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float
                   ) -> xr.Dataset:
    """Importance sampling centred on the FORM design point(s)."""
    t0 = time.perf_counter()
    found, starts = form_design_points(ev, s, seed)
    form_runs = ev.n_runs
    if not found:
        msg = "; ".join(r["error"] or "not converged" for r in starts)
        failed = any(r["error"].startswith("model failed") for r in starts)
        return failure_report(ev, "importance", pf=math.nan, interval_kind="none",
                              confidence=confidence, settings=s, seed=seed,
                              wall_time=time.perf_counter() - t0, status=2 if failed else 1,
                              message=f"FORM found no design point to centre on: {msg}")
    centres = np.array([p["u"] for p in found])
    betas = np.array([p["beta"] for p in found])
    mix = stats.norm.sf(betas) if s["weights"] == "probability" else np.ones(len(found))
    mix = mix / mix.sum()
    contrib: list[np.ndarray] = []
    n_valid, b = 0, 0
    z = stats.norm.isf((1 - confidence) / 2)
    while True:
        rng = np.random.default_rng(np.random.SeedSequence([seed, 11, b]))
        m = min(s["n_samples"], s["max_samples"] - n_valid - ev.n_invalid)
        which = rng.choice(len(found), size=m, p=mix)
        u = centres[which] + s["sampling_std"] * rng.standard_normal((m, ev.dim))
        res = ev.evaluate(u, f"importance/batch{b}")
        ok = res["status"] == 0
        logw = mixture_log_weights(u[ok], centres, mix, s["sampling_std"])
        contrib.append(np.where(res["g"][ok] <= 0.0, np.exp(logw), 0.0))
        n_valid += int(ok.sum())
        b += 1
        est = _estimate(np.concatenate(contrib), z)
        if (est["cov"] <= s["target_cov"]
                or n_valid + ev.n_invalid >= s["max_samples"] or m <= 0):
            break
    return _report(ev, s, seed, confidence, est, found, form_runs, t0)


def _estimate(c: np.ndarray, z: float) -> dict[str, float]:
    n = c.size
    pf = float(c.mean()) if n else math.nan
    se = float(c.std(ddof=1) / math.sqrt(n)) if n > 1 else math.inf
    fail = c[c > 0]
    ess = float(fail.sum() ** 2 / np.sum(fail**2)) if fail.size else 0.0
    share = float(fail.max() / fail.sum()) if fail.size else math.nan
    return {"pf": pf, "se": se, "cov": se / pf if pf > 0 else math.inf, "n": n,
            "n_fail": int(fail.size), "ess": ess, "max_share": share,
            "lower": max(pf - z * se, 0.0), "upper": pf + z * se}


def _report(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float,
            est: dict[str, float], found: list[dict[str, Any]], form_runs: int, t0: float
            ) -> xr.Dataset:
    status, message, bound = 0, "", False
    pf, lower, upper = est["pf"], est["lower"], est["upper"]
    if est["n_fail"] == 0:
        status, bound = 4, True
        pf = lower = math.nan
        upper = 3.0 / est["n"]
        message = ("no importance sample failed: the design point(s) do not lead into the "
                   "failure domain; pf_upper is a rough bound only")
    elif est["max_share"] > 0.5 or est["ess"] < 10:
        status = 3
        message = (f"weights degenerate: one sample carries {est['max_share']:.0%} of the "
                   f"estimate, effective sample size {est['ess']:.1f} of {est['n_fail']} failing "
                   "samples; the interval is not trustworthy (a failure region the design "
                   "points miss, or too narrow a density)")
    elif est["cov"] > s["target_cov"]:
        status = 1
        message = f"max_samples reached with CoV {est['cov']:.3f} > target {s['target_cov']}"
    extra = {
        "n_failures": ((), np.int64(est["n_fail"]), {"units": "1", "long_name":
                       "failing importance samples"}),
        "effective_sample_size": ((), est["ess"], {"units": "1", "long_name":
                                  "(sum w)^2 / sum w^2 over failing samples"}),
        "max_weight_share": ((), est["max_share"], {"units": "1", "long_name":
                             "largest share of one sample in the pf estimate"}),
        "n_form_runs": ((), np.int64(form_runs), {"units": "1", "long_name":
                        "model runs of the FORM search (included in n_model_runs)"}),
    }
    return failure_report(
        ev, "importance", pf=pf, pf_lower=lower, pf_upper=upper, cov=est["cov"],
        interval_kind="normal approximation pf +- z se of the importance-sampling estimator",
        confidence=confidence, settings=s, seed=seed, wall_time=time.perf_counter() - t0,
        status=status, message=message, pf_is_upper_bound=bound, design_points=found,
        extra=extra)
