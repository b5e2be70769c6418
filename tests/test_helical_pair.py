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
    with pytest.raises(ValueError, match="option 'length_scale'.*> 0"):
        model.response({}, [0.0, 1.0], outputs=["p1"], length_scale=0.0)
    with pytest.raises(ValueError, match="option 'length_scale'.*'b5'"):
        model.response({}, [0.0, 1.0], outputs=["p1"], length_scale="b6")
    with pytest.raises(ValueError, match="option 'mesh_damping'.*'in_contact'"):
        model.response({}, [0.0, 1.0], outputs=["p1"], mesh_damping="gated")
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


@pytest.mark.e2e  # over 10 s: CI runs it with the e2e marker
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


# --------------------------------------------------------------------------------------------
# Vibration about the static state, length scale, gated mesh damping, coupled resonance
# --------------------------------------------------------------------------------------------

_STATIC_CASES = {  # loads, clearances, a constant error and the back flank
    "T": [2600.0, 300.0, 0.0, 2600.0, 1500.0], "e_0": [0.0, 3e-6, -5e-6, 0.0, 1e-5],
    "b1": [5.35e-5, 0.0, 1e-4, 5.35e-5, 2e-6], "k_r": [5.968e6, 1e9, 1e8, 5.968e6, 3e7],
    "b5": [2e-5, 0.0, 2e-5, 1e-4, 5e-6], "s": [0.1, 0.3, 0.0, 0.1, 0.2],
}


def test_static_state_is_an_equilibrium_of_the_compiled_equations(model):
    """rhs(static state) = 0 once the excitation is removed (s = 0, e_a = 0): the closed form
    of physics.static_state checked by the kernel, which shares no code with it."""
    coef, _ = model.coefficients(model.validate_params(_STATIC_CASES))
    q = model.static_state(coef)
    still = coef.copy()
    still[:, 1] = 0.0  # I_S
    still[:, 3] = 0.0  # I_EPSA
    for i in range(coef.shape[0]):
        acc = np.zeros(20)
        kernel.rhs(0.7, np.concatenate([q[i], np.zeros(10)]), still[i], acc)
        load = np.abs(still[i, I_ETA:I_ETA + N_DOF] * q[i]).max()
        assert np.abs(acc).max() <= 1e-12 * load, (i, acc)


def test_vibration_outputs_are_p_minus_the_static_state(model):
    t = np.linspace(0.0, 60.0, 31)
    names = [f"p{i}" for i in range(1, 11)] + [f"v{i}" for i in range(1, 11)]
    names += ["x_p", "vib_x_p", "theta_gz", "vib_theta_gz"]
    ds = model.response(_STATIC_CASES, t, outputs=names)
    # the route the demo used before: the same samples without excitation, one instant
    still = model.response({**_STATIC_CASES, "s": [0.0] * 5, "e_a": [0.0] * 5}, t[:1],
                           outputs=[f"p{i}" for i in range(1, 11)])
    assert (ds["status"] == 0).all() and (still["status"] == 0).all()
    for i in range(1, 11):
        np.testing.assert_allclose(ds[f"v{i}"], ds[f"p{i}"] - still[f"p{i}"][:, :1].values,
                                   rtol=0, atol=1e-9 * float(np.abs(ds[f"p{i}"]).max()))
    # SI vibration = nondimensional vibration in metres / radians
    r_g = 6e-3 * 84 / (2 * np.cos(np.radians(17)))
    np.testing.assert_allclose(ds["vib_x_p"], ds["v1"] * 1e-5, rtol=1e-12)
    np.testing.assert_allclose(ds["vib_theta_gz"], ds["v10"] * 1e-5 / r_g, rtol=1e-12)
    # the static state is not the initial state when the stiffness at tau = 0 is not its mean
    assert float(np.abs(ds["v5"][0, 0])) > 1e-3


def test_vibration_has_zero_mean_in_the_linear_case(model):
    """LTI system (no dead zones): the steady response oscillates about the static state."""
    params = _linear_case(e_0=4e-6)
    p = model.validate_params(params)
    omega = float(model.coefficients(p)[0][0, 0])
    period = 2 * np.pi / omega
    t = 400 * period + np.linspace(0, period, 129)[:-1]
    ds = model.response(params, t, outputs=[f"v{i}" for i in range(1, 11)],
                        rtol=1e-10, atol=1e-12)
    for i in range(1, 11):
        v = ds[f"v{i}"].values[0]
        assert abs(v.mean()) < 1e-6 * max(np.abs(v).max(), 1e-3), (i, v.mean())


