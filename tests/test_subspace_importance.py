"""Importance sampling moved in a few directions behind a gate (gearuq.failure.methods.subspace).

Oracles: a linear limit state in 50 dimensions of which 2 matter, with a gate that truncates
one of them across the design point, so ``P(F and gate)`` is a one-dimensional integral
(quadrature, no sampling); and a crude count at a moderate level.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from gearuq.failure.methods.subspace import (
    fit_subspace_density,
    gate_probability,
    gated_batch,
    given_gate,
    subspace_density,
    subspace_estimate,
)

DIM = 50


def _problem(b: float, c: float):
    """``F = {u1 + u2 >= b}``, gate ``{u1 <= c}``; exact P(F and gate) and P(gate)."""
    def limit(u):
        return b - u[:, 0] - u[:, 1], np.ones(len(u), bool)

    def gate(u):
        return u[:, 0] <= c

    joint = integrate.quad(lambda x: stats.norm.pdf(x) * stats.norm.sf(b - x), -np.inf, c,
                           epsabs=0.0, epsrel=1e-10)[0]
    return limit, gate, joint, stats.norm.cdf(c)


def _basis() -> np.ndarray:
    basis = np.zeros((DIM, 3))
    basis[0, 0] = basis[1, 1] = basis[7, 2] = 1.0  # u8 does not matter: CE must leave it
    return basis


@pytest.mark.e2e
def test_rare_gated_linear_limit_intervals_hold_the_quadrature():
    """b = 6, gate u1 <= 2.5 (through the unconstrained design point (3, 3)): P(F | gate)
    = 2.04e-6 exactly
    (1.1e-5 untruncated); 20 seeds of CE + 2000 fresh draws; the 95 % intervals hold it in
    at least 17 of 20 (P(<= 16 of 20) = 1.6 % for a true 95 % interval)."""
    limit, gate, joint, p_gate = _problem(6.0, 2.5)
    exact = joint / p_gate
    assert 2.0e-6 < exact < 2.1e-6
    held, estimates = 0, []
    for seed in range(20):
        dens, info = fit_subspace_density(limit, _basis(), n_per_level=400, seed=seed,
                                          gate=gate)
        assert info["reached"] and info["runs"] < 400 * len(info["levels"])  # gate saves runs
        est = subspace_estimate(limit, dens, n=2000, seed=seed, gate=gate)
        assert est["status"] == 0, est["message"]
        assert est["max_share"] < 0.1 and est["ess"] > 50  # 50-D, weights not degenerate
        res = given_gate(est, p_gate, 0.0)
        held += res["lower"] <= exact <= res["upper"]
        estimates.append(res["pf"])
    assert held >= 17
    # the estimator is unbiased: the mean of 20 within 3 standard errors of the exact value
    mean, se = np.mean(estimates), np.std(estimates, ddof=1) / math.sqrt(20)
    assert abs(mean - exact) < 3.0 * se


@pytest.mark.e2e
def test_moderate_level_against_a_crude_count():
    """b = 2, gate u1 <= 0.5: the estimate and a crude count of 400 000 draws agree."""
    limit, gate, _, _ = _problem(2.0, 0.5)
    dens, _ = fit_subspace_density(limit, _basis(), n_per_level=300, seed=3, gate=gate)
    est = subspace_estimate(limit, dens, n=3000, seed=4, gate=gate)
    p_gate, se_gate = gate_probability(gate, DIM, n=400_000, seed=11)
    res = given_gate(est, p_gate, se_gate)
    u = np.random.default_rng(12).standard_normal((400_000, DIM))
    inside = gate(u)
    count = np.mean(limit(u[inside])[0] <= 0.0)
    se = math.hypot(math.sqrt(count * (1 - count) / inside.sum()), est["cov"] * res["pf"])
    assert abs(res["pf"] - count) < 3.5 * se


def test_mixture_of_the_levels_is_unbiased_too():
    """``keep_levels``: one component per cross-entropy level, weights still at most 10;
    the estimate at a moderate level agrees with the quadrature."""
    limit, gate, joint, _ = _problem(4.0, 1.5)
    dens, info = fit_subspace_density(limit, _basis(), n_per_level=300, seed=5, gate=gate,
                                      keep_levels=True)
    assert dens.means.shape[0] == len(info["levels"]) > 1
    est = subspace_estimate(limit, dens, n=3000, seed=6, gate=gate)
    assert est["status"] == 0, est["message"]
    assert abs(est["pf"] - joint) < 3.5 * est["cov"] * est["pf"]


def test_weights_depend_on_the_subspace_only_and_are_bounded():
    basis = _basis()
    dens = subspace_density(basis, np.array([3.0, 3.0, 0.0]), np.diag([0.3, 0.3, 1.0]) ** 2,
                            0.1)
    u = dens.sample(5000, np.random.default_rng(1))
    w = np.exp(dens.log_weights(u))
    assert w.max() <= 1.0 / 0.1 * (1 + 1e-12)
    moved = u.copy()
    moved[:, 20:] = np.random.default_rng(2).standard_normal((5000, DIM - 20))
    np.testing.assert_allclose(np.exp(dens.log_weights(moved)), w, rtol=1e-9)
    # E_h[w] = 1: the density integrates the input law
    assert np.mean(w) == pytest.approx(1.0, abs=4 * np.std(w) / math.sqrt(5000))


def test_draws_outside_the_gate_cost_no_run():
    calls = []

    def limit(u):
        calls.append(len(u))
        return 1.0 - u[:, 0], np.ones(len(u), bool)

    dens = subspace_density(_basis(), np.zeros(3), np.eye(3), 0.1)
    bt = gated_batch(limit, dens, 1000, 5, gate=lambda u: u[:, 1] > 0.0)
    assert calls == [int(bt["runs"])] and 400 < bt["runs"] < 600
    assert not np.any(bt["fail"] & (bt["u"][:, 1] <= 0.0))


def test_bad_input_names_the_parameter():
    with pytest.raises(ValueError, match="defensive"):
        subspace_density(_basis(), np.zeros(3), np.eye(3), 0.0)
    with pytest.raises(ValueError, match="orthonormal"):
        subspace_density(2.0 * _basis(), np.zeros(3), np.eye(3), 0.1)
    with pytest.raises(ValueError, match="n_per_level"):
        fit_subspace_density(lambda u: (u[:, 0], np.ones(len(u), bool)), _basis(),
                             n_per_level=5, seed=0)


@pytest.mark.e2e
def test_markov_lower_bound_holds_where_the_interval_does_not():
    """A density centred on only one of two failure modes (F = {|u1 + u2| >= 4.6} in 50-D,
    the moved component at (+3.3, +3.3), 2 % defensive, 200 draws): the estimate is about
    half the exact P = 2 sf(4.6 / sqrt 2) and the two-sided interval misses it in nearly
    every seed (290 of 300 when written), even where the weights look healthy (status 0 in
    56, 49 of them missing): no weight diagnostic sees a mode the draws never reach. The
    one-sided ``lower_one_sided`` = 0.05 pf_hat stays below P in at least 95 % of the seeds
    (299 of 300), as Markov's inequality promises for any unbiased non-negative estimate;
    through ``given_gate`` it is divided by P(gate)'s upper end."""
    b = 4.6
    exact = 2.0 * stats.norm.sf(b / math.sqrt(2.0))

    def limit(u):
        return b - np.abs(u[:, 0] + u[:, 1]), np.ones(len(u), bool)

    basis = np.zeros((DIM, 2))
    basis[0, 0] = basis[1, 1] = 1.0
    dens = subspace_density(basis, np.array([3.3, 3.3]), np.eye(2), defensive=0.02)
    missed, below = 0, 0
    for seed in range(300):
        est = subspace_estimate(limit, dens, n=200, seed=seed, batch=200)
        assert est["lower_one_sided"] == pytest.approx(0.05 * est["pf"], rel=1e-12)
        missed += not est["lower"] <= exact <= est["upper"]
        below += est["lower_one_sided"] <= exact
    assert missed >= 150  # the case is hard: the CLT interval misses in most seeds
    assert below >= 285  # 95 % of 300
    res = given_gate(est, 0.5, 0.01)
    z = stats.norm.isf(0.025)
    assert res["lower_one_sided"] == pytest.approx(est["lower_one_sided"] / (0.5 + z * 0.01))


