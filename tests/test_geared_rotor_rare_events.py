"""The headline study's pieces: its space, its cheap model's agreement with the rotor, the
crude-MC exceedance with failed runs, and the CLI's quick flag."""

from __future__ import annotations

import numpy as np
import pytest

from gearuq.failure.intervals import clopper_pearson_interval
from gearuq_studies import geared_rotor_rare_events as study


def test_space_is_the_germ_of_both_gears_relief_tolerance_and_torque_spread():
    space = study.study_space()
    assert space.dim == 60
    assert sum(n.startswith("pitch_xi_p_") for n in space.names) == 29
    assert sum(n.startswith("pitch_xi_g_") for n in space.names) == 29
    assert space.mean()["torque"] == pytest.approx(1000.0)
    assert space.std()["torque"] == pytest.approx(100.0)
    assert space.ppf("tip_relief_amount", 0.0) == pytest.approx(37.0)
    assert space.ppf("tip_relief_amount", 1.0) == pytest.approx(47.0)
    assert study.study_model().nominal()["iso_grade"] == 6


@pytest.mark.e2e
def test_cheap_model_is_within_a_fraction_of_a_micrometre_of_the_rotor():
    """The documented claim behind the cheap model (40 speeds, 2 harmonics): on random
    samples of the study's space its dte_rms_max is within 0.5 um of the rotor's (measured:
    0.17 um at most on 120 samples, 0.36 um on one of these 12, whose peak falls between the
    coarse grid's speeds) and ranks the samples the same way."""
    model = study.study_model()
    x = study.study_space().sample(12, rng=5)
    hf = model.response(x, None, outputs=["dte_rms_max"])
    lf = model.response(x, None, outputs=["dte_rms_max"], **study.LOW_FIDELITY_OPTIONS)
    y, z = hf["dte_rms_max"].values * 1e6, lf["dte_rms_max"].values * 1e6
    assert np.all(hf["status"].values == 0) and np.all(lf["status"].values == 0)
    assert np.abs(y - z).max() <= 0.5
    assert np.corrcoef(y, z)[0, 1] > 0.999
    # and it is not a copy: the grids differ, so the values do too
    assert np.abs(y - z).max() > 0.0


def test_exceedance_counts_failed_runs_in_the_interval_not_the_estimate():
    mc = {"y": np.array([1.0, 5.0, 7.0, 2.0, np.nan, 9.0]),
          "ok": np.array([True, True, True, True, False, True])}
    e = study.exceedance(mc, 6.0)
    assert e["failures"] == 2 and e["invalid"] == 1 and e["pf"] == pytest.approx(2 / 6)
    lo, _ = clopper_pearson_interval(2, 6)
    _, up = clopper_pearson_interval(3, 6)
    assert e["lower"] == pytest.approx(float(lo)) and e["upper"] == pytest.approx(float(up))


def test_study_cli_refuses_quick_for_a_study_without_it(capsys, monkeypatch, tmp_path):
    """Every packaged study has a quick mode; a third-party study without one is refused
    with a reason, before it runs."""
    from gearuq import cli, registry

    ran = []

    def no_quick(out: str = "gearuq_x") -> int:
        """A study without a quick mode."""
        ran.append(out)
        return 0

    monkeypatch.setattr(registry, "get_study", lambda name: no_quick)
    rc = cli.main(["study", "third_party", "--quick", "--out", str(tmp_path / "x")])
    assert rc == 2 and "no quick mode" in capsys.readouterr().err and not ran



@pytest.mark.parametrize("quick", [False, True])
def test_study_mfis_settings_are_valid_and_the_full_study_tilts_the_fitted_quadratic(
        monkeypatch, quick):
    """The study's MFIS call passes settings the method accepts (checked without a run); the
    full study fits the quadratic form of dte_rms_max^2 (the response is X - g, so the
    offset is X in metres) and the quick one keeps the Gaussian mixture."""
    from gearuq.failure.api import validate_settings

    seen = {}

    def capture(model, space, limit, **kw):
        seen.update(kw)
        return "report"

    monkeypatch.setattr(study, "failure_probability", capture)
    assert study.mfis(62.0, 3, quick) == "report"
    assert seen.pop("method") == "mfis" and seen.pop("rng") == 3
    # the quick run is two fidelity steps down: the benchmark case's cheap rotor plays the
    # rotor, and the same at half its speeds the cheap model
    model_options = seen.pop("model_options", None)
    settings = validate_settings("mfis", seen)
    if quick:
        assert settings["biasing"] == "gaussian"
        assert model_options == {"n_speeds": 20, "range_mesh_harmonics": 1}
        assert settings["low_fidelity_options"] == {"n_speeds": 10, "range_mesh_harmonics": 1}
        # half the rotor draws from the standard normal: every weight at most 1 / 0.5
        assert settings["defensive"] == 0.5 and settings["max_components"] == 1
    else:
        assert settings["biasing"] == "quadratic" and model_options is None
        assert settings["response_offset"] == pytest.approx(62e-6)
        assert settings["n_fit"] >= (60 + 1) * (60 + 2) // 2  # the form's coefficients


def test_every_stage_of_the_study_runs_on_the_cores_it_is_given(monkeypatch):
    """The study's executor and chunking reach MFIS, subset simulation and crude Monte Carlo
    (serial, a batch of 200 rotor runs was one chunk: one core of two); by default worker
    processes, 100 samples a chunk."""
    execution = {"executor": "processes", "chunk_size": 100}
    assert study.DEFAULT_EXECUTION == execution
    seen = []

    def capture(*args, **kw):
        seen.append({k: kw.get(k) for k in execution})
        raise RuntimeError("captured")

    monkeypatch.setattr(study, "failure_probability", capture)
    monkeypatch.setattr(study.gearuq, "monte_carlo", capture)
    for stage in (lambda: study.mfis(62.0, 3, False, execution),
                  lambda: study.subset(62.0, 3, False, execution),
                  lambda: study.crude_monte_carlo(10, 3, None, execution)):
        with pytest.raises(RuntimeError, match="captured"):
            stage()
    assert seen == [execution] * 3


@pytest.mark.parametrize("quick, given, expected", [
    (True, None, "serial"), (False, None, "processes"), (True, "processes", "processes")])
def test_the_quick_run_stays_in_one_process_unless_told(monkeypatch, tmp_path, capsys, quick,
                                                        given, expected):
    """Its stages are seconds each: a worker pool (imports and kernel loads in every worker)
    would cost more CPU than it shares. An executor given is used; the full study's default
    is worker processes. The quick run also says it is quick, and asks one level only."""
    seen = []

    def capture(*args, **kw):
        seen.append((kw.get("executor"), kw.get("method")))
        raise RuntimeError("captured")

    monkeypatch.setattr(study, "failure_probability", capture)
    monkeypatch.setattr(study, "study_model", lambda: type(
        "Stub", (), {"response": lambda *a, **k: None})())
    with pytest.raises(RuntimeError, match="captured"):
        study.run(out=tmp_path, quick=quick, executor=given)
    assert seen == [(expected, "mfis")]
    mark = "quick: about 330 rotor and 330 cheap-model runs, not a result"
    assert (mark in capsys.readouterr().out) is quick
    assert list(study.QUICK_LEVELS_UM.values()) == [25.0]
