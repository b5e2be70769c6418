"""``n_model_runs`` counts every evaluation, re-runs of chunks that raised included.

The oracle is a counter inside the model: the model function adds the number of samples it is
handed to a module-level tally before it does anything else (and before it raises). Every
failure-probability method must report exactly that tally, whether or not the model raises.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import gearuq
from gearuq.execution import AllSamplesFailedError, evaluate_chunks

TALLY = {"high": 0, "low": 0}


def _counted(x1, x2, *, key: str, raising: bool):
    TALLY[key] += int(np.size(x1))
    if raising and np.any(x2 > 2.0):  # a whole call raises: the driver bisects and re-runs
        raise RuntimeError("solver blew up for x2 > 2")
    return 3.0 - x1 + 0.0 * x2


def _high(x1, x2):
    return _counted(x1, x2, key="high", raising=True)


def _high_ok(x1, x2):
    return _counted(x1, x2, key="high", raising=False)


def _low(x1, x2):
    return _counted(x1, x2, key="low", raising=False) + 0.05


def _model(fn, name):
    return gearuq.FunctionModel(fn, ["x1", "x2"], ["g"], name=name)


SPACE = gearuq.ParameterSpace.normal(x1=(0.0, 1.0), x2=(0.0, 1.0))

CASES = {
    "mc": {"n_samples": 4000},
    "form": {"n_starts": 5},
    "sorm": {"n_starts": 3},
    "importance": {"n_samples": 400, "max_samples": 800, "n_starts": 3},
    "subset": {"n_per_level": 400},
    "akmcs": {"n_mc": 2000, "max_mc": 2000, "max_runs": 40, "n_initial": 8},
    "mfis": {"n_per_level": 400, "n_samples": 200, "max_samples": 400},
}


@pytest.mark.e2e
@pytest.mark.parametrize("raising", [True, False], ids=["raising", "clean"])
@pytest.mark.parametrize("method", list(CASES))
def test_n_model_runs_equals_the_models_own_count(method: str, raising: bool) -> None:
    TALLY.update(high=0, low=0)
    model = _model(_high if raising else _high_ok, "counted_high")
    settings = dict(CASES[method])
    if method == "mfis":
        settings["low_fidelity"] = _model(_low, "counted_low")
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # the driver's "samples raised"
        rep = gearuq.failure_probability(model, SPACE, "g", method=method, rng=3,
                                         executor="serial", chunk_size=64, **settings)
    assert int(rep["n_model_runs"]) == TALLY["high"], (method, raising, TALLY)
    if method == "mfis":
        assert int(rep["n_low_fidelity_runs"]) == TALLY["low"]
    if raising and method == "mc":
        # the re-runs are what made the reported count exceed the design's size
        assert int(rep["n_model_runs"]) > settings["n_samples"]
        assert int(rep["n_invalid"]) > 0


def test_driver_counts_bisection_reruns_exactly() -> None:
    """One raising sample in a chunk of 8: 8 + 4 + 2 + 1 failing calls and 4 + 2 + 1 good
    ones, i.e. 8 + 2 (4 + 2 + 1) = 22 evaluations; other chunks once."""
    TALLY.update(high=0, low=0)
    model = _model(_high, "counted_high")
    x1 = np.zeros(32)
    x2 = np.zeros(32)
    x2[5] = 3.0  # chunk 0 (samples 0..7) raises once per bisection level
    with pytest.warns(RuntimeWarning, match="1 sample"):
        ds = evaluate_chunks(model, {"x1": x1, "x2": x2}, model.prepare(outputs=["g"]),
                             chunk_size=8, executor="serial", progress=False)
    assert ds.attrs["n_evaluations"] == TALLY["high"] == 8 + 2 * (4 + 2 + 1) + 24
    assert int(ds["status"][5]) == gearuq.model.STATUS_MODEL_ERROR
    assert int(np.count_nonzero(ds["status"])) == 1


def test_all_failed_design_still_counts() -> None:
    TALLY.update(high=0, low=0)
    model = _model(_high, "counted_high")
    with pytest.raises(AllSamplesFailedError) as info:
        evaluate_chunks(model, {"x1": np.zeros(4), "x2": np.full(4, 3.0)},
                        model.prepare(outputs=["g"]), chunk_size=4, executor="serial",
                        progress=False)
    # 4 + 2 + 2 + 1 + 1 + 1 + 1 calls' samples: every level of the bisection fails
    assert info.value.n_evaluations == TALLY["high"] == 4 + 2 * 2 + 4 * 1
