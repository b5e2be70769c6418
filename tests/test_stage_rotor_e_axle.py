"""The geared rotor of the e-axle stage (27/79, per-bearing stiffness, classes 6/7, linear
reliefs), each check against an oracle written here without gearuq's code under test."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse
import scipy.sparse.linalg
import scipy.stats

import gearuq
from gearuq.gears.stage import GearStage


@pytest.fixture(scope="module")
def e_axle() -> GearStage:
    return GearStage.example("e_axle_27_79")


# ----------------------------------------------------------------- oracle: a beam
def _timoshenko_beam_on_springs(sections, springs, disk, E, nu, rho, element=1e-3):
    """Lateral natural frequencies [Hz] of a free stepped Timoshenko beam on radial springs
    with a rigid disk (written for this test, no gearuq code).

    Deflection ``w`` and section rotation ``psi`` interpolated linearly on elements of about
    ``element`` [m] (the shear term integrated at the element's midpoint, which keeps it free
    of shear locking): strain energy ``EI psi'^2 + kappa G A (w' - psi)^2``, kinetic energy
    ``rho A w^2 + rho I psi^2``, Cowper's ``kappa = 6 (1 + nu) / (7 + 6 nu)`` of a solid
    section. Converges as element^2 to the exact beam. sections: [(length, outer d, inner d)]
    [m] from z = 0; springs: [(z, k)] [m, N/m]; disk: (z, mass, diametral inertia).
    """
    G, kappa = E / (2 * (1 + nu)), 6 * (1 + nu) / (7 + 6 * nu)
    z, props = [0.0], []
    for length, do, di in sections:
        n = max(1, round(length / element))
        z.extend(z[-1] + length * np.arange(1, n + 1) / n)
        props += [(math.pi * (do**2 - di**2) / 4, math.pi * (do**4 - di**4) / 64)] * n
    z = np.array(z)
    n_dof = 2 * z.size  # node i: w = 2 i, psi = 2 i + 1
    K, M = np.zeros((n_dof, n_dof)), np.zeros((n_dof, n_dof))
    for e, (A, I) in enumerate(props):
        h = z[e + 1] - z[e]
        idx = np.array([2 * e, 2 * e + 1, 2 * e + 2, 2 * e + 3])
        g = np.array([-1 / h, -0.5, 1 / h, -0.5])  # w' - psi at the midpoint
        dpsi = np.array([0.0, -1 / h, 0.0, 1 / h])
        K[np.ix_(idx, idx)] += (E * I * np.outer(dpsi, dpsi) + kappa * G * A * np.outer(g, g)) * h
        m = np.array([[2.0, 1.0], [1.0, 2.0]]) * h / 6  # consistent linear mass
        M[np.ix_(idx[[0, 2]], idx[[0, 2]])] += rho * A * m
        M[np.ix_(idx[[1, 3]], idx[[1, 3]])] += rho * I * m
    for zb, k in springs:
        i = int(np.argmin(abs(z - zb)))
        K[2 * i, 2 * i] += k
    zd, mass, J = disk
    i = int(np.argmin(abs(z - zd)))
    M[2 * i, 2 * i] += mass
    M[2 * i + 1, 2 * i + 1] += J
    w2 = scipy.sparse.linalg.eigsh(scipy.sparse.csc_matrix(K), k=6,
                                   M=scipy.sparse.csc_matrix(M), sigma=0.0,
                                   return_eigenvectors=False)
    return np.sqrt(np.sort(w2)) / (2 * math.pi)


def _gear_body(stage, gear):
    """Mass and diametral inertia of a gear body as the rotor's docs state it: an annulus
    from the seat's diameter to sqrt((d_f^2 + d_a^2) / 2), the face width wide."""
    p = stage.pair
    shaft = stage.pinion_shaft if gear == "pinion" else stage.wheel_shaft
    df, da, b = (p.df1, p.da1, p.b1) if gear == "pinion" else (p.df2, p.da2, p.b2)
    bore = shaft.section_at(shaft.gear_position)[1] * 1e-3
    D = math.sqrt(0.5 * (df**2 + da**2))
    m = stage.material.density * math.pi / 4 * (D**2 - bore**2) * b
    return m, m * ((D**2 + bore**2) / 16 + b**2 / 12)


