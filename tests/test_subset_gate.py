"""Subset simulation behind a gate (an event of the inputs known without the model): the walk
samples the law given the gate and estimates ``P(G <= 0 | gate)``.

Oracle: ``g = beta - u1`` with the gate ``u1 - u2 <= c`` in the standard normal plane, where
``P(u1 >= beta and gate) = int_beta^inf phi(x) Phi(c - x) dx`` (one-dimensional quadrature)
and ``P(gate) = Phi(c / sqrt 2)``: the gate cuts the failure set, as inspection does on the
gear stage (the large pitch errors that drive K_v are the ones it rejects).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from gearuq.failure.api import failure_probability
from gearuq.model import FunctionModel
from gearuq.testing.problems import standard_normal_space

BETA, CUT = 3.5, 1.5


def _g(x1, x2):
    return BETA - np.asarray(x1, float) + 0.0 * np.asarray(x2, float)


def _model() -> FunctionModel:
    return FunctionModel(_g, ["x1", "x2"], ["g"], name="gated_offset")


def _gate(u: np.ndarray) -> np.ndarray:
    return u[:, 0] - u[:, 1] <= CUT


def _reference() -> float:
    joint, _ = integrate.quad(lambda x: stats.norm.pdf(x) * stats.norm.cdf(CUT - x), BETA,
                              np.inf, epsabs=0.0, epsrel=1e-12)
    return joint / stats.norm.cdf(CUT / math.sqrt(2.0))


PF_GIVEN_GATE = _reference()


def _run(seed: int, **settings):
    settings.setdefault("gate", _gate)
    return failure_probability(_model(), standard_normal_space(2), "g", method="subset",
                               rng=seed, executor="serial", **settings)


def test_reference_is_rare_and_cut_by_the_gate():
    """The oracle itself: 3.76e-6, the gate lowering the failure probability 62 times."""
    assert 1e-6 < PF_GIVEN_GATE < 1e-5
    assert PF_GIVEN_GATE < stats.norm.sf(BETA) / 50


def test_gated_estimate_holds_the_conditional_reference():
    rep = _run(5, n_per_level=1000, second_walk="never")
    assert int(rep["status"]) == 0, str(rep.attrs["message"])
    assert float(rep["pf_lower"]) <= PF_GIVEN_GATE <= float(rep["pf_upper"])
    # the unconditional probability of failure (62 times larger) is outside the interval
    assert float(rep["pf_upper"]) < stats.norm.sf(BETA)
    assert "conditional on the gate" in rep.attrs["interval_kind"]
    # the failing samples' mean lies in the gated failure set, near its most probable point
    # (u1 = beta, u2 = beta - cut: the corner of the wedge)
    mean = rep["failure_mean_u"].values
    assert mean[0] >= BETA and mean[0] - mean[1] <= CUT
    np.testing.assert_allclose(mean, [BETA, BETA - CUT], atol=0.5)


def test_no_model_run_outside_the_gate():
    """A model that refuses every point outside the gate: no run is invalid, so none was
    made there, and the walk still finds the failure set."""
    def guarded(x1, x2):
        x1, x2 = np.asarray(x1, float), np.asarray(x2, float)
        return np.where(x1 - x2 <= CUT, BETA - x1, np.nan)

    model = FunctionModel(guarded, ["x1", "x2"], ["g"], name="guarded_offset")
    rep = failure_probability(model, standard_normal_space(2), "g", method="subset", rng=3,
                              executor="serial", gate=_gate, n_per_level=500,
                              second_walk="never")
    assert int(rep["n_invalid"]) == 0
    assert float(rep["pf"]) > 0
    # and without the gate the same model is run where it refuses
    bare = failure_probability(model, standard_normal_space(2), "g", method="subset", rng=3,
                               executor="serial", n_per_level=500, second_walk="never",
                               max_levels=2)
    assert int(bare["n_invalid"]) > 0


@pytest.mark.e2e
def test_gate_coverage_over_seeds():
    """20 seeds at 500 samples a level (modified Metropolis, the default): the 95 % intervals
    hold the quadrature reference in at least 18 (measured: 99 of 100 seeds, 60 of 60 of
    another 60), and the pooled mean's t-interval (99 %) holds it: the estimator is unbiased
    to the precision of 20 walks (their scatter is 1.7 times the reference, measured on
    100 seeds)."""
    held, estimates = 0, []
    for seed in range(20):
        rep = _run(100 + seed, n_per_level=500)
        estimates.append(float(rep["pf"]))
        held += float(rep["pf_lower"]) <= PF_GIVEN_GATE <= float(rep["pf_upper"])
    assert held >= 18, held
    half = stats.t.isf(0.005, 19) * np.std(estimates, ddof=1) / math.sqrt(20)
    assert abs(np.mean(estimates) - PF_GIVEN_GATE) <= half, (np.mean(estimates), half)


def test_bad_gates_are_refused_by_name():
    with pytest.raises(ValueError, match="gate"):
        _run(1, gate=3.0)
    with pytest.raises(ValueError, match="gate: returned 1 verdicts"):
        _run(1, gate=lambda u: np.array([True]), n_per_level=100)
    with pytest.raises(ValueError, match="gate: passed"):
        _run(1, gate=lambda u: u[:, 0] > 5.0, n_per_level=100)
    # adaptive conditional sampling under-covers behind a gate (82 of 100 seeds on this
    # wedge, its mean 0.63 of the reference; 60 of 60 on the parallel system): refused
    with pytest.raises(ValueError, match="mcmc='acs' is not supported behind a gate"):
        _run(1, mcmc="acs", n_per_level=100)


class _Counter:
    """Model calls counted outside the function's fingerprint (its repr never changes)."""

    runs = 0

    def __repr__(self) -> str:
        return "_Counter()"


