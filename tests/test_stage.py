"""The gear stage: geometry against ISO 21771 closed forms, files, refusals, mesh stiffness.

The closed forms here are written from ISO 21771 / textbook formulas in drawing units (mm,
degrees), independently of gearuq.gears.geometry.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import gearuq
from gearuq.gears.geometry import iso_tr_6336_30_example1, seed000_pair, seed002_pair
from gearuq.gears.stage import (
    Bearing,
    GearStage,
    Relief,
    Shaft,
    StiffnessBandWarning,
    stage_mesh_stiffness,
)

PAIR_ONLY = """
[pair]
normal_module = 2.0
teeth = [27, 79]
normal_pressure_angle = 20.0
helix_angle = 22.0
face_width = [30.0, 28.0]
profile_shift = [0.3, -0.2]
"""


def _inv(a: float) -> float:
    return math.tan(a) - a


def _iso21771(mn, z1, z2, an_deg, beta_deg, b, x1, x2, ha=1.0):
    """ISO 21771 closed forms in mm (zero-backlash centre distance), written for the test."""
    an, beta = math.radians(an_deg), math.radians(beta_deg)
    at = math.atan(math.tan(an) / math.cos(beta))
    mt = mn / math.cos(beta)
    d1, d2 = z1 * mt, z2 * mt
    db1, db2 = d1 * math.cos(at), d2 * math.cos(at)
    # working pressure angle by bisection of inv(awt) = inv(at) + 2 tan(an)(x1+x2)/(z1+z2)
    target = _inv(at) + 2 * math.tan(an) * (x1 + x2) / (z1 + z2)
    lo, hi = 1e-6, 1.5
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _inv(mid) < target else (lo, mid)
    awt = 0.5 * (lo + hi)
    a = (d1 + d2) / 2 * math.cos(at) / math.cos(awt)
    da1, da2 = d1 + 2 * mn * (ha + x1), d2 + 2 * mn * (ha + x2)
    pbt = math.pi * mt * math.cos(at)
    g_alpha = 0.5 * (math.sqrt(da1**2 - db1**2) + math.sqrt(da2**2 - db2**2)) - a * math.sin(awt)
    return {"d1": d1, "d2": d2, "db1": db1, "db2": db2, "da1": da1, "da2": da2,
            "centre_distance": a, "pbt": pbt, "pbn": math.pi * mn * math.cos(an),
            "eps_alpha": g_alpha / pbt, "eps_beta": b * math.sin(beta) / (math.pi * mn)}


@pytest.fixture(scope="module")
def e_axle() -> GearStage:
    return GearStage.example("e_axle_27_79")


def test_examples_are_shipped_and_round_trip_exactly(tmp_path):
    names = GearStage.examples()
    assert {"e_axle_27_79", "li_hu_han", "yuan_liu_liu", "iso_tr_6336_30_example1"} <= set(names)
    for name in names:
        stage = GearStage.example(name)
        path = tmp_path / f"{name}.toml"
        stage.to_toml(path)
        again = GearStage.from_toml(path)
        assert again == stage
        assert again.to_toml() == stage.to_toml()  # the writer is a fixed point
        assert again.pair == stage.pair
    with pytest.raises(ValueError, match="not a shipped stage"):
        GearStage.example("nope")


def test_paper_stage_files_give_the_built_in_pairs_bit_for_bit():
    assert GearStage.example("li_hu_han").pair == seed000_pair()
    assert GearStage.example("yuan_liu_liu").pair == seed002_pair()
    assert GearStage.example("iso_tr_6336_30_example1").pair == iso_tr_6336_30_example1()
    assert gearuq.GearStage is GearStage


@pytest.mark.parametrize("name", ["e_axle_27_79", "li_hu_han", "yuan_liu_liu"])
def test_geometry_against_iso21771_closed_forms(name):
    stage = GearStage.example(name)
    z1, z2 = stage.teeth
    ref = _iso21771(stage.normal_module, z1, z2, stage.normal_pressure_angle,
                    stage.helix_angle, min(stage.face_width), *stage.profile_shift)
    summary = stage.summary()
    for key in ("d1", "d2", "db1", "db2", "da1", "da2", "centre_distance", "pbt", "pbn"):
        assert summary[key] == pytest.approx(ref[key], rel=1e-12), key
    assert summary["eps_alpha"] == pytest.approx(ref["eps_alpha"], rel=1e-9)
    assert summary["eps_beta"] == pytest.approx(ref["eps_beta"], rel=1e-12)
    # the base pitch is the same on both gears and the normal one is pbt cos(beta_b)
    assert summary["pbn"] == pytest.approx(
        summary["pbt"] * math.cos(math.radians(summary["beta_b_deg"])), rel=1e-12)


def test_iso_tr_6336_30_published_contact_ratios():
    # ISO/TR 6336-30:2017 Example 1 prints eps_alpha = 1.54934 and eps_beta = 1.0834
    s = GearStage.example("iso_tr_6336_30_example1").summary()
    assert s["eps_alpha"] == pytest.approx(1.54934, abs=5e-5)
    assert s["eps_beta"] == pytest.approx(1.0834, abs=5e-4)


def test_pair_only_file_is_a_stage_with_documented_defaults(tmp_path):
    path = tmp_path / "pair.toml"
    path.write_text(PAIR_ONLY)
    stage = GearStage.from_toml(path)
    assert stage.teeth == (27, 79) and stage.pinion_shaft is None
    assert stage.material.young_modulus == 206000.0 and stage.stiffness_source == "ltca"
    assert stage.is_hunting_tooth and stage.long_period_mesh_cycles == 27 * 79 == 2133
    assert stage.mesh_frequency(16000.0) == pytest.approx(27 * 16000 / 60)


def test_relief_lengths_from_start_diameter_and_roll_length(e_axle):
    p = e_axle.pair
    db1, da1 = p.db1 * 1e3, p.da1 * 1e3
    # pinion tip relief from d = 60.5 mm: roll length from the tip circle to 60.5 mm
    expect = 0.5 * math.sqrt(da1**2 - db1**2) - 0.5 * math.sqrt(60.5**2 - db1**2)
    assert e_axle.relief_length("pinion", "tip") == pytest.approx(expect, rel=1e-12)
    # the same relief stated as a start roll length
    roll = 0.5 * math.sqrt(60.5**2 - db1**2)
    same = Relief("linear", 8.0, start_roll_length=roll)
    assert same.start_roll(db1) == pytest.approx(roll)
    # linear relief: amount at the tip, half of it half way, zero at the start
    s_tip = (p.g_f1 + p.g_alpha) * 1e3
    length = e_axle.relief_length("pinion", "tip")
    rel = e_axle.profile_relief([s_tip, s_tip - length / 2, s_tip - length])
    wheel_at_s_tip = 0.0  # the wheel's tip relief is at the other end of the path
    assert rel[0] == pytest.approx(8.0 + wheel_at_s_tip)
    assert rel[1] == pytest.approx(4.0)
    assert rel[2] == pytest.approx(0.0, abs=1e-12)


def test_relief_shapes():
    lin, par, arc = (Relief(k, 10.0, start_diameter=50.0) for k in ("linear", "parabolic", "arc"))
    v = [0.0, 1.0, 2.0]
    assert list(lin.profile(v, 2.0)) == pytest.approx([0.0, 5.0, 10.0])
    assert list(par.profile(v, 2.0)) == pytest.approx([0.0, 2.5, 10.0])
    # arc tangent at the start through (L, C): circle of radius R = (L^2 + C^2) / (2 C)
    c_mm, L = 10e-3, 2.0
    R = (L**2 + c_mm**2) / (2 * c_mm)
    assert arc.profile([1.0], L)[0] == pytest.approx((R - math.sqrt(R**2 - 1.0)) * 1e3)
    assert arc.profile([L], L)[0] == pytest.approx(10.0, rel=1e-9)


def _pair(**changes):
    base = dict(normal_module=2.0, teeth=(27, 79), normal_pressure_angle=20.0,
                helix_angle=22.0, face_width=(30.0, 28.0), profile_shift=(0.3, -0.2))
    return GearStage(**(base | changes))


@pytest.mark.parametrize("changes, match", [
    (dict(teeth=(8, 79), profile_shift=(-0.5, 0.0)), r"profile_shift\[0\].*undercut"),
    (dict(profile_shift=(2.0, 0.0)), r"profile_shift\[0\].*pointed tip"),
    (dict(addendum_factor=0.3), "transverse contact ratio"),
    (dict(normal_module=-1.0), r"normal_module \[mm\]=-1.0 is outside"),
    (dict(teeth=(27, 4)), r"teeth\[1\]=4 is outside its valid range \[5"),
    (dict(helix_angle=50.0), r"helix_angle \[deg\]=50.0"),
    (dict(face_width=(30.0, float("nan"))), r"face_width\[1\]"),
])
def test_impossible_pairs_are_refused_by_name(changes, match):
    with pytest.raises(ValueError, match=match):
        _pair(**changes)


def test_tip_interference_is_refused():
    # 20/200 at 14.5 deg on a = 220 mm: the wheel's tip roll length exceeds T1T2 = a sin(alpha)
    a, alpha = 220.0, math.radians(14.5)
    db2, da2 = 400.0 * math.cos(alpha), 404.0
    assert 0.5 * math.sqrt(da2**2 - db2**2) > a * math.sin(alpha)  # the oracle says: interferes
    with pytest.raises(ValueError, match=r"teeth\[1\] \(z2\)/x2: the tip of gear 2 reaches "
                       "below the base circle of gear 1"):
        GearStage(normal_module=2.0, teeth=(20, 200), normal_pressure_angle=14.5,
                  helix_angle=0.0, face_width=(20.0, 20.0), profile_shift=(0.4, 0.0),
                  centre_distance=a)


def _shaft(**changes):
    base = dict(sections=((40.0, 30.0, 0.0), (60.0, 45.0, 0.0), (40.0, 30.0, 0.0)),
                gear_position=70.0, bearings=(Bearing(20.0, 300.0), Bearing(120.0, 300.0)))
    return Shaft(**(base | changes))


def test_shaft_refusals():
    with pytest.raises(ValueError, match=r"bearings\[1\] position=150.0 mm is off the shaft"):
        _shaft(bearings=(Bearing(20.0, 300.0), Bearing(150.0, 300.0)))
    with pytest.raises(ValueError, match="beyond the shaft's sections"):
        _pair(pinion_shaft=_shaft(gear_position=130.0))
    with pytest.raises(ValueError, match="root diameter"):
        _pair(pinion_shaft=_shaft(sections=((40.0, 30.0, 0.0), (60.0, 60.0, 0.0),
                                             (40.0, 30.0, 0.0))))
    with pytest.raises(ValueError, match="inner_diameter"):
        _shaft(sections=((40.0, 30.0, 31.0),))
    with pytest.raises(ValueError, match="radial_stiffness"):
        Bearing(10.0, 0.0)


def test_relief_outside_active_profile_is_refused():
    from gearuq.gears.stage import GearData

    with pytest.raises(ValueError, match=r"\[pinion.tip_relief\].*active profile"):
        _pair(pinion=GearData(tip_relief=Relief("linear", 8.0, start_diameter=70.0)))
    with pytest.raises(ValueError, match="exactly one of start_diameter"):
        Relief("linear", 8.0)
    with pytest.raises(ValueError, match="shape='cubic'"):
        Relief("cubic", 8.0, start_diameter=60.0)


def test_file_errors_name_the_key(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(PAIR_ONLY + "helix = 3\n")
    with pytest.raises(ValueError, match=r"\[pair\]: unknown key\(s\) \['helix'\]"):
        GearStage.from_toml(path)
    path.write_text(PAIR_ONLY.replace("[27, 79]", "[27.5, 79]"))
    with pytest.raises(TypeError, match=r"teeth\[0\]=27.5 must be an integer"):
        GearStage.from_toml(path)
    path.write_text(PAIR_ONLY + "[pinion_shaft]\nsections = [[10, 20, 0]]\ngear_position = 5\n"
                    "[[pinion_shaft.bearings]]\nposition = 11\nradial_stiffness = 1\n")
    with pytest.raises(ValueError, match=r"\[pinion_shaft\] bearings\[0\] position=11.0"):
        GearStage.from_toml(path)


_numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=64),
                     st.integers(-10, 500), st.text(max_size=3), st.none(), st.booleans())


@pytest.mark.e2e
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    mn=st.one_of(st.floats(0.1, 20.0), _numbers), z1=st.one_of(st.integers(3, 150), _numbers),
    z2=st.one_of(st.integers(3, 300), _numbers), an=st.one_of(st.floats(10.0, 35.0), _numbers),
    beta=st.one_of(st.floats(0.0, 44.0), _numbers),
    b=st.one_of(st.tuples(st.floats(1.0, 200.0), st.floats(1.0, 200.0)), _numbers),
    x=st.one_of(st.tuples(st.floats(-1.0, 1.5), st.floats(-1.0, 1.5)), _numbers),
    ha=st.one_of(st.floats(0.5, 1.5), _numbers),
    cd=st.one_of(st.none(), st.floats(10.0, 2000.0)),
)
def test_generated_stages_fail_only_with_a_message(mn, z1, z2, an, beta, b, x, ha, cd):
    data = {"pair": {"normal_module": mn, "teeth": [z1, z2], "normal_pressure_angle": an,
                     "helix_angle": beta, "face_width": b, "profile_shift": x,
                     "addendum_factor": ha}}
    if cd is not None:
        data["pair"]["centre_distance"] = cd
    data["pair"] = {k: v for k, v in data["pair"].items() if v is not None}
    try:
        stage = GearStage.from_dict(data)
    except (ValueError, TypeError) as exc:
        assert str(exc)  # a message, never a bare error
        return
    s = stage.summary()
    assert all(math.isfinite(v) for v in s.values())
    assert s["eps_alpha"] >= 1.0 and s["da1"] > s["db1"] and s["da2"] > s["db2"]
    assert GearStage.from_dict(stage.to_dict()) == stage


def _iso6336_c_gamma_b(stage) -> float:
    """ISO 6336-1:2019 method B c_gamma_alpha b [N/um], written here from the standard."""
    z1, z2 = stage.teeth
    x1, x2 = stage.profile_shift
    beta, an = math.radians(stage.helix_angle), math.radians(stage.normal_pressure_angle)
    at = math.atan(math.tan(an) / math.cos(beta))
    bb = math.atan(math.tan(beta) * math.cos(at))
    zn1, zn2 = (z / (math.cos(bb) ** 2 * math.cos(beta)) for z in (z1, z2))
    q = (0.04723 + 0.15551 / zn1 + 0.25791 / zn2 - 0.00635 * x1 - 0.11654 * x1 / zn1
         - 0.00193 * x2 - 0.24188 * x2 / zn2 + 0.00529 * x1**2 + 0.00182 * x2**2)
    c_b = (1 + 0.5 * (1.2 - stage.dedendum_factor)) * (
        1 - 0.02 * (20.0 - stage.normal_pressure_angle))
    c_prime = 0.8 * 1.0 * c_b * math.cos(beta) / q
    eps_alpha = stage.summary()["eps_alpha"]
    return c_prime * (0.75 * eps_alpha + 0.25) * min(stage.face_width)


def test_stage_mesh_stiffness_against_iso_6336_1(e_axle):
    """Mean LTCA stiffness against ISO 6336-1 c_gamma (an oracle sharing no code): the
    like-for-like ratio lies in the measured band, for the paper's pair and the e-axle."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", StiffnessBandWarning)
        for stage in (GearStage.example("yuan_liu_liu"), e_axle,
                      GearStage.example("iso_tr_6336_30_example1")):
            r = stage_mesh_stiffness(stage, positions_per_cycle=8, n_pts=8)
            iso = _iso6336_c_gamma_b(stage)
            assert r.iso_c_gamma_b == pytest.approx(iso, rel=1e-9)
            beta_b = math.radians(stage.summary()["beta_b_deg"])
            ratio = r.secant_mean * math.cos(beta_b) ** 2 / iso
            assert r.ratio == pytest.approx(ratio, rel=1e-12)
            assert r.band[0] <= ratio <= r.band[1]
            assert r.tangent_mean > r.secant_mean > 0  # stiffening Hertzian contact
            assert r.value == r.tangent_mean and r.source == "ltca"
    li = stage_mesh_stiffness(GearStage.example("li_hu_han"), positions_per_cycle=8, n_pts=8)
    assert li.source == "iso6336" and li.value == li.iso_c_gamma_b