def _lateral_frequencies(rotor, shaft_index):
    """The rotor's natural frequencies whose shapes are >= 90 % in one shaft's bending DOFs,
    each x/y pair once, sorted (mesh stiffness 0: the shafts are uncoupled; the bearings are
    isotropic, so each bending frequency is a double eigenvalue whose shapes the solver may
    mix between x and y)."""
    from gearuq.rotor.modal import undamped_modes

    modes = undamped_modes(rotor)
    line = rotor.shafts[shaft_index]
    dofs = [rotor.dof(n, d) for n in range(line.first_node, line.last_node + 1)
            for d in ("x", "y", "theta_x", "theta_y")]
    M = rotor.M()
    out = []
    for j in range(modes.shapes.shape[1]):
        phi = modes.shapes[:, j]
        share = (phi[dofs] @ M[np.ix_(dofs, dofs)] @ phi[dofs]) / (phi @ M @ phi)
        if share > 0.9 and modes.omega[j] > 1.0:
            out.append(modes.omega[j] / (2 * math.pi))
    out = np.sort(out)
    assert out.size % 2 == 0 and np.allclose(out[0::2], out[1::2], rtol=1e-6)
    return out[0::2]


@pytest.mark.e2e
@pytest.mark.parametrize("stiffness", [None, ((300.0, 100.0), (400.0, 150.0))],
                         ids=["as_drawn", "unequal_on_each_shaft"])
@pytest.mark.parametrize("scale", [1.0, 2.5])
def test_bearing_modes_against_a_timoshenko_beam_with_each_bearings_stiffness(e_axle, stiffness,
                                                                         scale):
    from gearuq_plugins.geared_rotor.stage import StageRotorFactory

    stage = e_axle
    if stiffness is not None:  # each bearing of each shaft its own radial stiffness
        stage = replace(stage, **{name: replace(getattr(stage, name), bearings=tuple(
            replace(b, radial_stiffness=k) for b, k in zip(getattr(stage, name).bearings,
                                                           ks, strict=True)))
            for name, ks in zip(("pinion_shaft", "wheel_shaft"), stiffness, strict=True)})
    model = gearuq.get_model("geared_rotor", stage=stage)
    values = {p.name: p.nominal for p in model.parameters} | {"bearing_stiffness_scale": scale}
    # the model's own rotor of the sample (no end hubs), with no mesh stiffness
    rotor = StageRotorFactory(stage, values, "pitch_point", ends=False)(0.0)
    E, rho = stage.material.young_modulus * 1e6, stage.material.density
    nu = stage.material.poisson_ratio
    for index, (gear, shaft) in enumerate((("pinion", stage.pinion_shaft),
                                           ("wheel", stage.wheel_shaft))):
        sections = [(s[0] * 1e-3, s[1] * 1e-3, s[2] * 1e-3) for s in shaft.sections]
        springs = [(b.position * 1e-3, b.radial_stiffness * 1e6 * scale)
                   for b in shaft.bearings]
        ref = _timoshenko_beam_on_springs(sections, springs, (shaft.gear_position * 1e-3,
                                                        *_gear_body(stage, gear)), E, nu, rho)
        got = _lateral_frequencies(rotor, index)
        # the two bearing-dominated modes (bounce and rock on the bearings); the rotor's
        # elements are up to 20 mm long, the oracle's 1 mm
        np.testing.assert_allclose(got[:2], ref[:2], rtol=3e-3)
        # the bearings set them: at least 20 % below the shaft on rigid supports
        rigid = _timoshenko_beam_on_springs(sections, [(z, 1e14) for z, _ in springs],
                                      (shaft.gear_position * 1e-3,
                                       *_gear_body(stage, gear)), E, nu, rho)
        assert ref[0] < 0.8 * rigid[0]


