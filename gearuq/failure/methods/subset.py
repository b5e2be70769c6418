"""Subset simulation (Au and Beck 2001): modified Metropolis or adaptive conditional sampling.

The failure probability is a product of conditional probabilities of nested events
``F_1 > F_2 > ... > F_m = F`` with ``F_i = {G <= b_i}``:

1. level 0: ``N`` independent standard normal samples; the threshold ``b_1`` is the
   ``p0``-quantile of ``G`` (the ``N p0``-th smallest value);
2. the ``N p0`` samples below the threshold seed Markov chains of length ``1/p0`` that stay in
   ``F_i``. ``mcmc="mma"`` (default), modified Metropolis: each component of a candidate is
   accepted with probability ``min(1, phi(xi_j)/phi(u_j))`` under a normal proposal of width
   ``proposal_std``. ``mcmc="acs"``, adaptive conditional sampling (Papaioannou et al.
   2015): the candidate ``rho u + sqrt(1 - rho^2) xi`` keeps the standard normal invariant,
   its width adapted to an acceptance of 0.44 (see :class:`_Sampler`). Either way the
   candidate is kept if ``G <= b_i``, else the chain repeats its state;
3. repeat until the threshold reaches 0; then ``pf = prod p_i * P(G <= 0 | F_{m-1})``.

Each conditional probability is the fraction of the level's samples below the next threshold,
so ties (flat or discontinuous responses) are counted, not forced to ``p0``. A candidate whose
components were all rejected is not run (it is the current state).

An invalid model run (nonzero status, NaN or inf) is neither safe nor failed. While exploring,
subset simulation reads it as failed (``g = -inf``), so the chains can enter a failure region
where the model gives no answer instead of stopping at its edge; the last level's failing
samples then tell which share of them is valid. The report's ``pf`` counts only the valid ones
(as crude Monte Carlo does), the interval runs from that reading's lower end to the upper end
of the reading that counts the invalid runs as failed, and the status says so. A **censored**
run (a status the limit state names in ``censored_statuses``: its ``g`` an upper bound of
the true value) is read at that bound instead; a bound at or below 0 is a valid failure, and
the levels count how often they refused such a run on its bound (``level_censored_left_out``).
The last level's such samples (read safe on a bound above 0) are counted as failed by the
interval's upper end; at an earlier level a refusal may leave pf low, which status 6 says in
words.

The coefficient of variation follows Au and Beck: ``delta_i^2 = (1 - p_i)/(N p_i) (1 +
gamma_i)`` with ``gamma_i = 2 sum_k (1 - k/N_s) rho_i(k)`` from the correlation of the failure
indicator along the chains; the level estimates are taken uncorrelated, ``delta^2 = sum
delta_i^2`` (``cov_pf``; the fully correlated bound ``sum delta_i`` is ``cov_pf_upper``). The
interval is lognormal with the larger of the two, ``pf exp(-+ z s)``, ``s^2 = ln(1 +
delta^2)``.

A walk whose last level's failing samples descend from fewer than
:data:`SECOND_WALK_LINEAGES` of its level-1 chains cannot measure its own scatter (the
lineage bootstrap then rests on a handful of lineages), and a walk trapped in one part of the
failure domain cannot see the part it never visited. With ``second_walk="auto"`` (default)
such a walk is checked by a second, independent one: the report gives their mean and the hull
of their intervals, and status 1 unless both pass the lineage check and agree within their
reported spreads (:func:`second_walk_reason`). A walk with enough lineages is reported alone,
bit for bit as before.

With a **gate** (``gate=``: a callable ``u -> bool`` per row, an event of the inputs known
without the model, such as inspection's acceptance of a gear pair) the walk samples the law
given the gate: level 0 draws standard normal rows until ``N`` pass it (rejection, cheap), and
a chain's candidate outside it is rejected without a model run (the target ``phi 1_gate
1_{G <= b}`` is left invariant by either sampler's proposal, reversible under ``phi``). The
report's ``pf`` is then ``P(G <= 0 | gate)``; a parallel system ``F and gate`` would instead
spend its runs on points the gate rejects while its thresholds are above 0.

For a time-dependent limit state the engine sees ``min_t g(t)``: the limit state of the running
maximum of the response over the output instants, i.e. first passage.

Every batch of candidates is one deterministic design given the seed and the previous batches
(random numbers from ``SeedSequence([seed, level, step])``), so with a store the run resumes
where it stopped.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from gearuq.failure.evaluator import LimitStateEvaluator
from gearuq.failure.report import failure_report
from gearuq.model import Option

__all__ = ["SETTINGS", "run_subset", "simulate", "Walk", "chain_correlation_factor",
           "level_cov", "lineage_spread", "mixing_reason", "MIXING_ZERO_SHARE",
           "SECOND_WALK_LINEAGES", "second_walk_reason"]


def _check_gate(value: Any) -> Any:
    if value is not None and not callable(value):
        raise ValueError(f"gate must be None or a callable u -> bool per row of standard "
                         f"normal points, got {value!r}")
    return value


#: Standard normal rows drawn for level 0 per sample kept, at most, before a gate that
#: passes too few of them is refused (a gate passing under 1e-3 of the law needs its own
#: sampler).
GATE_DRAWS_PER_SAMPLE = 1000


def _check_p0(value: Any) -> float:
    p0 = float(value)
    if not 0.0 < p0 <= 0.5:
        raise ValueError(f"p0 must lie in (0, 0.5] (conditional probability per level), got "
                         f"{value!r}")
    return p0


SETTINGS = (
    Option("n_per_level", 1000, "samples per level N (N p0 chains of length 1/p0)", lower=2),
    Option("p0", 0.1, "conditional probability per level, in (0, 0.5]", kind="any",
           check=_check_p0),
    Option("mcmc", "mma", "Markov chain sampler: 'mma' modified Metropolis (Au and Beck "
           "2001) or 'acs' adaptive conditional sampling (Papaioannou et al. 2015)",
           choices=("mma", "acs")),
    Option("proposal_std", 1.0, "width of the component-wise normal proposal of 'mma'",
           lower=1e-3, upper=10.0),
    Option("max_levels", 25, "largest number of conditional levels", lower=1),
    Option("second_walk", "auto", "a second, independent walk checks the first: 'auto' "
           "when the first walk's failures descend from fewer than SECOND_WALK_LINEAGES of "
           "its level-1 chains (its own spread is then not measurable), 'always' or 'never'",
           choices=("auto", "always", "never")),
    Option("gate", None, "an event of the inputs known without the model: a callable u -> "
           "bool per row of standard normal points (n, d); the walk samples the law given it, "
           "a point outside costs no run, and pf is P(G <= 0 | gate) (None: no gate)",
           kind="any", allow_none=True, check=_check_gate),
    Option("replicates", 1, "independent runs pooled: the mean of their estimates with a "
           "log-t interval from their scatter (measured, not modelled by the Au-Beck CoV)",
           lower=1, upper=1000),
)


def chain_correlation_factor(indicator: np.ndarray) -> float:
    """``gamma = 2 sum_{k=1}^{Ns-1} (1 - k/Ns) rho(k)`` of Au and Beck (2001).

    Parameters
    ----------
    indicator : ndarray of bool, shape (n_chains, n_states)
        Failure indicator (next threshold) along each chain, seed first.
    """
    i = np.asarray(indicator, dtype=float)
    n_chains, n_states = i.shape
    n = i.size
    p = i.mean()
    r0 = p * (1 - p)
    if r0 <= 0 or n_states < 2:
        return 0.0
    gamma = 0.0
    for k in range(1, n_states):
        rk = np.sum(i[:, :-k] * i[:, k:]) / (n - k * n_chains) - p * p
        gamma += 2.0 * (1.0 - k / n_states) * rk / r0
    return float(max(gamma, 0.0))


def level_cov(p: float, n: int, gamma: float) -> float:
    """``sqrt((1 - p)/(n p) (1 + gamma))``."""
    return math.sqrt((1 - p) / (n * p) * (1 + gamma)) if p > 0 else math.inf


def lineage_spread(lineage: list[tuple[np.ndarray, np.ndarray]], n_boot: int = 2000,
                   seed: int = 0) -> dict[str, float]:
    """Scatter of ``ln prod_{i >= 1} p_i`` measured by resampling the level-1 chains.

    Every sample of level 1 and deeper descends from one of the ``N p0`` chains started at
    level 1 (its lineage). When the chains mix, every lineage contributes to every level
    alike and resampling lineages changes little; when they do not, a few lineages carry the
    deep levels and resampling them moves the estimate by decades. Each bootstrap draw takes
    lineages with replacement (multinomial weights) and recomputes each level's conditional
    probability as the weighted share of its samples below the next threshold, so the
    correlation within chains and across levels that the Au-Beck CoV leaves out is in it.

    Parameters
    ----------
    lineage : list of (root, below)
        Per level from 1 on (:attr:`Walk.lineage`).

    Returns
    -------
    dict
        ``s``: standard deviation of ``ln prod p_i*`` over the draws that keep a failure
        (inf if fewer than 10 do); ``zero_share``: share of draws without any failure at some
        level; ``n_eff``: effective number of lineages among the last level's failing samples
        (``(sum f_r)^2 / sum f_r^2``); ``n_lineages``: chains started at level 1.
    """
    if not lineage:
        return {"s": 0.0, "zero_share": 0.0, "n_eff": math.nan, "n_lineages": 0}
    n_roots = int(max(int(r.max()) for r, _ in lineage)) + 1
    counts = np.array([np.bincount(r, minlength=n_roots) for r, _ in lineage], dtype=float)
    hits = np.array([np.bincount(r, weights=b.astype(float), minlength=n_roots)
                     for r, b in lineage])
    rng = np.random.default_rng(np.random.SeedSequence([seed, 31]))
    w = rng.multinomial(n_roots, np.full(n_roots, 1.0 / n_roots), size=n_boot).astype(float)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = (w @ hits.T) / (w @ counts.T)  # (draws, levels)
        log_p = np.where(p > 0, np.log(np.where(p > 0, p, 1.0)), -np.inf).sum(axis=1)
    finite = log_p[np.isfinite(log_p)]
    last = hits[-1]
    n_eff = float(last.sum() ** 2 / np.sum(last**2)) if last.sum() > 0 else 0.0
    return {"s": float(finite.std(ddof=1)) if finite.size >= 10 else math.inf,
            "zero_share": float(1.0 - finite.size / n_boot), "n_eff": n_eff,
            "n_lineages": n_roots}


def _inside(gate: Any, cand: np.ndarray) -> np.ndarray:
    """The gate's verdict on each row (all pass without a gate)."""
    if gate is None:
        return np.ones(cand.shape[0], dtype=bool)
    inside = np.asarray(gate(cand), dtype=bool).reshape(-1)
    if inside.shape != (cand.shape[0],):
        raise ValueError(f"gate: returned {inside.size} verdicts for {cand.shape[0]} points; "
                         "it must give one bool per row")
    return inside


