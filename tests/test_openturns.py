"""OpenTURNS interoperability: distributions both ways, OpenTURNS algorithms on gearuq models.

Oracles: closed-form marginal moments and quantiles (scipy.stats), the exact Spearman
correlation of a Gaussian copula, ``(6 / pi) asin(R / 2)``, gearuq's own FORM and the
resistance-load failure probability by one-dimensional quadrature
(:func:`gearuq.testing.reliability_problems.resistance_load_pf`).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

ot = pytest.importorskip("openturns")

import gearuq  # noqa: E402
from gearuq.interop.openturns import (  # noqa: E402
    from_openturns_distribution,
    to_openturns_distribution,
    to_openturns_function,
)
from gearuq.space import ParameterSpace  # noqa: E402
from gearuq.testing.reliability_problems import (  # noqa: E402
    resistance_load_model,
    resistance_load_pf,
    resistance_load_space,
)

#: ``ot.JointDistribution``, called ComposedDistribution before OpenTURNS 1.24.
JOINT = getattr(ot, "JointDistribution", None) or ot.ComposedDistribution

#: Block-diagonal copula (ComposedCopula before OpenTURNS 1.24).
BLOCKS = getattr(ot, "BlockIndependentCopula", None) or ot.ComposedCopula

#: Probabilities where quantiles are compared. Beyond 1 - 1e-3 OpenTURNS inverts a
#: one-sided TruncatedDistribution numerically (~1e-9 relative at 1 - 1e-6).
U = np.array([1e-6, 1e-2, 0.3, 0.5, 0.9, 0.999])
TOL = 1e-10

SPECS = [
    {"name": "a", "dist": "normal", "mean": 2e-5, "std": 3.3e-9},
    {"name": "b", "dist": "lognormal", "mu": 0.3, "sigma": 0.25, "shift": 1.5},
    {"name": "c", "dist": "uniform", "lower": -1.0, "upper": 3.0},
    {"name": "d", "dist": "loguniform", "lower": 1e-3, "upper": 10.0},
    {"name": "e", "dist": "truncnormal", "mean": 1.0, "std": 2.0, "lower": 0.0, "upper": 4.0},
    {"name": "f", "dist": "weibull", "shape": 2.5, "scale": 3.0, "shift": 0.5},
    {"name": "g", "dist": "gumbel", "loc": 3.0, "scale": 2.0},
    {"name": "h", "dist": "triangular", "lower": 0.0, "mode": 0.3, "upper": 1.0},
    {"name": "i", "dist": "gamma", "shape": 2.5, "scale": 0.4, "shift": 1.0},
    {"name": "j", "dist": "truncnormal", "mean": 1.0, "std": 2.0, "lower": 0.0,
     "upper": math.inf},
]

#: The same marginals as frozen scipy.stats distributions (an oracle independent of both).
SCIPY = {
    "a": stats.norm(2e-5, 3.3e-9),
    "b": stats.lognorm(0.25, loc=1.5, scale=math.exp(0.3)),
    "c": stats.uniform(-1.0, 4.0),
    "d": stats.loguniform(1e-3, 10.0),
    "e": stats.truncnorm(-0.5, 1.5, loc=1.0, scale=2.0),
    "f": stats.weibull_min(2.5, loc=0.5, scale=3.0),
    "g": stats.gumbel_r(3.0, 2.0),
    "h": stats.triang(0.3, loc=0.0, scale=1.0),
    "i": stats.gamma(2.5, loc=1.0, scale=0.4),
    "j": stats.truncnorm(-0.5, math.inf, loc=1.0, scale=2.0),
}

#: Normal-score correlation of a, b, f, g (the others independent of them).
R_SUB = np.array([[1.0, 0.6, -0.3, 0.2],
                  [0.6, 1.0, 0.1, 0.0],
                  [-0.3, 0.1, 1.0, 0.4],
                  [0.2, 0.0, 0.4, 1.0]])
R_IDX = [0, 1, 5, 6]


def _full_correlation() -> np.ndarray:
    r = np.eye(len(SPECS))
    r[np.ix_(R_IDX, R_IDX)] = R_SUB
    return r


def _close(actual: np.ndarray, expected: np.ndarray, scale: float) -> None:
    """|actual - expected| <= TOL max(|expected|, scale) elementwise."""
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    bound = TOL * np.maximum(np.abs(expected), scale)
    assert np.all(np.abs(actual - expected) <= bound), (actual, expected)


def _ot_quantiles(d, u=U) -> np.ndarray:
    return np.array([d.computeQuantile(float(x))[0] for x in u])


# =========================================================================== distributions
def test_space_to_openturns_marginals_match_closed_forms():
    space = ParameterSpace.from_spec(SPECS, _full_correlation())
    joint = to_openturns_distribution(space)
    assert joint.getClassName() in ("JointDistribution", "ComposedDistribution")
    assert list(joint.getDescription()) == space.names
    for i, name in enumerate(space.names):
        m, o, ref = space.marginal(name), joint.getMarginal(i), SCIPY[name]
        sd = ref.std()
        _close(o.getMean()[0], ref.mean(), sd)
        _close(o.getStandardDeviation()[0], sd, sd)
        _close(o.getMean()[0], m.mean(), sd)
        _close(o.getStandardDeviation()[0], m.std(), sd)
        _close(_ot_quantiles(o), ref.ppf(U), sd)
        _close(_ot_quantiles(o), m.inv(U), sd)


def test_gaussian_copula_goes_over_as_its_normal_score_correlation():
    r = _full_correlation()
    joint = to_openturns_distribution(ParameterSpace.from_spec(SPECS, r))
    copula = joint.getCopula()
    assert copula.getImplementation().getClassName() == "NormalCopula"
    np.testing.assert_allclose(np.array(copula.getShapeMatrix()), r, rtol=0, atol=1e-15)
    # the exact Spearman correlation of a Gaussian copula with normal-score correlation R
    np.testing.assert_allclose(np.array(joint.getSpearmanCorrelation()),
                               6 / math.pi * np.arcsin(r / 2), rtol=0, atol=1e-12)


def test_spearman_input_reaches_openturns_exactly():
    """A space built from a Spearman target: OpenTURNS reports that Spearman correlation."""
    rho_s = np.array([[1.0, 0.5], [0.5, 1.0]])
    space = ParameterSpace({"x": {"dist": "gumbel", "loc": 0.0, "scale": 1.0},
                            "y": {"dist": "weibull", "shape": 2.0, "scale": 1.0}},
                           rho_s, correlation_type="spearman")
    joint = to_openturns_distribution(space)
    np.testing.assert_allclose(np.array(joint.getSpearmanCorrelation()), rho_s,
                               rtol=0, atol=1e-12)


def test_openturns_samples_have_gearuqs_normal_score_correlation():
    """Draws of the OpenTURNS distribution mapped by gearuq's own transform to normal scores
    have the space's correlation (within sampling error: se ~ (1 - r^2) / sqrt(n))."""
    r = _full_correlation()
    space = ParameterSpace.from_spec(SPECS, r)
    ot.RandomGenerator.SetSeed(7)
    x = np.array(to_openturns_distribution(space).getSample(40_000))
    z = space.to_normal({k: x[:, j] for j, k in enumerate(space.names)})
    est = np.corrcoef(z, rowvar=False)
    se = (1 - r**2) / math.sqrt(x.shape[0])
    assert np.all(np.abs(est - r) <= 5 * se + 1e-12), np.abs(est - r) / np.maximum(se, 1e-300)


