"""Hunting-tooth stages through the models (issue 27, follow-up): the line-load table route of
``mesh_excitation`` against the full LTCA of the same samples."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearuq.bench.long_period import hunting_13_17_pair, uniform_stage
from gearuq.gears.stage import GearStage
from gearuq_plugins.mesh_excitation import MeshExcitation
from gearuq_plugins.mesh_excitation.physics import (
    TABLE_TORQUE_STEPS_PER_OCTAVE,
    table_torque,
)

LONG_PERIOD = 13 * 17  # mesh cycles of the coprime pair
SCALARS = ("ste_mean", "ste_ptp", "lpms_mean", "lpms_ptp", "lpms_tangent_mean",
           "lpms_tangent_ptp", "cms_mean", "cms_ptp", "contact_loss_fraction",
           "unloaded_share_max")
# documented tolerances of the table route on the plugin's outputs
# (docs/theory/mesh_excitation.md, "The line-load table route")
RTOL = {"ste_mean": 2e-5, "ste_ptp": 2e-5, "lpms_mean": 5e-4, "lpms_tangent_mean": 5e-4,
        "lpms_ptp": 5e-3, "lpms_tangent_ptp": 5e-3, "cms_ptp": 1e-3}
ATOL = {"cms_mean": 5e-3, "contact_loss_fraction": 0.03, "unloaded_share_max": 0.05}


def _germ_params(model: MeshExcitation, torque: np.ndarray, seed: int) -> dict:
    """Grade-6 samples with a parabolic tip relief and crowning, germ drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    n = torque.size
    params = {"torque": torque, "tip_relief_amount": np.full(n, 8.0),
              "tip_relief_length": np.full(n, 3.0), "crowning": np.full(n, 4.0),
              "iso_grade": np.full(n, 6.0)}
    return params | {p.name: rng.standard_normal(n) for p in model.parameters
                     if p.name.startswith("pitch_xi_")}


@pytest.fixture(scope="module")
def routes_13_17():
    """Both routes on the same three 13/17 samples over the whole long period."""
    model = MeshExcitation(hunting_13_17_pair())
    # 90 N m: 41 % of the positions in partial contact loss; 230 N m: none
    params = _germ_params(model, np.array([90.0, 150.0, 230.0]), seed=3)
    t = np.arange(LONG_PERIOD * 24) / 24.0
    full = model.response(params, t, ltca_route="full", threads=1)
    table = model.response(params, t, ltca_route="table", threads=1)
    return model, params, full, table


@pytest.mark.e2e
def test_table_route_equals_full_route_on_13_17(routes_13_17):
    _, _, full, table = routes_13_17
    assert np.all(full["status"].values == 0) and np.all(table["status"].values == 0)
    assert table.attrs["ltca_route"] == "table" and full.attrs["ltca_route"] == "full"
    assert float(full["contact_loss_fraction"][0]) > 0.3  # the hard case is in the set
    for name in SCALARS:
        a, b = full[name].values, table[name].values
        if name in RTOL:
            np.testing.assert_allclose(b, a, rtol=RTOL[name], err_msg=name)
        else:
            np.testing.assert_allclose(b, a, rtol=0.0, atol=ATOL[name], err_msg=name)
    # the long-period series position by position: STE to 5 nm, stiffnesses to 3 % of their
    # largest value at the worst position (a point entering contact between load nodes)
    np.testing.assert_allclose(table["ste"].values, full["ste"].values, atol=5e-3)
    for name in ("lpms", "lpms_tangent"):
        err = np.abs(table[name].values - full[name].values)
        assert err.max() < 0.03 * np.abs(full[name].values).max(), name
        assert np.median(err) < 1e-3 * np.abs(full[name].values).max(), name
    # the shaft-order sidebands come from the pitch deviations alone: the table keeps them
    np.testing.assert_allclose(table["ste_spectrum"].values, full["ste_spectrum"].values,
                               atol=1e-4)
    np.testing.assert_allclose(table["lpms_tangent_spectrum"].values,
                               full["lpms_tangent_spectrum"].values, atol=0.1)


