"""The dynamic factor K_v and the mesh-order response of the geared rotor over a speed range.

Oracles that share no code with the harmonic balance's outputs: the quasi-static limit of
ISO 6336-1's definition (K_v -> 1, at first order in the speed with damping, second order
without), the resonance where the mesh frequency meets a natural frequency of the
linearised rotor (eigenvalues of the full FE matrices), the closed form of the linear
time-invariant mesh (the full FE receptance), a time integration of the same rotor, and a
fine sweep against the located peak.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
import scipy.linalg as sla

from gearuq_plugins.geared_rotor import GearedRotor

#: A coarse LTCA keeps these tests fast (positions_per_cycle 8 resolves 3 mesh harmonics).
COARSE = {"positions_per_cycle": 8, "n_pts": 6, "range_mesh_harmonics": 3}
DEVIATED = {"torque": 1000.0, "pitch_xi_p_1": 1.0, "pitch_xi_g_2": -1.0, "iso_grade": 6,
            "damping_ratio": 0.02}


@pytest.fixture(scope="module")
def model() -> GearedRotor:
    return GearedRotor()


@pytest.fixture(scope="module")
def problem(model):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", category=UserWarning)
        return model.rotor_problem(DEVIATED, speed_range=True, **COARSE)


def _mesh_modes(prob) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies [Hz] and mesh strain-energy shares from the full FE matrices."""
    rotor = prob.rotor
    w2, vec = sla.eigh(rotor.K(), rotor.M())
    elastic = w2 > 1e-6 * w2[-1]
    omega, shapes = np.sqrt(w2[elastic]), vec[:, elastic]
    share = prob.excitation.mean_stiffness * (rotor.mesh_vector() @ shapes) ** 2 / omega**2
    return omega / (2.0 * math.pi), share


@pytest.mark.parametrize("damping_ratio, order", [(0.02, 1.0), (0.0, 2.0)])
def test_kv_tends_to_one_in_the_quasi_static_limit(model, damping_ratio, order):
    """K_v - 1 -> 0 as n -> 0: linearly with viscous damping (force ~ c w), as n^2 without."""
    prob = model.rotor_problem(DEVIATED | {"damping_ratio": damping_ratio}, speed_range=True,
                               **COARSE)
    speeds = np.array([0.5, 1.0, 2.0])
    excess = np.array([prob.dynamics_at(s)[0]["kv"] - 1.0 for s in speeds])
    assert np.all(excess > 0.0) and excess[0] < 1e-6
    slopes = np.diff(np.log(excess)) / np.diff(np.log(speeds))
    np.testing.assert_allclose(slopes, order, atol=0.05)
    # the mean mesh force is the static normal force at any speed (torque balance)
    sol = prob.dynamics_at(3000.0)[1]
    assert sol.force[0].real == pytest.approx(prob.excitation.normal_force, rel=1e-9)


def test_kv_peaks_where_the_mesh_frequency_meets_the_mesh_mode(problem):
    """The mode with the largest mesh strain energy below 8000 rpm: z1 n / 60 = f_r."""
    f, share = _mesh_modes(problem)
    in_range = f * 60.0 / problem.pinion_teeth < 8000.0
    r = int(np.argmax(np.where(in_range, share, 0.0)))
    predicted = f[r] * 60.0 / problem.pinion_teeth
    assert share[r] > 0.3
    speeds = np.linspace(0.85 * predicted, 1.15 * predicted, 13)
    dyn = problem.dynamics_over_speeds(speeds, refine=("kv",))
    kv, at, bracket = dyn.peaks["kv"]
    assert at == pytest.approx(predicted, rel=0.02)
    assert kv > 1.5 and bracket <= 1.0
    # the located peak against a fine sweep (0.25 rpm steps) around it
    fine = at + np.arange(-10.0, 10.01, 0.25)
    kv_fine = np.array([problem.dynamics_at(s)[0]["kv"] for s in fine])
    assert kv >= kv_fine.max() * (1.0 - 1e-5)
    assert at == pytest.approx(fine[np.argmax(kv_fine)], abs=1.0)
    # the grid alone (25 rpm steps here) misses the top by several per cent of K_v - 1
    assert dyn.kv.max() < kv - 0.02 * (kv - 1.0)


