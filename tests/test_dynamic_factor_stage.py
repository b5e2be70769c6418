"""The dynamic question on a hunting-tooth stage (``geared_rotor_dynamic_factor --stage``).

Each check against an oracle written here: the stage file's numbers, ISO 1328-1's tolerance
formulas, the binomial law of a capable process truncated by inspection, and ISO 6336-1
Method B written out by hand from the standard's clauses.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.stats

import gearuq
from gearuq.gears.stage import GearStage
from gearuq_studies import geared_rotor_dynamic_factor as study

STAGE = "e_axle_27_79"


def _binomial_holds(k: int, n: int, p: float, alpha: float = 1e-4) -> bool:
    """Whether ``k`` of ``n`` is inside the two-sided 1 - alpha acceptance region of B(n, p)."""
    return bool(scipy.stats.binom.cdf(k, n, p) > alpha / 2
                and scipy.stats.binom.sf(k - 1, n, p) > alpha / 2)


def _F_pT(d_mm: float, mn_mm: float, grade: int) -> float:
    """ISO 1328-1:2013 total cumulative pitch tolerance [um], unrounded."""
    return (0.002 * d_mm + 0.55 * math.sqrt(d_mm) + 0.7 * mn_mm + 12.0) * \
        math.sqrt(2.0) ** (grade - 5)


def test_the_stage_sets_the_inputs():
    """27/79 germs (26 + 78 normals), the drawing's reliefs, the file's load and damping."""
    e_axle = GearStage.example(STAGE)
    space = study.study_space(e_axle)
    germ = [n for n in space.names if n.startswith("pitch_xi_")]
    assert len(germ) == 26 + 78
    assert {f"pitch_xi_p_{k}" for k in range(1, 27)} | {f"pitch_xi_g_{k}" for k in
                                                        range(1, 79)} == set(germ)
    x = space.sample(4000, rng=3)
    for gear in ("pinion", "wheel"):
        amount = x[f"{gear}_tip_relief_amount"]  # 8 +- 3 um, 1 % of the process beyond
        assert amount.min() >= 5.0 and amount.max() <= 11.0
        assert np.mean(np.abs(amount - 8.0) > 2.5) == pytest.approx(
            (scipy.stats.norm.cdf(-2.5 / (3.0 / scipy.stats.norm.ppf(0.995))) * 2 - 0.01)
            / 0.99, abs=0.01)
    assert x["torque"].min() >= 50.0 and x["torque"].max() <= 250.0
    assert np.mean(x["torque"]) == pytest.approx(150.0, abs=3.0)
    assert x["damping_ratio"].min() >= 0.01 and x["damping_ratio"].max() <= 0.05
    options = study.stage_options(e_axle)
    assert (options["speed_min"], options["speed_max"]) == (500.0, 16000.0)
    # the paper's rotor keeps today's space and options
    paper = study.study_space()
    assert len(paper.names) == 58 + 3 and "speed_min" not in study.OPTIONS
    with pytest.raises(ValueError, match=r"stage='no_such_stage' is neither a built-in stage "
                                         r"\(valid: .*e_axle_27_79"):
        study.load_stage("no_such_stage")


def test_the_stage_option_routes_and_refuses_what_a_stage_does_not_use(tmp_path):
    """``stage`` sends the call to the stage's population; the paper's call is unchanged."""
    from gearuq.cli import study_parser

    with pytest.raises(ValueError, match=r"grade=13 is outside its valid range"):
        study.run(out=tmp_path, grade=13)  # the paper's own validation: not routed
    with pytest.raises(ValueError, match=r"grade=7 is not used on a stage"):
        study.run(out=tmp_path, grade=7, stage=STAGE)
    with pytest.raises(ValueError, match=r"n_per_level=5 is outside its valid range: 0"):
        study.run(out=tmp_path, n_per_level=5, stage=STAGE)
    args = study_parser("geared_rotor_dynamic_factor", study.run).parse_args(
        ["--stage", STAGE, "--n-per-level", "0"])
    assert vars(args) == {"stage": STAGE, "n_per_level": 0}
    with pytest.raises(ValueError, match=r"sobol_base=1 is outside its valid range: 0"):
        study.run(out=tmp_path, sobol_base=1, stage=STAGE)
    # the rare level on a stage: the gated walk, then lines along its failing mean, at an X
    # given by name; lines alone have no direction
    with pytest.raises(ValueError, match=r"rare_methods=\('lines',\) is outside what a stage"):
        study.run(out=tmp_path, rare_methods=("lines",), stage=STAGE)
    with pytest.raises(ValueError, match=r"rare_methods=\('subset', 'mirrored'\) is outside"):
        study.run(out=tmp_path, rare_methods=("subset", "mirrored"), stage=STAGE)
    with pytest.raises(ValueError, match=r"rare_x=0.5 is outside its valid range"):
        study.run(out=tmp_path, rare_x=0.5, stage=STAGE)
    with pytest.raises(ValueError, match=r"rare_per_level=3 is outside its valid range"):
        study.run(out=tmp_path, rare_per_level=3, stage=STAGE)


def test_the_stage_gets_rare_x_only_when_it_is_given(tmp_path, monkeypatch):
    """The paper's RARE_X is not the stage's: without --rare-x no rare level runs on a
    stage; with it, its value and samples per level reach the stage's run."""
    import functools

    calls = []
    real = study.run_on_stage

    @functools.wraps(real)
    def recorded(stage, **kw):
        calls.append(kw)
        return 0

    monkeypatch.setattr(study, "run_on_stage", recorded)
    study.run(out=tmp_path, stage=STAGE)
    study.run(out=tmp_path, stage=STAGE, rare_x=3.0, rare_per_level=50,
              rare_methods=("subset",))
    study.run(out=tmp_path, stage=STAGE, rare_x=3.0, rare_methods=("subset", "lines"))
    assert "rare_x" not in calls[0]
    assert calls[1]["rare_x"] == 3.0 and calls[1]["rare_per_level"] == 50
    assert not calls[1]["rare_lines"] and calls[2]["rare_lines"]


