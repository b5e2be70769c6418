"""Two periodic responses at one speed: the run-down beside the run-up.

Where the teeth separate, the mesh softens and a resonance bends toward lower speeds; over a
band of speeds a small response in full contact and a large one with contact loss coexist.
A run-up reads the small one there (it jumps onto the large one only where the small one
ends); ``sweep_direction="up_and_down"`` sweeps the run-up's contact-loss range down again and
keeps the larger. Oracles: a time integration of the rotor from each response (both must be
periodic and stable), the run-up's values unchanged bit for bit, and the linear response
(unique) where the teeth never part.
"""

from __future__ import annotations

import numpy as np
import pytest

from gearuq.rotor.examples import seed002_rotor
from gearuq.rotor.excitation import MeshExcitation
from gearuq.rotor.geared import GearedRotorProblem

#: Static normal force [N] and mean mesh stiffness [N/m] of the synthetic mesh.
LOAD, STIFFNESS = 1.5e4, 6e8


def _problem(error_amplitude: float) -> GearedRotorProblem:
    """Yuan, Liu and Liu's rotor on a one-cycle mesh with a sinusoidal error, 3 % damping
    (12 harmonics: enough for the contact-loss responses to pass the time integration)."""
    exc = MeshExcitation.synthetic(STIFFNESS, LOAD, n_cycles=1, positions_per_cycle=32,
                                   error_harmonics={1: error_amplitude})
    return GearedRotorProblem(lambda k: seed002_rotor(k, drive_inertia=0.03,
                                                      load_inertia=0.03),
                              exc, 30, damping_ratio=0.03, n_harmonics=12, cutoff_factor=4.0)


SPEEDS = np.linspace(3300.0, 4300.0, 11)


@pytest.fixture(scope="module")
def softening():
    prob = _problem(10e-6)
    both = prob.dynamics_over_speeds(SPEEDS, refine=("kv",), peaks_refined=1, speed_tol=4.0,
                                     sweep_direction="up_and_down")
    up = prob.dynamics_over_speeds(SPEEDS, refine=(), peaks_refined=0)  # the grid's maxima
    return prob, both, up


# about 5 s of CPU: CI runs it with the end-to-end runs (-m e2e); the default suite keeps the
# run-down's cheaper checks below
@pytest.mark.e2e
def test_the_run_down_finds_the_larger_of_two_stable_responses(softening):
    """At 3500 and 3600 rpm the run-up reads the full-contact response (K_v 1.7-2.0) and the
    run-down one with the teeth apart (K_v about 3); the time integration of the rotor from
    each (the dense sweeps with ``verify``) returns to it: both exist and are stable."""
    prob, both, up = softening
    np.testing.assert_array_equal(both.kv_run_up, up.kv)  # the run-up is untouched
    assert both.run_down_speeds > 0
    two = [2, 3]  # 3500, 3600 rpm
    assert np.all(both.status[two] == 0) and np.all(both.kv[two] > up.kv[two] + 1.0)
    # the dense sweeps, checked by time integration: down from 3800 rpm (teeth apart on both
    # sweeps there), up from 3300 rpm (full contact)
    down = prob.sweep(SPEEDS[5:1:-1], verify=True)[::-1]  # 3500..3800 rpm
    rising = prob.sweep(SPEEDS[:4], verify=True)  # 3300..3600 rpm
    for i in two:
        d, r = down[i - 2], rising[i]
        assert d.branch == "contact_loss" and d.stable and d.status == 0
        assert r.branch == "full_contact" and r.status == 0  # linear: stable with damping
        assert prob.peak_mesh_force(d) / LOAD == pytest.approx(both.kv[i], rel=1e-6)
        assert prob.peak_mesh_force(r) / LOAD == pytest.approx(up.kv[i], rel=1e-6)
    # elsewhere each quantity is the larger of the two sweeps, never below a converged
    # run-up's (at 3700 rpm the run-up's jump did not settle: status 3, kept as the speed's)
    ok = up.status == 0
    assert both.status[4] == up.status[4] == 3 and ok.sum() == SPEEDS.size - 1
    assert np.all(both.kv[ok] >= up.kv[ok])
    assert np.all(both.dte_mesh_band_rms[ok] >= up.dte_mesh_band_rms[ok])
    # the located peak sits on the run-down's branch, near its end, above the run-up's
    kv, at, bracket = both.peaks["kv"]
    assert kv >= both.kv.max() and kv > up.peaks["kv"][0] + 0.3
    assert 3400.0 < at < 3500.0 and bracket <= 4.0


