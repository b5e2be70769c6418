"""Bad input found by trying gearuq as a new user: each is refused by name, with the value and
the valid range, or handled as documented, never a traceback or a silent answer."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import warnings
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


def test_an_output_folder_that_cannot_be_made_is_refused_by_name(tmp_path, capsys):
    # under a file: no folder can be made there, whoever runs it
    blocker = tmp_path / "f"
    blocker.write_text("")
    err = _usage_error(["demo", "--out", str(blocker / "sub" / "out")], capsys)
    assert "argument --out" in err and f"{blocker} is not a folder" in err
    if Path("/proc/self").is_dir():  # Linux: nothing can be made in /proc, not even by root
        err = _usage_error(["demo", "--out", "/proc/gearuq_out"], capsys)
        assert "argument --out" in err and "cannot write into /proc" in err
    # a folder that can be made is accepted and not made while parsing (nor a probe left)
    args = cli.build_parser().parse_args(["demo", "--out", str(tmp_path / "new" / "out")])
    assert args.out == str(tmp_path / "new" / "out")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]


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
    ("upper = 1.5e-05", "upper = -1.5e-05",
     "[reliability] Band on 'peak_dte_amplitude': upper=-1.5e-05 is below every value "
     "peak_dte_amplitude can take (peak_dte_amplitude >= 0 m): every sample would fail"),
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


# ================================================= bands beyond what an output can take
def test_a_band_outside_what_its_output_can_take_is_refused():
    from gearuq.failure import Band

    with pytest.raises(ValueError, match=r"upper=-1 is below every value y can take "
                                         r"\(y >= 0 m\): every sample would fail"):
        Band("y", upper=-1.0).check_reach(0.0, "m")
    with pytest.raises(ValueError, match=r"lower=0 is at or below every value y can take .* "
                                         r"no sample can fail"):
        Band("y", lower=0.0).check_reach(0.0)
    with pytest.raises(ValueError, match=r"upper=0.5 is below every value \|y\| can take"):
        Band("y", upper=0.5, absolute=True).check_reach(1.0)
    for band in (Band("y", upper=1e-9), Band("y", lower=1e-9), Band("y", lower=-1, upper=2),
                 Band("y", upper=0.0), Band("y", upper=-1.0, absolute=False)):
        if band.upper >= 0:
            band.check_reach(0.0)  # reachable on both sides: nothing to refuse
        band.check_reach(None)  # no bound known: nothing to check
    Band("y", upper=-1.0).check_reach(-2.0)
    Band("y", upper=1.0, absolute=True).check_reach(-5.0)  # |y| >= 0 only


def test_reliability_and_failure_probability_refuse_a_band_no_sample_can_meet(tmp_path):
    from gearuq.failure import Band

    model = gearuq.get_model("linear_oscillator")
    space = {"k": {"dist": "uniform", "lower": 900.0, "upper": 1100.0}}
    ds = gearuq.monte_carlo(model, space, n_samples=8, rng=1, outputs=["steady_amplitude"])
    assert ds["steady_amplitude"].attrs["valid_min"] == 0.0
    assert "valid_min" not in ds["k"].attrs
    with pytest.raises(ValueError, match=r"upper=-0.001 is below every value steady_amplitude"):
        gearuq.reliability(ds, Band("steady_amplitude", upper=-1e-3))
    with pytest.raises(ValueError, match=r"no sample can fail"):
        gearuq.reliability(ds, Band("steady_amplitude", lower=-1.0))
    # the saved file keeps the bound, so a reloaded result is checked the same way
    gearuq.save(ds, tmp_path / "r.nc")
    back = gearuq.load(tmp_path / "r.nc")
    assert back["steady_amplitude"].attrs["valid_min"] == 0.0
    with pytest.raises(ValueError, match=r"every sample would fail"):
        gearuq.reliability(back, Band("steady_amplitude", upper=-1e-3))
    with pytest.raises(ValueError, match=r"every sample would fail"):
        gearuq.failure_probability(model, space, Band("steady_amplitude", upper=-1e-3),
                                   method="mc", n_samples=10)
    rep = gearuq.reliability(ds, Band("steady_amplitude", upper=float(
        ds["steady_amplitude"].median())))
    assert 0.0 < float(rep["pf"].max()) < 1.0


@pytest.mark.e2e
def test_every_declared_lower_bound_holds_on_sampled_outputs():
    """A ``valid_min`` is a claim about the physics: check it on every model's outputs."""
    calls = [  # (model, instants, options, outputs: None for every bounded one)
        ("linear_oscillator", np.linspace(0.0, 1.0, 11), {}, None),
        ("helical_pair", np.linspace(0.0, 20.0, 11), {}, None),
        ("mesh_excitation", np.linspace(0.0, 2.0, 25), {}, None),
        ("mesh_oscillator", None, {"n_frequencies": 41}, "frequency"),
        ("mesh_oscillator", np.linspace(0.0, 2.0 * np.pi, 201), {}, ["kv"]),
        ("geared_rotor", None, {"speed_max": 3000.0, "n_speeds": 6, "peaks_refined": 0}, None),
    ]
    for name, t, options, which in calls:
        model = gearuq.get_model(name)
        bounded = [o.name for o in model.outputs if o.valid_min is not None]
        assert bounded, name
        if which == "frequency":
            bounded = [o for o in bounded if "frequency" in model.output(o).dims]
        elif which is not None:
            bounded = which
        space = model.default_space()
        design = (space.sample(3, rng=3) if space is not None else  # the oscillator has none
                  {"k": np.array([5e3, 1e4, 4e4]), "c": np.array([2.0, 20.0, 200.0]),
                   "omega": np.array([10.0, 100.0, 300.0])})
        ds = model.response(design, t, outputs=bounded, **options)
        ok = ds["status"].values == 0
        assert ok.any(), name
        for out in bounded:
            values = ds[out].values[ok]
            values = values[np.isfinite(values)]
            floor = ds[out].attrs["valid_min"]
            assert values.size and values.min() >= floor, (name, out, values.min())


