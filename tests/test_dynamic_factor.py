"""The dynamic factor K_v and the mesh-order response of the geared rotor over a speed range.

Oracles that share no code with the harmonic balance's outputs: the quasi-static limit of
ISO 6336-1's definition (K_v -> 1, at first order in the speed with damping, second order
without), the resonance where the mesh frequency meets a natural frequency of the
linearised rotor (eigenvalues of the full FE matrices), the closed form of the linear
time-invariant mesh (the full FE receptance), a time integration of the same rotor, and a
fine sweep against the located peak.
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
import scipy.linalg as sla
from scipy import stats

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


@pytest.mark.e2e
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


@pytest.mark.e2e
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


# ------------------------------------------------------------------ ISO 6336-1 Method B
def test_iso_method_b_against_a_hand_calculation():
    """Yuan, Liu and Liu's 30/30 pair, 1000 N m, class 6, no relief, at one speed per range.

    Written out from the standard's formulas with the pair's printed geometry (d = 189.263
    mm, d_a = 201.263 mm, d_f = 174.263 mm, d_b = 176.761 mm, b = 40 mm, eps_gamma = 2.2005,
    alpha_t = 20.942 deg) and the stiffness of :func:`mesh_stiffness` as inputs.
    """
    from gearuq.gears.geometry import seed002_pair
    from gearuq.gears.iso6336 import mesh_stiffness, pair_dynamic_factor_method_b

    pair = seed002_pair()
    w = 2000.0 * 1000.0 / 189.2632 / 40.0                     # K_A F_t / b = 264.2 N/mm
    st = mesh_stiffness(pair, load_per_width=w)               # no light-load correction
    c1, cga = st.c_prime, st.c_gamma_alpha
    d_m = (201.2632 + 174.2632) / 2.0
    m_red = math.pi / 8.0 * (d_m / 176.7611) ** 2 * d_m**2 / (2.0 / 7.83e-6)
    n_E1 = 30000.0 / (math.pi * 30) * math.sqrt(cga / m_red)
    grade = math.sqrt(2.0)  # class 6 = 5 + 1
    f_pt = (0.001 * 189.2632 + 0.4 * 6 + 5.0) * grade         # 10.89 um
    f_pb = f_pt * math.cos(math.radians(20.9419))
    f_f = (2.5 * math.sqrt(6.0) + 0.17 * math.sqrt(189.2632) + 0.5) * grade
    y = 0.075 * f_pb
    C_a = (1500.0 / 97.0 - 18.45) ** 2 / 18.0 + 1.5
    B_p, B_f, B_k = c1 * (f_pb - y) / w, c1 * (f_f - y) / w, abs(1.0 - c1 * C_a / w)
    e = 2.20054
    C = (0.32, 0.57 / (e - 0.3), 0.096 / (e - 1.56), (0.57 - 0.05 * e) / (e - 1.44), 0.47,
         0.12 / (e - 1.74), 0.125 * math.sin(math.pi * (e - 2.0)) + 0.875)
    main = C[0] * B_p + C[1] * B_f + C[3] * B_k + 1.0
    sup = C[4] * B_p + C[5] * B_f + C[6]
    N = np.array([0.4, 1.0, 1.3, 1.8])
    expected = [N[0] * (C[0] * B_p + C[1] * B_f + C[2] * B_k) + 1.0, main,
                sup + (main - sup) * (1.5 - N[2]) / 0.35, sup]
    assert 5300.0 < n_E1 < 5500.0
    iso = pair_dynamic_factor_method_b(pair, 1000.0, N * n_E1, accuracy_grade=6)
    assert iso.resonance_speed_rpm == pytest.approx(n_E1, rel=1e-5)
    np.testing.assert_allclose(iso.kv, expected, rtol=1e-4)
    assert list(iso.regime) == ["subcritical", "main_resonance", "intermediate",
                                "supercritical"]


def test_iso_method_b_is_continuous_where_the_standard_joins_its_ranges():
    from gearuq.gears.geometry import seed002_pair
    from gearuq.gears.iso6336 import pair_dynamic_factor_method_b

    pair = seed002_pair()
    for torque, relief in ((1000.0, 0.0), (1000.0, 20.0), (300.0, 0.0)):
        n_E1 = pair_dynamic_factor_method_b(pair, torque, 1.0, accuracy_grade=7,
                                            tip_relief_um=relief).resonance_speed_rpm
        kv = pair_dynamic_factor_method_b(pair, torque, n_E1 * np.array(
            [1.15 - 1e-9, 1.15 + 1e-9, 1.5 - 1e-9, 1.5 + 1e-9, 1e-6]), accuracy_grade=7,
            tip_relief_um=relief).kv
        assert kv[0] == pytest.approx(kv[1], abs=1e-6) and kv[2] == pytest.approx(kv[3], abs=1e-6)
        assert kv[4] == pytest.approx(1.0, abs=1e-5)
    # coarser class -> larger B_p, B_f -> larger K_v; relief matched to the load -> B_k ~ 0
    a = pair_dynamic_factor_method_b(pair, 1000.0, 5000.0, accuracy_grade=6)
    b = pair_dynamic_factor_method_b(pair, 1000.0, 5000.0, accuracy_grade=7)
    c = pair_dynamic_factor_method_b(pair, 1000.0, 5000.0, accuracy_grade=6, tip_relief_um=20.0)
    assert b.kv[0] > a.kv[0] > c.kv[0] and c.B_k < 0.1
    with pytest.raises(ValueError, match=r"torque=-1\.0 is outside its valid range"):
        pair_dynamic_factor_method_b(pair, -1.0, 5000.0, accuracy_grade=6)
    with pytest.raises(ValueError, match=r"accuracy_grade=13"):
        pair_dynamic_factor_method_b(pair, 1000.0, 5000.0, accuracy_grade=13)


def test_plugin_iso_and_pitch_outputs_need_no_dynamics(model):
    """kv_iso_* follow the sample's torque and class; F_p is max - min of the deviations."""
    from gearuq.gears.deviations import cumulative_pitch_from_normals, iso1328_pitch_tolerances
    from gearuq.gears.geometry import seed002_pair
    from gearuq.gears.iso6336 import pair_dynamic_factor_method_b

    pair = seed002_pair()
    params = {"torque": np.array([500.0, 1000.0]), "iso_grade": np.array([6, 7]),
              "pitch_xi_p_1": np.array([1.0, -0.3]), "pitch_xi_g_3": np.array([0.5, 2.0])}
    ds = model.response(params, None, outputs=["kv_iso_max", "kv_iso_over_speed",
                                               "pitch_total_deviation_pinion",
                                               "pitch_total_deviation_wheel"])
    speeds = ds["range_speed"].values
    for i, (torque, grade) in enumerate(((500.0, 6), (1000.0, 7))):
        iso = pair_dynamic_factor_method_b(pair, torque, speeds, accuracy_grade=grade)
        np.testing.assert_allclose(ds["kv_iso_over_speed"].values[i], iso.kv, rtol=1e-12)
        assert ds["kv_iso_max"].values[i] == pytest.approx(iso.kv.max())
        f_pT, F_pT = iso1328_pitch_tolerances(pair.d2, pair.mn, grade)
        xi = np.zeros(29)
        xi[2] = params["pitch_xi_g_3"][i]
        wheel = cumulative_pitch_from_normals(xi, 30, amplitude=F_pT / 2,
                                              sigma=f_pT / (3 * math.sqrt(2)))
        assert ds["pitch_total_deviation_wheel"].values[i] == pytest.approx(np.ptp(wheel))
    # the pinion's once-per-revolution wave alone: F_p = 2 * amplitude/sqrt(2) * |xi|
    F_pT = iso1328_pitch_tolerances(pair.d1, pair.mn, 6)[1]
    assert ds["pitch_total_deviation_pinion"].values[0] == pytest.approx(
        2.0 * F_pT / 2.0 / math.sqrt(2.0) * 1.0, rel=0.02)


