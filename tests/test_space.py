"""Tests of gearuq.space.ParameterSpace: marginals, sampling rules, copula, conversions."""

from __future__ import annotations

import math
import warnings

import chaospy as cp
import numpy as np
import pytest
from scipy import stats

import gearuq
from gearuq.model import Parameter
from gearuq.space import ParameterSpace

N = 20_000
EULER = np.euler_gamma

# kind spec -> (textbook mean, textbook std)
SPECS = [
    ({"dist": "normal", "mean": 2e-5, "std": 3.3e-9}, 2e-5, 3.3e-9),
    ({"dist": "lognormal", "mean": 2.0, "std": 0.5}, 2.0, 0.5),
    ({"dist": "lognormal", "mu": 0.1, "sigma": 0.3},
     math.exp(0.1 + 0.045), math.exp(0.1 + 0.045) * math.sqrt(math.expm1(0.09))),
    ({"dist": "uniform", "lower": 0.05, "upper": 0.15}, 0.1, 0.1 / math.sqrt(12)),
    ({"dist": "loguniform", "lower": 1.0, "upper": 10.0},
     9 / math.log(10), math.sqrt((100 - 1) / (2 * math.log(10)) - (9 / math.log(10)) ** 2)),
    ({"dist": "truncnormal", "mean": 0.0, "std": 1.0, "lower": 0.0, "upper": math.inf},
     math.sqrt(2 / math.pi), math.sqrt(1 - 2 / math.pi)),
    ({"dist": "weibull", "shape": 2.0, "scale": 3.0},
     3 * math.gamma(1.5), 3 * math.sqrt(math.gamma(2.0) - math.gamma(1.5) ** 2)),
    ({"dist": "gumbel", "loc": 1.0, "scale": 2.0}, 1 + 2 * EULER, 2 * math.pi / math.sqrt(6)),
    ({"dist": "triangular", "lower": 0.0, "mode": 0.2, "upper": 1.0},
     1.2 / 3, math.sqrt((1 + 0.04 - 0.2) / 18)),
    ({"dist": "gamma", "shape": 2.0, "scale": 3.0, "shift": 1.0}, 7.0, 3 * math.sqrt(2)),
]


def _ids(specs):
    return [s[0]["dist"] + ("_mom" if "mean" in s[0] and s[0]["dist"] == "lognormal" else "")
            for s in specs]


# ------------------------------------------------------------------------------- marginals
@pytest.mark.parametrize(("spec", "mean", "std"), SPECS, ids=_ids(SPECS))
def test_marginal_moments_match_textbook_and_chaospy(spec, mean, std):
    space = ParameterSpace.from_spec([{"name": "x", **spec}])
    m = space.marginal("x")
    assert space.mean()["x"] == pytest.approx(mean, rel=1e-9)
    assert space.std()["x"] == pytest.approx(std, rel=1e-9)
    # the chaospy distribution is the same one (independent moment computation)
    assert float(cp.E(m.dist)) == pytest.approx(mean, rel=1e-6)
    assert float(cp.Std(m.dist)) == pytest.approx(std, rel=1e-5)


@pytest.mark.parametrize(("spec", "mean", "std"), SPECS, ids=_ids(SPECS))
@pytest.mark.parametrize("rule", ["random", "lhs"])
def test_sample_moments_within_5_se(spec, mean, std, rule):
    space = ParameterSpace.from_spec([{"name": "x", **spec}])
    x = space.sample(N, rule=rule, rng=42)["x"]
    assert x.shape == (N,)
    assert abs(x.mean() - mean) < 5 * std / math.sqrt(N)
    # variance: SE of s^2 is sqrt((mu4 - sigma^4) / n); mu4 from scipy's kurtosis
    kurt = float(space.marginal("x")._scipy.stats(moments="k"))
    se_var = std**2 * math.sqrt((kurt + 2) / N)
    assert abs(x.var(ddof=1) - std**2) < 5 * se_var