def _annulus(r: float, b: float):
    """``F = {u1^2 + u2^2 >= r^2 and u3 >= b}``: an annulus in the (u1, u2) plane, whatever
    the phase, times a half-line; P(F) = exp(-r^2 / 2) Phi(-b) (chi-square with 2 degrees
    of freedom), gate ``{u4 <= 1}`` independent of it."""
    def limit(u):
        g = np.maximum(r**2 - u[:, 0] ** 2 - u[:, 1] ** 2, b - u[:, 2])
        return g, np.ones(len(u), bool)

    def gate(u):
        return u[:, 3] <= 1.0

    return limit, gate, math.exp(-0.5 * r**2) * stats.norm.sf(b)


@pytest.mark.e2e
def test_centred_group_reaches_every_phase_of_an_annulus():
    """r^2 = 2 ln 1000 and b = 3.09: P(F | gate) = 1.0e-6 in 50 dimensions. With the
    (u1, u2) plane a centred group, cross-entropy inflates the variance there and shifts u3;
    over 20 seeds of CE + 2000 draws, at least 17 intervals of 20 hold the exact value and
    the estimates average to it; a mean shift alone fits one phase (its plane mean far from
    0): one phase of the annulus."""
    r, b = math.sqrt(2.0 * math.log(1000.0)), 3.09
    limit, gate, exact = _annulus(r, b)
    basis = np.zeros((DIM, 3))
    basis[0, 0] = basis[1, 1] = basis[2, 2] = 1.0
    held, estimates = 0, []
    for seed in range(20):
        dens, info = fit_subspace_density(limit, basis, n_per_level=400, seed=seed,
                                          gate=gate, centred=[[0, 1]])
        assert info["reached"] and np.allclose(info["mean"][:2], 0.0)
        assert info["cov"][0, 0] == pytest.approx(info["cov"][1, 1]) and info["cov"][0, 0] > 2
        est = subspace_estimate(limit, dens, n=2000, seed=seed, gate=gate)
        res = given_gate(est, stats.norm.cdf(1.0), 0.0)
        held += res["lower"] <= exact <= res["upper"]
        estimates.append(res["pf"])
    assert held >= 17
    mean = float(np.mean(estimates))
    assert abs(mean - exact) < 3.0 * np.std(estimates) / math.sqrt(20)
    _, shifted = fit_subspace_density(limit, basis, n_per_level=400, seed=0, gate=gate)
    assert np.hypot(*shifted["mean"][:2]) > 2.0


