"""Tests of the geared rotor's steady state on a sparse set of orders (issue 27, part 2).

Oracles: on the full set of harmonics the order-restricted balance is the full harmonic
balance; in full contact with an excitation held by the set it is exact (the parametric
coupling maps the set onto itself); with contact loss it converges to the full balance as
the sidebands grow.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearuq.rotor.examples import seed002_rotor
from gearuq.rotor.excitation import MeshExcitation
from gearuq.rotor.geared import GearedRotorProblem
from gearuq.rotor.harmonic_balance import solve_periodic, synthesize
from gearuq.rotor.sideband_balance import (
    excitation_from_long_period,
    mesh_force_on_grid,
    prepare_krylov,
    prepare_orders,
    sideband_orders,
    solve_periodic_krylov,
    solve_periodic_orders,
    spectral_orders,
    synthesize_orders,
)

L = 77  # a 7/11 tooth pattern: the long period holds 77 mesh cycles


@pytest.fixture(scope="module")
def problem():
    """Yuan, Liu and Liu's rotor with a synthetic 7/11 long-period excitation: mesh orders,
    shaft orders of both gears and their sidebands; 12 um at the mesh order loses contact
    between 3500 and 5000 rpm."""
    exc = MeshExcitation.synthetic(
        6e8, 1.5e4, n_cycles=L, positions_per_cycle=12,
        stiffness_harmonics={L: 0.15, 2 * L: 0.05j},
        error_harmonics={7: 3e-6, 11: 2e-6j, L: 12e-6, L - 7: 3e-6, L + 11: 2e-6},
        mean_error=1e-6)
    return GearedRotorProblem(lambda k: seed002_rotor(k), exc, pinion_teeth=30,
                              n_harmonics=3 * L)


def _solve(problem, rpm, orders):
    model = problem.reduced(rpm)
    T, om = problem.period(rpm), 2 * math.pi * rpm / 60
    prep = prepare_orders(problem.excitation, orders)
    return prep, solve_periodic_orders(model, prep, T, om, channels=["dte"])


def _full(problem, rpm):
    model = problem.reduced(rpm)
    T, om = problem.period(rpm), 2 * math.pi * rpm / 60
    return solve_periodic(model, problem.prep, T, om, channels=["dte"])


def test_sideband_orders_of_a_hunting_pair():
    J = sideband_orders(27, 79, 2, 1)
    # shaft orders: 79 long-period harmonics per pinion turn, 27 per wheel turn
    expected = {0, 27, 79, 79 - 27, 79 + 27}
    for h in (1, 2):
        expected |= {h * 2133 + i * 79 + l * 27 for i in (-1, 0, 1) for l in (-1, 0, 1)}
    assert set(J.tolist()) == expected
    assert np.all(np.diff(J) > 0)
    with pytest.raises(ValueError, match="n_sidebands=-1"):
        sideband_orders(27, 79, 2, -1)
    with pytest.raises(ValueError, match="n_mesh_harmonics=0"):
        sideband_orders(27, 79, 0, 1)


@pytest.mark.parametrize("rpm", [3000.0, 3500.0])
def test_full_set_is_the_full_harmonic_balance(problem, rpm):
    full = _full(problem, rpm)
    _, sol = _solve(problem, rpm, np.arange(problem.n_harmonics + 1))
    assert sol.status == 0 and full.status == 0
    assert sol.branch == full.branch
    scale = np.abs(full.delta[1:]).max()
    assert np.abs(sol.delta - full.delta).max() < 1e-10 * scale
    np.testing.assert_allclose(sol.channels["dte"], full.channels["dte"], atol=1e-10 * np.abs(
        full.channels["dte"][1:]).max())


def test_exact_in_full_contact_when_the_set_holds_the_excitation(problem):
    rpm = 3000.0
    full = _full(problem, rpm)
    assert full.branch == "full_contact"
    J = sideband_orders(7, 11, 3, 2)
    J = J[J <= problem.n_harmonics]
    assert J.size < problem.n_harmonics / 2
    _, sol = _solve(problem, rpm, J)
    assert np.abs(sol.delta - full.delta[J]).max() < 1e-12 * np.abs(full.delta[1:]).max()
    # and the full solution has nothing outside the set
    outside = np.delete(full.delta, J)
    assert np.abs(outside).max() < 1e-10 * np.abs(full.delta[1:]).max()


def test_contact_loss_converges_with_the_sidebands(problem):
    rpm = 3500.0
    full = _full(problem, rpm)
    assert full.branch == "contact_loss" and full.contact_loss_fraction > 0.2
    T = problem.period(rpm)
    t = np.arange(4096) * T / 4096
    ref = synthesize(full.channels["dte"], t, T)
    errs = []
    for S in (1, 2, 3):
        J = sideband_orders(7, 11, 3, S)
        prep, sol = _solve(problem, rpm, J[J <= problem.n_harmonics])
        assert sol.status == 0 and sol.branch == "contact_loss"
        dte = synthesize_orders(sol.channels["dte"], prep.orders, t, T)
        errs.append(np.abs(dte - ref).max() / np.ptp(ref))
        force = mesh_force_on_grid(prep, sol)
        assert force.min() == 0.0  # the flanks separate: the law gives exactly zero
    assert errs[2] < errs[1] < errs[0]
    # the quantities at 3 sidebands (measured 3e-4 and 2.3e-3; pointwise 2 %)
    assert abs(np.std(dte) / np.std(ref) - 1) < 1e-3
    assert abs(np.ptp(dte) / np.ptp(ref) - 1) < 5e-3


def test_bad_input(problem):
    with pytest.raises(ValueError, match="exceed"):
        prepare_orders(problem.excitation, [10 ** 6])
    with pytest.raises(ValueError, match="-3"):
        prepare_orders(problem.excitation, [-3, 5])
    prep = prepare_orders(problem.excitation, [77])
    with pytest.raises(ValueError, match="period=0"):
        solve_periodic_orders(problem.reduced(3000.0), prep, 0.0, 300.0)


def test_spectral_orders_find_the_excitation(problem):
    exc = problem.excitation
    J = spectral_orders(exc, 3 * L, energy=1.0)
    # the synthetic excitation holds k at L, 2L and k e at the error orders and their
    # products with the stiffness harmonics: all found, nothing else
    four = exc.fourier()
    held = np.flatnonzero((np.abs(four["stiffness"][:3 * L + 1]) > 1e-9 * exc.mean_stiffness)
                          | (np.abs(four["stiffness_error"][:3 * L + 1]) > 1e-9 * abs(
                              four["stiffness_error"][0])))
    assert set(J.tolist()) == set(held.tolist()) | {0}
    few = spectral_orders(exc, 3 * L, energy=0.5, always=[L, 2 * L])
    assert {0, L, 2 * L} <= set(few.tolist()) and few.size < J.size
    with pytest.raises(ValueError, match="energy=0"):
        spectral_orders(exc, 3 * L, energy=0.0)
    with pytest.raises(ValueError, match="max_order=0"):
        spectral_orders(exc, 0)


def test_excitation_from_long_period_matches_the_ltca_route():
    from gearuq.gears.deviations import FlankDeviations, random_cumulative_pitch_deviations
    from gearuq.gears.geometry import seed002_pair
    from gearuq.gears.long_period import long_period_ltca
    from gearuq.gears.ltca import ltca, ltca_setup

    pair = seed002_pair()
    dev = FlankDeviations(Fp1=random_cumulative_pitch_deviations(30, seed=4),
                          Fp2=random_cumulative_pitch_deviations(30, seed=5))
    setup = ltca_setup(pair, positions_per_cycle=12, n_pts=10)
    ref = MeshExcitation.from_setup(setup, 600.0, deviations=dev)
    full = excitation_from_long_period(ltca(pair, torque=600.0, deviations=dev, setup=setup,
                                            keep_points=False))
    np.testing.assert_allclose(full.stiffness, ref.stiffness, rtol=1e-12)
    np.testing.assert_allclose(full.error, ref.error, rtol=0, atol=1e-15)
    assert full.n_cycles == 30 and full.normal_force == pytest.approx(ref.normal_force)
    from gearuq.gears.long_period import LongPeriodSettings

    fast = excitation_from_long_period(long_period_ltca(
        pair, dev, torque=600.0, settings=LongPeriodSettings(positions_per_cycle=12, n_pts=10)))
    assert np.abs(fast.stiffness / ref.stiffness - 1).max() < 0.03
    assert np.abs(fast.error - ref.error).max() < 0.03 * np.ptp(ref.error)


def test_krylov_on_every_harmonic_is_the_full_balance(problem):
    """GMRES with the mesh-order preconditioner on all 3 L harmonics equals the dense
    balance, in full contact and, by Newton on the contact law, with contact loss."""
    prep = prepare_krylov(problem.excitation, 3)
    assert prep.n_harmonics == problem.n_harmonics
    for rpm in (3000.0, 6000.0):
        full = _full(problem, rpm)
        assert full.branch == "full_contact"
        model = problem.reduced(rpm)
        sol = solve_periodic_krylov(model, prep, problem.period(rpm), 2 * math.pi * rpm / 60,
                                    channels=["dte"])
        assert sol.status == 0 and 0 < sol.iterations < 30
        scale = np.abs(full.delta[1:]).max()
        assert np.abs(sol.delta - full.delta).max() < 1e-9 * scale
        np.testing.assert_allclose(sol.channels["dte"], full.channels["dte"],
                                   atol=1e-9 * np.abs(full.channels["dte"][1:]).max())
    # with contact loss the AFT grid discretises the law: the dense balance's grid
    prep = prepare_krylov(problem.excitation, 3, n_time=problem.prep.n_time)
    model = problem.reduced(3500.0)
    args = (model, prep, problem.period(3500.0), 2 * math.pi * 3500.0 / 60)
    lost = solve_periodic_krylov(*args, channels=["dte"], contact_loss=False)
    assert lost.status == 4 and lost.min_force < 0.0
    # with the contact law: the dense balance's contact-loss solution (31 % apart)
    full = _full(problem, 3500.0)
    sol = solve_periodic_krylov(*args, channels=["dte"])
    assert sol.status == 0 and sol.branch == "contact_loss" == full.branch
    # the Newton steps' preconditioner holds the contact indicator's mesh-cycle average:
    # 4122 GMRES iterations with the full-contact blocks, 311 with it (exact Newton steps;
    # 80 with the inexact steps)
    assert sol.iterations < 1000
    assert abs(sol.contact_loss_fraction - full.contact_loss_fraction) < 1e-12
    assert np.abs(sol.delta - full.delta).max() < 1e-8 * np.abs(full.delta[1:]).max()
    with pytest.raises(ValueError, match="n_mesh_harmonics=0"):
        prepare_krylov(problem.excitation, 0)
    with pytest.raises(ValueError, match="n_time=900"):
        prepare_krylov(problem.excitation, 3, n_time=900)


def test_krylov_residual_from_the_gmres_products(problem):
    """In full contact the residual comes from what GMRES's products computed (the approach
    on the grid and ``((k - k_bar) delta)_j``, combined as its directions are): the
    remainder equals ``((k - k_bar) delta - k e)_j`` computed afresh from ``delta`` by FFT,
    started from zero and from a neighbouring speed's solution."""
    prep = prepare_krylov(problem.excitation, 3)
    N, H = prep.n_time, prep.n_harmonics

    def at(rpm, **kw):
        return solve_periodic_krylov(problem.reduced(rpm), prep, problem.period(rpm),
                                     2 * math.pi * rpm / 60, channels=["dte"], tol=1e-6, **kw)

    first = at(3000.0)
    for sol in (first, at(3050.0, initial=first.delta)):
        assert sol.status == 0 and sol.branch == "full_contact" and sol.iterations > 0
        grid = np.fft.irfft(sol.delta * N, n=N)
        fresh = np.fft.rfft(grid * (prep.k_grid - prep.mean_stiffness))[:H + 1] / N
        np.testing.assert_allclose(sol.remainder, fresh - prep.stiffness_error, rtol=0,
                                   atol=1e-12 * np.abs(fresh).max())