# ------------------------------------------------------------------ laws of production
def _total_deviation_draws(z, amplitude, sigma, n, seed):
    """F_p of n germs through the public expansion (one gear), an independent estimator."""
    from gearuq.gears.deviations import cumulative_pitch_from_normals

    xi = np.random.default_rng(seed).standard_normal((n, z - 1))
    return np.array([np.ptp(cumulative_pitch_from_normals(x, z, amplitude=amplitude,
                                                          sigma=sigma)) for x in xi])


@pytest.mark.e2e
def test_capable_process_puts_the_stated_share_beyond_F_pT():
    from gearuq.gears.deviations import capable_pitch_scatter, iso1328_pitch_tolerances
    from gearuq.gears.geometry import seed002_pair

    pair = seed002_pair()
    f_pT, F_pT = iso1328_pitch_tolerances(pair.d1, pair.mn, 6)
    n = 8000
    # today's reading of a class: about half of the gears exceed the class's own F_pT
    untruncated = _total_deviation_draws(30, 0.5 * F_pT, f_pT / (3 * math.sqrt(2)), n, 7)
    assert 0.42 < np.mean(untruncated > F_pT) < 0.55
    for share in (0.05, 0.0027):
        A, s = capable_pitch_scatter(30, f_pT, F_pT, share)
        assert s / A == pytest.approx((f_pT / (3 * math.sqrt(2))) / (0.5 * F_pT))
        beyond = np.mean(_total_deviation_draws(30, A, s, n, 11) > F_pT)
        se = math.sqrt(share * (1 - share) / n)
        assert abs(beyond - share) < 4.0 * se + 0.003 * share
    with pytest.raises(ValueError, match=r"share_beyond=0\.7 is outside its valid range"):
        capable_pitch_scatter(30, f_pT, F_pT, 0.7)


