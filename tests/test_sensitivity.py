"""Sobol' indices (SALib Saltelli, Jansen, PCE route) and Morris screening against oracles."""

from __future__ import annotations

import math

import numpy as np
import pytest

import gearuq
from gearuq.engines.sensitivity import morris_screening, sobol_indices

PI = math.pi
ISHIGAMI_S1 = np.array([0.313905, 0.442411, 0.0])
ISHIGAMI_ST = np.array([0.557589, 0.442411, 0.243684])
G_A = np.array([0.0, 1.0, 4.5, 9.0, 99.0, 99.0, 99.0, 99.0])
G_NAMES = [f"x{i + 1}" for i in range(8)]


def _g_exact():
    v = 1.0 / (3.0 * (1.0 + G_A) ** 2)
    total = np.prod(1.0 + v) - 1.0
    s1 = v / total
    st = v * np.prod(1.0 + v) / (1.0 + v) / total
    return s1, st


def ishigami():
    model = gearuq.FunctionModel(
        lambda x1, x2, x3: np.sin(x1) + 7 * np.sin(x2) ** 2 + 0.1 * x3**4 * np.sin(x1),
        ["x1", "x2", "x3"], ["y"], name="ishigami")
    space = gearuq.ParameterSpace.uniform(x1=(-PI, PI), x2=(-PI, PI), x3=(-PI, PI))
    return model, space


def gfunction():
    def g(**x):
        return np.prod([(np.abs(4 * x[n] - 2) + a) / (1 + a)
                        for n, a in zip(G_NAMES, G_A, strict=True)], axis=0)

    model = gearuq.FunctionModel(g, G_NAMES, ["y"], name="g_function")
    space = gearuq.ParameterSpace.uniform(**{n: (0.0, 1.0) for n in G_NAMES})
    return model, space


def test_g_function_reference_values():
    s1, _ = _g_exact()
    np.testing.assert_allclose(s1[:4], [0.71619, 0.17905, 0.02368, 0.00716], atol=6e-6)


@pytest.mark.parametrize("estimator", ["saltelli", "jansen"])
def test_ishigami_mc_within_intervals(estimator):
    model, space = ishigami()
    ds = sobol_indices(model, space, n_base=2**13, estimator=estimator, rng=7)
    assert ds["S1"].dims == ("output", "parameter")
    s1, st = ds["S1"].sel(output="y").values, ds["ST"].sel(output="y").values
    np.testing.assert_allclose(s1, ISHIGAMI_S1, atol=0.02)
    np.testing.assert_allclose(st, ISHIGAMI_ST, atol=0.02)
    assert np.all(np.abs(s1 - ISHIGAMI_S1) <= ds["S1_conf"].sel(output="y").values)
    assert np.all(np.abs(st - ISHIGAMI_ST) <= ds["ST_conf"].sel(output="y").values)
    assert ds.attrs["n_model_evaluations"] == 2**13 * (3 + 2)
    # x3 has no first-order effect: its estimate is flagged (negative or interval at 0)
    assert int(ds["S1_flag"].sel(output="y", parameter="x3")) == 1
    assert int(ds["ST_flag"].sel(output="y", parameter="x1")) == 0


def test_ishigami_second_order():
    model, space = ishigami()
    ds = sobol_indices(model, space, n_base=2**12, second_order=True, rng=3)
    s2 = ds["S2"].sel(output="y")
    assert float(s2.sel(parameter="x1", parameter_2="x3")) == pytest.approx(0.243684, abs=0.03)
    assert float(s2.sel(parameter="x1", parameter_2="x2")) == pytest.approx(0.0, abs=0.03)
    assert ds.attrs["n_model_evaluations"] == 2**12 * (2 * 3 + 2)


def test_ishigami_pce_route():
    model, space = ishigami()
    ds = sobol_indices(model, space, n_base=1024, method="pce", pce_order=12, rng=1)
    np.testing.assert_allclose(ds["S1"].sel(output="y"), ISHIGAMI_S1, atol=0.005)
    np.testing.assert_allclose(ds["ST"].sel(output="y"), ISHIGAMI_ST, atol=0.005)
    assert ds.attrs["n_model_evaluations"] == 1024
    assert float(ds["loo_error"].sel(output="y")) < 1e-4