def test_round_trip_space_openturns_space():
    r = _full_correlation()
    space = ParameterSpace.from_spec(SPECS, r)
    back = from_openturns_distribution(to_openturns_distribution(space))
    assert back.names == space.names
    np.testing.assert_allclose(back.correlation, r, rtol=0, atol=1e-15)
    for name in space.names:
        m, b = space.marginal(name), back.marginal(name)
        assert b.kind == m.kind
        for k, v in m.params.items():
            assert b.params[k] == pytest.approx(v, rel=1e-14, abs=0), (name, k)
        sd = m.std()
        _close(b.mean(), m.mean(), sd)
        _close(b.std(), sd, sd)
        _close(b.inv(U), m.inv(U), sd)
    independent = ParameterSpace.from_spec(SPECS)
    assert from_openturns_distribution(to_openturns_distribution(independent)).independent


def test_round_trip_openturns_space_openturns():
    marginals = [ot.Normal(1.0, 0.1), ot.LogNormal(0.1, 0.2, 0.5), ot.Uniform(-2.0, 1.0),
                 ot.LogUniform(-1.0, 2.0), ot.TruncatedNormal(0.0, 1.0, -1.0, 2.0),
                 ot.WeibullMin(2.0, 1.5, 0.1), ot.Gumbel(2.0, 3.0),
                 ot.Triangular(0.0, 0.3, 1.0), ot.Gamma(2.0, 0.5, 1.0),
                 ot.Exponential(2.0, 1.0),
                 ot.TruncatedDistribution(ot.Normal(1.0, 2.0), 0.0,
                                          ot.TruncatedDistribution.LOWER),
                 ot.TruncatedDistribution(ot.Gumbel(2.0, 3.0), 2.0, 9.0)]
    dim = len(marginals)
    shape = np.eye(dim)
    shape[0, 1] = shape[1, 0] = 0.7
    shape[1, 6] = shape[6, 1] = -0.4
    joint = JOINT(marginals, ot.NormalCopula(ot.CorrelationMatrix(shape)))
    space = from_openturns_distribution(joint)
    assert space.names == [f"X{i}" for i in range(dim)]
    assert [space.marginal(n).kind for n in space.names] == [
        "normal", "lognormal", "uniform", "loguniform", "truncnormal", "weibull", "gumbel",
        "triangular", "gamma", "gamma", "truncnormal", "truncated"]
    np.testing.assert_allclose(space.correlation, shape, rtol=0, atol=1e-15)
    again = to_openturns_distribution(space)
    np.testing.assert_allclose(np.array(again.getCopula().getShapeMatrix()), shape, atol=1e-15)
    for i, name in enumerate(space.names):
        o, m, o2 = marginals[i], space.marginal(name), again.getMarginal(i)
        sd = o.getStandardDeviation()[0]
        for dist_moment in (m.mean(), o2.getMean()[0]):
            _close(dist_moment, o.getMean()[0], sd)
        for dist_sd in (m.std(), o2.getStandardDeviation()[0]):
            _close(dist_sd, sd, sd)
        _close(_ot_quantiles(o2), _ot_quantiles(o), sd)
        if m.kind != "truncated":  # see test_truncated_kind_quantiles_match_openturns
            _close(m.inv(U), _ot_quantiles(o), sd)