# ============================================== fourteenth round: FunctionModel's contract
def test_function_model_refuses_a_result_of_the_wrong_shape():
    one_for_all = gearuq.FunctionModel(lambda a: a[:1], ["a"], ["y"])
    with pytest.raises(ValueError, match=r"output 'y' has shape \(1,\), expected \(5,\)"):
        one_for_all.response({"a": np.arange(5.0)})
    # a run falls back to one sample per call after a chunk's error, where a[:1] is right
    ds = gearuq.monte_carlo(one_for_all, {"a": {"dist": "normal", "mean": 0.0, "std": 1.0}},
                            n_samples=5, rng=1, executor="serial")
    np.testing.assert_array_equal(ds["y"].values, ds["a"].values)  # no value copied
    narrow = gearuq.FunctionModel(lambda a, t: np.ones((len(a), 1)) * t[:1], ["a"], ["y"],
                                  time_dependent=True)
    with pytest.raises(ValueError, match=r"shape \(2, 1\), expected \(2, 3\)"):
        narrow.response({"a": [1.0, 2.0]}, np.array([0.0, 1.0, 2.0]))
    wide = gearuq.FunctionModel(lambda a: np.ones((len(a), 3)), ["a"], ["y"])
    with pytest.raises(ValueError, match="needs the output declared time-dependent"):
        wide.response({"a": [1.0, 2.0]})
    keyed = gearuq.FunctionModel(lambda a: {"z": a}, ["a"], ["y"])
    with pytest.raises(ValueError, match=r"fn returned the keys \['z'\]; the declared output"):
        keyed.response({"a": [1.0, 2.0]})
    # the right shapes pass, values untouched
    good = gearuq.FunctionModel(lambda a, t: a[:, None] * t, ["a"], ["y"], time_dependent=True)
    np.testing.assert_array_equal(good.response({"a": [1.0, 2.0]}, np.array([0.0, 1.0]))["y"],
                                  [[0.0, 1.0], [0.0, 2.0]])


def test_function_model_refuses_declarations_that_cannot_work():
    with pytest.raises(ValueError, match=r"outputs: duplicate name\(s\) \['y'\]"):
        gearuq.FunctionModel(lambda a: (a, 2 * a), ["a"], ["y", "y"])
    with pytest.raises(ValueError, match=r"parameters: duplicate name\(s\) \['a'\]"):
        gearuq.FunctionModel(lambda a: a, ["a", "a"], ["y"])
    with pytest.raises(ValueError, match=r"fn takes \(b\) .* no argument for \['a'\]"):
        gearuq.FunctionModel(lambda b: b, ["a"], ["y"])
    with pytest.raises(TypeError, match=r"\('a', 2.0\): a tuple is \(name, units, nominal"):
        gearuq.FunctionModel(lambda a: a, [("a", 2.0)], ["y"])
    # a function taking **kwargs is called with every parameter
    any_kw = gearuq.FunctionModel(lambda **kw: kw["a"] + kw["b"], ["a", "b"], ["y"])
    np.testing.assert_array_equal(any_kw.response({"a": [1.0], "b": [2.0]})["y"], [3.0])