def test_failed_static_state_is_flagged_not_used():
    from gearuq_plugins.helical_pair.outputs import STATUS_STATIC_NOT_FINITE, assemble
    from gearuq_plugins.helical_pair.physics import PairSystem

    model = gearuq.get_model("helical_pair")
    system = model.system(model.validate_params({"T": [2600.0, 2600.0]}))
    coef = system.coef.copy()
    coef[1, I_V + 4] = 0.0  # no torsional projection: the torque balance has no solution
    broken = PairSystem(coef=coef, gear=system.gear)
    states = np.zeros((2, 3, 1))
    data, status = assemble(broken, ["v1", "p1"], states=states, save=np.array([0]),
                            tau=np.arange(3.0), length_scale=1e-5,
                            status=np.zeros(2, dtype=np.int8))
    assert status.tolist() == [0, STATUS_STATIC_NOT_FINITE]
    assert np.isfinite(data["v1"][0]).all() and not np.isfinite(data["v1"][1]).any()


def test_length_scale_b5_is_the_seed_scaling(model):
    t = np.linspace(0.0, 30.0, 16)
    params = {"b5": [2e-5, 5e-6, 0.0]}
    ref = model.response(params, t, outputs=["p1", "v5", "dp6", "x_p"])
    seed = model.response(params, t, outputs=["p1", "v5", "dp6", "x_p", "length_unit"],
                          length_scale="b5")
    for o in ("p1", "v5", "dp6"):
        np.testing.assert_allclose(seed[o][:2], ref[o][:2] * (1e-5 / np.array([[2e-5], [5e-6]])),
                                   rtol=1e-13)
    np.testing.assert_allclose(seed["length_unit"][:2], [2e-5, 5e-6], rtol=1e-15)
    # b5 = 0 cannot be a unit: that sample is flagged, its SI outputs are still there
    from gearuq_plugins.helical_pair.outputs import STATUS_LENGTH_SCALE_ZERO

    assert seed["status"].values.tolist() == [0, 0, STATUS_LENGTH_SCALE_ZERO]
    assert np.isnan(seed["p1"][2]).all()
    np.testing.assert_array_equal(seed["x_p"], ref["x_p"])
    si_only = model.response(params, t, outputs=["x_p"], length_scale="b5")
    assert (si_only["status"] == 0).all()
    assert seed.attrs["length_scale"].startswith("b5")


def _gated():
    return {"b5": [2e-5, 0.0, 2e-5], "s": [0.1, 0.3, 0.0]}


def test_gated_kernel_equals_numpy_twin_and_sided_rhs():
    """Gated mesh: compiled rhs = NumPy twin; the frozen-side rhs with the sides of the state
    gives the same accelerations."""
    from gearuq_plugins.helical_pair.layout import N_COEF, N_SWITCH_GATED
    from gearuq_plugins.helical_pair.physics import rhs_numpy

    model = gearuq.get_model("helical_pair")
    prob = model.ode_problem(_gated(), mesh_damping="in_contact")
    rng = np.random.default_rng(5)
    for i in range(3):
        for _ in range(40):
            y = prob["y0"][i] + rng.normal(0, 3.0, 20)
            tau = rng.uniform(0, 100)
            out, sided = np.zeros(20), np.zeros(20)
            kernel.rhs(tau, y, prob["coef"][i], out)
            np.testing.assert_allclose(out, rhs_numpy(tau, y, prob["coef"][i]),
                                       rtol=1e-12, atol=1e-12)
            g = np.zeros(N_SWITCH_GATED)
            kernel.switch(tau, y, prob["coef"][i], g)
            p = np.concatenate([prob["coef"][i], np.sign(g)])
            assert p.size == N_COEF + N_SWITCH_GATED
            kernel.rhs_sides(tau, y, p, sided)
            np.testing.assert_allclose(sided, out, rtol=1e-12, atol=1e-12)


def test_gated_mesh_equals_default_without_damping_or_contact_loss(model):
    t = np.linspace(0.0, 120.0, 61)
    tight = {"rtol": 1e-10, "atol": 1e-12}
    # zeta_m = 0: nothing to gate and k f(d) is compressive on both flanks
    loss = {"e_a": [4e-5], "T": [300.0], "zeta_m": [0.0]}
    a = model.response(loss, t, outputs=["p5", "p1"], **tight)
    b = model.response(loss, t, outputs=["p5", "p1"], mesh_damping="in_contact", **tight)
    assert int(a["n_events"][0]) > 10
    for o in ("p5", "p1"):
        np.testing.assert_allclose(b[o], a[o], rtol=0, atol=1e-7 * float(np.abs(a[o]).max()))
    # heavy load, small error: the mesh never opens, the force never pulls
    held = {"e_a": [2e-6], "T": [2600.0]}
    a = model.response(held, t, outputs=["p5", "mesh_force"], **tight)
    b = model.response(held, t, outputs=["p5", "mesh_force"], mesh_damping="in_contact", **tight)
    assert float(a["mesh_force"].min()) > 0
    np.testing.assert_allclose(b["p5"], a["p5"], rtol=1e-12)