_CALLS = _Counter()


def _counted(x1, x2):
    _CALLS.runs += np.size(x1)
    return _g(x1, x2)


@pytest.mark.e2e
def test_resumes_from_its_store(tmp_path):
    """A second call with the same gate and store reads every run back (the model is not
    called again) and gives the same answer; the report names the gate by its qualified
    name."""
    model = FunctionModel(_counted, ["x1", "x2"], ["g"], name="counted_offset")
    _CALLS.runs = 0

    def run():
        return failure_probability(model, standard_normal_space(2), "g", method="subset",
                                   rng=7, executor="serial", gate=_gate, n_per_level=200,
                                   second_walk="never", store=tmp_path / "walk")

    first = run()
    n_first = _CALLS.runs
    again = run()
    assert n_first > 200 and _CALLS.runs == n_first
    assert float(again["pf"]) == float(first["pf"])
    assert "test_subset_gate._gate" in first.attrs["settings"]


@pytest.mark.e2e
def test_a_walk_at_a_lower_level_reuses_the_runs_it_shares(tmp_path):
    """Same seed, same store, two levels of ``y = u1``: the walk to 3.0 makes the same
    designs as the walk to 3.5 until its threshold passes 3.0 (the thresholds are quantiles
    of y, whatever the level), so it reads every run back; its answer is bit for bit that
    of a walk at 3.0 without a store. The stored chunks are model outputs tied to their
    inputs by the design's digest, not to the limit state."""
    from gearuq.failure.modes import LimitState

    model = FunctionModel(_counted_y, ["x1", "x2"], ["y"], name="exceedance")
    _CALLS.runs = 0

    def walk(level, store):
        return failure_probability(model, standard_normal_space(2), LimitState.upper(
            "y", level), method="subset", rng=11, executor="serial", n_per_level=300,
            gate=_gate, second_walk="never", **({"store": store} if store else {}))

    deep = walk(3.5, tmp_path / "walk")
    after_deep = _CALLS.runs
    shallow = walk(3.0, tmp_path / "walk")
    assert _CALLS.runs == after_deep  # nothing ran again
    fresh = walk(3.0, None)
    assert float(shallow["pf"]) == float(fresh["pf"]) > float(deep["pf"])
    assert shallow.sizes["level"] < deep.sizes["level"]


def _counted_y(x1, x2):
    _CALLS.runs += np.size(x1)
    return np.asarray(x1, float) + 0.0 * np.asarray(x2, float)