# ============================================ fourteenth round: estimates that cannot hold
def _oscillator_problem():
    model = gearuq.get_model("linear_oscillator")
    space = gearuq.ParameterSpace({
        "m": {"dist": "normal", "mean": 1.0, "std": 0.05},
        "k": {"dist": "uniform", "lower": 9000.0, "upper": 11000.0}})
    return model, space


def test_an_interval_beyond_zero_and_one_is_clipped_and_not_vouched_for():
    model, space = _oscillator_problem()
    limit = gearuq.LimitState.upper("steady_amplitude", 3e-3)
    rep = gearuq.failure_probability(model, space, limit, method="subset", rng=1,
                                     n_per_level=2)
    assert 0.0 <= float(rep["pf_lower"]) <= float(rep["pf_upper"]) <= 1.0
    assert int(rep["status"]) == 1
    assert "reached beyond [0, 1]" in gearuq.describe_status(rep)
    # an adequate run is untouched: its interval holds a 20 000-run reference (0.177)
    rep = gearuq.failure_probability(model, space, limit, method="subset", rng=1,
                                     n_per_level=100)
    assert int(rep["status"]) == 0
    assert float(rep["pf_lower"]) <= 0.177 <= float(rep["pf_upper"])


def test_sobol_indices_flag_impossible_and_undefined_values():
    from gearuq.engines.sensitivity import SOBOL_FLAGS

    model, space = _oscillator_problem()
    with pytest.raises(ValueError, match=r"n_base: 3 is not a power of 2 .* 2 or 4"):
        gearuq.sobol_indices(model, space, n_base=3, outputs="steady_amplitude", rng=1)
    tiny = gearuq.sobol_indices(model, space, n_base=4, outputs="steady_amplitude", rng=1)
    s1 = tiny["S1"].values.ravel()
    assert s1.max() > 1.0  # sampling error at N = 4 ...
    assert 2 in tiny["S1_flag"].values  # ... flagged, and said
    assert "sum to up to" in tiny.attrs["note"] and "flagged 2" in tiny.attrs["note"]
    assert tiny["S1_flag"].attrs["flag_meanings"].split()[2].startswith("impossible")
    flat = gearuq.sobol_indices(model, {"x0": {"dist": "normal", "mean": 0.0, "std": 0.1}},
                                n_base=8, outputs="steady_amplitude", rng=1)
    assert np.isnan(flat["S1"].values).all() and (flat["S1_flag"].values == 3).all()
    assert SOBOL_FLAGS[3] in flat.attrs["note"]
    good = gearuq.sobol_indices(model, space, n_base=256, outputs="steady_amplitude", rng=1)
    assert not good["S1_flag"].values.any() and not good["ST_flag"].values.any()
    # the chaos route takes any training size
    gearuq.sobol_indices(model, space, n_base=30, method="pce", outputs="steady_amplitude",
                         rng=1)


def test_a_multifidelity_budget_below_two_samples_is_refused():
    model, space = _oscillator_problem()
    with pytest.raises(ValueError, match=r"budget=0.5 buys fewer than the 2 samples of "
                                         r"models\[0\]"):
        gearuq.multifidelity_estimate([model, model], space, "steady_amplitude", budget=0.5,
                                      costs=[1.0, 0.1], rng=1)


def test_booleans_are_checked_by_name(tmp_path):
    from gearuq.failure import Band

    model, space = _oscillator_problem()
    ds = gearuq.monte_carlo(model, space, np.linspace(0.0, 1.0, 5), n_samples=6, rng=1)
    band = {"displacement": (-0.01, 0.01)}
    for key in ("system", "first_passage"):
        with pytest.raises(TypeError, match=f"{key}: expected True or False, got 'no'"):
            gearuq.reliability(ds, band, **{key: "no"})
    with pytest.raises(TypeError, match="ok_only: expected True or False"):
        gearuq.estimate_mean(ds, "steady_amplitude", ok_only="yes")
    gearuq.save(ds, tmp_path / "r.nc")
    with pytest.raises(TypeError, match="lazy: expected True or False, got 'yes'"):
        gearuq.load(tmp_path / "r.nc", lazy="yes")
    with pytest.raises(ValueError, match=r"absolute band with lower=-1 and no upper"):
        Band("displacement", lower=-1.0, absolute=True)
    assert gearuq.reliability(ds, band, system=np.bool_(False)).sizes["mode"] == 1