def test_truncated_kind_quantiles_match_openturns():
    g = stats.gumbel_r(3.0, 2.0)
    lo, hi = g.cdf(2.0), g.cdf(9.0)
    exact = g.ppf(lo + U * (hi - lo))
    trunc = ot.TruncatedDistribution(ot.Gumbel(2.0, 3.0), 2.0, 9.0)
    _close(_ot_quantiles(trunc), exact, g.std())  # OpenTURNS is right
    m = from_openturns_distribution(trunc, names=["x"]).marginal("x")
    _close(m.inv(U), exact, g.std())


def test_block_independent_and_multivariate_normal():
    block = BLOCKS([
        ot.NormalCopula(ot.CorrelationMatrix([[1.0, 0.3], [0.3, 1.0]])),
        ot.IndependentCopula(1)])
    joint = JOINT([ot.Normal(), ot.Uniform(0.0, 1.0), ot.Gumbel(1.0, 0.0)], block)
    space = from_openturns_distribution(joint, names=["p", "q", "r"])
    expected = np.eye(3)
    expected[0, 1] = expected[1, 0] = 0.3
    np.testing.assert_array_equal(space.correlation, expected)
    mvn = ot.Normal([1.0, 2.0], [0.5, 3.0], ot.CorrelationMatrix([[1.0, -0.6], [-0.6, 1.0]]))
    space = from_openturns_distribution(mvn, names=["u", "v"])
    assert space.mean() == {"u": 1.0, "v": 2.0}
    assert space.std() == {"u": 0.5, "v": 3.0}
    assert space.correlation[0, 1] == -0.6


# =========================================================================== algorithms
def _form(solver, event, start):
    solver.setStartingPoint(start)
    solver.setMaximumIterationNumber(1000)
    for setter, value in (("setMaximumAbsoluteError", 1e-10),
                          ("setMaximumRelativeError", 1e-10),
                          ("setMaximumResidualError", 1e-10),
                          ("setMaximumConstraintError", 1e-10)):
        getattr(solver, setter)(value)
    try:
        algo = ot.FORM(solver, event)
    except (TypeError, NotImplementedError):  # OpenTURNS < 1.26: starting point argument
        algo = ot.FORM(solver, event, start)
    algo.run()
    return algo.getResult()