@pytest.mark.e2e
def test_table_route_reuses_one_table_per_torque_level(routes_13_17):
    model, params, _, table = routes_13_17
    tables = [k for k in model._cache if k[0] == "table"]
    levels = {table_torque(float(v)) for v in params["torque"]}
    assert len(tables) == len(levels) == 3
    again = model.response(params, np.arange(5) / 24.0, ltca_route="table", threads=1,
                           outputs=SCALARS)
    assert len([k for k in model._cache if k[0] == "table"]) == 3
    for name in SCALARS:  # the same samples give the same numbers from the cached tables
        np.testing.assert_array_equal(again[name].values, table[name].values)


@pytest.mark.e2e
def test_table_route_off_grid_instants_match_the_full_route(routes_13_17):
    model, params, _, _ = routes_13_17
    tau = np.array([0.013, 100.37, 220.99, 221.5])  # 221.5 wraps to 0.5
    sub = {k: v[:1] for k, v in params.items()}
    a = model.response(sub, tau, ltca_route="full", threads=1, outputs=["ste", "lpms"])
    b = model.response(sub, tau, ltca_route="table", threads=1, outputs=["ste", "lpms"])
    # off the grid both routes solve the full LTCA at those instants: identical
    np.testing.assert_allclose(b["ste"].values, a["ste"].values, rtol=1e-12)
    np.testing.assert_allclose(b["lpms"].values, a["lpms"].values, rtol=1e-12)


@pytest.mark.parametrize("torque", [1.0, 50.0, 149.99, 150.0, 250.0, 4999.0])
def test_table_torque_is_the_next_level_up(torque):
    level = table_torque(torque)
    k = math.log2(level) * TABLE_TORQUE_STEPS_PER_OCTAVE
    assert abs(k - round(k)) < 1e-9  # on the ladder
    assert torque <= level < torque * 2.0 ** (1.0 / TABLE_TORQUE_STEPS_PER_OCTAVE) * (1 + 1e-12)


@pytest.mark.parametrize("bad", [0.0, -3.0, math.inf, math.nan])
def test_table_torque_refuses_a_bad_torque(bad):
    with pytest.raises(ValueError, match="torque"):
        table_torque(bad)


def test_bad_route_is_refused_naming_the_choices():
    model = MeshExcitation(hunting_13_17_pair())
    with pytest.raises(ValueError, match="ltca_route"):
        model.response({"torque": [100.0]}, np.zeros(1), ltca_route="fast")


def _stage_13_17() -> GearStage:
    """The e-axle stage's flanks (linear tip reliefs, grades 6/7) on a 13/17 pair."""
    data = GearStage.example("e_axle_27_79").to_dict()
    data["name"] = "hunting_13_17"
    data["pair"]["teeth"] = [13, 17]
    data["pair"]["normal_module"] = 3.0
    for shaft in ("pinion_shaft", "wheel_shaft"):  # sized for the 2 mm gears; unused here
        data.pop(shaft)
    stage = GearStage.from_dict(data | {"pinion": {**data["pinion"], "tip_relief": {
        "shape": "linear", "amount": 8.0, "start_roll_length": 13.0, "amount_tolerance": 3.0}},
        "wheel": {**data["wheel"], "tip_relief": {
            "shape": "linear", "amount": 6.0, "start_roll_length": 13.5,
            "amount_tolerance": 3.0}}})
    return stage


def test_table_route_takes_a_stage_with_linear_reliefs():
    """Linear per-gear reliefs travel as the stage's clearance map, the same on every tooth."""
    model = MeshExcitation(stage=_stage_13_17())
    assert model.stage_relief is not None
    rng = np.random.default_rng(11)
    params = {"torque": np.array([120.0])} | {
        p.name: rng.standard_normal(1) for p in model.parameters
        if p.name.startswith("pitch_xi_")}
    t = np.arange(LONG_PERIOD * 12) / 12.0
    opts = {"positions_per_cycle": 12, "n_pts": 12, "threads": 1}
    full = model.response(params, t, ltca_route="full", **opts)
    table = model.response(params, t, ltca_route="table", **opts)
    assert int(full["status"][0]) == 0 and int(table["status"][0]) == 0
    np.testing.assert_allclose(table["ste"].values, full["ste"].values, atol=5e-3)
    for name in ("ste_mean", "ste_ptp", "lpms_mean", "lpms_tangent_mean"):
        np.testing.assert_allclose(table[name].values, full[name].values,
                                   rtol=RTOL[name], err_msg=name)
    # both routes measure contact loss against the pattern of the relieved flank
    for name in ("contact_loss_fraction", "unloaded_share_max"):
        np.testing.assert_allclose(table[name].values, full[name].values, atol=ATOL[name],
                                   err_msg=name)
    # the relief amount is a parameter: a different amount builds its own table
    more = model.response(params | {"pinion_tip_relief_amount": np.array([14.0])},
                          np.zeros(1), ltca_route="table", outputs=["ste_mean"], **opts)
    assert len([k for k in model._cache if k[0] == "table"]) == 2
    assert float(more["ste_mean"][0]) > float(table["ste_mean"][0])