# ==================================================== fourteenth round: files and folders
def test_save_refuses_what_netcdf_would_not_give_back(tmp_path):
    ds = xr.Dataset({"y": ("sample", np.arange(3.0))})
    for extra, words in [
        (np.full(3, np.datetime64("2020-01-01", "ns")), "variable 'v' holds dates"),
        (np.ones(3) + 1j, "variable 'v' is complex"),
        (np.array([None] * 3, dtype=object), "variable 'v' holds Python objects (NoneType"),
    ]:
        with pytest.raises(TypeError, match=re.escape(words)):
            gearuq.save(ds.assign(v=("sample", extra)), tmp_path / "x.nc")
    with pytest.raises(ValueError, match=r"x.csv' would hold netCDF under a .csv name"):
        gearuq.save(ds, tmp_path / "x.csv")
    with pytest.raises(ValueError, match="path: empty"):
        gearuq.save(ds, "")
    with pytest.raises(ValueError, match="path: empty"):
        gearuq.load("")
    assert not list(tmp_path.iterdir())
    # text held as Python objects is text: it round-trips, its checksum holds
    labelled = ds.assign(lab=("sample", np.array(["a", "bb", "c"], dtype=object)))
    gearuq.save(labelled, tmp_path / "t.nc")
    np.testing.assert_array_equal(gearuq.load(tmp_path / "t.nc")["lab"].values, ["a", "bb", "c"])


def test_an_export_into_an_earlier_export_leaves_no_stale_file(tmp_path):
    model, space = _oscillator_problem()
    ds = gearuq.monte_carlo(model, space, np.linspace(0.0, 1.0, 5), n_samples=6, rng=1)
    gearuq.export_csv(ds, tmp_path / "e")
    assert (tmp_path / "e" / "sample-time.csv").exists()
    user_file = tmp_path / "e" / "notes.csv"
    user_file.write_text("mine\n")
    with pytest.warns(UserWarning, match=r"held an earlier export; its sample-time.csv removed"):
        gearuq.export_csv(ds.isel(time=0, drop=True)[["m"]], tmp_path / "e")
    assert sorted(p.name for p in (tmp_path / "e").iterdir()) == [
        "notes.csv", "provenance.json", "sample.csv"]  # a file no export wrote is kept


# ======================================================= fourteenth round: stages, studies
def test_a_helical_pair_built_from_a_stage_samples_the_stage():
    stage = gearuq.GearStage.example("e_axle_27_79")
    model = gearuq.get_model("helical_pair", stage=stage)
    space = model.default_space()
    paper = gearuq.get_model("helical_pair").default_space()
    for name in space.names:
        nominal = model.parameter(name).nominal
        assert space.marginal(name).mean() == pytest.approx(nominal, rel=1e-12)
        # Table 2's coefficient of variation, kept
        cov = space.marginal(name).std() / abs(nominal)
        ref = paper.marginal(name).std() / abs(paper.marginal(name).mean())
        assert cov == pytest.approx(ref, rel=1e-12)
    assert model.parameter("n").nominal != paper.marginal("n").mean()


@pytest.mark.parametrize(("argv", "words"), [
    (["run", ""], "stage: empty; give a stage file (TOML) or the name of a shipped stage"),
    (["run", "missing.toml"], "stage file 'missing.toml': no such file"),
    (["models", "helical_pair", "--stage", ""], "stage: empty"),
])
def test_stage_arguments_are_named(argv, words, capsys):
    assert cli.main(argv) == 2
    assert words in capsys.readouterr().err


def test_a_stage_file_is_read_as_text_with_or_without_a_byte_order_mark(tmp_path, capsys):
    text = (STAGES / "e_axle_27_79.toml").read_bytes()
    (tmp_path / "bom.toml").write_bytes(b"\xef\xbb\xbf" + text)
    assert cli.main(["models", "helical_pair", "--stage", str(tmp_path / "bom.toml")]) == 0
    assert cli.main(["models", "helical_pair", "--stage", "e_axle_27_79"]) == 0  # a name
    capsys.readouterr()
    (tmp_path / "r.nc").write_bytes(b"\x89HDF\r\n\x1a\n\xff\xfe")
    assert cli.main(["run", str(tmp_path / "r.nc")]) == 2
    assert "not a text file; a stage file is TOML text" in capsys.readouterr().err


