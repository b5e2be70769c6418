"""Polynomial chaos: exactness, analytic moments and Sobol' indices, sparse selection against
independent oracles, fit on labelled data, storage round trip, reliability, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

import gearuq
from gearuq.engines.pce import PolynomialChaos, multi_indices, polynomial_chaos
from gearuq.engines.pce.basis import basis_matrix
from gearuq.engines.pce.regression import greedy_path
from gearuq.failure.modes import Band
from gearuq.model import Option
from gearuq.testing.problems import (
    FOUR_BRANCH_PF,
    ISHIGAMI_MEAN,
    ISHIGAMI_S1,
    ISHIGAMI_ST,
    ISHIGAMI_VARIANCE,
    four_branch_model,
    ishigami_model,
    ishigami_space,
    linear_limit_state_model,
    linear_limit_state_pf,
    standard_normal_space,
)


@pytest.mark.e2e
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
    assert float(pce.mean()) == pytest.approx(ISHIGAMI_MEAN, abs=2e-3)
    assert float(pce.variance()) == pytest.approx(ISHIGAMI_VARIANCE, rel=2e-3)
    assert pce.loo_error["y"] < 1e-4
    assert pce.n_evaluations == (15**3 if method == "quadrature" else kw["n_samples"])


def test_sparse_ishigami_auto_degree_reaches_the_issue_target():
    """Auto degree <= 14, N = 512: hold-out error <= 1e-9 (issue 8 item 6; measured 1.6e-11).

    The hold-out set is independent of the design (random draws, another seed) and the
    error is computed here from the exact function, not by the engine.
    """
    model, space = ishigami_model(), ishigami_space()
    pce = polynomial_chaos(model, space, order="auto", max_order=14, method="sparse",
                           n_samples=512, rng=1)
    x = space.sample(4000, "random", 99)
    exact = model.fn(**x)
    holdout = np.mean((pce.predict(x) - exact) ** 2) / np.var(exact)
    assert holdout <= 1e-9
    assert pce.order >= 12 and pce.n_terms < 150  # sparse: a few dozen of 680 candidates
    np.testing.assert_allclose(pce.sobol()["S1"].values, ISHIGAMI_S1, atol=1e-6)
    np.testing.assert_allclose(pce.sobol()["ST"].values, ISHIGAMI_ST, atol=1e-6)
    # the corrected LOO is larger than the plain one, and both are below 1e-9 here; the
    # hold-out error is larger than either (selection bias; docs/pce_sensitivity.md)
    assert pce.loo_error["y"] <= pce.corrected_loo_error["y"] <= 1e-9
    assert pce.fit_info["n_design"] == 512 and pce.fit_info["orders_tried"][-1] == pce.order


def _design(n=120, p=6, seed=0):
    rng = np.random.default_rng(seed)
    z = rng.uniform(-1, 1, (n, 2))
    idx = multi_indices(2, p)
    psi = basis_matrix(z, idx, ["uniform", "uniform"])
    y = np.exp(0.7 * z[:, 0]) * np.cos(2 * z[:, 1]) + 0.05 * rng.standard_normal(n)
    return psi, y


def test_lar_order_matches_scikit_learn():
    """Independent implementation: sklearn's lars_path (method='lar') on the same
    standardised columns activates the same columns in the same order."""
    linear_model = pytest.importorskip("sklearn.linear_model")
    psi, y = _design()
    path = greedy_path(psi, y, "lars", patience=10**6)
    x = psi[:, 1:] - psi[:, 1:].mean(axis=0)
    x /= np.linalg.norm(x, axis=0)
    _, active, _ = linear_model.lars_path(x, y - y.mean(), method="lar", max_iter=20)
    np.testing.assert_array_equal(np.asarray(path.order[1:21]) - 1, np.asarray(active)[:20])


@pytest.mark.parametrize("solver", ["lars", "omp"])
def test_incremental_loo_equals_explicit_hat_matrix(solver):
    """Every prefix's LOO (Gram-Schmidt updates) equals the brute-force leave-one-out refit
    for a few prefixes, and the corrected LOO the explicit Chapelle factor."""
    psi, y = _design(n=60, p=4)
    path = greedy_path(psi, y, solver, patience=10**6)
    var = np.var(y, ddof=1)
    for k in (2, 5, 9):
        cols = path.order[:k]
        a = psi[:, cols]
        loo = []
        for i in range(a.shape[0]):  # drop sample i, refit, predict it
            keep = np.arange(a.shape[0]) != i
            c = np.linalg.lstsq(a[keep], y[keep], rcond=None)[0]
            loo.append(y[i] - a[i] @ c)
        direct = np.mean(np.square(loo)) / var
        assert path.loo[k - 2] == pytest.approx(direct, rel=1e-9)
        n, p = a.shape
        factor = n / (n - p) * (1 + np.trace(np.linalg.inv(a.T @ a)))
        assert path.corrected[k - 2] == pytest.approx(direct * factor, rel=1e-8)


def test_omp_picks_the_column_most_correlated_with_the_residual():
    psi, y = _design(n=80, p=5, seed=3)
    path = greedy_path(psi, y, "omp", patience=10**6)
    for k in (1, 4, 7):
        a = psi[:, path.order[:k]]
        res = y - a @ np.linalg.lstsq(a, y, rcond=None)[0]
        x = psi[:, 1:] - psi[:, 1:].mean(axis=0)
        score = np.abs(x.T @ res) / np.linalg.norm(x, axis=0)
        score[np.asarray(path.order[1:k], dtype=int) - 1] = -1
        assert path.order[k] == int(np.argmax(score)) + 1


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


def test_fit_on_a_monte_carlo_result_equals_the_pipeline():
    """The same design evaluated by monte_carlo and fitted by PolynomialChaos.fit gives the
    coefficients of polynomial_chaos (design -> evaluate -> fit are the same three steps)."""
    model, space = ishigami_model(), ishigami_space()
    pce = polynomial_chaos(model, space, order=6, method="sparse", n_samples=256, rng=4)
    ds = gearuq.monte_carlo(model, space, n_samples=256, rule="sobol", rng=4,
                            executor="serial", progress=False)
    refit = PolynomialChaos(space, order=6, method="sparse").fit(ds)
    np.testing.assert_array_equal(refit.indices, pce.indices)
    np.testing.assert_allclose(refit.coefficients["y"], pce.coefficients["y"], rtol=1e-12,
                               atol=1e-14)
    assert refit.source_model == "ishigami" and refit.n_evaluations == 256
    # plain arrays work too, failed samples (status != 0) are excluded and counted
    x = {k: ds[k].values for k in space.names}
    status = np.zeros(256, dtype=int)
    status[:10] = 3
    y = np.where(status == 0, ds["y"].values, np.nan)
    arr = PolynomialChaos(space, order=6, method="sparse").fit(x, {"y": y}, status=status)
    assert arr.n_failed == 10 and arr.n_evaluations == 256
    assert float(arr.mean()) == pytest.approx(float(pce.mean()), abs=0.05)


def test_saved_surrogate_rebuilds_identically(tmp_path):
    model = gearuq.get_model("linear_oscillator")
    space = gearuq.ParameterSpace.normal(force=(10.0, 1.0), k=(1.0e4, 300.0))
    t = np.linspace(0.0, 0.1, 11)
    pce = polynomial_chaos(model, space, t, order=4, method="sparse",
                           outputs=["displacement", "steady_amplitude"], n_samples=64, rng=2)
    gearuq.save(pce.to_dataset(), tmp_path / "pce.nc")
    back = PolynomialChaos.from_dataset(gearuq.load(tmp_path / "pce.nc"))
    x = space.sample(50, rng=8)
    for o in ("displacement", "steady_amplitude"):
        np.testing.assert_array_equal(back.predict(x, o), pce.predict(x, o))
        assert back.loo_error[o] == pce.loo_error[o]
        assert back.corrected_loo_error[o] == pce.corrected_loo_error[o]
    np.testing.assert_array_equal(back.sobol("displacement")["ST"],
                                  pce.sobol("displacement")["ST"])
    assert back.order == pce.order and back.n_terms == pce.n_terms
    assert back.germ_kinds == pce.germ_kinds and back.name == pce.name
    assert back.response(x)["k"].attrs["units"] == "N m-1"
    with pytest.raises(ValueError, match="not a saved polynomial chaos"):
        PolynomialChaos.from_dataset(gearuq.load(tmp_path / "pce.nc").drop_vars("multi_index"))


def test_fitted_surrogate_honours_the_plugin_contract():
    """A fitted surrogate is a Model: conformance checker (pickle and netCDF round trips
    included), for a static and a time-dependent output."""
    from gearuq.testing import check_model

    check_model(polynomial_chaos(ishigami_model(), ishigami_space(), order=4, method="sparse",
                                 n_samples=64, rng=1))
    model = gearuq.get_model("linear_oscillator")
    space = gearuq.ParameterSpace.normal(force=(10.0, 1.0), k=(1.0e4, 300.0))
    t = np.linspace(0.0, 0.1, 11)
    check_model(polynomial_chaos(model, space, t, order=3, outputs=["displacement"],
                                 n_samples=32, rng=1), t)


def test_repr_and_summary_say_what_the_surrogate_is():
    space = ishigami_space()
    unfitted = PolynomialChaos(space, order=5, method="sparse")
    assert "not fitted" in repr(unfitted)
    with pytest.raises(ValueError, match="not fitted"):
        unfitted.response({"x1": [0.0], "x2": [0.0], "x3": [0.0]})
    pce = polynomial_chaos(ishigami_model(), space, order=5, method="sparse", n_samples=128,
                           rng=1, n_holdout=64)
    text = repr(pce)
    assert "sparse" in text and f"{pce.n_terms} terms" in text and "ishigami" in text
    summary = pce.summary()
    for needle in ("LOO", "corrected LOO", "hold-out", "Legendre", "optimistic",
                   f"{pce.n_evaluations} model runs"):
        assert needle in summary


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


def test_correlated_space_indices_are_labelled_nataf_innovations():
    """y = a + 2 b with corr(a, b) = rho: the germ of a carries the full index of a,
    Var(E[y|a]) / V = (s_a + 2 rho s_b)^2 / V, the germ of b only the part of b independent
    of a, 4 s_b^2 (1 - rho^2) / V (closed forms of the linear Gaussian case)."""
    model = gearuq.FunctionModel(lambda a, b: a + 2 * b, ["a", "b"], ["y"], name="lin")
    rho, sa, sb = 0.5, 1.0, 2.0
    space = gearuq.ParameterSpace.normal(correlation=[[1, rho], [rho, 1]],
                                         a=(1.0, sa), b=(0.0, sb))
    pce = polynomial_chaos(model, space, order=1, n_samples=16, rng=1)
    var = sa**2 + 4 * sb**2 + 4 * rho * sa * sb
    assert float(pce.mean()) == pytest.approx(1.0, rel=1e-12)
    assert float(pce.variance()) == pytest.approx(var, rel=1e-12)
    with pytest.warns(UserWarning, match="depend on the order"):
        s = pce.sobol()
    assert float(s["S1"].sel(parameter="a")) == pytest.approx((sa + 2 * rho * sb) ** 2 / var,
                                                              rel=1e-10)
    assert float(s["S1"].sel(parameter="b")) == pytest.approx(4 * sb**2 * (1 - rho**2) / var,
                                                              rel=1e-10)
    assert list(s["germ_variable"].values) == ["a", "b | a"] and "order" in s.attrs["note"]


def test_order_auto_picks_the_true_degree():
    model = gearuq.FunctionModel(lambda a, b: a**3 - a * b + 0.5 * b**2, ["a", "b"], ["y"])
    space = gearuq.ParameterSpace.normal(a=(0.0, 1.0), b=(1.0, 1.0))
    pce = polynomial_chaos(model, space, order="auto", max_order=5, n_samples=64, rng=1)
    assert pce.order == 3 and pce.loo_error["y"] < 1e-20


def test_linear_limit_state_pf_equals_phi_minus_beta():
    pce = polynomial_chaos(linear_limit_state_model(), standard_normal_space(2), order=1,
                           n_samples=8, rng=0)
    rel = pce.reliability(Band("g", lower=0.0), n_samples=10**6, rng=11)
    pf = float(rel["pf"].sel(mode="g"))
    exact = linear_limit_state_pf()
    assert float(rel["pf_lower"].sel(mode="g")) <= exact <= float(rel["pf_upper"].sel(mode="g"))
    assert pf == pytest.approx(exact, rel=0.1)
    assert rel.attrs["n_model_evaluations"] == 8 and rel.attrs["seed"] == 11


def _shifted(x1, x2, shift=0.0):
    return 3.0 - shift - (x1 + x2) / math.sqrt(2.0)


def test_compare_mc_surrogate_uses_the_model_options_on_both_sides():
    """Regression test of the issue-8 bug: ``shift=5`` reached the PCE fit but not the Monte
    Carlo reference (Pf 0.0225 against 0.9987). With g = 3 - shift - (x1 + x2)/sqrt(2),
    shift = 5 gives Pf = Phi(2) on both sides."""
    from gearuq.engines.pce import compare_mc_surrogate

    model = gearuq.FunctionModel(_shifted, ["x1", "x2"], ["g"], name="shifted_linear",
                                 options=[Option("shift", 0.0, "offset of the limit state")])
    space = standard_normal_space(2)
    cmp = compare_mc_surrogate(model, space, Band("g", lower=0.0), n_mc=20_000, order=1,
                               n_samples=8, n_surrogate=20_000, rng=3,
                               model_options={"shift": 5.0})
    exact = stats.norm.cdf(2.0)
    for approach in ("monte_carlo", "pce"):
        row = cmp.sel(approach=approach, mode="g")
        assert float(row["pf_lower"]) <= exact <= float(row["pf_upper"]), approach
    assert '"shift": 5.0' in cmp.attrs["options"]
    # a reference made with other options is refused, and so is an unknown option
    mc = gearuq.monte_carlo(model, space, n_samples=100, rng=1, executor="serial",
                            progress=False)
    with pytest.raises(ValueError, match="computed with model options"):
        compare_mc_surrogate(model, space, Band("g", lower=0.0), n_mc=100, mc=mc,
                             model_options={"shift": 5.0})
    with pytest.raises(ValueError, match="unknown option"):
        compare_mc_surrogate(model, space, Band("g", lower=0.0), n_mc=100, shfit=5.0)


def test_four_branch_mc_and_surrogate():
    from gearuq.engines.pce import compare_mc_surrogate

    cmp = compare_mc_surrogate(four_branch_model(), standard_normal_space(2),
                               Band("g", lower=0.0), n_mc=400_000, order=10, n_samples=1000,
                               method="sparse", rule="lhs", n_surrogate=400_000, rng=3)
    mc = cmp.sel(approach="monte_carlo", mode="g")
    assert float(mc["pf_lower"]) <= FOUR_BRANCH_PF <= float(mc["pf_upper"])
    pce_pf = float(cmp["pf"].sel(approach="pce", mode="g"))
    # a global PCE of a min() of branches smooths the kinks: it is biased, not exact
    # (docs/pce_sensitivity.md gives the spread over designs); the assertion states how
    # far, it does not hide it
    assert 0.5 * FOUR_BRANCH_PF < pce_pf < 2.0 * FOUR_BRANCH_PF
    assert float(cmp["pce_loo_error"]) < 0.2
    assert int(cmp["n_model_evaluations"].sel(approach="pce")) == 1000


_CALLS: list[int] = []


def _counted(x1, x2):
    _CALLS.append(x1.size)  # a module global: the store fingerprint hashes closures, not these
    return np.exp(0.3 * x1) + x2**2


def test_store_resumes_without_running_the_model_again(tmp_path):
    model = gearuq.FunctionModel(_counted, ["x1", "x2"], ["y"], name="counted")
    space = standard_normal_space(2)
    _CALLS.clear()
    kw = {"order": 4, "method": "sparse", "n_samples": 64, "rng": 7, "n_holdout": 32,
          "store": tmp_path / "run", "chunk_size": 16}
    first = polynomial_chaos(model, space, **kw)
    n_calls = len(_CALLS)
    assert sum(_CALLS) == 64 + 32
    again = polynomial_chaos(model, space, **kw)
    assert len(_CALLS) == n_calls  # every chunk came from the store
    np.testing.assert_array_equal(again.coefficients["y"], first.coefficients["y"])
    assert again.holdout_error == first.holdout_error
    assert (tmp_path / "run" / "design").is_dir() and (tmp_path / "run" / "holdout").is_dir()


def test_rng_none_records_a_seed_that_reproduces_the_fit():
    model, space = ishigami_model(), ishigami_space()
    a = polynomial_chaos(model, space, order=3, n_samples=64, rule="lhs")
    b = polynomial_chaos(model, space, order=3, n_samples=64, rule="lhs",
                         rng=a.fit_info["seed"])
    np.testing.assert_array_equal(a.coefficients["y"], b.coefficients["y"])


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
    with pytest.raises(ValueError, match="solver.*'lasso'"):
        polynomial_chaos(model, space, order=2, method="sparse", solver="lasso")
    with pytest.raises(ValueError, match="compress"):
        PolynomialChaos(space, compress=0)
    other = gearuq.ParameterSpace.normal(zz=(0.0, 1.0))
    with pytest.raises(ValueError, match="'zz' not in model"):
        polynomial_chaos(model, other, order=2)
    with pytest.raises(ValueError, match="truncation"):
        polynomial_chaos(model, space, order=2, truncation=0.0)
    with pytest.raises(ValueError, match="unknown option"):
        polynomial_chaos(model, space, order=2, model_options={"rtol": 1e-3})
    pce = polynomial_chaos(model, space, order=2, n_samples=40, rule="lhs", rng=0)
    with pytest.raises(ValueError, match="unknown parameter"):
        pce.response({"nope": [1.0]})
    with pytest.raises(ValueError, match="not fitted"):
        pce.sobol("nope")
    with pytest.raises(ValueError, match="no variable.*x9"):
        PolynomialChaos(gearuq.ParameterSpace.normal(x9=(0.0, 1.0))).fit(
            gearuq.monte_carlo(model, space, n_samples=8, rng=1, executor="serial"))


# e2e: the whole surrogate benchmark in its quick mode (four problems, eight methods), 2.5 CPU s
@pytest.mark.e2e
def test_bench_surrogate_quick(tmp_path):
    """The quick run of the surrogate benchmark (its numbers asserted)."""
    from gearuq.bench import surrogate as bench_surrogate

    res = bench_surrogate.run(tmp_path, quick=True)
    assert (tmp_path / "surrogate_bench.md").exists()
    assert (tmp_path / "surrogate_bench.png").stat().st_size > 0
    rows = res["rows"]
    assert {r["benchmark"] for r in rows} == {"ishigami", "g_function", "linear", "four_branch"}

    def row(bench, method):
        return [r for r in rows if r["benchmark"] == bench and r["method"] == method]

    assert row("ishigami", "PCE quadrature")[0]["error"] < 1e-5
    sparse = row("ishigami", "PCE sparse auto")[0]
    assert sparse["holdout"] <= 1e-9 and sparse["error"] < 1e-6 and sparse["n_eval"] == 512
    lin = row("linear", "PCE LS")[0]
    assert lin["loo"] < 1e-20 and lin["error"] < 0.1
    fb = row("four_branch", "MC")[-1]
    assert fb["pf_lower"] <= FOUR_BRANCH_PF <= fb["pf_upper"]
    # Sobol' MC error shrinks with N (N = 2^8 -> 2^12: expected 4x, allow 2x)
    mc = row("ishigami", "Sobol MC (saltelli)")
    assert mc[-1]["error"] < 0.5 * mc[0]["error"]
