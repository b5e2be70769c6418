"""Tests of gearuq.fitting: ML fits, ranking, KS/AD statistics, bootstrap p-values, tail pf."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr
from scipy import stats

from gearuq.failure.modes import Band
from gearuq.fitting import FAMILIES, ad_statistic, fit_distributions, ks_statistic

N_LARGE = 5000


# =========================================================================== parameter recovery
def test_lognormal_parameters_recovered():
    s, scale = 0.4, 3.0
    x = stats.lognorm(s, scale=scale).rvs(N_LARGE, random_state=np.random.default_rng(1))
    res = fit_distributions(x, ["lognormal"])
    row = res.dataset.sel(candidate="lognormal")
    # asymptotic SEs: s_hat ~ s/sqrt(2n), ln(scale_hat) ~ s/sqrt(n)
    assert abs(float(row["shape"]) - s) < 4 * s / math.sqrt(2 * N_LARGE)
    assert abs(math.log(float(row["scale"])) - math.log(scale)) < 4 * s / math.sqrt(N_LARGE)
    assert float(row["loc"]) == 0.0 and int(row["loc_fixed"]) == 1
    assert int(row["n_params"]) == 2


def test_rayleigh_scale_recovered_and_bootstrap_se():
    scale, n = 2.0, N_LARGE
    x = stats.rayleigh(scale=scale).rvs(n, random_state=np.random.default_rng(2))
    row = fit_distributions(x, ["rayleigh"]).dataset.sel(candidate="rayleigh")
    se = scale / (2 * math.sqrt(n))
    assert abs(float(row["scale"]) - scale) < 4 * se
    assert float(row["scale"]) == pytest.approx(math.sqrt(np.sum(x**2) / (2 * n)), rel=1e-10)
    assert int(row["n_params"]) == 1
    # parametric-bootstrap SE agrees with the asymptotic one (n = 500, B = 300)
    res = fit_distributions(x[:500], ["rayleigh"], bootstrap=300, rng=3)
    se_boot = float(res.dataset["scale_se"].sel(candidate="rayleigh"))
    assert se_boot == pytest.approx(float(res.dataset["scale"][0]) / (2 * math.sqrt(500)), rel=0.2)


# =========================================================================== model selection
TRUE_FAMILIES = {
    "lognormal": stats.lognorm(0.5, scale=1.0),
    "rayleigh": stats.rayleigh(scale=1.0),
    "normal": stats.norm(10.0, 1.0),
    "weibull": stats.weibull_min(1.5, scale=2.0),
    "gamma": stats.gamma(3.0, scale=1.0),
}


@pytest.mark.parametrize("name", list(TRUE_FAMILIES))
def test_true_family_ranks_first(name):
    x = TRUE_FAMILIES[name].rvs(N_LARGE, random_state=np.random.default_rng(100))
    res = fit_distributions(x)
    assert res.best == name, res.table
    ds = res.dataset
    # Rayleigh is Weibull with c = 2: the 1-parameter-richer Weibull wins on AIC whenever the
    # likelihood-ratio statistic exceeds 2 (P = 0.157 under H0; 20/100 seeds measured), so
    # AIC-first holds for this seed only; BIC (penalty ln 5000 = 8.5, P = 0.004) is robust.
    assert int(ds["bic_rank"].sel(candidate=name)) == 1
    assert str(ds["candidate"][0].values) == name
    assert int(ds["aic_rank"].sel(candidate=name)) == 1
    # AIC sorted, dAIC, weights and BIC ranks consistent
    fitted = ds.where(ds["aic_rank"] > 0, drop=True)
    assert np.all(np.diff(fitted["aic"].values) >= 0)
    assert float(fitted["delta_aic"][0]) == 0.0
    assert float(fitted["aic_weight"].sum()) == pytest.approx(1.0)
    assert sorted(fitted["bic_rank"].values.astype(int)) == list(range(1, fitted.sizes["candidate"]
                                                                       + 1))
    k, ll, n = ds["n_params"], ds["loglik"], N_LARGE
    np.testing.assert_allclose(ds["aic"], 2 * k - 2 * ll)
    np.testing.assert_allclose(ds["bic"], k * math.log(n) - 2 * ll)


def test_parameter_counts_and_free_loc():
    x = stats.gamma(3.0, loc=5.0).rvs(2000, random_state=np.random.default_rng(4))
    fixed = fit_distributions(x, ["lognormal", "rayleigh", "normal", "exponential"]).dataset
    assert dict(zip(fixed["candidate"].values, fixed["n_params"].values, strict=True)) == {
        "lognormal": 2, "rayleigh": 1, "normal": 2, "exponential": 1}
    free = fit_distributions(x, ["gamma", "lognormal", "rayleigh"], floc="free").dataset
    assert dict(zip(free["candidate"].values, free["n_params"].values, strict=True)) == {
        "gamma": 3, "lognormal": 3, "rayleigh": 2}
    assert np.all(free["loc_fixed"].values == 0)
    assert float(free["loc"].sel(candidate="gamma")) == pytest.approx(5.0, abs=0.3)
    shifted = fit_distributions(x, ["gamma"], floc=5.0).dataset
    assert float(shifted["loc"][0]) == 5.0
    assert float(shifted["shape"][0]) == pytest.approx(3.0, rel=0.1)


def test_negative_data_skips_positive_families_with_reason():
    x = stats.norm(0.0, 1.0).rvs(300, random_state=np.random.default_rng(5))
    res = fit_distributions(x, ["normal", "lognormal", "weibull"])
    ds = res.dataset
    assert res.best == "normal"
    status = ds["fit_status"].sel(candidate="lognormal").item()
    assert status.startswith("skipped") and "floc='free'" in status
    assert int(ds["aic_rank"].sel(candidate="weibull")) == -1
    assert np.isnan(float(ds["aic"].sel(candidate="weibull")))
    assert "skipped" in res.table
    with pytest.raises(ValueError, match="not fitted"):
        res.frozen("lognormal")
    with pytest.raises(ValueError, match="no candidate could be fitted"):
        fit_distributions(x, ["lognormal", "gamma"])
    free = fit_distributions(x, ["normal", "weibull"], floc="free").dataset
    assert np.all(free["fit_status"].values == "ok")


# =========================================================================== GOF statistics
def test_ks_statistic_equals_scipy_kstest():
    x = stats.gamma(2.0, scale=1.5).rvs(700, random_state=np.random.default_rng(6))
    res = fit_distributions(x, ["gamma", "lognormal", "weibull", "normal", "gumbel"])
    for name in res.ranking:
        d = res.frozen(name)
        ref = stats.kstest(x, d.cdf)
        row = res.dataset.sel(candidate=name)
        assert float(row["ks_statistic"]) == pytest.approx(ref.statistic, rel=1e-12, abs=1e-15)
        assert float(row["ks_pvalue_naive"]) == pytest.approx(ref.pvalue, rel=1e-8)
        assert ks_statistic(x, d) == pytest.approx(ref.statistic, rel=1e-12)


def test_ad_statistic_equals_scipy_anderson_normal():
    x = stats.norm(3.0, 2.0).rvs(400, random_state=np.random.default_rng(7))
    ref = stats.anderson(x, "norm", method="interpolate").statistic
    # scipy uses mean and ddof=1 std: compare with the same parameters
    ours = ad_statistic(x, stats.norm(x.mean(), x.std(ddof=1)))
    assert ours == pytest.approx(ref, rel=1e-10)


def test_ad_statistic_equals_scipy_anderson_expon_gumbel():
    rng = np.random.default_rng(8)
    xe = stats.expon(scale=2.0).rvs(300, random_state=rng)
    # scipy's expon case uses loc 0 and scale = mean, which is our ML fit with floc = 0
    row = fit_distributions(xe, ["exponential"]).dataset.sel(candidate="exponential")
    assert float(row["scale"]) == pytest.approx(xe.mean(), rel=1e-12)
    ref = stats.anderson(xe, "expon", method="interpolate").statistic
    assert float(row["ad_statistic"]) == pytest.approx(ref, rel=1e-10)
    xg = stats.gumbel_r(1.0, 0.5).rvs(300, random_state=rng)
    # scipy's gumbel_r case uses gumbel_r.fit (ML), as we do
    row = fit_distributions(xg, ["gumbel"]).dataset.sel(candidate="gumbel")
    ref = stats.anderson(xg, "gumbel_r", method="interpolate").statistic
    assert float(row["ad_statistic"]) == pytest.approx(ref, rel=1e-8)


def test_ad_statistic_matches_textbook_formula():
    x = stats.lognorm(0.3).rvs(200, random_state=np.random.default_rng(9))
    d = stats.lognorm(0.32, scale=1.02)
    y = np.sort(x)
    n = y.size
    i = np.arange(1, n + 1)
    a2 = -n - np.sum((2 * i - 1) * (np.log(d.cdf(y)) + np.log(1 - d.cdf(y[::-1])))) / n
    assert ad_statistic(x, d) == pytest.approx(a2, rel=1e-10)
    assert ad_statistic(np.append(x, -1.0), d) == math.inf  # outside the support


# =========================================================================== p-values
def test_bootstrap_pvalues_true_family_vs_wrong_family():
    rng = np.random.default_rng(10)
    x = stats.norm(5.0, 1.0).rvs(200, random_state=rng)
    ds = fit_distributions(x, ["normal"], bootstrap=199, rng=11).dataset
    assert float(ds["ks_pvalue"][0]) > 0.01 and float(ds["ad_pvalue"][0]) > 0.01
    assert int(ds["n_bootstrap_ok"][0]) == 199
    assert "parametric bootstrap" in ds.attrs["pvalue_method"]
    xe = stats.expon().rvs(300, random_state=rng)
    wrong = fit_distributions(xe, ["normal"], bootstrap=199, rng=12).dataset
    assert float(wrong["ks_pvalue"][0]) < 0.01 and float(wrong["ad_pvalue"][0]) < 0.01


# 3-4 s of CPU, a statistical check over many runs: CI runs it with the end-to-end
# runs (-m e2e)
@pytest.mark.e2e
def test_bootstrap_pvalues_roughly_uniform_under_h0_and_naive_is_lenient():
    rng = np.random.default_rng(13)
    p_boot, p_naive = [], []
    for _ in range(40):
        x = stats.norm().rvs(40, random_state=rng)
        ds = fit_distributions(x, ["normal"], bootstrap=99, rng=rng).dataset
        p_boot.append(float(ds["ad_pvalue"][0]))
        p_naive.append(float(ds["ks_pvalue_naive"][0]))
    p_boot = np.array(p_boot)
    assert 0.3 < p_boot.mean() < 0.7
    assert np.mean(p_boot < 0.1) <= 0.25
    # the naive KS p-value ignores the fitted parameters and is biased upwards
    assert np.mean(p_naive) > p_boot.mean() + 0.1
    assert np.mean(p_naive) > 0.7


def test_no_bootstrap_gives_only_labelled_naive_pvalue():
    x = stats.norm().rvs(50, random_state=np.random.default_rng(14))
    ds = fit_distributions(x, ["normal"]).dataset
    assert "ks_pvalue" not in ds and "ad_pvalue" not in ds
    assert "NOT account" in ds["ks_pvalue_naive"].attrs["long_name"]


# =========================================================================== tail probability
@pytest.mark.e2e
def test_upper_tail_pf_from_fit_close_to_exact():
    true = stats.lognorm(0.5, scale=1.0)
    thr = true.isf(1e-3)
    x = true.rvs(N_LARGE, random_state=np.random.default_rng(15))
    # 100 bootstrap refits (half the cost of 200): the lognormal interval's ends move by under
    # 1 % (0.827e-3 and 1.224e-3 against 0.829e-3 and 1.237e-3), 17-22 % from the truth
    res = fit_distributions(x, ["lognormal", "gamma", "weibull"], threshold=thr,
                            bootstrap=100, rng=16)
    ds = res.dataset
    pf = float(ds["pf_fit"].sel(candidate="lognormal"))
    assert pf == pytest.approx(1e-3, rel=0.3)
    assert float(ds["pf_fit_lower"].sel(candidate="lognormal")) <= 1e-3
    assert 1e-3 <= float(ds["pf_fit_upper"].sel(candidate="lognormal"))
    assert float(ds["beta_fit"].sel(candidate="lognormal")) == pytest.approx(
        stats.norm.isf(pf), rel=1e-12)
    k = int(np.sum(x > thr))
    assert int(ds["n_exceed"]) == k and float(ds["pf_empirical"]) == k / N_LARGE
    assert float(ds["pf_empirical_lower"]) <= 1e-3 <= float(ds["pf_empirical_upper"])
    # gamma's lighter tail underestimates the lognormal tail
    assert float(ds["pf_fit"].sel(candidate="gamma")) < 0.5e-3
    assert "empirical pf" in res.table


def test_lower_and_two_sided_tails():
    rng = np.random.default_rng(17)
    x = stats.norm(0.0, 1.0).rvs(N_LARGE, random_state=rng)
    low = fit_distributions(x, ["normal"], threshold=-2.5, tail="lower").dataset
    assert float(low["pf_fit"][0]) == pytest.approx(stats.norm.cdf(-2.5), rel=0.15)
    two = fit_distributions(x, ["normal"], threshold=(-2.0, 2.5), tail="two-sided").dataset
    exact = stats.norm.cdf(-2.0) + stats.norm.sf(2.5)
    assert float(two["pf_fit"][0]) == pytest.approx(exact, rel=0.1)
    assert int(two["n_exceed"]) == int(np.sum((x < -2.0) | (x > 2.5)))
    band = fit_distributions(x, ["normal"], threshold=Band("y", upper=2.0, absolute=True))
    assert float(band.dataset["pf_fit"][0]) == pytest.approx(2 * stats.norm.sf(2.0), rel=0.1)


# =========================================================================== inputs and result
def test_dataarray_with_status_drops_invalid_nan():
    rng = np.random.default_rng(18)
    v = stats.rayleigh().rvs(500, random_state=rng)
    v[:5] = np.nan
    status = np.zeros(500, np.int8)
    status[:5] = 3
    da = xr.DataArray(v, dims="sample", name="amp", attrs={"units": "m"},
                      coords={"status": ("sample", status)})
    res = fit_distributions(da, ["rayleigh", "weibull"])
    assert res.dataset.attrs["n"] == 495 and res.dataset.attrs["n_invalid"] == 5
    assert res.dataset["scale"].attrs["units"] == "m"
    ref = fit_distributions(v[5:], ["rayleigh", "weibull"]).dataset
    np.testing.assert_allclose(res.dataset["scale"], ref["scale"])
    res2 = fit_distributions(da.drop_vars("status"), ["rayleigh"], status=status)
    assert res2.dataset.attrs["n_invalid"] == 5
    with pytest.raises(ValueError, match=r"5 of 500 valid sample\(s\) are non-finite.*status"):
        fit_distributions(da.drop_vars("status"), ["rayleigh"])


def test_bad_inputs():
    x = np.array([1.0, 2.0, 3.0, 4.0])
    with pytest.raises(ValueError, match=r"unknown.*'cauchy'.*valid: lognormal, rayleigh"):
        fit_distributions(x, ["normal", "cauchy"])
    with pytest.raises(ValueError, match="empty"):
        fit_distributions(np.array([]))
    with pytest.raises(ValueError, match=r"1 of 5 valid sample\(s\) are non-finite"):
        fit_distributions(np.append(x, np.inf))
    with pytest.raises(ValueError, match="1-D"):
        fit_distributions(np.ones((3, 3)))
    with pytest.raises(ValueError, match="constant"):
        fit_distributions(np.full(10, 2.0))
    with pytest.raises(ValueError, match="floc"):
        fit_distributions(x, floc="auto")
    with pytest.raises(ValueError, match="two-sided"):
        fit_distributions(x, threshold=(1.0, 2.0))
    with pytest.raises(ValueError, match="tail"):
        fit_distributions(x, threshold=1.0, tail="left")
    with pytest.raises(ValueError, match="bootstrap"):
        fit_distributions(x, bootstrap=-1)
    with pytest.raises(ValueError, match="lower=3 must be < upper=1"):
        fit_distributions(x, threshold=(3.0, 1.0), tail="two-sided")


def test_aliases_frozen_pdf_and_netcdf(tmp_path):
    x = stats.lognorm(0.3, scale=2.0).rvs(300, random_state=np.random.default_rng(19))
    res = fit_distributions(x, ["lognorm", "norm", "weibull_min", "lognormal"])
    assert list(res.dataset["candidate"].values) == sorted(
        ["lognormal", "normal", "weibull"], key=lambda c: float(res.dataset["aic"].sel(
            candidate=c)))
    row = res.dataset.sel(candidate="lognormal")
    grid = np.linspace(0.5, 5, 7)
    ref = stats.lognorm(float(row["shape"]), scale=float(row["scale"]))
    np.testing.assert_allclose(res.pdf("lognormal", grid), ref.pdf(grid))
    np.testing.assert_allclose(res.cdf(None, grid), res.frozen().cdf(grid))
    assert set(FAMILIES) >= {"lognormal", "rayleigh", "normal", "weibull", "gamma"}
    path = tmp_path / "fit.nc"
    res.dataset.to_netcdf(path)
    back = xr.load_dataset(path)
    assert back.attrs["best"] == res.best
    np.testing.assert_allclose(back["aic"], res.dataset["aic"])
