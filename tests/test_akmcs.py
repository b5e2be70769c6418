"""AK-MCS: the four-branch system (one output, and component by component), the non-linear
oscillator, the surrogate's own error, and its failure on a discontinuous response."""

from __future__ import annotations

import numpy as np
import pytest

from gearuq.failure.api import failure_probability
from gearuq.failure.methods.akmcs import learning_function_u
from gearuq.testing import reliability_problems as rp
from gearuq.testing.problems import FOUR_BRANCH_PF, four_branch_model, standard_normal_space


# 3-4 s of CPU, a statistical check over many runs: CI runs it with the end-to-end
# runs (-m e2e)
@pytest.mark.e2e
def test_four_branch_single_output_within_interval_and_150_runs():
    rep = failure_probability(four_branch_model(), standard_normal_space(2), "g",
                              method="akmcs", rng=1, n_mc=50_000, target_cov=0.1,
                              executor="serial")
    assert int(rep["n_model_runs"]) <= 150
    assert float(rep["pf_lower"]) <= FOUR_BRANCH_PF <= float(rep["pf_upper"])
    assert int(rep["status"]) == 0 and float(rep["min_u"]) >= 2.0
    hist = rep["iteration_model_runs"].values
    assert np.all(np.diff(hist) >= 0) and hist[-1] == int(rep["n_model_runs"])


@pytest.mark.e2e
def test_four_branch_as_series_system_learns_each_branch():
    """One Kriging model per branch (AK-SYS): the kinks are in the min, not in a surrogate."""
    p = rp.reliability_problems()["four_branch_system"]
    rep = failure_probability(p["model"], p["space"], p["limit_state"], method="akmcs", rng=1,
                              executor="serial")
    assert int(rep["n_model_runs"]) <= 40
    assert float(rep["pf_lower"]) <= FOUR_BRANCH_PF <= float(rep["pf_upper"])
    # the surrogate is sure of every point: its own error interval has collapsed
    assert float(rep["pf_surrogate_lower"]) == float(rep["pf_surrogate_upper"]) == float(
        rep["pf"])


@pytest.mark.e2e
def test_oscillator_within_interval_with_fewer_than_100_runs():
    rep = failure_probability(rp.oscillator_model(), rp.oscillator_space(), "g",
                              method="akmcs", rng=2, n_mc=30_000, executor="serial")
    assert int(rep["n_model_runs"]) < 100
    assert float(rep["pf_lower"]) <= rp.OSCILLATOR_PF_MC <= float(rep["pf_upper"])


@pytest.mark.slow
def test_oscillator_within_3_percent():
    """4e5 population points (population CoV 1 %): within 3 % with fewer than 100 runs."""
    rep = failure_probability(rp.oscillator_model(), rp.oscillator_space(), "g",
                              method="akmcs", rng=0, target_cov=0.01, executor="serial")
    assert int(rep["n_model_runs"]) < 100
    assert float(rep["pf"]) == pytest.approx(rp.OSCILLATOR_PF_MC, rel=0.03)


@pytest.mark.e2e
def test_discontinuous_response_stalls_the_learning():
    """g = 3.5 - x1 - 1.5 [x2 > 1]: the squared-exponential Kriging model cannot represent the
    jump, U stays far below 2 along it and the learning runs to max_runs. The report says it
    did not converge, and its interval - population and surrogate error together - is wide
    and still holds the truth."""
    rep = failure_probability(rp.jump_model(), standard_normal_space(2), "g", method="akmcs",
                              rng=2, max_mc=100_000, max_runs=80, executor="serial")
    assert int(rep["status"]) == 1 and int(rep["n_model_runs"]) == 80
    assert float(rep["min_u"]) < 2.0 and "max_runs=80 reached" in rep.attrs["message"]
    assert float(rep["pf_lower"]) <= rp.JUMP_PF <= float(rep["pf_upper"])
    assert float(rep["pf_surrogate_upper"]) > float(rep["pf_surrogate_lower"])


def test_learning_function():
    u = learning_function_u(np.array([1.0, -2.0, 0.0, 1.0]), np.array([0.5, 1.0, 1.0, 0.0]))
    np.testing.assert_array_equal(u, [2.0, 2.0, 0.0, np.inf])


def test_bad_settings():
    with pytest.raises(ValueError, match="option 'n_initial'"):
        failure_probability(four_branch_model(), standard_normal_space(2), "g",
                            method="akmcs", n_initial=1)