def test_stage_relief_alone_is_not_contact_loss():
    """Error-free gears with the stage's linear reliefs: the relief is the design pattern.

    At 30 N m the relieved tips stay unloaded (a pattern without the reliefs would read 26 %
    of it lost at every position)."""
    model = MeshExcitation(stage=_stage_13_17())
    params = {"torque": np.array([30.0]), "iso_grade": np.array([0.0]),
              "iso_grade_wheel": np.array([0.0]), "pitch_amplitude": np.array([0.0]),
              "pitch_sigma": np.array([0.0])}
    opts = {"positions_per_cycle": 12, "n_pts": 12, "threads": 1,
            "outputs": ["unloaded_share_max", "contact_loss_fraction"]}
    for route in ("full", "table"):
        r = model.response(params, np.zeros(1), ltca_route=route, **opts)
        assert float(r["unloaded_share_max"][0]) < 1e-9, route
        assert float(r["contact_loss_fraction"][0]) == 0.0, route


# ------------------------------------------------------------------ geared rotor
@pytest.fixture(scope="module")
def rotor_13_17():
    import gearuq

    model = gearuq.get_model("geared_rotor", stage=uniform_stage((13, 17), True))
    rng = np.random.default_rng(7)
    params = {"torque": 150.0, "damping_ratio": 0.03} | {
        p.name: float(rng.standard_normal()) for p in model.parameters
        if p.name.startswith("pitch_xi_")}
    return model, params


def _dense_twin(problem):
    """The dense balance on every harmonic 0..H of the same rotor and excitation."""
    from gearuq.rotor.geared import GearedRotorProblem

    return GearedRotorProblem(lambda k: problem.rotor, problem.excitation,
                              problem.pinion_teeth, damping_ratio=problem.damping_ratio,
                              n_harmonics=problem.n_harmonics,
                              cutoff_factor=problem.cutoff_factor, backlash=problem.backlash)


@pytest.mark.e2e
@pytest.mark.parametrize("solver, energy, tol, gmres_tol", [("gmres", 0.99, 1e-9, 1e-12),
                                                             ("gmres", 0.99, 1e-6, None),
                                                             ("spectral_orders", 1.0, 1e-9, None),
                                                             ("spectral_orders", 0.99, None, None)])
