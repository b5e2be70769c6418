"""The ``geared_rotor`` plugin: contract, quasi-static limit with the LTCA, spectra, flags."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from gearuq.testing import check_model
from gearuq_plugins.geared_rotor import GearedRotor

#: A coarse discretisation keeps the contract checks fast (the physics is the same).
COARSE = {"positions_per_cycle": 8, "n_pts": 6, "n_mesh_harmonics": 2}


@pytest.fixture(scope="module")
def model() -> GearedRotor:
    return GearedRotor()


@pytest.fixture(autouse=True)
def _quiet():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", category=UserWarning)
        yield


@pytest.mark.e2e  # over 10 s: CI runs it with the e2e marker
def test_conformance(model):
    ds = check_model(model, np.linspace(0.0, 0.02, 9), options=COARSE)
    assert set(ds["order_label"].values[[30, 29, 31, 60]]) == {
        "f_m", "f_m - 1 f_s", "f_m + 1 f_s", "2 f_m"}
    assert ds["bearing_force_y"].dims == ("sample", "bearing", "time")
    assert np.all(ds["status"].values == 0)


def test_quasi_static_dte_equals_static_te_of_the_assembled_rotor(model):
    """25 rpm: the DTE follows the position-wise static TE (LTCA excitation, full FE statics)."""
    from gearuq.rotor.geared import single_threaded_blas
    from gearuq_plugins.geared_rotor.physics import problem_for

    opts = {**COARSE, "positions_per_cycle": 16, "n_mesh_harmonics": 7}
    values = {p.name: p.nominal for p in model.parameters}
    values["speed"] = 25.0
    options = model.validate_options(opts)
    prob = problem_for(model, values, options)
    ex = prob.excitation
    rotor, v = prob.rotor, prob.rotor.mesh_vector()
    te, K = rotor.transmission_error_vector(), rotor.K()
    idx = np.arange(0, ex.tau.size, 4)
    with single_threaded_blas():
        static = np.array([
            te @ rotor.static(prob.load + ex.stiffness[i] * ex.error[i] * v,
                              stiffness=K + (ex.stiffness[i] - ex.mean_stiffness) * np.outer(v, v))
            for i in idx])
    t = ex.tau[idx] / (30 * 25.0 / 60.0)
    ds = model.response({"speed": [25.0]}, t, outputs=["dte", "mesh_approach"], **opts)
    # the band-limited steady state of a step-like excitation: within 2 % of its range
    assert np.abs(ds["dte"].values[0] - static).max() < 0.02 * np.ptp(static)
    assert np.abs(ds["mesh_approach"].values[0] - ex.ste[idx]).max() < 0.02 * np.ptp(ex.ste)
    # shaft and bearing compliance add to the LTCA STE
    assert ds["dte"].values[0].mean() > 3.0 * ex.ste.mean()


def test_rms_and_spectrum_agree_with_the_time_signal(model):
    ds = model.response({"speed": [3000.0]}, None, outputs=["dte_rms", "dte_spectrum",
                                                            "dte_mean"], **COARSE)
    period = 60.0 / 3000.0
    n = 512
    t = np.arange(n) * period / n
    sig = model.response({"speed": [3000.0]}, t, outputs=["dte"], **COARSE)["dte"].values[0]
    assert ds["dte_rms"].values[0] == pytest.approx(sig.std(), rel=1e-10)
    assert ds["dte_mean"].values[0] == pytest.approx(sig.mean(), rel=1e-12)
    amp = 2 * np.abs(np.fft.rfft(sig)) / n
    np.testing.assert_allclose(ds["dte_spectrum"].values[0, 1:61], amp[1:61],
                               atol=1e-9 * amp.max())


def test_tip_relief_lowers_the_mesh_harmonic(model):
    """Yuan et al. (2020) Sec. 3.2: relief reduces the mesh-frequency DTE (no pitch deviations)."""
    base = {"pitch_amplitude": [0.0, 0.0], "pitch_sigma": [0.0, 0.0], "speed": [2000.0] * 2,
            "tip_relief_amount": [0.0, 42.0]}
    opts = {**COARSE, "positions_per_cycle": 16, "n_pts": 10}
    ds = model.response(base, None, outputs=["dte_spectrum", "ste_ptp"], **opts)
    fm = ds["dte_spectrum"].sel(order=30).values
    assert fm[1] < 0.3 * fm[0]
    assert ds["ste_ptp"].values[1] < 0.3 * ds["ste_ptp"].values[0]


def test_a_failing_ltca_sample_is_flagged_not_dropped(model, monkeypatch):
    from gearuq.rotor import excitation

    original = excitation.MeshExcitation.from_setup.__func__

    def failing(cls, setup, torque, **kw):
        if torque > 4000.0:
            raise ValueError(f"torque={torque!r} N m: the LTCA did not converge")
        return original(cls, setup, torque, **kw)

    monkeypatch.setattr(excitation.MeshExcitation, "from_setup", classmethod(failing))
    fresh = GearedRotor(cache_size=0)
    ds = fresh.response({"torque": [1000.0, 4500.0]}, None, outputs=["dte_rms"], **COARSE)
    assert list(ds["status"].values) == [0, 19]
    assert np.isfinite(ds["dte_rms"].values[0]) and np.isnan(ds["dte_rms"].values[1])
    assert "ltca_cannot_carry_the_load" in ds["status"].attrs["flag_meanings"]


def test_bad_inputs_raise_with_names(model):
    with pytest.raises(ValueError, match="speed"):
        model.response({"speed": [0.0]}, None, outputs=["dte_rms"], **COARSE)
    with pytest.raises(ValueError, match="torque"):
        model.response({"torque": [-5.0]}, None, outputs=["dte_rms"], **COARSE)
    with pytest.raises(ValueError, match="n_mesh_harmonics"):
        model.response({}, None, outputs=["dte_rms"], positions_per_cycle=8,
                       n_mesh_harmonics=5)
    with pytest.raises(ValueError, match="n_harmonic"):
        model.response({}, None, outputs=["dte_rms"], n_harmonic=3)


def test_model_pickles_without_its_cache(model):
    import pickle

    model.response({}, None, outputs=["dte_rms"], **COARSE)
    assert model._cache
    clone = pickle.loads(pickle.dumps(model))
    assert clone._cache == {} and clone.cache_size == model.cache_size


def test_dte_rms_max_is_the_largest_rms_of_the_per_speed_steady_states(model):
    """The range outputs equal the max over the same speeds solved one by one (same H)."""
    opts = {**COARSE, "speed_min": 500.0, "speed_max": 6000.0, "n_speeds": 12,
            "range_mesh_harmonics": 2, "range_cutoff_factor": 1.0}
    germ = {"pitch_xi_p_1": [1.2], "pitch_xi_g_2": [-0.7], "pitch_xi_p_5": [0.4]}
    ds = model.response(germ, None, outputs=["dte_rms_max", "speed_at_dte_rms_max"], **opts)
    speeds = np.linspace(500.0, 6000.0, 12)
    each = model.response({k: v * 12 for k, v in germ.items()} | {"speed": speeds}, None,
                          outputs=["dte_rms"], **COARSE)  # n_mesh_harmonics 2, cut-off 1.5
    one_by_one = model.response({k: v * 12 for k, v in germ.items()} | {"speed": speeds},
                                None, outputs=["dte_rms"],
                                **{**COARSE, "cutoff_factor": 1.0})["dte_rms"].values
    assert ds["dte_rms_max"].values[0] == pytest.approx(one_by_one.max(), rel=1e-9)
    assert ds["speed_at_dte_rms_max"].values[0] == speeds[one_by_one.argmax()]
    # the cut-off of the range changes the largest RMS by far less than 1 %
    assert each["dte_rms"].values.max() == pytest.approx(one_by_one.max(), rel=1e-2)
    assert ds["status"].values[0] == 0


@pytest.mark.e2e
def test_continuation_along_speed_gives_the_same_contact_loss_states_with_fewer_iterations(
        model):
    from gearuq.rotor.geared import single_threaded_blas
    from gearuq_plugins.geared_rotor.physics import problem_for

    values = {p.name: p.nominal for p in model.parameters} | {
        "torque": 100.0, "pitch_amplitude": 40.0}
    options = model.validate_options({**COARSE, "pitch_model": "seeded", "end_inertias": "none"})
    prob = problem_for(model, values, options, speed_range=True)
    speeds = np.linspace(3000.0, 5000.0, 9)
    with single_threaded_blas():
        cont = prob.rms_over_speeds(speeds, continuation=True)
        cold = prob.rms_over_speeds(speeds, continuation=False)
    assert np.all(cont.contact_loss_fraction > 0.0) and np.all(cont.status == 0)
    np.testing.assert_allclose(cont.rms, cold.rms, rtol=1e-7)
    assert cont.iterations.sum() < cold.iterations.sum()


def test_speed_range_bad_input(model):
    with pytest.raises(ValueError, match=r"speed_min=8000\.0 rpm must be below speed_max="
                                         r"8000\.0 rpm"):
        model.response({}, None, outputs=["dte_rms_max"], speed_min=8000.0)
    with pytest.raises(ValueError, match=r"n_speeds.*got 1.*\[2, "):
        model.response({}, None, outputs=["dte_rms_max"], n_speeds=1)


def test_harmonics_from_speed_reach_the_converged_dte_ptp(model):
    """``n_mesh_harmonics=None`` keeps every mesh harmonic below 10.5 kHz (4..11).

    At 875 rpm (4 harmonics drop the 5th, next to a mode) the chosen count gives the
    peak-to-peak DTE of all 11 harmonics the LTCA resolves; 4 harmonics are off by > 2 %.
    """
    from gearuq_plugins.geared_rotor.physics import mesh_harmonics

    opts = model.validate_options({})
    assert [mesh_harmonics(opts, s) for s in (100.0, 1400.0, 2000.0, 3000.0, 8000.0)] == [
        11, 11, 11, 7, 4]
    p = {"speed": [875.0], "pitch_amplitude": [15.0], "pitch_sigma": [3.0]}
    kw = {"outputs": ["dte_ptp"], "pitch_model": "seeded", "end_inertias": "none"}
    auto = model.response(p, None, **kw)
    full = model.response(p, None, n_mesh_harmonics=11, **kw)
    four = model.response(p, None, n_mesh_harmonics=4, **kw)
    assert auto["n_mesh_harmonics"].values[0] == 11
    ref = full["dte_ptp"].values[0]
    assert auto["dte_ptp"].values[0] == pytest.approx(ref, rel=1e-12)
    assert abs(four["dte_ptp"].values[0] / ref - 1.0) > 0.02


def test_end_inertias_lower_the_rolling_mode(model):
    """The lowest mode (shafts rolling on their bearings with the gear bodies) drops with
    the drive and load inertias; the hub carries exactly the inertia asked for."""
    from gearuq.rotor.examples import seed002_rotor, shaft_end_hub
    from gearuq.rotor.modal import undamped_modes

    assert shaft_end_hub(0, 0.03, 0.07).polar_inertia == pytest.approx(0.03, rel=1e-12)
    f = [undamped_modes(seed002_rotor(8.0e8, drive_inertia=J, load_inertia=J)).elastic.omega[0]
         / (2 * np.pi) for J in (None, 0.03, 0.5)]
    assert 440.0 < f[0] < 455.0 and f[0] > f[1] > f[2] and f[2] < 200.0
    with pytest.raises(ValueError, match=r"drive_inertia.*value 0 .*outside valid range"):
        model.response({"drive_inertia": [0.0]}, None, outputs=["dte_rms"], **COARSE)
    with pytest.raises(ValueError, match=r"load_inertia=-1\.0 is outside its valid range"):
        seed002_rotor(8.0e8, load_inertia=-1.0)


def test_contact_loss_fraction_within_one_percent_of_the_converged_share(model):
    """100 N m, 4600 rpm, 40 um: the AFT grid alone gives 13.9 % (4 harmonics) against
    14.7 % converged; the share on the 16x finer grid is within 1 %."""
    from gearuq.rotor.harmonic_balance import contact_loss_share
    from gearuq_plugins.geared_rotor.physics import problem_for

    values = {p.name: p.nominal for p in model.parameters} | {
        "torque": 100.0, "pitch_amplitude": 40.0, "speed": 4600.0}
    kw = {"pitch_model": "seeded", "end_inertias": "none"}
    ref_prob = problem_for(model, values, model.validate_options({"n_mesh_harmonics": 11,
                                                                   **kw}))
    ref_sol = ref_prob.steady_state(4600.0)
    reference = contact_loss_share(ref_prob.prep, ref_sol, ref_prob.backlash, oversample=64)
    assert 0.14 < reference < 0.15
    ds = model.response({k: [v] for k, v in values.items()}, None,
                        outputs=["contact_loss_fraction"], **kw)
    assert ds["contact_loss_fraction"].values[0] == pytest.approx(reference, rel=0.01)
    coarse = problem_for(model, values, model.validate_options({"n_mesh_harmonics": 4, **kw}))
    assert abs(coarse.steady_state(4600.0).contact_loss_fraction / reference - 1) > 0.04


def test_negative_times_are_refused(model):
    with pytest.raises(ValueError, match=r"t contains negative instants \(smallest -0\.001 s\); "
                                         r"valid range \[0, inf\) s"):
        model.response({}, np.array([-0.001, 0.0]), outputs=["dte"], **COARSE)