def test_inspected_normal_is_the_capable_process_truncated_to_the_tolerance():
    from scipy.stats import norm

    from gearuq.gears.deviations import inspected_normal_spec
    from gearuq.space import ParameterSpace

    spec = inspected_normal_spec(20.0, 5.0, 0.01)
    assert 2.0 * norm.sf(5.0 / spec["std"]) == pytest.approx(0.01, rel=1e-12)
    draws = ParameterSpace({"tip_relief_amount": spec}).sample(4000, rng=3)["tip_relief_amount"]
    assert draws.min() >= 15.0 and draws.max() <= 20.0 + 5.0
    # truncating a normal at +-2.576 sigma shrinks its variance by 2.6 %: close to the process
    assert np.std(draws) == pytest.approx(spec["std"] * math.sqrt(1 - 2 * 2.5758 *
                                          norm.pdf(2.5758) / 0.99), rel=0.05)


@pytest.mark.e2e
def test_failure_given_acceptance_is_a_parallel_system(model):
    """P(F_p1 > 0.9 F_pT | both gears pass) from the failure package against plain counting."""
    from gearuq import ParallelSystem
    from gearuq.failure import LimitState, failure_probability
    from gearuq.gears.deviations import capable_pitch_scatter, iso1328_pitch_tolerances
    from gearuq.gears.geometry import seed002_pair
    from gearuq.space import ParameterSpace

    pair = seed002_pair()
    f1, F1 = iso1328_pitch_tolerances(pair.d1, pair.mn, 7)
    space = ParameterSpace({f"pitch_xi_{g}_{i}": {"dist": "normal", "mean": 0.0, "std": 1.0}
                            for g in "pg" for i in range(1, 30)})
    opts = {"pitch_tolerance_law": "capable_process", "process_share_beyond": 0.2}
    rotor = model.with_nominal(iso_grade=7)
    fails = LimitState.upper("pitch_total_deviation_pinion", 0.9 * F1, name="large_Fp")
    accepted = LimitState.upper("pitch_acceptance_margin", 0.0, name="accepted")
    both = failure_probability(rotor, space, ParallelSystem([fails, accepted]), method="mc",
                               n_samples=3000, rng=5, model_options=opts, executor="serial")
    acc = failure_probability(rotor, space, accepted, method="mc", n_samples=3000, rng=5,
                              model_options=opts, executor="serial")
    conditional = float(both["pf"]) / float(acc["pf"])
    # independent: the pinion alone decides the numerator given the wheel passes
    A, s = capable_pitch_scatter(30, f1, F1, 0.2)
    Fp = _total_deviation_draws(30, A, s, 10_000, 13)
    exact = np.mean((Fp > 0.9 * F1) & (Fp <= F1)) / np.mean(Fp <= F1)
    assert float(acc["pf"]) == pytest.approx(0.8**2, abs=0.03)
    assert conditional == pytest.approx(exact, abs=0.025)


