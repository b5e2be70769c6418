"""Fidelity links: the adapter's construction checks, the helical pair's map against a hand
computation, the same limit state on both fidelities, the measured correlation, and MFIS with
a link as its cheap model against crude Monte Carlo."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

import gearuq
from gearuq.failure.api import failure_probability
from gearuq.failure.modes import LimitState
from gearuq.links import STATUS_LOW_FIDELITY_RANGE, FidelityLink
from gearuq.model import FunctionModel, Parameter
from gearuq.registry import get_link, get_model

T = np.linspace(0.0, 200.0, 201)


# ----------------------------------------------------------------- cheap generic models
def _high_fn(x1, x2):
    return 3.0 - (x1 + x2) / math.sqrt(2.0)


def _low_fn(a, b):
    return 2.9 - 0.95 * a - 0.05 * b  # correlated, biased


def _high() -> FunctionModel:
    return FunctionModel(_high_fn, ["x1", "x2"], ["g"], name="toy_high")


def _low() -> FunctionModel:
    return FunctionModel(_low_fn, [Parameter("a", "1", 0.0, -10.0, 10.0), "b"], ["h"],
                         name="toy_low")


def _map(params):
    return {"a": (params["x1"] + params["x2"]) / math.sqrt(2.0), "b": params["x2"]}


def _link(**kw) -> FidelityLink:
    args = {"input_map": _map, "produces": ("a", "b"), "output_map": {"h": "g"},
            "neglects": ("the cheap model's bias",)} | kw
    return FidelityLink(_high(), _low(), **args)


SPACE = gearuq.ParameterSpace.normal(x1=(0.0, 1.0), x2=(0.0, 1.0))


# ----------------------------------------------------------------- construction checks
@pytest.mark.parametrize("kw, words", [
    ({"output_map": {"nope": "g"}}, ["'nope'", "not an output of the low-fidelity", "valid: h"]),
    ({"output_map": {"h": "zz"}}, ["'zz'", "not an output of the high-fidelity", "valid: g"]),
    ({"produces": ("a", "c")}, ["'c'", "not a parameter of the low-fidelity", "valid: a, b"]),
    ({"reads": ("x9",)}, ["'x9'", "not a parameter of the high-fidelity", "valid: x1, x2"]),
    ({"low_options": {"tol": 1}}, ["unknown option", "'tol'"]),
])
def test_construction_refuses_bad_maps_naming_the_item_and_the_valid_ones(kw, words):
    with pytest.raises(ValueError) as err:
        _link(**kw)
    for w in words:
        assert w in str(err.value)


def test_an_input_map_returning_other_names_than_declared_is_refused_at_the_call():
    link = _link(input_map=lambda p: {"a": p["x1"]})
    with pytest.raises(ValueError, match=r"missing \['b'\]"):
        link.response({"x1": [0.0], "x2": [0.0]})


def test_a_link_over_another_parameter_space_is_refused_before_any_run():
    """The link takes x1, x2; a study over y1 cannot use it as its cheap model."""
    other = FunctionModel(lambda y1: 3.0 - y1, ["y1"], ["g"], name="other")
    space = gearuq.ParameterSpace.normal(y1=(0.0, 1.0))
    with pytest.raises(ValueError, match=r"no parameter\(s\) 'y1'"):
        failure_probability(other, space, "g", method="mfis", low_fidelity=_link(), rng=1,
                            executor="serial")
    with pytest.raises(ValueError, match=r"no parameter\(s\) 'y1'"):
        gearuq.multifidelity_estimate([other, _link()], space, "g", budget=10.0)


def test_an_input_map_carrying_arrays_of_the_wrong_length_is_refused():
    from gearuq.links import LowFidelityInputs

    link = _link(input_map=lambda p: LowFidelityInputs(_map(p), carry={"z": np.zeros(5)}))
    with pytest.raises(ValueError, match=r"carry\['z'\] has shape \(5,\).*2 samples"):
        link.response({"x1": [0.0, 1.0], "x2": [0.0, 0.0]})


def test_link_carries_high_names_parameters_space_and_provenance():
    link = _link()
    assert link.parameter_names == ["x1", "x2"] and link.output_names == ["g"]
    assert link.name == "toy_high->toy_low"
    ds = link.response({"x1": [1.0, 0.0], "x2": [1.0, 0.0]})
    np.testing.assert_allclose(ds["g"], _low_fn(np.array([math.sqrt(2), 0.0]),
                                                np.array([1.0, 0.0])))
    assert ds.attrs["high_fidelity_model"] == "toy_high"
    assert ds.attrs["low_fidelity_model"] == "toy_low"
    assert "bias" in ds.attrs["link_neglects"]
    assert link.settings()["neglects"] == ["the cheap model's bias"]


def test_samples_mapped_outside_the_low_model_range_are_flagged_not_dropped():
    ds = _link().response({"x1": [0.0, 20.0], "x2": [0.0, 0.0]})  # a = 14.1 > 10
    assert list(ds["status"].values) == [0, STATUS_LOW_FIDELITY_RANGE]
    assert np.isfinite(ds["g"].values[0]) and np.isnan(ds["g"].values[1])
    assert "a: 1 sample(s) outside" in ds.attrs["low_fidelity_range_notes"]


def test_get_link_unknown_pair_lists_the_registered_links():
    with pytest.raises(ValueError, match="helical_pair -> mesh_oscillator"):
        get_link("helical_pair", "linear_oscillator")


@pytest.mark.e2e
def test_mfis_with_a_link_as_cheap_model_holds_against_crude_monte_carlo():
    """Pf = Phi(-3) = 1.35e-3 exactly; crude MC with 4e5 runs as the independent check."""
    exact = stats.norm.cdf(-3.0)
    mc = failure_probability(_high(), SPACE, "g", method="mc", n_samples=400_000, rng=5,
                             executor="serial")
    res = failure_probability(_high(), SPACE, "g", method="mfis", low_fidelity=_link(),
                              rng=11, executor="serial", n_per_level=500, n_samples=200,
                              max_samples=2000)
    assert int(res["status"]) == 0
    assert float(res["pf_lower"]) <= exact <= float(res["pf_upper"])
    assert float(res["pf_lower"]) <= float(mc["pf_upper"])
    assert float(mc["pf_lower"]) <= float(res["pf_upper"])
    assert int(res["n_model_runs"]) <= 2000 and int(res["n_low_fidelity_runs"]) > 0


# ----------------------------------------------------------------- helical pair link
@pytest.fixture(scope="module")
def pair_link():
    return get_link("helical_pair", "mesh_oscillator")


def test_helical_link_reproduces_a_hand_computation_of_the_oscillator_inputs(pair_link):
    from gearuq.gears.geometry import HelicalGearPair
    from gearuq.gears.iso6336 import mesh_stiffness

    hp = get_model("helical_pair")
    p = {"B1": 0.071, "B2": 0.0695, "rho": 7800.0, "s": 0.12, "n": 3900.0, "T": 2500.0,
         "zeta_m": 0.07, "e_a": 8e-6, "phi": 0.4}
    ds = pair_link.response({k: [v] for k, v in p.items()}, T[:3], outputs=["mesh_force"])
    nom = hp.nominal()
    z1, z2, mn = nom["z1"], nom["z2"], nom["m_n"]
    beta, alpha_n = math.radians(nom["beta"]), math.radians(nom["alpha_n"])
    # stiffness: ISO 6336 c_gamma_alpha [N/(mm um)] times the smaller face width
    iso = mesh_stiffness(HelicalGearPair(mn=mn, z1=int(z1), z2=int(z2), alpha_n=alpha_n,
                                         beta=beta, b1=1.0, b2=1.0, x1=0.0, x2=0.0))
    k = iso.c_gamma_alpha * 1e3 * min(p["B1"], p["B2"]) * 1e6
    # masses: solid steel cylinders of the reference diameters
    rp, rg = mn * z1 / (2 * math.cos(beta)), mn * z2 / (2 * math.cos(beta))
    mp, mg = p["rho"] * math.pi * rp**2 * p["B1"], p["rho"] * math.pi * rg**2 * p["B2"]
    jp, jg = mp * rp**2 / 2, mg * rg**2 / 2
    jyp, jyg = mp * (3 * rp**2 + p["B1"] ** 2) / 12, mg * (3 * rg**2 + p["B2"] ** 2) / 12
    ny, nz = math.cos(alpha_n) * math.cos(beta), math.cos(alpha_n) * math.sin(beta)
    m_line = 1 / (1 / mp + 1 / mg + nz**2 * (rp**2 / jyp + rg**2 / jyg)
                  + ny**2 * (rp**2 / jp + rg**2 / jg))
    xi = 2 * math.pi * p["n"] * z1 / 60
    w_osc, w_pair = math.sqrt(k / m_line), math.sqrt(k / (1 / (rp**2 / jp + rg**2 / jg)))
    force = p["T"] / (rp * ny)
    d = force / k + p["s"] * p["e_a"] * math.sin(p["phi"]) / 2
    assert float(ds["lf_frequency_ratio"][0]) == pytest.approx(xi / w_osc, rel=1e-9)
    assert float(ds["lf_damping_ratio"][0]) == pytest.approx(p["zeta_m"] * w_osc / w_pair,
                                                             rel=1e-9)
    assert float(ds["lf_alpha_0_0"][0]) == pytest.approx(force / (k * d), rel=1e-9)
    assert float(ds["lf_e_1"][0]) == pytest.approx(p["e_a"] / d, rel=1e-9)
    assert float(ds["lf_alpha_1_1"][0]) == pytest.approx(p["s"])
    # the torsional mass: inertias and base radii, projected on the normal line of action
    from gearuq_plugins.links.helical_pair import equivalent_mass

    gear = hp.gear_data(hp.validate_params({k_: [v] for k_, v in p.items()}))
    alpha_t = math.atan(math.tan(alpha_n) / math.cos(beta))
    cbb = math.cos(math.asin(math.sin(beta) * math.cos(alpha_n)))
    rbp, rbg = rp * math.cos(alpha_t), rg * math.cos(alpha_t)
    m_tors = jp * jg / (jp * rbg**2 + jg * rbp**2) / cbb**2
    assert float(equivalent_mass(gear, "torsional")[0]) == pytest.approx(m_tors, rel=1e-9)
    assert float(equivalent_mass(gear, "mesh_line")[0]) == pytest.approx(m_line, rel=1e-9)


def test_helical_link_outputs_carry_pair_names_and_one_limit_state_runs_on_both(pair_link):
    hp = get_model("helical_pair")
    x = hp.default_space().sample(24, rng=7)
    limit = LimitState.upper("mesh_force", 76_000.0, window=(100.0, 200.0))
    high = hp.response(x, T, outputs=["mesh_force"])
    low = pair_link.response(x, T, outputs=["mesh_force"])
    assert low["mesh_force"].dims == high["mesh_force"].dims
    assert low["mesh_force"].attrs["units"] == "N"
    g_high, g_low = limit.sample_values(high), limit.sample_values(low)
    assert np.all(np.isfinite(g_low)) and (low["status"] == 0).all()
    # the peak force of the link within 0.5 % of the pair's (measured: 0.06 % on average)
    np.testing.assert_allclose(76_000.0 - g_low, 76_000.0 - g_high, rtol=5e-3)


def test_helical_link_correlates_with_the_pair_over_its_default_space(pair_link):
    """Measured on 400 draws: Pearson 0.994 (95 % CI 0.992-0.995), Spearman 0.988
    (docs/theory/fidelity_links.md); on 60 draws a Pearson below 0.9 would mean the map
    broke (its 95 % interval at rho = 0.99 is about 0.984-0.994)."""
    hp = get_model("helical_pair")
    x = hp.default_space().sample(60, rng=2)
    limit = LimitState.upper("mesh_force", 76_000.0, window=(100.0, 200.0))
    g_high = limit.sample_values(hp.response(x, T, outputs=["mesh_force"]))
    g_low = limit.sample_values(pair_link.response(x, T, outputs=["mesh_force"]))
    assert stats.pearsonr(g_high, g_low)[0] > 0.9
    assert stats.spearmanr(g_high, g_low)[0] > 0.85


def test_helical_link_honours_the_model_contract(pair_link):
    from gearuq.testing import check_model

    check_model(pair_link, np.linspace(0.0, 20.0, 11))


def test_helical_link_refuses_a_pair_with_fourier_stiffness():
    with pytest.raises(ValueError, match="stiffness_harmonics"):
        get_link("helical_pair", "mesh_oscillator",
                 pair=get_model("helical_pair", stiffness_harmonics=[[0.1, 0.0]]))


# ----------------------------------------------------------------- geared rotor link
@pytest.fixture(scope="module")
def rotor_link():
    return get_link("geared_rotor", "mesh_oscillator")


def test_rotor_link_equivalent_mass_from_the_gear_bodies_by_hand():
    """Rigid steel bodies 40 mm wide, bore 110 mm, outer diameter sqrt((d_f^2 + d_a^2)/2)
    (docs/theory/geared_rotor.md: Ip = 0.0342 kg m^2), torsional mass on the normal line."""
    from gearuq.gears.geometry import seed002_pair
    from gearuq_plugins.links.geared_rotor import equivalent_mass

    p = seed002_pair()
    outer = math.sqrt((p.df1**2 + p.da1**2) / 2.0)
    ip = 7850.0 * math.pi * 0.040 * (outer**4 - 0.110**4) / 32.0
    assert ip == pytest.approx(0.0342, abs=5e-5)
    rb = p.db1 / 2.0
    m = ip * ip / (ip * rb**2 + ip * rb**2) / math.cos(p.beta_b) ** 2
    assert equivalent_mass() == pytest.approx(m, rel=1e-3)


@pytest.mark.e2e
def test_rotor_link_is_the_sdof_receptance_on_the_ltca_harmonics(rotor_link):
    """Error-free flanks: the STE repeats every mesh cycle, so only the mesh harmonics
    j = 30 r load the oscillator; the link's dte_rms over speed is, independently,
    sqrt(2 sum |STE_j|^2 / ((1 - r^2)^2 + (2 zeta r)^2)) with r = j w0 / omega_n and its
    maximum sits where the mesh frequency meets omega_n."""
    x = {"torque": [1000.0], "pitch_amplitude": [0.0], "pitch_sigma": [0.0],
         "damping_ratio": [0.05]}
    opts = {"speed_min": 3000.0, "speed_max": 8000.0, "n_speeds": 501}
    ds = rotor_link.response(x, None, outputs=["dte_rms_max", "speed_at_dte_rms_max"],
                             **opts)
    assert list(ds["status"].values) == [0]
    assert ds["dte_rms_max"].attrs["units"] == "m"
    # independent path: the LTCA model itself, a closed-form receptance, no interpolation
    from gearuq_plugins.links.geared_rotor import equivalent_mass

    exc = rotor_link.also_runs[0]
    tau = np.arange(720) / 24.0
    ltca = exc.response({"torque": [1000.0], "pitch_amplitude": [0.0], "pitch_sigma": [0.0]},
                        tau, outputs=["ste", "lpms_tangent"], threads=1)
    ste = ltca["ste"].values[0] * 1e-6
    c = np.abs(np.fft.rfft(ste) / ste.size)[1:91]
    assert np.max(np.delete(c, np.arange(29, 90, 30))) < 1e-6 * c[29]  # mesh orders only
    wn = math.sqrt(ltca["lpms_tangent"].values[0].mean() * 1e6 / equivalent_mass())
    speeds = np.linspace(3000.0, 8000.0, 501)
    r = np.arange(1, 91)[None, :] * (2 * math.pi * speeds[:, None] / 60.0) / wn
    rms = np.sqrt(2 * np.sum(c**2 / ((1 - r**2) ** 2 + (0.1 * r) ** 2), axis=1))
    assert float(ds["dte_rms_max"][0]) == pytest.approx(rms.max(), rel=2e-3)
    assert float(ds["speed_at_dte_rms_max"][0]) == pytest.approx(speeds[rms.argmax()],
                                                                 abs=10.0)
    assert float(ds["speed_at_dte_rms_max"][0]) == pytest.approx(
        60.0 * wn / (2 * math.pi * 30), rel=0.01)  # f_m = z1 n / 60 meets omega_n


@pytest.mark.e2e
def test_rotor_link_runs_the_rotors_limit_state_on_its_names_and_space(rotor_link):
    rotor = get_model("geared_rotor")
    assert rotor_link.parameter_names == rotor.parameter_names
    assert rotor_link.default_space().names == rotor.default_space().names
    assert set(rotor_link.output_names) == {"dte_rms_max", "speed_at_dte_rms_max"}
    x = rotor.default_space().sample(3, rng=4)
    opts = {"n_speeds": 40}
    low = rotor_link.response(x, None, outputs=["dte_rms_max"], **opts)
    high = rotor.response({k: v[:2] for k, v in x.items()}, None, outputs=["dte_rms_max"],
                          **opts)
    limit = LimitState.upper("dte_rms_max", 14e-6)
    g, g_high = limit.sample_values(low), limit.sample_values(high)
    assert g.shape == (3,) and np.all(np.isfinite(g)) and np.all(np.isfinite(g_high))
    assert low["dte_rms_max"].attrs["units"] == high["dte_rms_max"].attrs["units"] == "m"
    s = rotor_link.settings()
    assert s["high_fidelity"]["name"] == "geared_rotor"
    assert s["also_runs"][0]["name"] == "mesh_excitation"


def test_rotor_link_refuses_a_bad_speed_range(rotor_link):
    with pytest.raises(ValueError, match="speed_min=5000.0 rpm must be below speed_max"):
        rotor_link.response({"torque": [1000.0]}, None, outputs=["dte_rms_max"],
                            speed_min=5000.0, speed_max=4000.0)


@pytest.mark.e2e
def test_rotor_link_honours_the_model_contract(rotor_link):
    from gearuq.testing import check_model

    check_model(rotor_link, np.linspace(0.0, 0.01, 5))