def test_long_period_solvers_against_the_dense_balance_on_13_17(rotor_13_17, solver, energy,
                                                                 tol, gmres_tol):
    """GMRES converged and all orders: the dense balance itself; GMRES at its default
    tolerance (the fast route): within the documented 1e-6 (1e-7 measured); 99 % of the
    energy: the documented truncation (docs/theory/geared_rotor.md, "Hunting-tooth stages in
    the plugin")."""
    model, params = rotor_13_17
    opts = {"range_mesh_harmonics": 3, "long_period_solver": solver, "spectral_energy": energy}
    if gmres_tol is not None:
        opts["gmres_tol"] = gmres_tol
    problem = model.rotor_problem(params, speed_range=True, **opts)
    assert problem.n_harmonics == 3 * 221
    dense = _dense_twin(problem)
    worst = dict.fromkeys(("kv", "dte_rms", "dte_mesh_band_rms", "dte_mesh_orders"), 0.0)
    for rpm in (2000.0, 7000.0, 12000.0):
        got, sol = problem.dynamics_at(rpm)
        ref, ref_sol = dense.dynamics_at(rpm)
        assert sol.status == 0 and ref_sol.status == 0
        worst["kv"] = max(worst["kv"], abs(got["kv"] - ref["kv"]))
        if tol is not None:  # every order: the same mesh force, harmonic by harmonic
            np.testing.assert_allclose(sol.force, ref_sol.force[problem.kept], rtol=0.0,
                                       atol=tol * np.abs(ref_sol.force[0]))
        for name in ("dte_rms", "dte_mesh_band_rms"):
            worst[name] = max(worst[name], abs(got[name] / ref[name] - 1.0))
        worst["dte_mesh_orders"] = max(worst["dte_mesh_orders"], float(np.max(
            np.abs(got["dte_mesh_orders"] - ref["dte_mesh_orders"])
            / ref["dte_mesh_orders"].max())))
    if tol is not None:
        assert problem.kept.size > 0.9 * (problem.n_harmonics + 1)
        # K_v: the dense route's maximum is sampled (64 instants per period of the highest
        # harmonic), the long-period route's polished by Newton: within the sampling bound
        assert worst["kv"] < 1e-4, worst
        assert max(worst["dte_rms"], worst["dte_mesh_band_rms"], worst["dte_mesh_orders"]) \
            < tol, worst
    else:
        assert problem.kept.size < 0.5 * (problem.n_harmonics + 1)
        # the mesh orders hold, the RMS loses the shaft orders left out (3 % measured)
        assert worst["dte_mesh_orders"] < 1e-4 and worst["kv"] < 5e-3, worst
        assert worst["dte_rms"] < 0.05 and worst["dte_mesh_band_rms"] < 0.01, worst


@pytest.mark.e2e
def test_geared_rotor_gives_the_speed_range_of_a_hunting_tooth_stage(rotor_13_17, tmp_path):
    import gearuq

    model, params = rotor_13_17
    opts = {"speed_min": 2000.0, "speed_max": 14000.0, "n_speeds": 7, "peaks_refined": 1}
    ds = model.response({k: np.array([v]) for k, v in params.items()}, None,
                        outputs=["kv_max", "speed_at_kv_max", "kv_over_speed", "dte_rms_max",
                                 "dte_mesh_order_max"], **opts)
    assert int(ds["status"][0]) == 0 and ds.attrs["long_period_mesh_cycles"] == 221
    kv = ds["kv_over_speed"].values[0]
    # the located peak is never below the grid's largest value, and K_v > 1 (dynamic)
    assert float(ds["kv_max"][0]) >= kv.max() > 1.0
    assert 2000.0 <= float(ds["speed_at_kv_max"][0]) <= 14000.0
    # the grid values are the problem's own steady states (the sweep starts GMRES from the
    # previous speed: the same balance to the GMRES tolerance)
    problem = model.rotor_problem(params, speed_range=True)
    for j, rpm in enumerate(ds["range_speed"].values[::3]):
        assert problem.dynamics_at(float(rpm))[0]["kv"] == pytest.approx(kv[3 * j], rel=1e-6)
    gearuq.save(ds, tmp_path / "hunting.nc")  # units, provenance and statuses round-trip
    back = gearuq.load(tmp_path / "hunting.nc")
    np.testing.assert_array_equal(back["kv_over_speed"].values[0], kv)
    assert back["kv_max"].attrs["units"] == ds["kv_max"].attrs["units"]


def test_geared_rotor_hunting_tooth_stage_refuses_single_speed_outputs(rotor_13_17):
    model, params = rotor_13_17
    with pytest.raises(ValueError, match="dte_rms"):
        model.response({"speed": np.array([3000.0])}, None, outputs=["dte_rms"])
    with pytest.raises(NotImplementedError, match="dynamics_over_speeds"):
        model.rotor_problem(params, speed_range=True).steady_state(3000.0)


def test_geared_rotor_pitch_outputs_read_the_stage_pair(rotor_13_17):
    """The drawing's numbers of a stage: its own tooth numbers and ISO tolerances."""
    from gearuq.gears.deviations import (
        cumulative_pitch_from_normals,
        iso1328_pitch_tolerances,
        pitch_germ_names,
    )

    model, params = rotor_13_17
    ds = model.response({k: np.array([v]) for k, v in params.items()}, None,
                        outputs=["pitch_total_deviation_pinion", "pitch_acceptance_margin"])
    pair = model.stage.pair
    f_pt, big_f_pt = iso1328_pitch_tolerances(pair.d1, pair.mn, 6)
    xi = np.array([params[n] for n in pitch_germ_names(13, 1)])
    fp = cumulative_pitch_from_normals(xi, 13, amplitude=0.5 * big_f_pt,
                                       sigma=f_pt / (3.0 * math.sqrt(2.0)))
    assert float(ds["pitch_total_deviation_pinion"][0]) == pytest.approx(np.ptp(fp), rel=1e-12)
    assert float(ds["pitch_acceptance_margin"][0]) <= 1.0 - np.ptp(fp) / big_f_pt + 1e-12


