"""The importance-sampling stopping rule: a pilot sizes the estimate and fresh draws make it,
so the estimate is unbiased; stopping once the running CoV reaches the target leans high.

Both rules sample the same defensive density for the same limit state ``g = 3 - u1`` (Pf
``Phi(-3)`` exactly) from the same streams; the model is a stand-in evaluator (the rules
only see ``g``), so a thousand runs take seconds. The sequential rule is written here
without the code under test."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from gearuq.failure.methods.importance import (
    SAFETY,
    Mixture,
    plan_size,
    sample_until,
)

EXACT = float(stats.norm.sf(3.0))
#: Small batches and a loose target: the regime where the sequential rule stops after a few
#: batches, i.e. where its selection shows (the rotor benchmark's runs stopped after 1-5).
SEQUENTIAL = {"n_samples": 20, "target_cov": 0.3, "max_samples": 2000}
#: The same target; a pilot of 100 draws (about 14 of them fail).
TWO_STAGE = {**SEQUENTIAL, "n_samples": 100}
RUNS = 600


class _Line:
    """``g = 3 - u1`` in two standard normal inputs, counting runs like the evaluator."""

    dim = 2
    time_dependent = False

    def __init__(self) -> None:
        self.n_runs = 0

    def evaluate(self, u: np.ndarray, tag: str) -> dict[str, np.ndarray]:
        self.n_runs += u.shape[0]
        g = 3.0 - u[:, 0]
        return {"g": g, "g_half": g, "status": np.zeros(u.shape[0], dtype=np.int8)}


def _density() -> Mixture:
    # centred short of the failure set (as a too-pessimistic cheap model would put it): few
    # draws fail, so the running CoV tracks the running pf closely
    return Mixture(np.array([[2.0, 0.0]]), np.eye(2)[None], np.ones(1), 0.1)


def _sequential(seed: int) -> float:
    """Batches until the running CoV of ``mean(1_F w)`` is at most the target."""
    mix, ev = _density(), _Line()
    c = np.empty(0)
    for b in range(SEQUENTIAL["max_samples"] // SEQUENTIAL["n_samples"]):
        rng = np.random.default_rng(np.random.SeedSequence([seed, b]))
        u = mix.sample(SEQUENTIAL["n_samples"], rng)
        w = np.exp(mix.log_weights(u))
        c = np.append(c, np.where(ev.evaluate(u, "")["g"] <= 0, w, 0.0))
        pf = c.mean()
        if pf > 0 and c.std(ddof=1) / math.sqrt(c.size) / pf <= SEQUENTIAL["target_cov"]:
            break
    return float(c.mean())


def _two_stage(seed: int) -> dict:
    return sample_until(_Line(), _density(), TWO_STAGE, 0.95, np.random.SeedSequence([seed]),
                        "test")


def _bias_in_standard_errors(pf: np.ndarray) -> float:
    return float((pf.mean() - EXACT) / (pf.std(ddof=1) / math.sqrt(pf.size)))


@pytest.mark.e2e
def test_the_two_stage_rule_is_unbiased_where_the_sequential_one_leans_high(monkeypatch):
    """600 runs of each rule. The sequential rule's mean lies more than 3 standard errors
    above the exact value (the same rule inside MFIS on a two-input problem, 400 seeds:
    +8.3 % of Pf, +4.9 standard errors); the two-stage rule's within 3, and its reported CoV
    matches the spread of its estimates within 15 %. The weights' Pareto diagnostic is not
    under test and is skipped (its fit is most of the run time)."""
    import gearuq.failure.methods.importance as imp

    monkeypatch.setattr(imp, "pareto_shape", lambda values: math.nan)
    seq = np.array([_sequential(seed) for seed in range(RUNS)])
    assert _bias_in_standard_errors(seq) > 3.0, seq.mean() / EXACT
    runs = [_two_stage(seed) for seed in range(RUNS)]
    pf = np.array([r["pf"] for r in runs])
    assert abs(_bias_in_standard_errors(pf)) < 3.0, pf.mean() / EXACT
    cov_reported = np.mean([r["cov"] for r in runs])
    assert cov_reported == pytest.approx(pf.std(ddof=1) / EXACT, rel=0.15)
    # the estimate never reuses the pilot: its draws are the planned fresh ones
    assert all(r["n"] >= r["n_pilot"] for r in runs)


def test_the_pilot_sizes_the_estimate_for_the_target():
    """``N = SAFETY (cv_1 / target)^2`` from the pilot's per-draw CoV, capped by the budget;
    a pilot with too few failures uses the whole budget; reweighting to another density
    gives that density's per-draw CoV (here the density itself: the same N)."""
    rng = np.random.default_rng(0)
    w = rng.uniform(0.5, 1.5, 400)
    fail = rng.random(400) < 0.25
    c = np.where(fail, w, 0.0)
    cv1 = math.sqrt(np.mean(c**2) / c.mean() ** 2 - 1.0)
    s = {"target_cov": 0.1, "max_samples": 100_000}
    n, capped = plan_size({"w": w, "fail": fail}, s)
    assert n == math.ceil(SAFETY * (cv1 / 0.1) ** 2) and not capped
    assert plan_size({"w": w, "fail": fail}, s, w_new=w) == (n, False)
    assert plan_size({"w": w, "fail": fail}, {**s, "max_samples": 600}) == (200, True)
    few = np.zeros(400, dtype=bool)
    few[:5] = True
    assert plan_size({"w": w, "fail": few}, s) == (100_000 - 400, True)
