"""Multifidelity Monte Carlo: the allocation against its closed form (and MXMCPy where it is
installed), unbiasedness and interval coverage over seeds against exact Ishigami moments and
a large Monte Carlo probability, the variance reduction, and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

import gearuq
from gearuq.engines.multifidelity import _mfmc_variance, mfmc_allocation, multifidelity_estimate
from gearuq.failure.modes import LimitState

A, B = 7.0, 0.1
MEAN = A / 2
VARIANCE = A**2 / 8 + B * np.pi**4 / 5 + B**2 * np.pi**8 / 18 + 0.5


def _ishigami(x1, x2, x3):
    return np.sin(x1) + A * np.sin(x2) ** 2 + B * x3**4 * np.sin(x1)


def _cheap(x1, x2, x3):  # drops most of the x3 interaction
    return np.sin(x1) + A * np.sin(x2) ** 2 + 0.5 * B * x3**2 * np.sin(x1)


def _cheaper(x1, x2, x3):
    return 6.0 * np.sin(x2) ** 2 + 0.5 * x1


MODELS = [gearuq.FunctionModel(f, ["x1", "x2", "x3"], ["y"], name=f.__name__.strip("_"))
          for f in (_ishigami, _cheap, _cheaper)]
SPACE = gearuq.ParameterSpace.uniform(x1=(-np.pi, np.pi), x2=(-np.pi, np.pi),
                                      x3=(-np.pi, np.pi))
COSTS = [1.0, 0.05, 0.01]


def test_allocation_closed_form_for_two_models():
    """Two models: r = sqrt(w0 rho^2 / (w1 (1 - rho^2))), m0 = B / (w0 + w1 r)."""
    m, kept = mfmc_allocation([1.0, 0.01], [1.0, 0.9], 100.0)
    r = math.sqrt(0.81 / (0.01 * 0.19))
    assert kept == [0, 1]
    assert m[0] == pytest.approx(100.0 / (1.0 + 0.01 * r))
    assert m[1] / m[0] == pytest.approx(r)
    # a cheap model that is not cheap enough for its correlation is left out
    m, kept = mfmc_allocation([1.0, 0.9], [1.0, 0.5], 100.0)
    assert kept == [0] and m[0] == pytest.approx(100.0)


def test_allocation_agrees_with_mxmcpy():
    mxmc = pytest.importorskip("mxmc.optimizers.mfmc")
    sigma = np.array([1.0, 0.8, 1.3])
    rho = np.array([1.0, 0.95, 0.7])
    cov = np.outer(sigma, sigma) * np.array([[1, 0.95, 0.7], [0.95, 1, 0.7 * 0.95],
                                             [0.7, 0.7 * 0.95, 1]])
    costs = np.array([1.0, 0.05, 0.002])
    theirs = mxmc.MFMC(costs, cov).optimize(1000.0)
    ours, kept = mfmc_allocation(costs, rho, 1000.0)
    assert kept == [0, 1, 2]
    np.testing.assert_allclose(theirs.allocation.get_number_of_samples_per_model(),
                               np.floor(ours), rtol=0, atol=1)
    assert _mfmc_variance(np.floor(ours), sigma, rho) == pytest.approx(
        theirs.variance, rel=1e-2)


@pytest.mark.e2e
@pytest.mark.parametrize("statistic,reference,estimator", [
    ("mean", MEAN, "mfmc"), ("variance", VARIANCE, "mfmc"), ("mean", MEAN, "acvmf")])
def test_unbiased_with_intervals_that_hold(statistic, reference, estimator):
    """40 seeds: the mean estimate within 3 standard errors of the exact moment, the 95 %
    intervals holding it in at least 32 of 40 (binomial 0.1 % quantile at p = 0.95 is 33)."""
    est, held = [], 0
    for seed in range(40):
        r = multifidelity_estimate(MODELS, SPACE, "y", statistic=statistic, budget=150.0,
                                   costs=COSTS, pilot=50, rng=seed, executor="serial",
                                   estimator=estimator)
        est.append(float(r["estimate"]))
        held += float(r["estimate_lower"]) <= reference <= float(r["estimate_upper"])
    est = np.array(est)
    assert abs(est.mean() - reference) <= 3 * est.std(ddof=1) / math.sqrt(est.size)
    assert held >= 32


@pytest.mark.e2e
def test_variance_reduction_against_plain_mc_at_equal_cost():
    """The predicted reduction and the measured one: MFMC's spread over seeds against plain
    Monte Carlo with the same budget (150 runs of the expensive model)."""
    mf = [multifidelity_estimate(MODELS, SPACE, "y", budget=150.0, costs=COSTS, pilot=50,
                                 rng=100 + s, executor="serial") for s in range(30)]
    predicted = np.mean([float(r["variance_reduction"]) for r in mf])
    measured = (VARIANCE / 150) / np.var([float(r["estimate"]) for r in mf], ddof=1)
    assert predicted > 1.5 and measured > 1.3


@pytest.mark.e2e
def test_exceedance_probability_of_a_moderate_level():
    """P(y >= 8) of the Ishigami function with failure indicators as control variates,
    against 2e6 plain samples."""
    rng = np.random.default_rng(0)
    x = rng.uniform(-np.pi, np.pi, (2_000_000, 3))
    ref = float(np.mean(_ishigami(*x.T) >= 8.0))
    limit = LimitState.upper("y", 8.0)
    est, held = [], 0
    for seed in range(20):
        r = multifidelity_estimate(MODELS, SPACE, limit, statistic="probability", budget=400.0,
                                   costs=COSTS, pilot=100, rng=seed, executor="serial")
        est.append(float(r["estimate"]))
        held += float(r["estimate_lower"]) <= ref <= float(r["estimate_upper"])
    est = np.array(est)
    assert abs(est.mean() - ref) <= 3 * est.std(ddof=1) / math.sqrt(est.size)
    assert held >= stats.binom.ppf(0.001, 20, 0.95)


def test_acvmf_allocation_minimises_its_variance():
    """The optimiser's ratios beat every ratio on a grid around them (two cheap models)."""
    from gearuq.engines.multifidelity import _acvmf_variance, acvmf_allocation

    sd = np.array([1.0, 0.9, 1.2])
    corr = np.array([[1.0, 0.95, 0.8], [0.95, 1.0, 0.85], [0.8, 0.85, 1.0]])
    cov = corr * np.outer(sd, sd)
    costs = np.array([1.0, 0.05, 0.01])
    n, r = acvmf_allocation(costs, cov, 100.0)
    best = _acvmf_variance(cov, r, n)
    for f1 in (0.7, 0.9, 1.1, 1.4):
        for f2 in (0.7, 0.9, 1.1, 1.4):
            rr = np.maximum(r * [f1, f2], 1.0 + 1e-9)
            assert best <= _acvmf_variance(cov, rr, 100.0 / (1.0 + costs[1:] @ rr)) * (1 + 1e-6)
    assert 100.0 == pytest.approx(n * (costs[0] + costs[1:] @ r))


def test_bad_input():
    with pytest.raises(ValueError, match="at least one cheaper"):
        multifidelity_estimate(MODELS[:1], SPACE, "y", budget=10.0)
    with pytest.raises(ValueError, match="budget"):
        multifidelity_estimate(MODELS, SPACE, "y", budget=-1.0)
    with pytest.raises(ValueError, match="costs"):
        multifidelity_estimate(MODELS, SPACE, "y", budget=10.0, costs=[1.0, 0.0, 0.1])
    other = gearuq.FunctionModel(lambda a: a, ["a"], ["y"], name="other")
    with pytest.raises(ValueError, match=r"no parameter\(s\) 'x1'"):
        multifidelity_estimate([MODELS[0], other], SPACE, "y", budget=10.0)
    with pytest.raises(ValueError, match="statistic"):
        multifidelity_estimate(MODELS, SPACE, "y", budget=10.0, statistic="median")
    with pytest.raises(ValueError, match="estimator"):
        multifidelity_estimate(MODELS, SPACE, "y", budget=10.0, estimator="mlmc")
