"""Tests of the ``mesh_excitation`` plugin (issue 10): contract, oracles, reproducibility."""

from __future__ import annotations

import math

import numpy as np
import pytest

import gearuq
from gearuq.gears.deviations import (
    FlankDeviations,
    cumulative_pitch_from_germ,
    pitch_deviation_germ,
    random_cumulative_pitch_deviations,
)
from gearuq.gears.geometry import seed002_pair
from gearuq.gears.ltca import ltca
from gearuq.testing import check_model
from gearuq_plugins.mesh_excitation import MeshExcitation
from gearuq_plugins.mesh_excitation.physics import (
    order_amplitudes,
    order_table,
    sample_deviations,
)

COARSE = {"positions_per_cycle": 8, "n_pts": 8}
ERROR_FREE = {"pitch_amplitude": 0.0, "pitch_sigma": 0.0}


@pytest.fixture(scope="module")
def model():
    return MeshExcitation()


def test_conformance(model):
    ds = check_model(model, np.linspace(0.0, 1.0, 5), options=COARSE)
    assert ds["ste_spectrum"].dims == ("sample", "order")
    assert list(ds["order_label"].values[:4]) == ["1fs", "2fs", "3fs", "1fm-3fs"]
    assert ds["order"].attrs["units"] == "mesh orders"
    # the tangent stiffness is 3-5 % above the secant one of seed Eq. 4 (Weber's law)
    ratio = ds["lpms_tangent_mean"] / ds["lpms_mean"]
    assert np.all((ratio > 1.02) & (ratio < 1.06))


def test_error_free_flank_gives_error_free_ste(model):
    pair = seed002_pair()
    tau = np.arange(48) / 24.0
    r = model.response({"torque": [750.0], **ERROR_FREE}, tau)
    ref = ltca(pair, torque=750.0, tau=tau, n_pts=20)
    np.testing.assert_allclose(r["ste"].values[0], ref["ste"].values, rtol=1e-10)
    np.testing.assert_allclose(r["lpms_tangent"].values[0], ref["lpms_tangent"].values,
                               rtol=1e-10)
    np.testing.assert_allclose(r["cms"].values[0], 0.0, atol=1e-12)
    # periodic with the mesh cycle: no shaft orders, no sidebands, only mesh orders
    spec = r["ste_spectrum"].isel(sample=0)
    mesh = np.array([lab.endswith("fm") for lab in r["order_label"].values])
    assert float(spec[~mesh].max()) < 1e-9 * float(spec[mesh].max())
    assert float(r["contact_loss_fraction"][0]) == 0.0


def test_off_grid_instants_are_solved_exactly(model):
    tau = np.array([0.013, 7.5, 29.99, 31.2])  # 31.2 wraps to 1.2 (long period: 30 cycles)
    r = model.response({"torque": [400.0]}, tau, outputs=["ste", "lpms"],
                       pitch_model="seeded")
    pair = seed002_pair()
    rng = np.random.default_rng(2020)
    dev = FlankDeviations(Fp1=random_cumulative_pitch_deviations(30, seed=rng),
                          Fp2=random_cumulative_pitch_deviations(30, seed=rng))
    ref = ltca(pair, torque=400.0, deviations=dev, tau=np.mod(tau, 30.0), n_pts=20)
    np.testing.assert_allclose(r["ste"].values[0], ref["ste"].values, rtol=1e-10)
    np.testing.assert_allclose(r["lpms"].values[0], ref["lpms"].values, rtol=1e-10)


