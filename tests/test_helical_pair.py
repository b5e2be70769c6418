"""Physics checks of the helical_pair plugin: oracles, conservation, symmetry, hard cases."""

import numpy as np
import pytest

import gearuq
from gearuq.testing import check_model
from gearuq_plugins.helical_pair import DOFS, kernel
from gearuq_plugins.helical_pair.layout import I_B5, I_ETA, I_MU, I_V, I_XI, I_ZETA, N_DOF

SI_DOFS = [d[0] for d in DOFS]


@pytest.fixture(scope="module")
def model():
    return gearuq.get_model("helical_pair")


def test_conformance(model):
    check_model(model, np.linspace(0.0, 5.0, 6), n_samples=3)


def test_mesh_stiffness_is_iso_6336(model):
    from gearuq.gears.geometry import seed000_pair
    from gearuq.gears.iso6336 import mesh_stiffness

    ds = model.response({}, outputs=["k_mesh", "contact_ratio"])
    ref = mesh_stiffness(seed000_pair())
    assert float(ds["k_mesh"][0]) == pytest.approx(ref.k_mesh_N_per_m, rel=1e-12)
    assert float(ds["contact_ratio"][0]) == pytest.approx(ref.eps_alpha, rel=1e-12)


def test_static_equilibrium_is_kept(model):
    """No excitation (s = 0, e = 0): the static initial state is an exact equilibrium."""
    t = np.linspace(0, 50, 11)
    ds = model.response({"s": [0.0], "e_a": [0.0], "T": [2600.0]}, t,
                        outputs=["mesh_force", "p1", "dp5"], rtol=1e-10, atol=1e-12)
    r_p = 6e-3 * 34 / (2 * np.cos(np.radians(17)))
    n_y = np.cos(np.radians(25)) * np.cos(np.radians(17))
    np.testing.assert_allclose(ds["mesh_force"], 2600 / (r_p * n_y), rtol=1e-9)
    np.testing.assert_allclose(ds["p1"], ds["p1"][0, 0], rtol=1e-9)
    assert np.abs(ds["dp5"]).max() < 1e-8


def _linear_case(**extra):
    base = dict(s=0.0, b5=0.0, b1=0.0, b2=0.0, b3=0.0, b4=0.0, k_r=1e9, k_a=1e9,
                zeta_s=0.2, e_a=5e-6, phi=0.0)
    base.update(extra)
    return {k: np.atleast_1d(float(v)) for k, v in base.items()}


def test_linear_time_invariant_matches_frequency_response(model):
    """b5 = b_i = 0, s = 0: LTI system; steady-state amplitude from (K - W^2 M + i W C) X = F."""
    params = _linear_case()
    p = model.validate_params(params)
    coef, _ = model.coefficients(p)
    c = coef[0]
    v, mu = c[I_V:I_V + N_DOF], c[I_MU:I_MU + N_DOF]
    eta, xi, zeta = c[I_ETA:I_ETA + N_DOF], c[I_XI:I_XI + N_DOF], c[I_ZETA]
    omega = c[0]
    eps_a = 5e-6 / 1e-5
    K = np.diag(eta) + (mu * v)[:, None] * v[None, :]
    C = np.diag(xi) + 2 * zeta * (mu * v)[:, None] * v[None, :]
    F = mu * v * eps_a * (1 + 2j * zeta * omega)  # from eps = eps_a exp(i W tau)
    X = np.linalg.solve(K - omega**2 * np.eye(N_DOF) + 1j * omega * C, F)
    period = 2 * np.pi / omega
    t = 400 * period + np.linspace(0, period, 257)[:-1]
    ds = model.response(params, t, outputs=[f"p{i + 1}" for i in range(N_DOF)],
                        rtol=1e-10, atol=1e-12)
    for i in range(N_DOF):
        x = ds[f"p{i + 1}"].values[0]
        amp = (x.max() - x.min()) / 2
        assert amp == pytest.approx(abs(X[i]), rel=2e-4, abs=1e-7 * eps_a), SI_DOFS[i]


def test_rigid_rotation_produces_no_mesh_force():
    """Adding r_p th_p = r_g th_g (p5 = p10) leaves every acceleration unchanged."""
    model = gearuq.get_model("helical_pair")
    p = model.validate_params({"b5": [2e-5]})
    coef, _ = model.coefficients(p)
    y = model.initial_state(coef)[0] + np.random.default_rng(1).normal(0, 0.5, 20)
    a0, a1 = np.zeros(20), np.zeros(20)
    kernel.rhs(0.3, y, coef[0], a0)
    y2 = y.copy()
    y2[4] += 3.7
    y2[9] += 3.7
    kernel.rhs(0.3, y2, coef[0], a1)
    np.testing.assert_allclose(a1, a0, rtol=0, atol=1e-12 * np.abs(a0).max())