def test_table_route_honours_the_contract():
    """Pickling (the tables are rebuilt in each worker), netCDF round trip, statuses."""
    from gearuq.testing import check_model

    check_model(MeshExcitation(stage=_stage_13_17()), np.array([0.0, 0.5, 7.25]),
                options={"positions_per_cycle": 8, "n_pts": 6, "n_mesh_orders": 1,
                         "n_sidebands": 1, "threads": 1, "ltca_route": "table"},
                n_samples=2)


@pytest.mark.e2e
def test_gmres_falls_back_to_back_flank_contact(rotor_13_17):
    """Grade 11 gears at 10 N m with 0.5 um of backlash rattle onto the back flank: GMRES has
    no back flank, the fallback (order balance on every harmonic) equals the dense balance."""
    model, params = rotor_13_17
    rattle = params | {"torque": 10.0, "damping_ratio": 0.01, "backlash": 0.5,
                       "iso_grade": 11}
    problem = model.rotor_problem(rattle, speed_range=True)
    assert problem.solver == "gmres"
    got, sol = problem.dynamics_at(8000.0)
    ref, ref_sol = _dense_twin(problem).dynamics_at(8000.0)
    assert sol.branch == ref_sol.branch == "back_flank_contact"
    assert sol.status == 0 and ref_sol.status == 0 and sol.back_contact_fraction > 0.1
    np.testing.assert_allclose(sol.force, ref_sol.force, rtol=0.0,
                               atol=1e-8 * abs(ref_sol.force[0]))
    # the same force: K_v is its maximum polished by Newton here, sampled at 64 instants per
    # period of the highest harmonic on the dense route (short of it by up to 0.12 % of that
    # harmonic's amplitude)
    assert ref["kv"] - 1e-12 <= got["kv"] == pytest.approx(ref["kv"], rel=1e-4)
    assert got["kv"] > 3.0


def _rattle_truncated(rotor_13_17, monkeypatch, largest_spectral_set=None):
    """The 13/17 rattle case at 8000 rpm with the dense fallback limited to 100 harmonics
    (and, if given, the spectral fallback to ``largest_spectral_set`` orders)."""
    from gearuq_plugins.geared_rotor import long_period

    monkeypatch.setattr(long_period, "MAX_DENSE_FALLBACK_ORDERS", 100)
    if largest_spectral_set is not None:
        monkeypatch.setattr(long_period, "MAX_SPECTRAL_FALLBACK_ORDERS", largest_spectral_set)
    model, params = rotor_13_17
    rattle = params | {"torque": 10.0, "damping_ratio": 0.01, "backlash": 0.5,
                       "iso_grade": 11}
    problem = model.rotor_problem(rattle, speed_range=True, spectral_energy=0.995)
    return long_period, model, rattle, problem, problem.dynamics_at(8000.0)


@pytest.mark.e2e  # over 10 s: CI runs it with the e2e marker
def test_back_flank_beyond_the_dense_fallback_is_flagged(rotor_13_17, monkeypatch):
    """Too many harmonics for a dense fallback: spectral orders, and a status that says so."""
    long_period, model, rattle, problem, (got, sol) = _rattle_truncated(rotor_13_17,
                                                                        monkeypatch)
    assert sol.status == long_period.STATUS_BACK_FLANK_TRUNCATED
    assert sol.branch == "back_flank_contact" and sol.delta.size == problem.n_harmonics + 1
    ref, _ = _dense_twin(problem).dynamics_at(8000.0)
    assert got["kv"] == pytest.approx(ref["kv"], rel=0.1)
    opts = {"speed_min": 7000.0, "speed_max": 9000.0, "n_speeds": 2, "peaks_refined": 0,
            "spectral_energy": 0.995}
    ds = model.response({k: np.array([v]) for k, v in rattle.items()}, None,
                        outputs=["kv_max"], **opts)
    assert int(ds["status"][0]) == 20
    assert "spectral_orders_only" in ds["status"].attrs["flag_meanings"]