def test_raw_chaospy_distributions_are_recognised():
    space = ParameterSpace({
        "b5": cp.Normal(2e-5, 3.3e-9),
        "s": cp.Uniform(0.05, 0.15),
        "g": cp.LogWeibull(2, 1),  # the Gumbel distribution (cp.Gumbel is a copula)
        "w": cp.Weibull(2, scale=3),
        "ln": cp.LogNormal(0, 0.3),
        "tn": cp.TruncNormal(0, 1, 0.3, 0.4),
        "beta": cp.Beta(2, 3),
    })
    kinds = {k: space.marginal(k).kind for k in space.names}
    assert kinds == {"b5": "normal", "s": "uniform", "g": "gumbel", "w": "weibull",
                     "ln": "lognormal", "tn": "truncnormal", "beta": "chaospy"}
    assert space.marginal("g").params == {"loc": 1.0, "scale": 2.0}
    assert space.marginal("tn").params == {"mean": 0.3, "std": 0.4, "lower": 0.0, "upper": 1.0}
    assert space.mean()["beta"] == pytest.approx(0.4)
    # quantiles agree with chaospy's own inverse
    u = np.linspace(0.01, 0.99, 41)
    for k in space.names:
        np.testing.assert_allclose(space.ppf(k, u), space.marginal(k).dist.inv(u), rtol=1e-9)


def test_basic_properties_and_helpers():
    space = ParameterSpace.normal(a=(1.0, 0.1), b=(2.0, 0.5))
    assert space.names == ["a", "b"]
    assert space.dim == len(space) == 2
    assert "a" in space and "c" not in space
    assert "a ~ normal(mean=1, std=0.1)" in repr(space)
    assert space.cdf("b", 2.0) == pytest.approx(0.5)
    assert space.ppf("b", 0.975) == pytest.approx(2.0 + 0.5 * stats.norm.ppf(0.975))
    assert space.independent and space.correlation is None
    with pytest.raises(ValueError, match="no parameter 'c'; valid: a, b"):
        space.marginal("c")
    u = ParameterSpace.uniform(s=(0.0, 2.0))
    assert u.mean() == {"s": 1.0}


def test_extreme_unit_values_give_finite_draws():
    space = ParameterSpace.from_spec([
        {"name": "a", "dist": "normal", "mean": 0, "std": 1},
        {"name": "b", "dist": "gumbel", "loc": 0, "scale": 1},
    ])
    x = space.transform(np.array([[0.0, 0.0], [1.0, 1.0]]))
    assert np.all(np.isfinite(x["a"])) and np.all(np.isfinite(x["b"]))


# ------------------------------------------------------------------------------- sampling rules
def test_lhs_has_exactly_one_point_per_stratum():
    space = ParameterSpace.from_spec([
        {"name": "a", "dist": "normal", "mean": 0, "std": 1},
        {"name": "b", "dist": "weibull", "shape": 1.5, "scale": 2.0},
        {"name": "c", "dist": "uniform", "lower": -1, "upper": 1},
    ])
    n = 97
    u = space.sample_unit(n, rule="lhs", rng=7)
    for j in range(3):
        assert sorted(np.floor(u[:, j] * n).astype(int)) == list(range(n))
    # the same holds after the marginal transform, in probability space
    x = space.sample(n, rule="lhs", rng=7)
    for k in space.names:
        strata = np.floor(space.cdf(k, x[k]) * n + 1e-9).astype(int)
        assert sorted(strata) == list(range(n))


@pytest.mark.parametrize("rule", ["random", "lhs", "sobol", "halton"])
def test_rules_reproducible_from_one_seed(rule):
    space = ParameterSpace.normal(a=(0.0, 1.0), b=(5.0, 2.0), c=(1.0, 0.1))
    a = space.sample(64, rule=rule, rng=123)
    b = space.sample(64, rule=rule, rng=123)
    c = space.sample(64, rule=rule, rng=124)
    g = space.sample(64, rule=rule, rng=np.random.default_rng(123))
    for k in space.names:
        assert np.array_equal(a[k], b[k])
        assert np.array_equal(a[k], g[k])
        assert not np.array_equal(a[k], c[k])


def test_sobol_and_halton_are_balanced():
    space = ParameterSpace.uniform(a=(0, 1), b=(0, 1), c=(0, 1))
    s = space.sample_unit(256, rule="sobol", rng=5)
    for j in range(3):  # (0, 8, 1)-net in every coordinate: one point per 1/256 stratum
        assert sorted(np.floor(s[:, j] * 256).astype(int)) == list(range(256))
    h = space.sample_unit(81, rule="halton", rng=5)
    # dimension 0 has base 2, dimension 1 base 3: first b^k points fill every b^-k stratum
    assert sorted(np.floor(h[:64, 0] * 64).astype(int)) == list(range(64))
    assert sorted(np.floor(h[:81, 1] * 81).astype(int)) == list(range(81))
    assert np.all(np.abs(h.mean(axis=0) - 0.5) < 0.02)