@pytest.mark.e2e
@pytest.mark.parametrize("rho", [0.0, -0.5])
@pytest.mark.parametrize("solver", ["Cobyla", "AbdoRackwitz"])
def test_openturns_form_on_a_gearuq_model_agrees_with_gearuq_form(rho, solver):
    model, space = resistance_load_model(), resistance_load_space(rho)
    dist = to_openturns_distribution(space)
    g = to_openturns_function(model, space, "g")
    event = ot.ThresholdEvent(ot.CompositeRandomVector(g, ot.RandomVector(dist)),
                              ot.LessOrEqual(), 0.0)
    res_ot = _form(getattr(ot, solver)(), event, dist.getMean())
    res = gearuq.failure_probability(model, space, "g", method="form", rng=1, tol_u=1e-10,
                                     tol_g=1e-10, fd_scheme="central")
    assert int(res.status) == 0
    assert res_ot.getHasoferReliabilityIndex() == pytest.approx(float(res.beta), abs=1e-4)
    assert res_ot.getEventProbability() == pytest.approx(float(res.pf), rel=1e-3)
    np.testing.assert_allclose(np.array(res_ot.getPhysicalSpaceDesignPoint()),
                               res.design_point_x.values[0], rtol=1e-4)


def test_openturns_monte_carlo_on_the_event_brackets_the_exact_pf():
    rho = -0.5
    model, space = resistance_load_model(), resistance_load_space(rho)
    dist = to_openturns_distribution(space)
    g = to_openturns_function(model, space, "g")
    event = ot.ThresholdEvent(ot.CompositeRandomVector(g, ot.RandomVector(dist)),
                              ot.LessOrEqual(), 0.0)
    ot.RandomGenerator.SetSeed(2024)
    algo = ot.ProbabilitySimulationAlgorithm(event, ot.MonteCarloExperiment())
    algo.setBlockSize(20_000)  # one model call per block: the function is vectorised
    algo.setMaximumOuterSampling(5)
    algo.setMaximumCoefficientOfVariation(0.0)
    algo.run()
    result = algo.getResult()
    assert result.getOuterSampling() * result.getBlockSize() == 100_000
    assert g.getEvaluationCallsNumber() == 100_000
    # 99 % two-sided normal interval from OpenTURNS' standard error of the estimate
    pf = result.getProbabilityEstimate()
    half = stats.norm.ppf(0.995) * result.getStandardDeviation()
    exact = resistance_load_pf(rho)
    assert abs(pf - exact) <= half, (pf, half, exact)
    assert half < 0.15 * exact  # an informative interval, not a vacuous one
    # the independent case has a different pf: the copula matters and went through
    assert abs(resistance_load_pf(0.0) - exact) > 5 * half


def test_helical_pair_as_an_openturns_function_matches_response():
    model = gearuq.get_model("helical_pair")
    space = model.default_space()
    ot.RandomGenerator.SetSeed(3)
    x = to_openturns_distribution(space).getSample(4)
    params = {k: np.array(x)[:, j] for j, k in enumerate(space.names)}
    f = to_openturns_function(model, space, ["k_mesh", "contact_ratio"])
    assert list(f.getInputDescription()) == space.names
    assert list(f.getOutputDescription()) == ["k_mesh", "contact_ratio"]
    ds = model.response(params, outputs=["k_mesh", "contact_ratio"])
    np.testing.assert_array_equal(np.array(f(x)), np.column_stack([ds.k_mesh, ds.contact_ratio]))
    # one point gives the same as the sample
    np.testing.assert_array_equal(np.array(f(x[1])), np.array(f(x))[1])

    t = np.linspace(0.0, 10.0, 21)
    ds = model.response(params, t, outputs=["mesh_force"], rtol=1e-8)
    for reduce, expected in (("max", ds.mesh_force.max("time")),
                             ("min", ds.mesh_force.min("time")),
                             (5.0, ds.mesh_force.sel(time=5.0))):
        h = to_openturns_function(model, space, "mesh_force", t=t, reduce=reduce, rtol=1e-8)
        np.testing.assert_array_equal(np.array(h(x))[:, 0], expected.values)