def test_pitch_seed_reproduces_the_realisation(model):
    pair = seed002_pair()
    values = {"pitch_seed": 2020.7, "iso_grade": 0, "pitch_amplitude": 15.0,
              "pitch_sigma": 3.0, "tip_relief_amount": 0.0, "tip_relief_length": 0.0,
              "root_relief_amount": 0.0, "root_relief_length": 0.0, "crowning": 0.0}
    dev = sample_deviations(pair, values, "sine", "seeded")
    rng = np.random.default_rng(2020)  # the integer part selects the realisation
    np.testing.assert_array_equal(dev.Fp1, random_cumulative_pitch_deviations(30, seed=rng))
    np.testing.assert_array_equal(dev.Fp2, random_cumulative_pitch_deviations(30, seed=rng))
    # the scatter only scales the germ: sigma 6 um doubles the scatter part
    doubled = sample_deviations(pair, {**values, "pitch_sigma": 6.0}, "sine", "seeded")
    ph1, n1, _, _ = pitch_deviation_germ(30, 30, 2020)
    wave = 15e-6 * np.sin(2 * np.pi * np.arange(30) / 30 + ph1)
    np.testing.assert_allclose(doubled.Fp1 - wave, 2 * (dev.Fp1 - wave), rtol=1e-12,
                               atol=1e-20)
    # "largest" reading: the largest cumulative deviation is the amplitude
    largest = sample_deviations(pair, values, "largest", "seeded")
    assert np.abs(largest.Fp1).max() == pytest.approx(15e-6, rel=1e-12)
    assert np.abs(dev.Fp1).max() > 15e-6  # the sine reading exceeds it
    # ISO 1328 grade 5 on Yuan, Liu and Liu's pair: sine amplitude F_pT / 2
    iso = sample_deviations(pair, {**values, "iso_grade": 5, "pitch_sigma": 0.0}, "sine", "seeded")
    d_mm = pair.d1 * 1e3
    F_pT = (0.002 * d_mm + 0.55 * math.sqrt(d_mm) + 0.7 * 6.0 + 12.0) * 1e-6
    f_pT = (0.001 * d_mm + 0.4 * 6.0 + 5.0) * 1e-6
    expect = cumulative_pitch_from_germ(ph1, n1, amplitude=F_pT / 2,
                                        sigma=f_pT / (3 * math.sqrt(2)))
    np.testing.assert_allclose(iso.Fp1, expect, rtol=1e-12)


_SEEDED_SPACE = {
    "torque": {"dist": "uniform", "lower": 200.0, "upper": 1000.0},
    "pitch_seed": {"dist": "uniform", "lower": 0.0, "upper": 1e6},
}
_SEEDED_RUN = dict(n_samples=4, rng=11, outputs=["ste_ptp", "cms_ptp"], chunk_size=2,
                   model_options={**COARSE, "pitch_model": "seeded"})


def test_same_realisation_in_any_order(model):
    space = gearuq.ParameterSpace(_SEEDED_SPACE)
    serial = gearuq.monte_carlo(model, space, executor="serial", **_SEEDED_RUN)
    # one sample alone, in another order, gives the same numbers
    alone = model.response({k: serial[k].values[::-1] for k in ("torque", "pitch_seed")},
                           outputs=["ste_ptp"], **COARSE, pitch_model="seeded")
    np.testing.assert_array_equal(alone["ste_ptp"].values[::-1], serial["ste_ptp"].values)


@pytest.mark.e2e  # starts a process pool whose workers import gearuq and load the LTCA (3.3 s)
def test_same_realisation_on_any_executor(model):
    space = gearuq.ParameterSpace(_SEEDED_SPACE)
    serial = gearuq.monte_carlo(model, space, executor="serial", **_SEEDED_RUN)
    spawned = gearuq.monte_carlo(model, space, executor="processes", **_SEEDED_RUN)
    np.testing.assert_array_equal(serial["ste_ptp"].values, spawned["ste_ptp"].values)
    np.testing.assert_array_equal(serial["cms_ptp"].values, spawned["cms_ptp"].values)


