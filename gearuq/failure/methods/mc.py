"""Crude Monte Carlo, Latin hypercube and QMC, optionally as independent randomised replicates.

One replicate gives the binomial (Clopper-Pearson) interval of ``k`` failures in ``n``
samples: coverage at least the stated level for i.i.d. samples at any count (the Wilson
interval undercovers at a few failures), conservative for LHS (Owen 1997), not guaranteed for QMC
(use ``replicates >= 2``: a Student-t interval over the replicates' estimates, valid for any
randomised design).

Invalid runs are neither safe nor failed: ``pf`` counts them as safe (``k / n_all``) and the
interval runs from the lower end of that reading to the upper end of the reading that counts
them as failed (``(k + n_invalid) / n_all``), with status ``invalid_samples``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np
import xarray as xr
from scipy import special, stats

from gearuq.failure.evaluator import LimitStateEvaluator
from gearuq.failure.intervals import binomial_interval
from gearuq.failure.report import Reason, failure_report
from gearuq.model import Option

__all__ = ["SETTINGS", "run"]

SETTINGS = (
    Option("n_samples", 10_000, "samples per replicate", lower=1),
    Option("rule", "random", "sampling rule", choices=("random", "lhs", "sobol", "halton")),
    Option("replicates", 1, "independent randomised designs; >= 2 gives a Student-t interval "
           "valid for LHS and QMC designs", lower=1),
    Option("batch_size", 20_000, "largest design evaluated at once (random rule; bounds the "
           "memory of time-dependent outputs)", lower=1),
)


def run(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float
        ) -> xr.Dataset:
    """Crude Monte Carlo (or LHS / QMC), with randomised replicates when asked."""
    t0 = time.perf_counter()
    counts = []  # per replicate: failures, invalid, all samples, failures on the half grid
    for r in range(s["replicates"]):
        k = n_inv = n_all = k_half = 0
        for b, u in enumerate(_designs(ev, s, seed, r)):
            res = ev.evaluate(u, f"mc/rep{r}/batch{b}")
            ok = res["status"] == 0
            k += int(np.sum(res["g"][ok] <= 0.0))
            k_half += int(np.sum(res["g_half"][ok] <= 0.0))
            n_inv += int((~ok).sum())
            n_all += u.shape[0]
        counts.append((k, n_inv, n_all, k_half))
    k_tot, inv_tot, n_tot, half_tot = (sum(c[i] for c in counts) for i in range(4))
    reasons: list[Reason] = []
    status, bound = 0, False
    if inv_tot == n_tot:
        return failure_report(ev, "mc", pf=math.nan, interval_kind="none",
                              confidence=confidence, settings=s, seed=seed,
                              wall_time=time.perf_counter() - t0)
    pf = k_tot / n_tot
    if s["replicates"] == 1 or k_tot + inv_tot == 0:
        # Clopper-Pearson: exact coverage at any count; the Wilson interval undercovers at
        # a few failures (1e5 samples at Pf 3.4e-6 and 5.2e-6: 4 of 5 and 5 of 8 held)
        lo = float(binomial_interval(k_tot, n_tot, confidence, "clopper-pearson")[0])
        up = float(binomial_interval(k_tot + inv_tot, n_tot, confidence, "clopper-pearson")[1])
        cov = math.sqrt((1 - pf) / (n_tot * pf)) if pf > 0 else math.inf
        kind = ("binomial (Clopper-Pearson) on all samples: "
                + ("valid (i.i.d.)" if s["rule"] == "random" else
                   "conservative for LHS (Owen 1997)" if s["rule"] == "lhs" else
                   "not guaranteed for QMC; use replicates >= 2"))
        if k_tot + inv_tot == 0:
            pf, bound, status = up, True, 4
    else:
        p_safe = np.array([k / n for k, _, n, _ in counts])
        p_fail = np.array([(k + i) / n for k, i, n, _ in counts])
        pf = float(p_safe.mean())
        q = stats.t.isf((1 - confidence) / 2, p_safe.size - 1)
        se = float(p_safe.std(ddof=1) / math.sqrt(p_safe.size))
        se_fail = float(p_fail.std(ddof=1) / math.sqrt(p_fail.size))
        lo, up = max(pf - q * se, 0.0), float(p_fail.mean()) + q * se_fail
        cov = se / pf if pf > 0 else math.inf
        kind = (f"Student-t over {p_safe.size} independent randomised replicates "
                f"(rule={s['rule']!r}); valid for any design")
    if inv_tot:
        reasons.append((6, f"{inv_tot} of {n_tot} samples were invalid (see attrs errors): pf "
                        f"counts them as safe; read as failed pf would be "
                        f"{(k_tot + inv_tot) / n_tot:.4g}; the interval covers both"))
    msg = ("no failure observed: pf is the upper end of the interval, not an estimate"
           if bound else "")
    gap = (k_tot - half_tot) / n_tot if ev.time_dependent else math.nan
    return failure_report(ev, "mc", pf=pf, pf_lower=lo, pf_upper=up, cov=cov,
                          interval_kind=kind, confidence=confidence, settings=s, seed=seed,
                          wall_time=time.perf_counter() - t0, status=status, message=msg,
                          reasons=reasons, grid_gap=gap, pf_is_upper_bound=bound,
                          extra={"n_failures": ((), np.int64(k_tot), {
                              "units": "1", "long_name": "failed valid samples"})})


def _designs(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, r: int
             ) -> Iterator[np.ndarray]:
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