def _explored(res: Mapping[str, np.ndarray]) -> np.ndarray:
    """``g`` as the walk reads it while exploring: a valid run's value, a censored run's bound
    (the run is at least as close to failure as that), ``-inf`` for any other invalid run
    (read as failed)."""
    g = np.where(res["status"] == 0, res["g"], -np.inf)
    bound = res.get("g_bound")
    return g if bound is None else np.where(np.isfinite(bound), bound, g)


def _censored_left_out(res: Mapping[str, np.ndarray], g_read: np.ndarray, b: float) -> int:
    """Censored runs that a level refused on their bound (``> b``): their true ``g`` may
    have been inside it."""
    bound = res.get("g_bound")
    return 0 if bound is None else int(np.sum(np.isfinite(bound) & (g_read > b)))


def _mcmc_step(ev: LimitStateEvaluator, u: np.ndarray, g: np.ndarray, b: float, sigma: float,
               rng: np.random.Generator, tag: str, gate: Any = None
               ) -> tuple[np.ndarray, np.ndarray, int, int, int]:
    """One modified-Metropolis step of every chain: new states, values, accepted, invalid,
    censored candidates refused on their bound.

    A candidate outside the ``gate`` is rejected without a run."""
    xi = u + sigma * rng.standard_normal(u.shape)
    ratio = np.exp(-0.5 * (xi * xi - u * u))
    keep = rng.random(u.shape) < np.minimum(1.0, ratio)
    cand = np.where(keep, xi, u)
    moved = keep.any(axis=1)
    if gate is not None and moved.any():
        moved[moved] = _inside(gate, cand[moved])
    u_new, g_new = u.copy(), g.copy()
    accepted, invalid, left_out = 0, 0, 0
    if moved.any():
        res = ev.evaluate(cand[moved], tag)
        g_c = _explored(res)
        ok = g_c <= b
        idx = np.flatnonzero(moved)[ok]
        u_new[idx] = cand[idx]
        g_new[idx] = g_c[ok]
        accepted = int(ok.sum())
        invalid = int(np.sum(res["status"] != 0))
        left_out = _censored_left_out(res, g_c, b)
    return u_new, g_new, accepted, invalid, left_out


