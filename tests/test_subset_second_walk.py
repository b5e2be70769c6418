"""Subset simulation's second walk (issue 30, item 3): a walk whose failures descend from few
level-1 chains cannot measure its own scatter, so an independent walk checks it.

Oracles: the effective number of lineages of a constructed lineage table (exact), the single
walk itself (``simulate``: a run the rule leaves alone must be that walk, bit for bit), exact
failure probabilities (``g = 4.5 - x1``; one limit state ``min(1e3 g1, 1e-3 g2)`` of two linear
margins, 1-D quadrature), and the ridge whose chains do not mix.
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
from scipy import stats

import gearuq
from gearuq.failure.api import validate_settings
from gearuq.failure.evaluator import LimitStateEvaluator
from gearuq.failure.methods.subset import (
    SECOND_WALK_LINEAGES,
    second_walk_reason,
    simulate,
)
from gearuq.testing.reliability_problems import (
    OFFSET_PF,
    RIDGE_B,
    RIDGE_K,
    offset_model,
    offset_space,
    resistance_load_model,
    resistance_load_pf,
    resistance_load_space,
    ridge_model,
    unit_modes_limit_state,
    unit_modes_model,
    unit_modes_pf,
)


def _subset(model, space, limit_state, seed, **settings):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gearuq.failure_probability(model, space, limit_state, method="subset", rng=seed,
                                          executor="serial", **settings)


def _lineage(k: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """One level: 100 chains of 10 samples; two samples of each of the first ``k`` chains
    fail, so the failures descend from exactly ``k`` equal lineages (``n_eff = k``)."""
    root = np.repeat(np.arange(100), 10)
    below = np.zeros(1000, dtype=bool)
    for r in range(k):
        below[10 * r: 10 * r + 2] = True
    return [(root, below)]


def test_the_rule_counts_the_lineages_that_carry_the_failures() -> None:
    k = SECOND_WALK_LINEAGES
    assert second_walk_reason(_lineage(k)) == ""
    reason = second_walk_reason(_lineage(k - 1))
    assert f"about {k - 1:.1f} of its level-1 chains" in reason
    assert second_walk_reason(_lineage(1), mode="never") == ""
    assert second_walk_reason(_lineage(50), mode="always") != ""


@pytest.mark.e2e
@pytest.mark.parametrize("seed", [1000, 1001])
def test_a_walk_the_rule_leaves_alone_is_reported_bit_for_bit(seed: int) -> None:
    """Pf ~ 2e-3 (three levels, failures from 8-30 lineages): the default run is the single
    walk, the same numbers as ``second_walk="never"`` and as ``simulate`` itself."""
    model, space = resistance_load_model(), resistance_load_space()
    default = _subset(model, space, "g", seed)
    single = _subset(model, space, "g", seed, second_walk="never")
    assert "replicate_pf" not in default
    for var in ("pf", "pf_lower", "pf_upper", "cov_pf", "n_model_runs", "status",
                "level_probability", "lineage_log_spread"):
        np.testing.assert_array_equal(default[var].values, single[var].values)
    ev = LimitStateEvaluator(model, space, "g", executor="serial", seed=seed)
    walk = simulate(ev, validate_settings("subset", {}), seed)
    assert float(default["pf"]) == walk.pf
    assert int(default["n_model_runs"]) == ev.n_runs
    assert float(default["pf_lower"]) <= resistance_load_pf() <= float(default["pf_upper"])


# 3-4 s of CPU, a statistical check over many runs: CI runs it with the end-to-end
# runs (-m e2e)
@pytest.mark.e2e
def test_two_walks_on_a_deep_healthy_problem_hold_and_cost_two_walks(tmp_path) -> None:
    """``g = 4.5 - x1`` (Pf 3.4e-6, six levels): the failures of a walk descend from 2-6
    level-1 chains, so the default runs two walks. Their mean is unbiased, the hull of their
    intervals holds the exact value, the cost is that of the two walks and the reported
    (Au-Beck) CoV that of their mean."""
    held, flagged, cost_ratio, cov_ratio = 0, 0, [], []
    for seed in range(4):
        rep = _subset(offset_model(), offset_space(), "g", seed)
        one = _subset(offset_model(), offset_space(), "g", seed, second_walk="never")
        pfs = rep["replicate_pf"].values
        assert float(rep["pf"]) == pytest.approx(pfs.mean(), rel=1e-12)
        assert float(rep["pf"]) == pytest.approx(float(one["pf"]) / 2 + pfs[1] / 2, rel=1e-12)
        assert float(rep["pf_lower"]) == rep["replicate_pf_lower"].values.min()
        assert float(rep["pf_upper"]) == rep["replicate_pf_upper"].values.max()
        cost_ratio.append(int(rep["n_model_runs"]) / int(one["n_model_runs"]))
        cov_ratio.append(float(rep["cov_pf"]) / float(one["cov_pf"]))
        if int(rep["status"]) == 0:
            held += float(rep["pf_lower"]) <= OFFSET_PF <= float(rep["pf_upper"])
        else:
            flagged += 1
    assert held + flagged == 4 and flagged <= 1
    gearuq.save(rep, tmp_path / "pair.nc")  # the pair's report round-trips like any other
    back = gearuq.load(tmp_path / "pair.nc")
    np.testing.assert_array_equal(back["replicate_pf"].values, rep["replicate_pf"].values)
    assert back.attrs["interval_kind"] == rep.attrs["interval_kind"]
    assert 1.6 < np.mean(cost_ratio) < 2.4  # the levels of the two walks may differ by one
    # the Au-Beck CoV of a mean of two walks: about 1/sqrt(2) of one walk's
    assert 0.5 < np.mean(cov_ratio) < 0.95, cov_ratio


# 3-4 s of CPU, a statistical check over many runs: CI runs it with the end-to-end
# runs (-m e2e)
@pytest.mark.e2e
def test_a_walk_that_missed_a_mode_is_caught_by_the_second() -> None:
    """One limit state ``min(1e3 g1, 1e-3 g2)`` (Pf 1.573e-3): the thresholds follow the
    component in the large unit, and a walk may miss the other mode. Two walks on every seed:
    the status-0 intervals hold the quadrature value and no two of them are disjoint; a pair
    whose walks disagree says so."""
    plane = gearuq.ParameterSpace.normal(u1=(0.0, 1.0), u2=(0.0, 1.0))
    model, limit, truth = unit_modes_model((1e3, 1e-3)), unit_modes_limit_state(False), \
        unit_modes_pf()
    reps = [_subset(model, plane, limit, seed, second_walk="always")
            for seed in range(1000, 1020)]
    ok = [r for r in reps if int(r["status"]) == 0]
    assert len(ok) >= 16
    assert all(float(r["pf_lower"]) <= truth <= float(r["pf_upper"]) for r in ok)
    bounds = [(float(r["pf_lower"]), float(r["pf_upper"])) for r in ok]
    assert max(lo for lo, _ in bounds) <= min(up for _, up in bounds)  # all overlap
    for r in reps:
        if int(r["status"]) != 0:
            words = " ".join(x["message"] for x in json.loads(r.attrs["status_reasons"]))
            assert "disagree" in words or "did not mix" in words


@pytest.mark.e2e
def test_ridge_pairs_say_the_chains_did_not_mix() -> None:
    """The ridge (thin wedge along x1 = x2, four inert inputs; walks scatter by decades): a
    pair is status 0 only if both walks pass the lineage check and agree, and then it holds."""
    space = gearuq.ParameterSpace.normal(**{f"x{i}": (0.0, 1.0) for i in range(1, 7)})
    across = np.abs(np.random.default_rng(0).standard_normal(1_000_000))
    truth = float(np.mean(stats.norm.sf(RIDGE_B + RIDGE_K * math.sqrt(2.0) * across)))
    for seed in range(3):
        rep = _subset(ridge_model(), space, "g", seed)
        assert "replicate_pf" in rep
        if int(rep["status"]) == 0:
            assert float(rep["pf_lower"]) <= truth <= float(rep["pf_upper"])
        else:
            words = " ".join(x["message"] for x in json.loads(rep.attrs["status_reasons"]))
            assert "disagree" in words or "did not mix" in words