@pytest.mark.e2e
def test_quick_dynamic_factor_study(tmp_path):
    """The study's quick mode: its answers are consistent and its figures say what they are."""
    import json

    from gearuq import registry

    assert registry.get_study("geared_rotor_dynamic_factor")(
        out=tmp_path, quick=True, executor="serial") == 0
    info = json.loads((tmp_path / "summary.json").read_text())
    assert info["quick"] and info["X"] > 1.0
    count, ss = info["crude_mc"], info["subset"]
    assert count["lower"] <= count["pf"] <= count["upper"]
    rare = info["rare"]  # quick: the rare stage's code path at the moderate X
    assert ss["p_pass"] == rare["mirrored"]["p_pass"] == pytest.approx(0.95**2, abs=0.004)
    assert rare["X"] == info["X"] and set(rare) == {"X", "lines", "mirrored"}
    for method in ("lines", "mirrored"):
        res = rare[method]
        assert res["lower"] <= res["pf"] <= res["upper"]
        assert isinstance(res["message"], str) and res["message"]
    # rejected pairs cost no run: at most the quick sampler's draws
    assert rare["mirrored"]["runs"] <= _quick_mirrored_draws()
    assert rare["lines"]["n_lines"] == 4 and rare["lines"]["p_pass"] == ss["p_pass"]
    assert set(info["stages_wall_cpu_s"]) == {"population", "subset", "rare_lines",
                                              "rare_mirrored"}
    assert min(info["kv_max_quantiles"]) >= 1.0 and min(info["kv_iso_max_quantiles"]) >= 1.0
    assert {p.name for p in tmp_path.glob("*.png")} == {"kv_over_speed.png",
                                                       "campbell_map.png"}


@pytest.mark.e2e
def test_a_failed_steady_state_while_locating_a_peak_is_flagged(problem, monkeypatch):
    """Golden-section search that meets a failed steady state stops with the largest value
    found so far; the range says so (refinement_status) instead of reporting a resolved
    peak, and the grid's maximum stays a lower bound of what is reported."""
    f, share = _mesh_modes(problem)
    r = int(np.argmax(np.where(f * 60.0 / problem.pinion_teeth < 8000.0, share, 0.0)))
    predicted = f[r] * 60.0 / problem.pinion_teeth
    speeds = np.linspace(0.85 * predicted, 1.15 * predicted, 13)
    clean = problem.dynamics_over_speeds(speeds, refine=("kv",))
    assert clean.refinement_status == 0 and clean.peaks["kv"][2] <= 1.0
    real = type(problem).dynamics_at
    grid = set(speeds.tolist())

    def failing_off_grid(self, speed, **kw):
        values, sol = real(self, speed, **kw)
        if speed not in grid:  # every refinement point fails, as a diverged solve would
            values = dict(values, status=1)
        return values, sol

    monkeypatch.setattr(type(problem), "dynamics_at", failing_off_grid)
    dyn = problem.dynamics_over_speeds(speeds, refine=("kv",))
    assert dyn.worst_status() == 0 and dyn.refinement_status == 1
    kv, at, bracket = dyn.peaks["kv"]
    assert kv == pytest.approx(dyn.kv.max()) and bracket > 1.0  # the grid's, unresolved
    assert kv < clean.peaks["kv"][0]


#: The rare-stage tests' small rotor (3 speeds, 1 harmonic) and its cheaper twin.
def _quick_mirrored_draws() -> int:
    """Draws of the quick mirrored sampler (each a rotor run at most)."""
    from gearuq_studies import geared_rotor_dynamic_factor as study

    return int(study.QUICK_MIRRORED["n_rotor"])


_SMALL_ROTOR = {"pitch_tolerance_law": "capable_process", "process_share_beyond": 0.05,
                "n_speeds": 3, "speed_min": 6000.0, "speed_max": 8000.0,
                "range_mesh_harmonics": 1, "peaks_refined": 0}
_SMALL_CHEAP = {**_SMALL_ROTOR, "n_speeds": 2, "positions_per_cycle": 12, "n_pts": 8}

def _agrees_with_a_crude_count(res: dict, small: dict, x: float) -> None:
    """``res["pf"]`` against P(kv_max >= x | pass) counted on 400 draws of the small rotor
    (the acceptance read from the rotor's output), within 3.5 joint standard errors."""
    from gearuq_studies import geared_rotor_dynamic_factor as study

    draws = study.study_space().sample(400, rng=17)
    ds = study.study_model(6).response(draws, None, outputs=["kv_max",
                                                             "pitch_acceptance_margin"], **small)
    assert np.all(ds["status"].values == 0)
    acc = ds["pitch_acceptance_margin"].values >= 0
    k, n = int(np.sum(acc & (ds["kv_max"].values >= x))), int(acc.sum())
    count = k / n
    assert 0.05 < count < 0.5  # a moderate level, so the count resolves it
    se = math.hypot(math.sqrt(count * (1 - count) / n), res["cov"] * res["pf"])
    assert abs(res["pf"] - count) < 3.5 * se