def _acs_step(ev: LimitStateEvaluator, u: np.ndarray, g: np.ndarray, b: float,
              sigma: np.ndarray, rng: np.random.Generator, tag: str, gate: Any = None
              ) -> tuple[np.ndarray, np.ndarray, int, int, int]:
    """One conditional-sampling step of every chain (Papaioannou et al. 2015, Alg. 2).

    The candidate ``rho u + sqrt(1 - rho^2) xi`` leaves the standard normal invariant, so it
    is kept whenever it stays inside ``G <= b`` (and the ``gate``: outside it no run is made);
    there is no component-wise rejection.
    """
    rho = np.sqrt(1.0 - sigma**2)
    cand = rho * u + sigma * rng.standard_normal(u.shape)
    inside = _inside(gate, cand)
    u_new, g_new = u.copy(), g.copy()
    if not inside.any():
        return u_new, g_new, 0, 0, 0
    res = ev.evaluate(cand[inside], tag)
    g_c = _explored(res)
    ok = g_c <= b
    idx = np.flatnonzero(inside)[ok]
    u_new[idx] = cand[idx]
    g_new[idx] = g_c[ok]
    return (u_new, g_new, int(ok.sum()), int(np.sum(res["status"] != 0)),
            _censored_left_out(res, g_c, b))


def _threshold(g: np.ndarray, n_seeds: int) -> float:
    """The ``n_seeds``-th smallest value (invalid runs, ``-inf``, sort first)."""
    return float(np.sort(g)[n_seeds - 1])


def run_subset(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float
               ) -> xr.Dataset:
    """Subset simulation; see the module docstring."""
    t0 = time.perf_counter()
    if s["replicates"] > 1:
        return _run_replicates(ev, s, seed, confidence, t0)
    walk = simulate(ev, s, seed)
    if walk.levels is None:
        return _no_valid_level0(ev, s, seed, confidence, t0, walk.message)
    why = second_walk_reason(walk.lineage, s["second_walk"], seed)
    if not why:
        return _with_failure_mean(_report(ev, s, seed, confidence, walk.levels, walk.status,
                                          walk.message, t0, walk.lineage), ev, [walk])
    second_seed = _replicate_seed(seed, 1)
    second = simulate(ev, s, second_seed, tag="subset/rep1")
    if second.levels is None:
        return _no_valid_level0(ev, s, seed, confidence, t0, f"second walk: {second.message}")
    return _with_failure_mean(_report_pair(ev, s, seed, confidence, t0, (walk, second),
                                           (seed, second_seed), why), ev, [walk, second])


def _with_failure_mean(rep: xr.Dataset, ev: LimitStateEvaluator, walks: list[Walk]
                       ) -> xr.Dataset:
    """``failure_mean_u``: the mean of the walks' failing samples in the standard normal
    space, valid ones and censored ones whose bound is at or below 0 (failures whatever their
    true value; the important direction line sampling can start from; absent when none
    failed)."""
    failing = np.concatenate([w.u[np.isfinite(w.g) & (w.g <= 0.0)] for w in walks])
    if failing.shape[0] == 0:
        return rep
    return rep.assign(failure_mean_u=xr.DataArray(
        failing.mean(axis=0), dims="parameter", coords={"parameter": list(ev.names)},
        attrs={"units": "1", "long_name": f"mean of the {failing.shape[0]} failing samples "
               "of the last level (valid, or censored with a bound at or below 0) in the "
               "standard normal space"}))


def _no_valid_level0(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int,
                     confidence: float, t0: float, message: str) -> xr.Dataset:
    return failure_report(ev, "subset", pf=math.nan, interval_kind="none",
                          confidence=confidence, settings=s, seed=seed,
                          wall_time=time.perf_counter() - t0, status=2, message=message)


@dataclass
class Walk:
    """What one subset-simulation run found.

    Attributes
    ----------
    levels : list of dict or None
        Per level: threshold, conditional probability, chain correlation, CoV, counts
        (None when level 0 had no valid run).
    u, g : ndarray
        The last level's samples (standard normal space) and limit-state values (``-inf``
        for an invalid run).
    status : int
    message : str
    lineage : list of (ndarray, ndarray)
        Per level from 1 on: the chain of level 1 each sample descends from, and whether it
        lies below the next threshold (for :func:`lineage_spread`).
    """

    levels: list[dict[str, Any]] | None
    u: np.ndarray
    g: np.ndarray
    status: int = 0
    message: str = ""
    lineage: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)

    @property
    def pf(self) -> float:
        """Product of the levels' conditional probabilities."""
        return float(np.prod([lv["p"] for lv in self.levels])) if self.levels else math.nan

    def failing(self) -> np.ndarray:
        """The last level's samples that fail (``g <= 0``), valid or not."""
        return self.u[self.g <= 0.0]