def test_mesh_coupling_is_symmetric():
    """Mass-weighted stiffness (Jacobian of the forces in contact) is symmetric."""
    model = gearuq.get_model("helical_pair")
    p = model.validate_params({"s": [0.0], "b1": [0.0], "b2": [0.0], "b3": [0.0]})
    coef, _ = model.coefficients(p)
    c = coef[0]
    y = model.initial_state(coef)[0]
    J = np.zeros((N_DOF, N_DOF))
    h = 1e-4
    for j in range(N_DOF):
        yp, ym = y.copy(), y.copy()
        yp[j] += h
        ym[j] -= h
        ap, am = np.zeros(20), np.zeros(20)
        kernel.rhs(0.0, yp, c, ap)
        kernel.rhs(0.0, ym, c, am)
        J[:, j] = (ap[N_DOF:] - am[N_DOF:]) / (2 * h)
    mu = c[I_MU:I_MU + N_DOF]
    stiffness = -J / mu[:, None]  # = diag(M) K / (m_e omega_n^2)
    np.testing.assert_allclose(stiffness, stiffness.T, rtol=1e-7, atol=1e-9)
    assert np.all(np.linalg.eigvalsh(0.5 * (stiffness + stiffness.T)) > -1e-9)


def test_rigid_body_momentum_is_conserved(model):
    """M_5 p_5 + M_10 p_10 (rigid rotation) stays zero, with backlash and contact loss."""
    t = np.linspace(0, 300, 301)
    params = {"e_a": [1.08e-5, 4e-5], "T": [2600.0, 300.0]}
    ds = model.response(params, t, outputs=["p5", "p10"], rtol=1e-9, atol=1e-10)
    coef, _ = model.coefficients(model.validate_params(params))
    mu5, mu10 = coef[:, I_MU + 4], coef[:, I_MU + 9]
    rigid = ds["p5"].values / mu5[:, None] + ds["p10"].values / mu10[:, None]
    scale = np.abs(ds["p5"].values / mu5[:, None]).max()
    assert np.abs(rigid).max() < 1e-7 * scale


def test_error_decreases_with_rtol_on_dead_zone_case(model):
    params = {"e_a": [4e-5], "T": [300.0]}  # light load, large error: contact loss
    t = np.linspace(100, 150, 51)
    ref = model.response(params, t, outputs=["p5"], method="dop853", rtol=1e-12, atol=1e-13)
    assert int(ref["n_events"][0]) > 10  # the case really switches
    errors = []
    for rtol in (1e-4, 1e-6, 1e-8):
        ds = model.response(params, t, outputs=["p5"], rtol=rtol, atol=rtol * 1e-2)
        errors.append(float(np.abs(ds["p5"] - ref["p5"]).max()))
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 1e-5 * float(np.abs(ref["p5"]).max())


def test_si_outputs_and_time_axis(model):
    tau = np.linspace(0, 20, 21)
    ds = model.response({}, tau, outputs=["p1", "x_p", "p5", "theta_pz", "dp1", "x_p_dot",
                                          "omega_n"])
    L = 1e-5
    r_p = 6e-3 * 34 / (2 * np.cos(np.radians(17)))
    np.testing.assert_allclose(ds["x_p"], ds["p1"] * L, rtol=1e-14)
    np.testing.assert_allclose(ds["theta_pz"], ds["p5"] * L / r_p, rtol=1e-14)
    omega_n = float(ds["omega_n"][0])
    np.testing.assert_allclose(ds["x_p_dot"], ds["dp1"] * L * omega_n, rtol=1e-14)
    # the same instants asked in seconds give the same trajectory
    ds_s = model.response({}, tau / omega_n, outputs=["p1"], time="s")
    assert ds_s["time"].attrs["units"] == "s"
    np.testing.assert_allclose(ds_s["p1"], ds["p1"], rtol=1e-9, atol=1e-9)


def test_fourier_stiffness_equals_cosine_form():
    t = np.linspace(0, 40, 41)
    a = gearuq.get_model("helical_pair").response({"s": [0.1]}, t, outputs=["p5"], rtol=1e-10)
    b = gearuq.get_model("helical_pair", stiffness_harmonics=[(0.1, 0.0)]).response(
        {"s": [0.0]}, t, outputs=["p5"], rtol=1e-10)
    np.testing.assert_allclose(a["p5"], b["p5"], rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="stiffness_harmonics"):
        gearuq.get_model("helical_pair", stiffness_harmonics=[(0.7, 0.5)])


@pytest.mark.parametrize("case", [
    {"b5": [0.0]}, {"b5": [1e-12]}, {"k_r": [1e13], "k_a": [1e13]}, {"k_r": [1e4], "k_a": [1e4]},
    {"zeta_m": [0.0], "zeta_s": [0.0]}, {"e_a": [1e-4], "T": [50.0]},
    {"b5": [1e-3], "b1": [1e-3], "b2": [1e-3], "b3": [1e-3], "b4": [1e-3]},
    {"n": [30000.0], "s": [0.9]}, {"T": [0.0], "e_a": [0.0]},
])
def test_hard_cases_do_not_crash_or_mislead(model, case):
    t = np.linspace(0, 200, 201)
    ds = model.response(case, t, outputs=["p1", "p5", "mesh_force"], max_steps=400_000)
    st = int(ds["status"][0])
    if st == 0:
        assert np.all(np.isfinite(ds["p5"])) and np.all(np.isfinite(ds["mesh_force"]))
    else:  # a flagged sample keeps its finite prefix and says why
        assert ds["status"].attrs["flag_meanings"]