@pytest.mark.e2e
def test_rare_stage_against_an_independent_count():
    """The rare stage's MFIS on a small rotor (3 speeds) at a moderate level against a crude
    count of accepted pairs that shares no estimator code with it (and divides by the
    counted acceptance, not the exact 0.95^2 the stage uses)."""
    from gearuq_studies import geared_rotor_dynamic_factor as study

    small, cheap, x = _SMALL_ROTOR, _SMALL_CHEAP, 1.22
    settings = {**study.RARE_MFIS, "n_per_level": 100, "n_samples": 60, "max_samples": 180,
                "target_cov": 0.2}
    res = study.mfis_given_acceptance(x, 5, 6, settings, {"executor": "serial"},
                                      options=small, cheap_options=cheap)
    assert res["p_pass"] == pytest.approx(0.95**2, abs=0.004) and res["cheap_runs"] >= 100
    assert res["runs"] <= 180 and res["lower"] <= res["pf"] <= res["upper"]
    _agrees_with_a_crude_count(res, small, x)


@pytest.mark.e2e
def test_germ_acceptance_margin_is_the_plugins_output(model):
    """The rare stage's vectorised gate equals the rotor's own ``pitch_acceptance_margin``
    (no dynamics run: pitch outputs need none), and accepts 0.95^2 of the capable process."""
    from gearuq_studies import geared_rotor_dynamic_factor as study

    space = study.study_space()
    u = np.random.default_rng(8).standard_normal((40, len(space.names)))
    design = {n: space.marginal(n).from_normal(u[:, j]) for j, n in enumerate(space.names)}
    ds = study.study_model(6).response(design, None, outputs=["pitch_acceptance_margin"],
                                       **study.OPTIONS)
    np.testing.assert_allclose(study.germ_acceptance_margin(u, 6),
                               ds["pitch_acceptance_margin"].values, atol=1e-12)
    many = np.random.default_rng(9).standard_normal((200_000, 58))
    share = np.mean(study.germ_acceptance_margin(many, 6) >= 0)
    # the process's quantile comes from 200 000 draws (0.3 % in F_p): 0.95 to about 1e-3
    assert share == pytest.approx(0.95**2, abs=0.004)


# 2-6 s of CPU: CI runs it with the end-to-end runs (-m e2e)
@pytest.mark.e2e
def test_given_acceptance_divides_by_the_counted_acceptance():
    """Every rare path divides by one counted P(pass): it agrees with an independent count
    of the vectorised gate, differs from the declared 0.95^2 by more than its own error (the
    process quantile is estimated once), and the interval's ends are divided by its ends."""
    import xarray as xr

    from gearuq_studies import geared_rotor_dynamic_factor as study

    p, se = study.accepted_probability(6)
    assert se == pytest.approx(math.sqrt(p * (1 - p) / 2e6))
    many = np.random.default_rng(11).standard_normal((200_000, 58))
    share = float(np.mean(study.germ_acceptance_margin(many, 6) >= 0))
    assert abs(p - share) < 4.0 * math.sqrt(share * (1 - share) / many.shape[0])
    assert abs(p - 0.95**2) > 3.0 * se
    rep = xr.Dataset({"pf": 1e-3, "pf_lower": 6e-4, "pf_upper": 1.5e-3, "cov_pf": 0.2,
                      "status": 0, "n_model_runs": 40, "wall_time": 1.0})
    out = study.given_acceptance(rep, (p, se))
    assert out["pf"] == pytest.approx(1e-3 / p, rel=1e-12)
    assert 6e-4 / (p + 3 * se) < out["lower"] < 6e-4 / p < 1.5e-3 / p < out["upper"]
    assert out["upper"] < 1.5e-3 / (p - 3 * se) and out["p_pass"] == p