@pytest.mark.e2e  # over 10 s: CI runs it with the e2e marker
def test_back_flank_fallback_too_large_is_refused_and_flagged(rotor_13_17, monkeypatch):
    """Spectral orders beyond the fallback's limit are not solved densely (minutes per steady
    state for a 27/79 sample): the reduced rotor integrated in time, which has the back
    flank, gives the steady state (37 long periods to return to itself at damping ratio
    0.01); its K_v within 3 % of the dense balance's (1.5 % measured: with impacts on the
    back flank the balance's three mesh orders miss what the integration's every mode
    holds)."""
    _, _, rattle, problem, (got, sol) = _rattle_truncated(rotor_13_17, monkeypatch,
                                                          largest_spectral_set=10)
    assert problem.orders.orders.size > 10  # the spectral fallback was asked, and refused
    assert sol.status == 0 and sol.start == "time_integration"
    assert sol.branch == "back_flank_contact" and sol.back_contact_fraction > 0.1
    assert sol.delta.size == problem.n_harmonics + 1
    ref, _ = _dense_twin(problem).dynamics_at(8000.0)
    assert got["kv"] == pytest.approx(ref["kv"], rel=0.03)


def test_table_route_in_threads_gives_the_serial_numbers(routes_13_17):
    """A fresh model built in threads: one table per level, the serial run's numbers."""
    _, params, _, table = routes_13_17
    model = MeshExcitation(hunting_13_17_pair())
    many = {k: np.concatenate([v, v]) for k, v in params.items()}  # two samples per level
    threaded = model.response(many, np.zeros(1), ltca_route="table", threads=2,
                              outputs=list(SCALARS))
    assert len([k for k in model._cache if k[0] == "table"]) == 3
    for name in SCALARS:
        np.testing.assert_array_equal(threaded[name].values, np.tile(table[name].values, 2))


def test_speed_continuation_is_reproducible_and_within_the_gmres_tolerance(rotor_13_17):
    """GMRES started from the previous speed: a call's results depend on its arguments alone
    (bit for bit on a second call) and equal the cold-started ones within 1e-5 (two solves
    each to a 1e-6 residual), with fewer iterations."""
    model, params = rotor_13_17
    problem = model.rotor_problem(params, speed_range=True, range_mesh_harmonics=2)
    speeds = np.linspace(6000.0, 6400.0, 5)
    kw = {"peaks_refined": 0, "refine": ()}
    first = problem.dynamics_over_speeds(speeds, **kw)
    again = problem.dynamics_over_speeds(speeds, **kw)
    cold = problem.dynamics_over_speeds(speeds, continuation=False, **kw)
    assert np.all(first.status == 0) and np.all(cold.status == 0)
    for name in ("kv", "dte_rms", "dte_mesh_band_rms", "dte_mesh_orders"):
        np.testing.assert_array_equal(getattr(first, name), getattr(again, name))
        np.testing.assert_allclose(getattr(first, name), getattr(cold, name), rtol=1e-5)
    assert first.iterations[1:].sum() < cold.iterations[1:].sum()


def test_speed_range_gmres_account_bounds_a_sample(rotor_13_17, monkeypatch):
    """Once a speed-range call has spent its GMRES budget, each further steady state gets
    ``SPENT_SWEEP_GMRES`` iterations and, short of them, status 1 (a 27/79 sample with
    contact loss near a resonance ran past 5 min of CPU); the next call has its own
    account."""
    from gearuq_plugins.geared_rotor import long_period

    model, params = rotor_13_17
    problem = model.rotor_problem(params, speed_range=True, range_mesh_harmonics=2)
    speeds = np.linspace(6000.0, 6400.0, 5)
    kw = {"peaks_refined": 0, "refine": ()}
    full = problem.dynamics_over_speeds(speeds, **kw)
    assert np.all(full.status == 0) and np.all(full.iterations > 0)
    monkeypatch.setattr(long_period, "SWEEP_GMRES_BUDGET", int(full.iterations[0]))
    monkeypatch.setattr(long_period, "SPENT_SWEEP_GMRES", 0)
    cut = problem.dynamics_over_speeds(speeds, **kw)
    # the first speed spends the account; the others get none, and say they failed
    assert cut.status[0] == 0 and np.all(cut.status[1:] == 1)
    assert np.all(cut.iterations[1:] == 0) and cut.worst_status() == 1
    monkeypatch.undo()
    again = problem.dynamics_over_speeds(speeds, **kw)
    np.testing.assert_array_equal(again.kv, full.kv)


