"""Geared-rotor dynamics: statics, reduction, harmonic balance and time integration.

Oracles sharing no code with the solvers: rigid-body equilibrium of a shaft on two bearings,
the Timoshenko midspan deflection, full-model static solutions at each mesh position,
full-model receptances, Newmark integration of the full model, and the batched integrator on
the reduced model with located contact-loss events.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from gearuq.gears.geometry import seed002_pair
from gearuq.rotor import (
    BearingElement,
    DiskElement,
    HelicalMeshElement,
    Material,
    Rotor,
    ShaftLine,
)
from gearuq.rotor.examples import seed002_rotor
from gearuq.rotor.excitation import MeshExcitation
from gearuq.rotor.geared import GearedRotorProblem, torque_load
from gearuq.rotor.harmonic_balance import synthesize
from gearuq.rotor.reduction import full_receptance
from gearuq.rotor.time_integration import initial_state, integrate_reduced, newmark_full

PAIR = seed002_pair()
K_MESH = 7.8e8


@pytest.fixture(autouse=True)
def _single_thread_blas():
    """Small dense problems: one BLAS thread is faster and keeps timings stable."""
    threadpoolctl = pytest.importorskip("threadpoolctl")
    with threadpoolctl.threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore", category=UserWarning)
        yield


def _two_shafts(k_mesh, *, material, kr, ka, helix=True, half_span=0.25, d=0.11, n_half=4):
    """Two uniform shafts, gear at midspan between two bearings, a 40 mm-wide mesh."""
    z = np.linspace(0.0, 2 * half_span, 2 * n_half + 1)
    s1 = ShaftLine(tuple(z), d, material=material, name="s1")
    s2 = ShaftLine(tuple(z), d, material=material, first_node=s1.last_node + 1,
                   axis=(PAIR.centre_distance, 0.0), spin_ratio=-1.0, name="s2")
    g1, g2 = s1.node_at(half_span), s2.node_at(half_span)
    els = s1.elements() + s2.elements()
    els += [DiskElement.from_geometry(g1, 0.04, d, 0.19, material),
            DiskElement.from_geometry(g2, 0.04, d, 0.19, material, spin_ratio=-1.0)]
    ends = (s1.first_node, s1.last_node, s2.first_node, s2.last_node)
    els += [BearingElement(n, kr, kr, ka, label=f"bearing {i + 1}") for i, n in enumerate(ends)]
    els.append(HelicalMeshElement(g1, g2, PAIR.db1 / 2, PAIR.db2 / 2, PAIR.alpha_wt,
                                  PAIR.beta_b if helix else 0.0, stiffness=k_mesh))
    return Rotor(els, shafts=[s1, s2], tags={"input": s1.first_node, "output": s2.last_node})


def _mesh_geometry(helix=True):
    a, bb = PAIR.alpha_wt, (PAIR.beta_b if helix else 0.0)
    t = np.array([math.sin(a), math.cos(a), 0.0])
    n = math.cos(bb) * t - math.sin(bb) * np.array([0.0, 0.0, 1.0])
    rw1, rw2 = PAIR.db1 / 2 / math.cos(a), PAIR.db2 / 2 / math.cos(a)
    return n, np.array([rw1, 0, 0]), np.array([-rw2, 0, 0])


def test_static_te_equals_ltca_ste_plus_bearing_contribution():
    """Rigid shafts on elastic bearings: closed-form rigid-body equilibrium of each shaft."""
    rigid = Material("rigid", E=2.06e16, G=2.06e16 / 2.6, rho=7850.0)
    kr, ka, torque = 4e8, 1.5e8, 1000.0
    rotor = _two_shafts(K_MESH, material=rigid, kr=kr, ka=ka)
    q = rotor.static(torque_load(rotor, torque))
    cb = math.cos(PAIR.beta_b)
    P = torque / (PAIR.db1 / 2 * cb)
    n, r_p, r_g = _mesh_geometry()
    delta = rotor.mesh_vector() @ q
    assert delta == pytest.approx(P / K_MESH, rel=1e-9)  # = LTCA STE with zero error
    sum_d2 = 2 * 0.25**2
    contributions = 0.0
    for force, arm, sign in ((-P * n, r_p, 1.0), (P * n, r_g, -1.0)):
        u = np.array([force[0] / (2 * kr), force[1] / (2 * kr), force[2] / (2 * ka)])
        moment = np.cross(arm, force)
        theta = np.array([moment[0] / (kr * sum_d2), moment[1] / (kr * sum_d2), 0.0])
        contributions += sign * (n @ u + np.cross(arm, n) @ theta)
    dte = rotor.transmission_error_vector() @ q
    assert dte == pytest.approx(delta - contributions, rel=1e-5)
    assert dte > delta  # bearings add to the transmission error


def test_static_te_includes_timoshenko_shaft_bending():
    """Spur mesh, rigid bearings: each gear moves by P (L^3/48EI + L/(4 kappa G A))."""
    steel = Material("steel", E=206e9, G=206e9 / 2.6, rho=7850.0)
    rotor = _two_shafts(K_MESH, material=steel, kr=1e16, ka=1e16, helix=False)
    torque = 800.0
    q = rotor.static(torque_load(rotor, torque))
    P = torque / (PAIR.db1 / 2)
    span, d = 0.5, 0.11
    A, inertia = math.pi * d**2 / 4, math.pi * d**4 / 64
    nu = 0.3
    kappa = 6 * (1 + nu) / (7 + 6 * nu)
    compliance = span**3 / (48 * steel.E * inertia) + span / (4 * kappa * steel.G * A)
    dte = rotor.transmission_error_vector() @ q
    assert dte == pytest.approx(P / K_MESH + 2 * P * compliance, rel=1e-6)


def _synthetic(P=8000.0, **kw):
    return MeshExcitation.synthetic(K_MESH, P, n_cycles=30, positions_per_cycle=16, **kw)


def _seed_problem(excitation, **kw):
    return GearedRotorProblem(lambda k: seed002_rotor(k, pair=PAIR), excitation, PAIR.z1, **kw)


def test_constant_mesh_and_zero_error_give_a_static_response_at_every_speed():
    prob = _seed_problem(_synthetic(), n_harmonics=60)
    for n in (25.0, 1000.0, 4000.0, 8000.0):
        sol = prob.steady_state(n)
        assert sol.status == 0 and sol.branch == "full_contact"
        for name in ("delta", "dte", "bearing 1 force y"):
            c = sol.channels[name]
            assert np.abs(c[1:]).max() <= 1e-12 * abs(c[0]), name
        # accelerations: round-off of the displacement scaled by (j w0)^2 only
        w_max = 60 * 2 * np.pi / sol.period
        u_static = abs(prob.reduced(n).channels["bearing 1 force y"]["static"]) / 5e8
        assert np.abs(sol.channels["bearing 1 acceleration y"]).max() < 1e-12 * u_static * w_max**2
        assert sol.delta[0].real == pytest.approx(8000.0 / K_MESH, rel=1e-12)


def test_quasi_static_limit_equals_positionwise_full_model_statics():
    """At 25 rpm the DTE is the static TE at each position; the gap is inertia (speed^2,
    undamped) and damping (speed, with modal damping), so it vanishes as speed -> 0."""
    ex = _synthetic(stiffness_harmonics={30: 0.08, 60: 0.03j},
                    error_harmonics={1: 4e-6, 30: 0.5e-6, 60: 0.2e-6j})
    gaps = {}
    for zeta in (0.0, 0.05):
        prob = _seed_problem(ex, n_harmonics=200, damping_ratio=zeta)
        rotor, load, v = prob.rotor, prob.load, prob.rotor.mesh_vector()
        te, K = rotor.transmission_error_vector(), rotor.K()
        idx = np.arange(0, ex.tau.size, 8)
        static = np.array([
            te @ rotor.static(load + ex.stiffness[i] * ex.error[i] * v,
                              stiffness=K + (ex.stiffness[i] - K_MESH) * np.outer(v, v))
            for i in idx])
        for n in (5.0, 25.0, 50.0):
            sol = prob.steady_state(n)
            t = ex.tau[idx] / (PAIR.z1 * n / 60.0)
            hb = synthesize(sol.channels["dte"], t, sol.period)
            gaps[zeta, n] = np.abs(hb - static).max() / np.ptp(static)
    assert gaps[0.0, 25.0] < 2e-5 and gaps[0.05, 25.0] < 5e-5
    assert gaps[0.0, 50.0] / gaps[0.0, 25.0] == pytest.approx(4.0, rel=0.05)
    assert gaps[0.05, 5.0] < gaps[0.05, 25.0] / 3


def test_reduction_error_against_the_full_model_falls_with_the_cutoff():
    prob = _seed_problem(_synthetic(), n_harmonics=60)
    n = 4000.0
    w = 2 * np.pi / prob.period(n) * np.arange(0, 61, 3)
    full = full_receptance(prob.rotor, prob.full_damping(), 2 * np.pi * n / 60, w)
    errors = []
    for factor in (0.75, 1.5, 3.0):
        model = prob.reduced(cutoff=factor * prob.cutoff(n) / prob.cutoff_factor)
        h = model.receptances(2 * np.pi * n / 60, w, [])["mesh"]
        errors.append(np.abs(h - full).max() / np.abs(full).max())
    assert errors[0] > errors[1] > errors[2]
    assert errors[1] < 1e-2 and errors[2] < 5e-4  # measured 4.7e-3, 1.4e-4
    # zero frequency is exact (static correction)
    assert model.receptances(0.0, np.zeros(1), [])["mesh"][0].real == pytest.approx(
        full[0].real, rel=1e-10)


@pytest.mark.e2e
def test_harmonic_balance_against_full_model_newmark():
    ex = _synthetic(stiffness_harmonics={30: 0.06}, error_harmonics={1: 3e-6, 30: 0.6e-6})
    prob = _seed_problem(ex, n_harmonics=90)
    n = 4000.0
    sol = prob.steady_state(n)
    T, rotor = prob.period(n), prob.rotor
    C = prob.full_damping() + 2 * np.pi * n / 60 * rotor.G()
    per_period = 30 * 32
    res = []
    for refine in (1, 2):
        steps = per_period * refine
        nm = newmark_full(rotor.M(), C, rotor.K(), prob.load, rotor.mesh_vector(), prob.prep,
                          T, T / steps, 7 * steps, q0=rotor.static(prob.load),
                          record_from=6 * steps + 1,
                          outputs={"dte": rotor.transmission_error_vector()})
        hb = synthesize(sol.channels["dte"], nm.t[0], T)
        res.append(np.abs(nm.channels["dte"][0] - hb).max() / np.ptp(hb))
    assert res[1] < 5e-3
    assert res[0] / res[1] > 2.5  # Newmark's second order: the gap is its own error


def test_harmonic_balance_against_batched_time_integration_with_contact_loss():
    ex = _synthetic(P=1500.0, stiffness_harmonics={30: 0.05}, error_harmonics={30: 1.0e-6})
    prob = _seed_problem(ex, n_harmonics=120, damping_ratio=0.03)
    speeds = [4400.0, 4600.0]
    sols = [prob.steady_state(s) for s in speeds]
    assert all(s.status == 0 and s.branch == "contact_loss" for s in sols)
    model = prob.reduced(max(speeds))
    T = [prob.period(s) for s in speeds]
    om = [2 * np.pi * s / 60 for s in speeds]
    y0 = np.stack([initial_state(model, prob.steady_state(s, cutoff=model.cutoff), w)
                   for s, w in zip(speeds, om, strict=True)])
    N = 512
    t = np.stack([6 * Ti + np.arange(N) * Ti / N for Ti in T])
    tr = integrate_reduced(model, prob.prep, om, T, t, y0=y0)
    assert np.all(tr.status == 0) and np.all(tr.stats["n_events"] > 0)
    for i, s in enumerate(speeds):
        sol = prob.steady_state(s, cutoff=model.cutoff)
        hb = synthesize(sol.delta, t[i], T[i])
        assert np.abs(tr.delta[i] - hb).max() < 0.03 * np.ptp(hb)
        assert np.mean(tr.force[i] <= 0) == pytest.approx(sol.contact_loss_fraction, abs=0.03)


def _compact_rotor(k):
    s1 = ShaftLine((0.0, 0.05, 0.1), 0.11, name="s1")
    s2 = ShaftLine((0.0, 0.05, 0.1), 0.11, first_node=3, axis=(PAIR.centre_distance, 0.0),
                   spin_ratio=-1.0, name="s2")
    els = s1.elements() + s2.elements() + [
        DiskElement.from_geometry(1, 0.04, 0.11, 0.19),
        DiskElement.from_geometry(4, 0.04, 0.11, 0.19, spin_ratio=-1.0)]
    els += [BearingElement(n, 1e10, 1e10, 1e10, label=f"bearing {i + 1}")
            for i, n in enumerate((0, 2, 3, 5))]
    els.append(HelicalMeshElement.from_pair(PAIR, 1, 4, stiffness=k))
    return Rotor(els, shafts=[s1, s2], tags={"input": 0, "output": 5})


@pytest.mark.e2e
def test_up_and_down_sweeps_land_on_different_branches():
    """Mesh resonance crossed with contact loss: a jump, two stable periodic responses."""
    ex = _synthetic(P=1500.0, stiffness_harmonics={30: 0.05}, error_harmonics={30: 0.6e-6})
    prob = GearedRotorProblem(_compact_rotor, ex, PAIR.z1, damping_ratio=0.01,
                              n_harmonics=60)
    speeds = np.array([3800.0, 3900.0, 3950.0, 4050.0, 4150.0])
    up = prob.sweep(speeds, verify=True)
    down = prob.sweep(speeds[::-1], verify=True)[::-1]
    i = 2  # 3950 rpm: inside the hysteresis band
    assert up[i].status == 0 and down[i].status == 0
    assert up[i].branch == "full_contact" and down[i].branch == "contact_loss"
    assert down[i].stable
    assert 2 * abs(down[i].delta[30]) > 1.4 * 2 * abs(up[i].delta[30])
    assert up[-1].branch == "contact_loss" and down[0].branch == "full_contact"


def test_hard_cases_return_a_result_or_a_flag():
    ex = _synthetic(P=1500.0, stiffness_harmonics={30: 0.05}, error_harmonics={30: 0.6e-6})
    # zero damping everywhere, away from resonance: finite, converged
    undamped = _seed_problem(ex, n_harmonics=60, damping_ratio=0.0)
    for n in (25.0, 8000.0):
        sol = undamped.steady_state(n)
        assert sol.status == 0 and np.all(np.isfinite(sol.delta))
    # grazing: scale the error so that the smallest force is just above zero
    prob = _seed_problem(_synthetic(P=1500.0, error_harmonics={30: 1e-7}), n_harmonics=60)
    lin = prob.steady_state(3000.0)
    assert lin.branch == "full_contact" and lin.min_force > 0
    margin = lin.min_force / 1500.0
    scale = 1.0 / (1.0 - margin)  # the dynamic force fluctuation is linear in the error
    for factor, branch in ((0.999, "full_contact"), (1.002, "contact_loss")):
        amp = 1e-7 * scale * factor
        p = _seed_problem(_synthetic(P=1500.0, error_harmonics={30: amp}), n_harmonics=60)
        s = p.steady_state(3000.0)
        assert s.status == 0 and s.branch == branch
        assert abs(s.min_force) < 5e-3 * 1500.0


def test_bad_inputs_raise():
    prob = _seed_problem(_synthetic(), n_harmonics=30)
    with pytest.raises(ValueError, match="speed"):
        prob.steady_state(0.0)
    with pytest.raises(ValueError, match="speed"):
        prob.steady_state(-10.0)
    with pytest.raises(ValueError, match="n_harmonics"):
        _seed_problem(_synthetic(), n_harmonics=300)
    with pytest.raises(ValueError, match="torque"):
        MeshExcitation.from_ltca(PAIR, 0.0)
    with pytest.raises(ValueError, match="stiffness"):
        MeshExcitation(np.arange(4.0), np.array([1.0, -1.0, 1.0, 1.0]), np.zeros(4), 1.0, 1,
                       np.zeros(4))


def test_a_load_the_ltca_cannot_carry_raises_with_the_positions():
    from gearuq.rotor.excitation import _check_ltca

    with pytest.raises(ValueError, match=r"torque=300.0 N m: .* 1 position\(s\) \(tau = 0.5"):
        _check_ltca(np.array([0, 1, 0]), np.array([0.0, 0.5, 1.0]), 300.0)
    _check_ltca(np.zeros(3, dtype=int), np.array([0.0, 0.5, 1.0]), 300.0)  # converged: silent


def test_ltca_tangent_equals_an_independent_finite_difference():
    """The LTCA's analytic dP/dSTE against a central difference of two more LTCA runs."""
    from gearuq.gears.ltca import ltca_setup

    setup = ltca_setup(PAIR, positions_per_cycle=4, n_pts=8)
    analytic = MeshExcitation.from_setup(setup, 1000.0)
    fd = MeshExcitation.from_setup(setup, 1000.0, tangent="finite_difference")
    np.testing.assert_allclose(analytic.stiffness, fd.stiffness, rtol=1e-6)
    # the linearised law passes through the static state: k (STE - e) = P
    np.testing.assert_allclose(analytic.stiffness * (analytic.ste - analytic.error),
                               analytic.normal_force, rtol=1e-12)


def test_real_form_solve_equals_the_complex_harmonic_balance_system():
    """The (2H+1) real equations of a real signal give the complex system's solution."""
    import scipy.linalg as sla

    from gearuq.rotor.harmonic_balance import _real_blocks, _solve_real, _two_sided

    rng = np.random.default_rng(4)
    H = 17
    dk = rng.normal(size=2 * H + 1) + 1j * rng.normal(size=2 * H + 1)
    dk[0] = dk[0].real
    h1 = rng.normal(size=H + 1) + 1j * rng.normal(size=H + 1)
    b1 = rng.normal(size=H + 1) + 1j * rng.normal(size=H + 1)
    h1[0], b1[0] = h1[0].real, b1[0].real
    T = sla.toeplitz(dk, np.conj(dk))
    x = sla.solve(np.eye(2 * H + 1) + _two_sided(h1, H)[:, None] * T, _two_sided(b1, H))
    y = _solve_real(h1, _real_blocks(dk, H), b1)
    np.testing.assert_allclose(y, x, rtol=0, atol=1e-12 * np.abs(x).max())
    np.testing.assert_allclose(y[:H], np.conj(y[H + 1:][::-1]))  # a real signal
