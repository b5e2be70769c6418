"""Polynomial chaos: exactness, analytic moments and Sobol' indices, reliability, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

import gearuq
from gearuq.engines.pce import PolynomialChaos, multi_indices, polynomial_chaos
from gearuq.reliability import Band

PI = math.pi
ISHIGAMI_S1 = np.array([0.313905, 0.442411, 0.0])
ISHIGAMI_ST = np.array([0.557589, 0.442411, 0.243684])


def ishigami_model():
    return gearuq.FunctionModel(
        lambda x1, x2, x3: np.sin(x1) + 7 * np.sin(x2) ** 2 + 0.1 * x3**4 * np.sin(x1),
        ["x1", "x2", "x3"], ["y"], name="ishigami")


def ishigami_space():
    return gearuq.ParameterSpace.uniform(x1=(-PI, PI), x2=(-PI, PI), x3=(-PI, PI))


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("method,kw", [
    ("regression", {"order": 12, "n_samples": 1500, "rule": "lhs"}),
    ("sparse", {"order": 14, "n_samples": 600, "rule": "lhs"}),
    ("quadrature", {"order": 14}),
])
def test_ishigami_sobol_analytic(method, kw):
    pce = polynomial_chaos(ishigami_model(), ishigami_space(), method=method, rng=1, **kw)
    s = pce.sobol()
    np.testing.assert_allclose(s["S1"].values, ISHIGAMI_S1, atol=0.005)
    np.testing.assert_allclose(s["ST"].values, ISHIGAMI_ST, atol=0.005)
    # mean a/2 = 3.5, variance a^2/8 + b pi^4/5 + b^2 pi^8/18 + 1/2
    var = 49 / 8 + 0.1 * PI**4 / 5 + 0.01 * PI**8 / 18 + 0.5
    assert float(pce.mean()) == pytest.approx(3.5, abs=2e-3)
    assert float(pce.variance()) == pytest.approx(var, rel=2e-3)
    assert pce.loo_error["y"] < 1e-4
    assert pce.n_evaluations == (15**3 if method == "quadrature" else kw["n_samples"])


def _poly_model():
    return gearuq.FunctionModel(
        lambda a, b, c: 1.0 + 2 * a - 0.5 * a * b**2 + c**3 - a * b * c,
        ["a", "b", "c"], ["y"], name="cubic")


@pytest.mark.parametrize("method", ["regression", "quadrature", "sparse"])
def test_polynomial_model_reproduced_to_roundoff(method):
    space = gearuq.ParameterSpace({
        "a": {"dist": "normal", "mean": 1.0, "std": 0.5},
        "b": {"dist": "uniform", "lower": -1.0, "upper": 3.0},
        "c": {"dist": "normal", "mean": -2.0, "std": 2.0},
    })
    kw = {"n_samples": 64} if method != "quadrature" else {}
    pce = polynomial_chaos(_poly_model(), space, order=3, method=method, rng=3, **kw)
    x = space.sample(500, rng=9)
    exact = _poly_model().response(x)["y"].values
    np.testing.assert_allclose(pce.predict(x), exact, rtol=1e-10, atol=1e-10)
    assert pce.loo_error["y"] < 1e-20
    # analytic mean: 1 + 2*1 - 0.5*1*E[b^2] + E[c^3] - 1*1*(-2), E[b^2]=1+4/3, E[c^3]=mu^3+3mu s^2
    eb2 = 1.0 + 16.0 / 12.0
    ec3 = (-2.0) ** 3 + 3 * (-2.0) * 4.0
    assert float(pce.mean()) == pytest.approx(1 + 2 - 0.5 * eb2 + ec3 + 2, rel=1e-12)


def test_multi_indices_hyperbolic():
    full = multi_indices(4, 3)
    assert full.shape[0] == math.comb(4 + 3, 3)
    assert np.all(full[0] == 0) and np.all(np.diff(full.sum(axis=1)) >= 0)
    hyp = multi_indices(4, 3, truncation=0.5)
    assert 4 * 3 + 1 <= hyp.shape[0] < full.shape[0]
    assert np.all((np.sum(np.sqrt(hyp), axis=1) ** 2) <= 3 + 1e-9)


def test_linear_oscillator_moments_match_closed_form():
    model = gearuq.get_model("linear_oscillator")
    nominal = model.nominal()
    space = gearuq.ParameterSpace.normal(force=(10.0, 1.0), k=(1.0e4, 400.0))
    pce = polynomial_chaos(model, space, order=8, method="quadrature",
                           outputs="steady_amplitude")
    m, c, w = nominal["m"], nominal["c"], nominal["omega"]

    def g(k):
        return 1.0 / np.hypot(k - m * w**2, c * w)

    def expect(fn):
        return integrate.quad(lambda k: fn(k) * stats.norm.pdf(k, 1e4, 400.0),
                              1e4 - 12 * 400, 1e4 + 12 * 400, epsabs=0, epsrel=1e-12,
                              limit=200)[0]

    ef, ef2 = 10.0, 101.0  # F ~ N(10, 1) stays positive (P(F<0) ~ 1e-23)
    mean = ef * expect(g)
    var = ef2 * expect(lambda k: g(k) ** 2) - mean**2
    assert float(pce.mean()) == pytest.approx(mean, rel=1e-8)
    assert float(pce.variance()) == pytest.approx(var, rel=1e-5)
    # F enters linearly and separately: the first-order index of F is exact closed form
    s = pce.sobol()
    s_f = (ef2 - ef**2) * expect(g) ** 2 / var
    assert float(s["S1"].sel(parameter="force")) == pytest.approx(s_f, rel=1e-4)


def test_time_series_one_fit_compressed_and_schema():
    model = gearuq.get_model("linear_oscillator")
    space = gearuq.ParameterSpace.normal(force=(10.0, 1.0), k=(1.0e4, 300.0))
    t = np.linspace(0.0, 0.2, 41)
    pce = polynomial_chaos(model, space, t, order=5, outputs=["displacement"],
                           n_samples=128, rng=2, compress=0.999999, n_holdout=100)
    assert isinstance(pce, gearuq.Model) and isinstance(pce, PolynomialChaos)
    info = pce.compression["displacement"]
    assert 1 <= info["components"] < t.size and info["energy_lost"] < 1e-6
    assert pce.loo_error["displacement"] < 1e-4
    assert pce.holdout_error["displacement"] < 1e-4
    assert pce.n_evaluations == 128 + 100
    assert pce.loo_error_t["displacement"].shape == t.shape
    x = space.sample(5, rng=1)
    ds = pce.response(x)
    ref = model.response(x, t, outputs="displacement")
    assert ds["displacement"].dims == ("sample", "time")
    np.testing.assert_allclose(ds["time"], t)
    assert ds["k"].attrs["units"] == "N m-1" and ds["displacement"].attrs["units"] == "m"
    assert ds["status"].dtype == np.int8 and np.all(ds["status"] == 0)
    scale = float(np.abs(ref["displacement"]).max())
    np.testing.assert_allclose(ds["displacement"], ref["displacement"], atol=1e-3 * scale)
    # interpolation between fitted instants, and an instant outside is refused
    assert pce.response(x, [0.05])["displacement"].shape == (5, 1)
    with pytest.raises(ValueError, match="fitted on"):
        pce.response(x, [1.0])
    s = pce.sobol("displacement")
    assert s["S1"].dims == ("parameter", "time")
    assert s.to_netcdf() is not None and pce.to_dataset().to_netcdf() is not None


def test_failed_samples_excluded_and_counted():
    def f(a, b):
        y = 1.0 + a + 2.0 * b
        return np.where(a > 1.5, np.nan, y)

    model = gearuq.FunctionModel(f, ["a", "b"], ["y"], name="sometimes_fails")
    space = gearuq.ParameterSpace.normal(a=(0.0, 1.0), b=(0.0, 1.0))
    pce = polynomial_chaos(model, space, order=1, n_samples=200, rule="random", rng=5)
    assert 0 < pce.n_failed < 40 and pce.n_evaluations == 200
    assert float(pce.mean()) == pytest.approx(1.0, abs=1e-12)
    assert float(pce.variance()) == pytest.approx(5.0, rel=1e-12)


def test_correlated_space_through_nataf():
    model = gearuq.FunctionModel(lambda a, b: a + 2 * b, ["a", "b"], ["y"], name="lin")
    space = gearuq.ParameterSpace.normal(correlation=[[1, 0.5], [0.5, 1]],
                                         a=(1.0, 1.0), b=(0.0, 2.0))
    pce = polynomial_chaos(model, space, order=1, n_samples=16, rng=1)
    assert float(pce.mean()) == pytest.approx(1.0, rel=1e-12)
    assert float(pce.variance()) == pytest.approx(1 + 16 + 2 * 0.5 * 1 * 2 * 2, rel=1e-12)
    assert "germ" in pce.sobol().attrs["note"]


def test_order_auto_picks_the_true_degree():
    model = gearuq.FunctionModel(lambda a, b: a**3 - a * b + 0.5 * b**2, ["a", "b"], ["y"])
    space = gearuq.ParameterSpace.normal(a=(0.0, 1.0), b=(1.0, 1.0))
    pce = polynomial_chaos(model, space, order="auto", max_order=5, n_samples=64, rng=1)
    assert pce.order == 3 and pce.loo_error["y"] < 1e-20


def test_linear_limit_state_pf_equals_phi_minus_beta():
    beta = 3.0
    model = gearuq.FunctionModel(lambda x1, x2: beta - (x1 + x2) / math.sqrt(2),
                                 ["x1", "x2"], ["g"], name="linear_ls")
    space = gearuq.ParameterSpace.normal(x1=(0.0, 1.0), x2=(0.0, 1.0))
    pce = polynomial_chaos(model, space, order=1, n_samples=8, rng=0)
    rel = pce.reliability(Band("g", lower=0.0), n_samples=10**6, rng=11)
    pf = float(rel["pf"].sel(mode="g"))
    exact = stats.norm.cdf(-beta)
    assert float(rel["pf_lower"].sel(mode="g")) <= exact <= float(rel["pf_upper"].sel(mode="g"))
    assert pf == pytest.approx(exact, rel=0.1)
    assert rel.attrs["n_model_evaluations"] == 8


K_FOUR_BRANCH = 6 / math.sqrt(2)


def four_branch(x1, x2, k=K_FOUR_BRANCH):
    return np.minimum.reduce([
        3 + 0.1 * (x1 - x2) ** 2 - (x1 + x2) / math.sqrt(2),
        3 + 0.1 * (x1 - x2) ** 2 + (x1 + x2) / math.sqrt(2),
        (x1 - x2) + k,
        (x2 - x1) + k,
    ])


def test_four_branch_mc_and_surrogate():
    from gearuq.engines.pce import compare_mc_surrogate

    model = gearuq.FunctionModel(four_branch, ["x1", "x2"], ["g"], name="four_branch")
    space = gearuq.ParameterSpace.normal(x1=(0.0, 1.0), x2=(0.0, 1.0))
    cmp = compare_mc_surrogate(model, space, Band("g", lower=0.0), n_mc=400_000, order=10,
                               n_samples=1000, method="sparse", rule="lhs",
                               n_surrogate=400_000, rng=3)
    mc = cmp.sel(approach="monte_carlo", mode="g")
    assert float(mc["pf_lower"]) <= 4.4573e-3 <= float(mc["pf_upper"])
    pce_pf = float(cmp["pf"].sel(approach="pce", mode="g"))
    # a global PCE of a min() of branches smooths the kinks: it is biased, not exact.
    # Measured over 5 designs (sparse degree 10, 1000 runs): 4.0e-3 .. 6.9e-3, i.e. up to
    # ~55 % off; full least squares of degree >= 8 overfits and its LOO error says so
    # (docs/pce_sensitivity.md). The assertion states how far, it does not hide it.
    assert 0.5 * 4.4573e-3 < pce_pf < 2.0 * 4.4573e-3
    assert float(cmp["pce_loo_error"]) < 0.2
    assert int(cmp["n_model_evaluations"].sel(approach="pce")) == 1000


def test_bad_input_messages():
    model, space = ishigami_model(), ishigami_space()
    with pytest.raises(ValueError, match="order"):
        polynomial_chaos(model, space, order=-1)
    with pytest.raises(ValueError, match="order"):
        polynomial_chaos(model, space, order=2.5)
    with pytest.raises(ValueError, match=r"not larger than the basis of 20 terms"):
        polynomial_chaos(model, space, order=3, n_samples=10)
    with pytest.raises(ValueError, match="method.*'nope'"):
        polynomial_chaos(model, space, order=2, method="nope")
    other = gearuq.ParameterSpace.normal(zz=(0.0, 1.0))
    with pytest.raises(ValueError, match="'zz' not in model"):
        polynomial_chaos(model, other, order=2)
    with pytest.raises(ValueError, match="truncation"):
        polynomial_chaos(model, space, order=2, truncation=0.0)
    pce = polynomial_chaos(model, space, order=2, n_samples=40, rule="lhs", rng=0)
    with pytest.raises(ValueError, match="unknown parameter"):
        pce.response({"nope": [1.0]})
    with pytest.raises(ValueError, match="not fitted"):
        pce.sobol("nope")


def test_bench_surrogate_quick(tmp_path):
    from gearuq import bench_surrogate

    res = bench_surrogate.run(tmp_path, quick=True)
    assert (tmp_path / "surrogate_bench.md").exists()
    assert (tmp_path / "surrogate_bench.png").stat().st_size > 0
    rows = res["rows"]
    assert {r["benchmark"] for r in rows} == {"ishigami", "g_function", "linear", "four_branch"}
    quad = [r for r in rows if r["benchmark"] == "ishigami" and r["method"] == "PCE quadrature"]
    assert quad[0]["error"] < 1e-5
    lin = [r for r in rows if r["benchmark"] == "linear" and r["method"] == "PCE LS"]
    assert lin[0]["loo"] < 1e-20 and lin[0]["error"] < 0.1
    fb = [r for r in rows if r["benchmark"] == "four_branch" and r["method"] == "MC"][-1]
    assert fb["pf_lower"] <= bench_surrogate.FOUR_BRANCH_PF <= fb["pf_upper"]
