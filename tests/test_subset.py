"""Subset simulation: estimates within their intervals on exact references, first passage of
a time-dependent response, the chain correlation factor, bad settings, resumable runs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearuq.failure.api import failure_probability
from gearuq.failure.methods.subset import chain_correlation_factor, level_cov
from gearuq.failure.modes import LimitState
from gearuq.model import FunctionModel
from gearuq.space import ParameterSpace
from gearuq.testing import reliability_problems as rp
from gearuq.testing.problems import (
    FOUR_BRANCH_PF,
    four_branch_model,
    standard_normal_space,
)


@pytest.mark.e2e
def test_linear_100d_within_interval():
    rep = failure_probability(rp.linear_sum_model(), standard_normal_space(100), "g",
                              method="subset", rng=11, executor="serial")
    assert float(rep["pf_lower"]) <= rp.LINEAR_100D_PF <= float(rep["pf_upper"])
    assert rep.sizes["level"] == 4  # three levels of 0.1, then P(G <= 0 | F_3) ~ 0.23
    assert int(rep["n_model_runs"]) < 4000


def test_four_branch_within_interval():
    rep = failure_probability(four_branch_model(), standard_normal_space(2), "g",
                              method="subset", rng=12, executor="serial")
    assert float(rep["pf_lower"]) <= FOUR_BRANCH_PF <= float(rep["pf_upper"])
    np.testing.assert_allclose(rep["level_probability"][:2], 0.1, atol=0.01)


@pytest.mark.parametrize("mcmc", ["mma", "acs"])
def test_offset_within_interval_at_5000_runs(mcmc):
    """Pf = 3.4e-6 with <= ~5500 runs for one walk. Subset simulation's CoV there is 0.4-0.75
    (measured over 40 seeds: 0.75 modified Metropolis, 0.44 aCS), so the estimate is within
    its interval but not within 15 % in general. (The default adds a second walk there:
    ``tests/test_subset_second_walk.py``.)"""
    rep = failure_probability(rp.offset_model(), rp.offset_space(), "g", method="subset",
                              rng=13, executor="serial", mcmc=mcmc, second_walk="never")
    assert int(rep["n_model_runs"]) <= 5500
    assert float(rep["pf_lower"]) <= rp.OFFSET_PF <= float(rep["pf_upper"])
    assert 0.2 < float(rep["cov_pf"]) < 0.8
    if mcmc == "acs":  # aCS steers the acceptance of each level towards 0.44
        acceptance = rep["level_acceptance"].values[:-1]
        assert np.all((acceptance > 0.25) & (acceptance < 0.65)), acceptance


def _offset_estimates(mcmc: str, seeds: range) -> tuple[np.ndarray, float]:
    pf, runs = [], []
    for seed in seeds:
        rep = failure_probability(rp.offset_model(), rp.offset_space(), "g", method="subset",
                                  rng=seed, executor="serial", mcmc=mcmc,
                                  second_walk="never")
        pf.append(float(rep["pf"]))
        runs.append(int(rep["n_model_runs"]))
    return np.array(pf), float(np.mean(runs))


@pytest.mark.e2e
def test_both_samplers_unbiased_and_acs_more_efficient():
    """Over 30 seeds both chain samplers are unbiased on Pf = 3.4e-6 (mean within 3 standard
    errors), and adaptive conditional sampling needs fewer model runs for a given CoV
    (CoV^2 x runs; measured over 40 seeds: 1.1e3 against 2.8e3 for modified Metropolis)."""
    work = {}
    for mcmc in ("acs", "mma"):
        pf, runs = _offset_estimates(mcmc, range(100, 130))
        se = pf.std(ddof=1) / math.sqrt(pf.size)
        assert abs(pf.mean() - rp.OFFSET_PF) < 3 * se, (mcmc, pf.mean(), se)
        work[mcmc] = (pf.std(ddof=1) / pf.mean()) ** 2 * runs
    assert work["acs"] < 0.8 * work["mma"], work


def test_first_passage_of_a_time_dependent_response():
    """Random-phase harmonic over one period: P(max_t y >= 5.26) = exp(-5.26^2 / 2) ~ 1e-6
    (101 instants: the grid loses at most (pi/100)^2/2 = 5e-4 of a peak)."""
    level = 5.26
    exact = rp.random_phase_first_passage(level, 2 * math.pi)
    t = np.linspace(0.0, 2 * math.pi, 101)
    space = ParameterSpace.normal(X1=(0.0, 1.0), X2=(0.0, 1.0))
    rep = failure_probability(rp.random_phase_model(), space, LimitState.upper("y", level), t,
                              method="subset", rng=14, executor="serial", second_walk="never")
    assert float(rep["pf_lower"]) <= exact <= float(rep["pf_upper"])
    assert 6 <= rep.sizes["level"] <= 7 and int(rep["n_model_runs"]) < 7000


def test_chain_correlation_factor():
    indep = np.random.default_rng(0).random((200, 10)) < 0.3
    assert chain_correlation_factor(indep) < 0.3
    # chains frozen at their seed: rho(k) = 1, gamma = 2 sum (1 - k/Ns) = Ns - 1
    frozen = np.repeat(np.random.default_rng(1).random((200, 1)) < 0.3, 10, axis=1)
    assert chain_correlation_factor(frozen) == pytest.approx(9.0)
    assert level_cov(0.1, 1000, 0.0) == pytest.approx(math.sqrt(0.9 / 100))


@pytest.mark.parametrize("p0", [0.0, 0.7, -0.1])
def test_p0_outside_its_range(p0):
    with pytest.raises(ValueError, match=r"p0 must lie in \(0, 0.5\]"):
        failure_probability(rp.offset_model(), rp.offset_space(), "g", method="subset", p0=p0)


_CALLS = {"n": 0, "stop_after": None}


def _counted(x1, x2):
    _CALLS["n"] += len(x1)
    if _CALLS["stop_after"] is not None and _CALLS["n"] > _CALLS["stop_after"]:
        raise KeyboardInterrupt  # an interrupted run (not a model error)
    return 2.0 - x1 + 0.0 * x2


@pytest.mark.e2e
def test_interrupted_run_resumes_from_its_store(tmp_path):
    model = FunctionModel(_counted, ["x1", "x2"], ["g"], name="counted")
    kw = {"method": "subset", "rng": 15, "executor": "serial", "n_per_level": 200, "p0": 0.2}
    _CALLS.update(n=0, stop_after=None)
    whole = failure_probability(model, standard_normal_space(2), "g", **kw)
    total = _CALLS["n"]
    _CALLS.update(n=0, stop_after=total // 2)
    with pytest.raises(KeyboardInterrupt):
        failure_probability(model, standard_normal_space(2), "g", store=tmp_path / "s", **kw)
    done = _CALLS["n"]
    _CALLS.update(n=0, stop_after=None)
    resumed = failure_probability(model, standard_normal_space(2), "g", store=tmp_path / "s",
                                  **kw)
    assert 0 < _CALLS["n"] < total  # only the missing stages ran
    assert _CALLS["n"] + done >= total
    for var in ("pf", "pf_lower", "pf_upper", "level_threshold", "level_probability"):
        np.testing.assert_array_equal(resumed[var].values, whole[var].values)
    _CALLS.update(n=0)
    again = failure_probability(model, standard_normal_space(2), "g", store=tmp_path / "s", **kw)
    assert _CALLS["n"] == 0 and float(again["pf"]) == float(whole["pf"])