# =========================================================================== bad input
def test_unsupported_openturns_objects_are_refused_by_name():
    with pytest.raises(ValueError, match=r"parameter 'X0': OpenTURNS marginal Beta .*"
                                         r"supported: Normal, LogNormal"):
        from_openturns_distribution(JOINT([ot.Beta(2.0, 3.0, 0.0, 1.0)]))
    with pytest.raises(ValueError, match=r"marginal WeibullMax"):
        from_openturns_distribution(ot.WeibullMax(1.0, 2.0), names=["w"])
    with pytest.raises(ValueError, match=r"copula ClaytonCopula .*supported: "
                                         r"IndependentCopula, NormalCopula"):
        from_openturns_distribution(JOINT([ot.Normal()] * 2,
                                                         ot.ClaytonCopula(2.0)))
    with pytest.raises(ValueError, match=r"copula (BlockIndependent|Composed)Copula"):
        from_openturns_distribution(JOINT(
            [ot.Normal()] * 3,
            BLOCKS([ot.GumbelCopula(2.0), ot.IndependentCopula(1)])))
    with pytest.raises(ValueError, match=r"description \['x y'\] is not 1 distinct"):
        d = ot.Normal()
        d.setDescription(["x y"])
        from_openturns_distribution(d)
    with pytest.raises(ValueError, match=r"names: expected 2 names"):
        from_openturns_distribution(ot.Normal(2), names=["a"])
    with pytest.raises(ValueError, match=r"dist: expected an OpenTURNS distribution"):
        from_openturns_distribution({"x": 1})


def test_unsupported_gearuq_objects_are_refused_by_name():
    import chaospy as cp

    space = ParameterSpace({"x": cp.Beta(2.0, 3.0)})
    with pytest.raises(ValueError, match=r"parameter 'x': .*kind 'chaospy'.* supported kinds: "
                                         r"normal, lognormal"):
        to_openturns_distribution(space)
    with pytest.raises(ValueError, match=r"space: expected a gearuq ParameterSpace"):
        to_openturns_distribution({"x": {"dist": "normal", "mean": 0, "std": 1}})


def test_function_bad_input():
    model, space = resistance_load_model(), resistance_load_space()
    with pytest.raises(ValueError, match=r"no output\(s\) 'h'; valid: g"):
        to_openturns_function(model, space, "h")
    with pytest.raises(ValueError, match=r"reduce: 'max' given but no requested output is "
                                         r"time-dependent"):
        to_openturns_function(model, space, "g", reduce="max")
    with pytest.raises(ValueError, match=r"parameter\(s\) 'x' are not parameters of model "
                                         r"'resistance_load'; valid: R, S"):
        to_openturns_function(model, ParameterSpace.normal(x=(0.0, 1.0)), "g")
    with pytest.raises(ValueError, match=r"unknown option\(s\) 'rtol'"):
        to_openturns_function(model, space, "g", rtol=1e-3)

    def series(x, t):
        return x[:, None] * np.asarray(t)[None, :]

    timed = gearuq.FunctionModel(series, ["x"], ["y"], time_dependent=True, name="series")
    xs = ParameterSpace.normal(x=(0.0, 1.0))
    with pytest.raises(ValueError, match=r"'y' of model 'series' are time-dependent.*"
                                         r"reduce='max', 'min' or an instant of t"):
        to_openturns_function(timed, xs, "y", t=[0.0, 1.0])
    with pytest.raises(ValueError, match=r"reduce: unknown reduction 'mean'"):
        to_openturns_function(timed, xs, "y", t=[0.0, 1.0], reduce="mean")
    with pytest.raises(ValueError, match=r"instant 0.5 is not one of the output instants t "
                                         r"\(2 in \[0, 1\]\)"):
        to_openturns_function(timed, xs, "y", t=[0.0, 1.0], reduce=0.5)
    f = to_openturns_function(timed, xs, "y", t=[0.0, 1.0, 2.0], reduce=1.0)
    assert f([3.0])[0] == 3.0
    assert to_openturns_function(timed, xs, "y", t=[0.0, 1.0, 2.0], reduce="min")([3.0])[0] == 0


def test_a_failing_sample_stops_the_evaluation_naming_it():
    holey = gearuq.FunctionModel(lambda x, y: np.where(x > 1.0, np.nan, x + y), ["x", "y"],
                                 ["g"], name="holey")
    f = to_openturns_function(holey, ParameterSpace.normal(x=(0.0, 1.0), y=(0.0, 1.0)), "g")
    assert np.array(f([[0.5, 1.0], [0.25, 0.0]]))[:, 0].tolist() == [1.5, 0.25]
    with pytest.raises(RuntimeError, match=r"model 'holey': 1 of 2 sample\(s\) failed; first: "
                                           r"sample 1 \(x=2, y=1\) with status 3 "
                                           r"\(non_finite_state\)"):
        f([[0.5, 1.0], [2.0, 1.0]])