def test_band_warning_is_raised_outside_the_band(monkeypatch, e_axle):
    import gearuq.gears.stage as mod

    monkeypatch.setattr(mod, "STIFFNESS_BAND", (0.5, 0.6))
    mod._stage_mesh_stiffness.cache_clear()
    with pytest.warns(StiffnessBandWarning, match="outside the band"):
        r = mod.stage_mesh_stiffness(e_axle, positions_per_cycle=8, n_pts=8)
    assert not r.within_band
    mod._stage_mesh_stiffness.cache_clear()


_any = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-5, 500),
                 st.text(max_size=2), st.none(), st.lists(st.floats(0, 100), max_size=3))
_relief_tables = st.fixed_dictionaries(
    {"shape": st.one_of(st.sampled_from(["linear", "parabolic", "arc"]), _any),
     "amount": st.one_of(st.floats(0.0, 50.0), _any)},
    optional={"start_diameter": st.one_of(st.floats(50.0, 70.0), _any),
              "start_roll_length": st.one_of(st.floats(5.0, 20.0), _any),
              "amount_tolerance": st.one_of(st.floats(0.0, 10.0), _any)})
_bearing_tables = st.fixed_dictionaries(
    {"position": st.one_of(st.floats(-10.0, 200.0), _any),
     "radial_stiffness": st.one_of(st.floats(0.0, 1e3), _any)},
    optional={"axial_stiffness": st.one_of(st.floats(0.0, 1e3), _any),
              "damping": st.one_of(st.floats(0.0, 1e3), _any)})
