"""Subset simulation must say when its chains did not mix (issue 30, item 3).

The oracle problem is a thin failure wedge along ``x1 = x2`` with four inert inputs (the shape
of the helical pair's peak mesh force): component-wise chains cannot follow it, single runs
scatter by decades. Its reference is computed here by conditioning on the distance across the
ridge, averaged over a million Monte Carlo draws of it (independent of the quadrature in
``gearuq.testing``). The demand: every status-0 interval holds the truth and no two status-0
intervals of the same quantity are disjoint; the others say in words that the chains did not
mix. On a problem whose chains mix, the check stays silent.
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
from scipy import stats

import gearuq
from gearuq.failure.methods.subset import lineage_spread
from gearuq.testing.reliability_problems import RIDGE_B, RIDGE_K, offset_model, ridge_model

SPACE6 = gearuq.ParameterSpace.normal(**{f"x{i}": (0.0, 1.0) for i in range(1, 7)})


def _ridge_truth() -> float:
    across = np.abs(np.random.default_rng(0).standard_normal(1_000_000))
    return float(np.mean(stats.norm.sf(RIDGE_B + RIDGE_K * math.sqrt(2.0) * across)))


def _runs(model, space, seeds, **settings):
    out = []
    for seed in seeds:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out.append(gearuq.failure_probability(model, space, "g", method="subset",
                                                  rng=seed, executor="serial", **settings))
    return out


def _disjoint_pairs(reps) -> int:
    ints = [(float(r["pf_lower"]), float(r["pf_upper"])) for r in reps]
    return sum(1 for i in range(len(ints)) for j in range(i + 1, len(ints))
               if ints[i][1] < ints[j][0] or ints[j][1] < ints[i][0])


@pytest.mark.e2e
def test_ridge_runs_that_did_not_mix_say_so_and_status0_intervals_hold() -> None:
    truth = _ridge_truth()
    # one walk each: the lineage check alone (the default's second walk: test_subset_second_walk)
    reps = _runs(ridge_model(), SPACE6, range(6), second_walk="never")
    ok = [r for r in reps if int(r["status"]) == 0]
    flagged = [r for r in reps if int(r["status"]) != 0]
    assert all(float(r["pf_lower"]) <= truth <= float(r["pf_upper"]) for r in ok)
    assert _disjoint_pairs(ok) == 0
    # the single-run scatter is real here: the runs' estimates span more than a decade
    pfs = np.array([float(r["pf"]) for r in reps])
    assert pfs.max() / pfs.min() > 10
    assert len(flagged) >= 4
    for r in flagged:
        reasons = json.loads(r.attrs["status_reasons"])
        assert any(x["status"] == 1 and "did not mix" in x["message"] for x in reasons)
        assert float(r["lineage_zero_share"]) > 0.05


# 3-4 s of CPU, a statistical check over many runs: CI runs it with the end-to-end
# runs (-m e2e)
@pytest.mark.e2e
def test_chains_that_mix_are_not_flagged() -> None:
    space = gearuq.ParameterSpace.normal(x1=(0.0, 1.0), x2=(0.0, 1.0))
    truth = float(stats.norm.sf(4.5))
    reps = _runs(offset_model(), space, range(8), n_per_level=1000)
    assert all(int(r["status"]) == 0 for r in reps)
    held = sum(float(r["pf_lower"]) <= truth <= float(r["pf_upper"]) for r in reps)
    assert held >= 7


def test_lineage_spread_of_independent_lineages_matches_the_binomial() -> None:
    """One level, every lineage an independent chain of 10 samples with p = 0.1 each: the
    bootstrap's sd of ln p must match the binomial's sqrt((1 - p)/(n p))."""
    rng = np.random.default_rng(3)
    root = np.repeat(np.arange(100), 10)
    below = rng.random(1000) < 0.1
    spread = lineage_spread([(root, below)], n_boot=4000)
    p = below.mean()
    assert spread["s"] == pytest.approx(math.sqrt((1 - p) / (1000 * p)), rel=0.15)
    assert spread["zero_share"] == 0.0
    # one lineage carries every failure: most draws lose it
    below_one = root == 7
    one = lineage_spread([(root, below_one)], n_boot=4000)
    assert one["n_eff"] == pytest.approx(1.0)
    assert one["zero_share"] == pytest.approx((1 - 1 / 100) ** 100, abs=0.03)