def test_sobol_warns_for_non_power_of_two():
    space = ParameterSpace.uniform(a=(0, 1))
    with pytest.warns(UserWarning, match="power of 2"):
        space.sample_unit(100, rule="sobol", rng=1)


# ------------------------------------------------------------------------------- dependence
R3 = np.array([[1.0, 0.6, -0.3], [0.6, 1.0, 0.2], [-0.3, 0.2, 1.0]])


def _mixed_space(correlation=R3, correlation_type="normal"):
    return ParameterSpace.from_spec(
        [
            {"name": "a", "dist": "lognormal", "mean": 1.0, "std": 0.4},
            {"name": "b", "dist": "uniform", "lower": 0.0, "upper": 2.0},
            {"name": "c", "dist": "gumbel", "loc": 0.0, "scale": 1.0},
        ],
        correlation,
        correlation_type=correlation_type,
    )


def test_gaussian_copula_normal_space_correlation_matches():
    space = _mixed_space()
    n = 40_000
    x = space.sample(n, rule="random", rng=11)
    z = space.to_normal(x)
    r = np.corrcoef(z, rowvar=False)
    se = (1 - R3**2) / math.sqrt(n)
    assert np.all(np.abs(r - R3) <= 5 * se + 1e-12)
    # marginals are untouched by the copula
    assert abs(x["b"].mean() - 1.0) < 5 * (2 / math.sqrt(12)) / math.sqrt(n)


def test_gaussian_copula_spearman_closed_form():
    space = _mixed_space()
    n = 40_000
    x = space.sample(n, rule="random", rng=12)
    rs = stats.spearmanr(np.column_stack([x[k] for k in space.names])).statistic
    expected = 6 / np.pi * np.arcsin(R3 / 2)
    se = (1 - expected**2) * math.sqrt(1.06 / n)
    off = ~np.eye(3, dtype=bool)
    assert np.all(np.abs(rs - expected)[off] <= 5 * se[off])


def test_spearman_and_kendall_inputs_are_converted_exactly():
    target = np.array([[1.0, 0.5, 0.0], [0.5, 1.0, -0.4], [0.0, -0.4, 1.0]])
    sp = _mixed_space(target, "spearman")
    np.testing.assert_allclose(6 / np.pi * np.arcsin(sp.correlation / 2), target, atol=1e-14)
    assert sp.correlation_input == {"type": "spearman", "matrix": target.tolist()}
    kd = _mixed_space(target, "kendall")
    np.testing.assert_allclose(2 / np.pi * np.arcsin(kd.correlation), target, atol=1e-14)
    n = 40_000
    x = sp.sample(n, rule="lhs", rng=3)
    rs = stats.spearmanr(x["a"], x["b"]).statistic
    assert abs(rs - 0.5) < 5 * (1 - 0.25) * math.sqrt(1.06 / n)