def test_sobol_groups_put_every_input_of_a_stage_under_one_cause():
    """The grouped Sobol' indices on a stage: each gear's germ its own group, both gears'
    reliefs one, load and damping one each; an input of no cause is refused by name."""
    e_axle = GearStage.example(STAGE)
    names = study.study_space(e_axle).names
    causes = study.sobol_groups(names)
    count = {c: causes.count(c) for c in set(causes)}
    assert count == {"pinion pitch": 26, "wheel pitch": 78, "relief": 2, "load": 1,
                     "damping": 1}
    assert [c for n, c in zip(names, causes, strict=True) if "relief" in n] == ["relief"] * 2
    paper = study.sobol_groups(study.study_space().names)
    assert {c: paper.count(c) for c in set(paper)} == {
        "pinion pitch": 29, "wheel pitch": 29, "relief": 1, "load": 1, "damping": 1}
    with pytest.raises(ValueError, match=r"input 'backlash' has no cause"):
        study.sobol_groups(["torque", "backlash"])


# 2-6 s of CPU: CI runs it with the end-to-end runs (-m e2e)
@pytest.mark.e2e
def test_accepted_share_is_the_capable_process_closed_form():
    """Each gear of its own class and germ count: 5 % beyond F_pT, so P(pass) = 0.95^2.

    F_pT written from ISO 1328-1 (class 6 pinion, class 7 wheel), the margin recomputed
    from the two F_p; 4000 pairs, a binomial region at 1e-4 for each share.
    """
    e_axle = GearStage.example(STAGE)
    model, space = study.study_model(stage=e_axle), study.study_space(e_axle)
    n = 4000
    ds = model.response(space.sample(n, rng=11), None,
                        outputs=["pitch_total_deviation_pinion", "pitch_total_deviation_wheel",
                                 "pitch_acceptance_margin"], **study.OPTIONS)
    pair = e_axle.pair
    tol = (_F_pT(pair.d1 * 1e3, 2.0, 6), _F_pT(pair.d2 * 1e3, 2.0, 7))
    fp = (ds["pitch_total_deviation_pinion"].values * 1e6,
          ds["pitch_total_deviation_wheel"].values * 1e6)
    np.testing.assert_allclose(ds["pitch_acceptance_margin"].values,
                               np.minimum(1 - fp[0] / tol[0], 1 - fp[1] / tol[1]), atol=1e-9)
    for f, t in zip(fp, tol, strict=True):
        assert _binomial_holds(int(np.sum(f > t)), n, 0.05)
    passed = int(np.sum(ds["pitch_acceptance_margin"].values >= 0))
    assert _binomial_holds(passed, n, 0.95**2)
    # the count is not blind: a 30/30 calibration on these gears would be visibly off
    assert not _binomial_holds(passed, n, 0.95**2 - 0.04)


