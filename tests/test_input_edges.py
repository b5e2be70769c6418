"""Bad input found by trying gearuq as a new user: each is refused by name, with the value and
the valid range, or handled as documented, never a traceback or a silent answer."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import gearuq
from gearuq import cli

STAGES = Path(gearuq.__file__).parent / "gears" / "stages"


def _usage_error(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """The command line refuses ``argv`` while parsing it (exit 2) and says why."""
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 2
    return capsys.readouterr().err


# ============================================================================ the command line
@pytest.mark.parametrize("command", [["demo"], ["study", "sensitivity_ranking", "--quick"],
                                     ["run", "e_axle_27_79"]])
def test_an_output_folder_that_is_a_file_is_refused_by_name(command, tmp_path, capsys):
    path = tmp_path / "f"
    path.write_text("")
    err = _usage_error([*command[:1], "--out", str(path), *command[1:]], capsys)
    assert "--out" in err and "is an existing file, not a folder" in err
    assert path.read_text() == ""


def test_a_store_that_is_a_file_is_refused_by_name(tmp_path, capsys):
    path = tmp_path / "f"
    path.write_text("")
    err = _usage_error(["demo", "--store", str(path)], capsys)
    assert "--store" in err and "is an existing file" in err
    from gearuq.execution.store import ChunkStore

    with pytest.raises(ValueError, match="store: .* is an existing file, not a folder"):
        ChunkStore(path, {"call": 1})


@pytest.mark.parametrize(("argv", "words"), [
    (["demo", "--n-samples", "2"], "--n-samples: 2 is outside its valid range: integers >= 3"),
    (["demo", "--seed", "-1"], "--seed: -1 is outside its valid range: integers >= 0"),
    (["study", "mc_vs_surrogate", "--seed", "-1"], "--seed: -1 is outside its valid range"),
    (["run", "e_axle_27_79", "--n-speeds", "-3"], "--n-speeds: -3 is outside its valid range"),
    (["run", "e_axle_27_79", "--n-speeds", "1"], "integers >= 2"),
    (["run", "e_axle_27_79", "--rotor-speeds", "1"], "0 (skip the run-up) or integers >= 2"),
    (["run", "e_axle_27_79", "--rotor-speeds", "-1"], "--rotor-speeds: -1 is outside"),
])
def test_numbers_out_of_range_are_refused_before_any_work(argv, words, capsys):
    assert words in _usage_error(argv, capsys)


def test_zero_rotor_speeds_still_means_skip():
    args = cli.build_parser().parse_args(["run", "e_axle_27_79", "--rotor-speeds", "0"])
    assert args.rotor_speeds == 0


def test_run_on_a_folder_says_it_is_a_folder(tmp_path, capsys):
    assert cli.main(["run", str(tmp_path)]) == 2
    assert "is a folder; give a stage file" in capsys.readouterr().err


def _stage_without(tmp_path: Path, key: str, replace: str | None = None) -> Path:
    lines = (STAGES / "e_axle_27_79.toml").read_text().splitlines()
    kept = [(replace if replace is not None else None) if ln.startswith(f"{key} ") else ln
            for ln in lines]
    path = tmp_path / "bad.toml"
    path.write_text("\n".join(ln for ln in kept if ln is not None) + "\n")
    return path


def test_a_stage_file_missing_a_required_key_names_it(tmp_path, capsys):
    path = _stage_without(tmp_path, "normal_module")
    assert cli.main(["run", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("gearuq: error: bad.toml: [pair]: required key(s) ['normal_module']")
    assert "Traceback" not in err


def test_a_wrong_type_in_a_stage_file_is_an_error_line_not_a_traceback(tmp_path, capsys,
                                                                       monkeypatch):
    path = _stage_without(tmp_path, "normal_module", 'normal_module = "two"')
    assert cli.main(["run", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("gearuq: error: bad.toml: [pair] normal_module") and "'two'" in err
    monkeypatch.setenv("GEARUQ_TRACEBACK", "1")  # where it was raised, for a bug report
    with pytest.raises(TypeError, match="normal_module"):
        cli.main(["run", str(path)])


@pytest.mark.e2e  # a fresh interpreter (1-2 s of CPU)
def test_a_closed_pipe_ends_the_listing_quietly():
    listing = "from gearuq.cli import main; import sys; sys.exit(main(['models', 'helical_pair']))"
    proc = subprocess.run(f'{sys.executable} -c "{listing}" | head -c 1', shell=True,
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONWARNINGS": "ignore"})
    assert "Traceback" not in proc.stderr and "BrokenPipe" not in proc.stderr, proc.stderr


@pytest.mark.e2e  # imports distributed and waits for a refused connection (about 3 s)
def test_an_unreachable_scheduler_is_named_as_the_executor():
    # distributed's config defaults first: leaving dask.config.set restores the config as
    # it found it, and would drop a 'distributed' section added inside the block
    import dask
    import distributed  # noqa: F401

    from gearuq.execution.runners import resolve_executor

    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}), \
            pytest.raises(ValueError, match=r"executor='tcp://127.0.0.1:1': no dask scheduler"):
        resolve_executor("tcp://127.0.0.1:1")


# ============================================================================ the Python API
def test_unknown_construction_options_are_named_with_the_valid_ones():
    with pytest.raises(ValueError, match=r"unknown construction option\(s\) \['bogus'\]; "
                                         r"valid: none"):
        gearuq.get_model("linear_oscillator", bogus=1)
    with pytest.raises(ValueError, match=r"\['bogus'\]; valid: \[.*'stiffness_harmonics'"):
        gearuq.get_model("helical_pair", bogus=1)


def test_params_outputs_and_booleans_are_checked_by_name():
    model = gearuq.get_model("linear_oscillator")
    t = np.linspace(0.0, 1.0, 5)
    with pytest.raises(TypeError, match="params: expected a mapping"):
        model.response([1.0, 2.0], t)
    with pytest.raises(TypeError, match="outputs: expected an output name or a list"):
        model.response({}, t, outputs=3)
    with pytest.raises(TypeError, match="outputs: names are text"):
        model.response({}, t, outputs=["displacement", 3])
    with pytest.raises(ValueError, match="parameter 'm': value True is of type bool"):
        model.response({"m": True}, t)
    with pytest.raises(ValueError, match="parameter 'm': value True at sample 0"):
        model.response({"m": np.array([True, False])}, t)
    # an xarray Dataset of inputs is a mapping and still works
    ds = model.response(xr.Dataset({"m": ("sample", [1.0, 2.0])}), t)
    assert ds.sizes["sample"] == 2 and np.all(ds["status"].values == 0)


def test_fitting_saving_and_averaging_name_their_argument(tmp_path):
    with pytest.raises(ValueError, match="samples must be real numbers"):
        gearuq.fit_distributions("abc")
    with pytest.raises(TypeError, match="ds: expected an xarray.Dataset"):
        gearuq.save({"a": 1}, tmp_path / "x.nc")
    assert not (tmp_path / "x.nc").exists()
    failed = xr.Dataset({"y": (("sample", "time"), np.ones((4, 3))),
                         "status": ("sample", np.ones(4, dtype=np.int8))})
    with pytest.raises(ValueError, match=r"0 valid value\(s\) of 'y' in 4 samples \(4 with a "
                                         r"nonzero status\)"):
        gearuq.estimate_mean(failed, "y")
    ok = failed.assign(status=("sample", np.array([0, 0, 1, 1], dtype=np.int8)))
    mean = gearuq.estimate_mean(ok, "y")
    assert np.all(mean["n"].values == 2) and np.allclose(mean["mean"].values, 1.0)


def test_stage_analysis_and_study_counts_are_checked_by_name(tmp_path):
    from gearuq.stage_analysis import analyse_stage

    stage = gearuq.GearStage.example("e_axle_27_79")
    with pytest.raises(ValueError, match="n_speeds=0 is outside its valid range"):
        analyse_stage(stage, n_speeds=0, progress=False)
    with pytest.raises(ValueError, match="rotor_speeds=1 is outside its valid range"):
        analyse_stage(stage, rotor_speeds=1, progress=False)
    study = gearuq.get_study("helical_pair_dynamics")
    for bad in (0, -5):  # refused, not replaced by the default
        with pytest.raises(ValueError, match=f"periods={bad} is outside its valid range"):
            study(out=tmp_path / "d", quick=True, periods=bad)
    assert not (tmp_path / "d").exists()


@pytest.mark.parametrize(("old", "new", "words"), [
    ('output = "peak_dte_amplitude"', 'output = "nope"',
     "[reliability] output='nope' is not an output of model 'mesh_oscillator'"),
    ('method = "subset"', 'method = "bogus"', "[reliability] method='bogus' is not a method"),
    ("[random.damping_ratio]", "[random.damping_ratioo]",
     "[random] ['damping_ratioo']: not parameters of model 'mesh_oscillator'"),
    ("n_frequencies = 41", "n_frequencies = 0", "[reliability] model 'mesh_oscillator'"),
])
def test_a_stage_file_s_reliability_table_is_checked_before_the_analysis(
        old, new, words, tmp_path, capsys, monkeypatch):
    text = (STAGES / "e_axle_27_79.toml").read_text()
    assert old in text
    path = tmp_path / "bad.toml"
    path.write_text(text.replace(old, new, 1))

    def analysis_not_reached(*args, **kwargs):
        raise AssertionError("the analysis started before the [reliability] table was checked")

    monkeypatch.setattr("gearuq.stage_analysis.analyse_stage", analysis_not_reached)
    assert cli.main(["run", str(path), "--quiet"]) == 2
    assert words in capsys.readouterr().err


def test_options_that_would_be_ignored_are_refused(capsys):
    assert cli.main(["models", "--stage", "e_axle_27_79"]) == 2
    assert "--stage builds one model from the stage; give its NAME" in capsys.readouterr().err
    assert cli.main(["bench", "surrogate", "--coverage", "--seeds", "5"]) == 2
    err = capsys.readouterr().err
    assert "bench surrogate: --coverage, --seeds belong(s) to `gearuq bench reliability`" in err


def test_a_design_larger_than_the_memory_is_refused_by_name():
    model = gearuq.get_model("linear_oscillator")
    space = gearuq.ParameterSpace.normal(m=(1.0, 0.01))
    with pytest.raises(ValueError, match=r"n_samples: 1000000000000000 samples of \d+ "
                                         r"parameters need about .* for the design alone"):
        gearuq.monte_carlo(model, space, np.linspace(0.0, 1.0, 3), n_samples=10**15, rng=1)
