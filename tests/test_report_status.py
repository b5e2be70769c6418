"""Statuses people can read: the IntEnum, the words, FORM's one sentence, a PCE that is not
usable carried into every result built on it."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

import gearuq
from gearuq.engines.pce.surrogate import STATUS_SURROGATE_NOT_USABLE
from gearuq.failure.report import (
    REPORT_STATUS,
    STATUS_TEXT,
    ReportStatus,
    describe_status,
)


def test_enum_keeps_the_integer_codes_and_their_words() -> None:
    assert [int(s) for s in ReportStatus] == list(range(10))
    assert {int(s): s.name.lower() for s in ReportStatus} == REPORT_STATUS
    assert ReportStatus(3) == 3 and ReportStatus.WEIGHTS_DEGENERATE.meaning == STATUS_TEXT[3]
    assert ReportStatus.SURROGATE_NOT_USABLE == STATUS_SURROGATE_NOT_USABLE
    assert describe_status(4) == "status 4: " + STATUS_TEXT[4]
    with pytest.raises(ValueError, match="valid codes"):
        describe_status(42)


def _parabola(u1, u2):
    return 3.0 - u2 - 0.3 * u1**2


def test_report_carries_its_words_and_describe_status_renders_them() -> None:
    model = gearuq.FunctionModel(_parabola, ["u1", "u2"], ["g"], name="parabola_words")
    space = gearuq.ParameterSpace.normal(u1=(0, 1), u2=(0, 1))
    rep = gearuq.failure_probability(model, space, "g", method="mc", n_samples=100, rng=1,
                                     executor="serial")
    # 100 samples at pf ~ 2e-3: usually no failure at all -> status 4, an upper bound
    code = int(rep["status"])
    assert rep.attrs["status_text"] == f"status {code}: {STATUS_TEXT[code]}"
    assert json.loads(rep.attrs["status_meanings"])[str(code)] == STATUS_TEXT[code]
    line = describe_status(rep)
    assert line.startswith(f"status {code}: {STATUS_TEXT[code]}")
    if code:
        assert rep.attrs["message"] in line


def test_form_without_a_design_point_says_why_in_one_sentence() -> None:
    model = gearuq.FunctionModel(_parabola, ["u1", "u2"], ["g"], name="parabola_form")
    space = gearuq.ParameterSpace.normal(u1=(0, 1), u2=(0, 1))
    rep = gearuq.failure_probability(model, space, "g", method="form", rng=2, max_iter=1,
                                     executor="serial")
    msg = rep.attrs["message"]
    assert int(rep["status"]) == 1 and not np.isfinite(float(rep["pf"]))
    assert msg.count("FORM found no design point") == 1
    assert "not converged" not in msg
    assert "13 ran out of max_iter=1" in msg and "subset" in msg
    assert msg.count(";") == 1 and len(msg) < 400, msg


def _wiggly(x1, x2):
    return np.sin(9.0 * x1) * np.cos(7.0 * x2)


def _smooth(x1, x2):
    return 1.0 + x1 + 0.5 * x2**2


@pytest.mark.parametrize("fn, usable", [(_smooth, True), (_wiggly, False)])
def test_unusable_pce_sets_status_in_sobol_reliability_and_reports(fn, usable) -> None:
    space = gearuq.ParameterSpace.normal(x1=(0, 1), x2=(0, 1))
    model = gearuq.FunctionModel(fn, ["x1", "x2"], ["y"], name=f"pce_{fn.__name__}")
    ds = gearuq.monte_carlo(model, space, n_samples=64, rule="sobol", rng=4,
                            executor="serial")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pce = gearuq.PolynomialChaos(space, order=3).fit(ds)
    loo = pce.corrected_loo_error["y"]
    # the oracle: a degree-3 chaos reproduces the quadratic exactly, and cannot follow
    # sin(9 x1) cos(7 x2), whose variance sits in degrees far above 3
    assert (loo < 1e-8) if usable else (loo > 0.5)
    code, message = pce.surrogate_status()
    assert code == (0 if usable else 9)
    assert any("not usable" in str(w.message) for w in caught) == (not usable)
    sob = pce.sobol("y")
    rel = pce.reliability(gearuq.Band("y", upper=0.9), n_samples=2000, rng=1)
    for result in (sob, rel):
        assert result.attrs["status"] == code
        assert ("not usable" in result.attrs["status_text"]) == (not usable)
    rep = gearuq.failure_probability(pce, space, gearuq.Band("y", upper=0.9), method="mc",
                                     n_samples=2000, rng=1, executor="serial")
    reasons = [r["status"] for r in json.loads(rep.attrs["status_reasons"])]
    assert (9 in reasons) == (not usable)
    if not usable:
        assert "not usable" in rep.attrs["message"]
