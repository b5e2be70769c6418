"""Censored runs in subset simulation: a model status under which the output is only a lower
bound of the response (the geared rotor's peak located from below, status 21), named by the
limit state's ``censored_statuses``.

Oracle: the response ``y = u1`` of two standard normals, failure ``y >= beta`` (``pf =
Phi(-beta)``). Over a band of the inputs (``u2 > BAND``, 6.7 % of the law) the model reports
``y - gap`` with a nonzero status: a lower bound of the true response. With ``gap = 0`` the bound
is the true value, so a walk that reads censored runs at their bound must be the walk of the
model without censoring, bit for bit. Read as failed instead (the reading of any other invalid
run), the band's runs seed every level and the walk's interval is wide.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from gearuq.failure.api import failure_probability
from gearuq.failure.evaluator import LimitStateEvaluator
from gearuq.failure.modes import LimitState
from gearuq.model import Evaluation, FunctionModel
from gearuq.testing.problems import standard_normal_space

BETA, BAND, CENSORED = 3.5, 1.5, 16
PF = float(stats.norm.sf(BETA))


class _BandCensored(FunctionModel):
    """``y = x1``; where ``x2 > BAND`` the run says status 16 and reports ``x1 - gap``."""

    def __init__(self, gap: float, status: int = CENSORED) -> None:
        super().__init__(lambda x1, x2: x1 + 0.0 * x2, ["x1", "x2"], ["y"],
                         name="band_censored")
        self.gap, self.code = gap, status

    def _evaluate(self, params, t, outputs, **options):
        x1 = np.asarray(params["x1"], float)
        band = np.asarray(params["x2"], float) > BAND
        y = np.where(band, x1 - self.gap, x1)
        status = np.where(band, self.code, 0).astype(np.int8)
        return Evaluation(data={"y": y}, status=status,
                          status_meanings={self.code: "peak_located_from_below"})


def _walk(model, limit_state, seed=7, n=500):
    return failure_probability(model, standard_normal_space(2), limit_state, method="subset",
                               rng=seed, executor="serial", n_per_level=n,
                               second_walk="never")


def test_a_bound_equal_to_the_truth_makes_the_uncensored_walk_bit_for_bit():
    exact = _walk(FunctionModel(lambda x1, x2: x1 + 0.0 * x2, ["x1", "x2"], ["y"]),
                  LimitState.upper("y", BETA))
    read = _walk(_BandCensored(gap=0.0),
                 LimitState.upper("y", BETA, censored_statuses=[CENSORED]))
    assert float(read["pf"]) == float(exact["pf"])
    np.testing.assert_array_equal(read["level_threshold"], exact["level_threshold"])
    assert float(read["pf_lower"]) <= PF <= float(read["pf_upper"])
    # the runs stay invalid and flagged, and the report says how they were read
    assert int(read["status"]) == 6
    assert int(read["n_invalid"]) >= int(read["n_censored"]) > 0
    assert "censored" in read.attrs["message"] and "read at that bound" in read.attrs["message"]
    assert int(read["level_censored_left_out"].sum()) > 0


def test_read_as_failed_the_band_takes_the_walk_and_read_at_the_bound_it_does_not():
    model = _BandCensored(gap=0.5)
    failed = _walk(model, LimitState.upper("y", BETA))
    bound = _walk(model, LimitState.upper("y", BETA, censored_statuses=[CENSORED]))
    # read as failed, the band's runs (6.7 % of the law) are below every threshold: the
    # reading that counts them as failed is the band's probability, not Phi(-beta)
    assert float(failed["pf_upper"]) > 20 * PF
    # read at its bound, the walk follows y: its interval holds the true pf and is narrow;
    # the band's failures with x1 in [beta, beta + gap) are missed, 1 % of pf here
    assert float(bound["pf_lower"]) <= PF <= float(bound["pf_upper"])
    assert float(bound["pf_upper"]) < 3 * PF
    assert float(bound["pf_upper"]) < float(failed["pf_upper"]) / 5
    assert int(bound["status"]) == 6 and "may be low" in bound.attrs["message"]


def test_a_bound_at_or_below_zero_is_a_failure_counted_as_valid():
    """Every failing run censored (the band covers the failure set): pf is not zeroed by
    the invalid share, since each such run fails whatever its true value."""
    model = _BandCensored(gap=0.0)
    rep = failure_probability(model, standard_normal_space(2),
                              LimitState.upper("y", 2.0,
                                               censored_statuses=[CENSORED]),
                              method="subset", rng=3, executor="serial", n_per_level=500,
                              second_walk="never")
    # y >= 2 fails (2.3 %); the censored failing runs (x2 > 1.5) count among the failures
    want = float(stats.norm.sf(2.0))
    assert float(rep["pf_lower"]) <= want <= float(rep["pf_upper"])


def test_an_undeclared_status_is_not_censored_and_nonfinite_outputs_never_are():
    model = _BandCensored(gap=0.0, status=17)
    ev = LimitStateEvaluator(model, standard_normal_space(2),
                             LimitState.upper("y", BETA, censored_statuses=[CENSORED]),
                             engine="test", executor="serial")
    u = np.array([[0.0, 0.0], [1.0, 2.0]])
    res = ev.evaluate(u, "t0")
    assert np.isnan(res["g_bound"]).all() and ev.n_censored == 0
    ev2 = LimitStateEvaluator(_BandCensored(gap=0.25), standard_normal_space(2),
                              LimitState.upper("y", BETA, censored_statuses=[CENSORED]),
                              engine="test", executor="serial")
    res = ev2.evaluate(u, "t1")
    assert np.isnan(res["g"][1]) and res["status"][1] == CENSORED
    assert res["g_bound"][1] == pytest.approx(BETA - (1.0 - 0.25))
    assert np.isnan(res["g_bound"][0]) and ev2.n_censored == 1
    assert ev2.is_censored(u).tolist() == [False, True]
    # a component's view reads no bound, so none of its points is censored
    view = ev2.component(0)
    res = view.evaluate(u, "t1")
    assert np.isnan(res["g_bound"]).all() and view.is_censored(u).tolist() == [False, False]


@pytest.mark.parametrize("bad", [[0], ["21"], [True], [300], 2.5])
def test_censored_statuses_refused_by_name(bad):
    with pytest.raises(ValueError, match="censored_statuses"):
        LimitState.upper("y", 1.0, censored_statuses=bad)


def test_the_definition_records_the_censored_statuses():
    ls = LimitState.upper("kv_max", 3.0, censored_statuses=(21, 21))
    assert ls.to_dict()["censored_statuses"] == [21]
    assert "censored_statuses" not in LimitState.upper("kv_max", 3.0).to_dict()


@pytest.mark.e2e
def test_read_at_the_bound_the_intervals_hold_over_seeds():
    """20 seeds, gap 0.5: at least 18 intervals hold Phi(-beta) (measured: 59 of 60 seeds,
    the estimates' mean 1.18 times it)."""
    model = _BandCensored(gap=0.5)
    ls = LimitState.upper("y", BETA, censored_statuses=[CENSORED])
    reps = [_walk(model, ls, seed=100 + k) for k in range(20)]
    held = sum(float(r["pf_lower"]) <= PF <= float(r["pf_upper"]) for r in reps)
    assert held >= 18, held
    # the mean of the estimates is not far below the truth (the missed band is 1 % of it)
    assert 0.5 < np.mean([float(r["pf"]) for r in reps]) / PF < 2.0


def test_a_widened_cheap_model_moves_a_censored_bound_with_its_g():
    """MFIS's widened cheap model (``g - delta``) shifts a censored run's bound alike, so the
    walk on it reads the bound of the widened set, not of the original one."""
    from gearuq.failure.methods.biasing import Widened

    ev = LimitStateEvaluator(_BandCensored(gap=0.25), standard_normal_space(2),
                             LimitState.upper("y", BETA, censored_statuses=[CENSORED]),
                             engine="test", executor="serial")
    res = Widened(ev, 0.5).evaluate(np.array([[0.0, 0.0], [1.0, 2.0]]), "w")
    assert np.isnan(res["g_bound"][0])
    assert res["g_bound"][1] == pytest.approx(BETA - (1.0 - 0.25) - 0.5)


def test_the_upper_end_counts_the_last_levels_censored_samples_read_safe_as_failed(
        monkeypatch):
    """The last level's censored samples whose bound lies above 0 may be failures: the
    interval's upper end is that of the reading counting them as failed, the walk's upper end
    times (failing + those) / failing, by the report's own level counts."""
    from gearuq.failure.methods import subset

    class NearFailure(FunctionModel):
        """``y = x1``; censored where ``x1 > 3.3`` and ``x2 > 0``, reporting ``x1 - 0.4``: a
        failing run with ``x1 < 3.9`` there reads safe on its bound."""

        def __init__(self) -> None:
            super().__init__(lambda x1, x2: x1 + 0.0 * x2, ["x1", "x2"], ["y"],
                             name="near_failure_censored")

        def _evaluate(self, params, t, outputs, **options):
            x1 = np.asarray(params["x1"], float)
            near = (x1 > 3.3) & (np.asarray(params["x2"], float) > 0.0)
            return Evaluation(data={"y": np.where(near, x1 - 0.4, x1)},
                              status=np.where(near, CENSORED, 0).astype(np.int8),
                              status_meanings={CENSORED: "peak_located_from_below"})

    model = NearFailure()
    limit = LimitState.upper("y", BETA, censored_statuses=[CENSORED])
    rep = _walk(model, limit, seed=1)
    left = int(rep["level_censored_left_out"].values[-1])
    assert left > 0 and float(rep["level_threshold"].values[-1]) == 0.0
    failing = float(rep["level_probability"].values[-1]) * 500
    monkeypatch.setattr(subset, "_censored_last_factor", lambda levels: 1.0)
    plain = _walk(model, limit, seed=1)
    assert float(plain["pf"]) == float(rep["pf"])  # the same walk, the same estimate
    np.testing.assert_allclose(float(rep["pf_upper"]),
                               float(plain["pf_upper"]) * (failing + left) / failing,
                               rtol=1e-12)
    assert f"{left} sample(s) of the last level were read safe" in rep.attrs["message"]


@pytest.mark.e2e  # five walks, 3 s of CPU
@pytest.mark.parametrize("setting", [{"second_walk": "always"}, {"replicates": 3}])
def test_pairs_and_replicates_count_every_walk_s_refusals(setting):
    """A pair reports the first walk's levels, replicates none: the per-walk counts carry the
    refusals of every walk, and they add up to the count the status words give."""
    import re

    from gearuq_studies.geared_rotor_dynamic_factor import _censored_refused

    rep = failure_probability(_BandCensored(gap=0.0), standard_normal_space(2),
                              LimitState.upper("y", BETA, censored_statuses=[CENSORED]),
                              method="subset", rng=7, executor="serial", n_per_level=300,
                              **({"second_walk": "never"} | setting))
    per_walk = rep["replicate_censored_left_out"].values
    assert per_walk.shape == (2 if "second_walk" in setting else 3,)
    assert (per_walk > 0).all()
    if "level_censored_left_out" in rep:  # the pair: the first walk's levels
        assert per_walk[0] == int(rep["level_censored_left_out"].sum())
    words = rep.attrs["message"]
    last = re.search(r"(\d+) sample\(s\) of the last level were read safe", words)
    earlier = re.search(r"(\d+) time\(s\) an earlier level refused", words)
    told = (int(last.group(1)) if last else 0) + (int(earlier.group(1)) if earlier else 0)
    assert told == per_walk.sum() == _censored_refused(rep)
