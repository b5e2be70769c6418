"""The helical-pair rare-event case and how its references are made: the case's definition,
the reference runs' peak against the limit state the methods see, the bounded weights and
the summary's estimators against hand counts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearuq.testing import helical_pair_reference as hr
from gearuq.testing.reliability_problems import (
    HELICAL_PAIR_GRID_LEVEL,
    HELICAL_PAIR_LEVEL,
    HELICAL_PAIR_PF,
    HELICAL_PAIR_PF_INTERVAL,
    helical_pair_problem,
)


def test_cases_and_their_references():
    peak, grid = helical_pair_problem(), helical_pair_problem("grid")
    assert peak["limit_state"].first_passage == "parabola"
    assert grid["limit_state"].first_passage == "grid"
    assert np.allclose(np.diff(peak["t"]), 0.05) and grid["t"].size == 201
    lo, up = HELICAL_PAIR_PF_INTERVAL
    assert lo < HELICAL_PAIR_PF < up and peak["pf"] == HELICAL_PAIR_PF
    assert grid["pf_interval"][0] < grid["pf"] < grid["pf_interval"][1]
    with pytest.raises(ValueError, match="variant"):
        helical_pair_problem("fine")


def test_reference_peaks_are_the_limit_states_of_both_cases():
    """``peaks`` (what the references count) equals level - g of the limit states the methods
    evaluate, for the peak case and for the grid case on its own 201 instants."""
    from gearuq.failure.evaluator import LimitStateEvaluator

    u = np.random.default_rng(5).standard_normal((6, 6)) + np.array([2.2, 2.3, 0, 0, 0, 0])
    got = hr.peaks(u)
    for variant, key, level in (("peak", "peak", HELICAL_PAIR_LEVEL),
                                ("grid", "grid", HELICAL_PAIR_GRID_LEVEL)):
        p = helical_pair_problem(variant)
        ev = LimitStateEvaluator(p["model"], p["space"], p["limit_state"], p["t"],
                                 executor="serial")
        np.testing.assert_allclose(level - ev.evaluate(u, "t")["g"], got[key], rtol=0,
                                   atol=1e-6)
    assert np.all(got["peak"] >= got["grid"]) and np.all(got["status"] == 0)


def test_bounded_weights_and_the_summary_estimators(tmp_path):
    rng = np.random.default_rng(1)
    u = rng.standard_normal((5000, 6)) * 2.0 + 1.0
    lw = hr.is_log_weights(u)
    assert lw.max() <= math.log(2.0) + 1e-12
    # against the two densities written out
    phi = np.exp(-0.5 * np.sum(u * u, axis=1))
    q = np.exp(-0.5 * np.sum(((u - hr.IS_MEAN) / hr.IS_STD) ** 2, axis=1)) / np.prod(hr.IS_STD)
    np.testing.assert_allclose(np.exp(lw), phi / (0.5 * phi + 0.5 * q), rtol=1e-10)
    # crude: 3 failures of 2000 at the level (one of them invalid), Clopper-Pearson
    from gearuq.failure.intervals import binomial_interval

    peak = np.full(2000, 76000.0)
    peak[:4] = 76300.0
    status = np.zeros(2000, np.int8)
    status[3] = 3
    np.savez(tmp_path / "s1_c0000.npz", u=np.zeros((2000, 6)), peak=peak, status=status)
    w = np.full(2000, 0.5)
    np.savez(tmp_path / "is1_n2000.npz", u=np.zeros((2000, 6)), peak=peak, status=status,
             log_w=np.log(w))
    res = hr.summary(tmp_path, {"peak": 76220.0})
    crude = res["crude/peak"]
    assert crude["failures"] == 3 and crude["invalid"] == 1
    lo, up = binomial_interval(3, 2000, 0.95, "clopper-pearson")
    assert crude["lower"] == pytest.approx(float(lo)) and crude["upper"] == pytest.approx(up)
    assert res["is/peak"]["pf"] == pytest.approx(3 * 0.5 / 2000)