def test_shaft_order_of_a_sine_pitch_error(model):
    """A once-per-revolution sine pitch error appears at 1 fs with its kinematic amplitude.

    Both gears carry ``A sin(2 pi k/30 + phase_g)``; at full contact the CMS is the
    load-weighted mean of the errors of the 2-3 teeth in contact, so the 1 fs amplitude of the
    STE is ``|A (e^{i phase_1} + e^{i phase_2})| cos(alpha_t) cos(beta_b)`` up to the
    smoothing over one tooth pitch (cos(2 pi / 30) = 0.978 at worst).
    """
    pair = seed002_pair()
    A = 10.0
    r = model.response({"torque": [1000.0], "pitch_amplitude": [A], "pitch_sigma": [0.0],
                        "pitch_seed": [7.0]}, outputs=["ste_spectrum"], pitch_model="seeded")
    ph1, _, ph2, _ = pitch_deviation_germ(30, 30, 7)
    expect = A * abs(np.exp(1j * ph1) + np.exp(1j * ph2)) * math.cos(pair.alpha_t) * math.cos(
        pair.beta_b)
    amp = float(r["ste_spectrum"].sel(order=r["order"][0]).values[0])
    assert str(r["order_label"].values[0]) == "1fs"
    assert amp == pytest.approx(expect, rel=0.025)
    assert amp < expect  # smoothing can only lower it


def test_germ_first_harmonic_is_the_kinematic_shaft_order(model):
    """The germ's ``pitch_xi_p_1`` is a once-per-revolution cosine of amplitude ``A/sqrt 2``.

    Alone (no scatter) it puts ``A/sqrt(2) cos(alpha_t) cos(beta_b)`` on 1 fs of the STE, up
    to the smoothing over one tooth pitch (as the seeded sine above); the response moves
    continuously with the normal (halving it halves the shaft order within 1 %).
    """
    pair = seed002_pair()
    A = 10.0
    base = {"torque": [1000.0], "pitch_amplitude": [A], "pitch_sigma": [0.0]}
    one = model.response({**base, "pitch_xi_p_1": [1.0]}, outputs=["ste_spectrum"])
    half = model.response({**base, "pitch_xi_p_1": [0.5]}, outputs=["ste_spectrum"])
    expect = A / math.sqrt(2.0) * math.cos(pair.alpha_t) * math.cos(pair.beta_b)
    amp = float(one["ste_spectrum"].values[0, 0])
    assert amp == pytest.approx(expect, rel=0.025) and amp < expect
    assert float(half["ste_spectrum"].values[0, 0]) == pytest.approx(amp / 2, rel=0.01)
    # the nominal germ is the error-free flank
    nominal = model.response({"torque": [1000.0]}, outputs=["ste_spectrum"])
    assert float(nominal["ste_spectrum"].values[0, 0]) < 1e-9


def test_germ_bad_input(model):
    with pytest.raises(ValueError, match=r"pitch_harmonics=16.*valid range: integers 1\.\.15"):
        model.response({}, outputs=["ste_ptp"], pitch_harmonics=16)
    with pytest.raises(ValueError, match=r"pitch_xi_g_9=1\.0 is outside the germ kept by "
                                         r"pitch_harmonics=4 \(valid: pitch_xi_g_1\.\."
                                         r"pitch_xi_g_8"):
        model.response({"pitch_xi_g_9": [0.0, 1.0]}, outputs=["ste_ptp"], pitch_harmonics=4)
    # the default space is continuous: torque and 2 x 29 standard normals
    space = model.default_space()
    assert space.dim == 59 and "pitch_seed" not in space.names
    assert model.default_space(pitch_harmonics=2).dim == 1 + 2 * 4