def test_kv_of_the_linear_time_invariant_mesh_has_its_closed_form(model):
    """Constant stiffness k, error b cos(w_m t): F = P + k b |k h(w_m) - 1| cos(...).

    ``h`` is the mesh receptance of the full FE rotor (no modal reduction), so the closed form
    K_v = 1 + k b |k h(w_m) - 1| / P checks the reduction, the balance and the peak force.
    """
    from gearuq.rotor.excitation import MeshExcitation
    from gearuq.rotor.geared import GearedRotorProblem
    from gearuq.rotor.reduction import full_receptance

    base = model.rotor_problem(DEVIATED, speed_range=True, **COARSE)
    # 1 um keeps K_v - 1 < 1: the teeth never part, so the mesh stays linear
    k, P, b = base.excitation.mean_stiffness, base.excitation.normal_force, 1e-6
    exc = MeshExcitation.synthetic(k, P, n_cycles=30, positions_per_cycle=8,
                                   error_harmonics={30: b})
    from gearuq.rotor.examples import seed002_rotor

    prob = GearedRotorProblem(lambda kk: seed002_rotor(kk, drive_inertia=0.03,
                                                       load_inertia=0.03),
                              exc, 30, damping_ratio=0.02, n_harmonics=90, cutoff_factor=4.0)
    damping = prob.full_damping()
    for speed in (1500.0, 5000.0, 7000.0):
        w_m = 30 * speed / 60.0 * 2.0 * math.pi
        h = full_receptance(prob.rotor, damping, 2.0 * math.pi * speed / 60.0,
                            np.array([w_m]))[0]
        expected = 1.0 + k * b * abs(k * h - 1.0) / P
        values, sol = prob.dynamics_at(speed)
        assert sol.branch == "full_contact"
        assert values["kv"] - 1.0 == pytest.approx(expected - 1.0, rel=2e-3), speed


def test_peak_mesh_force_agrees_with_time_integration(problem):
    """The HB peak force against the reduced model integrated in time (dop853)."""
    from gearuq.rotor.time_integration import initial_state, integrate_reduced

    speed = 4100.0
    values, sol = problem.dynamics_at(speed)
    model = problem.reduced(speed)
    T, omega = problem.period(speed), 2.0 * math.pi * speed / 60.0
    # from the HB state: a wrong periodic state would not repeat over the two periods (it
    # repeats to 0.3 % of the force range: the truncation of the balance to 3 mesh harmonics)
    t_eval = np.arange(2 * 4096) * T / 4096
    y0 = initial_state(model, sol, omega)[None]
    tr = integrate_reduced(model, problem.prep, [omega], [T], t_eval, y0=y0)
    assert tr.status[0] == 0
    first, second = tr.force[0, :4096], tr.force[0, 4096:]
    assert np.abs(second - first).max() < 1e-2 * np.ptp(second)
    kv_time = float(second.max()) / problem.excitation.normal_force
    # the balance keeps 3 mesh harmonics, time integration all the stiffness series carries
    assert values["kv"] - 1.0 == pytest.approx(kv_time - 1.0, rel=0.03)


def test_range_outputs_of_the_plugin(model):
    """kv_max is at least the grid curve's maximum and within it by the located peak."""
    opts = COARSE | {"speed_min": 3500.0, "speed_max": 6000.0, "n_speeds": 11}
    params = {k: np.array([v]) for k, v in DEVIATED.items()}
    outs = ["kv_max", "speed_at_kv_max", "kv_over_speed", "dte_mesh_order_max",
            "speed_at_dte_mesh_order_max", "dte_mesh_order_over_speed",
            "bearing1_acceleration_y_mesh_order_max", "dte_mesh_band_rms_max",
            "dte_mesh_band_rms_over_speed", "dte_rms_max", "speed_at_dte_rms_max"]
    ds = model.response(params, None, outputs=outs, **opts)
    assert ds["status"].values[0] == 0
    curve = ds["kv_over_speed"].values[0]
    assert ds["kv_over_speed"].dims == ("sample", "range_speed")
    np.testing.assert_allclose(ds["range_speed"].values, np.linspace(3500.0, 6000.0, 11))
    assert curve.max() <= ds["kv_max"].values[0] <= curve.max() * 1.2
    assert ds["dte_mesh_order_max"].dims == ("sample", "mesh_harmonic")
    orders = ds["dte_mesh_order_over_speed"].values[0]
    assert np.all(ds["dte_mesh_order_max"].values[0] >= orders.max(axis=0))
    # the mesh band holds the mesh orders: its RMS is at least that of the three harmonics
    band = ds["dte_mesh_band_rms_over_speed"].values[0]
    assert np.all(band >= np.sqrt(0.5 * np.sum(orders**2, axis=1)) * (1 - 1e-12))
    # dte_rms_max from the same sweep equals the one computed alone
    alone = model.response(params, None, outputs=["dte_rms_max"], **opts)
    assert ds["dte_rms_max"].values[0] == pytest.approx(alone["dte_rms_max"].values[0],
                                                        rel=1e-10)