@pytest.mark.parametrize(("old", "new", "words"), [
    ("upper = 1.5e-05", "upper = nan", "[reliability] upper=nan is not a finite number"),
    ("seed = 2026", "seed = -1", "[reliability] seed=-1 is outside its valid range"),
    ("n_base = 128", "n_base = 100", "[reliability] n_base=100 is not a power of 2"),
    ("frequency_min = 0.6", "frequency_min = 1.5",
     "frequency_max=1.4 must exceed frequency_min=1.5"),
])
def test_a_stage_file_s_numbers_are_named_before_any_run(old, new, words, tmp_path, capsys,
                                                         monkeypatch):
    text = (STAGES / "e_axle_27_79.toml").read_text()
    assert old in text
    (tmp_path / "s.toml").write_text(text.replace(old, new, 1))

    def analysis_not_reached(*args, **kwargs):
        raise AssertionError("the analysis started before the file was checked")

    monkeypatch.setattr("gearuq.stage_analysis.analyse_stage", analysis_not_reached)
    assert cli.main(["run", str(tmp_path / "s.toml"), "--quiet",
                     "--out", str(tmp_path / "o")]) == 2
    assert words in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_a_refused_command_leaves_no_folder_and_an_interrupt_says_what_resumes(
        tmp_path, capsys, monkeypatch):
    out = tmp_path / "demo_out"
    assert cli.main(["demo", "--out", str(out), "--executor", "bogus"]) == 2
    assert "executor: unknown 'bogus'" in capsys.readouterr().err
    assert not out.exists()

    def interrupted(**kwargs):
        Path(kwargs["out"]).mkdir()
        raise KeyboardInterrupt

    monkeypatch.setattr("gearuq.registry.get_study", lambda name: interrupted)
    assert cli.main(["demo", "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert "gearuq: interrupted" in err and "Traceback" not in err
    assert out.exists()  # what an interrupted run made is kept


def test_study_and_bench_options_refuse_what_they_cannot_use(capsys):
    err = _usage_error(["study", "helical_pair_dynamics", "--quick", "--n-rpm", "nan"], capsys)
    assert "argument --n-rpm: 'nan' is not a finite number" in err
    err = _usage_error(["bench", "reliability", "--coverage", "--problems", ""], capsys)
    assert "argument --problems: expected comma-separated names, got ''" in err


def test_the_quick_note_of_the_default_study_follows_its_sample_count():
    from gearuq_studies import helical_pair_reliability as study

    assert "about 3.2 times wider" in study._quick_left_out({"n_samples": 10_000})
    assert "about 10.0 times wider" in study._quick_left_out({"n_samples": 100_000})
    assert study._quick_left_out({"n_samples": 3}).startswith("nothing")


# ================================================== fourteenth round: arguments that apply
def test_settings_that_would_apply_to_nothing_are_refused():
    from gearuq.failure import Band, LimitState

    model, space = _oscillator_problem()
    t = np.linspace(0.0, 1.0, 5)
    ds = gearuq.monte_carlo(model, space, t, n_samples=6, rng=1)
    with pytest.raises(ValueError, match=r"time=\(0.0, 0.5\) applies to nothing"):
        gearuq.reliability(ds, {"steady_amplitude": (None, 1e-3)}, time=(0.0, 0.5))
    with pytest.raises(ValueError, match=r"window=\(0.0, 0.5\) applies to nothing"):
        gearuq.failure_probability(model, space, LimitState.upper(
            "steady_amplitude", 1e-3, window=(0.0, 0.5)), t, method="mc", rng=1, n_samples=10)
    with pytest.raises(ValueError, match="n_samples=50 does not apply to method='quadrature'"):
        gearuq.polynomial_chaos(model, space, order=2, method="quadrature",
                                outputs="steady_amplitude", rng=1, n_samples=50)
    with pytest.raises(ValueError, match=r"Band on 'displacement': lower='a' is not a number"):
        gearuq.reliability(ds, {"displacement": ("a", "b")})
    with pytest.raises(ValueError, match=r"unknown key\(s\) \['uper'\]"):
        gearuq.reliability(ds, {"displacement": {"upper": 1.0, "uper": 2.0}})
    with pytest.raises(ValueError, match="threshold: nan is not a finite number"):
        gearuq.fit_distributions(np.linspace(1.0, 2.0, 20), threshold=float("nan"))
    with pytest.raises(ValueError, match=r"frequency_max=1.1 must exceed frequency_min=1.5"):
        gearuq.get_model("mesh_oscillator").prepare(None, frequency_min=1.5, frequency_max=1.1)
    assert Band("displacement", upper=1.0)  # the time range still applies to time outputs
    assert "time" in gearuq.reliability(ds, {"displacement": (-1.0, 1.0)}, time=(0.0, 0.5)).dims


def test_a_limit_state_of_the_wrong_shape_or_nan_is_named():
    from gearuq.failure import LimitState

    model, space = _oscillator_problem()
    ds = gearuq.monte_carlo(model, space, np.linspace(0.0, 1.0, 5), n_samples=8, rng=1)
    with pytest.raises(ValueError, match=r"returned shape \(\); it must return one value per "
                                         r"sample \(shape \(6,\)"):
        gearuq.failure_probability(model, space, LimitState(
            lambda steady_amplitude: 1.0, "steady_amplitude"), method="mc", rng=1, n_samples=6)
    with pytest.raises(ValueError, match="it must keep the 8 samples"):
        gearuq.reliability(ds, LimitState(lambda steady_amplitude: steady_amplitude[:3],
                                          "steady_amplitude"))
    rep = gearuq.failure_probability(model, space, LimitState(
        lambda steady_amplitude: np.full_like(steady_amplitude, np.nan), "steady_amplitude"),
        method="mc", rng=1, n_samples=6)
    assert int(rep["status"]) == 2
    assert "not by the model, which ran: the limit state returned NaN" in gearuq.describe_status(
        rep)


def test_paths_and_degenerate_models_are_named(tmp_path):
    ds = xr.Dataset({"y": ("sample", np.arange(3.0))})
    (tmp_path / "afile").write_text("")
    with pytest.raises(ValueError, match=r"afile' is a file, not a folder"):
        gearuq.save(ds, tmp_path / "afile" / "x.nc")
    with pytest.raises(ValueError, match=r"is a folder; give a file name in it"):
        gearuq.save(ds, tmp_path)
    with pytest.raises(TypeError, match=r"expected a file path .* got int 12345"):
        gearuq.load(12345)
    with pytest.raises(TypeError, match="give one file at a time"):
        gearuq.load(["a.nc"])
    with pytest.raises(ValueError, match=r"threshold=\(1.0, -1.0\): lower=1 must be < upper=-1"):
        gearuq.fit_distributions(np.linspace(-2.0, 2.0, 30), candidates=["normal"],
                                 threshold=(1.0, -1.0), tail="two-sided")
    model, space = _oscillator_problem()
    with pytest.raises(ValueError, match=r"perfectly correlated with models\[0\]"):
        gearuq.multifidelity_estimate([model, model], space, "steady_amplitude", budget=100.0,
                                      costs=[1.0, 1.0], rng=1)
    flat = gearuq.FunctionModel(lambda m, k: np.zeros_like(m), ["m", "k"], ["steady_amplitude"])
    with pytest.raises(ValueError, match=r"models\[1\] \('function'\) gives the same mean"):
        gearuq.multifidelity_estimate([model, flat], space, "steady_amplitude", budget=50.0,
                                      costs=[1.0, 0.1], rng=1, estimator="acvmf")
    # the default estimator leaves a constant cheaper model out (n_samples 0), without
    # NumPy's divide-by-zero warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        rep = gearuq.multifidelity_estimate([model, flat], space, "steady_amplitude",
                                            budget=50.0, costs=[1.0, 0.1], rng=1)
    assert int(rep["n_samples"].values[1]) == 0 and int(rep["n_samples"].values[0]) > 0
    with pytest.raises(ValueError, match=r"models\[0\] \('function'\) .* enlarge the pilot"):
        gearuq.multifidelity_estimate([flat, model], space, "steady_amplitude", budget=50.0,
                                      costs=[1.0, 0.1], rng=1)
    with pytest.raises(ValueError, match=r"FORM: g = -1.003 <= 0 already at the start"):
        gearuq.failure_probability(model, space, gearuq.LimitState.upper(
            "steady_amplitude", -1.0), method="form", rng=1)
