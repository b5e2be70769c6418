"""The gear models' reliability benchmark cases live in their plugins and are found through
the ``gearuq.reliability_cases`` entry points: by the coverage benchmark, by the registry and
under their old names in ``gearuq.testing.reliability_problems``."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from gearuq.bench.reliability import coverage_cases
from gearuq.failure.api import validate_settings
from gearuq.registry import get_reliability_case
from gearuq.testing import reliability_problems as rp

CASES = ("geared_rotor", "helical_pair", "helical_pair_deep", "helical_pair_grid")


def test_listing_the_cases_reads_metadata_and_imports_no_plugin():
    code = ("import sys; from gearuq.registry import list_reliability_cases as l; "
            "print(l()); print(any(m.startswith('gearuq_plugins') for m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split("\n")
    assert out[0] == str(list(CASES)) and out[1] == "False"


@pytest.mark.parametrize("name", CASES)
def test_each_case_is_complete_and_its_coverage_rows_are_valid_settings(name):
    case = get_reliability_case(name)
    assert {"model", "space", "limit_state", "pf", "pf_interval", "source"} <= set(case)
    assert case["model"].name == name.split("_grid")[0].split("_deep")[0]
    # the limit state reads an output of the model, over inputs of the model
    assert case["limit_state"].outputs[0] in case["model"].output_names
    assert set(case["space"].names) <= set(case["model"].parameter_names)
    lo, up = case["pf_interval"]
    assert 0.0 < case["pf"] < 1e-3 and (np.isnan(lo) or lo < case["pf"] < up)
    assert case["coverage"]
    for method, settings in case["coverage"]:
        validate_settings(method, settings)  # raises on an unknown or invalid setting


def test_old_names_are_the_plugins_objects_found_through_the_entry_points():
    peak = rp.helical_pair_problem()
    case = get_reliability_case("helical_pair")
    assert rp.helical_pair_problem.__module__ == "gearuq_plugins.helical_pair.reliability_cases"
    assert rp.geared_rotor_problem.__module__ == "gearuq_plugins.geared_rotor.reliability_cases"
    assert peak["pf"] == rp.HELICAL_PAIR_PF == case["pf"]
    assert repr(peak["limit_state"]) == repr(case["limit_state"])
    np.testing.assert_array_equal(peak["t"], rp.HELICAL_PAIR_T)
    settings = rp.geared_rotor_mfis_settings()
    assert settings["response_offset"] == rp.GEARED_ROTOR_LEVEL
    assert settings["low_fidelity_options"] == rp.GEARED_ROTOR_LOW_FIDELITY_OPTIONS
    from gearuq.bench import reliability as bench

    assert bench.HELICAL_PAIR_LOW_FIDELITY["low_fidelity_options"] == {"rtol": 1e-4}
    with pytest.raises(AttributeError, match="no attribute 'HELICAL_PAIR_NOPE'"):
        rp.HELICAL_PAIR_NOPE  # noqa: B018


def test_the_coverage_benchmark_runs_the_rows_each_plugin_declares():
    full, quick = coverage_cases(quick=False), coverage_cases(quick=True)
    for name in CASES:
        declared = [method for method, _ in get_reliability_case(name)["coverage"]]
        assert [m for n, m, _ in full if n == name] == declared
        assert not [row for row in quick if row[0] == name]  # the gear models: full size only
    assert [n for n, _, _ in full if n in CASES][:7] == ["helical_pair"] * 5 + [
        "helical_pair_grid", "geared_rotor"]  # the table keeps its order
