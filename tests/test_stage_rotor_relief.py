"""The geared rotor's tip relief shapes: the rotor's LTCA with a linear (or arc) relief is
``mesh_excitation``'s LTCA with the same relief given as a stage's drawing."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import gearuq
from gearuq.gears.stage import GearStage, Relief

_LTCA = dict(positions_per_cycle=8, n_pts=6)


def _paper_with_tip_relief(shape: str, amount: float, length: float) -> GearStage:
    """Yuan, Liu and Liu's stage with the same tip relief on both gears, stated as a drawing
    does: its start as a roll length from the base-circle tangency point."""
    stage = GearStage.example("yuan_liu_liu")
    p = stage.pair
    gears = {}
    for gear, g_f in (("pinion", p.g_f1), ("wheel", p.g_f2)):
        start = (g_f + p.g_alpha) * 1e3 - length  # tip roll length minus the relief length
        gears[gear] = replace(getattr(stage, gear), tip_relief=Relief(
            shape, amount, start_roll_length=start))
    return replace(stage, **gears)


@pytest.mark.parametrize("shape", ["linear", "arc"])
def test_rotor_tip_relief_shape_equals_mesh_excitation_relief(shape):
    amount, length = 20.0, 8.0
    rotor = gearuq.get_model("geared_rotor")
    stage = _paper_with_tip_relief(shape, amount, length)
    assert stage.relief_length("pinion", "tip") == pytest.approx(length, abs=1e-9)
    assert stage.relief_length("wheel", "tip") == pytest.approx(length, abs=1e-9)
    excitation = gearuq.get_model("mesh_excitation", stage=stage,
                                  bore_ratio=0.110 / stage.pair.df1)
    torque = 800.0
    # no pitch deviations: the germ at zero (the default) and zero scale in both models
    common = {"torque": torque, "pitch_amplitude": 0.0, "pitch_sigma": 0.0}
    problem = rotor.rotor_problem(common | {"tip_relief_amount": amount,
                                            "tip_relief_length": length},
                                  tip_relief_shape=shape, **_LTCA)
    ste_rotor = problem.excitation.ste * 1e6  # um
    tau = problem.excitation.tau
    ds = excitation.response({k: np.array([v]) for k, v in common.items()}, tau,
                             outputs=["ste", "lpms_tangent_mean"], threads=1, **_LTCA)
    assert int(ds["status"][0]) == 0
    np.testing.assert_allclose(ste_rotor, ds["ste"].values[0], rtol=1e-9, atol=1e-9)
    assert problem.excitation.mean_stiffness / 1e6 == pytest.approx(
        ds["lpms_tangent_mean"].item(), rel=1e-6)
    # the shape matters: a linear relief is not the parabola of the same amount and length
    # (an arc of C << L is: R - sqrt(R^2 - v^2) = C (v / L)^2 (1 + O(C^2 / L^2)))
    parabolic = rotor.rotor_problem(common | {"tip_relief_amount": amount,
                                              "tip_relief_length": length}, **_LTCA)
    gap = np.max(np.abs(parabolic.excitation.ste * 1e6 - ste_rotor))
    assert gap > 0.05 if shape == "linear" else gap < 1e-3


def test_parabolic_shape_through_the_relief_map_equals_the_built_in_relief():
    """The map's parabola (the stage's Relief.profile) against the LTCA's own Eq. 12."""
    from gearuq.gears.contact import MeshKinematics
    from gearuq.gears.deviations import FlankDeviations
    from gearuq_plugins.geared_rotor.physics import SharedTipRelief

    pair = GearStage.example("yuan_liu_liu").pair
    kin = MeshKinematics.of(pair)
    s = np.linspace(kin.s_A - 1e-3, kin.s_E + 1e-3, 401)
    zeros = np.zeros_like(s)
    idx = np.zeros(s.shape, dtype=int)
    built_in = FlankDeviations.symmetric_tip_relief(15e-6, 6e-3).clearance(
        pair, kin, s, zeros, idx, idx)
    mapped = SharedTipRelief(pair, "parabolic", 15.0, 6.0)(s, zeros, idx, idx)
    np.testing.assert_allclose(mapped, built_in, rtol=1e-9, atol=1e-15)
    # the linear relief: amount at each end of the path, half of it half-way along
    linear = SharedTipRelief(pair, "linear", 15.0, 6.0)
    at = np.array([kin.s_E, kin.s_E - 3e-3, kin.s_A, kin.s_A + 3e-3, kin.s_A + 7e-3])
    got = linear(at, np.zeros(5), np.zeros(5, int), np.zeros(5, int)) / kin.cos_bb
    np.testing.assert_allclose(got, [15e-6, 7.5e-6, 15e-6, 7.5e-6, 0.0], rtol=1e-9,
                               atol=1e-15)


def test_tip_relief_shape_is_a_checked_option():
    rotor = gearuq.get_model("geared_rotor")
    with pytest.raises(ValueError, match="tip_relief_shape"):
        rotor.validate_options({"tip_relief_shape": "cubic"})
