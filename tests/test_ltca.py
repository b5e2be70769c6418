"""Tests of the LTCA (issue 5): contact lines, compliance, deviations, solver, seed 002 trends."""

from __future__ import annotations

import math

import numpy as np
import pytest

import gearuq
from gearuq.gears.compliance import ComplianceModel, kernel_cell_average, tooth_compliance
from gearuq.gears.contact import contact_grid, long_period_cycles
from gearuq.gears.deviations import (
    FlankDeviations,
    iso1328_pitch_tolerances,
    pitch_deviations_from_cumulative,
    random_cumulative_pitch_deviations,
)
from gearuq.gears.geometry import HelicalGearPair, seed002_pair
from gearuq.gears.iso6336 import mesh_stiffness
from gearuq.gears.ltca import (
    force_at_deflection,
    force_deflection,
    ltca,
    normal_force_from_torque,
    tip_relief_map,
)

DEG = math.pi / 180


@pytest.fixture(scope="module")
def pair():
    return seed002_pair()


@pytest.fixture(scope="module")
def comp(pair):
    return ComplianceModel(pair)


@pytest.fixture(scope="module")
def random_dev(pair):
    rng = np.random.default_rng(2020)
    return FlankDeviations(
        Fp1=random_cumulative_pitch_deviations(pair.z1, seed=rng),
        Fp2=random_cumulative_pitch_deviations(pair.z2, seed=rng),
    )


@pytest.fixture(scope="module")
def seed_runs(pair, comp, random_dev):
    """Long period at the seed's four torques plus 1500 N m (12 positions/cycle, 12 points)."""
    return {
        T: ltca(pair, torque=T, deviations=random_dev, compliance=comp,
                positions_per_cycle=12, n_pts=12)
        for T in (200.0, 350.0, 600.0, 1000.0, 1500.0)
    }


# ------------------------------------------------------------------ geometry of contact lines
def test_long_period_and_mean_contact_length(pair):
    assert long_period_cycles(pair) == 30
    assert long_period_cycles(HelicalGearPair(mn=2e-3, z1=20, z2=50, alpha_n=20 * DEG,
                                              beta=15 * DEG, b1=0.02, b2=0.02)) == 100
    tau = (np.arange(4000) + 0.5) / 4000
    g = contact_grid(pair, tau, n_pts=3)
    expected = pair.eps_alpha * pair.face_width / math.cos(pair.beta_b)
    assert g.length.mean() == pytest.approx(expected, rel=1e-6)
    assert g.length.min() == pytest.approx(pair.contact_line_length_min, rel=1e-3)
    # points lie on the lines s + y tan(beta_b) = c inside the zone
    assert np.all(g.s[g.valid] >= g.kin.s_A - 1e-12)
    assert np.all(g.s[g.valid] <= g.kin.s_E + 1e-12)
    assert np.all((g.y[g.valid] >= 0) & (g.y[g.valid] <= pair.face_width))
    c = g.s + g.y * g.kin.tan_bb
    assert np.allclose(np.ptp(c, axis=2)[g.valid], 0.0, atol=1e-15)
    # number of lines in contact is floor or ceil of eps_gamma
    n_lines = g.valid.sum(axis=1)
    assert set(np.unique(n_lines)) <= {math.floor(pair.eps_gamma), math.ceil(pair.eps_gamma)}


# ------------------------------------------------------------------ compliance model
def test_tooth_compliance_and_kernel(pair):
    t = tooth_compliance(pair, 1)
    assert np.all(t.total > 0)
    # compliance grows towards the tip (longer lever) over the active flank
    kin = contact_grid(pair, [0.0]).kin
    rho = np.linspace(kin.s_A, kin.s_E, 10)
    assert np.all(np.diff(t(rho)) > 0)
    # kernel with mirror images: rows of a uniformly loaded face integrate to 1 exactly
    b, n, lam = 0.04, 40, 6e-3
    lo = np.arange(n) * b / n
    y = lo + 0.5 * b / n
    K = kernel_cell_average(y[:, None], lo[None, :], lo[None, :] + b / n, lam, b)
    assert np.allclose(K @ np.full(n, b / n), 1.0, atol=2e-3)  # single images: 1e-3 level
    assert np.allclose(K, K.T)
    assert np.all(np.linalg.eigvalsh(K) > 0)


# ------------------------------------------------------------------ oracles
def test_constant_stiffness_oracle(pair):
    k = 1.4e10
    comp = ComplianceModel(pair, kind="constant", k_per_length=k)
    r = ltca(pair, normal_force=10e3, compliance=comp, positions_per_cycle=50, n_cycles=2)
    L = r["contact_length"].values * 1e-3
    assert np.allclose(r["ste"].values * 1e-6, 10e3 / (k * L), rtol=1e-12, atol=0)
    assert np.allclose(r["lpms"].values * 1e6, k * L, rtol=1e-12)
    assert np.allclose(r["cms"].values, 0.0)
    assert (r["contact_loss_fraction"] == 0).all()
    # spur limit: one or two full-width lines
    spur = HelicalGearPair(mn=6e-3, z1=30, z2=30, alpha_n=20 * DEG, beta=0.0, b1=0.04, b2=0.04)
    rs = ltca(spur, normal_force=1e3, compliance=ComplianceModel(spur, kind="constant"),
              positions_per_cycle=20, n_cycles=1)
    assert set(np.unique(np.round(rs["contact_length"].values, 9))) == {40.0, 80.0}


