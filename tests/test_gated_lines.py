"""Radial line sampling behind a gate (:mod:`gearuq.failure.methods.gated_lines`).

The textbook case: a gated annulus. In 12 standard normal dimensions, failure is
``|(u0, u1)| >= R + c u2`` (a disc's exterior whose radius the complement moves) and the gate
``|(u0, u1)| <= R_g and u3 <= 1.5`` (known without the model: it cuts the failure set to an
annulus and rejects whole lines). The exact ``P(F and gate)`` is a 1-D quadrature over
``u2`` of ``exp(-r^2 / 2) - exp(-R_g^2 / 2)`` (the chi-2 survival), times ``Phi(1.5)``,
written here without the sampler.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from gearuq.failure.methods.gated_lines import gate_pieces, gated_line_sampling

R, C, R_GATE, D = 4.4, 0.15, 5.2, 12


def _limit(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return (R + C * u[:, 2]) - np.hypot(u[:, 0], u[:, 1]), np.ones(len(u), bool)


def _gate(u: np.ndarray) -> np.ndarray:
    return (np.hypot(u[:, 0], u[:, 1]) <= R_GATE) & (u[:, 3] <= 1.5)


def _exact() -> float:
    def inner(v: float) -> float:
        r = max(R + C * v, 0.0)
        if r >= R_GATE:
            return 0.0
        return (math.exp(-0.5 * r * r) - math.exp(-0.5 * R_GATE**2)) * stats.norm.pdf(v)

    total, _ = integrate.quad(inner, -12.0, (R_GATE - R) / C, epsabs=1e-16, limit=200)
    return total * stats.norm.cdf(1.5)


def _basis() -> np.ndarray:
    return np.eye(D)[:, :2]


@pytest.mark.e2e
def test_gated_annulus_intervals_hold_over_seeds():
    """20 seeds of 200 lines each: at least 18 of 20 95 % intervals hold the exact value,
    their mean is within 5 % of it, every run is vouched for (status 0), the lines cross
    once on each side, and a line whose origin the gate rejects costs no run."""
    exact = _exact()
    assert 1e-6 < exact < 1e-4  # a rare level
    held, means = 0, []
    for seed in range(20):
        res = gated_line_sampling(_limit, _basis(), n_lines=200, seed=seed, gate=_gate,
                                  root_tol=1e-4)
        held += res["lower"] <= exact <= res["upper"]
        means.append(res["pf"])
        assert res["status"] == 0 and "no weights" in res["message"], res["message"]
        # the annulus: two crossings, or none where R + c u2 >= R_g, on every line
        assert res["lines_by_crossings"][1] == res["lines_by_crossings"][3] == 0
        # u3 > 1.5 rejects a line whole: 6.7 % of the lines, none of them run
        assert 0 < res["lines_gated_out"] < 40
        assert res["runs"] < 200 * 40
    assert held >= 18
    assert np.mean(means) == pytest.approx(exact, rel=0.05)


def test_gate_pieces_are_the_gate_edges():
    """Along a line through the origin of the subspace, the accepted piece is
    ``[-R_g, R_g]`` to the bisection's tolerance; with u3 > 1.5 it is empty."""
    origins = np.zeros((2, D))
    origins[1, 3] = 2.0
    dirs = np.zeros((2, D))
    dirs[:, 0] = 0.6
    dirs[:, 1] = 0.8
    pieces = gate_pieces(_gate, origins, dirs, 8.0)
    assert pieces[1] == []
    ((a, b),) = pieces[0]
    assert a == pytest.approx(-R_GATE, abs=1e-8) and b == pytest.approx(R_GATE, abs=1e-8)