_shaft_tables = st.fixed_dictionaries(
    {"sections": st.one_of(st.lists(st.tuples(st.floats(1.0, 100.0), st.floats(5.0, 80.0),
                                              st.floats(0.0, 10.0)).map(list),
                                    min_size=1, max_size=4), _any),
     "gear_position": st.one_of(st.floats(-10.0, 300.0), _any),
     "bearings": st.lists(_bearing_tables, max_size=3)},
    optional={"end_inertia": st.one_of(st.floats(0.0, 1.0), _any)})


@pytest.mark.e2e
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tip=st.one_of(st.none(), _relief_tables), root=st.one_of(st.none(), _relief_tables),
       grade=st.one_of(st.integers(0, 14), _any), shaft=st.one_of(st.none(), _shaft_tables),
       torque=st.one_of(st.lists(st.floats(-10.0, 500.0), min_size=2, max_size=2), _any))
def test_generated_full_stages_fail_only_with_a_message(tip, root, grade, shaft, torque):
    data = {"pair": {"normal_module": 2.0, "teeth": [27, 79], "normal_pressure_angle": 20.0,
                     "helix_angle": 22.0, "face_width": [30.0, 28.0],
                     "profile_shift": [0.3, -0.2]},
            "pinion": {"iso_grade": grade}, "operation": {"torque": torque}}
    if tip is not None:
        data["pinion"]["tip_relief"] = tip
    if root is not None:
        data["pinion"]["root_relief"] = root
    if shaft is not None:
        data["pinion_shaft"] = shaft
    try:
        stage = GearStage.from_dict(data)
    except (ValueError, TypeError) as exc:
        assert str(exc)
        return
    assert GearStage.from_dict(stage.to_dict()) == stage
    p = stage.pair
    s = np.linspace(p.g_f1, p.g_f1 + p.g_alpha, 9) * 1e3
    relief = stage.profile_relief(s)
    assert np.all(np.isfinite(relief)) and np.all(relief >= 0.0)