def simulate(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, tag: str = "subset"
             ) -> Walk:
    """Run the levels of subset simulation; return the levels and the last level's samples.

    Also the explorer of multi-fidelity importance sampling, which fits its density to the
    last level's failing samples of a cheap model.
    """
    n, p0 = s["n_per_level"], s["p0"]
    gate = s.get("gate")
    if gate is not None and s["mcmc"] != "mma":
        # measured on a wedge (g = 3.5 - u1 behind u1 - u2 <= 1.5, 100 seeds of 500 a level):
        # aCS behind the gate held the reference in 82, its estimates' mean 0.63 of it, where
        # modified Metropolis held it in 99 and aCS on the parallel system in 60 of 60
        raise ValueError(f"gate: mcmc={s['mcmc']!r} is not supported behind a gate (its chains "
                         "under-cover there: 82 of 100 intervals held a wedge's reference); "
                         "valid: mcmc='mma', or the gate as a component of a ParallelSystem")
    sampler = _Sampler(s["mcmc"], s["proposal_std"], gate)
    n_seeds = max(1, int(round(n * p0)))
    n_states = int(math.ceil(n / n_seeds))
    rng0 = np.random.default_rng(np.random.SeedSequence([seed, 0]))
    # the gate's refusals first: a refused gate costs no run of the calibration below
    u = _level0_draws(rng0, n, ev.dim, gate)
    # a system: its components' g divided by their gradients at the origin, so that the
    # level thresholds follow every component alike whatever its units (failure set unchanged)
    ev.calibrate_scales()
    res = ev.evaluate(u, f"{tag}/level0")
    # an invalid run is read as failed while exploring (g = -inf): the chains then enter where
    # the model fails, and the last level tells which share of the failing samples is valid;
    # a censored run is read at its bound (_explored)
    g = _explored(res)
    if not np.any(res["status"] == 0):
        return Walk(None, u, g, 2, f"no one of the {n} model runs of level 0 was valid "
                    "(each failed or was censored): subset simulation has no level to start")
    chains = None  # (n_seeds, n_states) indices of the level's samples, for gamma
    levels: list[dict[str, Any]] = []
    lineage: list[tuple[np.ndarray, np.ndarray]] = []
    root = None  # the level-1 chain each sample descends from (None at level 0)
    status, message = 0, ""
    for level in range(s["max_levels"] + 1):
        b = _threshold(g, n_seeds)
        final = b <= 0.0
        b_next = 0.0 if final else b
        below = g <= b_next
        if root is not None:
            lineage.append((root, below))
        p_level = float(below.mean())
        gamma = 0.0 if chains is None else chain_correlation_factor(below[chains])
        censored = ev.is_censored(u)
        levels.append({"threshold": b_next, "p": p_level, "gamma": gamma,
                       "cov": level_cov(p_level, n, gamma), "n": int(g.size),
                       "invalid": int(np.sum(np.isneginf(g))),
                       "valid_share": float(np.mean(np.isfinite(g[below]))) if below.any()
                       else 1.0,
                       # censored samples above the threshold: their true g may be below it
                       "censored_left_out": int(np.sum(censored & ~below))})
        if final or p_level == 0.0:
            break
        if level == s["max_levels"]:
            status = 1
            message = (f"max_levels={s['max_levels']} reached at threshold {b:.4g} > 0; pf is "
                       "an upper bound (the product of the levels so far)")
            break
        order = np.argsort(g, kind="stable")[:n_seeds]
        seed_root = np.arange(n_seeds) if root is None else root[order]
        refused_before = sampler.censored_left_out
        u, g, chains, acc = _grow_chains(ev, u[order], g[order], b, sampler, n_states, n,
                                         seed, level + 1, tag)
        levels[-1]["censored_left_out"] += sampler.censored_left_out - refused_before
        root = seed_root[np.arange(u.shape[0]) // n_states]  # flat samples: chain-major
        levels[-1]["acceptance"] = acc[0] / max(acc[2], 1)
        levels[-1]["accepted"], levels[-1]["invalid_candidates"] = acc[0], acc[1]
    return Walk(levels, u, g, status, message, lineage)


def _level0_draws(rng: np.random.Generator, n: int, dim: int, gate: Any) -> np.ndarray:
    """``n`` standard normal rows; with a ``gate``, the first ``n`` that pass it (drawn in
    batches of ``n``; at most :data:`GATE_DRAWS_PER_SAMPLE` ``n`` rows are tried)."""
    if gate is None:
        return rng.standard_normal((n, dim))
    kept: list[np.ndarray] = []
    count, drawn = 0, 0
    while count < n:
        if drawn >= GATE_DRAWS_PER_SAMPLE * n:
            raise ValueError(f"gate: passed {count} of {drawn} standard normal draws, fewer "
                             f"than the {n} samples of level 0 (it must pass at least about "
                             f"1/{GATE_DRAWS_PER_SAMPLE} of the law)")
        batch = rng.standard_normal((n, dim))
        batch = batch[_inside(gate, batch)]
        kept.append(batch)
        count += batch.shape[0]
        drawn += n
    return np.concatenate(kept)[:n]


class _Sampler:
    """The chain sampler and its adapted scale (``lambda`` of aCS, kept from level to level).

    aCS adapts after every lockstep batch of chains (a batch of ``N p0`` candidates, where
    the paper adapts after each group of ``p_a N p0`` chains run one after another): ``ln
    lambda += (a - 0.44)/sqrt(i)`` with ``a`` the batch's acceptance rate and ``i`` the batch
    count of the level; ``sigma_j = min(1, lambda s_j)`` with ``s_j`` the spread of the
    level's seeds in component ``j``.
    """

    TARGET_ACCEPTANCE = 0.44

    def __init__(self, kind: str, proposal_std: float, gate: Any = None) -> None:
        self.kind = kind
        self.proposal_std = proposal_std
        self.gate = gate
        self.scale = 0.6  # initial lambda of Papaioannou et al.
        self.censored_left_out = 0  # censored candidates refused on their bound

    def grow(self, ev: LimitStateEvaluator, u: np.ndarray, g: np.ndarray, b: float,
             rng: np.random.Generator, tag: str, seeds_spread: np.ndarray, batch: int
             ) -> tuple[np.ndarray, np.ndarray, int, int]:
        if self.kind == "mma":
            u_new, g_new, accepted, invalid, left_out = _mcmc_step(
                ev, u, g, b, self.proposal_std, rng, tag, self.gate)
            self.censored_left_out += left_out
            return u_new, g_new, accepted, invalid
        sigma = np.minimum(1.0, self.scale * seeds_spread)
        u_new, g_new, accepted, invalid, left_out = _acs_step(ev, u, g, b, sigma, rng, tag,
                                                              self.gate)
        self.censored_left_out += left_out
        rate = accepted / max(u.shape[0], 1)
        self.scale *= math.exp((rate - self.TARGET_ACCEPTANCE) / math.sqrt(batch))
        return u_new, g_new, accepted, invalid


def _grow_chains(ev: LimitStateEvaluator, seeds_u: np.ndarray, seeds_g: np.ndarray, b: float,
                 sampler: _Sampler, n_states: int, n: int, seed: int, level: int,
                 prefix: str = "subset"
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[int, int, int]]:
    """Grow ``len(seeds)`` chains of ``n_states`` states (seed included) inside ``G <= b``.

    The chains advance in lockstep, one batch (one design) per step.
    """
    n_chains = seeds_u.shape[0]
    spread = seeds_u.std(axis=0, ddof=1) if n_chains > 1 else np.ones(seeds_u.shape[1])
    spread = np.where(spread > 0, spread, 1.0)
    states_u = [seeds_u]
    states_g = [seeds_g]
    accepted, tried, invalid = 0, 0, 0
    for step in range(1, n_states):
        rng = np.random.default_rng(np.random.SeedSequence([seed, level, step]))
        tag = f"{prefix}/level{level}/step{step}"
        u_new, g_new, acc, inv = sampler.grow(ev, states_u[-1], states_g[-1], b, rng, tag,
                                              spread, step)
        states_u.append(u_new)
        states_g.append(g_new)
        accepted += acc
        invalid += inv
        tried += n_chains
    u_all = np.stack(states_u, axis=1)  # (chains, states, d)
    g_all = np.stack(states_g, axis=1)
    flat_u = u_all.reshape(-1, u_all.shape[2])[:n]
    flat_g = g_all.reshape(-1)[:n]
    index = np.arange(n_chains * n_states).reshape(n_chains, n_states)
    chains = index if n_chains * n_states == n else index[:, : n // n_chains]
    return flat_u, flat_g, chains, (accepted, invalid, tried)


#: Share of the lineage-bootstrap draws without a failure above which a run says its chains
#: did not mix (status 1): on problems whose chains mix it stayed at or below 0.021 in 20
#: seeds (g = 4.5 - x1), on the helical pair's deep level it reached 0.1-0.4 (docs).
MIXING_ZERO_SHARE = 0.05


def mixing_reason(spread: Mapping[str, float]) -> list[tuple[int, str]]:
    """Status 1 in words when resampling the level-1 chains often leaves no failure."""
    if not spread.get("zero_share", 0.0) > MIXING_ZERO_SHARE:
        return []
    return [(1, f"the chains did not mix: the last level's failing samples descend from "
             f"about {spread['n_eff']:.1f} of the {spread['n_lineages']} chains started at "
             f"level 1, and resampling those chains leaves no failure in "
             f"{spread['zero_share']:.0%} of the draws, so this run's interval cannot be "
             "vouched for (runs of such responses scatter by several times their own "
             "interval); pool independent runs (replicates=K) or use another method")]


#: A walk whose last level's failing samples descend from fewer level-1 chains than this
#: (effective number, ``lineage_n_eff``) runs a second, independent walk (``second_walk=
#: "auto"``). The lineage bootstrap measures the walk's spread from the lineages that carry its
#: failures; a standard deviation from ``k`` independent units is understated by more than a
#: factor 2 with probability ``P(chi2_{k-1} < (k-1)/4)``, at most 5 % from ``k = 7`` on
#: (0.060 at 6, 0.041 at 7): below it, one walk cannot measure its own scatter (docs).
SECOND_WALK_LINEAGES = 7


def second_walk_reason(lineage: list[tuple[np.ndarray, np.ndarray]], mode: str = "auto",
                       seed: int = 0) -> str:
    """Why a second, independent walk must check this one (empty: no need).

    Parameters
    ----------
    lineage : list of (root, below)
        The first walk's lineages (:attr:`Walk.lineage`).
    mode : {"auto", "always", "never"}
        The ``second_walk`` setting.
    seed : int
        The first walk's seed (its lineage bootstrap).
    """
    if mode == "never" or (mode == "auto" and not lineage):
        return ""
    if mode == "always":
        return "second_walk='always'"
    n_eff = lineage_spread(lineage, seed=seed)["n_eff"]
    if n_eff >= SECOND_WALK_LINEAGES:
        return ""
    return (f"the first walk's failures descend from about {n_eff:.1f} of its level-1 chains "
            f"(fewer than {SECOND_WALK_LINEAGES}), too few to measure its own scatter")


def _censored_refusals(levels: list[dict[str, Any]]) -> int:
    """A walk's refusals of censored runs on their bound, all its levels summed."""
    return sum(int(lv.get("censored_left_out", 0)) for lv in levels)


def _censored_read_safe(levels: list[dict[str, Any]]) -> int:
    """The last level's censored samples read safe on a bound above 0 (none where the walk
    stopped above 0: its pf is then an upper bound already)."""
    last = levels[-1]
    return int(last.get("censored_left_out", 0)) if last["threshold"] == 0.0 else 0


def _censored_last_factor(levels: list[dict[str, Any]]) -> float:
    """What the :func:`_censored_read_safe` samples would multiply pf by were they all
    failures: ``(n_failing + n_left) / n_failing`` (1 without any, or without a failing
    sample, pf then 0). The upper end of the interval is scaled by it, so that it covers
    that reading too."""
    left = _censored_read_safe(levels)
    n_failing = levels[-1]["p"] * levels[-1]["n"]
    return (n_failing + left) / n_failing if left and n_failing > 0 else 1.0


def _censored_reasons(ev: LimitStateEvaluator, walks: list[list[dict[str, Any]]]
                      ) -> list[tuple[int, str]]:
    """Status 6 in words for censored runs (the limit state's ``censored_statuses``): read
    at their bound while exploring; say how many a level refused on that bound."""
    if not ev.n_censored:
        return []
    left = sum(_censored_refusals(levels) for levels in walks)
    text = (f"{ev.n_censored} model runs were censored (a status of the limit state's "
            "censored_statuses: g an upper bound of the true value) and were read at that "
            "bound while exploring; a bound at or below 0 counts as a failure")
    last = sum(_censored_read_safe(levels) for levels in walks)
    if last:
        text += (f"; {last} sample(s) of the last level were read safe on a bound above 0: "
                 "the interval's upper end counts them as failed")
    if left - last:
        text += (f"; {left - last} time(s) an earlier level refused such a run on its bound "
                 "(a chain's step, or a threshold) where its true value may have been inside: "
                 "pf may be low by their share, which the interval does not cover")
    if not left:
        text += ("; no level refused one on its bound, so every count of the walk is the one "
                 "the true values would give (the walk may differ from theirs where a bound "
                 "set a threshold or a seed's order: the same estimator, not a biased one)")
    return [(6, text)]


def _replicate_censored(walk_levels: list[list[dict[str, Any]]]) -> dict[str, tuple]:
    """``replicate_censored_left_out``: each walk's refusals of censored runs on their bound,
    all levels summed (pairs and replicates report the first walk's levels, or none)."""
    return {"replicate_censored_left_out": (("replicate",), np.array(
        [_censored_refusals(levels) for levels in walk_levels]), {
        "units": "1", "long_name": "censored runs each walk refused on their bound (a chain's "
        "step or a threshold), all its levels: their true value may have been inside"})}


def _report_pair(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float,
                 t0: float, walks: tuple[Walk, Walk], seeds: tuple[int, int], why: str
                 ) -> xr.Dataset:
    """Two independent walks: their mean, the hull of their intervals, status 1 unless both
    pass the lineage check and agree within their reported spreads.

    The hull holds pf whenever either walk's interval does, so its confidence is at least
    each walk's. Agreement: ``|ln pf_1 - ln pf_2| <= z sqrt(s_1^2 + s_2^2)`` with ``s_k`` the
    log half-width of walk ``k``'s interval over ``z`` (the two-sample test at the report's
    confidence); a walk without a failure agrees when its upper bound reaches the other's
    lower end.
    """
    z = stats.norm.isf((1 - confidence) / 2)
    names = ("first walk", "second walk")
    pfs, lows, ups, spreads, reasons = [], [], [], [], []
    for name, walk, walk_seed in zip(names, walks, seeds, strict=True):
        spread = lineage_spread(walk.lineage, seed=walk_seed)
        pf_k, low_k, up_k = _walk_interval(walk.levels, spread, confidence)
        share = walk.levels[-1]["valid_share"]  # invalid runs: the interval covers both
        pfs.append(pf_k * share)
        lows.append(low_k * share)
        ups.append(up_k * _censored_last_factor(walk.levels))
        spreads.append(spread)
        if walk.status:
            reasons.append((walk.status, f"{name}: {walk.message}"))
        if pf_k > 0:
            reasons.extend((code, f"{name}: {text}") for code, text in mixing_reason(spread))
    pf = 0.5 * (pfs[0] + pfs[1])
    lower, upper = min(lows), max(ups)
    if pfs[0] > 0 and pfs[1] > 0:
        s_k = [math.log(u / lo) / (2 * z) for lo, u in zip(lows, ups, strict=True)]
        gap, allowed = abs(math.log(pfs[0] / pfs[1])), z * math.hypot(*s_k)
        disagree = gap > allowed
        words = (f"|ln pf_1 - ln pf_2| = {gap:.2f} exceeds z sqrt(s_1^2 + s_2^2) = "
                 f"{allowed:.2f}")
    else:
        disagree = lows[0] > ups[1] or lows[1] > ups[0]
        words = "one walk saw no failure and its upper bound lies below the other's interval"
    if disagree:
        reasons.append((1, f"two independent walks disagree beyond their reported spreads: "
                        f"{pfs[0]:.3g} [{lows[0]:.3g}, {ups[0]:.3g}] and {pfs[1]:.3g} "
                        f"[{lows[1]:.3g}, {ups[1]:.3g}] ({words}): the chains did not explore "
                        "the failure domain alike and neither interval can be vouched for; "
                        "pool independent runs (replicates=K) or use another method"))
    bound = pf <= 0
    status, message = 0, ""
    if bound:
        pf, status = upper, 4
        message = "neither walk observed a failure: pf is the larger of their upper bounds"
    reasons.extend(_censored_reasons(ev, [w.levels for w in walks]))
    n_inv = ev.n_invalid - ev.n_censored
    if n_inv and not bound:
        reasons.append((6, f"{n_inv} model runs were invalid; each walk counts only "
                        "the valid failing samples of its last level; the interval covers the "
                        "reading that counts them as failed"))
    # the Au-Beck CoV of the mean of the two, as a single walk reports its own
    c_k = [_level_covs(w.levels)[0] for w in walks]
    cov = (math.hypot(pfs[0] * c_k[0], pfs[1] * c_k[1]) / (pfs[0] + pfs[1])
           if not bound else math.nan)
    extra = _walk_variables(walks[0].levels, spreads[0], of="first walk")
    rep = ("replicate",)
    extra.update({
        "replicate_pf": (rep, np.array(pfs), {"units": "1", "long_name":
                         "estimate of each independent walk"}),
        "replicate_pf_lower": (rep, np.array(lows), {"units": "1", "long_name":
                               "each walk's own lower end"}),
        "replicate_pf_upper": (rep, np.array(ups), {"units": "1", "long_name":
                               "each walk's own upper end"}),
        "replicate_levels": (rep, np.array([len(w.levels) for w in walks]), {
            "units": "1", "long_name": "levels of each walk"}),
        "replicate_lineage_n_eff": (rep, np.array([sp["n_eff"] for sp in spreads]), {
            "units": "1", "long_name": "effective number of level-1 chains each walk's "
            "failures descend from"}),
        **_replicate_censored([w.levels for w in walks]),
    })
    kind = (f"hull of two independent walks' intervals (each lognormal with the larger of the "
            f"Au-Beck and the lineage-bootstrap spread) about their mean; second walk because "
            f"{why}")
    return _finish(ev, s, seed, confidence, t0, (pf, lower, upper, cov), kind,
                   (status, message, reasons), bound, extra)


def _report(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float,
            levels: list[dict[str, Any]], status: int, message: str, t0: float,
            lineage: list[tuple[np.ndarray, np.ndarray]] | None = None) -> xr.Dataset:
    cov, _ = _level_covs(levels)
    bound = False
    spread = lineage_spread(lineage or [], seed=seed)
    pf, lower, upper = _walk_interval(levels, spread, confidence)
    upper *= _censored_last_factor(levels)  # 1 where no sample of the last level failed
    if pf <= 0:  # no sample of the last level failed: bound from the product of the others
        pf, bound, status = upper, True, 4
        message = message or "no sample of the last level failed: pf is an upper bound"
    extra = _walk_variables(levels, spread)
    kind = ("lognormal with the larger of the Au-Beck CoV (chain correlation included; the "
            "larger of the uncorrelated-level and fully-correlated-level values) and the "
            "scatter of ln pf measured by resampling the chains started at level 1")
    reasons = list(mixing_reason(spread)) if pf > 0 else []
    valid_share = levels[-1]["valid_share"]
    reasons.extend(_censored_reasons(ev, [levels]))
    n_inv = ev.n_invalid - ev.n_censored  # the censored ones were read at their bound
    if n_inv and pf > 0:
        pf_failed = pf
        pf, lower = pf * valid_share, lower * valid_share
        reasons.append((6, f"{n_inv} model runs were invalid; subset simulation read them as "
                        f"failed while exploring: with them pf would be {pf_failed:.4g}; pf "
                        f"counts only the valid failing samples of the last level "
                        f"({valid_share:.0%}); the interval covers both readings"))
    return _finish(ev, s, seed, confidence, t0, (pf, lower, upper, cov), kind,
                   (status, message, reasons), bound, extra)


def _finish(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float,
            t0: float, estimate: tuple[float, float, float, float], kind: str,
            outcome: tuple[int, str, list[tuple[int, str]]], bound: bool,
            extra: dict[str, tuple]) -> xr.Dataset:
    """The report of one walk or a pair: ``estimate`` is ``(pf, lower, upper, cov)``,
    ``outcome`` ``(status, message, reasons)``."""
    pf, lower, upper, cov = estimate
    status, message, reasons = outcome
    return failure_report(ev, "subset", pf=pf, pf_lower=lower, pf_upper=upper, cov=cov,
                          interval_kind=_given_gate(kind, s), confidence=confidence,
                          settings=s, seed=seed,
                          wall_time=time.perf_counter() - t0, status=status, message=message,
                          reasons=reasons, grid_gap=ev.grid_gap_fraction * pf
                          if ev.time_dependent else math.nan,
                          pf_is_upper_bound=bound, extra=extra)


def _given_gate(kind: str, s: Mapping[str, Any]) -> str:
    """The interval's description, saying so when pf is conditional on a gate."""
    if s.get("gate") is None:
        return kind
    return kind + "; pf, its interval and its levels are conditional on the gate: P(G <= 0 | gate)"


def _walk_interval(levels: list[dict[str, Any]], spread: Mapping[str, float],
                   confidence: float) -> tuple[float, float, float]:
    """One walk's ``(pf, lower, upper)``: lognormal with the larger of the Au-Beck spread and
    the measured one (level 0's own and the lineage bootstrap's); ``pf = 0`` when no sample
    of the last level failed, with ``upper`` the product of the other levels times the Wilson
    bound of the last."""
    p = np.array([lv["p"] for lv in levels])
    pf = float(np.prod(p))
    cov, cov_upper = _level_covs(levels)
    z = stats.norm.isf((1 - confidence) / 2)
    # measured: level 0 (independent draws) and the lineage bootstrap of the deeper levels
    s_measured = math.sqrt(math.log1p(levels[0]["cov"] ** 2) + spread["s"] ** 2)
    if pf > 0:
        lower, upper = _lognormal_interval(pf, max(cov, cov_upper), z)
        if math.isfinite(s_measured) and s_measured > math.sqrt(math.log1p(
                max(cov, cov_upper) ** 2)):
            lower, upper = pf * math.exp(-z * s_measured), pf * math.exp(z * s_measured)
        return pf, lower, upper
    from gearuq.failure.intervals import wilson_interval

    upper = float(np.prod(p[:-1]) * wilson_interval(0, levels[-1]["n"], confidence)[1])
    return 0.0, 0.0, upper


def _walk_variables(levels: list[dict[str, Any]], spread: Mapping[str, float],
                    of: str = "") -> dict[str, tuple]:
    """The report's per-level and lineage variables of one walk (``of``: which walk)."""
    dims = ("level",)
    p = np.array([lv["p"] for lv in levels])
    covs = np.array([lv["cov"] for lv in levels])
    _, cov_upper = _level_covs(levels)
    extra = {
        "level_threshold": (dims, np.array([lv["threshold"] for lv in levels]), {
            "units": "1", "long_name": "intermediate threshold b_i of the limit state"}),
        "level_probability": (dims, p, {"units": "1", "long_name":
                              "conditional probability P(G <= b_i | previous level)"}),
        "level_gamma": (dims, np.array([lv["gamma"] for lv in levels]), {
            "units": "1", "long_name": "chain correlation factor gamma_i (Au and Beck)"}),
        "level_cov": (dims, covs, {"units": "1", "long_name": "CoV of each level estimate"}),
        "level_censored_left_out": (dims, np.array([lv.get("censored_left_out", 0)
                                                     for lv in levels]), {
            "units": "1", "long_name": "censored runs this level refused on their bound (a "
            "chain's step or the next threshold): their true value may have been inside"}),
        "level_acceptance": (dims, np.array([lv.get("acceptance", math.nan) for lv in levels]),
                             {"units": "1", "long_name":
                              "acceptance rate of the chains grown from this level"}),
        "cov_pf_upper": ((), cov_upper, {"units": "1", "long_name":
                         "CoV bound for fully correlated levels, sum of level CoVs"}),
        "lineage_log_spread": ((), spread["s"], {"units": "1", "long_name": (
            "standard deviation of ln pf measured by resampling the chains started at level 1 "
            "(lineage bootstrap, with level 0's own)")}),
        "lineage_zero_share": ((), spread["zero_share"], {"units": "1", "long_name": (
            "share of lineage-bootstrap draws without any failure (above "
            f"{MIXING_ZERO_SHARE}: the chains did not mix, status 1)")}),
        "lineage_n_eff": ((), spread["n_eff"], {"units": "1", "long_name": (
            "effective number of level-1 chains the last level's failing samples descend "
            "from")}),
    }
    if of:
        for var in extra.values():
            var[2]["long_name"] += f" ({of})"
    return extra


def _level_covs(levels: list[dict[str, Any]]) -> tuple[float, float]:
    """CoV of the product of the levels: uncorrelated levels (``sqrt(sum delta_i^2)``) and
    fully correlated levels (``sum delta_i``), Au and Beck (2001)."""
    covs = np.array([lv["cov"] for lv in levels])
    return float(np.sqrt(np.sum(covs**2))), float(np.sum(covs))


def _lognormal_interval(pf: float, cov: float, z: float) -> tuple[float, float]:
    """``pf exp(-+ z s)``, ``s^2 = ln(1 + cov^2)``."""
    spread = z * math.sqrt(math.log1p(cov**2))
    return pf * math.exp(-spread), pf * math.exp(spread)


def _replicate_seed(seed: int, k: int) -> int:
    return int(np.random.SeedSequence([seed, 500, k]).generate_state(1, np.uint64)[0] % 2**63)


def _run_replicates(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int,
                    confidence: float, t0: float) -> xr.Dataset:
    """``replicates`` independent runs, pooled by the mean with a log-t interval.

    On a response whose failure set the chains cannot cross (the helical pair's peak mesh
    force: a thin ridge along ``B1 = B2``), each run's levels are correlated and the Au-Beck
    CoV understates the scatter 1.4-2.5x; the spread of independent runs measures it.
    Interval: ``mean exp(-+ t_{K-1} sqrt(ln(1 + c^2)))`` with ``c`` the larger of
    ``s / (sqrt(K) mean)`` and the runs' mean Au-Beck CoV over ``sqrt(K)`` (positive, keeps the
    estimator's skew; on the helical pair at Pf ~ 1e-4 this held the crude-MC reference in
    20/20, 20/20 and 19/20 groups of ten and 40/40 groups of five). Status 1 when two
    replicates' own intervals are disjoint: their single-run intervals cannot be trusted and
    the pooled one rests on the replicates' scatter alone.
    """
    k_rep = s["replicates"]
    z = stats.norm.isf((1 - confidence) / 2)
    pfs, lows, ups, n_levels, run_covs = [], [], [], [], []
    walk_levels: list[list[dict[str, Any]]] = []
    for k in range(k_rep):
        walk = simulate(ev, s, _replicate_seed(seed, k), tag=f"subset/rep{k}")
        if walk.levels is None:
            return failure_report(ev, "subset", pf=math.nan, interval_kind="none",
                                  confidence=confidence, settings=s, seed=seed,
                                  wall_time=time.perf_counter() - t0, status=2,
                                  message=f"replicate {k}: {walk.message}")
        pf_k = walk.pf * walk.levels[-1]["valid_share"]
        cov_k = max(_level_covs(walk.levels))
        low_k, up_k = _lognormal_interval(pf_k, cov_k, z)
        run_covs.append(cov_k)
        pfs.append(pf_k)
        lows.append(low_k)
        ups.append(up_k if pf_k > 0 else math.inf)
        n_levels.append(len(walk.levels))
        walk_levels.append(walk.levels)
    pfs_a = np.array(pfs)
    mean = float(pfs_a.mean())
    reasons = []
    if mean > 0:
        # the larger of the scatter measured between the runs and the runs' own (Au-Beck)
        # CoV of a mean of K: with few replicates the sample spread alone can come out small
        c = max(float(pfs_a.std(ddof=1) / (math.sqrt(k_rep) * mean)),
                float(np.mean(run_covs)) / math.sqrt(k_rep))
        lower, upper = _lognormal_interval(mean, c, stats.t.isf((1 - confidence) / 2,
                                                                 k_rep - 1))
        # each replicate's last-level censored samples read safe on a bound above 0, counted
        # as failed: at most the largest of their factors on the mean
        upper *= max(_censored_last_factor(levels) for levels in walk_levels)
        status, message = 0, ""
        disjoint = [(i, j) for i in range(k_rep) for j in range(i + 1, k_rep)
                    if ups[i] < lows[j] or ups[j] < lows[i]]
        if disjoint:
            reasons.append((1, f"{len(disjoint)} pair(s) of the {k_rep} replicates have "
                            "disjoint intervals: single runs are not honest on this response "
                            "(correlated levels) and the pooled interval rests on the "
                            "replicates' scatter alone; raise replicates"))
    else:
        c = math.inf
        lower, upper, status = 0.0, float(np.max(ups)) if np.isfinite(ups).any() else 1.0, 4
        message = "no replicate observed a failure: pf_upper is the largest replicate bound"
    extra = {
        "replicate_pf": (("replicate",), pfs_a, {"units": "1", "long_name":
                         "estimate of each independent run"}),
        "replicate_pf_lower": (("replicate",), np.array(lows), {"units": "1", "long_name":
                               "each run's own lower end (Au-Beck)"}),
        "replicate_pf_upper": (("replicate",), np.array(ups), {"units": "1", "long_name":
                               "each run's own upper end (Au-Beck)"}),
        "replicate_levels": (("replicate",), np.array(n_levels), {"units": "1", "long_name":
                             "levels of each run"}),
        **_replicate_censored(walk_levels),
    }
    reasons.extend(_censored_reasons(ev, walk_levels))
    if ev.n_invalid - ev.n_censored:
        reasons.append((6, f"{ev.n_invalid - ev.n_censored} model runs were invalid; each "
                        "replicate counts only "
                        "the valid failing samples of its last level (the interval does not "
                        "widen for the reading that counts them as failed)"))
    kind = (f"log-t over {k_rep} independent runs: mean exp(-+ t sqrt(ln(1 + c^2))), c the "
            "CoV of the mean: the larger of their scatter and their own Au-Beck CoV / sqrt(K)")
    return failure_report(ev, "subset", pf=mean if mean > 0 else upper, pf_lower=lower,
                          pf_upper=upper, cov=c, interval_kind=_given_gate(kind, s),
                          confidence=confidence,
                          settings=s, seed=seed, wall_time=time.perf_counter() - t0,
                          status=status, message=message, reasons=reasons,
                          grid_gap=ev.grid_gap_fraction * mean if ev.time_dependent
                          else math.nan, pf_is_upper_bound=mean <= 0, extra=extra)
