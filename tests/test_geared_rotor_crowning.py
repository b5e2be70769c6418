"""The geared rotor's ``lead_crowning``: the LTCA's crowning, 0 leaves every result unchanged."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

import gearuq
from gearuq_plugins.geared_rotor.physics import _SEAT_DIAMETER, problem_for, seed_pair

#: A coarse LTCA keeps the test fast; both models get the same one.
LTCA = {"positions_per_cycle": 8, "n_pts": 6}
#: Perfect pitch (no germ), a parabolic tip relief: the excitation is the designed flank's.
FLANK = {"tip_relief_amount": 15.0, "tip_relief_length": 11.4, "torque": 1000.0,
         "iso_grade": 0.0, "pitch_amplitude": 0.0, "pitch_sigma": 0.0}


@pytest.fixture(autouse=True)
def _quiet():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", category=UserWarning)
        yield


def rotor_excitation(model: gearuq.Model, crowning: float) -> object:
    """The rotor's problem (its LTCA excitation) for one sample with ``crowning`` [um]."""
    values = {p.name: p.nominal for p in model.parameters} | FLANK | {"lead_crowning": crowning}
    return problem_for(model, values, model.validate_options({**LTCA, "n_mesh_harmonics": 2}))


def test_crowning_parameter_is_declared_with_its_range():
    p = {q.name: q for q in gearuq.get_model("geared_rotor").parameters}["lead_crowning"]
    assert (p.units, p.nominal, p.lower, p.upper) == ("um", 0.0, 0.0, 2000.0)
    with pytest.raises(ValueError, match="lead_crowning"):
        gearuq.get_model("geared_rotor").response({"lead_crowning": [-1.0]}, None,
                                                  outputs=["dte_rms"], **LTCA)


@pytest.mark.parametrize("crowning", [8.0, 25.0])
def test_rotor_excitation_with_crowning_equals_the_mesh_excitation_ltca(crowning):
    """The rotor's STE and mesh stiffness with crowning C_b are those of the mesh_excitation
    plugin's LTCA with the same crowning (same pair and bore), to rounding; and crowning
    raises the STE (a crowned flank leaves its face ends out of contact)."""
    rotor = gearuq.get_model("geared_rotor")
    ltca = gearuq.get_model("mesh_excitation", bore_ratio=_SEAT_DIAMETER / seed_pair().df1)
    ex = rotor_excitation(rotor, crowning).excitation
    flat = rotor_excitation(rotor, 0.0).excitation
    ds = ltca.response({"crowning": [crowning], **{k: [v] for k, v in FLANK.items()}}, None,
                       outputs=["ste_mean", "ste_ptp", "lpms_tangent_mean"], **LTCA)
    assert ex.ste.mean() * 1e6 == pytest.approx(float(ds["ste_mean"][0]), rel=1e-9)
    assert np.ptp(ex.ste) * 1e6 == pytest.approx(float(ds["ste_ptp"][0]), rel=1e-9)
    assert ex.mean_stiffness / 1e6 == pytest.approx(float(ds["lpms_tangent_mean"][0]), rel=1e-6)
    # the crown takes load off the face ends: softer mesh, larger mean STE
    assert ex.ste.mean() > flat.ste.mean() + 0.1 * crowning * 1e-6
    assert ex.mean_stiffness < flat.mean_stiffness


def test_zero_crowning_is_bit_identical_to_no_crowning():
    """``lead_crowning=0`` takes the route without crowning: the same floats to the last bit
    as the LTCA of the sample's deviations without the parameter, and the same outputs as a
    run that does not name it."""
    from gearuq.gears.ltca import ltca_setup
    from gearuq.rotor.excitation import MeshExcitation
    from gearuq_plugins.geared_rotor.physics import compliance_model, sample_deviations

    rotor = gearuq.get_model("geared_rotor")
    a = rotor_excitation(rotor, 0.0).excitation
    pair = seed_pair()
    values = {p.name: p.nominal for p in rotor.parameters} | FLANK
    del values["lead_crowning"]
    setup = ltca_setup(pair, compliance=compliance_model(pair), **LTCA)
    b = MeshExcitation.from_setup(setup, FLANK["torque"],
                                  deviations=sample_deviations(pair, values))
    np.testing.assert_array_equal(a.ste, b.ste)
    np.testing.assert_array_equal(a.stiffness, b.stiffness)
    x = {"speed": [3000.0, 5000.0], "lead_crowning": [0.0, 0.0]}
    opts = {**LTCA, "n_mesh_harmonics": 2}
    with_zero = rotor.response(x, None, outputs=["dte_rms", "mesh_force_rms"], **opts)
    without = rotor.response({"speed": x["speed"]}, None, outputs=["dte_rms", "mesh_force_rms"],
                             **opts)
    for name in ("dte_rms", "mesh_force_rms"):
        np.testing.assert_array_equal(with_zero[name].values, without[name].values)


def test_a_stage_files_crowning_is_the_parameters_nominal():
    """A stage with 3 + 2 um of lead crowning: its rotor's nominal ``lead_crowning`` is 5 um,
    and its excitation equals the paper rotor's at ``lead_crowning=5`` (the paper's stage
    file rebuilds the paper's rotor bit for bit)."""
    paper = gearuq.GearStage.example("yuan_liu_liu")
    crowned = replace(paper, pinion=replace(paper.pinion, lead_crowning=3.0),
                      wheel=replace(paper.wheel, lead_crowning=2.0))
    on_stage = gearuq.get_model("geared_rotor", stage=crowned)
    assert {p.name: p for p in on_stage.parameters}["lead_crowning"].nominal == 5.0
    values = {p.name: p.nominal for p in on_stage.parameters} | FLANK
    ex_stage = problem_for(on_stage, values, on_stage.validate_options(
        {**LTCA, "n_mesh_harmonics": 2})).excitation
    ex_paper = rotor_excitation(gearuq.get_model("geared_rotor"), 5.0).excitation
    np.testing.assert_array_equal(ex_stage.ste, ex_paper.ste)