@pytest.mark.e2e  # over 10 s: CI runs it with the e2e marker
def test_gated_mesh_at_the_seed_point(model):
    """3600 rpm, 2600 N m: the default lets ~10 kN of damping force act across the open gap
    (35 % of the static load) and pulls in contact; the gated mesh does neither, and both
    event treatments agree on it."""
    t = np.linspace(0.0, 150.0, 2401)
    par = {"n": [3600.0]}
    outs = ["mesh_force", "mesh_deflection", "v5"]
    free = model.response(par, t, outputs=outs, rtol=1e-9, atol=1e-11)
    gate = model.response(par, t, outputs=outs, rtol=1e-9, atol=1e-11,
                          mesh_damping="in_contact")
    retake = model.response(par, t, outputs=outs, rtol=1e-9, atol=1e-11, method="dopri5",
                            freeze_sides=False, mesh_damping="in_contact")
    static_load = 2600 / (6e-3 * 34 / (2 * np.cos(np.radians(17)))
                          * np.cos(np.radians(25)) * np.cos(np.radians(17)))
    d, f = free["mesh_deflection"].values[0], free["mesh_force"].values[0]
    gap = np.abs(d) <= 2e-5
    assert 0.30 < np.abs(f[gap]).max() / static_load < 0.40
    assert f[d > 2e-5].min() < -0.2 * static_load  # the default pulls the teeth together
    d, f = gate["mesh_deflection"].values[0], gate["mesh_force"].values[0]
    assert (f[np.abs(d) <= 2e-5] == 0).all()
    assert f[d > 2e-5].min() >= 0.0 and (d < -2e-5).any() and f[d < -2e-5].max() <= 0.0
    scale = float(np.abs(gate["v5"]).max())
    assert float(np.abs(retake["v5"] - gate["v5"]).max()) < 1e-6 * scale
    assert float(np.abs(free["v5"] - gate["v5"]).max()) > 0.1 * scale  # it matters


def test_seed_operating_points_sit_near_the_coupled_mesh_resonance(model):
    """Linearised in contact (kappa = 1), from the SI matrices of the theory page: the mode
    that carries the mesh is at 1.173 omega_n with 9.5 % modal damping; the seed's mesh
    frequencies (3600, 4000 rpm) are 0.990 and 1.100 omega_n."""
    from gearuq_plugins.helical_pair.physics import (
        generalised_masses,
        mesh_direction,
        support_stiffness,
    )

    p = model.validate_params({"n": [3600.0, 4000.0]})
    gd = model.gear_data(p)
    M = generalised_masses(gd)[0]
    w = mesh_direction(gd)[0]
    k_m = gd["k_mesh"][0]
    k_s = support_stiffness(p, gd)[0]
    m_e = 1 / (1 / M[4] + 1 / M[9])
    omega_n = np.sqrt(k_m / m_e)
    c_m = 2 * 0.08 * np.sqrt(k_m * m_e)
    K = np.diag(k_s) + k_m * np.outer(w, w)
    C = np.diag(2 * 0.05 * np.sqrt(k_s * M)) + c_m * np.outer(w, w)
    Minv = np.diag(1 / M)
    A = np.block([[np.zeros((10, 10)), np.eye(10)], [-Minv @ K, -Minv @ C]])
    lam, vec = np.linalg.eig(A)
    mesh_share = np.abs(w @ vec[:10]) ** 2 / np.sum(np.abs(vec[:10]) ** 2, axis=0)
    j = int(np.argmax(np.where(lam.imag > 0, mesh_share, -1)))
    assert abs(lam[j]) / omega_n == pytest.approx(1.173, abs=1e-3)
    assert -lam[j].real / abs(lam[j]) == pytest.approx(0.095, abs=1e-3)
    mesh_ratio = 2 * np.pi * p["n"] * 34 / 60 / omega_n
    np.testing.assert_allclose(mesh_ratio, [0.990, 1.100], atol=1e-3)


@pytest.mark.e2e
def test_retake_does_not_stall_where_the_force_jumps(model):
    """Gated mesh, re-taken steps: at a contact onset the damping force jumps, and the
    switching function at the end of a step cut for it can stay within rounding noise on the
    old side. The integrator used to cut ever shorter steps there (step limit at tau = 1.6);
    it now registers that crossing at the start of the next step."""
    par = {"n": [3000.0], "T": [1000.0], "e_a": [2e-5], "b5": [5e-6]}
    t = np.linspace(0.0, 200.0, 801)
    common = {"outputs": ["v5"], "mesh_damping": "in_contact", "rtol": 1e-9, "atol": 1e-11}
    retake = model.response(par, t, method="dopri5", freeze_sides=False, max_steps=200_000,
                            **common)
    frozen = model.response(par, t, **common)
    assert int(retake["status"][0]) == 0 and int(frozen["status"][0]) == 0
    assert int(retake["n_events"][0]) == int(frozen["n_events"][0]) > 100
    scale = float(np.abs(frozen["v5"]).max())
    assert float(np.abs(retake["v5"] - frozen["v5"]).max()) < 1e-6 * scale
