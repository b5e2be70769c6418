"""Gear models built from a stage: the papers' files give today's results bit for bit, and a
stage that is not the paper's gives its own masses, supports and mesh stiffness."""

from __future__ import annotations

import math

import numpy as np
import pytest

import gearuq
from gearuq.gears.stage import GearStage, stage_mesh_stiffness


@pytest.fixture(scope="module")
def e_axle() -> GearStage:
    return GearStage.example("e_axle_27_79")


def _same_dataset(a, b) -> None:
    for name in a.data_vars:
        if np.issubdtype(a[name].dtype, np.number):
            np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)


def test_helical_pair_paper_stage_is_bit_identical():
    today = gearuq.get_model("helical_pair")
    staged = gearuq.get_model("helical_pair", stage=GearStage.example("li_hu_han"))
    assert staged.parameters == today.parameters and staged.stiffness_factor == 1.0
    t = np.linspace(0.0, 20.0, 11)
    params = {"n": np.array([3600.0, 4000.0])}
    out = ["p1", "p5", "dp5", "k_mesh"]
    _same_dataset(today.response(params, t, outputs=out), staged.response(params, t, outputs=out))


def test_mesh_excitation_paper_stage_is_bit_identical():
    today = gearuq.get_model("mesh_excitation")
    staged = gearuq.get_model("mesh_excitation", stage=GearStage.example("yuan_liu_liu"))
    assert staged.pair == today.pair
    assert staged.settings() == today.settings() | {"stage": staged.stage.to_dict()}
    params = {"torque": np.array([800.0]), "pitch_xi_p_1": np.array([0.7])}
    opts = dict(positions_per_cycle=8, n_pts=6, threads=1)
    out = ["ste_ptp", "lpms_tangent_mean", "cms_ptp"]
    _same_dataset(today.response(params, None, outputs=out, **opts),
                  staged.response(params, None, outputs=out, **opts))


def test_helical_pair_from_a_stage_takes_its_masses_supports_and_stiffness(e_axle):
    model = gearuq.get_model("helical_pair", stage=e_axle)
    nominal = {p.name: p.nominal for p in model.parameters}
    # masses: solid cylinders of the reference diameters (written here, ISO 21771 d = z mn/cos b)
    d1 = 27 * 2.0 / math.cos(math.radians(22.0)) * 1e-3
    gear = model.gear_data({k: np.array([float(v)]) for k, v in nominal.items()})
    assert gear["m_p"][0] == pytest.approx(7850 * math.pi * (d1 / 2) ** 2 * 0.030, rel=1e-12)
    # the mesh stiffness is the stage's (LTCA mean tangent), not ISO 6336-1's
    mesh = stage_mesh_stiffness(e_axle)
    assert gear["k_mesh"][0] == pytest.approx(mesh.value * 1e6, rel=1e-14)
    assert gear["k_mesh"][0] != pytest.approx(mesh.iso_c_gamma_b * 1e6, rel=0.1)
    # per-shaft supports: pinion bearings 90 mm apart, wheel 110 mm, sums of the bearings
    assert nominal["k_r"] == 600e6 and nominal["span"] == 0.045
    assert nominal["k_r_wheel"] == 800e6 and nominal["span_wheel"] == 0.055
    assert nominal["k_a"] == 150e6 and nominal["k_a_wheel"] == 200e6
    assert nominal["b5"] == 30e-6 and nominal["T"] == 250.0 and nominal["n"] == 16000.0


def test_helical_pair_wheel_support_enters_the_equations(e_axle):
    """The wheel's radial support: static radial deflection of the wheel = F_r / k_r_wheel."""
    model = gearuq.get_model("helical_pair", stage=e_axle)
    params = {"k_r_wheel": np.array([800e6, 400e6])}
    coef, _ = model.coefficients(model.validate_params(params))
    q = model.static_state(coef)
    # radial force on each support is the same mesh force: halving k doubles the deflection
    assert q[1, 5] == pytest.approx(2.0 * q[0, 5], rel=1e-9)
    assert q[1, 0] == pytest.approx(q[0, 0], rel=1e-9)  # the pinion's support is untouched