def test_stagnating_newton_falls_back_to_the_time_integration(monkeypatch,
                                                            separating_long_period):
    """Where Newton's method under contact loss runs out of its GMRES iterations, the
    speed's steady state comes from the reduced rotor integrated in time (status 0, not 1),
    and the next speeds that separate start there: a synthetic 7/11 pattern losing contact
    over up to 36 % of the long period (at 3400 rpm Newton's method fails, the dense
    balance's too; the integration settles), forced onto that path at every separating
    speed, against the default sweep (Newton wherever it converges): K_v within 1e-2 and
    DTE RMS within 3e-3 (the balance keeps harmonics 0..H, the integration every mode, and
    its step error on this coarse pattern, 12 instants per mesh cycle: docs/theory/
    geared_rotor.md), the same contact-loss shares to 2 grid instants."""
    import gearuq.rotor.sideband_balance as sb
    from gearuq_plugins.geared_rotor import long_period

    problem, speeds = separating_long_period
    kw = {"peaks_refined": 0, "refine": ()}
    newton = problem.dynamics_over_speeds(speeds, **kw)
    assert np.all(newton.status == 0) and newton.contact_loss_fraction.max() > 0.3
    calls = []
    original = sb.solve_periodic_by_integration

    def counted(*args, **kwargs):
        calls.append(kwargs["start"].start)
        return original(*args, **kwargs)

    monkeypatch.setattr(sb, "solve_periodic_by_integration", counted)
    monkeypatch.setattr(long_period, "NEWTON_GMRES_BEFORE_INTEGRATION", 5)
    timed = problem.dynamics_over_speeds(speeds, **kw)
    assert np.all(timed.status == 0)
    lost = int(np.sum(newton.contact_loss_fraction > 0))
    # the first separating speed from Newton's iterate, the others from the previous state
    assert len(calls) == lost and calls[0] != "time_integration"
    assert calls[1:] == ["time_integration"] * (lost - 1)
    assert np.abs(timed.kv / newton.kv - 1.0).max() < 1e-2
    assert np.abs(timed.dte_rms / newton.dte_rms - 1.0).max() < 3e-3
    N = problem.krylov.n_time
    assert np.abs(timed.contact_loss_fraction - newton.contact_loss_fraction).max() <= 2.0 / N


def test_series_maximum_against_a_fine_search():
    """The polished maximum of a sparse trigonometric series, against an independent
    brute-force search (direct cosine sums on 200 000 instants, then a bounded scalar
    minimisation around the best)."""
    from scipy.optimize import minimize_scalar

    from gearuq_plugins.geared_rotor.long_period import _series_maximum

    rng = np.random.default_rng(3)
    orders = np.array([0, 1, 7, 40, 41, 300, 900])
    c = rng.normal(size=7) + 1j * rng.normal(size=7)
    c[0] = c[0].real

    def f(t):
        return float(c[0].real + 2.0 * np.sum(np.abs(c[1:]) * np.cos(
            orders[1:] * t + np.angle(c[1:]))))

    t = np.linspace(0.0, 2.0 * np.pi, 200_000, endpoint=False)
    values = c[0].real + 2.0 * (np.abs(c[1:]) * np.cos(
        np.outer(t, orders[1:]) + np.angle(c[1:]))).sum(axis=1)
    best = t[np.argmax(values)]
    step = t[1]
    found = minimize_scalar(lambda s: -f(s), bounds=(best - step, best + step),
                            method="bounded", options={"xatol": 1e-13})
    scale = 2.0 * np.abs(c).sum()
    assert _series_maximum(c, orders, 2.0 * np.pi) == pytest.approx(-found.fun,
                                                                    abs=1e-11 * scale)