def test_b5_to_zero_is_continuous(model):
    t = np.linspace(50, 60, 11)
    a = model.response({"b5": [0.0]}, t, outputs=["p5"], rtol=1e-10, atol=1e-12)
    b = model.response({"b5": [1e-12]}, t, outputs=["p5"], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(a["p5"], b["p5"], atol=1e-5)


def test_long_window(model):
    t = np.linspace(0, 2000, 2001)
    ds = model.response({"n": [3600.0]}, t, outputs=["p1"])
    assert int(ds["status"][0]) == 0
    assert np.all(np.isfinite(ds["p1"]))


def test_step_limit_is_flagged_not_dropped(model):
    t = np.linspace(0, 200, 11)
    ds = model.response({"b5": [2e-5, 2e-5]}, t, outputs=["p1"], max_steps=50)
    assert ds.sizes["sample"] == 2
    assert np.all(ds["status"].values == 1)
    assert np.isnan(ds["p1"].values[:, -1]).all()


def test_bad_input(model):
    with pytest.raises(ValueError, match="'b5'.*outside valid range"):
        model.response({"b5": [-1e-6]}, [0.0, 1.0], outputs=["p1"])
    with pytest.raises(ValueError, match="'z1'.*whole number"):
        model.response({"z1": [34.5]}, [0.0, 1.0], outputs=["p1"])
    with pytest.raises(ValueError, match="option 'time'.*'ms'.*'tau', 's'"):
        model.response({}, [0.0, 1.0], outputs=["p1"], time="ms")
    with pytest.raises(ValueError, match="option 'rtol'.*-5.*valid: float in"):
        model.response({}, [0.0, 1.0], outputs=["k_mesh"], rtol=-5)
    with pytest.raises(ValueError, match="unknown option.*'rtoll'.*valid: time"):
        model.response({}, [0.0, 1.0], outputs=["p1"], rtoll=1e-6)
    with pytest.raises(ValueError, match="length_scale"):
        gearuq.get_model("helical_pair", length_scale=0.0)
    with pytest.raises(ValueError, match="sample 0.*contact ratio|eps_alpha|geometry"):
        model.response({"z1": [8.0], "x_shift_p": [-0.5]}, [0.0, 1.0], outputs=["p1"])


def test_contact_loss_is_located(model):
    """Near resonance with a large error the mesh separates; events are counted."""
    ds = model.response({"e_a": [6e-5], "T": [200.0]}, np.linspace(0, 100, 101),
                        outputs=["mesh_deflection"])
    b5 = 2e-5
    d = ds["mesh_deflection"].values[0]
    assert (np.abs(d) <= b5).any()  # separation happened
    assert int(ds["n_events"][0]) >= 2
    assert I_B5 > 0


def test_compiled_kernel_equals_numpy_twin(model):
    """Two independent implementations of the equations agree on random states."""
    from gearuq_plugins.helical_pair.physics import rhs_numpy

    prob = model.ode_problem({"b5": [2e-5, 0.0], "s": [0.1, 0.3]})
    rng = np.random.default_rng(3)
    for i in range(2):
        for _ in range(20):
            y = prob["y0"][i] + rng.normal(0, 3.0, 20)
            tau = rng.uniform(0, 100)
            out = np.zeros(20)
            kernel.rhs(tau, y, prob["coef"][i], out)
            np.testing.assert_allclose(out, rhs_numpy(tau, y, prob["coef"][i]),
                                       rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_frozen_sides_and_retake_agree_with_tight_reference(model, method):
    """Both event treatments converge to the same trajectory on a contact-loss case."""
    params = {"e_a": [4e-5], "T": [300.0]}
    t = np.linspace(0, 120, 61)
    ref = model.response(params, t, outputs=["p5"], method="dop853", rtol=1e-12, atol=1e-13,
                         freeze_sides=False)
    for frozen in (True, False):
        ds = model.response(params, t, outputs=["p5"], method=method, rtol=1e-9, atol=1e-11,
                            freeze_sides=frozen)
        err = float(np.abs(ds["p5"] - ref["p5"]).max())
        assert err < 1e-6 * float(np.abs(ref["p5"]).max()), (frozen, err)


def test_internally_parallel_model_runs_serially_by_default(model):
    """The compiled integrator already uses every core: no worker processes by default."""
    ds = gearuq.monte_carlo(model, model.default_space(), np.linspace(0, 5, 3), n_samples=64,
                            rng=1, outputs=["p1"], chunk_size=16, progress=False)
    assert ds.attrs["executor"] == "serial"
    assert int((ds["status"] != 0).sum()) == 0
