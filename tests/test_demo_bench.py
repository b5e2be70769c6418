"""The main job (gearuq demo) and the integrator benchmark, on small sizes."""

import json

import numpy as np
import pytest
from scipy.stats import norm

import gearuq
from gearuq.bench import core as bench
from gearuq.registry import DEFAULT_STUDY, get_study
from gearuq_studies.helical_pair_reliability import SEED_TABLE3, seed_beta_explanation

run_demo = get_study(DEFAULT_STUDY)


def test_seed_table3_betas_do_not_follow_from_its_pf():
    text = seed_beta_explanation()
    for pf, beta in SEED_TABLE3.values():
        assert f"{norm.isf(pf):.4f}" in text
        assert abs(norm.isf(pf) - beta) > 0.5  # the printed beta is not Phi^-1(1 - P_f)


@pytest.mark.e2e
def test_demo_small_run_writes_consistent_results(tmp_path, capsys):
    assert run_demo(tmp_path, n_samples=300, seed=5, progress=False) == 0
    out = capsys.readouterr().out
    assert "Table 3 analog" in out and "system" in out
    for name in ("helical_pair_mc.nc", "reliability_margin.nc", "reliability_tolerance.nc",
                 "reliability_R_t.png", "failure_probability_t.png",
                 "fitted_distributions.png", "table3.json"):
        assert (tmp_path / name).stat().st_size > 0, name
    ds = gearuq.load(tmp_path / "helical_pair_mc.nc")
    assert ds.sizes["sample"] == 300 and ds.attrs["model"] == "helical_pair"
    assert json.loads(ds.attrs["space"])  # provenance: the space as JSON
    rel = gearuq.load(tmp_path / "reliability_tolerance.nc")
    rows = json.loads((tmp_path / "table3.json").read_text())
    for r in rows:
        assert 0.0 <= r["pf_lower"] <= r["pf"] <= r["pf_upper"] <= 1.0
        if r["beta_lower_bound"] == 0:
            assert r["beta"] == pytest.approx(norm.isf(r["pf"]), rel=1e-9)
    system = rel.sel(mode="system").isel(time=-1)
    single = [r["pf"] for r in rows]
    assert float(system["pf"]) >= max(single) - 1e-12  # series system >= each mode
    assert "chunks computed; removed" in out  # the store goes once the result is written
    assert not list(tmp_path.glob("chunks-*"))
    # with --keep-chunks a rerun of the same settings reuses every chunk and says so
    again = tmp_path / "again"
    assert run_demo(again, n_samples=300, seed=5, progress=False, keep_chunks=True) == 0
    capsys.readouterr()
    assert run_demo(again, n_samples=300, seed=5, progress=False, keep_chunks=True) == 0
    out = capsys.readouterr().out
    assert "reused 1 of 1 chunks" in out and "kept" in out
    ds2 = gearuq.load(again / "helical_pair_mc.nc")
    np.testing.assert_array_equal(ds2["v1"].values, ds["v1"].values)
    # another setting gets another store, never a mismatch error
    assert run_demo(again, n_samples=200, seed=5, progress=False, keep_chunks=True) == 0
    assert len(list(again.glob("chunks-*"))) == 2


def test_studies_are_listed_and_run_through_the_registry():
    assert DEFAULT_STUDY in gearuq.registry.list_studies()
    with pytest.raises(ValueError, match="unknown study 'nope'.*helical_pair_reliability"):
        get_study("nope")


@pytest.mark.e2e  # ~28 s CPU: scipy's DOP853 reference and four compiled integrator variants
def test_integrator_benchmark_accuracy():
    """Event location beats stepping across kinks at equal rtol; the reference agrees with
    scipy's DOP853 (accuracy only: timings belong to `-m bench`)."""
    res = bench.integrator_table(n_samples=2, n_scipy=1, rtols=(1e-4, 1e-6))
    rows = {(r["method"], r["rtol"]): r for r in res["rows"]}
    assert res["reference_vs_scipy_dop853"] < 1e-6
    ev = rows[("gearuq DOPRI5 + events (frozen sides)", 1e-6)]
    plain = rows[("gearuq DOPRI5 no events", 1e-6)]
    assert ev["error"] < plain["error"] / 10
    assert ev["error"] < rows[("gearuq DOPRI5 + events (frozen sides)", 1e-4)]["error"]
    assert "gearuq DOPRI5 + events (frozen sides)" in bench.render_markdown(res)


@pytest.mark.bench
def test_integrator_benchmark_speed_ratio():
    """Side by side in one run: the compiled batched integrator beats the scipy loop."""
    res = bench.integrator_table(n_samples=2, n_scipy=1, rtols=(1e-4,))
    rows = {(r["method"], r["rtol"]): r for r in res["rows"]}
    ev = rows[("gearuq DOPRI5 + events (frozen sides)", 1e-4)]
    assert rows[("scipy RK45 loop", 1e-4)]["time_per_sample"] / ev["time_per_sample"] > 10
