"""FORM and SORM against exact answers: linear limit states, a paraboloid, lognormal R minus
normal S (independent and correlated), two design points, sensitivities, failures."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from gearuq.failure.api import failure_probability
from gearuq.failure.methods.form import curvatures, sorm_probabilities
from gearuq.model import FunctionModel, Parameter
from gearuq.space import ParameterSpace
from gearuq.testing import reliability_problems as rp
from gearuq.testing.problems import standard_normal_space


def test_offset_form_and_sorm_exact():
    rep = failure_probability(rp.offset_model(), rp.offset_space(), "g", method="sorm", rng=0,
                              executor="serial")
    assert float(rep["beta_design_point"][0]) == pytest.approx(4.5, abs=1e-8)
    assert float(rep["pf_form"]) == pytest.approx(rp.OFFSET_PF, rel=1e-7)
    for formula in ("breitung", "hohenbichler", "tvedt"):
        assert float(rep[f"pf_{formula}"]) == pytest.approx(rp.OFFSET_PF, rel=1e-6)
    np.testing.assert_allclose(rep["curvature"], 0.0, atol=1e-5)
    np.testing.assert_allclose(rep["design_point_x"][0], [4.5, 0.0], atol=1e-7)
    np.testing.assert_allclose(rep["importance_factor"][0], [1.0, 0.0], atol=1e-12)
    assert int(rep["status"]) == 0 and rep.attrs["interval_kind"].startswith("none")


@pytest.mark.e2e
def test_linear_100d_form_exact():
    """g = 3.5 sqrt(100) - sum(x): beta = 3.5, u* = 0.35 in every direction."""
    rep = failure_probability(rp.linear_sum_model(), standard_normal_space(100), "g",
                              method="form", rng=0, executor="serial", n_starts=1)
    assert float(rep["beta"]) == pytest.approx(3.5, abs=1e-7)
    assert float(rep["pf"]) == pytest.approx(rp.LINEAR_100D_PF, rel=1e-6)
    np.testing.assert_allclose(rep["design_point_u"][0], 0.35, atol=1e-7)
    np.testing.assert_allclose(rep["importance_factor"][0], 0.01, atol=1e-9)
    # one gradient at the origin (101 runs), one step, one gradient (100): 202 runs
    assert int(rep["n_model_runs"]) == 202
    # one start cannot tell whether other design points exist, and says so
    assert int(rep["status"]) == 8 and "one FORM start" in rep.attrs["message"]
    # the default search (origin and ten random directions) finds the one design point
    # from every start and vouches for it
    auto = failure_probability(rp.linear_sum_model(), standard_normal_space(100), "g",
                               method="form", rng=0, executor="serial")
    assert int(auto["status"]) == 0 and auto.sizes["design_point"] == 1
    assert float(auto["pf"]) == pytest.approx(rp.LINEAR_100D_PF, rel=1e-6)


@pytest.mark.e2e
@pytest.mark.parametrize("rho", [0.0, 0.3])
def test_resistance_load_tvedt_within_one_percent(rho):
    """R lognormal (10, 1) minus S normal (5, 1.5): Tvedt within 1 % of quadrature (also with
    a Gaussian copula); the FORM error is reported beside it."""
    ref = rp.resistance_load_pf(rho)
    rep = failure_probability(rp.resistance_load_model(), rp.resistance_load_space(rho), "g",
                              method="sorm", rng=0, executor="serial")
    assert float(rep["pf"]) == pytest.approx(ref, rel=0.01)
    assert float(rep["pf_tvedt"]) == float(rep["pf"])
    form_error = float(rep["pf_form"]) / ref - 1
    assert 0.03 < form_error < 0.15  # FORM overestimates by 5.7 % (9.3 % correlated)
    assert abs(float(rep["pf_hohenbichler"]) / ref - 1) < 0.01
    assert abs(float(rep["pf_breitung"]) / ref - 1) < abs(form_error)


@pytest.mark.e2e
def test_paraboloid_curvature_and_sorm():
    """G = 3 - u2 + 0.1 u1^2: curvature 0.2; Pf = int phi(u1) Phi(-(3 + 0.1 u1^2)) du1."""
    model = FunctionModel(lambda u1, u2: 3.0 - u2 + 0.1 * u1**2, ["u1", "u2"], ["g"])
    space = ParameterSpace.normal(u1=(0.0, 1.0), u2=(0.0, 1.0))
    exact, _ = integrate.quad(lambda u: stats.norm.pdf(u) * stats.norm.sf(3.0 + 0.1 * u * u),
                              -12, 12, epsabs=1e-14)
    rep = failure_probability(model, space, "g", method="sorm", rng=0, executor="serial")
    np.testing.assert_allclose(rep["curvature"], [0.2], rtol=1e-4)
    assert float(rep["pf_tvedt"]) == pytest.approx(exact, rel=2e-3)
    assert float(rep["pf_breitung"]) == pytest.approx(
        stats.norm.sf(3.0) / math.sqrt(1 + 3.0 * 0.2), rel=1e-4)


def test_sorm_formulas_and_curvatures_helpers():
    hess = np.diag([0.4, -0.2, 0.0])
    grad = np.array([0.0, 0.0, -2.0])  # alpha along the third axis
    np.testing.assert_allclose(sorm_probabilities(2.0, np.array([]))["tvedt"],
                               stats.norm.sf(2.0), rtol=1e-12)
    np.testing.assert_allclose(np.sort(curvatures(hess, grad)), [-0.1, 0.2], atol=1e-12)
    invalid = sorm_probabilities(3.0, np.array([-0.5]))
    assert math.isnan(invalid["breitung"]) and math.isnan(invalid["tvedt"])


def test_sensitivities_and_importance_with_correlation():
    """g = 12 - X1 - X2, X normal with copula rho: beta, d beta/d mean, d beta/d std and the
    importance factors sigma_i^2 / (sigma_1^2 + sigma_2^2) in closed form."""
    s1, s2, rho, m1, m2 = 1.5, 0.8, 0.4, 4.0, 3.0
    model = FunctionModel(lambda x1, x2: 12.0 - x1 - x2, ["x1", "x2"], ["g"])
    space = ParameterSpace.normal(correlation={("x1", "x2"): rho}, x1=(m1, s1), x2=(m2, s2))
    sd = math.sqrt(s1**2 + s2**2 + 2 * rho * s1 * s2)
    beta = (12.0 - m1 - m2) / sd
    rep = failure_probability(model, space, "g", method="form", rng=0, executor="serial")
    assert float(rep["beta"]) == pytest.approx(beta, rel=1e-7)
    np.testing.assert_allclose(rep["dbeta_dmean"], [-1 / sd, -1 / sd], rtol=1e-6)
    # d beta / d s1 = -(mu margin) * d sd / d s1 / sd^2
    np.testing.assert_allclose(rep["dbeta_dstd"], [-beta * (s1 + rho * s2) / sd**2,
                                                   -beta * (s2 + rho * s1) / sd**2], rtol=1e-5)
    np.testing.assert_allclose(rep["importance_factor"][0],
                               [s1**2 / (s1**2 + s2**2), s2**2 / (s1**2 + s2**2)], rtol=1e-6)
    np.testing.assert_allclose(rep["dpf_dmean"], -stats.norm.pdf(beta) * rep["dbeta_dmean"])


@pytest.mark.e2e
def test_two_design_points_are_found_and_reported():
    """Der Kiureghian and Dakessian's parabola: the nearest design point alone misses 39 % of
    Pf; the series FORM over both found design points is within 7 %."""
    rep = failure_probability(rp.parabola_model(), rp._named_normals(["u1", "u2"]), "g",
                              method="form", n_starts=6, rng=2, executor="serial")
    assert rep.sizes["design_point"] == 2
    assert "2 different design points" in rep.attrs["message"]
    err_single = abs(float(rep["pf_form"]) / rp.PARABOLA_PF - 1)
    err_multi = abs(float(rep["pf_multi_design_points"]) / rp.PARABOLA_PF - 1)
    assert err_single > 0.3 and err_multi < 0.1
    # the reported pf is the series FORM over both design points, not the nearest alone
    assert float(rep["pf"]) == float(rep["pf_multi_design_points"])
    np.testing.assert_allclose(np.sort(rep["beta_design_point"]), [2.906, 3.094], atol=2e-3)


def _fragile(x1, x2):
    if np.any(x1 > 3.9):
        raise RuntimeError("solver diverged")
    return 4.0 - x1 + 0 * x2


@pytest.mark.e2e
def test_model_failing_near_the_design_point_is_flagged():
    model = FunctionModel(_fragile, ["x1", "x2"], ["g"])
    rep = failure_probability(model, standard_normal_space(2), "g", method="form", rng=0,
                              executor="serial")
    assert int(rep["status"]) in (1, 2) and math.isnan(float(rep["pf"]))
    assert int(rep["n_invalid"]) > 0
    assert "solver diverged" in rep.attrs["errors"]


def test_gradient_step_at_the_edge_of_the_valid_range():
    """A finite-difference point beyond the model's valid range is replaced by the backward
    difference; a design point beyond it is a clear error naming the parameter."""
    space = standard_normal_space(2)

    def model(upper):
        return FunctionModel(rp.offset, [Parameter("x1", "1", 0.0, -np.inf, upper),
                                         Parameter("x2", "1", 0.0)], ["g"])

    rep = failure_probability(model(4.5 + 5e-5), space, "g", method="form", rng=0,
                              executor="serial")
    assert float(rep["beta"]) == pytest.approx(4.5, abs=1e-7)
    with pytest.raises(ValueError, match=r"parameter 'x1' = .* outside the model's valid range"):
        failure_probability(model(4.0), space, "g", method="form", rng=0, executor="serial")
