"""Every packaged study is runnable by name from an install, with a quick mode.

Contract checks cover all studies registered under ``gearuq.studies``; the quick modes of the
cheap studies run through the registry into a temporary folder, and each asserts a number
its physics fixes (not only that files exist). The quick modes over a few seconds of CPU run
with ``-m e2e`` (``.ci/run`` does), so every study's quick output is checked for its marks in CI;
each is under a minute of CPU (docs/benchmarks.md, "Quick modes, measured one by one").
"""

from __future__ import annotations

import inspect
import re
from importlib.metadata import entry_points
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import gearuq
import gearuq_studies
from gearuq import cli, registry
from gearuq.plot import QUICK_MARK_KEY

STUDY_DIR = Path(gearuq_studies.__file__).parent
#: A status code followed by its meaning (``status 3: the ...``, ``status: all 400 samples ok``)
#: and one printed bare (``status 3``, ``status=3``): .ci/quick_studies.py reads screens alike.
STATUS_IN_WORDS = re.compile(r"status(?: -?\d+)?: [a-z]", re.IGNORECASE)
STATUS_CODE = re.compile(r"status\W{0,3}-?\d", re.IGNORECASE)
MODULES = sorted(p.stem for p in STUDY_DIR.glob("*.py") if p.stem != "__init__")


def _entry_points() -> dict[str, str]:
    return {ep.name: ep.value for ep in entry_points(group=registry.STUDY_GROUP)}


# =========================================================================== the contract
def test_every_study_module_is_registered_under_its_own_name():
    eps = _entry_points()
    assert len(MODULES) >= 15, MODULES
    assert sorted(eps) == MODULES
    for name, value in eps.items():
        assert value == f"gearuq_studies.{name}:run", (name, value)


def test_studies_list_shows_every_study_with_its_description(capsys):
    assert cli.main(["studies"]) == 0
    text = capsys.readouterr().out
    assert "BROKEN" not in text
    for row in registry.describe_studies():
        assert not row.error, row
        assert f"{row.name}  " in text and row.description in text


@pytest.mark.parametrize("name", MODULES)
def test_study_run_signature_and_description(name):
    run = registry.get_study(name)
    params = inspect.signature(run).parameters
    first = (run.__doc__ or "").strip().splitlines()
    assert first and len(first[0]) > 20, f"{name}: no one-line description"
    # papers are cited by their authors, never by a corpus label
    assert not re.search(r"\bseed\b", first[0], re.IGNORECASE), first[0]
    default = params["out"].default
    assert isinstance(default, str | Path) and not Path(default).is_absolute(), default
    assert Path(default).name.startswith("gearuq_"), default
    assert "quick" in params and params["quick"].default is False, name


@pytest.mark.parametrize("name", MODULES)
def test_study_writes_nothing_into_the_source_tree_and_gets_models_from_the_registry(name):
    import ast
    import importlib

    text = (STUDY_DIR / f"{name}.py").read_text()
    assert "studies/output" not in text and "__file__" not in text, name
    # a plugin's public helpers (a force-deflection table, say) may be imported; its model
    # classes may not: models come from gearuq.get_model
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("gearuq_plugins"):
            module = importlib.import_module(node.module)
            for alias in node.names:
                obj = getattr(module, alias.name)
                assert not (isinstance(obj, type) and issubclass(obj, gearuq.Model)), (
                    f"{name} imports the model class {alias.name}: use gearuq.get_model")