def test_mesh_oscillator_from_a_stage_uses_the_stage_ltca(e_axle):
    model = gearuq.get_model("mesh_oscillator", stage=e_axle)
    nominal = {p.name: p.nominal for p in model.parameters}
    from gearuq.gears.ltca import normal_force_from_torque

    assert nominal["mean_force"] == normal_force_from_torque(e_axle.pair, 250.0)
    # equivalent mass along the line of action, written here from the gear bodies
    p = e_axle.pair
    inertia = [0.5 * 7850 * math.pi * (d / 2) ** 4 * b for d, b in ((p.d1, 0.030),
                                                                    (p.d2, 0.028))]
    inv = math.cos(p.beta_b) ** 2 * ((p.db1 / 2) ** 2 / inertia[0] + (p.db2 / 2) ** 2 /
                                     inertia[1])
    assert nominal["mass"] == pytest.approx(1.0 / inv, rel=1e-12)
    # the table's tangent stiffness at the design load, averaged over the cycle, is the
    # stage's mesh stiffness (32 vs 24 positions: within 1 %)
    force = model.force
    mean_at = np.interp(nominal["mean_force"], force.loads, force.tangent_stiffness.mean(axis=1))
    assert mean_at / 1e6 == pytest.approx(stage_mesh_stiffness(e_axle).tangent_mean, rel=0.02)


def test_mesh_excitation_from_a_stage_takes_per_gear_classes_and_linear_relief(e_axle):
    model = gearuq.get_model("mesh_excitation", stage=e_axle)
    names = {p.name: p for p in model.parameters}
    assert names["iso_grade"].nominal == 6 and names["iso_grade_wheel"].nominal == 7
    assert names["pinion_tip_relief_amount"].nominal == 8.0
    assert "linear" in names["wheel_tip_relief_amount"].description
    assert model.pair == e_axle.pair
    # the relief map the samples use is the stage's, with the sampled amount
    values = {"pinion_tip_relief_amount": 4.0, "wheel_tip_relief_amount": 8.0}
    clearance = model.stage_relief(values)
    p = e_axle.pair
    s_tip = np.array([(p.g_f1 + p.g_alpha)])  # pinion tip, m
    got = clearance(s_tip, np.zeros(1), np.zeros(1, int), np.zeros(1, int))[0]
    assert got == pytest.approx(4.0e-6 * math.cos(p.beta_b), rel=1e-9)


def test_mesh_excitation_refuses_measured_pitch_deviations():
    from dataclasses import replace

    stage = GearStage.example("yuan_liu_liu")
    spd = tuple(math.sin(2 * math.pi * k / 30) for k in range(30))
    bad = replace(stage, pinion=replace(stage.pinion, single_pitch_deviations=spd))
    with pytest.raises(ValueError, match=r"\[pinion\] single_pitch_deviations is not taken"):
        gearuq.get_model("mesh_excitation", stage=bad)
    with pytest.raises(ValueError, match="not both"):
        gearuq.get_model("mesh_excitation", stage=stage, pair=stage.pair)
    with pytest.raises(TypeError, match="must be a gearuq.GearStage"):
        gearuq.get_model("helical_pair", stage="e_axle.toml")


def test_geared_rotor_paper_stage_is_bit_identical():
    today = gearuq.get_model("geared_rotor")
    staged = gearuq.get_model("geared_rotor", stage=GearStage.example("yuan_liu_liu"))
    assert [p.name for p in staged.parameters] == [p.name for p in today.parameters]
    assert [p.nominal for p in staged.parameters] == [p.nominal for p in today.parameters]
    opts = dict(positions_per_cycle=8, n_pts=6, n_mesh_harmonics=2)
    params = {"torque": np.array([900.0]), "speed": np.array([3000.0]),
              "pitch_xi_g_3": np.array([0.5])}
    out = ["dte_rms", "mesh_force_rms", "dte_mean", "bearing1_acceleration_y_rms"]
    _same_dataset(today.response(params, None, outputs=out, **opts),
                  staged.response(params, None, outputs=out, **opts))


