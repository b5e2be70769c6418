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