def test_light_load_tends_to_kinematic_te(pair, comp, random_dev):
    tau = np.linspace(0, 3, 18, endpoint=False)
    gaps = []
    for P in (1e2, 1.0, 1e-2):
        r = ltca(pair, normal_force=P, deviations=random_dev, compliance=comp, tau=tau, n_pts=8)
        gaps.append(np.abs(r["ste"] - r["kinematic_te"]).max().item())
    assert gaps[0] > gaps[1] > gaps[2]
    assert gaps[2] < 1e-3  # um, at 0.01 N


def test_uniform_pitch_error_shifts_ste_only(pair, comp):
    base = ltca(pair, torque=500, compliance=comp, n_cycles=2, n_pts=10)
    c = 7e-6
    dev = FlankDeviations(Fp1=np.full(pair.z1, c), Fp2=np.full(pair.z2, c))
    shifted = ltca(pair, torque=500, deviations=dev, compliance=comp, n_cycles=2, n_pts=10)
    shift = 2 * c * math.cos(pair.alpha_t) * math.cos(pair.beta_b) * 1e6
    assert np.allclose(shifted["ste"] - base["ste"], shift, rtol=0, atol=1e-9)
    assert np.allclose(shifted["lpms"], base["lpms"], rtol=1e-9)


def test_complementarity_exact(seed_runs):
    for T, r in seed_runs.items():
        assert int(r["status"].max()) == 0, T
        assert float(r["complementarity_residual"].max()) < 1e-10, T
        assert np.all(r["force"].values >= 0)
        assert np.nanmin(r["gap"].values) > -1e-10 * float(r["ste"].max())
        assert np.allclose(r["force"].sum(("line", "point")), r.attrs["normal_force_N"],
                           rtol=1e-12)


def test_discretisation_convergence_order(pair, comp, random_dev):
    tau = np.linspace(0, 2, 16, endpoint=False) + 0.013
    ste = {n: ltca(pair, torque=600, deviations=random_dev, compliance=comp, tau=tau,
                   n_pts=n)["ste"].values for n in (10, 20, 40, 80)}
    d1 = np.abs(ste[10] - ste[20]).max()
    d2 = np.abs(ste[20] - ste[40]).max()
    d3 = np.abs(ste[40] - ste[80]).max()
    order = [math.log2(d1 / d2), math.log2(d2 / d3)]
    assert d3 < 2e-3  # um
    assert min(order) > 1.5  # observed ~2 (midpoint rule on smooth kernels)


# ------------------------------------------------------------------ seed 002 trends
def test_seed_trends(seed_runs):
    loss = {T: r["partial_contact_loss"].groupby("mesh_cycle").any().values
            for T, r in seed_runs.items()}
    n_loss = {T: int(v.sum()) for T, v in loss.items()}
    assert n_loss[200.0] >= n_loss[350.0] >= n_loss[600.0] >= n_loss[1000.0]
    assert n_loss[200.0] >= 5 and n_loss[1000.0] == 0 and n_loss[1500.0] == 0
    # LPMS lower in the cycles with contact loss
    km200 = seed_runs[200.0]["lpms"].groupby("mesh_cycle").mean().values
    km1000 = seed_runs[1000.0]["lpms"].groupby("mesh_cycle").mean().values
    cyc = loss[200.0]
    assert (km200[cyc] / km1000[cyc]).mean() < 0.85 < (km200[~cyc] / km1000[~cyc]).mean()
    # STE: same shape, level rising with load
    s = {T: r["ste"].values for T, r in seed_runs.items()}
    assert s[200.0].mean() < s[350.0].mean() < s[600.0].mean() < s[1000.0].mean()
    assert np.corrcoef(s[600.0], s[1000.0])[0, 1] > 0.95
    # CMS load-independent once the contact is full
    cms = {T: r["cms"].values for T, r in seed_runs.items()}
    full = np.abs(cms[1000.0] - cms[1500.0]).max()
    light = np.abs(cms[200.0] - cms[1500.0]).max()
    assert full < 0.05 * np.ptp(cms[1500.0]) and light > 10 * full


def test_iso_ratio(pair, comp):
    r = ltca(pair, torque=1000, compliance=comp, n_cycles=1, positions_per_cycle=48)
    k_transverse = float(r["lpms"].mean()) * math.cos(pair.beta_b) ** 2 * 1e6
    ratio = k_transverse / mesh_stiffness(pair).k_mesh_N_per_m
    assert 0.75 < ratio < 1.25