@pytest.mark.e2e
def test_per_gear_iso_classes_set_each_gears_total_pitch_deviation(e_axle):
    # ISO 1328-1:2013, 5.3: F_pT = (0.002 d + 0.55 sqrt(d) + 0.7 m_n + 12) sqrt(2)^(A - 5) um
    def F_pT(d_mm, mn_mm, A):
        return (0.002 * d_mm + 0.55 * math.sqrt(d_mm) + 0.7 * mn_mm + 12.0) * 2 ** (
            (A - 5) / 2) * 1e-6

    mn, z, beta = 2.0, e_axle.teeth, math.radians(22.0)
    d = [zi * mn / math.cos(beta) for zi in z]
    tolerances = {"pinion": F_pT(d[0], mn, 6), "wheel": F_pT(d[1], mn, 7)}
    model = gearuq.get_model("geared_rotor", stage=e_axle)
    n = 1500
    space = model.default_space()
    germ = [k for k in space.names if k.startswith("pitch_xi")]
    rng = np.random.default_rng(1328)
    params = {k: rng.standard_normal(n) for k in germ}
    outs = ["pitch_total_deviation_pinion", "pitch_total_deviation_wheel"]
    ds = model.response(params, None, outputs=outs, pitch_tolerance_law="capable_process",
                        process_share_beyond=0.05)
    for gear in ("pinion", "wheel"):
        beyond = int(np.sum(ds[f"pitch_total_deviation_{gear}"].values > tolerances[gear]))
        # 5 % of each gear's process beyond its own class's F_pT: a two-sided 99.9 % test
        lo, hi = scipy.stats.binom.ppf([0.0005, 0.9995], n, 0.05)
        assert lo <= beyond <= hi, (gear, beyond, lo, hi)
    # the other class's tolerance would be off: 6 for the wheel puts far more beyond
    wheel_at_6 = F_pT(d[1], mn, 6)
    assert np.mean(ds["pitch_total_deviation_wheel"].values > wheel_at_6) > 0.15


def test_measured_pitch_deviations_are_a_deterministic_realisation(e_axle):
    z1 = e_axle.teeth[0]
    k = np.arange(z1)
    f_pt = 4.0 * np.sin(2 * math.pi * 3 * k / z1) + 1.5 * np.cos(2 * math.pi * k / z1)
    stage = replace(e_axle, pinion=replace(e_axle.pinion,
                                           single_pitch_deviations=tuple(f_pt.tolist())))
    model = gearuq.get_model("geared_rotor", stage=stage)
    assert "pitch_xi_p_1" not in model.parameter_names
    assert "pitch_xi_g_1" in model.parameter_names
    ds = model.response({"pitch_xi_g_1": np.array([0.0, 1.0])}, None,
                        outputs=["pitch_total_deviation_pinion", "pitch_total_deviation_wheel"])
    cumulative = np.cumsum(f_pt)  # F_p,k = sum of the single pitch deviations up to tooth k
    np.testing.assert_allclose(ds["pitch_total_deviation_pinion"].values,
                               np.ptp(cumulative) * 1e-6, rtol=1e-12)
    assert ds["pitch_total_deviation_wheel"].values[0] == 0.0
    assert ds["pitch_total_deviation_wheel"].values[1] > 0.0


def test_e_axle_run_up_resonance_where_the_mesh_frequency_meets_a_mesh_mode(e_axle):
    from gearuq.rotor.modal import undamped_modes

    model = gearuq.get_model("geared_rotor", stage=e_axle)
    options = dict(positions_per_cycle=8, n_pts=6, range_mesh_harmonics=1, n_speeds=7,
                   speed_min=10500.0, speed_max=15000.0, peaks_refined=1,
                   peak_speed_tol=20.0)
    outputs = ["dte_mesh_order_max", "speed_at_dte_mesh_order_max",
               "dte_mesh_order_over_speed"]
    ds = model.response({}, None, outputs=outputs, **options)
    assert int(ds["status"][0]) == 0
    speed = ds["speed_at_dte_mesh_order_max"].item()
    curve = ds["dte_mesh_order_over_speed"].values[0, :, 0]
    # the DTE at f_m peaks inside the range, well above its values at both ends
    assert ds["dte_mesh_order_max"].item() > 2.0 * max(curve[0], curve[-1])
    # the mesh modes of the model's rotor at its mean mesh stiffness: natural frequencies
    # with >= 10 % of their strain energy in the mesh spring
    problem = model.rotor_problem({}, speed_range=True, **{
        k: v for k, v in options.items() if k in ("positions_per_cycle", "n_pts",
                                                  "range_mesh_harmonics")})
    k_mesh, rotor = problem.excitation.mean_stiffness, problem.rotor  # its rotor at k_mesh
    modes = undamped_modes(rotor)
    v = rotor.mesh_vector()
    elastic = modes.omega > 1.0
    omega, shapes = modes.omega[elastic], modes.shapes[:, elastic]
    share = k_mesh * (v @ shapes) ** 2 / omega**2
    z1 = e_axle.teeth[0]
    band = (z1 * options["speed_min"] / 60.0, z1 * options["speed_max"] / 60.0)
    mesh_modes = omega[share >= 0.1] / (2 * math.pi)
    in_band = mesh_modes[(mesh_modes > band[0]) & (mesh_modes < band[1])]
    assert in_band.size == 1  # one mesh mode for the mesh frequency to meet in this range
    # the peak is where z1 n / 60 meets it (light damping: the peak shifts by ~zeta^2)
    assert z1 * speed / 60.0 == pytest.approx(in_band[0], rel=5e-3)