def test_krylov_contact_loss_is_bounded_by_its_iteration_budget(problem):
    """A steady state whose Newton's method needs more GMRES iterations than its budget
    returns status 1 within the budget, never loops on (a 27/79 sample near a resonance with
    contact loss ran past 2 min of CPU: up to 10 000 iterations per Newton step, 40 steps);
    started from its own solution (``newton_start``) it takes no Newton step."""
    prep = prepare_krylov(problem.excitation, 3, n_time=problem.prep.n_time)
    model = problem.reduced(3500.0)
    args = (model, prep, problem.period(3500.0), 2 * math.pi * 3500.0 / 60)
    sol = solve_periodic_krylov(*args, channels=["dte"])
    assert sol.status == 0 and sol.branch == "contact_loss"
    linear = solve_periodic_krylov(*args, channels=["dte"], contact_loss=False).iterations
    assert sol.iterations > linear + 20  # Newton's steps took GMRES iterations of their own
    for budget in (linear + 10, sol.iterations // 2, linear - 1):
        cut = solve_periodic_krylov(*args, channels=["dte"], max_iter=budget)
        assert cut.status == 1 and cut.iterations <= budget
    again = solve_periodic_krylov(*args, channels=["dte"], newton_start=sol.delta)
    assert again.status == 0 and again.iterations == linear
    assert np.abs(again.delta - sol.delta).max() < 1e-12 * np.abs(sol.delta[1:]).max()
    # a start worse than the linear solution is not taken: the same Newton path
    worse = solve_periodic_krylov(*args, channels=["dte"], newton_start=10.0 * sol.delta)
    assert worse.iterations == sol.iterations
    np.testing.assert_array_equal(worse.delta, sol.delta)


# 2-6 s of CPU: CI runs it with the end-to-end runs (-m e2e)
@pytest.mark.e2e
def test_periodic_state_by_integration_against_an_independent_integrator(problem):
    """The reduced rotor integrated long period by long period (classical Runge-Kutta, the
    contact law at each stage) until its state returns to itself, against the adaptive
    integrator with located switches (``integrate_reduced``, dop853 at rtol 1e-10) run five
    long periods from rest: the same contact-loss share, the approach within the step's
    error, which falls as h^2 with contact loss (switches inside steps) and as h^4 in full
    contact; Newton on the balance agrees to its harmonic truncation."""
    from gearuq.rotor.sideband_balance import solve_periodic_by_integration
    from gearuq.rotor.time_integration import integrate_reduced

    prep = prepare_krylov(problem.excitation, 3, n_time=problem.prep.n_time)
    N, H = prep.n_time, prep.n_harmonics
    for rpm, order in ((3500.0, 2), (6000.0, 4)):
        model, T = problem.reduced(rpm), problem.period(rpm)
        om = 2 * math.pi * rpm / 60
        ref = integrate_reduced(model, problem.prep, [om], [T], 5 * T + np.arange(N) * T / N,
                                rtol=1e-10, atol_scale=1e-9)
        assert ref.status[0] == 0
        d_ref = np.fft.irfft(np.fft.rfft(ref.delta[0])[:H + 1], n=N)  # harmonics 0..H
        errors = []
        for steps in (2, 4):
            sol = solve_periodic_by_integration(model, prep, T, om, channels=["dte"],
                                                steps_per_instant=steps)
            assert sol.status == 0 and sol.start == "time_integration" and sol.residual < 1e-6
            assert sol.iterations <= 8
            assert abs(sol.contact_loss_fraction - np.mean(ref.force[0] <= 0.0)) <= 2.0 / N
            errors.append(np.abs(np.fft.irfft(sol.delta * N, n=N) - d_ref).max()
                          / np.ptp(ref.delta[0]))
        assert errors[0] < 5e-3 and errors[0] / errors[1] > 0.7 * 2.0 ** order, errors
        full = _full(problem, rpm)
        assert full.status == 0 and sol.branch == full.branch
        # the balance keeps harmonics 0..H of the response, the integration every mode
        scale = np.abs(full.delta[1:]).max()
        assert np.abs(sol.delta - full.delta).max() < (2e-2 if order == 2 else 1e-3) * scale
        np.testing.assert_allclose(sol.channels["dte"][1:], full.channels["dte"][1:], rtol=0,
                                   atol=2e-2 * np.abs(full.channels["dte"][1:]).max())
    # started from the balance's solution it is periodic at once (2 periods: the check)
    started = solve_periodic_by_integration(model, prep, T, om, channels=["dte"], start=full)
    assert started.status == 0 and started.iterations <= 3
    # a state that has not returned to itself within max_periods: said so (status 3)
    model = problem.reduced(3500.0)
    args = (model, prep, problem.period(3500.0), 2 * math.pi * 3500.0 / 60)
    # the back flank, met over a fifth of the period with the backlash half the smallest
    # approach without it: as the adaptive integrator with located switches
    free = solve_periodic_by_integration(*args)
    backlash = -0.5 * free.min_approach
    back = solve_periodic_by_integration(*args, backlash=backlash)
    ref = integrate_reduced(model, problem.prep, [args[3]], [args[2]],
                            args[2] * (5 + np.arange(N) / N), rtol=1e-10, atol_scale=1e-9,
                            backlash=backlash)
    assert back.status == 0 and back.branch == "back_flank_contact"
    assert back.back_contact_fraction > 0.2
    assert abs(back.back_contact_fraction - np.mean(ref.force[0] < 0.0)) <= 2.0 / N
    assert abs(back.contact_loss_fraction - np.mean(ref.force[0] == 0.0)) <= 2.0 / N
    d_ref = np.fft.irfft(np.fft.rfft(ref.delta[0])[:H + 1], n=N)
    assert np.abs(np.fft.irfft(back.delta * N, n=N) - d_ref).max() < 5e-3 * np.ptp(d_ref)
    short = solve_periodic_by_integration(*args, max_periods=2, tol=1e-15)
    assert short.status == 3 and short.iterations == 2
    for bad, match in (({"tol": 0.0}, "tol=0.0"), ({"max_periods": 1}, "max_periods=1"),
                       ({"steps_per_instant": 0}, "steps_per_instant=0"),
                       ({"backlash": 0.0}, "backlash=0.0")):
        with pytest.raises(ValueError, match=match):
            solve_periodic_by_integration(*args, **bad)


# e2e: the default suite's costliest test (19 CPU s from an empty numba cache, 9 of them a
# compile no earlier test had paid; 10 s warm): three dense balances, an integration over
# the long period and a dop853 check over eight more
@pytest.mark.e2e
def test_dense_balance_restarted_from_the_time_integration(problem):
    """At 3400 rpm Newton's method on the dense balance fails from the linear start (its
    iterate 17 % apart); ``dynamics_at`` integrates the reduced rotor from that iterate to
    its periodic response and restarts Newton there: converged, over 30 % apart, and the
    adaptive integration from the solution (``verify``: dop853 with located switches, eight
    long periods) stays on it."""
    rpm = 3400.0
    model, T = problem.reduced(rpm), problem.period(rpm)
    plain = solve_periodic(model, problem.prep, T, 2 * math.pi * rpm / 60, channels=["dte"])
    assert plain.status == 1 and plain.branch == "contact_loss"
    values, sol = problem.dynamics_at(rpm)
    assert values["status"] == 0 and sol.start == "time_integration"
    assert sol.residual < 1e-9 and sol.contact_loss_fraction > 0.3
    checked = problem.verify(sol, rpm)
    assert checked.status == 0 and checked.stable, checked.drift
    assert checked.drift < 0.05


def test_backtracking_line_search_follows_the_armijo_rule():
    """The one line search of the three semi-smooth Newton solvers, against the rule by hand:
    halve from the full step until the norm falls by the fraction 1e-4 lam."""
    from gearuq.rotor.harmonic_balance import _backtrack

    def residual(z):  # norm |z - 0.3|: the full step (to 1) overshoots, half a step lands
        return None, float(abs(z[0] - 0.3))

    trial, (_, norm), accepted = _backtrack(np.zeros(1), np.ones(1), 0.3, residual)
    assert accepted and trial[0] == 0.5 and norm == pytest.approx(0.2, rel=1e-15)
    # a norm that never falls: halved down to lam = 2^-10 < 1e-3, then refused
    trial, (_, norm), accepted = _backtrack(np.zeros(1), np.ones(1), 1.0,
                                            lambda z: (None, 1.0))
    assert not accepted and trial[0] == 2.0 ** -10
    # the Armijo fraction: a decrease smaller than 1e-4 lam of the norm is not enough
    trial, _, accepted = _backtrack(np.zeros(1), np.ones(1), 1.0,
                                    lambda z: (None, 1.0 - 0.5e-4 * float(z[0])))
    assert accepted and trial[0] == 2.0 ** -10


def _class_block_by_hand(prep, h_two, r):
    """Members of class ``r`` (``j = r + m L``, ``|j| <= H``), slots ``m + n`` and the block
    ``I + diag(h) T`` built member by member from the mesh-periodic stiffness harmonics."""
    H, n = prep.n_harmonics, (prep.class_coupling.shape[0] - 1) // 2

    def dk(k):
        v = prep.mesh_stiffness[abs(k) // L]
        return v if k >= 0 else np.conj(v)

    members = [j for j in range(-H, H + 1) if (j - r) % L == 0]
    B = np.eye(len(members)) + np.array(
        [[h_two[a + H] * dk(a - b) for b in members] for a in members])
    return members, [(j - r) // L + n for j in members], B


def _random_receptance(H, seed):
    rng = np.random.default_rng(seed)
    h = 1e-8 * (rng.normal(size=H + 1) + 1j * rng.normal(size=H + 1))
    h[0] = h[0].real
    return rng, np.concatenate([np.conj(h[:0:-1]), h])


def test_preconditioner_factors_against_each_class_built_by_hand(problem):
    """The LU factors (classes 0..L/2, the others left to their mirror) reassemble each
    class's block built member by member: ``P^T L U = B``."""
    from gearuq.rotor.sideband_balance import _class_blocks

    prep = prepare_krylov(problem.excitation, 3)
    _, h_two = _random_receptance(prep.n_harmonics, 5)
    lu, piv = _class_blocks(prep, h_two)
    assert lu.shape[0] == L // 2 + 1
    for r in range(L // 2 + 1):
        members, pos, B = _class_block_by_hand(prep, h_two, r)
        n = len(members)
        assert pos == list(range(n))  # the padding, if any, is the last slot
        low = np.tril(lu[r][:n, :n], -1) + np.eye(n)
        A = low @ np.triu(lu[r][:n, :n])
        for k in range(n - 1, -1, -1):  # undo the swaps, last first
            A[[k, piv[r][k]]] = A[[piv[r][k], k]]
        np.testing.assert_allclose(A, B, rtol=0, atol=1e-12)


# ------------------------------------------------------------------ compiled kernels (speed)
def test_receptances_equal_the_reduced_model_solved_frequency_by_frequency(problem):
    """The pole sums (compiled, real arithmetic) against the reduced model's dynamic
    stiffness ``diag(w_r^2) - w^2 I + i w (D + speed G)`` solved at each frequency, for the
    mesh and every output (displacement, velocity and acceleration channels)."""
    rpm = 4700.0
    model = problem.reduced(rpm)
    speed = 2 * math.pi * rpm / 60
    w = 2 * math.pi / problem.period(rpm) * np.array([0.0, 1.0, 17.0, 230.0, 231.0])
    got = model.receptances(speed, w)
    assert model.n_modes > 5
    want = {name: np.zeros(w.size, dtype=complex) for name in got}
    for i, wi in enumerate(w):
        Z = (np.diag(model.omega ** 2) - wi ** 2 * np.eye(model.n_modes)
             + 1j * wi * (model.damping + speed * model.gyroscopic))
        eta = np.linalg.solve(Z, model.mesh)
        want["mesh"][i] = model.mesh @ eta + model.mesh_residual
        for name, ch in model.channels.items():
            y = ch["a"] @ eta + ch["a_res"]
            if ch["b"] is not None:
                y += 1j * wi * (ch["b"] @ eta + ch["b_res"])
            want[name][i] = y * (1j * wi) ** ch["derivative"]
    # to the rounding the state matrix's eigenvectors allow (the pole sums go through them):
    # cond(X) eps of each output's scale, times 10 (cond(X) 6.6e4 here, so 1.5e-10; the
    # largest error seen, 5.3e-11, on a bearing's y acceleration with OpenBLAS 0.3.31)
    X = np.linalg.eig(model.state_matrix(speed))[1]
    rel = max(1e-11, 10 * np.linalg.cond(X) * np.finfo(float).eps)
    for name in got:
        np.testing.assert_allclose(got[name], want[name], rtol=0,
                                   atol=rel * np.abs(want[name]).max(), err_msg=name)


def test_pole_sums_pair_conjugate_poles_and_keep_real_ones():
    """The compiled pole sums, conjugate pairs summed as one term (first ``n_pairs``
    poles) and real or unpaired poles singly, against the complex sum over every pole
    written out in numpy."""
    from gearuq.rotor._spectral_kernels import pole_sums

    rng = np.random.default_rng(5)
    pairs = -rng.uniform(10.0, 900.0, 6) + 1j * rng.uniform(50.0, 3e4, 6)
    real = -rng.uniform(1e2, 1e4, 3)
    wp = rng.normal(size=(6, 4)) + 1j * rng.normal(size=(6, 4))
    wr = rng.normal(size=(3, 4)) + 0j
    w = np.concatenate([[0.0], np.sort(rng.uniform(0.0, 4e4, 300)), pairs.imag])
    poles = np.concatenate([pairs, np.conj(pairs), real])
    weights = np.concatenate([wp, np.conj(wp), wr])
    want = (weights[None, :, :] / (1j * w[:, None, None] - poles[None, :, None])).sum(axis=1)
    got = pole_sums(w, np.concatenate([pairs, real]), np.concatenate([wp, wr]), 6)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * np.abs(want).max())
    # with no pair declared every pole is summed singly
    np.testing.assert_allclose(pole_sums(w, poles, weights, 0), want, rtol=0,
                               atol=1e-13 * np.abs(want).max())


def test_gmres_meets_its_tolerance_with_restarts():
    """Right-preconditioned GMRES against a dense solve: the true residual is below the
    tolerance, also when it restarts (restart 4, Krylov buffers grown past their first
    size with restart 20), and a start at the solution takes no iteration."""
    from gearuq.rotor.sideband_balance import _gmres

    rng = np.random.default_rng(2)
    n = 120
    A = np.eye(n) * np.linspace(1.0, 30.0, n) + 0.3 * rng.normal(size=(n, n))
    b = rng.normal(size=n)
    d = np.diag(A).copy()
    exact = np.linalg.solve(A, b)
    for restart in (4, 20):
        x, ok, its, _ = _gmres(lambda v: A @ v, lambda v: v / d, b, None, 1e-10, restart, 200)
        assert ok and its > restart // 2
        assert np.linalg.norm(b - A @ x) <= 1e-10 * np.linalg.norm(b) * (1 + 1e-6)
        np.testing.assert_allclose(x, exact, rtol=0, atol=1e-8 * np.abs(exact).max())
    x, ok, its, _ = _gmres(lambda v: A @ v, lambda v: v / d, b, exact, 1e-10, 20, 200)
    assert ok and its == 0
    # by-products linear in the vector (here B v) are combined into x's, across restarts
    # and from a start
    B = rng.normal(size=(7, n))
    last = []

    def apply(v):
        last[:] = [B @ v]
        return A @ v

    for start in (None, exact + 0.1 * rng.normal(size=n)):
        x, ok, its, parts = _gmres(apply, lambda v: v / d, b, start, 1e-10, 4, 200,
                                   by_products=lambda: (last[0],))
        assert ok and its > 4
        np.testing.assert_allclose(parts[0], B @ x, rtol=0, atol=1e-12 * np.abs(B @ x).max())
    # too few iterations (a budget across restarts): not converged, said so, and the
    # budget holds exactly
    x, ok, its, _ = _gmres(lambda v: A @ v, lambda v: v, b, None, 1e-12, 2, 5)
    assert not ok and its == 5
    assert np.linalg.norm(b - A @ x) < np.linalg.norm(b)  # what it did lowered the residual


def test_block_preconditioner_applied_in_the_real_layout(problem):
    """The compiled solves (half of the classes, their mirrors read as conjugates) against
    every class's block, built by hand and inverted densely, applied to the two-sided
    spectrum and read back on j >= 0."""
    from gearuq.rotor._spectral_kernels import apply_class_factors
    from gearuq.rotor.sideband_balance import _class_blocks

    prep = prepare_krylov(problem.excitation, 3)
    H = prep.n_harmonics
    rng, h_two = _random_receptance(H, 8)
    v = rng.normal(size=2 * H + 1)
    x = v[:H + 1] + 0j
    x[1:] += 1j * v[H + 1:]
    two = np.concatenate([np.conj(x[:0:-1]), x])
    out = np.zeros(2 * H + 1, dtype=complex)
    for r in range(L):
        members, _, B = _class_block_by_hand(prep, h_two, r)
        out[np.add(members, H)] = np.linalg.solve(B, two[np.add(members, H)])
    want = np.concatenate([out[H:].real, out[H + 1:].imag])
    got = apply_class_factors(*_class_blocks(prep, h_two), prep.class_index, v)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * np.abs(want).max())


def test_rotor_bench_table_renders_every_kind_of_row():
    """The table writer of `gearuq bench longperiod_rotor` takes each kind of row (a plugin
    sample of a pair that also names a GMRES table, 27/79, went to the wrong table)."""
    from gearuq.bench.long_period import _rotor_table

    errs = {"dte_rms_rel": 1e-8, "dte_ptp_rel": 2e-8, "force_max_rel": 3e-5,
            "force_min_over_max": 2e-5}
    rows = [{"pair": "27/79", "n_speeds": 160, "method": "every harmonic, GMRES 1e-06",
             "n_orders": 8533, "cpu_per_speed_ms": 9.0, "gmres_iterations": 3.1, **errs},
            {"pair": "27/79 at 100 N m", "n_speeds": 10, "max_contact_loss": 0.27,
             "method": "reference", "n_orders": 8533, "cpu_per_speed_ms": 4e3,
             "gmres_iterations": 3e3},
            {"pair": "27/79 at 100 N m", "n_speeds": 10, "max_contact_loss": 0.27,
             "method": "GMRES 1e-06", "n_orders": 8533, "cpu_per_speed_ms": 9e2,
             "gmres_iterations": 6e2, "failed_speeds": [4450.0], "loss_abs": 0.0, **errs},
            {"pair": "30/30", "plugin": True, "n_speeds": 160, "cpu_s": 2.0, "kv_max": 4.57,
             "dte_rms_max": 1.1e-5},
            {"pair": "27/79", "plugin": True, "n_speeds": 160, "cpu_s": 1.4, "kv_max": 1.369,
             "dte_rms_max": 1.8e-5, "cpu_ref_s": 2.0, "kv_max_rel": 4e-8, "status": 0,
             "dte_rms_max_rel": 4e-11, "kv_over_speed_rel": 1.3e-6}]
    lines: list[str] = []
    _rotor_table(rows, lines)
    plugin = [ln for ln in lines if ln.startswith("| 27/79 | 1.40 | 2.00 |")]
    assert len(plugin) == 1 and "1.3e-06" in plugin[0]
    # nine cells (status after the CPU columns): dte_rms_max and its error apart
    assert plugin[0].count("|") == 10 and "| 2.00 | 0 | 1.369000 |" in plugin[0]
    assert any(ln.startswith("| every harmonic, GMRES 1e-06 | 8533 | 9.0 | 1.44 |")
               for ln in lines)
    assert sum(ln.startswith("| 30/30 | 2.00 | - |") for ln in lines) == 1
    # a contact-loss row says at which speeds its steady state did not converge
    assert any(ln.startswith("| GMRES 1e-06 (not converged at 4450 rpm) | 8533 | 900.0 |")
               for ln in lines)
