"""Speeds without a periodic response: K_v read from the time integration's window.

Where the time integration of the reduced rotor does not return to its state within its long
periods (a subharmonic, quasi-periodic or chaotic rattle, or a transient slower than the
integration), no periodic response is known. ``aperiodic_response="invalid"`` leaves the speed
without a value (its status); ``"window_max"`` reads K_v as the largest mesh force over the
integration's last long periods, as a measurement over that window would. Oracles: an
independent integrator (the batched DOP853 of ``gearuq.ode`` with located contact switches)
over the same window from the same state, and the sweep's other speeds unchanged bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearuq.rotor.sideband_balance import prepare_krylov, solve_periodic_by_integration
from gearuq.rotor.time_integration import initial_state, integrate_reduced
from tests.test_run_down import LOAD, SPEEDS, _problem

#: 3700 rpm on the one-cycle mesh with a 10 um error: the teeth part over 40 % of the period
RPM = 3700.0


@pytest.mark.e2e
def test_the_window_peak_is_what_an_independent_integrator_reads():
    """From the static state, 8 periods with a tolerance no transient meets (status 3), the
    window of the last 3: its largest force is the largest force of DOP853 on the same
    instants to 1e-5, and within 0.1 % of a 20 000-instant sampling of the window (the
    instants' own sampling error)."""
    prob = _problem(10e-6)
    T, omega = prob.period(RPM), 2.0 * math.pi * RPM / 60.0
    model = prob.reduced(RPM)
    prep = prepare_krylov(prob.excitation, prob.n_harmonics, n_time=prob.prep.n_time)
    sol = solve_periodic_by_integration(model, prep, T, omega, backlash=prob.backlash,
                                        max_periods=8, window_periods=3, tol=1e-12)
    assert sol.status == 3 and sol.iterations == 8 and sol.window_periods == 3
    assert sol.contact_loss_fraction > 0.3  # the window holds contact loss
    N = prep.n_time
    y0 = initial_state(model)[None]
    same = integrate_reduced(model, prob.prep, [omega], [T], 5 * T + np.arange(3 * N) * T / N,
                             y0=y0, backlash=prob.backlash)
    assert same.status[0] == 0
    assert sol.window_peak_force == pytest.approx(same.force[0].max(), rel=1e-5)
    fine = integrate_reduced(model, prob.prep, [omega], [T], np.linspace(5 * T, 8 * T, 20000),
                             y0=y0, backlash=prob.backlash)
    assert 0.0 <= fine.force[0].max() / sol.window_peak_force - 1.0 < 1e-3
    # the window is the last periods: the first ones' transient is not in it
    first = integrate_reduced(model, prob.prep, [omega], [T], np.arange(3 * N) * T / N,
                              y0=y0, backlash=prob.backlash)
    assert first.force[0].max() != pytest.approx(sol.window_peak_force, rel=1e-3)


# about 4.5 s of CPU (three integrations of 100 periods): with the end-to-end runs (-m e2e)
@pytest.mark.e2e
def test_a_stalled_return_map_ends_the_integration_and_a_shrinking_one_does_not():
    """``stall_periods``: from the static state at 3700 rpm the change over a period stops
    shrinking (the response heads for a period-2 one): with ``stall_periods=10`` the
    integration ends after fewer than 40 of its 100 periods, status 3, its window the last
    10. At 4200 rpm the change shrinks for all 100 periods (a slow transient): the rule never
    acts and the result is bit for bit the one without it."""
    prob = _problem(10e-6)
    for rpm, stalls in ((RPM, True), (4200.0, False)):
        T, omega = prob.period(rpm), 2.0 * math.pi * rpm / 60.0
        model = prob.reduced(rpm)
        prep = prepare_krylov(prob.excitation, prob.n_harmonics, n_time=prob.prep.n_time)
        run = [solve_periodic_by_integration(model, prep, T, omega, backlash=prob.backlash,
                                             stall_periods=stall) for stall in (None, 10)]
        assert run[0].status == run[1].status == 3 and run[0].iterations == 100
        if stalls:
            assert 20 <= run[1].iterations < 40 and run[1].window_periods == 10
        else:
            assert run[1].iterations == 100
            np.testing.assert_array_equal(run[1].delta, run[0].delta)
            assert run[1].window_peak_force == run[0].window_peak_force


@pytest.mark.e2e
def test_window_max_gives_the_speed_its_window():
    """At 3700 rpm the run-up's integration (from Newton's iterate, 100 long periods) does
    not settle (status 3). With ``"window_max"`` the speed gets K_v from its window of 10
    long periods, status 0, counted once; the window reads the large response's force (the
    run-down's contact-loss branch has K_v 2.7-3.0 at 3600-3800 rpm)."""
    prob = _problem(10e-6)
    values, sol = prob.dynamics_at(RPM, aperiodic_response="window_max")
    assert sol.status == 3 and sol.start == "time_integration"
    assert values["status"] == 0 and values["aperiodic"] == 1
    assert values["kv"] == sol.window_peak_force / LOAD and sol.window_periods == 10
    assert 2.7 < values["kv"] < 3.2


@pytest.mark.e2e
def test_a_sweep_with_window_max_differs_only_where_no_periodic_response_is_known():
    """The grid of 3300-4300 rpm swept up and down, the K_v peak located (about 10 s of
    CPU). At 3700 rpm the run-up's integration does not settle: ``"invalid"`` keeps status 3
    there, ``"window_max"`` reads its window (3.00, above the run-down's periodic 2.87 at the
    same speed: the larger of two coexisting responses), counted once. The run-down starts
    from the same speeds under both rules (a window is no range top) and every other speed
    is bit for bit the same; the located peak (on the run-down's branch) too."""
    prob = _problem(10e-6)
    kw = {"refine": ("kv",), "peaks_refined": 1, "speed_tol": 4.0,
          "sweep_direction": "up_and_down"}
    invalid = prob.dynamics_over_speeds(SPEEDS, **kw)
    window = prob.dynamics_over_speeds(SPEEDS, aperiodic_response="window_max", **kw)
    i = int(np.flatnonzero(SPEEDS == RPM)[0])
    assert invalid.status[i] == 3 and window.status[i] == 0
    assert np.all(window.status == 0)
    assert invalid.aperiodic_speeds == 0 and window.aperiodic_speeds == 1
    assert window.run_down_speeds == invalid.run_down_speeds > 0
    others = np.arange(SPEEDS.size) != i
    np.testing.assert_array_equal(window.kv[others], invalid.kv[others])
    np.testing.assert_array_equal(window.status[others], invalid.status[others])
    window_kv = prob.dynamics_at(RPM, aperiodic_response="window_max")[0]["kv"]
    assert window.kv[i] == window_kv and window.kv_run_up[i] == window_kv
    assert window_kv > invalid.kv[i] > 2.8  # the run-down's periodic response there
    assert window.peaks["kv"] == invalid.peaks["kv"]


def test_an_unknown_rule_is_refused_by_name():
    prob = _problem(1e-6)
    with pytest.raises(ValueError, match=r"aperiodic_response='ignore'.*valid set"):
        prob.dynamics_over_speeds(SPEEDS, aperiodic_response="ignore")
    model = prob.reduced(RPM)
    prep = prepare_krylov(prob.excitation, prob.n_harmonics, n_time=prob.prep.n_time)
    with pytest.raises(ValueError, match=r"window_periods=0.*integers >= 1"):
        solve_periodic_by_integration(model, prep, prob.period(RPM), 1.0, window_periods=0)