def test_pearson_input_solves_the_nataf_integral():
    # normal-normal: no correction
    nn = ParameterSpace.normal(a=(0, 1), b=(3, 2), correlation=[[1, 0.7], [0.7, 1]])
    pn = ParameterSpace.from_spec(
        [{"name": "a", "dist": "normal", "mean": 0, "std": 1},
         {"name": "b", "dist": "normal", "mean": 3, "std": 2}],
        [[1, 0.7], [0.7, 1]], correlation_type="pearson")
    assert pn.correlation[0, 1] == pytest.approx(nn.correlation[0, 1], abs=1e-10)
    # lognormal-uniform: the normal-space correlation is larger than the target
    sp = ParameterSpace.from_spec(
        [{"name": "a", "dist": "lognormal", "mean": 1.0, "std": 0.5},
         {"name": "b", "dist": "uniform", "lower": 0.0, "upper": 1.0}],
        [[1, 0.6], [0.6, 1]], correlation_type="pearson")
    assert sp.correlation[0, 1] > 0.62
    n = 100_000
    x = sp.sample(n, rule="random", rng=5)
    assert abs(np.corrcoef(x["a"], x["b"])[0, 1] - 0.6) < 0.01
    # exact oracle: corr(exp(s Z1), Z2) = r s / sqrt(e^{s^2} - 1) for corr(Z1, Z2) = r
    for sigma, rho in ((1.0, 0.3), (2.0, 0.1), (0.5, -0.45)):
        ln = ParameterSpace.from_spec(
            [{"name": "a", "dist": "lognormal", "mu": 0.2, "sigma": sigma},
             {"name": "b", "dist": "normal", "mean": 1.0, "std": 3.0}],
            [[1, rho], [rho, 1]], correlation_type="pearson")
        exact = rho * math.sqrt(math.expm1(sigma**2)) / sigma
        assert ln.correlation[0, 1] == pytest.approx(exact, rel=1e-8)
    # feasible range: lognormal(sigma=1) vs normal is at most 1 / sqrt(e - 1) = 0.762874
    bound = 1 / math.sqrt(math.e - 1)
    with pytest.raises(ValueError, match=r"'a' and 'b' is not reachable.*0\.762874\]"):
        ParameterSpace.from_spec(
            [{"name": "a", "dist": "lognormal", "mu": 0.0, "sigma": 1.0},
             {"name": "b", "dist": "normal", "mean": 0.0, "std": 1.0}],
            [[1, 0.8], [0.8, 1]], correlation_type="pearson")
    edge = ParameterSpace.from_spec(
        [{"name": "a", "dist": "lognormal", "mu": 0.0, "sigma": 1.0},
         {"name": "b", "dist": "normal", "mean": 0.0, "std": 1.0}],
        [[1, bound - 1e-4], [bound - 1e-4, 1]], correlation_type="pearson")
    assert edge.correlation[0, 1] > 0.99


def test_correlation_as_pair_mapping():
    sp = ParameterSpace.normal(a=(0, 1), b=(0, 1), c=(0, 1), correlation={("a", "c"): 0.4})
    expected = np.eye(3)
    expected[0, 2] = expected[2, 0] = 0.4
    np.testing.assert_array_equal(sp.correlation, expected)


def test_to_chaospy_independent_and_nataf():
    ind = _mixed_space(None)
    joint = ind.to_chaospy()
    assert isinstance(joint, cp.J) and len(joint) == 3
    space = _mixed_space()
    nataf = space.to_chaospy()
    assert isinstance(nataf, cp.Nataf)
    u = np.random.default_rng(0).random((500, 3))
    x = space.transform(u)
    y = nataf.inv(u.T)
    for j, k in enumerate(space.names):
        np.testing.assert_allclose(x[k], y[j], rtol=1e-9, atol=1e-12)


# ------------------------------------------------------------------------------- serialisation
def test_json_round_trip_reproduces_identical_samples():
    space = ParameterSpace(
        {
            "a": {"dist": "lognormal", "mean": 1.0, "std": 0.3},
            "b": cp.Beta(2, 3),
            "c": cp.Trunc(cp.Gamma(2), upper=3),
            "d": {"dist": "truncnormal", "mean": 0.1 + 0.2, "std": 1 / 3, "lower": 0,
                  "upper": math.inf},
            "e": {"dist": "gumbel", "loc": -1.0, "scale": 0.7},
        },
        correlation={("a", "e"): 0.35, ("b", "d"): -0.2},
        correlation_type="spearman",
    )
    text = space.to_json()
    back = ParameterSpace.from_json(text)
    assert back == space
    assert back.to_json() == text
    assert back.correlation_input == space.correlation_input
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # sobol n not a power of 2
        for rule in ("random", "lhs", "sobol", "halton"):
            a, b = space.sample(37, rule, 9), back.sample(37, rule, 9)
            for k in space.names:
                assert np.array_equal(a[k], b[k]), (rule, k)


def test_from_json_rejects_garbage():
    with pytest.raises(ValueError, match="invalid JSON"):
        ParameterSpace.from_json("{not json")
    with pytest.raises(ValueError, match="not a gearuq ParameterSpace"):
        ParameterSpace.from_json('{"x": 1}')
    with pytest.raises(ValueError, match="is not a chaospy distribution"):
        ParameterSpace.from_spec([{"name": "x", "dist": "chaospy", "expr": "__import__('os')"}])


