"""Tests of the long-period LTCA from the line-load table (issue 27, part 1).

The reference is the full LTCA (:func:`gearuq.gears.ltca.ltca`), which solves every position of
the long period with all its lines coupled; the table route solves each line geometry alone
and assembles the long period from the tabulated curves. Tolerances are those documented in
docs/theory/ltca.md, Sec. 10, with a margin over the measured errors.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearuq.gears.deviations import FlankDeviations, random_cumulative_pitch_deviations
from gearuq.gears.geometry import HelicalGearPair, seed002_pair
from gearuq.gears.long_period import (
    LongPeriodSettings,
    line_load_table,
    long_period_ltca,
    pitch_separations,
)
from gearuq.gears.ltca import ltca, normal_force_from_torque

DEG = math.pi / 180


def grade6_deviations(pair: HelicalGearPair, relief: tuple[float, float], seed: int):
    rng = np.random.default_rng(seed)
    fp = [random_cumulative_pitch_deviations(z, seed=rng, accuracy_grade=6, d=d, mn=pair.mn)
          for z, d in ((pair.z1, pair.d1), (pair.z2, pair.d2))]
    return FlankDeviations.symmetric_tip_relief(*relief, Fp1=fp[0], Fp2=fp[1])


@pytest.fixture(scope="module")
def hunting():
    """13/17 pair (lcm 221, coprime), grade-6 pitch deviations, tip relief, 150 N m."""
    pair = HelicalGearPair(mn=3e-3, z1=13, z2=17, alpha_n=20 * DEG, beta=20 * DEG,
                           b1=30e-3, b2=30e-3, x1=0.2, x2=0.0)
    dev = grade6_deviations(pair, (8e-6, 3e-3), seed=3)
    torque = 150.0
    full = ltca(pair, torque=torque, deviations=dev, keep_points=True)
    return pair, dev, torque, full


def _ptp(ds):
    return float(ds["ste"].max() - ds["ste"].min())


def _check_against_full(fast, full, *, ptp_rel, mean_rel, ste_um, point_rel):
    assert int(fast["status"].max()) == 0
    assert fast.sizes["position"] == full.sizes["position"]
    np.testing.assert_allclose(fast["tau"], full["tau"], atol=1e-12)
    assert abs(_ptp(fast) / _ptp(full) - 1.0) < ptp_rel
    for v in ("lpms", "lpms_tangent"):
        assert abs(float(fast[v].mean() / full[v].mean()) - 1.0) < mean_rel, v
        rel = np.abs(fast[v] - full[v]) / full[v]
        assert float(rel.max()) < point_rel, v
    assert float(np.abs(fast["ste"] - full["ste"]).max()) < ste_um
    # the no-load kinematic TE is exact (no interpolation enters it)
    np.testing.assert_allclose(fast["kinematic_te"], full["kinematic_te"], atol=1e-9)
    np.testing.assert_allclose(fast["contact_length"], full["contact_length"], rtol=1e-12)


def test_table_route_equals_full_long_period_on_coprime_pair(hunting):
    pair, dev, torque, full = hunting
    assert math.lcm(pair.z1, pair.z2) == 221
    table = line_load_table(pair, max_torque=torque, modifications=dev)
    fast = long_period_ltca(pair, dev, torque=torque, table=table)
    _check_against_full(fast, full, ptp_rel=1e-4, mean_rel=1e-3, ste_um=0.01, point_rel=0.02)
    # the pitch deviations matter: the STE p-p is far above the error-free one
    smooth = long_period_ltca(pair, dev.design_only(), torque=torque, table=table, n_cycles=1)
    assert _ptp(full) > 5 * _ptp(smooth)
    # independent of the decomposition: each tooth pair's load equals the full LTCA's sum of
    # its point forces, and the loads add up to the mesh force
    full_lines = full["force"].sum("point").values
    P = normal_force_from_torque(pair, torque)
    assert np.abs(fast["line_load"].values - full_lines).max() < 1e-3 * P
    np.testing.assert_allclose(fast["line_load"].sum("line"), P, rtol=1e-12)
    np.testing.assert_array_equal(fast["pinion_tooth"].values[fast["valid"].values],
                                  full["pinion_tooth"].values[full["valid"].values])
    # contact pattern: the teeth in contact agree; loaded length within two segments (a
    # boundary point of the pattern can carry 1e-5 of the load, docs Sec. 10)
    assert (fast["n_teeth_in_contact"].values == full["n_teeth_in_contact"].values).mean() > 0.999
    seg = float(table.segment.max()) * 1e3
    assert float(np.abs(fast["loaded_length"] - full["loaded_length"]).max()) < 2.5 * seg
    flags = fast["partial_contact_loss"].values != full["partial_contact_loss"].values
    assert flags.mean() < 0.01


def test_error_falls_with_load_nodes(hunting):
    pair, dev, torque, full = hunting
    errs = []
    for n in (12, 48):
        fast = long_period_ltca(pair, dev, torque=torque,
                                settings=LongPeriodSettings(n_load_nodes=n))
        errs.append(abs(float(fast["lpms"].mean() / full["lpms"].mean()) - 1.0))
    # second order in the node spacing between active-set changes: 16x for 4x the nodes
    assert errs[1] < errs[0] / 4


def test_common_factor_pair_reproduces_full_ltca():
    """30/30 (Yuan, Liu and Liu's pair): the table route reproduces today's full LTCA."""
    pair = seed002_pair()
    dev = FlankDeviations.symmetric_tip_relief(
        20e-6, 10e-3, Fp1=random_cumulative_pitch_deviations(30, seed=1),
        Fp2=random_cumulative_pitch_deviations(30, seed=2))
    full = ltca(pair, torque=600.0, deviations=dev, positions_per_cycle=12, n_pts=10,
                keep_points=False)
    fast = long_period_ltca(pair, dev, torque=600.0,
                            settings=LongPeriodSettings(positions_per_cycle=12, n_pts=10))
    _check_against_full(fast, full, ptp_rel=1e-4, mean_rel=1e-3, ste_um=0.02, point_rel=0.03)


def test_one_table_serves_lower_loads_and_uniform_shift_oracle(hunting):
    pair, dev, torque, _ = hunting
    table = line_load_table(pair, max_torque=2 * torque, modifications=dev)
    full = ltca(pair, torque=torque, deviations=dev, n_cycles=20, keep_points=False)
    fast = long_period_ltca(pair, dev, torque=torque, table=table, n_cycles=20)
    _check_against_full(fast, full, ptp_rel=1e-3, mean_rel=1e-3, ste_um=0.01, point_rel=0.02)
    # a uniform pitch deviation of the wheel turns it rigidly: STE shifts by its normal
    # projection (Yuan et al. Eq. 2), stiffness and pattern stay
    c = 7e-6
    shifted = FlankDeviations(Fp1=dev.Fp1, Fp2=np.asarray(dev.Fp2) + c,
                              tip_relief1=dev.tip_relief1, tip_relief2=dev.tip_relief2)
    moved = long_period_ltca(pair, shifted, torque=torque, table=table, n_cycles=20)
    shift_um = c * math.cos(pair.alpha_t) * math.cos(pair.beta_b) * 1e6
    np.testing.assert_allclose(moved["ste"] - fast["ste"], shift_um, atol=1e-9)
    np.testing.assert_allclose(moved["lpms"], fast["lpms"], rtol=1e-9)


def test_pitch_separations_follow_tooth_pairing():
    pair = seed002_pair()
    fp1 = np.arange(30) * 1e-6
    fp2 = np.arange(30)[::-1] * 2e-6
    sep = pitch_separations(pair, FlankDeviations(Fp1=fp1, Fp2=fp2), n_cycles=35, n_lines=3)
    conv = math.cos(pair.alpha_t) * math.cos(pair.beta_b)
    m, a = 33, 2  # slot 2 of cycle 33 is tooth pair 31: pinion tooth 1, wheel tooth 1
    assert sep[m, a] == pytest.approx((fp1[1] + fp2[1]) * conv, rel=1e-14)
    assert np.all(pitch_separations(pair, None, 4, 3) == 0.0)


def test_netcdf_roundtrip(tmp_path, hunting):
    import xarray as xr

    pair, dev, torque, _ = hunting
    ds = long_period_ltca(pair, dev, torque=torque, n_cycles=3,
                          settings=LongPeriodSettings(n_load_nodes=8))
    path = tmp_path / "lp.nc"
    ds.to_netcdf(path)
    back = xr.open_dataset(path)
    xr.testing.assert_allclose(back.load(), ds)
    assert back["ste"].attrs["units"] == "um" and back.attrs["setting_n_load_nodes"] == 8


def test_bad_input(hunting):
    pair, dev, torque, _ = hunting
    with pytest.raises(ValueError, match="n_load_nodes=3"):
        LongPeriodSettings(n_load_nodes=3)
    with pytest.raises(ValueError, match="min_load_fraction=0.5"):
        LongPeriodSettings(min_load_fraction=0.5)
    with pytest.raises(ValueError, match="exactly one"):
        long_period_ltca(pair, dev)
    table = line_load_table(pair, max_torque=torque, modifications=dev,
                            settings=LongPeriodSettings(n_load_nodes=6, n_pts=4))
    with pytest.raises(ValueError, match="normal_force=.*valid range"):
        long_period_ltca(pair, dev, torque=2 * torque, table=table)
    with pytest.raises(ValueError, match="designed modifications"):
        long_period_ltca(pair, FlankDeviations(Fp1=dev.Fp1), torque=torque, table=table)
    with pytest.raises(ValueError, match="deviations.user"):
        long_period_ltca(pair, FlankDeviations(user=lambda s, y, k1, k2: 0 * s), torque=torque)
    with pytest.raises(ValueError, match="n_cycles=0"):
        long_period_ltca(pair, dev, torque=torque, table=table, n_cycles=0)
    with pytest.raises(ValueError, match="Fp1 has shape"):
        long_period_ltca(pair, FlankDeviations(Fp1=np.zeros(5), tip_relief1=dev.tip_relief1,
                                               tip_relief2=dev.tip_relief2),
                         torque=torque, table=table)


@pytest.mark.e2e
def test_eaxle_27_79_within_one_percent_and_far_cheaper():
    """Issue 27's target pair (lcm 2133): STE p-p and mean mesh stiffness within 1 % of the
    full LTCA; one sample from the table costs a small fraction of the full long period
    (CPU ratio measured side by side; docs/benchmarks.md has the times)."""
    import time

    pair = HelicalGearPair(mn=2e-3, z1=27, z2=79, alpha_n=20 * DEG, beta=22 * DEG,
                           b1=30e-3, b2=28e-3, x1=0.3, x2=-0.2)
    dev = grade6_deviations(pair, (8e-6, 2e-3), seed=0)
    table = line_load_table(pair, max_torque=150.0, modifications=dev)
    long_period_ltca(pair, dev, torque=150.0, table=table, n_cycles=1)  # compiled
    t0 = time.process_time()
    fast = long_period_ltca(pair, dev, torque=150.0, table=table)
    t_fast = time.process_time() - t0
    t0 = time.process_time()
    full = ltca(pair, torque=150.0, deviations=dev, keep_points=False)
    t_full = time.process_time() - t0
    assert full.sizes["position"] == 2133 * 24
    _check_against_full(fast, full, ptp_rel=0.01, mean_rel=0.01, ste_um=0.01, point_rel=0.03)
    assert t_fast < t_full / 10