def _iso_method_b_by_hand(pair, torque: float, relief_um: float, grade: int,
                          speed: float) -> float:
    """ISO 6336-1 Method B K_v at one pinion speed, written out from the standard.

    Inputs taken from elsewhere: the pair's ISO 21771 geometry (tested against closed forms
    in tests/test_stage.py) and the stiffness c', c_gamma_alpha of ISO 6336-1 clause 9.
    """
    from gearuq.gears.iso6336 import mesh_stiffness

    d1, d2 = pair.d1 * 1e3, pair.d2 * 1e3
    b = pair.face_width * 1e3
    w = 2000.0 * torque / d1 / b                           # K_A F_t / b, K_A = 1 [N/mm]
    st = mesh_stiffness(pair, load_per_width=w)
    c1, cga = st.c_prime, st.c_gamma_alpha
    d_m = (pair.da1 + pair.df1) / 2.0 * 1e3
    u = pair.z2 / pair.z1
    rho = 7.83e-6                                          # steel [kg/mm^3]
    m_red = math.pi / 8.0 * (d_m / (pair.db1 * 1e3)) ** 2 * d_m**2 / (
        1.0 / rho + 1.0 / (rho * u**2))
    n_E1 = 30000.0 / (math.pi * pair.z1) * math.sqrt(cga / m_red)
    k = math.sqrt(2.0) ** (grade - 5)
    f_pt = max(0.001 * d + 0.4 * 2.0 + 5.0 for d in (d1, d2)) * k
    f_pb = f_pt * math.cos(pair.alpha_t)
    f_f = max(2.5 * math.sqrt(2.0) + 0.17 * math.sqrt(d) + 0.5 for d in (d1, d2)) * k
    y = min(0.075 * f_pb, 3.0)                             # case-hardened running-in
    B_p, B_f, B_k = c1 * (f_pb - y) / w, c1 * (f_f - y) / w, abs(1.0 - c1 * relief_um / w)
    e = pair.eps_gamma
    assert e > 2.5                                         # C_v7 = 1 above 2.5
    C = (0.32, 0.57 / (e - 0.3), 0.096 / (e - 1.56), (0.57 - 0.05 * e) / (e - 1.44), 0.47,
         0.12 / (e - 1.74), 1.0)
    N = speed / n_E1
    N_S = 0.85 if w >= 100.0 else 0.5 + 0.35 * math.sqrt(w / 100.0)
    main = C[0] * B_p + C[1] * B_f + C[3] * B_k + 1.0
    sup = C[4] * B_p + C[5] * B_f + C[6]
    if N <= N_S:
        return N * (C[0] * B_p + C[1] * B_f + C[2] * B_k) + 1.0
    if N <= 1.15:
        return main
    if N < 1.5:
        return sup + (main - sup) * (1.5 - N) / 0.35
    return sup


