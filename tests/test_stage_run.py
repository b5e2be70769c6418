"""``gearuq run STAGE.toml``: the files it writes and the physics of its run-up."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

import gearuq
from gearuq.cli import main
from gearuq.gears.stage import GearStage


@pytest.fixture(scope="module")
def e_axle_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    path = out / "e_axle.toml"
    GearStage.example("e_axle_27_79").to_toml(path)
    # the geared rotor's run-up at a reduced setting (12 speeds; 32 by default)
    assert main(["run", str(path), "--out", str(out / "res"), "--quiet", "--no-reliability",
                 "--n-speeds", "400", "--rotor-speeds", "12"]) == 0
    return out / "res"


@pytest.mark.e2e
def test_run_writes_netcdf_csv_and_a_self_contained_report(e_axle_run):
    names = {p.name for p in e_axle_run.iterdir()}
    assert {"stage.nc", "report.html", "geometry.csv", "iso6336.csv", "mesh_cycle.csv",
            "run_up.csv", "modes.csv", "resonances.csv", "rotor_run_up.csv"} <= names
    ds = gearuq.load(e_axle_run / "stage.nc")
    stage = GearStage.example("e_axle_27_79")
    # the file holds the stage itself: it rebuilds the same stage
    import tomllib

    assert GearStage.from_dict(tomllib.loads(ds.attrs["stage_toml"])) == stage
    assert ds["geometry"].sel(geometry_quantity="d1").item() == pytest.approx(
        27 * 2.0 / math.cos(math.radians(22.0)), rel=1e-12)
    assert ds["ltca_ste"].attrs["units"] == "um"
    assert int(ds["ltca_status"].max()) == 0
    report = (e_axle_run / "report.html").read_text()
    assert report.count("data:image/png;base64,") == 3 and "<script" not in report
    for text in ("ISO 21771 closed form", "ISO 6336-1", "LTCA", "modal damping"):
        assert text in report
    with open(e_axle_run / "resonances.csv") as fh:
        rows = list(csv.DictReader(fh))
    # headers carry units as ``gearuq export --csv`` writes them
    assert rows and {"resonance_speed [rpm]", "resonance_frequency [Hz]"} <= set(rows[0])


def test_run_up_resonance_is_at_the_mesh_frequency_of_a_mesh_mode(e_axle_run):
    """At each marked resonance the mesh harmonic h z1 n / 60 (written here) meets a natural
    frequency of a mode that strains the mesh, within the run-up's speed step and the shift
    of a 3 %-damped peak."""
    ds = gearuq.load(e_axle_run / "stage.nc")
    speeds = ds["speed"].values
    step_rpm = speeds[1] - speeds[0]
    f_n = ds["natural_frequency"].values[ds["mesh_energy_share"].values >= 0.01]
    assert ds["resonance_speed"].size >= 1
    for n, h in zip(ds["resonance_speed"].values, ds["resonance_harmonic"].values,
                    strict=True):
        f_mesh = h * 27 * n / 60.0
        nearest = f_n[np.argmin(abs(f_n - f_mesh))]
        assert abs(f_mesh - nearest) <= h * 27 * step_rpm / 60.0 + 0.015 * nearest
    # the mesh mode of largest mesh-energy share whose first-harmonic crossing lies in the
    # speed range is found as a first-harmonic resonance
    share = ds["mesh_energy_share"].values
    f_all = ds["natural_frequency"].values
    in_range = (f_all * 60 / 27 > speeds[0]) & (f_all * 60 / 27 < speeds[-1])
    mode = f_all[in_range][np.argmax(share[in_range])]
    h1 = ds["resonance_speed"].values[ds["resonance_harmonic"].values == 1]
    assert np.any(abs(h1 * 27 / 60.0 - mode) < 0.015 * mode)


@pytest.mark.e2e
def test_geared_rotor_run_up_peaks_where_the_mesh_frequency_meets_a_mesh_mode(e_axle_run):
    """The geared rotor's harmonic-balance run-up (per-bearing stiffness, classes 6/7, linear
    reliefs, the 2133-cycle long period): its located peak of the DTE at f_m is where
    z1 n / 60 meets a natural frequency of a mode that strains the mesh (>= 1 % of its
    strain energy in the mesh, the modal run-up's criterion; its rotor has the stage's mesh
    stiffness, the geared rotor's LTCA stiffness over the long period differs by a few per
    cent, which moves a mesh mode by less)."""
    ds = gearuq.load(e_axle_run / "stage.nc")
    assert ds.attrs["rotor_run_up"] == "geared_rotor on 12 speeds"
    assert int(ds["rotor_status"]) == 0
    assert ds["rotor_kv"].sizes["rotor_speed"] == 12 and np.all(ds["rotor_kv"].values >= 1.0)
    n = ds["rotor_speed_at_dte_mesh_order_max"].sel(rotor_mesh_harmonic=1).item()
    f_n = ds["natural_frequency"].values[ds["mesh_energy_share"].values >= 0.01]
    f_mesh = 27 * n / 60.0
    assert np.min(abs(f_n - f_mesh)) < 0.02 * f_mesh
    with open(e_axle_run / "rotor_run_up.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 12 * 2
    assert {"rotor_speed [rpm]", "rotor_kv [1]", "rotor_dte_mesh_order [m]"} <= set(rows[0])


def test_run_up_limits(e_axle_run):
    """Far above every mode the dynamic force tends to k e_h (the rotor cannot follow); the
    mesh-energy shares of the modes sum to 1: sum_r k (v.phi_r)^2 / w_r^2 = k v.K^-1 v, which
    is 1 when the torsion of the two shafts is held by the mesh alone (free ends)."""
    ds = gearuq.load(e_axle_run / "stage.nc")
    k = ds.attrs["mesh_stiffness_N_per_um"]
    e3 = ds["ste_harmonic"].sel(harmonic=3).item()
    top = ds["dynamic_mesh_force"].sel(harmonic=3).values[-1]
    # h = 3 at 16 000 rpm is 21.6 kHz, above the modes that load the mesh
    assert top == pytest.approx(k * e3, rel=0.1)
    assert ds["mesh_energy_share"].sum().item() == pytest.approx(1.0, abs=1e-6)


def test_models_command_lists_stage_parameters(tmp_path, capsys):
    path = tmp_path / "e.toml"
    GearStage.example("e_axle_27_79").to_toml(path)
    assert main(["models", "mesh_excitation", "--stage", str(path)]) == 0
    text = capsys.readouterr().out
    assert "iso_grade_wheel" in text and "pinion_tip_relief_amount" in text
    assert "pitch_xi_g_78" in text  # the germ's size follows z2 = 79


@pytest.mark.e2e  # ~80 s on the shared machine: the oscillator's kernels and 332 model runs
def test_reliability_step_from_the_file(tmp_path):
    """The file's [random] and [reliability] tables give a failure probability with an
    interval and a Sobol' ranking; an independent Monte Carlo estimate (own draws, own
    seed, the model evaluated directly) falls inside the reported interval."""
    from gearuq.space import ParameterSpace
    from gearuq.stage_analysis import analyse_stage, reliability, write_stage_results

    stage = GearStage.example("e_axle_27_79")
    data = stage.to_dict()
    data["reliability"] |= {"method": "mc", "n_base": 8,
                            "method_settings": {"n_samples": 300},
                            "model_options": {"n_frequencies": 11, "frequency_min": 0.7,
                                              "frequency_max": 1.3}, "upper": 6e-6}
    small = GearStage.from_dict(data)
    assert GearStage.from_dict(small.to_dict()) == small
    report, sobol = reliability(small)
    pf, lo, hi = (float(report[k]) for k in ("pf", "pf_lower", "pf_upper"))
    assert 0.0 < lo <= pf <= hi < 1.0 and int(report["n_model_runs"]) == 300
    model = gearuq.get_model("mesh_oscillator", stage=small)
    space = ParameterSpace(small.random_inputs)
    draws = space.sample(400, rng=99)
    ds = model.response(draws, None, outputs=["peak_dte_amplitude"], n_frequencies=11,
                        frequency_min=0.7, frequency_max=1.3)
    independent = float(np.mean(ds["peak_dte_amplitude"].values > 6e-6))
    assert lo - 0.05 <= independent <= hi + 0.05  # two estimates of one probability
    assert set(sobol["parameter"].values) == {"damping_ratio", "mean_force"}
    ds = analyse_stage(small, positions_per_cycle=8, n_pts=6, n_speeds=50, progress=False)
    paths = write_stage_results(ds, tmp_path / "out", reliability=(report, sobol),
                                reliability_settings=small.reliability_settings)
    text = paths["report"].read_text()
    assert "Reliability" in text and "Sobol" in text and "pf_upper" in text
    assert gearuq.load(paths["reliability"])["pf"].item() == pf
    assert (tmp_path / "out" / "reliability.csv").exists()
