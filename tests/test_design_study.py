"""The relief_design study: its quick mode end to end (slow: rotor compilation), and the
design space it builds, checked without the rotor."""

from __future__ import annotations

import json

import numpy as np
import pytest

import gearuq
from gearuq import registry
from gearuq.design import space_at


def test_relief_space_moves_the_tolerance_band_with_the_design():
    from gearuq_studies import relief_design as study

    problem = study.design_problem(study.SEARCH_SPEEDS, study.SEARCH_OPTIONS)
    sp = space_at(problem.space, problem.variables, [10.0, 6.0])
    amount, length = sp.marginal("tip_relief_amount"), sp.marginal("tip_relief_length")
    assert (amount.params["lower"], amount.params["upper"]) == pytest.approx(
        (10.0 - study.AMOUNT_TOL, 10.0 + study.AMOUNT_TOL))
    assert (length.params["lower"], length.params["upper"]) == pytest.approx(
        (6.0 - study.LENGTH_TOL, 6.0 + study.LENGTH_TOL))
    # the load spread and the 58 pitch normals do not move with the design
    assert sp.marginal("torque").mean() == pytest.approx(1000.0)
    assert len(sp.names) == 2 + 1 + 58


def test_bad_seed_names_the_setting(tmp_path):
    with pytest.raises(ValueError, match="seed=-1"):
        registry.get_study("relief_design")(out=tmp_path, seed=-1)


@pytest.mark.slow
def test_quick_relief_design(tmp_path):
    code = registry.get_study("relief_design")(out=tmp_path, quick=True)
    assert code in (0, 1, 4, 6)  # quick sizes rarely vouch for anything; it must say why
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["quick"] and summary["message"]
    assert summary["model_runs"]["naive_nested_loop"] > summary["model_runs"]["search"]
    det = gearuq.load(tmp_path / "deterministic.nc")
    y = det["deterministic_response"].values
    # nominal gears at the design load: a relief of 3 um leaves the mesh deflection
    # excitation in place; the best relief on the grid cuts the mesh-order DTE by over half
    assert np.nanmin(y[0]) > 2.0 * np.nanmin(y)
    res = gearuq.load(tmp_path / "relief_design.nc")
    pf, lo, up = (res[f"landscape_pf{s}"].values for s in ("", "_lower", "_upper"))
    assert np.all((0 <= lo) & (lo <= pf) & (pf <= up) & (up <= 1))
    for name in ("pf_landscape.png", "response_band.png", "brute.nc"):
        assert (tmp_path / name).stat().st_size > 0