@pytest.mark.parametrize("name", MODULES)
def test_study_command_line_has_out_and_quick(name, capsys):
    module = __import__(f"gearuq_studies.{name}", fromlist=["main"])
    with pytest.raises(SystemExit) as exc:
        module.main(["--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    assert "--out" in text and "--quick" in text


def test_unknown_study_exits_nonzero_and_lists_the_valid_names(capsys):
    assert cli.main(["study", "no_such_study"]) != 0
    err = capsys.readouterr().err
    assert "no_such_study" in err
    for name in MODULES:
        assert name in err


def test_bad_setting_names_the_parameter(tmp_path):
    with pytest.raises(ValueError, match="step=-5"):
        registry.get_study("geared_rotor_speed_sweep")(out=tmp_path, step=-5.0)
    with pytest.raises(ValueError, match="link='gear'"):
        registry.get_study("fidelity_link_correlation")(out=tmp_path, link="gear")


# =========================================================================== quick runs
def _run_quick(name: str, out: Path) -> None:
    """Run a study's quick mode; it must say so on screen and stamp every figure it saves."""
    import contextlib
    import io

    from matplotlib.figure import Figure

    saved, unmarked = [], []
    savefig = Figure.savefig

    def recording_savefig(fig, path, *args, **kwargs):
        saved.append(Path(path).name)
        if not getattr(fig, "_gearuq_quick_mark", False):
            unmarked.append(Path(path).name)
        return savefig(fig, path, *args, **kwargs)

    screen = io.StringIO()
    with pytest.MonkeyPatch.context() as mp, contextlib.redirect_stdout(screen):
        mp.setattr(Figure, "savefig", recording_savefig)
        assert registry.get_study(name)(out=out, quick=True) == 0
    text = screen.getvalue()
    first = next(line for line in text.splitlines() if line.startswith("quick: "))
    assert ", not a result; left out: " in first, first
    assert saved and not unmarked, f"{name}: figures without the quick mark: {unmarked}"
    bare = [line for line in text.splitlines()
            if STATUS_CODE.search(line) and not STATUS_IN_WORDS.search(line)]
    assert not bare, f"{name}: a status printed without its meaning: {bare[:3]}"
    pngs = sorted(out.glob("*.png"))
    assert pngs, f"{name} wrote no PNG"
    for path in pngs:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", path
        # the written file carries the mark too, where a reader of the folder finds it
        assert Image.open(path).text.get(QUICK_MARK_KEY) == first.split(";")[0], path
    for path in sorted(out.glob("*.nc")):
        gearuq.load(path)  # every netCDF the study wrote reopens with gearuq.io


def test_quick_fidelity_link_correlation(tmp_path):
    _run_quick("fidelity_link_correlation", tmp_path)
    ds = gearuq.load(tmp_path / "correlation.nc")
    ok = ds["status"].values == 0
    a, b = ds["high_fidelity"].values[ok], ds["link"].values[ok]
    # the stored correlation is that of the stored values, and the link follows the pair
    assert ds.attrs["pearson"] == pytest.approx(np.corrcoef(a, b)[0, 1], abs=1e-9)
    assert ds.attrs["pearson_lower"] > 0.9
    assert abs(b.mean() / a.mean() - 1.0) < 0.02
    assert (tmp_path / "correlation.md").read_text().count("pearson") == 1


def test_fidelity_link_correlation_command_line(tmp_path):
    from gearuq_studies import fidelity_link_correlation as study

    assert study.main(["--out", str(tmp_path), "--n", "24", "--space", "wide"]) == 0
    ds = gearuq.load(tmp_path / "correlation.nc")
    assert ds.sizes["sample"] == 24 and ds.attrs["space"] == "wide"


# e2e: the whole study in its quick mode (three models, a frequency sweep each), 2.9 CPU s
@pytest.mark.e2e
def test_quick_model_fidelity(tmp_path):
    _run_quick("model_fidelity", tmp_path)
    ds = gearuq.load(tmp_path / "dte_vs_mesh_frequency.nc")
    f = ds["frequency"].values
    step = f[1] - f[0]
    hp = ds["helical_pair_e_a_1.0um"].values
    free = ds["ISO_supports_free_e_a_1.0um"].values
    rigid = ds["ISO_torsional_rigid_bearings_e_a_1.0um"].values
    # with contact kept, the SDOF with the support-free mass puts the resonance where the
    # 10-DOF pair has it; the rigid-bearing mass misplaces it by hundreds of Hz
    assert abs(f[np.argmax(hp)] - f[np.nanargmax(free)]) <= 2 * step
    assert abs(f[np.argmax(hp)] - f[np.nanargmax(rigid)]) > 300.0
    assert np.nanmax(free) == pytest.approx(hp.max(), rel=0.15)


@pytest.mark.e2e
def test_quick_sensitivity_ranking(tmp_path):
    _run_quick("sensitivity_ranking", tmp_path)
    ds = gearuq.load(tmp_path / "indices_tau200.nc").isel(time=0)
    names = list(ds["parameter"].values)
    top2 = [{names[j] for j in np.argsort(-ds["ST"].sel(output=o).values)[:2]}
            for o in ds["output"].values]
    # the face widths dominate through b = min(B1, B2) (ranking.md explains why)
    assert sum(t == {"B1", "B2"} for t in top2) >= 8, top2
    assert (tmp_path / "ranking.md").exists()


@pytest.mark.e2e
def test_quick_helical_pair_dynamics(tmp_path):
    _run_quick("helical_pair_dynamics", tmp_path)
    ds = gearuq.load(tmp_path / "dynamics.nc")
    tau = ds["time"].values
    period = float(ds.attrs["mesh_period_tau"])
    # the last 64 mesh periods (32 points each): the forced response peaks at the mesh
    # frequency, read off an FFT independent of the study's own spectrum code
    n = 64 * 32
    p = ds["p2"].values[0][-n:]
    spec = np.abs(np.fft.rfft(p - p.mean()))
    freq = np.fft.rfftfreq(n, d=tau[1] - tau[0])
    assert freq[np.argmax(spec)] == pytest.approx(1.0 / period, rel=0.02)


@pytest.mark.e2e
def test_quick_pitch_deviation_excitation(tmp_path):
    _run_quick("pitch_deviation_excitation", tmp_path)
    ds = gearuq.load(tmp_path / "ltca_long_period.nc")
    lpms = ds["lpms"].mean("position").values
    loss = ds["contact_loss_fraction"].mean("position").values
    # a loaded mesh stiffens and closes its gaps as the torque grows (200 ... 1000 N m)
    assert np.all(np.diff(lpms) > 0), lpms
    assert loss[-1] < loss[0], loss
    rmap = gearuq.load(tmp_path / "tip_relief_map.nc")
    assert rmap.attrs["optimum_ste_ptp_um"] < float(rmap["ste_ptp"].isel(amount=0).min())


@pytest.mark.e2e
def test_quick_geared_rotor_spectra(tmp_path):
    _run_quick("geared_rotor_spectra", tmp_path)
    loads = gearuq.load(tmp_path / "spectra_torques.nc")
    relief = gearuq.load(tmp_path / "spectra_relief.nc")
    a_fm = loads["dte_spectrum"].sel(order=30).values  # f_m = 30 f_s (30 pinion teeth)
    assert np.all(np.diff(a_fm) > 0), a_fm  # mesh-order DTE grows with torque
    fm_relief = relief["dte_spectrum"].sel(order=30).values
    assert fm_relief[1] < 0.5 * fm_relief[0], fm_relief  # the 42 um relief near its optimum


@pytest.mark.e2e
def test_quick_transmission_error_uq(tmp_path):
    _run_quick("transmission_error_uq", tmp_path)
    sob = gearuq.load(tmp_path / "sobol_indices.nc").sel(output="ste_ptp")
    # the STE peak-to-peak of a pitch-deviated pair is set by the realisation itself
    assert str(sob["parameter"].values[int(np.argmax(sob["ST"].values))]) == "pitch_seed"
    exc = gearuq.load(tmp_path / "ste_exceedance.nc")
    assert np.all((exc["pf_lower"] <= exc["pf"]) & (exc["pf"] <= exc["pf_upper"]))


# =========================================================================== e2e quick runs
@pytest.mark.e2e
def test_quick_mc_vs_surrogate(tmp_path):
    _run_quick("mc_vs_surrogate", tmp_path)
    ds = gearuq.load(tmp_path / "comparison.nc")
    pf = ds["pf_ref"].values  # ten DOFs, then the series system
    assert pf[:-1].max() <= pf[-1] <= pf[:-1].sum()


@pytest.mark.e2e
def test_quick_geared_rotor_reliability(tmp_path):
    _run_quick("geared_rotor_reliability", tmp_path)
    med = [float(np.nanmedian(gearuq.load(tmp_path / f"rms_dte_grade{g}.nc")["dte_rms"]))
           for g in (5, 6, 7)]
    assert med[0] < med[1] < med[2], med  # a coarser ISO grade, a larger kinematic error


@pytest.mark.e2e
def test_quick_geared_rotor_speed_sweep(tmp_path):
    _run_quick("geared_rotor_speed_sweep", tmp_path)
    ds = gearuq.load(tmp_path / "rms_dte_vs_speed.nc")
    rms = ds["dte_rms"].values  # (modification, amplitude, speed)
    assert np.all(rms[1, 0] < rms[0, 0])  # error-free teeth: the relief helps at every speed


@pytest.mark.e2e
def test_quick_geared_rotor_speed_range_bench(tmp_path):
    _run_quick("geared_rotor_speed_range_bench", tmp_path)
    ds = gearuq.load(tmp_path / "timings.nc")
    assert np.all(np.abs(ds["relative_error"].sel(path="plugin dte_rms_max").values) < 1e-3)


@pytest.mark.e2e
def test_quick_helical_pair_rare_events(tmp_path):
    import json

    _run_quick("helical_pair_rare_events", tmp_path)
    info = json.loads((tmp_path / "summary.json").read_text())
    pf = [info["subset"][k][0]["pf"] for k in ("check", "1e-4", "1e-6")]
    assert pf[0] > pf[1] > pf[2] > 0, pf  # a higher force limit is reached less often


@pytest.mark.e2e
def test_quick_mesh_oscillator_regions(tmp_path):
    _run_quick("mesh_oscillator_regions", tmp_path)
    ds = gearuq.load(tmp_path / "reliability_mc.nc")
    ok = ds["status"].values == 0
    # the largest amplitude on either sweep is at least the run-up's
    assert np.all(ds["peak_dte_either"].values[ok] >= ds["peak_dte_runup"].values[ok])


@pytest.mark.e2e
def test_quick_geared_rotor_rare_events(tmp_path):
    import json

    _run_quick("geared_rotor_rare_events", tmp_path)
    info = json.loads((tmp_path / "summary.json").read_text())
    (check,) = info["crude_mc"]  # the one quick level, checked by crude Monte Carlo
    assert check["X_um"] == 25.0 and check["runs"] == 100 and check["invalid"] == 0
    assert sorted(r["method"] for r in info["rows"]) == ["mfis", "subset"]
    for row in info["rows"]:
        if row["status"] == 0:  # an interval vouched for meets crude Monte Carlo's
            assert row["lower"] <= check["upper"] and check["lower"] <= row["upper"], row


@pytest.mark.e2e
def test_quick_relief_design(tmp_path):
    import json

    _run_quick("relief_design", tmp_path)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["quick"] and summary["message"]
    assert summary["search_options"]["n_speeds"] == 12  # the quick fidelity it announced
    assert summary["model_runs"]["naive_nested_loop"] > summary["model_runs"]["search"]
    # the stage file of the paper's rotor rebuilds it: kv_max equal sample by sample
    assert summary["stage_check"]["largest_relative_difference"] < 1e-6
    assert set(summary["per_shape"]) == {"parabolic", "linear"}
    det = gearuq.load(tmp_path / "deterministic.nc")
    y = det["deterministic_kv_max"].values
    assert np.all(np.isfinite(y)) and np.all(y >= 1.0)  # a dynamic factor is at least 1
    res = gearuq.load(tmp_path / "relief_design.nc")
    pf, lo, up = (res[f"landscape_pf{s}"].values for s in ("", "_lower", "_upper"))
    assert np.all((0 <= lo) & (lo <= pf) & (pf <= up) & (up <= 1))
    assert (tmp_path / "brute.nc").stat().st_size > 0


@pytest.mark.e2e
def test_quick_helical_pair_reliability(tmp_path):
    _run_quick("helical_pair_reliability", tmp_path)
    ds = gearuq.load(tmp_path / "reliability_tolerance.nc")
    pf = ds["pf"].isel(time=-1)
    dofs = pf.sel(mode=[m for m in pf["mode"].values if m != "system"]).values
    system = float(pf.sel(mode="system"))
    assert int(ds["n_samples"]) == 1000  # the quick size it announced
    # a series system fails at least as often as its worst DOF and at most as all together
    assert dofs.max() <= system <= dofs.sum()
    assert np.allclose(pf.values, ds["n_failures"].isel(time=-1).values / int(ds["n_valid"]))