def test_spectrum_oracle():
    orders, labels, bins = order_table(30, 30, 2, 2, 24)
    assert labels == ["1fs", "2fs", "1fm-2fs", "1fm-1fs", "1fm", "1fm+1fs", "1fm+2fs",
                      "2fm-2fs", "2fm-1fs", "2fm", "2fm+1fs", "2fm+2fs"]
    np.testing.assert_allclose(orders[[0, 4, 5]], [1 / 30, 1.0, 1 + 1 / 30])
    n = 30 * 24
    x = np.arange(n) / 24.0  # mesh cycles
    signal = 3.0 + 2.0 * np.cos(2 * np.pi * x) + 0.5 * np.sin(2 * np.pi * (1 + 2 / 30) * x + 1)
    amp = order_amplitudes(signal, bins)
    expect = np.zeros(len(labels))
    expect[labels.index("1fm")] = 2.0
    expect[labels.index("1fm+2fs")] = 0.5
    np.testing.assert_allclose(amp, expect, atol=1e-12)
    with pytest.raises(ValueError, match="n_sidebands=15"):
        order_table(30, 30, 2, 15, 24)
    with pytest.raises(ValueError, match="n_mesh_orders=12"):
        order_table(30, 30, 12, 1, 24)


def test_design_relief_is_not_contact_loss(model):
    relief = {"tip_relief_amount": [30.0], "tip_relief_length": [8.0], "torque": [600.0]}
    clean = model.response({**relief, **ERROR_FREE}, outputs=["contact_loss_fraction",
                                                               "unloaded_share_max"])
    assert float(clean["contact_loss_fraction"][0]) == 0.0
    assert float(clean["unloaded_share_max"][0]) == 0.0
    # the same relief unloads part of the geometric contact length by design
    pair = seed002_pair()
    dev = FlankDeviations.symmetric_tip_relief(30e-6, 8e-3)
    geo = ltca(pair, torque=600.0, deviations=dev, n_cycles=1)
    assert float(geo["geometric_loss_fraction"].max()) > 0.05
    assert float(geo["contact_loss_fraction"].max()) == 0.0
    # with the seed's pitch scatter at light load, contact is lost in some positions
    light = model.response({**relief, "torque": [200.0]}, outputs=["contact_loss_fraction"],
                           pitch_model="seeded")
    assert float(light["contact_loss_fraction"][0]) > 0.05


def test_bad_input(model):
    g_alpha_mm = seed002_pair().g_alpha * 1e3
    with pytest.raises(ValueError, match="tip_relief_length.*outside valid range"):
        model.response({"tip_relief_length": [g_alpha_mm + 0.5]}, outputs=["ste_ptp"])
    with pytest.raises(ValueError, match="root_relief_length"):
        model.response({"root_relief_length": [40.0]}, outputs=["ste_ptp"])
    for torque in (0.0, -100.0):
        with pytest.raises(ValueError, match="torque.*outside valid range"):
            model.response({"torque": [torque]}, outputs=["ste_ptp"])
    for grade in (13, -1):
        with pytest.raises(ValueError, match="iso_grade.*outside valid range"):
            model.response({"iso_grade": [grade]}, outputs=["ste_ptp"])
    with pytest.raises(ValueError, match="iso_grade.*whole number"):
        model.response({"iso_grade": [4.5]}, outputs=["ste_ptp"])
    with pytest.raises(ValueError, match="n_mesh_orders"):
        model.response({}, outputs=["ste_spectrum"], n_mesh_orders=13)
    with pytest.raises(ValueError, match="positions_per_cycle"):
        model.response({}, outputs=["ste_ptp"], positions_per_cycle=2)
    with pytest.raises(ValueError, match="amplitude_reading"):
        model.response({}, outputs=["ste_ptp"], amplitude_reading="peak")
    # deviation arrays of the wrong length (the gears API the plugin builds on)
    with pytest.raises(ValueError, match=r"Fp2 has shape \(31,\), valid: \(30,\)"):
        ltca(seed002_pair(), torque=100.0, deviations=FlankDeviations(Fp2=np.zeros(31)))
    with pytest.raises(ValueError, match="pair="):
        MeshExcitation(pair="30/30")
    with pytest.raises(ValueError, match="bore_ratio"):
        MeshExcitation(bore_ratio=1.5)