@pytest.mark.e2e
def test_the_run_down_costs_nothing_where_the_teeth_never_part():
    """A 1 um error keeps the mesh in contact: the linear response is the only one, the
    run-down solves no speed and both calls agree bit for bit."""
    prob = _problem(1e-6)
    both = prob.dynamics_over_speeds(SPEEDS, refine=(), peaks_refined=0,
                                     sweep_direction="up_and_down")
    up = prob.dynamics_over_speeds(SPEEDS, refine=(), peaks_refined=0)
    assert both.run_down_speeds == 0 and np.all(both.contact_loss_fraction == 0)
    np.testing.assert_array_equal(both.kv, up.kv)
    assert both.peaks == up.peaks


def test_an_unknown_sweep_direction_is_refused_by_name():
    prob = _problem(1e-6)
    with pytest.raises(ValueError, match=r"sweep_direction='down'.*valid set"):
        prob.dynamics_over_speeds(SPEEDS, sweep_direction="down")


def test_the_plugin_option_is_refused_by_name_and_recorded():
    """``sweep_direction`` and ``aperiodic_response`` are declared options of geared_rotor: a
    wrong value is refused naming it; a run records them, the run-down's count and the
    speeds read from a window."""
    from gearuq_plugins.geared_rotor import GearedRotor

    model = GearedRotor()
    with pytest.raises(ValueError, match="sweep_direction"):
        model.response({"torque": [1000.0]}, outputs=["kv_max"], sweep_direction="down")
    with pytest.raises(ValueError, match="aperiodic_response"):
        model.response({"torque": [1000.0]}, outputs=["kv_max"], aperiodic_response="nan")
    ds = model.response({"torque": [1000.0]}, outputs=["kv_max"], n_speeds=3,
                        speed_min=1000.0, speed_max=2000.0, positions_per_cycle=8, n_pts=6,
                        peaks_refined=0, sweep_direction="up_and_down",
                        aperiodic_response="window_max")
    assert '"sweep_direction": "up_and_down"' in ds.attrs["options"]
    assert '"aperiodic_response": "window_max"' in ds.attrs["options"]
    assert ds["run_down_speeds"].values[0] == 0  # nothing parts at 1000-2000 rpm
    assert ds["aperiodic_speeds"].values[0] == 0
    assert ds["kv_grid_max_run_up"].values[0] == pytest.approx(ds["kv_max"].values[0])


def test_the_long_period_route_restores_gmres_state_per_sweep(separating_long_period):
    """The GMRES route (conftest's synthetic 7/11 pattern over 77 mesh cycles, losing
    contact over up to 36 % of the period, one response at every speed): the run-up's
    values are those of the run-up alone bit for bit (its starts restored from each sweep's
    own state), and the run-down, started from the top, reads the same response within the
    solvers' errors."""
    problem, speeds = separating_long_period
    kw = {"peaks_refined": 0, "refine": ()}
    up = problem.dynamics_over_speeds(speeds, **kw)
    both = problem.dynamics_over_speeds(speeds, sweep_direction="up_and_down", **kw)
    np.testing.assert_array_equal(both.kv_run_up, up.kv)
    # the top speed loses contact: the run-down starts there and follows the one response
    # down the whole grid, reading the run-up's response
    assert up.contact_loss_fraction[-1] > 0 and both.run_down_speeds == speeds.size - 1
    assert np.all(up.status == 0) and np.all(both.status == 0)
    # where Newton's method stagnates either sweep may take the time integration's periodic
    # response (K_v within 1e-2, DTE RMS within 3e-3 of the balance's: test_hunting.py)
    np.testing.assert_allclose(both.kv, up.kv, rtol=1e-2)
    np.testing.assert_allclose(both.dte_rms, up.dte_rms, rtol=3e-3)