def _stage_26_78():
    from dataclasses import replace

    from gearuq.gears.stage import Bearing

    e = GearStage.example("e_axle_27_79")
    b = Bearing(0.0, 400.0, 150.0, damping=200.0)
    shafts = {name: replace(getattr(e, name), bearings=tuple(
        replace(b, position=x.position) for x in getattr(e, name).bearings))
        for name in ("pinion_shaft", "wheel_shaft")}
    return replace(e, teeth=(26, 78), pinion=replace(e.pinion, tip_relief=None),
                   wheel=replace(e.wheel, iso_grade=6, tip_relief=None), name="e_26_78",
                   **shafts)


def test_geared_rotor_from_a_stage_that_is_not_the_paper():
    stage = _stage_26_78()
    model = gearuq.get_model("geared_rotor", stage=stage)
    names = model.parameter_names
    assert "pitch_xi_g_77" in names and "pitch_xi_p_25" in names and "pitch_xi_p_26" not in names
    nominal = {p.name: p.nominal for p in model.parameters}
    assert nominal["bearing_stiffness"] == 400e6 and nominal["load_inertia"] == 0.2
    assert set(model.default_space().names) <= set(names)
    ds = model.response({"speed": np.array([6000.0])}, None,
                        outputs=["mesh_frequency", "ste_ptp", "dte_rms"],
                        positions_per_cycle=8, n_pts=6, n_mesh_harmonics=2)
    assert int(ds["status"][0]) == 0
    assert ds["mesh_frequency"].item() == 26 * 6000.0 / 60.0
    assert ds.attrs["long_period_mesh_cycles"] == 78
    assert 0 < ds["dte_rms"].item() < 1e-5 and np.isfinite(ds["ste_ptp"].item())


def test_geared_rotor_takes_the_e_axle_stage(e_axle):
    # its long period (tests/test_hunting.py), bearings, classes and linear reliefs
    # (tests/test_stage_rotor_e_axle.py); one stage taken only with two bearings per shaft
    from dataclasses import replace

    model = gearuq.get_model("geared_rotor", stage=e_axle)
    assert {"iso_grade_wheel", "bearing_stiffness_scale", "pinion_tip_relief_amount",
            "wheel_tip_relief_amount"} <= set(model.parameter_names)
    shaft = e_axle.pinion_shaft
    three = replace(e_axle, pinion_shaft=replace(shaft, bearings=shaft.bearings + (
        replace(shaft.bearings[0], position=100.0),)))
    with pytest.raises(ValueError, match=r"\[pinion_shaft\] needs exactly two bearings"):
        gearuq.get_model("geared_rotor", stage=three)


def test_pair_link_from_a_stage(e_axle):
    link = gearuq.get_link("helical_pair", "mesh_oscillator", stage=e_axle)
    assert link.high.stage is e_axle
    from gearuq_plugins.links.helical_pair import oscillator_inputs

    params = link.high.validate_params({})
    _, scales = oscillator_inputs(link.high, params, "mesh_line")
    assert scales["k"][0] == pytest.approx(stage_mesh_stiffness(e_axle).value * 1e6,
                                           rel=1e-14)


@pytest.mark.e2e
@pytest.mark.parametrize("name, t, options", [
    ("helical_pair", np.linspace(0.0, 5.0, 4), {}),
    ("mesh_oscillator", None, {"n_frequencies": 5}),
    ("mesh_excitation", np.array([0.0, 0.5]), {"positions_per_cycle": 4, "n_pts": 3,
                                               "n_mesh_orders": 1, "n_sidebands": 1,
                                               "threads": 1}),
])
def test_models_built_from_a_stage_honour_the_contract(e_axle, name, t, options):
    from gearuq.testing import check_model

    check_model(gearuq.get_model(name, stage=e_axle), t, options=options, n_samples=2)