def test_g_function_mc_and_pce():
    model, space = gfunction()
    s1_ex, st_ex = _g_exact()
    ds = sobol_indices(model, space, n_base=2**12, estimator="jansen", rng=2)
    s1, st = ds["S1"].sel(output="y").values, ds["ST"].sel(output="y").values
    assert np.all(np.abs(s1 - s1_ex) <= ds["S1_conf"].sel(output="y").values)
    assert np.all(np.abs(st - st_ex) <= ds["ST_conf"].sel(output="y").values)
    np.testing.assert_allclose(s1, s1_ex, atol=0.02)
    # PCE of the kinked G function: sparse, hyperbolic, 1024 runs (measured 6e-4 / 4e-3)
    pce = sobol_indices(model, space, n_base=1024, method="pce", pce_order=10,
                        pce_options={"method": "sparse", "truncation": 0.5}, rng=1)
    np.testing.assert_allclose(pce["S1"].sel(output="y"), s1_ex, atol=0.005)
    np.testing.assert_allclose(pce["ST"].sel(output="y"), st_ex, atol=0.01)


def test_time_dependent_indices_follow_closed_form():
    # y(t) = a t + b: S_a(t) = var_a t^2 / (var_a t^2 + var_b)
    model = gearuq.FunctionModel(lambda a, b, t: a[:, None] * t[None] + b[:, None],
                                 ["a", "b"], ["y"], time_dependent=True)
    space = gearuq.ParameterSpace.normal(a=(0.0, 1.0), b=(0.0, 2.0))
    t = np.linspace(0.0, 4.0, 9)
    exact = t**2 / (t**2 + 4.0)
    for method in ("mc", "pce"):
        ds = sobol_indices(model, space, t, n_base=2**11, method=method, pce_order=1, rng=1)
        assert ds["S1"].dims == ("output", "parameter", "time")
        np.testing.assert_allclose(ds["S1"].sel(output="y", parameter="a"), exact,
                                   atol=0.05 if method == "mc" else 1e-10)
        np.testing.assert_allclose(ds["ST"].sel(output="y", parameter="b"), 1 - exact,
                                   atol=0.05 if method == "mc" else 1e-10)


def test_morris_ranks_g_function():
    model, space = gfunction()
    ds = morris_screening(model, space, n_trajectories=40, rng=1)
    rank = ds["rank"].sel(output="y").values
    np.testing.assert_array_equal(rank[:4], [1, 2, 3, 4])
    assert ds.attrs["n_model_evaluations"] == 40 * (8 + 1)
    assert set(ds.data_vars) >= {"mu", "mu_star", "sigma", "mu_star_conf"}


def test_errors():
    model, space = ishigami()
    corr = gearuq.ParameterSpace.normal(correlation=[[1, 0.3], [0.3, 1]],
                                        x1=(0.0, 1.0), x2=(0.0, 1.0))
    with pytest.raises(ValueError, match="independent inputs"):
        sobol_indices(model, corr, n_base=64)
    with pytest.raises(ValueError, match="independent inputs"):
        morris_screening(model, corr, n_trajectories=10)
    with pytest.raises(ValueError, match="estimator.*'sobol2'"):
        sobol_indices(model, space, n_base=64, estimator="sobol2")
    with pytest.raises(ValueError, match="method.*'fast'"):
        sobol_indices(model, space, n_base=64, method="fast")
    with pytest.raises(ValueError, match="n_base"):
        sobol_indices(model, space, n_base=1)
    bad = gearuq.ParameterSpace.normal(q=(0.0, 1.0))
    with pytest.raises(ValueError, match="'q' not in model"):
        sobol_indices(model, bad, n_base=64)
    # the PCE route accepts a correlated space (indices of the independent germ)
    lin = gearuq.FunctionModel(lambda x1, x2: x1 + x2, ["x1", "x2"], ["y"])
    ds = sobol_indices(lin, corr, n_base=32, method="pce", pce_order=1)
    assert "germ" in ds.attrs["dependence_note"] and ds.attrs["method"] == "pce"
    assert float(ds["S1"].sum()) == pytest.approx(1.0, abs=1e-9)