def test_iso_tr_6336_30_stage_stiffness_table_matches_the_published_example():
    """The stage file's ISO 6336-1 table against the worked example's printed values
    (q' = 0.0560041 mm um/N, c'_th = 17.8558, c' = 12.3705 N/(mm um))."""
    from gearuq.stage_analysis import iso6336_table

    table = iso6336_table(GearStage.example("iso_tr_6336_30_example1"))["iso6336"]
    assert table.sel(iso_quantity="q_prime").item() == pytest.approx(0.0560041, abs=5e-8)
    assert table.sel(iso_quantity="c_th").item() == pytest.approx(17.8558, abs=5e-5)
    assert table.sel(iso_quantity="c_prime").item() == pytest.approx(12.3705, abs=5e-5)


def test_helix_slope_deviation_tilts_the_clearance_and_softens_the_mesh(e_axle):
    """f_Hbeta enters the stage's LTCA as the clearance f_Hbeta (y/b - 1/2) cos(beta_b)
    (written here), antisymmetric over the face; a slope that opens part of the face
    unloads it, so the mean mesh stiffness drops."""
    from dataclasses import replace

    tilted = replace(e_axle, pinion=replace(e_axle.pinion, helix_slope_deviation=6.0),
                     wheel=replace(e_axle.wheel, helix_slope_deviation=4.0))
    p = tilted.pair
    s_mid = np.full(3, (p.g_f1 + 0.5 * p.g_alpha))  # mid path: no relief there
    y = np.array([0.0, 0.5, 1.0]) * p.face_width
    got = tilted.relief_clearance()(s_mid, y, np.zeros(3, int), np.zeros(3, int))
    expect = 10e-6 * (y / p.face_width - 0.5) * math.cos(p.beta_b)
    np.testing.assert_allclose(got, expect, rtol=1e-12, atol=1e-18)
    straight = stage_mesh_stiffness(e_axle, positions_per_cycle=8, n_pts=8)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StiffnessBandWarning)
        slanted = stage_mesh_stiffness(tilted, positions_per_cycle=8, n_pts=8)
    assert slanted.secant_mean < straight.secant_mean
    # mesh_excitation carries it in the stage's clearance map (reliefs as amount parameters)
    model = gearuq.get_model("mesh_excitation", stage=tilted)
    assert model.stage_relief is not None and "pinion_tip_relief_amount" in model.parameter_names