@pytest.mark.e2e
@pytest.mark.parametrize("method", ["subspace", "harmonic"])
def test_rare_stage_densities_against_an_independent_count(method):
    """The rare stage's importance sampling, on a small rotor (3 speeds) at a moderate level,
    against a crude count of accepted pairs that shares no estimator code with it (the
    acceptance read from the rotor's output, not the stage's gate): ``subspace`` moves a few
    gradient directions, ``harmonic`` shifts damping, torque and relief and inflates the
    pitch harmonics 12-15 of the pinion-plus-wheel sum whatever their phase."""
    from gearuq_studies import geared_rotor_dynamic_factor as study

    if method == "harmonic":
        basis, groups = study.harmonic_planes()
        assert basis.shape == (61, 10) and groups == [[3, 4], [5, 6], [7, 8], [9]]
        np.testing.assert_allclose(basis.T @ basis, np.eye(10), atol=1e-12)
    small, cheap, x = _SMALL_ROTOR, _SMALL_CHEAP, 1.22
    quick = {"subspace": study.QUICK_SUBSPACE, "harmonic": study.QUICK_HARMONIC}[method]
    settings = {**quick, "n_per_level": 60, "n_cheap": 60, "n_rotor": 150, "widen": 0.02}
    res = study.subspace_given_acceptance(x, 5, 6, settings, {"executor": "serial"},
                                          options=small, cheap_options=cheap)
    rotor = res["rotor"]
    # rejected pairs cost no run: fewer runs than draws at every level
    assert 0 < res["fit"]["runs"] < 60 * len(res["fit"]["levels"]) and rotor["runs"] < 150
    assert (res["directions"]["runs"] == 0) == (method == "harmonic")
    assert rotor["lower"] <= rotor["pf"] <= rotor["upper"] and rotor["status"] in (0, 1)
    assert rotor["pf_over_x"]["pf"][f"{x:.3f}"] == pytest.approx(rotor["pf"], rel=1e-9)
    _agrees_with_a_crude_count(rotor, small, x)


def test_pf_over_x_flags_invalid_runs_instead_of_reading_them_below_x():
    """A run without a steady state (``kv_max`` NaN) is counted, read as safe in ``pf`` and
    as failed in the upper reading, exactly as the main estimate reads it; with no invalid
    run the two readings are one. The weighted sums are redone here by hand."""
    from gearuq.failure.methods.subspace import subspace_density
    from gearuq_studies import geared_rotor_dynamic_factor as study

    density = subspace_density(np.eye(3)[:, :1], np.array([1.5]), np.array([[1.0]]), 0.1)
    rng = np.random.default_rng(4)
    u = rng.standard_normal((50, 3)) + [1.5, 0.0, 0.0]
    kv = 1.7 + 0.1 * rng.standard_normal(50)
    kv[[3, 17, 40]] = np.nan
    x, n, p_pass = 1.75, 80, 0.9
    out = study._pf_over_x([(u[:20], x - kv[:20]), (u[20:], x - kv[20:])], density, n, x,
                           p_pass)
    w = np.exp(density.log_weights(u))
    bad = np.isnan(kv)
    assert out["invalid_runs"] == 3
    for xp in (x - 0.04, x, x + 0.06):
        key = f"{xp:.3f}"
        safe = np.sum(w[~bad] * (kv[~bad] >= xp)) / n / p_pass
        assert out["pf"][key] == pytest.approx(safe, rel=1e-12)
        assert out["invalid_as_failures"][key] == pytest.approx(
            safe + np.sum(w[bad]) / n / p_pass, rel=1e-12)
    clean = study._pf_over_x([(u[~bad], x - kv[~bad])], density, n, x, p_pass)
    assert clean["invalid_runs"] == 0 and clean["pf"] == clean["invalid_as_failures"]


@pytest.mark.e2e
def test_rare_stage_lines_against_an_independent_count():
    """The rare stage's second method, radial line sampling behind the inspection gate, on
    the small rotor (3 speeds) at a moderate level, against the crude count of accepted
    pairs (acceptance read from the rotor's output): no weight, every line either crosses
    or is gated out, and only accepted points cost runs."""
    from gearuq_studies import geared_rotor_dynamic_factor as study

    x = 1.22
    # radial lines, uniform directions: the rare settings aim at the rare level's heavy lines
    settings = {**study.RADIAL_LINES, "n_lines": 40, "t_grid": (-6.0, -3.0, 0.0, 3.0, 6.0),
                "root_tol": 0.01, "chunk_lines": 40, "direction_means": None}
    res = study.lines_given_acceptance(x, 5, 6, settings, {"executor": "serial"},
                                       options=_SMALL_ROTOR)
    assert res["n_lines"] == 40 and len(res["line_pf"]) == 40
    assert res["lower"] <= res["pf"] <= res["upper"] and res["status"] in (0, 1)
    assert res["lines_by_crossings"][3] == 0 and res["max_weight"] == 1.0
    # a grid of 5 points a line plus the refinement; a gated-out line costs nothing
    assert res["runs"] < 40 * (5 + 2 * 12)
    assert res["p_pass"] == study.accepted_probability(6)[0]
    _agrees_with_a_crude_count(res, _SMALL_ROTOR, x)