def test_centred_groups_are_checked():
    basis = np.eye(DIM)[:, :3]
    limit, gate, _ = _annulus(3.0, 1.0)
    for bad in ([[0, 3]], [[0, 1], [1, 2]], [[]]):
        with pytest.raises(ValueError, match="centred"):
            fit_subspace_density(limit, basis, n_per_level=40, seed=0, centred=bad)


@pytest.mark.e2e
def test_status_0_is_no_coverage_guarantee_off_the_design_point():
    """Measured, not mended (docs/reliability.md, "What status 0 does not promise"): on the
    tilted half-space F = {u1 + u2 >= 4.5} (exact sf(4.5 / sqrt 2) = 7.3e-4) the density
    moved to the design point (2.25, 2.25) gives 95 % intervals that hold the exact value in
    294 of 300 seeds (600 draws each), all status 0. Moved to (2.6, 1.2) instead, off the
    design point but reaching the whole failure set (weights bounded by 1 / 0.3), the
    status-0 intervals hold it in 244 of 266 (92 %; 34 runs flagged): the runs that did not
    draw the rare heavy weights read low with tight intervals and healthy diagnostics (the
    effective sample size is then high, not low). A second method that shares no estimator
    code is what vouches at the rare level; this test pins the measured gap so that a
    better interval shows here."""
    b = 4.5
    exact = stats.norm.sf(b / math.sqrt(2.0))
    basis = np.eye(4)[:, :2]  # the weight depends on the moved coordinates only

    def limit(u):
        return b - u[:, 0] - u[:, 1], np.ones(len(u), bool)

    held = {}
    for name, mean in (("design point", (2.25, 2.25)), ("off it", (2.6, 1.2))):
        dens = subspace_density(basis, np.array(mean), np.eye(2), defensive=0.3)
        hits, status0 = 0, 0
        for seed in range(300):
            est = subspace_estimate(limit, dens, n=600, seed=seed, batch=600)
            if est["status"] == 0:
                status0 += 1
                hits += est["lower"] <= exact <= est["upper"]
        held[name] = (hits, status0)
    hits, status0 = held["design point"]
    assert status0 == 300 and hits >= 276  # 92 % of 300
    hits, status0 = held["off it"]
    assert status0 >= 200 and hits / status0 <= 0.93


@pytest.mark.e2e
def test_min_ess_flags_runs_the_weight_diagnostics_pass():
    """``min_ess``: a run whose weight diagnostics give status 0 or 1 but that rests on
    fewer effective failing draws than ``min_ess`` gets status 3 and says so with both
    numbers; the estimate and its interval are unchanged, and a run above the threshold
    keeps its status."""
    b = 4.5
    basis = np.eye(4)[:, :2]

    def limit(u):
        return b - u[:, 0] - u[:, 1], np.ones(len(u), bool)

    dens = subspace_density(basis, np.array([2.6, 1.2]), np.eye(2), defensive=0.3)
    seen = {"below": False, "above": False}
    for seed in range(40):
        plain = subspace_estimate(limit, dens, n=600, seed=seed, batch=600)
        strict = subspace_estimate(limit, dens, n=600, seed=seed, batch=600, min_ess=30.0)
        assert strict["pf"] == plain["pf"] and strict["upper"] == plain["upper"]
        if plain["status"] in (0, 1) and plain["ess"] < 30.0:
            assert strict["status"] == 3 and "min_ess = 30" in strict["message"]
            assert f"{plain['ess']:.1f} effective failing draws" in strict["message"]
            seen["below"] = True
        else:
            assert strict["status"] == plain["status"]
            seen["above"] |= plain["status"] == 0
    assert all(seen.values()), seen