def test_rotor_link_takes_the_e_axle_rotor(e_axle):
    from gearuq_plugins.links.geared_rotor import equivalent_mass

    link = gearuq.get_link("geared_rotor", "mesh_oscillator", stage=e_axle)
    assert link.parameter_names == link.high.parameter_names
    assert link.high.stage is e_axle
    # the gear bodies by hand: steel annuli from the seat to sqrt((d_f^2 + d_a^2) / 2),
    # turning about their axes, their torsional mass on the normal line of action
    p = e_axle.pair
    inertia = []
    for shaft, df, da, b in ((e_axle.pinion_shaft, p.df1, p.da1, p.b1),
                             (e_axle.wheel_shaft, p.df2, p.da2, p.b2)):
        bore = shaft.section_at(shaft.gear_position)[1] * 1e-3
        outer = math.sqrt((df**2 + da**2) / 2.0)
        inertia.append(e_axle.material.density * math.pi * b * (outer**4 - bore**4) / 32.0)
    rbp, rbg = p.db1 / 2.0, p.db2 / 2.0
    ip, ig = inertia
    mass = ip * ig / (ip * rbg**2 + ig * rbp**2) / math.cos(p.beta_b) ** 2
    assert equivalent_mass(stage=e_axle) == pytest.approx(mass, rel=1e-9)
    # the oscillator's resonance: z1 n / 60 meets sqrt(k / m) with the rotor's LTCA stiffness
    options = dict(positions_per_cycle=8, n_pts=6, range_mesh_harmonics=1)
    k_mesh = link.high.rotor_problem({}, speed_range=True, **options
                                     ).excitation.mean_stiffness
    n_res = 60.0 * math.sqrt(k_mesh / mass) / (2 * math.pi * e_axle.teeth[0])
    ds = link.response({}, None, outputs=["dte_rms_max", "speed_at_dte_rms_max"],
                       speed_min=15000.0, speed_max=20000.0, n_speeds=201, **options)
    assert int(ds["status"][0]) == 0
    assert ds["speed_at_dte_rms_max"].item() == pytest.approx(n_res, rel=5e-3)


def test_e_axle_excitation_equals_mesh_excitations_for_the_same_stage(e_axle):
    """Per-gear classes (6/7), per-gear linear reliefs with a sampled amount and the pitch
    germ: the rotor's LTCA excitation over the 2133-cycle long period is mesh_excitation's
    (its own deviation code) for the same stage and compliance, by the line-load table."""
    rotor = gearuq.get_model("geared_rotor", stage=e_axle)
    excitation = gearuq.get_model("mesh_excitation", stage=e_axle,
                                  bore_ratio=rotor.compliance.bore_ratio)
    values = {"pitch_xi_p_1": 0.8, "pitch_xi_g_2": -0.5, "pinion_tip_relief_amount": 5.0}
    ltca = dict(positions_per_cycle=8, n_pts=6)
    ex = rotor.rotor_problem(values, speed_range=True, range_mesh_harmonics=1,
                             **ltca).excitation
    ds = excitation.response({k: np.array([v]) for k, v in (values | {"torque": 250.0}).items()},
                             ex.tau, outputs=["ste", "lpms_tangent_mean"], threads=1,
                             ltca_route="table", **ltca)
    assert int(ds["status"][0]) == 0
    ste = ex.ste * 1e6
    np.testing.assert_allclose(ste, ds["ste"].values[0], rtol=0, atol=1e-6 * np.ptp(ste))
    assert ex.mean_stiffness / 1e6 == pytest.approx(ds["lpms_tangent_mean"].item(), rel=1e-6)
    # the wheel's class matters: at class 6 its pitch deviations, and so the STE, shrink
    at_6 = rotor.rotor_problem(values | {"iso_grade_wheel": 6}, speed_range=True,
                               range_mesh_harmonics=1, **ltca).excitation
    assert np.ptp(at_6.ste) < np.ptp(ex.ste) - 1e-6