@pytest.mark.e2e
def test_quick_dynamic_factor_study_on_the_stage(tmp_path):
    """``--quick --stage e_axle_27_79``: K_v >= 1, the acceptance law, ISO by hand, marks."""
    from gearuq import registry

    assert registry.get_study("geared_rotor_dynamic_factor")(
        out=tmp_path, quick=True, executor="serial", stage=STAGE) == 0
    info = json.loads((tmp_path / "summary.json").read_text())
    ds = gearuq.load(tmp_path / "population.nc")
    n = study.QUICK_STAGE_RUNS
    assert info["quick"] and info["stage"] == STAGE and info["classes"] == [6, 7]
    assert ds.sizes["sample"] == n
    # a run without a steady state is flagged (16: heavy contact loss), never dropped
    valid = ds["status"].values == 0
    assert set(ds["status"].values[~valid]) <= {16} and valid.sum() >= n // 2
    count, bound = info["crude_mc"], info["crude_mc_invalid_as_failures"]
    assert count["invalid"] == int((~valid).sum()) and count["runs"] == n
    speeds = ds["range_speed"].values
    assert (speeds[0], speeds[-1]) == (500.0, 16000.0)
    # K_v: the largest force over the mean, which is the static force (to the balance's
    # tolerance); the located peak is at least the grid's largest value
    kv = ds["kv_over_speed"].values[valid]
    assert kv.min() >= 1.0 - 1e-6
    assert np.all(ds["kv_max"].values[valid] >= kv.max(axis=1) - 1e-9)
    # inspection's verdict is kinematic: known for every run, the flagged ones included
    passes = ds["pitch_acceptance_margin"].values >= 0
    assert _binomial_holds(int(passes.sum()), n, 0.95**2)
    assert info["accepted_share_closed_form"] == pytest.approx(0.95**2)
    p_pass, se_pass, n_germs = info["accepted_probability_counted"]
    assert n_germs == 400_000 and abs(p_pass - 0.95**2) < 0.006 and 0 < se_pass < 1e-3
    acc = passes & valid
    assert count["accepted"] == int(acc.sum()) and count["lower"] <= count["pf"] <= count["upper"]
    assert bound["invalid_accepted"] == int((passes & ~valid).sum())
    assert bound["pf"] >= count["pf"] and bound["upper"] >= count["upper"]
    assert info["X"] == pytest.approx(np.quantile(ds["kv_max"].values[acc], 0.9))
    # ISO 6336-1 Method B of one sample at three speeds (classes 6/7: the coarser, 7)
    pair = GearStage.example(STAGE).pair
    i = int(np.argmin(ds["torque"].values))  # the lightest load: the largest B_p, B_f
    relief = max(ds["pinion_tip_relief_amount"].values[i],
                 ds["wheel_tip_relief_amount"].values[i])
    for j in (0, speeds.size // 2, speeds.size - 1):
        assert ds["kv_iso_over_speed"].values[i, j] == pytest.approx(_iso_method_b_by_hand(
            pair, float(ds["torque"].values[i]), float(relief), 7, float(speeds[j])), rel=1e-6)
    assert {p.name for p in tmp_path.glob("*.png")} == {"kv_over_speed.png",
                                                       "campbell_map.png"}
    assert set(info["kv_rank_correlations"]) >= {"damping_ratio", "torque"}


@pytest.mark.e2e
def test_germ_acceptance_margin_on_the_stage_is_the_plugins_output():
    """The vectorised margin on the e-axle (26 + 78 germ normals, classes 6 and 7) equals
    the rotor's own ``pitch_acceptance_margin`` (pitch outputs run no dynamics), and the
    counted P(pass) is near the declared (1 - 0.05)^2."""
    stage = GearStage.example(STAGE)
    space = study.study_space(stage)
    names = space.names
    assert names[:104] == [f"pitch_xi_p_{k}" for k in range(1, 27)] + [
        f"pitch_xi_g_{k}" for k in range(1, 79)]
    u = np.random.default_rng(8).standard_normal((30, len(names)))
    design = {n: space.marginal(n).from_normal(u[:, j]) for j, n in enumerate(names)}
    ds = study.study_model(stage=stage).response(
        design, None, outputs=["pitch_acceptance_margin"], **study.stage_options(stage))
    np.testing.assert_allclose(study.germ_acceptance_margin(u, 0, stage),
                               ds["pitch_acceptance_margin"].values, atol=1e-12)
    p, se = study.accepted_probability(0, stage, n=100_000)
    assert se == pytest.approx(math.sqrt(p * (1 - p) / 1e5))
    assert p == pytest.approx(0.95**2, abs=0.004)


@pytest.mark.e2e
def test_acceptance_line_names_the_counted_and_the_closed_form_values():
    """The stage's screen line names the runs' share, P(pass) counted on germ pairs with its
    standard error, and the closed form (0.95)^2 = 0.9025, each for what it is; the count
    agrees with the closed form to the process quantile's error (it is estimated once)."""
    e_axle = GearStage.example(STAGE)
    p, se = study.accepted_probability(0, e_axle, 100_000)
    assert se == pytest.approx(math.sqrt(p * (1 - p) / 1e5)) and abs(p - 0.95**2) < 0.006
    info = {"stage": STAGE, "crude_mc": {"accepted": 90, "runs": 112, "invalid": 11},
            "accepted_share": 90 / 101, "accepted_share_interval": (0.81, 0.94),
            "accepted_share_closed_form": 0.95**2,
            "accepted_probability_counted": (p, se, 100_000)}
    line = study.acceptance_line(info)
    assert "passed 90 of 101 runs (0.891 [0.810, 0.940])" in line
    assert f"counted P(pass) = {p:.4f} +- {se:.4f} (standard error, 100000 germ pairs)" in line
    assert "closed form (1 - 0.05)^2 = 0.9025" in line


def test_grouped_sobol_solves_a_failed_run_again_and_reports_what_stays_failed(monkeypatch):
    """The Sobol' design on a stage: a run without a steady state is solved again with the
    fallback solver (and counted); one that fails again voids the indices, said so with its
    status, never computed from a design with holes; a run whose peak search alone failed
    enters with its lower bound, counted. The model is a stand-in whose kv_max is
    additive in the load and the damping, so the indices have a closed form."""
    import xarray as xr

    e_axle = GearStage.example(STAGE)
    calls = []

    def fake_evaluate(model, design, request, progress, store=None, **execution):
        solver = request.options["long_period_solver"]
        calls.append((solver, len(next(iter(design.values())))))
        torque, damping = np.asarray(design["torque"]), np.asarray(design["damping_ratio"])
        kv = 1.0 + (torque - 50.0) / 200.0 + 2.0 * (damping - 0.01) / 0.04
        status = np.zeros(kv.size, np.int8)
        if solver == "gmres":
            status[:3] = 16               # GMRES fails on the first three runs
            status[3] = 21                # and one run's peak search (its value a bound)
        elif fail_again:
            status[0] = 16                # and the fallback on the first of them
        out = xr.Dataset({"kv_max": ("sample", np.where(status == 16, np.nan, kv)),
                          "status": ("sample", status)})
        out["status"].attrs = {"flag_values": np.array([0, 16, 21], np.int8),
                               "flag_meanings": "ok harmonic_balance_not_converged "
                                                "steady_state_failed_while_locating_a_peak"}
        return out

    monkeypatch.setattr(study, "evaluate_chunks", fake_evaluate)
    fail_again = False
    res = study.grouped_sobol(256, 5, 0, {"executor": "serial"}, e_axle)
    assert calls == [("gmres", 7 * 256), ("spectral_orders", 3)] and res["retried"] == 3
    assert res["lower_bounds"] == 1
    assert res["groups"] == ["pinion pitch", "wheel pitch", "relief", "load", "damping"]
    total = dict(zip(res["groups"], res["ST"], strict=True))
    # kv = 1 + U + 2 V, U and V uniform on (0, 1) (torque on 50-250 N m, damping on 1-5 %):
    # variances 1/12 and 4/12, total indices 0.2 and 0.8, none for the other groups
    assert total["pinion pitch"] == total["wheel pitch"] == total["relief"] == 0.0
    assert total["load"] == pytest.approx(0.2, abs=0.05)
    assert total["damping"] == pytest.approx(0.8, abs=0.1)
    calls.clear()
    fail_again = True
    res = study.grouped_sobol(4, 5, 0, {"executor": "serial"}, e_axle)
    assert "S1" not in res and res["failed"] == 1 and res["retried"] == 2
    assert res["lower_bounds"] == 1
    assert res["failed_status"] == {16: 1} and "not computed" in res["message"]


@pytest.mark.e2e
def test_the_stage_walk_samples_the_accepted_law(tmp_path, monkeypatch):
    """The rare walk on a stage: K_v's limit state alone behind inspection's gate (no
    parallel system), modified Metropolis, the gate a named object whose verdict is the
    plugin's margin formula on the germs; the direction of the lines is checked by name."""
    e_axle = GearStage.example(STAGE)
    seen = {}

    def fake(model, space, limit_state, **kw):
        seen.update(kw, limit_state=limit_state, space=space)
        raise RuntimeError("stop here")

    monkeypatch.setattr(study, "failure_probability", fake)
    with pytest.raises(RuntimeError, match="stop here"):
        study.rare_subset_on_stage(e_axle, 5.0, 1, 100, {"executor": "serial"}, tmp_path)
    gate = seen["gate"]
    assert isinstance(seen["limit_state"], gearuq.LimitState)
    assert seen["limit_state"].name == "kv_max >= 5" and seen["method"] == "subset"
    assert repr(gate) == "AcceptanceGate(stage='e_axle_27_79')"
    u = np.random.default_rng(3).standard_normal((4000, len(seen["space"].names)))
    verdict = gate(u)
    np.testing.assert_array_equal(verdict,
                                  study.germ_acceptance_margin(u, 0, e_axle) >= 0.0)
    # the declared process: 5 % of each gear beyond F_pT, so about 0.95^2 pass
    assert abs(verdict.mean() - 0.9025) < 4 * math.sqrt(0.9025 * 0.0975 / 4000)
    dim = len(seen["space"].names)  # 26 + 78 germs, two reliefs, load, damping
    assert dim == 108
    # the lines' direction: the walk's failing mean without its 104 germ coordinates
    mean = np.arange(1.0, dim + 1.0)
    direction = study.stage_line_direction(e_axle, mean)
    kept = [n for n, v in zip(seen["space"].names, direction, strict=True) if v != 0.0]
    assert sorted(kept) == sorted(n for n in seen["space"].names
                                  if not n.startswith("pitch_xi_")) and len(kept) == 4
    with pytest.raises(ValueError, match=r"failure_mean_u: 108 standard normal"):
        study.stage_line_direction(e_axle, mean[:-1])
    for bad in (np.zeros(dim), np.ones(dim - 2)):
        with pytest.raises(ValueError, match=r"direction: a nonzero vector of 108"):
            study.lines_on_stage(e_axle, 5.0, bad, 1, study.STAGE_LINES,
                                 {"executor": "serial"})


def test_the_walks_limit_state_censors_a_peak_located_from_below():
    """The status the walk reads at its bound is the plugin's "peak not located" status, the
    one whose kv_max is the largest value found before the failed steady state."""
    from gearuq_plugins.geared_rotor.physics import STATUS_MEANINGS, STATUS_PEAK_NOT_LOCATED

    ls = study.kv_exceeds(3.0)
    assert ls.censored_statuses == (STATUS_PEAK_NOT_LOCATED,) == (study.PEAK_NOT_LOCATED,)
    assert STATUS_MEANINGS[STATUS_PEAK_NOT_LOCATED] == "steady_state_failed_while_locating_a_peak"
    # the system of the untruncated law keeps reading it as invalid (a system has no bound)
    system = gearuq.ParallelSystem([ls, study.accepted()])
    assert getattr(system, "censored_statuses", ()) == ()
