"""Engines against the analytic oracle plugin (linear_oscillator): exact failure probabilities."""

import chaospy as cp
import numpy as np
import pytest
from scipy.stats import lognorm, norm

import gearuq
from gearuq.reliability import Band, wilson_interval
from gearuq_plugins.linear_oscillator import closed_form

M, K, C, OMEGA = 1.0, 1.0e4, 20.0, 80.0  # linear_oscillator nominal values


@pytest.fixture(scope="module")
def model():
    return gearuq.get_model("linear_oscillator")


def _unit_response(t):
    """x(t) for F = 1 (x is linear in F with x0 = v0 = 0)."""
    x, _ = closed_form([M], [K], [C], [1.0], [OMEGA], [0.0], [0.0], t)
    return x[0]


@pytest.mark.parametrize("rule", ["random", "lhs"])
def test_pf_of_displacement_at_several_instants_and_bands(model, rule):
    """F ~ N(10, 2): x(t) = F h(t) is normal; P(x outside band) is exact."""
    t = np.array([0.02, 0.05, 0.11, 0.3])
    space = gearuq.ParameterSpace({"force": cp.Normal(10.0, 2.0)})
    n = 20_000
    ds = gearuq.monte_carlo(model, space, t, n_samples=n, rule=rule, rng=11,
                            outputs=["displacement"], executor="serial")
    h = _unit_response(t)
    mean, sd = 10.0 * h, 2.0 * np.abs(h)
    checked = 0
    for j in range(t.size):
        one = ds.isel(time=slice(j, j + 1))
        # bands in units of each instant's own spread: two-sided, upper only, lower only
        for zl, zu in ((-1.5, 2.0), (None, 1.0), (-2.3, None)):
            lo = None if zl is None else mean[j] + zl * sd[j]
            hi = None if zu is None else mean[j] + zu * sd[j]
            exact = (0.0 if hi is None else norm.sf(zu)) + (0.0 if lo is None else norm.cdf(zl))
            r = gearuq.reliability(one, [Band("displacement", lo, hi, name="b")],
                                   confidence=0.99).sel(mode="b").isel(time=0)
            assert float(r["pf_lower"]) <= exact <= float(r["pf_upper"]), (rule, t[j], zl, zu)
            checked += 1
    assert checked == 12


def test_pf_of_steady_amplitude_with_lognormal_stiffness(model):
    """k lognormal: amp > a iff |k - m W^2| < sqrt((F/a)^2 - (c W)^2): exact interval prob."""
    s, scale = 0.25, 6400.0  # median k at resonance m W^2 = 6400
    space = gearuq.ParameterSpace({"k": cp.LogNormal(np.log(scale), s)})
    a = 0.003
    r = np.sqrt((10.0 / a) ** 2 - (C * OMEGA) ** 2)
    k_res = M * OMEGA**2
    exact = lognorm.cdf(k_res + r, s, scale=scale) - lognorm.cdf(k_res - r, s, scale=scale)
    n = 40_000
    ds = gearuq.monte_carlo(model, space, n_samples=n, rule="random", rng=3,
                            outputs=["steady_amplitude"], executor="serial")
    rel = gearuq.reliability(ds, {"steady_amplitude": (None, a)}, confidence=0.99)
    row = rel.sel(mode="steady_amplitude")
    assert float(row["pf_lower"]) <= exact <= float(row["pf_upper"])
    lo, hi = wilson_interval(int(row["n_failures"]), n, 0.99)
    assert float(lo) <= exact <= float(hi)


def test_lhs_variance_smaller_than_crude_mc_on_monotone_output(model):
    """Steady amplitude is monotone in |F|: LHS estimator variance over repeated seeds."""
    space = gearuq.ParameterSpace({"force": cp.Uniform(5.0, 15.0), "c": cp.Uniform(15.0, 25.0)})
    est = {"random": [], "lhs": []}
    for seed in range(40):
        for rule in est:
            ds = gearuq.monte_carlo(model, space, n_samples=64, rule=rule, rng=seed,
                                    outputs=["steady_amplitude"], executor="serial",
                                    progress=False)
            est[rule].append(float(ds["steady_amplitude"].mean()))
    ratio = np.var(est["lhs"]) / np.var(est["random"])
    assert ratio < 0.25, ratio