def test_lines_settings_are_checked_before_any_run():
    """Straight lines along harmonic 15: an origin density over more columns than precede
    the line's coordinate (it would move the line's own coordinate and make the weight
    depend on it), or a spread of another length, is refused by name before any run."""
    from gearuq_studies import geared_rotor_dynamic_factor as study

    def never(*_args, **_kwargs):
        raise AssertionError("no model run expected")

    for bad in ({"origin_means": (0.0,) * 10}, {"origin_std": (1.0,) * 3}):
        with pytest.raises(ValueError, match="origin_means"):
            study.lines_given_acceptance(1.77, 0, 6, {**study.RARE_LINES, **bad},
                                         {"executor": never})
    basis, groups = study.harmonic_planes(study.RARE_LINES["harmonics"])
    column = groups[-1][0]
    # the line's coordinate is the pinion-plus-wheel sum of the germs' last normal (cos 15)
    names = study.study_space().names
    assert {names[i] for i in np.flatnonzero(basis[:, column])} == {"pitch_xi_p_29",
                                                                     "pitch_xi_g_29"}
    assert len(study.RARE_LINES["origin_means"]) <= column


def test_mirrored_density_is_the_lines_origins_times_a_mirrored_pair():
    """The mirrored density moves relief, torque, damping, the planes of harmonics 12-14 and
    harmonic 15's pinion-plus-wheel coordinate only: its weight is even in that coordinate
    (the two components mirrored), depends on no other germ coordinate, is at most
    1 / defensive, and its marginal along harmonic 15 is the written mixture (checked
    against a histogram of its draws)."""
    from gearuq_studies import geared_rotor_dynamic_factor as study

    settings = study.RARE_MIRRORED
    dens = study.mirrored_density(settings)
    planes, groups = study.harmonic_planes(tuple(settings["harmonics"]))
    along = planes[:, groups[-1][0]]
    rng = np.random.default_rng(3)
    u = rng.standard_normal((2000, 61))
    t = u @ along
    mirror = u - 2.0 * np.outer(t, along)
    np.testing.assert_allclose(dens.log_weights(mirror), dens.log_weights(u), atol=1e-10)
    # a germ coordinate orthogonal to every moved column leaves the weight unchanged
    other = np.zeros(61)
    other[0], other[29] = math.sqrt(0.5), -math.sqrt(0.5)  # harmonic 1, pinion minus wheel
    assert abs(other @ planes).max() < 1e-12
    np.testing.assert_allclose(dens.log_weights(u + 2.5 * other), dens.log_weights(u),
                               atol=1e-10)
    assert np.exp(dens.log_weights(u)).max() <= 1.0 / settings["defensive"] + 1e-12
    sample = dens.sample(40_000, rng)
    draws = sample @ along
    m, s, a = settings["along_mean"], settings["along_std"], settings["defensive"]
    # relief, torque and damping: the defensive normal and the lines' origin moments
    for j in range(3):
        mean = (1 - a) * settings["origin_means"][j]
        var = a + (1 - a) * (settings["origin_std"][j] ** 2 + settings["origin_means"][j] ** 2)
        assert np.mean(sample @ planes[:, j]) == pytest.approx(
            mean, abs=4.0 * math.sqrt((var - mean**2) / 40_000))
    for lo, hi in ((-5.0, -3.0), (-1.0, 1.0), (3.0, 4.0), (4.0, 6.0)):
        exact = a * (stats.norm.cdf(hi) - stats.norm.cdf(lo)) + (1 - a) * 0.5 * sum(
            stats.norm.cdf((hi - c) / s) - stats.norm.cdf((lo - c) / s) for c in (m, -m))
        share = np.mean((draws >= lo) & (draws < hi))
        assert share == pytest.approx(exact, abs=4.0 * math.sqrt(exact / 40_000) + 1e-4)


