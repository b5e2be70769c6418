"""One keyword shape for every estimator: ``model_options={...}`` for the model, ``**`` only
for the method's own settings; the old ``**``-as-model-options calls keep working for one
release with a DeprecationWarning, and a name both sides know is never routed silently."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import stats

import gearuq
from gearuq.engines.pce import compare_mc_surrogate
from gearuq.failure.modes import Band
from gearuq.model import Option
from gearuq.testing.problems import standard_normal_space


def _shifted(x1, x2, shift=0.0):
    return 3.0 - shift - (x1 + x2) / math.sqrt(2.0)


def _shifted_model() -> gearuq.FunctionModel:
    return gearuq.FunctionModel(_shifted, ["x1", "x2"], ["g"], name="shifted_plane",
                                options=[Option("shift", 0.0, "offset of the limit state")])


def _tilted(x1, x2, tilt=0.0):
    return 3.0 - (1.0 + tilt) * x1 - x2


def _tilted_model() -> gearuq.FunctionModel:
    """A plane whose option changes its mean and its sensitivities alike."""
    return gearuq.FunctionModel(_tilted, ["x1", "x2"], ["g"], name="tilted_plane",
                                options=[Option("tilt", 0.0, "extra weight of x1")])


SPACE = standard_normal_space(2)
ENGINES = {
    "monte_carlo": lambda m, **kw: gearuq.monte_carlo(m, SPACE, n_samples=64, rng=3,
                                                      executor="serial", **kw),
    "polynomial_chaos": lambda m, **kw: gearuq.polynomial_chaos(m, SPACE, order=1,
                                                                n_samples=8, rng=3, **kw),
    "sobol_indices": lambda m, **kw: gearuq.sobol_indices(m, SPACE, n_base=16, rng=3,
                                                          n_bootstrap=10, **kw),
    "morris_screening": lambda m, **kw: gearuq.morris_screening(m, SPACE, n_trajectories=4,
                                                                rng=3, n_bootstrap=10, **kw),
}


def _numbers(result) -> np.ndarray:
    if isinstance(result, gearuq.PolynomialChaos):
        return np.array([result.mean("g"), result.variance("g")])
    name = "g" if "g" in result else "ST" if "ST" in result else "mu_star"
    return np.asarray(result[name].values, dtype=float)


@pytest.mark.parametrize("engine", sorted(ENGINES))
def test_old_keyword_shape_warns_and_gives_the_same_numbers(engine):
    run = ENGINES[engine]
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)  # the new shape never warns
        new = run(_tilted_model(), model_options={"tilt": 0.5})
    with pytest.warns(DeprecationWarning) as caught:
        old = run(_tilted_model(), tilt=0.5)
    text = " ".join(str(w.message) for w in caught)
    assert f"{engine}: tilt=" in text and "model_options={'tilt': 0.5}" in text
    assert caught[0].filename == __file__  # the warning points at the caller's line
    np.testing.assert_array_equal(_numbers(old), _numbers(new))
    # and the option took effect (the plane tilted), so the equality is not vacuous
    assert np.max(np.abs(_numbers(run(_tilted_model())) - _numbers(new))) > 1e-3


def test_compare_mc_surrogate_routes_fit_keywords_and_model_options():
    band = Band("g", lower=0.0)
    kw = dict(n_mc=4000, n_samples=8, n_surrogate=4000, rng=2, order=1)
    with pytest.warns(DeprecationWarning, match=r"compare_mc_surrogate: shift="):
        old = compare_mc_surrogate(_shifted_model(), SPACE, band, shift=1.0, **kw)
    new = compare_mc_surrogate(_shifted_model(), SPACE, band, model_options={"shift": 1.0},
                               **kw)
    np.testing.assert_array_equal(old["pf"].values, new["pf"].values)
    exact = stats.norm.cdf(-2.0)  # g = 2 - (x1 + x2)/sqrt(2)
    row = new.sel(approach="monte_carlo", mode="g")
    assert float(row["pf_lower"]) <= exact <= float(row["pf_upper"])


def _model_with_an_order_option(seen: list[int]) -> gearuq.FunctionModel:
    def fn(x1, x2, order=1):
        seen.append(order)
        return 3.0 - (x1 + x2) / math.sqrt(2.0) + 0.0 * order
    return gearuq.FunctionModel(fn, ["x1", "x2"], ["g"], name="order_option",
                                options=[Option("order", 1, "a model option named like a "
                                                "fitting setting", lower=1)])


def test_a_name_both_sides_know_is_refused_until_model_options_says_so():
    seen: list[int] = []
    model = _model_with_an_order_option(seen)
    band = Band("g", lower=0.0)
    with pytest.raises(ValueError, match=r"'order' is both a setting of compare_mc_surrogate "
                                         r"and an option of model 'order_option'"):
        compare_mc_surrogate(model, SPACE, band, n_mc=100, order=2)
    assert seen == []  # refused before any run
    cmp = compare_mc_surrogate(model, SPACE, band, n_mc=100, n_samples=16, n_surrogate=100,
                               order=2, model_options={"order": 5})
    assert set(seen) == {5}  # the model saw its own value on both sides...
    assert "order 2" in cmp.attrs["pce"]  # ...and the fit took the keyword


def test_failure_probability_keywords_are_method_settings_only():
    seen: list[int] = []

    def fn(x1, x2, n_samples=1):
        seen.append(int(n_samples))
        return 2.0 - (x1 + x2) / math.sqrt(2.0)
    model = gearuq.FunctionModel(fn, ["x1", "x2"], ["g"], name="n_samples_option",
                                 options=[Option("n_samples", 1, "a model option named like "
                                                 "a method setting", lower=1)])
    with pytest.raises(ValueError, match=r"'n_samples' is both a setting of "
                                         r"failure_probability\(method='mc'\)"):
        gearuq.failure_probability(model, SPACE, "g", method="mc", n_samples=500, rng=1)
    with pytest.raises(ValueError, match=r"write model_options=\{'shift': 1.0\}"):
        gearuq.failure_probability(_shifted_model(), SPACE, "g", method="mc", shift=1.0)
    with pytest.raises(ValueError, match="unknown setting"):
        gearuq.failure_probability(_shifted_model(), SPACE, "g", method="mc", shfit=1.0)
    assert seen == []
    rep = gearuq.failure_probability(model, SPACE, "g", method="mc", n_samples=500, rng=1,
                                     model_options={"n_samples": 7})
    assert int(rep["n_model_runs"]) == 500 and set(seen) == {7}


def test_the_run_context_keeps_its_former_names():
    """``gearuq.engines.common`` re-exports the run context from its floor, ``gearuq.runs``."""
    from gearuq import runs
    from gearuq.engines import common

    for name in common.__all__:
        assert getattr(common, name) is getattr(runs, name), name
    assert set(common.__all__) < set(runs.__all__)
