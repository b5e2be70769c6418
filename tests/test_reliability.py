"""Tests of gearuq.failure.samples (the module behind ``gearuq.reliability``): intervals, beta,
bands, limit states, system and first-passage estimates, streaming, design labels, and the
one entry point ``failure_probability`` with its report form."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr
from scipy import stats

from gearuq.failure.intervals import (
    beta_from_pf,
    clopper_pearson_interval,
    mean_value_beta,
    pf_from_beta,
    wilson_interval,
)
from gearuq.failure.modes import Band
from gearuq.failure.samples import reliability
from gearuq.model import FunctionModel

Z975 = stats.norm.isf(0.025)


def _dataset(values: dict, status=None, time=None, units="m") -> xr.Dataset:
    """Build a result Dataset with the model schema from arrays (sample[, time])."""
    n = len(next(iter(values.values())))
    coords = {"sample": np.arange(n)}
    if time is not None:
        coords["time"] = ("time", np.asarray(time, dtype=float), {"units": "s"})
    ds = xr.Dataset(coords=coords)
    for k, v in values.items():
        v = np.asarray(v, dtype=float)
        dims = ("sample", "time") if v.ndim == 2 else ("sample",)
        ds[k] = (dims, v, {"units": units, "role": "output"})
    st = np.zeros(n, np.int8) if status is None else np.asarray(status, np.int8)
    ds["status"] = ("sample", st)
    return ds


# =========================================================================== intervals
def test_wilson_hand_values():
    # k=5, n=20, 95 %: closed form with z = 1.95996...
    k, n, z = 5, 20, Z975
    p = k / n
    centre = (p + z**2 / (2 * n)) / (1 + z**2 / n)
    half = z * math.sqrt(p * (1 - p) / n + z**2 / (4 * n**2)) / (1 + z**2 / n)
    lo, up = wilson_interval(k, n, 0.95)
    assert lo == pytest.approx(centre - half, abs=1e-12)
    assert up == pytest.approx(centre + half, abs=1e-12)
    # the textbook values for 5/20
    assert lo == pytest.approx(0.1119, abs=1e-4)
    assert up == pytest.approx(0.4687, abs=1e-4)
    # k = 0: lower exactly 0, upper z^2/(n + z^2)
    lo, up = wilson_interval(0, 50, 0.95)
    assert lo == 0.0
    assert up == pytest.approx(z**2 / (50 + z**2), rel=1e-12)
    lo, up = wilson_interval(50, 50, 0.95)
    assert up == 1.0
    assert lo == pytest.approx(1 - z**2 / (50 + z**2), rel=1e-12)


def test_clopper_pearson_hand_values():
    n, alpha = 40, 0.05
    lo, up = clopper_pearson_interval(0, n, 0.95)
    assert lo == 0.0
    assert up == pytest.approx(1 - (alpha / 2) ** (1 / n), rel=1e-10)
    lo, up = clopper_pearson_interval(n, n, 0.95)
    assert up == 1.0
    assert lo == pytest.approx((alpha / 2) ** (1 / n), rel=1e-10)
    lo, up = clopper_pearson_interval(5, 20, 0.95)
    assert lo == pytest.approx(0.0866, abs=1e-4)
    assert up == pytest.approx(0.4910, abs=1e-4)
    # k = 1: lower bound solves 1 - (1 - p)^n = alpha/2
    lo, _ = clopper_pearson_interval(1, n, 0.95)
    assert 1 - (1 - lo) ** n == pytest.approx(alpha / 2, rel=1e-8)


def test_intervals_vectorised_and_contain_estimate():
    k = np.arange(0, 31)
    for fn in (wilson_interval, clopper_pearson_interval):
        lo, up = fn(k, 30, 0.9)
        assert lo.shape == up.shape == (31,)
        assert np.all(lo <= k / 30) and np.all(k / 30 <= up)
        assert np.all(np.diff(lo) > 0) and np.all(np.diff(up) > 0)
    # CP is wider than Wilson
    lo_w, up_w = wilson_interval(k, 30)
    lo_c, up_c = clopper_pearson_interval(k, 30)
    assert np.all(up_c - lo_c >= up_w - lo_w - 1e-12)


def test_interval_exact_coverage():
    """Exact binomial coverage: CP >= nominal at every p, Wilson close to nominal on average."""
    n = 60
    k = np.arange(n + 1)
    lo_c, up_c = clopper_pearson_interval(k, n, 0.95)
    lo_w, up_w = wilson_interval(k, n, 0.95)
    cov_c, cov_w = [], []
    for p in np.linspace(0.01, 0.99, 197):
        pmf = stats.binom.pmf(k, n, p)
        cov_c.append(pmf[(lo_c <= p) & (p <= up_c)].sum())
        cov_w.append(pmf[(lo_w <= p) & (p <= up_w)].sum())
    assert min(cov_c) >= 0.95 - 1e-9
    assert 0.94 <= np.mean(cov_w) <= 0.96


@pytest.mark.parametrize("fn", [wilson_interval, clopper_pearson_interval])
def test_interval_coverage_by_simulation(fn):
    rng = np.random.default_rng(11)
    p, n = 0.05, 200
    k = rng.binomial(n, p, size=2000)
    lo, up = fn(k, n, 0.95)
    coverage = np.mean((lo <= p) & (p <= up))
    assert 0.93 <= coverage <= 0.99  # nominal 0.95; 2000 draws give SE ~ 0.005


def test_interval_bad_input():
    with pytest.raises(ValueError, match="0 <= k <= n"):
        wilson_interval(5, 3)
    with pytest.raises(ValueError, match="n must be >= 1"):
        clopper_pearson_interval(0, 0)
    with pytest.raises(ValueError, match="confidence"):
        wilson_interval(1, 3, 1.5)


# =========================================================================== beta helpers
def test_beta_pf_helpers():
    b = np.array([-1.0, 0.0, 1.5, 3.0, 6.0])
    np.testing.assert_allclose(beta_from_pf(pf_from_beta(b)), b, rtol=1e-12, atol=1e-12)
    assert pf_from_beta(3.0) == pytest.approx(stats.norm.cdf(-3.0), rel=1e-14)
    assert beta_from_pf(1e-20) == pytest.approx(9.262340, abs=1e-5)  # isf stays accurate
    assert beta_from_pf(0.0) == math.inf


# =========================================================================== linear limit state
def test_linear_limit_state_normal_inputs():
    a, b1, b2 = 2.6, 1.0, -0.7
    beta_exact = a / math.hypot(b1, b2)
    model = FunctionModel(lambda x1, x2: a + b1 * x1 + b2 * x2, ["x1", "x2"], ["y"])
    rng = np.random.default_rng(2024)
    n = 40_000
    ds = model.response({"x1": rng.standard_normal(n), "x2": rng.standard_normal(n)})
    res = reliability(ds, Band("y", lower=0.0), system=False)
    m = res.sel(mode="y")
    assert m["beta_lower"] <= beta_exact <= m["beta_upper"]
    assert m["pf_lower"] <= stats.norm.cdf(-beta_exact) <= m["pf_upper"]
    assert float(m["beta"]) == pytest.approx(beta_exact, abs=0.05)
    # identity pf = Phi(-beta) for the estimate and its interval
    assert float(m["pf"]) == pytest.approx(pf_from_beta(float(m["beta"])), rel=1e-12)
    assert float(m["pf_upper"]) == pytest.approx(pf_from_beta(float(m["beta_lower"])), rel=1e-12)
    assert float(m["r"]) == pytest.approx(1 - float(m["pf"]))
    # generalised beta = Cornell beta for a normal response (up to MC error)
    b_mv = mean_value_beta(ds["y"], lower=0.0)
    assert float(b_mv) == pytest.approx(beta_exact, abs=0.02)
    assert "Cornell" in b_mv.attrs["long_name"]
    width = float(m["beta_upper"] - m["beta_lower"])
    assert abs(float(b_mv) - float(m["beta"])) < width
    # coefficient of variation of the estimator
    pf, k = float(m["pf"]), int(m["n_failures"])
    assert float(m["cov_pf"]) == pytest.approx(math.sqrt((1 - pf) / (n * pf)))
    assert k == int(np.sum(ds["y"].values < 0))


def test_cornell_differs_from_generalised_for_skewed_response():
    rng = np.random.default_rng(5)
    y = rng.lognormal(0.0, 0.6, 50_000)
    upper = 4.0
    exact_beta = stats.norm.isf(stats.lognorm(0.6).sf(upper))
    res = reliability(_dataset({"y": y}), Band("y", upper=upper), system=False)
    assert float(res["beta"].sel(mode="y")) == pytest.approx(exact_beta, abs=0.05)
    b_mv = mean_value_beta(y, upper=upper)
    assert abs(b_mv - exact_beta) > 0.3  # labelled Cornell index: not Phi^-1(R) here
    # two-sided: minimum over the sides
    assert mean_value_beta(y, lower=0.5, upper=upper) == pytest.approx(
        min((y.mean() - 0.5) / y.std(ddof=1), (upper - y.mean()) / y.std(ddof=1)))


# =========================================================================== bounds at k=0, k=n
@pytest.mark.parametrize("method", ["wilson", "clopper-pearson"])
def test_zero_failures_gives_finite_lower_bound(method):
    n = 500
    y = np.linspace(-1, 1, n)
    res = reliability(_dataset({"y": y}), {"y": (-2.0, 2.0)}, interval=method, system=False)
    m = res.sel(mode="y")
    assert int(m["n_failures"]) == 0 and float(m["pf"]) == 0.0
    assert int(m["beta_is_lower_bound"]) == 1 and int(m["beta_is_upper_bound"]) == 0
    assert np.isfinite(float(m["beta"]))
    assert float(m["beta"]) == pytest.approx(-stats.norm.ppf(float(m["pf_upper"])), rel=1e-12)
    assert float(m["beta"]) == float(m["beta_lower"])
    assert float(m["beta_upper"]) == math.inf
    if method == "clopper-pearson":
        assert float(m["pf_upper"]) == pytest.approx(1 - 0.025 ** (1 / n), rel=1e-10)
    assert float(m["cov_pf"]) == math.inf


@pytest.mark.parametrize("method", ["wilson", "clopper-pearson"])
def test_all_failures_symmetric(method):
    n = 500
    y = np.linspace(3, 4, n)
    res = reliability(_dataset({"y": y}), Band("y", upper=2.0), interval=method, system=False)
    m = res.sel(mode="y")
    assert float(m["pf"]) == 1.0
    assert int(m["beta_is_upper_bound"]) == 1 and int(m["beta_is_lower_bound"]) == 0
    assert np.isfinite(float(m["beta"]))
    assert float(m["beta"]) == pytest.approx(-stats.norm.ppf(float(m["pf_lower"])), rel=1e-12)
    assert float(m["beta_lower"]) == -math.inf
    # symmetric to the zero-failure case
    res0 = reliability(_dataset({"y": -y}), Band("y", upper=-2.0), interval=method)
    res1 = reliability(_dataset({"y": -y}), Band("y", lower=-2.0), interval=method)
    assert float(res1["beta"].sel(mode="y")) == pytest.approx(-float(res0["beta"].sel(mode="y")))


# =========================================================================== system
def test_series_system_independent_modes():
    rng = np.random.default_rng(7)
    n = 40_000
    y1, y2 = rng.standard_normal(n), rng.standard_normal(n)
    u1, u2 = stats.norm.isf(0.04), stats.norm.isf(0.07)
    res = reliability(_dataset({"y1": y1, "y2": y2}), {"y1": (None, u1), "y2": (None, u2)})
    assert list(res["mode"].values) == ["y1", "y2", "system"]
    s = res.sel(mode="system")
    exact = 1 - (1 - 0.04) * (1 - 0.07)
    assert float(s["pf_lower"]) <= exact <= float(s["pf_upper"])
    assert int(s["n_failures"]) == int(np.sum((y1 > u1) | (y2 > u2)))
    # series bounds: max(p_i) <= P_sys <= sum(p_i)
    p = res["pf"].sel(mode=["y1", "y2"]).values
    assert p.max() <= float(s["pf"]) <= p.sum()


def test_series_system_fully_correlated_equals_single():
    rng = np.random.default_rng(8)
    y = rng.standard_normal(5000)
    ds = _dataset({"y": y})
    res = reliability(ds, [Band("y", upper=1.5, name="a"), Band("y", upper=1.5, name="b")])
    for var in ("pf", "pf_lower", "pf_upper", "beta", "n_failures"):
        assert float(res[var].sel(mode="system")) == float(res[var].sel(mode="a"))
    # a stricter band on the same output dominates the system
    res = reliability(ds, [Band("y", upper=1.5, name="a"), Band("y", upper=1.0, name="b")])
    assert float(res["pf"].sel(mode="system")) == float(res["pf"].sel(mode="b"))


# =========================================================================== first passage
def test_first_passage_properties():
    rng = np.random.default_rng(3)
    n, t = 4000, np.linspace(0, 10, 41)
    amp = rng.rayleigh(1.0, (n, 1))
    phase = rng.uniform(0, 2 * np.pi, (n, 1))
    y1 = amp * np.sin(1.3 * t + phase)
    y2 = 0.5 * rng.standard_normal((n, 1)) + 0.05 * t
    ds = _dataset({"y1": y1, "y2": y2}, time=t)
    res = reliability(ds, [Band("y1", -1.8, 1.8), Band("y2", upper=0.8)])
    assert res["pf"].dims == ("mode", "time")
    inst, fp = res["pf"].values, res["pf_first_passage"].values
    assert np.all(fp >= inst - 1e-15)
    assert np.all(np.diff(fp, axis=1) >= 0)
    np.testing.assert_array_equal(fp[:, 0], inst[:, 0])
    # system first passage dominates every mode's first passage
    assert np.all(fp[-1] >= fp[:-1].max(axis=0))
    assert np.all(res["beta_first_passage"].values <= res["beta"].values + 1e-12)


def test_first_passage_iid_instants_exact():
    """Independent instants: P_fp(t_k) = 1 - (1 - p)^k."""
    rng = np.random.default_rng(4)
    n, m, p = 40_000, 6, 0.03
    y = rng.standard_normal((n, m))
    ds = _dataset({"y": y}, time=np.arange(m))
    res = reliability(ds, Band("y", upper=stats.norm.isf(p)), interval="clopper-pearson")
    r = res.sel(mode="y")
    exact = 1 - (1 - p) ** np.arange(1, m + 1)
    assert np.all(r["pf_first_passage_lower"].values <= exact)
    assert np.all(exact <= r["pf_first_passage_upper"].values)


def test_time_window_selection():
    n, t = 100, np.arange(5.0)
    y = np.tile(np.array([0.0, 3.0, 0.0, 0.0, 0.0]), (n, 1))
    y[: n // 2, 3] = 3.0
    ds = _dataset({"y": y}, time=t)
    full = reliability(ds, Band("y", upper=1.0), system=False)
    np.testing.assert_array_equal(full["pf_first_passage"].sel(mode="y"), [0, 1, 1, 1, 1])
    win = reliability(ds, Band("y", upper=1.0), system=False, time=(2.0, 4.0))
    np.testing.assert_array_equal(win["time"], [2.0, 3.0, 4.0])
    np.testing.assert_array_equal(win["pf_first_passage"].sel(mode="y"), [0, 0.5, 0.5])
    np.testing.assert_array_equal(win["pf"].sel(mode="y"), [0, 0.5, 0])


def test_static_outputs_have_no_time_dim_and_mix_with_time_outputs():
    rng = np.random.default_rng(0)
    n, t = 1000, np.arange(3.0)
    ds = _dataset({"s": rng.standard_normal(n), "y": rng.standard_normal((n, 3))}, time=t)
    only_static = reliability(ds, Band("s", upper=1.0))
    assert only_static["pf"].dims == ("mode",)
    assert "pf_first_passage" not in only_static
    mixed = reliability(ds, [Band("s", upper=1.0), Band("y", upper=1.0)])
    assert mixed["pf"].dims == ("mode", "time")
    np.testing.assert_array_equal(mixed["pf"].sel(mode="s"), float(only_static["pf"][0]))


# =========================================================================== bands
def test_absolute_band():
    rng = np.random.default_rng(9)
    y = rng.standard_normal(50_000)
    res = reliability(_dataset({"y": y}), Band("y", upper=2.0, absolute=True), system=False)
    m = res.sel(mode="|y|")
    exact = 2 * stats.norm.sf(2.0)
    assert float(m["pf_lower"]) <= exact <= float(m["pf_upper"])
    assert int(m["absolute"]) == 1
    assert Band("y", upper=2.0, absolute=True).pf_from_distribution(stats.norm()) == (
        pytest.approx(exact, rel=1e-12))
    band = Band("y", lower=0.5, upper=2.0, absolute=True)
    assert band.pf_from_distribution(stats.norm()) == pytest.approx(
        exact + stats.norm.cdf(0.5) - stats.norm.cdf(-0.5), rel=1e-12)


def test_limit_value_is_safe():
    res = reliability(_dataset({"y": [0.0, 1.0, 2.0, 3.0]}), Band("y", 1.0, 2.0))
    assert int(res["n_failures"].sel(mode="y")) == 2


def test_extra_dims_expand_into_modes():
    rng = np.random.default_rng(1)
    n, t = 2000, np.arange(4.0)
    v = rng.standard_normal((n, 4, 2))
    ds = xr.Dataset(
        {"x": (("sample", "time", "dof"), v, {"units": "m", "role": "output"}),
         "status": ("sample", np.zeros(n, np.int8))},
        coords={"sample": np.arange(n), "time": t, "dof": ["a", "b"]})
    res = reliability(ds, Band("x", upper=1.0))
    assert list(res["mode"].values) == ["x[dof=a]", "x[dof=b]", "system"]
    np.testing.assert_array_equal(res["n_failures"].sel(mode="x[dof=b]"),
                                  (v[:, :, 1] > 1.0).sum(axis=0))
    sel = reliability(ds, Band("x", upper=1.0, select={"dof": "a"}, name="xa"), system=False)
    np.testing.assert_array_equal(sel["n_failures"].sel(mode="xa"),
                                  (v[:, :, 0] > 1.0).sum(axis=0))


# =========================================================================== invalid samples
def test_invalid_samples_excluded_and_counted():
    rng = np.random.default_rng(12)
    n = 1000
    y = rng.standard_normal(n)
    status = np.zeros(n, np.int8)
    status[:30] = 1
    y[:10] = np.nan  # a failed solve may leave NaN
    y[10:30] = 10.0  # ... or garbage that would count as failures if used
    res = reliability(_dataset({"y": y}, status=status), Band("y", upper=1.0), system=False)
    m = res.sel(mode="y")
    k = int(np.sum(y[30:] > 1.0))
    assert int(res["n_invalid"]) == 30 and int(res["n_valid"]) == 970
    assert int(m["n_failures"]) == k
    assert float(m["pf"]) == pytest.approx(k / 970)
    assert float(m["pf_if_invalid_failed"]) == pytest.approx((k + 30) / 1000)
    assert float(m["pf_if_invalid_safe"]) == pytest.approx(k / 1000)
    assert res.attrs["n_invalid"] == 30 and "excluded" in res.attrs["invalid_samples"]


def test_nan_in_valid_sample_raises():
    y = np.array([0.0, 1.0, np.nan, 0.5])
    with pytest.raises(ValueError, match=r"non-finite value\(s\) in 1 sample\(s\) with status 0"):
        reliability(_dataset({"y": y}), Band("y", upper=1.0))
    # same NaN in an invalid sample is fine
    res = reliability(_dataset({"y": y}, status=[0, 0, 3, 0]), Band("y", upper=0.8))
    assert int(res["n_invalid"]) == 1 and int(res["n_failures"].sel(mode="y")) == 1


def test_all_invalid_raises():
    with pytest.raises(ValueError, match="no valid sample"):
        reliability(_dataset({"y": [1.0, 2.0]}, status=[1, 2]), Band("y", upper=1.0))


def test_missing_status_means_all_valid():
    ds = _dataset({"y": [0.0, 2.0]}).drop_vars("status")
    res = reliability(ds, Band("y", upper=1.0))
    assert int(res["n_invalid"]) == 0 and "no status" in res.attrs["invalid_samples"]


# =========================================================================== bad input
def test_band_validation_errors():
    with pytest.raises(ValueError, match=r"'vib'.*lower=2.*upper=1"):
        Band("vib", 2.0, 1.0)
    with pytest.raises(ValueError, match="lower=1 must be < upper=1"):
        Band("vib", 1.0, 1.0)
    with pytest.raises(ValueError, match="both sides open"):
        Band("vib")
    with pytest.raises(ValueError, match="absolute band needs upper > 0"):
        Band("vib", upper=-1.0, absolute=True)
    with pytest.raises(ValueError, match="lower=3 must be < upper=1"):
        reliability(_dataset({"y": [0.0]}), {"y": (3.0, 1.0)})


def test_reliability_input_errors():
    ds = _dataset({"y": [0.0, 1.0], "z": [1.0, 2.0]})
    with pytest.raises(ValueError, match=r"'nope' not in the Dataset.*available outputs: y, z"):
        reliability(ds, Band("nope", upper=1.0))
    with pytest.raises(ValueError, match="interval 'agresti' unknown"):
        reliability(ds, Band("y", upper=1.0), interval="agresti")
    with pytest.raises(ValueError, match="duplicate or reserved mode label"):
        reliability(ds, [Band("y", upper=1.0), Band("y", upper=2.0)])
    with pytest.raises(ValueError, match="reserved"):
        reliability(ds, Band("y", upper=1.0, name="system"))
    with pytest.raises(ValueError, match="confidence"):
        reliability(ds, Band("y", upper=1.0), confidence=95)
    with pytest.raises(ValueError, match="empty"):
        reliability(ds, [])


# =========================================================================== netCDF
def test_netcdf_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    ds = _dataset({"y": rng.standard_normal((200, 3))}, time=[0.0, 1.0, 2.0])
    res = reliability(ds, [Band("y", upper=1.0), Band("y", lower=-5.0, name="low")])
    path = tmp_path / "rel.nc"
    res.to_netcdf(path)
    back = xr.load_dataset(path)
    assert back["beta_is_lower_bound"].dtype == np.int8
    assert back.attrs["interval"] == "wilson" and back.attrs["confidence"] == 0.95
    assert back["pf"].attrs["units"] == "1"
    xr.testing.assert_allclose(back["pf_first_passage"], res["pf_first_passage"])
    assert list(back["mode"].values) == ["y", "low", "system"]
    assert np.all(np.isfinite(back["beta"].values))


# =========================================================================== naming
def test_reliability_is_the_function_and_probability_the_module():
    import importlib
    import importlib.util

    import gearuq

    ds = _dataset({"y": [0.0, 2.0]})
    res = gearuq.reliability(ds, Band("y", upper=1.0))
    assert float(res["pf"].sel(mode="y")) == 0.5
    assert gearuq.Band is Band
    module = importlib.import_module("gearuq.failure.samples")
    assert module.reliability is reliability
    # one name each: the function is never shadowed by a module of the same name
    assert not importlib.util.find_spec("gearuq.reliability")
    assert callable(gearuq.reliability) and not isinstance(gearuq.reliability, type(module))


# =========================================================================== limit states
def test_limit_state_boundary_fails_where_band_limit_is_safe():
    """g = max(x, 0) with x ~ N(0, 1): P(g <= 0) = 0.5; a band [0, inf) on g says 0."""
    from gearuq.failure.modes import LimitState

    rng = np.random.default_rng(21)
    x = rng.standard_normal(20_000)
    ds = _dataset({"g": np.maximum(x, 0.0)})
    res = reliability(ds, [LimitState.output("g"), Band("g", lower=0.0, name="band")],
                      system=False)
    k_ls = int(res["n_failures"].sel(mode="g"))
    assert k_ls == int(np.sum(x <= 0))
    assert float(res["pf_lower"].sel(mode="g")) <= 0.5 <= float(res["pf_upper"].sel(mode="g"))
    assert int(res["n_failures"].sel(mode="band")) == 0
    assert "boundary fails" in str(res["definition"].sel(mode="g").values)


def test_limit_state_and_system_modes_match_counts():
    from gearuq.failure.modes import LimitState, ParallelSystem, SeriesSystem

    rng = np.random.default_rng(22)
    n = 5000
    a, b = rng.standard_normal(n), rng.standard_normal(n)
    ds = _dataset({"a": a, "b": b})
    la, lb = LimitState.upper("a", 1.0), LimitState.lower("b", -0.5)
    res = reliability(ds, [SeriesSystem([la, lb], name="s"), ParallelSystem([la, lb], name="p")],
                      system=False)
    assert int(res["n_failures"].sel(mode="s")) == int(np.sum((a >= 1.0) | (b <= -0.5)))
    assert int(res["n_failures"].sel(mode="p")) == int(np.sum((a >= 1.0) & (b <= -0.5)))


# =========================================================================== streaming
def test_streamed_result_equals_in_memory_bit_for_bit(tmp_path):
    """monte_carlo(..., store=...) returns a dask-backed result; reliability reads it one
    chunk at a time and gives exactly the in-memory numbers."""

    import gearuq
    from gearuq.failure.modes import LimitState

    def response(a, b, t):
        return {"y": a[:, None] * np.sin(t[None, :] + b[:, None]),
                "s": a + b}

    model = FunctionModel(response, ["a", "b"], [gearuq.Output("y", "m"),
                                                 gearuq.Output("s", "m", ("sample",))],
                          name="stream_check")
    space = gearuq.ParameterSpace.normal(a=(1.0, 0.5), b=(0.0, 1.0))
    t = np.linspace(0.0, 6.0, 13)
    kw = {"n_samples": 3000, "rng": 5, "executor": "serial", "chunk_size": 700}
    mem = gearuq.monte_carlo(model, space, t, **kw)
    lazy = gearuq.monte_carlo(model, space, t, store=tmp_path / "run", **kw)
    assert lazy["y"].chunks is not None and len(lazy["y"].chunks[0]) == 5
    bands = [Band("y", -1.2, 1.2), Band("s", upper=2.0), LimitState.upper("y", 1.5, name="ls")]
    a = reliability(mem, bands)
    b = reliability(lazy, bands)
    xr.testing.assert_identical(a, b)
    for var in a.data_vars:  # bit for bit, not just close
        np.testing.assert_array_equal(a[var].values, b[var].values)


def test_blocks_follow_the_stored_chunks(tmp_path):
    from gearuq.failure.samples import sample_blocks as _sample_blocks

    ds = _dataset({"y": np.zeros((10, 2))}, time=[0.0, 1.0]).chunk({"sample": 4})
    assert _sample_blocks(ds, ["y"], 10, 2) == [(0, 4), (4, 8), (8, 10)]
    assert _sample_blocks(ds.load(), ["y"], 10, 2) == [(0, 10)]


# =========================================================================== design labels
@pytest.mark.parametrize(("rule", "word"), [("random", "valid"), ("lhs", "conservative"),
                                            ("sobol", "not guaranteed")])
def test_interval_labelled_by_design_rule(rule, word):
    ds = _dataset({"y": np.linspace(-3, 3, 64)})
    ds.attrs["rule"] = rule
    res = reliability(ds, Band("y", upper=2.0))
    assert res.attrs["interval_validity"].startswith(word)
    assert res.attrs["design_rule"] == rule


# =========================================================================== grid check
@pytest.mark.e2e
def test_first_passage_grid_check_flags_a_coarse_grid():
    """Random-phase harmonic over 10 time units: 9 instants miss crossings (the first-passage
    estimate is ~23 % low, its interval excludes the exact value); 201 instants resolve it."""
    from gearuq.testing.reliability_problems import random_phase, random_phase_first_passage

    rng = np.random.default_rng(31)
    x1, x2 = rng.standard_normal(40_000), rng.standard_normal(40_000)
    exact = random_phase_first_passage(2.0, 10.0)
    flags = {}
    for n_t in (9, 201):
        t = np.linspace(0.0, 10.0, n_t)
        ds = _dataset({"y": random_phase(x1, x2, t)["y"]}, time=t)
        m = reliability(ds, Band("y", upper=2.0), system=False).sel(mode="y")
        fp_upper = float(m["pf_first_passage_upper"].isel(time=-1))
        flags[n_t] = (int(m["first_passage_grid_warning"]), fp_upper, float(
            m["pf_first_passage_grid_gap"]))
    assert flags[9][1] < exact  # the coarse grid's interval excludes the truth ...
    assert flags[9][1] + flags[9][2] < exact  # ... and the half-grid gap misses it (aliasing)
    assert flags[201][0] == 0
    lo = float(m["pf_first_passage_lower"].isel(time=-1))
    assert lo <= exact <= flags[201][1]


# =========================================================================== entry point
def _offset():
    from gearuq.testing.reliability_problems import offset_model, offset_space

    return offset_model(), offset_space()


def test_crude_mc_reports_a_bound_never_zero():
    """g = 4.5 - x1 (Pf = 3.4e-6) with 10^4 runs: no failure, pf is the Clopper-Pearson upper
    bound 1 - 0.025^(1/n) (flagged), not 0."""
    from gearuq.failure.api import failure_probability
    from gearuq.testing.reliability_problems import OFFSET_PF

    model, space = _offset()
    rep = failure_probability(model, space, "g", method="mc", rng=1, executor="serial")
    assert int(rep["pf_is_upper_bound"]) == 1 and int(rep["status"]) == 4
    assert float(rep["pf"]) == float(rep["pf_upper"]) > 0
    assert float(rep["pf_upper"]) == pytest.approx(1.0 - 0.025 ** (1 / 1e4), rel=1e-9)
    assert float(rep["pf_upper"]) / OFFSET_PF > 100  # honest but 108x the truth
    assert int(rep["n_model_runs"]) == 10_000


@pytest.mark.parametrize("rule", ["lhs", "sobol"])
def test_replicated_designs_give_a_real_interval(rule):
    from gearuq.failure.api import failure_probability
    from gearuq.testing.problems import FOUR_BRANCH_PF, four_branch_model, standard_normal_space

    rep = failure_probability(four_branch_model(), standard_normal_space(2), "g", method="mc",
                              rule=rule, n_samples=8192, replicates=8, rng=3,
                              executor="serial")
    assert "Student-t over 8" in rep.attrs["interval_kind"]
    assert float(rep["pf_lower"]) <= FOUR_BRANCH_PF <= float(rep["pf_upper"])
    assert int(rep["n_model_runs"]) == 8 * 8192


@pytest.mark.e2e
def test_one_report_form_for_every_method():
    from gearuq.failure.api import failure_probability

    model, space = _offset()
    common = {"pf", "pf_lower", "pf_upper", "cov_pf", "beta", "beta_lower", "beta_upper",
              "n_model_runs", "n_invalid", "wall_time", "status", "pf_is_upper_bound"}
    settings = {"mc": {"n_samples": 2000}, "form": {}, "sorm": {},
                "importance": {"n_samples": 500, "max_samples": 500},
                "subset": {"n_per_level": 300}, "akmcs": {"n_mc": 2000, "max_mc": 2000}}
    for method, kw in settings.items():
        rep = failure_probability(model, space, "g", method=method, rng=2, executor="serial",
                                  **kw)
        assert common <= set(rep.data_vars), method
        assert rep.attrs["method"] == method
        assert rep.attrs["engine"] == "failure_probability"
        assert "interval_kind" in rep.attrs and "settings" in rep.attrs
        assert int(rep["n_model_runs"]) > 0


def test_entry_point_bad_input():
    from gearuq.failure.api import failure_probability
    from gearuq.failure.modes import LimitState

    model, space = _offset()
    with pytest.raises(ValueError, match=r"unknown output\(s\) 'nope'.*valid outputs: g"):
        failure_probability(model, space, LimitState.upper("nope", 1.0), method="form")
    with pytest.raises(ValueError, match="method: unknown 'magic'; valid: mc, form"):
        failure_probability(model, space, "g", method="magic")
    with pytest.raises(ValueError, match=r"unknown setting\(s\) 'n_sample'.*valid: n_samples"):
        failure_probability(model, space, "g", method="mc", n_sample=10)
    with pytest.raises(ValueError, match="ambiguous"):
        failure_probability(model, space, ["g", "g"], method="form")
    with pytest.raises(ValueError, match="confidence"):
        failure_probability(model, space, "g", confidence=1.5)


# =========================================================================== benchmark
def test_bench_rows_table_and_docs_section(tmp_path):
    from gearuq.bench import reliability as bench
    from gearuq.testing.reliability_problems import OFFSET_PF, reliability_problems

    rows = bench.cases(quick=True)
    labels = {(p, label) for p, label, _, _ in rows}
    assert ("parabola", "FORM") in labels and ("jump", "AK-MCS") in labels
    assert all(m != "akmcs" for p, _, m, _ in rows if p == "linear_100d")
    p = reliability_problems()["offset"]
    form = bench._summarise("offset", "FORM", "form", OFFSET_PF,
                            [bench._one(p, "form", {"n_starts": 1}, 1)])
    mc = bench._summarise("offset", "crude MC", "mc", OFFSET_PF,
                          [bench._one(p, "mc", {"n_samples": 2000}, 1)])
    assert form["error"] < 1e-6 and form["runs"] == 6
    assert form["saving"] == pytest.approx(100 * (1 - OFFSET_PF) / OFFSET_PF / 6)
    assert mc["bound"] == 1 and mc["runs_10pct"] == pytest.approx(mc["mc_runs_10pct"])
    text = bench.markdown([form, mc], quick=True, n_seeds=1)
    assert "| offset | 3.398e-06 | FORM |" in text and "(bound)" in text
    doc = tmp_path / "benchmarks.md"
    doc.write_text("# Benchmarks\n\n## other\n\nkeep me\n")
    bench.update_docs(doc, text)
    bench.update_docs(doc, text.replace("FORM", "FORM again"))
    out = doc.read_text()
    assert out.count("## `gearuq bench reliability`") == 1 and "keep me" in out
    assert "FORM again" in out and out.count("| offset | 3.398e-06 | FORM") == 1


@pytest.mark.bench
def test_bench_reliability_quick(tmp_path):
    from gearuq.bench import reliability as bench

    res = bench.run(tmp_path, quick=True)
    by = {(r["problem"], r["row"]): r for r in res["rows"]}
    assert by[("offset", "IS")]["saving"] > 100
    assert by[("offset", "subset")]["saving"] > 100
    assert by[("linear_100d", "FORM")]["error"] < 1e-6


@pytest.mark.e2e
def test_coverage_benchmark_rows_and_docs_section(tmp_path):
    """The coverage table on a tiny case: counts, coverage of status-0 runs, the docs block."""
    from gearuq.bench import reliability as bench

    doc = tmp_path / "benchmarks.md"
    doc.write_text("# Benchmarks\n")
    out = bench.coverage(tmp_path, seeds=3, docs=doc,
                         cases_=[("offset", "mc", {"n_samples": 2000}),
                                 ("resistance_load", "subset", {"n_per_level": 500})])
    by = {r["problem"]: r for r in out["rows"]}
    assert by["offset"]["n_status0"] == 0  # no failure in 2000 runs: a bound, status 4
    assert by["offset"]["statuses"] == [4] and by["offset"]["held_or_flagged"] == 1.0
    assert by["resistance_load"]["seeds"] == 3 and by["resistance_load"]["runs"] > 1000
    text = doc.read_text()
    assert "reliability-coverage:start" in text and "| resistance_load |" in text


def test_coverage_for_some_problems_replaces_only_their_rows(tmp_path):
    """``problems=[...]`` reruns some rows: the docs table keeps the others in their order,
    replaces the rerun ones, and an unknown problem is refused with the valid names."""
    from gearuq.bench import reliability as bench

    doc = tmp_path / "benchmarks.md"
    doc.write_text("# Benchmarks\n")
    cases = [("offset", "mc", {"n_samples": 2000}),
             ("resistance_load", "mc", {"n_samples": 2000})]
    bench.coverage(tmp_path, seeds=2, docs=doc, cases_=cases)
    first = doc.read_text()
    bench.coverage(tmp_path, seeds=2, docs=doc, cases_=cases + [
        ("resistance_load", "subset", {"n_per_level": 500})], problems=["resistance_load"])
    text = doc.read_text()
    block = text[text.index("reliability-coverage:start"):text.index("reliability-coverage:end")]
    rows = [line for line in block.splitlines() if line.startswith("| ") and "problem" not in
            line]
    assert [r.split("|")[1].strip() + "/" + r.split("|")[3].strip() for r in rows] == [
        "offset/mc", "resistance_load/mc", "resistance_load/subset"]
    offset_row = [r for r in rows if r.startswith("| offset")][0]
    assert offset_row in first  # kept as it was
    with pytest.raises(ValueError, match="unknown.*valid: offset, resistance_load"):
        bench.coverage(tmp_path, seeds=1, cases_=cases, problems=["bogus"])


def test_runs_to_ten_percent_is_runs_times_squared_cov_ratio():
    """The runs-to-10 % column: mean runs x (empirical CoV / 0.1)^2, gain against
    100 (1 - Pf) / Pf crude-MC runs."""
    from gearuq.bench import reliability as bench

    runs = [{"pf": pf, "cov": 0.1, "covered": True, "runs": 1000, "wall": 1.0, "status": 0,
             "bound": 0, "lf_runs": 50} for pf in (0.8e-3, 1.0e-3, 1.2e-3)]
    row = bench.coverage_row("p", "m", 1e-3, runs)
    assert row["cov_empirical"] == pytest.approx(0.2)
    assert row["runs_10pct"] == pytest.approx(4000.0)
    assert row["gain_vs_mc"] == pytest.approx(99_900.0 / 4000.0)
    assert row["lf_runs"] == 50 and row["coverage_all"] == 1.0
    assert "| p | 0.001 | m |" in bench.runs_markdown([row], 3)


def test_rejudge_compares_stored_intervals_with_the_current_reference(tmp_path):
    """Stored runs are judged again against the problem's reference as it is now: an
    interval is held exactly when it contains the reference, whatever the stored flag."""
    import json

    from gearuq.bench import reliability as bench
    from gearuq.testing.reliability_problems import OFFSET_PF

    runs = [{"problem": "offset", "method": "m", "seed": k, "pf": OFFSET_PF * f,
             "lower": OFFSET_PF * f * 0.9, "upper": OFFSET_PF * f * 1.1, "cov": 0.05,
             "covered": False, "runs": 100, "wall": 0.1, "status": 0, "bound": 0}
            for k, f in enumerate((0.95, 1.05, 1.3, 0.7))]
    (tmp_path / "reliability_coverage_runs.json").write_text(json.dumps(runs))
    doc = tmp_path / "benchmarks.md"
    doc.write_text("# Benchmarks\n")
    res = bench.rejudge(tmp_path, docs=doc)
    row = res["rows"][0]
    assert row["coverage_status0"] == 0.5 and row["seeds"] == 4
    assert row["pf_mean"] == pytest.approx(OFFSET_PF)
    assert "| offset |" in doc.read_text()
