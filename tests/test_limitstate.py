"""Limit states and systems: definitions, inclusive failure, systems against closed forms,
ambiguous input."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from scipy import stats

from gearuq.failure.modes import (
    Band,
    LimitState,
    ParallelSystem,
    SeriesSystem,
    as_limit_state,
    cut_set_system,
)
from gearuq.failure.samples import reliability


def _ds(n: int = 40_000, seed: int = 0, time: np.ndarray | None = None) -> xr.Dataset:
    rng = np.random.default_rng(seed)
    data = {k: ("sample", rng.standard_normal(n), {"units": "m", "role": "output"})
            for k in ("a", "b", "c")}
    ds = xr.Dataset(data, coords={"sample": np.arange(n)})
    if time is not None:
        ds = ds.assign_coords(time=("time", time))
        ds["y"] = (("sample", "time"), ds["a"].values[:, None] * np.cos(time)[None, :]
                   + ds["b"].values[:, None] * np.sin(time)[None, :])
    ds["status"] = ("sample", np.zeros(n, np.int8))
    return ds


def test_constructors_and_values():
    ds = _ds(10)
    a = ds["a"].values
    np.testing.assert_array_equal(LimitState.output("a").sample_values(ds), a)
    np.testing.assert_array_equal(LimitState.upper("a", 1.0).sample_values(ds), 1.0 - a)
    np.testing.assert_array_equal(LimitState.upper("a", 1.0, absolute=True).sample_values(ds),
                                  1.0 - np.abs(a))
    np.testing.assert_array_equal(LimitState.lower("a", -1.0).sample_values(ds), a + 1.0)
    fn = LimitState(lambda a, b: a - b, ["a", "b"], name="diff")
    np.testing.assert_array_equal(fn.sample_values(ds), a - ds["b"].values)
    assert fn.name == "diff" and fn.variables == ("a", "b")
    band = LimitState.from_band(Band("a", -0.5, 0.5))
    np.testing.assert_array_equal(band.sample_values(ds), np.minimum(a + 0.5, 0.5 - a))
    assert '"kind": "upper"' in LimitState.upper("a", 1.0).to_json()


def test_failure_is_inclusive():
    ds = xr.Dataset({"g": ("sample", np.array([-1.0, 0.0, 1.0]))})
    assert LimitState.output("g").fails(ds).values.tolist() == [True, True, False]
    assert Band("g", lower=0.0).fails(ds["g"].values).tolist() == [True, False, False]


def test_first_passage_value_is_min_over_window():
    t = np.linspace(0, 2 * np.pi, 64)
    ds = _ds(200, time=t)
    ls = LimitState.upper("y", 1.0)
    y = ds["y"].values
    np.testing.assert_array_equal(ls.sample_values(ds), 1.0 - y.max(axis=1))
    win = LimitState.upper("y", 1.0, window=(1.0, 2.0))
    keep = (t >= 1.0) & (t <= 2.0)
    np.testing.assert_array_equal(win.sample_values(ds), 1.0 - y[:, keep].max(axis=1))
    with pytest.raises(ValueError, match="window"):
        LimitState.upper("y", 1.0, window=(7.0, 8.0)).sample_values(ds)


def test_series_parallel_cut_sets_against_closed_forms():
    """Independent standard normals a, b, c with upper limits: products of tail probabilities."""
    ds = _ds()
    la, lb, lc = (LimitState.upper(k, 1.0) for k in "abc")
    p = stats.norm.sf(1.0)
    exact = {
        "series": 1 - (1 - p) ** 2,
        "parallel": p * p,
        "cuts": 1 - (1 - p * p) * (1 - p),  # {a and b} or {c}
    }
    systems = {"series": SeriesSystem([la, lb], name="series"),
               "parallel": ParallelSystem([la, lb], name="parallel"),
               "cuts": cut_set_system([[la, lb], [lc]], name="cuts")}
    res = reliability(ds, list(systems.values()), system=False)
    for name, value in exact.items():
        m = res.sel(mode=name)
        assert float(m["pf_lower"]) <= value <= float(m["pf_upper"]), name
    a, b, c = (ds[k].values >= 1.0 for k in "abc")
    assert int(res["n_failures"].sel(mode="cuts")) == int(np.sum((a & b) | c))


def test_cut_sets_may_share_a_member():
    ds = _ds(2000, seed=3)
    la, lb, lc = (LimitState.upper(k, 0.5) for k in "abc")
    sys_ = cut_set_system([[la, lb], [la, lc]])
    a, b, c = (ds[k].values >= 0.5 for k in "abc")
    g = sys_.sample_values(ds)
    np.testing.assert_array_equal(g <= 0, (a & b) | (a & c))


def test_combine_returns_governing_component():
    series = SeriesSystem([LimitState.output("a"), ParallelSystem(
        [LimitState.output("b"), LimitState.output("c")])])
    leaf = np.array([[1.0, 2.0, 3.0], [5.0, -1.0, 0.5], [0.2, -3.0, -4.0]])
    g, gov = series.combine(leaf)
    np.testing.assert_array_equal(g, [1.0, 0.5, -3.0])
    np.testing.assert_array_equal(gov, [0, 2, 1])
    assert [leaf.name for leaf in series.leaves()] == ["a", "b", "c"]


def test_ambiguous_and_bad_input():
    with pytest.raises(ValueError, match="series or parallel"):
        as_limit_state([LimitState.output("a"), LimitState.output("b")])
    with pytest.raises(ValueError, match="upper or a lower limit"):
        as_limit_state({"a": 1.0})
    with pytest.raises(ValueError, match="expected a LimitState"):
        as_limit_state(3.0)
    with pytest.raises(ValueError, match="at least two components"):
        SeriesSystem([LimitState.output("a")])
    with pytest.raises(ValueError, match="names must be distinct"):
        SeriesSystem([LimitState.upper("a", 1.0), LimitState.upper("a", 1.0)])
    with pytest.raises(ValueError, match="limit: must be finite"):
        LimitState.upper("a", np.inf)
    ds = _ds(5)
    with pytest.raises(ValueError, match=r"'nope'.*available outputs: a, b, c"):
        LimitState.upper("nope", 1.0).sample_values(ds)
    extra = xr.Dataset({"v": (("sample", "dof"), np.zeros((3, 2)))},
                       coords={"dof": ["x", "y"]})
    with pytest.raises(ValueError, match="extra dim.*select"):
        LimitState.upper("v", 1.0).sample_values(extra)
    sel = LimitState.upper("v", 1.0, select={"dof": "y"})
    np.testing.assert_array_equal(sel.sample_values(extra), [1.0, 1.0, 1.0])
    assert isinstance(as_limit_state("a"), LimitState)
    assert isinstance(as_limit_state(Band("a", upper=1.0)), LimitState)


# =========================================================================== between instants
def test_first_passage_parabola_is_exact_for_a_parabola_and_never_above_the_grid():
    from gearuq.failure.modes import first_passage_min

    t = np.array([0.0, 0.3, 1.0, 1.2, 2.0, 3.5])  # uneven spacing
    centre = np.array([0.55, 1.1, 2.6])
    g = (t[None, :] - centre[:, None]) ** 2 * np.array([[1.0], [3.0], [0.5]]) - 1.0
    np.testing.assert_allclose(first_passage_min(g, t, "parabola"), -1.0, atol=1e-12)
    assert np.all(first_passage_min(g, t, "grid") > -1.0 + 1e-3)
    rng = np.random.default_rng(3)
    noisy = rng.standard_normal((500, 40))
    tt = np.sort(rng.uniform(0, 10, 40))
    assert np.all(first_passage_min(noisy, tt, "parabola") <= noisy.min(axis=1))
    # a minimum on the first or last instant stays as sampled (nothing known beyond it)
    edge = np.array([[0.0, 1.0, 3.0, 2.0, 5.0], [4.0, 3.0, 2.0, 1.5, -1.0]])
    np.testing.assert_array_equal(first_passage_min(edge, np.arange(5.0), "parabola"),
                                  [0.0, -1.0])
    with_nan = np.array([[1.0, np.nan, 0.0, 2.0]])
    assert np.isnan(first_passage_min(with_nan, np.arange(4.0), "parabola")[0])
    with pytest.raises(ValueError, match="first_passage"):
        first_passage_min(g, t, "cubic")
    with pytest.raises(ValueError, match="increase"):
        first_passage_min(g, t[::-1], "parabola")
    with pytest.raises(ValueError, match="first_passage"):
        LimitState.upper("y", 1.0, first_passage="spline")


def test_first_passage_parabola_recovers_a_harmonic_peak_between_instants():
    """y = a cos t + b sin t over two periods on 13 instants per period: the grid misses up to
    A (1 - cos(h / 2)) = 2.9 % of the amplitude A, the parabola's vertex at most 0.13 %
    (its error falls as h^4 on a peak where g''' = 0)."""
    t = np.linspace(0.0, 4 * np.pi, 27)
    ds = _ds(2000, seed=4, time=t)
    amp = np.hypot(ds["a"].values, ds["b"].values)  # exact peak: the window holds a period
    grid = LimitState.upper("y", 0.0).sample_values(ds)
    par = LimitState.upper("y", 0.0, first_passage="parabola")
    refined = par.sample_values(ds)
    assert np.max(np.abs(-grid - amp) / amp) > 0.02
    assert np.max(np.abs(-refined - amp) / amp) < 1.5e-3
    assert par.to_dict()["first_passage"] == "parabola"
    assert "first_passage" not in LimitState.upper("y", 0.0).to_dict()
    system = SeriesSystem([par, LimitState.upper("y", 0.0, name="g2")],
                          first_passage="parabola")
    np.testing.assert_allclose(system.sample_values(ds), refined)
    assert system.to_dict()["first_passage"] == "parabola"


def test_evaluator_refines_the_full_and_the_half_grid():
    """The evaluator's first-passage value and its half-grid check both follow the limit
    state: on a grid that resolves the peak with the parabola, the half grid loses (almost)
    nothing, while the plain grid max loses failures."""
    from gearuq.failure.evaluator import LimitStateEvaluator
    from gearuq.testing.reliability_problems import random_phase_model

    model = random_phase_model()
    space = {"X1": {"dist": "normal", "mean": 0.0, "std": 1.0},
             "X2": {"dist": "normal", "mean": 0.0, "std": 1.0}}
    t = np.linspace(0.0, 4 * np.pi, 49)  # 24 instants per period; the half grid 12
    u = np.random.default_rng(8).standard_normal((4000, 2))
    amp = np.hypot(u[:, 0], u[:, 1])
    level = 2.0
    for how, worst in (("grid", 0.02), ("parabola", 1e-3)):
        ev = LimitStateEvaluator(model, space, LimitState.upper("y", level, first_passage=how),
                                 t, executor="serial")
        res = ev.evaluate(u, "x")
        assert np.max(np.abs((level - res["g"]) - amp)) < worst * amp.max()
        assert np.all(res["g"] <= res["g_half"] + 1e-12) or how == "parabola"
    assert ev.grid_gap_fraction < 0.01  # the refined half grid keeps the failures