def test_an_invalid_run_is_flagged_and_read_both_ways():
    """Runs invalid where 1 < u3 (the gate lets u3 <= 1.5 through: 9 % of the lines lose
    every run): status 6, pf reads them as safe (low by about that share), the upper end
    as failed, so the interval still holds the exact value."""
    def limit(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        g, _ = _limit(u)
        return g, u[:, 3] <= 1.0

    res = gated_line_sampling(limit, _basis(), n_lines=200, seed=3, gate=_gate)
    assert res["status"] == 6 and "invalid" in res["message"]
    assert res["pf"] < _exact() <= res["upper"]


@pytest.mark.parametrize("kwargs, name", [({"n_lines": 1}, "n_lines"),
                                          ({"t_grid": np.array([1.0])}, "t_grid"),
                                          ({"root_tol": 0.0}, "root_tol")])
def test_bad_settings_are_refused_by_name(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gated_line_sampling(_limit, _basis(), **{"n_lines": 10, "seed": 0, **kwargs})
    with pytest.raises(ValueError, match="basis"):
        gated_line_sampling(_limit, np.ones((D, 2)), n_lines=10, seed=0)


@pytest.mark.e2e
def test_projected_normal_density_against_the_parabolic_cylinder_function():
    """``log PN(e; m)`` against ``Gamma(k) exp(b^2/4) D_-k(-b)`` (scipy's ``pbdv``, an
    independent special function), and its mean ratio to the uniform density over uniform
    directions is 1 (it is a probability density on the sphere)."""
    from scipy import special

    from gearuq.failure.methods.gated_lines import projected_normal_logpdf

    for k in (3, 10):
        for b in (-3.0, 0.0, 2.0, 5.0):
            mean, e = np.zeros(k), np.eye(k)[:1]
            mean[0] = b
            exact = (math.lgamma(k) + b * b / 4 + math.log(special.pbdv(-k, -b)[0])
                     - 0.5 * k * math.log(2 * math.pi) - 0.5 * b * b)
            assert projected_normal_logpdf(e, mean)[0] == pytest.approx(exact, abs=1e-9)
    k = 5
    w = np.random.default_rng(2).standard_normal((20_000, k))
    e = w / np.linalg.norm(w, axis=1, keepdims=True)
    log_uniform = math.lgamma(k / 2) - math.log(2) - k / 2 * math.log(math.pi)
    ratio = np.exp(projected_normal_logpdf(e, np.array([2.0, -1.0, 0.0, 0.5, 0.0]))
                   - log_uniform)
    assert np.mean(ratio) == pytest.approx(1.0, abs=4 * np.std(ratio) / math.sqrt(len(e)))


def _half_space(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return 4.5 - u[:, 0], np.ones(len(u), bool)


def _gate_u3(u: np.ndarray) -> np.ndarray:
    return u[:, 3] <= 1.5


@pytest.mark.e2e
def test_directions_drawn_towards_a_half_space_vouch_for_the_interval():
    """A half-space ``u0 >= 4.5`` behind the gate ``u3 <= 1.5`` (exact
    ``Phi(-4.5) Phi(1.5)``), radial lines in the 3-D subspace (u0, u1, u2): uniform
    directions leave 13-22 effective lines of 200 (status 3 in each of 20 seeds); drawn
    from the projected normal about (3, 0, 0) with 30 % uniform, 20 of 20 intervals hold,
    the mean is within 3 % of exact, every run has status 0, no weight exceeds 1 / 0.3."""
    exact = stats.norm.sf(4.5) * stats.norm.cdf(1.5)
    basis = np.eye(D)[:, :3]
    uniform = [gated_line_sampling(_half_space, basis, n_lines=200, seed=s, gate=_gate_u3,
                                   root_tol=1e-4) for s in range(20)]
    assert all(r["status"] == 3 and r["n_effective"] < 30 for r in uniform)
    drawn = [gated_line_sampling(_half_space, basis, n_lines=200, seed=s, gate=_gate_u3,
                                 root_tol=1e-4, direction_means=np.array([[3.0, 0.0, 0.0]]))
             for s in range(20)]
    assert all(r["status"] == 0 and r["max_weight"] <= 1 / 0.3 for r in drawn)
    # a weighted run's message says its terms carry weights, an unweighted one says none
    assert all("weights at most" in r["message"] for r in drawn)
    assert sum(r["lower"] <= exact <= r["upper"] for r in drawn) >= 18
    assert np.mean([r["pf"] for r in drawn]) == pytest.approx(exact, rel=0.03)
    with pytest.raises(ValueError, match="direction_means"):
        gated_line_sampling(_half_space, basis, n_lines=10, seed=0,
                            direction_means=np.zeros((1, 2)))


@pytest.mark.e2e
def test_origins_drawn_towards_failure_vouch_for_straight_lines():
    """Straight lines along u0 (k = 1) for ``u0 - u2 >= 5.5`` behind ``u3 <= 1.5`` (exact
    ``Phi(-5.5 / sqrt 2) Phi(1.5)``): each line's probability ``Phi(-(5.5 + u2))`` depends on
    its origin, so standard normal origins leave 1-11 effective lines of 200 (status 3 in
    every seed); origins drawn from the defensive mixture shifted to u2 = -2.75 (weights
    <= 1 / 0.3, independent of u0) give 18 of 20 intervals holding, mean within 4 % of
    exact, all status 0. A density that moves the line's own coordinate is refused."""
    from gearuq.failure.methods.subspace import subspace_density

    def limit(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return 5.5 - (u[:, 0] - u[:, 2]), np.ones(len(u), bool)

    exact = stats.norm.sf(5.5 / math.sqrt(2)) * stats.norm.cdf(1.5)
    basis = np.eye(D)[:, :1]
    shifted = subspace_density(np.eye(D)[:, 2:3], np.array([-2.75]), np.eye(1), 0.3)
    runs = {name: [gated_line_sampling(limit, basis, n_lines=200, seed=s, gate=_gate_u3,
                                       root_tol=1e-4, origin_density=density)
                   for s in range(20)]
            for name, density in (("normal", None), ("shifted", shifted))}
    assert all(r["status"] == 3 for r in runs["normal"])
    drawn = runs["shifted"]
    assert all(r["status"] == 0 and r["max_weight"] <= 1 / 0.3 for r in drawn)
    # a weighted run's message says its terms carry weights, an unweighted one says none
    assert all("weights at most" in r["message"] for r in drawn)
    assert sum(r["lower"] <= exact <= r["upper"] for r in drawn) >= 18
    assert np.mean([r["pf"] for r in drawn]) == pytest.approx(exact, rel=0.04)
    moves_u0 = subspace_density(np.eye(D)[:, :1], np.array([1.0]), np.eye(1), 0.3)
    with pytest.raises(ValueError, match="origin_density"):
        gated_line_sampling(limit, basis, n_lines=10, seed=0, origin_density=moves_u0)


def test_a_handful_of_lines_is_not_vouched_for():
    """With 10 lines the effective-lines rule (half of them) could pass: the status says
    that too few lines were drawn for the normal interval, in words."""
    res = gated_line_sampling(_limit, _basis(), n_lines=10, seed=1, gate=_gate)
    assert res["status"] != 0 and "lines" in res["message"]


def test_lines_that_all_miss_bound_pf_by_the_share_they_could_miss() -> None:
    """A failure set only origins with u1 >= 3 reach (P = Phi(-2) Phi(-3) = 3.1e-5) and 20
    lines along u0: none crosses, and the upper end is the share of lines 20 could all miss
    at 97.5 %, 1 - 0.025^(1/20) = 0.168 (it was the mass beyond c_max, 1e-15, below the
    truth)."""
    def corner(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.maximum(2.0 - u[:, 0], 3.0 - u[:, 1]), np.ones(len(u), bool)

    basis = np.zeros((4, 1))
    basis[0, 0] = 1.0
    est = gated_line_sampling(corner, basis, n_lines=20, seed=3,
                              t_grid=np.array([-8.0, 0.0, 2.5, 8.0]))
    assert est["status"] == 4 and est["pf"] == 0.0
    assert est["upper"] >= stats.norm.sf(2.0) * stats.norm.sf(3.0)
    assert est["upper"] == pytest.approx(1.0 - 0.025 ** (1.0 / 20.0), rel=1e-9)