# ------------------------------------------------------------------ deviations
def test_random_pitch_deviations():
    a = random_cumulative_pitch_deviations(30, seed=5)
    assert np.array_equal(a, random_cumulative_pitch_deviations(30, seed=5))
    assert not np.array_equal(a, random_cumulative_pitch_deviations(30, seed=6))
    f = pitch_deviations_from_cumulative(a)
    assert f.sum() == pytest.approx(0.0, abs=1e-18) and f[3] == a[3] - a[2]
    pure = random_cumulative_pitch_deviations(30, sigma=0.0, phase=0.0)
    assert np.ptp(pure) == pytest.approx(2 * 15e-6 * math.sin(2 * math.pi * 7 / 30), rel=1e-12)
    # large sample: scatter of the sine residual has sigma ~ 3 um
    z = 4000
    big = random_cumulative_pitch_deviations(z, seed=1, phase=0.0)
    resid = big - 15e-6 * np.sin(2 * np.pi * np.arange(z) / z)
    assert np.std(resid) == pytest.approx(3e-6, rel=0.05)
    f_pT, F_pT = iso1328_pitch_tolerances(0.1893, 6e-3, 5)
    assert f_pT * 1e6 == pytest.approx(0.001 * 189.3 + 2.4 + 5, rel=1e-9)
    assert F_pT * 1e6 == pytest.approx(0.002 * 189.3 + 0.55 * math.sqrt(189.3) + 4.2 + 12,
                                       rel=1e-9)
    iso = random_cumulative_pitch_deviations(30, seed=1, accuracy_grade=7, d=0.1893, mn=6e-3)
    assert np.abs(iso).max() < 1.5 * iso1328_pitch_tolerances(0.1893, 6e-3, 7)[1]


def test_tip_relief_map_and_force_deflection(pair, comp):
    m = tip_relief_map(pair, np.array([0.0, 15e-6, 28e-6]), np.array([4e-3, 13.5e-3]),
                       torque=1000, compliance=comp, positions_per_cycle=12, n_pts=10)
    assert m.attrs["optimum_ste_ptp_um"] < 0.3 * float(m["ste_ptp"][0].min())
    fd = force_deflection(pair, [500.0, 2000.0, 8000.0], compliance=comp, n_cycles=1,
                          positions_per_cycle=4, n_pts=10)
    F = force_at_deflection(fd, fd["ste"].values[1, 2])
    assert float(F[2, 0]) == pytest.approx(2000.0, rel=1e-9)
    assert np.all(np.diff(fd["ste"].values, axis=0) > 0)


def test_netcdf_roundtrip(tmp_path, pair, comp, random_dev):
    r = ltca(pair, torque=350, deviations=random_dev, compliance=comp, n_cycles=2, n_pts=6)
    back = gearuq.load(gearuq.save(r, tmp_path / "ltca.nc"))
    assert np.allclose(back["ste"], r["ste"]) and back["ste"].attrs["units"] == "um"


# ------------------------------------------------------------------ bad input
def test_bad_input(pair):
    with pytest.raises(ValueError, match="x1.*undercut"):
        HelicalGearPair(mn=6e-3, z1=8, z2=30, alpha_n=20 * DEG, beta=18 * DEG, b1=0.04,
                        b2=0.04)
    with pytest.raises(ValueError, match="eps_alpha"):
        HelicalGearPair(mn=6e-3, z1=30, z2=30, alpha_n=20 * DEG, beta=18 * DEG, b1=0.04,
                        b2=0.04, ha_star=0.5)
    with pytest.raises(ValueError, match="b1=-0.04"):
        HelicalGearPair(mn=6e-3, z1=30, z2=30, alpha_n=20 * DEG, beta=18 * DEG, b1=-0.04,
                        b2=0.04)
    for bad in (0.0, -5.0, float("nan")):
        with pytest.raises(ValueError, match=r"torque=.*valid range \(0, inf\)"):
            ltca(pair, torque=bad)
        with pytest.raises(ValueError, match="normal_force="):
            ltca(pair, normal_force=bad)
    with pytest.raises(ValueError, match="exactly one"):
        ltca(pair)
    with pytest.raises(ValueError, match=r"Fp1 has shape \(29,\), valid: \(30,\)"):
        ltca(pair, torque=100, deviations=FlankDeviations(Fp1=np.zeros(29)))
    with pytest.raises(ValueError, match="Fp2"):
        ltca(pair, torque=100, deviations=FlankDeviations(Fp2=np.zeros((30, 2))))
    with pytest.raises(ValueError, match="tip_relief1 length"):
        ltca(pair, torque=100, deviations=FlankDeviations(tip_relief1=(1e-5, 1.0)))
    with pytest.raises(ValueError, match="n_pts=0"):
        ltca(pair, torque=100, n_pts=0)
    with pytest.raises(ValueError, match="coupling_length"):
        ComplianceModel(pair, coupling_length=-1.0)
    with pytest.raises(ValueError, match="z=3"):
        random_cumulative_pitch_deviations(3)
    with pytest.raises(ValueError, match="accuracy_grade=12"):
        iso1328_pitch_tolerances(0.1, 6e-3, 12)
    assert normal_force_from_torque(pair, 1000) == pytest.approx(
        1000 / (pair.db1 / 2 * math.cos(pair.beta_b)))