def test_mirrored_settings_are_checked_before_any_run():
    """Origin means of another length than the columns before harmonic 15's, or a
    non-positive mirrored mean or spread, are refused by name."""
    from gearuq_studies import geared_rotor_dynamic_factor as study

    for bad, name in (({"origin_means": (0.0,) * 10}, "origin_means"),
                      ({"origin_std": (1.0,) * 3}, "origin_means"),
                      ({"along_mean": 0.0}, "along_mean"), ({"along_std": -1.0}, "along_std")):
        with pytest.raises(ValueError, match=name):
            study.mirrored_density({**study.RARE_MIRRORED, **bad})


def test_mirrored_coverage_resumes_from_its_store(tmp_path, monkeypatch):
    """Each finished seed is one line of the store as soon as it ends: a second call runs
    only the seeds not there, an interrupted seed loses nothing before it, and the table
    counts the intervals holding the reference, among all and among status 0."""
    from gearuq_studies import geared_rotor_dynamic_factor as study

    calls = []

    def fake(x, seed, grade, settings, execution, options=None):
        calls.append(seed)
        if seed == 4 and len(calls) == 3:
            raise KeyboardInterrupt
        pf = 1.5e-6 * (1.0 + 0.1 * (seed - 3))
        return {"pf": pf, "lower": pf * 0.9, "upper": pf * 1.1, "status": seed % 2,
                "ess": 40.0, "n_fail": 100, "runs": 7, "max_share": 0.1}

    monkeypatch.setattr(study, "mirrored_given_acceptance", fake)
    store = tmp_path / "cov.jsonl"
    execution = {"executor": "serial"}
    with pytest.raises(KeyboardInterrupt):
        study.mirrored_coverage([1, 2, 4, 3], store, execution=execution)
    assert [json.loads(line)["seed"] for line in store.read_text().splitlines()] == [1, 2]
    out = study.mirrored_coverage([1, 2, 3, 4], store, execution=execution)
    assert calls == [1, 2, 4, 3, 4]
    ref = study.LINES_REFERENCE["pf"]
    holds = {r["seed"]: r["holds"] for r in out["rows"]}
    for seed in (1, 2, 3, 4):
        pf = 1.5e-6 * (1.0 + 0.1 * (seed - 3))
        assert holds[seed] == (0.9 * pf <= ref <= 1.1 * pf)
    assert out["n"] == 4 and out["held"] == sum(holds.values())
    assert out["n_status0"] == 2 and out["held_status0"] == holds[2] + holds[4]
    assert study.mirrored_coverage([1, 2], store, execution=execution)["n"] == 2
    assert len(calls) == 5
    # seeds from a generator, repeated: each once, counted once
    out = study.mirrored_coverage((s for s in (2, 2, 1)), store, execution=execution)
    assert out["n"] == 2 and len(calls) == 5
    # a last line cut short by an interruption is redone; other settings are refused
    store.write_text(store.read_text() + '{"seed": 5, "pf": 1.')
    assert study.mirrored_coverage([5], store, execution=execution)["n"] == 1
    assert calls[-1] == 5
    assert study.mirrored_coverage([1, 2, 3, 4, 5], store, execution=execution)["n"] == 5
    assert len(calls) == 6
    with pytest.raises(ValueError, match="other settings"):
        study.mirrored_coverage([1], store, execution=execution,
                                settings={**study.RARE_MIRRORED, "n_rotor": 10})


@pytest.mark.e2e
def test_rare_stage_mirrored_against_an_independent_count():
    """The mirrored importance sampler on the small rotor (3 speeds) at a moderate level,
    against the crude count of accepted pairs: rejected draws cost no run, and the estimate
    agrees with the count."""
    from gearuq_studies import geared_rotor_dynamic_factor as study

    x = 1.22
    # the rare settings aim at X = 1.77 (ESS 10 of 133 failing here): a density for this level
    settings = {**study.QUICK_MIRRORED, "n_rotor": 200, "batch": 100, "min_ess": 30.0,
                "along_mean": 1.0, "along_std": 1.5, "origin_means": (0.0,) * 9,
                "origin_std": (1.2,) * 9}
    res = study.mirrored_given_acceptance(x, 5, 6, settings, {"executor": "serial"},
                                          options=_SMALL_ROTOR)
    assert res["runs"] < 200 and res["lower"] <= res["pf"] <= res["upper"]
    assert res["status"] in (0, 1), res["message"]
    assert res["pf_over_x"]["pf"][f"{x:.3f}"] == pytest.approx(res["pf"], rel=1e-9)
    _agrees_with_a_crude_count(res, _SMALL_ROTOR, x)