# ------------------------------------------------------------------------------- SALib
def test_to_salib_conventions_sample_through_salib():
    from SALib.sample import saltelli
    from SALib.sample import sobol as salib_sobol

    space = ParameterSpace.from_spec([
        {"name": "n", "dist": "normal", "mean": 2.0, "std": 0.5},
        {"name": "ln", "dist": "lognormal", "mean": 1.5, "std": 0.3},
        {"name": "u", "dist": "uniform", "lower": -1.0, "upper": 3.0},
        {"name": "tn", "dist": "truncnormal", "mean": 0.0, "std": 1.0, "lower": -0.5,
         "upper": 2.0},
        {"name": "tri", "dist": "triangular", "lower": 0.0, "mode": 0.25, "upper": 1.0},
        {"name": "w", "dist": "weibull", "shape": 2.0, "scale": 3.0},
        {"name": "g", "dist": "gumbel", "loc": 1.0, "scale": 0.5},
    ])
    with pytest.raises(ValueError, match="'g'.*no SALib equivalent"):
        space.to_salib()
    problem = space.to_salib(unsupported="unit")
    assert problem["dists"] == ["norm", "lognorm", "unif", "truncnorm", "triang", "weibull",
                                "unif"]
    assert problem["gearuq_unit"] == ["g"]
    sigma2 = math.log1p((0.3 / 1.5) ** 2)
    assert problem["bounds"][1] == pytest.approx([math.log(1.5) - sigma2 / 2, math.sqrt(sigma2)])
    assert problem["bounds"][3] == [-0.5, 2.0, 0.0, 1.0]
    assert problem["bounds"][4] == [0.0, 1.0, 0.25]
    means, stds = space.mean(), space.std()
    x_sobol = salib_sobol.sample(problem, 1024, calc_second_order=False, seed=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # saltelli is deprecated in SALib 1.5+
        x_saltelli = saltelli.sample(problem, 1024, calc_second_order=False)
    for x_raw in (x_sobol, x_saltelli):
        x = space.from_salib(x_raw, problem)
        for k in space.names:
            assert abs(x[k].mean() - means[k]) < 5 * stds[k] / math.sqrt(len(x[k])), k
    # the fallback column holds probabilities, mapped through the Gumbel quantile
    np.testing.assert_allclose(x["g"], stats.gumbel_r(1.0, 0.5).ppf(x_saltelli[:, -1]))


def test_to_salib_rejects_correlated_space():
    with pytest.raises(ValueError, match="independent inputs"):
        _mixed_space().to_salib(unsupported="unit")


# ------------------------------------------------------------------------------- around_nominal
def _model():
    return gearuq.FunctionModel(
        lambda k, c, z: k * (1 + c) + z,
        [Parameter("k", "N m-1", 1e8, 0.0, math.inf, "mesh stiffness"),
         Parameter("c", "1", 0.05, 0.0, 1.0, "damping ratio"),
         Parameter("z", "m", 0.0, -1.0, 1.0, "offset")],
        ["y"],
        name="toy",
    )


def test_around_nominal_uses_nominal_values():
    space = ParameterSpace.around_nominal(_model(), {"k": 0.05, "c": 0.1}, std={"z": 0.01})
    assert space.names == ["k", "c", "z"]
    assert space.mean()["k"] == pytest.approx(1e8)
    assert space.std()["k"] == pytest.approx(5e6)
    assert space.std()["c"] == pytest.approx(0.005)
    for kind in ("lognormal", "uniform", "gumbel", "weibull"):
        sp = ParameterSpace.around_nominal(_model(), {"k": 0.05}, dist=kind)
        assert sp.marginal("k").kind == kind
        assert sp.mean()["k"] == pytest.approx(1e8, rel=1e-9)
        assert sp.std()["k"] == pytest.approx(5e6, rel=1e-7)


def test_around_nominal_mass_outside_range():
    with pytest.raises(ValueError, match=r"'c'.*probability 0\.10\d.*outside.*\[0, 1\]"):
        ParameterSpace.around_nominal(_model(), {"c": 0.8})
    with pytest.warns(UserWarning, match="'c'"):
        ParameterSpace.around_nominal(_model(), {"c": 0.8}, outside="warn")
    sp = ParameterSpace.around_nominal(_model(), {"c": 0.8}, outside="truncate")
    assert sp.marginal("c").kind == "truncnormal"
    x = sp.sample(5000, rng=1)["c"]
    assert x.min() >= 0 and x.max() <= 1
    assert sp.check_range(_model())["c"] == pytest.approx(0.0, abs=1e-15)
    lg = ParameterSpace.around_nominal(_model(), {"c": 0.8}, dist="gumbel", outside="truncate")
    assert lg.marginal("c").kind == "truncated"
    x = lg.sample(5000, rng=1)["c"]
    assert x.min() >= 0 and x.max() <= 1
    assert ParameterSpace.from_json(lg.to_json()) == lg


def test_around_nominal_errors():
    with pytest.raises(ValueError, match="no parameter 'q'"):
        ParameterSpace.around_nominal(_model(), {"q": 0.1})
    with pytest.raises(ValueError, match="'z'.*nominal is 0"):
        ParameterSpace.around_nominal(_model(), {"z": 0.1})
    with pytest.raises(ValueError, match="'k'.*relative std must be > 0"):
        ParameterSpace.around_nominal(_model(), {"k": -0.1})
    with pytest.raises(ValueError, match="outside: unknown"):
        ParameterSpace.around_nominal(_model(), {"k": 0.1}, outside="clip")
    # a space never looks a model up by name (no registry access from gearuq.space)
    with pytest.raises(ValueError, match="does not look models up by name"):
        ParameterSpace.around_nominal("linear_oscillator", {"k": 0.1})


def test_space_package_is_split_and_keeps_its_public_names():
    """gearuq.space is a package; the names callers use stay importable from it, and the
    space modules import neither the registry nor any model."""
    import ast
    import pathlib

    import gearuq.space as space_pkg
    from gearuq.space import CORRELATION_TYPES, KINDS, RULES, Marginal, as_generator
    from gearuq.space.adapters import from_salib, to_chaospy, to_salib

    assert RULES == ("random", "lhs", "sobol", "halton") and "gumbel" in KINDS
    assert CORRELATION_TYPES[0] == "normal" and Marginal.__name__ == "Marginal"
    assert isinstance(as_generator(1), np.random.Generator)
    sp = ParameterSpace.normal(a=(0.0, 1.0), b=(2.0, 0.5))
    assert to_salib(sp) == sp.to_salib()
    assert repr(to_chaospy(sp)) == repr(sp.to_chaospy())
    x = np.array([[0.1, 2.0], [0.2, 2.1]])
    np.testing.assert_array_equal(from_salib(sp, x)["b"], x[:, 1])
    for path in pathlib.Path(space_pkg.__file__).parent.glob("*.py"):
        tree = ast.parse(path.read_text())
        imported = {getattr(n, "module", None) or a.name for n in ast.walk(tree)
                    if isinstance(n, (ast.Import, ast.ImportFrom)) for a in n.names}
        assert not {m for m in imported if m and ("registry" in m or "gearuq_plugins" in m)
                    or m in ("gearuq.model", "gearuq.engines")}, path.name


# ------------------------------------------------------------------------------- bad inputs
BAD_SPECS = [
    ({"name": "b5", "dist": "normal", "mean": 1.0, "std": -0.1}, r"'b5'.*std must be > 0.*-0\.1"),
    ({"name": "b5", "dist": "normal", "mean": 1.0, "std": 0.0}, r"'b5'.*std must be > 0.*0\.0"),
    ({"name": "s", "dist": "uniform", "lower": 2.0, "upper": 1.0},
     r"'s'.*lower 2\.0 must be < upper 1\.0"),
    ({"name": "s", "dist": "uniform", "lower": 1.0, "upper": 1.0},
     r"'s'.*lower 1\.0 must be < upper 1\.0"),
    ({"name": "x", "dist": "cauchyy", "loc": 0}, r"'x'.*unknown distribution type 'cauchyy'; "
     r"valid: normal, lognormal, uniform"),
    ({"name": "x", "dist": "lognormal", "mean": -1.0, "std": 0.1}, r"'x'.*mean must be > 0.*-1"),
    ({"name": "x", "dist": "lognormal", "mean": 1.0, "std": 0.1, "mu": 0.0}, r"'x'.*not both"),
    ({"name": "x", "dist": "lognormal", "mu": 0.0, "sigma": -2.0}, r"'x'.*sigma must be > 0"),
    ({"name": "x", "dist": "truncnormal", "mean": 0, "std": 1, "lower": 1, "upper": 0},
     r"'x'.*lower 1\.0 must be < upper 0\.0"),
    ({"name": "x", "dist": "weibull", "shape": 0.0, "scale": 1.0}, r"'x'.*shape must be > 0"),
    ({"name": "x", "dist": "gumbel", "loc": 0.0, "scale": -1.0}, r"'x'.*scale must be > 0"),
    ({"name": "x", "dist": "triangular", "lower": 0, "mode": 2, "upper": 1}, r"'x'.*mode 2\.0"),
    ({"name": "x", "dist": "loguniform", "lower": 0.0, "upper": 1.0}, r"'x'.*lower must be > 0"),
    ({"name": "x", "dist": "normal", "mean": 1.0}, r"'x'.*missing std"),
    ({"name": "x", "dist": "normal", "mean": 1.0, "std": 1.0, "sd": 2}, r"'x'.*unknown 'sd'"),
    ({"name": "x", "dist": "normal", "mean": "abc", "std": 1.0}, r"'x'.*mean must be a number"),
    ({"name": "x", "dist": "normal", "mean": math.nan, "std": 1.0}, r"'x'.*mean is NaN"),
    ({"name": "x", "dist": "normal", "mean": math.inf, "std": 1.0}, r"'x'.*mean must be finite"),
    ({"name": "x", "mean": 0, "std": 1}, r"'x'.*needs a 'dist'"),
    ({"name": "1x", "dist": "normal", "mean": 0, "std": 1}, r"'1x' is not a valid identifier"),
]


@pytest.mark.parametrize(("spec", "match"), BAD_SPECS)
def test_bad_specs_raise_naming_parameter_and_value(spec, match):
    with pytest.raises(ValueError, match=match):
        ParameterSpace.from_spec([spec])


BAD_CORR = [
    ([[1, 0.5], [0.4, 1]], r"not symmetric.*'a', 'b'.*0\.5.*0\.4"),
    ([[1, 0.5], [0.5, 0.9]], r"diagonal entry for 'b' is 0\.9"),
    ([[1, 1.5], [1.5, 1]], r"\('a', 'b'\) = 1\.5 outside \[-1, 1\]"),
    ([[1, 0.5, 0], [0.5, 1, 0], [0, 0, 1]], r"expected a 2x2 matrix.*shape \(3, 3\)"),
    ([[1, np.nan], [np.nan, 1]], r"not finite"),
]


@pytest.mark.parametrize(("corr", "match"), BAD_CORR)
def test_bad_correlation_matrices(corr, match):
    with pytest.raises(ValueError, match=match):
        ParameterSpace.normal(a=(0, 1), b=(0, 1), correlation=corr)


def test_not_positive_definite_and_bad_pairs():
    r = [[1, 0.9, -0.9], [0.9, 1, 0.9], [-0.9, 0.9, 1]]
    with pytest.raises(ValueError, match="not positive definite.*smallest eigenvalue"):
        ParameterSpace.normal(a=(0, 1), b=(0, 1), c=(0, 1), correlation=r)
    with pytest.raises(ValueError, match="unknown parameter 'q'"):
        ParameterSpace.normal(a=(0, 1), b=(0, 1), correlation={("a", "q"): 0.3})
    with pytest.raises(ValueError, match="correlation_type: unknown 'rank'"):
        ParameterSpace({"a": cp.Normal()}, None, correlation_type="rank")


def test_other_bad_inputs():
    space = ParameterSpace.normal(a=(0, 1))
    with pytest.raises(ValueError, match="unknown sampling rule 'mc'; valid: random, lhs"):
        space.sample(10, rule="mc")
    for n in (0, -3, 2.5, True):
        with pytest.raises(ValueError, match="n:"):
            space.sample(n)
    with pytest.raises(ValueError, match="'ab'.*univariate"):
        ParameterSpace({"ab": cp.J(cp.Normal(), cp.Normal())})
    with pytest.raises(ValueError, match="'q'.*expected a chaospy distribution"):
        ParameterSpace({"q": 3.0})
    with pytest.raises(ValueError, match="non-empty"):
        ParameterSpace({})
    with pytest.raises(ValueError, match="duplicate parameter name 'a'"):
        ParameterSpace.from_spec([{"name": "a", "dist": "normal", "mean": 0, "std": 1}] * 2)
    with pytest.raises(ValueError, match=r"shape \(n, 1\)"):
        space.transform(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="'e'.*cannot evaluate its inverse cdf"):
        ParameterSpace({"e": cp.Normal(0, 1) * 2 + 3})  # a chaospy 4.3 bug, reported clearly

