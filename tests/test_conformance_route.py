"""``check_model`` holds one kernel route throughout (its bit-for-bit comparisons)."""

from __future__ import annotations

import numpy as np
import pytest

from gearuq._firstcall import _forced
from gearuq.model import FunctionModel
from gearuq.testing import check_model

_ROUTES_SEEN: list[str] = []


def _first_call_rounds_differently(a: np.ndarray) -> np.ndarray:
    """3a, with the last bit of an interpreted first call's rounding under ``"auto"``.

    It stands for a kernel whose first small call from an empty cache runs as plain Python
    and whose later calls run compiled: the two agree only to rounding.
    """
    route = _forced.get() or "auto"
    first = not _ROUTES_SEEN
    _ROUTES_SEEN.append(route)
    y = 3.0 * np.asarray(a, dtype=float)
    if route == "interpreted" or (route == "auto" and first):
        y = y + np.spacing(y)
    return y


@pytest.fixture
def route_model():
    _ROUTES_SEEN.clear()
    return FunctionModel(_first_call_rounds_differently, ["a"], ["y"])


@pytest.mark.parametrize("route", ["compiled", "interpreted"])
def test_every_call_of_the_check_runs_on_the_route_given(route_model, route):
    if route == "compiled":
        check_model(route_model)  # the default
    else:
        check_model(route_model, route=route)
    assert _ROUTES_SEEN and set(_ROUTES_SEEN) == {route}


def test_a_route_change_between_calls_would_fail_the_bitwise_comparisons(route_model):
    # the check under the default rule sees the first call round differently from the later
    # ones: what a cold cache did to the mesh oscillator's conformance test run on its own
    with pytest.raises(AssertionError, match="differs|not equal"):
        check_model(route_model, route="auto")


def test_a_bad_route_is_refused_by_name(route_model):
    with pytest.raises(ValueError, match="route='fast'"):
        check_model(route_model, route="fast")
