"""The relief_design study: the design space it builds and the acceptance probability it
divides by, checked against the rotor (its quick mode end to end: tests/test_studies.py)."""

from __future__ import annotations

import numpy as np
import pytest

import gearuq
from gearuq import registry
from gearuq.design import space_at
from gearuq.failure.intervals import clopper_pearson_interval


def test_relief_space_moves_the_tolerance_band_with_the_design():
    from gearuq_studies import relief_design as study

    problem = study.design_problem(study.SEARCH_OPTIONS)
    sp = space_at(problem.space, problem.variables, [10.0, 6.0, 8.0])
    amount, length = sp.marginal("tip_relief_amount"), sp.marginal("tip_relief_length")
    crowning = sp.marginal("lead_crowning")
    assert (amount.params["lower"], amount.params["upper"]) == pytest.approx(
        (10.0 - study.AMOUNT_TOL, 10.0 + study.AMOUNT_TOL))
    assert (length.params["lower"], length.params["upper"]) == pytest.approx(
        (6.0 - study.LENGTH_TOL, 6.0 + study.LENGTH_TOL))
    assert (crowning.params["lower"], crowning.params["upper"]) == pytest.approx(
        (8.0 - study.CROWNING_TOL, 8.0 + study.CROWNING_TOL))
    # the box keeps every drawn crowning within the rotor's range (no hollow crown)
    assert study.CROWNING_BOUNDS[0] - study.CROWNING_TOL >= 0.0
    # the load spread and the 58 pitch normals do not move with the design
    assert sp.marginal("torque").mean() == pytest.approx(1000.0)
    assert len(sp.names) == 3 + 1 + 58
    # the inspected law is the search's and the confirmation's
    assert problem.model_options["pitch_tolerance_law"] == "capable_process"
    assert study.CONFIRM_OPTIONS["pitch_tolerance_law"] == "capable_process"


@pytest.mark.e2e
def test_acceptance_probability_the_study_divides_by():
    """P(both gears pass) = 0.95^2 under the capable process, counted on the rotor's own
    acceptance margin (pitch only: no dynamics solved)."""
    from gearuq_studies import relief_design as study

    model = study.rotor(6)
    n = 2000
    x = gearuq.ParameterSpace({f"pitch_xi_{g}_{k}": {"dist": "normal", "mean": 0.0,
                                                      "std": 1.0}
                               for g in ("p", "g") for k in range(1, 30)}).sample(
        n, rule="random", rng=11)
    ds = model.response(x, None, outputs=["pitch_acceptance_margin"],
                        **study.SEARCH_OPTIONS)
    k = int(np.sum(ds["pitch_acceptance_margin"].values >= 0))
    lo, up = clopper_pearson_interval(k, n, 0.999)
    assert lo <= study.P_PASS <= up, (k / n, lo, up)
    assert study.given_pass(study.P_PASS / 2) == pytest.approx(0.5)


def test_bad_settings_name_the_setting(tmp_path):
    study = registry.get_study("relief_design")
    with pytest.raises(ValueError, match="seed=-1"):
        study(out=tmp_path, seed=-1)
    with pytest.raises(ValueError, match="grade=8"):
        study(out=tmp_path, grade=8)
    with pytest.raises(ValueError, match="scale=0"):
        study(out=tmp_path, scale=0)
